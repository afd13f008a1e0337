//! The burr's feel on the tooth (docs/DRILLING.md, "Vibration" and "Breakthrough"): a
//! vibration at the set frequency whose amplitude follows each region's setting and how hard
//! the burr cuts, and the force's drop when the burr breaks into the pulp.
//!
//! Oracles: a discrete Fourier transform of the force's magnitude, summed here in f64; the
//! amplitude law `A * min(1, (F - threshold) / (F_max - threshold))` written here from the
//! docs, with `F` the force without its vibration estimated as the mean magnitude over one
//! period (four ticks at 250 Hz, over which the sinusoid sums to zero); each tick's region
//! from the mesh's own labels of the contact's tet; the first pulp leaf from the pulp's
//! removed volume.

use std::collections::BTreeMap;
use std::f64::consts::TAU;

use tetradrill::engine::{self, EngineStorage, ShaftState, TickParams};
use tetradrill::scenario::Scenario;
use tetradrill::traces::PoseSource;
use tetradrill_core::force::ToolState;
use tetradrill_core::script::DRILL_ON;
use tetradrill_tests::scratch_dir;

const ENAMEL: i32 = 1;
const DENTIN: i32 = 2;
const PULP: i32 = 3;
/// Newtons at full cut, as configured here: enamel's vibration twice dentin's.
const A_ENAMEL: f64 = 0.6;
const A_DENTIN: f64 = 0.3;
const HZ: f64 = 250.0;
/// The servo's rate.
const RATE: f64 = 1000.0;

/// The tooth scenario with the vibration amplitudes above and `hz`.
fn tooth(hz: f64) -> Scenario {
    let mut s = Scenario::load("builtin:firmware-tooth").expect("the tooth");
    s.vibration_hz = hz;
    for (label, a) in [(ENAMEL, A_ENAMEL), (DENTIN, A_DENTIN)] {
        s.regions
            .get_mut(&label.to_string())
            .expect("the tooth's region")
            .vibration = Some(a);
    }
    s
}

/// What one replay of a scenario gave, tick by tick.
struct Ticks {
    /// Each tick's force magnitude, newtons.
    force: Vec<f64>,
    /// Each tick's force, as `--forces` writes it.
    rows: Vec<[f32; 3]>,
    /// Whether the drill was on.
    drilling: Vec<bool>,
    /// The mesh label of the contact's tet, if in contact.
    label: Vec<Option<i32>>,
    /// The volume removed so far from each region, by label.
    removed: Vec<BTreeMap<i32, f64>>,
}

/// The replay's ticks in process (`replay` runs exactly these: `engine::tick_tool` over the
/// scenario's poses).
fn replay_in_process(sc: &Scenario) -> Ticks {
    let setup = sc.setup().expect("set-up");
    let params = TickParams::of(&setup).expect("params");
    let loaded = engine::load_mesh(&setup).expect("the tooth's mesh");
    let labels = loaded.labels.clone();
    let poses = PoseSource::new(&setup.poses, Some(&loaded.mesh)).expect("poses");
    let mut store = EngineStorage::new(loaded.mesh, &setup).expect("storage");
    store.set_labels(&labels, &setup).expect("labels");
    let region_labels = store.region_labels().to_vec();
    let mut world = store.world().expect("world");
    let (mut tool, mut shaft) = (ToolState::default(), ShaftState::default());
    let n = poses.ticks() as usize;
    let mut t = Ticks {
        force: Vec::with_capacity(n),
        rows: Vec::with_capacity(n),
        drilling: Vec::with_capacity(n),
        label: Vec::with_capacity(n),
        removed: Vec::with_capacity(n),
    };
    for i in 0..poses.ticks() {
        let pose = poses.at(i);
        let (f, _) = engine::tick_tool(&mut world, &mut tool, &mut shaft, &params, &pose);
        t.force.push(f64::from(f.length()));
        t.rows.push([f.x, f.y, f.z]);
        t.drilling.push(pose.buttons & DRILL_ON != 0);
        t.label.push(
            world
                .contact()
                .valid
                .then(|| world.contact_tet())
                .flatten()
                .map(|tet| labels[tet.idx()]),
        );
        let regions = world.regions().expect("the tooth has regions");
        t.removed.push(
            regions
                .table()
                .iter()
                .zip(&region_labels)
                .map(|(r, &l)| (l, r.removed()))
                .collect(),
        );
    }
    t
}

