//! The servo task: every 1 ms, read the device, compute the force with the law (the burr's
//! contact plane or a mesh tool's held contact), pass it through the passivity observer, write
//! it; the stall recovery and the tick's bookkeeping.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crossbeam::queue::ArrayQueue;
use tetradrill_core::force::{
    ForceDigest, ForceParams, PassivityObserver, PassivityParams, Storage, ToolState,
};
use tetradrill_core::servo::{burr_storage, servo_force, ContactState};
use tetradrill_core::{Quat, Vec3};
use tetradrill_device::{DeviceError, ForceCommand, HapticDevice, MotorCutoff};

use crate::engine::TickParams;
use crate::platform::now_ns;
use crate::rt::{Periodic, RtConfig, RtStatus};
use crate::watchdog::StopRequest;

use super::{
    CameraOut, DeviceFrame, DeviceLimits, RecordRing, ServoCounters, SignProbe, ToolSample,
    Workspace, SERVO_PERIOD_NS,
};

/// Why the servo task ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServoEnd {
    /// It ran the ticks it was given (`--duration`, a trace's length).
    Ticks,
    /// A stop was requested ([`StopRequest`]: a signal, or a caller): the force was zeroed
    /// within the tick that saw it.
    Requested,
    /// Another task set the pipeline's stop flag (the live window closed).
    Stopped,
    /// The device failed.
    DeviceError,
}

impl ServoEnd {
    /// The name the JSON's `stop_reason` gives it: `duration`, `signal`, `window`,
    /// `device_error`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Ticks => "duration",
            Self::Requested => "signal",
            Self::Stopped => "window",
            Self::DeviceError => "device_error",
        }
    }
}

/// What the servo task measured, returned when it ends (its timing distributions are in the
/// [`ServoCounters`] it was given).
#[derive(Debug)]
pub struct ServoResult {
    /// Real-time settings achieved.
    pub rt: RtStatus,
    /// Why it ended.
    pub end: ServoEnd,
    /// After a stop request: nanoseconds from the request to the end of the zero-force write.
    pub request_to_zero_ns: Option<u64>,
    /// Magnitude of the last force command the device took (newtons, device frame): 0 after
    /// the closing zero-force write went through.
    pub last_written_n: f32,
    /// Ticks done.
    pub ticks: u64,
    /// Deadlines missed.
    pub overruns: u64,
    /// Digest of the force series.
    pub digest: ForceDigest,
    /// Largest force, newtons.
    pub max_force: f32,
    /// The device error that ended the run, if one did.
    pub error: Option<DeviceError>,
    /// Device samples with a NaN or infinite position (force zero on those ticks).
    pub nonfinite_samples: u64,
    /// The passivity observer at the end of the run (trips, energies).
    pub passivity: PassivityObserver,
    /// Deepest penetration of the tool's contact point, metres (0 for a law that does not
    /// report one).
    pub max_depth_m: f32,
    /// The tick the force was armed ([`ServoGate::arm_on_exit`]), if it was.
    pub armed_at: Option<u64>,
    /// The device's limits at the end of the run (recoveries from a trip, seconds derated).
    pub limits: DeviceLimits,
    /// The force-sign probe at the end of the run (its trips, its least statistic).
    pub probe: SignProbe,
    /// Warnings the device's vendor library reported, the run going on through them
    /// ([`HapticDevice::library_warnings`]).
    pub library_warnings: tetradrill_device::LibraryWarnings,
}

/// When the servo renders force at all, besides the device's own
/// [`HapticDevice::force_ready`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ServoGate {
    /// No force until the law has given zero force once with the device ready (the tool
    /// outside the solid): the tool is then *armed*. A device that starts with its tool inside
    /// the solid does not push the hand out with the full force the moment it starts.
    pub arm_on_exit: bool,
    /// Run the force-sign probe ([`SignProbe`]) on the device's force: the pipeline's runs
    /// do; a caller that checks the law's forces bit for bit at the device may not.
    pub sign_probe: bool,
}

