//! Point location of the pen's nodes in the cow or the teddy, for instruction counts: the
//! contact bench's `query` groups (50 touching or impaled poses of the pen x10) without
//! criterion, each query in its own function so that callgrind can count it alone.
//!
//! Usage: `query_profile MESH touching|impaled [REPS]` (MESH relative to the meshes folder:
//! `TETRADRILL_MESHES` or the repository's `tests/data/meshes`). Prints, per query, the
//! contacts and the candidate tets tested per pose. Instruction counts:
//! `valgrind --tool=callgrind --toggle-collect='*run_walked*' query_profile ...` (also
//! `run_plain`, `run_occupied`). The environment may set the hash's cell edge in average edges
//! (`CELL_SCALE`, default 1) and its entries per tet (`PER`, default 16). Exit status 2 for bad
//! arguments, an unreadable mesh or a saturated hash.

use std::hint::black_box;
use std::process::ExitCode;

use glam::{Quat, Vec3};
use tetradrill::pen::ObjectCells;
use tetradrill_benches::{impaled_poses, load_mesh, profile_args, touch_poses};
use tetradrill_core::collide::{
    hash_tets, points_in_tets, points_in_tets_occupied, points_in_tets_walked, walks_exact, Body,
    CollideReport, Collision, Occupancy, WalkStarts,
};
use tetradrill_core::depth::{graph_sizes, NodeGraph};
use tetradrill_core::hash::{average_edge_length, prime_at_most, HashEntry, SpatialHash};
use tetradrill_core::ids::{NodeId, TetId};
use tetradrill_core::mesh::Mesh;

/// The contact bench's poses: touching (tip up to 0.05 in, axis near the normal) or impaled
/// (tip up to 0.25 in, any orientation), seed 7.
fn poses(obj: &Mesh<'_>, n: usize, touching: bool) -> Vec<(Vec3, Quat)> {
    if touching {
        touch_poses(obj, n, 0.05, 7)
    } else {
        impaled_poses(obj, n, 0.25, 7)
    }
}

/// Everything a query reads.
struct Scene<'s> {
    hash: &'s SpatialHash<'s>,
    cells: &'s Occupancy<'s>,
    body: Body<'s, 's>,
    graph: NodeGraph<'s>,
    walks: u32,
}

#[inline(never)]
fn run_plain(s: &Scene<'_>, poses: &[Vec<Vec3>], out: &mut [Collision]) -> CollideReport {
    let mut sum = CollideReport::default();
    for pts in poses {
        let r = black_box(points_in_tets(s.hash, &s.body, pts, false, out));
        sum.count += r.count;
        sum.candidates += r.candidates;
    }
    sum
}

#[inline(never)]
fn run_occupied(s: &Scene<'_>, poses: &[Vec<Vec3>], out: &mut [Collision]) -> CollideReport {
    let mut sum = CollideReport::default();
    for pts in poses {
        let r = black_box(points_in_tets_occupied(
            s.hash,
            s.cells,
            &s.body,
            pts,
            false,
            out,
            0,
            |_| true,
        ));
        sum.count += r.count;
        sum.candidates += r.candidates;
    }
    sum
}

#[inline(never)]
fn run_walked(
    s: &Scene<'_>,
    poses: &[Vec<Vec3>],
    out: &mut [Collision],
    found: &mut [TetId],
) -> CollideReport {
    let mut sum = CollideReport::default();
    for pts in poses {
        let starts = WalkStarts {
            found: &mut *found,
            near: |i| s.graph.neighbours(NodeId::from_idx(i)),
            max_steps: s.walks,
        };
        let r = black_box(points_in_tets_walked(
            s.hash,
            s.cells,
            &s.body,
            pts,
            out,
            0,
            starts,
            |_| true,
        ));
        sum.count += r.count;
        sum.candidates += r.candidates;
    }
    sum
}

fn main() -> ExitCode {
    let (mesh, touching, reps) = match profile_args("query_profile", 1) {
        Ok(a) => a,
        Err(line) => {
            eprintln!("{line}");
            return ExitCode::from(2);
        }
    };
    let set = if touching { "touching" } else { "impaled" };
    let (mut pen_m, mut obj_m) = match (
        load_mesh("models/pen_tool_gmsh.mesh", 10.0),
        load_mesh(&mesh, 1.0),
    ) {
        (Ok(p), Ok(o)) => (p, o),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("query_profile: {e}");
            return ExitCode::from(2);
        }
    };
    let (pen, obj) = (pen_m.view(), obj_m.view());
    let body = Body::fixed(&obj);
    let cell = average_edge_length(&obj)
        * std::env::var("CELL_SCALE")
            .ok()
            .and_then(|v| v.parse::<f32>().ok())
            .unwrap_or(1.0);
    // The contact bench's table: 16 entries per tet, buckets about twice the entries.
    let per: usize = std::env::var("PER")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(16);
    let buckets = prime_at_most((2 * per * obj.tet_count()).clamp(3, u32::MAX as usize) as u32);
    let mut starts = vec![0u32; buckets as usize + 1];
    let mut entries = vec![HashEntry::default(); per * obj.tet_count()];
    let Ok(mut hash) = SpatialHash::new(&mut starts, &mut entries, cell) else {
        eprintln!("query_profile: {mesh}: no spatial hash for cell size {cell}");
        return ExitCode::from(2);
    };
    let built = hash_tets(&mut hash, &body);
    let per_tet = built.entries as f64 / obj.tet_count() as f64;
    if built.saturated {
        eprintln!("query_profile: {mesh}: the tet hash saturated");
        return ExitCode::from(2);
    }
    let mut cell_store = ObjectCells::new(&obj, cell);
    let Ok(cells) = cell_store.build(&body, cell) else {
        eprintln!("query_profile: {mesh}: no occupancy grid");
        return ExitCode::from(2);
    };
    let (go, ga) = graph_sizes(&pen);
    let (mut offsets, mut adj) = (vec![0u32; go], vec![NodeId::NONE; ga]);
    let Ok(graph) = NodeGraph::build(&pen, &mut offsets, &mut adj) else {
        eprintln!("query_profile: the pen's node graph does not fit");
        return ExitCode::from(2);
    };
    let walks = if walks_exact(&body) { 8 } else { 0 };
    let scene = Scene {
        hash: &hash,
        cells: &cells,
        body,
        graph,
        walks,
    };
    let pose_pts: Vec<Vec<Vec3>> = poses(&obj, 200, touching)
        .into_iter()
        .take(50)
        .map(|(p, q)| pen.positions().iter().map(|&x| q * x + p).collect())
        .collect();
    let mut out = vec![Collision::default(); pen.node_count()];
    let mut found = vec![TetId::NONE; pen.node_count()];
    let n = (pose_pts.len() * reps) as f64;
    for _ in 0..reps {
        let p = run_plain(&scene, &pose_pts, &mut out);
        let o = run_occupied(&scene, &pose_pts, &mut out);
        let w = run_walked(&scene, &pose_pts, &mut out, &mut found);
        if p.count != o.count || p.count != w.count {
            eprintln!("query_profile: the queries disagree");
            return ExitCode::from(1);
        }
        println!(
            "{mesh} {set}: {per_tet:.1} hash entries per tet; {} contacts in {} poses; candidates per pose: plain {:.1}, occupied {:.1}, walked {:.1} (walks: {walks} steps)",
            p.count,
            pose_pts.len(),
            p.candidates as f64 * reps as f64 / n,
            o.candidates as f64 * reps as f64 / n,
            w.candidates as f64 * reps as f64 / n,
        );
    }
    ExitCode::SUCCESS
}
