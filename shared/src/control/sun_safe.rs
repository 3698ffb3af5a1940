//! Sun-pointing safe-mode law: coarse sun sensors + gyro only (no attitude estimate).
//!
//! Goal: turn a body axis `a` (the solar-panel normal) to the Sun, damp the rates, find
//! the Sun from any attitude and hold a power-positive attitude through eclipse. The
//! algorithm only; the mode manager decides when it runs (issue 10).
//!
//! Law (Wie, *Space Vehicle Dynamics and Control*, 2nd ed., 2008, §7.3, eigen-axis
//! pointing of one body axis; Markley & Crassidis 2014, §7.4 sun-safe pointing):
//! - **Pointing** (Sun seen, unit body direction `ŝ`): `T = kp u − Kd ω` with
//!   `u = a × ŝ` (`|u| = sin θ`, θ the panel–Sun angle) while `a·ŝ ≥ 0`, and
//!   `u = (a × ŝ)/|a × ŝ|` beyond 90° (the plain cross product vanishes at the anti-Sun
//!   attitude, an equilibrium the law must not have; within 1e-3 of it the search axis,
//!   which is ⟂ `a`, is used). `kp` is a scalar, `Kd = diag(kd)` positive. With `J` the
//!   inertia and a fixed Sun, `V = kp P(θ) + ½ ωᵀJω` with `P = 1 − cos θ` (θ ≤ 90°),
//!   `P = θ − π/2 + 1` (θ > 90°) has `dV/dt = −ωᵀ Kd ω ≤ 0` while the torque is not
//!   saturated (`dP/dt = −ω·u`, Euler's equations give `d(½ωᵀJω)/dt = ωᵀT`); so the panel
//!   converges to the Sun from every attitude but the measure-zero anti-Sun set.
//!   Saturation scales the whole torque into the per-axis box (direction kept).
//! - **EclipseHold** (Sun not seen, and either `eclipse_expected` — the flight software's
//!   orbit and Sun models say the spacecraft is in the Earth's shadow — or the last
//!   sighting is younger than `sun_timeout_s`): the remembered body direction is
//!   propagated with the gyro, `ŝ ← R(−ω dt) ŝ` (exact rotation for a constant rate over
//!   the step, renormalised; to first order `ŝ − ω × ŝ dt`), and the same pointing law
//!   holds the panel on it: the attitude stays power-positive and the Sun reappears where
//!   expected. The memory drifts at the gyro's bias: after `t` s the remembered direction
//!   is off by at most `|b| t` (plus the angle random walk). With no memory at all
//!   (eclipse from the start) the law only damps rates (`T = −Kd ω`).
//! - **Searching** (Sun not seen, no eclipse expected, memory absent or timed out — a
//!   timed-out memory is discarded, it failed to bring the Sun into view): `T = −Kd (ω −
//!   ω_s e_s)`, a slow rotation about the search axis `e_s ⟂ a`. The panel normal then
//!   sweeps the great circle ⟂ `e_s`; a sensor set with hemispherical coverage about `a`
//!   sees every direction whose angle from that circle is below 90°, i.e. every direction
//!   except exactly ±`e_s`, within one revolution `2π/ω_s` (half a revolution from the
//!   most favourable start). For a non-principal `e_s` the gyroscopic torque `ω × Jω`,
//!   not compensated, leaves a small rate error; choose `e_s` along a principal axis.
//!
//! Non-finite inputs (Sun vector, gyro, `dt`) and a zero Sun vector give zero torque with
//! `input_rejected` set and leave the state unchanged. No heap, no loops, no panics.

use super::scale_to_box;
use crate::math::f32m::{atan2, sin_cos};
use crate::math::{Vec3, all_finite, norm};
use crate::params::sun_safe::{SunSafeError, SunSafeParams};

/// Largest accepted time step (s).
pub const SUN_SAFE_MAX_DT_S: f32 = 10.0;
/// Below this |a × ŝ| beyond 90° (within ~0.06° of anti-Sun) the search axis is the
/// rotation axis.
const ANTI_SUN_SIN: f32 = 1e-3;
/// The memory's age saturates here (s), far above any timeout.
const MAX_AGE_S: f32 = 1e9;

/// What the law is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SunSafePhase {
    /// Sun seen: pointing the panel at it.
    Pointing,
    /// Sun not seen: rotating about the search axis.
    Searching,
    /// Sun not seen, eclipse expected or sighting recent: holding on the gyro-propagated
    /// memory (or only damping rates when there is no memory).
    EclipseHold,
}

/// One step's result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunSafeOutput {
    /// Body torque demand (N m), within the per-axis limits.
    pub torque_nm: Vec3,
    pub phase: SunSafePhase,
    /// Angle between the panel normal and the (seen or remembered) Sun (rad); NaN if the
    /// Sun direction is unknown.
    pub sun_angle_rad: f32,
    /// The torque was scaled into the limits.
    pub saturated: bool,
    /// An input was NaN/inf (or the Sun vector zero): zero torque, state unchanged.
    pub input_rejected: bool,
}

/// The sun-safe law and its state (the remembered Sun direction and its age).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunSafe {
    params: SunSafeParams,
    panel: Vec3,
    search_axis: Vec3,
    kd: Vec3,
    limit: Vec3,
    sun_memory_body: Option<Vec3>,
    memory_age_s: f32,
    phase: SunSafePhase,
}

