//! Shared helpers for tetradrill's cross-crate tests: where the real meshes are, small oracles.
//!
//! The oracles are written here, apart from the crates they check (the exhaustive search of
//! [`search`] takes the core's closest point on a triangle); the rest sets up scenes through the
//! crates' public API:
//! - [`brute`]: Kuhn-tet blocks, f64 signed volumes, tet boxes and their overlap;
//! - [`oracle`]: f64 vector math for the reference computations;
//! - [`contact`]: the pen-contact scene (meshes, rig, random poses, one fresh tick);
//! - [`drill`]: the brute-force visible-face oracle and hierarchy storage;
//! - [`faults`]: a device wrapper that injects faults by read number, the devices it wraps;
//! - [`search`]: world storage and the exhaustive contact search;
//! - [`tetgen_reader`]: a minimal TetGen reader, independent of the host's readers;
//! - [`viewer`]: the render size, engine storage and the f64 pinhole model.

pub mod brute;
pub mod contact;
pub mod drill;
pub mod faults;
pub mod force_log;
pub mod oracle;
pub mod search;
pub mod tetgen_reader;
pub mod viewer;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The folder of real meshes: `tests/data/meshes` in the repository (the public models the
/// suite needs; a fresh clone has them), or the folder named by `TETRADRILL_MESHES` when that is
/// set (an override with the same layout, e.g. a larger set for benches). Tests that need real
/// meshes fail loudly when the folder is missing: a skipped oracle is a defect, not a pass.
pub fn meshes_dir() -> PathBuf {
    let p = match std::env::var_os("TETRADRILL_MESHES") {
        // Relative paths are taken from the workspace root.
        Some(dir) => workspace_root().join(PathBuf::from(dir)),
        None => workspace_root().join("tests/data/meshes"),
    };
    assert!(
        p.is_dir(),
        "no meshes folder at {} (TETRADRILL_MESHES names another one)",
        p.display()
    );
    p
}

/// The workspace root (the parent of this crate's folder).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests crate has a parent folder")
        .to_path_buf()
}

/// Path of one mesh file below the meshes folder ([`meshes_dir`]).
pub fn mesh(rel: &str) -> PathBuf {
    let p = meshes_dir().join(rel);
    assert!(p.exists(), "missing mesh {}", p.display());
    p
}

/// A mesh by its path below the meshes folder (or a `builtin:` name), scaled by `scale`.
pub fn load(rel: &str, scale: f64) -> tetradrill::owned::OwnedMesh {
    let p = if rel.starts_with("builtin:") {
        Path::new(rel).to_path_buf()
    } else {
        mesh(rel)
    };
    tetradrill::meshio::load(&p, scale)
        .expect("mesh loads")
        .mesh
}

/// Runs of the wall-clock pipeline a loaded machine may disturb: a run whose servo stalled
/// past the watchdog (the force cut for a while, the hand pushing the stylus on meanwhile) is
/// not the run a test is about, and [`unstalled`] runs it again, up to this many times.
pub const STALL_ATTEMPTS: usize = 5;

/// One wall-clock run of the servo at a time in a test binary: two of them (a servo and a
/// simulation thread each) on a two-core machine stall each other's servo, and each stalled
/// run is run again. Held by [`unstalled`] over its runs and by tests that run the servo for
/// seconds; a test that panicked while holding it leaves it usable.
pub fn one_realtime_run() -> std::sync::MutexGuard<'static, ()> {
    static ONE: std::sync::Mutex<()> = std::sync::Mutex::new(());
    ONE.lock().unwrap_or_else(|e| e.into_inner())
}

/// `run()` until `stalls` of its result is 0, at most [`STALL_ATTEMPTS`] times; the first run
/// without a stall. Panics (the test fails) when every run stalled. Holds
/// [`one_realtime_run`] throughout.
pub fn unstalled<T>(mut run: impl FnMut() -> T, stalls: impl Fn(&T) -> u64) -> T {
    let _one = one_realtime_run();
    let mut last = run();
    for _ in 1..STALL_ATTEMPTS {
        if stalls(&last) == 0 {
            return last;
        }
        last = run();
    }
    assert_eq!(
        stalls(&last),
        0,
        "the servo stalled in {STALL_ATTEMPTS} runs"
    );
    last
}

