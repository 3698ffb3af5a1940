//! Campaigns: planning is deterministic and per-key independent, the planned scenarios are
//! the base scenario with exactly the drawn changes and re-run alone with `sim-host run`,
//! the distributions are what they claim, errors and interruptions are survived, and the
//! merge's verdicts follow the binomial bounds.

use sim_core::attitude::{from_xyzw, quat_from_euler};
use sim_core::scenario::Scenario;
use sim_host::campaign::draw::{self, haar_angle};
use sim_host::campaign::spec::{Apply, Dispersion, Distribution};
use sim_host::campaign::{self, Campaign, Manifest, RunStatus, Shard};
use sim_host::campaign::{merge::Verdict, path::KeyPath};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn sim_host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sim-host"))
}

/// A campaign file in `dir` on `base` (absolute path) with extra TOML.
fn campaign_file(dir: &Path, base: &Path, runs: u32, extra: &str) -> PathBuf {
    let p = dir.join("c.toml");
    let text = format!("name = \"t\"\nbase = {:?}\nruns = {runs}\nseed = 7\n{extra}", base.display().to_string());
    std::fs::write(&p, text).unwrap();
    p
}

fn test3() -> PathBuf {
    repo().join("scenarios/paper000/test3.toml")
}

fn all_files(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(p.strip_prefix(dir).unwrap().to_path_buf(), std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

const TEST3_DISPERSIONS: &str = r#"
[[dispersion]]
key = "spacecraft.inertia_kgm2"
dist = { type = "uniform", low = 0.9, high = 1.1 }
apply = "scale"
[[dispersion]]
key = "initial.euler_deg"
dist = { type = "rotation", max_deg = 20.0 }
[[dispersion]]
key = "sensors.seed"
dist = { type = "seed" }
"#;

/// Every shipped scenario survives the round trip the planner makes (parsed, every default
/// made explicit, written, parsed again) unchanged: `Debug` prints f64 in shortest
/// round-trip form, so equal text means equal values.
#[test]
fn materialised_scenarios_equal_their_source() {
    let mut n = 0;
    for group in std::fs::read_dir(repo().join("scenarios")).unwrap() {
        for f in std::fs::read_dir(group.unwrap().path()).unwrap() {
            let p = f.unwrap().path();
            let sc = Scenario::load(&p).unwrap();
            let text = toml::to_string(&toml::Value::try_from(&sc).unwrap()).unwrap();
            let back = Scenario::from_toml(&text).unwrap_or_else(|e| panic!("{}: {e:#}", p.display()));
            assert_eq!(format!("{sc:?}"), format!("{back:?}"), "{}", p.display());
            n += 1;
        }
    }
    assert!(n >= 25, "only {n} scenarios found");
}

/// Same campaign file, two directories: the same bytes. One more dispersion: the draws of
/// the others do not move.
#[test]
fn planning_is_deterministic_and_draws_are_independent_per_key() {
    let t = tempfile::tempdir().unwrap();
    let f = campaign_file(t.path(), &test3(), 12, TEST3_DISPERSIONS);
    let c = Campaign::load(&f).unwrap();
    let (a, b) = (t.path().join("a"), t.path().join("b"));
    let ma = campaign::plan(&c, &a, None).unwrap();
    campaign::plan(&c, &b, None).unwrap();
    assert_eq!(all_files(&a), all_files(&b));
    // Re-planning into the same directory is allowed and changes nothing.
    campaign::plan(&c, &a, None).unwrap();
    assert_eq!(all_files(&a), all_files(&b));

    let extra = format!(
        "{TEST3_DISPERSIONS}\n[[dispersion]]\nkey = \"sensors.attitude_noise_deg\"\ndist = {{ type = \"uniform\", low = 0.0, high = 0.1 }}\n"
    );
    let f2 = campaign_file(t.path(), &test3(), 12, &extra);
    let mc = campaign::plan(&Campaign::load(&f2).unwrap(), &t.path().join("c"), None).unwrap();
    for (ra, rc) in ma.runs.iter().zip(&mc.runs) {
        for (k, v) in &ra.draws {
            assert_eq!(Some(v), rc.draws.get(k), "run {} key {k}", ra.index);
        }
        assert_eq!(rc.draws.len(), ra.draws.len() + 1);
    }
    // A different campaign in the same directory is refused.
    let e = campaign::plan(&Campaign::load(&f2).unwrap(), &a, None).unwrap_err();
    assert!(e.to_string().contains("another campaign"), "{e}");
    // Draws differ between runs (the seed stream depends on the run index).
    assert_ne!(ma.runs[0].draws["sensors.seed"], ma.runs[1].draws["sensors.seed"]);
}

/// A planned scenario is the base with the drawn changes only: the inertia scaled by the
/// drawn factor, the initial attitude at the drawn angle from the nominal.
#[test]
fn planned_scenarios_carry_exactly_the_drawn_values() {
    let t = tempfile::tempdir().unwrap();
    let f = campaign_file(t.path(), &test3(), 20, TEST3_DISPERSIONS);
    let m = campaign::plan(&Campaign::load(&f).unwrap(), t.path(), None).unwrap();
    let base = Scenario::load(&test3()).unwrap();
    let q0 = base.initial.attitude.quaternion();
    for run in &m.runs {
        let sc = Scenario::load(&t.path().join(&run.scenario)).unwrap();
        let k = run.draws["spacecraft.inertia_kgm2"].as_f64().unwrap();
        assert!((0.9..=1.1).contains(&k));
        for r in 0..3 {
            for c in 0..3 {
                let want = base.spacecraft.inertia_kgm2[r][c] * k;
                assert!((sc.spacecraft.inertia_kgm2[r][c] - want).abs() <= 1e-15 * want.abs().max(1.0));
            }
        }
        let rv: Vec<f64> =
            run.draws["initial.euler_deg"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        let angle_deg = rv.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(angle_deg <= 20.0);
        let q = sc.initial.attitude.quaternion();
        let e = sim_core::attitude::error_angle(&q, &q0).to_degrees();
        assert!((e - angle_deg).abs() < 1e-9, "run {}: {e} vs {angle_deg}", run.index);
        assert_eq!(sc.sensors.seed, run.draws["sensors.seed"].as_u64().unwrap());
        assert_eq!(sc.duration_s, base.duration_s);
    }
}

/// A run of the campaign and the same scenario flown by `sim-host run` give the same
/// summary, bit for bit (wall-clock keys aside).
#[test]
fn a_campaign_run_reruns_alone_with_sim_host_run() {
    let t = tempfile::tempdir().unwrap();
    let f = campaign_file(t.path(), &test3(), 4, TEST3_DISPERSIONS);
    let dir = t.path().join("c");
    let ok = sim_host().args(["campaign", "plan"]).arg(&f).arg("--out").arg(&dir).status().unwrap();
    assert!(ok.success());
    let ok = sim_host().args(["campaign", "run", "--jobs", "2", "-q"]).arg(&dir).status().unwrap();
    assert!(ok.success());
    let out = t.path().join("rerun");
    let ok = sim_host()
        .args(["run", "-q", "--no-plots"])
        .arg(dir.join("runs/000003/scenario.toml"))
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(ok.success());
    let alone: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let rec: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("runs/000003/result.json")).unwrap()).unwrap();
    let strip = |v: &serde_json::Value| {
        let mut m = campaign::flatten(v);
        m.retain(|k, _| !campaign::merge::WALL_CLOCK_KEYS.contains(&k.as_str()));
        m
    };
    let (a, b) = (strip(&alone), strip(&rec["summary"]));
    assert!(a.len() > 20);
    for (k, v) in &a {
        assert_eq!(v.map(f64::to_bits), b[k].map(f64::to_bits), "{k}");
    }
}

/// A run the flight code cannot control (the MEKF never claims an estimate:
/// `lost_attitude_sigma_deg` below anything it can reach) has `run_status` `no_control`
/// (issue 37): a campaign counts it as such, it fails every requirement whatever its
/// figures, and the merge fails (exit 1).
#[test]
fn runs_the_flight_code_cannot_control_fail_the_campaign() {
    let t = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("scenarios/estimation/mekf-hold.toml")).unwrap();
    let text = text
        .replace("duration_s = 3000.0", "duration_s = 300.0")
        .replace("lost_attitude_sigma_deg = 1.0", "lost_attitude_sigma_deg = 1e-4");
    assert!(text.contains("lost_attitude_sigma_deg = 1e-4") && text.contains("duration_s = 300.0"));
    let base = t.path().join("uncontrolled.toml");
    std::fs::write(&base, text).unwrap();
    let extra = "[[dispersion]]\nkey = \"sensors.seed\"\ndist = { type = \"seed\" }\n\
                 [[requirement]]\nname = \"error\"\nkey = \"final_error_deg\"\nop = \"<\"\nvalue = 1000.0\n";
    let f = campaign_file(t.path(), &base, 2, extra);
    let dir = t.path().join("c");
    assert!(sim_host().args(["campaign", "plan"]).arg(&f).arg("--out").arg(&dir).status().unwrap().success());
    assert!(sim_host().args(["campaign", "run", "-q"]).arg(&dir).status().unwrap().success());
    let o = sim_host().args(["campaign", "merge", "--no-plots"]).arg(&dir).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stdout));
    let c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("campaign.json")).unwrap()).unwrap();
    assert_eq!(c["no_control"], serde_json::json!([0, 1]), "{c}");
    // A requirement every figure would meet (final error < 1000 deg) fails on both runs.
    assert_eq!(c["requirements"][0]["failed_runs"], serde_json::json!([0, 1]), "{}", c["requirements"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("2 not controlled"));
}

