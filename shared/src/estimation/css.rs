//! Sun direction from coarse sun sensors (CSS): cosine detectors on several faces.
//!
//! Model (Wertz, *Spacecraft Attitude Determination and Control*, 1978, §6.1; Markley &
//! Crassidis 2014, §4.3.1): head `i` with unit normal `nᵢ` (body axes) reads a normalised
//! current `Iᵢ ≈ max(0, nᵢ·s)`, `s` the Sun direction times the illumination (1 = full Sun
//! at normal incidence), plus noise and, in orbit, Earth albedo (not modelled here: the
//! lit threshold is what keeps albedo-level readings out).
//!
//! Algorithm ([`sun_vector`]):
//! 1. every current must be finite (`NonFinite`) and at most [`CSS_MAX_CURRENT`]
//!    (`OutOfRange`); negative currents count as 0;
//! 2. lit heads: `Iᵢ > lit_threshold`; none → [`CssError::NotSeen`] (eclipse, or the Sun
//!    outside every head's field of view);
//! 3. if the lit normals span 3-D, the least-squares solution of `nᵢ·s = Iᵢ` (lit heads):
//!    `s = M⁻¹ Σ Iᵢ nᵢ` with `M = Σ nᵢ nᵢᵀ`, solved by the adjugate. The well-conditioning
//!    test is `trace(M⁻¹) = trace(adj M) / det M ≤` [`CSS_MAX_TRACE_INV`] (evaluated without
//!    dividing: `trace(adj M) ≤ CSS_MAX_TRACE_INV · det M`). `trace(M⁻¹)` is exactly the
//!    noise gain: with independent current noise σ the solution error has covariance
//!    `σ² M⁻¹`, so the bound caps the error at `σ·√CSS_MAX_TRACE_INV` (RMS, all axes);
//! 4. otherwise (one or two lit heads, or nearly coplanar lit normals) the coarse direction
//!    `Σ Iᵢ nᵢ`, flagged [`CssSolution::Coarse`]. It is biased toward the lit normals:
//!    for orthogonal heads (±x ±y ±z) the components whose heads are below the threshold
//!    are dropped, so the error is at most `asin(√2 · lit_threshold)` (two components
//!    below it) — this is the documented degeneracy.
//!
//! `intensity` is `|s|` before normalising: ≈ 1 in full Sun for the least-squares solution
//! (a penumbra or a degraded head shows as less); for the coarse solution it is only a
//! lower bound. No heap, loops over at most [`MAX_CSS_HEADS`] heads, no panics.

use crate::math::{Mat3, Vec3, norm};

use crate::types::MAX_CSS_HEADS;

/// Largest accepted normalised current: 10× full Sun at normal incidence. Sunlight plus
/// the brightest Earth albedo stays under 1.5; a larger reading is a failed head or a bad
/// scale factor, refused rather than trusted ([`CssError::OutOfRange`]).
pub const CSS_MAX_CURRENT: f32 = 10.0;

/// Largest accepted `trace((Σ n nᵀ)⁻¹)` for the least-squares solution (the noise gain,
/// dimensionless for normalised currents). Three orthogonal lit heads give 3; a boresight
/// head plus four heads tilted 45° around it, all lit, give 7/3. For three lit heads
/// `trace(M⁻¹) = ‖N⁻¹‖²_F` (`N` the matrix of their normals), which grows as
/// 1/det(N)² when they approach a plane. 20 caps the RMS error of the solution at
/// √20 σ ≈ 4.5 σ (σ the current noise); beyond it the coarse direction is safer.
pub const CSS_MAX_TRACE_INV: f32 = 20.0;

/// Tolerance on `|n| = 1` of a head normal.
pub const CSS_UNIT_TOL: f32 = 1e-3;

/// Head geometry and the lit threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CssHeads {
    /// Unit normals in body axes; only the first `count` are used.
    pub normals_body: [[f32; 3]; MAX_CSS_HEADS],
    /// Number of heads fitted, 1..=[`MAX_CSS_HEADS`].
    pub count: u8,
    /// A head is lit when its normalised current exceeds this, in (0, 1): above the
    /// albedo and noise level of an unlit head.
    pub lit_threshold: f32,
}

/// Why no Sun vector was produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CssError {
    /// `count` is 0 or above [`MAX_CSS_HEADS`].
    BadCount,
    /// A used normal is not finite or not unit within [`CSS_UNIT_TOL`].
    BadNormal,
    /// `lit_threshold` is not in (0, 1).
    BadThreshold,
    /// A used head's current is NaN or infinite.
    NonFinite,
    /// A used head's current exceeds [`CSS_MAX_CURRENT`].
    OutOfRange,
    /// No head is lit: eclipse, or the Sun is outside every head's field of view.
    NotSeen,
}

