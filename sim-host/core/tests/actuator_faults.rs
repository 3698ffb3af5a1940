//! `[[faults]]` on CMGs and thrusters (issue 42), each against its closed form, flown
//! through the whole run loop (`Simulation`, open loop, free space: no external torque but
//! the thrusters'), so the injection path of a run is the one tested.

use sim_core::attitude::Vec3;
use sim_core::link::in_process::InProcess;
use sim_core::plant::State;
use sim_core::plant::thrusters::G0_M_S2;
use sim_core::recorder::series::Discard;
use sim_core::recorder::summary::Summary;
use sim_core::scenario::{Resolved, Scenario};
use sim_core::simulation::Simulation;

/// A four-CMG pyramid flown open loop: gimbal rates [0.1, -0.05, 0.08, 0.02] rad/s.
const CMG: &str = r#"
name = "cmg-faults"
duration_s = 6.0
[timing]
control_rate_hz = 10.0
dynamics_substeps = 4
[spacecraft]
inertia_kgm2 = [[3.1, 0, 0], [0, 3.4, 0], [0, 0, 5.8]]
[initial]
euler_deg = [10, -20, 30]
rate_rad_s = [0.01, -0.02, 0.015]
[target]
euler_deg = [0, 0, 0]
[actuators.cmg]
layout = "pyramid4"
skew_deg = 54.73
h0_nms = 0.623
max_gimbal_rate_deg_s = 60.0
initial_gimbal_deg = [10.0, -20.0, 30.0, 5.0]
[controller]
type = "none"
[open_loop]
commands = [{ t_s = 0.0, gimbal_rate_rad_s = [0.1, -0.05, 0.08, 0.02] }]
"#;

/// The gimbal-rate commands of `CMG`, rad/s, as the f32 of the wire carries them.
const RATES: [f64; 4] = [0.1f32 as f64, -0.05f32 as f64, 0.08f32 as f64, 0.02f32 as f64];
const DT: f64 = 0.1;

