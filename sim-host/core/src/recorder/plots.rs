//! PNG figures of recorded time series, in the style of a GNC paper, drawn so that they
//! never mislead (the style rules are in `docs/outputs.md`, "Figures").
//!
//! A [`Figure`] is a stack of [`Panel`]s sharing one x axis (normally column `"t_s"`). Each panel
//! draws one or more [`Series`] (a column of the [`TimeSeries`] plus a legend label; `dashed` for
//! targets / commands) and can use a logarithmic y axis (`log_y`, e.g. for attitude error).
//! [`render`] writes one PNG per figure and returns the paths.
//!
//! Drawing goes in two steps: [`plan`] resolves a figure against the data into a
//! [`FigurePlan`] (which panels are drawn, each panel's y range, each line's colour and dash
//! pattern and legend label, the legend's place, the mode-transition markers, the title and
//! its font size), then the plan is drawn. Tests inspect the plan, not pixels. The rules the
//! plan follows:
//! - a y axis never spans less than its quantity's resolution floor ([`resolution_floor`],
//!   by the panel's unit); a series that is identically zero is labelled "≡ 0", one whose
//!   span is below the floor "≈ value (< floor)", so rounding noise is never drawn as signal;
//! - a panel of a model that is absent ([`Presence`]: all its series identically zero, or a
//!   column that tells the model is off) is left out; a figure whose `requires` column is
//!   missing is left out;
//! - within a panel no two lines share a (colour, dash) pair: the Okabe–Ito colours
//!   ([`PALETTE`]) in order, then the same colours dotted, then long-dashed ([`Dash`]);
//! - the legend sits right of the plot area, never on the data;
//! - every figure names its scenario and time window in a subtitle ([`FigureContext`]);
//! - with a `mode` column, every time plot gets a mode ribbon (mode names over time) and
//!   vertical lines at the transitions; with an `eclipse` column (1 in shadow), grey shading;
//! - step signals (modes, counters; [`Panel::step`]) are drawn as steps between recorded
//!   values, category panels ([`Panel::categories`]) with the category names on the y axis;
//! - `thresholds` are horizontal reference lines in the panel's unit, `Figure::x_lines`
//!   vertical ones (the x range is widened to include them); `Panel::points` are marked
//!   points (a ringed cross with a legend entry, e.g. a Nyquist plot's critical point);
//! - a figure with `equal_scale` (a Nyquist plot) has square plot areas and the same span
//!   on x and y, so one unit is as many pixels both ways and a circle is drawn round;
//! - a panel whose lines lie on one another (`Panel::cycle_dashes`, e.g. three identical
//!   axes) draws the first solid and the others dashed, dotted, long-dashed in turn, so
//!   every colour shows.
//!
//! Lines are drawn 2 px wide as two 1-px lines one pixel apart, not as plotters' polygonised
//! wide paths: a min/max envelope of a long run zigzags at sub-pixel spacing and the
//! polygon's mitre at such acute turns shoots far past the data (that was the "dip below
//! hold" of the mission's mode plot near 7,000 s, at a 4 → 3 transition).
//!
//! Robustness rules: a series whose column is missing is skipped, a panel left without series is
//! skipped, a figure left without panels (or whose x column is missing) is skipped; none of that
//! is an error. Non-finite samples (and, on log axes, samples <= 0) break the line.
//!
//! Pure Rust, no system fonts or C libraries: `plotters` (bitmap backend + `ab_glyph` text) draws
//! into an RGB buffer and the `png` crate encodes it. The text font is DejaVu Sans 2.37, embedded
//! from `sim-host/core/assets/DejaVuSans.ttf` (Bitstream Vera license with DejaVu changes in the public domain:
//! free to use, embed and redistribute; see `sim-host/core/assets/DejaVuSans-LICENSE.txt`; copied from the
//! `dejavu` 2.37.0 crate on crates.io).

use plotters::coord::Shift;
use plotters::coord::ranged1d::{BoldPoints, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::element::{DashedPathElement, Rectangle};
use plotters::prelude::{
    BitMapBackend, Cartesian2d, ChartBuilder, ChartContext, Color, DrawingArea, DrawingBackend, FontStyle,
    IntoDrawingArea, IntoFont, IntoLogRange, PathElement, RGBColor, Ranged, ShapeStyle, TextStyle,
};
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::io;
use std::path::{Path, PathBuf};

pub use crate::recorder::series::TimeSeries;

/// One line on a panel: column name and legend label; `dashed` for targets/commands.
#[derive(Clone, Debug, Default)]
pub struct Series {
    pub column: String,
    pub label: String,
    pub dashed: bool,
}

/// When a panel is drawn: a panel of a model that is off in the run is left out.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Presence {
    /// Whenever one of its columns exists.
    #[default]
    Always,
    /// Unless every series is identically zero (or NaN): the model is off.
    NonZero,
    /// When one of these columns exists and is not identically zero.
    NonZeroIn(Vec<String>),
    /// When these columns exist and are all identically zero (e.g. the mechanical power of
    /// ideal wheels, whose motor current is recorded as 0).
    ZeroIn(Vec<String>),
    /// Unless every series is NaN throughout (a quantity the run does not have, e.g. a
    /// site's elevation without a ground pointing).
    AnyFinite,
}

/// One panel (sub-plot) with a y-axis label (the unit: it selects the resolution floor,
/// [`resolution_floor`]); `log_y` for quantities like attitude error.
#[derive(Clone, Debug, Default)]
pub struct Panel {
    pub title: String,
    pub y_label: String,
    pub series: Vec<Series>,
    pub log_y: bool,
    /// A step signal (mode, counter): drawn as steps between the recorded values.
    pub step: bool,
    /// A category axis: (recorded value, name), bottom to top (drawn as steps).
    pub categories: Vec<(f64, String)>,
    /// Horizontal reference lines: (value in the panel's unit, label).
    pub thresholds: Vec<(f64, String)>,
    pub presence: Presence,
    /// Marked points: (x, y, legend label), drawn as a ringed cross; inside the ranges.
    pub points: Vec<(f64, f64, String)>,
    /// The lines lie on one another: the first is drawn solid, the others dashed, dotted,
    /// long-dashed in turn (whatever their `dashed`), so that every colour shows.
    pub cycle_dashes: bool,
    /// Columns drawn as a pale band under the other lines (a noisy error that the σ bound
    /// or a reference line drawn over it must not be hidden by).
    pub bands: Vec<String>,
    /// Factor from the columns' unit to the panel's `y_label` (e.g. rad/s → deg/s).
    pub y_scale: Option<f64>,
    /// (column, value, title): the title used instead when the column takes the value
    /// somewhere in the run (e.g. a mention of B-dot only when the run detumbled).
    pub title_when: Option<(String, f64, String)>,
}

/// A figure: panels stacked vertically sharing the x axis (column `x`, usually "t_s", label "time [s]").
#[derive(Clone, Debug, Default)]
pub struct Figure {
    pub file_name: String,
    pub title: String,
    pub x: String,
    pub x_label: String,
    pub panels: Vec<Panel>,
    /// The figure is drawn only when this column exists (e.g. `mode` for `modes.png`).
    pub requires: Option<String>,
    /// Vertical reference lines on every panel (e.g. a requirement's threshold): (x, label).
    pub x_lines: Vec<(f64, String)>,
    /// One unit is as many pixels on x as on y (a Nyquist plot): square plot areas and the
    /// same span on both axes, each centred on its data.
    pub equal_scale: bool,
    /// The x column holds log10 of the quantity (a frequency): ticks are labelled with the
    /// quantity at whole decades (0.1, 1, 10, 100), other ticks unlabelled.
    pub x_log10: bool,
    /// (column, subtitle note): spans where the column is 1 are shaded in a pale blue
    /// (e.g. a pointing blend); the note names the shading in the subtitle.
    pub shade: Option<(String, String)>,
}

