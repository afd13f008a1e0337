//! Reading text mesh files: the file as one checked string, and a [`Cursor`] that hands out
//! tokens or whole lines with their line numbers, so every error names `FILE:LINE`.

use std::path::Path;
use std::str::SplitAsciiWhitespace;

use crate::MeshError;

/// Reads a whole file as text (decompressed when its name ends in `.gz`). Empty files, files with NUL bytes and files that are not UTF-8
/// are refused (`binary {format} files are not supported`), naming the first bad line.
pub(crate) fn read_text(path: &Path, format: &str) -> Result<String, MeshError> {
    text_from(path, crate::source::read_file(path)?, format)
}

/// [`read_text`] for bytes already read (and decompressed).
pub(crate) fn text_from(path: &Path, bytes: Vec<u8>, format: &str) -> Result<String, MeshError> {
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(MeshError::at(path, None, "empty file"));
    }
    let bad = match std::str::from_utf8(&bytes) {
        Ok(s) => s.bytes().position(|b| b == 0),
        Err(e) => Some(e.valid_up_to()),
    };
    if let Some(at) = bad {
        let line = 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
        return Err(MeshError::at(
            path,
            Some(line),
            format!("binary data in a text {format} file"),
        ));
    }
    String::from_utf8(bytes).map_err(|_| MeshError::at(path, None, "not UTF-8 text"))
}

