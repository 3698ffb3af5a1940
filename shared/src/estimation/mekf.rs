//! Multiplicative extended Kalman filter (MEKF) for attitude and gyro bias.
//!
//! Lefferts, Markley & Shuster 1982; Markley & Crassidis, *Fundamentals of Spacecraft
//! Attitude Determination and Control* (2014), §6.2.4 (the "MEKF") — full references in
//! docs/references.md.
//!
//! State: attitude `q` (body → reference, scalar-last Hamilton, docs/conventions.md) and
//! gyro bias `b` (rad/s, body). The filter's error state is `δx = [δθ; δb]` with the
//! attitude error in **body** axes, `q_true = q ⊗ δq(δθ)`, and covariance `P` (6×6, rad²
//! and (rad/s)², f32).
//!
//! - Propagation with the gyro `ω_m` over `dt` (rate held constant): `ω = ω_m − b`,
//!   `q ← q ⊗ exp(½ ω dt)`; `P ← Φ P Φᵀ + Q` with `Φ = [[Θ, Ψ], [0, I]]`,
//!   `Θ = exp(−[ω×] dt)`, `Ψ = −∫₀^dt exp(−[ω×] s) ds` (closed forms below, series near
//!   ω = 0), and the Farrenkopf gyro model's discrete noise (M&C eq 6.93):
//!   `Q₁₁ = (σv² dt + σu² dt³/3) I`, `Q₁₂ = −σu² dt²/2 I`, `Q₂₂ = σu² dt I`
//!   (σv angle random walk in rad/√s, σu rate random walk in rad/s^1.5).
//! - Star-tracker update with a measured quaternion `q_m`: innovation
//!   `y = 2 vec(q* ⊗ q_m)` (sign so the scalar is ≥ 0), `H = [I 0]`, `R` 3×3 in body axes
//!   (the tracker's cross- and about-boresight variances rotated by the caller).
//! - Unit-vector update (Sun, magnetic field) with body measurement `b_m` and reference
//!   `r`: predicted `b̂ = q* ⊗ r ⊗ q`, `y = b_m − b̂`, `H = [[b̂×] 0]`, `R = σ² I`
//!   (Shuster's QUEST measurement model), one vector at a time (sequential updates).
//! - Every update: chi-square gate on the normalised innovation `yᵀ S⁻¹ y` (rejected
//!   measurements change nothing and are counted), Joseph form
//!   `P = (I − K H) P (I − K H)ᵀ + K R Kᵀ`, symmetrised; the error is folded into `q`
//!   (`q ← q ⊗ [δθ/2, 1]`, normalised) and `b` and reset to zero.
//!
//! No heap, no panics, no loops but fixed-size matrix products; a rejected call (non-finite
//! input, bad time step, singular innovation, non-finite result) returns a typed error
//! and leaves the state and covariance exactly as they were.

use crate::math::f32m::{sin_cos, sqrt};
use crate::math::{Quat, Vec3, norm, quat_normalized, rotate_ref_to_body};
use nalgebra::{Cholesky, Matrix3, SMatrix, SVector};

type Mat6 = SMatrix<f32, 6, 6>;
type Mat63 = SMatrix<f32, 6, 3>;

/// Chi-square 99.9 % quantile with 3 degrees of freedom: gate of the tracker update.
pub const CHI2_3DOF_999: f32 = 16.266;
/// Chi-square 99.9 % quantile with 2 degrees of freedom: gate of a unit-vector update (the
/// residual of two unit vectors has two components to first order).
pub const CHI2_2DOF_999: f32 = 13.816;
/// Smallest accepted pivot² of the scaled innovation covariance (as `kalman`).
const MIN_SCALED_PIVOT_SQ: f32 = 1e-6;

