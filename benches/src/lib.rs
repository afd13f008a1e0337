//! Shared set-up for tetradrill's benchmarks and worst-case timing harness: the deterministic
//! generator and the pen poses the contact bench and `query_profile` both use, and the drill
//! bench's convergence case ([`swept`]).

pub mod swept;

use std::path::PathBuf;

use glam::{Quat, Vec3};
use tetradrill::owned::OwnedMesh;
use tetradrill_core::mesh::Mesh;

/// Where the benches find their meshes: `TETRADRILL_MESHES`, else the project's test data.
pub fn meshes_dir() -> PathBuf {
    match std::env::var("TETRADRILL_MESHES") {
        Ok(d) => PathBuf::from(d),
        Err(_) => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/meshes"),
    }
}

/// The mesh `rel` (a path under [`meshes_dir`]) scaled by `scale`.
///
/// # Errors
/// The file's path and the reader's reason, in one line.
pub fn load_mesh(rel: &str, scale: f64) -> Result<OwnedMesh, String> {
    let path = meshes_dir().join(rel);
    tetradrill::meshio::load(&path, scale)
        .map(|l| l.mesh)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// The arguments of a profiling binary `bin`: `MESH touching|impaled [REPS]` (REPS default
/// `default_reps`). `Err` is the one line to print before exiting with status 2.
///
/// # Errors
/// A missing argument, an unknown pose set, a REPS that is not a positive whole number.
pub fn profile_args(bin: &str, default_reps: usize) -> Result<(String, bool, usize), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(mesh), Some(set)) = (args.first(), args.get(1)) else {
        return Err(format!("usage: {bin} MESH touching|impaled [REPS]"));
    };
    let touching = match set.as_str() {
        "touching" => true,
        "impaled" => false,
        other => {
            return Err(format!(
                "{bin}: pose set must be touching or impaled, not `{other}`"
            ))
        }
    };
    let reps = match args.get(2).map(|r| r.parse::<usize>()) {
        None => default_reps,
        Some(Ok(n)) if n > 0 => n,
        Some(_) => return Err(format!("{bin}: REPS must be a positive whole number")),
    };
    Ok((mesh.clone(), touching, reps))
}

/// What a pen profiling binary runs over ([`pen_profile_setup`]).
#[derive(Debug)]
pub struct PenProfile {
    /// The object mesh's path as given (relative to the meshes folder).
    pub mesh: String,
    /// The pen x10.
    pub pen: OwnedMesh,
    /// The object.
    pub obj: OwnedMesh,
    /// `true` for the touching poses, `false` for the impaled ones.
    pub touching: bool,
    /// The poses: the whole set, or only pose `POSE` when the environment sets it.
    pub poses: Vec<(Vec3, Quat)>,
    /// The set's index of `poses[0]` (`POSE`, else 0).
    pub first: usize,
    /// Calls per pose.
    pub reps: usize,
}

/// The set-up of a pen profiling binary `bin`: [`profile_args`], the pen x10 and the object
/// loaded, the bench's 200 touching or impaled poses, only pose `POSE` when the environment
/// sets it. `Err` is the one line to print before exiting with status 2.
///
/// # Errors
/// [`profile_args`]'s, a mesh that does not load, a `POSE` past the set.
pub fn pen_profile_setup(bin: &str, default_reps: usize) -> Result<PenProfile, String> {
    let (mesh, touching, reps) = profile_args(bin, default_reps)?;
    let pen = load_mesh("models/pen_tool_gmsh.mesh", 10.0).map_err(|e| format!("{bin}: {e}"))?;
    let mut obj = load_mesh(&mesh, 1.0).map_err(|e| format!("{bin}: {e}"))?;
    let mut poses = if touching {
        touch_poses(&obj.view(), 200, 0.05, 7)
    } else {
        impaled_poses(&obj.view(), 200, 0.25, 7)
    };
    let mut first = 0;
    if let Some(i) = std::env::var("POSE")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
    {
        if i >= poses.len() {
            return Err(format!("{bin}: POSE must be below {}", poses.len()));
        }
        poses = vec![poses[i]];
        first = i;
    }
    Ok(PenProfile {
        mesh,
        pen,
        obj,
        touching,
        poses,
        first,
        reps,
    })
}

