//! `--body soft` as the simulation loop takes it ([`SoftSpec`]): the materials, per region
//! where the set-up gives them, the fixed nodes, the rate and substeps; and what a body's
//! materials and stiffness come to ([`MaterialUse`], [`Stiffness`]).

use serde::Serialize;

use tetradrill_core::soft::Material;

use super::SoftOwned;
use crate::error::Error;
use crate::setup::Setup;
use crate::traces::PERIOD_S;

/// Young's modulus of `--body soft` without `--young`, pascal: soft tissue's order, and a
/// dent of about a centimetre under the demo's few newtons on its block of 1 m.
pub const DEFAULT_YOUNG: f64 = 5_000.0;
/// Poisson ratio of `--body soft` without `--poisson`.
pub const DEFAULT_POISSON: f64 = 0.3;
/// Density of the soft body, kilogram per cubic metre (water, as soft tissue).
pub const DENSITY: f32 = 1000.0;
/// Velocity damping rate of the soft body, per second: above critical (`2 omega`) for the
/// demo block's slowest modes at the default modulus (`omega` a few rad/s), so a dent does
/// not ring; it settles in a second or two.
pub const DAMPING: f32 = 10.0;
/// XPBD substeps per physics step (one iteration each) without `--soft-substeps`.
pub const SUBSTEPS: u32 = 10;
/// Physics steps a second without `--soft-rate`: four servo ticks a step.
pub const DEFAULT_RATE_HZ: f64 = 250.0;

/// Which nodes of a soft body are fixed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fix {
    /// Rest coordinate on the axis (0, 1, 2: x, y, z) at or below the value.
    Below(usize, f64),
    /// The lowest tenth of the body's rest extent in z.
    LowestTenth,
}

/// One region's soft values (a set-up's region `young`, `poisson`, `density`);
/// each absent one is the body's global value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoftRegion {
    /// The mesh's region label.
    pub label: i32,
    /// Young's modulus, pascal.
    pub young: Option<f64>,
    /// Poisson ratio.
    pub poisson: Option<f64>,
    /// Density, kilogram per cubic metre.
    pub density: Option<f64>,
}

/// A set-up's soft body, its values checked: materials, fixed nodes, rate.
#[derive(Debug, Clone, PartialEq)]
pub struct SoftSpec {
    /// Young's modulus of every tet no region gives its own, pascal.
    pub young: f64,
    /// Poisson ratio of every tet no region gives its own.
    pub poisson: f64,
    /// Density of every tet no region gives its own, kilogram per cubic metre.
    pub density: f64,
    /// Whether `young` was given (`--young` or the key), not the default.
    pub young_given: bool,
    /// Whether `poisson` was given (`--poisson` or the key), not the default.
    pub poisson_given: bool,
    /// The scenario's regions in label order (every `[regions]` entry, with or without soft
    /// values); [`SoftSpec::materials`] lists their materials after the global one.
    pub regions: Vec<SoftRegion>,
    /// Fixed nodes.
    pub fix: Fix,
    /// Servo ticks (1 ms) per physics step.
    pub ticks_per_step: u32,
    /// XPBD substeps per physics step.
    pub substeps: u32,
    /// The step and the world's update spread over the ticks of each cycle
    /// ([`tetradrill_core::soft::Link`]).
    pub spread: bool,
}

impl SoftSpec {
    /// The soft body of `setup`, or `None` for a rigid one.
    ///
    /// # Errors
    /// [`Error::Unsupported`] for a tet-mesh tool (the soft body is pushed by a burr's
    /// contact).
    pub fn of(setup: &Setup) -> Result<Option<Self>, Error> {
        let Some(soft) = setup.soft() else {
            return Ok(None);
        };
        if setup.tool.is_mesh() {
            return Err(Error::Unsupported(
                "--body soft (key body): a soft body is pushed by a burr's contact; use \
                 --tool sphere:R or drill:..., not a mesh tool"
                    .into(),
            ));
        }
        let fix = match soft.fix_below {
            Some(f) => Fix::Below(f.axis, f.value),
            None => Fix::LowestTenth,
        };
        let hz = soft.rate_hz.unwrap_or(DEFAULT_RATE_HZ);
        // In label order (the materials' map is) for a binary search.
        let regions: Vec<SoftRegion> = setup
            .materials
            .regions
            .iter()
            .map(|(&label, r)| SoftRegion {
                label,
                young: r.young,
                poisson: r.poisson,
                density: r.density,
            })
            .collect();
        Ok(Some(Self {
            young: soft.young.unwrap_or(DEFAULT_YOUNG),
            poisson: soft.poisson.unwrap_or(DEFAULT_POISSON),
            density: f64::from(DENSITY),
            young_given: soft.young.is_some(),
            poisson_given: soft.poisson.is_some(),
            regions,
            fix,
            ticks_per_step: (1000.0 / hz).round().max(1.0) as u32,
            substeps: soft.substeps.unwrap_or(SUBSTEPS),
            spread: soft.spread,
        }))
    }

    /// A single-material body: every tet of `young`, `poisson` and [`DENSITY`], no regions
    /// (its values not counted as given on the command line: no warning when regions added
    /// later cover every tet).
    pub fn uniform(young: f64, poisson: f64, fix: Fix, ticks_per_step: u32) -> Self {
        Self {
            young,
            poisson,
            density: f64::from(DENSITY),
            young_given: false,
            poisson_given: false,
            regions: Vec::new(),
            fix,
            ticks_per_step,
            substeps: SUBSTEPS,
            spread: false,
        }
    }

