//! The 3D replay (`sim-host view`, docs/viewer.md) in a real headless browser: Debian's
//! Chromium driven by playwright-core (tools/viewer/test/drive.mjs), never a downloaded
//! browser. What the page's scene holds is read back and compared with the run:
//! - the attitude of the drawn spacecraft, taken back to ECI through the camera frame,
//!   equals the run's quaternion to round-off (1e-9) in every camera frame;
//! - the Sun and Earth directions of the scene equal the run's recorded ones within 0.01°;
//! - scrubbing to just after each mode transition shows that mode; a click on the time plot
//!   seeks to the time under the pointer (within one plot pixel);
//! - the page loads with no console error, no page error and no network request;
//! - a failed run's page says so, with the reason.
//!
//! The geometry the page recomputes from the scenario (runs without recorded orbit
//! columns) is checked against the recorded columns of a run that has them.
//!
//! Needs node, Chromium, tools/viewer/node_modules and the bundle (`scripts/setup.sh`):
//! under CI a missing one fails the test (support/require_tool.rs).

#[path = "support/shipped_scenario.rs"]
mod shipped_scenario;
use acs_test_support::vec3::rotate_xyzw;
use shipped_scenario::scenario;
#[path = "support/require_tool.rs"]
mod require_tool;

use require_tool::{Tool, require_tool};
use serde_json::{Value, json};
use sim_core::recorder::output::read_run;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn sim_host() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_sim-host"));
    c.current_dir(repo());
    c
}

