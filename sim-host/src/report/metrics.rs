//! The numbers a run offers the outcome table: every numeric key of its summary (arrays as
//! `key[i]`, nested objects as `a.b`), and metrics derived from its time series that the
//! papers report but the summary does not carry.

use sim_core::recorder::series::TimeSeries;
use sim_core::runner::RunResult;
use std::collections::BTreeMap;

fn flatten(prefix: &str, v: &serde_json::Value, out: &mut BTreeMap<String, f64>) {
    match v {
        serde_json::Value::Number(n) => {
            out.insert(prefix.to_owned(), n.as_f64().unwrap_or(f64::NAN));
        }
        serde_json::Value::Null => {
            out.insert(prefix.to_owned(), f64::NAN);
        }
        serde_json::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                flatten(&format!("{prefix}[{i}]"), x, out);
            }
        }
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                flatten(&key, x, out);
            }
        }
        _ => {}
    }
}

/// Angle difference wrapped to (−180°, 180°].
fn wrap_deg(a: f64) -> f64 {
    let r = (a + 180.0).rem_euclid(360.0) - 180.0;
    if r == -180.0 { 180.0 } else { r }
}

/// Largest excursion of an Euler angle past its target, on the side opposite to where it
/// started (0 when it never crosses), deg: the overshoot of a step response.
pub fn overshoot_deg(angle: &[f64], target: &[f64]) -> f64 {
    let Some(e0) = angle.first().zip(target.first()).map(|(a, t)| wrap_deg(a - t)) else { return f64::NAN };
    let s = e0.signum();
    angle.iter().zip(target).map(|(a, t)| -s * wrap_deg(a - t)).fold(0.0, f64::max)
}

/// Largest per-axis Euler error |angle − target| from `t_from` on, deg (NaN if no row).
pub fn max_axis_error_from(ts: &TimeSeries, t_from: f64) -> f64 {
    let (Some(t), axes) = (ts.col("t_s"), ["roll", "pitch", "yaw"]) else { return f64::NAN };
    let mut worst = f64::NAN;
    for a in axes {
        let (Some(x), Some(r)) = (ts.col(&format!("{a}_deg")), ts.col(&format!("{a}_target_deg"))) else {
            return f64::NAN;
        };
        for ((&ti, &xi), &ri) in t.iter().zip(x).zip(r) {
            if ti >= t_from {
                worst = worst.max(wrap_deg(xi - ri).abs());
            }
        }
    }
    worst
}

/// Every number of a run: summary keys, then the derived metrics.
pub fn of_run(r: &RunResult) -> BTreeMap<String, f64> {
    let mut m = BTreeMap::new();
    if let Ok(v) = serde_json::to_value(&r.summary) {
        flatten("", &v, &mut m);
    }
    let ts = &r.series;
    for a in ["roll", "pitch", "yaw"] {
        if let (Some(x), Some(t)) = (ts.col(&format!("{a}_deg")), ts.col(&format!("{a}_target_deg"))) {
            m.insert(format!("overshoot_{a}_deg"), overshoot_deg(x, t));
        }
    }
    if let Some(c) = ts.col("singularity_m").filter(|c| !c.is_empty()) {
        m.insert("singularity_m_start".into(), c.first().copied().unwrap_or(f64::NAN));
        m.insert("singularity_m_max".into(), c.iter().copied().fold(f64::NAN, f64::max));
        m.insert("singularity_m_end".into(), c.last().copied().unwrap_or(f64::NAN));
    }
    // "After the first fifth": a 5-orbit run's orbits 2-5 (paper 003's "error < 15° over 5 orbits").
    m.insert("max_axis_error_after_first_fifth_deg".into(), max_axis_error_from(ts, r.summary.sim_time_s / 5.0));
    // Steady accuracy: RMS of the error over the last quarter of the run.
    if let (Some(t), Some(e)) = (ts.col("t_s"), ts.col("error_deg")) {
        let from = r.summary.sim_time_s * 0.75;
        let tail: Vec<f64> = t.iter().zip(e).filter(|(t, _)| **t >= from).map(|(_, e)| *e).collect();
        let rms = (tail.iter().map(|e| e * e).sum::<f64>() / tail.len() as f64).sqrt();
        m.insert("rms_error_last_quarter_deg".into(), rms);
    }
    m.insert("mode_transitions".into(), r.summary.mode_transitions.len() as f64);
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overshoot_of_a_damped_step() {
        // x(t) = 1 − e^{−ζωt}(cos ωd t + ζ/√(1−ζ²) sin ωd t): overshoot e^{−πζ/√(1−ζ²)}.
        let (z, wn) = (0.47_f64, 0.7_f64);
        let wd = wn * (1.0 - z * z).sqrt();
        let x: Vec<f64> = (0..20_000)
            .map(|i| {
                let t = f64::from(i) * 0.001;
                10.0 * (1.0 - (-z * wn * t).exp() * ((wd * t).cos() + z / (1.0 - z * z).sqrt() * (wd * t).sin()))
            })
            .collect();
        let target = vec![10.0; x.len()];
        let expected = 10.0 * (-std::f64::consts::PI * z / (1.0 - z * z).sqrt()).exp();
        assert!((overshoot_deg(&x, &target) - expected).abs() < 1e-6, "{}", overshoot_deg(&x, &target));
    }

    #[test]
    fn wraps_angles() {
        assert_eq!(wrap_deg(350.0), -10.0);
        assert_eq!(wrap_deg(-190.0), 170.0);
        assert_eq!(wrap_deg(180.0), 180.0);
        assert_eq!(overshoot_deg(&[-5.0, -2.0, 1.0, 0.0], &[0.0; 4]), 1.0);
    }
}
