//! Orbit, environment models and the air-bearing rig of a scenario.

use super::{Scenario, bad, finite, parse_epoch, positive, yes};
use crate::attitude::Vec3;
use crate::environment::frames::{EarthOrientation, EarthRotation, MAX_POLAR_MOTION_ARCSEC, MAX_UT1_UTC_S};
use crate::environment::magnetic::{FieldModel, MagneticField};
use crate::environment::model::{Environment, FieldSource};
use crate::environment::orbit::{OrbitModel, OrbitPropagator, PropagatorOptions};
use crate::environment::torques::{
    Atmosphere, Disturbances, DragGeometry, DragModel, HarmonicTorque, Plate, SrpModel, box_plates,
};
use crate::plant::rig::Rig;
use anyhow::Result;
use serde::{Deserialize, Serialize};

/// Orbit elements, by kind.
#[derive(Clone, Debug, PartialEq)]
pub enum OrbitKind {
    Circular { altitude_km: f64, inclination_deg: f64, raan_deg: f64, arg_lat_deg: f64 },
    Kepler { a_km: f64, e: f64, inclination_deg: f64, raan_deg: f64, argp_deg: f64, true_anomaly_deg: f64 },
    Tle { line1: String, line2: String },
}

/// Orbit: `kind = "circular"` (altitude_km, inclination_deg, raan_deg, arg_lat_deg),
/// `"kepler"` (a_km, e, inclination_deg, raan_deg, argp_deg, true_anomaly_deg) or `"tle"`
/// (line1, line2).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OrbitSpec {
    pub kind: String,
    #[serde(default)]
    pub altitude_km: Option<f64>,
    #[serde(default)]
    pub a_km: Option<f64>,
    #[serde(default)]
    pub e: Option<f64>,
    #[serde(default)]
    pub inclination_deg: Option<f64>,
    #[serde(default)]
    pub raan_deg: f64,
    /// Circular: argument of latitude at t = 0.
    #[serde(default)]
    pub arg_lat_deg: f64,
    #[serde(default)]
    pub argp_deg: f64,
    #[serde(default)]
    pub true_anomaly_deg: f64,
    #[serde(default)]
    pub line1: Option<String>,
    #[serde(default)]
    pub line2: Option<String>,
    /// Numerical J2 propagation (circular/Kepler).
    #[serde(default)]
    pub j2: bool,
    /// UTC epoch of t = 0, "YYYY-MM-DDThh:mm:ss" (Earth rotation, WMM date, Sun).
    #[serde(default = "default_epoch")]
    pub epoch_utc: String,
    /// UT1 − UTC of the truth's Earth rotation for ground sites, s (the magnetic field
    /// keeps UTC).
    #[serde(default)]
    pub ut1_utc_s: f64,
    /// Polar motion `[x_p, y_p]` of the truth's terrestrial frame for ground sites, arcsec.
    #[serde(default)]
    pub polar_motion_arcsec: [f64; 2],
}

impl OrbitSpec {
    /// The elements of the chosen kind, or an error naming the missing key.
    pub fn elements(&self) -> Result<OrbitKind> {
        let need = |k: &str, v: Option<f64>| {
            v.ok_or_else(|| bad(&format!("orbit.{k}"), format!("required for kind = {:?}", self.kind)))
        };
        Ok(match self.kind.as_str() {
            "circular" => OrbitKind::Circular {
                altitude_km: need("altitude_km", self.altitude_km)?,
                inclination_deg: need("inclination_deg", self.inclination_deg)?,
                raan_deg: self.raan_deg,
                arg_lat_deg: self.arg_lat_deg,
            },
            "kepler" => OrbitKind::Kepler {
                a_km: need("a_km", self.a_km)?,
                e: need("e", self.e)?,
                inclination_deg: need("inclination_deg", self.inclination_deg)?,
                raan_deg: self.raan_deg,
                argp_deg: self.argp_deg,
                true_anomaly_deg: self.true_anomaly_deg,
            },
            "tle" => OrbitKind::Tle {
                line1: self.line1.clone().ok_or_else(|| bad("orbit.line1", "required for kind = \"tle\""))?,
                line2: self.line2.clone().ok_or_else(|| bad("orbit.line2", "required for kind = \"tle\""))?,
            },
            other => {
                return Err(bad(
                    "orbit.kind",
                    format!("unknown kind {other:?} (known: \"circular\", \"kepler\", \"tle\")"),
                ));
            }
        })
    }
}

