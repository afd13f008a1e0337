//! TetGen `.node` + `.ele`: the input is the `.node` file, a NUL byte, then the `.ele` file (a
//! NUL cannot occur in a text file the reader accepts). Both names of the pair are tried, as
//! either may be given on the command line; the checks are tetradrill_fuzz::check_mesh_file.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (node, ele) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let node_path = tetradrill_fuzz::write_scratch("pair.node", node);
    let ele_path = tetradrill_fuzz::write_scratch("pair.ele", ele);
    tetradrill_fuzz::check_mesh_file(&node_path);
    tetradrill_fuzz::check_mesh_file(&ele_path);
});
