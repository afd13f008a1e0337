//! The Touch loader (`tetradrill_device::os::hdapi`) without a Touch: the error paths when no library
//! exists or the override is not a library, and the real `dlopen` path through a small
//! stand-in HD library written here in C and compiled with the system C compiler at test time.
//!
//! The stand-in is not the vendor library: it exports the HDAPI entry point names the loader
//! resolves, with trivial behaviour written for these tests (a frame counter drives the
//! position and buttons, the force set is kept and read back through `HD_CURRENT_FORCE` while
//! force output is enabled, frame
//! misuse pushes an error on a small error stack; with `WITH_SCHEDULER`, a scheduler thread
//! that runs the stall guard's callback). Its numeric codes are the ones the loader declares;
//! the test checks the loader against them, not against hardware.

use std::path::{Path, PathBuf};
use std::process::Command;

use tetradrill_device::os::hdapi::{candidates, HdApi, HdLoadError, HD_LIBRARY_ENV};
use tetradrill_device::safety::SafetyConfig;
use tetradrill_device::touch::{HdLibrary, TouchDevice, HD_LIBRARY_NAMES};
use tetradrill_device::{DeviceError, ForceCommand, HapticDevice};
use tetradrill_tests::Scratch;

/// The stand-in library. `FAIL_INIT` makes `hdInitDevice` fail as with no device attached.
/// `WITH_SCHEDULER` adds a scheduler thread (started by `hdStartScheduler`, stopped and
/// joined by `hdStopScheduler`) that calls the callback given to `hdScheduleAsynchronous`
/// about every millisecond; frames and the error stack are then per thread, as the force is
/// shared under a lock.
const FAKE_HD_C: &str = r#"
#include <stddef.h>

typedef unsigned int HHD;
typedef unsigned int HDenum;
typedef struct { unsigned int errorCode; int internalErrorCode; HHD hHD; } HDErrorInfo;

#ifdef WITH_SCHEDULER
#include <pthread.h>
#include <time.h>
#define PER_THREAD __thread
static pthread_mutex_t force_lock = PTHREAD_MUTEX_INITIALIZER;
#define LOCK() pthread_mutex_lock(&force_lock)
#define UNLOCK() pthread_mutex_unlock(&force_lock)
#else
#define PER_THREAD
#define LOCK()
#define UNLOCK()
#endif

static int initialised = 0, force_on = 0, scheduler = 0, calibrated = 0;
static PER_THREAD int in_frame = 0;
static long frames = 0;
static double force[3];
static PER_THREAD HDErrorInfo errors[8];
static PER_THREAD int n_errors = 0;

#ifdef WITH_SCHEDULER
typedef unsigned int (*HDSchedulerCallback)(void *);
static HDSchedulerCallback callback = NULL;
static void *callback_data = NULL;
static int running = 0;
static pthread_t scheduler_thread;

static void *scheduler_loop(void *arg) {
    struct timespec ms = { 0, 1000000 };
    (void)arg;
    while (__atomic_load_n(&running, __ATOMIC_ACQUIRE)) {
        HDSchedulerCallback f = __atomic_load_n(&callback, __ATOMIC_ACQUIRE);
        if (f) f(callback_data);
        nanosleep(&ms, NULL);
    }
    return NULL;
}
unsigned long hdScheduleAsynchronous(HDSchedulerCallback f, void *data, unsigned short prio) {
    (void)prio;
    callback_data = data;
    __atomic_store_n(&callback, f, __ATOMIC_RELEASE);
    return 1;
}
void hdUnschedule(unsigned long h) { if (h == 1) __atomic_store_n(&callback, NULL, __ATOMIC_RELEASE); }
#endif

