//! Validation of the `[sensors]` table: the shortcut noises and latency, every sensor's
//! sample rate and sample timing (phase, jitter, latency; the samples in flight within
//! [`MAX_SAMPLES_IN_FLIGHT`]; a first sample within the run), then one validator per
//! sensor table (gyro, magnetometer, coarse sun sensors, GNSS receiver, star tracker), in
//! that order (the first error is reported); and the sensors' timing against what the
//! on-board estimator can fuse ([`Scenario::validate_estimator_timing`]).

use super::super::{Scenario, bad, finite, non_negative, positive};
use super::{CssSpec, GnssSpec, GyroSpec, MagnetometerSpec, Sensors, StarTrackerSpec};
use crate::sensors::clock::{SampleTiming, Sampled};
use crate::sensors::latency::MAX_SAMPLES_IN_FLIGHT;
use acs_flight::estimation::waiting::WAITING_PER_SENSOR;
use anyhow::{Result, anyhow};

impl Scenario {
    /// `[sensors]`.
    pub(in crate::scenario) fn validate_sensors(&self) -> Result<()> {
        let s = &self.sensors;
        validate_shortcuts(s)?;
        validate_rates(s)?;
        validate_timing(s, self.timing.control_rate_hz)?;
        validate_in_flight(s, self.timing.control_rate_hz, self.duration_s)?;
        if let Some(g) = &s.gyro {
            validate_gyro(g)?;
        }
        if let Some(m) = &s.magnetometer {
            validate_magnetometer(m)?;
        }
        if let Some(c) = &s.css {
            validate_css(c)?;
        }
        if let Some(g) = &s.gnss {
            validate_gnss(g)?;
        }
        if let Some(t) = &s.star_tracker {
            validate_star_tracker(t)?;
        }
        Ok(())
    }
}

/// The shortcut noises, the suite latency and the constant rate bias.
fn validate_shortcuts(s: &Sensors) -> Result<()> {
    for (k, v) in [
        ("sensors.attitude_noise_deg", s.attitude_noise_deg),
        ("sensors.rate_noise_rad_s", s.rate_noise_rad_s),
        ("sensors.gimbal_noise_deg", s.gimbal_noise_deg),
        ("sensors.magnetometer_noise_t", s.magnetometer_noise_t),
        ("sensors.wheel_speed_noise_rad_s", s.wheel_speed_noise_rad_s),
        ("sensors.latency_s", s.latency_s),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(bad(k, "must be >= 0"));
        }
    }
    if s.latency_s > 10.0 {
        return Err(bad("sensors.latency_s", "must be <= 10"));
    }
    finite("sensors.rate_bias_rad_s", &s.rate_bias_rad_s)
}

/// Every sensor's own sample rate (the sample clock needs a positive finite rate), and the
/// star tracker's rate limit.
fn validate_rates(s: &Sensors) -> Result<()> {
    for which in Sampled::ALL {
        if let Some(r) = s.timing_keys(which).and_then(|t| t.rate_hz) {
            positive(&format!("sensors.{}.rate_hz", which.key()), r)?;
        }
    }
    if let Some(m) = s.star_tracker.as_ref().and_then(|t| t.max_rate_deg_s) {
        positive("sensors.star_tracker.max_rate_deg_s", m)?;
    }
    Ok(())
}

/// Every sensor table's sample grid and delay: `phase_s` in [0, 1/rate), `jitter_s` in
/// [0, 1/(2 rate)) (so the jittered grid points keep their order), `latency_s` in [0, 10]
/// (rates checked before: [`validate_rates`]).
fn validate_timing(s: &Sensors, control_rate_hz: f64) -> Result<()> {
    for which in Sampled::ALL {
        let Some(t) = s.timing_keys(which) else { continue };
        let (rate, phase, jitter, latency) = (t.rate_hz, t.phase_s, t.jitter_s, t.latency_s);
        let key = |k: &str| format!("sensors.{}.{k}", which.key());
        let period = 1.0 / rate.unwrap_or(control_rate_hz);
        if !(latency.is_finite() && (0.0..=10.0).contains(&latency)) {
            return Err(bad(&key("latency_s"), format!("must be in [0, 10] s (got {latency})")));
        }
        if !(phase.is_finite() && phase >= 0.0 && phase < period) {
            return Err(bad(&key("phase_s"), format!("must be in [0, 1/rate_hz = {period}) s (got {phase})")));
        }
        if !(jitter.is_finite() && jitter >= 0.0 && jitter < 0.5 * period) {
            return Err(bad(
                &key("jitter_s"),
                format!("must be in [0, half the period = {}) s (got {jitter})", 0.5 * period),
            ));
        }
    }
    Ok(())
}

