//! The pipeline's threads: the servo under its panic guard, the recorder, the watchdog, and the
//! tasks the main thread runs (status line, viewer) until the run ends.

use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::Duration;

use tetradrill_device::{DeviceError, DeviceKind, HapticDevice};

use crate::error::CliError;
use crate::rt::RtConfig;
use crate::tasks::{self, RecordRing, Shared, SimStatus, Workspace};
use crate::watchdog::{self, StopRequest};

use super::DeviceFactory;

/// Why the servo thread ended without its result.
#[derive(Debug)]
pub(super) enum ServoFailure {
    /// The device could not be opened.
    Device(DeviceError),
    /// The servo (or the device under it) panicked: a bug.
    Panicked {
        /// Ticks done before.
        ticks: u64,
        /// The panic's one line.
        panic: String,
        /// What happened to the force (`force was set to zero`, or why not).
        force: String,
    },
}

/// What the servo thread needs besides its law.
pub(super) struct ServoRun<'c> {
    pub(super) open: DeviceFactory,
    pub(super) rt: RtConfig,
    pub(super) ticks: u64,
    pub(super) workspace: Workspace,
    pub(super) frame: tasks::DeviceFrame,
    pub(super) camera: Option<&'c mut tasks::CameraOut>,
    pub(super) request: &'c StopRequest,
    pub(super) record: Option<std::sync::Arc<RecordRing>>,
    pub(super) gate: tasks::ServoGate,
}

/// The servo thread: opens the device, attaches its cutoff to the watchdog, and runs
/// [`tasks::servo_task`] with `law` under a panic guard (a panic zeroes the force).
pub(super) fn spawn_servo<'scope, 'env: 'scope, L: tasks::ForceLaw + Send>(
    scope: &'scope std::thread::Scope<'scope, 'env>,
    sh: &'env Shared,
    run: ServoRun<'env>,
    law: &'env mut L,
) -> Result<std::thread::ScopedJoinHandle<'scope, Result<tasks::ServoResult, ServoFailure>>, CliError>
{
    let ServoRun {
        open,
        rt,
        ticks,
        workspace,
        frame,
        camera,
        request,
        record,
        gate,
    } = run;
    std::thread::Builder::new()
        .name(tasks::SERVO.name.into())
        .spawn_scoped(scope, move || {
            let watch = &sh.counters.watch;
            let opened = watchdog::quiet_unwind(open);
            let mut device = match opened {
                Ok(Ok(d)) => d,
                Ok(Err(e)) => {
                    sh.stop.store(true, Ordering::Relaxed);
                    return Err(ServoFailure::Device(e));
                }
                Err(panic) => {
                    sh.stop.store(true, Ordering::Relaxed);
                    return Err(ServoFailure::Panicked {
                        ticks: 0,
                        panic,
                        force: "the motors were never turned on".into(),
                    });
                }
            };
            let cutoff = device.cutoff();
            watch.attach(cutoff.clone());
            let run = watchdog::quiet_unwind(|| {
                tasks::servo_task(
                    device.as_mut(),
                    rt,
                    ticks,
                    workspace,
                    law,
                    &sh.ring,
                    &sh.counters,
                    &sh.stop,
                    request,
                    record,
                    frame,
                    camera,
                    gate,
                )
            });
            run.map_err(|panic| {
                let force = watchdog::after_panic(watch, device, cutoff, &sh.stop);
                ServoFailure::Panicked {
                    ticks: sh.counters.ticks.load(Ordering::Relaxed),
                    panic,
                    force,
                }
            })
        })
        .map_err(|e| {
            // The tasks already started end too (the scope waits for them).
            sh.stop.store(true, Ordering::Relaxed);
            CliError::failure(format!("cannot start the servo task: {e}"))
        })
}

/// `--record FILE`: the file, created before the run starts (a path that cannot be written is
/// bad input: exit 2 naming it), and the ring the servo feeds.
pub(super) struct Recorder {
    pub(super) file: Option<(PathBuf, std::fs::File)>,
    pub(super) ring: Option<std::sync::Arc<RecordRing>>,
}

