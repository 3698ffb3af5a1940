//! The gyro monitor of the estimation stage: a stuck axis (issue 42; docs/fdir.md "Gyro").
//!
//! A live gyro axis carries noise far above its f32 resolution, so it repeats its reading
//! exactly only when stuck (a latched converter, a hung interface): an axis whose rate
//! repeats more than `max_repeats` times in a row over fresh samples (new time tags) is
//! declared failed ([`super::repeat`]; the per-sample false-alarm probability for
//! quantised noise is in docs/fdir.md "Frozen or stuck output").
//!
//! Recovery (documented fallback): a failed axis reads 0 rad/s from then on — rate and
//! angle increment — for every consumer (the filter, the laws), instead of the stuck value
//! that would act as a rate offset; the pointing modes, which need a full rate to hold a
//! fine attitude, lack their input and the mode manager falls back (sun-safe damps the
//! other two axes). The wheel monitor, whose residual uses the gyro, stops judging.

use super::repeat::Repeats;
use crate::math::Vec3;
use crate::params::fdir::GyroFdirParams;
use crate::types::GyroRate;

/// The monitor's state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GyroMonitor {
    repeats: Repeats<3>,
    last_time_us: Option<u64>,
    /// Bit i: axis i (x, y, z) declared failed (stuck, or erratic).
    failed_axes: u8,
    /// Bit i: axis i declared erratic by the bias-step test's repeats
    /// ([`super::bias::ERRATIC_STEPS`]), not by its own repeats.
    erratic_axes: u8,
    events: u16,
}

impl GyroMonitor {
    pub const fn new() -> Self {
        Self { repeats: Repeats::EMPTY, last_time_us: None, failed_axes: 0, erratic_axes: 0, events: 0 }
    }

    /// Judges a sample (a repeated time tag is not judged) and returns it with the failed
    /// axes read as 0.
    pub fn judge(&mut self, p: &GyroFdirParams, g: &GyroRate) -> GyroRate {
        if self.last_time_us != Some(g.time_us) {
            self.last_time_us = Some(g.time_us);
            let r = g.rate_rad_s;
            // Bits 0..=2 of a u32 mask of three components: fits a u8.
            let stuck = u8::try_from(self.repeats.push(p.max_repeats, &[r.x, r.y, r.z]) & 0b111).unwrap_or(0);
            let new = stuck & !self.failed_axes;
            self.events = self.events.saturating_add(u16::from(new != 0));
            self.failed_axes |= new;
        }
        self.without_failed(g)
    }

    fn without_failed(&self, g: &GyroRate) -> GyroRate {
        if self.failed_axes == 0 {
            return *g;
        }
        let keep = Vec3::from_fn(|i, _| if self.failed_axes & (1 << i) == 0 { 1.0 } else { 0.0 });
        let mut out = *g;
        out.rate_rad_s = out.rate_rad_s.component_mul(&keep);
        if let Some(inc) = out.increment.as_mut() {
            inc.angle_rad = inc.angle_rad.component_mul(&keep);
        }
        out
    }

    /// Bit i: axis i declared failed (stuck or erratic).
    pub fn failed_axes(&self) -> u8 {
        self.failed_axes
    }

    /// Bit i: axis i declared erratic ([`Self::fail_erratic`]).
    pub fn erratic_axes(&self) -> u8 {
        self.erratic_axes
    }

    /// The estimation stage declares axis `axis` (0 x, 1 y, 2 z) erratic: the bias-step
    /// test named it [`super::bias::ERRATIC_STEPS`] times in a short span. It is read as 0
    /// from the next sample on, as a stuck axis; an axis already failed, or out of range,
    /// changes nothing.
    pub fn fail_erratic(&mut self, axis: u8) {
        let bit = 1u8.checked_shl(u32::from(axis)).filter(|b| *b <= 0b100).unwrap_or(0);
        if bit != 0 && self.failed_axes & bit == 0 {
            self.failed_axes |= bit;
            self.erratic_axes |= bit;
            self.events = self.events.saturating_add(1);
        }
    }

    /// Gyro axes declared stuck since boot (saturating; a clear does not lower it).
    pub fn events(&self) -> u16 {
        self.events
    }

    /// The ground re-enables the gyro: failures and history forgotten, events kept.
    pub fn clear(&mut self) {
        *self = Self { events: self.events, ..Self::new() };
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn an_erratic_axis_is_failed_once_and_read_as_zero() {
        let mut m = GyroMonitor::new();
        m.fail_erratic(1);
        m.fail_erratic(1);
        m.fail_erratic(9);
        assert_eq!((m.failed_axes(), m.erratic_axes(), m.events()), (0b010, 0b010, 1));
        let g = GyroRate { time_us: 1, rate_rad_s: Vec3::new(0.1, 0.2, 0.3), increment: None };
        assert_eq!(m.without_failed(&g).rate_rad_s, Vec3::new(0.1, 0.0, 0.3));
        m.clear();
        assert_eq!((m.failed_axes(), m.erratic_axes(), m.events()), (0, 0, 1));
    }
    use super::*;

    fn sample(i: u64, r: [f32; 3]) -> GyroRate {
        GyroRate { time_us: 1000 * i, rate_rad_s: Vec3::from(r), increment: None }
    }

    #[test]
    fn a_stuck_axis_is_declared_after_max_repeats_and_then_reads_zero() {
        let p = GyroFdirParams { max_repeats: 3, bias_step: None };
        let mut m = GyroMonitor::new();
        let mut declared_at = None;
        for i in 0..10u64 {
            let live = 1e-3 * (i as f32 + 1.0);
            let out = m.judge(&p, &sample(i, [live, 0.02, -live]));
            if m.failed_axes() != 0 && declared_at.is_none() {
                declared_at = Some(i);
                assert_eq!(out.rate_rad_s, Vec3::new(live, 0.0, -live), "the stuck y axis reads 0");
            }
            // A repeated tag (the same sample again) is not judged.
            m.judge(&p, &sample(i, [live, 0.02, -live]));
        }
        // Sample 0 sets the value; samples 1..=4 repeat it: the 4th repeat exceeds 3.
        assert_eq!((declared_at, m.failed_axes(), m.events()), (Some(4), 0b010, 1));
        m.clear();
        assert_eq!((m.failed_axes(), m.events()), (0, 1));
    }
}
