//! The figures of a margin measurement, drawn with the recorder's plotting helpers
//! (`sim_core::recorder::plots`): `bode.png` (loop-at-a-time `|l_i|` and phase against
//! ω on a log axis labelled in decades of rad/s, the crossover and phase-crossing
//! frequencies marked in different styles, the margins in the
//! panel titles), `nyquist.png` (each `l_i` near the critical point, one scale on both
//! axes, the unit circle and the critical point −1 marked) and `disk.png` (`|s_i − 1/2|`
//! per axis and the multiloop μ bound of `S − I/2`, whose peaks are the reciprocal disk
//! margins; the multiloop peak marked). Lines that lie on one another within a pixel are
//! drawn solid, dashed, dotted in turn and the panel's title says which coincide.
//! [`figures`] / [`plans`] describe the figures (tests check the plans), [`write`] draws.

use super::analysis::{self, C64, Cmat};
use super::report::{AxisReport, MarginReport};
use sim_core::recorder::plots::{self, Figure, FigureContext, FigurePlan, Panel, Series, TimeSeries, render};
use std::path::{Path, PathBuf};

/// The measured axes' names (x, y, z; magnetorquers: the two perpendicular to the field).
fn axis_names(r: &MarginReport) -> Vec<&'static str> {
    r.axes.iter().map(|a| a.axis).collect()
}

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
    let axes = axis_names(r);
    let mut names = vec!["log10_w".to_string()];
    for a in &axes {
        names.extend([format!("mag_{a}"), format!("phase_{a}")]);
    }
    let mut ts = TimeSeries::with_columns(names, r.frequencies_rad_s.len());
    let l: Vec<Vec<C64>> = (0..axes.len()).map(|i| axis_loop(s, i)).collect();
    let ph: Vec<Vec<f64>> = l.iter().map(|li| unwrap_deg(li)).collect();
    for (k, w) in r.frequencies_rad_s.iter().enumerate() {
        let mut row = vec![w.log10()];
        for i in 0..axes.len() {
            row.extend([20.0 * l[i][k].norm().log10(), ph[i][k]]);
        }
        ts.push_row(&row);
    }
    let mag: Vec<Series> = axes.iter().map(|a| series(&format!("mag_{a}"), &format!("|l_{a}|"), false)).collect();
    let phase: Vec<Series> = axes.iter().map(|a| series(&format!("phase_{a}"), &format!("arg l_{a}"), false)).collect();
    // The crossovers and phase crossings that set the margins, marked on both panels; axes
    // with the same figures share one line.
    let crossover = |a: &AxisReport| a.crossover_rad_s.zip(a.phase_margin_deg);
    let phase_crossing = |a: &AxisReport| {
        let gm = a.gain_margin_high_db.or(a.gain_margin_low_db)?;
        a.gain_crossings.iter().find(|c| c.gain_margin_db == gm).map(|c| (c.frequency_rad_s, gm))
    };
    let wc = by_value(&r.axes, crossover);
    let w180 = by_value(&r.axes, phase_crossing);
    let mut x_lines: Vec<(f64, String)> =
        wc.iter().map(|((w, _), ax)| (w.log10(), format!("ω_c {} rad/s ({ax})", short(*w)))).collect();
    x_lines.extend(w180.iter().map(|((w, _), ax)| (w.log10(), format!("ω_180 {} rad/s ({ax})", short(*w)))));
    let pm: Vec<String> = wc.iter().map(|((_, pm), ax)| format!("PM {pm:.1}° at ω_c, {ax}")).collect();
    let gm: Vec<String> = w180.iter().map(|((_, gm), ax)| format!("GM {gm:.1} dB at ω_180, {ax}")).collect();
    let or_none = |v: Vec<String>, none: &str| if v.is_empty() { none.to_string() } else { v.join("; ") };
    let fig = Figure {
        file_name: "bode.png".into(),
        title: format!(
            "{}: loop-at-a-time loops at the {}, t = {} s{}",
            r.scenario,
            loop_name(r),
            r.at_s,
            if r.loop_axes_body.is_some() { " (perp1, perp2: ⊥ the frozen field)" } else { "" }
        ),
        x: "log10_w".into(),
        x_label: "frequency [rad/s], log scale".into(),
        x_log10: true,
        panels: vec![
            Panel {
                title: format!("magnitude: {}", or_none(gm, "no phase crossing, gain margin infinite")),
                y_label: "|l| [dB]".into(),
                series: mag,
                thresholds: vec![(0.0, "dB".into())],
                ..Default::default()
            },
            Panel {
                title: format!("phase: {}", or_none(pm, "no gain crossover")),
                y_label: "phase [deg]".into(),
                series: phase,
                thresholds: vec![(-180.0, "deg".into())],
                ..Default::default()
            },
        ],
        x_lines,
        ..Default::default()
    };
    (ts, fig)
}

