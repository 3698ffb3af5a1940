//! Host ↔ flight-computer link messages (framing: [`super::framing`]).
//!
//! Session: host sends `Hello` (protocol version and schema hash must match), then
//! `UploadParams` (validated; rejected with the offending field) — or, for a mode table,
//! one `UploadModeParams` per mode and `ArmModes` — then one `Sensor` frame per control
//! step; the flight side answers each with a `Step` report, or, for a repeated or
//! out-of-order `seq`, refuses it unstepped with `Error(StaleSequence)` (one frame, one
//! step; protocol 12). Every other message gets exactly one reply.
//!
//! Wire types are plain arrays of f32/u32 so that no layout depends on a math library.
//! Flag fields stay `u16` on the wire; the flight code reads and writes them through the
//! typed [`Valid`] and [`Status`] (`from_bits_retain` / `bits`, same bits) at this boundary.

use crate::checksum::CRC32;
use crate::params::{
    EstimationParams, FlightParams, GuidanceParams, MAX_THRUSTERS, Mode, ModeManagerParams, ModeRequest, ParamError,
};
use crate::params::{TimelineError, TimelineSegment};
#[allow(unused_imports)] // doc links
use crate::types::{MAX_CSS_HEADS, MAX_WHEELS, Status, Valid};
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// Bumped whenever a message changes; the schema hash catches forgotten bumps.
pub const PROTOCOL_VERSION: u16 = 26;

/// Largest postcard payload of any message (checked by a test).
pub const MAX_PAYLOAD: usize = 1280;
/// Largest frame on the wire: COBS overhead + CRC + delimiter.
pub const MAX_FRAME: usize = MAX_PAYLOAD + 4 + MAX_PAYLOAD / 254 + 2;

/// `SensorFrame::valid` bits on the wire: the bits of [`Valid`] (one definition).
pub mod valid {
    use crate::types::Valid;
    pub const ATTITUDE: u16 = Valid::ATTITUDE.bits();
    pub const RATE: u16 = Valid::RATE.bits();
    pub const GIMBALS: u16 = Valid::GIMBALS.bits();
    pub const WHEELS: u16 = Valid::WHEELS.bits();
    pub const MAG: u16 = Valid::MAG.bits();
    pub const SUN: u16 = Valid::SUN.bits();
    /// A GNSS fix (`gnss_*`) taken at this frame's time.
    pub const GNSS: u16 = Valid::GNSS.bits();
    /// Coarse-sun-sensor outputs (`css_output`).
    pub const CSS: u16 = Valid::CSS.bits();
    pub const ALL: u16 = Valid::all().bits();
}

/// `ActuatorCommand::status` bits on the wire: the bits of [`Status`] (one definition,
/// documented there).
pub mod status {
    use crate::types::Status;
    pub const TORQUE_LIMITED: u16 = Status::TORQUE_LIMITED.bits();
    pub const RATE_SCALED: u16 = Status::RATE_SCALED.bits();
    pub const ANGLE_LIMITED: u16 = Status::ANGLE_LIMITED.bits();
    pub const SINGULAR: u16 = Status::SINGULAR.bits();
    pub const BAD_INPUT: u16 = Status::BAD_INPUT.bits();
    pub const TORQUE_SHORTFALL: u16 = Status::TORQUE_SHORTFALL.bits();
    pub const NOT_CONFIGURED: u16 = Status::NOT_CONFIGURED.bits();
    pub const HOLD: u16 = Status::HOLD.bits();
    pub const ALLOC_FALLBACK: u16 = Status::ALLOC_FALLBACK.bits();
    pub const UNREALISED: u16 = Status::UNREALISED.bits();
    pub const MOMENTUM_SATURATION: u16 = Status::MOMENTUM_SATURATION.bits();
    pub const LAW_FAULT: u16 = Status::LAW_FAULT.bits();
    pub const NO_ESTIMATE: u16 = Status::NO_ESTIMATE.bits();
}

/// When each sensor's sample in a frame was taken, on the flight clock, µs (protocol 13).
/// A sensor slower than the control loop repeats its last sample, with its old time, in
/// every frame until the next one: the flight code fuses a sample once, when its time
/// first changes, at that time, and knows its age (`SensorFrame::time_us` − the sample's
/// time). The gimbal encoders and wheel tachometers are read at the frame's time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SampleTimes {
    /// End of the gyro's angle increment and time of its rate sample.
    pub gyro_us: u64,
    /// Star tracker: the exposure, not the delivery.
    pub star_tracker_us: u64,
    pub sun_sensor_us: u64,
    pub css_us: u64,
    pub magnetometer_us: u64,
    /// The GNSS fix's validity time.
    pub gnss_us: u64,
}

