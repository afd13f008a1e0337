//! A tet-mesh tool (the pen) in the real-time pipeline: the contact task runs the core's
//! [`tetradrill_core::force::pen_pass`] (collisions and consistent depths; on one thread or,
//! `--pass-threads 2`, two: [`crate::pen_pair`]) as often as it can at the newest tool pose
//! and publishes what it found; the servo's [`PenLaw`] carries that contact to the tool's pose
//! of every tick with [`pen_servo_force`] (the split of Turini et al. 2006, section 3.3, applied to
//! the pen).
//!
//! The hand-off is a triple buffer of [`HeldPen`]: three copies allocated before the run, each
//! with room for every penetration a pass can write, so publishing is a copy into the back
//! copy and a swap, and the servo's read is a few atomic operations; neither side waits.

use std::sync::atomic::Ordering;

use tetradrill_core::depth::Penetration;
use tetradrill_core::force::{
    display_offset, pen_servo_force, HeldContact, PenOptions, PenScene, PenState, ServoScratch,
};
use tetradrill_core::servo::World;
use tetradrill_core::{Quat, Vec3};

use crate::pen_pair::{PassRunner, WorkerGone};
use crate::platform::now_ns;
use crate::tasks::{ForceLaw, ServoCounters, Shared, SimStatus, ToolSample};
use crate::viewer::handoff::ToolView;
use crate::viewer::publish::SimViewer;

/// One contact pass, as the contact task hands it to the servo.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct HeldPen {
    /// This pass's number in the contact task (1, 2, ...; 0: none yet, no contact).
    pub pass: u64,
    /// Servo tick of the tool sample the pass was run at.
    pub tick: u64,
    /// The pose the pass was run at.
    pub position: Vec3,
    /// The rotation the pass was run at.
    pub rotation: Quat,
    /// Pen nodes in the object: storage, the first `counts.0` are this pass's.
    pub pen: Vec<Penetration>,
    /// Object nodes in the pen: storage, the first `counts.1` are this pass's.
    pub object: Vec<Penetration>,
    /// Penetrations of this pass (pen nodes, object nodes).
    pub counts: (usize, usize),
}

impl HeldPen {
    /// No contact yet, with room for `pen` and `object` penetrations.
    pub fn with_room(pen: usize, object: usize) -> Self {
        Self {
            pen: vec![Penetration::default(); pen],
            object: vec![Penetration::default(); object],
            ..Self::default()
        }
    }

    /// The contact for [`pen_servo_force`].
    pub fn contact(&self) -> HeldContact<'_> {
        HeldContact {
            position: self.position,
            rotation: self.rotation,
            pen: self.pen.get(..self.counts.0).unwrap_or(&[]),
            object: self.object.get(..self.counts.1).unwrap_or(&[]),
        }
    }

    /// Copies pass number `pass`, run at `sample`, in (as many penetrations as there is room
    /// for; returns `false` when some did not fit, which [`HeldPen::with_room`] sized from the
    /// pass buffers never does). No allocation.
    pub fn set(
        &mut self,
        pass: u64,
        sample: &ToolSample,
        pen: &[Penetration],
        object: &[Penetration],
    ) -> bool {
        let np = pen.len().min(self.pen.len());
        let no = object.len().min(self.object.len());
        self.pen[..np].copy_from_slice(&pen[..np]);
        self.object[..no].copy_from_slice(&object[..no]);
        self.pass = pass;
        self.tick = sample.tick;
        self.position = sample.position;
        self.rotation = sample.rotation;
        self.counts = (np, no);
        np == pen.len() && no == object.len()
    }
}

/// The servo's end of the pen hand-off.
pub type HeldOut = triple_buffer::Output<HeldPen>;
/// The contact task's end of the pen hand-off.
pub type HeldIn = triple_buffer::Input<HeldPen>;

/// A pen hand-off with room for `pen` and `object` penetrations in each of its three copies.
pub fn held_handoff(pen: usize, object: usize) -> (HeldIn, HeldOut) {
    triple_buffer::TripleBuffer::new(&HeldPen::with_room(pen, object)).split()
}

/// What the servo's pen law counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PenServoStats {
    /// Ticks that had a pass to carry.
    pub carried_ticks: u64,
    /// Sum over those ticks of the pass's age (servo ticks since the sample it was run at).
    pub age_sum: u64,
    /// The oldest pass carried, servo ticks.
    pub age_max: u64,
    /// Ticks whose force was clamped.
    pub clamped_ticks: u64,
    /// Ticks whose scratch could not carry every held penetration.
    pub short_ticks: u64,
    /// Ticks whose pose was not finite (zero force).
    pub nonfinite_ticks: u64,
}

