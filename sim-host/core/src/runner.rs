//! The run loop: a [`Simulation`] stepped from `t = 0` to the scenario's duration, its rows
//! pushed into a [`Recorder`] (streamed to disk by the CLI, kept in memory by [`run`]).
//! The physics of one control step is in [`crate::simulation`].

use crate::link::FlightLink;
use crate::recorder::series::{Recorder, TimeSeries};
pub use crate::recorder::summary::{
    MarginStatus, MarginSummary, ModeTransition, SETTLE_BOUND_DEG, StatusCounts, Summary,
};
use crate::scenario::{Resolved, Scenario};
pub use crate::simulation::{Simulation, column_names, recorded_rows};
use anyhow::Result;
use std::time::{Duration, Instant};

/// A run recorded in memory (tests, benches, library use).
pub struct RunResult {
    pub summary: Summary,
    pub series: TimeSeries,
}

/// Flies a scenario in-process, recording nothing but the summary (campaigns, report).
pub fn fly(sc: &Scenario) -> Result<Summary> {
    let mut l = crate::link::open(&crate::link::LinkKind::InProcess, &crate::link::LinkOptions::default())?;
    run_recorded(sc, l.as_mut(), false, &mut crate::recorder::series::Discard)
}

/// Run the scenario and keep the recorded rows in memory (see [`run_recorded`]).
pub fn run(sc: &Scenario, link: &mut dyn FlightLink, progress: bool) -> Result<RunResult> {
    let mut series = TimeSeries::default();
    let summary = run_recorded(sc, link, progress, &mut series)?;
    Ok(RunResult { summary, series })
}

/// Run the scenario, pushing the recorded rows into `rec` as the run goes. Closed loop:
/// against an already-opened link; open loop (`controller.type = "none"`): the link is
/// not used. `rec` may refuse the run before its first step.
pub fn run_recorded(
    sc: &Scenario,
    link: &mut dyn FlightLink,
    progress: bool,
    rec: &mut dyn Recorder,
) -> Result<Summary> {
    let mut bar = Progress::new(progress, 0);
    let start = Instant::now();
    let summary = run_observed(sc, link, rec, &mut |done, total| {
        bar.steps = total;
        bar.update(done, start);
        Ok(())
    })?;
    bar.finish();
    Ok(summary)
}

/// [`run_recorded`] without the progress bar, calling `observe(steps done, steps in the
/// run)` after every control step instead: a caller's own progress display, or a way to
/// stop the run (an `Err` from `observe` ends it with that error; the Python package
/// checks for Ctrl-C there). The observer sees the run, it does not change it: the rows
/// and the summary are those of [`run_recorded`].
pub fn run_observed(
    sc: &Scenario,
    link: &mut dyn FlightLink,
    rec: &mut dyn Recorder,
    observe: &mut dyn FnMut(u64, u64) -> Result<()>,
) -> Result<Summary> {
    let mut sim = Simulation::new(Resolved::try_from(sc)?, link)?;
    rec.start(sim.columns(), sim.recorded_rows())?;
    let start = Instant::now();
    while !sim.finished() {
        sim.step(rec)?;
        observe(sim.steps_done(), sim.steps())?;
    }
    let wall = start.elapsed().as_secs_f64();
    Ok(sim.summary(wall))
}

/// A progress bar that appears when a run takes more than a second.
struct Progress {
    enabled: bool,
    steps: u64,
    bar: Option<indicatif::ProgressBar>,
}

impl Progress {
    fn new(enabled: bool, steps: u64) -> Self {
        Self { enabled, steps, bar: None }
    }

    fn update(&mut self, done: u64, start: Instant) {
        if !self.enabled || !done.is_multiple_of(1024) {
            return;
        }
        if self.bar.is_none() && start.elapsed() > Duration::from_secs(1) {
            let b = indicatif::ProgressBar::new(self.steps);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:40}] {pos}/{len} steps ({per_sec}, eta {eta})",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            self.bar = Some(b);
        }
        if let Some(b) = &self.bar {
            b.set_position(done);
        }
    }

    fn finish(self) {
        if let Some(b) = self.bar {
            b.finish_and_clear();
        }
    }
}
