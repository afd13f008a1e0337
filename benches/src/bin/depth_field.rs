//! A precomputed distance field against the consistent depth, on the contact bench's pen
//! poses: what the pen's forces would be, and what the depth would cost, if each colliding
//! node took its depth from the other body's distance-to-surface field instead of the
//! propagation from the border edges.
//!
//! Usage: `depth_field MESH touching|impaled` (MESH relative to the meshes folder, as for
//! `pen_profile`). Each body's field is the distance (f64, brute force over its boundary
//! triangles, computed for the tets the poses reach) from its nodes to its boundary surface; a node inside a tet takes the linear
//! interpolation of its corners' values (barycentric coordinates), and the direction out of
//! the body is minus the field's gradient in that tet. For every pose the pass
//! (`pen_contact`, traced, crossings searched) runs once; the nodes it gave a consistent
//! depth are given the field's depth too, and the two raw forces (stiffness 1) are compared
//! as the f64 reference test compares forces: the difference over the springs' summed
//! magnitudes (its tolerance is 1e-4), and with the field for the object's nodes only. Prints the depth differences, the force differences,
//! the angle between the two forces, and the nodes the field was evaluated at.
//!
//! Instruction counts of the field's depth alone: `valgrind --tool=callgrind
//! --collect-atstart=no --toggle-collect='depth_field::field_forces' depth_field MESH
//! touching` (the fields' values are computed before, outside the count). Exit status 2 for bad
//! arguments or an unreadable mesh.

use std::hint::black_box;
use std::process::ExitCode;

use glam::{Quat, Vec3};
use tetradrill::pen::PenRig;
use tetradrill_benches::{impaled_poses, load_mesh, profile_args, touch_poses};
use tetradrill_core::depth::Penetration;
use tetradrill_core::force::{pen_contact, PenOptions, PenState};
use tetradrill_core::mesh::template::FACE_VERTS;
use tetradrill_core::mesh::Mesh;

/// One body's distance-to-surface field: a value per node, and per tet the direction out of
/// the body (minus its gradient) and the inverse of its edge matrix (for barycentric
/// coordinates). Values are computed on first use ([`Field::ensure`]), so only the tets the
/// poses reach cost their brute force.
struct Field {
    /// Node positions of the body in the frame the field is built in.
    pos: Vec<Vec3>,
    /// Boundary triangles, f64.
    faces: Vec<[DVec3; 3]>,
    /// Tet corners' node indices.
    tets: Vec<[u32; 4]>,
    /// Distance from each node to the boundary surface (NaN until computed).
    value: Vec<f32>,
    /// Per tet: the unit direction out of the body (NaN until computed).
    out: Vec<Vec3>,
    /// Per tet: the rows of the inverse edge matrix (barycentric coordinates 1..3 of
    /// `x - corner 0`).
    inv: Vec<[Vec3; 3]>,
}

/// A point or vector in f64 (the workspace's glam is built without f64 types).
#[derive(Clone, Copy, Debug)]
struct DVec3([f64; 3]);

impl DVec3 {
    fn of(v: Vec3) -> Self {
        Self([v.x as f64, v.y as f64, v.z as f64])
    }
    fn dot(self, o: Self) -> f64 {
        self.0[0] * o.0[0] + self.0[1] * o.0[1] + self.0[2] * o.0[2]
    }
    fn cross(self, o: Self) -> Self {
        let (a, b) = (self.0, o.0);
        Self([
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ])
    }
    fn length_squared(self) -> f64 {
        self.dot(self)
    }
    fn as_vec3(self) -> Vec3 {
        Vec3::new(self.0[0] as f32, self.0[1] as f32, self.0[2] as f32)
    }
}

impl std::ops::Add for DVec3 {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self([self.0[0] + o.0[0], self.0[1] + o.0[1], self.0[2] + o.0[2]])
    }
}

impl std::ops::Sub for DVec3 {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self([self.0[0] - o.0[0], self.0[1] - o.0[1], self.0[2] - o.0[2]])
    }
}

