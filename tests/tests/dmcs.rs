//! Paper 001's adaptive DMCS on the reaction-wheel spacecraft (accurate wheel model) with
//! the +20 % inertia change at 100 s: both manoeuvres converge and the adaptive gains
//! settle.

use acs_tests::{run_in_process, scenario};
use sim_core::recorder::columns::Col;

#[test]
fn dmcs_manoeuvres_converge_through_the_inertia_change_and_the_gains_settle() {
    for f in ["paper001/dmcs-m1.toml", "paper001/dmcs-m2.toml"] {
        let r = run_in_process(&scenario(f));
        let s = &r.summary;
        let ts = &r.series;
        let t = ts.fixed(Col::T).unwrap();
        // Gains over the last 200 s: settled (spread small against their size).
        let spread = ["x", "y", "z"]
            .iter()
            .map(|a| {
                let g: Vec<f64> = ts
                    .col(&format!("adaptive_gain_{a}"))
                    .unwrap()
                    .iter()
                    .zip(t)
                    .filter(|(_, t)| **t >= 700.0)
                    .map(|(g, _)| *g)
                    .collect();
                let (lo, hi) = g.iter().fold((f64::MAX, f64::MIN), |(l, h), x| (l.min(*x), h.max(*x)));
                (hi - lo) / hi.abs().max(1e-9)
            })
            .fold(0.0f64, f64::max);
        eprintln!(
            "{}: settle {:?} s, final {:.3} deg, wheel peak {:.0} rpm / {:.0} W, adaptive-gain spread in the last 200 s {:.1} %",
            s.scenario,
            s.settle_time_s,
            s.final_error_deg,
            s.max_wheel_speed_rpm.unwrap(),
            s.max_wheel_power_w.unwrap(),
            100.0 * spread
        );
        assert!(s.final_error_deg < 1.0 && s.settle_time_s.unwrap() < 600.0);
        assert!(spread < 0.1, "gains settle: {spread}");
        assert!(s.max_wheel_power_w.unwrap() <= 470.0);
    }
}
