//! Haptic forces (Turini et al. 2006, section 3; Praktikum report, sections 4-6).
//!
//! | file          | what                                                                  |
//! |---------------|-----------------------------------------------------------------------|
//! | `triangles` | sphere / active sample point: radius minus distance to the surface    |
//! | `passive`   | passive points tracked tick to tick, held at a face they cross; force  |
//! | `shaft`     | a drill: the burr and the passive points along its shaft               |
//! | `pen`       | tet-mesh tool: collisions both ways, consistent depth, summed force   |
//! | `held`      | the pen's servo half: force carried from the last contact pass        |
//! | `entry`     | the thin-pen remedy: an entry plane remembered while in contact        |
//! | `response`  | damping, clamping, the displayed (non-penetrating) tool offset        |
//! | [`frames`]    | camera `C = M . T`, allocentric pen `P_a = P_e . C`, forces mapped back |
//! | `digest`    | FNV-1a 64 over the force series' bit patterns                          |
//! | `passivity` | time-domain passivity observer and controller, the energy trip         |
//!
//! Triangles handed to the force functions are `[Vec3; 3]` listed counter-clockwise seen
//! from outside (right-hand normal pointing out of the object); `boundary_triangle` turns a
//! mesh boundary face (listed clockwise) into one.
//!
//! ```
//! use tetradrill_core::force::{clamp_force, sphere_contact, ForceParams};
//! use tetradrill_core::Vec3;
//!
//! // A floor at z = 0 (counter-clockwise from above) and a burr of radius 0.1 sunk 0.02 into it.
//! let floor = [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
//! let contact = sphere_contact(Vec3::new(0.0, 0.0, 0.08), 0.1, [floor]);
//! assert!(contact.touching() && (contact.depth - 0.02).abs() < 1e-6);
//! assert_eq!(contact.normal, Vec3::Z);
//!
//! // Its spring force, 700 N per unit x 0.02 = 14 N, clamped to the device's 3.3 N.
//! let params = ForceParams::default();
//! let force = clamp_force(contact.normal * params.stiffness * contact.depth, params.max_force);
//! assert!((force - Vec3::Z * 3.3).length() < 1e-5);
//! ```

mod digest;
mod entry;
pub mod frames;
mod held;
mod passive;
mod passivity;
mod pen;
mod pen_storage;
mod response;
mod shaft;
mod triangles;

pub use digest::{force_digest, ForceDigest};
pub use held::{pen_servo_force, pen_torque, HeldContact, PenServo, ServoScratch};
pub use passive::PassivePoint;
pub(crate) use passive::{offer_near, passive_force, PassiveProbe, Walked};
pub use passivity::{penalty_storage, PassivityObserver, PassivityParams, Storage};
pub use pen::{
    object_side, pen_contact, pen_pass, pen_place, pen_side, DepthMethod, PenBuffers, PenContact,
    PenForce, PenOptions, PenPass, PenPlacement, PenScene, PenState, SideBuffers, SideReport,
};
pub use pen_storage::{
    occupancy_words, PenBufferSizes, CLUSTER_EDGE, OCCUPANCY_LIST_SPLIT, OCCUPANCY_MARGIN,
    REST_GRID_EDGE, REST_MARGIN,
};
pub(crate) use response::damping_force;
pub use response::{clamp_force, display_offset, ForceParams, ToolState};
pub use shaft::{DrillTool, MAX_PASSIVE};
pub use triangles::{
    closest_point_on_triangle, mesh_sphere_contact, sphere_contact, SphereContact,
};

#[cfg(test)]
mod passive_tests;
#[cfg(test)]
mod tests;
