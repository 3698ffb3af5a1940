//! The regression corpus (`timing/corpus/<scenario>.json`: the worst inputs a search
//! found) and the budget file (`timing/budget.toml`), see docs/timing.md.

use super::search::{Found, SearchResult, mode_name};
use super::{Cost, Evaluator, InputJson};
use anyhow::{Context, Result, anyhow, bail};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One stored input and the cost measured when it was found.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Entry {
    /// "worst", "mode:<name>", "population:<k>", ...
    pub label: String,
    pub instructions: u64,
    /// Mode of the costliest step ("none" without a mode table).
    pub mode: String,
    pub status: u16,
    /// The estimation stage in that step: `estimate_flags` by name ("mekf nav sun ...",
    /// see [`super::search::estimate_names`]) and the MEKF's update counters since the
    /// upload (accepted, rejected, restarts). Empty in entries recorded before protocol 11.
    #[serde(default)]
    pub estimate: String,
    #[serde(default)]
    pub mekf_updates: [u32; 3],
    /// Most state-history nodes one late sample re-ran since the upload (0 in entries
    /// recorded before protocol 13).
    #[serde(default)]
    pub replayed_nodes: u16,
    /// What FDIR had declared after the sequence's last step ("tracker(contradicted) gyro-x wheel-0
    /// bias-step×1"; absent: nothing, or an entry recorded before this field).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub fdir: String,
    /// The costliest step of the sequence in which FDIR declared something: [step,
    /// instructions] (absent: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub declaration: Option<(usize, u64)>,
    pub input: InputJson,
}

impl Entry {
    pub fn new(label: String, f: &Found) -> Self {
        Self {
            label,
            instructions: f.cost.instructions,
            mode: mode_name(f.cost.mode).into(),
            status: f.cost.status,
            estimate: super::search::estimate_names(f.cost.estimate_flags),
            mekf_updates: [f.cost.mekf_accepted, f.cost.mekf_rejected, u32::from(f.cost.mekf_resets)],
            replayed_nodes: f.cost.replayed_nodes,
            fdir: f.cost.fdir.names(),
            declaration: f.cost.declaration,
            input: InputJson::from(&f.input),
        }
    }
}

/// `timing/corpus/<scenario>.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Corpus {
    /// Scenario name (budget key) and file, relative to the repository root.
    pub scenario: String,
    pub scenario_file: String,
    /// How the entries were found.
    pub seed: u64,
    pub budget_seconds: f64,
    pub evaluations: u64,
    pub generations: u64,
    pub worst_instructions: u64,
    pub mean_instructions: f64,
    pub population_mean_instructions: f64,
    pub nominal_instructions: Option<u64>,
    pub entries: Vec<Entry>,
}

impl Corpus {
    /// The corpus of a search: the worst input, the worst per mode, then the rest of the
    /// final population (duplicates of the same cost and mode dropped).
    pub fn from_search(scenario_file: &str, name: &str, seed: u64, budget_s: f64, r: &SearchResult) -> Self {
        let mut entries = vec![Entry::new("worst".into(), &r.worst)];
        if let Some(f) = &r.worst_no_failures {
            entries.push(Entry::new("worst:no-extra-failures".into(), f));
        }
        for (code, f) in &r.per_mode {
            entries.push(Entry::new(format!("mode:{}", mode_name(*code)), f));
        }
        for (k, f) in r.population.iter().enumerate().skip(1) {
            entries.push(Entry::new(format!("population:{k}"), f));
        }
        let mut seen = std::collections::HashSet::new();
        entries.retain(|e| seen.insert((e.instructions, e.mode.clone(), e.status)));
        Self {
            scenario: name.into(),
            scenario_file: scenario_file.into(),
            seed,
            budget_seconds: budget_s,
            evaluations: r.evaluations,
            generations: r.generations,
            worst_instructions: r.worst.cost.instructions,
            mean_instructions: r.mean_instructions,
            population_mean_instructions: r.population_mean,
            nominal_instructions: r.nominal.map(|c| c.instructions),
            entries,
        }
    }

    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))
    }

    pub fn save(&self, path: &Path) -> Result<()> {
        if let Some(d) = path.parent() {
            std::fs::create_dir_all(d).with_context(|| format!("creating {} (for {})", d.display(), path.display()))?;
        }
        sim_core::files::write_atomic(path, (serde_json::to_string_pretty(self)? + "\n").as_bytes())
    }
}

