//! Attitude models of papers 002 and 003: nonlinear `f(x, u)` and analytic small-angle
//! linearisations `ẋ = A x + B u`.
//!
//! # State, frames, conventions
//! `x = [φ, θ, ψ, φ̇, θ̇, ψ̇]`: roll, pitch, yaw of the body B relative to a reference
//! frame R and their rates. Sequence 3-2-1, the project's default `EulerSeq::Zyx321`
//! (`q_RB = q_z(ψ) q_y(θ) q_x(φ)`, Hamilton, scalar-last), so the R→B direction cosine
//! matrix is the matrix of paper 003 eq 17 and the body rate relative to R is
//! `ω_BR = E(φ,θ) α̇` with `E` of paper 003 eq 13 (that paper calls the sequence
//! "1→2→3", but its eqs 13, 14 and 17 are those of yaw-pitch-roll 3-2-1).
//! - In orbit R is LVLH: x along-track (roll axis), z nadir (yaw axis), y = z × x = −orbit
//!   normal (pitch axis); R rotates at `ω_RI = −n ŷ`, n the orbit rate.
//! - On the air-bearing rig (paper 003) R is the lab frame with z down (vertical) and
//!   `ω_RI = 0` (the paper neglects Earth rate, eq 12).
//!
//! # Nonlinear model
//! `I ω̇ = T_u + 3n² o₃ × I o₃ + (m g r) × o₃ − ω × (I ω + h)`, `ω = E α̇ + C_BR ω_RI`,
//! `α̈ = E⁻¹ (ω̇ − Ė α̇ + ω_BR × C_BR ω_RI)`, where `o₃ = C_BR ẑ` is the nadir (orbit) or
//! vertical (rig) unit vector in body axes — paper 003's `K = [−sθ, sφcθ, cφcθ]` (eq 17) —
//! `h` the stored (CMG) momentum and `T_u = B_t u` the input torque:
//! `B_t = I₃` (body torque), `B_t = −J(δ₀)` (paper 002: gimbal rates, `T = −J δ̇`, with
//! the pyramid Jacobian J at the frozen gimbal angles δ₀), or a magnetic map (paper 003).
//!
//! # Classical linear equations (principal inertia J₁ J₂ J₃, torque input; Wie, *Space
//! Vehicle Dynamics and Control*, §6.3; Sidi §4.6)
//! ```text
//! J₁ φ̈ − n (J₁ − J₂ + J₃) ψ̇ + 4 n² (J₂ − J₃) φ = T₁
//! J₂ θ̈ + 3 n² (J₁ − J₃) θ                      = T₂
//! J₃ ψ̈ + n (J₁ − J₂ + J₃) φ̇ + n² (J₂ − J₁) ψ   = T₃
//! ```
//! (paper 002 eqs 8-11 in its notation: `ω_x = φ̇ − ω₀ψ`, `ω_y = θ̇ − ω₀`, `ω_z = ψ̇ + ω₀φ`).
//! Paper 003 eq 17 (rig, n = 0, full inertia):
//! `I α̈ = T_c + m g [r_y − r_z φ, −r_x − r_z θ, r_x φ + r_y θ]ᵀ`.
//!
//! # General analytic linearisation ([`AttitudeModel::linear`])
//! About α = α̇ = 0 with `ω₀ = [0, −n, 0]`, `δω = α̇ + N α`, `N = n[[0,0,−1],[0,0,0],[1,0,0]]`,
//! `o₃ ≈ ẑ + P α`, `P = [[0,−1,0],[1,0,0],[0,0,0]]`:
//! `G_y = −[ω₀×] I + [(I ω₀)×] + [h×]`, `K_gg = 3n² ([ẑ×] I − [(I ẑ)×]) P`, `K_p = [(mgr)×] P`,
//! `A = [[0, I₃], [I⁻¹(G_y N + K_gg + K_p), I⁻¹ G_y − N]]`, `B = [[0], [I⁻¹ B_t]]`.
//! It is the Jacobian of `f` whenever x = 0 is an equilibrium (principal axes aligned
//! with LVLH and h ∥ ŷ in orbit; on the rig with the trim torque [`AttitudeModel::bias_torque`]
//! cancelled). Otherwise `f(0, u₀) ≠ 0` and the exact Jacobian has extra
//! bias × angle terms that the papers' small-angle equations drop.

