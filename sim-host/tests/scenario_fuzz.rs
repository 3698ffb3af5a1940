//! Seeded, bounded-time fuzz of the scenario loader and the run (issue 21): every shipped
//! scenario, its duration clamped short, mutated one key at a time (extreme values, NaN and
//! infinities, wrong array lengths, a huge array, wrong types). For every case, one of:
//!
//! - refused: exit 1 and the message names the mutated key;
//! - run: exit 0, `summary.json` with finite figures and not every step refused;
//! - failed run: exit 3, `summary.json` with a failed `run_status` ("diverged",
//!   "all_refused", "no_control", ...).
//!
//! Anything else (exit 0 on a non-finite or all-refused run, a panic, a signal, a hang
//! beyond the per-case limit) fails the test, listing every offending case.
//!
//! A second fuzz (issue 37) mutates the sensors' timing (`rate_hz`, `phase_s`,
//! `jitter_s`, `latency_s` of each sensor table, the suite's `latency_s`) and the
//! estimator's settings (`max_sample_latency_s`, `max_replayed_nodes`, `max_sample_age_s`,
//! `coarse_update_interval_s`, ...) of the MEKF scenarios, one to three keys at a time,
//! over 60 s runs with every step recorded. Every case is refused naming a mutated key,
//! or runs (exit 0) with commands and an estimate — at most 10 % of the steps after the
//! start-up allowance held the safe command for a missing input or estimate, counted
//! from the time series' `status` column here —, or exits 3 with a failed status (a
//! `no_control` verdict checked against the same count). None exits 0 with no control.

// SplitMix64 (Steele, Lea & Flood 2014): the test's only source of randomness.
use acs_test_support::cases::run_cases;
use acs_test_support::rng::SplitMix64;
use serde_json::Value as Json;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use toml::Value;

/// The seed and the number of mutated cases (plus one unmutated run of each shipped
/// scenario as the control); `SCENARIO_FUZZ_SEED` / `SCENARIO_FUZZ_CASES` override them to
/// explore further.
const SEED: u64 = 0x21_F022;
const CASES: usize = 400;

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}
/// Parallel runs (the CI machine has 2 cores).
const WORKERS: usize = 2;
/// One case may take this long before it counts as a hang.
const CASE_LIMIT: Duration = Duration::from_secs(60);

#[derive(Clone, Debug)]
enum Seg {
    Key(String),
    Idx(usize),
}

type KeyPath = Vec<Seg>;

fn dotted(p: &KeyPath) -> String {
    let mut s = String::new();
    for seg in p {
        match seg {
            Seg::Key(k) if s.is_empty() => s += k,
            Seg::Key(k) => s += &format!(".{k}"),
            Seg::Idx(i) => s += &format!("[{i}]"),
        }
    }
    s
}

/// The table holding a path's last key, as written in a refusal (`controller`,
/// `modes.hold.controller`).
fn table_of(p: &KeyPath) -> String {
    let last_key = p.iter().rposition(|s| matches!(s, Seg::Key(_))).unwrap_or(0);
    dotted(&p[..last_key].to_vec())
}

/// The last key name of a path: what a refusal must mention.
fn leaf_key(p: &KeyPath) -> String {
    p.iter()
        .rev()
        .find_map(|s| match s {
            Seg::Key(k) => Some(k.clone()),
            Seg::Idx(_) => None,
        })
        .unwrap_or_default()
}

/// Every number and every array of the document, with its path.
fn collect(v: &Value, path: &mut KeyPath, numbers: &mut Vec<KeyPath>, arrays: &mut Vec<KeyPath>) {
    match v {
        Value::Integer(_) | Value::Float(_) => numbers.push(path.clone()),
        Value::Array(a) => {
            arrays.push(path.clone());
            for (i, x) in a.iter().enumerate() {
                path.push(Seg::Idx(i));
                collect(x, path, numbers, arrays);
                path.pop();
            }
        }
        Value::Table(t) => {
            for (k, x) in t {
                path.push(Seg::Key(k.clone()));
                collect(x, path, numbers, arrays);
                path.pop();
            }
        }
        _ => {}
    }
}

fn at<'a>(v: &'a mut Value, p: &KeyPath) -> &'a mut Value {
    p.iter().fold(v, |v, seg| match seg {
        Seg::Key(k) => v.get_mut(k.as_str()).expect("path exists"),
        Seg::Idx(i) => v.get_mut(*i).expect("index exists"),
    })
}

