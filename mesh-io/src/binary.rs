//! Reading binary mesh data: a [`Bytes`] cursor over a file's bytes that reads fixed-size
//! numbers in the file's byte order, checks every length and declared count against the bytes
//! that are left before anything is allocated, and names the byte offset in every error.

use std::path::Path;

use crate::text::one_line;
use crate::MeshError;

/// A cursor over (part of) a file's bytes.
#[derive(Debug, Clone)]
pub(crate) struct Bytes<'a> {
    path: &'a Path,
    data: &'a [u8],
    pos: usize,
    /// File offset of `data[0]`, for messages.
    base: usize,
    /// Numbers are big-endian.
    pub(crate) big: bool,
}

impl<'a> Bytes<'a> {
    /// A cursor over `data`, which starts at file offset `base`.
    pub(crate) fn new(path: &'a Path, data: &'a [u8], base: usize, big: bool) -> Self {
        Self {
            path,
            data,
            pos: 0,
            base,
            big,
        }
    }

    /// The file offset of the next byte.
    pub(crate) fn offset(&self) -> usize {
        self.base + self.pos
    }

    /// Bytes left.
    pub(crate) fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    /// Whether every byte has been read.
    pub(crate) fn at_end(&self) -> bool {
        self.pos >= self.data.len()
    }

    /// The bytes not yet read.
    pub(crate) fn rest(&self) -> &'a [u8] {
        &self.data[self.pos..]
    }

    /// Moves to file offset `offset` (at most the end).
    pub(crate) fn seek(&mut self, offset: usize) -> Result<(), MeshError> {
        match offset.checked_sub(self.base) {
            Some(p) if p <= self.data.len() => {
                self.pos = p;
                Ok(())
            }
            _ => Err(self.err_at(
                self.offset(),
                format!(
                    "position {offset} is outside the file ({} bytes)",
                    self.base + self.data.len()
                ),
            )),
        }
    }

    /// An error at file offset `at`.
    pub(crate) fn err_at(&self, at: usize, reason: impl std::fmt::Display) -> MeshError {
        MeshError::at_byte(self.path, at as u64, one_line(&reason.to_string()))
    }

    /// An error at the current offset.
    pub(crate) fn err(&self, reason: impl std::fmt::Display) -> MeshError {
        self.err_at(self.offset(), reason)
    }

    /// The next `n` bytes; fewer left is a "truncated" error naming `what`.
    pub(crate) fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], MeshError> {
        if n > self.remaining() {
            return Err(self.err(format!(
                "unexpected end of file (truncated?): {what} needs {n} bytes, {} left",
                self.remaining()
            )));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], MeshError> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N, what)?);
        if self.big != cfg!(target_endian = "big") {
            a.reverse();
        }
        Ok(a)
    }

    /// A 32-bit signed integer.
    pub(crate) fn i32(&mut self, what: &str) -> Result<i32, MeshError> {
        Ok(i32::from_ne_bytes(self.array(what)?))
    }

    /// A 64-bit signed integer.
    pub(crate) fn i64(&mut self, what: &str) -> Result<i64, MeshError> {
        Ok(i64::from_ne_bytes(self.array(what)?))
    }

    /// An unsigned integer of `size` bytes (4 or 8).
    pub(crate) fn uint(&mut self, size: usize, what: &str) -> Result<u64, MeshError> {
        if size == 4 {
            Ok(u32::from_ne_bytes(self.array(what)?) as u64)
        } else {
            Ok(u64::from_ne_bytes(self.array(what)?))
        }
    }

    /// A signed integer of `size` bytes (4 or 8).
    pub(crate) fn int(&mut self, size: usize, what: &str) -> Result<i64, MeshError> {
        if size == 4 {
            Ok(self.i32(what)? as i64)
        } else {
            self.i64(what)
        }
    }

    /// A float of `size` bytes (4 or 8); NaN and infinities are refused.
    pub(crate) fn float(&mut self, size: usize, what: &str) -> Result<f64, MeshError> {
        let at = self.offset();
        let v = if size == 4 {
            f32::from_ne_bytes(self.array(what)?) as f64
        } else {
            f64::from_ne_bytes(self.array(what)?)
        };
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err_at(at, format!("NaN or infinite {what}")))
        }
    }

    /// Checks a declared count of records of at least `per` bytes each against the bytes left,
    /// before anything is allocated for them.
    pub(crate) fn count(&self, declared: u64, per: usize, what: &str) -> Result<usize, MeshError> {
        let room = self.remaining() as u64;
        match declared.checked_mul(per.max(1) as u64) {
            Some(need) if need <= room && declared < u32::MAX as u64 => Ok(declared as usize),
            _ => Err(self.err(format!(
                "declares {declared} {what}, more than the rest of the file can hold (at most {})",
                room / per.max(1) as u64
            ))),
        }
    }

    /// The next line (without its `\n` and any `\r`), or `None` at the end.
    pub(crate) fn line(&mut self) -> Option<&'a [u8]> {
        if self.at_end() {
            return None;
        }
        let rest = self.rest();
        let (line, used) = match rest.iter().position(|&b| b == b'\n') {
            Some(i) => (&rest[..i], i + 1),
            None => (rest, rest.len()),
        };
        self.pos += used;
        Some(line.strip_suffix(b"\r").unwrap_or(line))
    }

    /// Skips ASCII whitespace.
    pub(crate) fn skip_space(&mut self) {
        while self.pos < self.data.len() && self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
    }
}

/// Text of a line or token for a message (lossy, control characters escaped, shortened).
pub(crate) fn show(b: &[u8]) -> String {
    crate::text::short(&String::from_utf8_lossy(b))
}
