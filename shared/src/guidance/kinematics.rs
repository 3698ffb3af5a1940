//! Vectors with their first and second time derivatives, and the operations pointing is
//! built from (difference, cross product, unit vector), so that the guided attitude's
//! angular rate and acceleration are the exact derivatives of the guided attitude: the
//! target's motion is fed forward analytically, not by differencing past commands
//! (docs/guidance.md, "Rates").
//!
//! A commanded frame built from two directions has axes `e₁ = p̂`, `e₂ = (p̂ × ŝ)/|p̂ × ŝ|`,
//! `e₃ = e₁ × e₂`; a frame whose axes move as `ėᵢ = ω × eᵢ` has
//! `ω = ½ Σ eᵢ × ėᵢ` and, differentiating once more (`ėᵢ × ėᵢ = 0`),
//! `ω̇ = ½ Σ eᵢ × ëᵢ` ([`FrameKin::rates`]).

use crate::math::{Vec3, norm};

/// Smallest vector length [`VecKin::unit`] normalises (below it the direction is undefined).
pub const MIN_LENGTH: f32 = 1.0e-20;

/// A vector `x(t)` with `ẋ` and `ẍ`, at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VecKin {
    pub x: Vec3,
    pub dx: Vec3,
    pub ddx: Vec3,
}

impl VecKin {
    /// A vector fixed in the frame its derivatives are taken in.
    pub fn constant(x: Vec3) -> Self {
        Self { x, dx: Vec3::zeros(), ddx: Vec3::zeros() }
    }

    pub fn new(x: Vec3, dx: Vec3, ddx: Vec3) -> Self {
        Self { x, dx, ddx }
    }

    /// `self − other`.
    pub fn minus(&self, other: &Self) -> Self {
        Self { x: self.x - other.x, dx: self.dx - other.dx, ddx: self.ddx - other.ddx }
    }

    /// `−self`.
    pub fn negated(&self) -> Self {
        Self { x: -self.x, dx: -self.dx, ddx: -self.ddx }
    }

    /// `self × other`: `(a × b)˙ = ȧ × b + a × ḃ`, `(a × b)¨ = ä × b + 2 ȧ × ḃ + a × b̈`.
    pub fn cross(&self, other: &Self) -> Self {
        let (a, b) = (self, other);
        Self {
            x: a.x.cross(&b.x),
            dx: a.dx.cross(&b.x) + a.x.cross(&b.dx),
            ddx: a.ddx.cross(&b.x) + a.dx.cross(&b.dx) * 2.0 + a.x.cross(&b.ddx),
        }
    }

    /// The unit vector `u = x/n`, `n = |x|`, with `u̇ = (ẋ − u ṅ)/n`, `ṅ = u·ẋ`, and
    /// `ü = (ẍ − u n̈ − 2 u̇ ṅ)/n`, `n̈ = u̇·ẋ + u·ẍ` (from differentiating `n u = x` twice).
    /// `None` for a vector shorter than [`MIN_LENGTH`] or not finite.
    pub fn unit(&self) -> Option<Self> {
        let n = norm(&self.x);
        if !(n.is_finite() && n > MIN_LENGTH) {
            return None;
        }
        let u = self.x / n;
        let n_dot = u.dot(&self.dx);
        let u_dot = (self.dx - u * n_dot) / n;
        let n_ddot = u_dot.dot(&self.dx) + u.dot(&self.ddx);
        let u_ddot = (self.ddx - u * n_ddot - u_dot * (2.0 * n_dot)) / n;
        let out = Self { x: u, dx: u_dot, ddx: u_ddot };
        out.is_finite().then_some(out)
    }

    /// Every component of the vector and its derivatives is finite.
    pub fn is_finite(&self) -> bool {
        [self.x, self.dx, self.ddx].iter().all(|v| v.iter().all(|c| c.is_finite()))
    }
}

