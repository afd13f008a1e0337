//! A drill's two rates without a lock: each simulation step ([`super::World::simulate_drill`])
//! publishes its burr's contact and its shaft's passive-point planes together into a
//! [`DrillHandoff`], and a [`DrillServo`] at the higher rate reads the newest pair and renders
//! the drill's force and torque ([`drill_force`], [`drill_torque`]) at its own pose.
//!
//! The hand-off is the two sequence-locked slots of [`ContactHandoff`] (`handoff.rs`), each
//! holding one step's contact, its number, the count of passive points and each point's
//! plane: the servo never renders a burr contact of one step with the shaft of another. The
//! way back (the burr's force pressing it into the material at the next step) is the
//! [`ContactHandoff`]'s ([`ContactHandoff::report_force`], [`ContactHandoff::pressing`]), so a
//! drill uses both: this one for the contact, that one for the pressing force.

use glam::Vec3;

use super::handoff::{Published, SeqPair, WORDS};
use super::passive::{drill_force, drill_torque, DrillState};
use super::{ContactHandoff, ContactState};
use crate::force::{DrillTool, ForceDigest, ForceParams, ToolState, MAX_PASSIVE};

/// Words of one passive point's plane: present, point, normal.
const PLANE_WORDS: usize = 7;

/// Words of a published drill contact: the burr's contact and the step's number (as
/// [`ContactHandoff`]'s), the passive points' count, and [`MAX_PASSIVE`] planes.
const DRILL_WORDS: usize = WORDS + 1 + PLANE_WORDS * MAX_PASSIVE;

/// A drill's contact as its servo receives it: the burr's contact, the shaft's planes and the
/// step's number (0: none yet).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct DrillPublished {
    /// The burr's contact and the step's number.
    pub burr: Published,
    /// The shaft's passive points with their contact planes
    /// ([`crate::force::PassivePoint::plane`]; the proxies and held planes stay with the
    /// simulation, `None`).
    pub shaft: DrillState,
}

/// Word `k` of a shaft's words: its count, then each point's plane (zero past the end).
fn shaft_word(shaft: &DrillState, k: usize) -> u32 {
    let Some(k) = k.checked_sub(1) else {
        return shaft.count.min(MAX_PASSIVE) as u32;
    };
    let Some((p, n)) = shaft.points.get(k / PLANE_WORDS).and_then(|pt| pt.plane) else {
        return 0;
    };
    match k % PLANE_WORDS {
        0 => 1,
        1 => p.x.to_bits(),
        2 => p.y.to_bits(),
        3 => p.z.to_bits(),
        4 => n.x.to_bits(),
        5 => n.y.to_bits(),
        _ => n.z.to_bits(),
    }
}

impl DrillPublished {
    fn from_words(w: &[u32; DRILL_WORDS]) -> Self {
        let mut burr = [0u32; WORDS];
        burr.copy_from_slice(w.get(..WORDS).unwrap_or(&[0; WORDS]));
        let mut shaft = DrillState {
            count: w.get(WORDS).map_or(0, |&c| (c as usize).min(MAX_PASSIVE)),
            ..DrillState::default()
        };
        let planes = w.get(WORDS + 1..).unwrap_or(&[]);
        for (pt, c) in shaft
            .points
            .iter_mut()
            .zip(planes.chunks_exact(PLANE_WORDS))
        {
            let f = |i: usize| f32::from_bits(c.get(i).copied().unwrap_or(0));
            let present = c.first().is_some_and(|&v| v != 0);
            pt.plane = present.then(|| (Vec3::new(f(1), f(2), f(3)), Vec3::new(f(4), f(5), f(6))));
        }
        Self {
            burr: Published::from_words(burr),
            shaft,
        }
    }
}

/// The lock-free hand-off of a drill's contact between its simulation step and its servo
/// (module docs). All zeros is a valid empty hand-off.
#[derive(Debug)]
pub struct DrillHandoff {
    pair: SeqPair<DRILL_WORDS>,
}

impl Default for DrillHandoff {
    fn default() -> Self {
        Self::new()
    }
}

impl DrillHandoff {
    /// An empty hand-off: nothing published.
    pub const fn new() -> Self {
        Self {
            pair: SeqPair::new(),
        }
    }

    /// Publishes a step's burr contact and its shaft's planes (`shaft`'s points in use, as
    /// [`super::World::simulate_drill`] left them); returns the step's number (1 for the
    /// first).
    ///
    /// # Bounded work
    /// Constant: 239 word stores into the slot the servo is not reading, then the switch.
    /// Never waits. One publisher at a time.
    pub fn publish(&self, contact: &ContactState, shaft: &DrillState) -> u32 {
        // The contact's words once; the last of them is the step's number.
        let head = Published {
            contact: *contact,
            step: 0,
        }
        .to_words();
        self.pair.publish(|i, step| match i.checked_sub(WORDS) {
            Some(k) => shaft_word(shaft, k),
            None if i + 1 == WORDS => step,
            None => head.get(i).copied().unwrap_or(0),
        })
    }