/// The recorder thread's handle: the rows it wrote, or why it stopped.
type RecorderHandle<'scope> = Option<(
    PathBuf,
    std::thread::ScopedJoinHandle<'scope, std::io::Result<u64>>,
)>;

impl Recorder {
    pub(super) fn open(path: Option<&std::path::Path>) -> Result<Self, CliError> {
        let Some(path) = path else {
            return Ok(Self {
                file: None,
                ring: None,
            });
        };
        let file = std::fs::File::create(path)
            .map_err(|e| CliError::at(path, None, format!("--record: cannot create: {e}")))?;
        Ok(Self {
            file: Some((path.to_path_buf(), file)),
            ring: Some(std::sync::Arc::new(RecordRing::new(tasks::RECORD_RING))),
        })
    }

    pub(super) fn ring(&self) -> Option<std::sync::Arc<RecordRing>> {
        self.ring.clone()
    }

    pub(super) fn dropped(&self) -> u64 {
        self.ring.as_ref().map_or(0, |r| r.dropped())
    }

    /// The recorder task ([`tasks::recorder_task`]) on its own thread, until `sh.stop`.
    pub(super) fn spawn<'scope, 'env: 'scope>(
        &'env self,
        scope: &'scope std::thread::Scope<'scope, 'env>,
        sh: &'env Shared,
    ) -> Result<RecorderHandle<'scope>, CliError> {
        let (Some((path, file)), Some(ring)) = (&self.file, &self.ring) else {
            return Ok(None);
        };
        let h = std::thread::Builder::new()
            .name(tasks::RECORDER.name.into())
            .spawn_scoped(scope, move || tasks::recorder_task(ring, file, &sh.stop))
            .map_err(|e| {
                sh.stop.store(true, Ordering::Relaxed);
                CliError::failure(format!("cannot start the recorder task: {e}"))
            })?;
        Ok(Some((path.clone(), h)))
    }

    /// The rows written (0 without `--record`); a write error ends the run with exit 1.
    pub(super) fn join(h: RecorderHandle<'_>) -> Result<u64, CliError> {
        let Some((path, h)) = h else {
            return Ok(0);
        };
        h.join()
            .map_err(|_| CliError::failure("the recorder task panicked"))?
            .map_err(|e| {
                CliError::failure(format!("{}: --record: cannot write: {e}", path.display()))
            })
    }
}

/// A signal's name (`SIGINT`), or its number.
pub(super) fn signal_name(sig: i32) -> String {
    match sig {
        libc::SIGINT => "SIGINT".into(),
        libc::SIGTERM => "SIGTERM".into(),
        libc::SIGHUP => "SIGHUP".into(),
        n => format!("signal {n}"),
    }
}

/// The watchdog thread ([`watchdog::supervisor_task`]) for a run of `kind`.
pub(super) fn spawn_watchdog<'scope, 'env: 'scope>(
    scope: &'scope std::thread::Scope<'scope, 'env>,
    sh: &'env Shared,
    rt: RtConfig,
    kind: DeviceKind,
) -> Result<std::thread::ScopedJoinHandle<'scope, ()>, CliError> {
    std::thread::Builder::new()
        .name(tasks::WATCHDOG.name.into())
        .spawn_scoped(scope, move || {
            watchdog::supervisor_rt(&rt);
            watchdog::supervisor_task(
                &sh.counters.watch,
                kind.name(),
                watchdog::SERVO_WATCHDOG_NS,
                &sh.stop,
                |line| errln!("tetradrill: warning: {line}"),
            );
        })
        .map_err(|e| {
            sh.stop.store(true, Ordering::Relaxed);
            CliError::failure(format!("cannot start the watchdog task: {e}"))
        })
}

/// What the main thread needs for its part of a run.
pub(super) struct Front<'v> {
    pub(super) view: &'v crate::viewer::ViewOptions,
    pub(super) status_line: bool,
    pub(super) initial_volume: f64,
    pub(super) controls: crate::viewer::handoff::ControlsIn,
    pub(super) initial_controls: crate::viewer::handoff::Controls,
    pub(super) camera: tasks::CameraIn,
}

/// What [`main_thread_tasks`] gives back: the servo's result, the last status, the simulation
/// task's result and the scene a screenshot draws.
type Joined<S> = (
    Result<tasks::ServoResult, ServoFailure>,
    SimStatus,
    S,
    crate::viewer::scene::Scene,
);

