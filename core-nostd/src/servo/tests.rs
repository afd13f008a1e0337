//! Unit tests of [`servo_force`](super::servo_force): the spring of one plane, plane switches as
//! ramps against an f64 oracle, flickering planes, motion during a ramp, lost contact and NaN.

use super::*;
use crate::force::{ForceParams, ToolState};

fn params(switch_time: f32) -> ForceParams {
    ForceParams {
        stiffness: 200.0,
        damping: 0.0,
        max_force: 8.0,
        dt: 1e-3,
        switch_time,
    }
}

fn plane(point: Vec3, normal: Vec3) -> ContactState {
    ContactState {
        valid: true,
        point,
        normal,
        ..ContactState::default()
    }
}

/// A burr of radius 0.1 at the origin between two walls facing each other (planes x =
/// -0.08 facing +x and x = 0.07 facing -x): springs of 200 * 0.02 = 4 N along +x and
/// 200 * 0.03 = 6 N along -x.
fn walls() -> (ContactState, ContactState) {
    (
        plane(Vec3::new(-0.08, 0.0, 0.0), Vec3::X),
        plane(Vec3::new(0.07, 0.0, 0.0), -Vec3::X),
    )
}

/// A tool that has been on `c` at the origin long enough for any ramp to be over.
fn settled(c: &ContactState, p: &ForceParams) -> ToolState {
    let mut tool = ToolState::default();
    for _ in 0..20 {
        servo_force(c, Vec3::ZERO, 0.1, &mut tool, p);
    }
    tool
}

/// The spring of one plane, felt at once when the tool moves into it; a plane that shows
/// up already penetrated (first tick, a jump of the tool) ramps in from zero.
#[test]
fn one_plane_gives_the_spring() {
    let (a, _) = walls();
    let p = params(0.016);
    let mut tool = ToolState::default();
    let out = Vec3::new(0.5, 0.0, 0.0);
    assert_eq!(servo_force(&a, out, 0.1, &mut tool, &p), Vec3::ZERO);
    let f = servo_force(&a, Vec3::ZERO, 0.1, &mut tool, &p);
    assert!((f - Vec3::new(4.0, 0.0, 0.0)).length() < 1e-5, "{f:?}");
    assert_eq!(tool.residual, Vec3::ZERO);
    let mut fresh = ToolState::default();
    for t in 0..6 {
        let f = servo_force(&a, Vec3::ZERO, 0.1, &mut fresh, &p);
        let expected = (t as f32 + 1.0).min(4.0);
        assert!((f.x - expected).abs() < 1e-4, "tick {t}: {f:?}");
    }
}

/// Switching from one wall to the other ramps the force linearly (f64 oracle) from the
/// old wall's 4 N to the new wall's -6 N, 2 * 8 N * 1 ms / 16 ms = 1 N per tick, the
/// switch tick included: 10 ticks.
#[test]
fn a_plane_switch_is_a_ramp_of_bounded_slope() {
    let (a, b) = walls();
    let p = params(0.016);
    let mut tool = settled(&a, &p);
    let mut last = servo_force(&a, Vec3::ZERO, 0.1, &mut tool, &p);
    for t in 0..14 {
        let f = servo_force(&b, Vec3::ZERO, 0.1, &mut tool, &p);
        let expected = (3.0 - t as f64).max(-6.0);
        assert!(
            (f64::from(f.x) - expected).abs() < 1e-4 && f.y == 0.0 && f.z == 0.0,
            "tick {t}: {f:?}, expected {expected}"
        );
        assert!(f.distance(last) <= 1.0 + 1e-4);
        last = f;
    }
    // Without the ramp the force reverses at once.
    let p0 = params(0.0);
    let mut tool = settled(&a, &p0);
    let f = servo_force(&b, Vec3::ZERO, 0.1, &mut tool, &p0);
    assert!((f - Vec3::new(-6.0, 0.0, 0.0)).length() < 1e-5, "{f:?}");
}

/// Walls swapping every tick (the burr equidistant from both): the force never jumps by
/// more than the ramp's slope and stays between the two springs.
#[test]
fn flickering_planes_never_reverse_the_force() {
    let (a, b) = walls();
    let p = params(0.016);
    let mut tool = settled(&a, &p);
    let mut last = servo_force(&a, Vec3::ZERO, 0.1, &mut tool, &p);
    for t in 0..200 {
        let c = if (t / 3) % 2 == 0 { &b } else { &a };
        let f = servo_force(c, Vec3::ZERO, 0.1, &mut tool, &p);
        assert!(
            f.distance(last) <= 1.0 + 1e-4,
            "tick {t}: {last:?} -> {f:?}"
        );
        assert!(f.x >= -6.0 - 1e-4 && f.x <= 4.0 + 1e-4, "tick {t}: {f:?}");
        last = f;
    }
}

