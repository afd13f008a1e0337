//! Meshes from outside the program: the firmware's mesh blob, read in place on any target
//! (`td_blob_counts`, `td_world_size_blob`, `td_world_init_blob`), and, on hosted builds, mesh
//! files read through `tetradrill-meshio` (`td_mesh_file_read` and its arrays).

use super::*;

use tetradrill_core::blob::BlobError;

/// The byte offset a blob error names (`u32::MAX` when it names none).
fn blob_byte(e: &BlobError) -> u32 {
    let at = match *e {
        BlobError::Truncated { got, .. } => got,
        BlobError::TrailingBytes { expected, .. } => expected,
        BlobError::BadMagic => 0,
        BlobError::Version(_) => 4,
        BlobError::HeaderLength(_) => 6,
        BlobError::PayloadLength { .. } => 16,
        BlobError::Checksum { .. } => 20,
        BlobError::BadRecord { offset, .. } => offset,
        _ => return u32::MAX,
    };
    u32::try_from(at).unwrap_or(u32::MAX)
}

/// The blob at `blob` (`len` bytes), checked whole; `TdErrBlob` with the byte at fault in
/// `*bad_item` when refused.
///
/// # Safety
/// `blob` points at `len` readable bytes that stay unchanged for `'static` (flash, or memory
/// the caller keeps for as long as a world reads it); `bad_item` is null or writable.
unsafe fn parse(
    blob: *const u8,
    len: usize,
    bad_item: *mut u32,
) -> Result<MeshBlob<'static>, TdStatus> {
    if blob.is_null() {
        return Err(TdStatus::TdErrNull);
    }
    // SAFETY: the caller's contract: `len` readable bytes, unchanged while used.
    let bytes: &'static [u8] = unsafe { core::slice::from_raw_parts(blob, len) };
    MeshBlob::parse(bytes).map_err(|e| {
        // SAFETY: the caller's contract on `bad_item`.
        unsafe { report_bad(bad_item, blob_byte(&e)) };
        TdStatus::TdErrBlob
    })
}

/// Checks the mesh blob at `blob` (`len` bytes, as `tetradrill export --firmware` writes it)
/// and writes its node and tet counts, for `td_params_default`.
///
/// # Bounded work
/// O(blob length): the checksum and every record's ids.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer; `TD_ERR_BLOB` for a refused blob, with the
/// byte offset at fault in `*bad_item` when `bad_item` is not null (`UINT32_MAX`: none).
///
/// # Safety
/// `blob` points at `len` readable bytes; `nodes` and `tets` at writable `uint32_t`s;
/// `bad_item` at a writable `uint32_t` or null.
#[no_mangle]
pub unsafe extern "C" fn td_blob_counts(
    blob: *const u8,
    len: usize,
    nodes: *mut u32,
    tets: *mut u32,
    bad_item: *mut u32,
) -> TdStatus {
    status(|| {
        check_ptr(nodes)?;
        check_ptr(tets)?;
        // SAFETY: the caller's contract on `blob` (read during this call only) and `bad_item`.
        let b = unsafe { parse(blob, len, bad_item) }?;
        // Both counts are below 2^32: the blob's header holds them as u32.
        // SAFETY: checked above; writable by the caller's contract.
        unsafe {
            put(nodes, b.node_count() as u32)?;
            put(tets, b.tet_count() as u32)
        }
    })
}

/// `td_world_size` for a world whose mesh is read in place from a blob
/// (`td_world_init_blob`): no tet records and no build scratch in the world's memory.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_world_size`.
///
/// # Safety
/// As `td_world_size`.
#[no_mangle]
pub unsafe extern "C" fn td_world_size_blob(
    params: *const TdParams,
    out_size: *mut usize,
    out_align: *mut usize,
) -> TdStatus {
    // SAFETY: the caller's contract on the outputs and on `params` (`get` checks it).
    unsafe {
        sized(out_size, out_align, || {
            let plan = Plan::of(&get(params)?, true)?;
            Ok((plan.size, plan.align))
        })
    }
}