fn default_epoch() -> String {
    "2026-01-01T00:00:00".into()
}

/// Environment models.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentSpec {
    /// "none", "dipole" (tilted dipole) or "wmm" (World Magnetic Model), along the orbit.
    #[serde(default = "default_field")]
    pub magnetic_field: String,
    /// A constant field in the reference (lab) frame, T — for rigs without an orbit.
    #[serde(default)]
    pub lab_field_t: Option<[f64; 3]>,
    #[serde(default = "yes")]
    pub gravity_gradient: bool,
    /// "none", "exponential" (Vallado table) or a fixed density via `density_kg_m3`.
    #[serde(default = "default_atmosphere")]
    pub atmosphere: String,
    #[serde(default)]
    pub density_kg_m3: Option<f64>,
    /// Solar radiation pressure on the `box_m` plates.
    #[serde(default)]
    pub solar_pressure: bool,
}

impl Default for EnvironmentSpec {
    fn default() -> Self {
        Self {
            magnetic_field: default_field(),
            lab_field_t: None,
            gravity_gradient: true,
            atmosphere: default_atmosphere(),
            density_kg_m3: None,
            solar_pressure: false,
        }
    }
}

fn default_field() -> String {
    "dipole".into()
}
fn default_atmosphere() -> String {
    "none".into()
}

/// Air-bearing rig.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RigSpec {
    /// "paper003" (m g r of eq 28, ±40° roll and pitch) or "paper000" (no pendulum term
    /// given, ±45° roll and pitch); explicit keys below override the preset.
    #[serde(default)]
    pub preset: Option<String>,
    /// `m g r`, body axes, N m (paper 003 eq 28: [-0.004, -0.001, 0.5]).
    #[serde(default)]
    pub mgr_nm: Option<[f64; 3]>,
    #[serde(default)]
    pub roll_limit_deg: Option<f64>,
    #[serde(default)]
    pub pitch_limit_deg: Option<f64>,
    /// Air-bearing friction per body axis: viscous, N m s, and (smoothed) Coulomb, N m.
    #[serde(default)]
    pub viscous_friction_nms: [f64; 3],
    #[serde(default)]
    pub coulomb_friction_nm: [f64; 3],
}

impl RigSpec {
    /// `[rig]`, checked (errors naming the key) and built in one place: the preset's
    /// pendulum term and travel stops, overridden by the keys given.
    pub fn rig(&self) -> Result<Rig> {
        let base = match self.preset.as_deref() {
            Some("paper003") => Rig::paper003().1,
            Some("paper000") => Rig::paper000(),
            Some(p) => {
                return Err(bad("rig.preset", format!("unknown preset {p:?} (known: \"paper003\", \"paper000\")")));
            }
            None if self.mgr_nm.is_none() => return Err(bad("rig.mgr_nm", "required without a preset")),
            None => Rig::free(),
        };
        finite("rig.mgr_nm", &self.mgr_nm.unwrap_or_default())?;
        for (k, l) in [("rig.roll_limit_deg", self.roll_limit_deg), ("rig.pitch_limit_deg", self.pitch_limit_deg)] {
            if let Some(l) = l {
                positive(k, l)?;
            }
        }
        for (k, v) in [
            ("rig.viscous_friction_nms", self.viscous_friction_nms),
            ("rig.coulomb_friction_nm", self.coulomb_friction_nm),
        ] {
            if v.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                return Err(bad(k, "must be finite and >= 0"));
            }
        }
        Ok(Rig {
            viscous_nms: Vec3::from(self.viscous_friction_nms),
            coulomb_nm: Vec3::from(self.coulomb_friction_nm),
            mgr_nm: self.mgr_nm.map_or(base.mgr_nm, Vec3::from),
            roll_limit_rad: self.roll_limit_deg.map(f64::to_radians).or(base.roll_limit_rad),
            pitch_limit_rad: self.pitch_limit_deg.map(f64::to_radians).or(base.pitch_limit_rad),
        })
    }
}

