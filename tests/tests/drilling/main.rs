//! Drilling: the removed material, the visible faces, the drill's positions and convergence,
//! materials, the shaft, debris, long sessions and the drilling bounds, in-process and through
//! the binary; one test binary, a module per file.

mod bounds_drill;
mod burr_sound;
mod cutting_energy;
mod debris;
mod drill_convergence;
mod drill_faces;
mod drill_positions;
mod drill_tool_run;
mod drill_volume;
mod fine_mesh;
mod long_drilling;
mod materials;
mod premolar_access;
mod removal_law;
mod resolution;
mod shaft;
mod sideways_pull;
mod smooth_normals;
mod surface_export;
mod surface_obj;
mod vibration;
