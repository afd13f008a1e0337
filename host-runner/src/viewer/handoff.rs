//! What the simulation hands the viewer, and what the viewer hands back: snapshots through a
//! bounded queue that refuses instead of blocking, controls through a triple buffer.
//!
//! Both directions are lock-free: the simulation only ever `try_publish`es (a full queue hands
//! the snapshot back, and the simulation keeps the changed tets for the next one), the viewer
//! only ever drains. A slow viewer therefore sees fewer, larger snapshots; it never slows the
//! simulation or the servo down.

use std::sync::atomic::{AtomicU64, Ordering};

use crossbeam::queue::ArrayQueue;
use tetradrill_core::{Quat, Vec3};

/// What the simulation publishes for the status line and the summary.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SimStatus {
    /// Simulation steps done.
    pub steps: u64,
    /// Removed volume.
    pub removed_volume: f64,
    /// Hierarchy nodes.
    pub hierarchy_nodes: usize,
    /// Visible faces.
    pub visible_faces: u32,
    /// Saturations so far, all kinds.
    pub saturations: u32,
    /// Last step's compute time, ns.
    pub last_step_ns: u64,
    /// Longest step, ns.
    pub max_step_ns: u64,
    /// The force pressing the burr into the material at the last step, newtons.
    pub press_n: f32,
    /// The pressure threshold of the material under the burr, newtons (`None` without a
    /// contact, without regions, or for a material removed at once whatever the force).
    pub threshold_n: Option<f32>,
    /// The smooth normals' saturations (corners that found no free vertex, times the queue
    /// was full; [`tetradrill_core::hierarchy::SmoothStats`]).
    pub smooth_saturations: u32,
    /// The smooth normals' work left for later snapshots (0: every normal is current).
    pub smooth_pending: u32,
}

/// Snapshots the queue holds: a viewer more than this many snapshots behind makes the
/// simulation merge its changes into later ones.
pub const SNAPSHOT_QUEUE: usize = 4;

/// Least time between two snapshots (about 60 Hz).
pub const SNAPSHOT_PERIOD_NS: u64 = 16_000_000;

/// One visible triangle as the viewer draws it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SurfTri {
    /// Corners, counter-clockwise seen from outside the material.
    pub corners: [[f32; 3]; 3],
    /// Each corner's smooth normal (unit), or zero where the face is shaded flat.
    pub normals: [[f32; 3]; 3],
    /// Not on the original boundary: material was drilled away here.
    pub drilled: bool,
}

/// The visible triangles of one coarse tet's tree (all of them: it replaces what the viewer
/// had for that tet; an empty patch removes the tet's triangles).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Patch {
    /// Coarse tet.
    pub tet: u32,
    /// Its visible triangles.
    pub tris: Vec<SurfTri>,
}

/// Tool and force at a snapshot.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ToolView {
    /// Tool centre as the device puts it (may be inside the material).
    pub position: Vec3,
    /// Displayed, non-penetrating centre: on the contact plane (`position + depth * normal`,
    /// which is `position + F_spring / stiffness`).
    pub shown: Vec3,
    /// Burr radius.
    pub radius: f32,
    /// Force on the tool, newtons (mesh frame).
    pub force: Vec3,
    /// Drill on.
    pub drilling: bool,
    /// The tool's rotation (a mesh tool's; the burr's sphere ignores it).
    pub rotation: Quat,
    /// A drill's shaft, drawn from the burr along the tool's axis.
    pub shaft: Option<ShaftView>,
}

/// A drill's shaft as drawn: a row of spheres of its radius along its axis, as its passive
/// points sample it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ShaftView {
    /// Unit axis, burr to handle.
    pub axis: Vec3,
    /// Where the shaft starts, from the burr's centre (the burr's radius).
    pub from: f32,
    /// Length, burr centre to handle.
    pub length: f32,
    /// Radius.
    pub radius: f32,
}

/// A tool drawn as a mesh (the pen): its boundary triangles in its own frame (tip at the
/// origin, counter-clockwise seen from outside), drawn at a [`ToolView`]'s `shown` and
/// `rotation`. Shared, never copied: full snapshots carry the same allocation.
pub type ToolShape = std::sync::Arc<[[Vec3; 3]]>;

/// The colour slot of every coarse tet's region (see [`region_slots`]). Shared, never
/// copied: full snapshots carry the same allocation.
pub type RegionSlots = std::sync::Arc<[u8]>;

/// Region colours besides the surface's own: a mesh's regions take the surface colour (its
/// smallest label) and then these slots in turn.
pub const REGION_SLOTS: u8 = 8;

/// The colour slot of each tet from its region label: the smallest label present gets slot
/// 0 (the surface colour), the next ones slots 1, 2, ... in label order, wrapping after
/// [`REGION_SLOTS`] - 1 colours. `None` when every tet has the same label (nothing to tell
/// apart).
pub fn region_slots(labels: &[i32]) -> Option<RegionSlots> {
    let mut distinct: Vec<i32> = labels.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.len() < 2 {
        return None;
    }
    let slot = |l: i32| {
        let i = distinct.binary_search(&l).unwrap_or(0);
        if i == 0 {
            0
        } else {
            (1 + (i - 1) % (REGION_SLOTS as usize - 1)) as u8
        }
    };
    Some(labels.iter().map(|&l| slot(l)).collect())
}

