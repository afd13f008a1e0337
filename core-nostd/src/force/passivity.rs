//! Time-domain passivity: an observer of the energy the servo loop exchanges with the user
//! and a controller that dissipates what the rendered environment generates (Hannaford and
//! Ryu 2002; Ryu, Kwon and Hannaford 2004 for the position-based variant).
//!
//! Sign convention: `f` is the force the environment puts on the tool (what the device
//! renders), `p` the tool's position. Over one servo tick the force is held (zero-order hold),
//! so the work the loop does on the user is exactly `f_k . (p_{k+1} - p_k)`; the energy that
//! flows into the environment is its negative. The observer sums that inflow, `E`.
//!
//! Two ways to count what the environment generated:
//! - with the law's storage function `U` ([`Storage`], the energy its spring holds at the
//!   tool's depth), the strict form: passivity is `U(t) <= E(t)` (an environment holds at most
//!   what it took), so the generated energy is `U - E`; whenever the environment dissipated
//!   (`E > U`), `E` is set to `U`, so a static press gives no credit that would let an
//!   oscillation around it grow. For a penalty wall `K` with damping `b` under the zero-order
//!   hold, a tick that moves the tool `dx` out of the wall generates `(K / 2 - b / T) dx^2`:
//!   more than nothing exactly when `b < K T / 2`, Colgate's bound. A contact that begins
//!   counts what the wall holds at once as taken.
//! - without one (any force law), the classic form: the environment has generated energy when
//!   `E < 0` (it gave back more than it took). A contact that ends (zero force) forgets what
//!   the environment had absorbed (`E = min(E, 0)`): a penalty wall holds nothing once it
//!   pushes no more. By default this form only observes
//!   ([`PassivityParams::act_without_storage`]).
//!
//! The controller (when [`PassivityParams::dissipate`]) adds a variable damper `-alpha v` with
//! `alpha = (G - slack) / (T |v|^2)`, at most [`PassivityParams::max_damping`], whenever the
//! generated energy `G` exceeds [`PassivityParams::slack_j`]: the damper dissipates the excess
//! over the next tick. Below the slack the law's force passes bit for bit.
//!
//! Velocity: the damper's `v` is the central difference over the last two ticks,
//! `(p_k - p_{k-2}) / 2T`: a two-tap filter that halves the encoder quantisation noise of a
//! raw one-tick difference at the price of half a tick of delay. The energy itself needs no
//! velocity: it is the exact work of the held force over each tick's displacement.
//!
//! A law whose spring is no storage function because the environment gives way by design (a
//! drill removing material dissipates what the tool pushes into it) is fed through
//! [`PassivityObserver::step_removing`]: the classic form counts and acts (damps), and the trip
//! still measures the energy past the force limit.
//!
//! The trip: when the energy a law stores past its force limit ([`Storage::past_limit_j`],
//! counted above the least of it since the contact began, so a tool that starts deep inside
//! trips nothing until it is driven deeper) exceeds [`PassivityParams::trip_j`], the observer
//! latches tripped and its output is zero until the caller [`recovers`](PassivityObserver::recover)
//! it. A sign or mirror fault at the device
//! is invisible to any observer at this port (the measured signals are those of a user
//! pushing harder), but it drives the tool ever deeper into the wall, past the depth where the
//! law's force reaches its limit: a passive wall holds no more than `F^2 / 2K` there, and the
//! energy beyond it is what the faulty motors put into the user.
//!
//! ```
//! use tetradrill_core::force::{penalty_storage, PassivityObserver};
//! use tetradrill_core::Vec3;
//!
//! // A wall at z = 0 of 200 N/m clamped at 8 N (reached 4 cm deep), and a tool driven into it
//! // 1 mm a tick, as a reversed motor would drive it.
//! let mut observer = PassivityObserver::default();
//! let mut out = Vec3::ZERO;
//! for tick in 0..60 {
//!     let depth = 0.001 * tick as f32;
//!     let force = Vec3::Z * (200.0 * depth).min(8.0);
//!     let stored = penalty_storage(depth, 200.0, 8.0);
//!     out = observer.step(Vec3::new(0.0, 0.0, -depth), force, Some(stored));
//! }
//! // Driven about 2 cm past the depth of the force limit, the tool has stored some 8 N x 2 cm
//! // = 0.16 J past it, over the 50 mJ trip: the observer tripped and its output is zero.
//! assert!(observer.tripped() && observer.trips() == 1);
//! assert_eq!(out, Vec3::ZERO);
//! ```

