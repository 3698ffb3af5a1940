//! The truth of pointing (f64, the simulator's own models, docs/guidance.md "The truth"):
//! the directions a pointing is made of, from the true orbit state, the simulator's Sun
//! ephemeris and its Earth orientation (UT1 − UTC and polar motion:
//! [`EarthOrientation`]); the ideal two-vector attitude of a pointing; and how far the true
//! attitude is from it — the primary (boresight) error, the angle between the true
//! primary body axis and the true primary direction; the secondary error, the angle
//! between the true secondary body axis and the ideal frame's; the primary direction in
//! body axes; the site's visibility.
//!
//! Written apart from the flight's `acs_flight::guidance` (f32, its own GMST, Sun
//! almanac and two-body derivatives) so that the flight's simplifications show in the
//! errors instead of cancelling.

use super::frames::{EarthOrientation, geodetic_to_ecef, lat_height};
use crate::attitude::{Quat, Vec3};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion};

/// A direction of the truth (the scenario's `DirectionSpec`, resolved).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TruthDirection {
    Nadir,
    NadirGeodetic,
    Zenith,
    Velocity,
    AntiVelocity,
    OrbitNormal,
    AntiOrbitNormal,
    Sun,
    Ground(Site),
    /// A unit vector fixed in the simulator's ECI.
    Celestial(Vec3),
}

/// A geodetic site: its ITRF position and the ellipsoid's outward normal there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Site {
    pub itrf_m: Vec3,
    pub up_itrf: Vec3,
}

impl Site {
    /// WGS-84 geodetic latitude, longitude (rad) and height (m).
    pub fn geodetic(lat_rad: f64, lon_rad: f64, alt_m: f64) -> Self {
        let (sp, cp) = lat_rad.sin_cos();
        let (sl, cl) = lon_rad.sin_cos();
        Self { itrf_m: geodetic_to_ecef(lat_rad, lon_rad, alt_m), up_itrf: Vec3::new(cp * cl, cp * sl, sp) }
    }
}

impl TruthDirection {
    /// Right ascension and declination (rad) in the simulator's ECI.
    pub fn celestial(ra_rad: f64, dec_rad: f64) -> Self {
        let (sa, ca) = ra_rad.sin_cos();
        let (sd, cd) = dec_rad.sin_cos();
        Self::Celestial(Vec3::new(cd * ca, cd * sa, sd))
    }
}

/// The truth at one instant: the orbit state, the Sun and the Earth's orientation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sky {
    /// Position and velocity, ECI, m and m/s.
    pub r_m: Vec3,
    pub v_m_s: Vec3,
    /// The Sun's geocentric position, ECI, m.
    pub sun_m: Vec3,
    /// ITRF → ECI.
    pub itrf_to_eci: Matrix3<f64>,
}

impl Sky {
    pub fn new(t_s: f64, r_m: Vec3, v_m_s: Vec3, sun_m: Vec3, earth: &EarthOrientation) -> Self {
        Self { r_m, v_m_s, sun_m, itrf_to_eci: earth.itrf_to_eci(t_s) }
    }

    /// The unit direction `d` from the spacecraft, ECI (`None` when undefined: a zero
    /// vector).
    pub fn direction(&self, d: &TruthDirection) -> Option<Vec3> {
        let (r, v) = (self.r_m, self.v_m_s);
        let x = match d {
            TruthDirection::Nadir => -r,
            TruthDirection::NadirGeodetic => -self.geodetic_up(),
            TruthDirection::Zenith => r,
            TruthDirection::Velocity => v,
            TruthDirection::AntiVelocity => -v,
            TruthDirection::OrbitNormal => r.cross(&v),
            TruthDirection::AntiOrbitNormal => v.cross(&r),
            TruthDirection::Sun => self.sun_m - r,
            TruthDirection::Ground(site) => self.itrf_to_eci * site.itrf_m - r,
            TruthDirection::Celestial(u) => *u,
        };
        let n = x.norm();
        (n.is_finite() && n > 0.0).then(|| x / n)
    }

    /// The ellipsoid's outward normal through the spacecraft, ECI: the geodetic latitude of
    /// its ITRF position (iterated to 1e-15 rad, [`lat_height`]).
    fn geodetic_up(&self) -> Vec3 {
        let p = self.itrf_to_eci.transpose() * self.r_m;
        let (lat, _) = lat_height(p.x.hypot(p.y), p.z);
        let lon = p.y.atan2(p.x);
        let (sp, cp) = lat.sin_cos();
        self.itrf_to_eci * Vec3::new(cp * lon.cos(), cp * lon.sin(), sp)
    }

