//! The pen's contact pass (`pen_contact`, traced depth, crossings searched) on the contact
//! bench's poses of the pen x10 against the teddy (200 touching, 200 impaled), against an
//! independent f64 reference: every node of each body tested against every tet of the other
//! whose box holds it (barycentric coordinates in f64), every border edge against every
//! boundary face of the other body whose box meets the edge's (the first outward crossing
//! along the edge, Heidelberger's depth computed naively), its own breadth-first layers, and
//! the force and the torque about the tip summed in f64.
//!
//! Only nodes within 1e-5 (in barycentric coordinates) of a tet's face are left to the pass's
//! own answer (f32 and f64 may disagree there); every other node must be classified alike.
//! Tolerances: depth 1e-4, direction 1e-3 (as `contact_depth`'s reference), force and torque
//! 1e-4 relative to the sum of the node springs' magnitudes.

use std::collections::{HashMap, HashSet, VecDeque};

use glam::{Quat, Vec3};
use tetradrill_benches::{impaled_poses, touch_poses};
use tetradrill_core::depth::Penetration;
use tetradrill_core::force::{pen_contact, PenContact, PenOptions, PenState};
use tetradrill_core::mesh::Mesh;
use tetradrill_tests::contact::{rig, TEDDY};
use tetradrill_tests::oracle::{AsD, DVec3};

/// Barycentric slack below which a node's side is left to the pass.
const AMBIGUOUS: f64 = 1e-5;

/// Items binned by their boxes in a uniform grid (the reference's own, nothing shared with the
/// core's hash).
struct Grid {
    cell: f64,
    bins: HashMap<[i64; 3], Vec<u32>>,
}

impl Grid {
    fn new(cell: f64) -> Self {
        Self {
            cell,
            bins: HashMap::new(),
        }
    }
    fn key(&self, v: f64) -> i64 {
        (v / self.cell).floor() as i64
    }
    fn range(&self, lo: DVec3, hi: DVec3) -> impl Iterator<Item = [i64; 3]> {
        let (l, h) = (
            [self.key(lo.x), self.key(lo.y), self.key(lo.z)],
            [self.key(hi.x), self.key(hi.y), self.key(hi.z)],
        );
        (l[0]..=h[0]).flat_map(move |i| {
            (l[1]..=h[1]).flat_map(move |j| (l[2]..=h[2]).map(move |k| [i, j, k]))
        })
    }
    fn insert(&mut self, lo: DVec3, hi: DVec3, id: u32) {
        let keys: Vec<_> = self.range(lo, hi).collect();
        for k in keys {
            self.bins.entry(k).or_default().push(id);
        }
    }
    fn query(&self, lo: DVec3, hi: DVec3) -> Vec<u32> {
        let mut out: Vec<u32> = self
            .range(lo, hi)
            .filter_map(|k| self.bins.get(&k))
            .flatten()
            .copied()
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }
}

fn dmin(a: DVec3, b: DVec3) -> DVec3 {
    DVec3 {
        x: a.x.min(b.x),
        y: a.y.min(b.y),
        z: a.z.min(b.z),
    }
}

fn dmax(a: DVec3, b: DVec3) -> DVec3 {
    DVec3 {
        x: a.x.max(b.x),
        y: a.y.max(b.y),
        z: a.z.max(b.z),
    }
}

fn vol(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    (b - a).dot((c - a).cross(d - a))
}

/// A body in f64: node positions and outward boundary normals, tets, boundary faces (with the
/// fourth node of their tet), node adjacency, and grids over its tets and boundary faces.
struct RefBody {
    pos: Vec<DVec3>,
    nrm: Vec<DVec3>,
    tets: Vec<[u32; 4]>,
    faces: Vec<([u32; 3], u32)>,
    adj: Vec<Vec<usize>>,
    tet_grid: Grid,
    face_grid: Grid,
}

