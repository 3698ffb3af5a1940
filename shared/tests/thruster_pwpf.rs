//! PWPF modulator (paper fig 5, table 3) vs its closed forms.
//!
//! dt = 1e-5 s. Switching is quantised to the sample grid: a switch is seen up to
//! one step late, so the filter overshoots the threshold by at most one step of its
//! slope, which the next phase has to undo at *its* slope. Hence, per phase,
//!   |ΔT_on|  <= dt (1 + s_off(Uon) / s_on(Uon)),
//!   |ΔT_off| <= dt (1 + s_on(Uoff) / s_off(Uoff)),
//! with slopes s_on(f) = |Km (E - Um) - f| / Tm, s_off(f) = (Km E - f) / Tm; duty
//! cycle and frequency tolerances follow to first order (×1.1 margin).
#![allow(clippy::needless_range_loop, clippy::collapsible_if)]
use acs_flight::allocation::thruster::Pwpf;
use acs_flight::allocation::thruster::paper::PAPER_PWPF;

const DT: f32 = 1e-5;

/// Simulate a constant input; return (mean on time, mean off time) over `periods`
/// full periods after the first pulse, and the first pulse width.
fn measure(e: f32, periods: usize, max_steps: usize) -> Option<(f64, f64, f64)> {
    let mut m = Pwpf::<1>::new(PAPER_PWPF, DT).unwrap();
    let mut prev = false;
    let mut edges: Vec<(usize, bool)> = Vec::new();
    for k in 0..max_steps {
        let on = m.step(&[e]) & 1 != 0;
        if on != prev {
            edges.push((k, on));
            prev = on;
        }
        if edges.len() > 2 * periods + 3 {
            break;
        }
    }
    if edges.len() < 2 * periods + 3 {
        return None;
    }
    let first_width = (edges[1].0 - edges[0].0) as f64 * DT as f64;
    // whole periods from the 2nd rising edge
    let mut on = 0usize;
    let mut off = 0usize;
    for p in 0..periods {
        let (r0, f0, r1) = (edges[2 + 2 * p].0, edges[3 + 2 * p].0, edges[4 + 2 * p].0);
        assert!(edges[2 + 2 * p].1 && !edges[3 + 2 * p].1);
        on += f0 - r0;
        off += r1 - f0;
    }
    let n = periods as f64;
    Some((on as f64 * DT as f64 / n, off as f64 * DT as f64 / n, first_width))
}

#[test]
fn static_duty_cycle_and_frequency() {
    let p = PAPER_PWPF;
    let dt = DT as f64;
    println!(
        "PWPF (Km {}, Tm {}, Uon {}, Uoff {}): dead zone {:.4}, saturation {:.4}, min pulse {:.3} ms",
        p.km,
        p.tm,
        p.u_on,
        p.u_off,
        p.dead_zone(),
        p.saturation(),
        p.min_pulse_width() * 1e3
    );
    let mut worst = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for e in [0.12f32, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0] {
        let (ton, toff, _) = measure(e, 10, 5_000_000).expect("pulses");
        let (ton_c, toff_c) = (p.on_time(e) as f64, p.off_time(e) as f64);
        let dc = ton / (ton + toff);
        let f = 1.0 / (ton + toff);
        let (dc_c, f_c) = (p.duty_cycle(e) as f64, p.frequency(e) as f64);
        println!(
            "E {e:.2}: T_on {:.5} s (closed {:.5}), T_off {:.5} s (closed {:.5}), duty {dc:.5} (closed {dc_c:.5}), f {f:.3} Hz (closed {f_c:.3})",
            ton, ton_c, toff, toff_c
        );
        let (km, ee, um) = (p.km as f64, e as f64, p.u_m as f64);
        let s_on = |f: f64| (km * (ee - um) - f).abs();
        let s_off = |f: f64| km * ee - f;
        let tol_on = dt * (1.0 + s_off(p.u_on as f64) / s_on(p.u_on as f64));
        let tol_off = dt * (1.0 + s_on(p.u_off as f64) / s_off(p.u_off as f64));
        assert!((ton - ton_c).abs() <= tol_on, "T_on: {ton} vs {ton_c} (tol {tol_on})");
        assert!((toff - toff_c).abs() <= tol_off, "T_off: {toff} vs {toff_c} (tol {tol_off})");
        let period = ton_c + toff_c;
        let tol_dc = 1.1 * (toff_c * tol_on + ton_c * tol_off) / (period * period);
        let tol_f = 1.1 * (tol_on + tol_off) / period;
        assert!((dc - dc_c).abs() <= tol_dc, "duty");
        assert!((f - f_c).abs() / f_c <= tol_f, "frequency");
        worst.0 = worst.0.max((ton - ton_c).abs());
        worst.3 = worst.3.max((toff - toff_c).abs());
        worst.1 = worst.1.max((dc - dc_c).abs());
        worst.2 = worst.2.max((f - f_c).abs() / f_c);
    }
    println!(
        "worst |ΔT_on| {:.2e} s, |ΔT_off| {:.2e} s, |Δduty| {:.2e}, rel Δf {:.2e} (dt {dt:e})",
        worst.0, worst.3, worst.1, worst.2
    );
}

