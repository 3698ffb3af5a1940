//! Effectiveness of four single-gimbal CMGs in a pyramid (paper 000 eqs 4, 6-8): the
//! cluster momentum, its Jacobian, the torque gimbal rates produce on the body, and the
//! momentum-envelope test; the steering laws that invert it are [`crate::allocation::cmg`].
//!
//! Momentum (eq 6), gimbal angles `δ_i`, skew `β`, `c = cos`, `s = sin`:
//! `h = h0 ( [-cβ s1, c1, sβ s1] + [-c2, -cβ s2, sβ s2] + [cβ s3, -c3, sβ s3] + [c4, cβ s4, sβ s4] )`
//! Jacobian `J = ∂h/∂δ` (eq 8), 3×4. Torque on the body (eq 4): `T = -J δ̇ - ω × h`.
//!
//! The singularity measure `m = det(J₁ J₁ᵀ)` uses the unit-momentum Jacobian
//! `J₁ = J / h0`, so α and `m` are dimensionless and independent of the rotor size.

use crate::math::f32m::sin_cos;
use crate::math::{Mat3, Vec3};
use nalgebra::SMatrix;

pub type Jacobian = SMatrix<f32, 3, 4>;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CmgPyramid {
    pub h0_nms: f32,
    cos_skew: f32,
    sin_skew: f32,
}

/// `[sin δ_i]`, `[cos δ_i]`, computed once per step and shared by `h` and `J`.
#[derive(Clone, Copy, Debug)]
pub struct GimbalTrig {
    pub s: [f32; 4],
    pub c: [f32; 4],
}

impl GimbalTrig {
    pub fn new(delta_rad: &[f32; 4]) -> Self {
        let sc = delta_rad.map(sin_cos);
        Self { s: sc.map(|v| v.0), c: sc.map(|v| v.1) }
    }
}

impl CmgPyramid {
    pub fn new(skew_rad: f32, h0_nms: f32) -> Self {
        let (sin_skew, cos_skew) = sin_cos(skew_rad);
        Self { h0_nms, cos_skew, sin_skew }
    }

    /// Cluster momentum in body axes, N m s (eq 6).
    pub fn momentum(&self, t: &GimbalTrig) -> Vec3 {
        let (cb, sb) = (self.cos_skew, self.sin_skew);
        let [s1, s2, s3, s4] = t.s;
        let [c1, c2, c3, c4] = t.c;
        Vec3::new(-cb * s1 - c2 + cb * s3 + c4, c1 - cb * s2 - c3 + cb * s4, sb * (s1 + s2 + s3 + s4)) * self.h0_nms
    }

    /// Unit-momentum Jacobian `J₁ = ∂h/∂δ / h0` (eq 8).
    pub fn unit_jacobian(&self, t: &GimbalTrig) -> Jacobian {
        let (cb, sb) = (self.cos_skew, self.sin_skew);
        let [s1, s2, s3, s4] = t.s;
        let [c1, c2, c3, c4] = t.c;
        #[rustfmt::skip]
        let j = Jacobian::new(
            -cb * c1,  s2,       cb * c3, -s4,
            -s1,      -cb * c2,  s3,       cb * c4,
             sb * c1,  sb * c2,  sb * c3,  sb * c4,
        );
        j
    }

    /// Jacobian with units, N m s / rad.
    pub fn jacobian(&self, t: &GimbalTrig) -> Jacobian {
        self.unit_jacobian(t) * self.h0_nms
    }

    /// Torque the gimbal rates produce on the body (eq 4): `-J δ̇ - ω × h`.
    pub fn torque_on_body(&self, t: &GimbalTrig, rate_rad_s: &Vec3, gimbal_rate_rad_s: &[f32; 4]) -> Vec3 {
        let d = nalgebra::Vector4::from(*gimbal_rate_rad_s);
        -(self.jacobian(t) * d) - rate_rad_s.cross(&self.momentum(t))
    }

    /// Unit rotor momentum vectors of the four units (columns of eq 6 with `h0 = 1`).
    fn unit_momenta(&self, t: &GimbalTrig) -> [Vec3; 4] {
        let (cb, sb) = (self.cos_skew, self.sin_skew);
        let [s1, s2, s3, s4] = t.s;
        let [c1, c2, c3, c4] = t.c;
        [
            Vec3::new(-cb * s1, c1, sb * s1),
            Vec3::new(-c2, -cb * s2, sb * s2),
            Vec3::new(cb * s3, -c3, sb * s3),
            Vec3::new(c4, cb * s4, sb * s4),
        ]
    }

