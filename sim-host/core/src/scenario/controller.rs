//! Control laws of a scenario: the `[controller]` table, its flight parameters and the
//! LQR/LQG designs computed at load.

use super::{OrbitKind, Scenario, bad, f32_rows, finite, positive};
use crate::attitude::Vec3;
use acs_flight::params::{ControllerParams, DcmPdParams, QuaternionFeedbackParams};
use anyhow::{Result, bail};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields, tag = "type", rename_all = "snake_case")]
pub enum Controller {
    /// `u = -K q_e - D ω - Ki ∫q_e` with `K = 2 ωn² I`, `D = 2 ζ ωn I`, `Ki = ki_per_s K`
    /// (paper 000 eqs 15-18), or explicit diagonal gains.
    QuaternionFeedback {
        #[serde(default)]
        zeta: Option<f64>,
        #[serde(default)]
        wn_rad_s: Option<f64>,
        /// Explicit diagonal K (N m) instead of ζ, ωn.
        #[serde(default)]
        k_diag_nm: Option<[f64; 3]>,
        /// Explicit diagonal D (N m s) instead of ζ, ωn.
        #[serde(default)]
        d_diag_nms: Option<[f64; 3]>,
        #[serde(default)]
        ki_per_s: f64,
        #[serde(default = "default_integral_limit")]
        integral_limit_s: f64,
        #[serde(default = "default_torque_limit")]
        torque_limit_nm: [f64; 3],
        #[serde(default)]
        gyro_compensation: bool,
        /// Eigen-axis slew-rate limit (Wie & Lu 1995), deg/s; absent = none.
        #[serde(default)]
        max_slew_rate_deg_s: Option<f64>,
    },
    /// PD on the DCM error (paper 004 eqs 25-27): `M = Kp ∘ [a32-a23, a13-a31, a21-a12] + Kd ∘ ω`.
    DcmPd {
        kp_nm: [f64; 3],
        kd_nms: [f64; 3],
        #[serde(default = "default_torque_limit")]
        torque_limit_nm: [f64; 3],
    },
    /// PD on Euler-angle errors (paper 003 eq 23): `T = -Kp ∘ e - Kd ∘ ω`.
    EulerPd {
        kp_nm: [f64; 3],
        kd_nms: [f64; 3],
        #[serde(default = "default_torque_limit")]
        torque_limit_nm: [f64; 3],
    },
    /// LQR `u = -K [e; ω - ω_c]`: an explicit 3×6 `gain`, or `q_diag` (6) and `r_diag` (3)
    /// with the gain computed at load (CARE) on the linearised `model`: "free" (rigid
    /// body), "orbit" (gravity gradient about LVLH at the scenario's orbit rate) or "rig"
    /// (pendulum of `[rig]`); default from the scenario. `input = "gimbal_rates"` (CMG
    /// only, paper 002): u is the 4 gimbal rates, designed on the body + pyramid model at
    /// the initial gimbal angles (`T = -J(δ₀) δ̇`, stored momentum `h(δ₀)`), `r_diag` (4).
    Lqr {
        #[serde(default)]
        gain: Option<[[f64; 6]; 3]>,
        #[serde(default)]
        q_diag: Option<[f64; 6]>,
        #[serde(default)]
        r_diag: Option<Vec<f64>>,
        /// "torque" (default) or "gimbal_rates".
        #[serde(default)]
        input: Option<String>,
        #[serde(default)]
        model: Option<String>,
        #[serde(default = "default_torque_limit")]
        torque_limit_nm: [f64; 3],
    },
    /// LQG (paper 002 eq 13): the LQR of `q_diag`, `r_diag`, `model` on the estimate of a
    /// steady-state Kalman filter designed on the same model discretised at the control
    /// period, with `process_noise` (6, per control step) and `measurement_noise` (6:
    /// angle errors in rad, rates in rad/s) variances.
    Lqg {
        q_diag: [f64; 6],
        r_diag: [f64; 3],
        #[serde(default)]
        model: Option<String>,
        process_noise: [f64; 6],
        measurement_noise: [f64; 6],
        #[serde(default = "default_torque_limit")]
        torque_limit_nm: [f64; 3],
        /// Run the time-varying filter in flight (covariance propagated from
        /// `initial_covariance`, default `measurement_noise`: the first estimate is the
        /// first measurement) instead of the steady-state gain.
        #[serde(default)]
        time_varying: bool,
        #[serde(default)]
        initial_covariance: Option<[f64; 6]>,
    },
    /// Adaptive DMCS (paper 001 eqs 31-51).
    Dmcs {
        wn_rad_s: f64,
        zeta: f64,
        model_inertia_kgm2: [f64; 3],
        alpha: f64,
        beta: f64,
        #[serde(default = "default_dmcs_q")]
        q_weights: [f64; 2],
        #[serde(default = "default_gain_limit")]
        gain_limit: f64,
        #[serde(default = "default_torque_limit")]
        torque_limit_nm: [f64; 3],
    },
    /// Rate damping `T = -Kd ∘ ω` (gyro only): detumbling without magnetorquers.
    RateDamping {
        kd_nms: [f64; 3],
        #[serde(default = "default_torque_limit")]
        torque_limit_nm: [f64; 3],
    },
    /// Sun-pointing safe mode on the coarse sun sensors and the gyro (no attitude):
    /// points `panel_normal_body` at the Sun with `T = kp (a × ŝ) − Kd ω`, searches by
    /// rotating about `search_axis_body` (⟂ panel, a principal axis) at
    /// `search_rate_deg_s` when the Sun is not seen, and holds the gyro-propagated Sun
    /// direction through eclipse (`acs_flight::control::sun_safe`).
    SunSafe {
        panel_normal_body: [f64; 3],
        kp_nm_per_rad: f64,
        kd_nm_s_per_rad: [f64; 3],
        search_axis_body: [f64; 3],
        search_rate_deg_s: f64,
        #[serde(default = "default_torque_limit")]
        torque_limit_nm: [f64; 3],
        /// How long a remembered Sun direction is trusted outside an expected eclipse, s.
        #[serde(default = "default_sun_timeout_s")]
        sun_timeout_s: f64,
    },
    /// B-dot detumbling `m = -k dB/dt` with a filtered derivative (magnetorquers).
    Bdot {
        gain_am2_s_per_t: f64,
        #[serde(default)]
        filter_time_constant_s: f64,
    },
    /// No flight code: actuators follow `[open_loop]` (or nothing), for model validation.
    None,
}