impl std::ops::Mul<f64> for DVec3 {
    type Output = Self;
    fn mul(self, k: f64) -> Self {
        Self([self.0[0] * k, self.0[1] * k, self.0[2] * k])
    }
}

/// The closest point to `p` on the triangle `a b c` (Ericson, Real-Time Collision Detection
/// 5.1.5), in f64.
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

impl Field {
    /// The field of `mesh` as stored, nothing computed yet.
    fn new(mesh: &Mesh<'_>) -> Self {
        let pos = mesh.positions().to_vec();
        let mut faces = Vec::new();
        for tet in mesh.tets() {
            for f in 0..4u8 {
                if tet.neighbours[f as usize].is_none() {
                    let [a, b, c] = FACE_VERTS[f as usize].map(|k| tet.nodes[k as usize]);
                    faces.push([a, b, c].map(|n| DVec3::of(pos[n.idx()])));
                }
            }
        }
        let tets: Vec<[u32; 4]> = mesh
            .tets()
            .map(|t| t.nodes.map(|n| n.idx() as u32))
            .collect();
        Self {
            value: vec![f32::NAN; pos.len()],
            out: vec![Vec3::NAN; tets.len()],
            inv: vec![[Vec3::ZERO; 3]; tets.len()],
            pos,
            faces,
            tets,
        }
    }

    /// Computes tet `t`'s corner values (brute force over the boundary triangles), its
    /// direction out and its inverse edge matrix, once.
    fn ensure(&mut self, t: usize) {
        if !self.out[t].x.is_nan() {
            return;
        }
        let c = self.tets[t];
        for &n in &c {
            if self.value[n as usize].is_nan() {
                let p = DVec3::of(self.pos[n as usize]);
                self.value[n as usize] = self
                    .faces
                    .iter()
                    .map(|&[a, b, c]| (closest_on_triangle(p, a, b, c) - p).length_squared())
                    .fold(f64::INFINITY, f64::min)
                    .sqrt() as f32;
            }
        }
        let x = c.map(|n| DVec3::of(self.pos[n as usize]));
        // Rows of the inverse of the edge matrix [e1 e2 e3]: (e2 x e3, e3 x e1, e1 x e2) / det.
        let (e1, e2, e3) = (x[1] - x[0], x[2] - x[0], x[3] - x[0]);
        let det = e1.dot(e2.cross(e3));
        let rows = [e2.cross(e3), e3.cross(e1), e1.cross(e2)].map(|r| r * (1.0 / det));
        let phi = c.map(|n| self.value[n as usize] as f64);
        let grad =
            rows[0] * (phi[1] - phi[0]) + rows[1] * (phi[2] - phi[0]) + rows[2] * (phi[3] - phi[0]);
        self.out[t] = (grad * -1.0).as_vec3().normalize_or_zero();
        self.inv[t] = rows.map(|r| r.as_vec3());
    }

    /// The field's depth and outward direction at `x` in tet `t` (frame of the field).
    #[inline]
    fn at(&self, t: usize, x: Vec3) -> (f32, Vec3) {
        let c = self.tets[t];
        let r = x - self.pos[c[0] as usize];
        let inv = &self.inv[t];
        let b = [inv[0].dot(r), inv[1].dot(r), inv[2].dot(r)];
        let v = |k: usize| self.value[c[k] as usize];
        let depth = v(0) * (1.0 - b[0] - b[1] - b[2]) + v(1) * b[0] + v(2) * b[1] + v(3) * b[2];
        (depth, self.out[t])
    }
}

