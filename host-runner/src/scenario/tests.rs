//! Scenario files, built-ins and flags: what is read, what is refused.

use super::*;
use crate::setup::{
    capacity, check_soft_rate, CAPACITIES, DEMO_CORE_YOUNG, DEMO_SHELL_YOUNG, MAX_BUFFER_BYTES,
    TOOTH_DENTIN, TOOTH_ENAMEL, TOOTH_PULP,
};

#[test]
fn flags_override_the_scenario() {
    let f = ScenarioFlags {
        scenario: Some("builtin:firmware".into()),
        stiffness: Some(50.0),
        ..Default::default()
    };
    let s = Scenario::from_flags(&f).expect("valid");
    assert_eq!(s.mesh, "builtin:block:4");
    assert_eq!(s.stiffness, 50.0);
}

#[test]
fn bad_scenarios_name_the_file_and_line() {
    let dir = std::env::temp_dir().join(format!("tdscn-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let p = dir.join("bad.toml");
    std::fs::write(&p, "mesh = \"builtin:cube12\"\nstiffnes = 3.0\n").expect("write");
    let e = Scenario::load(p.to_str().expect("utf8")).expect_err("unknown key");
    assert_eq!(e.code, 2);
    assert!(e.message.contains("bad.toml:2:"), "{}", e.message);
    std::fs::write(&p, "tool = \"sphere:-1\"\n").expect("write");
    let e = Scenario::load(p.to_str().expect("utf8")).expect_err("negative radius");
    assert!(e.message.contains("radius"), "{}", e.message);
    assert!(Scenario::load("builtin:nope").is_err());
    std::fs::write(
        &p,
        "mesh = \"builtin:cube12\"\n# zero\n  hash_capacity =0\n",
    )
    .expect("write");
    let e = Scenario::load(p.to_str().expect("utf8")).expect_err("zero capacity");
    assert!(e.message.contains("bad.toml:3:"), "{}", e.message);
    assert!(e.message.contains("--hash-capacity"), "{}", e.message);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn capacities_refuse_zero_and_more_than_a_gibibyte() {
    for c in CAPACITIES {
        assert!(c.check(0).is_err(), "{}", c.key);
        assert!(c.check(c.min).is_ok(), "{}", c.key);
        assert!(c.check(c.max()).is_ok(), "{}", c.key);
        assert!(c.check(c.max() + 1).is_err(), "{}", c.key);
        assert!(c.max() * c.entry_bytes <= MAX_BUFFER_BYTES);
        let s = Setup::default();
        assert!(
            s.capacity_value(c.key).is_none_or(|v| c.check(v).is_ok()),
            "the default {} is accepted",
            c.key
        );
    }
    assert!(capacity("hierarchy_capacity").is_some_and(|c| c.check(7).is_err()));
}

#[test]
fn firmware_tooth_names_the_tooth_its_path_and_three_materials() {
    let s = Scenario::load("builtin:firmware-tooth").expect("built in");
    assert!(s.mesh.ends_with(TOOTH), "{}", s.mesh);
    assert!(Path::new(&s.mesh).is_file(), "{}", s.mesh);
    assert_eq!(s.trace, "builtin:tooth-access");
    assert!(s.check().is_ok());
    let r = |l: i32| &s.regions[&l.to_string()];
    let (e, d, p) = (r(TOOTH_ENAMEL), r(TOOTH_DENTIN), r(TOOTH_PULP));
    assert_eq!(s.regions.len(), 3);
    assert!(e.hardness > d.hardness && d.hardness > p.hardness);
    assert!(e.threshold > d.threshold && d.threshold > p.threshold);
    assert!(e.stiffness > d.stiffness && d.stiffness > p.stiffness);
    assert!([e, d, p].iter().all(|m| m.rgb().is_some()));
}

#[test]
fn the_real_size_tooth_names_its_mesh_its_path_and_the_firmware_tooths_materials() {
    let s = Scenario::load("builtin:tooth").expect("built in");
    assert!(s.mesh.ends_with(teeth::PREMOLAR), "{}", s.mesh);
    assert!(Path::new(&s.mesh).is_file(), "{}", s.mesh);
    assert_eq!(s.trace, "builtin:premolar-access");
    assert_eq!(s.tool, "sphere:0.0007");
    assert!(s.check().is_ok());
    let firmware = Scenario::load("builtin:firmware-tooth").expect("built in");
    assert_eq!(s.regions, firmware.regions);
    assert_eq!(s.setup().expect("a set-up").poses.to_string(), s.trace);
}

#[test]
fn soft_keys_read_back_and_a_rigid_scenario_leaves_them_out() {
    let text = "body = \"soft\"\nyoung = 2000.0\npoisson = 0.25\nfix_below = \"y:-0.4\"\nsoft_rate = 500.0\n";
    let s: Scenario = toml::from_str(text).expect("soft keys");
    assert!(s.check().is_ok());
    assert_eq!(s.body, BodyKind::Soft);
    assert_eq!((s.young, s.poisson), (Some(2000.0), Some(0.25)));
    assert_eq!(
        FixBelow::parse(s.fix_below.as_deref().expect("set")),
        Ok(FixBelow {
            axis: 1,
            value: -0.4
        })
    );
    let back: Scenario = toml::from_str(&toml::to_string(&s).expect("to TOML")).expect("back");
    assert_eq!(back, s);
    let rigid = toml::to_string(&Scenario::default()).expect("to TOML");
    for key in ["body", "young", "poisson", "fix_below", "soft_rate"] {
        assert!(!rigid.contains(key), "{key} in {rigid}");
    }
    // The rate is a whole number of 1 ms ticks a step.
    assert!(check_soft_rate(250.0).is_ok() && check_soft_rate(1000.0).is_ok());
    for bad in [0.0, -5.0, 300.0, 1500.0, f64::NAN] {
        assert!(check_soft_rate(bad).is_err(), "{bad}");
    }
    for bad in ["z", "w:1", "z:nan", "z:", ":1"] {
        assert!(FixBelow::parse(bad).is_err(), "{bad}");
    }
}

#[test]
fn region_soft_keys_read_back_and_bad_ones_name_the_region_and_its_line() {
    let text = "body = \"soft\"\n[regions.1]\nyoung = 3000.0\npoisson = 0.2\ndensity = 1100.0\n\
                [regions.12]\nhardness = 1.0\n";
    let s: Scenario = toml::from_str(text).expect("region soft keys");
    assert!(s.check().is_ok());
    let r = &s.regions["1"];
    assert_eq!(
        (r.young, r.poisson, r.density),
        (Some(3000.0), Some(0.2), Some(1100.0))
    );
    assert_eq!(s.regions["12"].young, None);
    let back: Scenario = toml::from_str(&toml::to_string(&s).expect("to TOML")).expect("back");
    assert_eq!(back, s);
    let dir = std::env::temp_dir().join(format!("tdscn-soft-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let p = dir.join("bad.toml");
    for (text, line, what) in [
        (
            "[regions.1]\nyoung = 1.0\n[regions.12]\nyoung = -5.0\n",
            3,
            "regions.12.young",
        ),
        (
            "[regions.12]\nhardness = 1.0\n[regions.1]\npoisson = 0.5\n",
            3,
            "regions.1.poisson",
        ),
        ("\n[regions.2]\ndensity = 0.0\n", 2, "regions.2.density"),
        ("[regions.2]\nyoung = 1e300\n", 1, "regions.2.young"),
        (
            "[regions.3]\nthreshold = 1.0\ncutting_energy = -2.0\n",
            1,
            "regions.3.cutting_energy",
        ),
    ] {
        std::fs::write(&p, text).expect("write");
        let e = Scenario::load(p.to_str().expect("utf8")).expect_err(what);
        assert_eq!(e.code, 2);
        assert!(
            e.message.contains(&format!("bad.toml:{line}:")),
            "{}",
            e.message
        );
        assert!(e.message.contains(what), "{}", e.message);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn builtin_regions_carry_checked_soft_values() {
    let tooth = tooth_regions();
    let e = |l: i32| tooth[&l].young.expect("a modulus");
    assert!(e(TOOTH_ENAMEL) > e(TOOTH_DENTIN) && e(TOOTH_DENTIN) > e(TOOTH_PULP));
    let demo = demo_regions();
    assert_eq!(demo[&1].young, Some(DEMO_SHELL_YOUNG));
    assert_eq!(demo[&2].young, Some(DEMO_CORE_YOUNG));
    for r in tooth.values().chain(demo.values()) {
        assert!(r.check().is_ok());
    }
}