/// The three axes of a moving right-handed orthonormal frame (in the frame the
/// derivatives are taken in), with their derivatives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameKin {
    pub e1: VecKin,
    pub e2: VecKin,
    pub e3: VecKin,
}

impl FrameKin {
    /// The frame of two directions: `e₁` along `primary`, `e₂` along `primary × secondary`,
    /// `e₃ = e₁ × e₂` (so `secondary` lies in the `e₁`–`e₃` half-plane with `e₃·ŝ ≥ 0`).
    /// `None` when either is zero or they are parallel (the caller's fallback).
    pub fn from_two(primary: &VecKin, secondary: &VecKin) -> Option<Self> {
        let e1 = primary.unit()?;
        let e2 = e1.cross(secondary).unit()?;
        let e3 = e1.cross(&e2);
        Some(Self { e1, e2, e3 })
    }

    /// Angular velocity and acceleration of the frame, in the axes the derivatives are
    /// taken in: `ω = ½ Σ eᵢ × ėᵢ`, `ω̇ = ½ Σ eᵢ × ëᵢ`.
    pub fn rates(&self) -> (Vec3, Vec3) {
        let axes = [&self.e1, &self.e2, &self.e3];
        let w = axes.iter().fold(Vec3::zeros(), |acc, e| acc + e.x.cross(&e.dx)) * 0.5;
        let w_dot = axes.iter().fold(Vec3::zeros(), |acc, e| acc + e.x.cross(&e.ddx)) * 0.5;
        (w, w_dot)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A vector rotating at a constant rate about z with a growing length: its unit
    /// vector's derivatives are known in closed form.
    #[test]
    fn unit_vector_of_a_rotating_vector_has_the_closed_form_derivatives() {
        let (w, t, r0, rdot) = (0.3f32, 0.7f32, 2.0f32, 0.5f32);
        let (s, c) = crate::math::f32m::sin_cos(w * t);
        let r = r0 + rdot * t;
        // x = r (cos wt, sin wt, 0)
        let x = Vec3::new(r * c, r * s, 0.0);
        let dx = Vec3::new(rdot * c - r * w * s, rdot * s + r * w * c, 0.0);
        let ddx = Vec3::new(-2.0 * rdot * w * s - r * w * w * c, 2.0 * rdot * w * c - r * w * w * s, 0.0);
        let u = VecKin::new(x, dx, ddx).unit().unwrap();
        let expect =
            VecKin::new(Vec3::new(c, s, 0.0), Vec3::new(-w * s, w * c, 0.0), Vec3::new(-w * w * c, -w * w * s, 0.0));
        for (a, b) in [(u.x, expect.x), (u.dx, expect.dx), (u.ddx, expect.ddx)] {
            assert!((a - b).norm() < 1e-6, "{a:?} vs {b:?}");
        }
    }

    #[test]
    fn a_frame_spun_about_a_fixed_axis_has_that_rate_and_no_acceleration() {
        let w = Vec3::new(0.1, -0.2, 0.3);
        // Two body-fixed vectors rotating rigidly: ẋ = ω × x, ẍ = ω × (ω × x).
        let moving = |x: Vec3| VecKin::new(x, w.cross(&x), w.cross(&w.cross(&x)));
        let f = FrameKin::from_two(&moving(Vec3::new(1.0, 0.2, 0.0)), &moving(Vec3::new(0.0, 1.0, 0.5))).unwrap();
        let (rate, acc) = f.rates();
        assert!((rate - w).norm() < 1e-6, "{rate:?}");
        assert!(acc.norm() < 1e-6, "{acc:?}");
    }

    #[test]
    fn degenerate_inputs_give_none() {
        let z = VecKin::constant(Vec3::zeros());
        assert!(z.unit().is_none());
        let a = VecKin::constant(Vec3::new(1.0, 0.0, 0.0));
        assert!(FrameKin::from_two(&a, &a).is_none());
        assert!(VecKin::constant(Vec3::new(f32::NAN, 0.0, 1.0)).unit().is_none());
    }
}
