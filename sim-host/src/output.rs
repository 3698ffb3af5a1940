//! Run outputs: `timeseries.csv`, `summary.json` and the PNG figures.

use crate::plots::{self, Figure, Panel, Series};
use crate::runner::RunResult;
use anyhow::{Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Column store of a run's recorded (decimated) samples. Every column has the same length.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TimeSeries {
    pub names: Vec<String>,
    pub cols: Vec<Vec<f64>>,
}

impl TimeSeries {
    pub fn with_columns(names: Vec<String>, capacity: usize) -> Self {
        let cols = names.iter().map(|_| Vec::with_capacity(capacity)).collect();
        Self { names, cols }
    }

    pub fn col(&self, name: &str) -> Option<&[f64]> {
        self.names.iter().position(|n| n == name).map(|i| self.cols[i].as_slice())
    }

    pub fn push_row(&mut self, row: &[f64]) {
        for (c, x) in self.cols.iter_mut().zip(row) {
            c.push(*x);
        }
    }

    pub fn len(&self) -> usize {
        self.cols.first().map_or(0, Vec::len)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// CSV with a header line; numbers in Rust's shortest round-trip form, NaN as empty.
    pub fn write_csv(&self, w: &mut impl Write) -> std::io::Result<()> {
        writeln!(w, "{}", self.names.join(","))?;
        let mut line = String::new();
        for r in 0..self.len() {
            line.clear();
            for (i, c) in self.cols.iter().enumerate() {
                if i > 0 {
                    line.push(',');
                }
                let x = c[r];
                if x.is_finite() {
                    line.push_str(&format!("{x}"));
                }
            }
            writeln!(w, "{line}")?;
        }
        Ok(())
    }
}

fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

/// One series per wheel / thruster (missing columns are skipped by the renderer).
fn per_unit(prefix: &str, quantity: &str, label: &str, n: usize) -> Vec<Series<'static>> {
    (1..=n)
        .map(|i| Series {
            column: leak(format!("{prefix}{i}_{quantity}")),
            label: leak(format!("{label}{i}")),
            dashed: false,
        })
        .collect()
}

fn xyz(prefix: &str, suffix: &str) -> Vec<Series<'static>> {
    ["x", "y", "z"]
        .iter()
        .map(|a| Series { column: leak(format!("{prefix}_{a}_{suffix}")), label: leak(a.to_string()), dashed: false })
        .collect()
}

fn xyz_plain(prefix: &str) -> Vec<Series<'static>> {
    ["x", "y", "z"]
        .iter()
        .map(|a| Series { column: leak(format!("{prefix}_{a}")), label: leak(a.to_string()), dashed: false })
        .collect()
}

