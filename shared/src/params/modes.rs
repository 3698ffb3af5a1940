//! The mode table's types: the modes themselves ([`Mode`], shared by the mode manager, the
//! wire telemetry and the upload messages), the ground's [`ModeRequest`], and the
//! thresholds of the automatic transitions with their validation ([`ModeManagerParams`]).

use super::{ParamError, ParamField, ParamReason};
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// Number of modes (slots of the mode table).
pub const MODE_COUNT: usize = 5;

/// `ActuatorCommand::mode` when no mode table is armed (a single parameter set runs);
/// modes are reported as [`Mode::code`] = slot index + 1.
pub const MODE_NONE: u8 = 0;

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    Detumble,
    Stabilise,
    Manoeuvre,
    Hold,
    /// Sun-pointing safe mode on the coarse sun sensors and the gyro (protocol 11; last so
    /// the codes of the others stay).
    SunSafe,
}

impl Mode {
    /// Slot order (telemetry codes 1 … 5).
    pub const ALL: [Mode; MODE_COUNT] = [Mode::Detumble, Mode::Stabilise, Mode::Manoeuvre, Mode::Hold, Mode::SunSafe];
    /// The nominal sequence the convergence transitions follow.
    pub const SEQUENCE: [Mode; MODE_COUNT] =
        [Mode::Detumble, Mode::SunSafe, Mode::Stabilise, Mode::Manoeuvre, Mode::Hold];

    /// Position in [`Mode::SEQUENCE`].
    pub const fn rank(self) -> usize {
        match self {
            Mode::Detumble => 0,
            Mode::SunSafe => 1,
            Mode::Stabilise => 2,
            Mode::Manoeuvre => 3,
            Mode::Hold => 4,
        }
    }

    /// Slot index (also the telemetry code).
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Telemetry code (`ActuatorCommand::mode`): 1 … 4; 0 is [`MODE_NONE`].
    pub const fn code(self) -> u8 {
        (self as u8).saturating_add(1)
    }

    pub fn from_code(c: u8) -> Option<Mode> {
        Mode::ALL.get(usize::from(c).checked_sub(1)?).copied()
    }

    pub const fn name(self) -> &'static str {
        match self {
            Mode::Detumble => "detumble",
            Mode::Stabilise => "stabilise",
            Mode::Manoeuvre => "manoeuvre",
            Mode::Hold => "hold",
            Mode::SunSafe => "sun_safe",
        }
    }
}

/// A mode command from the ground.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModeRequest {
    /// Switch now; automatic transitions continue from there.
    Enter(Mode),
    /// Switch now and suspend automatic transitions.
    Lock(Mode),
    /// Resume automatic transitions.
    Auto,
}

/// Thresholds of the automatic transitions (rad, rad/s, s).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModeManagerParams {
    /// Bit `i`: the table uses slot `i` (`Mode::index`). Every such slot must have been
    /// uploaded; slots outside the mask are dropped when the table is armed, so a table
    /// left on the flight computer by an earlier session cannot leak into this one.
    pub slots: u8,
    pub initial: Mode,
    pub detumble_enter_rate_rad_s: f32,
    pub detumble_exit_rate_rad_s: f32,
    pub stabilise_exit_error_rad: f32,
    pub stabilise_exit_rate_rad_s: f32,
    pub hold_enter_error_rad: f32,
    pub hold_enter_rate_rad_s: f32,
    pub hold_exit_error_rad: f32,
    /// How long a convergence condition must hold before the mode moves on.
    pub dwell_s: f32,
    /// How long a fault condition (rate high, off target) must hold before it acts.
    pub trigger_persistence_s: f32,
    /// Momentum FDIR (protocol 12): the largest wheel speed as a fraction of its limit
    /// above which, held for `trigger_persistence_s`, a momentum event is counted and a
    /// pointing mode falls back to sun-safe (else detumble). 0 = monitor off.
    pub momentum_trip_fraction: f32,
    /// Sun-safe hands back to the pointing modes only below this fraction (hysteresis,
    /// `< momentum_trip_fraction`).
    pub momentum_recover_fraction: f32,
    /// "Unloading cannot keep up" (protocol 12): the stored wheel momentum `|h|` above
    /// this fraction of the cluster capacity `J_w Ω_max` (one wheel at its limit) for
    /// `slow_fdir_persistence_s` counts a keep-up event (flag only). 0 = monitor off.
    pub momentum_keepup_fraction: f32,
    /// CMG gimbal saturation (protocol 12): a gimbal within 1e-3 rad of its angle limit,
    /// or the singularity measure `det(J₁J₁ᵀ)` below this, for `slow_fdir_persistence_s`
    /// counts a gimbal event (flag only). 0 = the singularity test off (the angle test
    /// runs whenever the persistence is set).
    pub gimbal_singularity_min: f32,
    /// Persistence of the keep-up and gimbal monitors, s (0 = both off).
    pub slow_fdir_persistence_s: f32,
}

