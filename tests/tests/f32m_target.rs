//! Same bits on host and target for the flight math, and no double precision on the target:
//! - the firmware images contain no soft-double routine (`__aeabi_d*`, `__adddf3`, ...):
//!   every float operation of the flight code is single precision (the M4F FPU);
//! - `acs_flight::math::f32m` gives the same bits on the Cortex-M4F (QEMU mps2-an386,
//!   firmware/examples/f32m_fingerprint.rs) as on the host, over a dense sweep.
//!
//! Skips (loudly) only where qemu-system-arm is not installed.

use acs_tests::repo;
use std::path::Path;
use std::process::{Command, Stdio};

fn qemu_available() -> bool {
    let ok = Command::new("qemu-system-arm").arg("--version").output().is_ok_and(|o| o.status.success());
    if !ok {
        eprintln!("SKIPPED: qemu-system-arm is not installed (scripts/setup.sh installs it)");
    }
    ok
}

/// Names of the symbols of an ELF32 little-endian file (SHT_SYMTAB + its string table).
/// Minimal reader so the check needs no binutils.
fn elf32_symbols(path: &Path) -> Vec<String> {
    let d = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(&d[..6], b"\x7fELF\x01\x01", "{}: not an ELF32 LE file", path.display());
    let u16_at = |o: usize| u16::from_le_bytes([d[o], d[o + 1]]) as usize;
    let u32_at = |o: usize| u32::from_le_bytes([d[o], d[o + 1], d[o + 2], d[o + 3]]) as usize;
    let (shoff, shentsize, shnum) = (u32_at(0x20), u16_at(0x2E), u16_at(0x30));
    let sh = |i: usize| shoff + i * shentsize;
    let mut names = Vec::new();
    for i in 0..shnum {
        if u32_at(sh(i) + 4) != 2 {
            continue; // not SHT_SYMTAB
        }
        let (off, size, link, entsize) =
            (u32_at(sh(i) + 16), u32_at(sh(i) + 20), u32_at(sh(i) + 24), u32_at(sh(i) + 36));
        let stroff = u32_at(sh(link) + 16);
        for s in (off..off + size).step_by(entsize) {
            let start = stroff + u32_at(s);
            let end = start + d[start..].iter().position(|&b| b == 0).unwrap();
            names.push(String::from_utf8_lossy(&d[start..end]).into_owned());
        }
    }
    names
}

/// compiler-builtins / libgcc double-precision routines (ARM EABI names and generic names).
const SOFT_DOUBLE: &[&str] = &[
    "__aeabi_dadd",
    "__aeabi_dsub",
    "__aeabi_drsub",
    "__aeabi_dmul",
    "__aeabi_ddiv",
    "__aeabi_dneg",
    "__aeabi_dcmp",
    "__aeabi_d2f",
    "__aeabi_d2iz",
    "__aeabi_d2uiz",
    "__aeabi_d2lz",
    "__aeabi_d2ulz",
    "__aeabi_f2d",
    "__aeabi_i2d",
    "__aeabi_ui2d",
    "__aeabi_l2d",
    "__aeabi_ul2d",
    "__adddf3",
    "__subdf3",
    "__muldf3",
    "__divdf3",
    "__negdf2",
    "__extendsfdf2",
    "__truncdfsf2",
    "__fixdfsi",
    "__fixdfdi",
    "__fixunsdfsi",
    "__fixunsdfdi",
    "__floatsidf",
    "__floatdidf",
    "__floatunsidf",
    "__floatundidf",
    "__cmpdf2",
    "__eqdf2",
    "__nedf2",
    "__gedf2",
    "__gtdf2",
    "__ledf2",
    "__ltdf2",
    "__unorddf2",
    "__powidf2",
];

fn soft_double_symbols(elf: &Path) -> Vec<String> {
    let syms = elf32_symbols(elf);
    // The reader must have seen the real table (cortex-m-rt's entry symbol is always there).
    assert!(syms.len() > 50 && syms.iter().any(|s| s == "Reset"), "{}: symbol table not read", elf.display());
    syms.into_iter().filter(|s| SOFT_DOUBLE.iter().any(|d| s.contains(d))).collect()
}

#[test]
fn soft_double_detector_sees_a_double_routine() {
    // Positive control: the host test binary's own symbols are not ELF32, so check the
    // matcher on names as they appear in a Cortex-M image (EABI alias, mangled builtin).
    for name in ["__aeabi_dmul", "_RNvNtNtCs7NhdfSRABLd_17compiler_builtins5float3add8___adddf3"] {
        assert!(SOFT_DOUBLE.iter().any(|d| name.contains(d)), "{name}");
    }
    assert!(!SOFT_DOUBLE.iter().any(|d| "__aeabi_fmul".contains(d) || "__aeabi_uldivmod".contains(d)));
}

#[test]
fn firmware_images_contain_no_soft_double_routine() {
    // Both boards, rebuilt (incremental; scripts/test.sh has just built them) so that a
    // stale image is never checked.
    for cmd in ["build", "build-stm32"] {
        let st = Command::new(repo().join("scripts/firmware.sh")).arg(cmd).stdout(Stdio::null()).status().unwrap();
        assert!(st.success(), "scripts/firmware.sh {cmd} failed");
    }
    let elfs = [
        repo().join("firmware/target/thumbv7em-none-eabihf/release/acs-firmware"),
        repo().join("firmware/target/stm32f405/thumbv7em-none-eabihf/release/acs-firmware"),
    ];
    for elf in elfs {
        let found = soft_double_symbols(&elf);
        assert!(found.is_empty(), "{}: soft-double routines {found:?}", elf.display());
    }
}

#[test]
fn f32m_gives_the_same_bits_on_the_cortex_m4_as_on_the_host() {
    if !qemu_available() {
        return;
    }
    let out = Command::new(repo().join("scripts/firmware.sh")).arg("math-fingerprint").output().unwrap();
    assert!(out.status.success(), "math-fingerprint failed: {}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .find(|l| l.starts_with("f32m fingerprint "))
        .unwrap_or_else(|| panic!("no fingerprint in {text:?}"));
    let mut f = line.split_whitespace().skip(2);
    let points: u32 = f.next().unwrap().parse().unwrap();
    let target = u64::from_str_radix(f.next().unwrap(), 16).unwrap();
    assert!(points >= 1 << 16, "sweep too sparse: {points}");
    let host = acs_flight::math::f32m::sweep_fingerprint(points);
    println!("f32m fingerprint over {points} points: host {host:016x}, Cortex-M4 (QEMU) {target:016x}");
    assert_eq!(host, target, "f32m differs between host and target");
    // The example ELF itself is single precision too.
    let ex = repo().join("firmware/target/thumbv7em-none-eabihf/release/examples/f32m_fingerprint");
    assert!(soft_double_symbols(&ex).is_empty());
}