use glam::Vec3;

use super::response::clamp_force;

/// Settings of a [`PassivityObserver`]. SI units: the observer is fed metres and newtons.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct PassivityParams {
    /// Servo period, seconds.
    pub dt: f32,
    /// Largest damping the controller adds, N s/m (the device's own damping limit).
    pub max_damping: f32,
    /// Largest force magnitude the output may have, newtons.
    pub max_force: f32,
    /// Generated energy left alone, joules: below it the law's force passes unchanged.
    pub slack_j: f32,
    /// Energy stored past the force limit (for a law without a storage function: generated
    /// energy) that trips the observer, joules.
    pub trip_j: f32,
    /// Run the controller (the damper). `false` observes only (the trip stays armed).
    pub dissipate: bool,
    /// Ticks after a [`PassivityObserver::restart`] during which the energy past the force
    /// limit is not counted: a device's safety filter ramps the force up again after a cut
    /// (500 ticks on the simulated device and the Falcon), and meanwhile the hand can push the
    /// tool deeper than the loop's force would let it.
    pub regrip_ticks: u32,
    /// Whether the controller and the trip also act for a law without a storage function
    /// (the classic form). Off by default: there the observer only observes and reports, since
    /// the classic form's credit and the contact planes a drill moves make its generated
    /// energy a poor guide to act on (and the forces of such laws stay theirs, bit for bit).
    pub act_without_storage: bool,
}

/// Default [`PassivityParams::slack_j`]: 0.1 mJ. A penalty wall at the default stiffness
/// (200 N/m, damping 0.5 N s/m, 1 kHz) generates nothing (Colgate's bound holds), and the
/// contact plane's updates and switches add a few microjoules at most; 0.1 mJ is the energy of
/// a 0.1 kg stylus at 4.5 cm/s.
pub(crate) const DEFAULT_SLACK_J: f32 = 1e-4;

/// Default [`PassivityParams::trip_j`]: 50 mJ. A healthy press at the force limit stores at
/// most `F^2 / 2K` (0.16 J for 8 N at 200 N/m) and nothing past it; 50 mJ past the limit is
/// the tool 6 mm deeper than where an 8 N limit is reached, which a reversed force or a
/// mirrored axis reaches within a few hundred milliseconds of contact at the default
/// stiffness (and within a few ticks at ten times it), while the controller keeps a healthy
/// stiff wall's generated energy near the 0.1 mJ slack, 500 times lower.
pub(crate) const DEFAULT_TRIP_J: f32 = 0.05;

impl Default for PassivityParams {
    /// 1 kHz, 20 N s/m (the simulated device's and the Falcon's damping limit), no force
    /// limit, `DEFAULT_SLACK_J`, `DEFAULT_TRIP_J`, controller on, 500 ticks to regrip, the
    /// classic form observing only.
    fn default() -> Self {
        Self {
            dt: 1e-3,
            max_damping: 20.0,
            max_force: f32::INFINITY,
            slack_j: DEFAULT_SLACK_J,
            trip_j: DEFAULT_TRIP_J,
            dissipate: true,
            regrip_ticks: 500,
            act_without_storage: false,
        }
    }
}

/// What a force law stores at the tool's current pose (joules when the observer is fed
/// metres).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct Storage {
    /// Energy the environment's spring holds (its storage function `U`).
    pub stored_j: f32,
    /// The part of it stored past the force limit: the work the tool did against a clamped
    /// force (zero while the force is below the limit).
    pub past_limit_j: f32,
}

impl Storage {
    /// Both energies times `k` (e.g. `1 / scale` from newton mesh units to joules).
    pub fn scaled(self, k: f32) -> Self {
        Self {
            stored_j: self.stored_j * k,
            past_limit_j: self.past_limit_j * k,
        }
    }
}

