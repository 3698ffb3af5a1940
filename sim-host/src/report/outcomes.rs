//! The published outcomes (`docs/outcomes.toml`): each one the paper's claim, where our
//! figure comes from, the check that decides "reproduced", and what explains a difference.
//! Parsed once into typed values; a reference to a run, metric or experiment that does not
//! exist is an error, not an empty cell.

use super::experiment::{Experiment, Explains, sig};
use anyhow::{Context as _, Result, bail};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    outcome: Vec<Outcome>,
}

/// Where our figure comes from.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged, deny_unknown_fields)]
pub enum Source {
    /// A key of a run's `summary.json` (e.g. `settle_time_s`, `final_euler_deg[2]`) or a
    /// metric the report derives from its time series (`report::metrics`); `run` is the
    /// scenario path under `scenarios/` without `.toml` (`paper000/test3`).
    Run { run: String, key: String },
    /// A named finding of an experiment.
    Experiment { experiment: String, finding: String },
}

/// The check that makes a row "reproduced".
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
pub enum Check {
    Lt {
        value: f64,
    },
    Le {
        value: f64,
    },
    Gt {
        value: f64,
    },
    Ge {
        value: f64,
    },
    /// |ours − value| ≤ abs.
    Within {
        value: f64,
        abs: f64,
    },
    /// |ours − value| ≤ rel·|value|.
    Rel {
        value: f64,
        rel: f64,
    },
    /// lo ≤ ours ≤ hi.
    Range {
        lo: f64,
        hi: f64,
    },
}

impl Check {
    pub fn passes(&self, x: f64) -> bool {
        if !x.is_finite() {
            return false;
        }
        match *self {
            Check::Lt { value } => x < value,
            Check::Le { value } => x <= value,
            Check::Gt { value } => x > value,
            Check::Ge { value } => x >= value,
            Check::Within { value, abs } => (x - value).abs() <= abs,
            Check::Rel { value, rel } => (x - value).abs() <= rel * value.abs(),
            Check::Range { lo, hi } => (lo..=hi).contains(&x),
        }
    }

    /// The criterion as text, in the row's unit.
    pub fn text(&self, unit: &str) -> String {
        let g = |v: f64| with_unit(v, 3, unit);
        let n = |v: f64| sig(v, 3);
        match *self {
            Check::Lt { value } => format!("< {}", g(value)),
            Check::Le { value } => format!("≤ {}", g(value)),
            Check::Gt { value } => format!("> {}", g(value)),
            Check::Ge { value } => format!("≥ {}", g(value)),
            Check::Within { value, abs } => format!("{} ± {}", n(value), g(abs)),
            Check::Rel { value, rel } => format!("{} ± {} %", g(value), n(rel * 100.0)),
            Check::Range { lo, hi } => format!("{} … {}", n(lo), g(hi)),
        }
    }
}

/// One published outcome.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Outcome {
    /// "000" … "004".
    pub paper: String,
    pub id: String,
    /// The paper's claim (each paper in our words: `docs/papers.md`).
    pub claim: String,
    /// The paper's figure as printed ("~10 s", "0.6412 kg").
    pub paper_value: String,
    pub ours: Source,
    /// When set, ours = ours / ratio_to (e.g. test 3's settle time over test 1's).
    #[serde(default)]
    pub ratio_to: Option<Source>,
    #[serde(default)]
    pub unit: String,
    #[serde(default = "three")]
    pub digits: usize,
    pub check: Check,
    /// The experiment that investigates a difference.
    #[serde(default)]
    pub experiment: Option<String>,
    /// An analytic explanation of a difference (no experiment needed), e.g. a definition
    /// the paper does not give.
    #[serde(default)]
    pub explanation: Option<String>,
    /// The experiment's variant that comes closest to the paper (shown beside the verdict).
    #[serde(default)]
    pub best: Option<Source>,
}

