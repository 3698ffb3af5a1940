//! `[[faults]]` (issue 42): each injected fault against its closed form.
//!
//! Actuators fly through the whole run loop (`Simulation`, open loop, free space: no
//! external torque), so the injection path of a run is the one tested. Sensors are driven
//! through the suite the run builds (`Resolved::sensors` with `set_faults`, the call the
//! run makes) on a truth given in closed form (a constant-rate rotation), so measured and
//! true are compared sample by sample.

use nalgebra::{Unit, UnitQuaternion};
use sim_core::attitude::{Quat, Vec3, from_xyzw};
use sim_core::faults::MAX_FAULTS;
use sim_core::link::in_process::InProcess;
use sim_core::plant::wheel::WheelState;
use sim_core::plant::{MAX_GIMBALS, MAX_WHEELS, State};
use sim_core::recorder::series::Discard;
use sim_core::scenario::{Resolved, Scenario};
use sim_core::simulation::Simulation;

const BASE: &str = r#"
name = "faults"
duration_s = 6.0
[timing]
control_rate_hz = 10.0
dynamics_substeps = 4
[spacecraft]
inertia_kgm2 = [[0.5, 0, 0], [0, 0.6, 0], [0, 0, 0.4]]
[initial]
euler_deg = [10, -20, 30]
rate_rad_s = [0.01, -0.02, 0.015]
[target]
euler_deg = [0, 0, 0]
[actuators.wheels]
layout = "pyramid4"
model = "ideal"
max_torque_nm = 0.01
max_speed_rpm = 6000.0
inertia_kgm2 = 1e-4
initial_speed_rpm = [1500.0, -500.0, 1000.0, 300.0]
[actuators.magnetorquers]
max_dipole_am2 = [0.2, 0.2, 0.2]
[environment]
lab_field_t = [2e-5, -1e-5, 3e-5]
[controller]
type = "none"
[open_loop]
commands = [{ t_s = 0.0, wheel_torque_nm = [0.004, -0.003, 0.002, 0.001] }]
[sensors]
seed = 42
wheel_speed_noise_rad_s = 0.01
[sensors.gyro]
rate_hz = 10.0
arw_rad_sqrt_s = 1e-4
[sensors.star_tracker]
rate_hz = 10.0
noise_cross_deg = 0.01
noise_about_deg = 0.05
boresight_body = [0.6, 0.0, 0.8]
"#;

/// Commanded wheel torques of `BASE`, N m, as the f32 of the wire carries them.
const CMD_NM: [f64; 4] = [0.004f32 as f64, -0.003f32 as f64, 0.002f32 as f64, 0.001f32 as f64];
const I_W: f64 = 1e-4;
const MAX_TORQUE_NM: f64 = 0.01;
const DT: f64 = 0.1;

/// `BASE` with the torquers commanded to [0.1, -0.05, 0.08] A m² (the others fly with the
/// rods off: no external torque).
fn with_dipole(faults: &str) -> Scenario {
    let text = BASE.replace("0.002, 0.001] }", "0.002, 0.001], dipole_am2 = [0.1, -0.05, 0.08] }");
    Scenario::from_toml(&format!("{text}{faults}")).unwrap()
}

fn scenario(faults: &str) -> Scenario {
    Scenario::from_toml(&format!("{BASE}{faults}")).unwrap()
}

fn err_of(faults: &str) -> String {
    format!("{:#}", Scenario::from_toml(&format!("{BASE}{faults}")).unwrap_err())
}

/// The plant state at every control step (t = k DT) and the summary.
fn fly(sc: &Scenario) -> (Vec<State>, sim_core::recorder::summary::Summary) {
    let mut link = InProcess::new();
    let mut sim = Simulation::new(Resolved::try_from(sc).unwrap(), &mut link).unwrap();
    let mut states = Vec::new();
    while !sim.finished() {
        states.push(*sim.state());
        sim.step(&mut Discard).unwrap();
    }
    (states, sim.summary(1.0))
}

/// Absolute (inertial axial) speed of each wheel, `h_a / I_w`, rad/s.
fn abs_speed(s: &State, i: usize) -> f64 {
    s.wheels[i].h_abs_nms / I_W
}

#[test]
fn absent_faults_add_nothing_and_entries_are_typed() {
    let sc = scenario("");
    assert!(sc.faults().unwrap().is_empty());
    let names = sim_core::simulation::column_names(&sc, 4, 0);
    assert!(!names.iter().any(|n| n == "fault_active"));
    let (_, s) = fly(&sc);
    assert!(s.faults.is_none());
    let sc = scenario("[[faults]]\nonset_s = 1.0\nunit = \"wheel.3\"\nkind = \"torque_gain\"\nmagnitude = 0.5\n");
    let f = sc.faults().unwrap();
    assert_eq!(
        (f[0].fault.unit(), f[0].fault.kind(), f[0].fault.magnitude()),
        ("wheel.3".into(), "torque_gain", Some(0.5))
    );
}

