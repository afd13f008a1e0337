//! The soft body's step spread over servo ticks (`tetradrill_core::soft::Link`) against a
//! reference written here from whole steps: a burr pressing and drilling a soft block, the
//! reference gathering the reaction itself (at the world's contact point over the contact
//! tet, each tick), stepping the body whole (`SoftBody::step`) with the previous cycle's mean
//! load at each cycle's last tick and moving its world with `World::set_positions`. The link's world must give the same forces and positions bit for
//! bit, tick after tick, with each tick's work within its share; and `replay` of
//! `builtin:firmware-soft` runs the same twice and dents the block.

use glam::Vec3;
use tetradrill::soft::SoftOwned;
use tetradrill_core::drill::DrillParams;
use tetradrill_core::force::{ForceParams, ToolState};
use tetradrill_core::hash::{Aabb, HashEntry};
use tetradrill_core::servo::{servo_force, SpareStorage, WorldSizes};
use tetradrill_core::soft::{
    spread_point_force, Link, LinkBuffers, LinkError, Material, SoftParams, TET_UNITS,
};
use tetradrill_tests::search::{block_mesh, Store};
use tetradrill_tests::{scratch_dir, tetradrill_bin};

const MATERIAL: Material = Material {
    young: 3e3,
    poisson: 0.3,
    density: 1000.0,
};

fn params() -> SoftParams {
    SoftParams {
        gravity: Vec3::ZERO,
        damping: 10.0,
        substeps: 3,
        iterations: 1,
    }
}

#[test]
fn the_link_moves_the_world_as_whole_steps_a_cycle_late() {
    let ticks = 7u32;
    let dt = 1e-3f32;
    let mut om_a = block_mesh(4);
    let mut om_b = block_mesh(4);
    let (mesh_a, mesh_b) = (om_a.view(), om_b.view());
    let n = mesh_a.node_count();
    let t = mesh_a.tet_count();
    let mut soft_a = SoftOwned::from_mesh(&mesh_a);
    let mut soft_b = soft_a.clone();
    let mut body_a = soft_a.body(&[MATERIAL], params()).unwrap();
    let mut body_b = soft_b.body(&[MATERIAL], params()).unwrap();
    let origin = Vec3::new(0.0, 0.0, -0.45);
    body_a.fix_below(origin, Vec3::Z);
    body_b.fix_below(origin, Vec3::Z);
    let mut st_a = Store::new(t, 1 << 15);
    let mut st_b = Store::new(t, 1 << 15);
    let mut a = st_a.world(mesh_a);
    let mut b = st_b.world(mesh_b);
    let (mut rest_a, mut rest_b) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    a.enable_deformation(&mut rest_a).unwrap();
    b.enable_deformation(&mut rest_b).unwrap();
    assert_eq!(
        Link::new(&body_b, &b, ticks, dt).err(),
        Some(LinkError::NoSpare)
    );
    let sizes = WorldSizes::new(t, 0);
    let mut starts = vec![0u32; sizes.hash_starts];
    let mut entries = vec![HashEntry::default(); sizes.hash_entries];
    let mut boxes = vec![Aabb::point(Vec3::ZERO); sizes.tet_boxes];
    let mut normals = vec![Vec3::ZERO; n];
    b.set_spare(SpareStorage {
        hash_starts: &mut starts,
        hash_entries: &mut entries,
        tet_boxes: &mut boxes,
        normals: &mut normals,
    })
    .unwrap();
    assert_eq!(Link::new(&body_b, &b, 0, dt).err(), Some(LinkError::Cycle));
    let mut link = Link::new(&body_b, &b, ticks, dt).unwrap();
    let per_tick = link.units_per_tick();
    assert!(u64::from(per_tick) * u64::from(ticks) >= link.cycle_units());
    let (mut la, mut lb, mut next) = (
        vec![Vec3::ZERO; n],
        vec![Vec3::ZERO; n],
        vec![Vec3::ZERO; n],
    );

    // The reference's loads: the cycle being gathered and the one being stepped.
    let mut gathering = vec![Vec3::ZERO; n];
    let mut stepping = vec![Vec3::ZERO; n];
    let mut gathered = 0u32;
    let mut now = vec![Vec3::ZERO; n];
    let drill = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 3_000,
    };
    let fp = ForceParams {
        stiffness: 400.0,
        max_force: 20.0,
        ..ForceParams::default()
    };
    let (mut tool_a, mut tool_b) = (ToolState::default(), ToolState::default());
    let (mut fa, mut fb) = (Vec3::ZERO, Vec3::ZERO);
    let (mut most, mut commits, mut touching) = (0u32, 0u32, 0u32);
    let (radius, reach) = (0.12f32, 0.06f32);
    for i in 0..(30 * ticks) {
        // Down into the top, then along it with the drill on.
        let s = i as f32 / (30 * ticks) as f32;
        let centre = Vec3::new(
            0.2 * s - 0.1,
            0.05 * (9.0 * s).sin(),
            0.5 + radius - 0.04 * s.min(0.5) * 2.0,
        );
        let drilling = i > 100;
        // The servo's force from the last step's contact, then this tick's step (as a
        // firmware's release rule).
        fa = servo_force(a.contact(), centre, radius, &mut tool_a, &fp);
        fb = servo_force(b.contact(), centre, radius, &mut tool_b, &fp);
        assert_eq!(
            fa.to_array().map(f32::to_bits),
            fb.to_array().map(f32::to_bits),
            "tick {i}"
        );
        a.simulate(centre, radius, reach, drilling, &drill);
        b.simulate(centre, radius, reach, drilling, &drill);
        assert_eq!(a.contact(), b.contact(), "tick {i}");
        let c = i % ticks;
        if c == 0 {
            // The cycle's load: the mean of the last cycle's reactions.
            let mean = 1.0 / gathered.max(1) as f32;
            for (l, s) in stepping.iter_mut().zip(gathering.iter_mut()) {
                *l = *s * mean;
                *s = Vec3::ZERO;
            }
            gathered = 0;
        }
        if let (Some(tet), true) = (a.contact_tet(), fa != Vec3::ZERO) {
            touching += 1;
            let ids = a.mesh().tet_nodes(tet);
            let parts =
                spread_point_force(a.mesh().tet_positions(tet), a.contact().point, -fa).unwrap();
            for (k, f) in ids.iter().zip(parts) {
                gathering[k.idx()] += f;
            }
        }
        gathered += 1;
        let out = link
            .tick(
                &mut body_b,
                &mut b,
                LinkBuffers {
                    a: &mut la,
                    b: &mut lb,
                    next: &mut next,
                },
                fb,
            )
            .unwrap();
        most = most.max(out.units);
        assert!(
            out.units < per_tick + TET_UNITS,
            "tick {i}: {} units",
            out.units
        );
        if c + 1 == ticks {
            body_a.step(ticks as f32 * dt, &stepping).unwrap();
            body_a.write_positions(&mut now);
            let rep = a.set_positions(&now).unwrap();
            assert_eq!(
                out.committed.map(|r| r.max_displacement),
                Some(rep.max_displacement)
            );
            commits += 1;
        } else {
            assert!(out.committed.is_none());
        }
        // The two worlds at every tick, bit for bit.
        let bits = |v: &[Vec3]| -> Vec<u32> {
            v.iter()
                .flat_map(|x| x.to_array().map(f32::to_bits))
                .collect()
        };
        assert_eq!(
            bits(a.mesh().positions()),
            bits(b.mesh().positions()),
            "tick {i}"
        );
    }
    assert_eq!(link.late(), 0);
    assert_eq!(link.steps(), commits);
    assert!(touching > 100, "{touching} ticks in contact");
    assert!(most > per_tick / 2);
    let dent = link.max_displacement();
    assert!(dent > 1e-3, "dent {dent}");
    let _ = (fa, fb);
}

