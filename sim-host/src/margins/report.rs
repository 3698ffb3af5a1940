//! `margins.json` ([`MarginReport`], format version 1, docs/margins.md "Output") and the
//! console table: the measured response and every margin computed from it.

use super::analysis::{self, AxisMargins, C64, Cmat, DiskMargin};
use super::{LoopPoint, MarginError, MarginOptions, Measured, Method};
use serde::Serialize;
use sim_core::link::LinkKind;
use sim_core::scenario::Scenario;
use std::fmt::Write as _;

/// The amplitude rule and what it gave (docs/margins.md, "Excitation").
#[derive(Clone, Debug, Serialize)]
pub struct Amplitude {
    /// The rule in words.
    pub rule: String,
    /// Attitude excitation aimed at, rad.
    pub attitude_target_rad: f64,
    /// Smallest and largest sine amplitude used (N m at the input, rad at the output).
    pub min: f64,
    pub max: f64,
    /// Smallest and largest peak true-attitude difference an experiment produced, rad.
    pub peak_attitude_min_rad: f64,
    pub peak_attitude_max_rad: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct OperatingPoint {
    pub steady: bool,
    pub reason: Option<String>,
}

#[derive(Clone, Debug, Serialize)]
pub struct GainCrossing {
    pub frequency_rad_s: f64,
    pub gain_margin_db: f64,
}

/// Loop-at-a-time figures of one axis.
#[derive(Clone, Debug, Serialize)]
pub struct AxisReport {
    pub axis: &'static str,
    pub crossover_rad_s: Option<f64>,
    pub phase_margin_deg: Option<f64>,
    pub gain_margin_low_db: Option<f64>,
    pub gain_margin_high_db: Option<f64>,
    pub gain_crossings: Vec<GainCrossing>,
    pub delay_margin_s: Option<f64>,
    /// The discrete-time bound: whole control periods of added delay the loop tolerates,
    /// `floor(delay_margin_s / T)`.
    pub delay_margin_steps: Option<i64>,
    pub sensitivity_peak_db: f64,
    pub sensitivity_peak_rad_s: f64,
    pub complementary_peak_db: f64,
    pub complementary_peak_rad_s: f64,
    pub disk_margin: DiskMargin,
    /// Every gain crossover (frequency, phase margin), when there are several.
    pub crossovers: Vec<[f64; 2]>,
    pub notes: Vec<String>,
}

/// How the measurement went.
#[derive(Clone, Debug, Serialize)]
pub struct Cost {
    pub experiments: u64,
    pub pilot_frequencies: usize,
    pub refined_frequencies: usize,
    pub unconverged_experiments: usize,
    pub crossover_estimate_rad_s: f64,
    pub wall_time_s: f64,
}

/// `margins.json`.
#[derive(Clone, Debug, Serialize)]
pub struct MarginReport {
    pub format_version: u32,
    pub scenario: String,
    pub at_s: f64,
    #[serde(rename = "loop")]
    pub loop_point: LoopPoint,
    pub link: String,
    /// `closed` or `open` (docs/margins.md, "Open-loop measurement").
    pub method: Method,
    /// Why the method is not the one asked for (auto's fallback to the open loop).
    pub method_note: Option<String>,
    /// An adaptive law measured at its frozen adaptation state: the note and the frozen
    /// gains (`null` for a law that does not adapt).
    pub adaptation: Option<super::freeze::FrozenAdaptation>,
    pub control_period_s: f64,
    pub nyquist_rad_s: f64,
    pub amplitude: Amplitude,
    pub operating_point: OperatingPoint,
    pub frequencies_rad_s: Vec<f64>,
    /// The loop axes (rows, body axes) when they are not the body axes: magnetorquers,
    /// two axes perpendicular to the frozen field and the field's direction, about which
    /// no torque can be made (`axes` lists the first two; the third's row and column of
    /// `response` are zero). `null`: the body axes x, y, z.
    pub loop_axes_body: Option<[[f64; 3]; 3]>,
    /// Magnetorquers: the field frozen at the operating point (docs/margins.md,
    /// "Magnetorquer loops").
    pub field_note: Option<String>,
    /// `response[k][i][j] = [re, im]` of `L(ω_k)`, output axis i, input axis j.
    pub response: Vec<[[[f64; 2]; 3]; 3]>,
    pub axes: Vec<AxisReport>,
    /// D-scaled μ upper bound: a guaranteed margin (the one reported).
    pub multiloop_disk_margin: DiskMargin,
    /// `1 / max σ̄(S − I/2)`, without scaling (more conservative).
    pub multiloop_disk_margin_unscaled: DiskMargin,
    pub stable: bool,
    pub cost: Cost,
}

fn axis_report(name: &'static str, a: &AxisMargins, dt: f64) -> AxisReport {
    let critical = a.critical_crossover();
    let delay = a.delay_margin_s();
    let mut notes = Vec::new();
    if a.crossovers.is_empty() {
        notes.push("no gain crossover on the grid: no phase or delay margin".into());
    }
    if a.phase_crossings.is_empty() {
        notes.push("no phase crossing at -180 deg on the grid: gain margins infinite (null)".into());
    }
    AxisReport {
        axis: name,
        crossover_rad_s: critical.map(|c| c.frequency_rad_s),
        phase_margin_deg: critical.map(|c| c.phase_margin_deg),
        gain_margin_low_db: a.gain_margin_low_db(),
        gain_margin_high_db: a.gain_margin_high_db(),
        gain_crossings: a
            .phase_crossings
            .iter()
            .map(|p| GainCrossing { frequency_rad_s: p.frequency_rad_s, gain_margin_db: p.gain_margin_db })
            .collect(),
        delay_margin_s: delay,
        delay_margin_steps: delay.map(|d| (d / dt).floor() as i64),
        sensitivity_peak_db: a.sensitivity_peak.0,
        sensitivity_peak_rad_s: a.sensitivity_peak.1,
        complementary_peak_db: a.complementary_peak.0,
        complementary_peak_rad_s: a.complementary_peak.1,
        disk_margin: a.disk,
        crossovers: a.crossovers.iter().map(|c| [c.frequency_rad_s, c.phase_margin_deg]).collect(),
        notes,
    }
}

/// Margins are on the stable side: every crossover of every axis has a positive phase
/// margin (closed loop: the time-domain check has already found no divergence; open loop:
/// the verdict rests on the measured `L` alone, with the multiloop disk margin).
fn margins_stable(axes: &[AxisReport]) -> bool {
    axes.iter().all(|a| a.crossovers.iter().all(|c| c[1] > 0.0))
}

fn link_name(k: &LinkKind) -> String {
    match k {
        LinkKind::InProcess => "in-process".into(),
        LinkKind::Qemu => "qemu".into(),
        LinkKind::Tcp(a) => format!("tcp:{a}"),
        LinkKind::Serial { device, baud } => format!("serial:{device}@{baud}"),
    }
}

/// The amplitude rule in words.
fn amplitude_rule(point: LoopPoint, method: Method) -> &'static str {
    match (point, method) {
        (LoopPoint::Input, Method::Closed) => {
            "input torque a(w) = min(theta * J_jj * max(w, wc)^2, 5 % of the tightest actuator channel limit)"
        }
        (LoopPoint::Input, Method::Open) => {
            "input torque a(w) = min(theta * J_jj * w^2, 5 % of the tightest actuator channel limit), loop open"
        }
        (LoopPoint::Output, _) => "attitude rotation a = theta on the attitude sample",
    }
}

