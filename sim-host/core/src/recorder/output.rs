//! Run outputs: the time series (`timeseries.parquet` by default, or `timeseries.csv`;
//! streamed to disk as the run goes), `summary.json` and the PNG figures (drawn from a
//! bounded min/max decimation of the recorded rows); [`read_run`] reads a run's time
//! series back from either format.

use crate::recorder::columns::Col;
use crate::recorder::csv::CsvRows;
use crate::recorder::decimate::Envelope;
use crate::recorder::parquet::{ParquetStream, RunMetadata};
use crate::recorder::plots::{self, Figure, FigureContext, Panel, Presence, Series};
use crate::recorder::series::{Recorder, TimeSeries};
use crate::recorder::summary::Summary;
use anyhow::{Context, Result, bail};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// One series per wheel / thruster (missing columns are skipped by the renderer).
fn per_unit(prefix: &str, quantity: &str, label: &str, n: usize) -> Vec<Series> {
    (1..=n).map(|i| line(&format!("{prefix}{i}_{quantity}"), &format!("{label}{i}"), false)).collect()
}

/// The column names of one quantity of every wheel.
fn wheel_columns(quantity: &str) -> Vec<String> {
    (1..=6).map(|i| format!("wheel{i}_{quantity}")).collect()
}

fn xyz(prefix: &str, suffix: &str) -> Vec<Series> {
    ["x", "y", "z"].iter().map(|a| line(&format!("{prefix}_{a}_{suffix}"), a, false)).collect()
}

fn xyz_plain(prefix: &str) -> Vec<Series> {
    ["x", "y", "z"].iter().map(|a| line(&format!("{prefix}_{a}"), a, false)).collect()
}

fn line(column: &str, label: &str, dashed: bool) -> Series {
    Series { column: column.into(), label: label.into(), dashed }
}

fn panel(title: &str, y_label: &str, series: Vec<Series>) -> Panel {
    Panel { title: title.into(), y_label: y_label.into(), series, ..Panel::default() }
}

fn log_panel(title: &str, y_label: &str, series: Vec<Series>) -> Panel {
    Panel { log_y: true, ..panel(title, y_label, series) }
}

/// A panel of a model that may be off: left out when every series is identically zero.
fn model_panel(title: &str, y_label: &str, series: Vec<Series>) -> Panel {
    Panel { presence: Presence::NonZero, ..panel(title, y_label, series) }
}

/// A panel of step signals (counters).
fn step_panel(title: &str, y_label: &str, series: Vec<Series>) -> Panel {
    Panel { step: true, ..panel(title, y_label, series) }
}

fn figure(file_name: &str, title: &str, panels: Vec<Panel>) -> Figure {
    Figure {
        file_name: file_name.into(),
        title: title.into(),
        x: Col::T.name().into(),
        x_label: "time [s]".into(),
        panels,
        ..Figure::default()
    }
}

/// Thresholds of the mode manager, for `modes.png` (deg and deg/s, as in `[modes]`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ModeThresholds {
    /// (value in deg, label) compared with the attitude error.
    pub error_deg: Vec<(f64, String)>,
    /// (value in deg/s, label) compared with the body rate.
    pub rate_deg_s: Vec<(f64, String)>,
}

/// The body-rate norm in deg/s, a column the plots derive ([`RunOutput`] computes it per
/// recorded row before decimation; it is not written to the time series).
pub const RATE_NORM_DEG_S: &str = "rate_norm_deg_s";

/// 1 while the guidance blends from one pointing to the next (`guidance_flags` bit 3,
/// `acs_flight::guidance::flags::BLENDING`), else 0 (NaN without guidance): a column the
/// plots derive, shaded on `pointing.png`.
pub const GUIDANCE_BLENDING: &str = "guidance_blending";

/// [`GUIDANCE_BLENDING`] of a recorded row with the guidance flags at `flags` (if any).
fn guidance_blending(row: &[f64], flags: Option<usize>) -> f64 {
    match flags.and_then(|i| row.get(i)) {
        Some(f) if f.is_finite() => f64::from((*f as u32) & u32::from(acs_flight::guidance::flags::BLENDING) != 0),
        _ => f64::NAN,
    }
}

/// The body-rate norm of a recorded row, deg/s ([`RATE_NORM_DEG_S`]).
pub fn rate_norm_deg_s(row: &[f64]) -> f64 {
    let rate = Col::RATE.map(|c| row.get(c.index()).copied().unwrap_or(f64::NAN));
    rate.iter().map(|w| w * w).sum::<f64>().sqrt().to_degrees()
}

/// `ts` with the columns the figures derive ([`RATE_NORM_DEG_S`]) appended (for a full,
/// undecimated series; [`RunOutput`] derives them row by row before its decimation).
pub fn with_plot_columns(ts: &TimeSeries) -> TimeSeries {
    let mut out = ts.clone();
    if let Some(flags) = ts.col("guidance_flags") {
        let blending = flags.iter().map(|f| guidance_blending(&[*f], Some(0)));
        out.names.push(GUIDANCE_BLENDING.into());
        out.cols.push(blending.collect());
    }
    if let Some(fixed) = Col::RATE.iter().map(|c| ts.fixed(*c)).collect::<Option<Vec<_>>>() {
        let norm = (0..ts.len()).map(|i| fixed.iter().map(|c| c[i] * c[i]).sum::<f64>().sqrt().to_degrees());
        out.names.push(RATE_NORM_DEG_S.into());
        out.cols.push(norm.collect());
    }
    out
}

/// The figures of a run: the paper-style attitude, CMG, torque and singularity plots,
/// and one figure per actuator family or environment present (figures whose columns are
/// absent are skipped).
pub fn figures() -> Vec<Figure> {
    figures_with(&ModeThresholds::default())
}

