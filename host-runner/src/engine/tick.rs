//! One tick of a burr tool in one thread ([`tick`], [`tick_tool`]) and its parameters
//! ([`TickParams`]).

use tetradrill_core::drill::DrillParams;
use tetradrill_core::force::{DrillTool, ForceParams, ToolState};
use tetradrill_core::servo::{
    drill_force, servo_force, DrillState, PassiveReport, SimReport, World,
};
use tetradrill_core::Vec3;

use crate::error::Error;
use crate::setup::{Setup, Tool};
use crate::traces::{Pose, PERIOD_S};

/// The per-tick parameters of a burr tool, from a [`Setup`].
#[derive(Debug, Clone, Copy)]
pub struct TickParams {
    /// Burr radius, mesh units.
    pub radius: f32,
    /// The drill's shape when the tool is `drill:...` (a burr on a shaft of passive points).
    pub shaft: Option<DrillTool>,
    /// How far beyond the burr the simulation looks for the surface (the servo's
    /// extrapolation range).
    pub reach: f32,
    /// Drill step parameters.
    pub drill: DrillParams,
    /// Force parameters.
    pub force: ForceParams,
    /// Servo ticks between a simulation step and the force that uses its contact: 0 or 1
    /// ([`crate::setup::Drilling::servo_lag`]).
    pub servo_lag: u32,
    /// The burr's angular velocity along the tool's axis (burr to handle) while the drill is
    /// on: -1 or +1 ([`crate::setup::Spin::sign`]).
    pub spin: f32,
}

impl TickParams {
    /// The parameters of a set-up with a burr (`sphere:R` or `drill:...`).
    ///
    /// # Errors
    /// [`Error::Unsupported`] for a tet-mesh tool, and for a mesh tool's settings (a contact
    /// period, two pass threads, the entry remedy) with a burr.
    pub fn of(setup: &Setup) -> Result<Self, Error> {
        let mut shaft = None;
        let radius = match setup.tool {
            Tool::Sphere { radius } => radius as f32,
            Tool::Drill {
                burr,
                shaft_length,
                shaft_radius,
            } => {
                shaft = Some(DrillTool {
                    burr_radius: burr as f32,
                    shaft_length: shaft_length as f32,
                    shaft_radius: shaft_radius as f32,
                });
                burr as f32
            }
            Tool::Mesh { ref path, .. } => {
                return Err(Error::Unsupported(format!(
                    "tool mesh:{}: the drilling pipeline takes a spherical burr (sphere:R); \
                     tet-mesh tools are for contact-only runs",
                    path.display()
                )))
            }
        };
        let pen = &setup.pen;
        if pen.contact_period != 1 {
            return Err(Error::Unsupported(
                "--contact-period spaces a mesh tool's contact passes; a sphere tool simulates \
                 every tick"
                    .into(),
            ));
        }
        if pen.pass_threads != 1 {
            return Err(Error::Unsupported(
                "--pass-threads splits a mesh tool's contact pass over two threads; a sphere \
                 tool has no such pass"
                    .into(),
            ));
        }
        if pen.entry_remedy {
            return Err(Error::Unsupported(
                "--entry-remedy is a mesh tool's remedy (Praktikum report, section 6); a sphere \
                 tool has none"
                    .into(),
            ));
        }
        let (d, f) = (&setup.drilling, &setup.forces);
        Ok(Self {
            radius,
            shaft,
            reach: 0.5 * radius,
            drill: DrillParams {
                max_depth: d.max_depth,
                min_area: d.min_area as f32,
                budget: d.budget_per_tick,
            },
            force: ForceParams {
                stiffness: f.stiffness as f32,
                damping: f.damping as f32,
                max_force: f.max_force as f32,
                dt: PERIOD_S as f32,
                switch_time: (f.switch_ms / 1000.0) as f32,
            },
            servo_lag: d.servo_lag,
            spin: f.spin.sign(),
        })
    }
}

