//! The sun-safe law in closed loop with a rigid body simulated here in f64 (Euler's
//! equations + quaternion kinematics, RK4, pure torque actuator, 3U-cubesat inertia
//! diag(0.037, 0.036, 0.006) kg m², 2e-4 N m per axis), coarse sun sensors with
//! noise-free cosine currents through `estimation::css`:
//! (a) acquisition from 200 random attitudes with the Sun always visible (six-head cube);
//! (b) search from attitudes with the Sun behind a hemispherical field of view;
//! (c) a 2,100 s eclipse on a biased, noisy MEMS gyro: panel error within the closed-form
//!     drift bound, re-acquisition at exit;
//! (d) the Lyapunov function `V = kp P(θ) + ½ωᵀJω` does not increase while unsaturated;
//! plus parameter validation and absurd inputs.
//!
//! Gains: ωn = 0.05 rad/s on the largest inertia, ζ = 0.7 on every axis:
//! kp = J_max ωn² = 9.25e-5 N m/rad, kd_i = 2ζ √(kp J_i) = (2.59, 2.55, 1.04)e-3 N m s/rad.
//! Search 0.02 rad/s about body x (a principal axis ⟂ the panel normal +z): one
//! revolution 314 s. Timeout 200 s. Control step 0.1 s (zero-order hold).

#![allow(clippy::disallowed_methods)]

use acs_flight::control::sun_safe::{SunSafe, SunSafeOutput, SunSafePhase};
use acs_flight::estimation::css::{CssHeads, sun_vector};
use acs_flight::math::Vec3;
use acs_flight::params::{SunSafeError, SunSafeParams};
use acs_flight::types::MAX_CSS_HEADS;
use acs_test_support::rng::SplitMix64 as Rng;
use nalgebra::{Quaternion, Vector3};

type V64 = Vector3<f64>;
type Q64 = Quaternion<f64>;

const J: [f64; 3] = [0.037, 0.036, 0.006];
const TORQUE_LIMIT_NM: f32 = 2e-4;
const OMEGA_N: f64 = 0.05;
const ZETA: f64 = 0.7;
const SEARCH_RATE: f64 = 0.02;
const DT: f64 = 0.1;
const SETTLED_ANGLE_DEG: f64 = 5.0;
const SETTLED_RATE_DEG_S: f64 = 0.05;

fn kp() -> f64 {
    J[0] * OMEGA_N * OMEGA_N
}
fn kd() -> [f64; 3] {
    J.map(|j| 2.0 * ZETA * (kp() * j).sqrt())
}

fn params() -> SunSafeParams {
    SunSafeParams {
        panel_normal_body: [0.0, 0.0, 1.0],
        kp_nm_per_rad: kp() as f32,
        kd_nm_s_per_rad: kd().map(|k| k as f32),
        search_axis_body: [1.0, 0.0, 0.0],
        search_rate_rad_s: SEARCH_RATE as f32,
        torque_limit_nm: [TORQUE_LIMIT_NM; 3],
        sun_timeout_s: 200.0,
    }
}

fn panel() -> V64 {
    V64::z()
}

