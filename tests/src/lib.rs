//! Shared helpers for tetradrill's cross-crate tests: where the real meshes are, small oracles.

use std::path::PathBuf;

/// The folder of real meshes, from `TETRADRILL_MESHES`, or `../shared/meshes` next to the
/// workspace when it exists. Tests that need real meshes fail loudly when neither is there:
/// a skipped oracle is a defect, not a pass.
pub fn meshes_dir() -> PathBuf {
    if let Ok(dir) = std::env::var("TETRADRILL_MESHES") {
        let p = PathBuf::from(dir);
        if p.is_absolute() {
            return p;
        }
        // Relative paths are taken from the workspace root, as CI sets `../shared/meshes`.
        return workspace_root().join(p);
    }
    let p = workspace_root().join("../shared/meshes");
    assert!(
        p.is_dir(),
        "set TETRADRILL_MESHES to the shared meshes folder (tried {})",
        p.display()
    );
    p
}

/// The workspace root (the parent of this crate's folder).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests crate has a parent folder")
        .to_path_buf()
}

/// Path of one mesh file below the shared meshes folder.
pub fn mesh(rel: &str) -> PathBuf {
    let p = meshes_dir().join(rel);
    assert!(p.exists(), "missing shared mesh {}", p.display());
    p
}
