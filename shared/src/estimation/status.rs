//! What the estimation stage reports about one step: its own types, independent of the
//! wire. `Fsw::step` packs them into `link::EstimateTelemetry`
//! ([`crate::fsw::report::estimate_telemetry`]), as it does for the law and the allocation.

use crate::math::{Quat, Vec3};

bitflags::bitflags! {
    /// What the estimation stage had this step (`EstimateTelemetry::flags` on the wire,
    /// same bits).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub struct EstimateFlags: u16 {
        /// The attitude the laws used this step is available (sensor, or MEKF within
        /// `lost_attitude_sigma_rad`).
        const ATTITUDE = 1 << 0;
        /// The MEKF is initialised and running.
        const MEKF = 1 << 1;
        /// A navigation solution (fix or propagated) and time exist.
        const NAVIGATION = 1 << 2;
        /// The on-board models put the spacecraft in the Earth's shadow.
        const ECLIPSE = 1 << 3;
        /// The Sun was seen this step (fine or coarse sun sensors).
        const SUN_SEEN = 1 << 4;
    }
}

/// Age of the newest sample of each sensor at the step (step time − sample time), s;
/// −1 for a sensor without a sample, negative for one from the future.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampleAges {
    pub gyro: f32,
    pub star_tracker: f32,
    /// The fine sun sensor's, else the coarse sun sensors'.
    pub sun: f32,
    pub magnetometer: f32,
}

/// What the estimator did with the samples since configuration (saturating counters).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FusionCounts {
    /// Samples fused at the newest filter time / at an earlier time (late, replayed).
    pub fused_now: u32,
    pub fused_late: u32,
    /// Refused: older than the filter history.
    pub too_old: u32,
    /// Refused: newer than the step (from the future).
    pub from_the_future: u32,
    /// Refused: not newer than the sensor's last fused sample.
    pub out_of_order: u32,
    /// Refused: non-finite or degenerate input, or a failed replay.
    pub bad_input: u32,
    /// Most history nodes re-run to carry one late sample to now.
    pub max_replayed_nodes: u16,
    /// Samples newer than the filter that waited for the gyro and were then fused at their
    /// own time (counted in `fused_now` too).
    pub fused_after_wait: u32,
    /// Refused: dropped while waiting for the gyro (queue full, or the filter stopped).
    pub dropped_waiting: u32,
    /// Samples waiting for the gyro after this step (at most
    /// [`super::waiting::MAX_WAITING`]).
    pub waiting: u16,
}

impl FusionCounts {
    pub const ZERO: Self = Self {
        fused_now: 0,
        fused_late: 0,
        too_old: 0,
        from_the_future: 0,
        out_of_order: 0,
        bad_input: 0,
        max_replayed_nodes: 0,
        fused_after_wait: 0,
        dropped_waiting: 0,
        waiting: 0,
    };
}

/// The filter's state at the step's time (present only while the MEKF runs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterStatus {
    /// Estimated gyro bias, body axes, rad/s.
    pub bias_rad_s: Vec3,
    /// Upper triangle of the covariance, row by row (`[δθ (body, rad); δb (rad/s)]`).
    pub covariance_upper: [f32; 21],
    /// Time since the last accepted update, s.
    pub since_update_s: f32,
    /// Normalised innovation squared of the last measurement offered.
    pub last_nis: f32,
}

/// The estimation stage's report of one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimateStatus {
    /// The attitude estimate `q_ib`: the MEKF's while it runs (even when not available to
    /// the laws), else the attitude sensor's if available; `None`: neither.
    pub q_est: Option<Quat>,
    /// The MEKF's state, `None` without a running filter.
    pub filter: Option<FilterStatus>,
    /// Updates accepted / rejected by the chi-square gates since configuration.
    pub accepted: u32,
    pub rejected: u32,
    /// Filter re-initialisations after divergence (saturating).
    pub resets: u16,
    pub flags: EstimateFlags,
    pub sample_age_s: SampleAges,
    pub fusion: FusionCounts,
}
