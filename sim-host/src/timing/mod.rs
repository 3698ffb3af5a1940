//! Worst-case timing of one flight step on the firmware (QEMU lockstep: the step cost
//! counter gives instructions, see docs/firmware.md and docs/timing.md).
//!
//! An [`Input`] is what one measurement feeds the flight code: the scenario's parameters
//! (or mode table) with an optional extra failure mask, an optional ground mode command,
//! a prefix of up to [`MAX_PREFIX`] sensor frames (the flight code has state: integrators,
//! PWPF, mode manager, estimator, navigation fix, the MEKF and its state history) and the
//! measured frame, each with its per-sensor sample times and gyro increment (protocol 13). Every evaluation
//! re-uploads the parameters (or mode table) and the estimation parameters first, which
//! gives the flight code fresh state, so an input's cost does not depend on what was
//! evaluated before it (checked by the replay of the corpus).
//!
//! - [`search`]: seeded (μ+λ) evolutionary search for the costliest input;
//! - [`corpus`]: the committed worst inputs, their replay and the budget file;
//! - [`text`]: what `sim-host timing search|replay` print.

pub mod corpus;
pub mod search;
pub mod text;

/// What other tools read of the timing results (the report's cost table).
pub use corpus::{StepCost, step_cost};

use acs_flight::estimation::history::HISTORY_DEPTH;
#[allow(unused_imports)] // doc links
use acs_flight::link::estimate_flags;
use acs_flight::link::{ALL_UNITS, FswMsg, HostMsg, SampleTimes, SensorFrame};
use acs_flight::params::{ActuatorParams, EstimationParams, FlightParams};
use acs_flight::params::{Mode, ModeRequest};
use acs_flight::types::{MAX_CSS_HEADS, MAX_WHEELS};
use anyhow::{Context, Result, anyhow, bail};
use serde::{Deserialize, Serialize};
use sim_core::link::{FlightLink, LinkInfo, ModeTable};
use sim_core::scenario::{Resolved, Scenario, Upload};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Longest prefix of frames before the measured one: the MEKF's state history
/// ([`HISTORY_DEPTH`] nodes) filled with one propagation node per frame, so a late sample
/// can replay it all even without sample nodes or clock gaps (which fill it faster); it also
/// reaches the field model's first bracket (24 steps at 2 Hz). A bound on the cost of one
/// evaluation: 33 frames take ~0.3 s of the emulated UART.
pub const MAX_PREFIX: usize = HISTORY_DEPTH;

/// The f32 fields of a sensor frame, in wire order: (name, length). The integer fields
/// (`seq`, `time_us`, `sampled_at`, `gyro_interval_us`, `valid`, `gnss_j2000_days`) are
/// stored beside them ([`FrameJson`]). (Protocol 11 replaced `q_ref_xyzw`/`ref_rate_rad_s`
/// by the GNSS and CSS fields, protocol 13 added `gyro_angle_rad`: a corpus entry recorded
/// before lacks them — they read as zeros — and its old fields are ignored.)
pub const FRAME_FIELDS: [(&str, usize); 11] = [
    ("q_ib_xyzw", 4),
    ("rate_rad_s", 3),
    ("gyro_angle_rad", 3),
    ("gimbal_angle_rad", 4),
    ("wheel_speed_rad_s", MAX_WHEELS),
    ("mag_field_t", 3),
    ("sun_dir", 3),
    ("css_output", MAX_CSS_HEADS),
    ("gnss_pos_m", 3),
    ("gnss_vel_m_s", 3),
    ("gnss_j2000_s", 1),
];

/// Number of f32 genes of a frame.
pub const N_FLOATS: usize = 4 + 3 + 3 + 4 + MAX_WHEELS + 3 + 3 + MAX_CSS_HEADS + 3 + 3 + 1;

