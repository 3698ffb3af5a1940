//! The campaign file (`campaigns/*.toml`), parsed and checked once into typed values:
//! a base scenario, the number of runs, a master seed, dispersions and requirements.
//! See `docs/campaigns.md` for the format.

use super::path::KeyPath;
use anyhow::{Context, Result, anyhow, bail};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Largest campaign: run indices are six digits in directory names.
pub const MAX_RUNS: u32 = 1_000_000;

/// The campaign file as written (also echoed into `manifest.json`).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CampaignFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// Base scenario, relative to the campaign file.
    pub base: PathBuf,
    pub runs: u32,
    /// Master seed: every draw derives from (seed, run index, key).
    pub seed: u64,
    #[serde(default, rename = "dispersion")]
    pub dispersions: Vec<DispersionSpec>,
    #[serde(default, rename = "requirement")]
    pub requirements: Vec<RequirementSpec>,
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DispersionSpec {
    /// Scenario key path, e.g. `initial.euler_deg[2]`.
    pub key: String,
    pub dist: Distribution,
    /// How a numeric draw acts on the base value: replace it (`set`, default), multiply
    /// it (`scale`) or add to it (`offset`). Rotations always compose; choice, k-of-n and
    /// seed draws always set.
    #[serde(default)]
    pub apply: Apply,
    /// On an array or matrix: one draw per element (`true`) or one draw for all (default).
    #[serde(default)]
    pub per_element: bool,
}

#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Apply {
    #[default]
    Set,
    Scale,
    Offset,
}

/// A distribution, `{ type = "...", ... }`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Distribution {
    Uniform {
        low: f64,
        high: f64,
    },
    Normal {
        mean: f64,
        sd: f64,
    },
    /// Normal restricted to `[low, high]` (rejection sampling).
    TruncatedNormal {
        mean: f64,
        sd: f64,
        low: f64,
        high: f64,
    },
    /// `ln X ~ N(mu, sigma²)` (median `e^mu`).
    Lognormal {
        mu: f64,
        sigma: f64,
    },
    /// One of `values` (any TOML values), with optional relative weights.
    Choice {
        values: Vec<toml::Value>,
        #[serde(default)]
        weights: Option<Vec<f64>>,
    },
    /// A random rotation composed with the addressed attitude, matrix or rotation vector:
    /// uniform over rotations (Haar measure) of angle ≤ `max_deg` (all rotations when
    /// absent), or a rotation vector with independent N(0, sd²) components (`sd_deg`).
    Rotation {
        #[serde(default)]
        max_deg: Option<f64>,
        #[serde(default)]
        sd_deg: Option<f64>,
    },
    /// `k` of `n` items (1-based, sorted), `k` drawn uniformly from the list, the subset
    /// uniformly among all of that size: failure masks. With `item = "thruster"` the
    /// value is `[{ thruster = i }, ...]`, else `[i, ...]`.
    KOfN {
        n: u32,
        k: KList,
        #[serde(default)]
        item: Option<String>,
    },
    /// A fresh integer seed in `[0, 2^32)` (noise streams).
    Seed,
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum KList {
    One(u32),
    Many(Vec<u32>),
}