/// [`figures`], with the mode manager's thresholds drawn on `modes.png`.
pub fn figures_with(thresholds: &ModeThresholds) -> Vec<Figure> {
    let s = line;
    let rates = || Col::RATE.iter().zip(["ωx", "ωy", "ωz"]).map(|(c, l)| s(c.name(), l, false)).collect();
    let error = || log_panel("attitude error", "deg", vec![s(Col::Error.name(), "error", false)]);
    let euler = |i: usize, a: &str| {
        panel(a, "deg", vec![s(Col::EULER[i].name(), a, false), s(Col::EULER_TARGET[i].name(), "target", true)])
    };
    let torque = |i: usize, a: &str| {
        let applied = s(Col::APPLIED[i].name(), "applied", false);
        panel(&format!("{a} axis"), "N m", vec![applied, s(Col::DEMAND[i].name(), "demand", true)])
    };
    let gimbal_rates = (1..=4).map(|i| line(&format!("gimbal_rate{i}_rad_s"), &format!("dδ{i}/dt"), false)).collect();
    vec![
        figure(
            "attitude.png",
            "Euler angles and target",
            vec![euler(0, "roll"), euler(1, "pitch"), euler(2, "yaw"), error()],
        ),
        figure(
            "gimbals.png",
            "CMG gimbal angles and rates",
            vec![
                panel("gimbal angles δ", "deg", per_unit("gimbal", "deg", "δ", 4)),
                // dδ/dt, not δ̇: the embedded font's renderer does not compose the combining dot.
                // In deg/s, the unit of the scenario's `max_gimbal_rate_deg_s`.
                Panel {
                    y_scale: Some(180.0 / std::f64::consts::PI),
                    ..panel("commanded gimbal rates dδ/dt", "deg/s", gimbal_rates)
                },
            ],
        ),
        figure(
            "torque.png",
            "Control torque: demanded (dashed) and applied by the actuators",
            vec![torque(0, "x"), torque(1, "y"), torque(2, "z")],
        ),
        figure(
            "singularity.png",
            "Singularity measure m = det(J Jᵀ) and SR weight",
            vec![
                panel("singularity measure m", "(dimensionless)", vec![s("singularity_m", "m", false)]),
                panel("SR weight α", "(dimensionless)", vec![s("steering_alpha", "α", false)]),
            ],
        ),
        figure("rates.png", "Body rates", vec![panel("body rate", "rad/s", rates())]),
        modes_figure(thresholds),
    ]
    .into_iter()
    .chain(actuator_figures())
    .chain([
        estimation_figure(),
        environment_figure(),
        pointing_figure(),
        fdir_figure(),
        magnetometer_fdir_figure(),
        gnss_fdir_figure(),
    ])
    .collect()
}

/// `fdir.png` (runs with `[fdir.wheels]`): each wheel's torque residual against the
/// threshold (±), the wheels FDIR dropped and the faults in force, `faults[0]`'s window
/// shaded.
fn fdir_figure() -> Figure {
    let mut residuals = per_unit("wheel", "residual_nm", "r", 6);
    residuals.push(line("wheel_residual_threshold_nm", "threshold", true));
    let masks = vec![line("fdir_failed_wheels", "dropped by FDIR", false), line("fault_active", "injected", true)];
    Figure {
        requires: Some("wheel_residual_threshold_nm".into()),
        shade: Some(("fault_active".into(), "blue: a fault in force".into())),
        ..figure(
            "fdir.png",
            "Wheel FDIR: torque residual r = u − I_w (Δω_w + aᵀΔω)/Δt against its threshold",
            vec![
                panel("wheel torque residuals", "N m", residuals),
                panel("wheels dropped (bit i: wheel i+1) and faults in force (bit i: faults[i])", "(bit mask)", masks),
            ],
        )
    }
}

/// `fdir-magnetometer.png` (runs with `[fdir.magnetometer]`): the field-magnitude residual
/// and its threshold (the test is on the absolute value), and the faults in force.
fn magnetometer_fdir_figure() -> Figure {
    let residual = vec![
        line("mag_residual_t", "|B_meas| − |B_model|", false),
        line("mag_residual_threshold_t", "threshold", true),
    ];
    let masks = vec![line("fault_active", "injected", true)];
    Figure {
        requires: Some("mag_residual_threshold_t".into()),
        shade: Some(("fault_active".into(), "blue: a fault in force".into())),
        ..figure(
            "fdir-magnetometer.png",
            "Magnetometer FDIR: measured field magnitude against the on-board model",
            vec![
                panel("field magnitude residual", "T", residual),
                panel("faults in force (bit i: faults[i])", "(bit mask)", masks),
            ],
        )
    }
}

/// `fdir-gnss.png` (runs with `[fdir.gnss]`): each fix's distance from the last accepted
/// fix propagated to its time and the same for its velocity, their thresholds (log axes:
/// metres to thousands of km, cm/s to km/s), and the faults in force.
fn gnss_fdir_figure() -> Figure {
    let residual =
        vec![line("gnss_residual_m", "|r_fix − r_pred|", false), line("gnss_residual_threshold_m", "threshold", true)];
    let velocity = vec![
        line("gnss_velocity_residual_m_s", "|v_fix − v_pred|", false),
        line("gnss_velocity_residual_threshold_m_s", "threshold", true),
    ];
    let masks = vec![line("fault_active", "injected", true)];
    Figure {
        requires: Some("gnss_residual_threshold_m".into()),
        shade: Some(("fault_active".into(), "blue: a fault in force".into())),
        ..figure(
            "fdir-gnss.png",
            "GNSS FDIR: each fix against the last accepted one propagated to its time",
            vec![
                Panel { log_y: true, ..panel("position residual", "m", residual) },
                Panel { log_y: true, ..panel("velocity residual", "m/s", velocity) },
                panel("faults in force (bit i: faults[i])", "(bit mask)", masks),
            ],
        )
    }
}