/// `l_i(ω_k)` along the grid (NaN where the response is missing).
fn axis_loop(s: &[Option<Cmat>], i: usize) -> Vec<C64> {
    s.iter().map(|m| m.map_or(C64::new(f64::NAN, f64::NAN), |m| analysis::loop_at_a_time(&m, i))).collect()
}

/// The distinct values of `f` over the axes, each with the axes that have it ("x, z", or
/// "all axes"): (frequency, margin) pairs equal to 3 significant digits (a pixel on the
/// plot's log axis) and 0.1 (deg or dB) are one.
fn by_value(axes: &[AxisReport], f: impl Fn(&AxisReport) -> Option<(f64, f64)>) -> Vec<((f64, f64), String)> {
    let mut out: Vec<((f64, f64), Vec<&str>)> = Vec::new();
    for a in axes {
        let Some(v) = f(a) else { continue };
        let same = |u: &(f64, f64)| short(u.0) == short(v.0) && format!("{:.1}", u.1) == format!("{:.1}", v.1);
        match out.iter_mut().find(|o| same(&o.0)) {
            Some(o) => o.1.push(a.axis),
            None => out.push((v, vec![a.axis])),
        }
    }
    let all = |ax: &[&str]| ax.len() == axes.len() && axes.len() > 1;
    out.into_iter().map(|(v, ax)| (v, if all(&ax) { "all axes".into() } else { ax.join(", ") })).collect()
}

/// 3 significant digits.
fn short(v: f64) -> String {
    format!("{}", format!("{v:.2e}").parse::<f64>().unwrap_or(v))
}

fn loop_name(r: &MarginReport) -> &'static str {
    match r.loop_point {
        super::LoopPoint::Input => "actuator input",
        super::LoopPoint::Output => "attitude measurement",
    }
}

/// The Nyquist plot, clipped to `|l| ≤ 4` around the critical point: rows of each axis's
/// curve in turn (NaN in the other columns), then the unit circle. Drawn to one scale on
/// both axes (`equal_scale`), with the critical point −1 marked.
fn nyquist(r: &MarginReport, s: &[Option<Cmat>]) -> (TimeSeries, Figure) {
    let axes = axis_names(r);
    let n = axes.len();
    let names: Vec<String> =
        ["re".into()].into_iter().chain(axes.iter().map(|a| format!("im_{a}"))).chain(["circle".into()]).collect();
    let mut ts = TimeSeries::with_columns(names, (n + 1) * r.frequencies_rad_s.len() + 200);
    let nan = f64::NAN;
    for i in 0..n {
        for z in nyquist_points(s, i) {
            let mut row = vec![nan; n + 2];
            (row[0], row[1 + i]) = (z.re, z.im);
            ts.push_row(&row);
        }
        ts.push_row(&vec![nan; n + 2]);
    }
    for k in 0..=180 {
        let a = k as f64 * std::f64::consts::TAU / 180.0;
        let mut row = vec![nan; n + 2];
        (row[0], row[n + 1]) = (a.cos(), a.sin());
        ts.push_row(&row);
    }
    let mut lines: Vec<Series> = axes.iter().map(|a| series(&format!("im_{a}"), &format!("l_{a}"), false)).collect();
    lines.push(series("circle", "unit circle", true));
    let fig = Figure {
        file_name: "nyquist.png".into(),
        title: format!("{}: Nyquist plot of l_i (|l| ≤ 4)", r.scenario),
        x: "re".into(),
        x_label: "Re l".into(),
        panels: vec![Panel {
            title: "loop-at-a-time".into(),
            y_label: "Im l".into(),
            series: lines,
            points: vec![(-1.0, 0.0, "critical point −1".into())],
            ..Default::default()
        }],
        equal_scale: true,
        ..Default::default()
    };
    (ts, fig)
}

