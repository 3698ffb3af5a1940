//! Seeded, bounded-time fuzz of `[[faults]]` lists (issue 42): on shipped spacecraft — the
//! 3U mission (`scenarios/modes/cubesat-mission.toml`, 6,500 s: detumble to hold; with and
//! without `[fdir.wheels]`) and the 6U (`scenarios/fdir/wheel-seized-6u.toml`, 1,500 s,
//! `[fdir.wheels]`, its own fault removed), a CMG pyramid (`scenarios/paper000/test1.toml`,
//! 150 s: the slew and a hold) and eight thrusters (`scenarios/paper004/dp-nominal.toml`,
//! 150 s, with `[performance] propellant_budget_kg` = [`PROPELLANT_BUDGET_KG`]) — random lists
//! of 1 to 33 entries: every fault class at random onsets and
//! magnitudes (in range, and NaN, ±inf, negative, huge), units the spacecraft does not have
//! (`wheel.7` on four wheels, `magnetorquer.5`, `cmg.4` or `cmg.0` without CMGs,
//! `thruster.8` or `thruster.0` without thrusters, unmodelled units, `gyro.w`,
//! `magnetometer` without an axis), kinds a unit does not have, `end_s` ≤ `onset_s`.
//! The test predicts each entry's validity itself (docs/scenario.md `[[faults]]`), and every
//! case must end in exactly one of:
//!
//! - refused: exit 1, predicted invalid, and the message names the first bad entry's key
//!   (`faults[i]`, or `faults` for 33 entries);
//! - run: exit 0, predicted valid, and from the time series (every step recorded) control
//!   was not lost — not every step of the last 60 s after the first injection with the true
//!   error above 10° or the body rate above 3°/s (docs/scenario.md "Run status") — or
//!   `summary.json` lists FDIR events and the last row's `mode` is a safe mode (detumble 1,
//!   sun-safe 5: the recovery fell back to survival);
//! - failed run: exit 3 with a failed `run_status`; a `control_lost` verdict must be what the
//!   series shows (lost, no FDIR event), a `recovery_failed` one too (lost, FDIR events, the
//!   last row not in a safe mode); a `pointing_degraded` one is what the series shows too
//!   (not lost, every row of the last 60 s after the injection in hold — or without a mode
//!   manager — and more than 1 − confidence of them above the degraded-hold bound: the
//!   window's APE above it; the injection at least 60 s before the window, its recovery
//!   allowance; no FDIR event), and a `recovery_failed` may also be that
//!   degraded hold after an FDIR event; a `propellant_exceeded` one is what the series
//!   shows too (the last row's `propellant_kg` above the budget) and neither a pointing
//!   verdict's loss nor a degraded hold (those win over it).
//!
//! Anything else (a panic, a signal, a hang beyond 60 s, exit 0 with control lost and no
//! event or with events but not in a safe mode, exit 0 with a degraded hold, exit 0 over the
//! propellant budget, an invalid entry accepted or a valid one refused) fails, listing the
//! cases.

use acs_test_support::cases::run_cases;
use acs_test_support::rng::SplitMix64;
use serde_json::Value as Json;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use toml::Value;

/// Seed and number of cases; `FAULT_FUZZ_SEED` / `FAULT_FUZZ_CASES` override them.
const SEED: u64 = 0x42_F422;
const CASES: usize = 500;
const WORKERS: usize = 2;
const CASE_LIMIT: Duration = Duration::from_secs(60);

/// The verdict's definition, restated apart from the simulator (docs/scenario.md).
const ERROR_BOUND_DEG: f64 = 10.0;
const RATE_BOUND_DEG_S: f64 = 3.0; // the mission's detumble_enter_rate_deg_s and the default
const WINDOW_S: f64 = 60.0;
const RECOVERY_ALLOWANCE_S: f64 = 60.0;
/// The safe modes' telemetry codes (docs/outputs.md `mode`: detumble 1, sun-safe 5).
const DETUMBLE_CODE: f64 = 1.0;
const SUN_SAFE_CODE: f64 = 5.0;
const HOLD_CODE: f64 = 4.0;

