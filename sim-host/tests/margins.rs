//! `sim-host margins` through its library API (`sim_host::margins::measure`): the same
//! operating point gives the same bits twice and whether the experiments are forked or
//! re-flown from t = 0 (what a QEMU measurement does); a decoupled plant gives a diagonal
//! response; a loop made unstable on purpose, an operating point in wheel stiction and a
//! loop without momentum-exchange actuators are refused with a message, not measured.
//! The closed-form comparisons of the measured response live with the analytic reference.

use sim_core::scenario::Scenario;
use sim_host::margins::{MarginError, MarginOptions, MarginReport, measure};
use std::path::Path;

fn scenario(rel: &str) -> Scenario {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios").join(rel);
    Scenario::load(&p).unwrap_or_else(|e| panic!("{}: {e:#}", p.display()))
}

/// A small measurement: 24 frequencies from the hinted crossover / 30 to Nyquist (about as
/// few as an unrefined grid may have: adjacent frequencies within 1.5×, test 3's 100 Hz
/// loop needs 22), no pilot and no refinement.
fn small(hint: f64) -> MarginOptions {
    MarginOptions { grid_points: 24, crossover_hint_rad_s: Some(hint), refine: false, ..MarginOptions::default() }
}

/// The text of the reference loop's fixture, `tests/scenarios/margins/rigid-pd.toml`:
/// ideal wheels on the body axes, a diagonal inertia, and an operating point that is the
/// target itself at rest (nothing couples the axes but second-order terms). Variants edit
/// it ([`edited`]).
fn rigid_pd_text() -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenarios/margins/rigid-pd.toml");
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// `text` with each `(from, to)` replaced; every `from` must be there.
fn edited(mut text: String, edits: &[(&str, &str)]) -> String {
    for (from, to) in edits {
        assert!(text.contains(from), "{from:?} not in the fixture");
        text = text.replace(from, to);
    }
    text
}

fn bits(r: &MarginReport) -> Vec<u64> {
    r.response.iter().flatten().flatten().flatten().map(|x| x.to_bits()).collect()
}

#[test]
fn the_same_operating_point_gives_the_same_bits_twice_and_forked_equals_reflown() {
    let sc = scenario("paper000/test3.toml");
    let a = measure(&sc, &small(2.0)).unwrap();
    let b = measure(&sc, &small(2.0)).unwrap();
    assert_eq!(a.frequencies_rad_s, b.frequencies_rad_s);
    assert_eq!(bits(&a), bits(&b), "two measurements of the same operating point differ");
    let c = measure(&sc, &MarginOptions { refly: true, threads: 1, ..small(2.0) }).unwrap();
    assert_eq!(bits(&a), bits(&c), "forked experiments differ from experiments re-flown from t = 0");
    assert!(a.stable && a.cost.unconverged_experiments == 0, "{a:?}");
}

#[test]
fn a_diagonal_inertia_on_decoupled_wheels_gives_a_diagonal_response() {
    let sc = Scenario::from_toml(&rigid_pd_text()).unwrap();
    let r = measure(&sc, &small(0.8)).unwrap();
    for l in &r.response {
        for (i, row) in l.iter().enumerate() {
            let diag = row[i][0].hypot(row[i][1]);
            for (j, z) in row.iter().enumerate().filter(|(j, _)| *j != i) {
                let off = z[0].hypot(z[1]);
                assert!(off <= 1e-9 * diag, "L[{i}][{j}] = {off:e} beside |L[{i}][{i}]| = {diag:e}");
            }
        }
    }
    assert!(r.stable);
}

#[test]
fn a_loop_made_unstable_on_purpose_is_reported_unstable_not_measured() {
    // Gains x 10 (K and D) with 0.3 s of sensor latency, from a small initial error.
    let text = edited(
        rigid_pd_text(),
        &[
            ("k_diag_nm = [5.0, 6.0, 7.5]", "k_diag_nm = [50.0, 60.0, 75.0]"),
            ("d_diag_nms = [7.0, 8.4, 10.5]", "d_diag_nms = [70.0, 84.0, 105.0]"),
            ("seed = 1", "seed = 1\nlatency_s = 0.3"),
            ("euler_deg = [0.0, 0.0, 0.0]\nrate", "euler_deg = [1.0, -1.0, 0.5]\nrate"),
        ],
    );
    let sc = Scenario::from_toml(&text).unwrap();
    let e = measure(&sc, &small(1.0)).expect_err("an unstable loop has no margins to measure");
    assert!(matches!(e, MarginError::Unstable { .. } | MarginError::NotSteady { .. }), "{e}");
    assert_eq!(e.exit_code(), 3, "{e}");
}

