//! Seeded, bounded-time fuzz of the margins options (issue 37): the `sim-host margins`
//! flags and the scenario's `[margins]` keys, each drawn valid, at or just past a bound of
//! its range, or absurd (negative, zero, NaN, ±∞, 1e300, a huge integer, text, a wrong
//! TOML type, an unknown key), on the rigid-PD reference loop
//! (`tests/scenarios/margins/rigid-pd.toml`: PM 63.0°, crossover 0.772 rad/s, multiloop
//! disk α 1.12 on every axis) and, for the flags, two variants no flag may make exit 0:
//! gains × 10 with 0.2 s of torque delay (unstable, PM −15.4°) and rotors of 1e-6 kg m²
//! that every experiment spins to their speed limit. For every case, one of:
//!
//! - refused naming what was refused: `sim-host margins` exit 2 with a flag of the case on
//!   stderr (a flag out of range, a hint above the crossover, a loop the method cannot
//!   break, over the plant-step budget) and no `margins.json`; `sim-host run` exit 1 with
//!   the `[margins]` key on stderr;
//! - measured: exit 0, a stable loop whose figures are this loop's — every axis's phase
//!   margin within 5° and crossover within 10 % of the closed form of the loop broken where
//!   the case breaks it (at the input, `loop_reference::AxisLoop`: 63.0°, 0.772 rad/s; at
//!   the attitude measurement, the rate loop closed, `ωn²/(s(s + 2ζωn))`: 65.2°, 0.324
//!   rad/s), the multiloop α in (0, 2]; `sim-host run`: `run_status` ok, `margins.status`
//!   measured;
//! - a failed measurement: exit 3 with the reason (not a steady hold, unstable or a
//!   negative margin), `margins.json` only with `stable: false`; `sim-host run`:
//!   `run_status` margins_failed.
//!
//! Anything else — exit 0 with infinite or off margins, a panic, an abort, a signal, no
//! answer within the per-case limit — fails the test, listing every offending case. Every
//! `sim-host margins` case carries `--max-plant-steps` (drawn: a budget is how a caller
//! bounds a measurement's cost, and a valid hint of 1e-5 rad/s would otherwise ask for an
//! hours-long one); the `[margins]` cases draw `grid_points` up to 30 when valid, for time.

use acs_test_support::cases::run_cases;
use acs_test_support::rng::SplitMix64;
use serde_json::Value as Json;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const SEED: u64 = 0x37_0005;
/// `MARGINS_FUZZ_SEED`, `MARGINS_FUZZ_CLI_CASES` and `MARGINS_FUZZ_TABLE_CASES` override
/// these to explore further.
const CLI_CASES: usize = 60;
const TABLE_CASES: usize = 8;
const WORKERS: usize = 2;
/// One case may take this long before it counts as a hang (a loaded machine included).
const CASE_LIMIT: Duration = Duration::from_secs(300);
const FIXTURE: &str = "tests/scenarios/margins/rigid-pd.toml";
const DURATION_S: f64 = 20.0;

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// One of `xs`.
fn pick<'a>(rng: &mut SplitMix64, xs: &[&'a str]) -> &'a str {
    xs[rng.below(xs.len())]
}

/// Log-uniform in `[lo, hi]`.
fn log_uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    (rng.range(lo.ln(), hi.ln())).exp()
}

/// A flag's valid value.
fn valid_value(rng: &mut SplitMix64, flag: &str) -> String {
    match flag {
        "--at" => format!("{}", rng.range(0.0, DURATION_S)),
        "--grid-points" => format!("{}", 5 + rng.below(26)),
        "--threads" => format!("{}", 1 + rng.below(4)),
        "--amplitude-rad" => format!("{:e}", log_uniform(rng, 1e-6, 1e-2)),
        "--crossover-hint" => format!("{:e}", log_uniform(rng, 1e-5, 31.4)),
        "--loop" => pick(rng, &["input", "input", "output"]).into(),
        "--method" => pick(rng, &["auto", "closed", "open"]).into(),
        _ => format!("{}", log_uniform(rng, 1e6, 1.2e7).round()),
    }
}

/// A flag's value at or just past a bound of its range (one draw in three), or absurd.
fn bad_value(rng: &mut SplitMix64, flag: &str) -> String {
    let absurd = ["-1", "0", "NaN", "inf", "-inf", "1e300", "abc", "", "18446744073709551616"];
    if rng.below(3) != 0 {
        return pick(rng, &absurd).into();
    }
    match flag {
        "--at" => pick(rng, &["0", "20", "20.000001", "-0", "1e-320", "19.99"]),
        "--grid-points" => pick(rng, &["4", "5", "19", "20", "400", "401", "1e9", "1000000000"]),
        "--threads" => pick(rng, &["0", "1", "64", "65", "5000"]),
        "--amplitude-rad" => pick(rng, &["9.9e-7", "1e-6", "1e-2", "0.0101", "-1e-4"]),
        "--crossover-hint" => pick(rng, &["31.4159", "31.5", "6.5e-6", "30", "0.77"]),
        "--loop" => pick(rng, &["sideways", "INPUT"]),
        "--method" => pick(rng, &["both", "Closed"]),
        _ => pick(rng, &["0", "1", "-5", "1e30", "99999999999999999999"]),
    }
    .into()
}