    /// The spacecraft's elevation above the site's horizon (the ellipsoid's tangent
    /// plane), rad.
    pub fn elevation_rad(&self, site: &Site) -> f64 {
        let up = self.itrf_to_eci * site.up_itrf;
        let los = self.r_m - self.itrf_to_eci * site.itrf_m;
        (up.dot(&los) / los.norm()).clamp(-1.0, 1.0).asin()
    }
}

/// A pointing of the truth, with its fallback state.
#[derive(Clone, Debug, PartialEq)]
pub struct TruthPointing {
    kind: TruthKind,
    /// Last good second axis of the ideal frame (ECI), for the near-parallel fallback.
    last_e2: Option<Vec3>,
}

#[derive(Clone, Debug, PartialEq)]
enum TruthKind {
    /// A fixed attitude relative to ECI or LVLH.
    Fixed {
        q_rel: Quat,
        lvlh: bool,
    },
    Align(Box<AlignTruth>),
}

#[derive(Clone, Debug, PartialEq)]
struct AlignTruth {
    primary_body: Vec3,
    secondary_body: Vec3,
    /// Body triad `[p̂, (p̂ × ŝ)^, p̂ × (p̂ × ŝ)^]` as columns.
    body: Matrix3<f64>,
    primary: TruthDirection,
    secondary: TruthDirection,
    sin_threshold: f64,
}

/// Triad of two directions as matrix columns: `[a, (a × b)^, a × (a × b)^]`; `None` when
/// they are parallel or zero.
fn triad(a: &Vec3, b: &Vec3) -> Option<Matrix3<f64>> {
    let e1 = a.try_normalize(0.0)?;
    let e2 = e1.cross(b).try_normalize(1e-300)?;
    Some(Matrix3::from_columns(&[e1, e2, e1.cross(&e2)]))
}

/// The truth's ideal attitude of one step and what the errors are measured against.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ideal {
    /// Body → ECI.
    pub q: Quat,
    /// Two-vector pointing: the primary direction (ECI), the primary and secondary body
    /// axes; `None` for a fixed attitude.
    pub axes: Option<IdealAxes>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdealAxes {
    pub primary_eci: Vec3,
    pub primary_body: Vec3,
    pub secondary_body: Vec3,
    /// The directions were within the threshold of parallel: the ideal frame holds the
    /// last good constraint (as the flight's documented fallback).
    pub parallel: bool,
}

/// The errors of a true attitude from an [`Ideal`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointingErrors {
    /// Angle between the true primary body axis and the primary direction, rad.
    pub primary_rad: f64,
    /// Angle between the true secondary body axis and the ideal frame's, rad.
    pub secondary_rad: f64,
    /// The primary direction in body axes (unit).
    pub target_body: Vec3,
    /// The boresight error as a rotation vector in body axes: about `p_B × t_B`, of the
    /// primary error's angle (perpendicular to the boresight).
    pub primary_vec_rad: Vec3,
}

impl TruthPointing {
    /// A fixed attitude (`q_rel` relative to ECI, or to LVLH).
    pub fn fixed(q_rel: Quat, lvlh: bool) -> Self {
        Self { kind: TruthKind::Fixed { q_rel, lvlh }, last_e2: None }
    }

    /// Two-vector pointing; `None` when the body axes are parallel or zero.
    pub fn align(
        primary_body: Vec3,
        primary: TruthDirection,
        secondary_body: Vec3,
        secondary: TruthDirection,
        threshold_rad: f64,
    ) -> Option<Self> {
        let body = triad(&primary_body, &secondary_body)?;
        let kind = TruthKind::Align(Box::new(AlignTruth {
            primary_body: primary_body.normalize(),
            secondary_body: secondary_body.normalize(),
            body,
            primary,
            secondary,
            sin_threshold: threshold_rad.sin(),
        }));
        Some(Self { kind, last_e2: None })
    }

    /// The ground site of the primary, if it is one.
    pub fn primary_site(&self) -> Option<Site> {
        match &self.kind {
            TruthKind::Align(a) => match a.primary {
                TruthDirection::Ground(s) => Some(s),
                _ => None,
            },
            _ => None,
        }
    }

