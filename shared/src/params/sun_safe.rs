//! Parameters of the sun-safe law ([`crate::control::sun_safe`]), with their validation.

use crate::math::{Vec3, norm};

/// Tolerance on the unit length of the panel normal and the search axis.
pub const SUN_SAFE_UNIT_TOL: f32 = 1e-3;
/// Largest accepted |cos| between the search axis and the panel normal (≈ 0.6° from ⟂).
pub const SUN_SAFE_PERP_TOL: f32 = 1e-2;

/// Parameters of the sun-safe law (a wire type: `ControllerParams::SunSafe`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize, postcard_schema::Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SunSafeParams {
    /// Body axis to point at the Sun (unit).
    pub panel_normal_body: [f32; 3],
    /// Pointing stiffness (N m per unit of `|a × ŝ|`, i.e. per rad for small angles); a
    /// scalar so that `V` of [`crate::control::sun_safe`] is a Lyapunov function.
    pub kp_nm_per_rad: f32,
    /// Rate damping per body axis (N m s/rad), diagonal of `Kd`.
    pub kd_nm_s_per_rad: [f32; 3],
    /// Search rotation axis (unit, ⟂ panel normal within [`SUN_SAFE_PERP_TOL`]).
    pub search_axis_body: [f32; 3],
    /// Search rotation rate (rad/s, > 0).
    pub search_rate_rad_s: f32,
    /// Torque limit per body axis (N m, > 0).
    pub torque_limit_nm: [f32; 3],
    /// How long a remembered Sun direction is trusted without a sighting outside an
    /// expected eclipse (s, ≥ 0): longer than a slew back to the memory takes.
    pub sun_timeout_s: f32,
}

/// Which parameter is invalid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SunSafeError {
    PanelNormal,
    SearchAxis,
    /// Search axis not perpendicular to the panel normal.
    SearchAxisNotPerpendicular,
    Gain,
    SearchRate,
    TorqueLimit,
    Timeout,
}

impl core::fmt::Display for SunSafeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "sun-safe parameter rejected: {self:?}")
    }
}
#[cfg(feature = "std")]
impl std::error::Error for SunSafeError {}

fn unit_ok(v: &[f32; 3]) -> bool {
    let n = norm(&Vec3::from(*v));
    n.is_finite() && libm::fabsf(n - 1.0) <= SUN_SAFE_UNIT_TOL
}

fn positive(v: f32) -> bool {
    v.is_finite() && v > 0.0
}

impl SunSafeParams {
    /// Check every parameter (see the field docs).
    pub fn validate(&self) -> Result<(), SunSafeError> {
        if !unit_ok(&self.panel_normal_body) {
            return Err(SunSafeError::PanelNormal);
        }
        if !unit_ok(&self.search_axis_body) {
            return Err(SunSafeError::SearchAxis);
        }
        let c = Vec3::from(self.panel_normal_body).dot(&Vec3::from(self.search_axis_body));
        if !(libm::fabsf(c) <= SUN_SAFE_PERP_TOL) {
            return Err(SunSafeError::SearchAxisNotPerpendicular);
        }
        if !(positive(self.kp_nm_per_rad) && self.kd_nm_s_per_rad.iter().all(|k| positive(*k))) {
            return Err(SunSafeError::Gain);
        }
        if !positive(self.search_rate_rad_s) {
            return Err(SunSafeError::SearchRate);
        }
        if !self.torque_limit_nm.iter().all(|l| positive(*l)) {
            return Err(SunSafeError::TorqueLimit);
        }
        if !(self.sun_timeout_s.is_finite() && self.sun_timeout_s >= 0.0) {
            return Err(SunSafeError::Timeout);
        }
        Ok(())
    }
}