impl SampleTimes {
    /// Every sample taken at `time_us`.
    pub const fn all(time_us: u64) -> Self {
        Self {
            gyro_us: time_us,
            star_tracker_us: time_us,
            sun_sensor_us: time_us,
            css_us: time_us,
            magnetometer_us: time_us,
            gnss_us: time_us,
        }
    }
}

/// Everything the flight code reads at one control step (`time_us`, the frame's time on
/// the flight clock); each sensor's sample carries its own time in `sampled_at`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorFrame {
    pub seq: u32,
    pub time_us: u64,
    /// Each sensor's sample time (protocol 13).
    pub sampled_at: SampleTimes,
    /// Measured attitude `q_ib`, scalar-last.
    pub q_ib_xyzw: [f32; 4],
    /// Measured body rate, body axes: the gyro's instantaneous sample at
    /// `sampled_at.gyro_us` (what the rate loop feeds back).
    pub rate_rad_s: [f32; 3],
    /// The gyro's integrated angle increment ∫ω dt, body axes, rad, over the
    /// `gyro_interval_us` ending at `sampled_at.gyro_us` (what an IMU's delta-angle output
    /// gives; the MEKF propagates with it). `gyro_interval_us = 0`: no increment, the
    /// flight code falls back to the rate samples (protocol 13).
    pub gyro_angle_rad: [f32; 3],
    pub gyro_interval_us: u32,
    /// Measured gimbal angles of the four CMGs.
    pub gimbal_angle_rad: [f32; 4],
    /// Measured wheel speeds relative to the body.
    pub wheel_speed_rad_s: [f32; MAX_WHEELS],
    /// Magnetometer, body axes, T.
    pub mag_field_t: [f32; 3],
    /// Fine sun sensor: Sun direction, body axes (unit).
    pub sun_dir: [f32; 3],
    /// Coarse sun sensors: each head's output normalised to full Sun at normal incidence
    /// (≈ max(0, n·s) plus albedo and noise); heads as configured in `EstimationParams`.
    pub css_output: [f32; MAX_CSS_HEADS],
    /// GNSS fix valid at `sampled_at.gnss_us`: position and velocity in the inertial frame (m, m/s)
    /// and the receiver's time as whole days and seconds since J2000.0. Protocol 11
    /// (replaces the ready-made reference frame of protocol ≤ 10).
    pub gnss_pos_m: [f32; 3],
    pub gnss_vel_m_s: [f32; 3],
    pub gnss_j2000_days: i32,
    pub gnss_j2000_s: f32,
    /// [`valid`] bits.
    pub valid: u16,
}

impl SensorFrame {
    /// A frame with nothing valid yet (identity attitudes, zeros; every sample time the
    /// frame's, no gyro increment).
    pub const fn empty(seq: u32, time_us: u64) -> Self {
        Self {
            seq,
            time_us,
            sampled_at: SampleTimes::all(time_us),
            q_ib_xyzw: [0.0, 0.0, 0.0, 1.0],
            rate_rad_s: [0.0; 3],
            gyro_angle_rad: [0.0; 3],
            gyro_interval_us: 0,
            gimbal_angle_rad: [0.0; 4],
            wheel_speed_rad_s: [0.0; MAX_WHEELS],
            mag_field_t: [0.0; 3],
            sun_dir: [0.0; 3],
            css_output: [0.0; MAX_CSS_HEADS],
            gnss_pos_m: [0.0; 3],
            gnss_vel_m_s: [0.0; 3],
            gnss_j2000_days: 0,
            gnss_j2000_s: 0.0,
            valid: 0,
        }
    }
}