/// Largest mode-manager threshold or time the flight code accepts (rad, rad/s or s).
pub const MAX_THRESHOLD: f32 = 1.0e6;

impl ModeManagerParams {
    pub fn validate(&self) -> Result<(), ParamError> {
        let bad = |reason| Err(ParamError { field: ParamField::ModeTable, reason });
        let all = [
            self.detumble_enter_rate_rad_s,
            self.detumble_exit_rate_rad_s,
            self.stabilise_exit_error_rad,
            self.stabilise_exit_rate_rad_s,
            self.hold_enter_error_rad,
            self.hold_enter_rate_rad_s,
            self.hold_exit_error_rad,
            self.dwell_s,
            self.trigger_persistence_s,
        ];
        if !all.iter().all(|x| x.is_finite()) {
            return bad(ParamReason::NotFinite);
        }
        if !all.iter().all(|x| *x >= 0.0 && *x <= MAX_THRESHOLD) {
            return bad(ParamReason::OutOfRange);
        }
        // Hysteresis: the band between exit and enter must be open.
        if !(self.detumble_enter_rate_rad_s > self.detumble_exit_rate_rad_s)
            || !(self.hold_exit_error_rad > self.hold_enter_error_rad)
            || !(self.detumble_exit_rate_rad_s > 0.0)
        {
            return bad(ParamReason::OutOfRange);
        }
        let (trip, recover) = (self.momentum_trip_fraction, self.momentum_recover_fraction);
        if !(trip.is_finite() && recover.is_finite()) {
            return bad(ParamReason::NotFinite);
        }
        if trip != 0.0 && !(trip <= 1.0 && recover >= 0.0 && recover < trip) {
            return bad(ParamReason::OutOfRange);
        }
        let slow = [self.momentum_keepup_fraction, self.gimbal_singularity_min, self.slow_fdir_persistence_s];
        if !slow.iter().all(|x| x.is_finite()) {
            return bad(ParamReason::NotFinite);
        }
        if !(0.0..=1.0).contains(&self.momentum_keepup_fraction)
            || !(0.0..=2.0).contains(&self.gimbal_singularity_min)
            || !(0.0..=1.0e7).contains(&self.slow_fdir_persistence_s)
        {
            return bad(ParamReason::OutOfRange);
        }
        if self.slots & (1 << self.initial.index()) == 0 || self.slots >> MODE_COUNT != 0 {
            return bad(ParamReason::OutOfRange);
        }
        Ok(())
    }

    /// CRC-32 of the postcard encoding (what the flight side reports when it arms).
    pub fn checksum(&self) -> Result<u32, ParamError> {
        let mut buf = [0u8; 64];
        let used = postcard::to_slice(self, &mut buf)
            .map_err(|_| ParamError { field: ParamField::ModeTable, reason: ParamReason::TooLarge })?;
        Ok(crate::checksum::CRC32.checksum(used))
    }
}