const FLAGS: [&str; 7] =
    ["--at", "--grid-points", "--threads", "--amplitude-rad", "--crossover-hint", "--loop", "--method"];

/// The fixtures of the flag cases: (name, edits to the reference loop).
const FIXTURES: [(&str, &[(&str, &str)]); 3] = [
    ("nominal", &[]),
    (
        "unstable",
        &[
            ("k_diag_nm = [5.0, 6.0, 7.5]", "k_diag_nm = [50.0, 60.0, 75.0]"),
            ("d_diag_nms = [7.0, 8.4, 10.5]", "d_diag_nms = [70.0, 84.0, 105.0]"),
            ("torque_limit_nm = [50.0, 50.0, 50.0]", "torque_limit_nm = [500.0, 500.0, 500.0]"),
            ("inertia_kgm2 = 0.01", "inertia_kgm2 = 0.01\ntorque_delay_s = 0.2"),
        ],
    ),
    (
        "tiny-rotors",
        &[
            ("max_torque_nm = 5.0", "max_torque_nm = 0.05"),
            ("inertia_kgm2 = 0.01", "inertia_kgm2 = 0.000001"),
            ("dynamics_substeps = 20 ", "dynamics_substeps = 320 "),
        ],
    ),
];

/// The arguments of one `sim-host margins` case after the scenario, the fixture first:
/// each flag present (one in two) with a valid value, `--no-refine` one in two, a
/// plant-step budget always; then in three cases of five one flag (the budget too) drawn
/// at a bound or absurd instead.
fn cli_case(rng: &mut SplitMix64) -> Vec<String> {
    let fixture = match rng.below(10) {
        0..7 => 0,
        7..9 => 1,
        _ => 2,
    };
    let mut flags: Vec<(&str, String)> = Vec::new();
    for flag in FLAGS {
        if rng.below(2) == 0 {
            flags.push((flag, valid_value(rng, flag)));
        }
    }
    flags.push(("--max-plant-steps", valid_value(rng, "--max-plant-steps")));
    if rng.below(5) < 3 {
        let all: Vec<&str> = FLAGS.iter().copied().chain(["--max-plant-steps"]).collect();
        let flag = pick(rng, &all);
        let value = bad_value(rng, flag);
        flags.retain(|f| f.0 != flag);
        flags.push((flag, value));
    }
    let mut args = vec![FIXTURES[fixture].0.to_string()];
    args.extend(flags.iter().map(|(f, v)| format!("{f}={v}")));
    if rng.below(2) == 0 {
        args.push("--no-refine".into());
    }
    args
}

/// A `[margins]` table: each key valid, past a bound or absurd (a wrong TOML type too),
/// sometimes an unknown key.
fn table_case(rng: &mut SplitMix64) -> String {
    let mut t = String::from("[margins]\n");
    if rng.below(10) < 7 {
        let v = match rng.below(10) {
            0..5 => format!("{:.3}", rng.range(0.0, DURATION_S)),
            5..7 => pick(rng, &["0.0", "20.0", "20.001", "-0.5"]).into(),
            _ => pick(rng, &["nan", "inf", "-inf", "1e300", "\"soon\"", "[1.0]", "true"]).into(),
        };
        t += &format!("at_s = {v}\n");
    }
    if rng.below(10) < 7 {
        let v = match rng.below(10) {
            0..5 => format!("{}", 5 + rng.below(16)),
            5..7 => pick(rng, &["4", "5", "401"]).into(),
            _ => pick(rng, &["0", "-3", "1000000000", "3.5", "\"many\"", "nan"]).into(),
        };
        t += &format!("grid_points = {v}\n");
    }
    if rng.below(10) < 5 {
        t += &format!("loop = {}\n", pick(rng, &["\"input\"", "\"output\"", "\"sideways\"", "1"]));
    }
    if rng.below(10) == 0 {
        t += "threads = 5000\n";
    }
    t
}

#[derive(Debug)]
enum Outcome {
    /// The refusal's first words (printed).
    #[allow(dead_code)]
    Refused(String),
    Measured,
    Failed,
}

