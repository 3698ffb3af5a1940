//! The flight computer's own reference models (f32, `acs_flight::models`) against the
//! simulator's f64 truth and published values: Sun direction, GMST, the geomagnetic field
//! per truncation degree against the full WMM2025, the LVLH frame.

use acs_flight::math::Vec3;
use acs_flight::models::lvlh::lvlh;
use acs_flight::models::magnetic::field_ecef_t;
use acs_flight::models::sun::sun_direction_eci;
use acs_flight::models::time::{J2000Time, eci_to_ecef, gmst_rad};
use nalgebra::Vector3;
use sim_core::environment::frames::{gmst_iau82, julian_date, q_lvlh_to_eci};
use sim_core::environment::magnetic::wmm_ecef;
use sim_core::environment::torques::sun_position_eci;

const JD_J2000: f64 = 2_451_545.0;

fn t_of_jd(jd: f64) -> J2000Time {
    let d = jd - JD_J2000;
    let days = d.floor();
    J2000Time::new(days as i32, ((d - days) * 86400.0) as f32).expect("finite")
}

fn v64(v: &Vec3) -> Vector3<f64> {
    Vector3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z))
}

fn angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.normalize().dot(&b.normalize()).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Seeded uniform numbers in [0, 1).
struct Rng(rand_chacha::ChaCha8Rng);
impl Rng {
    fn new(seed: u64) -> Self {
        Self(rand::SeedableRng::seed_from_u64(seed))
    }
    fn uniform(&mut self) -> f64 {
        rand::RngExt::random::<f64>(&mut self.0)
    }
}

#[test]
fn sun_direction_matches_the_almanac_and_the_host() {
    // Published instants (UTC): 2024 March equinox 03:06 (RA 0, dec 0), June solstice
    // 20:51 (dec +23.44°), 2025 December solstice 15:03 (dec −23.44°).
    let eq = sun_direction_eci(&t_of_jd(julian_date(2024, 3, 20, 3, 6, 0.0))).0;
    assert!(angle_deg(&v64(&eq), &Vector3::x()) < 0.02, "equinox: {eq:?}");
    for (jd, dec) in [(julian_date(2024, 6, 20, 20, 51, 0.0), 23.44), (julian_date(2025, 12, 21, 15, 3, 0.0), -23.44)] {
        let s = sun_direction_eci(&t_of_jd(jd)).0;
        let got = f64::from(s.z).asin().to_degrees();
        assert!((got - dec).abs() < 0.02, "solstice declination {got}");
    }
    // Against the host's f64 ephemeris over 2000–2050: f32 evaluation error only.
    let mut rng = Rng::new(11);
    let mut worst = 0.0_f64;
    for _ in 0..5000 {
        let jd = JD_J2000 + rng.uniform() * 50.0 * 365.25;
        let (s, au) = sun_direction_eci(&t_of_jd(jd));
        let h = sun_position_eci(jd);
        worst = worst.max(angle_deg(&v64(&s), &h));
        assert!((f64::from(au) * 1.495_978_707e11 / h.norm() - 1.0).abs() < 1e-4);
    }
    assert!(worst < 0.002, "flight vs host Sun: {worst}°");
    eprintln!("Sun direction, flight f32 vs host f64, 2000–2050: max {worst:.5}°");
}

