//! Each test compares the model with an independent closed form, with a stated tolerance.
//! Integration: a local RK4 over the wheel state (body fixed unless stated).
use sim_core::plant::delay::DelayLine;
use sim_core::plant::wheel::*;
use std::f64::consts::PI;

const Z: [f64; 3] = [0.0; 3];

fn rk4(p: &WheelParams, s: &WheelState, cmd: f64, dt: f64) -> WheelState {
    let f = |x: &WheelState| evaluate(p, x, cmd, &Z, &Z).0;
    let k1 = f(s);
    let k2 = f(&s.add_scaled(&k1, dt / 2.0));
    let k3 = f(&s.add_scaled(&k2, dt / 2.0));
    let k4 = f(&s.add_scaled(&k3, dt));
    s.add_scaled(&k1, dt / 6.0).add_scaled(&k2, dt / 3.0).add_scaled(&k3, dt / 3.0).add_scaled(&k4, dt / 6.0)
}

/// Paper wheel without Coulomb, bearing and ripple terms.
fn quiet() -> WheelParams {
    WheelParams { coulomb_nm: 0.0, bearing_nm: 0.0, ripple_nm: 0.0, ..WheelParams::paper001() }
}

/// Amplitude of the component of `x` at angular frequency `w` (samples every `dt`, integer periods).
fn dft_amp(x: &[f64], w: f64, dt: f64) -> f64 {
    let (mut re, mut im) = (0.0, 0.0);
    for (n, v) in x.iter().enumerate() {
        let (s, c) = (w * n as f64 * dt).sin_cos();
        re += v * c;
        im -= v * s;
    }
    2.0 * (re * re + im * im).sqrt() / x.len() as f64
}

#[test]
fn paper_params_valid_and_step() {
    let p = WheelParams::paper001();
    p.validate().unwrap();
    WheelParams::ideal(0.2, 200.0, 0.05).validate().unwrap();
    let kf = p.torque_constant_nm_per_a;
    assert!((kf * p.max_current_a - p.max_torque_nm).abs() < 1e-12);
    assert!((p.speed_loop_gain * kf / p.inertia_kgm2 - 2.5).abs() < 1e-12); // eq 11 bound
    println!(
        "fastest rate {:.1}/s, tau {:.3} ms, max stable step {:.2} ms, harmonic step {:.3} ms",
        p.fastest_rate_per_s(),
        1e3 * p.fastest_time_constant_s(),
        1e3 * p.max_stable_step_s(),
        1e3 * p.harmonic_step_s()
    );
    for (f, bad) in [
        ("spin_axis", WheelParams { spin_axis: [1.0, 1.0, 0.0], ..p.clone() }),
        ("inertia_kgm2", WheelParams { inertia_kgm2: 0.0, ..p.clone() }),
        ("resistance_ohm", WheelParams { resistance_ohm: -1.0, ..p.clone() }),
        ("max_power_w", WheelParams { quiescent_power_w: 500.0, ..p.clone() }),
        ("coulomb_nm", WheelParams { coulomb_nm: f64::NAN, ..p.clone() }),
    ] {
        let e = bad.validate().unwrap_err();
        assert!(e.contains(f), "{e}");
    }
}

/// Eq 15 alone (loop open, no current): ω(t) = ω0 exp(-λ t / I_w). Tol 1e-9 relative.
#[test]
fn viscous_spin_down() {
    let p = WheelParams { speed_loop_gain: 0.0, ..quiet() };
    let w0 = 300.0;
    let mut s = WheelState::spinning(&p, w0, &Z);
    let dt = 0.05;
    let mut worst: f64 = 0.0;
    for n in 1..=12000 {
        s = rk4(&p, &s, 0.0, dt);
        let t = n as f64 * dt;
        let truth = w0 * (-p.viscous_nms * t / p.inertia_kgm2).exp();
        let w = evaluate(&p, &s, 0.0, &Z, &Z).1.speed_rad_s;
        worst = worst.max(((w - truth) / truth).abs());
    }
    println!("viscous spin-down over 600 s: worst rel err {worst:.2e}");
    assert!(worst < 1e-9);
}