/// Runs `sim-host ARGS` in `dir` within [`CASE_LIMIT`]: (exit status, stderr).
fn run(dir: &Path, args: &[String]) -> Result<(Option<i32>, String), String> {
    let err_path = dir.join("stderr.txt");
    let mut child = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&err_path).unwrap())
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
            return Err(format!("no answer within {CASE_LIMIT:?}"));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    Ok((status.code(), std::fs::read_to_string(&err_path).unwrap_or_default()))
}

/// The closed form of the loop broken at `point` (module doc): (phase margin, deg;
/// crossover, rad/s). Output: `L = ωn²/(s(s + 2ζωn))`, ωn = 0.5, ζ = 0.7, `ωc² =
/// (√(4ζ⁴ωn⁴ + ωn⁴) − 2ζ²ωn²)`, `PM = 90° − atan(ωc / 2ζωn)` (the 10 Hz hold's `ωc T/2`,
/// 0.9°, is inside the tolerance); input: the measured reference (tests/tests/margins.rs
/// checks it against `loop_reference::AxisLoop` to 1 %).
fn closed_form(point: &str) -> (f64, f64) {
    if point == "output" {
        let (wn, z) = (0.5f64, 0.7f64);
        let wc = ((4.0 * z.powi(4) * wn.powi(4) + wn.powi(4)).sqrt() - 2.0 * z * z * wn * wn).sqrt();
        (90.0 - (wc / (2.0 * z * wn)).atan().to_degrees(), wc)
    } else {
        (63.0, 0.772)
    }
}

/// Phase margin within 5° and crossover within 10 % of [`closed_form`].
fn close_to(point: &str, pm: Option<f64>, wc: Option<f64>) -> bool {
    let (pm_ref, wc_ref) = closed_form(point);
    pm.is_some_and(|p| (p - pm_ref).abs() <= 5.0) && wc.is_some_and(|w| (w / wc_ref - 1.0).abs() <= 0.1)
}

/// A measured stable loop's figures are this loop's (module doc).
fn figures_of_this_loop(m: &Json) -> Result<(), String> {
    if m["stable"] != true {
        return Err(format!("exit 0 but stable = {}", m["stable"]));
    }
    let point = m["loop"].as_str().unwrap_or("?");
    for a in m["axes"].as_array().into_iter().flatten() {
        let (pm, wc) = (a["phase_margin_deg"].as_f64(), a["crossover_rad_s"].as_f64());
        if !close_to(point, pm, wc) {
            return Err(format!("exit 0 with {point} axis {}: PM {pm:?} deg, crossover {wc:?} rad/s", a["axis"]));
        }
    }
    let alpha = m["multiloop_disk_margin"]["alpha"].as_f64();
    if !alpha.is_some_and(|x| x > 0.0 && x <= 2.0) {
        return Err(format!("exit 0 with multiloop alpha {alpha:?}"));
    }
    Ok(())
}

