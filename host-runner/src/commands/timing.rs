//! `tetradrill timing`: the servo thread's wake-up latency, measured as cyclictest measures it
//! (absolute-deadline sleeps at 1 kHz, latency = wake-up time - deadline), and the compute time
//! of the servo tick run at each wake-up.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use serde::Serialize;

use crate::error::CliError;
use crate::platform;
use crate::rt::{Periodic, RtConfig};
use crate::stats::{histogram_us, summarise_ns, Summary};
use crate::workload::{with_work, Work};

/// Arguments of `timing`.
#[derive(Debug, clap::Args)]
pub struct TimingArgs {
    /// Seconds to measure.
    #[arg(
        long,
        default_value_t = 10.0,
        allow_negative_numbers = true,
        value_parser = crate::scenario::positive_seconds
    )]
    pub duration: f64,
    /// Write the results as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Servo period in microseconds.
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u64).range(50..=100_000))]
    pub period_us: u64,
    /// Sleep until this many microseconds before each deadline and spin the rest.
    #[arg(long, default_value_t = 0)]
    pub spin_us: u64,
    /// Do not ask for SCHED_FIFO, pinning or memory locking.
    #[arg(long)]
    pub no_rt: bool,
    /// The work each tick runs after waking up.
    #[arg(long, value_enum, default_value_t = Work::Servo)]
    pub work: Work,
}

/// The JSON of `timing`.
#[derive(Debug, Serialize)]
pub struct TimingReport {
    /// Ticks measured.
    pub ticks: usize,
    /// Deadlines missed by more than a period.
    pub overruns: u64,
    /// Wake-up latency in microseconds.
    pub wake_us: Summary,
    /// Servo tick compute time in microseconds.
    pub tick_us: Summary,
    /// Wake-up latency histogram: counts per 1 us bucket, the last one is the overflow bucket.
    pub wake_histogram_us: Vec<u64>,
    /// SCHED_FIFO, pinning and memory locking as achieved.
    pub realtime: RealtimeReport,
    /// The work each tick ran.
    pub workload: String,
}

/// Which real-time settings were in force.
#[derive(Debug, Serialize)]
pub struct RealtimeReport {
    /// SCHED_FIFO in force.
    pub fifo: bool,
    /// Core pinned to.
    pub pinned: Option<usize>,
    /// Memory locked.
    pub memory_locked: bool,
}

/// Runs `timing`.
pub fn run(args: &TimingArgs) -> Result<(), CliError> {
    let ticks = (args.duration * 1e6 / args.period_us as f64).ceil() as usize;
    let name = args.work.describe().to_string();
    errln!(
        "tetradrill: timing {ticks} ticks at {} us; tick work: {name}",
        args.period_us
    );
    let cfg = if args.no_rt {
        RtConfig {
            fifo_priority: None,
            core: None,
            lock_memory: false,
        }
    } else {
        RtConfig::default()
    };
    let (period_ns, spin_ns) = (args.period_us * 1000, args.spin_us * 1000);
    let progress = Arc::new(AtomicUsize::new(0));
    let seen = Arc::clone(&progress);
    let work = args.work;
    let handle = std::thread::Builder::new()
        .name(crate::tasks::SERVO.name.into())
        .spawn(move || {
            with_work(work, |step| {
                let status = cfg.apply();
                let m = measure(ticks, period_ns, spin_ns, step, &seen);
                (status, m)
            })
        })
        .map_err(|e| CliError::failure(format!("cannot start the servo thread: {e}")))?;
    let mut last = 0;
    while !handle.is_finished() {
        std::thread::sleep(std::time::Duration::from_millis(250));
        let done = progress.load(Ordering::Relaxed);
        if done * args.period_us as usize / 1_000_000 != last * args.period_us as usize / 1_000_000
        {
            errln!(
                "  {:.0}/{:.0} s",
                done as f64 * args.period_us as f64 / 1e6,
                args.duration
            );
        }
        last = done;
    }
    let (status, (wake, tick, overruns)) = handle
        .join()
        .map_err(|_| CliError::failure("the servo thread panicked"))??;
    for w in &status.warnings {
        errln!("tetradrill: warning: {w}");
    }
    let rep = report(&wake, &tick, overruns, &status, name);
    print_summary(&rep);
    if let Some(path) = &args.json {
        crate::report::write_json(path, &rep)?;
    }
    Ok(())
}

fn print_summary(r: &TimingReport) {
    let w = &r.wake_us;
    let t = &r.tick_us;
    outln!("ticks {}  overruns {}", r.ticks, r.overruns);
    outln!(
        "wake-up latency us: min {:.1}  p50 {:.1}  p99 {:.1}  p99.9 {:.1}  max {:.1}",
        w.min,
        w.p50,
        w.p99,
        w.p999,
        w.max
    );
    outln!(
        "tick compute us:    mean {:.1}  p99 {:.1}  max {:.1}",
        t.mean,
        t.p99,
        t.max
    );
    outln!(
        "real-time: SCHED_FIFO {}  pinned {}  memory locked {}",
        r.realtime.fifo,
        r.realtime
            .pinned
            .map_or("no".to_string(), |c| format!("core {c}")),
        r.realtime.memory_locked
    );
}

/// Measures `ticks` wake-ups at `period_ns` on the calling thread, running `step` (if any)
/// after each wake-up. Buffers are allocated before the loop; the loop itself neither
/// allocates nor locks.
pub fn measure(
    ticks: usize,
    period_ns: u64,
    spin_ns: u64,
    step: &mut dyn FnMut(u64),
    progress: &AtomicUsize,
) -> (Vec<u64>, Vec<u64>, u64) {
    let mut wake = vec![0u64; ticks];
    let mut tick = vec![0u64; ticks];
    let mut timer = Periodic::new(period_ns, spin_ns);
    for i in 0..ticks {
        let w = timer.wait();
        wake[i] = w.latency_ns;
        let t0 = platform::now_ns();
        step(i as u64);
        tick[i] = platform::now_ns() - t0;
        progress.store(i + 1, Ordering::Relaxed);
    }
    (wake, tick, timer.overruns)
}

/// Turns measured buffers into the report.
pub fn report(
    wake: &[u64],
    tick: &[u64],
    overruns: u64,
    rt: &crate::rt::RtStatus,
    workload: String,
) -> TimingReport {
    TimingReport {
        ticks: wake.len(),
        overruns,
        wake_us: summarise_ns(wake),
        tick_us: summarise_ns(tick),
        wake_histogram_us: histogram_us(wake, 200),
        realtime: RealtimeReport {
            fifo: rt.fifo,
            pinned: rt.pinned,
            memory_locked: rt.memory_locked,
        },
        workload,
    }
}