/// One whole tick in one thread. With `servo_lag` 0: the simulation step at `pose`, then
/// the servo force at the same pose. With `servo_lag` 1 (the RTIC firmware's release rule):
/// the servo force at `pose` from the contact of the previous tick's step, then the step at
/// `pose`, whose contact the next tick uses. Replays, `timing` and the firmware run exactly
/// this. The force's magnitude presses the burr into the material at the next step
/// ([`World::set_pressing`]; with `servo_lag` 0 the step after this tick's, with 1 this tick's
/// own step, which follows the force).
pub fn tick(
    world: &mut World<'_>,
    tool: &mut ToolState,
    p: &TickParams,
    pose: &Pose,
) -> (Vec3, SimReport) {
    let drill_on = pose.buttons & tetradrill_core::script::DRILL_ON != 0;
    tool.set_spin(spin(p, pose, drill_on));
    if p.servo_lag == 0 {
        let rep = world.simulate(pose.position, p.radius, p.reach, drill_on, &p.drill);
        let f = servo_force(world.contact(), pose.position, p.radius, tool, &p.force);
        // What presses the burr against the material in the next step: this tick's force.
        world.set_pressing(f.length(), PERIOD_S as f32);
        (f, rep)
    } else {
        let f = servo_force(world.contact(), pose.position, p.radius, tool, &p.force);
        world.set_pressing(f.length(), PERIOD_S as f32);
        let rep = world.simulate(pose.position, p.radius, p.reach, drill_on, &p.drill);
        (f, rep)
    }
}

/// The burr's spin at `pose` (`ToolState::set_spin`): the tool's axis (the pose's rotated +z,
/// burr to handle) times `p.spin` while the drill is on, zero while it is off.
fn spin(p: &TickParams, pose: &Pose, drill_on: bool) -> Vec3 {
    if !drill_on {
        return Vec3::ZERO;
    }
    let [w, x, y, z] = pose.rotation;
    DrillTool::axis(tetradrill_core::Quat::from_xyzw(x, y, z, w)) * p.spin
}

/// What a drill tool carries from tick to tick besides the burr's [`ToolState`]: its passive
/// points ([`DrillState`]) and the shaft's damping state.
#[derive(Debug, Clone, Copy, Default)]
pub struct ShaftState {
    /// The passive points' proxies and planes.
    pub drill: DrillState,
    /// The shaft's damping state.
    pub damping: ToolState,
    /// The last step's passive-point report.
    pub last: PassiveReport,
}

/// [`tick`] for any burr tool: a drill (`p.shaft`) runs [`World::simulate_drill`] and
/// [`drill_force`] with the tool's axis from the pose's rotation (`shaft` carries its
/// state); a plain burr runs [`tick`] exactly.
pub fn tick_tool(
    world: &mut World<'_>,
    tool: &mut ToolState,
    shaft: &mut ShaftState,
    p: &TickParams,
    pose: &Pose,
) -> (Vec3, SimReport) {
    let Some(d) = p.shaft else {
        return tick(world, tool, p, pose);
    };
    let drill_on = pose.buttons & tetradrill_core::script::DRILL_ON != 0;
    let [w, x, y, z] = pose.rotation;
    let axis = DrillTool::axis(tetradrill_core::Quat::from_xyzw(x, y, z, w));
    tool.set_spin(spin(p, pose, drill_on));
    let (rep, prep) = world.simulate_drill(
        &d,
        pose.position,
        axis,
        p.reach,
        drill_on,
        &p.drill,
        &mut shaft.drill,
    );
    shaft.last = prep;
    let (f, on_burr) = drill_force(
        world.contact(),
        &d,
        pose.position,
        axis,
        &shaft.drill,
        tool,
        &mut shaft.damping,
        &p.force,
    );
    // What presses the burr in the next step: the burr's own force, not the shaft's.
    world.set_pressing(on_burr.length(), PERIOD_S as f32);
    (f, rep)
}
