//! Scenario files (TOML). The format is documented in `docs/scenario.md`; every table
//! rejects unknown keys, and [`Scenario::validate`] rejects impossible values naming
//! the key, before anything runs.

use crate::attitude::{Quat, from_xyzw, quat_from_euler};
use crate::plant::{MAX_GIMBALS, Spacecraft, State, cmg::CmgCluster};
use acs_flight::math::EulerSeq;
use acs_flight::params::{
    ActuatorParams, AlphaSchedule, CmgParams, ControllerParams, FlightParams, PARAMS_VERSION,
    QuaternionFeedbackParams, SteeringLaw, SteeringParams, TargetFrame,
};
use anyhow::{Context, Result, anyhow, bail};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub duration_s: f64,
    pub timing: Timing,
    pub spacecraft: SpacecraftSpec,
    pub initial: InitialState,
    pub target: AttitudeSpec,
    pub actuators: Actuators,
    pub controller: Controller,
    pub steering: Steering,
    #[serde(default)]
    pub sensors: Sensors,
    #[serde(default)]
    pub link: LinkSpec,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Timing {
    pub control_rate_hz: f64,
    /// RK4 steps per control period (dynamics rate = control rate × this).
    #[serde(default = "one")]
    pub dynamics_substeps: u32,
    /// Record every Nth control step in timeseries.csv and the plots.
    #[serde(default = "one")]
    pub output_every: u32,
}

fn one() -> u32 {
    1
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SpacecraftSpec {
    /// Row-major, kg m².
    pub inertia_kgm2: [[f64; 3]; 3],
    #[serde(default)]
    pub mass_kg: Option<f64>,
    /// Constant external torque, body axes.
    #[serde(default)]
    pub external_torque_nm: [f64; 3],
}

/// An attitude: Euler angles `[roll, pitch, yaw]` in degrees with a sequence, or a quaternion.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct AttitudeSpec {
    #[serde(default)]
    pub euler_deg: Option<[f64; 3]>,
    #[serde(default)]
    pub euler_sequence: EulerSequence,
    #[serde(default)]
    pub quaternion_xyzw: Option<[f64; 4]>,
}

#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
pub enum EulerSequence {
    #[default]
    #[serde(rename = "321")]
    Zyx321,
    #[serde(rename = "123")]
    Xyz123,
}

impl From<EulerSequence> for EulerSeq {
    fn from(s: EulerSequence) -> Self {
        match s {
            EulerSequence::Zyx321 => EulerSeq::Zyx321,
            EulerSequence::Xyz123 => EulerSeq::Xyz123,
        }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct InitialState {
    #[serde(flatten)]
    pub attitude: AttitudeSpec,
    #[serde(default)]
    pub rate_rad_s: [f64; 3],
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Actuators {
    #[serde(default)]
    pub cmg: Option<CmgSpec>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CmgSpec {
    /// Only "pyramid4" for now.
    #[serde(default = "pyramid4")]
    pub layout: String,
    pub skew_deg: f64,
    pub h0_nms: f64,
    pub max_gimbal_rate_deg_s: f64,
    /// Symmetric gimbal stop, deg; absent = unlimited.
    #[serde(default)]
    pub gimbal_limit_deg: Option<f64>,
    #[serde(default)]
    pub initial_gimbal_deg: [f64; 4],
}

fn pyramid4() -> String {
    "pyramid4".into()
}

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
    },
}

fn default_integral_limit() -> f64 {
    1.0
}
fn default_torque_limit() -> [f64; 3] {
    [1.0e3; 3]
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Steering {
    /// "mp" (Moore-Penrose) or "sr" (singularity robust).
    pub law: String,
    #[serde(default)]
    pub alpha: Option<Alpha>,
    #[serde(default = "default_singular_threshold")]
    pub singular_threshold: f64,
}

fn default_singular_threshold() -> f64 {
    1e-6
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields, tag = "schedule", rename_all = "snake_case")]
pub enum Alpha {
    /// eq 12
    Quadratic { a0: f64, m0: f64, m_cr: f64 },
    /// eq 13
    Inverse { a0: f64, m_cr: f64, a_max: f64 },
    /// eq 14
    Exponential { a0: f64, mu: f64 },
}

#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Sensors {
    #[serde(default)]
    pub seed: u64,
    /// 1σ attitude noise per axis (small rotation), deg. Paper 000's AHRS: ~2 deg.
    #[serde(default)]
    pub attitude_noise_deg: f64,
    /// 1σ white rate noise per axis, rad/s.
    #[serde(default)]
    pub rate_noise_rad_s: f64,
    /// Constant rate bias, rad/s.
    #[serde(default)]
    pub rate_bias_rad_s: [f64; 3],
    /// 1σ gimbal-angle encoder noise, deg.
    #[serde(default)]
    pub gimbal_noise_deg: f64,
}

#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LinkSpec {
    /// Default link: "in-process", "qemu", "tcp:ADDR" or "serial:DEV[@BAUD]"; the CLI
    /// `--link` overrides it.
    #[serde(default)]
    pub kind: Option<String>,
}