use nalgebra::{DMatrix, DVector, Matrix3, Matrix3x4, Vector3};

pub const MU_EARTH: f64 = 3.986_004_418e14;
pub const R_EARTH: f64 = 6_378_137.0;

/// Mean motion of a circular orbit at `altitude_m`, rad/s.
pub fn circular_orbit_rate(altitude_m: f64) -> f64 {
    (MU_EARTH / (R_EARTH + altitude_m).powi(3)).sqrt()
}

/// Paper 002, table 1.
pub mod paper002 {
    pub const INERTIA_DIAG: f64 = 2.5;
    pub const ALTITUDE_M: f64 = 300e3;
    pub const H0_NMS: f64 = 0.35;
    pub const BETA_DEG: f64 = 54.73;
    pub const GIMBAL_RATE_MAX: f64 = 0.12;
}

/// Paper 003: rig inertia (eq 27), pendulum (eq 28), LQR weights (eqs 33-34), printed
/// gain (eq 35, as `K`, 3×6 row-major, i.e. the transpose of the printed 6×3 matrix).
pub mod paper003 {
    pub const INERTIA: [[f64; 3]; 3] = [[1.76, -0.01, -0.05], [-0.01, 1.79, -0.01], [-0.05, -0.01, 2.92]];
    pub const MGR: [f64; 3] = [-0.004, -0.001, 0.5];
    pub const Q_DIAG: [f64; 6] = [100e5, 10e5, 0.41e5, 1000e5, 1e5, 2105e5];
    pub const R_DIAG: f64 = 100.0;
    pub const K_EQ35: [[f64; 6]; 3] = [
        [-4.074, -28.19, 1.141, -1155.0, -9.632, 141.6],
        [19.42, -4.931, -16.2, -47.8, -175.4, -2009.0],
        [14.65, -2.128, -12.09, 27.42, -130.8, -1500.0],
    ];
}

/// Four single-gimbal CMGs in a pyramid (paper 000 eq 6, used by paper 002):
/// `h = h0([-cβ s1, c1, sβ s1] + [-c2, -cβ s2, sβ s2] + [cβ s3, -c3, sβ s3] + [c4, cβ s4, sβ s4])`.
#[derive(Clone, Copy, Debug)]
pub struct CmgPyramid {
    pub beta: f64,
    pub h0: f64,
}

impl CmgPyramid {
    pub fn paper002() -> Self {
        Self { beta: paper002::BETA_DEG.to_radians(), h0: paper002::H0_NMS }
    }

    /// Cluster momentum in body axes, N m s.
    pub fn momentum(&self, d: &[f64; 4]) -> Vector3<f64> {
        let (cb, sb) = (self.beta.cos(), self.beta.sin());
        let (s, c) = (d.map(f64::sin), d.map(f64::cos));
        Vector3::new(
            -cb * s[0] - c[1] + cb * s[2] + c[3],
            c[0] - cb * s[1] - c[2] + cb * s[3],
            sb * (s[0] + s[1] + s[2] + s[3]),
        ) * self.h0
    }

    /// `J = ∂h/∂δ`, N m s / rad.
    pub fn jacobian(&self, d: &[f64; 4]) -> Matrix3x4<f64> {
        let (cb, sb) = (self.beta.cos(), self.beta.sin());
        let (s, c) = (d.map(f64::sin), d.map(f64::cos));
        #[rustfmt::skip]
        let j = Matrix3x4::new(
            -cb * c[0],  s[1],       cb * c[2], -s[3],
            -s[0],      -cb * c[1],  s[2],       cb * c[3],
             sb * c[0],  sb * c[1],  sb * c[2],  sb * c[3],
        );
        j * self.h0
    }
}

