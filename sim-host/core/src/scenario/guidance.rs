//! `[guidance]`: what the spacecraft points where, by two vectors or as a fixed attitude —
//! the alternative to `[target]` (docs/scenario.md, "[guidance]"; the flight side:
//! `acs_flight::guidance`, docs/guidance.md). Also per mode (`[modes.<mode>] guidance`)
//! and as a ground command (`[[commands]] guidance`, sent as `SetPointing`).
//!
//! ```toml
//! [guidance]
//! label = "target pass"
//! pointing = { primary_body = [0, 0, 1], primary = { ground = { lat_deg = 48.1, lon_deg = 11.6 } },
//!              secondary_body = [1, 0, 0], secondary = "sun" }
//! min_elevation_deg = 20.0                                   # the site sees the spacecraft above this
//! otherwise = { primary_body = [0, 0, 1], primary = "nadir", secondary_body = [1, 0, 0], secondary = "sun" }
//! transition_s = 60.0
//! feedforward = true
//! ```
//! Every value is checked here naming its key; the flight code's own validation of the
//! built [`GuidanceParams`] is the last line of defence.

use super::{AttitudeSpec, EulerSequence, RefFrame, bad, finite};
use crate::attitude::Vec3;
use crate::environment::guidance::{Gate, Site, TruthDirection, TruthPointing, TruthSet};
use acs_flight::params::{Direction, GuidanceParams, Pointing, TargetFrame, guidance as glim};
use anyhow::Result;
use serde::{Deserialize, Serialize};

/// A direction a body axis is pointed at (the flight's [`Direction`], in degrees).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum DirectionSpec {
    /// Towards the Earth's centre.
    Nadir,
    /// Down the WGS-84 ellipsoid normal through the spacecraft.
    NadirGeodetic,
    Zenith,
    Velocity,
    AntiVelocity,
    OrbitNormal,
    AntiOrbitNormal,
    Sun,
    /// A WGS-84 geodetic site on the rotating Earth.
    Ground {
        lat_deg: f64,
        lon_deg: f64,
        #[serde(default)]
        alt_m: f64,
    },
    /// A fixed inertial direction.
    Celestial {
        ra_deg: f64,
        dec_deg: f64,
    },
}

impl DirectionSpec {
    /// Every direction but a celestial one is computed from the orbit.
    pub fn needs_orbit(&self) -> bool {
        !matches!(self, Self::Celestial { .. })
    }

