//! The Touch loader (`tetradrill_device::os::hdapi`) without a Touch: the error paths when no library
//! exists or the override is not a library, and the real `dlopen` path through a small
//! stand-in HD library written here in C and compiled with the system C compiler at test time.
//!
//! The stand-in is not the vendor library: it exports the HDAPI entry point names the loader
//! resolves, with trivial behaviour written for these tests: a scheduler thread (started by
//! `hdStartScheduler`, stopped and joined by `hdStopScheduler`) calls the callback given to
//! `hdScheduleAsynchronous` about every millisecond and unschedules it when it answers
//! `HD_CALLBACK_DONE`; a frame counter drives the position and buttons; the force set is kept
//! and read back through `HD_CURRENT_FORCE` while force output is enabled; frame misuse pushes
//! an error on a per-thread error stack; a frame begun outside the scheduler's callback is
//! counted. At `hdDisableDevice` (the loader's last call) it writes what it saw to a report
//! file, which the tests read after the library is unloaded. Its numeric codes are the ones
//! the loader declares; the tests check the loader against them, not against hardware.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use tetradrill_device::os::hdapi::{candidates, HdApi, HdLoadError, HD_LIBRARY_ENV};
use tetradrill_device::safety::SafetyConfig;
use tetradrill_device::touch::{TouchDevice, HD_LIBRARY_NAMES};
use tetradrill_device::{DeviceError, ForceCommand, HapticDevice};
use tetradrill_tests::Scratch;

/// The stand-in library. `FAIL_INIT` makes `hdInitDevice` fail as with no device attached;
/// `WARN_AT=N` raises `HD_WARM_MOTORS` in frame N and `FAIL_AT=N` `HD_COMM_ERROR` in frame N
/// (both in the scheduler's thread, where the frame is); `REPORT="path"` names the report.
const FAKE_HD_C: &str = r#"
#include <stddef.h>
#include <stdio.h>
#include <pthread.h>
#include <time.h>

typedef unsigned int HHD;
typedef unsigned int HDenum;
typedef struct { unsigned int errorCode; int internalErrorCode; HHD hHD; } HDErrorInfo;
typedef unsigned int (*HDSchedulerCallback)(void *);

static pthread_mutex_t force_lock = PTHREAD_MUTEX_INITIALIZER;
static int initialised = 0, force_on = 0, scheduler = 0, calibrated = 0;
static __thread int in_frame = 0, in_callback = 0;
static long frames = 0, frames_outside = 0, callbacks = 0, done = 0;
static double force[3];
static __thread HDErrorInfo errors[8];
static __thread int n_errors = 0;

static HDSchedulerCallback callback = NULL;
static void *callback_data = NULL;
static int running = 0;
static pthread_t scheduler_thread;

static void push(unsigned int code, int internal) {
    if (n_errors < 8) {
        errors[n_errors].errorCode = code;
        errors[n_errors].internalErrorCode = internal;
        errors[n_errors].hHD = 7;
        n_errors++;
    }
}

static void *scheduler_loop(void *arg) {
    struct timespec ms = { 0, 1000000 };
    (void)arg;
    while (__atomic_load_n(&running, __ATOMIC_ACQUIRE)) {
        HDSchedulerCallback f = __atomic_load_n(&callback, __ATOMIC_ACQUIRE);
        if (f) {
            in_callback = 1;
            if (f(callback_data) == 0) {
                __atomic_store_n(&callback, NULL, __ATOMIC_RELEASE);
                __atomic_add_fetch(&done, 1, __ATOMIC_RELAXED);
            }
            in_callback = 0;
            __atomic_add_fetch(&callbacks, 1, __ATOMIC_RELAXED);
        }
        nanosleep(&ms, NULL);
    }
    return NULL;
}
unsigned long hdScheduleAsynchronous(HDSchedulerCallback f, void *data, unsigned short prio) {
    if (prio != 0xFFFF) push(0x0500, 0);
    callback_data = data;
    __atomic_store_n(&callback, f, __ATOMIC_RELEASE);
    return 1;
}
void hdUnschedule(unsigned long h) { if (h == 1) __atomic_store_n(&callback, NULL, __ATOMIC_RELEASE); }

