//! Issue 38, finding 1: the standard cubesat set (wheels + magnetorquers + `[momentum]`
//! under one `[controller]`) flies without `[modes]`; the family combinations a
//! `[controller]` cannot fly are refused with what to write instead; `[modes]` asks only
//! for the thresholds of the transitions it can make.
//!
//! Independent truth for the flight (`a_controller_on_wheels_is_unloaded_by_the_rods`):
//! conservation of angular momentum. An inertially held body (ω ≈ 0) under a constant
//! external torque τ stores all of it in its wheels, `h(T) − h(0) = τ T`; with the rods
//! unloading, `h(T) − h(0) = ∫ (τ + m × B) dt`, the second term from the recorded rod
//! torque, integrated here by the trapezoid rule.

use sim_core::link::in_process::InProcess;
use sim_core::runner::{RunResult, run};
use sim_core::scenario::Scenario;
use std::path::Path;

fn example() -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/examples/cubesat-6u-wheels-mtq.toml");
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Text edit; panics when `from` is not there (a change to the example cannot void a case).
fn set(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "line {from:?} not found");
    text.replacen(from, to, 1)
}

/// The text without the table `[name]` (up to the next table header).
fn without_table(text: &str, name: &str) -> String {
    let head = format!("\n[{name}]\n");
    let start = text.find(&head).unwrap_or_else(|| panic!("no [{name}]")) + 1;
    let end = text[start + head.len() - 1..].find("\n[").map_or(text.len(), |k| start + head.len() - 1 + k + 1);
    format!("{}{}", &text[..start], &text[end..])
}

fn refusal(text: &str) -> String {
    format!("{:#}", Scenario::from_toml(text).expect_err("must be refused"))
}

const THRUSTERS: &str = "\n[actuators.thrusters]\nlayout = \"paper004\"\nthrust_n = 0.01\nisp_s = 60.0\n";

#[test]
fn the_example_flies_one_controller_on_the_wheels_beside_the_unloading_rods() {
    let sc = Scenario::from_toml(&example()).unwrap();
    assert!(sc.modes.is_none() && sc.momentum.is_some());
    assert_eq!(sc.control_family().unwrap().name(), "wheels");
    let p = sc.flight_params().unwrap();
    assert!(matches!(p.actuator, acs_flight::params::ActuatorParams::Wheels(_)));
    assert!(p.momentum.enabled, "the rods unload the wheels");
}

#[test]
fn combinations_a_controller_cannot_fly_are_refused_naming_the_fix() {
    let base = example();
    // Wheels and rods without [momentum]: the rods have no job; add [momentum] or [modes].
    let e = refusal(&without_table(&base, "momentum"));
    for part in
        ["`actuators`", "[actuators.wheels] and [actuators.magnetorquers]", "[momentum]", "gain_per_s", "[modes]"]
    {
        assert!(e.contains(part), "{part:?} not in: {e}");
    }
    // Wheels and thrusters with magnetic unloading: the thrusters have no job; a thruster
    // dump is `method = "thrusters"`.
    let e = refusal(&set(&base, "\n[controller]", &format!("{THRUSTERS}\n[controller]")));
    for part in ["[actuators.wheels] and [actuators.thrusters]", "method = \"thrusters\"", "dump_gain_per_s", "[modes]"]
    {
        assert!(e.contains(part), "{part:?} not in: {e}");
    }
    // Rods and thrusters, nothing storing momentum: only [modes] can split them.
    let no_wheels = without_table(&without_table(&base, "actuators.wheels"), "momentum");
    let e = refusal(&set(&no_wheels, "\n[controller]", &format!("{THRUSTERS}\n[controller]")));
    for part in [
        "[actuators.magnetorquers] and [actuators.thrusters]",
        "[modes]",
        "actuator = \"magnetorquers\" | \"thrusters\"",
    ] {
        assert!(e.contains(part), "{part:?} not in: {e}");
    }
    // B-dot on the rods that [momentum] gives to unloading: detumble under [modes].
    let ctl = "type = \"quaternion_feedback\"\nzeta = 0.9\nwn_rad_s = 0.2\nki_per_s = 0.02\ngyro_compensation = true\n\
               max_slew_rate_deg_s = 1.0\ntorque_limit_nm = [1.5e-3, 1.5e-3, 1.5e-3]";
    let e = refusal(&set(&base, ctl, "type = \"bdot\"\ngain_am2_s_per_t = 1.0e5\nfilter_time_constant_s = 2.0"));
    for part in ["`controller.type`", "B-dot", "[modes.detumble] actuator = \"magnetorquers\""] {
        assert!(e.contains(part), "{part:?} not in: {e}");
    }
}

