//! `sim-host campaign run`: the pending runs of one shard, in-process, in parallel, each
//! result written atomically (`runs/NNNNNN/result.json`) so that an interrupted shard
//! resumes where it stopped.

use super::lock::{Shard, ShardLock};
use super::plan::{Manifest, PlannedRun};
use super::spec::Requirement;
use super::{flatten, write_atomic};
use crate::fly::{FlyOptions, Watch, fly};
use anyhow::{Result, anyhow};
use serde::{Deserialize, Serialize};
use sim_core::link::cancel::Cancel;
use sim_core::link::{LinkKind, LinkOptions};
use sim_core::recorder::series::Discard;
use sim_core::runner;
use sim_core::scenario::Scenario;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum RunStatus {
    /// Flew and met every requirement.
    Ok,
    /// Flew, and missed at least one requirement.
    RequirementFailed,
    /// Did not fly to the end: invalid drawn scenario, simulation error or panic.
    Error,
    /// Flew, but the state or a flight command became non-finite (summary `run_status`
    /// `diverged`): misses every requirement.
    Diverged,
    /// Flew, but the flight code refused the input of every step (summary `run_status`
    /// `all_refused`): misses every requirement.
    AllRefused,
    /// Flew, but the margins its `[margins]` asks for are not those of a stable loop at a
    /// steady hold (summary `run_status` `margins_failed`, `margins.status` not
    /// `measured`: what `sim-host run` exits non-zero for): misses every requirement.
    MarginsFailed,
    /// Flew, but the flight code could not control for a material part of the run (summary
    /// `run_status` `no_control`: no estimate or a refused input after the start-up
    /// allowance): misses every requirement.
    NoControl,
    /// Flew with `[[faults]]`, and the truth lost control through the end of the run with
    /// no FDIR event (summary `run_status` `control_lost`): misses every requirement.
    ControlLost,
    /// Flew with `[[faults]]`, the FDIR raised an event, but the truth lost control through
    /// the end of the run and the flight did not end in a safe mode (summary `run_status`
    /// `recovery_failed`): misses every requirement.
    RecoveryFailed,
    /// Flew with `[[faults]]`, and held off by more than the degraded-hold bound through the
    /// end of the run with no FDIR event (summary `run_status` `pointing_degraded`): misses
    /// every requirement.
    PointingDegraded,
    /// Flew, and its thrusters used more propellant than `[performance]
    /// propellant_budget_kg` (summary `run_status` `propellant_exceeded`): misses every
    /// requirement.
    PropellantExceeded,
}

impl RunStatus {
    /// Whether the run flew to the end with a result its requirements can be judged on
    /// (`ok` or `requirement_failed`).
    pub fn flew(self) -> bool {
        matches!(self, RunStatus::Ok | RunStatus::RequirementFailed)
    }
}

/// `runs/NNNNNN/result.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunRecord {
    pub index: u32,
    pub status: RunStatus,
    #[serde(default)]
    pub error: Option<String>,
    /// Names of the requirements this run missed.
    #[serde(default)]
    pub failed_requirements: Vec<String>,
    /// The run's `summary.json` (absent after an error).
    #[serde(default)]
    pub summary: Option<serde_json::Value>,
    /// Wall time of the whole run (parse, set-up, flight), s.
    pub wall_time_s: f64,
}

impl RunRecord {
    pub fn path(dir: &Path, run: &PlannedRun) -> PathBuf {
        dir.join(&run.scenario).with_file_name("result.json")
    }

    /// The completed result of `run`, if any (a file that does not parse is not one).
    pub fn load(dir: &Path, run: &PlannedRun) -> Option<Self> {
        let text = std::fs::read_to_string(Self::path(dir, run)).ok()?;
        serde_json::from_str::<RunRecord>(&text).ok().filter(|r| r.index == run.index)
    }
}

fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| (*s).to_owned())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

