//! The mode manager in closed loop on the flight software's own attitude determination: a
//! 3U cubesat from a 10 deg/s tumble through detumble (B-dot, magnetorquers) → sun-safe
//! (coarse sun sensors + gyro, wheels) → stabilise (LQR, wheels, LVLH from on-board
//! navigation) → manoeuvre (eigen-axis quaternion feedback) → hold (with integral), all on
//! the MEKF, then ground commands (new target, locked stabilise, auto). Every automatic
//! transition is checked against the recorded truth: its condition held, with the
//! thresholds of the scenario, over the whole dwell before it, and no transition happened
//! without one.

use acs_tests::{run_in_process, scenario};
use sim_core::recorder::columns::Col;
use sim_core::runner::ModeTransition;

struct Series {
    t: Vec<f64>,
    mode: Vec<f64>,
    rate_deg_s: Vec<f64>,
    error_deg: Vec<f64>,
}

fn series(r: &sim_core::runner::RunResult) -> Series {
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
fn mission_runs_detumble_sun_safe_stabilise_manoeuvre_hold_and_obeys_commands() {
    let sc = scenario("modes/cubesat-mission.toml");
    let m = sc.modes.clone().unwrap();
    let th = m.thresholds().unwrap();
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
            ("detumble", "sun_safe", "detumbled"),
            ("sun_safe", "stabilise", "estimate_valid"),
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
    assert!(!dwell.is_empty() && dwell.iter().all(|w| *w < th.detumble_exit_rate_deg_s + 0.01), "{dwell:?}");
    assert!(window(&s, 0.0, t_detumbled - m.dwell_s - step_out).any(|i| s.rate_deg_s[i] > th.detumble_exit_rate_deg_s));
    // The initial 10 deg/s tumble is above the trigger, so no mode but detumble ran before.
    assert!(window(&s, 0.0, t_detumbled).all(|i| s.mode[i] == 1.0));

    // Sun-safe (Wie's pointing law on the coarse sun sensors): its gains were chosen so its
    // pointing potential cannot spin the body back above detumble_enter (the scenario's
    // comment); the truth rate stays below it, and sun-safe is left when the MEKF's fine
    // attitude is back (the star tracker sees again below 2 deg/s).
    let (t_ss, t_fine) = (at(0).t_s, at(1).t_s);
    let peak_ss = window(&s, t_ss, t_fine).map(|i| s.rate_deg_s[i]).fold(0.0, f64::max);
    eprintln!("sun-safe {t_ss:.0}-{t_fine:.0} s: peak rate {peak_ss:.3} deg/s");
    assert!(peak_ss < th.detumble_enter_rate_deg_s, "{peak_ss}");
    assert!(t_fine - t_ss >= m.dwell_s, "{t_ss} {t_fine}");

    // Manoeuvre → hold: the error to the mission target (the runner's error column) stayed
    // below hold_enter over the dwell; the eigen-axis limit held the slew to 1 deg/s.
    for k in [3, 5, 8] {
        let (t0, t1) = (at(k - 1).t_s, at(k).t_s);
        let e: Vec<f64> = window(&s, t1 - m.dwell_s + step_out, t1).map(|i| s.error_deg[i]).collect();
        assert!(!e.is_empty() && e.iter().all(|x| *x < th.hold_enter_error_deg), "transition {k}: {e:?}");
        let peak = window(&s, t0 + 20.0, t1).map(|i| s.rate_deg_s[i]).fold(0.0, f64::max);
        eprintln!("manoeuvre {t0:.0}-{t1:.0} s: peak rate {peak:.3} deg/s");
        assert!(peak < 1.1, "eigen-axis slew rate limit 1 deg/s: {peak}");
    }

    // The retarget at 7000 s: hold leaves after the trigger persistence, not before.
    let retarget = sc.commands[0].at_s;
    assert!(
        at(4).t_s >= retarget + m.trigger_persistence_s - dt && at(4).t_s < retarget + m.trigger_persistence_s + 1.0
    );

    // Locked stabilise 8200-8700 s: converged long before 8700 s but stays until "auto".
    let (lock, auto) = (sc.commands[1].at_s, sc.commands[2].at_s);
    assert!((at(6).t_s - lock).abs() < dt / 2.0);
    assert!(window(&s, lock + dt, auto).all(|i| s.mode[i] == 2.0));
    assert!(at(7).t_s >= auto, "stabilise stayed locked until {auto} s: left at {}", at(7).t_s);

    // Hold: fine pointing, and the last hold lasts to the end.
    let hold: Vec<f64> = window(&s, at(8).t_s + 60.0, f64::INFINITY).map(|i| s.error_deg[i]).collect();
    let rms = (hold.iter().map(|e| e * e).sum::<f64>() / hold.len() as f64).sqrt();
    let max = hold.iter().copied().fold(0.0, f64::max);
    eprintln!(
        "hold: RMS {rms:.4} deg, max {max:.4} deg; wheels peak {:.0} rpm",
        r.summary.max_wheel_speed_rpm.unwrap()
    );
    assert!(rms < 0.02 && max < th.hold_enter_error_deg, "{rms} {max}");
    assert_eq!(r.summary.final_mode.as_deref(), Some("hold"));
    assert!(r.summary.max_wheel_speed_rpm.unwrap() < 10_000.0);
    // B-dot ran on gyro and magnetometer and sun-safe on the coarse sun sensors and gyro
    // while the star tracker was blind (10 deg/s > its 2 deg/s limit): no step lacked an
    // input or an estimate its mode needs.
    assert_eq!(r.summary.status_counts.bad_input, 0);
    assert_eq!(r.summary.status_counts.no_estimate, 0);
    // Once the filter has its fine attitude (sun-safe → stabilise), it is consistent: mean
    // NEES near 6 (χ² with 6 degrees of freedom; the samples are correlated over many
    // steps, so ±50 % rather than the i.i.d. bound), no restart, and its attitude error
    // within its own σ (√tr Pθθ) in RMS.
    let col = |n: &str| r.series.col(n).unwrap_or_else(|| panic!("column {n}")).to_vec();
    let (nees, err, sig, resets) = (col("est_nees"), col("est_error_deg"), col("est_sigma_deg"), col("est_resets"));
    let fine: Vec<usize> = window(&s, t_fine, f64::INFINITY).collect();
    let mean = |v: &[f64]| fine.iter().map(|&i| v[i]).sum::<f64>() / fine.len() as f64;
    let rms = |v: &[f64]| fine.iter().map(|&i| v[i] * v[i]).sum::<f64>().sqrt() / (fine.len() as f64).sqrt();
    let (nees_fine, err_rms, sig_rms) = (mean(&nees), rms(&err), rms(&sig));
    eprintln!("after fine attitude: NEES {nees_fine:.2}, error RMS {err_rms:.4} deg, σ RMS {sig_rms:.4} deg");
    assert!((3.0..9.0).contains(&nees_fine), "{nees_fine}");
    assert!(err_rms < 1.5 * sig_rms, "{err_rms} {sig_rms}");
    assert!(fine.iter().all(|&i| resets[i] == resets[fine[0]]));
    // Before the tracker locks (tumble and sun-safe: gyro, magnetometer and coarse sun
    // sensors only), the filter is honest too: its coarse vectors' correlated errors are
    // fused at most every `coarse_update_interval_s`. Mean NEES in the same band, the
    // actual RMS error not above 1.5 × the σ it claims (the σ's RMS is dominated by the
    // 5° it starts with: conservative, not overconfident), the bias error within its 3σ at
    // 99 % of the steps, and no restart when the tracker first sees.
    let (b_err, b_sig) = (col("est_bias_error_deg_h"), col("est_bias_sigma_deg_h"));
    let coarse: Vec<usize> = window(&s, 0.0, t_fine).filter(|&i| nees[i].is_finite()).collect();
    let cmean = |v: &[f64]| coarse.iter().map(|&i| v[i]).sum::<f64>() / coarse.len() as f64;
    let crms = |v: &[f64]| (coarse.iter().map(|&i| v[i] * v[i]).sum::<f64>() / coarse.len() as f64).sqrt();
    let within_3sigma = coarse.iter().filter(|&&i| b_err[i] <= 3.0 * b_sig[i]).count() as f64 / coarse.len() as f64;
    eprintln!(
        "coarse sensors only ({} steps): NEES {:.2}, error RMS {:.3} deg, σ RMS {:.3} deg, bias within 3σ {:.1} %",
        coarse.len(),
        cmean(&nees),
        crms(&err),
        crms(&sig),
        100.0 * within_3sigma
    );
    assert!(coarse.len() > 100);
    assert!((3.0..9.0).contains(&cmean(&nees)), "{}", cmean(&nees));
    assert!(crms(&err) < 1.5 * crms(&sig), "{} {}", crms(&err), crms(&sig));
    assert!(within_3sigma >= 0.99, "{within_3sigma}");
    assert_eq!(r.summary.estimator_resets, Some(0));
    eprintln!(
        "estimation: RMS {:?} deg, max {:?} deg, NEES {:?}, bias error {:?} deg/h, rejected {:?}, resets {:?}",
        r.summary.estimation_error_rms_deg,
        r.summary.estimation_error_max_deg,
        r.summary.nees_mean,
        r.summary.bias_error_final_deg_h,
        r.summary.innovations_rejected,
        r.summary.estimator_resets
    );
    let blind = sc.sensors.star_tracker.as_ref().and_then(|t| t.max_rate_deg_s).unwrap();
    assert!(s.rate_deg_s[0] > blind);
}

/// The mission started in hold on target at `rate_deg_s` about y, with the star tracker
/// off over `outage_s`, on the MEKF or on the tracker's quaternion as measured.
fn from_hold(
    rate_deg_s: f64,
    outage_s: Option<[f64; 2]>,
    mekf: bool,
) -> (sim_core::scenario::Scenario, sim_core::runner::RunResult) {
    let mut sc = scenario("modes/cubesat-mission.toml");
    let modes = sc.modes.as_mut().unwrap();
    modes.initial = "hold".into();
    sc.initial.attitude = sc.target.clone().unwrap();
    sc.initial.rate_rad_s = [0.0, f64::to_radians(rate_deg_s), 0.0];
    sc.commands.clear();
    sc.duration_s = 5000.0;
    sc.timing.output_every = 1;
    sc.sensors.star_tracker.as_mut().unwrap().outages_s = outage_s.into_iter().collect();
    if !mekf {
        // The attitude as the star tracker measures it (no filter between).
        sc.estimation = None;
    }
    let r = run_in_process(&sc);
    for x in &r.summary.mode_transitions {
        eprintln!(
            "from hold at {rate_deg_s} deg/s, outage {outage_s:?}, MEKF {mekf}: t = {:8.1} s  {} -> {} ({})",
            x.t_s, x.from, x.to, x.reason
        );
    }
    (sc, r)
}

fn steps_without_inputs(r: &sim_core::runner::RunResult) -> u64 {
    r.summary.status_counts.bad_input + r.summary.status_counts.no_estimate
}

#[test]
fn a_kick_in_hold_is_handled_by_the_rate_trigger_or_the_lost_input_rule() {
    // The filter starts cold and the star tracker is blind above 2 deg/s: hold has no fine
    // attitude (TRIAD on Sun and field gives the filter 5 deg) and holds the safe command
    // until a rule hands over. 5 deg/s is above detumble_enter (3 deg/s): the rate trigger
    // fires after its persistence. 2.5 deg/s is below it: the lost-input rule hands over
    // to sun-safe (coarse sun sensors and gyro), which damps the rate; the tracker returns
    // and the mission climbs back to hold.
    for (kick_deg_s, to, why) in [(5.0, "detumble", "rate_high"), (2.5, "sun_safe", "input_lost")] {
        let (sc, r) = from_hold(kick_deg_s, None, true);
        let m = sc.modes.as_ref().unwrap();
        let tr = &r.summary.mode_transitions;
        assert_eq!((tr[0].from.as_str(), tr[0].to.as_str(), tr[0].reason.as_str()), ("hold", to, why));
        assert!(tr[0].t_s <= m.trigger_persistence_s + 1.0, "{}", tr[0].t_s);
        let blind = steps_without_inputs(&r) as f64;
        let dt = 1.0 / sc.timing.control_rate_hz;
        eprintln!("kick {kick_deg_s} deg/s: {blind} steps of safe command before {to}");
        assert!(blind > 0.0 && blind <= tr[0].t_s / dt + 1.0, "{blind}");
        assert_eq!(r.summary.final_mode.as_deref(), Some("hold"));
        assert!(r.summary.final_error_deg < 0.5, "{}", r.summary.final_error_deg);
    }
}

#[test]
fn the_mekf_carries_hold_through_a_tracker_outage_that_blinds_the_raw_tracker() {
    // Ten minutes without the star tracker from 1000 s, in hold at rest. On the MEKF the
    // attitude is carried by the gyro: after t s its 1σ grows as √(σv² t + σu² t³/3)
    // (gyro ARW σv, RRW σu) — 0.051 deg after 600 s (the RRW term dominates), under the
    // 0.1 deg lost threshold — so hold never lets go, and the pointing error grows by at
    // most a few of those σ.
    let outage = [1000.0, 1600.0];
    let (sc, r) = from_hold(0.0, Some(outage), true);
    let e = sc.estimation.as_ref().unwrap();
    let t = outage[1] - outage[0];
    let sigma_deg =
        (e.gyro_arw_rad_sqrt_s.powi(2) * t + e.gyro_rrw_rad_s_sqrt_s.powi(2) * t.powi(3) / 3.0).sqrt().to_degrees();
    assert!(r.summary.mode_transitions.is_empty(), "{:?}", r.summary.mode_transitions);
    assert_eq!(steps_without_inputs(&r), 0);
    let s = series(&r);
    let worst = window(&s, outage[0], outage[1] + 60.0).map(|i| s.error_deg[i]).fold(0.0, f64::max);
    let before = window(&s, outage[0] - 300.0, outage[0]).map(|i| s.error_deg[i]).fold(0.0, f64::max);
    eprintln!(
        "outage on the MEKF: worst pointing error {worst:.4} deg (before {before:.4}), 1σ growth {sigma_deg:.4} deg"
    );
    assert!(worst < before + 3.0 * sigma_deg.max(0.0) + 0.01, "{worst} {before} {sigma_deg}");

    // On the tracker's quaternion the same outage blinds hold: the lost-input rule drops to
    // sun-safe after its persistence, and the mission returns to hold after the outage.
    let (sc, r) = from_hold(0.0, Some(outage), false);
    let m = sc.modes.as_ref().unwrap();
    let tr = &r.summary.mode_transitions;
    assert_eq!((tr[0].from.as_str(), tr[0].to.as_str(), tr[0].reason.as_str()), ("hold", "sun_safe", "input_lost"));
    assert!(tr[0].t_s >= outage[0] && tr[0].t_s <= outage[0] + m.trigger_persistence_s + 1.0, "{}", tr[0].t_s);
    let back = tr.iter().find(|x| x.from == "sun_safe").expect("leaves sun-safe");
    assert!(back.t_s >= outage[1], "{}", back.t_s);
    assert_eq!(r.summary.final_mode.as_deref(), Some("hold"));
}

#[test]
fn mode_table_scenarios_are_validated_naming_the_key() {
    let text = std::fs::read_to_string(acs_tests::repo().join("scenarios/modes/cubesat-mission.toml")).unwrap();
    let err = |from: &str, to: &str| {
        assert!(text.contains(from), "{from}");
        format!("{:#}", sim_core::scenario::Scenario::from_toml(&text.replacen(from, to, 1)).unwrap_err())
    };
    let cases = [
        ("hold_exit_error_deg = 3.0", "hold_exit_error_deg = 0.1", "modes.hold_exit_error_deg"),
        ("detumble_exit_rate_deg_s = 1.0", "detumble_exit_rate_deg_s = 5.0", "modes.detumble_enter_rate_deg_s"),
        ("initial = \"detumble\"", "initial = \"safe\"", "modes.initial"),
        ("actuator = \"magnetorquers\"", "actuator = \"thrusters\"", "modes.detumble.actuator"),
        ("mode = \"stabilise\"", "mode = \"sleep\"", "commands[1].mode"),
        ("at_s = 8700.0", "at_s = 100.0", "commands[2]"),
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
    use sim_core::scenario::{Controller, StarTrackerSpec};
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
