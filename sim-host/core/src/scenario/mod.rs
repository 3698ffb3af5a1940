//! Scenario files (TOML). The format is documented in `docs/scenario.md`; every table
//! rejects unknown keys, and [`Scenario::validate`] rejects impossible values naming
//! the key, before anything runs.

use crate::attitude::{Quat, Vec3, from_xyzw, quat_from_euler, rotate_ref_to_body};
use crate::environment::frames::julian_date;
use crate::environment::model::EnvSnapshot;
use crate::plant::cmg::GimbalServo;
use crate::plant::wheel::WheelState;
use crate::plant::{MAX_GIMBALS, MAX_WHEELS, NOMINAL_ROTORS, Spacecraft, State, cmg::CmgCluster};
use acs_flight::math::EulerSeq;
use acs_flight::params::{FlightParams, GuidanceParams, PARAMS_VERSION, TargetFrame};
use anyhow::{Context, Result, anyhow};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};
use std::path::Path;

mod actuators;
mod controller;
mod environment;
pub mod estimation;
mod faults;
pub use faults::{FaultSpec, MAX_GYRO_BIAS_STEP_RAD_S};
mod fdir;
pub use fdir::{FdirSpec, GyroFdirSpec, TrackerFdirSpec, WheelFdirSpec};
mod guidance;
mod manoeuvre;
pub use guidance::{DirectionSpec, GuidanceSet, GuidanceSpec, PointingKind, PointingSpec};
pub use manoeuvre::{KeepOutSpec, ManoeuvreSpec};
mod limits;
mod margins;
mod modes;
pub use margins::{
    AMPLITUDE_RAD, GRID_POINTS, LoopPoint, MarginOption, MarginRequest, MarginsSpec, OptionRefused, PILOT_LEVELS,
    THREADS, UNREFINED_MAX_RATIO, check as margin_check,
};
mod momentum;
pub use momentum::MomentumSpec;
mod performance;
pub use performance::{Performance, PerformanceSpec};
mod resolved;
mod sensors;
mod timeline;
pub use actuators::{
    Actuators, Alpha, CmgConfig, CmgSpec, Family, GsrSpec, MAX_GIMBAL_MISALIGNMENT_DEG, MagnetorquersSpec, Steering,
    ThrusterFailureSpec, ThrustersSpec, WheelsSpec,
};
pub use controller::{Controller, LqrDesign};
pub use environment::{EnvironmentSpec, OrbitKind, OrbitSpec, RigSpec};
pub use limits::{
    MAX_ANGLE_NOISE_DEG, MAX_INPUT_BYTES, MAX_MAGNITUDE, MAX_SCALE_FACTOR_PPM, NOISE_FRACTION_OF_LIMIT, read_capped,
};
pub use modes::{
    CommandSpec, ModeSpec, ModeTable, ModesSpec, Thresholds, UNUSED_HOLD_ENTER_DEG, UNUSED_HOLD_EXIT_DEG, parse_mode,
    unused_detumble_rates_deg_s,
};
pub use resolved::{GroundCommand, Resolved, TargetConfig, Upload, layout};
pub use sensors::{
    CssSpec, GnssSpec, GyroSpec, MagnetometerSpec, SampleTimingSpec, Sensors, StarTrackerSpec, SunSensorSpec,
};
pub use timeline::{TimelineEntry, TimelineSpec};

