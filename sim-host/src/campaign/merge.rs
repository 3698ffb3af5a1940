//! `sim-host campaign merge`: every run's result into statistics of every summary key,
//! requirement verdicts with confidence bounds, groups by discrete dispersion (failure
//! masks, choices), `campaign.json` (identical whatever ran the runs: local, threads,
//! Slurm), `report.md` and histogram/CDF plots.

use super::exec::{RunRecord, RunStatus};
use super::plan::{Manifest, PlannedRun};
use super::spec::{Campaign, Distribution, Op, Requirement};
use super::stats::{self, Moments};
use super::{flatten, run_dir_name, write_atomic};
use crate::format::sig_campaign;
use anyhow::{Context, Result};
use serde::Serialize;
use sim_core::recorder::plots::{self, Figure, Panel, Series, TimeSeries};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Summary keys that time the host or the link, not the flight: left out of the
/// statistics and of `campaign.json`, which are then identical across machines.
pub const WALL_CLOCK_KEYS: [&str; 6] =
    ["wall_time_s", "real_time_factor", "mean_step_us", "max_step_us", "allocation_us_per_call", "max_step_ticks"];

/// A completed run: its plan, its record (summary dropped once read) and its summary's
/// numeric values, in the order of [`Keys`] (a few hundred bytes a run).
struct Completed<'a> {
    run: &'a PlannedRun,
    rec: RunRecord,
    values: Vec<Option<f64>>,
}

/// The summary keys the merge keeps (the manifest's, wall-clock keys removed).
struct Keys {
    names: Vec<String>,
    index: BTreeMap<String, usize>,
}

impl Keys {
    fn new(summary_keys: &[String]) -> Self {
        let names: Vec<String> =
            summary_keys.iter().filter(|k| !WALL_CLOCK_KEYS.contains(&k.as_str())).cloned().collect();
        let index = names.iter().enumerate().map(|(i, k)| (k.clone(), i)).collect();
        Self { names, index }
    }

    fn values_of(&self, summary: &serde_json::Value) -> Vec<Option<f64>> {
        let flat = flatten(summary);
        self.names.iter().map(|k| flat.get(k).copied().flatten()).collect()
    }

    fn get(&self, values: &[Option<f64>], key: &str) -> Option<f64> {
        self.index.get(key).and_then(|i| values.get(*i).copied().flatten())
    }
}

/// Worst runs listed per key.
const WORST: usize = 5;

/// The command that re-runs one run alone, from the campaign directory.
pub fn rerun_command(index: u32) -> String {
    let d = run_dir_name(index);
    format!("sim-host run runs/{d}/scenario.toml --out runs/{d}/out")
}

/// [`rerun_command`] with its paths under the campaign directory `dir` as the merge was
/// given it, for `report.md`: it then works from where the campaign was run, as typed there
/// (issue 38). `campaign.json` keeps the form relative to the campaign directory, so it
/// stays identical whichever directory and machine merged it.
fn rerun_from(dir: &Path, index: u32) -> String {
    let run = dir.join("runs").join(run_dir_name(index));
    format!("sim-host run {} --out {}", run.join("scenario.toml").display(), run.join("out").display())
}

#[derive(Clone, Debug, Serialize)]
pub struct RunValue {
    pub run: u32,
    pub value: f64,
    pub rerun: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct KeyStats {
    #[serde(flatten)]
    pub moments: Moments,
    /// Runs that flew but have no value (e.g. `settle_time_s` of a run that never settled).
    pub nulls: usize,
    /// Largest values (smallest for a key a requirement wants large: `>`, `>=`).
    pub worst: Vec<RunValue>,
}

#[derive(Clone, Copy, Debug, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    Met,
    /// Every run (or enough) passed, but too few runs to claim the probability.
    NotDemonstrated,
    NotMet,
}

#[derive(Clone, Debug, Serialize)]
pub struct RequirementResult {
    #[serde(flatten)]
    pub requirement: Requirement,
    pub runs: usize,
    pub passed: usize,
    /// One-sided lower confidence bounds on the probability of meeting it.
    pub clopper_pearson_lower: f64,
    pub wilson_lower: f64,
    pub verdict: Verdict,
    pub statement: String,
    /// Every run that missed it (errors included), ascending.
    pub failed_runs: Vec<u32>,
    /// The runs furthest on the wrong side.
    pub worst: Vec<RunValue>,
}

