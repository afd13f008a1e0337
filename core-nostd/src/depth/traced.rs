//! The traced intersection (seed 000 section 4): walk the line through B's tets.

use glam::Vec3;

use super::surface::{exit_values, hit_on_face, on_edge, SurfaceHit};
use crate::collide::Body;
use crate::ids::TetId;

/// Follows the line `p -> q` from tet `start` (which holds `p`) through neighbours until it
/// leaves `body` through a boundary face; returns that crossing if it lies on the segment.
/// `steps` receives the tets crossed.
///
/// # Bounded work
/// At most `max_steps` tets, four face tests each. A walk that needs more, or that finds no
/// exit face (rounding on a degenerate configuration), returns `None`.
pub fn trace_to_surface(
    body: &Body<'_, '_>,
    start: TetId,
    p: Vec3,
    q: Vec3,
    max_steps: u32,
    steps: &mut u32,
) -> Option<SurfaceHit> {
    trace_exit(body, start, p, q, max_steps, steps).filter(on_edge)
}

/// Where the line from `p` towards `q` first leaves `body` through a boundary face, walking
/// from `start` (which holds `p`), wherever that is along the line (`s` may exceed 1).
///
/// # Bounded work
/// As [`trace_to_surface`].
pub(crate) fn trace_exit(
    body: &Body<'_, '_>,
    start: TetId,
    p: Vec3,
    q: Vec3,
    max_steps: u32,
    steps: &mut u32,
) -> Option<SurfaceHit> {
    let mut t = start;
    let mut entry = 4u8;
    for _ in 0..max_steps {
        *steps = steps.wrapping_add(1);
        let mut exit = None;
        for f in 0..4u8 {
            if f == entry {
                continue;
            }
            if let Some(e) = exit_values(body, t, f, p, q) {
                exit = Some((f, e));
                break;
            }
        }
        let (f, e) = exit?;
        let nb = body.neighbour(t, f);
        if nb.is_none() {
            return hit_on_face(body, t, f, e, p, q);
        }
        entry = body
            .mesh
            .tets()
            .get(t.idx())?
            .reverse
            .get(f as usize)?
            .face();
        t = nb;
    }
    None
}