HHD hdInitDevice(const char *name) {
#ifdef FAIL_INIT
    (void)name;
    push(0x0300, 42);
    return 0xFFFFFFFFu;
#else
    if (name != NULL) { push(0x0101, 0); return 0xFFFFFFFFu; }
    initialised = 1;
    return 7;
#endif
}
void hdDisableDevice(HHD h) {
    if (h == 7) initialised = 0; else push(0x0104, 0);
#ifdef REPORT
    {
        FILE *f = fopen(REPORT, "w");
        if (f) {
            fprintf(f, "frames=%ld frames_outside=%ld callbacks=%ld done=%ld force_on=%d force=%g,%g,%g\n",
                    frames, frames_outside, callbacks, done, force_on, force[0], force[1], force[2]);
            fclose(f);
        }
    }
#endif
}
void hdMakeCurrentDevice(HHD h) { if (h != 7 || !initialised) push(0x0104, 0); }
void hdStartScheduler(void) {
    scheduler = 1;
    __atomic_store_n(&running, 1, __ATOMIC_RELEASE);
    pthread_create(&scheduler_thread, NULL, scheduler_loop, NULL);
}
void hdStopScheduler(void) {
    if (scheduler) {
        __atomic_store_n(&running, 0, __ATOMIC_RELEASE);
        pthread_join(scheduler_thread, NULL);
    }
    scheduler = 0;
}
void hdBeginFrame(HHD h) {
    long n;
    if (h != 7) { push(0x0104, 0); return; }
    if (in_frame) { push(0x0400, 0); return; }
    if (!in_callback) __atomic_add_fetch(&frames_outside, 1, __ATOMIC_RELAXED);
    in_frame = 1;
    n = __atomic_add_fetch(&frames, 1, __ATOMIC_RELAXED);
#ifdef WARN_AT
    if (n == WARN_AT) push(0x0200, 3);
#endif
#ifdef FAIL_AT
    if (n >= FAIL_AT) push(0x0302, 5);
#endif
    (void)n;
}
void hdEndFrame(HHD h) {
    if (h != 7) { push(0x0104, 0); return; }
    if (!in_frame) { push(0x0401, 0); return; }
    in_frame = 0;
}
HDErrorInfo hdGetError(void) {
    HDErrorInfo none = { 0, 0, 0 };
    if (n_errors == 0) return none;
    return errors[--n_errors];
}
const char *hdGetErrorString(unsigned int code) {
    return code == 0x0300 ? "stand-in: no device attached" : "stand-in error";
}
void hdEnable(HDenum cap) { if (cap == 0x4000) force_on = 1; else push(0x0100, 0); }
void hdDisable(HDenum cap) { if (cap == 0x4000) force_on = 0; else push(0x0100, 0); }
void hdGetDoublev(HDenum p, double *v) {
    int i;
    if (p == 0x2050) { v[0] = (double)frames; v[1] = 2.0 * frames; v[2] = -0.5 * frames; }
    else if (p == 0x2052) {
        for (i = 0; i < 16; i++) v[i] = (i % 5 == 0) ? 1.0 : 0.0;
        v[12] = (double)frames; v[13] = 2.0 * frames; v[14] = -0.5 * frames;
    }
    else if (p == 0x2700) {
        /* What reaches the motors: nothing while force output is disabled. */
        pthread_mutex_lock(&force_lock);
        for (i = 0; i < 3; i++) v[i] = force_on ? force[i] : 0.0;
        pthread_mutex_unlock(&force_lock);
    }
    else push(0x0100, 0);
}
void hdGetIntegerv(HDenum p, int *v) {
    if (p == 0x2000) v[0] = (int)(frames % 4);
    else if (p == 0x2555) v[0] = (1 << 2) | (1 << 0);
    else push(0x0100, 0);
}
void hdGetBooleanv(HDenum p, unsigned char *v) {
    /* The inkwell switch reads 0 while docked: docked on every tenth frame. */
    if (p == 0x2002) v[0] = (frames % 10 == 0) ? 0 : 1;
    else push(0x0100, 0);
}
void hdSetDoublev(HDenum p, const double *v) {
    if (!in_frame) { push(0x0102, 0); return; }
    if (p == 0x2700) {
        pthread_mutex_lock(&force_lock);
        force[0] = v[0]; force[1] = v[1]; force[2] = v[2];
        pthread_mutex_unlock(&force_lock);
    }
    else push(0x0100, 0);
}
HDenum hdCheckCalibration(void) {
    if (!in_frame) push(0x0102, 0);
    return calibrated ? 0x5000 : 0x5001;
}
void hdUpdateCalibration(HDenum style) {
    if (style == (1 << 2)) calibrated = 1;
    else push(0x0101, 0);
}
"#;

/// A fresh directory under the system's temporary directory, removed when it drops.
fn scratch(tag: &str) -> Scratch {
    tetradrill_tests::scratch_dir("hdapi", tag)
}

