//! Reference soft-body physics on a tet mesh: XPBD with a deviatoric constraint on the Green
//! strain and a volumetric one on `det F - 1` per tet, both zero at rest, solved as one 2x2
//! system per tet, with fixed nodes, gravity, damping and external node forces.
//!
//! A [`SoftBody`] borrows the rest positions and tets ([`SoftMesh`]) and the caller's
//! storage ([`SoftStorage`]); [`SoftBody::step`] advances it by `dt` in a fixed number of
//! substeps and iterations, so its work is bounded and it never allocates. The same step
//! spread over calls, a bounded amount of work each ([`SoftBody::begin_step`],
//! [`SoftBody::advance`], `resume.rs`), is its one implementation: [`SoftBody::step`] runs it
//! with an unlimited amount, so a step gives the same bits however it is sliced. Positions are kept
//! as displacements from rest, so small strains stay exact in f32 whatever the mesh's
//! offset. docs/SOFT.md has the formulation, its small-strain limit and the measured times.

#[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
mod lanes;
mod link;
mod load;
mod material;
mod order;
mod parts;
mod resume;
mod storage;
mod tet;

pub use link::{Link, LinkBuffers, LinkError, LinkTick};
pub(crate) use load::below_plane;
pub use load::spread_point_force;
pub use material::{Lame, Material, MaterialError};
pub use order::{lane_order, LANE_WINDOW};
pub use parts::{PartSweep, TwoParts};
pub(crate) use resume::NODE_UNITS;
pub use resume::{Advance, TET_UNITS};
pub use storage::{carve_mesh, mesh_lines, mesh_parts};
pub(crate) use tet::project;
pub use tet::TetRest;

use core::fmt;

use glam::Vec3;

use crate::mesh::Mesh;

/// Most substeps per [`SoftBody::step`].
pub const MAX_SUBSTEPS: u32 = 1000;
/// Most solver iterations per substep.
pub const MAX_ITERATIONS: u32 = 100;

/// Step parameters: gravity, damping, and the fixed substep and iteration counts that bound
/// a step's work.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoftParams {
    /// Gravity (acceleration) on every free node.
    pub gravity: Vec3,
    /// Velocity damping rate `c` (per unit time): each substep scales velocities by
    /// `1 / (1 + c h)` before adding the substep's accelerations. It damps rigid motion too (like a viscous surrounding); 0 for none.
    pub damping: f32,
    /// Substeps per step (`1..=MAX_SUBSTEPS`): the multipliers restart every substep.
    pub substeps: u32,
    /// Gauss-Seidel sweeps over all tets per substep (`1..=MAX_ITERATIONS`).
    pub iterations: u32,
}

impl Default for SoftParams {
    fn default() -> Self {
        Self {
            gravity: Vec3::ZERO,
            damping: 0.0,
            substeps: 10,
            iterations: 1,
        }
    }
}

/// The mesh a soft body works on: rest positions, four node indices per positively oriented
/// tet, and an optional material index per tet (empty: every tet uses material 0).
#[derive(Debug, Clone, Copy)]
pub struct SoftMesh<'a> {
    /// Rest positions, one per node.
    pub rest: &'a [Vec3],
    /// Node indices of each tet, positively oriented (`det[x1-x0, x2-x0, x3-x0] > 0`).
    pub tets: &'a [[u32; 4]],
    /// Material index per tet into the materials list, or empty for material 0 everywhere.
    pub tet_material: &'a [u32],
}

/// Caller storage: per node (the rest positions' length) and per tet.
#[derive(Debug)]
pub struct SoftStorage<'a> {
    /// Displacement from rest per node (the state; set it to start deformed).
    pub displacement: &'a mut [Vec3],
    /// Velocity per node (the state).
    pub velocity: &'a mut [Vec3],
    /// Scratch per node: the displacement at the start of a substep.
    pub previous: &'a mut [Vec3],
    /// Lumped mass per node (filled at construction).
    pub mass: &'a mut [f32],
    /// Inverse mass per node, zero for fixed nodes (filled at construction).
    pub inv_mass: &'a mut [f32],
    /// Rest data per tet (filled at construction).
    pub tet_rest: &'a mut [TetRest],
    /// Scratch per tet: the two constraint multipliers.
    pub lambdas: &'a mut [[f32; 2]],
}

