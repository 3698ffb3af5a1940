//! The wheel FDIR chain the flight step runs (docs/fdir.md "Wiring"): detection by the
//! torque residual ([`super::wheel`]), isolation of each newly declared wheel to its rotor
//! or its tachometer ([`super::isolate`]), recovery by dropping the wheel from the
//! allocation (its bit in [`WheelFdir::failed_mask`], OR-ed into the wheel parameters'
//! own failure mask by the caller), and the telemetry of every step.
//!
//! Recovery is the same whatever the isolation says: a wheel whose tachometer lies cannot
//! be kept in the null-space and speed-limit management either, so it is dropped too; the
//! isolation is reported so that the ground knows what to look at. A ground clear
//! re-enables the wheel and forgets its exceedances.
//!
//! Inputs are the frame's tachometer speeds and gyro rate, differenced over the frame
//! times; a step without both samples valid, or with a non-increasing time (a repeated or
//! late frame), is not judged and starts the differences afresh. Bounded: at most
//! `MAX_WHEELS` residuals and isolations per step.

use super::isolate::{WheelIsolation, body_mismatch_nm, isolate_wheel};
use super::wheel::{WheelMonitor, WheelStep, WheelVerdict};
use crate::allocation::effectiveness::wheels::{stored_momentum_nms, torque_on_body_nm};
use crate::link::{FdirTelemetry, SensorFrame};
use crate::math::{self, Mat3, Vec3, f32m};
use crate::params::WheelParams;
use crate::params::fdir::WheelFdirParams;
use crate::types::{MAX_WHEELS, Valid};

/// Fraction of the speed limit below it where a wheel is not judged (the drive's own
/// limiter fades the torque there; the simulator's ideal wheel over the last 1 %).
pub const SPEED_LIMIT_BAND: f32 = 0.02;

/// The last judged sample: frame time and gyro rate (the monitor keeps the speeds).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Sample {
    time_us: u64,
    rate_rad_s: Vec3,
}

/// Wheel FDIR state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WheelFdir {
    monitor: WheelMonitor,
    /// The commands of the last step, which the motors hold over this one, N m.
    applied_nm: [f32; MAX_WHEELS],
    last: Option<Sample>,
    verdict: WheelVerdict,
    failed: u8,
    tachometer: u8,
    ambiguous: u8,
    events: u16,
}

/// Bit `i` of a `u8` mask (0 beyond 7).
fn bit(i: usize) -> u8 {
    u32::try_from(i).ok().and_then(|i| 1u8.checked_shl(i)).unwrap_or(0)
}

impl WheelFdir {
    pub const fn new() -> Self {
        Self {
            monitor: WheelMonitor::new(),
            applied_nm: [0.0; MAX_WHEELS],
            last: None,
            verdict: WheelVerdict::NONE,
            failed: 0,
            tachometer: 0,
            ambiguous: 0,
            events: 0,
        }
    }

    /// Wheels declared failed (bit `i`: wheel `i`), to drop from the allocation.
    pub fn failed_mask(&self) -> u8 {
        self.failed
    }

    /// The commands the motors hold until the next step (what this step returned).
    pub fn command_sent(&mut self, torque_nm: &[f32; MAX_WHEELS]) {
        self.applied_nm = *torque_nm;
    }

    /// A step without the monitor (off, or the family in force has no wheels): the next
    /// judged step starts its differences afresh.
    pub fn skip(&mut self) {
        self.last = None;
        self.monitor.restart();
        self.verdict = WheelVerdict::NONE;
    }

    /// One step on the wheels `w` of a body of inertia `inertia`.
    pub fn step(&mut self, p: &WheelFdirParams, w: &WheelParams, inertia: &Mat3, f: &SensorFrame) {
        let valid = Valid::from_bits_retain(f.valid);
        if !valid.contains(Valid::WHEELS | Valid::RATE) {
            return self.skip();
        }
        let rate = Vec3::from(f.rate_rad_s);
        let dt_s = match self.last {
            Some(l) => match f.time_us.checked_sub(l.time_us).filter(|d| *d > 0) {
                Some(d_us) => d_us as f32 * 1e-6,
                // A repeated or late frame: not judged, the last sample kept.
                None => {
                    self.verdict = WheelVerdict::NONE;
                    return;
                }
            },
            None => 0.0,
        };
        let step = WheelStep {
            applied_command_nm: self.applied_nm,
            speed_rad_s: f.wheel_speed_rad_s,
            axial_body_rate_change_rad_s: self.axial_rate_change(w, &rate),
            dt_s,
            not_judged: near_speed_limit(w, &f.wheel_speed_rad_s) | near_speed_limit(w, &self.monitor.last_speed()),
        };
        let count = usize::from(w.count).min(MAX_WHEELS);
        self.verdict = self.monitor.step(&p.monitor(w.inertia_kgm2), count, &step);
        let new = self.verdict.failed & !self.failed & !w.failed_mask;
        if new != 0 {
            self.isolate(p, w, inertia, &step, &rate, new);
        }
        self.last = Some(Sample { time_us: f.time_us, rate_rad_s: rate });
    }