/// The f32 fields of `f` in [`FRAME_FIELDS`] order.
pub fn floats(f: &SensorFrame) -> [f32; N_FLOATS] {
    let mut v = [0.0; N_FLOATS];
    let src = f
        .q_ib_xyzw
        .iter()
        .chain(&f.rate_rad_s)
        .chain(&f.gyro_angle_rad)
        .chain(&f.gimbal_angle_rad)
        .chain(&f.wheel_speed_rad_s)
        .chain(&f.mag_field_t)
        .chain(&f.sun_dir)
        .chain(&f.css_output)
        .chain(&f.gnss_pos_m)
        .chain(&f.gnss_vel_m_s)
        .chain(core::iter::once(&f.gnss_j2000_s));
    for (d, s) in v.iter_mut().zip(src) {
        *d = *s;
    }
    v
}

/// Mutable references to the f32 fields of `f` in [`FRAME_FIELDS`] order.
pub fn floats_mut(f: &mut SensorFrame) -> Vec<&mut f32> {
    f.q_ib_xyzw
        .iter_mut()
        .chain(&mut f.rate_rad_s)
        .chain(&mut f.gyro_angle_rad)
        .chain(&mut f.gimbal_angle_rad)
        .chain(&mut f.wheel_speed_rad_s)
        .chain(&mut f.mag_field_t)
        .chain(&mut f.sun_dir)
        .chain(&mut f.css_output)
        .chain(&mut f.gnss_pos_m)
        .chain(&mut f.gnss_vel_m_s)
        .chain(core::iter::once(&mut f.gnss_j2000_s))
        .collect()
}

/// A float in JSON: a number, or "NaN" / "inf" / "-inf" / "bits:0x…" (other NaNs): JSON
/// has no non-finite numbers.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(untagged)]
pub enum JsonF32 {
    Num(f32),
    Text(String),
}

impl JsonF32 {
    fn of(x: f32) -> Self {
        if x.is_finite() {
            JsonF32::Num(x)
        } else {
            JsonF32::Text(if x.to_bits() == f32::NAN.to_bits() {
                "NaN".into()
            } else if x.is_nan() {
                // Sign and payload kept: the flight code may branch on the sign bit.
                format!("bits:{:#010x}", x.to_bits())
            } else if x > 0.0 {
                "inf".into()
            } else {
                "-inf".into()
            })
        }
    }
    fn value(&self) -> Result<f32> {
        match self {
            JsonF32::Num(x) => Ok(*x),
            JsonF32::Text(s) => match s.as_str() {
                "NaN" => Ok(f32::NAN),
                "inf" => Ok(f32::INFINITY),
                "-inf" => Ok(f32::NEG_INFINITY),
                _ => match s.strip_prefix("bits:0x") {
                    Some(h) => {
                        Ok(f32::from_bits(u32::from_str_radix(h, 16).with_context(|| format!("bad float {s:?}"))?))
                    }
                    None => bail!("bad float {s:?}"),
                },
            },
        }
    }
}

/// A sensor frame as stored in the corpus (readable, non-finite values as strings).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FrameJson {
    pub seq: u32,
    pub time_us: u64,
    pub valid: u16,
    /// Whole days since J2000.0 of the GNSS fix (0 in entries recorded before protocol 11).
    #[serde(default)]
    pub gnss_j2000_days: i32,
    /// Each sensor's sample time, µs (protocol 13; an entry recorded before has none: every
    /// sample at `time_us`, as `SensorFrame::empty` gives).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sampled_at: Option<SampleTimes>,
    /// The gyro increment's interval, µs (0 = none; 0 in entries recorded before protocol 13).
    #[serde(default)]
    pub gyro_interval_us: u32,
    #[serde(flatten)]
    pub fields: BTreeMap<String, Vec<JsonF32>>,
}

impl From<&SensorFrame> for FrameJson {
    fn from(f: &SensorFrame) -> Self {
        let v = floats(f);
        let mut fields = BTreeMap::new();
        let mut i = 0;
        for (name, n) in FRAME_FIELDS {
            fields.insert(name.to_string(), v[i..i + n].iter().map(|x| JsonF32::of(*x)).collect());
            i += n;
        }
        Self {
            seq: f.seq,
            time_us: f.time_us,
            valid: f.valid,
            gnss_j2000_days: f.gnss_j2000_days,
            sampled_at: Some(f.sampled_at),
            gyro_interval_us: f.gyro_interval_us,
            fields,
        }
    }
}

