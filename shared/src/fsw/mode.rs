//! The mode step of `Fsw::step`: mode logic on the active mode's view of the measurements.

use super::{Fsw, check};
use crate::allocation::effectiveness::cmg::{CmgPyramid, GimbalTrig};
use crate::allocation::effectiveness::wheels::stored_momentum_nms;
use crate::estimation::determination::Estimate;
use crate::link::SensorFrame;
use crate::math::{attitude_error, norm, rotation_angle};
use crate::modes::ModeInputs;
use crate::params::{ActuatorParams, MODE_COUNT, WheelParams};
use crate::types::Valid;

/// Whether a set flying wheels still has three axes of torque with the wheels FDIR dropped
/// (`lost`) and its own failed ones out: a wheel mode without them lacks an input, and the
/// mode manager falls back as for a lost sensor (docs/fdir.md "Wiring"). True for other
/// families and when FDIR dropped nothing (no cost on the healthy path).
fn wheels_span(p: &crate::params::FlightParams, lost: u8) -> bool {
    let ActuatorParams::Wheels(w) = &p.actuator else { return true };
    if lost == 0 {
        return true;
    }
    let healthy = !u32::from(w.failed_mask | lost);
    let m = crate::allocation::effectiveness::wheels::axes_gram(w, usize::from(w.count), healthy);
    crate::allocation::effectiveness::wheels::spans_three_axes(&m)
}

impl Fsw {
    /// Mode logic on the active mode's view of the measurements; switches `active`. The
    /// rate trigger needs only the gyro: a tumble that blinds the star tracker must still
    /// reach detumble. Without the active mode's inputs, error and relative rate are NaN
    /// (never converged, never off target).
    pub(super) fn update_mode(&mut self, f: &SensorFrame, est: &Estimate) {
        let wheel_speed_fraction = self.wheel_speed_fraction(f);
        let stored_momentum_fraction = self.stored_momentum_fraction(f);
        let gimbal_saturated = self.gimbal_saturated(f);
        let (Some(mgr), Some(Some(cfg))) = (self.manager.as_mut(), self.slots.get(self.active)) else {
            return;
        };
        let Some(w) = est.rate_rad_s else {
            return;
        };
        let (error_rad, rel_rate_rad_s) =
            match check::check_frame(f, cfg.required | Valid::ATTITUDE, cfg.needs_navigation, est) {
                Ok(m) => {
                    let (q_cmd, w_cmd) = cfg.guidance.reference(&m);
                    (rotation_angle(&attitude_error(&m.q, &q_cmd)), norm(&(m.rate_rad_s - w_cmd)))
                }
                Err(_) => (f32::NAN, f32::NAN),
            };
        let lost = self.wheel_fdir.failed_mask();
        // A stuck gyro axis (read as 0) cannot carry a fine attitude: the pointing laws lack
        // their input; the rate-only laws (B-dot, rate damping, sun-safe) go on.
        let gyro_failed = self.determination.gyro_monitor().failed_axes() != 0;
        let mut inputs_ok = [false; MODE_COUNT];
        for (ok, slot) in inputs_ok.iter_mut().zip(self.slots.iter()) {
            *ok = slot.as_ref().is_some_and(|c| {
                check::check_frame(f, c.required, c.needs_navigation, est).is_ok()
                    && wheels_span(&c.params, lost)
                    && !(gyro_failed && c.required.contains(Valid::ATTITUDE))
            });
        }
        let inputs = ModeInputs {
            rate_rad_s: norm(&w),
            rel_rate_rad_s,
            error_rad,
            inputs_ok,
            wheel_speed_fraction,
            stored_momentum_fraction,
            gimbal_saturated,
        };
        if let Some((mode, _)) = mgr.update(&inputs) {
            self.switch_slot(mode.index());
        }
    }

    /// The wheel array of the first slot that has one (the wheels are the same whichever
    /// mode runs).
    fn wheel_array(&self) -> Option<WheelParams> {
        self.slots.iter().flatten().find_map(|c| match &c.params.actuator {
            ActuatorParams::Wheels(w) => Some(*w),
            _ => None,
        })
    }

    /// Stored wheel momentum `|Σ a_i J_w Ω_i|` over `J_w Ω_max` (the keep-up monitor);
    /// NaN without valid wheel speeds or a wheel array (never trips).
    fn stored_momentum_fraction(&self, f: &SensorFrame) -> f32 {
        let Some(w) = self.wheel_array().filter(|_| Valid::from_bits_truncate(f.valid).contains(Valid::WHEELS)) else {
            return f32::NAN;
        };
        if self.manager.as_ref().is_none_or(|m| m.params.slow_fdir_persistence_s <= 0.0) {
            return f32::NAN;
        }
        let h = stored_momentum_nms(&w, &f.wheel_speed_rad_s);
        norm(&h) / (w.inertia_kgm2 * w.max_speed_rad_s)
    }

    /// A CMG gimbal within 1e-3 rad of its angle limit, or `det(J₁J₁ᵀ)` below
    /// `gimbal_singularity_min` (CMG geometry of the first CMG slot; false without CMGs,
    /// valid gimbal angles or the monitor).
    fn gimbal_saturated(&self, f: &SensorFrame) -> bool {
        const MARGIN_RAD: f32 = 1e-3;
        let Some(mgr) = self.manager.as_ref().filter(|m| m.params.slow_fdir_persistence_s > 0.0) else {
            return false;
        };
        let cmg = self.slots.iter().flatten().find_map(|c| match &c.params.actuator {
            ActuatorParams::Cmg { cmg, .. } => Some(*cmg),
            _ => None,
        });
        let Some(c) = cmg.filter(|_| Valid::from_bits_truncate(f.valid).contains(Valid::GIMBALS)) else {
            return false;
        };
        let at_limit = f.gimbal_angle_rad.iter().enumerate().any(|(i, d)| {
            let live = u32::from(c.failed_mask) & crate::allocation::thruster::lp::bit_of(i) == 0;
            live && (*d <= c.gimbal_min_rad + MARGIN_RAD || *d >= c.gimbal_max_rad - MARGIN_RAD)
        });
        let min = mgr.params.gimbal_singularity_min;
        if at_limit || !(min > 0.0) {
            return at_limit;
        }
        let p = CmgPyramid::new(c.skew_rad, c.h0_nms);
        let j1 = p.unit_jacobian(&GimbalTrig::new(&f.gimbal_angle_rad));
        (j1 * j1.transpose()).determinant() < min
    }

    /// Largest measured wheel speed as a fraction of its limit, from the first slot with
    /// a wheel array (the wheels are the same whichever mode runs); NaN without valid
    /// wheel speeds (the momentum monitor never trips on missing data).
    fn wheel_speed_fraction(&self, f: &SensorFrame) -> f32 {
        if !Valid::from_bits_truncate(f.valid).contains(Valid::WHEELS) {
            return f32::NAN;
        }
        let wheels = self.slots.iter().flatten().find_map(|c| match &c.params.actuator {
            ActuatorParams::Wheels(w) => Some(*w),
            _ => None,
        });
        let Some(w) = wheels else {
            return f32::NAN;
        };
        let mut peak = 0.0f32;
        for s in f.wheel_speed_rad_s.iter().take(usize::from(w.count)) {
            let x = libm::fabsf(*s) / w.max_speed_rad_s;
            // NaN propagates (not `max`, which would drop it).
            peak = if x > peak || x.is_nan() { x } else { peak };
        }
        peak
    }
}