/// Most control steps of a run: the sensor frame numbers them with a `u32`.
pub const MAX_STEPS: u64 = u32::MAX as u64;
/// Highest altitude of the World Magnetic Model, km (its validity range).
pub const WMM_MAX_ALTITUDE_KM: f64 = 850.0;
/// Largest ratio of the largest to the smallest principal moment of inertia.
pub const MAX_INERTIA_RATIO: f64 = 1e9;
/// Most RK4 steps per control period (`timing.dynamics_substeps`).
pub const MAX_DYNAMICS_SUBSTEPS: u32 = 1000;
/// Most RK4 steps of a whole run (control steps × substeps): 1e9, about half an hour to a
/// few hours of wall time at the measured 1–10 µs per RK4 step with the environment.
pub const MAX_RK4_STEPS: u64 = 1_000_000_000;

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
    /// The mission's fixed target attitude (or `[guidance]`: exactly one of the two).
    #[serde(default)]
    pub target: Option<AttitudeSpec>,
    /// The mission's pointing by two vectors or as a fixed attitude (instead of `[target]`).
    #[serde(default)]
    pub guidance: Option<GuidanceSpec>,
    /// Planned slews and keep-out cones, for the mission and every mode (absent: changes
    /// of pointing are blended).
    #[serde(default)]
    pub manoeuvre: Option<ManoeuvreSpec>,
    pub actuators: Actuators,
    /// The control law (absent with `[modes]`).
    #[serde(default)]
    pub controller: Option<Controller>,
    /// Mode manager: a law, actuator family and target per mode, and the thresholds of
    /// the transitions (instead of `[controller]`).
    #[serde(default)]
    pub modes: Option<ModesSpec>,
    /// Timed ground commands sent over the link (new target, mode commands).
    #[serde(default)]
    pub commands: Vec<CommandSpec>,
    /// `[[timeline]]`: a pointing timeline uploaded at the start (docs/scenario.md).
    #[serde(default)]
    pub timeline: Option<Vec<TimelineSpec>>,
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
    /// The flight software's attitude determination (absent: the sensor's attitude as
    /// measured).
    #[serde(default)]
    pub estimation: Option<estimation::EstimationSpec>,
    #[serde(default)]
    pub link: LinkSpec,
    /// Momentum management (magnetic unloading) in the flight code.
    #[serde(default)]
    pub momentum: Option<MomentumSpec>,
    /// How the run's pointing is judged: settle bound, pointing-performance windows and
    /// confidence (defaults when absent).
    #[serde(default)]
    pub performance: PerformanceSpec,
    /// Measure the stability margins after the run (`summary.json` `margins`;
    /// docs/margins.md).
    #[serde(default)]
    pub margins: Option<MarginsSpec>,
    /// Faults injected into the plant and the sensors (`[[faults]]`; absent: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub faults: Vec<FaultSpec>,
    /// The flight code's fault detection, isolation and recovery (`[fdir]`; absent: off).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fdir: Option<FdirSpec>,
    /// Deprecated spellings the file used, each with its replacement (filled by
    /// [`Scenario::from_toml`]; the CLI prints them as warnings). Not part of the format.
    #[serde(skip)]
    pub deprecations: Vec<String>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Timing {
    pub control_rate_hz: f64,
    /// RK4 steps per control period (dynamics rate = control rate × this).
    #[serde(default = "one")]
    pub dynamics_substeps: u32,
    /// Record every Nth control step in the time series and the plots.
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
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
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

#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LinkSpec {
    /// Default link: "in-process", "qemu", "tcp:ADDR" or "serial:DEV[@BAUD]"; the CLI
    /// `--link` overrides it.
    #[serde(default)]
    pub kind: Option<String>,
}

/// A fixed target attitude as the flight's pointing (what `[target]` uploads).
pub fn fixed_guidance(target: &AttitudeSpec) -> GuidanceParams {
    let q = target.quaternion();
    GuidanceParams::fixed(
        [q.i as f32, q.j as f32, q.k as f32, q.w as f32],
        match target.frame {
            RefFrame::Inertial => TargetFrame::Inertial,
            RefFrame::Lvlh => TargetFrame::Reference,
        },
    )
}

/// A 3×3 matrix as the flight code's row-major f32 array.
fn f32_rows(m: &Matrix3<f64>) -> [[f32; 3]; 3] {
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)] as f32))
}

fn yes() -> bool {
    true
}

fn bad(key: &str, why: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("invalid value for `{key}`: {why}")
}

fn finite(key: &str, xs: &[f64]) -> Result<()> {
    if xs.iter().all(|x| x.is_finite()) { Ok(()) } else { Err(bad(key, "must be finite")) }
}

fn non_negative(key: &str, x: f64) -> Result<()> {
    if x.is_finite() && x >= 0.0 { Ok(()) } else { Err(bad(key, format!("must be >= 0 (got {x})"))) }
}

fn positive(key: &str, x: f64) -> Result<()> {
    if x.is_finite() && x > 0.0 { Ok(()) } else { Err(bad(key, format!("must be > 0 (got {x})"))) }
}

/// How far from 1 a scenario quaternion's norm may be (docs/scenario.md): tighter than
/// the f32 flight quaternion's own resolution (≈ 6e-8) would be pointless to demand of a
/// hand-written file, looser would hide a typo in a component.
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-6;

