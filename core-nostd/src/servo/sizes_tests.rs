//! The carving of a world's storage (`sizes.rs`, `crate::storage`): sizes, lines,
//! placement, starting values, refusals.

use glam::Vec3;

use crate::drill::Pending;
use crate::hash::{Aabb, HashEntry};
use crate::hierarchy::{HNode, HierarchySizes, HierarchyStorage, SphereSlot, VEntry};
use crate::ids::TetId;
use crate::servo::{SpareStorage, WorldSizes, WorldStorage};
use crate::storage::*;

/// Small sizes with every part of a different, odd length (so a wrong order or a wrong
/// length shows).
fn odd_sizes() -> WorldSizes {
    let mut s = WorldSizes::new(13, 8 * 9);
    s.pending = 7;
    s.candidates = 5;
    s.sphere_memo = 3;
    s.changes = 11;
    s
}

fn line_aligned<T>(s: &[T]) -> bool {
    (s.as_ptr() as usize).is_multiple_of(LINE)
}

#[test]
fn a_block_of_the_sizes_lines_holds_every_part_and_nothing_more() {
    let sizes = odd_sizes();
    let n = sizes.lines().unwrap();
    // The lines by hand: each part's bytes rounded up to 64.
    let by_hand: usize = [
        sizes.hash_starts * 4,
        sizes.hash_entries * 16,
        sizes.tet_boxes * 24,
        sizes.roots * 8,
        sizes.arena * 8,
        sizes.vlist * 12,
        sizes.changes * 4,
        sizes.pending * 64,
        sizes.candidates * 4,
        sizes.sphere_memo * 24,
    ]
    .iter()
    .map(|b| b.div_ceil(64))
    .sum();
    assert_eq!(n, by_hand);
    assert_eq!(sizes.bytes(), Some(64 * by_hand));

    let mut lines = [Line::ZERO; 128];
    let mut block = Block::from_lines(&mut lines[..n]);
    let st = WorldStorage::carve(&sizes, &mut block).unwrap();
    assert_eq!(block.left(), 0);
    assert_eq!(st.hash_starts.len(), sizes.hash_starts);
    assert_eq!(st.hash_entries.len(), sizes.hash_entries);
    assert_eq!(st.tet_boxes.len(), sizes.tet_boxes);
    assert_eq!(st.hierarchy.roots.len(), sizes.roots);
    assert_eq!(st.hierarchy.arena.len(), sizes.arena);
    assert_eq!(st.hierarchy.vlist.len(), sizes.vlist);
    assert_eq!(st.hierarchy.changes.len(), sizes.changes);
    assert_eq!(st.pending.len(), sizes.pending);
    assert_eq!(st.candidates.len(), sizes.candidates);
    assert_eq!(st.sphere_memo.len(), sizes.sphere_memo);
    assert!(line_aligned(st.hash_starts) && line_aligned(st.hash_entries));
    assert!(line_aligned(st.tet_boxes) && line_aligned(st.hierarchy.roots));
    assert!(line_aligned(st.hierarchy.arena) && line_aligned(st.hierarchy.vlist));
    assert!(line_aligned(st.hierarchy.changes));
    assert!(line_aligned(st.pending) && line_aligned(st.candidates));
    assert!(line_aligned(st.sphere_memo));
}

#[test]
fn one_line_short_names_the_last_part() {
    let sizes = odd_sizes();
    let n = sizes.lines().unwrap();
    let mut lines = [Line::ZERO; 128];
    let e = WorldStorage::carve(&sizes, &mut Block::from_lines(&mut lines[..n - 1])).unwrap_err();
    assert_eq!(
        e,
        StorageError::TooSmall {
            part: Part::SphereMemo,
            needed: 3 * 24,
            left: 64
        }
    );
    // An empty block fails at the first part.
    let e = WorldStorage::carve(&sizes, &mut Block::new(&mut [])).unwrap_err();
    assert!(matches!(
        e,
        StorageError::TooSmall {
            part: Part::HashStarts,
            left: 0,
            ..
        }
    ));
}

#[test]
fn every_slot_starts_at_its_value_whatever_the_memory_held() {
    let sizes = odd_sizes();
    let n = sizes.lines().unwrap();
    let mut lines = [Line([0xA5; LINE]); 128];
    let st = WorldStorage::carve(&sizes, &mut Block::from_lines(&mut lines[..n])).unwrap();
    assert!(st.hash_starts.iter().all(|&v| v == 0));
    assert!(st.hash_entries.iter().all(|e| *e == HashEntry::default()));
    assert!(st.tet_boxes.iter().all(|b| *b == Aabb::point(Vec3::ZERO)));
    assert!(st.hierarchy.roots.iter().all(|n| *n == HNode::default()));
    assert!(st.hierarchy.arena.iter().all(|n| *n == HNode::default()));
    assert!(st.hierarchy.vlist.iter().all(|v| *v == VEntry::default()));
    assert!(st.hierarchy.changes.iter().all(|&t| t == TetId::NONE));
    assert!(st.pending.iter().all(|p| *p == Pending::default()));
    assert!(st.candidates.iter().all(|&t| t == TetId::NONE));
    assert!(st.sphere_memo.iter().all(|s| *s == SphereSlot::EMPTY));
}