#[derive(Clone, Debug, Serialize)]
pub struct GroupRow {
    /// The drawn value (e.g. the failed thrusters `[1, 3]`).
    pub value: serde_json::Value,
    pub runs: usize,
    pub errors: usize,
    /// Runs of this value that diverged, whose every step was refused, or whose margins
    /// failed.
    pub failed_runs: usize,
    /// Runs of this value that missed each requirement (by name).
    pub failed: BTreeMap<String, usize>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Group {
    pub key: String,
    pub rows: Vec<GroupRow>,
}

#[derive(Clone, Debug, Serialize)]
pub struct ErrorRun {
    pub run: u32,
    pub message: String,
    pub rerun: String,
}

/// `campaign.json`.
#[derive(Clone, Debug, Serialize)]
pub struct CampaignResult {
    pub campaign: String,
    pub description: String,
    pub base_scenario: String,
    pub seed: u64,
    pub runs: usize,
    pub completed: usize,
    pub missing: Vec<u32>,
    pub ok: usize,
    pub requirement_failed: usize,
    pub errors: Vec<ErrorRun>,
    /// Runs whose state or flight command became non-finite (summary `run_status`
    /// `diverged`), and runs whose every step the flight code refused (`all_refused`):
    /// each misses every requirement and fails the campaign.
    pub diverged: Vec<u32>,
    pub all_refused: Vec<u32>,
    /// Runs whose `[margins]` measurement is not a stable loop at a steady hold (summary
    /// `run_status` `margins_failed`: `sim-host run` exits non-zero for them): each misses
    /// every requirement and fails the campaign.
    pub margins_failed: Vec<u32>,
    /// Runs the flight code could not control for a material part of (summary
    /// `run_status` `no_control`): each misses every requirement and fails the campaign.
    pub no_control: Vec<u32>,
    /// Runs with `[[faults]]` that lost control with no FDIR event (summary `run_status`
    /// `control_lost`): each misses every requirement and fails the campaign.
    pub control_lost: Vec<u32>,
    /// Runs with `[[faults]]` whose FDIR raised an event but that lost control through the
    /// end anyway, not in a safe mode (summary `run_status` `recovery_failed`): each misses
    /// every requirement and fails the campaign.
    pub recovery_failed: Vec<u32>,
    /// Runs with `[[faults]]` that held off by more than the degraded-hold bound through the
    /// end with no FDIR event (summary `run_status` `pointing_degraded`): each misses every
    /// requirement and fails the campaign.
    pub pointing_degraded: Vec<u32>,
    /// Runs whose thrusters used more propellant than `[performance] propellant_budget_kg`
    /// (summary `run_status` `propellant_exceeded`; a run that also lost or degraded its
    /// pointing is counted there): each misses every requirement and fails the campaign.
    pub propellant_exceeded: Vec<u32>,
    pub requirements: Vec<RequirementResult>,
    /// Groups by discrete dispersion (choice, k-of-n).
    pub groups: Vec<Group>,
    pub statistics: BTreeMap<String, KeyStats>,
}

impl CampaignResult {
    /// Whether the campaign passes: every run present, none in error, diverged, refused or
    /// with failed margins, every requirement met.
    pub fn passed(&self) -> bool {
        self.missing.is_empty()
            && self.errors.is_empty()
            && self.diverged.is_empty()
            && self.all_refused.is_empty()
            && self.margins_failed.is_empty()
            && self.no_control.is_empty()
            && self.control_lost.is_empty()
            && self.recovery_failed.is_empty()
            && self.pointing_degraded.is_empty()
            && self.propellant_exceeded.is_empty()
            && self.requirements.iter().all(|r| r.verdict == Verdict::Met)
    }
}

pub struct MergeOutcome {
    pub result: CampaignResult,
    pub files: Vec<PathBuf>,
    /// Total wall time of the completed runs, s (not in campaign.json: it times the host).
    pub run_wall_s: f64,
}

fn pct(x: f64) -> String {
    format!("{:.2} %", 100.0 * x)
}

fn requirement_result(r: &Requirement, keys: &Keys, records: &[Completed]) -> RequirementResult {
    let mut failed_runs = Vec::new();
    let mut wrong_side: Vec<(u32, f64)> = Vec::new();
    for Completed { run, rec, values } in records {
        let v = keys.get(values, &r.key);
        let pass = rec.status.flew() && r.met_by(v);
        if !pass {
            failed_runs.push(run.index);
        }
        if let Some(v) = v {
            wrong_side.push((run.index, if r.op.larger_is_worse() { v } else { -v }));
        }
    }
    wrong_side.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    let worst = wrong_side
        .iter()
        .take(WORST)
        .map(|(run, v)| RunValue {
            run: *run,
            value: if r.op.larger_is_worse() { *v } else { -*v },
            rerun: rerun_command(*run),
        })
        .collect();
    let n = records.len();
    let passed = n - failed_runs.len();
    let (k, nn) = (passed as u64, n as u64);
    let cp = stats::clopper_pearson_lower(k, nn, r.confidence);
    let wilson = stats::wilson_lower(k, nn, r.confidence);
    let what = format!("`{} {} {}`", r.key, r.op.symbol(), r.value);
    let conf = pct(r.confidence);
    let bounds = format!("Clopper-Pearson lower bound {} (Wilson {}) at {conf} confidence", pct(cp), pct(wilson));
    let (verdict, statement) = if r.probability >= 1.0 {
        if passed == n && n > 0 {
            (Verdict::Met, format!("{what} in every run: {passed}/{n} passed; {bounds}"))
        } else {
            (Verdict::NotMet, format!("{what} in every run: NOT MET, {passed}/{n} passed"))
        }
    } else {
        let claim = format!("{what} in >= {} of cases at {conf} confidence", pct(r.probability));
        if cp >= r.probability {
            (Verdict::Met, format!("{claim}: met, {passed}/{n} passed; {bounds}"))
        } else if n > 0 && passed as f64 / n as f64 >= r.probability {
            let need = stats::runs_to_demonstrate(r.probability, r.confidence)
                .map(|m| format!("; with no failure, {m} runs would demonstrate it"))
                .unwrap_or_default();
            (Verdict::NotDemonstrated, format!("{claim}: NOT DEMONSTRATED, {passed}/{n} passed; {bounds}{need}"))
        } else {
            (Verdict::NotMet, format!("{claim}: NOT MET, {passed}/{n} passed; {bounds}"))
        }
    };
    RequirementResult {
        requirement: r.clone(),
        runs: n,
        passed,
        clopper_pearson_lower: cp,
        wilson_lower: wilson,
        verdict,
        statement,
        failed_runs,
        worst,
    }
}

/// Order of group rows: numbers by value, arrays by length then element by element (a
/// failure mask `[2]` before `[1, 3]`), anything else by its JSON text.
fn value_order(a: &serde_json::Value, b: &serde_json::Value) -> std::cmp::Ordering {
    use serde_json::Value as V;
    match (a, b) {
        (V::Number(x), V::Number(y)) => x.as_f64().unwrap_or(0.0).total_cmp(&y.as_f64().unwrap_or(0.0)),
        (V::Array(x), V::Array(y)) => x.len().cmp(&y.len()).then_with(|| {
            x.iter().zip(y).map(|(p, q)| value_order(p, q)).find(|o| o.is_ne()).unwrap_or(std::cmp::Ordering::Equal)
        }),
        _ => a.to_string().cmp(&b.to_string()),
    }
}

/// The runs of the manifest that left a record (with their summary values), and the
/// indices of those that did not.
fn load_records<'a>(dir: &Path, manifest: &'a Manifest, keys: &Keys) -> (Vec<Completed<'a>>, Vec<u32>) {
    let mut records = Vec::new();
    let mut missing = Vec::new();
    for run in &manifest.runs {
        match RunRecord::load(dir, run) {
            Some(mut rec) => {
                let values = rec.summary.take().map(|s| keys.values_of(&s)).unwrap_or_default();
                records.push(Completed { run, rec, values });
            }
            None => missing.push(run.index),
        }
    }
    (records, missing)
}

