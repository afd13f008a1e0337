//! The simulation task: drains the servo's tool samples, steps the world (candidates, drill,
//! contact search) and publishes the contact plane, the status and the viewer's snapshots.

use std::sync::atomic::{AtomicBool, Ordering};

use crossbeam::queue::ArrayQueue;
use tetradrill_core::drill::Sphere;
use tetradrill_core::force::DrillTool;
use tetradrill_core::servo::{ContactState, DrillState, World};

use crate::engine::TickParams;
use crate::platform::now_ns;
use crate::soft::SoftDriver;

use super::{DrillContact, ServoCounters, SimStatus, ToolSample, MAX_SPHERES};

/// A drill's side of the simulation task: the tool's shape, its passive points' state, and
/// where the step's planes go to the servo.
#[derive(Debug)]
pub struct ShaftLink<'a> {
    /// The drill's shape (its burr radius follows the viewer's radius control).
    pub tool: DrillTool,
    /// The passive points, carried from step to step.
    pub state: DrillState,
    /// To the servo's [`super::DrillLaw`].
    pub out: &'a mut triple_buffer::Input<DrillContact>,
}

impl<'a> ShaftLink<'a> {
    /// A link for `tool` with no point tracked yet.
    pub fn new(tool: DrillTool, out: &'a mut triple_buffer::Input<DrillContact>) -> Self {
        Self {
            tool,
            state: DrillState::default(),
            out,
        }
    }
}

/// How the simulation task ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimEnd {
    /// `stop` was set.
    Stopped,
    /// The viewer asked for a reset: rebuild the world and call the task again.
    Reset,
}

/// The simulation task: drains the tool ring, erodes along the swept path (burr positions
/// [`tetradrill_core::servo::DRILL_SPACING`] radii apart, up to [`MAX_SPHERES`] per step), updates the contact plane at
/// the newest position and publishes it, until `stop`. With a `viewer`, it applies the
/// viewer's controls (radius and stiffness also go to the servo through `counters`) and
/// publishes snapshots of the changed surface without ever waiting.
///
/// With a `shaft` (the drill tool), each step then tracks the shaft's passive points at the
/// newest pose ([`World::track_shaft`]) and publishes the burr's plane with the
/// points' planes ([`DrillContact`]); the burr is pressed by the burr's own force
/// (`counters.burr_press_bits`), not the shaft's push, and the viewer gets the shaft.
#[allow(clippy::too_many_arguments)]
pub fn simulation_task(
    world: &mut World<'_>,
    params: TickParams,
    ring: &ArrayQueue<ToolSample>,
    contact: &mut triple_buffer::Input<ContactState>,
    status: &mut triple_buffer::Input<SimStatus>,
    stop: &AtomicBool,
    counters: &ServoCounters,
    viewer: Option<&mut crate::viewer::publish::SimViewer<'_>>,
    shaft: Option<ShaftLink<'_>>,
) -> SimEnd {
    simulation_task_soft(
        world, params, ring, contact, status, stop, counters, viewer, shaft, None,
    )
}