impl RefBody {
    fn new(mesh: &Mesh<'_>, pos: Vec<DVec3>, nrm: Vec<DVec3>, cell: f64) -> Self {
        let tets: Vec<[u32; 4]> = mesh.tets().map(|t| t.nodes.map(|n| n.0)).collect();
        let mut adj: Vec<Vec<usize>> = vec![Vec::new(); pos.len()];
        let mut count: HashMap<[u32; 3], (usize, [u32; 3], u32)> = HashMap::new();
        let mut tet_grid = Grid::new(cell);
        for (i, t) in tets.iter().enumerate() {
            for a in 0..4 {
                for b in 0..4 {
                    let (u, v) = (t[a] as usize, t[b] as usize);
                    if a != b && !adj[u].contains(&v) {
                        adj[u].push(v);
                    }
                }
                let l: Vec<u32> = (0..4).filter(|&k| k != a).map(|k| t[k]).collect();
                let mut key = [l[0], l[1], l[2]];
                key.sort();
                count.entry(key).or_insert((0, [l[0], l[1], l[2]], t[a])).0 += 1;
            }
            let c = t.map(|n| pos[n as usize]);
            let (lo, hi) = c
                .iter()
                .fold((c[0], c[0]), |(l, h), &x| (dmin(l, x), dmax(h, x)));
            tet_grid.insert(lo, hi, i as u32);
        }
        let mut faces: Vec<([u32; 3], u32)> = count
            .values()
            .filter(|v| v.0 == 1)
            .map(|v| (v.1, v.2))
            .collect();
        faces.sort_unstable();
        let mut face_grid = Grid::new(cell);
        for (i, (f, _)) in faces.iter().enumerate() {
            let c = f.map(|n| pos[n as usize]);
            let lo = dmin(dmin(c[0], c[1]), c[2]);
            let hi = dmax(dmax(c[0], c[1]), c[2]);
            face_grid.insert(lo, hi, i as u32);
        }
        Self {
            pos,
            nrm,
            tets,
            faces,
            adj,
            tet_grid,
            face_grid,
        }
    }

    /// Whether `x` is inside a tet: `Some(true)` when some tet holds it by more than
    /// [`AMBIGUOUS`] in every coordinate, `Some(false)` when every tet misses it by more, `None`
    /// in between.
    fn holds(&self, x: DVec3) -> Option<bool> {
        let mut best = f64::NEG_INFINITY;
        for t in self.tet_grid.query(x, x) {
            let c = self.tets[t as usize].map(|n| self.pos[n as usize]);
            let v = vol(c[0], c[1], c[2], c[3]);
            if v == 0.0 {
                continue;
            }
            let b = [
                vol(x, c[1], c[2], c[3]) / v,
                vol(c[0], x, c[2], c[3]) / v,
                vol(c[0], c[1], x, c[3]) / v,
                vol(c[0], c[1], c[2], x) / v,
            ];
            best = best.max(b.iter().copied().fold(f64::INFINITY, f64::min));
        }
        if best > AMBIGUOUS {
            Some(true)
        } else if best < -AMBIGUOUS {
            Some(false)
        } else {
            None
        }
    }

    /// The first place the edge `p -> q` leaves this body through a boundary face (outward,
    /// smallest edge parameter in `[-1e-4, 1 + 1e-4]`): the point and the interpolated normal.
    fn first_exit(&self, p: DVec3, q: DVec3) -> Option<(DVec3, DVec3)> {
        let d = q - p;
        let pad = DVec3 {
            x: 1e-6,
            y: 1e-6,
            z: 1e-6,
        };
        let mut best: Option<(f64, DVec3, DVec3)> = None;
        for i in self.face_grid.query(dmin(p, q) - pad, dmax(p, q) + pad) {
            let (f, opposite) = self.faces[i as usize];
            let [a, b, c] = f.map(|n| self.pos[n as usize]);
            let n0 = (b - a).cross(c - a);
            let n = if n0.dot(self.pos[opposite as usize] - a) > 0.0 {
                -n0
            } else {
                n0
            };
            let den = n.dot(d);
            if den <= 0.0 {
                continue; // not leaving
            }
            let s = n.dot(a - p) / den;
            if !(-1e-4..=1.0 + 1e-4).contains(&s) {
                continue;
            }
            let x = p + d * s;
            let area = |u: DVec3, v: DVec3, w: DVec3| (v - u).cross(w - u).dot(n0);
            let (wa, wb, wc) = (area(x, b, c), area(a, x, c), area(a, b, x));
            if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                continue;
            }
            let ni = self.nrm[f[0] as usize] * wa
                + self.nrm[f[1] as usize] * wb
                + self.nrm[f[2] as usize] * wc;
            if best.is_none_or(|(bs, _, _)| s < bs) {
                best = Some((s, x, ni.normalize()));
            }
        }
        best.map(|(_, x, n)| (x, n))
    }
}