/// The failed statuses a run may end in (docs/scenario.md "Run status").
const FAILED: [&str; 11] = [
    "diverged",
    "all_refused",
    "no_control",
    "samples_dropped",
    "keepout_violated",
    "timeline_missed",
    "fdir_false_alarm",
    "control_lost",
    "recovery_failed",
    "pointing_degraded",
    "propellant_exceeded",
];

/// The paper 004 base's propellant budget, kg: five times its fault-free use over 150 s
/// (0.0197 kg, docs/fdir.md), which one stuck-open valve (10 N at Isp 220 s: 4.6 g/s) spends
/// alone in about 22 s — so onsets late in the run exceed it without a judged pointing
/// verdict, early ones are `pointing_degraded` first.
const PROPELLANT_BUDGET_KG: f64 = 0.1;

const FDIR_WHEELS: &str = "floor_nm = 5.0e-8\nthreshold_sigma = 6.0\ngyro_sigma_rad_s = 1.4e-5\n";

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A base spacecraft: its scenario (no faults, every step recorded) and the units it has.
struct Base {
    name: &'static str,
    doc: Value,
    wheels: usize,
    /// Coarse sun sensor heads (`[sensors.css] normals_body`; 0 without the table).
    css_heads: usize,
    /// Torquer rods (3 with `[actuators.magnetorquers]`), CMGs (the pyramid's 4 with
    /// `[actuators.cmg]`), thrusters (paper 004's 8 with `[actuators.thrusters]`).
    rods: usize,
    cmgs: usize,
    thrusters: usize,
    /// A GNSS fix: only with `[orbit]`.
    gnss: bool,
    duration_s: f64,
}

fn base(name: &'static str, file: &'static str, duration_s: f64, fdir: bool) -> Base {
    let mut doc: Value = toml::from_str(&std::fs::read_to_string(repo().join(file)).unwrap()).unwrap();
    doc["duration_s"] = Value::Float(duration_s);
    doc["timing"].as_table_mut().unwrap().insert("output_every".into(), Value::Integer(1));
    let t = doc.as_table_mut().unwrap();
    t.remove("faults");
    if fdir {
        let wheels: Value = toml::from_str(FDIR_WHEELS).unwrap();
        t.insert("fdir".into(), Value::Table([("wheels".to_string(), wheels)].into_iter().collect()));
    } else {
        t.remove("fdir");
    }
    let act = &doc["actuators"];
    let wheels = match act.get("wheels").and_then(|w| w.get("layout")).and_then(Value::as_str) {
        Some("pyramid4") => 4,
        _ => act.get("wheels").and_then(|w| w.get("axes")).and_then(Value::as_array).map_or(0, Vec::len),
    };
    let has = |table: &str| act.get(table).is_some();
    // The bases' thrusters are paper 004's layout (eight).
    assert!(!has("thrusters") || act["thrusters"].get("layout").is_none_or(|l| l.as_str() == Some("paper004")));
    let css_heads = doc
        .get("sensors")
        .and_then(|s| s.get("css"))
        .map_or(0, |c| c.get("normals_body").and_then(Value::as_array).map_or(0, Vec::len));
    let (rods, cmgs, thrusters) =
        (3 * usize::from(has("magnetorquers")), 4 * usize::from(has("cmg")), 8 * usize::from(has("thrusters")));
    let gnss = doc.get("orbit").is_some();
    if thrusters > 0 {
        let budget = [("propellant_budget_kg".to_string(), Value::Float(PROPELLANT_BUDGET_KG))];
        assert!(doc.get("performance").is_none(), "{file}: a [performance] of its own");
        doc.as_table_mut().unwrap().insert("performance".into(), Value::Table(budget.into_iter().collect()));
    }
    Base { name, doc, wheels, css_heads, rods, cmgs, thrusters, gnss, duration_s }
}

/// One `[[faults]]` entry as drawn.
#[derive(Clone, Debug)]
struct Entry {
    onset_s: f64,
    unit: String,
    kind: String,
    magnitude: Option<f64>,
    end_s: Option<f64>,
}

