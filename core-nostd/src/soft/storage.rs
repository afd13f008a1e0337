//! A soft body's storage carved from memory (see [`crate::storage`]): its state and scratch
//! ([`SoftStorage::carve`]), its rest mesh's arrays ([`carve_mesh`]) and a link's buffers
//! ([`LinkBuffers::carve`]), each part on a line, every slot at its starting value.

use glam::Vec3;

use super::{LinkBuffers, SoftStorage, TetRest};
use crate::storage::{carve, lines_of, Memory, Part, PartSet, Slots, StorageError};

/// The lines of `parts` (`None` on overflow).
const fn lines(parts: &[Slots]) -> Option<usize> {
    lines_of(parts, PartSet::EMPTY, false)
}

impl<'a> SoftStorage<'a> {
    /// Every slice of a [`SoftStorage`] for `nodes` nodes and `tets` tets, in the order
    /// [`SoftStorage::carve`] takes them.
    pub const fn parts(nodes: usize, tets: usize) -> [Slots; 7] {
        [
            Slots::of::<Vec3>(Part::SoftDisplacement, nodes),
            Slots::of::<Vec3>(Part::SoftVelocity, nodes),
            Slots::of::<Vec3>(Part::SoftPrevious, nodes),
            Slots::of::<f32>(Part::SoftMass, nodes),
            Slots::of::<f32>(Part::SoftInvMass, nodes),
            Slots::of::<TetRest>(Part::SoftTetRest, tets),
            Slots::of::<[f32; 2]>(Part::SoftLambdas, tets),
        ]
    }

    /// The [`crate::storage::Line`]s a [`crate::storage::Block`] starting on a line needs for
    /// [`SoftStorage::parts`] (`None` when they overflow the address space).
    pub const fn lines(nodes: usize, tets: usize) -> Option<usize> {
        lines(&Self::parts(nodes, tets))
    }

    /// Carves a soft body's storage for `nodes` nodes and `tets` tets from `mem`: a body at
    /// rest (zero displacements and velocities; [`super::SoftBody::new`] fills the masses
    /// and the rest data). A caller that starts the body deformed sets
    /// [`SoftStorage::displacement`] before handing the storage over.
    ///
    /// # Bounded work
    /// O(`nodes + tets`): every slot is written.
    ///
    /// # Errors
    /// [`StorageError`] naming the first part the memory could not hold.
    pub fn carve(
        nodes: usize,
        tets: usize,
        mem: &mut impl Memory<'a>,
    ) -> Result<Self, StorageError> {
        Ok(Self {
            displacement: carve(mem, Part::SoftDisplacement, nodes, Vec3::ZERO)?,
            velocity: carve(mem, Part::SoftVelocity, nodes, Vec3::ZERO)?,
            previous: carve(mem, Part::SoftPrevious, nodes, Vec3::ZERO)?,
            mass: carve(mem, Part::SoftMass, nodes, 0.0f32)?,
            inv_mass: carve(mem, Part::SoftInvMass, nodes, 0.0f32)?,
            tet_rest: carve(mem, Part::SoftTetRest, tets, TetRest::default())?,
            lambdas: carve(mem, Part::SoftLambdas, tets, [0.0f32; 2])?,
        })
    }
}

/// The slices of a soft body's rest mesh ([`super::SoftMesh`]: rest positions, tets as node
/// indices) for `nodes` nodes and `tets` tets, in the order [`carve_mesh`] takes them.
pub const fn mesh_parts(nodes: usize, tets: usize) -> [Slots; 2] {
    [
        Slots::of::<Vec3>(Part::SoftRest, nodes),
        Slots::of::<[u32; 4]>(Part::SoftTets, tets),
    ]
}

/// The lines of [`mesh_parts`] (`None` on overflow).
pub const fn mesh_lines(nodes: usize, tets: usize) -> Option<usize> {
    lines(&mesh_parts(nodes, tets))
}

/// Carves the arrays of a soft body's rest mesh from `mem`: `nodes` rest positions at the
/// origin and `tets` tets of node 0, for the caller to fill (from a built mesh:
/// [`super::mesh_tets`]).
///
/// # Bounded work
/// O(`nodes + tets`).
///
/// # Errors
/// [`StorageError`] naming the part the memory could not hold.
pub fn carve_mesh<'a>(
    nodes: usize,
    tets: usize,
    mem: &mut impl Memory<'a>,
) -> Result<(&'a mut [Vec3], &'a mut [[u32; 4]]), StorageError> {
    Ok((
        carve(mem, Part::SoftRest, nodes, Vec3::ZERO)?,
        carve(mem, Part::SoftTets, tets, [0u32; 4])?,
    ))
}

impl<'b> LinkBuffers<'b> {
    /// Every slice of a [`LinkBuffers`] for `nodes` nodes, in the order
    /// [`LinkBuffers::carve`] takes them.
    pub const fn parts(nodes: usize) -> [Slots; 3] {
        [
            Slots::of::<Vec3>(Part::LinkLoadA, nodes),
            Slots::of::<Vec3>(Part::LinkLoadB, nodes),
            Slots::of::<Vec3>(Part::LinkNext, nodes),
        ]
    }

    /// The lines of [`LinkBuffers::parts`] (`None` on overflow).
    pub const fn lines(nodes: usize) -> Option<usize> {
        lines(&Self::parts(nodes))
    }