/// A run whose injected fault loses control with no FDIR event (the 3U mission, `gyro.x`
/// stuck in hold; docs/scenario.md "Control lost") has `run_status` `control_lost`: a
/// campaign lists it as such, it fails every requirement whatever its figures, and the
/// merge fails (exit 1).
#[test]
fn runs_that_lose_control_unnoticed_fail_the_campaign() {
    let t = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("scenarios/modes/cubesat-mission.toml")).unwrap()
        + "\n[[faults]]\nonset_s = 6000.0\nunit = \"gyro.x\"\nkind = \"stuck\"\n";
    let base = t.path().join("gyro-stuck.toml");
    std::fs::write(&base, text).unwrap();
    let extra = "[[dispersion]]\nkey = \"faults[0].onset_s\"\ndist = { type = \"uniform\", low = 5900.0, high = 6100.0 }\n\
                 [[requirement]]\nname = \"error\"\nkey = \"final_error_deg\"\nop = \"<\"\nvalue = 1000.0\n";
    let f = campaign_file(t.path(), &base, 2, extra);
    let dir = t.path().join("c");
    assert!(sim_host().args(["campaign", "plan"]).arg(&f).arg("--out").arg(&dir).status().unwrap().success());
    assert!(sim_host().args(["campaign", "run", "-q"]).arg(&dir).status().unwrap().success());
    let o = sim_host().args(["campaign", "merge", "--no-plots"]).arg(&dir).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stdout));
    let c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("campaign.json")).unwrap()).unwrap();
    assert_eq!(c["control_lost"], serde_json::json!([0, 1]), "{c}");
    assert_eq!(c["requirements"][0]["failed_runs"], serde_json::json!([0, 1]), "{}", c["requirements"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("2 control lost unnoticed"));
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(report.contains("2 lost control with no FDIR event"), "{report}");
}

