//! Teschner's spatial hash (Teschner et al. 2003; Praktikum report, section 3).
//!
//! Space is cut into cubic cells of edge `g`; a point `x` lies in cell
//! `(floor(x/g), floor(y/g), floor(z/g))` (a true floor, so `-0.5` is in cell `-1`). A cell
//! maps to a bucket by `(i*73856093) xor (j*19349663) xor (k*83492791)` in wrapping `i32`
//! arithmetic, cast to `u32`, modulo the bucket count (a prime, see [`prime_at_most`]).
//!
//! [`SpatialHash`] stores its entries densely by counting sort: one counting pass, one
//! prefix-sum pass over the buckets, one filling pass. There are no per-cell lists. Every entry
//! remembers its cell, so a query only returns items of the cell it asked for (different cells
//! share buckets).
//!
//! Two uses: an object's tets are hashed (each tet into every cell its bounding box overlaps;
//! once for a static object, again each step for a deforming one) and moving points are queried
//! each tick; or points are hashed (again each step if they move) and tets walk the cells of
//! their bounding boxes (Teschner's original order).

mod cell;
mod query;
mod rebuild;
mod table;

pub(crate) use cell::cells_in;
pub(crate) use cell::floor_i32;
pub use cell::{average_edge_length, bucket_of, cell_of, prime_at_most, Aabb, Cell};
pub use rebuild::{RebuildCursor, Rebuilt, REBUILD_BUCKETS_PER_UNIT, REBUILD_ITEM_UNITS};
pub use table::{HashEntry, HashError, HashStats, SpatialHash, ITEM_BITS, MAX_ITEMS};
