//! Real-time mode: the control task paces steps with the flight computer's own clock.
//!
//! Started by `StartRealTime` (see `link.rs`). Every control period (`1 / control_rate_hz`,
//! an `embassy_time::Timer` at the next release time) it:
//! 1. takes the newest sensor frame if one arrived since the last period (fresh), else
//!    counts a missed frame and reuses the previous one;
//! 2. steps the flight software on it — or, after `hold_after_missed_frames` periods
//!    without a fresh frame (or before the first frame), sends the safe command with
//!    `status::HOLD` (zero gimbal rates) without stepping;
//! 3. sends exactly one `Step` report;
//! 4. counts a deadline miss for every period boundary that passed before the step and
//!    its report were done, and then skips the missed periods (no catch-up burst).

use acs_flight::link::{status, FswMsg, SensorFrame};
use acs_flight::Fsw;
use embassy_time::{Duration, Instant, Timer};

use crate::state::{self, SharedSession, SharedTx};

/// Control period for a validated rate (0.01 … 10 000 Hz), rounded to whole µs ticks.
fn period_of(rate_hz: f32) -> Duration {
    let us = 1.0e6f64 / f64::from(rate_hz.max(0.01)) + 0.5;
    // Float → integer `as` saturates; `us` is positive and far below u64::MAX.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let us = us as u64;
    Duration::from_micros(us.max(1))
}

/// `t + d`, saturating at the end of time (embassy's `+` panics on overflow).
fn advance(t: Instant, d: Duration) -> Instant {
    t.checked_add(d).unwrap_or(Instant::MAX)
}

/// Periods that ended in `(release, now]`, i.e. deadlines missed by work released at
/// `release`.
fn periods_elapsed(release: Instant, now: Instant, period: Duration) -> u64 {
    let p = period.as_ticks().max(1);
    now.checked_duration_since(release).map_or(0, |d| d.as_ticks().checked_div(p).unwrap_or(0))
}

#[embassy_executor::task]
pub async fn control_task(session: &'static SharedSession, tx: &'static SharedTx) {
    state::START_REAL_TIME.wait().await;

    let mut last: Option<SensorFrame> = None;
    let mut stale: u32 = 0;
    let mut holding = false;

    let mut rate_hz = session.lock().await.fsw.params().map_or(100.0, |p| p.control_rate_hz);
    let mut period = period_of(rate_hz);
    // Nominal release time of the period the next tick starts. Not `embassy_time::Ticker`:
    // its `Instant + Duration` panics on overflow (tools/elf-check), `advance` saturates.
    let mut release = advance(Instant::now(), period);
    defmt::info!("control task: {=f32} Hz, period {=u64} us", rate_hz, period.as_micros());

    loop {
        Timer::at(release).await;

        if let Some(f) = state::LATEST_FRAME.try_take() {
            last = Some(f);
            stale = 0;
        } else {
            stale = stale.saturating_add(1);
        }

        let (cmd, cost, new_rate) = {
            let mut s = session.lock().await;
            let (hold_after, new_rate) =
                s.fsw.params().map_or((1, rate_hz), |p| (u32::from(p.hold_after_missed_frames), p.control_rate_hz));
            match last {
                Some(ref f) if stale < hold_after => {
                    let (cmd, cost) = state::measured_step(&mut s.fsw, f);
                    (cmd, cost, new_rate)
                }
                _ => (Fsw::safe_command(last.map_or(0, |f| f.seq), status::HOLD), 0, new_rate),
            }
        };
        let hold_now = cmd.status & status::HOLD != 0;
        if hold_now != holding {
            holding = hold_now;
            if holding {
                defmt::warn!("HOLD: no fresh sensor frame for {=u32} periods", stale);
            } else {
                defmt::info!("fresh sensor frames again: stepping");
            }
        }

        // Periods that ended before the step finished.
        let missed_in_step = periods_elapsed(release, Instant::now(), period);
        let report = {
            let mut s = session.lock().await;
            // A miss count beyond u32 saturates the (saturating) counter.
            let n = u32::try_from(missed_in_step).unwrap_or(u32::MAX);
            s.deadline_misses = s.deadline_misses.saturating_add(n);
            s.report(cmd, cost, state::frames_dropped())
        };
        state::send(tx, &FswMsg::Step(report)).await;

        // Include the report's transmission; then skip to the next period boundary.
        let missed = periods_elapsed(release, Instant::now(), period);
        if missed > missed_in_step {
            let mut s = session.lock().await;
            let n = u32::try_from(missed.saturating_sub(missed_in_step)).unwrap_or(u32::MAX);
            s.deadline_misses = s.deadline_misses.saturating_add(n);
        }
        if missed > 0 {
            defmt::warn!("deadline missed: {=u64} period(s)", missed);
            let skip = Duration::from_ticks(period.as_ticks().saturating_mul(missed));
            // Next tick at the first boundary still ahead of us.
            release = advance(release, skip);
        }
        release = advance(release, period);

        if new_rate.to_bits() != rate_hz.to_bits() {
            rate_hz = new_rate;
            period = period_of(rate_hz);
            release = advance(Instant::now(), period);
            defmt::info!("control rate now {=f32} Hz", rate_hz);
        }
    }
}
