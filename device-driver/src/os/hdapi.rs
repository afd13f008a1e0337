//! The Geomagic / 3D Systems Touch through the vendor's HD library (OpenHaptics HDAPI),
//! opened at run time with `libloading`. Nothing is linked at build time and no vendor
//! header is used or committed: the few HDAPI types and codes this file needs are written out
//! below, each with where its value was checked.
//!
//! [`HdApi`] implements [`HdLibrary`], so the device itself is this crate's
//! [`TouchDevice`](crate::touch::TouchDevice) with its `ForceSafety` filter.
//!
//! `unsafe` is allowed in this file (one of the OS transports of [`crate::os`]): loading a
//! library runs its initialisers, and every HDAPI entry point is a foreign call. Each block is
//! one call with its `// SAFETY:` reason.
//!
//! # Threads
//! HDAPI's own pattern is `hdInitDevice` on the application thread and every frame inside a
//! callback of its scheduler. [`HdApi::open_device`] runs `hdInitDevice` and
//! `hdStartScheduler` where it is called (the command line does it on the main thread, so a
//! failure becomes one line and exit status 2); the [`HdApi`] is `Send` and moves into the
//! servo thread's device factory, where [`HdLibrary::init`] makes the device current and
//! [`HdLibrary::schedule`] schedules `frame_callback` with `hdScheduleAsynchronous` at the
//! highest priority. The callback runs [`callback_frame`]: the frame's reads and the force in
//! one `hdBeginFrame` / `hdEndFrame` pair, in the scheduler's thread. The servo thread makes
//! no HD call on its ticks.
//!
//! # Untested on hardware
//! Nothing here has run against a real Touch or a real `libHD.so`; the tests drive a small C
//! stand-in compiled at test time, whose scheduler is a thread calling the callback each
//! millisecond. In particular:
//! - The inkwell switch polarity (0 = stylus docked) is taken from public code that reads it
//!   (H3DAPI's `PhantomHapticsDevice.cpp`: `in_inkwell = !inkwell_switch`), not measured.
//! - That force output needs the scheduler running is from OpenHaptics' programmer's guide,
//!   chapter 5 (read in a public translation), not measured.
//! - Which calibration style a Touch reports, and the error codes a missing device produces.
//! - Which force warnings a Touch raises in practice (the classification is OpenHaptics'
//!   `hduIsForceError`, [`is_force_warning`](crate::touch::is_force_warning)).
#![allow(unsafe_code)]

use std::ffi::{c_char, c_int, c_ulong, c_void, CStr, CString, OsStr};
use std::fmt;
use std::sync::Arc;

use libloading::Library;

use crate::device::{DeviceError, DeviceKind};
use crate::touch::{
    callback_frame, CallbackCode, Exchange, HdError, HdFrame, HdLibrary, HD_LIBRARY_NAMES,
};

// ---------------------------------------------------------------------------------------------
// HDAPI types and codes.
//
// Values checked against `hdDefines.h` as published in public repositories (OpenHaptics 3.0
// and 3.3 headers, e.g. github.com/hhmai/PhantomAPI `include/HD/hdDefines.h`), and cross-checked
// against an independent MIT-licensed HDAPI wrapper (Kirurobo's "ManagedPhantom" `HdAPI.cs`, as
// found in github.com/AssiaBoukezzi/LRAhaptic, whose enums carry the same numbers). One public
// stub header with different error numbers was seen and disagrees with both; it was ignored. Function signatures checked against `hd.h` as quoted
// in public code (`HDAPI HHD HDAPIENTRY hdInitDevice(HDstring pConfigName)`, ...). On Linux
// `HDAPIENTRY` is empty: the plain C calling convention. Nothing was copied; only the numbers.
// ---------------------------------------------------------------------------------------------

/// `HHD`: `typedef unsigned int HHD` (hdDefines.h).
pub type Hhd = u32;
/// `HDenum` / `HDerror`: `typedef unsigned int` (hdDefines.h).
pub type HdEnum = u32;