/// A run whose FDIR declares the fault but that still loses control and does not end in a
/// safe mode (the 6U, no mode table, `gyro.y` stuck and declared; docs/scenario.md
/// "Recovery failed") has `run_status` `recovery_failed`: a campaign lists it as such, it
/// fails every requirement whatever its figures, and the merge fails (exit 1).
#[test]
fn runs_whose_recovery_fails_fail_the_campaign() {
    let t = tempfile::tempdir().unwrap();
    let six = std::fs::read_to_string(repo().join("scenarios/fdir/wheel-seized-6u.toml")).unwrap();
    let text = six[..six.find("\n[[faults]]").unwrap()].replace("duration_s = 6000.0", "duration_s = 1000.0")
        + "\n[fdir.gyro]\n\n[[faults]]\nonset_s = 846.0\nunit = \"gyro.y\"\nkind = \"stuck\"\n";
    let base = t.path().join("gyro-stuck-6u.toml");
    std::fs::write(&base, text).unwrap();
    let extra = "[[dispersion]]\nkey = \"faults[0].onset_s\"\ndist = { type = \"uniform\", low = 840.0, high = 850.0 }\n\
                 [[requirement]]\nname = \"error\"\nkey = \"final_error_deg\"\nop = \"<\"\nvalue = 1000.0\n";
    let f = campaign_file(t.path(), &base, 2, extra);
    let dir = t.path().join("c");
    assert!(sim_host().args(["campaign", "plan"]).arg(&f).arg("--out").arg(&dir).status().unwrap().success());
    assert!(sim_host().args(["campaign", "run", "-q"]).arg(&dir).status().unwrap().success());
    let o = sim_host().args(["campaign", "merge", "--no-plots"]).arg(&dir).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stdout));
    let c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("campaign.json")).unwrap()).unwrap();
    assert_eq!(c["recovery_failed"], serde_json::json!([0, 1]), "{c}");
    assert_eq!(c["control_lost"], serde_json::json!([]), "{c}");
    assert_eq!(c["requirements"][0]["failed_runs"], serde_json::json!([0, 1]), "{}", c["requirements"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("2 recovery failed"));
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(report.contains("2 lost control after an FDIR event"), "{report}");
}