/// `pointing.png` (runs with `[guidance]`): the truth's primary (boresight) and secondary
/// errors on log axes, the flight's commanded attitude against the truth's ideal one, and
/// the site's view of the spacecraft as a visibility strip (the mode ribbon on top with a
/// mode manager).
fn pointing_figure() -> Figure {
    let s = line;
    let visible = Panel {
        categories: vec![(0.0, "no".into()), (1.0, "yes".into())],
        presence: Presence::AnyFinite,
        ..panel(
            "site sees the spacecraft (truth, at or above the mask)",
            "visible",
            vec![s("target_visible", "visible", false)],
        )
    };
    Figure {
        requires: Some("pointing_primary_error_deg".into()),
        shade: Some((GUIDANCE_BLENDING.into(), "blue: pointing blend".into())),
        ..figure(
            "pointing.png",
            "Pointing (truth): boresight and secondary errors, guidance, visibility",
            vec![
                log_panel(
                    "primary (boresight) error: true primary axis to the true target direction",
                    "deg",
                    vec![s("pointing_primary_error_deg", "primary", false)],
                ),
                log_panel(
                    "secondary-axis error: true secondary axis to the ideal frame's",
                    "deg",
                    vec![s("pointing_secondary_error_deg", "secondary", false)],
                ),
                log_panel(
                    "flight's commanded attitude to the truth's ideal attitude (on-board models, navigation)",
                    "deg",
                    vec![s("guidance_error_deg", "guidance", false)],
                ),
                panel(
                    "elevation of the spacecraft above the site",
                    "deg",
                    vec![s("target_elevation_deg", "elevation", false)],
                ),
                visible,
            ],
        )
    }
}

/// The file of [`keepout_figure`] (drawn only for runs with keep-out cones).
pub const KEEPOUT_FIGURE: &str = "keepout.png";

/// The names `slew_phase` takes (docs/guidance.md, telemetry), for `keepout.png`.
const SLEW_PHASES: [&str; 6] = ["idle", "planning", "accelerating", "coasting", "decelerating", "refused"];

/// The legend label of a keep-out margin column (`keepout_<name>_<cone>_margin_deg`:
/// "name · Sun"), `None` for any other column.
fn keepout_label(column: &str) -> Option<String> {
    let rest = column.strip_prefix("keepout_")?;
    let (name, cone) = if let Some(n) = rest.strip_suffix("_sun_margin_deg") {
        (n, "Sun")
    } else {
        (rest.strip_suffix("_earth_margin_deg")?, "Earth")
    };
    Some(format!("{name} · {cone}"))
}

/// `keepout.png` (runs with `[[manoeuvre.keepout]]` cones; `None` otherwise): each
/// boresight's margin to each of its cones (truth, deg; negative inside) with the cone edge
/// at 0 and the flight's own margin of its command dashed, the slew phase, and the timeline
/// segment in force as a strip (with a `timeline_segment` column); eclipses shaded and the
/// mode ribbon as on every time figure. Built from the run's columns: the margin columns
/// are named by the scenario's boresights.
pub fn keepout_figure(ts: &TimeSeries) -> Option<Figure> {
    let mut margins: Vec<Series> =
        ts.names.iter().filter_map(|c| keepout_label(c).map(|l| line(c, &l, false))).collect();
    if margins.is_empty() {
        return None;
    }
    margins.push(line("keepout_margin_flight_deg", "flight: its command, smallest (on-board models)", true));
    let margin = Panel {
        thresholds: vec![(0.0, "cone edge (inside below)".into())],
        ..panel("margin of each boresight to each keep-out cone (truth): angle to the cone's edge", "deg", margins)
    };
    let phases = SLEW_PHASES.iter().enumerate().map(|(i, n)| (i as f64, n.to_string())).collect();
    let phase = Panel {
        categories: phases,
        ..panel("planned slew (flight)", "phase", vec![line("slew_phase", "phase", false)])
    };
    let mut panels = vec![margin, phase];
    // One category per segment the run reached (0: none yet); the recorded values are
    // whole numbers, at most the 16 segments a timeline holds.
    let last = ts.col("timeline_segment").map(|c| c.iter().filter(|v| v.is_finite()).fold(0.0f64, |m, v| m.max(*v)));
    if let Some(last) = last {
        let names = (0..=(last.clamp(0.0, 16.0) as usize))
            .map(|k| (k as f64, if k == 0 { "none".to_string() } else { format!("{k}") }))
            .collect();
        panels.push(Panel {
            categories: names,
            ..panel(
                "timeline segment in force (flight; [[timeline]] index + 1)",
                "segment",
                vec![line("timeline_segment", "segment", false)],
            )
        });
    }
    Some(figure(KEEPOUT_FIGURE, "Keep-out cones: boresight margins (truth), slews and the timeline", panels))
}

/// The figures of a run with these columns: [`figures_with`] and [`keepout_figure`].
pub fn figures_for(ts: &TimeSeries, thresholds: &ModeThresholds) -> Vec<Figure> {
    figures_with(thresholds).into_iter().chain(keepout_figure(ts)).collect()
}