#[test]
fn invalid_entries_are_refused_naming_the_key() {
    let entry = |unit: &str, kind: &str, more: &str| {
        format!("[[faults]]\nonset_s = 1.0\nunit = \"{unit}\"\nkind = \"{kind}\"\n{more}\n")
    };
    let cases = [
        (entry("wheel.4", "stuck", ""), "faults[0].unit", "wheel.0 to wheel.3"),
        (entry("wheel.x", "stuck", ""), "faults[0].unit", "0-based"),
        (entry("reactor.1", "stuck", ""), "faults[0].unit", "unknown unit"),
        (entry("gyro.w", "stuck", ""), "faults[0].unit", "gyro.x"),
        (entry("cmg.0", "gimbal_stuck", ""), "faults[0].unit", "no cmg (no [actuators.cmg])"),
        (entry("thruster.0", "stuck_open", ""), "faults[0].unit", "no thruster (no [actuators.thrusters])"),
        (entry("magnetorquer.3", "open", ""), "faults[0].unit", "magnetorquer.0 to magnetorquer.2"),
        (entry("wheel.1", "flip", ""), "faults[0].kind", "not a fault of wheel.1"),
        (entry("star_tracker", "stuck", ""), "faults[0].kind", "\"flip\", \"frozen\""),
        (entry("wheel.1", "torque_gain", "magnitude = 1.5"), "faults[0].magnitude", "out of range"),
        (entry("wheel.1", "torque_gain", ""), "faults[0].magnitude", "required"),
        (entry("wheel.1", "runaway", "magnitude = 0.5"), "faults[0].magnitude", "1 or -1"),
        (entry("gyro.z", "bias_step", "magnitude = 2.0"), "faults[0].magnitude", "out of range"),
        (entry("wheel.1", "stuck", "magnitude = 1.0"), "faults[0].magnitude", "takes no magnitude"),
        (entry("wheel.1", "stuck", "end_s = 0.5"), "faults[0].end_s", "> onset_s"),
        (entry("wheel.1", "stuck", "typo = 1"), "typo", "unknown field"),
        (entry("gyro.x", "noise", "magnitude = 0.5"), "faults[0].magnitude", "out of range"),
        (entry("gyro.x", "noise", ""), "faults[0].magnitude", "required"),
        (entry("gyro.y", "saturation", "magnitude = -0.1"), "faults[0].magnitude", "out of range"),
        (entry("gyro.y", "saturation", "magnitude = 60.0"), "faults[0].magnitude", "out of range"),
        (entry("gyro.w", "saturation", "magnitude = 0.1"), "faults[0].unit", "gyro.x"),
        (entry("gyro.z", "noisy", ""), "faults[0].kind", "\"noise\", \"saturation\""),
        (entry("css.0", "dead", ""), "faults[0].unit", "no css (no [sensors.css])"),
        (entry("gnss", "position_jump", "magnitude = 100.0"), "faults[0].unit", "no GNSS fix (no [orbit])"),
        (entry("gnss.0", "position_jump", "magnitude = 100.0"), "faults[0].unit", "unknown unit"),
        (entry("wheel.4", "power_off", ""), "faults[0].unit", "wheel.0 to wheel.3"),
        (entry("wheel.1", "power_off", "magnitude = 1.0"), "faults[0].magnitude", "takes no magnitude"),
        (entry("wheel.1", "tach_noise", "magnitude = 0.5"), "faults[0].magnitude", "out of range"),
        (entry("wheel.1", "tach_noise", ""), "faults[0].magnitude", "required"),
        (entry("wheel.1", "explode", ""), "faults[0].kind", "\"power_off\", \"tach_noise\", \"friction\""),
        (entry("wheel.1", "friction", "magnitude = 2.0"), "faults[0].kind", "no friction to scale"),
        (entry("magnetometer", "stuck", ""), "faults[0].unit", "magnetometer.x, magnetometer.y or magnetometer.z"),
        (entry("magnetometer.w", "bias", "magnitude = 1e-6"), "faults[0].unit", "magnetometer.x"),
        (entry("magnetometer.x", "flip", ""), "faults[0].kind", "\"stuck\", \"bias\""),
        (entry("magnetometer.y", "bias", "magnitude = 0.02"), "faults[0].magnitude", "out of range"),
        (entry("magnetometer.y", "bias", "magnitude = nan"), "faults[0].magnitude", "must be finite"),
        (entry("magnetometer.y", "bias", ""), "faults[0].magnitude", "required"),
        (entry("magnetometer.z", "stuck", "magnitude = 1e-6"), "faults[0].magnitude", "takes no magnitude"),
    ];
    for (text, key, why) in &cases {
        let e = err_of(text);
        assert!(e.contains(key) && e.contains(why), "expected {key} / {why} in: {e}");
    }
    let e = err_of("[[faults]]\nonset_s = -1.0\nunit = \"wheel.1\"\nkind = \"stuck\"\n");
    assert!(e.contains("faults[0].onset_s") && e.contains(">= 0"), "{e}");
    // The second entry is named by its own index.
    let e = err_of(&(entry("wheel.1", "stuck", "") + &entry("gyro.q", "stuck", "")));
    assert!(e.contains("faults[1].unit"), "{e}");
    // A spacecraft without torquers has no magnetorquer to fail.
    let text = BASE.replace("[actuators.magnetorquers]\nmax_dipole_am2 = [0.2, 0.2, 0.2]\n", "")
        + &entry("magnetorquer.0", "open", "");
    let e = format!("{:#}", Scenario::from_toml(&text).unwrap_err());
    assert!(e.contains("faults[0].unit") && e.contains("no magnetorquer"), "{e}");
    let many: String = (0..=MAX_FAULTS).map(|_| entry("wheel.0", "stuck", "")).collect();
    assert!(err_of(&many).contains("at most 32"), "{}", err_of(&many));
}

#[test]
fn a_campaign_can_disperse_a_fault_onset_by_key_path() {
    // What the campaign planner does (docs/campaigns.md): parse the base, write every field
    // back, set the dispersed key by path, parse the drawn scenario again.
    let sc = scenario("[[faults]]\nonset_s = 1.0\nunit = \"gyro.y\"\nkind = \"stuck\"\n");
    let mut v = toml::Value::try_from(&sc).unwrap();
    let set = |v: &mut toml::Value, x: f64| {
        let entry = v.get_mut("faults").and_then(|f| f.get_mut(0)).and_then(|e| e.as_table_mut()).unwrap();
        entry.insert("onset_s".into(), toml::Value::Float(x));
    };
    set(&mut v, 3.25);
    let drawn = Scenario::from_toml(&toml::to_string(&v).unwrap()).unwrap();
    assert_eq!(drawn.faults().unwrap()[0].window.onset_s, 3.25);
    set(&mut v, -0.5);
    let e = format!("{:#}", Scenario::from_toml(&toml::to_string(&v).unwrap()).unwrap_err());
    assert!(e.contains("faults[0].onset_s"), "{e}");
}

#[test]
fn a_stuck_wheel_holds_its_speed_and_the_total_momentum_is_conserved() {
    // Onset between control steps: the plant seizes the wheel from the first dynamics step
    // at or after it (2.025 s, a substep boundary at 40 Hz).
    let sc = scenario("[[faults]]\nonset_s = 2.02\nunit = \"wheel.1\"\nkind = \"stuck\"\n");
    let craft = sc.spacecraft().unwrap();
    let (states, summary) = fly(&sc);
    let h0 = craft.angular_momentum_inertial(&states[0]);
    let k_on = 21; // t = 2.1 s: the wheel has been seized since 2.025 s
    let h_stuck = states[k_on].wheels[1].h_abs_nms;
    let mut worst_h = 0.0f64;
    for s in &states[k_on..] {
        // Seized: no axial torque, so its absolute momentum (and inertial speed) stays, to
        // the bit (RK4 adds zeros).
        assert_eq!(s.wheels[1].h_abs_nms, h_stuck);
        worst_h = worst_h.max((craft.angular_momentum_inertial(s) - h0).norm() / h0.norm());
    }
    // The other wheels go on exchanging momentum with the body: ΔH = 0 (free space, no
    // external torque) to RK4 truncation and round-off.
    eprintln!("stuck wheel: largest relative drift of the total angular momentum {worst_h:e}");
    assert!(worst_h < 1e-10, "momentum drift {worst_h:e}");
    let (a, b) = (abs_speed(&states[30], 0), abs_speed(&states[50], 0));
    assert!(((b - a) / 2.0 - CMD_NM[0] / I_W).abs() < 1e-9 * (CMD_NM[0] / I_W));
    // Before the onset the wheel was accelerating at its command.
    let (a, b) = (abs_speed(&states[0], 1), abs_speed(&states[20], 1));
    assert!(((b - a) / 2.0 - CMD_NM[1] / I_W).abs() < 1e-9 * (CMD_NM[1] / I_W).abs());
    let rec = &summary.faults.unwrap()[0];
    assert_eq!(
        (rec.unit.as_str(), rec.kind, rec.injected_at_s, rec.detected_at_s),
        ("wheel.1", "stuck", Some(2.1), None)
    );
}

