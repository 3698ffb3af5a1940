//! No silent wrong result (issue 21, items 1, 6, 7): a run whose state or flight command
//! turns non-finite stops there, says `diverged` in summary.json and exits 3; a run whose
//! every step the flight code refused says `all_refused` and exits 3; campaigns count such
//! runs against every requirement and refuse at planning what could only fail later; one
//! runner per campaign shard; a failed re-run leaves no stale output; I/O errors name
//! their file.

use acs_flight::link::status::BAD_INPUT;
use acs_flight::link::{StepReport, status};
use sim_core::link::tap::{Tap, Tapped};
use sim_core::link::{self, LinkKind, LinkOptions};
use sim_core::recorder::summary::{Failure, RunStatus as Status};
use sim_core::runner;
use sim_core::scenario::Scenario;
use sim_host::campaign::lock::ShardLock;
use sim_host::campaign::{self, Campaign, RunStatus, Shard};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn sim_host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sim-host"))
}

/// A shipped scenario with `from` replaced by `to` (and the duration shortened to
/// `duration_s`), written into `dir`.
fn scenario(dir: &Path, shipped: &str, from: &str, to: &str, duration_s: f64) -> PathBuf {
    let text = std::fs::read_to_string(repo().join(shipped)).unwrap();
    assert!(text.contains(from), "{shipped}: {from}");
    let mut out = String::new();
    for line in text.replacen(from, to, 1).lines() {
        if line.starts_with("duration_s") {
            out += &format!("duration_s = {duration_s:?}\n");
        } else {
            out += line;
            out.push('\n');
        }
    }
    static N: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let p = dir.join(format!("sc{}.toml", N.fetch_add(1, std::sync::atomic::Ordering::Relaxed)));
    std::fs::write(&p, out).unwrap();
    p
}

