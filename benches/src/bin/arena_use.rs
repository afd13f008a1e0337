//! Hierarchy arena use over a long replay (issue 10): every `--every` ticks, one tab-separated
//! line with the arena nodes handed out, those holding material, those of wholly erased
//! subtrees (which refinements take back once the fresh blocks are used up), the blocks taken
//! back so far, the refinements refused (arena full) and the work items dropped (pending deque
//! full), the removed volume and the wall time. The ticks are the replay's
//! (`engine::tick`, as `tetradrill replay` runs them).
//!
//! ```text
//! M=tests/data/meshes cargo run --release -p tetradrill-benches --bin arena_use -- \
//!   --mesh $M/models/teddy_cgalbear_tetgen_q1.414.node --trace wander:1 \
//!   --tool sphere:0.03 --max-depth 5 --ticks 40000
//! ```
//!
//! Flags (defaults: the replay's scenario): `--mesh`, `--trace`, `--tool`, `--max-depth`,
//! `--hierarchy-capacity`, `--budget-per-tick`, `--ticks` (default: the trace's length),
//! `--every` (default 1000), `--census` (at the end, the blocks whose 8 nodes are leaves, by
//! kind: all erased, all material without a visible face, the rest).

use std::collections::HashMap;
use std::process::ExitCode;
use std::time::Instant;

use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::scenario::Scenario;
use tetradrill::traces::PoseSource;
use tetradrill_core::force::ToolState;
use tetradrill_core::hierarchy::Hierarchy;
use tetradrill_core::TetId;

struct Args {
    sc: Scenario,
    ticks: Option<u64>,
    every: u64,
    census: bool,
}

fn usage_error(msg: &str) -> ExitCode {
    eprintln!(
        "arena_use: {msg} (flags: --mesh, --trace, --tool, --max-depth, --hierarchy-capacity, \
         --budget-per-tick, --ticks, --every, --census)"
    );
    ExitCode::from(2)
}

fn number<T: std::str::FromStr + PartialOrd + Default>(flag: &str, v: &str) -> Result<T, ExitCode> {
    match v.parse::<T>() {
        Ok(n) if n > T::default() => Ok(n),
        _ => Err(usage_error(&format!("{flag} {v}: a whole number > 0"))),
    }
}

fn parse_args() -> Result<Args, ExitCode> {
    let mut a = Args {
        sc: Scenario::default(),
        ticks: None,
        every: 1000,
        census: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--census" {
            a.census = true;
            continue;
        }
        let Some(v) = it.next() else {
            return Err(usage_error(&format!("flag {flag} needs a value")));
        };
        match flag.as_str() {
            "--mesh" => a.sc.mesh = v,
            "--trace" => a.sc.trace = v,
            "--tool" => a.sc.tool = v,
            "--max-depth" => a.sc.max_depth = number(&flag, &v)?,
            "--hierarchy-capacity" => a.sc.hierarchy_capacity = Some(number(&flag, &v)?),
            "--budget-per-tick" => a.sc.budget_per_tick = number(&flag, &v)?,
            "--ticks" => a.ticks = Some(number(&flag, &v)?),
            "--every" => a.every = number(&flag, &v)?,
            _ => return Err(usage_error(&format!("unknown flag {flag}"))),
        }
    }
    Ok(a)
}

/// Blocks whose 8 nodes are leaves, by kind: all erased (taken back first), all material
/// without a visible face, the rest (drilled surface or partly erased).
fn census(h: &Hierarchy<'_>) -> [usize; 3] {
    let mut out = [0usize; 3];
    for t in 0..h.tet_count() {
        // Per parent index: (leaf children, erased, material without a visible face).
        let mut by_parent: HashMap<u32, [u32; 3]> = HashMap::new();
        h.for_each_leaf(TetId::from_idx(t), |l| {
            if l.index == 0 {
                return;
            }
            let e = by_parent.entry((l.index - 1) / 8).or_default();
            e[0] += 1;
            if l.record.erased() {
                e[1] += 1;
            } else if l.record.visible() == 0 {
                e[2] += 1;
            }
        });
        for [n, erased, solid] in by_parent.into_values() {
            if n == 8 {
                out[if erased == 8 {
                    0
                } else if solid == 8 {
                    1
                } else {
                    2
                }] += 1;
            }
        }
    }
    out
}

fn main() -> ExitCode {
    let a = match parse_args() {
        Ok(a) => a,
        Err(code) => return code,
    };
    let fail = |e: &dyn std::fmt::Display| {
        eprintln!("arena_use: {e}");
        ExitCode::from(2)
    };
    let setup = match a.sc.setup() {
        Ok(s) => s,
        Err(e) => return fail(&e),
    };
    let params = match TickParams::of(&setup) {
        Ok(p) => p,
        Err(e) => return fail(&e),
    };
    let loaded = match engine::load_mesh(&setup) {
        Ok(l) => l,
        Err(e) => return fail(&e),
    };
    let poses = match PoseSource::new(&setup.poses, Some(&loaded.mesh)) {
        Ok(p) => p,
        Err(e) => return fail(&e),
    };
    let mut store = match EngineStorage::new(loaded.mesh, &setup) {
        Ok(s) => s,
        Err(e) => return fail(&e),
    };
    let mut world = match store.world() {
        Ok(w) => w,
        Err(e) => return fail(&e),
    };
    let ticks = a.ticks.unwrap_or_else(|| poses.ticks());
    let mut tool = ToolState::default();
    let t0 = Instant::now();
    println!("tick\tarena_used\tarena_live\tarena_reclaimable\treclaimed\tarena_refusals\tpending_drops\tremoved\tsecs");
    for i in 0..ticks {
        engine::tick(&mut world, &mut tool, &params, &poses.at(i));
        if (i + 1) % a.every == 0 || i + 1 == ticks {
            let h = world.hierarchy();
            let s = world.saturations();
            println!(
                "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{:.6e}\t{:.2}",
                i + 1,
                h.arena_used(),
                h.arena_live(),
                h.arena_reclaimable(),
                h.reclaimed(),
                s.arena,
                s.pending,
                h.removed_volume(),
                t0.elapsed().as_secs_f64()
            );
        }
    }
    if a.census {
        let [erased, solid, rest] = census(world.hierarchy());
        println!(
            "blocks of 8 leaves: all erased {erased}, all material without a visible face \
             {solid}, the rest (surface, partly erased) {rest}"
        );
    }
    if let Err(e) = engine::validate(&world) {
        eprintln!("arena_use: the final state is invalid: {e}");
        return ExitCode::from(1);
    }
    ExitCode::SUCCESS
}