/// The pen's force law on the servo thread: the latest published pass carried to this tick's
/// pose ([`pen_servo_force`]): bounded by the penetrations held (at most the pass buffers'
/// size), no allocation, no lock, no wait.
pub struct PenLaw<'a, 's, 'm, 'p> {
    scene: &'a PenScene<'s, 'm, 'p>,
    counters: &'a ServoCounters,
    held: HeldOut,
    now_pen: Vec<Penetration>,
    now_object: Vec<Penetration>,
    opts: PenOptions,
    state: PenState,
    /// What the law counted.
    pub stats: PenServoStats,
}

impl std::fmt::Debug for PenLaw<'_, '_, '_, '_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PenLaw")
            .field("opts", &self.opts)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl<'a, 's, 'm, 'p> PenLaw<'a, 's, 'm, 'p> {
    /// The law over `scene` reading `held`, with scratch for as many penetrations as the
    /// hand-off holds; the viewer's stiffness, when it set one, comes through `counters`.
    pub fn new(
        scene: &'a PenScene<'s, 'm, 'p>,
        counters: &'a ServoCounters,
        held: HeldOut,
        opts: PenOptions,
    ) -> Self {
        let (np, no) = {
            let h = held.output_buffer();
            (h.pen.len(), h.object.len())
        };
        Self {
            scene,
            counters,
            held,
            now_pen: vec![Penetration::default(); np],
            now_object: vec![Penetration::default(); no],
            opts,
            state: PenState::default(),
            stats: PenServoStats::default(),
        }
    }
}

impl ForceLaw for PenLaw<'_, '_, '_, '_> {
    fn force(&mut self, tick: u64, position: Vec3, rotation: Quat) -> Vec3 {
        if !(position.is_finite() && rotation.is_finite()) {
            self.stats.nonfinite_ticks += 1;
            return Vec3::ZERO;
        }
        let held = self.held.read();
        let contact = if held.pass == 0 {
            HeldContact::NONE
        } else {
            let age = tick.saturating_sub(held.tick);
            self.stats.carried_ticks += 1;
            self.stats.age_sum += age;
            self.stats.age_max = self.stats.age_max.max(age);
            held.contact()
        };
        let mut now = ServoScratch {
            pen: &mut self.now_pen,
            object: &mut self.now_object,
        };
        // The viewer's stiffness (0: the scenario's).
        let mut opts = self.opts;
        let k = self.counters.stiffness_bits.load(Ordering::Relaxed);
        if k != 0 {
            opts.params.stiffness = f32::from_bits(k);
        }
        let s = pen_servo_force(
            self.scene,
            &contact,
            &mut now,
            position,
            rotation,
            &opts,
            &mut self.state,
        );
        self.stats.clamped_ticks += u64::from(s.force.clamped);
        self.stats.short_ticks += u64::from(s.short);
        s.force.force
    }
}

/// What the contact task counted.
#[derive(Debug, Default)]
pub struct PenTaskReport {
    /// Passes run.
    pub passes: u64,
    /// The passes' compute times (fixed buckets, allocated when the report is made: the
    /// memory does not grow with the run).
    pub pass: crate::stats::Histogram,
    /// Passes whose buffers saturated (collisions, depth output or queue).
    pub saturated: u64,
    /// Passes whose collision or depth output filled.
    pub contacts_full: u32,
    /// Passes whose depth queue filled.
    pub queue_full: u32,
    /// Colliding nodes that got no depth (no border edge), summed over passes.
    pub unreached: u64,
    /// Most pen nodes inside the object in one pass.
    pub pen_collisions_max: usize,
    /// Most object nodes inside the pen in one pass.
    pub object_collisions_max: usize,
    /// Set when a two-thread pass lost its worker (the task then stopped the run).
    pub worker_gone: Option<WorkerGone>,
}

impl PenTaskReport {
    /// An empty report.
    pub fn new() -> Self {
        Self::default()
    }
}

/// The viewer's side of the pen's contact task: the link publishing snapshots and the
/// untouched object whose surface the first one carries.
pub struct PenViewer<'v, 'q, 'w> {
    /// The link (with the pen's shape set: [`crate::viewer::publish::tool_shape`]).
    pub link: &'v mut SimViewer<'q>,
    /// The object.
    pub world: &'v World<'w>,
    /// Wait for the last snapshot to go out when the run ends (a screenshot draws it; a
    /// closed window drains nothing more).
    pub last_picture: bool,
}

impl std::fmt::Debug for PenViewer<'_, '_, '_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PenViewer").finish_non_exhaustive()
    }
}

