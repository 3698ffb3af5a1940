//! Issue 25 proof: `sim-host margins` (the loop broken at the wheel torque command, measured
//! through the flight step in SIL) against the closed form of
//! `acs_test_support::loop_reference` (derived independently of the measurement), on the
//! rigid-body loop of tests/scenarios/margins/rigid-pd.toml and its variants (actuator lag,
//! whole and fractional sample delays, inertia × 2, gains × 10 with a delay).
//!
//! Per axis: measured `L_ii(e^{jωT})` within 1 % in magnitude and 1° in phase of the closed
//! form over the whole grid, the off-diagonal terms below 1 % of the diagonal; crossover,
//! phase margin, delay margin and high gain margin within 1 %; a plant delay Δ lowers the
//! phase margin by ωc Δ (1°); the inertia × 2 moves the crossover where the closed form puts
//! it; the high gain margin includes the phase crossover at the Nyquist frequency (the sampled
//! PD loop is real and negative there); gains × 10 with a delay give a non-zero exit and no
//! crash, and are reported unstable with the closed form's negative phase margin, measured
//! with the loop broken open (auto's fallback); the open-loop method on the nominal loop
//! gives the closed-loop method's response and margins.
//!
//! The measurement runs the release CLI (`target/release/sim-host`, built here if needed).

use acs_test_support::loop_reference::{AxisLoop, C, Margins, margins};
use acs_tests::repo;
use serde_json::Value;
use std::process::Command;

const BASE: &str = "tests/scenarios/margins/rigid-pd.toml";
/// Scenario inertia (wheels included) and the wheels' axial inertia.
const J: [f64; 3] = [10.0, 12.0, 15.0];
const J_WHEEL: f64 = 0.01;
const K: [f64; 3] = [5.0, 6.0, 7.5];
const D: [f64; 3] = [7.0, 8.4, 10.5];
const T: f64 = 0.1;

/// A variant of the base scenario: `edits` = (line prefix to replace, new line) or
/// (`[actuators.wheels]`, lines to add to that table).
fn variant(name: &str, edits: &[(&str, &str)]) -> String {
    let mut text = std::fs::read_to_string(repo().join(BASE)).unwrap();
    for (from, to) in edits {
        if from.starts_with('[') {
            text = text.replace(from, &format!("{from}\n{to}"));
        } else {
            let line = text.lines().find(|l| l.starts_with(from)).unwrap_or_else(|| panic!("{from}")).to_string();
            text = text.replace(&line, to);
        }
    }
    text.replace("name = \"margins-rigid-pd\"", &format!("name = \"margins-{name}\""))
}

/// Runs `sim-host margins SCENARIO --json --out DIR`: (exit code, margins.json or stdout).
fn measure(name: &str, text: &str) -> (Option<i32>, Option<Value>, String) {
    measure_with(name, text, &[])
}

/// [`measure`] with extra arguments (`--method open`).
fn measure_with(name: &str, text: &str, args: &[&str]) -> (Option<i32>, Option<Value>, String) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    let out = dir.path().join("out");
    let o = Command::new(acs_tests::sim_host_bin())
        .args(["margins", path.to_str().unwrap(), "--json", "--out", out.to_str().unwrap()])
        .args(args)
        .output()
        .expect("running sim-host margins");
    let stderr = String::from_utf8_lossy(&o.stderr).to_string();
    let file = std::fs::read_to_string(out.join("margins.json")).ok();
    let json = file.and_then(|f| serde_json::from_str(&f).ok()).or_else(|| serde_json::from_slice(&o.stdout).ok());
    (o.status.code(), json, stderr)
}

fn reference(axis: usize, delay_s: f64, lag_s: f64, inertia_factor: f64, gain_factor: f64) -> AxisLoop {
    AxisLoop {
        plant_inertia_kgm2: J[axis] * inertia_factor - J_WHEEL,
        k_nm: K[axis] * gain_factor,
        d_nms: D[axis] * gain_factor,
        period_s: T,
        delay_s,
        lag_s,
    }
}

fn num(v: &Value) -> Option<f64> {
    v.as_f64()
}