/// `HDErrorInfo` (hdDefines.h): `{ HDerror errorCode; int internalErrorCode; HHD hHD; }`,
/// returned by value from `hdGetError()`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HdErrorInfo {
    /// The `HD_*` error code; `HD_SUCCESS` (0) when the error stack is empty.
    pub error_code: HdEnum,
    /// The device's own code, for the vendor's support.
    pub internal_error_code: c_int,
    /// The device current when the error happened.
    pub hhd: Hhd,
}

/// `HD_INVALID_HANDLE 0xFFFFFFFF` (hdDefines.h, "Null device handle").
pub const HD_INVALID_HANDLE: Hhd = 0xFFFF_FFFF;
// `HD_DEFAULT_DEVICE` is `NULL` (hdDefines.h): `open_device(None)` passes a null name.

/// `HD_SUCCESS 0x0000` (hdDefines.h, error codes).
pub const HD_SUCCESS: HdEnum = 0x0000;
pub use crate::touch::frame::HD_INVALID_OPERATION;
/// `HD_DEVICE_FAULT 0x0300` (hdDefines.h, device errors).
pub const HD_DEVICE_FAULT: HdEnum = 0x0300;
/// `HD_COMM_ERROR 0x0302` (hdDefines.h, device errors).
pub const HD_COMM_ERROR: HdEnum = 0x0302;

/// `HD_CURRENT_BUTTONS 0x2000` (hdDefines.h, get parameters, raw values).
pub const HD_CURRENT_BUTTONS: HdEnum = 0x2000;
/// `HD_CURRENT_INKWELL_SWITCH 0x2002` (hdDefines.h, get parameters, raw values).
pub const HD_CURRENT_INKWELL_SWITCH: HdEnum = 0x2002;
/// `HD_CURRENT_POSITION 0x2050` (hdDefines.h, Cartesian values): 3 doubles, mm.
pub const HD_CURRENT_POSITION: HdEnum = 0x2050;
/// `HD_CURRENT_TRANSFORM 0x2052` (hdDefines.h, Cartesian values): 16 doubles, column-major.
pub const HD_CURRENT_TRANSFORM: HdEnum = 0x2052;
/// `HD_CALIBRATION_STYLE 0x2555` (hdDefines.h, device hardware properties).
pub const HD_CALIBRATION_STYLE: HdEnum = 0x2555;
/// `HD_CURRENT_FORCE 0x2700` (hdDefines.h, get and set parameters): 3 doubles, N.
pub const HD_CURRENT_FORCE: HdEnum = 0x2700;
/// `HD_FORCE_OUTPUT 0x4000` (hdDefines.h, enable/disable capabilities).
pub const HD_FORCE_OUTPUT: HdEnum = 0x4000;
pub use crate::touch::frame::{
    HD_CALIBRATION_AUTO, HD_CALIBRATION_ENCODER_RESET, HD_CALIBRATION_INKWELL,
    HD_CALIBRATION_NEEDS_MANUAL_INPUT, HD_CALIBRATION_NEEDS_UPDATE, HD_CALIBRATION_OK,
};

/// `HD_MAX_SCHEDULER_PRIORITY USHRT_MAX` (hdDefines.h, scheduler priority ranges).
pub const HD_MAX_SCHEDULER_PRIORITY: u16 = u16::MAX;
/// `HD_CALLBACK_DONE 0` (hdDefines.h): the callback is unscheduled.
pub const HD_CALLBACK_DONE: u32 = 0;
/// `HD_CALLBACK_CONTINUE 1` (hdDefines.h): the callback runs again next scheduler tick.
pub const HD_CALLBACK_CONTINUE: u32 = 1;
/// `HDSchedulerHandle`: `typedef unsigned long` (hdDefines.h).
pub type HdSchedulerHandle = c_ulong;

/// Environment variable naming the HD library to load instead of [`HD_LIBRARY_NAMES`].
pub const HD_LIBRARY_ENV: &str = "TETRADRILL_HD_LIBRARY";

/// Most errors drained from HDAPI's error stack after one call (bounded work).
const MAX_ERRORS_DRAINED: usize = 16;

