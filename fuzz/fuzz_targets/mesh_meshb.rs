//! MEDIT binary `.meshb` (versions 1 to 4, either byte order): the input is the whole file.
//! `read` and `load` never panic; refusals are one-line exit-2 errors; a loaded mesh passes
//! `validate()` (`check_mesh_file`).

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = tetradrill_fuzz::write_scratch("input.meshb", data);
    tetradrill_fuzz::check_mesh_file(&path);
});
