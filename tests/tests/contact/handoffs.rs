//! The lock-free hand-offs between a simulation step and a servo (`ContactHandoff` and
//! `Servo`, `DrillHandoff` and `DrillServo`, `PenHandoff`), through their public interface: a
//! published step comes back bit for bit, a servo renders what the free functions render
//! from the same contacts, and a reader on another thread never sees a mix of two steps nor a
//! step older than the one before (the threads are why these live outside the `no_std` core).

mod contact {
    use std::sync::atomic::AtomicBool;
    use std::sync::atomic::Ordering;
    use std::thread;
    use tetradrill_core::force::{ForceDigest, ForceParams, ToolState};
    use tetradrill_core::servo::*;
    use tetradrill_core::Vec3;

    /// A contact whose every field is a function of `i`, so a mix of two is recognisable.
    fn contact(i: u32) -> ContactState {
        let x = i as f32;
        ContactState {
            valid: i % 2 == 1,
            point: Vec3::new(x, x + 0.5, -x),
            normal: Vec3::new(0.25 * x, 1.0, x * x),
            depth: 3.0 * x,
            centre: Vec3::new(-2.0 * x, 7.0, x + 1.0),
            triangles: i.wrapping_mul(3),
            stiffness: x + 100.0,
            vibration: VibrationCue {
                hz: x + 200.0,
                amplitude: x + 300.0,
                threshold: x + 400.0,
            },
            friction: x + 500.0,
        }
    }

    #[test]
    fn a_published_contact_comes_back_bit_for_bit_with_its_step() {
        let h = ContactHandoff::new();
        assert_eq!(h.latest(), Some(Published::default()));
        for i in 1..=5 {
            let mut c = contact(i);
            c.normal.y = f32::from_bits(0x7fc0_1234); // a NaN payload survives
            assert_eq!(h.publish(&c), i);
            let p = h.latest().expect("no publisher running");
            assert_eq!(p.step, i);
            assert_eq!(p.contact.normal.y.to_bits(), 0x7fc0_1234);
            c.normal.y = 0.0;
            let mut got = p.contact;
            got.normal.y = 0.0;
            assert_eq!(got, c);
        }
    }

    #[test]
    fn the_servo_reports_its_force_and_ticks_to_the_simulation() {
        let h = ContactHandoff::new();
        let mut seen = 0;
        assert_eq!(h.pressing(&mut seen), None);
        h.report_force(Vec3::new(3.0, 4.0, 0.0));
        h.report_force(Vec3::new(0.0, 0.0, 2.0));
        assert_eq!(h.pressing(&mut seen), Some((2.0, 2)));
        assert_eq!(h.pressing(&mut seen), None);
        h.report_force(Vec3::ZERO);
        assert_eq!(h.pressing(&mut seen), Some((0.0, 1)));
    }

    #[test]
    fn a_servo_renders_what_servo_force_renders_from_the_same_contacts() {
        let params = ForceParams::default();
        let h = ContactHandoff::new();
        let mut servo = Servo::new(0.1, params);
        let (mut tool, mut digest) = (ToolState::default(), ForceDigest::default());
        let plane = ContactState {
            valid: true,
            point: Vec3::ZERO,
            normal: Vec3::Z,
            depth: 0.05,
            centre: Vec3::new(0.0, 0.0, 0.05),
            triangles: 1,
            stiffness: 0.0,
            vibration: VibrationCue::default(),
            friction: 0.0,
        };
        for i in 0..50 {
            let c = if i < 20 {
                plane
            } else {
                ContactState::default()
            };
            h.publish(&c);
            let at = Vec3::new(0.0, 0.0, 0.1 - 0.004 * i as f32);
            let want = servo_force(&c, at, 0.1, &mut tool, &params);
            digest.push(want);
            assert_eq!(servo.tick(&h, at), want, "tick {i}");
        }
        assert_eq!(servo.digest(), digest.value());
        assert_eq!(
            (servo.ticks(), servo.stale_reads(), servo.step()),
            (50, 0, 50)
        );
        assert!(servo.contact_ticks() > 0);
    }

    /// A publisher and a reader on two threads: every contact read is one the publisher
    /// wrote whole (all fields from one `i`, with that step's number), and steps never go
    /// back.
    #[test]
    fn a_reader_on_another_thread_never_sees_a_mixed_contact() {
        let h = ContactHandoff::new();
        let done = AtomicBool::new(false);
        const STEPS: u32 = 200_000;
        thread::scope(|s| {
            s.spawn(|| {
                for i in 1..=STEPS {
                    assert_eq!(h.publish(&contact(i)), i);
                }
                done.store(true, Ordering::Release);
            });
            let (mut last, mut reads, mut stale) = (0, 0u64, 0u64);
            while !done.load(Ordering::Acquire) || reads == 0 {
                match h.latest() {
                    Some(p) => {
                        assert!(p.step >= last, "step {} after {last}", p.step);
                        if p.step > 0 {
                            assert_eq!(p.contact, contact(p.step), "a mixed contact");
                        }
                        last = p.step;
                        reads += 1;
                    }
                    None => stale += 1,
                }
            }
            assert!(reads > 0);
            // Once the publisher is done, the newest is its last.
            assert_eq!(h.latest().map(|p| p.step), Some(STEPS));
            let _ = stale;
        });
    }
}