#[test]
fn torque_gain_and_runaway_set_the_wheel_acceleration() {
    let g = 0.4;
    let sc = scenario(&format!(
        "[[faults]]\nonset_s = 2.0\nunit = \"wheel.0\"\nkind = \"torque_gain\"\nmagnitude = {g}\n\
         [[faults]]\nonset_s = 2.0\nunit = \"wheel.2\"\nkind = \"runaway\"\nmagnitude = -1.0\nend_s = 4.0\n"
    ));
    let (states, summary) = fly(&sc);
    // dω/dt of the absolute speed = ḣ_a / I_w = the torque the motor delivers / I_w (ideal
    // wheel far below its speed band: no fade), per control step.
    let accel = |i: usize, k: usize| (abs_speed(&states[k + 1], i) - abs_speed(&states[k], i)) / DT;
    let close = |x: f64, want: f64| (x - want).abs() < 1e-9 * want.abs();
    for k in 0..states.len() - 1 {
        let t = k as f64 * DT;
        let want0 = if t >= 2.0 - 1e-9 { g * CMD_NM[0] } else { CMD_NM[0] } / I_W;
        assert!(close(accel(0, k), want0), "wheel 0 at {t}: {} vs {want0}", accel(0, k));
        let runaway = (2.0 - 1e-9..4.0 - 1e-9).contains(&t);
        let want2 = if runaway { -MAX_TORQUE_NM } else { CMD_NM[2] } / I_W;
        assert!(close(accel(2, k), want2), "wheel 2 at {t}: {} vs {want2}", accel(2, k));
        assert!(close(accel(3, k), CMD_NM[3] / I_W), "healthy wheel 3 at {t}");
    }
    let recs = summary.faults.unwrap();
    assert_eq!((recs[1].kind, recs[1].magnitude, recs[1].end_s), ("runaway", Some(-1.0), Some(4.0)));
}

#[test]
fn fault_active_is_the_bitmask_of_the_entries_in_force() {
    let sc = scenario(
        "[[faults]]\nonset_s = 1.0\nunit = \"wheel.0\"\nkind = \"tach_stuck\"\nend_s = 3.0\n\
         [[faults]]\nonset_s = 2.0\nunit = \"gyro.x\"\nkind = \"stuck\"\n",
    );
    let r = sim_core::runner::run(&sc, &mut InProcess::new(), false).unwrap();
    let (t, m) = (r.series.col("t_s").unwrap(), r.series.col("fault_active").unwrap());
    for (t, m) in t.iter().zip(m) {
        let want = u32::from((1.0..3.0).contains(&(t + 1e-9))) | (u32::from(*t >= 2.0 - 1e-9) << 1);
        assert_eq!(*m, f64::from(want), "t = {t}");
    }
    let recs = r.summary.faults.unwrap();
    assert_eq!((recs[0].injected_at_s, recs[1].injected_at_s), (Some(1.0), Some(2.0)));
}

#[test]
fn an_open_rod_gives_no_dipole_and_a_reversed_rod_the_negative() {
    let sc = with_dipole(
        "[[faults]]\nonset_s = 1.0\nunit = \"magnetorquer.0\"\nkind = \"open\"\n\
         [[faults]]\nonset_s = 2.0\nunit = \"magnetorquer.1\"\nkind = \"reversed\"\n",
    );
    let r = sim_core::runner::run(&sc, &mut InProcess::new(), false).unwrap();
    let c = |n: &str| r.series.col(n).unwrap();
    let (t, x, y, z) = (c("t_s"), c("dipole_x_am2"), c("dipole_y_am2"), c("dipole_z_am2"));
    for k in 0..t.len() {
        // Commanded [0.1, -0.05, 0.08] A m² (f32 on the wire), inside the rods' ±0.2:
        // realised as commanded.
        let cmd = [0.1f32, -0.05, 0.08].map(f64::from);
        assert_eq!(x[k], if t[k] >= 1.0 - 1e-9 { 0.0 } else { cmd[0] }, "t = {}", t[k]);
        assert_eq!(y[k], if t[k] >= 2.0 - 1e-9 { -cmd[1] } else { cmd[1] }, "t = {}", t[k]);
        assert_eq!(z[k], cmd[2]);
        assert_eq!(c("dipole_cmd_x_am2")[k], cmd[0]);
    }
}

// --- sensors, on a closed-form truth ---

/// Body rate of the closed-form truth, rad/s, and its attitude at `t`:
/// `q(t) = q0 ⊗ exp(ω t / 2)` (constant body rate).
const W_TRUE: [f64; 3] = [0.02, -0.03, 0.05];

fn truth_q(t: f64) -> Quat {
    let q0 = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
    (q0 * UnitQuaternion::from_scaled_axis(Vec3::from(W_TRUE) * t)).into_inner()
}

/// The truth at `t`: attitude, rate and wheels whose relative speed ramps at 50 rad/s².
fn truth(t: f64, craft: &sim_core::plant::Spacecraft) -> State {
    let w = Vec3::from(W_TRUE);
    let mut wheels = [WheelState::default(); MAX_WHEELS];
    for (i, p) in craft.wheels.iter().enumerate() {
        let rel = 100.0 + 50.0 * t + 10.0 * i as f64;
        wheels[i].h_abs_nms = p.inertia_kgm2 * (rel + Vec3::from(p.spin_axis).dot(&w));
    }
    State {
        q: truth_q(t),
        w,
        gimbal_rad: [0.0; MAX_GIMBALS],
        gimbal_rate_rad_s: [0.0; MAX_GIMBALS],
        wheels,
        cmg_rotor_scale: sim_core::plant::NOMINAL_ROTORS,
    }
}

/// The frames of 10 s of samples at 10 Hz on the truth, with the scenario's faults.
fn frames(sc: &Scenario) -> Vec<(f64, State, acs_flight::link::SensorFrame)> {
    let r = Resolved::try_from(sc).unwrap();
    let (craft, mut suite) = (r.craft, r.sensors);
    suite.set_faults(&sc.faults().unwrap());
    (0..=100)
        .map(|k| {
            let t = k as f64 * DT;
            let s = truth(t, &craft);
            let f = suite.sample(k, t, &s, &craft, None, &[0.0; 3]);
            (t, s, f)
        })
        .collect()
}

/// Per-sample 1σ of the gyro: ARW × √rate.
const GYRO_SIGMA: f64 = 1e-4 * 3.1622776601683795;

#[test]
fn a_stuck_gyro_axis_repeats_itself_and_the_others_follow_the_truth() {
    let sc = scenario("[[faults]]\nonset_s = 4.0\nunit = \"gyro.y\"\nkind = \"stuck\"\n");
    let fr = frames(&sc);
    let held = fr.iter().find(|(t, ..)| *t >= 4.0 - 1e-9).unwrap().2.rate_rad_s[1];
    let mut y_moved = 0;
    for (t, s, f) in &fr {
        for a in [0, 2] {
            // 5σ per sample (plus f32 rounding of the wire).
            assert!((f.rate_rad_s[a] as f64 - s.w[a]).abs() < 5.0 * GYRO_SIGMA + 1e-7, "axis {a} at {t}");
        }
        if *t >= 4.0 - 1e-9 {
            assert_eq!(f.rate_rad_s[1], held, "at {t}");
            // Its increment is the held rate over the interval (0.1 s).
            assert!((f.gyro_angle_rad[1] as f64 - held as f64 * DT).abs() < 1e-9, "at {t}");
        } else {
            assert!((f.rate_rad_s[1] as f64 - s.w[1]).abs() < 5.0 * GYRO_SIGMA + 1e-7);
            y_moved += usize::from(f.rate_rad_s[1] != held);
        }
    }
    // Healthy, the axis's noise made every reading differ from the later held one.
    assert!(y_moved >= 39, "{y_moved}");
}