/// Moments, nulls and worst runs of every summary key over the runs that flew (worst:
/// largest, or smallest for the keys in `smaller_is_worse`).
fn key_statistics(keys: &Keys, records: &[Completed], smaller_is_worse: &[&str]) -> BTreeMap<String, KeyStats> {
    let mut statistics = BTreeMap::new();
    for key in &keys.names {
        let mut xs = Vec::new();
        let mut nulls = 0;
        for Completed { run, rec, values } in records {
            // Errors have no summary; a diverged or refused run's partial figures are no
            // sample of the flight (they are counted apart).
            if !rec.status.flew() {
                continue;
            }
            match keys.get(values, key) {
                Some(v) => xs.push((run.index, v)),
                None => nulls += 1,
            }
        }
        let vals: Vec<f64> = xs.iter().map(|x| x.1).collect();
        if let Some(moments) = stats::moments(&vals) {
            let mut w = xs.clone();
            let sign = if smaller_is_worse.contains(&key.as_str()) { -1.0 } else { 1.0 };
            w.sort_by(|a, b| (sign * b.1).total_cmp(&(sign * a.1)).then(a.0.cmp(&b.0)));
            let worst =
                w.iter().take(WORST).map(|(r, v)| RunValue { run: *r, value: *v, rerun: rerun_command(*r) }).collect();
            statistics.insert(key.clone(), KeyStats { moments, nulls, worst });
        }
    }
    statistics
}