/// The forces `replay --scenario FILE --vibration-hz HZ --forces F` writes, `sc` written to
/// FILE as TOML.
fn replay_forces(sc: &Scenario, hz: f64, name: &str) -> Vec<[f32; 3]> {
    let dir = scratch_dir("vibration", name);
    let file = dir.join("tooth.toml");
    std::fs::write(&file, toml::to_string(sc).expect("to TOML")).expect("write the scenario");
    let forces = dir.join("forces.csv");
    let hz = hz.to_string();
    tetradrill_tests::run_ok([
        "replay".as_ref(),
        "--quiet".as_ref(),
        "--scenario".as_ref(),
        file.as_os_str(),
        "--vibration-hz".as_ref(),
        hz.as_ref(),
        "--forces".as_ref(),
        forces.as_os_str(),
    ]);
    tetradrill_tests::read_forces(&forces)
}

/// The amplitude of the component of `x` at `hz` (sampled at [`RATE`]): `2 / N |sum x_n
/// e^(-i 2 pi hz n / RATE)|`, the mean taken out first.
fn amplitude_at(x: &[f64], hz: f64) -> f64 {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let (mut re, mut im) = (0.0, 0.0);
    for (k, v) in x.iter().enumerate() {
        let a = TAU * hz * k as f64 / RATE;
        re += (v - mean) * a.cos();
        im -= (v - mean) * a.sin();
    }
    2.0 * re.hypot(im) / n
}

/// The largest peak of the spectrum of `x` above 20 Hz: its frequency and amplitude, over the
/// DFT's bins `k * RATE / N`.
fn largest_peak(x: &[f64]) -> (f64, f64) {
    let n = x.len();
    let mut best = (0.0, 0.0);
    for k in 1..=n / 2 {
        let f = k as f64 * RATE / n as f64;
        if f <= 20.0 {
            continue;
        }
        let a = amplitude_at(x, f);
        if a > best.1 {
            best = (f, a);
        }
    }
    best
}

/// The ticks from the first to the last with the drill on.
fn drilling_span(t: &Ticks) -> std::ops::Range<usize> {
    let first = t
        .drilling
        .iter()
        .position(|&d| d)
        .expect("the trace drills");
    let last = t
        .drilling
        .iter()
        .rposition(|&d| d)
        .expect("the trace drills");
    first..last + 1
}

fn magnitudes(rows: &[[f32; 3]]) -> Vec<f64> {
    rows.iter()
        .map(|r| {
            let [x, y, z] = r.map(f64::from);
            (x * x + y * y + z * z).sqrt()
        })
        .collect()
}

/// `replay --vibration-hz 250`: the force's spectrum over the drilling ticks peaks at 250 Hz;
/// with `--vibration-hz 0` the same scenario has at least 20 dB less there.
#[test]
fn the_tooths_force_vibrates_at_the_set_frequency() {
    let sc = tooth(0.0);
    let on = replay_forces(&sc, HZ, "on");
    let off = replay_forces(&sc, 0.0, "off");
    // The binary's ticks are the ones replayed in process here.
    let t = replay_in_process(&tooth(HZ));
    assert_eq!(on, t.rows, "replay --forces against the ticks in process");
    let span = drilling_span(&t);
    let (m_on, m_off) = (magnitudes(&on), magnitudes(&off));
    let (f, a) = largest_peak(&m_on[span.clone()]);
    let near = |m: &[f64]| {
        (-5..=5)
            .map(|d| amplitude_at(&m[span.clone()], HZ + f64::from(d)))
            .fold(0.0, f64::max)
    };
    let a_off = near(&m_off);
    println!(
        "{} drilling ticks: largest peak above 20 Hz at {f:.2} Hz, {a:.4} N; within 5 Hz of \
         250 Hz without vibration {a_off:.5} N ({:.1} dB lower)",
        span.len(),
        20.0 * (a / a_off).log10()
    );
    assert!((f - HZ).abs() <= 5.0, "the peak is at {f} Hz");
    assert!(a > 0.01, "a peak of {a} N");
    assert!(
        20.0 * (a / a_off).log10() >= 20.0,
        "250 Hz: {a} N with vibration, {a_off} N without"
    );
}

