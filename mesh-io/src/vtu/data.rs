//! Data arrays of a `.vtu` file: ASCII, inline base64 and appended (raw or base64) data, size
//! headers, compressed block tables (zlib, LZ4, LZMA) and byte order, decoded into numbers.

use std::io::Read;
use std::path::Path;

use base64::Engine;

use super::super::text::{line_of, one_line, parse_float, parse_int, short, Cursor};
use crate::MeshError;

/// A `DataArray` as declared: its attributes and where its data is.
#[derive(Debug, Clone, Default)]
pub(super) struct Array<'a> {
    pub(super) name: &'a str,
    pub(super) ty: &'a str,
    pub(super) format: &'a str,
    pub(super) comps: &'a str,
    /// `offset` attribute (appended arrays).
    pub(super) offset: Option<&'a str>,
    /// Byte offset of the tag in the text.
    pub(super) tag: usize,
    /// Byte range of the element's content in the text.
    pub(super) content: (usize, usize),
}

/// The compressor named by the `VTKFile` element.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Compressor {
    None,
    Zlib,
    Lz4,
    Lzma,
}

impl Compressor {
    pub(super) fn name(self) -> &'static str {
        match self {
            Compressor::None => "uncompressed",
            Compressor::Zlib => "zlib",
            Compressor::Lz4 => "lz4",
            Compressor::Lzma => "lzma",
        }
    }
}

/// What every array of the file shares.
pub(super) struct Ctx<'a> {
    pub(super) path: &'a Path,
    /// The file up to the appended data (all of it without one), as text.
    pub(super) text: &'a str,
    pub(super) big: bool,
    pub(super) header: usize,
    pub(super) compressor: Compressor,
    /// The appended data (after its `_` marker), its file offset and whether it is base64.
    pub(super) appended: Option<(&'a [u8], usize, bool)>,
    /// Every appended array's offset, sorted (a base64 array ends where the next begins).
    pub(super) appended_offsets: Vec<usize>,
}

/// Numbers of one array.
pub(super) enum Values {
    Float(Vec<f64>),
    Int(Vec<i64>),
}

/// Bytes per value of a VTK type name, and whether it is a float.
pub(super) fn type_size(ty: &str) -> Option<(usize, bool)> {
    Some(match ty {
        "Int8" | "UInt8" => (1, false),
        "Int16" | "UInt16" => (2, false),
        "Int32" | "UInt32" => (4, false),
        "Int64" | "UInt64" => (8, false),
        "Float32" => (4, true),
        "Float64" => (8, true),
        _ => return None,
    })
}

/// Decodes base64 made of one or more padded pieces (VTK encodes a compressed array's
/// header and its data separately), whitespace ignored.
pub(super) fn base64_pieces(s: &[u8]) -> Result<Vec<u8>, String> {
    let clean: Vec<u8> = s
        .iter()
        .copied()
        .filter(|b| !b.is_ascii_whitespace())
        .collect();
    let mut out = Vec::with_capacity(clean.len() / 4 * 3);
    let mut from = 0;
    let mut k = 0;
    while k < clean.len() {
        // A piece ends after the 4-character group that holds padding, or at the end.
        let group_end = (k + 4).min(clean.len());
        if clean[k..group_end].contains(&b'=') || group_end == clean.len() {
            base64::engine::general_purpose::STANDARD
                .decode_vec(&clean[from..group_end], &mut out)
                .map_err(|e| format!("bad base64 data (character {} of the array): {e}", from))?;
            from = group_end;
        }
        k = group_end;
    }
    Ok(out)
}