/// [`simulation_task`] over a deforming world with a soft body (`--body soft`): after each
/// step, the servo's last force over the ticks the step covered goes to the body
/// ([`SoftDriver::after_ticks`]), which steps at its own rate and hands its positions to the
/// world; the new contact plane is published, and the viewer gets the whole deformed surface.
/// A refused soft step (it does not happen on a body the driver accepted) prints one line and
/// leaves the body where it was for the rest of the run.
#[allow(clippy::too_many_arguments)]
pub fn simulation_task_soft(
    world: &mut World<'_>,
    params: TickParams,
    ring: &ArrayQueue<ToolSample>,
    contact: &mut triple_buffer::Input<ContactState>,
    status: &mut triple_buffer::Input<SimStatus>,
    stop: &AtomicBool,
    counters: &ServoCounters,
    mut viewer: Option<&mut crate::viewer::publish::SimViewer<'_>>,
    mut shaft: Option<ShaftLink<'_>>,
    mut soft: Option<&mut SoftDriver<'_>>,
) -> SimEnd {
    let mut params = params;
    let mut st = SimStatus::default();
    let mut spheres = [Sphere::default(); MAX_SPHERES];
    let mut paused = false;
    let mut reset_seen: Option<u32> = None;
    let mut last_tool: Option<ToolSample> = None;
    loop {
        if let Some(c) = viewer.as_deref_mut().and_then(|v| v.new_controls()) {
            if reset_seen.is_some_and(|r| r != c.reset) {
                return SimEnd::Reset;
            }
            reset_seen = Some(c.reset);
            params.radius = c.radius;
            params.reach = 0.5 * c.radius;
            params.force.stiffness = c.stiffness;
            params.drill.max_depth = c.max_depth;
            paused = c.paused;
            counters
                .radius_bits
                .store(c.radius.to_bits(), Ordering::Relaxed);
            counters
                .stiffness_bits
                .store(c.stiffness.to_bits(), Ordering::Relaxed);
        }
        let spacing = tetradrill_core::servo::DRILL_SPACING * params.radius;
        let stopping = stop.load(Ordering::Relaxed);
        let mut ns = 0usize;
        let mut latest: Option<ToolSample> = None;
        let mut drained = 0u32;
        while let Some(s) = ring.pop() {
            drained += 1;
            let on = s.buttons & tetradrill_core::script::DRILL_ON != 0 && !paused;
            if on {
                let far = ns == 0 || spheres[ns - 1].center.distance(s.position) >= spacing;
                if far && ns < MAX_SPHERES {
                    spheres[ns] = Sphere {
                        center: s.position,
                        radius: params.radius,
                    };
                    ns += 1;
                } else if far {
                    spheres[MAX_SPHERES - 1].center = s.position;
                }
            }
            latest = Some(s);
        }
        // When stopping with nothing new, one more step at the last position (no erosion)
        // lets the viewer's last snapshot out.
        let last = if stopping && viewer.is_some() {
            last_tool.take()
        } else {
            None
        };
        let Some(tool) = latest.or(last) else {
            if stopping {
                break;
            }
            std::thread::sleep(std::time::Duration::from_micros(200));
            continue;
        };
        last_tool = Some(tool);
        let t0 = now_ns();
        let on = tool.buttons & tetradrill_core::script::DRILL_ON != 0 && !paused;
        if on && ns > 0 && spheres[ns - 1].center != tool.position {
            if ns < MAX_SPHERES {
                ns += 1;
            }
            spheres[ns - 1] = Sphere {
                center: tool.position,
                radius: params.radius,
            };
        }
        // The servo's last force presses the burr into the material for the servo ticks
        // this step covers (one per sample drained).
        let press = if shaft.is_some() {
            f32::from_bits(counters.burr_press_bits.load(Ordering::Relaxed))
        } else {
            counters.force().length()
        };
        world.set_pressing(press, drained as f32 * crate::traces::PERIOD_S as f32);
        let rep = world.simulate_spheres(
            tool.position,
            params.radius,
            params.reach,
            &spheres[..ns],
            &params.drill,
        );
        contact.write(*world.contact());
        if let Some(link) = shaft.as_mut() {
            if link.tool.burr_radius != params.radius {
                // The viewer changed the burr: the points move along the shaft, tracked anew.
                link.tool.burr_radius = params.radius;
                link.state = DrillState::default();
            }
            let axis = DrillTool::axis(tool.rotation);
            // A full candidate list is counted in the world's saturations.
            world.track_shaft(
                &link.tool,
                tool.position,
                axis,
                link.tool.shaft_reach(params.reach),
                &mut link.state,
            );
            link.out.write(DrillContact {
                burr: *world.contact(),
                shaft: link.state,
            });
        }
        let mut deformed = false;
        if let Some(body) = soft.as_deref_mut() {
            match body.after_ticks(world, counters.force(), drained) {
                Ok(stepped) => deformed = stepped,
                Err(e) => {
                    errln!("tetradrill: {e}; the soft body stays where it is");
                    soft = None;
                }
            }
        }
        let dt = now_ns() - t0;
        st.steps += 1;
        st.last_step_ns = dt;
        st.max_step_ns = st.max_step_ns.max(dt);
        st.removed_volume = world.hierarchy().removed_volume();
        st.hierarchy_nodes = world.hierarchy().node_count();
        st.visible_faces = world.hierarchy().visible_face_count();
        st.saturations = world.saturations().total();
        st.press_n = press;
        // Only a material that is not removed at once has a threshold worth showing.
        st.threshold_n = world
            .contact_material()
            .filter(|m| m.threshold > 0.0 || m.rate_limited())
            .map(|m| m.threshold);
        status.write(st);
        if let Some(v) = viewer.as_deref_mut() {
            v.note_step(world, rep.drill.created + rep.drill.erased > 0);
            if deformed {
                v.note_deformed();
            }
            let mut tv = crate::viewer::publish::tool_view(
                world,
                tool.position,
                params.radius,
                counters.force(),
                on,
            );
            if let Some(link) = shaft.as_ref() {
                let q = tool.rotation;
                tv = crate::viewer::publish::with_shaft(
                    tv,
                    Some(link.tool),
                    [q.w, q.x, q.y, q.z],
                    &link.state,
                );
            }
            if stopping {
                // The last picture must get through: the servo has stopped, waiting is fine.
                let until = now_ns() + 2_000_000_000;
                while !v.publish_now(world, tv, &st, now_ns()) && now_ns() < until {
                    std::thread::sleep(std::time::Duration::from_millis(2));
                }
            } else {
                v.publish(world, tv, &st, now_ns());
            }
        }
        if stopping {
            break;
        }
    }
    SimEnd::Stopped
}