#[test]
fn gmst_matches_iau82() {
    let mut rng = Rng::new(12);
    let mut worst = 0.0_f64;
    for _ in 0..5000 {
        let jd = JD_J2000 + rng.uniform() * 40.0 * 365.25;
        let ours = f64::from(gmst_rad(&t_of_jd(jd)));
        let host = gmst_iau82(jd, 0.0);
        let d = (ours - host + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        worst = worst.max(d.abs().to_degrees());
    }
    // Linear term only, f32: within 0.005° (≈ 1.2 s of Earth rotation, 0.5 km at the equator).
    assert!(worst < 0.005, "GMST error {worst}°");
    eprintln!("GMST, flight f32 vs IAU-82 f64, 2000–2040: max {worst:.5}°");
}

/// Field error statistics of the flight model at `degree` vs the full WMM over LEO.
fn field_errors(degree: usize) -> (f64, f64, f64) {
    let mut rng = Rng::new(13);
    let (mut worst, mut sum2, mut worst_mag) = (0.0_f64, 0.0, 0.0_f64);
    let n = 2000;
    for _ in 0..n {
        let lat = (2.0 * rng.uniform() - 1.0).asin();
        let lon = (2.0 * rng.uniform() - 1.0) * std::f64::consts::PI;
        let r = 6.371e6 + 400e3 + 400e3 * rng.uniform();
        let p = Vector3::new(r * lat.cos() * lon.cos(), r * lat.cos() * lon.sin(), r * lat.sin());
        let year = 2025.0 + 4.9 * rng.uniform();
        let host = wmm_ecef(&p, year, 0.0).expect("valid");
        let ours = field_ecef_t(&Vec3::new(p.x as f32, p.y as f32, p.z as f32), year as f32, degree).expect("valid");
        let a = angle_deg(&v64(&ours), &host);
        worst = worst.max(a);
        sum2 += a * a;
        worst_mag = worst_mag.max((v64(&ours).norm() / host.norm() - 1.0).abs());
    }
    (worst, (sum2 / f64::from(n)).sqrt(), worst_mag)
}

#[test]
fn field_model_truncations_against_the_full_wmm() {
    let mut last_rms = f64::INFINITY;
    let mut rows = Vec::new();
    for degree in [1, 2, 4, 6, 8, 12] {
        let (worst, rms, mag) = field_errors(degree);
        rows.push(format!(
            "degree {degree:2}: direction max {worst:.3}°, RMS {rms:.3}°; magnitude max {:.2} %",
            mag * 100.0
        ));
        // Each degree adds information: the RMS direction error must not grow.
        assert!(rms <= last_rms * 1.001, "degree {degree}: RMS {rms} > {last_rms}");
        last_rms = rms;
        if degree == 12 {
            // Same model, f32 and a day-resolved date on the host: numerically equal.
            assert!(worst < 0.01 && mag < 1e-4, "degree 12: {worst}° {mag}");
        }
        if degree == 1 {
            // A centred dipole misses the quadrupole and octupole terms: tens of degrees in LEO
            // (worst over the South Atlantic Anomaly), not zero.
            assert!(worst > 2.0 && worst < 45.0, "dipole: {worst}°");
        }
    }
    eprintln!("{}", rows.join("\n"));
}

/// The flight LVLH frame of an f64 position and velocity (rounded to f32 as on board),
/// its ECI ← LVLH quaternion in f64, and its rate (rad/s, LVLH axes).
fn flight_lvlh(r: &Vector3<f64>, v: &Vector3<f64>) -> (nalgebra::UnitQuaternion<f64>, Vector3<f64>) {
    let f = lvlh(&Vec3::new(r.x as f32, r.y as f32, r.z as f32), &Vec3::new(v.x as f32, v.y as f32, v.z as f32))
        .expect("frame");
    let q = f.q_eci_lvlh;
    let q64 = nalgebra::Quaternion::new(f64::from(q.w), f64::from(q.i), f64::from(q.j), f64::from(q.k));
    (nalgebra::UnitQuaternion::from_quaternion(q64), f.rate_lvlh_rad_s.map(f64::from))
}

#[test]
fn lvlh_matches_the_host_frame_and_orbit_rate() {
    let mut rng = Rng::new(14);
    for _ in 0..1000 {
        let r = Vector3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5).normalize() * 7.0e6;
        let v = Vector3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5) * 15e3;
        if r.cross(&v).norm() < 0.1 * r.norm() * v.norm() {
            continue;
        }
        let (ours, rate_lvlh) = flight_lvlh(&r, &v);
        let host = q_lvlh_to_eci(&r, &v);
        assert!(ours.angle_to(&host) < 2e-6, "LVLH off by {} rad", ours.angle_to(&host));
        let rate = r.cross(&v).norm() / r.norm_squared();
        assert!((-rate_lvlh.y / rate - 1.0).abs() < 1e-5);
    }
    assert!(lvlh(&Vec3::new(7e6, 0.0, 0.0), &Vec3::new(7e3, 0.0, 0.0)).is_err());
    assert!(lvlh(&Vec3::new(f32::NAN, 0.0, 0.0), &Vec3::new(0.0, 7e3, 0.0)).is_err());
}

