//! `--device-config FILE`: the device constants, read from a TOML file.
//!
//! The file has up to three tables, `[omni]`, `[falcon]` and `[touch]`; a table or key left
//! out keeps its built-in default ([`OmniConfig::default`], [`FalconConfig::default`]). The
//! defaults are shipped with their public sources in `docs/devices/*.toml`, and a test checks
//! that those files equal the built-in values. An unknown table or key, a value of the wrong
//! type or out of range is one line naming the file, the line and the key (exit status 2).
//!
//! | table      | keys |
//! |------------|------|
//! | `[omni]`   | [`OMNI_KEYS`] ([`OmniConfig`]'s fields; `max_force_n`, `ramp_ticks`, `watchdog_ticks` are its safety settings) |
//! | `[falcon]` | [`FALCON_KEYS`] ([`FalconConfig`]'s fields, the same safety keys) |
//! | `[touch]`  | [`TOUCH_KEYS`]: the safety filter's (the vendor library holds the rest) |

use std::path::Path;

use tetradrill_device::falcon::FalconConfig;
use tetradrill_device::omni::OmniConfig;
use tetradrill_device::safety::SafetyConfig;
use tetradrill_device::DeviceSpec;
use toml::de::{DeTable, DeValue};
use toml::Spanned;

use crate::error::CliError;

/// Largest device file read, bytes (checked before reading it).
pub const MAX_FILE_BYTES: u64 = 256 * 1024;

/// The `[omni]` keys.
pub const OMNI_KEYS: &[&str] = &[
    "dock_angles",
    "encoder_sign",
    "joint3_coupling",
    "counts_per_rev",
    "dac_per_newton_metre",
    "gimbal_gain",
    "gimbal_offset",
    "link_lengths_m",
    "startup_quadlet",
    "period_s",
    "max_force_n",
    "ramp_ticks",
    "watchdog_ticks",
];

/// The `[falcon]` keys.
pub const FALCON_KEYS: &[&str] = &[
    "command_per_newton_metre",
    "max_command",
    "origin",
    "period_s",
    "timeout_ms",
    "reads_per_tick",
    "homing_ramp_s",
    "handshake_tries",
    "upload_tries",
    "status_tries",
    "loader_timeout_ms",
    "max_lost_in_row",
    "max_force_n",
    "ramp_ticks",
    "watchdog_ticks",
];

/// The `[touch]` keys: its safety filter's (the vendor library holds its other constants).
pub const TOUCH_KEYS: &[&str] = &["max_force_n", "ramp_ticks", "watchdog_ticks"];

/// Every device's constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceConfig {
    /// The PHANTOM Omni's.
    pub omni: OmniConfig,
    /// The Novint Falcon's.
    pub falcon: FalconConfig,
    /// The Touch's safety filter (`TouchDevice::with_safety`).
    pub touch: SafetyConfig,
}

impl Default for DeviceConfig {
    fn default() -> DeviceConfig {
        DeviceConfig {
            omni: OmniConfig::default(),
            falcon: FalconConfig::default(),
            touch: SafetyConfig::for_max_force(DeviceSpec::TOUCH.max_force_n),
        }
    }
}

impl DeviceConfig {
    /// The built-in defaults without a file, else [`DeviceConfig::load`].
    pub fn from_flag(path: Option<&Path>) -> Result<DeviceConfig, CliError> {
        path.map_or(Ok(DeviceConfig::default()), DeviceConfig::load)
    }

    /// Reads and checks a device file.
    pub fn load(path: &Path) -> Result<DeviceConfig, CliError> {
        let cannot = |e: std::io::Error| CliError::at(path, None, format!("cannot read: {e}"));
        let len = std::fs::metadata(path).map_err(cannot)?.len();
        if len > MAX_FILE_BYTES {
            return Err(CliError::at(
                path,
                None,
                format!("{len} bytes; a device file holds at most {MAX_FILE_BYTES}"),
            ));
        }
        let text = std::fs::read_to_string(path).map_err(cannot)?;
        DeviceConfig::parse(path, &text)
    }

    /// Parses a device file's text (`path` names it in errors).
    pub fn parse(path: &Path, text: &str) -> Result<DeviceConfig, CliError> {
        let line = |at: usize| text[..at.min(text.len())].matches('\n').count() + 1;
        let doc = DeTable::parse(text).map_err(|e| {
            CliError::at(
                path,
                e.span().map(|s| line(s.start)),
                e.message().trim().replace('\n', " "),
            )
        })?;
        let mut out = DeviceConfig::default();
        for (name, value) in doc.get_ref() {
            let at = line(name.span().start);
            let bad = |reason: String| CliError::at(path, Some(at), reason);
            let Some(table) = value.get_ref().as_table() else {
                return Err(bad(format!(
                    "`{}` is not a table ([omni], [falcon] or [touch])",
                    name.get_ref()
                )));
            };
            match name.get_ref().as_ref() {
                "omni" => each(table, &line, |key, v| omni_key(&mut out.omni, key, v)),
                "falcon" => each(table, &line, |key, v| falcon_key(&mut out.falcon, key, v)),
                "touch" => each(table, &line, |key, v| {
                    let peak = DeviceSpec::TOUCH.max_force_n;
                    match safety_key(&mut out.touch, peak, "Touch", key, v)? {
                        true => Ok(()),
                        false => Err(unknown("touch", key, TOUCH_KEYS)),
                    }
                }),
                other => Err((
                    at,
                    format!("unknown table `[{other}]` (known: [omni], [falcon], [touch])"),
                )),
            }
            .map_err(|(l, reason)| CliError::at(path, Some(l), reason))?;
        }
        Ok(out)
    }
}