/// What every figure of one render names: the scenario (or campaign, or experiment).
#[derive(Clone, Debug, Default)]
pub struct FigureContext {
    pub scenario: String,
}

impl FigureContext {
    pub fn new(scenario: &str) -> Self {
        Self { scenario: scenario.into() }
    }
}

/// Dash pattern of a line ([`PALETTE`] colours repeat only with another pattern).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Dash {
    Solid,
    Dashed,
    Dotted,
    LongDash,
}

/// A line as it will be drawn.
#[derive(Clone, Debug)]
pub struct LinePlan {
    pub column: String,
    /// Legend label, annotated "≡ 0", "≡ c" or "≈ c (span < floor)" when flat.
    pub label: String,
    pub colour: RGBColor,
    pub dash: Dash,
    /// The y values (category indices on a category axis; NaN outside a steady-state
    /// panel's window).
    pub y: Vec<f64>,
    /// Drawn as a pale band under the other lines ([`Panel::bands`]).
    pub band: bool,
}

/// A panel as it will be drawn.
#[derive(Clone, Debug)]
pub struct PanelPlan {
    pub title: String,
    pub title_size: u32,
    pub y_label: String,
    pub log_y: bool,
    pub step: bool,
    /// Category names, bottom to top (empty: a numeric axis).
    pub categories: Vec<String>,
    /// The y axis range.
    pub y_range: (f64, f64),
    /// The smallest span the y axis may have ([`resolution_floor`] of `y_label`).
    pub floor: f64,
    /// The y tick labels of a linear or category axis (empty for a log axis).
    pub y_ticks: Vec<String>,
    pub lines: Vec<LinePlan>,
    pub thresholds: Vec<(f64, String)>,
    pub points: Vec<(f64, f64, String)>,
    /// The x range drawn: the figure's, or a steady-state panel's window.
    pub x_range: (f64, f64),
    /// A steady-state panel: the panel above it rescaled to `t ≥ this` ([`STEADY_ZOOM`]).
    pub steady_from: Option<f64>,
    /// The legend's text, laid out (wrapped, sized, placed) as it is drawn.
    pub legend: Vec<LegendEntry>,
}

/// What marks a legend entry.
#[derive(Clone, Debug, PartialEq)]
pub enum LegendMark {
    Line { colour: RGBColor, dash: Dash, band: bool },
    Point,
    Threshold,
}

/// One legend entry: its text lines (wrapped to the legend column), font size, where the
/// text starts (x) and the centre of its first line (y), relative to the panel's legend
/// cell.
#[derive(Clone, Debug, PartialEq)]
pub struct LegendEntry {
    pub lines: Vec<String>,
    pub size: u32,
    pub x: i32,
    pub y: i32,
    pub mark: LegendMark,
}

impl LegendEntry {
    /// Height of one text line of this entry, px.
    pub fn line_height(&self) -> i32 {
        self.size as i32 + 4
    }
}

/// A pixel rectangle, `x0..x1` × `y0..y1` (relative to the panel's cell).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    pub x0: i32,
    pub y0: i32,
    pub x1: i32,
    pub y1: i32,
}

/// A figure as it will be drawn.
#[derive(Clone, Debug)]
pub struct FigurePlan {
    pub file_name: String,
    pub title: String,
    pub title_size: u32,
    /// Scenario name and time window.
    pub subtitle: String,
    pub subtitle_size: u32,
    pub x_label: String,
    pub x: Vec<f64>,
    pub x_range: (f64, f64),
    /// See [`Figure::x_log10`].
    pub x_log10: bool,
    pub panels: Vec<PanelPlan>,
    /// Mode spans (from, to, mode name) for the ribbon and the transition lines.
    pub modes: Vec<(f64, f64, String)>,
    /// Eclipse spans (from, to).
    pub eclipses: Vec<(f64, f64)>,
    /// Spans shaded by [`Figure::shade`] (from, to).
    pub shaded: Vec<(f64, f64)>,
    /// Start of the steady-state window of a time figure (the second half of the run),
    /// [`STEADY_ZOOM`]; `None` for other figures.
    pub steady_from: Option<f64>,
    pub x_lines: Vec<(f64, String)>,
    pub width: u32,
    pub height: u32,
    /// Height of each panel's cell (the last one has the x-axis label under it too).
    pub panel_height: u32,
    /// Where the data are drawn in each panel's cell, and where its legend goes.
    pub plot_area: Rect,
    pub legend_area: Rect,
}

impl FigurePlan {
    /// Height of panel `k`'s cell (the last one also holds the x-axis label).
    pub fn cell_height(&self, k: usize) -> u32 {
        self.panel_height + if k + 1 == self.panels.len() { XLABEL_H } else { 0 }
    }
}

/// Steady state: the second half of a time figure's run. A linear panel whose lines over
/// that window span less than `ZOOM_BELOW` of its axis (a start-up transient set the
/// scale) gets a second panel under it with that window alone, rescaled; a line whose
/// steady-state part still spans less than `VISIBLE_FRACTION` of its panel's axis is
/// labelled with its value there ("≈ c ± d").
pub const STEADY_ZOOM: SteadyZoom = SteadyZoom { from_fraction: 0.5, zoom_below: 0.2, visible_fraction: 0.03 };

/// The constants of [`STEADY_ZOOM`].
#[derive(Clone, Copy, Debug)]
pub struct SteadyZoom {
    pub from_fraction: f64,
    pub zoom_below: f64,
    pub visible_fraction: f64,
}

const WIDTH: u32 = 1200;
/// Width of the legend column right of every panel.
const LEGEND_W: u32 = 230;
const TITLE_H: u32 = 62;
/// Height of the mode ribbon under the title (runs with a `mode` column).
const RIBBON_H: u32 = 26;
const PANEL_H: u32 = 300;
/// Extra height of the bottom panel for the x-axis label.
const XLABEL_H: u32 = 30;
const MARGIN: u32 = 8;
const MARGIN_RIGHT: u32 = 14;
const Y_AREA: u32 = 110;
const X_AREA: u32 = 32;
const CAPTION_H: i32 = 30;
/// Maximum number of tick labels on the x / y axes.
const X_TICKS: usize = 12;
const Y_TICKS: usize = 8;
const FONT: &str = "sans-serif";
/// Okabe–Ito colour-blind-safe palette (yellow dropped: invisible on white), indexed by the
/// series' position in its panel; past 7 lines the colours repeat with another dash pattern
/// ([`line_style`]).
pub const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
    RGBColor(0, 0, 0),       // black
];
const GREY: RGBColor = RGBColor(110, 110, 110);
/// Mode names by telemetry code (1 … 5, `acs_flight::params::Mode::ALL`), and the order
/// they are drawn in, bottom to top (the nominal sequence, sun-safe between detumble and
/// the pointing modes).
pub const MODE_NAMES: [(f64, &str); 5] =
    [(1.0, "detumble"), (5.0, "sun-safe"), (2.0, "stabilise"), (3.0, "manoeuvre"), (4.0, "hold")];

/// The smallest y span drawn for a panel whose axis label is `unit`: below it, differences
/// are rounding noise, not signal (docs/outputs.md has the table). Unknown units: 1e-12.
pub fn resolution_floor(unit: &str) -> f64 {
    match unit {
        "deg" | "deg/s" => 1e-6,
        "rad" | "rad/s" => 1e-8,
        "deg/h" => 1e-4,
        "N m" | "N m s" => 1e-12,
        "A" | "V" | "W" | "s" | "m" | "A m²" => 1e-6,
        "rpm" => 1e-3,
        "T" => 1e-10,
        "kg" => 1e-9,
        "count" | "pulses" => 1.0,
        "(dimensionless)" => 1e-9,
        _ => 1e-12,
    }
}

/// (colour, dash) of the `i`-th line of a panel: unique within the panel for up to 14
/// solid and 14 dashed lines (the palette's 7 colours, then dotted / long-dashed).
pub fn line_style(i: usize, dashed: bool) -> (RGBColor, Dash) {
    let dash = match (i / PALETTE.len(), dashed) {
        (0, false) => Dash::Solid,
        (0, true) => Dash::Dashed,
        (_, false) => Dash::Dotted,
        (_, true) => Dash::LongDash,
    };
    (PALETTE[i % PALETTE.len()], dash)
}

