//! Touching from Python: a tet-mesh tool (the pen) against an object, the consistent
//! penetration depth's force at each pose.
//!
//! The contact scene (the object's hashes and grids, the pen's rest frame: about 0.2 s for the
//! teddy) is built once, by a thread of the object's own that keeps it and the pen's state
//! from call to call: `run` hands that thread its poses and waits, looking at Python's signals
//! meanwhile, so a Ctrl-C stops the thread between two ticks and the ticks run are kept.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::thread::JoinHandle;

use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tetradrill::pen;
use tetradrill::scenario::Scenario;
use tetradrill::traces::Pose;
use tetradrill_core::force::PenContact;
use tetradrill_core::Vec3;

use crate::arrays::{self, Drill};
use crate::interrupt::Signals;
use crate::{errors, settings};

/// What the scene's thread is asked to do.
enum Job {
    /// One tick a pose, from where the last call left the pen.
    Run(Vec<Pose>),
    /// Back to rest.
    Reset,
}

/// The thread that holds the contact scene and the pen's state.
#[derive(Debug)]
struct Scene {
    jobs: Option<mpsc::Sender<Job>>,
    /// The thread's replies (behind a lock only so that the Python object may be shared
    /// between threads; one call at a time takes it).
    done: Mutex<mpsc::Receiver<Result<Vec<PenContact>, tetradrill::Error>>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    /// The process that started the thread: a child forked from it has no such thread.
    pid: u32,
    /// Ticks run since the start or the last reset.
    ticks: u64,
}

impl Scene {
    /// Starts the thread over `inner` and waits until it has built the scene (or failed to:
    /// the scene's error, as `errors::of` maps it).
    fn start(inner: pen::Touching) -> PyResult<Self> {
        let (jobs, inbox) = mpsc::channel::<Job>();
        let (reply, done) = mpsc::channel();
        let stop = Arc::new(AtomicBool::new(false));
        let halt = Arc::clone(&stop);
        let thread = std::thread::Builder::new()
            .name("tetradrill-touching".into())
            .spawn(move || {
                let mut inner = inner;
                let built = inner.run(|touch| {
                    let _ = reply.send(Ok(Vec::new()));
                    for job in inbox.iter() {
                        let out = match job {
                            Job::Reset => {
                                touch.reset();
                                Vec::new()
                            }
                            Job::Run(poses) => poses
                                .iter()
                                .take_while(|_| !halt.load(Ordering::Relaxed))
                                .map(|p| touch.tick(p))
                                .collect(),
                        };
                        if reply.send(Ok(out)).is_err() {
                            break;
                        }
                    }
                });
                if let Err(e) = built {
                    let _ = reply.send(Err(e));
                }
            })
            .map_err(|e| {
                errors::TetradrillError::new_err(format!("cannot start the contact thread: {e}"))
            })?;
        done.recv()
            .map_err(|_| errors::TetradrillError::new_err("the contact thread ended"))?
            .map_err(errors::of)?;
        Ok(Self {
            jobs: Some(jobs),
            done: Mutex::new(done),
            stop,
            thread: Some(thread),
            pid: std::process::id(),
            ticks: 0,
        })
    }

    /// Hands `job` to the thread and waits for its contacts, looking at Python's signals
    /// every [`crate::interrupt::EVERY`]: a signal's exception stops the thread after its
    /// tick under way (what it ran is kept) and is returned.
    fn call(&mut self, job: Job) -> PyResult<Vec<PenContact>> {
        if std::process::id() != self.pid {
            return Err(errors::TetradrillError::new_err(
                "this Touching was made in the parent process: its contact thread is not in a \
                 forked child (make a Touching in the child)",
            ));
        }
        if matches!(job, Job::Reset) {
            self.ticks = 0;
        }
        let gone = || errors::TetradrillError::new_err("the contact thread ended");
        self.jobs
            .as_ref()
            .ok_or_else(gone)?
            .send(job)
            .map_err(|_| gone())?;
        let done = self
            .done
            .get_mut()
            .map_err(|_| errors::TetradrillError::new_err("the contact thread failed"))?;
        let ticks = &mut self.ticks;
        let mut count = |r: Result<Vec<PenContact>, tetradrill::Error>| {
            let r = r.map_err(errors::of)?;
            *ticks += r.len() as u64;
            Ok(r)
        };
        let mut signals = Signals::new();
        loop {
            match done.recv_timeout(crate::interrupt::EVERY) {
                Ok(r) => return count(r),
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    if let Err(e) = signals.check() {
                        self.stop.store(true, Ordering::Relaxed);
                        // The ticks run before the stop are kept (and counted).
                        if let Ok(r) = done.recv() {
                            let _ = count(r);
                        }
                        self.stop.store(false, Ordering::Relaxed);
                        return Err(e);
                    }
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => return Err(gone()),
            }
        }
    }
}

