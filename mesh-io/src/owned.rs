//! [`OwnedMesh`]: the host's storage for one core mesh, from the core's owned-storage layer
//! (`tetradrill_core::owned`), re-exported where the readers return it.

pub use tetradrill_core::owned::OwnedMesh;
