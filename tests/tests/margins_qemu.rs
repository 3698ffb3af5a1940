//! SIL = PIL for the margin measurement: `sim-host margins` against the firmware under QEMU
//! (every experiment and its twin re-flown from t = 0, the firmware's flight state cannot
//! be copied) must measure the same response, bit for bit, as in-process (experiments
//! forked from one flight to the operating point), for a wheel loop and a magnetorquer loop.
//! A small grid keeps it short. And the
//! `FreezeAdaptation` message `sim-host margins` sends to an adaptive law (DMCS) works over
//! QEMU as in-process: the same Δk_p, bit for bit, constant once frozen. Where
//! qemu-system-arm is not installed: fails under CI, skips loudly otherwise.

use acs_flight::link::law_slots;
use acs_tests::{build_qemu_firmware, qemu_available, repo};
use sim_core::link::{LinkKind, LinkOptions};
use sim_core::recorder::series::Discard;
use sim_core::scenario::{Resolved, Scenario};
use sim_core::simulation::probe::Probe;
use sim_host::margins::{MarginOptions, measure};

/// `sim-host margins` of `rel` at t = 1 s on a small unrefined grid (11 frequencies 1.47×
/// apart from hint / 30 = 0.67 rad/s, below both loops' crossover, to Nyquist), in-process
/// and over QEMU: the same response and phase margin, bit for bit.
fn sil_equals_pil(rel: &str) {
    let sc = Scenario::load(&repo().join(rel)).unwrap();
    let opts = MarginOptions {
        at_s: Some(1.0),
        grid_points: 11,
        crossover_hint_rad_s: Some(20.0),
        refine: false,
        ..MarginOptions::default()
    };
    let sil = measure(&sc, &opts).unwrap();
    let pil = measure(&sc, &MarginOptions { link: LinkKind::Qemu, ..opts }).unwrap();
    assert_eq!(sil.frequencies_rad_s, pil.frequencies_rad_s);
    let bits = |r: &sim_host::margins::MarginReport| -> Vec<u64> {
        r.response.iter().flatten().flatten().flatten().map(|x| x.to_bits()).collect()
    };
    assert_eq!(bits(&sil), bits(&pil), "{rel}: the response measured over QEMU differs from the in-process one");
    assert_eq!(pil.link, "qemu");
    let (a, b) = (&sil.axes[0], &pil.axes[0]);
    eprintln!(
        "{rel}: margins SIL = PIL: {} frequencies, axis {} PM {:?} deg at {:?} rad/s, {} experiments under QEMU in \
         {:.1} s",
        pil.frequencies_rad_s.len(),
        b.axis,
        b.phase_margin_deg,
        b.crossover_rad_s,
        pil.cost.experiments,
        pil.cost.wall_time_s
    );
    assert_eq!(a.phase_margin_deg.map(f64::to_bits), b.phase_margin_deg.map(f64::to_bits));
}

#[test]
fn margins_over_qemu_equal_the_in_process_ones_bit_for_bit() {
    if !qemu_available("margins SIL = PIL") {
        return;
    }
    build_qemu_firmware();
    // The reference loop (tests/scenarios/margins/rigid-pd.toml): 10 Hz, ideal wheels, at
    // rest on its target from t = 0: the flight to the operating point (1 s) and the
    // experiments stay short under QEMU (~50 lockstep steps/s here).
    sil_equals_pil("tests/scenarios/margins/rigid-pd.toml");
}

/// The magnetorquer loop (field frozen at the operating point, 2×2 perpendicular to it):
/// the freeze and the dipole injection are on the plant side, the cross-product law on the
/// firmware: the same bits.
#[test]
fn magnetorquer_margins_over_qemu_equal_the_in_process_ones_bit_for_bit() {
    if !qemu_available("magnetorquer margins SIL = PIL") {
        return;
    }
    build_qemu_firmware();
    sil_equals_pil("tests/scenarios/margins/rigid-mtq.toml");
}

/// Δk_p and Δk_u reported at every step of a DMCS run frozen at step `freeze_at`.
fn frozen_dmcs_run(link: &LinkKind, sc: &Scenario, freeze_at: u64) -> Vec<([[f32; 2]; 3], [f32; 3])> {
    let mut l = sim_core::link::open(link, &LinkOptions::default()).unwrap();
    let mut sim = Probe::new(Resolved::try_from(sc).unwrap(), l.as_mut()).unwrap();
    let mut gains = Vec::new();
    while !sim.finished() {
        if sim.steps_done() == freeze_at {
            assert!(sim.freeze_adaptation(true).unwrap(), "DMCS adapts: the freeze is acknowledged");
        }
        sim.step(&mut Discard).unwrap();
        let (cmd, _) = sim.last_step().unwrap();
        gains.push((
            law_slots::dmcs_proportional_gain(&cmd.law_telemetry),
            law_slots::dmcs_feedforward_gain(&cmd.law_telemetry),
        ));
    }
    gains
}

#[test]
fn adaptation_frozen_over_qemu_as_in_process() {
    if !qemu_available("FreezeAdaptation over QEMU") {
        return;
    }
    build_qemu_firmware();
    // DMCS on paper 001's manoeuvre 1 (ideal wheels), 30 s: adapting for 20 s (the
    // manoeuvre's error drives the gains), then frozen.
    let mut sc = Scenario::load(&repo().join("tests/scenarios/margins/dmcs-m1-ideal-wheels.toml")).unwrap();
    sc.duration_s = 30.0;
    let freeze_at = 200;
    let sil = frozen_dmcs_run(&LinkKind::InProcess, &sc, freeze_at);
    let pil = frozen_dmcs_run(&LinkKind::Qemu, &sc, freeze_at);
    let bits = |g: &[([[f32; 2]; 3], [f32; 3])]| -> Vec<u32> {
        g.iter().flat_map(|(p, u)| p.iter().flatten().chain(u).map(|x| x.to_bits()).collect::<Vec<_>>()).collect()
    };
    assert_eq!(bits(&sil), bits(&pil), "the gains over QEMU differ from the in-process ones");
    let k = freeze_at as usize;
    assert_ne!(pil[k / 2], pil[k - 1], "adapting before the freeze");
    assert!(pil[k - 1].0.iter().flatten().any(|x| *x != 0.0), "Δk_p built before the freeze: {:?}", pil[k - 1]);
    for (i, g) in pil.iter().enumerate().skip(k) {
        assert_eq!(*g, pil[k - 1], "step {i}: the frozen gains changed");
    }
    eprintln!("FreezeAdaptation over QEMU: {} steps, Δk_p frozen at {:?}", pil.len(), pil[k - 1].0);
}
