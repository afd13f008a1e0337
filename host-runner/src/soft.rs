//! Host-owned storage for one soft body (`tetradrill_core::soft`): the caller slices the core
//! borrows, sized from a rest mesh, so a host, a test or a bench builds a body in one call;
//! and the simulation loop's side of `--body soft` ([`SoftSpec`], [`SoftDriver`]), with a
//! material per region of the mesh where the scenario's `[regions]` table gives one.

use tetradrill_core::mesh::Mesh;
use tetradrill_core::servo::World;
use tetradrill_core::soft::{
    mesh_tets, Link, LinkBuffers, Material, SoftBody, SoftError, SoftMesh, SoftParams, SoftStorage,
    TetRest,
};
use tetradrill_core::Vec3;

use serde::Serialize;

use crate::error::CliError;
use crate::platform::now_ns;
use crate::scenario::{parse_fix_below, Body, Scenario};
use crate::stats::summarise_ns;
use crate::traces::PERIOD_S;

/// Every slice a [`SoftBody`] borrows, owned: the rest mesh and the per-node and per-tet state.
#[derive(Debug, Clone)]
pub struct SoftOwned {
    /// Rest positions.
    pub rest: Vec<Vec3>,
    /// Tets as node indices.
    pub tets: Vec<[u32; 4]>,
    /// Each tet's material index ([`SoftMesh::tet_material`]; empty: all of material 0).
    pub tet_material: Vec<u32>,
    /// [`SoftStorage::displacement`].
    pub displacement: Vec<Vec3>,
    /// [`SoftStorage::velocity`].
    pub velocity: Vec<Vec3>,
    /// [`SoftStorage::previous`].
    pub previous: Vec<Vec3>,
    /// [`SoftStorage::mass`].
    pub mass: Vec<f32>,
    /// [`SoftStorage::inv_mass`].
    pub inv_mass: Vec<f32>,
    /// [`SoftStorage::tet_rest`].
    pub tet_rest: Vec<TetRest>,
    /// [`SoftStorage::lambdas`].
    pub lambdas: Vec<[f32; 2]>,
}

impl SoftOwned {
    /// Storage for a body over `rest` and `tets` (zeroed state; [`SoftOwned::body`] fills it).
    pub fn new(rest: Vec<Vec3>, tets: Vec<[u32; 4]>) -> Self {
        let (n, t) = (rest.len(), tets.len());
        Self {
            rest,
            tets,
            tet_material: Vec::new(),
            displacement: vec![Vec3::ZERO; n],
            velocity: vec![Vec3::ZERO; n],
            previous: vec![Vec3::ZERO; n],
            mass: vec![0.0; n],
            inv_mass: vec![0.0; n],
            tet_rest: vec![TetRest::default(); t],
            lambdas: vec![[0.0; 2]; t],
        }
    }

    /// Fills [`SoftOwned::tet_material`] from the mesh's region `labels` (one per tet, the
    /// world's order): a tet whose label is one of `spec`'s regions takes that region's
    /// material (index `1 + ` its place in [`SoftSpec::regions`], the order of
    /// [`SoftSpec::materials`]), every other tet the global one (index 0). Left empty when no
    /// tet takes a region's material, so such a body is the single-material one. Warns in one
    /// line when `--young` or `--poisson` was given but every tet's region sets its own.
    ///
    /// # Errors
    /// Exit status 1 when `labels` does not have one label per tet (a failure of the caller).
    pub fn set_regions(&mut self, labels: &[i32], spec: &SoftSpec) -> Result<(), CliError> {
        self.tet_material.clear();
        if spec.regions.is_empty() {
            return Ok(());
        }
        if labels.len() != self.tets.len() {
            return Err(CliError::failure(format!(
                "soft body: {} region labels for {} tets",
                labels.len(),
                self.tets.len()
            )));
        }
        let index = |l: &i32| {
            spec.regions
                .binary_search_by_key(l, |r| r.label)
                .map_or(0, |i| i as u32 + 1)
        };
        self.tet_material = labels.iter().map(index).collect();
        let global = |pick: fn(&SoftRegion) -> Option<f64>| {
            self.tet_material
                .iter()
                .any(|&m| m == 0 || pick(&spec.regions[m as usize - 1]).is_none())
        };
        let unused: Vec<&str> = [
            ("--young", spec.young_given && !global(|r| r.young)),
            ("--poisson", spec.poisson_given && !global(|r| r.poisson)),
        ]
        .iter()
        .filter(|(_, unused)| *unused)
        .map(|(flag, _)| *flag)
        .collect();
        if !unused.is_empty() {
            errln!(
                "tetradrill: warning: {} set, but every tet's region sets its own \
                 ([regions]): no effect",
                unused.join(", ")
            );
        }
        if self.tet_material.iter().all(|&m| m == 0) {
            self.tet_material.clear();
        }
        Ok(())
    }