/// A run whose thrusters use more than `[performance] propellant_budget_kg` (paper 004,
/// 60 s, thruster 0 stuck open from 5 s: 0.80 kg against budgets of 0.05-0.5 kg; docs/scenario.md
/// "Propellant exceeded") has `run_status` `propellant_exceeded`: a campaign lists it as such,
/// it fails every requirement whatever its figures, and the merge fails (exit 1).
#[test]
fn runs_over_their_propellant_budget_fail_the_campaign() {
    let t = tempfile::tempdir().unwrap();
    let dp = std::fs::read_to_string(repo().join("scenarios/paper004/dp-nominal.toml")).unwrap();
    let text = dp
        + "\n[performance]\npropellant_budget_kg = 0.1\n\n[[faults]]\nonset_s = 5.0\nunit = \"thruster.0\"\n\
           kind = \"stuck_open\"\n";
    let base = t.path().join("stuck-open.toml");
    std::fs::write(&base, text).unwrap();
    let extra = "[[dispersion]]\nkey = \"performance.propellant_budget_kg\"\n\
                 dist = { type = \"uniform\", low = 0.05, high = 0.5 }\n\
                 [[requirement]]\nname = \"error\"\nkey = \"final_error_deg\"\nop = \"<\"\nvalue = 1000.0\n";
    let f = campaign_file(t.path(), &base, 2, extra);
    let dir = t.path().join("c");
    assert!(sim_host().args(["campaign", "plan"]).arg(&f).arg("--out").arg(&dir).status().unwrap().success());
    let o = sim_host().args(["campaign", "run", "-q"]).arg(&dir).output().unwrap();
    assert!(o.status.success() && String::from_utf8_lossy(&o.stdout).contains("2 propellant exceeded"));
    let o = sim_host().args(["campaign", "merge", "--no-plots"]).arg(&dir).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stdout));
    let c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("campaign.json")).unwrap()).unwrap();
    assert_eq!(c["propellant_exceeded"], serde_json::json!([0, 1]), "{c}");
    assert_eq!(c["pointing_degraded"], serde_json::json!([]), "{c}");
    assert_eq!(c["requirements"][0]["failed_runs"], serde_json::json!([0, 1]), "{}", c["requirements"]);
    // Each run's own summary: above its drawn budget.
    for i in 0..2 {
        let path = dir.join(format!("runs/{i:06}/result.json"));
        let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let s = &r["summary"];
        assert!(s["propellant_kg"].as_f64().unwrap() > s["propellant_budget_kg"].as_f64().unwrap(), "{s}");
    }
    assert!(String::from_utf8_lossy(&o.stdout).contains("2 propellant exceeded"));
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(report.contains("2 used more propellant than their budget"), "{report}");
}

/// The re-run commands `report.md` lists (here the worst runs of a requirement) work as
/// written from the directory the campaign was run in (issue 38: they used to hold only
/// inside the campaign directory), and give the run's own summary.
#[test]
fn report_rerun_commands_work_from_where_the_campaign_ran() {
    let t = tempfile::tempdir().unwrap();
    let extra = "[[requirement]]\nname = \"settles\"\nkey = \"settle_time_s\"\nop = \"<\"\nvalue = 15.0\n";
    let f = campaign_file(t.path(), &test3(), 3, &format!("{TEST3_DISPERSIONS}{extra}"));
    let in_tmp = |args: &[&str]| {
        let o = sim_host().current_dir(t.path()).args(args).output().unwrap();
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    };
    in_tmp(&["campaign", "plan", f.to_str().unwrap(), "--out", "c"]);
    in_tmp(&["campaign", "run", "-q", "c"]);
    let _ = sim_host().current_dir(t.path()).args(["campaign", "merge", "c", "--no-plots"]).output().unwrap();
    let report = std::fs::read_to_string(t.path().join("c/report.md")).unwrap();
    let commands: Vec<&str> =
        report.split('`').filter(|s| s.starts_with("sim-host run ") && s.contains("/runs/0")).collect();
    assert!(!commands.is_empty(), "no re-run command in report.md:\n{report}");
    for c in &commands {
        let words: Vec<&str> = c.split_whitespace().skip(1).collect();
        assert!(words[1].starts_with("c/runs/"), "{c}");
        in_tmp(&[&words[..], &["-q", "--no-plots"]].concat());
        let out = t.path().join(words[words.len() - 1]);
        let alone: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
        let rec: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.parent().unwrap().join("result.json")).unwrap()).unwrap();
        assert_eq!(alone["final_error_deg"], rec["summary"]["final_error_deg"], "{c}");
    }
}