/// Why a call changed nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MekfError {
    /// A configuration value is not finite or not positive where it must be.
    BadConfig,
    /// A measurement, reference or rate is NaN/inf or not a unit vector where one is needed.
    NonFiniteInput,
    /// `dt` is not in (0, `max_dt_s`].
    BadTimeStep,
    /// The innovation failed the chi-square gate; `nis` is its normalised square.
    Rejected { nis: f32 },
    /// `S = H P Hᵀ + R` is not numerically positive definite.
    SingularInnovation,
    /// The result was not finite (e.g. overflow); discarded.
    NonFiniteResult,
}

/// Noise model and limits, parsed once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MekfConfig {
    /// Gyro angle random walk σv, rad/√s.
    pub gyro_arw_rad_sqrt_s: f32,
    /// Gyro rate (bias) random walk σu, rad/s^1.5.
    pub gyro_rrw_rad_s_sqrt_s: f32,
    /// Initial 1σ attitude uncertainty per axis, rad.
    pub initial_attitude_sigma_rad: f32,
    /// Initial 1σ bias uncertainty per axis, rad/s.
    pub initial_bias_sigma_rad_s: f32,
    /// Longest accepted propagation step, s (longer gaps: propagate in pieces).
    pub max_dt_s: f32,
    /// Gate of the tracker update (NIS, 3 dof).
    pub gate_attitude: f32,
    /// Gate of a unit-vector update (NIS, 2 dof).
    pub gate_vector: f32,
}

impl MekfConfig {
    fn valid(&self) -> bool {
        let pos = |x: f32| x.is_finite() && x > 0.0;
        let nonneg = |x: f32| x.is_finite() && x >= 0.0;
        nonneg(self.gyro_arw_rad_sqrt_s)
            && nonneg(self.gyro_rrw_rad_s_sqrt_s)
            && pos(self.initial_attitude_sigma_rad)
            && pos(self.initial_bias_sigma_rad_s)
            && pos(self.max_dt_s)
            && pos(self.gate_attitude)
            && pos(self.gate_vector)
    }

    fn initial_covariance(&self) -> Mat6 {
        let a = self.initial_attitude_sigma_rad * self.initial_attitude_sigma_rad;
        let b = self.initial_bias_sigma_rad_s * self.initial_bias_sigma_rad_s;
        Mat6::from_diagonal(&SVector::<f32, 6>::new(a, a, a, b, b, b))
    }
}

/// Estimator health, for telemetry and the mode manager.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MekfHealth {
    /// Trace of the attitude block of `P`, rad².
    pub attitude_variance_rad2: f32,
    /// Trace of the bias block of `P`, (rad/s)².
    pub bias_variance_rad2_s2: f32,
    /// Measurements accepted / rejected by the gate since start.
    pub accepted: u32,
    pub rejected: u32,
    /// Time since the last accepted update, s (saturates).
    pub since_update_s: f32,
    /// NIS of the last measurement offered (accepted or not).
    pub last_nis: f32,
}

/// The filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mekf {
    cfg: MekfConfig,
    q: Quat,
    bias: Vec3,
    p: Mat6,
    health: MekfHealth,
}

fn finite<const R: usize, const C: usize>(m: &SMatrix<f32, R, C>) -> bool {
    m.iter().all(|v| v.is_finite())
}

fn skew(v: &Vec3) -> Matrix3<f32> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

fn sym(m: &Mat6) -> Mat6 {
    (m + m.transpose()) * 0.5
}

/// `Θ = exp(−[ω×] dt)` and `Ψ = −∫₀^dt exp(−[ω×] s) ds` for a constant rate (M&C §6.2.4):
/// `Θ = I − [ω×] sin(w dt)/w + [ω×]² (1 − cos w dt)/w²`,
/// `Ψ = −I dt + [ω×] (1 − cos w dt)/w² − [ω×]² (w dt − sin w dt)/w³`,
/// with the Taylor series of the three coefficients when `w dt` is small (their closed
/// forms lose every digit in f32 there).
fn transition(omega: &Vec3, dt: f32) -> (Matrix3<f32>, Matrix3<f32>) {
    let w = norm(omega);
    let x = w * dt;
    let (c1, c2, c3) = if x < 0.02 {
        let x2 = x * x;
        (
            dt * (1.0 - x2 / 6.0),                  // sin(x)/w
            0.5 * dt * dt * (1.0 - x2 / 12.0),      // (1 − cos x)/w²
            dt * dt * dt / 6.0 * (1.0 - x2 / 20.0), // (x − sin x)/w³
        )
    } else {
        let (s, c) = sin_cos(x);
        (s / w, (1.0 - c) / (w * w), (x - s) / (w * w * w))
    };
    let k = skew(omega);
    let k2 = k * k;
    let i = Matrix3::identity();
    (i - k * c1 + k2 * c2, -i * dt + k * c2 - k2 * c3)
}