/// The storage of a penalty spring `stiffness` at `depth` whose force is clamped at
/// `max_force`: `K d^2 / 2` up to the depth `F / K` where the limit is reached, then `F` per
/// unit of depth beyond it (the part beyond is [`Storage::past_limit_j`]). Zero out of contact
/// (`depth <= 0`) or for a non-finite or non-positive parameter.
///
/// # Bounded work
/// Constant.
pub fn penalty_storage(depth: f32, stiffness: f32, max_force: f32) -> Storage {
    let ok = depth.is_finite() && stiffness.is_finite() && stiffness > 0.0 && max_force > 0.0;
    if !ok || depth <= 0.0 {
        return Storage::default();
    }
    let limit_depth = max_force / stiffness;
    if depth <= limit_depth {
        return Storage {
            stored_j: 0.5 * stiffness * depth * depth,
            past_limit_j: 0.0,
        };
    }
    let past = max_force * (depth - limit_depth);
    Storage {
        stored_j: 0.5 * max_force * limit_depth + past,
        past_limit_j: past,
    }
}

/// The time-domain passivity observer and controller of one servo loop (module docs).
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct PassivityObserver {
    params: PassivityParams,
    /// The last two positions (`[p_{k-1}, p_{k-2}]`) and how many of them are known.
    history: [Vec3; 2],
    known: u8,
    /// The force output last tick (held over the tick that just ended).
    held: Vec3,
    /// The controller's part of `held`.
    held_damper: Vec3,
    /// Net energy into the environment, `E`.
    energy: f32,
    generated: f32,
    generated_max: f32,
    past_limit_max: f32,
    /// The law stored energy last tick (a contact was going on).
    holding: bool,
    /// The least energy past the force limit during this contact.
    past_base: f32,
    /// Ticks left before the energy past the limit counts again after a restart.
    regrip: u32,
    dissipated: f64,
    tripped: bool,
    trips: u32,
}

impl Default for PassivityObserver {
    fn default() -> Self {
        Self::new(PassivityParams::default())
    }
}

impl PassivityObserver {
    /// A fresh observer (no energy exchanged yet, not tripped).
    pub(crate) const fn new(params: PassivityParams) -> Self {
        Self {
            params,
            history: [Vec3::ZERO; 2],
            known: 0,
            held: Vec3::ZERO,
            held_damper: Vec3::ZERO,
            energy: 0.0,
            generated: 0.0,
            generated_max: 0.0,
            past_limit_max: 0.0,
            holding: false,
            past_base: 0.0,
            regrip: 0,
            dissipated: 0.0,
            tripped: false,
            trips: 0,
        }
    }

    /// Replaces the settings (the energies and the trip stay).
    pub fn set_params(&mut self, params: PassivityParams) {
        self.params = params;
    }

    /// One servo tick: the tool at `position` (metres), the law's force `force` (newtons) and,
    /// when the law knows it, its `storage` at that position (joules). Returns the force to
    /// write: `force` unchanged while the generated energy is within the slack, `force` plus
    /// the controller's damper otherwise (clamped to [`PassivityParams::max_force`]), zero
    /// once tripped. A non-finite position or force restarts the velocity history and passes
    /// the force through (the laws give such a pose zero force); nothing is counted for it.
    ///
    /// # Bounded work
    /// Constant: a few dozen flops, no loop, no allocation, no panic.
    pub fn step(&mut self, position: Vec3, force: Vec3, storage: Option<Storage>) -> Vec3 {
        self.step_as(position, force, storage, false)
    }

    /// [`step`](Self::step) for an environment that gives way by design (a drill removing
    /// material): its spring is no storage function, so the classic form counts the generated
    /// energy and the controller acts on it (whatever
    /// [`PassivityParams::act_without_storage`] says), while the trip still measures the energy
    /// `storage` puts past the force limit since the contact began.
    ///
    /// # Bounded work
    /// Constant, as [`step`](Self::step).
    pub fn step_removing(&mut self, position: Vec3, force: Vec3, storage: Option<Storage>) -> Vec3 {
        self.step_as(position, force, storage, true)
    }

