//! Same bits on host and target for the flight math, and no double precision on the target:
//! - the firmware images contain no soft-double routine (`__aeabi_d*`, `__adddf3`, ...):
//!   every float operation of the flight code is single precision (the M4F FPU);
//! - `acs_flight::math::f32m` gives the same bits on the Cortex-M4F (QEMU mps2-an386,
//!   firmware/examples/f32m_fingerprint.rs) as on the host, over a dense sweep.
//!
//! Where qemu-system-arm is not installed: fails under CI, skips loudly otherwise
//! (`acs_tests::require_tool`).

use acs_tests::{SOFT_DOUBLE, repo, soft_double_symbols};
use std::process::{Command, Stdio};

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
    if !acs_tests::qemu_available("f32m bits on the target") {
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