/// A tiny deterministic generator (the benches have no `rand`; the tests' seeded paths use it
/// too): a 64-bit linear congruential generator, Knuth's MMIX constants.
#[derive(Debug, Clone)]
pub struct Lcg(pub u64);

impl Lcg {
    /// The next state.
    fn step(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0
    }
    /// The next value in `[0, 1)` (the state's top 24 bits).
    pub fn unit(&mut self) -> f32 {
        ((self.step() >> 40) as f32) / ((1u64 << 24) as f32)
    }
    /// The next value in `[-1, 1)` (the state's top 31 bits).
    pub fn signed(&mut self) -> f32 {
        ((self.step() >> 33) as f32 / (1u64 << 31) as f32) * 2.0 - 1.0
    }
    /// The next value in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
}

/// Touching poses: the tip pushed up to `depth` into the surface along the normal, the pen's
/// axis (+z at rest) within about 40 degrees of the outward normal, any twist.
pub fn touch_poses(obj: &Mesh<'_>, n: usize, depth: f32, seed: u64) -> Vec<(Vec3, Quat)> {
    let mut r = Lcg(seed);
    let boundary: Vec<usize> = (0..obj.node_count())
        .filter(|&i| obj.nodes()[i].boundary())
        .collect();
    (0..n)
        .map(|_| {
            let b = boundary[(r.unit() * boundary.len() as f32) as usize % boundary.len()];
            let nrm = obj.normals()[b];
            let tip = obj.positions()[b] - nrm * r.range(0.0, depth);
            let tilt = Vec3::new(r.range(-0.6, 0.6), r.range(-0.6, 0.6), r.range(-0.6, 0.6));
            let axis = (nrm + tilt).normalize();
            let q = Quat::from_rotation_arc(Vec3::Z, axis)
                * Quat::from_rotation_z(r.range(0.0, std::f32::consts::TAU));
            (tip, q)
        })
        .collect()
}

/// Adversarial poses: the tip near the surface, pushed in by up to `depth`, any orientation,
/// so the pen often runs deep through the object.
pub fn impaled_poses(obj: &Mesh<'_>, n: usize, depth: f32, seed: u64) -> Vec<(Vec3, Quat)> {
    let mut r = Lcg(seed);
    let boundary: Vec<usize> = (0..obj.node_count())
        .filter(|&i| obj.nodes()[i].boundary())
        .collect();
    (0..n)
        .map(|_| {
            let b = boundary[(r.unit() * boundary.len() as f32) as usize % boundary.len()];
            let tip = obj.positions()[b] - obj.normals()[b] * r.range(0.0, depth);
            let q = Quat::from_xyzw(
                r.range(-1.0, 1.0),
                r.range(-1.0, 1.0),
                r.range(-1.0, 1.0),
                r.range(-1.0, 1.0),
            )
            .normalize();
            (tip, q)
        })
        .collect()
}

/// The soft-body benches' scene on `soft` (the soft bench and `soft_positions`, which the
/// numpy reference `scripts/xpbd_reference.py` reproduces): E 100 kPa, nu 0.3, density 1000,
/// gravity, damping 20 /s, 10 substeps of `iterations` iterations, the lowest tenth of the
/// body in z fixed. Returns the body at rest and the fixed node count.
///
/// # Errors
/// The core's refusal of the mesh or the parameters.
pub fn soft_bench_body(
    soft: &mut tetradrill::soft::SoftOwned,
    iterations: u32,
) -> Result<(tetradrill_core::soft::SoftBody<'_>, usize), tetradrill_core::soft::SoftError> {
    use tetradrill_core::soft::{Material, SoftParams};
    let (lo, hi) = soft
        .rest
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), x| (a.min(x.z), b.max(x.z)));
    let mat = Material {
        young: 1e5,
        poisson: 0.3,
        density: 1000.0,
    };
    let params = SoftParams {
        gravity: Vec3::new(0.0, 0.0, -9.81),
        damping: 20.0,
        substeps: 10,
        iterations,
    };
    let mut body = soft.body(&[mat], params)?;
    let fixed = body.fix_below(Vec3::new(0.0, 0.0, lo + 0.1 * (hi - lo)), Vec3::Z);
    Ok((body, fixed))
}
