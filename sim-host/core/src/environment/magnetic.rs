//! Geomagnetic field in ECI [T]: centred tilted dipole, or the World Magnetic Model
//! (`world_magnetic_model` crate, WMM2020 + WMM2025 coefficients, valid 2020-01-01 ..
//! 2029-12-31, heights -1 .. 850 km).
use crate::environment::frames::{self, EarthRotation};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use world_magnetic_model::GeomagneticField;
use world_magnetic_model::time::{Date, util::days_in_year};
use world_magnetic_model::uom::si::angle::radian;
use world_magnetic_model::uom::si::f32::{Angle, Length};
use world_magnetic_model::uom::si::length::meter;
use world_magnetic_model::uom::si::magnetic_flux_density::tesla;

type V3 = Vector3<f64>;

/// IGRF/WMM geomagnetic reference radius [m]; B0 is the equatorial field at this radius.
pub const DIPOLE_REF_RADIUS: f64 = 6371.2e3;
/// "Standard" equatorial dipole field [T] (Wertz 1978 / Markley-Crassidis value, epoch ~1975).
/// The WMM2025 first-degree coefficients give 2.9735e-5 T.
pub const B0_STANDARD: f64 = 3.12e-5;
/// WMM2025 (epoch 2025.0) dipole: colatitude of the north geomagnetic pole [deg]
/// = atan(sqrt(g11^2 + h11^2)/|g10|), g10 = -29351.8, g11 = -1410.8, h11 = 4545.4 nT.
pub const WMM2025_DIPOLE_TILT_DEG: f64 = 9.2109;
/// WMM2025 north geomagnetic pole east longitude [deg] = atan2(-h11, -g11) (80.79 N, 72.76 W).
pub const WMM2025_DIPOLE_LON_DEG: f64 = -72.7566;

/// Field model. Dipole: `b0_t` equatorial field at 6371.2 km, `m_tilt_deg` colatitude and
/// `m_lon_deg` east longitude of the north geomagnetic pole (the dipole moment points the
/// other way, to the southern hemisphere). WMM: `decimal_year` at t = 0 (crate
/// convention: year + (day_of_year - 1 + day_fraction)/days_in_year).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum FieldModel {
    TiltedDipole { b0_t: f64, m_tilt_deg: f64, m_lon_deg: f64 },
    Wmm { decimal_year: f64 },
}

impl FieldModel {
    /// B0 = 3.12e-5 T with the WMM2025 dipole axis (tilt 9.21 deg, pole at 72.76 W).
    pub fn default_dipole() -> Self {
        FieldModel::TiltedDipole {
            b0_t: B0_STANDARD,
            m_tilt_deg: WMM2025_DIPOLE_TILT_DEG,
            m_lon_deg: WMM2025_DIPOLE_LON_DEG,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MagError {
    /// Out of the WMM date/height/latitude validity (the crate's error).
    Wmm(world_magnetic_model::Error),
    /// Date arithmetic failed (decimal year not representable).
    BadDate,
}
impl std::fmt::Display for MagError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MagError::Wmm(e) => write!(f, "WMM: {e}"),
            MagError::BadDate => write!(f, "invalid date"),
        }
    }
}
impl std::error::Error for MagError {}

/// A field model plus the Earth rotation used to put it into ECI.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MagneticField {
    pub model: FieldModel,
    pub earth: EarthRotation,
}

impl MagneticField {
    pub fn new(model: FieldModel, earth: EarthRotation) -> Self {
        Self { model, earth }
    }

    /// Field [T] in ECI at ECI position `r` [m], t seconds after the epoch.
    pub fn b_eci_t(&self, r_eci: &V3, t_s: f64) -> Result<V3, MagError> {
        let rot = self.earth.eci_to_ecef(t_s);
        let r_ecef = rot * r_eci;
        let b_ecef = match self.model {
            FieldModel::TiltedDipole { b0_t, m_tilt_deg, m_lon_deg } => {
                dipole_ecef(&r_ecef, b0_t, m_tilt_deg.to_radians(), m_lon_deg.to_radians())
            }
            FieldModel::Wmm { decimal_year } => wmm_ecef(&r_ecef, decimal_year, t_s)?,
        };
        Ok(rot.inverse() * b_ecef)
    }
}

