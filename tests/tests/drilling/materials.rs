//! Materials per region (docs/DRILLING.md, "Materials"): removal driven by the pressing force
//! against each region's threshold and hardness, the removed volume by region, and the contact
//! stiffness of the material under the burr.
//!
//! Oracles: the model's closed form `(F - threshold) / hardness * T` computed here, within the
//! leaf quantisation (a leaf is erased whole once its volume is earned, so the removed volume
//! lags the closed form by less than the largest leaf: a coarse tet); the removed volume by
//! label recomputed from the erased leaves' f64 corners (`tetradrill_tests::drill::leaves`, its
//! own Bey descent) summed by their root tet's label; the spring `stiffness x depth` of each
//! region's stiffness.

use std::collections::BTreeMap;

use glam::Vec3;
use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::scenario::Scenario;
use tetradrill::setup::Setup;
use tetradrill::setup::{RegionSpec, Tool};
use tetradrill::traces::PoseSource;
use tetradrill_core::drill::DrillParams;
use tetradrill_core::force::{ForceParams, ToolState};
use tetradrill_core::servo::{servo_force, World};
use tetradrill_tests::drill::leaves;
use tetradrill_tests::oracle::{cross, dot, sub};

/// Seconds per servo tick as the world is told it (the grant uses the f32 value).
const DT: f32 = 0.001;

/// A block of 8^3 cubes drilled to depth 3; the default region of `hardness` and `threshold`.
fn block_scenario(hardness: f64, threshold: f64) -> Setup {
    let mut sc = Setup::new("builtin:block:8", Tool::sphere(0.3));
    sc.drilling.max_depth = 3;
    sc.materials.hardness = hardness;
    sc.materials.pressure_threshold = threshold;
    sc.drilling.budget_per_tick = 1 << 30;
    sc.drilling.tick_budget = 0;
    sc.capacities.hierarchy = Some(1 << 20);
    sc
}

/// Storage for `sc`'s world with every tet labelled `labels` (or the mesh's own labels).
fn storage(sc: &Setup, labels: Option<&[i32]>) -> (EngineStorage, Vec<i32>) {
    let loaded = engine::load_mesh(sc).expect("built-in mesh");
    let labels = labels.map_or(loaded.labels.clone(), <[i32]>::to_vec);
    let mut store = EngineStorage::new(loaded.mesh, sc).expect("storage");
    store.set_labels(&labels, sc).expect("regions");
    (store, labels)
}

/// Holds a burr of radius 0.3 centred on the block's top face, drill on, pressing with `force`
/// newtons for `ticks` ticks; the volume the burr cut after each tick (the removed volume
/// less the debris the drill's checks erased: crumbs its flutes carry away, not cut at the
/// material's rate).
fn press(world: &mut World<'_>, force: f32, ticks: usize) -> Vec<f64> {
    press_at(world, Vec3::new(0.03, -0.02, 0.5), force, ticks)
}

/// [`press`] with the burr at `centre`.
fn press_at(world: &mut World<'_>, centre: Vec3, force: f32, ticks: usize) -> Vec<f64> {
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 1 << 30,
    };
    (0..ticks)
        .map(|_| {
            world.set_pressing(force, DT);
            world.simulate(centre, 0.3, 0.15, true, &params);
            world.hierarchy().removed_volume() - world.debris().volume
        })
        .collect()
}

/// The largest leaf: a coarse tet of the 8-block, `(1/8)^3 / 6`.
const LEAF: f64 = 1.0 / (512.0 * 6.0);

/// The closed form: `(force - threshold) / hardness` cubic units a second.
fn closed_form(force: f32, threshold: f64, hardness: f64, ticks: usize) -> f64 {
    (f64::from(force) - threshold) / hardness * (ticks as f64 * f64::from(DT))
}

#[test]
fn a_constant_force_removes_the_closed_form_volume_within_a_leaf() {
    let sc = block_scenario(400.0, 1.0);
    let (mut store, _) = storage(&sc, Some(&[0; 3072]));
    let mut world = store.world().expect("world");
    let removed = press(&mut world, 5.0, 1500);
    // 4 N above the threshold, hardness 400: 0.01 cubic units a second, while the half
    // sphere of radius 0.3 (0.0565) still holds material.
    for t in [100, 250, 500, 1000, 1500] {
        let expect = closed_form(5.0, 1.0, 400.0, t);
        let got = removed[t - 1];
        assert!(
            got <= expect + 1e-12 && got >= expect - LEAF,
            "after {t} ticks: removed {got}, closed form {expect}"
        );
    }
    let r = world.regions().expect("regions");
    assert!((r.table()[0].removed() - world.hierarchy().removed_volume()).abs() < 1e-12);
}

