//! The lock-free hand-offs between the servo and the simulation: two single-producer
//! single-consumer queues (`heapless::spsc`), one each way. Each end is a local resource of
//! exactly one task, so neither side ever takes a lock or masks an interrupt: an enqueue or a
//! dequeue is a few loads and stores and one atomic store of an index (no critical section:
//! 0 instructions with interrupts masked on the hand-off path).

use heapless::spsc::{Consumer, Producer, Queue};

use tetradrill_core::servo::ContactState;
use tetradrill_core::Vec3;

/// Slots of each queue (one fewer usable): the servo releases one step a tick and the
/// simulation finishes it before the next tick, so at most two messages wait at once (the last
/// step and [`Release::Finish`]).
pub const SLOTS: usize = 4;

/// What the servo hands the simulation.
#[derive(Clone, Copy, Debug)]
pub enum Release {
    /// Run the simulation step of servo tick `tick` at this pose.
    Step {
        /// The servo tick that released the step.
        tick: u32,
        /// Tool centre read from the device at that tick.
        position: Vec3,
        /// The drill button.
        drill_on: bool,
        /// The magnitude of the force this tick wrote, newtons: it presses the burr into the
        /// material in the step it releases (`World::set_pressing`, as the host's replay with
        /// `servo_lag` 1 feeds it).
        pressing: f32,
        /// The force this tick wrote: its reaction pushes the soft body (the host's
        /// `SoftDriver` takes the same force after the same step).
        #[cfg(scenario_soft)]
        force: Vec3,
        /// Instructions the servo tick took from the timer event to this release.
        servo_instructions: u32,
    },
    /// The script is over: print the results and leave QEMU.
    Finish(crate::servo::Summary),
}

/// What the simulation hands back: the contact of one finished step.
#[derive(Clone, Copy, Debug)]
pub struct Done {
    /// The servo tick whose release the step ran.
    pub tick: u32,
    /// The contact plane the step found.
    pub contact: ContactState,
}

/// The servo's end of the pose queue.
pub type ReleaseTx = Producer<'static, Release>;
/// The simulation's end of the pose queue.
pub type ReleaseRx = Consumer<'static, Release>;
/// The simulation's end of the contact queue.
pub type DoneTx = Producer<'static, Done>;
/// The servo's end of the contact queue.
pub type DoneRx = Consumer<'static, Done>;
/// A queue of releases.
pub type ReleaseQueue = Queue<Release, SLOTS>;
/// A queue of finished steps.
pub type DoneQueue = Queue<Done, SLOTS>;