type FnInit = unsafe extern "C" fn(*const c_char) -> Hhd;
type FnHandle = unsafe extern "C" fn(Hhd);
type FnVoid = unsafe extern "C" fn();
type FnGetError = unsafe extern "C" fn() -> HdErrorInfo;
type FnErrorString = unsafe extern "C" fn(HdEnum) -> *const c_char;
type FnEnum = unsafe extern "C" fn(HdEnum);
type FnGetDoublev = unsafe extern "C" fn(HdEnum, *mut f64);
type FnGetIntegerv = unsafe extern "C" fn(HdEnum, *mut c_int);
type FnGetBooleanv = unsafe extern "C" fn(HdEnum, *mut u8);
type FnSetDoublev = unsafe extern "C" fn(HdEnum, *const f64);
type FnCheckCalibration = unsafe extern "C" fn() -> HdEnum;
/// `HDSchedulerCallback`: `HDCallbackCode (*)(void *pUserData)` (hdDefines.h).
type HdCallback = unsafe extern "C" fn(*mut c_void) -> u32;
type FnScheduleAsynchronous =
    unsafe extern "C" fn(HdCallback, *mut c_void, u16) -> HdSchedulerHandle;
type FnUnschedule = unsafe extern "C" fn(HdSchedulerHandle);

/// The entry points, resolved once. Plain function pointers: `Copy` and `Send`.
#[derive(Clone, Copy, Debug)]
struct Entry {
    init_device: FnInit,
    disable_device: FnHandle,
    make_current_device: FnHandle,
    begin_frame: FnHandle,
    end_frame: FnHandle,
    get_error: FnGetError,
    get_error_string: FnErrorString,
    enable: FnEnum,
    disable: FnEnum,
    get_doublev: FnGetDoublev,
    get_integerv: FnGetIntegerv,
    get_booleanv: FnGetBooleanv,
    set_doublev: FnSetDoublev,
    check_calibration: FnCheckCalibration,
    update_calibration: FnEnum,
    start_scheduler: FnVoid,
    stop_scheduler: FnVoid,
    schedule_asynchronous: FnScheduleAsynchronous,
    unschedule: FnUnschedule,
}

/// What the frame callback needs, boxed so its address stays put while the vendor scheduler
/// holds it.
struct CallbackData {
    exchange: Arc<Exchange>,
    entry: Entry,
    handle: Hhd,
}

/// The frame calls over the resolved entry points, for [`callback_frame`] in the scheduler's
/// thread. Each call is one foreign call; errors stay on HDAPI's stack until
/// [`HdFrame::next_error`] pops them, as OpenHaptics' own callbacks do.
struct EntryFrame<'a> {
    entry: &'a Entry,
    handle: Hhd,
}

impl EntryFrame<'_> {
    fn doubles<const N: usize>(&mut self, pname: HdEnum) -> [f64; N] {
        let mut v = [0.0f64; N];
        // SAFETY: `v` holds N doubles, the count HDAPI writes for `pname` (3 for positions,
        // 16 for the transform).
        unsafe { (self.entry.get_doublev)(pname, v.as_mut_ptr()) };
        v
    }

    fn integer(&mut self, pname: HdEnum) -> i32 {
        // Room for more than the one value asked for, in case a parameter has more.
        let mut v = [0 as c_int; 4];
        // SAFETY: `v` is writable for 4 ints; the parameters asked for here have one.
        unsafe { (self.entry.get_integerv)(pname, v.as_mut_ptr()) };
        v[0]
    }
}