fn default_sun_timeout_s() -> f64 {
    300.0
}

fn default_dmcs_q() -> [f64; 2] {
    [0.1, 1.0]
}
fn default_gain_limit() -> f64 {
    1.0e6
}

fn default_integral_limit() -> f64 {
    1.0
}
fn default_torque_limit() -> [f64; 3] {
    [1.0e3; 3]
}

/// An LQR design: the gain and what it was computed from.
#[derive(Clone, Debug)]
pub struct LqrDesign {
    /// One row per input (3 torques or 4 gimbal rates).
    pub gain: Vec<[f64; 6]>,
    /// "torque" or "gimbal_rates".
    pub input: String,
    /// "given" for an explicit gain, else the model name.
    pub model: String,
    /// Closed-loop eigenvalues of `A - B K` (empty for a given gain).
    pub closed_loop_eigenvalues: Vec<nalgebra::Complex<f64>>,
    /// Relative CARE residual (0 for a given gain).
    pub residual: f64,
    /// The continuous linear model `ẋ = A x + B u` (zeros for a given gain).
    pub a: nalgebra::DMatrix<f64>,
    pub b: nalgebra::DMatrix<f64>,
}

impl Scenario {
    /// The LQR gain of `controller.type = "lqr"`, computed at load when not given.
    pub fn lqr_design(&self) -> Result<LqrDesign> {
        self.lqr_design_of(self.controller.as_ref().ok_or_else(|| bad("controller", "missing"))?)
    }