mod drill {
    use core::sync::atomic::{AtomicBool, Ordering};
    use std::thread;
    use tetradrill_core::force::*;
    use tetradrill_core::servo::*;
    use tetradrill_core::Vec3;

    /// A step's contact and shaft whose every field is a function of `i`, so a mix of two is
    /// recognisable; points with and without a plane.
    fn published(i: u32) -> (ContactState, DrillState) {
        let x = i as f32;
        let c = ContactState {
            valid: i % 2 == 1,
            point: Vec3::new(x, -x, 0.5),
            normal: Vec3::new(0.0, 1.0, x),
            depth: 2.0 * x,
            centre: Vec3::new(x, 1.0, -3.0),
            triangles: i.wrapping_mul(7),
            stiffness: x + 1.0,
            vibration: VibrationCue::default(),
            friction: x + 3.0,
        };
        let mut s = DrillState {
            count: (i as usize % MAX_PASSIVE) + 1,
            ..DrillState::default()
        };
        for (k, pt) in s.points.iter_mut().enumerate() {
            let y = k as f32;
            *pt = PassivePoint {
                // The proxy and held plane are the simulation's: not handed over.
                proxy: None,
                held: None,
                plane: (!(k + i as usize).is_multiple_of(3))
                    .then(|| (Vec3::new(x, y, x + y), Vec3::new(y, -x, 1.0))),
            };
        }
        (c, s)
    }

    #[test]
    fn a_published_drill_contact_comes_back_bit_for_bit_with_its_step() {
        let h = DrillHandoff::new();
        assert_eq!(h.latest(), Some(DrillPublished::default()));
        for i in 1..=40 {
            let (c, s) = published(i);
            assert_eq!(h.publish(&c, &s), i);
            let p = h.latest().expect("no publisher running");
            assert_eq!(
                p.burr,
                Published {
                    contact: c,
                    step: i
                }
            );
            assert_eq!(p.shaft.count, s.count);
            assert_eq!(p.shaft.points, s.points);
        }
    }

    #[test]
    fn the_proxies_and_held_planes_stay_with_the_simulation() {
        let h = DrillHandoff::new();
        let (c, mut s) = published(3);
        s.points[0].proxy = Some(Vec3::ONE);
        s.points[0].held = Some((Vec3::ONE, Vec3::Z));
        h.publish(&c, &s);
        let p = h.latest().expect("no publisher running");
        assert_eq!(p.shaft.points[0].proxy, None);
        assert_eq!(p.shaft.points[0].held, None);
        assert_eq!(p.shaft.points[0].plane, s.points[0].plane);
    }

    /// The servo renders, tick by tick, what `drill_force` and `drill_torque` render from the
    /// same contacts and shafts with their own states, and reports the burr's force.
    #[test]
    fn a_drill_servo_renders_what_drill_force_renders_from_the_same_contacts() {
        let params = ForceParams::default();
        let tool = DrillTool {
            burr_radius: 0.1,
            shaft_length: 0.6,
            shaft_radius: 0.03,
        };
        let (h, press) = (DrillHandoff::new(), ContactHandoff::new());
        let mut servo = DrillServo::new(tool, params);
        let (mut burr, mut shaft) = (ToolState::default(), ToolState::default());
        let (mut digest, mut torques) = (ForceDigest::new(), ForceDigest::new());
        // The burr under the plane z = 0 and the shaft lying on it along +x.
        let axis = Vec3::X;
        let plane = ContactState {
            valid: true,
            normal: Vec3::Z,
            triangles: 1,
            ..ContactState::default()
        };
        let mut state = DrillState {
            count: tool.passive_count(),
            ..DrillState::default()
        };
        for pt in state.points.iter_mut().take(state.count) {
            pt.plane = Some((Vec3::ZERO, Vec3::Z));
        }
        let mut seen = 0;
        let mut pushed = 0;
        for i in 0..60 {
            let c = if i < 40 {
                plane
            } else {
                ContactState::default()
            };
            h.publish(&c, &state);
            let at = Vec3::new(0.0, 0.0, 0.1 - 0.002 * i as f32);
            let (want, on_burr) =
                drill_force(&c, &tool, at, axis, &state, &mut burr, &mut shaft, &params);
            let torque = drill_torque(&tool, at, axis, &state, &params);
            digest.push(want);
            torques.push(torque);
            assert_eq!(servo.tick(&h, &press, at, axis), (want, torque), "tick {i}");
            assert_eq!(press.pressing(&mut seen), Some((on_burr.length(), 1)));
            pushed += u32::from(torque != Vec3::ZERO);
        }
        assert!(pushed > 0, "the shaft pushed");
        assert_eq!(servo.digest(), digest.value());
        assert_eq!(servo.torque_digest(), torques.value());
        assert_eq!(
            (servo.ticks(), servo.stale_reads(), servo.step()),
            (60, 0, 60)
        );
        assert!(servo.contact_ticks() > 0);
    }

