//! The page's JSON document: the run's identity and status, the decimation, the
//! spacecraft as the scene draws it (body box, actuator axes, sensor boresights and their
//! exclusion cones) and the channels.

use super::decimate::Selection;
use super::geometry::Source;
use super::layout::Channel;
use acs_flight::params::Mode;
use anyhow::Result;
use serde_json::{Value, json};
use sim_core::scenario::{Scenario, TargetConfig};
use std::collections::BTreeMap;
use std::path::Path;

/// Version of the document the page reads (tools/viewer/src/data.js checks it).
pub const FORMAT_VERSION: u32 = 1;
/// Longest side of the default body box, m, when the scenario gives neither `box_m` nor a
/// mass (the box then has the proportions of the inertia's uniform box).
pub const DEFAULT_BOX_SIDE_M: f64 = 1.0;

pub struct Inputs<'a> {
    pub run_dir: &'a Path,
    pub summary: Option<&'a Value>,
    pub scenario: Option<&'a Scenario>,
    pub metadata: &'a BTreeMap<String, String>,
    pub channels: &'a [Channel],
    pub rows_recorded: usize,
    pub selection: &'a Selection,
    pub geometry: &'a Source,
}

/// The document embedded in the page.
pub fn document(i: &Inputs) -> Result<Value> {
    let s = i.summary;
    let name = s
        .and_then(|s| s["scenario"].as_str())
        .or(i.metadata.get("scenario").map(String::as_str))
        .or(i.scenario.map(|sc| sc.name.as_str()))
        .unwrap_or("(unnamed run)");
    let status = s.and_then(|s| s["run_status"].as_str()).unwrap_or("unknown (no summary.json)");
    let modes: BTreeMap<String, &str> = Mode::ALL.iter().map(|m| (m.code().to_string(), m.name())).collect();
    Ok(json!({
        "format_version": FORMAT_VERSION,
        "scenario": name,
        "run_dir": i.run_dir.display().to_string(),
        "run_status": status,
        "failure": s.map(|s| failure_text(&s["failure"])).unwrap_or(Value::Null),
        "summary": s.map(|s| json!({
            "final_error_deg": s["final_error_deg"],
            "settle_time_s": s["settle_time_s"],
            "sim_time_s": s["sim_time_s"],
            "mode_transitions": s["mode_transitions"],
            "link": s["link"],
        })).unwrap_or(Value::Null),
        "decimation": {
            "rows_recorded": i.rows_recorded,
            "rows_kept": i.selection.rows.len(),
            "buckets": i.selection.buckets,
            "transition_rows": i.selection.transition_rows,
            "transition_rows_dropped": i.selection.transition_rows_dropped,
        },
        "geometry": { "source": format!("{:?}", i.geometry).to_lowercase(), "note": i.geometry.describe() },
        "target_frame": i.scenario.map(|sc| if TargetConfig::of(sc).lvlh { "lvlh" } else { "inertial" }),
        "modes": modes,
        "spacecraft": i.scenario.map(spacecraft).unwrap_or_else(|| json!({ "box_m": [1.0, 1.0, 1.0], "box_source": "default (no scenario)" })),
        "channels": i.channels.iter().map(Channel::encode).collect::<Vec<_>>(),
    }))
}

/// The summary's `failure` (untagged: `{"t_s", "quantity"}` or `{"reason"}`) as one line.
fn failure_text(f: &Value) -> Value {
    match f {
        Value::Null => Value::Null,
        Value::Object(m) => match (m.get("quantity"), m.get("t_s"), m.get("reason")) {
            (Some(Value::String(q)), Some(t), _) => Value::String(format!("diverged: {q} is not finite at t = {t} s")),
            (_, _, Some(Value::String(r))) => Value::String(r.clone()),
            _ => Value::String(f.to_string()),
        },
        other => Value::String(other.to_string()),
    }
}

/// The body box: `spacecraft.box_m`, else the uniform box of the diagonal inertia (real
/// size with `mass_kg`, else longest side [`DEFAULT_BOX_SIDE_M`]).
pub fn body_box(sc: &Scenario) -> ([f64; 3], &'static str) {
    if let Some(b) = sc.spacecraft.box_m {
        return (b, "spacecraft.box_m");
    }
    let j = sc.spacecraft.inertia_kgm2;
    let (ix, iy, iz) = (j[0][0], j[1][1], j[2][2]);
    // Uniform box: I_x = m (b² + c²) / 12, so a² = 6 (I_y + I_z - I_x) / m.
    let sq = [iy + iz - ix, ix + iz - iy, ix + iy - iz].map(|x| x.max(1e-12));
    match sc.spacecraft.mass_kg.filter(|m| *m > 0.0) {
        Some(m) => (sq.map(|x| (6.0 * x / m).sqrt()), "uniform box of the inertia and mass"),
        None => {
            let longest = sq.iter().copied().fold(0.0, f64::max).sqrt();
            (sq.map(|x| DEFAULT_BOX_SIDE_M * x.sqrt() / longest), "proportions of the inertia (no mass)")
        }
    }
}

