//! SIL = PIL for the margin measurement: `sim-host margins` against the firmware under QEMU
//! (every experiment and its twin re-flown from t = 0, the firmware's flight state cannot
//! be copied) must measure the same response, bit for bit, as in-process (experiments
//! forked from one flight to the operating point). A small grid keeps it short. Where
//! qemu-system-arm is not installed: fails under CI, skips loudly otherwise.

use acs_tests::{build_qemu_firmware, qemu_available};
use sim_core::link::LinkKind;
use sim_core::scenario::Scenario;
use sim_host::margins::{MarginOptions, measure};

const HOLD: &str = r#"
name = "qemu-margins-hold"
duration_s = 20.0
[timing]
control_rate_hz = 10.0
dynamics_substeps = 2
[spacecraft]
inertia_kgm2 = [[10.0, 0.0, 0.0], [0.0, 14.0, 0.0], [0.0, 0.0, 8.0]]
[initial]
euler_deg = [0.0, 0.0, 0.0]
rate_rad_s = [0.0, 0.0, 0.0]
[target]
euler_deg = [0.0, 0.0, 0.0]
[actuators.wheels]
layout = "axes"
axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
model = "ideal"
max_torque_nm = 0.5
max_speed_rpm = 6000.0
inertia_kgm2 = 0.01
initial_speed_rpm = [0.0, 0.0, 0.0]
[controller]
type = "quaternion_feedback"
zeta = 0.7
wn_rad_s = 0.5
torque_limit_nm = [0.5, 0.5, 0.5]
[sensors]
seed = 1
"#;

#[test]
fn margins_over_qemu_equal_the_in_process_ones_bit_for_bit() {
    if !qemu_available("margins SIL = PIL") {
        return;
    }
    build_qemu_firmware();
    // 10 Hz, ideal wheels, at rest on its target from t = 0: the flight to the operating
    // point (1 s) and the experiments stay short under QEMU (~50 lockstep steps/s here).
    let sc = Scenario::from_toml(HOLD).unwrap();
    let opts = MarginOptions {
        at_s: Some(1.0),
        grid_points: 3,
        crossover_hint_rad_s: Some(10.0),
        refine: false,
        ..MarginOptions::default()
    };
    let sil = measure(&sc, &opts).unwrap();
    let pil = measure(&sc, &MarginOptions { link: LinkKind::Qemu, ..opts }).unwrap();
    assert_eq!(sil.frequencies_rad_s, pil.frequencies_rad_s);
    let bits = |r: &sim_host::margins::MarginReport| -> Vec<u64> {
        r.response.iter().flatten().flatten().flatten().map(|x| x.to_bits()).collect()
    };
    assert_eq!(bits(&sil), bits(&pil), "the response measured over QEMU differs from the in-process one");
    assert_eq!(pil.link, "qemu");
    let (a, b) = (&sil.axes[0], &pil.axes[0]);
    eprintln!(
        "margins SIL = PIL: {} frequencies, x axis PM {:?} deg at {:?} rad/s, {} experiments under QEMU in {:.1} s",
        pil.frequencies_rad_s.len(),
        b.phase_margin_deg,
        b.crossover_rad_s,
        pil.cost.experiments,
        pil.cost.wall_time_s
    );
    assert_eq!(a.phase_margin_deg.map(f64::to_bits), b.phase_margin_deg.map(f64::to_bits));
}
