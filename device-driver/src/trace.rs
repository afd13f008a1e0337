//! Device traces: recording and playback of device samples as CSV (docs/DEVICES.md, "Traces").
//!
//! The header is exactly `t,x,y,z,qw,qx,qy,qz,buttons`: seconds, metres (or mesh units), a unit
//! quaternion, and a button bit mask (bit 0 = drill on). Parse errors are data
//! ([`TraceError`]: a line number and a [`TraceErrorKind`]); the command line prints them as
//! `FILE:LINE: reason` with [`TraceError::at`].

use core::fmt;
use std::io;

use crate::device::{DeviceState, Quat, Vec3};

/// The CSV header, exactly.
pub const TRACE_HEADER: &str = "t,x,y,z,qw,qx,qy,qz,buttons";

/// Quaternions whose norm differs from 1 by at most this much are normalised; others refused.
pub const QUAT_NORM_TOLERANCE: f64 = 1e-2;

/// One trace sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceSample {
    /// Time, s.
    pub t: f64,
    /// Position.
    pub position: Vec3,
    /// Unit quaternion `[w, x, y, z]`.
    pub rotation: Quat,
    /// Button bit mask.
    pub buttons: u32,
}

impl TraceSample {
    /// The sample a device state would record.
    pub fn from_state(state: &DeviceState) -> TraceSample {
        TraceSample {
            t: state.timestamp_s,
            position: state.position,
            rotation: state.rotation,
            buttons: state.buttons,
        }
    }
}

/// Why a trace line was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceErrorKind {
    /// The text is empty: no header line.
    MissingHeader,
    /// The first line is not `t,x,y,z,qw,qx,qy,qz,buttons`.
    WrongHeader,
    /// A row with fewer than 9 fields.
    ShortRow {
        /// Fields found.
        found: u8,
    },
    /// A row with more than 9 fields.
    LongRow,
    /// A field that is not a number (column index 0..=8).
    NotANumber {
        /// Column, 0-based.
        column: u8,
    },
    /// NaN or an infinite value (column index 0..=8).
    NonFinite {
        /// Column, 0-based.
        column: u8,
    },
    /// The buttons field is not an unsigned 32-bit integer.
    BadButtons,
    /// Time smaller than the previous row's.
    TimeBackwards,
    /// The quaternion's norm is too far from 1 to be a rotation.
    QuaternionNotUnit,
    /// The quaternion is zero.
    ZeroQuaternion,
    /// A header but no samples.
    Empty,
}

const COLUMNS: [&str; 9] = ["t", "x", "y", "z", "qw", "qx", "qy", "qz", "buttons"];

impl fmt::Display for TraceErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let col = |c: u8| COLUMNS.get(usize::from(c)).copied().unwrap_or("?");
        match *self {
            TraceErrorKind::MissingHeader => write!(f, "missing header `{TRACE_HEADER}`"),
            TraceErrorKind::WrongHeader => write!(f, "wrong header, expected `{TRACE_HEADER}`"),
            TraceErrorKind::ShortRow { found } => write!(f, "short row: {found} of 9 fields"),
            TraceErrorKind::LongRow => f.write_str("long row: more than 9 fields"),
            TraceErrorKind::NotANumber { column } => {
                write!(f, "field `{}` is not a number", col(column))
            }
            TraceErrorKind::NonFinite { column } => {
                write!(f, "field `{}` is NaN or infinite", col(column))
            }
            TraceErrorKind::BadButtons => f.write_str("field `buttons` is not an unsigned integer"),
            TraceErrorKind::TimeBackwards => f.write_str("time goes backwards"),
            TraceErrorKind::QuaternionNotUnit => f.write_str("quaternion is not a unit quaternion"),
            TraceErrorKind::ZeroQuaternion => f.write_str("quaternion is zero"),
            TraceErrorKind::Empty => f.write_str("trace has no samples"),
        }
    }
}

/// A trace parse error: 1-based line number and reason.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TraceError {
    /// 1-based line number.
    pub line: usize,
    /// Reason.
    pub kind: TraceErrorKind,
}

impl TraceError {
    /// Display as `FILE:LINE: reason`.
    pub fn at<'a>(&'a self, file: &'a str) -> impl fmt::Display + 'a {
        struct At<'a>(&'a TraceError, &'a str);
        impl fmt::Display for At<'_> {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{}:{}: {}", self.1, self.0.line, self.0.kind)
            }
        }
        At(self, file)
    }
}

impl fmt::Display for TraceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.kind)
    }
}

impl std::error::Error for TraceError {}

/// A recorded trajectory, samples in non-decreasing time.
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    name: String,
    samples: Vec<TraceSample>,
}

