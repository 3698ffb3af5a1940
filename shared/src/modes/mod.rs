//! Mode manager: detumble → sun-safe → stabilise → manoeuvre → hold.
//!
//! Each mode is a complete, separately validated [`FlightParams`](crate::params::FlightParams)
//! (its own control law, actuator family and target), uploaded one by one
//! (`HostMsg::UploadModeParams`) so that no single message has to hold every law; the
//! table is then armed with [`ModeManagerParams`] (`HostMsg::ArmModes`).
//!
//! Automatic transitions (evaluated every step on the validated measurements, before the
//! law runs, so the new mode commands the same step):
//! - any mode but detumble → detumble: `|ω| > detumble_enter_rate` for
//!   `trigger_persistence_s` (the safety net after separation or a failure);
//! - detumble → next: `|ω| < detumble_exit_rate` for `dwell_s`;
//! - stabilise → next: error to the stabilise target `< stabilise_exit_error` and
//!   `|ω - ω_c| < stabilise_exit_rate` for `dwell_s`;
//! - manoeuvre → hold: error `< hold_enter_error` and `|ω - ω_c| < hold_enter_rate` for
//!   `dwell_s`;
//! - hold → manoeuvre: error `> hold_exit_error` for `trigger_persistence_s` (e.g. after a
//!   new target was commanded);
//! - any pointing mode → sun-safe (else detumble): the mode's inputs missing (a star
//!   tracker blinded by a tumble, the fine attitude estimate lost or diverged) while the
//!   fallback's are there, for `trigger_persistence_s`;
//! - sun-safe → next: every input of the next mode (the fine attitude) present for
//!   `dwell_s` (sun-safe itself needs only the gyro: it searches when the Sun is not seen);
//! - no convergence transition goes into a mode whose inputs this frame lacks;
//! - momentum FDIR (`momentum_trip_fraction > 0`): a wheel above that fraction of its
//!   speed limit for `trigger_persistence_s` counts one momentum event (reported as
//!   `ActuatorCommand::momentum_events` and the `MOMENTUM_SATURATION` status bit while
//!   it lasts) and sends stabilise, manoeuvre or hold to sun-safe (else detumble) with
//!   reason `MomentumHigh`; sun-safe hands back only once every wheel is below
//!   `momentum_recover_fraction` (the safe modes may carry their own unloading,
//!   [`crate::params::MomentumParams`]).
//!
//! Hysteresis: every enter threshold is strictly beyond its exit threshold (validated),
//! and conditions must persist, so noise at a threshold cannot make the mode chatter.
//! "next" skips modes that have no parameter set (a table without stabilise goes from
//! detumble straight to manoeuvre). Commands over the link: `Enter(mode)` switches now
//! and automatic transitions go on from there; `Lock(mode)` switches and suspends them
//! (ground tests, anomaly handling); `Auto` resumes them.
//!
//! Counters are in control steps, saturating: the loop has no unbounded state.
//!
//! [`params`] holds the thresholds and their validation ([`ModeManagerParams`]),
//! [`manager`] the transition logic ([`ModeManager`]).

use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

pub mod manager;
pub mod params;

pub use manager::{ModeInputs, ModeManager};
pub use params::{MAX_THRESHOLD, ModeManagerParams};

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

/// Why the current mode was entered (`ActuatorCommand::mode_reason`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Reason {
    /// The initial mode of the armed table.
    Armed = 0,
    /// Body rate above `detumble_enter_rate`.
    RateHigh = 1,
    /// Body rate below `detumble_exit_rate`.
    Detumbled = 2,
    /// Stabilise converged.
    Stabilised = 3,
    /// Manoeuvre converged.
    OnTarget = 4,
    /// Hold error above `hold_exit_error` (new target or disturbance).
    OffTarget = 5,
    /// Commanded over the link.
    Commanded = 6,
    /// The mode's inputs were missing (star tracker blinded by a tumble, fine attitude
    /// estimate lost or diverged) while the fallback's (sun-safe, else detumble) were there.
    InputLost = 7,
    /// Sun-safe: the fine attitude (and every input of the next mode) is back.
    EstimateValid = 8,
    /// Momentum FDIR: a wheel above `momentum_trip_fraction` of its speed limit for
    /// `trigger_persistence_s` (protocol 12).
    MomentumHigh = 9,
}

impl Reason {
    pub fn from_code(c: u8) -> Option<Reason> {
        [
            Reason::Armed,
            Reason::RateHigh,
            Reason::Detumbled,
            Reason::Stabilised,
            Reason::OnTarget,
            Reason::OffTarget,
            Reason::Commanded,
            Reason::InputLost,
            Reason::EstimateValid,
            Reason::MomentumHigh,
        ]
        .get(c as usize)
        .copied()
    }

    pub const fn name(self) -> &'static str {
        match self {
            Reason::Armed => "armed",
            Reason::RateHigh => "rate_high",
            Reason::Detumbled => "detumbled",
            Reason::Stabilised => "stabilised",
            Reason::OnTarget => "on_target",
            Reason::OffTarget => "off_target",
            Reason::Commanded => "commanded",
            Reason::InputLost => "input_lost",
            Reason::EstimateValid => "estimate_valid",
            Reason::MomentumHigh => "momentum_high",
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