/// Resolves `fig` against the data: `None` when it is not drawn (missing x or `requires`
/// column, no panel left).
pub fn plan(ts: &TimeSeries, fig: &Figure, ctx: &FigureContext) -> Option<FigurePlan> {
    if let Some(r) = &fig.requires {
        ts.col(r)?;
    }
    let x = ts.col(&fig.x)?;
    let mut panels: Vec<PanelPlan> = fig.panels.iter().filter_map(|p| plan_panel(ts, p)).collect();
    if panels.is_empty() {
        return None;
    }
    let data_range = finite_range(x.iter().copied()).unwrap_or((0.0, 1.0));
    let mut x_range = x_range_of(x, fig, &panels);
    let cell_w = (WIDTH - LEGEND_W) as i32;
    let plot_w = cell_w - (MARGIN + MARGIN_RIGHT + Y_AREA) as i32;
    // The caption's height as plotters lays it out (the first panel's; estimated 30 px
    // when the font is not there).
    let caption_h = panels.first().map_or(CAPTION_H, |p| caption_height(&p.title, p.title_size));
    let panel_h = if fig.equal_scale {
        x_range = equal_spans(x_range, &mut panels);
        plot_w as u32 + 2 * MARGIN + caption_h as u32 + X_AREA
    } else {
        PANEL_H
    };
    let time = fig.x == "t_s";
    let steady_from = (time && !fig.equal_scale && data_range.1 > data_range.0)
        .then_some(data_range.0 + STEADY_ZOOM.from_fraction * (data_range.1 - data_range.0));
    for p in panels.iter_mut() {
        p.x_range = x_range;
    }
    if let Some(from) = steady_from {
        panels = with_steady_panels(panels, x, from, data_range.1);
    }
    let modes = if time { mode_spans(ts, x, x_range) } else { Vec::new() };
    let eclipses = if time { eclipse_spans(ts, x, "eclipse") } else { Vec::new() };
    let shaded = match (&fig.shade, time) {
        (Some((column, _)), true) => eclipse_spans(ts, x, column),
        _ => Vec::new(),
    };
    let subtitle = if time {
        let shade = if eclipses.is_empty() { None } else { Some("grey: eclipse") };
        let note = fig.shade.as_ref().filter(|_| !shaded.is_empty()).map(|s| s.1.as_str());
        time_subtitle(&ctx.scenario, data_range, [shade, note])
    } else {
        ctx.scenario.clone()
    };
    let n = panels.len() as u32;
    let ribbon = if modes.is_empty() { 0 } else { RIBBON_H };
    let plot_area = Rect {
        x0: (MARGIN + Y_AREA) as i32,
        y0: MARGIN as i32 + caption_h,
        x1: cell_w - MARGIN_RIGHT as i32,
        y1: (panel_h - MARGIN - X_AREA) as i32,
    };
    for p in panels.iter_mut() {
        p.legend = layout_legend(p, &fig.x_lines, plot_area);
    }
    Some(FigurePlan {
        file_name: fig.file_name.clone(),
        title: fig.title.clone(),
        title_size: fit_font(&fig.title, 26, WIDTH - 40),
        subtitle_size: fit_font(&subtitle, 16, WIDTH - 40),
        subtitle,
        x_label: fig.x_label.clone(),
        x: x.to_vec(),
        x_range,
        x_log10: fig.x_log10,
        panels,
        modes,
        eclipses,
        shaded,
        steady_from,
        x_lines: fig.x_lines.clone(),
        width: WIDTH,
        height: TITLE_H + ribbon + n * panel_h + XLABEL_H,
        panel_height: panel_h,
        plot_area,
        legend_area: Rect { x0: cell_w, y0: 0, x1: WIDTH as i32, y1: panel_h as i32 },
    })
}

/// The x range: the data, the vertical lines and the marked points (3 % margins with
/// vertical lines or an equal scale).
fn x_range_of(x: &[f64], fig: &Figure, panels: &[PanelPlan]) -> (f64, f64) {
    let lines = fig.x_lines.iter().map(|l| l.0);
    let points = panels.iter().flat_map(|p| p.points.iter().map(|q| q.0)).collect::<Vec<_>>();
    let x_range = finite_range(x.iter().copied().chain(lines).chain(points)).unwrap_or((0.0, 1.0));
    if x_range.1 <= x_range.0 {
        pad(x_range, 0.0)
    } else if !fig.x_lines.is_empty() || fig.equal_scale {
        pad(x_range, 0.03)
    } else {
        x_range
    }
}

/// "scenario · t = a … b s" and the notes of the shadings drawn.
fn time_subtitle(scenario: &str, (a, b): (f64, f64), notes: [Option<&str>; 2]) -> String {
    let notes: String = notes.iter().flatten().map(|n| format!(" · {n}")).collect();
    format!("{scenario} · t = {} … {} s{notes}", short(a), short(b))
}

/// The panels with a steady-state panel after each linear one whose steady-state part
/// (`x ≥ from`) a transient has flattened ([`STEADY_ZOOM`]), and the lines still flat
/// over that window labelled with their value there.
fn with_steady_panels(panels: Vec<PanelPlan>, x: &[f64], from: f64, end: f64) -> Vec<PanelPlan> {
    let mut out = Vec::with_capacity(2 * panels.len());
    for mut p in panels {
        let zoom = steady_panel(&p, x, from, end);
        if zoom.is_none() {
            label_flat_tails(&mut p, x, from, true);
        }
        out.push(p);
        out.extend(zoom);
    }
    out
}

/// Range of the finite values of `y` where `x ≥ from`.
fn tail_range(x: &[f64], y: &[f64], from: f64) -> Option<(f64, f64)> {
    finite_range(x.iter().zip(y).filter(|(t, _)| **t >= from).map(|(_, v)| *v))
}

/// The steady-state panel of `p` (`None`: not a linear panel, or its steady-state part
/// already spans a fair part of its axis, or is flat).
fn steady_panel(p: &PanelPlan, x: &[f64], from: f64, end: f64) -> Option<PanelPlan> {
    if p.log_y || !p.categories.is_empty() {
        return None;
    }
    let tails: Vec<(f64, f64)> = p.lines.iter().filter_map(|l| tail_range(x, &l.y, from)).collect();
    let lo = tails.iter().map(|t| t.0).reduce(f64::min)?;
    let hi = tails.iter().map(|t| t.1).reduce(f64::max)?;
    let axis = p.y_range.1 - p.y_range.0;
    if hi - lo < p.floor.max(1e-9 * lo.abs().max(hi.abs())) || hi - lo >= STEADY_ZOOM.zoom_below * axis {
        return None;
    }
    let y_range = linear_range([lo, hi].into_iter(), p.floor);
    let lines = p
        .lines
        .iter()
        .map(|l| {
            let y: Vec<f64> = x.iter().zip(&l.y).map(|(t, v)| if *t >= from { *v } else { f64::NAN }).collect();
            let label = annotate(base_label(&l.label), &y, p.floor, &p.y_label);
            LinePlan { label, y, ..l.clone() }
        })
        .collect();
    let title = format!("{} — steady state, t ≥ {} s, rescaled", p.title, short(from));
    let mut zoom = PanelPlan {
        title_size: fit_font(&title, 19, WIDTH - LEGEND_W - 40),
        title,
        y_range,
        y_ticks: linear_ticks(y_range),
        lines,
        thresholds: p.thresholds.iter().filter(|t| (y_range.0..=y_range.1).contains(&t.0)).cloned().collect(),
        points: Vec::new(),
        x_range: (from, end),
        steady_from: Some(from),
        legend: Vec::new(),
        ..p.clone()
    };
    label_flat_tails(&mut zoom, x, from, false);
    Some(zoom)
}