/// `L[i][j]` at each frequency of the measurement.
fn response(m: &Value, i: usize, j: usize) -> Vec<C> {
    m["response"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            let c = &f[i][j];
            C::new(c[0].as_f64().unwrap(), c[1].as_f64().unwrap())
        })
        .collect()
}

fn within(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs()
}

/// Compares one measurement with the closed form on every axis; returns the reference
/// margins per axis.
fn check_against_reference(name: &str, m: &Value, delay_s: f64, lag_s: f64, inertia: f64) -> Vec<Margins> {
    let freqs: Vec<f64> = m["frequencies_rad_s"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert!((m["control_period_s"].as_f64().unwrap() - T).abs() < 1e-12);
    let nyq = std::f64::consts::PI / T;
    let mut out = Vec::new();
    for axis in 0..3 {
        let r = reference(axis, delay_s, lag_s, inertia, 1.0);
        let meas = response(m, axis, axis);
        let (mut worst_mag, mut worst_ph) = (0.0f64, 0.0f64);
        for (w, l) in freqs.iter().zip(&meas) {
            let ratio = *l / r.response(*w);
            worst_mag = worst_mag.max((ratio.norm() - 1.0).abs());
            worst_ph = worst_ph.max(ratio.arg().to_degrees().abs());
            for j in (0..3).filter(|j| *j != axis) {
                let off = response(m, axis, j)[freqs.iter().position(|x| x == w).unwrap()];
                assert!(off.norm() <= 0.01 * l.norm(), "{name} axis {axis}: L[{axis}][{j}] at {w} = {off:?}");
            }
        }
        eprintln!(
            "{name} axis {axis}: {} frequencies, worst |L| error {:.3} %, phase {worst_ph:.3} deg",
            freqs.len(),
            100.0 * worst_mag
        );
        assert!(worst_mag <= 0.01 && worst_ph <= 1.0, "{name} axis {axis}: {worst_mag} {worst_ph}");
        let want = margins(&|w| r.response(w), freqs[0].min(1e-3), nyq, 20_000);
        let a = &m["axes"][axis];
        let pairs = [
            ("crossover_rad_s", want.crossover_rad_s),
            ("phase_margin_deg", want.phase_margin_deg),
            ("delay_margin_s", want.delay_margin_s),
            ("gain_margin_high_db", want.gain_margin_high_db),
        ];
        for (key, w) in pairs {
            let got = num(&a[key]);
            eprintln!("  {key}: measured {got:?}, closed form {w:?}");
            match (got, w) {
                (Some(g), Some(w)) => assert!(within(g, w, 0.01), "{name} axis {axis} {key}: {g} vs {w}"),
                (g, w) => assert_eq!(g.is_some(), w.is_some(), "{name} axis {axis} {key}: {g:?} vs {w:?}"),
            }
        }
        let alpha = num(&a["disk_margin"]["alpha"]);
        eprintln!(
            "  disk alpha: measured {alpha:?}, closed form {}; |S| peak {:?} dB at {:?} vs {:.4} dB at {:.4}; \
             |T| peak {:?} dB at {:?} vs {:.4} dB at {:.4}; closed-form phase crossovers {:?}",
            want.disk.alpha,
            num(&a["sensitivity_peak_db"]),
            num(&a["sensitivity_peak_rad_s"]),
            want.sensitivity_peak_db,
            want.sensitivity_peak_rad_s,
            num(&a["complementary_peak_db"]),
            num(&a["complementary_peak_rad_s"]),
            want.complementary_peak_db,
            want.complementary_peak_rad_s,
            want.gain_crossings
        );
        assert!(within(alpha.unwrap(), want.disk.alpha, 0.01), "{name} axis {axis} disk alpha");
        out.push(want);
    }
    assert_eq!(m["stable"].as_bool(), Some(true), "{name}");
    out
}

fn measured_ok(name: &str, text: &str) -> Value {
    let (code, json, stderr) = measure(name, text);
    assert_eq!(code, Some(0), "{name}: {stderr}");
    json.unwrap_or_else(|| panic!("{name}: no margins.json ({stderr})"))
}

#[test]
fn nominal_loop_matches_the_closed_form() {
    let m = measured_ok("nominal", &variant("nominal", &[]));
    check_against_reference("nominal", &m, 0.0, 0.0, 1.0);
}

#[test]
fn actuator_lag_matches_the_closed_form() {
    let m = measured_ok("lag", &variant("lag", &[("[actuators.wheels]", "torque_lag_s = 0.2")]));
    check_against_reference("lag 0.2 s", &m, 0.0, 0.2, 1.0);
}

/// Whole (T, 2T) and fractional (T/2, 1.3 T: multiples of the 5 ms dynamics step) delays:
/// the closed form, and the phase margin lowered by ωc Δ.
#[test]
fn plant_delays_match_the_closed_form_and_cost_omega_c_delta() {
    let m0 = measured_ok("nominal", &variant("nominal", &[]));
    for delay in [0.1, 0.2, 0.05, 0.13] {
        let name = format!("delay {delay} s");
        let line = format!("torque_delay_s = {delay}");
        let m = measured_ok("delay", &variant("delay", &[("[actuators.wheels]", &line)]));
        check_against_reference(&name, &m, delay, 0.0, 1.0);
        for axis in 0..3 {
            let (a0, a) = (&m0["axes"][axis], &m["axes"][axis]);
            let wc = num(&a0["crossover_rad_s"]).unwrap();
            let drop = num(&a0["phase_margin_deg"]).unwrap() - num(&a["phase_margin_deg"]).unwrap();
            let want = (wc * delay).to_degrees();
            eprintln!("{name} axis {axis}: PM lowered by {drop:.3} deg, wc delta = {want:.3} deg");
            assert!((drop - want).abs() <= 1.0, "{name} axis {axis}: {drop} vs {want}");
        }
    }
}

/// Inertia × 2 with the gains fixed: `|L|` halves, the crossover moves to the closed form's.
#[test]
fn inertia_scaling_moves_the_crossover_as_the_closed_form_predicts() {
    let text = variant(
        "inertia2",
        &[("inertia_kgm2 = [[10.0", "inertia_kgm2 = [[20.0, 0.0, 0.0], [0.0, 24.0, 0.0], [0.0, 0.0, 30.0]]")],
    );
    let m0 = measured_ok("nominal", &variant("nominal", &[]));
    let m = measured_ok("inertia2", &text);
    let want = check_against_reference("inertia x 2", &m, 0.0, 0.0, 2.0);
    for (axis, w) in want.iter().enumerate() {
        let (c0, c) =
            (num(&m0["axes"][axis]["crossover_rad_s"]).unwrap(), num(&m["axes"][axis]["crossover_rad_s"]).unwrap());
        let predicted = w.crossover_rad_s.unwrap();
        eprintln!("axis {axis}: crossover {c0:.4} -> {c:.4} rad/s, closed form {predicted:.4}");
        assert!(within(c, predicted, 0.01) && c < c0);
    }
}

fn unstable_variant() -> String {
    variant(
        "unstable",
        &[
            ("k_diag_nm", "k_diag_nm = [50.0, 60.0, 75.0]"),
            ("d_diag_nms", "d_diag_nms = [70.0, 84.0, 105.0]"),
            ("torque_limit_nm", "torque_limit_nm = [500.0, 500.0, 500.0]"),
            ("[actuators.wheels]", "torque_delay_s = 0.2"),
        ],
    )
}

/// Gains × 10 with two samples of delay: the closed loop is unstable (reference: spectral
/// radius > 1, negative phase margin); the CLI exits non-zero and does not crash.
#[test]
fn gains_times_ten_with_a_delay_exits_non_zero_without_a_crash() {
    for axis in 0..3 {
        let r = reference(axis, 0.2, 0.0, 1.0, 10.0);
        assert!(r.closed_loop_spectral_radius() > 1.0, "axis {axis}: the reference loop must be unstable");
        let m = margins(&|w| r.response(w), 1e-3, std::f64::consts::PI / T, 20_000);
        assert!(m.phase_margin_deg.is_some_and(|p| p < 0.0), "axis {axis}: {m:?}");
    }
    let (code, _, stderr) = measure("unstable", &unstable_variant());
    eprintln!("gains x 10 with 0.2 s delay: exit {code:?}\n{stderr}");
    assert!(code.is_some() && code != Some(0) && code != Some(101), "exit {code:?}: {stderr}");
    assert!(!stderr.contains("invalid value"), "the scenario itself must be valid: {stderr}");
}

/// The same loop must be reported as unstable, with negative margins (issue 25: "reported with
/// negative margins, not a crash or a fit artefact"): the closed-loop experiment saturates, the
/// measurement falls back to the open loop (docs/margins.md, "Open-loop measurement"), exits 3
/// with margins.json, and its response, crossover and (negative) phase margin are the closed
/// form's on every axis.
#[test]
fn gains_times_ten_with_a_delay_is_reported_unstable_with_negative_margins() {
    let (code, json, stderr) = measure("unstable", &unstable_variant());
    assert_eq!(code, Some(3), "exit {code:?}: {stderr}");
    let m = json.unwrap_or_else(|| panic!("no margins.json: {stderr}"));
    assert_eq!(m["stable"].as_bool(), Some(false));
    assert_eq!(m["method"].as_str(), Some("open"), "auto falls back to the open loop");
    assert!(m["method_note"].is_string(), "the fallback is said: {}", m["method_note"]);
    let negative = (0..3).any(|a| {
        let ax = &m["axes"][a];
        num(&ax["phase_margin_deg"]).is_some_and(|p| p < 0.0)
            || num(&ax["gain_margin_high_db"]).is_some_and(|g| g < 0.0)
    });
    assert!(negative, "no negative margin reported: {}", m["axes"]);
    let freqs = frequencies(&m);
    for axis in 0..3 {
        let r = reference(axis, 0.2, 0.0, 1.0, 10.0);
        let (mag, ph) = worst_response_error(&m, axis, &r);
        eprintln!("unstable axis {axis}: {} frequencies, worst |L| error {mag:.2e}, phase {ph:.2e} deg", freqs.len());
        assert!(mag <= 0.01 && ph <= 1.0, "unstable axis {axis}: {mag} {ph}");
        let want = margins(&|w| r.response(w), freqs[0].min(1e-3), std::f64::consts::PI / T, 20_000);
        let a = &m["axes"][axis];
        let (wc, pm) = (num(&a["crossover_rad_s"]).unwrap(), num(&a["phase_margin_deg"]).unwrap());
        let (wc_ref, pm_ref) = (want.crossover_rad_s.unwrap(), want.phase_margin_deg.unwrap());
        eprintln!(
            "  crossover {wc:.4} rad/s (closed form {wc_ref:.4}), phase margin {pm:.3} deg (closed form {pm_ref:.3})"
        );
        assert!(pm_ref < 0.0 && pm < 0.0, "axis {axis}: {pm} vs {pm_ref}");
        assert!(within(wc, wc_ref, 0.01), "axis {axis} crossover: {wc} vs {wc_ref}");
        assert!((pm - pm_ref).abs() <= 1.0, "axis {axis} phase margin: {pm} vs {pm_ref}");
    }
}

/// The open-loop method on the nominal loop: the closed form (response, margins: as the
/// closed-loop measurement is checked) and the closed-loop measurement itself (`|L|` within
/// 1 %, phase 1° at every frequency both measured; crossover, phase, delay and gain margins
/// within 1 %).
#[test]
fn the_open_loop_method_measures_the_nominal_loop_as_the_closed_loop_one() {
    let closed = measured_ok("nominal", &variant("nominal", &[]));
    let (code, json, stderr) = measure_with("nominal-open", &variant("nominal", &[]), &["--method", "open"]);
    assert_eq!(code, Some(0), "{stderr}");
    let open = json.unwrap_or_else(|| panic!("no margins.json: {stderr}"));
    assert_eq!((closed["method"].as_str(), open["method"].as_str()), (Some("closed"), Some("open")));
    assert!(closed["method_note"].is_null() && open["method_note"].is_null());
    check_against_reference("nominal, open loop", &open, 0.0, 0.0, 1.0);
    let (fc, fo) = (frequencies(&closed), frequencies(&open));
    let common: Vec<(usize, usize)> =
        fo.iter().enumerate().filter_map(|(k, w)| fc.iter().position(|x| x == w).map(|j| (j, k))).collect();
    assert!(common.len() >= fo.len() / 2, "{} of {} frequencies in common", common.len(), fo.len());
    for axis in 0..3 {
        let (lc, lo) = (response(&closed, axis, axis), response(&open, axis, axis));
        let (mut mag, mut ph) = (0.0f64, 0.0f64);
        for (j, k) in &common {
            let ratio = lo[*k] / lc[*j];
            mag = mag.max((ratio.norm() - 1.0).abs());
            ph = ph.max(ratio.arg().to_degrees().abs());
        }
        eprintln!(
            "axis {axis}: open vs closed over {} frequencies: worst |L| error {mag:.2e}, phase {ph:.2e} deg",
            common.len()
        );
        assert!(mag <= 0.01 && ph <= 1.0, "axis {axis}: {mag} {ph}");
        for key in ["crossover_rad_s", "phase_margin_deg", "delay_margin_s", "gain_margin_high_db"] {
            let (c, o) = (num(&closed["axes"][axis][key]).unwrap(), num(&open["axes"][axis][key]).unwrap());
            eprintln!("  {key}: closed {c:.5}, open {o:.5}");
            assert!(within(o, c, 0.01), "axis {axis} {key}: open {o} vs closed {c}");
        }
    }
    eprintln!(
        "wall time: closed {:.2} s, open {:.2} s",
        num(&closed["cost"]["wall_time_s"]).unwrap(),
        num(&open["cost"]["wall_time_s"]).unwrap()
    );
}

fn frequencies(m: &Value) -> Vec<f64> {
    m["frequencies_rad_s"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect()
}

/// Worst relative `|L_ii|` error and phase error (degrees) of a measurement against `r` over
/// its frequencies; the off-diagonal terms of that row below 1 % of the diagonal.
fn worst_response_error(m: &Value, axis: usize, r: &AxisLoop) -> (f64, f64) {
    let (mut mag, mut ph) = (0.0f64, 0.0f64);
    let meas = response(m, axis, axis);
    for (k, (w, l)) in frequencies(m).iter().zip(&meas).enumerate() {
        let ratio = *l / r.response(*w);
        mag = mag.max((ratio.norm() - 1.0).abs());
        ph = ph.max(ratio.arg().to_degrees().abs());
        for j in (0..3).filter(|j| *j != axis) {
            let off = response(m, axis, j)[k];
            assert!(off.norm() <= 0.01 * l.norm(), "axis {axis}: L[{axis}][{j}] at {w} = {off:?}");
        }
    }
    (mag, ph)
}

/// The sampled PD loop without delay has `L(-1) = -D T/(2 J_p)` (θ/e vanishes at z = -1):
/// real and negative at the Nyquist frequency, a phase crossover with the gain margin
/// `-20 log₁₀(D T/(2 J_p))` (the reference's closed-loop matrix gets a pole at z = -1 at
/// exactly that gain). The measurement must report it as the high gain margin.
#[test]
fn gain_margin_at_the_nyquist_frequency() {
    let m = measured_ok("nominal", &variant("nominal", &[]));
    for axis in 0..3 {
        let r = reference(axis, 0.0, 0.0, 1.0, 1.0);
        let gm = -20.0 * (r.d_nms * T / (2.0 * r.plant_inertia_kgm2)).log10();
        let k = 10f64.powf(gm / 20.0);
        let at = |f: f64| AxisLoop { k_nm: f * r.k_nm, d_nms: f * r.d_nms, ..r }.closed_loop_spectral_radius();
        assert!(at(0.999 * k) < 1.0 && at(1.001 * k) > 1.0);
        let got = num(&m["axes"][axis]["gain_margin_high_db"]);
        eprintln!("axis {axis}: gain margin at Nyquist {gm:.4} dB, measured {got:?}");
        assert!(got.is_some_and(|g| within(g, gm, 0.01)), "axis {axis}: {got:?} vs {gm}");
    }
}
