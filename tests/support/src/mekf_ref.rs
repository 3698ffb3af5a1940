//! Reference multiplicative EKF (attitude + gyro bias) in f64, written from the literature
//! independently of the flight filter (`acs_flight::estimation::mekf`), to check it: a
//! test oracle (sim-host/core/tests/mekf_reference.rs), kept in the test-support crate so
//! that it is not compiled into the product.
//!
//! Crassidis & Junkins, *Optimal Estimation of Dynamic Systems* (2nd ed. 2012), Table 7.1
//! ("Extended Kalman filter for attitude estimation"), and Markley & Crassidis,
//! *Fundamentals of Spacecraft Attitude Determination and Control* (2014), §6.2.4 and
//! Table 6.3. The formulation here is C&J's, on purpose different from the flight code's:
//!
//! - the quaternion as a 4-vector `q = [ϱ; q₄]` with the matrices `Ξ(q)`, `Ψ(q)` and the
//!   attitude matrix `A(q) = Ξᵀ(q) Ψ(q)`;
//! - propagation `q⁻ₖ₊₁ = Ω̄(ω̂) q⁺ₖ` with C&J's discrete `Ω̄` (rate held over the step);
//! - the error covariance with `Φ` and `Q_d` from van Loan's matrix exponential
//!   (van Loan 1978) of the continuous model `F = [[−[ω̂×], −I], [0, 0]]`,
//!   `G = [[−I, 0], [0, I]]`, `Q = diag(σv² I, σu² I)` (C&J eq 7.39–7.40; `exp` by
//!   nalgebra's scaling-and-squaring Padé), not the closed form of M&C eq 6.93;
//! - gain `K = P Hᵀ (H P Hᵀ + R)⁻¹` and the standard update `P⁺ = (I − K H) P⁻`
//!   (C&J Table 7.1; f64 needs no Joseph form here), `q⁺ = q⁻ + ½ Ξ(q⁻) δα`, normalised.
//!
//! ## Conventions (C&J/Shuster → this project)
//!
//! C&J use Shuster's (JPL) convention: `q = [ϱ; q₄]` scalar last, `A(q)` maps reference
//! vectors to body, and `q ⊗ q'` is defined so that `A(q ⊗ q') = A(q) A(q')`. For the same
//! four numbers, `A(q)` is the transpose of the Hamilton rotation matrix `R(q)`
//! (docs/conventions.md: `R(q)` maps body → reference). Hence a Hamilton body → reference
//! quaternion stored `[x, y, z, w]` *is* C&J's quaternion of the same attitude, number for
//! number: [`MekfRef::new`] takes `Quaternion::coords` as `[ϱ; q₄]` unchanged. Products
//! swap order (`q ⊗_S p = p ⊗_H q`). C&J's error `q = δq ⊗_S q̂` is `q = q̂ ⊗_H δq`, i.e.
//! the error `δα` is in body axes, as the flight filter's `δθ`: the two error states and
//! covariances are the same quantities and are compared directly.
//!
//! The tracker update (not in C&J Table 7.1) follows M&C §6.2.4: the measured quaternion
//! `q_m` gives `y = 2 Ξᵀ(q̂) q_m` (the vector part of `q_m ⊗_S q̂⁻¹`, sign chosen so that
//! `q̂ᵀ q_m ≥ 0`), `H = [I 0]`. Unit vectors: `h = A(q̂) r`, `H = [[h×] 0]`, `R = σ² I`
//! (Shuster's measurement model). Every update is gated on `yᵀ S⁻¹ y` like the flight
//! filter (the same gate, so both reject the same outliers).

// Host reference in f64: nalgebra's norms are fine here.
#![allow(clippy::disallowed_methods)]

use nalgebra::{Matrix3, Matrix4, Matrix4x3, Matrix6, Quaternion, SMatrix, Vector3, Vector4, Vector6};

type Mat12 = SMatrix<f64, 12, 12>;
type Mat36 = SMatrix<f64, 3, 6>;

