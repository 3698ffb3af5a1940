//! The figures of a margin measurement, drawn with the recorder's plotting helpers
//! (`sim_core::recorder::plots`): `bode.png` (loop-at-a-time `|l_i|` and phase against
//! `log10 ω`), `nyquist.png` (each `l_i` near the critical point, with the unit circle)
//! and `disk.png` (`|s_i − 1/2|` per axis and the multiloop μ bound of `S − I/2`, whose
//! peaks are the reciprocal disk margins).

use super::analysis::{self, C64, Cmat};
use super::report::MarginReport;
use sim_core::recorder::plots::{Figure, FigureContext, Panel, Series, TimeSeries, render};
use std::path::{Path, PathBuf};

const AXES: [&str; 3] = ["x", "y", "z"];

fn series(column: &str, label: &str, dashed: bool) -> Series {
    Series { column: column.into(), label: label.into(), dashed }
}

fn loops(r: &MarginReport) -> Vec<Option<Cmat>> {
    r.response
        .iter()
        .map(|l| {
            let l: Cmat = l.map(|row| row.map(|[re, im]| C64::new(re, im)));
            analysis::sensitivity(&l)
        })
        .collect()
}

/// Unwrapped phase in degrees (continuous along the frequencies).
fn unwrap_deg(z: &[C64]) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::with_capacity(z.len());
    for p in z.iter().map(|z| z.arg().to_degrees()) {
        let v = match out.last() {
            Some(prev) => p + 360.0 * ((prev - p) / 360.0).round(),
            None => p,
        };
        out.push(v);
    }
    out
}

fn bode(r: &MarginReport, s: &[Option<Cmat>]) -> (TimeSeries, Figure) {
    let mut names = vec!["log10_w".to_string()];
    for a in AXES {
        names.extend([format!("mag_{a}"), format!("phase_{a}")]);
    }
    names.extend(["zero_db".into(), "minus_180".into()]);
    let mut ts = TimeSeries::with_columns(names, r.frequencies_rad_s.len());
    let l: Vec<Vec<C64>> = (0..3)
        .map(|i| {
            s.iter().map(|m| m.map_or(C64::new(f64::NAN, f64::NAN), |m| analysis::loop_at_a_time(&m, i))).collect()
        })
        .collect();
    let ph: Vec<Vec<f64>> = l.iter().map(|li| unwrap_deg(li)).collect();
    for (k, w) in r.frequencies_rad_s.iter().enumerate() {
        let mut row = vec![w.log10()];
        for i in 0..3 {
            row.extend([20.0 * l[i][k].norm().log10(), ph[i][k]]);
        }
        row.extend([0.0, -180.0]);
        ts.push_row(&row);
    }
    let mut mag: Vec<Series> = AXES.iter().map(|a| series(&format!("mag_{a}"), &format!("|l_{a}|"), false)).collect();
    mag.push(series("zero_db", "0 dB", true));
    let mut phase: Vec<Series> =
        AXES.iter().map(|a| series(&format!("phase_{a}"), &format!("arg l_{a}"), false)).collect();
    phase.push(series("minus_180", "-180 deg", true));
    let fig = Figure {
        file_name: "bode.png".into(),
        title: format!("{}: loop-at-a-time loops at the {}, t = {} s", r.scenario, loop_name(r), r.at_s),
        x: "log10_w".into(),
        x_label: "log10 frequency [rad/s]".into(),
        panels: vec![
            Panel {
                title: "magnitude".into(),
                y_label: "|l| [dB]".into(),
                series: mag,
                log_y: false,
                ..Default::default()
            },
            Panel {
                title: "phase".into(),
                y_label: "phase [deg]".into(),
                series: phase,
                log_y: false,
                ..Default::default()
            },
        ],
        ..Default::default()
    };
    (ts, fig)
}

fn loop_name(r: &MarginReport) -> &'static str {
    match r.loop_point {
        super::LoopPoint::Input => "actuator input",
        super::LoopPoint::Output => "attitude measurement",
    }
}

