//! Guidance: the commanded attitude and rate the laws track (target in the inertial or in
//! a reference frame such as LVLH), and the clock of the GSR steering dither.

use crate::math::{Quat, Vec3, rotate_ref_to_body};
use crate::params::{SteeringLaw, SteeringParams, TargetFrame};
use crate::types::{Measurements, Setpoint};

/// A target attitude and the frame it is given in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Target {
    /// Target attitude (unit): relative to inertial, or to the reference frame.
    pub q: Quat,
    pub frame: TargetFrame,
}

impl Target {
    /// The target frame needs the on-board navigation solution (LVLH).
    pub fn needs_navigation(&self) -> bool {
        self.frame == TargetFrame::Reference
    }

    /// Commanded attitude and rate (body axes) for these measurements.
    pub fn command_frame(&self, m: &Measurements) -> (Quat, Vec3) {
        match self.frame {
            TargetFrame::Inertial => (self.q, Vec3::zeros()),
            TargetFrame::Reference => (m.q_ref * self.q, rotate_ref_to_body(&m.q, &m.ref_rate_rad_s)),
        }
    }

    /// The set point of one step; `steering`: the CMG steering law, if any (its dither).
    pub fn setpoint(&self, m: &Measurements, steering: Option<&SteeringParams>, time_us: u64) -> Setpoint {
        let (q_cmd, rate_cmd_rad_s) = self.command_frame(m);
        Setpoint { q_cmd, rate_cmd_rad_s, dither_time_s: steering.map_or(0.0, |s| dither_time_s(s, time_us)) }
    }
}

/// The GSR dither phase only matters modulo its period: reduce the clock there so f32
/// keeps full resolution for ever.
pub fn dither_time_s(p: &SteeringParams, time_us: u64) -> f32 {
    match p.law {
        SteeringLaw::GeneralizedSr { omega_rad_s, .. } if omega_rad_s > 0.0 => {
            // Float → integer `as` saturates (and maps NaN to 0); ω > 0 keeps it positive.
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let period_us = ((core::f32::consts::TAU / omega_rad_s) * 1.0e6) as u64;
            time_us.checked_rem(period_us.max(1)).unwrap_or(0) as f32 * 1.0e-6
        }
        _ => 0.0,
    }
}