/// The servo task: `ticks` ticks at 1 kHz (`u64::MAX`: no end), or until `stop` or a
/// `request`, each computing its force with `law` ([`BurrLaw`] for the drill,
/// [`crate::pen_tasks::PenLaw`] for a mesh tool). Everything it needs is allocated before its
/// loop; the loop neither allocates nor locks (the allocation-counting tests run [`servo_io`],
/// the loop's body, with either law, and the histogram and recorder pushes). Wake-up latency
/// and tick time go into `counters.wake` and `counters.tick` (fixed buckets: memory does not
/// grow with the run). With a `record` ring, each tick's sample is pushed there too (a full
/// ring drops the row and counts it; never a wait).
///
/// A stop `request` is looked at right after each wake-up: the tick that sees it writes zero
/// force ([`crate::watchdog::zero_force`], the watchdog's cutoff and the servo's own path)
/// and ends the loop, so the device gets zero force within one period of the request. `frame` is
/// the device frame it starts with; with a
/// `camera` hand-off, each tick takes the latest camera the viewer published (a triple-buffer
/// read: a few atomic operations, never a wait).
///
/// Each tick feeds the watchdog (`counters.watch`, an atomic store) from the first tick to the
/// last. When the watchdog caught a stall (or the device's cutoff latch is set), the next tick
/// first writes [`ForceCommand::OFF`] through the device and re-arms the cutoff, so the force
/// ramps up again from zero; the stall's length is counted.
#[allow(clippy::too_many_arguments)]
pub fn servo_task(
    device: &mut dyn HapticDevice,
    rt: RtConfig,
    ticks: u64,
    workspace: Workspace,
    law: &mut dyn ForceLaw,
    ring: &ArrayQueue<ToolSample>,
    counters: &ServoCounters,
    stop: &AtomicBool,
    request: &StopRequest,
    record: Option<Arc<RecordRing>>,
    frame: DeviceFrame,
    mut camera: Option<&mut CameraOut>,
    gate: ServoGate,
) -> ServoResult {
    let rt = rt.apply();
    let mut state = ServoState {
        frame,
        record,
        gate,
        ..ServoState::default()
    };
    let spec = device.spec();
    state
        .passivity
        .set_params(passivity_params(&spec, SERVO_PERIOD_NS));
    state.limits = DeviceLimits::new(&spec, SERVO_PERIOD_NS as f32 * 1e-9);
    if gate.sign_probe {
        state.probe = SignProbe::new(&spec);
    }
    let mut end = ServoEnd::Ticks;
    let mut request_to_zero_ns = None;
    let watch = &counters.watch;
    let cutoff = device.cutoff();
    let mut timer = Periodic::new(SERVO_PERIOD_NS, 0);
    let mut error = None;
    let mut done = 0u64;
    let mut window_max = 0u64;
    // The end of the last tick, and the time between the last two ends: a stall is the longer
    // of that gap (stalled inside a tick) and the time since (stalled between ticks).
    let mut last_end = now_ns();
    let mut last_gap = 0u64;
    while done < ticks {
        if stop.load(Ordering::Relaxed) {
            end = ServoEnd::Stopped;
            break;
        }
        let w = timer.wait();
        if request.is_requested() {
            if crate::watchdog::zero_force(device, cutoff.as_deref()).is_ok() {
                state.last_written = 0.0;
            }
            let at = request.requested_at_ns().unwrap_or(0);
            request_to_zero_ns = Some(now_ns().saturating_sub(at));
            request.force_zeroed();
            end = ServoEnd::Requested;
            break;
        }
        let t0 = now_ns();
        let stalled = last_gap.max(t0.saturating_sub(last_end));
        if recover_from_stall(device, cutoff.as_deref(), watch, stalled) {
            // The force was off: what the tool did meanwhile was not the loop's doing.
            state.passivity.restart();
        }
        // The viewer's camera (a matrix that is not a rotation is refused: the old one stays).
        if let Some(c) = camera.as_deref_mut() {
            if c.update() {
                state.frame.set_camera(c.output_buffer());
            }
        }
        let out = servo_io(device, &workspace, law, ring, &mut state, done);
        counters.record_wake(w.latency_ns, done, &mut window_max);
        for (a, v) in counters.force_xyz.iter().zip(state.last_force.to_array()) {
            a.store(v.to_bits(), Ordering::Relaxed);
        }
        let t1 = now_ns();
        counters.tick.record(t1 - t0);
        last_gap = t1.saturating_sub(last_end);
        last_end = t1;
        done += 1;
        watch.beat(done);
        counters.ticks.store(done, Ordering::Relaxed);
        counters.overruns.store(timer.overruns, Ordering::Relaxed);
        counters
            .dropped_samples
            .store(state.dropped, Ordering::Relaxed);
        counters.force_bits.store(
            state.last_force.length().to_bits() as u64,
            Ordering::Relaxed,
        );
        if let Err(e) = out {
            error = Some(e);
            end = ServoEnd::DeviceError;
            break;
        }
    }
    // Leave the device safe: force off, whatever happened.
    watch.disarm();
    if device.write(&ForceCommand::OFF).is_ok() {
        state.last_written = 0.0;
    }
    stop.store(true, Ordering::Release);
    ServoResult {
        rt,
        end,
        request_to_zero_ns,
        last_written_n: state.last_written,
        ticks: done,
        overruns: timer.overruns,
        digest: state.digest,
        max_force: state.max_force,
        error,
        nonfinite_samples: state.nonfinite_samples,
        passivity: state.passivity,
        max_depth_m: state.max_depth_m,
        armed_at: state.armed_at,
        limits: state.limits,
        probe: state.probe,
        library_warnings: device.library_warnings(),
    }
}

