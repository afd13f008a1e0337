//! The burr's sound (`replay --audio-out`): its fundamental, read from the WAV file by a DFT
//! written here, is the free-running speed in the air and falls by the configured share under
//! a full load; harder material rings brighter.

use std::path::Path;

use tetradrill::audio::{brightness, BurrSound, BurrVoice, TickSound, SAMPLE_RATE};
use tetradrill_tests::{run_ok, scratch_dir};

/// The WAV file's samples (16-bit mono PCM, the header checked).
fn read_wav(path: &Path) -> Vec<f64> {
    let b = std::fs::read(path).expect("the WAV file");
    assert_eq!(&b[0..4], b"RIFF");
    assert_eq!(&b[8..16], b"WAVEfmt ");
    assert_eq!(u16::from_le_bytes([b[22], b[23]]), 1, "mono");
    assert_eq!(
        u32::from_le_bytes([b[24], b[25], b[26], b[27]]),
        SAMPLE_RATE
    );
    assert_eq!(u16::from_le_bytes([b[34], b[35]]), 16, "16-bit");
    assert_eq!(&b[36..40], b"data");
    b[44..]
        .chunks_exact(2)
        .map(|c| f64::from(i16::from_le_bytes([c[0], c[1]])))
        .collect()
}

/// The magnitude of `x` at `hz` (a Hann-windowed DFT term).
fn amplitude(x: &[f64], hz: f64) -> f64 {
    let n = x.len() as f64;
    let (mut re, mut im) = (0.0, 0.0);
    for (i, v) in x.iter().enumerate() {
        let w = 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / n).cos();
        let ph = std::f64::consts::TAU * hz * i as f64 / f64::from(SAMPLE_RATE);
        re += w * v * ph.cos();
        im -= w * v * ph.sin();
    }
    (re * re + im * im).sqrt()
}

/// The strongest frequency of `x` between `lo` and `hi`, on a 2 Hz grid.
fn peak(x: &[f64], lo: f64, hi: f64) -> f64 {
    let mut best = (0.0, lo);
    let mut f = lo;
    while f <= hi {
        let a = amplitude(x, f);
        if a > best.0 {
            best = (a, f);
        }
        f += 2.0;
    }
    best.1
}

#[test]
fn the_fundamental_falls_with_the_load_as_configured() {
    let dir = scratch_dir("sound", "press");
    let trace = dir.join("press.csv");
    // In the air for 0.8 s, then 0.2 into the paper's cube's top face and held there: the
    // force stays past the sound's full load (4 N) while the hard material gives way slowly.
    std::fs::write(
        &trace,
        "t,x,y,z,qw,qx,qy,qz,buttons\n0.0,0,0,0.9,1,0,0,0,1\n0.8,0,0,0.9,1,0,0,0,1\n\
         1.2,0,0,0.45,1,0,0,0,1\n4.0,0,0,0.45,1,0,0,0,1\n",
    )
    .expect("trace");
    let wav = dir.join("press.wav");
    run_ok([
        "replay".as_ref(),
        "--mesh".as_ref(),
        "builtin:cube12".as_ref(),
        "--trace".as_ref(),
        trace.as_os_str(),
        "--tool".as_ref(),
        "sphere:0.15".as_ref(),
        "--pressure-threshold".as_ref(),
        "0.5".as_ref(),
        "--hardness".as_ref(),
        "1000".as_ref(),
        "--quiet".as_ref(),
        "--audio-out".as_ref(),
        wav.as_os_str(),
    ]);
    let x = read_wav(&wav);
    // 4.001 s of ticks, 44.1 samples each.
    assert!(
        (x.len() as f64 - 4.001 * 44_100.0).abs() < 2.0,
        "{}",
        x.len()
    );
    // The documented settings: 320,000 rpm free, 35 % slower at 4 N and past.
    let free = 320_000.0 / 60.0;
    let loaded = free * (1.0 - 0.35);
    let window = |t0: f64| {
        let i = (t0 * 44_100.0) as usize;
        &x[i..i + 8_820]
    };
    for t0 in [0.2, 0.5] {
        let f = peak(window(t0), 2_000.0, 7_000.0);
        assert!((f - free).abs() < 10.0, "in the air at {t0} s: {f} Hz");
    }
    for t0 in [2.0, 3.0, 3.7] {
        let f = peak(window(t0), 2_000.0, 7_000.0);
        assert!(
            (f - loaded).abs() < 10.0,
            "pressed at {t0} s: {f} Hz, not {loaded}"
        );
    }
}

#[test]
fn harder_material_rings_brighter_and_the_button_silences_it() {
    // Two voices at the same speed, one in the hardest material and one in the softest: the
    // second harmonic against the fundamental is larger in the hard one, as configured
    // (harmonic k weighted brightness^(k-1) / k).
    let sound = BurrSound {
        free_hz: 3_000.0,
        ..BurrSound::default()
    };
    let ratio = |b: f64| {
        let mut v = BurrVoice::new(sound);
        let s = TickSound {
            on: true,
            load_n: 0.0,
            brightness: b,
            grinding: 0.0,
        };
        for _ in 0..400 {
            v.tick(&s);
        }
        let x: Vec<f64> = v.samples()[v.samples().len() - 8_820..]
            .iter()
            .map(|s| f64::from(*s))
            .collect();
        amplitude(&x, 6_000.0) / amplitude(&x, 3_000.0)
    };
    let (hard, soft) = (brightness(3_200.0, 3_200.0), brightness(640.0, 3_200.0));
    let (rh, rs) = (ratio(hard), ratio(soft));
    assert!(
        (rh - hard / 2.0).abs() < 0.05 * hard,
        "hard: {rh} against {}",
        hard / 2.0
    );
    assert!(
        (rs - soft / 2.0).abs() < 0.05 * soft,
        "soft: {rs} against {}",
        soft / 2.0
    );
    // The button off: the whine ramps out within 0.1 s.
    let mut v = BurrVoice::new(sound);
    let on = TickSound {
        on: true,
        brightness: 0.5,
        ..TickSound::default()
    };
    for _ in 0..200 {
        v.tick(&on);
    }
    for _ in 0..300 {
        v.tick(&TickSound::default());
    }
    let tail = &v.samples()[v.samples().len() - 4_410..];
    assert!(tail.iter().all(|s| s.abs() < 50), "still sounding");
}

#[test]
fn a_run_writes_the_sound_of_its_length() {
    let dir = scratch_dir("sound", "run");
    let wav = dir.join("run.wav");
    let w = wav.to_str().expect("utf8");
    run_ok([
        "run",
        "--duration",
        "0.6",
        "--no-rt",
        "--quiet",
        "--audio-out",
        w,
    ]);
    let x = read_wav(&wav);
    // The audio task follows the wall clock from its start to the run's stop, in 10 ms looks.
    let secs = x.len() as f64 / 44_100.0;
    assert!((0.4..1.5).contains(&secs), "{secs} s");
    // The burr spins from the start: past the 20 ms ramp, the whine at the free speed or
    // below it under load.
    let f = peak(&x[8_820..8_820 + 8_820], 2_000.0, 7_000.0);
    let free = 320_000.0 / 60.0;
    assert!((0.65 * free - 10.0..free + 10.0).contains(&f), "{f} Hz");
}

#[test]
fn sound_without_the_feature_is_refused_in_one_line() {
    // The tests' binary is the default build, without the `sound` feature.
    tetradrill_tests::refused(
        &["run", "--sound", "--duration", "0.1", "--no-rt"],
        &["--sound", "sound` feature", "--audio-out"],
    );
}