    /// Carves a link's buffers for `nodes` nodes from `mem`, all zero (as
    /// [`super::Link::tick`] wants them at the start).
    ///
    /// # Bounded work
    /// O(`nodes`).
    ///
    /// # Errors
    /// [`StorageError`] naming the first part the memory could not hold.
    pub fn carve(nodes: usize, mem: &mut impl Memory<'b>) -> Result<Self, StorageError> {
        Ok(Self {
            a: carve(mem, Part::LinkLoadA, nodes, Vec3::ZERO)?,
            b: carve(mem, Part::LinkLoadB, nodes, Vec3::ZERO)?,
            next: carve(mem, Part::LinkNext, nodes, Vec3::ZERO)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::storage::{Block, Line};
    use glam::Mat3;

    const NODES: usize = 27;
    const TETS: usize = 48;
    const ALL: usize = match (
        SoftStorage::lines(NODES, TETS),
        mesh_lines(NODES, TETS),
        LinkBuffers::lines(NODES),
    ) {
        (Some(a), Some(b), Some(c)) => a + b + c,
        _ => 0,
    };

    /// Lines of `n` slots of `bytes` bytes, counted here by hand.
    fn lines(n: usize, bytes: usize) -> usize {
        (n * bytes).div_ceil(64)
    }

    #[test]
    fn the_sizes_count_every_part_in_lines() {
        // Vec3 12 bytes, f32 4, TetRest 52, [f32; 2] 8, [u32; 4] 16.
        let state = 3 * lines(NODES, 12) + 2 * lines(NODES, 4) + lines(TETS, 52) + lines(TETS, 8);
        assert_eq!(SoftStorage::lines(NODES, TETS), Some(state));
        let mesh = lines(NODES, 12) + lines(TETS, 16);
        assert_eq!(mesh_lines(NODES, TETS), Some(mesh));
        assert_eq!(LinkBuffers::lines(NODES), Some(3 * lines(NODES, 12)));
        assert_eq!(ALL, state + mesh + 3 * lines(NODES, 12));
        assert_eq!(SoftStorage::lines(usize::MAX, 1), None);
    }

    #[test]
    fn carving_puts_every_part_on_a_line_and_writes_its_starting_values() {
        let mut lines = [Line([0x5A; 64]); ALL];
        let base = lines.as_ptr() as usize;
        let end = base + ALL * 64;
        let mut mem = Block::from_lines(&mut lines);
        let s = SoftStorage::carve(NODES, TETS, &mut mem).unwrap();
        let (rest, tets) = carve_mesh(NODES, TETS, &mut mem).unwrap();
        let l = LinkBuffers::carve(NODES, &mut mem).unwrap();
        let starts = [
            s.displacement.as_ptr() as usize,
            s.velocity.as_ptr() as usize,
            s.previous.as_ptr() as usize,
            s.mass.as_ptr() as usize,
            s.inv_mass.as_ptr() as usize,
            s.tet_rest.as_ptr() as usize,
            s.lambdas.as_ptr() as usize,
            rest.as_ptr() as usize,
            tets.as_ptr() as usize,
            l.a.as_ptr() as usize,
            l.b.as_ptr() as usize,
            l.next.as_ptr() as usize,
        ];
        for (i, at) in starts.iter().enumerate() {
            assert_eq!((at - base) % 64, 0, "part {i} off its line");
        }
        assert!(starts[11] + NODES * 12 <= end);
        let vec3s = [
            &*s.displacement,
            &*s.velocity,
            &*s.previous,
            &*rest,
            &*l.a,
            &*l.b,
            &*l.next,
        ];
        for (i, v) in vec3s.into_iter().enumerate() {
            assert_eq!(v.len(), NODES, "slice {i}");
            assert!(v.iter().all(|&p| p == Vec3::ZERO), "slice {i}");
        }
        assert_eq!((s.mass.len(), s.inv_mass.len()), (NODES, NODES));
        assert!(s.mass.iter().chain(s.inv_mass.iter()).all(|&m| m == 0.0));
        assert_eq!(
            (s.tet_rest.len(), s.lambdas.len(), tets.len()),
            (TETS, TETS, TETS)
        );
        let identity = |r: &TetRest| {
            r.inv_dm == Mat3::IDENTITY
                && r.volume == 0.0
                && r.alpha_dev == 0.0
                && r.alpha_hydro == 0.0
                && r.gamma == 1.0
        };
        assert!(s.tet_rest.iter().all(identity));
        assert!(s.lambdas.iter().all(|&l| l == [0.0; 2]));
        assert!(tets.iter().all(|&t| t == [0; 4]));
    }

    #[test]
    fn a_block_one_line_short_is_refused_naming_the_part() {
        let mut lines = [Line::ZERO; ALL];
        let state = SoftStorage::lines(NODES, TETS).unwrap();
        let err = SoftStorage::carve(NODES, TETS, &mut Block::from_lines(&mut lines[..state - 1]))
            .unwrap_err();
        assert!(
            matches!(
                err,
                StorageError::TooSmall {
                    part: Part::SoftLambdas,
                    ..
                }
            ),
            "{err:?}"
        );
        let mesh = mesh_lines(NODES, TETS).unwrap();
        let err =
            carve_mesh(NODES, TETS, &mut Block::from_lines(&mut lines[..mesh - 1])).unwrap_err();
        assert!(
            matches!(
                err,
                StorageError::TooSmall {
                    part: Part::SoftTets,
                    ..
                }
            ),
            "{err:?}"
        );
        let link = LinkBuffers::lines(NODES).unwrap();
        let err =
            LinkBuffers::carve(NODES, &mut Block::from_lines(&mut lines[..link - 1])).unwrap_err();
        assert!(
            matches!(
                err,
                StorageError::TooSmall {
                    part: Part::LinkNext,
                    ..
                }
            ),
            "{err:?}"
        );
    }
}