/// What one control step decided, plus what it achieved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ActuatorCommand {
    /// Sequence number of the sensor frame this answers.
    pub seq: u32,
    pub gimbal_rate_cmd_rad_s: [f32; 4],
    /// Motor torque on each wheel rotor (the body receives the reaction), N m.
    pub wheel_torque_cmd_nm: [f32; MAX_WHEELS],
    /// Magnetorquer dipole command, body axes, A m².
    pub dipole_cmd_am2: [f32; 3],
    /// Bit i: thruster i open during the next control period (after PWPF).
    pub thruster_on: u16,
    /// Allocated thrust level in [0, 1] per thruster (the PWPF input).
    pub thruster_level: [f32; MAX_THRUSTERS],
    /// Torque the control law asked for (after its own limit), body axes.
    pub torque_demand_nm: [f32; 3],
    /// Torque the commands produce according to the flight code's actuator model
    /// (CMG: eq 4 with `ω × h`; thrusters: the allocated level, before modulation).
    pub torque_realised_nm: [f32; 3],
    /// `det(J Jᵀ)` with unit rotor momentum.
    pub singularity_measure: f32,
    /// SR weight α used this step (0 for Moore-Penrose).
    pub steering_alpha: f32,
    /// Rotation angle of the attitude error, rad.
    pub attitude_error_rad: f32,
    /// Allocation iterations (simplex pivots, wheel re-allocation passes).
    pub alloc_iterations: u16,
    /// Internal state of the law in force, one generic slot for every law: what each
    /// value means depends on the law ([`law_slots`]); unused values 0 (protocol 18).
    pub law_telemetry: [f32; LAW_TELEMETRY_LEN],
    /// Bit i: actuator i at a limit (either side).
    pub saturated: u32,
    /// [`status`] bits.
    pub status: u16,
    /// Mode in force ([`Mode::code`](crate::params::Mode::code)); 0 without a mode table.
    pub mode: u8,
    /// Why it was entered ([`Reason`](crate::modes::Reason) as `u8`).
    pub mode_reason: u8,
    /// Mode transitions since the table was armed (saturating).
    pub mode_transitions: u16,
    /// What attitude determination and navigation produced this step (protocol 11).
    pub estimate: EstimateTelemetry,
    /// Stored actuator momentum the unloading law saw, body axes, N m s (zero when the
    /// mode does not run momentum management; protocol 12).
    pub stored_momentum_nms: [f32; 3],
    /// Momentum FDIR events since the table was armed (saturating; protocol 12).
    pub momentum_events: u16,
    /// "Unloading cannot keep up" events since the table was armed (saturating; flag
    /// only; protocol 12).
    pub momentum_keepup_events: u16,
    /// CMG gimbal-saturation events since the table was armed (saturating; flag only;
    /// protocol 12).
    pub gimbal_events: u16,
    /// What guidance commanded this step (protocol 16; zero on a safe command).
    pub guidance: GuidanceTelemetry,
    /// What fault detection concluded (protocol 20; docs/fdir.md).
    pub fdir: FdirTelemetry,
    /// Bit i: wheel i's drive is switched off (FDIR dropped it; protocol 20): its motor
    /// applies no torque whatever its command or its electronics' fault.
    pub wheel_power_off: u8,
}