/// Why a soft body is refused at construction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SoftError {
    /// A storage slice (named) does not have the node or tet count as its length.
    Length(&'static str),
    /// More nodes than a `u32` index can name.
    TooManyNodes,
    /// A tet names a node past the end.
    NodeOutOfRange {
        /// The tet's index.
        tet: u32,
    },
    /// A tet is inverted or degenerate at rest (volume not above `1e-7` times its longest
    /// edge cubed).
    DegenerateTet {
        /// The tet's index.
        tet: u32,
    },
    /// A tet names a material past the end of the list.
    MaterialIndex {
        /// The tet's index.
        tet: u32,
    },
    /// A material's value is out of range.
    Material {
        /// The material's index.
        index: u32,
        /// What is wrong with it.
        error: MaterialError,
    },
    /// A step parameter (named) is out of range.
    Param(&'static str),
    /// The storage could not be carved or allocated ([`SoftStorage::carve`]).
    Storage(crate::storage::StorageError),
}

impl fmt::Display for SoftError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Length(what) => write!(f, "soft body: {what} has the wrong length"),
            Self::TooManyNodes => f.write_str("soft body: more than 2^32 - 1 nodes"),
            Self::NodeOutOfRange { tet } => write!(f, "soft body: tet {tet} names a missing node"),
            Self::DegenerateTet { tet } => {
                write!(f, "soft body: tet {tet} is inverted or flat at rest")
            }
            Self::MaterialIndex { tet } => {
                write!(f, "soft body: tet {tet} names a missing material")
            }
            Self::Material { index, error } => write!(f, "soft body: material {index}: {error}"),
            Self::Param(what) => write!(f, "soft body: {what} is out of range"),
            Self::Storage(e) => write!(f, "soft body: {e}"),
        }
    }
}

impl core::error::Error for SoftError {}

/// Why a step was not taken (nothing changed).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum StepError {
    /// `dt` is not finite and positive.
    TimeStep,
    /// A step spread over calls ([`SoftBody::begin_step`]) is under way: finish it first.
    InProgress,
}

impl fmt::Display for StepError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TimeStep => f.write_str("soft body: time step must be finite and positive"),
            Self::InProgress => f.write_str("soft body: a spread step is under way"),
        }
    }
}

impl core::error::Error for StepError {}

impl SoftParams {
    /// Checks the ranges of the parameters.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn check(&self) -> Result<(), SoftError> {
        if !self.gravity.is_finite() {
            return Err(SoftError::Param("gravity"));
        }
        if !(self.damping.is_finite() && self.damping >= 0.0) {
            return Err(SoftError::Param("damping"));
        }
        if !(1..=MAX_SUBSTEPS).contains(&self.substeps) {
            return Err(SoftError::Param("substeps"));
        }
        if !(1..=MAX_ITERATIONS).contains(&self.iterations) {
            return Err(SoftError::Param("iterations"));
        }
        Ok(())
    }
}

/// Copies a mesh's tets as node index arrays into `out` (for [`SoftMesh::tets`]). Returns the
/// tet count, or `None` when `out` is shorter than the mesh's tets (nothing is written).
///
/// # Bounded work
/// O(T).
pub fn mesh_tets(mesh: &Mesh<'_>, out: &mut [[u32; 4]]) -> Option<usize> {
    let count = mesh.tet_count();
    if out.len() < count {
        return None;
    }
    for (o, t) in out.iter_mut().zip(mesh.tets()) {
        *o = t.nodes.map(|n| n.0);
    }
    Some(count)
}