/// The main thread's part of a run once the simulation, servo and watchdog threads are up: the
/// live window (the status task then on its own thread; a closed window ends the run) or the
/// status task, draining snapshots for a screenshot; then the joins, in the order that lets
/// every task end (servo, watchdog, simulation).
pub(super) fn main_thread_tasks<'scope, 'env: 'scope, S>(
    scope: &'scope std::thread::Scope<'scope, 'env>,
    sh: &'env Shared,
    front: Front<'_>,
    mut status_out: triple_buffer::Output<SimStatus>,
    servo: std::thread::ScopedJoinHandle<'scope, Result<tasks::ServoResult, ServoFailure>>,
    supervisor: std::thread::ScopedJoinHandle<'scope, ()>,
    sim: std::thread::ScopedJoinHandle<'scope, S>,
) -> Result<Joined<S>, CliError> {
    let Front {
        view,
        status_line,
        initial_volume,
        controls,
        initial_controls,
        camera,
    } = front;
    let any_view = view.any();
    let mut scene = crate::viewer::scene::Scene::new();
    let drain = |scene: &mut crate::viewer::scene::Scene| {
        while let Some(snap) = sh.snapshots.take() {
            scene.apply(snap);
        }
    };
    if view.window {
        // The viewer on the main thread, the status task on its own.
        let status = std::thread::Builder::new()
            .name(tasks::STATUS.name.into())
            .spawn_scoped(scope, move || {
                status_loop(sh, &mut status_out, status_line, initial_volume, || {});
                status_out
            })
            .map_err(|e| {
                sh.stop.store(true, Ordering::Relaxed);
                CliError::failure(format!("cannot start the status task: {e}"))
            })?;
        let link = crate::viewer::LiveLink {
            shared: sh,
            controls,
            initial: initial_controls,
            camera: Some(camera),
            clip: view.clip,
        };
        let shown = crate::viewer::run_window(link);
        // A closed window ends the run.
        sh.stop.store(true, Ordering::Relaxed);
        scene = shown?;
        status_out = status
            .join()
            .map_err(|_| CliError::failure("the status task panicked"))?;
    } else {
        drop(controls);
        drop(camera);
        // The status task: the main thread.
        status_loop(sh, &mut status_out, status_line, initial_volume, || {
            if any_view {
                drain(&mut scene)
            }
        });
    }
    let servo = servo.join();
    sh.stop.store(true, Ordering::Relaxed);
    let servo = servo.map_err(|_| CliError::failure("the servo task panicked"))?;
    supervisor
        .join()
        .map_err(|_| CliError::failure("the watchdog task panicked"))?;
    while !sim.is_finished() {
        if any_view && !view.window {
            drain(&mut scene);
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let ending = sim
        .join()
        .map_err(|_| CliError::failure("the simulation task panicked"))?;
    if any_view && !view.window {
        drain(&mut scene);
    }
    Ok((servo, *status_out.read(), ending, scene))
}

/// The audio task: until `stop`, every 10 ms, the burr's state for the sound from the servo's
/// counters (the force pressing the burr: a drill's burr alone, else the whole force): kept as
/// samples for the time since the last look when `keep` (`--audio-out`), and published to a
/// live sound card's callback when `live` (`--sound`, the `sound` feature). The burr spins for
/// the whole run; the grinding follows the load; the timbre is the middle one (the counters do
/// not say which material is cut: `replay --audio-out` does). Not a real-time thread: it only
/// reads atomics.
pub(super) fn spawn_audio<'scope, 'env: 'scope>(
    scope: &'scope std::thread::Scope<'scope, 'env>,
    sh: &'env Shared,
    sound: crate::audio::BurrSound,
    keep: bool,
    live: bool,
) -> Result<std::thread::ScopedJoinHandle<'scope, crate::audio::BurrVoice>, CliError> {
    std::thread::Builder::new()
        .name("audio".into())
        .spawn_scoped(scope, move || {
            let state = std::sync::Arc::new(crate::audio::LiveState::default());
            // Kept alive until the run stops: dropping it stops the sound.
            let _player = live.then(|| start_player(&state, sound)).flatten();
            let mut voice = crate::audio::BurrVoice::new(sound);
            let mut last = std::time::Instant::now();
            while !sh.stop.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(10));
                let c = &sh.counters;
                let burr = f32::from_bits(c.burr_press_bits.load(Ordering::Relaxed));
                let whole = f32::from_bits(c.force_bits.load(Ordering::Relaxed) as u32);
                let load = f64::from(if burr > 0.0 { burr } else { whole });
                let now = std::time::Instant::now();
                let s = crate::audio::TickSound {
                    on: true,
                    load_n: load,
                    brightness: crate::audio::brightness(0.0, 0.0),
                    grinding: (load / sound.full_load_n).min(1.0),
                };
                state.set(&s);
                if keep {
                    voice.advance(&s, (now - last).as_secs_f64());
                }
                last = now;
            }
            voice
        })
        .map_err(|e| CliError::failure(format!("cannot start the audio task: {e}")))
}

