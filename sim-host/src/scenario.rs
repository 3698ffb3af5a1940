//! Scenario files (TOML). The format is documented in `docs/scenario.md`; every table
//! rejects unknown keys, and [`Scenario::validate`] rejects impossible values naming
//! the key, before anything runs.

use crate::attitude::{Quat, Vec3, from_xyzw, quat_from_euler, rotate_ref_to_body};
use crate::environment::frames::{EarthRotation, julian_date};
use crate::environment::magnetic::{FieldModel, MagneticField};
use crate::environment::model::{EnvSnapshot, Environment, FieldSource};
use crate::environment::orbit::{OrbitModel, OrbitPropagator, PropagatorOptions};
use crate::environment::torques::{
    Atmosphere, Disturbances, DragGeometry, DragModel, HarmonicTorque, SrpModel, box_plates,
};
use crate::plant::cmg::GimbalServo;
use crate::plant::magnetorquers::{MagnetorquerSet, MagnetorquerSpec};
use crate::plant::rig::Rig;
use crate::plant::thrusters::{Failure as ThrusterFailure, ThrusterSet, ThrusterSpec};
use crate::plant::wheel::{WheelParams, WheelState};
use crate::plant::{MAX_GIMBALS, MAX_WHEELS, Spacecraft, State, cmg::CmgCluster};
use acs_flight::math::EulerSeq;
use acs_flight::params::{
    ActuatorParams, AlphaSchedule, CmgParams, ControllerParams, DcmPdParams, FlightParams, MAX_THRUSTERS,
    MagnetorquerParams, PARAMS_VERSION, QuaternionFeedbackParams, SteeringLaw, SteeringParams, TargetFrame,
    ThrusterMethod, ThrusterParams,
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
    /// CMG steering law (required with a CMG cluster under closed-loop control).
    #[serde(default)]
    pub steering: Option<Steering>,
    /// Orbit; absent: free space (or the lab, with `[rig]`).
    #[serde(default)]
    pub orbit: Option<OrbitSpec>,
    #[serde(default)]
    pub environment: EnvironmentSpec,
    /// Air-bearing test rig (pendulum torque, travel stops); excludes `[orbit]`.
    #[serde(default)]
    pub rig: Option<RigSpec>,
    /// Open-loop actuator command profile (with `controller.type = "none"`).
    #[serde(default)]
    pub open_loop: Option<OpenLoop>,
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
    /// Harmonic disturbance `a sin(2π f t + φ)` per body axis, added to the constant one.
    #[serde(default)]
    pub harmonic_torque: Option<HarmonicSpec>,
    /// A step change of the inertia during the run (paper 001 injects one at 100 s).
    #[serde(default)]
    pub inertia_change: Option<InertiaChange>,
    /// Residual magnetic dipole, body axes, A m² (paper 003: [0, 0, 0.001]).
    #[serde(default)]
    pub residual_dipole_am2: [f64; 3],
    /// Outer dimensions of a box-shaped body centred on the CoM, m (drag and SRP plates).
    #[serde(default)]
    pub box_m: Option<[f64; 3]>,
    /// Drag reference area and centre-of-pressure offset from the CoM (instead of `box_m`).
    #[serde(default)]
    pub drag_area_m2: Option<f64>,
    #[serde(default)]
    pub cp_offset_m: [f64; 3],
    #[serde(default = "default_cd")]
    pub drag_coefficient: f64,
}

fn default_cd() -> f64 {
    2.2
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct InertiaChange {
    pub at_s: f64,
    /// The whole inertia is multiplied by this (1.2: +20 %).
    pub factor: f64,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct HarmonicSpec {
    pub amplitude_nm: [f64; 3],
    pub frequency_hz: [f64; 3],
    #[serde(default)]
    pub phase_rad: [f64; 3],
}

/// Orbit elements, by kind.
#[derive(Clone, Debug, PartialEq)]
pub enum OrbitKind {
    Circular { altitude_km: f64, inclination_deg: f64, raan_deg: f64, arg_lat_deg: f64 },
    Kepler { a_km: f64, e: f64, inclination_deg: f64, raan_deg: f64, argp_deg: f64, true_anomaly_deg: f64 },
    Tle { line1: String, line2: String },
}

/// Orbit: `kind = "circular"` (altitude_km, inclination_deg, raan_deg, arg_lat_deg),
/// `"kepler"` (a_km, e, inclination_deg, raan_deg, argp_deg, true_anomaly_deg) or `"tle"`
/// (line1, line2).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OrbitSpec {
    pub kind: String,
    #[serde(default)]
    pub altitude_km: Option<f64>,
    #[serde(default)]
    pub a_km: Option<f64>,
    #[serde(default)]
    pub e: Option<f64>,
    #[serde(default)]
    pub inclination_deg: Option<f64>,
    #[serde(default)]
    pub raan_deg: f64,
    /// Circular: argument of latitude at t = 0.
    #[serde(default)]
    pub arg_lat_deg: f64,
    #[serde(default)]
    pub argp_deg: f64,
    #[serde(default)]
    pub true_anomaly_deg: f64,
    #[serde(default)]
    pub line1: Option<String>,
    #[serde(default)]
    pub line2: Option<String>,
    /// Numerical J2 propagation (circular/Kepler).
    #[serde(default)]
    pub j2: bool,
    /// UTC epoch of t = 0, "YYYY-MM-DDThh:mm:ss" (Earth rotation, WMM date, Sun).
    #[serde(default = "default_epoch")]
    pub epoch_utc: String,
}

impl OrbitSpec {
    /// The elements of the chosen kind, or an error naming the missing key.
    pub fn elements(&self) -> Result<OrbitKind> {
        let need = |k: &str, v: Option<f64>| {
            v.ok_or_else(|| bad(&format!("orbit.{k}"), format!("required for kind = {:?}", self.kind)))
        };
        Ok(match self.kind.as_str() {
            "circular" => OrbitKind::Circular {
                altitude_km: need("altitude_km", self.altitude_km)?,
                inclination_deg: need("inclination_deg", self.inclination_deg)?,
                raan_deg: self.raan_deg,
                arg_lat_deg: self.arg_lat_deg,
            },
            "kepler" => OrbitKind::Kepler {
                a_km: need("a_km", self.a_km)?,
                e: need("e", self.e)?,
                inclination_deg: need("inclination_deg", self.inclination_deg)?,
                raan_deg: self.raan_deg,
                argp_deg: self.argp_deg,
                true_anomaly_deg: self.true_anomaly_deg,
            },
            "tle" => OrbitKind::Tle {
                line1: self.line1.clone().ok_or_else(|| bad("orbit.line1", "required for kind = \"tle\""))?,
                line2: self.line2.clone().ok_or_else(|| bad("orbit.line2", "required for kind = \"tle\""))?,
            },
            other => {
                return Err(bad(
                    "orbit.kind",
                    format!("unknown kind {other:?} (known: \"circular\", \"kepler\", \"tle\")"),
                ));
            }
        })
    }
}

fn default_epoch() -> String {
    "2026-01-01T00:00:00".into()
}

/// Environment models.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentSpec {
    /// "none", "dipole" (tilted dipole) or "wmm" (World Magnetic Model), along the orbit.
    #[serde(default = "default_field")]
    pub magnetic_field: String,
    /// A constant field in the reference (lab) frame, T — for rigs without an orbit.
    #[serde(default)]
    pub lab_field_t: Option<[f64; 3]>,
    #[serde(default = "yes")]
    pub gravity_gradient: bool,
    /// "none", "exponential" (Vallado table) or a fixed density via `density_kg_m3`.
    #[serde(default = "default_atmosphere")]
    pub atmosphere: String,
    #[serde(default)]
    pub density_kg_m3: Option<f64>,
    /// Solar radiation pressure on the `box_m` plates.
    #[serde(default)]
    pub solar_pressure: bool,
}

impl Default for EnvironmentSpec {
    fn default() -> Self {
        Self {
            magnetic_field: default_field(),
            lab_field_t: None,
            gravity_gradient: true,
            atmosphere: default_atmosphere(),
            density_kg_m3: None,
            solar_pressure: false,
        }
    }
}

fn default_field() -> String {
    "dipole".into()
}
fn default_atmosphere() -> String {
    "none".into()
}
fn yes() -> bool {
    true
}

/// Air-bearing rig.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RigSpec {
    /// "paper003" (m g r of eq 28, ±40° roll and pitch) or "paper000" (no pendulum term
    /// given, ±45° roll and pitch); explicit keys below override the preset.
    #[serde(default)]
    pub preset: Option<String>,
    /// `m g r`, body axes, N m (paper 003 eq 28: [-0.004, -0.001, 0.5]).
    #[serde(default)]
    pub mgr_nm: Option<[f64; 3]>,
    #[serde(default)]
    pub roll_limit_deg: Option<f64>,
    #[serde(default)]
    pub pitch_limit_deg: Option<f64>,
}