impl HdFrame for EntryFrame<'_> {
    fn begin_frame(&mut self) {
        // SAFETY: `handle` is the initialised device (hdInitDevice's); this runs in the
        // scheduler's callback, HDAPI's documented place for frames.
        unsafe { (self.entry.begin_frame)(self.handle) };
    }
    fn end_frame(&mut self) {
        // SAFETY: as `begin_frame`; the frame this closes was begun by the same callback.
        unsafe { (self.entry.end_frame)(self.handle) };
    }
    fn position_mm(&mut self) -> [f64; 3] {
        self.doubles::<3>(HD_CURRENT_POSITION)
    }
    fn transform(&mut self) -> [f64; 16] {
        self.doubles::<16>(HD_CURRENT_TRANSFORM)
    }
    fn buttons(&mut self) -> u32 {
        self.integer(HD_CURRENT_BUTTONS) as u32
    }
    /// `hdGetBooleanv(HD_CURRENT_INKWELL_SWITCH)`: the switch reads 0 while the stylus sits
    /// in the inkwell (as public code that reads it interprets it; untested on hardware).
    fn inkwell(&mut self) -> bool {
        let mut v = [0u8; 4];
        // SAFETY: `v` is writable for 4 HDbooleans (unsigned char); the switch has one.
        unsafe { (self.entry.get_booleanv)(HD_CURRENT_INKWELL_SWITCH, v.as_mut_ptr()) };
        v[0] == 0
    }
    fn set_force(&mut self, force: [f64; 3]) {
        // The servo's safety filter sends finite forces only; a non-finite one is zeroed here
        // rather than given to the motors.
        let force = if force.iter().all(|f| f.is_finite()) {
            force
        } else {
            [0.0; 3]
        };
        // SAFETY: `force` holds the 3 doubles HD_CURRENT_FORCE takes; read during the call.
        unsafe { (self.entry.set_doublev)(HD_CURRENT_FORCE, force.as_ptr()) };
    }
    fn enable_force(&mut self, on: bool) {
        let f = if on {
            self.entry.enable
        } else {
            self.entry.disable
        };
        // SAFETY: HD_FORCE_OUTPUT is a capability hdEnable / hdDisable take.
        unsafe { f(HD_FORCE_OUTPUT) };
    }
    fn calibration_styles(&mut self) -> u32 {
        self.integer(HD_CALIBRATION_STYLE) as u32
    }
    fn check_calibration(&mut self) -> u32 {
        // SAFETY: no arguments; a device is current and a frame is open.
        unsafe { (self.entry.check_calibration)() }
    }
    fn update_calibration(&mut self, style: u32) {
        // SAFETY: `style` is one of the calibration styles the device reported.
        unsafe { (self.entry.update_calibration)(style) };
    }
    fn next_error(&mut self) -> Option<HdError> {
        // SAFETY: no arguments; returns the struct by value (C ABI, `#[repr(C)]` layout).
        let e = unsafe { (self.entry.get_error)() };
        (e.error_code != HD_SUCCESS).then_some(HdError {
            code: e.error_code,
            internal: e.internal_error_code,
        })
    }
}

/// The frame callback, run by the vendor scheduler at its own rate in its own thread:
/// [`callback_frame`] over the entry points. Never blocks, allocates or panics.
unsafe extern "C" fn frame_callback(user: *mut c_void) -> u32 {
    // SAFETY: `user` is the `CallbackData` box `HdApi::schedule` scheduled; it is freed only
    // after `hdStopScheduler` and `hdUnschedule` (`HdApi::drop`), so it is alive here, and
    // it is only read.
    let Some(d) = (unsafe { (user as *const CallbackData).as_ref() }) else {
        return HD_CALLBACK_DONE;
    };
    let mut frame = EntryFrame {
        entry: &d.entry,
        handle: d.handle,
    };
    match callback_frame(&mut frame, &d.exchange, d.exchange.now_ns()) {
        CallbackCode::Continue => HD_CALLBACK_CONTINUE,
        CallbackCode::Done => HD_CALLBACK_DONE,
    }
}

/// Why the HD library could not be used. Each `Display` is one line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum HdLoadError {
    /// None of the names could be opened (no vendor driver installed).
    NotFound {
        /// Names or paths tried, in order.
        tried: Vec<String>,
    },
    /// The file named by the override exists but could not be loaded as a library.
    Unloadable {
        /// The path given.
        path: String,
        /// The loader's reason.
        reason: String,
    },
    /// The library loaded but lacks an HDAPI entry point.
    MissingSymbol {
        /// The library loaded.
        path: String,
        /// The entry point missing.
        symbol: &'static str,
    },
    /// `hdInitDevice` failed (typically: no device attached, or its daemon not running).
    Init {
        /// The `HD_*` code.
        code: HdEnum,
        /// The device's internal code.
        internal: i32,
        /// `hdGetErrorString(code)`.
        text: String,
    },
}

