//! The soft body in the simulation loop ([`SoftDriver`]): the tool's reaction gathered tick by
//! tick, a physics step every few ticks (or spread over them), its positions handed to the
//! world; and what a run's JSON says of it ([`DeformSummary`]).

use serde::Serialize;

use tetradrill_core::servo::World;
use tetradrill_core::soft::{Link, LinkBuffers, SoftBody, SoftError, SoftParams, TwoParts};
use tetradrill_core::Vec3;

use super::{
    material_uses, move_on_two_threads, on_two_threads, Fix, MaterialUse, PartsOrder, SoftOwned,
    SoftSpec, Stiffness, DAMPING,
};
use crate::error::Error;
use crate::platform::now_ns;
use crate::stats::summarise_ns;
use crate::traces::PERIOD_S;

/// The fewest tets for which [`SoftDriver::with_threads`] runs a whole step on two threads:
/// the demo's block (3,072 tets) stepped 17 % slower on two (the second thread started
/// each sweep), the cow (18,098) 30 % faster (docs/SOFT.md, "Two threads").
pub const TWO_THREADS_FROM_TETS: usize = 8_192;

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
    /// Threads a whole step ran on (1 or 2; the same bits either way; 1 for the spread step).
    pub threads: usize,
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
    /// Whole steps: the body's nodes and tets in two parts, each in groups of four for the
    /// sweep's lanes ([`SoftOwned::in_two_parts`]), and the body's index of each world tet.
    /// `None` for the spread step, which keeps the world's order (the firmware's).
    order: Option<Ordered>,
    /// Threads a whole step runs on (1 or 2; the same bits either way).
    threads: usize,
}