/// Runs, errors and missed requirements per value of each discrete dispersion (choice,
/// k-of-n).
fn groups(campaign: &Campaign, records: &[Completed], requirements: &[RequirementResult]) -> Vec<Group> {
    let mut groups = Vec::new();
    for d in campaign
        .dispersions
        .iter()
        .filter(|d| matches!(d.dist, Distribution::Choice { .. } | Distribution::KOfN { .. }))
    {
        let key = d.key.as_str();
        let mut rows: BTreeMap<String, GroupRow> = BTreeMap::new();
        for Completed { run, rec, .. } in records {
            let value = run.draws.get(key).cloned().unwrap_or(serde_json::Value::Null);
            let row = rows.entry(value.to_string()).or_insert_with(|| GroupRow {
                value: value.clone(),
                runs: 0,
                errors: 0,
                failed_runs: 0,
                failed: campaign.requirements.iter().map(|r| (r.name.clone(), 0)).collect(),
            });
            row.runs += 1;
            if rec.status == RunStatus::Error {
                row.errors += 1;
            }
            if matches!(
                rec.status,
                RunStatus::Diverged
                    | RunStatus::AllRefused
                    | RunStatus::MarginsFailed
                    | RunStatus::NoControl
                    | RunStatus::ControlLost
                    | RunStatus::RecoveryFailed
                    | RunStatus::PointingDegraded
                    | RunStatus::PropellantExceeded
            ) {
                row.failed_runs += 1;
            }
            for r in requirements {
                if r.failed_runs.binary_search(&run.index).is_ok() {
                    *row.failed.entry(r.requirement.name.clone()).or_default() += 1;
                }
            }
        }
        let mut rows: Vec<GroupRow> = rows.into_values().collect();
        rows.sort_by(|a, b| value_order(&a.value, &b.value));
        groups.push(Group { key: key.to_owned(), rows });
    }
    groups
}

/// Merges the campaign in `dir`: writes `campaign.json`, `report.md` and (with `plots`)
/// `plots/*.png`.
pub fn merge(dir: &Path, with_plots: bool) -> Result<MergeOutcome> {
    let manifest = Manifest::load(dir)?;
    let campaign = manifest.campaign()?;
    let keys = Keys::new(&manifest.summary_keys);
    let (records, missing) = load_records(dir, &manifest, &keys);
    let run_wall_s = records.iter().map(|c| c.rec.wall_time_s).sum();
    let requirements: Vec<RequirementResult> =
        campaign.requirements.iter().map(|r| requirement_result(r, &keys, &records)).collect();
    // A key required to be large (`>`, `>=`: a margin) is worst at its smallest values.
    let smaller_is_worse: Vec<&str> =
        campaign.requirements.iter().filter(|r| !r.op.larger_is_worse()).map(|r| r.key.as_str()).collect();
    let statistics = key_statistics(&keys, &records, &smaller_is_worse);
    let groups = groups(&campaign, &records, &requirements);
    let errors = records
        .iter()
        .filter(|c| c.rec.status == RunStatus::Error)
        .map(|c| ErrorRun {
            run: c.run.index,
            message: c.rec.error.clone().unwrap_or_default(),
            rerun: rerun_command(c.run.index),
        })
        .collect();
    let count = |s: RunStatus| records.iter().filter(|c| c.rec.status == s).count();
    let runs_of = |s: RunStatus| records.iter().filter(|c| c.rec.status == s).map(|c| c.run.index).collect();
    let result = CampaignResult {
        campaign: manifest.campaign.name.clone(),
        description: manifest.campaign.description.clone(),
        base_scenario: manifest.base_scenario.clone(),
        seed: manifest.campaign.seed,
        runs: manifest.runs.len(),
        completed: records.len(),
        missing,
        ok: count(RunStatus::Ok),
        requirement_failed: count(RunStatus::RequirementFailed),
        errors,
        diverged: runs_of(RunStatus::Diverged),
        all_refused: runs_of(RunStatus::AllRefused),
        margins_failed: runs_of(RunStatus::MarginsFailed),
        no_control: runs_of(RunStatus::NoControl),
        control_lost: runs_of(RunStatus::ControlLost),
        recovery_failed: runs_of(RunStatus::RecoveryFailed),
        pointing_degraded: runs_of(RunStatus::PointingDegraded),
        propellant_exceeded: runs_of(RunStatus::PropellantExceeded),
        requirements,
        groups,
        statistics,
    };

    let mut files = Vec::new();
    let json_path = dir.join("campaign.json");
    write_atomic(&json_path, serde_json::to_string_pretty(&result)?.as_bytes())?;
    files.push(json_path);
    let mut figures = Vec::new();
    if with_plots {
        figures = write_plots(dir, &result, &keys, &records)?;
        files.extend(figures.iter().cloned());
    }
    let md_path = dir.join("report.md");
    write_atomic(&md_path, report_markdown(&result, &figures, dir, run_wall_s).as_bytes())?;
    files.push(md_path);
    Ok(MergeOutcome { result, files, run_wall_s })
}

fn file_stem_of(key: &str) -> String {
    key.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '-' }).collect()
}