/// `modes.png` (runs with a mode manager only): the mode as named levels, the errors and
/// the rate norm with the thresholds the mode manager compares them with.
fn modes_figure(t: &ModeThresholds) -> Figure {
    let s = line;
    let categories = plots::MODE_NAMES.iter().map(|(v, n)| (*v, n.to_string())).collect();
    let mode = Panel { categories, ..panel("flight mode", "mode", vec![s("mode", "mode", false)]) };
    let error = Panel {
        thresholds: t.error_deg.clone(),
        ..log_panel(
            "attitude error (flight's own estimate, and truth)",
            "deg",
            vec![s("flight_error_deg", "flight", false), s(Col::Error.name(), "truth", true)],
        )
    };
    let rate = Panel {
        thresholds: t.rate_deg_s.clone(),
        ..log_panel("body rate |ω| (truth)", "deg/s", vec![s(RATE_NORM_DEG_S, "|ω|", false)])
    };
    Figure {
        requires: Some("mode".into()),
        ..figure("modes.png", "Mode manager: mode, attitude error, body rate", vec![mode, error, rate])
    }
}

/// The figures of the DMCS law and the actuator families.
fn actuator_figures() -> Vec<Figure> {
    let s = line;
    let mut dipoles = xyz("dipole", "am2");
    dipoles.extend(xyz("dipole_cmd", "am2").into_iter().map(|x| Series {
        dashed: true,
        label: format!("{} cmd", x.label),
        ..x
    }));
    let current = wheel_columns("current_a");
    vec![
        figure(
            "adaptive.png",
            "DMCS adaptive feed-forward gains Δk_u",
            vec![panel("adaptive gain", "(dimensionless)", xyz_plain("adaptive_gain"))],
        ),
        figure(
            "wheels.png",
            "Reaction wheels",
            vec![
                panel("speed", "rpm", per_unit("wheel", "speed_rpm", "w", 6)),
                Panel {
                    presence: Presence::NonZeroIn(current.clone()),
                    ..panel("motor current", "A", per_unit("wheel", "current_a", "w", 6))
                },
                Panel {
                    presence: Presence::NonZeroIn(current.clone()),
                    ..panel("electrical power (eq 30; < 0 regenerating)", "W", per_unit("wheel", "power_w", "w", 6))
                },
                Panel {
                    presence: Presence::ZeroIn(current),
                    ..panel("mechanical power ω_w ḣ (ideal wheels)", "W", per_unit("wheel", "power_w", "w", 6))
                },
                panel("torque on the body", "N m", per_unit("wheel", "torque_nm", "w", 6)),
            ],
        ),
        figure(
            "momentum.png",
            "Momentum management: stored momentum (truth) and unloading torque",
            vec![
                panel("stored momentum, body axes", "N m s", xyz("h_body", "nms")),
                panel("stored momentum, inertial axes", "N m s", xyz("h_inertial", "nms")),
                Panel {
                    title_when: Some((
                        "mode".into(),
                        1.0,
                        "torquer torque m × B (B-dot while detumbling, unloading after)".into(),
                    )),
                    ..panel("torquer torque m × B (unloading)", "N m", xyz("torque_unload", "nm"))
                },
                panel("|h|", "N m s", vec![line("h_norm_nms", "|h|", false)]),
            ],
        ),
        figure(
            "magnetorquers.png",
            "Magnetorquer dipoles (commanded dashed) and field",
            vec![panel("dipole", "A m²", dipoles), panel("field in body axes", "T", xyz("b_body", "t"))],
        ),
        figure(
            "thrusters.png",
            "Thrusters",
            vec![
                panel("allocated level (PWPF input)", "(dimensionless)", per_unit("thruster", "level", "T", 12)),
                panel("propellant used", "kg", vec![s("propellant_kg", "propellant", false)]),
                step_panel("valve openings (all thrusters)", "pulses", vec![s("pulses_total", "pulses", false)]),
            ],
        ),
    ]
}

/// The on-board attitude determination against the truth.
fn estimation_figure() -> Figure {
    let s = line;
    figure(
        "estimation.png",
        "On-board attitude determination (MEKF) against the truth; σ: the filter's own (dashed)",
        vec![
            Panel {
                bands: vec!["est_error_deg".into()],
                ..log_panel(
                    "attitude error |δθ| (pale) and √tr Pθθ",
                    "deg",
                    vec![s("est_error_deg", "error", false), s("est_sigma_deg", "σ", true)],
                )
            },
            Panel {
                bands: vec!["est_bias_error_deg_h".into()],
                ..log_panel(
                    "gyro bias error |δb| (pale) and √tr Pbb",
                    "deg/h",
                    vec![s("est_bias_error_deg_h", "error", false), s("est_bias_sigma_deg_h", "σ", true)],
                )
            },
            Panel {
                thresholds: vec![(6.0, "mean of χ²₆".into())],
                bands: vec!["est_nees".into()],
                ..log_panel("NEES (pale; χ²₆: mean 6)", "(dimensionless)", vec![s("est_nees", "NEES", false)])
            },
            step_panel(
                "innovations rejected, filter restarts; samples refused (too old, future, out of order)",
                "count",
                vec![
                    s("est_rejected", "rejected", false),
                    s("est_resets", "restarts", false),
                    s("est_refused", "refused", true),
                ],
            ),
            model_panel(
                "age of each sensor's newest sample at the step",
                "s",
                vec![
                    s("est_age_gyro_s", "gyro", false),
                    s("est_age_tracker_s", "tracker", false),
                    s("est_age_sun_s", "Sun", false),
                    s("est_age_mag_s", "magnetometer", false),
                ],
            ),
            step_panel(
                "samples fused at their own time (late: carried forward through the history)",
                "count",
                vec![s("est_fused", "fused", false), s("est_fused_late", "fused late", true)],
            ),
        ],
    )
}

/// The environment torques (a panel per model that is on in the run).
fn environment_figure() -> Figure {
    figure(
        "environment.png",
        "Environment torques, body axes",
        vec![
            model_panel("gravity gradient", "N m", xyz("torque_gravity_gradient", "nm")),
            model_panel("aerodynamic drag", "N m", xyz("torque_drag", "nm")),
            model_panel("solar radiation pressure", "N m", xyz("torque_srp", "nm")),
            model_panel("magnetic (m × B)", "N m", xyz("torque_magnetic", "nm")),
            model_panel("rig pendulum and stops", "N m", xyz("torque_rig", "nm")),
            model_panel("external (scenario)", "N m", xyz("torque_external", "nm")),
        ],
    )
}