/// Centred dipole `B = B0 (Rref/r)^3 [3 (m^.r^) r^ - m^]` (Wertz 1978 app. H;
/// Markley & Crassidis 2014 eq. 3.150) with m^ = -(north geomagnetic pole direction).
/// |B| = B0 (R/r)^3 on the magnetic equator, 2 B0 (R/r)^3 at the magnetic poles.
pub fn dipole_ecef(r: &V3, b0: f64, tilt: f64, lon: f64) -> V3 {
    let m = -Vector3::new(tilt.sin() * lon.cos(), tilt.sin() * lon.sin(), tilt.cos());
    let rn = r.norm();
    let u = r / rn;
    b0 * (DIPOLE_REF_RADIUS / rn).powi(3) * (3.0 * m.dot(&u) * u - m)
}

/// WMM field in geodetic NED [T] (north X, east Y, down Z) at one calendar day.
pub fn wmm_ned(lat: f64, lon: f64, h: f64, date: Date) -> Result<V3, MagError> {
    let f = GeomagneticField::new(
        Length::new::<meter>(h as f32),
        Angle::new::<radian>(lat as f32),
        Angle::new::<radian>(lon as f32),
        date,
    )
    .map_err(MagError::Wmm)?;
    Ok(Vector3::new(f.x().get::<tesla>() as f64, f.y().get::<tesla>() as f64, f.z().get::<tesla>() as f64))
}

/// (year, zero-based fractional day of year) of `decimal_year + t/86400 days`.
fn year_day(decimal_year: f64, t_s: f64) -> Result<(i32, f64), MagError> {
    if !decimal_year.is_finite() || !t_s.is_finite() || !(1.0..9999.0).contains(&decimal_year) {
        return Err(MagError::BadDate);
    }
    let mut y = decimal_year.floor() as i32;
    let mut d = (decimal_year - y as f64) * days_in_year(y) as f64 + t_s / 86400.0;
    for _ in 0..200 {
        let n = days_in_year(y) as f64;
        if d >= n {
            d -= n;
            y += 1;
        } else if d < 0.0 {
            y -= 1;
            d += days_in_year(y) as f64;
        } else {
            return Ok((y, d));
        }
    }
    Err(MagError::BadDate)
}