impl Mekf {
    /// A placeholder that never ran (zero attitude, zero covariance), for storage that
    /// holds no running filter yet ([`super::determination`]'s history before a start):
    /// not a filter to read or update.
    pub(crate) const fn placeholder(cfg: MekfConfig) -> Self {
        let zero = MekfHealth {
            attitude_variance_rad2: 0.0,
            bias_variance_rad2_s2: 0.0,
            accepted: 0,
            rejected: 0,
            since_update_s: 0.0,
            last_nis: 0.0,
        };
        Self {
            cfg,
            q: Quat::new(0.0, 0.0, 0.0, 0.0),
            bias: Vec3::new(0.0, 0.0, 0.0),
            p: Mat6::from_array_storage(nalgebra::ArrayStorage([[0.0; 6]; 6])),
            health: zero,
        }
    }

    /// A filter at attitude `q0` and bias `bias0` with the configured initial covariance.
    pub fn new(cfg: MekfConfig, q0: Quat, bias0: Vec3) -> Result<Self, MekfError> {
        if !cfg.valid() {
            return Err(MekfError::BadConfig);
        }
        let q = quat_normalized(&q0).ok_or(MekfError::NonFiniteInput)?;
        if !finite(&bias0) {
            return Err(MekfError::NonFiniteInput);
        }
        let p = cfg.initial_covariance();
        Ok(Self { cfg, q, bias: bias0, p, health: Self::health_of(&p, MekfHealth::default()) })
    }

    /// Restart at `q0`, `bias0` with the initial covariance (e.g. from a TRIAD/QUEST fix);
    /// counters are kept.
    pub fn reset(&mut self, q0: Quat, bias0: Vec3) -> Result<(), MekfError> {
        let q = quat_normalized(&q0).ok_or(MekfError::NonFiniteInput)?;
        if !finite(&bias0) {
            return Err(MekfError::NonFiniteInput);
        }
        self.q = q;
        self.bias = bias0;
        self.p = self.cfg.initial_covariance();
        self.health.since_update_s = 0.0;
        self.health = Self::health_of(&self.p, self.health);
        Ok(())
    }

    pub fn attitude(&self) -> Quat {
        self.q
    }

    pub fn bias_rad_s(&self) -> Vec3 {
        self.bias
    }

    /// Error-state covariance `[δθ; δb]`, rad² / (rad/s)².
    pub fn covariance(&self) -> &Mat6 {
        &self.p
    }

    pub fn health(&self) -> MekfHealth {
        self.health
    }

    pub fn config(&self) -> &MekfConfig {
        &self.cfg
    }

    /// Adds `var_rad2` to each attitude variance: white attitude noise the propagation
    /// model does not carry (an output prediction that holds one noisy rate sample over
    /// longer than the sample's own interval). The state is unchanged.
    pub fn add_attitude_variance(&mut self, var_rad2: f32) -> Result<(), MekfError> {
        if !(var_rad2.is_finite() && var_rad2 >= 0.0) {
            return Err(MekfError::NonFiniteInput);
        }
        for i in 0..3 {
            if let Some(v) = self.p.get_mut((i, i)) {
                *v += var_rad2;
            }
        }
        self.health = Self::health_of(&self.p, self.health);
        Ok(())
    }

    /// The body rate estimate for a gyro reading: `ω_m − b`.
    pub fn rate_rad_s(&self, gyro_rad_s: &Vec3) -> Vec3 {
        gyro_rad_s - self.bias
    }