/// Rigid body about a reference frame, with optional gravity gradient, pendulum torque,
/// stored momentum and an arbitrary 3×m input-to-torque map.
#[derive(Clone, Debug)]
pub struct AttitudeModel {
    /// Inertia about the centre of mass (rig: centre of rotation), body axes, kg m².
    pub inertia: Matrix3<f64>,
    /// Orbit rate n, rad/s (0 on the rig).
    pub orbit_rate: f64,
    pub gravity_gradient: bool,
    /// `m g r`, N m (paper 003 eq 28), zero in orbit.
    pub mgr: Vector3<f64>,
    /// Constant stored momentum h (CMG cluster at δ₀), body axes, N m s.
    pub stored_momentum: Vector3<f64>,
    /// Torque = `input · u`, 3×m.
    pub input: DMatrix<f64>,
}

impl AttitudeModel {
    /// (a) Rigid body, gravity gradient, body-torque input.
    pub fn orbit_torque(inertia: Matrix3<f64>, orbit_rate: f64) -> Self {
        Self {
            inertia,
            orbit_rate,
            gravity_gradient: true,
            mgr: Vector3::zeros(),
            stored_momentum: Vector3::zeros(),
            input: DMatrix::identity(3, 3),
        }
    }

    /// (b) Paper 002: gimbal-rate input through `T = −J(δ₀) δ̇`, stored momentum `h(δ₀)`.
    pub fn orbit_cmg(inertia: Matrix3<f64>, orbit_rate: f64, cmg: &CmgPyramid, delta0: &[f64; 4]) -> Self {
        let j = cmg.jacobian(delta0);
        Self {
            inertia,
            orbit_rate,
            gravity_gradient: true,
            mgr: Vector3::zeros(),
            stored_momentum: cmg.momentum(delta0),
            input: DMatrix::from_fn(3, 4, |r, c| -j[(r, c)]),
        }
    }

    /// Paper 002 table 1: 2.5 I kg m², 300 km, pyramid at δ₀.
    pub fn paper002(delta0: &[f64; 4]) -> Self {
        Self::orbit_cmg(
            Matrix3::identity() * paper002::INERTIA_DIAG,
            circular_orbit_rate(paper002::ALTITUDE_M),
            &CmgPyramid::paper002(),
            delta0,
        )
    }

    /// (c) Paper 003 rig: eq 27 inertia, eq 28 pendulum, body-torque input, no orbit.
    pub fn rig003() -> Self {
        Self {
            inertia: Matrix3::from_fn(|r, c| paper003::INERTIA[r][c]),
            orbit_rate: 0.0,
            gravity_gradient: false,
            mgr: Vector3::from(paper003::MGR),
            stored_momentum: Vector3::zeros(),
            input: DMatrix::identity(3, 3),
        }
    }

    /// Number of inputs.
    pub fn m(&self) -> usize {
        self.input.ncols()
    }

    /// Environmental + gyroscopic torque at x = 0 with u = 0 (zero when x = 0 is an
    /// equilibrium). On the rig it is `m g [r_y, −r_x, 0]`; a torque input of minus this
    /// is the trim about which eq 17 is the exact Jacobian.
    pub fn bias_torque(&self) -> Vector3<f64> {
        let w0 = Vector3::new(0.0, -self.orbit_rate, 0.0);
        let z = Vector3::z();
        let mut t = self.mgr.cross(&z) - w0.cross(&(self.inertia * w0 + self.stored_momentum));
        if self.gravity_gradient {
            t += 3.0 * self.orbit_rate.powi(2) * z.cross(&(self.inertia * z));
        }
        t
    }

