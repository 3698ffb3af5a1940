//! The scene's inputs at each kept row (docs/viewer.md, "Geometry"): the commanded
//! attitude (the target ghost), and with an orbit the Sun and Earth directions, the
//! Earth's angular radius, the LVLH frame, the position, the Earth rotation angle and the
//! eclipse, all in ECI. Taken from the run's columns when it records them (issue 40's
//! `r_eci_*_m`, `v_eci_*_m_s`, `sun_eci_*`), else recomputed from the scenario in the
//! run's metadata with sim-core's own models: the orbit propagator of
//! `Scenario::environment` (the run's), `environment::torques::sun_position_eci` at
//! `Environment::julian_date` (the eclipse and SRP model's Sun), `frames::q_lvlh_to_eci`,
//! `EarthRotation::angle` and the cylindrical shadow of `in_shadow_cylindrical`.
//! Quaternions follow docs/conventions.md: scalar-last, body (or LVLH) → ECI.

use super::layout::{Channel, Dtype};
use anyhow::{Result, anyhow};
use sim_core::attitude::{Quat, Vec3, quat_from_euler};
use sim_core::environment::frames::q_lvlh_to_eci;
use sim_core::environment::orbit::R_E;
use sim_core::environment::torques::{in_shadow_cylindrical, sun_position_eci};
use sim_core::recorder::series::TimeSeries;
use sim_core::scenario::{Scenario, TargetConfig};

/// Where the orbit geometry came from (shown on the page and in docs/viewer.md).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Source {
    /// The run has no orbit (a lab rig, free space): no Sun, no Earth.
    None,
    /// Recorded columns (position, velocity, Sun).
    Columns,
    /// Recomputed from the scenario with sim-core's environment models.
    Scenario,
}

impl Source {
    pub fn describe(&self) -> &'static str {
        match self {
            Source::None => "no orbit: no Sun, Earth or LVLH in the scene",
            Source::Columns => "orbit, Sun and Earth from the run's recorded columns (r_eci, v_eci, sun_eci)",
            Source::Scenario => {
                "orbit, Sun and Earth recomputed from the scenario with sim-core's models (the run's orbit \
                 propagator, sun_position_eci, q_lvlh_to_eci, EarthRotation)"
            }
        }
    }
}

/// One row's orbit geometry, ECI.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitPoint {
    pub r_m: Vec3,
    /// Unit vector to the Sun.
    pub sun: Vec3,
    /// Unit vector to the Earth's centre (`-r/|r|`).
    pub earth: Vec3,
    /// Angular radius of the Earth seen from `r`, rad (`asin(R_E/|r|)`, spherical Earth).
    pub earth_radius_rad: f64,
    /// LVLH → ECI.
    pub q_lvlh: Quat,
    /// Earth rotation angle (ECI → ECEF about z), rad.
    pub earth_rotation_rad: f64,
    pub eclipse: bool,
}

/// The orbit geometry from a position, velocity and Sun vector (any length) at `t_s`.
pub fn orbit_point(r_m: Vec3, v_m_s: Vec3, sun: Vec3, earth_rotation_rad: f64) -> OrbitPoint {
    let rn = r_m.norm();
    OrbitPoint {
        r_m,
        sun: sun.normalize(),
        earth: -r_m / rn,
        earth_radius_rad: (R_E / rn).min(1.0).asin(),
        q_lvlh: *q_lvlh_to_eci(&r_m, &v_m_s).quaternion(),
        earth_rotation_rad,
        eclipse: in_shadow_cylindrical(&r_m, &sun),
    }
}

fn col3<'a>(ts: &'a TimeSeries, names: [&str; 3]) -> Option<[&'a [f64]; 3]> {
    Some([ts.col(names[0])?, ts.col(names[1])?, ts.col(names[2])?])
}

fn at(c: &[&[f64]; 3], i: usize) -> Vec3 {
    Vec3::new(c[0][i], c[1][i], c[2][i])
}

/// The orbit geometry at each kept row, and where it came from.
pub fn orbit(sc: Option<&Scenario>, ts: &TimeSeries, rows: &[usize]) -> Result<(Source, Vec<OrbitPoint>)> {
    let Some(mut env) = sc.map(Scenario::environment).transpose()?.flatten() else {
        return Ok((Source::None, Vec::new()));
    };
    if env.orbit.is_none() {
        return Ok((Source::None, Vec::new()));
    }
    let t = ts.col("t_s").ok_or_else(|| anyhow!("the time series has no t_s column"))?;
    let r_cols = col3(ts, ["r_eci_x_m", "r_eci_y_m", "r_eci_z_m"]);
    let v_cols = col3(ts, ["v_eci_x_m_s", "v_eci_y_m_s", "v_eci_z_m_s"]);
    let sun_cols = col3(ts, ["sun_eci_x", "sun_eci_y", "sun_eci_z"]);
    let recorded = r_cols.is_some() && v_cols.is_some() && sun_cols.is_some();
    let mut out = Vec::with_capacity(rows.len());
    for &i in rows {
        let t_s = t[i];
        let (r, v, sun) = match (&r_cols, &v_cols, &sun_cols) {
            (Some(r), Some(v), Some(s)) => (at(r, i), at(v, i), at(s, i)),
            _ => {
                let jd = env.julian_date(t_s);
                let prop = env.orbit.as_mut().ok_or_else(|| anyhow!("no orbit"))?;
                let (r, v) = prop.try_state_at(t_s).map_err(|e| anyhow!("orbit at t = {t_s} s: {e:?}"))?;
                (r, v, sun_position_eci(jd))
            }
        };
        out.push(orbit_point(r, v, sun, env.earth.angle(t_s)));
    }
    Ok((if recorded { Source::Columns } else { Source::Scenario }, out))
}