/// A [`SoftDriver`]'s body in an order of its own.
#[derive(Debug)]
struct Ordered {
    order: PartsOrder,
    parts: Option<TwoParts>,
    body_tet: Vec<u32>,
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
    /// Whole steps number the body's nodes and tets their own way, once
    /// ([`SoftOwned::in_two_parts`], kept in `owned` for a driver made again over it); the
    /// driver maps the contact's tet and the positions to and from the world's order.
    ///
    /// # Errors
    /// Exit status 2 when the core refuses the body (a flat or inverted tet, a material out
    /// of range); a failure for a spread step over a body a whole-step driver reordered.
    pub fn new(owned: &'a mut SoftOwned, spec: &SoftSpec) -> Result<Self, Error> {
        let n = owned.rest.len();
        let (lo, hi) = owned
            .rest
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.z), hi.max(p.z))
            });
        let materials = material_uses(spec, &owned.tet_material, owned.tets.len());
        // Whole steps: the body in two parts that share no node, each part's tets in groups of
        // four that share no node (the sweep solves them four at a time), once: a driver made
        // again over the same body (a reset) finds the order it has.
        let mut order = None;
        if !spec.spread {
            if owned.driven.is_none() {
                let (two, o) = owned.in_two_parts();
                *owned = two;
                owned.driven = Some(o);
            }
            order = owned.driven.clone();
        } else if owned.driven.is_some() {
            return Err(Error::Failure(
                "--soft-spread: the soft body was reordered for whole steps".into(),
            ));
        }
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
                    Error::Soft(format!("--body soft: regions.{label}: {error}"))
                }
                e => Error::Soft(format!("--body soft: {e}")),
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
        let order = order.map(|order| {
            let mut body_tet = vec![0u32; order.tet_of.len()];
            for (new, &old) in order.tet_of.iter().enumerate() {
                body_tet[old as usize] = new as u32;
            }
            Ordered {
                parts: order.parts(&body),
                order,
                body_tet,
            }
        });
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
            order,
            threads: 1,
        })
    }

    /// [`SoftDriver::new`] for a run with no servo thread beside it (`replay`, the library's
    /// `Drilling`): whole steps on two threads where the machine has two cores
    /// ([`super::step_threads`]), the same bits as on one.
    ///
    /// # Errors
    /// As [`SoftDriver::new`].
    pub fn unattended(owned: &'a mut SoftOwned, spec: &SoftSpec) -> Result<Self, Error> {
        Ok(Self::new(owned, spec)?.with_threads(super::step_threads(1)))
    }

    /// Whole steps on `threads` threads (1 or 2: `SoftBody::step` or `SoftBody::step_two`
    /// with [`on_two_threads`], then `World::set_positions` or `World::set_positions_two`
    /// with [`move_on_two_threads`], the same bits) when the body has at least
    /// [`TWO_THREADS_FROM_TETS`] tets (a smaller one loses more to the thread's start each
    /// sweep than the second core gives); the spread step runs on the caller's thread.
    pub fn with_threads(mut self, threads: usize) -> Self {
        self.threads = if self.body.tet_count() >= TWO_THREADS_FROM_TETS {
            threads.clamp(1, 2)
        } else {
            1
        };
        self
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
    pub fn after_tick(&mut self, world: &mut World<'_>, force: Vec3) -> Result<bool, Error> {
        self.after_ticks(world, force, 1)
    }

    /// [`SoftDriver::after_tick`] for a simulation step that covered `ticks` servo ticks of
    /// the same `force` (the real-time simulation task): their reaction is gathered (weighted
    /// by `ticks`), and at most one physics step (of the fixed `ticks_per_step` ms, loaded with
    /// the mean reaction since the last step) runs; at most a step's worth of ticks past it
    /// carry to the next call, so a physics slower than real time falls behind (a lower
    /// reached rate) instead of piling up steps or loads. A spread step runs one link tick
    /// for each of at most `ticks_per_step` of the ticks: at most one cycle's work a call.
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
    ) -> Result<bool, Error> {
        if self.spread.is_some() {
            // At most a cycle's ticks a call, as whole steps run at most one step: a task that
            // fell behind drops the ticks past a cycle (their force with them) instead of
            // doing their work late, which made each call longer than the last.
            let mut stepped = false;
            for _ in 0..ticks.min(self.ticks_per_step) {
                stepped |= self.spread_tick(world, force)?;
            }
            return Ok(stepped);
        }
        if let Some(t) = world.contact_tet() {
            if force != Vec3::ZERO && ticks > 0 {
                let tet = self.order.as_ref().map_or(t.idx(), |o| {
                    o.body_tet.get(t.idx()).map_or(t.idx(), |&k| k as usize)
                });
                self.body.add_point_force(
                    tet,
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
        let dt = self.ticks_per_step as f32 * PERIOD_S as f32;
        let parts = self.order.as_ref().and_then(|o| o.parts);
        let two = self.threads >= 2 && parts.is_some();
        match parts {
            Some(parts) if two => {
                self.body
                    .step_two(dt, &self.external, parts, &mut on_two_threads)
            }
            _ => self.body.step(dt, &self.external),
        }
        .map_err(|e| Error::Failure(format!("soft body step: {e}")))?;
        match self.order.as_ref() {
            Some(o) => {
                // The body's node i is the world's node `node_of[i]`, at rest plus
                // displacement as `SoftBody::write_positions` writes it.
                let body = &self.body;
                for ((&x, &u), &k) in body
                    .rest()
                    .iter()
                    .zip(body.displacements())
                    .zip(&o.order.node_of)
                {
                    if let Some(slot) = self.now.get_mut(k as usize) {
                        *slot = x + u;
                    }
                }
            }
            None => self.body.write_positions(&mut self.now),
        }
        let rep = if two {
            world.set_positions_two(&self.now, &mut move_on_two_threads)
        } else {
            world.set_positions(&self.now)
        }
        .map_err(|e| Error::Failure(format!("soft body positions: {e}")))?;
        self.step_ns.push(now_ns() - t0);
        self.external.fill(Vec3::ZERO);
        self.max_displacement = self.max_displacement.max(rep.max_displacement);
        Ok(true)
    }

    /// One tick of the spread step ([`Link::tick`]): returns whether a step was committed
    /// (its cycle's time is then one timing sample).
    fn spread_tick(&mut self, world: &mut World<'_>, force: Vec3) -> Result<bool, Error> {
        let Some(sp) = self.spread.as_mut() else {
            return Ok(false);
        };
        let t0 = now_ns();
        if sp.link.is_none() {
            let dt = PERIOD_S as f32;
            let link = Link::new(&self.body, world, self.ticks_per_step, dt)
                .map_err(|e| Error::Failure(format!("--soft-spread: {e}")))?;
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
            .map_err(|e| Error::Failure(format!("soft body: {e}")))?;
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
            threads: if self.spread.is_some() || self.order.as_ref().and_then(|o| o.parts).is_none()
            {
                1
            } else {
                self.threads
            },
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