/// `x` and its unit: "2.03°", "6.34 s".
pub fn with_unit(x: f64, digits: usize, unit: &str) -> String {
    if x.is_nan() {
        return "—".into();
    }
    match unit {
        "" => sig(x, digits),
        u if u.starts_with('°') => format!("{}{u}", sig(x, digits)),
        u => format!("{} {u}", sig(x, digits)),
    }
}

fn three() -> usize {
    3
}

/// How our figure compares with the paper's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    Reproduced,
    DiffersExplained,
    DiffersOpen,
}

impl Verdict {
    pub fn text(self) -> &'static str {
        match self {
            Verdict::Reproduced => "reproduced",
            Verdict::DiffersExplained => "differs, explained",
            Verdict::DiffersOpen => "differs, open",
        }
    }
}

/// A row of the outcome table.
#[derive(Clone, Debug)]
pub struct Row {
    pub outcome: Outcome,
    /// NaN when the source has no value (e.g. a run that never settles).
    pub ours: f64,
    pub verdict: Verdict,
    /// Experiment or explanation that the verdict rests on (text).
    pub basis: String,
}

/// Reads and checks `docs/outcomes.toml`.
pub fn load(path: &Path) -> Result<Vec<Outcome>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let f: File = toml::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    let mut seen = std::collections::BTreeSet::new();
    for o in &f.outcome {
        if !seen.insert((o.paper.clone(), o.id.clone())) {
            bail!("{}: outcome {}/{} twice", path.display(), o.paper, o.id);
        }
    }
    Ok(f.outcome)
}

/// Values a row can read: per run (summary keys and derived metrics), per experiment.
pub struct Values<'a> {
    pub runs: &'a BTreeMap<String, BTreeMap<String, f64>>,
    pub experiments: &'a BTreeMap<String, Experiment>,
}

impl Values<'_> {
    /// The source's value; NaN when the key exists but has no value (null); an error when
    /// the run, key, experiment or finding does not exist.
    pub fn get(&self, s: &Source) -> Result<f64> {
        match s {
            Source::Run { run, key } => {
                let r = self.runs.get(run).with_context(|| format!("no run {run}"))?;
                r.get(key).copied().with_context(|| format!("run {run} has no key {key}"))
            }
            Source::Experiment { experiment, finding } => self
                .experiments
                .get(experiment)
                .with_context(|| format!("no experiment {experiment}"))?
                .finding(finding),
        }
    }
}