impl fmt::Display for HdLoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HdLoadError::NotFound { tried } => write!(
                f,
                "vendor HD library (OpenHaptics / Touch device drivers) not found: tried {}; \
                 set {HD_LIBRARY_ENV} to its path",
                tried.join(", ")
            ),
            HdLoadError::Unloadable { path, reason } => {
                write!(f, "{HD_LIBRARY_ENV}={path} could not be loaded: {reason}")
            }
            HdLoadError::MissingSymbol { path, symbol } => {
                write!(f, "{path} is not an HD library: it has no {symbol}")
            }
            HdLoadError::Init {
                code,
                internal,
                text,
            } => write!(
                f,
                "hdInitDevice failed: {} ({code:#06x}, internal {internal}){}",
                error_name(*code),
                if text.is_empty() {
                    String::new()
                } else {
                    format!(": {text}")
                }
            ),
        }
    }
}

impl std::error::Error for HdLoadError {}

impl HdLoadError {
    /// The device crate's error for this failure.
    pub fn device_error(&self) -> DeviceError {
        match self {
            HdLoadError::Init { code, .. } => DeviceError::LibraryCall { code: *code },
            _ => DeviceError::LibraryNotFound,
        }
    }
}

pub use crate::touch::error_name;

/// The names to try: the override alone when `override_path` is set and not empty, else
/// [`HD_LIBRARY_NAMES`] (found through the dynamic loader's search path).
pub fn candidates(override_path: Option<&OsStr>) -> Vec<String> {
    match override_path {
        Some(p) if !p.is_empty() => vec![p.to_string_lossy().into_owned()],
        _ => HD_LIBRARY_NAMES.iter().map(|s| s.to_string()).collect(),
    }
}

/// The vendor HD library, loaded, with its entry points resolved and at most one device open.
pub struct HdApi {
    // Field order matters for nothing here: `Drop` disables the device before the library
    // is unloaded (fields drop after `drop` runs).
    entry: Entry,
    path: String,
    handle: Option<Hhd>,
    scheduler: bool,
    callback: Option<(HdSchedulerHandle, Box<CallbackData>)>,
    _lib: Library,
}

impl fmt::Debug for HdApi {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("HdApi")
            .field("path", &self.path)
            .field("handle", &self.handle)
            .field("scheduler", &self.scheduler)
            .finish_non_exhaustive()
    }
}

impl HdApi {
    /// Loads the library named by `TETRADRILL_HD_LIBRARY`, or the first of
    /// [`HD_LIBRARY_NAMES`] that loads. No device is opened.
    pub fn load() -> Result<HdApi, HdLoadError> {
        let env = std::env::var_os(HD_LIBRARY_ENV);
        let overridden = env.as_deref().is_some_and(|p| !p.is_empty());
        HdApi::load_from(&candidates(env.as_deref()), overridden)
    }

    /// Loads the first of `names` that opens. With `explicit` (a path the user gave), a
    /// failure to load is reported with the loader's reason instead of "not found".
    pub fn load_from(names: &[String], explicit: bool) -> Result<HdApi, HdLoadError> {
        let mut last_reason = String::new();
        for name in names {
            // SAFETY: opening a shared library runs its initialisers. The names are the
            // vendor's HD library (or the user's explicit choice); its initialisers are what
            // any OpenHaptics application runs.
            match unsafe { Library::new(name) } {
                Ok(lib) => return HdApi::resolve(lib, name.clone()),
                Err(e) => last_reason = e.to_string(),
            }
        }
        match names {
            [one] if explicit => Err(HdLoadError::Unloadable {
                path: one.clone(),
                reason: last_reason,
            }),
            _ => Err(HdLoadError::NotFound {
                tried: names.to_vec(),
            }),
        }
    }

