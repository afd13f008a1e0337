//! Index newtypes. Every id is a `u32` with one reserved `NONE` value (`u32::MAX`), so a
//! missing neighbour costs no extra byte and an id fits the compact records of [`crate::mesh`].

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
