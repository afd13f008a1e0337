//! A hierarchy over the 12-tet cube on the stack, for the unit tests of the hierarchy and
//! the drill.

/// `cube_hierarchy!(h, &mesh, A)`: `let mut h` = a hierarchy over the 12-tet cube's roots, an
/// arena of `A` nodes and the v_list that arena needs, all on the stack.
macro_rules! cube_hierarchy {
    ($h:ident, $mesh:expr, $arena:expr) => {
        let mut roots = [$crate::hierarchy::HNode::LEAF; $crate::builtin::CUBE12_TETS];
        let mut arena = [$crate::hierarchy::HNode::LEAF; $arena];
        let mut vlist =
            [$crate::hierarchy::VEntry::default(); $crate::builtin::CUBE12_TETS + 7 * ($arena / 8)];
        let mut $h = $crate::hierarchy::Hierarchy::new(
            $mesh,
            $crate::hierarchy::HierarchyStorage {
                roots: &mut roots,
                arena: &mut arena,
                vlist: &mut vlist,
                changes: &mut [],
            },
        )
        .expect("test hierarchy");
    };
}
pub(crate) use cube_hierarchy;