/// Flies one run and, with `[margins]`, measures its margins into `summary.margins` (one
/// worker thread: the campaign runs its runs in parallel). A measurement that is not a
/// stable loop at a steady hold makes the run `margins_failed` (summary `run_status`).
/// Once `cancel` is cancelled the run and its measurement stop at their next control step.
fn fly_with_margins(sc: &Scenario, cancel: &Cancel) -> anyhow::Result<runner::Summary> {
    let opts = FlyOptions {
        link: Some(LinkKind::InProcess),
        link_options: LinkOptions { cancel: Some(cancel.clone()), ..Default::default() },
        margin_threads: 1,
    };
    // The token checked at every step (open-loop runs use no link).
    let watch = Watch::Observer(&mut |_, _| cancel.check());
    Ok(fly(sc, &opts, &mut Discard, watch)?.summary)
}

/// How a summary's run failed, if it did: its `run_status`, and a `margins.status` other
/// than `measured` whatever `run_status` says (a summary written before `margins_failed`).
fn failed_run(summary: &serde_json::Value) -> Option<RunStatus> {
    let margins = summary.get("margins").filter(|m| !m.is_null());
    match summary.get("run_status").and_then(|s| s.as_str()) {
        Some("diverged") => Some(RunStatus::Diverged),
        Some("all_refused") => Some(RunStatus::AllRefused),
        Some("margins_failed") => Some(RunStatus::MarginsFailed),
        Some("no_control") => Some(RunStatus::NoControl),
        Some("control_lost") => Some(RunStatus::ControlLost),
        Some("recovery_failed") => Some(RunStatus::RecoveryFailed),
        Some("pointing_degraded") => Some(RunStatus::PointingDegraded),
        Some("propellant_exceeded") => Some(RunStatus::PropellantExceeded),
        Some("ok") if margins.is_some_and(|m| m.get("status").and_then(|s| s.as_str()) != Some("measured")) => {
            Some(RunStatus::MarginsFailed)
        }
        Some("ok") => None,
        // Any other failed run (e.g. `link_anomaly`; a summary without a status is not
        // one this simulator wrote): its figures are not to be judged either.
        _ => Some(RunStatus::Error),
    }
}

/// One run, start to verdict; never fails (errors and panics become the record's status).
/// A run cut short by `cancel` gives a record that must not be kept (see [`run_shard_until`]).
pub fn run_one(dir: &Path, run: &PlannedRun, requirements: &[Requirement], cancel: &Cancel) -> RunRecord {
    let start = Instant::now();
    let path = dir.join(&run.scenario);
    let flown = std::panic::catch_unwind(|| Scenario::load(&path).and_then(|sc| fly_with_margins(&sc, cancel)))
        .unwrap_or_else(|p| Err(anyhow!("panic: {}", panic_message(p.as_ref()))));
    let wall_time_s = start.elapsed().as_secs_f64();
    let summary = match flown.and_then(|s| Ok(serde_json::to_value(&s)?)) {
        Ok(s) => s,
        Err(e) => {
            return RunRecord {
                index: run.index,
                status: RunStatus::Error,
                error: Some(format!("{e:#}")),
                failed_requirements: Vec::new(),
                summary: None,
                wall_time_s,
            };
        }
    };
    let values = flatten(&summary);
    // A diverged, refused or margins-failed run misses every requirement, whatever its
    // figures say.
    let failed_run = failed_run(&summary);
    let failed_requirements: Vec<String> = requirements
        .iter()
        .filter(|r| failed_run.is_some() || !r.met_by(values.get(&r.key).copied().flatten()))
        .map(|r| r.name.clone())
        .collect();
    let error = summary.get("failure").filter(|f| !f.is_null()).map(|f| f.to_string());
    let status = match failed_run {
        Some(s) => s,
        None if failed_requirements.is_empty() => RunStatus::Ok,
        None => RunStatus::RequirementFailed,
    };
    RunRecord { index: run.index, status, error, failed_requirements, summary: Some(summary), wall_time_s }
}

/// What one `campaign run` did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ShardReport {
    /// Runs of this shard.
    pub assigned: usize,
    /// Already completed before (not run again).
    pub skipped: usize,
    pub ran: usize,
    pub ok: usize,
    pub requirement_failed: usize,
    pub errors: usize,
    /// Runs that diverged or whose every step the flight code refused.
    pub diverged: usize,
    pub all_refused: usize,
    /// Runs whose `[margins]` measurement is not a stable loop at a steady hold.
    pub margins_failed: usize,
    pub no_control: usize,
    pub control_lost: usize,
    pub recovery_failed: usize,
    pub pointing_degraded: usize,
    pub propellant_exceeded: usize,
}