/// Uniform rotations within a cone: the angle distribution against rejection sampling of
/// Haar-uniform quaternions (normalised 4-D Gaussians), by a two-sample Kolmogorov-Smirnov
/// statistic (critical value at alpha = 0.001: 1.95 sqrt(2/n)).
#[test]
fn rotation_draws_are_haar_uniform_within_the_cone() {
    use rand::{RngExt, SeedableRng};
    use rand_distr::{Distribution as _, StandardNormal};
    let max = 40f64.to_radians();
    let n = 4000;
    let mut rng = draw::stream(1, 0, "k");
    let mut ours: Vec<f64> = (0..n).map(|_| haar_angle(rng.random::<f64>(), max)).collect();
    let mut r2 = rand_chacha::ChaCha8Rng::seed_from_u64(99);
    let mut truth = Vec::new();
    while truth.len() < n {
        let q: [f64; 4] = std::array::from_fn(|_| StandardNormal.sample(&mut r2));
        let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        let angle = 2.0 * (q[3].abs() / norm).min(1.0).acos();
        if angle <= max {
            truth.push(angle);
        }
    }
    ours.sort_by(f64::total_cmp);
    truth.sort_by(f64::total_cmp);
    let mut d: f64 = 0.0;
    for x in ours.iter().chain(&truth) {
        let fa = ours.partition_point(|y| y <= x) as f64 / n as f64;
        let fb = truth.partition_point(|y| y <= x) as f64 / n as f64;
        d = d.max((fa - fb).abs());
    }
    let crit = 1.95 * (2.0 / n as f64).sqrt();
    assert!(d < crit, "KS distance {d} >= {crit}");
    // Full SO(3): the mean angle of a Haar rotation is pi/2 + 2/pi.
    let mean = (0..n).map(|_| haar_angle(rng.random::<f64>(), std::f64::consts::PI)).sum::<f64>() / n as f64;
    let want = std::f64::consts::FRAC_PI_2 + 2.0 / std::f64::consts::PI;
    assert!((mean - want).abs() < 0.03, "{mean} vs {want}");
}

fn disperse(key: &str, dist: Distribution, v: &mut toml::Value, run: u32) -> serde_json::Value {
    let d = Dispersion { key: KeyPath::parse(key).unwrap(), dist, apply: Apply::Set, per_element: false };
    draw::apply(&d, v, &mut draw::stream(3, run, key)).unwrap()
}

/// Rotations act by the key's form: a quaternion attitude turns by the drawn angle, an
/// inertia keeps its eigenvalues, a rotation vector composes.
#[test]
fn rotations_act_on_attitudes_matrices_and_rotation_vectors() {
    let v: toml::Value = toml::from_str(
        "[a]\nquaternion_xyzw = [0.0, 0.0, 0.6, 0.8]\ninertia_kgm2 = [[3.0, 0.1, 0.0], [0.1, 4.0, 0.2], [0.0, 0.2, 5.0]]\nmis_deg = [1.0, 0.0, 0.0]\n[b]\neuler_deg = [10.0, 20.0, 30.0]\neuler_sequence = \"123\"\n",
    )
    .unwrap();
    let base = v.clone();
    for run in 0..50 {
        let mut w = base.clone();
        let rot = |m: Option<f64>| Distribution::Rotation { max_deg: m, sd_deg: None };
        let dq = disperse("a.quaternion_xyzw", rot(Some(30.0)), &mut w, run);
        let de = disperse("b.euler_deg", rot(Some(30.0)), &mut w, run);
        disperse("a.inertia_kgm2", rot(None), &mut w, run);
        disperse("a.mis_deg", Distribution::Rotation { max_deg: None, sd_deg: Some(1.0) }, &mut w, run);
        let norm = |d: &serde_json::Value| {
            d.as_array().unwrap().iter().map(|x| x.as_f64().unwrap().powi(2)).sum::<f64>().sqrt()
        };
        let arr =
            |x: &toml::Value| -> Vec<f64> { x.as_array().unwrap().iter().map(|e| e.as_float().unwrap()).collect() };
        let q = |x: &toml::Value| {
            let a = arr(x);
            from_xyzw([a[0], a[1], a[2], a[3]])
        };
        let angle = sim_core::attitude::error_angle(&q(&w["a"]["quaternion_xyzw"]), &q(&base["a"]["quaternion_xyzw"]));
        assert!((angle.to_degrees() - norm(&dq)).abs() < 1e-9);
        let e = |x: &toml::Value| {
            let a = arr(x);
            quat_from_euler([a[0], a[1], a[2]].map(f64::to_radians), acs_flight::math::EulerSeq::Xyz123)
        };
        let angle = sim_core::attitude::error_angle(&e(&w["b"]["euler_deg"]), &e(&base["b"]["euler_deg"]));
        assert!((angle.to_degrees() - norm(&de)).abs() < 1e-9);
        let m = |x: &toml::Value| {
            let rows: Vec<Vec<f64>> = x.as_array().unwrap().iter().map(arr).collect();
            nalgebra::Matrix3::from_fn(|i, j| rows[i][j])
        };
        let (m0, m1) = (m(&base["a"]["inertia_kgm2"]), m(&w["a"]["inertia_kgm2"]));
        let mut e0: Vec<f64> = m0.symmetric_eigenvalues().iter().copied().collect();
        let mut e1: Vec<f64> = m1.symmetric_eigenvalues().iter().copied().collect();
        e0.sort_by(f64::total_cmp);
        e1.sort_by(f64::total_cmp);
        for (a, b) in e0.iter().zip(&e1) {
            assert!((a - b).abs() < 1e-12);
        }
        assert!((m1 - m1.transpose()).norm() < 1e-14);
        assert_eq!(arr(&w["a"]["mis_deg"]).len(), 3);
    }
}