/// The example under a mode table of hold and sun-safe only.
fn hold_sun_safe_table(extra: &str) -> String {
    let base = without_table(&example(), "controller");
    format!(
        "{base}
[modes]
initial = \"hold\"
dwell_s = 30.0
trigger_persistence_s = 5.0
{extra}
[modes.hold]
actuator = \"wheels\"
controller = {{ type = \"quaternion_feedback\", zeta = 0.9, wn_rad_s = 0.2, ki_per_s = 0.02, gyro_compensation = true, torque_limit_nm = [1.5e-3, 1.5e-3, 1.5e-3] }}

[modes.sun_safe]
actuator = \"wheels\"
controller = {{ type = \"sun_safe\", panel_normal_body = [1.0, 0.0, 0.0], kp_nm_per_rad = 1.0e-5, kd_nm_s_per_rad = [2.0e-3, 1.6e-3, 0.7e-3], search_axis_body = [0.0, 0.0, 1.0], search_rate_deg_s = 0.5, torque_limit_nm = [1.5e-3, 1.5e-3, 1.5e-3] }}
"
    )
}

#[test]
fn a_mode_table_asks_only_for_the_thresholds_of_its_transitions() {
    use sim_core::scenario::{UNUSED_HOLD_ENTER_DEG, UNUSED_HOLD_EXIT_DEG, unused_detumble_rates_deg_s};
    // Hold and sun-safe: no detumble rates, no manoeuvre ↔ hold thresholds.
    let sc = Scenario::from_toml(&hold_sun_safe_table("")).unwrap();
    let table = sc.mode_table().unwrap().unwrap();
    let m = table.manager;
    let (enter, exit) = unused_detumble_rates_deg_s();
    // Inert values, as documented: they pass the flight code's checks and never trigger.
    assert_eq!(m.detumble_enter_rate_rad_s, enter.to_radians() as f32);
    assert_eq!(m.detumble_exit_rate_rad_s, exit.to_radians() as f32);
    assert_eq!(m.hold_enter_error_rad, (UNUSED_HOLD_ENTER_DEG as f32).to_radians());
    assert_eq!(m.hold_exit_error_rad, UNUSED_HOLD_EXIT_DEG.to_radians() as f32);
    assert!(m.validate().is_ok());
    // The thresholds drawn in modes.png are the file's only: none here.
    let drawn = sc.modes.as_ref().unwrap().plot_thresholds();
    assert!(drawn.error_deg.is_empty() && drawn.rate_deg_s.is_empty(), "{drawn:?}");

    // A detumble slot beside them makes the detumble pair required, named.
    let detumble = "[modes.detumble]\nactuator = \"magnetorquers\"\n\
                    controller = { type = \"bdot\", gain_am2_s_per_t = 1.0e5, filter_time_constant_s = 2.0 }\n";
    let e = refusal(&hold_sun_safe_table(detumble));
    assert!(e.contains("missing key `modes.detumble_enter_rate_deg_s`") && e.contains("[modes.detumble]"), "{e}");
    let e = refusal(&hold_sun_safe_table(&format!("detumble_enter_rate_deg_s = 3.0\n{detumble}")));
    assert!(e.contains("missing key `modes.detumble_exit_rate_deg_s`"), "{e}");
    let both = format!("detumble_enter_rate_deg_s = 3.0\ndetumble_exit_rate_deg_s = 0.5\n{detumble}");
    Scenario::from_toml(&hold_sun_safe_table(&both)).unwrap();
    // A manoeuvre slot makes the hold triple required; half a group is refused too.
    let manoeuvre = "[modes.manoeuvre]\nactuator = \"wheels\"\n\
                     controller = { type = \"quaternion_feedback\", zeta = 0.9, wn_rad_s = 0.2, torque_limit_nm = [1.5e-3, 1.5e-3, 1.5e-3] }\n";
    let e = refusal(&hold_sun_safe_table(manoeuvre));
    assert!(e.contains("missing key `modes.hold_enter_error_deg`") && e.contains("[modes.manoeuvre]"), "{e}");
    let e = refusal(&hold_sun_safe_table("hold_exit_error_deg = 2.0\n"));
    assert!(e.contains("missing key `modes.hold_enter_error_deg`"), "{e}");
    let all =
        format!("hold_enter_error_deg = 0.5\nhold_enter_rate_deg_s = 0.05\nhold_exit_error_deg = 2.0\n{manoeuvre}");
    Scenario::from_toml(&hold_sun_safe_table(&all)).unwrap();
}

#[test]
fn a_hold_and_sun_safe_table_flies_in_hold() {
    let text = set(&hold_sun_safe_table(""), "duration_s = 17031.0", "duration_s = 600.0");
    let r = fly(&Scenario::from_toml(&text).unwrap());
    assert!(r.summary.mode_transitions.is_empty(), "{:?}", r.summary.mode_transitions);
    assert_eq!(r.summary.final_mode.as_deref(), Some("hold"));
    assert!(r.summary.final_error_deg < 0.05, "{}", r.summary.final_error_deg);
}

fn fly(sc: &Scenario) -> RunResult {
    run(sc, &mut InProcess::new(), false).unwrap()
}

const TORQUE_NM: [f64; 3] = [2.0e-7, -1.0e-7, 1.5e-7];
const GAIN_PER_S: f64 = 0.002;

/// Two orbits (500 km, 5677 s each) of an inertial hold under a constant body torque (no
/// gravity gradient, drag or dipole): the wheels take the torque, the rods (when present)
/// unload them with the cross-product law of gain `GAIN_PER_S`.
fn inertial_hold(rods: bool) -> Scenario {
    let unloading = "\n[actuators.magnetorquers]\nmax_dipole_am2 = [0.2, 0.2, 0.2]\n\n\
                     [momentum]\ngain_per_s = 0.002\ndeadband_nms = 0.0\n";
    assert!(unloading.contains(&format!("gain_per_s = {GAIN_PER_S}")));
    let text = format!(
        r#"
name = "wheels-rods-inertial-hold"
duration_s = 11354.0
[timing]
control_rate_hz = 2.0
dynamics_substeps = 4
output_every = 2
[spacecraft]
inertia_kgm2 = [[0.18, 0.0, 0.0], [0.0, 0.14, 0.0], [0.0, 0.0, 0.06]]
external_torque_nm = {TORQUE_NM:?}
[orbit]
kind = "circular"
altitude_km = 500.0
inclination_deg = 97.4
[environment]
magnetic_field = "dipole"
gravity_gradient = false
[initial]
euler_deg = [0.0, 0.0, 0.0]
[target]
euler_deg = [0.0, 0.0, 0.0]
[actuators.wheels]
layout = "axes"
axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
model = "ideal"
max_torque_nm = 2.0e-3
max_speed_rpm = 6000.0
inertia_kgm2 = 1.6e-5
[controller]
type = "quaternion_feedback"
zeta = 0.9
wn_rad_s = 0.2
ki_per_s = 0.02
torque_limit_nm = [1.5e-3, 1.5e-3, 1.5e-3]
{}"#,
        if rods { unloading } else { "" }
    );
    Scenario::from_toml(&text).unwrap()
}

fn col<'a>(r: &'a RunResult, name: &str) -> &'a [f64] {
    r.series.col(name).unwrap_or_else(|| panic!("no column {name}"))
}

/// Stored wheel momentum at row `i` from the wheel speeds (a triad along the body axes,
/// J_w = 1.6e-5 kg m²), body axes: what the momentum columns report, computed apart.
fn h_at(r: &RunResult, i: usize) -> nalgebra::Vector3<f64> {
    let rpm = std::f64::consts::PI / 30.0;
    nalgebra::Vector3::from_fn(|k, _| {
        1.6e-5 * rpm * col(r, ["wheel1_speed_rpm", "wheel2_speed_rpm", "wheel3_speed_rpm"][k])[i]
    })
}

#[test]
fn a_controller_on_the_wheels_is_unloaded_by_the_rods() {
    let tau = nalgebra::Vector3::from(TORQUE_NM);
    let free = fly(&inertial_hold(false));
    let t = col(&free, "t_s");
    let last = t.len() - 1;
    let secular = tau * t[last];
    // Without rods: every bit of the external torque ends in the wheels (conservation).
    let gained = h_at(&free, last) - h_at(&free, 0);
    let err_free = (gained - secular).norm() / secular.norm();
    assert!(err_free < 0.01, "without rods: gained {gained:?}, τT {secular:?} ({err_free:.3e})");

    let unloaded = fly(&inertial_hold(true));
    let t = col(&unloaded, "t_s");
    let last = t.len() - 1;
    let h_end = h_at(&unloaded, last);
    // ∫ (τ + m × B) dt by the trapezoid rule on the recorded rows (body ≈ inertial axes
    // while held at the identity to within the hold error).
    let rod = ["torque_unload_x_nm", "torque_unload_y_nm", "torque_unload_z_nm"].map(|c| col(&unloaded, c));
    let mut impulse = nalgebra::Vector3::zeros();
    for i in 1..=last {
        let dt = t[i] - t[i - 1];
        impulse += nalgebra::Vector3::from_fn(|k, _| 0.5 * (rod[k][i] + rod[k][i - 1]) * dt) + tau * dt;
    }
    let balance = (h_end - h_at(&unloaded, 0) - impulse).norm() / secular.norm();
    // The recorder's stored momentum (body axes) is the same quantity.
    let h_rec =
        nalgebra::Vector3::from_fn(|k, _| col(&unloaded, ["h_body_x_nms", "h_body_y_nms", "h_body_z_nms"][k])[last]);
    assert!((h_rec - h_end).norm() <= 1e-9 + 1e-6 * h_end.norm(), "{h_rec:?} {h_end:?}");
    let peak = (0..=last).map(|i| h_at(&unloaded, i).norm()).fold(0.0, f64::max);
    eprintln!(
        "|τT| {:.3e} N m s; without rods |h(T)| {:.3e} ({err_free:.2e} from τT); with rods |h(T)| {:.3e}, peak {peak:.3e}, \
         momentum balance residual {balance:.2e} of |τT|",
        secular.norm(),
        h_at(&free, free.series.len() - 1).norm(),
        h_end.norm()
    );
    // The rods remove the momentum the torque brings. The law realises k h⊥ (h across the
    // field), so it settles where k h⊥ balances τ⊥: |h| of order |τ|/k, the part along
    // the field waiting for the field to turn; bound 3 |τ|/k. Without rods it grows as τT.
    let level = 3.0 * tau.norm() / GAIN_PER_S;
    assert!(h_end.norm() < level && level < 0.5 * secular.norm(), "{h_end:?} vs {level}");
    // Bounded, not secular: the second orbit's peak is no higher than the first's (+10 %).
    let half = last / 2;
    let peak_in = |a: usize, b: usize| (a..=b).map(|i| h_at(&unloaded, i).norm()).fold(0.0, f64::max);
    let (first, second) = (peak_in(0, half), peak_in(half, last));
    assert!(second <= 1.1 * first, "orbit peaks {first:.3e} then {second:.3e}");
    // … and it is their m × B that does it (the balance closes on the recorded torque).
    assert!(balance < 0.01, "{balance}");
    assert_eq!(unloaded.summary.momentum.as_ref().map(|m| m.fdir_events), Some(0));
}
