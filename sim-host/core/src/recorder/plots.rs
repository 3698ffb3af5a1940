//! PNG figures of recorded time series, in the style of a GNC paper.
//!
//! A [`Figure`] is a stack of [`Panel`]s sharing one x axis (normally column `"t_s"`). Each panel
//! draws one or more [`Series`] (a column of the [`TimeSeries`] plus a legend label; `dashed` for
//! targets / commands) and can use a logarithmic y axis (`log_y`, e.g. for attitude error).
//! [`render`] writes one PNG per figure (1200 px wide, ~300 px per panel) and returns the paths.
//!
//! Robustness rules: a series whose column is missing is skipped, a panel left without series is
//! skipped, a figure left without panels (or whose x column is missing) is skipped; none of that
//! is an error. Non-finite samples (and, on log axes, samples <= 0) break the line. y ranges come
//! from the data with a 5 % margin (a constant series gets +-10 % of its value, or +-1 if zero);
//! log axes start at half the smallest positive value. The x axis spans the data exactly.
//!
//! Pure Rust, no system fonts or C libraries: `plotters` (bitmap backend + `ab_glyph` text) draws
//! into an RGB buffer and the `png` crate encodes it. The text font is DejaVu Sans 2.37, embedded
//! from `sim-host/core/assets/DejaVuSans.ttf` (Bitstream Vera license with DejaVu changes in the public domain:
//! free to use, embed and redistribute; see `sim-host/core/assets/DejaVuSans-LICENSE.txt`; copied from the
//! `dejavu` 2.37.0 crate on crates.io).

use plotters::coord::ranged1d::{BoldPoints, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::element::{DashedPathElement, IntoDynElement};
use plotters::prelude::{
    BitMapBackend, Cartesian2d, ChartBuilder, ChartContext, Color, DrawingBackend, FontStyle, IntoDrawingArea,
    IntoFont, IntoLogRange, PathElement, RGBColor, Ranged, SeriesLabelPosition, TextStyle, WHITE,
};
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::io;
use std::path::{Path, PathBuf};

pub use crate::recorder::series::TimeSeries;

/// One line on a panel: column name and legend label; `dashed` for targets/commands.
pub struct Series {
    pub column: String,
    pub label: String,
    pub dashed: bool,
}
/// One panel (sub-plot) with a y-axis label; `log_y` for quantities like attitude error.
pub struct Panel {
    pub title: String,
    pub y_label: String,
    pub series: Vec<Series>,
    pub log_y: bool,
}
/// A figure: panels stacked vertically sharing the x axis (column `x`, usually "t_s", label "time [s]").
pub struct Figure {
    pub file_name: String,
    pub title: String,
    pub x: String,
    pub x_label: String,
    pub panels: Vec<Panel>,
}

const WIDTH: u32 = 1200;
const TITLE_H: u32 = 50;
const PANEL_H: u32 = 300;
/// Extra height of the bottom panel for the x-axis label.
const XLABEL_H: u32 = 30;
/// Maximum number of tick labels on the x / y axes.
const X_TICKS: usize = 12;
const Y_TICKS: usize = 8;
const FONT: &str = "sans-serif";
/// Okabe–Ito colour-blind-safe palette (yellow dropped: invisible on white), indexed by the
/// series' position in its panel.
const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
    RGBColor(0, 0, 0),       // black
];

/// A series resolved against the store: (palette index, series, y column).
type Line<'a> = (usize, &'a Series, &'a [f64]);

/// Registers the embedded font with plotters once per process.
fn ensure_font() -> io::Result<()> {
    static DONE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    static TTF: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
    let ok = *DONE.get_or_init(|| {
        ["sans-serif", "serif", "monospace"]
            .iter()
            .all(|f| plotters::style::register_font(f, FontStyle::Normal, TTF).is_ok())
    });
    ok.then_some(()).ok_or_else(|| io::Error::other("plots: embedded font failed to load"))
}

fn err<E: std::fmt::Display>(e: E) -> io::Error {
    io::Error::other(format!("plots: {e}"))
}

