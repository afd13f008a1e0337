//! The 8-byte hierarchy node and the 12-byte v_list entry.

use crate::ids::TetId;

/// "No child block": what [`HNode::block`] never returns (the largest 24-bit value).
pub(crate) const NO_BLOCK: u32 = 0x00FF_FFFF;
/// "Not on the v_list".
pub(crate) const NO_SLOT: u32 = u32::MAX;
/// Largest number of child blocks an arena can hold (24-bit field storing `block + 1`, zero
/// for a leaf).
pub(crate) const MAX_BLOCKS: usize = NO_BLOCK as usize;

const BLOCK_MASK: u32 = 0x00FF_FFFF;
const VIS_SHIFT: u32 = 24;
const ERASED: u32 = 1 << 28;
const INVERTED: u32 = 1 << 29;
const SURFACE: u32 = 1 << 30;
const HOLLOW: u32 = 1 << 31;

/// One node of a subdivision tree: 8 bytes, all zero for a fresh leaf ([`HNode::LEAF`]), so
/// statics of nodes can start in `.bss`.
///
/// `word`: bits 0-23 the index of its block of 8 children in the arena plus one (0 for a
/// leaf), bits 24-27 the visible-face bits (bit `24 + i` for face `i`), bit 28 erased, bit 29
/// inverted (vertex order opposite to the root's, from T6/T8 steps), bit 30 *surface*: the
/// subtree holds a v_list leaf (for a leaf: it is on the v_list), kept exact by Erase and
/// Refine so walks over the drilled surface skip erased and interior material, bit 31
/// *hollow*: an inner node every leaf below which is erased (its subtree can be given back,
/// see [`super::Hierarchy::arena_reclaimable`]). `slot`: its index in the v_list of
/// non-erased leaves with a visible face plus one, 0 when not there; an erased leaf is never
/// on the v_list, so its `slot` word is spare: the arena's list of reclaimable blocks is
/// threaded through the spare words of the blocks' own erased leaves.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct HNode {
    word: u32,
    slot: u32,
}

/// Bytes per hierarchy node, pinned at compile time.
pub const NODE_BYTES: usize = core::mem::size_of::<HNode>();
const _: () = assert!(NODE_BYTES == 8, "a hierarchy node must stay within 8 bytes");

impl HNode {
    /// A fresh leaf: no children, nothing visible, not erased, not on the v_list. All zero
    /// bytes (it is also `HNode::default()`).
    pub const LEAF: Self = Self { word: 0, slot: 0 };

    /// A fresh leaf with the given orientation bit.
    #[inline]
    pub const fn leaf(inverted: bool) -> Self {
        Self {
            word: if inverted { INVERTED } else { 0 },
            slot: 0,
        }
    }

    /// Child block index, or `None` for a leaf.
    #[inline]
    pub const fn block(self) -> Option<u32> {
        let b = self.word & BLOCK_MASK;
        if b == 0 {
            None
        } else {
            Some(b - 1)
        }
    }

    /// `true` when the node has no children.
    #[inline]
    pub const fn is_leaf(self) -> bool {
        self.word & BLOCK_MASK == 0
    }

    /// Sets the child block (`b < MAX_BLOCKS`; larger values are masked).
    #[inline]
    pub(crate) fn set_block(&mut self, b: u32) {
        self.word = (self.word & !BLOCK_MASK) | (b.wrapping_add(1) & BLOCK_MASK);
    }

    /// The four visible-face bits (bit `i` for face `i`).
    #[inline]
    pub const fn visible(self) -> u8 {
        ((self.word >> VIS_SHIFT) & 0xF) as u8
    }

    #[inline]
    pub(crate) fn set_visible(&mut self, bits: u8) {
        self.word = (self.word & !(0xF << VIS_SHIFT)) | (((bits & 0xF) as u32) << VIS_SHIFT);
    }

    /// `true` once the node has been erased.
    #[inline]
    pub const fn erased(self) -> bool {
        self.word & ERASED != 0
    }

    #[inline]
    pub(crate) fn set_erased(&mut self) {
        self.word |= ERASED;
    }

    /// `true` when every leaf of the node's subtree is erased: an erased leaf, or a *hollow*
    /// inner node.
    #[inline]
    pub const fn all_erased(self) -> bool {
        self.word & (ERASED | HOLLOW) != 0
    }

    /// `true` for an erased leaf (erased, no children).
    #[inline]
    pub const fn erased_leaf(self) -> bool {
        self.word & (ERASED | BLOCK_MASK) == ERASED
    }

    /// Marks an inner node hollow (every leaf below erased).
    #[inline]
    pub(crate) fn set_hollow(&mut self) {
        self.word |= HOLLOW;
    }

    /// `true` when the raw hollow bit is set (an inner node whose leaves are all erased).
    #[inline]
    pub(crate) const fn hollow(self) -> bool {
        self.word & HOLLOW != 0
    }

    /// Turns a hollow inner node into an erased leaf (its children block is given back):
    /// no children, no visible faces, not on the v_list, no surface below; the orientation bit
    /// stays.
    #[inline]
    pub(crate) fn collapse(&mut self) {
        self.word = (self.word & INVERTED) | ERASED;
        self.slot = 0;
    }

    /// The spare word of an erased leaf (its unused v_list slot), raw.
    #[inline]
    pub(crate) const fn spare(self) -> u32 {
        self.slot
    }

    /// Writes the spare word of an erased leaf (callers only do so on erased leaves).
    #[inline]
    pub(crate) fn set_spare(&mut self, w: u32) {
        self.slot = w;
    }

    /// `true` when the vertex order is inverted relative to the root (T6/T8 steps).
    #[inline]
    pub const fn inverted(self) -> bool {
        self.word & INVERTED != 0
    }

    /// `true` when the node's subtree holds a leaf of the v_list (a non-erased leaf with a
    /// visible face); for a leaf, `true` iff it is on the v_list.
    #[inline]
    pub const fn surface(self) -> bool {
        self.word & SURFACE != 0
    }

    #[inline]
    pub(crate) fn set_surface(&mut self, on: bool) {
        if on {
            self.word |= SURFACE;
        } else {
            self.word &= !SURFACE;
        }
    }

    /// The node's v_list slot, or `NO_SLOT` (always for an erased node, whose slot word
    /// is spare).
    #[inline]
    pub const fn slot(self) -> u32 {
        if self.word & ERASED != 0 {
            NO_SLOT
        } else {
            self.slot.wrapping_sub(1)
        }
    }

    #[inline]
    pub(crate) fn set_slot(&mut self, s: u32) {
        self.slot = s.wrapping_add(1);
    }
}

/// One v_list entry: a non-erased leaf with at least one visible face. 12 bytes.
#[derive(Clone, Copy, PartialEq, Eq, Debug, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct VEntry {
    /// The coarse tet whose tree holds the leaf.
    pub tet: TetId,
    /// Its tree index.
    pub index: u32,
    /// Its node reference (see `super::Hierarchy::node`).
    pub node: u32,
}

impl Default for VEntry {
    fn default() -> Self {
        Self {
            tet: TetId::NONE,
            index: 0,
            node: NO_SLOT,
        }
    }
}

const _: () = assert!(core::mem::size_of::<VEntry>() == 12);