    /// Nonlinear dynamics `ẋ = f(x, u)` (see module doc). Singular at θ = ±90°.
    pub fn f(&self, x: &DVector<f64>, u: &DVector<f64>) -> DVector<f64> {
        let (ph, th, ps) = (x[0], x[1], x[2]);
        let ad = Vector3::new(x[3], x[4], x[5]);
        let c = dcm_ref_to_body(ph, th, ps);
        let e = euler_rate_matrix(ph, th);
        let w_br = e * ad;
        let w_ri = c * Vector3::new(0.0, -self.orbit_rate, 0.0);
        let w = w_br + w_ri;
        let o3: Vector3<f64> = c.column(2).into();
        let tu = &self.input * u;
        let mut torque = Vector3::new(tu[0], tu[1], tu[2]);
        torque += self.mgr.cross(&o3) - w.cross(&(self.inertia * w + self.stored_momentum));
        if self.gravity_gradient {
            torque += 3.0 * self.orbit_rate.powi(2) * o3.cross(&(self.inertia * o3));
        }
        let wdot = self.inertia.try_inverse().unwrap_or_else(Matrix3::zeros) * torque;
        let add = euler_rate_matrix_inv(ph, th) * (wdot - edot_times_rate(ph, th, &ad) + w_br.cross(&w_ri));
        DVector::from_column_slice(&[ad[0], ad[1], ad[2], add[0], add[1], add[2]])
    }

    /// Analytic small-angle linearisation (module doc, "General analytic linearisation").
    pub fn linear(&self) -> (DMatrix<f64>, DMatrix<f64>) {
        let n = self.orbit_rate;
        let i = self.inertia;
        let ii = i.try_inverse().unwrap_or_else(Matrix3::zeros);
        let w0 = Vector3::new(0.0, -n, 0.0);
        let nmat = Matrix3::new(0.0, 0.0, -n, 0.0, 0.0, 0.0, n, 0.0, 0.0);
        let p = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let z = Vector3::z();
        let gy = -w0.cross_matrix() * i + (i * w0).cross_matrix() + self.stored_momentum.cross_matrix();
        let kgg = if self.gravity_gradient {
            3.0 * n * n * (z.cross_matrix() * i - (i * z).cross_matrix()) * p
        } else {
            Matrix3::zeros()
        };
        let kp = self.mgr.cross_matrix() * p;
        let a21 = ii * (gy * nmat + kgg + kp);
        let a22 = ii * gy - nmat;
        let mut a = DMatrix::<f64>::zeros(6, 6);
        a.view_mut((0, 3), (3, 3)).copy_from(&Matrix3::<f64>::identity());
        a.view_mut((3, 0), (3, 3)).copy_from(&a21);
        a.view_mut((3, 3), (3, 3)).copy_from(&a22);
        let mut b = DMatrix::<f64>::zeros(6, self.m());
        b.view_mut((3, 0), (3, self.m())).copy_from(&(DMatrix::from_fn(3, 3, |r, c| ii[(r, c)]) * &self.input));
        (a, b)
    }
}

/// Classical small-angle LVLH equations (module doc), principal inertia, torque input.
/// An independent transcription used to check [`AttitudeModel::linear`].
pub fn classical_gg_linear(j: [f64; 3], n: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let [j1, j2, j3] = j;
    let s = j1 - j2 + j3;
    let mut a = DMatrix::<f64>::zeros(6, 6);
    for k in 0..3 {
        a[(k, k + 3)] = 1.0;
    }
    a[(3, 0)] = -4.0 * n * n * (j2 - j3) / j1;
    a[(3, 5)] = n * s / j1;
    a[(4, 1)] = -3.0 * n * n * (j1 - j3) / j2;
    a[(5, 2)] = -n * n * (j2 - j1) / j3;
    a[(5, 3)] = -n * s / j3;
    let mut b = DMatrix::<f64>::zeros(6, 3);
    for (k, jk) in j.iter().enumerate() {
        b[(k + 3, k)] = 1.0 / jk;
    }
    (a, b)
}