/// The file format of a run's time series.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Format {
    /// `timeseries.parquet` ([`crate::recorder::parquet`]).
    #[default]
    Parquet,
    /// `timeseries.csv` ([`crate::recorder::csv`]).
    Csv,
}

impl Format {
    /// The name of the time-series file in the output directory.
    pub const fn file_name(self) -> &'static str {
        match self {
            Format::Parquet => "timeseries.parquet",
            Format::Csv => "timeseries.csv",
        }
    }

    /// Estimated size of the time series of `rows` rows of `columns` columns, bytes (an
    /// upper bound: see [`CSV_BYTES_PER_VALUE`], [`PARQUET_BYTES_PER_VALUE`]).
    pub fn estimated_bytes(self, rows: u64, columns: usize) -> u64 {
        match self {
            Format::Csv => estimated_csv_bytes(rows, columns),
            Format::Parquet => rows
                .saturating_mul(columns as u64)
                .saturating_mul(PARQUET_BYTES_PER_VALUE)
                .saturating_add(PARQUET_FIXED_BYTES.saturating_add(columns as u64 * PARQUET_BYTES_PER_COLUMN)),
        }
    }
}

impl std::str::FromStr for Format {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "parquet" => Ok(Format::Parquet),
            "csv" => Ok(Format::Csv),
            _ => Err(format!("unknown format {s:?} (parquet | csv)")),
        }
    }
}

/// Estimated bytes of one CSV value: a full-precision value in Rust's shortest round-trip
/// form is ~20 characters (more for small magnitudes, which never use an exponent), plus
/// the separator.
pub const CSV_BYTES_PER_VALUE: u64 = 24;
/// Bytes of one Parquet value, uncompressed worst case: the 8 bytes of the double plus
/// one for the page headers and statistics (a page holds thousands of values).
pub const PARQUET_BYTES_PER_VALUE: u64 = 9;
/// Bytes of a Parquet file besides its values: magic, footer, metadata (the scenario text
/// included, ≤ 1 MiB), and per column and row group its schema entry and chunk metadata.
const PARQUET_FIXED_BYTES: u64 = 2 << 20;
const PARQUET_BYTES_PER_COLUMN: u64 = 4 << 10;
/// Headroom kept free besides the time series (summary, plots, the rest of the system).
pub const DISK_RESERVE_BYTES: u64 = 64 << 20;

/// Estimated size of `timeseries.csv`, bytes.
pub fn estimated_csv_bytes(rows: u64, columns: usize) -> u64 {
    rows.saturating_mul(columns as u64).saturating_mul(CSV_BYTES_PER_VALUE)
}

/// Free bytes for an unprivileged user on the filesystem of `dir` (which must exist).
pub fn free_bytes(dir: &Path) -> Result<u64> {
    fs4::available_space(dir).with_context(|| format!("free space of {}", dir.display()))
}

/// Refuses a run whose time series would not fit in `free` bytes (keeping
/// [`DISK_RESERVE_BYTES`]).
pub fn check_space(dir: &Path, format: Format, rows: u64, columns: usize, free: u64) -> Result<()> {
    let size = format.estimated_bytes(rows, columns);
    if size.saturating_add(DISK_RESERVE_BYTES) > free {
        bail!(
            "the run would record {rows} rows of {columns} columns (~{:.3} GB of {}, plus {:.3} GB kept \
             free) but {} has {:.3} GB free: raise timing.output_every or shorten duration_s",
            size as f64 / 1e9,
            format.file_name(),
            DISK_RESERVE_BYTES as f64 / 1e9,
            dir.display(),
            free as f64 / 1e9
        );
    }
    Ok(())
}

/// The files a run writes into its output directory, besides the figures (the time series
/// in either format).
pub const RUN_FILES: [&str; 3] = ["timeseries.parquet", "timeseries.csv", "summary.json"];

/// The files a margins measurement writes (`sim-host margins`, and `sim-host run` with
/// `[margins]`; `sim_host::margins::plots` draws the three figures).
pub const MARGIN_FILES: [&str; 4] = ["margins.json", "bode.png", "nyquist.png", "disk.png"];

/// Whether `name` is a temporary file [`crate::files::write_atomic`] (or the streamed time
/// series) leaves behind when its process is killed before the rename: `.NAME.tmp-…` of one
/// of `outputs`.
fn is_stale_temporary<'a>(name: &str, mut outputs: impl Iterator<Item = &'a str>) -> bool {
    name.strip_prefix('.')
        .and_then(|rest| rest.split_once(".tmp-"))
        .is_some_and(|(output, _)| outputs.any(|o| o == output))
}

/// Removes the files a previous run wrote into `dir` ([`RUN_FILES`], [`MARGIN_FILES`],
/// every figure of [`figures`] and [`KEEPOUT_FIGURE`]), and the temporaries of those files that a killed run left
/// (`.timeseries.parquet.tmp-…`: a run killed by SIGINT or SIGKILL never renames its
/// temporary); nothing else, and nothing when `dir` does not exist. Two runs into one
/// directory at once are not supported (each clears the other's outputs).
pub fn clear_previous(dir: &Path) -> Result<()> {
    let figures = figures();
    let names = RUN_FILES.iter().chain(&MARGIN_FILES).copied().chain(figures.iter().map(|f| f.file_name.as_str()));
    clear_files(dir, &names.chain([KEEPOUT_FIGURE]).collect::<Vec<_>>())
}