#[test]
fn wheels_in_stiction_and_loops_without_momentum_exchange_actuators_are_refused() {
    let e = measure(&scenario("paper001/wheel-slew.toml"), &small(0.1)).unwrap_err();
    assert!(matches!(&e, MarginError::NotSteady { reason, .. } if reason.contains("stiction")), "{e}");
    let e = measure(&scenario("paper004/dcm-pd.toml"), &small(0.1)).unwrap_err();
    assert!(matches!(e, MarginError::Unsupported(_)), "{e}");
    assert_eq!(e.exit_code(), 2);
}

/// The Nyquist plot's plan (`margins::plots::plans`, what is drawn): one unit is as many
/// pixels on x as on y (within 2 %: the unit circle is drawn round), the critical point
/// −1 lies inside the drawn range and is marked, and the three identical axes of the
/// reference loop are said to coincide.
#[test]
fn the_nyquist_plot_has_one_scale_on_both_axes_and_shows_the_critical_point() {
    let sc = Scenario::from_toml(&rigid_pd_text()).unwrap();
    let r = measure(&sc, &small(0.8)).unwrap();
    let plans = sim_host::margins::plots::plans(&r);
    let names: Vec<&str> = plans.iter().map(|p| p.file_name.as_str()).collect();
    assert_eq!(names, ["bode.png", "nyquist.png", "disk.png"]);
    // What a run clears before it writes (sim_core::recorder::output::MARGIN_FILES).
    assert_eq!(names, sim_core::recorder::output::MARGIN_FILES[1..]);
    let p = &plans[1];
    let (kx, ky) = sim_host::margins::plots::pixels_per_unit(p, 0);
    assert!((kx / ky - 1.0).abs() <= 0.02, "{kx:.2} px per unit on x, {ky:.2} on y");
    let (x, y) = (p.x_range, p.panels[0].y_range);
    assert!(x.0 < -1.0 && -1.0 < x.1 && y.0 < 0.0 && 0.0 < y.1, "-1 outside the drawn range {x:?} × {y:?}");
    assert!(p.panels[0].points.iter().any(|q| (q.0, q.1) == (-1.0, 0.0)), "the critical point is not marked");
    assert!(p.panels[0].title.contains("coincide within a pixel"), "{:?}", p.panels[0].title);
    for p in &plans {
        assert!(p.legend_area.x0 >= p.plot_area.x1, "{}: legend on the plot area", p.file_name);
        for panel in &p.panels {
            let styles: std::collections::HashSet<_> = panel.lines.iter().map(|l| (l.colour, l.dash)).collect();
            assert_eq!(
                styles.len(),
                panel.lines.len(),
                "{} {}: a (colour, dash) pair repeats",
                p.file_name,
                panel.title
            );
        }
    }
    // The Bode plot marks the crossover.
    let wc = r.axes[0].crossover_rad_s.unwrap().log10();
    assert!(
        plans[0].x_lines.iter().any(|l| (l.0 - wc).abs() < 1e-12 && l.1.starts_with("ω_c")),
        "{:?}",
        plans[0].x_lines
    );
}

/// The reference loop with rotors of 1e-6 kg m², 0.05 N m and 6000 rpm (issue 37, finding
/// 4; 320 RK4 substeps keep the light rotors' torque fade stable). Its operating point is the
/// nominal one (at rest on target, wheels at rest), but any excitation large enough to be
/// measured spins the rotors to their speed limit: before, it was reported "stable" with
/// the unsaturated loop's margins.
fn tiny_rotors_text() -> String {
    edited(
        rigid_pd_text(),
        &[
            ("max_torque_nm = 5.0", "max_torque_nm = 0.05"),
            ("inertia_kgm2 = 0.01", "inertia_kgm2 = 0.000001"),
            ("dynamics_substeps = 20 ", "dynamics_substeps = 320 "),
        ],
    )
}

/// Issue 37, finding 4: a wheel that reaches its speed limit during an experiment makes the
/// measurement refused (not steady, exit status 3, the wheel and the limit named, at a time
/// after the operating point), with the default options (pilot sweep, auto method) and
/// with a hint; the same loop with the nominal rotors is measured.
#[test]
fn wheels_saturating_during_the_experiments_refuse_the_measurement() {
    let sc = Scenario::from_toml(&tiny_rotors_text()).unwrap();
    for opts in [MarginOptions::default(), small(0.8)] {
        let e = measure(&sc, &opts).expect_err("saturated experiments have no linear margin");
        eprintln!("tiny rotors: {e}");
        assert_eq!(e.exit_code(), 3, "{e}");
        let MarginError::NotSteady { t_s, reason } = &e else { panic!("{e}") };
        assert!(reason.contains("wheel") && reason.contains("speed limit"), "{reason}");
        assert!(*t_s > sc.duration_s, "the operating point itself is steady: {t_s}");
    }
    let nominal = measure(&Scenario::from_toml(&rigid_pd_text()).unwrap(), &small(0.8)).unwrap();
    assert!(nominal.stable);
}

