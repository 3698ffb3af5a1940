//! The mode manager in closed loop: a 3U cubesat from a 10 deg/s tumble through
//! detumble (B-dot, magnetorquers) → stabilise (LQR, wheels, LVLH) → manoeuvre
//! (eigen-axis quaternion feedback) → hold (with integral), then ground commands (new
//! target, locked stabilise, auto). Every automatic transition is checked against the
//! recorded truth: its condition held, with the thresholds of the scenario, over the
//! whole dwell before it, and no transition happened without one.

use acs_tests::{run_in_process, scenario};
use sim_host::columns::Col;
use sim_host::runner::ModeTransition;

struct Series {
    t: Vec<f64>,
    mode: Vec<f64>,
    rate_deg_s: Vec<f64>,
    error_deg: Vec<f64>,
}

fn series(r: &sim_host::runner::RunResult) -> Series {
    let ts = &r.series;
    let c = |n: Col| ts.fixed(n).unwrap_or_else(|| panic!("column {}", n.name())).to_vec();
    let (wx, wy, wz) = (c(Col::RateX), c(Col::RateY), c(Col::RateZ));
    Series {
        t: c(Col::T),
        mode: ts.col("mode").map(<[f64]>::to_vec).unwrap_or_default(),
        rate_deg_s: (0..wx.len())
            .map(|i| (wx[i].powi(2) + wy[i].powi(2) + wz[i].powi(2)).sqrt().to_degrees())
            .collect(),
        error_deg: c(Col::Error),
    }
}

/// Samples in `[t0, t1)`.
fn window(s: &Series, t0: f64, t1: f64) -> impl Iterator<Item = usize> + '_ {
    (0..s.t.len()).filter(move |&i| s.t[i] >= t0 && s.t[i] < t1)
}