/// Same spin-down with a free body (1 axis, inertia J without the rotor): checks the
/// absolute-momentum coupling. ω_rel(t) = ω_rel0 exp(-λ t (1/I_w + 1/J)). Tol 1e-9 relative.
#[test]
fn viscous_spin_down_free_body() {
    let p = WheelParams { speed_loop_gain: 0.0, spin_axis: [0.6, 0.0, 0.8], ..quiet() };
    let j = 2.0; // body inertia about the spin axis (J of eq 3), small to make coupling visible
    let a = p.spin_axis;
    let (w0, wb0) = (200.0, 0.3);
    let mut s = WheelState::spinning(&p, w0, &a.map(|x| x * wb0));
    let mut wb = wb0;
    let dt = 0.02;
    let f = |s: &WheelState, wb: f64| {
        let d = evaluate(&p, s, 0.0, &a.map(|x| x * wb), &Z).0;
        (d, -d.dh_abs_nm / j) // J ω̇ = -ḣ_a (eq 5 / simulator convention)
    };
    let rate = p.viscous_nms * (1.0 / p.inertia_kgm2 + 1.0 / j);
    let mut worst: f64 = 0.0;
    for n in 1..=5000 {
        let (k1, b1) = f(&s, wb);
        let (k2, b2) = f(&s.add_scaled(&k1, dt / 2.0), wb + dt / 2.0 * b1);
        let (k3, b3) = f(&s.add_scaled(&k2, dt / 2.0), wb + dt / 2.0 * b2);
        let (k4, b4) = f(&s.add_scaled(&k3, dt), wb + dt * b3);
        s = s.add_scaled(&k1, dt / 6.0).add_scaled(&k2, dt / 3.0).add_scaled(&k3, dt / 3.0).add_scaled(&k4, dt / 6.0);
        wb += dt / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4);
        let w = evaluate(&p, &s, 0.0, &a.map(|x| x * wb), &Z).1.speed_rad_s;
        let truth = w0 * (-rate * n as f64 * dt).exp();
        worst = worst.max(((w - truth) / truth).abs());
    }
    // total axial momentum J ω_b + h_a is conserved
    let h_tot0 = j * wb0 + p.inertia_kgm2 * (w0 + wb0);
    assert!((j * wb + s.h_abs_nms - h_tot0).abs() < 1e-10);
    println!("free-body spin-down: worst rel err {worst:.2e}");
    assert!(worst < 1e-9);
}

/// ḣ_a does not depend on ω̇; eq 23 output ω̇_w = ḣ_a/I_w - aᵀω̇. Tol 1e-12.
#[test]
fn body_accel_only_enters_eq23_output() {
    let p = WheelParams { spin_axis: [0.0, 0.6, 0.8], ..WheelParams::paper001() };
    let wb = [0.01, -0.02, 0.03];
    let s = WheelState::spinning(&p, 150.0, &wb);
    let acc = [0.1, 0.2, -0.3];
    let (d0, o0) = evaluate(&p, &s, 0.3, &wb, &Z);
    let (d1, o1) = evaluate(&p, &s, 0.3, &wb, &acc);
    assert_eq!(d0, d1);
    assert!((o0.speed_rad_s - 150.0).abs() < 1e-12);
    let expect = -(0.6 * 0.2 + 0.8 * -0.3);
    assert!((o1.speed_accel_rad_s2 - o0.speed_accel_rad_s2 - expect).abs() < 1e-12);
}

/// Eq 10: a step of internal torque T_e reaches the body as u_out = -T_e exp(-p t),
/// p = K_f K_c / I_w, and the speed sags by T_e/(I_w p)(1 - exp(-p t)). Tol 1e-6 relative to T_f0.
#[test]
fn speed_loop_rejects_friction_eq10() {
    let p = WheelParams { viscous_nms: 0.0, coulomb_nm: 0.04, ..quiet() };
    let w0 = 100.0;
    let mut s = WheelState::spinning(&p, w0, &Z); // Dahl converged: T_e = T_f0 constant
    let pole = p.torque_constant_nm_per_a * p.speed_loop_gain / p.inertia_kgm2;
    let dt = 0.005;
    let mut worst: f64 = 0.0;
    for n in 0..=2000 {
        let t = n as f64 * dt;
        let o = evaluate(&p, &s, 0.0, &Z, &Z).1;
        let u_out = -o.delivered_torque_nm;
        let tu = -p.coulomb_nm * (-pole * t).exp();
        let tw = w0 - p.coulomb_nm / (p.inertia_kgm2 * pole) * (1.0 - (-pole * t).exp());
        worst = worst.max((u_out - tu).abs() / p.coulomb_nm).max((o.speed_rad_s - tw).abs() / p.coulomb_nm);
        s = rk4(&p, &s, 0.0, dt);
    }
    println!("eq 10 rejection: worst err {worst:.2e} (pole {pole} rad/s)");
    assert!(worst < 1e-6);
}

