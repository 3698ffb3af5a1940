//! The time-series outputs of `sim-host run` (docs/outputs.md): `timeseries.parquet` (the
//! default) and `timeseries.csv` (`--format csv`) of the same run hold the same values
//! bit for bit, the Parquet file carries the units and the run's metadata, and every
//! column of every shipped scenario has a unit.

use sim_core::recorder::columns::unit;
use sim_core::recorder::output::{Equality, first_difference_by, read_run};
use sim_core::recorder::parquet::FORMAT_VERSION;
use sim_core::scenario::{Resolved, Scenario};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn run(scenario: &Path, out: &Path, format: &str) {
    let r = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(["run", scenario.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-plots", "--quiet"])
        .args(["--link", "in-process", "--format", format])
        .output()
        .unwrap();
    assert_eq!(r.status.code(), Some(0), "{}: {}", scenario.display(), String::from_utf8_lossy(&r.stderr));
}

/// Three cheap shipped scenarios (a CMG test, the open-loop rig with its environment
/// torques, the cubesat mission with modes and NaN estimation columns while the filter
/// starts): the CSV, parsed with `str::parse::<f64>` (empty = NaN), equals the Parquet
/// file bit for bit.
#[test]
fn parquet_and_csv_of_a_run_hold_the_same_bits() {
    let tmp = tempfile::tempdir().unwrap();
    for sc in ["paper000/test1.toml", "paper003/rig-open-loop.toml", "modes/cubesat-mission.toml"] {
        let path = repo().join("scenarios").join(sc);
        let (pq, csv) = (tmp.path().join("pq"), tmp.path().join("csv"));
        run(&path, &pq, "parquet");
        run(&path, &csv, "csv");
        assert!(!pq.join("timeseries.csv").exists() && !csv.join("timeseries.parquet").exists());
        let (a, b) = (read_run(&pq).unwrap(), read_run(&csv).unwrap());
        assert!(a.series.len() > 100, "{sc}");
        assert_eq!(first_difference_by(&a.series, &b.series, Equality::of(&a, &b)), None, "{sc}");
        // The CSV's empty fields are exactly the Parquet file's non-finite values.
        for (x, y) in a.series.cols.iter().zip(&b.series.cols) {
            assert!(x.iter().zip(y).all(|(p, q)| p.is_finite() == q.is_finite()), "{sc}");
        }
        // In-process runs measure no step cost: NaN in every row.
        assert!(a.series.col("step_cost_insns").unwrap().iter().all(|x| x.is_nan()), "{sc}");
        if sc.starts_with("modes") {
            assert!(a.series.col("est_error_deg").unwrap().iter().any(|x| x.is_nan()), "{sc}: no NaN");
        }
        check_metadata(&a.metadata, &path, &a.series.names);
    }
}

fn check_metadata(kv: &BTreeMap<String, String>, path: &Path, names: &[String]) {
    let sc = Scenario::load(path).unwrap();
    assert_eq!(kv["scenario"], sc.name);
    assert_eq!(kv["scenario_path"], path.display().to_string());
    assert_eq!(kv["seed"], sc.sensors.seed.to_string());
    assert_eq!(kv["scenario_toml"], std::fs::read_to_string(path).unwrap());
    assert_eq!(kv["protocol_version"], acs_flight::link::PROTOCOL_VERSION.to_string());
    assert_eq!(kv["format_version"], FORMAT_VERSION.to_string());
    let units: BTreeMap<String, String> = serde_json::from_str(&kv["units"]).unwrap();
    assert_eq!(units.len(), names.len());
    for n in names {
        assert!(!units[n].is_empty(), "{n}: no unit");
    }
}

/// Every column of every shipped scenario has a unit (or the explicit "1").
#[test]
fn every_column_of_every_shipped_scenario_has_a_unit() {
    let mut scenarios = 0;
    for dir in std::fs::read_dir(repo().join("scenarios")).unwrap() {
        for f in std::fs::read_dir(dir.unwrap().path()).unwrap() {
            let path = f.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                let sc = Scenario::load(&path).unwrap();
                let layout = Resolved::try_from(&sc).unwrap().layout;
                for name in layout.names() {
                    assert!(unit(&name).is_some(), "{}: column {name} has no unit", path.display());
                }
                scenarios += 1;
            }
        }
    }
    assert!(scenarios >= 30, "{scenarios} scenarios");
}

/// `sim-host ARGS` in `dir`: (exit status, stderr).
fn sim_host_in(dir: &Path, args: &[&str]) -> (Option<i32>, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_sim-host")).args(args).current_dir(dir).output().unwrap();
    (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// The reference margins loop, and the same loop with rotors so light that every
/// experiment spins them to their speed limit (refused, exit 3: issue 37, finding 4).
fn margins_fixtures(dir: &Path) -> (PathBuf, PathBuf) {
    let text = std::fs::read_to_string(repo().join("tests/scenarios/margins/rigid-pd.toml")).unwrap();
    let tiny = text
        .replace("max_torque_nm = 5.0", "max_torque_nm = 0.05")
        .replace("inertia_kgm2 = 0.01", "inertia_kgm2 = 0.000001")
        .replace("dynamics_substeps = 20 ", "dynamics_substeps = 320 ");
    assert_ne!(tiny, text);
    let (a, b) = (dir.join("nominal.toml"), dir.join("tiny.toml"));
    std::fs::write(&a, format!("{text}\n[margins]\ngrid_points = 5\n")).unwrap();
    std::fs::write(&b, format!("{tiny}\n[margins]\ngrid_points = 5\n")).unwrap();
    (a, b)
}

const MARGIN_OUTPUTS: [&str; 4] = ["margins.json", "bode.png", "nyquist.png", "disk.png"];

/// Issue 37, finding 6: a re-run into the same directory first removes the previous run's
/// margins outputs, so a refused measurement (exit 3) leaves no `margins.json` saying
/// `stable: true` beside it — for `sim-host margins` and for `sim-host run` with
/// `[margins]`; and a run without `[margins]` removes them too.
#[test]
fn a_rerun_leaves_no_previous_margins_outputs() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let (nominal, tiny) = margins_fixtures(d);
    let (n, t) = (nominal.to_str().unwrap(), tiny.to_str().unwrap());
    let present = |dir: &str| MARGIN_OUTPUTS.iter().filter(|f| d.join(dir).join(f).exists()).count();
    assert_eq!(sim_host_in(d, &["margins", n, "--out", "m"]).0, Some(0));
    assert_eq!(present("m"), 4);
    // A killed measurement's temporaries go with the outputs; a user's file stays.
    let stale = [".margins.json.tmp-4242-ThreadId(2)", ".bode.png.tmp-4242-ThreadId(3)"];
    for f in stale.iter().chain(&["notes.txt"]) {
        std::fs::write(d.join("m").join(f), b"x").unwrap();
    }
    let (code, stderr) = sim_host_in(d, &["margins", t, "--out", "m"]);
    assert_eq!(code, Some(3), "{stderr}");
    assert_eq!(present("m"), 0, "{stderr}");
    assert!(stale.iter().all(|f| !d.join("m").join(f).exists()), "stale temporaries left");
    assert!(d.join("m/notes.txt").exists(), "a file no run wrote was removed");

    assert_eq!(sim_host_in(d, &["run", n, "--out", "r", "--quiet"]).0, Some(0));
    assert_eq!(present("r"), 4);
    let (code, stderr) = sim_host_in(d, &["run", t, "--out", "r", "--quiet", "--no-plots"]);
    assert_eq!(code, Some(3), "{stderr}");
    assert_eq!(present("r"), 0, "{stderr}");
    let s: serde_json::Value = serde_json::from_slice(&std::fs::read(d.join("r/summary.json")).unwrap()).unwrap();
    assert_eq!(
        (s["run_status"].as_str(), s["margins"]["status"].as_str()),
        (Some("margins_failed"), Some("not_steady"))
    );
    assert_eq!(sim_host_in(d, &["run", n, "--out", "r", "--quiet"]).0, Some(0));
    let plain = repo().join("scenarios/paper000/test1.toml");
    assert_eq!(sim_host_in(d, &["run", plain.to_str().unwrap(), "--out", "r", "--quiet", "--no-plots"]).0, Some(0));
    assert_eq!(present("r"), 0);

    // An error clearing or writing an output names that file, not the directory.
    std::fs::create_dir_all(d.join("m/margins.json/x")).unwrap();
    let (code, stderr) = sim_host_in(d, &["margins", n, "--out", "m"]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("m/margins.json"), "{stderr}");
}

/// Issue 37, finding 6: `margins.json` is written whole or not at all. A write that fails
/// part way — here at the file-size limit (`ulimit -f 8`, 4 KiB, with SIGXFSZ ignored so
/// that the write returns EFBIG where a full disk returns ENOSPC) — leaves no
/// `margins.json` (written in place, the first 4 KiB of it stayed under its final name)
/// and no temporary, and exits 1 with an error naming the file. The limit is under the
/// file's size, which the unlimited run before it measures.
#[test]
fn a_margins_json_that_cannot_be_written_whole_is_not_left_half_written() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let (nominal, _) = margins_fixtures(d);
    let args = ["margins", nominal.to_str().unwrap(), "--out", "m", "--no-plots", "--grid-points", "20", "--no-refine"];
    assert_eq!(sim_host_in(d, &args).0, Some(0));
    let size = std::fs::metadata(d.join("m/margins.json")).unwrap().len();
    assert!(size > 8 * 1024, "margins.json is {size} bytes: the 4 KiB limit must cut it");
    let o = Command::new("/bin/sh")
        .args(["-c", "trap '' XFSZ; ulimit -f 8 && exec \"$0\" \"$@\"", env!("CARGO_BIN_EXE_sim-host")])
        .args(args)
        .current_dir(d)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    eprintln!("margins.json: {size} bytes; under a 4 KiB limit: exit {:?}, {}", o.status.code(), stderr.trim());
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("writing m/margins.json"), "the error must name the file: {stderr}");
    let left: Vec<String> =
        std::fs::read_dir(d.join("m")).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    assert!(left.is_empty(), "a failed write left {left:?}");
}