/// In chunks of ticks where the burr cuts one region only, the amplitude at 250 Hz follows
/// `A * min(1, (F - threshold) / (F_max - threshold))` with the region's `A` and threshold,
/// within 10 %, and enamel's against dentin's as configured.
#[test]
fn the_vibrations_amplitude_follows_the_region_and_the_cut() {
    let sc = tooth(HZ);
    let max_force = sc.max_force;
    let t = replay_in_process(&sc);
    // Chunks of 40 ticks (ten periods) with the drill on and the contact in one region.
    const CHUNK: usize = 40;
    let mut sums: BTreeMap<i32, (f64, f64, usize)> = BTreeMap::new();
    let mut i = 0;
    while i + CHUNK <= t.force.len() {
        let l = t.label[i];
        let one = (i..i + CHUNK).all(|k| t.drilling[k] && t.label[k] == l);
        let Some(l) = l.filter(|&l| one && (l == ENAMEL || l == DENTIN)) else {
            i += 1;
            continue;
        };
        let spec = &sc.regions[&l.to_string()];
        let (a_cfg, threshold) = (spec.vibration.expect("configured"), spec.threshold);
        let x = &t.force[i..i + CHUNK];
        // The force without its vibration: the mean over the period centred on each tick.
        let law: f64 = (0..CHUNK)
            .map(|k| {
                let lo = (i + k).saturating_sub(2);
                let f0 = t.force[lo..lo + 4].iter().sum::<f64>() / 4.0;
                if f0 > threshold {
                    a_cfg * ((f0 - threshold) / (max_force - threshold)).min(1.0)
                } else {
                    0.0
                }
            })
            .sum::<f64>()
            / CHUNK as f64;
        let e = sums.entry(l).or_default();
        e.0 += amplitude_at(x, HZ);
        e.1 += law;
        e.2 += 1;
        i += CHUNK;
    }
    let mut measured = BTreeMap::new();
    for (l, (got, law, chunks)) in &sums {
        println!(
            "region {l}: {chunks} chunks of {CHUNK} ticks, mean amplitude at 250 Hz {:.4} N, \
             the law's {:.4} N ({:.3})",
            got / *chunks as f64,
            law / *chunks as f64,
            got / law
        );
        assert!(*chunks >= 5, "region {l}: {chunks} chunks");
        assert!(
            (got / law - 1.0).abs() < 0.1,
            "region {l}: {got} against the law's {law}"
        );
        measured.insert(*l, (got / *chunks as f64, law / *chunks as f64));
    }
    let (e, d) = (measured[&ENAMEL], measured[&DENTIN]);
    let ratio = (e.0 / d.0) / (e.1 / d.1);
    assert!(
        (ratio - 1.0).abs() < 0.1,
        "enamel against dentin {} as measured, {} by the law",
        e.0 / d.0,
        e.1 / d.1
    );
}

/// `--vibration-hz` above 500 is refused in one line naming the flag.
#[test]
fn a_vibration_above_500_hz_is_refused() {
    tetradrill_tests::refused(
        &[
            "replay",
            "--quiet",
            "--scenario",
            "builtin:firmware-tooth",
            "--ticks",
            "10",
            "--vibration-hz",
            "600",
        ],
        &["--vibration-hz", "600"],
    );
}

/// The breakthrough on the access trace: within 5 ticks of the burr's first pulp leaf the
/// force is at most half its value while it cut dentin (the mean over the 50 dentin ticks
/// before). On this trace the first pulp leaf falls in the withdrawal (the hand rises from
/// tick 16,400), so the force was already falling with the hand when the pulp opened
/// (docs/DRILLING.md, "Breakthrough").
#[test]
fn breaking_into_the_pulp_halves_the_force_within_5_ticks() {
    let t = replay_in_process(&Scenario::load("builtin:firmware-tooth").expect("the tooth"));
    let pulp = |k: usize| t.removed[k].get(&PULP).copied().unwrap_or(0.0);
    let first = (1..t.force.len())
        .find(|&k| pulp(k) > pulp(k - 1))
        .expect("the access trace opens the pulp");
    let dentin: Vec<f64> = (0..first)
        .rev()
        .filter(|&k| t.drilling[k] && t.label[k] == Some(DENTIN))
        .take(50)
        .map(|k| t.force[k])
        .collect();
    assert_eq!(dentin.len(), 50, "dentin ticks before the pulp");
    let dentin = dentin.iter().sum::<f64>() / 50.0;

    let after = t.force[first..=first + 5]
        .iter()
        .copied()
        .fold(f64::MAX, f64::min);
    println!(
        "first pulp leaf at tick {first}: the force {after:.3} N within 5 ticks, {dentin:.3} N \
         while cutting dentin; ticks {}..: {:?}",
        first.saturating_sub(3),
        &t.force[first.saturating_sub(3)..first + 12]
    );
    assert!(
        after <= 0.5 * dentin,
        "the force {after} N within 5 ticks of the pulp, {dentin} N in dentin"
    );
}