/// Consistent depths `(depth, direction)` of `colliding` nodes of `a` inside `b`.
fn reference_depth(
    a: &RefBody,
    b: &RefBody,
    colliding: &HashSet<usize>,
) -> HashMap<usize, (f64, DVec3)> {
    let mut known: HashMap<usize, (f64, DVec3, u32)> = HashMap::new();
    for &i in colliding {
        let p = a.pos[i];
        let (mut sw, mut sd, mut sn) = (0.0, 0.0, DVec3::ZERO);
        for &j in &a.adj[i] {
            if colliding.contains(&j) {
                continue;
            }
            if let Some((x, ni)) = b.first_exit(p, a.pos[j]) {
                let w = 1.0 / (x - p).length_squared();
                sw += w;
                sd += w * (x - p).dot(ni);
                sn += ni * w;
            }
        }
        if sw > 0.0 {
            known.insert(i, (sd / sw, sn.normalize(), 0));
        }
    }
    let mut queue: VecDeque<usize> = {
        let mut k: Vec<usize> = known.keys().copied().collect();
        k.sort();
        k.into()
    };
    let mut layer: HashMap<usize, u32> = known.keys().map(|&k| (k, 0)).collect();
    while let Some(u) = queue.pop_front() {
        let lu = layer[&u];
        for &v in &a.adj[u] {
            if colliding.contains(&v) && !layer.contains_key(&v) {
                layer.insert(v, lu + 1);
                queue.push_back(v);
            }
        }
        if !known.contains_key(&u) {
            let p = a.pos[u];
            let (mut sm, mut sd, mut sr) = (0.0, 0.0, DVec3::ZERO);
            for &j in &a.adj[u] {
                if let Some(&(dj, rj, lj)) = known.get(&j) {
                    if lj < lu {
                        let v = a.pos[j] - p;
                        let mu = 1.0 / v.length_squared();
                        sm += mu;
                        sd += mu * (v.dot(rj) + dj);
                        sr += rj * mu;
                    }
                }
            }
            known.insert(u, (sd / sm, sr.normalize(), lu));
        }
    }
    known
        .into_iter()
        .map(|(k, (d, r, _))| (k, (d, r)))
        .collect()
}

/// `q v q*` in f64.
fn rotate(q: Quat, v: DVec3) -> DVec3 {
    let (w, u) = (q.w as f64, q.xyz().to_dvec3());
    u * (2.0 * u.dot(v)) + v * (w * w - u.dot(u)) + u.cross(v) * (2.0 * w)
}

/// Which nodes of `a` lie in `b`: the reference's answer, the pass's for ambiguous nodes.
/// Returns the set and the number of ambiguous nodes; fails on any other disagreement.
fn colliding(
    a: &RefBody,
    b: &RefBody,
    pass: &HashSet<usize>,
    what: &str,
) -> (HashSet<usize>, usize) {
    let mut set = HashSet::new();
    let mut ambiguous = 0;
    for (i, &x) in a.pos.iter().enumerate() {
        let inside = match b.holds(x) {
            Some(v) => {
                assert_eq!(v, pass.contains(&i), "{what} node {i}: inside {v} in f64");
                v
            }
            None => {
                ambiguous += 1;
                pass.contains(&i)
            }
        };
        if inside {
            set.insert(i);
        }
    }
    (set, ambiguous)
}

/// Force and torque about `tip` of springs `k d r` at the nodes `at` (minus for `sign < 0`).
fn wrench(
    k: f64,
    tip: DVec3,
    springs: impl Iterator<Item = (DVec3, f64, DVec3)>,
) -> (DVec3, DVec3, f64) {
    let (mut f, mut t, mut mag) = (DVec3::ZERO, DVec3::ZERO, 0.0);
    for (x, d, r) in springs {
        let s = r * (k * d);
        f += s;
        t += (x - tip).cross(s);
        mag += s.length() * (1.0 + (x - tip).length());
    }
    (f, t, mag)
}

fn compare_depths(
    got: &[Penetration],
    want: &HashMap<usize, (f64, DVec3)>,
    what: &str,
    worst: &mut f64,
) {
    assert_eq!(got.len(), want.len(), "{what}: the same nodes get a depth");
    for g in got {
        let (d, r) = want[&g.node.idx()];
        let (ed, er) = ((g.depth as f64 - d).abs(), (g.dir.to_dvec3() - r).length());
        assert!(
            ed < 1e-4,
            "{what} {:?}: depth {} vs f64 {d}",
            g.node,
            g.depth
        );
        assert!(
            er < 1e-3,
            "{what} {:?}: dir {:?} vs f64 {r:?}",
            g.node,
            g.dir
        );
        *worst = worst.max(ed);
    }
}

