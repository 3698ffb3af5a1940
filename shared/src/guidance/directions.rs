//! The directions pointing is made of, computed on board from the flight code's own
//! navigation, clock and models, each with its first and second time derivatives
//! ([`VecKin`], inertial axes): nadir (geocentric and geodetic), zenith, orbit velocity and
//! anti-velocity, orbit normal and anti-normal, the Sun, a geodetic point on the rotating
//! Earth, and an inertial direction given by right ascension and declination.
//!
//! The frame is the flight code's inertial frame, the one its navigation positions and
//! star-tracker attitudes are given in (docs/guidance.md, "Frames"). The Earth turns in it
//! about z by the mean sidereal angle (IAU 1982) of UT1 = on-board time +
//! `ut1_minus_clock_s`; nutation and polar motion are omitted (their cost is in
//! docs/guidance.md, "Error budget"). The orbit is two-body: `a = −μ r/|r|³`,
//! `ȧ = −μ (v/|r|³ − 3 r (r·v)/|r|⁵)`, so derivatives ignore J2 (≈ 1e-3 of `a` in LEO).

use super::kinematics::VecKin;
use crate::math::f32m::{atan2, sin_cos, sqrt};
use crate::math::{Vec3, norm};
use crate::models::orbit::MU_EARTH_M3_S2;
use crate::models::sun::sun_direction_eci;
use crate::models::time::{J2000Time, ecef_to_eci};
use crate::params::Direction;

/// WGS-84 semi-major axis, m, and first eccentricity squared.
pub const WGS84_A_M: f32 = 6_378_137.0;
pub const WGS84_E2: f32 = 6.694_38e-3;
/// Earth rotation rate, rad/s (IERS nominal).
pub const EARTH_RATE_RAD_S: f32 = 7.292_115e-5;
/// Astronomical unit, m.
const AU_M: f32 = 1.495_978_7e11;
/// Mean motion of the Sun's ecliptic longitude, rad/s (0.9856474°/day).
const SUN_RATE_RAD_S: f32 = 1.991_021e-7;

/// What the directions are computed from at one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Epoch {
    /// Spacecraft position and velocity, inertial, m and m/s.
    pub r_m: Vec3,
    pub v_m_s: Vec3,
    /// On-board time (the navigation solution's).
    pub time: J2000Time,
    /// UT1 − on-board time, s (uploaded: DUT1 and the GNSS time scale's offset).
    pub ut1_minus_clock_s: f32,
}

/// A geodetic site precomputed at configuration: its Earth-fixed position and the
/// ellipsoid's outward normal there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Site {
    pub ecef_m: Vec3,
    pub up_ecef: Vec3,
}

impl Site {
    /// WGS-84 geodetic latitude, longitude (rad) and height above the ellipsoid (m).
    pub fn geodetic(lat_rad: f32, lon_rad: f32, alt_m: f32) -> Self {
        let (sp, cp) = sin_cos(lat_rad);
        let (sl, cl) = sin_cos(lon_rad);
        let n = WGS84_A_M / sqrt(1.0 - WGS84_E2 * sp * sp);
        let ecef_m = Vec3::new((n + alt_m) * cp * cl, (n + alt_m) * cp * sl, (n * (1.0 - WGS84_E2) + alt_m) * sp);
        Self { ecef_m, up_ecef: Vec3::new(cp * cl, cp * sl, sp) }
    }
}

impl Epoch {
    /// Position as a [`VecKin`]: `r`, `v`, `a` (two-body).
    fn position(&self) -> VecKin {
        VecKin::new(self.r_m, self.v_m_s, self.acceleration())
    }

    /// Velocity as a [`VecKin`]: `v`, `a`, `ȧ` (two-body).
    fn velocity(&self) -> VecKin {
        let (r, v) = (self.r_m, self.v_m_s);
        let rn = norm(&r);
        let r3 = rn * rn * rn;
        let jerk = -(v / r3 - r * (3.0 * r.dot(&v) / (r3 * rn * rn))) * MU_EARTH_M3_S2;
        VecKin::new(v, self.acceleration(), jerk)
    }

    fn acceleration(&self) -> Vec3 {
        let rn = norm(&self.r_m);
        -self.r_m * (MU_EARTH_M3_S2 / (rn * rn * rn))
    }