/// Removes `names` from `dir`, and their temporaries (see [`clear_previous`]); each error
/// names its file.
pub fn clear_files(dir: &Path, names: &[&str]) -> Result<()> {
    for name in names {
        crate::files::remove_if_present(&dir.join(name))?;
    }
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(e).with_context(|| format!("listing {} (for stale temporary files)", dir.display())),
    };
    for entry in entries {
        let entry = entry.with_context(|| format!("listing {} (for stale temporary files)", dir.display()))?;
        let name = entry.file_name();
        if name.to_str().is_some_and(|n| is_stale_temporary(n, names.iter().copied())) {
            crate::files::remove_if_present(&entry.path())?;
        }
    }
    Ok(())
}

/// A run's time series read back ([`read_run`]).
#[derive(Clone, Debug, Default)]
pub struct RunData {
    pub series: TimeSeries,
    /// The Parquet file's key-value metadata (empty for a CSV).
    pub metadata: BTreeMap<String, String>,
    /// Read from a `timeseries.csv`: its empty fields (NaN here) stand for NaN or ±∞
    /// ([`Equality::CsvBlank`]).
    pub from_csv: bool,
}

/// Reads a run's time series: a `timeseries.parquet` or `timeseries.csv` file, or a run's
/// output directory (its `timeseries.parquet`, else its `timeseries.csv`).
pub fn read_run(path: &Path) -> Result<RunData> {
    let file = if path.is_dir() {
        let parquet = path.join(Format::Parquet.file_name());
        let csv = path.join(Format::Csv.file_name());
        match (parquet.exists(), csv.exists()) {
            (true, _) => parquet,
            (false, true) => csv,
            (false, false) => bail!("{} has neither timeseries.parquet nor timeseries.csv", path.display()),
        }
    } else {
        path.to_path_buf()
    };
    match file.extension().and_then(|e| e.to_str()) {
        Some("parquet") => {
            let (series, metadata) = crate::recorder::parquet::read_parquet(&file)?;
            Ok(RunData { series, metadata, from_csv: false })
        }
        Some("csv") => {
            Ok(RunData { series: crate::recorder::csv::read_csv(&file)?, metadata: BTreeMap::new(), from_csv: true })
        }
        _ => bail!("{}: not a .parquet or .csv file", file.display()),
    }
}

/// When two recorded values are the same (`sim-host compare-series`, docs/outputs.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Equality {
    /// The same bits; any two NaNs are equal whatever their payload and sign (a NaN's
    /// payload is not a result), and a NaN equals nothing else: NaN ≠ +∞ ≠ −∞.
    Exact,
    /// As `Exact`, and a NaN on either side — a CSV's empty field, which the CSV writes for
    /// NaN and for both infinities — equals any non-finite value on the other.
    CsvBlank,
}

impl Equality {
    /// The rule for comparing two runs: `CsvBlank` when either was read from a CSV.
    pub fn of(a: &RunData, b: &RunData) -> Self {
        if a.from_csv || b.from_csv { Equality::CsvBlank } else { Equality::Exact }
    }
}

/// Whether two recorded values are the same under `rule` ([`Equality`]).
pub fn same_value(a: f64, b: f64, rule: Equality) -> bool {
    if a.is_nan() || b.is_nan() {
        return match rule {
            Equality::Exact => a.is_nan() && b.is_nan(),
            Equality::CsvBlank => !a.is_finite() && !b.is_finite(),
        };
    }
    a.to_bits() == b.to_bits()
}

/// The first difference between two time series (names, lengths, values by
/// [`same_value`] under [`Equality::Exact`]), `None` when they are the same.
pub fn first_difference(a: &TimeSeries, b: &TimeSeries) -> Option<String> {
    first_difference_by(a, b, Equality::Exact)
}

/// The first difference between two time series under `rule`, `None` when they are the
/// same.
pub fn first_difference_by(a: &TimeSeries, b: &TimeSeries, rule: Equality) -> Option<String> {
    if a.names != b.names {
        let i = a.names.iter().zip(&b.names).position(|(x, y)| x != y).unwrap_or(a.names.len().min(b.names.len()));
        let name = |n: &[String]| n.get(i).map_or("(none)".to_string(), Clone::clone);
        return Some(format!(
            "{} and {} columns, column {i} is {} and {}",
            a.names.len(),
            b.names.len(),
            name(&a.names),
            name(&b.names)
        ));
    }
    if a.len() != b.len() {
        return Some(format!("{} and {} rows", a.len(), b.len()));
    }
    for (name, (x, y)) in a.names.iter().zip(a.cols.iter().zip(&b.cols)) {
        if let Some(r) = x.iter().zip(y).position(|(p, q)| !same_value(*p, *q, rule)) {
            return Some(format!(
                "{name} row {r}: {:e} ({:#x}) and {:e} ({:#x})",
                x[r],
                x[r].to_bits(),
                y[r],
                y[r].to_bits()
            ));
        }
    }
    None
}

/// The open time-series file of a run.
enum Sink {
    Csv { file: BufWriter<File>, rows: CsvRows },
    Parquet(Box<ParquetStream<File>>),
}

