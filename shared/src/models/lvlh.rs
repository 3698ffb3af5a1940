//! Local-vertical local-horizontal frame from position and velocity (ECI): the orbit frame
//! the simulator used to hand the flight code ready-made. Axes (docs/conventions.md):
//! `z` toward the Earth's centre (−r̂), `y` opposite the orbit normal (−(r × v)/|r × v|),
//! `x = y × z` (along the velocity for a circular orbit). The rate of the frame is the
//! orbit rate `|r × v| / |r|²` about `y` (negative y for a prograde orbit).

use crate::math::f32m::sqrt;
use crate::math::{Mat3, Quat, Vec3, quat_from_rotation_matrix};

/// Why no frame: position or velocity zero, not finite, or parallel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LvlhError;

/// The LVLH frame: attitude (LVLH → ECI, as a quaternion, scalar-last Hamilton) and its
/// angular velocity in LVLH axes, rad/s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lvlh {
    pub q_eci_lvlh: Quat,
    pub rate_lvlh_rad_s: Vec3,
}

pub fn lvlh(r_eci_m: &Vec3, v_eci_m_s: &Vec3) -> Result<Lvlh, LvlhError> {
    let rn2 = r_eci_m.norm_squared();
    let h = r_eci_m.cross(v_eci_m_s);
    let hn = sqrt(h.norm_squared());
    let rn = sqrt(rn2);
    if !(rn.is_finite() && hn.is_finite() && rn > 1.0 && hn > 1e-3 * rn) {
        return Err(LvlhError);
    }
    let z = -r_eci_m / rn;
    let y = -h / hn;
    let x = y.cross(&z);
    let m = Mat3::from_columns(&[x, y, z]);
    let q = quat_from_rotation_matrix(&m).ok_or(LvlhError)?;
    Ok(Lvlh { q_eci_lvlh: q, rate_lvlh_rad_s: Vec3::new(0.0, -hn / rn2, 0.0) })
}