#[test]
fn a_gyro_bias_step_shifts_the_mean_error_by_the_step() {
    let step = 2e-3;
    let sc =
        scenario(&format!("[[faults]]\nonset_s = 5.0\nunit = \"gyro.z\"\nkind = \"bias_step\"\nmagnitude = {step}\n"));
    let fr = frames(&sc);
    let mean = |after: bool| {
        let e: Vec<f64> = fr
            .iter()
            .filter(|(t, ..)| (*t >= 5.0 - 1e-9) == after)
            .map(|(_, s, f)| f.rate_rad_s[2] as f64 - s.w[2])
            .collect();
        (e.iter().sum::<f64>() / e.len() as f64, e.len())
    };
    let ((before, n0), (after, n1)) = (mean(false), mean(true));
    // The jump's standard error is σ √(1/n0 + 1/n1); 5 of them.
    let tol = 5.0 * GYRO_SIGMA * (1.0 / n0 as f64 + 1.0 / n1 as f64).sqrt();
    eprintln!("bias step: mean error {before:e} -> {after:e} rad/s (step {step:e}, tol {tol:e})");
    assert!((after - before - step).abs() < tol, "{} vs {step}", after - before);
    // The other axes see no step.
    let x_after: f64 =
        fr.iter().filter(|(t, ..)| *t >= 5.0).map(|(_, s, f)| f.rate_rad_s[0] as f64 - s.w[0]).sum::<f64>() / n1 as f64;
    assert!(x_after.abs() < 5.0 * GYRO_SIGMA / (n1 as f64).sqrt(), "{x_after}");
}

/// Rotation angle between two attitudes, rad.
fn angle_between(a: &Quat, b: &Quat) -> f64 {
    let d = (a.conjugate() * b).normalize();
    2.0 * d.imag().norm().atan2(d.w.abs())
}

fn measured_q(f: &acs_flight::link::SensorFrame) -> Quat {
    from_xyzw(f.q_ib_xyzw.map(f64::from)).normalize()
}

#[test]
fn a_flipped_tracker_reports_the_truth_turned_half_a_turn_about_its_boresight() {
    let sc = scenario("[[faults]]\nonset_s = 3.0\nunit = \"star_tracker\"\nkind = \"flip\"\n");
    let fr = frames(&sc);
    let b = Unit::new_normalize(Vec3::new(0.6, 0.0, 0.8));
    let flip = UnitQuaternion::from_axis_angle(&b, std::f64::consts::PI).into_inner();
    // Noise: 0.05° about the boresight, 0.01° across; 5σ of the largest, plus f32 rounding.
    let tol = 5.0 * 0.05f64.to_radians() + 1e-6;
    for (t, s, f) in &fr {
        let q = measured_q(f);
        if *t >= 3.0 - 1e-9 {
            assert!(angle_between(&(s.q * flip), &q) < tol, "at {t}");
            assert!((angle_between(&s.q, &q) - std::f64::consts::PI).abs() < tol, "at {t}");
        } else {
            assert!(angle_between(&s.q, &q) < tol, "at {t}");
        }
    }
}

#[test]
fn a_frozen_tracker_repeats_its_attitude_with_fresh_time_tags() {
    let sc = scenario("[[faults]]\nonset_s = 3.0\nunit = \"star_tracker\"\nkind = \"frozen\"\nend_s = 7.0\n");
    let fr = frames(&sc);
    let held = fr.iter().find(|(t, ..)| *t >= 3.0 - 1e-9).unwrap().2.q_ib_xyzw;
    let tol = 5.0 * 0.05f64.to_radians() + 1e-6;
    for (t, s, f) in &fr {
        // Fresh: every frame's tracker sample is this step's.
        assert_eq!(f.sampled_at.star_tracker_us, (t * 1e6).round() as u64);
        if (3.0 - 1e-9..7.0 - 1e-9).contains(t) {
            assert_eq!(f.q_ib_xyzw, held, "at {t}");
        } else {
            assert!(angle_between(&s.q, &measured_q(f)) < tol, "at {t}");
        }
    }
    // Meanwhile the truth turned |ω| × 4 s = 0.24 rad away from the held attitude.
    let (s7, q3) = (&fr[69].1, from_xyzw(held.map(f64::from)).normalize());
    assert!(angle_between(&s7.q, &q3) > 0.2);
}

#[test]
fn a_stuck_tachometer_repeats_its_reading_while_the_wheel_speeds_up() {
    let sc = scenario("[[faults]]\nonset_s = 2.0\nunit = \"wheel.2\"\nkind = \"tach_stuck\"\n");
    let fr = frames(&sc);
    let held = fr[20].2.wheel_speed_rad_s[2];
    let rel = |s: &State, i: usize, craft_axis: Vec3| s.wheels[i].h_abs_nms / I_W - craft_axis.dot(&s.w);
    let craft = sc.spacecraft().unwrap();
    let axis = |i: usize| Vec3::from(craft.wheels[i].spin_axis);
    for (t, s, f) in &fr {
        // Tachometer noise 0.01 rad/s: 5σ, plus f32 rounding at ~600 rad/s.
        let tol = 0.05 + 1e-4;
        assert!((f.wheel_speed_rad_s[1] as f64 - rel(s, 1, axis(1))).abs() < tol, "healthy tach at {t}");
        if *t >= 2.0 - 1e-9 {
            assert_eq!(f.wheel_speed_rad_s[2], held, "at {t}");
        } else {
            assert!((f.wheel_speed_rad_s[2] as f64 - rel(s, 2, axis(2))).abs() < tol, "at {t}");
        }
    }
    // The true speed went on: 50 rad/s² for 8 s.
    let (s2, s10) = (&fr[20].1, &fr[100].1);
    assert!((rel(s10, 2, axis(2)) - rel(s2, 2, axis(2)) - 400.0).abs() < 1e-6);
}

// --- magnetometer ---

/// The reference (lab) field the magnetometer tests measure, T.
const B_REF_T: [f64; 3] = [2e-5, -1e-5, 3e-5];
/// The magnetometer's per-sample 1σ in those tests, T.
const MAG_SIGMA_T: f64 = 1e-8;

/// `BASE` with a noisy magnetometer and `faults`.
fn mag_scenario(faults: &str) -> Scenario {
    let text = BASE.replace("seed = 42\n", &format!("seed = 42\nmagnetometer_noise_t = {MAG_SIGMA_T:e}\n"));
    Scenario::from_toml(&format!("{text}{faults}")).unwrap()
}

/// The frames of 10 s of samples at 10 Hz on the closed-form truth in the field `B_REF_T`,
/// and the true body field of each, T.
fn mag_frames(sc: &Scenario) -> Vec<(f64, Vec3, acs_flight::link::SensorFrame)> {
    use sim_core::environment::model::EnvSnapshot;
    let r = Resolved::try_from(sc).unwrap();
    let (craft, mut suite) = (r.craft, r.sensors);
    suite.set_faults(&sc.faults().unwrap());
    let b_ref = Vec3::from(B_REF_T);
    (0..=100)
        .map(|k| {
            let t = k as f64 * DT;
            let s = truth(t, &craft);
            let env = EnvSnapshot { t_s: t, b_ref_t: Some(b_ref), ..Default::default() };
            let f = suite.sample(k, t, &s, &craft, Some(&env), &[0.0; 3]);
            (t, sim_core::attitude::rotate_ref_to_body(&s.q, &b_ref), f)
        })
        .collect()
}