/// The pen's contact task: until `shared.stop`, takes the newest tool sample from the ring
/// (older ones are passed over: a pass depends on the pose only), runs a pass there on
/// `runner` ([`tetradrill_core::force::pen_pass`], on one or two threads) and
/// publishes it through `held`, and its time and saturations through `status` (starting from
/// the status the hand-off was made with: the object's counts). Sleeps 200 us when no sample
/// came. Allocation-free after start-up (`report.pass` has its buckets already) but for the
/// viewer's snapshots, at most about 60 a second: the pen at the pass's pose moved back along
/// the pass's force by its deepest penetration along it (Praktikum report, section 5), with the
/// servo's force.
#[allow(clippy::too_many_arguments)]
pub fn pen_contact_task(
    runner: &mut dyn PassRunner,
    opts: &PenOptions,
    shared: &Shared,
    held: &mut HeldIn,
    status: &mut triple_buffer::Input<SimStatus>,
    report: &mut PenTaskReport,
    mut viewer: Option<PenViewer<'_, '_, '_>>,
) {
    let mut state = PenState::default();
    let mut st = *status.input_buffer();
    let mut shown: Option<ToolView> = None;
    loop {
        let stopping = shared.stop.load(Ordering::Relaxed);
        let mut latest = None;
        while let Some(s) = shared.ring.pop() {
            latest = Some(s);
        }
        let Some(tool) = latest.filter(|t| t.position.is_finite() && t.rotation.is_finite()) else {
            if stopping {
                if let (Some(v), Some(tv)) = (viewer.as_mut(), shown) {
                    last_picture(v, tv, &st);
                }
                break;
            }
            std::thread::sleep(std::time::Duration::from_micros(200));
            continue;
        };
        let t0 = now_ns();
        let pass = match runner.pass(tool.position, tool.rotation, opts, &mut state) {
            Ok(p) => p,
            Err(e) => {
                // No pass can run any more: the servo keeps the last one, and the run stops.
                report.worker_gone = Some(e);
                shared.stop.store(true, Ordering::Relaxed);
                break;
            }
        };
        let (np, no) = pass.penetrations;
        let (pens, objs) = runner.pens();
        let pen = pens.get(..np).unwrap_or(&[]);
        let object = objs.get(..no).unwrap_or(&[]);
        report.passes += 1;
        held.input_buffer_mut()
            .set(report.passes, &tool, pen, object);
        held.publish();
        let dt = now_ns() - t0;

        report.pass.record(dt);
        report.saturated += u64::from(pass.saturated());
        report.contacts_full += u32::from(pass.contacts_full());
        report.queue_full += u32::from(pass.queue_full());
        report.unreached += u64::from(pass.pen_depth.unreached + pass.object_depth.unreached);
        report.pen_collisions_max = report.pen_collisions_max.max(pass.pen_collisions.count);
        report.object_collisions_max = report
            .object_collisions_max
            .max(pass.object_collisions.count);

        st.steps += 1;
        st.last_step_ns = dt;
        st.max_step_ns = st.max_step_ns.max(dt);
        st.saturations = report.contacts_full + report.queue_full;
        status.write(st);
        if let Some(v) = viewer.as_mut() {
            // The window's stiffness goes to the servo's law (its drilling controls do not
            // apply to a mesh tool).
            if let Some(c) = v.link.new_controls() {
                shared
                    .counters
                    .stiffness_bits
                    .store(c.stiffness.to_bits(), Ordering::Relaxed);
            }
            let tv = pen_view(&tool, pen, object, shared.counters.force());
            shown = Some(tv);
            if stopping {
                last_picture(v, tv, &st);
            } else {
                v.link.publish(v.world, tv, &st, now_ns());
            }
        }
        if stopping {
            break;
        }
    }
}

/// The pen as the viewer draws it: at the pass's pose moved back along the pass's force so no
/// colliding node stays inside ([`display_offset`]), with the servo's `force`.
fn pen_view(
    tool: &ToolSample,
    pen: &[Penetration],
    object: &[Penetration],
    force: Vec3,
) -> ToolView {
    let mut raw = Vec3::ZERO;
    for p in pen {
        raw += p.dir * p.depth;
    }
    for p in object {
        raw -= p.dir * p.depth;
    }
    ToolView {
        position: tool.position,
        shown: tool.position + display_offset(raw, pen, object),
        force,
        rotation: tool.rotation,
        ..ToolView::default()
    }
}

/// The run's last snapshot must get through (a screenshot draws it): the servo has stopped,
/// so waiting up to 2 s for the viewer to drain is fine.
fn last_picture(v: &mut PenViewer<'_, '_, '_>, tv: ToolView, st: &SimStatus) {
    if !v.last_picture {
        return;
    }
    let until = now_ns() + 2_000_000_000;
    while !v.link.publish_now(v.world, tv, st, now_ns()) && now_ns() < until {
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
}