const ALL_KINDS: [&str; 23] = [
    "stuck",
    "torque_gain",
    "runaway",
    "tach_stuck",
    "power_off",
    "tach_noise",
    "friction",
    "bias_step",
    "flip",
    "frozen",
    "open",
    "reversed",
    "bias",
    "dead",
    "position_jump",
    "velocity_jump",
    "noise",
    "saturation",
    "gimbal_stuck",
    "rotor_spin_down",
    "stuck_closed",
    "stuck_open",
    "explode",
];

/// The largest magnetometer bias the format takes, T (the flight code's f32 field limit).
const MAX_MAG_BIAS_T: f64 = 1e-2f32 as f64;
/// The largest gyro saturation bound the format takes, rad/s (the flight code's rate limit).
const MAX_RATE_RAD_S: f64 = 50.0;
const MAGNETOMETER_AXES: [&str; 3] = ["magnetometer.x", "magnetometer.y", "magnetometer.z"];

/// The kinds each unit has on the bases (their wheels are ideal: no `friction`).
fn kinds_of(unit: &str) -> &'static [&'static str] {
    match unit.split('.').next() {
        Some("wheel") => &["stuck", "torque_gain", "runaway", "tach_stuck", "power_off", "tach_noise"],
        Some("gyro") => &["stuck", "bias_step", "noise", "saturation"],
        Some("star_tracker") => &["flip", "frozen"],
        Some("magnetorquer") => &["open", "reversed"],
        Some("magnetometer") => &["stuck", "bias"],
        Some("css") => &["dead"],
        Some("gnss") => &["position_jump", "velocity_jump"],
        Some("cmg") => &["gimbal_stuck", "rotor_spin_down"],
        Some("thruster") => &["stuck_closed", "stuck_open"],
        _ => &["stuck"],
    }
}

fn pick<'a, T>(rng: &mut SplitMix64, xs: &'a [T]) -> &'a T {
    &xs[rng.below(xs.len())]
}

/// An entry; `clean`: drawn from the valid pools only.
fn draw_entry(rng: &mut SplitMix64, b: &Base, clean: bool) -> Entry {
    let bad = |rng: &mut SplitMix64, p: f64| !clean && rng.uniform() < p;
    let mut valid_units: Vec<String> = (0..b.wheels).map(|i| format!("wheel.{i}")).collect();
    valid_units.extend(["gyro.x", "gyro.y", "gyro.z", "star_tracker"].map(String::from));
    valid_units.extend((0..b.rods).map(|i| format!("magnetorquer.{i}")));
    valid_units.extend(MAGNETOMETER_AXES.map(String::from));
    valid_units.extend((0..b.css_heads).map(|i| format!("css.{i}")));
    valid_units.extend((0..b.cmgs).map(|i| format!("cmg.{i}")));
    valid_units.extend((0..b.thrusters).map(|i| format!("thruster.{i}")));
    if b.gnss {
        valid_units.push("gnss".into());
    }
    let unit = if bad(rng, 0.06) {
        let wrong = [
            format!("wheel.{}", b.wheels),
            "wheel.7".into(),
            "magnetorquer.5".into(),
            "cmg.0".into(),
            format!("cmg.{}", b.cmgs),
            "cmg.x".into(),
            "thruster.0".into(),
            format!("thruster.{}", b.thrusters),
            "thruster".into(),
            "gnss".into(),
            "magnetometer".into(),
            "magnetometer.w".into(),
            "magnetometer.0".into(),
            format!("css.{}", b.css_heads),
            "css.9".into(),
            "css".into(),
            "gnss.0".into(),
            "gyro.w".into(),
            "star_tracker.1".into(),
            "wheel".into(),
            "wheel.-1".into(),
            "flywheel.0".into(),
            String::new(),
        ];
        pick(rng, &wrong).clone()
    } else {
        pick(rng, &valid_units).clone()
    };
    let kind = if bad(rng, 0.05) { *pick(rng, &ALL_KINDS) } else { *pick(rng, kinds_of(&unit)) };
    let magnitude = match kind {
        _ if bad(rng, 0.06) => Some(*pick(rng, &[f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -5.0, 1.5, 1e300, 0.5])),
        "torque_gain" => Some(rng.uniform()),
        "runaway" => Some(*pick(rng, &[1.0, -1.0])),
        // 1e-6 to 1 rad/s (the largest step the format takes), either sign.
        "bias_step" => Some(*pick(rng, &[1.0, -1.0]) * 10f64.powf(-6.0 * rng.uniform())),
        // 1 to 1000 (the largest factor the format takes).
        "noise" | "tach_noise" => Some(10f64.powf(3.0 * rng.uniform())),
        // 1e-4 to 50 rad/s (the flight code's rate limit, the largest bound the format takes).
        "saturation" => Some(MAX_RATE_RAD_S * 10f64.powf(-5.7 * rng.uniform())),
        // 1 m to 1e7 m (the largest jump the format takes), either sign.
        "position_jump" => Some(*pick(rng, &[1.0, -1.0]) * 10f64.powf(7.0 * rng.uniform())),
        // 0.01 m/s to 1e4 m/s (the largest jump the format takes), either sign.
        "velocity_jump" => Some(*pick(rng, &[1.0, -1.0]) * 10f64.powf(6.0 * rng.uniform() - 2.0)),
        // 1e-9 to 1e-2 T (the largest bias the format takes), either sign.
        "bias" => Some(*pick(rng, &[1.0, -1.0]) * MAX_MAG_BIAS_T * 10f64.powf(-7.0 * rng.uniform())),
        // 1 s to 1e7 s (the shortest and longest time constants the format takes).
        "rotor_spin_down" => Some(10f64.powf(7.0 * rng.uniform())),
        _ => None,
    };
    let onset_s = if bad(rng, 0.03) {
        *pick(rng, &[-1.0, f64::NAN, f64::INFINITY, -1e-9])
    } else if rng.below(20) == 0 {
        *pick(rng, &[0.0, 1e300]) // valid: at the start, and never
    } else {
        rng.uniform() * b.duration_s
    };
    let end_s = match rng.below(10) {
        _ if bad(rng, 0.04) => Some(*pick(rng, &[onset_s, onset_s - 1.0, f64::NAN, f64::INFINITY])),
        0..=6 => None,
        _ => Some(onset_s + 1.0 + 600.0 * rng.uniform()),
    };
    Entry { onset_s, unit, kind: kind.into(), magnitude, end_s }
}