impl Scenario {
    /// The environment of the run (`None`: free space without a field, or a rig without one).
    pub fn environment(&self) -> Result<Option<Environment>> {
        let sc = &self.spacecraft;
        let inertia = self.inertia();
        let external = match &sc.harmonic_torque {
            Some(h) => HarmonicTorque {
                a: Vec3::zeros(),
                b: Vec3::from(h.amplitude_nm),
                omega: Vec3::from(h.frequency_hz) * std::f64::consts::TAU,
                phi: Vec3::from(h.phase_rad),
            },
            None => HarmonicTorque::default(),
        };
        let plates = sc.box_m.map(|b| box_plates(b[0], b[1], b[2], Vec3::zeros()));
        let env = &self.environment;
        let Some(o) = &self.orbit else {
            if env.lab_field_t.is_none() && sc.harmonic_torque.is_none() {
                return Ok(None);
            }
            let disturbances = Disturbances {
                inertia,
                gravity_gradient: false,
                drag: None,
                srp: None,
                residual_dipole_am2: Vec3::zeros(),
                external,
            };
            let field = env.lab_field_t.map_or(FieldSource::None, |b| FieldSource::Fixed(Vec3::from(b)));
            return Ok(Some(Environment {
                orbit: None,
                earth: EarthRotation::Simple { theta0_rad: 0.0 },
                field,
                disturbances,
            }));
        };
        let (model, jd) = o.checked()?;
        let prop = OrbitPropagator::new(&model, PropagatorOptions { j2: o.j2, step_s: 10.0 })
            .map_err(|e| bad("orbit", format!("{e:?}")))?;
        // A TLE brings its own epoch.
        let jd = prop.epoch_jd_utc().unwrap_or(jd);
        let earth = EarthRotation::Gmst { jd_ut1_epoch: jd };
        let field = match env.magnetic_field.as_str() {
            "dipole" => FieldSource::Model(MagneticField::new(FieldModel::default_dipole(), earth)),
            "wmm" => FieldSource::Model(MagneticField::new(
                FieldModel::Wmm { decimal_year: 2000.0 + (jd - 2_451_544.5) / 365.25 },
                earth,
            )),
            _ => FieldSource::None,
        };
        let drag = self.drag_model(plates.as_ref());
        let srp = match (&plates, env.solar_pressure) {
            (Some(p), true) => Some(SrpModel { plates: p.clone(), pressure_n_m2: 4.56e-6, jd_epoch: jd }),
            _ => None,
        };
        let disturbances = Disturbances {
            inertia,
            gravity_gradient: env.gravity_gradient,
            drag,
            srp,
            residual_dipole_am2: Vec3::zeros(),
            external,
        };
        Ok(Some(Environment { orbit: Some(prop), earth, field, disturbances }))
    }

    /// Drag: a reference area with a centre-of-pressure offset, or the box's plates; with
    /// an atmosphere (`None` without either).
    fn drag_model(&self, plates: Option<&Vec<Plate>>) -> Option<DragModel> {
        let (sc, env) = (&self.spacecraft, &self.environment);
        let geometry = match (sc.drag_area_m2, &plates) {
            (Some(a), _) => Some(DragGeometry::CopOffset { area_m2: a, cop_b: Vec3::from(sc.cp_offset_m) }),
            (None, Some(p)) => Some(DragGeometry::Plates((*p).clone())),
            _ => None,
        };
        let atmosphere = match env.atmosphere.as_str() {
            "exponential" => Some(Atmosphere::ExponentialVallado),
            "fixed" => env.density_kg_m3.map(|rho| Atmosphere::Fixed { rho_kg_m3: rho }),
            _ => None,
        };
        match (geometry, atmosphere) {
            (Some(geometry), Some(atmosphere)) => Some(DragModel { geometry, cd: sc.drag_coefficient, atmosphere }),
            _ => None,
        }
    }
}