/// Three thrusters of 2 N about the CG at the origin: 0 at y = +0.5 m and 1 at y = -0.5 m
/// both pushing +x (torques -1 and +1 N m about z), 2 at x = 0.3 m pushing +z (-0.6 N m
/// about y). Thruster 1 (paper numbering 2) is commanded on throughout; no delays.
const THRUSTERS: &str = r#"
name = "thruster-faults"
duration_s = 6.0
[timing]
control_rate_hz = 10.0
dynamics_substeps = 4
[spacecraft]
inertia_kgm2 = [[9.0, 0, 0], [0, 13.0, 0], [0, 0, 11.0]]
[initial]
euler_deg = [0, 0, 0]
[target]
euler_deg = [0, 0, 0]
[actuators.thrusters]
layout = "geometry"
positions_m = [[0.0, 0.5, 0.0], [0.0, -0.5, 0.0], [0.3, 0.0, 0.0]]
directions = [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
thrust_n = 2.0
isp_s = 220.0
[controller]
type = "none"
[open_loop]
commands = [{ t_s = 0.0, thrusters_on = [2] }]
"#;

fn parse(base: &str, faults: &str) -> Scenario {
    Scenario::from_toml(&format!("{base}{faults}")).unwrap()
}

fn err_of(base: &str, faults: &str) -> String {
    format!("{:#}", Scenario::from_toml(&format!("{base}{faults}")).unwrap_err())
}

fn entry(unit: &str, kind: &str, more: &str) -> String {
    format!("[[faults]]\nonset_s = 1.0\nunit = \"{unit}\"\nkind = \"{kind}\"\n{more}\n")
}

/// The plant state at every control step (t = k DT) and the summary.
fn fly(sc: &Scenario) -> (Vec<State>, Summary) {
    let mut link = InProcess::new();
    let mut sim = Simulation::new(Resolved::try_from(sc).unwrap(), &mut link).unwrap();
    let mut states = Vec::new();
    while !sim.finished() {
        states.push(*sim.state());
        sim.step(&mut Discard).unwrap();
    }
    (states, sim.summary(1.0))
}

#[test]
fn cmg_and_thruster_entries_are_refused_naming_the_key() {
    let wheels_only = CMG.replace(
        "[actuators.cmg]\nlayout = \"pyramid4\"\nskew_deg = 54.73\nh0_nms = 0.623\nmax_gimbal_rate_deg_s = 60.0\n\
         initial_gimbal_deg = [10.0, -20.0, 30.0, 5.0]\n",
        "[actuators.magnetorquers]\nmax_dipole_am2 = [0.2, 0.2, 0.2]\n[environment]\nlab_field_t = [2e-5, 0, 0]\n",
    );
    let wheels_only = wheels_only.replace("gimbal_rate_rad_s = [0.1, -0.05, 0.08, 0.02]", "dipole_am2 = [0, 0, 0]");
    assert!(Scenario::from_toml(&wheels_only).is_ok(), "the base without CMGs parses");
    let cases = [
        (CMG, entry("cmg.4", "gimbal_stuck", ""), "faults[0].unit", "cmg.0 to cmg.3"),
        (CMG, entry("cmg.x", "gimbal_stuck", ""), "faults[0].unit", "0-based"),
        (CMG, entry("cmg", "gimbal_stuck", ""), "faults[0].unit", "0-based"),
        (CMG, entry("cmg.1", "stuck", ""), "faults[0].kind", "\"gimbal_stuck\", \"rotor_spin_down\""),
        (CMG, entry("cmg.1", "gimbal_stuck", "magnitude = 1.0"), "faults[0].magnitude", "takes no magnitude"),
        (CMG, entry("cmg.1", "rotor_spin_down", ""), "faults[0].magnitude", "required"),
        (CMG, entry("cmg.1", "rotor_spin_down", "magnitude = 0.5"), "faults[0].magnitude", "out of range"),
        (CMG, entry("cmg.1", "rotor_spin_down", "magnitude = 2e7"), "faults[0].magnitude", "out of range"),
        (CMG, entry("cmg.1", "rotor_spin_down", "magnitude = -3.0"), "faults[0].magnitude", "out of range"),
        (CMG, entry("thruster.0", "stuck_open", ""), "faults[0].unit", "no thruster (no [actuators.thrusters])"),
        (&wheels_only, entry("cmg.0", "gimbal_stuck", ""), "faults[0].unit", "no cmg (no [actuators.cmg])"),
        (THRUSTERS, entry("thruster.3", "stuck_open", ""), "faults[0].unit", "thruster.0 to thruster.2"),
        (THRUSTERS, entry("thruster.-1", "stuck_open", ""), "faults[0].unit", "0-based"),
        (THRUSTERS, entry("thruster.1", "stuck_closed", "magnitude = 1.0"), "faults[0].magnitude", "no magnitude"),
        (THRUSTERS, entry("thruster.1", "stuck_open", "magnitude = 1.0"), "faults[0].magnitude", "no magnitude"),
        (THRUSTERS, entry("thruster.1", "open", ""), "faults[0].kind", "\"stuck_closed\", \"stuck_open\""),
        (THRUSTERS, entry("cmg.0", "rotor_spin_down", "magnitude = 10.0"), "faults[0].unit", "no cmg"),
        (THRUSTERS, entry("thruster.0", "stuck_open", "end_s = 1.0"), "faults[0].end_s", "> onset_s"),
    ];
    for (base, text, key, why) in &cases {
        let e = err_of(base, text);
        assert!(e.contains(key) && e.contains(why), "expected {key} / {why} in: {e}");
    }
    // The second entry is named by its own index.
    let e = err_of(THRUSTERS, &(entry("thruster.0", "stuck_open", "") + &entry("thruster.9", "stuck_closed", "")));
    assert!(e.contains("faults[1].unit"), "{e}");
    // Valid entries are typed with their unit, kind and magnitude as the summary names them.
    let f = parse(CMG, &entry("cmg.3", "rotor_spin_down", "magnitude = 30.0")).faults().unwrap();
    assert_eq!(
        (f[0].fault.unit(), f[0].fault.kind(), f[0].fault.magnitude()),
        ("cmg.3".into(), "rotor_spin_down", Some(30.0))
    );
    let f = parse(THRUSTERS, &entry("thruster.2", "stuck_open", "")).faults().unwrap();
    assert_eq!(
        (f[0].fault.unit(), f[0].fault.kind(), f[0].fault.magnitude()),
        ("thruster.2".into(), "stuck_open", None)
    );
}

#[test]
fn a_stuck_gimbal_keeps_its_angle_to_the_bit_and_the_others_follow_their_commands() {
    let sc = parse(CMG, "[[faults]]\nonset_s = 2.0\nunit = \"cmg.1\"\nkind = \"gimbal_stuck\"\nend_s = 4.0\n");
    let craft = sc.spacecraft().unwrap();
    let cluster = craft.cmg.clone().unwrap();
    let (states, summary) = fly(&sc);
    let d0: Vec<f64> = [10.0f64, -20.0, 30.0, 5.0].iter().map(|d| d.to_radians()).collect();
    let held = states[20].gimbal_rad[1];
    let h_held = cluster.unit_momentum(1, held);
    let h0 = craft.angular_momentum_inertial(&states[0]);
    let mut worst_h = 0.0f64;
    for (k, s) in states.iter().enumerate() {
        let t = k as f64 * DT;
        // Closed form: δ_i(t) = δ_i(0) + r_i t for the healthy ones; the stuck one loses
        // the 2 s of its window. RK4 of a constant rate: round-off only.
        for i in [0, 2, 3] {
            assert!((s.gimbal_rad[i] - (d0[i] + RATES[i] * t)).abs() < 1e-12, "gimbal {i} at {t}");
        }
        let moving_s = t.min(2.0) + (t - 4.0).max(0.0);
        assert!((s.gimbal_rad[1] - (d0[1] + RATES[1] * moving_s)).abs() < 1e-12, "gimbal 1 at {t}");
        if (20..=40).contains(&k) {
            // Seized from 2.0 s (a dynamics step) through the step that ends at 4.0 s.
            assert_eq!(s.gimbal_rad[1].to_bits(), held.to_bits(), "gimbal 1 at {t}");
            assert_eq!(cluster.unit_momentum(1, s.gimbal_rad[1]), h_held, "its momentum direction at {t}");
        }
        worst_h = worst_h.max((craft.angular_momentum_inertial(s) - h0).norm() / h0.norm());
    }
    // Free space: the total is conserved whatever the gimbals do.
    eprintln!("stuck gimbal: largest relative drift of the total angular momentum {worst_h:e}");
    assert!(worst_h < 1e-10, "{worst_h:e}");
    let rec = &summary.faults.unwrap()[0];
    assert_eq!(
        (rec.unit.as_str(), rec.kind, rec.magnitude, rec.injected_at_s),
        ("cmg.1", "gimbal_stuck", None, Some(2.0))
    );
}

#[test]
fn a_stuck_gimbal_gives_the_body_no_torque() {
    // At rest, only CMG 1 commanded, seized from 0 to 3 s: with ω = 0 there is no body-rate
    // coupling, so the body gets no torque at all: its rate stays 0 to the bit. Freed, the
    // gimbal moves and the body turns (the command was real).
    let text = CMG
        .replace("rate_rad_s = [0.01, -0.02, 0.015]", "rate_rad_s = [0.0, 0.0, 0.0]")
        .replace("[0.1, -0.05, 0.08, 0.02]", "[0.0, 0.3, 0.0, 0.0]");
    let sc = parse(&text, "[[faults]]\nonset_s = 0.0\nunit = \"cmg.1\"\nkind = \"gimbal_stuck\"\nend_s = 3.0\n");
    let (states, _) = fly(&sc);
    for (k, s) in states.iter().enumerate().take(31) {
        assert_eq!(s.w, Vec3::zeros(), "body rate at {} s", k as f64 * DT);
        assert_eq!(s.gimbal_rad[1], states[0].gimbal_rad[1]);
    }
    assert!(states[40].w.norm() > 1e-3, "freed, the gimbal turns the body: {}", states[40].w);
}

#[test]
fn a_stuck_gimbal_with_a_servo_is_at_rest_and_its_servo_restarts_from_rest() {
    // Servo lag τ = 0.2 s, no friction: freed at 2 s from rest, the rate follows
    // r (1 - exp(-(t - 2)/τ)) (the servo's first-order closed form).
    let tau = 0.2;
    let text = CMG.replace(
        "initial_gimbal_deg",
        &format!("servo_time_constant_s = {tau}\ngimbal_inertia_kgm2 = 0.01\ninitial_gimbal_deg"),
    );
    let sc = parse(&text, "[[faults]]\nonset_s = 1.0\nunit = \"cmg.3\"\nkind = \"gimbal_stuck\"\nend_s = 2.0\n");
    let (states, _) = fly(&sc);
    let held = states[10].gimbal_rad[3];
    assert!(states[10].gimbal_rate_rad_s[3].abs() > 0.9 * RATES[3], "moving at the onset");
    for s in &states[11..=20] {
        assert_eq!((s.gimbal_rad[3].to_bits(), s.gimbal_rate_rad_s[3]), (held.to_bits(), 0.0));
    }
    let mut worst = 0.0f64;
    for (k, s) in states.iter().enumerate().skip(20) {
        let t = k as f64 * DT - 2.0;
        worst = worst.max((s.gimbal_rate_rad_s[3] - RATES[3] * (1.0 - (-t / tau).exp())).abs());
    }
    // RK4 at h = 25 ms on a τ = 0.2 s lag: (h/τ)⁵/120 ≈ 2.5e-7 of the rate a step, over
    // the few τ/h = 8 steps before it decays: a few 1e-6.
    eprintln!("stuck gimbal with a servo: largest rate error after release {worst:e} rad/s");
    assert!(worst < 1e-5 * RATES[3], "{worst:e}");
}

#[test]
fn a_spinning_down_rotor_decays_as_the_exponential_and_the_body_takes_its_momentum() {
    let tau = 3.0;
    let sc = parse(
        CMG,
        &format!(
            "[[faults]]\nonset_s = 1.0\nunit = \"cmg.2\"\nkind = \"rotor_spin_down\"\nmagnitude = {tau}\nend_s = 5.0\n"
        ),
    );
    let craft = sc.spacecraft().unwrap();
    let (states, summary) = fly(&sc);
    let h0 = craft.angular_momentum_inertial(&states[0]);
    let (mut worst_scale, mut worst_h) = (0.0f64, 0.0f64);
    for (k, s) in states.iter().enumerate() {
        let t = k as f64 * DT;
        // Closed form: h(t) = h0 exp(-(t - 1)/τ) in [1, 5) s, then held.
        let want = (-((t.min(5.0) - 1.0).max(0.0)) / tau).exp();
        worst_scale = worst_scale.max((s.cmg_rotor_scale[2] - want).abs() / want);
        for i in [0, 1, 3] {
            assert_eq!(s.cmg_rotor_scale[i], 1.0, "rotor {i} at {t}");
        }
        if t < 1.0 {
            assert_eq!(s.cmg_rotor_scale[2], 1.0);
        }
        worst_h = worst_h.max((craft.angular_momentum_inertial(s) - h0).norm() / h0.norm());
    }
    // RK4 on ṡ = -s/τ at h = 25 ms: (h/τ)⁵/120 ≈ 3e-13 a step, 160 steps.
    eprintln!("rotor spin-down: largest relative error to the exponential {worst_scale:e}");
    assert!(worst_scale < 1e-9, "{worst_scale:e}");
    // The rotor's lost momentum went to the body (bearing friction is internal): the
    // total is conserved.
    eprintln!("rotor spin-down: largest relative drift of the total angular momentum {worst_h:e}");
    assert!(worst_h < 1e-10, "{worst_h:e}");
    // Held after the window, at exp(-4/3) of h0.
    assert!((states[59].cmg_rotor_scale[2] - (-4.0f64 / tau).exp()).abs() < 1e-9);
    let rec = &summary.faults.unwrap()[0];
    assert_eq!((rec.unit.as_str(), rec.kind, rec.magnitude), ("cmg.2", "rotor_spin_down", Some(tau)));
}

#[test]
fn a_cmg_fault_after_the_run_changes_nothing() {
    let (a, _) = fly(&parse(CMG, ""));
    let (b, _) = fly(&parse(
        CMG,
        "[[faults]]\nonset_s = 100.0\nunit = \"cmg.0\"\nkind = \"rotor_spin_down\"\nmagnitude = 5.0\n",
    ));
    assert_eq!(a, b);
}

#[test]
fn stuck_thrusters_give_the_body_their_r_cross_f_torque_exactly_over_their_window() {
    // Thruster 1 (commanded on) stuck closed from 2 s; thruster 0 (never commanded) stuck
    // open from 3.01 s (inside a dynamics step: the valve model cuts the step there) to 5 s.
    let sc = parse(
        THRUSTERS,
        "[[faults]]\nonset_s = 2.0\nunit = \"thruster.1\"\nkind = \"stuck_closed\"\n\
         [[faults]]\nonset_s = 3.01\nunit = \"thruster.0\"\nkind = \"stuck_open\"\nend_s = 5.0\n",
    );
    let craft = sc.spacecraft().unwrap();
    let jz = 11.0;
    let (states, summary) = fly(&sc);
    // r × F by hand: (0, -0.5, 0) × (2, 0, 0) = (0, 0, +1) N m for thruster 1, and
    // (0, 0.5, 0) × (2, 0, 0) = (0, 0, -1) N m for thruster 0. A torque about a principal
    // axis from rest keeps the rotation about it: ω = (0, 0, ∫τ_z / J_z), H = (0, 0, ∫τ_z).
    let impulse = |t: f64| t.min(2.0) - (t.min(5.0) - 3.01).max(0.0);
    let mut worst = 0.0f64;
    for (k, s) in states.iter().enumerate() {
        let t = k as f64 * DT;
        let want_w = Vec3::new(0.0, 0.0, impulse(t) / jz);
        worst = worst.max((s.w - want_w).norm());
        let h = craft.angular_momentum_inertial(s);
        assert!((h - Vec3::new(0.0, 0.0, impulse(t))).norm() < 1e-12, "ΔH ≠ impulse at {t}: {h}");
    }
    eprintln!("stuck thrusters: largest body-rate error to the closed form {worst:e} rad/s");
    assert!(worst < 1e-13, "{worst:e}");
    // Propellant: valves open 2 s (thruster 1) + 1.99 s (thruster 0) at 2 N, Isp 220 s.
    let want = 2.0 * (2.0 + 1.99) / (220.0 * G0_M_S2);
    let got = summary.propellant_kg.unwrap();
    assert!((got - want).abs() < 1e-12 * want, "{got} vs {want}");
    let recs = summary.faults.unwrap();
    assert_eq!((recs[0].unit.as_str(), recs[0].kind), ("thruster.1", "stuck_closed"));
    assert_eq!((recs[1].unit.as_str(), recs[1].kind, recs[1].injected_at_s), ("thruster.0", "stuck_open", Some(3.1)));
}
