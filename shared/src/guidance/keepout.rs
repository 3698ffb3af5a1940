//! Keep-out cones: body-fixed boresights (star trackers, an instrument, a radiator) that
//! must stay a given angle away from the Sun and from the Earth's disc (its angular radius
//! from the orbit altitude, plus a margin).
//!
//! A boresight's *margin* to a cone is the angle from the boresight to the cone's edge:
//! `∠(b_I, d) − half_angle`, negative inside. Along an eigen-axis rotation of the whole
//! body by `φ ∈ [0, Θ]` about the inertial unit axis `e`, a boresight traces a circle:
//! `v(φ) = v_∥ + v_⊥ cos φ + (e × v_⊥) sin φ`, so `d·v(φ) = A + B cos φ + C sin φ` with
//! `A = d·v_∥`, `B = d·v_⊥`, `C = d·(e × v_⊥)`. Its largest value over the arc — the
//! smallest angle to `d` — is `A + √(B² + C²)` when the maximiser `φ* = atan2(C, B)` lies
//! in `[0, Θ]`, else the larger end point: the worst margin of a whole slew leg in closed
//! form, no sampling ([`arc_min_margin_rad`]).

use crate::math::f32m::{atan2, sqrt};
use crate::math::{Quat, Vec3, norm, rotate_body_to_ref};

/// Angle between two unit vectors from their dot product, rad, in [0, π] (the dot
/// product clamped; `atan2` keeps accuracy near 0 and π).
pub fn angle_from_cos(c: f32) -> f32 {
    let c = crate::math::clamp_abs(c, 1.0);
    atan2(sqrt((1.0 - c * c).max(0.0)), c)
}

/// The keep-out margin of `boresight_body` (unit) at attitude `q` (body → inertial) to a
/// cone of `half_angle_rad` about the inertial unit direction `d`, rad.
pub fn margin_rad(q: &Quat, boresight_body: &Vec3, d: &Vec3, half_angle_rad: f32) -> f32 {
    let v = rotate_body_to_ref(q, boresight_body);
    angle_from_cos(v.dot(d)) - half_angle_rad
}

/// The smallest margin of `boresight_body` to the cone (`d`, `half_angle_rad`) along the
/// eigen-axis rotation from `q0` by `angle_rad ∈ [0, 2π)` about the inertial unit axis
/// `axis` (`q(φ) = Exp(φ axis) q0`), rad. A zero or non-finite axis is a rotation by 0.
pub fn arc_min_margin_rad(
    q0: &Quat,
    axis: &Vec3,
    angle_rad: f32,
    boresight_body: &Vec3,
    d: &Vec3,
    half_angle_rad: f32,
) -> f32 {
    let v = rotate_body_to_ref(q0, boresight_body);
    let n = norm(axis);
    if !(n > 1.0e-12 && n.is_finite() && angle_rad > 0.0) {
        return angle_from_cos(v.dot(d)) - half_angle_rad;
    }
    let e = axis / n;
    let v_par = e * e.dot(&v);
    let v_perp = v - v_par;
    let (a, b, c) = (d.dot(&v_par), d.dot(&v_perp), d.dot(&e.cross(&v_perp)));
    let two_pi = core::f32::consts::TAU;
    let mut phi_star = atan2(c, b);
    if phi_star < 0.0 {
        phi_star += two_pi;
    }
    let end = {
        let (s, co) = crate::math::f32m::sin_cos(angle_rad);
        b * co + c * s
    };
    let best = if phi_star <= angle_rad { sqrt(b * b + c * c) } else { b.max(end) };
    angle_from_cos(a + best) - half_angle_rad
}

/// Angular radius of the Earth's disc seen from `r_m` (inertial position, m), rad; the
/// mean equatorial radius (a conservative disc for the polar flattening).
pub fn earth_angular_radius_rad(r_m: &Vec3) -> Option<f32> {
    let d = norm(r_m);
    let re = crate::models::sun::EARTH_RADIUS_M;
    (d.is_finite() && d > re).then(|| crate::math::f32m::asin(re / d))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::guidance::blend::quat_exp;

    /// The closed form against a dense sampling of the same arc.
    #[test]
    fn the_arc_minimum_equals_a_dense_sampling() {
        let cases = [
            (Vec3::new(0.0, 0.0, 1.0), 2.5f32, Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.2)),
            (Vec3::new(0.3, -0.5, 0.8), 1.2, Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.5, 0.5, 0.7)),
            (Vec3::new(1.0, 1.0, 0.0), 5.9, Vec3::new(0.2, -0.9, 0.1), Vec3::new(-0.3, 0.1, 0.9)),
        ];
        let q0 = quat_exp(&Vec3::new(0.2, -0.4, 0.7));
        for (axis, theta, b, d) in cases {
            let (b, d) = (b / b.norm(), d / d.norm());
            let exact = arc_min_margin_rad(&q0, &axis, theta, &b, &d, 0.3);
            let e = axis / axis.norm();
            let sampled = (0..=20_000)
                .map(|k| {
                    let phi = theta * k as f32 / 20_000.0;
                    margin_rad(&(quat_exp(&(e * phi)) * q0), &b, &d, 0.3)
                })
                .fold(f32::INFINITY, f32::min);
            assert!((exact - sampled).abs() < 1e-4, "{exact} vs {sampled}");
        }
    }
}