    /// The ideal attitude now (`q_lvlh`: LVLH → ECI, for a fixed LVLH attitude). `None`
    /// when it cannot be defined (no orbit for a direction, a zero vector).
    pub fn ideal(&mut self, sky: Option<&Sky>, q_lvlh: Option<Quat>) -> Option<Ideal> {
        match &self.kind {
            TruthKind::Fixed { q_rel, lvlh } => {
                let frame = if *lvlh { q_lvlh? } else { Quat::identity() };
                Some(Ideal { q: frame * q_rel, axes: None })
            }
            TruthKind::Align(a) => {
                let AlignTruth { primary_body, secondary_body, body, primary, secondary, sin_threshold } = &**a;
                let dir = |d: &TruthDirection| match (d, sky) {
                    (TruthDirection::Celestial(u), _) => Some(*u),
                    (_, Some(s)) => s.direction(d),
                    (_, None) => None,
                };
                let p = dir(primary)?;
                let s = dir(secondary)?;
                let parallel = !(p.cross(&s).norm() >= *sin_threshold);
                // Near-parallel: the last good e₂ re-orthogonalised against p̂ stands in for
                // the secondary (before any, the ECI axis least aligned with p̂).
                let constraint = if parallel {
                    let held = self.last_e2.unwrap_or_else(|| least_aligned_axis(&p));
                    held.cross(&p)
                } else {
                    s
                };
                let e = triad(&p, &constraint)?;
                self.last_e2 = Some(e.column(1).into_owned());
                let r = Rotation3::from_matrix_unchecked(e * body.transpose());
                let q = *UnitQuaternion::from_rotation_matrix(&r).quaternion();
                let axes = IdealAxes {
                    primary_eci: p,
                    primary_body: *primary_body,
                    secondary_body: *secondary_body,
                    parallel,
                };
                Some(Ideal { q, axes: Some(axes) })
            }
        }
    }
}

/// A pointing gated by a site's visibility: `main` while the site sees the spacecraft at
/// least `min_elevation_rad` high, `otherwise` below.
#[derive(Clone, Debug, PartialEq)]
pub struct Gate {
    pub site: Site,
    pub min_elevation_rad: f64,
    pub otherwise: TruthPointing,
}

/// Which pointing of a set is in force.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Branch {
    Main,
    Otherwise,
}

/// The truth of one guidance table (`[guidance]`, a mode's or a command's).
#[derive(Clone, Debug, PartialEq)]
pub struct TruthSet {
    /// What the outputs call it.
    pub label: String,
    pub main: TruthPointing,
    pub gate: Option<Gate>,
}

/// The truth of one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthStep {
    /// `None` when the pointing in force cannot be defined this step.
    pub ideal: Option<Ideal>,
    pub branch: Branch,
    /// Elevation of the spacecraft above the gate's site (or the main primary's ground
    /// site), rad; `None` without one.
    pub elevation_rad: Option<f64>,
    /// The site sees the spacecraft (above the mask, or the horizon without a gate).
    pub visible: Option<bool>,
}

impl TruthSet {
    /// The branch in force by the truth's visibility, and its ideal attitude.
    pub fn step(&mut self, sky: Option<&Sky>, q_lvlh: Option<Quat>) -> TruthStep {
        let site = self.gate.as_ref().map(|g| g.site).or_else(|| self.main.primary_site());
        let elevation_rad = site.zip(sky).map(|(site, sky)| sky.elevation_rad(&site));
        let mask = self.gate.as_ref().map_or(0.0, |g| g.min_elevation_rad);
        let visible = elevation_rad.map(|e| e >= mask);
        let (branch, pointing) = match &mut self.gate {
            Some(g) if visible == Some(false) => (Branch::Otherwise, &mut g.otherwise),
            _ => (Branch::Main, &mut self.main),
        };
        TruthStep { ideal: pointing.ideal(sky, q_lvlh), branch, elevation_rad, visible }
    }
}

/// The truth's pointings of a run with `[guidance]`: the mission's (replaced by ground
/// commands), each mode's own, and the Earth orientation the directions use.
#[derive(Clone, Debug, PartialEq)]
pub struct TruthGuidance {
    pub mission: TruthSet,
    /// Indexed by `Mode::index()`; `None`: the mode points as the mission does.
    pub modes: Vec<Option<TruthSet>>,
    pub earth: EarthOrientation,
}

fn least_aligned_axis(p: &Vec3) -> Vec3 {
    let a = p.abs();
    if a.x <= a.y && a.x <= a.z {
        Vec3::x()
    } else if a.y <= a.z {
        Vec3::y()
    } else {
        Vec3::z()
    }
}