#[test]
fn below_the_threshold_nothing_is_removed_however_long() {
    let sc = block_scenario(400.0, 1.0);
    let (mut store, _) = storage(&sc, Some(&[0; 3072]));
    let mut world = store.world().expect("world");
    let tets = world.mesh().tet_count();
    let removed = press(&mut world, 0.99, 3000);
    assert_eq!(removed.last().copied(), Some(0.0));
    assert_eq!(
        world.hierarchy().node_count(),
        tets,
        "nothing refined either"
    );
    // Pressed harder, the burr sinks a little into the material (the spring's depth grows)
    // and cuts.
    let removed = press_at(&mut world, Vec3::new(0.03, -0.02, 0.495), 1.5, 200);
    assert!(removed.last().is_some_and(|&v| v > 0.0));
}

#[test]
fn a_harder_region_removes_less_in_the_ratio_of_the_hardnesses() {
    let mut got = Vec::new();
    for hardness in [300.0, 900.0] {
        let sc = block_scenario(hardness, 0.5);
        let (mut store, _) = storage(&sc, Some(&[0; 3072]));
        let mut world = store.world().expect("world");
        let removed = press(&mut world, 3.5, 2000);
        let v = removed[1999];
        let expect = closed_form(3.5, 0.5, hardness, 2000);
        assert!(
            v <= expect + 1e-12 && v >= expect - LEAF,
            "{hardness}: {v} {expect}"
        );
        got.push(v);
    }
    // Three times as hard: a third of the volume (0.02 against 0.00667), within a leaf each.
    let ratio = got[0] / got[1];
    let (lo, hi) = ((0.02 - LEAF) / 0.02 * 3.0, 3.0 * 0.02 / (0.02 - 3.0 * LEAF));
    assert!(
        ratio > lo && ratio < hi,
        "ratio {ratio}, expected 3 ({lo}..{hi})"
    );
}

/// The volume of the tet of corners `p` (f64).
fn volume(p: &[[f64; 3]; 4]) -> f64 {
    dot(sub(p[1], p[0]), cross(sub(p[2], p[0]), sub(p[3], p[0]))).abs() / 6.0
}

/// The demo's two regions (shell 1, core 2 of the built-in block) on its scripted path: the
/// removed volume by label sums to the removed volume and equals each label's erased leaves.
#[test]
fn removed_by_region_is_each_labels_erased_leaves() {
    let sc = tetradrill::scenario::builtin("demo")
        .expect("demo")
        .setup()
        .expect("a valid set-up");
    assert_eq!(sc.materials.regions.len(), 2);
    let params = TickParams::of(&sc).expect("params");
    let poses = PoseSource::new(&sc.poses, None).expect("demo path");
    let (mut store, labels) = storage(&sc, None);
    let region_labels = store.region_labels().to_vec();
    assert_eq!(region_labels, vec![1, 2]);
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    for i in 0..poses.ticks() {
        engine::tick(&mut world, &mut tool, &params, &poses.at(i));
    }
    let by = engine::removed_by_region(&world, &region_labels).expect("regions");
    let total = world.hierarchy().removed_volume();
    assert!(total > 0.01, "the demo removes material: {total}");
    let sum: f64 = by.values().sum();
    assert!(
        (sum - total).abs() < 1e-12 * total.max(1.0),
        "{sum} vs {total}"
    );
    // Independently: the erased leaves' own volumes by their root tet's label.
    let mut oracle: BTreeMap<String, f64> = BTreeMap::new();
    let mesh = world.mesh();
    for l in leaves(mesh, world.hierarchy(), 0..mesh.tet_count()) {
        if l.erased {
            *oracle.entry(labels[l.tet.idx()].to_string()).or_default() += volume(&l.p);
        }
    }
    for (label, v) in &by {
        let o = oracle.get(label).copied().unwrap_or(0.0);
        assert!(
            (v - o).abs() < 1e-9,
            "label {label}: {v} vs the leaves' {o}"
        );
    }
    assert!(
        by["1"] > 0.0 && by["2"] > 0.0,
        "{by:?}: the path cuts the shell and the core"
    );
}

