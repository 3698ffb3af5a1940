//! Helpers shared by the integration tests.

use acs_flight::link::{HostMsg, MAX_FRAME, SensorFrame, encode_frame, valid};
use sim_host::link::FlightLink;
use sim_host::link::framed::Framed;
use sim_host::link::in_process::InProcess;
use sim_host::runner::{self, RunResult};
use sim_host::scenario::Scenario;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// Repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Whether `qemu-system-arm` is installed; when it is not, says loudly what `what` (the
/// calling test) leaves untested (scripts/setup.sh installs QEMU).
pub fn qemu_available(what: &str) -> bool {
    let ok = std::process::Command::new("qemu-system-arm").arg("--version").output().is_ok_and(|o| o.status.success());
    if !ok {
        eprintln!("SKIPPED: qemu-system-arm is not installed (scripts/setup.sh installs it); {what} not tested");
    }
    ok
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
    assert!(sim_host::link::qemu::default_firmware().exists());
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
