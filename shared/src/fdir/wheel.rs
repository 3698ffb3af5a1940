//! A reaction wheel's torque residual: the torque commanded to its rotor against the
//! torque its tachometer says the rotor received.
//!
//! Over one control step of `Δt` the motor applies `u` (the command of the previous step,
//! held) to the rotor about its axis `a`; with the relative speed `ω_w` the tachometer
//! reads and the body rate `ω` (paper 001 eqs 4, 23: `I_w (ω̇_w + aᵀω̇) = u − T_e`),
//!
//! `r = u − I_w (Δω_w + aᵀΔω) / Δt`  (N m).
//!
//! A healthy wheel leaves only the friction its speed loop does not reject and the
//! measurement noise: tachometer white noise `σ_t`, quantisation `q` (uniform, `q²/12`)
//! and the gyro's `σ_g` about the axis enter each difference twice, so
//!
//! `σ_r = (I_w/Δt) √(2 (σ_t² + q²/12 + σ_g²))`.
//!
//! A seized rotor, a motor that lost torque or runs away, or a frozen tachometer leaves a
//! residual of the size of the command (or of the runaway torque): the monitor declares
//! the wheel when `|r| > max(n σ_r, floor)` persists ([`super::window`]).

use super::window::Persistence;
use crate::math::f32m;
use crate::params::fdir::{WheelMonitorParams, WheelResidualNoise};
use crate::types::MAX_WHEELS;

/// σ of the torque residual, N m (see the module doc); not finite for a non-positive or
/// non-finite `dt_s`.
pub fn residual_sigma_nm(noise: &WheelResidualNoise, inertia_kgm2: f32, dt_s: f32) -> f32 {
    let var = noise.tach_sigma_rad_s * noise.tach_sigma_rad_s
        + noise.tach_lsb_rad_s * noise.tach_lsb_rad_s / 12.0
        + noise.gyro_sigma_rad_s * noise.gyro_sigma_rad_s;
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return f32::NAN;
    }
    inertia_kgm2 / dt_s * f32m::sqrt(2.0 * var)
}

/// One step's inputs for every wheel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelStep {
    /// The command each rotor received over the step (the previous step's, held), N m.
    pub applied_command_nm: [f32; MAX_WHEELS],
    /// Tachometer readings (relative speed) at the step's end, rad/s.
    pub speed_rad_s: [f32; MAX_WHEELS],
    /// `aᵢᵀ Δω`: the body's rate change about each wheel axis over the step, rad/s (zeros
    /// when not used; then `gyro_sigma_rad_s` should be 0 and the body's reaction counts
    /// as residual, `I_w/I_body` of the command).
    pub axial_body_rate_change_rad_s: [f32; MAX_WHEELS],
    /// The step, s.
    pub dt_s: f32,
    /// Wheels not judged this step (bit `i`: wheel `i`; e.g. at the speed limit, where
    /// the drive itself withholds torque): no residual, no exceedance, window unchanged.
    pub not_judged: u8,
}

/// What the monitor concluded this step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WheelVerdict {
    /// Residuals, N m (0 for a wheel not monitored or before the first difference).
    pub residual_nm: [f32; MAX_WHEELS],
    /// The threshold they were held against, N m (NaN when this step gave no verdict).
    pub threshold_nm: f32,
    /// Wheels whose persistence window fired (bit `i`: wheel `i`).
    pub failed: u8,
    /// Whether this step was judged (false: first step, or `dt_s` not positive/finite).
    pub judged: bool,
}

impl WheelVerdict {
    /// No verdict (the step was not judged).
    pub const NONE: Self = Self { residual_nm: [0.0; MAX_WHEELS], threshold_nm: f32::NAN, failed: 0, judged: false };
}

/// Residual monitors of up to [`MAX_WHEELS`] wheels.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WheelMonitor {
    last_speed_rad_s: Option<[f32; MAX_WHEELS]>,
    persistence: [Persistence; MAX_WHEELS],
}

impl WheelMonitor {
    pub const fn new() -> Self {
        Self { last_speed_rad_s: None, persistence: [Persistence::new(); MAX_WHEELS] }
    }

    /// The speeds of the last judged step (zeros before the first).
    pub fn last_speed(&self) -> [f32; MAX_WHEELS] {
        self.last_speed_rad_s.unwrap_or([0.0; MAX_WHEELS])
    }

    /// Forgets the last speeds (the next step is a first one), keeping the exceedances.
    pub fn restart(&mut self) {
        self.last_speed_rad_s = None;
    }

    /// One step over the first `count` wheels. A non-finite residual (a non-finite speed
    /// or command) is an exceedance; a step with a non-positive or non-finite `dt_s` is not
    /// judged (a repeated frame carries no new difference) and keeps the last speeds.
    pub fn step(&mut self, p: &WheelMonitorParams, count: usize, s: &WheelStep) -> WheelVerdict {
        let sigma = residual_sigma_nm(&p.noise, p.inertia_kgm2, s.dt_s);
        let Some(last) = self.last_speed_rad_s.filter(|_| sigma.is_finite()) else {
            if s.dt_s.is_finite() && s.dt_s > 0.0 || self.last_speed_rad_s.is_none() {
                self.last_speed_rad_s = Some(s.speed_rad_s);
            }
            return WheelVerdict { threshold_nm: f32::NAN, ..WheelVerdict::default() };
        };
        let threshold_nm = (p.threshold_sigma * sigma).max(p.floor_nm);
        let mut v = WheelVerdict { threshold_nm, judged: true, ..WheelVerdict::default() };
        let wheels = s
            .applied_command_nm
            .iter()
            .zip(s.speed_rad_s.iter().zip(last.iter()))
            .zip(s.axial_body_rate_change_rad_s.iter())
            .zip(self.persistence.iter_mut().zip(v.residual_nm.iter_mut()))
            .take(count.min(MAX_WHEELS));
        for (i, (((u, (w, w0)), dw_body), (persist, r))) in wheels.enumerate() {
            if s.not_judged & u8::try_from(i).ok().and_then(|i| 1u8.checked_shl(u32::from(i))).unwrap_or(0) != 0 {
                continue;
            }
            *r = u - p.inertia_kgm2 * ((w - w0) + dw_body) / s.dt_s;
            // `!(≤)`: NaN counts as an exceedance.
            let exceeded = !(r.abs() <= threshold_nm);
            if persist.push(&p.window, exceeded) {
                v.failed |= u8::try_from(i).ok().and_then(|i| 1u8.checked_shl(u32::from(i))).unwrap_or(0);
            }
        }
        self.last_speed_rad_s = Some(s.speed_rad_s);
        v
    }

    /// Forgets wheel `i`'s exceedances (the ground re-enabled it).
    pub fn clear(&mut self, i: usize) {
        if let Some(p) = self.persistence.get_mut(i) {
            p.clear();
        }
    }
}
