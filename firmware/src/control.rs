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
//!    its report were done, and then skips the missed periods (no catch-up burst);
//! 5. feeds the independent watchdog only if that cycle met its deadline.
//!
//! Watchdog: armed here, at `StartRealTime`, and never in lockstep. In lockstep the host
//! paces the steps (an idle flight computer waiting for a frame is correct, not hung),
//! and on QEMU a running watchdog would make an idle `-icount …,sleep=off` guest warp its
//! clock (see board/qemu.rs). In real-time mode the flight computer commands the
//! actuators on its own clock, so a hang would freeze the last command: there the
//! watchdog resets the board after `WATCHDOG_TIMEOUT_US` without an in-time cycle, and it
//! comes back unconfigured in lockstep (safe command) and reports the cause in `HelloAck`.
//! With periods longer than `FEED_SLICE` the task also feeds while it waits for the next
//! release, as long as the last cycle was on time (a hung step still starves it).

use acs_flight::link::{status, FswMsg, SensorFrame};
use acs_flight::Fsw;
use embassy_futures::select::{select, Either};
use embassy_time::{Duration, Instant, Timer};

use crate::board::{self, Watchdog};
use crate::state::{self, SharedSession, SharedTx};

/// Longest wait between two feeds while the loop idles on time (see module docs).
const FEED_SLICE: Duration = Duration::from_millis(200);
// Feeding every slice keeps a healthy loop well inside the timeout.
const _: () = assert!(FEED_SLICE.as_micros() * 2 < board::WATCHDOG_TIMEOUT_US as u64);

/// Wait for the next release; with periods longer than `FEED_SLICE` feed the watchdog
/// every slice meanwhile if the previous cycle was on time.
async fn next_release(release: Instant, period: Duration, wdg: &mut Watchdog, on_time: bool) {
    if period <= FEED_SLICE {
        Timer::at(release).await;
        return;
    }
    loop {
        // `Timer::at(advance(..))`, not `Timer::after`: embassy's `now + d` panics on
        // overflow (tools/elf-check).
        match select(Timer::at(release), Timer::at(advance(Instant::now(), FEED_SLICE))).await {
            Either::First(()) => return,
            Either::Second(()) => {
                if on_time {
                    wdg.feed();
                }
            }
        }
    }
}

/// Before real-time mode: wait for `StartRealTime`, keeping the watchdog's free-running
/// counter (QEMU real-time boots) from expiring twice meanwhile.
async fn wait_for_real_time(wdg: &mut Watchdog) {
    let Some(every) = wdg.keep_alive_period_s() else {
        state::START_REAL_TIME.wait().await;
        return;
    };
    loop {
        match select(state::START_REAL_TIME.wait(), Timer::at(advance(Instant::now(), Duration::from_secs(every))))
            .await
        {
            Either::First(()) => return,
            Either::Second(()) => wdg.keep_alive(),
        }
    }
}

/// Control period for a validated rate (0.01 … 10 000 Hz), rounded to whole µs ticks.
/// In f32 (no soft-double on the M4F): the quotient's rounding error is < 1 µs for periods
/// below 2^23 µs (8.4 s, rates ≥ 0.12 Hz) and < 8 µs in the 100 s period of 0.01 Hz.
fn period_of(rate_hz: f32) -> Duration {
    let us = 1.0e6f32 / rate_hz.max(0.01) + 0.5;
    // Float → integer `as` saturates (and is one `vcvt` to u32); `us` is positive and
    // at most 1e8 + 0.5 < u32::MAX.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let us = u64::from(us as u32);
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
pub async fn control_task(session: &'static SharedSession, tx: &'static SharedTx, mut wdg: Watchdog) {
    wait_for_real_time(&mut wdg).await;
    if wdg.arm(board::WATCHDOG_TIMEOUT_US) {
        defmt::info!("watchdog armed: reset after {=u32} us without an in-time cycle", board::WATCHDOG_TIMEOUT_US);
    } else {
        defmt::warn!("no watchdog: QEMU was started without the `realtime` argument (lockstep boot)");
    }
    let mut on_time = true;

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
        next_release(release, period, &mut wdg, on_time).await;

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
            let (cmd, cost, new_rate) = match last {
                Some(ref f) if stale < hold_after => {
                    let (cmd, cost) = state::measured_step(&mut s.fsw, f);
                    (cmd, cost, new_rate)
                }
                _ => (Fsw::safe_command(last.map_or(0, |f| f.seq), status::HOLD), 0, new_rate),
            };
            // Parameters are accepted in real-time mode only while the loop holds.
            s.set_holding(cmd.status & status::HOLD != 0);
            (cmd, cost, new_rate)
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
        // Only a cycle that met its deadline proves the loop alive.
        on_time = missed == 0;
        if on_time {
            wdg.feed();
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
