//! The estimation section's checks (`scenarios/estimation/`): figures computed from runs
//! flown here, each beside the criterion that decides it. The same criteria are asserted by
//! `sim-host/core/tests/estimation_closed_loop.rs`; this table only reports them.
//!
//! - Hold on the MEKF against hold on an ideal attitude (`mekf-hold` flown again without
//!   `[estimation]`, a noise-free star tracker and no gyro model): pointing on an estimate
//!   costs at most its error, `RMS_mekf ≤ RMS_ideal + 3 RMS_estimation`.
//! - A star-tracker outage through eclipse (`tracker-outage-eclipse`): the gyro-only error
//!   stays under the Farrenkopf growth `e0 + 3√3 √(σb² t² + σv² t + σu² t³/3)` (σv ARW,
//!   σu RRW of the scenario's gyro, σb the filter's bias σ at the outage start — here
//!   √tr P_bb, an upper bound of the per-axis σ the test uses, so the ratio reported is at
//!   most the test's), and is back under 0.05° 60 s after the tracker returns.
//!
//! And the cost of the whole flight step on the Cortex-M4F with determination in the loop,
//! as the timing module reports it from its committed worst-case corpus
//! ([`crate::timing::step_cost`]: instructions counted on the QEMU firmware by
//! `sim-host timing search`, docs/timing.md), so this report stays free of wall-clock
//! figures and of QEMU.

use super::experiment::{Block, fly_recorded, load_scenario as load, sig};
use crate::timing::step_cost;
use anyhow::{Result, anyhow};
use std::path::Path;

fn row(check: &str, scenario: &str, figures: String, criterion: &str, met: bool) -> Vec<String> {
    let met = if met { "yes" } else { "**no**" };
    [check, scenario, &figures, criterion, met].map(String::from).to_vec()
}

/// Hold RMS on the MEKF and on an ideal attitude, and the estimation RMS.
fn hold_versus_ideal(repo: &Path) -> Result<Vec<String>> {
    let sc = load(repo, "estimation/mekf-hold.toml")?;
    let mekf = fly_recorded(&sc)?.summary;
    let mut ideal = sc.clone();
    ideal.estimation = None;
    ideal.sensors.gyro = None;
    let t = ideal.sensors.star_tracker.as_mut().ok_or_else(|| anyhow!("mekf-hold has no star tracker"))?;
    t.noise_cross_deg = Some(0.0);
    t.noise_about_deg = Some(0.0);
    let ideal = fly_recorded(&ideal)?.summary;
    let est = mekf.estimation_error_rms_deg.ok_or_else(|| anyhow!("mekf-hold did not run the MEKF"))?;
    // A hold that never settles has no post-settle RMS: NaN fails the comparison below.
    let (rms_mekf, rms_ideal) =
        (mekf.rms_error_after_settle_deg.unwrap_or(f64::NAN), ideal.rms_error_after_settle_deg.unwrap_or(f64::NAN));
    Ok(row(
        "hold on the MEKF vs on an ideal attitude",
        "`estimation/mekf-hold`",
        format!(
            "hold RMS {}° on the MEKF, {}° ideal; estimation RMS {}°",
            sig(rms_mekf, 3),
            sig(rms_ideal, 3),
            sig(est, 3)
        ),
        "RMS_mekf ≤ RMS_ideal + 3 RMS_estimation",
        rms_mekf <= rms_ideal + 3.0 * est,
    ))
}

