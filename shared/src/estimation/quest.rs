//! QUEST: the optimal attitude from several weighted vector observations, i.e. Wahba's
//! problem (Shuster & Oh 1981; Markley & Crassidis §5.3–5.5).
//!
//! Minimise `Σ aᵢ |rᵢ − R bᵢ|²` over rotations `R` (body → reference) for body
//! measurements `bᵢ`, references `rᵢ` and weights `aᵢ = σᵢ⁻²` (normalised here).
//! Davenport's K matrix of `B = Σ aᵢ rᵢ bᵢᵀ`, `S = B + Bᵀ`, `σ = tr B`,
//! `z = [B₂₃ − B₃₂, B₃₁ − B₁₃, B₁₂ − B₂₁]`; its largest eigenvalue λ solves Shuster's
//! quartic `λ⁴ − (a + b) λ² − c λ + (a b + c σ − d) = 0`, `a = σ² − tr adj S`,
//! `b = σ² + zᵀz`, `c = det S + zᵀ S z`, `d = zᵀ S² z`, found by Newton from `λ₀ = Σ aᵢ`
//! (at most [`QUEST_MAX_NEWTON`] steps; it converges in 1–3 for consistent data). The
//! eigenvector is taken as the null vector of `K − λ I` by the generalised cross product
//! of three of its rows (the best-conditioned choice of the four), which, unlike Shuster's
//! Gibbs-vector formula, has no singularity at 180° rotations: no sequential rotations.
//!
//! With Shuster's measurement model (each `bᵢ` = true direction + small isotropic noise
//! σᵢ perpendicular to it) the attitude error covariance in body axes is
//! `P = (Σ σᵢ⁻² (I − bᵢ bᵢᵀ))⁻¹` ([`quest_covariance`]).
//!
//! Degenerate: fewer than two non-parallel directions (typed error).

use super::triad::{TRIAD_MIN_SEPARATION_RAD, WahbaError, unit};
use crate::math::f32m::{sin, sqrt};
use crate::math::{Mat3, Quat, Vec3};
use nalgebra::{Matrix4, Vector4};

/// Most Newton steps on the characteristic quartic.
pub const QUEST_MAX_NEWTON: u32 = 20;
/// Most observations one call takes.
pub const QUEST_MAX_OBSERVATIONS: usize = 8;

/// One vector observation: body measurement, reference direction, 1σ noise (rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observation {
    pub body: Vec3,
    pub reference: Vec3,
    pub sigma_rad: f32,
}

fn weight(sigma: f32) -> Result<f32, WahbaError> {
    let w = 1.0 / (sigma * sigma);
    if sigma.is_finite() && sigma > 0.0 && w.is_finite() { Ok(w) } else { Err(WahbaError::BadInput) }
}

/// Checks that at least two body directions are not parallel.
fn observable(obs: &[Observation]) -> Result<(), WahbaError> {
    let min = sin(TRIAD_MIN_SEPARATION_RAD);
    let first = obs.first().ok_or(WahbaError::Degenerate)?;
    let b0 = unit(&first.body)?;
    for o in obs.iter().skip(1) {
        if sqrt(b0.cross(&unit(&o.body)?).norm_squared()) >= min {
            return Ok(());
        }
    }
    Err(WahbaError::Degenerate)
}

fn det3(c0: [f32; 3], c1: [f32; 3], c2: [f32; 3]) -> f32 {
    c0[0] * (c1[1] * c2[2] - c1[2] * c2[1]) - c1[0] * (c0[1] * c2[2] - c0[2] * c2[1])
        + c2[0] * (c0[1] * c1[2] - c0[2] * c1[1])
}

/// Null vector of the 3×4 matrix with rows `a`, `b`, `c` (generalised cross product).
fn cross4(a: &Vector4<f32>, b: &Vector4<f32>, c: &Vector4<f32>) -> Vector4<f32> {
    // Component j: (−1)^j det of the 3×3 minor without column j.
    let col = |j: usize| -> [f32; 3] {
        [a.get(j).copied().unwrap_or(0.0), b.get(j).copied().unwrap_or(0.0), c.get(j).copied().unwrap_or(0.0)]
    };
    let (c0, c1, c2, c3) = (col(0), col(1), col(2), col(3));
    Vector4::new(det3(c1, c2, c3), -det3(c0, c2, c3), det3(c0, c1, c3), -det3(c0, c1, c2))
}