#[test]
fn a_stuck_magnetometer_axis_repeats_itself_in_its_window_and_the_others_follow_the_truth() {
    let sc = mag_scenario("[[faults]]\nonset_s = 3.0\nunit = \"magnetometer.y\"\nkind = \"stuck\"\nend_s = 7.0\n");
    let fr = mag_frames(&sc);
    let held = fr[30].2.mag_field_t[1];
    // 5σ per sample, plus the f32 of the wire (~4e-12 T at 4e-5 T).
    let tol = 5.0 * MAG_SIGMA_T + 1e-11;
    let mut moved = 0.0f64;
    for (t, b, f) in &fr {
        assert!(f.valid & acs_flight::link::valid::MAG != 0, "at {t}");
        for a in [0, 2] {
            assert!((f.mag_field_t[a] as f64 - b[a]).abs() < tol, "axis {a} at {t}");
        }
        if (3.0 - 1e-9..7.0 - 1e-9).contains(t) {
            assert_eq!(f.mag_field_t[1], held, "at {t}");
            moved = moved.max((b[1] - f64::from(held)).abs());
        } else {
            assert!((f.mag_field_t[1] as f64 - b[1]).abs() < tol, "axis y at {t}");
        }
    }
    // Meanwhile the true y field moved far beyond the noise (the body turned 0.24 rad).
    eprintln!("stuck magnetometer: true y field moved {moved:e} T from the held reading in the window");
    assert!(moved > 100.0 * MAG_SIGMA_T, "{moved:e}");
}

#[test]
fn a_magnetometer_bias_adds_exactly_its_field_to_its_axis_in_its_window() {
    let bias_t = 2e-6;
    let faulty = mag_scenario(&format!(
        "[[faults]]\nonset_s = 4.0\nunit = \"magnetometer.z\"\nkind = \"bias\"\nmagnitude = {bias_t:e}\nend_s = 8.0\n"
    ));
    // Second method: the same run without the fault (the noise draws are the same).
    let (with, without) = (mag_frames(&faulty), mag_frames(&mag_scenario("")));
    for ((t, b, f), (_, _, g)) in with.iter().zip(&without) {
        let d = |a: usize| f64::from(f.mag_field_t[a]) - f64::from(g.mag_field_t[a]);
        assert_eq!((d(0), d(1)), (0.0, 0.0), "other axes at {t}");
        if (4.0 - 1e-9..8.0 - 1e-9).contains(t) {
            // The f32 of the wire: half an ulp of each reading (~4e-12 T at 4e-5 T).
            assert!((d(2) - bias_t).abs() < 1e-11, "at {t}: {:e}", d(2));
            // And against the truth: bias plus noise.
            assert!((f64::from(f.mag_field_t[2]) - b[2] - bias_t).abs() < 5.0 * MAG_SIGMA_T + 1e-11, "at {t}");
        } else {
            assert_eq!(d(2), 0.0, "at {t}");
        }
    }
    let (_, summary) = fly(&faulty);
    let rec = &summary.faults.unwrap()[0];
    assert_eq!(
        (rec.unit.as_str(), rec.kind, rec.magnitude, rec.injected_at_s, rec.end_s),
        ("magnetometer.z", "bias", Some(bias_t), Some(4.0), Some(8.0))
    );
}

// --- gyro noise and saturation ---

/// `n` gyro samples at 10 Hz on the closed-form truth with the scenario's faults.
fn gyro_frames(sc: &Scenario, n: u32) -> Vec<(f64, acs_flight::link::SensorFrame)> {
    let r = Resolved::try_from(sc).unwrap();
    let (craft, mut suite) = (r.craft, r.sensors);
    suite.set_faults(&sc.faults().unwrap());
    (0..n)
        .map(|k| {
            let t = k as f64 * DT;
            (t, suite.sample(k, t, &truth(t, &craft), &craft, None, &[0.0; 3]))
        })
        .collect()
}

/// Mean and sample standard deviation.
fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    (mean, (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt())
}

#[test]
fn a_noisy_gyro_axis_has_its_sigma_times_the_factor_and_the_others_keep_theirs() {
    let factor = 4.0;
    let sc =
        scenario(&format!("[[faults]]\nonset_s = 0.0\nunit = \"gyro.x\"\nkind = \"noise\"\nmagnitude = {factor}\n"));
    let n = 20_000;
    let fr = gyro_frames(&sc, n);
    let err = |a: usize| -> Vec<f64> { fr.iter().map(|(_, f)| f64::from(f.rate_rad_s[a]) - W_TRUE[a]).collect() };
    // Increments (from the second frame: the first has no interval): truth ω DT.
    let inc = |a: usize| -> Vec<f64> {
        fr.iter().skip(1).map(|(_, f)| f64::from(f.gyro_angle_rad[a]) - W_TRUE[a] * DT).collect()
    };
    // Sample σ of N normals: relative standard error 1/√(2N) = 0.5 %; 3 % is 6 of them.
    let arw_sigma_inc = 1e-4 * DT.sqrt();
    for (a, want_rate, want_inc) in [
        (0, factor * GYRO_SIGMA, factor * arw_sigma_inc),
        (1, GYRO_SIGMA, arw_sigma_inc),
        (2, GYRO_SIGMA, arw_sigma_inc),
    ] {
        let ((_, sd), (_, sd_inc)) = (mean_sd(&err(a)), mean_sd(&inc(a)));
        eprintln!(
            "gyro noise x{factor} on x: axis {a} rate σ {sd:e} (want {want_rate:e}), increment σ {sd_inc:e} (want {want_inc:e})"
        );
        assert!((sd / want_rate - 1.0).abs() < 0.03, "axis {a}: {sd:e} vs {want_rate:e}");
        assert!((sd_inc / want_inc - 1.0).abs() < 0.03, "axis {a}: {sd_inc:e} vs {want_inc:e}");
    }
}

#[test]
fn a_saturated_gyro_axis_never_exceeds_its_bound_and_reads_the_truth_below_it() {
    // ω_y = -0.03 rad/s with σ = 3.2e-4: a bound of 0.0302 clips about a quarter of the samples.
    let bound = 0.0302;
    let sc = scenario(&format!(
        "[[faults]]\nonset_s = 2.0\nunit = \"gyro.y\"\nkind = \"saturation\"\nmagnitude = {bound}\nend_s = 8.0\n"
    ));
    // Second method: the same samples without the fault (the noise draws are the same).
    let (with, without) = (gyro_frames(&sc, 101), gyro_frames(&scenario(""), 101));
    let (mut clipped, mut below) = (0, 0);
    for ((t, f), (_, g)) in with.iter().zip(&without) {
        assert_eq!((f.rate_rad_s[0], f.rate_rad_s[2]), (g.rate_rad_s[0], g.rate_rad_s[2]), "other axes at {t}");
        let (y, y0) = (f64::from(f.rate_rad_s[1]), f64::from(g.rate_rad_s[1]));
        if !(2.0 - 1e-9..8.0 - 1e-9).contains(t) {
            assert_eq!(f.rate_rad_s[1], g.rate_rad_s[1], "outside the window at {t}");
            continue;
        }
        // The f32 of the wire: within an ulp of the bound.
        assert!(y.abs() <= bound * (1.0 + 1e-7), "at {t}: {y}");
        assert!(f64::from(f.gyro_angle_rad[1]).abs() <= bound * DT * (1.0 + 1e-7), "increment at {t}");
        if y0.abs() < bound * (1.0 - 1e-6) {
            assert_eq!(f.rate_rad_s[1], g.rate_rad_s[1], "below the bound at {t}");
            below += 1;
        } else {
            assert_eq!(y, (bound * y0.signum()) as f32 as f64, "clipped at {t}");
            clipped += 1;
        }
    }
    eprintln!("gyro saturation at {bound} rad/s: {clipped} samples clipped, {below} below the bound");
    assert!(clipped > 5 && below > 5, "{clipped} clipped, {below} below: the test exercises both");
    let (_, summary) = fly(&sc);
    let rec = &summary.faults.unwrap()[0];
    assert_eq!((rec.unit.as_str(), rec.kind, rec.magnitude), ("gyro.y", "saturation", Some(bound)));
}