fn run_cli(sc: &Path, out: &Path, plots: bool) -> Output {
    let mut c = sim_host();
    c.args(["run", sc.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet", "--link", "in-process"]);
    if !plots {
        c.arg("--no-plots");
    }
    c.output().unwrap()
}

fn summary_json(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

/// Every number in a JSON value (NaN and infinities cannot be JSON numbers: serde writes
/// them as null, so a non-finite statistic shows as a null, never as a small number).
fn numbers(v: &serde_json::Value, out: &mut Vec<f64>) {
    match v {
        serde_json::Value::Number(x) => out.push(x.as_f64().unwrap()),
        serde_json::Value::Array(a) => a.iter().for_each(|x| numbers(x, out)),
        serde_json::Value::Object(m) => m.values().for_each(|x| numbers(x, out)),
        _ => {}
    }
}

/// The checks of a diverged run's summary: the status, a failure at a time within the run
/// naming a quantity, and no error figure claiming the run settled.
fn assert_diverged(s: &serde_json::Value, what: &str, duration_s: f64) {
    assert_eq!(s["run_status"], "diverged", "{what}: {s}");
    let t = s["failure"]["t_s"].as_f64().unwrap();
    assert!(t > 0.0 && t <= duration_s, "{what}: t_s {t}");
    assert!(!s["failure"]["quantity"].as_str().unwrap().is_empty(), "{what}");
    assert_eq!(s["sim_time_s"].as_f64(), Some(t), "{what}: the run stops at the failure");
    for k in [
        "settle_time_s",
        "max_error_after_settle_deg",
        "final_error_deg",
        "mean_error_whole_run_deg",
        "rms_error_after_settle_deg",
        "after_settle_from_s",
        "ape_after_settle_deg",
    ] {
        assert!(s[k].is_null(), "{what}: {k} = {}", s[k]);
    }
    let mut xs = Vec::new();
    numbers(s, &mut xs);
    assert!(xs.iter().all(|x| x.is_finite()), "{what}");
}

/// The finite-but-huge inputs of the issue: each either diverges (exit 3, summary says so)
/// or is refused before the first step with exit 1 naming the key — never exit 0.
#[test]
fn huge_inputs_end_diverged_with_exit_3_or_are_refused_naming_the_key() {
    let tmp = tempfile::tempdir().unwrap();
    let cases = [
        (
            "scenarios/paper000/test3.toml",
            "rate_rad_s = [0.0, 0.0, 0.0]",
            "rate_rad_s = [1e300, 0.0, 0.0]",
            "rate_rad_s",
        ),
        (
            "scenarios/paper000/test3.toml",
            "[spacecraft]\n",
            "[spacecraft]\nexternal_torque_nm = [1e300, 0.0, 0.0]\n",
            "external_torque_nm",
        ),
        ("scenarios/estimation/mekf-hold.toml", "drag_area_m2 = 0.034", "drag_area_m2 = 1e300", "drag_area_m2"),
        (
            "scenarios/estimation/mekf-hold.toml",
            "residual_dipole_am2 = [0.0, 0.0, 0.001]",
            "residual_dipole_am2 = [0.0, 0.0, 1e300]",
            "residual_dipole_am2",
        ),
        (
            "scenarios/paper001/wheel-slew.toml",
            "initial_speed_rpm = [0.0, 0.0, 0.0, 0.0]",
            "initial_speed_rpm = [1e300, 0.0, 0.0, 0.0]",
            "initial_speed_rpm",
        ),
    ];
    for (shipped, from, to, key) in cases {
        let sc = scenario(tmp.path(), shipped, from, to, 5.0);
        let out = tmp.path().join("out");
        let r = run_cli(&sc, &out, false);
        let err = String::from_utf8_lossy(&r.stderr);
        match r.status.code() {
            Some(3) => {
                assert_diverged(&summary_json(&out), to, 5.0);
                assert!(err.contains("diverged"), "{to}: {err}");
            }
            Some(1) => assert!(err.contains(key), "{to}: refused without naming `{key}`: {err}"),
            c => panic!("{to}: exit {c:?}: {err}"),
        }
    }
}

/// Every step refused by the flight code (a gyro noise of 1e30 rad/s): exit 3, and the
/// summary says why (or the input is refused before the run, naming the key).
#[test]
fn a_run_whose_every_step_was_refused_fails_and_says_why() {
    let tmp = tempfile::tempdir().unwrap();
    let sc =
        scenario(tmp.path(), "scenarios/paper000/test3.toml", "seed = 1 ", "seed = 1\nrate_noise_rad_s = 1e30\n", 2.0);
    let out = tmp.path().join("out");
    let r = run_cli(&sc, &out, false);
    let err = String::from_utf8_lossy(&r.stderr);
    match r.status.code() {
        Some(3) => {
            let s = summary_json(&out);
            assert_eq!(s["run_status"], "all_refused", "{s}");
            assert!(s["failure"]["reason"].as_str().unwrap().contains("bad_input"), "{s}");
            assert_eq!(s["status_counts"]["bad_input"].as_u64(), Some(s["steps"].as_u64().unwrap() + 1));
            assert!(err.contains("refused"), "{err}");
        }
        Some(1) => assert!(err.contains("rate_noise_rad_s"), "{err}"),
        c => panic!("exit {c:?}: {err}"),
    }
}

/// The in-process flight code behind a telemetry tap whose hook may corrupt its step
/// reports (`hook(seq, report)`, `seq` of the frame answered): a flight computer that
/// answers NaN, or refuses everything, whatever the scenario's validation lets through.
fn fly(sc: &Scenario, hook: impl Fn(u32, &mut StepReport)) -> runner::RunResult {
    let inner = link::open(&LinkKind::InProcess, &LinkOptions::default()).unwrap();
    let mut l = Tap::new(inner, |t: Tapped<'_>| {
        if let Some(r) = t.reply() {
            hook(r.cmd.seq, r)
        }
    });
    runner::run(sc, &mut l, false).unwrap()
}

fn test3(duration_s: f64) -> Scenario {
    let mut sc = Scenario::load(&repo().join("scenarios/paper000/test3.toml")).unwrap();
    sc.duration_s = duration_s;
    sc
}

/// A NaN gimbal-rate command at step 50 (t = 0.5 s): the run stops at that step, the
/// failure names the command, the rows before it equal those of the untouched run bit for
/// bit, and the error figures do not claim the (nearly finished) slew settled.
#[test]
fn a_non_finite_flight_command_stops_the_run_at_that_step() {
    let sc = test3(2.0);
    let clean = fly(&sc, |_, _| {});
    assert_eq!(clean.summary.run_status, Status::Ok);
    assert_eq!(clean.summary.failure, None);
    let bad = fly(&sc, |seq, r| {
        if seq == 50 {
            r.cmd.gimbal_rate_cmd_rad_s[2] = f32::NAN;
        }
    });
    let s = &bad.summary;
    assert_eq!(s.run_status, Status::Diverged);
    assert_eq!(s.failure, Some(Failure::Diverged { t_s: 0.5, quantity: "command.gimbal_rate_cmd_rad_s".into() }));
    assert_eq!(s.sim_time_s, 0.5);
    assert_eq!(s.settle_time_s, None);
    assert!(s.final_error_deg.is_nan() && s.mean_error_whole_run_deg.is_nan());
    // Rows every 5th step: t = 0, 0.05, ..., 0.45 — ten rows, each equal to the clean run's.
    let n = bad.series.len();
    assert_eq!(n, 10);
    for (a, b) in bad.series.cols.iter().zip(&clean.series.cols) {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(a), bits(&b[..n]));
    }
    // The flight code answered 51 steps (0..=50); the statistics cover the 50 flown.
    assert!(s.status_counts.bad_input == 0 && clean.summary.status_counts.bad_input == 0);
}

/// Every step's status carries `bad_input`: all_refused with the reason. One step
/// accepted: not `all_refused` (that rule is "every step"), but not ok either: a run the
/// flight code could not control for a material part is `no_control` (issue 37).
#[test]
fn all_refused_means_every_step() {
    let sc = test3(1.0);
    let all = fly(&sc, |_, r| r.cmd.status |= status::BAD_INPUT);
    assert_eq!(all.summary.run_status, Status::AllRefused);
    assert_eq!(all.summary.status_counts.bad_input, 101);
    match &all.summary.failure {
        Some(Failure::Refused { reason }) => {
            assert!(reason.contains("101") && reason.contains("bad_input"), "{reason}")
        }
        f => panic!("{f:?}"),
    }
    let but_one = fly(&sc, |seq, r| {
        if seq != 7 {
            r.cmd.status |= status::BAD_INPUT
        }
    });
    assert_eq!(but_one.summary.run_status, Status::NoControl);
    assert_eq!(but_one.summary.status_counts.bad_input, 100);
}

/// The no-control rule (issue 37) at its edges, on 1 s of test3 at 100 Hz: 101 flight
/// steps, start-up allowance ⌈10 % × 101⌉ = 11 steps (under 60 s), 90 steps judged, at
/// most 10 % = 9 of them uncontrolled (`bad_input` or `no_estimate`). Uncontrolled steps
/// inside the allowance do not count; any other status bit does not count.
#[test]
fn no_control_means_more_than_a_tenth_of_the_steps_after_the_start_up_allowance() {
    use acs_flight::link::status::{NO_ESTIMATE, TORQUE_LIMITED};
    let sc = test3(1.0);
    let with = |lo: u32, hi: u32, bit: u16| {
        fly(&sc, move |seq, r| {
            if (lo..hi).contains(&seq) {
                r.cmd.status |= bit;
            }
        })
        .summary
    };
    // The allowance (0..11) and 9 more: ok.
    let s = with(0, 20, NO_ESTIMATE);
    assert_eq!((s.run_status, s.status_counts.no_estimate), (Status::Ok, 20));
    // 10 after the allowance: no_control, and the reason counts them.
    let s = with(11, 21, BAD_INPUT);
    assert_eq!(s.run_status, Status::NoControl);
    match &s.failure {
        Some(Failure::Control { reason }) => assert!(reason.contains("10 of the 90 control steps"), "{reason}"),
        f => panic!("{f:?}"),
    }
    let s = with(91, 101, NO_ESTIMATE);
    assert_eq!(s.run_status, Status::NoControl);
    // Other status bits are not a loss of control.
    let s = with(0, 101, TORQUE_LIMITED);
    assert_eq!(s.run_status, Status::Ok);
}

/// The campaign of the issue: `initial.rate_rad_s[0]` drawn from {0, 1e300}, requirement
/// settle < 15 s. Every run drawn 1e300 misses the requirement (diverged, or refused if the
/// scenario checks catch it), no other does, and the merge fails listing them.
#[test]
fn the_nan_campaign_fails_its_requirement() {
    let t = tempfile::tempdir().unwrap();
    let base = scenario(t.path(), "scenarios/paper000/test3.toml", "duration_s = 30.0", "duration_s = 20.0", 20.0);
    let text = format!(
        "name = \"nan\"\nbase = {:?}\nruns = 20\nseed = 7\n\
         [[dispersion]]\nkey = \"initial.rate_rad_s[0]\"\ndist = {{ type = \"choice\", values = [0.0, 1e300] }}\n\
         [[requirement]]\nkey = \"settle_time_s\"\nop = \"<\"\nvalue = 15.0\n",
        base.display().to_string()
    );
    let f = t.path().join("c.toml");
    std::fs::write(&f, text).unwrap();
    let dir = t.path().join("c");
    let m = campaign::plan(&Campaign::load(&f).unwrap(), &dir, None).unwrap();
    let huge: Vec<u32> =
        m.runs.iter().filter(|r| r.draws["initial.rate_rad_s[0]"].as_f64() == Some(1e300)).map(|r| r.index).collect();
    assert!(!huge.is_empty() && huge.len() < 20, "{huge:?}");
    let r = campaign::run_shard(&dir, Shard::ALL, 2, false).unwrap();
    assert_eq!(r.ok, 20 - huge.len());
    assert_eq!(r.diverged + r.errors, huge.len());
    let out = campaign::merge(&dir, false).unwrap();
    let res = &out.result;
    assert_eq!(res.requirements[0].failed_runs, huge);
    assert_eq!(res.requirements[0].passed, 20 - huge.len());
    let mut failed: Vec<u32> = res.diverged.iter().copied().chain(res.errors.iter().map(|e| e.run)).collect();
    failed.sort_unstable();
    assert_eq!(failed, huge);
    assert!(!res.passed());
    // Statistics come from the runs that flew to the end only.
    assert_eq!(res.statistics["settle_time_s"].moments.n, 20 - huge.len());
    let st = sim_host().args(["campaign", "merge", "--no-plots"]).arg(&dir).output().unwrap();
    let stdout = String::from_utf8_lossy(&st.stdout);
    assert_eq!(st.status.code(), Some(1), "{stdout}");
    assert!(stdout.contains(&format!("{}/20 passed", 20 - huge.len())), "{stdout}");
    if !res.diverged.is_empty() {
        assert!(stdout.contains(&format!("{} diverged", res.diverged.len())), "{stdout}");
    }
    // A recorded run status survives in result.json.
    let rec: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join(format!("runs/{:06}/result.json", huge[0]))).unwrap())
            .unwrap();
    assert!(rec["status"] == "diverged" || rec["status"] == "error", "{rec}");
    assert!(!RunStatus::Diverged.flew() && !RunStatus::AllRefused.flew() && RunStatus::RequirementFailed.flew());
}

