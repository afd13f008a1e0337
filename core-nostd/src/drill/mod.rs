//! Budgeted erosion by tool sample spheres (seed 001 section 3.2; DESIGN 2.5).
//!
//! [`Drill::step`] takes the candidate coarse tets near the tool (from the spatial hash) and
//! the active sample spheres, refines the hierarchy nodes that cross a sphere until
//! `max_depth` or `min_area`, and erases the frontier nodes inside it (a leaf entirely inside,
//! or a leaf at the refinement limit whose centroid is inside). A work budget bounds each tick;
//! the rest waits in a pending deque in caller storage and is done in the next ticks, against
//! the sphere it was queued for, so the removed shape converges to the swept volume.

mod candidates;
mod deque;
mod spacing;
mod sphere;
mod step;

pub use candidates::candidates_brute_force;
pub use deque::FINE_MIN_DEQUE;
pub use spacing::{Spacing, DRILL_HOLD_STEPS, DRILL_SETTLE, DRILL_SPACING, MAX_STEP_SPHERES};
pub use sphere::{classify, Class, Sphere};
pub use step::{Drill, DrillParams, DrillReport, Pending, WorkCost, DEFER_LAG, SWEPT, SWEPT_AHEAD};

#[cfg(test)]
mod tests;