    fn validate(&self, key: &str) -> Result<()> {
        match *self {
            Self::Ground { lat_deg, lon_deg, alt_m } => {
                let k = |f: &str| format!("{key}.ground.{f}");
                finite(&k("lat_deg"), &[lat_deg])?;
                if !(-90.0..=90.0).contains(&lat_deg) {
                    return Err(bad(&k("lat_deg"), format!("{lat_deg} is outside [-90, 90]")));
                }
                if !(lon_deg.is_finite() && (-360.0..=360.0).contains(&lon_deg)) {
                    return Err(bad(&k("lon_deg"), format!("{lon_deg} is outside [-360, 360]")));
                }
                let (lo, hi) = glim::SITE_ALT_RANGE_M;
                if !(alt_m.is_finite() && (f64::from(lo)..=f64::from(hi)).contains(&alt_m)) {
                    return Err(bad(&k("alt_m"), format!("{alt_m} is outside [{lo}, {hi}] m")));
                }
            }
            Self::Celestial { ra_deg, dec_deg } => {
                let k = |f: &str| format!("{key}.celestial.{f}");
                if !(ra_deg.is_finite() && (-360.0..=360.0).contains(&ra_deg)) {
                    return Err(bad(&k("ra_deg"), format!("{ra_deg} is outside [-360, 360]")));
                }
                if !(dec_deg.is_finite() && (-90.0..=90.0).contains(&dec_deg)) {
                    return Err(bad(&k("dec_deg"), format!("{dec_deg} is outside [-90, 90]")));
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// The flight's direction (radians, f32).
    pub fn flight(&self) -> Direction {
        let r = |deg: f64| deg.to_radians() as f32;
        match *self {
            Self::Nadir => Direction::Nadir,
            Self::NadirGeodetic => Direction::NadirGeodetic,
            Self::Zenith => Direction::Zenith,
            Self::Velocity => Direction::Velocity,
            Self::AntiVelocity => Direction::AntiVelocity,
            Self::OrbitNormal => Direction::OrbitNormal,
            Self::AntiOrbitNormal => Direction::AntiOrbitNormal,
            Self::Sun => Direction::Sun,
            Self::Ground { lat_deg, lon_deg, alt_m } => {
                Direction::Ground { lat_rad: r(lat_deg), lon_rad: r(lon_deg), alt_m: alt_m as f32 }
            }
            Self::Celestial { ra_deg, dec_deg } => Direction::Celestial { ra_rad: r(ra_deg), dec_rad: r(dec_deg) },
        }
    }

    /// The truth's direction (f64 from the file's degrees).
    pub fn truth(&self) -> TruthDirection {
        match *self {
            Self::Nadir => TruthDirection::Nadir,
            Self::NadirGeodetic => TruthDirection::NadirGeodetic,
            Self::Zenith => TruthDirection::Zenith,
            Self::Velocity => TruthDirection::Velocity,
            Self::AntiVelocity => TruthDirection::AntiVelocity,
            Self::OrbitNormal => TruthDirection::OrbitNormal,
            Self::AntiOrbitNormal => TruthDirection::AntiOrbitNormal,
            Self::Sun => TruthDirection::Sun,
            Self::Ground { lat_deg, lon_deg, alt_m } => {
                TruthDirection::Ground(Site::geodetic(lat_deg.to_radians(), lon_deg.to_radians(), alt_m))
            }
            Self::Celestial { ra_deg, dec_deg } => TruthDirection::celestial(ra_deg.to_radians(), dec_deg.to_radians()),
        }
    }

    /// A short name for labels: `nadir`, `ground`, …
    pub fn name(&self) -> &'static str {
        match self {
            Self::Nadir => "nadir",
            Self::NadirGeodetic => "geodetic nadir",
            Self::Zenith => "zenith",
            Self::Velocity => "velocity",
            Self::AntiVelocity => "anti-velocity",
            Self::OrbitNormal => "orbit normal",
            Self::AntiOrbitNormal => "anti-normal",
            Self::Sun => "Sun",
            Self::Ground { .. } => "ground",
            Self::Celestial { .. } => "celestial",
        }
    }
}

/// One pointing as the file gives it: two-vector (`primary_body`, `primary`,
/// `secondary_body`, `secondary`) or a fixed attitude (`frame`, `euler_deg` or
/// `quaternion_xyzw`, `euler_sequence`: as `[target]`). Checked by [`PointingSpec::kind`].
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PointingSpec {
    #[serde(default)]
    pub primary_body: Option<[f64; 3]>,
    #[serde(default)]
    pub primary: Option<DirectionSpec>,
    #[serde(default)]
    pub secondary_body: Option<[f64; 3]>,
    #[serde(default)]
    pub secondary: Option<DirectionSpec>,
    #[serde(default)]
    pub frame: Option<RefFrame>,
    #[serde(default)]
    pub euler_deg: Option<[f64; 3]>,
    #[serde(default)]
    pub euler_sequence: Option<EulerSequence>,
    #[serde(default)]
    pub quaternion_xyzw: Option<[f64; 4]>,
}

/// A checked pointing.
#[derive(Clone, Debug, PartialEq)]
pub enum PointingKind {
    /// A fixed attitude in its frame.
    Fixed(AttitudeSpec),
    /// Two-vector pointing: unit body axes (normalised) and their directions.
    Align { primary_body: [f64; 3], primary: DirectionSpec, secondary_body: [f64; 3], secondary: DirectionSpec },
}

/// Largest |norm − 1| of a body axis in the file.
pub const AXIS_UNIT_TOL: f64 = 1e-6;

fn unit_axis(key: &str, a: &[f64; 3]) -> Result<[f64; 3]> {
    finite(key, a)?;
    let n = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    if !((n - 1.0).abs() <= AXIS_UNIT_TOL) {
        return Err(bad(key, format!("must be a unit vector (norm {n})")));
    }
    Ok(a.map(|x| x / n))
}

impl PointingSpec {
    fn is_align(&self) -> bool {
        self.primary_body.is_some()
            || self.primary.is_some()
            || self.secondary_body.is_some()
            || self.secondary.is_some()
    }

    fn is_fixed(&self) -> bool {
        self.frame.is_some()
            || self.euler_deg.is_some()
            || self.quaternion_xyzw.is_some()
            || self.euler_sequence.is_some()
    }

    /// The pointing, checked (`key`: its key, e.g. `guidance.pointing`): lengths, unit
    /// and distinct body axes, directions in range, an orbit for what needs one.
    pub fn kind(&self, key: &str, has_orbit: bool) -> Result<PointingKind> {
        match (self.is_align(), self.is_fixed()) {
            (true, true) => Err(bad(
                key,
                "give two-vector pointing (primary_body, primary, secondary_body, secondary) or a fixed attitude \
                 (frame, euler_deg / quaternion_xyzw), not both",
            )),
            (false, false) => Err(bad(
                key,
                "needs primary_body, primary, secondary_body, secondary (two-vector pointing) or frame with \
                 euler_deg / quaternion_xyzw (a fixed attitude)",
            )),
            (false, true) => {
                let a = AttitudeSpec {
                    frame: self.frame.unwrap_or_default(),
                    euler_deg: self.euler_deg,
                    euler_sequence: self.euler_sequence.unwrap_or_default(),
                    quaternion_xyzw: self.quaternion_xyzw,
                };
                a.validate(key)?;
                if a.frame == RefFrame::Lvlh && !has_orbit {
                    return Err(bad(&format!("{key}.frame"), "\"lvlh\" needs an [orbit]"));
                }
                Ok(PointingKind::Fixed(a))
            }
            (true, false) => self.align(key, has_orbit),
        }
    }

    fn align(&self, key: &str, has_orbit: bool) -> Result<PointingKind> {
        let k = |f: &str| format!("{key}.{f}");
        let need = |f: &str| bad(&k(f), "required for two-vector pointing");
        let p_body = unit_axis(&k("primary_body"), &self.primary_body.ok_or_else(|| need("primary_body"))?)?;
        let s_body = unit_axis(&k("secondary_body"), &self.secondary_body.ok_or_else(|| need("secondary_body"))?)?;
        let cross = [
            p_body[1] * s_body[2] - p_body[2] * s_body[1],
            p_body[2] * s_body[0] - p_body[0] * s_body[2],
            p_body[0] * s_body[1] - p_body[1] * s_body[0],
        ];
        let sin = cross.iter().map(|x| x * x).sum::<f64>().sqrt();
        let min_deg = f64::from(glim::MIN_BODY_AXES_ANGLE_RAD).to_degrees();
        // The flight's test is on f32 axes: a margin of 1e-4 keeps the two sides agreeing.
        if !(sin >= f64::from(glim::MIN_BODY_AXES_ANGLE_RAD).sin() * (1.0 + 1e-4)) {
            return Err(bad(
                &k("secondary_body"),
                format!("is (anti-)parallel to primary_body (within {min_deg:.0} deg): it constrains nothing"),
            ));
        }
        let primary = self.primary.clone().ok_or_else(|| need("primary"))?;
        let secondary = self.secondary.clone().ok_or_else(|| need("secondary"))?;
        for (f, d) in [("primary", &primary), ("secondary", &secondary)] {
            d.validate(&k(f))?;
            if d.needs_orbit() && !has_orbit {
                return Err(bad(&k(f), format!("{:?} is computed from the orbit: needs an [orbit]", d.name())));
            }
        }
        Ok(PointingKind::Align { primary_body: p_body, primary, secondary_body: s_body, secondary })
    }
}

impl PointingKind {
    /// The flight's pointing.
    pub fn flight(&self) -> Pointing {
        let f = |a: &[f64; 3]| a.map(|x| x as f32);
        match self {
            Self::Fixed(a) => {
                let q = a.quaternion();
                Pointing::Fixed {
                    q_xyzw: [q.i as f32, q.j as f32, q.k as f32, q.w as f32],
                    frame: match a.frame {
                        RefFrame::Inertial => TargetFrame::Inertial,
                        RefFrame::Lvlh => TargetFrame::Reference,
                    },
                }
            }
            Self::Align { primary_body, primary, secondary_body, secondary } => Pointing::Align {
                primary_body: f(primary_body),
                primary: primary.flight(),
                secondary_body: f(secondary_body),
                secondary: secondary.flight(),
            },
        }
    }

    /// The truth's pointing (`threshold_deg`: the near-parallel threshold).
    pub fn truth(&self, threshold_deg: f64) -> TruthPointing {
        match self {
            Self::Fixed(a) => TruthPointing::fixed(a.quaternion(), a.frame == RefFrame::Lvlh),
            Self::Align { primary_body, primary, secondary_body, secondary } => TruthPointing::align(
                Vec3::from(*primary_body),
                primary.truth(),
                Vec3::from(*secondary_body),
                secondary.truth(),
                threshold_deg.to_radians(),
            )
            // Checked: unit body axes at least 1° apart.
            .unwrap_or_else(|| TruthPointing::fixed(crate::attitude::Quat::identity(), false)),
        }
    }

    /// A label from the directions: "ground / Sun", "fixed (lvlh)".
    pub fn label(&self) -> String {
        match self {
            Self::Fixed(a) => format!("fixed ({})", if a.frame == RefFrame::Lvlh { "lvlh" } else { "inertial" }),
            Self::Align { primary, secondary, .. } => format!("{} / {}", primary.name(), secondary.name()),
        }
    }

    /// The ground site of a two-vector primary: (lat, lon, alt) in deg, deg, m.
    pub fn primary_site(&self) -> Option<(f64, f64, f64)> {
        match self {
            Self::Align { primary: DirectionSpec::Ground { lat_deg, lon_deg, alt_m }, .. } => {
                Some((*lat_deg, *lon_deg, *alt_m))
            }
            _ => None,
        }
    }
}

/// `[guidance]` (and a mode's or a command's `guidance`).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GuidanceSpec {
    /// What the pointing is called in the outputs (segments, figures); default: its
    /// directions.
    #[serde(default)]
    pub label: Option<String>,
    pub pointing: PointingSpec,
    /// With a ground primary: `pointing` while the site sees the spacecraft at least this
    /// high, `otherwise` below, deg.
    #[serde(default)]
    pub min_elevation_deg: Option<f64>,
    /// The pointing while the site does not see the spacecraft (with `min_elevation_deg`).
    #[serde(default)]
    pub otherwise: Option<PointingSpec>,
    /// A change of pointing is blended over this long, s (0: a step).
    #[serde(default)]
    pub transition_s: f64,
    /// Near-parallel primary and secondary directions hold the last good secondary
    /// constraint below this angle, deg.
    #[serde(default = "default_parallel_threshold")]
    pub parallel_threshold_deg: f64,
    /// UT1 − on-board clock uploaded to the flight code, s.
    #[serde(default)]
    pub ut1_minus_clock_s: f64,
    /// Feed the guided frame's angular acceleration forward as torque (quaternion feedback).
    #[serde(default)]
    pub feedforward: bool,
}

fn default_parallel_threshold() -> f64 {
    5.0
}

/// A checked guidance table.
#[derive(Clone, Debug, PartialEq)]
pub struct GuidanceSet {
    pub label: String,
    pub pointing: PointingKind,
    /// The gate (elevation mask, deg) and the pointing below it.
    pub gate: Option<(f64, PointingKind)>,
    pub parallel_threshold_deg: f64,
    pub params: GuidanceParams,
}

impl GuidanceSet {
    /// The truth of this table.
    pub fn truth(&self) -> TruthSet {
        let gate = self.gate.as_ref().and_then(|(e, o)| {
            let (lat, lon, alt) = self.pointing.primary_site()?;
            Some(Gate {
                site: Site::geodetic(lat.to_radians(), lon.to_radians(), alt),
                min_elevation_rad: e.to_radians(),
                otherwise: o.truth(self.parallel_threshold_deg),
            })
        });
        TruthSet { label: self.label.clone(), main: self.pointing.truth(self.parallel_threshold_deg), gate }
    }
}

impl GuidanceSpec {
    /// The table, checked naming each key (`key`: `guidance`, `modes.stabilise.guidance`,
    /// `commands[2].guidance`).
    pub fn resolve(&self, key: &str, has_orbit: bool) -> Result<GuidanceSet> {
        let k = |f: &str| format!("{key}.{f}");
        let pointing = self.pointing.kind(&k("pointing"), has_orbit)?;
        let gate = match (self.min_elevation_deg, &self.otherwise) {
            (Some(e), Some(o)) => {
                if !(e.is_finite() && (-90.0..=90.0).contains(&e)) {
                    return Err(bad(&k("min_elevation_deg"), format!("{e} is outside [-90, 90]")));
                }
                if pointing.primary_site().is_none() {
                    return Err(bad(
                        &k("min_elevation_deg"),
                        "an elevation mask gates a ground site: needs pointing.primary = { ground = { … } }",
                    ));
                }
                Some((e, o.kind(&k("otherwise"), has_orbit)?))
            }
            (Some(_), None) => return Err(bad(&k("otherwise"), "required with min_elevation_deg")),
            (None, Some(_)) => return Err(bad(&k("otherwise"), "only with min_elevation_deg (the gate)")),
            (None, None) => None,
        };
        let t = self.transition_s;
        if !(t.is_finite() && (0.0..=f64::from(glim::MAX_TRANSITION_S)).contains(&t)) {
            return Err(bad(&k("transition_s"), format!("{t} is outside [0, {}] s", glim::MAX_TRANSITION_S)));
        }
        let (lo, hi) = glim::PARALLEL_THRESHOLD_RANGE_RAD;
        let (lo, hi) = (f64::from(lo).to_degrees() * 1.0001, f64::from(hi).to_degrees() * 0.9999);
        let p = self.parallel_threshold_deg;
        if !(p.is_finite() && (lo..=hi).contains(&p)) {
            return Err(bad(&k("parallel_threshold_deg"), format!("{p} is outside [{lo:.3}, {hi:.3}] deg")));
        }
        let u = self.ut1_minus_clock_s;
        let max_u = f64::from(glim::MAX_UT1_OFFSET_S);
        if !(u.is_finite() && u.abs() <= max_u) {
            return Err(bad(&k("ut1_minus_clock_s"), format!("|{u}| exceeds {max_u} s")));
        }
        let params = GuidanceParams {
            pointing: pointing.flight(),
            min_elevation_rad: gate.as_ref().map(|(e, _)| e.to_radians() as f32),
            otherwise: gate.as_ref().map_or(Pointing::INERTIAL_IDENTITY, |(_, o)| o.flight()),
            transition_s: t as f32,
            parallel_threshold_rad: p.to_radians() as f32,
            ut1_minus_clock_s: u as f32,
            feedforward: self.feedforward,
        };
        params.validate().map_err(|e| super::limits::param_refusal(e, key))?;
        let label = self.label.clone().unwrap_or_else(|| pointing.label());
        Ok(GuidanceSet { label, pointing, gate, parallel_threshold_deg: p, params })
    }
}

#[cfg(test)]
mod tests {
    use super::super::Scenario;

    /// A wheel cubesat in orbit with two-vector pointing (ground target, Sun secondary)
    /// gated by elevation, nadir otherwise.
    pub const GUIDED: &str = r#"
name = "g"
duration_s = 10.0
[timing]
control_rate_hz = 2.0
dynamics_substeps = 4
[spacecraft]
inertia_kgm2 = [[0.04, 0, 0], [0, 0.04, 0], [0, 0, 0.01]]
[orbit]
kind = "circular"
altitude_km = 500.0
inclination_deg = 97.4
[initial]
euler_deg = [0, 0, 0]
[guidance]
pointing = { primary_body = [0, 0, 1], primary = { ground = { lat_deg = 10.0, lon_deg = 20.0 } }, secondary_body = [1, 0, 0], secondary = "sun" }
min_elevation_deg = 10.0
otherwise = { primary_body = [0, 0, 1], primary = "nadir", secondary_body = [1, 0, 0], secondary = "sun" }
transition_s = 30.0
[actuators.wheels]
layout = "axes"
axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
model = "ideal"
max_torque_nm = 2.3e-4
max_speed_rpm = 10000.0
inertia_kgm2 = 1.6e-6
[controller]
type = "quaternion_feedback"
zeta = 0.9
wn_rad_s = 0.1
"#;

    fn err_of(text: &str) -> String {
        format!("{:#}", Scenario::from_toml(text).unwrap_err())
    }

    #[test]
    fn a_guided_scenario_uploads_its_pointing() {
        let sc = Scenario::from_toml(GUIDED).unwrap();
        let g = sc.flight_params().unwrap().guidance;
        assert_eq!(g.min_elevation_rad, Some(10f64.to_radians() as f32));
        assert!(matches!(
            g.pointing,
            acs_flight::params::Pointing::Align { primary: acs_flight::params::Direction::Ground { .. }, .. }
        ));
        assert_eq!((g.transition_s, g.feedforward), (30.0, false));
        assert!((g.parallel_threshold_rad - 5f32.to_radians()).abs() < 1e-7);
    }

    /// Each refusal the issue lists, naming the key.
    #[test]
    fn impossible_pointings_are_refused_naming_the_key() {
        let cases = [
            ("lat_deg = 10.0", "lat_deg = 90.5", "guidance.pointing.primary.ground.lat_deg"),
            (
                "primary_body = [0, 0, 1], primary = {",
                "primary_body = [0, 0, 0], primary = {",
                "guidance.pointing.primary_body",
            ),
            (
                "primary_body = [0, 0, 1], primary = {",
                "primary_body = [0, 0, 2], primary = {",
                "guidance.pointing.primary_body",
            ),
            (
                "secondary_body = [1, 0, 0], secondary = \"sun\" }\nmin",
                "secondary_body = [0, 0, -1], secondary = \"sun\" }\nmin",
                "guidance.pointing.secondary_body",
            ),
            (
                "primary = { ground = { lat_deg = 10.0, lon_deg = 20.0 } }",
                "primary = \"zenith\"",
                "guidance.min_elevation_deg",
            ),
            ("min_elevation_deg = 10.0", "min_elevation_deg = 95.0", "guidance.min_elevation_deg"),
            ("min_elevation_deg = 10.0\n", "", "guidance.otherwise"),
            ("transition_s = 30.0", "transition_s = -1.0", "guidance.transition_s"),
            ("transition_s = 30.0", "parallel_threshold_deg = 60.0", "guidance.parallel_threshold_deg"),
            ("transition_s = 30.0", "ut1_minus_clock_s = 500.0", "guidance.ut1_minus_clock_s"),
            ("secondary = \"sun\" }\nmin", "secondary = \"sunn\" }\nmin", "sunn"),
            ("[initial]", "[target]\neuler_deg = [0, 0, 0]\n[initial]", "guidance"),
        ];
        for (from, to, key) in cases {
            let text = GUIDED.replacen(from, to, 1);
            assert_ne!(text, GUIDED, "{from}");
            let e = err_of(&text);
            assert!(e.contains(key), "expected {key} in: {e}");
        }
        // A pointing that needs an orbit, in a scenario without one.
        let no_orbit =
            GUIDED.replace("[orbit]\nkind = \"circular\"\naltitude_km = 500.0\ninclination_deg = 97.4\n", "");
        let e = err_of(&no_orbit);
        assert!(e.contains("guidance.pointing.primary") && e.contains("[orbit]"), "{e}");
        // … while a celestial pointing flies without one.
        let celestial = no_orbit
            .replace("primary = { ground = { lat_deg = 10.0, lon_deg = 20.0 } }", "primary = { celestial = { ra_deg = 10.0, dec_deg = -20.0 } }")
            .replace("secondary = \"sun\" }\nmin_elevation_deg = 10.0\notherwise = { primary_body = [0, 0, 1], primary = \"nadir\", secondary_body = [1, 0, 0], secondary = \"sun\" }", "secondary = { celestial = { ra_deg = 100.0, dec_deg = 0.0 } } }");
        Scenario::from_toml(&celestial).unwrap();
        let e = err_of(&celestial.replace("dec_deg = -20.0", "dec_deg = -91.0"));
        assert!(e.contains("guidance.pointing.primary.celestial.dec_deg"), "{e}");
    }

    #[test]
    fn orbit_earth_orientation_keys_are_checked() {
        let ok = GUIDED.replace(
            "inclination_deg = 97.4",
            "inclination_deg = 97.4\nut1_utc_s = -0.3\npolar_motion_arcsec = [0.1, 0.3]",
        );
        Scenario::from_toml(&ok).unwrap();
        let e = err_of(&ok.replace("ut1_utc_s = -0.3", "ut1_utc_s = 1.5"));
        assert!(e.contains("orbit.ut1_utc_s"), "{e}");
        let e = err_of(&ok.replace("[0.1, 0.3]", "[0.1, 3.0]"));
        assert!(e.contains("orbit.polar_motion_arcsec"), "{e}");
    }
}