/// One snapshot from the simulation.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Snapshot {
    /// Sequence number (1, 2, ...).
    pub seq: u64,
    /// The patches cover the whole surface: drop every triangle first.
    pub full: bool,
    /// Changed coarse tets.
    pub patches: Vec<Patch>,
    /// Tool and force.
    pub tool: ToolView,
    /// Simulation status.
    pub status: SimStatus,
    /// Initial volume of the mesh.
    pub initial_volume: f64,
    /// A mesh tool's shape (full snapshots only; `None` leaves the viewer's as it is).
    pub tool_shape: Option<ToolShape>,
    /// The object's region colours (full snapshots only; `None` leaves the viewer's as it
    /// is).
    pub regions: Option<RegionSlots>,
    /// The colour the scenario gives each region, in label order (full snapshots only;
    /// `None` leaves the viewer's as it is).
    pub region_colours: Option<RegionColours>,
    /// The regions on a grid, for the clip plane's section (full snapshots only; `None`
    /// leaves the viewer's as it is).
    pub labels: Option<super::labels::LabelGridRef>,
}

/// The colour a scenario gives each region (`[regions.LABEL] colour`), in label order, as
/// linear RGB; `None` where it sets none (the palette's colour for that slot).
pub type RegionColours = std::sync::Arc<[Option<[f32; 3]>]>;

/// The snapshot queue: the simulation publishes, the viewer drains.
#[derive(Debug)]
pub struct SnapshotQueue {
    queue: ArrayQueue<Box<Snapshot>>,
    refused: AtomicU64,
    full_wanted: std::sync::atomic::AtomicBool,
}

impl Default for SnapshotQueue {
    fn default() -> Self {
        Self::with_capacity(SNAPSHOT_QUEUE)
    }
}

impl SnapshotQueue {
    /// A queue of `capacity` snapshots (at least 1).
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            queue: ArrayQueue::new(capacity.max(1)),
            refused: AtomicU64::new(0),
            full_wanted: std::sync::atomic::AtomicBool::new(false),
        }
    }

    /// Hands `s` to the viewer without waiting; a full queue gives it back (and counts it).
    ///
    /// # Errors
    /// The snapshot, when the queue is full.
    pub fn try_publish(&self, s: Snapshot) -> Result<(), Box<Snapshot>> {
        self.queue.push(Box::new(s)).inspect_err(|_| {
            self.refused.fetch_add(1, Ordering::Relaxed);
        })
    }

    /// `true` when a snapshot would be refused now (then counted as refused: the caller
    /// keeps its changes for a later snapshot).
    pub fn refuses(&self) -> bool {
        let full = self.queue.is_full();
        if full {
            self.refused.fetch_add(1, Ordering::Relaxed);
        }
        full
    }

    /// The oldest snapshot not taken yet.
    pub fn take(&self) -> Option<Snapshot> {
        self.queue.pop().map(|b| *b)
    }

    /// Snapshots refused so far (the simulation merged them into later ones).
    pub fn refused(&self) -> u64 {
        self.refused.load(Ordering::Relaxed)
    }

    /// Asks the simulation for a full snapshot (the viewer lost track, e.g. a new GL context).
    pub fn request_full(&self) {
        self.full_wanted.store(true, Ordering::Relaxed);
    }

    /// Takes the request for a full snapshot.
    pub fn full_requested(&self) -> bool {
        self.full_wanted.swap(false, Ordering::Relaxed)
    }
}

/// What the viewer's controls ask of the simulation (and, through atomics, of the servo).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Controls {
    /// Burr radius (mesh units): the drill spheres and the servo's contact.
    pub radius: f32,
    /// Spring stiffness of the servo force (N per mesh unit).
    pub stiffness: f32,
    /// Deepest refinement level of the drill.
    pub max_depth: u8,
    /// Erosion paused: the burr still touches (force stays on), nothing is removed.
    pub paused: bool,
    /// Incremented on each press of Reset: the simulation rebuilds the untouched world.
    pub reset: u32,
}

/// The viewer's end of the control hand-off (a triple buffer: the last write wins).
pub type ControlsIn = triple_buffer::Input<Controls>;
/// The simulation's end of the control hand-off.
pub type ControlsOut = triple_buffer::Output<Controls>;

/// A control hand-off starting at `initial`.
pub fn controls(initial: Controls) -> (ControlsIn, ControlsOut) {
    triple_buffer::TripleBuffer::new(&initial).split()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_queue_hands_the_snapshot_back() {
        let q = SnapshotQueue::with_capacity(2);
        for seq in 1..=2 {
            assert!(q
                .try_publish(Snapshot {
                    seq,
                    ..Snapshot::default()
                })
                .is_ok());
        }
        let back = q.try_publish(Snapshot {
            seq: 3,
            ..Snapshot::default()
        });
        assert_eq!(back.map_err(|s| s.seq), Err(3));
        assert_eq!(q.refused(), 1);
        assert_eq!(q.take().map(|s| s.seq), Some(1));
        assert!(q
            .try_publish(Snapshot {
                seq: 3,
                ..Snapshot::default()
            })
            .is_ok());
    }
}