/// Fault detection, isolation and recovery telemetry of one step ([`crate::fdir`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FdirTelemetry {
    /// Units declared failed since boot, wheels and sensors (saturating; a ground clear
    /// does not lower it).
    pub events: u16,
    /// Bit i: wheel i declared failed and dropped from the allocation.
    pub failed_wheels: u8,
    /// Bit i: wheel i's failure was isolated to its tachometer (otherwise its rotor).
    pub tachometer_wheels: u8,
    /// Bit i: the isolation of wheel i could not decide (treated as a rotor fault).
    pub ambiguous_wheels: u8,
    /// The wheel monitor judged this step (false: off, first step, a repeated frame or a
    /// wheel or gyro sample missing).
    pub wheel_judged: bool,
    /// Wheel torque residuals `u − I_w (Δω_w + aᵀΔω)/Δt` this step, N m (0 when not
    /// judged).
    pub wheel_residual_nm: [f32; MAX_WHEELS],
    /// The threshold they were held against, N m (0 when not judged).
    pub wheel_threshold_nm: f32,
    /// Bit 0 ([`FAILED_STAR_TRACKER`]): the star tracker declared failed and no longer
    /// fused; bits 1–3 ([`FAILED_GYRO_X`] …): gyro axis x, y, z declared stuck and read as
    /// 0 (protocol 21); bits 4–6 ([`FAILED_MAG_X`] …): magnetometer axis x, y, z declared
    /// stuck, bit 7 ([`FAILED_MAGNETOMETER`]): its field magnitude contradicts the model;
    /// either drops the magnetometer from the estimation (protocol 23).
    pub failed_sensors: u8,
    /// The star tracker's failure was the frozen-output test (otherwise its attitude was
    /// contradicted by the Sun or the field).
    pub tracker_frozen: bool,
    /// The largest angle between a witness (measured Sun, measured field) and where the
    /// tracker's last judged attitude puts it, rad (0 without the monitor or a witness).
    pub tracker_witness_rad: f32,
    /// Gyro bias steps declared since boot (protocol 22; [`crate::fdir::bias`]; also in
    /// `events`). Each restarted the filter with the step added to its bias.
    pub gyro_bias_steps: u16,
    /// The last declared step, rad/s (body axes; 0 before the first).
    pub gyro_bias_step_rad_s: [f32; 3],
    /// Bit i: the last step was isolated to axis i (x, y, z); 0 with steps declared: it
    /// was ambiguous (several axes).
    pub gyro_bias_axes: u8,
    /// The magnetometer monitor's last residual `|B_meas| − |B_model|` and its threshold,
    /// T (protocol 23; 0 when not judged).
    pub mag_residual_t: f32,
    pub mag_threshold_t: f32,
    /// The GNSS receiver declared failed: its fixes are no longer taken (protocol 24,
    /// [`crate::fdir::gnss`]).
    pub gnss_failed: bool,
    /// The GNSS monitor's last residual `|r_fix − r_pred|` and its threshold, m (0 when not
    /// judged).
    pub gnss_residual_m: f32,
    pub gnss_threshold_m: f32,
    /// Bit i: gyro axis i's failure (its `failed_sensors` bit) was the bias-step test naming
    /// it again and again (an erratic axis, [`crate::fdir::bias::ERRATIC_STEPS`]), not its
    /// repeats (protocol 25).
    pub gyro_erratic_axes: u8,
    /// The GNSS monitor's last velocity residual `|v_fix − v_pred|` and its threshold, m/s
    /// (protocol 26; 0 when not judged).
    pub gnss_velocity_residual_m_s: f32,
    pub gnss_velocity_threshold_m_s: f32,
}

/// [`FdirTelemetry::failed_sensors`]: the star tracker.
pub const FAILED_STAR_TRACKER: u8 = 1;
/// [`FdirTelemetry::failed_sensors`]: gyro axis x (y, z: the next two bits).
pub const FAILED_GYRO_X: u8 = 2;
/// [`FdirTelemetry::failed_sensors`]: magnetometer axis x stuck (y, z: the next two bits).
pub const FAILED_MAG_X: u8 = 0x10;
/// [`FdirTelemetry::failed_sensors`]: the magnetometer's field magnitude contradicts the
/// on-board model.
pub const FAILED_MAGNETOMETER: u8 = 0x80;

/// Values in [`ActuatorCommand::law_telemetry`].
pub const LAW_TELEMETRY_LEN: usize = 9;

/// Where each law puts its state in [`ActuatorCommand::law_telemetry`] (the flight side
/// fills it from [`crate::control::LawStatus`]; the ground reads it by the law it
/// configured). A new law's slots go here, within [`LAW_TELEMETRY_LEN`].
pub mod law_slots {
    use super::LAW_TELEMETRY_LEN;
    use core::ops::Range;

    /// DMCS (paper 001 eq 44): the adaptive feed-forward gains Δk_u, x y z.
    pub const DMCS_FEEDFORWARD_GAIN: Range<usize> = 0..3;
    /// DMCS: the adaptive proportional gains Δk_p, per axis `[on q_e, on ω]`, row-major.
    pub const DMCS_PROPORTIONAL_GAIN: Range<usize> = 3..9;
    /// Sun-safe: phase code (0 pointing, 1 searching, 2 eclipse hold).
    pub const SUN_SAFE_PHASE: usize = 0;
    /// Sun-safe: age of the remembered Sun direction, s.
    pub const SUN_SAFE_MEMORY_AGE_S: usize = 1;

    // One law's slots do not overlap and every slot fits the message.
    const _: () = assert!(DMCS_FEEDFORWARD_GAIN.end <= DMCS_PROPORTIONAL_GAIN.start);
    const _: () = assert!(DMCS_PROPORTIONAL_GAIN.end <= LAW_TELEMETRY_LEN);
    const _: () = assert!(SUN_SAFE_PHASE != SUN_SAFE_MEMORY_AGE_S && SUN_SAFE_MEMORY_AGE_S < LAW_TELEMETRY_LEN);