    fn step_as(
        &mut self,
        position: Vec3,
        force: Vec3,
        storage: Option<Storage>,
        removing: bool,
    ) -> Vec3 {
        if self.tripped {
            // Latched: nothing is rendered, so nothing more is counted.
            return Vec3::ZERO;
        }
        if !(position.is_finite() && force.is_finite()) {
            self.known = 0;
            self.held = Vec3::ZERO;
            self.held_damper = Vec3::ZERO;
            return force;
        }
        let dt = self.params.dt;
        let mut velocity = Vec3::ZERO;
        if self.known >= 1 {
            let dp = position - self.history[0];
            // The held force's work on the user, and the damper's share of it.
            self.energy -= self.held.dot(dp);
            self.dissipated += f64::from(-self.held_damper.dot(dp));
            velocity = if self.known >= 2 {
                (position - self.history[1]) / (2.0 * dt)
            } else {
                dp / dt
            };
        }
        let begins = !self.holding && storage.is_some_and(|s| s.stored_j > 0.0);
        if begins {
            if let Some(s) = storage {
                // The energy past the limit is measured from where the contact began.
                self.past_base = s.past_limit_j;
            }
        }
        let strict = storage.filter(|_| !removing);
        let generated = match strict {
            Some(s) if s.stored_j.is_finite() => {
                if begins {
                    // A contact begins (or the tool is inside at the start): what the wall
                    // holds at once is counted as taken, a deficit from before is kept, and
                    // the energy past the limit is measured from here.
                    self.energy = s.stored_j + self.energy.min(0.0);
                }
                if self.energy > s.stored_j {
                    // The environment dissipated the difference: no credit for later.
                    self.energy = s.stored_j;
                }
                s.stored_j - self.energy
            }
            _ => {
                if force == Vec3::ZERO {
                    self.energy = self.energy.min(0.0);
                }
                (-self.energy).max(0.0)
            }
        };
        self.holding = storage.is_some_and(|s| s.stored_j > 0.0);
        self.generated = generated;
        self.generated_max = self.generated_max.max(generated);
        // The trip: with a storage function, the energy past the force limit (the storage
        // form's generated energy also counts a contact plane that moves under a still tool,
        // which the damper takes but must not trip); without one, the generated energy.
        let acting = storage.is_some() || removing || self.params.act_without_storage;
        let measure = match storage {
            Some(s) if s.past_limit_j.is_finite() => {
                if self.regrip > 0 {
                    self.past_base = s.past_limit_j;
                }
                self.past_base = self.past_base.min(s.past_limit_j);
                s.past_limit_j - self.past_base
            }
            Some(_) => 0.0,
            None if removing => 0.0,
            None => generated,
        };
        self.past_limit_max = self.past_limit_max.max(measure);
        if acting && !self.tripped && measure > self.params.trip_j {
            self.tripped = true;
            self.trips = self.trips.saturating_add(1);
        }
        self.regrip = self.regrip.saturating_sub(1);
        self.history = [position, self.history[0]];
        self.known = (self.known + 1).min(2);
        let excess = generated - self.params.slack_j;
        let v2 = velocity.length_squared();
        let out = if self.tripped {
            Vec3::ZERO
        } else if acting && self.params.dissipate && excess > 0.0 && v2 > 0.0 && dt > 0.0 {
            let alpha = (excess / (dt * v2)).min(self.params.max_damping);
            let out = clamp_force(force - alpha * velocity, self.params.max_force);
            if out.is_finite() {
                out
            } else {
                force
            }
        } else {
            force
        };
        self.held = out;
        self.held_damper = out - force;
        if self.tripped {
            self.held_damper = Vec3::ZERO;
        }
        out
    }

    /// Forgets the contact and the velocity history (not the energies' maxima, the dissipated
    /// energy or the trip): the next tick starts afresh, and the energy past the force limit
    /// counts again only after [`PassivityParams::regrip_ticks`]. For a caller whose force was
    /// off for a while (a watchdog cut): the motion then, and while the device ramps the force
    /// up again, is not the loop's doing.
    ///
    /// # Bounded work
    /// Constant.
    pub fn restart(&mut self) {
        self.known = 0;
        self.held = Vec3::ZERO;
        self.held_damper = Vec3::ZERO;
        self.holding = false;
        self.energy = self.energy.min(0.0);
        self.regrip = self.params.regrip_ticks;
    }

