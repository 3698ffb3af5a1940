//! The f32 flight MEKF (`acs_flight::estimation::mekf`) against the independent f64
//! reference (`acs_test_support::mekf_ref`, Crassidis & Junkins Table 7.1 with van
//! Loan's discretisation) on the same seeded measurement stream, and the flight's
//! closed-form process noise (M&C eq 6.93) against van Loan's.
//!
//! Both filters get the same numbers: the stream is simulated in f64, rounded to f32 for
//! the flight filter and those f32 values widened back for the reference, so that the
//! difference between the two is the filters' own arithmetic (f32 vs f64, closed forms vs
//! matrix exponential, Joseph vs standard update), not their inputs.

// Host test in f64: nalgebra's norms are the reference here.
#![allow(clippy::disallowed_methods)]

use acs_flight::estimation::mekf::{CHI2_2DOF_999, CHI2_3DOF_999, Mekf, MekfConfig};
use acs_flight::math::{Quat, Vec3};
use acs_test_support::mekf_ref::{MekfRef, MekfRefConfig, cross_matrix, discretise};
use nalgebra::{Matrix3, Matrix6, Quaternion, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

type V64 = Vector3<f64>;
type Q64 = Quaternion<f64>;

/// f32 unit roundoff.
const EPS32: f64 = f32::EPSILON as f64 / 2.0;

fn cfg() -> MekfConfig {
    MekfConfig {
        gyro_arw_rad_sqrt_s: 3e-5,   // 0.1°/√h
        gyro_rrw_rad_s_sqrt_s: 3e-8, // bias random walk
        initial_attitude_sigma_rad: 0.02,
        initial_bias_sigma_rad_s: 2e-4,
        max_dt_s: 1.0,
        gate_attitude: CHI2_3DOF_999,
        gate_vector: CHI2_2DOF_999,
    }
}

fn ref_cfg(c: &MekfConfig) -> MekfRefConfig {
    MekfRefConfig {
        gyro_arw_rad_sqrt_s: f64::from(c.gyro_arw_rad_sqrt_s),
        gyro_rrw_rad_s_sqrt_s: f64::from(c.gyro_rrw_rad_s_sqrt_s),
        gate_attitude: f64::from(c.gate_attitude),
        gate_vector: f64::from(c.gate_vector),
    }
}

fn f32v(v: &V64) -> Vec3 {
    Vec3::new(v.x as f32, v.y as f32, v.z as f32)
}
fn f64v(v: &Vec3) -> V64 {
    v.map(f64::from)
}
fn f32q(q: &Q64) -> Quat {
    Quat::new(q.w as f32, q.i as f32, q.j as f32, q.k as f32)
}
fn f64q(q: &Quat) -> Q64 {
    Q64::from(q.coords.map(f64::from))
}
fn qexp(v: &V64) -> Q64 {
    UnitQuaternion::from_scaled_axis(*v).into_inner()
}
/// Rotation vector of `a* ⊗ b` (b relative to a, body axes of a), rad.
fn err_vec(a: &Q64, b: &Q64) -> V64 {
    let mut e = a.conjugate() * b;
    if e.w < 0.0 {
        e = -e;
    }
    let s = e.imag().norm();
    if s < 1e-300 { e.imag() * 2.0 } else { e.imag() * (2.0 * s.atan2(e.w) / s) }
}

struct Rng(ChaCha8Rng);
impl Rng {
    fn normal(&mut self) -> f64 {
        StandardNormal.sample(&mut self.0)
    }
    fn vec(&mut self) -> V64 {
        V64::new(self.normal(), self.normal(), self.normal())
    }
}

/// Which sensors run in a phase (the gyro always does).
#[derive(Clone, Copy, Debug)]
struct Phase {
    name: &'static str,
    seconds: u32,
    tracker: bool,
    vectors: bool,
}

/// Worst disagreement over one phase, sampled after every 1 Hz measurement epoch.
#[derive(Debug, Default)]
struct Agreement {
    /// max √(dᵀ P⁻¹ d), d = attitude difference, P = the reference's attitude block.
    attitude_sigma: f64,
    /// max |d|, rad.
    attitude_rad: f64,
    /// max √(eᵀ P_b⁻¹ e) of the bias difference.
    bias_sigma: f64,
    /// max |e|, rad/s.
    bias_rad_s: f64,
    /// max over the 6 diagonal entries of |P_f − P_r| / P_r.
    cov_diag_rel: f64,
    /// Smallest attitude σ (√ of the smallest eigenvalue of the attitude block), rad.
    min_attitude_sigma_rad: f64,
    /// Updates offered, and how many the two filters decided differently.
    offered: u32,
    decisions_differ: u32,
}

/// Truth simulated in f64 (rate profile, gyro with Farrenkopf ARW/RRW and bias, tracker
/// σ 10″/axis at 1 Hz, Sun σ 0.2° and field σ 1° at 1 Hz, Shuster's vector noise model),
/// both filters driven at 10 Hz; returns one `Agreement` per phase.
fn fly(seed: u64, c: MekfConfig, phases: &[Phase]) -> Vec<Agreement> {
    let mut rng = Rng(ChaCha8Rng::seed_from_u64(seed));
    let dt = 0.1_f32;
    let dt64 = f64::from(dt);
    let (sv, su) = (f64::from(c.gyro_arw_rad_sqrt_s), f64::from(c.gyro_rrw_rad_s_sqrt_s));
    let axis = rng.vec().normalize();
    let mut q_true = qexp(&(axis * 2.0));
    let mut bias = rng.vec() * f64::from(c.initial_bias_sigma_rad_s);
    let q0 = f32q(&(q_true * qexp(&(rng.vec() * f64::from(c.initial_attitude_sigma_rad)))));
    let mut flight = Mekf::new(c, q0, Vec3::zeros()).expect("config");
    let mut reference = MekfRef::new(ref_cfg(&c), &f64q(&q0), V64::zeros(), flight.covariance().map(f64::from));
    let st = (10.0_f64 / 3600.0).to_radians();
    let r_tracker = Matrix3::<f32>::identity() * (st * st) as f32;
    let sun = V64::new(0.6, 0.8, 0.0);
    let mag = V64::new(0.0, 0.3, -0.95).normalize();
    let vec_sigma = [0.2_f64.to_radians(), 1.0_f64.to_radians()];
    let mut out = Vec::new();
    let mut k = 0_u32;
    for ph in phases {
        let mut a = Agreement { min_attitude_sigma_rad: f64::INFINITY, ..Default::default() };
        for _ in 0..ph.seconds * 10 {
            let time = f64::from(k) * dt64;
            k += 1;
            let w = V64::new(0.01 * (0.01 * time).sin(), 0.005, -0.008 * (0.02 * time).cos());
            let b_next = bias + rng.vec() * (su * dt64.sqrt());
            let gyro = f32v(&(w + 0.5 * (bias + b_next) + rng.vec() * (sv / dt64.sqrt())));
            q_true *= qexp(&(w * dt64));
            bias = b_next;
            flight.propagate(&gyro, dt).expect("propagate");
            reference.propagate(&f64v(&gyro), dt64);
            if !k.is_multiple_of(10) {
                continue;
            }
            if ph.tracker {
                let qm = f32q(&(q_true * qexp(&(rng.vec() * st))));
                let f = flight.update_attitude(&qm, &r_tracker).is_ok();
                let r = reference.update_attitude(&f64q(&qm), &r_tracker.map(f64::from)).is_ok();
                a.offered += 1;
                a.decisions_differ += u32::from(f != r);
            }
            if ph.vectors {
                for (r, s) in [sun, mag].iter().zip(vec_sigma) {
                    let b = q_true.conjugate() * Q64::from_imag(*r) * q_true;
                    let b = b.imag();
                    let e = rng.vec() * s;
                    let bm = f32v(&(b + (e - b * b.dot(&e))).normalize());
                    let rr = f32v(r);
                    let f = flight.update_vector(&bm, &rr, s as f32).is_ok();
                    let g = reference.update_vector(&f64v(&bm), &f64v(&rr), f64::from(s as f32)).is_ok();
                    a.offered += 1;
                    a.decisions_differ += u32::from(f != g);
                }
            }
            let p = *reference.covariance();
            let d = err_vec(&reference.attitude(), &f64q(&flight.attitude()));
            let e = f64v(&flight.bias_rad_s()) - reference.bias_rad_s();
            let pa = p.fixed_view::<3, 3>(0, 0).into_owned();
            let pb = p.fixed_view::<3, 3>(3, 3).into_owned();
            a.attitude_sigma = a.attitude_sigma.max(d.dot(&(pa.try_inverse().expect("P_att") * d)).sqrt());
            a.attitude_rad = a.attitude_rad.max(d.norm());
            a.bias_sigma = a.bias_sigma.max(e.dot(&(pb.try_inverse().expect("P_bias") * e)).sqrt());
            a.bias_rad_s = a.bias_rad_s.max(e.norm());
            let pf = flight.covariance().map(f64::from);
            for i in 0..6 {
                a.cov_diag_rel = a.cov_diag_rel.max((pf[(i, i)] - p[(i, i)]).abs() / p[(i, i)]);
            }
            a.min_attitude_sigma_rad = a.min_attitude_sigma_rad.min(pa.symmetric_eigenvalues().min().sqrt());
        }
        println!("{} ({} s, tracker {}, vectors {}): {a:?}", ph.name, ph.seconds, ph.tracker, ph.vectors);
        out.push(a);
    }
    out
}

/// Tolerances, from what f32 allows (ε = 2⁻²⁴ ≈ 6e-8):
///
/// - Attitude. Each f32 propagation rounds the quaternion (4 components of a product and a
///   normalisation): ≈ 2ε ≈ 1.2e-7 rad of rotation per step, random. Over the 10 steps
///   between 1 Hz updates that is √10·2ε ≈ 3.8e-7 rad; an update with gain K removes the
///   fraction K of any difference, so in the tracker phases (σ_tracker 48 µrad, attitude
///   σ ≈ 33 µrad, K ≈ 0.45) the difference settles at ≈ 3.8e-7/√(2K − K²) ≈ 0.45 µrad
///   rms: ≤ 2 µrad (4.4 rms) and ≈ 0.014 σ rms. The bias is estimated from those same
///   attitude residuals, so its difference is of the same order in its own σ. In an
///   outage the bias difference integrates into the attitude while σ grows the same way,
///   so the attitude difference in σ units tends to the bias's. Both ≤ 0.1 σ (≈ 7× the
///   rms above): the filters agree to a small fraction of their own uncertainty.
/// - Covariance diagonal. Without updates each propagation adds Q to P in f32: the bias
///   block gains σu² dt ≈ 1e-4 of itself per step, each sum rounded by ≤ ε/2 relative, and
///   Φ P Φᵀ adds a few more roundings: over the longest gap (6000 steps) the relative
///   error stays below 6000 · 2ε ≈ 7e-4; updates only shrink it (they forget P⁻).
/// - Gating: both filters use the same gates; with no outlier in the stream no
///   measurement may be accepted by one and rejected by the other.
#[test]
fn flight_mekf_agrees_with_the_f64_reference_on_the_same_measurements() {
    let phases = [
        Phase { name: "all sensors", seconds: 300, tracker: true, vectors: true },
        Phase { name: "tracker out: Sun + field", seconds: 600, tracker: false, vectors: true },
        Phase { name: "tracker out: gyro only", seconds: 600, tracker: false, vectors: false },
        Phase { name: "tracker back", seconds: 300, tracker: true, vectors: false },
    ];
    let res = fly(11, cfg(), &phases);
    for (ph, a) in phases.iter().zip(&res) {
        assert_eq!(a.decisions_differ, 0, "{}: gate decisions differ", ph.name);
        assert_eq!(a.offered, ph.seconds * (u32::from(ph.tracker) + 2 * u32::from(ph.vectors)), "{}", ph.name);
        assert!(a.attitude_sigma < 0.1, "{}: attitude difference {} σ", ph.name, a.attitude_sigma);
        if ph.tracker {
            assert!(a.attitude_rad < 2e-6, "{}: attitude difference {} rad", ph.name, a.attitude_rad);
        }
        assert!(a.bias_sigma < 0.1, "{}: bias difference {} σ", ph.name, a.bias_sigma);
        assert!(a.cov_diag_rel < 6000.0 * 2.0 * EPS32, "{}: covariance diagonal off by {}", ph.name, a.cov_diag_rel);
    }
}

/// The flight filter's discrete process noise (M&C eq 6.93, closed form) against van
/// Loan's exact discretisation: read back as the covariance after one step from a
/// negligible initial covariance (σ 1e-20: P₀ ~ 1e-40, below every Q entry by 20 orders).
fn flight_q(omega: &Vec3, dt: f32) -> Matrix6<f64> {
    let mut c = cfg();
    c.initial_attitude_sigma_rad = 1e-20;
    c.initial_bias_sigma_rad_s = 1e-20;
    let mut f = Mekf::new(c, Quat::identity(), Vec3::zeros()).expect("config");
    f.propagate(omega, dt).expect("propagate");
    f.covariance().map(f64::from)
}

#[test]
fn flight_process_noise_is_van_loans_to_the_order_eq_6_93_neglects() {
    let c = cfg();
    let (sv, su) = (f64::from(c.gyro_arw_rad_sqrt_s), f64::from(c.gyro_rrw_rad_s_sqrt_s));
    // ω = 0: eq 6.93 is exact; the flight's f32 entries within a few roundings.
    let dt = 0.1_f32;
    let qf = flight_q(&Vec3::zeros(), dt);
    let (_, qv) = discretise(&V64::zeros(), f64::from(dt), sv, su);
    for i in 0..6 {
        for j in 0..6 {
            let (x, y) = (qf[(i, j)], qv[(i, j)]);
            let tol = 8.0 * EPS32 * y.abs() + 1e-45;
            assert!((x - y).abs() <= tol, "ω = 0, Q[{i},{j}]: flight {x:e}, van Loan {y:e}");
        }
    }
    // ω ≠ 0: van Loan's Q₁₂ = σu²(−dt²/2 I + [ω×] dt³/6 − …); eq 6.93 keeps −σu² dt²/2 I.
    // The difference must be the first neglected term, O(dt³) against Q₁₁ = O(dt), i.e.
    // O(dt²) relative, and shrink 8× per halving of dt.
    let w = Vec3::new(0.02, -0.01, 0.03);
    let mut prev = None;
    for dt in [0.4_f32, 0.2, 0.1] {
        let d64 = f64::from(dt);
        let qf = flight_q(&w, dt);
        let (_, qv) = discretise(&f64v(&w), d64, sv, su);
        let d12 = (qf - qv).fixed_view::<3, 3>(0, 3).into_owned();
        let first = -cross_matrix(&f64v(&w)) * (su * su * d64.powi(3) / 6.0);
        let leading = su * su * d64 * d64 / 2.0;
        let next = su * su * f64v(&w).norm_squared() * d64.powi(4) / 24.0;
        assert!(
            (d12 - first).abs().max() <= 2.0 * next + 8.0 * EPS32 * leading,
            "dt {dt}: Q12 flight − van Loan {d12:e} vs first neglected term {first:e}"
        );
        let diag_rel = (0..6).map(|i| ((qf[(i, i)] - qv[(i, i)]) / qv[(i, i)]).abs()).fold(0.0, f64::max);
        assert!(diag_rel < 8.0 * EPS32 + (f64::from(w.norm()) * d64).powi(2), "dt {dt}: diagonal off by {diag_rel}");
        let size = d12.abs().max();
        if let Some(p) = prev {
            let ratio: f64 = p / size;
            assert!((ratio - 8.0).abs() < 0.5, "dt halved: Q12 difference shrank {ratio}× (want 8)");
        }
        prev = Some(size);
        println!("dt {dt}: |Q12 flight − van Loan| {size:e} (= σu² |[ω×]| dt³/6), Q11 {:e}", qv[(0, 0)]);
    }
}