    /// DMCS's Δk_u from a slot (zeros for another law's slot).
    pub fn dmcs_feedforward_gain(t: &[f32; LAW_TELEMETRY_LEN]) -> [f32; 3] {
        let [a, b, c, ..] = *t;
        [a, b, c]
    }

    /// DMCS's Δk_p from a slot, per axis `[on q_e, on ω]`.
    pub fn dmcs_proportional_gain(t: &[f32; LAW_TELEMETRY_LEN]) -> [[f32; 2]; 3] {
        let [_, _, _, a, b, c, d, e, f] = *t;
        [[a, b], [c, d], [e, f]]
    }
}

/// Guidance telemetry of one step ([`crate::guidance`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GuidanceTelemetry {
    /// [`crate::guidance::flags`] bits.
    pub flags: u8,
    /// Commanded attitude, body → inertial, scalar-last.
    pub q_cmd_xyzw: [f32; 4],
    /// Angular rate and acceleration of the commanded frame, inertial axes.
    pub rate_cmd_rad_s: [f32; 3],
    pub accel_cmd_rad_s2: [f32; 3],
    /// Primary target direction, inertial unit vector (zero for a fixed attitude).
    pub primary_eci: [f32; 3],
    /// Entries into the near-parallel fallback and pointing switches (saturating).
    pub parallel_events: u16,
    pub switches: u16,
    /// The commanded attitude's smallest keep-out margin over every cone, rad (negative:
    /// inside; +∞ without cones or geometry).
    pub keepout_margin_rad: f32,
    /// Slews planned (of which through a waypoint), and refused by reason: target inside
    /// a cone, no path, no geometry (saturating; protocol 17).
    pub slews_planned: u16,
    pub slews_with_waypoint: u16,
    pub slews_refused: [u16; 3],
    /// [`crate::guidance::manoeuvre::phase`] of this step, and the latest refusal's reason
    /// ([`crate::guidance::manoeuvre::Refusal::code`], 0: none yet).
    pub slew_phase: u8,
    pub slew_refusal: u8,
}

/// `EstimateTelemetry::flags` bits.
pub mod estimate_flags {
    /// The attitude the laws used this step is available (sensor, or MEKF within
    /// `lost_attitude_sigma_rad`).
    pub const ATTITUDE: u16 = 1 << 0;
    /// The MEKF is initialised and running.
    pub const MEKF: u16 = 1 << 1;
    /// A navigation solution (fix or propagated) and time exist.
    pub const NAVIGATION: u16 = 1 << 2;
    /// The on-board models put the spacecraft in the Earth's shadow.
    pub const ECLIPSE: u16 = 1 << 3;
    /// The Sun was seen this step (fine or coarse sun sensors).
    pub const SUN_SEEN: u16 = 1 << 4;
}

/// Attitude-determination telemetry of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EstimateTelemetry {
    /// The attitude estimate `q_ib`, scalar-last (the sensor's with `AttitudeSource::Sensor`).
    pub q_est_xyzw: [f32; 4],
    /// Estimated gyro bias, body axes, rad/s.
    pub bias_est_rad_s: [f32; 3],
    /// Upper triangle of the MEKF covariance, row by row (`[δθ (body, rad); δb (rad/s)]`,
    /// 21 values); zeros without the MEKF.
    pub covariance_upper: [f32; 21],
    /// Updates accepted / rejected by the chi-square gates since configuration.
    pub accepted: u32,
    pub rejected: u32,
    /// Time since the last accepted update, s.
    pub since_update_s: f32,
    /// Normalised innovation squared of the last measurement offered.
    pub last_nis: f32,
    /// Filter re-initialisations after divergence (saturating).
    pub resets: u16,
    /// [`estimate_flags`] bits.
    pub flags: u16,
    /// Age of the newest sample of each sensor at this step (frame time − sample time), s;
    /// −1 for a sensor without a sample (protocol 13).
    pub sample_age_s: SampleAges,
    /// Samples fused at their own time and samples refused, with the reason (protocol 13).
    pub fusion: FusionCounters,
}

/// Age of the newest sample of each sensor, s (−1: none yet).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SampleAges {
    pub gyro: f32,
    pub star_tracker: f32,
    pub sun: f32,
    pub magnetometer: f32,
}

