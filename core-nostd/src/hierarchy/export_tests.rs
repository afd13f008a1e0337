//! Unit tests of the surface exporter with tiny capacities: random Erase and Refine on the
//! 12-tet cube, the exporter called with a small budget after each operation, its buffers
//! checked against an independent listing of the visible faces, a mirror fed only from the
//! change ranges checked against the buffers, and every call's work against its bound.

use glam::Vec3;

use super::test_support::{mesh, random_op, Cube, Rng};
use super::*;
use crate::builtin::CUBE12_TETS;
use crate::ids::TetId;
use crate::mesh::Mesh;

/// Slots of the roomy exporter.
const SLOTS: usize = 600;
/// Most visible faces the runs reach (checked).
const MAX_FACES: usize = 600;

/// A face as the tests compare them: its corners' bits and its label.
type Tri = ([u32; 9], i32);

fn tri(corners: [Vec3; 3], label: i32) -> Tri {
    let mut b = [0u32; 9];
    for (k, c) in corners.iter().enumerate() {
        b[3 * k] = c.x.to_bits();
        b[3 * k + 1] = c.y.to_bits();
        b[3 * k + 2] = c.z.to_bits();
    }
    (b, label)
}

fn label_of(t: TetId) -> i32 {
    100 + t.0 as i32
}

/// The renderer's side: the buffers the exporter writes and a mirror copied from them only
/// through the ranges each call reports.
struct Buffers {
    pos: [[f32; 3]; 3 * SLOTS],
    nrm: [[f32; 3]; 3 * SLOTS],
    lab: [i32; 3 * SLOTS],
    idx: [u32; 3 * SLOTS],
    m_pos: [[f32; 3]; 3 * SLOTS],
    m_nrm: [[f32; 3]; 3 * SLOTS],
    m_lab: [i32; 3 * SLOTS],
    m_idx: [u32; 3 * SLOTS],
}

impl Buffers {
    fn new() -> Self {
        Self {
            pos: [[0.0; 3]; 3 * SLOTS],
            nrm: [[0.0; 3]; 3 * SLOTS],
            lab: [0; 3 * SLOTS],
            idx: [0; 3 * SLOTS],
            m_pos: [[0.0; 3]; 3 * SLOTS],
            m_nrm: [[0.0; 3]; 3 * SLOTS],
            m_lab: [0; 3 * SLOTS],
            m_idx: [0; 3 * SLOTS],
        }
    }

    /// One call of the exporter, then the mirror updated from its ranges and compared with
    /// the buffers.
    fn update(
        &mut self,
        ex: &mut SurfaceExport<'_>,
        h: &Hierarchy<'_>,
        mesh: &Mesh<'_>,
        budget: u32,
        ranges: &mut [SlotRange],
    ) -> ExportReport {
        let n = 3 * ex.capacity();
        let mut out = SurfaceBuffers {
            positions: &mut self.pos[..n],
            normals: &mut self.nrm[..n],
            labels: &mut self.lab[..n],
            indices: &mut self.idx[..n],
            ranges,
        };
        let rep = ex.update(h, mesh, label_of, budget, &mut out).unwrap();
        for r in &ranges[..rep.ranges as usize] {
            let (a, b) = (3 * r.first as usize, 3 * (r.first + r.count) as usize);
            assert!(b <= n, "a range past the buffers: {r:?}");
            self.m_pos[a..b].copy_from_slice(&self.pos[a..b]);
            self.m_nrm[a..b].copy_from_slice(&self.nrm[a..b]);
            self.m_lab[a..b].copy_from_slice(&self.lab[a..b]);
            self.m_idx[a..b].copy_from_slice(&self.idx[a..b]);
        }
        assert!(
            self.m_pos == self.pos && self.m_nrm == self.nrm,
            "mirror differs"
        );
        assert!(
            self.m_lab == self.lab && self.m_idx == self.idx,
            "mirror differs"
        );
        rep
    }