/// The report of a finished measurement.
pub fn build(
    sc: &Scenario,
    opts: &MarginOptions,
    at_s: f64,
    dt: f64,
    m: &Measured,
    experiments: u64,
    wall_s: f64,
) -> Result<MarginReport, MarginError> {
    let r = &m.response;
    let w = r.rad_s(dt);
    let s: Vec<Cmat> =
        super::sensitivities(r).into_iter().collect::<Option<Vec<_>>>().ok_or_else(|| MarginError::Unstable {
            reason: "I + L is singular at a measured frequency (closed-loop pole on the unit circle)".into(),
        })?;
    let mut axes: Vec<AxisReport> = m
        .axes
        .names()
        .iter()
        .enumerate()
        .map(|(i, n)| axis_report(n, &analysis::axis_margins(&w, &s, i, std::f64::consts::PI / dt), dt))
        .collect();
    let (ml, ml_unscaled) = analysis::multiloop_disk_margin(&w, &s);
    // Columns with no block are the unactuated axis's (magnetorquers: along the field).
    let peaks = r.columns.iter().flatten().filter(|c| c.blocks > 0).map(|c| c.peak_attitude_rad);
    let fold = |it: &mut dyn Iterator<Item = f64>, f: fn(f64, f64) -> f64, z: f64| it.fold(z, f);
    let unconverged = r.columns.iter().flatten().filter(|c| !c.converged).count();
    let rule = amplitude_rule(opts.point, m.method);
    let stable = margins_stable(&axes) && ml.alpha > 0.0;
    if !stable {
        for a in &mut axes {
            a.notes.push(
                "the loop is not stable: the disk margins and the |S|, |T| peaks are those of the measured \
                 (I + L)^-1 on the unit circle, not guarantees"
                    .into(),
            );
        }
    }
    Ok(MarginReport {
        format_version: 1,
        scenario: sc.name.clone(),
        at_s,
        loop_point: opts.point,
        link: link_name(&opts.link),
        method: m.method,
        method_note: m.method_note.clone(),
        adaptation: None,
        control_period_s: dt,
        nyquist_rad_s: std::f64::consts::PI / dt,
        amplitude: Amplitude {
            rule: rule.into(),
            attitude_target_rad: opts.amplitude_rad,
            min: fold(&mut m.amplitudes.iter().copied(), f64::min, f64::INFINITY),
            max: fold(&mut m.amplitudes.iter().copied(), f64::max, 0.0),
            peak_attitude_min_rad: fold(&mut peaks.clone(), f64::min, f64::INFINITY),
            peak_attitude_max_rad: fold(&mut peaks.clone(), f64::max, 0.0),
        },
        operating_point: OperatingPoint { steady: true, reason: None },
        frequencies_rad_s: w,
        loop_axes_body: m.axes.body,
        field_note: m.field_note.clone(),
        response: r.l.iter().map(|l| l.map(|row| row.map(|z: C64| [z.re, z.im]))).collect(),
        axes,
        multiloop_disk_margin: ml,
        multiloop_disk_margin_unscaled: ml_unscaled,
        stable,
        cost: Cost {
            experiments,
            pilot_frequencies: m.pilot_frequencies,
            refined_frequencies: m.refined_frequencies,
            unconverged_experiments: unconverged,
            crossover_estimate_rad_s: m.crossover_estimate_rad_s,
            wall_time_s: wall_s,
        },
    })
}

