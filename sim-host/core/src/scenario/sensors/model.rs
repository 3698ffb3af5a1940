//! The `[sensors]` table in the sensor models' terms: each table's file form (degrees,
//! ppm, scalars, optional rates) converted to its model's specification (SI units, per
//! axis), the shortcut keys standing in for a table that is absent.

use super::Sensors;
use crate::sensors::clock::Sampled;
use crate::sensors::css::CssModel;
use crate::sensors::gnss::GnssModel;
use crate::sensors::gyro::GyroModel;
use crate::sensors::magnetometer::MagnetometerModel;
use crate::sensors::star_tracker::AttitudeSensorModel;
use crate::sensors::suite::SuiteSpec;
use crate::sensors::sun_sensor::SunSensorModel;

impl Sensors {
    /// Everything the sensor suite is built from; `control_rate_hz` is the sample rate of
    /// a sensor whose table gives none.
    pub fn suite_spec(&self, control_rate_hz: f64) -> SuiteSpec {
        SuiteSpec {
            seed: self.seed,
            gimbal_noise_rad: self.gimbal_noise_deg.to_radians(),
            wheel_speed_noise_rad_s: self.wheel_speed_noise_rad_s,
            gyro: self.gyro_model(control_rate_hz),
            attitude: self.attitude_model(control_rate_hz),
            magnetometer: self.magnetometer_model(control_rate_hz),
            sun: self.sun_model(control_rate_hz),
            css: self.css_model(control_rate_hz),
            gnss: self.gnss_model(control_rate_hz),
            timings: Sampled::ALL.map(|w| self.timing(w, control_rate_hz)),
            tracker_outages_s: self.star_tracker.as_ref().map_or_else(Vec::new, |a| a.outages_s.clone()),
        }
    }

    /// The gyro model: the `[sensors.gyro]` table when there is one (the same value on each
    /// axis), else the legacy white rate noise `rate_noise_rad_s` and bias `rate_bias_rad_s`.
    pub fn gyro_model(&self, control_rate_hz: f64) -> GyroModel {
        match &self.gyro {
            Some(g) => GyroModel {
                rate_hz: g.timing.rate_hz.unwrap_or(control_rate_hz),
                arw_rad_sqrt_s: [g.arw_rad_sqrt_s; 3],
                rrw_rad_s_sqrt_s: [g.rrw_rad_s_sqrt_s; 3],
                bias_rad_s: g.bias_rad_s,
                scale_factor: [g.scale_factor_ppm * 1e-6; 3],
                misalignment_rad: g.misalignment_deg.map(f64::to_radians),
                saturation_rad_s: g.saturation_rad_s,
                quantisation_rad_s: g.quantisation_rad_s,
                bias_instability_rad_s: g.bias_instability_rad_s,
                bias_correlation_s: g.bias_correlation_s.unwrap_or(0.0),
            },
            // White noise of σ per sample at the control rate: ARW = σ / √rate.
            None => GyroModel {
                rate_hz: control_rate_hz,
                arw_rad_sqrt_s: [self.rate_noise_rad_s / control_rate_hz.sqrt(); 3],
                rrw_rad_s_sqrt_s: [0.0; 3],
                bias_rad_s: self.rate_bias_rad_s,
                scale_factor: [0.0; 3],
                misalignment_rad: [0.0; 3],
                saturation_rad_s: None,
                quantisation_rad_s: 0.0,
                bias_instability_rad_s: 0.0,
                bias_correlation_s: 0.0,
            },
        }
    }

    /// The attitude sensor: `[sensors.star_tracker]` when given, else the shortcut
    /// `attitude_noise_deg` (isotropic, body axes).
    pub fn attitude_model(&self, control_rate_hz: f64) -> AttitudeSensorModel {
        let Some(a) = &self.star_tracker else {
            return AttitudeSensorModel {
                rate_hz: control_rate_hz,
                noise_rad: [self.attitude_noise_deg.to_radians(); 3],
                bias_rad: [0.0; 3],
                max_rate_rad_s: None,
                boresight_body: None,
                sun_exclusion_rad: None,
                earth_exclusion_rad: None,
            };
        };
        let anisotropic = a.noise_cross_deg.is_some() || a.noise_about_deg.is_some();
        let (cross, about) = (a.noise_cross_deg.unwrap_or(a.noise_deg), a.noise_about_deg.unwrap_or(a.noise_deg));
        AttitudeSensorModel {
            rate_hz: a.timing.rate_hz.unwrap_or(control_rate_hz),
            noise_rad: [cross.to_radians(), cross.to_radians(), about.to_radians()],
            bias_rad: a.bias_deg.map(f64::to_radians),
            max_rate_rad_s: a.max_rate_deg_s.map(f64::to_radians),
            // Without a boresight or split noise the noise stays in body axes (the
            // isotropic shortcut, bit for bit as before).
            boresight_body: a.boresight_body.or(anisotropic.then_some([0.0, 0.0, 1.0])),
            sun_exclusion_rad: a.sun_exclusion_deg.map(f64::to_radians),
            earth_exclusion_rad: a.earth_exclusion_deg.map(f64::to_radians),
        }
    }

    /// The magnetometer: `[sensors.magnetometer]` when given, else the shortcut
    /// `magnetometer_noise_t`.
    pub fn magnetometer_model(&self, control_rate_hz: f64) -> MagnetometerModel {
        match &self.magnetometer {
            Some(m) => MagnetometerModel {
                rate_hz: m.timing.rate_hz.unwrap_or(control_rate_hz),
                noise_t: [m.noise_t; 3],
                bias_t: m.bias_t,
                coupling_t_per_am2: m.coupling_t_per_am2,
                misalignment_rad: m.misalignment_deg.map(f64::to_radians),
            },
            None => MagnetometerModel {
                rate_hz: control_rate_hz,
                noise_t: [self.magnetometer_noise_t; 3],
                bias_t: [0.0; 3],
                coupling_t_per_am2: [[0.0; 3]; 3],
                misalignment_rad: [0.0; 3],
            },
        }
    }

    /// The sun sensor (`None` without `[sensors.sun]`).
    pub fn sun_model(&self, control_rate_hz: f64) -> Option<SunSensorModel> {
        self.sun.as_ref().map(|x| SunSensorModel {
            rate_hz: x.timing.rate_hz.unwrap_or(control_rate_hz),
            noise_rad: x.noise_deg.to_radians(),
            boresight_body: x.boresight_body,
            fov_half_angle_rad: x.fov_half_angle_deg.to_radians(),
        })
    }

    /// The coarse sun sensors (`None` without `[sensors.css]`).
    pub fn css_model(&self, control_rate_hz: f64) -> Option<CssModel> {
        self.css.as_ref().map(|c| CssModel {
            rate_hz: c.timing.rate_hz.unwrap_or(control_rate_hz),
            normals_body: c.normals_body.clone(),
            noise: c.noise,
            albedo: c.albedo,
        })
    }

    /// The GNSS receiver (`None` without `[sensors.gnss]`: the suite then gives the ideal
    /// state on every frame).
    pub fn gnss_model(&self, control_rate_hz: f64) -> Option<GnssModel> {
        self.gnss.as_ref().map(|g| GnssModel {
            rate_hz: g.timing.rate_hz.unwrap_or(control_rate_hz),
            position_noise_m: g.position_noise_m,
            velocity_noise_m_s: g.velocity_noise_m_s,
            outages_s: g.outages_s.clone(),
        })
    }
}