    /// The live slots' faces, sorted; every live slot checked for its indices and normal,
    /// every free one for zeros.
    fn live(&self, slots: usize, out: &mut [Tri; MAX_FACES]) -> usize {
        let mut n = 0;
        for s in 0..slots {
            let v = 3 * s;
            let idx = &self.idx[v..v + 3];
            if idx == [0, 0, 0] {
                assert!(
                    self.pos[v..v + 3] == [[0.0; 3]; 3],
                    "free slot {s} not zero"
                );
                assert!(self.nrm[v..v + 3] == [[0.0; 3]; 3] && self.lab[v..v + 3] == [0; 3]);
                continue;
            }
            assert_eq!(
                idx,
                [v as u32, v as u32 + 1, v as u32 + 2],
                "slot {s}'s indices"
            );
            let c = [0, 1, 2].map(|k| Vec3::from_array(self.pos[v + k]));
            // The normal against an f64 cross product of the corners.
            let d = |p: Vec3| [p.x as f64, p.y as f64, p.z as f64];
            let (a, b, cc) = (d(c[0]), d(c[1]), d(c[2]));
            let (u, w) = (
                [0, 1, 2].map(|i| b[i] - a[i]),
                [0, 1, 2].map(|i| cc[i] - a[i]),
            );
            let x = [
                u[1] * w[2] - u[2] * w[1],
                u[2] * w[0] - u[0] * w[2],
                u[0] * w[1] - u[1] * w[0],
            ];
            let len = libm::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
            for k in 0..3 {
                for (got, want) in self.nrm[v + k].iter().zip(x) {
                    let e = (*got as f64 - want / len).abs();
                    assert!(e < 1e-5, "slot {s}'s normal");
                }
                assert_eq!(self.lab[v + k], self.lab[v]);
            }
            out[n] = tri(c, self.lab[v]);
            n += 1;
        }
        out[..n].sort_unstable();
        n
    }
}

/// The oracle: the visible faces as [`Hierarchy::for_each_visible`] lists them (the v_list),
/// sorted, checked against a brute-force listing of every leaf of every tree (the visible
/// bits of the non-erased leaves: no v_list, no surface bits, no walk by surface).
fn visible(h: &Hierarchy<'_>, mesh: &Mesh<'_>, out: &mut [Tri; MAX_FACES]) -> usize {
    let mut keys = [(0u32, 0u32, 0u8); MAX_FACES];
    let mut n = 0;
    h.for_each_visible(mesh, |t| {
        assert!(n < MAX_FACES, "more faces than the test holds");
        out[n] = tri(t.corners, label_of(t.tet));
        keys[n] = (t.tet.0, t.index, t.face);
        n += 1;
    });
    let mut brute = [(0u32, 0u32, 0u8); MAX_FACES];
    let mut m = 0;
    for t in 0..h.tet_count() {
        h.for_each_leaf(TetId::from_idx(t), |leaf| {
            if leaf.record.erased() {
                return;
            }
            for f in 0..4u8 {
                if leaf.record.visible() & (1 << f) != 0 {
                    brute[m] = (t as u32, leaf.index, f);
                    m += 1;
                }
            }
        });
    }
    keys[..n].sort_unstable();
    brute[..m].sort_unstable();
    assert_eq!(
        &keys[..n],
        &brute[..m],
        "the v_list's faces are not the leaves'"
    );
    out[..n].sort_unstable();
    n
}

/// Visible faces of each tet (by the oracle's listing), and live slots of each tet in the
/// buffers (by label).
fn per_tet(h: &Hierarchy<'_>, mesh: &Mesh<'_>, b: &Buffers, slots: usize) -> [(u32, u32); 12] {
    let mut c = [(0u32, 0u32); CUBE12_TETS];
    h.for_each_visible(mesh, |t| c[t.tet.idx()].0 += 1);
    for s in 0..slots {
        if b.idx[3 * s..3 * s + 3] != [0, 0, 0] {
            c[(b.lab[3 * s] - 100) as usize].1 += 1;
        }
    }
    c
}