    fn health_of(p: &Mat6, mut h: MekfHealth) -> MekfHealth {
        h.attitude_variance_rad2 = p.fixed_view::<3, 3>(0, 0).trace();
        h.bias_variance_rad2_s2 = p.fixed_view::<3, 3>(3, 3).trace();
        h
    }

    /// Time update over `dt_s` with the gyro reading `gyro_rad_s` (held over the step).
    pub fn propagate(&mut self, gyro_rad_s: &Vec3, dt_s: f32) -> Result<(), MekfError> {
        if !finite(gyro_rad_s) {
            return Err(MekfError::NonFiniteInput);
        }
        if !(dt_s.is_finite() && dt_s > 0.0 && dt_s <= self.cfg.max_dt_s) {
            return Err(MekfError::BadTimeStep);
        }
        let omega = gyro_rad_s - self.bias;
        let w = norm(&omega);
        let (s, c) = sin_cos(0.5 * w * dt_s);
        // q ⊗ [ω̂ sin(w dt/2), cos(w dt/2)]; ω̂ sin(·) → ω dt/2 as w → 0.
        let axis = if w * dt_s < 1e-6 { omega * (0.5 * dt_s) } else { omega * (s / w) };
        let dq = Quat::new(c, axis.x, axis.y, axis.z);
        let q = quat_normalized(&(self.q * dq)).ok_or(MekfError::NonFiniteResult)?;

        let (theta, psi) = transition(&omega, dt_s);
        let mut phi = Mat6::identity();
        phi.fixed_view_mut::<3, 3>(0, 0).copy_from(&theta);
        phi.fixed_view_mut::<3, 3>(0, 3).copy_from(&psi);
        // `x * x`, not `powi`: `f32::powi` is not in `core` (the no_std target build).
        let (sv, su) = (self.cfg.gyro_arw_rad_sqrt_s, self.cfg.gyro_rrw_rad_s_sqrt_s);
        let (sv2, su2) = (sv * sv, su * su);
        let q11 = sv2 * dt_s + su2 * dt_s * dt_s * dt_s / 3.0;
        let q12 = -su2 * dt_s * dt_s / 2.0;
        let q22 = su2 * dt_s;
        let i3 = Matrix3::<f32>::identity();
        let mut qd = Mat6::zeros();
        qd.fixed_view_mut::<3, 3>(0, 0).copy_from(&(i3 * q11));
        qd.fixed_view_mut::<3, 3>(0, 3).copy_from(&(i3 * q12));
        qd.fixed_view_mut::<3, 3>(3, 0).copy_from(&(i3 * q12));
        qd.fixed_view_mut::<3, 3>(3, 3).copy_from(&(i3 * q22));
        let p = sym(&(phi * self.p * phi.transpose() + qd));
        if !finite(&p) {
            return Err(MekfError::NonFiniteResult);
        }
        self.q = q;
        self.p = p;
        self.health.since_update_s = (self.health.since_update_s + dt_s).min(1e9);
        self.health = Self::health_of(&self.p, self.health);
        Ok(())
    }

    /// Star-tracker update with the measured attitude `q_meas` (body → reference) and its
    /// noise covariance `r_rad2` in body axes (3×3, rad²). Returns the NIS.
    pub fn update_attitude(&mut self, q_meas: &Quat, r_rad2: &Matrix3<f32>) -> Result<f32, MekfError> {
        let qm = quat_normalized(q_meas).ok_or(MekfError::NonFiniteInput)?;
        if !finite(r_rad2) {
            return Err(MekfError::NonFiniteInput);
        }
        let mut e = self.q.conjugate() * qm;
        if e.w < 0.0 {
            e = -e;
        }
        let y = e.imag() * 2.0;
        let mut h = SMatrix::<f32, 3, 6>::zeros();
        h.fixed_view_mut::<3, 3>(0, 0).copy_from(&Matrix3::identity());
        self.update(&y, &h, r_rad2, self.cfg.gate_attitude)
    }

