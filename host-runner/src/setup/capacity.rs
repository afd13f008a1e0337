//! The capacities a set-up may size, in one table: each one's key (the scenario key, and
//! the flag with `-` for `_`), the bytes of one entry and the smallest value that works.

/// Largest storage one buffer may take. A larger capacity is refused as absurd: a mistyped
/// value would otherwise abort the allocation or push the machine into swap.
pub const MAX_BUFFER_BYTES: usize = 1 << 30;

/// One capacity of a scenario: its key (the TOML key, and the flag with `-` for `_`), the
/// bytes of one entry (0: a bound on work, not storage) and the smallest value that works.
#[derive(Debug, Clone, Copy)]
pub struct Capacity {
    /// TOML key.
    pub key: &'static str,
    /// Bytes per entry.
    pub entry_bytes: usize,
    /// Smallest value accepted.
    pub min: usize,
}

impl Capacity {
    /// The command-line flag.
    pub fn flag(&self) -> String {
        format!("--{}", self.key.replace('_', "-"))
    }

    /// Largest value accepted: [`MAX_BUFFER_BYTES`] of entries, and ids fit in `u32`.
    pub fn max(&self) -> usize {
        let by_bytes = MAX_BUFFER_BYTES
            .checked_div(self.entry_bytes)
            .unwrap_or(usize::MAX);
        by_bytes.min(u32::MAX as usize)
    }

    /// `Ok` when `v` is within `min..=max`, else one line naming the key and the flag.
    pub fn check(&self, v: usize) -> Result<(), String> {
        if (self.min..=self.max()).contains(&v) {
            return Ok(());
        }
        let unit = if self.entry_bytes == 0 {
            String::new()
        } else {
            format!(" ({} MiB at most)", MAX_BUFFER_BYTES >> 20)
        };
        Err(format!(
            "{} ({}) must be {}..={}{unit}, got {v}",
            self.key,
            self.flag(),
            self.min,
            self.max()
        ))
    }
}

/// Every capacity a scenario sets, in one place (docs/SAFETY.md lists what each does when full).
pub const CAPACITIES: [Capacity; 8] = {
    use std::mem::size_of;
    use tetradrill_core::collide::Collision;
    use tetradrill_core::depth::Penetration;
    use tetradrill_core::drill::Pending;
    use tetradrill_core::hash::HashEntry;
    use tetradrill_core::hierarchy::{HNode, VEntry};
    [
        // One block of eight children at least: a smaller arena holds no block at all.
        Capacity {
            key: "hierarchy_capacity",
            entry_bytes: size_of::<HNode>(),
            min: 8,
        },
        Capacity {
            key: "hash_capacity",
            entry_bytes: size_of::<HashEntry>(),
            min: 1,
        },
        Capacity {
            key: "candidate_capacity",
            entry_bytes: size_of::<tetradrill_core::TetId>(),
            min: 1,
        },
        Capacity {
            key: "vlist_capacity",
            entry_bytes: size_of::<VEntry>(),
            min: 1,
        },
        Capacity {
            key: "pending_capacity",
            entry_bytes: size_of::<Pending>(),
            min: 1,
        },
        Capacity {
            key: "contact_search_nodes",
            entry_bytes: 0,
            min: 1,
        },
        Capacity {
            key: "contact_capacity",
            entry_bytes: size_of::<Collision>() + size_of::<Penetration>(),
            min: 1,
        },
        Capacity {
            key: "queue_capacity",
            entry_bytes: size_of::<tetradrill_core::NodeId>(),
            min: 1,
        },
    ]
};

/// The capacity named `key` (one of [`CAPACITIES`]).
pub fn capacity(key: &str) -> Option<Capacity> {
    CAPACITIES.iter().copied().find(|c| c.key == key)
}