    /// At a (near-)singular `J₁ J₁ᵀ`: is it the momentum envelope (all unit momenta on
    /// one side of the singular direction)? The singular direction is the largest column
    /// of the adjugate (row cross products), which needs no eigen-solver.
    pub fn at_momentum_envelope(&self, t: &GimbalTrig, jjt: &Mat3) -> bool {
        let r = |i: usize| Vec3::new(jjt[(i, 0)], jjt[(i, 1)], jjt[(i, 2)]);
        let cands = [r(1).cross(&r(2)), r(2).cross(&r(0)), r(0).cross(&r(1))];
        let u =
            cands.iter().fold(Vec3::zeros(), |best, c| if c.norm_squared() > best.norm_squared() { *c } else { best });
        let n = crate::math::norm(&u);
        if !(n > 0.0) || !n.is_finite() {
            return false;
        }
        let u = u / n;
        let p = self.unit_momenta(t).map(|h| h.dot(&u));
        let tol = 0.05;
        p.iter().all(|x| *x > tol) || p.iter().all(|x| *x < -tol)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BETA: f32 = 0.955_233_9; // 54.73 deg

    /// Independent form of eq 6: sum of the four unit vectors as the paper prints them.
    fn momentum_eq6(h0: f64, beta: f64, d: [f64; 4]) -> [f64; 3] {
        let (cb, sb) = (beta.cos(), beta.sin());
        let (s, c) = (d.map(f64::sin), d.map(f64::cos));
        let terms = [
            [-cb * s[0], c[0], sb * s[0]],
            [-c[1], -cb * s[1], sb * s[1]],
            [cb * s[2], -c[2], sb * s[2]],
            [c[3], cb * s[3], sb * s[3]],
        ];
        let mut h = [0.0; 3];
        for t in terms {
            for k in 0..3 {
                h[k] += h0 * t[k];
            }
        }
        h
    }

    #[test]
    fn momentum_matches_eq6_and_zero_gimbals_cancel() {
        let p = CmgPyramid::new(BETA, 0.623);
        let h = p.momentum(&GimbalTrig::new(&[0.0; 4]));
        assert!(h.norm() < 1e-6, "zero gimbals store no momentum: {h:?}");
        let d = [0.3f32, -1.1, 2.0, 0.7];
        let h = p.momentum(&GimbalTrig::new(&d));
        let r = momentum_eq6(0.623, BETA as f64, d.map(|x| x as f64));
        for k in 0..3 {
            assert!((h[k] as f64 - r[k]).abs() < 1e-6);
        }
    }

    #[test]
    fn jacobian_matches_central_differences_of_eq6() {
        let p = CmgPyramid::new(BETA, 0.623);
        for d in [[0.0f32, 0.0, 0.0, 0.0], [0.3, -1.1, 2.0, 0.7], [1.57, 0.0, -1.57, 0.0]] {
            let j = p.jacobian(&GimbalTrig::new(&d));
            let d64 = d.map(|x| x as f64);
            let eps = 1e-6;
            for i in 0..4 {
                let (mut a, mut b) = (d64, d64);
                a[i] += eps;
                b[i] -= eps;
                let (ha, hb) = (momentum_eq6(0.623, BETA as f64, a), momentum_eq6(0.623, BETA as f64, b));
                for k in 0..3 {
                    let fd = (ha[k] - hb[k]) / (2.0 * eps);
                    assert!((j[(k, i)] as f64 - fd).abs() < 1e-5, "J[{k},{i}] {} vs {fd}", j[(k, i)]);
                }
            }
        }
    }

    #[test]
    fn zero_gimbal_singularity_measure_is_the_known_value() {
        // At δ = 0 the columns are [-cβ,0,sβ], [0,-cβ,sβ], [cβ,0,sβ], [0,cβ,sβ]:
        // J₁ J₁ᵀ = diag(2cβ², 2cβ², 4sβ²) → m = 16 cβ⁴ sβ².
        let p = CmgPyramid::new(BETA, 1.0);
        let j = p.unit_jacobian(&GimbalTrig::new(&[0.0; 4]));
        let m = (j * j.transpose()).determinant();
        let (cb, sb) = (BETA.cos(), BETA.sin());
        let expect = 16.0 * cb.powi(4) * sb * sb;
        assert!((m - expect).abs() < 1e-5 * expect);
    }
}
