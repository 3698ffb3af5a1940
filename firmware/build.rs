//! Selects the linker memory map for the chosen board and puts it (as `memory.x`) on the
//! linker search path; `link.x` (cortex-m-rt) includes it.
//!
//! - `board-qemu` (default): `memory-mps2-an386.x` next to this file.
//! - `board-stm32f405`: the repository's top-level `memory.x`.
// Host-side build script: aborting the build on a missing file is the right reaction,
// so the flight rules of the [lints] table do not apply here.
#![allow(
    clippy::expect_used,
    clippy::unwrap_used,
    clippy::panic,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects
)]

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let qemu = env::var_os("CARGO_FEATURE_BOARD_QEMU").is_some();
    let stm32 = env::var_os("CARGO_FEATURE_BOARD_STM32F405").is_some();
    let manifest = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));

    let memory = match (qemu, stm32) {
        (true, false) => manifest.join("memory-mps2-an386.x"),
        (false, true) => manifest.join("..").join("memory.x"),
        (true, true) => panic!(
            "features `board-qemu` and `board-stm32f405` are exclusive: \
             build the STM32 image with `--no-default-features --features board-stm32f405`"
        ),
        (false, false) => panic!("select a board: feature `board-qemu` or `board-stm32f405`"),
    };
    let text = fs::read(&memory).unwrap_or_else(|e| panic!("cannot read memory map {}: {e}", memory.display()));
    fs::write(out.join("memory.x"), text).expect("write memory.x");
    println!("cargo:rerun-if-changed={}", memory.display());

    if qemu {
        // cortex-m-rt's `device` feature makes link.x `INCLUDE device.x`; the QEMU board has
        // no PAC, so its interrupt table (`__INTERRUPTS`) is defined in src/board/qemu.rs
        // and device.x only has to exist.
        fs::write(out.join("device.x"), "/* mps2-an386: __INTERRUPTS is defined in src/board/qemu.rs */\n")
            .expect("write device.x");
    }

    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=memory-mps2-an386.x");
}
