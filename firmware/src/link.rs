//! The link task: owns the UART receive side, reassembles frames and answers messages.
//!
//! Message semantics are `acs_flight::session::Session::handle` (shared with the host's
//! virtual flight computer). Lockstep mode (default): every `Sensor` frame is stepped at
//! once and answered with exactly one `Step` report. Real-time mode (after
//! `StartRealTime`): `Sensor` frames only replace the latest frame; the control task
//! (`control.rs`) steps and reports.

use core::sync::atomic::Ordering;

use acs_flight::link::{schema_hash, FrameAccumulator, FswMsg, HostMsg, MAX_FRAME, PROTOCOL_VERSION};
use acs_flight::params::PARAMS_VERSION;

use crate::board;
use crate::state::{self, SharedSession, SharedTx};

#[embassy_executor::task]
pub async fn link_task(mut rx: board::LinkRx, session: &'static SharedSession, tx: &'static SharedTx) {
    let mut acc = FrameAccumulator::<MAX_FRAME>::new();
    let mut buf = [0u8; 64];
    defmt::info!(
        "link up: protocol {=u16}, schema {=u32:#010x}, params v{=u16}",
        PROTOCOL_VERSION,
        schema_hash(),
        PARAMS_VERSION
    );
    loop {
        let n = rx.read(&mut buf).await;
        for &byte in buf.iter().take(n) {
            let Some(result) = acc.push::<HostMsg>(byte) else {
                continue;
            };
            let dropped = acc.stats.dropped();
            state::FRAMES_DROPPED.store(dropped, Ordering::Relaxed);
            match result {
                Ok(msg) => handle(&msg, dropped, session, tx).await,
                Err(e) => defmt::warn!("frame dropped ({}), {=u32} so far", e, dropped),
            }
        }
    }
}

async fn handle(msg: &HostMsg, dropped: u32, session: &SharedSession, tx: &SharedTx) {
    let reply = {
        let mut s = session.lock().await;
        if let HostMsg::Sensor(frame) = msg {
            if s.real_time() {
                state::LATEST_FRAME.signal(*frame);
                return;
            }
        }
        #[cfg(feature = "debug-hang")]
        if matches!(msg, HostMsg::DebugHang) && s.real_time() {
            debug_hang();
        }
        if let HostMsg::Hello { .. } = msg {
            // Scanned on request only (stack.rs): the cost is one load per unused word.
            s.stack_hwm_bytes = crate::stack::high_water_mark();
        }
        let was_real_time = s.real_time();
        let reply = s.handle(msg, dropped, &mut state::counter);
        if s.real_time() && !was_real_time {
            defmt::info!("real-time mode");
            state::START_REAL_TIME.signal(());
        }
        reply
    };
    log(msg, reply.as_ref());
    if let Some(r) = reply {
        state::send(tx, &r).await;
    }
}

/// Test hook (feature `debug-hang`, QEMU test image only): spin forever in the link task
/// with interrupts enabled, so the executor never runs the control task again and the
/// watchdog, armed in real-time mode, must reset the board. Honoured only in real-time
/// mode (where the watchdog runs); otherwise the session answers `Error(DebugDisabled)`.
#[cfg(feature = "debug-hang")]
fn debug_hang() -> ! {
    defmt::warn!("DebugHang: hanging the link task (the watchdog must reset us)");
    loop {
        core::hint::spin_loop();
    }
}

fn log(msg: &HostMsg, reply: Option<&FswMsg>) {
    match (msg, reply) {
        (HostMsg::Sensor(f), Some(FswMsg::Step(r))) => {
            defmt::trace!("step {=u32}: {=u32} ticks", f.seq, r.step_cost_ticks)
        }
        (_, Some(FswMsg::HelloAck { .. })) => defmt::info!("hello"),
        (HostMsg::UploadParams(p), Some(FswMsg::ParamsAccepted { checksum })) => {
            defmt::info!("params accepted: checksum {=u32:#010x}, {=f32} Hz", checksum, p.control_rate_hz)
        }
        (_, Some(FswMsg::ParamsRejected(e))) => defmt::warn!("params rejected: {}", e),
        (HostMsg::SetTarget { .. }, Some(FswMsg::Ack)) => defmt::info!("target set"),
        (HostMsg::UploadModeParams { mode, .. }, Some(FswMsg::ParamsAccepted { checksum })) => {
            defmt::info!("mode {} params accepted: checksum {=u32:#010x}", mode, checksum)
        }
        (_, Some(FswMsg::ModesArmed { checksum })) => defmt::info!("mode table armed: {=u32:#010x}", checksum),
        (_, Some(FswMsg::ModeAccepted { mode })) => defmt::info!("mode {}", mode),
        (_, Some(FswMsg::Error(e))) => defmt::warn!("{} -> {}", msg, e),
        _ => {}
    }
}
