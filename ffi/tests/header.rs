//! The checked-in header `include/tetradrill.h` is what cbindgen generates from the crate now:
//! a change to the C interface that is not regenerated fails here.

use std::path::PathBuf;

#[test]
fn header_matches_the_source() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(&dir)
        .with_config(config)
        .generate()
        .expect("cbindgen generates the header")
        .write(&mut generated);
    let generated = String::from_utf8(generated).expect("the header is UTF-8");
    let path = dir.join("include/tetradrill.h");
    if std::env::var_os("TETRADRILL_BLESS").is_some() {
        std::fs::write(&path, &generated).expect("write include/tetradrill.h");
        return;
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        checked_in == generated,
        "ffi/include/tetradrill.h differs from what cbindgen generates from ffi/src; \
         regenerate it with `TETRADRILL_BLESS=1 cargo test -p tetradrill-ffi --test header` \
         and commit it"
    );
}
