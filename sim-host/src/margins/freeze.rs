//! Adaptive laws measured at a frozen adaptation state (docs/margins.md, "DMCS: adapting,
//! and at a frozen adaptation state"). At a hold the first-order variation of the DMCS
//! adaptation increments (paper 001 eqs 50-51) is zero, so the linearisation of the
//! adapting loop is the loop at frozen gains `u = Δk_p x_p + Δk_u u_m`: that is the loop a
//! margin describes. The experiment and its twin are frozen at the operating point through
//! the link (`FreezeAdaptation`), before they fork (in-process) or on each re-flown run
//! (QEMU): the same message and the same bits either way.

use super::MarginError;
use acs_flight::link::law_slots;
use serde::Serialize;
use sim_core::simulation::probe::Probe;

/// What `margins.json` says of an adaptive law (`adaptation`; `null` for the others).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrozenAdaptation {
    pub note: String,
    /// Δk_p per axis `[on q_e, on ω]` at the operating point, as the flight reported it.
    pub proportional_gain: [[f32; 2]; 3],
    /// Δk_u per axis.
    pub feedforward_gain: [f32; 3],
}

/// Freezes the adaptation of the flight law of `sim` (at its operating point); `None` when
/// the law does not adapt (nothing changed).
pub fn freeze(sim: &mut Probe) -> Result<Option<FrozenAdaptation>, MarginError> {
    if !sim.freeze_adaptation(true).map_err(MarginError::flight)? {
        return Ok(None);
    }
    let (cmd, _) = sim.last_step().ok_or_else(|| MarginError::Flight("no flight step before the freeze".into()))?;
    Ok(Some(FrozenAdaptation {
        note: format!(
            "the adaptive law (DMCS) was measured at its frozen adaptation state: the adaptation (eqs 50-51) was \
             stopped at t = {:.3} s in the experiments and their twins, the gains kept (the linearisation of the \
             adapting loop at a hold; docs/margins.md)",
            sim.steps_done() as f64 * sim.control_period_s()
        ),
        proportional_gain: law_slots::dmcs_proportional_gain(&cmd.law_telemetry),
        feedforward_gain: law_slots::dmcs_feedforward_gain(&cmd.law_telemetry),
    }))
}

/// A refusal of a frozen measurement says that the loop measured was the frozen one.
pub fn said_frozen(e: MarginError, frozen: Option<&FrozenAdaptation>) -> MarginError {
    if frozen.is_none() {
        return e;
    }
    let add = |r: String| format!("{r} (DMCS adaptation frozen at the operating point)");
    match e {
        MarginError::NotSteady { t_s, reason } => MarginError::NotSteady { t_s, reason: add(reason) },
        MarginError::Unstable { reason } => MarginError::Unstable { reason: add(reason) },
        other => other,
    }
}
