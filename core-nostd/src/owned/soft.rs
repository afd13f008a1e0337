//! A soft body's storage on the heap ([`SoftBuffers`]).

use crate::soft::{Material, SoftBody, SoftError, SoftMesh, SoftParams, SoftStorage};
use crate::storage::{Part, StorageError};

use super::Heap;

/// A [`SoftBody`]'s storage on the heap: `SoftBuffers::new(nodes, tets)`, then
/// [`SoftBuffers::body`] for each body over it (each starts at rest), or
/// [`SoftBuffers::storage`] for a caller that sets the starting state itself.
///
/// ```
/// use tetradrill_core::builtin;
/// use tetradrill_core::owned::SoftBuffers;
/// use tetradrill_core::soft::{Material, SoftMesh, SoftParams};
/// use tetradrill_core::Vec3;
///
/// let (mut rest, mut tets) = ([Vec3::ZERO; 8], [[0u32; 4]; 6]);
/// builtin::block(1, 1.0, Vec3::ZERO, &mut rest, &mut tets).unwrap();
/// let mesh = SoftMesh { rest: &rest, tets: &tets, tet_material: &[] };
/// let material = Material { young: 1000.0, poisson: 0.3, density: 1.0 };
/// let mut buffers = SoftBuffers::new(8, 6)?;
/// let mut body = buffers.body(mesh, &[material], SoftParams::default())?;
/// body.step(0.01, &[Vec3::Z; 8])?;
/// assert!(body.position(7).unwrap().z > 1.0);
/// # Ok::<(), tetradrill_core::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct SoftBuffers {
    nodes: usize,
    tets: usize,
    heap: Heap,
}

impl SoftBuffers {
    /// Allocates the storage of a body of `nodes` nodes and `tets` tets (one heap block,
    /// [`SoftStorage::lines`]).
    ///
    /// # Errors
    /// [`StorageError`] when the sizes overflow or the heap refuses them.
    pub fn new(nodes: usize, tets: usize) -> Result<Self, StorageError> {
        Ok(Self {
            heap: Heap::new(SoftStorage::lines(nodes, tets), Part::SoftDisplacement)?,
            nodes,
            tets,
        })
    }

    /// The node and tet counts these buffers hold.
    pub fn counts(&self) -> (usize, usize) {
        (self.nodes, self.tets)
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.heap.bytes()
    }

    /// The storage of a body at rest, every slot at its starting value
    /// ([`SoftStorage::carve`]): set its displacements to start the body deformed.
    ///
    /// # Bounded work
    /// O(bytes held).
    ///
    /// # Errors
    /// None in practice (the block was sized for the counts); a [`StorageError`] otherwise.
    pub fn storage(&mut self) -> Result<SoftStorage<'_>, StorageError> {
        SoftStorage::carve(self.nodes, self.tets, &mut self.heap.block())
    }

    /// A body at rest over `mesh` and these buffers (see [`SoftBody::new`]).
    ///
    /// # Bounded work
    /// O(bytes held + N + T).
    ///
    /// # Errors
    /// What [`SoftBody::new`] refuses ([`SoftError::Length`] when the mesh's counts are not
    /// the buffers'), [`SoftError::Storage`] when the storage cannot be carved.
    pub fn body<'a>(
        &'a mut self,
        mesh: SoftMesh<'a>,
        materials: &[Material],
        params: SoftParams,
    ) -> Result<SoftBody<'a>, SoftError> {
        let storage = self.storage().map_err(SoftError::Storage)?;
        SoftBody::new(mesh, materials, params, storage)
    }
}
