//! Scenario reader (`Scenario::load`, TOML then `check()`): the input is the file.
//!
//! Properties: no panic; a refusal is a one-line exit-2 error; an accepted scenario passes
//! `check()` again and survives a TOML round trip (`toml::to_string` then `toml::from_str`).

#![no_main]

use libfuzzer_sys::fuzz_target;
use tetradrill::scenario::Scenario;

fuzz_target!(|data: &[u8]| {
    let path = tetradrill_fuzz::write_scratch("scenario.toml", data);
    let spec = path.to_str().expect("scratch paths are UTF-8");
    match Scenario::load(spec) {
        Ok(sc) => {
            sc.check().expect("a loaded scenario passes check()");
            let text = toml::to_string(&sc).expect("a scenario serialises");
            let back: Scenario = toml::from_str(&text).expect("its own TOML parses");
            assert_eq!(back, sc, "TOML round trip changed the scenario:\n{text}");
        }
        Err(e) => tetradrill_fuzz::check_line(e.code, &e.message),
    }
});