/// The raw force (stiffness 1; the caller scales it) the field gives the nodes of `pens` (pen nodes in the object,
/// at `world`) and `objs` (object nodes in the pen, at `obj_pos`), the pen at `(tip,
/// rotation)`. Counted under callgrind on its own.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn field_forces(
    obj_field: &Field,
    pen_field: &Field,
    world: &[Vec3],
    obj_pos: &[Vec3],
    pens: &[Penetration],
    objs: &[Penetration],
    tip: Vec3,
    rotation: Quat,
    depths: &mut Vec<(f32, Vec3)>,
) -> Vec3 {
    depths.clear();
    let mut raw = Vec3::ZERO;
    for p in pens {
        let (d, n) = obj_field.at(p.tet.idx(), world[p.node.idx()]);
        raw += n * d;
        depths.push((d, n));
    }
    let back = rotation.inverse();
    for p in objs {
        let x = back * (obj_pos[p.node.idx()] - tip);
        let (d, n) = pen_field.at(p.tet.idx(), x);
        let n = rotation * n;
        raw -= n * d;
        depths.push((d, n));
    }
    raw
}

/// `(mean, p99, max)` of `v` (sorted here); zeros for none.
fn stats(v: &mut [f64]) -> (f64, f64, f64) {
    if v.is_empty() {
        return (0.0, 0.0, 0.0);
    }
    v.sort_by(f64::total_cmp);
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let p99 = v[(v.len() * 99 / 100).min(v.len() - 1)];
    (mean, p99, v[v.len() - 1])
}