/// One run: `ops` random operations on the cube with a change log of `log` entries and an
/// exporter of `slots` slots, `ranges` range entries and `budget` units a call.
fn run(seed: u64, ops: usize, log: usize, slots: usize, ranges: usize, budget: u32) -> u32 {
    let mut c = Cube::new();
    let mesh = mesh(&mut c);
    let mut roots = [HNode::LEAF; CUBE12_TETS];
    let mut arena = [HNode::LEAF; 8 * 48];
    let mut vlist = [VEntry::default(); CUBE12_TETS + 7 * 48];
    let mut changes = [TetId::NONE; 16];
    let storage = HierarchyStorage {
        roots: &mut roots,
        arena: &mut arena,
        vlist: &mut vlist,
        changes: &mut changes[..log],
    };
    let mut h = Hierarchy::new(&mesh, storage).unwrap();
    let mut recs = [SlotRecord::FREE; SLOTS];
    let mut tets = [TetRecord::EMPTY; CUBE12_TETS];
    let storage = SurfaceStorage {
        slots: &mut recs[..slots],
        tets: &mut tets,
    };
    let mut ex = SurfaceExport::new(storage, &h).unwrap();
    let mut b = Buffers::new();
    let mut range_buf = [SlotRange::default(); 8];
    let (mut want, mut got) = ([([0; 9], 0); MAX_FACES], [([0; 9], 0); MAX_FACES]);
    let mut rng = Rng(seed);
    let mut dropped = 0;
    for op in 0..=ops {
        if op > 0 {
            random_op(&mut h, &mesh, &mut rng);
        }
        // Each tree lists its faces in the order of `walk_key` (so unchanged faces keep
        // their slots).
        for t in 0..CUBE12_TETS {
            let mut last = None;
            h.for_each_visible_in(&mesh, &[TetId::from_idx(t)], None, |vt| {
                let k = super::export::walk_key(vt.index, vt.face);
                assert!(last < Some(k), "tet {t}: listing out of key order");
                last = Some(k);
            });
        }
        // Calls until the buffers are up to date (or, when faces are left out, a bounded
        // number of them).
        for call in 0..1000 {
            let counts = per_tet(&h, &mesh, &b, slots);
            let rep = b.update(&mut ex, &h, &mesh, budget, &mut range_buf[..ranges]);
            dropped += rep.dropped;
            // The work bound: below the budget plus one tet's listing.
            let worst = counts.iter().map(|&(v, s)| 1 + v + s).max().unwrap();
            assert!(
                rep.work < budget + worst,
                "work {} budget {budget}",
                rep.work
            );
            let n = b.live(slots, &mut got);
            assert_eq!(n as u32, rep.live);
            assert!(rep.used as usize <= slots && rep.live <= rep.used);
            let m = visible(&h, &mesh, &mut want);
            if rep.pending == 0 {
                assert_eq!(
                    &got[..n],
                    &want[..m],
                    "seed {seed} op {op}: buffers != surface"
                );
                break;
            }
            if m > slots {
                // Full buffers: once a call has listed every tet since the last operation,
                // every live slot is a visible face, each at most once.
                let rep = b.update(&mut ex, &h, &mesh, 10_000, &mut range_buf[..ranges]);
                assert!(rep.pending > 0 && rep.live as usize == slots);
                let n = b.live(slots, &mut got);
                let mut j = 0;
                for g in &got[..n] {
                    while j < m && want[j] < *g {
                        j += 1;
                    }
                    assert!(j < m && want[j] == *g, "a live slot that is not visible");
                    j += 1;
                }
                break;
            }
            assert!(call < 999, "no progress");
        }
    }
    dropped
}

#[test]
fn the_buffers_follow_random_erasures_and_refinements() {
    for seed in 1..6u64 {
        // A change log that never loses entries between calls, small budgets.
        assert_eq!(run(seed, 120, 16, SLOTS, 8, 7), 0);
        // No change log at all: every change is a sweep.
        assert_eq!(run(seed, 60, 0, SLOTS, 8, 5), 0);
        // A log of 2 (lost when an erasure touches more tets), one range entry (merged).
        assert_eq!(run(seed, 60, 2, SLOTS, 1, 3), 0);
        // A budget of one unit a call.
        assert_eq!(run(seed, 30, 16, SLOTS, 8, 1), 0);
    }
}