impl Trace {
    /// An empty trace (for recording) with a display name.
    pub fn new(name: &str) -> Trace {
        Trace {
            name: name.to_owned(),
            samples: Vec::new(),
        }
    }

    /// Builds a trace from samples, checking them like the parser does (line = index + 2).
    pub fn from_samples(name: &str, samples: &[TraceSample]) -> Result<Trace, TraceError> {
        let mut trace = Trace::new(name);
        for (i, s) in samples.iter().enumerate() {
            let line = i + 2;
            let err = |kind| TraceError { line, kind };
            let fields = [
                s.t,
                s.position[0],
                s.position[1],
                s.position[2],
                s.rotation[0],
                s.rotation[1],
                s.rotation[2],
                s.rotation[3],
            ];
            if let Some(c) = fields.iter().position(|v| !v.is_finite()) {
                return Err(err(TraceErrorKind::NonFinite { column: c as u8 }));
            }
            let rotation = normalise_quat(s.rotation).map_err(err)?;
            trace
                .push(TraceSample { rotation, ..*s })
                .map_err(|_| err(TraceErrorKind::TimeBackwards))?;
        }
        if trace.samples.is_empty() {
            return Err(TraceError {
                line: 1,
                kind: TraceErrorKind::Empty,
            });
        }
        Ok(trace)
    }

    /// Parses CSV text. `name` (usually the file path) becomes the trace's display name.
    pub fn parse(text: &str, name: &str) -> Result<Trace, TraceError> {
        let mut lines = text.lines().enumerate();
        let header = loop {
            match lines.next() {
                None => {
                    return Err(TraceError {
                        line: 1,
                        kind: TraceErrorKind::MissingHeader,
                    })
                }
                Some((_, l)) if l.trim().is_empty() => continue,
                Some((i, l)) => break (i + 1, l.trim()),
            }
        };
        if header.1 != TRACE_HEADER {
            let compact: String = header.1.chars().filter(|c| !c.is_whitespace()).collect();
            if compact != TRACE_HEADER {
                let kind = if header
                    .1
                    .starts_with(|c: char| c.is_ascii_digit() || c == '-')
                {
                    TraceErrorKind::MissingHeader
                } else {
                    TraceErrorKind::WrongHeader
                };
                return Err(TraceError {
                    line: header.0,
                    kind,
                });
            }
        }
        let mut trace = Trace::new(name);
        let mut last_line = header.0;
        for (i, raw) in lines {
            let line = i + 1;
            last_line = line;
            let row = raw.trim();
            if row.is_empty() || row.starts_with('#') {
                continue;
            }
            let sample = parse_row(row).map_err(|kind| TraceError { line, kind })?;
            trace.push(sample).map_err(|_| TraceError {
                line,
                kind: TraceErrorKind::TimeBackwards,
            })?;
        }
        if trace.samples.is_empty() {
            return Err(TraceError {
                line: last_line,
                kind: TraceErrorKind::Empty,
            });
        }
        Ok(trace)
    }