/// A legend label without the flatness note [`annotate`] added.
fn base_label(label: &str) -> &str {
    [" ≡ ", " ≈ ", " (no data)"].iter().filter_map(|m| label.find(m)).min().map_or(label, |i| &label[..i])
}

/// Labels each line whose part at `x ≥ from` spans under [`STEADY_ZOOM`]'s visible
/// fraction of the axis with its value there, "≈ c ± d" (`say_when`: "for t ≥ from s").
fn label_flat_tails(p: &mut PanelPlan, x: &[f64], from: f64, say_when: bool) {
    if p.log_y || !p.categories.is_empty() {
        return;
    }
    let axis = p.y_range.1 - p.y_range.0;
    for l in p.lines.iter_mut().filter(|l| base_label(&l.label) == l.label) {
        let Some((lo, hi)) = tail_range(x, &l.y, from) else { continue };
        if hi - lo < STEADY_ZOOM.visible_fraction * axis {
            let when = if say_when { format!(" for t ≥ {} s", short(from)) } else { String::new() };
            l.label = format!("{} ≈ {} ± {}{when}", l.label, short(0.5 * (lo + hi)), short(0.5 * (hi - lo)));
        }
    }
}

/// The legend of a panel, laid out: one entry per line, vertical reference line and
/// marked point from the top, at the largest size from 15 down to 12 at which every label
/// fits on one line (at 12, the ones still too wide are wrapped); then the thresholds'
/// labels beside their lines (moved down when they would overlap), wrapped likewise.
fn layout_legend(panel: &PanelPlan, x_lines: &[(f64, String)], area: Rect) -> Vec<LegendEntry> {
    let marks: Vec<(String, LegendMark)> = panel
        .lines
        .iter()
        .map(|l| (l.label.clone(), LegendMark::Line { colour: l.colour, dash: l.dash, band: l.band }))
        .chain(x_lines.iter().enumerate().map(|(k, l)| {
            let (colour, dash) = x_line_style(k);
            (l.1.clone(), LegendMark::Line { colour, dash, band: false })
        }))
        .chain(panel.points.iter().map(|q| (q.2.clone(), LegendMark::Point)))
        .collect();
    let width = LEGEND_W - LEGEND_TEXT_X as u32 - 4;
    let size = marks.iter().map(|m| fit_font(&m.0, 15, width)).min().unwrap_or(15).max(12);
    let mut entries = Vec::new();
    let mut y = MARGIN as i32 + CAPTION_H + 8;
    for (label, mark) in marks {
        let e = LegendEntry { lines: wrap(&label, size, width), size, x: LEGEND_TEXT_X, y, mark };
        y += e.lines.len() as i32 * e.line_height() + 2;
        entries.push(e);
    }
    let (lo, hi) = panel.y_range;
    let row = |v: f64| {
        let f = if panel.log_y { (hi.log10() - v.log10()) / (hi.log10() - lo.log10()) } else { (hi - v) / (hi - lo) };
        area.y0 + (f * (area.y1 - area.y0) as f64).round() as i32
    };
    let mut order: Vec<(i32, &(f64, String))> = panel.thresholds.iter().map(|t| (row(t.0), t)).collect();
    order.sort_by_key(|o| o.0);
    let mut next = y;
    for (r, t) in order {
        let label = format!("{} {}", short(t.0), t.1);
        let e = LegendEntry {
            lines: wrap(&label, 13, LEGEND_W - THRESHOLD_TEXT_X as u32 - 4),
            size: 13,
            x: THRESHOLD_TEXT_X,
            y: r.max(next),
            mark: LegendMark::Threshold,
        };
        next = e.y + e.lines.len() as i32 * e.line_height();
        entries.push(e);
    }
    entries
}

/// Where a legend entry's text starts in the legend cell (lines and points; thresholds).
const LEGEND_TEXT_X: i32 = 40;
const THRESHOLD_TEXT_X: i32 = 24;

/// `text` in lines of at most `width` px at font size `size`: broken at spaces, a word
/// wider than a line broken between characters.
pub fn wrap(text: &str, size: u32, width: u32) -> Vec<String> {
    if ensure_font().is_err() {
        return vec![text.to_string()];
    }
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split(' ') {
        let joined = if line.is_empty() { word.to_string() } else { format!("{line} {word}") };
        if text_width(&joined, size) <= width {
            line = joined;
            continue;
        }
        if !line.is_empty() {
            lines.push(std::mem::take(&mut line));
        }
        for c in word.chars() {
            if !line.is_empty() && text_width(&format!("{line}{c}"), size) > width {
                lines.push(std::mem::take(&mut line));
            }
            line.push(c);
        }
    }
    lines.push(line);
    lines
}

/// Gives `x_range` and every panel's y range one span (the largest, so every range still
/// holds its data), each centred where it was; returns the new x range. Drawn in square
/// plot areas, one unit is then as many pixels on both axes.
fn equal_spans(x_range: (f64, f64), panels: &mut [PanelPlan]) -> (f64, f64) {
    let span = panels.iter().map(|p| p.y_range.1 - p.y_range.0).fold(x_range.1 - x_range.0, f64::max);
    let centred = |(lo, hi): (f64, f64)| (0.5 * (lo + hi) - 0.5 * span, 0.5 * (lo + hi) + 0.5 * span);
    for p in panels.iter_mut().filter(|p| !p.log_y && p.categories.is_empty()) {
        p.y_range = centred(p.y_range);
        p.y_ticks = linear_ticks(p.y_range);
    }
    centred(x_range)
}

/// The tick labels plotters will place on a linear axis over `range`.
fn linear_ticks(range: (f64, f64)) -> Vec<String> {
    let fmt = tick_formatter(range.0, range.1, Y_TICKS);
    RangedCoordf64::from(range.0..range.1).key_points(BoldPoints(Y_TICKS)).iter().map(fmt).collect()
}

/// A panel resolved against the data (`None`: no column, or its model is off).
fn plan_panel(ts: &TimeSeries, p: &Panel) -> Option<PanelPlan> {
    let cols: Vec<(&Series, &[f64])> = p.series.iter().filter_map(|s| Some((s, ts.col(&s.column)?))).collect();
    if cols.is_empty() || !present(ts, p, &cols) {
        return None;
    }
    let floor = resolution_floor(&p.y_label);
    let categorical = !p.categories.is_empty();
    let lines: Vec<LinePlan> = cols
        .iter()
        .enumerate()
        .map(|(i, (s, y))| {
            let (colour, mut dash) = line_style(i, s.dashed);
            if p.cycle_dashes && i > 0 {
                // Never solid again: a later solid line would hide all those under it.
                dash = [Dash::Dashed, Dash::Dotted, Dash::LongDash][(i - 1) % 3];
            }
            let k = p.y_scale.unwrap_or(1.0);
            let y: Vec<f64> = if categorical {
                y.iter().map(|v| category_index(&p.categories, *v)).collect()
            } else {
                y.iter().map(|v| k * v).collect()
            };
            let label = if categorical { s.label.clone() } else { annotate(&s.label, &y, floor, &p.y_label) };
            let band = p.bands.contains(&s.column);
            LinePlan { column: s.column.clone(), label, colour, dash, y, band }
        })
        .collect();
    let values = lines
        .iter()
        .flat_map(|l| l.y.iter().copied())
        .chain(p.thresholds.iter().map(|t| t.0))
        .chain(p.points.iter().map(|q| q.1));
    let y_range = if categorical {
        (-0.5, p.categories.len() as f64 - 0.5)
    } else if p.log_y {
        log_range(values)
    } else {
        linear_range(values, floor)
    };
    let y_ticks = match () {
        _ if categorical => p.categories.iter().map(|c| c.1.clone()).collect(),
        _ if p.log_y => Vec::new(),
        _ => linear_ticks(y_range),
    };
    let title = match &p.title_when {
        Some((column, value, title)) if ts.col(column).is_some_and(|c| c.contains(value)) => title.clone(),
        _ => p.title.clone(),
    };
    Some(PanelPlan {
        y_ticks,
        title_size: fit_font(&title, 19, WIDTH - LEGEND_W - 40),
        title,
        y_label: p.y_label.clone(),
        log_y: p.log_y && !categorical,
        step: p.step || categorical,
        categories: p.categories.iter().map(|c| c.1.clone()).collect(),
        y_range,
        floor,
        lines,
        thresholds: p.thresholds.clone(),
        points: p.points.clone(),
        x_range: (0.0, 1.0),
        steady_from: None,
        legend: Vec::new(),
    })
}