/// What the estimator did with the samples since configuration (saturating counters).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FusionCounters {
    /// Samples fused at the newest filter time / at an earlier time (late, replayed).
    pub fused_now: u32,
    pub fused_late: u32,
    /// Refused: older than the filter history.
    pub too_old: u32,
    /// Refused: newer than the frame (from the future). A sample newer than the gyro but
    /// not than the frame waits instead (`waiting`; protocol 15).
    pub from_the_future: u32,
    /// Refused: not newer than the sensor's last fused sample (out of order).
    pub out_of_order: u32,
    /// Refused: non-finite or degenerate input, or a failed replay.
    pub bad_input: u32,
    /// Most history nodes re-run to carry one late sample to now.
    pub max_replayed_nodes: u16,
    /// Samples taken after the filter's time (the gyro lagging them) that waited for the
    /// gyro and were then fused at their own time (counted in `fused_now` too). Protocol 15.
    pub fused_after_wait: u32,
    /// Refused: dropped while waiting for the gyro (the sensor's wait queue full, or the
    /// filter stopped). Protocol 15.
    pub dropped_waiting: u32,
    /// Samples waiting for the gyro after this step (at most
    /// `estimation::waiting::MAX_WAITING`). Protocol 15.
    pub waiting: u16,
}

/// A step's command and what the flight computer measured while producing it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepReport {
    pub cmd: ActuatorCommand,
    /// Cost of `Fsw::step` in ticks of the cost counter (see `HelloAck`); 0 = not measured.
    pub step_cost_ticks: u32,
    /// Real-time mode: control periods that ended before the step finished.
    pub deadline_misses: u32,
    /// Frames the flight side dropped so far (CRC, COBS, decode, oversize).
    pub frames_dropped: u32,
    /// Lockstep `Sensor` frames refused since the last `Hello` because their `seq` was not
    /// above the last stepped one (a repeated or out-of-order frame; each got an
    /// `Error(StaleSequence)` reply and was not stepped). Protocol 12.
    pub seq_refused: u32,
    /// The pointing timeline after this step (protocol 19).
    pub timeline: TimelineTelemetry,
}

/// Pointing-timeline counters of a step report ([`crate::guidance::timeline`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimelineTelemetry {
    /// Segments of the armed timeline (0: none armed).
    pub segments: u8,
    /// Index + 1 of the segment whose pointing is in force (0: none yet).
    pub in_force: u8,
    /// Segments on target at their start, and not (late, refused, or skipped while the
    /// timeline was not stepped); saturating, reset at each arming.
    pub met: u16,
    pub missed: u16,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkError {
    ProtocolVersion {
        flight: u16,
    },
    SchemaHash {
        flight: u32,
    },
    NotConfigured,
    UnexpectedMessage,
    /// A target that is not a unit quaternion.
    BadTarget,
    /// A mode command without an armed table, or for a mode the table does not have.
    NoSuchMode,
    /// Parameters (`UploadParams`, `UploadModeParams`, `ArmModes`) sent in real-time mode
    /// while the loop is stepping: they could change the control rate or law mid-flight.
    /// Accepted again once the loop is in the safe hold (no fresh sensor frames).
    RealTimeNotInHold,
    /// `DebugHang` to a flight side built without the debug hook (every flight build).
    DebugDisabled,
    /// Lockstep: a `Sensor` frame whose `seq` is not above the last stepped frame's
    /// (`last_seq`) — a repeated or out-of-order frame. It was not stepped (one frame, one
    /// step); `StepReport::seq_refused` counts these. Protocol 12.
    StaleSequence {
        seq: u32,
        last_seq: u32,
    },
    /// Sent by the host's virtual flight computer (`sim-host serve`) to a client that
    /// connects while another one is being served; the connection is then closed.
    /// Protocol 12.
    Busy,
    /// `FreezeAdaptation` while the law in force does not adapt (only DMCS does): nothing
    /// changed. Protocol 14.
    NotAdaptive,
    /// A fault clear named a unit the flight code does not have (protocol 20).
    NoSuchUnit,
}

/// Why the flight computer last started (`HelloAck::reset_cause`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ResetCause {
    /// Power-on (or brown-out) reset, or a start with no recorded cause (host side).
    PowerOn,
    /// The independent watchdog expired (a control cycle did not complete in time).
    Watchdog,
    /// Software reset request (`SYSRESETREQ`).
    Software,
    /// External reset pin.
    Pin,
    /// Low-power management reset, window watchdog or any other recorded cause.
    Other,
}

