//! The Falcon's homing gate on the wire: the mock reports homed bits 0b000, then 0b011, then
//! 0b111 together with the encoder jump that homing causes. The frames must carry zero
//! torque until all three axes are homed, then a ramp with no step, at the jump or anywhere;
//! the homing bit stays in every frame; the jump is counted as a position reset.

use tetradrill_device::falcon::frame::{FalconReport, LED_GREEN, LED_RED};
use tetradrill_device::falcon::kinematics;
use tetradrill_device::falcon::mock::MockTransport;
use tetradrill_device::falcon::{FalconConfig, FalconDevice};
use tetradrill_device::{ForceCommand, HapticDevice};

/// Encoder counts that put the tool at `p` (mechanism frame), from the published scale.
fn counts_for(p: [f64; 3]) -> [i16; 3] {
    let t = kinematics::inverse(p).expect("reachable");
    t.map(|a| {
        let deg = a.to_degrees() - kinematics::THETA_OFFSET_DEG;
        (deg * 4.0 * 320.0 * 0.110 / (360.0 * 0.01425)).round() as i16
    })
}

/// `-10000 x J^T F` at the mechanism point `mech`, from the Jacobian (not the torque solver
/// the driver uses).
fn full_command(mech: [f64; 3], f: [f64; 3]) -> [f64; 3] {
    let j = kinematics::jacobian(mech).expect("jacobian");
    let mut m = [0.0; 3];
    for (i, slot) in m.iter_mut().enumerate() {
        let tau = j[0][i] * f[0] + j[1][i] * f[1] + j[2][i] * f[2];
        *slot = -10_000.0 * tau;
    }
    m
}

const RAMP_TICKS: u32 = 50;
const PUSH: [f64; 3] = [0.0, 0.0, 3.0];

struct Tick {
    homed: u8,
    motors: [i16; 3],
    leds: u8,
    homing_bit: bool,
    mech: [f64; 3],
}

/// Runs one tick per report in `reports`: set what the mock answers, read, write `PUSH`.
fn run(dev: &mut FalconDevice<MockTransport>, reports: &[FalconReport]) -> Vec<Tick> {
    let origin = kinematics::WORKSPACE_CENTRE;
    reports
        .iter()
        .map(|r| {
            dev.transport_mut().report = *r;
            let s = dev.read().expect("read");
            dev.write(&ForceCommand::force(PUSH)).expect("write");
            let cmd = *dev.transport().commands.last().expect("a frame");
            Tick {
                homed: dev.homed(),
                motors: cmd.motors,
                leds: cmd.leds,
                homing_bit: cmd.homing,
                mech: [
                    s.position[0] + origin[0],
                    s.position[1] + origin[1],
                    s.position[2] + origin[2],
                ],
            }
        })
        .collect()
}

fn report(at: [f64; 3], homed: u8) -> FalconReport {
    FalconReport {
        encoders: counts_for(at),
        buttons: 0,
        homed,
    }
}

fn max_abs(m: [i16; 3]) -> i32 {
    m.iter().map(|v| i32::from(*v).abs()).max().unwrap_or(0)
}