/// The key(s) of a sensor's effective latency: its table's `latency_s`, plus the suite's
/// `sensors.latency_s` for the gyro and the tracker when that is set.
fn latency_key(s: &Sensors, which: Sampled) -> String {
    let own = format!("sensors.{}.latency_s", which.key());
    match which {
        Sampled::Gyro | Sampled::StarTracker if s.latency_s != 0.0 => format!("{own}` + `sensors.latency_s"),
        _ => own,
    }
}

/// The key of a sensor's sample rate: its table's `rate_hz`, else the control rate (the
/// default).
fn rate_key(s: &Sensors, which: Sampled) -> String {
    if s.timing_keys(which).and_then(|k| k.rate_hz).is_some() {
        format!("sensors.{}.rate_hz", which.key())
    } else {
        "timing.control_rate_hz".into()
    }
}

/// Every sensor's queue of samples in flight fits [`MAX_SAMPLES_IN_FLIGHT`] (its size,
/// `⌈latency × rate⌉ + 2`, is what the simulator allocates from), and every sensor table
/// delivers a first sample within the run (its grid's first point, `phase_s`, plus its
/// latency, not after `duration_s`).
fn validate_in_flight(s: &Sensors, control_rate_hz: f64, duration_s: f64) -> Result<()> {
    for which in Sampled::ALL {
        let t = s.timing(which, control_rate_hz);
        let in_flight = crate::sensors::latency::in_flight_cap(t.latency_s, t.rate_hz);
        if in_flight.is_none_or(|n| n > MAX_SAMPLES_IN_FLIGHT) {
            return Err(anyhow!(
                "`{}` = {} Hz with `{}` = {} s: ⌈latency × rate⌉ + 2 samples in flight exceeds the \
                 simulator's cap of {MAX_SAMPLES_IN_FLIGHT} per sensor",
                rate_key(s, which),
                t.rate_hz,
                latency_key(s, which),
                t.latency_s
            ));
        }
        if s.timing_keys(which).is_some() && t.phase_s + t.latency_s > duration_s {
            return Err(anyhow!(
                "`sensors.{0}.phase_s` = {1} s + `{2}` = {3} s is after `duration_s` = {duration_s} s: \
                 the {0} would deliver no sample within the run",
                which.key(),
                t.phase_s,
                latency_key(s, which),
                t.latency_s
            ));
        }
    }
    Ok(())
}

impl Scenario {
    /// With the on-board MEKF: each sensor's timing against what the estimator can fuse
    /// (docs/estimation-timing.md, "What the loader refuses"). Nominal figures: the
    /// latencies as configured, a sample period `1/rate_hz`, the dynamics substep `h`;
    /// jitter and the frames' quantisation (up to a control period) come on top and show
    /// in the run (`sample_fusion`, `no_control`). Each refusal names the keys involved.
    ///
    /// - the gyro's latency plus its period within `estimation.max_sample_age_s` (else the
    ///   gyro is lost between samples and the filter stops);
    /// - each fused sensor's latency beyond the gyro's within `max_sample_latency_s` (else
    ///   every sample is refused as too old), and within `max_replayed_nodes` propagation
    ///   steps (`⌈(L − L_gyro) × min(control, gyro rate)⌉`, the nodes its replay re-runs at
    ///   the least);
    /// - the samples a sensor delivers while waiting for a lagging gyro,
    ///   `⌈(L_gyro + 1/gyro rate + h − L) × f⌉` with `f` the sensor's rate (at most the
    ///   control rate, at most one per `coarse_update_interval_s` for the coarse sensors),
    ///   within the flight code's `WAITING_PER_SENSOR`.
    pub(in crate::scenario) fn validate_estimator_timing(&self) -> Result<()> {
        let Some(e) = self.estimation.as_ref().filter(|e| e.source == crate::scenario::estimation::SourceSpec::Mekf)
        else {
            return Ok(());
        };
        let s = &self.sensors;
        let fc = self.timing.control_rate_hz;
        let h = 1.0 / (fc * f64::from(self.timing.dynamics_substeps.max(1)));
        let g = s.timing(Sampled::Gyro, fc);
        let gyro_latency = latency_key(s, Sampled::Gyro);
        let gyro_age = g.latency_s + 1.0 / g.rate_hz;
        if gyro_age > e.max_sample_age_s {
            return Err(anyhow!(
                "`{gyro_latency}` = {} s + one period of `{}` = {} Hz is {gyro_age} s, more than \
                 `estimation.max_sample_age_s` = {} s: the gyro would be lost between its samples and the filter stop",
                g.latency_s,
                rate_key(s, Sampled::Gyro),
                g.rate_hz,
                e.max_sample_age_s
            ));
        }
        let coarse = |on: bool| {
            if on && e.coarse_update_interval_s > 0.0 { 1.0 / e.coarse_update_interval_s } else { f64::INFINITY }
        };
        let fused = [
            (Sampled::StarTracker, true, f64::INFINITY),
            (Sampled::Sun, s.sun.is_some() && e.sun_sensor_sigma_deg.is_some_and(|x| x > 0.0), f64::INFINITY),
            (Sampled::Css, s.css.is_some() && e.css_sigma_deg.is_some_and(|x| x > 0.0), coarse(true)),
            (Sampled::Magnetometer, e.magnetometer_sigma_deg.is_some_and(|x| x > 0.0), coarse(true)),
        ];
        for (which, used, coarse_hz) in fused {
            if used {
                let x = s.timing(which, fc);
                self.check_fusable(which, &x, &g, (h, coarse_hz), &gyro_latency)?;
            }
        }
        Ok(())
    }

