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
//!
//! ```
//! use tetradrill_core::hash::{prime_at_most, HashEntry, HashError, SpatialHash};
//! use tetradrill_core::Vec3;
//!
//! // 7 buckets (a prime) and one entry per point, cells of edge 0.5.
//! assert_eq!(prime_at_most(8), 7);
//! let (mut starts, mut entries) = ([0u32; 8], [HashEntry::EMPTY; 4]);
//! let mut hash = SpatialHash::new(&mut starts, &mut entries, 0.5)?;
//! let points = [
//!     Vec3::new(0.1, 0.1, 0.1),
//!     Vec3::new(0.3, 0.2, 0.4),
//!     Vec3::new(-0.2, 0.1, 0.1),
//!     Vec3::new(2.0, 0.0, 0.0),
//! ];
//! assert!(!hash.rebuild_points(&points).saturated);
//!
//! // Points 0 and 1 share the cell [0, 0.5)^3; -0.2 lies in cell -1 along x.
//! let cell = hash.cell_of(Vec3::new(0.45, 0.0, 0.25));
//! assert_eq!(cell, [0, 0, 0]);
//! assert_eq!(hash.items_in_cell_ascending(cell).collect::<Vec<_>>(), [0, 1]);
//! assert_eq!(hash.cell_of(points[2]), [-1, 0, 0]);
//! # Ok::<(), HashError>(())
//! ```

mod cell;
mod query;
mod rebuild;
mod shift;
mod table;
mod update;

pub(crate) use cell::cells_in;
pub(crate) use cell::floor_i32;
pub use cell::{average_edge_length, prime_at_most, Aabb};
pub(crate) use cell::{cell_of, Cell};
pub(crate) use rebuild::RebuildCursor;
pub use rebuild::{Rebuilt, REBUILD_ITEM_UNITS};
pub(crate) use shift::MoveSpan;
pub use table::{HashEntry, HashError, HashStats, SpatialHash};
pub(crate) use update::Sorted;