/// A run killed by SIGKILL (as by SIGINT: no destructor runs) leaves its hidden
/// `.timeseries.parquet.tmp-…`; the next run into the directory removes it.
#[test]
fn a_killed_runs_temporary_is_removed_by_the_next_run() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("k");
    let long = repo().join("scenarios/modes/cubesat-two-weeks.toml");
    let temporaries = || -> Vec<String> {
        std::fs::read_dir(&out)
            .map(|d| d.filter_map(|e| e.ok()?.file_name().into_string().ok()).filter(|n| n.contains(".tmp-")).collect())
            .unwrap_or_default()
    };
    let mut child = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(["run", long.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-plots", "--quiet"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while temporaries().is_empty() && start.elapsed().as_secs() < 300 {
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let left = temporaries();
    assert!(left.iter().any(|n| n.starts_with(".timeseries.parquet.tmp-")), "{left:?}");
    let short = repo().join("scenarios/paper000/test1.toml");
    assert_eq!(
        sim_host_in(tmp.path(), &["run", short.to_str().unwrap(), "--out", "k", "--quiet", "--no-plots"]).0,
        Some(0)
    );
    assert_eq!(temporaries(), Vec::<String>::new());
    assert!(out.join("timeseries.parquet").exists());
}

/// A one-column Parquet file of `values` ([`sim_core::recorder::parquet::ParquetStream`]).
fn parquet_of(path: &Path, values: &[f64]) {
    let names = ["t_s".to_string(), "v".to_string()];
    let mut w = sim_core::recorder::parquet::ParquetStream::new(Vec::new(), &names, Vec::new()).unwrap();
    for (i, v) in values.iter().enumerate() {
        w.push_row(&[i as f64, *v]).unwrap();
    }
    std::fs::write(path, w.finish().unwrap()).unwrap();
}

/// `sim-host compare-series`: equal only bit for bit, any two NaNs equal whatever their
/// payload, NaN ≠ ±∞, +∞ ≠ −∞; against a CSV, whose empty field is NaN or ±∞, an empty
/// field matches any non-finite value (docs/outputs.md).
#[test]
fn compare_series_is_bit_for_bit_with_the_stated_nan_rule() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let payload = f64::from_bits(0x7ff8_dead_beef_0001);
    let (inf, nan) = (f64::INFINITY, f64::NAN);
    let compare = |a: &[f64], b: &[f64]| {
        parquet_of(&d.join("a.parquet"), a);
        parquet_of(&d.join("b.parquet"), b);
        sim_host_in(d, &["compare-series", "a.parquet", "b.parquet"]).0
    };
    assert_eq!(compare(&[1.0, nan, -inf], &[1.0, payload, -inf]), Some(0));
    assert_eq!(compare(&[1.0, nan], &[1.0, inf]), Some(1), "NaN against +inf");
    assert_eq!(compare(&[inf], &[-inf]), Some(1));
    assert_eq!(compare(&[0.0], &[-0.0]), Some(1));
    assert_eq!(compare(&[0.3], &[0.1 + 0.2]), Some(1));
    std::fs::write(d.join("c.csv"), "t_s,v\n0,\n1,2\n").unwrap();
    for (other, want) in [([inf, 2.0], Some(0)), ([nan, 2.0], Some(0)), ([-inf, 2.0], Some(0)), ([0.0, 2.0], Some(1))] {
        parquet_of(&d.join("p.parquet"), &other);
        assert_eq!(sim_host_in(d, &["compare-series", "c.csv", "p.parquet"]).0, want, "{other:?}");
    }
}