/// Compiles the stand-in into `dir/name`, or `None` (with a note) when there is no C compiler.
fn build_fake(dir: &Path, name: &str, defines: &[&str]) -> Option<PathBuf> {
    let src = dir.join("fake_hd.c");
    std::fs::write(&src, FAKE_HD_C).expect("write the C source");
    let out = dir.join(name);
    let cc = std::env::var("CC").unwrap_or_else(|_| "gcc".into());
    let mut cmd = Command::new(&cc);
    cmd.args(["-shared", "-fPIC", "-pthread", "-O1", "-o"])
        .arg(&out)
        .arg(&src);
    for d in defines {
        cmd.arg(format!("-D{d}"));
    }
    match cmd.output() {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            eprintln!("note: skipped: no C compiler ({cc}) to build the stand-in HD library");
            None
        }
        Err(e) => panic!("{cc} could not run: {e}"),
        Ok(o) => {
            assert!(
                o.status.success(),
                "{cc} failed: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            Some(out)
        }
    }
}

#[test]
fn no_library_is_a_clear_error_naming_what_was_tried() {
    let dir = scratch("none");
    let names: Vec<String> = ["libHD-absent.so", "libHD-absent.so.3.4"]
        .iter()
        .map(|n| dir.join(n).to_string_lossy().into_owned())
        .collect();
    let e = HdApi::load_from(&names, false).expect_err("nothing to load");
    assert_eq!(
        e,
        HdLoadError::NotFound {
            tried: names.clone()
        }
    );
    let line = e.to_string();
    assert!(!line.contains('\n'), "{line}");
    for n in &names {
        assert!(line.contains(n.as_str()), "{line}");
    }
    assert!(line.contains(HD_LIBRARY_ENV), "{line}");
    assert_eq!(e.device_error(), DeviceError::LibraryNotFound);
}

#[test]
fn default_names_and_the_override() {
    let names = candidates(None);
    assert_eq!(names, HD_LIBRARY_NAMES.map(String::from).to_vec());
    assert_eq!(candidates(Some("".as_ref())), names);
    assert_eq!(
        candidates(Some("/opt/x/libHD.so".as_ref())),
        vec!["/opt/x/libHD.so"]
    );
}

#[test]
fn override_pointing_at_a_non_library_is_a_clean_error() {
    let dir = scratch("notlib");
    let path = dir.join("libHD.so");
    std::fs::write(&path, "this is not an ELF file\n").expect("write");
    let p = path.to_string_lossy().into_owned();
    let e = HdApi::load_from(std::slice::from_ref(&p), true).expect_err("not a library");
    match &e {
        HdLoadError::Unloadable { path, reason } => {
            assert_eq!(path, &p);
            assert!(!reason.is_empty());
        }
        other => panic!("expected Unloadable, got {other:?}"),
    }
    let line = e.to_string();
    assert!(line.starts_with(&format!("{HD_LIBRARY_ENV}={p}")), "{line}");
    assert!(!line.contains('\n'), "{line}");
    assert_eq!(e.device_error(), DeviceError::LibraryNotFound);
}

#[test]
fn a_library_without_the_entry_points_is_refused() {
    // libc loads fine but is no HD library.
    let e = HdApi::load_from(&["libc.so.6".to_string()], true).expect_err("no HDAPI in libc");
    assert_eq!(
        e,
        HdLoadError::MissingSymbol {
            path: "libc.so.6".into(),
            symbol: "hdInitDevice"
        }
    );
}

#[test]
fn stand_in_library_without_a_device_reports_what_hd_init_device_said() {
    let dir = scratch("nodev");
    let Some(lib) = build_fake(&dir, "libHD.so", &["FAIL_INIT"]) else {
        return;
    };
    let p = lib.to_string_lossy().into_owned();
    let mut api = HdApi::load_from(std::slice::from_ref(&p), true).expect("the stand-in loads");
    assert_eq!(api.path(), p);
    let e = api.open_device(None).expect_err("no device");
    assert_eq!(
        e,
        HdLoadError::Init {
            code: 0x0300,
            internal: 42,
            text: "stand-in: no device attached".into()
        }
    );
    let line = e.to_string();
    assert!(
        line.contains("hdInitDevice failed: HD_DEVICE_FAULT (0x0300"),
        "{line}"
    );
    assert_eq!(api.handle(), None);
    // Through the trait the same failure is the device crate's error.
    assert_eq!(
        TouchDevice::new(api, None).err(),
        Some(DeviceError::LibraryCall { code: 0x0300 })
    );
}