// --- coarse sun sensors ---

/// `BASE` in a 500 km orbit with six coarse sun sensor heads (noise `noise`) and `faults`.
fn css_scenario(noise: f64, faults: &str) -> Scenario {
    let orbit = "[orbit]\nkind = \"circular\"\naltitude_km = 500.0\ninclination_deg = 97.4\n\
                 epoch_utc = \"2026-04-15T00:00:00\"\n[environment]\n";
    let css = format!(
        "[sensors.css]\nnormals_body = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]\n\
         noise = {noise:e}\n"
    );
    let text = BASE.replace("[environment]\nlab_field_t = [2e-5, -1e-5, 3e-5]\n", orbit) + &css + faults;
    Scenario::from_toml(&text).unwrap()
}

/// The CSS outputs of 10 s of frames at 10 Hz on the closed-form attitude, the spacecraft
/// on the Sun side of the Earth (sunlit, 7000 km from its centre).
fn css_frames(sc: &Scenario) -> Vec<(f64, [f32; 6])> {
    use sim_core::environment::model::EnvSnapshot;
    use sim_core::environment::torques::sun_position_eci;
    let r = Resolved::try_from(sc).unwrap();
    let (craft, mut suite) = (r.craft, r.sensors);
    suite.set_faults(&sc.faults().unwrap());
    let jd = |t: f64| craft.env.as_ref().unwrap().julian_date(t);
    (0..=100)
        .map(|k| {
            let t = k as f64 * DT;
            let pos = sun_position_eci(jd(t)).normalize() * 7.0e6;
            let env = EnvSnapshot { t_s: t, orbit: Some((pos, Vec3::zeros())), ..Default::default() };
            let f = suite.sample(k, t, &truth(t, &craft), &craft, Some(&env), &[0.0; 3]);
            assert!(f.valid & acs_flight::link::valid::CSS != 0, "at {t}");
            (t, f.css_output)
        })
        .collect()
}

#[test]
fn a_dead_css_head_reads_what_a_dark_head_reads_and_the_others_are_untouched() {
    // Noise-free: what a head that sees nothing reads (the one of each opposite pair facing
    // away from the Sun).
    let quiet = css_frames(&css_scenario(0.0, ""));
    let dark: Vec<f32> = quiet.iter().flat_map(|(_, o)| [0, 2, 4].map(|i| o[i].min(o[i + 1]))).collect();
    assert!(dark.iter().all(|x| *x == dark[0]), "dark heads disagree: {dark:?}");
    // The head that sees the Sun best fails (a dead dark head would prove nothing).
    let lit = |i: usize| quiet.iter().map(|(_, o)| o[i]).sum::<f32>();
    let head = (0..6).max_by(|a, b| lit(*a).total_cmp(&lit(*b))).unwrap();
    let dead = format!("[[faults]]\nonset_s = 3.0\nunit = \"css.{head}\"\nkind = \"dead\"\nend_s = 7.0\n");
    // Second method: the same noisy samples without the fault (the noise draws are the same).
    let (with, without) = (css_frames(&css_scenario(0.01, &dead)), css_frames(&css_scenario(0.01, "")));
    let mut lit_before = 0;
    for ((t, o), (_, o0)) in with.iter().zip(&without) {
        for i in (0..6).filter(|i| *i != head) {
            assert_eq!(o[i], o0[i], "head {i} at {t}");
        }
        if (3.0 - 1e-9..7.0 - 1e-9).contains(t) {
            assert_eq!(o[head], dark[0], "at {t}");
        } else {
            assert_eq!(o[head], o0[head], "at {t}");
            lit_before += usize::from(o[head] > 0.05);
        }
    }
    // Healthy, the head saw the Sun (else the test would not tell dead from dark).
    eprintln!("dead css head {head}: {lit_before} of 61 healthy samples lit (> 0.05), dark reading {}", dark[0]);
    assert!(lit_before > 30, "{lit_before}");
    let (_, summary) = fly(&css_scenario(0.01, &dead));
    let rec = &summary.faults.unwrap()[0];
    assert_eq!((rec.unit.as_str(), rec.kind, rec.magnitude), (format!("css.{head}").as_str(), "dead", None));
}

// --- GNSS ---

/// `BASE` in a 500 km orbit, with `more` (a `[sensors.gnss]` table, faults).
fn orbit_scenario(more: &str) -> Scenario {
    Scenario::from_toml(&orbit_scenario_text(more)).unwrap()
}

fn orbit_scenario_text(more: &str) -> String {
    let orbit = "[orbit]\nkind = \"circular\"\naltitude_km = 500.0\ninclination_deg = 97.4\n\
                 epoch_utc = \"2026-04-15T00:00:00\"\n[environment]\n";
    BASE.replace("[environment]\nlab_field_t = [2e-5, -1e-5, 3e-5]\n", orbit) + more
}

/// The true position (a circle of 6878 km at 1.1e-3 rad/s) and the GNSS fix of 20 s of
/// frames at 10 Hz.
fn gnss_frames(sc: &Scenario) -> Vec<(f64, Vec3, acs_flight::link::SensorFrame)> {
    use sim_core::environment::model::EnvSnapshot;
    let r = Resolved::try_from(sc).unwrap();
    let (craft, mut suite) = (r.craft, r.sensors);
    suite.set_faults(&sc.faults().unwrap());
    (0..=200)
        .map(|k| {
            let t = k as f64 * DT;
            let (s, c) = (1.1e-3 * t).sin_cos();
            let pos = Vec3::new(c, s * 0.2, s * 0.98) * 6.878e6;
            let vel = Vec3::new(-s, c * 0.2, c * 0.98) * (6.878e6 * 1.1e-3);
            let env = EnvSnapshot { t_s: t, orbit: Some((pos, vel)), ..Default::default() };
            (t, pos, suite.sample(k, t, &truth(t, &craft), &craft, Some(&env), &[0.0; 3]))
        })
        .collect()
}

