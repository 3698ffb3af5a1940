//! `[margins]`: measure the stability margins of the flight loop after the run, and report
//! them in `summary.json` `margins` (docs/margins.md, "In runs and campaigns"). The table
//! is optional; present, `sim-host run`, campaign runs and the Python `acs.run` measure.
//! `sim-host margins` takes its defaults from it.
//!
//! ```toml
//! [margins]
//! at_s = 30.0          # operating point, s (default: duration_s)
//! loop = "input"       # where the loop is broken: "input" (actuator command) or "output"
//! grid_points = 40     # log-spaced frequencies before refinement
//! ```
//!
//! The ranges of every margins option — of the `[margins]` keys and of the `sim-host
//! margins` flags alike — are checked here, once ([`check`]): the scenario refuses its keys
//! with them, `sim_host::margins::measure` refuses its options with them before flying, and
//! the command line parses its flags with them.

use super::{Scenario, bad};
use anyhow::Result;
use serde::{Deserialize, Serialize};

pub use crate::recorder::summary::LoopPoint;

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MarginsSpec {
    #[serde(default)]
    pub at_s: Option<f64>,
    #[serde(default, rename = "loop")]
    pub loop_point: LoopPoint,
    #[serde(default = "grid_points")]
    pub grid_points: usize,
}

fn grid_points() -> usize {
    40
}

impl Default for MarginsSpec {
    fn default() -> Self {
        Self { at_s: None, loop_point: LoopPoint::Input, grid_points: grid_points() }
    }
}

/// Fewest and most grid frequencies: below, no crossing can be bracketed; above, the
/// measurement costs minutes without a better margin (refinement adds points at crossings).
pub const GRID_POINTS: (usize, usize) = (5, 400);
/// Without refinement (`--no-refine`) the margins are interpolated between grid
/// frequencies, so adjacent ones must be at most this ratio apart (the grid spans `ωc/30`
/// to Nyquist: checked once the crossover estimate is known). On the reference loop
/// (docs/margins.md) 20 points, 1.45× apart, give the refined phase margin to 0.13°; 10
/// points, 2.2× apart, miss it by 2.8°, and 5 points by 19.5°.
pub const UNREFINED_MAX_RATIO: f64 = 1.5;
/// Fewest and most worker threads: each flies its own copy of the operating point, and a
/// batch has at most three experiments per frequency.
pub const THREADS: (usize, usize) = (1, 64);
/// Smallest and largest attitude excitation, rad: ten times the f32 resolution of the
/// flight's quaternion (≈ 6e-8) at least, and small enough that `sin(θ/2) = θ/2` to 1e-5.
pub const AMPLITUDE_RAD: (f64, f64) = (1e-6, 1e-2);
/// The pilot sweep descends from the Nyquist frequency by factors of 3 this many times; a
/// crossover hint must lie in `[π/T / 3^PILOT_LEVELS, π/T)` like the pilot's estimate.
pub const PILOT_LEVELS: i32 = 14;

/// One option of a margins measurement, named as its `sim-host margins` flag and, for those
/// a scenario sets, its `[margins]` key.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MarginOption {
    AtS,
    Loop,
    GridPoints,
    Threads,
    AmplitudeRad,
    CrossoverHint,
    MaxPlantSteps,
}

impl MarginOption {
    /// The `sim-host margins` flag.
    pub fn flag(self) -> &'static str {
        match self {
            MarginOption::AtS => "--at",
            MarginOption::Loop => "--loop",
            MarginOption::GridPoints => "--grid-points",
            MarginOption::Threads => "--threads",
            MarginOption::AmplitudeRad => "--amplitude-rad",
            MarginOption::CrossoverHint => "--crossover-hint",
            MarginOption::MaxPlantSteps => "--max-plant-steps",
        }
    }

    /// The `[margins]` key (`None`: not a scenario key).
    pub fn key(self) -> Option<&'static str> {
        match self {
            MarginOption::AtS => Some("margins.at_s"),
            MarginOption::Loop => Some("margins.loop"),
            MarginOption::GridPoints => Some("margins.grid_points"),
            _ => None,
        }
    }
}

/// A margins option refused by [`check`]: which, the value given and why.
#[derive(Clone, Debug, PartialEq)]
pub struct OptionRefused {
    pub option: MarginOption,
    pub value: String,
    pub why: String,
}

/// A number as a refusal quotes it: the shorter of its positional and exponent forms
/// (`20.000001`, `1e-9`, `1e300`).
fn quoted(x: f64) -> String {
    let (plain, exp) = (x.to_string(), format!("{x:e}"));
    if exp.len() < plain.len() { exp } else { plain }
}

impl OptionRefused {
    fn new(option: MarginOption, value: impl std::fmt::Display, why: impl Into<String>) -> Self {
        Self { option, value: value.to_string(), why: why.into() }
    }

    fn number(option: MarginOption, x: f64, why: impl Into<String>) -> Self {
        Self::new(option, quoted(x), why)
    }