    /// UT1 as on-board time plus the uploaded offset (`None` if not representable).
    fn ut1(&self) -> Option<J2000Time> {
        self.time.add_seconds(self.ut1_minus_clock_s)
    }

    /// An Earth-fixed point in inertial axes with its motion (`ω_E ẑ ×` once and twice).
    fn earth_fixed(&self, ecef_m: &Vec3) -> Option<VecKin> {
        let x = ecef_to_eci(&self.ut1()?, ecef_m);
        let w = Vec3::new(0.0, 0.0, EARTH_RATE_RAD_S);
        let dx = w.cross(&x);
        Some(VecKin::new(x, dx, w.cross(&dx)))
    }

    /// The Earth-fixed vector `ecef` (a direction, not a point) in inertial axes.
    pub fn earth_fixed_direction(&self, ecef: &Vec3) -> Option<Vec3> {
        Some(ecef_to_eci(&self.ut1()?, ecef))
    }

    /// The site's position relative to the spacecraft (not normalised).
    pub fn line_of_sight(&self, site: &Site) -> Option<VecKin> {
        Some(self.earth_fixed(&site.ecef_m)?.minus(&self.position()))
    }

    /// Sine of the spacecraft's elevation above the site's horizon (the ellipsoid's
    /// tangent plane): `up · (r − r_site)/|r − r_site|`.
    pub fn elevation_sine(&self, site: &Site) -> Option<f32> {
        let los = self.line_of_sight(site)?.x;
        let up = self.earth_fixed_direction(&site.up_ecef)?;
        let n = norm(&los);
        (n > 0.0 && n.is_finite()).then(|| -up.dot(&los) / n)
    }

    /// Downward normal of the WGS-84 ellipsoid through the spacecraft. The normal at
    /// geodetic latitude φ is `(x, y, k z)` normalised, `k = (N + h)/(N (1 − e²) + h)`
    /// (from `x = (N + h) cos φ cos λ`, `z = (N (1 − e²) + h) sin φ`); `diag(1, 1, k)`
    /// commutes with the Earth's rotation about z, so the same scaling holds in inertial
    /// axes. φ and h from Bowring's formula (sub-millimetre below 1,000 km); `k` is held
    /// over the step, so the derivatives omit `k̇` (≤ 7e-6 rad/s of rate in LEO, measured
    /// in docs/guidance.md).
    fn geodetic_down(&self) -> Option<VecKin> {
        let r = self.position();
        let k = geodetic_k(&r.x)?;
        let s = |v: Vec3| Vec3::new(v.x, v.y, k * v.z);
        Some(VecKin::new(s(r.x), s(r.dx), s(r.ddx)).negated())
    }

    /// The Sun seen from the spacecraft: `d û − r` with `û` the on-board ephemeris
    /// (mean equator of date, [`sun_direction_eci`]), turning about the ecliptic pole at
    /// the Sun's mean motion.
    fn sun(&self) -> VecKin {
        let (u, dist_au) = sun_direction_eci(&self.time);
        let d = dist_au * AU_M;
        // Ecliptic pole in equatorial axes (obliquity 23.439°).
        let pole = Vec3::new(0.0, -0.397_777_2, 0.917_482_1);
        let du = pole.cross(&u) * SUN_RATE_RAD_S;
        let ddu = pole.cross(&du) * SUN_RATE_RAD_S;
        VecKin::new(u * d, du * d, ddu * d).minus(&self.position())
    }

    /// The direction `d` from the spacecraft (not normalised; `site`: the precomputed
    /// site of a `Ground` direction). `None` when it cannot be computed (a zero position,
    /// a time out of range).
    pub fn direction(&self, d: &Direction, site: Option<&Site>) -> Option<VecKin> {
        let out = match d {
            Direction::Nadir => self.position().negated(),
            Direction::NadirGeodetic => self.geodetic_down()?,
            Direction::Zenith => self.position(),
            Direction::Velocity => self.velocity(),
            Direction::AntiVelocity => self.velocity().negated(),
            Direction::OrbitNormal => self.position().cross(&self.velocity()),
            Direction::AntiOrbitNormal => self.velocity().cross(&self.position()),
            Direction::Sun => self.sun(),
            Direction::Ground { .. } => self.line_of_sight(site?)?,
            Direction::Celestial { .. } => Self::celestial(d)?,
        };
        out.is_finite().then_some(out)
    }