/// Builds the stand-in with a report file and `defines`, opens it and starts the device on
/// another thread (as the command line does: opened on the main thread, made current in the
/// servo's). `None` when there is no C compiler.
fn started(dir: &Path, defines: &[&str]) -> Option<(TouchDevice<HdApi>, PathBuf)> {
    let report = dir.join("report.txt");
    let mut all = vec![format!("REPORT=\"{}\"", report.display())];
    all.extend(defines.iter().map(|d| d.to_string()));
    let refs: Vec<&str> = all.iter().map(String::as_str).collect();
    let lib = build_fake(dir, "libHD.so", &refs)?;
    let p = lib.to_string_lossy().into_owned();
    let mut api = HdApi::load_from(&[p], true).expect("the stand-in loads");
    api.open_device(None).expect("the stand-in opens");
    assert_eq!(api.handle(), Some(7));
    let dev = std::thread::spawn(move || {
        TouchDevice::new(api, None)
            .expect("made current, first frame")
            .with_safety(SafetyConfig {
                ramp_ticks: 1,
                ..SafetyConfig::for_max_force(3.3)
            })
    })
    .join()
    .expect("no panic");
    Some((dev, report))
}

/// The stand-in's report after the device and the library are dropped: `key=value` pairs.
fn report(path: &Path) -> std::collections::HashMap<String, String> {
    let text = std::fs::read_to_string(path).expect("the stand-in wrote its report");
    text.split_whitespace()
        .filter_map(|kv| kv.split_once('='))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

/// Polls `done` every millisecond for at most 10 s (a guard against a hang, not a timing
/// claim).
fn eventually(mut done: impl FnMut() -> bool) -> bool {
    let until = Instant::now() + Duration::from_secs(10);
    while Instant::now() < until {
        if done() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    false
}

/// One servo tick: read, write `f`, sleep a period.
fn tick(dev: &mut TouchDevice<HdApi>, f: [f64; 3]) -> Result<(), DeviceError> {
    dev.read()?;
    let w = dev.write(&ForceCommand::force(f));
    std::thread::sleep(Duration::from_millis(1));
    w
}

#[test]
fn stand_in_library_frames_only_in_the_scheduler_position_buttons_and_force() {
    let dir = scratch("dev");
    let Some((mut dev, report_path)) = started(&dir, &[]) else {
        return;
    };
    // Calibration runs in a frame of the callback: needs an update, the stand-in offers
    // inkwell and encoder reset, the inkwell style is chosen and the next check is OK.
    dev.calibrate().expect("calibrates");
    dev.calibrate().expect("already calibrated");

    let mut last_tick = 0;
    let mut docked_seen = false;
    for _ in 0..2000 {
        let s = dev.read().expect("read");
        assert!(s.tick > last_tick);
        last_tick = s.tick;
        // The position is a multiple of the frame count: x = n mm, y = 2n mm, z = -n/2 mm,
        // all three from one frame.
        let n = s.position[0] * 1e3;
        assert!(n >= 1.0 && (n - n.round()).abs() < 1e-9, "{:?}", s.position);
        assert!((s.position[1] - 2.0 * s.position[0]).abs() < 1e-12);
        assert!((s.position[2] + 0.5 * s.position[0]).abs() < 1e-12);
        assert!(s.buttons < 4);
        assert_eq!(s.rotation, [1.0, 0.0, 0.0, 0.0]);
        docked_seen |= s.docked;
        dev.write(&ForceCommand::force([0.0, 10.0, -1.0]))
            .expect("write");
        std::thread::sleep(Duration::from_millis(1));
        if docked_seen && s.tick >= 12 {
            break;
        }
    }
    assert!(docked_seen, "the stand-in docks every tenth frame");
    // The force reaches the motors clamped to 3.3 N, direction kept, in the callback's frame.
    let lib_force = |dev: &TouchDevice<HdApi>| dev.library().current_force().expect("read back");
    assert!(eventually(|| {
        let f = lib_force(&dev);
        ((f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt() - 3.3).abs() < 1e-9
    }));
    let f = lib_force(&dev);
    assert!((f[1] / f[2] + 10.0).abs() < 1e-9, "{f:?}");

    // NaN is refused and zero force is sent.
    assert_eq!(
        dev.write(&ForceCommand::force([f64::NAN, 0.0, 0.0])),
        Err(DeviceError::NonFiniteCommand)
    );
    assert!(eventually(|| lib_force(&dev) == [0.0; 3]));
    assert_eq!(dev.exchange().warnings(), 0);
    drop(dev);
    let r = report(&report_path);
    assert_eq!(r["frames_outside"], "0", "{r:?}");
    assert!(r["frames"].parse::<u64>().expect("frames") >= 12, "{r:?}");
    assert_eq!(r["force_on"], "0", "force output off after the drop: {r:?}");
    assert_eq!(r["force"], "0,0,0", "{r:?}");
    assert_eq!(r["done"], "1", "the callback ended itself: {r:?}");
}

#[test]
fn the_callback_zeroes_a_stalled_servos_force_and_the_servo_goes_on() {
    let dir = scratch("guard");
    let Some((mut dev, report_path)) = started(&dir, &[]) else {
        return;
    };
    tick(&mut dev, [0.0, 0.0, 1.0]).expect("tick");
    assert!(eventually(
        || dev.library().current_force() == Ok([0.0, 0.0, 1.0])
    ));
    let trips_before = dev.exchange().stall_trips();
    // The servo stops here. The callback sees no new command for 5 ms and sets zero.
    assert!(
        eventually(|| dev.exchange().stall_trips() > trips_before
            && dev.library().current_force() == Ok([0.0; 3])),
        "the callback never zeroed the stalled servo's force"
    );
    // The servo goes on: its force comes back, ramped.
    for _ in 0..5 {
        tick(&mut dev, [0.0, 0.0, 1.0]).expect("tick after the stall");
    }
    assert!(eventually(
        || dev.library().current_force() == Ok([0.0, 0.0, 1.0])
    ));
    drop(dev);
    assert_eq!(report(&report_path)["frames_outside"], "0");
}

#[test]
fn a_warm_motors_warning_is_counted_and_the_run_goes_on() {
    let dir = scratch("warn");
    let Some((mut dev, report_path)) = started(&dir, &["WARN_AT=20"]) else {
        return;
    };
    assert!(eventually(|| {
        tick(&mut dev, [0.0, 1.0, 0.0]).expect("a warning ends nothing");
        dev.exchange().warnings() >= 1
    }));
    let w = dev.library_warnings();
    assert_eq!(w.count, 1);
    assert_eq!(w.last, Some("HD_WARM_MOTORS"));
    for _ in 0..10 {
        tick(&mut dev, [0.0, 1.0, 0.0]).expect("goes on");
    }
    drop(dev);
    assert_eq!(report(&report_path)["frames_outside"], "0");
}

#[test]
fn an_hd_error_in_the_callback_ends_the_run_with_force_off() {
    let dir = scratch("fail");
    let Some((mut dev, report_path)) = started(&dir, &["FAIL_AT=30"]) else {
        return;
    };
    let mut err = None;
    assert!(eventually(|| match tick(&mut dev, [0.0, 1.0, 0.0]) {
        Ok(()) => false,
        Err(e) => {
            err = Some(e);
            true
        }
    }));
    // HD_COMM_ERROR: the device is gone.
    assert_eq!(err, Some(DeviceError::Disconnected));
    assert_eq!(
        dev.exchange().fatal().map(|e| (e.code, e.internal)),
        Some((0x0302, 5))
    );
    assert_eq!(
        dev.library().current_force(),
        Ok([0.0; 3]),
        "force output off"
    );
    drop(dev);
    let r = report(&report_path);
    assert_eq!(r["frames"], "30", "no frame after the error's: {r:?}");
    assert_eq!(r["frames_outside"], "0", "{r:?}");
    assert_eq!(r["force_on"], "0", "{r:?}");
}

#[test]
fn a_run_on_the_stand_in_touch_reports_its_warnings_and_stops_cleanly() {
    let dir = scratch("run");
    let report_path = dir.join("report.txt");
    let report_define = format!("REPORT=\"{}\"", report_path.display());
    let Some(lib) = build_fake(&dir, "libHD.so", &[&report_define, "WARN_AT=100"]) else {
        return;
    };
    let json = dir.join("run.json");
    let out = Command::new(tetradrill_tests::tetradrill_bin())
        .args([
            "run",
            "--device",
            "touch",
            "--duration",
            "0.5",
            "--no-rt",
            "--json",
        ])
        .arg(&json)
        .env(HD_LIBRARY_ENV, &lib)
        .output()
        .expect("run tetradrill");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("the JSON")).expect("JSON");
    assert_eq!(v["device"], "touch");
    assert_eq!(v["safety"]["library_warnings"], 1, "{v}");
    assert_eq!(v["safety"]["library_warning_last"], "HD_WARM_MOTORS");
    assert!(
        err.lines()
            .any(|l| l.contains("library warned 1 time (last: HD_WARM_MOTORS)")),
        "{err}"
    );
    let r = report(&report_path);
    assert_eq!(r["frames_outside"], "0", "{r:?}");
    assert_eq!(r["force_on"], "0", "{r:?}");
    assert!(r["frames"].parse::<u64>().expect("frames") >= 300, "{r:?}");
}