/// Whether the format takes this entry on the base's spacecraft (its wheels, rods, coarse
/// sun sensor heads, CMGs, thrusters and GNSS fix)
/// (docs/scenario.md `[[faults]]`, and "every number": finite, within the f32 range),
/// decided from the values alone.
fn valid(e: &Entry, b: &Base) -> bool {
    let numbers = [Some(e.onset_s), e.magnitude, e.end_s];
    let in_range = numbers.iter().flatten().all(|x| x.is_finite() && x.abs() <= f64::from(f32::MAX));
    let onset_ok = e.onset_s.is_finite() && e.onset_s >= 0.0;
    let end_ok = e.end_s.is_none_or(|x| x.is_finite() && x > e.onset_s);
    let index_below = |prefix: &str, n: usize| {
        e.unit.strip_prefix(prefix).and_then(|i| i.parse::<usize>().ok()).is_some_and(|i| i < n)
    };
    let unit_ok = index_below("wheel.", b.wheels)
        || index_below("magnetorquer.", b.rods)
        || index_below("css.", b.css_heads)
        || index_below("cmg.", b.cmgs)
        || index_below("thruster.", b.thrusters)
        || ["gyro.x", "gyro.y", "gyro.z", "star_tracker"].contains(&e.unit.as_str())
        || MAGNETOMETER_AXES.contains(&e.unit.as_str())
        || (b.gnss && e.unit == "gnss");
    let kind_ok = unit_ok && kinds_of(&e.unit).contains(&e.kind.as_str());
    let m = e.magnitude;
    let magnitude_ok = match e.kind.as_str() {
        "torque_gain" => m.is_some_and(|g| (0.0..=1.0).contains(&g)),
        "runaway" => m.is_some_and(|s| s == 1.0 || s == -1.0),
        "bias_step" => m.is_some_and(|x| x.is_finite() && x.abs() <= 1.0),
        "bias" => m.is_some_and(|x| x.is_finite() && x.abs() <= MAX_MAG_BIAS_T),
        "noise" | "tach_noise" => m.is_some_and(|x| (1.0..=1000.0).contains(&x)),
        "position_jump" => m.is_some_and(|x| x.abs() <= 1.0e7),
        "velocity_jump" => m.is_some_and(|x| x.abs() <= 1.0e4),
        "saturation" => m.is_some_and(|x| (0.0..=MAX_RATE_RAD_S).contains(&x)),
        "rotor_spin_down" => m.is_some_and(|x| (1.0..=1.0e7).contains(&x)),
        _ => m.is_none(),
    };
    in_range && onset_ok && end_ok && unit_ok && kind_ok && magnitude_ok
}

