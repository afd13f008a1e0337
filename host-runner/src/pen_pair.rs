//! The pen's contact pass on two threads ([`with_pen_pair`], [`PenPair`]).
//!
//! A pass is [`pen_place`], then [`pen_side`] and [`object_side`], which write disjoint
//! storage. Here the calling thread places the pen and runs the pen side while a worker thread
//! places its own copy of the pen (the same function, the same bits) and runs the object side:
//! the pass takes about as long as its longer side instead of both. The forces are those of
//! [`tetradrill_core::force::pen_contact`], bit for bit (`tests/tests/contact/pen_pair.rs`).
//!
//! The object side's storage goes to the worker with each job and comes back with its
//! result, so the calling thread owns every buffer between passes. A waiting thread spins for
//! up to [`SPIN_HOT`], then yields its core between tries up to [`SPIN`], then parks until
//! the other unparks it (nothing on either side allocates or takes a lock):
//! back-to-back passes hand over in well under a microsecond, a pair that shares its cores
//! with other work lets the other thread run, and an idle pair costs no CPU. The spinning worker takes a core while passes run: give the
//! pair two cores (the servo thread, at real-time priority, preempts it when it shares one).

use std::thread::Thread;
use std::time::{Duration, Instant};

use crossbeam::channel::{bounded, Receiver, Sender, TryRecvError};
use tetradrill_core::depth::Penetration;
use tetradrill_core::force::{
    object_side, pen_pass, pen_place, pen_side, PenBuffers, PenContact, PenOptions, PenPass,
    PenScene, PenState, SideBuffers, SideReport,
};
use tetradrill_core::ids::TetId;
use tetradrill_core::{Quat, Vec3};

/// How long a thread of the pair waits for the other before it sleeps.
pub const SPIN: Duration = Duration::from_millis(2);

/// How long of that it spins without yielding its core.
pub const SPIN_HOT: Duration = Duration::from_micros(50);

/// One object side to run: the pose, the options, last pass's count and the storage.
struct Job<'p, 'b> {
    position: Vec3,
    rotation: Quat,
    opts: PenOptions,
    listed: usize,
    side: SideBuffers<'p, 'b>,
}

/// A finished object side, with its storage back.
struct Done<'p, 'b> {
    report: SideReport,
    side: SideBuffers<'p, 'b>,
}

/// The worker thread ended (it panicked): its side's storage went with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WorkerGone;

impl std::fmt::Display for WorkerGone {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("the pen pass's object-side worker thread ended")
    }
}

impl std::error::Error for WorkerGone {}

/// The pen's contact pass with its object side on a worker thread ([`with_pen_pair`]).
pub struct PenPair<'p, 'b> {
    scene: PenScene<'p, 'p, 'p>,
    /// The worker, woken when a job is sent.
    worker: Thread,
    world: &'p mut [Vec3],
    found: &'p mut [TetId],
    pen: SideBuffers<'p, 'b>,
    /// `None` only while the worker holds it, inside [`PenPair::pass`].
    object: Option<SideBuffers<'p, 'b>>,
    jobs: Sender<Job<'p, 'b>>,
    done: Receiver<Done<'p, 'b>>,
}

impl std::fmt::Debug for PenPair<'_, '_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PenPair")
            .field("pen_nodes", &self.world.len())
            .field("worker_busy", &self.object.is_none())
            .finish_non_exhaustive()
    }
}