/// The commanded attitude (target ghost) at each kept row, body → ECI: the recorded target
/// Euler angles (`roll_target_deg` …, which follow ground commands) in the scenario's
/// sequence, in the scenario target's frame (LVLH from `orbit`, else inertial). `None`
/// when the run records no target.
pub fn target(sc: Option<&Scenario>, ts: &TimeSeries, rows: &[usize], orbit: &[OrbitPoint]) -> Option<Vec<Quat>> {
    let sc = sc?;
    let e = col3(ts, ["roll_target_deg", "pitch_target_deg", "yaw_target_deg"])?;
    let TargetConfig { seq, lvlh, .. } = TargetConfig::of(sc);
    if lvlh && orbit.len() != rows.len() {
        return None;
    }
    Some(
        rows.iter()
            .enumerate()
            .map(|(k, &i)| {
                let q_rel = quat_from_euler(at(&e, i).map(f64::to_radians).into(), seq);
                if lvlh { orbit[k].q_lvlh * q_rel } else { q_rel }
            })
            .collect(),
    )
}

/// The geometry as page channels (prefix `geo_`): ECI unit vectors to the Sun and the
/// Earth, the position, the Earth's angular radius and rotation angle, LVLH → ECI, the
/// eclipse, and the target ghost.
pub fn channels(orbit: &[OrbitPoint], target: Option<&[Quat]>) -> Vec<Channel> {
    let mut out = Vec::new();
    let mut put = |name: &str, unit: &str, dtype: Dtype, values: Vec<f64>| {
        out.push(Channel { name: name.into(), unit: unit.into(), dtype, values });
    };
    if !orbit.is_empty() {
        for (a, axis) in ["x", "y", "z"].iter().enumerate() {
            put(&format!("geo_sun_eci_{axis}"), "1", Dtype::F64, orbit.iter().map(|p| p.sun[a]).collect());
            put(&format!("geo_earth_eci_{axis}"), "1", Dtype::F64, orbit.iter().map(|p| p.earth[a]).collect());
            put(&format!("geo_r_eci_{axis}_m"), "m", Dtype::F32, orbit.iter().map(|p| p.r_m[a]).collect());
        }
        put("geo_earth_radius_rad", "rad", Dtype::F64, orbit.iter().map(|p| p.earth_radius_rad).collect());
        put("geo_earth_rotation_rad", "rad", Dtype::F64, orbit.iter().map(|p| p.earth_rotation_rad).collect());
        put("geo_eclipse", "1", Dtype::F32, orbit.iter().map(|p| f64::from(u8::from(p.eclipse))).collect());
        for (a, axis) in ["x", "y", "z", "w"].iter().enumerate() {
            put(&format!("geo_q_lvlh_{axis}"), "1", Dtype::F64, orbit.iter().map(|p| p.q_lvlh.coords[a]).collect());
        }
    }
    if let Some(q) = target {
        for (a, axis) in ["x", "y", "z", "w"].iter().enumerate() {
            put(&format!("geo_q_target_{axis}"), "1", Dtype::F64, q.iter().map(|q| q.coords[a]).collect());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orbit_point_from_a_circular_equatorial_state() {
        // r along x at 7000 km, v along y: LVLH z = nadir = -x, y = -orbit normal = -z,
        // x = along track = y (docs/conventions.md; frames::rot_lvlh_to_eci).
        let r = Vec3::new(7.0e6, 0.0, 0.0);
        let p = orbit_point(r, Vec3::new(0.0, 7.5e3, 0.0), Vec3::new(-1.5e11, 0.0, 0.0), 0.3);
        assert!((p.earth - Vec3::new(-1.0, 0.0, 0.0)).norm() < 1e-15);
        assert!((p.earth_radius_rad - (R_E / 7.0e6).asin()).abs() < 1e-15);
        assert!(p.eclipse, "behind the Earth from a Sun on -x");
        let m = |v: Vec3| p.q_lvlh * sim_core::attitude::Quat::from_imag(v) * p.q_lvlh.conjugate();
        assert!((m(Vec3::z()).imag() - Vec3::new(-1.0, 0.0, 0.0)).norm() < 1e-12, "LVLH z is nadir");
        assert!((m(Vec3::x()).imag() - Vec3::new(0.0, 1.0, 0.0)).norm() < 1e-12, "LVLH x is along track");
        assert!((m(Vec3::y()).imag() - Vec3::new(0.0, 0.0, -1.0)).norm() < 1e-12, "LVLH y is -orbit normal");
    }
}