#[test]
fn replay_of_firmware_soft_is_deterministic_and_dents() {
    let dir = scratch_dir("soft_link", "replay");
    let mut digests = Vec::new();
    for k in 0..2 {
        let out = dir.join(format!("run{k}.json"));
        let o = std::process::Command::new(tetradrill_bin())
            .args([
                "replay",
                "--quiet",
                "--scenario",
                "builtin:firmware-soft",
                "--json",
            ])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        let d = &j["deform"];
        assert!(d["max_displacement"].as_f64().unwrap() > 1e-3, "{d}");
        assert_eq!(d["spread"]["late"], 0);
        assert!(
            d["spread"]["units_max"].as_u64().unwrap()
                < d["spread"]["units_per_tick"].as_u64().unwrap() + u64::from(TET_UNITS)
        );
        digests.push(j["force_digest"].as_str().unwrap().to_string());
    }
    assert_eq!(digests[0], digests[1]);
}

/// Runs `tetradrill` and asserts exit status 2 with a first stderr line holding every needle.
fn refused(args: &[&str], needles: &[&str]) {
    let o = std::process::Command::new(tetradrill_bin())
        .args(args)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    let first = err.lines().next().unwrap_or("");
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    for n in needles {
        assert!(first.contains(n), "{args:?}: `{first}` lacks `{n}`");
    }
}

#[test]
fn bad_spread_flags_and_keys_exit_2() {
    refused(
        &["replay", "--body", "soft", "--soft-substeps", "0"],
        &["--soft-substeps"],
    );
    refused(
        &["replay", "--body", "soft", "--soft-spread", "maybe"],
        &["--soft-spread"],
    );
    let dir = scratch_dir("soft_link", "keys");
    for (name, text, needle) in [
        (
            "substeps.toml",
            "body = \"soft\"\nsoft_substeps = 5000\n",
            "substeps.toml:2:",
        ),
        (
            "spread.toml",
            "body = \"soft\"\nsoft_spread = 3\n",
            "spread.toml:2",
        ),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        refused(&["replay", "--scenario", &p.to_string_lossy()], &[needle]);
    }
}