/// Runs `f` with a [`PenPair`] over `scene` and `bufs` (and a worker thread, which ends when
/// `f` returns). The worker places the pen into its own buffer, allocated here, as long as
/// [`PenBuffers::world`].
pub fn with_pen_pair<'p, 'b, R>(
    scene: &PenScene<'p, 'p, 'p>,
    bufs: &'p mut PenBuffers<'b>,
    f: impl FnOnce(&mut PenPair<'p, 'b>) -> R,
) -> R {
    let scene = *scene;
    let mut world2 = vec![Vec3::ZERO; bufs.world.len()];
    let PenBuffers {
        world,
        pen_hits,
        pen_found,
        object_hits,
        pen_pens,
        object_pens,
        pen_depth,
        object_depth,
    } = bufs;
    let (jobs, job_rx) = bounded::<Job<'p, 'b>>(1);
    let (done_tx, done) = bounded::<Done<'p, 'b>>(1);
    std::thread::scope(|sc| {
        let worker_world = &mut world2;
        // The thread that made the pair, woken when a result is sent (a pair used from another
        // thread still works: its waits time out every millisecond).
        let caller = std::thread::current();
        let worker = sc.spawn(move || {
            while let Some(mut job) = wait(&job_rx) {
                let at = pen_place(&scene, worker_world, job.position, job.rotation);
                let report = object_side(
                    &scene,
                    &at,
                    worker_world,
                    job.side.reborrow(),
                    &job.opts,
                    job.listed,
                );
                let sent = done_tx.try_send(Done {
                    report,
                    side: job.side,
                });
                caller.unpark();
                if sent.is_err() {
                    return;
                }
            }
        });
        let worker = worker.thread().clone();
        let mut pair = PenPair {
            scene,
            worker,
            world,
            found: pen_found,
            pen: SideBuffers {
                hits: pen_hits,
                pens: pen_pens,
                depth: pen_depth,
            },
            object: Some(SideBuffers {
                hits: object_hits,
                pens: object_pens,
                depth: object_depth,
            }),
            jobs,
            done,
        };
        let r = f(&mut pair);
        // Dropping the pair closes the job channel: the worker's wait returns `None`.
        let PenPair { worker, jobs, .. } = pair;
        drop(jobs);
        worker.unpark();
        r
    })
}

/// The next message of `rx`: spinning for up to [`SPIN_HOT`], then yielding the core
/// between tries (the other thread of the pair may be waiting for it) up to [`SPIN`], then
/// parked (the sender unparks this thread after each message; a millisecond's timeout
/// covers any wake-up missed); `None` once the sender is gone. Allocates nothing.
fn wait<T>(rx: &Receiver<T>) -> Option<T> {
    let start = Instant::now();
    let mut tries = 0u32;
    loop {
        match rx.try_recv() {
            Ok(v) => return Some(v),
            Err(TryRecvError::Disconnected) => return None,
            Err(TryRecvError::Empty) => {}
        }
        tries = tries.wrapping_add(1);
        if tries < 64 {
            std::hint::spin_loop();
            continue;
        }
        let waited = start.elapsed();
        if waited > SPIN {
            std::thread::park_timeout(Duration::from_millis(1));
        } else if waited > SPIN_HOT {
            std::thread::yield_now();
        } else {
            std::hint::spin_loop();
        }
    }
}

