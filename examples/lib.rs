//! tetradrill's example programs, one file each beside this one: `drill_block`,
//! `drill_tooth_regions`, `touch_with_pen`, `soft_body` and `own_device`. Run one with
//! `cargo run --release -p tetradrill-examples --example NAME`; each checks its own result
//! and exits with an error when the check fails. `c/` holds the C programs over the C
//! interface (`scripts/c-example.sh`).

/// The repository's test meshes (the tooth, the pen), for the examples.
pub const MESHES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/meshes");