    /// Named as the scenario key (`invalid value for `margins.at_s`: …`), or as the flag for
    /// an option a scenario cannot set.
    pub fn as_key(&self) -> anyhow::Error {
        match self.option.key() {
            Some(k) => bad(k, format!("{} (got {})", self.why, self.value)),
            None => anyhow::anyhow!("{self}"),
        }
    }
}

impl std::fmt::Display for OptionRefused {
    /// Named as the flag: `--grid-points 3: …`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}: {}", self.option.flag(), self.value, self.why)
    }
}

impl std::error::Error for OptionRefused {}

/// The range checks of the margins options (module doc): each returns the value, or why it
/// is refused.
pub mod check {
    use super::*;
    use MarginOption as O;

    /// The operating point, s, in `[0, duration_s]`.
    pub fn at_s(t: f64, duration_s: f64) -> Result<f64, OptionRefused> {
        if t.is_finite() && (0.0..=duration_s).contains(&t) {
            Ok(t)
        } else {
            Err(OptionRefused::number(O::AtS, t, format!("must be a time in [0, duration_s = {duration_s}] s")))
        }
    }

    /// Grid frequencies in [`GRID_POINTS`] (without refinement, also
    /// [`unrefined_spacing`] once the grid's span is known).
    pub fn grid_points(n: usize) -> Result<usize, OptionRefused> {
        let (lo, hi) = GRID_POINTS;
        if (lo..=hi).contains(&n) {
            Ok(n)
        } else {
            Err(OptionRefused::new(O::GridPoints, n, format!("must be in [{lo}, {hi}]")))
        }
    }

    /// Worker threads in [`THREADS`].
    pub fn threads(n: usize) -> Result<usize, OptionRefused> {
        let (lo, hi) = THREADS;
        if (lo..=hi).contains(&n) {
            Ok(n)
        } else {
            Err(OptionRefused::new(O::Threads, n, format!("must be in [{lo}, {hi}]")))
        }
    }

    /// The attitude excitation in [`AMPLITUDE_RAD`].
    pub fn amplitude_rad(a: f64) -> Result<f64, OptionRefused> {
        let (lo, hi) = AMPLITUDE_RAD;
        if a.is_finite() && (lo..=hi).contains(&a) {
            Ok(a)
        } else {
            Err(OptionRefused::number(O::AmplitudeRad, a, format!("must be in [{lo:e}, {hi:e}] rad")))
        }
    }

    /// A crossover hint: finite and positive (the command line's parse), and with the
    /// control period `dt_s` known, in `[π/dt / 3^PILOT_LEVELS, π/dt)`.
    pub fn crossover_hint(w: f64, dt_s: Option<f64>) -> Result<f64, OptionRefused> {
        if !(w.is_finite() && w > 0.0) {
            return Err(OptionRefused::number(O::CrossoverHint, w, "must be a finite frequency > 0 rad/s"));
        }
        let Some(dt) = dt_s else { return Ok(w) };
        let nyquist = std::f64::consts::PI / dt;
        let lowest = nyquist / 3f64.powi(PILOT_LEVELS);
        if (lowest..nyquist).contains(&w) {
            Ok(w)
        } else {
            Err(OptionRefused::number(
                O::CrossoverHint,
                w,
                format!(
                    "must be below the control Nyquist frequency {nyquist:.6} rad/s and at least {lowest:.3e} rad/s \
                     (3^-{PILOT_LEVELS} of it, the pilot sweep's reach)"
                ),
            ))
        }
    }

    /// Without refinement, a log grid of `n` frequencies from `lo` to `hi` rad/s must have
    /// adjacent frequencies within [`UNREFINED_MAX_RATIO`].
    pub fn unrefined_spacing(n: usize, lo: f64, hi: f64) -> Result<(), OptionRefused> {
        let ratio = (hi / lo).powf(1.0 / (n.max(2) - 1) as f64);
        if ratio <= UNREFINED_MAX_RATIO {
            return Ok(());
        }
        let need = 1 + ((hi / lo).ln() / UNREFINED_MAX_RATIO.ln()).ceil() as usize;
        Err(OptionRefused::new(
            O::GridPoints,
            n,
            format!(
                "with --no-refine, {n} frequencies from {lo:.4e} to {hi:.4e} rad/s are {ratio:.2} x apart: the margins \
                 would be interpolated across brackets that wide; at least {need} points keep them within \
                 {UNREFINED_MAX_RATIO} x (or drop --no-refine)"
            ),
        ))
    }

    /// A plant-step budget of at least one step.
    pub fn max_plant_steps(n: u64) -> Result<u64, OptionRefused> {
        if n >= 1 { Ok(n) } else { Err(OptionRefused::new(O::MaxPlantSteps, n, "must be at least 1 plant step")) }
    }
}

/// The validated `[margins]` request.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarginRequest {
    /// Operating point, s, in [0, duration_s].
    pub at_s: f64,
    pub point: LoopPoint,
    pub grid_points: usize,
}