impl Drop for Scene {
    fn drop(&mut self) {
        // Closing the channel ends the thread's loop (a forked child has no thread to wait
        // for).
        self.jobs = None;
        if let Some(t) = self
            .thread
            .take()
            .filter(|_| std::process::id() == self.pid)
        {
            let _ = t.join();
        }
    }
}

/// A tet-mesh tool (the pen) touching an object, neither drilled.
///
/// `Touching(mesh=None, tool=None, *, scenario=None, **keys)`: `tool` is `"mesh:FILE"` or the
/// tool's mesh file as a path (tip at the origin, axis +z); `mesh` the object; `tool_scale`,
/// `stiffness`, `damping`, `max_force`, `depth_method`, `crossings`, `entry_remedy` and the
/// other scenario keys as keywords. Reads both meshes and builds the contact scene once.
#[pyclass(module = "tetradrill")]
#[derive(Debug)]
pub struct Touching {
    scene: Scene,
    tool_nodes: usize,
    object_nodes: usize,
    scenario: Scenario,
}

#[pymethods]
impl Touching {
    #[new]
    #[pyo3(signature = (mesh=None, tool=None, *, scenario=None, **keys))]
    fn new(
        py: Python<'_>,
        mesh: Option<PathBuf>,
        tool: Option<&Bound<'_, PyAny>>,
        scenario: Option<PathBuf>,
        keys: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let (sc, setup) = settings::resolve(py, scenario, mesh, settings::tool_spec(tool)?, keys)?;
        let inner = py
            .detach(|| pen::Touching::new(&setup))
            .map_err(errors::of)?;
        let tool_nodes = inner.rig().pen.positions().len();
        let object_nodes = inner.rig().obj.positions().len();
        let scene = py.detach(|| Scene::start(inner))?;
        Ok(Self {
            scene,
            tool_nodes,
            object_nodes,
            scenario: sc,
        })
    }

    /// The pen at each row of `poses` (`N x 3` tip positions, or `N x 7` with quaternions
    /// turning its +z axis), one 1 ms tick each, going on from the last call (its damping's
    /// memory and lists; `reset()` starts from rest); the GIL released while they run. The forces on the hand, `N x 3`,
    /// newtons; with `full=True` a dict: `force`, `raw` (before damping and clamping),
    /// `display_offset` (where to draw the pen so it does not visibly penetrate, `N x 3`),
    /// `penetrations` (`N x 2`: pen nodes in the object, object nodes in the pen), `clamped`
    /// (`N` bools).
    #[pyo3(signature = (poses, *, full=false))]
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        poses: &Bound<'py, PyAny>,
        full: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let poses: Vec<Pose> = arrays::poses(poses, &Drill::All(false))?;
        let scene = &mut self.scene;
        let contacts = py.detach(|| scene.call(Job::Run(poses)))?;
        let pick = |f: fn(&PenContact) -> Vec3| contacts.iter().map(f).collect::<Vec<_>>();
        let force = arrays::to_numpy(py, &pick(|c| c.force))?;
        if !full {
            return Ok(force.into_any());
        }
        let d = PyDict::new(py);
        d.set_item("force", force)?;
        d.set_item("raw", arrays::to_numpy(py, &pick(|c| c.raw))?)?;
        d.set_item(
            "display_offset",
            arrays::to_numpy(py, &pick(|c| c.display_offset))?,
        )?;
        let pens: Vec<[i64; 2]> = contacts
            .iter()
            .map(|c| [c.penetrations.0 as i64, c.penetrations.1 as i64])
            .collect();
        let pens: Bound<'py, PyArray2<i64>> = arrays::rows(py, &pens)?;
        d.set_item("penetrations", pens)?;
        let clamped: Vec<bool> = contacts.iter().map(|c| c.clamped).collect();
        d.set_item("clamped", PyArray1::from_vec(py, clamped))?;
        Ok(d.into_any())
    }

    /// Back to rest: the next `run` gives the forces of a new `Touching`'s.
    fn reset(&mut self, py: Python<'_>) -> PyResult<()> {
        let scene = &mut self.scene;
        py.detach(|| scene.call(Job::Reset)).map(|_| ())
    }

    /// Ticks run since the start or the last `reset()` (an interrupted `run`'s included).
    #[getter]
    fn ticks(&self) -> u64 {
        self.scene.ticks
    }

    /// The tool's node count.
    #[getter]
    fn tool_nodes(&self) -> usize {
        self.tool_nodes
    }

    /// The object's node count.
    #[getter]
    fn object_nodes(&self) -> usize {
        self.object_nodes
    }

    /// The scenario this runs, as a dict of its keys.
    #[getter]
    fn scenario<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        settings::as_python(py, &self.scenario)
    }

    fn __repr__(&self) -> String {
        format!(
            "Touching(mesh={:?}, tool={:?})",
            self.scenario.mesh, self.scenario.tool
        )
    }
}