    /// The moment by hand: a shaft along +x from the origin, its last point (at the handle,
    /// 0.6 out) 0.02 into the plane under it, pushed up with 200 N/unit x 0.02 = 4 N: a
    /// moment of 0.6 x 4 about -y. With the points at 0.1, 0.3941 and 0.6 all pushing, the
    /// 12 N the springs add up to is clamped to 8 N, and the moment with it.
    #[test]
    fn the_torque_is_the_moment_of_the_shafts_springs_about_the_burr() {
        let tool = DrillTool {
            burr_radius: 0.1,
            shaft_length: 0.6,
            shaft_radius: 0.03,
        };
        let params = ForceParams {
            stiffness: 200.0,
            max_force: 8.0,
            ..ForceParams::default()
        };
        let n = tool.passive_count();
        assert_eq!(n, 18);
        let mut state = DrillState {
            count: n,
            ..DrillState::default()
        };
        let last = n - 1;
        state.points[last].plane = Some((Vec3::new(0.6, 0.0, -0.01), Vec3::Z));
        let t = drill_torque(&tool, Vec3::ZERO, Vec3::X, &state, &params);
        assert!((t - Vec3::new(0.0, -2.4, 0.0)).length() < 1e-5, "{t}");
        // Two more points pushing as hard: 12 N clamped to 8, the moment by 8 / 12.
        let offset = |k: usize| 0.1 + 0.5 * k as f32 / (n - 1) as f32;
        for k in [0, 10] {
            state.points[k].plane = Some((Vec3::new(offset(k), 0.0, -0.01), Vec3::Z));
        }
        let t = drill_torque(&tool, Vec3::ZERO, Vec3::X, &state, &params);
        let want = -4.0 * (0.6 + offset(0) + offset(10)) * 8.0 / 12.0;
        assert!(
            (t - Vec3::new(0.0, want, 0.0)).length() < 1e-5,
            "{t} against {want}"
        );
        // Moved and turned, the moment turns with the shaft: along +y, pushed towards -x.
        let c = Vec3::new(1.0, 2.0, 3.0);
        let mut turned = DrillState {
            count: n,
            ..DrillState::default()
        };
        turned.points[last].plane = Some((c + Vec3::new(0.01, 0.6, 0.0), -Vec3::X));
        let t = drill_torque(&tool, c, Vec3::Y, &turned, &params);
        // (0.6 y) x (-4 x) = 2.4 z.
        assert!((t - Vec3::new(0.0, 0.0, 2.4)).length() < 1e-4, "{t}");
        // No plane, or the points short of it: no moment; NaN: none.
        assert_eq!(
            drill_torque(&tool, c, Vec3::Y, &DrillState::default(), &params),
            Vec3::ZERO
        );
        assert_eq!(
            drill_torque(&tool, Vec3::NAN, Vec3::X, &state, &params),
            Vec3::ZERO
        );
    }

    /// A publisher and a reader on two threads: every drill contact read is one the publisher
    /// wrote whole (all fields from one `i`), and steps never go back.
    #[test]
    fn a_reader_on_another_thread_never_sees_a_mixed_drill_contact() {
        let h = DrillHandoff::new();
        let done = AtomicBool::new(false);
        const STEPS: u32 = 20_000;
        thread::scope(|s| {
            s.spawn(|| {
                for i in 1..=STEPS {
                    let (c, st) = published(i);
                    assert_eq!(h.publish(&c, &st), i);
                }
                done.store(true, Ordering::Release);
            });
            let (mut last, mut reads) = (0, 0u64);
            while !done.load(Ordering::Acquire) || reads == 0 {
                if let Some(p) = h.latest() {
                    let step = p.burr.step;
                    assert!(step >= last, "step {step} after {last}");
                    if step > 0 {
                        let (c, st) = published(step);
                        assert_eq!(p.burr.contact, c, "a mixed contact");
                        assert_eq!(p.shaft.count, st.count, "a mixed count");
                        assert_eq!(p.shaft.points, st.points, "a mixed shaft");
                    }
                    last = step;
                    reads += 1;
                }
            }
            assert_eq!(h.latest().map(|p| p.burr.step), Some(STEPS));
        });
    }
}