/// Moving while a switch is under way: the spring of the new plane follows the motion at
/// once, the ramp only carries the jump.
#[test]
fn motion_is_felt_at_once_during_a_ramp() {
    let (a, b) = walls();
    let p = params(0.016);
    let mut tool = settled(&a, &p);
    let f0 = servo_force(&b, Vec3::ZERO, 0.1, &mut tool, &p);
    // 1 mm towards the new wall: its spring grows by 0.2 N, the residual shrinks by 1 N.
    let f1 = servo_force(&b, Vec3::new(0.001, 0.0, 0.0), 0.1, &mut tool, &p);
    assert!(
        (f64::from(f1.x - f0.x) - (-0.2 - 1.0)).abs() < 1e-4,
        "{f0:?} {f1:?}"
    );
}

/// Contact lost (erosion took the material): the force fades out over at most the switch
/// time; non-finite input gives zero and forgets the residual.
#[test]
fn lost_contact_fades_and_nan_forgets() {
    let (a, _) = walls();
    let p = params(0.016);
    let mut tool = settled(&a, &p);
    let none = ContactState::default();
    for t in 0..6 {
        let x = servo_force(&none, Vec3::ZERO, 0.1, &mut tool, &p).x;
        let expected = (3.0 - t as f32).max(0.0);
        assert!((x - expected).abs() < 1e-4, "tick {t}: {x}");
    }
    servo_force(&a, Vec3::ZERO, 0.1, &mut tool, &p);
    let nan = servo_force(&none, Vec3::splat(f32::NAN), 0.1, &mut tool, &p);
    assert_eq!(nan, Vec3::ZERO);
    assert_eq!((tool.residual, tool.plane), (Vec3::ZERO, None));
}

/// The vibration: on a settled plane of 4 N (threshold 1 N, clamp 8 N, so a share of
/// `(4 - 1) / (8 - 1)`), a 250 Hz cue of 0.7 N adds `0.3 sin(2 pi (k + 1) / 4)` newtons along
/// the force at tick `k` (an f64 oracle); without a cue, or with the drill's cue at zero
/// frequency, the force is the same bits as before.
#[test]
fn a_cue_vibrates_the_force_along_itself() {
    let (a, _) = walls();
    let p = params(0.016);
    let plain = servo_force(&a, Vec3::ZERO, 0.1, &mut settled(&a, &p), &p);
    let cue = VibrationCue {
        hz: 250.0,
        amplitude: 0.7,
        threshold: 1.0,
    };
    let shaken = ContactState {
        vibration: cue,
        ..a
    };
    let mut tool = settled(&a, &p);
    for k in 0..12 {
        let f = servo_force(&shaken, Vec3::ZERO, 0.1, &mut tool, &p);
        let phase = (f64::from(250.0f32 * 1e-3f32) * (k + 1) as f64).fract();
        let v = 0.7 * (3.0 / 7.0) * libm::sin(core::f64::consts::TAU * phase);
        assert!((f64::from(f.x) - (4.0 + v)).abs() < 1e-4, "tick {k}: {f:?}");
        assert!(f.y == 0.0 && f.z == 0.0);
    }
    let off = ContactState {
        vibration: VibrationCue { hz: 0.0, ..cue },
        ..a
    };
    let mut tool = settled(&a, &p);
    assert_eq!(servo_force(&off, Vec3::ZERO, 0.1, &mut tool, &p), plain);
    // Below the threshold nothing vibrates; an amplitude beyond the force never reverses it.
    let hard = ContactState {
        vibration: VibrationCue {
            threshold: 5.0,
            ..cue
        },
        ..a
    };
    let mut tool = settled(&a, &p);
    for _ in 0..8 {
        assert_eq!(servo_force(&hard, Vec3::ZERO, 0.1, &mut tool, &p), plain);
    }
    let wild = ContactState {
        vibration: VibrationCue {
            amplitude: 1e6,
            threshold: 0.0,
            ..cue
        },
        ..a
    };
    let mut tool = settled(&a, &p);
    for _ in 0..8 {
        let f = servo_force(&wild, Vec3::ZERO, 0.1, &mut tool, &p);
        assert!(f.x >= 0.0 && f.x <= 8.0 + 1e-4, "{f:?}");
    }
}