    /// Storage for a body over a built core mesh at its current positions.
    pub fn from_mesh(mesh: &Mesh<'_>) -> Self {
        let mut tets = vec![[0u32; 4]; mesh.tet_count()];
        let n = mesh_tets(mesh, &mut tets).unwrap_or(0);
        tets.truncate(n);
        Self::new(mesh.positions().to_vec(), tets)
    }

    /// A body over this storage's state (at rest when fresh from [`SoftOwned::new`];
    /// [`SoftDriver::new`] puts it back at rest first), each tet of the material [`SoftOwned::tet_material`]
    /// names in `materials` (all of `materials[0]` when that is empty).
    ///
    /// # Errors
    /// What [`SoftBody::new`] refuses (flat or inverted tets, bad materials or parameters).
    pub fn body(
        &mut self,
        materials: &[Material],
        params: SoftParams,
    ) -> Result<SoftBody<'_>, SoftError> {
        SoftBody::new(
            SoftMesh {
                rest: &self.rest,
                tets: &self.tets,
                tet_material: &self.tet_material,
            },
            materials,
            params,
            SoftStorage {
                displacement: &mut self.displacement,
                velocity: &mut self.velocity,
                previous: &mut self.previous,
                mass: &mut self.mass,
                inv_mass: &mut self.inv_mass,
                tet_rest: &mut self.tet_rest,
                lambdas: &mut self.lambdas,
            },
        )
    }
}

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

/// One region's soft values (a scenario's `[regions.LABEL]` `young`, `poisson`, `density`);
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