/// The passivity observer's settings for a device: its force and damping limits, the servo
/// period, the core's default slack and trip bound (a law without a storage function, a mesh
/// tool's, is observed only: its forces stay the law's, bit for bit).
pub fn passivity_params(spec: &tetradrill_device::DeviceSpec, period_ns: u64) -> PassivityParams {
    let mut p = PassivityParams {
        dt: period_ns as f32 * 1e-9,

        ..PassivityParams::default()
    };
    if spec.max_force_n.is_finite() && spec.max_force_n > 0.0 {
        p.max_force = spec.max_force_n as f32;
    }
    if spec.max_damping_n_s_per_m.is_finite() && spec.max_damping_n_s_per_m > 0.0 {
        p.max_damping = spec.max_damping_n_s_per_m as f32;
    }
    p
}

/// The top of a servo tick: when the watchdog caught a stall (or the device's cutoff latch is
/// set), writes [`ForceCommand::OFF`] through the device, re-arms the cutoff (the device's
/// filter then ramps the force up again from zero) and counts the stall, `stalled_ns` long.
/// Returns whether it did. Atomics and at most one device write: no lock, no allocation.
pub fn recover_from_stall(
    device: &mut dyn HapticDevice,
    cutoff: Option<&dyn MotorCutoff>,
    watch: &crate::watchdog::ServoWatch,
    stalled_ns: u64,
) -> bool {
    let tripped = watch.tripped();
    if !(tripped || cutoff.is_some_and(|c| c.is_cut())) {
        return false;
    }
    let _ = device.write(&ForceCommand::OFF);
    if let Some(c) = cutoff {
        c.rearm();
    }
    if tripped {
        watch.resumed(stalled_ns);
    }
    true
}

/// What the servo carries from tick to tick.
#[derive(Debug, Default)]
pub struct ServoState {
    /// Damping state of [`servo_tick`] (the laws of [`servo_task`] keep their own).
    pub tool: ToolState,
    /// Digest of the forces.
    pub digest: ForceDigest,
    /// Largest force.
    pub max_force: f32,
    /// Last force.
    pub last_force: Vec3,
    /// Tool samples dropped (ring full).
    pub dropped: u64,
    /// The egocentric frame positions and forces go through (the identity by default).
    pub frame: DeviceFrame,
    /// Device samples whose position was NaN or infinite (their force is zero).
    pub nonfinite_samples: u64,
    /// Magnitude of the last force command the device took, newtons (device frame).
    pub last_written: f32,
    /// Where each tick's sample is recorded (`--record`), if anywhere.
    pub record: Option<Arc<RecordRing>>,
    /// The time-domain passivity observer and controller between the law and the device.
    pub passivity: PassivityObserver,
    /// Deepest penetration of the tool's contact point so far, metres.
    pub max_depth_m: f32,
    /// The device's position resets seen so far ([`HapticDevice::position_resets`]: the
    /// Falcon's homing moves its coordinates); a new one restarts the passivity observer, whose
    /// energy would otherwise count the jump as the tool's motion.
    pub position_resets: u64,
    /// When force is rendered at all.
    pub gate: ServoGate,
    /// The tick the force was armed ([`ServoGate::arm_on_exit`]).
    pub armed_at: Option<u64>,
    /// The last tick rendered no force for the gate or the device's readiness: the passivity
    /// observer restarts when force comes back.
    pub paused: bool,
    /// The device's limits: the peak clamp, the continuous-force derating, the recovery from a
    /// passivity trip ([`DeviceLimits::default`]: none; [`servo_task`] sets the device's).
    pub limits: DeviceLimits,
    /// The force-sign probe after the observer ([`SignProbe::default`]: none; [`servo_task`]
    /// sets the device's): a trip of its own goes through the observer's
    /// ([`PassivityObserver::trip`]).
    pub probe: SignProbe,
}

