//! [`SphereMemo`]: the bounding spheres of hierarchy nodes, remembered across contact searches.
//!
//! A node's bounding sphere is a function of its coarse tet and its tree index only while the
//! mesh does not move, so a remembered sphere never goes stale, whatever the drill erases,
//! refines or takes back; a world whose nodes move empties the memo ([`SphereMemo::clear`]). The contact search of a slowly moving burr tests the same nodes step
//! after step; on a Cortex-M4 evaluating a node's corners and sphere is about half of a node
//! test (a software square root among it). The memo is direct mapped over caller storage: one
//! slot per key, a newer sphere takes the slot of an older one. Whether a sphere comes from the
//! memo or is evaluated, its bits are the same, so a search gives the same answer, the same node
//! count and the same resume place with any memo, or none.

use glam::Vec3;

use crate::ids::TetId;

/// One remembered sphere (24 bytes; all zero bytes when empty, so a static array of them
/// needs no initial data).
#[derive(Clone, Copy, PartialEq, Debug, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct SphereSlot {
    /// The tet's number plus one (0: empty).
    tet1: u32,
    index: u32,
    mid: Vec3,
    rad: f32,
}

impl SphereSlot {
    /// An empty slot.
    pub const EMPTY: Self = Self {
        tet1: 0,
        index: 0,
        mid: Vec3::ZERO,
        rad: 0.0,
    };
}

impl Default for SphereSlot {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// Bounding spheres of hierarchy nodes keyed by `(tet, tree index)`, over caller storage.
/// An empty slice remembers nothing (every look-up misses).
#[derive(Debug)]
pub struct SphereMemo<'a> {
    slots: &'a mut [SphereSlot],
    hits: u32,
    misses: u32,
}

impl<'a> SphereMemo<'a> {
    /// A memo over `slots`, emptied.
    ///
    /// # Bounded work
    /// O(slots).
    pub fn new(slots: &'a mut [SphereSlot]) -> Self {
        slots.fill(SphereSlot::EMPTY);
        Self {
            slots,
            hits: 0,
            misses: 0,
        }
    }

    /// Forgets every sphere (the hit and miss counts stay): for a mesh whose nodes moved, as
    /// the spheres are measured on the positions.
    ///
    /// # Bounded work
    /// O(slots).
    pub(crate) fn clear(&mut self) {
        self.slots.fill(SphereSlot::EMPTY);
    }

    /// Slots in the memo.
    #[cfg(test)]
    pub(crate) fn capacity(&self) -> usize {
        self.slots.len()
    }

    /// Look-ups answered from the memo so far (saturating).
    pub fn hits(&self) -> u32 {
        self.hits
    }

    /// Look-ups that missed so far (saturating).
    pub fn misses(&self) -> u32 {
        self.misses
    }

    #[inline]
    fn slot(&self, tet: TetId, index: u32) -> usize {
        let n = self.slots.len();
        if n == 0 {
            return 0;
        }
        let h = tet.0.wrapping_mul(0x9e37_79b1) ^ index.wrapping_mul(0x85eb_ca77);
        (h ^ (h >> 15)) as usize % n
    }

    /// The sphere `(centre, radius)` remembered for node `index` of `tet`, if any
    /// ([`TetId::NONE`] never has one).
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn get(&mut self, tet: TetId, index: u32) -> Option<(Vec3, f32)> {
        let k = self.slot(tet, index);
        match self.slots.get(k) {
            Some(s) if s.tet1 == tet.0.wrapping_add(1) && s.index == index && s.tet1 != 0 => {
                self.hits = self.hits.saturating_add(1);
                Some((s.mid, s.rad))
            }
            _ => {
                self.misses = self.misses.saturating_add(1);
                None
            }
        }
    }

    /// Remembers `sphere` for node `index` of `tet` (in place of whatever had its slot;
    /// nothing for [`TetId::NONE`]).
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn put(&mut self, tet: TetId, index: u32, sphere: (Vec3, f32)) {
        let k = self.slot(tet, index);
        if let Some(s) = self.slots.get_mut(k).filter(|_| tet != TetId::NONE) {
            *s = SphereSlot {
                tet1: tet.0.wrapping_add(1),
                index,
                mid: sphere.0,
                rad: sphere.1,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Keys that share a slot evict each other; a key is only ever answered with its own
    /// sphere; an empty memo misses and holds nothing.
    #[test]
    fn answers_only_its_own_key() {
        let mut slots = [SphereSlot::default(); 3];
        let mut m = SphereMemo::new(&mut slots);
        let sphere = |k: u32| (Vec3::splat(k as f32), k as f32 * 0.5);
        for k in 0..40u32 {
            m.put(TetId(k % 7), k, sphere(k));
        }
        let mut held = 0;
        for k in 0..40u32 {
            if let Some(s) = m.get(TetId(k % 7), k) {
                assert_eq!(s, sphere(k));
                held += 1;
            }
            assert_eq!(m.get(TetId(k % 7 + 1), k), None);
        }
        assert!((1..=3).contains(&held), "{held} held in 3 slots");
        assert_eq!(m.hits(), held);
        m.put(TetId::NONE, 0, sphere(9));
        assert_eq!(m.get(TetId::NONE, 0), None);
        let mut none = SphereMemo::new(&mut []);
        none.put(TetId(1), 2, sphere(3));
        assert_eq!(none.get(TetId(1), 2), None);
        assert_eq!(none.capacity(), 0);
    }
}