    /// Clears a trip: the output is the law's force again (the caller ramps it back in), and
    /// the observer starts afresh as after a [`restart`](Self::restart) (the energy past the
    /// force limit counts again after [`PassivityParams::regrip_ticks`]). For a caller that
    /// saw the tool out of contact long enough after a trip; [`trips`](Self::trips) keeps
    /// counting.
    ///
    /// # Bounded work
    /// Constant.
    pub fn recover(&mut self) {
        self.tripped = false;
        self.past_base = 0.0;
        self.restart();
    }

    /// Trips the observer from a check outside it (the servo's force-sign probe), latched and
    /// counted as its own trips are (nothing when already tripped). Constant work.
    pub fn trip(&mut self) {
        self.trips = self.trips.saturating_add(u32::from(!self.tripped));
        self.tripped = true;
    }

    /// Whether the observer has tripped (latched: its output is zero until
    /// [`recover`](Self::recover)).
    pub fn tripped(&self) -> bool {
        self.tripped
    }

    /// How often it tripped (each trip latches until a [`recover`](Self::recover)).
    pub fn trips(&self) -> u32 {
        self.trips
    }

    /// Net energy into the environment so far, `E`, joules.
    #[cfg(test)]
    pub(crate) fn energy_j(&self) -> f32 {
        self.energy
    }

    /// The largest generated energy seen up to the trip, joules.
    pub fn generated_j_max(&self) -> f32 {
        self.generated_max
    }

    /// The largest value of the trip's measure seen up to the trip, joules: the energy stored
    /// past the force limit (since the contact began) for a law with a storage function, the
    /// generated energy for one without.
    pub fn trip_measure_j_max(&self) -> f32 {
        self.past_limit_max
    }

