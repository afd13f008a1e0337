//! Budgeted erosion by tool sample spheres (Turini et al. 2006, section 3.2).
//!
//! [`Drill::step`] takes the candidate coarse tets near the tool (from the spatial hash) and
//! the active sample spheres, refines the hierarchy nodes that cross a sphere until
//! `max_depth` or `min_area`, and erases the frontier nodes inside it (a leaf entirely inside,
//! or a leaf at the refinement limit whose centroid is inside). A work budget bounds each tick;
//! the rest waits in a pending deque in caller storage and is done in the next ticks, against
//! the sphere it was queued for, so the removed shape converges to the swept volume.
//!
//! With materials per region ([`Regions`], [`Drill::set_regions`]) a leaf is removed only while
//! the burr presses harder than its region's threshold, at the rate its hardness gives: each
//! region earns credit from the pressing force and a leaf is erased once its region's credit
//! covers its volume (`material.rs`, docs/DRILLING.md "Materials").

mod candidates;
mod cost;
mod crumbs;
mod deque;
mod item;
mod material;
mod spacing;
mod sphere;
mod step;
mod swept;

pub use candidates::candidates_brute_force;
pub use cost::{DrillParams, WorkCost};
pub use deque::FINE_MIN_DEQUE;
pub use material::{Material, Region, RegionError, Regions, Spend, CREDIT_STEPS};
pub use spacing::{Spacing, DRILL_HOLD_STEPS, DRILL_SETTLE, DRILL_SPACING, MAX_STEP_SPHERES};
pub use sphere::{classify, Class, Sphere};
pub use step::{Drill, DrillReport, Pending, CRUMB_SHARE, DEFER_LAG};
pub use swept::{SWEPT, SWEPT_AHEAD};

#[cfg(test)]
mod tests;