/// What could only fail at run time is refused at planning, naming the dispersion, and no
/// manifest is written.
#[test]
fn planning_refuses_overflows_unknown_keys_and_replaced_tables() {
    let t = tempfile::tempdir().unwrap();
    let base = repo().join("scenarios/paper000/test3.toml");
    let cases = [
        (
            "key = \"spacecraft.nonexistent_key\"\ndist = { type = \"uniform\", low = 0.0, high = 1.0 }",
            "nonexistent_key",
        ),
        ("key = \"sensors\"\ndist = { type = \"seed\" }", "holds a table"),
        ("key = \"spacecraft\"\ndist = { type = \"choice\", values = [1.0] }", "holds a table"),
        (
            "key = \"initial.rate_rad_s[0]\"\ndist = { type = \"choice\", values = [0.0, 1.0], weights = [1e308, 1e308] }",
            "sum to inf",
        ),
        ("key = \"initial.rate_rad_s[0]\"\ndist = { type = \"uniform\", low = -1e308, high = 1e308 }", "overflows"),
        ("key = \"initial.rate_rad_s[0]\"\ndist = { type = \"lognormal\", mu = 800.0, sigma = 1.0 }", "overflows"),
        (
            "key = \"spacecraft.inertia_kgm2\"\ndist = { type = \"uniform\", low = 1e307, high = 1e308 }\napply = \"scale\"",
            "not a finite number",
        ),
    ];
    for (i, (disp, want)) in cases.iter().enumerate() {
        let f = t.path().join(format!("c{i}.toml"));
        let text = format!(
            "name = \"p\"\nbase = {:?}\nruns = 3\nseed = 1\n[[dispersion]]\n{disp}\n",
            base.display().to_string()
        );
        std::fs::write(&f, text).unwrap();
        let out = t.path().join(format!("o{i}"));
        let r = sim_host().args(["campaign", "plan"]).arg(&f).arg("--out").arg(&out).output().unwrap();
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(1), "{disp}: {err}");
        assert!(err.contains(want), "{disp}: {err}");
        assert!(!out.join("manifest.json").exists(), "{disp}");
    }
}

