//! A haptic device written here, driven by tetradrill's real-time servo for one second: its
//! stylus rests 5 mm inside the built-in block's top face, and the device must feel the block
//! push it back up on nearly every one of the 1,000 servo ticks.
//!
//! `cargo run --release -p tetradrill-examples --example own_device`

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use tetradrill::prelude::*;
use tetradrill::servo::{self, ServoOptions};
use tetradrill_device::{DeviceError, DeviceSpec, DeviceState, ForceCommand, HapticDevice};

/// A stylus held still at `at` (metres in the device frame, here the mesh's units), counting
/// the force commands that push it up.
struct StillStylus {
    at: [f64; 3],
    tick: u64,
    pushed_up: Arc<AtomicU64>,
}

impl HapticDevice for StillStylus {
    fn spec(&self) -> DeviceSpec {
        DeviceSpec::FALCON
    }

    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        self.tick += 1;
        Ok(DeviceState {
            timestamp_s: self.tick as f64 * 1e-3,
            tick: self.tick,
            position: self.at,
            ..DeviceState::ZERO
        })
    }

    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError> {
        if command.enable && command.force[2] > 0.0 {
            self.pushed_up.fetch_add(1, Ordering::Relaxed);
        }
        Ok(())
    }

    fn calibrate(&mut self) -> Result<(), DeviceError> {
        Ok(())
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let pushed_up = Arc::new(AtomicU64::new(0));
    let stylus = StillStylus {
        at: [0.0, 0.0, 0.5 + 0.1 - 0.005], // the burr's centre: its surface 5 mm deep
        tick: 0,
        pushed_up: Arc::clone(&pushed_up),
    };
    let setup = Setup::new("builtin:block:8", Tool::sphere(0.1));
    let report = servo::run(&setup, stylus, ServoOptions::for_ms(1000))?;
    let up = pushed_up.load(Ordering::Relaxed);
    println!(
        "{} ticks, {} deadlines missed, {} force commands pushing up",
        report.ticks, report.overruns, up
    );
    if report.ticks != 1000 {
        return Err(format!("{} ticks, not 1000", report.ticks).into());
    }
    if up < 900 {
        return Err(format!("only {up} of 1000 commands pushed the stylus up").into());
    }
    Ok(())
}

#[test]
fn runs() {
    main().unwrap();
}