/// A soft body over borrowed mesh and storage. See the module docs.
///
/// ```
/// use tetradrill_core::builtin;
/// use tetradrill_core::soft::{Material, SoftBody, SoftMesh, SoftParams, SoftStorage, TetRest};
/// use tetradrill_core::Vec3;
///
/// // A unit cube in 6 tets, E = 1 kPa, 1 kg per unit volume.
/// let (mut rest, mut tets) = ([Vec3::ZERO; 8], [[0u32; 4]; 6]);
/// builtin::block(1, 1.0, Vec3::ZERO, &mut rest, &mut tets).unwrap();
/// let mesh = SoftMesh { rest: &rest, tets: &tets, tet_material: &[] };
/// let material = Material { young: 1000.0, poisson: 0.3, density: 1.0 };
/// let (mut u, mut v, mut previous) = ([Vec3::ZERO; 8], [Vec3::ZERO; 8], [Vec3::ZERO; 8]);
/// let (mut mass, mut inv_mass) = ([0.0; 8], [0.0; 8]);
/// let (mut tet_rest, mut lambdas) = ([TetRest::default(); 6], [[0.0; 2]; 6]);
/// let storage = SoftStorage {
///     displacement: &mut u, velocity: &mut v, previous: &mut previous,
///     mass: &mut mass, inv_mass: &mut inv_mass, tet_rest: &mut tet_rest, lambdas: &mut lambdas,
/// };
/// let params = SoftParams { damping: 20.0, ..SoftParams::default() };
/// let mut body = SoftBody::new(mesh, &[material], params, storage).expect("a valid body");
/// assert_eq!(body.fix_below(Vec3::ZERO, Vec3::Z), 4); // its bottom face held
///
/// // 10 N pull the top face up for 1 s: it stretches by a little under F / (E A) = 1 %
/// // (its held bottom face and its six tets stiffen it).
/// let load = rest.map(|p| if p.z > 0.5 { Vec3::Z * 2.5 } else { Vec3::ZERO });
/// for _ in 0..100 {
///     body.step(0.01, &load).expect("a valid time step");
/// }
/// let top = body.position(7).unwrap();
/// assert!(top.z > 1.004 && top.z < 1.01, "{top}");
/// assert_eq!(body.position(0), Some(Vec3::ZERO));
/// assert!(body.elastic_energy() > 0.0);
/// ```
#[derive(Debug)]
pub struct SoftBody<'a> {
    rest: &'a [Vec3],
    tets: &'a [[u32; 4]],
    s: SoftStorage<'a>,
    params: SoftParams,
    /// The step spread over calls, when one is under way ([`SoftBody::begin_step`]).
    run: Option<resume::Run>,
}