/// Over-demanding command: speed settles where the limited motor torque balances friction
/// `T_f0 + λω` (Dahl converged). Closed forms:
/// speed limiter (eq 27): ω* = (K²ω_max/k_b - T_f0)/(K²/k_b + λ);
/// back-EMF/winding (eqs 28-29, limiter off, power limit lifted): ω* = (K V/R - T_f0)/(K²/R + λ);
/// power (eq 30, limiter off, paper p_max): R I² + K ω I = p_max with K I = T_f0 + λω (bisection).
/// Tol 1e-6 relative. With the limiter the speed never exceeds ω_max.
#[test]
fn saturation_speed_closed_form() {
    for case in 0..3 {
        let p = WheelParams { speed_limiter: case == 0, coulomb_nm: 0.04, ..quiet() };
        let p = if case == 1 { WheelParams { max_power_w: 5000.0, ..p } } else { p };
        let (k, l, tf, r) = (p.torque_constant_nm_per_a, p.viscous_nms, p.coulomb_nm, p.resistance_ohm);
        let truth = match case {
            0 => (k * k * p.max_speed_rad_s / p.speed_limiter_gain_ohm - tf) / (k * k / p.speed_limiter_gain_ohm + l),
            1 => (k * p.motor_voltage_max_v / r - tf) / (k * k / r + l),
            _ => {
                let g = |w: f64| {
                    let i = (tf + l * w) / k;
                    r * i * i + k * w * i - p.max_power_w
                };
                let (mut a, mut b) = (0.0, p.motor_voltage_max_v / k);
                for _ in 0..200 {
                    let m = 0.5 * (a + b);
                    if g(m) > 0.0 { b = m } else { a = m }
                }
                a
            }
        };
        let dt = p.max_stable_step_s();
        let mut s = WheelState::default();
        let mut wmax: f64 = 0.0;
        let t_end = [300.0, 1000.0, 4000.0][case]; // case 2 approaches with τ ≈ 130 s
        for _ in 0..(t_end / dt) as usize {
            s = rk4(&p, &s, 5.0, dt);
            wmax = wmax.max(evaluate(&p, &s, 5.0, &Z, &Z).1.speed_rad_s);
        }
        let o = evaluate(&p, &s, 5.0, &Z, &Z).1;
        println!(
            "case {case} (0 limiter, 1 back-EMF, 2 power): speed {:.6} rad/s, closed form {truth:.6} (V/K = {:.3}), I {:.3} A, V {:.3} V, P {:.2} W, max seen {wmax:.6}",
            o.speed_rad_s,
            p.motor_voltage_max_v / k,
            o.current_a,
            o.voltage_v,
            o.power_w
        );
        assert!(((o.speed_rad_s - truth) / truth).abs() < 1e-6);
        if case == 0 {
            assert!(wmax <= p.max_speed_rad_s);
        }
    }
}

/// ±over-max torque commands reversing over 10 minutes (full paper model incl. ripple, bearing,
/// Dahl): current, torque, power and voltage never exceed their limits, and speed stays ≤ ω_max.
/// Also checks that each limit is actually reached (non-vacuous). Tol 1e-9 W / 1e-12 A.
#[test]
fn limits_hold_in_reversing_saturation() {
    for (pq, ai) in [(0.0, 0.0), (15.0, 0.01)] {
        let p = WheelParams { quiescent_power_w: pq, control_loss_coeff: ai, ..WheelParams::paper001() };
        let dt = p.max_stable_step_s();
        let mut s = WheelState::default();
        let (mut pmax, mut imax, mut vmax, mut wmax, mut tmax): (f64, f64, f64, f64, f64) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (cmd, dur) in [(1.5, 100.0), (-1.5, 180.0), (1.5, 40.0), (-1.5, 20.0), (1.5, 170.0), (-1.5, 90.0)] {
            for _ in 0..(dur / dt) as usize {
                let o = evaluate(&p, &s, cmd, &Z, &Z).1;
                pmax = pmax.max(o.power_w);
                imax = imax.max(o.current_a.abs());
                vmax = vmax.max(o.voltage_v.abs());
                wmax = wmax.max(o.speed_rad_s.abs());
                tmax = tmax.max(o.motor_torque_nm.abs());
                s = rk4(&p, &s, cmd, dt);
            }
        }
        println!(
            "p_q {pq} a_i {ai}: max power {pmax:.3} W, |I| {imax:.4} A, |V| {vmax:.3} V, |ω| {wmax:.3} rad/s, |K I| {tmax:.5} N m"
        );
        assert!(pmax <= p.max_power_w + 1e-9 && pmax > 0.99 * p.max_power_w);
        assert!(imax <= p.max_current_a + 1e-12 && imax > 0.99 * p.max_current_a);
        assert!(tmax <= p.max_torque_nm + 1e-12);
        assert!(vmax <= p.motor_voltage_max_v + 1e-9);
        assert!(wmax <= p.max_speed_rad_s);
    }
}