#[test]
fn a_gnss_position_jump_offsets_the_fix_by_its_magnitude_along_the_radial() {
    let jump_m = -1500.0;
    let fault = format!(
        "[[faults]]\nonset_s = 5.0\nunit = \"gnss\"\nkind = \"position_jump\"\nmagnitude = {jump_m}\nend_s = 15.0\n"
    );
    let in_window = |t: f64| (5.0 - 1e-9..15.0 - 1e-9).contains(&t);
    let pos = |f: &acs_flight::link::SensorFrame| Vec3::from(f.gnss_pos_m.map(f64::from));
    // The ideal fix (no receiver table): the truth plus the jump, to the f32 of the wire
    // (half an ulp, 0.25 m, per component at 6878 km).
    let mut worst = 0.0f64;
    for (t, r, f) in gnss_frames(&orbit_scenario(&fault)) {
        let want = if in_window(t) { r + r.normalize() * jump_m } else { r };
        let e = (pos(&f) - want).amax();
        worst = worst.max(e);
        assert!(e <= 0.5, "at {t}: {e} m");
    }
    eprintln!("gnss position jump {jump_m} m (ideal fix): largest error against truth + jump {worst} m");
    // A receiver with noise, against the same fixes without the fault (same draws).
    let rx = "[sensors.gnss]\nrate_hz = 1.0\nposition_noise_m = 5.0\nvelocity_noise_m_s = 0.05\n";
    let (with, without) = (gnss_frames(&orbit_scenario(&(rx.to_string() + &fault))), gnss_frames(&orbit_scenario(rx)));
    let mut jumped = 0;
    for ((t, _, f), (_, _, g)) in with.iter().zip(&without) {
        assert_eq!(f.sampled_at.gnss_us, g.sampled_at.gnss_us);
        assert_eq!(f.gnss_vel_m_s, g.gnss_vel_m_s, "velocity at {t}");
        let tag_s = f.sampled_at.gnss_us as f64 * 1e-6;
        // The fix's position is the truth at its tag: the jump along that radial.
        let (s, c) = (1.1e-3 * tag_s).sin_cos();
        let r_tag = Vec3::new(c, s * 0.2, s * 0.98);
        let want = if in_window(tag_s) { r_tag * jump_m } else { Vec3::zeros() };
        assert!((pos(f) - pos(g) - want).amax() <= 1.0, "at {t} (fix of {tag_s}): {:?}", pos(f) - pos(g));
        jumped += usize::from(in_window(tag_s));
    }
    assert!(jumped >= 90, "{jumped}");
    let (_, summary) = fly(&orbit_scenario(&fault));
    let rec = &summary.faults.unwrap()[0];
    assert_eq!((rec.unit.as_str(), rec.kind, rec.magnitude), ("gnss", "position_jump", Some(jump_m)));
}

#[test]
fn a_gnss_velocity_jump_offsets_the_velocity_by_its_magnitude_along_it() {
    let jump_m_s = 250.0;
    let fault = format!(
        "[[faults]]\nonset_s = 5.0\nunit = \"gnss\"\nkind = \"velocity_jump\"\nmagnitude = {jump_m_s}\nend_s = 15.0\n"
    );
    let in_window = |t: f64| (5.0 - 1e-9..15.0 - 1e-9).contains(&t);
    let vel = |f: &acs_flight::link::SensorFrame| Vec3::from(f.gnss_vel_m_s.map(f64::from));
    // A receiver with noise, against the same fixes without the fault (same draws): the
    // position untouched, the velocity moved by the jump along the true velocity at the
    // fix's tag (the circle of `gnss_frames`, written apart), to the f32 of the wire.
    let rx = "[sensors.gnss]\nrate_hz = 1.0\nposition_noise_m = 5.0\nvelocity_noise_m_s = 0.05\n";
    let (with, without) = (gnss_frames(&orbit_scenario(&(rx.to_string() + &fault))), gnss_frames(&orbit_scenario(rx)));
    let mut jumped = 0;
    for ((t, _, f), (_, _, g)) in with.iter().zip(&without) {
        assert_eq!(f.sampled_at.gnss_us, g.sampled_at.gnss_us);
        assert_eq!(f.gnss_pos_m, g.gnss_pos_m, "position at {t}");
        let tag_s = f.sampled_at.gnss_us as f64 * 1e-6;
        let (s, c) = (1.1e-3 * tag_s).sin_cos();
        let v_hat = Vec3::new(-s, c * 0.2, c * 0.98).normalize();
        let want = if in_window(tag_s) { v_hat * jump_m_s } else { Vec3::zeros() };
        assert!((vel(f) - vel(g) - want).amax() <= 1e-3, "at {t} (fix of {tag_s}): {:?}", vel(f) - vel(g));
        jumped += usize::from(in_window(tag_s));
    }
    assert!(jumped >= 90, "{jumped}");
    let (_, summary) = fly(&orbit_scenario(&fault));
    let rec = &summary.faults.unwrap()[0];
    assert_eq!((rec.unit.as_str(), rec.kind, rec.magnitude), ("gnss", "velocity_jump", Some(jump_m_s)));
    // Refused beyond the flight code's speed limit, naming the key.
    let big = fault.replace("magnitude = 250", "magnitude = 2.0e4");
    let err = format!("{:#}", Scenario::from_toml(&orbit_scenario_text(&big)).unwrap_err());
    assert!(err.contains("faults[0].magnitude"), "{err}");
}

/// With `[fdir.gnss]` on the 6U of `scenarios/fdir/wheel-seized-6u.toml` (flown 30 s, its
/// wheel fault replaced): a one-fix velocity glitch (100 m/s at 10 s) is refused and declares
/// nothing; a velocity that stays 5 m/s off from 20 s is declared at its third fix (22 s) by
/// the velocity test, and the event names that fault (faults[1]), not the glitch that ended
/// before it on the same unit.
#[test]
fn a_gnss_velocity_fault_is_declared_by_the_velocity_test_and_attributed_to_itself() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/fdir/wheel-seized-6u.toml");
    let text = std::fs::read_to_string(path).unwrap().replace("duration_s = 6000.0", "duration_s = 30.0");
    let base = &text[..text.find("\n[[faults]]").unwrap()];
    let faults = "[[faults]]\nonset_s = 10.0\nend_s = 10.5\nunit = \"gnss\"\nkind = \"velocity_jump\"\nmagnitude = 100.0\n\
                  [[faults]]\nonset_s = 20.0\nunit = \"gnss\"\nkind = \"velocity_jump\"\nmagnitude = -5.0\n";
    let (_, summary) = fly(&Scenario::from_toml(&format!("{base}\n[fdir.gnss]\n\n{faults}")).unwrap());
    let f = summary.fdir.expect("[fdir.gnss] reports");
    assert_eq!(f.false_alarms, 0, "{f:?}");
    assert_eq!(f.events.len(), 1, "the glitch declares nothing: {f:?}");
    let e = &f.events[0];
    assert_eq!((e.unit.as_str(), e.test, e.fault), ("gnss", "gnss_velocity_consistency", Some(1)), "{e:?}");
    // Fixes at 20, 21 and 22 s exceed: declared with the 22 s fix (within a control step).
    assert!((22.0..22.5).contains(&e.detected_at_s), "{e:?}");
}

// --- wheel power off and tachometer noise ---