    fn resolve(lib: Library, path: String) -> Result<HdApi, HdLoadError> {
        macro_rules! sym {
            ($name:literal) => {{
                // SAFETY: the symbol is an HDAPI entry point; its type is the signature of
                // `hd.h` (see the types above). The pointer is used only while `lib` is
                // loaded: `HdApi` owns `lib`.
                match unsafe { lib.get(concat!($name, "\0").as_bytes()) } {
                    Ok(s) => *s,
                    Err(_) => {
                        return Err(HdLoadError::MissingSymbol {
                            path,
                            symbol: $name,
                        })
                    }
                }
            }};
        }
        let entry = Entry {
            init_device: sym!("hdInitDevice"),
            disable_device: sym!("hdDisableDevice"),
            make_current_device: sym!("hdMakeCurrentDevice"),
            begin_frame: sym!("hdBeginFrame"),
            end_frame: sym!("hdEndFrame"),
            get_error: sym!("hdGetError"),
            get_error_string: sym!("hdGetErrorString"),
            enable: sym!("hdEnable"),
            disable: sym!("hdDisable"),
            get_doublev: sym!("hdGetDoublev"),
            get_integerv: sym!("hdGetIntegerv"),
            get_booleanv: sym!("hdGetBooleanv"),
            set_doublev: sym!("hdSetDoublev"),
            check_calibration: sym!("hdCheckCalibration"),
            update_calibration: sym!("hdUpdateCalibration"),
            start_scheduler: sym!("hdStartScheduler"),
            stop_scheduler: sym!("hdStopScheduler"),
            schedule_asynchronous: sym!("hdScheduleAsynchronous"),
            unschedule: sym!("hdUnschedule"),
        };
        Ok(HdApi {
            entry,
            path,
            handle: None,
            scheduler: false,
            callback: None,
            _lib: lib,
        })
    }

    /// The name or path the library was loaded from.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// The device handle once opened.
    pub fn handle(&self) -> Option<Hhd> {
        self.handle
    }

    /// `hdInitDevice(name)` (`None`: `HD_DEFAULT_DEVICE`, a null name), then
    /// `hdStartScheduler`. On failure, what `hdGetError` and `hdGetErrorString` said.
    /// Opening an already opened `HdApi` does nothing.
    pub fn open_device(&mut self, name: Option<&str>) -> Result<(), HdLoadError> {
        if self.handle.is_some() {
            return Ok(());
        }
        let cname = name.map(|n| CString::new(n).unwrap_or_default());
        let ptr = cname.as_ref().map_or(std::ptr::null(), |c| c.as_ptr());
        self.drain_errors();
        // SAFETY: `ptr` is null (HD_DEFAULT_DEVICE) or a NUL-terminated string alive for the
        // call.
        let h = unsafe { (self.entry.init_device)(ptr) };
        let err = self.drain_errors();
        if h == HD_INVALID_HANDLE || err.error_code != HD_SUCCESS {
            let code = if err.error_code == HD_SUCCESS {
                HD_DEVICE_FAULT
            } else {
                err.error_code
            };
            return Err(HdLoadError::Init {
                code,
                internal: err.internal_error_code,
                text: self.error_string(code),
            });
        }
        self.handle = Some(h);
        // SAFETY: no arguments; a device is initialised, as HDAPI requires.
        unsafe { (self.entry.start_scheduler)() };
        let err = self.drain_errors();
        if err.error_code != HD_SUCCESS {
            return Err(HdLoadError::Init {
                code: err.error_code,
                internal: err.internal_error_code,
                text: format!("hdStartScheduler: {}", self.error_string(err.error_code)),
            });
        }
        self.scheduler = true;
        Ok(())
    }

    /// `hdGetDoublev(HD_CURRENT_FORCE)`: the force set in the current frame (N), for checks.
    pub fn current_force(&self) -> Result<[f64; 3], DeviceError> {
        self.get_doubles::<3>(HD_CURRENT_FORCE)
    }

    /// `hdGetErrorString(code)`, empty when the library returns null.
    fn error_string(&self, code: HdEnum) -> String {
        // SAFETY: plain value argument; HDAPI returns a static string or null.
        let p = unsafe { (self.entry.get_error_string)(code) };
        if p.is_null() {
            return String::new();
        }
        // SAFETY: `p` is non-null and points to a NUL-terminated static string of the library,
        // which stays loaded while `self` lives; it is copied at once.
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }

    /// Pops HDAPI's error stack (most recent first, at most [`MAX_ERRORS_DRAINED`]) and
    /// returns the most recent error, or a `HD_SUCCESS` record.
    fn drain_errors(&self) -> HdErrorInfo {
        let mut first = HdErrorInfo::default();
        for _ in 0..MAX_ERRORS_DRAINED {
            // SAFETY: no arguments; returns the struct by value (C ABI, `#[repr(C)]` layout).
            let e = unsafe { (self.entry.get_error)() };
            if e.error_code == HD_SUCCESS {
                break;
            }
            if first.error_code == HD_SUCCESS {
                first = e;
            }
        }
        first
    }

