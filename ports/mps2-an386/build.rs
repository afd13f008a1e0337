//! Puts `memory.x` where the linker finds it (cortex-m-rt's `link.x` includes it): the MPS2
//! map with the target's PSRAM address written in, or a chip's (`chip-f405`:
//! `memory-f405.x.in`; `chip-h743`: `memory-h743.x.in`) with the chip's own addresses, or with
//! `TETRADRILL_CHIP_MAP=qemu` the addresses of the QEMU machine that stands in for it, the
//! stack's reserve written in; and picks
//! the scenario: `TETRADRILL_SCENARIO=cow` or `tooth` with `TETRADRILL_BLOB=FILE` (a blob
//! written by `tetradrill export --firmware`) copies the blob to `OUT_DIR/mesh.tdb` for
//! `include_bytes!` and writes its counts to `OUT_DIR/mesh_counts.rs` so the statics are sized
//! at build time (cfg `blob_mesh`, and `scenario_cow` or `scenario_tooth`); otherwise the
//! firmware builds the built-in block and the blob is empty (`TETRADRILL_SCENARIO=regions` or
//! `soft`: cfg `scenario_regions` or `scenario_soft` on the block).

use std::env;
use std::fs;
use std::path::PathBuf;

/// The stack's reserve on a chip's RAM, its MPU guard included (`memory::GUARD_BYTES`, 4 KB):
/// the link fails when the statics leave less. The deepest mark measured is start-up's, about
/// 30 KB (`World::new`'s frame, docs/PORTING.md).
const STACK_RESERVE: &str = "36K";

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let f405 = env::var_os("CARGO_FEATURE_CHIP_F405").is_some();
    let h743 = env::var_os("CARGO_FEATURE_CHIP_H743").is_some();
    assert!(
        !(f405 && h743),
        "chip-f405 and chip-h743 are two chips: pick one"
    );
    // The chip's own addresses, or QEMU's stand-in machine's (scripts/port-check.sh --chip).
    let qemu = env::var("TETRADRILL_CHIP_MAP").is_ok_and(|m| m == "qemu");
    let memory = if f405 {
        // QEMU's STM32F405 has no CCM: its build puts the CCM's 64 KB in the upper part of
        // QEMU's 192 KB of SRAM (memory-f405.x.in).
        let ccm = if qemu { "0x20020000" } else { "0x10000000" };
        include_str!("memory-f405.x.in")
            .replace("CCM_ORIGIN", ccm)
            .replace("STACK_RESERVE", STACK_RESERVE)
    } else if h743 {
        // mps2-an500 maps no memory at the H743's flash, AXI SRAM, SRAM1-3 and SRAM4 addresses
        // (memory-h743.x.in).
        let [flash, axi, sram123, sram4] = if qemu {
            ["0x00000000", "0x20100000", "0x60000000", "0x60100000"]
        } else {
            ["0x08000000", "0x24000000", "0x30000000", "0x38000000"]
        };
        include_str!("memory-h743.x.in")
            .replace("FLASH_ORIGIN", flash)
            .replace("AXISRAM_ORIGIN", axi)
            .replace("SRAM123_ORIGIN", sram123)
            .replace("SRAM4_ORIGIN", sram4)
            .replace("STACK_RESERVE", STACK_RESERVE)
    } else {
        let psram = if env::var_os("CARGO_FEATURE_M7").is_some() {
            "0x60000000"
        } else {
            "0x21000000"
        };
        include_str!("memory.x.in").replace("PSRAM_ORIGIN", psram)
    };
    fs::write(out.join("memory.x"), memory).expect("cannot write memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x.in");
    println!("cargo:rerun-if-changed=memory-f405.x.in");
    println!("cargo:rerun-if-changed=memory-h743.x.in");
    println!("cargo:rerun-if-env-changed=TETRADRILL_CHIP_MAP");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=TETRADRILL_SCENARIO");
    println!("cargo:rerun-if-env-changed=TETRADRILL_BLOB");
    println!("cargo::rustc-check-cfg=cfg(scenario_cow)");
    println!("cargo::rustc-check-cfg=cfg(scenario_regions)");
    println!("cargo::rustc-check-cfg=cfg(scenario_tooth)");
    println!("cargo::rustc-check-cfg=cfg(scenario_soft)");
    println!("cargo::rustc-check-cfg=cfg(blob_mesh)");
    println!("cargo::rustc-check-cfg=cfg(fpu_sp)");
    // A Cortex-M7 with a single-precision FPU (fpv5-sp-d16) builds with `-C target-cpu=cortex-m7
    // -C target-feature=-fp64`; rustc has no cfg for `fp64`, so the flag itself says which.
    println!("cargo:rerun-if-env-changed=CARGO_ENCODED_RUSTFLAGS");
    let flags = env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
    if flags.split('\x1f').any(|f| f.contains("-fp64")) {
        println!("cargo:rustc-cfg=fpu_sp");
    }
    if env::var("TETRADRILL_SCENARIO").is_ok_and(|s| s == "regions") {
        println!("cargo:rustc-cfg=scenario_regions");
    }
    if env::var("TETRADRILL_SCENARIO").is_ok_and(|s| s == "soft") {
        println!("cargo:rustc-cfg=scenario_soft");
    }
    let scenario = env::var("TETRADRILL_SCENARIO").unwrap_or_default();
    let cow = scenario == "cow";
    let tooth = scenario == "tooth";
    let (blob, nodes, tets) = if cow || tooth {
        let path = env::var("TETRADRILL_BLOB").unwrap_or_else(|_| {
            panic!("TETRADRILL_SCENARIO={scenario} needs TETRADRILL_BLOB=FILE (tetradrill export --firmware)")
        });
        println!("cargo:rerun-if-changed={path}");
        let blob = fs::read(&path).unwrap_or_else(|e| panic!("{path}: cannot read: {e}"));
        assert!(
            blob.len() >= 24 && &blob[0..4] == b"TDMB",
            "{path}: not a tetradrill mesh blob"
        );
        let word = |at: usize| u32::from_le_bytes(blob[at..at + 4].try_into().unwrap());
        println!("cargo:rustc-cfg=blob_mesh");
        if cow {
            println!("cargo:rustc-cfg=scenario_cow");
        } else {
            println!("cargo:rustc-cfg=scenario_tooth");
        }
        let (n, t) = (word(8), word(12));
        (blob, n, t)
    } else {
        (Vec::new(), 0, 0)
    };
    fs::write(out.join("mesh.tdb"), &blob).expect("cannot write mesh.tdb");
    fs::write(
        out.join("mesh_counts.rs"),
        format!(
            "/// Nodes of the included blob.\npub const BLOB_NODES: usize = {nodes};\n\
             /// Tets of the included blob.\npub const BLOB_TETS: usize = {tets};\n"
        ),
    )
    .expect("cannot write mesh_counts.rs");
}