/// The points of `l_i` drawn on the Nyquist plot (NaN outside `|l| ≤ 4`).
fn nyquist_points(s: &[Option<Cmat>], i: usize) -> Vec<C64> {
    let nan = C64::new(f64::NAN, f64::NAN);
    axis_loop(s, i).into_iter().map(|z| if z.norm() <= 4.0 { z } else { nan }).collect()
}

fn disk(r: &MarginReport, s: &[Option<Cmat>]) -> (TimeSeries, Figure) {
    let axes = axis_names(r);
    let names: Vec<String> = ["log10_w".into()]
        .into_iter()
        .chain(axes.iter().map(|a| format!("disk_{a}")))
        .chain(["mu".into(), "unscaled".into()])
        .collect();
    let mut ts = TimeSeries::with_columns(names, r.frequencies_rad_s.len());
    for (w, m) in r.frequencies_rad_s.iter().zip(s) {
        let mut row = vec![w.log10()];
        match m {
            Some(m) => {
                row.extend((0..axes.len()).map(|i| (m[i][i] - 0.5).norm()));
                let d = analysis::disk_matrix(m);
                row.extend([analysis::mu_upper_bound(&d).0, analysis::max_singular_value(&d)]);
            }
            None => row.extend(vec![f64::NAN; axes.len() + 2]),
        }
        ts.push_row(&row);
    }
    let mut lines: Vec<Series> =
        axes.iter().map(|a| series(&format!("disk_{a}"), &format!("|s_{a} − 1/2| (axis {a})"), false)).collect();
    lines.push(series("mu", "μ bound of S − I/2", false));
    lines.push(series("unscaled", "σ_max(S − I/2)", true));
    let m = &r.multiloop_disk_margin;
    let gm = m.gain_margin_db.map_or("inf".into(), |g| format!("{g:.2}"));
    let fig = Figure {
        file_name: "disk.png".into(),
        title: format!("{}: disk margins = 1 / peak (multiloop α {:.3})", r.scenario, m.alpha),
        x: "log10_w".into(),
        x_label: "frequency [rad/s], log scale".into(),
        x_log10: true,
        panels: vec![Panel {
            title: format!("balanced (σ = 0): multiloop ±{gm} dB, ±{:.1}°", m.phase_margin_deg),
            y_label: "1 / α(ω)".into(),
            series: lines,
            thresholds: vec![(1.0 / m.alpha, "multiloop peak".into())],
            ..Default::default()
        }],
        x_lines: vec![(m.frequency_rad_s.log10(), format!("peak at {} rad/s", short(m.frequency_rad_s)))],
        ..Default::default()
    };
    (ts, fig)
}

/// Pixels per unit on x and on y of panel `k` of a linear-axis plan.
pub fn pixels_per_unit(p: &FigurePlan, k: usize) -> (f64, f64) {
    let a = p.plot_area;
    let y = p.panels[k].y_range;
    ((a.x1 - a.x0) as f64 / (p.x_range.1 - p.x_range.0), (a.y1 - a.y0) as f64 / (y.1 - y.0))
}

/// For each of `n` lines, the first earlier line it lies on (`distance_px(i, j) < 1`).
fn coincident(n: usize, distance_px: impl Fn(usize, usize) -> f64) -> Vec<Option<usize>> {
    (0..n).map(|i| (0..i).find(|&j| distance_px(i, j) < 1.0)).collect()
}

/// Largest pixel distance between lines `i` and `j` of panel `k` (same x samples);
/// infinite when they have no finite sample in common.
fn line_distance_px(p: &FigurePlan, k: usize, i: usize, j: usize) -> f64 {
    let panel = &p.panels[k];
    let a = p.plot_area;
    let scale = |v: f64| if panel.log_y { v.log10() } else { v };
    let span = scale(panel.y_range.1) - scale(panel.y_range.0);
    let per_unit = (a.y1 - a.y0) as f64 / span;
    let (yi, yj) = (&panel.lines[i].y, &panel.lines[j].y);
    let d = yi.iter().zip(yj).filter(|(u, v)| u.is_finite() && v.is_finite());
    d.map(|(u, v)| (scale(*u) - scale(*v)).abs() * per_unit)
        .fold(None, |m: Option<f64>, e| Some(m.map_or(e, |m| m.max(e))))
        .unwrap_or(f64::INFINITY)
}

