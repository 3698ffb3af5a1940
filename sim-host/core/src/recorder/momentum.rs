//! Stored-momentum statistics of a run with `[momentum]` (or the momentum FDIR on):
//! every control step (not only the recorded rows), for `summary.json`'s `"momentum"`.
//! Constant memory whatever the duration.

use serde::Serialize;

/// Length of the "first day" window the long-duration figures compare against, s.
pub const DAY_S: f64 = 86_400.0;
/// Start of the first-day pointing window (start-up transients excluded), s.
pub const FIRST_DAY_FROM_S: f64 = 3_600.0;

/// `summary.json` → `"momentum"`.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct MomentumSummary {
    /// Largest and last `|h|` of the stored actuator momentum (truth), N m s.
    pub peak_nms: f64,
    pub final_nms: f64,
    /// Time mean of `|h|`, N m s.
    pub mean_nms: f64,
    /// Time mean of the stored momentum vector in body axes, N m s.
    pub mean_body_nms: [f64; 3],
    /// Largest wheel speed over its limit, whole run and after the first day.
    pub max_wheel_speed_fraction: f64,
    pub max_wheel_speed_fraction_after_first_day: Option<f64>,
    /// The FDIR trip fraction (`[modes] momentum_trip_speed_fraction`; null when off)
    /// and the time any wheel spent above it, s.
    pub trip_speed_fraction: Option<f64>,
    pub time_above_trip_s: Option<f64>,
    /// Momentum FDIR events the flight code reported (last telemetry).
    pub fdir_events: u16,
    /// "Unloading cannot keep up" and CMG gimbal-saturation events the flight code
    /// reported (flag only; present only when `[modes] slow_fdir_persistence_s` > 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub keepup_events: Option<u16>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gimbal_events: Option<u16>,
    /// Pointing error (truth) over [1 h, 1 d) and over [1 d, end], deg (null when the
    /// run does not reach the window).
    pub error_max_first_day_deg: Option<f64>,
    pub error_rms_first_day_deg: Option<f64>,
    pub error_max_after_first_day_deg: Option<f64>,
    pub error_rms_after_first_day_deg: Option<f64>,
}

#[derive(Clone, Debug, Default)]
struct Window {
    max: f64,
    sum_sq: f64,
    n: u64,
}

impl Window {
    fn push(&mut self, x: f64) {
        self.max = self.max.max(x);
        self.sum_sq += x * x;
        self.n += 1;
    }
    fn max(&self) -> Option<f64> {
        (self.n > 0).then_some(self.max)
    }
    fn rms(&self) -> Option<f64> {
        (self.n > 0).then(|| (self.sum_sq / self.n as f64).sqrt())
    }
}

/// Running figures (one `push` per control step).
#[derive(Clone, Debug, Default)]
pub struct MomentumStats {
    trip: Option<f64>,
    dt: f64,
    peak: f64,
    last: f64,
    sum: f64,
    sum_body: [f64; 3],
    n: u64,
    max_frac: f64,
    max_frac_late: Option<f64>,
    above_s: f64,
    events: u16,
    /// Keep-up and gimbal events (None: the slow monitors are off).
    slow_events: Option<(u16, u16)>,
    first_day: Window,
    later: Window,
}

impl MomentumStats {
    /// `trip`: the FDIR trip fraction (None: off); `dt`: control period, s.
    pub fn new(trip: Option<f64>, dt: f64) -> Self {
        Self { trip, dt, ..Self::default() }
    }

    /// One control step at `t`: stored momentum (body), the largest wheel speed fraction,
    /// the pointing error (deg) and the flight code's event count.
    pub fn push(&mut self, t: f64, h_body_nms: [f64; 3], wheel_fraction: f64, err_deg: f64, events: u16) {
        let h = h_body_nms.iter().map(|x| x * x).sum::<f64>().sqrt();
        self.peak = self.peak.max(h);
        self.last = h;
        self.sum += h;
        for (s, x) in self.sum_body.iter_mut().zip(h_body_nms) {
            *s += x;
        }
        self.n += 1;
        self.max_frac = self.max_frac.max(wheel_fraction);
        if t >= DAY_S {
            self.max_frac_late = Some(self.max_frac_late.unwrap_or(0.0).max(wheel_fraction));
            self.later.push(err_deg);
        } else if t >= FIRST_DAY_FROM_S {
            self.first_day.push(err_deg);
        }
        if self.trip.is_some_and(|f| wheel_fraction > f) {
            self.above_s += self.dt;
        }
        self.events = events;
    }

    /// The slow monitors are on: record their counts (last telemetry).
    pub fn slow_events(&mut self, keepup: u16, gimbal: u16) {
        self.slow_events = Some((keepup, gimbal));
    }

    pub fn summary(&self) -> MomentumSummary {
        let n = self.n.max(1) as f64;
        MomentumSummary {
            peak_nms: self.peak,
            final_nms: self.last,
            mean_nms: self.sum / n,
            mean_body_nms: self.sum_body.map(|s| s / n),
            max_wheel_speed_fraction: self.max_frac,
            max_wheel_speed_fraction_after_first_day: self.max_frac_late,
            trip_speed_fraction: self.trip,
            time_above_trip_s: self.trip.map(|_| self.above_s),
            fdir_events: self.events,
            keepup_events: self.slow_events.map(|e| e.0),
            gimbal_events: self.slow_events.map(|e| e.1),
            error_max_first_day_deg: self.first_day.max(),
            error_rms_first_day_deg: self.first_day.rms(),
            error_max_after_first_day_deg: self.later.max(),
            error_rms_after_first_day_deg: self.later.rms(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_follow_their_windows() {
        let mut s = MomentumStats::new(Some(0.5), 10.0);
        s.push(0.0, [3.0, 4.0, 0.0], 0.6, 9.0, 0);
        s.push(FIRST_DAY_FROM_S, [0.0, 0.0, 1.0], 0.4, 1.0, 0);
        s.push(DAY_S, [0.0, 0.0, 2.0], 0.3, 2.0, 1);
        let m = s.summary();
        assert_eq!((m.peak_nms, m.final_nms, m.mean_nms), (5.0, 2.0, 8.0 / 3.0));
        assert_eq!(m.mean_body_nms, [1.0, 4.0 / 3.0, 1.0]);
        assert_eq!((m.max_wheel_speed_fraction, m.max_wheel_speed_fraction_after_first_day), (0.6, Some(0.3)));
        assert_eq!((m.time_above_trip_s, m.fdir_events), (Some(10.0), 1));
        assert_eq!((m.error_max_first_day_deg, m.error_max_after_first_day_deg), (Some(1.0), Some(2.0)));
        assert_eq!(MomentumStats::new(None, 1.0).summary().time_above_trip_s, None);
    }
}