/// k-of-n masks: every pair equally likely (chi-square, 27 degrees of freedom, critical
/// value at alpha = 0.001: 55.5); sizes as drawn; items 1-based and distinct.
#[test]
fn k_of_n_masks_are_uniform_over_subsets() {
    let mut counts: BTreeMap<Vec<u32>, u32> = BTreeMap::new();
    let n = 5600;
    for run in 0..n {
        let mut rng = draw::stream(11, run, "mask");
        let m = draw::k_of_n(8, 2, &mut rng);
        assert!(m.len() == 2 && m[0] < m[1] && m[0] >= 1 && m[1] <= 8);
        *counts.entry(m).or_default() += 1;
    }
    assert_eq!(counts.len(), 28);
    let e = f64::from(n) / 28.0;
    let chi2: f64 = counts.values().map(|c| (f64::from(*c) - e).powi(2) / e).sum();
    assert!(chi2 < 55.5, "chi2 {chi2}");
    // As failure tables: `[{ thruster = i }, ...]`.
    let mut v: toml::Value = toml::from_str("[t]\nfailures = []\n").unwrap();
    let k = sim_host::campaign::spec::KList::Many(vec![1, 2]);
    let drawn = disperse("t.failures", Distribution::KOfN { n: 8, k, item: Some("thruster".into()) }, &mut v, 0);
    let items = v["t"]["failures"].as_array().unwrap();
    assert_eq!(items.len(), drawn.as_array().unwrap().len());
    assert!(items.iter().all(|i| i["thruster"].as_integer().is_some()));
}

/// Scalar distributions against their closed forms: truncated normal on [-1, 1] sd has
/// variance 1 - 2 phi(1) / (2 Phi(1) - 1) = 0.291125; lognormal median e^mu; uniform mean.
#[test]
fn scalar_draws_match_closed_forms() {
    let n = 40_000;
    let mut rng = draw::stream(5, 0, "x");
    let tn = Distribution::TruncatedNormal { mean: 2.0, sd: 0.5, low: 1.5, high: 2.5 };
    let xs: Vec<f64> = (0..n).map(|_| draw::scalar(&tn, &mut rng).unwrap()).collect();
    assert!(xs.iter().all(|x| (1.5..=2.5).contains(x)));
    let mean = xs.iter().sum::<f64>() / n as f64;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    // sd of the sample variance ~ 0.25 * 0.29 * sqrt(2/n) ~ 5e-4 (generous: 5 sigma).
    assert!((var - 0.25 * 0.291_125).abs() < 2.5e-3, "var {var}");
    assert!((mean - 2.0).abs() < 5e-3);
    let ln = Distribution::Lognormal { mu: 0.5, sigma: 0.3 };
    let mut ys: Vec<f64> = (0..n).map(|_| draw::scalar(&ln, &mut rng).unwrap()).collect();
    ys.sort_by(f64::total_cmp);
    assert!((ys[n / 2] / 0.5f64.exp() - 1.0).abs() < 0.01);
    let u = Distribution::Uniform { low: -1.0, high: 3.0 };
    let m = (0..n).map(|_| draw::scalar(&u, &mut rng).unwrap()).sum::<f64>() / n as f64;
    assert!((m - 1.0).abs() < 0.03);
}