/// Rigid body, f64: `q` body → inertial (scalar-last Hamilton, `dq/dt = ½ q ⊗ [ω; 0]`),
/// `J ω̇ = T − ω × Jω`; RK4 with the torque held over the step.
struct Body {
    q: Q64,
    w: V64,
}
impl Body {
    fn deriv(q: &Q64, w: &V64, t: &V64) -> (Q64, V64) {
        let jw = V64::new(J[0] * w.x, J[1] * w.y, J[2] * w.z);
        let rhs = t - w.cross(&jw);
        (q * Q64::from_imag(*w) * 0.5, V64::new(rhs.x / J[0], rhs.y / J[1], rhs.z / J[2]))
    }
    fn step(&mut self, t: &V64, h: f64) {
        let (q0, w0) = (self.q, self.w);
        let (k1q, k1w) = Self::deriv(&q0, &w0, t);
        let (k2q, k2w) = Self::deriv(&(q0 + k1q * (0.5 * h)), &(w0 + k1w * (0.5 * h)), t);
        let (k3q, k3w) = Self::deriv(&(q0 + k2q * (0.5 * h)), &(w0 + k2w * (0.5 * h)), t);
        let (k4q, k4w) = Self::deriv(&(q0 + k3q * h), &(w0 + k3w * h), t);
        self.q = (q0 + (k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (h / 6.0)).normalize();
        self.w = w0 + (k1w + k2w * 2.0 + k3w * 2.0 + k4w) * (h / 6.0);
    }
    /// The inertial direction `v_i` in body axes.
    fn to_body(&self, v_i: &V64) -> V64 {
        (self.q.conjugate() * Q64::from_imag(*v_i) * self.q).imag()
    }
    fn energy(&self) -> f64 {
        0.5 * (J[0] * self.w.x * self.w.x + J[1] * self.w.y * self.w.y + J[2] * self.w.z * self.w.z)
    }
}

fn angle(a: &V64, b: &V64) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}
fn f32v(v: &V64) -> Vec3 {
    Vec3::new(v.x as f32, v.y as f32, v.z as f32)
}
fn f64v(v: &Vec3) -> V64 {
    V64::new(f64::from(v.x), f64::from(v.y), f64::from(v.z))
}

fn heads(normals: &[[f32; 3]], thr: f32) -> CssHeads {
    let mut n = [[0.0f32; 3]; MAX_CSS_HEADS];
    n[..normals.len()].copy_from_slice(normals);
    CssHeads { normals_body: n, count: normals.len() as u8, lit_threshold: thr }
}
/// Six heads ±x ±y ±z, threshold 0.02: sees every direction (coarse within
/// asin(√2·0.02) = 1.6° of a head axis).
fn cube() -> CssHeads {
    heads(
        &[[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]],
        0.02,
    )
}
/// Boresight head on the panel normal +z and four heads tilted 45° from it: least
/// squares (exact) wherever all five are lit, i.e. within ~43° of +z.
fn pyramid() -> CssHeads {
    let s = std::f32::consts::FRAC_1_SQRT_2;
    heads(&[[0.0, 0.0, 1.0], [s, 0.0, s], [0.0, s, s], [-s, 0.0, s], [0.0, -s, s]], 0.02)
}
fn cosine_currents(h: &CssHeads, s_b: &V64) -> [f32; MAX_CSS_HEADS] {
    let mut c = [0.0f32; MAX_CSS_HEADS];
    for (ci, n) in c.iter_mut().zip(&h.normals_body[..h.count as usize]) {
        *ci = (V64::new(f64::from(n[0]), f64::from(n[1]), f64::from(n[2])).dot(s_b)).max(0.0) as f32;
    }
    c
}
/// The CSS Sun direction, `None` when not seen.
fn css(h: &CssHeads, s_b: &V64) -> Option<Vec3> {
    sun_vector(h, &cosine_currents(h, s_b)).ok().map(|s| s.dir_body)
}

struct Run {
    /// Last time (s) the panel was ≥ 5° off the Sun or the rate ≥ 0.05 deg/s (0 if never).
    settle_s: f64,
    first_seen_s: Option<f64>,
    final_angle_deg: f64,
    final_rate_deg_s: f64,
}

fn settled(body: &Body, sun_i: &V64) -> bool {
    angle(&panel(), &body.to_body(sun_i)).to_degrees() < SETTLED_ANGLE_DEG
        && body.w.norm().to_degrees() < SETTLED_RATE_DEG_S
}