/// A histogram and the empirical CDF of each requirement's key (and the final error).
fn write_plots(dir: &Path, result: &CampaignResult, keys: &Keys, records: &[Completed]) -> Result<Vec<PathBuf>> {
    let mut plotted: Vec<(String, Option<&RequirementResult>)> =
        result.requirements.iter().map(|r| (r.requirement.key.clone(), Some(r))).collect();
    if !plotted.iter().any(|k| k.0 == "final_error_deg") {
        plotted.push(("final_error_deg".into(), None));
    }
    let mut seen = std::collections::BTreeSet::new();
    plotted.retain(|k| seen.insert(k.0.clone()));
    let out = dir.join("plots");
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let ctx = plots::FigureContext::new(&format!("campaign {}", result.campaign));
    let mut files = Vec::new();
    for (key, req) in plotted {
        let flown = records.iter().filter(|c| c.rec.status.flew()).count();
        let mut xs: Vec<f64> =
            records.iter().filter(|c| c.rec.status.flew()).filter_map(|c| keys.get(&c.values, &key)).collect();
        if xs.is_empty() {
            continue;
        }
        xs.sort_by(f64::total_cmp);
        let (ts, fig) = distribution_figure(&key, &xs, flown, req.map(|r| &r.requirement));
        files.extend(plots::render(&out, &ts, &[fig], &ctx)?);
    }
    Ok(files)
}

/// The columns of [`distribution_figure`] (`xs` sorted, not empty): `x`, `cdf` and its
/// Clopper–Pearson lower bound `cdf_lower`, `tail` = 1 − CDF and `tail_upper`, `cdf_upper`
/// (the CDF's one-sided upper bound: the lower tail's, for a key required to be large),
/// `runs` (the histogram of `bins` bins, on rows of its own at the bins' left edges, drawn
/// as steps).
/// The CDF goes on at 1 to `end` when that is right of the data.
fn distribution_series(xs: &[f64], end: Option<f64>, confidence: f64, bins: usize) -> TimeSeries {
    let n = xs.len();
    let (lo, hi) = (xs[0], xs[n - 1]);
    let width = if hi > lo { (hi - lo) / bins as f64 } else { 1.0 };
    let mut counts = vec![0.0; bins];
    for x in xs {
        counts[(((x - lo) / width) as usize).min(bins - 1)] += 1.0;
    }
    let names = ["x", "cdf", "cdf_lower", "tail", "tail_upper", "cdf_upper", "runs"].map(String::from).to_vec();
    let mut ts = TimeSeries::with_columns(names, n + bins + 3);
    let mut push = |x: f64, f: f64, lower: f64, upper: f64, runs: f64| {
        ts.push_row(&[x, f, lower, 1.0 - f, 1.0 - lower, upper, runs])
    };
    // Upper bound of the fraction k/n: one minus the lower bound of the complement's.
    let upper = |k: usize| 1.0 - stats::clopper_pearson_lower((n - k) as u64, n as u64, confidence);
    push(lo, 0.0, 0.0, upper(0), f64::NAN);
    // The CDF steps up at each distinct value (to the count of runs at or below it).
    for (k, x) in xs.iter().enumerate() {
        if k + 1 < n && xs[k + 1] == *x {
            continue;
        }
        let cp = stats::clopper_pearson_lower(k as u64 + 1, n as u64, confidence);
        push(*x, (k + 1) as f64 / n as f64, cp, upper(k + 1), f64::NAN);
    }
    if let Some(end) = end.filter(|v| *v > hi) {
        push(end, 1.0, stats::clopper_pearson_lower(n as u64, n as u64, confidence), 1.0, f64::NAN);
    }
    let nan = f64::NAN;
    for (b, c) in counts.iter().enumerate() {
        push(lo + b as f64 * width, nan, nan, nan, *c);
    }
    push(lo + bins as f64 * width, nan, nan, nan, counts[bins - 1]);
    ts
}