fn identically_zero(y: &[f64]) -> bool {
    y.iter().all(|v| *v == 0.0 || v.is_nan())
}

/// Whether the panel's model is on in this run ([`Presence`]).
fn present(ts: &TimeSeries, p: &Panel, cols: &[(&Series, &[f64])]) -> bool {
    match &p.presence {
        Presence::Always => true,
        Presence::NonZero => !cols.iter().all(|(_, y)| identically_zero(y)),
        Presence::AnyFinite => cols.iter().any(|(_, y)| y.iter().any(|v| !v.is_nan())),
        Presence::NonZeroIn(names) => names.iter().filter_map(|n| ts.col(n)).any(|y| !identically_zero(y)),
        Presence::ZeroIn(names) => {
            let c: Vec<&[f64]> = names.iter().filter_map(|n| ts.col(n)).collect();
            !c.is_empty() && c.iter().all(|y| identically_zero(y))
        }
    }
}

/// Index of `v` in the category list (NaN when not a category).
fn category_index(categories: &[(f64, String)], v: f64) -> f64 {
    categories.iter().position(|c| c.0 == v).map_or(f64::NAN, |i| i as f64)
}

/// The legend label of a flat series: "≡ 0", "≡ c", or "≈ c (span < floor)".
fn annotate(label: &str, y: &[f64], floor: f64, unit: &str) -> String {
    let Some((lo, hi)) = finite_range(y.iter().copied()) else {
        return format!("{label} (no data)");
    };
    if lo == 0.0 && hi == 0.0 {
        format!("{label} ≡ 0")
    } else if lo == hi {
        format!("{label} ≡ {}", short(lo))
    } else if hi - lo < floor.max(1e-9 * lo.abs().max(hi.abs())) {
        format!("{label} ≈ {} (span < {} {unit})", short(0.5 * (lo + hi)), short(floor))
    } else {
        label.to_string()
    }
}

/// A linear y range: the data with a 5 % margin, never narrower than `floor` (nor than
/// 1e-9 of the values' magnitude); a flat panel spans ± max(floor / 2, 10 % of its value).
fn linear_range(values: impl Iterator<Item = f64>, floor: f64) -> (f64, f64) {
    let (lo, hi) = finite_range(values).unwrap_or((0.0, 0.0));
    let floor = floor.max(1e-9 * lo.abs().max(hi.abs()));
    if hi - lo < floor {
        let c = 0.5 * (lo + hi);
        let half = (0.5 * floor).max(0.1 * c.abs());
        (c - half, c + half)
    } else {
        pad((lo, hi), 0.05)
    }
}

/// A log y range over the positive values: from half the smallest to a little above the
/// largest, at least one decade.
fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = finite_range(values.filter(|v| *v > 0.0)).unwrap_or((0.1, 10.0));
    let lo = lo / 2.0;
    let hi = hi * (hi / lo).powf(0.05).max(1.2);
    if hi / lo < 10.0 { (lo.min(hi / 10.0), hi) } else { (lo, hi) }
}

/// The mode spans of the run (from the `mode` column), spans shorter than 1/2000 of the
/// x range (a sub-pixel zigzag of the decimation envelope at a transition) merged into
/// the span before.
fn mode_spans(ts: &TimeSeries, x: &[f64], (x0, x1): (f64, f64)) -> Vec<(f64, f64, String)> {
    let Some(mode) = ts.col("mode") else { return Vec::new() };
    let name = |v: f64| MODE_NAMES.iter().find(|m| m.0 == v).map_or(format!("mode {v}"), |m| m.1.to_string());
    let mut spans: Vec<(f64, f64, f64)> = Vec::new();
    for (&t, &m) in x.iter().zip(mode).filter(|(t, m)| t.is_finite() && m.is_finite()) {
        match spans.last_mut() {
            Some(s) if s.2 == m => s.1 = t,
            Some(s) => {
                s.1 = t;
                spans.push((t, t, m));
            }
            None => spans.push((t, t, m)),
        }
    }
    let min_len = (x1 - x0) / 2000.0;
    let mut merged: Vec<(f64, f64, f64)> = Vec::new();
    for s in spans {
        match merged.last_mut() {
            Some(last) if s.1 - s.0 < min_len || last.2 == s.2 => last.1 = s.1,
            _ => merged.push(s),
        }
    }
    merged.into_iter().map(|(a, b, m)| (a, b, name(m))).collect()
}

/// Spans where `column` is 1 (the `eclipse` column: 1 in shadow).
fn eclipse_spans(ts: &TimeSeries, x: &[f64], column: &str) -> Vec<(f64, f64)> {
    let Some(e) = ts.col(column) else { return Vec::new() };
    let mut spans: Vec<(f64, f64)> = Vec::new();
    let mut inside = false;
    for (&t, &v) in x.iter().zip(e) {
        match (inside, v > 0.5) {
            (false, true) => spans.push((t, t)),
            (true, true) => {
                if let Some(s) = spans.last_mut() {
                    s.1 = t;
                }
            }
            _ => {}
        }
        inside = v > 0.5;
    }
    // Plotted from a min/max envelope, a bucket across an edge holds both 0 and 1: spans
    // a couple of samples apart are one eclipse, not several.
    let gap = 4.0 * (x.last().copied().unwrap_or(0.0) - x.first().copied().unwrap_or(0.0)) / x.len().max(1) as f64;
    let mut merged: Vec<(f64, f64)> = Vec::new();
    for s in spans {
        match merged.last_mut() {
            Some(m) if s.0 - m.1 <= gap => m.1 = m.1.max(s.1),
            _ => merged.push(s),
        }
    }
    merged
}

/// The largest font size from `size` down to 11 at which `text` fits in `width` pixels.
fn fit_font(text: &str, size: u32, width: u32) -> u32 {
    if ensure_font().is_err() {
        return size;
    }
    (11..=size).rev().find(|s| text_width(text, *s) <= width).unwrap_or(11)
}

/// Height of a chart caption `title` at font size `size`, as plotters lays it out (the
/// text's box and up to 5 px above and below); [`CAPTION_H`] without the font.
fn caption_height(title: &str, size: u32) -> i32 {
    if ensure_font().is_err() {
        return CAPTION_H;
    }
    let h = (FONT, size as f64).into_font().box_size(title).map_or(0, |b| b.1) as i32;
    h + 2 * (h / 2).min(5)
}

/// Width of `text` in pixels at font size `size`.
pub fn text_width(text: &str, size: u32) -> u32 {
    (FONT, size as f64).into_font().box_size(text).map_or(0, |b| b.0)
}

/// A short form of a value for labels: 4 significant digits, scientific outside 1e-3 … 1e5.
fn short(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.2e}")
    } else {
        let d = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        let s = format!("{v:.d$}");
        if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
    }
}

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