/// The plant-side limits `actuator_limit` checks, each reached by an injection on the
/// commands the plant receives at a hold (a step with the injection just under the limit is
/// clean): a wheel's motor torque (rigid-PD fixture, 5 N m), a gimbal's rate (paper 000
/// test 1 at its end, 60°/s) and a rod's dipole (the magnetorquer fixture, 20000 A m²).
#[test]
fn actuator_limits_are_checked_on_the_commands_the_plant_receives() {
    use sim_core::recorder::series::Discard;
    use sim_core::scenario::Resolved;
    use sim_core::simulation::probe::{LoopInjection, Probe};
    use sim_host::margins::excite::{Family, actuator_limit};
    let limit_after = |sc: &Scenario, inj: LoopInjection| {
        let mut link = sim_core::link::open(&sim_core::link::LinkKind::InProcess, &Default::default()).unwrap();
        let mut sim = Probe::new(Resolved::try_from(sc).unwrap(), link.as_mut()).unwrap();
        while sim.steps_done() + 1 < sc.steps() {
            sim.step(&mut Discard).unwrap();
        }
        assert_eq!(actuator_limit(&sim, Family::of(&sim)), None, "at the hold");
        sim.set_injection(Some(inj));
        sim.step(&mut Discard).unwrap();
        actuator_limit(&sim, Family::of(&sim))
    };
    let wheels = Scenario::from_toml(&rigid_pd_text()).unwrap();
    let torque = |x| {
        let mut inj = LoopInjection::default();
        inj.wheel_torque_nm[1] = x;
        inj
    };
    assert_eq!(limit_after(&wheels, torque(4.99)), None);
    let r = limit_after(&wheels, torque(-5.01)).unwrap();
    assert!(r.starts_with("wheel 2 command") && r.contains("beyond its 5.0000e0 N m limit"), "{r}");

    let cmg = scenario("paper000/test1.toml");
    let max = 60f64.to_radians();
    let rate = |x| {
        let mut inj = LoopInjection::default();
        inj.gimbal_rate_rad_s[2] = x;
        inj
    };
    assert_eq!(limit_after(&cmg, rate(0.99 * max)), None);
    let r = limit_after(&cmg, rate(1.01 * max)).unwrap();
    assert!(r.starts_with("gimbal 3 command") && r.contains("rad/s limit"), "{r}");

    let mtq_text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenarios/margins/rigid-mtq.toml"),
    )
    .unwrap();
    let mtq = Scenario::from_toml(&mtq_text).unwrap();
    let dipole = |x| LoopInjection { dipole_am2: [x, 0.0, 0.0], ..Default::default() };
    assert_eq!(limit_after(&mtq, dipole(19_990.0)), None);
    let r = limit_after(&mtq, dipole(20_010.0)).unwrap();
    assert!(r.contains("magnetorquer 1 at its dipole limit"), "{r}");
    // A dead band: a non-zero command inside it makes no torque.
    let banded = Scenario::from_toml(&mtq_text.replace(
        "max_dipole_am2 = [20000.0, 20000.0, 20000.0]",
        "max_dipole_am2 = [20000.0, 20000.0, 20000.0]\ndeadband_am2 = [-100.0, 100.0]",
    ))
    .unwrap();
    let r = limit_after(&banded, dipole(50.0)).unwrap();
    assert!(r.contains("inside its dead band"), "{r}");
}

/// The allocation's `RATE_SCALED` bit is named for the family it scaled (issue 37: a wheel
/// scenario was refused for "gimbal rates scaled").
#[test]
fn the_scaled_commands_bit_is_named_per_actuator_family() {
    use acs_flight::link::{ActuatorCommand, status};
    use sim_host::margins::excite::{Family, nonlinear_status};
    let cmd = ActuatorCommand { status: status::RATE_SCALED, ..Default::default() };
    let wheels = nonlinear_status(&cmd, Some(Family::Wheels)).unwrap();
    assert!(wheels.contains("wheel torques scaled") && !wheels.contains("gimbal"), "{wheels}");
    assert_eq!(nonlinear_status(&cmd, Some(Family::Cmg)).as_deref(), Some("gimbal rates scaled"));
    // Magnetorquers scale along the field at every step (the loop's rank): not a saturation.
    assert_eq!(nonlinear_status(&cmd, Some(Family::Magnetorquers)), None);
}