/// Eqs 16-20 at constant wheel speed (no friction): each body component of the imbalance
/// torque is a sinusoid at ω_w with amplitude D_d ω²|(I-aaᵀ)e_k| (dynamic) or
/// D_s ω²|(I-aaᵀ)(e_k × R_w)| (static, |R_w × f_s| projected), computed without the model's
/// basis. DFT tol 1e-9 relative; no energy at 2ω_w; zero crossings = 2 per revolution.
#[test]
#[allow(clippy::needless_range_loop)]
fn imbalance_frequency_and_amplitude() {
    let (al, be) = (PI / 4.0, 54.73_f64.to_radians());
    let a = [al.cos() * be.sin(), al.sin() * be.sin(), be.cos()]; // column 1 of eq 9
    let r = [0.4, -0.3, 0.25];
    let w = 300.0;
    let proj = |v: [f64; 3]| {
        let d = v[0] * a[0] + v[1] * a[1] + v[2] * a[2];
        ((v[0] - d * a[0]).powi(2) + (v[1] - d * a[1]).powi(2) + (v[2] - d * a[2]).powi(2)).sqrt()
    };
    for dynamic in [true, false] {
        let base = WheelParams {
            speed_loop_gain: 0.0,
            viscous_nms: 0.0,
            spin_axis: a,
            position_m: r,
            phase_rad: 0.3,
            ..quiet()
        };
        let p = if dynamic {
            WheelParams { static_imbalance_kgm: 0.0, ..base }
        } else {
            WheelParams { dyn_imbalance_kgm2: 0.0, ..base }
        };
        let dt = 2.0 * PI / w / 64.0;
        let mut s = WheelState::spinning(&p, w, &Z);
        let mut tq = vec![Vec::new(); 3];
        let mut fmag: f64 = 0.0;
        for _ in 0..640 {
            let o = evaluate(&p, &s, 0.0, &Z, &Z).1;
            for k in 0..3 {
                tq[k].push(o.imbalance_torque_nm[k]);
            }
            let f = o.imbalance_force_n;
            fmag = fmag.max((f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt());
            s = rk4(&p, &s, 0.0, dt);
        }
        for k in 0..3 {
            let mut e = [0.0; 3];
            e[k] = 1.0;
            let truth = if dynamic {
                p.dyn_imbalance_kgm2 * w * w * proj(e)
            } else {
                let exr = [e[1] * r[2] - e[2] * r[1], e[2] * r[0] - e[0] * r[2], e[0] * r[1] - e[1] * r[0]];
                p.static_imbalance_kgm * w * w * proj(exr)
            };
            let amp = dft_amp(&tq[k], w, dt);
            let amp2 = dft_amp(&tq[k], 2.0 * w, dt);
            let crossings = tq[k].windows(2).filter(|v| v[0].signum() != v[1].signum()).count();
            println!(
                "{} axis {k}: DFT amp {amp:.6e}, closed form {truth:.6e}, 2ω amp {amp2:.1e}, zero crossings {crossings} (10 revs)",
                if dynamic { "dynamic" } else { "static" }
            );
            assert!(((amp - truth) / truth).abs() < 1e-9);
            assert!(amp2 < 1e-9 * truth);
            assert!((19..=21).contains(&crossings));
        }
        if !dynamic {
            assert!((fmag - p.static_imbalance_kgm * w * w).abs() < 1e-12 * fmag);
        }
    }
}

/// Ideal fidelity: delivered torque = -clip(cmd) away from the speed limit (exact), and the
/// speed never exceeds ω_max under a long saturating command in either direction.
#[test]
fn ideal_clip_and_speed_limit() {
    let p = WheelParams::ideal(0.2, 200.0, 0.05);
    for w in [-150.0, 0.0, 150.0] {
        let s = WheelState::spinning(&p, w, &Z);
        for c in [-0.5, -0.2, -0.1, 0.0, 0.05, 0.2, 0.3] {
            let o = evaluate(&p, &s, c, &Z, &Z).1;
            assert_eq!(o.delivered_torque_nm, -f64::clamp(c, -0.2, 0.2));
        }
    }
    let mut s = WheelState::default();
    let dt = 0.01;
    let (mut hi, mut lo): (f64, f64) = (0.0, 0.0);
    for (c, dur) in [(0.5, 100.0), (-0.5, 200.0)] {
        for _ in 0..(dur / dt) as usize {
            s = rk4(&p, &s, c, dt);
            let w = evaluate(&p, &s, c, &Z, &Z).1.speed_rad_s;
            hi = hi.max(w);
            lo = lo.min(w);
        }
    }
    println!("ideal: speed range [{lo:.9}, {hi:.9}] (max 200)");
    assert!(hi <= 200.0 && lo >= -200.0 && hi > 200.0 - 1e-6 && lo < -200.0 + 1e-6);
}

/// Eq 23 at a held speed ω: x = T_f0 - T_f sgn ω obeys ẋ = -β|ω| x² → x = x0/(1 + β|ω| x0 t).
/// Tol 1e-9 N m against that solution; converges to T_f0 sgn ω (within 1 % after 100 s at 10 rad/s).
#[test]
fn dahl_converges_at_constant_speed() {
    let p = WheelParams::paper001();
    for w in [10.0, -10.0] {
        let mut s = WheelState::spinning(&p, w, &Z);
        s.dahl_friction_nm = 0.0;
        let f = |t: f64| evaluate(&p, &WheelState { dahl_friction_nm: t, ..s }, 0.0, &Z, &Z).0.ddahl;
        let dt = 0.01;
        let mut worst: f64 = 0.0;
        for n in 1..=10000 {
            let t = s.dahl_friction_nm;
            let (k1, k2) = (f(t), f(t + dt / 2.0 * f(t)));
            let k3 = f(t + dt / 2.0 * k2);
            let k4 = f(t + dt * k3);
            s.dahl_friction_nm += dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            let x0 = p.coulomb_nm;
            let truth = w.signum() * (p.coulomb_nm - x0 / (1.0 + p.dahl_beta * w.abs() * x0 * n as f64 * dt));
            worst = worst.max((s.dahl_friction_nm - truth).abs());
        }
        println!("Dahl at {w} rad/s: T_f(100 s) = {:.6}, worst err {worst:.1e}", s.dahl_friction_nm);
        assert!(worst < 1e-9);
        assert!((s.dahl_friction_nm - 0.04 * w.signum()).abs() < 0.01 * 0.04);
    }
}

/// Speed reversal through zero under constant torque (loop open): T_f goes from +T_f0 toward
/// -T_f0 without chattering: ddahl changes sign at most once, |Ṫ_f| ≤ 4βT_f0²|ω|max, and
/// after the crossing T_f follows the angle-domain solution T_f = -T_f0 + x0/(1 + β x0 ψ),
/// x0 = 2T_f0, ψ = angle travelled since the crossing (independent of the speed profile).
/// Tol 1e-5 N m (the tanh band |ω| < 0.03 rad/s is travelled in ~1e-4 rad).
#[test]
fn dahl_reverses_smoothly() {
    let p = WheelParams { speed_loop_gain: 0.0, ..WheelParams::paper001() };
    let p = WheelParams { bearing_nm: 0.0, ripple_nm: 0.0, ..p };
    let mut s = WheelState::spinning(&p, 5.0, &Z);
    let dt = 1e-3;
    let (mut sign_changes, mut last_sign, mut max_rate, mut max_w) = (0, 0.0, 0.0_f64, 0.0_f64);
    let mut cross_angle = None;
    for _ in 0..10000 {
        let (d, o) = evaluate(&p, &s, -0.2, &Z, &Z);
        if d.ddahl.abs() > 1e-12 {
            let sg = d.ddahl.signum();
            if last_sign != 0.0 && sg != last_sign {
                sign_changes += 1;
            }
            last_sign = sg;
        }
        max_rate = max_rate.max(d.ddahl.abs());
        max_w = max_w.max(o.speed_rad_s.abs());
        let before = o.speed_rad_s;
        s = rk4(&p, &s, -0.2, dt);
        if before > 0.0 && evaluate(&p, &s, -0.2, &Z, &Z).1.speed_rad_s <= 0.0 {
            cross_angle = Some(s.rotor_angle_rad);
        }
    }
    let psi = cross_angle.unwrap() - s.rotor_angle_rad;
    let x0 = 2.0 * p.coulomb_nm;
    let truth = -p.coulomb_nm + x0 / (1.0 + p.dahl_beta * x0 * psi);
    let bound = 4.0 * p.dahl_beta * p.coulomb_nm.powi(2) * max_w;
    println!(
        "reversal: T_f end {:.6} vs closed form {truth:.6} (ψ = {psi:.2} rad), max |dT_f/dt| {max_rate:.4} ≤ {bound:.4}, sign changes {sign_changes}",
        s.dahl_friction_nm
    );
    assert!(sign_changes <= 1);
    assert!(max_rate <= bound);
    assert!((s.dahl_friction_nm - truth).abs() < 1e-5);
}

/// max_stable_step_s is stable for the worst Dahl state (T_f = -T_f0 at top speed, the
/// Jacobian bound): T_f rises monotonically to T_f0 without overshoot beyond 1e-9 N m.
#[test]
fn dahl_worst_case_stable_at_max_step() {
    let p = WheelParams { speed_loop_gain: 0.0, ..WheelParams::paper001() };
    let w = p.max_speed_rad_s;
    let s0 = WheelState { dahl_friction_nm: -p.coulomb_nm, ..WheelState::spinning(&p, w, &Z) };
    let f = |t: f64| evaluate(&p, &WheelState { dahl_friction_nm: t, ..s0 }, 0.0, &Z, &Z).0.ddahl;
    let dt = p.max_stable_step_s();
    let mut t = s0.dahl_friction_nm;
    for _ in 0..2000 {
        let (k1, k2) = (f(t), f(t + dt / 2.0 * f(t)));
        let k3 = f(t + dt / 2.0 * k2);
        let k4 = f(t + dt * k3);
        let tn = t + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        assert!(tn >= t - 1e-15 && tn <= p.coulomb_nm + 1e-9, "{t} -> {tn}");
        t = tn;
    }
    assert!((t - p.coulomb_nm).abs() < 1e-3 * p.coulomb_nm);
}

/// Keeps every recorded row (the run's time series in memory; `columns` from the simulation).
struct Rows {
    columns: Vec<String>,
    rows: Vec<Vec<f64>>,
}

impl sim_core::recorder::series::Recorder for Rows {
    fn start(&mut self, _: &[String], _: u64) -> anyhow::Result<()> {
        Ok(())
    }
    fn record(&mut self, row: &[f64]) -> anyhow::Result<()> {
        self.rows.push(row.to_vec());
        Ok(())
    }
}

/// The standing current of `scenarios/paper001/wheel-slew.toml`: after the slew wheel 3 sits
/// at ~0 rpm holding ~4 A and ~1.3 W (module doc of `plant/wheel.rs`, "Standing current at
/// zero speed"). Closed form at rest (`ω ≈ 0`, `ḣ_a ≈ 0`): eq 24 gives
/// `K_f I = T_f + λω + C_s sin(φ+φ0) + B sin(3Pφ)` (the Dahl state and the rotor-angle
/// dependent bearing/ripple torques at the rest angle hold the motor torque), the speed loop
/// (eq 25) gives `I = T_cmd/K_f + K_c (ω_ref - ω)` with `T_cmd ≈ 0` (the loop's reference runs
/// ahead of the stuck rotor), and eq 30 gives `P = R I² + K_f ω I ≈ R I²` (`p_q = a_i = 0`).
/// Checked against the plant's own states behind every recorded row after t = 250 s at which
/// the rotor is stuck (`|ḣ_a| < 1e-4 N m`): eq 24 within 2e-3 relative (`ḣ_a/K_f` ≤ 5.2e-3 A),
/// the loop form within 1e-2 relative (the wheel's share `T_cmd` of the hold command), the
/// power within 1e-9 relative. The rest are stick-slip events: the rotor slips to the next
/// angle that holds the current (at most ten of them, each under 2 rpm).
#[test]
fn standing_current_at_zero_speed_is_the_held_speed_loop_error() {
    use sim_core::link::in_process::InProcess;
    use sim_core::scenario::{Resolved, Scenario};
    use sim_core::simulation::Simulation;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/paper001/wheel-slew.toml");
    let sc = Scenario::load(&path).unwrap();
    let p = sc.wheel_params().unwrap()[2].clone();
    let mut link = InProcess::new();
    let mut rec = Rows { columns: Vec::new(), rows: Vec::new() };
    let mut held = Vec::new(); // (wheel-3 state behind the row, row)
    {
        let mut sim = Simulation::new(Resolved::try_from(&sc).unwrap(), &mut link).unwrap();
        rec.columns = sim.columns().to_vec();
        while !sim.finished() {
            let before = sim.state().wheels[2];
            let n = rec.rows.len();
            sim.step(&mut rec).unwrap();
            if rec.rows.len() > n {
                held.push((before, rec.rows[n].clone()));
            }
        }
    }
    let col = |name: &str| rec.columns.iter().position(|c| c == name).unwrap();
    let (t_c, w_c, i_c, p_c, f_c, d_c) = (
        col("t_s"),
        col("wheel3_speed_rpm"),
        col("wheel3_current_a"),
        col("wheel3_power_w"),
        col("wheel3_friction_nm"),
        col("wheel3_torque_nm"),
    );
    let (k, r) = (p.torque_constant_nm_per_a, p.resistance_ohm);
    let (mut worst_eq24, mut worst_loop, mut worst_p, mut max_stuck_rpm, mut max_slip_rpm) =
        (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
    let (mut stuck, mut slipping, mut slips, mut last) = (0, 0, Vec::new(), None);
    for (s, row) in held.iter().filter(|(_, row)| row[t_c] >= 250.0) {
        let w = row[w_c] * std::f64::consts::PI / 30.0;
        let (i, pw) = (row[i_c], row[p_c]);
        assert!((row[f_c] - s.dahl_friction_nm - p.viscous_nms * w).abs() < 1e-12);
        worst_p = worst_p.max((r * i * i + k * w * i - pw).abs() / pw);
        if row[d_c].abs() >= 1e-4 {
            if slipping == 0 {
                slips.push(row[t_c]);
            }
            slipping += 1;
            max_slip_rpm = max_slip_rpm.max(row[w_c].abs());
            continue;
        }
        slipping = 0;
        stuck += 1;
        let phi = s.rotor_angle_rad;
        let cogging = p.bearing_nm * (phi + p.phase_rad).sin() + p.ripple_nm * (3.0 * p.motor_poles * phi).sin();
        let hold = s.dahl_friction_nm + p.viscous_nms * w + cogging;
        worst_eq24 = worst_eq24.max((hold / k - i).abs() / i);
        worst_loop = worst_loop.max((p.speed_loop_gain * (s.speed_ref_rad_s - w) - i).abs() / i);
        max_stuck_rpm = max_stuck_rpm.max(row[w_c].abs());
        last = Some((row.clone(), s.dahl_friction_nm, cogging, s.speed_ref_rad_s - w));
    }
    let (row, tf, cogging, lead) = last.unwrap();
    println!(
        "t = {} s: wheel 3 at {:.2e} rpm, I = {:.4} A (closed form (T_f {tf:.5} + cogging {cogging:.5}) / K_f = {:.4} A; \
         K_c Δω = {:.4} A, Δω = ω_ref - ω = {lead:.4} rad/s = {:.2} rpm), P = {:.4} W (R I² = {:.4} W)",
        row[t_c],
        row[w_c],
        row[i_c],
        (tf + cogging) / k,
        p.speed_loop_gain * lead,
        lead * 30.0 / std::f64::consts::PI,
        row[p_c],
        r * row[i_c] * row[i_c],
    );
    println!(
        "t ≥ 250 s: {stuck} rows stuck (max |ω| {max_stuck_rpm:.2e} rpm), slips from t = {slips:?} s (max {max_slip_rpm:.2} rpm); \
         worst rel. error when stuck: eq 24 {worst_eq24:.1e}, loop {worst_loop:.1e}; power {worst_p:.1e}"
    );
    assert!(max_stuck_rpm < 0.1 && stuck > 900 && (1..=10).contains(&slips.len()) && max_slip_rpm < 2.0);
    assert!(worst_eq24 < 2e-3 && worst_loop < 1e-2 && worst_p < 1e-9);
    // The figures of the issue: ~4 A, ~1.3 W, friction ~0.041 N m, all copper loss.
    assert!((3.5..4.5).contains(&row[i_c]) && (1.0..1.6).contains(&row[p_c]));
    assert!((row[p_c] - r * row[i_c] * row[i_c]).abs() < 1e-3 * row[p_c]);
    assert!((row[f_c] - 0.041).abs() < 1e-3);
    // The hold is shared: the friction state near T_f0, the rest from the rotor angle.
    assert!(cogging > 0.0 && cogging <= p.bearing_nm + p.ripple_nm);
}

/// `torque_lag_s`: the torque the wheel applies to its rotor follows a command step as
/// `T (1 - e^{-t/τ})` (first-order lag, RK4 as a state: relative error ≈ (h/τ)⁵/120 per step,
/// tolerance 1e-9 of the step at h = τ/50); without a lag it is the command at once.
#[test]
fn torque_lag_step_response_is_one_minus_exp() {
    let tau = 0.05;
    let p = WheelParams { torque_lag_s: tau, ..WheelParams::ideal(0.2, 600.0, 0.01) };
    p.validate().unwrap();
    assert!((p.fastest_rate_per_s() - (1.0 / tau).max(0.2 / (0.01 * 6.0))).abs() < 1e-12);
    let (cmd, h) = (0.1, tau / 50.0);
    let mut s = WheelState::default();
    let mut worst: f64 = 0.0;
    for k in 0..=500 {
        let t = k as f64 * h;
        let applied = evaluate(&p, &s, cmd, &Z, &Z).0.dh_abs_nm;
        worst = worst.max((applied - cmd * (1.0 - (-t / tau).exp())).abs() / cmd);
        s = rk4(&p, &s, cmd, h);
    }
    eprintln!("lag step response: worst error {worst:.2e} of the step");
    assert!(worst < 1e-9, "{worst}");
    // No lag: the command at once, the lag state never moves.
    let p0 = WheelParams::ideal(0.2, 600.0, 0.01);
    let (d, _) = evaluate(&p0, &WheelState::default(), cmd, &Z, &Z);
    assert_eq!((d.dh_abs_nm, d.dapplied_torque), (cmd, 0.0));
    for (f, bad) in [
        ("torque_lag_s", WheelParams { torque_lag_s: -1.0, ..p0.clone() }),
        ("torque_delay_s", WheelParams { torque_delay_s: f64::NAN, ..p0.clone() }),
    ] {
        let e = bad.validate().unwrap_err();
        assert!(e.contains(f), "{e}");
    }
}

/// `torque_delay_s`: the delay line returns the command of `round(Δ/h)` dynamics steps
/// earlier (zeros before), Δ rounded to whole steps.
#[test]
fn torque_delay_line_shifts_by_whole_dynamics_steps() {
    let h = 0.001;
    for (delay, steps) in [(0.0, 0), (0.003, 3), (0.0034, 3), (0.0036, 4), (0.0004, 0)] {
        let mut d = DelayLine::<2>::from_seconds(delay, h);
        assert_eq!(d.steps(), steps, "{delay}");
        for k in 0..20usize {
            let y = d.push([k as f64 + 1.0, -(k as f64) - 1.0]);
            let want = if k >= steps { (k - steps) as f64 + 1.0 } else { 0.0 };
            assert_eq!(y, [want, -want], "delay {delay} k {k}");
        }
    }
}

/// An ideal wheel has no size of its own (issue 22): a scenario edited in code past the
/// validation, without one of the three sizes, gets an error naming the key from
/// `wheel_params`, not paper 001's wheel.
#[test]
fn an_ideal_wheel_without_its_size_is_an_error_not_paper_001s_wheel() {
    use sim_core::scenario::Scenario;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/scenarios/margins/rigid-pd.toml");
    let sc = Scenario::load(&path).unwrap();
    let p = sc.wheel_params().unwrap();
    assert_eq!((p.len(), p[0].max_torque_nm, p[0].inertia_kgm2), (3, 5.0, 0.01));
    let mut unsized_wheel = sc.clone();
    unsized_wheel.actuators.wheels.as_mut().unwrap().inertia_kgm2 = None;
    let e = unsized_wheel.wheel_params().unwrap_err().to_string();
    assert!(e.contains("actuators.wheels.inertia_kgm2") && e.contains("no default"), "{e}");
}
