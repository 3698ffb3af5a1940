//! Thruster momentum dump (issue 24): paper 004's spacecraft and eight-thruster layout
//! (table 2, 1 N per thruster, Isp 220 s) with a reaction-wheel triad holding the
//! attitude. The wheels start with a stored momentum `H0 = [2, 0, 0]` N m s; the flight
//! code dumps it through the thruster LP allocation while the wheels absorb the pulses.
//!
//! Independent truth: the minimum propellant that delivers an angular impulse `ΔH` with
//! thrusters of torque-per-newton columns `b_i` is `min Σ x_i` subject to `Σ b_i x_i = ΔH`,
//! `x ≥ 0` (x_i: impulse of thruster i, N s), divided by `Isp g0`. That LP is solved
//! here by enumerating its basic solutions (every set of three columns: solve the 3×3
//! system, keep the non-negative ones, take the cheapest), in f64, sharing no code with
//! the flight simplex. `ΔH` is the change of the total angular momentum `J ω + h_wheels`
//! (what only the thrusters can change: no other external torque in this scenario).

use sim_core::link::in_process::InProcess;
use sim_core::runner::{RunResult, run};
use sim_core::scenario::Scenario;

const G0: f64 = 9.80665;
const ISP_S: f64 = 220.0;
const THRUST_N: f64 = 1.0;
const J_WHEEL: f64 = 0.05;

fn scenario(h0_x_nms: f64) -> Scenario {
    Scenario::from_toml(&scenario_text(h0_x_nms)).unwrap()
}

fn scenario_text(h0_x_nms: f64) -> String {
    let rpm = h0_x_nms / J_WHEEL * 30.0 / std::f64::consts::PI;
    format!(
        r#"
name = "paper004-thruster-dump"
duration_s = 60.0

[timing]
control_rate_hz = 100.0
dynamics_substeps = 2
output_every = 10

[spacecraft]
inertia_kgm2 = [[9.0, 0.0, 0.0], [0.0, 13.0, 0.0], [0.0, 0.0, 13.0]]
mass_kg = 150.0

[initial]
euler_deg = [0.0, 0.0, 0.0]

[target]
euler_deg = [0.0, 0.0, 0.0]

[actuators.wheels]
layout = "axes"
axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
model = "ideal"
max_torque_nm = 3.0
max_speed_rpm = 6000.0
inertia_kgm2 = {J_WHEEL}
initial_speed_rpm = [{rpm}, 0.0, 0.0]

[actuators.thrusters]
layout = "paper004"
thrust_n = {THRUST_N}
isp_s = {ISP_S}
method = "direction_preserving"
pwpf = [4.5, 0.15, 0.45, 0.15]
failures = []

[controller]
type = "dcm_pd"
kp_nm = [21.0, 53.0, 53.0]
kd_nms = [-42.0, -91.0, -91.0]
torque_limit_nm = [3.0, 3.0, 3.0]

[momentum]
method = "thrusters"
gain_per_s = 0.0
dump_gain_per_s = 2.0
dump_torque_max_nm = 0.3
dump_start_nms = 1.0
dump_stop_nms = 0.1
"#
    )
}

/// Paper 004 table 2 per newton (N m per N), columns = thrusters.
fn layout() -> Vec<[f64; 3]> {
    let (r, d, e) = (0.73, 0.73, 0.43);
    let rows = [[r, 0.0, r, -e, -r, 0.0, -r, e], [d, -e, -d, 0.0, -d, e, d, 0.0], [d, -d, d, -d, d, -d, d, -d]];
    let k = std::f64::consts::FRAC_1_SQRT_2;
    (0..8).map(|j| [k * rows[0][j], k * rows[1][j], k * rows[2][j]]).collect()
}

/// `min Σ x` s.t. `B x = dh`, `x ≥ 0`, by enumerating the basic solutions.
fn min_impulse_ns(b: &[[f64; 3]], dh: &nalgebra::Vector3<f64>) -> f64 {
    let mut best = f64::INFINITY;
    let n = b.len();
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let m = nalgebra::Matrix3::from_columns(&[b[i].into(), b[j].into(), b[k].into()]);
                let Some(inv) = m.try_inverse() else { continue };
                let x = inv * dh;
                if x.iter().all(|v| *v >= -1e-12) {
                    best = best.min(x.sum());
                }
            }
        }
    }
    best
}

fn col<'a>(r: &'a RunResult, name: &str) -> &'a [f64] {
    r.series.col(name).unwrap_or_else(|| panic!("no column {name}"))
}

/// Total angular momentum `J ω + h_wheels` (body axes) at row `i`.
fn total_h(r: &RunResult, i: usize) -> nalgebra::Vector3<f64> {
    let j = nalgebra::Vector3::new(9.0, 13.0, 13.0);
    let w = nalgebra::Vector3::new(col(r, "rate_x_rad_s")[i], col(r, "rate_y_rad_s")[i], col(r, "rate_z_rad_s")[i]);
    let h = nalgebra::Vector3::new(col(r, "h_body_x_nms")[i], col(r, "h_body_y_nms")[i], col(r, "h_body_z_nms")[i]);
    j.component_mul(&w) + h
}

