//! Continuity across a change of pointing: the command in force when the change happens
//! (`q₀`, inertial rate `ω₀`) is carried on at that rate, `q_a(t) = Exp(ω₀ Δt) q₀`, and
//! rotated into the new pointing's command `q_b(t)` along the short rotation `φ` (inertial
//! axes) between them: `q(t) = Exp(s(τ) φ) q_a(t)`, `τ = Δt/T`, with the quintic
//! smoothstep `s = 10τ³ − 15τ⁴ + 6τ⁵`, whose first and second derivatives vanish at both
//! ends. So at the switch the command, its rate and its acceleration are those of the
//! old command, and at `τ = 1` exactly the new one's.
//!
//! Rate and acceleration during the blend: `ω = (1 − s) ω₀ + s ω_b + ṡ φ` and
//! `ω̇ = s ω̇_b + 2 ṡ (ω_b − ω₀) + s̈ φ`, exact when `φ` keeps its axis; the error is of
//! order `|φ| |ω_b − ω₀|` (docs/guidance.md, "Transitions"). Planned, rate- and
//! torque-limited slews are a separate matter (they replace a blend where configured).

use super::Guided;
use super::profile::Profile;
use crate::math::f32m::{atan2, sin_cos};
use crate::math::{Quat, Vec3, norm, quat_normalized};

/// How the blend weight `s` runs from 0 to 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// The quintic smoothstep over a duration, s.
    Quintic { duration_s: f32 },
    /// A rate- and acceleration-limited rest-to-rest profile over the angle between the
    /// two commands at the start ([`super::profile`]): `s = angle(t)/Θ`, so a slew between
    /// two fixed attitudes is the exact eigen-axis bang-coast-bang manoeuvre.
    Profile(Profile),
}

impl Shape {
    fn duration_s(&self) -> f32 {
        match self {
            Self::Quintic { duration_s } => *duration_s,
            Self::Profile(p) => p.duration_s(),
        }
    }

    /// `(s, ṡ, s̈)` at `dt` into the blend (`dt < duration`).
    fn weight(&self, dt: f32) -> (f32, f32, f32) {
        match self {
            Self::Quintic { duration_s } => {
                let tau = dt / duration_s;
                let (t2, t3) = (tau * tau, tau * tau * tau);
                let s = t3 * (10.0 - 15.0 * tau + 6.0 * t2);
                let s_dot = 30.0 * t2 * (1.0 - tau) * (1.0 - tau) / duration_s;
                let s_ddot = 60.0 * tau * (1.0 - 3.0 * tau + 2.0 * t2) / (duration_s * duration_s);
                (s, s_dot, s_ddot)
            }
            Self::Profile(p) if p.angle_rad > 0.0 => {
                let x = p.at(dt);
                (x.angle_rad / p.angle_rad, x.rate_rad_s / p.angle_rad, x.accel_rad_s2 / p.angle_rad)
            }
            Self::Profile(_) => (1.0, 0.0, 0.0),
        }
    }
}

/// A blend in progress.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blend {
    from: Guided,
    start_us: u64,
    shape: Shape,
    /// The rotation it started along (planned slews): a rotation near 180° toward a moving
    /// target keeps this sense instead of flipping to the other short way.
    sense: Option<Vec3>,
}

/// `Exp(v)`: the unit quaternion of the rotation vector `v` (rad).
pub fn quat_exp(v: &Vec3) -> Quat {
    let angle = norm(v);
    if !(angle > 1.0e-12) {
        return Quat::new(1.0, 0.5 * v.x, 0.5 * v.y, 0.5 * v.z);
    }
    let (s, c) = sin_cos(0.5 * angle);
    let a = v * (s / angle);
    Quat::new(c, a.x, a.y, a.z)
}

/// `Log(q)`: the rotation vector of a unit quaternion, the short way (angle ≤ π).
pub fn quat_log(q: &Quat) -> Vec3 {
    let q = if q.w < 0.0 { -q } else { *q };
    let v = q.imag();
    let n = norm(&v);
    if !(n > 1.0e-12) {
        return v * 2.0;
    }
    v * (2.0 * atan2(n, q.w) / n)
}

impl Blend {
    /// A quintic blend over `duration_s`.
    pub fn new(from: Guided, start_us: u64, duration_s: f32) -> Self {
        Self { from, start_us, shape: Shape::Quintic { duration_s }, sense: None }
    }