impl KList {
    pub fn values(&self) -> Vec<u32> {
        match self {
            KList::One(k) => vec![*k],
            KList::Many(v) => v.clone(),
        }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RequirementSpec {
    /// Name in reports; default `key op value`.
    #[serde(default)]
    pub name: Option<String>,
    /// A key of the run's summary (`summary.json`), e.g. `settle_time_s`,
    /// `final_euler_deg[2]`, `status_counts.alloc_fallback`.
    pub key: String,
    /// `<`, `<=`, `>` or `>=`. A run whose value is null (e.g. never settled) or that
    /// ended in error fails.
    pub op: String,
    pub value: f64,
    /// Fraction of cases that must meet it (default 1: every run).
    #[serde(default)]
    pub probability: Option<f64>,
    /// Confidence of the statement (default 0.95).
    #[serde(default)]
    pub confidence: Option<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Op {
    #[serde(rename = "<")]
    Lt,
    #[serde(rename = "<=")]
    Le,
    #[serde(rename = ">")]
    Gt,
    #[serde(rename = ">=")]
    Ge,
}

impl Op {
    pub fn holds(self, x: f64, bound: f64) -> bool {
        match self {
            Op::Lt => x < bound,
            Op::Le => x <= bound,
            Op::Gt => x > bound,
            Op::Ge => x >= bound,
        }
    }

    pub fn symbol(self) -> &'static str {
        match self {
            Op::Lt => "<",
            Op::Le => "<=",
            Op::Gt => ">",
            Op::Ge => ">=",
        }
    }

    /// Whether larger values are worse (the requirement is an upper bound).
    pub fn larger_is_worse(self) -> bool {
        matches!(self, Op::Lt | Op::Le)
    }
}

/// A checked dispersion.
#[derive(Clone, Debug)]
pub struct Dispersion {
    pub key: KeyPath,
    pub dist: Distribution,
    pub apply: Apply,
    pub per_element: bool,
}

/// A checked requirement.
#[derive(Clone, Debug, Serialize)]
pub struct Requirement {
    pub name: String,
    pub key: String,
    pub op: Op,
    pub value: f64,
    pub probability: f64,
    pub confidence: f64,
}

impl Requirement {
    /// Whether a run's value meets it (`None`: no value, fails).
    pub fn met_by(&self, x: Option<f64>) -> bool {
        x.is_some_and(|x| self.op.holds(x, self.value))
    }
}

/// The campaign, checked.
#[derive(Clone, Debug)]
pub struct Campaign {
    pub file: CampaignFile,
    pub base_path: PathBuf,
    pub dispersions: Vec<Dispersion>,
    pub requirements: Vec<Requirement>,
}

fn positive_finite(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

/// Standard deviations within which a normal draw is checked to stay finite at planning
/// (a draw beyond has probability < 2e-23; a non-finite draw is refused anyway).
pub const DRAW_SD_SPAN: f64 = 10.0;

impl Distribution {
    fn check(&self) -> Result<()> {
        let finite = |xs: &[f64]| xs.iter().all(|x| x.is_finite());
        // mean ± 10 sd must be finite (a huge sd overflows `mean + sd z`).
        let span_finite = |mean: f64, sd: f64| finite(&[mean + DRAW_SD_SPAN * sd, mean - DRAW_SD_SPAN * sd]);
        match self {
            Distribution::Uniform { low, high } if finite(&[*low, *high]) && low <= high => {
                if !(high - low).is_finite() {
                    bail!("uniform: high − low = {} overflows (draws would not be finite)", high - low);
                }
                Ok(())
            }
            Distribution::Uniform { .. } => bail!("uniform needs finite low <= high"),
            Distribution::Normal { mean, sd } if mean.is_finite() && positive_finite(*sd) => {
                if !span_finite(*mean, *sd) {
                    bail!("normal: mean ± {DRAW_SD_SPAN} sd overflows (draws would not be finite)");
                }
                Ok(())
            }
            Distribution::Normal { .. } => bail!("normal needs a finite mean and sd > 0"),
            Distribution::TruncatedNormal { mean, sd, low, high }
                if finite(&[*mean, *low, *high]) && positive_finite(*sd) && low < high =>
            {
                if !span_finite(*mean, *sd) {
                    bail!("truncated_normal: mean ± {DRAW_SD_SPAN} sd overflows (draws would not be finite)");
                }
                // Rejection sampling: refuse windows it would rarely hit.
                let z = |x: f64| (x - mean) / sd;
                if z(*high) < -5.0 || z(*low) > 5.0 {
                    bail!("truncated_normal: [low, high] lies beyond 5 sd of the mean");
                }
                Ok(())
            }
            Distribution::TruncatedNormal { .. } => bail!("truncated_normal needs finite mean, sd > 0, low < high"),
            Distribution::Lognormal { mu, sigma } if mu.is_finite() && positive_finite(*sigma) => {
                let top = (mu + DRAW_SD_SPAN * sigma).exp();
                if !top.is_finite() {
                    bail!("lognormal: exp(mu + {DRAW_SD_SPAN} sigma) overflows (draws would not be finite)");
                }
                Ok(())
            }
            Distribution::Lognormal { .. } => bail!("lognormal needs a finite mu and sigma > 0"),
            Distribution::Choice { values, weights } => {
                if values.is_empty() {
                    bail!("choice needs at least one value");
                }
                if let Some(w) = weights {
                    if w.len() != values.len() {
                        bail!("choice: {} weights for {} values", w.len(), values.len());
                    }
                    let total: f64 = w.iter().sum();
                    if !w.iter().all(|x| x.is_finite() && *x >= 0.0) || total <= 0.0 {
                        bail!("choice: weights must be finite, >= 0, not all zero");
                    }
                    // [1e308, 1e308] sums to inf: every draw would pick the last value.
                    if !total.is_finite() {
                        bail!("choice: the weights sum to {total} (they are relative: scale them down)");
                    }
                }
                Ok(())
            }
            Distribution::Rotation { max_deg, sd_deg } => match (max_deg, sd_deg) {
                (Some(m), None) if positive_finite(*m) => Ok(()),
                (None, Some(s)) if positive_finite(*s) => Ok(()),
                (None, None) => Ok(()),
                _ => bail!("rotation takes max_deg > 0 or sd_deg > 0 (or neither: any rotation)"),
            },
            Distribution::KOfN { n, k, item } => {
                let ks = k.values();
                if *n == 0 || *n > 64 || ks.is_empty() || ks.iter().any(|k| *k > *n) {
                    bail!("k_of_n needs 1 <= n <= 64 and every k in 0..=n");
                }
                if item.as_ref().is_some_and(|s| s.is_empty()) {
                    bail!("k_of_n: item must be a key name");
                }
                Ok(())
            }
            Distribution::Seed => Ok(()),
        }
    }

    /// Whether draws are numbers that `apply = "scale" | "offset"` can act with.
    fn is_scalar(&self) -> bool {
        matches!(
            self,
            Distribution::Uniform { .. }
                | Distribution::Normal { .. }
                | Distribution::TruncatedNormal { .. }
                | Distribution::Lognormal { .. }
        )
    }
}

impl Campaign {
    pub fn load(path: &Path) -> Result<Self> {
        let text = sim_core::scenario::read_capped(path)?;
        let file: CampaignFile = toml::from_str(&text)
            .map_err(|e| anyhow!("{e}"))
            .with_context(|| format!("campaign {}", path.display()))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        Self::from_file(file, dir).with_context(|| format!("campaign {}", path.display()))
    }

    /// Checks a parsed campaign file; `dir` is where relative paths start.
    pub fn from_file(file: CampaignFile, dir: &Path) -> Result<Self> {
        if file.runs == 0 || file.runs > MAX_RUNS {
            bail!("invalid value for `runs`: 1..={MAX_RUNS} (got {})", file.runs);
        }
        let mut dispersions = Vec::new();
        for (i, d) in file.dispersions.iter().enumerate() {
            let ctx = || format!("dispersion {} (`{}`)", i + 1, d.key);
            let key = KeyPath::parse(&d.key).with_context(ctx)?;
            d.dist.check().with_context(ctx)?;
            if d.apply != Apply::Set && !d.dist.is_scalar() {
                return Err(anyhow!("apply = {:?} needs a numeric distribution", d.apply)).with_context(ctx);
            }
            if file.dispersions[..i].iter().any(|o| o.key == d.key) {
                return Err(anyhow!("the key is dispersed twice")).with_context(ctx);
            }
            dispersions.push(Dispersion { key, dist: d.dist.clone(), apply: d.apply, per_element: d.per_element });
        }
        let mut requirements = Vec::new();
        for (i, r) in file.requirements.iter().enumerate() {
            let ctx = || format!("requirement {} (`{}`)", i + 1, r.key);
            let op = match r.op.as_str() {
                "<" => Op::Lt,
                "<=" => Op::Le,
                ">" => Op::Gt,
                ">=" => Op::Ge,
                o => return Err(anyhow!("op {o:?}: one of <, <=, >, >=")).with_context(ctx),
            };
            if !r.value.is_finite() {
                return Err(anyhow!("value must be finite")).with_context(ctx);
            }
            let probability = r.probability.unwrap_or(1.0);
            let confidence = r.confidence.unwrap_or(0.95);
            if !(probability > 0.0 && probability <= 1.0 && confidence > 0.0 && confidence < 1.0) {
                return Err(anyhow!("probability in (0, 1], confidence in (0, 1)")).with_context(ctx);
            }
            KeyPath::parse(&r.key).with_context(ctx)?;
            let name = r.name.clone().unwrap_or_else(|| format!("{} {} {}", r.key, op.symbol(), r.value));
            if requirements.iter().any(|q: &Requirement| q.name == name) {
                return Err(anyhow!("two requirements are named {name:?}")).with_context(ctx);
            }
            requirements.push(Requirement { name, key: r.key.clone(), op, value: r.value, probability, confidence });
        }
        let base_path = dir.join(&file.base);
        Ok(Self { file, base_path, dispersions, requirements })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(extra: &str) -> Result<Campaign> {
        let text = format!("name = \"t\"\nbase = \"b.toml\"\nruns = 10\nseed = 1\n{extra}");
        Campaign::from_file(toml::from_str(&text).map_err(|e| anyhow!("{e}"))?, Path::new("."))
    }

    #[test]
    fn accepts_every_distribution() {
        let c = parse(
            r#"
[[dispersion]]
key = "spacecraft.inertia_kgm2"
dist = { type = "uniform", low = 0.9, high = 1.1 }
apply = "scale"
[[dispersion]]
key = "initial.euler_deg"
dist = { type = "rotation", max_deg = 20.0 }
[[dispersion]]
key = "a.b"
dist = { type = "truncated_normal", mean = 0.0, sd = 1.0, low = -2.0, high = 2.0 }
[[dispersion]]
key = "a.c"
dist = { type = "lognormal", mu = 0.0, sigma = 0.1 }
apply = "scale"
[[dispersion]]
key = "a.d"
dist = { type = "choice", values = ["sr", "gsr"], weights = [1.0, 3.0] }
[[dispersion]]
key = "actuators.thrusters.failures"
dist = { type = "k_of_n", n = 8, k = [1, 2], item = "thruster" }
[[dispersion]]
key = "sensors.seed"
dist = { type = "seed" }
[[requirement]]
key = "settle_time_s"
op = "<"
value = 15.0
probability = 0.99
"#,
        )
        .unwrap();
        assert_eq!(c.dispersions.len(), 7);
        assert_eq!(c.requirements[0].name, "settle_time_s < 15");
        assert!((c.requirements[0].confidence - 0.95).abs() < 1e-15);
    }

    #[test]
    fn refuses_bad_campaigns_naming_the_entry() {
        let cases = [
            ("[[dispersion]]\nkey = \"a\"\ndist = { type = \"uniform\", low = 2.0, high = 1.0 }\n", "dispersion 1"),
            ("[[dispersion]]\nkey = \"a\"\ndist = { type = \"normal\", mean = 0.0, sd = 0.0 }\n", "sd > 0"),
            ("[[dispersion]]\nkey = \"a\"\ndist = { type = \"seed\" }\napply = \"scale\"\n", "numeric"),
            ("[[dispersion]]\nkey = \"a[\"\ndist = { type = \"seed\" }\n", "unclosed"),
            ("[[dispersion]]\nkey = \"a\"\ndist = { type = \"k_of_n\", n = 4, k = 5 }\n", "k_of_n"),
            (
                "[[dispersion]]\nkey = \"a\"\ndist = { type = \"truncated_normal\", mean = 0.0, sd = 1.0, low = 6.0, high = 7.0 }\n",
                "5 sd",
            ),
            ("[[requirement]]\nkey = \"x\"\nop = \"!=\"\nvalue = 1.0\n", "op"),
            (
                "[[dispersion]]\nkey = \"a\"\ndist = { type = \"choice\", values = [0.0, 1.0], weights = [1e308, 1e308] }\n",
                "sum to inf",
            ),
            ("[[dispersion]]\nkey = \"a\"\ndist = { type = \"uniform\", low = -1e308, high = 1e308 }\n", "overflows"),
            ("[[dispersion]]\nkey = \"a\"\ndist = { type = \"lognormal\", mu = 800.0, sigma = 1.0 }\n", "overflows"),
            ("[[dispersion]]\nkey = \"a\"\ndist = { type = \"lognormal\", mu = 700.0, sigma = 1.0 }\n", "overflows"),
            ("[[dispersion]]\nkey = \"a\"\ndist = { type = \"normal\", mean = 0.0, sd = 1e308 }\n", "overflows"),
            (
                "[[dispersion]]\nkey = \"a\"\ndist = { type = \"truncated_normal\", mean = 0.0, sd = 1e308, low = -1.0, high = 1.0 }\n",
                "overflows",
            ),
            ("[[requirement]]\nkey = \"x\"\nop = \"<\"\nvalue = 1.0\nprobability = 1.5\n", "probability"),
        ];
        for (extra, want) in cases {
            let e = format!("{:#}", parse(extra).unwrap_err());
            assert!(e.contains(want), "{extra}: {e}");
        }
        assert!(parse("").is_ok());
        // Just inside the overflow checks: accepted.
        for ok in [
            "dist = { type = \"lognormal\", mu = 690.0, sigma = 1.0 }",
            "dist = { type = \"uniform\", low = -1e307, high = 1e307 }",
            "dist = { type = \"choice\", values = [0.0, 1.0], weights = [1e307, 1e307] }",
        ] {
            assert!(parse(&format!("[[dispersion]]\nkey = \"a\"\n{ok}\n")).is_ok(), "{ok}");
        }
        let e = Campaign::from_file(
            toml::from_str("name = \"t\"\nbase = \"b\"\nruns = 0\nseed = 1\n").unwrap(),
            Path::new("."),
        )
        .unwrap_err();
        assert!(e.to_string().contains("runs"), "{e}");
    }
}