/// Open-loop command table: each row holds from its time until the next row.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OpenLoop {
    #[serde(default)]
    pub commands: Vec<OpenLoopRow>,
}

#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OpenLoopRow {
    pub t_s: f64,
    #[serde(default)]
    pub gimbal_rate_rad_s: Option<[f64; 4]>,
    #[serde(default)]
    pub wheel_torque_nm: Option<Vec<f64>>,
    #[serde(default)]
    pub dipole_am2: Option<[f64; 3]>,
    /// 1-based thruster numbers that are on.
    #[serde(default)]
    pub thrusters_on: Option<Vec<usize>>,
}

/// An attitude: Euler angles `[roll, pitch, yaw]` in degrees with a sequence, or a quaternion.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct AttitudeSpec {
    /// "inertial" (default) or "lvlh" (the orbit frame: z nadir, y = -orbit normal).
    #[serde(default)]
    pub frame: RefFrame,
    #[serde(default)]
    pub euler_deg: Option<[f64; 3]>,
    #[serde(default)]
    pub euler_sequence: EulerSequence,
    #[serde(default)]
    pub quaternion_xyzw: Option<[f64; 4]>,
}

#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum RefFrame {
    #[default]
    Inertial,
    Lvlh,
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
    /// Add the rate that keeps the body fixed in LVLH (needs `[orbit]`).
    #[serde(default)]
    pub orbit_synchronous: bool,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Actuators {
    #[serde(default)]
    pub cmg: Option<CmgSpec>,
    #[serde(default)]
    pub wheels: Option<WheelsSpec>,
    #[serde(default)]
    pub magnetorquers: Option<MagnetorquersSpec>,
    #[serde(default)]
    pub thrusters: Option<ThrustersSpec>,
}

/// Reaction wheels.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct WheelsSpec {
    /// "pyramid4" (paper 001 eq 9 with `pyramid_alpha_deg`, `pyramid_beta_deg`) or "axes".
    #[serde(default = "pyramid4")]
    pub layout: String,
    #[serde(default = "default_alpha")]
    pub pyramid_alpha_deg: f64,
    #[serde(default = "default_beta")]
    pub pyramid_beta_deg: f64,
    /// Spin axes (body, unit) when `layout = "axes"`.
    #[serde(default)]
    pub axes: Vec<[f64; 3]>,
    /// "ideal" (torque and speed limits) or "accurate" (paper 001 electrical model).
    #[serde(default = "default_model")]
    pub model: String,
    /// Wheel data (defaults: paper 001): max torque 0.75 N m, 6000 rpm, 0.086 kg m².
    #[serde(default)]
    pub max_torque_nm: Option<f64>,
    #[serde(default)]
    pub max_speed_rpm: Option<f64>,
    #[serde(default)]
    pub inertia_kgm2: Option<f64>,
    #[serde(default)]
    pub initial_speed_rpm: Vec<f64>,
    /// Flight null-space momentum management.
    #[serde(default)]
    pub null_gain_per_s: f64,
    #[serde(default)]
    pub bias_speed_rpm: Vec<f64>,
    /// 1-based wheel numbers the flight code treats as failed (the plant still has them).
    #[serde(default)]
    pub failed: Vec<usize>,
}

fn default_alpha() -> f64 {
    45.0
}
fn default_beta() -> f64 {
    54.73
}
fn default_model() -> String {
    "ideal".into()
}

/// Magnetorquer rods along the body axes.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MagnetorquersSpec {
    /// Largest positive and negative dipole per axis (magnitudes), A m².
    pub max_dipole_am2: [f64; 3],
    #[serde(default)]
    pub min_dipole_am2: Option<[f64; 3]>,
    /// Hysteresis dead band per axis (paper 003 rig: -1.26 … +1.86 A m²).
    #[serde(default)]
    pub deadband_am2: Option<[f64; 2]>,
}

/// Thrusters.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ThrustersSpec {
    /// "paper004" (table 2), "matrix" (`torque_per_newton_m`) or "geometry"
    /// (`positions_m`, `directions`, about `cg_m`).
    #[serde(default = "paper004")]
    pub layout: String,
    /// Columns: torque per newton of each thruster, body axes, m.
    #[serde(default)]
    pub torque_per_newton_m: Vec<[f64; 3]>,
    /// Nozzle positions and force directions (unit), body axes.
    #[serde(default)]
    pub positions_m: Vec<[f64; 3]>,
    #[serde(default)]
    pub directions: Vec<[f64; 3]>,
    #[serde(default)]
    pub cg_m: [f64; 3],
    pub thrust_n: f64,
    pub isp_s: f64,
    #[serde(default)]
    pub min_on_time_s: f64,
    #[serde(default)]
    pub open_delay_s: f64,
    #[serde(default)]
    pub close_delay_s: f64,
    /// "direction_preserving" or "bodson".
    #[serde(default = "default_method")]
    pub method: String,
    /// PWPF (paper 004 table 3 defaults: Km 4.5, Tm 0.15 s, Uon 0.45, Uoff 0.15).
    #[serde(default = "default_pwpf")]
    pub pwpf: [f64; 4],
    #[serde(default)]
    pub failures: Vec<ThrusterFailureSpec>,
}