    /// A celestial direction (right ascension, declination): fixed, needs no epoch.
    pub fn celestial(d: &Direction) -> Option<VecKin> {
        let Direction::Celestial { ra_rad, dec_rad } = d else { return None };
        let (sa, ca) = sin_cos(*ra_rad);
        let (sd, cd) = sin_cos(*dec_rad);
        Some(VecKin::constant(Vec3::new(cd * ca, cd * sa, sd)))
    }
}

/// The ellipsoid-normal scaling `k` of [`Epoch::geodetic_down`] for a position `r`
/// (inertial or Earth-fixed: only `√(x² + y²)` and z enter). `None` at the centre.
fn geodetic_k(r: &Vec3) -> Option<f32> {
    let a = WGS84_A_M;
    let b = a * sqrt(1.0 - WGS84_E2);
    let ep2 = WGS84_E2 / (1.0 - WGS84_E2);
    let p = sqrt(r.x * r.x + r.y * r.y);
    if !(p.is_finite() && r.z.is_finite()) || (p == 0.0 && r.z == 0.0) {
        return None;
    }
    // Bowring: parametric latitude β, then φ.
    let beta = atan2(r.z * a, p * b);
    let (sb, cb) = sin_cos(beta);
    let phi = atan2(r.z + ep2 * b * sb * sb * sb, p - WGS84_E2 * a * cb * cb * cb);
    let (sp, cp) = sin_cos(phi);
    let n = a / sqrt(1.0 - WGS84_E2 * sp * sp);
    // Height along the normal, well conditioned at every latitude.
    let h = p * cp + r.z * sp - a * a / n;
    let k = (n + h) / (n * (1.0 - WGS84_E2) + h);
    k.is_finite().then_some(k)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn epoch() -> Epoch {
        // 500 km circular, 51.6° inclination, somewhere along it.
        let r = 6_878_137.0f32;
        let v = sqrt(MU_EARTH_M3_S2 / r);
        let (si, ci) = sin_cos(51.6f32.to_radians());
        Epoch {
            r_m: Vec3::new(r * 0.6, r * 0.8 * ci, r * 0.8 * si),
            v_m_s: Vec3::new(-v * 0.8, v * 0.6 * ci, v * 0.6 * si),
            time: J2000Time::new(9_500, 12_345.0).unwrap(),
            ut1_minus_clock_s: 0.0,
        }
    }

    #[test]
    fn orbit_normal_of_a_two_body_orbit_does_not_move() {
        let n = epoch().direction(&Direction::OrbitNormal, None).unwrap().unit().unwrap();
        assert!(n.dx.norm() < 1e-9 && n.ddx.norm() < 1e-9, "{n:?}");
    }

    #[test]
    fn nadir_turns_at_the_orbit_rate() {
        let e = epoch();
        let n = e.direction(&Direction::Nadir, None).unwrap().unit().unwrap();
        let rate = sqrt(MU_EARTH_M3_S2 / norm(&e.r_m).powi(3));
        assert!((norm(&n.dx) / rate - 1.0).abs() < 1e-5, "{} vs {rate}", norm(&n.dx));
    }

    #[test]
    fn geodetic_nadir_is_geocentric_at_the_equator_and_differs_by_the_known_angle_at_45_degrees() {
        let e = epoch();
        let eq = Epoch { r_m: Vec3::new(6_878_137.0, 0.0, 0.0), ..e };
        let a = eq.direction(&Direction::NadirGeodetic, None).unwrap().unit().unwrap().x;
        assert!((a - Vec3::new(-1.0, 0.0, 0.0)).norm() < 1e-6);
        // A point 500 km above geodetic latitude 45°: its downward normal is the
        // latitude's, 0.19° from the geocentric nadir.
        let site = Site::geodetic(45f32.to_radians(), 0.0, 500_000.0);
        let at45 = Epoch { r_m: site.ecef_m, ..e };
        let down = at45.direction(&Direction::NadirGeodetic, None).unwrap().unit().unwrap().x;
        assert!((down + site.up_ecef).norm() < 2e-6, "{down:?} vs {:?}", -site.up_ecef);
    }
}