/// Paper 003 eq 17 transcribed literally: `I α̈ = T_c + [−r_z φ, −r_z θ, r_x φ + r_y θ] m g`
/// (the constants `m g r_y`, `−m g r_x` are a bias, not part of A).
pub fn rig_eq17_linear(inertia: &Matrix3<f64>, mgr: &Vector3<f64>) -> (DMatrix<f64>, DMatrix<f64>) {
    let k = Matrix3::new(-mgr.z, 0.0, 0.0, 0.0, -mgr.z, 0.0, mgr.x, mgr.y, 0.0);
    let ii = inertia.try_inverse().unwrap_or_else(Matrix3::zeros);
    let a21 = ii * k;
    let mut a = DMatrix::<f64>::zeros(6, 6);
    let mut b = DMatrix::<f64>::zeros(6, 3);
    for r in 0..3 {
        a[(r, r + 3)] = 1.0;
        for c in 0..3 {
            a[(r + 3, c)] = a21[(r, c)];
            b[(r + 3, c)] = ii[(r, c)];
        }
    }
    (a, b)
}

/// Paper 003 eqs 18 + 21: dipole command `u = M̄`, `M = M̄ × B/|B|`, `T = M × B`
/// ⇒ `T = −|B| (I − b̂ b̂ᵀ) M̄`. Returns that 3×3 input map for a body-frame field `b` (T).
pub fn magnetic_projected_input(b: &Vector3<f64>) -> DMatrix<f64> {
    let nb = b.norm();
    let bh = if nb > 0.0 { b / nb } else { Vector3::zeros() };
    let m = -(Matrix3::identity() - bh * bh.transpose()) * nb;
    DMatrix::from_fn(3, 3, |r, c| m[(r, c)])
}

/// Paper 003 eqs 18-19 with the dipole as input: `T = M × B = −[B×] M`.
pub fn magnetic_cross_input(b: &Vector3<f64>) -> DMatrix<f64> {
    let m = -b.cross_matrix();
    DMatrix::from_fn(3, 3, |r, c| m[(r, c)])
}

/// R→B direction cosine matrix for 3-2-1 Euler angles (paper 003 eq 17 matrix).
#[rustfmt::skip]
pub fn dcm_ref_to_body(ph: f64, th: f64, ps: f64) -> Matrix3<f64> {
    let (sf, cf, st, ct, sp, cp) = (ph.sin(), ph.cos(), th.sin(), th.cos(), ps.sin(), ps.cos());
    Matrix3::new(
        ct * cp,                 ct * sp,                 -st,
        sf * st * cp - cf * sp,  sf * st * sp + cf * cp,  sf * ct,
        cf * st * cp + sf * sp,  cf * st * sp - sf * cp,  cf * ct,
    )
}

/// `ω_BR = E α̇` (paper 003 eq 13).
pub fn euler_rate_matrix(ph: f64, th: f64) -> Matrix3<f64> {
    let (sf, cf, st, ct) = (ph.sin(), ph.cos(), th.sin(), th.cos());
    Matrix3::new(1.0, 0.0, -st, 0.0, cf, sf * ct, 0.0, -sf, cf * ct)
}

/// `E⁻¹` (paper 003 eq 14).
pub fn euler_rate_matrix_inv(ph: f64, th: f64) -> Matrix3<f64> {
    let (sf, cf, ct, tt) = (ph.sin(), ph.cos(), th.cos(), th.tan());
    Matrix3::new(1.0, sf * tt, cf * tt, 0.0, cf, -sf, 0.0, sf / ct, cf / ct)
}

/// `Ė α̇` for the 3-2-1 rate matrix.
fn edot_times_rate(ph: f64, th: f64, ad: &Vector3<f64>) -> Vector3<f64> {
    let (sf, cf, st, ct) = (ph.sin(), ph.cos(), th.sin(), th.cos());
    let (pd, td, yd) = (ad[0], ad[1], ad[2]);
    Vector3::new(
        -yd * td * ct,
        -td * pd * sf + yd * (pd * cf * ct - td * sf * st),
        -td * pd * cf - yd * (pd * sf * ct + td * cf * st),
    )
}