/// Most threads one `campaign run` starts.
pub const MAX_JOBS: usize = 256;

/// Runs the pending runs of `shard` on `jobs` threads (at most [`MAX_JOBS`]).
pub fn run_shard(dir: &Path, shard: Shard, jobs: usize, progress: bool) -> Result<ShardReport> {
    run_shard_until(dir, shard, jobs, progress, &Cancel::new())
}

/// [`run_shard`] that stops once `cancel` is cancelled (Ctrl-C in the Python package):
/// no run starts after that, the runs in flight stop at their next control step and their
/// results are not written, so the shard resumes with them. The report counts the runs
/// whose results were written.
pub fn run_shard_until(dir: &Path, shard: Shard, jobs: usize, progress: bool, cancel: &Cancel) -> Result<ShardReport> {
    let manifest = Manifest::load(dir)?;
    let requirements = manifest.campaign()?.requirements;
    // Held until the shard returns: a second runner of these runs refuses.
    let _lock = ShardLock::acquire(dir, shard)?;
    let mine: Vec<&PlannedRun> = manifest.runs.iter().filter(|r| shard.owns(r.index)).collect();
    let pending: Vec<&PlannedRun> = mine.iter().copied().filter(|r| RunRecord::load(dir, r).is_none()).collect();
    let report =
        Mutex::new(ShardReport { assigned: mine.len(), skipped: mine.len() - pending.len(), ..ShardReport::default() });
    let bar = progress_bar(progress, pending.len());
    let next = AtomicUsize::new(0);
    let failure: Mutex<Option<anyhow::Error>> = Mutex::new(None);
    // At most one thread per pending run, and no more than MAX_JOBS (a typo such as
    // `--jobs 100000` must not spawn a hundred thousand threads).
    let jobs = jobs.clamp(1, pending.len().clamp(1, MAX_JOBS));
    std::thread::scope(|s| {
        for _ in 0..jobs {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(run) = pending.get(i) else { break };
                    let rec = run_one(dir, run, &requirements, cancel);
                    if cancel.is_cancelled() {
                        break; // cut short, or not to be judged: run again on resume
                    }
                    let written = serde_json::to_vec_pretty(&rec)
                        .map_err(anyhow::Error::from)
                        .and_then(|b| write_atomic(&RunRecord::path(dir, run), &b));
                    if let Err(e) = written {
                        // The disk, not the run: stop this shard (resumable later).
                        failure.lock().unwrap_or_else(|p| p.into_inner()).get_or_insert(e);
                        next.store(pending.len(), Ordering::Relaxed);
                        break;
                    }
                    let mut r = report.lock().unwrap_or_else(|p| p.into_inner());
                    r.ran += 1;
                    match rec.status {
                        RunStatus::Ok => r.ok += 1,
                        RunStatus::RequirementFailed => r.requirement_failed += 1,
                        RunStatus::Error => r.errors += 1,
                        RunStatus::Diverged => r.diverged += 1,
                        RunStatus::AllRefused => r.all_refused += 1,
                        RunStatus::MarginsFailed => r.margins_failed += 1,
                        RunStatus::NoControl => r.no_control += 1,
                        RunStatus::ControlLost => r.control_lost += 1,
                        RunStatus::RecoveryFailed => r.recovery_failed += 1,
                        RunStatus::PointingDegraded => r.pointing_degraded += 1,
                        RunStatus::PropellantExceeded => r.propellant_exceeded += 1,
                    }
                    if let Some(b) = &bar {
                        b.inc(1);
                    }
                }
            });
        }
    });
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if let Some(e) = failure.into_inner().unwrap_or_else(|p| p.into_inner()) {
        return Err(e.context("writing a run's result"));
    }
    Ok(report.into_inner().unwrap_or_else(|p| p.into_inner()))
}

fn progress_bar(enabled: bool, n: usize) -> Option<indicatif::ProgressBar> {
    if !enabled || n == 0 {
        return None;
    }
    let b = indicatif::ProgressBar::new(n as u64);
    b.set_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} runs ({per_sec}, eta {eta})")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    Some(b)
}