/// Host → flight computer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HostMsg {
    Hello {
        protocol_version: u16,
        schema_hash: u32,
    },
    /// A single parameter set (no mode manager). Reply: `ParamsAccepted`/`ParamsRejected`.
    UploadParams(FlightParams),
    Sensor(SensorFrame),
    /// New mission target (the manoeuvre/hold target with a mode table). Reply: `Ack`.
    SetTarget {
        target_q_xyzw: [f32; 4],
    },
    /// One mode's parameter set of a mode table (one message per mode keeps every message
    /// within `MAX_PAYLOAD`). Reply: `ParamsAccepted`/`ParamsRejected`.
    UploadModeParams {
        mode: Mode,
        params: FlightParams,
    },
    /// Arm the uploaded table with its transition thresholds. Reply: `ModesArmed`/`ParamsRejected`.
    ArmModes(ModeManagerParams),
    /// Attitude-determination parameters for every mode (protocol 11). Reply:
    /// `ParamsAccepted`/`ParamsRejected`; the estimator restarts.
    ConfigureEstimation(EstimationParams),
    /// Ground mode command. Reply: `ModeAccepted`/`Error(NoSuchMode)`.
    CommandMode(ModeRequest),
    /// Real-time mode only: start pacing steps with the flight computer's own clock.
    StartRealTime,
    /// Freeze (`frozen: true`) or resume the adaptation of the law in force, keeping its
    /// state: unlike `UploadParams`, the law is not reset (DMCS keeps its gains Δk_p,
    /// Δk_u and reference model and skips the increments of eqs 50-51 while frozen). A
    /// mode switch or a new configuration starts the next law adapting. Reply: `Ack`;
    /// `Error(NotAdaptive)` when the law in force does not adapt, `Error(NotConfigured)`
    /// without one (nothing changed either way). Protocol 14.
    FreezeAdaptation {
        frozen: bool,
    },
    /// Test hook: the flight side stops answering and stops its control loop (a hang) so
    /// that the watchdog must reset it. Only firmware built with the `debug-hang` feature
    /// (the QEMU test image, never a flight image) obeys; everything else answers
    /// `Error(DebugDisabled)`.
    DebugHang,
    /// New pointing for the mission modes (manoeuvre and hold with a mode table; the set in
    /// force otherwise), blended in over its `transition_s` (protocol 16). Reply: `Ack`, or
    /// `ParamsRejected` naming the field (nothing changed).
    SetPointing(GuidanceParams),
    /// Stage segment `index` (0-based, < `MAX_TIMELINE_SEGMENTS`) of a pointing timeline
    /// (protocol 19, docs/guidance.md "Timeline"). Reply: `Ack`, or `ParamsRejected` (its
    /// pointing invalid, or the index out of range). A timeline already armed keeps running.
    UploadTimelineSegment {
        index: u8,
        segment: TimelineSegment,
    },
    /// Arm staged segments `0..count` whose CRC-32 (postcard of each, in order) is `crc32`
    /// (protocol 19). Reply: `TimelineArmed`, or `TimelineRejected` naming the first bad
    /// segment and why (the timeline in force, if any, unchanged).
    ArmTimeline {
        count: u8,
        crc32: u32,
    },
    /// Drop the timeline, staged and armed; the pointing in force stays (protocol 19).
    /// Reply: `Ack`.
    ClearTimeline,
    /// Re-enable wheel `wheel` (0-based) that fault detection dropped, forgetting its
    /// exceedances; `ALL_UNITS` re-enables every wheel (protocol 20, docs/fdir.md). Reply:
    /// `Ack`, or `Error(NoSuchUnit)` for an index beyond the wheels (nothing changed).
    ClearWheelFault {
        wheel: u8,
    },
    /// Re-enable the star tracker, the gyro axes, the magnetometer and the GNSS receiver
    /// the estimation stage's monitors declared failed (used again from their next sample;
    /// protocol 21, the magnetometer 23, the GNSS 24; docs/fdir.md "Star tracker", "Gyro",
    /// "Magnetometer", "GNSS"). Reply: `Ack`.
    ClearSensorFaults,
}

/// [`HostMsg::ClearWheelFault`]'s "every unit".
pub const ALL_UNITS: u8 = u8::MAX;