impl FrameJson {
    pub fn frame(&self) -> Result<SensorFrame> {
        let mut f = SensorFrame::empty(self.seq, self.time_us);
        f.valid = self.valid;
        f.gnss_j2000_days = self.gnss_j2000_days;
        if let Some(t) = self.sampled_at {
            f.sampled_at = t;
        }
        f.gyro_interval_us = self.gyro_interval_us;
        let mut v = Vec::with_capacity(N_FLOATS);
        for (name, n) in FRAME_FIELDS {
            let Some(xs) = self.fields.get(name) else {
                // Recorded before the field existed: zeros (what `SensorFrame::empty` holds).
                v.extend(std::iter::repeat_n(0.0, n));
                continue;
            };
            if xs.len() != n {
                bail!("frame field {name}: {} values, expected {n}", xs.len());
            }
            for x in xs {
                v.push(x.value()?);
            }
        }
        for (d, s) in floats_mut(&mut f).into_iter().zip(v) {
            *d = s;
        }
        Ok(f)
    }
}

/// One measured input (the genome of the search).
#[derive(Clone, Debug, PartialEq)]
pub struct Input {
    /// Ground mode command sent after the upload (mode tables only); `lock` suspends the
    /// automatic transitions.
    pub mode: Option<(Mode, bool)>,
    /// Extra actuators the flight code is told have failed (ORed into the scenario's).
    pub failed_mask: u16,
    /// Frames stepped before the measured one.
    pub prefix: Vec<SensorFrame>,
    /// The measured frame.
    pub frame: SensorFrame,
}

/// [`Input`] as stored.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct InputJson {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mode: Option<String>,
    #[serde(default)]
    pub lock_mode: bool,
    #[serde(default)]
    pub failed_mask: u16,
    #[serde(default)]
    pub prefix: Vec<FrameJson>,
    pub frame: FrameJson,
}

impl From<&Input> for InputJson {
    fn from(i: &Input) -> Self {
        Self {
            mode: i.mode.map(|(m, _)| m.name().to_string()),
            lock_mode: i.mode.is_some_and(|(_, l)| l),
            failed_mask: i.failed_mask,
            prefix: i.prefix.iter().map(FrameJson::from).collect(),
            frame: FrameJson::from(&i.frame),
        }
    }
}

impl InputJson {
    pub fn input(&self) -> Result<Input> {
        let mode = match &self.mode {
            Some(name) => Some((
                Mode::ALL.into_iter().find(|m| m.name() == name).ok_or_else(|| anyhow!("unknown mode {name:?}"))?,
                self.lock_mode,
            )),
            None => None,
        };
        Ok(Input {
            mode,
            failed_mask: self.failed_mask,
            prefix: self.prefix.iter().map(FrameJson::frame).collect::<Result<_>>()?,
            frame: self.frame.frame()?,
        })
    }
}

/// The actuator family of a parameter set, for the failure masks.
fn actuator_count(a: &ActuatorParams) -> (usize, &'static str) {
    match a {
        ActuatorParams::Cmg { .. } => (4, "cmg"),
        ActuatorParams::Wheels(w) => (w.count as usize, "wheels"),
        ActuatorParams::Magnetorquers(_) => (0, "magnetorquers"),
        ActuatorParams::Thrusters(t) => (t.count as usize, "thrusters"),
    }
}

/// `p` with `extra` ORed into its failure mask (bits beyond the family's count dropped).
fn with_failures(p: &FlightParams, extra: u16) -> FlightParams {
    let mut p = *p;
    match &mut p.actuator {
        ActuatorParams::Cmg { cmg, .. } => cmg.failed_mask |= (extra & 0xf) as u8,
        ActuatorParams::Wheels(w) => w.failed_mask |= (extra & ((1u16 << w.count.min(8)) - 1)) as u8,
        ActuatorParams::Magnetorquers(_) => {}
        ActuatorParams::Thrusters(t) => t.failed_mask |= extra & ((1u32 << t.count.min(16)) - 1) as u16,
    }
    p
}