impl Ctx<'_> {
    /// An error about array `a`, at its line.
    pub(super) fn err(&self, a: &Array<'_>, reason: impl std::fmt::Display) -> MeshError {
        MeshError::at(
            self.path,
            Some(line_of(self.text, a.tag)),
            one_line(&format!("DataArray '{}': {reason}", short(a.name))),
        )
    }

    /// The values of array `a`.
    pub(super) fn values(&self, a: &Array<'_>) -> Result<Values, MeshError> {
        self.values_lines(a, None)
    }

    /// The values of array `a`, and for an ASCII array the line of each when `lines` is given.
    pub(super) fn values_lines(
        &self,
        a: &Array<'_>,
        lines: Option<&mut Vec<usize>>,
    ) -> Result<Values, MeshError> {
        let Some((size, float)) = type_size(a.ty) else {
            return Err(self.err(
                a,
                format!("type \"{}\" is not a VTK number type", short(a.ty)),
            ));
        };
        if a.format == "ascii" {
            return self.ascii(a, float, lines);
        }
        let (bytes, base) = match a.format {
            "binary" => {
                let s = &self.text.as_bytes()[a.content.0..a.content.1];
                (base64_pieces(s).map_err(|e| self.err(a, e))?, None)
            }
            _ => {
                let Some((data, start, b64)) = self.appended else {
                    return Err(
                        self.err(a, "format=\"appended\" but the file has no <AppendedData>")
                    );
                };
                let off: usize = a.offset.and_then(|o| o.parse().ok()).unwrap_or(0);
                if off > data.len() {
                    return Err(self.err(
                        a,
                        format!(
                            "offset {off} is past the end of the appended data ({} bytes)",
                            data.len()
                        ),
                    ));
                }
                if b64 {
                    let end = self
                        .appended_offsets
                        .iter()
                        .find(|&&o| o > off)
                        .copied()
                        .unwrap_or(data.len())
                        .min(data.len());
                    (
                        base64_pieces(&data[off..end]).map_err(|e| self.err(a, e))?,
                        None,
                    )
                } else {
                    (data[off..].to_vec(), Some(start + off))
                }
            }
        };
        let raw = self.block(a, &bytes, base)?;
        if raw.len() % size != 0 {
            return Err(self.err(
                a,
                format!(
                    "{} bytes of data is not a whole number of {size}-byte values",
                    raw.len()
                ),
            ));
        }
        let mut r = crate::binary::Bytes::new(self.path, &raw, 0, self.big);
        let n = raw.len() / size;
        if float {
            let mut v = Vec::with_capacity(n);
            for _ in 0..n {
                v.push(
                    r.float(size, "value")
                        .map_err(|_| self.err(a, "NaN or infinite value"))?,
                );
            }
            Ok(Values::Float(v))
        } else {
            let unsigned = a.ty.starts_with('U');
            let mut v = Vec::with_capacity(n);
            for _ in 0..n {
                let x = match (size, unsigned) {
                    (1, false) => r.take(1, "value")?[0] as i8 as i64,
                    (1, true) => r.take(1, "value")?[0] as i64,
                    (2, _) => {
                        let b = r.take(2, "value")?;
                        let b = [b[0], b[1]];
                        match (self.big, unsigned) {
                            (false, false) => i16::from_le_bytes(b) as i64,
                            (false, true) => u16::from_le_bytes(b) as i64,
                            (true, false) => i16::from_be_bytes(b) as i64,
                            (true, true) => u16::from_be_bytes(b) as i64,
                        }
                    }
                    (4, true) => r.uint(4, "value")? as i64,
                    (4, false) => r.int(4, "value")?,
                    (_, true) => {
                        let u = r.uint(8, "value")?;
                        i64::try_from(u).map_err(|_| self.err(a, format!("value {u} too large")))?
                    }
                    _ => r.int(8, "value")?,
                };
                v.push(x);
            }
            Ok(Values::Int(v))
        }
    }

    /// An ASCII array, and the line of each value when `lines` is given.
    pub(super) fn ascii(
        &self,
        a: &Array<'_>,
        float: bool,
        mut lines: Option<&mut Vec<usize>>,
    ) -> Result<Values, MeshError> {
        let (s, e) = a.content;
        let mut c = Cursor::new(self.path, &self.text[s..e], line_of(self.text, s), None);
        if float {
            let mut v = Vec::new();
            while let Some((t, l)) = c.token() {
                v.push(parse_float(&c, t, l, "a number")?);
            }
            Ok(Values::Float(v))
        } else {
            let mut v = Vec::new();
            while let Some((t, l)) = c.token() {
                v.push(parse_int(&c, t, l, "an integer")?);
                if let Some(lines) = lines.as_deref_mut() {
                    lines.push(l);
                }
            }
            Ok(Values::Int(v))
        }
    }

    /// One binary array's data: its size header and data, or its block table and the
    /// decompressed blocks. `base` is the file offset of `bytes` for raw appended data.
    pub(super) fn block(
        &self,
        a: &Array<'_>,
        bytes: &[u8],
        base: Option<usize>,
    ) -> Result<Vec<u8>, MeshError> {
        let path = self.path;
        let mut r = crate::binary::Bytes::new(path, bytes, base.unwrap_or(0), self.big);
        // Errors inside inline data name the array's line; inside raw appended data, the byte.
        // Errors from the cursor read `FILE: byte N: reason`: inside raw appended data they
        // keep the byte and gain the array's name; inside inline data they name the array's
        // line and the byte of the decoded data.
        let wrap = |e: MeshError, r: &crate::binary::Bytes<'_>| {
            let m = &e.message;
            let (off, reason) = m
                .find(": byte ")
                .and_then(|i| m[i + 7..].split_once(": "))
                .map_or(("", m.as_str()), |(o, r)| (o, r));
            match (base, off.parse::<u64>()) {
                (Some(_), Ok(off)) => MeshError::at_byte(
                    path,
                    off,
                    format!("DataArray '{}': {reason}", short(a.name)),
                ),
                _ => self.err(
                    a,
                    format!("{reason} (at byte {} of the decoded data)", r.offset()),
                ),
            }
        };
        let h = self.header;
        if self.compressor == Compressor::None {
            let n = r.uint(h, "the data size header").map_err(|e| wrap(e, &r))?;
            let n = usize::try_from(n).unwrap_or(usize::MAX);
            return match r.take(n, "the array data") {
                Ok(d) => Ok(d.to_vec()),
                Err(e) => Err(wrap(e, &r)),
            };
        }
        let table = (|| {
            let nb = r.uint(h, "the number of compressed blocks")?;
            let bs = r.uint(h, "the block size")?;
            let last = r.uint(h, "the last block size")?;
            let nb = r.count(nb, h, "compressed blocks")?;
            let mut sizes = Vec::with_capacity(nb);
            for _ in 0..nb {
                sizes.push(r.uint(h, "a compressed block size")?);
            }
            Ok((nb, bs, last, sizes))
        })();
        let (nb, bs, last, sizes) = table.map_err(|e| wrap(e, &r))?;
        let total: u64 = sizes.iter().fold(0u64, |s, &x| s.saturating_add(x));
        if total > r.remaining() as u64 {
            return Err(wrap(
                r.err(format!(
                    "the {nb} compressed blocks claim {total} bytes, {} are left (truncated?)",
                    r.remaining()
                )),
                &r,
            ));
        }
        let mut out = Vec::new();
        for (k, &cs) in sizes.iter().enumerate() {
            let at = r.offset();
            let comp = r
                .take(cs as usize, "a compressed block")
                .map_err(|e| wrap(e, &r))?;
            let want = if k + 1 == nb && last != 0 { last } else { bs };
            let got = decompress(self.compressor, comp, want).map_err(|why| {
                let what = format!(
                    "{} block {} of {nb} (compressed bytes {at}..{}): {why}",
                    self.compressor.name(),
                    k + 1,
                    at + cs as usize
                );
                match base {
                    Some(_) => MeshError::at_byte(
                        path,
                        at as u64,
                        one_line(&format!("DataArray '{}': {what}", short(a.name))),
                    ),
                    None => self.err(a, what),
                }
            })?;
            out.extend_from_slice(&got);
        }
        Ok(out)
    }
}