/// Closed loop for `t_end` s: `sensor` maps the true body Sun to a measurement,
/// `gyro` the true rate to a measured one, `eclipse(t)` hides the Sun and tells the law.
#[allow(clippy::too_many_arguments)]
fn run(
    law: &mut SunSafe,
    body: &mut Body,
    sun_i: &V64,
    t_end: f64,
    sensor: &dyn Fn(&V64) -> Option<Vec3>,
    gyro: &mut dyn FnMut(&V64) -> V64,
    eclipse: &dyn Fn(f64) -> bool,
    observe: &mut dyn FnMut(f64, &Body, &SunSafeOutput),
) -> Run {
    let steps = (t_end / DT).round() as usize;
    let mut r = Run { settle_s: 0.0, first_seen_s: None, final_angle_deg: 0.0, final_rate_deg_s: 0.0 };
    for k in 0..steps {
        let t = k as f64 * DT;
        let ecl = eclipse(t);
        let s_b = body.to_body(sun_i);
        let meas = if ecl { None } else { sensor(&s_b) };
        if meas.is_some() && r.first_seen_s.is_none() {
            r.first_seen_s = Some(t);
        }
        let out = law.update(meas, ecl, &f32v(&gyro(&body.w)), DT as f32);
        assert!(!out.input_rejected);
        observe(t, body, &out);
        body.step(&f64v(&out.torque_nm), DT);
        if !settled(body, sun_i) {
            r.settle_s = t + DT;
        }
    }
    r.final_angle_deg = angle(&panel(), &body.to_body(sun_i)).to_degrees();
    r.final_rate_deg_s = body.w.norm().to_degrees();
    r
}

fn random_rate(rng: &mut Rng, max_deg_s: f64) -> V64 {
    rng.unit() * rng.uniform() * max_deg_s.to_radians()
}

#[test]
fn a_acquires_the_sun_from_random_attitudes() {
    // 200 random attitudes, rates up to 1 deg/s (after B-dot), Sun fixed, always visible to
    // the six-head cube; ideal gyro. Settled = within 5° and below 0.05 deg/s from then on.
    let mut rng = Rng(51);
    let sun_i = rng.unit();
    let h = cube();
    let (mut worst, mut sum, mut worst_final) = (0.0f64, 0.0, 0.0f64);
    for _ in 0..200 {
        let mut law = SunSafe::new(params()).unwrap();
        let mut body = Body { q: rng.quat(), w: random_rate(&mut rng, 1.0) };
        let r = run(&mut law, &mut body, &sun_i, 1200.0, &|s| css(&h, s), &mut |w| *w, &|_| false, &mut |_, _, out| {
            assert_ne!(out.phase, SunSafePhase::Searching)
        });
        assert!(r.final_angle_deg < SETTLED_ANGLE_DEG && r.final_rate_deg_s < SETTLED_RATE_DEG_S);
        worst = worst.max(r.settle_s);
        worst_final = worst_final.max(r.final_angle_deg);
        sum += r.settle_s;
    }
    println!(
        "(a) 200 random attitudes: settled (< 5 deg, < 0.05 deg/s) after {:.0} s mean, {worst:.0} s max; \
         worst final angle {worst_final:.2} deg (cube coarse dead band ≤ 1.62 deg)",
        sum / 200.0
    );
    // Measured max 177 s (mean 133 s); asserted at 250 s. For scale: the linear settling
    // time 4/(ζ ωn) = 114 s on the slowest axis, plus the large-angle slew (up to 180°).
    assert!(worst <= 250.0, "settling {worst} s");
    assert!(worst_final <= 2.0);
}

