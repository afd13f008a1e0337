//! A mesh file's bytes: read whole, and decompressed when its name ends in `.gz` (gzip, one
//! or more members), so every reader sees the file as written.

use std::io::Read;
use std::path::{Path, PathBuf};

use flate2::read::MultiGzDecoder;

use crate::MeshError;

/// The most a `.gz` file may expand to (4 GiB): past it the file is refused rather than read
/// without bound.
pub const MAX_GUNZIPPED: u64 = 4 << 30;

/// The path without a trailing `.gz` (the name whose extension gives the format), and whether
/// it had one.
pub(crate) fn strip_gz(path: &Path) -> (PathBuf, bool) {
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("gz") => (path.with_extension(""), true),
        _ => (path.to_path_buf(), false),
    }
}

/// Reads a whole file; a `.gz` file is decompressed (an error says how many bytes came out
/// before the stream broke).
pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>, MeshError> {
    let bytes =
        std::fs::read(path).map_err(|e| MeshError::at(path, None, format!("cannot read: {e}")))?;
    if !strip_gz(path).1 {
        return Ok(bytes);
    }
    gunzip(path, &bytes)
}

/// Decompresses a gzip file held in memory. The output grows with what the stream really
/// holds (nothing is allocated from a size the file claims), up to [`MAX_GUNZIPPED`].
pub(crate) fn gunzip(path: &Path, bytes: &[u8]) -> Result<Vec<u8>, MeshError> {
    if bytes.len() < 2 || bytes[0] != 0x1f || bytes[1] != 0x8b {
        return Err(MeshError::at(
            path,
            None,
            "not a gzip file (the name ends in .gz but the data does not start with the gzip magic 1f 8b)",
        ));
    }
    let mut out = Vec::new();
    let res = MultiGzDecoder::new(bytes)
        .take(MAX_GUNZIPPED + 1)
        .read_to_end(&mut out);
    match res {
        Err(e) => Err(MeshError::at(
            path,
            None,
            format!(
                "corrupt or truncated gzip data after {} decompressed bytes: {e}",
                out.len()
            ),
        )),
        Ok(_) if out.len() as u64 > MAX_GUNZIPPED => Err(MeshError::at(
            path,
            None,
            format!("gzip data expands past {MAX_GUNZIPPED} bytes"),
        )),
        Ok(_) => Ok(out),
    }
}