#[test]
fn thruster_dump_uses_the_minimum_impulse_and_holds_the_attitude() {
    let sc = scenario(2.0);
    sc.validate().unwrap();
    let r = run(&sc, &mut InProcess::new(), false).unwrap();
    let last = r.series.len() - 1;
    let (h_start, h_end) = (total_h(&r, 0), total_h(&r, last));
    let dh = h_start - h_end;
    let hn = col(&r, "h_norm_nms");
    let err = col(&r, "error_deg");
    let max_err = err.iter().fold(0.0f64, |a, x| a.max(*x));
    let prop = r.summary.propellant_kg.unwrap();
    let closed = min_impulse_ns(&layout(), &dh) / (ISP_S * G0);
    let closed_h0 = min_impulse_ns(&layout(), &nalgebra::Vector3::new(2.0, 0.0, 0.0)) / (ISP_S * G0);
    eprintln!(
        "dH = {dh:?}, |h| end {:.4}, propellant {prop:.6e} kg, closed form {closed:.6e} kg ({:+.2} %), \
         closed(H0) {closed_h0:.6e}, max error {max_err:.3e} deg, final {:.3e}",
        hn[last],
        100.0 * (prop / closed - 1.0),
        err[last]
    );
    // A dump happened (most of H0 removed) and ended below the release threshold.
    assert!(dh.x > 1.8 && hn[0] > 1.9, "{dh:?}");
    assert!(hn[last] < 0.1, "{}", hn[last]);
    // The thrusters are closed once it ended: no propellant over the last 10 s.
    let p = col(&r, "propellant_kg");
    assert_eq!(p[last], p[last - 10], "thrusters idle after the dump");
    // Propellant against the minimum-impulse closed form.
    assert!((prop / closed - 1.0).abs() < 0.02, "{prop} vs {closed}");
    // Attitude held while the wheels absorbed the pulses.
    assert!(max_err < 1e-3, "{max_err}");
}

/// The same spacecraft under a mode table (hold only) with the "unloading cannot keep
/// up" monitor at 5 % of `J_w Ω_max` (0.05 × 0.05 kg m² × 628.3 rad/s = 1.571 N m s)
/// held 5 s. `H0` = 2 N m s is above it. With the dump the stored momentum falls below
/// 1.571 N m s within (2 - 1.571) / 0.3 = 1.4 s of capped dump torque: no event. Without
/// it the momentum stays at 2 N m s: exactly one event after 5 s, flag only (the mode
/// stays hold, the speed trip counts nothing).
fn with_modes(dump: bool) -> Scenario {
    let text = scenario_text(2.0);
    let (c, m) = (text.find("[controller]").unwrap(), text.find("[momentum]").unwrap());
    let mut t = format!("{}{}", &text[..c], if dump { &text[m..] } else { "" });
    t.push_str(
        r#"
[modes]
initial = "hold"
momentum_keepup_fraction = 0.05
slow_fdir_persistence_s = 5.0
detumble_enter_rate_deg_s = 3.0
detumble_exit_rate_deg_s = 1.0
stabilise_exit_error_deg = 10.0
stabilise_exit_rate_deg_s = 0.1
hold_enter_error_deg = 0.5
hold_enter_rate_deg_s = 0.02
hold_exit_error_deg = 3.0
dwell_s = 60.0
trigger_persistence_s = 5.0

[modes.hold]
actuator = "wheels"
controller = { type = "dcm_pd", kp_nm = [21.0, 53.0, 53.0], kd_nms = [-42.0, -91.0, -91.0], torque_limit_nm = [3.0, 3.0, 3.0] }
"#,
    );
    Scenario::from_toml(&t).unwrap()
}

#[test]
fn keepup_monitor_flags_momentum_the_unloading_does_not_remove() {
    for dump in [true, false] {
        let sc = with_modes(dump);
        sc.validate().unwrap();
        let r = run(&sc, &mut InProcess::new(), false).unwrap();
        let m = r.summary.momentum.clone().unwrap();
        eprintln!("dump {dump}: keep-up events {:?}, final |h| {:.4}", m.keepup_events, m.final_nms);
        assert_eq!(m.keepup_events, Some(if dump { 0 } else { 1 }));
        assert_eq!((m.gimbal_events, m.fdir_events), (Some(0), 0));
        // Flag only: the mode never changed.
        let last = r.series.len() - 1;
        assert_eq!(col(&r, "mode")[last], col(&r, "mode")[0]);
        assert!(col(&r, "mode").iter().all(|x| *x == col(&r, "mode")[0]));
    }
}