/// The orbit model of `[orbit]` (circular, Kepler elements or TLE).
impl OrbitSpec {
    /// `[orbit]`, checked (errors naming the key) and built in one place: the orbit model
    /// and the epoch (Julian date, UTC).
    pub fn checked(&self) -> Result<(OrbitModel, f64)> {
        let kind = self.elements()?;
        match &kind {
            OrbitKind::Circular { altitude_km, inclination_deg, raan_deg, arg_lat_deg } => {
                positive("orbit.altitude_km", *altitude_km)?;
                finite("orbit", &[*inclination_deg, *raan_deg, *arg_lat_deg])?;
            }
            OrbitKind::Kepler { a_km, e, inclination_deg, raan_deg, argp_deg, true_anomaly_deg } => {
                if !(a_km.is_finite() && *a_km > 6378.137) {
                    return Err(bad("orbit.a_km", "must exceed the Earth's radius (6378.137 km)"));
                }
                if !(0.0..1.0).contains(e) {
                    return Err(bad("orbit.e", "must be in [0, 1)"));
                }
                if a_km * (1.0 - e) <= 6378.137 {
                    return Err(bad("orbit.e", "perigee below the Earth's surface"));
                }
                finite("orbit", &[*inclination_deg, *raan_deg, *argp_deg, *true_anomaly_deg])?;
            }
            OrbitKind::Tle { .. } => {}
        }
        let jd = parse_epoch(&self.epoch_utc).map_err(|e| bad("orbit.epoch_utc", e))?;
        self.earth_orientation(EarthRotation::Simple { theta0_rad: 0.0 })?;
        Ok((orbit_model(&kind), jd))
    }

    /// The truth's Earth orientation on `rotation` (`ut1_utc_s`, `polar_motion_arcsec`,
    /// checked naming the key).
    pub fn earth_orientation(&self, rotation: EarthRotation) -> Result<EarthOrientation> {
        let u = self.ut1_utc_s;
        if !(u.is_finite() && u.abs() <= MAX_UT1_UTC_S) {
            return Err(bad("orbit.ut1_utc_s", format!("|{u}| exceeds {MAX_UT1_UTC_S} s")));
        }
        let [xp, yp] = self.polar_motion_arcsec;
        if !([xp, yp].iter().all(|x| x.is_finite() && x.abs() <= MAX_POLAR_MOTION_ARCSEC)) {
            return Err(bad("orbit.polar_motion_arcsec", format!("each within ±{MAX_POLAR_MOTION_ARCSEC} arcsec")));
        }
        let arcsec = std::f64::consts::PI / (180.0 * 3600.0);
        Ok(EarthOrientation { rotation, ut1_utc_s: u, xp_rad: xp * arcsec, yp_rad: yp * arcsec })
    }
}

fn orbit_model(kind: &OrbitKind) -> OrbitModel {
    match kind {
        OrbitKind::Circular { altitude_km, inclination_deg, raan_deg, arg_lat_deg } => OrbitModel::Circular {
            altitude_m: altitude_km * 1e3,
            inclination_rad: inclination_deg.to_radians(),
            raan_rad: raan_deg.to_radians(),
            arg_lat0_rad: arg_lat_deg.to_radians(),
        },
        OrbitKind::Kepler { a_km, e, inclination_deg, raan_deg, argp_deg, true_anomaly_deg } => OrbitModel::Kepler {
            a_m: a_km * 1e3,
            e: *e,
            i: inclination_deg.to_radians(),
            raan: raan_deg.to_radians(),
            argp: argp_deg.to_radians(),
            nu0: true_anomaly_deg.to_radians(),
        },
        OrbitKind::Tle { line1, line2 } => OrbitModel::Tle { line1: line1.clone(), line2: line2.clone() },
    }
}