/// The figure of one key's distribution over the runs (`xs` sorted, the values of the
/// `flown` runs that have one): the empirical CDF as a step function with its one-sided
/// Clopper–Pearson lower bound at the requirement's confidence (95 % without one), the
/// requirement's threshold (vertical) and probability (horizontal, on the side of the CDF
/// the requirement is on), the failing side's tail on a log axis with its upper bound (the
/// fraction above x, or below x for a key required to be large: a margin), and a 30-bin
/// histogram. The title says how many runs have no value (they fail any requirement on it).
fn distribution_figure(key: &str, xs: &[f64], flown: usize, req: Option<&Requirement>) -> (TimeSeries, Figure) {
    let n = xs.len();
    let confidence = req.map_or(0.95, |r| r.confidence);
    let bins = 30usize;
    let ts = distribution_series(xs, req.map(|r| r.value), confidence, bins);
    let conf = format!("{:.0} %", 100.0 * confidence);
    let mut cdf = Panel {
        title: "empirical CDF (steps) and its one-sided Clopper–Pearson lower bound".into(),
        y_label: "fraction of runs ≤ x".into(),
        series: vec![
            Series { column: "cdf".into(), label: "CDF".into(), dashed: false },
            Series { column: "cdf_lower".into(), label: format!("lower bound, {conf}"), dashed: true },
        ],
        step: true,
        ..Default::default()
    };
    let large = req.is_some_and(|r| matches!(r.op, Op::Gt | Op::Ge));
    let (side, column, bound, label) =
        if large { ("at or below", "cdf", "cdf_upper", "CDF") } else { ("above", "tail", "tail_upper", "1 − CDF") };
    let mut tail = Panel {
        title: format!("failing side: fraction of runs {side} x, and its Clopper–Pearson upper bound (log)"),
        y_label: format!("fraction of runs {}", if large { "≤ x" } else { "> x" }),
        series: vec![
            Series { column: column.into(), label: label.into(), dashed: false },
            Series { column: bound.into(), label: format!("upper bound, {conf}"), dashed: true },
        ],
        step: true,
        log_y: true,
        ..Default::default()
    };
    let mut x_lines = Vec::new();
    let runs = if n < flown {
        format!("{n} of {flown} runs have a value ({} without: failures of any requirement on it)", flown - n)
    } else {
        format!("{n} runs")
    };
    let mut title = format!("{key}: {runs}");
    if let Some(r) = req {
        let needed = match r.op {
            Op::Lt | Op::Le => r.probability,
            Op::Gt | Op::Ge => 1.0 - r.probability,
        };
        cdf.thresholds.push((needed, format!("required ({})", r.name)));
        let allowed = if large { needed } else { 1.0 - needed };
        tail.thresholds.push((allowed, format!("allowed ({})", r.name)));
        x_lines.push((r.value, format!("threshold ({})", r.name)));
        title = format!("{key}: {runs}, requirement {} ({} % at {conf})", r.name, 100.0 * r.probability);
    }
    let fig = Figure {
        file_name: format!("{}.png", file_stem_of(key)),
        title,
        x: "x".into(),
        x_label: format!("{key} (dashed vertical: the requirement's threshold)"),
        panels: vec![
            cdf,
            tail,
            Panel {
                title: "histogram".into(),
                y_label: "runs per bin".into(),
                series: vec![Series { column: "runs".into(), label: format!("{bins} bins"), dashed: false }],
                step: true,
                ..Default::default()
            },
        ],
        x_lines,
        ..Default::default()
    };
    (ts, fig)
}

/// The report's head: base scenario, run counts, failed and missing runs, the verdict.
fn md_head(s: &mut String, r: &CampaignResult, dir: &Path) {
    let _ = writeln!(s, "# Campaign `{}`\n", r.campaign);
    if !r.description.is_empty() {
        let _ = writeln!(s, "{}\n", r.description);
    }
    let _ = writeln!(
        s,
        "Base scenario `{}`, master seed {}. {} of {} runs completed: {} met every requirement, {} missed one, \
         {} diverged (non-finite state or command), {} had every step refused by the flight code, \
         {} had margins that are not a stable loop at a steady hold, {} were not controlled for a material \
         part of the run, {} lost control with no FDIR event, {} lost control after an FDIR event and not in a safe mode \
         (recovery failed), {} held off their pointing with no FDIR event, {} used more propellant than their budget, \
         {} ended in error.\n",
        r.base_scenario,
        r.seed,
        r.completed,
        r.runs,
        r.ok,
        r.requirement_failed,
        r.diverged.len(),
        r.all_refused.len(),
        r.margins_failed.len(),
        r.no_control.len(),
        r.control_lost.len(),
        r.recovery_failed.len(),
        r.pointing_degraded.len(),
        r.propellant_exceeded.len(),
        r.errors.len()
    );
    for (what, runs) in [
        ("Diverged runs", &r.diverged),
        ("Runs with every step refused", &r.all_refused),
        ("Runs whose margins are not a stable loop at a steady hold (`margins.status`)", &r.margins_failed),
        ("Runs not controlled for a material part of the run (`run_status` `no_control`)", &r.no_control),
        ("Runs that lost control with no FDIR event (`run_status` `control_lost`)", &r.control_lost),
        ("Runs whose recovery from a declared fault failed (`run_status` `recovery_failed`)", &r.recovery_failed),
        (
            "Runs that held off their pointing with no FDIR event (`run_status` `pointing_degraded`)",
            &r.pointing_degraded,
        ),
        (
            "Runs that used more propellant than their budget (`run_status` `propellant_exceeded`)",
            &r.propellant_exceeded,
        ),
    ] {
        if !runs.is_empty() {
            let shown: Vec<String> = runs.iter().take(50).map(|i| format!("{i} (`{}`)", rerun_from(dir, *i))).collect();
            let _ = writeln!(s, "**{what} ({}, each fails every requirement):** {}\n", runs.len(), shown.join(", "));
        }
    }
    if !r.missing.is_empty() {
        let shown: Vec<String> = r.missing.iter().take(50).map(u32::to_string).collect();
        let _ = writeln!(s, "**Missing runs ({}):** {}\n", r.missing.len(), shown.join(", "));
    }
    let _ = writeln!(s, "**Verdict: {}**\n", if r.passed() { "PASS" } else { "FAIL" });
}