fn opt(x: Option<f64>, prec: usize) -> String {
    x.map_or("inf".into(), |v| format!("{v:.prec$}"))
}

/// The console table.
pub fn table(r: &MarginReport) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: margins at t = {} s, loop broken at the {} ({}, {}), T = {} s, {} frequencies, {} experiments, {:.1} s",
        r.scenario,
        r.at_s,
        match r.loop_point {
            LoopPoint::Input => "actuator input",
            LoopPoint::Output => "attitude measurement",
        },
        match r.method {
            Method::Closed => "measured closed loop",
            Method::Open => "measured open loop",
        },
        r.link,
        r.control_period_s,
        r.frequencies_rad_s.len(),
        r.cost.experiments,
        r.cost.wall_time_s
    );
    for n in r.method_note.iter().chain(&r.field_note) {
        let _ = writeln!(s, "note: {n}");
    }
    if let Some(a) = &r.adaptation {
        let _ = writeln!(s, "note: {}", a.note);
    }
    let _ = writeln!(
        s,
        "axis  wc[rad/s]  PM[deg]  GMlow[dB]  GMhigh[dB]  DM[s]     |S|pk[dB]  |T|pk[dB]  disk a   diskGM[dB]  diskPM[deg]"
    );
    for a in &r.axes {
        let d = &a.disk_margin;
        let _ = writeln!(
            s,
            "{:<4}  {:>9}  {:>7}  {:>9}  {:>10}  {:>8}  {:>9.2}  {:>9.2}  {:>7.3}  {:>10}  {:>11.1}",
            a.axis,
            opt(a.crossover_rad_s, 4),
            opt(a.phase_margin_deg, 1),
            opt(a.gain_margin_low_db, 1),
            opt(a.gain_margin_high_db, 1),
            opt(a.delay_margin_s, 4),
            a.sensitivity_peak_db,
            a.complementary_peak_db,
            d.alpha,
            opt(d.gain_margin_db, 2),
            d.phase_margin_deg
        );
    }
    let m = &r.multiloop_disk_margin;
    let _ = writeln!(
        s,
        "multiloop disk margin (D-scaled mu bound): alpha {:.3}, gain {} dB, phase {:.1} deg at {:.4} rad/s (unscaled alpha {:.3}); {}",
        m.alpha,
        opt(m.gain_margin_db, 2),
        m.phase_margin_deg,
        m.frequency_rad_s,
        r.multiloop_disk_margin_unscaled.alpha,
        if r.stable { "stable" } else { "NOT STABLE: a margin is negative" }
    );
    s
}