fn paper004() -> String {
    "paper004".into()
}
fn default_method() -> String {
    "direction_preserving".into()
}
fn default_pwpf() -> [f64; 4] {
    [4.5, 0.15, 0.45, 0.15]
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ThrusterFailureSpec {
    /// 1-based thruster number.
    pub thruster: usize,
    #[serde(default)]
    pub at_s: f64,
    /// "off" or "stuck_on".
    #[serde(default = "off")]
    pub mode: String,
    /// Whether the flight code is told (its allocation then excludes the thruster).
    #[serde(default = "yes")]
    pub known_to_flight: bool,
}

fn off() -> String {
    "off".into()
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CmgSpec {
    /// Only "pyramid4" for now.
    #[serde(default = "pyramid4")]
    pub layout: String,
    pub skew_deg: f64,
    /// Rotor momentum per unit; or give `rotor_speed_rpm` and `rotor_inertia_kgm2`.
    #[serde(default)]
    pub h0_nms: Option<f64>,
    #[serde(default)]
    pub rotor_speed_rpm: Option<f64>,
    #[serde(default)]
    pub rotor_inertia_kgm2: Option<f64>,
    pub max_gimbal_rate_deg_s: f64,
    /// Gimbal rate servo: first-order lag (s) and Coulomb friction on the gimbal bearing
    /// (N m, with the gimbal inertia in kg m²). Absent: ideal rate servo.
    #[serde(default)]
    pub servo_time_constant_s: Option<f64>,
    #[serde(default)]
    pub gimbal_inertia_kgm2: Option<f64>,
    #[serde(default)]
    pub gimbal_friction_nm: f64,
    /// Symmetric gimbal stop, deg; absent = unlimited.
    #[serde(default)]
    pub gimbal_limit_deg: Option<f64>,
    #[serde(default)]
    pub initial_gimbal_deg: [f64; 4],
    /// 1-based CMGs the flight code treats as failed (locked, column removed).
    #[serde(default)]
    pub failed: Vec<usize>,
}

impl CmgSpec {
    /// Rotor momentum per unit, N m s.
    pub fn h0(&self) -> f64 {
        self.h0_nms.unwrap_or_else(|| {
            self.rotor_speed_rpm.unwrap_or(0.0) * std::f64::consts::PI / 30.0 * self.rotor_inertia_kgm2.unwrap_or(0.0)
        })
    }
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
    /// (pendulum of `[rig]`); default from the scenario.
    Lqr {
        #[serde(default)]
        gain: Option<[[f64; 6]; 3]>,
        #[serde(default)]
        q_diag: Option<[f64; 6]>,
        #[serde(default)]
        r_diag: Option<[f64; 3]>,
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
    /// B-dot detumbling `m = -k dB/dt` with a filtered derivative (magnetorquers).
    Bdot {
        gain_am2_s_per_t: f64,
        #[serde(default)]
        filter_time_constant_s: f64,
    },
    /// No flight code: actuators follow `[open_loop]` (or nothing), for model validation.
    None,
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

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Steering {
    /// "mp" (Moore-Penrose), "sr" (singularity robust) or "gsr" (generalized SR).
    pub law: String,
    #[serde(default)]
    pub alpha: Option<Alpha>,
    /// GSR: `{ lambda0, mu, eps0, omega_rad_s }` (Wie: 0.01, 10, 0.01, π/2).
    #[serde(default)]
    pub gsr: Option<GsrSpec>,
    #[serde(default = "default_singular_threshold")]
    pub singular_threshold: f64,
    /// Null motion towards `preferred_gimbal_deg`, 1/s (0 = off).
    #[serde(default)]
    pub null_gain_per_s: f64,
    #[serde(default)]
    pub preferred_gimbal_deg: [f64; 4],
    /// Below this singularity measure the saturation (envelope) check runs.
    #[serde(default = "default_saturation_check")]
    pub saturation_check_m: f64,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GsrSpec {
    pub lambda0: f64,
    pub mu: f64,
    pub eps0: f64,
    pub omega_rad_s: f64,
}

fn default_saturation_check() -> f64 {
    0.05
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
    /// 1σ magnetometer noise per axis, T.
    #[serde(default)]
    pub magnetometer_noise_t: f64,
    /// 1σ wheel tachometer noise, rad/s.
    #[serde(default)]
    pub wheel_speed_noise_rad_s: f64,
    /// Detailed models (replace the shortcuts above when given).
    #[serde(default)]
    pub gyro: Option<GyroSensorSpec>,
    #[serde(default)]
    pub star_tracker: Option<StarTrackerSpec>,
    #[serde(default)]
    pub magnetometer: Option<MagnetometerSensorSpec>,
    #[serde(default)]
    pub sun: Option<SunSensorSpecToml>,
}

/// Rate gyro: angle random walk, rate (bias) random walk, constant bias, scale factor.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GyroSensorSpec {
    /// Sample rate (default: the control rate).
    #[serde(default)]
    pub rate_hz: Option<f64>,
    #[serde(default)]
    pub arw_rad_s_rthz: f64,
    #[serde(default)]
    pub rrw_rad_s2_rthz: f64,
    #[serde(default)]
    pub bias_rad_s: [f64; 3],
    #[serde(default)]
    pub scale_factor_ppm: f64,
}

/// Attitude sensor (star tracker / AHRS): small-rotation noise and bias per axis.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StarTrackerSpec {
    #[serde(default)]
    pub rate_hz: Option<f64>,
    #[serde(default)]
    pub noise_deg: f64,
    #[serde(default)]
    pub bias_deg: [f64; 3],
}

/// Magnetometer: noise, bias, and the field of the torquers (T per A m², row-major).
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MagnetometerSensorSpec {
    #[serde(default)]
    pub rate_hz: Option<f64>,
    #[serde(default)]
    pub noise_t: f64,
    #[serde(default)]
    pub bias_t: [f64; 3],
    #[serde(default)]
    pub coupling_t_per_am2: [[f64; 3]; 3],
}

/// Sun sensor: angular noise, field of view around a boresight, eclipse.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SunSensorSpecToml {
    #[serde(default)]
    pub rate_hz: Option<f64>,
    #[serde(default)]
    pub noise_deg: f64,
    pub boresight_body: [f64; 3],
    pub fov_half_angle_deg: f64,
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
    if xs.iter().all(|x| x.is_finite()) { Ok(()) } else { Err(bad(key, "must be finite")) }
}

fn positive(key: &str, x: f64) -> Result<()> {
    if x.is_finite() && x > 0.0 { Ok(()) } else { Err(bad(key, format!("must be > 0 (got {x})"))) }
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
            (Some(_), Some(_)) => Err(bad(key, "give either euler_deg or quaternion_xyzw, not both")),
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
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
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
        let e = i.symmetric_eigenvalues();
        if e.min() <= 0.0 {
            return Err(bad("spacecraft.inertia_kgm2", "must be positive definite"));
        }
        let (a, b, c) = (e[0], e[1], e[2]);
        if a + b < c * (1.0 - 1e-9) || b + c < a * (1.0 - 1e-9) || a + c < b * (1.0 - 1e-9) {
            return Err(bad("spacecraft.inertia_kgm2", "principal moments violate the triangle inequality"));
        }
        let sc = &self.spacecraft;
        if let Some(m) = sc.mass_kg {
            positive("spacecraft.mass_kg", m)?;
        }
        finite("spacecraft.external_torque_nm", &sc.external_torque_nm)?;
        finite("spacecraft.residual_dipole_am2", &sc.residual_dipole_am2)?;
        if let Some(c) = &sc.inertia_change {
            positive("spacecraft.inertia_change.factor", c.factor)?;
            finite("spacecraft.inertia_change.at_s", &[c.at_s])?;
        }
        finite("spacecraft.cp_offset_m", &sc.cp_offset_m)?;
        positive("spacecraft.drag_coefficient", sc.drag_coefficient)?;
        if let Some(bx) = sc.box_m {
            for x in bx {
                positive("spacecraft.box_m", x)?;
            }
        }
        if let Some(a) = sc.drag_area_m2 {
            positive("spacecraft.drag_area_m2", a)?;
        }
        if let Some(h) = &sc.harmonic_torque {
            finite("spacecraft.harmonic_torque", &[h.amplitude_nm, h.frequency_hz, h.phase_rad].concat())?;
        }
        self.initial.attitude.validate("initial")?;
        finite("initial.rate_rad_s", &self.initial.rate_rad_s)?;
        self.target.validate("target")?;
        let needs_orbit =
            |k: &str| -> Result<()> { if self.orbit.is_none() { Err(bad(k, "needs an [orbit]")) } else { Ok(()) } };
        if self.initial.attitude.frame == RefFrame::Lvlh {
            needs_orbit("initial.frame")?;
        }
        if self.initial.orbit_synchronous {
            needs_orbit("initial.orbit_synchronous")?;
        }
        if self.target.frame == RefFrame::Lvlh {
            needs_orbit("target.frame")?;
        }
        if let Some(o) = &self.orbit {
            if self.rig.is_some() {
                return Err(bad("rig", "a rig sits in a lab: remove [orbit] or [rig]"));
            }
            match &o.elements()? {
                OrbitKind::Circular { altitude_km, inclination_deg, raan_deg, arg_lat_deg } => {
                    positive("orbit.altitude_km", *altitude_km)?;
                    finite("orbit", &[*inclination_deg, *raan_deg, *arg_lat_deg])?;
                }
                OrbitKind::Kepler { a_km, e, inclination_deg, raan_deg, argp_deg, true_anomaly_deg } => {
                    if !(a_km.is_finite() && *a_km > 6378.137) {
                        return Err(bad("orbit.a_km", "must exceed the Earth's radius (6378.137 km)"));
                    }
                    if !(0.0..1.0).contains(e) {
                        return Err(bad("orbit.e", "must be in [0, 1)"));
                    }
                    if a_km * (1.0 - e) <= 6378.137 {
                        return Err(bad("orbit.e", "perigee below the Earth's surface"));
                    }
                    finite("orbit", &[*inclination_deg, *raan_deg, *argp_deg, *true_anomaly_deg])?;
                }
                OrbitKind::Tle { .. } => {}
            }
            parse_epoch(&o.epoch_utc).map_err(|e| bad("orbit.epoch_utc", e))?;
        }
        let env = &self.environment;
        match env.magnetic_field.as_str() {
            "none" => {}
            "dipole" | "wmm" => {}
            other => {
                return Err(bad(
                    "environment.magnetic_field",
                    format!("unknown model {other:?} (known: \"none\", \"dipole\", \"wmm\")"),
                ));
            }
        }
        if let Some(b) = env.lab_field_t {
            finite("environment.lab_field_t", &b)?;
            if self.orbit.is_some() {
                return Err(bad("environment.lab_field_t", "only without an [orbit]"));
            }
        }
        match env.atmosphere.as_str() {
            "none" | "exponential" => {}
            "fixed" => positive("environment.density_kg_m3", env.density_kg_m3.unwrap_or(f64::NAN))?,
            other => {
                return Err(bad(
                    "environment.atmosphere",
                    format!("unknown model {other:?} (known: \"none\", \"exponential\", \"fixed\")"),
                ));
            }
        }
        if env.atmosphere != "none" && sc.box_m.is_none() && sc.drag_area_m2.is_none() {
            return Err(bad("environment.atmosphere", "drag needs spacecraft.box_m or spacecraft.drag_area_m2"));
        }
        if env.solar_pressure && sc.box_m.is_none() {
            return Err(bad("environment.solar_pressure", "needs spacecraft.box_m"));
        }
        if let Some(r) = &self.rig {
            if let Some(p) = &r.preset {
                if !matches!(p.as_str(), "paper003" | "paper000") {
                    return Err(bad("rig.preset", format!("unknown preset {p:?} (known: \"paper003\", \"paper000\")")));
                }
            } else if r.mgr_nm.is_none() {
                return Err(bad("rig.mgr_nm", "required without a preset"));
            }
            finite("rig.mgr_nm", &r.mgr_nm.unwrap_or_default())?;
            for (k, l) in [("rig.roll_limit_deg", r.roll_limit_deg), ("rig.pitch_limit_deg", r.pitch_limit_deg)] {
                if let Some(l) = l {
                    positive(k, l)?;
                }
            }
        }
        self.validate_actuators()?;
        if let Controller::QuaternionFeedback {
            zeta,
            wn_rad_s,
            k_diag_nm,
            d_diag_nms,
            ki_per_s,
            integral_limit_s,
            torque_limit_nm,
            ..
        } = &self.controller
        {
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
                    return Err(bad("controller", "give zeta and wn_rad_s, or k_diag_nm and d_diag_nms"));
                }
            }
            if let Controller::QuaternionFeedback { max_slew_rate_deg_s: Some(r), .. } = &self.controller {
                positive("controller.max_slew_rate_deg_s", *r)?;
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
        if let Controller::DcmPd { kp_nm, kd_nms, torque_limit_nm }
        | Controller::EulerPd { kp_nm, kd_nms, torque_limit_nm } = &self.controller
        {
            finite("controller.kp_nm", kp_nm)?;
            finite("controller.kd_nms", kd_nms)?;
            for t in torque_limit_nm {
                positive("controller.torque_limit_nm", *t)?;
            }
        }
        if let Controller::Bdot { gain_am2_s_per_t, filter_time_constant_s } = &self.controller {
            positive("controller.gain_am2_s_per_t", *gain_am2_s_per_t)?;
            if !(filter_time_constant_s.is_finite() && *filter_time_constant_s >= 0.0) {
                return Err(bad("controller.filter_time_constant_s", "must be >= 0"));
            }
            if self.actuators.magnetorquers.is_none() {
                return Err(bad("controller", "B-dot commands dipoles: it needs [actuators.magnetorquers]"));
            }
        }
        let s = &self.sensors;
        for (k, v) in [
            ("sensors.attitude_noise_deg", s.attitude_noise_deg),
            ("sensors.rate_noise_rad_s", s.rate_noise_rad_s),
            ("sensors.gimbal_noise_deg", s.gimbal_noise_deg),
            ("sensors.magnetometer_noise_t", s.magnetometer_noise_t),
            ("sensors.wheel_speed_noise_rad_s", s.wheel_speed_noise_rad_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(k, "must be >= 0"));
            }
        }
        finite("sensors.rate_bias_rad_s", &s.rate_bias_rad_s)?;
        if let Some(ol) = &self.open_loop {
            if !matches!(self.controller, Controller::None) {
                return Err(bad("open_loop", "needs controller.type = \"none\""));
            }
            let mut last = f64::NEG_INFINITY;
            for (k, row) in ol.commands.iter().enumerate() {
                let key = format!("open_loop.commands[{k}]");
                if !(row.t_s.is_finite() && row.t_s >= last) {
                    return Err(bad(&key, "t_s must be finite and non-decreasing"));
                }
                last = row.t_s;
                let n_w = self.actuators.wheels.as_ref().map_or(0, |w| self.wheel_axes(w).len());
                if let Some(w) = &row.wheel_torque_nm {
                    if w.len() != n_w {
                        return Err(bad(&key, format!("wheel_torque_nm has {} entries for {n_w} wheels", w.len())));
                    }
                    finite(&key, w)?;
                }
                if row.gimbal_rate_rad_s.is_some() && self.actuators.cmg.is_none() {
                    return Err(bad(&key, "gimbal_rate_rad_s without [actuators.cmg]"));
                }
                if row.dipole_am2.is_some() && self.actuators.magnetorquers.is_none() {
                    return Err(bad(&key, "dipole_am2 without [actuators.magnetorquers]"));
                }
                if let Some(t) = &row.thrusters_on {
                    let n = self.thruster_set().map_or(0, |s| s.thrusters.len());
                    if t.iter().any(|i| *i == 0 || *i > n) {
                        return Err(bad(&key, format!("thrusters_on must be 1..={n}")));
                    }
                }
            }
        }
        if !matches!(self.controller, Controller::None) {
            // Last line of defence: the flight code's own validation must accept the upload.
            self.flight_params()?.validate().map_err(|e| anyhow!("flight parameters rejected: {e}"))?;
        }
        Ok(())
    }

    fn validate_actuators(&self) -> Result<()> {
        let act = &self.actuators;
        let families = [act.cmg.is_some(), act.wheels.is_some(), act.magnetorquers.is_some(), act.thrusters.is_some()];
        let n_families = families.iter().filter(|x| **x).count();
        if !matches!(self.controller, Controller::None) && n_families != 1 {
            return Err(bad(
                "actuators",
                format!("closed-loop control allocates to exactly one actuator family ({n_families} given)"),
            ));
        }
        if let Some(cmg) = &act.cmg {
            if cmg.layout != "pyramid4" {
                return Err(bad(
                    "actuators.cmg.layout",
                    format!("unknown layout {:?} (known: \"pyramid4\")", cmg.layout),
                ));
            }
            if !(cmg.skew_deg > 0.0 && cmg.skew_deg < 90.0) {
                return Err(bad("actuators.cmg.skew_deg", "must be in (0, 90)"));
            }
            match (cmg.h0_nms, cmg.rotor_speed_rpm, cmg.rotor_inertia_kgm2) {
                (Some(h), None, None) => positive("actuators.cmg.h0_nms", h)?,
                (None, Some(w), Some(i)) => {
                    positive("actuators.cmg.rotor_speed_rpm", w)?;
                    positive("actuators.cmg.rotor_inertia_kgm2", i)?;
                }
                _ => return Err(bad("actuators.cmg.h0_nms", "give h0_nms, or rotor_speed_rpm and rotor_inertia_kgm2")),
            }
            if let Some(tau) = cmg.servo_time_constant_s {
                positive("actuators.cmg.servo_time_constant_s", tau)?;
                positive("actuators.cmg.gimbal_inertia_kgm2", cmg.gimbal_inertia_kgm2.unwrap_or(f64::NAN))?;
            }
            if !(cmg.gimbal_friction_nm.is_finite() && cmg.gimbal_friction_nm >= 0.0) {
                return Err(bad("actuators.cmg.gimbal_friction_nm", "must be >= 0"));
            }
            if cmg.gimbal_friction_nm > 0.0 && cmg.servo_time_constant_s.is_none() {
                return Err(bad(
                    "actuators.cmg.gimbal_friction_nm",
                    "needs servo_time_constant_s (friction acts on the servo)",
                ));
            }
            positive("actuators.cmg.max_gimbal_rate_deg_s", cmg.max_gimbal_rate_deg_s)?;
            if let Some(l) = cmg.gimbal_limit_deg {
                positive("actuators.cmg.gimbal_limit_deg", l)?;
                if cmg.initial_gimbal_deg.iter().any(|d| d.abs() > l) {
                    return Err(bad("actuators.cmg.initial_gimbal_deg", "outside gimbal_limit_deg"));
                }
            }
            finite("actuators.cmg.initial_gimbal_deg", &cmg.initial_gimbal_deg)?;
            if cmg.failed.iter().any(|i| *i == 0 || *i > 4) {
                return Err(bad("actuators.cmg.failed", "CMG numbers are 1..=4"));
            }
            if !matches!(self.controller, Controller::None) && self.steering.is_none() {
                return Err(bad("steering", "a CMG cluster under control needs [steering]"));
            }
            if let Some(st) = &self.steering {
                match (st.law.as_str(), &st.alpha) {
                    ("mp", None) => {}
                    ("mp", Some(_)) => {
                        return Err(bad("steering.alpha", "Moore-Penrose takes no alpha"));
                    }
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
                    ("gsr", _) => {
                        let g = st
                            .gsr
                            .as_ref()
                            .ok_or_else(|| bad("steering.gsr", "GSR needs { lambda0, mu, eps0, omega_rad_s }"))?;
                        if [g.lambda0, g.mu, g.eps0].iter().any(|x| !x.is_finite() || *x < 0.0)
                            || g.omega_rad_s.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
                        {
                            return Err(bad("steering.gsr", "lambda0, mu, eps0 >= 0 and omega_rad_s > 0"));
                        }
                    }
                    (other, _) => {
                        return Err(bad(
                            "steering.law",
                            format!("unknown law {other:?} (known: \"mp\", \"sr\", \"gsr\")"),
                        ));
                    }
                }
                positive("steering.singular_threshold", st.singular_threshold)?;
                if !(st.null_gain_per_s.is_finite() && st.null_gain_per_s >= 0.0) {
                    return Err(bad("steering.null_gain_per_s", "must be >= 0"));
                }
                finite("steering.preferred_gimbal_deg", &st.preferred_gimbal_deg)?;
            }
        }
        if let Some(w) = &act.wheels {
            match w.layout.as_str() {
                "pyramid4" => {
                    finite("actuators.wheels.pyramid_alpha_deg", &[w.pyramid_alpha_deg])?;
                    if !(w.pyramid_beta_deg > 0.0 && w.pyramid_beta_deg < 90.0) {
                        return Err(bad("actuators.wheels.pyramid_beta_deg", "must be in (0, 90)"));
                    }
                }
                "axes" => {
                    if w.axes.is_empty() || w.axes.len() > MAX_WHEELS {
                        return Err(bad("actuators.wheels.axes", format!("needs 1..={MAX_WHEELS} axes")));
                    }
                    for a in &w.axes {
                        let n = Vec3::from(*a).norm();
                        if !n.is_finite() || n < 1e-9 {
                            return Err(bad("actuators.wheels.axes", "zero-norm or non-finite axis"));
                        }
                    }
                }
                other => {
                    return Err(bad(
                        "actuators.wheels.layout",
                        format!("unknown layout {other:?} (known: \"pyramid4\", \"axes\")"),
                    ));
                }
            }
            if !matches!(w.model.as_str(), "ideal" | "accurate") {
                return Err(bad("actuators.wheels.model", "must be \"ideal\" or \"accurate\""));
            }
            for (k, v) in [
                ("actuators.wheels.max_torque_nm", w.max_torque_nm),
                ("actuators.wheels.max_speed_rpm", w.max_speed_rpm),
                ("actuators.wheels.inertia_kgm2", w.inertia_kgm2),
            ] {
                if let Some(v) = v {
                    positive(k, v)?;
                }
            }
            let n = self.wheel_axes(w).len();
            for (k, v) in [
                ("actuators.wheels.initial_speed_rpm", &w.initial_speed_rpm),
                ("actuators.wheels.bias_speed_rpm", &w.bias_speed_rpm),
            ] {
                if !v.is_empty() && v.len() != n {
                    return Err(bad(k, format!("has {} entries for {n} wheels", v.len())));
                }
                finite(k, v)?;
            }
            if w.failed.iter().any(|i| *i == 0 || *i > n) {
                return Err(bad("actuators.wheels.failed", format!("wheel numbers are 1..={n}")));
            }
            if !(w.null_gain_per_s.is_finite() && w.null_gain_per_s >= 0.0) {
                return Err(bad("actuators.wheels.null_gain_per_s", "must be >= 0"));
            }
            for p in self.wheel_params()? {
                p.validate().map_err(|e| bad("actuators.wheels", e))?;
            }
        }
        if let Some(m) = &act.magnetorquers {
            for x in m.max_dipole_am2.iter().chain(m.min_dipole_am2.iter().flatten()) {
                positive("actuators.magnetorquers.max_dipole_am2", *x)?;
            }
            if let Some([lo, hi]) = m.deadband_am2
                && !(lo <= 0.0 && hi >= 0.0 && lo.is_finite() && hi.is_finite())
            {
                return Err(bad("actuators.magnetorquers.deadband_am2", "must be [lo <= 0, hi >= 0]"));
            }
            if self.orbit.is_none() && self.environment.lab_field_t.is_none() {
                return Err(bad("actuators.magnetorquers", "need a field: an [orbit] or environment.lab_field_t"));
            }
        }
        if let Some(t) = &act.thrusters {
            positive("actuators.thrusters.thrust_n", t.thrust_n)?;
            positive("actuators.thrusters.isp_s", t.isp_s)?;
            for (k, v) in [
                ("actuators.thrusters.min_on_time_s", t.min_on_time_s),
                ("actuators.thrusters.open_delay_s", t.open_delay_s),
                ("actuators.thrusters.close_delay_s", t.close_delay_s),
            ] {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(bad(k, "must be >= 0"));
                }
            }
            match t.layout.as_str() {
                "paper004" => {}
                "matrix" => {
                    if t.torque_per_newton_m.is_empty() || t.torque_per_newton_m.len() > MAX_THRUSTERS {
                        return Err(bad(
                            "actuators.thrusters.torque_per_newton_m",
                            format!("needs 1..={MAX_THRUSTERS} columns"),
                        ));
                    }
                    finite("actuators.thrusters.torque_per_newton_m", &t.torque_per_newton_m.concat())?;
                }
                "geometry" => {
                    let n = t.positions_m.len();
                    if n == 0 || n > MAX_THRUSTERS || t.directions.len() != n {
                        return Err(bad(
                            "actuators.thrusters.positions_m",
                            format!("needs 1..={MAX_THRUSTERS} positions and as many directions"),
                        ));
                    }
                    finite("actuators.thrusters.positions_m", &t.positions_m.concat())?;
                    for d in &t.directions {
                        let norm = Vec3::from(*d).norm();
                        if !(norm.is_finite() && norm > 1e-9) {
                            return Err(bad("actuators.thrusters.directions", "zero-norm or non-finite direction"));
                        }
                    }
                }
                other => {
                    return Err(bad(
                        "actuators.thrusters.layout",
                        format!("unknown layout {other:?} (known: \"paper004\", \"matrix\", \"geometry\")"),
                    ));
                }
            }
            if !matches!(t.method.as_str(), "direction_preserving" | "bodson") {
                return Err(bad("actuators.thrusters.method", "must be \"direction_preserving\" or \"bodson\""));
            }
            let n = self.thruster_set().map_or(0, |s| s.thrusters.len());
            for f in &t.failures {
                if f.thruster == 0 || f.thruster > n {
                    return Err(bad("actuators.thrusters.failures", format!("thruster numbers are 1..={n}")));
                }
                if !(matches!(f.mode.as_str(), "off" | "stuck_on") && f.at_s.is_finite() && f.at_s >= 0.0) {
                    return Err(bad("actuators.thrusters.failures", "mode \"off\" or \"stuck_on\", at_s >= 0"));
                }
            }
        }
        Ok(())
    }

    /// Spin axes of the wheels (unit, body).
    pub fn wheel_axes(&self, w: &WheelsSpec) -> Vec<[f64; 3]> {
        match w.layout.as_str() {
            "axes" => w.axes.iter().map(|a| (Vec3::from(*a).normalize()).into()).collect(),
            _ => {
                // Paper 001 eq 9.
                let (al, be) = (w.pyramid_alpha_deg.to_radians(), w.pyramid_beta_deg.to_radians());
                let (ca, sa, cb, sb) = (al.cos(), al.sin(), be.cos(), be.sin());
                vec![[ca * sb, sa * sb, cb], [-sa * sb, ca * sb, cb], [-ca * sb, -sa * sb, cb], [sa * sb, -ca * sb, cb]]
            }
        }
    }

    /// Plant models of the wheels.
    pub fn wheel_params(&self) -> Result<Vec<WheelParams>> {
        let Some(w) = &self.actuators.wheels else {
            return Ok(Vec::new());
        };
        let base = WheelParams::paper001();
        let rpm = std::f64::consts::PI / 30.0;
        Ok(self
            .wheel_axes(w)
            .into_iter()
            .map(|axis| {
                let mut p = match w.model.as_str() {
                    "accurate" => base.clone(),
                    _ => WheelParams::ideal(
                        w.max_torque_nm.unwrap_or(base.max_torque_nm),
                        w.max_speed_rpm.map_or(base.max_speed_rad_s, |x| x * rpm),
                        w.inertia_kgm2.unwrap_or(base.inertia_kgm2),
                    ),
                };
                if let Some(t) = w.max_torque_nm {
                    p.max_torque_nm = t;
                }
                if let Some(s) = w.max_speed_rpm {
                    p.max_speed_rad_s = s * rpm;
                }
                if let Some(i) = w.inertia_kgm2 {
                    p.inertia_kgm2 = i;
                }
                p.spin_axis = axis;
                p
            })
            .collect())
    }

    /// Plant model of the magnetorquers (rods + residual dipole).
    pub fn magnetorquer_set(&self) -> MagnetorquerSet {
        let residual = self.spacecraft.residual_dipole_am2;
        match &self.actuators.magnetorquers {
            Some(m) => {
                let [lo, hi] = m.deadband_am2.unwrap_or([0.0, 0.0]);
                let neg = m.min_dipole_am2.unwrap_or(m.max_dipole_am2);
                let rods = (0..3)
                    .map(|i| {
                        let mut axis = [0.0; 3];
                        axis[i] = 1.0;
                        MagnetorquerSpec {
                            axis,
                            max_pos_am2: m.max_dipole_am2[i],
                            max_neg_am2: neg[i],
                            deadband_lo_am2: lo,
                            deadband_hi_am2: hi,
                        }
                    })
                    .collect();
                MagnetorquerSet { rods, residual_dipole_am2: residual }
            }
            None => MagnetorquerSet { rods: Vec::new(), residual_dipole_am2: residual },
        }
    }

    /// Plant model of the thrusters, failures included.
    pub fn thruster_set(&self) -> Option<ThrusterSet> {
        let t = self.actuators.thrusters.as_ref()?;
        let mut set = match t.layout.as_str() {
            "geometry" => ThrusterSet {
                thrusters: t
                    .positions_m
                    .iter()
                    .zip(&t.directions)
                    .map(|(p, d)| ThrusterSpec {
                        position_m: *p,
                        direction: Vec3::from(*d).normalize().into(),
                        thrust_n: t.thrust_n,
                        isp_s: t.isp_s,
                        min_on_time_s: t.min_on_time_s,
                        open_delay_s: t.open_delay_s,
                        close_delay_s: t.close_delay_s,
                        torque_per_n_m: None,
                    })
                    .collect(),
                failures: Vec::new(),
                cg_m: t.cg_m,
            },
            layout => {
                let cols: Vec<[f64; 3]> = if layout == "matrix" {
                    t.torque_per_newton_m.clone()
                } else {
                    ThrusterSet::paper004(1.0).torque_matrix()
                };
                ThrusterSet::from_torque_matrix(
                    &cols,
                    t.thrust_n,
                    t.isp_s,
                    t.min_on_time_s,
                    t.open_delay_s,
                    t.close_delay_s,
                )
            }
        };
        set.failures = t
            .failures
            .iter()
            .map(|f| {
                (
                    f.thruster - 1,
                    f.at_s,
                    if f.mode == "stuck_on" { ThrusterFailure::StuckOn } else { ThrusterFailure::Off },
                )
            })
            .collect();
        Some(set)
    }

    /// The environment of the run (`None`: free space without a field, or a rig without one).
    pub fn environment(&self) -> Result<Option<Environment>> {
        let sc = &self.spacecraft;
        let inertia = self.inertia();
        let external = match &sc.harmonic_torque {
            Some(h) => HarmonicTorque {
                a: Vec3::zeros(),
                b: Vec3::from(h.amplitude_nm),
                omega: Vec3::from(h.frequency_hz) * std::f64::consts::TAU,
                phi: Vec3::from(h.phase_rad),
            },
            None => HarmonicTorque::default(),
        };
        let plates = sc.box_m.map(|b| box_plates(b[0], b[1], b[2], Vec3::zeros()));
        let env = &self.environment;
        let Some(o) = &self.orbit else {
            if env.lab_field_t.is_none() && sc.harmonic_torque.is_none() {
                return Ok(None);
            }
            let disturbances = Disturbances {
                inertia,
                gravity_gradient: false,
                drag: None,
                srp: None,
                residual_dipole_am2: Vec3::zeros(),
                external,
            };
            let field = env.lab_field_t.map_or(FieldSource::None, |b| FieldSource::Fixed(Vec3::from(b)));
            return Ok(Some(Environment {
                orbit: None,
                earth: EarthRotation::Simple { theta0_rad: 0.0 },
                field,
                disturbances,
            }));
        };
        let jd = parse_epoch(&o.epoch_utc).map_err(|e| bad("orbit.epoch_utc", e))?;
        let model = match &o.elements()? {
            OrbitKind::Circular { altitude_km, inclination_deg, raan_deg, arg_lat_deg } => OrbitModel::Circular {
                altitude_m: altitude_km * 1e3,
                inclination_rad: inclination_deg.to_radians(),
                raan_rad: raan_deg.to_radians(),
                arg_lat0_rad: arg_lat_deg.to_radians(),
            },
            OrbitKind::Kepler { a_km, e, inclination_deg, raan_deg, argp_deg, true_anomaly_deg } => {
                OrbitModel::Kepler {
                    a_m: a_km * 1e3,
                    e: *e,
                    i: inclination_deg.to_radians(),
                    raan: raan_deg.to_radians(),
                    argp: argp_deg.to_radians(),
                    nu0: true_anomaly_deg.to_radians(),
                }
            }
            OrbitKind::Tle { line1, line2 } => OrbitModel::Tle { line1: line1.clone(), line2: line2.clone() },
        };
        let prop = OrbitPropagator::new(&model, PropagatorOptions { j2: o.j2, step_s: 10.0 })
            .map_err(|e| bad("orbit", format!("{e:?}")))?;
        // A TLE brings its own epoch.
        let jd = prop.epoch_jd_utc().unwrap_or(jd);
        let earth = EarthRotation::Gmst { jd_ut1_epoch: jd };
        let field = match env.magnetic_field.as_str() {
            "dipole" => FieldSource::Model(MagneticField::new(FieldModel::default_dipole(), earth)),
            "wmm" => FieldSource::Model(MagneticField::new(
                FieldModel::Wmm { decimal_year: 2000.0 + (jd - 2_451_544.5) / 365.25 },
                earth,
            )),
            _ => FieldSource::None,
        };
        let geometry = match (sc.drag_area_m2, &plates) {
            (Some(a), _) => Some(DragGeometry::CopOffset { area_m2: a, cop_b: Vec3::from(sc.cp_offset_m) }),
            (None, Some(p)) => Some(DragGeometry::Plates(p.clone())),
            _ => None,
        };
        let atmosphere = match env.atmosphere.as_str() {
            "exponential" => Some(Atmosphere::ExponentialVallado),
            "fixed" => env.density_kg_m3.map(|rho| Atmosphere::Fixed { rho_kg_m3: rho }),
            _ => None,
        };
        let drag = match (geometry, atmosphere) {
            (Some(geometry), Some(atmosphere)) => Some(DragModel { geometry, cd: sc.drag_coefficient, atmosphere }),
            _ => None,
        };
        let srp = match (&plates, env.solar_pressure) {
            (Some(p), true) => Some(SrpModel { plates: p.clone(), pressure_n_m2: 4.56e-6, jd_epoch: jd }),
            _ => None,
        };
        let disturbances = Disturbances {
            inertia,
            gravity_gradient: env.gravity_gradient,
            drag,
            srp,
            residual_dipole_am2: Vec3::zeros(),
            external,
        };
        Ok(Some(Environment { orbit: Some(prop), earth, field, disturbances }))
    }

    /// The plant described by the scenario.
    pub fn spacecraft(&self) -> Result<Spacecraft> {
        let cmg = self.actuators.cmg.as_ref().map(|c| {
            let mut cl = CmgCluster::pyramid(
                c.skew_deg.to_radians(),
                c.h0(),
                c.max_gimbal_rate_deg_s.to_radians(),
                c.gimbal_limit_deg.map(|l| (-l.to_radians(), l.to_radians())),
            );
            cl.servo = c.servo_time_constant_s.map(|tau| GimbalServo {
                time_constant_s: tau,
                gimbal_inertia_kgm2: c.gimbal_inertia_kgm2.unwrap_or(1.0),
                friction_nm: c.gimbal_friction_nm,
            });
            cl
        });
        let wheels = self.wheel_params()?;
        // The scenario inertia includes the wheels; the body equation uses J = I - Σ I_w a aᵀ.
        let mut j = self.inertia();
        for w in &wheels {
            let a = Vec3::from(w.spin_axis);
            j -= a * a.transpose() * w.inertia_kgm2;
        }
        let mut sc = Spacecraft::new(j, cmg)
            .ok_or_else(|| bad("spacecraft.inertia_kgm2", "singular once the wheels' axial inertia is removed"))?;
        sc.wheels = wheels;
        sc.external_torque_nm = self.spacecraft.external_torque_nm.into();
        sc.env = self.environment()?;
        sc.rig = self.rig.as_ref().map(|r| {
            let base = match r.preset.as_deref() {
                Some("paper003") => Rig::paper003().1,
                Some("paper000") => Rig::paper000(),
                _ => Rig { mgr_nm: Vec3::zeros(), roll_limit_rad: None, pitch_limit_rad: None },
            };
            Rig {
                mgr_nm: r.mgr_nm.map_or(base.mgr_nm, Vec3::from),
                roll_limit_rad: r.roll_limit_deg.map(f64::to_radians).or(base.roll_limit_rad),
                pitch_limit_rad: r.pitch_limit_deg.map(f64::to_radians).or(base.pitch_limit_rad),
            }
        });
        Ok(sc)
    }

    /// Initial state; `env` is needed for attitudes or rates given relative to LVLH.
    pub fn initial_state(&self, craft: &Spacecraft, env0: Option<&EnvSnapshot>) -> State {
        let mut g = [0.0; MAX_GIMBALS];
        if let Some(c) = &self.actuators.cmg {
            for (x, d) in g.iter_mut().zip(c.initial_gimbal_deg) {
                *x = d.to_radians();
            }
        }
        let q_lvlh = env0.and_then(|e| e.q_lvlh).unwrap_or_else(Quat::identity);
        let mut q = self.initial.attitude.quaternion();
        if self.initial.attitude.frame == RefFrame::Lvlh {
            q = q_lvlh * q;
        }
        let mut w = Vec3::from(self.initial.rate_rad_s);
        if self.initial.orbit_synchronous {
            w += rotate_ref_to_body(&q, &env0.map_or(Vec3::zeros(), |e| e.lvlh_rate_ref));
        }
        let mut wheels = [WheelState::default(); MAX_WHEELS];
        let rpm = std::f64::consts::PI / 30.0;
        let speeds = self.actuators.wheels.as_ref().map_or(Vec::new(), |w| w.initial_speed_rpm.clone());
        for (i, p) in craft.wheels.iter().enumerate() {
            wheels[i] = WheelState::spinning(p, speeds.get(i).copied().unwrap_or(0.0) * rpm, &w.into());
        }
        State { q, w, gimbal_rad: g, gimbal_rate_rad_s: [0.0; MAX_GIMBALS], wheels }
    }

    /// The parameter set uploaded to the flight code.
    pub fn flight_params(&self) -> Result<FlightParams> {
        let inertia = self.inertia();
        let f =
            |m: &Matrix3<f64>| -> [[f32; 3]; 3] { std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)] as f32)) };
        let controller = match &self.controller {
            Controller::QuaternionFeedback {
                zeta,
                wn_rad_s,
                k_diag_nm,
                d_diag_nms,
                ki_per_s,
                integral_limit_s,
                torque_limit_nm,
                gyro_compensation,
                max_slew_rate_deg_s,
            } => {
                let (k, d) = match (zeta, wn_rad_s, k_diag_nm, d_diag_nms) {
                    (Some(z), Some(w), _, _) => (inertia * (2.0 * w * w), inertia * (2.0 * z * w)),
                    (_, _, Some(k), Some(d)) => {
                        (Matrix3::from_diagonal(&(*k).into()), Matrix3::from_diagonal(&(*d).into()))
                    }
                    _ => return Err(bad("controller", "give zeta and wn_rad_s, or k_diag_nm and d_diag_nms")),
                };
                ControllerParams::QuaternionFeedback(QuaternionFeedbackParams {
                    k_att_nm: f(&k),
                    d_rate_nms: f(&d),
                    ki_att_nm_s: f(&(k * *ki_per_s)),
                    integral_limit_s: *integral_limit_s as f32,
                    torque_limit_nm: torque_limit_nm.map(|x| x as f32),
                    gyro_compensation: *gyro_compensation,
                    max_slew_rate_rad_s: max_slew_rate_deg_s.map_or(0.0, |r| r.to_radians() as f32),
                })
            }
            Controller::DcmPd { kp_nm, kd_nms, torque_limit_nm } => ControllerParams::DcmPd(DcmPdParams {
                kp_nm: kp_nm.map(|x| x as f32),
                kd_nms: kd_nms.map(|x| x as f32),
                torque_limit_nm: torque_limit_nm.map(|x| x as f32),
            }),
            Controller::EulerPd { kp_nm, kd_nms, torque_limit_nm } => ControllerParams::EulerPd(DcmPdParams {
                kp_nm: kp_nm.map(|x| x as f32),
                kd_nms: kd_nms.map(|x| x as f32),
                torque_limit_nm: torque_limit_nm.map(|x| x as f32),
            }),
            Controller::Lqr { torque_limit_nm, .. } => {
                let k = self.lqr_design()?.gain;
                ControllerParams::Lqr {
                    k: k.map(|row| row.map(|x| x as f32)),
                    torque_limit_nm: torque_limit_nm.map(|x| x as f32),
                }
            }
            Controller::Lqg { .. } => ControllerParams::Lqg(self.lqg_design()?),
            Controller::Dmcs {
                wn_rad_s,
                zeta,
                model_inertia_kgm2,
                alpha,
                beta,
                q_weights,
                gain_limit,
                torque_limit_nm,
            } => ControllerParams::Dmcs(acs_flight::params::DmcsParams {
                wn_rad_s: *wn_rad_s as f32,
                zeta: *zeta as f32,
                model_inertia_kgm2: model_inertia_kgm2.map(|x| x as f32),
                alpha: *alpha as f32,
                beta: *beta as f32,
                q_weights: q_weights.map(|x| x as f32),
                gain_limit: *gain_limit as f32,
                torque_limit_nm: torque_limit_nm.map(|x| x as f32),
            }),
            Controller::Bdot { gain_am2_s_per_t, filter_time_constant_s } => ControllerParams::Bdot {
                gain_am2_s_per_t: *gain_am2_s_per_t as f32,
                filter_time_constant_s: *filter_time_constant_s as f32,
            },
            Controller::None => bail!("controller.type = \"none\" uploads no flight parameters"),
        };
        let q = self.target.quaternion();
        Ok(FlightParams {
            version: PARAMS_VERSION,
            control_rate_hz: self.timing.control_rate_hz as f32,
            inertia_kgm2: f(&inertia),
            controller,
            actuator: self.actuator_params()?,
            target_q_xyzw: [q.i as f32, q.j as f32, q.k as f32, q.w as f32],
            target_frame: match self.target.frame {
                RefFrame::Inertial => TargetFrame::Inertial,
                RefFrame::Lvlh => TargetFrame::Reference,
            },
            hold_after_missed_frames: 10,
        })
    }

    fn actuator_params(&self) -> Result<ActuatorParams> {
        let act = &self.actuators;
        if let Some(cmg) = &act.cmg {
            let st = self.steering.as_ref().ok_or_else(|| bad("steering", "missing"))?;
            let lim = cmg.gimbal_limit_deg.map_or(1000.0, |l| l.to_radians());
            let law = match (st.law.as_str(), &st.alpha) {
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
                    SteeringLaw::SingularityRobust(AlphaSchedule::Exponential { a0: *a0 as f32, mu: *mu as f32 })
                }
                ("gsr", _) => match &st.gsr {
                    Some(g) => SteeringLaw::GeneralizedSr {
                        lambda0: g.lambda0 as f32,
                        mu: g.mu as f32,
                        eps0: g.eps0 as f32,
                        omega_rad_s: g.omega_rad_s as f32,
                    },
                    None => bail!("invalid value for `steering.gsr`: missing"),
                },
                _ => SteeringLaw::MoorePenrose,
            };
            return Ok(ActuatorParams::Cmg {
                cmg: CmgParams {
                    skew_rad: cmg.skew_deg.to_radians() as f32,
                    h0_nms: cmg.h0() as f32,
                    max_gimbal_rate_rad_s: cmg.max_gimbal_rate_deg_s.to_radians() as f32,
                    gimbal_min_rad: -lim as f32,
                    gimbal_max_rad: lim as f32,
                    failed_mask: cmg.failed.iter().fold(0u8, |m, i| m | (1 << (i - 1))),
                },
                steering: SteeringParams {
                    law,
                    singular_threshold: st.singular_threshold as f32,
                    null_gain_per_s: st.null_gain_per_s as f32,
                    preferred_gimbal_rad: st.preferred_gimbal_deg.map(|d| d.to_radians() as f32),
                    saturation_check_m: st.saturation_check_m as f32,
                },
            });
        }
        if let Some(w) = &act.wheels {
            let plant = self.wheel_params()?;
            let mut axes = [[0.0f32; 3]; MAX_WHEELS];
            let mut bias = [0.0f32; MAX_WHEELS];
            let rpm = std::f64::consts::PI / 30.0;
            for (i, p) in plant.iter().enumerate().take(MAX_WHEELS) {
                axes[i] = p.spin_axis.map(|x| x as f32);
                bias[i] = (w.bias_speed_rpm.get(i).copied().unwrap_or(0.0) * rpm) as f32;
            }
            let p0 = plant.first().ok_or_else(|| bad("actuators.wheels", "no wheels"))?;
            let failed_mask = w.failed.iter().fold(0u8, |m, i| m | (1u8 << (i - 1)));
            return Ok(ActuatorParams::Wheels(acs_flight::params::WheelParams {
                count: plant.len() as u8,
                axes,
                max_torque_nm: p0.max_torque_nm as f32,
                max_speed_rad_s: p0.max_speed_rad_s as f32,
                inertia_kgm2: p0.inertia_kgm2 as f32,
                null_gain_per_s: w.null_gain_per_s as f32,
                bias_speed_rad_s: bias,
                failed_mask,
            }));
        }
        if let Some(m) = &act.magnetorquers {
            let neg = m.min_dipole_am2.unwrap_or(m.max_dipole_am2);
            let [lo, hi] = m.deadband_am2.unwrap_or([0.0, 0.0]);
            return Ok(ActuatorParams::Magnetorquers(MagnetorquerParams {
                max_dipole_am2: m.max_dipole_am2.map(|x| x as f32),
                min_dipole_am2: neg.map(|x| x as f32),
                deadband_lo_am2: [lo as f32; 3],
                deadband_hi_am2: [hi as f32; 3],
                min_field_t: 1e-7,
            }));
        }
        if let Some(t) = &act.thrusters {
            let set = self.thruster_set().ok_or_else(|| bad("actuators.thrusters", "missing"))?;
            let b = set.torque_matrix();
            let mut torque_nm = [[0.0f32; MAX_THRUSTERS]; 3];
            for (j, col) in b.iter().enumerate().take(MAX_THRUSTERS) {
                for k in 0..3 {
                    torque_nm[k][j] = col[k] as f32;
                }
            }
            let failed_mask = t
                .failures
                .iter()
                .filter(|f| f.known_to_flight && f.mode == "off")
                .fold(0u16, |m, f| m | (1 << (f.thruster - 1)));
            return Ok(ActuatorParams::Thrusters(ThrusterParams {
                count: b.len() as u8,
                torque_nm,
                method: if t.method == "bodson" { ThrusterMethod::Bodson } else { ThrusterMethod::DirectionPreserving },
                pwpf_km: t.pwpf[0] as f32,
                pwpf_tm_s: t.pwpf[1] as f32,
                pwpf_u_on: t.pwpf[2] as f32,
                pwpf_u_off: t.pwpf[3] as f32,
                failed_mask,
            }));
        }
        bail!("invalid value for `actuators`: no actuator to control")
    }

    pub fn control_dt(&self) -> f64 {
        1.0 / self.timing.control_rate_hz
    }

    pub fn steps(&self) -> u64 {
        (self.duration_s * self.timing.control_rate_hz).round() as u64
    }
}