/// Gyro-only growth through the outage against its bound, and the recovery.
fn outage_against_the_gyro_bound(repo: &Path) -> Result<Vec<String>> {
    let mut sc = load(repo, "estimation/tracker-outage-eclipse.toml")?;
    sc.timing.output_every = 1;
    let [t0, t1] = sc
        .sensors
        .star_tracker
        .as_ref()
        .and_then(|t| t.outages_s.first().copied())
        .ok_or_else(|| anyhow!("tracker-outage-eclipse has no tracker outage"))?;
    let gyro = sc.sensors.gyro.as_ref().ok_or_else(|| anyhow!("tracker-outage-eclipse has no gyro model"))?;
    let (sv, su) = (gyro.arw_rad_sqrt_s, gyro.rrw_rad_s_sqrt_s);
    let r = fly_recorded(&sc)?;
    let col = |n: &str| r.series.col(n).ok_or_else(|| anyhow!("column {n}"));
    let (t, err, bsig) = (col("t_s")?, col("est_error_deg")?, col("est_bias_sigma_deg_h")?);
    let at = |x: f64| t.iter().position(|v| *v >= x).ok_or_else(|| anyhow!("no sample at {x} s"));
    let (k0, k1, k_rec) = (at(t0)?, at(t1)?, at(t1 + 60.0)?);
    let e0 = err[k0].to_radians();
    let sb = (bsig[k0] / 3600.0).to_radians();
    let mut worst = 0.0f64;
    for k in k0 + 1..k1 {
        let dt = t[k] - t0;
        let bound = e0 + 3.0 * 3f64.sqrt() * (sb * sb * dt * dt + sv * sv * dt + su * su * dt.powi(3) / 3.0).sqrt();
        worst = worst.max(err[k].to_radians() / bound.max(1e-12));
    }
    let (e_end, e_rec) = (err[k1 - 1], err[k_rec]);
    let ok = worst <= 1.0 && e_rec < 0.05 && worst.is_finite() && e_rec.is_finite();
    Ok(row(
        "tracker outage through eclipse, gyro only",
        "`estimation/tracker-outage-eclipse`",
        format!(
            "{} s without tracker: error {}° → {}°, worst error / bound {}; {}° 60 s after it returns",
            sig(t1 - t0, 4),
            sig(err[k0], 3),
            sig(e_end, 3),
            sig(worst, 3),
            sig(e_rec, 3)
        ),
        "error ≤ e0 + 3√3 √(σb² t² + σv² t + σu² t³/3); < 0.05° 60 s after",
        ok,
    ))
}

/// The scenarios whose step cost is reported (their corpus files are named after them).
const COSTED: [&str; 4] = [
    "modes/cubesat-mission.toml",
    "estimation/mekf-hold.toml",
    "estimation/tracker-outage-eclipse.toml",
    "estimation/sun-safe-from-tumble.toml",
];
/// The flight board's clock and the cycles-per-instruction range of `timing/budget.toml`.
const CLOCK_HZ: f64 = 168e6;
const CPI_MAX: f64 = 2.7;

/// Searched worst step per scenario (and per mode) from the timing corpus.
pub fn cost_table(repo: &Path) -> Result<Block> {
    let mut rows = Vec::new();
    for rel in COSTED {
        let sc = load(repo, rel)?;
        let c = step_cost(repo, &sc.name)?;
        let modes: Vec<String> = c.worst_per_mode.iter().map(|(m, n)| format!("{m} {n}")).collect();
        let period_s = 1.0 / sc.timing.control_rate_hz;
        let worst_s = c.worst_instructions as f64 * CPI_MAX / CLOCK_HZ;
        rows.push(vec![
            format!("`{}`", rel.trim_end_matches(".toml")),
            c.worst_instructions.to_string(),
            if modes.is_empty() { "—".into() } else { modes.join("; ") },
            c.nominal_instructions.map_or_else(|| "—".into(), |n| n.to_string()),
            format!("{:.0}–{:.0}", c.worst_instructions as f64 / CLOCK_HZ * 1e6, worst_s * 1e6),
            format!("{}", sig(100.0 * worst_s / period_s, 2)),
            c.evaluations.to_string(),
        ]);
    }
    Ok(Block::Table {
        header: [
            "scenario",
            "searched worst (instructions)",
            "worst per mode",
            "nominal input",
            "µs at 168 MHz (1–2.7 CPI)",
            "% of the period (2.7 CPI)",
            "inputs evaluated",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    })
}

/// The checks table.
pub fn checks(repo: &Path) -> Result<Block> {
    Ok(Block::Table {
        header: ["check", "scenario", "ours", "criterion", "met"].map(String::from).to_vec(),
        rows: vec![hold_versus_ideal(repo)?, outage_against_the_gyro_bound(repo)?],
    })
}