/// The live sound on the default output, or one line saying why not.
#[cfg(feature = "sound")]
fn start_player(
    state: &std::sync::Arc<crate::audio::LiveState>,
    sound: crate::audio::BurrSound,
) -> Option<crate::audio::live::Player> {
    match crate::audio::live::Player::start(std::sync::Arc::clone(state), sound) {
        Ok(p) => Some(p),
        Err(e) => {
            errln!("tetradrill: --sound: {e}; the run goes on without it");
            None
        }
    }
}

/// Without the `sound` feature there is no live sound (`--sound` is refused before the run).
#[cfg(not(feature = "sound"))]
fn start_player(
    _state: &std::sync::Arc<crate::audio::LiveState>,
    _sound: crate::audio::BurrSound,
) -> Option<()> {
    None
}

/// The status task: until `stop`, the status line every 250 ms (one line a second in logs),
/// and `each` every 25 ms (the screenshot's snapshot drain).
pub(super) fn status_loop(
    sh: &Shared,
    status_out: &mut triple_buffer::Output<SimStatus>,
    status_line: bool,
    initial_volume: f64,
    mut each: impl FnMut(),
) {
    let mut last_ticks = 0u64;
    let mut last_steps = 0u64;
    let mut printed = false;
    let mut last_at = std::time::Instant::now();
    let mut slice = 0u32;
    while !sh.stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(25));
        each();
        slice += 1;
        if !slice.is_multiple_of(10) || !status_line {
            continue;
        }
        let st = *status_out.read();
        let c = &sh.counters;
        let t = c.ticks.load(Ordering::Relaxed);
        let f = f32::from_bits(c.force_bits.load(Ordering::Relaxed) as u32);
        // On a terminal the line updates in place; in a log, one line a second.
        let tty = std::io::IsTerminal::is_terminal(&std::io::stderr());
        if !tty && !(sh.counters.ticks.load(Ordering::Relaxed) / 250).is_multiple_of(4) {
            continue;
        }
        // With materials: the force pressing the burr against the threshold of the material
        // under it.
        let press = st
            .threshold_n
            .map(|th| format!(" (press {:5.2} / threshold {th:4.2} N)", st.press_n))
            .unwrap_or_default();
        err!(
            "{} t {:5.1} s | servo {:4} Hz, overruns {}, wake p99 {:4.0} us | sim {:4} Hz | removed {:.5} ({:.2}%) | force {:5.2} N{}   {}",
            if tty { "\r" } else { "" },
            t as f64 / 1000.0,
            ((t - last_ticks) as f64 / last_at.elapsed().as_secs_f64()).round(),
            c.overruns.load(Ordering::Relaxed),
            c.wake_percentile_us(0.99).unwrap_or(0.0),
            ((st.steps - last_steps) as f64 / last_at.elapsed().as_secs_f64()).round(),
            st.removed_volume,
            100.0 * st.removed_volume / initial_volume.max(f64::MIN_POSITIVE),
            f,
            press,
            if tty { "" } else { "\n" }
        );
        printed = tty;
        last_ticks = t;
        last_steps = st.steps;
        last_at = std::time::Instant::now();
    }
    if printed {
        errln!();
    }
}