/// An LQR design: the gain and what it was computed from.
#[derive(Clone, Debug)]
pub struct LqrDesign {
    pub gain: [[f64; 6]; 3],
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
        use crate::design::models::{AttitudeModel, circular_orbit_rate};
        use crate::design::riccati;
        use nalgebra::DMatrix;
        let (q, r, model) = match &self.controller {
            Controller::Lqr { gain: Some(k), .. } => {
                return Ok(LqrDesign {
                    gain: *k,
                    model: "given".into(),
                    closed_loop_eigenvalues: Vec::new(),
                    residual: 0.0,
                    a: DMatrix::zeros(6, 6),
                    b: DMatrix::zeros(6, 3),
                });
            }
            Controller::Lqr { q_diag: Some(q), r_diag: Some(r), model, .. } => (q, r, model),
            Controller::Lqr { .. } => return Err(bad("controller", "lqr needs `gain`, or `q_diag` and `r_diag`")),
            Controller::Lqg { q_diag, r_diag, model, .. } => (q_diag, r_diag, model),
            _ => bail!("controller.type is not \"lqr\" or \"lqg\""),
        };
        let default_model = if self.rig.is_some() {
            "rig"
        } else if self.orbit.is_some() {
            "orbit"
        } else {
            "free"
        };
        let model = model.clone().unwrap_or_else(|| default_model.into());
        let orbit_rate = match self.orbit.as_ref().map(|o| o.elements()).transpose()? {
            Some(OrbitKind::Circular { altitude_km, .. }) => circular_orbit_rate(altitude_km * 1e3),
            Some(OrbitKind::Kepler { a_km, .. }) => (3.986004418e14 / (a_km * 1e3).powi(3)).sqrt(),
            _ => 0.0,
        };
        let mgr = self.spacecraft()?.rig.map_or(Vec3::zeros(), |r| r.mgr_nm);
        let m = AttitudeModel {
            inertia: self.inertia(),
            orbit_rate: if model == "orbit" { orbit_rate } else { 0.0 },
            gravity_gradient: model == "orbit",
            mgr: if model == "rig" { mgr } else { Vec3::zeros() },
            stored_momentum: Vec3::zeros(),
            input: DMatrix::identity(3, 3),
        };
        if !matches!(model.as_str(), "free" | "orbit" | "rig") {
            return Err(bad(
                "controller.model",
                format!("unknown model {model:?} (known: \"free\", \"orbit\", \"rig\")"),
            ));
        }
        let (a, b) = m.linear();
        let qm = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(q));
        let rm = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(r));
        let (k, x) =
            riccati::lqr(&a, &b, &qm, &rm).map_err(|e| bad("controller", format!("LQR design failed: {e:?}")))?;
        let residual = riccati::care_residual_rel(&a, &b, &qm, &rm, &x).unwrap_or(f64::NAN);
        let closed = &a - &b * &k;
        let gain = std::array::from_fn(|i| std::array::from_fn(|j| k[(i, j)]));
        Ok(LqrDesign {
            gain,
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
        use crate::design::{discretize::c2d, kalman::steady_state_kalman};
        use nalgebra::DMatrix;
        let Controller::Lqg { process_noise, measurement_noise, torque_limit_nm, .. } = &self.controller else {
            bail!("controller.type is not \"lqg\"");
        };
        let d = self.lqr_design()?;
        let (ad, bd) = c2d(&d.a, &d.b, self.control_dt()).map_err(|e| bad("controller", format!("c2d: {e:?}")))?;
        let c = DMatrix::<f64>::identity(6, 6);
        let qn = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(process_noise));
        let rn = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(measurement_noise));
        let (l, _p) = steady_state_kalman(&ad, &c, &qn, &rn)
            .map_err(|e| bad("controller", format!("Kalman design failed: {e:?}")))?;
        let f6 =
            |m: &DMatrix<f64>| -> [[f32; 6]; 6] { std::array::from_fn(|r| std::array::from_fn(|k| m[(r, k)] as f32)) };
        Ok(acs_flight::params::LqgParams {
            k: d.gain.map(|row| row.map(|x| x as f32)),
            a: f6(&ad),
            b: std::array::from_fn(|r| std::array::from_fn(|k| bd[(r, k)] as f32)),
            l: f6(&l),
            torque_limit_nm: torque_limit_nm.map(|x| x as f32),
        })
    }
}