    /// One fused sensor `x` against the gyro `g` (see [`Self::validate_estimator_timing`]);
    /// `(h, coarse_hz)`: the dynamics substep, s, and the coarse-update rate cap, Hz.
    fn check_fusable(
        &self,
        which: Sampled,
        x: &SampleTiming,
        g: &SampleTiming,
        (h, coarse_hz): (f64, f64),
        gyro_latency: &str,
    ) -> Result<()> {
        let Some(e) = self.estimation.as_ref() else { return Ok(()) };
        let key = latency_key(&self.sensors, which);
        let fc = self.timing.control_rate_hz;
        let beyond = x.latency_s - g.latency_s;
        // 1e-9: a latency that is an exact multiple of the period is that many nodes.
        let ceil = |v: f64| (v - 1e-9).ceil().max(0.0);
        if beyond > e.max_sample_latency_s {
            return Err(anyhow!(
                "`{key}` = {} s is {beyond} s beyond the gyro's (`{gyro_latency}` = {} s), more than \
                 `estimation.max_sample_latency_s` = {} s: the MEKF would refuse every {} sample as too old",
                x.latency_s,
                g.latency_s,
                e.max_sample_latency_s,
                which.key()
            ));
        }
        let nodes = ceil(beyond * fc.min(g.rate_hz));
        if nodes > f64::from(e.max_replayed_nodes) {
            return Err(anyhow!(
                "`{key}` = {} s is {beyond} s beyond the gyro's (`{gyro_latency}` = {} s): fusing its samples re-runs \
                 at least {nodes} history nodes, more than `estimation.max_replayed_nodes` = {}: the MEKF would \
                 refuse every {} sample",
                x.latency_s,
                g.latency_s,
                e.max_replayed_nodes,
                which.key()
            ));
        }
        let ahead = g.latency_s + 1.0 / g.rate_hz + h - x.latency_s;
        let waiting = ceil(ahead * x.rate_hz.min(fc).min(coarse_hz));
        if waiting > WAITING_PER_SENSOR as f64 {
            return Err(anyhow!(
                "`{gyro_latency}` = {} s plus one period of `{}` = {} Hz against `{key}` = {} s: up to {waiting} {} \
                 samples would wait for the gyro, more than the flight code's {WAITING_PER_SENSOR} per sensor",
                g.latency_s,
                rate_key(&self.sensors, Sampled::Gyro),
                g.rate_hz,
                x.latency_s,
                which.key()
            ));
        }
        Ok(())
    }
}

/// `[sensors.gyro]`.
fn validate_gyro(g: &GyroSpec) -> Result<()> {
    finite("sensors.gyro.misalignment_deg", &g.misalignment_deg)?;
    if let Some(sat) = g.saturation_rad_s {
        positive("sensors.gyro.saturation_rad_s", sat)?;
    }
    if !(g.quantisation_rad_s.is_finite() && g.quantisation_rad_s >= 0.0) {
        return Err(bad("sensors.gyro.quantisation_rad_s", "must be >= 0"));
    }
    non_negative("sensors.gyro.bias_instability_rad_s", g.bias_instability_rad_s)?;
    match g.bias_correlation_s {
        Some(tau) => positive("sensors.gyro.bias_correlation_s", tau)?,
        None if g.bias_instability_rad_s > 0.0 => {
            return Err(bad("sensors.gyro.bias_correlation_s", "required with bias_instability_rad_s > 0"));
        }
        None => {}
    }
    Ok(())
}