/// What the search needs to know about a scenario.
#[derive(Clone, Debug)]
pub struct Target {
    /// The scenario's name (corpus file and budget key).
    pub name: String,
    /// Path of the scenario file as given.
    pub path: PathBuf,
    pub upload: Upload,
    /// The scenario's attitude-determination parameters (`[estimation]`); `None`: the
    /// flight code's default ([`EstimationParams::SENSOR`], the attitude sensor as
    /// measured), which every evaluation uploads as well (it also clears the navigation fix).
    pub estimation: Option<EstimationParams>,
    /// The sensor frame of the scenario's initial state (the nominal input).
    pub nominal: SensorFrame,
    /// Control period.
    pub dt_s: f64,
    /// The modes of the mode table (empty without one).
    pub modes: Vec<Mode>,
    /// Actuators that may be failed, and their family.
    pub n_actuators: usize,
    pub family: &'static str,
    /// Directions worth aligning demands with: thruster columns and the normals of the
    /// facets of their attainable set (cross products of column pairs), unit, body axes.
    pub directions: Vec<[f32; 3]>,
}

impl Target {
    pub fn load(path: &Path) -> Result<Self> {
        let sc = Scenario::load(path)?;
        Self::new(&sc, path)
    }

    pub fn new(sc: &Scenario, path: &Path) -> Result<Self> {
        let r = Resolved::try_from(sc)?;
        let upload = r.upload.clone().ok_or_else(|| anyhow!("{}: open loop, the flight code does not run", sc.name))?;
        let mut sensors = r.sensors;
        let nominal = sensors.sample(0, 0.0, &r.initial, &r.craft, r.snap0.as_ref(), &[0.0; 3]);
        let (modes, first) = match &upload {
            Upload::Modes(t) => (t.slots.iter().map(|(m, _)| *m).collect(), t.slots.first().map(|(_, p)| *p)),
            Upload::Params(p) => (Vec::new(), Some(**p)),
        };
        let first = first.context("empty mode table")?;
        let (n_actuators, family) = actuator_count(&first.actuator);
        let mut directions = Vec::new();
        if let Some(set) = &r.thrusters {
            let cols = set.torque_matrix();
            let unit = |v: [f64; 3]| {
                let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                (n > 1e-12).then(|| [(v[0] / n) as f32, (v[1] / n) as f32, (v[2] / n) as f32])
            };
            directions.extend(cols.iter().filter_map(|c| unit(*c)));
            for (i, a) in cols.iter().enumerate() {
                for b in &cols[i + 1..] {
                    let c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
                    directions.extend(unit(c));
                }
            }
        }
        if directions.is_empty() {
            directions = vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        }
        Ok(Self {
            name: sc.name.clone(),
            path: path.to_path_buf(),
            upload,
            estimation: r.estimation,
            nominal,
            dt_s: sc.control_dt(),
            modes,
            n_actuators,
            family,
            directions,
        })
    }

    /// The most wheels a parameter set of the scenario flies (any slot of a mode table).
    pub fn wheel_count(&self) -> usize {
        let wheels = |p: &FlightParams| match &p.actuator {
            ActuatorParams::Wheels(w) => w.count as usize,
            _ => 0,
        };
        match &self.upload {
            Upload::Params(p) => wheels(p),
            Upload::Modes(t) => t.slots.iter().map(|(_, p)| wheels(p)).max().unwrap_or(0),
        }
    }

    /// The FDIR monitors the evaluations upload (flight and estimation parameters).
    pub fn monitors(&self) -> Monitors {
        let wheels = match &self.upload {
            Upload::Params(p) => p.fdir.wheel.is_some(),
            Upload::Modes(t) => t.slots.iter().any(|(_, p)| p.fdir.wheel.is_some()),
        };
        let e = self.estimation.as_ref();
        let gyro = e.and_then(|e| e.gyro_fdir);
        Monitors {
            wheels,
            tracker: e.is_some_and(|e| e.tracker_fdir.is_some()),
            gyro: gyro.is_some(),
            bias_step: gyro.is_some_and(|g| g.bias_step.is_some()),
            magnetometer: e.is_some_and(|e| e.magnetometer_fdir.is_some()),
            gnss: e.is_some_and(|e| e.gnss_fdir.is_some()),
        }
    }

