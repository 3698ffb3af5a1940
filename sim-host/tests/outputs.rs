//! The time-series outputs of `sim-host run` (docs/outputs.md): `timeseries.parquet` (the
//! default) and `timeseries.csv` (`--format csv`) of the same run hold the same values
//! bit for bit, the Parquet file carries the units and the run's metadata, and every
//! column of every shipped scenario has a unit.

use sim_core::recorder::columns::unit;
use sim_core::recorder::output::{first_difference, read_run};
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
        assert_eq!(first_difference(&a.series, &b.series), None, "{sc}");
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