#[test]
fn zero_torque_until_homed_then_a_ramp_without_a_step_at_the_jump() {
    let mut c = FalconConfig::default();
    c.safety.ramp_ticks = 1; // only the homing gate ramps
    c.homing_ramp_s = f64::from(RAMP_TICKS) * c.period_s;
    let mut dev = FalconDevice::new(MockTransport::running(), c);
    // Before homing the encoders say one place; homing resets them and the same grip reads
    // 15 mm away (the jump).
    let before = [0.0, 0.0, 0.11];
    let after = [0.008, -0.006, 0.122];
    let mut reports = Vec::new();
    reports.extend([report(before, 0b000); 20]);
    reports.extend([report(before, 0b011); 20]);
    reports.extend([report(after, 0b111); 120]);
    let ticks = run(&mut dev, &reports);

    // Every frame carries the homing bit (libnifalcon: it must be in every packet).
    assert!(dev.transport().commands.iter().all(|c| c.homing));
    assert!(ticks.iter().all(|t| t.homing_bit));
    // Zero torque and the red LED for as long as an axis is not homed.
    let first_homed = ticks.iter().position(|t| t.homed == 0b111).expect("homed");
    assert!(first_homed >= 40);
    for t in &ticks[..first_homed] {
        assert_eq!(t.motors, [0; 3], "homed {:03b}", t.homed);
        assert_eq!(t.leds, LED_RED);
    }
    // The jump happened: the position moved by more than 10 mm between the two reports.
    let (a, b) = (ticks[first_homed - 1].mech, ticks[first_homed].mech);
    let jump = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    assert!(jump > 0.010, "jump {jump}");
    // After homing: the k-th homed frame carries min(1, k / 50) of the full command at the
    // reported position, within a count of rounding.
    let full = full_command(ticks[first_homed].mech, PUSH);
    let full_max = full.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(full_max > 100.0, "a real force: {full:?}");
    for (k, t) in ticks[first_homed..].iter().enumerate() {
        let s = ((k + 1) as f64 / f64::from(RAMP_TICKS)).min(1.0);
        for (i, (m, f)) in t.motors.iter().zip(full).enumerate() {
            assert!(
                (f64::from(*m) - s * f).abs() <= 1.0,
                "homed tick {k}, motor {i}: {m} vs {}",
                s * f
            );
        }
        assert_eq!(t.leds, LED_GREEN);
    }
    // No step anywhere, the jump included: consecutive frames differ by at most a 50th of
    // the full command (plus a count of rounding).
    let bound = (full_max / f64::from(RAMP_TICKS)).ceil() as i32 + 1;
    for w in ticks.windows(2) {
        for i in 0..3 {
            let d = (i32::from(w[1].motors[i]) - i32::from(w[0].motors[i])).abs();
            assert!(d <= bound, "step {d} > {bound}");
        }
    }
    assert!(max_abs(ticks[first_homed].motors) <= bound);
    // Two reports set homed bits (0b000 -> 0b011, 0b011 -> 0b111): two position resets.
    assert_eq!(dev.position_resets(), 2);
}

#[test]
fn losing_an_axis_zeroes_the_force_and_homing_again_ramps_again() {
    let mut c = FalconConfig::default();
    c.safety.ramp_ticks = 1;
    c.homing_ramp_s = f64::from(RAMP_TICKS) * c.period_s;
    let mut dev = FalconDevice::new(MockTransport::running(), c);
    let p = [0.0, 0.005, 0.115];
    let q = [-0.007, 0.0, 0.108];
    let mut reports = Vec::new();
    reports.extend([report(p, 0b111); 80]);
    reports.extend([report(p, 0b101); 10]);
    reports.extend([report(q, 0b111); 80]);
    let ticks = run(&mut dev, &reports);
    let full_p = full_command(ticks[79].mech, PUSH);
    let full_max = full_p.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // Full force at the end of the first homing.
    assert!((f64::from(max_abs(ticks[79].motors)) - full_max).abs() <= 1.0);
    // An axis lost: zero torque and the red LED while it is.
    let lost: Vec<&Tick> = ticks.iter().filter(|t| t.homed != 0b111).collect();
    assert!(!lost.is_empty());
    assert!(lost.iter().all(|t| t.motors == [0; 3] && t.leds == LED_RED));
    // Homed again at the new place: a ramp from the last zero frame on, no step. (Losing the
    // axis dropped the force to zero at once: a step down is what safety wants.)
    let last_lost = ticks.iter().rposition(|t| t.homed != 0b111).expect("lost");
    let bound = (f64::from(max_abs(ticks[169].motors)) / f64::from(RAMP_TICKS)).ceil() as i32 + 1;
    for w in ticks[last_lost..].windows(2) {
        for i in 0..3 {
            let d = (i32::from(w[1].motors[i]) - i32::from(w[0].motors[i])).abs();
            assert!(d <= bound, "step {d} > {bound}");
        }
    }
    // The first homing (from nothing to 0b111) and the second (0b101 -> 0b111).
    assert_eq!(dev.position_resets(), 2);
}