    /// The nominal input: the initial state's frame, no prefix, the scenario's own
    /// parameters and initial mode.
    pub fn nominal_input(&self) -> Input {
        Input { mode: None, failed_mask: 0, prefix: Vec::new(), frame: self.nominal }
    }
}

/// The cost of one evaluated input.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cost {
    /// Instructions of the costliest step of the sequence (prefix and measured frame).
    pub instructions: u64,
    /// Index of that step in the sequence (prefix.len() = the measured frame).
    pub step: usize,
    /// Flight mode that step ran in (telemetry code, 0 = no mode table).
    pub mode: u8,
    /// Status bits of that step.
    pub status: u16,
    /// What the estimation stage did in that step: [`estimate_flags`] bits (MEKF running,
    /// navigation, Sun seen, ...) and its update counters since the upload.
    pub estimate_flags: u16,
    pub mekf_accepted: u32,
    pub mekf_rejected: u32,
    pub mekf_resets: u16,
    /// Most history nodes one late sample re-ran since the upload (`FusionCounters`).
    pub replayed_nodes: u16,
    /// FDIR after the sequence's last step (telemetry `FdirTelemetry`): wheels and sensors
    /// declared failed, gyro bias steps declared.
    pub fdir: FdirSeen,
    /// The costliest step in which FDIR declared something (its `events` rose over the
    /// step before): (step index, instructions). `None`: nothing declared in the sequence.
    pub declaration: Option<(usize, u64)>,
}

/// What FDIR had declared after a step ([`acs_flight::link::FdirTelemetry`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FdirSeen {
    /// Bit i: wheel i declared failed.
    pub failed_wheels: u8,
    /// `FAILED_STAR_TRACKER`, `FAILED_GYRO_X` << axis.
    pub failed_sensors: u8,
    /// The tracker's failure was the frozen-output test.
    pub tracker_frozen: bool,
    /// Gyro bias steps declared.
    pub bias_steps: u16,
}

impl FdirSeen {
    fn of(t: &acs_flight::link::FdirTelemetry) -> Self {
        Self {
            failed_wheels: t.failed_wheels,
            failed_sensors: t.failed_sensors,
            tracker_frozen: t.tracker_frozen,
            bias_steps: t.gyro_bias_steps,
        }
    }

    /// "tracker(flip) gyro-x wheel-0 bias-step×1", or "" when nothing is declared.
    pub fn names(&self) -> String {
        use acs_flight::link::{FAILED_GYRO_X, FAILED_STAR_TRACKER};
        let mut v = Vec::new();
        if self.failed_sensors & FAILED_STAR_TRACKER != 0 {
            v.push(format!("tracker({})", if self.tracker_frozen { "frozen" } else { "contradicted" }));
        }
        for (a, name) in ["x", "y", "z"].iter().enumerate() {
            if self.failed_sensors & (FAILED_GYRO_X << a) != 0 {
                v.push(format!("gyro-{name}"));
            }
        }
        for i in 0..8 {
            if self.failed_wheels & (1 << i) != 0 {
                v.push(format!("wheel-{i}"));
            }
        }
        if self.bias_steps > 0 {
            v.push(format!("bias-step×{}", self.bias_steps));
        }
        v.join(" ")
    }
}

/// The FDIR monitors a scenario turns on (what every evaluation uploads).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Monitors {
    /// `[fdir.wheels]`: the wheel monitor in the flight parameters (any slot of a table).
    pub wheels: bool,
    /// `[fdir.star_tracker]`: `tracker_fdir` in the estimation parameters.
    pub tracker: bool,
    /// `[fdir.gyro]`: the stuck-axis test, and its bias-step test.
    pub gyro: bool,
    pub bias_step: bool,
    /// `[fdir.magnetometer]`: `magnetometer_fdir` in the estimation parameters.
    pub magnetometer: bool,
    /// `[fdir.gnss]`: `gnss_fdir` in the estimation parameters.
    pub gnss: bool,
}

