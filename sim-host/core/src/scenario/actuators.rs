//! Actuators of a scenario: CMG cluster and steering, reaction wheels, magnetorquers,
//! thrusters — their TOML tables, validation, plant models and flight parameters.

use super::{Controller, MomentumSpec, Scenario, bad, finite, positive, yes};
use crate::attitude::Vec3;
use crate::plant::MAX_WHEELS;
use crate::plant::magnetorquers::{MagnetorquerSet, MagnetorquerSpec};
use crate::plant::thrusters::{Failure as ThrusterFailure, ThrusterSet, ThrusterSpec};
use crate::plant::wheel::WheelParams;
use acs_flight::params::{
    ActuatorParams, AlphaSchedule, CmgParams, MAX_THRUSTERS, MagnetorquerParams, SteeringLaw, SteeringParams,
    ThrusterMethod, ThrusterParams,
};
use anyhow::{Result, bail};
use serde::{Deserialize, Serialize};

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
    /// First-order lag of the torque command, s (0: none; `plant::wheel` module doc).
    #[serde(default)]
    pub torque_lag_s: f64,
    /// Pure delay of the torque command, s, rounded to whole dynamics steps (0: none).
    #[serde(default)]
    pub torque_delay_s: f64,
}

/// Longest wheel torque delay line, dynamics steps (`[actuators.wheels] torque_delay_s`).
pub const MAX_WHEEL_DELAY_STEPS: usize = 100_000;

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
    /// Pure delay of the dipole commands, s, rounded to whole control periods (default 0).
    #[serde(default)]
    pub delay_s: f64,
    /// Rods (0 = x, 1 = y, 2 = z) the flight code is told not to use: the ground's mask
    /// after a rod failed (issue 42, docs/fdir.md "Magnetorquer rank loss"). The plant's
    /// rods are unaffected (a rod's own failure is a `[[faults]]` entry).
    #[serde(default)]
    pub masked_rods: Vec<usize>,
}

impl MagnetorquersSpec {
    /// `masked_rods` as the flight code's bit mask (bit i: rod i), checked: each in 0..=2,
    /// no repeat.
    pub fn masked_rods_mask(&self) -> Result<u8> {
        let mut mask = 0u8;
        for &i in &self.masked_rods {
            if i > 2 || mask & (1 << i) != 0 {
                let why = format!("rods are 0 (x), 1 (y), 2 (z), each once (got {:?})", self.masked_rods);
                return Err(bad("actuators.magnetorquers.masked_rods", why));
            }
            mask |= 1 << i;
        }
        Ok(mask)
    }
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
    /// Plant only: per unit, a rotation vector in body axes, deg (direction = axis, norm =
    /// angle, at most [`MAX_GIMBAL_MISALIGNMENT_DEG`]), rotating that unit's gimbal frame
    /// from the nominal pyramid to the true one (`true = R · nominal`). The flight code
    /// keeps the nominal geometry. Default zeros.
    #[serde(default)]
    pub gimbal_misalignment_deg: [[f64; 3]; 4],
    /// Plant only: pure delay of the gimbal-rate commands, s, in [0, 60] s, rounded to
    /// whole control periods (the flight code does not know it). Default 0.
    #[serde(default)]
    pub rate_delay_s: f64,
}

/// Largest accepted gimbal misalignment angle, deg: a misalignment, not another layout.
pub const MAX_GIMBAL_MISALIGNMENT_DEG: f64 = 10.0;