/// Unit null vector of `K − λ I` from the best-conditioned three of its rows.
fn null_vector(k: &Matrix4<f32>, lam: f32) -> Result<Vector4<f32>, WahbaError> {
    let m = k - Matrix4::identity() * lam;
    let [r0, r1, r2, r3] = [m.row(0).transpose(), m.row(1).transpose(), m.row(2).transpose(), m.row(3).transpose()];
    let candidates = [cross4(&r1, &r2, &r3), cross4(&r0, &r2, &r3), cross4(&r0, &r1, &r3), cross4(&r0, &r1, &r2)];
    let best = candidates
        .iter()
        .copied()
        .max_by(|x, y| x.norm_squared().total_cmp(&y.norm_squared()))
        .ok_or(WahbaError::Degenerate)?;
    let n = sqrt(best.norm_squared());
    if !(n.is_finite() && n > 0.0) {
        return Err(WahbaError::Degenerate);
    }
    Ok(best / n)
}

/// Optimal attitude `q` (body → reference) from 2 … [`QUEST_MAX_OBSERVATIONS`] observations.
pub fn quest(obs: &[Observation]) -> Result<Quat, WahbaError> {
    if obs.len() < 2 || obs.len() > QUEST_MAX_OBSERVATIONS {
        return Err(WahbaError::BadInput);
    }
    observable(obs)?;
    let mut total = 0.0_f32;
    let mut b = Mat3::zeros();
    for o in obs {
        let w = weight(o.sigma_rad)?;
        total += w;
        b += unit(&o.reference)? * unit(&o.body)?.transpose() * w;
    }
    // Normalised weights keep every term O(1) in f32.
    b /= total;
    let s = b + b.transpose();
    let sigma = b.trace();
    let z = Vec3::new(b.m23 - b.m32, b.m31 - b.m13, b.m12 - b.m21);
    let adj_trace = s.m22 * s.m33 - s.m23 * s.m32 + s.m11 * s.m33 - s.m13 * s.m31 + s.m11 * s.m22 - s.m12 * s.m21;
    let qa = sigma * sigma - adj_trace;
    let qb = sigma * sigma + z.dot(&z);
    let qc = s.determinant() + z.dot(&(s * z));
    let qd = z.dot(&(s * (s * z)));
    let mut lam = 1.0_f32; // Σ aᵢ after normalisation
    for _ in 0..QUEST_MAX_NEWTON {
        let l2 = lam * lam;
        let f = l2 * l2 - (qa + qb) * l2 - qc * lam + (qa * qb + qc * sigma - qd);
        let df = 4.0 * l2 * lam - 2.0 * (qa + qb) * lam - qc;
        if !(f.is_finite() && df.is_finite()) || df == 0.0 {
            break;
        }
        let step = f / df;
        lam -= step;
        if step.abs() <= 1e-7 * lam.abs() {
            break;
        }
    }
    if !lam.is_finite() {
        return Err(WahbaError::BadInput);
    }
    // K = [[S − σI, z], [zᵀ, σ]] in scalar-last order.
    let mut k = Matrix4::zeros();
    k.fixed_view_mut::<3, 3>(0, 0).copy_from(&(s - Mat3::identity() * sigma));
    k.fixed_view_mut::<3, 1>(0, 3).copy_from(&z);
    k.fixed_view_mut::<1, 3>(3, 0).copy_from(&z.transpose());
    k.m44 = sigma;
    let mut v = null_vector(&k, lam)?;
    // The quartic's λ carries the cancellation of its f32 coefficients; the Rayleigh
    // quotient of the first eigenvector is accurate to the square of that vector's error,
    // so one more null vector with it reaches f32 rounding.
    let rq = v.dot(&(k * v));
    if rq.is_finite() {
        v = null_vector(&k, rq).unwrap_or(v);
    }
    // Davenport's q (scalar last) belongs to the passive matrix A(q) with gain tr(A Bᵀ)
    // and maps bᵢ → rᵢ here; the Hamilton rotation with the same matrix is its conjugate.
    let q = Quat::new(v.w, -v.x, -v.y, -v.z);
    Ok(if q.w < 0.0 { -q } else { q })
}

/// Attitude error covariance of the optimal estimate under Shuster's measurement model,
/// body axes, rad²: `(Σ σᵢ⁻² (I − bᵢ bᵢᵀ))⁻¹`; `None` when unobservable.
pub fn quest_covariance(obs: &[Observation]) -> Option<Mat3> {
    let mut f = Mat3::zeros();
    for o in obs.iter().take(QUEST_MAX_OBSERVATIONS) {
        let b = unit(&o.body).ok()?;
        f += (Mat3::identity() - b * b.transpose()) * weight(o.sigma_rad).ok()?;
    }
    f.try_inverse()
}