struct Case {
    base: usize,
    entries: Vec<Entry>,
    doc: Value,
    /// The keys a refusal may name, one of them (empty: the list is valid): each invalid
    /// entry's (the loader checks every number of the document before the list, so the
    /// first entry refused need not be the first invalid one), and `faults` beyond 32.
    refusal_keys: Vec<String>,
}

fn fault_value(e: &Entry) -> Value {
    let mut t = toml::map::Map::new();
    t.insert("onset_s".into(), Value::Float(e.onset_s));
    t.insert("unit".into(), Value::String(e.unit.clone()));
    t.insert("kind".into(), Value::String(e.kind.clone()));
    if let Some(m) = e.magnitude {
        t.insert("magnitude".into(), Value::Float(m));
    }
    if let Some(x) = e.end_s {
        t.insert("end_s".into(), Value::Float(x));
    }
    Value::Table(t)
}

fn cases(bases: &[Base]) -> Vec<Case> {
    let mut rng = SplitMix64(env_or("FAULT_FUZZ_SEED", SEED));
    let mut all: Vec<Case> = (0..bases.len())
        .map(|i| Case { base: i, entries: vec![], doc: bases[i].doc.clone(), refusal_keys: vec![] })
        .collect();
    for _ in 0..env_or("FAULT_FUZZ_CASES", CASES) {
        let bi = rng.below(bases.len());
        let b = &bases[bi];
        let n = match rng.below(20) {
            0 => 33,
            1 => 32,
            2..=4 => 4 + rng.below(28),
            _ => 1 + rng.below(3),
        };
        let clean = n > 3 && rng.below(2) == 0;
        let entries: Vec<Entry> = (0..n).map(|_| draw_entry(&mut rng, b, clean)).collect();
        let mut refusal_keys: Vec<String> =
            (0..n).filter(|i| !valid(&entries[*i], b)).map(|i| format!("`faults[{i}]")).collect();
        if n > 32 {
            refusal_keys.push("`faults`".into());
        }
        let mut doc = b.doc.clone();
        doc.as_table_mut().unwrap().insert("faults".into(), Value::Array(entries.iter().map(fault_value).collect()));
        all.push(Case { base: bi, entries, doc, refusal_keys });
    }
    all
}

#[derive(Debug, PartialEq)]
enum Verdict {
    Refused,
    /// Exit 0: not lost, or lost with FDIR events and ending in a safe mode (the flag).
    Ok {
        lost_reported: bool,
    },
    Failed(String),
    Bad(String),
}

/// The degraded-hold bound of a scenario, deg (docs/scenario.md "Pointing degraded"):
/// `[performance] degraded_hold_error_deg`, else `[modes] hold_enter_error_deg`, else
/// `[performance] settle_bound_deg`, else its default 1°; with the APE's confidence
/// (`[performance] confidence`, default 0.95).
fn degraded_bound(doc: &Value) -> Bound {
    let key = |table: &str, k: &str| doc.get(table).and_then(|t| t.get(k)).and_then(Value::as_float);
    let deg = key("performance", "degraded_hold_error_deg")
        .or_else(|| key("modes", "hold_enter_error_deg"))
        .or_else(|| key("performance", "settle_bound_deg"))
        .unwrap_or(1.0);
    Bound {
        deg,
        confidence: key("performance", "confidence").unwrap_or(0.95),
        budget_kg: key("performance", "propellant_budget_kg"),
    }
}

/// The degraded-hold bound and the confidence of the window's APE; the propellant budget.
#[derive(Clone, Copy)]
struct Bound {
    deg: f64,
    confidence: f64,
    budget_kg: Option<f64>,
}

