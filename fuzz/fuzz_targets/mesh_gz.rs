//! Gzipped mesh files: the first byte picks the format inside (0 `.mesh`, 1 `.msh`, 2 `.vtk`,
//! 3 `.vtu`, 4 `.meshb`, modulo 5), the rest is the `.gz` file. Covers the gzip decoder and
//! every reader behind it; the checks are tetradrill_fuzz::check_mesh_file.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, gz)) = data.split_first() else {
        return;
    };
    let name = tetradrill_fuzz::GZ_NAMES[pick as usize % tetradrill_fuzz::GZ_NAMES.len()];
    let path = tetradrill_fuzz::write_scratch(name, gz);
    tetradrill_fuzz::check_mesh_file(&path);
});