/// Line number (1-based) of byte offset `at` in `text`.
pub(crate) fn line_of(text: &str, at: usize) -> usize {
    1 + text.as_bytes()[..at.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

/// Tokens a line keeps without allocating (a tet's line has five to nine).
const INLINE_TOKENS: usize = 16;

/// The tokens of one line, as a slice: up to [`INLINE_TOKENS`] held inline, a longer line's in
/// a `Vec`. Millions of lines are read without an allocation each.
// The inline variant is the point: it lives on the stack, one per line read.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub(crate) enum Tokens<'a> {
    /// A line of at most [`INLINE_TOKENS`] tokens: the first `.1` of the array.
    Inline([&'a str; INLINE_TOKENS], usize),
    /// A longer line.
    Heap(Vec<&'a str>),
}

impl<'a> Tokens<'a> {
    fn of(mut it: impl Iterator<Item = &'a str>) -> Self {
        let mut a = [""; INLINE_TOKENS];
        let mut n = 0;
        while n < INLINE_TOKENS {
            match it.next() {
                Some(t) => {
                    a[n] = t;
                    n += 1;
                }
                None => return Self::Inline(a, n),
            }
        }
        match it.next() {
            None => Self::Inline(a, n),
            Some(t) => {
                let mut v = a.to_vec();
                v.push(t);
                v.extend(it);
                Self::Heap(v)
            }
        }
    }
}

impl<'a, 'b> IntoIterator for &'b Tokens<'a> {
    type Item = &'b &'a str;
    type IntoIter = std::slice::Iter<'b, &'a str>;

    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<'a> std::ops::Deref for Tokens<'a> {
    type Target = [&'a str];

    fn deref(&self) -> &[&'a str] {
        match self {
            Self::Inline(a, n) => &a[..*n],
            Self::Heap(v) => v,
        }
    }
}

/// Tokens and lines of a text, with line numbers and optional comments to end of line.
#[derive(Debug)]
pub(crate) struct Cursor<'a> {
    path: &'a Path,
    text: &'a str,
    /// Byte offset of the first line not yet loaded.
    pos: usize,
    /// Number of the line held in `cur` (0 before the first).
    line_no: usize,
    cur: SplitAsciiWhitespace<'a>,
    comment: Option<char>,
}

impl<'a> Cursor<'a> {
    /// A cursor over `text`, whose first line is line `first_line` of the file `path`.
    pub(crate) fn new(
        path: &'a Path,
        text: &'a str,
        first_line: usize,
        comment: Option<char>,
    ) -> Self {
        Self {
            path,
            text,
            pos: 0,
            line_no: first_line.saturating_sub(1),
            cur: "".split_ascii_whitespace(),
            comment,
        }
    }

    /// Loads the next line into `cur`; `false` at the end of the text.
    fn advance(&mut self) -> bool {
        if self.pos >= self.text.len() {
            self.cur = "".split_ascii_whitespace();
            return false;
        }
        let rest = &self.text[self.pos..];
        let (line, used) = match rest.find('\n') {
            Some(i) => (&rest[..i], i + 1),
            None => (rest, rest.len()),
        };
        self.pos += used;
        self.line_no += 1;
        let line = match self.comment.and_then(|c| line.find(c)) {
            Some(i) => &line[..i],
            None => line,
        };
        self.cur = line.split_ascii_whitespace();
        true
    }

    /// The next token and its line, or `None` at the end.
    pub(crate) fn token(&mut self) -> Option<(&'a str, usize)> {
        loop {
            if let Some(t) = self.cur.next() {
                return Some((t, self.line_no));
            }
            if !self.advance() {
                return None;
            }
        }
    }

    /// Drops what is left of the current line and returns the tokens of the next line that has
    /// any, with its number; `None` at the end.
    pub(crate) fn line(&mut self) -> Option<(usize, Tokens<'a>)> {
        loop {
            if !self.advance() {
                return None;
            }
            let toks = Tokens::of(self.cur.clone());
            if !toks.is_empty() {
                self.cur = "".split_ascii_whitespace();
                return Some((self.line_no, toks));
            }
        }
    }

    /// [`Cursor::line`] for the hot loops of large files: hands the next line's tokens to `f`
    /// as a slice on the stack, without moving them (`None` at the end). `f` gets the cursor
    /// back for its errors.
    pub(crate) fn with_line<R>(
        &mut self,
        f: impl FnOnce(&Self, usize, &[&'a str]) -> R,
    ) -> Option<R> {
        loop {
            if !self.advance() {
                return None;
            }
            let mut a = [""; INLINE_TOKENS];
            let mut n = 0;
            let mut it = self.cur.clone();
            for slot in a.iter_mut() {
                match it.next() {
                    Some(t) => {
                        *slot = t;
                        n += 1;
                    }
                    None => break,
                }
            }
            if n == 0 {
                continue;
            }
            self.cur = "".split_ascii_whitespace();
            return Some(match it.next() {
                None => f(self, self.line_no, &a[..n]),
                Some(t) => {
                    let mut v = a.to_vec();
                    v.push(t);
                    v.extend(it);
                    f(self, self.line_no, &v)
                }
            });
        }
    }

    /// Like [`Cursor::line`], but the end of the text is an error naming `what` was expected.
    pub(crate) fn need_line(&mut self, what: &str) -> Result<(usize, Tokens<'a>), MeshError> {
        match self.line() {
            Some(l) => Ok(l),
            None => Err(self.eof(what)),
        }
    }

    /// The next token; the end of the text is an error naming `what` was expected.
    pub(crate) fn need(&mut self, what: &str) -> Result<(&'a str, usize), MeshError> {
        match self.token() {
            Some(t) => Ok(t),
            None => Err(self.eof(what)),
        }
    }

    /// Bytes not yet read (an upper bound for what the rest of the file can hold).
    pub(crate) fn remaining_bytes(&self) -> usize {
        self.text.len() - self.pos + self.cur.clone().map(|t| t.len() + 1).sum::<usize>()
    }

    /// Error at a line of this file.
    pub(crate) fn err(&self, line: usize, reason: impl std::fmt::Display) -> MeshError {
        MeshError::at(
            self.path,
            (line > 0).then_some(line),
            one_line(&reason.to_string()),
        )
    }

    /// "Truncated" error at the last line.
    pub(crate) fn eof(&self, what: &str) -> MeshError {
        self.err(
            self.line_no.max(1),
            format!("unexpected end of file (truncated?): expected {what}"),
        )
    }

    /// Checks a declared record count against the bytes left before anything is allocated:
    /// each record has at least `min_tokens` tokens of at least one byte plus a separator.
    pub(crate) fn count(
        &self,
        declared: u64,
        min_tokens: usize,
        what: &str,
        line: usize,
    ) -> Result<usize, MeshError> {
        let per = 2 * min_tokens.max(1) as u64;
        let room = self.remaining_bytes() as u64 + 1;
        match declared.checked_mul(per) {
            Some(need) if need <= room && declared < u32::MAX as u64 => Ok(declared as usize),
            _ => Err(self.err(
                line,
                format!(
                    "declares {declared} {what}, more than the rest of the file can hold \
                     (at most {})",
                    room / per
                ),
            )),
        }
    }

    /// The next token as an unsigned integer.
    pub(crate) fn uint(&mut self, what: &str) -> Result<(u64, usize), MeshError> {
        let (t, l) = self.need(what)?;
        Ok((parse_uint(self, t, l, what)?, l))
    }

    /// The next token as a finite float.
    pub(crate) fn float(&mut self, what: &str) -> Result<f64, MeshError> {
        let (t, l) = self.need(what)?;
        parse_float(self, t, l, what)
    }
}

/// Parses an unsigned integer token.
pub(crate) fn parse_uint(
    c: &Cursor<'_>,
    t: &str,
    line: usize,
    what: &str,
) -> Result<u64, MeshError> {
    t.parse::<u64>().map_err(|_| {
        c.err(
            line,
            format!(
                "expected {what} (a non-negative integer), found '{}'",
                short(t)
            ),
        )
    })
}

/// Parses a signed integer token (node indices, which may be 0 or negative in a bad file).
pub(crate) fn parse_int(
    c: &Cursor<'_>,
    t: &str,
    line: usize,
    what: &str,
) -> Result<i64, MeshError> {
    fast_int(t)
        .or_else(|| t.parse::<i64>().ok())
        .ok_or_else(|| {
            c.err(
                line,
                format!("expected {what} (an integer), found '{}'", short(t)),
            )
        })
}

/// An optional sign and at most 18 ASCII digits (no overflow possible), the common case of
/// a mesh file's integers, without `str::parse`'s generality; `None` for anything else (the
/// caller falls back to `str::parse`, so the accepted set is the same).
fn fast_int(t: &str) -> Option<i64> {
    let b = t.as_bytes();
    let (neg, digits) = match b.first() {
        Some(b'-') => (true, &b[1..]),
        Some(b'+') => (false, &b[1..]),
        _ => (false, b),
    };
    if digits.is_empty() || digits.len() > 18 {
        return None;
    }
    let mut v = 0i64;
    for &c in digits {
        let d = c.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        v = v * 10 + d as i64;
    }
    Some(if neg { -v } else { v })
}

/// Parses a float token and refuses NaN and infinities.
pub(crate) fn parse_float(
    c: &Cursor<'_>,
    t: &str,
    line: usize,
    what: &str,
) -> Result<f64, MeshError> {
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(c.err(line, format!("NaN or infinite {what} '{}'", short(t)))),
        Err(_) => Err(c.err(
            line,
            format!("expected {what} (a number), found '{}'", short(t)),
        )),
    }
}

/// Three coordinates from three tokens.
pub(crate) fn parse_xyz(c: &Cursor<'_>, t: &[&str], line: usize) -> Result<[f64; 3], MeshError> {
    Ok([
        parse_float(c, t[0], line, "coordinate")?,
        parse_float(c, t[1], line, "coordinate")?,
        parse_float(c, t[2], line, "coordinate")?,
    ])
}

/// A reason with its control characters escaped, so an error stays one line whatever the
/// file held.
pub(crate) fn one_line(reason: &str) -> String {
    if reason.chars().any(char::is_control) {
        reason
            .chars()
            .flat_map(|c| {
                if c.is_control() {
                    c.escape_default().collect()
                } else {
                    vec![c]
                }
            })
            .collect()
    } else {
        reason.to_string()
    }
}

/// A token for a message: control characters escaped (so the message stays one line) and cut
/// to a printable length.
pub(crate) fn short(t: &str) -> String {
    let mut out = String::new();
    for (k, ch) in t.chars().enumerate() {
        if k == 24 {
            out.push_str("...");
            break;
        }
        if ch.is_control() {
            out.extend(ch.escape_default());
        } else {
            out.push(ch);
        }
    }
    out
}

/// Converts node numbers of one tet from a file's numbering (first node `base`) to 0-based
/// ids, refusing 0 in a 1-based file and anything past the last node.
pub(crate) fn node_ids(
    c: &Cursor<'_>,
    raw: [i64; 4],
    base: i64,
    nodes: usize,
    line: usize,
) -> Result<[u32; 4], MeshError> {
    let mut out = [0u32; 4];
    for (o, &v) in out.iter_mut().zip(raw.iter()) {
        let last = base + nodes as i64 - 1;
        if v < base || v > last {
            let reason = if v == 0 && base == 1 {
                format!("node index 0 in a 1-based file (nodes are numbered 1..{last})")
            } else {
                format!("node index {v} out of range (nodes are numbered {base}..{last})")
            };
            return Err(c.err(line, reason));
        }
        *o = (v - base) as u32;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_of_any_length_give_their_tokens_in_order() {
        for n in [
            1usize,
            5,
            INLINE_TOKENS - 1,
            INLINE_TOKENS,
            INLINE_TOKENS + 1,
            40,
        ] {
            let words: Vec<String> = (0..n).map(|i| format!("w{i}")).collect();
            let text = format!("\n  # nothing\n{}  # tail\n", words.join(" \t "));
            let mut c = Cursor::new(Path::new("t"), &text, 1, Some('#'));
            let (line, toks) = c.line().expect("a line");
            assert_eq!(line, 3);
            assert_eq!(toks.len(), n);
            assert!(toks.iter().zip(&words).all(|(a, b)| a == b), "{n}");
            assert!(matches!(toks, Tokens::Inline(..)) == (n <= INLINE_TOKENS));
            assert!(c.line().is_none());
        }
    }

    #[test]
    fn fast_integers_agree_with_str_parse() {
        let mut cases: Vec<String> = ["0", "-0", "+7", "-", "+", "", "12a", "1.0", " 1", "٣"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        for k in 0..=19 {
            let n = 10i64.pow(k.min(18)) - 1 + (k as i64);
            cases.push(n.to_string());
            cases.push(format!("-{n}"));
            cases.push(format!("+{n}"));
        }
        cases.push(i64::MAX.to_string());
        cases.push(i64::MIN.to_string());
        cases.push("9223372036854775808".into());
        for t in &cases {
            let fast = fast_int(t).or_else(|| t.parse::<i64>().ok());
            assert_eq!(fast, t.parse::<i64>().ok(), "{t:?}");
        }
    }
}