/// Where a servo tick's force comes from: the burr's contact plane ([`BurrLaw`]) or a mesh
/// tool's held contact ([`crate::pen_tasks::PenLaw`]). Any `FnMut(tick, position, rotation)`
/// closure is one too.
pub trait ForceLaw {
    /// The force on the tool at `position` and `rotation` (scene frame) at servo tick `tick`,
    /// newtons. Runs on the servo thread every tick: bounded work, no allocation, no lock, no
    /// wait (hand-offs are read through triple buffers).
    fn force(&mut self, tick: u64, position: Vec3, rotation: Quat) -> Vec3;

    /// The contact behind the last force, when the law knows its storage function (the
    /// passivity observer then uses its stricter form and trips on the energy stored past the
    /// force limit); `None` (the default) leaves the observer its classic form.
    fn contact(&self) -> Option<LawContact> {
        None
    }
}

impl<F: FnMut(u64, Vec3, Quat) -> Vec3> ForceLaw for F {
    fn force(&mut self, tick: u64, position: Vec3, rotation: Quat) -> Vec3 {
        self(tick, position, rotation)
    }
}

/// What a law knows of its contact at the tool's pose (scene units).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LawContact {
    /// Penetration of the tool's contact point, mesh units (0 out of contact).
    pub depth: f32,
    /// The energy its spring holds there, newton mesh units.
    pub storage: Storage,
}

/// The burr's contact at `centre`: the depth below the contact plane and the storage of its
/// penalty spring ([`burr_storage`]: the stiffness the servo renders there, the material's
/// under the contact or else `force`'s, and `force`'s limit). Out of contact, or for a pose
/// that is not finite, zero.
///
/// # Bounded work
/// Constant.
pub fn burr_contact(
    contact: &ContactState,
    centre: Vec3,
    radius: f32,
    force: &ForceParams,
) -> LawContact {
    let (depth, storage) = burr_storage(contact, centre, radius, force);
    LawContact { depth, storage }
}

/// The burr's force law: the latest contact plane the simulation published, at the burr's
/// current position (Turini et al. 2006, section 3.3), with the viewer's radius and stiffness when
/// it set them (`counters`).
#[derive(Debug)]
pub struct BurrLaw<'a> {
    /// The scenario's parameters.
    pub params: TickParams,
    /// The simulation's contact plane.
    pub contact: &'a mut triple_buffer::Output<ContactState>,
    /// The viewer's controls (radius and stiffness, 0 = the scenario's).
    pub counters: &'a ServoCounters,
    /// Damping state.
    pub tool: ToolState,
    /// The contact behind the last force.
    pub last: LawContact,
}

impl<'a> BurrLaw<'a> {
    /// The law for `params` over `contact`, controlled through `counters`.
    pub fn new(
        params: TickParams,
        contact: &'a mut triple_buffer::Output<ContactState>,
        counters: &'a ServoCounters,
    ) -> Self {
        Self {
            params,
            contact,
            counters,
            tool: ToolState::default(),
            last: LawContact::default(),
        }
    }
}