/// Decompresses one block that must expand to exactly `want` bytes. The output grows with
/// what the block really holds (LZ4, which needs its size first, is checked against the
/// format's largest ratio before anything is allocated).
pub(super) fn decompress(c: Compressor, comp: &[u8], want: u64) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    match c {
        Compressor::None => out.extend_from_slice(comp),
        Compressor::Zlib => {
            flate2::read::ZlibDecoder::new(comp)
                .take(want.saturating_add(1))
                .read_to_end(&mut out)
                .map_err(|e| format!("corrupt zlib data: {e}"))?;
        }
        Compressor::Lz4 => {
            // An LZ4 block expands at most 255 times (plus a little).
            if want > (comp.len() as u64).saturating_mul(255).saturating_add(16) {
                return Err(format!(
                    "claims {want} bytes from {} compressed, more than LZ4 can hold",
                    comp.len()
                ));
            }
            out = lz4_flex::block::decompress(comp, want as usize)
                .map_err(|e| format!("corrupt lz4 data: {e}"))?;
        }
        Compressor::Lzma => {
            // The decoder holds a whole LZMA2 run in memory before handing it on: the sizes
            // the chunk headers declare are checked against the table first.
            match xz_declared_size(comp) {
                Some(n) if n <= want => {}
                Some(n) => {
                    return Err(format!(
                        "its xz chunks declare {n} bytes, the block table says {want}"
                    ))
                }
                None => return Err("not an xz stream of LZMA2 chunks (truncated?)".into()),
            }
            let mut input = comp;
            let mut w = Limited {
                out: &mut out,
                limit: want,
            };
            lzma_rs::xz_decompress(&mut input, &mut w)
                .map_err(|e| format!("corrupt lzma (xz) data: {e}"))?;
        }
    }
    if out.len() as u64 != want {
        return Err(format!(
            "expands to {}{} bytes, the block table says {want}",
            out.len(),
            if out.len() as u64 > want {
                " or more"
            } else {
                ""
            }
        ));
    }
    Ok(out)
}