/// A key's value as the setters see it.
type Value<'a> = Spanned<DeValue<'a>>;

fn unknown(table: &str, key: &str, known: &[&str]) -> String {
    if known.is_empty() {
        format!("unknown key `{key}` in [{table}] (it has no keys)")
    } else {
        format!(
            "unknown key `{key}` in [{table}] (known: {})",
            known.join(", ")
        )
    }
}

/// Runs `set` on every key of `table`; an error comes back with the key's line.
fn each(
    table: &DeTable<'_>,
    line: &dyn Fn(usize) -> usize,
    mut set: impl FnMut(&str, &Value<'_>) -> Result<(), String>,
) -> Result<(), (usize, String)> {
    for (key, value) in table {
        set(key.get_ref(), value).map_err(|m| (line(key.span().start), m))?;
    }
    Ok(())
}

fn number(key: &str, v: &Value<'_>) -> Result<f64, String> {
    let x = match v.get_ref() {
        DeValue::Float(f) => f.as_str().replace('_', "").parse::<f64>().ok(),
        DeValue::Integer(i) => {
            let digits = i.as_str().replace('_', "");
            let (neg, body) = match digits.strip_prefix('-') {
                Some(b) => (true, b.to_string()),
                None => (false, digits.trim_start_matches('+').to_string()),
            };
            let body = body
                .trim_start_matches("0x")
                .trim_start_matches("0o")
                .trim_start_matches("0b")
                .to_string();
            i64::from_str_radix(&body, i.radix())
                .ok()
                .map(|n| if neg { -(n as f64) } else { n as f64 })
        }
        other => {
            return Err(format!(
                "`{key}` is a {}, expected a number",
                other.type_str()
            ))
        }
    };
    match x {
        Some(x) if x.is_finite() => Ok(x),
        _ => Err(format!("`{key}` is not a finite number")),
    }
}

fn positive(key: &str, v: &Value<'_>) -> Result<f64, String> {
    let x = number(key, v)?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err(format!("`{key}` is {x}; it must be above zero"))
    }
}

fn non_negative(key: &str, v: &Value<'_>) -> Result<f64, String> {
    let x = number(key, v)?;
    if x >= 0.0 && x.is_finite() {
        Ok(x)
    } else {
        Err(format!("`{key}` is {x}; it must be zero or above"))
    }
}

fn integer(key: &str, v: &Value<'_>, lo: u32, hi: u32) -> Result<u32, String> {
    let x = number(key, v)?;
    if x.fract() == 0.0 && x >= f64::from(lo) && x <= f64::from(hi) {
        Ok(x as u32)
    } else {
        Err(format!(
            "`{key}` is {x}; expected a whole number in {lo}..={hi}"
        ))
    }
}

fn array<const N: usize>(key: &str, v: &Value<'_>) -> Result<[f64; N], String> {
    let Some(items) = v.get_ref().as_array() else {
        return Err(format!(
            "`{key}` is a {}, expected an array of {N} numbers",
            v.get_ref().type_str()
        ));
    };
    if items.len() != N {
        return Err(format!("`{key}` has {} values, expected {N}", items.len()));
    }
    let mut out = [0.0; N];
    for (slot, item) in out.iter_mut().zip(items.iter()) {
        *slot = number(key, item)?;
    }
    Ok(out)
}

fn boolean(key: &str, v: &Value<'_>) -> Result<bool, String> {
    v.get_ref().as_bool().ok_or_else(|| {
        format!(
            "`{key}` is a {}, expected true or false",
            v.get_ref().type_str()
        )
    })
}

/// The safety keys shared by the devices; `false` when `key` is not one of them.
fn safety_key(
    s: &mut SafetyConfig,
    peak: f64,
    device: &str,
    key: &str,
    v: &Value<'_>,
) -> Result<bool, String> {
    match key {
        "max_force_n" => {
            let f = positive(key, v)?;
            if f > peak {
                return Err(format!(
                    "`max_force_n` is {f} N, above the {device}'s {peak} N peak"
                ));
            }
            s.max_force_n = f;
        }
        "ramp_ticks" => s.ramp_ticks = integer(key, v, 0, 60_000)?,
        "watchdog_ticks" => s.watchdog_ticks = integer(key, v, 1, 1000)?,
        _ => return Ok(false),
    }
    Ok(true)
}

