//! Selects the linker memory map for the chosen board and puts it (as `memory.x`) on the
//! linker search path; `link.x` (cortex-m-rt) includes it.
//!
//! Both boards' maps live in the repository's top-level `memory.x`, one block per board
//! feature (`BOARD board-qemu` … `END BOARD`, `BOARD board-stm32f405` … `END BOARD`); this
//! script copies the selected board's block, and only it, to `$OUT_DIR/memory.x`.
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
use std::path::{Path, PathBuf};

fn main() {
    let qemu = env::var_os("CARGO_FEATURE_BOARD_QEMU").is_some();
    let stm32 = env::var_os("CARGO_FEATURE_BOARD_STM32F405").is_some();
    let manifest = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));

    let board = match (qemu, stm32) {
        (true, false) => "board-qemu",
        (false, true) => "board-stm32f405",
        (true, true) => panic!(
            "features `board-qemu` and `board-stm32f405` are exclusive: \
             build the STM32 image with `--no-default-features --features board-stm32f405`"
        ),
        (false, false) => panic!("select a board: feature `board-qemu` or `board-stm32f405`"),
    };
    let memory = manifest.join("..").join("memory.x");
    let text =
        fs::read_to_string(&memory).unwrap_or_else(|e| panic!("cannot read memory map {}: {e}", memory.display()));
    fs::write(out.join("memory.x"), board_block(&text, board, &memory)).expect("write memory.x");
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
}

/// The lines of `text` from the one line starting `/* BOARD <board>` to the next line
/// starting `/* END BOARD`, both included.
fn board_block(text: &str, board: &str, path: &Path) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let is_start =
        |l: &&str| l.trim_start().strip_prefix("/* BOARD ").is_some_and(|r| r.split_whitespace().next() == Some(board));
    let starts: Vec<usize> = (0..lines.len()).filter(|&i| is_start(&lines[i])).collect();
    let [start] = starts[..] else {
        panic!("{}: expected exactly one `/* BOARD {board}` line, found {}", path.display(), starts.len())
    };
    let end = (start..lines.len())
        .find(|&i| lines[i].trim_start().starts_with("/* END BOARD"))
        .unwrap_or_else(|| panic!("{}: block `{board}` has no `/* END BOARD` line", path.display()));
    let mut block = lines[start..=end].join("\n");
    block.push('\n');
    block
}