/// The requirements table and each requirement's statement with its worst runs.
fn md_requirements(s: &mut String, r: &CampaignResult, dir: &Path) {
    if r.requirements.is_empty() {
        return;
    }
    let _ = writeln!(s, "## Requirements\n\n| requirement | passed | CP lower | verdict |\n|---|---|---|---|");
    for q in &r.requirements {
        let _ = writeln!(
            s,
            "| {} | {}/{} | {} | {:?} |",
            q.requirement.name,
            q.passed,
            q.runs,
            pct(q.clopper_pearson_lower),
            q.verdict
        );
    }
    s.push('\n');
    for q in &r.requirements {
        let _ = writeln!(s, "- {}", q.statement);
        for w in q.worst.iter().take(3) {
            let _ = writeln!(
                s,
                "  - run {}: {} = {} (`{}`)",
                w.run,
                q.requirement.key,
                sig_campaign(w.value),
                rerun_from(dir, w.run)
            );
        }
    }
    s.push('\n');
}

/// One table per discrete dispersion, then the runs in error.
fn md_groups_and_errors(s: &mut String, r: &CampaignResult, dir: &Path) {
    for g in &r.groups {
        let _ = writeln!(s, "## By `{}`\n", g.key);
        let names: Vec<&String> = r.requirements.iter().map(|q| &q.requirement.name).collect();
        let _ = write!(s, "| value | runs | errors | diverged, refused or margins failed |");
        for n in &names {
            let _ = write!(s, " missed `{n}` |");
        }
        let _ = write!(s, "\n|---|---|---|---|");
        for _ in &names {
            s.push_str("---|");
        }
        s.push('\n');
        for row in &g.rows {
            let _ = write!(s, "| `{}` | {} | {} | {} |", row.value, row.runs, row.errors, row.failed_runs);
            for n in &names {
                let _ = write!(s, " {} |", row.failed.get(*n).copied().unwrap_or(0));
            }
            s.push('\n');
        }
        s.push('\n');
    }
    if !r.errors.is_empty() {
        let _ = writeln!(s, "## Runs in error\n");
        for e in r.errors.iter().take(50) {
            let _ = writeln!(s, "- run {}: {} (`{}`)", e.run, e.message, rerun_from(dir, e.run));
        }
        s.push('\n');
    }
}

/// The statistics table of the keys that vary over the campaign.
fn md_statistics(s: &mut String, r: &CampaignResult) {
    let _ = writeln!(
        s,
        "## Statistics\n\n| key | n | nulls | mean | sd | min | p50 | p95 | p99 | max | worst run |\n|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for (k, st) in &r.statistics {
        let m = &st.moments;
        if m.min == m.max && st.nulls == 0 {
            continue; // constant over the campaign: nothing to learn
        }
        let _ = writeln!(
            s,
            "| {k} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            m.n,
            st.nulls,
            sig_campaign(m.mean),
            sig_campaign(m.sd),
            sig_campaign(m.min),
            sig_campaign(m.p50),
            sig_campaign(m.p95),
            sig_campaign(m.p99),
            sig_campaign(m.max),
            st.worst.first().map_or(String::new(), |w| w.run.to_string())
        );
    }
    s.push_str("\n(Keys constant over every run are left out; see campaign.json.)\n\n");
}