/// Angle between two unit vectors, accurate at every angle (`atan2(|a × b|, a · b)`).
pub fn angle_between(a: &Vec3, b: &Vec3) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

impl Ideal {
    /// The errors of the true attitude `q` (body → ECI); `None` for a fixed attitude.
    pub fn errors(&self, q: &Quat) -> Option<PointingErrors> {
        let a = self.axes?;
        let uq = UnitQuaternion::new_unchecked(*q);
        let target_body = uq.inverse_transform_vector(&a.primary_eci);
        let primary_rad = angle_between(&a.primary_body, &target_body);
        let ideal_secondary = UnitQuaternion::new_unchecked(self.q).transform_vector(&a.secondary_body);
        let secondary_rad = angle_between(&uq.transform_vector(&a.secondary_body), &ideal_secondary);
        let axis = a.primary_body.cross(&target_body);
        let primary_vec_rad = axis.try_normalize(1e-300).map_or(Vec3::zeros(), |u| u * primary_rad);
        Some(PointingErrors { primary_rad, secondary_rad, target_body, primary_vec_rad })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::environment::frames::{EarthRotation, WGS84_A};

    fn sky() -> Sky {
        let earth = EarthOrientation::of(EarthRotation::Simple { theta0_rad: 0.0 });
        let r = Vec3::new(WGS84_A + 500e3, 0.0, 0.0);
        Sky::new(0.0, r, Vec3::new(0.0, 7612.0, 0.0), Vec3::new(0.0, 0.0, 1.5e11), &earth)
    }

    /// Over the equator at longitude 0: nadir is −x, a site under the spacecraft sees it
    /// at 90°, a site 10° east of it along the equator sees it at the elevation of plane
    /// geometry on the sphere.
    #[test]
    fn directions_and_elevation_over_the_equator() {
        let s = sky();
        assert!((s.direction(&TruthDirection::Nadir).unwrap() + Vec3::x()).norm() < 1e-15);
        assert!((s.direction(&TruthDirection::NadirGeodetic).unwrap() + Vec3::x()).norm() < 1e-12);
        let below = Site::geodetic(0.0, 0.0, 0.0);
        assert!((s.elevation_rad(&below) - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
        let lam = 10f64.to_radians();
        let east = Site::geodetic(0.0, lam, 0.0);
        // Elevation e of a satellite at radius r seen from the surface R at central angle λ:
        // tan e = (cos λ − R/r) / sin λ.
        let (big_r, r) = (WGS84_A, WGS84_A + 500e3);
        let e = ((lam.cos() - big_r / r) / lam.sin()).atan();
        assert!((s.elevation_rad(&east) - e).abs() < 1e-12, "{} vs {e}", s.elevation_rad(&east));
    }

    /// The ideal frame puts the primary body axis on the primary direction and the
    /// secondary body axis in the half-plane of the secondary: a true attitude equal to it
    /// has zero errors; one turned by δ about the primary has a secondary error δ and a
    /// primary error 0; one turned by δ about a perpendicular axis has a primary error δ.
    #[test]
    fn errors_of_turned_attitudes_are_the_turn() {
        let mut p =
            TruthPointing::align(Vec3::z(), TruthDirection::Nadir, Vec3::x(), TruthDirection::Sun, 0.01).unwrap();
        let ideal = p.ideal(Some(&sky()), None).unwrap();
        let a = ideal.axes.unwrap();
        let q = UnitQuaternion::new_unchecked(ideal.q);
        assert!((q * Vec3::z() + Vec3::x()).norm() < 1e-15);
        // The Sun is along +z: the x body axis points there.
        assert!((q * Vec3::x() - Vec3::z()).norm() < 1e-12);
        let e0 = ideal.errors(&ideal.q).unwrap();
        assert!(e0.primary_rad < 1e-12 && e0.secondary_rad < 1e-12);
        let d = 0.01;
        let about = |axis: Vec3| *(q * UnitQuaternion::from_scaled_axis(axis * d)).quaternion();
        let e = ideal.errors(&about(Vec3::z())).unwrap();
        assert!(e.primary_rad < 1e-12 && (e.secondary_rad - d).abs() < 1e-12, "{e:?}");
        let e = ideal.errors(&about(Vec3::y())).unwrap();
        assert!((e.primary_rad - d).abs() < 1e-12 && (e.primary_vec_rad.norm() - d).abs() < 1e-12, "{e:?}");
        assert!(!a.parallel);
    }
}