impl ForceLaw for BurrLaw<'_> {
    fn force(&mut self, _tick: u64, position: Vec3, rotation: Quat) -> Vec3 {
        // The burr spins about the stylus's axis; the contact carries a friction only while
        // the drill is on.
        self.tool
            .set_spin(tetradrill_core::force::DrillTool::axis(rotation) * self.params.spin);
        // The viewer's controls (0: the scenario's value).
        let mut live = self.params;
        let r = self.counters.radius_bits.load(Ordering::Relaxed);
        if r != 0 {
            live.radius = f32::from_bits(r);
        }
        let k = self.counters.stiffness_bits.load(Ordering::Relaxed);
        if k != 0 {
            live.force.stiffness = f32::from_bits(k);
        }
        let contact = self.contact.read();
        self.last = burr_contact(contact, position, live.radius, &live.force);
        servo_force(contact, position, live.radius, &mut self.tool, &live.force)
    }

    fn contact(&self) -> Option<LawContact> {
        Some(self.last)
    }
}

/// [`servo_tick`]'s law: the burr's force from a fixed contact plane.
struct PlaneLaw<'a> {
    contact: &'a ContactState,
    params: &'a TickParams,
    tool: ToolState,
    last: LawContact,
}

impl ForceLaw for PlaneLaw<'_> {
    fn force(&mut self, _tick: u64, position: Vec3, _rotation: Quat) -> Vec3 {
        let p = self.params;
        self.last = burr_contact(self.contact, position, p.radius, &p.force);
        servo_force(self.contact, position, p.radius, &mut self.tool, &p.force)
    }

    fn contact(&self) -> Option<LawContact> {
        Some(self.last)
    }
}

/// One burr servo tick: [`servo_io`] with the force from `contact` (the damping state in
/// `st.tool`). Allocation-free and lock-free.
///
/// # Errors
/// A device error (disconnect, NaN refused, ...) is returned after the force was zeroed.
pub fn servo_tick(
    device: &mut dyn HapticDevice,
    workspace: &Workspace,
    params: &TickParams,
    contact: &ContactState,
    ring: &ArrayQueue<ToolSample>,
    st: &mut ServoState,
    tick: u64,
) -> Result<(), DeviceError> {
    let mut law = PlaneLaw {
        contact,
        params,
        tool: st.tool,
        last: LawContact::default(),
    };
    let out = servo_io(device, workspace, &mut law, ring, st, tick);
    st.tool = law.tool;
    out
}