/// The driver script, when node, Chromium, playwright-core and the bundle are all there.
fn browser() -> Option<PathBuf> {
    let found = (|| -> Result<PathBuf, String> {
        let node = Command::new("node").arg("--version").output().map_err(|e| format!("`node --version`: {e}"))?;
        if !node.status.success() {
            return Err(format!("`node --version` exited with {}", node.status));
        }
        let chromium = std::env::var("ACS_CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
        if !Path::new(&chromium).exists() {
            return Err(format!("{chromium} is missing"));
        }
        let viewer = repo().join("tools/viewer");
        if !viewer.join("node_modules/playwright-core/package.json").exists() {
            return Err("tools/viewer/node_modules has no playwright-core (npm ci)".into());
        }
        let bundle = sim_host::view::bundle_path();
        if !bundle.exists() {
            return Err(format!("the viewer bundle {} is missing", bundle.display()));
        }
        Ok(viewer.join("test/drive.mjs"))
    })();
    require_tool(Tool::Browser, found)
}

/// Runs the driver on a script and returns what the page showed.
fn drive(driver: &Path, dir: &Path, script: Value) -> Value {
    let path = dir.join(format!("drive-{}.json", std::process::id()));
    std::fs::write(&path, script.to_string()).unwrap();
    let out = Command::new("node").arg(driver).arg(&path).output().unwrap();
    assert!(
        out.status.success(),
        "drive.mjs failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in ["consoleErrors", "pageErrors", "requests"] {
        assert_eq!(v[key], json!([]), "the page reported {key}: {v}");
    }
    assert_eq!(v["startError"], Value::Null, "{v}");
    v
}

fn run_with_view(sc: &Path, out: &Path) -> Output {
    let args = ["run", sc.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-plots", "--quiet", "--view"];
    sim_host().args(args).output().unwrap()
}

fn vec_of(v: &Value) -> Vec<f64> {
    v.as_array().unwrap_or_else(|| panic!("not an array: {v}")).iter().map(|x| x.as_f64().unwrap()).collect()
}

/// Largest component difference of two attitudes given as [x, y, z, w] (q and -q are
/// the same attitude).
fn quat_distance(a: &[f64], b: &[f64]) -> f64 {
    let diff = |s: f64| a.iter().zip(b).map(|(x, y)| (x - s * y).abs()).fold(0.0, f64::max);
    diff(1.0).min(diff(-1.0))
}

fn angle_deg(a: &[f64], b: &[f64]) -> f64 {
    let dot: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let cross = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    cross.iter().map(|c| c * c).sum::<f64>().sqrt().atan2(dot).to_degrees()
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    v.map(|x| x / n)
}

/// The shipped mission: the attitude in every camera frame at rows around every mode
/// transition and spread over the run, each transition's mode, a click on the plot.
#[test]
fn the_mission_replays_as_flown() {
    let Some(driver) = browser() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("mission");
    let r = run_with_view(&repo().join("scenarios/modes/cubesat-mission.toml"), &out);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let run = read_run(&out).unwrap();
    let ts = &run.series;
    let t = ts.col("t_s").unwrap();
    let q: Vec<&[f64]> = ["q_x", "q_y", "q_z", "q_w"].iter().map(|c| ts.col(c).unwrap()).collect();
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let transitions = summary["mode_transitions"].as_array().unwrap().clone();
    assert!(transitions.len() >= 4, "{transitions:?}");
    // Rows: spread over the run, and the first row at or after each transition.
    let mut rows: Vec<usize> = (0..7).map(|k| k * (t.len() - 1) / 6).collect();
    let after: Vec<usize> =
        transitions.iter().map(|m| t.partition_point(|&x| x < m["t_s"].as_f64().unwrap()).min(t.len() - 1)).collect();
    rows.extend(&after);
    let cameras = ["inertial", "lvlh", "body"];
    let mut ops: Vec<Value> =
        rows.iter().enumerate().map(|(k, &i)| json!({ "op": "state", "t": t[i], "camera": cameras[k % 3] })).collect();
    ops.push(json!({ "op": "clickPlot", "fraction": 0.25 }));
    let v = drive(&driver, tmp.path(), json!({ "page": out.join("replay.html"), "ops": ops }));
    let res = v["results"].as_array().unwrap();
    for (k, &i) in rows.iter().enumerate() {
        let s = &res[k];
        assert_eq!(s["t"].as_f64().unwrap(), t[i], "{s}");
        let want = [q[0][i], q[1][i], q[2][i], q[3][i]];
        let got = vec_of(&s["bodyToEci"]);
        assert!(
            quat_distance(&got, &want) < 1e-9,
            "t = {} s, camera {}: scene {got:?}, run {want:?}",
            t[i],
            s["camera"]
        );
    }
    // Just after each transition the page shows the mode entered.
    for (m, s) in transitions.iter().zip(&res[7..]) {
        assert_eq!(s["mode"], m["to"], "transition {m}: page {s}");
    }
    // The click: a quarter of the plot's data width is a quarter of the run, within a pixel
    // of the plot (1400 px wide, 64 px of margins).
    let span = t[t.len() - 1] - t[0];
    let clicked = res.last().unwrap()["t"].as_f64().unwrap();
    assert!((clicked - (t[0] + 0.25 * span)).abs() < span / 1336.0 * 1.5, "click seeked to {clicked} s");
    assert!(v["firstFrameMs"].as_f64().unwrap() > 0.0, "{v}");
}

/// A guidance run records its orbit, Sun and Earth angle: the scene's Sun and Earth
/// directions equal them within 0.01° in every camera frame, so does the ray to the tracked
/// site (its recorded body-axes direction), and the geometry the page
/// computes from the scenario alone (for runs that record none) agrees with them too.
#[test]
fn sun_and_earth_are_where_the_run_says() {
    let Some(driver) = browser() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let sc = scenario(tmp.path(), "scenarios/guidance/eo-cubesat.toml", 600.0, None);
    let out = tmp.path().join("eo");
    let r = run_with_view(&sc, &out);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let run = read_run(&out).unwrap();
    let ts = &run.series;
    let col = |n: &str| ts.col(n).unwrap_or_else(|| panic!("no column {n}"));
    let t = col("t_s");
    let (sun, r_m) = (
        [col("sun_eci_x"), col("sun_eci_y"), col("sun_eci_z")],
        [col("r_eci_x_m"), col("r_eci_y_m"), col("r_eci_z_m")],
    );
    let rows: Vec<usize> = (0..6).map(|k| k * (t.len() - 1) / 5).collect();
    let cameras = ["inertial", "lvlh", "body"];
    let ops: Vec<Value> =
        rows.iter().enumerate().map(|(k, &i)| json!({ "op": "state", "t": t[i], "camera": cameras[k % 3] })).collect();
    let v = drive(&driver, tmp.path(), json!({ "page": out.join("replay.html"), "ops": ops }));
    let mut targets = 0;
    for (s, &i) in v["results"].as_array().unwrap().iter().zip(&rows) {
        let sun_run = unit([sun[0][i], sun[1][i], sun[2][i]]);
        let earth_run = unit([-r_m[0][i], -r_m[1][i], -r_m[2][i]]);
        let e_sun = angle_deg(&vec_of(&s["sunEci"]), &sun_run);
        let e_earth = angle_deg(&vec_of(&s["earthEci"]), &earth_run);
        assert!(
            e_sun < 0.01 && e_earth < 0.01,
            "t = {} s, {}: Sun off by {e_sun}°, Earth by {e_earth}°",
            t[i],
            s["camera"]
        );
        // The tracked site: the recorded body-axes direction, turned into ECI here by the
        // run's quaternion (v' = q v q*, written out), against the ray the page draws.
        let tb = [col("target_body_x")[i], col("target_body_y")[i], col("target_body_z")[i]];
        if tb.iter().all(|x| x.is_finite()) {
            let q = [col("q_x")[i], col("q_y")[i], col("q_z")[i], col("q_w")[i]];
            let want = rotate_xyzw(&q, &unit(tb));
            let e_target = angle_deg(&vec_of(&s["targetEci"]), &want);
            assert!(e_target < 0.01, "t = {} s, {}: target ray off by {e_target}°", t[i], s["camera"]);
            assert_eq!(s["targetVisible"], json!(col("target_visible")[i] == 1.0), "{s}");
            targets += 1;
        }
        let radius = (sim_core::environment::orbit::R_E / r_m.iter().map(|c| c[i] * c[i]).sum::<f64>().sqrt()).asin();
        assert!((s["earthRadiusRad"].as_f64().unwrap() - radius).abs() < 1e-6, "{s}");
    }
    assert!(targets >= 3, "the target ray was checked at {targets} rows only");
    // The geometry from the scenario alone: same run, recorded orbit columns hidden.
    let sc_run = sim_core::scenario::Scenario::load(&sc).unwrap();
    let mut bare = ts.clone();
    let keep: Vec<usize> = (0..bare.names.len()).filter(|&k| !bare.names[k].contains("_eci_")).collect();
    bare.names = keep.iter().map(|&k| bare.names[k].clone()).collect();
    bare.cols = keep.iter().map(|&k| bare.cols[k].clone()).collect();
    let all: Vec<usize> = (0..t.len()).step_by(7).collect();
    let (source, orbit) = sim_host::view::geometry::orbit(Some(&sc_run), &bare, &all).unwrap();
    assert_eq!(source, sim_host::view::geometry::Source::Scenario);
    for (p, &i) in orbit.iter().zip(&all) {
        let sun_run = unit([sun[0][i], sun[1][i], sun[2][i]]);
        let r_run = [r_m[0][i], r_m[1][i], r_m[2][i]];
        let dr = (0..3).map(|a| (p.r_m[a] - r_run[a]).powi(2)).sum::<f64>().sqrt();
        assert!(
            angle_deg(p.sun.as_slice(), &sun_run) < 0.01,
            "t = {} s: recomputed Sun {:?} vs {sun_run:?}",
            t[i],
            p.sun
        );
        assert!(dr < 1.0, "t = {} s: recomputed position {dr} m from the recorded one", t[i]);
    }
}

/// A run that fails (exit 3: here the filter never claims an attitude within 1e-4°, so
/// no step is controlled — `no_control`) still gets its page, and the page says so where
/// the title is, with the summary's reason.
#[test]
fn a_failed_run_says_so() {
    let Some(driver) = browser() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let edit = ("lost_attitude_sigma_deg = 1.0", "lost_attitude_sigma_deg = 0.0001");
    let sc = scenario(tmp.path(), "scenarios/estimation/mekf-hold.toml", 300.0, Some(edit));
    let out = tmp.path().join("failed");
    let r = run_with_view(&sc, &out);
    assert_eq!(r.status.code(), Some(3), "{}", String::from_utf8_lossy(&r.stderr));
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["run_status"], "no_control", "{summary}");
    let v = drive(
        &driver,
        tmp.path(),
        json!({ "page": out.join("replay.html"), "ops": [{ "op": "text", "selector": "#status" }] }),
    );
    let status = v["results"][0].as_str().unwrap();
    let reason = summary["failure"]["reason"].as_str().unwrap();
    assert!(status.starts_with("RUN NO_CONTROL: ") && status.contains(reason), "{status}");
}

/// `sim-host view CAMPAIGN --run worst` opens the run `campaign.json` names as the first
/// requirement's worst: the page is that run's (its scenario, and its final error equal to
/// the error the merge recorded for it, bit for bit), and it loads in the browser.
#[test]
fn a_campaigns_worst_run_opens_the_same_way() {
    let Some(driver) = browser() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let base = scenario(tmp.path(), "scenarios/paper000/test3.toml", 10.0, None);
    let spec = tmp.path().join("c.toml");
    let text = format!(
        "name = \"v\"\nbase = {:?}\nruns = 4\nseed = 11\n\
         [[dispersion]]\nkey = \"initial.euler_deg\"\ndist = {{ type = \"rotation\", max_deg = 40.0 }}\n\
         [[requirement]]\nname = \"error\"\nkey = \"final_error_deg\"\nop = \"<\"\nvalue = 1000.0\n",
        base.display().to_string()
    );
    std::fs::write(&spec, text).unwrap();
    let dir = tmp.path().join("c");
    let ok = |args: &[&str]| {
        let o = sim_host().args(args).output().unwrap();
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    };
    let d = dir.to_str().unwrap();
    ok(&["campaign", "plan", spec.to_str().unwrap(), "--out", d]);
    ok(&["campaign", "run", "-q", d]);
    ok(&["campaign", "merge", "--no-plots", d]);
    ok(&["view", d, "--run", "worst"]);
    let merged: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("campaign.json")).unwrap()).unwrap();
    let worst = &merged["requirements"][0]["worst"][0];
    let run = worst["run"].as_u64().unwrap();
    let out = dir.join("runs").join(format!("{run:06}")).join("out");
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["final_error_deg"], worst["value"], "worst {worst}, flown again {summary}");
    let v = drive(
        &driver,
        tmp.path(),
        json!({ "page": out.join("replay.html"), "ops": [{ "op": "text", "selector": "#title" }] }),
    );
    assert_eq!(v["results"][0], summary["scenario"]);
}
