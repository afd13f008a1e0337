//! The 8-byte hierarchy node and the 12-byte v_list entry.

use crate::ids::TetId;

/// "No child block" in the 24-bit child field.
pub const NO_BLOCK: u32 = 0x00FF_FFFF;
/// "Not on the v_list".
pub const NO_SLOT: u32 = u32::MAX;
/// Largest number of child blocks an arena can hold (24-bit block index, one value reserved).
pub const MAX_BLOCKS: usize = NO_BLOCK as usize;

const VIS_SHIFT: u32 = 24;
const ERASED: u32 = 1 << 28;
const INVERTED: u32 = 1 << 29;

/// One node of a subdivision tree: 8 bytes.
///
/// `word`: bits 0-23 the index of its block of 8 children in the arena ([`NO_BLOCK`] for a
/// leaf), bits 24-27 the visible-face bits (bit `24 + i` for face `i`), bit 28 erased, bit 29
/// inverted (vertex order opposite to the root's, from T6/T8 steps). `slot`: its index in the
/// v_list of non-erased leaves with a visible face, or [`NO_SLOT`].
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[repr(C)]
pub struct HNode {
    word: u32,
    slot: u32,
}

/// Bytes per hierarchy node, pinned at compile time.
pub const NODE_BYTES: usize = core::mem::size_of::<HNode>();
const _: () = assert!(NODE_BYTES == 8, "a hierarchy node must stay within 8 bytes");

impl Default for HNode {
    fn default() -> Self {
        Self::LEAF
    }
}

impl HNode {
    /// A fresh leaf: no children, nothing visible, not erased, not on the v_list.
    pub const LEAF: Self = Self {
        word: NO_BLOCK,
        slot: NO_SLOT,
    };

    /// A fresh leaf with the given orientation bit.
    #[inline]
    pub const fn leaf(inverted: bool) -> Self {
        Self {
            word: NO_BLOCK | if inverted { INVERTED } else { 0 },
            slot: NO_SLOT,
        }
    }

    /// Child block index, or `None` for a leaf.
    #[inline]
    pub const fn block(self) -> Option<u32> {
        let b = self.word & NO_BLOCK;
        if b == NO_BLOCK {
            None
        } else {
            Some(b)
        }
    }

    /// `true` when the node has no children.
    #[inline]
    pub const fn is_leaf(self) -> bool {
        self.word & NO_BLOCK == NO_BLOCK
    }

    #[inline]
    pub(crate) fn set_block(&mut self, b: u32) {
        self.word = (self.word & !NO_BLOCK) | (b & NO_BLOCK);
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

    /// `true` when the vertex order is inverted relative to the root (T6/T8 steps).
    #[inline]
    pub const fn inverted(self) -> bool {
        self.word & INVERTED != 0
    }

    /// The node's v_list slot, or [`NO_SLOT`].
    #[inline]
    pub const fn slot(self) -> u32 {
        self.slot
    }

    #[inline]
    pub(crate) fn set_slot(&mut self, s: u32) {
        self.slot = s;
    }
}

/// One v_list entry: a non-erased leaf with at least one visible face. 12 bytes.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[repr(C)]
pub struct VEntry {
    /// The coarse tet whose tree holds the leaf.
    pub tet: TetId,
    /// Its tree index.
    pub index: u32,
    /// Its node reference (see [`super::Hierarchy::node`]).
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