/// `[v×]`, so that `[v×] u = v × u`.
pub fn cross_matrix(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// C&J's `Ξ(q) = [q₄ I + [ϱ×]; −ϱᵀ]` (4×3).
pub fn xi(q: &Vector4<f64>) -> Matrix4x3<f64> {
    let rho = q.xyz();
    let mut m = Matrix4x3::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&(Matrix3::identity() * q.w + cross_matrix(&rho)));
    m.fixed_view_mut::<1, 3>(3, 0).copy_from(&(-rho.transpose()));
    m
}

/// C&J's `Ψ(q) = [q₄ I − [ϱ×]; −ϱᵀ]` (4×3).
pub fn psi(q: &Vector4<f64>) -> Matrix4x3<f64> {
    let rho = q.xyz();
    let mut m = Matrix4x3::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&(Matrix3::identity() * q.w - cross_matrix(&rho)));
    m.fixed_view_mut::<1, 3>(3, 0).copy_from(&(-rho.transpose()));
    m
}

/// Attitude matrix `A(q) = Ξᵀ(q) Ψ(q)`: reference → body.
pub fn attitude_matrix(q: &Vector4<f64>) -> Matrix3<f64> {
    xi(q).transpose() * psi(q)
}

/// C&J's discrete quaternion transition for a rate `ω` held over `dt`:
/// `Ω̄ = [[cos(½|ω|dt) I − [ψ×], ψ], [−ψᵀ, cos(½|ω|dt)]]`, `ψ = sin(½|ω|dt) ω/|ω|`.
pub fn omega_bar(omega: &Vector3<f64>, dt: f64) -> Matrix4<f64> {
    let n = omega.norm();
    let half = 0.5 * n * dt;
    // sin(½|ω|dt)/|ω| → dt/2 as |ω| → 0.
    let s = if half > 1e-8 { half.sin() / n } else { 0.5 * dt * (1.0 - half * half / 6.0) };
    let p = omega * s;
    let c = half.cos();
    let mut m = Matrix4::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&(Matrix3::identity() * c - cross_matrix(&p)));
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&p);
    m.fixed_view_mut::<1, 3>(3, 0).copy_from(&(-p.transpose()));
    m[(3, 3)] = c;
    m
}

/// Continuous error dynamics `F = [[−[ω̂×], −I], [0, 0]]` (C&J eq 7.39).
pub fn error_dynamics(omega: &Vector3<f64>) -> Matrix6<f64> {
    let mut f = Matrix6::zeros();
    f.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-cross_matrix(omega)));
    f.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-Matrix3::identity()));
    f
}

/// Van Loan (1978): for `ẋ = F x + w`, `E[w wᵀ] = W δ(t − τ)`, the exponential of
/// `[[−F, W], [0, Fᵀ]] dt` is `[[·, Φ⁻¹ Q_d], [0, Φᵀ]]`: returns `(Φ, Q_d)` with
/// `Φ = exp(F dt)` and `Q_d = ∫₀^dt exp(F s) W exp(F s)ᵀ ds`.
pub fn van_loan(f: &Matrix6<f64>, w: &Matrix6<f64>, dt: f64) -> (Matrix6<f64>, Matrix6<f64>) {
    let mut a = Mat12::zeros();
    a.fixed_view_mut::<6, 6>(0, 0).copy_from(&(-f * dt));
    a.fixed_view_mut::<6, 6>(0, 6).copy_from(&(w * dt));
    a.fixed_view_mut::<6, 6>(6, 6).copy_from(&(f.transpose() * dt));
    let b = a.exp();
    let phi: Matrix6<f64> = b.fixed_view::<6, 6>(6, 6).transpose();
    let qd = phi * b.fixed_view::<6, 6>(0, 6);
    (phi, qd)
}