#[test]
fn full_buffers_leave_faces_out_and_count_them() {
    let mut dropped = 0;
    for seed in 1..4u64 {
        dropped += run(seed, 60, 16, 20, 4, 9);
    }
    assert!(dropped > 0, "20 slots never filled up");
}

#[test]
fn a_move_of_every_face_writes_every_slot_again() {
    let mut c = Cube::new();
    let mesh = mesh(&mut c);
    let mut roots = [HNode::LEAF; CUBE12_TETS];
    let mut vlist = [VEntry::default(); CUBE12_TETS];
    let mut changes = [TetId::NONE; 4];
    let storage = HierarchyStorage {
        roots: &mut roots,
        arena: &mut [],
        vlist: &mut vlist,
        changes: &mut changes,
    };
    let mut h = Hierarchy::new(&mesh, storage).unwrap();
    let mut recs = [SlotRecord::FREE; 16];
    let mut tets = [TetRecord::EMPTY; CUBE12_TETS];
    let storage = SurfaceStorage {
        slots: &mut recs,
        tets: &mut tets,
    };
    let mut ex = SurfaceExport::new(storage, &h).unwrap();
    let mut b = Buffers::new();
    let mut ranges = [SlotRange::default(); 4];
    let rep = b.update(&mut ex, &h, &mesh, 100, &mut ranges);
    assert_eq!((rep.live, rep.written, rep.pending), (12, 12, 0));
    let rep = b.update(&mut ex, &h, &mesh, 100, &mut ranges);
    assert_eq!(
        (rep.written, rep.work),
        (0, 0),
        "nothing changed, nothing done"
    );
    h.note_all_changed();
    let rep = b.update(&mut ex, &h, &mesh, 100, &mut ranges);
    assert_eq!((rep.written, rep.ranges, rep.pending), (12, 1, 0));
    assert_eq!(
        ranges[0],
        SlotRange {
            first: 0,
            count: 12
        }
    );
}

#[test]
fn short_buffers_and_storage_are_refused() {
    let mut c = Cube::new();
    let mesh = mesh(&mut c);
    let mut roots = [HNode::LEAF; CUBE12_TETS];
    let mut vlist = [VEntry::default(); CUBE12_TETS];
    let storage = HierarchyStorage {
        roots: &mut roots,
        arena: &mut [],
        vlist: &mut vlist,
        changes: &mut [],
    };
    let h = Hierarchy::new(&mesh, storage).unwrap();
    let mut recs = [SlotRecord::FREE; 4];
    let mut tets = [TetRecord::EMPTY; CUBE12_TETS];
    let short = SurfaceStorage {
        slots: &mut recs,
        tets: &mut tets[..11],
    };
    assert_eq!(
        SurfaceExport::new(short, &h).err(),
        Some(SurfaceError::Storage)
    );
    let storage = SurfaceStorage {
        slots: &mut recs,
        tets: &mut tets,
    };
    let mut ex = SurfaceExport::new(storage, &h).unwrap();
    let (mut p, mut n) = ([[0.0; 3]; 12], [[0.0; 3]; 12]);
    let (mut l, mut i) = ([0; 12], [0; 11]);
    let mut r = [SlotRange::default(); 1];
    let mut out = SurfaceBuffers {
        positions: &mut p,
        normals: &mut n,
        labels: &mut l,
        indices: &mut i,
        ranges: &mut r,
    };
    let e = ex.update(&h, &mesh, label_of, 10, &mut out);
    assert_eq!(e, Err(SurfaceError::Buffers));
    let mut i = [0; 12];
    let mut out = SurfaceBuffers {
        positions: &mut p,
        normals: &mut n,
        labels: &mut l,
        indices: &mut i,
        ranges: &mut [],
    };
    let e = ex.update(&h, &mesh, label_of, 10, &mut out);
    assert_eq!(e, Err(SurfaceError::Buffers));
}