/// A dispersion that makes some inertias invalid: those runs end in error with the reason,
/// the others fly, the merge lists the errors and fails the campaign.
#[test]
fn runs_in_error_are_reported_and_the_campaign_goes_on() {
    let t = tempfile::tempdir().unwrap();
    // Izz = 5.8 scaled by up to 1.5 breaks Izz <= Ixx + Iyy = 6.2 above 1.069.
    let extra = r#"
[[dispersion]]
key = "spacecraft.inertia_kgm2[2][2]"
dist = { type = "uniform", low = 0.5, high = 1.5 }
apply = "scale"
[[requirement]]
key = "final_error_deg"
op = "<"
value = 0.1
"#;
    let f = campaign_file(t.path(), &test3(), 24, extra);
    let dir = t.path().join("c");
    let m = campaign::plan(&Campaign::load(&f).unwrap(), &dir, None).unwrap();
    let r = campaign::run_shard(&dir, Shard::ALL, 2, false).unwrap();
    let invalid: Vec<u32> = m
        .runs
        .iter()
        .filter(|run| 5.8 * run.draws["spacecraft.inertia_kgm2[2][2]"].as_f64().unwrap() > 6.2)
        .map(|run| run.index)
        .collect();
    assert!(!invalid.is_empty() && invalid.len() < 24);
    assert_eq!(r.errors, invalid.len());
    assert_eq!(r.ok + r.errors, 24);
    let out = campaign::merge(&dir, false).unwrap();
    let errs: Vec<u32> = out.result.errors.iter().map(|e| e.run).collect();
    assert_eq!(errs, invalid);
    assert!(out.result.errors.iter().all(|e| e.message.contains("inertia")), "{:?}", out.result.errors);
    assert!(!out.result.passed());
    assert_eq!(out.result.requirements[0].failed_runs, invalid);
    // The CLI says so with its exit status.
    let st = sim_host().args(["campaign", "merge", "--no-plots"]).arg(&dir).output().unwrap();
    assert!(!st.status.success());
}