impl CmgSpec {
    /// `gimbal_misalignment_deg`, checked (finite, each angle at most
    /// [`MAX_GIMBAL_MISALIGNMENT_DEG`]), as rotation vectors in rad for the plant.
    pub fn gimbal_misalignment_rad(&self) -> Result<[[f64; 3]; 4]> {
        const KEY: &str = "actuators.cmg.gimbal_misalignment_deg";
        finite(KEY, self.gimbal_misalignment_deg.as_flattened())?;
        for (i, rv) in self.gimbal_misalignment_deg.iter().enumerate() {
            let angle = Vec3::from(*rv).norm();
            if angle > MAX_GIMBAL_MISALIGNMENT_DEG {
                return Err(bad(KEY, format!("CMG {}: {angle} deg is more than {MAX_GIMBAL_MISALIGNMENT_DEG}", i + 1)));
            }
        }
        Ok(self.gimbal_misalignment_deg.map(|rv| rv.map(f64::to_radians)))
    }

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

/// An actuator family, as `[actuators.<name>]` and `modes.<mode>.actuator` name it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    Cmg,
    Wheels,
    Magnetorquers,
    Thrusters,
}

impl Family {
    /// The table's name: `[actuators.<name>]`.
    pub const fn name(self) -> &'static str {
        match self {
            Family::Cmg => "cmg",
            Family::Wheels => "wheels",
            Family::Magnetorquers => "magnetorquers",
            Family::Thrusters => "thrusters",
        }
    }
}

/// Why a `[controller]` cannot choose among `several` families, and what to write
/// instead (`stores`: wheels or CMGs are present, which magnetorquers or thrusters
/// could unload).
fn several_families(several: &[Family], stores: bool) -> String {
    let tables: Vec<String> = several.iter().map(|f| format!("[actuators.{}]", f.name())).collect();
    let has = |f: Family| several.contains(&f);
    let fix = if has(Family::Cmg) && has(Family::Wheels) {
        "remove one of the momentum-exchange families".to_string()
    } else if stores && has(Family::Magnetorquers) && !has(Family::Thrusters) {
        "add a [momentum] table (`gain_per_s`, 1/s) so the magnetorquers unload the stored momentum while the \
         [controller] flies the wheels (CMGs)"
            .to_string()
    } else if stores && has(Family::Thrusters) && !has(Family::Magnetorquers) {
        "add a [momentum] table with `method = \"thrusters\"` (`dump_gain_per_s`, `dump_torque_max_nm`, \
         `dump_start_nms`, `dump_stop_nms`) so the thrusters dump the stored momentum while the [controller] \
         flies the wheels (CMGs)"
            .to_string()
    } else {
        "remove the families the law does not use".to_string()
    };
    format!(
        "a [controller] allocates to one actuator family, and {} are given: {fix}; or replace [controller] by \
         [modes], each `[modes.<mode>]` naming its `actuator = \"{}\"` (docs/scenario.md, \"[modes]\")",
        tables.join(" and "),
        several.iter().map(|f| f.name()).collect::<Vec<_>>().join("\" | \""),
    )
}

impl Scenario {
    pub(super) fn validate_actuators(&self) -> Result<()> {
        let act = &self.actuators;
        if self.controller.as_ref().is_some_and(|c| !matches!(c, Controller::None)) {
            self.control_family()?;
        }
        if let Some(cmg) = &act.cmg {
            self.validate_cmg(cmg)?;
        }
        if let Some(w) = &act.wheels {
            self.validate_wheels(w)?;
        }
        if let Some(m) = &act.magnetorquers {
            self.validate_magnetorquers(m)?;
        }
        if let Some(t) = &act.thrusters {
            self.validate_thrusters(t)?;
        }
        Ok(())
    }