static void push(unsigned int code, int internal) {
    if (n_errors < 8) {
        errors[n_errors].errorCode = code;
        errors[n_errors].internalErrorCode = internal;
        errors[n_errors].hHD = 7;
        n_errors++;
    }
}

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
void hdDisableDevice(HHD h) { if (h == 7) initialised = 0; else push(0x0104, 0); }
void hdMakeCurrentDevice(HHD h) { if (h != 7 || !initialised) push(0x0104, 0); }
void hdStartScheduler(void) {
    scheduler = 1;
#ifdef WITH_SCHEDULER
    __atomic_store_n(&running, 1, __ATOMIC_RELEASE);
    pthread_create(&scheduler_thread, NULL, scheduler_loop, NULL);
#endif
}
void hdStopScheduler(void) {
#ifdef WITH_SCHEDULER
    if (scheduler) {
        __atomic_store_n(&running, 0, __ATOMIC_RELEASE);
        pthread_join(scheduler_thread, NULL);
    }
#endif
    scheduler = 0;
}
void hdBeginFrame(HHD h) {
    if (h != 7) { push(0x0104, 0); return; }
    if (in_frame) { push(0x0400, 0); return; }
    in_frame = 1;
    __atomic_add_fetch(&frames, 1, __ATOMIC_RELAXED);
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
        LOCK();
        for (i = 0; i < 3; i++) v[i] = force_on ? force[i] : 0.0;
        UNLOCK();
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
    if (p == 0x2700) { LOCK(); force[0] = v[0]; force[1] = v[1]; force[2] = v[2]; UNLOCK(); }
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

#[test]
fn stand_in_library_frames_position_buttons_and_force() {
    let dir = scratch("dev");
    let Some(lib) = build_fake(&dir, "libHD.so", &[]) else {
        return;
    };
    let p = lib.to_string_lossy().into_owned();
    let mut api = HdApi::load_from(&[p], true).expect("the stand-in loads");
    api.open_device(None).expect("the stand-in opens");
    assert_eq!(api.handle(), Some(7));

    // Frame misuse reaches the caller as the HD error code.
    assert_eq!(
        api.set_force([1.0, 0.0, 0.0]),
        Err(DeviceError::LibraryCall { code: 0x0102 })
    );
    assert_eq!(
        api.end_frame(),
        Err(DeviceError::LibraryCall { code: 0x0401 })
    );

    // Calibration: needs an update, the stand-in offers inkwell and encoder reset: the
    // inkwell style is chosen and the next check is OK.
    api.update_calibration().expect("calibrates");
    api.update_calibration().expect("already calibrated");

    // Open on "another thread": init only makes the device current.
    let mut dev = std::thread::spawn(move || {
        TouchDevice::new(api, None)
            .expect("made current")
            .with_safety(SafetyConfig {
                ramp_ticks: 1,
                ..SafetyConfig::for_max_force(3.3)
            })
    })
    .join()
    .expect("no panic");

    let mut last_tick = 0;
    let mut docked_seen = false;
    for _ in 0..12 {
        let s = dev.read().expect("read");
        assert!(s.tick > last_tick);
        last_tick = s.tick;
        // The position is a multiple of the frame count: x = n mm, y = 2n mm, z = -n/2 mm.
        let n = s.position[0] * 1e3;
        assert!(n >= 1.0 && (n - n.round()).abs() < 1e-9, "{:?}", s.position);
        assert!((s.position[1] - 2.0 * s.position[0]).abs() < 1e-12);
        assert!((s.position[2] + 0.5 * s.position[0]).abs() < 1e-12);
        assert!(s.buttons < 4);
        assert_eq!(s.rotation, [1.0, 0.0, 0.0, 0.0]);
        docked_seen |= s.docked;
        dev.write(&ForceCommand::force([0.0, 10.0, -1.0]))
            .expect("write");
    }
    assert!(docked_seen, "the stand-in docks every tenth frame");
    // The force reached the library clamped to 3.3 N, direction kept.
    let f = dev.library().current_force().expect("read back");
    let norm = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
    assert!((norm - 3.3).abs() < 1e-9, "{f:?}");
    assert!((f[1] / f[2] + 10.0).abs() < 1e-9, "{f:?}");

    // NaN is refused and zero force is sent.
    assert_eq!(
        dev.write(&ForceCommand::force([f64::NAN, 0.0, 0.0])),
        Err(DeviceError::NonFiniteCommand)
    );
    assert_eq!(dev.library().current_force(), Ok([0.0; 3]));
    drop(dev);
}

#[test]
fn the_scheduler_runs_the_stall_guard_which_zeroes_a_stalled_servos_force() {
    let dir = scratch("guard");
    let Some(lib) = build_fake(&dir, "libHD.so", &["WITH_SCHEDULER"]) else {
        return;
    };
    let p = lib.to_string_lossy().into_owned();
    let mut api = HdApi::load_from(&[p], true).expect("the stand-in loads");
    api.open_device(None).expect("the stand-in opens");
    let mut dev = TouchDevice::new(api, None)
        .expect("made current")
        .with_safety(SafetyConfig {
            ramp_ticks: 1,
            ..SafetyConfig::for_max_force(3.3)
        });
    assert!(
        dev.stall_guarded(),
        "the stand-in has hdScheduleAsynchronous"
    );
    dev.read().expect("read");
    dev.write(&ForceCommand::force([0.0, 0.0, 1.0]))
        .expect("write");
    let trips_before = dev.heartbeat().trips();
    // The servo stops here. The stand-in's scheduler runs the guard about every millisecond;
    // once the heartbeat is 2 ms old the guard sets zero. The loop only keeps a broken guard
    // from hanging the test; nothing is asserted about how long it took.
    let mut zeroed = false;
    for _ in 0..10_000 {
        if dev.heartbeat().trips() > trips_before && dev.library().current_force() == Ok([0.0; 3]) {
            zeroed = true;
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    assert!(zeroed, "the guard never zeroed the stalled servo's force");
    // The guard's frames left no HD error behind: the servo goes on.
    dev.read().expect("read after the stall");
    // Dropping stops the scheduler, unschedules the guard and unloads the library.
    drop(dev);
}
