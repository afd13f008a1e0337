//! One error type for a program that builds a world from the core's parts with `?`
//! ([`Error`]): each part's own error, kept whole, behind one enum, with no allocation (a
//! `Box<dyn Error>` needs the heap the core does without).

use core::fmt;

macro_rules! errors {
    ($($(#[$m:meta])* $variant:ident($ty:ty),)*) => {
        /// Any of the core's errors, kept whole: what a function that builds a mesh, its
        /// hierarchy, storage and a world in a row returns with `?` (each part's error
        /// converts with `From`).
        #[derive(Debug, Clone, PartialEq)]
        #[non_exhaustive]
        pub enum Error {
            $($(#[$m])* $variant($ty),)*
        }

        $(
            impl From<$ty> for Error {
                fn from(e: $ty) -> Self {
                    Self::$variant(e)
                }
            }
        )*

        impl fmt::Display for Error {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                match self {
                    $(Self::$variant(e) => fmt::Display::fmt(e, f),)*
                }
            }
        }

        impl core::error::Error for Error {
            fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
                match self {
                    $(Self::$variant(e) => Some(e),)*
                }
            }
        }
    };
}

errors! {
    /// Building a mesh ([`crate::mesh::Mesh::build`]).
    Build(crate::mesh::BuildError),
    /// A mesh's invariants ([`crate::mesh::Mesh::validate`]).
    Validation(crate::mesh::ValidationError),
    /// A tet view of caller arrays.
    TetView(crate::mesh::TetViewError),
    /// The spatial hash.
    Hash(crate::hash::HashError),
    /// The hierarchy.
    Hierarchy(crate::hierarchy::HierarchyError),
    /// A surface export.
    Surface(crate::hierarchy::SurfaceError),
    /// The smooth normals.
    Smooth(crate::hierarchy::SmoothError),
    /// Carving caller storage.
    Storage(crate::storage::StorageError),
    /// A world.
    World(crate::servo::WorldError),
    /// A deforming world.
    Deform(crate::servo::DeformError),
    /// The regions' materials.
    Region(crate::drill::RegionError),
    /// A mesh blob.
    Blob(crate::blob::BlobError),
    /// The depth's graph.
    Graph(crate::depth::GraphError),
    /// A rigid body's collisions.
    Rigid(crate::collide::RigidError),
    /// The occupancy grid.
    Occupancy(crate::collide::OccupancyError),
    /// A soft body.
    Soft(crate::soft::SoftError),
    /// A soft body's step.
    Step(crate::soft::StepError),
    /// A soft material.
    Material(crate::soft::MaterialError),
    /// The soft body's link to the world.
    Link(crate::soft::LinkError),
}