/// "(x, y, z coincide within a pixel)" for lines drawn on one another (names by line), or
/// `None`.
fn coincidence_note(on: &[Option<usize>], names: &[&str]) -> Option<String> {
    let groups: Vec<String> = (0..on.len())
        .filter(|&j| on[j].is_none())
        .filter_map(|j| {
            let members: Vec<&str> = (0..on.len()).filter(|&i| i == j || on[i] == Some(j)).map(|i| names[i]).collect();
            (members.len() > 1).then(|| members.join(", "))
        })
        .collect();
    (!groups.is_empty()).then(|| format!("({} coincide within a pixel)", groups.join("; ")))
}

/// Marks the lines that lie on one another (within a pixel of the plan): their panel
/// draws them in turn solid, dashed, dotted, long-dashed and its title says which coincide.
fn mark_coincident(fig: &mut Figure, ts: &TimeSeries, ctx: &FigureContext, names: &[&str]) {
    let Some(p) = plots::plan(ts, fig, ctx) else { return };
    for (k, panel) in fig.panels.iter_mut().enumerate() {
        let n = p.panels[k].lines.len().min(names.len());
        let on = coincident(n, |i, j| line_distance_px(&p, k, i, j));
        if let Some(note) = coincidence_note(&on, names) {
            panel.title = format!("{} {note}", panel.title);
            panel.cycle_dashes = true;
        }
    }
}

/// Marks the Nyquist curves that lie on one another within a pixel (as
/// [`mark_coincident`], from the complex values).
fn mark_coincident_nyquist(
    fig: &mut Figure,
    ts: &TimeSeries,
    ctx: &FigureContext,
    r: &MarginReport,
    s: &[Option<Cmat>],
) {
    let Some(p) = plots::plan(ts, fig, ctx) else { return };
    let (per_unit, _) = pixels_per_unit(&p, 0);
    let names: Vec<String> = axis_names(r).iter().map(|a| format!("l_{a}")).collect();
    let z: Vec<Vec<C64>> = (0..names.len()).map(|i| nyquist_points(s, i)).collect();
    let distance = |i: usize, j: usize| {
        let d = z[i].iter().zip(&z[j]).filter(|(u, v)| u.is_finite() && v.is_finite()).map(|(u, v)| (u - v).norm());
        d.fold(None, |m: Option<f64>, e| Some(m.map_or(e, |m| m.max(e)))).map_or(f64::INFINITY, |d| d * per_unit)
    };
    let on = coincident(names.len(), distance);
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    if let (Some(note), Some(panel)) = (coincidence_note(&on, &names), fig.panels.first_mut()) {
        panel.title = format!("{} {note}", panel.title);
        panel.cycle_dashes = true;
    }
}

/// The three figures (data and description), coinciding lines marked.
pub fn figures(r: &MarginReport) -> Vec<(TimeSeries, Figure)> {
    let s = loops(r);
    let ctx = context(r);
    let (bts, mut bfig) = bode(r, &s);
    let axes = axis_names(r);
    mark_coincident(&mut bfig, &bts, &ctx, &axes);
    let (nts, mut nfig) = nyquist(r, &s);
    mark_coincident_nyquist(&mut nfig, &nts, &ctx, r, &s);
    let (dts, mut dfig) = disk(r, &s);
    let disk_names: Vec<&str> = axes.iter().copied().chain(["μ bound", "σ_max"]).collect();
    mark_coincident(&mut dfig, &dts, &ctx, &disk_names);
    vec![(bts, bfig), (nts, nfig), (dts, dfig)]
}

fn context(r: &MarginReport) -> FigureContext {
    FigureContext { scenario: r.scenario.clone() }
}

/// The plans of the figures as they will be drawn (what tests check).
pub fn plans(r: &MarginReport) -> Vec<FigurePlan> {
    let ctx = context(r);
    figures(r).iter().filter_map(|(ts, fig)| plots::plan(ts, fig, &ctx)).collect()
}

/// Writes `bode.png`, `nyquist.png` and `disk.png` into `dir`; returns the paths.
pub fn write(dir: &Path, r: &MarginReport) -> std::io::Result<Vec<PathBuf>> {
    let ctx = context(r);
    let mut out = Vec::new();
    for (ts, fig) in figures(r) {
        out.extend(render(dir, &ts, &[fig], &ctx)?);
    }
    Ok(out)
}