    /// `aᵢᵀ Δω` per wheel (zeros on the first sample).
    fn axial_rate_change(&self, w: &WheelParams, rate: &Vec3) -> [f32; MAX_WHEELS] {
        let mut out = [0.0; MAX_WHEELS];
        if let Some(l) = &self.last {
            let d = rate - l.rate_rad_s;
            for (o, a) in out.iter_mut().zip(w.axes.iter()) {
                *o = Vec3::from(*a).dot(&d);
            }
        }
        out
    }

    /// Names each newly declared wheel of `new` and drops it (an event each).
    fn isolate(&mut self, p: &WheelFdirParams, w: &WheelParams, j: &Mat3, s: &WheelStep, rate: &Vec3, new: u8) {
        let count = usize::from(w.count).min(MAX_WHEELS);
        let before = self.last.map_or(*rate, |l| l.rate_rad_s);
        // The torques the tachometers imply, `u − r`, and their reaction on the body.
        let mut tach_nm = [0.0f32; MAX_WHEELS];
        for (t, (u, r)) in tach_nm.iter_mut().zip(s.applied_command_nm.iter().zip(self.verdict.residual_nm.iter())) {
            *t = u - r;
        }
        let tach_axes_nm = -torque_on_body_nm(w, count, &tach_nm);
        let h = stored_momentum_nms(w, &s.speed_rad_s);
        let m = body_mismatch_nm(j, &before, rate, s.dt_s, &h, &tach_axes_nm);
        let sigma = mismatch_sigma_nm(p, w, j, s.dt_s);
        let wheels = w.axes.iter().zip(self.verdict.residual_nm.iter()).take(count);
        for (i, (a, r)) in wheels.enumerate() {
            let b = bit(i);
            if new & b == 0 {
                continue;
            }
            match isolate_wheel(*r, &Vec3::from(*a), &m, sigma, p.isolation_min_ratio) {
                WheelIsolation::Rotor => {}
                WheelIsolation::Tachometer => self.tachometer |= b,
                WheelIsolation::Ambiguous => self.ambiguous |= b,
            }
            self.failed |= b;
            self.events = self.events.saturating_add(1);
        }
    }

    /// Re-enables wheel `i` (`None`: every wheel) and forgets its exceedances.
    pub fn clear(&mut self, wheel: Option<usize>) {
        let mask = wheel.map_or(u8::MAX, bit);
        for i in 0..MAX_WHEELS {
            if mask & bit(i) != 0 {
                self.monitor.clear(i);
            }
        }
        self.failed &= !mask;
        self.tachometer &= !mask;
        self.ambiguous &= !mask;
    }

    pub fn telemetry(&self) -> FdirTelemetry {
        FdirTelemetry {
            events: self.events,
            failed_wheels: self.failed,
            tachometer_wheels: self.tachometer,
            ambiguous_wheels: self.ambiguous,
            wheel_judged: self.verdict.judged,
            wheel_residual_nm: self.verdict.residual_nm,
            wheel_threshold_nm: if self.verdict.judged { self.verdict.threshold_nm } else { 0.0 },
            // The sensors' part is the estimation stage's (`fsw::report::sensor_fdir`).
            ..FdirTelemetry::default()
        }
    }
}

/// Wheels within [`SPEED_LIMIT_BAND`] of their speed limit (bit `i`: wheel `i`): the
/// drive withholds torque there by design, so a residual is not a fault.
fn near_speed_limit(w: &WheelParams, speed_rad_s: &[f32; MAX_WHEELS]) -> u8 {
    let limit = (1.0 - SPEED_LIMIT_BAND) * w.max_speed_rad_s;
    let mut mask = 0;
    for (i, s) in speed_rad_s.iter().enumerate().take(usize::from(w.count)) {
        // A NaN speed compares false: judged (an exceedance), not excused.
        if s.abs() >= limit {
            mask |= bit(i);
        }
    }
    mask
}

/// σ per axis of the body mismatch (docs/fdir.md "Wiring"): the gyro's rate noise through
/// `J Δω/Δt` (each end once, bounded by the largest row norm of `J`), every tachometer's
/// torque noise, and the unmodelled body torque, in quadrature, N m.
pub fn mismatch_sigma_nm(p: &WheelFdirParams, w: &WheelParams, j: &Mat3, dt_s: f32) -> f32 {
    let n = &p.noise;
    let j_max = (0..3).map(|r| math::norm(&j.row(r))).fold(0.0f32, f32::max);
    let gyro = j_max * n.gyro_sigma_rad_s / dt_s;
    let tach_var = n.tach_sigma_rad_s * n.tach_sigma_rad_s + n.tach_lsb_rad_s * n.tach_lsb_rad_s / 12.0;
    let tach = w.inertia_kgm2 / dt_s;
    let var = 2.0 * gyro * gyro + 2.0 * f32::from(w.count) * tach * tach * tach_var;
    f32m::sqrt(var + p.body_torque_sigma_nm * p.body_torque_sigma_nm)
}