/// Renders each figure ([`plan`], then drawn) to `dir/file_name`; figures that are not
/// drawn are skipped. Returns the paths written.
pub fn render(dir: &Path, ts: &TimeSeries, figures: &[Figure], ctx: &FigureContext) -> io::Result<Vec<PathBuf>> {
    ensure_font()?;
    let mut written = Vec::new();
    for fig in figures {
        let Some(p) = plan(ts, fig, ctx) else { continue };
        let (buf, _) = draw(&p)?;
        let path = dir.join(&p.file_name);
        write_png(&path, p.width, p.height, &buf)?;
        written.push(path);
    }
    Ok(written)
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Draws a plan into an RGB buffer; also returns each panel's plot area as drawn
/// (relative to its cell: the plan's `plot_area`, which a test checks).
fn draw(p: &FigurePlan) -> io::Result<(Vec<u8>, Vec<Rect>)> {
    let (w, h) = (p.width, p.height);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let mut areas = Vec::new();
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let (top, mut area) = root.split_vertically(TITLE_H);
        let centre = Pos::new(HPos::Center, VPos::Center);
        let title = TextStyle::from((FONT, p.title_size as f64).into_font()).pos(centre);
        top.draw_text(&p.title, &title, ((w / 2) as i32, 20)).map_err(err)?;
        let sub = TextStyle::from((FONT, p.subtitle_size as f64).into_font()).color(&GREY).pos(centre);
        top.draw_text(&p.subtitle, &sub, ((w / 2) as i32, 48)).map_err(err)?;
        let ribbon = if p.modes.is_empty() {
            None
        } else {
            let (r, rest) = area.split_vertically(RIBBON_H);
            area = rest;
            Some(r)
        };
        let mut plot_px = None;
        for (k, panel) in p.panels.iter().enumerate() {
            let last = k + 1 == p.panels.len();
            let (cell, rest) = area.split_vertically(p.panel_height + if last { XLABEL_H } else { 0 });
            area = rest;
            let (chart_cell, legend_cell) = cell.split_horizontally(WIDTH - LEGEND_W);
            let drawn = draw_panel(&chart_cell, p, panel, last)?;
            draw_legend(&legend_cell, panel)?;
            plot_px = Some((drawn.x0, drawn.x1));
            let base = chart_cell.get_base_pixel();
            areas.push(Rect {
                x0: drawn.x0 - base.0,
                y0: drawn.y0 - base.1,
                x1: drawn.x1 - base.0,
                y1: drawn.y1 - base.1,
            });
        }
        if let (Some(r), Some(px)) = (ribbon, plot_px) {
            draw_ribbon(&r, p, px)?;
        }
        root.present().map_err(err)?;
    }
    Ok((buf, areas))
}

/// Width of the y tick labels' column: [`Y_AREA`] less the rotated axis description.
pub const Y_TICK_W: u32 = Y_AREA - 36;

/// Draws one panel's chart; returns the plot area in absolute pixels.
fn draw_panel(cell: &Area, p: &FigurePlan, panel: &PanelPlan, last: bool) -> io::Result<Rect> {
    let mut cb = ChartBuilder::on(cell);
    cb.margin(MARGIN)
        .margin_right(MARGIN_RIGHT)
        .caption(&panel.title, (FONT, panel.title_size as f64))
        .x_label_area_size(if last { X_AREA + XLABEL_H } else { X_AREA })
        .y_label_area_size(Y_AREA);
    let x_rng = panel.x_range.0..panel.x_range.1;
    let (lo, hi) = panel.y_range;
    if panel.log_y {
        let chart = cb.build_cartesian_2d(x_rng, (lo..hi).log_scale()).map_err(err)?;
        fill_panel(chart, p, panel, last, &log_tick)
    } else if !panel.categories.is_empty() {
        let chart = cb.build_cartesian_2d(x_rng, lo..hi).map_err(err)?;
        let names = panel.categories.clone();
        let fmt = move |v: &f64| {
            let i = v.round();
            if (v - i).abs() < 1e-6 && i >= 0.0 {
                names.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        };
        fill_panel(chart, p, panel, last, &fmt)
    } else {
        let chart = cb.build_cartesian_2d(x_rng, lo..hi).map_err(err)?;
        fill_panel(chart, p, panel, last, &tick_formatter(lo, hi, Y_TICKS))
    }
}

/// Mesh, shading, reference lines and data lines of one panel (generic over linear / log y).
fn fill_panel<'a, DB, Y>(
    mut chart: ChartContext<'a, DB, Cartesian2d<RangedCoordf64, Y>>,
    p: &FigurePlan,
    panel: &PanelPlan,
    last: bool,
    y_fmt: &dyn Fn(&f64) -> String,
) -> io::Result<Rect>
where
    DB: DrawingBackend + 'a,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let (x0, x1) = panel.x_range;
    let linear_fmt = tick_formatter(x0, x1, X_TICKS);
    let x_fmt = |v: &f64| if p.x_log10 { decade_tick(*v) } else { linear_fmt(v) };
    let mut mesh = chart.configure_mesh();
    let y_ticks = if panel.categories.is_empty() { Y_TICKS } else { 2 * panel.categories.len() + 1 };
    mesh.y_desc(&panel.y_label)
        .x_labels(X_TICKS)
        .y_labels(y_ticks)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(y_fmt)
        .x_max_light_lines(1)
        .y_max_light_lines(1)
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 18))
        .bold_line_style(RGBColor(200, 200, 200))
        .light_line_style(RGBColor(238, 238, 238));
    if last {
        mesh.x_desc(&p.x_label);
    }
    mesh.draw().map_err(err)?;
    let (lo, hi) = panel.y_range;
    let inside = |&&(a, b): &&(f64, f64)| b >= x0 && a <= x1;
    let eclipse = RGBColor(215, 215, 215).mix(0.5).filled();
    let blend = PALETTE[5].mix(0.18).filled();
    let spans = p
        .eclipses
        .iter()
        .filter(inside)
        .map(|s| (s, eclipse))
        .chain(p.shaded.iter().filter(inside).map(|s| (s, blend)));
    for (&(a, b), style) in spans {
        chart.draw_series([Rectangle::new([(a.max(x0), lo), (b.min(x1), hi)], style)]).map_err(err)?;
    }
    let area = chart.plotting_area().use_screen_coord();
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    let px = |x: f64, y: f64| chart.backend_coord(&(x, y));
    let vertical = |x: f64| vec![(px(x, lo).0, ys.start), (px(x, lo).0, ys.end - 1)];
    let within = |x: &f64| (x0..=x1).contains(x);
    for m in p.modes.iter().skip(1).filter(|m| within(&m.0)) {
        stroke(&area, vertical(m.0), GREY, Dash::Dashed)?;
    }
    for (k, l) in p.x_lines.iter().enumerate().filter(|(_, l)| within(&l.0)) {
        let (colour, dash) = x_line_style(k);
        stroke(&area, vertical(l.0), colour, dash)?;
    }
    // z-order: pale bands, then the reference lines, then targets and commands (dashed,
    // drawn wider so that a response lying on them leaves their edges showing), then the
    // responses on top.
    let draw_lines = |lines: &mut dyn Iterator<Item = &LinePlan>, width: Width| -> io::Result<()> {
        for line in lines {
            let colour = if line.band { pale(line.colour) } else { line.colour };
            for run in runs(&p.x, &line.y, panel.log_y, panel.step) {
                let pts: Vec<(i32, i32)> = run.iter().map(|&(x, y)| px(x, y)).collect();
                stroke_width(&area, dedup(pts), colour, line.dash, width)?;
            }
        }
        Ok(())
    };
    draw_lines(&mut panel.lines.iter().filter(|l| l.band), Width::Normal)?;
    for t in &panel.thresholds {
        let y = px(x0, t.0).1;
        stroke(&area, vec![(xs.start, y), (xs.end - 1, y)], GREY, Dash::Dotted)?;
    }
    draw_lines(&mut panel.lines.iter().filter(|l| !l.band && l.dash != Dash::Solid), Width::Wide)?;
    draw_lines(&mut panel.lines.iter().filter(|l| !l.band && l.dash == Dash::Solid), Width::Normal)?;
    for &(x, y, _) in &panel.points {
        point_marker(&area, px(x, y))?;
    }
    Ok(Rect { x0: xs.start, y0: ys.start, x1: xs.end, y1: ys.end })
}