fn bad(key: &str, why: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("invalid value for `{key}`: {why}")
}

fn finite(key: &str, xs: &[f64]) -> Result<()> {
    if xs.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(bad(key, "must be finite"))
    }
}

fn positive(key: &str, x: f64) -> Result<()> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(bad(key, format!("must be > 0 (got {x})")))
    }
}

impl AttitudeSpec {
    fn validate(&self, key: &str) -> Result<()> {
        match (&self.euler_deg, &self.quaternion_xyzw) {
            (Some(e), None) => finite(&format!("{key}.euler_deg"), e),
            (None, Some(q)) => {
                let k = format!("{key}.quaternion_xyzw");
                finite(&k, q)?;
                let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
                if (n - 1.0).abs() > 1e-6 {
                    return Err(bad(&k, format!("must have unit norm (got {n})")));
                }
                Ok(())
            }
            (Some(_), Some(_)) => Err(bad(
                key,
                "give either euler_deg or quaternion_xyzw, not both",
            )),
            (None, None) => Err(bad(key, "needs euler_deg or quaternion_xyzw")),
        }
    }

    pub fn quaternion(&self) -> Quat {
        match (&self.euler_deg, &self.quaternion_xyzw) {
            (_, Some(q)) => from_xyzw(*q).normalize(),
            (Some(e), None) => quat_from_euler(e.map(f64::to_radians), self.euler_sequence.into()),
            (None, None) => Quat::identity(),
        }
    }
}

impl Scenario {
    pub fn from_toml(text: &str) -> Result<Self> {
        let s: Scenario = toml::from_str(text).map_err(|e| anyhow!("{e}"))?;
        s.validate()?;
        Ok(s)
    }

