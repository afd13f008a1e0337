//! Where a border edge crosses the other body's surface ([`crossing`], by either method), and
//! the face it crossed last tick, remembered and tried first ([`Crossing`], [`reuse`]).

use glam::Vec3;

use super::hashed::hashed_hit;
use super::propagate::DepthReport;
use super::surface::{exit_values, hit_on_face, on_edge, SurfaceHit, S_SLACK};
use super::traced::trace_exit;
use super::Method;
use crate::collide::Body;
use crate::ids::TetId;
use crate::mesh::FaceUse;

/// The boundary face of B where one directed edge of A's graph last left B (see
/// [`DepthScratch::with_crossings`](super::DepthScratch::with_crossings)).
#[derive(Clone, Copy, PartialEq, Eq, Debug, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Crossing {
    /// The face's tet ([`TetId::NONE`]: no crossing remembered).
    tet: TetId,
    /// The face's local index in `tet` (a word: no padding, so a block of bytes can hold it).
    local: u32,
}

impl Crossing {
    /// The remembered face.
    pub(super) fn face(self) -> FaceUse {
        FaceUse {
            tet: self.tet,
            local: self.local as u8,
        }
    }

    /// `face` remembered.
    pub(super) fn of(face: FaceUse) -> Self {
        Self {
            tet: face.tet,
            local: u32::from(face.local),
        }
    }
}

impl Default for Crossing {
    fn default() -> Self {
        Self {
            tet: TetId::NONE,
            local: 0,
        }
    }
}

/// The remembered face's crossing when the edge `p -> q` still leaves B through it, on the
/// edge.
pub(super) fn reuse(
    b: &Body<'_, '_>,
    face: FaceUse,
    p: Vec3,
    q: Vec3,
    r: &mut DepthReport,
) -> Option<SurfaceHit> {
    if face.tet.is_none() {
        return None;
    }
    r.work = r.work.wrapping_add(1);
    let e = exit_values(b, face.tet, face.local, p, q)?;
    let h = hit_on_face(b, face.tet, face.local, e, p, q).filter(on_edge)?;
    r.reused += 1;
    Some(h)
}

/// Where the border edge `p -> q` (p in tet `tet` of B) leaves B: on the edge, or with
/// `past = Some(max_steps)` (a partial list) also past `q`.
pub(super) fn crossing(
    b: &Body<'_, '_>,
    tet: TetId,
    p: Vec3,
    q: Vec3,
    method: &Method<'_>,
    past: Option<u32>,
    r: &mut DepthReport,
) -> Option<SurfaceHit> {
    match method {
        Method::Traced { max_steps } => traced_crossing(b, tet, p, q, *max_steps, past, r),
        Method::Hashed {
            faces,
            world_to_hash,
            max_cells,
        } => {
            let on = hashed_hit(faces, world_to_hash, b, p, q, *max_cells, &mut r.work);
            if on.is_some() {
                return on;
            }
            let h = trace_exit(b, tet, p, q, past?, &mut r.work)?;
            beyond(h, r)
        }
    }
}

/// [`crossing`] with [`Method::Traced`]: the walk stops at the first boundary face, on the
/// edge or past its end.
#[inline(always)]
pub(super) fn traced_crossing(
    b: &Body<'_, '_>,
    tet: TetId,
    p: Vec3,
    q: Vec3,
    max_steps: u32,
    past: Option<u32>,
    r: &mut DepthReport,
) -> Option<SurfaceHit> {
    let h = trace_exit(b, tet, p, q, max_steps, &mut r.work)?;
    if on_edge(&h) {
        Some(h)
    } else if past.is_some() {
        beyond(h, r)
    } else {
        None
    }
}

/// A crossing past the edge's end (`s` beyond 1), counted in [`DepthReport::beyond`].
fn beyond(h: SurfaceHit, r: &mut DepthReport) -> Option<SurfaceHit> {
    (h.s > 1.0 + S_SLACK).then(|| {
        r.beyond += 1;
        h
    })
}