/// A band's colour: the line's colour mixed 35 % into white.
fn pale(c: RGBColor) -> RGBColor {
    let mix = |v: u8| (255.0 - 0.35 * (255.0 - v as f64)).round() as u8;
    RGBColor(mix(c.0), mix(c.1), mix(c.2))
}

/// Line widths: 2 px, or 4 px for targets under responses.
#[derive(Clone, Copy)]
enum Width {
    Normal,
    Wide,
}

/// A marked point: a black cross in a ring, 6 px from its centre.
fn point_marker<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, (x, y): (i32, i32)) -> io::Result<()> {
    let black = RGBColor(0, 0, 0);
    stroke(area, vec![(x - 6, y), (x + 6, y)], black, Dash::Solid)?;
    stroke(area, vec![(x, y - 6), (x, y + 6)], black, Dash::Solid)?;
    area.draw(&plotters::element::Circle::new((x, y), 6, ShapeStyle::from(&black).stroke_width(2))).map_err(err)
}

/// Runs of drawable points (finite; positive on a log axis), as steps when `step`.
fn runs(x: &[f64], y: &[f64], log_y: bool, step: bool) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    for (&xv, &yv) in x.iter().zip(y) {
        let ok = xv.is_finite() && yv.is_finite() && (!log_y || yv > 0.0);
        match runs.last_mut() {
            Some(r) if ok => {
                if let (true, Some(&(_, prev))) = (step, r.last()) {
                    r.push((xv, prev));
                }
                r.push((xv, yv));
            }
            Some(r) if !r.is_empty() => runs.push(Vec::new()),
            _ => {}
        }
    }
    runs.retain(|r| !r.is_empty());
    runs
}

fn dedup(mut pts: Vec<(i32, i32)>) -> Vec<(i32, i32)> {
    pts.dedup();
    pts
}

/// A 2-px line through pixel points: two 1-px lines one pixel apart (no polygon mitres).
fn stroke<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    pts: Vec<(i32, i32)>,
    colour: RGBColor,
    dash: Dash,
) -> io::Result<()> {
    stroke_width(area, pts, colour, dash, Width::Normal)
}

/// [`stroke`] at `width`: 2 px, or 4 px (one more row above and below).
fn stroke_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    pts: Vec<(i32, i32)>,
    colour: RGBColor,
    dash: Dash,
    width: Width,
) -> io::Result<()> {
    let style = ShapeStyle::from(&colour).stroke_width(1);
    let rows: &[i32] = match width {
        Width::Normal => &[0, 1],
        Width::Wide => &[-1, 0, 1, 2],
    };
    for &dy in rows {
        let p: Vec<(i32, i32)> = pts.iter().map(|&(x, y)| (x, y + dy)).collect();
        let drawn = match dash {
            Dash::Solid => area.draw(&PathElement::new(p, style)),
            Dash::Dashed => area.draw(&DashedPathElement::new(p, 8, 5, style)),
            Dash::Dotted => area.draw(&DashedPathElement::new(p, 2, 3, style)),
            Dash::LongDash => area.draw(&DashedPathElement::new(p, 16, 5, style)),
        };
        drawn.map_err(err)?;
    }
    Ok(())
}

/// The legend right of the plot, as laid out in the plan ([`layout_legend`]).
fn draw_legend(cell: &Area, panel: &PanelPlan) -> io::Result<()> {
    let left = Pos::new(HPos::Left, VPos::Center);
    for e in &panel.legend {
        let y = e.y;
        let colour = match e.mark {
            LegendMark::Line { colour, dash, band } => {
                let (c, w) = if band { (pale(colour), Width::Normal) } else { (colour, Width::Normal) };
                stroke_width(cell, vec![(6, y), (34, y)], c, dash, w)?;
                RGBColor(0, 0, 0)
            }
            LegendMark::Point => {
                point_marker(cell, (20, y))?;
                RGBColor(0, 0, 0)
            }
            LegendMark::Threshold => {
                stroke(cell, vec![(6, y), (20, y)], GREY, Dash::Dotted)?;
                GREY
            }
        };
        let style = TextStyle::from((FONT, e.size as f64).into_font()).color(&colour).pos(left);
        for (k, line) in e.lines.iter().enumerate() {
            cell.draw_text(line, &style, (e.x, y + k as i32 * e.line_height())).map_err(err)?;
        }
    }
    Ok(())
}

/// Short names of the modes, for ribbon spans too narrow for the full name.
fn mode_abbreviation(name: &str) -> &str {
    match name {
        "detumble" => "det",
        "sun-safe" => "safe",
        "stabilise" => "stab",
        "manoeuvre" => "man",
        _ => name,
    }
}

