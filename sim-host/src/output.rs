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
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.cols[i].as_slice())
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

/// The paper-style figures of a CMG run.
pub fn figures() -> Vec<Figure<'static>> {
    let s = |column, label, dashed| Series {
        column,
        label,
        dashed,
    };
    vec![
        Figure {
            file_name: "attitude.png",
            title: "Euler angles and target",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![
                Panel {
                    title: "roll",
                    y_label: "deg",
                    series: vec![
                        s("roll_deg", "roll", false),
                        s("roll_target_deg", "target", true),
                    ],
                    log_y: false,
                },
                Panel {
                    title: "pitch",
                    y_label: "deg",
                    series: vec![
                        s("pitch_deg", "pitch", false),
                        s("pitch_target_deg", "target", true),
                    ],
                    log_y: false,
                },
                Panel {
                    title: "yaw",
                    y_label: "deg",
                    series: vec![
                        s("yaw_deg", "yaw", false),
                        s("yaw_target_deg", "target", true),
                    ],
                    log_y: false,
                },
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
                Panel {
                    title: "gimbal angles",
                    y_label: "deg",
                    series: (1..=4)
                        .map(|i| s(GIMBAL_DEG[i - 1], GIMBAL_LABEL[i - 1], false))
                        .collect(),
                    log_y: false,
                },
                Panel {
                    title: "commanded gimbal rates",
                    y_label: "rad/s",
                    series: (1..=4)
                        .map(|i| s(GIMBAL_RATE[i - 1], GIMBAL_LABEL[i - 1], false))
                        .collect(),
                    log_y: false,
                },
            ],
        },
        Figure {
            file_name: "torque.png",
            title: "Control torque: demanded (dashed) and realised by the cluster",
            x: "t_s",
            x_label: "time [s]",
            panels: (0..3)
                .map(|i| Panel {
                    title: AXIS_TITLE[i],
                    y_label: "N m",
                    series: vec![
                        s(TORQUE_APPLIED[i], "applied", false),
                        s(TORQUE_DEMAND[i], "demand", true),
                    ],
                    log_y: false,
                })
                .collect(),
        },
        Figure {
            file_name: "singularity.png",
            title: "Singularity measure m = det(J Jᵀ) and SR weight",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![
                Panel {
                    title: "singularity measure",
                    y_label: "m",
                    series: vec![s("singularity_m", "m", false)],
                    log_y: false,
                },
                Panel {
                    title: "SR weight α",
                    y_label: "α",
                    series: vec![s("steering_alpha", "α", false)],
                    log_y: false,
                },
            ],
        },
        Figure {
            file_name: "rates.png",
            title: "Body rates",
            x: "t_s",
            x_label: "time [s]",
            panels: vec![Panel {
                title: "body rate",
                y_label: "rad/s",
                series: vec![
                    s("rate_x_rad_s", "ωx", false),
                    s("rate_y_rad_s", "ωy", false),
                    s("rate_z_rad_s", "ωz", false),
                ],
                log_y: false,
            }],
        },
    ]
}

const GIMBAL_DEG: [&str; 4] = ["gimbal1_deg", "gimbal2_deg", "gimbal3_deg", "gimbal4_deg"];
const GIMBAL_RATE: [&str; 4] = [
    "gimbal_rate1_rad_s",
    "gimbal_rate2_rad_s",
    "gimbal_rate3_rad_s",
    "gimbal_rate4_rad_s",
];
const GIMBAL_LABEL: [&str; 4] = ["δ1", "δ2", "δ3", "δ4"];
const AXIS_TITLE: [&str; 3] = ["x", "y", "z"];
const TORQUE_APPLIED: [&str; 3] = [
    "torque_applied_x_nm",
    "torque_applied_y_nm",
    "torque_applied_z_nm",
];
const TORQUE_DEMAND: [&str; 3] = [
    "torque_demand_x_nm",
    "torque_demand_y_nm",
    "torque_demand_z_nm",
];

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