/// Regions split at x = 0 (soft left, stiff right): the spring at the same depth is each
/// side's stiffness times the depth, and a probe sliding across feels the change as a ramp.
#[test]
fn the_force_uses_the_stiffness_of_the_region_under_the_contact() {
    let spec = |k: f64| RegionSpec {
        hardness: 0.0,
        threshold: 0.0,
        stiffness: Some(k),
        colour: None,
        ..RegionSpec::default()
    };
    let sc = Scenario {
        mesh: "builtin:block:8".into(),
        regions: BTreeMap::from([("1".into(), spec(100.0)), ("2".into(), spec(400.0))]),
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    let loaded = engine::load_mesh(&sc).expect("block");
    let labels: Vec<i32> = (0..loaded.mesh.tets().len())
        .map(|t| {
            let tet = &loaded.mesh.tets()[t];
            let x: f32 = tet
                .nodes
                .iter()
                .map(|v| loaded.mesh.positions()[v.idx()].x)
                .sum();
            if x < 0.0 {
                1
            } else {
                2
            }
        })
        .collect();
    let (mut store, _) = storage(&sc, Some(&labels));
    let mut world = store.world().expect("world");
    let params = DrillParams::default();
    let force = ForceParams {
        stiffness: 200.0,
        damping: 0.0,
        max_force: 8.0,
        dt: DT,
        switch_time: 0.016,
    };
    let (r, depth) = (0.1f32, 0.01f32);
    let z = 0.5 + r - depth;
    let mut tool = ToolState::default();
    let at = |world: &mut World<'_>, tool: &mut ToolState, x: f32| {
        let c = Vec3::new(x, 0.06, z);
        world.simulate(c, r, 0.05, false, &params);
        servo_force(world.contact(), c, r, tool, &force)
    };
    let mut f = Vec3::ZERO;
    for _ in 0..40 {
        f = at(&mut world, &mut tool, -0.25);
    }
    assert!((f.z - 100.0 * depth).abs() < 1e-4, "soft side: {f:?}");
    // Slide across x = 0 in 500 ticks: the force changes by at most the ramp's step per tick
    // (2 max_force dt / switch_time = 1 N) and ends at the stiff side's spring.
    let mut last = f;
    for k in 1..=500 {
        let x = -0.25 + 0.5 * k as f32 / 500.0;
        let g = at(&mut world, &mut tool, x);
        assert!(
            (g - last).length() <= 1.0 + 1e-4,
            "tick {k}: {last:?} -> {g:?}"
        );
        last = g;
    }
    for _ in 0..40 {
        last = at(&mut world, &mut tool, 0.25);
    }
    assert!(
        (last.z - 400.0 * depth).abs() < 1e-4,
        "stiff side: {last:?}"
    );
    // The same probe without regions feels the force parameters' stiffness on both sides.
    let mut plain = sc.clone();
    plain.materials.regions.clear();
    let (mut store, _) = storage(&plain, Some(&vec![0; labels.len()]));
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    for _ in 0..40 {
        last = at(&mut world, &mut tool, 0.25);
    }
    assert!(
        (last.z - 200.0 * depth).abs() < 1e-4,
        "default stiffness: {last:?}"
    );
}

/// Runs `tetradrill replay` with `args` and returns its JSON.
fn replay_json(args: &[&str], name: &str) -> serde_json::Value {
    let mut all = vec!["replay"];
    all.extend_from_slice(args);
    all.push("--quiet");
    tetradrill_tests::json_of(&all, "materials", name)
}

/// The sum of `removed_by_region`'s values.
fn by_region_sum(j: &serde_json::Value) -> f64 {
    j["removed_by_region"]
        .as_object()
        .expect("removed_by_region")
        .values()
        .map(|v| v.as_f64().expect("a volume"))
        .sum()
}

#[test]
fn a_scenario_file_sets_the_regions_and_the_json_reports_them() {
    let dir = tetradrill_tests::scratch_dir("materials", "scenario");
    let sc = dir.join("two.toml");
    std::fs::write(
        &sc,
        "mesh = \"builtin:block:8\"\n\
         [regions.1]\nhardness = 2000.0\nthreshold = 3.0\nstiffness = 300.0\ncolour = \"#e8dcc0\"\n\
         [regions.2]\nhardness = 300.0\nthreshold = 0.5\n",
    )
    .expect("write");
    let j = replay_json(&["--scenario", sc.to_str().expect("utf8")], "scenario-run");
    let removed = j["removed_volume"].as_f64().expect("removed");
    let by = j["removed_by_region"].as_object().expect("by region");
    assert_eq!(by.keys().collect::<Vec<_>>(), ["1", "2"]);
    assert!(removed > 0.0);
    assert!((by_region_sum(&j) - removed).abs() < 1e-12);
    assert_eq!(j["scenario"]["regions"]["1"]["threshold"], 3.0);
    // Without a table, the same path removes more: the block is all the default material.
    let plain = replay_json(&["--mesh", "builtin:block:8"], "scenario-plain");
    assert!(plain["removed_volume"].as_f64().expect("removed") > removed);
    assert!((by_region_sum(&plain) - plain["removed_volume"].as_f64().expect("v")).abs() < 1e-12);
}