/// `(Φ, Q_d)` of the gyro error model over `dt` at rate `ω̂`: `G Q Gᵀ = diag(σv² I, σu² I)`.
/// `Q_d` is linear in the two intensities; each is discretised with unit intensity and
/// scaled afterwards, so that `σu² ≪ σv²` loses no relative accuracy in the exponential.
pub fn discretise(omega: &Vector3<f64>, dt: f64, arw: f64, rrw: f64) -> (Matrix6<f64>, Matrix6<f64>) {
    let f = error_dynamics(omega);
    let unit = |block: usize| {
        let mut w = Matrix6::zeros();
        w.fixed_view_mut::<3, 3>(block, block).copy_from(&Matrix3::identity());
        w
    };
    let (phi, qv) = van_loan(&f, &unit(0), dt);
    let (_, qu) = van_loan(&f, &unit(3), dt);
    let qd = qv * (arw * arw) + qu * (rrw * rrw);
    (phi, (qd + qd.transpose()) * 0.5)
}

/// Noise model and gates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MekfRefConfig {
    /// σv, rad/√s.
    pub gyro_arw_rad_sqrt_s: f64,
    /// σu, rad/s^1.5.
    pub gyro_rrw_rad_s_sqrt_s: f64,
    /// Gate on `yᵀ S⁻¹ y` of a tracker update.
    pub gate_attitude: f64,
    /// Gate on `yᵀ S⁻¹ y` of a unit-vector update.
    pub gate_vector: f64,
}

/// The reference filter. State `q = [ϱ; q₄]` (see the module doc), bias `β` (rad/s),
/// covariance of `[δα; Δβ]`.
#[derive(Clone, Debug, PartialEq)]
pub struct MekfRef {
    cfg: MekfRefConfig,
    q: Vector4<f64>,
    bias: Vector3<f64>,
    p: Matrix6<f64>,
}

impl MekfRef {
    /// `q0`: Hamilton body → reference (its coords are C&J's `[ϱ; q₄]`), normalised here.
    pub fn new(cfg: MekfRefConfig, q0: &Quaternion<f64>, bias0: Vector3<f64>, p0: Matrix6<f64>) -> Self {
        Self { cfg, q: q0.coords.normalize(), bias: bias0, p: p0 }
    }

    /// Attitude estimate as a Hamilton body → reference quaternion.
    pub fn attitude(&self) -> Quaternion<f64> {
        Quaternion::from(self.q)
    }

    pub fn bias_rad_s(&self) -> Vector3<f64> {
        self.bias
    }

    pub fn covariance(&self) -> &Matrix6<f64> {
        &self.p
    }

    /// Time update with the gyro reading `gyro` held over `dt` (C&J Table 7.1).
    pub fn propagate(&mut self, gyro: &Vector3<f64>, dt: f64) {
        let omega = gyro - self.bias;
        let (phi, qd) = discretise(&omega, dt, self.cfg.gyro_arw_rad_sqrt_s, self.cfg.gyro_rrw_rad_s_sqrt_s);
        self.q = (omega_bar(&omega, dt) * self.q).normalize();
        let p = phi * self.p * phi.transpose() + qd;
        self.p = (p + p.transpose()) * 0.5;
    }

    /// Tracker update with the measured attitude `q_meas` (Hamilton body → reference) and
    /// its noise covariance in body axes. `Ok(nis)` when accepted, `Err(nis)` when gated.
    pub fn update_attitude(&mut self, q_meas: &Quaternion<f64>, r: &Matrix3<f64>) -> Result<f64, f64> {
        let mut qm = q_meas.coords.normalize();
        if self.q.dot(&qm) < 0.0 {
            qm = -qm;
        }
        let y = xi(&self.q).transpose() * qm * 2.0;
        let mut h = Mat36::zeros();
        h.fixed_view_mut::<3, 3>(0, 0).copy_from(&Matrix3::identity());
        self.update(&y, &h, r, self.cfg.gate_attitude)
    }

    /// Unit-vector update: `b_meas` in body axes, `r_ref` in the reference frame (both
    /// normalised here), 1σ noise `sigma_rad`. `Ok(nis)` when accepted, `Err(nis)` when gated.
    pub fn update_vector(&mut self, b_meas: &Vector3<f64>, r_ref: &Vector3<f64>, sigma_rad: f64) -> Result<f64, f64> {
        let predicted = attitude_matrix(&self.q) * r_ref.normalize();
        let y = b_meas.normalize() - predicted;
        let mut h = Mat36::zeros();
        h.fixed_view_mut::<3, 3>(0, 0).copy_from(&cross_matrix(&predicted));
        self.update(&y, &h, &(Matrix3::identity() * (sigma_rad * sigma_rad)), self.cfg.gate_vector)
    }