/// One servo tick: read the device, map its pose into the scene through `st.frame`, hand the
/// sample to the simulation, compute the force with `law`, pass it through the passivity
/// observer and controller (`st.passivity`), write it back through the frame.
/// Allocation-free and lock-free when `law` is.
///
/// A non-finite position is counted and still handed to `law` (the laws give it zero force).
///
/// Between the law and the observer, [`DeviceLimits::shape`] clamps, derates and ramps the force:
/// the observer is fed what the device is sent. The tick the observer trips, the device's
/// cutoff is cut (direct zero, latch: the watchdog's path); that tick and every later one
/// writes [`ForceCommand::OFF`] until the tool has been out of contact for
/// [`super::RECOVER_TICKS`] ([`DeviceLimits::recovers`]): then the cutoff is re-armed and the
/// force ramps back in.
///
/// # Errors
/// A device error (disconnect, NaN refused, ...) is returned after the force was zeroed.
pub fn servo_io(
    device: &mut dyn HapticDevice,
    workspace: &Workspace,
    law: &mut dyn ForceLaw,
    ring: &ArrayQueue<ToolSample>,
    st: &mut ServoState,
    tick: u64,
) -> Result<(), DeviceError> {
    let s = match device.read() {
        Ok(s) => s,
        Err(e) => {
            if device.write(&ForceCommand::OFF).is_ok() {
                st.last_written = 0.0;
            }
            return Err(e);
        }
    };
    let s_buttons = s.buttons;
    let device_position = s.position;
    let resets = device.position_resets();
    if resets != st.position_resets {
        st.position_resets = resets;
        st.passivity.restart();
        st.probe.restart();
    }
    let position = st.frame.to_scene(workspace, s.position);
    let rotation = st.frame.rotation_to_scene(s.rotation);
    st.nonfinite_samples += u64::from(!position.is_finite());
    let sample = ToolSample {
        tick,
        position,
        rotation,
        buttons: s.buttons,
    };
    if ring.push(sample).is_err() {
        st.dropped += 1;
    }
    if let Some(r) = &st.record {
        r.push(sample);
    }
    let f = law.force(tick, position, rotation);
    // The gate: nothing while the device waits for its calibration (the observer paused, as
    // no force goes out), nor before the tool was armed outside the solid.
    let ready = device.force_ready();
    if st.gate.arm_on_exit
        && st.armed_at.is_none()
        && ready
        && position.is_finite()
        && f == Vec3::ZERO
    {
        st.armed_at = Some(tick);
    }
    if !ready || (st.gate.arm_on_exit && st.armed_at.is_none()) {
        st.paused = true;
        return write_off(device, st);
    }
    if st.paused {
        // Force comes back: what the tool did meanwhile was not the loop's doing.
        st.paused = false;
        st.passivity.restart();
        st.probe.restart();
    }
    // The observer works in SI: scene positions over the workspace scale are metres (in the
    // scene's rotated frame, where the power is the device's).
    let s = workspace.scale;
    let to_si = if s.is_finite() && s > 0.0 {
        1.0 / s
    } else {
        1.0
    };
    let contact = law.contact();
    if let Some(c) = contact {
        let d = c.depth * to_si;
        if d.is_finite() {
            st.max_depth_m = st.max_depth_m.max(d);
        }
    }
    // A trip: zero with the motors off until the tool has been out of contact for a second
    // (then the cutoff is re-armed and the force ramps back in), or for good after too many.
    if st.passivity.tripped() && st.limits.recovers(f) {
        st.passivity.recover();
        st.probe.restart();
        if let Some(c) = device.cutoff() {
            c.rearm();
        }
    }
    if st.passivity.tripped() {
        return write_off(device, st);
    }
    // The force the device is sent: clamped at its peak, derated, ramped in after a recovery;
    // the law's storage scaled with it (the environment the device renders).
    let (sent, k) = st.limits.shape(f);
    let storage = contact.map(|c| c.storage.scaled(to_si).scaled(k));
    // With the drill on the material gives way by design (removal dissipates what the tool
    // pushes into it), so the law's spring is no storage function: the classic form damps, and
    // the trip still measures the energy past the force limit.
    let drilling = s_buttons & tetradrill_core::script::DRILL_ON != 0;
    let f = if drilling {
        st.passivity.step_removing(position * to_si, sent, storage)
    } else {
        st.passivity.step(position * to_si, sent, storage)
    };
    if st.passivity.tripped() {
        st.limits.tripped_at(tick);
        if let Some(c) = device.cutoff() {
            let _ = c.cut();
        }
        return write_off(device, st);
    }
    st.limits.heat_by(f);
    st.digest.push(f);
    st.max_force = st.max_force.max(f.length());
    st.last_force = f;
    // Scene force to the device frame: back through the camera (the workspace map is a uniform
    // scale and a shift, which leave directions alone).
    let d = st.frame.force_to_device(f);
    let d = [d.x as f64, d.y as f64, d.z as f64];
    // The force-sign probe: what the device did with the probes of the last ticks, and this
    // tick's, added to what the device is sent (not to the digest, the observer or the heat).
    // Not for a law without a contact of its own (a mesh tool's forces stay the law's).
    let probed = if contact.is_some() { d } else { [0.0; 3] };
    let probe = st.probe.step(device_position, probed);
    if st.probe.reversed() {
        st.probe.tripped();
        st.passivity.trip();
        st.limits.tripped_at(tick);
        if let Some(c) = device.cutoff() {
            let _ = c.cut();
        }
        return write_off(device, st);
    }
    let cmd = ForceCommand::force([d[0] + probe[0], d[1] + probe[1], d[2] + probe[2]]);
    device.write(&cmd)?;
    let c = cmd.force;
    st.last_written = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt() as f32;
    Ok(())
}

/// A tick that renders nothing: zero force in the digest, the motors off, the continuous-force
/// model cooling.
fn write_off(device: &mut dyn HapticDevice, st: &mut ServoState) -> Result<(), DeviceError> {
    st.digest.push(Vec3::ZERO);
    st.last_force = Vec3::ZERO;
    st.limits.heat_by(Vec3::ZERO);
    device.write(&ForceCommand::OFF)?;
    st.last_written = 0.0;
    Ok(())
}