#[test]
fn the_default_region_flags_gate_the_removal() {
    // A threshold above the force clamp (8 N): nothing is ever removed.
    let j = replay_json(
        &["--hardness", "500", "--pressure-threshold", "9"],
        "flags-gate",
    );
    assert_eq!(j["removed_volume"], 0.0);
    assert_eq!(j["scenario"]["pressure_threshold"], 9.0);
    // A hardness alone slows the removal down against the unlimited default.
    let slow = replay_json(&["--hardness", "2000"], "flags-slow");
    let fast = replay_json(&[], "flags-fast");
    let (s, f) = (
        slow["removed_volume"].as_f64().expect("v"),
        fast["removed_volume"].as_f64().expect("v"),
    );
    assert!(s > 0.0 && s < 0.8 * f, "{s} vs {f}");
}

#[test]
fn bad_region_tables_name_the_file_and_line() {
    let dir = tetradrill_tests::scratch_dir("materials", "bad");
    let cases = [
        (
            "label.toml",
            "mesh = \"builtin:block:4\"\n\n[regions.shell]\nhardness = 1.0\n",
            "label.toml:3:",
            "region label",
        ),
        (
            "colour.toml",
            "[regions.1]\ncolour = \"red\"\n",
            "colour.toml:2:",
            "#rrggbb",
        ),
        (
            "key.toml",
            "[regions.1]\nhardnes = 1.0\n",
            "key.toml:2:",
            "hardnes",
        ),
        (
            "neg.toml",
            "[regions.2]\nthreshold = -1.0\n",
            "neg.toml:1:",
            "threshold",
        ),
        (
            "top.toml",
            "pressure_threshold = -2\n",
            "top.toml:1:",
            "pressure_threshold",
        ),
    ];
    for (name, text, at, why) in cases {
        let p = dir.join(name);
        std::fs::write(&p, text).expect("write");
        let p = p.to_str().expect("utf8").to_string();
        tetradrill_tests::refused(
            &["replay", "--scenario", &p, "--json", "/dev/null"],
            &[at, why],
        );
    }
    tetradrill_tests::refused(
        &["replay", "--hardness", "-1", "--json", "/dev/null"],
        &["--hardness"],
    );
}

/// A world rebuilt over the same storage (the viewer's reset) starts with no credit and
/// nothing removed by region, as its hierarchy does.
#[test]
fn a_new_world_over_the_same_storage_starts_from_nothing() {
    let sc = block_scenario(400.0, 1.0);
    let (mut store, _) = storage(&sc, Some(&[0; 3072]));
    {
        let mut world = store.world().expect("world");
        press(&mut world, 5.0, 300);
        let r = world.regions().expect("regions").table()[0];
        assert!(r.removed() > 0.0 && r.credit() > 0.0);
    }
    let world = store.world().expect("world");
    let r = world.regions().expect("regions").table()[0];
    assert_eq!((r.removed(), r.credit()), (0.0, 0.0));
    assert_eq!(world.hierarchy().removed_volume(), 0.0);
}

/// `demo` (the real-time pipeline, simulated device) reports the removed volume by region in
/// its JSON, summing to its removed volume.
#[test]
fn the_demo_json_has_the_removed_volume_by_region() {
    let j = tetradrill_tests::json_of(
        &["demo", "--headless", "--no-rt", "--duration", "2.5"],
        "materials",
        "demo",
    );
    let removed = j["removed_volume"].as_f64().expect("removed");
    let by = j["removed_by_region"].as_object().expect("by region");
    assert_eq!(by.keys().collect::<Vec<_>>(), ["1", "2"]);
    assert!(removed > 0.0, "the demo drills");
    assert!((by_region_sum(&j) - removed).abs() < 1e-12, "{j}");
}