    /// The one actuator family a single `[controller]` allocates its torque to (issue
    /// 38): the family present that does not serve `[momentum]`. Magnetic unloading puts
    /// the magnetorquers beside the wheels (or CMGs), a thruster dump the thrusters: the
    /// standard cubesat set (wheels + magnetorquers + `[momentum]`) flies without
    /// `[modes]`. Any other combination is refused with what to write instead.
    pub fn control_family(&self) -> Result<Family> {
        let act = &self.actuators;
        let stores = act.wheels.is_some() || act.cmg.is_some();
        let unloading = self.momentum.as_ref();
        let rods_unload = stores && act.magnetorquers.is_some() && unloading.is_some_and(|m| !m.dumps());
        let thrusters_dump = stores && act.thrusters.is_some() && unloading.is_some_and(MomentumSpec::dumps);
        let present: Vec<Family> = [
            (Family::Cmg, act.cmg.is_some()),
            (Family::Wheels, act.wheels.is_some()),
            (Family::Magnetorquers, act.magnetorquers.is_some() && !rods_unload),
            (Family::Thrusters, act.thrusters.is_some() && !thrusters_dump),
        ]
        .into_iter()
        .filter_map(|(f, on)| on.then_some(f))
        .collect();
        let family = match present.as_slice() {
            [one] => *one,
            [] => {
                return Err(bad(
                    "actuators",
                    "closed-loop control needs an actuator: add [actuators.wheels], [actuators.magnetorquers], [actuators.cmg] or [actuators.thrusters]",
                ));
            }
            several => return Err(bad("actuators", several_families(several, stores))),
        };
        // A law that commands the rods cannot fly on the wheels beside them.
        if rods_unload && matches!(self.controller, Some(Controller::Bdot { .. })) {
            return Err(bad(
                "controller.type",
                "B-dot commands the magnetorquers, which [momentum] gives to unloading while the [controller] \
                 flies the wheels (CMGs): detumble with B-dot under [modes] (`[modes.detumble] actuator = \"magnetorquers\"`)",
            ));
        }
        Ok(family)
    }

    /// `[actuators.cmg]` (and `[steering]` with it).
    fn validate_cmg(&self, cmg: &CmgSpec) -> Result<()> {
        self.cmg_config(cmg).map(|_| ())
    }

    /// `[actuators.cmg]` and `[steering]`, checked and built in one place: the cluster's
    /// flight parameters and, when given, the steering law (a CMG may run open loop
    /// without `[steering]`; closed-loop control requires it).
    pub fn cmg_config(&self, cmg: &CmgSpec) -> Result<CmgConfig> {
        let cluster = cmg_params(cmg)?;
        if self.closed_loop() && self.steering.is_none() {
            return Err(bad("steering", "a CMG cluster under control needs [steering]"));
        }
        let steering = self.steering.as_ref().map(steering_params).transpose()?;
        // The flight code's own check of the cluster (and law), before any design uses it.
        let law = steering.unwrap_or(acs_flight::params::SteeringParams {
            law: acs_flight::params::SteeringLaw::MoorePenrose,
            singular_threshold: 1e-6,
            null_gain_per_s: 0.0,
            preferred_gimbal_rad: [0.0; 4],
            saturation_check_m: 0.0,
        });
        acs_flight::params::validate_cmg(&cluster, &law)
            .map_err(|e| self.param_refusal(e, "controller", None, "target"))?;
        Ok(CmgConfig { cluster, steering })
    }

    /// `[actuators.wheels]`.
    fn validate_wheels(&self, w: &WheelsSpec) -> Result<()> {
        self.wheel_flight_params(w).map(|_| ())
    }

    /// `[actuators.magnetorquers]`.
    fn validate_magnetorquers(&self, m: &MagnetorquersSpec) -> Result<()> {
        self.magnetorquer_flight_params(m).map(|_| ())
    }