impl Scenario {
    /// `[margins]`, validated (None without the table); errors name the key. A measurement
    /// `[margins]` asks for always refines its grid.
    pub fn margin_request(&self) -> Result<Option<MarginRequest>> {
        let Some(m) = &self.margins else { return Ok(None) };
        let at_s = check::at_s(m.at_s.unwrap_or(self.duration_s), self.duration_s).map_err(|e| e.as_key())?;
        let grid_points = check::grid_points(m.grid_points).map_err(|e| e.as_key())?;
        Ok(Some(MarginRequest { at_s, point: m.loop_point, grid_points }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(table: &str) -> Result<Option<MarginRequest>> {
        let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/paper000/test1.toml"))
            .unwrap();
        Scenario::from_toml(&format!("{text}\n{table}\n"))?.margin_request()
    }

    #[test]
    fn defaults_and_refusals_name_the_key() {
        assert_eq!(with("").unwrap(), None);
        let r = with("[margins]").unwrap().unwrap();
        assert_eq!((r.point, r.grid_points), (LoopPoint::Input, 40));
        assert!(r.at_s > 0.0);
        let r = with("[margins]\nat_s = 5.0\nloop = \"output\"\ngrid_points = 7").unwrap().unwrap();
        assert_eq!(r, MarginRequest { at_s: 5.0, point: LoopPoint::Output, grid_points: 7 });
        for (t, key) in [
            ("at_s = -1.0", "margins.at_s"),
            ("at_s = 1e9", "margins.at_s"),
            ("at_s = nan", "margins.at_s"),
            ("at_s = inf", "margins.at_s"),
            ("grid_points = 2", "margins.grid_points"),
            ("grid_points = 401", "margins.grid_points"),
        ] {
            let e = format!("{:#}", with(&format!("[margins]\n{t}")).unwrap_err());
            assert!(e.contains(key), "{t}: {e}");
        }
        assert!(with("[margins]\nloop = \"sideways\"").is_err());
    }

    /// `--loop` parses as `[margins] loop` does: the same spellings accepted to the same
    /// value, the same ones refused (the TOML parser is the independent reading).
    #[test]
    fn loop_flag_parses_as_the_toml_key() {
        for word in ["input", "output", "INPUT", "Output", "sideways", ""] {
            let toml = with(&format!("[margins]\nloop = \"{word}\"")).map(|r| r.map(|r| r.point));
            let flag = word.parse::<LoopPoint>();
            match (toml, flag) {
                (Ok(Some(a)), Ok(b)) => assert_eq!((a, b.name()), (b, word)),
                (Err(_), Err(e)) => assert!(e.contains("expected input or output"), "{word}: {e}"),
                (t, f) => panic!("{word:?}: TOML {t:?}, flag {f:?}"),
            }
        }
    }

    /// The checks the command line and `measure` share: each bound refused on both sides,
    /// named as the flag.
    #[test]
    fn option_checks_refuse_outside_their_ranges_naming_the_flag() {
        assert_eq!(check::at_s(0.0, 10.0), Ok(0.0));
        assert_eq!(check::at_s(10.0, 10.0), Ok(10.0));
        for t in [-1e-9, 10.000001, 1e300, f64::NAN, f64::INFINITY] {
            assert!(check::at_s(t, 10.0).unwrap_err().to_string().starts_with("--at "), "{t}");
        }
        assert!(check::grid_points(5).is_ok() && check::grid_points(400).is_ok());
        for n in [0, 1, 3, 4, 401, 1_000_000_000] {
            let e = check::grid_points(n).unwrap_err().to_string();
            assert!(e.starts_with(&format!("--grid-points {n}: ")), "{e}");
        }
        assert!(check::threads(1).is_ok() && check::threads(64).is_ok());
        for n in [0, 65, 5000] {
            assert!(check::threads(n).unwrap_err().to_string().starts_with("--threads "));
        }
        for a in [0.0, -1e-4, 9.9e-7, 0.0101, f64::NAN, f64::INFINITY] {
            assert!(check::amplitude_rad(a).unwrap_err().to_string().starts_with("--amplitude-rad "), "{a}");
        }
        assert!(check::amplitude_rad(1e-6).is_ok() && check::amplitude_rad(1e-2).is_ok());
        let dt = Some(0.1);
        for w in [-1.0, 0.0, f64::NAN, f64::INFINITY, 31.5, 1e-9] {
            assert!(check::crossover_hint(w, dt).unwrap_err().to_string().starts_with("--crossover-hint "), "{w}");
        }
        assert!(check::crossover_hint(31.5, None).is_ok(), "without the period only finite and positive");
        assert!(check::crossover_hint(31.4, dt).is_ok() && check::crossover_hint(1e-5, dt).is_ok());
        assert!(check::max_plant_steps(0).is_err() && check::max_plant_steps(1).is_ok());
        // 20 points over 1222× (the reference loop's grid) are 1.453× apart; over 4712× (a
        // 100 Hz loop's) 1.56×: 22 are needed.
        assert!(check::unrefined_spacing(20, 31.4159 / 1222.0, 31.4159).is_ok());
        let e = check::unrefined_spacing(20, 314.159 / 4712.0, 314.159).unwrap_err().to_string();
        assert!(e.starts_with("--grid-points 20: ") && e.contains("at least 22 points"), "{e}");
        assert!(check::unrefined_spacing(22, 314.159 / 4712.0, 314.159).is_ok());
    }
}