impl AttitudeSpec {
    fn validate(&self, key: &str) -> Result<()> {
        match (&self.euler_deg, &self.quaternion_xyzw) {
            (Some(e), None) => finite(&format!("{key}.euler_deg"), e),
            (None, Some(q)) => {
                let k = format!("{key}.quaternion_xyzw");
                finite(&k, q)?;
                let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
                if (n - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
                    return Err(bad(
                        &k,
                        format!("must have unit norm within {QUATERNION_NORM_TOLERANCE:e} (got {n}): normalise it"),
                    ));
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
        let s: Scenario = toml::from_str(text).map_err(|e| limits::parse_error(text, e))?;
        let given: toml::Table = toml::from_str(text).map_err(|e| anyhow!("{e}"))?;
        let kept = toml::Table::try_from(&s).context("writing the parsed scenario back out")?;
        limits::exact_lengths(&given, &kept)?;
        limits::finite_numbers(&toml::Value::Table(kept), "")?;
        s.validate()?;
        let mut s = s;
        s.deprecations = limits::deprecated_spellings(&given)?;
        Ok(s)
    }

    /// Reads (at most [`MAX_INPUT_BYTES`]) and validates a scenario file.
    pub fn load(path: &Path) -> Result<Self> {
        let text = read_capped(path)?;
        Self::from_toml(&text).with_context(|| format!("scenario {}", path.display()))
    }

    pub fn inertia(&self) -> Matrix3<f64> {
        Matrix3::from_fn(|r, c| self.spacecraft.inertia_kgm2[r][c])
    }

    /// `spacecraft.inertia_kgm2`, checked (finite, symmetric, positive definite, principal
    /// moments obeying the triangle inequality): the one place the body inertia is accepted.
    pub fn checked_inertia(&self) -> Result<Matrix3<f64>> {
        let i = self.inertia();
        finite("spacecraft.inertia_kgm2", i.as_slice())?;
        if (i - i.transpose()).abs().max() > 1e-9 * i.abs().max() {
            return Err(bad("spacecraft.inertia_kgm2", "must be symmetric"));
        }
        let e = i.symmetric_eigenvalues();
        if e.min() <= 0.0 {
            return Err(bad("spacecraft.inertia_kgm2", "must be positive definite"));
        }
        if e.max() > MAX_INERTIA_RATIO * e.min() {
            return Err(bad(
                "spacecraft.inertia_kgm2",
                format!(
                    "principal moments {:e} to {:e}: their ratio must be <= {MAX_INERTIA_RATIO:e}",
                    e.min(),
                    e.max()
                ),
            ));
        }
        let (a, b, c) = (e[0], e[1], e[2]);
        if a + b < c * (1.0 - 1e-9) || b + c < a * (1.0 - 1e-9) || a + c < b * (1.0 - 1e-9) {
            return Err(bad("spacecraft.inertia_kgm2", "principal moments violate the triangle inequality"));
        }
        Ok(i)
    }

    pub fn validate(&self) -> Result<()> {
        self.validate_timing()?;
        self.validate_spacecraft()?;
        self.validate_frames_and_orbit()?;
        self.manoeuvre_params()?;
        self.validate_environment()?;
        self.validate_actuators()?;
        if let Some(c) = &self.controller {
            self.validate_controller(c, "controller")?;
        }
        self.validate_sensors()?;
        self.validate_input_limits()?;
        self.validate_momentum()?;
        self.validate_control_source()?;
        self.validate_estimation()?;
        self.validate_estimator_timing()?;
        self.performance()?;
        self.margin_request()?;
        self.faults()?;
        self.validate_fdir()?;
        Ok(())
    }

    /// `[estimation]`: the flight code's validation of the set, refusals naming the key.
    fn validate_estimation(&self) -> Result<()> {
        if let Some(e) = &self.estimation {
            self.estimation_params(e)?;
        }
        Ok(())
    }

    /// `duration_s` and `[timing]` (see [`Clock`]).
    fn validate_timing(&self) -> Result<()> {
        Clock::try_from(self).map(|_| ())
    }

    /// `[spacecraft]`.
    fn validate_spacecraft(&self) -> Result<()> {
        self.checked_inertia()?;
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
        Ok(())
    }

    /// `[initial]`, `[target]` and `[orbit]`.
    fn validate_frames_and_orbit(&self) -> Result<()> {
        self.initial.attitude.validate("initial")?;
        finite("initial.rate_rad_s", &self.initial.rate_rad_s)?;
        let needs_orbit =
            |k: &str| -> Result<()> { if self.orbit.is_none() { Err(bad(k, "needs an [orbit]")) } else { Ok(()) } };
        if self.initial.attitude.frame == RefFrame::Lvlh {
            needs_orbit("initial.frame")?;
        }
        if self.initial.orbit_synchronous {
            needs_orbit("initial.orbit_synchronous")?;
        }
        match (&self.target, &self.guidance) {
            (Some(t), None) => {
                t.validate("target")?;
                if t.frame == RefFrame::Lvlh {
                    needs_orbit("target.frame")?;
                }
            }
            (None, Some(g)) => {
                g.resolve("guidance", self.orbit.is_some())?;
            }
            (Some(_), Some(_)) => return Err(bad("guidance", "give [target] or [guidance], not both")),
            (None, None) => return Err(bad("target", "missing (or give [guidance])")),
        }
        if let Some(o) = &self.orbit {
            if self.rig.is_some() {
                return Err(bad("rig", "a rig sits in a lab: remove [orbit] or [rig]"));
            }
            o.checked()?;
        }
        Ok(())
    }

    /// `[environment]` and `[rig]`.
    fn validate_environment(&self) -> Result<()> {
        let sc = &self.spacecraft;
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
            r.rig()?;
        }
        // The WMM is defined up to 850 km: the field lookup fails above it.
        if let (Some(OrbitKind::Circular { altitude_km, .. }), "wmm") =
            (self.orbit.as_ref().and_then(|o| o.elements().ok()), env.magnetic_field.as_str())
            && altitude_km > WMM_MAX_ALTITUDE_KM
        {
            return Err(bad(
                "orbit.altitude_km",
                format!(
                    "{altitude_km} km is above the WMM's {WMM_MAX_ALTITUDE_KM} km (use magnetic_field = \"dipole\")"
                ),
            ));
        }
        Ok(())
    }

    /// `[open_loop]`, the controller or mode table, and the ground commands.
    fn validate_control_source(&self) -> Result<()> {
        if let Some(ol) = &self.open_loop {
            if self.closed_loop() {
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
        match (&self.controller, &self.modes) {
            (Some(_), Some(_)) => return Err(bad("modes", "give [controller] or [modes], not both")),
            (None, None) => return Err(bad("controller", "missing (or give [modes])")),
            (Some(Controller::None), None) => {}
            (Some(_), None) => {
                // Last line of defence: the flight code's own validation must accept the upload.
                let law = self.controller.as_ref();
                let aim = if self.guidance.is_some() { "guidance" } else { "target" };
                self.flight_params()?.validate().map_err(|e| self.param_refusal(e, "controller", law, aim))?;
            }
            (None, Some(m)) => self.validate_modes(m)?,
        }
        self.validate_commands()?;
        self.timeline_entries()?;
        Ok(())
    }

    /// The plant described by the scenario.
    pub fn spacecraft(&self) -> Result<Spacecraft> {
        let cmg = self.actuators.cmg.as_ref().map(|c| -> Result<CmgCluster> {
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
            cl.rate_delay_s = c.rate_delay_s;
            // Plant only: the flight parameters keep the nominal pyramid.
            Ok(cl.misaligned(&c.gimbal_misalignment_rad()?))
        });
        let cmg = cmg.transpose()?;
        let wheels = self.wheel_params()?;
        // The scenario inertia includes the wheels; the body equation uses J = I - Σ I_w a aᵀ.
        let mut j = self.checked_inertia()?;
        for w in &wheels {
            let a = Vec3::from(w.spin_axis);
            j -= a * a.transpose() * w.inertia_kgm2;
        }
        let mut sc = Spacecraft::new(j, cmg)
            .ok_or_else(|| bad("spacecraft.inertia_kgm2", "singular once the wheels' axial inertia is removed"))?;
        sc.wheels = wheels;
        sc.external_torque_nm = self.spacecraft.external_torque_nm.into();
        sc.env = self.environment()?;
        sc.rig = self.rig.as_ref().map(RigSpec::rig).transpose()?;
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
        State { q, w, gimbal_rad: g, gimbal_rate_rad_s: [0.0; MAX_GIMBALS], wheels, cmg_rotor_scale: NOMINAL_ROTORS }
    }

    /// The parameter set uploaded to the flight code (single `[controller]`).
    pub fn flight_params(&self) -> Result<FlightParams> {
        let c = self.controller.as_ref().ok_or_else(|| bad("controller", "missing (or use [modes])"))?;
        // The family the law flies on: the one not serving [momentum] (`control_family`).
        let family = match c {
            Controller::None => None,
            _ => Some(self.control_family()?.name()),
        };
        let mut p = self.params_for(c, family, self.mission_guidance()?)?;
        p.momentum = self.momentum_params(None, &p.actuator);
        Ok(p)
    }

    /// The mission's pointing as the flight code receives it: `[target]` as a fixed
    /// attitude in its frame, or `[guidance]`.
    pub fn mission_guidance(&self) -> Result<GuidanceParams> {
        match (&self.target, &self.guidance) {
            (_, Some(g)) => Ok(g.resolve("guidance", self.orbit.is_some())?.params),
            (Some(t), None) => Ok(fixed_guidance(t)),
            (None, None) => Err(bad("target", "missing (or give [guidance])")),
        }
    }

    /// The mission's pointing, checked (`None` with `[target]`).
    pub fn mission_set(&self) -> Result<Option<GuidanceSet>> {
        self.guidance.as_ref().map(|g| g.resolve("guidance", self.orbit.is_some())).transpose()
    }

    /// A parameter set for one law, on one actuator family (`None`: the only one
    /// present), pointing as `guidance` says.
    pub fn params_for(&self, c: &Controller, family: Option<&str>, guidance: GuidanceParams) -> Result<FlightParams> {
        let inertia = self.inertia();
        let f = f32_rows;
        let controller = self.controller_params(c, "controller")?;
        let actuator = self.actuator_params(family)?;
        Ok(FlightParams {
            version: PARAMS_VERSION,
            control_rate_hz: self.timing.control_rate_hz as f32,
            inertia_kgm2: f(&inertia),
            controller,
            fdir: self.fdir_params(&actuator)?,
            actuator,
            guidance,
            manoeuvre: self.manoeuvre_params()?,
            hold_after_missed_frames: 10,
            momentum: acs_flight::params::MomentumParams::OFF,
        })
    }

    /// `[manoeuvre]` as flight parameters (off when absent); keep-out cones need an orbit
    /// (the Sun and the Earth are placed from the on-board navigation).
    pub fn manoeuvre_params(&self) -> Result<acs_flight::params::ManoeuvreParams> {
        let Some(m) = &self.manoeuvre else { return Ok(acs_flight::params::ManoeuvreParams::OFF) };
        if !m.keepout.is_empty() && self.orbit.is_none() {
            return Err(bad("manoeuvre.keepout", "keep-out cones need an [orbit]"));
        }
        m.params("manoeuvre")
    }

    /// Whether the flight code runs (a controller other than "none", or a mode table).
    pub fn closed_loop(&self) -> bool {
        self.modes.is_some() || self.controller.as_ref().is_some_and(|c| !matches!(c, Controller::None))
    }

    pub fn control_dt(&self) -> f64 {
        Clock::dt_of(self)
    }

    pub fn steps(&self) -> u64 {
        Clock::steps_of(self)
    }
}

/// The run's clock, parsed once from `duration_s` and `[timing]` (every value checked,
/// errors naming the key).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clock {
    /// Control period, s.
    pub dt: f64,
    /// Control steps after t = 0 (the run samples steps 0..=steps).
    pub steps: u64,
    /// RK4 steps per control period.
    pub substeps: u32,
    /// Every `output_every`-th step (and the last) is recorded.
    pub output_every: u64,
}

impl Clock {
    fn dt_of(sc: &Scenario) -> f64 {
        1.0 / sc.timing.control_rate_hz
    }

    fn steps_of(sc: &Scenario) -> u64 {
        (sc.duration_s * sc.timing.control_rate_hz).round() as u64
    }

    /// Length of one RK4 step, s.
    pub fn h(&self) -> f64 {
        self.dt / self.substeps as f64
    }
}

impl TryFrom<&Scenario> for Clock {
    type Error = anyhow::Error;

    fn try_from(sc: &Scenario) -> Result<Self> {
        let t = &sc.timing;
        positive("duration_s", sc.duration_s)?;
        positive("timing.control_rate_hz", t.control_rate_hz)?;
        if t.control_rate_hz > 10_000.0 {
            return Err(bad("timing.control_rate_hz", "must be <= 10000"));
        }
        if !(1..=MAX_DYNAMICS_SUBSTEPS).contains(&t.dynamics_substeps) {
            return Err(bad(
                "timing.dynamics_substeps",
                format!("{} must be in 1..={MAX_DYNAMICS_SUBSTEPS}", t.dynamics_substeps),
            ));
        }
        if t.output_every == 0 {
            return Err(bad("timing.output_every", "must be >= 1"));
        }
        let steps = sc.duration_s * t.control_rate_hz;
        if steps.round() > MAX_STEPS as f64 {
            return Err(bad(
                "duration_s",
                format!(
                    "{} s at timing.control_rate_hz = {} is {steps:.3e} control steps; at most {MAX_STEPS} \
                     (the step counter of the sensor frame is 32-bit)",
                    sc.duration_s, t.control_rate_hz
                ),
            ));
        }
        if steps.round() < 1.0 {
            return Err(bad(
                "duration_s",
                format!(
                    "{} s is less than one control period (1 / timing.control_rate_hz = {} s)",
                    sc.duration_s,
                    1.0 / t.control_rate_hz
                ),
            ));
        }
        let rk4 = steps.round() * f64::from(t.dynamics_substeps);
        if rk4 > MAX_RK4_STEPS as f64 {
            return Err(bad(
                "duration_s",
                format!(
                    "duration_s × timing.control_rate_hz × timing.dynamics_substeps = {rk4:.3e} RK4 steps; \
                     at most {:.0e} per run",
                    MAX_RK4_STEPS as f64
                ),
            ));
        }
        Ok(Self {
            dt: Self::dt_of(sc),
            steps: Self::steps_of(sc),
            substeps: t.dynamics_substeps,
            output_every: t.output_every as u64,
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
    use acs_flight::params::ControllerParams;

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

    #[test]
    fn the_clock_is_parsed_once_from_duration_and_timing() {
        let text = MINIMAL
            .replace("control_rate_hz = 100.0", "control_rate_hz = 40.0\ndynamics_substeps = 4\noutput_every = 3");
        let c = Clock::try_from(&Scenario::from_toml(&text).unwrap()).unwrap();
        // 10 s at 40 Hz: 400 steps of 25 ms, RK4 every 6.25 ms.
        assert_eq!((c.steps, c.substeps, c.output_every), (400, 4, 3));
        assert!((c.dt - 0.025).abs() < 1e-15 && (c.h() - 0.00625).abs() < 1e-15);
        let s = Scenario::from_toml(&text).unwrap();
        assert_eq!((s.steps(), s.control_dt()), (c.steps, c.dt));
    }

    #[test]
    fn a_cmg_is_checked_and_built_once_steering_optional_open_loop() {
        let s = Scenario::from_toml(MINIMAL).unwrap();
        let c = s.cmg_config(s.actuators.cmg.as_ref().unwrap()).unwrap();
        assert!(c.steering.is_some());
        assert!((c.cluster.h0_nms - 0.623).abs() < 1e-6);
        let open = MINIMAL
            .replace("type = \"quaternion_feedback\"\nzeta = 0.47\nwn_rad_s = 0.7", "type = \"none\"")
            .replace("[steering]\nlaw = \"sr\"\nalpha = { schedule = \"exponential\", a0 = 0.01, mu = 10.0 }\n", "");
        let s = Scenario::from_toml(&open).unwrap();
        assert!(s.steering.is_none());
        assert_eq!(s.cmg_config(s.actuators.cmg.as_ref().unwrap()).unwrap().steering, None);
        let e =
            err_of(&MINIMAL.replace(
                "[steering]\nlaw = \"sr\"\nalpha = { schedule = \"exponential\", a0 = 0.01, mu = 10.0 }\n",
                "",
            ));
        assert!(e.contains("`steering`"), "{e}");
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
            ("duration_s = 10.0", "duration_s = 1e12", "duration_s"),
            ("duration_s = 10.0", "duration_s = inf", "duration_s"),
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