/// Flight computer → host.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FswMsg {
    HelloAck {
        protocol_version: u16,
        schema_hash: u32,
        params_version: u16,
        /// Frequency of the counter `step_cost_ticks` is read from, Hz.
        cost_counter_hz: u32,
        /// 0 = in-process (host), 1 = QEMU mps2-an386, 2 = STM32F405.
        board: u8,
        /// Why the flight computer last started (a watchdog reset means it came back up
        /// in the safe state: unconfigured, lockstep, safe command).
        reset_cause: ResetCause,
        /// Deepest stack use since boot, bytes below the initial stack pointer, measured
        /// when this reply is built (painted-stack scan, see docs/elf-check.md); 0 = not
        /// measured (host). Protocol 10.
        stack_hwm_bytes: u32,
    },
    ParamsAccepted {
        checksum: u32,
    },
    ParamsRejected(ParamError),
    ModesArmed {
        checksum: u32,
    },
    ModeAccepted {
        mode: Mode,
    },
    /// Success of a message that has no other reply (`SetTarget`, `FreezeAdaptation`).
    Ack,
    Step(StepReport),
    Error(LinkError),
    /// `ArmTimeline` accepted: the timeline's checksum (protocol 19).
    TimelineArmed {
        checksum: u32,
    },
    /// `ArmTimeline` refused: the first offending segment and why (protocol 19).
    TimelineRejected(TimelineError),
}

/// A `postcard::ser_flavors::Flavor` that only feeds a CRC digest.
struct CrcSink<'a>(crc::Digest<'a, u32>);

impl postcard::ser_flavors::Flavor for CrcSink<'_> {
    type Output = u32;
    fn try_push(&mut self, data: u8) -> postcard::Result<()> {
        self.0.update(&[data]);
        Ok(())
    }
    fn try_extend(&mut self, data: &[u8]) -> postcard::Result<()> {
        self.0.update(data);
        Ok(())
    }
    fn finalize(self) -> postcard::Result<u32> {
        Ok(self.0.finalize())
    }
}

/// CRC-32 of the postcard-schema description of both message enums: any change of a
/// field, type, order or name of a wire type changes it.
pub fn schema_hash() -> u32 {
    let mut d = CRC32.digest();
    for s in [HostMsg::SCHEMA, FswMsg::SCHEMA] {
        let sink = CrcSink(CRC32.digest());
        if let Ok(h) = postcard::serialize_with_flavor(s, sink) {
            d.update(&h.to_le_bytes());
        }
    }
    d.finalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The typed flags keep the wire bits of protocol version 9 (bit 6 renamed GNSS and bit 7 CSS added in 11) (literal values), and a
    /// frame carrying them encodes to the same bytes as with the literal `u16`s.
    #[test]
    fn typed_flags_keep_the_wire_bits() {
        assert_eq!(
            [
                valid::ATTITUDE,
                valid::RATE,
                valid::GIMBALS,
                valid::WHEELS,
                valid::MAG,
                valid::SUN,
                valid::GNSS,
                valid::CSS
            ],
            [1, 2, 4, 8, 16, 32, 64, 128]
        );
        assert_eq!(valid::ALL, 0xff);
        let st = [
            status::TORQUE_LIMITED,
            status::RATE_SCALED,
            status::ANGLE_LIMITED,
            status::SINGULAR,
            status::BAD_INPUT,
            status::TORQUE_SHORTFALL,
            status::NOT_CONFIGURED,
            status::HOLD,
            status::ALLOC_FALLBACK,
            status::UNREALISED,
            status::MOMENTUM_SATURATION,
            status::LAW_FAULT,
            status::NO_ESTIMATE,
        ];
        assert_eq!(st, core::array::from_fn(|i| 1u16 << i));
        assert_eq!(Status::all().bits(), 0x1fff);
        let typed =
            SensorFrame { valid: (Valid::ATTITUDE | Valid::RATE | Valid::GNSS).bits(), ..SensorFrame::empty(3, 7) };
        let literal = SensorFrame { valid: 0b100_0011, ..SensorFrame::empty(3, 7) };
        let (mut a, mut b) = ([0u8; MAX_PAYLOAD], [0u8; MAX_PAYLOAD]);
        let ea = postcard::to_slice(&typed, &mut a).unwrap();
        let eb = postcard::to_slice(&literal, &mut b).unwrap();
        assert_eq!(ea, eb);
        let cmd = ActuatorCommand { status: (Status::LAW_FAULT | Status::SINGULAR).bits(), ..Default::default() };
        let cmd_lit = ActuatorCommand { status: 0x0808, ..Default::default() };
        assert_eq!(postcard::to_slice(&cmd, &mut a).unwrap(), postcard::to_slice(&cmd_lit, &mut b).unwrap());
    }
}