#[test]
fn time_normalises_and_rotations_invert() {
    let t = J2000Time::new(9000, 90_000.0).expect("finite");
    assert_eq!((t.days, t.seconds), (9001, 3600.0));
    let t = J2000Time::new(9000, -1.0).expect("finite");
    assert_eq!((t.days, t.seconds), (8999, 86_399.0));
    assert!(J2000Time::new(0, f32::NAN).is_none());
    assert!(J2000Time::new(i32::MAX, 86_400.0 * 2.0).is_none());
    let v = Vec3::new(1.0, 2.0, 3.0);
    let t = t_of_jd(julian_date(2026, 11, 23, 9, 0, 0.0));
    let back = acs_flight::models::time::ecef_to_eci(&t, &eci_to_ecef(&t, &v));
    assert!((back - v).norm() < 1e-6);
    // Decimal year of 2026-07-02 12:00 is 2026.5 to within a day.
    let t = t_of_jd(julian_date(2026, 7, 2, 12, 0, 0.0));
    assert!((t.decimal_year() - 2026.5).abs() < 1.0 / 365.0, "{}", t.decimal_year());
}

/// LVLH on board from a noisy GNSS fix (1σ 5 m per axis, 0.05 m/s per axis) at 617 km:
/// first order, the frame turns by δr⊥/r about the two horizontal axes and by δv_normal/v
/// about the radial axis, so the mean squared angle is 2(σr/r)² + (σv/v)². That angle is
/// the pointing error it adds to an LVLH target.
#[test]
fn lvlh_from_a_noisy_gnss_fix_errs_as_first_order_predicts() {
    let mut rng = Rng::new(15);
    let mut gauss = || {
        let (u1, u2) = (rng.uniform().max(1e-300), rng.uniform());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    let (sr, sv) = (5.0, 0.05);
    let rn = 6_378_137.0 + 617.0e3;
    let vn = (3.986_004_418e14f64 / rn).sqrt();
    let n = 20_000;
    let mut sum_sq = 0.0;
    for k in 0..n {
        // Circular orbit, inclination 97.8°, phase k.
        let u = k as f64 * 0.01;
        let i = 97.8f64.to_radians();
        let r = Vector3::new(u.cos(), u.sin() * i.cos(), u.sin() * i.sin()) * rn;
        let v = Vector3::new(-u.sin(), u.cos() * i.cos(), u.cos() * i.sin()) * vn;
        let rm = r + Vector3::new(gauss(), gauss(), gauss()) * sr;
        let vm = v + Vector3::new(gauss(), gauss(), gauss()) * sv;
        let (ours, _) = flight_lvlh(&rm, &vm);
        let a = ours.angle_to(&q_lvlh_to_eci(&r, &v));
        sum_sq += a * a;
    }
    let rms = (sum_sq / n as f64).sqrt();
    let predicted = (2.0 * (sr / rn) * (sr / rn) + (sv / vn) * (sv / vn)).sqrt();
    eprintln!(
        "LVLH from noisy GNSS: RMS {:.3e} rad ({:.5} deg), first order {predicted:.3e} rad",
        rms,
        rms.to_degrees()
    );
    // f32 rounding of the frame (< 2e-6 rad, test above) adds in quadrature.
    let with_rounding = (predicted * predicted + 1e-12).sqrt();
    assert!(rms > 0.9 * predicted && rms < 1.1 * with_rounding, "{rms} vs {predicted}");
}