    /// The linear model an LQR is designed on (`model`: "free", "orbit" or "rig", default
    /// from the scenario; `input`: "torque" or "gimbal_rates").
    fn design_model(
        &self,
        model: &Option<String>,
        input: &str,
    ) -> Result<(String, crate::design::models::AttitudeModel)> {
        use nalgebra::DMatrix;
        let default_model = if self.rig.is_some() {
            "rig"
        } else if self.orbit.is_some() {
            "orbit"
        } else {
            "free"
        };
        let model = model.clone().unwrap_or_else(|| default_model.into());
        let orbit_rate = match self.orbit.as_ref().map(|o| o.elements()).transpose()? {
            Some(OrbitKind::Circular { altitude_km, .. }) => {
                crate::design::models::circular_orbit_rate(altitude_km * 1e3)
            }
            Some(OrbitKind::Kepler { a_km, .. }) => (3.986004418e14 / (a_km * 1e3).powi(3)).sqrt(),
            _ => 0.0,
        };
        let mgr = self.spacecraft()?.rig.map_or(Vec3::zeros(), |r| r.mgr_nm);
        let mut m = crate::design::models::AttitudeModel {
            inertia: self.inertia(),
            orbit_rate: if model == "orbit" { orbit_rate } else { 0.0 },
            gravity_gradient: model == "orbit",
            mgr: if model == "rig" { mgr } else { Vec3::zeros() },
            stored_momentum: Vec3::zeros(),
            input: DMatrix::identity(3, 3),
        };
        match input {
            "torque" => {}
            "gimbal_rates" => {
                let cmg = self
                    .actuators
                    .cmg
                    .as_ref()
                    .ok_or_else(|| bad("controller.input", "\"gimbal_rates\" needs [actuators.cmg]"))?;
                let pyramid = crate::design::models::CmgPyramid { beta: cmg.skew_deg.to_radians(), h0: cmg.h0() };
                let d0 = cmg.initial_gimbal_deg.map(f64::to_radians);
                let j = pyramid.jacobian(&d0);
                m.stored_momentum = pyramid.momentum(&d0);
                m.input = DMatrix::from_fn(3, 4, |r, c| -j[(r, c)]);
            }
            other => {
                return Err(bad(
                    "controller.input",
                    format!("unknown input {other:?} (known: \"torque\", \"gimbal_rates\")"),
                ));
            }
        }
        Ok((model, m))
    }