/// The sideways pull: on a settled plane of 4 N along +x (the wall at x = -0.08), a burr
/// spinning about +z (its side on the wall) with a friction of 0.3 is pulled by
/// `0.3 * 4 = 1.2` N along `z x x = +y`, the other way when it spins the other way, by
/// `1.2 sin(a)` with the spin at an angle `a` to the normal, not at all about the normal
/// itself; without a friction or a spin the force is the same bits as before.
#[test]
fn a_spinning_burr_is_pulled_sideways_by_the_friction() {
    let (a, _) = walls();
    let p = params(0.016);
    let plain = servo_force(&a, Vec3::ZERO, 0.1, &mut settled(&a, &p), &p);
    let rough = ContactState { friction: 0.3, ..a };
    let spun = |omega: Vec3, c: &ContactState| {
        let mut tool = settled(&a, &p);
        tool.set_spin(omega);
        servo_force(c, Vec3::ZERO, 0.1, &mut tool, &p)
    };
    let f = spun(Vec3::Z, &rough);
    assert!((f - Vec3::new(4.0, 1.2, 0.0)).length() < 1e-4, "{f:?}");
    let f = spun(-Vec3::Z * 7.0, &rough);
    assert!((f - Vec3::new(4.0, -1.2, 0.0)).length() < 1e-4, "{f:?}");
    // Tilted 60 degrees from the normal: sin 60 of the pull.
    let tilt = Vec3::new(
        libm::sinf(core::f32::consts::FRAC_PI_6),
        0.0,
        libm::cosf(core::f32::consts::FRAC_PI_6),
    );
    let f = spun(tilt, &rough);
    assert!(
        (f.y - 1.2 * libm::cosf(core::f32::consts::FRAC_PI_6)).abs() < 1e-4,
        "{f:?}"
    );
    assert_eq!(
        spun(Vec3::X, &rough),
        plain,
        "spinning about the normal: no slide"
    );
    assert_eq!(spun(Vec3::Z, &a), plain, "no friction");
    assert_eq!(spun(Vec3::ZERO, &rough), plain, "no spin");
    assert_eq!(
        spun(Vec3::splat(f32::NAN), &rough),
        plain,
        "a spin that is not a number"
    );
    // Clamped with the rest.
    let wild = ContactState {
        friction: 50.0,
        ..a
    };
    assert!(spun(Vec3::Z, &wild).length() <= 8.0 + 1e-4);
}

#[test]
fn the_burrs_storage_is_the_spring_the_servo_renders() {
    // A plane at z = 0, the burr (radius 0.1) 0.02 below it; energies worked out by hand:
    // K d^2 / 2 below the force limit's depth F / K, then F a unit of depth past it.
    let contact = ContactState {
        valid: true,
        point: Vec3::ZERO,
        normal: Vec3::Z,
        ..ContactState::default()
    };
    let params = ForceParams {
        stiffness: 200.0,
        max_force: 8.0,
        ..ForceParams::default()
    };
    let centre = Vec3::new(0.3, -0.2, 0.08);
    let (d, s) = burr_storage(&contact, centre, 0.1, &params);
    assert!((d - 0.02).abs() < 1e-6);
    assert!(
        (s.stored_j - 0.04).abs() < 1e-6 && s.past_limit_j == 0.0,
        "{s:?}"
    );
    // A region of 1,000 N per unit under the contact: the servo renders its stiffness, so the
    // limit (8 N) is reached 0.008 deep: 0.032 stored up to there, 8 x 0.012 past it.
    let stiff = ContactState {
        stiffness: 1000.0,
        ..contact
    };
    let (d, s) = burr_storage(&stiff, centre, 0.1, &params);
    assert!((d - 0.02).abs() < 1e-6);
    assert!((s.stored_j - 0.128).abs() < 1e-5, "{s:?}");
    assert!((s.past_limit_j - 0.096).abs() < 1e-5, "{s:?}");
    // Out of contact, no contact, a pose that is not finite: nothing.
    for (c, at) in [
        (contact, Vec3::new(0.0, 0.0, 0.2)),
        (ContactState::default(), centre),
        (contact, Vec3::NAN),
    ] {
        assert_eq!(
            burr_storage(&c, at, 0.1, &params),
            (0.0, Default::default())
        );
    }
}