/// Evaluates every outcome: value, check, verdict and its basis.
pub fn evaluate(outcomes: &[Outcome], v: &Values) -> Result<Vec<Row>> {
    outcomes
        .iter()
        .map(|o| {
            let mut x = v.get(&o.ours).with_context(|| format!("outcome {}/{}", o.paper, o.id))?;
            if let Some(d) = &o.ratio_to {
                x /= v.get(d).with_context(|| format!("outcome {}/{}", o.paper, o.id))?;
            }
            let exp = o
                .experiment
                .as_ref()
                .map(|id| {
                    v.experiments.get(id).with_context(|| format!("outcome {}/{}: no experiment {id}", o.paper, o.id))
                })
                .transpose()?;
            let best = o
                .best
                .as_ref()
                .map(|b| v.get(b).with_context(|| format!("outcome {}/{}", o.paper, o.id)))
                .transpose()?;
            let (verdict, basis) = if o.check.passes(x) {
                (Verdict::Reproduced, String::new())
            } else if let (Some(b), Some(id)) = (best.filter(|b| o.check.passes(*b)), &o.experiment) {
                // A named variant of the experiment meets the same check: that variant's
                // parameters account for the difference, whatever the experiment's overall verdict.
                (
                    Verdict::DiffersExplained,
                    format!("experiment `{id}`: its closest variant gives {}", with_unit(b, o.digits, &o.unit)),
                )
            } else if let Some(e) = exp.filter(|e| e.explains == Explains::Yes) {
                (Verdict::DiffersExplained, format!("experiment `{}`", e.id))
            } else if let Some(t) = &o.explanation {
                (Verdict::DiffersExplained, t.clone())
            } else if let Some(e) = exp {
                (Verdict::DiffersOpen, format!("experiment `{}` rules out its candidates", e.id))
            } else {
                (Verdict::DiffersOpen, "no experiment".into())
            };
            let basis = match (&o.experiment, verdict) {
                (Some(id), Verdict::Reproduced) => format!("see experiment `{id}`"),
                _ => basis,
            };
            let basis = match best {
                Some(b) if verdict != Verdict::Reproduced && !o.check.passes(b) => {
                    format!("{basis}; closest variant {}", with_unit(b, o.digits, &o.unit))
                }
                _ => basis,
            };
            Ok(Row { outcome: o.clone(), ours: x, verdict, basis })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks() {
        assert!(Check::Lt { value: 18.0 }.passes(6.3));
        assert!(!Check::Lt { value: 18.0 }.passes(f64::NAN));
        assert!(Check::Within { value: 10.0, abs: 2.0 }.passes(8.0));
        assert!(!Check::Within { value: 10.0, abs: 2.0 }.passes(7.9));
        assert!(Check::Rel { value: 2.95, rel: 0.1 }.passes(2.7));
        assert!(!Check::Rel { value: 2.95, rel: 0.1 }.passes(2.6));
        assert!(Check::Range { lo: 0.25, hi: 0.45 }.passes(0.42));
        assert_eq!(Check::Rel { value: 2.95, rel: 0.1 }.text("°"), "2.95° ± 10.0 %");
        assert_eq!(Check::Lt { value: 18.0 }.text("s"), "< 18.0 s");
    }

    #[test]
    fn missing_sources_are_errors_and_nulls_fail_the_check() {
        let mut runs = BTreeMap::new();
        runs.insert("p/a".to_owned(), BTreeMap::from([("settle_time_s".to_owned(), f64::NAN)]));
        let experiments = BTreeMap::new();
        let v = Values { runs: &runs, experiments: &experiments };
        let o = |run: &str, key: &str, experiment: Option<&str>| Outcome {
            paper: "000".into(),
            id: "x".into(),
            claim: String::new(),
            paper_value: String::new(),
            ours: Source::Run { run: run.into(), key: key.into() },
            ratio_to: None,
            unit: String::new(),
            digits: 3,
            check: Check::Lt { value: 10.0 },
            experiment: experiment.map(str::to_owned),
            explanation: None,
            best: None,
        };
        assert!(evaluate(&[o("p/b", "settle_time_s", None)], &v).is_err());
        assert!(evaluate(&[o("p/a", "nope", None)], &v).is_err());
        assert!(evaluate(&[o("p/a", "settle_time_s", Some("missing"))], &v).is_err());
        // A run that never settles (null) is not "reproduced" by `< 10`.
        let rows = evaluate(&[o("p/a", "settle_time_s", None)], &v).expect("evaluates");
        assert_eq!(rows[0].verdict, Verdict::DiffersOpen);
    }

    #[test]
    fn parses_sources_and_checks() {
        let f: File = toml::from_str(
            r#"
            [[outcome]]
            paper = "000"
            id = "t3"
            claim = "c"
            paper_value = "~10 s"
            ours = { run = "paper000/test3", key = "settle_time_s" }
            check = { op = "within", value = 10.0, abs = 3.0 }
            experiment = "p000-rig-effects"
            [[outcome]]
            paper = "004"
            id = "x"
            claim = "c"
            paper_value = "v"
            ours = { experiment = "e", finding = "f" }
            check = { op = "gt", value = 1.0 }
            "#,
        )
        .expect("parses");
        assert_eq!(f.outcome[0].ours, Source::Run { run: "paper000/test3".into(), key: "settle_time_s".into() });
        assert_eq!(f.outcome[1].ours, Source::Experiment { experiment: "e".into(), finding: "f".into() });
        assert!(toml::from_str::<File>("[[outcome]]\npaper='0'\nid='a'\nclaim=''\npaper_value=''\nours={run='a',key='b'}\ncheck={op='lt',value=1}\nbogus=1").is_err());
    }
}