/// `td_world_init` with the mesh read in place from the blob at `blob` (`len` bytes): its
/// tets stay in the blob (in flash on a microcontroller), its positions, normals and node
/// records are copied into `mem`, and its region labels give the world's regions as a mesh
/// file's do. `params` counts must be the blob's (`td_blob_counts`); `mem` is sized by
/// `td_world_size_blob`.
///
/// # Bounded work
/// O(blob length) to check it, O(N + T) to copy the nodes and count the faces, O(every
/// capacity) to initialise the storage, O(T log R + R^2) for the labels; once.
///
/// # Errors
/// As `td_world_init`, with `TD_ERR_BLOB` for a refused blob (`*bad_item` gets the byte at
/// fault) and `TD_ERR_PARAMS` for counts other than the blob's.
///
/// # Safety
/// As `td_world_init` for `mem`, `params`, `out` and `bad_item`; `blob` points at `len`
/// readable bytes outside `mem` that stay unchanged for as long as the world is used (the
/// world reads its tets there).
#[no_mangle]
pub unsafe extern "C" fn td_world_init_blob(
    mem: *mut c_void,
    len: usize,
    params: *const TdParams,
    blob: *const u8,
    blob_len: usize,
    out: *mut *mut TdWorld,
    bad_item: *mut u32,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `params`; `get` checks null and alignment.
        let p = unsafe { get(params) }?;
        // SAFETY: the caller's contract on `blob`: unchanged for as long as the world is used.
        let b = unsafe { parse(blob, blob_len, bad_item) }?;
        if b.node_count() != p.node_count as usize || b.tet_count() != p.tet_count as usize {
            return Err(TdStatus::TdErrParams);
        }
        // SAFETY: the caller's contract on `mem`, `len` and `bad_item`; `out` checked.
        unsafe { init(mem, len, &p, Source::Blob(b), out, bad_item) }
    })
}

#[cfg(not(target_os = "none"))]
pub use hosted::*;

/// Mesh files on hosted builds.
#[cfg(not(target_os = "none"))]
mod hosted {
    use super::*;
    use std::boxed::Box;
    use std::path::Path;
    use std::vec::Vec;

    use tetradrill_meshio::{Location, MeshError};

    /// Bytes of `td_file_error.message`, its NUL included.
    pub const TD_FILE_MESSAGE: usize = 512;

    /// Why a mesh file was refused: the line (text formats) or byte (binary formats) at fault
    /// where the reader knows it, and the reader's one line naming the file and the reason.
    #[repr(C)]
    #[derive(Clone, Copy, Debug)]
    pub struct TdFileError {
        /// Line of the file, from 1; 0 when the error names no line.
        pub line: u64,
        /// Byte offset into a binary file, from 0; `UINT64_MAX` when the error names no byte.
        pub byte: u64,
        /// NUL-terminated UTF-8 (cut at a character boundary when longer).
        pub message: [c_char; TD_FILE_MESSAGE],
    }

    /// A mesh file read and built (`td_mesh_file_read`): its arrays, owned by the library
    /// until `td_mesh_file_free`. Opaque.
    #[derive(Debug)]
    pub struct TdMeshFile {
        xyz: Vec<f32>,
        tets: Vec<u32>,
        labels: Option<Vec<i32>>,
    }

    /// A mesh file's arrays, as `td_world_init` takes them (`labels` null when the file has
    /// none). The pointers stay valid until `td_mesh_file_free`.
    #[repr(C)]
    #[derive(Clone, Copy, Debug)]
    pub struct TdMeshArrays {
        /// Nodes (`3 * node_count` floats in `positions`).
        pub node_count: u32,
        /// Tets (`4 * tet_count` indices in `tets`, `tet_count` labels).
        pub tet_count: u32,
        /// x, y, z of each node, scaled.
        pub positions: *const f32,
        /// Four node indices from 0 per tet.
        pub tets: *const u32,
        /// Each tet's region label, or null when the file has none.
        pub labels: *const i32,
    }

    /// Writes `e` to `*err` when `err` is not null and aligned.
    ///
    /// # Safety
    /// `err` is null or points at a writable `td_file_error`.
    unsafe fn report(err: *mut TdFileError, e: &MeshError) {
        if err.is_null() || !err.is_aligned() {
            return;
        }
        let mut out = TdFileError {
            line: 0,
            byte: u64::MAX,
            message: [0; TD_FILE_MESSAGE],
        };
        match e.location {
            Some(Location::Line(l)) => out.line = l as u64,
            Some(Location::Byte(b)) => out.byte = b,
            _ => {}
        }
        let mut end = e.message.len().min(TD_FILE_MESSAGE - 1);
        while !e.message.is_char_boundary(end) {
            end -= 1;
        }
        for (o, &b) in out.message.iter_mut().zip(&e.message.as_bytes()[..end]) {
            *o = b as c_char;
        }
        // SAFETY: not null, aligned; writable by the caller's contract.
        unsafe { err.write(out) };
    }