    /// A blend of any shape.
    pub fn shaped(from: Guided, start_us: u64, shape: Shape) -> Self {
        Self { from, start_us, shape, sense: None }
    }

    /// The same blend kept turning in the sense of `rotation`.
    pub fn keeping_sense(self, rotation: Vec3) -> Self {
        Self { sense: Some(rotation), ..self }
    }

    /// The command it starts from, when, and its shape.
    pub fn from(&self) -> Guided {
        self.from
    }

    pub fn start_us(&self) -> u64 {
        self.start_us
    }

    pub fn shape(&self) -> Shape {
        self.shape
    }

    /// When it ends, µs on the flight clock (`None` for a non-finite duration).
    pub fn end_us(&self) -> Option<u64> {
        let d = self.shape.duration_s();
        // Finite, non-negative and below 2^53 µs (checked): the conversion is exact enough.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        (0.0..1.0e9).contains(&d).then(|| self.start_us.saturating_add((d * 1.0e6) as u64))
    }

    /// The blended command at `now_us` toward `to`; `None` once the blend is over (or
    /// before it began: a clock that stepped back ends it).
    pub fn apply(&self, to: &Guided, now_us: u64) -> Option<Guided> {
        let dt = crate::estimation::history::span_s(self.start_us, now_us)?;
        let duration = self.shape.duration_s();
        if !(duration > 0.0) || dt >= duration {
            return None;
        }
        let (s, s_dot, s_ddot) = self.shape.weight(dt);
        let w0 = self.from.rate_rad_s;
        let q_a = quat_exp(&(w0 * dt)) * self.from.q;
        let mut phi = quat_log(&(to.q * q_a.conjugate()));
        if let Some(r) = self.sense {
            let n = norm(&phi);
            // The other way round by 2π − n (only past a quarter turn, where the flip can be).
            if phi.dot(&r) < 0.0 && n > core::f32::consts::FRAC_PI_2 {
                phi *= (n - core::f32::consts::TAU) / n;
            }
        }
        let q = quat_normalized(&(quat_exp(&(phi * s)) * q_a))?;
        let rate = w0 * (1.0 - s) + to.rate_rad_s * s + phi * s_dot;
        let accel = to.accel_rad_s2 * s + (to.rate_rad_s - w0) * (2.0 * s_dot) + phi * s_ddot;
        let out = Guided { q, rate_rad_s: rate, accel_rad_s2: accel };
        let finite = q.coords.iter().chain(rate.iter()).chain(accel.iter()).all(|x| x.is_finite());
        finite.then_some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{EulerSeq, quat_from_euler, rotation_angle};

    fn g(q: Quat, w: Vec3) -> Guided {
        Guided { q, rate_rad_s: w, accel_rad_s2: Vec3::zeros() }
    }

    #[test]
    fn exp_and_log_are_inverse() {
        for v in [Vec3::new(0.3, -1.2, 2.0), Vec3::new(1e-7, 0.0, 0.0), Vec3::zeros()] {
            let back = quat_log(&quat_exp(&v));
            assert!((back - v).norm() < 1e-5, "{v:?} -> {back:?}");
        }
    }

    /// The blend starts on the old command (attitude and rate), ends on the new one,
    /// and the attitude moves continuously in between (no step larger than the rates
    /// allow over one sample).
    #[test]
    fn a_blend_is_continuous_from_the_old_command_to_the_new() {
        let from = g(Quat::identity(), Vec3::new(0.0, 0.0, 0.01));
        let to = g(quat_from_euler([0.0, 0.5, 1.0], EulerSeq::Zyx321), Vec3::new(0.002, 0.0, 0.0));
        let b = Blend::new(from, 0, 20.0);
        let start = b.apply(&to, 0).unwrap();
        assert!(rotation_angle(&(start.q * from.q.conjugate())) < 1e-6);
        assert!((start.rate_rad_s - from.rate_rad_s).norm() < 1e-7);
        assert!(b.apply(&to, 20_000_000).is_none());
        let near_end = b.apply(&to, 19_999_000).unwrap();
        assert!(rotation_angle(&(near_end.q * to.q.conjugate())) < 1e-4);
        let mut prev = start.q;
        for k in 1..200u64 {
            let now = b.apply(&to, k * 100_000).unwrap();
            // 0.1 s steps: at most |ω| dt with |ω| ≤ |φ| max ṡ + rates ≈ 1.2 × 1.875/20.
            assert!(rotation_angle(&(now.q * prev.conjugate())) < 0.015, "step {k}");
            prev = now.q;
        }
    }
}