mod pen {
    use core::sync::atomic::AtomicBool;
    use std::sync::atomic::{AtomicU32, Ordering};
    use std::thread;
    use tetradrill_core::depth::Penetration;
    use tetradrill_core::servo::*;
    use tetradrill_core::{NodeId, Quat, TetId, Vec3};

    /// A pass whose every value is a function of `i`: `1 + i % 5` pen and `i % 3` object
    /// penetrations.
    fn pass(i: u32) -> (Vec3, Quat, [Penetration; 6], usize, [Penetration; 3], usize) {
        let x = i as f32;
        let p = |k: u32, s: f32| Penetration {
            node: NodeId(i.wrapping_mul(7) + k),
            tet: TetId(i + k),
            depth: s * x + k as f32,
            dir: Vec3::new(x, -x, k as f32),
            layer: k,
        };
        let pen = core::array::from_fn(|k| p(k as u32, 0.5));
        let object = core::array::from_fn(|k| p(k as u32, -0.25));
        let rot = Quat::from_xyzw(x, 1.0, -x, 0.5);
        (
            Vec3::new(x, 2.0 * x, -x),
            rot,
            pen,
            1 + (i as usize) % 5,
            object,
            (i as usize) % 3,
        )
    }

    #[test]
    fn a_published_pass_comes_back_bit_for_bit_with_its_step() {
        let words: [AtomicU32; 160] = [const { AtomicU32::new(7) }; 160];
        assert_eq!(PenHandoff::words_for(6, 3), Some(2 * (11 + 9 * 7)));
        assert!(PenHandoff::new(&words[..147], 6, 3).is_none());
        let h = PenHandoff::new(&words, 6, 3).expect("room");
        let (mut pb, mut ob) = ([Penetration::default(); 6], [Penetration::default(); 3]);
        assert_eq!(h.latest(&mut pb, &mut ob), Some(PenPublished::default()));
        for i in 1..=20 {
            let (at, rot, pen, np, object, no) = pass(i);
            assert_eq!(h.publish(at, rot, &pen[..np], &object[..no]), (i, false));
            let got = h.latest(&mut pb, &mut ob).expect("no publisher running");
            assert_eq!((got.position, got.rotation), (at, rot));
            assert_eq!((got.pen, got.object, got.step), (np, no, i));
            assert_eq!(pb[..np], pen[..np]);
            assert_eq!(ob[..no], object[..no]);
        }
        // More than the capacities: cut, and said so; a short buffer takes what fits.
        let (at, rot, pen, _, object, _) = pass(4);
        let small = PenHandoff::new(&words, 2, 1).expect("room");
        assert_eq!(small.publish(at, rot, &pen, &object), (1, true));
        let got = small
            .latest(&mut pb[..1], &mut ob)
            .expect("no publisher running");
        assert_eq!((got.pen, got.object), (1, 1));
        assert_eq!((pb[0], ob[0]), (pen[0], object[0]));
    }

    /// A publisher and a reader on two threads: every pass read is one the publisher wrote
    /// whole, and passes never go back.
    #[test]
    fn a_reader_on_another_thread_never_sees_a_mixed_pass() {
        let words: [AtomicU32; 148] = [const { AtomicU32::new(0) }; 148];
        let h = PenHandoff::new(&words, 6, 3).expect("room");
        let done = AtomicBool::new(false);
        const STEPS: u32 = 50_000;
        thread::scope(|s| {
            s.spawn(|| {
                for i in 1..=STEPS {
                    let (at, rot, pen, np, object, no) = pass(i);
                    assert_eq!(h.publish(at, rot, &pen[..np], &object[..no]).0, i);
                }
                done.store(true, Ordering::Release);
            });
            let (mut pb, mut ob) = ([Penetration::default(); 6], [Penetration::default(); 3]);
            let (mut last, mut reads) = (0, 0u64);
            while !done.load(Ordering::Acquire) || reads == 0 {
                if let Some(got) = h.latest(&mut pb, &mut ob) {
                    assert!(got.step >= last, "pass {} after {last}", got.step);
                    if got.step > 0 {
                        let (at, rot, pen, np, object, no) = pass(got.step);
                        assert_eq!((got.position, got.rotation), (at, rot), "a mixed pose");
                        assert_eq!((got.pen, got.object), (np, no), "mixed counts");
                        assert_eq!(pb[..np], pen[..np], "mixed pen penetrations");
                        assert_eq!(ob[..no], object[..no], "mixed object penetrations");
                    }
                    last = got.step;
                    reads += 1;
                }
            }
            let got = h.latest(&mut pb, &mut ob).map(|p| p.step);
            assert_eq!(got, Some(STEPS));
        });
    }
}
