//! Helpers shared by the integration tests.

use acs_flight::link::{HostMsg, MAX_FRAME, SensorFrame, encode_frame, valid};
use sim_core::link::FlightLink;
use sim_core::link::framed::Framed;
use sim_core::link::in_process::InProcess;
use sim_core::runner::{self, RunResult};
use sim_core::scenario::Scenario;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// Repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[path = "../../sim-host/tests/support/require_tool.rs"]
pub mod require_tool;
pub use require_tool::{Tool, require_tool};

/// The release `sim-host` binary, built once per test binary (incremental: about a second
/// when it is current), for tests that run the CLI.
pub fn sim_host_bin() -> PathBuf {
    static BUILT: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    BUILT
        .get_or_init(|| {
            let st = std::process::Command::new(env!("CARGO"))
                .args(["build", "--release", "-p", "sim-host", "--bin", "sim-host"])
                .current_dir(repo())
                .status()
                .expect("cargo build");
            assert!(st.success(), "building sim-host");
            repo().join("target/release/sim-host")
        })
        .clone()
}

/// Whether `qemu-system-arm` is installed; when it is not, fails under CI and otherwise says
/// loudly (and in the skip log) what `what` (the calling test) leaves untested
/// ([`require_tool`]; scripts/setup.sh installs QEMU).
pub fn qemu_available(what: &str) -> bool {
    require_tool(Tool::Qemu, require_tool::qemu().map_err(|e| format!("{e}; {what} not tested"))).is_some()
}

/// (Re)builds the QEMU firmware image once per test binary: incremental, about a second
/// when it is current, and a stale image (whose schema hash the host would refuse) is
/// never tested.
pub fn build_qemu_firmware() {
    static BUILT: std::sync::Once = std::sync::Once::new();
    BUILT.call_once(|| {
        let st = std::process::Command::new(repo().join("scripts/firmware.sh"))
            .arg("build")
            .stdout(std::process::Stdio::null())
            .status()
            .expect("scripts/firmware.sh");
        assert!(st.success(), "firmware build failed");
    });
    assert!(sim_core::link::qemu::default_firmware().exists());
}

pub fn scenario(rel: &str) -> Scenario {
    let p = repo().join("scenarios").join(rel);
    Scenario::load(&p).unwrap_or_else(|e| panic!("{}: {e:#}", p.display()))
}

pub fn run_in_process(sc: &Scenario) -> RunResult {
    runner::run(sc, &mut InProcess::new(), false).unwrap_or_else(|e| panic!("{}: {e:#}", sc.name))
}

fn frame(seq: u32) -> SensorFrame {
    SensorFrame { q_ib_xyzw: [0.0, 0.0, 0.1, 0.995], valid: valid::ALL, ..SensorFrame::empty(seq, seq as u64 * 10_000) }
}

/// Shared by the QEMU test: corrupt frames between good ones never stop the flight side.
pub fn corrupt_frames_are_dropped_and_counted<S: Read + Write>(link: &mut Framed<S>) {
    link.hello().unwrap();
    link.upload(&acs_flight::params::FlightParams::default()).unwrap();
    let mut buf = [0u8; MAX_FRAME];
    let good = encode_frame(&HostMsg::Sensor(frame(1)), &mut buf).unwrap().to_vec();
    let mut flipped = good.clone();
    flipped[5] ^= 0x10;
    let truncated = [&good[..good.len() / 2], &[0u8]].concat();
    let garbage = vec![0x55u8, 0xAA, 0x01, 0x02, 0x00];
    let oversize = [vec![0x42u8; MAX_FRAME + 50], vec![0]].concat();
    let mut expected_drops = 0;
    for (k, bad) in [flipped, truncated, garbage, oversize].iter().enumerate() {
        link.send_raw(bad).unwrap();
        expected_drops += 1;
        let seq = 10 + k as u32;
        let r = link.step(&frame(seq)).unwrap();
        assert_eq!(r.cmd.seq, seq);
        assert_eq!(r.frames_dropped, expected_drops, "after corruption {k}");
    }
}

/// Shared by the TCP (virtual flight computer) and QEMU (firmware) tests, so SIL and PIL
/// are held to the same rule. One frame, one step: a repeated and an older `seq` are
/// refused with `StaleSequence` and counted in `seq_refused`; a CRC-valid frame with
/// trailing junk is dropped and counted in `frames_dropped` (no reply). None of them
/// touches the flight state: the commands of the next frames equal, bit for bit, those of
/// an in-process `Session` that only saw the clean frames.
pub fn repeated_frames_and_trailing_junk_are_refused<S: Read + Write>(link: &mut Framed<S>) {
    use acs_flight::link::{FswMsg, LinkError};
    use acs_flight::session::{Session, board};
    fn reference_step(s: &mut Session, seq: u32) -> acs_flight::link::ActuatorCommand {
        match s.handle(&HostMsg::Sensor(frame(seq)), 0, &mut || 0) {
            Some(FswMsg::Step(r)) => r.cmd,
            other => panic!("reference: {other:?}"),
        }
    }
    let params = acs_flight::params::FlightParams::default();
    let mut reference = Session::new(board::HOST, 0);
    assert!(matches!(
        reference.handle(&HostMsg::UploadParams(params), 0, &mut || 0),
        Some(FswMsg::ParamsAccepted { .. })
    ));
    link.hello().unwrap();
    link.upload(&params).unwrap();
    let first = link.step(&frame(20)).unwrap();
    assert_eq!(first.cmd, reference_step(&mut reference, 20));
    let dropped0 = first.frames_dropped;
    for (seq, n) in [(20u32, 1u32), (19, 2)] {
        link.send(&HostMsg::Sensor(frame(seq))).unwrap();
        match link.recv().unwrap() {
            FswMsg::Error(LinkError::StaleSequence { seq: s, last_seq }) => assert_eq!((s, last_seq), (seq, 20)),
            other => panic!("frame {seq} again: {other:?} (refusal {n} expected)"),
        }
    }
    // Frame 21 with two junk bytes after the message, under a valid CRC (postcard
    // encodes the tuple as the message's bytes followed by the two bytes).
    let mut buf = [0u8; MAX_FRAME];
    link.send_raw(encode_frame(&(HostMsg::Sensor(frame(21)), [0xABu8, 0xCD]), &mut buf).unwrap()).unwrap();
    for seq in [22u32, 23] {
        let r = link.step(&frame(seq)).unwrap();
        assert_eq!(r.cmd, reference_step(&mut reference, seq), "frame {seq}: a refused frame changed the flight state");
        assert_eq!((r.seq_refused, r.frames_dropped - dropped0), (2, 1), "frame {seq}");
    }
    assert_eq!(link.anomalies(), sim_core::link::LinkAnomalies { frames_refused_flight: 2, ..Default::default() });
}

/// Names of the symbols of an ELF32 little-endian file (SHT_SYMTAB + its string table).
/// Minimal reader so the check needs no binutils.
pub fn elf32_symbols(path: &Path) -> Vec<String> {
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
pub const SOFT_DOUBLE: &[&str] = &[
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

/// The soft-double routines an ELF links (empty: every float operation is single precision).
pub fn soft_double_symbols(elf: &Path) -> Vec<String> {
    let syms = elf32_symbols(elf);
    // The reader must have seen the real table (cortex-m-rt's entry symbol is always there).
    assert!(syms.len() > 50 && syms.iter().any(|s| s == "Reset"), "{}: symbol table not read", elf.display());
    syms.into_iter().filter(|s| SOFT_DOUBLE.iter().any(|d| s.contains(d))).collect()
}
