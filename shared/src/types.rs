//! The data the algorithms exchange: typed sensor samples, measurements, set point, torque
//! demand and typed flag sets. Algorithms use these; [`crate::validation`] and `Fsw::step`
//! convert the wire frame at their boundary, never the reverse, so no estimator depends on
//! the wire format.

use crate::math::{Quat, Vec3};

/// Capacity of the reaction-wheel array (the wire arrays and the wheel parameters).
pub const MAX_WHEELS: usize = 6;
/// Number of coarse-sun-sensor heads the link carries.
pub const MAX_CSS_HEADS: usize = 6;

bitflags::bitflags! {
    /// What a sensor frame carries (`SensorFrame::valid` on the wire, same bits).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub struct Valid: u16 {
        const ATTITUDE = 1 << 0;
        const RATE = 1 << 1;
        const GIMBALS = 1 << 2;
        const WHEELS = 1 << 3;
        const MAG = 1 << 4;
        const SUN = 1 << 5;
        /// A GNSS fix (position, velocity, time) taken at the frame's time.
        const GNSS = 1 << 6;
        /// Coarse-sun-sensor outputs.
        const CSS = 1 << 7;
    }
}

bitflags::bitflags! {
    /// What a control step did (`ActuatorCommand::status` on the wire, same bits).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub struct Status: u16 {
        /// The torque demand exceeded its limit and was scaled (direction kept).
        const TORQUE_LIMITED = 1 << 0;
        /// Gimbal rates were scaled to the rate limit (direction kept).
        const RATE_SCALED = 1 << 1;
        /// At least one gimbal sat at its angle limit and its rate was zeroed.
        const ANGLE_LIMITED = 1 << 2;
        /// The steering matrix was singular for the chosen law (MP): safe zero rates.
        const SINGULAR = 1 << 3;
        /// The sensor frame was invalid (NaN, non-unit quaternion, flags): safe command held.
        const BAD_INPUT = 1 << 4;
        /// The realised torque differs from the demand by more than 1 % of its norm.
        const TORQUE_SHORTFALL = 1 << 5;
        /// The flight code is not configured (no accepted parameters): safe command.
        const NOT_CONFIGURED = 1 << 6;
        /// Real-time mode: no fresh sensor frame, the safe command is held.
        const HOLD = 1 << 7;
        /// The allocation failed (infeasible, iteration cap, non-finite, internal error):
        /// its documented safe fallback was commanded.
        const ALLOC_FALLBACK = 1 << 8;
        /// Some actuator cannot realise its command (magnetorquer dead band, wheel at its
        /// speed limit).
        const UNREALISED = 1 << 9;
        /// CMG cluster at its momentum envelope (saturation singularity): no more torque
        /// along the singular direction; momentum must be dumped.
        const MOMENTUM_SATURATION = 1 << 10;
        /// The control law produced a non-finite demand (overflow from extreme gains or
        /// states): zero torque was allocated and the law's state reset.
        const LAW_FAULT = 1 << 11;
        /// The mode needs the fine attitude estimate or the navigation solution and it is
        /// not available (estimator lost, never initialised, no GNSS yet): safe command.
        const NO_ESTIMATE = 1 << 12;
    }
}

impl Status {
    /// Conditions after which the integrating laws freeze their integrators next step
    /// (conditional integration, anti-windup).
    pub const SATURATING: Self = Self::TORQUE_LIMITED
        .union(Self::RATE_SCALED)
        .union(Self::ANGLE_LIMITED)
        .union(Self::TORQUE_SHORTFALL)
        .union(Self::SINGULAR)
        .union(Self::ALLOC_FALLBACK)
        .union(Self::UNREALISED);
}

/// A gyro sample: body rate, body axes, rad/s (flagged, finite, within range), and the
/// integrated angle increment ending at the same time when the gyro gives one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroRate {
    /// On-board time of the sample, µs.
    pub time_us: u64,
    pub rate_rad_s: Vec3,
    pub increment: Option<GyroIncrement>,
}

/// The gyro's angle increment ∫ω dt over `interval_s` ending at the sample's time, body
/// axes, rad (finite, interval > 0, mean rate within range).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroIncrement {
    pub angle_rad: Vec3,
    pub interval_s: f32,
}

/// A star-tracker (attitude sensor) sample: `q_ib`, unit (normalised from a reading within
/// 10 % of unit norm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StarTrackerAttitude {
    /// On-board time of the sample, µs.
    pub time_us: u64,
    pub q_ib: Quat,
}

/// A fine-sun-sensor sample: the Sun direction, body axes, as measured (not normalised).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunSensorDirection {
    /// On-board time of the sample, µs.
    pub time_us: u64,
    pub dir_body: Vec3,
}