impl Monitors {
    pub fn any(&self) -> bool {
        self.wheels || self.tracker || self.gyro || self.magnetometer || self.gnss
    }
}

/// Evaluates inputs of one scenario on a link that reports instructions (QEMU lockstep).
pub struct Evaluator<'a> {
    pub target: Target,
    link: &'a mut dyn FlightLink,
    pub info: LinkInfo,
    ipt: f64,
    /// Inputs evaluated so far (rejected ones included).
    pub evaluations: u64,
}

impl<'a> Evaluator<'a> {
    pub fn new(target: Target, link: &'a mut dyn FlightLink) -> Result<Self> {
        let info = link.hello().context("hello")?;
        let ipt = info.instructions_per_tick.ok_or_else(|| {
            anyhow!("link {} does not count instructions (use the qemu link: -icount lockstep)", link.name())
        })?;
        Ok(Self { target, link, info, ipt, evaluations: 0 })
    }

    fn upload(&mut self, failed_mask: u16) -> Result<bool> {
        let ok = match &self.target.upload {
            Upload::Params(p) => {
                let p = with_failures(p, failed_mask);
                matches!(self.link.request(&HostMsg::UploadParams(p))?, FswMsg::ParamsAccepted { .. })
            }
            Upload::Modes(t) => {
                let t = ModeTable {
                    slots: t.slots.iter().map(|(m, p)| (*m, with_failures(p, failed_mask))).collect(),
                    manager: t.manager,
                };
                // An armed table refuses slots of another control rate (the flight's rule:
                // one table, one rate), and the link may hold the previous scenario's table:
                // a single set first clears it, so each scenario starts from its own table.
                let mut ok = match t.slots.first() {
                    Some((_, p)) => {
                        matches!(self.link.request(&HostMsg::UploadParams(*p))?, FswMsg::ParamsAccepted { .. })
                    }
                    None => false,
                };
                for (mode, params) in &t.slots {
                    let r = self.link.request(&HostMsg::UploadModeParams { mode: *mode, params: *params })?;
                    ok &= matches!(r, FswMsg::ParamsAccepted { .. });
                }
                ok && matches!(self.link.request(&HostMsg::ArmModes(t.manager))?, FswMsg::ModesArmed { .. })
            }
        };
        // The wheel monitor keeps its declarations across parameter uploads (a failed wheel
        // stays failed until the ground clears it): cleared, so that one input's
        // declarations do not drop wheels in the next.
        if self.target.monitors().wheels
            && !matches!(self.link.request(&HostMsg::ClearWheelFault { wheel: ALL_UNITS })?, FswMsg::Ack)
        {
            bail!("{}: the flight code refuses to clear the wheel faults", self.target.name);
        }
        // The estimation stage keeps its state (navigation fix, MEKF) across parameter
        // uploads: a fresh one every evaluation, the scenario's or the default.
        let est = self.target.estimation.unwrap_or(EstimationParams::SENSOR);
        if !matches!(self.link.request(&HostMsg::ConfigureEstimation(est))?, FswMsg::ParamsAccepted { .. }) {
            bail!("{}: the flight code rejects the scenario's estimation parameters", self.target.name);
        }
        Ok(ok)
    }