    /// The LQR design of a law (`lqr` or `lqg`).
    pub fn lqr_design_of(&self, c: &Controller) -> Result<LqrDesign> {
        use crate::design::riccati;
        use nalgebra::DMatrix;
        let (q, r, model, input): (&[f64; 6], &[f64], _, _) = match c {
            Controller::Lqr { gain: Some(k), .. } => {
                return Ok(LqrDesign {
                    gain: k.to_vec(),
                    input: "torque".into(),
                    model: "given".into(),
                    closed_loop_eigenvalues: Vec::new(),
                    residual: 0.0,
                    a: DMatrix::zeros(6, 6),
                    b: DMatrix::zeros(6, 3),
                });
            }
            Controller::Lqr { q_diag: Some(q), r_diag: Some(r), model, input, .. } => {
                (q, r.as_slice(), model, input.as_deref().unwrap_or("torque"))
            }
            Controller::Lqr { .. } => return Err(bad("controller", "lqr needs `gain`, or `q_diag` and `r_diag`")),
            Controller::Lqg { q_diag, r_diag, model, .. } => (q_diag, r_diag.as_slice(), model, "torque"),
            _ => bail!("controller.type is not \"lqr\" or \"lqg\""),
        };
        let (model, m) = self.design_model(model, input)?;
        if r.len() != m.m() {
            return Err(bad("controller.r_diag", format!("needs {} entries for input {input:?}", m.m())));
        }
        if !matches!(model.as_str(), "free" | "orbit" | "rig") {
            return Err(bad(
                "controller.model",
                format!("unknown model {model:?} (known: \"free\", \"orbit\", \"rig\")"),
            ));
        }
        if let Some(i) = q.iter().position(|v| !(*v >= 0.0)) {
            return Err(bad(&format!("controller.q_diag[{i}]"), "must be >= 0 (a state weight)"));
        }
        if let Some(i) = r.iter().position(|v| !(*v > 0.0)) {
            return Err(bad(&format!("controller.r_diag[{i}]"), "must be > 0 (an input weight)"));
        }
        let (a, b) = m.linear();
        let qm = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(q));
        let rm = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(r));
        let (k, x) = riccati::lqr(&a, &b, &qm, &rm).map_err(|e| {
            // The weights are the only inputs of the design that the user chose here.
            bad("controller.q_diag / controller.r_diag", format!("the LQR design failed with these weights: {e:?}"))
        })?;
        let residual = riccati::care_residual_rel(&a, &b, &qm, &rm, &x).unwrap_or(f64::NAN);
        let closed = &a - &b * &k;
        let gain = (0..k.nrows()).map(|i| std::array::from_fn(|j| k[(i, j)])).collect();
        Ok(LqrDesign {
            gain,
            input: input.into(),
            model,
            closed_loop_eigenvalues: riccati::eigenvalues(&closed).unwrap_or_default(),
            residual,
            a,
            b,
        })
    }

    /// LQG: the LQR design, the model discretised at the control period, and the
    /// steady-state Kalman gain for `z = x`.
    pub fn lqg_design(&self) -> Result<acs_flight::params::LqgParams> {
        self.lqg_design_of(self.controller.as_ref().ok_or_else(|| bad("controller", "missing"))?)
    }

    /// The LQG design of an `lqg` law.
    pub fn lqg_design_of(&self, c: &Controller) -> Result<acs_flight::params::LqgParams> {
        use crate::design::{discretize::c2d, kalman::steady_state_kalman};
        use nalgebra::DMatrix;
        let Controller::Lqg {
            process_noise, measurement_noise, torque_limit_nm, time_varying, initial_covariance, ..
        } = c
        else {
            bail!("controller.type is not \"lqg\"");
        };
        let d = self.lqr_design_of(c)?;
        let (ad, bd) = c2d(&d.a, &d.b, self.control_dt()).map_err(|e| bad("controller", format!("c2d: {e:?}")))?;
        let c = DMatrix::<f64>::identity(6, 6);
        let qn = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(process_noise));
        let rn = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(measurement_noise));
        let (l, _p) = steady_state_kalman(&ad, &c, &qn, &rn)
            .map_err(|e| bad("controller", format!("Kalman design failed: {e:?}")))?;
        let f6 =
            |m: &DMatrix<f64>| -> [[f32; 6]; 6] { std::array::from_fn(|r| std::array::from_fn(|k| m[(r, k)] as f32)) };
        Ok(acs_flight::params::LqgParams {
            k: std::array::from_fn(|i| d.gain.get(i).copied().unwrap_or_default().map(|x| x as f32)),
            a: f6(&ad),
            b: std::array::from_fn(|r| std::array::from_fn(|k| bd[(r, k)] as f32)),
            l: f6(&l),
            torque_limit_nm: torque_limit_nm.map(|x| x as f32),
            time_varying: *time_varying,
            process_noise: process_noise.map(|x| x as f32),
            measurement_noise: measurement_noise.map(|x| x as f32),
            p0_diag: initial_covariance.unwrap_or(*measurement_noise).map(|x| x as f32),
        })
    }
}

impl Scenario {
    /// Reject impossible controller values, naming the key (`key` = "controller" or
    /// "modes.<mode>.controller"). The checks live in [`Self::controller_params`], the one
    /// place that validates and builds a law; LQR and LQG gains are designed (and their
    /// designs checked) when the flight parameters are built.
    pub(super) fn validate_controller(&self, c: &Controller, key: &str) -> Result<()> {
        match c {
            Controller::Lqr { .. } | Controller::Lqg { .. } | Controller::None => Ok(()),
            _ => self.controller_params(c, key).map(|_| ()),
        }
    }

