//! Issue 21, findings 4 and 5: what `sim-host check` accepts, the flight code accepts.
//! Each input below used to pass `check` (and then run with every step refused, run into
//! a flight-side `ParamError` that named no key, silently drop array elements, or run
//! unbounded); each is now refused by `check` with exit 1 and a message naming the key.
//! Every refusal has its accepted neighbour (the shipped value, or the value at the limit)
//! so a test cannot pass by refusing everything.

use acs_flight::validation::{MAX_GIMBAL_ANGLE_RAD, MAX_RATE_RAD_S};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn check(path: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sim-host")).args(["check", path.to_str().unwrap()]).output().unwrap()
}

/// `check` of the shipped scenario `base` with `from` replaced by `to`: exit code and
/// stderr.
fn check_edit(base: &str, from: &str, to: &str) -> (Option<i32>, String) {
    check_edits(base, &[(from, to)])
}

fn check_edits(base: &str, edits: &[(&str, &str)]) -> (Option<i32>, String) {
    let mut text = std::fs::read_to_string(repo().join("scenarios").join(base)).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{base}: {from}");
        text = text.replacen(from, to, 1);
    }
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("sc.toml");
    std::fs::write(&p, text).unwrap();
    let r = check(&p);
    (r.status.code(), String::from_utf8_lossy(&r.stderr).into_owned())
}

fn refused(base: &str, from: &str, to: &str, key: &str, also: &str) {
    let (code, err) = check_edit(base, from, to);
    assert_eq!(code, Some(1), "{to}: {err}");
    assert!(err.contains(key) && err.contains(also), "{to}: expected `{key}` and `{also}` in: {err}");
}

fn accepted(base: &str, from: &str, to: &str) {
    let (code, err) = check_edit(base, from, to);
    assert_eq!(code, Some(0), "{to}: {err}");
}

const P0: &str = "paper000/test3.toml";
const GIMBALS: &str = "initial_gimbal_deg = [0.0, 0.0, 0.0, 0.0]";
const SENSORS: &str = "[sensors]\n";

#[test]
fn values_the_flight_input_validation_refuses_on_every_step_are_refused_naming_the_key() {
    refused(P0, GIMBALS, "initial_gimbal_deg = [60000.0, 0, 0, 0]", "actuators.cmg.initial_gimbal_deg", "");
    let inside = (f64::from(MAX_GIMBAL_ANGLE_RAD).to_degrees() * 0.999).floor();
    accepted(P0, GIMBALS, &format!("initial_gimbal_deg = [{inside}, 0, 0, 0]"));
    let rate = "rate_rad_s = [0.0, 0.0, 0.0]";
    refused(P0, rate, "rate_rad_s = [1e30, 0, 0]", "initial.rate_rad_s", "");
    let w = f64::from(MAX_RATE_RAD_S);
    accepted(P0, rate, &format!("rate_rad_s = [{w}, 0, 0]"));
    refused(P0, rate, &format!("rate_rad_s = [0, {}, 0]", w * 1.001), "initial.rate_rad_s", "");
    for (k, ok) in [("attitude_noise_deg", "2.0"), ("rate_noise_rad_s", "0.01"), ("magnetometer_noise_t", "1e-7")] {
        refused(P0, SENSORS, &format!("[sensors]\n{k} = 1e30\n"), &format!("sensors.{k}"), "");
        accepted(P0, SENSORS, &format!("[sensors]\n{k} = {ok}\n"));
    }
}

