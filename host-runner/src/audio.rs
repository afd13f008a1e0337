//! The burr's sound, synthesised from the simulation's state: a spinning burr's whine whose
//! pitch is its rotation frequency, falling under load as a handpiece's speed does, with a
//! timbre set by the material it cuts, and a grinding noise that follows the removal.
//!
//! The model (one servo tick at a time, [`BurrVoice::tick`]):
//! - speed: the free-running rotation frequency `free_hz`, falling linearly with the load to
//!   `free_hz * (1 - load_drop)` at `full_load_n` (and no further): an air turbine's or a
//!   motor's speed-torque line, the torque taken as proportional to the force pressing the
//!   burr while it cuts. The speed follows with the rotor's inertia (time constant
//!   `spin_tau_s`);
//! - whine: the speed's fundamental and its harmonics below 18 kHz, harmonic `k` weighted
//!   `brightness^(k-1) / k`, where `brightness` grows with the hardness of the material cut
//!   (enamel rings brighter than dentin, pulp dullest);
//! - grinding: white noise, first-order high-passed, with an amplitude following the volume
//!   removed per second;
//! - on and off: the drill's button (a trace's `DRILL_ON`), with a 20 ms ramp.
//!
//! Work: a few dozen floating-point operations per sample, 44.1 samples a tick; none of it on
//! the servo thread (`replay` synthesises after each tick; `run` from the status task's
//! polls).

use std::io::Write;
use std::path::Path;

use crate::error::CliError;

/// Samples a second of the sound.
pub const SAMPLE_RATE: u32 = 44_100;

/// Highest harmonic frequency synthesised, Hz (below the Nyquist frequency with room).
const MAX_HARMONIC_HZ: f64 = 18_000.0;

/// The burr's sound settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BurrSound {
    /// Rotation frequency running free, Hz. Default 5,333 Hz: 320,000 rpm, within the 300,000
    /// to 400,000 rpm a dental air turbine runs at without load.
    pub free_hz: f64,
    /// Fraction of the free speed lost at `full_load_n`.
    pub load_drop: f64,
    /// The force pressing the burr at which the speed has fallen by `load_drop`, newtons.
    pub full_load_n: f64,
    /// The rotor's time constant, seconds.
    pub spin_tau_s: f64,
}

impl Default for BurrSound {
    fn default() -> Self {
        Self {
            free_hz: 320_000.0 / 60.0,
            load_drop: 0.35,
            full_load_n: 4.0,
            spin_tau_s: 0.02,
        }
    }
}

impl BurrSound {
    /// The rotation frequency the speed settles at under `load_n` newtons, Hz.
    pub fn loaded_hz(&self, load_n: f64) -> f64 {
        let l = if load_n.is_finite() {
            load_n.max(0.0)
        } else {
            0.0
        };
        let share = (l / self.full_load_n.max(1e-9)).min(1.0);
        self.free_hz * (1.0 - self.load_drop * share)
    }
}

/// One tick's state for the sound.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TickSound {
    /// The burr spins.
    pub on: bool,
    /// The force pressing the burr into the material while it cuts, newtons (0 in the air).
    pub load_n: f64,
    /// The material's brightness, 0 to 1 ([`brightness`]).
    pub brightness: f64,
    /// Volume removed per second relative to the grinding's full loudness (0 to 1).
    pub grinding: f64,
}

/// A material's brightness from its hardness relative to the hardest region's: 0.25 for the
/// softest, 0.85 for the hardest; 0.55 when no region has a hardness.
pub fn brightness(hardness: f64, hardest: f64) -> f64 {
    if hardest > 0.0 && hardness.is_finite() {
        0.25 + 0.6 * (hardness / hardest).clamp(0.0, 1.0)
    } else {
        0.55
    }
}

/// The synthesiser: phase-continuous; [`BurrVoice::advance`] keeps its output as 16-bit
/// samples, [`BurrVoice::next_sample`] hands one sample at a time to a sound card.
#[derive(Debug, Clone)]
pub struct BurrVoice {
    sound: BurrSound,
    rate: f64,
    speed_hz: f64,
    phase: f64,
    gain: f64,
    grind: f64,
    bright: f64,
    noise: u64,
    hp_last_in: f64,
    hp_last_out: f64,
    carry: f64,
    samples: Vec<i16>,
}

impl BurrVoice {
    /// A voice at rest (the burr not spinning), at [`SAMPLE_RATE`].
    pub fn new(sound: BurrSound) -> Self {
        Self::with_rate(sound, f64::from(SAMPLE_RATE))
    }

    /// A voice at rest at `rate` samples a second (a sound card's).
    pub fn with_rate(sound: BurrSound, rate: f64) -> Self {
        Self {
            sound,
            rate: if rate.is_finite() && rate >= 8_000.0 {
                rate
            } else {
                f64::from(SAMPLE_RATE)
            },
            speed_hz: 0.0,
            phase: 0.0,
            gain: 0.0,
            grind: 0.0,
            bright: 0.55,
            noise: 0x9e37_79b9_7f4a_7c15,
            hp_last_in: 0.0,
            hp_last_out: 0.0,
            carry: 0.0,
            samples: Vec::new(),
        }
    }