#[test]
fn b_search_finds_the_sun_behind_a_hemispherical_field_of_view() {
    // The pyramid heads behind a baffle: the Sun is seen only in the hemisphere about the
    // panel normal (s·a > 0) and when a head is lit. Starts: Sun behind the panel.
    let mut rng = Rng(52);
    let sun_i = V64::new(0.3, -0.5, 0.8).normalize();
    let h = pyramid();
    let sensor = |s: &V64| if s.z > 0.0 { css(&h, s) } else { None };
    // Spin-up to the search rate: rate-loop time constant J_x/kd_x = 14.3 s, unsaturated
    // (kd_x · 0.03 rad/s = 7.8e-5 N m < 2e-4); three time constants = 43 s. Then at most
    // one revolution 2π/ω_s = 314 s before the Sun is in the hemisphere.
    let tau = J[0] / kd()[0];
    let bound_found = 3.0 * tau + 2.0 * std::f64::consts::PI / SEARCH_RATE;
    let (mut worst_found, mut worst_settle, mut n) = (0.0f64, 0.0f64, 0);
    while n < 50 {
        let q = rng.quat();
        let body0 = Body { q, w: random_rate(&mut rng, 0.5) };
        if body0.to_body(&sun_i).z > -0.05 {
            continue; // Sun (nearly) in view: not a search case
        }
        let mut body = body0;
        let mut law = SunSafe::new(params()).unwrap();
        let mut searched = false;
        let r = run(&mut law, &mut body, &sun_i, 1500.0, &sensor, &mut |w| *w, &|_| false, &mut |_, _, out| {
            searched |= out.phase == SunSafePhase::Searching
        });
        assert!(searched);
        let found = r.first_seen_s.unwrap();
        assert!(found <= bound_found, "found after {found} s > {bound_found} s");
        assert!(r.final_angle_deg < SETTLED_ANGLE_DEG && r.final_rate_deg_s < SETTLED_RATE_DEG_S);
        worst_found = worst_found.max(found);
        worst_settle = worst_settle.max(r.settle_s);
        n += 1;
    }
    println!(
        "(b) 50 searches: Sun first seen after {worst_found:.0} s max (bound 3τ + 2π/ω_s = {bound_found:.0} s), \
         settled after {worst_settle:.0} s max"
    );
    // Settling after sighting: at most the acquisition time of (a) (≤ 250 s asserted there).
    assert!(worst_settle <= bound_found + 250.0);
}

#[test]
fn c_eclipse_hold_on_a_biased_gyro_and_reacquisition() {
    // MEMS gyro: residual bias 1e-4 rad/s (20.6 deg/h: an uncompensated turn-on and
    // temperature bias of a MEMS part, several times its bias instability) on an axis ⟂
    // the Sun (worst case); angle random walk 0.3 deg/√h = 8.73e-5 rad/√s (ADIS16488
    // class), white rate noise of ARW/√dt per 0.1 s sample. Settle 600 s on the pyramid
    // (exact least squares near the Sun), then 2,100 s of eclipse, then 900 s of Sun.
    let bias = V64::new(0.6, -0.8, 0.0) * 1e-4;
    let arw = 0.3f64.to_radians() / 60.0;
    let (t_in, t_ecl, t_after) = (600.0, 2100.0, 900.0);
    let sun_i = V64::new(-0.2, 0.9, 0.1).normalize();
    let h = pyramid();
    let mut rng = Rng(53);
    let mut noise = Rng(54);
    let mut body = Body { q: rng.quat(), w: V64::zeros() };
    // Start with the Sun in view (pyramid sees ~135° around +z).
    while body.to_body(&sun_i).z < 0.3 {
        body.q = rng.quat();
    }
    let mut law = SunSafe::new(params()).unwrap();
    let mut gyro = |w: &V64| w + bias + V64::new(noise.normal(), noise.normal(), noise.normal()) * (arw / DT.sqrt());
    let eclipse = |t: f64| t >= t_in && t < t_in + t_ecl;
    // Bound on the true panel–Sun angle in eclipse, t after entry: the memory drifts by the
    // bias component ⟂ the Sun, |b⊥| t (closed form for a constant bias with the body
    // held), plus the angle random walk (4 σ of one axis, ARW √t), plus the loop's ramp
    // lag (kd/kp) |b| = 2ζ/ωn |b| on the slowest axis, plus the error at entry θ0.
    let b_perp = bias.norm(); // bias ⟂ panel and Sun by construction
    let lag = kd()[0] / kp() * bias.norm();
    let mut theta0: Option<f64> = None;
    let (mut worst_ratio, mut theta_end) = (0.0f64, 0.0);
    let mut reacquired: Option<f64> = None;
    let mut last_settle = 0.0;
    let r = run(
        &mut law,
        &mut body,
        &sun_i,
        t_in + t_ecl + t_after,
        &|s| css(&h, s),
        &mut gyro,
        &eclipse,
        &mut |t, b, out| {
            let s_b = b.to_body(&sun_i);
            let theta = angle(&panel(), &s_b);
            if eclipse(t) {
                assert_eq!(out.phase, SunSafePhase::EclipseHold);
                let th0 = *theta0.get_or_insert(theta);
                let te = t - t_in;
                let bound = th0 + b_perp * te + 4.0 * arw * te.sqrt() + lag + 1e-3;
                worst_ratio = worst_ratio.max(theta / bound);
                theta_end = theta;
            } else if t >= t_in + t_ecl {
                if reacquired.is_none() && out.phase == SunSafePhase::Pointing {
                    reacquired = Some(t - t_in - t_ecl);
                }
                if theta.to_degrees() >= SETTLED_ANGLE_DEG || b.w.norm().to_degrees() >= SETTLED_RATE_DEG_S {
                    last_settle = t - t_in - t_ecl + DT;
                }
            }
        },
    );
    let drift_closed_form = b_perp * t_ecl;
    println!(
        "(c) eclipse {t_ecl} s, bias {:.1e} rad/s ⟂ Sun, ARW {arw:.2e} rad/√s: panel–Sun angle at entry {:.3} deg, \
         at exit {:.2} deg (closed form |b⊥| t = {:.2} deg); worst angle / bound {worst_ratio:.3}; \
         re-acquired {:.1} s after exit, settled {last_settle:.0} s after exit",
        bias.norm(),
        theta0.unwrap().to_degrees(),
        theta_end.to_degrees(),
        drift_closed_form.to_degrees(),
        reacquired.unwrap()
    );
    assert!(worst_ratio <= 1.0);
    // The drift is the bias, not something else: within the noise of the closed form.
    assert!((theta_end - theta0.unwrap() - drift_closed_form).abs() <= 4.0 * arw * t_ecl.sqrt() + lag + 1e-3);
    assert!(reacquired.unwrap() <= DT, "Sun seen again at the first step after exit");
    assert!(last_settle <= 600.0);
    assert!(r.final_angle_deg < SETTLED_ANGLE_DEG);
}

