//! The mode step of `Fsw::step`: mode logic on the active mode's view of the measurements.

use super::{Fsw, validate};
use crate::estimation::determination::Estimate;
use crate::link::SensorFrame;
use crate::math::{attitude_error, norm, rotation_angle};
use crate::modes::{MODE_COUNT, ModeInputs};
use crate::types::Valid;

impl Fsw {
    /// Mode logic on the active mode's view of the measurements; switches `active`. The
    /// rate trigger needs only the gyro: a tumble that blinds the star tracker must still
    /// reach detumble. Without the active mode's inputs, error and relative rate are NaN
    /// (never converged, never off target).
    pub(super) fn update_mode(&mut self, f: &SensorFrame, est: &Estimate) {
        let (Some(mgr), Some(Some(cfg))) = (self.manager.as_mut(), self.slots.get(self.active)) else {
            return;
        };
        let Some(w) = est.rate_rad_s else {
            return;
        };
        let (error_rad, rel_rate_rad_s) =
            match validate::check_frame(f, cfg.required | Valid::ATTITUDE, cfg.needs_navigation, est) {
                Ok(m) => {
                    let (q_cmd, w_cmd) = cfg.target.command_frame(&m);
                    (rotation_angle(&attitude_error(&m.q, &q_cmd)), norm(&(m.rate_rad_s - w_cmd)))
                }
                Err(_) => (f32::NAN, f32::NAN),
            };
        let mut inputs_ok = [false; MODE_COUNT];
        for (ok, slot) in inputs_ok.iter_mut().zip(self.slots.iter()) {
            *ok = slot.as_ref().is_some_and(|c| validate::check_frame(f, c.required, c.needs_navigation, est).is_ok());
        }
        let inputs = ModeInputs { rate_rad_s: norm(&w), rel_rate_rad_s, error_rad, inputs_ok };
        if let Some((mode, _)) = mgr.update(&inputs) {
            self.active = mode.index();
            self.reset_law_state();
        }
    }
}