/// A coarse-sun-sensor sample: each head's output normalised to full Sun at normal
/// incidence (heads as configured in `EstimationParams`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CssOutputs {
    /// On-board time of the sample, µs.
    pub time_us: u64,
    pub output: [f32; MAX_CSS_HEADS],
}

/// A magnetometer sample: the field, body axes, T (finite).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagnetometerField {
    /// On-board time of the sample, µs.
    pub time_us: u64,
    pub field_body_t: Vec3,
}

/// A GNSS fix as received: inertial position and velocity (m, m/s) and the receiver's
/// time as whole days and seconds since J2000.0 (plausibility is navigation's check).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssFix {
    /// On-board time the fix is valid at, µs.
    pub time_us: u64,
    pub pos_eci_m: Vec3,
    pub vel_eci_m_s: Vec3,
    pub j2000_days: i32,
    pub j2000_s: f32,
}

/// The last accepted fix carried to a new fix's time (`estimation::navigation::Navigation::
/// predict_fix`): what the GNSS monitor (`fdir::gnss`) judges the new fix against.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PredictedFix {
    /// Inertial position and velocity, m, m/s.
    pub r_m: Vec3,
    pub v_m_s: Vec3,
    /// The time carried over, s.
    pub dt_s: f32,
}

/// The typed sensor samples of one step (`crate::validation::sensor_samples`): what the
/// estimation stage reads; `None` for a sensor not flagged valid or not usable.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorSamples {
    /// On-board time of the step, µs.
    pub time_us: u64,
    pub gyro: Option<GyroRate>,
    pub star_tracker: Option<StarTrackerAttitude>,
    pub sun_sensor: Option<SunSensorDirection>,
    pub css: Option<CssOutputs>,
    pub magnetometer: Option<MagnetometerField>,
    pub gnss: Option<GnssFix>,
}

/// Validated, normalised measurements (what `Fsw::step` checked a sensor frame into).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurements {
    /// Attitude `q_ib` from the estimation stage (identity when not available and the
    /// configuration does not need it).
    pub q: Quat,
    /// Body rate, body axes, rad/s (bias-corrected with the MEKF).
    pub rate_rad_s: Vec3,
    pub gimbal_angle_rad: [f32; 4],
    pub wheel_speed_rad_s: [f32; MAX_WHEELS],
    /// Magnetometer, body axes, T.
    pub mag_field_t: Vec3,
    /// Reference frame (LVLH from on-board navigation) relative to inertial (identity
    /// without a navigation solution).
    pub q_ref: Quat,
    /// Angular velocity of the reference frame, inertial axes, rad/s.
    pub ref_rate_rad_s: Vec3,
    /// Measured Sun direction, body axes (unit), if seen (fine or coarse sun sensors).
    pub sun_body: Option<Vec3>,
    /// The on-board models put the spacecraft in the Earth's shadow.
    pub eclipse: bool,
}

/// Commanded attitude and rate (guidance output).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setpoint {
    pub q_cmd: Quat,
    /// Rate of the commanded frame, body axes, rad/s.
    pub rate_cmd_rad_s: Vec3,
    /// Angular acceleration of the commanded frame, body axes, rad/s² (the target's motion
    /// fed forward; zero for a fixed attitude).
    pub accel_cmd_rad_s2: Vec3,
    /// Feed the commanded frame's motion forward (`GuidanceParams::feedforward`): the laws
    /// that support it add `J (ω̇_c − ω × ω_c)`.
    pub feedforward: bool,
    /// GSR dither clock, s (reduced modulo the dither period; 0 without GSR).
    pub dither_time_s: f32,
}

/// Result of one control-law update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TorqueDemand {
    pub torque_nm: Vec3,
    /// The demand hit `torque_limit_nm` and was scaled.
    pub limited: bool,
    /// Rotation angle of the attitude error, rad.
    pub error_angle_rad: f32,
}

/// What a control law asks the actuators for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Demand {
    /// A body torque, N m, body axes (steered/allocated to the configured family).
    Torque(Vec3),
    /// Gimbal rates straight from the law (gimbal-rate LQR), rad/s: no steering.
    GimbalRates([f32; 4]),
}

impl Demand {
    /// The torque asked for (zero for direct gimbal rates, which have no torque demand).
    pub fn torque_nm(&self) -> Vec3 {
        match self {
            Self::Torque(u) => *u,
            Self::GimbalRates(_) => Vec3::zeros(),
        }
    }

    pub fn is_finite(&self) -> bool {
        match self {
            Self::Torque(u) => u.iter().all(|x| x.is_finite()),
            Self::GimbalRates(r) => r.iter().all(|x| x.is_finite()),
        }
    }

    /// The documented fallback after a law fault: the same kind of demand, all zero.
    pub fn zeroed(&self) -> Self {
        match self {
            Self::Torque(_) => Self::Torque(Vec3::zeros()),
            Self::GimbalRates(_) => Self::GimbalRates([0.0; 4]),
        }
    }
}