impl<'b> PenPair<'_, 'b> {
    /// [`tetradrill_core::force::pen_pass`] with the object side on the worker: the same
    /// result and the same buffers written, bit for bit. Updates [`PenState::pen_listed`] and
    /// [`PenState::object_listed`]. [`WorkerGone`] when the worker has ended (it cannot
    /// while the core does not panic); the pair is then unusable.
    pub fn pass(
        &mut self,
        position: Vec3,
        rotation: Quat,
        opts: &PenOptions,
        state: &mut PenState,
    ) -> Result<PenPass, WorkerGone> {
        let side = self.object.take().ok_or(WorkerGone)?;
        let job = Job {
            position,
            rotation,
            opts: *opts,
            listed: state.object_listed,
            side,
        };
        // The channel is empty here (each job's result is taken before the next is sent).
        if let Err(e) = self.jobs.try_send(job) {
            self.object = Some(e.into_inner().side);
            return Err(WorkerGone);
        }
        self.worker.unpark();
        let at = pen_place(&self.scene, self.world, position, rotation);
        let pen = pen_side(
            &self.scene,
            &at,
            self.world,
            self.found,
            self.pen.reborrow(),
            opts,
            state.pen_listed,
        );
        let Done { report, side } = wait(&self.done).ok_or(WorkerGone)?;
        self.object = Some(side);
        Ok(at.pass(pen, report, opts, state))
    }

    /// [`tetradrill_core::force::pen_contact`] with the object side on the worker: the same
    /// force, bit for bit.
    pub fn contact(
        &mut self,
        position: Vec3,
        rotation: Quat,
        opts: &PenOptions,
        state: &mut PenState,
    ) -> Result<PenContact, WorkerGone> {
        let pass = self.pass(position, rotation, opts, state)?;
        Ok(pass.contact(
            self.world,
            self.pen.pens,
            self.object_pens(),
            position,
            opts,
            state,
        ))
    }

    /// The pen's nodes at the last pass's pose.
    pub fn world(&self) -> &[Vec3] {
        self.world
    }

    /// The pen nodes' depths of the last pass (the first [`PenPass::penetrations`]`.0`).
    pub fn pen_pens(&self) -> &[Penetration] {
        self.pen.pens
    }

    /// The object nodes' depths of the last pass (the first [`PenPass::penetrations`]`.1`).
    pub fn object_pens(&self) -> &[Penetration] {
        self.object.as_ref().map_or(&[], |s| &*s.pens)
    }
}

/// Where a pen pass runs: on the calling thread ([`pen_pass`] over the buffers) or with its
/// object side on a worker ([`PenPair`]); the same results either way
/// ([`with_pass_runner`]).
pub trait PassRunner {
    /// One contact pass at the pose ([`pen_pass`]).
    fn pass(
        &mut self,
        position: Vec3,
        rotation: Quat,
        opts: &PenOptions,
        state: &mut PenState,
    ) -> Result<PenPass, WorkerGone>;

    /// The depth buffers the passes write (pen nodes, object nodes), whole: the first
    /// [`PenPass::penetrations`] of each are the last pass's.
    fn pens(&self) -> (&[Penetration], &[Penetration]);
}

/// [`PassRunner`] on the calling thread.
#[derive(Debug)]
pub struct OneThread<'r, 'p, 'b> {
    scene: &'r PenScene<'p, 'p, 'p>,
    bufs: &'r mut PenBuffers<'b>,
}

impl PassRunner for OneThread<'_, '_, '_> {
    fn pass(
        &mut self,
        position: Vec3,
        rotation: Quat,
        opts: &PenOptions,
        state: &mut PenState,
    ) -> Result<PenPass, WorkerGone> {
        Ok(pen_pass(
            self.scene, self.bufs, position, rotation, opts, state,
        ))
    }

    fn pens(&self) -> (&[Penetration], &[Penetration]) {
        (self.bufs.pen_pens, self.bufs.object_pens)
    }
}

impl PassRunner for PenPair<'_, '_> {
    fn pass(
        &mut self,
        position: Vec3,
        rotation: Quat,
        opts: &PenOptions,
        state: &mut PenState,
    ) -> Result<PenPass, WorkerGone> {
        PenPair::pass(self, position, rotation, opts, state)
    }

    fn pens(&self) -> (&[Penetration], &[Penetration]) {
        (self.pen_pens(), self.object_pens())
    }
}

/// Runs `f` with the passes on `threads` threads: 1 on the calling thread, 2 with the object
/// side on a worker ([`with_pen_pair`]; any other count is taken as 2).
pub fn with_pass_runner<'p, 'b, R>(
    scene: &PenScene<'p, 'p, 'p>,
    bufs: &'p mut PenBuffers<'b>,
    threads: u32,
    f: impl FnOnce(&mut dyn PassRunner) -> R,
) -> R {
    if threads <= 1 {
        f(&mut OneThread { scene, bufs })
    } else {
        with_pen_pair(scene, bufs, |pair| f(pair))
    }
}
