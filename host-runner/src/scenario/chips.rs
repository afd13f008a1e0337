//! The capacities of the chips' built-in scenarios (`builtin:f405-block`,
//! `builtin:f405-regions`, `builtin:h743-tooth`), the numbers the firmware's `scenario::chip`
//! holds too (docs/PORTING.md, "On named chips").

/// Hierarchy arena nodes of `builtin:f405-block`.
pub const F405_ARENA: usize = 2_000;
/// Pending deque entries of `builtin:f405-block` (under 1,024: one coarse ring).
pub const F405_PENDING: usize = 128;
/// Candidate list entries of `builtin:f405-block`.
pub const F405_CANDIDATES: usize = 192;
/// Hash entries of `builtin:f405-block`.
pub const F405_HASH_ENTRIES: usize = 2_112;

/// Hierarchy arena nodes of `builtin:h743-tooth`.
pub const H743_ARENA: usize = 9_000;
/// Pending deque entries of `builtin:h743-tooth` (under 1,024: one coarse ring).
pub const H743_PENDING: usize = 832;
/// Candidate storage of `builtin:h743-tooth` (in thirds: its candidate gather).
pub const H743_CANDIDATES: usize = 1_152;
/// Hash entries of `builtin:h743-tooth`.
pub const H743_HASH_ENTRIES: usize = 23_872;