/// The searched cost of one flight step of a scenario, as other tools quote it (the
/// report's cost table): the committed corpus's figures, in instructions.
#[derive(Clone, Debug)]
pub struct StepCost {
    /// Costliest input found.
    pub worst_instructions: u64,
    /// Costliest input per mode: (mode name, instructions), in corpus order.
    pub worst_per_mode: Vec<(String, u64)>,
    /// The scenario's nominal input, when measured.
    pub nominal_instructions: Option<u64>,
    /// Inputs evaluated by the search.
    pub evaluations: u64,
}

/// The step cost of the scenario named `scenario_name`, read from the committed corpus
/// `timing/corpus/<scenario_name>.json` of the repository at `repo`.
pub fn step_cost(repo: &Path, scenario_name: &str) -> Result<StepCost> {
    let path = repo.join("timing/corpus").join(format!("{scenario_name}.json"));
    let c = Corpus::load(&path)?;
    Ok(StepCost {
        worst_instructions: c.worst_instructions,
        worst_per_mode: c
            .entries
            .iter()
            .filter_map(|e| e.label.strip_prefix("mode:").map(|m| (m.to_owned(), e.instructions)))
            .collect(),
        nominal_instructions: c.nominal_instructions,
        evaluations: c.evaluations,
    })
}