/// The figures of a run: the paper-style attitude, CMG, torque and singularity plots,
/// and one figure per actuator family or environment present (figures whose columns are
/// absent are skipped).
pub fn figures() -> Vec<Figure<'static>> {
    let s = |column, label, dashed| Series { column, label, dashed };
    let panel = |title, y_label, series| Panel { title, y_label, series, log_y: false };
    vec![
        Figure {
            file_name: "attitude.png",
            title: "Euler angles and target",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![
                panel("roll", "deg", vec![s("roll_deg", "roll", false), s("roll_target_deg", "target", true)]),
                panel("pitch", "deg", vec![s("pitch_deg", "pitch", false), s("pitch_target_deg", "target", true)]),
                panel("yaw", "deg", vec![s("yaw_deg", "yaw", false), s("yaw_target_deg", "target", true)]),
                Panel {
                    title: "attitude error",
                    y_label: "deg",
                    series: vec![s("error_deg", "error", false)],
                    log_y: true,
                },
            ],
        },
        Figure {
            file_name: "gimbals.png",
            title: "CMG gimbal angles and rates",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![
                panel("gimbal angles", "deg", per_unit("gimbal", "deg", "δ", 4)),
                panel(
                    "commanded gimbal rates",
                    "rad/s",
                    (1..=4)
                        .map(|i| Series {
                            column: leak(format!("gimbal_rate{i}_rad_s")),
                            label: leak(format!("δ{i}")),
                            dashed: false,
                        })
                        .collect(),
                ),
            ],
        },
        Figure {
            file_name: "torque.png",
            title: "Control torque: demanded (dashed) and applied by the actuators",
            x: "t_s",
            x_label: "time [s]",
            panels: ["x", "y", "z"]
                .iter()
                .map(|a| {
                    panel(
                        leak(a.to_string()),
                        "N m",
                        vec![
                            Series { column: leak(format!("torque_applied_{a}_nm")), label: "applied", dashed: false },
                            Series { column: leak(format!("torque_demand_{a}_nm")), label: "demand", dashed: true },
                        ],
                    )
                })
                .collect(),
        },
        Figure {
            file_name: "singularity.png",
            title: "Singularity measure m = det(J Jᵀ) and SR weight",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![
                panel("singularity measure", "m", vec![s("singularity_m", "m", false)]),
                panel("SR weight α", "α", vec![s("steering_alpha", "α", false)]),
            ],
        },
        Figure {
            file_name: "rates.png",
            title: "Body rates",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![panel(
                "body rate",
                "rad/s",
                vec![s("rate_x_rad_s", "ωx", false), s("rate_y_rad_s", "ωy", false), s("rate_z_rad_s", "ωz", false)],
            )],
        },
        Figure {
            file_name: "modes.png",
            title: "Mode manager: mode, attitude error to the mission target, body rates",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![
                panel("mode: 1 detumble, 2 stabilise, 3 manoeuvre, 4 hold", "mode", vec![s("mode", "mode", false)]),
                Panel {
                    title: "attitude error",
                    y_label: "deg",
                    series: vec![s("error_deg", "error", false)],
                    log_y: true,
                },
                panel(
                    "body rate",
                    "rad/s",
                    vec![
                        s("rate_x_rad_s", "ωx", false),
                        s("rate_y_rad_s", "ωy", false),
                        s("rate_z_rad_s", "ωz", false),
                    ],
                ),
            ],
        },
        Figure {
            file_name: "adaptive.png",
            title: "DMCS adaptive feed-forward gains Δk_u",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![panel("adaptive gain", "-", xyz_plain("adaptive_gain"))],
        },
        Figure {
            file_name: "wheels.png",
            title: "Reaction wheels",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![
                panel("speed", "rpm", per_unit("wheel", "speed_rpm", "w", 6)),
                panel("motor current", "A", per_unit("wheel", "current_a", "w", 6)),
                panel("electrical power", "W", per_unit("wheel", "power_w", "w", 6)),
                panel("torque on the body", "N m", per_unit("wheel", "torque_nm", "w", 6)),
            ],
        },
        Figure {
            file_name: "magnetorquers.png",
            title: "Magnetorquer dipoles (commanded dashed) and field",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![
                panel("dipole", "A m²", {
                    let mut v = xyz("dipole", "am2");
                    v.extend(xyz("dipole_cmd", "am2").into_iter().map(|mut x| {
                        x.dashed = true;
                        x.label = leak(format!("{} cmd", x.label));
                        x
                    }));
                    v
                }),
                panel("field in body axes", "T", xyz("b_body", "t")),
            ],
        },
        Figure {
            file_name: "thrusters.png",
            title: "Thrusters",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![
                panel(
                    "allocated level (PWPF input)",
                    "-",
                    (1..=12)
                        .map(|i| Series {
                            column: leak(format!("thruster{i}_level")),
                            label: leak(format!("T{i}")),
                            dashed: false,
                        })
                        .collect(),
                ),
                panel("propellant used", "kg", vec![s("propellant_kg", "propellant", false)]),
                panel("valve openings (all thrusters)", "pulses", vec![s("pulses_total", "pulses", false)]),
            ],
        },
        Figure {
            file_name: "environment.png",
            title: "Environment torques, body axes",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![
                panel("gravity gradient", "N m", xyz("torque_gravity_gradient", "nm")),
                panel("aerodynamic drag", "N m", xyz("torque_drag", "nm")),
                panel("solar radiation pressure", "N m", xyz("torque_srp", "nm")),
                panel("magnetic (m × B)", "N m", xyz("torque_magnetic", "nm")),
                panel("rig pendulum and stops", "N m", xyz("torque_rig", "nm")),
            ],
        },
    ]
}

/// Write everything a run produces into `dir`; returns the files written.
pub fn write_all(dir: &Path, r: &RunResult, with_plots: bool) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let csv = dir.join("timeseries.csv");
    let mut w = std::io::BufWriter::new(std::fs::File::create(&csv)?);
    r.series.write_csv(&mut w)?;
    w.flush()?;
    let json = dir.join("summary.json");
    std::fs::write(&json, serde_json::to_string_pretty(&r.summary)? + "\n")?;
    let mut files = vec![csv, json];
    if with_plots {
        files.extend(plots::render(dir, &r.series, &figures()).context("rendering plots")?);
    }
    Ok(files)
}