/// The outputs of a run in `dir`: streams the time series ([`Format`]), keeps the plot
/// decimation, and on [`RunOutput::finish`] writes `summary.json` and the figures.
///
/// Before the first step ([`Recorder::start`]) the files a previous run left there
/// ([`RUN_FILES`] and every figure of [`figures`]; nothing else) are removed, so that a run
/// that then fails leaves no stale summary or figure beside its own output. The time series
/// is streamed into a hidden temporary file renamed to `timeseries.parquet` (or `.csv`) by
/// `finish` (removed if the run ends in an error); the summary and the figures are written
/// through a temporary file and a rename. Every error names its file.
pub struct RunOutput {
    dir: PathBuf,
    with_plots: bool,
    format: Format,
    metadata: RunMetadata,
    /// Free space to assume instead of asking the filesystem (tests).
    free_bytes: Option<u64>,
    sink: Option<Sink>,
    /// The temporary time-series file while the run goes (`None` once renamed or before
    /// the start).
    tmp: Option<PathBuf>,
    plot: Envelope,
    /// A recorded row with the derived plot columns appended ([`RATE_NORM_DEG_S`],
    /// [`GUIDANCE_BLENDING`]).
    plot_row: Vec<f64>,
    /// Index of `guidance_flags` in the recorded row (runs with guidance).
    flags_column: Option<usize>,
    /// The mode manager's thresholds for `modes.png`.
    thresholds: ModeThresholds,
}

impl RunOutput {
    /// Outputs in `dir`, the time series as Parquet (see [`RunOutput::format`]).
    pub fn new(dir: &Path, with_plots: bool) -> Self {
        Self {
            dir: dir.to_path_buf(),
            with_plots,
            format: Format::default(),
            metadata: RunMetadata::default(),
            free_bytes: None,
            sink: None,
            tmp: None,
            plot: Envelope::new(),
            plot_row: Vec::new(),
            flags_column: None,
            thresholds: ModeThresholds::default(),
        }
    }

    /// Draw the mode manager's `thresholds` on `modes.png`.
    pub fn mode_thresholds(mut self, thresholds: ModeThresholds) -> Self {
        self.thresholds = thresholds;
        self
    }

    /// Write the time series in `format`.
    pub fn format(mut self, format: Format) -> Self {
        self.format = format;
        self
    }

    /// The run's metadata (stored in the Parquet file).
    pub fn metadata(mut self, metadata: RunMetadata) -> Self {
        self.metadata = metadata;
        self
    }

    /// Assume `bytes` free on the output filesystem (instead of `statvfs`).
    pub fn assume_free_bytes(mut self, bytes: Option<u64>) -> Self {
        self.free_bytes = bytes;
        self
    }

    fn series_path(&self) -> PathBuf {
        self.dir.join(self.format.file_name())
    }

    /// Removes what a previous run wrote into the directory (see [`clear_previous`]).
    pub fn clear_previous(&self) -> Result<()> {
        clear_previous(&self.dir)
    }

    /// The context every figure of this run names (the scenario).
    fn figure_context(&self) -> FigureContext {
        FigureContext::new(&self.metadata.scenario)
    }

    /// The figures [`RunOutput::finish`] would draw from the rows recorded so far, as
    /// plans (tests inspect them; empty without plots).
    pub fn figure_plans(&self) -> Vec<plots::FigurePlan> {
        if !self.with_plots {
            return Vec::new();
        }
        let (ts, ctx) = (self.plot.series(), self.figure_context());
        figures_for(&ts, &self.thresholds).iter().filter_map(|f| plots::plan(&ts, f, &ctx)).collect()
    }

    /// Closes the time series, writes the summary and the figures; returns the files
    /// written.
    pub fn finish(mut self, summary: &Summary) -> Result<Vec<PathBuf>> {
        let series = self.series_path();
        let written = || format!("writing {}", series.display());
        match self.sink.take().context("the run recorded nothing")? {
            Sink::Csv { mut file, .. } => file.flush().with_context(written)?,
            Sink::Parquet(stream) => drop(stream.finish().with_context(written)?),
        }
        if let Some(tmp) = self.tmp.take() {
            crate::files::rename(&tmp, &series)?;
        }
        let json = self.dir.join("summary.json");
        crate::files::write_atomic(&json, (serde_json::to_string_pretty(summary)? + "\n").as_bytes())?;
        let mut files = vec![series, json];
        if self.with_plots {
            let ctx = self.figure_context();
            let ts = self.plot.series();
            let figs = figures_for(&ts, &self.thresholds);
            files.extend(plots::render(&self.dir, &ts, &figs, &ctx).context("rendering plots")?);
        }
        Ok(files)
    }

    /// Creates the temporary time-series file and writes its header.
    fn open_sink(&self, columns: &[String], tmp: &Path) -> Result<Sink> {
        let file = File::create(tmp)
            .with_context(|| format!("creating {} (for {})", tmp.display(), self.series_path().display()))?;
        Ok(match self.format {
            Format::Csv => {
                let mut file = BufWriter::with_capacity(1 << 16, file);
                writeln!(file, "{}", columns.join(","))?;
                Sink::Csv { file, rows: CsvRows::default() }
            }
            Format::Parquet => {
                Sink::Parquet(Box::new(ParquetStream::new(file, columns, self.metadata.key_values(columns)?)?))
            }
        })
    }
}

impl Drop for RunOutput {
    /// A run that ended in an error leaves no partial time series.
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            self.sink = None;
            let _ = std::fs::remove_file(tmp);
        }
    }
}

impl Recorder for RunOutput {
    fn start(&mut self, columns: &[String], rows: u64) -> Result<()> {
        let dir = &self.dir;
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let free = match self.free_bytes {
            Some(b) => b,
            None => free_bytes(dir)?,
        };
        check_space(dir, self.format, rows, columns.len(), free)?;
        self.clear_previous()?;
        let tmp = crate::files::temp_path(&self.series_path());
        self.tmp = Some(tmp.clone());
        let sink =
            self.open_sink(columns, &tmp).with_context(|| format!("writing {}", self.series_path().display()))?;
        self.sink = Some(sink);
        if self.with_plots {
            let mut plot_columns = columns.to_vec();
            plot_columns.push(RATE_NORM_DEG_S.into());
            plot_columns.push(GUIDANCE_BLENDING.into());
            self.flags_column = columns.iter().position(|c| c == "guidance_flags");
            self.plot.start(&plot_columns, rows)?;
        }
        Ok(())
    }

