//! SIL = PIL for the margin measurement: `sim-host margins` against the firmware under QEMU
//! (every experiment and its twin re-flown from t = 0, the firmware's flight state cannot
//! be copied) must measure the same response, bit for bit, as in-process (experiments
//! forked from one flight to the operating point). A small grid keeps it short. Where
//! qemu-system-arm is not installed: fails under CI, skips loudly otherwise.

use acs_tests::{build_qemu_firmware, qemu_available, repo};
use sim_core::link::LinkKind;
use sim_core::scenario::Scenario;
use sim_host::margins::{MarginOptions, measure};

#[test]
fn margins_over_qemu_equal_the_in_process_ones_bit_for_bit() {
    if !qemu_available("margins SIL = PIL") {
        return;
    }
    build_qemu_firmware();
    // The reference loop (tests/scenarios/margins/rigid-pd.toml): 10 Hz, ideal wheels, at
    // rest on its target from t = 0: the flight to the operating point (1 s) and the
    // experiments stay short under QEMU (~50 lockstep steps/s here).
    let sc = Scenario::load(&repo().join("tests/scenarios/margins/rigid-pd.toml")).unwrap();
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