/// A second `campaign run` on a directory whose shard is being flown refuses, naming the
/// holder; once the first is done (lock released and removed), it runs.
#[test]
fn a_second_campaign_run_on_one_directory_refuses() {
    let t = tempfile::tempdir().unwrap();
    let base = repo().join("scenarios/paper000/test3.toml");
    let f = t.path().join("c.toml");
    let text = format!(
        "name = \"l\"\nbase = {:?}\nruns = 2\nseed = 1\n[[dispersion]]\nkey = \"sensors.seed\"\ndist = {{ type = \"seed\" }}\n",
        base.display().to_string()
    );
    std::fs::write(&f, text).unwrap();
    let dir = t.path().join("c");
    campaign::plan(&Campaign::load(&f).unwrap(), &dir, None).unwrap();
    let held = ShardLock::acquire(&dir, Shard::ALL).unwrap();
    let r = sim_host().args(["campaign", "run", "-q"]).arg(&dir).output().unwrap();
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(err.contains("locked by another") && err.contains(&format!("pid {}", std::process::id())), "{err}");
    assert!(!dir.join("runs/000000/result.json").exists(), "nothing flown");
    // An overlapping shard layout is refused too.
    let r = sim_host().args(["campaign", "run", "-q", "--shard", "1/2"]).arg(&dir).output().unwrap();
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).contains("overlap"));
    drop(held);
    let r = sim_host().args(["campaign", "run", "-q"]).arg(&dir).output().unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(dir.join("runs/000001/result.json").exists());
    assert!(!dir.join(".run-lock-0-of-1").exists(), "the lock is removed on exit");
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