    /// Quaternion feedback: gains from (ζ, ωn) and the inertia, or given diagonals.
    fn quaternion_feedback_params(&self, c: &Controller, key: &str) -> Result<ControllerParams> {
        let Controller::QuaternionFeedback {
            zeta,
            wn_rad_s,
            k_diag_nm,
            d_diag_nms,
            ki_per_s,
            integral_limit_s,
            torque_limit_nm,
            gyro_compensation,
            max_slew_rate_deg_s,
        } = c
        else {
            bail!("{key}: not a quaternion-feedback law");
        };
        let inertia = self.inertia();
        let (k, d) = match (zeta, wn_rad_s, k_diag_nm, d_diag_nms) {
            (Some(z), Some(w), None, None) => {
                positive(&format!("{key}.zeta"), *z)?;
                positive(&format!("{key}.wn_rad_s"), *w)?;
                (inertia * (2.0 * w * w), inertia * (2.0 * z * w))
            }
            (None, None, Some(k), Some(d)) => {
                finite(&format!("{key}.k_diag_nm"), k)?;
                finite(&format!("{key}.d_diag_nms"), d)?;
                (Matrix3::from_diagonal(&(*k).into()), Matrix3::from_diagonal(&(*d).into()))
            }
            _ => return Err(bad(key, "give zeta and wn_rad_s, or k_diag_nm and d_diag_nms")),
        };
        if let Some(r) = max_slew_rate_deg_s {
            positive(&format!("{key}.max_slew_rate_deg_s"), *r)?;
        }
        if !(ki_per_s.is_finite() && *ki_per_s >= 0.0) {
            return Err(bad(&format!("{key}.ki_per_s"), "must be >= 0"));
        }
        if !(integral_limit_s.is_finite() && *integral_limit_s >= 0.0) {
            return Err(bad(&format!("{key}.integral_limit_s"), "must be >= 0"));
        }
        let f = f32_rows;
        Ok(ControllerParams::QuaternionFeedback(QuaternionFeedbackParams {
            k_att_nm: f(&k),
            d_rate_nms: f(&d),
            ki_att_nm_s: f(&(k * *ki_per_s)),
            integral_limit_s: *integral_limit_s as f32,
            torque_limit_nm: torque_limits(key, torque_limit_nm)?,
            gyro_compensation: *gyro_compensation,
            max_slew_rate_rad_s: max_slew_rate_deg_s.map_or(0.0, |r| r.to_radians() as f32),
        }))
    }

    /// The flight parameters of a control law (gains designed here when asked): validated,
    /// naming `key`, and built in this one place.
    pub(super) fn controller_params(&self, c: &Controller, key: &str) -> Result<ControllerParams> {
        let p = match c {
            Controller::QuaternionFeedback { .. } => self.quaternion_feedback_params(c, key)?,
            Controller::DcmPd { kp_nm, kd_nms, torque_limit_nm } => {
                ControllerParams::DcmPd(pd_params(key, kp_nm, kd_nms, torque_limit_nm)?)
            }
            Controller::EulerPd { kp_nm, kd_nms, torque_limit_nm } => {
                ControllerParams::EulerPd(pd_params(key, kp_nm, kd_nms, torque_limit_nm)?)
            }
            Controller::Lqr { torque_limit_nm, .. } => self.lqr_params(c, torque_limit_nm)?,
            Controller::Lqg { .. } => ControllerParams::Lqg(self.lqg_design_of(c)?),
            Controller::Dmcs { .. } => dmcs_params(c, key)?,
            Controller::RateDamping { kd_nms, torque_limit_nm } => rate_damping_params(key, kd_nms, torque_limit_nm)?,
            Controller::SunSafe { .. } => sun_safe_params(c, key)?,
            Controller::Bdot { gain_am2_s_per_t, filter_time_constant_s } => {
                self.bdot_params(key, *gain_am2_s_per_t, *filter_time_constant_s)?
            }
            Controller::None => bail!("controller.type = \"none\" uploads no flight parameters"),
        };
        Ok(p)
    }

    /// LQR: the designed (or given) gain rows; a gimbal-rate LQR has no torque limit.
    fn lqr_params(&self, c: &Controller, torque_limit_nm: &[f64; 3]) -> Result<ControllerParams> {
        let d = self.lqr_design_of(c)?;
        let row = |i: usize| d.gain.get(i).copied().unwrap_or_default().map(|x| x as f32);
        if d.input == "gimbal_rates" {
            return Ok(ControllerParams::LqrGimbalRate { k: std::array::from_fn(row) });
        }
        Ok(ControllerParams::Lqr { k: std::array::from_fn(row), torque_limit_nm: torque_limit_nm.map(|x| x as f32) })
    }