/// The spacecraft as the scene draws it, body axes.
fn spacecraft(sc: &Scenario) -> Value {
    let (box_m, box_source) = body_box(sc);
    let wheels: Vec<Value> = sc
        .wheel_params()
        .map(|w| {
            w.iter()
                .map(|p| json!({ "axis": p.spin_axis, "max_speed_rpm": p.max_speed_rad_s * 30.0 / std::f64::consts::PI }))
                .collect()
        })
        .unwrap_or_default();
    let cmgs: Vec<Value> = sc
        .spacecraft()
        .ok()
        .and_then(|c| c.cmg)
        .map(|c| {
            c.units
                .iter()
                .map(|u| json!({ "gimbal": u.spin0.cross(&u.trans0).as_slice(), "spin0": u.spin0.as_slice(), "trans0": u.trans0.as_slice() }))
                .collect()
        })
        .unwrap_or_default();
    let rods: Vec<Value> = if sc.actuators.magnetorquers.is_some() {
        sc.magnetorquer_set().rods.iter().map(|r| json!({ "axis": r.axis, "max_am2": r.max_pos_am2 })).collect()
    } else {
        Vec::new()
    };
    let thrusters: Vec<Value> = sc
        .thruster_set()
        .map(|t| {
            t.thrusters
                .iter()
                .map(|s| json!({ "position_m": s.position_m, "direction": s.direction, "torque_only": s.torque_per_n_m.is_some() }))
                .collect()
        })
        .unwrap_or_default();
    json!({
        "box_m": box_m,
        "box_source": box_source,
        "wheels": wheels,
        "cmgs": cmgs,
        "magnetorquers": rods,
        "thrusters": thrusters,
        "boresights": boresights(sc),
    })
}

/// Sensor and instrument boresights, body axes, with their exclusion (keep-out) cones:
/// the star tracker's Sun and Earth-limb exclusions and the fine Sun sensor's field of
/// view. Issue 40's instrument boresights and issue 41's keep-out cones join this list.
fn boresights(sc: &Scenario) -> Vec<Value> {
    let mut v = Vec::new();
    if let Some(st) = &sc.sensors.star_tracker {
        v.push(json!({
            "name": "star tracker",
            "axis_body": st.boresight_body.unwrap_or([0.0, 0.0, 1.0]),
            "sun_exclusion_deg": st.sun_exclusion_deg,
            "earth_exclusion_deg": st.earth_exclusion_deg,
        }));
    }
    if let Some(s) = &sc.sensors.sun {
        v.push(json!({ "name": "sun sensor", "axis_body": s.boresight_body, "fov_deg": s.fov_half_angle_deg }));
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_box_has_the_inertia_of_a_uniform_box() {
        let text =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/paper000/test1.toml")).unwrap();
        let mut sc = Scenario::from_toml(&text).unwrap();
        sc.spacecraft.box_m = None;
        sc.spacecraft.mass_kg = Some(12.0);
        sc.spacecraft.inertia_kgm2 = [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.5]];
        let (b, _) = body_box(&sc);
        // Independent: the inertia of the box back from its sides.
        let m = 12.0;
        let i = [b[1] * b[1] + b[2] * b[2], b[0] * b[0] + b[2] * b[2], b[0] * b[0] + b[1] * b[1]].map(|x| m * x / 12.0);
        for (got, want) in i.iter().zip([1.0, 2.0, 2.5]) {
            assert!((got - want).abs() < 1e-12, "{i:?}");
        }
        sc.spacecraft.mass_kg = None;
        let (c, _) = body_box(&sc);
        assert!((c.iter().copied().fold(0.0, f64::max) - DEFAULT_BOX_SIDE_M).abs() < 1e-15);
        assert!((c[0] / c[1] - b[0] / b[1]).abs() < 1e-12);
    }

    #[test]
    fn failures_read_as_one_line() {
        let f = json!({ "t_s": 1.5, "quantity": "state.w" });
        assert_eq!(failure_text(&f), json!("diverged: state.w is not finite at t = 1.5 s"));
        assert_eq!(failure_text(&json!({ "reason": "every step refused" })), json!("every step refused"));
        assert_eq!(failure_text(&Value::Null), Value::Null);
    }
}
