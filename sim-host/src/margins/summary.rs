//! Margins in runs and campaigns (docs/margins.md, "In runs and campaigns"): a scenario's
//! `[margins]` table turned into measurement options, and a measurement (or its refusal)
//! turned into the `summary.json` `margins` scalars that campaigns disperse over and
//! require.

use super::{MarginError, MarginOptions, MarginReport, measure};
use sim_core::runner::{MarginStatus, MarginSummary, Summary};
use sim_core::scenario::{MarginRequest, Scenario, THREADS};

impl MarginOptions {
    /// These options (link, threads) with the operating point, loop and grid of a
    /// `[margins]` request, refined (`[margins]` always refines). The caller's thread count
    /// (the machine's cores, not a user's choice) is kept within [`THREADS`].
    pub fn with_request(&self, req: &MarginRequest) -> Self {
        Self {
            at_s: Some(req.at_s),
            point: req.point,
            grid_points: req.grid_points,
            refine: true,
            threads: self.threads.clamp(THREADS.0, THREADS.1),
            ..self.clone()
        }
    }
}

/// Worst over the axes of one per-axis figure (`None` entries skipped).
fn worst(values: impl Iterator<Item = Option<f64>>, pick: fn(f64, f64) -> f64) -> Option<f64> {
    values.flatten().reduce(pick)
}

/// The summary scalars of a measurement, or of its refusal at `req`.
pub fn summarize(req: &MarginRequest, measured: &Result<MarginReport, MarginError>) -> MarginSummary {
    let empty = |status, reason: String| MarginSummary {
        status,
        reason: Some(reason),
        at_s: req.at_s,
        loop_point: req.point,
        method: None,
        stable: None,
        phase_margin_deg: None,
        gain_margin_low_db: None,
        gain_margin_high_db: None,
        delay_margin_s: None,
        crossover_rad_s: None,
        sensitivity_peak_db: None,
        disk_alpha: None,
        multiloop_disk_alpha: None,
    };
    let r = match measured {
        Ok(r) => r,
        Err(e) => {
            let status = match e {
                MarginError::Flight(_) | MarginError::Refused(_) => MarginStatus::Error,
                MarginError::Unsupported(_) => MarginStatus::Unsupported,
                MarginError::OverBudget(_) => MarginStatus::OverBudget,
                MarginError::NotSteady { .. } => MarginStatus::NotSteady,
                MarginError::Unstable { .. } => MarginStatus::Unstable,
            };
            return empty(status, e.to_string());
        }
    };
    let axes = &r.axes;
    // A loop measured unstable keeps its figures (how far from stable), beside its status.
    let (status, reason) = if r.stable {
        (MarginStatus::Measured, None)
    } else {
        (
            MarginStatus::Unstable,
            Some(format!(
                "measured {} loop with a negative margin: the loop is not stable at the operating point (the \
                 figures are those of the unstable loop)",
                if r.method == super::Method::Open { "open" } else { "closed" }
            )),
        )
    };
    MarginSummary {
        status,
        reason,
        at_s: r.at_s,
        loop_point: r.loop_point,
        method: serde_json::to_value(r.method).ok().and_then(|v| v.as_str().map(str::to_owned)),
        stable: Some(r.stable),
        phase_margin_deg: worst(axes.iter().map(|a| a.phase_margin_deg), f64::min),
        gain_margin_low_db: worst(axes.iter().map(|a| a.gain_margin_low_db), f64::max),
        gain_margin_high_db: worst(axes.iter().map(|a| a.gain_margin_high_db), f64::min),
        delay_margin_s: worst(axes.iter().map(|a| a.delay_margin_s), f64::min),
        crossover_rad_s: worst(axes.iter().map(|a| a.crossover_rad_s), f64::max),
        sensitivity_peak_db: worst(axes.iter().map(|a| Some(a.sensitivity_peak_db)), f64::max),
        disk_alpha: worst(axes.iter().map(|a| Some(a.disk_margin.alpha)), f64::min),
        multiloop_disk_alpha: Some(r.multiloop_disk_margin.alpha),
    }
}

/// Measures the margins `[margins]` asks for (None without the table). An invalid table is
/// an error; a refused measurement is a summary with its status and reason. [`record`]
/// puts it into a run's summary.
pub fn for_scenario(
    sc: &Scenario,
    base: &MarginOptions,
) -> anyhow::Result<Option<(MarginSummary, Option<MarginReport>)>> {
    let Some(req) = sc.margin_request()? else { return Ok(None) };
    let measured = measure(sc, &base.with_request(&req));
    Ok(Some((summarize(&req, &measured), measured.ok())))
}

/// Measures the margins `[margins]` asks for into `summary` ([`Summary::record_margins`]:
/// a measurement that is not a stable loop at a steady hold fails the run,
/// `run_status` `margins_failed`); returns the report when one was measured.
pub fn record(sc: &Scenario, base: &MarginOptions, summary: &mut Summary) -> anyhow::Result<Option<MarginReport>> {
    let Some((m, report)) = for_scenario(sc, base)? else { return Ok(None) };
    summary.record_margins(m);
    Ok(report)
}

/// The exit status a run with `[margins]` ends with: 0 when measured (a stable loop at a
/// steady hold), else `sim-host margins`'s (1 error, 2 unsupported or over budget, 3 not
/// steady, or unstable — diverged, or measured with a negative margin).
pub fn exit_code(m: &MarginSummary) -> i32 {
    match m.status {
        MarginStatus::Measured if m.stable == Some(true) => 0,
        MarginStatus::Measured | MarginStatus::NotSteady | MarginStatus::Unstable => 3,
        MarginStatus::Unsupported | MarginStatus::OverBudget => 2,
        MarginStatus::Error => 1,
    }
}

/// One console line: the worst margins, or why none was measured.
pub fn line(m: &MarginSummary) -> String {
    use crate::format::sig_short as sig;
    let f = |v: Option<f64>, unit: &str| v.map_or("inf".into(), |x| format!("{}{unit}", sig(x, 4)));
    match m.status {
        MarginStatus::Measured | MarginStatus::Unstable if m.stable.is_some() => format!(
            "margins at t = {} s ({} loop, {}), worst axis: PM {}, GM {} / {}, delay margin {}, crossover {}, \
             multiloop disk alpha {}; {}",
            sig(m.at_s, 6),
            serde_json::to_value(m.loop_point).ok().and_then(|v| v.as_str().map(String::from)).unwrap_or_default(),
            m.method.as_deref().unwrap_or("?"),
            f(m.phase_margin_deg, " deg"),
            f(m.gain_margin_low_db, " dB"),
            f(m.gain_margin_high_db, " dB"),
            f(m.delay_margin_s, " s"),
            f(m.crossover_rad_s, " rad/s"),
            f(m.multiloop_disk_alpha, ""),
            if m.stable == Some(true) { "stable" } else { "NOT STABLE" }
        ),
        _ => format!("margins not measured ({:?}): {}", m.status, m.reason.as_deref().unwrap_or("")),
    }
}
