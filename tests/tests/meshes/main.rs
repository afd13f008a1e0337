//! Meshes: the compact mesh, the blob and the mesh read in place, every file format (good,
//! binary and refused), the load order, `tetradrill info`, the two premolar meshes and the fuzzing
//! regressions; one test binary, a module per file.

mod fuzz_regressions;
mod info_cli;
mod load_order;
mod mesh;
mod mesh_blob;
mod mesh_in_place;
mod meshio;
mod meshio_binary;
mod meshio_refused;
mod premolar_mesh;
mod tooth_mesh;