    /// Reads the mesh file at `path` (NUL-terminated; any format `tetradrill` reads: .node/.ele,
    /// .mesh, .meshb, .msh, .vtk, .vtu, each also .gz), scales it by `scale` and builds it as
    /// `tetradrill` does (unreferenced nodes dropped, nodes and tets in spatial order,
    /// orientation fixed), with its region labels; writes a handle to `*out`, whose arrays
    /// (`td_mesh_file_arrays`) go to `td_world_init`. Hosted builds only; it allocates (a
    /// set-up call, never the servo's).
    ///
    /// # Bounded work
    /// O(file size + T log T).
    ///
    /// # Errors
    /// `TD_ERR_NULL` / `TD_ERR_ALIGN` for `path` or `out`; `TD_ERR_PARAMS` for a scale that is
    /// not positive and finite; `TD_ERR_FILE` for a file that cannot be read or built, with
    /// `*err` (when not null) naming the line or byte and the reason.
    ///
    /// # Safety
    /// `path` points at a NUL-terminated string; `out` at a writable `td_mesh_file *`; `err`
    /// at a writable `td_file_error` or null.
    #[no_mangle]
    pub unsafe extern "C" fn td_mesh_file_read(
        path: *const c_char,
        scale: f64,
        out: *mut *mut TdMeshFile,
        err: *mut TdFileError,
    ) -> TdStatus {
        status(|| {
            check_ptr(out)?;
            if path.is_null() {
                return Err(TdStatus::TdErrNull);
            }
            if !(scale.is_finite() && scale > 0.0) {
                return Err(TdStatus::TdErrParams);
            }
            // SAFETY: the caller's contract: a NUL-terminated string.
            let bytes = unsafe { core::ffi::CStr::from_ptr(path) }.to_bytes();
            #[cfg(unix)]
            let path: &Path =
                <std::ffi::OsStr as std::os::unix::ffi::OsStrExt>::from_bytes(bytes).as_ref();
            #[cfg(not(unix))]
            let path: &Path = match core::str::from_utf8(bytes) {
                Ok(s) => s.as_ref(),
                Err(_) => {
                    let e = MeshError::input("the path is not UTF-8");
                    // SAFETY: the caller's contract on `err`.
                    unsafe { report(err, &e) };
                    return Err(TdStatus::TdErrFile);
                }
            };
            let loaded = tetradrill_meshio::load(path, scale).map_err(|e| {
                // SAFETY: the caller's contract on `err`.
                unsafe { report(err, &e) };
                TdStatus::TdErrFile
            })?;
            let mesh = &loaded.mesh;
            let file = TdMeshFile {
                xyz: mesh
                    .positions()
                    .iter()
                    .flat_map(|p| [p.x, p.y, p.z])
                    .collect(),
                tets: mesh
                    .tets()
                    .iter()
                    .flat_map(|t| t.nodes.map(|n| n.0))
                    .collect(),
                labels: loaded.label_source.is_some().then(|| loaded.labels.clone()),
            };
            // SAFETY: checked above; writable by the caller's contract.
            unsafe { put(out, Box::into_raw(Box::new(file))) }
        })
    }

    /// Writes the arrays of a mesh file read by `td_mesh_file_read` to `*out`.
    ///
    /// # Bounded work
    /// Constant.
    ///
    /// # Errors
    /// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer.
    ///
    /// # Safety
    /// `file` is a handle from `td_mesh_file_read` not yet freed; `out` points at a writable
    /// `td_mesh_arrays`.
    #[no_mangle]
    pub unsafe extern "C" fn td_mesh_file_arrays(
        file: *const TdMeshFile,
        out: *mut TdMeshArrays,
    ) -> TdStatus {
        status(|| {
            check_ptr(file)?;
            // SAFETY: checked; a live handle by the caller's contract.
            let f = unsafe { &*file };
            let arrays = TdMeshArrays {
                // At most the counts `tetradrill-meshio` reads, below 2^32.
                node_count: (f.xyz.len() / 3) as u32,
                tet_count: (f.tets.len() / 4) as u32,
                positions: f.xyz.as_ptr(),
                tets: f.tets.as_ptr(),
                labels: f.labels.as_ref().map_or(ptr::null(), |l| l.as_ptr()),
            };
            // SAFETY: the caller's contract on `out`; `put` checks null and alignment.
            unsafe { put(out, arrays) }
        })
    }

    /// Frees a mesh file's arrays (a world built from them does not need them). Null does
    /// nothing.
    ///
    /// # Bounded work
    /// Constant (the allocator's free).
    ///
    /// # Safety
    /// `file` is null or a handle from `td_mesh_file_read` not yet freed; its arrays are not
    /// used afterwards.
    #[no_mangle]
    pub unsafe extern "C" fn td_mesh_file_free(file: *mut TdMeshFile) {
        if !file.is_null() {
            // SAFETY: from `Box::into_raw` in `td_mesh_file_read`, freed once (the contract).
            drop(unsafe { Box::from_raw(file) });
        }
    }
}
