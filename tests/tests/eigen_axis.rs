//! Eigen-axis slew under a rate limit (Wie & Lu 1995) through the whole loop: paper 002's
//! manoeuvre with a 3 deg/s limit never turns faster, and still arrives.

use acs_tests::{run_in_process, scenario};
use sim_core::recorder::columns::Col;
use sim_core::scenario::Controller;

#[test]
fn rate_limited_quaternion_feedback_respects_the_slew_rate_and_arrives() {
    let mut sc = scenario("paper002/gsr-manoeuvre.toml");
    let Some(Controller::QuaternionFeedback { max_slew_rate_deg_s, .. }) = &mut sc.controller else { panic!() };
    *max_slew_rate_deg_s = Some(3.0);
    sc.duration_s = 60.0;
    let r = run_in_process(&sc);
    let ts = &r.series;
    let peak = (0..ts.len())
        .map(|i| Col::RATE.map(|c| ts.fixed(c).unwrap()[i]))
        .map(|w| (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt().to_degrees())
        .fold(0.0f64, f64::max);
    eprintln!("rate-limited slew: peak body rate {peak:.2} deg/s (limit 3), settle {:?} s", r.summary.settle_time_s);
    assert!(peak < 3.0 * 1.05 && peak > 3.0 * 0.8, "{peak}");
    assert!(r.summary.final_error_deg < 0.1);
}