    /// Fresh flight state (parameter upload), the mode command, the prefix, the frame.
    /// `None`: the flight code rejected the failure mask or the mode command (not a
    /// flight input: the ground would be told so).
    pub fn evaluate(&mut self, input: &Input) -> Result<Option<Cost>> {
        self.evaluations += 1;
        if !self.upload(input.failed_mask)? {
            // Restore an accepted configuration for the next input.
            if !self.upload(0)? {
                bail!("{}: the flight code rejects the scenario's own parameters", self.target.name);
            }
            return Ok(None);
        }
        if let Some((mode, lock)) = input.mode {
            let req = if lock { ModeRequest::Lock(mode) } else { ModeRequest::Enter(mode) };
            if !matches!(self.link.request(&HostMsg::CommandMode(req))?, FswMsg::ModeAccepted { .. }) {
                return Ok(None);
            }
        }
        let mut worst: Option<Cost> = None;
        let (mut declaration, mut events, mut last) = (None::<(usize, u64)>, None::<u16>, FdirSeen::default());
        for (k, f) in input.prefix.iter().chain(std::iter::once(&input.frame)).enumerate() {
            // Sequence numbers increase along the sequence whatever the genome says (the
            // link matches replies by seq); the genome's seq of the first frame is kept.
            let mut f = *f;
            f.seq = input.prefix.first().map_or(input.frame.seq, |p| p.seq).wrapping_add(k as u32);
            let r = self.link.step(&f)?;
            let instructions = (r.step_cost_ticks as f64 * self.ipt).round() as u64;
            // `events` counts since boot: a rise over the previous step is a declaration.
            let ev = r.cmd.fdir.events;
            if events.is_some_and(|e| ev > e) && declaration.is_none_or(|(_, c)| instructions > c) {
                declaration = Some((k, instructions));
            }
            events = Some(ev);
            if worst.is_none_or(|w| instructions > w.instructions) {
                let e = &r.cmd.estimate;
                worst = Some(Cost {
                    instructions,
                    step: k,
                    mode: r.cmd.mode,
                    status: r.cmd.status,
                    estimate_flags: e.flags,
                    mekf_accepted: e.accepted,
                    mekf_rejected: e.rejected,
                    mekf_resets: e.resets,
                    replayed_nodes: e.fusion.max_replayed_nodes,
                    fdir: FdirSeen::default(),
                    declaration: None,
                });
            }
            last = FdirSeen::of(&r.cmd.fdir);
        }
        Ok(worst.map(|w| Cost { fdir: last, declaration, ..w }))
    }

    /// Instructions per cost tick of the link.
    pub fn instructions_per_tick(&self) -> f64 {
        self.ipt
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stored form of an input gives back the same bits, non-finite values and
    /// subnormals included (the corpus must replay exactly what was measured).
    #[test]
    fn input_json_round_trip_is_bit_exact() {
        let mut f = SensorFrame::empty(7, u64::MAX - 3);
        f.valid = 0x5a;
        f.gnss_j2000_days = -9_612;
        f.sampled_at = SampleTimes {
            gyro_us: u64::MAX - 4,
            star_tracker_us: 0,
            sun_sensor_us: 1,
            css_us: u64::MAX,
            magnetometer_us: 123_456_789,
            gnss_us: u64::MAX - 3,
        };
        f.gyro_interval_us = u32::MAX;
        let specials = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -0.0, 1e-40, f32::MAX, 0.1, -3.4e-7];
        for (k, g) in floats_mut(&mut f).into_iter().enumerate() {
            *g = specials[k % specials.len()] * if k % 3 == 0 { 1.0 } else { -1.0 };
        }
        let x = Input { mode: Some((Mode::Hold, true)), failed_mask: 0b1010, prefix: vec![f, f], frame: f };
        let text = serde_json::to_string(&InputJson::from(&x)).unwrap();
        let back: InputJson = serde_json::from_str(&text).unwrap();
        let y = back.input().unwrap();
        let bits =
            |i: &Input| i.prefix.iter().chain([&i.frame]).flat_map(|f| floats(f).map(f32::to_bits)).collect::<Vec<_>>();
        assert_eq!(bits(&x), bits(&y));
        assert_eq!(
            (x.mode, x.failed_mask, x.frame.seq, x.frame.time_us, x.frame.valid, x.frame.gnss_j2000_days),
            (y.mode, y.failed_mask, y.frame.seq, y.frame.time_us, y.frame.valid, y.frame.gnss_j2000_days)
        );
        assert_eq!((x.frame.sampled_at, x.frame.gyro_interval_us), (y.frame.sampled_at, y.frame.gyro_interval_us));
        assert_eq!(floats(&x.frame).len(), FRAME_FIELDS.iter().map(|(_, n)| n).sum::<usize>());
    }