fn report_markdown(r: &CampaignResult, figures: &[PathBuf], dir: &Path, run_wall_s: f64) -> String {
    let mut s = String::new();
    md_head(&mut s, r, dir);
    md_requirements(&mut s, r, dir);
    md_groups_and_errors(&mut s, r, dir);
    md_statistics(&mut s, r);
    if !figures.is_empty() {
        let _ = writeln!(s, "## Figures\n");
        for f in figures {
            let rel = f.strip_prefix(dir).unwrap_or(f);
            let _ = writeln!(s, "![{}]({})", rel.display(), rel.display());
        }
        s.push('\n');
    }
    let _ = writeln!(
        s,
        "The commands above work from the directory the campaign was run in; from this directory, re-run any run \
         alone with `sim-host run runs/NNNNNN/scenario.toml --out DIR`.\n\n\
         Host time of the completed runs: {run_wall_s:.2} s in all, {:.2} ms per run (not in campaign.json).",
        1e3 * run_wall_s / r.completed.max(1) as f64
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdf_figure_has_steps_the_threshold_and_the_bound() {
        let xs: Vec<f64> = (0..200).map(|i| 4.0 + 0.03 * i as f64).collect();
        let req = Requirement {
            name: "settle < 15 s".into(),
            key: "settle_time_s".into(),
            op: Op::Lt,
            value: 15.0,
            probability: 0.99,
            confidence: 0.95,
        };
        let (ts, fig) = distribution_figure("settle_time_s", &xs, xs.len(), Some(&req));
        let plan = plots::plan(&ts, &fig, &plots::FigureContext::new("campaign c")).unwrap();
        // The x axis reaches the threshold (the data stop at 9.97).
        assert!(plan.x_range.0 <= 4.0 && plan.x_range.1 >= 15.0, "{:?}", plan.x_range);
        assert_eq!(plan.x_lines.len(), 1);
        let cdf = &plan.panels[0];
        assert!(cdf.step, "the empirical CDF is a step function");
        assert!(cdf.thresholds.iter().any(|t| t.0 == 0.99), "the required probability is drawn");
        // The Clopper–Pearson bound lies under the CDF, and the CDF reaches 1.
        let (f, lower) = (ts.col("cdf").unwrap(), ts.col("cdf_lower").unwrap());
        assert!(f.iter().zip(lower).filter(|(a, _)| a.is_finite()).all(|(a, b)| b <= a));
        assert_eq!(f.iter().copied().filter(|v| v.is_finite()).fold(0.0, f64::max), 1.0);
        assert!(plan.title.contains("settle < 15 s"));
        assert!(fig.panels[1].series[0].column == "tail", "a key required small fails above x");
    }

    /// The eo-cubesat campaign's requirement name was cut at the figure's right edge
    /// ("threshold (hold APE (95 % of the time) <"): every legend line, measured with the
    /// embedded font at the size it is drawn, ends inside the legend column, and every word
    /// of every label is in the legend.
    #[test]
    fn long_requirement_names_are_wrapped_inside_the_legend() {
        let xs: Vec<f64> = (0..200).map(|i| 0.001 * i as f64).collect();
        let name = "hold APE (95 % of the time) < 0.5 deg over every target pass, boresight";
        let req = Requirement {
            name: name.into(),
            key: "pointing.ape_deg".into(),
            op: Op::Lt,
            value: 0.5,
            probability: 0.95,
            confidence: 0.9,
        };
        let (ts, fig) = distribution_figure("pointing.ape_deg", &xs, xs.len(), Some(&req));
        let plan = plots::plan(&ts, &fig, &plots::FigureContext::new("campaign eo-cubesat-dispersed")).unwrap();
        let legend_w = plan.legend_area.x1 - plan.legend_area.x0;
        for (k, panel) in plan.panels.iter().enumerate() {
            let text: Vec<&str> = panel.legend.iter().flat_map(|e| e.lines.iter().map(|l| l.as_str())).collect();
            for e in &panel.legend {
                for l in &e.lines {
                    let right = e.x + plots::text_width(l, e.size) as i32;
                    assert!(right <= legend_w, "{l:?} ends at {right} px, the column is {legend_w} px");
                }
                let bottom = e.y + (e.lines.len() as i32 - 1) * e.line_height() + e.size as i32 / 2;
                assert!(bottom <= plan.cell_height(k) as i32, "{:?} below the panel", e.lines);
            }
            assert!(name.split(' ').all(|w| text.iter().any(|l| l.contains(w))), "{text:?}");
        }
        assert!(plots::text_width(&plan.title, plan.title_size) <= plan.width - 20);
    }

    /// A key required to be large (a margin): the tail panel is the lower tail (the failing
    /// side), with its upper bound above it and the allowed fraction `1 − p`; runs without a
    /// value are counted in the title.
    #[test]
    fn a_key_required_large_shows_its_lower_tail_and_the_runs_without_a_value() {
        let xs: Vec<f64> = (0..297).map(|i| 60.0 + 0.05 * i as f64).collect();
        let req = Requirement {
            name: "PM >= 30".into(),
            key: "margins.phase_margin_deg".into(),
            op: Op::Ge,
            value: 30.0,
            probability: 0.99,
            confidence: 0.95,
        };
        let (ts, fig) = distribution_figure("margins.phase_margin_deg", &xs, 300, Some(&req));
        let tail = &fig.panels[1];
        assert_eq!(tail.series[0].column, "cdf");
        assert_eq!(tail.series[1].column, "cdf_upper");
        assert!(tail.title.contains("at or below"), "{}", tail.title);
        assert!(tail.thresholds.iter().any(|t| (t.0 - 0.01).abs() < 1e-12), "{:?}", tail.thresholds);
        assert!(fig.title.contains("297 of 300 runs have a value"), "{}", fig.title);
        let (f, upper) = (ts.col("cdf").unwrap(), ts.col("cdf_upper").unwrap());
        assert!(f.iter().zip(upper).filter(|(a, _)| a.is_finite()).all(|(a, b)| b >= a));
        // At the lowest value one run of 297 is at or below it: its upper bound is the
        // Clopper–Pearson bound of 1 in 297 (1 − lower bound of 296 in 297).
        let want = 1.0 - stats::clopper_pearson_lower(296, 297, 0.95);
        assert!((upper[1] - want).abs() < 1e-12, "{} vs {want}", upper[1]);
    }
}