fn omni_key(c: &mut OmniConfig, key: &str, v: &Value<'_>) -> Result<(), String> {
    match key {
        "dock_angles" => c.dock_angles = array(key, v)?,
        "encoder_sign" => {
            let s = array::<3>(key, v)?;
            if s.iter().any(|x| x.abs() != 1.0) {
                return Err(format!("`encoder_sign` is {s:?}; each sign is 1 or -1"));
            }
            c.encoder_sign = s;
        }
        "joint3_coupling" => c.joint3_coupling = number(key, v)?,
        "counts_per_rev" => c.counts_per_rev = positive(key, v)?,
        "dac_per_newton_metre" => c.dac_per_newton_metre = array(key, v)?,
        "gimbal_gain" => c.gimbal_gain = array(key, v)?,
        "gimbal_offset" => c.gimbal_offset = array(key, v)?,
        "link_lengths_m" => {
            let l = array::<2>(key, v)?;
            if l.iter().any(|&x| x <= 0.0) {
                return Err(format!("`link_lengths_m` is {l:?}; lengths are above zero"));
            }
            c.link_lengths_m = l;
        }
        "startup_quadlet" => c.startup_quadlet = boolean(key, v)?,
        "period_s" => c.period_s = positive(key, v)?,
        _ => {
            let peak = DeviceSpec::OMNI.max_force_n;
            if !safety_key(&mut c.safety, peak, "Omni", key, v)? {
                return Err(unknown("omni", key, OMNI_KEYS));
            }
        }
    }
    Ok(())
}

fn falcon_key(c: &mut FalconConfig, key: &str, v: &Value<'_>) -> Result<(), String> {
    match key {
        "command_per_newton_metre" => c.command_per_newton_metre = number(key, v)?,
        "max_command" => c.max_command = integer(key, v, 1, i16::MAX as u32)? as i16,
        "origin" => c.origin = array(key, v)?,
        "period_s" => c.period_s = positive(key, v)?,
        "timeout_ms" => c.timeout_ms = integer(key, v, 1, 60_000)?,
        "reads_per_tick" => c.reads_per_tick = integer(key, v, 1, 1000)?,
        "homing_ramp_s" => c.homing_ramp_s = non_negative(key, v)?,
        "handshake_tries" => c.handshake_tries = integer(key, v, 1, 10_000)?,
        "upload_tries" => c.upload_tries = integer(key, v, 1, 100)?,
        "status_tries" => c.status_tries = integer(key, v, 1, 10_000)?,
        "loader_timeout_ms" => c.loader_timeout_ms = integer(key, v, 1, 60_000)?,
        "max_lost_in_row" => c.max_lost_in_row = integer(key, v, 1, 10_000)?,
        _ => {
            let peak = DeviceSpec::FALCON.max_force_n;
            if !safety_key(&mut c.safety, peak, "Falcon", key, v)? {
                return Err(unknown("falcon", key, FALCON_KEYS));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<DeviceConfig, CliError> {
        DeviceConfig::parse(Path::new("dev.toml"), text)
    }

    #[test]
    fn keys_set_fields_and_absent_keys_keep_defaults() {
        let c = parse(
            "# a comment\n[omni]\nencoder_sign = [1, 1, -1]\ncounts_per_rev = 15_000\n\
             startup_quadlet = false\nmax_force_n = 2.5\n[falcon]\nmax_command = 0x0800\n",
        )
        .unwrap();
        let mut want = DeviceConfig::default();
        want.omni.encoder_sign = [1.0, 1.0, -1.0];
        want.omni.startup_quadlet = false;
        want.omni.safety.max_force_n = 2.5;
        want.falcon.max_command = 2048;
        assert_eq!(c, want);
        assert_eq!(parse("").unwrap(), DeviceConfig::default());
    }

    #[test]
    fn bad_files_name_the_line_and_the_key() {
        let cases = [
            (
                "[omni]\n\nencoder_signs = [1, 1, 1]\n",
                "dev.toml:3:",
                "encoder_signs",
            ),
            (
                "[omni]\nencoder_sign = [1, 2, 1]\n",
                "dev.toml:2:",
                "1 or -1",
            ),
            (
                "[omni]\ndock_angles = [0, 0]\n",
                "dev.toml:2:",
                "expected 3",
            ),
            ("[omni]\nperiod_s = \"1ms\"\n", "dev.toml:2:", "string"),
            ("[omni]\nmax_force_n = 9\n", "dev.toml:2:", "peak"),
            ("[omni]\ncounts_per_rev = nan\n", "dev.toml:2:", "finite"),
            ("\n[phantom]\n", "dev.toml:2:", "unknown table"),
            ("[touch]\nname = 1\n", "dev.toml:2:", "unknown key `name`"),
            (
                "[falcon]\nmax_command = 1.5\n",
                "dev.toml:2:",
                "whole number",
            ),
            ("[omni\n", "dev.toml:1:", ""),
        ];
        for (text, at, why) in cases {
            let e = parse(text).expect_err(text);
            assert_eq!(e.code, crate::error::EXIT_BAD_INPUT);
            assert!(e.message.starts_with(at), "{text:?}: {}", e.message);
            assert!(e.message.contains(why), "{text:?}: {}", e.message);
            assert!(!e.message.contains('\n'), "{}", e.message);
        }
    }
}