/// A re-run into the directory of an earlier run: a failure before the run leaves none of
/// the old files; a diverged re-run leaves its own summary and figures only, and no
/// temporary file.
#[test]
fn a_failed_rerun_leaves_no_stale_output() {
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("out");
    let ok = scenario(t.path(), "scenarios/paper000/test3.toml", "duration_s = 30.0", "duration_s = 3.0", 3.0);
    assert!(run_cli(&ok, &out, true).status.success());
    let before = listing(&out);
    assert!(before.contains(&"summary.json".into()) && before.iter().filter(|f| f.ends_with(".png")).count() >= 3);
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    // Invalid scenario: exit 1, no summary, CSV or PNG of the earlier run remains; the
    // user's own file does.
    let bad =
        scenario(t.path(), "scenarios/paper000/test3.toml", "control_rate_hz = 100.0", "control_rate_hz = -1.0", 3.0);
    let r = run_cli(&bad, &out, true);
    assert_eq!(r.status.code(), Some(1), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(listing(&out), vec!["notes.txt".to_string()]);
    // The good run again, then a diverged one: its summary says diverged, and every file
    // there was written by it (timestamps not older than the run's start).
    assert!(run_cli(&ok, &out, true).status.success());
    let div = scenario(
        t.path(),
        "scenarios/paper000/test3.toml",
        "rate_rad_s = [0.0, 0.0, 0.0]",
        "rate_rad_s = [1e300, 0.0, 0.0]",
        3.0,
    );
    let start = std::time::SystemTime::now() - std::time::Duration::from_millis(10);
    let r = run_cli(&div, &out, true);
    if r.status.code() == Some(3) {
        assert_diverged(&summary_json(&out), "rerun", 3.0);
        for f in listing(&out).iter().filter(|f| *f != "notes.txt") {
            let m = std::fs::metadata(out.join(f)).unwrap().modified().unwrap();
            assert!(m >= start, "{f} is older than the run");
        }
    } else {
        assert_eq!(r.status.code(), Some(1));
        assert_eq!(listing(&out), vec!["notes.txt".to_string()]);
    }
    assert!(listing(&out).iter().all(|f| !f.starts_with('.')), "temporary files left: {:?}", listing(&out));
}

/// An output path that cannot be written: the error names the file.
#[test]
fn an_unwritable_summary_path_is_named() {
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("out");
    std::fs::create_dir_all(out.join("summary.json")).unwrap();
    std::fs::write(out.join("summary.json/keep"), "x").unwrap();
    let sc = scenario(t.path(), "scenarios/paper000/test3.toml", "duration_s = 30.0", "duration_s = 1.0", 1.0);
    let r = run_cli(&sc, &out, false);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(err.contains(&out.join("summary.json").display().to_string()), "{err}");
}