/// Render each figure to `dir/file_name` (PNG, ~1200 px wide, ~300 px per panel). Series whose
/// column is missing are skipped (not an error); a panel with no series left is skipped; a
/// figure with no panels is skipped. Non-finite values are skipped (line broken). Returns the
/// paths written.
pub fn render(dir: &Path, ts: &TimeSeries, figures: &[Figure]) -> io::Result<Vec<PathBuf>> {
    ensure_font()?;
    let mut written = Vec::new();
    for fig in figures {
        let Some(x) = ts.col(&fig.x) else { continue };
        // Resolve columns up front: (colour index, series, data).
        let panels: Vec<(&Panel, Vec<Line>)> = fig
            .panels
            .iter()
            .map(|p| {
                let s = p.series.iter().enumerate();
                (p, s.filter_map(|(i, s)| Some((i, s, ts.col(&s.column)?))).collect::<Vec<_>>())
            })
            .filter(|(_, s)| !s.is_empty())
            .collect();
        if panels.is_empty() {
            continue;
        }
        let n = panels.len() as u32;
        let (w, h) = (WIDTH, TITLE_H + n * PANEL_H + XLABEL_H);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            let (top, mut area) = root.split_vertically(TITLE_H);
            let centre = Pos::new(HPos::Center, VPos::Center);
            let title_style = TextStyle::from((FONT, 28).into_font()).pos(centre);
            top.draw_text(&fig.title, &title_style, ((w / 2) as i32, (TITLE_H / 2) as i32)).map_err(err)?;
            let x_range = finite_range(x.iter().copied()).unwrap_or((0.0, 1.0));
            let x_range = if x_range.1 > x_range.0 { x_range } else { pad(x_range, 0.0) };
            for (k, (panel, series)) in panels.iter().enumerate() {
                let last = k + 1 == panels.len();
                let (cell, rest) = area.split_vertically(PANEL_H + if last { XLABEL_H } else { 0 });
                area = rest;
                let mut cb = ChartBuilder::on(&cell);
                cb.margin(8)
                    .margin_right(30)
                    .caption(&panel.title, (FONT, 20))
                    .x_label_area_size(if last { 62 } else { 32 })
                    .y_label_area_size(95);
                let x_rng = x_range.0..x_range.1;
                let x_desc = last.then_some(fig.x_label.as_str());
                let ys = series.iter().flat_map(|(_, _, c)| c.iter().copied());
                if panel.log_y {
                    let (lo, hi) = finite_range(ys.filter(|v| *v > 0.0)).unwrap_or((0.1, 10.0));
                    let lo = lo / 2.0;
                    let hi = hi * (hi / lo).powf(0.05).max(1.2);
                    let chart = cb.build_cartesian_2d(x_rng, (lo..hi).log_scale()).map_err(err)?;
                    draw_panel(chart, x_desc, x_range, panel, x, series, &log_tick)?;
                } else {
                    let (lo, hi) = pad(finite_range(ys).unwrap_or((-1.0, 1.0)), 0.05);
                    let chart = cb.build_cartesian_2d(x_rng, lo..hi).map_err(err)?;
                    let y_fmt = tick_formatter(lo, hi, Y_TICKS);
                    draw_panel(chart, x_desc, x_range, panel, x, series, &y_fmt)?;
                }
            }
            root.present().map_err(err)?;
        }
        let path = dir.join(&fig.file_name);
        write_png(&path, w, h, &buf)?;
        written.push(path);
    }
    Ok(written)
}

/// Draws mesh, lines and legend of one panel (generic over linear / log y coordinates).
fn draw_panel<'a, DB, Y>(
    mut chart: ChartContext<'a, DB, Cartesian2d<RangedCoordf64, Y>>,
    x_desc: Option<&str>,
    (x_lo, x_hi): (f64, f64),
    panel: &Panel,
    x: &[f64],
    series: &[Line],
    y_fmt: &dyn Fn(&f64) -> String,
) -> io::Result<()>
where
    DB: DrawingBackend + 'a,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let x_fmt = tick_formatter(x_lo, x_hi, X_TICKS);
    let mut mesh = chart.configure_mesh();
    mesh.y_desc(&panel.y_label)
        .x_labels(X_TICKS)
        .y_labels(Y_TICKS)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(y_fmt)
        .x_max_light_lines(1)
        .y_max_light_lines(1)
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 19))
        .bold_line_style(RGBColor(200, 200, 200))
        .light_line_style(RGBColor(238, 238, 238));
    if let Some(d) = x_desc {
        mesh.x_desc(d);
    }
    mesh.draw().map_err(err)?;
    for &(i, s, y) in series {
        let c = PALETTE[i % PALETTE.len()];
        let style = c.stroke_width(2);
        // Split into runs of valid points so NaN/Inf (or <= 0 on a log axis) break the line.
        let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
        for (&xv, &yv) in x.iter().zip(y) {
            if xv.is_finite() && yv.is_finite() && (!panel.log_y || yv > 0.0) {
                runs.last_mut().unwrap().push((xv, yv));
            } else if !runs.last().unwrap().is_empty() {
                runs.push(Vec::new());
            }
        }
        runs.retain(|r| !r.is_empty());
        let anno = if s.dashed {
            let el = runs.into_iter().map(|r| DashedPathElement::new(r, 8, 5, style));
            chart.draw_series(el).map_err(err)?
        } else {
            chart.draw_series(runs.into_iter().map(|r| PathElement::new(r, style))).map_err(err)?
        };
        let dashed = s.dashed;
        anno.label(&s.label).legend(move |(lx, ly)| {
            let pts = vec![(lx, ly), (lx + 24, ly)];
            if dashed {
                DashedPathElement::new(pts, 7, 4, style).into_dyn()
            } else {
                PathElement::new(pts, style).into_dyn()
            }
        });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .margin(8)
        .legend_area_size(30)
        .label_font((FONT, 16))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(120, 120, 120))
        .draw()
        .map_err(err)
}