    /// `Ok` when the last calls raised no HD error; else the error as a [`DeviceError`].
    fn check(&self) -> Result<(), DeviceError> {
        match self.drain_errors().error_code {
            HD_SUCCESS => Ok(()),
            HD_COMM_ERROR | HD_DEVICE_FAULT => Err(DeviceError::Disconnected),
            code => Err(DeviceError::LibraryCall { code }),
        }
    }

    fn opened(&self) -> Result<Hhd, DeviceError> {
        self.handle.ok_or(DeviceError::NotFound(DeviceKind::Touch))
    }

    fn get_doubles<const N: usize>(&self, pname: HdEnum) -> Result<[f64; N], DeviceError> {
        self.opened()?;
        let mut v = [0.0f64; N];
        // SAFETY: `v` holds N doubles, the count HDAPI writes for `pname` (3 for positions
        // and forces, 16 for the transform).
        unsafe { (self.entry.get_doublev)(pname, v.as_mut_ptr()) };
        self.check()?;
        Ok(v)
    }
}

impl HdLibrary for HdApi {
    fn init(&mut self, name: Option<&str>) -> Result<(), DeviceError> {
        if let Some(h) = self.handle {
            // Opened on another thread: make it current on this one.
            // SAFETY: `h` is the handle hdInitDevice returned and the device is not disabled.
            unsafe { (self.entry.make_current_device)(h) };
            return self.check();
        }
        self.open_device(name).map_err(|e| e.device_error())
    }

    /// Schedules `frame_callback` with `hdScheduleAsynchronous` at
    /// [`HD_MAX_SCHEDULER_PRIORITY`]. A second call is refused (`HD_INVALID_OPERATION`): one
    /// device, one callback.
    fn schedule(&mut self, exchange: Arc<Exchange>) -> Result<(), DeviceError> {
        let h = self.opened()?;
        if self.callback.is_some() {
            return Err(DeviceError::LibraryCall {
                code: HD_INVALID_OPERATION,
            });
        }
        let data = Box::new(CallbackData {
            exchange,
            entry: self.entry,
            handle: h,
        });
        let user = &*data as *const CallbackData as *mut c_void;
        // SAFETY: the callback has the `HDSchedulerCallback` signature; `user` points into the
        // box kept in `self.callback` until after the callback is unscheduled (`Drop`).
        let id = unsafe {
            (self.entry.schedule_asynchronous)(frame_callback, user, HD_MAX_SCHEDULER_PRIORITY)
        };
        self.callback = Some((id, data));
        self.check()
    }
}

impl Drop for HdApi {
    /// Stops the scheduler (the callback has had its last frame, with zero force and force
    /// output off, when the device was dropped first), unschedules the callback, and only
    /// then frees its data and disables the device.
    fn drop(&mut self) {
        let Some(h) = self.handle.take() else {
            return;
        };
        if self.scheduler {
            // SAFETY: no arguments; the scheduler was started by `open_device`.
            unsafe { (self.entry.stop_scheduler)() };
        }
        if let Some((id, data)) = self.callback.take() {
            // SAFETY: `id` is the handle hdScheduleAsynchronous returned; the scheduler is
            // stopped, so the callback is not running; its data is freed after this call.
            unsafe { (self.entry.unschedule)(id) };
            if !data.exchange.stopped() {
                // The callback never had its last frame (its scheduler stalled): force output
                // off from here, the scheduler being stopped.
                // SAFETY: `h` is initialised; HD_FORCE_OUTPUT is a capability.
                unsafe { (self.entry.disable)(HD_FORCE_OUTPUT) };
            }
        }
        // SAFETY: `h` is initialised and is not used after this call.
        unsafe { (self.entry.disable_device)(h) };
        self.drain_errors();
    }
}

/// What `tetradrill devices` says about the HD library: where it was found, or why not.
pub fn probe() -> Result<String, HdLoadError> {
    HdApi::load().map(|api| api.path().to_string())
}
