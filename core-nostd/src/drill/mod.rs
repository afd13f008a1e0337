//! Budgeted erosion by tool sample spheres (Turini et al. 2006, section 3.2).
//!
//! [`Drill::step`] takes the candidate coarse tets near the tool (from the spatial hash) and
//! the active sample spheres, refines the hierarchy nodes that cross a sphere until
//! `max_depth` or `min_area`, and erases the frontier nodes inside it (a leaf entirely inside,
//! or a leaf at the refinement limit whose centroid is inside). A work budget bounds each tick;
//! the rest waits in a pending deque in caller storage and is done in the next ticks, against
//! the sphere it was queued for, so the removed shape converges to the swept volume.
//!
//! With materials per region ([`Regions`], `Drill::set_regions`) a leaf is removed only while
//! the burr presses harder than its region's threshold, at the rate its hardness gives: each
//! region earns credit from the pressing force and a leaf is erased once its region's credit
//! covers its volume (`material.rs`, docs/DRILLING.md "Materials").
//!
//! ```
//! use tetradrill_core::builtin;
//! use tetradrill_core::drill::{candidates_brute_force, Drill, Pending, Sphere};
//! use tetradrill_core::hierarchy::{Hierarchy, HierarchySizes, HierarchyStorage};
//! use tetradrill_core::prelude::*;
//!
//! let (mut pos, tets) = builtin::cube12();
//! let (mut nodes, mut normals) = ([Node::default(); 9], [Vec3::ZERO; 9]);
//! let (mut recs, mut scratch) = ([Tet::default(); 12], [FaceKey::default(); 48]);
//! let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
//! let mesh = Mesh::build(&mut pos, &tets, storage, &mut scratch, BuildOptions::default())?;
//! let sizes = HierarchySizes::new(12, 1 << 16);
//! let mut lines = vec![Line::ZERO; sizes.lines().unwrap()];
//! let storage = HierarchyStorage::carve(&sizes, &mut Block::from_lines(&mut lines))?;
//! let mut h = Hierarchy::new(&mesh, storage)?;
//!
//! // A burr of radius 0.2 centred on the top face, and the coarse tets near it.
//! let burr = [Sphere { center: Vec3::new(0.0, 0.0, 0.5), radius: 0.2 }];
//! let mut near = [TetId::NONE; 12];
//! let n = candidates_brute_force(&mesh, &burr, &mut near);
//!
//! // One step within its budget, then the work left, step after step.
//! let (mut pending, params) = (vec![Pending::default(); 1 << 14], DrillParams::default());
//! let mut drill = Drill::new(&mut pending);
//! let first = drill.step(&mut h, &mesh, &near[..n], &burr, &params);
//! assert!(first.removed_volume > 0.0 && drill.pending() > 0);
//! while drill.pending() > 0 {
//!     drill.step(&mut h, &mesh, &near[..n], &[], &params);
//! }
//! // What went is the half ball under the top face, to within 1 %.
//! let half_ball = 2.0 / 3.0 * core::f64::consts::PI * 0.2f64.powi(3);
//! assert!((h.removed_volume() / half_ball - 1.0).abs() < 0.01);
//! h.validate(&mesh)?;
//! # Ok::<(), tetradrill_core::Error>(())
//! ```

mod candidates;
mod cost;
mod crumbs;
mod deque;
mod item;
mod material;
#[cfg(test)]
mod material_tests;
mod spacing;
mod sphere;
mod step;
mod swept;

pub use candidates::candidates_brute_force;
pub use cost::{DrillParams, WorkCost};
pub use material::{Material, Region, RegionError, Regions};
pub use spacing::{Spacing, DRILL_HOLD_STEPS, DRILL_SETTLE, DRILL_SPACING, MAX_STEP_SPHERES};
pub use sphere::Sphere;
pub use step::{Drill, DrillReport, Pending};

#[cfg(test)]
mod tests;
