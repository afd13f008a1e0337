//! The soft body of `builtin:firmware-soft` (cfg `scenario_soft`): the block as an XPBD body,
//! its step and the world's update spread over the ticks of each cycle by the core's
//! `soft::Link`, run in the simulation task after each `World::simulate` with the force the
//! servo wrote that tick, exactly as the host's `SoftDriver` with `--soft-spread`.

use core::sync::atomic::Ordering;

use crate::println;

use tetradrill_core::servo::World;
use tetradrill_core::soft::{mesh_tets, Link, LinkBuffers, SoftBody, SoftMesh, SoftParams};
use tetradrill_core::Vec3;

use crate::clock::{self, Stats};
use crate::scenario;
use crate::servo::SERVO_BUSY;
use crate::storage::soft as statics;

/// Set at build time (`TETRADRILL_SOFT_LOG=1`) to print one line per tick: the servo tick,
/// the link's units and its instructions (for fitting the work units).
const SOFT_LOG: bool = option_env!("TETRADRILL_SOFT_LOG").is_some();

/// The soft body, its link and its buffers, and what its ticks cost.
pub struct SoftSim {
    body: SoftBody<'static>,
    link: Link,
    a: &'static mut [Vec3],
    b: &'static mut [Vec3],
    next: &'static mut [Vec3],
    /// Instructions of the link's tick on a cycle's other ticks (its share of the work).
    work: Stats,
    /// Instructions of the link's tick on a cycle's last tick (its share and the commit).
    last: Stats,
    /// Instructions of a whole cycle (one step).
    step: Stats,
    cycle: u64,
    units_max: u32,
    max_displacement: f32,
}

impl SoftSim {
    /// The body over the block at rest, fixed in its lowest tenth, and the world made
    /// deforming with its spare tables (call before the first step).
    pub fn new(world: &mut World<'static>) -> Self {
        let st = statics::take();
        let n = world.mesh().node_count();
        if st.rest.len() != n {
            crate::fail("soft storage counts differ from the mesh");
        }
        st.rest.copy_from_slice(world.mesh().positions());
        let rest: &'static [Vec3] = st.rest;
        if mesh_tets(world.mesh(), st.tets).is_none() {
            crate::fail("soft tet storage too small");
        }
        let tets: &'static [[u32; 4]] = st.tets;
        if world.enable_deformation(st.world_rest).is_err() || world.set_spare(st.spare).is_err() {
            crate::fail("the world refused its soft storage");
        }
        let mut body = SoftBody::new(
            SoftMesh {
                rest,
                tets,
                tet_material: &[],
            },
            &[scenario::SOFT_MATERIAL],
            SoftParams {
                gravity: Vec3::ZERO,
                damping: scenario::SOFT_DAMPING,
                substeps: scenario::SOFT_SUBSTEPS,
                iterations: 1,
            },
            st.storage,
        )
        .unwrap_or_else(|_| crate::fail("the soft body was refused"));
        // The host's default support: the lowest tenth of the rest extent in z.
        let (lo, hi) = rest
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.z), hi.max(p.z))
            });
        body.fix_below(Vec3::new(0.0, 0.0, lo + 0.1 * (hi - lo)), Vec3::Z);
        let link = Link::new(&body, world, scenario::SOFT_TICKS, scenario::DT)
            .unwrap_or_else(|_| crate::fail("the soft link was refused"));
        Self {
            body,
            link,
            a: st.link.a,
            b: st.link.b,
            next: st.link.next,
            work: Stats::default(),
            last: Stats::default(),
            step: Stats::default(),
            cycle: 0,
            units_max: 0,
            max_displacement: 0.0,
        }
    }

    /// The link's tick after the simulation step of servo tick `tick`, whose force was
    /// `force`. Returns its instructions (the servo's preemptions taken out).
    pub fn tick(
        &mut self,
        world: &mut World<'static>,
        tick: u32,
        force: Vec3,
        overhead: u64,
    ) -> u64 {
        let busy0 = SERVO_BUSY.load(Ordering::Acquire);
        let t0 = clock::now();
        let out = self.link.tick(
            &mut self.body,
            world,
            LinkBuffers {
                a: self.a,
                b: self.b,
                next: self.next,
            },
            force,
        );
        let t1 = clock::now();
        let busy = SERVO_BUSY.load(Ordering::Acquire).wrapping_sub(busy0);
        let n = clock::instructions((t1 - t0).saturating_sub(busy as u64)).saturating_sub(overhead);
        let out = out.unwrap_or_else(|_| crate::fail("the soft link failed"));
        if SOFT_LOG {
            println!("soft {} {} {}", tick, out.units, n);
        }
        self.units_max = self.units_max.max(out.units);
        self.cycle += n;
        match out.committed {
            Some(rep) => {
                self.last.add(tick, n);
                self.step.add(tick, self.cycle);
                self.cycle = 0;
                self.max_displacement = self.max_displacement.max(rep.max_displacement);
            }
            None => self.work.add(tick, n),
        }
        n
    }

    /// Prints the soft body's lines of the report.
    pub fn report(&self) {
        println!(
            "soft: rate_hz {} ticks_per_step {} substeps {} units_per_tick {} units_max {} cycle_units {} steps {} late {}",
            scenario::SOFT_RATE_HZ,
            self.link.ticks(),
            scenario::SOFT_SUBSTEPS,
            self.link.units_per_tick(),
            self.units_max,
            self.link.cycle_units(),
            self.link.steps(),
            self.link.late()
        );
        println!("soft_work_instructions_max={}", self.work.max);
        println!("soft_work_instructions_mean={}", self.work.mean());
        println!("soft_last_tick_instructions_max={}", self.last.max);
        println!("soft_last_tick_instructions_mean={}", self.last.mean());
        println!("soft_step_instructions_max={}", self.step.max);
        println!("soft_step_instructions_mean={}", self.step.mean());
        println!("soft_max_displacement={}", self.max_displacement);
    }
}