#[test]
fn flight_parameter_refusals_name_the_key_in_check_and_run() {
    let base = "estimation/mekf-hold.toml";
    let from = "tracker_sigma_cross_deg = 0.002";
    refused(base, from, "tracker_sigma_cross_deg = 720", "estimation.tracker_sigma_cross_deg = 720", "out of range");
    refused(base, from, "tracker_sigma_cross_deg = 0", "estimation.tracker_sigma_cross_deg", "out of range (0,");
    accepted(base, from, "tracker_sigma_cross_deg = 180");
    // `run` loads through the same validation: refused before the first step.
    let text = std::fs::read_to_string(repo().join("scenarios").join(base)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("sc.toml");
    std::fs::write(&p, text.replace(from, "tracker_sigma_cross_deg = 720")).unwrap();
    let out = dir.path().join("out");
    let r = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(["run", p.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-plots", "--quiet"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(err.contains("estimation.tracker_sigma_cross_deg") && !err.contains("ParamError"), "{err}");
    // A controller value the flight code refuses names its key.
    refused(
        P0,
        "torque_limit_nm = [10.0, 10.0, 10.0]",
        "torque_limit_nm = [10.0, 10.0, 1e12]",
        "controller.torque_limit_nm",
        "",
    );
    refused(P0, "h0_nms = 0.623", "h0_nms = 1e30", "actuators.cmg.h0_nms", "");
}

#[test]
fn arrays_must_have_exactly_their_length() {
    let inertia = "inertia_kgm2 = [[3.1, 0.0, 0.0], [0.0, 3.1, 0.0], [0.0, 0.0, 5.8]]";
    let long_row = "inertia_kgm2 = [[3.1, 0.0, 0.0, 99.0], [0.0, 3.1, 0.0], [0.0, 0.0, 5.8]]";
    refused(P0, inertia, long_row, "spacecraft.inertia_kgm2[0]", "has 4 elements, expected 3");
    refused(P0, GIMBALS, "initial_gimbal_deg = [0, 0, 0, 0, 0]", "actuators.cmg.initial_gimbal_deg", "expected 4");
    let huge = format!("initial_gimbal_deg = [{}]", vec!["0"; 100_000].join(", "));
    refused(P0, GIMBALS, &huge, "actuators.cmg.initial_gimbal_deg", "has 100000 elements, expected 4");
    let css = "[0, 0, 1], [0, 0, -1]]";
    let base = "estimation/sun-safe-from-tumble.toml";
    refused(base, css, "[0, 0, 1], [0, 0, -1, 5]]", "sensors.css.normals_body[5]", "has 4 elements, expected 3");
    // A short array was always refused by the reader; it still is, naming the key.
    refused(P0, GIMBALS, "initial_gimbal_deg = [0, 0, 0]", "initial_gimbal_deg", "");
    // Inside tables the reader takes whole (`[controller]` with its `type` tag, `[initial]`
    // with its flattened attitude) the reader named only the table; now the key.
    let torque = "torque_limit_nm = [10.0, 10.0, 10.0]";
    refused(P0, torque, "torque_limit_nm = [10.0, 10.0]", "`controller.torque_limit_nm`", "length");
    refused(P0, torque, "torque_limit_nm = [10.0, 10.0, \"x\"]", "`controller.torque_limit_nm`", "string");
    let euler = "euler_deg = [2.47, ";
    refused(P0, euler, "euler_deg = [\"x\", ", "`initial.euler_deg`", "string");
    accepted(P0, euler, "euler_deg = [1.0, ");
    let (code, err) = check_edit(P0, "rate_rad_s = [0.0, 0.0, 0.0]", "rate_rad_s = [0.0, 0.0, 0.0, 0.0]");
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("`initial.rate_rad_s`") && err.contains("expected 3"), "{err}");
}

#[test]
fn the_clock_keys_have_ranges() {
    let sub = "dynamics_substeps = 1 ";
    refused(P0, sub, "dynamics_substeps = 1000000000 ", "timing.dynamics_substeps", "1..=1000");
    refused(P0, sub, "dynamics_substeps = 1001 ", "timing.dynamics_substeps", "1..=1000");
    refused(P0, sub, "dynamics_substeps = 0 ", "timing.dynamics_substeps", "1..=1000");
    accepted(P0, sub, "dynamics_substeps = 1000 ");
    // 30 s at 100 Hz = 3000 steps: at 1000 substeps 3e6 RK4 steps (accepted above). 1e6 s
    // is 1e8 steps: accepted at 1 substep (1e8 RK4 steps), refused at 1000 (1e11 > 1e9).
    let d = "duration_s = 30.0";
    accepted(P0, d, "duration_s = 1e6");
    let (code, err) = check_edits(P0, &[(d, "duration_s = 1e6"), (sub, "dynamics_substeps = 1000 ")]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("duration_s") && err.contains("RK4 steps"), "{err}");
    // Shorter than one 10 ms control period: refused; exactly one: accepted.
    refused(P0, d, "duration_s = 1e-9", "duration_s", "less than one control period");
    refused(P0, d, "duration_s = 0.004", "duration_s", "less than one control period");
    accepted(P0, d, "duration_s = 0.01");
}

#[test]
fn an_endless_input_file_is_refused_quickly_naming_it() {
    if !Path::new("/dev/zero").exists() {
        return;
    }
    let t0 = Instant::now();
    let r = check(Path::new("/dev/zero"));
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(err.contains("/dev/zero") && err.contains("16 MiB"), "{err}");
    assert!(t0.elapsed() < Duration::from_secs(20), "took {:?}", t0.elapsed());
    // A campaign file is read with the same cap.
    let t0 = Instant::now();
    let out = tempfile::tempdir().unwrap();
    let r = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(["campaign", "plan", "/dev/zero", "--out"])
        .arg(out.path().join("c"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(err.contains("/dev/zero") && err.contains("16 MiB"), "{err}");
    assert!(t0.elapsed() < Duration::from_secs(20), "took {:?}", t0.elapsed());
}

/// Issue 21 finding 1's inputs that drove the plant to NaN: refused by their documented
/// range (1e30) or by the f32 range every number must fit (1e300), naming the key; the
/// shipped values pass.
#[test]
fn disturbance_and_orbit_keys_have_ranges() {
    let base = "paper003/orbit-mtq-hold.toml";
    let text = std::fs::read_to_string(repo().join("scenarios").join(base)).unwrap();
    for (from, key) in [
        ("cp_offset_m = [0.0, 0.0, 0.01]", "spacecraft.cp_offset_m"),
        ("drag_area_m2 = 0.034", "spacecraft.drag_area_m2"),
        ("residual_dipole_am2 = [0.0, 0.0, 0.001]", "spacecraft.residual_dipole_am2"),
        ("altitude_km = 617.0", "orbit.altitude_km"),
        ("density_kg_m3 = 1.68e-14", "environment.density_kg_m3"),
    ] {
        assert!(text.contains(from), "{from}");
        let (name, _) = from.split_once(" = ").unwrap();
        for x in ["1e30", "1e300", "nan"] {
            let to = if from.contains('[') { format!("{name} = [{x}, 0.0, 0.0]") } else { format!("{name} = {x}") };
            refused(base, from, &to, key, "");
        }
    }
    accepted(base, "duration_s", "duration_s");
    // The keys this scenario lacks, added to paper 000 test 3.
    for (add, key) in [
        ("external_torque_nm = [1e30, 0, 0]", "spacecraft.external_torque_nm"),
        ("external_torque_nm = [1e300, 0, 0]", "spacecraft.external_torque_nm"),
    ] {
        refused(P0, "[spacecraft]\n", &format!("[spacecraft]\n{add}\n"), key, "");
    }
    accepted(P0, "[spacecraft]\n", "[spacecraft]\nexternal_torque_nm = [1e-3, 0, 0]\n");
}

/// Issue 22: an ideal wheel has no default size (a small spacecraft must not silently get
/// paper 001's 0.75 N m wheel); the accurate model keeps the wheel its data belong to.
#[test]
fn ideal_wheels_must_be_sized() {
    const HOLD: &str = "estimation/mekf-hold.toml";
    for key in ["max_torque_nm = 2.3e-4", "max_speed_rpm = 10000.0", "inertia_kgm2 = 1.6e-6"] {
        let name = key.split(' ').next().unwrap();
        refused(HOLD, key, "", &format!("actuators.wheels.{name}"), "required for model = \"ideal\"");
    }
    accepted(HOLD, "max_torque_nm = 2.3e-4", "max_torque_nm = 2.3e-4");
    // paper 001's accurate wheel needs none of the three.
    let (code, err) = check_edit("paper001/wheel-slew.toml", "model = \"accurate\"", "model = \"accurate\"");
    assert_eq!(code, Some(0), "{err}");
}