/// What the series says of a run's end.
struct SeriesEnd {
    /// Every row of the last `WINDOW_S` lost, all at or after the first row with a fault.
    lost: bool,
    /// The last row's `mode` is a safe mode (false without a `mode` column: no mode manager).
    safe: bool,
    /// Every row of the same window held (mode hold, or no `mode` column), and more than
    /// `1 − confidence` of them above the bound.
    degraded: bool,
    /// The last row's `propellant_kg` is above the budget (NaN is; never without one).
    over_budget: bool,
}

/// From `timeseries.csv`, with the scenario's degraded-hold bound `bound_deg`.
fn lost_by_the_series(csv: &Path, bound: Bound) -> Result<SeriesEnd, String> {
    let text = std::fs::read_to_string(csv).map_err(|e| format!("{}: {e}", csv.display()))?;
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().ok_or("empty time series")?.split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).ok_or(format!("no column {n}"));
    let cols = [col("t_s")?, col("error_deg")?, col("rate_x_rad_s")?, col("rate_y_rad_s")?, col("rate_z_rad_s")?];
    // Without faults there is no `fault_active` column: nothing was ever injected.
    let active = col("fault_active").ok();
    let mode = col("mode").ok();
    let propellant = col("propellant_kg").ok();
    // Empty fields (NaN, ±inf) read as NaN: beyond any bound, as in the verdict.
    let num = |s: &str| s.parse::<f64>().unwrap_or(f64::NAN);
    let mut used_kg = f64::NAN;
    let rows: Vec<([f64; 5], f64, f64)> = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            used_kg = propellant.map_or(f64::NAN, |p| num(f[p]));
            (cols.map(|c| num(f[c])), active.map_or(0.0, |a| num(f[a])), mode.map_or(f64::NAN, |m| num(f[m])))
        })
        .collect();
    let over_budget = bound.budget_kg.is_some_and(|b| !(used_kg <= b));
    let Some(&(last, _, last_mode)) = rows.last() else {
        return Ok(SeriesEnd { lost: false, safe: false, degraded: false, over_budget });
    };
    let end = last[0];
    let injected = rows.iter().find(|r| r.1 != 0.0).map_or(f64::INFINITY, |r| r.0[0]);
    let tumbling_row =
        |r: &[f64; 5]| !((r[2] * r[2] + r[3] * r[3] + r[4] * r[4]).sqrt().to_degrees() <= RATE_BOUND_DEG_S);
    let lost_row = |r: &[f64; 5]| !(r[1] <= ERROR_BOUND_DEG) || tumbling_row(r);
    let window: Vec<&([f64; 5], f64, f64)> = rows.iter().filter(|r| r.0[0] >= end - WINDOW_S - 1e-9).collect();
    let judged = injected <= end - WINDOW_S + 1e-9;
    // Sun-safe tumbling over the whole window (the mode manager blind to it) is no survival.
    let tumbling = judged && window.iter().all(|r| tumbling_row(&r.0));
    let safe = last_mode == DETUMBLE_CODE || (last_mode == SUN_SAFE_CODE && !tumbling);
    // NaN mode: no mode column, the one law holds the whole run.
    let held = window.iter().all(|r| r.2.is_nan() || r.2 == HOLD_CODE);
    let above = window.iter().filter(|r| !(r.0[1] <= bound.deg)).count();
    Ok(SeriesEnd {
        lost: judged && window.iter().all(|r| lost_row(&r.0)),
        safe,
        degraded: injected <= end - WINDOW_S - RECOVERY_ALLOWANCE_S + 1e-9
            && held
            && above as f64 > (1.0 - bound.confidence) * window.len() as f64,
        over_budget,
    })
}