/// The mode ribbon: one tinted box per mode span with the mode's name (abbreviated when
/// narrow, none when narrower still), over the plot's x range; in the legend column a key
/// of the tints.
fn draw_ribbon(r: &Area, p: &FigurePlan, (px0, px1): (i32, i32)) -> io::Result<()> {
    let base = r.get_base_pixel().0;
    let (x0, x1) = p.x_range;
    let to_px = |x: f64| (px0 - base) as f64 + (x - x0) / (x1 - x0) * (px1 - px0) as f64;
    let centre = Pos::new(HPos::Center, VPos::Center);
    let tint = |name: &str| {
        let k = MODE_NAMES.iter().position(|m| m.1 == name).unwrap_or(PALETTE.len() - 1);
        PALETTE[k % PALETTE.len()].mix(0.25).filled()
    };
    let text = TextStyle::from((FONT, 12).into_font()).pos(centre);
    let h = RIBBON_H as i32;
    for (a, b, name) in &p.modes {
        let (a, b) = (to_px(*a) as i32, to_px(*b) as i32);
        r.draw(&Rectangle::new([(a, 2), (b.max(a + 1), h - 2)], tint(name))).map_err(err)?;
        let label =
            [name.as_str(), mode_abbreviation(name)].into_iter().find(|l| text_width(l, 12) + 4 < (b - a) as u32);
        if let Some(l) = label {
            r.draw_text(l, &text, ((a + b) / 2, h / 2)).map_err(err)?;
        }
    }
    // The key, in the legend column: the tints of the modes present.
    let mut x = (WIDTH - LEGEND_W) as i32 + 6;
    for (_, name) in MODE_NAMES {
        if !p.modes.iter().any(|m| m.2 == name) {
            continue;
        }
        let l = mode_abbreviation(name);
        let w = text_width(l, 12) as i32 + 8;
        r.draw(&Rectangle::new([(x, 2), (x + w, h - 2)], tint(name))).map_err(err)?;
        r.draw_text(l, &text, (x + w / 2, h / 2)).map_err(err)?;
        x += w + 3;
    }
    Ok(())
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

/// The style of the k-th vertical reference line: black dashed, then vermillion dotted,
/// blue long-dashed, … so that lines of different meaning (a crossover and a phase
/// crossing) are told apart in the legend.
fn x_line_style(k: usize) -> (RGBColor, Dash) {
    const STYLES: [(RGBColor, Dash); 4] = [
        (RGBColor(0, 0, 0), Dash::Dashed),
        (RGBColor(213, 94, 0), Dash::Dotted),
        (RGBColor(0, 114, 178), Dash::LongDash),
        (RGBColor(0, 158, 115), Dash::Dashed),
    ];
    STYLES[k % STYLES.len()]
}

/// Tick label of a log10 axis: the quantity at a whole decade (0.001 … 1000, else 1e-4),
/// nothing between decades.
fn decade_tick(v: f64) -> String {
    let e = v.round();
    if (v - e).abs() > 1e-9 {
        return String::new();
    }
    let x = 10f64.powi(e as i32);
    if (-3.0..=3.0).contains(&e) { short_decimal(x) } else { format!("{x:.0e}") }
}

/// 0.001, 0.01, 0.1, 1, 10 … without trailing zeros.
fn short_decimal(x: f64) -> String {
    let s = format!("{x:.3}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
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
    fn a_log10_axis_reads_decades_and_reference_lines_differ() {
        // The labels are the quantity, 10^v, at whole decades only.
        for (v, want) in [(-3.0, "0.001"), (-1.0, "0.1"), (0.0, "1"), (1.0, "10"), (2.0, "100"), (5.0, "1e5")] {
            assert_eq!(decade_tick(v), want, "v = {v}");
        }
        assert_eq!(decade_tick(0.5), "");
        assert_eq!(decade_tick(-1.0 + 1e-12), "0.1");
        // Consecutive reference lines never share colour and dash.
        for k in 0..8 {
            let (a, b) = (x_line_style(k), x_line_style(k + 1));
            assert!(a.0 != b.0 || a.1 != b.1, "lines {k} and {}", k + 1);
        }
    }

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

    #[test]
    fn floors_and_flat_series() {
        // Rounding noise around zero: the axis spans the floor, not 1e-17.
        let (lo, hi) = linear_range([1e-17, -2e-17].into_iter(), resolution_floor("deg"));
        assert!((hi - lo - 1e-6).abs() < 1e-12, "{lo} {hi}");
        // A constant 50 deg: ±10 % of it.
        assert_eq!(linear_range([50.0, 50.0].into_iter(), 1e-6), (45.0, 55.0));
        // A real signal: the data with 5 % margins.
        assert_eq!(linear_range([0.0, 10.0].into_iter(), 1e-6), (-0.5, 10.5));
        assert_eq!(annotate("z", &[0.0, 0.0, f64::NAN], 1e-12, "N m"), "z ≡ 0");
        assert_eq!(annotate("target", &[50.0; 3], 1e-6, "deg"), "target ≡ 50");
        assert_eq!(annotate("roll", &[1e-17, -1e-17], 1e-6, "deg"), "roll ≈ 0 (span < 1.00e-6 deg)");
        assert_eq!(annotate("roll", &[1.0, -1.0], 1e-6, "deg"), "roll");
        let (lo, hi) = log_range([1.0, 2.0].into_iter());
        assert!(hi / lo >= 10.0);
    }

    #[test]
    fn styles_do_not_repeat_within_a_panel() {
        let styles: std::collections::HashSet<_> =
            (0..14).flat_map(|i| [line_style(i, false), line_style(i, true)]).collect();
        assert_eq!(styles.len(), 28);
    }

    #[test]
    fn equal_scale_gives_one_pixel_scale_on_both_axes_where_drawn() {
        let mut ts = TimeSeries::with_columns(vec!["re".into(), "im".into()], 3);
        for row in [[-3.0, -1.6], [-0.5, -0.2], [0.0, 0.0]] {
            ts.push_row(&row);
        }
        let panel = Panel {
            title: "loop-at-a-time".into(),
            y_label: "Im".into(),
            series: vec![Series { column: "im".into(), label: "l".into(), dashed: false }],
            points: vec![(-1.0, 0.0, "critical point -1".into())],
            ..Default::default()
        };
        let fig = Figure {
            file_name: "n.png".into(),
            x: "re".into(),
            panels: vec![panel],
            equal_scale: true,
            ..Default::default()
        };
        let p = plan(&ts, &fig, &FigureContext::new("s")).unwrap();
        let a = p.plot_area;
        let (x, y) = (p.x_range, p.panels[0].y_range);
        let (kx, ky) = ((a.x1 - a.x0) as f64 / (x.1 - x.0), (a.y1 - a.y0) as f64 / (y.1 - y.0));
        assert!((kx / ky - 1.0).abs() < 1e-9, "{kx} px/unit on x, {ky} on y");
        assert!(x.0 < -3.0 && x.1 > 0.0 && y.0 < -1.6 && y.1 > 0.0, "{x:?} {y:?}");
        // The plot area drawn is the one planned (to a pixel).
        ensure_font().unwrap();
        let (_, drawn) = draw(&p).unwrap();
        let d = drawn[0];
        assert!([d.x0 - a.x0, d.y0 - a.y0, d.x1 - a.x1, d.y1 - a.y1].iter().all(|e| e.abs() <= 1), "{d:?} vs {a:?}");
    }

    #[test]
    fn a_transient_does_not_set_the_steady_state_scale() {
        // 100 at t = 0, then sin(t) of amplitude 1, and a second line flat at 0.5 ± 1e-3
        // after the start: the panel keeps the transient, a second panel shows t ≥ 50
        // (the second half) on the sine's scale, and the flat line is labelled there.
        let mut ts = TimeSeries::with_columns(vec!["t_s".into(), "a".into(), "b".into()], 101);
        for i in 0..=100 {
            let t = i as f64;
            let a = if i == 0 { 100.0 } else { t.sin() };
            ts.push_row(&[t, a, 0.5 + 1e-3 * (t / 7.0).cos()]);
        }
        let series = vec![
            Series { column: "a".into(), label: "a".into(), dashed: false },
            Series { column: "b".into(), label: "b".into(), dashed: false },
        ];
        let fig = Figure {
            file_name: "f.png".into(),
            x: "t_s".into(),
            panels: vec![Panel { title: "p".into(), y_label: "m".into(), series, ..Default::default() }],
            ..Default::default()
        };
        let p = plan(&ts, &fig, &FigureContext::new("s")).unwrap();
        assert_eq!(p.steady_from, Some(50.0));
        assert_eq!(p.panels.len(), 2, "{:?}", p.panels.iter().map(|q| &q.title).collect::<Vec<_>>());
        let (main, zoom) = (&p.panels[0], &p.panels[1]);
        assert!(main.y_range.1 >= 100.0 && main.steady_from.is_none());
        assert_eq!((zoom.steady_from, zoom.x_range), (Some(50.0), (50.0, 100.0)));
        // sin over t = 50 … 100 reaches within 1e-3 of ±1 (integer t); 5 % margins.
        let (lo, hi) = zoom.y_range;
        assert!((-1.11..=-1.09).contains(&lo) && (1.09..=1.11).contains(&hi), "{lo} {hi}");
        assert!(zoom.lines[0].y[..50].iter().all(|v| v.is_nan()), "nothing before the window");
        assert_eq!(zoom.lines[0].label, "a");
        assert!(zoom.lines[1].label.starts_with("b ≈ 0.5"), "{}", zoom.lines[1].label);
        // The panel height follows the number of panels.
        assert_eq!(p.height, TITLE_H + 2 * PANEL_H + XLABEL_H);
    }

    #[test]
    fn legend_text_is_wrapped_inside_its_column() {
        ensure_font().unwrap();
        let label = "threshold (hold APE (95 % of the time) < 0.5 deg over the pass of the target)";
        let width = LEGEND_W - LEGEND_TEXT_X as u32 - 4;
        let lines = wrap(label, 12, width);
        assert!(lines.len() >= 2, "{lines:?}");
        assert!(lines.iter().all(|l| text_width(l, 12) <= width), "{lines:?}");
        assert_eq!(lines.join(" "), label, "every word kept, in order");
        // A word wider than the column is broken between characters.
        let long = "x".repeat(200);
        let lines = wrap(&long, 12, width);
        assert!(lines.len() >= 2 && lines.iter().all(|l| text_width(l, 12) <= width));
        assert_eq!(lines.concat(), long);
    }

    #[test]
    fn steps_hold_the_recorded_values() {
        // The decimation envelope's zigzag at a 4 → 3 transition, drawn as steps: only the
        // recorded values appear, nothing below 3.
        let x = [0.0, 2.0, 4.0, 6.0, 8.0];
        let y = [4.0, 4.0, 3.0, 4.0, 3.0];
        let r = runs(&x, &y, false, true);
        assert_eq!(r.len(), 1);
        assert!(r[0].iter().all(|p| p.1 == 3.0 || p.1 == 4.0));
        assert_eq!(r[0][..4], [(0.0, 4.0), (2.0, 4.0), (2.0, 4.0), (4.0, 4.0)]);
        // NaN breaks the line.
        assert_eq!(runs(&x, &[1.0, f64::NAN, 1.0, 1.0, 1.0], false, false).len(), 2);
    }
}
