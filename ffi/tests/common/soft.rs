//! A soft body through the C interface, for the tests that use one: the block's arrays as the
//! host builds them, the body in memory of its own, the default parameters.

use std::ptr;

use super::Memory;
use tetradrill::soft::SoftOwned;
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