    /// Energy the controller's damper dissipated so far (its force times the displacement
    /// over each tick it was held), joules.
    pub fn dissipated_j(&self) -> f64 {
        self.dissipated
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: f64 = 1e-3;

    /// A free mass `m` (f64, exact under a force held over each tick) flying at `v0` along -z
    /// into a penalty wall at z = 0 (stiffness `k`, damping `b` from the last two samples,
    /// as the servo's law does), sampled and pushed through `obs` each tick. Returns the
    /// mass's kinetic energy before and after, and the observer.
    fn bounce(
        k: f64,
        b: f64,
        v0: f64,
        with_storage: bool,
        params: PassivityParams,
        ticks: usize,
    ) -> (f64, f64, PassivityObserver) {
        let m = 0.1;
        let (mut z, mut v) = (0.002f64, -v0);
        let mut prev = z;
        let mut obs = PassivityObserver::new(params);
        for _ in 0..ticks {
            let d = -z;
            let f = if d > 0.0 {
                k * d - b * (z - prev) / T
            } else {
                0.0
            };
            prev = z;
            let storage = with_storage.then(|| penalty_storage(d as f32, k as f32, f32::INFINITY));
            let out = obs.step(
                Vec3::new(0.0, 0.0, z as f32),
                Vec3::new(0.0, 0.0, f as f32),
                storage,
            );
            // Exact motion under the held force.
            let a = f64::from(out.z) / m;
            z += v * T + 0.5 * a * T * T;
            v += a * T;
        }
        (0.5 * m * v0 * v0, 0.5 * m * v * v, obs)
    }

    fn observe_only() -> PassivityParams {
        PassivityParams {
            dissipate: false,
            trip_j: f32::INFINITY,
            ..acting()
        }
    }

    /// The defaults, the classic form acting too.
    fn acting() -> PassivityParams {
        PassivityParams {
            act_without_storage: true,
            ..PassivityParams::default()
        }
    }

    #[test]
    fn the_observed_energy_is_the_kinetic_energy_the_wall_took_or_gave() {
        // Without damping the zero-order hold makes the wall give back more than it took.
        let (ke0, ke1, obs) = bounce(2000.0, 0.0, 0.1, false, observe_only(), 200);
        assert!(
            ke1 > ke0 * 1.01,
            "the ZOH wall generated energy: {ke0} -> {ke1}"
        );
        // The wall is the only force: the energy into it is the kinetic energy the mass lost.
        let want = ke0 - ke1;
        let got = f64::from(obs.energy_j());
        assert!((got - want).abs() < 1e-3 * ke0, "E {got} want {want}");
        let gen = f64::from(obs.generated_j_max());
        assert!((gen - (ke1 - ke0)).abs() < 1e-3 * ke0, "generated {gen}");
        assert_eq!(obs.dissipated_j(), 0.0);
        assert!(!obs.tripped());
    }

    #[test]
    fn the_controller_makes_the_bounce_passive() {
        for with_storage in [false, true] {
            let (ke0, ke1, obs) = bounce(2000.0, 0.0, 0.1, with_storage, acting(), 300);
            // Within the slack and f32 rounding, the mass leaves with no more than it brought.
            let slack = f64::from(DEFAULT_SLACK_J);
            assert!(
                ke1 <= ke0 + slack + 1e-6,
                "{ke0} -> {ke1} (storage {with_storage})"
            );
            assert!(obs.dissipated_j() > 0.0);
            // What the damper took is what the wall made beyond the slack.
            let (_, free, _) = bounce(2000.0, 0.0, 0.1, with_storage, observe_only(), 300);
            let made = free - ke0;
            assert!(
                obs.dissipated_j() > 0.5 * (made - slack),
                "{} {made}",
                obs.dissipated_j()
            );
        }
    }

    #[test]
    fn without_a_storage_function_it_only_observes_by_default() {
        let (ke0, ke1, obs) = bounce(2000.0, 0.0, 0.1, false, PassivityParams::default(), 300);
        assert!(ke1 > ke0);
        assert!(obs.generated_j_max() > 0.0);
        assert_eq!(obs.dissipated_j(), 0.0);
        // Far past the bound, still no trip: the classic form does not act.
        let mut obs = PassivityObserver::new(PassivityParams {
            trip_j: 1e-9,
            ..PassivityParams::default()
        });
        for i in 0..10 {
            let p = Vec3::new(0.0, 0.0, i as f32 * 1e-3);
            assert_eq!(obs.step(p, Vec3::Z * 8.0, None), Vec3::Z * 8.0);
        }
        assert!(obs.generated_j_max() > 1e-9);
        assert!(!obs.tripped());
    }

    #[test]
    fn colgates_bound_says_when_the_wall_generates() {
        // K T / 2 = 1 N s/m. Damping above the bound: the bounce loses energy and what the
        // observer counts as generated (the ticks where the mass enters and leaves the wall
        // within a tick) stays far below the slack, so the force passes untouched. Below
        // it, the generated energy is tens of times larger.
        let k = 2000.0;
        let (ke0, ke1, obs) = bounce(k, 1.5, 0.1, true, PassivityParams::default(), 300);
        assert!(ke1 < ke0);
        let above = obs.generated_j_max();
        assert!(above < 0.01 * DEFAULT_SLACK_J, "{above}");
        assert_eq!(obs.dissipated_j(), 0.0);
        for b in [0.5, 0.0] {
            let (_, ke1, obs) = bounce(k, b, 0.1, true, observe_only(), 300);
            let below = obs.generated_j_max();
            assert!(
                below > 20.0 * above,
                "b {b}: {below} vs {above}, kinetic {ke0} -> {ke1}"
            );
        }
    }

    #[test]
    fn within_the_slack_the_force_passes_bit_for_bit() {
        let mut obs = PassivityObserver::default();
        for i in 0..100 {
            let p = Vec3::new(0.0, 0.0, -1e-4 * i as f32);
            let f = Vec3::new(0.1, -0.0, 200.0 * 1e-4 * i as f32);
            let s = penalty_storage(-p.z, 200.0, 8.0);
            let out = obs.step(p, f, Some(s));
            assert_eq!(
                out.to_array().map(f32::to_bits),
                f.to_array().map(f32::to_bits)
            );
        }
    }

    #[test]
    fn an_outside_trip_latches_counts_once_and_recovers() {
        let (mut obs, f) = (PassivityObserver::default(), Vec3::new(0.0, 0.0, 2.0));
        assert_eq!(obs.step(Vec3::ZERO, f, None), f);
        obs.trip();
        obs.trip();
        assert!(obs.tripped() && obs.trips() == 1);
        assert_eq!(obs.step(Vec3::ZERO, f, None), Vec3::ZERO);
        obs.recover();
        assert!(!obs.tripped() && obs.trips() == 1);
        assert_eq!(obs.step(Vec3::ZERO, f, None), f);
    }

    #[test]
    fn energy_past_the_force_limit_trips_and_the_trip_is_latched() {
        let params = PassivityParams {
            max_force: 8.0,
            ..PassivityParams::default()
        };
        let mut obs = PassivityObserver::new(params);
        // 200 N/m clamped at 8 N: the limit is reached at 4 cm; 50 mJ more is 6.25 mm deeper.
        let limit = 0.04f32;
        let mut first = None;
        for i in 0..200 {
            let d = 0.035 + 1e-4 * i as f32;
            let f = Vec3::Z * (200.0 * d).min(8.0);
            let out = obs.step(
                Vec3::new(0.0, 0.0, -d),
                f,
                Some(penalty_storage(d, 200.0, 8.0)),
            );
            if obs.tripped() {
                first.get_or_insert(d);
                assert_eq!(out, Vec3::ZERO);
            } else {
                assert_eq!(out, f);
            }
        }
        let at = first.expect("tripped");
        let want = limit + DEFAULT_TRIP_J / 8.0;
        assert!((at - want).abs() < 2e-4, "tripped at {at}, want {want}");
        assert_eq!(obs.trips(), 1);
        // Latched: back out of contact, still zero.
        assert_eq!(obs.step(Vec3::Z, Vec3::Z, None), Vec3::ZERO);
        assert_eq!(obs.trips(), 1);
    }

    #[test]
    fn a_tool_that_starts_deep_trips_only_when_driven_deeper() {
        let mut obs = PassivityObserver::default();
        // Inside from the first tick, 2 cm past the 8 N limit (0.16 J past it): held still.
        let at = |d: f32| {
            (
                Vec3::new(0.0, 0.0, -d),
                Vec3::Z * 8.0,
                Some(penalty_storage(d, 200.0, 8.0)),
            )
        };
        for _ in 0..100 {
            let (p, f, s) = at(0.06);
            assert_eq!(obs.step(p, f, s), f);
        }
        assert!(!obs.tripped());
        // Pushed out 1 cm, then driven 7 mm deeper than the start: 8 N x 1.7 cm past the least.
        let mut d = 0.06;
        while d > 0.05 {
            d -= 1e-4;
            let (p, f, s) = at(d);
            obs.step(p, f, s);
        }
        assert!(!obs.tripped());
        while d < 0.067 && !obs.tripped() {
            d += 1e-4;
            let (p, f, s) = at(d);
            obs.step(p, f, s);
        }
        assert!(obs.tripped());
        assert!((d - (0.05 + DEFAULT_TRIP_J / 8.0)).abs() < 2e-4, "{d}");
    }

    #[test]
    fn penalty_storage_is_the_integral_of_the_clamped_force() {
        // Trapezoidal f64 integral of min(K x, F) from 0 to d.
        for d in [0.0f64, 0.01, 0.039, 0.04, 0.05, 0.2] {
            let n = 20_000;
            let mut sum = 0.0;
            for i in 0..n {
                let x0 = d * i as f64 / n as f64;
                let x1 = d * (i + 1) as f64 / n as f64;
                sum += 0.5 * ((200.0 * x0).min(8.0) + (200.0 * x1).min(8.0)) * (x1 - x0);
            }
            let s = penalty_storage(d as f32, 200.0, 8.0);
            assert!(
                (f64::from(s.stored_j) - sum).abs() < 1e-6,
                "{d}: {s:?} {sum}"
            );
            let past = (8.0 * (d - 0.04)).max(0.0);
            assert!((f64::from(s.past_limit_j) - past).abs() < 1e-6);
        }
        assert_eq!(penalty_storage(f32::NAN, 200.0, 8.0), Storage::default());
        assert_eq!(penalty_storage(0.1, 0.0, 8.0), Storage::default());
    }

    #[test]
    fn a_recovered_observer_passes_the_force_again_and_counts_a_second_trip() {
        let mut obs = PassivityObserver::default();
        // Driven 1 mm a tick into a 200 N/m wall clamped at 8 N: trips past 4 cm + 6.25 mm.
        let drive = |obs: &mut PassivityObserver| {
            for i in 0..80 {
                let d = 1e-3 * i as f32;
                let f = Vec3::Z * (200.0 * d).min(8.0);
                obs.step(
                    Vec3::new(0.0, 0.0, -d),
                    f,
                    Some(penalty_storage(d, 200.0, 8.0)),
                );
            }
        };
        drive(&mut obs);
        assert!(obs.tripped() && obs.trips() == 1);
        assert_eq!(obs.step(Vec3::Z, Vec3::ZERO, None), Vec3::ZERO);
        obs.recover();
        assert!(!obs.tripped());
        // Out of contact, then a gentle touch: the law's force passes bit for bit.
        assert_eq!(obs.step(Vec3::Z, Vec3::ZERO, None), Vec3::ZERO);
        let f = Vec3::new(0.0, 0.0, 0.2);
        let out = obs.step(
            Vec3::new(0.0, 0.0, -1e-3),
            f,
            Some(penalty_storage(1e-3, 200.0, 8.0)),
        );
        assert_eq!(out, f);
        // Once regripped, the same drive trips it again.
        for _ in 0..600 {
            obs.step(Vec3::Z, Vec3::ZERO, Some(Storage::default()));
        }
        drive(&mut obs);
        assert!(obs.tripped());
        assert_eq!(obs.trips(), 2);
    }

    #[test]
    fn removing_material_the_classic_form_acts_and_the_trip_measures_past_the_limit() {
        // The bounce with its storage fed as a removing environment: the damper acts on the
        // classic form's generated energy, as it does not by default without a storage.
        let mut obs = PassivityObserver::default();
        let (m, k) = (0.1f64, 2000.0f64);
        let (mut z, mut v) = (0.002f64, -0.1f64);
        let ke0 = 0.5 * m * v * v;
        for _ in 0..300 {
            let d = -z;
            let f = if d > 0.0 { k * d } else { 0.0 };
            let s = penalty_storage(d as f32, k as f32, f32::INFINITY);
            let out = obs.step_removing(
                Vec3::new(0.0, 0.0, z as f32),
                Vec3::new(0.0, 0.0, f as f32),
                Some(s),
            );
            let a = f64::from(out.z) / m;
            z += v * T + 0.5 * a * T * T;
            v += a * T;
        }
        assert!(obs.dissipated_j() > 0.0);
        assert!(0.5 * m * v * v <= ke0 + f64::from(DEFAULT_SLACK_J) + 1e-6);
        assert!(!obs.tripped());
        // Driven past the 8 N limit, the energy past it trips the removing form too.
        let mut obs = PassivityObserver::default();
        for i in 0..80 {
            let d = 1e-3 * i as f32;
            let f = Vec3::Z * (200.0 * d).min(8.0);
            obs.step_removing(
                Vec3::new(0.0, 0.0, -d),
                f,
                Some(penalty_storage(d, 200.0, 8.0)),
            );
        }
        assert!(obs.tripped());
        let want = DEFAULT_TRIP_J;
        assert!(obs.trip_measure_j_max() > want && obs.trip_measure_j_max() < want + 0.01);
    }

    #[test]
    fn a_non_finite_sample_counts_nothing_and_never_panics() {
        let mut obs = PassivityObserver::default();
        obs.step(Vec3::ZERO, Vec3::Z, None);
        let out = obs.step(Vec3::NAN, Vec3::Z, None);
        assert_eq!(out, Vec3::Z);
        assert_eq!(obs.energy_j(), 0.0);
        obs.step(Vec3::new(0.0, 0.0, 1.0), Vec3::Z, None);
        assert_eq!(obs.energy_j(), 0.0, "the gap is not counted");
        assert!(!obs.tripped());
    }
}