/// The Nyquist plot, clipped to `|l| ≤ 4` around the critical point: rows of each axis's
/// curve in turn (NaN in the other columns), then the unit circle.
fn nyquist(r: &MarginReport, s: &[Option<Cmat>]) -> (TimeSeries, Figure) {
    let names: Vec<String> =
        ["re".into()].into_iter().chain(AXES.iter().map(|a| format!("im_{a}"))).chain(["circle".into()]).collect();
    let mut ts = TimeSeries::with_columns(names, 4 * r.frequencies_rad_s.len() + 200);
    let nan = f64::NAN;
    for i in 0..3 {
        for m in s {
            let z = m.map_or(C64::new(nan, nan), |m| analysis::loop_at_a_time(&m, i));
            let z = if z.norm() <= 4.0 { z } else { C64::new(nan, nan) };
            let mut row = vec![z.re, nan, nan, nan, nan];
            row[1 + i] = z.im;
            ts.push_row(&row);
        }
        ts.push_row(&[nan; 5]);
    }
    for k in 0..=180 {
        let a = k as f64 * std::f64::consts::TAU / 180.0;
        ts.push_row(&[a.cos(), nan, nan, nan, a.sin()]);
    }
    let mut lines: Vec<Series> = AXES.iter().map(|a| series(&format!("im_{a}"), &format!("l_{a}"), false)).collect();
    lines.push(series("circle", "unit circle", true));
    let fig = Figure {
        file_name: "nyquist.png".into(),
        title: format!("{}: Nyquist plot of l_i (|l| <= 4), critical point -1", r.scenario),
        x: "re".into(),
        x_label: "Re l".into(),
        panels: vec![Panel {
            title: "loop-at-a-time".into(),
            y_label: "Im l".into(),
            series: lines,
            log_y: false,
            ..Default::default()
        }],
        ..Default::default()
    };
    (ts, fig)
}

fn disk(r: &MarginReport, s: &[Option<Cmat>]) -> (TimeSeries, Figure) {
    let names: Vec<String> = ["log10_w".into()]
        .into_iter()
        .chain(AXES.iter().map(|a| format!("disk_{a}")))
        .chain(["mu".into(), "unscaled".into()])
        .collect();
    let mut ts = TimeSeries::with_columns(names, r.frequencies_rad_s.len());
    for (w, m) in r.frequencies_rad_s.iter().zip(s) {
        let mut row = vec![w.log10()];
        match m {
            Some(m) => {
                row.extend((0..3).map(|i| (m[i][i] - 0.5).norm()));
                let d = analysis::disk_matrix(m);
                row.extend([analysis::mu_upper_bound(&d).0, analysis::max_singular_value(&d)]);
            }
            None => row.extend([f64::NAN; 5]),
        }
        ts.push_row(&row);
    }
    let mut lines: Vec<Series> =
        AXES.iter().map(|a| series(&format!("disk_{a}"), &format!("|s_{a} - 1/2| (axis {a})"), false)).collect();
    lines.push(series("mu", "mu bound of S - I/2 (multiloop)", false));
    lines.push(series("unscaled", "max singular value of S - I/2", true));
    let fig = Figure {
        file_name: "disk.png".into(),
        title: format!(
            "{}: disk margins = 1 / peak (multiloop alpha {:.3})",
            r.scenario, r.multiloop_disk_margin.alpha
        ),
        x: "log10_w".into(),
        x_label: "log10 frequency [rad/s]".into(),
        panels: vec![Panel {
            title: "balanced (sigma = 0)".into(),
            y_label: "1 / alpha(w)".into(),
            series: lines,
            log_y: true,
            ..Default::default()
        }],
        ..Default::default()
    };
    (ts, fig)
}

/// Writes `bode.png`, `nyquist.png` and `disk.png` into `dir`; returns the paths.
pub fn write(dir: &Path, r: &MarginReport) -> std::io::Result<Vec<PathBuf>> {
    let s = loops(r);
    let mut out = Vec::new();
    for (ts, fig) in [bode(r, &s), nyquist(r, &s), disk(r, &s)] {
        out.extend(render(dir, &ts, &[fig], &FigureContext { scenario: r.scenario.clone() })?);
    }
    Ok(out)
}
