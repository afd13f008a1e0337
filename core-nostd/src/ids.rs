//! Index newtypes. Every id is a `u32` with one reserved `NONE` value (`u32::MAX`), so a
//! missing neighbour costs no extra byte and an id fits the compact records of [`crate::mesh`].
//!
//! ```
//! use tetradrill_core::builtin;
//! use tetradrill_core::prelude::*;
//!
//! let t = TetId::from_idx(3);
//! assert_eq!((t.idx(), t.is_some()), (3, true));
//! assert!(TetId::NONE.is_none() && NodeId::NONE.0 == u32::MAX);
//!
//! // In a built mesh, the neighbour across a boundary face is `NONE`: each tet of the 12-tet
//! // cube has one face on the cube's surface.
//! let (mut pos, tets) = builtin::cube12();
//! let (mut nodes, mut normals) = ([Node::default(); 9], [Vec3::ZERO; 9]);
//! let (mut recs, mut scratch) = ([Tet::default(); 12], [FaceKey::default(); 48]);
//! let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
//! let mesh = Mesh::build(&mut pos, &tets, storage, &mut scratch, BuildOptions::default())?;
//! let outside = (0..4).filter(|&f| mesh.neighbour(TetId(0), f) == TetId::NONE).count();
//! assert_eq!(outside, 1);
//! # Ok::<(), tetradrill_core::mesh::BuildError>(())
//! ```

macro_rules! id_type {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(
            Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default,
            bytemuck::Pod, bytemuck::Zeroable,
        )]
        #[repr(transparent)]
        pub struct $name(pub u32);

        impl $name {
            /// "No such entity" (a boundary face's neighbour, an unset link).
            pub const NONE: Self = Self(u32::MAX);

            /// The id as a slice index.
            #[inline]
            pub const fn idx(self) -> usize {
                self.0 as usize
            }

            /// `true` unless this is [`Self::NONE`].
            #[inline]
            pub const fn is_some(self) -> bool {
                self.0 != u32::MAX
            }

            /// `true` for [`Self::NONE`].
            #[inline]
            pub const fn is_none(self) -> bool {
                self.0 == u32::MAX
            }

            /// Id of a slice index (indices above `u32::MAX - 1` are not representable;
            /// capacities are checked at build time so this never truncates there).
            #[inline]
            pub const fn from_idx(i: usize) -> Self {
                Self(i as u32)
            }
        }
    };
}

id_type!(
    /// Index of a tetrahedron in a mesh's tet array.
    TetId
);
id_type!(
    /// Index of a node (vertex) in a mesh's node array.
    NodeId
);