#[test]
fn mission_runs_detumble_stabilise_manoeuvre_hold_and_obeys_commands() {
    let sc = scenario("modes/cubesat-mission.toml");
    let m = sc.modes.clone().unwrap();
    let r = run_in_process(&sc);
    let s = series(&r);
    let tr: Vec<(&str, &str, &str)> =
        r.summary.mode_transitions.iter().map(|x| (x.from.as_str(), x.to.as_str(), x.reason.as_str())).collect();
    for x in &r.summary.mode_transitions {
        eprintln!("t = {:8.1} s  {} -> {} ({})", x.t_s, x.from, x.to, x.reason);
    }
    // The nominal sequence, the commanded retarget, the locked stabilise, then auto.
    assert_eq!(
        tr,
        [
            ("detumble", "stabilise", "detumbled"),
            ("stabilise", "manoeuvre", "stabilised"),
            ("manoeuvre", "hold", "on_target"),
            ("hold", "manoeuvre", "off_target"),
            ("manoeuvre", "hold", "on_target"),
            ("hold", "stabilise", "commanded"),
            ("stabilise", "manoeuvre", "stabilised"),
            ("manoeuvre", "hold", "on_target"),
        ]
    );
    let at = |k: usize| -> &ModeTransition { &r.summary.mode_transitions[k] };
    let dt = 1.0 / sc.timing.control_rate_hz;
    let step_out = dt * sc.timing.output_every as f64;

    // Detumble → stabilise: |ω| below the exit rate over the whole dwell (truth; the gyro
    // noise is 1e-5 rad/s = 6e-4 deg/s), and it was above it just before.
    let t_detumbled = at(0).t_s;
    let dwell: Vec<f64> =
        window(&s, t_detumbled - m.dwell_s + step_out, t_detumbled).map(|i| s.rate_deg_s[i]).collect();
    assert!(!dwell.is_empty() && dwell.iter().all(|w| *w < m.detumble_exit_rate_deg_s + 0.01), "{dwell:?}");
    assert!(window(&s, 0.0, t_detumbled - m.dwell_s - step_out).any(|i| s.rate_deg_s[i] > m.detumble_exit_rate_deg_s));
    // The initial 10 deg/s tumble is above the trigger, so no mode but detumble ran before.
    assert!(window(&s, 0.0, t_detumbled).all(|i| s.mode[i] == 1.0));

    // Manoeuvre → hold: the error to the mission target (the runner's error column) stayed
    // below hold_enter over the dwell; the eigen-axis limit held the slew to 1 deg/s.
    for k in [2, 4, 7] {
        let (t0, t1) = (at(k - 1).t_s, at(k).t_s);
        let e: Vec<f64> = window(&s, t1 - m.dwell_s + step_out, t1).map(|i| s.error_deg[i]).collect();
        assert!(!e.is_empty() && e.iter().all(|x| *x < m.hold_enter_error_deg), "transition {k}: {e:?}");
        let peak = window(&s, t0 + 20.0, t1).map(|i| s.rate_deg_s[i]).fold(0.0, f64::max);
        eprintln!("manoeuvre {t0:.0}-{t1:.0} s: peak rate {peak:.3} deg/s");
        assert!(peak < 1.1, "eigen-axis slew rate limit 1 deg/s: {peak}");
    }

    // The retarget at 4200 s: hold leaves after the trigger persistence, not before.
    let retarget = sc.commands[0].at_s;
    assert!(
        at(3).t_s >= retarget + m.trigger_persistence_s - dt && at(3).t_s < retarget + m.trigger_persistence_s + 1.0
    );

    // Locked stabilise 5400-5900 s: converged long before 5900 s but stays until "auto".
    let (lock, auto) = (sc.commands[1].at_s, sc.commands[2].at_s);
    assert!((at(5).t_s - lock).abs() < dt / 2.0);
    assert!(window(&s, lock + dt, auto).all(|i| s.mode[i] == 2.0));
    assert!(at(6).t_s >= auto, "stabilise stayed locked until {auto} s: left at {}", at(6).t_s);

    // Hold: fine pointing, and the last hold lasts to the end.
    let hold: Vec<f64> = window(&s, at(7).t_s + 60.0, f64::INFINITY).map(|i| s.error_deg[i]).collect();
    let rms = (hold.iter().map(|e| e * e).sum::<f64>() / hold.len() as f64).sqrt();
    let max = hold.iter().copied().fold(0.0, f64::max);
    eprintln!(
        "hold: RMS {rms:.4} deg, max {max:.4} deg; wheels peak {:.0} rpm",
        r.summary.max_wheel_speed_rpm.unwrap()
    );
    assert!(rms < 0.02 && max < m.hold_enter_error_deg, "{rms} {max}");
    assert_eq!(r.summary.final_mode.as_deref(), Some("hold"));
    assert!(r.summary.max_wheel_speed_rpm.unwrap() < 10_000.0);
    // B-dot ran on gyro and magnetometer while the star tracker was blind (10 deg/s >
    // its 2 deg/s limit): no step lacked an input its mode needs.
    assert_eq!(r.summary.status_counts.bad_input, 0);
    let blind = sc.sensors.star_tracker.as_ref().and_then(|t| t.max_rate_deg_s).unwrap();
    assert!(s.rate_deg_s[0] > blind);
}

#[test]
fn a_kick_in_hold_returns_to_detumble_and_the_mission_recovers() {
    // Start in hold on target and kick the body. 5 deg/s is above detumble_enter (3 deg/s):
    // the rate trigger fires. 2.5 deg/s is below it but above the star tracker's 2 deg/s:
    // hold is blind, and the lost-input rule must hand over to detumble (gyro and
    // magnetometer only) instead of holding the safe command for ever.
    for (kick_deg_s, why) in [(5.0, "rate_high"), (2.5, "input_lost")] {
        let mut sc = scenario("modes/cubesat-mission.toml");
        let modes = sc.modes.as_mut().unwrap();
        modes.initial = "hold".into();
        let persistence = modes.trigger_persistence_s;
        sc.initial.attitude = sc.target.clone();
        sc.initial.rate_rad_s = [0.0, f64::to_radians(kick_deg_s), 0.0];
        sc.commands.clear();
        sc.duration_s = 5000.0;
        let r = run_in_process(&sc);
        let tr = &r.summary.mode_transitions;
        for x in tr {
            eprintln!("kick {kick_deg_s} deg/s: t = {:8.1} s  {} -> {} ({})", x.t_s, x.from, x.to, x.reason);
        }
        assert_eq!((tr[0].from.as_str(), tr[0].to.as_str(), tr[0].reason.as_str()), ("hold", "detumble", why));
        assert!(tr[0].t_s <= persistence + 1.0, "{}", tr[0].t_s);
        // Blind hold holds the safe command only until the hand-over.
        let bad = r.summary.status_counts.bad_input as f64;
        let dt = 1.0 / sc.timing.control_rate_hz;
        eprintln!("kick {kick_deg_s} deg/s: {bad} steps of safe command before detumble");
        assert!(bad > 0.0 && bad <= tr[0].t_s / dt + 1.0, "{bad}");
        assert_eq!(r.summary.final_mode.as_deref(), Some("hold"));
        assert!(r.summary.final_error_deg < 0.5, "{}", r.summary.final_error_deg);
    }
}

