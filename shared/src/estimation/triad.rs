//! TRIAD: attitude from two vector observations (Black 1964; Markley & Crassidis §5.2).
//!
//! Inputs: two directions measured in body axes (`b1`, `b2`) and the same directions in
//! the reference frame (`r1`, `r2`, from the on-board models); the first pair is trusted
//! more (it fixes two degrees of freedom exactly, the second only the rotation about it):
//! pass the more accurate sensor first (star tracker > Sun > magnetometer).
//! Triads `t₁ = v₁`, `t₂ = v₁ × v₂ / |v₁ × v₂|`, `t₃ = t₁ × t₂` in both frames;
//! `R = [t₁ᴵ t₂ᴵ t₃ᴵ] [t₁ᴮ t₂ᴮ t₃ᴮ]ᵀ` maps body to reference; `q` from `R` (Shepperd).
//!
//! Degenerate cases (typed errors, nothing returned): a zero or non-finite vector, and
//! vectors within [`TRIAD_MIN_SEPARATION_RAD`] of parallel or antiparallel in either
//! frame (the rotation about the common direction is unobservable; in eclipse the Sun
//! vector is absent and the caller has only one vector — no TRIAD).

use crate::math::{Mat3, Quat, Vec3, quat_from_rotation_matrix};

/// Smallest accepted angle between the two vectors (and their references): 1°. Below it
/// the error about the first vector grows as σ₂ / sin(angle) (over 57 σ₂ at 1°).
pub const TRIAD_MIN_SEPARATION_RAD: f32 = 0.017_453_3;

/// Why no attitude was computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WahbaError {
    /// A vector is zero, NaN or infinite, or a weight is not positive and finite.
    BadInput,
    /// The observations do not fix the attitude (vectors near parallel).
    Degenerate,
}

/// `v / |v|`, refused when zero or not finite.
pub(crate) fn unit(v: &Vec3) -> Result<Vec3, WahbaError> {
    let n = crate::math::norm(v);
    if n.is_finite() && n > 1e-12 { Ok(v / n) } else { Err(WahbaError::BadInput) }
}

fn triad_frame(v1: &Vec3, v2: &Vec3) -> Result<Mat3, WahbaError> {
    let t1 = unit(v1)?;
    let c = t1.cross(&unit(v2)?);
    let s = crate::math::norm(&c);
    if !(s.is_finite() && s >= crate::math::f32m::sin(TRIAD_MIN_SEPARATION_RAD)) {
        return Err(WahbaError::Degenerate);
    }
    let t2 = c / s;
    let t3 = t1.cross(&t2);
    Ok(Mat3::from_columns(&[t1, t2, t3]))
}

/// Attitude `q` (body → reference) from body vectors `b1`, `b2` and their references
/// `r1`, `r2`; `b1`/`r1` is the trusted pair.
pub fn triad(b1: &Vec3, b2: &Vec3, r1: &Vec3, r2: &Vec3) -> Result<Quat, WahbaError> {
    let mb = triad_frame(b1, b2)?;
    let mr = triad_frame(r1, r2)?;
    quat_from_rotation_matrix(&(mr * mb.transpose())).ok_or(WahbaError::BadInput)
}