/// One mutation of `doc`; returns its description and the path mutated.
fn mutate(doc: &mut Value, rng: &mut SplitMix64) -> (String, KeyPath) {
    let (mut numbers, mut arrays) = (Vec::new(), Vec::new());
    collect(doc, &mut Vec::new(), &mut numbers, &mut arrays);
    let extremes = [1e300, -1e300, 0.0, -1.0, 1e-300, 1e30, f64::NAN, f64::INFINITY, f64::NEG_INFINITY];
    let kind = rng.below(10);
    if kind < 6 || arrays.is_empty() {
        let p = numbers[rng.below(numbers.len())].clone();
        let x = extremes[rng.below(extremes.len())];
        let slot = at(doc, &p);
        *slot = match slot {
            // Integers get an integer extreme half of the time, a float (a wrong type) else.
            Value::Integer(_) if rng.below(2) == 0 => Value::Integer([i64::MAX, -1, 0][rng.below(3)]),
            _ => Value::Float(x),
        };
        return (format!("{} = {}", dotted(&p), slot), p);
    }
    let p = arrays[rng.below(arrays.len())].clone();
    let Value::Array(a) = at(doc, &p) else { unreachable!() };
    let what = match kind {
        6 if !a.is_empty() => {
            a.push(a[a.len() - 1].clone());
            "one element more"
        }
        7 if !a.is_empty() => {
            a.pop();
            "one element less"
        }
        8 if !a.is_empty() => {
            let last = a[a.len() - 1].clone();
            a.resize(100_000, last);
            "100,000 elements"
        }
        _ => {
            let i = rng.below(a.len().max(1));
            if a.is_empty() {
                a.push(Value::String("x".into()));
            } else {
                a[i] = Value::String("x".into());
            }
            "a string element"
        }
    };
    (format!("{} with {what}", dotted(&p)), p)
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn shipped() -> Vec<PathBuf> {
    fn walk(d: &Path, out: &mut Vec<PathBuf>) {
        let mut es: Vec<_> = std::fs::read_dir(d).unwrap().map(|e| e.unwrap().path()).collect();
        es.sort();
        for p in es {
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|e| e == "toml") {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(&repo().join("scenarios"), &mut out);
    out
}

/// The scenario with its run clamped to at most 1 s (or 5 control periods if longer).
fn clamped(path: &Path) -> Value {
    let mut doc: Value = toml::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let rate = doc["timing"]["control_rate_hz"].as_float().unwrap();
    let d = doc["duration_s"].as_float().unwrap();
    shorten(&mut doc, d.min((5.0 / rate).max(1.0)));
    doc
}

/// Sets the run's `duration_s`, dropping the `[[timeline]]` segments that no longer start
/// inside it (a segment must start before the end; the shortening is not a mutation).
fn shorten(doc: &mut Value, duration_s: f64) {
    doc["duration_s"] = Value::Float(duration_s);
    let table = doc.as_table_mut().unwrap();
    if let Some(Value::Array(segments)) = table.get_mut("timeline") {
        segments.retain(|s| s.get("start_s").and_then(Value::as_float).is_some_and(|t| t < duration_s));
        if segments.is_empty() {
            table.remove("timeline");
        }
    }
}

struct Case {
    name: String,
    what: String,
    /// The mutated key's name, and the key of its table (a refusal names one of them:
    /// the flight code's parameter check knows the law's table, not each gain).
    key: String,
    table: String,
    doc: Value,
}

#[derive(Debug, PartialEq)]
enum Verdict {
    Refused,
    Ok,
    Failed(String),
    Bad(String),
}

/// Non-optional figures of the summary that a finite run always has.
const FIGURES: [&str; 5] =
    ["final_error_deg", "mean_error_whole_run_deg", "final_euler_deg", "final_rate_rad_s", "sim_time_s"];

fn finite_json(v: &Json) -> bool {
    match v {
        Json::Number(n) => n.as_f64().is_some_and(f64::is_finite),
        Json::Array(a) => a.iter().all(finite_json),
        Json::Object(o) => o.values().all(finite_json),
        _ => true,
    }
}

fn judge_summary(dir: &Path, code: i32) -> Verdict {
    let Ok(text) = std::fs::read_to_string(dir.join("summary.json")) else {
        return Verdict::Bad(format!("exit {code} without summary.json"));
    };
    let s: Json = serde_json::from_str(&text).unwrap();
    let status = s.get("run_status").and_then(Json::as_str);
    if code == 3 {
        return match status {
            // A failed run that says why (docs/scenario.md "Run status"): a mutation may make a
            // keep-out, a timeline or the FDIR's noise model (e.g. a gyro sampled so fast
            // that its per-sample noise swamps the wheel residual) fail, never exit 0.
            Some(
                st @ ("diverged"
                | "all_refused"
                | "no_control"
                | "samples_dropped"
                | "keepout_violated"
                | "timeline_missed"
                | "fdir_false_alarm"
                | "control_lost"
                | "recovery_failed"
                | "pointing_degraded"
                | "propellant_exceeded"),
            ) => Verdict::Failed(st.into()),
            other => Verdict::Bad(format!("exit 3 with run_status {other:?}")),
        };
    }
    if let Some(f) = FIGURES.iter().find(|f| s.get(**f).is_none_or(|v| v.is_null() || !finite_json(v))) {
        return Verdict::Bad(format!("exit 0 with {f} = {}", s.get(*f).unwrap_or(&Json::Null)));
    }
    // The figures after settle exist exactly when the run settled and their window (from
    // `after_settle_from_s`) reaches into the run (1e-9 s: the float of a sample time).
    let settled = !s.get("settle_time_s").is_none_or(Json::is_null);
    let from = s.get("after_settle_from_s").and_then(Json::as_f64);
    let end = s.get("sim_time_s").and_then(Json::as_f64).unwrap_or(f64::NAN);
    if settled != from.is_some() {
        return Verdict::Bad(format!(
            "exit 0 with after_settle_from_s = {} and settle_time_s = {}",
            s["after_settle_from_s"], s["settle_time_s"]
        ));
    }
    for f in ["rms_error_after_settle_deg", "max_error_after_settle_deg", "ape_after_settle_deg"] {
        let present = !s.get(f).is_none_or(Json::is_null);
        let inside = from.is_some_and(|t| t < end - 1e-9);
        let outside = from.is_none_or(|t| t > end + 1e-9);
        if (present && outside) || (!present && inside) {
            return Verdict::Bad(format!(
                "exit 0 with {f} = {}, after_settle_from_s = {}, sim_time_s = {end}",
                s[f], s["after_settle_from_s"]
            ));
        }
    }
    if !finite_json(&s) {
        return Verdict::Bad("exit 0 with a non-finite number in summary.json".into());
    }
    let steps = s["steps"].as_u64().unwrap_or(0);
    let refused = s["status_counts"]["bad_input"].as_u64().unwrap_or(0);
    if steps > 0 && refused >= steps {
        return Verdict::Bad(format!("exit 0 with every step refused ({refused} bad_input of {steps})"));
    }
    if status.is_some_and(|st| st != "ok") {
        return Verdict::Bad(format!("exit 0 with run_status {status:?}"));
    }
    Verdict::Ok
}

/// Runs `sim-host run` on the case's scenario (with `extra` arguments) into `dir/out`:
/// its exit code and stderr, or a verdict when it hangs.
fn spawn_case(doc: &Value, dir: &Path, extra: &[&str]) -> Result<(Option<i32>, String), Verdict> {
    let sc = dir.join("sc.toml");
    std::fs::write(&sc, toml::to_string(doc).unwrap()).unwrap();
    let out = dir.join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(["run", sc.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-plots", "--quiet"])
        .args(["--link", "in-process"])
        .args(extra)
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
            return Err(Verdict::Bad(format!("no answer within {CASE_LIMIT:?}")));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).ok();
    Ok((status.code(), err))
}

fn run_case(c: &Case, dir: &Path) -> Verdict {
    let (code, err) = match spawn_case(&c.doc, dir, &[]) {
        Ok(x) => x,
        Err(v) => return v,
    };
    let out = dir.join("out");
    match code {
        Some(1) if err.contains(&c.key) || (!c.table.is_empty() && err.contains(&format!("`{}`", c.table))) => {
            Verdict::Refused
        }
        Some(1) => Verdict::Bad(format!("refused without naming `{}`: {}", c.key, err.trim())),
        Some(code @ (0 | 3)) => judge_summary(&out, code),
        other => Verdict::Bad(format!("exit {other:?}: {}", err.trim())),
    }
}

fn cases() -> Vec<Case> {
    let mut rng = SplitMix64(env_or("SCENARIO_FUZZ_SEED", SEED));
    let bases: Vec<(String, Value)> =
        shipped().iter().map(|p| (p.strip_prefix(repo()).unwrap().display().to_string(), clamped(p))).collect();
    assert!(bases.len() >= 20, "found only {} shipped scenarios", bases.len());
    let mut all: Vec<Case> = bases
        .iter()
        .map(|(n, d)| Case {
            name: n.clone(),
            what: "unmutated".into(),
            key: "(none)".into(),
            table: String::new(),
            doc: d.clone(),
        })
        .collect();
    for _ in 0..env_or("SCENARIO_FUZZ_CASES", CASES) {
        let (name, base) = &bases[rng.below(bases.len())];
        let mut doc = base.clone();
        let (what, p) = mutate(&mut doc, &mut rng);
        all.push(Case { name: name.clone(), what, key: leaf_key(&p), table: table_of(&p), doc });
    }
    all
}

#[test]
fn mutated_scenarios_are_refused_naming_the_key_or_run_to_a_finite_or_failed_summary() {
    let t0 = Instant::now();
    let all = cases();
    let verdicts = run_all(&all, run_case);
    let count = |f: fn(&Verdict) -> bool| verdicts.iter().filter(|(_, v)| f(v)).count();
    println!(
        "scenario_fuzz: {} cases (seed {:#x}) in {:.1} s: {} refused, {} ok, {} failed runs, {} bad",
        verdicts.len(),
        env_or("SCENARIO_FUZZ_SEED", SEED),
        t0.elapsed().as_secs_f64(),
        count(|v| *v == Verdict::Refused),
        count(|v| *v == Verdict::Ok),
        count(|v| matches!(v, Verdict::Failed(_))),
        count(|v| matches!(v, Verdict::Bad(_)))
    );
    // Every shipped scenario runs as it is.
    let controls = verdicts.iter().filter(|(i, _)| all[*i].what == "unmutated");
    let broken: Vec<_> = controls.filter(|(_, v)| *v != Verdict::Ok).map(|(i, v)| (&all[*i].name, v)).collect();
    assert!(broken.is_empty(), "shipped scenarios that do not run: {broken:#?}");
    let bad: Vec<String> = verdicts
        .iter()
        .filter_map(|(i, v)| match v {
            Verdict::Bad(why) => Some(format!("{} [{}]: {why}", all[*i].name, all[*i].what)),
            _ => None,
        })
        .collect();
    assert!(bad.is_empty(), "{} of {} cases broke the contract:\n{}", bad.len(), verdicts.len(), bad.join("\n"));
}

/// Runs `judge` on every case, `WORKERS` at a time, each in its own directory; the
/// verdicts in case order.
fn run_all<C: Sync>(all: &[C], judge: impl Fn(&C, &Path) -> Verdict + Sync) -> Vec<(usize, Verdict)> {
    let tmp = tempfile::tempdir().unwrap();
    run_cases(all, WORKERS, tmp.path(), judge)
}

/// Cases of the timing fuzz; `TIMING_FUZZ_CASES` overrides.
const TIMING_CASES: usize = 400;
/// Run length of the timing fuzz, s: long enough for the start-up allowance (10 %, at most
/// 60 s) to leave most steps to judge.
const TIMING_DURATION_S: f64 = 60.0;

/// A value pool for a key.
#[derive(Clone, Copy)]
enum Pool {
    Floats(&'static [f64]),
    Ints(&'static [i64]),
}

const LATENCIES: Pool =
    Pool::Floats(&[0.0, 1e-4, 0.01, 0.05, 0.2, 0.3, 0.6, 1.0, 2.5, 10.0, 10.5, -0.1, f64::NAN, 1e300]);
const RATES: Pool =
    Pool::Floats(&[1e-9, 0.05, 0.3, 1.0, 2.0, 3.0, 4.0, 10.0, 100.0, 1e8, 0.0, -1.0, f64::NAN, f64::INFINITY]);
const PHASES: Pool = Pool::Floats(&[0.0, 0.01, 0.1, 0.4, 2.0, 5e8, -0.1, f64::NAN]);
const JITTERS: Pool = Pool::Floats(&[0.0, 0.001, 0.05, 0.2, -0.01]);

/// The keys the timing fuzz mutates: sensor timing in every sensor table the base has, the
/// suite's latency, and the estimator's settings.
fn timing_keys(doc: &Value) -> Vec<(KeyPath, Pool)> {
    let key = |a: &str, b: &str| vec![Seg::Key(a.into()), Seg::Key(b.into())];
    let mut keys = vec![(key("sensors", "latency_s"), LATENCIES)];
    for table in ["gyro", "star_tracker", "magnetometer", "css", "sun", "gnss"] {
        if doc["sensors"].get(table).is_some() {
            for (k, pool) in [("rate_hz", RATES), ("phase_s", PHASES), ("jitter_s", JITTERS), ("latency_s", LATENCIES)]
            {
                keys.push((vec![Seg::Key("sensors".into()), Seg::Key(table.into()), Seg::Key(k.into())], pool));
            }
        }
    }
    for (k, pool) in [
        ("max_sample_latency_s", Pool::Floats(&[0.01, 0.1, 0.3, 0.5, 2.0, 60.0, 0.0, 61.0, f64::NAN])),
        ("max_replayed_nodes", Pool::Ints(&[0, 1, 2, 4, 8, 31, 32, 255])),
        ("max_sample_age_s", Pool::Floats(&[0.05, 0.3, 1.0, 3.0, 60.0, 3600.0, 0.0, 1e5])),
        ("coarse_update_interval_s", Pool::Floats(&[0.0, 0.5, 5.0, 60.0, 1e5, -1.0])),
        ("lost_attitude_sigma_deg", Pool::Floats(&[1e-4, 0.01, 0.5, 1.0, 10.0])),
        ("initial_attitude_sigma_deg", Pool::Floats(&[0.01, 2.0, 30.0])),
        ("max_consecutive_rejections", Pool::Ints(&[1, 2, 20])),
    ] {
        keys.push((key("estimation", k), pool));
    }
    keys
}

/// Set `path` (a table's key, the table existing) to `v`.
fn set(doc: &mut Value, path: &KeyPath, v: Value) {
    let (last, table) = path.split_last().unwrap();
    let Seg::Key(k) = last else { unreachable!() };
    at(doc, &table.to_vec()).as_table_mut().unwrap().insert(k.clone(), v);
}

/// The MEKF scenarios, 60 s long, every step recorded.
fn timing_bases() -> Vec<(String, Value)> {
    shipped()
        .iter()
        .filter_map(|p| {
            let mut doc: Value = toml::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
            let mekf = doc.get("estimation").and_then(|e| e.get("source")).and_then(Value::as_str) == Some("mekf");
            mekf.then(|| {
                shorten(&mut doc, TIMING_DURATION_S);
                doc["timing"].as_table_mut().unwrap().insert("output_every".into(), Value::Integer(1));
                (p.strip_prefix(repo()).unwrap().display().to_string(), doc)
            })
        })
        .collect()
}

struct TimingCase {
    name: String,
    what: String,
    /// The dotted keys mutated: a refusal names one of them.
    keys: Vec<String>,
    doc: Value,
}

fn timing_cases() -> Vec<TimingCase> {
    let mut rng = SplitMix64(env_or("SCENARIO_FUZZ_SEED", SEED) ^ 0x37);
    let bases = timing_bases();
    assert!(bases.len() >= 4, "MEKF scenarios: {}", bases.len());
    let mut all: Vec<TimingCase> = bases
        .iter()
        .map(|(n, d)| TimingCase { name: n.clone(), what: "unmutated".into(), keys: vec![], doc: d.clone() })
        .collect();
    for _ in 0..env_or("TIMING_FUZZ_CASES", TIMING_CASES) {
        let (name, base) = &bases[rng.below(bases.len())];
        let mut doc = base.clone();
        let pool = timing_keys(&doc);
        let (mut what, mut keys) = (Vec::new(), Vec::new());
        for _ in 0..1 + rng.below(3) {
            let (path, values) = &pool[rng.below(pool.len())];
            let v = match values {
                Pool::Floats(xs) => Value::Float(xs[rng.below(xs.len())]),
                Pool::Ints(xs) => Value::Integer(xs[rng.below(xs.len())]),
            };
            what.push(format!("{} = {v}", dotted(path)));
            keys.push(dotted(path));
            set(&mut doc, path, v);
        }
        all.push(TimingCase { name: name.clone(), what: what.join(", "), keys, doc });
    }
    all
}

/// From `timeseries.csv` (every step): the steps after the start-up allowance (the first
/// 10 % of the steps, at most 60 s) and those of them that held the safe command for a
/// missing input or estimate (`BAD_INPUT` or `NO_ESTIMATE`).
fn uncontrolled(csv: &Path, control_rate_hz: f64) -> (usize, usize) {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "status").expect("status column");
    let status: Vec<u16> =
        lines.map(|l| l.split(',').nth(col).unwrap().parse::<f64>().map_or(u16::MAX, |x| x as u16)).collect();
    let allowance = ((0.1 * status.len() as f64).ceil()).min((60.0 * control_rate_hz).ceil()) as usize;
    let bits = acs_flight::link::status::BAD_INPUT | acs_flight::link::status::NO_ESTIMATE;
    let after = &status[allowance.min(status.len())..];
    (after.len(), after.iter().filter(|s| **s & bits != 0).count())
}

fn judge_timing(c: &TimingCase, dir: &Path) -> Verdict {
    let (code, err) = match spawn_case(&c.doc, dir, &["--format", "csv"]) {
        Ok(x) => x,
        Err(v) => return v,
    };
    let out = dir.join("out");
    match code {
        Some(1) if c.keys.iter().any(|k| err.contains(k.as_str())) => Verdict::Refused,
        Some(1) => Verdict::Bad(format!("refused without naming any of {:?}: {}", c.keys, err.trim())),
        Some(code @ (0 | 3)) => {
            let v = judge_summary(&out, code);
            if matches!(v, Verdict::Bad(_)) {
                return v;
            }
            let rate = c.doc["timing"]["control_rate_hz"].as_float().unwrap();
            let (n, bad) = uncontrolled(&out.join("timeseries.csv"), rate);
            let material = bad as f64 > 0.1 * n as f64;
            let s: Json = serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
            match (&v, material) {
                (Verdict::Ok, true) => Verdict::Bad(format!("exit 0 with {bad} of {n} steps uncontrolled")),
                (Verdict::Ok, false) if s.get("estimation_steps").and_then(Json::as_u64).unwrap_or(0) == 0 => {
                    Verdict::Bad("exit 0 and the filter never ran".into())
                }
                (Verdict::Failed(st), false) if st == "no_control" => {
                    Verdict::Bad(format!("no_control with {bad} of {n} steps uncontrolled"))
                }
                _ => v,
            }
        }
        other => Verdict::Bad(format!("exit {other:?}: {}", err.trim())),
    }
}

#[test]
fn sensor_timing_and_estimator_settings_are_refused_naming_a_key_or_run_controlled_or_fail() {
    let t0 = Instant::now();
    let all = timing_cases();
    let verdicts = run_all(&all, judge_timing);
    let count = |f: fn(&Verdict) -> bool| verdicts.iter().filter(|(_, v)| f(v)).count();
    println!(
        "timing fuzz: {} cases in {:.1} s: {} refused, {} ok, {} failed runs ({} no_control), {} bad",
        verdicts.len(),
        t0.elapsed().as_secs_f64(),
        count(|v| *v == Verdict::Refused),
        count(|v| *v == Verdict::Ok),
        count(|v| matches!(v, Verdict::Failed(_))),
        count(|v| matches!(v, Verdict::Failed(s) if s == "no_control")),
        count(|v| matches!(v, Verdict::Bad(_)))
    );
    let broken: Vec<_> = verdicts
        .iter()
        .filter(|(i, v)| all[*i].what == "unmutated" && *v != Verdict::Ok)
        .map(|(i, v)| format!("{}: {v:?}", all[*i].name))
        .collect();
    assert!(broken.is_empty(), "MEKF scenarios that do not run 60 s: {broken:#?}");
    let bad: Vec<String> = verdicts
        .iter()
        .filter_map(|(i, v)| match v {
            Verdict::Bad(why) => Some(format!("{} [{}]: {why}", all[*i].name, all[*i].what)),
            _ => None,
        })
        .collect();
    for (i, v) in &verdicts {
        if matches!(v, Verdict::Failed(_)) {
            println!("  {} [{}]: {v:?}", all[*i].name, all[*i].what);
        }
    }
    assert!(bad.is_empty(), "{} of {} cases broke the contract:\n{}", bad.len(), verdicts.len(), bad.join("\n"));
    // The fuzz reaches every outcome (else its pools are too tame or too wild).
    assert!(count(|v| *v == Verdict::Refused) > 10 && count(|v| *v == Verdict::Ok) > 10);
}