/// The uncompressed size that the LZMA2 chunk headers of an xz stream declare, read without
/// decoding (stream header, then per block: its header, the chunks, padding and check, until
/// the index); `None` when the bytes are not laid out so.
pub(super) fn xz_declared_size(x: &[u8]) -> Option<u64> {
    if x.len() < 12 || &x[..6] != b"\xFD7zXZ\x00" {
        return None;
    }
    let check = match x[7] & 0x0f {
        0 => 0,
        id => 4usize << ((id - 1) / 3),
    };
    let be16 = |p: usize| Some(u16::from_be_bytes([*x.get(p)?, *x.get(p + 1)?]) as u64);
    let mut p = 12usize;
    let mut total = 0u64;
    loop {
        let block = p;
        let h = *x.get(p)?;
        if h == 0 {
            // The index: no more blocks.
            return Some(total);
        }
        p = p.checked_add((h as usize + 1) * 4)?;
        loop {
            let c = *x.get(p)?;
            p += 1;
            match c {
                0 => break,
                1 | 2 => {
                    let n = be16(p)? + 1;
                    total = total.checked_add(n)?;
                    p = p.checked_add(2 + n as usize)?;
                }
                0x80..=0xff => {
                    let unpacked = (((c & 0x1f) as u64) << 16) + be16(p)? + 1;
                    let packed = be16(p + 2)? as usize + 1;
                    total = total.checked_add(unpacked)?;
                    p = p.checked_add(4 + usize::from(c >= 0xc0) + packed)?;
                }
                _ => return None,
            }
        }
        // Block padding to a multiple of four, then the check.
        p = p
            .checked_add((4 - (p - block) % 4) % 4)?
            .checked_add(check)?;
    }
}

/// A writer that refuses to grow past `limit` bytes.
pub(super) struct Limited<'a> {
    pub(super) out: &'a mut Vec<u8>,
    pub(super) limit: u64,
}

impl std::io::Write for Limited<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.out.len() as u64 + buf.len() as u64 > self.limit {
            return Err(std::io::Error::other("more data than the block table says"));
        }
        self.out.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An xz stream as Python's `lzma.compress(bytes(1000), format=lzma.FORMAT_XZ)` writes it
    /// (the framing of VTK's LZMA compressor): 1000 zero bytes.
    const ZEROS_1000: &[u8] = &[
        0xfd, 0x37, 0x7a, 0x58, 0x5a, 0x00, 0x00, 0x04, 0xe6, 0xd6, 0xb4, 0x46, 0x02, 0x00, 0x21,
        0x01, 0x16, 0x00, 0x00, 0x00, 0x74, 0x2f, 0xe5, 0xa3, 0xe0, 0x03, 0xe7, 0x00, 0x0b, 0x5d,
        0x00, 0x00, 0x6f, 0xfd, 0xff, 0xff, 0xa3, 0xb7, 0x5a, 0x0d, 0x5e, 0x00, 0x00, 0x00, 0x4f,
        0x25, 0x8a, 0xec, 0x2b, 0xe2, 0x2a, 0x37, 0x00, 0x01, 0x27, 0xe8, 0x07, 0x00, 0x00, 0x00,
        0xf4, 0x55, 0x8f, 0x5c, 0xb1, 0xc4, 0x67, 0xfb, 0x02, 0x00, 0x00, 0x00, 0x00, 0x04, 0x59,
        0x5a,
    ];

    #[test]
    fn xz_chunk_sizes_are_read_before_decoding() {
        assert_eq!(xz_declared_size(ZEROS_1000), Some(1000));
        let out = decompress(Compressor::Lzma, ZEROS_1000, 1000).unwrap();
        assert_eq!(out, vec![0u8; 1000]);
        // A table that says less than the chunks hold: refused before anything is decoded.
        let e = decompress(Compressor::Lzma, ZEROS_1000, 999).unwrap_err();
        assert!(e.contains("declare 1000 bytes"), "{e}");
        // Cut anywhere: refused, never a panic.
        for cut in 0..ZEROS_1000.len() {
            assert!(decompress(Compressor::Lzma, &ZEROS_1000[..cut], 1000).is_err());
        }
    }
}
