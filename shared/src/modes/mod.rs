//! Mode manager: detumble → sun-safe → stabilise → manoeuvre → hold.
//!
//! Each mode is a complete, separately validated [`FlightParams`](crate::params::FlightParams)
//! (its own control law, actuator family and target), uploaded one by one
//! (`HostMsg::UploadModeParams`) so that no single message has to hold every law; the
//! table is then armed with [`ModeManagerParams`](crate::params::ModeManagerParams) (`HostMsg::ArmModes`).
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
//! The modes, the ground's requests and the thresholds with their validation are
//! parameter-layer types ([`crate::params::modes`]: [`Mode`](crate::params::Mode),
//! [`ModeManagerParams`](crate::params::ModeManagerParams)), shared with the wire; here
//! are [`manager`], the transition logic ([`ModeManager`]), and the telemetry [`Reason`].

use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

pub mod manager;

pub use manager::{ModeInputs, ModeManager};

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