/// `s` rotated by `−φ` (φ = ω dt, rad): the body-frame motion of an inertially fixed
/// direction over a step at constant rate (Rodrigues; series for small |φ|).
fn rotate_by_minus(s: &Vec3, phi: &Vec3) -> Vec3 {
    let th2 = phi.norm_squared();
    let th = crate::math::f32m::sqrt(th2);
    let (a, b) = if th < 1e-2 {
        // sin θ/θ and (1 − cos θ)/θ² to O(θ⁴): relative error < 1e-10.
        (1.0 - th2 / 6.0, 0.5 - th2 / 24.0)
    } else {
        let (sn, cs) = sin_cos(th);
        (sn / th, (1.0 - cs) / th2)
    };
    let c = phi.cross(s);
    s - c * a + phi.cross(&c) * b
}

impl SunSafe {
    /// A law with no Sun memory (first phase: searching, or damping in an eclipse).
    pub fn new(params: SunSafeParams) -> Result<Self, SunSafeError> {
        params.validate()?;
        Ok(Self {
            params,
            panel: Vec3::from(params.panel_normal_body),
            search_axis: Vec3::from(params.search_axis_body),
            kd: Vec3::from(params.kd_nm_s_per_rad),
            limit: Vec3::from(params.torque_limit_nm),
            sun_memory_body: None,
            memory_age_s: 0.0,
            phase: SunSafePhase::Searching,
        })
    }

    /// Forget the Sun (on mode entry).
    pub fn reset(&mut self) {
        self.sun_memory_body = None;
        self.memory_age_s = 0.0;
        self.phase = SunSafePhase::Searching;
    }

    pub fn params(&self) -> &SunSafeParams {
        &self.params
    }
    pub fn phase(&self) -> SunSafePhase {
        self.phase
    }
    /// The remembered (last seen, gyro-propagated) unit Sun direction in body axes.
    pub fn sun_memory_body(&self) -> Option<Vec3> {
        self.sun_memory_body
    }
    /// Seconds since the Sun was last seen (0 while it is seen).
    pub fn memory_age_s(&self) -> f32 {
        self.memory_age_s
    }

    /// Pointing torque toward unit `s` (module docs), before saturation.
    fn pointing_torque(&self, s: &Vec3, w: &Vec3) -> Vec3 {
        let e = self.panel.cross(s);
        let u = if self.panel.dot(s) >= 0.0 {
            e
        } else {
            let sn = norm(&e);
            if sn > ANTI_SUN_SIN { e / sn } else { self.search_axis }
        };
        u * self.params.kp_nm_per_rad - self.kd.component_mul(w)
    }

    fn angle_to(&self, s: &Vec3) -> f32 {
        atan2(norm(&self.panel.cross(s)), self.panel.dot(s))
    }

    fn rejected(&self) -> SunSafeOutput {
        SunSafeOutput {
            torque_nm: Vec3::zeros(),
            phase: self.phase,
            sun_angle_rad: self.sun_memory_body.map_or(f32::NAN, |m| self.angle_to(&m)),
            saturated: false,
            input_rejected: true,
        }
    }

    /// One control step. `sun_body`: the measured Sun direction (any length > 0, e.g.
    /// [`crate::estimation::css::CssSun::dir_body`]) or `None` when not seen;
    /// `eclipse_expected`: the on-board models place the spacecraft in the Earth's shadow;
    /// `gyro_rad_s`: body rate; `dt_s` in (0, [`SUN_SAFE_MAX_DT_S`]].
    pub fn update(
        &mut self,
        sun_body: Option<Vec3>,
        eclipse_expected: bool,
        gyro_rad_s: &Vec3,
        dt_s: f32,
    ) -> SunSafeOutput {
        if !(all_finite(gyro_rad_s.as_slice()) && dt_s > 0.0 && dt_s <= SUN_SAFE_MAX_DT_S) {
            return self.rejected();
        }
        let seen = match sun_body {
            Some(s) => {
                let n = norm(&s);
                if !(n.is_finite() && n > 0.0) {
                    return self.rejected();
                }
                Some(s / n)
            }
            None => None,
        };
        let w = gyro_rad_s;
        // Next state, committed only if the result is finite.
        let (memory, age, phase, torque) = match seen {
            Some(s) => (Some(s), 0.0, SunSafePhase::Pointing, self.pointing_torque(&s, w)),
            None => {
                let propagated = self.sun_memory_body.map(|m| {
                    let r = rotate_by_minus(&m, &(w * dt_s));
                    let n = norm(&r);
                    r / n
                });
                let age = (self.memory_age_s + dt_s).min(MAX_AGE_S);
                match propagated {
                    Some(m) if eclipse_expected || age < self.params.sun_timeout_s => {
                        (Some(m), age, SunSafePhase::EclipseHold, self.pointing_torque(&m, w))
                    }
                    // No memory, or it timed out in daylight (discarded).
                    _ if eclipse_expected => (None, 0.0, SunSafePhase::EclipseHold, -self.kd.component_mul(w)),
                    _ => {
                        let target = self.search_axis * self.params.search_rate_rad_s;
                        (None, 0.0, SunSafePhase::Searching, -self.kd.component_mul(&(w - target)))
                    }
                }
            }
        };
        let (torque, saturated) = scale_to_box(&torque, &self.limit);
        let memory_ok = memory.is_none_or(|m| all_finite(m.as_slice()));
        if !(memory_ok && all_finite(torque.as_slice())) {
            // e.g. a finite but absurd gyro rate whose rotation angle is out of range.
            return self.rejected();
        }
        self.sun_memory_body = memory;
        self.memory_age_s = age;
        self.phase = phase;
        SunSafeOutput {
            torque_nm: torque,
            phase,
            sun_angle_rad: memory.map_or(f32::NAN, |m| self.angle_to(&m)),
            saturated,
            input_rejected: false,
        }
    }
}