/// The repository root (where `scenarios/` and `timing/` live): the working directory if
/// it has `timing/` or `scenarios/`, else the source tree this binary was built from.
pub fn repo_root() -> PathBuf {
    let cwd = std::env::current_dir().unwrap_or_default();
    if cwd.join("scenarios").is_dir() {
        return cwd;
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `timing/budget.toml`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BudgetFile {
    /// Core clock of the flight computer, Hz (STM32F405: 168 MHz).
    pub core_clock_hz: f64,
    /// Cycles per instruction assumed to turn instructions into time (1 until the cycle
    /// estimator gives a range).
    #[serde(default = "one")]
    pub cycles_per_instruction: f64,
    /// Largest fraction of the control period one step may take.
    pub max_period_fraction: f64,
    /// Per scenario name.
    pub scenario: BTreeMap<String, ScenarioBudget>,
}

fn one() -> f64 {
    1.0
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioBudget {
    /// Largest instructions of one step (any mode).
    pub max_instructions: u64,
    /// Control period, s (checked against the scenario's).
    pub control_period_s: f64,
    /// Tighter limits per mode name.
    #[serde(default)]
    pub modes: BTreeMap<String, u64>,
}

/// One budget verdict.
#[derive(Clone, Debug)]
pub struct Verdict {
    pub ok: bool,
    pub limit: Option<u64>,
    pub period_fraction: f64,
    pub message: String,
}

impl BudgetFile {
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let b: Self = toml::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
        if !(b.core_clock_hz > 0.0 && b.cycles_per_instruction > 0.0 && b.max_period_fraction > 0.0) {
            bail!("{}: core_clock_hz, cycles_per_instruction and max_period_fraction must be > 0", path.display());
        }
        Ok(b)
    }

    /// Step time at the core clock, s.
    pub fn seconds(&self, instructions: u64) -> f64 {
        instructions as f64 * self.cycles_per_instruction / self.core_clock_hz
    }

    /// Is `instructions` (of a step in `mode`) within the scenario's budget and within
    /// `max_period_fraction` of the control period `dt_s`? A scenario without a budget
    /// fails (every shipped closed-loop scenario must have one).
    pub fn check(&self, scenario: &str, mode: &str, instructions: u64, dt_s: f64) -> Verdict {
        let frac = self.seconds(instructions) / dt_s;
        let Some(s) = self.scenario.get(scenario) else {
            return Verdict {
                ok: false,
                limit: None,
                period_fraction: frac,
                message: format!("no budget for scenario {scenario} in the budget file"),
            };
        };
        let limit = s.modes.get(mode).copied().unwrap_or(s.max_instructions).min(s.max_instructions);
        let mut problems = Vec::new();
        if instructions > limit {
            problems.push(format!("{instructions} instructions > budget {limit}"));
        }
        if frac > self.max_period_fraction {
            problems.push(format!(
                "{:.1} % of the control period > {:.1} %",
                frac * 100.0,
                self.max_period_fraction * 100.0
            ));
        }
        if (s.control_period_s - dt_s).abs() > 1e-9 * dt_s.max(1.0) {
            problems.push(format!("budget control period {} s, scenario {dt_s} s", s.control_period_s));
        }
        Verdict {
            ok: problems.is_empty(),
            limit: Some(limit),
            period_fraction: frac,
            message: if problems.is_empty() {
                format!("within budget {limit} ({:.2} % of the period)", frac * 100.0)
            } else {
                problems.join("; ")
            },
        }
    }
}

/// A replayed entry.
#[derive(Clone, Debug)]
pub struct Replayed {
    pub label: String,
    pub recorded: u64,
    pub measured: Option<Cost>,
}

/// Replays every entry of `corpus` on `ev` (whose target must be the corpus's scenario).
pub fn replay(ev: &mut Evaluator, corpus: &Corpus) -> Result<Vec<Replayed>> {
    if ev.target.name != corpus.scenario {
        bail!("corpus of {} replayed on scenario {}", corpus.scenario, ev.target.name);
    }
    corpus
        .entries
        .iter()
        .map(|e| {
            let input = e.input.input().with_context(|| format!("entry {}", e.label))?;
            let measured = ev.evaluate(&input)?;
            Ok(Replayed { label: e.label.clone(), recorded: e.instructions, measured })
        })
        .collect()
}

/// Worst demands written by the LP helper (`lp-worst-demands.json`): every array of three
/// finite numbers found under a key containing "demand" is taken as a body torque
/// direction (the file's exact layout is not fixed; unknown shapes are ignored).
pub fn demand_directions(path: &Path) -> Result<Vec<[f32; 3]>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    let mut out = Vec::new();
    fn walk(v: &serde_json::Value, under_demand: bool, out: &mut Vec<[f32; 3]>) {
        match v {
            serde_json::Value::Array(a) => {
                let nums: Vec<f64> = a.iter().filter_map(serde_json::Value::as_f64).collect();
                if under_demand && a.len() == 3 && nums.len() == 3 {
                    let n = nums.iter().map(|x| x * x).sum::<f64>().sqrt();
                    if n > 0.0 && n.is_finite() {
                        out.push([(nums[0] / n) as f32, (nums[1] / n) as f32, (nums[2] / n) as f32]);
                    }
                } else {
                    for x in a {
                        walk(x, under_demand, out);
                    }
                }
            }
            serde_json::Value::Object(o) => {
                for (k, x) in o {
                    walk(x, under_demand || k.to_lowercase().contains("demand"), out);
                }
            }
            _ => {}
        }
    }
    walk(&v, false, &mut out);
    if out.is_empty() {
        return Err(anyhow!("{}: no demand vectors found", path.display()));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file() -> BudgetFile {
        toml::from_str(
            "core_clock_hz = 168e6\nmax_period_fraction = 0.05\n\
             [scenario.s]\nmax_instructions = 90000\ncontrol_period_s = 0.01\nmodes = { hold = 50000 }\n",
        )
        .unwrap()
    }

    /// 84 000 instructions at 168 MHz and 1 cycle each take 500 µs: exactly 5 % of a
    /// 10 ms period (the limit); one tick more is over it.
    #[test]
    fn budget_verdicts_follow_the_closed_form() {
        let b = file();
        let v = b.check("s", "none", 84_000, 0.01);
        assert!(v.ok, "{}", v.message);
        assert!((v.period_fraction - 0.05).abs() < 1e-12);
        assert!(!b.check("s", "none", 84_040, 0.01).ok);
        // The mode's tighter limit, the period mismatch, an unknown scenario.
        assert!(b.check("s", "detumble", 50_040, 0.01).ok);
        assert!(!b.check("s", "hold", 50_040, 0.01).ok);
        assert!(!b.check("s", "none", 1000, 0.02).ok);
        assert!(!b.check("t", "none", 1000, 0.01).ok);
    }

    /// Demand vectors are found under any key containing "demand", as unit vectors.
    #[test]
    fn demand_directions_are_read_loosely() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("lp.json");
        std::fs::write(&p, r#"{"cases": [{"worst_demand_nm": [0.0, 3.0, -4.0], "other": [1, 2, 3]}]}"#).unwrap();
        assert_eq!(demand_directions(&p).unwrap(), vec![[0.0, 0.6, -0.8]]);
        std::fs::write(&p, r#"{"x": [1, 2, 3]}"#).unwrap();
        assert!(demand_directions(&p).is_err());
    }
}
