//! What an experiment of the reproduction report returns, and the small toolkit the
//! experiments share (scenario loading, flying variants in parallel, sweep figures).
//!
//! An experiment explains one published number we do not match: it flies variants of a
//! shipped scenario (what the paper names: sensor noise, latency, friction, thrust
//! level, ...), tabulates and plots the effect, and states whether the variants bring our
//! figure to the paper's. Its `findings` are the named numbers the report's outcome table
//! and the experiment's test read; its `blocks` are what the report prints.

pub use crate::format::sig;
use anyhow::{Context as _, Result};
use sim_core::link::{self, FlightLink, LinkKind, LinkOptions};
use sim_core::recorder::plots::{self, Figure};
use sim_core::recorder::series::TimeSeries;
use sim_core::runner::{self, RunResult};
use sim_core::scenario::Scenario;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One piece of an experiment's (or a paper section's) body, rendered to Markdown and HTML.
#[derive(Clone, Debug, PartialEq)]
pub enum Block {
    /// A paragraph of Markdown-light text (inline `code`, **bold**; no headings).
    Para(String),
    /// A table: header cells and rows of already formatted cells.
    Table { header: Vec<String>, rows: Vec<Vec<String>> },
    /// A figure written by the experiment into [`Context::fig_dir`]: its file name there.
    Figure { file: String, caption: String },
}

/// Whether an experiment accounts for the gap it was written for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Explains {
    /// Some named effect (or combination) brings our figure to the paper's within the
    /// outcome's tolerance, or shows the published figure cannot come from the stated set-up.
    Yes,
    /// No tested effect does; the conclusion says what was ruled out.
    No,
}

/// The result of one experiment.
#[derive(Clone, Debug)]
pub struct Experiment {
    /// Stable identifier, e.g. `p000-rig-effects` (the outcome table refers to it).
    pub id: &'static str,
    /// Paper number as in `docs/papers.md`: "000" … "004".
    pub paper: &'static str,
    pub title: String,
    /// The gap, in one or two sentences: the paper's figure, ours, the question.
    pub question: String,
    pub blocks: Vec<Block>,
    /// Named numbers (units in the name: `settle_s`, `rms_deg`, `propellant_kg`, …).
    pub findings: BTreeMap<String, f64>,
    /// One paragraph: what explains the gap, or what was ruled out.
    pub conclusion: String,
    pub explains: Explains,
}

impl Experiment {
    /// A finding by name, or an error naming the experiment and the key.
    pub fn finding(&self, key: &str) -> Result<f64> {
        self.findings.get(key).copied().with_context(|| format!("experiment {} has no finding {key}", self.id))
    }
}

/// Where an experiment reads scenarios and writes figures, and how many threads it may use.
#[derive(Clone, Debug)]
pub struct Context {
    /// Repository root (scenarios are read from `repo/scenarios/...`).
    pub repo: PathBuf,
    /// Directory for the experiment's figures (created by the caller).
    pub fig_dir: PathBuf,
    /// Worker threads for [`par_map`] (≥ 1).
    pub jobs: usize,
}

impl Context {
    /// Loads `scenarios/<rel>` (e.g. `paper000/test3.toml`).
    pub fn scenario(&self, rel: &str) -> Result<Scenario> {
        load_scenario(&self.repo, rel)
    }

    /// What the experiment's figures name: the experiment (its figure directory).
    fn figure_context(&self) -> plots::FigureContext {
        let name = self.fig_dir.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
        plots::FigureContext::new(&format!("reproduction report, experiment {name}"))
    }

    /// Renders `fig` from `ts` into [`Self::fig_dir`]; returns the figure block.
    pub fn figure(&self, ts: &TimeSeries, fig: Figure, caption: &str) -> Result<Block> {
        let file = fig.file_name.clone();
        plots::render(&self.fig_dir, ts, std::slice::from_ref(&fig), &self.figure_context())
            .with_context(|| format!("rendering {file}"))?;
        Ok(Block::Figure { file, caption: caption.to_owned() })
    }
}

fn in_process() -> Result<Box<dyn FlightLink>> {
    link::open(&LinkKind::InProcess, &LinkOptions::default())
}

/// Flies a scenario in-process, recording nothing but the summary (the campaign runner's).
pub use sim_core::runner::fly;

/// Flies a scenario in-process and keeps every recorded row.
pub fn fly_recorded(sc: &Scenario) -> Result<RunResult> {
    let mut l = in_process()?;
    runner::run(sc, l.as_mut(), false)
}

/// `scenarios/<rel>` of the repository at `repo`.
pub fn load_scenario(repo: &std::path::Path, rel: &str) -> Result<Scenario> {
    let path = repo.join("scenarios").join(rel);
    Scenario::load(&path).with_context(|| format!("loading {}", path.display()))
}

/// `f` over `items` on `jobs` threads, results in item order (deterministic whatever
/// `jobs`: each item is computed independently).
pub fn par_map<T: Sync, R: Send>(jobs: usize, items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let jobs = jobs.clamp(1, items.len().max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut slots: Vec<Option<R>> = (0..items.len()).map(|_| None).collect();
    let done = std::sync::Mutex::new(Vec::with_capacity(items.len()));
    std::thread::scope(|s| {
        for _ in 0..jobs {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(item) = items.get(i) else { break };
                    let r = f(item);
                    done.lock().unwrap_or_else(|e| e.into_inner()).push((i, r));
                }
            });
        }
    });
    for (i, r) in done.into_inner().unwrap_or_else(|e| e.into_inner()) {
        slots[i] = Some(r);
    }
    slots.into_iter().flatten().collect()
}

/// A table built from a sweep: one column per name, rows of numbers formatted with `digits`
/// significant digits (see [`sig`]).
pub fn sweep_table(header: &[&str], rows: &[Vec<f64>], digits: usize) -> Block {
    Block::Table {
        header: header.iter().map(|s| (*s).to_owned()).collect(),
        rows: rows.iter().map(|r| r.iter().map(|&x| sig(x, digits)).collect()).collect(),
    }
}

/// Builds a time series from named columns of equal length (for sweep figures drawn with
/// [`plots::render`], whose x axis may be any column).
pub fn columns(cols: &[(&str, Vec<f64>)]) -> TimeSeries {
    let n = cols.first().map_or(0, |c| c.1.len());
    let mut ts = TimeSeries::with_columns(cols.iter().map(|c| c.0.to_owned()).collect(), n);
    for i in 0..n {
        let row: Vec<f64> = cols.iter().map(|c| c.1.get(i).copied().unwrap_or(f64::NAN)).collect();
        ts.push_row(&row);
    }
    ts
}

/// Repository root of this source tree (for tests and the CLI default).
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn par_map_keeps_order() {
        let v: Vec<u64> = (0..100).collect();
        let out = par_map(3, &v, |x| x * x);
        assert_eq!(out, v.iter().map(|x| x * x).collect::<Vec<_>>());
    }
}