/// `P(θ)` of the module docs: 1 − cos θ up to 90°, then 1 + (θ − π/2).
fn potential(theta: f64) -> f64 {
    if theta <= std::f64::consts::FRAC_PI_2 { 1.0 - theta.cos() } else { 1.0 + theta - std::f64::consts::FRAC_PI_2 }
}

#[test]
fn d_lyapunov_function_does_not_increase_while_unsaturated() {
    // Exact Sun direction (no sensor), ideal gyro, 100 random attitudes with rates up to
    // 0.3 deg/s. Over one control step the continuous law gives ΔV = −∫ωᵀKdω dt; the
    // zero-order hold perturbs that by the work of the held torque's deviation, the f32
    // torque by the work of its rounding. Assert ΔV ≤ those two bounds (derived below) on
    // every unsaturated step, and ΔV < 0 wherever the step dissipates more than 1e-12 J.
    let mut rng = Rng(55);
    let sun_i = V64::x();
    let kdv = kd();
    let (mut worst_rel, mut worst_abs, mut n_steps, mut n_sat) = (f64::NEG_INFINITY, f64::NEG_INFINITY, 0usize, 0usize);
    let mut worst_tol_use = f64::NEG_INFINITY;
    for _ in 0..100 {
        let mut law = SunSafe::new(params()).unwrap();
        let mut body = Body { q: rng.quat(), w: random_rate(&mut rng, 0.3) };
        for _ in 0..6000 {
            let s_b = body.to_body(&sun_i);
            let v0 = kp() * potential(angle(&panel(), &s_b)) + body.energy();
            let w0 = body.w;
            let out = law.update(Some(f32v(&s_b)), false, &f32v(&body.w), DT as f32);
            body.step(&f64v(&out.torque_nm), DT);
            let s_b1 = body.to_body(&sun_i);
            let v1 = kp() * potential(angle(&panel(), &s_b1)) + body.energy();
            if out.saturated {
                n_sat += 1;
                continue;
            }
            // Dissipation over the step, trapezoid of ωᵀKdω.
            let diss = |w: &V64| kdv[0] * w.x * w.x + kdv[1] * w.y * w.y + kdv[2] * w.z * w.z;
            let d = 0.5 * (diss(&w0) + diss(&body.w)) * DT;
            // The ratio is meaningful only where the step dissipates more than rounding.
            if d > 1e-12 {
                worst_rel = worst_rel.max((v1 - v0) / d);
            }
            worst_abs = worst_abs.max(v1 - v0);
            // f32 rounding of the torque (a few ulp of kp|u| + |Kd ω|) does work ω·δT dt.
            let f32_work = DT * w0.norm() * (kp() + kdv[0] * w0.norm()) * 8.0 * 2f64.powi(-24);
            // Zero-order hold: the held torque differs from the continuous law's by at most
            // (kp |u̇| + |Kd ω̇|)(t − t_k) with |u̇| ≤ |ω|, so its work over the step is at most
            // ½ dt² |ω|max (kp |ω|max + kd_max |Δω|/dt).
            let wmax = w0.norm().max(body.w.norm());
            let zoh_work = 0.5 * DT * DT * wmax * (kp() * wmax + kdv[0] * (body.w - w0).norm() / DT);
            assert!(v1 - v0 <= zoh_work + f32_work + 1e-18, "V grew by {} J (dissipation {d} J)", v1 - v0);
            worst_tol_use = worst_tol_use.max((v1 - v0) / (zoh_work + f32_work + 1e-18));
            n_steps += 1;
        }
    }
    println!(
        "(d) {n_steps} unsaturated steps: worst ΔV / dissipation = {worst_rel:.4} where dissipation > 1e-12 J \
         (−1 is the continuous law), largest ΔV {worst_abs:.1e} J, at most {worst_tol_use:.3} of the ZOH + f32 tolerance; {n_sat} saturated steps skipped"
    );
    assert!(worst_rel < 0.0, "V must decrease wherever the step dissipates measurably");
}