    fn update(&mut self, y: &Vector3<f64>, h: &Mat36, r: &Matrix3<f64>, gate: f64) -> Result<f64, f64> {
        let s = h * self.p * h.transpose() + r;
        let Some(s_inv) = s.try_inverse() else { return Err(f64::INFINITY) };
        let nis = y.dot(&(s_inv * y));
        if !(nis <= gate) {
            return Err(nis);
        }
        let k = self.p * h.transpose() * s_inv;
        let dx: Vector6<f64> = k * y;
        let p = (Matrix6::identity() - k * h) * self.p;
        self.p = (p + p.transpose()) * 0.5;
        let dalpha = dx.fixed_rows::<3>(0).into_owned();
        self.q = (self.q + xi(&self.q) * dalpha * 0.5).normalize();
        self.bias += dx.fixed_rows::<3>(3);
        Ok(nis)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn quats() -> Vec<Vector4<f64>> {
        // A fixed, spread set (no RNG needed): half turns and generic attitudes.
        let mut v = vec![
            Vector4::new(0.0, 0.0, 0.0, 1.0),
            Vector4::new(1.0, 0.0, 0.0, 0.0),
            Vector4::new(0.0, 0.6, 0.0, 0.8),
            Vector4::new(0.1, -0.7, 0.3, 0.2),
        ];
        for k in 0..50 {
            let t = f64::from(k);
            v.push(Vector4::new((1.3 * t).sin(), (0.7 * t + 1.0).cos(), (2.1 * t).sin() * 0.5, (0.3 * t).cos()));
        }
        v.into_iter().map(|q| q.normalize()).collect()
    }

    #[test]
    fn attitude_matrix_is_the_transpose_of_the_hamilton_rotation_with_the_same_numbers() {
        for q in quats() {
            let r = UnitQuaternion::from_quaternion(Quaternion::from(q)).to_rotation_matrix().into_inner();
            assert!((attitude_matrix(&q) - r.transpose()).abs().max() < 1e-15, "{q}");
        }
    }

    #[test]
    fn omega_bar_is_the_hamilton_product_with_the_rotation_increment() {
        let w = Vector3::new(0.3, -0.2, 0.5);
        let dt = 0.7;
        let inc = UnitQuaternion::from_scaled_axis(w * dt).into_inner();
        for q in quats() {
            let want = (Quaternion::from(q) * inc).coords;
            assert!((omega_bar(&w, dt) * q - want).abs().max() < 1e-15);
        }
        // ω = 0: identity.
        assert_eq!(omega_bar(&Vector3::zeros(), 0.1), Matrix4::identity());
    }

    #[test]
    fn van_loan_phi_is_the_closed_form_transition() {
        // Φ = [[Θ, Ψ], [0, I]] with Θ = exp(−[ω×] dt) (Rodrigues) and
        // Ψ = −I dt + [ω×](1 − cos x)/w² − [ω×]²(x − sin x)/w³, x = w dt (M&C §6.2.4).
        let w = Vector3::new(0.05, -0.12, 0.3);
        let dt = 0.5;
        let n = w.norm();
        let x = n * dt;
        let k = cross_matrix(&w);
        let theta = Matrix3::identity() - k * (x.sin() / n) + k * k * ((1.0 - x.cos()) / (n * n));
        let psi_cf = -Matrix3::identity() * dt + k * ((1.0 - x.cos()) / (n * n)) - k * k * ((x - x.sin()) / n.powi(3));
        let (phi, _) = discretise(&w, dt, 1e-5, 1e-8);
        assert!((phi.fixed_view::<3, 3>(0, 0) - theta).abs().max() < 1e-14);
        assert!((phi.fixed_view::<3, 3>(0, 3) - psi_cf).abs().max() < 1e-14);
        assert!(phi.fixed_view::<3, 3>(3, 0).abs().max() < 1e-15);
        assert!((phi.fixed_view::<3, 3>(3, 3) - Matrix3::identity()).abs().max() < 1e-15);
    }

    /// M&C eq 6.93: `Q₁₁ = (σv² dt + σu² dt³/3) I`, `Q₁₂ = −σu² dt²/2 I`, `Q₂₂ = σu² dt I`.
    fn eq_6_93(dt: f64, sv: f64, su: f64) -> Matrix6<f64> {
        let mut q = Matrix6::zeros();
        let i = Matrix3::identity();
        q.fixed_view_mut::<3, 3>(0, 0).copy_from(&(i * (sv * sv * dt + su * su * dt.powi(3) / 3.0)));
        q.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-i * (su * su * dt * dt / 2.0)));
        q.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-i * (su * su * dt * dt / 2.0)));
        q.fixed_view_mut::<3, 3>(3, 3).copy_from(&(i * (su * su * dt)));
        q
    }

    #[test]
    fn van_loan_noise_is_eq_6_93_plus_the_rate_coupling_it_neglects() {
        let (sv, su) = (3e-5, 3e-8);
        // At ω = 0 eq 6.93 is exact.
        let (_, q0) = discretise(&Vector3::zeros(), 0.1, sv, su);
        let want = eq_6_93(0.1, sv, su);
        let rel = (q0 - want).component_div(&want.map(|x| if x == 0.0 { 1.0 } else { x })).abs().max();
        assert!(rel < 1e-12, "ω = 0: relative difference {rel}");
        // With ω ≠ 0 the exact Q₁₂ = σu² ∫ Ψ(s) ds = σu² (−dt²/2 I + [ω×] dt³/6 − [ω×]² dt⁴/24 …),
        // Q₁₁ gains σu² [ω×]² dt⁵/60: eq 6.93 is right to O(dt³) absolute, i.e. O(dt²)
        // relative to the leading O(dt) term. Check the first neglected term and its order.
        let w = Vector3::new(0.02, -0.01, 0.03);
        let k = cross_matrix(&w);
        for dt in [0.4, 0.2, 0.1] {
            let (_, q) = discretise(&w, dt, sv, su);
            let d = q - eq_6_93(dt, sv, su);
            let d12 = d.fixed_view::<3, 3>(0, 3).into_owned();
            let first = k * (su * su * dt.powi(3) / 6.0);
            let next = (k * k * (su * su * dt.powi(4) / 24.0)).abs().max();
            assert!((d12 - first).abs().max() <= 2.0 * next, "dt {dt}: Q12 − eq 6.93 = {d12}");
            let d11 = d.fixed_view::<3, 3>(0, 0).abs().max();
            assert!(d11 <= su * su * (w.norm() * dt).powi(2) * dt.powi(3) / 30.0 + 1e-24, "dt {dt}: Q11 off by {d11}");
            assert!(d.fixed_view::<3, 3>(3, 3).abs().max() <= 1e-12 * su * su * dt);
        }
    }

    #[test]
    fn a_vector_update_moves_the_estimate_toward_the_measurement() {
        let cfg = MekfRefConfig {
            gyro_arw_rad_sqrt_s: 1e-5,
            gyro_rrw_rad_s_sqrt_s: 1e-8,
            gate_attitude: 1e9,
            gate_vector: 1e9,
        };
        let p0 = Matrix6::from_diagonal(&Vector6::new(1e-4, 1e-4, 1e-4, 1e-8, 1e-8, 1e-8));
        let mut f = MekfRef::new(cfg, &Quaternion::identity(), Vector3::zeros(), p0);
        let truth = UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 0.01));
        let r = Vector3::x();
        let b = truth.inverse_transform_vector(&r);
        assert!(f.update_vector(&b, &r, 1e-3).is_ok());
        let err = (UnitQuaternion::from_quaternion(f.attitude()).inverse() * truth).angle();
        assert!(err < 1e-3, "error after update {err} rad (was 0.01)");
    }
}