fn judge(c: &Case, dir: &Path) -> Verdict {
    let sc = dir.join("sc.toml");
    std::fs::write(&sc, toml::to_string(&c.doc).unwrap()).unwrap();
    let out = dir.join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(["run", sc.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-plots", "--quiet"])
        .args(["--link", "in-process", "--format", "csv"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t0.elapsed() > CASE_LIMIT {
            child.kill().ok();
            child.wait().ok();
            return Verdict::Bad(format!("no answer within {CASE_LIMIT:?}"));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).ok();
    let keys = &c.refusal_keys;
    match status.code() {
        Some(1) if keys.iter().any(|k| err.contains(k.as_str())) => Verdict::Refused,
        Some(1) if keys.is_empty() => Verdict::Bad(format!("a valid list refused: {}", err.trim())),
        Some(1) => Verdict::Bad(format!("refused without naming any of {keys:?}: {}", err.trim())),
        Some(0 | 3) if !keys.is_empty() => Verdict::Bad(format!("ran with invalid entries ({keys:?})")),
        Some(code @ (0 | 3)) => judge_run(&out, code, degraded_bound(&c.doc)),
        other => Verdict::Bad(format!("exit {other:?}: {}", err.trim())),
    }
}

fn judge_run(out: &Path, code: i32, bound: Bound) -> Verdict {
    let Ok(text) = std::fs::read_to_string(out.join("summary.json")) else {
        return Verdict::Bad(format!("exit {code} without summary.json"));
    };
    let s: Json = serde_json::from_str(&text).unwrap();
    let status = s["run_status"].as_str().unwrap_or("(none)").to_string();
    let events = s["fdir"]["events"].as_array().map_or(0, Vec::len);
    let SeriesEnd { lost, safe, degraded, over_budget } = match lost_by_the_series(&out.join("timeseries.csv"), bound) {
        Ok(l) => l,
        Err(e) => return Verdict::Bad(e),
    };
    let degraded = degraded && !lost;
    match code {
        0 if status != "ok" => Verdict::Bad(format!("exit 0 with run_status {status}")),
        0 if lost && events == 0 => Verdict::Bad("exit 0 with control lost and no FDIR event".into()),
        0 if lost && !safe => {
            Verdict::Bad(format!("exit 0 with control lost after {events} FDIR events, not in a safe mode"))
        }
        0 if degraded => Verdict::Bad(format!("exit 0 held with an APE above {} deg, {events} FDIR events", bound.deg)),
        0 if over_budget => Verdict::Bad(format!("exit 0 over the propellant budget {:?} kg", bound.budget_kg)),
        0 => Verdict::Ok { lost_reported: lost },
        _ if !FAILED.contains(&status.as_str()) => Verdict::Bad(format!("exit 3 with run_status {status}")),
        _ if status == "control_lost" && !(lost && events == 0) => {
            Verdict::Bad(format!("control_lost, but the series says lost {lost} with {events} FDIR events"))
        }
        _ if status == "recovery_failed" && !(events > 0 && ((lost && !safe) || degraded)) => Verdict::Bad(format!(
            "recovery_failed, but the series says lost {lost}, degraded {degraded}, safe mode at the end {safe}, \
             with {events} FDIR events"
        )),
        _ if status == "pointing_degraded" && !(degraded && events == 0) => Verdict::Bad(format!(
            "pointing_degraded, but the series says degraded {degraded} with {events} FDIR events"
        )),
        // The pointing verdicts win: lost (unless reported and ended safe) or degraded.
        _ if status == "propellant_exceeded" && !(over_budget && !(lost && (events == 0 || !safe)) && !degraded) => {
            Verdict::Bad(format!(
                "propellant_exceeded, but the series says over the budget {over_budget}, lost {lost} with {events} \
                 FDIR events (safe mode at the end {safe}), degraded {degraded}"
            ))
        }
        _ => Verdict::Failed(status),
    }
}

fn run_all(all: &[Case]) -> Vec<(usize, Verdict)> {
    let tmp = tempfile::tempdir().unwrap();
    run_cases(all, WORKERS, tmp.path(), judge)
}

fn describe(c: &Case) -> String {
    let list: Vec<String> = c
        .entries
        .iter()
        .take(4)
        .map(|e| {
            let m = e.magnitude.map_or(String::new(), |m| format!(" {m}"));
            let end = e.end_s.map_or(String::new(), |x| format!(" to {x}"));
            format!("{} {}{m} at {}{end}", e.unit, e.kind, e.onset_s)
        })
        .collect();
    let more = c.entries.len().saturating_sub(4);
    format!(
        "{} entries: {}{}",
        c.entries.len(),
        list.join("; "),
        if more > 0 { format!("; +{more}") } else { "".into() }
    )
}

#[test]
fn fault_lists_are_refused_naming_the_entry_or_run_without_losing_control_unnoticed_or_fail() {
    let t0 = Instant::now();
    let bases = [
        base("3U mission", "scenarios/modes/cubesat-mission.toml", 6500.0, false),
        base("3U mission + [fdir.wheels]", "scenarios/modes/cubesat-mission.toml", 6500.0, true),
        base("6U wheel-seized + [fdir.wheels]", "scenarios/fdir/wheel-seized-6u.toml", 1500.0, true),
        base("paper 000 CMG pyramid", "scenarios/paper000/test1.toml", 150.0, false),
        base("paper 004 thrusters", "scenarios/paper004/dp-nominal.toml", 150.0, false),
    ];
    let all = cases(&bases);
    let verdicts = run_all(&all);
    let count = |f: &dyn Fn(&Verdict) -> bool| verdicts.iter().filter(|(_, v)| f(v)).count();
    println!(
        "fault_fuzz: {} cases (seed {:#x}) in {:.1} s: {} refused, {} ok ({} of them lost control with FDIR events), \
         {} failed runs, {} bad",
        verdicts.len(),
        env_or("FAULT_FUZZ_SEED", SEED),
        t0.elapsed().as_secs_f64(),
        count(&|v| *v == Verdict::Refused),
        count(&|v| matches!(v, Verdict::Ok { .. })),
        count(&|v| *v == Verdict::Ok { lost_reported: true }),
        count(&|v| matches!(v, Verdict::Failed(_))),
        count(&|v| matches!(v, Verdict::Bad(_))),
    );
    for (bi, b) in bases.iter().enumerate() {
        let of_base: Vec<&Verdict> = verdicts.iter().filter(|(i, _)| all[*i].base == bi).map(|(_, v)| v).collect();
        let n = |f: &dyn Fn(&Verdict) -> bool| of_base.iter().filter(|v| f(v)).count();
        println!(
            "  {}: {} cases, {} refused, {} ok, {} failed runs",
            b.name,
            of_base.len(),
            n(&|v| *v == Verdict::Refused),
            n(&|v| matches!(v, Verdict::Ok { .. })),
            n(&|v| matches!(v, Verdict::Failed(_)))
        );
    }
    // The new actuator kinds must reach a run, not only refusals.
    for kind in ["gimbal_stuck", "rotor_spin_down", "stuck_closed", "stuck_open"] {
        let ran = verdicts
            .iter()
            .filter(|(i, v)| {
                matches!(v, Verdict::Ok { .. } | Verdict::Failed(_)) && all[*i].entries.iter().any(|e| e.kind == kind)
            })
            .count();
        println!("  runs with a {kind} entry: {ran}");
        assert!(ran > 0, "no run with a {kind} entry: the generator does not reach it");
    }
    for (i, v) in &verdicts {
        if matches!(v, Verdict::Failed(_)) {
            println!("  {} [{}]: {v:?}", bases[all[*i].base].name, describe(&all[*i]));
        }
    }
    let controls: Vec<_> = verdicts
        .iter()
        .filter(|(i, v)| all[*i].entries.is_empty() && *v != Verdict::Ok { lost_reported: false })
        .map(|(i, v)| format!("{}: {v:?}", bases[all[*i].base].name))
        .collect();
    assert!(controls.is_empty(), "bases without faults that do not run clean: {controls:#?}");
    let bad: Vec<String> = verdicts
        .iter()
        .filter_map(|(i, v)| match v {
            Verdict::Bad(why) => Some(format!("{} [{}]: {why}", bases[all[*i].base].name, describe(&all[*i]))),
            _ => None,
        })
        .collect();
    assert!(bad.is_empty(), "{} of {} cases broke the contract:\n{}", bad.len(), verdicts.len(), bad.join("\n"));
    // The fuzz reaches refusals and runs (else its pools are too tame or too wild).
    assert!(count(&|v| *v == Verdict::Refused) >= 10 && count(&|v| matches!(v, Verdict::Ok { .. })) >= 10);
}