    /// The display name (file path) given at construction.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The samples.
    pub fn samples(&self) -> &[TraceSample] {
        &self.samples
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Time of the first and last samples (`None` when empty).
    pub fn time_span(&self) -> Option<(f64, f64)> {
        Some((self.samples.first()?.t, self.samples.last()?.t))
    }

    /// Appends a sample (recording). Refuses, and hands back, a sample earlier than the last.
    pub fn push(&mut self, sample: TraceSample) -> Result<(), TraceSample> {
        match self.samples.last() {
            Some(last) if sample.t < last.t || sample.t.is_nan() => Err(sample),
            _ => {
                self.samples.push(sample);
                Ok(())
            }
        }
    }

    /// Appends what a device read (recording).
    pub fn record(&mut self, state: &DeviceState) -> Result<(), TraceSample> {
        self.push(TraceSample::from_state(state))
    }

    /// The trajectory at time `t`: linear position, normalised-lerp rotation (shortest arc),
    /// buttons of the earlier sample. Clamped to the first/last sample outside the span.
    /// `None` only for an empty trace.
    ///
    /// # Bounded work
    /// O(log n) in the number of samples.
    pub fn sample_at(&self, t: f64) -> Option<TraceSample> {
        let first = *self.samples.first()?;
        let last = *self.samples.last()?;
        if t.is_nan() || t <= first.t {
            return Some(TraceSample { t, ..first });
        }
        if t >= last.t {
            return Some(TraceSample { t, ..last });
        }
        // Index of the first sample with time > t; at least 1 and at most len-1 here.
        let hi = self.samples.partition_point(|s| s.t <= t);
        let a = self.samples.get(hi.checked_sub(1)?)?;
        let b = self.samples.get(hi)?;
        let dt = b.t - a.t;
        let u = if dt > 0.0 { (t - a.t) / dt } else { 0.0 };
        let lerp = |p: f64, q: f64| p + (q - p) * u;
        let position = [
            lerp(a.position[0], b.position[0]),
            lerp(a.position[1], b.position[1]),
            lerp(a.position[2], b.position[2]),
        ];
        Some(TraceSample {
            t,
            position,
            rotation: nlerp(a.rotation, b.rotation, u),
            buttons: a.buttons,
        })
    }

    /// Writes the trace as CSV (header plus one row per sample; round-trips exactly).
    pub fn write_csv<W: io::Write>(&self, mut out: W) -> io::Result<()> {
        writeln!(out, "{TRACE_HEADER}")?;
        for s in &self.samples {
            writeln!(
                out,
                "{},{},{},{},{},{},{},{},{}",
                s.t,
                s.position[0],
                s.position[1],
                s.position[2],
                s.rotation[0],
                s.rotation[1],
                s.rotation[2],
                s.rotation[3],
                s.buttons
            )?;
        }
        Ok(())
    }

    /// The trace as CSV text.
    pub fn to_csv(&self) -> String {
        let mut buf = Vec::new();
        // Writing to a Vec cannot fail.
        let _ = self.write_csv(&mut buf);
        String::from_utf8_lossy(&buf).into_owned()
    }
}

fn parse_row(row: &str) -> Result<TraceSample, TraceErrorKind> {
    let mut v = [0.0f64; 8];
    let mut buttons = 0u32;
    let mut n = 0usize;
    for (i, field) in row.split(',').enumerate() {
        let field = field.trim();
        n = i + 1;
        match i {
            0..=7 => {
                let x: f64 = field
                    .parse()
                    .map_err(|_| TraceErrorKind::NotANumber { column: i as u8 })?;
                if !x.is_finite() {
                    return Err(TraceErrorKind::NonFinite { column: i as u8 });
                }
                if let Some(slot) = v.get_mut(i) {
                    *slot = x;
                }
            }
            8 => buttons = field.parse().map_err(|_| TraceErrorKind::BadButtons)?,
            _ => return Err(TraceErrorKind::LongRow),
        }
    }
    if n < 9 {
        return Err(TraceErrorKind::ShortRow { found: n as u8 });
    }
    let rotation = normalise_quat([v[4], v[5], v[6], v[7]])?;
    Ok(TraceSample {
        t: v[0],
        position: [v[1], v[2], v[3]],
        rotation,
        buttons,
    })
}

/// Normalises a near-unit quaternion; refuses zero and far-from-unit ones.
pub fn normalise_quat(q: Quat) -> Result<Quat, TraceErrorKind> {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if n == 0.0 {
        return Err(TraceErrorKind::ZeroQuaternion);
    }
    if (n - 1.0).abs() > QUAT_NORM_TOLERANCE {
        return Err(TraceErrorKind::QuaternionNotUnit);
    }
    Ok([q[0] / n, q[1] / n, q[2] / n, q[3] / n])
}

/// Normalised linear interpolation along the shorter arc.
pub fn nlerp(a: Quat, b: Quat, u: f64) -> Quat {
    let d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    let s = if d < 0.0 { -1.0 } else { 1.0 };
    let q = [
        a[0] + (s * b[0] - a[0]) * u,
        a[1] + (s * b[1] - a[1]) * u,
        a[2] + (s * b[2] - a[2]) * u,
        a[3] + (s * b[3] - a[3]) * u,
    ];
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if n > 0.0 {
        [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "t,x,y,z,qw,qx,qy,qz,buttons\n\
        0,0,0,0,1,0,0,0,0\n\
        0.5,0.01,0,0,1,0,0,0,1\n\
        1.0,0.02,0.01,0,0.7071067811865476,0,0.7071067811865476,0,3\n";

    fn err(text: &str) -> TraceError {
        Trace::parse(text, "t.csv").expect_err("should fail")
    }

    #[test]
    fn parses_good_trace() {
        let t = Trace::parse(GOOD, "t.csv").unwrap();
        assert_eq!(t.len(), 3);
        assert_eq!(t.name(), "t.csv");
        assert_eq!(t.samples()[2].buttons, 3);
        assert_eq!(t.time_span(), Some((0.0, 1.0)));
    }

    #[test]
    fn header_errors_name_line() {
        assert_eq!(
            err(""),
            TraceError {
                line: 1,
                kind: TraceErrorKind::MissingHeader
            }
        );
        assert_eq!(
            err("0,0,0,0,1,0,0,0,0\n").kind,
            TraceErrorKind::MissingHeader
        );
        assert_eq!(
            err("\nt,x,y,z,w,qx,qy,qz,buttons\n"),
            TraceError {
                line: 2,
                kind: TraceErrorKind::WrongHeader
            }
        );
        assert_eq!(
            err("t,x,y,z,qw,qx,qy,qz,buttons\n"),
            TraceError {
                line: 1,
                kind: TraceErrorKind::Empty
            }
        );
    }

    #[test]
    fn row_errors_name_line_and_reason() {
        let h = "t,x,y,z,qw,qx,qy,qz,buttons\n0,0,0,0,1,0,0,0,0\n";
        let cases: [(&str, TraceErrorKind); 9] = [
            ("1,0,0,0,1,0,0\n", TraceErrorKind::ShortRow { found: 7 }),
            ("1,0,0,0,1,0,0,0,0,9\n", TraceErrorKind::LongRow),
            (
                "1,0,abc,0,1,0,0,0,0\n",
                TraceErrorKind::NotANumber { column: 2 },
            ),
            (
                "1,0,0,NaN,1,0,0,0,0\n",
                TraceErrorKind::NonFinite { column: 3 },
            ),
            (
                "1,inf,0,0,1,0,0,0,0\n",
                TraceErrorKind::NonFinite { column: 1 },
            ),
            ("1,0,0,0,1,0,0,0,-1\n", TraceErrorKind::BadButtons),
            ("-1,0,0,0,1,0,0,0,0\n", TraceErrorKind::TimeBackwards),
            ("1,0,0,0,2,0,0,0,0\n", TraceErrorKind::QuaternionNotUnit),
            ("1,0,0,0,0,0,0,0,0\n", TraceErrorKind::ZeroQuaternion),
        ];
        for (row, kind) in cases {
            let e = err(&format!("{h}{row}"));
            assert_eq!(e, TraceError { line: 3, kind }, "row {row:?}");
        }
        let e = err(&format!("{h}\n# comment\n1,0,0,0,1,0,0,0,x\n"));
        assert_eq!(e.line, 5);
        assert_eq!(
            e.at("data/a.csv").to_string(),
            "data/a.csv:5: field `buttons` is not an unsigned integer"
        );
    }

    #[test]
    fn near_unit_quaternion_is_normalised() {
        let t = Trace::parse("t,x,y,z,qw,qx,qy,qz,buttons\n0,0,0,0,1.005,0,0,0,0\n", "n").unwrap();
        assert_eq!(t.samples()[0].rotation, [1.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn csv_round_trips_bit_exactly() {
        let mut t = Trace::new("rec");
        for i in 0..50 {
            let x = f64::from(i) * 0.001 + 1.0 / 3.0;
            t.push(TraceSample {
                t: f64::from(i) * 0.001,
                position: [x, -x * 7.0, 1e-9 * x],
                rotation: normalise_quat([1.0, 0.001 * x, 0.0, 0.0]).unwrap(),
                buttons: i as u32 % 3,
            })
            .unwrap();
        }
        let back = Trace::parse(&t.to_csv(), "rec").unwrap();
        // normalise_quat of an already normalised quaternion may move the last bit; compare
        // positions exactly and rotations to 1 ulp-ish.
        for (a, b) in t.samples().iter().zip(back.samples()) {
            assert_eq!(a.t.to_bits(), b.t.to_bits());
            assert_eq!(a.position.map(f64::to_bits), b.position.map(f64::to_bits));
            assert_eq!(a.buttons, b.buttons);
            for k in 0..4 {
                assert!((a.rotation[k] - b.rotation[k]).abs() < 1e-15);
            }
        }
        assert!(t
            .push(TraceSample {
                t: 0.0,
                ..t.samples()[0]
            })
            .is_err());
    }

    #[test]
    fn sample_at_interpolates() {
        let t = Trace::parse(GOOD, "t.csv").unwrap();
        let s = t.sample_at(0.25).unwrap();
        assert!((s.position[0] - 0.005).abs() < 1e-15);
        assert_eq!(s.buttons, 0);
        let s = t.sample_at(0.75).unwrap();
        assert!((s.position[0] - 0.015).abs() < 1e-15);
        assert!((s.position[1] - 0.005).abs() < 1e-15);
        assert_eq!(s.buttons, 1);
        // Halfway between identity and 90 deg about y: 45 deg about y.
        let q = s.rotation;
        let half = (core::f64::consts::PI / 8.0).cos();
        assert!((q[0] - half).abs() < 1e-12, "{q:?}");
        assert!((q[0] * q[0] + q[2] * q[2] - 1.0).abs() < 1e-12);
        // Clamped outside.
        assert_eq!(t.sample_at(-5.0).unwrap().position, [0.0; 3]);
        assert_eq!(t.sample_at(9.0).unwrap().buttons, 3);
        assert_eq!(t.sample_at(1.0).unwrap().buttons, 3);
    }
}