impl core::fmt::Display for CssError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "coarse sun sensors: {self:?}")
    }
}
#[cfg(feature = "std")]
impl std::error::Error for CssError {}

/// How the direction was obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CssSolution {
    /// Least squares over lit heads spanning 3-D: exact on noise-free cosine currents.
    LeastSquares,
    /// Sum of lit normals weighted by their currents: biased (module docs).
    Coarse,
}

/// A Sun direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CssSun {
    /// Unit Sun direction in body axes.
    pub dir_body: Vec3,
    /// Number of lit heads used.
    pub lit: u8,
    pub solution: CssSolution,
    /// `|s|` before normalising (≈ 1 in full Sun for [`CssSolution::LeastSquares`]).
    pub intensity: f32,
}

impl CssHeads {
    /// Check the geometry: count in 1..=6, used normals finite and unit within
    /// [`CSS_UNIT_TOL`], threshold in (0, 1).
    pub fn validate(&self) -> Result<(), CssError> {
        let n = usize::from(self.count);
        if n == 0 || n > MAX_CSS_HEADS {
            return Err(CssError::BadCount);
        }
        for v in self.normals_body.iter().take(n) {
            let len = norm(&Vec3::from(*v));
            if !(len.is_finite() && libm::fabsf(len - 1.0) <= CSS_UNIT_TOL) {
                return Err(CssError::BadNormal);
            }
        }
        if !(self.lit_threshold > 0.0 && self.lit_threshold < 1.0) {
            return Err(CssError::BadThreshold);
        }
        Ok(())
    }
}

/// Sun direction (body axes) from the heads' normalised currents (module docs). Only the
/// first `heads.count` currents are read.
pub fn sun_vector(heads: &CssHeads, currents: &[f32; MAX_CSS_HEADS]) -> Result<CssSun, CssError> {
    heads.validate()?;
    let n = usize::from(heads.count);
    for i in currents.iter().take(n) {
        if !i.is_finite() {
            return Err(CssError::NonFinite);
        }
        if *i > CSS_MAX_CURRENT {
            return Err(CssError::OutOfRange);
        }
    }
    let mut m = Mat3::zeros();
    let mut b = Vec3::zeros();
    let mut lit: u8 = 0;
    for (nv, i) in heads.normals_body.iter().zip(currents.iter()).take(n) {
        // Negative currents count as 0, which is never above the (positive) threshold.
        if *i > heads.lit_threshold {
            let v = Vec3::from(*nv);
            m += v * v.transpose();
            b += v * *i;
            lit = lit.saturating_add(1);
        }
    }
    if lit == 0 {
        return Err(CssError::NotSeen);
    }
    let (s, solution) = match solve_well_conditioned(&m, &b) {
        Some(s) => (s, CssSolution::LeastSquares),
        None => (b, CssSolution::Coarse),
    };
    let intensity = norm(&s);
    // Lit currents are in (threshold, CSS_MAX_CURRENT] and the normals unit, so `s` is
    // finite and, for the coarse sum of positive weights, non-zero unless lit normals
    // cancel exactly (opposite heads both lit: impossible for a cosine detector, possible
    // for a faulty one) — refused as not seen rather than divided by ~0.
    if !(intensity.is_finite() && intensity > 1e-6) {
        return Err(CssError::NotSeen);
    }
    Ok(CssSun { dir_body: s / intensity, lit, solution, intensity })
}

/// `M⁻¹ b` by the adjugate when `trace(M⁻¹) ≤ CSS_MAX_TRACE_INV`, else `None`.
fn solve_well_conditioned(m: &Mat3, b: &Vec3) -> Option<Vec3> {
    // Cofactors of the symmetric M (adj M is symmetric too).
    let c00 = m.m22 * m.m33 - m.m23 * m.m32;
    let c11 = m.m11 * m.m33 - m.m13 * m.m31;
    let c22 = m.m11 * m.m22 - m.m12 * m.m21;
    let c01 = m.m13 * m.m32 - m.m12 * m.m33;
    let c02 = m.m12 * m.m23 - m.m13 * m.m22;
    let c12 = m.m13 * m.m21 - m.m11 * m.m23;
    let det = m.m11 * c00 + m.m12 * c01 + m.m13 * c02;
    let tr_adj = c00 + c11 + c22;
    // `!(a <= b)` also refuses NaN.
    if !(det > 0.0 && tr_adj <= CSS_MAX_TRACE_INV * det) {
        return None;
    }
    let adj = Mat3::new(c00, c01, c02, c01, c11, c12, c02, c12, c22);
    let s = adj * b / det;
    if s.iter().all(|x| x.is_finite()) { Some(s) } else { None }
}