    pub fn load(path: &Path) -> Result<Self> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        Self::from_toml(&text).with_context(|| format!("scenario {}", path.display()))
    }

    pub fn inertia(&self) -> Matrix3<f64> {
        Matrix3::from_fn(|r, c| self.spacecraft.inertia_kgm2[r][c])
    }

    pub fn validate(&self) -> Result<()> {
        positive("duration_s", self.duration_s)?;
        positive("timing.control_rate_hz", self.timing.control_rate_hz)?;
        if self.timing.control_rate_hz > 10_000.0 {
            return Err(bad("timing.control_rate_hz", "must be <= 10000"));
        }
        if self.timing.dynamics_substeps == 0 {
            return Err(bad("timing.dynamics_substeps", "must be >= 1"));
        }
        if self.timing.output_every == 0 {
            return Err(bad("timing.output_every", "must be >= 1"));
        }
        let i = self.inertia();
        finite("spacecraft.inertia_kgm2", i.as_slice())?;
        if (i - i.transpose()).abs().max() > 1e-9 * i.abs().max() {
            return Err(bad("spacecraft.inertia_kgm2", "must be symmetric"));
        }
        if i.symmetric_eigenvalues().min() <= 0.0 {
            return Err(bad("spacecraft.inertia_kgm2", "must be positive definite"));
        }
        let e = i.symmetric_eigenvalues();
        let (a, b, c) = (e[0], e[1], e[2]);
        if a + b < c * (1.0 - 1e-9) || b + c < a * (1.0 - 1e-9) || a + c < b * (1.0 - 1e-9) {
            return Err(bad(
                "spacecraft.inertia_kgm2",
                "principal moments violate the triangle inequality",
            ));
        }
        if let Some(m) = self.spacecraft.mass_kg {
            positive("spacecraft.mass_kg", m)?;
        }
        finite(
            "spacecraft.external_torque_nm",
            &self.spacecraft.external_torque_nm,
        )?;
        self.initial.attitude.validate("initial")?;
        finite("initial.rate_rad_s", &self.initial.rate_rad_s)?;
        self.target.validate("target")?;
        let Some(cmg) = &self.actuators.cmg else {
            bail!(
                "invalid value for `actuators`: this version steers a CMG cluster; add [actuators.cmg]"
            );
        };
        if cmg.layout != "pyramid4" {
            return Err(bad(
                "actuators.cmg.layout",
                format!("unknown layout {:?} (known: \"pyramid4\")", cmg.layout),
            ));
        }
        if !(cmg.skew_deg > 0.0 && cmg.skew_deg < 90.0) {
            return Err(bad("actuators.cmg.skew_deg", "must be in (0, 90)"));
        }
        positive("actuators.cmg.h0_nms", cmg.h0_nms)?;
        positive(
            "actuators.cmg.max_gimbal_rate_deg_s",
            cmg.max_gimbal_rate_deg_s,
        )?;
        if let Some(l) = cmg.gimbal_limit_deg {
            positive("actuators.cmg.gimbal_limit_deg", l)?;
            if cmg.initial_gimbal_deg.iter().any(|d| d.abs() > l) {
                return Err(bad(
                    "actuators.cmg.initial_gimbal_deg",
                    "outside gimbal_limit_deg",
                ));
            }
        }
        finite("actuators.cmg.initial_gimbal_deg", &cmg.initial_gimbal_deg)?;
        match &self.controller {
            Controller::QuaternionFeedback {
                zeta,
                wn_rad_s,
                k_diag_nm,
                d_diag_nms,
                ki_per_s,
                integral_limit_s,
                torque_limit_nm,
                ..
            } => {
                match (zeta, wn_rad_s, k_diag_nm, d_diag_nms) {
                    (Some(z), Some(w), None, None) => {
                        positive("controller.zeta", *z)?;
                        positive("controller.wn_rad_s", *w)?;
                    }
                    (None, None, Some(k), Some(d)) => {
                        finite("controller.k_diag_nm", k)?;
                        finite("controller.d_diag_nms", d)?;
                    }
                    _ => {
                        return Err(bad(
                            "controller",
                            "give zeta and wn_rad_s, or k_diag_nm and d_diag_nms",
                        ));
                    }
                }
                if !(ki_per_s.is_finite() && *ki_per_s >= 0.0) {
                    return Err(bad("controller.ki_per_s", "must be >= 0"));
                }
                if !(integral_limit_s.is_finite() && *integral_limit_s >= 0.0) {
                    return Err(bad("controller.integral_limit_s", "must be >= 0"));
                }
                for t in torque_limit_nm {
                    positive("controller.torque_limit_nm", *t)?;
                }
            }
        }
        match (self.steering.law.as_str(), &self.steering.alpha) {
            ("mp", None) => {}
            ("mp", Some(_)) => return Err(bad("steering.alpha", "Moore-Penrose takes no alpha")),
            ("sr", Some(a)) => {
                let v = match a {
                    Alpha::Quadratic { a0, m0, m_cr } => vec![*a0, *m0, *m_cr],
                    Alpha::Inverse { a0, m_cr, a_max } => vec![*a0, *m_cr, *a_max],
                    Alpha::Exponential { a0, mu } => vec![*a0, *mu],
                };
                if v.iter().any(|x| !x.is_finite() || *x < 0.0) {
                    return Err(bad("steering.alpha", "parameters must be finite and >= 0"));
                }
            }
            ("sr", None) => {
                return Err(bad("steering.alpha", "SR steering needs an alpha schedule"));
            }
            (other, _) => {
                return Err(bad(
                    "steering.law",
                    format!("unknown law {other:?} (known: \"mp\", \"sr\")"),
                ));
            }
        }
        positive(
            "steering.singular_threshold",
            self.steering.singular_threshold,
        )?;
        let s = &self.sensors;
        for (k, v) in [
            ("sensors.attitude_noise_deg", s.attitude_noise_deg),
            ("sensors.rate_noise_rad_s", s.rate_noise_rad_s),
            ("sensors.gimbal_noise_deg", s.gimbal_noise_deg),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(k, "must be >= 0"));
            }
        }
        finite("sensors.rate_bias_rad_s", &s.rate_bias_rad_s)?;
        // Last line of defence: the flight code's own validation must accept the upload.
        self.flight_params()?
            .validate()
            .map_err(|e| anyhow!("flight parameters rejected: {e}"))?;
        Ok(())
    }

    /// The plant described by the scenario.
    pub fn spacecraft(&self) -> Result<Spacecraft> {
        let cmg = self.actuators.cmg.as_ref().map(|c| {
            CmgCluster::pyramid(
                c.skew_deg.to_radians(),
                c.h0_nms,
                c.max_gimbal_rate_deg_s.to_radians(),
                c.gimbal_limit_deg
                    .map(|l| (-l.to_radians(), l.to_radians())),
            )
        });
        let mut sc = Spacecraft::new(self.inertia(), cmg)
            .ok_or_else(|| bad("spacecraft.inertia_kgm2", "singular"))?;
        sc.external_torque_nm = self.spacecraft.external_torque_nm.into();
        Ok(sc)
    }

    pub fn initial_state(&self) -> State {
        let mut g = [0.0; MAX_GIMBALS];
        if let Some(c) = &self.actuators.cmg {
            for (x, d) in g.iter_mut().zip(c.initial_gimbal_deg) {
                *x = d.to_radians();
            }
        }
        State {
            q: self.initial.attitude.quaternion(),
            w: self.initial.rate_rad_s.into(),
            gimbal_rad: g,
            wheels: Default::default(),
        }
    }

    /// The parameter set uploaded to the flight code.
    pub fn flight_params(&self) -> Result<FlightParams> {
        let inertia = self.inertia();
        let f = |m: &Matrix3<f64>| -> [[f32; 3]; 3] {
            std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)] as f32))
        };
        let Controller::QuaternionFeedback {
            zeta,
            wn_rad_s,
            k_diag_nm,
            d_diag_nms,
            ki_per_s,
            integral_limit_s,
            torque_limit_nm,
            gyro_compensation,
        } = &self.controller;
        let (k, d) = match (zeta, wn_rad_s, k_diag_nm, d_diag_nms) {
            (Some(z), Some(w), _, _) => (inertia * (2.0 * w * w), inertia * (2.0 * z * w)),
            (_, _, Some(k), Some(d)) => (
                Matrix3::from_diagonal(&(*k).into()),
                Matrix3::from_diagonal(&(*d).into()),
            ),
            _ => {
                return Err(bad(
                    "controller",
                    "give zeta and wn_rad_s, or k_diag_nm and d_diag_nms",
                ));
            }
        };
        let cmg = self
            .actuators
            .cmg
            .as_ref()
            .ok_or_else(|| bad("actuators.cmg", "missing"))?;
        let lim = cmg.gimbal_limit_deg.map_or(1000.0, |l| l.to_radians());
        let law = match (self.steering.law.as_str(), &self.steering.alpha) {
            ("sr", Some(Alpha::Quadratic { a0, m0, m_cr })) => {
                SteeringLaw::SingularityRobust(AlphaSchedule::Quadratic {
                    a0: *a0 as f32,
                    m0: *m0 as f32,
                    m_cr: *m_cr as f32,
                })
            }
            ("sr", Some(Alpha::Inverse { a0, m_cr, a_max })) => {
                SteeringLaw::SingularityRobust(AlphaSchedule::Inverse {
                    a0: *a0 as f32,
                    m_cr: *m_cr as f32,
                    a_max: *a_max as f32,
                })
            }
            ("sr", Some(Alpha::Exponential { a0, mu })) => {
                SteeringLaw::SingularityRobust(AlphaSchedule::Exponential {
                    a0: *a0 as f32,
                    mu: *mu as f32,
                })
            }
            _ => SteeringLaw::MoorePenrose,
        };
        let q = self.target.quaternion();
        Ok(FlightParams {
            version: PARAMS_VERSION,
            control_rate_hz: self.timing.control_rate_hz as f32,
            inertia_kgm2: f(&inertia),
            controller: ControllerParams::QuaternionFeedback(QuaternionFeedbackParams {
                k_att_nm: f(&k),
                d_rate_nms: f(&d),
                ki_att_nm_s: f(&(k * *ki_per_s)),
                integral_limit_s: *integral_limit_s as f32,
                torque_limit_nm: torque_limit_nm.map(|x| x as f32),
                gyro_compensation: *gyro_compensation,
            }),
            actuator: ActuatorParams::Cmg {
                cmg: CmgParams {
                    skew_rad: cmg.skew_deg.to_radians() as f32,
                    h0_nms: cmg.h0_nms as f32,
                    max_gimbal_rate_rad_s: cmg.max_gimbal_rate_deg_s.to_radians() as f32,
                    gimbal_min_rad: -lim as f32,
                    gimbal_max_rad: lim as f32,
                },
                steering: SteeringParams {
                    law,
                    singular_threshold: self.steering.singular_threshold as f32,
                },
            },
            target_frame: TargetFrame::Inertial,
            target_q_xyzw: [q.i as f32, q.j as f32, q.k as f32, q.w as f32],
            hold_after_missed_frames: 10,
        })
    }

    pub fn control_dt(&self) -> f64 {
        1.0 / self.timing.control_rate_hz
    }

    pub fn steps(&self) -> u64 {
        (self.duration_s * self.timing.control_rate_hz).round() as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub const MINIMAL: &str = r#"
name = "t"
duration_s = 10.0
[timing]
control_rate_hz = 100.0
[spacecraft]
inertia_kgm2 = [[3.1, 0, 0], [0, 3.1, 0], [0, 0, 5.8]]
[initial]
euler_deg = [0, 0, 0]
[target]
euler_deg = [0, 0, 50]
[actuators.cmg]
skew_deg = 54.73
h0_nms = 0.623
max_gimbal_rate_deg_s = 60
[controller]
type = "quaternion_feedback"
zeta = 0.47
wn_rad_s = 0.7
[steering]
law = "sr"
alpha = { schedule = "exponential", a0 = 0.01, mu = 10.0 }
"#;

    #[test]
    fn minimal_scenario_loads_and_makes_valid_params() {
        let s = Scenario::from_toml(MINIMAL).unwrap();
        let p = s.flight_params().unwrap();
        assert_eq!(p.validate(), Ok(()));
        // K = 2 ωn² I (eq 17)
        let ControllerParams::QuaternionFeedback(c) = &p.controller;
        assert!((c.k_att_nm[2][2] - 2.0 * 0.49 * 5.8).abs() < 1e-5);
        assert_eq!(s.steps(), 1000);
    }

    fn err_of(text: &str) -> String {
        format!("{:#}", Scenario::from_toml(text).unwrap_err())
    }

    #[test]
    fn unknown_keys_are_rejected_with_their_name() {
        let e = err_of(&MINIMAL.replace("h0_nms = 0.623", "h0_nms = 0.623\nh0_typo = 1"));
        assert!(e.contains("h0_typo"), "{e}");
        let e = err_of(&MINIMAL.replace("duration_s = 10.0", "duration_s = 10.0\ndurashun = 3"));
        assert!(e.contains("durashun"), "{e}");
    }

    #[test]
    fn impossible_values_are_rejected_with_the_key() {
        let cases = [
            (
                "[[3.1, 0, 0], [0, 3.1, 0], [0, 0, 5.8]]",
                "[[-3.1, 0, 0], [0, 3.1, 0], [0, 0, 5.8]]",
                "spacecraft.inertia_kgm2",
            ),
            (
                "[[3.1, 0, 0], [0, 3.1, 0], [0, 0, 5.8]]",
                "[[1, 0, 0], [0, 1, 0], [0, 0, 5.8]]",
                "triangle",
            ),
            (
                "[[3.1, 0, 0], [0, 3.1, 0], [0, 0, 5.8]]",
                "[[3.1, 1, 0], [0, 3.1, 0], [0, 0, 5.8]]",
                "symmetric",
            ),
            ("h0_nms = 0.623", "h0_nms = -1", "actuators.cmg.h0_nms"),
            ("duration_s = 10.0", "duration_s = 0", "duration_s"),
            ("law = \"sr\"", "law = \"xx\"", "steering.law"),
            ("zeta = 0.47", "zeta = -0.47", "controller.zeta"),
            (
                "control_rate_hz = 100.0",
                "control_rate_hz = nan",
                "timing.control_rate_hz",
            ),
        ];
        for (from, to, key) in cases {
            let e = err_of(&MINIMAL.replace(from, to));
            assert!(e.contains(key), "expected {key} in: {e}");
        }
    }
}
