//! Watchdog and safe recovery on the firmware under QEMU (mps2-an386, real-time clock):
//! a hang injected in real-time mode (`HostMsg::DebugHang`, compiled into the QEMU test
//! image only: feature `debug-hang`) must be ended by the CMSDK watchdog resetting the
//! board; the board must come back in the safe state (lockstep, unconfigured, safe
//! command, no spontaneous reports) and report `ResetCause::Watchdog` at the next hello.
//! Also: parameters are refused while the real-time loop steps and accepted in the hold.
//! Where qemu-system-arm is not installed: fails under CI, skips loudly otherwise
//! (`acs_tests::require_tool`).

use std::time::{Duration, Instant};

use acs_flight::Fsw;
use acs_flight::link::{FswMsg, HostMsg, LinkError, ResetCause, SensorFrame, status, valid};
use acs_flight::params::FlightParams;
use acs_tests::{build_qemu_firmware, qemu_available};
use sim_core::link::FlightLink;
use sim_core::link::qemu::{QemuClock, QemuLink};

/// A frame every configuration accepts: level attitude, at rest, all sensors valid.
fn frame(seq: u32) -> SensorFrame {
    SensorFrame { valid: valid::ALL, ..SensorFrame::empty(seq, u64::from(seq) * 10_000) }
}

/// Wait up to `timeout` for the next `Step` report (other messages are returned as errors).
fn next_step(link: &mut QemuLink, timeout: Duration) -> Option<acs_flight::link::StepReport> {
    match link.framed().recv_timeout(timeout).unwrap() {
        Some(FswMsg::Step(r)) => Some(r),
        Some(other) => panic!("expected a Step report, got {other:?}"),
        None => None,
    }
}

/// Send `msg` and return its reply, skipping the real-time loop's `Step` reports.
fn request(link: &mut QemuLink, msg: &HostMsg) -> FswMsg {
    link.framed().send(msg).unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline {
        match link.framed().recv_timeout(Duration::from_secs(1)).unwrap() {
            Some(FswMsg::Step(_)) | None => continue,
            Some(reply) => return reply,
        }
    }
    panic!("no reply to {msg:?}");
}

#[test]
fn watchdog_resets_a_hung_real_time_loop_into_the_safe_state() {
    if !qemu_available("watchdog") {
        return;
    }
    build_qemu_firmware();
    let t_start = Instant::now();
    let mut link = QemuLink::start_with(None, QemuClock::RealTime, &[]).unwrap();
    let info = link.hello().unwrap();
    assert_eq!(info.reset_cause, ResetCause::PowerOn);

    // Lockstep: the hang is refused (the watchdog only runs in real-time mode).
    assert_eq!(link.request(&HostMsg::DebugHang).unwrap(), FswMsg::Error(LinkError::DebugDisabled));

    // 100 Hz; hold only after 50 periods (0.5 s) without a fresh frame, so that a
    // parameter upload sent while frames flow reaches a stepping loop.
    let params = FlightParams { hold_after_missed_frames: 50, ..FlightParams::default() };
    link.upload(&params).unwrap();
    link.framed().send(&HostMsg::StartRealTime).unwrap();

    // Real time: one frame per report received; the loop must step (no HOLD).
    let mut stepping = 0;
    for seq in 1..=60u32 {
        link.framed().send(&HostMsg::Sensor(frame(seq))).unwrap();
        let r = next_step(&mut link, Duration::from_secs(2)).expect("real-time reports");
        if r.cmd.status & status::HOLD == 0 {
            stepping += 1;
        }
    }
    assert!(stepping >= 30, "the real-time loop stepped {stepping} of 60 periods");

    // Stepping: an upload (even of the same set) is refused with the typed reason.
    link.framed().send(&HostMsg::Sensor(frame(61))).unwrap();
    assert_eq!(request(&mut link, &HostMsg::UploadParams(params)), FswMsg::Error(LinkError::RealTimeNotInHold));

    // No frames: after 50 periods the loop holds; then the upload is accepted.
    let t_hold = Instant::now();
    loop {
        let r = next_step(&mut link, Duration::from_secs(2)).expect("real-time reports");
        if r.cmd.status & status::HOLD != 0 {
            break;
        }
        assert!(t_hold.elapsed() < Duration::from_secs(5), "the loop never entered the hold");
    }
    assert!(matches!(request(&mut link, &HostMsg::UploadParams(params)), FswMsg::ParamsAccepted { .. }));

    // Hang the firmware: reports stop, nothing answers, until the watchdog resets it.
    link.framed().send(&HostMsg::DebugHang).unwrap();
    let t_hang = Instant::now();
    // Reports already on their way (sent before the hang) are drained first.
    while next_step(&mut link, Duration::from_millis(300)).is_some() {}
    // Poll with hellos (a hung board buffers and then loses them; the reset board answers).
    let ack = loop {
        assert!(t_hang.elapsed() < Duration::from_secs(15), "no watchdog reset within 15 s");
        link.framed().send_raw(&[0]).unwrap();
        link.framed()
            .send(&HostMsg::Hello {
                protocol_version: acs_flight::link::PROTOCOL_VERSION,
                schema_hash: acs_flight::link::schema_hash(),
            })
            .unwrap();
        match link.framed().recv_timeout(Duration::from_millis(250)).unwrap() {
            Some(FswMsg::HelloAck { reset_cause, .. }) => break reset_cause,
            Some(FswMsg::Step(r)) => panic!("a Step report while hung: {r:?}"),
            Some(other) => panic!("unexpected {other:?}"),
            None => {}
        }
    };
    let t_reset = t_hang.elapsed();
    eprintln!("watchdog: hello answered again {:.2} s after DebugHang", t_reset.as_secs_f64());
    assert_eq!(ack, ResetCause::Watchdog);
    // Timeout 1 s to the NMI (cause recorded), 1 s more to the reset; the guest clock
    // follows the host clock, so the reset cannot come earlier.
    assert!(t_reset >= Duration::from_millis(1900), "reset after {t_reset:?}: not the watchdog's timing");

    // Safe state: no spontaneous reports (lockstep again, not configured); answers to
    // the earlier polling hellos may still come.
    while let Some(m) = link.framed().recv_timeout(Duration::from_millis(500)).unwrap() {
        assert!(matches!(m, FswMsg::HelloAck { reset_cause: ResetCause::Watchdog, .. }), "after the reset: {m:?}");
    }
    // ... the first command after the reset is the safe command ...
    let r = link.step(&frame(100)).unwrap();
    // (The estimation stage runs unconfigured too: its telemetry is not a command.)
    let commanded = acs_flight::link::ActuatorCommand { estimate: Default::default(), ..r.cmd };
    assert_eq!(commanded, Fsw::safe_command(100, status::NOT_CONFIGURED));
    // ... and the host can re-handshake (hello above), reconfigure and step.
    let info = link.hello().unwrap();
    assert_eq!(info.reset_cause, ResetCause::Watchdog);
    link.upload(&params).unwrap();
    let r = link.step(&frame(101)).unwrap();
    assert_eq!(r.cmd.status & status::NOT_CONFIGURED, 0);
    eprintln!("watchdog test: {:.1} s in all", t_start.elapsed().as_secs_f64());
}