    /// The samples [`BurrVoice::advance`] kept so far.
    pub fn samples(&self) -> &[i16] {
        &self.samples
    }

    /// The rotation frequency now, Hz.
    pub fn speed_hz(&self) -> f64 {
        self.speed_hz
    }

    /// Synthesises `seconds` of sound with the state `s` (one servo tick: 0.001), kept.
    pub fn advance(&mut self, s: &TickSound, seconds: f64) {
        let exact = seconds * self.rate + self.carry;
        let n = exact.floor().max(0.0);
        self.carry = exact - n;
        for _ in 0..n as u64 {
            let v = self.next_sample(s);
            self.samples
                .push((v.clamp(-1.0, 1.0) * f64::from(i16::MAX)) as i16);
        }
    }

    /// One servo tick (1 ms) with the state `s`.
    pub fn tick(&mut self, s: &TickSound) {
        self.advance(s, 0.001);
    }

    /// The next sample (-1 to 1) with the state `s`, not kept.
    pub fn next_sample(&mut self, s: &TickSound) -> f64 {
        let dt = 1.0 / self.rate;
        let target_hz = if s.on {
            self.sound.loaded_hz(s.load_n)
        } else {
            0.0
        };
        let spin = (dt / self.sound.spin_tau_s.max(dt)).min(1.0);
        let ramp = (dt / 0.02).min(1.0);
        let target_gain = if s.on { 1.0 } else { 0.0 };
        let target_grind = if s.on {
            s.grinding.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let target_bright = s.brightness.clamp(0.0, 1.0);
        self.speed_hz += (target_hz - self.speed_hz) * spin;
        self.gain += (target_gain - self.gain) * ramp;
        self.grind += (target_grind - self.grind) * ramp;
        self.bright += (target_bright - self.bright) * ramp;
        self.phase = (self.phase + self.speed_hz * dt).fract();
        let mut whine = 0.0;
        let mut norm = 0.0;
        let mut w = 1.0;
        for k in 1..=8u32 {
            if f64::from(k) * self.speed_hz > MAX_HARMONIC_HZ.min(0.45 * self.rate) {
                break;
            }
            let a = w / f64::from(k);
            whine += a * (std::f64::consts::TAU * f64::from(k) * self.phase).sin();
            norm += a;
            w *= self.bright;
        }
        if norm > 0.0 {
            whine /= norm;
        }
        // xorshift64 white noise, high-passed (first order).
        self.noise ^= self.noise << 13;
        self.noise ^= self.noise >> 7;
        self.noise ^= self.noise << 17;
        let white = (self.noise >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
        let hp = 0.75 * (self.hp_last_out + white - self.hp_last_in);
        self.hp_last_in = white;
        self.hp_last_out = hp;
        self.gain * (0.45 * whine + 0.35 * self.grind * hp)
    }
}

/// The state a live sound card's callback reads: atomics the audio task writes every 10 ms.
#[derive(Debug, Default)]
pub struct LiveState {
    on: std::sync::atomic::AtomicBool,
    load_bits: std::sync::atomic::AtomicU64,
    brightness_bits: std::sync::atomic::AtomicU64,
    grinding_bits: std::sync::atomic::AtomicU64,
}

impl LiveState {
    /// Publishes `s`.
    pub fn set(&self, s: &TickSound) {
        use std::sync::atomic::Ordering::Relaxed;
        self.load_bits.store(s.load_n.to_bits(), Relaxed);
        self.brightness_bits.store(s.brightness.to_bits(), Relaxed);
        self.grinding_bits.store(s.grinding.to_bits(), Relaxed);
        self.on.store(s.on, Relaxed);
    }

    /// The state last published (fields may come from two neighbouring publications).
    pub fn get(&self) -> TickSound {
        use std::sync::atomic::Ordering::Relaxed;
        TickSound {
            on: self.on.load(Relaxed),
            load_n: f64::from_bits(self.load_bits.load(Relaxed)),
            brightness: f64::from_bits(self.brightness_bits.load(Relaxed)),
            grinding: f64::from_bits(self.grinding_bits.load(Relaxed)),
        }
    }
}

/// Live playback through the default sound card (cargo feature `sound`, `cpal`).
#[cfg(feature = "sound")]
pub mod live {
    use std::sync::Arc;

    use cpal::traits::{DeviceTrait, HostTrait, StreamTrait};

    use super::{BurrSound, BurrVoice, LiveState};

    /// A playing stream; dropping it stops the sound. Not `Send` on every platform: made,
    /// kept and dropped on the audio task's thread.
    pub struct Player {
        _stream: cpal::Stream,
    }

    impl std::fmt::Debug for Player {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("Player")
        }
    }

    impl Player {
        /// Starts playing the voice of `state` on the default output device.
        ///
        /// # Errors
        /// No output device, or one that takes neither 32-bit float nor 16-bit samples; one
        /// line saying which.
        pub fn start(state: Arc<LiveState>, sound: BurrSound) -> Result<Player, String> {
            let host = cpal::default_host();
            let device = host
                .default_output_device()
                .ok_or_else(|| "no sound output device".to_string())?;
            let config = device
                .default_output_config()
                .map_err(|e| format!("the sound output device: {e}"))?;
            let format = config.sample_format();
            let config: cpal::StreamConfig = config.into();
            let channels = usize::from(config.channels.max(1));
            let mut voice = BurrVoice::with_rate(sound, f64::from(config.sample_rate));
            let err = |e: cpal::Error| eprintln!("tetradrill: sound: {e}");
            let stream = match format {
                cpal::SampleFormat::F32 => device.build_output_stream(
                    config,
                    move |data: &mut [f32], _: &cpal::OutputCallbackInfo| {
                        let s = state.get();
                        for frame in data.chunks_mut(channels) {
                            let v = voice.next_sample(&s) as f32;
                            frame.iter_mut().for_each(|x| *x = v);
                        }
                    },
                    err,
                    None,
                ),
                cpal::SampleFormat::I16 => device.build_output_stream(
                    config,
                    move |data: &mut [i16], _: &cpal::OutputCallbackInfo| {
                        let s = state.get();
                        for frame in data.chunks_mut(channels) {
                            let v = (voice.next_sample(&s).clamp(-1.0, 1.0) * 32767.0) as i16;
                            frame.iter_mut().for_each(|x| *x = v);
                        }
                    },
                    err,
                    None,
                ),
                other => return Err(format!("the sound output device takes {other} samples")),
            }
            .map_err(|e| format!("cannot open the sound output: {e}"))?;
            stream
                .play()
                .map_err(|e| format!("cannot start the sound: {e}"))?;
            Ok(Player { _stream: stream })
        }
    }
}

/// `--sound` in a build without the `sound` feature: one line, exit status 2.
///
/// # Errors
/// As said.
pub fn check_sound_flag(sound: bool) -> Result<(), CliError> {
    if sound && !cfg!(feature = "sound") {
        return Err(CliError::input(
            "--sound: this build plays no sound (build with the `sound` feature, which needs \
             libasound2-dev); --audio-out FILE.wav writes it",
        ));
    }
    Ok(())
}

/// Writes `samples` (mono, [`SAMPLE_RATE`]) as a 16-bit PCM WAV file.
///
/// # Errors
/// One line naming the file when it cannot be written.
pub fn write_wav(path: &Path, samples: &[i16]) -> Result<(), CliError> {
    let fail = |e: std::io::Error| {
        CliError::failure(format!("{}: cannot write the sound: {e}", path.display()))
    };
    let data_bytes = u32::try_from(samples.len() * 2).map_err(|_| {
        CliError::failure(format!(
            "{}: the sound is too long for a WAV file",
            path.display()
        ))
    })?;
    let mut out = Vec::with_capacity(44 + samples.len() * 2);
    out.extend_from_slice(b"RIFF");
    out.extend_from_slice(&(36 + data_bytes).to_le_bytes());
    out.extend_from_slice(b"WAVEfmt ");
    out.extend_from_slice(&16u32.to_le_bytes());
    out.extend_from_slice(&1u16.to_le_bytes()); // PCM
    out.extend_from_slice(&1u16.to_le_bytes()); // mono
    out.extend_from_slice(&SAMPLE_RATE.to_le_bytes());
    out.extend_from_slice(&(SAMPLE_RATE * 2).to_le_bytes());
    out.extend_from_slice(&2u16.to_le_bytes());
    out.extend_from_slice(&16u16.to_le_bytes());
    out.extend_from_slice(b"data");
    out.extend_from_slice(&data_bytes.to_le_bytes());
    for s in samples {
        out.extend_from_slice(&s.to_le_bytes());
    }
    let mut f = std::fs::File::create(path).map_err(fail)?;
    f.write_all(&out).map_err(fail)?;
    f.flush().map_err(fail)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_speed_falls_with_the_load_as_set_and_no_further() {
        let s = BurrSound::default();
        assert_eq!(s.loaded_hz(0.0), s.free_hz);
        assert!((s.loaded_hz(2.0) - s.free_hz * (1.0 - 0.35 * 0.5)).abs() < 1e-9);
        assert!((s.loaded_hz(40.0) - s.free_hz * 0.65).abs() < 1e-9);
        assert_eq!(s.loaded_hz(f64::NAN), s.free_hz);
        assert!(brightness(3200.0, 3200.0) > brightness(640.0, 3200.0));
    }

    #[test]
    fn a_wav_has_its_header_and_samples() {
        let dir = std::env::temp_dir().join(format!("tetradrill-wav-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let p = dir.join("a.wav");
        write_wav(&p, &[0, 1, -1, i16::MAX]).expect("write");
        let b = std::fs::read(&p).expect("read");
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(b.len(), 44 + 8);
        assert_eq!(&b[0..4], b"RIFF");
        assert_eq!(
            u32::from_le_bytes([b[24], b[25], b[26], b[27]]),
            SAMPLE_RATE
        );
        assert_eq!(i16::from_le_bytes([b[50], b[51]]), i16::MAX);
    }
}