/// A scenario's soft body, its values checked: materials, fixed nodes, rate.
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
    /// The soft body of `sc`, or `None` for `body = "rigid"`.
    ///
    /// # Errors
    /// Exit status 2 for a value out of range, naming the key and the flag, and for a
    /// tet-mesh tool (the soft body is pushed by a burr's contact).
    pub fn of(sc: &Scenario) -> Result<Option<Self>, CliError> {
        if sc.body == Body::Rigid {
            let set: Vec<&str> = [
                ("--young", sc.young.is_some()),
                ("--poisson", sc.poisson.is_some()),
                ("--fix-below", sc.fix_below.is_some()),
                ("--soft-rate", sc.soft_rate.is_some()),
                ("--soft-substeps", sc.soft_substeps.is_some()),
                ("--soft-spread", sc.soft_spread),
            ]
            .iter()
            .filter(|(_, on)| *on)
            .map(|(flag, _)| *flag)
            .collect();
            if !set.is_empty() {
                errln!(
                    "tetradrill: warning: {} set for a rigid body: no effect without --body soft",
                    set.join(", ")
                );
            }
            return Ok(None);
        }
        sc.check().map_err(CliError::input)?;
        if matches!(sc.tool_kind(), Ok(crate::scenario::ToolKind::Mesh(_))) {
            return Err(CliError::input(
                "--body soft (key body): a soft body is pushed by a burr's contact; use \
                 --tool sphere:R or drill:..., not a mesh tool",
            ));
        }
        let fix = match &sc.fix_below {
            Some(f) => {
                let (axis, v) = parse_fix_below(f).map_err(CliError::input)?;
                Fix::Below(axis, v)
            }
            None => Fix::LowestTenth,
        };
        let hz = sc.soft_rate.unwrap_or(DEFAULT_RATE_HZ);
        // Labels are integers (checked above); in label order for a binary search.
        let mut regions: Vec<SoftRegion> = sc
            .regions
            .iter()
            .filter_map(|(k, r)| {
                Some(SoftRegion {
                    label: k.trim().parse().ok()?,
                    young: r.young,
                    poisson: r.poisson,
                    density: r.density,
                })
            })
            .collect();
        regions.sort_by_key(|r| r.label);
        regions.dedup_by_key(|r| r.label);
        Ok(Some(Self {
            young: sc.young.unwrap_or(DEFAULT_YOUNG),
            poisson: sc.poisson.unwrap_or(DEFAULT_POISSON),
            density: f64::from(DENSITY),
            young_given: sc.young.is_some(),
            poisson_given: sc.poisson.is_some(),
            regions,
            fix,
            ticks_per_step: (1000.0 / hz).round().max(1.0) as u32,
            substeps: sc.soft_substeps.unwrap_or(SUBSTEPS),
            spread: sc.soft_spread,
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

    /// The materials list of a body ([`SoftMesh::tet_material`] indexes it): the global
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

/// The `deform` object of a soft run's JSON.
#[derive(Debug, Clone, Default, Serialize)]
pub struct DeformSummary {
    /// The largest distance of a node from its rest position over the run, metres (mesh
    /// units).
    pub max_displacement: f64,
    /// The physics step with the world's update (`World::set_positions`), microseconds.
    pub step_us: StepTiming,
    /// Physics steps a second: `replay`, the rate set; `run` and `demo`, the rate reached
    /// (steps over the run's seconds).
    pub rate_hz: f64,
    /// Physics steps run.
    pub steps: u64,
    /// Nodes fixed.
    pub fixed_nodes: usize,
    /// Young's modulus of the tets no region gives its own, pascal.
    pub young: f64,
    /// Poisson ratio of the tets no region gives its own.
    pub poisson: f64,
    /// The materials used, the global one (`label` null) first, then by region label, each
    /// with its tet count ([`MaterialUse`]).
    pub materials: Vec<MaterialUse>,
    /// The spread step's work (`--soft-spread`; absent: whole steps).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spread: Option<SpreadSummary>,
    /// How stiff the body is for its substep ([`Stiffness`]).
    pub stiffness: Stiffness,
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

/// The work of a step spread over ticks ([`tetradrill_core::soft::Link`]), in its units (one
/// is about a soft-body node update).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct SpreadSummary {
    /// Ticks a cycle (one step).
    pub ticks: u32,
    /// Units a cycle's work takes (the commit aside).
    pub cycle_units: u64,
    /// Units each tick is given.
    pub units_per_tick: u32,
    /// The most units one tick did.
    pub units_max: u32,
    /// Units a tick, on average.
    pub units_mean: f64,
    /// Cycles whose work was not done by their last tick (0: a check).
    pub late: u32,
}

/// Step timing of a soft run, microseconds.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct StepTiming {
    /// Mean.
    pub mean: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Largest.
    pub max: f64,
}

impl DeformSummary {
    /// One line for a summary.
    pub fn line(&self) -> String {
        let spread = self.spread.map_or(String::new(), |s| {
            format!(
                "; spread over {} ticks: {} units a tick (most {}, mean {:.0}, {} late)",
                s.ticks, s.units_per_tick, s.units_max, s.units_mean, s.late
            )
        });
        format!(
            "soft body ({}{} nodes fixed): {} steps at {:.0} Hz, max displacement {:.4e} m, step + world update us: mean {:.1}  p99 {:.1}  max {:.1}",
            self.materials_text(),
            self.fixed_nodes,
            self.steps,
            self.rate_hz,
            self.max_displacement,
            self.step_us.mean,
            self.step_us.p99,
            self.step_us.max
        ) + &spread
    }

    /// The materials as text, ending in a separator: `E 5000 Pa, nu 0.3, ` for one global
    /// material, else each one's values and tets (`region 1: E 3000 Pa, nu 0.3, 336 tets; ...; `).
    pub fn materials_text(&self) -> String {
        match &self.materials[..] {
            [] => return format!("E {} Pa, nu {}, ", self.young, self.poisson),
            [m] if m.label.is_none() => return format!("E {} Pa, nu {}, ", m.young, m.poisson),
            _ => {}
        }
        self.materials
            .iter()
            .map(|m| {
                let who = m
                    .label
                    .map_or("other tets".to_string(), |l| format!("region {l}"));
                format!("{who}: E {} Pa, nu {}, {} tets", m.young, m.poisson, m.tets)
            })
            .map(|t| t + "; ")
            .collect()
    }
}

/// A soft body driven by the simulation loop: the tool's reaction gathered tick by tick,
/// a physics step every [`SoftSpec::ticks_per_step`] ticks, its positions handed to the world.
#[derive(Debug)]
pub struct SoftDriver<'a> {
    body: SoftBody<'a>,
    external: Vec<Vec3>,
    now: Vec<Vec3>,
    ticks_per_step: u32,
    tick: u32,
    /// Servo ticks whose reaction `external` holds (their sum, unscaled).
    gathered: u32,
    step_ns: Vec<u64>,
    max_displacement: f32,
    fixed: usize,
    spec: SoftSpec,
    materials: Vec<MaterialUse>,
    stiffness: Stiffness,
    /// The spread step, when the spec asks for it.
    spread: Option<Spread>,
}

/// A [`SoftDriver`]'s spread step: the link (made at the first tick, from the world) and its
/// buffers, and what its ticks did.
#[derive(Debug, Default)]
struct Spread {
    link: Option<Link>,
    a: Vec<Vec3>,
    b: Vec<Vec3>,
    next: Vec<Vec3>,
    /// Nanoseconds of the cycle under way so far.
    cycle_ns: u64,
    units_max: u32,
    units_sum: u64,
    ticks: u64,
}

impl<'a> SoftDriver<'a> {
    /// A body at rest over `owned` (built from the world's mesh at rest, [`SoftOwned::from_mesh`],
    /// its regions set by [`SoftOwned::set_regions`]) with the spec's materials
    /// ([`SoftSpec::materials`]) and fixed nodes; warns in one line when no node is fixed.
    ///
    /// # Errors
    /// Exit status 2 when the core refuses the body (a flat or inverted tet, a material out
    /// of range).
    pub fn new(owned: &'a mut SoftOwned, spec: &SoftSpec) -> Result<Self, CliError> {
        let n = owned.rest.len();
        // At rest, whatever an earlier body over this storage left (a viewer's reset).
        owned.displacement.fill(Vec3::ZERO);
        owned.velocity.fill(Vec3::ZERO);
        owned.previous.fill(Vec3::ZERO);
        let (lo, hi) = owned
            .rest
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.z), hi.max(p.z))
            });
        let materials = material_uses(spec, &owned.tet_material, owned.tets.len());
        let stiffness = Stiffness::of(owned, spec);
        if stiffness.s_max > 1.0 {
            let who = stiffness
                .label
                .map_or("the body's material".to_string(), |l| format!("region {l}"));
            errln!(
                "tetradrill: warning: --body soft: {who} is too stiff for its substep of {:.3} ms \
                 (s = {:.3e} > 1, docs/SOFT.md \"Static accuracy\"): the body is about 1 + s \
                 times softer than its material and may not settle under the tool; raise \
                 --soft-substeps or --soft-rate, or use --body rigid",
                f64::from(spec.ticks_per_step) * 1000.0 * PERIOD_S
                    / f64::from(spec.substeps.max(1)),
                stiffness.s_max
            );
        }
        let mut body = owned
            .body(
                &spec.materials(),
                SoftParams {
                    gravity: Vec3::ZERO,
                    damping: DAMPING,
                    substeps: spec.substeps,
                    iterations: 1,
                },
            )
            .map_err(|e| match e {
                // A region's material: name it (the scenario checks the values first).
                SoftError::Material { index, error } if index > 0 => {
                    let label = spec.regions.get(index as usize - 1).map_or(0, |r| r.label);
                    CliError::input(format!("--body soft: regions.{label}: {error}"))
                }
                e => CliError::input(format!("--body soft: {e}")),
            })?;
        let fixed = match spec.fix {
            Fix::Below(axis, v) => {
                let up = [Vec3::X, Vec3::Y, Vec3::Z][axis];
                body.fix_below(up * v as f32, up)
            }
            Fix::LowestTenth => body.fix_below(Vec3::new(0.0, 0.0, lo + 0.1 * (hi - lo)), Vec3::Z),
        };
        if fixed == 0 {
            errln!(
                "tetradrill: warning: --fix-below fixes no node of the soft body: it drifts \
                 away under the tool"
            );
        }
        Ok(Self {
            body,
            external: vec![Vec3::ZERO; n],
            now: vec![Vec3::ZERO; n],
            ticks_per_step: spec.ticks_per_step.max(1),
            tick: 0,
            gathered: 0,
            step_ns: Vec::new(),
            max_displacement: 0.0,
            fixed,
            spec: spec.clone(),
            materials,
            stiffness,
            spread: spec.spread.then(|| Spread {
                a: vec![Vec3::ZERO; n],
                b: vec![Vec3::ZERO; n],
                next: vec![Vec3::ZERO; n],
                ..Spread::default()
            }),
        })
    }

    /// After one servo tick whose force on the user was `force`: the reaction (`-force`; a
    /// step's load is the mean over the ticks since the last step) spread over
    /// the corners of the world's contact tet at the contact point; at every
    /// `ticks_per_step`-th tick, a physics step of `ticks_per_step` ms and
    /// [`World::set_positions`]. Returns whether a step ran.
    ///
    /// # Errors
    /// A refused step or update (a failure: it does not happen on a body [`SoftDriver::new`]
    /// accepted, with positions the physics keeps finite).
    pub fn after_tick(&mut self, world: &mut World<'_>, force: Vec3) -> Result<bool, CliError> {
        self.after_ticks(world, force, 1)
    }

    /// [`SoftDriver::after_tick`] for a simulation step that covered `ticks` servo ticks of
    /// the same `force` (the real-time simulation task): their reaction is gathered (weighted
    /// by `ticks`), and at most one physics step (of the fixed `ticks_per_step` ms, loaded with
    /// the mean reaction since the last step) runs; at most a step's worth of ticks past it
    /// carry to the next call, so a physics slower than real time falls behind (a lower
    /// reached rate) instead of piling up steps or loads.
    ///
    /// # Bounded work
    /// Constant between steps; a step call adds one `SoftBody::step` (O(substeps x (N + T)))
    /// and `World::set_positions` (O(N + T + hash)) and two O(N) passes, allocating only the
    /// timing sample.
    ///
    /// # Errors
    /// As [`SoftDriver::after_tick`].
    pub fn after_ticks(
        &mut self,
        world: &mut World<'_>,
        force: Vec3,
        ticks: u32,
    ) -> Result<bool, CliError> {
        if self.spread.is_some() {
            let mut stepped = false;
            for _ in 0..ticks {
                stepped |= self.spread_tick(world, force)?;
            }
            return Ok(stepped);
        }
        if let Some(t) = world.contact_tet() {
            if force != Vec3::ZERO && ticks > 0 {
                self.body.add_point_force(
                    t.idx(),
                    world.contact().point,
                    -force * ticks as f32,
                    &mut self.external,
                );
            }
        }
        self.gathered = self.gathered.saturating_add(ticks);
        self.tick = self.tick.saturating_add(ticks);
        if self.tick < self.ticks_per_step {
            return Ok(false);
        }
        // Ticks past this step count towards the next one, at most a step's worth.
        self.tick = (self.tick - self.ticks_per_step).min(self.ticks_per_step - 1);
        let t0 = now_ns();
        // The step's load: the mean reaction over the ticks gathered since the last step.
        let mean = 1.0 / self.gathered.max(1) as f32;
        self.gathered = 0;
        for f in self.external.iter_mut() {
            *f *= mean;
        }
        self.body
            .step(self.ticks_per_step as f32 * PERIOD_S as f32, &self.external)
            .map_err(|e| CliError::failure(format!("soft body step: {e}")))?;
        self.body.write_positions(&mut self.now);
        let rep = world
            .set_positions(&self.now)
            .map_err(|e| CliError::failure(format!("soft body positions: {e}")))?;
        self.step_ns.push(now_ns() - t0);
        self.external.fill(Vec3::ZERO);
        self.max_displacement = self.max_displacement.max(rep.max_displacement);
        Ok(true)
    }

    /// One tick of the spread step ([`Link::tick`]): returns whether a step was committed
    /// (its cycle's time is then one timing sample).
    fn spread_tick(&mut self, world: &mut World<'_>, force: Vec3) -> Result<bool, CliError> {
        let Some(sp) = self.spread.as_mut() else {
            return Ok(false);
        };
        let t0 = now_ns();
        if sp.link.is_none() {
            let dt = PERIOD_S as f32;
            let link = Link::new(&self.body, world, self.ticks_per_step, dt)
                .map_err(|e| CliError::failure(format!("--soft-spread: {e}")))?;
            sp.link = Some(link);
        }
        let Some(link) = sp.link.as_mut() else {
            return Ok(false);
        };
        let out = link
            .tick(
                &mut self.body,
                world,
                LinkBuffers {
                    a: &mut sp.a,
                    b: &mut sp.b,
                    next: &mut sp.next,
                },
                force,
            )
            .map_err(|e| CliError::failure(format!("soft body: {e}")))?;
        sp.units_max = sp.units_max.max(out.units);
        sp.units_sum += u64::from(out.units);
        sp.ticks += 1;
        sp.cycle_ns += now_ns() - t0;
        let Some(rep) = out.committed else {
            return Ok(false);
        };
        self.step_ns.push(std::mem::take(&mut sp.cycle_ns));
        self.max_displacement = self.max_displacement.max(rep.max_displacement);
        Ok(true)
    }

    /// The run's figures so far.
    pub fn summary(&self) -> DeformSummary {
        let t = summarise_ns(&self.step_ns);
        DeformSummary {
            max_displacement: f64::from(self.max_displacement),
            step_us: StepTiming {
                mean: t.mean,
                p99: t.p99,
                max: t.max,
            },
            rate_hz: self.spec.rate_hz(),
            steps: self.step_ns.len() as u64,
            fixed_nodes: self.fixed,
            young: self.spec.young,
            poisson: self.spec.poisson,
            materials: self.materials.clone(),
            stiffness: self.stiffness,
            spread: self.spread.as_ref().and_then(|sp| {
                let link = sp.link.as_ref()?;
                Some(SpreadSummary {
                    ticks: link.ticks(),
                    cycle_units: link.cycle_units(),
                    units_per_tick: link.units_per_tick(),
                    units_max: sp.units_max,
                    units_mean: sp.units_sum as f64 / sp.ticks.max(1) as f64,
                    late: link.late(),
                })
            }),
        }
    }
}
