//! A soft body through the C interface, for the tests that use one: the block's arrays as the
//! host builds them, the body in memory of its own, the default parameters.

use std::ptr;

use super::Memory;
use tetradrill::soft::SoftOwned;
use tetradrill_core::Vec3;
use tetradrill_ffi::*;

/// The `n`-block's nodes (x, y, z each) and positively oriented tets, from the host's mesh
/// build.
pub fn block(n: usize) -> (Vec<f32>, Vec<u32>) {
    let mut m = tetradrill::meshio::load(std::path::Path::new(&format!("builtin:block:{n}")), 1.0)
        .expect("built-in block");
    let o = SoftOwned::from_mesh(&m.mesh.view());
    (
        o.rest.iter().flat_map(|v| v.to_array()).collect(),
        o.tets.iter().flatten().copied().collect(),
    )
}

/// Each node's lumped mass (a quarter of each tet's mass to each corner) of a body of
/// `density` over `xyz` and positively oriented `tets`, in f64 from the rest geometry.
pub fn lumped_masses(xyz: &[f32], tets: &[u32], density: f64) -> Vec<f64> {
    let mut mass = vec![0.0f64; xyz.len() / 3];
    let at = |k: u32| {
        let i = 3 * k as usize;
        [xyz[i], xyz[i + 1], xyz[i + 2]].map(f64::from)
    };
    for t in tets.chunks(4) {
        let [a, b, c, d] = [at(t[0]), at(t[1]), at(t[2]), at(t[3])];
        let e = |p: [f64; 3]| [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
        let (u, v, w) = (e(b), e(c), e(d));
        let vol = (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
            + u[2] * (v[0] * w[1] - v[1] * w[0]))
            / 6.0;
        assert!(vol > 0.0);
        for &k in t {
            mass[k as usize] += density * vol / 4.0;
        }
    }
    mass
}

/// The momentum of nodes of `mass` moving at `velocities` (x, y, z each), in f64.
pub fn momentum(mass: &[f64], velocities: &[f32]) -> [f64; 3] {
    core::array::from_fn(|j| {
        mass.iter()
            .zip(velocities.chunks(3))
            .map(|(m, v)| m * f64::from(v[j]))
            .sum()
    })
}

/// The bits of `v`, x, y, z of each vector.
pub fn vec_bits(v: &[Vec3]) -> Vec<u32> {
    v.iter()
        .flat_map(|f| f.to_array().map(f32::to_bits))
        .collect()
}

/// Asserts that the C run's forces are the core's, bit for bit, naming the first tick that
/// differs.
pub fn assert_same_forces(c: &[Vec3], core: &[Vec3]) {
    assert!(core.iter().any(|f| f.z > 1.0), "the burr presses the block");
    let first = vec_bits(c)
        .iter()
        .zip(vec_bits(core))
        .position(|(a, b)| *a != b);
    assert_eq!(
        first.map(|i| i / 3),
        None,
        "the first tick whose force differs"
    );
}

/// A soft body over `xyz` and `tets` in memory of its own.
pub struct CSoft {
    _mem: Memory,
    pub h: *mut TdSoft,
    pub nodes: u32,
}

impl CSoft {
    pub fn new(xyz: &[f32], tets: &[u32], p: &TdSoftParams) -> Result<Self, (TdStatus, u32)> {
        let (nodes, tcount) = ((xyz.len() / 3) as u32, (tets.len() / 4) as u32);
        let (mut size, mut align) = (0usize, 0usize);
        // SAFETY: valid out-pointers.
        let st = unsafe { td_soft_size(nodes, tcount, &mut size, &mut align) };
        if st != TdStatus::TdOk {
            return Err((st, u32::MAX));
        }
        let mem = Memory::new(size, align);
        let mut h = ptr::null_mut();
        let mut bad = u32::MAX;
        // SAFETY: `size` bytes at `align`; the arrays' lengths match the counts.
        let st = unsafe {
            td_soft_init(
                mem.ptr.cast(),
                size,
                xyz.as_ptr(),
                nodes,
                tets.as_ptr(),
                tcount,
                p,
                &mut h,
                &mut bad,
            )
        };
        if st != TdStatus::TdOk {
            return Err((st, bad));
        }
        Ok(Self {
            _mem: mem,
            h,
            nodes,
        })
    }

    pub fn nodes(&self, field: TdSoftField) -> Vec<f32> {
        let mut out = vec![0.0f32; 3 * self.nodes as usize];
        // SAFETY: a live handle; `3 nodes` floats.
        let st = unsafe { td_soft_nodes(self.h, field as u32, out.as_mut_ptr(), self.nodes) };
        assert_eq!(st, TdStatus::TdOk);
        out
    }

    pub fn step(&self, dt: f32, loads: Option<&[f32]>) -> TdStatus {
        // SAFETY: a live handle; `loads` of `3 nodes` floats or null.
        unsafe { td_soft_step(self.h, dt, loads.map_or(ptr::null(), |l| l.as_ptr())) }
    }

    /// Holds the block's base (the nodes at or below z = -0.49); how many.
    pub fn hold_base(&self) -> u32 {
        let mut held = 0u32;
        let (origin, up) = (
            TdVec3 {
                x: 0.0,
                y: 0.0,
                z: -0.49,
            },
            TdVec3 {
                x: 0.0,
                y: 0.0,
                z: 1.0,
            },
        );
        // SAFETY: a live handle and a writable count.
        let st = unsafe { td_soft_fix_below(self.h, origin, up, &mut held) };
        assert_eq!(st, TdStatus::TdOk);
        held
    }

    pub fn counts(&self) -> TdSoftCounts {
        let mut c = TdSoftCounts::default();
        // SAFETY: a live handle and a writable struct.
        assert_eq!(unsafe { td_soft_counters(self.h, &mut c) }, TdStatus::TdOk);
        c
    }
}

pub fn defaults() -> TdSoftParams {
    let mut p = TdSoftParams {
        young: 0.0,
        poisson: 0.0,
        density: 0.0,
        damping: 0.0,
        substeps: 0,
        iterations: 0,
        gravity: TdVec3::default(),
    };
    // SAFETY: a writable struct.
    assert_eq!(unsafe { td_soft_params_default(&mut p) }, TdStatus::TdOk);
    p
}