#[test]
fn mode_table_scenarios_are_validated_naming_the_key() {
    let text = std::fs::read_to_string(acs_tests::repo().join("scenarios/modes/cubesat-mission.toml")).unwrap();
    let err = |from: &str, to: &str| {
        assert!(text.contains(from), "{from}");
        format!("{:#}", sim_host::scenario::Scenario::from_toml(&text.replacen(from, to, 1)).unwrap_err())
    };
    let cases = [
        ("hold_exit_error_deg = 3.0", "hold_exit_error_deg = 0.1", "modes.hold_exit_error_deg"),
        ("detumble_exit_rate_deg_s = 1.0", "detumble_exit_rate_deg_s = 5.0", "modes.detumble_enter_rate_deg_s"),
        ("initial = \"detumble\"", "initial = \"safe\"", "modes.initial"),
        ("actuator = \"magnetorquers\"", "actuator = \"thrusters\"", "modes.detumble.actuator"),
        ("mode = \"stabilise\"", "mode = \"sleep\"", "commands[1].mode"),
        ("at_s = 5900.0", "at_s = 100.0", "commands[2]"),
        (
            "[modes.manoeuvre]\nactuator = \"wheels\"",
            "[modes.manoeuvre]\nactuator = \"wheels\"\ntarget = { euler_deg = [0, 0, 0] }",
            "modes.manoeuvre.target",
        ),
    ];
    for (from, to, key) in cases {
        let e = err(from, to);
        assert!(e.contains(key), "expected {key} in: {e}");
    }
    // B-dot on wheels: the flight code's own validation refuses the mode.
    let e = err("[modes.detumble]\nactuator = \"magnetorquers\"", "[modes.detumble]\nactuator = \"wheels\"");
    assert!(e.contains("detumble"), "{e}");
}

#[test]
fn rate_damping_detumbles_a_cmg_craft_on_the_gyro_alone_as_the_closed_form() {
    // Paper 002's 2.5 I kg m² nanosatellite (CMG pyramid, SR steering) tumbling at 3.8 deg/s
    // with a star tracker blind above 1 deg/s: T = -kd ω gives ω(t) = ω₀ e^{-kd t / I}
    // on a spherical body (the steering cancels ω × h).
    use sim_host::scenario::{Controller, StarTrackerSpec};
    let mut sc = scenario("paper002/lqr.toml");
    let kd = 0.5;
    sc.controller = Some(Controller::RateDamping { kd_nms: [kd; 3], torque_limit_nm: [0.2; 3] });
    sc.initial.rate_rad_s = [0.05, -0.03, 0.04];
    sc.initial.orbit_synchronous = false;
    sc.environment.gravity_gradient = false;
    sc.duration_s = 15.0;
    sc.sensors.star_tracker = Some(StarTrackerSpec { max_rate_deg_s: Some(1.0), ..StarTrackerSpec::default() });
    let r = run_in_process(&sc);
    let s = series(&r);
    let w0 = s.rate_deg_s[0];
    let tau = 2.5 / kd;
    let mut worst = 0.0f64;
    for (t, w) in s.t.iter().zip(&s.rate_deg_s) {
        let expect = w0 * (-t / tau).exp();
        worst = worst.max((w - expect).abs() / w0);
    }
    eprintln!(
        "rate damping: |ω| {w0:.2} -> {:.4} deg/s in 15 s; worst deviation from ω₀ e^(-t/τ) {worst:.2e} of ω₀",
        s.rate_deg_s.last().unwrap()
    );
    assert!(worst < 0.01, "{worst}");
    assert_eq!(r.summary.status_counts.bad_input, 0, "needs no attitude");
}