#[test]
fn pen_pass_matches_f64_reference_on_the_bench_poses() {
    let mut rig = rig(10.0, TEDDY, 1.0);
    let (touching, impaled) = {
        let obj = rig.obj.view();
        (
            touch_poses(&obj, 200, 0.05, 7),
            impaled_poses(&obj, 200, 0.25, 7),
        )
    };
    let opts = PenOptions::default();
    let k = opts.params.stiffness as f64;
    let (mut nodes, mut ambiguous, mut worst_d, mut worst_w, mut touched) =
        (0, 0, 0.0f64, 0.0f64, 0);
    rig.with(|scene, bufs| {
        let obj_mesh = scene.object.mesh;
        let cell = tetradrill_core::hash::average_edge_length(obj_mesh) as f64;
        let object = RefBody::new(
            obj_mesh,
            obj_mesh.positions().iter().map(|p| p.to_dvec3()).collect(),
            obj_mesh.normals().iter().map(|n| n.to_dvec3()).collect(),
            cell,
        );
        for &(tip, rot) in touching.iter().chain(&impaled) {
            let c: PenContact = pen_contact(scene, bufs, tip, rot, &opts, &mut PenState::default());
            assert!(!c.saturated(), "no buffer fills at {tip:?}");
            let pen = RefBody::new(
                scene.pen,
                bufs.world.iter().map(|p| p.to_dvec3()).collect(),
                scene
                    .pen
                    .normals()
                    .iter()
                    .map(|&n| rotate(rot, n.to_dvec3()))
                    .collect(),
                cell,
            );
            let set = |hits: &[tetradrill_core::collide::Collision]| -> HashSet<usize> {
                hits.iter().map(|h| h.node.idx()).collect()
            };
            let (pen_in, a1) = colliding(
                &pen,
                &object,
                &set(&bufs.pen_hits[..c.pen_collisions.count]),
                "pen",
            );
            let (obj_in, a2) = colliding(
                &object,
                &pen,
                &set(&bufs.object_hits[..c.object_collisions.count]),
                "object",
            );
            ambiguous += a1 + a2;
            let want_pen = reference_depth(&pen, &object, &pen_in);
            let want_obj = reference_depth(&object, &pen, &obj_in);
            let (np, no) = c.penetrations;
            let (got_pen, got_obj) = (&bufs.pen_pens[..np], &bufs.object_pens[..no]);
            compare_depths(got_pen, &want_pen, "pen", &mut worst_d);
            compare_depths(got_obj, &want_obj, "object", &mut worst_d);
            nodes += np + no;
            touched += (np + no > 0) as usize;

            // Force and torque: the reference's springs against the pass's.
            let t = tip.to_dvec3();
            let springs = |ps: &[Penetration], b: &RefBody| -> Vec<(DVec3, f64, DVec3)> {
                ps.iter()
                    .map(|p| (b.pos[p.node.idx()], p.depth as f64, p.dir.to_dvec3()))
                    .collect()
            };
            let mine =
                |m: &HashMap<usize, (f64, DVec3)>, b: &RefBody| -> Vec<(DVec3, f64, DVec3)> {
                    m.iter().map(|(&i, &(d, r))| (b.pos[i], d, r)).collect()
                };
            let neg = |v: Vec<(DVec3, f64, DVec3)>| v.into_iter().map(|(x, d, r)| (x, -d, r));
            let (gf, gt, _) = wrench(
                k,
                t,
                springs(got_pen, &pen)
                    .into_iter()
                    .chain(neg(springs(got_obj, &object))),
            );
            let (wf, wt, mag) = wrench(
                k,
                t,
                mine(&want_pen, &pen)
                    .into_iter()
                    .chain(neg(mine(&want_obj, &object))),
            );
            let tol = 1e-4 * mag.max(1.0);
            let (ef, et) = ((gf - wf).length(), (gt - wt).length());
            assert!(ef <= tol, "force {gf:?} vs f64 {wf:?} at {tip:?}");
            assert!(et <= tol, "torque {gt:?} vs f64 {wt:?} at {tip:?}");
            // The pass's own force is the sum of its springs.
            let raw = c.raw.to_dvec3();
            assert!((raw - gf).length() <= tol, "raw {raw:?} vs springs {gf:?}");
            worst_w = worst_w.max(ef.max(et) / mag.max(1.0));
        }
    })
    .expect("pen scene");
    println!(
        "pen pass vs f64: {touched} of 400 poses in contact, {nodes} nodes, {ambiguous} left to \
         the pass, worst depth error {worst_d:.2e}, worst force/torque error {worst_w:.2e} \
         (relative)"
    );
    assert!(touched > 300 && nodes > 50_000);
}

/// The f64 rotation agrees with glam's (the reference's normals of the moved pen).
#[test]
fn reference_rotation_is_glams() {
    let q = Quat::from_xyzw(0.3, -0.5, 0.2, 0.7).normalize();
    let v = Vec3::new(0.4, -1.2, 2.0);
    assert!((rotate(q, v.to_dvec3()) - (q * v).to_dvec3()).length() < 1e-6);
}