#[test]
fn minimum_pulse_width() {
    let p = PAPER_PWPF;
    let e = p.dead_zone() * 1.0001;
    let (ton, _, first) = measure(e, 2, 20_000_000).expect("pulses just above the dead zone");
    let closed = -(p.tm as f64) * (1.0 - (p.hysteresis() as f64) / (p.km as f64 * p.u_m as f64)).ln();
    let at_e = p.on_time(e) as f64;
    println!(
        "min pulse width: closed form -Tm ln(1 - h/(Km Um)) = {:.4} ms; measured {:.4} ms (first pulse {:.4} ms), T_on(E_d·1.0001) = {:.4} ms",
        closed * 1e3,
        ton * 1e3,
        first * 1e3,
        at_e * 1e3
    );
    // near the dead zone s_off(Uon) ≈ 0: the tolerance is ~1 dt
    assert!((ton - closed).abs() <= 1.5 * DT as f64 + (at_e - closed).abs());
    assert!((first - closed).abs() <= 1.5 * DT as f64 + (at_e - closed).abs());
}

#[test]
fn dead_zone_and_saturation() {
    let p = PAPER_PWPF;
    for e in [0.0f32, 0.05, p.dead_zone() * 0.999, -1.0] {
        let mut m = Pwpf::<1>::new(p, DT).unwrap();
        let fired = (0..1_000_000).any(|_| m.step(&[e]) != 0);
        assert!(!fired, "fired at E = {e}");
    }
    // above saturation: continuously on after the first switch-on
    let mut m = Pwpf::<1>::new(p, DT).unwrap();
    let mut seen_on = false;
    for _ in 0..500_000 {
        let on = m.step(&[1.1]) != 0;
        if seen_on {
            assert!(on);
        }
        seen_on |= on;
    }
    assert!(seen_on);
    println!(
        "no output below the dead zone E_d = Uon/Km = {:.4} (10 s at 0.999 E_d); continuously on above E_s = {:.4}",
        p.dead_zone(),
        p.saturation()
    );
}

#[test]
fn exact_discretisation_independent_of_dt() {
    // A filter-only check: with the trigger held off, f(t) = Km E (1 - e^{-t/Tm}).
    let mut p = PAPER_PWPF;
    p.u_on = 1e6; // never fires
    p.u_off = 1e5;
    for dt in [1e-4f32, 1e-3, 0.01, 0.05] {
        let mut m = Pwpf::<1>::new(p, dt).unwrap();
        let steps = (0.3 / dt).round() as usize;
        for _ in 0..steps {
            m.step(&[0.5]);
        }
        let t = steps as f64 * dt as f64;
        let want = 4.5 * 0.5 * (1.0 - (-t / 0.15).exp());
        assert!((m.filter()[0] as f64 - want).abs() < 1e-5, "dt {dt}: {} vs {want}", m.filter()[0]);
    }
}

#[test]
fn garbage_inputs() {
    let mut m = Pwpf::<4>::new(PAPER_PWPF, 0.01).unwrap();
    for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX, -f32::MAX, 1e30] {
        for _ in 0..100 {
            m.step(&[x, -x, x, 0.5]);
            assert!(m.filter().iter().all(|v| v.is_finite()));
        }
    }
    assert!(Pwpf::<1>::new(PAPER_PWPF, 0.0).is_none());
    assert!(Pwpf::<1>::new(PAPER_PWPF, f32::NAN).is_none());
    let mut bad = PAPER_PWPF;
    bad.u_off = 0.5;
    assert!(Pwpf::<1>::new(bad, 0.01).is_none());
}
