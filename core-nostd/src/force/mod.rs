//! `force`: see the crate docs' layer map. (Filled in by its issue.)