fn main() -> ExitCode {
    let (mesh, touching, _) = match profile_args("depth_field", 1) {
        Ok(a) => a,
        Err(line) => {
            eprintln!("{line}");
            return ExitCode::from(2);
        }
    };
    let (mut pen, mut obj) = match (
        load_mesh("models/pen_tool_gmsh.mesh", 10.0),
        load_mesh(&mesh, 1.0),
    ) {
        (Ok(p), Ok(o)) => (p, o),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("depth_field: {e}");
            return ExitCode::from(2);
        }
    };
    let (mut pen_field, mut obj_field) = (Field::new(&pen.view()), Field::new(&obj.view()));
    let obj_pos = obj_field.pos.clone();
    let poses = if touching {
        touch_poses(&obj.view(), 200, 0.05, 7)
    } else {
        impaled_poses(&obj.view(), 200, 0.25, 7)
    };
    let opts = PenOptions::default();
    let mut rig = PenRig { pen, obj };
    let run = rig.with(|scene, bufs| {
        let (mut force_err, mut angle, mut depth_err, mut dir_err) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut nodes, mut flipped) = (0usize, 0usize);
        let mut object_only = Vec::new();
        let mut depths = Vec::new();
        for &(tip, rot) in &poses {
            let c = pen_contact(scene, bufs, tip, rot, &opts, &mut PenState::default());
            let (p, o) = c.penetrations;
            let (pens, objs) = (&bufs.pen_pens[..p], &bufs.object_pens[..o]);
            if p + o == 0 {
                continue;
            }
            for q in pens {
                obj_field.ensure(q.tet.idx());
            }
            for q in objs {
                pen_field.ensure(q.tet.idx());
            }
            let raw = black_box(field_forces(
                &obj_field,
                &pen_field,
                bufs.world,
                &obj_pos,
                pens,
                objs,
                tip,
                rot,
                &mut depths,
            ));
            // The pass's force has the options' stiffness; the field's has 1.
            let k = opts.params.stiffness;
            let raw = raw * k;
            let springs: f64 = pens.iter().chain(objs).map(|q| (k * q.depth) as f64).sum();
            if springs > 0.0 {
                force_err.push((raw - c.raw).length() as f64 / springs);
            }
            // The field for the object nodes only (the pen's nodes keep the consistent depth).
            let mut hybrid = Vec3::ZERO;
            for q in pens {
                hybrid += q.dir * (k * q.depth);
            }
            for &(d, n) in &depths[p..] {
                hybrid -= n * (k * d);
            }
            if springs > 0.0 {
                object_only.push((hybrid - c.raw).length() as f64 / springs);
            }
            if raw.length() > 0.0 && c.raw.length() > 0.0 {
                angle.push(raw.angle_between(c.raw).to_degrees() as f64);
            }
            for (q, &(d, n)) in pens.iter().chain(objs).zip(&depths) {
                nodes += 1;
                depth_err.push((d - q.depth).abs() as f64);
                if q.dir != Vec3::ZERO && n != Vec3::ZERO {
                    let a = n.angle_between(q.dir).to_degrees() as f64;
                    if a > 90.0 {
                        flipped += 1;
                    }
                    dir_err.push(a);
                }
            }
        }
        (
            force_err,
            object_only,
            angle,
            depth_err,
            dir_err,
            nodes,
            flipped,
        )
    });
    let (mut force_err, mut object_only, mut angle, mut depth_err, mut dir_err, nodes, flipped) =
        match run {
            Ok(r) => r,
            Err(e) => {
                eprintln!("depth_field: {mesh}: {e}");
                return ExitCode::from(2);
            }
        };
    let poses_in = force_err.len();
    let fe = stats(&mut force_err);
    let oo = stats(&mut object_only);
    let an = stats(&mut angle);
    let de = stats(&mut depth_err);
    let di = stats(&mut dir_err);
    println!(
        "{mesh} {}: {poses_in} poses in contact, {nodes} nodes with a consistent depth ({} per pose)",
        if touching { "touching" } else { "impaled" },
        nodes / poses_in.max(1)
    );
    println!(
        "  force difference / springs' sum: mean {:.3e}, p99 {:.3e}, max {:.3e} (the reference test's tolerance: 1e-4)",
        fe.0, fe.1, fe.2
    );
    println!(
        "  the field for the object's nodes only: mean {:.3e}, p99 {:.3e}, max {:.3e}",
        oo.0, oo.1, oo.2
    );
    println!(
        "  angle between the forces, degrees: mean {:.2}, p99 {:.2}, max {:.2}",
        an.0, an.1, an.2
    );
    println!(
        "  node depth difference: mean {:.2e}, p99 {:.2e}, max {:.2e}; direction difference, degrees: mean {:.2}, p99 {:.2}, max {:.2}; {flipped} nodes turned more than 90 degrees",
        de.0, de.1, de.2, di.0, di.1, di.2
    );
    ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closest point is on the triangle and no sample of the triangle is closer; the
    /// samples' best is within the sampling step of it.
    #[test]
    fn closest_point_beats_every_sample_of_the_triangle() {
        let tri = [
            DVec3([0.0, 0.0, 0.0]),
            DVec3([1.0, 0.2, 0.0]),
            DVec3([0.3, 0.9, 0.4]),
        ];
        let [a, b, c] = tri;
        let n = 60;
        let mut seed = 7u64;
        let mut unit = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 4.0 - 2.0
        };
        for _ in 0..200 {
            let p = DVec3([unit(), unit(), unit()]);
            let q = closest_on_triangle(p, a, b, c);
            // On the triangle: its barycentric coordinates are in [0, 1].
            let (v0, v1, v2) = (b - a, c - a, q - a);
            let (d00, d01, d11) = (v0.dot(v0), v0.dot(v1), v1.dot(v1));
            let (d20, d21) = (v2.dot(v0), v2.dot(v1));
            let den = d00 * d11 - d01 * d01;
            let (v, w) = ((d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den);
            assert!(v >= -1e-9 && w >= -1e-9 && v + w <= 1.0 + 1e-9, "{v} {w}");
            let best = (q - p).length_squared().sqrt();
            let mut sampled = f64::INFINITY;
            for i in 0..=n {
                for j in 0..=(n - i) {
                    let (s, t) = (i as f64 / n as f64, j as f64 / n as f64);
                    let x = a + (b - a) * s + (c - a) * t;
                    sampled = sampled.min((x - p).length_squared().sqrt());
                }
            }
            assert!(best <= sampled + 1e-12, "{best} > {sampled}");
            assert!(
                sampled - best <= 2.0 / n as f64,
                "{best} far below {sampled}"
            );
        }
    }
}