/// WMM in ECEF [T]: ECEF -> geodetic -> WMM(NED) -> ECEF. The crate resolves dates to a day;
/// the result is interpolated linearly between consecutive days, which is exact inside an
/// epoch because WMM is linear in time (g(t) = g0 + g_dot (t - t0)). Costs two evaluations.
pub fn wmm_ecef(r_ecef: &V3, decimal_year: f64, t_s: f64) -> Result<V3, MagError> {
    let (y, d) = year_day(decimal_year, t_s)?;
    let day = d.floor();
    let frac = d - day;
    let date0 = Date::from_ordinal_date(y, day as u16 + 1).map_err(|_| MagError::BadDate)?;
    let (lat, lon, h) = frames::ecef_to_geodetic(r_ecef);
    let mut ned = wmm_ned(lat, lon, h, date0)?;
    if frac > 0.0 {
        // last valid day: no successor -> keep the day value
        if let Some(Ok(b1)) = date0.next_day().map(|d1| wmm_ned(lat, lon, h, d1)) {
            ned += frac * (b1 - ned);
        }
    }
    let [n, e, dn] = frames::ned_basis(lat, lon);
    Ok(ned.x * n + ned.y * e + ned.z * dn)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::environment::frames::{geodetic_to_ecef, ned_basis};

    #[test]
    fn dipole_equator_pole_and_inverse_cube() {
        let (tilt, lon) = (WMM2025_DIPOLE_TILT_DEG.to_radians(), WMM2025_DIPOLE_LON_DEG.to_radians());
        let pole = Vector3::new(tilt.sin() * lon.cos(), tilt.sin() * lon.sin(), tilt.cos());
        let eq = pole.cross(&Vector3::x()).normalize(); // on the magnetic equator
        let r = 7000e3;
        let bp = dipole_ecef(&(r * pole), B0_STANDARD, tilt, lon);
        let be = dipole_ecef(&(r * eq), B0_STANDARD, tilt, lon);
        let be2 = dipole_ecef(&(2.0 * r * eq), B0_STANDARD, tilt, lon);
        println!(
            "dipole: |Bpole|/|Beq| = {:.15}, |B(r)|/|B(2r)| = {:.15}, |Beq(R)| = {:.4e}",
            bp.norm() / be.norm(),
            be.norm() / be2.norm(),
            dipole_ecef(&(DIPOLE_REF_RADIUS * eq), B0_STANDARD, tilt, lon).norm()
        );
        assert!((bp.norm() / be.norm() - 2.0).abs() < 1e-12);
        assert!((be.norm() / be2.norm() - 8.0).abs() < 1e-12);
        assert!((be.norm() - B0_STANDARD * (DIPOLE_REF_RADIUS / r).powi(3)).abs() < 1e-18);
        // direction: at the north geomagnetic pole B points down (into the Earth); at the
        // magnetic equator it points north (along the pole direction)
        assert!(bp.dot(&pole) < 0.0 && (bp.normalize() + pole).norm() < 1e-12);
        assert!((be.normalize() - pole).norm() < 1e-12);
    }

    #[test]
    fn dipole_rotates_with_earth() {
        let f = MagneticField::new(FieldModel::default_dipole(), EarthRotation::Simple { theta0_rad: 0.4 });
        let r_ecef = Vector3::new(3e6, -5e6, 3.5e6);
        let t = 1234.5;
        let rot = f.earth.eci_to_ecef(t);
        let b = f.b_eci_t(&(rot.inverse() * r_ecef), t).unwrap();
        let (tl, ln) = (WMM2025_DIPOLE_TILT_DEG.to_radians(), WMM2025_DIPOLE_LON_DEG.to_radians());
        assert!((rot * b - dipole_ecef(&r_ecef, B0_STANDARD, tl, ln)).norm() < 1e-18);
    }

    /// WMM2025 Technical Report Table 6 (test values), as used by the crate's own
    /// `test_wmm_tr_table_6_elements`: X, Y, Z [nT]; crate tolerance 0.2 nT.
    #[test]
    fn wmm_tr_table6_through_eci() {
        let cases = [
            (2025.0, 100.0, 80.0f64, 0.0f64, [6216.0, 92.4, 52598.8]),
            (2025.0, 0.0, 0.0, 120.0, [39677.8, -109.6, -10580.2]),
            (2027.5, 100.0, -80.0, -120.0, [5984.0, 14760.1, -49317.7]),
            (2027.5, 0.0, 80.0, 0.0, [6500.8, 294.5, 54869.4]),
        ];
        let t = 0.0; // evaluated through an ECI frame rotated by theta0 = 2 rad
        for (year, h_km, lat_d, lon_d, xyz) in cases {
            let f =
                MagneticField::new(FieldModel::Wmm { decimal_year: year }, EarthRotation::Simple { theta0_rad: 2.0 });
            let (lat, lon): (f64, f64) = (lat_d.to_radians(), lon_d.to_radians());
            let r_ecef = geodetic_to_ecef(lat, lon, h_km * 1e3);
            let rot = f.earth.eci_to_ecef(t);
            let b_eci = f.b_eci_t(&(rot.inverse() * r_ecef), t).unwrap();
            let b = rot * b_eci;
            let [n, e, d] = ned_basis(lat, lon);
            let got = [b.dot(&n) * 1e9, b.dot(&e) * 1e9, b.dot(&d) * 1e9];
            let err = (0..3).map(|k| (got[k] - xyz[k]).abs()).fold(0.0, f64::max);
            println!(
                "WMM {year} {h_km} km ({lat_d},{lon_d}): XYZ = [{:.2}, {:.2}, {:.2}] nT, max err {err:.3} nT",
                got[0], got[1], got[2]
            );
            assert!(err < 0.3, "{got:?} vs {xyz:?}");
        }
    }

    #[test]
    fn wmm_validity_errors() {
        let earth = EarthRotation::Simple { theta0_rad: 0.0 };
        let r = Vector3::new(7000e3, 0.0, 0.0);
        for y in [2019.9, 2030.01] {
            let e = MagneticField::new(FieldModel::Wmm { decimal_year: y }, earth).b_eci_t(&r, 0.0);
            assert!(
                matches!(e, Err(MagError::Wmm(world_magnetic_model::Error::DateOutsideOfValidityRange { .. }))),
                "{e:?}"
            );
        }
        let f = MagneticField::new(FieldModel::Wmm { decimal_year: 2026.2 }, earth);
        assert!(f.b_eci_t(&r, 0.0).is_ok());
        assert!(matches!(f.b_eci_t(&Vector3::new(7300e3, 0.0, 0.0), 0.0), Err(MagError::Wmm(_)))); // > 850 km
        // stepping over the year boundary by t
        let f = MagneticField::new(FieldModel::Wmm { decimal_year: 2026.999 }, earth);
        assert!(f.b_eci_t(&r, 10.0 * 86400.0).is_ok());
        // continuity across a day boundary (interpolated): jump < 0.01 nT
        let f = MagneticField::new(FieldModel::Wmm { decimal_year: 2026.0 }, EarthRotation::Simple { theta0_rad: 0.0 });
        let r_ecef = Vector3::new(6000e3, 3000e3, 1000e3);
        let b = |t: f64| wmm_ecef(&r_ecef, 2026.0, t).unwrap();
        let jump = (b(86400.0 - 1e-3) - b(86400.0)).norm();
        println!("WMM day-boundary jump {:.2e} nT", jump * 1e9);
        assert!(jump < 1e-11);
        let _ = f;
        // time advance: 2026.0 + 182.5 days == decimal year 2026.5 (365-day year)
        let (y, d) = year_day(2026.0, 182.5 * 86400.0).unwrap();
        assert_eq!((y, d), (2026, 182.5));
        assert_eq!(year_day(2024.5, 183.0 * 86400.0).unwrap(), (2025, 0.0)); // 2024: 366 days
    }

    #[test]
    fn wmm_vs_dipole_same_order() {
        // sanity: at 617 km the WMM and the WMM2025-dipole (with its own B0) agree to ~20 %
        let earth = EarthRotation::Simple { theta0_rad: 0.0 };
        let w = MagneticField::new(FieldModel::Wmm { decimal_year: 2026.0 }, earth);
        let d = MagneticField::new(
            FieldModel::TiltedDipole {
                b0_t: 2.9735e-5,
                m_tilt_deg: WMM2025_DIPOLE_TILT_DEG,
                m_lon_deg: WMM2025_DIPOLE_LON_DEG,
            },
            earth,
        );
        let mut worst: f64 = 0.0;
        for k in 0..36 {
            let a = k as f64 * 10f64.to_radians();
            let r = (6378137.0 + 617e3) * Vector3::new(a.cos() * 0.2, a.sin() * 0.2, a.cos()).normalize();
            let (bw, bd) = (w.b_eci_t(&r, 0.0).unwrap(), d.b_eci_t(&r, 0.0).unwrap());
            worst = worst.max(bw.angle(&bd).to_degrees());
        }
        println!("WMM vs dipole worst angle at 617 km: {worst:.1} deg");
        assert!(worst < 25.0);
    }
}