/// A fresh, empty scratch folder for one test: `<tmp>/tetradrill-<prefix>-<pid>-<name>`,
/// removed with everything in it when the returned [`Scratch`] drops (kept when the
/// environment sets `TETRADRILL_KEEP_SCRATCH`, to look at what a failing test wrote).
pub fn scratch_dir(prefix: &str, name: &str) -> Scratch {
    let d = std::env::temp_dir().join(format!("tetradrill-{prefix}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create a scratch folder");
    Scratch(d)
}

/// A test's scratch folder ([`scratch_dir`]): a path while it lives, removed when it drops.
#[derive(Debug)]
pub struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<std::ffi::OsStr> for Scratch {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.as_os_str()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::env::var_os("TETRADRILL_KEEP_SCRATCH").is_none() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// The `tetradrill` binary of the build profile the tests run under, built once with cargo
/// (a no-op when it is fresh), for tests of exit statuses and real-time runs.
pub fn tetradrill_bin() -> PathBuf {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        let exe = std::env::current_exe().expect("test binary path");
        let mut dir = exe.parent().expect("test binary folder").to_path_buf();
        if dir.ends_with("deps") {
            dir.pop();
        }
        let profile = dir
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or("debug")
            .to_string();
        let target_dir = dir.parent().expect("target folder").to_path_buf();
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.current_dir(workspace_root())
            .args([
                "build",
                "--quiet",
                "-p",
                "tetradrill",
                "--bin",
                "tetradrill",
            ])
            .env("CARGO_TARGET_DIR", &target_dir);
        match profile.as_str() {
            "debug" => {}
            "release" => {
                cmd.arg("--release");
            }
            p => {
                cmd.args(["--profile", p]);
            }
        }
        let status = cmd
            .status()
            .expect("run cargo to build the tetradrill binary");
        assert!(status.success(), "building the tetradrill binary failed");
        let bin = dir.join(format!("tetradrill{}", std::env::consts::EXE_SUFFIX));
        assert!(bin.is_file(), "no binary at {}", bin.display());
        bin
    })
    .clone()
}

/// Runs the binary with `args` and asserts what bad input must give: exit status 2 and a
/// first stderr line holding every one of `needles` (the flag, the file and line, the reason).
pub fn refused(args: &[&str], needles: &[&str]) {
    let out = std::process::Command::new(tetradrill_bin())
        .args(args)
        .output()
        .expect("run tetradrill");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    let first = err.lines().next().unwrap_or("");
    for n in needles {
        assert!(first.contains(n), "{args:?}: {first:?} lacks {n:?}");
    }
}

/// Runs the binary with `args` and asserts that it succeeded (with its stderr on failure);
/// returns its output.
pub fn run_ok<I, S>(args: I) -> std::process::Output
where
    I: IntoIterator<Item = S>,
    S: AsRef<std::ffi::OsStr>,
{
    let args: Vec<std::ffi::OsString> = args.into_iter().map(|a| a.as_ref().into()).collect();
    let out = Command::new(tetradrill_bin())
        .args(&args)
        .output()
        .expect("run tetradrill");
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The rows of a `--forces` file (`tick,fx,fy,fz`): each tick's force, as f32.
pub fn read_forces(path: &Path) -> Vec<[f32; 3]> {
    std::fs::read_to_string(path)
        .expect("read the forces")
        .lines()
        .skip(1)
        .map(|l| {
            let mut v = l
                .split(',')
                .skip(1)
                .map(|x| x.parse::<f32>().expect("an f32"));
            let mut next = || v.next().expect("three components");
            [next(), next(), next()]
        })
        .collect()
}

/// A replay's `removed_by_region` (its JSON) by label, in cubic millimetres (the tooth meshes
/// are in metres).
pub fn removed_mm3_by_label(j: &serde_json::Value) -> std::collections::BTreeMap<i32, f64> {
    j["removed_by_region"]
        .as_object()
        .expect("removed_by_region")
        .iter()
        .map(|(k, v)| {
            (
                k.parse().expect("a label"),
                v.as_f64().expect("a volume") * 1e9,
            )
        })
        .collect()
}

/// Runs the binary with `args` and `--json FILE` (a scratch file under `scratch_dir(prefix,
/// name)`), asserts that it succeeded (with its stderr on failure), and returns the JSON.
pub fn json_of(args: &[&str], prefix: &str, name: &str) -> serde_json::Value {
    let dir = scratch_dir(prefix, name);
    let json = dir.join("out.json");
    let flag = ["--json".as_ref(), json.as_os_str()];
    run_ok(args.iter().map(std::ffi::OsStr::new).chain(flag));
    read_json(&json)
}

/// The JSON in the file at `path`.
pub fn read_json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).expect("read the JSON");
    serde_json::from_str(&text).expect("parse the JSON")
}

/// A set-up's tick parameters and its engine storage, its mesh loaded: what a test that
/// runs `engine::tick` over a world (`storage.world()`) starts from.
pub fn engine_storage(
    sc: &tetradrill::setup::Setup,
) -> (
    tetradrill::engine::TickParams,
    tetradrill::engine::EngineStorage,
) {
    let params = tetradrill::engine::TickParams::of(sc).expect("scenario");
    let loaded = tetradrill::engine::load_mesh(sc).expect("mesh");
    let store = tetradrill::engine::EngineStorage::new(loaded.mesh, sc).expect("storage");
    (params, store)
}
