//! The thin-pen remedy (Praktikum report, section 6): remember where contact began.
//!
//! The consistent depth of a node is measured along the border edges that leave the object.
//! A thin pen pushed sideways has short border edges across its thickness while part of its
//! cross-section is still outside; once the whole cross-section is inside, the only border
//! edges run along the pen to where it leaves the object's far sides, and the force jumps to
//! a large one along the pen. [`EntryPlane`] instead remembers, at the first tick of a contact,
//! the surface plane where the tool entered (the depth-weighted surface points and the
//! direction of the consistent force), and while the contact lasts measures every colliding
//! tool node's depth against that plane. The force stays along the entry normal and grows
//! smoothly with the push. The plane is forgotten when contact ends.

use glam::Vec3;

use crate::depth::Penetration;
use crate::ids::NodeId;

/// The remembered entry plane.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub(crate) struct EntryPlane {
    plane: Option<(Vec3, Vec3)>,
}

impl EntryPlane {
    /// The remembered `(point, outward normal)`, if in contact.
    #[cfg(test)]
    pub(crate) fn plane(&self) -> Option<(Vec3, Vec3)> {
        self.plane
    }

    /// Updates the memory with this tick's penetrations of the tool's nodes and returns the
    /// force: `stiffness * sum max(0, (e - p_i).n) * n` over colliding nodes `p_i`, with the
    /// plane `(e, n)` taken from the first tick of the contact. Returns zero and forgets the
    /// plane when there is no penetration.
    ///
    /// # Bounded work
    /// O(penetrations).
    #[cfg(test)]
    pub(crate) fn force(
        &mut self,
        positions: &[Vec3],
        pens: &[Penetration],
        stiffness: f32,
    ) -> Vec3 {
        self.force_at(|n| positions.get(n.idx()).copied(), pens, stiffness)
    }

    /// [`EntryPlane::force`] with each tool node's position given by `at` (nodes it has none
    /// for are left out).
    ///
    /// # Bounded work
    /// O(penetrations) calls of `at`.
    pub(crate) fn force_at<P: Fn(NodeId) -> Option<Vec3>>(
        &mut self,
        at: P,
        pens: &[Penetration],
        stiffness: f32,
    ) -> Vec3 {
        if pens.is_empty() {
            self.plane = None;
            return Vec3::ZERO;
        }
        if self.plane.is_none() {
            let (mut sp, mut sw, mut sf) = (Vec3::ZERO, 0.0f32, Vec3::ZERO);
            for q in pens {
                let Some(p) = at(q.node) else {
                    continue;
                };
                let w = q.depth.max(0.0);
                sp += (p + q.dir * q.depth) * w;
                sw += w;
                sf += q.dir * w;
            }
            let n = sf.normalize_or_zero();
            if sw.is_nan() || sw <= 0.0 || n == Vec3::ZERO {
                return Vec3::ZERO;
            }
            self.plane = Some((sp / sw, n));
        }
        let Some((e, n)) = self.plane else {
            return Vec3::ZERO;
        };
        let mut d = 0.0f32;
        for q in pens {
            let Some(p) = at(q.node) else {
                continue;
            };
            d += (e - p).dot(n).max(0.0);
        }
        n * (stiffness * d)
    }
}