#[test]
fn a_wheel_without_power_gets_no_torque_and_its_tachometer_reads_zero() {
    let sc = scenario("[[faults]]\nonset_s = 2.0\nunit = \"wheel.2\"\nkind = \"power_off\"\nend_s = 4.0\n");
    let (states, summary) = fly(&sc);
    // The ideal wheel's absolute speed changes at the torque the motor delivers / I_w: zero
    // while unpowered, the command otherwise (far below the speed band: no fade).
    let accel = |i: usize, k: usize| (abs_speed(&states[k + 1], i) - abs_speed(&states[k], i)) / DT;
    for k in 0..states.len() - 1 {
        let t = k as f64 * DT;
        let off = (2.0 - 1e-9..4.0 - 1e-9).contains(&t);
        let want = if off { 0.0 } else { CMD_NM[2] / I_W };
        assert!((accel(2, k) - want).abs() < 1e-9 * CMD_NM[2] / I_W, "wheel 2 at {t}: {}", accel(2, k));
        assert!((accel(1, k) - CMD_NM[1] / I_W).abs() < 1e-9 * (CMD_NM[1] / I_W).abs(), "wheel 1 at {t}");
    }
    let rec = &summary.faults.unwrap()[0];
    assert_eq!((rec.unit.as_str(), rec.kind, rec.magnitude), ("wheel.2", "power_off", None));
    // The tachometer on the closed-form truth: 0 in the window, the truth (noise 0.01 rad/s,
    // 5σ, plus f32 rounding) outside.
    let craft = sc.spacecraft().unwrap();
    for (t, s, f) in frames(&sc) {
        let axis = Vec3::from(craft.wheels[2].spin_axis);
        let rel = s.wheels[2].h_abs_nms / I_W - axis.dot(&s.w);
        if (2.0 - 1e-9..4.0 - 1e-9).contains(&t) {
            assert_eq!(f.wheel_speed_rad_s[2], 0.0, "at {t}");
        } else {
            assert!((f64::from(f.wheel_speed_rad_s[2]) - rel).abs() < 0.05 + 1e-4, "at {t}");
        }
    }
}

#[test]
fn a_noisy_tachometer_has_its_sigma_times_the_factor_and_the_others_keep_theirs() {
    let factor = 5.0;
    let sc = scenario(&format!(
        "[[faults]]\nonset_s = 0.0\nunit = \"wheel.0\"\nkind = \"tach_noise\"\nmagnitude = {factor}\n"
    ));
    let r = Resolved::try_from(&sc).unwrap();
    let (craft, mut suite) = (r.craft, r.sensors);
    suite.set_faults(&sc.faults().unwrap());
    // The wheels held at 100 to 130 rad/s (f32 rounding 4e-6 rad/s, far below σ).
    let s = truth(0.0, &craft);
    let rel = |i: usize| s.wheels[i].h_abs_nms / I_W - Vec3::from(craft.wheels[i].spin_axis).dot(&s.w);
    let n = 20_000u32;
    let mut err: Vec<Vec<f64>> = vec![Vec::new(); 4];
    for k in 0..n {
        let f = suite.sample(k, k as f64 * DT, &s, &craft, None, &[0.0; 3]);
        for (i, e) in err.iter_mut().enumerate() {
            e.push(f64::from(f.wheel_speed_rad_s[i]) - rel(i));
        }
    }
    // Sample σ of N normals: relative standard error 1/√(2N) = 0.5 %; 3 % is 6 of them.
    for (i, e) in err.iter().enumerate() {
        let want = if i == 0 { factor * 0.01 } else { 0.01 };
        let (_, sd) = mean_sd(e);
        eprintln!("tach noise x{factor} on wheel 0: wheel {i} σ {sd:e} rad/s (want {want:e})");
        assert!((sd / want - 1.0).abs() < 0.03, "wheel {i}: {sd:e} vs {want:e}");
    }
}

// --- wheel friction ---

#[test]
fn a_wheel_friction_fault_scales_the_viscous_and_coulomb_friction() {
    use sim_core::plant::wheel::WheelParams;
    // The motor model's RK4 stability limit asks for 17 substeps or more at 10 Hz, and its
    // Dahl friction x 3 (the fault) for 51.
    let text = BASE
        .replace(
            "model = \"ideal\"\nmax_torque_nm = 0.01\nmax_speed_rpm = 6000.0\ninertia_kgm2 = 1e-4\n",
            "model = \"accurate\"\n",
        )
        .replace("dynamics_substeps = 4\n", "dynamics_substeps = 60\n");
    let accurate = |faults: &str| Scenario::from_toml(&format!("{text}{faults}"));
    let k = 3.0;
    // A factor the dynamics step cannot resolve is refused naming its magnitude (at 60
    // substeps the limit is x 3.5: x 4 would diverge the integrator, as x 20 did at the
    // issue-42 friction campaign's 41 substeps).
    let too_stiff = "[[faults]]\nonset_s = 2.0\nunit = \"wheel.0\"\nkind = \"friction\"\nmagnitude = 4.0\n";
    let err = accurate(too_stiff).map(|_| ()).unwrap_err().to_string();
    assert!(err.contains("faults[0].magnitude") && err.contains("dynamics_substeps"), "{err}");
    let sc = accurate(&format!(
        "[[faults]]\nonset_s = 2.0\nunit = \"wheel.0\"\nkind = \"friction\"\nmagnitude = {k}\nend_s = 4.0\n"
    ))
    .unwrap();
    let p = WheelParams::paper001();
    let r = sim_core::runner::run(&sc, &mut InProcess::new(), false).unwrap();
    let c = |n: &str| r.series.col(n).unwrap();
    let (t, rpm, fr) = (c("t_s"), c("wheel1_speed_rpm"), c("wheel1_friction_nm"));
    // The converged Dahl friction (eq 23: T_f tanh(ω/ω_s) = T_c) plus the viscous term,
    // both scaled by the factor in force. After a change the Dahl state's error x obeys
    // ẋ ≈ −β|ω| x|x|, so |x(τ)| = |x0| / (1 + β|ω||x0|τ) < 1/(β|ω|τ), τ the time since the
    // change: that bound (10 % margin) is the tolerance, from 0.5 s after each change on.
    let mut judged = [0, 0];
    let mut worst = 0.0f64;
    for i in 0..t.len() {
        let since = [0.0, 2.0, 4.0].into_iter().filter(|c| t[i] >= c - 1e-9).fold(0.0, f64::max);
        let tau = t[i] - since;
        if tau < 0.5 - 1e-9 {
            continue;
        }
        let on = (2.0 - 1e-9..4.0 - 1e-9).contains(&t[i]);
        let f = if on { k } else { 1.0 };
        let w = rpm[i] * std::f64::consts::PI / 30.0;
        let want = f * (p.coulomb_nm / (w / p.sign_smoothing_rad_s).tanh() + p.viscous_nms * w);
        let tol = 1.1 / (p.dahl_beta * w.abs() * tau);
        let e = (fr[i] - want).abs();
        worst = worst.max(e / tol);
        assert!(e < tol, "at {}: friction {} vs {want} (ω {w} rad/s, tolerance {tol:e})", t[i], fr[i]);
        judged[usize::from(on)] += 1;
    }
    eprintln!("wheel friction x{k}: {judged:?} rows judged (off, on), worst error / tolerance {worst:.3}");
    assert!(judged[0] > 5 && judged[1] > 5, "{judged:?}");
    let recs = r.summary.faults.unwrap();
    assert_eq!((recs[0].unit.as_str(), recs[0].kind, recs[0].magnitude), ("wheel.0", "friction", Some(k)));
}