/// Tick labels for a linear axis over `lo..hi` with at most `n` ticks: one format for the whole
/// axis (fixed point, or scientific outside 1e-3..1e5) with the fewest decimals that represent
/// every tick plotters will place; values within 1e-9 of the span of zero print as "0".
fn tick_formatter(lo: f64, hi: f64, n: usize) -> impl Fn(&f64) -> String {
    let ticks = RangedCoordf64::from(lo..hi).key_points(BoldPoints(n));
    let step = ticks.windows(2).map(|w| w[1] - w[0]).fold(hi - lo, f64::min);
    let mag = lo.abs().max(hi.abs());
    let sci = !(1e-3..1e5).contains(&mag);
    let scale = if sci { 10f64.powf(mag.log10().floor()) } else { 1.0 };
    let exact = |d: i32, v: &f64| {
        let (m, p) = (v / scale, 10f64.powi(d));
        ((m * p).round() / p - m).abs() <= 1e-6 * step / scale
    };
    let dec = (0..8).find(|&d| ticks.iter().all(|v| exact(d, v))).unwrap_or(8) as usize;
    move |v: &f64| match () {
        _ if v.abs() <= 1e-9 * (hi - lo) => "0".into(),
        _ if sci => format!("{v:.dec$e}"),
        _ => format!("{v:.dec$}"),
    }
}

/// Tick label for log axes: powers of ten as 10⁻³ etc., anything else as 2e-3.
fn log_tick(v: &f64) -> String {
    let e = v.log10().round();
    if ((v / 10f64.powf(e)) - 1.0).abs() > 1e-6 {
        return format!("{v:.0e}");
    }
    let sup = |c| match c {
        '-' => '⁻',
        d => ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'][d as usize - '0' as usize],
    };
    format!("10{}", (e as i32).to_string().chars().map(sup).collect::<String>())
}

/// (min, max) of the finite values, if any.
fn finite_range(it: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    it.filter(|v| v.is_finite()).fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

/// Widens `(lo, hi)` by `frac` of its span; a (near-)constant range gets +-10 % (or +-1 at 0).
fn pad((lo, hi): (f64, f64), frac: f64) -> (f64, f64) {
    let span = hi - lo;
    if span > 1e-12 * lo.abs().max(hi.abs()) && span > f64::MIN_POSITIVE {
        (lo - frac * span, hi + frac * span)
    } else {
        let d = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
        (lo - d, hi + d)
    }
}

/// Encodes the image and writes it through a temporary file and a rename (a failed write
/// leaves no truncated PNG); an error names the file.
fn write_png(path: &Path, w: u32, h: u32, rgb: &[u8]) -> io::Result<()> {
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::Fast);
    let mut wr = enc.write_header().map_err(err)?;
    wr.write_image_data(rgb).map_err(err)?;
    wr.finish().map_err(err)?;
    crate::files::write_atomic(path, &bytes).map_err(|e| io::Error::other(format!("{e:#}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_and_ticks() {
        assert_eq!(pad((0.0, 10.0), 0.05), (-0.5, 10.5));
        assert_eq!(pad((0.0, 0.0), 0.05), (-1.0, 1.0));
        let (lo, hi) = pad((-2.0, -2.0), 0.05);
        assert!((lo + 2.2).abs() < 1e-12 && (hi + 1.8).abs() < 1e-12);
        assert_eq!(finite_range([f64::NAN, 3.0, f64::INFINITY, -1.0].into_iter()), Some((-1.0, 3.0)));
        assert_eq!(finite_range([f64::NAN].into_iter()), None);
        assert_eq!(
            (log_tick(&1e-3), log_tick(&1.0), log_tick(&100.0), log_tick(&2e-3)),
            ("10⁻³".into(), "10⁰".into(), "10²".into(), "2e-3".into())
        );
        let f = tick_formatter(-0.7, 1.05, Y_TICKS);
        assert_eq!((f(&0.5), f(&-5.551115123125783e-17), f(&1.0)), ("0.5".into(), "0".into(), "1.0".into()));
        let f = tick_formatter(-1.6e6, 1.6e6, Y_TICKS);
        assert_eq!((f(&5e5), f(&1.5e6)), ("5.0e5".into(), "1.5e6".into()));
        let f = tick_formatter(0.0, 299.9, X_TICKS);
        assert_eq!(f(&250.0), "250");
    }
}