impl<'a> SoftBody<'a> {
    /// Checks the mesh, materials and parameters, fills the rest data, lumped masses and
    /// inverse masses (every node free), and returns the body. The displacement and velocity
    /// slices are left as the caller set them (zero for a body at rest).
    ///
    /// Refused ([`SoftError`]): a slice of the wrong length, a node index or material index
    /// out of range, an inverted or flat tet, a bad material or parameter.
    ///
    /// # Bounded work
    /// O(N + T + materials).
    pub fn new(
        mesh: SoftMesh<'a>,
        materials: &[Material],
        params: SoftParams,
        storage: SoftStorage<'a>,
    ) -> Result<Self, SoftError> {
        let n = mesh.rest.len();
        let t = mesh.tets.len();
        if n > u32::MAX as usize {
            return Err(SoftError::TooManyNodes);
        }
        let lengths: [(&'static str, usize, usize); 7] = [
            ("displacement", storage.displacement.len(), n),
            ("velocity", storage.velocity.len(), n),
            ("previous", storage.previous.len(), n),
            ("mass", storage.mass.len(), n),
            ("inv_mass", storage.inv_mass.len(), n),
            ("tet_rest", storage.tet_rest.len(), t),
            ("lambdas", storage.lambdas.len(), t),
        ];
        for (what, have, want) in lengths {
            if have != want {
                return Err(SoftError::Length(what));
            }
        }
        if !mesh.tet_material.is_empty() && mesh.tet_material.len() != t {
            return Err(SoftError::Length("tet_material"));
        }
        if materials.is_empty() {
            return Err(SoftError::Length("materials"));
        }
        for (i, m) in materials.iter().enumerate() {
            m.check().map_err(|error| SoftError::Material {
                index: i as u32,
                error,
            })?;
        }
        params.check()?;
        storage.mass.fill(0.0);
        for (i, (tet, rest)) in mesh
            .tets
            .iter()
            .zip(storage.tet_rest.iter_mut())
            .enumerate()
        {
            let id = i as u32;
            let mut x = [Vec3::ZERO; 4];
            for (xk, &k) in x.iter_mut().zip(tet) {
                *xk = *mesh
                    .rest
                    .get(k as usize)
                    .ok_or(SoftError::NodeOutOfRange { tet: id })?;
            }
            let mi = mesh.tet_material.get(i).copied().unwrap_or(0);
            let mat = materials
                .get(mi as usize)
                .ok_or(SoftError::MaterialIndex { tet: id })?;
            *rest = TetRest::new(x, mat.lame()).ok_or(SoftError::DegenerateTet { tet: id })?;
            let quarter = mat.density * rest.volume * 0.25;
            for &k in tet {
                // In range: checked above (`get`: no panic path on a bare-metal build).
                if let Some(m) = storage.mass.get_mut(k as usize) {
                    *m += quarter;
                }
            }
        }
        for (w, &m) in storage.inv_mass.iter_mut().zip(storage.mass.iter()) {
            *w = if m > 0.0 { 1.0 / m } else { 0.0 };
        }
        storage.lambdas.fill([0.0; 2]);
        Ok(Self {
            rest: mesh.rest,
            tets: mesh.tets,
            s: storage,
            params,
            run: None,
        })
    }

    /// Number of nodes.
    #[inline]
    pub fn node_count(&self) -> usize {
        self.rest.len()
    }

    /// Number of tets.
    #[inline]
    pub fn tet_count(&self) -> usize {
        self.tets.len()
    }

    /// The step parameters.
    #[inline]
    pub fn params(&self) -> SoftParams {
        self.params
    }

    /// Replaces the step parameters (refused, unchanged, when out of range).
    ///
    /// # Bounded work
    /// Constant.
    pub fn set_params(&mut self, params: SoftParams) -> Result<(), SoftError> {
        params.check()?;
        self.params = params;
        Ok(())
    }

    /// Rest positions.
    #[inline]
    pub fn rest(&self) -> &[Vec3] {
        self.rest
    }

    /// Tets as node indices.
    #[inline]
    pub fn tets(&self) -> &[[u32; 4]] {
        self.tets
    }

    /// Displacements from rest.
    #[inline]
    pub fn displacements(&self) -> &[Vec3] {
        self.s.displacement
    }

    /// Velocities.
    #[inline]
    pub fn velocities(&self) -> &[Vec3] {
        self.s.velocity
    }

    /// Lumped masses.
    #[inline]
    pub fn masses(&self) -> &[f32] {
        self.s.mass
    }

    /// Current position of node `i` (rest plus displacement), or `None` past the end.
    #[inline]
    pub fn position(&self, i: usize) -> Option<Vec3> {
        Some(*self.rest.get(i)? + *self.s.displacement.get(i)?)
    }

    /// Writes current positions into `out` (as many as both lengths allow), for example into
    /// [`Mesh::positions_mut`].
    ///
    /// # Bounded work
    /// O(N).
    pub fn write_positions(&self, out: &mut [Vec3]) {
        for ((o, &x), &u) in out
            .iter_mut()
            .zip(self.rest)
            .zip(self.s.displacement.iter())
        {
            *o = x + u;
        }
    }

    /// Fixes (`true`) or frees node `i`. A fixed node keeps its displacement (the caller may
    /// move it as a kinematic support); a node in no tet has no mass and stays fixed.
    /// Returns `false` past the end.
    ///
    /// # Bounded work
    /// Constant.
    pub fn set_fixed(&mut self, i: usize, fixed: bool) -> bool {
        let (Some(w), Some(&m)) = (self.s.inv_mass.get_mut(i), self.s.mass.get(i)) else {
            return false;
        };
        *w = if fixed || m <= 0.0 { 0.0 } else { 1.0 / m };
        if let Some(v) = self.s.velocity.get_mut(i) {
            if *w == 0.0 {
                *v = Vec3::ZERO;
            }
        }
        true
    }

    /// `true` when node `i` does not move under forces (fixed, or massless).
    #[inline]
    pub fn is_fixed(&self, i: usize) -> bool {
        self.s.inv_mass.get(i).is_none_or(|&w| w == 0.0)
    }

    /// Fixes every node whose rest position lies on or below the plane through `origin`
    /// with upward normal `up` (the scenario key "nodes below a plane"). Returns how many.
    ///
    /// # Bounded work
    /// O(N).
    pub fn fix_below(&mut self, origin: Vec3, up: Vec3) -> usize {
        let mut count = 0;
        for i in 0..self.rest.len() {
            if below_plane(self.rest[i], origin, up) {
                self.set_fixed(i, true);
                count += 1;
            }
        }
        count
    }

    /// Adds a point force at `point` in tet `tet` (current positions) to `external`, spread
    /// over its four nodes by barycentric weights ([`spread_point_force`]): the way a tool's
    /// contact force pushes the touched nodes. Returns `false` (nothing added) for a tet or
    /// node past the end of either slice, or a degenerate current tet.
    ///
    /// # Bounded work
    /// Constant.
    pub fn add_point_force(
        &self,
        tet: usize,
        point: Vec3,
        force: Vec3,
        external: &mut [Vec3],
    ) -> bool {
        let Some((ids, parts)) = self.point_force(tet, point, force) else {
            return false;
        };
        if ids.iter().any(|&k| k as usize >= external.len()) {
            return false;
        }
        for (&k, f) in ids.iter().zip(parts) {
            external[k as usize] += f;
        }
        true
    }

    /// A point force at `point` in tet `tet` (current positions) as its four nodes and their
    /// shares ([`spread_point_force`]), for a caller whose loads are laid out its own way
    /// ([`SoftBody::add_point_force`] adds them to a `Vec3` a node); `None` for a tet past
    /// the end or a degenerate current tet.
    ///
    /// # Bounded work
    /// Constant.
    pub fn point_force(
        &self,
        tet: usize,
        point: Vec3,
        force: Vec3,
    ) -> Option<([u32; 4], [Vec3; 4])> {
        let ids = *self.tets.get(tet)?;
        let mut p = [Vec3::ZERO; 4];
        for (pk, &k) in p.iter_mut().zip(&ids) {
            *pk = self.position(k as usize)?;
        }
        Some((ids, spread_point_force(p, point, force)?))
    }

    /// Elastic energy of the whole body (zero at rest), in f64.
    ///
    /// # Bounded work
    /// O(T).
    pub fn elastic_energy(&self) -> f64 {
        let mut e = 0.0;
        for (tet, rest) in self.tets.iter().zip(self.s.tet_rest.iter()) {
            e += rest.energy(tet.map(|k| self.s.displacement[k as usize]));
        }
        e
    }

    /// Kinetic energy of the whole body, in f64.
    ///
    /// # Bounded work
    /// O(N).
    pub fn kinetic_energy(&self) -> f64 {
        let mut e = 0.0;
        for (&m, v) in self.s.mass.iter().zip(self.s.velocity.iter()) {
            e += 0.5 * m as f64 * v.length_squared() as f64;
        }
        e
    }

    /// Advances the body by `dt`: `substeps` substeps of length `h = dt / substeps`, each
    /// (1) damping and integrating velocities with gravity and `external` (force per node;
    /// missing entries count as zero, fixed nodes ignore theirs), (2) predicting
    /// displacements, (3) `iterations` Gauss-Seidel sweeps of `project` over all tets,
    /// (4) taking velocities from the displacement change. Refused, nothing changed, when
    /// `dt` is not finite and positive or a step spread over calls is under way.
    ///
    /// It is [`SoftBody::begin_step`] and [`SoftBody::advance`] with all the units a call can
    /// give (one call, or a few when the step's units, [`SoftBody::step_units`], pass
    /// `u32::MAX`): the step is written once, in `resume.rs`.
    ///
    /// # Bounded work
    /// O(substeps * (N + iterations * T)): fixed counts, no allocation, no search.
    pub fn step(&mut self, dt: f32, external: &[Vec3]) -> Result<(), StepError> {
        self.begin_step(dt)?;
        // A call stops short only when fewer than `TET_UNITS` of its u32::MAX units are
        // left: at most `step_units / (u32::MAX - TET_UNITS) + 1` calls.
        while !self.advance(external, u32::MAX).done {}
        Ok(())
    }
}