    fn record(&mut self, row: &[f64]) -> Result<()> {
        let written = match self.sink.as_mut().context("record before start")? {
            Sink::Csv { file, rows } => rows.write_row(file, row).map_err(anyhow::Error::from),
            Sink::Parquet(stream) => stream.push_row(row),
        };
        written.with_context(|| format!("writing {}", self.series_path().display()))?;
        if self.with_plots {
            self.plot_row.clear();
            self.plot_row.extend_from_slice(row);
            self.plot_row.push(rate_norm_deg_s(row));
            self.plot_row.push(guidance_blending(row, self.flags_column));
            self.plot.record(&self.plot_row)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `keepout.png` exists only with margin columns; its lines are the margin columns
    /// (named "boresight · cone") and the flight's, with the cone edge at 0; the timeline
    /// strip has one category per segment reached and "none".
    #[test]
    fn the_keepout_figure_draws_every_margin_column_and_the_segments_reached() {
        let names = ["t_s", "keepout_st_sun_margin_deg", "keepout_rad_earth_margin_deg", "keepout_margin_flight_deg"];
        let mut ts = TimeSeries::with_columns(names.iter().map(|n| n.to_string()).collect(), 3);
        for (t, m) in [(0.0, 10.0), (1.0, -2.0), (2.0, 5.0)] {
            ts.push_row(&[t, m, m + 20.0, m + 1.0]);
        }
        let mut without = ts.clone();
        without.names[1] = "st_sun_margin".into();
        without.names[2] = "keepout_rad_margin_deg".into();
        assert!(keepout_figure(&without).is_none(), "no margin column, no figure");
        assert!(keepout_figure(&ts).is_some_and(|f| f.panels.len() == 2), "no timeline column, no strip");
        ts.names.push("timeline_segment".into());
        ts.cols.push(vec![0.0, 2.0, 3.0]);
        let fig = keepout_figure(&ts).expect("a figure");
        let plan = plots::plan(&ts, &fig, &FigureContext::new("test")).expect("a plan");
        assert_eq!(plan.file_name, KEEPOUT_FIGURE);
        let margin = &plan.panels[0];
        let labels: Vec<&str> = margin.lines.iter().map(|l| l.label.as_str()).collect();
        assert_eq!(labels[..2], ["st · Sun", "rad · Earth"], "{labels:?}");
        assert_eq!(margin.lines.len(), 3, "{labels:?}");
        assert_eq!(margin.thresholds.first().map(|t| t.0), Some(0.0));
        let strip = plan.panels.iter().find(|p| p.title.starts_with("timeline segment")).expect("strip");
        assert_eq!(strip.categories, ["none", "1", "2", "3"]);
    }

    fn one(x: f64) -> TimeSeries {
        TimeSeries { names: vec!["v".into()], cols: vec![vec![x]] }
    }

    /// The comparison rule of `compare-series` (docs/outputs.md): bits, NaNs equal to each
    /// other whatever their payload, NaN ≠ ±∞, +∞ ≠ −∞, +0 ≠ −0; against a CSV an empty
    /// field (NaN) matches any non-finite value and nothing finite.
    #[test]
    fn values_are_equal_only_bit_for_bit_with_the_stated_nan_rule() {
        let quiet_payload = f64::from_bits(0x7ff8_0000_0000_0001);
        let negative_nan = f64::from_bits(0xfff8_0000_0000_0000);
        let (inf, ninf, nan) = (f64::INFINITY, f64::NEG_INFINITY, f64::NAN);
        for (a, b, exact, csv) in [
            (1.0, 1.0, true, true),
            (0.1 + 0.2, 0.3, false, false),
            (0.0, -0.0, false, false),
            (nan, quiet_payload, true, true),
            (nan, negative_nan, true, true),
            (nan, inf, false, true),
            (ninf, nan, false, true),
            (inf, ninf, false, false),
            (inf, inf, true, true),
            (nan, 0.0, false, false),
            (1e308, nan, false, false),
        ] {
            assert_eq!(same_value(a, b, Equality::Exact), exact, "{a:e} vs {b:e} exact");
            assert_eq!(same_value(b, a, Equality::Exact), exact, "symmetric");
            assert_eq!(same_value(a, b, Equality::CsvBlank), csv, "{a:e} vs {b:e} against a CSV");
            assert_eq!(first_difference(&one(a), &one(b)).is_none(), exact);
        }
    }

    /// A killed run's temporaries (`.NAME.tmp-PID-THREAD`) of a run output are removed with
    /// the previous run's outputs; other files (a user's, another tool's temporaries) stay.
    #[test]
    fn clearing_removes_the_outputs_and_the_stale_temporaries_of_killed_runs_only() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        let mine = [
            "summary.json",
            "margins.json",
            "bode.png",
            "disk.png",
            "attitude.png",
            ".timeseries.parquet.tmp-4242-ThreadId(1)",
            ".timeseries.csv.tmp-7-ThreadId(3)",
            ".margins.json.tmp-99-ThreadId(2)",
            ".summary.json.tmp-1-ThreadId(1)",
        ];
        let theirs = ["notes.txt", ".timeseries.parquet", ".other.json.tmp-1-ThreadId(1)", "timeseries.parquet.tmp-1"];
        for f in mine.iter().chain(&theirs) {
            std::fs::write(d.join(f), b"x").unwrap();
        }
        clear_previous(d).unwrap();
        let mut left: Vec<String> =
            std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        left.sort();
        let mut want: Vec<String> = theirs.iter().map(|s| s.to_string()).collect();
        want.sort();
        assert_eq!(left, want);
        clear_previous(&d.join("absent")).unwrap();
    }
}