#[test]
fn a_start_off_the_line_loses_the_bytes_to_the_next_line() {
    let sizes = HierarchySizes::new(4, 16).with_changes(3);
    let n = sizes.lines().unwrap();
    let mut lines = [Line::ZERO; 9];
    let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut lines[..n + 1]);
    let (_, off) = bytes.split_at_mut(8);
    let mut block = Block::new(off);
    let st = HierarchyStorage::carve(&sizes, &mut block).unwrap();
    assert!(line_aligned(st.roots) && line_aligned(st.arena) && line_aligned(st.vlist));
    assert!(line_aligned(st.changes));
    assert_eq!(block.left(), 0);
    // Without the spare line it does not fit.
    let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut lines[..n]);
    let (_, off) = bytes.split_at_mut(8);
    assert!(HierarchyStorage::carve(&sizes, &mut Block::new(off)).is_err());
}

#[test]
fn a_split_puts_the_chosen_parts_in_its_second_run() {
    let sizes = odd_sizes();
    let second = PartSet::EMPTY.with(Part::HashEntries).with(Part::Pending);
    let (na, nb) = (
        sizes.lines_in(second, false).unwrap(),
        sizes.lines_in(second, true).unwrap(),
    );
    assert_eq!(na + nb, sizes.lines().unwrap());
    assert_eq!(nb, (sizes.hash_entries * 16).div_ceil(64) + 7);
    let (mut a, mut b) = ([Line::ZERO; 128], [Line::ZERO; 128]);
    let b_range = b[..nb].as_ptr_range();
    let b_range = b_range.start as usize..b_range.end as usize;
    let mut split = Split {
        a: Block::from_lines(&mut a[..na]),
        b: Block::from_lines(&mut b[..nb]),
        second,
    };
    let st = WorldStorage::carve(&sizes, &mut split).unwrap();
    assert_eq!((split.a.left(), split.b.left()), (0, 0));
    assert!(b_range.contains(&(st.hash_entries.as_ptr() as usize)));
    assert!(b_range.contains(&(st.pending.as_ptr() as usize)));
    assert!(!b_range.contains(&(st.arena_ptr())));
}

trait ArenaPtr {
    fn arena_ptr(&self) -> usize;
}

impl ArenaPtr for WorldStorage<'_> {
    fn arena_ptr(&self) -> usize {
        self.hierarchy.arena.as_ptr() as usize
    }
}

#[test]
fn sizes_beyond_the_address_space_are_refused_not_wrapped() {
    let mut sizes = odd_sizes();
    sizes.pending = usize::MAX / 2;
    assert_eq!(sizes.lines(), None);
    assert_eq!(sizes.bytes(), None);
    let mut lines = [Line::ZERO; 4];
    let e = WorldStorage::carve(&sizes, &mut Block::from_lines(&mut lines)).unwrap_err();
    // The parts before it fit or not; whichever is refused first, nothing panics and the
    // answer names a part.
    assert!(matches!(
        e,
        StorageError::TooSmall { .. } | StorageError::Overflow { .. }
    ));
    let mut big = HierarchySizes::new(1, 8);
    big.arena = usize::MAX;
    assert_eq!(big.lines(), None);
    let e = HierarchyStorage::carve(&big, &mut Block::from_lines(&mut lines)).unwrap_err();
    assert_eq!(e, StorageError::Overflow { part: Part::Arena });
}

#[test]
fn spare_tables_match_the_world_they_serve() {
    let sizes = odd_sizes();
    let nodes = 11;
    let n = sizes.deform_lines(nodes).unwrap();
    let mut lines = [Line([0xFF; LINE]); 128];
    let mut block = Block::from_lines(&mut lines[..n]);
    let spare = SpareStorage::carve(&sizes, nodes, &mut block).unwrap();
    assert_eq!(spare.hash_starts.len(), sizes.hash_starts);
    assert_eq!(spare.hash_entries.len(), sizes.hash_entries);
    assert_eq!(spare.tet_boxes.len(), sizes.tet_boxes);
    assert_eq!(spare.normals.len(), nodes);
    let rest = crate::servo::carve_rest(nodes, &mut block).unwrap();
    assert_eq!(rest.len(), nodes);
    assert!(rest.iter().all(|p| *p == Vec3::ZERO));
    assert_eq!(block.left(), 0);
}

#[test]
fn errors_say_which_part() {
    use core::fmt::Write;
    struct Buf([u8; 128], usize);
    impl Write for Buf {
        fn write_str(&mut self, s: &str) -> core::fmt::Result {
            let b = s.as_bytes();
            let end = self.1 + b.len();
            self.0
                .get_mut(self.1..end)
                .ok_or(core::fmt::Error)?
                .copy_from_slice(b);
            self.1 = end;
            Ok(())
        }
    }
    let mut b = Buf([0; 128], 0);
    let e = StorageError::TooSmall {
        part: Part::Arena,
        needed: 640,
        left: 64,
    };
    write!(b, "{e}").unwrap();
    assert_eq!(
        core::str::from_utf8(&b.0[..b.1]).unwrap(),
        "storage too small for the hierarchy arena: 640 bytes needed, 64 left"
    );
}