    /// Physics steps a second.
    pub fn rate_hz(&self) -> f64 {
        1000.0 / f64::from(self.ticks_per_step)
    }

    /// The global material: every tet no region gives its own values.
    pub fn material(&self) -> Material {
        Material {
            young: self.young as f32,
            poisson: self.poisson as f32,
            density: self.density as f32,
        }
    }

    /// The values of `region` (Young's modulus, Poisson ratio, density): its own, the global
    /// ones where it has none.
    pub fn region_values(&self, region: &SoftRegion) -> [f64; 3] {
        [
            region.young.unwrap_or(self.young),
            region.poisson.unwrap_or(self.poisson),
            region.density.unwrap_or(self.density),
        ]
    }

    /// The material of `region` ([`SoftSpec::region_values`]).
    pub fn region_material(&self, region: &SoftRegion) -> Material {
        let [young, poisson, density] = self.region_values(region);
        Material {
            young: young as f32,
            poisson: poisson as f32,
            density: density as f32,
        }
    }

    /// The materials list of a body ([`tetradrill_core::soft::SoftMesh::tet_material`] indexes it): the global
    /// material, then each region's in [`SoftSpec::regions`] order.
    pub fn materials(&self) -> Vec<Material> {
        std::iter::once(self.material())
            .chain(self.regions.iter().map(|r| self.region_material(r)))
            .collect()
    }
}

/// One material of a soft run and the tets that have it (the JSON's `deform.materials`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MaterialUse {
    /// The region label (`null`: every tet whose label no `[regions]` entry names, the
    /// global material).
    pub label: Option<i32>,
    /// Young's modulus, pascal.
    pub young: f64,
    /// Poisson ratio.
    pub poisson: f64,
    /// Density, kilogram per cubic metre.
    pub density: f64,
    /// Tets of this material.
    pub tets: usize,
}

/// The materials `spec` gives the tets of `tet_material` (empty: all global; `tets` in all),
/// the ones with at least one tet, the global first.
///
/// # Bounded work
/// O(T + regions).
pub fn material_uses(spec: &SoftSpec, tet_material: &[u32], tets: usize) -> Vec<MaterialUse> {
    let mut count = vec![0usize; spec.regions.len() + 1];
    if tet_material.is_empty() {
        count[0] = tets;
    }
    for &m in tet_material {
        if let Some(c) = count.get_mut(m as usize) {
            *c += 1;
        }
    }
    let of = |label: Option<i32>, [young, poisson, density]: [f64; 3], tets: usize| MaterialUse {
        label,
        young,
        poisson,
        density,
        tets,
    };
    let global = [spec.young, spec.poisson, spec.density];
    std::iter::once(of(None, global, count[0]))
        .chain(
            spec.regions
                .iter()
                .zip(&count[1..])
                .map(|(r, &c)| of(Some(r.label), spec.region_values(r), c)),
        )
        .filter(|u| u.tets > 0)
        .collect()
}

/// The largest substep stiffness ratio of a soft body's tets: `s = h^2 (lambda + 2 mu) /
/// (rho l^2)`, the square of the substep's Courant number (`h` the substep, `l` the tet's
/// shortest edge), an estimate of docs/SOFT.md's `s = |grad C|_W^2 h^2 / alpha` ("Static
/// accuracy"): a steady state is about `1 + s` times softer than the material, so above 1 the
/// body does not hold its material's stiffness and under a tool's load it may not settle.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Stiffness {
    /// The largest `s` over the tets.
    pub s_max: f64,
    /// The region label of the tet with the largest `s` (`null`: a tet of the global
    /// material).
    pub label: Option<i32>,
}

impl Stiffness {
    /// The largest ratio over `owned`'s tets, with the materials of `spec` and its substep.
    pub fn of(owned: &SoftOwned, spec: &SoftSpec) -> Self {
        let materials = spec.materials();
        let h = f64::from(spec.ticks_per_step) * PERIOD_S / f64::from(spec.substeps.max(1));
        let mut worst = Self::default();
        for (t, tet) in owned.tets.iter().enumerate() {
            let m = owned.tet_material.get(t).map_or(0, |&m| m as usize);
            let Some(mat) = materials.get(m) else {
                continue;
            };
            let (e, nu, rho) = (
                f64::from(mat.young),
                f64::from(mat.poisson),
                f64::from(mat.density),
            );
            // P-wave modulus lambda + 2 mu.
            let modulus = e * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu));
            let mut l2 = f64::INFINITY;
            for i in 0..4 {
                for j in i + 1..4 {
                    // Node numbers were checked with the mesh; a missing one is skipped.
                    let node = |k: u32| owned.rest.get(k as usize).copied();
                    if let (Some(a), Some(b)) = (node(tet[i]), node(tet[j])) {
                        l2 = l2.min(f64::from(a.distance_squared(b)));
                    }
                }
            }
            let s = h * h * modulus / (rho * l2);
            if s > worst.s_max {
                worst = Self {
                    s_max: s,
                    label: m
                        .checked_sub(1)
                        .and_then(|r| spec.regions.get(r))
                        .map(|r| r.label),
                };
            }
        }
        worst
    }
}
