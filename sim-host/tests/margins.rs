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

/// A small measurement: 4 frequencies from the hinted crossover / 30 to Nyquist, no pilot
/// and no refinement.
fn small(hint: f64) -> MarginOptions {
    MarginOptions { grid_points: 4, crossover_hint_rad_s: Some(hint), refine: false, ..MarginOptions::default() }
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