/// A shard killed mid-way and run again completes the campaign without repeating the
/// runs that had finished (their result files are untouched).
#[test]
fn a_killed_shard_resumes_without_repeating_finished_runs() {
    let t = tempfile::tempdir().unwrap();
    // A slower base (200 s of flight, ~15 ms a run) so that the kill lands mid-way.
    let base_text = std::fs::read_to_string(test3()).unwrap().replace("duration_s = 30.0", "duration_s = 200.0");
    let base = t.path().join("base.toml");
    std::fs::write(&base, base_text).unwrap();
    let f = campaign_file(t.path(), &base, 200, TEST3_DISPERSIONS);
    let dir = t.path().join("c");
    let m = campaign::plan(&Campaign::load(&f).unwrap(), &dir, None).unwrap();
    let results = |m: &Manifest| -> BTreeMap<u32, std::fs::Metadata> {
        m.runs
            .iter()
            .filter_map(|r| {
                std::fs::metadata(dir.join(&r.scenario).with_file_name("result.json")).ok().map(|md| (r.index, md))
            })
            .collect()
    };
    let mut child = sim_host().args(["campaign", "run", "--jobs", "1", "-q"]).arg(&dir).spawn().unwrap();
    let start = std::time::Instant::now();
    while results(&m).len() < 20 {
        assert!(start.elapsed().as_secs() < 60, "no progress");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let before = results(&m);
    assert!(before.len() >= 20 && before.len() < 200, "{} done before the kill", before.len());
    let out = sim_host().args(["campaign", "run", "--jobs", "2", "-q"]).arg(&dir).output().unwrap();
    assert!(out.status.success());
    let line = String::from_utf8_lossy(&out.stdout);
    assert!(line.contains(&format!("{} already done, ran {}", before.len(), 200 - before.len())), "{line}");
    let after = results(&m);
    assert_eq!(after.len(), 200);
    for (i, md) in &before {
        assert_eq!(md.modified().unwrap(), after[i].modified().unwrap(), "run {i} was run again");
    }
    // No temporary file is left behind by the kill or the resume.
    let leftovers = all_files(&dir).into_keys().filter(|p| p.to_string_lossy().contains(".tmp-")).count();
    assert!(leftovers <= 1, "{leftovers} temporary files");
    let merged = campaign::merge(&dir, false).unwrap();
    assert!(merged.result.missing.is_empty());
    assert_eq!(merged.result.completed, 200);
}

/// Few runs cannot demonstrate 99 %: the verdict says how many would; missing runs fail
/// the merge and are listed.
#[test]
fn verdicts_follow_the_binomial_bounds_and_missing_runs_fail() {
    let t = tempfile::tempdir().unwrap();
    let extra = r#"
[[requirement]]
name = "settles"
key = "settle_time_s"
op = "<"
value = 15.0
probability = 0.99
[[requirement]]
name = "every run settles"
key = "settle_time_s"
op = "<"
value = 15.0
"#;
    let f = campaign_file(t.path(), &test3(), 10, &format!("{TEST3_DISPERSIONS}{extra}"));
    let dir = t.path().join("c");
    campaign::plan(&Campaign::load(&f).unwrap(), &dir, None).unwrap();
    campaign::run_shard(&dir, Shard { index: 0, count: 2 }, 1, false).unwrap();
    let half = campaign::merge(&dir, false).unwrap().result;
    assert_eq!(half.missing, vec![1, 3, 5, 7, 9]);
    assert!(!half.passed());
    campaign::run_shard(&dir, Shard { index: 1, count: 2 }, 1, false).unwrap();
    let r = campaign::merge(&dir, true).unwrap().result;
    assert!(r.missing.is_empty());
    let q = &r.requirements[0];
    assert_eq!((q.passed, q.runs), (10, 10));
    assert_eq!(q.verdict, Verdict::NotDemonstrated);
    assert!(q.statement.contains("299 runs"), "{}", q.statement);
    assert!((q.clopper_pearson_lower - 0.05f64.powf(0.1)).abs() < 1e-9);
    assert_eq!(r.requirements[1].verdict, Verdict::Met);
    assert!(!r.passed());
    assert!(dir.join("plots/settle_time_s.png").exists());
    let rec = campaign::RunRecord::load(&dir, &Manifest::load(&dir).unwrap().runs[4]).unwrap();
    assert_eq!(rec.status, RunStatus::Ok);
}

/// The shipped thruster-failure campaign (paper 004): the merge singles out, among the
/// drawn single and double failures, exactly those that the attainable-moment analysis
/// says lose three-axis authority (computed here from the layout, not copied), and every
/// one of them was drawn.
#[test]
fn the_thruster_failure_campaign_singles_out_the_authority_losing_pairs() {
    let t = tempfile::tempdir().unwrap();
    let f = repo().join("campaigns/paper004-thruster-failures.toml");
    let c = Campaign::load(&f).unwrap();
    let m = campaign::plan(&c, t.path(), None).unwrap();
    assert_eq!(m.runs.len(), 300);
    campaign::run_shard(t.path(), Shard::ALL, 2, false).unwrap();
    let r = campaign::merge(t.path(), false).unwrap().result;
    assert!(r.errors.is_empty() && r.missing.is_empty());

    let base = Scenario::load(&c.base_path).unwrap();
    let b = base.thruster_set().unwrap().torque_matrix();
    let table = sim_host::analysis::thrusters::failure_table(&b, &vec![1.0; b.len()], 2);
    let lost: Vec<Vec<u64>> =
        table.lost.iter().map(|s| s.iter().map(|i| *i as u64).collect()).filter(|s: &Vec<u64>| s.len() <= 2).collect();
    assert_eq!(lost.len(), 4, "{lost:?}");

    let group = r.groups.iter().find(|g| g.key == "actuators.thrusters.failures").unwrap();
    let mask =
        |v: &serde_json::Value| -> Vec<u64> { v.as_array().unwrap().iter().map(|x| x.as_u64().unwrap()).collect() };
    let name = &r.requirements[0].requirement.name;
    let mut failing = Vec::new();
    for row in &group.rows {
        let missed = row.failed[name];
        // A mask fails in all of its runs or in none (the initial attitude does not decide).
        assert!(missed == 0 || missed == row.runs, "{:?}: {missed}/{} runs missed", row.value, row.runs);
        if missed > 0 {
            failing.push(mask(&row.value));
        }
    }
    failing.sort();
    let mut want = lost.clone();
    want.sort();
    assert_eq!(failing, want);
    assert_eq!(group.rows.len(), 36, "every single and double mask drawn");
}

/// A `[[faults]]` entry's keys are dispersed like any key (issue 42): the planned runs
/// carry the drawn onset, parsed into the typed fault.
#[test]
fn a_campaign_disperses_a_fault_onset() {
    let t = tempfile::tempdir().unwrap();
    let base = t.path().join("base.toml");
    let text = std::fs::read_to_string(test3()).unwrap()
        + "\n[[faults]]\nonset_s = 1.0\nunit = \"gyro.x\"\nkind = \"bias_step\"\nmagnitude = 0.001\n";
    std::fs::write(&base, text).unwrap();
    let d = "[[dispersion]]\nkey = \"faults[0].onset_s\"\ndist = { type = \"uniform\", low = 2.0, high = 8.0 }\n";
    let m = campaign::plan(&Campaign::load(&campaign_file(t.path(), &base, 20, d)).unwrap(), t.path(), None).unwrap();
    let mut onsets = Vec::new();
    for run in &m.runs {
        let sc = Scenario::load(&t.path().join(&run.scenario)).unwrap();
        let f = sc.faults().unwrap();
        let drawn = run.draws["faults[0].onset_s"].as_f64().unwrap();
        assert_eq!(f[0].window.onset_s, drawn);
        assert!((2.0..=8.0).contains(&drawn), "{drawn}");
        assert_eq!(
            (f[0].fault.unit(), f[0].fault.kind(), f[0].fault.magnitude()),
            ("gyro.x".into(), "bias_step", Some(0.001))
        );
        onsets.push(drawn);
    }
    // Drawn, not copied: 20 distinct onsets.
    onsets.sort_by(f64::total_cmp);
    onsets.dedup();
    assert_eq!(onsets.len(), 20);
}