    /// B-dot: positive gain, non-negative filter time constant, and torquers to command.
    fn bdot_params(&self, key: &str, gain_am2_s_per_t: f64, filter_time_constant_s: f64) -> Result<ControllerParams> {
        positive(&format!("{key}.gain_am2_s_per_t"), gain_am2_s_per_t)?;
        if !(filter_time_constant_s.is_finite() && filter_time_constant_s >= 0.0) {
            return Err(bad(&format!("{key}.filter_time_constant_s"), "must be >= 0"));
        }
        if self.actuators.magnetorquers.is_none() {
            return Err(bad(key, "B-dot commands dipoles: it needs [actuators.magnetorquers]"));
        }
        Ok(ControllerParams::Bdot {
            gain_am2_s_per_t: gain_am2_s_per_t as f32,
            filter_time_constant_s: filter_time_constant_s as f32,
        })
    }
}

/// DMCS: the law's parameters in f32 (checked by the flight code).
fn dmcs_params(c: &Controller, key: &str) -> Result<ControllerParams> {
    let Controller::Dmcs { wn_rad_s, zeta, model_inertia_kgm2, alpha, beta, q_weights, gain_limit, torque_limit_nm } =
        c
    else {
        bail!("{key}: not a DMCS law");
    };
    Ok(ControllerParams::Dmcs(acs_flight::params::DmcsParams {
        wn_rad_s: *wn_rad_s as f32,
        zeta: *zeta as f32,
        model_inertia_kgm2: model_inertia_kgm2.map(|x| x as f32),
        alpha: *alpha as f32,
        beta: *beta as f32,
        q_weights: q_weights.map(|x| x as f32),
        gain_limit: *gain_limit as f32,
        torque_limit_nm: torque_limit_nm.map(|x| x as f32),
    }))
}

/// Rate damping: non-negative gains, positive torque limits.
fn rate_damping_params(key: &str, kd_nms: &[f64; 3], torque_limit_nm: &[f64; 3]) -> Result<ControllerParams> {
    if !kd_nms.iter().all(|k| k.is_finite() && *k >= 0.0) {
        return Err(bad(&format!("{key}.kd_nms"), "must be >= 0"));
    }
    Ok(ControllerParams::RateDamping {
        kd_nms: kd_nms.map(|x| x as f32),
        torque_limit_nm: torque_limits(key, torque_limit_nm)?,
    })
}

/// Sun-safe pointing and search: unit panel normal and search axis, checked by the
/// flight code.
fn sun_safe_params(c: &Controller, key: &str) -> Result<ControllerParams> {
    let Controller::SunSafe {
        panel_normal_body,
        kp_nm_per_rad,
        kd_nm_s_per_rad,
        search_axis_body,
        search_rate_deg_s,
        torque_limit_nm,
        sun_timeout_s,
    } = c
    else {
        bail!("{key}: not a sun-safe law");
    };
    let unit = |v: &[f64; 3]| {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| (x / n) as f32)
    };
    let p = acs_flight::params::SunSafeParams {
        panel_normal_body: unit(panel_normal_body),
        kp_nm_per_rad: *kp_nm_per_rad as f32,
        kd_nm_s_per_rad: kd_nm_s_per_rad.map(|x| x as f32),
        search_axis_body: unit(search_axis_body),
        search_rate_rad_s: search_rate_deg_s.to_radians() as f32,
        torque_limit_nm: torque_limits(key, torque_limit_nm)?,
        sun_timeout_s: *sun_timeout_s as f32,
    };
    p.validate().map_err(|e| {
        bad(
            key,
            format!("{e}: unit non-zero panel normal and search axis, ⟂ within 0.01, gains and rate > 0, timeout >= 0"),
        )
    })?;
    Ok(ControllerParams::SunSafe(p))
}

/// Torque limits of a law: each > 0.
fn torque_limits(key: &str, t: &[f64; 3]) -> Result<[f32; 3]> {
    for x in t {
        positive(&format!("{key}.torque_limit_nm"), *x)?;
    }
    Ok(t.map(|x| x as f32))
}

/// DCM-PD and Euler-PD gains.
fn pd_params(key: &str, kp_nm: &[f64; 3], kd_nms: &[f64; 3], torque_limit_nm: &[f64; 3]) -> Result<DcmPdParams> {
    finite(&format!("{key}.kp_nm"), kp_nm)?;
    finite(&format!("{key}.kd_nms"), kd_nms)?;
    Ok(DcmPdParams {
        kp_nm: kp_nm.map(|x| x as f32),
        kd_nms: kd_nms.map(|x| x as f32),
        torque_limit_nm: torque_limits(key, torque_limit_nm)?,
    })
}