    /// Unit-vector update: `b_meas` measured in body axes, `r_ref` its direction in the
    /// reference frame (both normalised here; rejected if either is near zero), `sigma_rad`
    /// the measurement's 1σ angular noise. Returns the NIS.
    pub fn update_vector(&mut self, b_meas: &Vec3, r_ref: &Vec3, sigma_rad: f32) -> Result<f32, MekfError> {
        let unit = |v: &Vec3| {
            let n = norm(v);
            (n.is_finite() && n > 1e-6).then(|| v / n)
        };
        let (Some(bm), Some(r)) = (unit(b_meas), unit(r_ref)) else { return Err(MekfError::NonFiniteInput) };
        if !(sigma_rad.is_finite() && sigma_rad > 0.0) {
            return Err(MekfError::NonFiniteInput);
        }
        let bhat = rotate_ref_to_body(&self.q, &r);
        let y = bm - bhat;
        let mut h = SMatrix::<f32, 3, 6>::zeros();
        h.fixed_view_mut::<3, 3>(0, 0).copy_from(&skew(&bhat));
        let r = Matrix3::identity() * (sigma_rad * sigma_rad);
        self.update(&y, &h, &r, self.cfg.gate_vector)
    }

    fn update(&mut self, y: &Vec3, h: &SMatrix<f32, 3, 6>, r: &Matrix3<f32>, gate: f32) -> Result<f32, MekfError> {
        let ph: Mat63 = self.p * h.transpose();
        let s = h * ph + r;
        let s = (s + s.transpose()) * 0.5;
        let dg = s.diagonal();
        if !dg.iter().all(|&d| d.is_finite() && d > 0.0) {
            return Err(MekfError::SingularInnovation);
        }
        let dinv = dg.map(|d| 1.0 / sqrt(d));
        let ds = Matrix3::from_diagonal(&dinv);
        let chol = Cholesky::new(ds * s * ds).ok_or(MekfError::SingularInnovation)?;
        if !chol.l_dirty().diagonal().iter().all(|&l| l * l >= MIN_SCALED_PIVOT_SQ) {
            return Err(MekfError::SingularInnovation);
        }
        let nis = y.dot(&(ds * chol.solve(&(ds * y))));
        self.health.last_nis = nis;
        if !nis.is_finite() {
            return Err(MekfError::NonFiniteResult);
        }
        if nis > gate {
            self.health.rejected = self.health.rejected.saturating_add(1);
            return Err(MekfError::Rejected { nis });
        }
        // Kᵀ = S⁻¹ H P.
        let k: Mat63 = (ds * chol.solve(&(ds * ph.transpose()))).transpose();
        let dx = k * y;
        let ikh = Mat6::identity() - k * h;
        let p = sym(&(ikh * self.p * ikh.transpose() + k * r * k.transpose()));
        let dth = dx.fixed_rows::<3>(0).into_owned();
        let db = dx.fixed_rows::<3>(3).into_owned();
        let q = quat_normalized(&(self.q * Quat::new(1.0, 0.5 * dth.x, 0.5 * dth.y, 0.5 * dth.z)))
            .ok_or(MekfError::NonFiniteResult)?;
        let bias = self.bias + db;
        if !(finite(&p) && finite(&bias)) {
            return Err(MekfError::NonFiniteResult);
        }
        self.q = q;
        self.bias = bias;
        self.p = p;
        self.health.accepted = self.health.accepted.saturating_add(1);
        self.health.since_update_s = 0.0;
        self.health = Self::health_of(&self.p, self.health);
        Ok(nis)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transition_series_meets_closed_form() {
        // At w dt = 0.02 both branches agree to f32 rounding.
        let omega = Vec3::new(0.1, -0.05, 0.2);
        let dt = 0.02 / norm(&omega);
        let (t1, p1) = transition(&omega, dt);
        let (t2, p2) = transition(&omega, dt * 1.0001);
        assert!((t1 - t2).norm() < 1e-4 && (p1 - p2).norm() < 1e-3 * dt);
    }
}