/// Julian date of a UTC time "YYYY-MM-DDThh:mm:ss" (seconds may have a fraction).
pub fn parse_epoch(s: &str) -> std::result::Result<f64, String> {
    let err = || format!("{s:?} is not YYYY-MM-DDThh:mm:ss");
    let (date, time) = s.split_once('T').ok_or_else(err)?;
    let d: Vec<&str> = date.split('-').collect();
    let t: Vec<&str> = time.split(':').collect();
    if d.len() != 3 || t.len() != 3 {
        return Err(err());
    }
    let y: i32 = d[0].parse().map_err(|_| err())?;
    let mo: u32 = d[1].parse().map_err(|_| err())?;
    let da: u32 = d[2].parse().map_err(|_| err())?;
    let h: u32 = t[0].parse().map_err(|_| err())?;
    let mi: u32 = t[1].parse().map_err(|_| err())?;
    let se: f64 = t[2].parse().map_err(|_| err())?;
    if !(1..=12).contains(&mo) || !(1..=31).contains(&da) || h > 23 || mi > 59 || !(0.0..61.0).contains(&se) {
        return Err(err());
    }
    Ok(julian_date(y, mo, da, h, mi, se))
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
        let ControllerParams::QuaternionFeedback(c) = &p.controller else { panic!("quaternion feedback") };
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
            ("[[3.1, 0, 0], [0, 3.1, 0], [0, 0, 5.8]]", "[[1, 0, 0], [0, 1, 0], [0, 0, 5.8]]", "triangle"),
            ("[[3.1, 0, 0], [0, 3.1, 0], [0, 0, 5.8]]", "[[3.1, 1, 0], [0, 3.1, 0], [0, 0, 5.8]]", "symmetric"),
            ("h0_nms = 0.623", "h0_nms = -1", "actuators.cmg.h0_nms"),
            ("duration_s = 10.0", "duration_s = 0", "duration_s"),
            ("law = \"sr\"", "law = \"xx\"", "steering.law"),
            ("zeta = 0.47", "zeta = -0.47", "controller.zeta"),
            ("control_rate_hz = 100.0", "control_rate_hz = nan", "timing.control_rate_hz"),
        ];
        for (from, to, key) in cases {
            let e = err_of(&MINIMAL.replace(from, to));
            assert!(e.contains(key), "expected {key} in: {e}");
        }
    }
}