    /// The newest published drill contact, or `None` when every one of
    /// [`super::HANDOFF_TRIES`] reads was overtaken by the publisher (only possible when the
    /// two run on different cores). Before the first publish: no contact, no shaft, step 0.
    ///
    /// # Bounded work
    /// At most [`super::HANDOFF_TRIES`] reads of 239 words. Never waits.
    pub fn latest(&self) -> Option<DrillPublished> {
        let mut words = [0u32; DRILL_WORDS];
        self.pair
            .latest(&mut words)
            .then(|| DrillPublished::from_words(&words))
    }
}

/// The servo's own state for a drill fed through a [`DrillHandoff`]: the drill's shape, the
/// contact it renders from, the burr's and the shaft's damping states, the force settings,
/// and the digests of the forces and torques it rendered.
#[derive(Clone, Copy, Debug)]
pub struct DrillServo {
    tool: DrillTool,
    contact: DrillPublished,
    burr: ToolState,
    shaft: ToolState,
    params: ForceParams,
    digest: ForceDigest,
    torque_digest: ForceDigest,
    ticks: u64,
    contact_ticks: u64,
    stale_reads: u64,
}

impl DrillServo {
    /// A servo for the drill `tool` with the force settings `params`, no contact yet.
    pub fn new(tool: DrillTool, params: ForceParams) -> Self {
        Self {
            tool,
            contact: DrillPublished::default(),
            burr: ToolState::default(),
            shaft: ToolState::default(),
            params,
            digest: ForceDigest::new(),
            torque_digest: ForceDigest::new(),
            ticks: 0,
            contact_ticks: 0,
            stale_reads: 0,
        }
    }

    /// One servo tick with the burr at `centre` and the shaft along the unit `axis`: takes
    /// the newest drill contact from `handoff` (or keeps the last one when every read was
    /// overtaken, counted), renders [`drill_force`] and [`drill_torque`] from it, reports the
    /// burr's own force through `press` (what presses the burr at the next step, as a
    /// single-task replay sets it) and adds the force and the torque to their digests.
    /// Returns `(force, torque)`.
    ///
    /// # Bounded work
    /// Constant: [`DrillHandoff::latest`], then O([`MAX_PASSIVE`]) for the force and the
    /// torque. Never waits, allocates or panics; a non-finite `centre` gives zero burr force.
    pub fn tick(
        &mut self,
        handoff: &DrillHandoff,
        press: &ContactHandoff,
        centre: Vec3,
        axis: Vec3,
    ) -> (Vec3, Vec3) {
        match handoff.latest() {
            Some(p) => self.contact = p,
            None => self.stale_reads += 1,
        }
        let (f, on_burr) = drill_force(
            &self.contact.burr.contact,
            &self.tool,
            centre,
            axis,
            &self.contact.shaft,
            &mut self.burr,
            &mut self.shaft,
            &self.params,
        );
        let t = drill_torque(&self.tool, centre, axis, &self.contact.shaft, &self.params);
        press.report_force(on_burr);
        self.digest.push(f);
        self.torque_digest.push(t);
        self.ticks += 1;
        if f != Vec3::ZERO {
            self.contact_ticks += 1;
        }
        (f, t)
    }

    /// Sets the burr's spin for the next ticks ([`ToolState::set_spin`] of the burr's state):
    /// the direction of its angular velocity, kept until set again (zero or not finite:
    /// none). A burr contact with a friction coefficient then pulls the drill sideways
    /// ([`crate::servo::servo_force`], "Sideways pull"); the shaft does not spin against
    /// anything.
    ///
    /// # Bounded work
    /// Constant.
    pub fn set_spin(&mut self, omega: Vec3) {
        self.burr.set_spin(omega);
    }

    /// The drill's shape.
    pub fn tool(&self) -> &DrillTool {
        &self.tool
    }

    /// Digest of every force rendered, as [`ForceDigest`].
    pub fn digest(&self) -> u64 {
        self.digest.value()
    }

    /// Digest of every torque rendered, as [`ForceDigest`].
    pub fn torque_digest(&self) -> u64 {
        self.torque_digest.value()
    }

    /// Ticks run.
    pub fn ticks(&self) -> u64 {
        self.ticks
    }

    /// Ticks with a force other than zero.
    pub fn contact_ticks(&self) -> u64 {
        self.contact_ticks
    }

    /// Ticks that kept the previous contact because the publisher overtook every read.
    pub fn stale_reads(&self) -> u64 {
        self.stale_reads
    }

    /// The step number of the contact in use (0: none yet).
    pub fn step(&self) -> u32 {
        self.contact.burr.step
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use core::sync::atomic::{AtomicBool, Ordering};
    use std::thread;

    use crate::force::PassivePoint;

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
            vibration: crate::servo::VibrationCue::default(),
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