/// The fixture `name` ([`FIXTURES`]) written into `dir`.
fn fixture(dir: &Path, name: &str) -> PathBuf {
    let mut text = std::fs::read_to_string(repo().join(FIXTURE)).unwrap();
    let edits = FIXTURES.iter().find(|f| f.0 == name).unwrap().1;
    for (from, to) in edits {
        assert!(text.contains(from), "{from}");
        text = text.replace(from, to);
    }
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

fn judge_cli(dir: &Path, case: &[String]) -> Result<Outcome, String> {
    let (name, args) = (&case[0], &case[1..]);
    let out = dir.join("m");
    let _ = std::fs::remove_dir_all(&out);
    let mut full = vec!["margins".to_string(), fixture(dir, name).display().to_string(), "--no-plots".into()];
    full.extend(["--out".to_string(), "m".to_string()]);
    full.extend(args.iter().cloned());
    let (code, err) = run(dir, &full)?;
    let json: Option<Json> = std::fs::read(out.join("margins.json"))
        .ok()
        .map(|b| serde_json::from_slice(&b).map_err(|e| e.to_string()))
        .transpose()?;
    let err = err.trim().to_string();
    match code {
        Some(2) => {
            let named = FLAGS.iter().chain(&["--max-plant-steps", "--no-refine"]).any(|f| err.contains(f));
            match (named, &json) {
                (true, None) => Ok(Outcome::Refused(err.lines().next().unwrap_or("").chars().take(90).collect())),
                (false, _) => Err(format!("exit 2 naming no flag of the case: {err}")),
                (true, Some(_)) => Err(format!("exit 2 beside a margins.json: {err}")),
            }
        }
        Some(0) if name != "nominal" => Err(format!("exit 0 on the {name} fixture")),
        Some(0) => {
            figures_of_this_loop(json.as_ref().ok_or("exit 0 without margins.json")?).map(|()| Outcome::Measured)
        }
        Some(3) if ["not a steady hold", "unstable", "negative"].iter().any(|w| err.contains(w)) => {
            match json.as_ref().map(|m| m["stable"].clone()) {
                None | Some(Json::Bool(false)) => Ok(Outcome::Failed),
                Some(s) => Err(format!("exit 3 beside margins.json stable = {s}")),
            }
        }
        other => Err(format!("exit {other:?}: {err}")),
    }
}

fn judge_table(dir: &Path, table: &str) -> Result<Outcome, String> {
    let text = std::fs::read_to_string(repo().join(FIXTURE)).unwrap();
    std::fs::write(dir.join("s.toml"), format!("{text}\n{table}")).unwrap();
    let _ = std::fs::remove_dir_all(dir.join("o"));
    let args: Vec<String> = ["run", "s.toml", "--out", "o", "--no-plots", "--quiet"].map(String::from).to_vec();
    let (code, err) = run(dir, &args)?;
    let summary: Option<Json> =
        std::fs::read(dir.join("o/summary.json")).ok().and_then(|b| serde_json::from_slice(&b).ok());
    let keys = ["at_s", "grid_points", "loop", "threads"];
    match (code, &summary) {
        (Some(1), None) if keys.iter().any(|k| err.contains(k) && table.contains(k)) => {
            Ok(Outcome::Refused(err.lines().next().unwrap_or("").chars().take(90).collect()))
        }
        (Some(1), _) => Err(format!("exit 1 naming no key of the table: {}", err.trim())),
        (Some(0), Some(s)) if s["run_status"] == "ok" && s["margins"]["status"] == "measured" => {
            let m = &s["margins"];
            let (pm, wc) = (m["phase_margin_deg"].as_f64(), m["crossover_rad_s"].as_f64());
            if close_to(m["loop"].as_str().unwrap_or("?"), pm, wc) {
                Ok(Outcome::Measured)
            } else {
                Err(format!("exit 0 with PM {pm:?}, crossover {wc:?}"))
            }
        }
        (Some(3), Some(s))
            if s["run_status"] == "margins_failed"
                && ["not_steady", "unstable"].contains(&s["margins"]["status"].as_str().unwrap_or("")) =>
        {
            Ok(Outcome::Failed)
        }
        (other, s) => Err(format!(
            "exit {other:?}, run_status {:?}, margins {:?}: {}",
            s.as_ref().map(|s| s["run_status"].clone()),
            s.as_ref().map(|s| s["margins"].clone()),
            err.trim()
        )),
    }
}

/// A judged case: its index, the verdict, its wall time in s.
type Judged = (usize, Result<Outcome, String>, f64);

#[test]
fn margins_flags_and_keys_are_refused_measured_or_failed_never_nonsense() {
    let mut rng = SplitMix64(env_or("MARGINS_FUZZ_SEED", SEED));
    let mut cases: Vec<(bool, Vec<String>)> =
        (0..env_or("MARGINS_FUZZ_CLI_CASES", CLI_CASES)).map(|_| (true, cli_case(&mut rng))).collect();
    cases.extend((0..env_or("MARGINS_FUZZ_TABLE_CASES", TABLE_CASES)).map(|_| (false, vec![table_case(&mut rng)])));
    let start = Instant::now();
    let tmp = tempfile::tempdir().unwrap();
    let results: Vec<Judged> = run_cases(&cases, WORKERS, tmp.path(), |(cli, case), dir| {
        let t0 = Instant::now();
        let r = if *cli { judge_cli(dir, case) } else { judge_table(dir, &case[0]) };
        (r, t0.elapsed().as_secs_f64())
    })
    .into_iter()
    .map(|(i, (r, secs))| (i, r, secs))
    .collect();
    let mut bad = Vec::new();
    let mut counts = [0usize; 3];
    for (i, r, secs) in &results {
        let (cli, case) = &cases[*i];
        let what = if *cli { case.join(" ") } else { case[0].replace('\n', "; ") };
        match r {
            Ok(o) => {
                counts[match o {
                    Outcome::Refused(_) => 0,
                    Outcome::Measured => 1,
                    Outcome::Failed => 2,
                }] += 1;
                eprintln!("case {i:>3} ({secs:>5.1} s) {o:?}: {what}");
            }
            Err(e) => bad.push(format!("case {i} ({}): {what}\n    {e}", if *cli { "margins" } else { "[margins]" })),
        }
    }
    eprintln!(
        "{} cases in {:.1} s: {} refused naming the flag or key, {} measured, {} failed with a status",
        results.len(),
        start.elapsed().as_secs_f64(),
        counts[0],
        counts[1],
        counts[2]
    );
    assert!(bad.is_empty(), "{} of {} cases misbehaved:\n{}", bad.len(), results.len(), bad.join("\n"));
    assert!(counts[1] > 0 && counts[0] > 0, "the draws must both refuse and measure: {counts:?}");
}