fn p_with(f: impl Fn(&mut SunSafeParams)) -> SunSafeParams {
    let mut p = params();
    f(&mut p);
    p
}

#[test]
fn validation_and_absurd_inputs() {
    assert!(params().validate().is_ok());
    assert_eq!(p_with(|p| p.panel_normal_body = [0.0, 0.0, 1.1]).validate(), Err(SunSafeError::PanelNormal));
    assert_eq!(p_with(|p| p.panel_normal_body = [f32::NAN, 0.0, 1.0]).validate(), Err(SunSafeError::PanelNormal));
    assert_eq!(p_with(|p| p.search_axis_body = [0.0, 0.0, 0.0]).validate(), Err(SunSafeError::SearchAxis));
    assert_eq!(
        p_with(|p| p.search_axis_body = [0.0, 0.6, 0.8]).validate(),
        Err(SunSafeError::SearchAxisNotPerpendicular)
    );
    assert_eq!(p_with(|p| p.kp_nm_per_rad = 0.0).validate(), Err(SunSafeError::Gain));
    assert_eq!(p_with(|p| p.kd_nm_s_per_rad[2] = f32::INFINITY).validate(), Err(SunSafeError::Gain));
    assert_eq!(p_with(|p| p.search_rate_rad_s = -0.01).validate(), Err(SunSafeError::SearchRate));
    assert_eq!(p_with(|p| p.torque_limit_nm[1] = 0.0).validate(), Err(SunSafeError::TorqueLimit));
    assert_eq!(p_with(|p| p.sun_timeout_s = f32::NAN).validate(), Err(SunSafeError::Timeout));
    assert!(SunSafe::new(p_with(|p| p.sun_timeout_s = -1.0)).is_err());

    // Phases from a known state: seen → Pointing; lost in daylight → hold for the timeout,
    // then Searching (memory discarded); eclipse without memory → damping only.
    let mut law = SunSafe::new(params()).unwrap();
    let w = Vec3::new(0.001, -0.002, 0.0005);
    let out = law.update(Some(Vec3::new(0.0, 1.0, 1.0)), false, &w, 0.1);
    assert_eq!(out.phase, SunSafePhase::Pointing);
    assert!((out.sun_angle_rad - std::f32::consts::FRAC_PI_4).abs() < 1e-6);
    let mut t = 0.0;
    while t < 199.85 {
        assert_eq!(law.update(None, false, &Vec3::zeros(), 0.1).phase, SunSafePhase::EclipseHold);
        t += 0.1;
    }
    let mut searching = false;
    for _ in 0..5 {
        searching |= law.update(None, false, &Vec3::zeros(), 0.1).phase == SunSafePhase::Searching;
    }
    assert!(searching && law.sun_memory_body().is_none());
    let out = law.update(None, false, &Vec3::zeros(), 0.1);
    // Search torque from rest: −kd (0 − ω_s e_x) on x only.
    assert!((f64::from(out.torque_nm.x) - kd()[0] * SEARCH_RATE).abs() < 1e-9 && out.torque_nm.yz().norm() == 0.0);
    assert!(out.sun_angle_rad.is_nan());
    let out = law.update(None, true, &w, 0.1);
    assert_eq!(out.phase, SunSafePhase::EclipseHold);
    let expect = -Vec3::from(params().kd_nm_s_per_rad).component_mul(&w);
    assert!((out.torque_nm - expect).norm() < 1e-9);
    // Anti-Sun: full-magnitude torque about the search axis, never zero.
    law.reset();
    let out = law.update(Some(Vec3::new(0.0, 0.0, -1.0)), false, &Vec3::zeros(), 0.1);
    assert!((f64::from(out.torque_nm.x) - kp()).abs() < 1e-9);
    // Memory propagation: a rotation of 90° about x over 10 s carries the Sun from +y to −z
    // in body axes (the body turns +90° about x, an inertial +y then lies along body −z).
    law.reset();
    law.update(Some(Vec3::new(0.0, 1.0, 0.0)), false, &Vec3::zeros(), 0.1);
    let rate = Vec3::new(std::f32::consts::FRAC_PI_2 / 10.0, 0.0, 0.0);
    for _ in 0..10 {
        law.update(None, true, &rate, 1.0);
    }
    let m = law.sun_memory_body().unwrap();
    assert!((m - Vec3::new(0.0, 0.0, -1.0)).norm() < 1e-5, "{m:?}");

    // Absurd inputs: zero torque, state unchanged, no panic.
    let before = law;
    for (sun, gyro, dt) in [
        (Some(Vec3::new(f32::NAN, 0.0, 1.0)), Vec3::zeros(), 0.1),
        (Some(Vec3::zeros()), Vec3::zeros(), 0.1),
        (Some(Vec3::new(1e30, 1e30, 1e30)), Vec3::zeros(), 0.1),
        (None, Vec3::new(f32::INFINITY, 0.0, 0.0), 0.1),
        (None, Vec3::new(1e30, 0.0, 0.0), 0.1),
        (None, Vec3::zeros(), 0.0),
        (None, Vec3::zeros(), -1.0),
        (None, Vec3::zeros(), f32::NAN),
        (None, Vec3::zeros(), 1e9),
    ] {
        let out = law.update(sun, true, &gyro, dt);
        assert!(out.input_rejected, "{sun:?} {gyro:?} {dt}");
        assert_eq!(out.torque_nm, Vec3::zeros());
        assert_eq!(law, before);
    }
    // Random bit patterns: any accepted output is finite and within the limits.
    let mut rng = Rng(56);
    let mut law = SunSafe::new(params()).unwrap();
    for k in 0..100_000u32 {
        let f = |rng: &mut Rng| -> f32 {
            if rng.next_u64().is_multiple_of(3) { f32::from_bits(rng.next_u64() as u32) } else { rng.normal() as f32 }
        };
        let sun = if k % 3 == 0 { None } else { Some(Vec3::new(f(&mut rng), f(&mut rng), f(&mut rng))) };
        let gyro = Vec3::new(f(&mut rng), f(&mut rng), f(&mut rng)) * 0.1;
        let dt = if k % 5 == 0 { f(&mut rng) } else { 0.1 };
        let out = law.update(sun, k % 2 == 0, &gyro, dt);
        assert!(out.torque_nm.iter().all(|x| x.is_finite() && x.abs() <= TORQUE_LIMIT_NM * 1.000_001));
    }
}