/// `[sensors.magnetometer]`.
fn validate_magnetometer(m: &MagnetometerSpec) -> Result<()> {
    finite("sensors.magnetometer.misalignment_deg", &m.misalignment_deg)?;
    let max = f64::from(acs_flight::params::momentum::MAX_MAG_COUPLING_T_PER_AM2);
    if !m.coupling_t_per_am2.iter().flatten().all(|c| c.is_finite() && c.abs() <= max) {
        return Err(bad(
            "sensors.magnetometer.coupling_t_per_am2",
            format!("each coefficient must be finite with |c| <= {max:e} T per A m2"),
        ));
    }
    Ok(())
}

/// `[sensors.css]`.
fn validate_css(c: &CssSpec) -> Result<()> {
    if let Some(r) = c.timing.rate_hz {
        positive("sensors.css.rate_hz", r)?;
    }
    let max = crate::sensors::css::MAX_CSS_HEADS;
    if !(1..=max).contains(&c.normals_body.len()) {
        return Err(bad("sensors.css.normals_body", format!("needs 1 to {max} heads (got {})", c.normals_body.len())));
    }
    for n in &c.normals_body {
        finite("sensors.css.normals_body", n)?;
        if n.iter().map(|x| x * x).sum::<f64>() < 1e-12 {
            return Err(bad("sensors.css.normals_body", "a normal must not be zero"));
        }
    }
    non_negative("sensors.css.noise", c.noise)?;
    if !(c.albedo.is_finite() && (0.0..=1.0).contains(&c.albedo)) {
        return Err(bad("sensors.css.albedo", format!("{} must be in [0, 1]", c.albedo)));
    }
    Ok(())
}

/// `[sensors.gnss]`.
fn validate_gnss(g: &GnssSpec) -> Result<()> {
    if let Some(r) = g.timing.rate_hz {
        positive("sensors.gnss.rate_hz", r)?;
    }
    non_negative("sensors.gnss.position_noise_m", g.position_noise_m)?;
    non_negative("sensors.gnss.velocity_noise_m_s", g.velocity_noise_m_s)?;
    validate_outages("sensors.gnss.outages_s", &g.outages_s)
}

/// `[sensors.star_tracker]` (its rates are checked with the others').
fn validate_star_tracker(t: &StarTrackerSpec) -> Result<()> {
    validate_outages("sensors.star_tracker.outages_s", &t.outages_s)?;
    for (k, v) in [("noise_cross_deg", t.noise_cross_deg), ("noise_about_deg", t.noise_about_deg)] {
        if let Some(v) = v.filter(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(bad(&format!("sensors.star_tracker.{k}"), format!("{v} must be >= 0")));
        }
    }
    for (k, v) in [("sun_exclusion_deg", t.sun_exclusion_deg), ("earth_exclusion_deg", t.earth_exclusion_deg)] {
        if let Some(v) = v.filter(|v| !(v.is_finite() && (0.0..=180.0).contains(v))) {
            return Err(bad(&format!("sensors.star_tracker.{k}"), format!("{v} must be in [0, 180]")));
        }
    }
    if let Some(b) = t.boresight_body {
        finite("sensors.star_tracker.boresight_body", &b)?;
        if b.iter().map(|x| x * x).sum::<f64>() < 1e-12 {
            return Err(bad("sensors.star_tracker.boresight_body", "must not be zero"));
        }
    }
    if !(t.timing.latency_s.is_finite() && (0.0..=10.0).contains(&t.timing.latency_s)) {
        return Err(bad("sensors.star_tracker.latency_s", "must be in [0, 10]"));
    }
    Ok(())
}

/// Outage intervals `[start, end]`: finite, start <= end.
fn validate_outages(key: &str, intervals: &[[f64; 2]]) -> Result<()> {
    for [a, b] in intervals {
        if !(a.is_finite() && b.is_finite() && a <= b) {
            return Err(bad(key, format!("[{a}, {b}] must be finite with start <= end")));
        }
    }
    Ok(())
}