    /// `[actuators.thrusters]`.
    fn validate_thrusters(&self, t: &ThrustersSpec) -> Result<()> {
        self.thruster_flight_params(t).map(|_| ())
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

    /// Plant models of the wheels. An ideal wheel has no size of its own: a scenario that
    /// does not give all three (`validate_wheel_ranges` refuses it; a scenario built or
    /// edited in code may skip validation) is an error naming the key, not a silent paper
    /// 001 wheel.
    pub fn wheel_params(&self) -> Result<Vec<WheelParams>> {
        let Some(w) = &self.actuators.wheels else {
            return Ok(Vec::new());
        };
        let rpm = std::f64::consts::PI / 30.0;
        let sized = |key: &str, v: Option<f64>| {
            v.ok_or_else(|| bad(key, "required for model = \"ideal\" (the wheel's size has no default)"))
        };
        let mut base = match w.model.as_str() {
            "accurate" => WheelParams::paper001(),
            _ => WheelParams::ideal(
                sized("actuators.wheels.max_torque_nm", w.max_torque_nm)?,
                sized("actuators.wheels.max_speed_rpm", w.max_speed_rpm)? * rpm,
                sized("actuators.wheels.inertia_kgm2", w.inertia_kgm2)?,
            ),
        };
        if let Some(t) = w.max_torque_nm {
            base.max_torque_nm = t;
        }
        if let Some(s) = w.max_speed_rpm {
            base.max_speed_rad_s = s * rpm;
        }
        if let Some(i) = w.inertia_kgm2 {
            base.inertia_kgm2 = i;
        }
        base.torque_lag_s = w.torque_lag_s;
        base.torque_delay_s = w.torque_delay_s;
        Ok(self.wheel_axes(w).into_iter().map(|axis| WheelParams { spin_axis: axis, ..base.clone() }).collect())
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
                // Validated finite, 0 … 60 s: the cast cannot overflow.
                let delay_steps = (m.delay_s * self.timing.control_rate_hz).round().max(0.0) as usize;
                MagnetorquerSet { rods, residual_dipole_am2: residual, delay_steps }
            }
            None => MagnetorquerSet { rods: Vec::new(), residual_dipole_am2: residual, delay_steps: 0 },
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
                injected: Vec::new(),
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

    /// Flight parameters of one actuator family ("cmg", "wheels", "magnetorquers",
    /// "thrusters"); `None`: the first present in that order.
    pub(super) fn actuator_params(&self, family: Option<&str>) -> Result<ActuatorParams> {
        let act = &self.actuators;
        let want = |f: &str| family.is_none_or(|x| x == f);
        if let Some(cmg) = act.cmg.as_ref().filter(|_| want("cmg")) {
            return self.cmg_flight_params(cmg);
        }
        if let Some(w) = act.wheels.as_ref().filter(|_| want("wheels")) {
            return self.wheel_flight_params(w);
        }
        if let Some(m) = act.magnetorquers.as_ref().filter(|_| want("magnetorquers")) {
            return self.magnetorquer_flight_params(m);
        }
        if let Some(t) = act.thrusters.as_ref().filter(|_| want("thrusters")) {
            return self.thruster_flight_params(t);
        }
        match family {
            Some(f) => bail!("invalid value for `actuators`: no [actuators.{f}] to control"),
            None => bail!("invalid value for `actuators`: no actuator to control"),
        }
    }

    /// The CMG cluster and its steering law.
    fn cmg_flight_params(&self, cmg: &CmgSpec) -> Result<ActuatorParams> {
        let CmgConfig { cluster, steering } = self.cmg_config(cmg)?;
        let steering = steering.ok_or_else(|| bad("steering", "missing"))?;
        Ok(ActuatorParams::Cmg { cmg: cluster, steering })
    }

    /// The reaction wheels.
    fn wheel_flight_params(&self, w: &WheelsSpec) -> Result<ActuatorParams> {
        validate_wheel_layout(w)?;
        self.validate_wheel_ranges(w)?;
        self.validate_wheel_step()?;
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
        Ok(ActuatorParams::Wheels(acs_flight::params::WheelParams {
            count: plant.len() as u8,
            axes,
            max_torque_nm: p0.max_torque_nm as f32,
            max_speed_rad_s: p0.max_speed_rad_s as f32,
            inertia_kgm2: p0.inertia_kgm2 as f32,
            null_gain_per_s: w.null_gain_per_s as f32,
            bias_speed_rad_s: bias,
            failed_mask,
        }))
    }

    /// The wheels' torque, speed and inertia ranges, the per-wheel lists, the failed
    /// wheels and the null-motion gain.
    fn validate_wheel_ranges(&self, w: &WheelsSpec) -> Result<()> {
        // Upper bounds: beyond any reaction wheel flown (speed: the flight code's own limit).
        let max_rpm = f64::from(acs_flight::validation::MAX_WHEEL_SPEED_RAD_S) * 60.0 / std::f64::consts::TAU;
        // Lower bounds: below a nanonewton-metre wheel, a 1e-6 kg m² rotor or 1 rpm of speed
        // range no wheel exists (and the speed-limit fade's time constant tends to 0).
        for (k, v, min, max) in [
            ("actuators.wheels.max_torque_nm", w.max_torque_nm, 1.0e-9, 1.0e3),
            ("actuators.wheels.max_speed_rpm", w.max_speed_rpm, 1.0, max_rpm),
            ("actuators.wheels.inertia_kgm2", w.inertia_kgm2, 1.0e-6, 1.0e3),
        ] {
            if let Some(v) = v
                && !(v >= min && v <= max)
            {
                return Err(bad(k, format!("{v} is outside the range [{min:e}, {max:.6e}]")));
            }
            // No silent sizing: the only wheel with data of its own is the accurate model's
            // (paper 001's 0.75 N m, 6000 rpm, 0.086 kg m² wheel); an ideal wheel is sized
            // by the user.
            if v.is_none() && w.model != "accurate" {
                return Err(bad(k, "required for model = \"ideal\" (the wheel's size has no default)".to_string()));
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
        self.validate_wheel_lag_delay(w)
    }

    /// `torque_lag_s` in [0, 1e3] s; `torque_delay_s` in [0, 60] s and at most
    /// `MAX_WHEEL_DELAY_STEPS` dynamics steps (the delay line's memory).
    fn validate_wheel_lag_delay(&self, w: &WheelsSpec) -> Result<()> {
        for (k, v, max) in [
            ("actuators.wheels.torque_lag_s", w.torque_lag_s, 1.0e3),
            ("actuators.wheels.torque_delay_s", w.torque_delay_s, 60.0),
        ] {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return Err(bad(k, format!("must be finite and in [0, {max}] s (got {v})")));
            }
        }
        let rate_hz = self.timing.control_rate_hz * f64::from(self.timing.dynamics_substeps.max(1));
        let steps = (w.torque_delay_s * rate_hz).round();
        if steps > MAX_WHEEL_DELAY_STEPS as f64 {
            return Err(bad(
                "actuators.wheels.torque_delay_s",
                format!("is {steps} dynamics steps, more than the delay line's {MAX_WHEEL_DELAY_STEPS}"),
            ));
        }
        Ok(())
    }

    /// The dynamics step against the wheels' RK4 stability limit.
    fn validate_wheel_step(&self) -> Result<()> {
        // RK4 on the plant: a wheel's fastest own dynamics (the ideal model's torque fade at
        // its speed limit, the accurate model's loops) must be resolved by the dynamics step,
        // else the wheel speed and its reaction torque oscillate numerically at the limit and
        // the "truth" attitude no longer follows its own body rate (a 3U cubesat at 0.25 s
        // put 0.0017 deg per step between the two and diverged the flight MEKF).
        let h_s = 1.0 / (self.timing.control_rate_hz * f64::from(self.timing.dynamics_substeps.max(1)));
        for p in self.wheel_params()? {
            p.validate().map_err(|e| bad("actuators.wheels", e))?;
            let h_max = p.max_stable_step_s();
            if h_s.is_finite() && h_s > h_max {
                let need = (1.0 / (self.timing.control_rate_hz * h_max)).ceil();
                return Err(bad(
                    "timing.dynamics_substeps",
                    format!(
                        "the dynamics step {h_s:.4} s is longer than the wheels' RK4 stability limit {h_max:.4} s \
                         (2.5 x their fastest time constant {:.4} s, the speed-limit torque fade or torque_lag_s); use \
                         dynamics_substeps >= {need}, or a smaller actuators.wheels.max_torque_nm / a larger \
                         inertia_kgm2",
                        p.fastest_time_constant_s()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The magnetorquers.
    fn magnetorquer_flight_params(&self, m: &MagnetorquersSpec) -> Result<ActuatorParams> {
        for x in m.max_dipole_am2 {
            positive("actuators.magnetorquers.max_dipole_am2", x)?;
        }
        for x in m.min_dipole_am2.iter().flatten() {
            positive("actuators.magnetorquers.min_dipole_am2", *x)?;
        }
        if let Some([lo, hi]) = m.deadband_am2
            && !(lo <= 0.0 && hi >= 0.0 && lo.is_finite() && hi.is_finite())
        {
            return Err(bad("actuators.magnetorquers.deadband_am2", "must be [lo <= 0, hi >= 0]"));
        }
        if !(m.delay_s.is_finite() && (0.0..=60.0).contains(&m.delay_s)) {
            return Err(bad("actuators.magnetorquers.delay_s", "must be in [0, 60] s"));
        }
        if self.orbit.is_none() && self.environment.lab_field_t.is_none() {
            return Err(bad("actuators.magnetorquers", "need a field: an [orbit] or environment.lab_field_t"));
        }
        let neg = m.min_dipole_am2.unwrap_or(m.max_dipole_am2);
        let [lo, hi] = m.deadband_am2.unwrap_or([0.0, 0.0]);
        let failed_mask = m.masked_rods_mask()?;
        Ok(ActuatorParams::Magnetorquers(MagnetorquerParams {
            failed_mask,
            max_dipole_am2: m.max_dipole_am2.map(|x| x as f32),
            min_dipole_am2: neg.map(|x| x as f32),
            deadband_lo_am2: [lo as f32; 3],
            deadband_hi_am2: [hi as f32; 3],
            min_field_t: 1e-7,
        }))
    }

    /// The thrusters (torque matrix of the set as built).
    fn thruster_flight_params(&self, t: &ThrustersSpec) -> Result<ActuatorParams> {
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
        thruster_layout(t)?;
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
        Ok(ActuatorParams::Thrusters(ThrusterParams {
            count: b.len() as u8,
            torque_nm,
            method: if t.method == "bodson" { ThrusterMethod::Bodson } else { ThrusterMethod::DirectionPreserving },
            pwpf_km: t.pwpf[0] as f32,
            pwpf_tm_s: t.pwpf[1] as f32,
            pwpf_u_on: t.pwpf[2] as f32,
            pwpf_u_off: t.pwpf[3] as f32,
            failed_mask,
        }))
    }
}

/// The thruster layout keys (`layout` and its matrix or geometry).
fn thruster_layout(t: &ThrustersSpec) -> Result<()> {
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
    Ok(())
}

/// A CMG cluster, checked: its flight parameters and, under control, its steering law.
#[derive(Clone, Debug, PartialEq)]
pub struct CmgConfig {
    pub cluster: CmgParams,
    /// `None`: no `[steering]` (allowed only open loop).
    pub steering: Option<SteeringParams>,
}

/// `[actuators.cmg]`: every value checked (errors naming the key), then the flight parameters.
fn cmg_params(cmg: &CmgSpec) -> Result<CmgParams> {
    if cmg.layout != "pyramid4" {
        return Err(bad("actuators.cmg.layout", format!("unknown layout {:?} (known: \"pyramid4\")", cmg.layout)));
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
    cmg.gimbal_misalignment_rad()?;
    if !(cmg.rate_delay_s.is_finite() && (0.0..=60.0).contains(&cmg.rate_delay_s)) {
        return Err(bad("actuators.cmg.rate_delay_s", format!("must be in [0, 60] s (got {})", cmg.rate_delay_s)));
    }
    let lim = cmg.gimbal_limit_deg.map_or(1000.0, |l| l.to_radians());
    Ok(CmgParams {
        skew_rad: cmg.skew_deg.to_radians() as f32,
        h0_nms: cmg.h0() as f32,
        max_gimbal_rate_rad_s: cmg.max_gimbal_rate_deg_s.to_radians() as f32,
        gimbal_min_rad: -lim as f32,
        gimbal_max_rad: lim as f32,
        failed_mask: cmg.failed.iter().fold(0u8, |m, i| m | (1 << (i - 1))),
    })
}

/// `[steering]`: every value checked (errors naming the key), then the flight parameters.
fn steering_params(st: &Steering) -> Result<SteeringParams> {
    let law = steering_law(st)?;
    positive("steering.singular_threshold", st.singular_threshold)?;
    if !(st.null_gain_per_s.is_finite() && st.null_gain_per_s >= 0.0) {
        return Err(bad("steering.null_gain_per_s", "must be >= 0"));
    }
    finite("steering.preferred_gimbal_deg", &st.preferred_gimbal_deg)?;
    Ok(SteeringParams {
        law,
        singular_threshold: st.singular_threshold as f32,
        null_gain_per_s: st.null_gain_per_s as f32,
        preferred_gimbal_rad: st.preferred_gimbal_deg.map(|d| d.to_radians() as f32),
        saturation_check_m: st.saturation_check_m as f32,
    })
}

/// `steering.law` with its `alpha` schedule or `gsr` parameters.
fn steering_law(st: &Steering) -> Result<SteeringLaw> {
    match (st.law.as_str(), &st.alpha) {
        ("mp", None) => Ok(SteeringLaw::MoorePenrose),
        ("mp", Some(_)) => Err(bad("steering.alpha", "Moore-Penrose takes no alpha")),
        ("sr", Some(a)) => {
            let (v, schedule) = match *a {
                Alpha::Quadratic { a0, m0, m_cr } => {
                    (vec![a0, m0, m_cr], AlphaSchedule::Quadratic { a0: a0 as f32, m0: m0 as f32, m_cr: m_cr as f32 })
                }
                Alpha::Inverse { a0, m_cr, a_max } => (
                    vec![a0, m_cr, a_max],
                    AlphaSchedule::Inverse { a0: a0 as f32, m_cr: m_cr as f32, a_max: a_max as f32 },
                ),
                Alpha::Exponential { a0, mu } => {
                    (vec![a0, mu], AlphaSchedule::Exponential { a0: a0 as f32, mu: mu as f32 })
                }
            };
            if v.iter().any(|x| !x.is_finite() || *x < 0.0) {
                return Err(bad("steering.alpha", "parameters must be finite and >= 0"));
            }
            Ok(SteeringLaw::SingularityRobust(schedule))
        }
        ("sr", None) => Err(bad("steering.alpha", "SR steering needs an alpha schedule")),
        ("gsr", _) => {
            let g =
                st.gsr.as_ref().ok_or_else(|| bad("steering.gsr", "GSR needs { lambda0, mu, eps0, omega_rad_s }"))?;
            if [g.lambda0, g.mu, g.eps0].iter().any(|x| !x.is_finite() || *x < 0.0)
                || g.omega_rad_s.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            {
                return Err(bad("steering.gsr", "lambda0, mu, eps0 >= 0 and omega_rad_s > 0"));
            }
            Ok(SteeringLaw::GeneralizedSr {
                lambda0: g.lambda0 as f32,
                mu: g.mu as f32,
                eps0: g.eps0 as f32,
                omega_rad_s: g.omega_rad_s as f32,
            })
        }
        (other, _) => Err(bad("steering.law", format!("unknown law {other:?} (known: \"mp\", \"sr\", \"gsr\")"))),
    }
}

/// The wheel layout (a four-wheel pyramid or explicit axes) and the wheel model.
fn validate_wheel_layout(w: &WheelsSpec) -> Result<()> {
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
    Ok(())
}