    /// An entry recorded before protocol 13 (no sample times, no gyro increment) reads as
    /// `SensorFrame::empty` gives them: every sample at the frame's time, no increment.
    #[test]
    fn frames_recorded_before_protocol_13_read_with_the_empty_frame_defaults() {
        let old = r#"{"seq": 3, "time_us": 250000, "valid": 3, "q_ib_xyzw": [0, 0, 0, 1], "rate_rad_s": [0.1, 0, 0]}"#;
        let f = serde_json::from_str::<FrameJson>(old).unwrap().frame().unwrap();
        let empty = SensorFrame::empty(3, 250_000);
        assert_eq!(f.sampled_at, SampleTimes::all(250_000));
        assert_eq!((f.gyro_angle_rad, f.gyro_interval_us), (empty.gyro_angle_rad, empty.gyro_interval_us));
        assert_eq!(f.rate_rad_s, [0.1, 0.0, 0.0]);
    }

    /// What the evaluations upload carries the scenario's FDIR: the wheel monitor in the
    /// flight parameters (every slot of the mode table that flies the wheels) and the tracker and gyro monitors
    /// in the estimation parameters, as the scenario file states them (read here from the
    /// TOML text, independently of the scenario loader); a scenario without `[fdir]` has
    /// none. Without them the search would time steps in which no monitor runs.
    #[test]
    fn the_upload_carries_the_scenarios_fdir_monitors() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let every = root.join("campaigns/base-3u-every-monitor.toml");
        let text = std::fs::read_to_string(&every).unwrap();
        let toml: toml::Value = toml::from_str(&text).unwrap();
        let fdir = &toml["fdir"];
        let t = Target::load(&every).unwrap();
        let m = t.monitors();
        assert_eq!(m.wheels, fdir.get("wheels").is_some());
        assert_eq!(m.tracker, fdir.get("star_tracker").is_some());
        assert_eq!(m.gyro, fdir.get("gyro").is_some());
        assert_eq!(m.bias_step, fdir["gyro"].get("bias_step").is_some());
        assert_eq!(m.magnetometer, fdir.get("magnetometer").is_some());
        assert_eq!(m.gnss, fdir.get("gnss").is_some());
        assert!(m.wheels && m.tracker && m.gyro && m.bias_step && m.magnetometer && m.gnss, "every monitor: {m:?}");
        let Upload::Modes(table) = &t.upload else { panic!("the 3U mission flies a mode table") };
        // The monitor rides with the wheels: every slot flying them (detumble flies the
        // magnetorquers).
        let wheel_slots: Vec<_> =
            table.slots.iter().filter(|(_, p)| matches!(p.actuator, ActuatorParams::Wheels(_))).collect();
        assert!(wheel_slots.len() >= 2);
        assert!(wheel_slots.iter().all(|(_, p)| p.fdir.wheel.is_some()));
        let e = t.estimation.unwrap();
        let k = fdir["star_tracker"]["k"].as_integer().unwrap();
        assert_eq!(e.tracker_fdir.map(|f| i64::from(f.window.k)), Some(k));
        let max_repeats = fdir["gyro"]["max_repeats"].as_integer().unwrap();
        assert_eq!(e.gyro_fdir.map(|g| i64::from(g.max_repeats)), Some(max_repeats));
        let plain = Target::load(&root.join("scenarios/modes/cubesat-mission.toml")).unwrap();
        assert_eq!(plain.monitors(), Monitors::default());
    }

    /// Failure bits beyond the family's actuator count are dropped, the scenario's own
    /// failures kept.
    #[test]
    fn extra_failures_are_ored_within_the_actuator_count() {
        let mut p = FlightParams::default();
        if let ActuatorParams::Cmg { cmg, .. } = &mut p.actuator {
            cmg.failed_mask = 0b0001;
        }
        match with_failures(&p, 0xfff4).actuator {
            ActuatorParams::Cmg { cmg, .. } => assert_eq!(cmg.failed_mask, 0b0101),
            _ => unreachable!(),
        }
    }
}
