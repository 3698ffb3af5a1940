//! Issue 37, finding 5: the `sim-host margins` flags are checked as the scenario's
//! `[margins]` keys are, by the same checks (`sim_core::scenario::margin_check`): the
//! issue's cases each exit with the command line's status for a refused flag (2), naming
//! the flag and writing nothing, instead of infinite margins, a hang or an abort; an
//! operating point at t = 0 is settle-checked like any other; a hint that puts the grid
//! above the crossover is refused; `[margins]` keys are refused by `sim-host run` and
//! `sim-host check` naming the key (exit 1, a scenario error).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

const RIGID_PD: &str = "tests/scenarios/margins/rigid-pd.toml";

/// `sim-host ARGS` in `dir`, with the wall time it took.
fn sim_host(dir: &Path, args: &[&str]) -> (Output, Duration) {
    let start = Instant::now();
    let o = Command::new(env!("CARGO_BIN_EXE_sim-host")).args(args).current_dir(dir).output().expect("sim-host");
    (o, start.elapsed())
}

/// `sim-host margins SCENARIO --no-plots --out DIR EXTRA…`.
fn margins(dir: &Path, scenario: &Path, extra: &[&str]) -> (Output, Duration) {
    let mut args = vec!["margins", scenario.to_str().unwrap(), "--no-plots", "--out", "m"];
    args.extend_from_slice(extra);
    sim_host(dir, &args)
}

/// Every case of the issue: exit status 2, the flag and the value named on stderr, no
/// `margins.json`, and an end (the refusals come before any flight but the unrefined
/// grid's, which comes after the pilot sweep, and the hint's, after the grid's 20
/// frequencies: 2 s alone here; the bound of 10 min only tells a hang from a loaded
/// machine).
#[test]
fn every_flag_the_issue_names_is_refused_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let sc = repo().join(RIGID_PD);
    let cases: [(&[&str], &str); 16] = [
        (&["--crossover-hint", "-1"], "--crossover-hint"),
        (&["--crossover-hint=-1"], "--crossover-hint"),
        (&["--crossover-hint", "NaN"], "--crossover-hint"),
        (&["--crossover-hint", "0"], "--crossover-hint"),
        (&["--crossover-hint", "30", "--grid-points", "20", "--no-refine"], "--crossover-hint 30"),
        (&["--crossover-hint", "1e-9"], "--crossover-hint 1e-9"),
        (&["--grid-points", "0"], "--grid-points"),
        (&["--grid-points", "1", "--no-refine"], "--grid-points"),
        (&["--grid-points", "3", "--no-refine"], "--grid-points"),
        (&["--grid-points", "12", "--no-refine"], "--grid-points 12"),
        (&["--grid-points", "1e9"], "--grid-points"),
        (&["--grid-points", "1000000000"], "--grid-points"),
        (&["--at", "1e300"], "--at 1e300"),
        (&["--threads", "5000"], "--threads"),
        (&["--amplitude-rad", "0"], "--amplitude-rad"),
        (&["--max-plant-steps", "0"], "--max-plant-steps"),
    ];
    for (args, flag) in cases {
        let (o, took) = margins(tmp.path(), &sc, args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        eprintln!("{args:?}: exit {:?} in {:.2} s: {}", o.status.code(), took.as_secs_f64(), stderr.trim());
        assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(flag), "{args:?}: the refusal must name {flag}: {stderr}");
        assert!(!tmp.path().join("m/margins.json").exists(), "{args:?}: a refused measurement wrote margins.json");
        assert!(took < Duration::from_secs(600), "{args:?}: {took:?}");
    }
}

/// `--at 0` flies no step: the settle check reads the initial state (paper 000 test 1
/// starts 37.8° from its target), exit 3; on the rigid-PD fixture, at rest on its target
/// from t = 0, the same operating point is a steady hold and is measured.
#[test]
fn an_operating_point_at_t_0_is_settle_checked() {
    let tmp = tempfile::tempdir().unwrap();
    let (o, _) = margins(tmp.path(), &repo().join("scenarios/paper000/test1.toml"), &["--at", "0"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("above the settle bound") && stderr.contains("t = 0.000 s"), "{stderr}");
    let (o, _) = margins(tmp.path(), &repo().join(RIGID_PD), &["--at", "0", "--grid-points", "20", "--no-refine"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(tmp.path().join("m/margins.json")).unwrap()).unwrap();
    assert_eq!((m["at_s"].as_f64(), m["stable"].as_bool()), (Some(0.0), Some(true)));
}

/// `[margins]` keys out of range: `sim-host run` and `sim-host check` refuse the scenario
/// naming the key (exit 1), before flying.
#[test]
fn margins_keys_are_refused_naming_the_key() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join(RIGID_PD)).unwrap();
    for (table, key) in [
        ("grid_points = 3", "margins.grid_points"),
        ("grid_points = 1000000000", "margins.grid_points"),
        ("at_s = 1e300", "margins.at_s"),
        ("at_s = -1.0", "margins.at_s"),
        ("at_s = nan", "margins.at_s"),
        ("loop = \"sideways\"", "loop"),
        ("threads = 5000", "threads"),
    ] {
        std::fs::write(tmp.path().join("s.toml"), format!("{text}\n[margins]\n{table}\n")).unwrap();
        for cmd in [&["run", "s.toml", "--out", "o", "--no-plots", "--quiet"][..], &["check", "s.toml"]] {
            let (o, _) = sim_host(tmp.path(), cmd);
            let stderr = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(1), "{table} ({}): {stderr}", cmd[0]);
            assert!(stderr.contains(key), "{table} ({}): {stderr}", cmd[0]);
        }
        assert!(!tmp.path().join("o/summary.json").exists(), "{table}: flown");
    }
}

/// The unrefined grid's spacing rule (`margin_check::unrefined_spacing`), checked once the
/// pilot has fixed the grid's span: on the reference loop (pilot crossover estimate
/// 0.80 rad/s, grid from 0.0267 rad/s to π/T = 31.4 rad/s, 1176×) the closed form
/// `1176^(1/(n−1)) ≤ 1.5` needs n ≥ 19: 18 points (1.52× apart) are refused naming the
/// flag and the count needed, 19 points (1.48×) are measured, within the 1.5° the doc
/// states of the refined phase margin 62.98° (measured: 61.86°, α 1.142 against 1.1194)
/// and the multiloop α within 5 % of the refined 1.1194 (docs/margins.md).
#[test]
fn the_unrefined_grid_spacing_is_checked_once_the_pilot_fixes_its_span() {
    let tmp = tempfile::tempdir().unwrap();
    let sc = repo().join(RIGID_PD);
    let (o, _) = margins(tmp.path(), &sc, &["--grid-points", "18", "--no-refine"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--grid-points 18: with --no-refine") && stderr.contains("at least 19 points"), "{stderr}");
    assert!(!tmp.path().join("m/margins.json").exists());
    let (o, _) = margins(tmp.path(), &sc, &["--grid-points", "19", "--no-refine"]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(tmp.path().join("m/margins.json")).unwrap()).unwrap();
    assert_eq!(m["stable"], true);
    for a in m["axes"].as_array().unwrap() {
        let pm = a["phase_margin_deg"].as_f64().unwrap();
        assert!((pm - 62.98).abs() < 1.5, "axis {}: PM {pm}", a["axis"]);
    }
    let alpha = m["multiloop_disk_margin"]["alpha"].as_f64().unwrap();
    assert!((alpha / 1.1194 - 1.0).abs() < 0.05, "multiloop alpha {alpha}");
}
