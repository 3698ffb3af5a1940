//! On-board orbit propagation between GNSS fixes: two-body Kepler motion, f32.
//!
//! Method: Lagrange f and g coefficients with Kepler's equation written in the change of
//! eccentric anomaly ΔE (Battin, *An Introduction to the Mathematics and Methods of
//! Astrodynamics*, 1999, §4.6; Vallado, *Fundamentals of Astrodynamics and Applications*,
//! 4th ed., 2013, §2.3 and Alg. 8): the state after `dt` is obtained in one evaluation from
//! the fix `(r0, v0)`, with no step accumulation, so the error does not grow with the
//! number of calls, only (linearly) with `dt`.
//!
//! Scaling (for f32): lengths in units of `L = |r0|`, times in `T = √(L³/μ)`, velocities in
//! `L/T`; then μ = 1, `|r0| = 1` and every quantity is of order 1. With `σ0 = r0·v0` and
//! `α = 2 − v0²` (= `L/a`):
//! - elliptic only: `α > 0`, `e cos E0 = 1 − α`, `e sin E0 = σ0 √α`, e < [`ORBIT_MAX_ECCENTRICITY`];
//! - `ΔM = α^{3/2} dt/T`, reduced to (−π, π] with 2π split in two parts (exact product);
//! - Kepler in `x = ΔE`: `ΔM = x − (1 − α) sin x + σ0 √α (1 − cos x)` (monotone, derivative
//!   `1 − e cos E ≥ 1 − e`), safeguarded Newton inside the bracket `|x − ΔM| ≤ 2e`, at most
//!   [`KEPLER_MAX_ITERATIONS`] iterations (≤ 4 in 99.6 % of a sweep over e < 0.9, E0 and
//!   ΔM, at most 9; unit test below), converged when a Newton step is
//!   below 1e-5 rad (the error after that step is quadratic, < 1e-9 rad);
//! - `f = 1 − (1 − cos x)/α`, `g = sin x/√α + σ0 (1 − cos x)/α` (Battin eq 4.43, the form
//!   without the cancelling `dt − (x − sin x)/n`), `r = cos x + (1 − cos x)/α + σ0 sin x/√α`,
//!   `ḟ = −sin x/(√α r)`, `ġ = 1 − (1 − cos x)/(α r)`; `1 − cos x = 2 sin²(x/2)`.
//!
//! Accuracy (against f64 RK4 and f64 classical-elements Kepler references from the same
//! f32 fix, `sim-host/core/tests/onboard_orbit.rs`): dominated by the f32 rounding of the
//! mean-anomaly change ΔM (the scaling's roundings enter the mean motion), measured worst
//! ≈ 11.4 · 2⁻²⁴ · r · (1 + |ΔM|) over 300 random orbits; typical figures are far smaller:
//! 617 km circular orbit 0.3 m after 100 s, 1.7 m after 6,000 s (one orbit), 3.3 m after
//! 20,000 s; e = 0.1 orbit 9 m after 6,000 s, 15 m after 20,000 s. Seen from the Earth's
//! centre (the LVLH frame's error) that is < 1e-4 deg.
//!
//! The model error is far larger: from the same state, a J2 orbit separates from the
//! two-body one by ~3.5 km after 600 s and ~108 km after 6,000 s (617 km, i = 97.8°;
//! 0.9° of LVLH error). Two-body propagation is therefore good for minutes between GNSS
//! fixes, not for a whole-orbit outage if sub-degree LVLH pointing is needed (adding the
//! J2 secular rates would be the next step).
//!
//! For a gap of at most [`SHORT_STEP_MAX_S`] (the GNSS monitor's usual 1 s between fixes),
//! [`propagate_short`] takes the second-order Taylor step instead: no Kepler solve, its
//! truncation bounded by [`short_step_truncation_m`] (0.47 m at 4 s, any ellipse from
//! 6,000 km) and, for the velocity, [`short_step_velocity_truncation_m_s`] (11 mm/s at 4 s).
//!
//! No heap, one bounded loop, no panics: every failure is an [`OrbitError`].

use crate::math::f32m::{atan2, floor, sin, sin_cos, sqrt};
use crate::math::{Vec3, all_finite, norm};

/// Earth's gravitational parameter (EGM96 / WGS-84), m³/s².
pub const MU_EARTH_M3_S2: f32 = 3.986_004_4e14;
/// Smallest accepted `|r0|` (below the Earth's surface plus margin is a bad fix).
pub const ORBIT_MIN_RADIUS_M: f32 = 6.0e6;
/// Largest accepted `|r0|` (beyond GEO by far; the Moon and the Sun dominate out there).
pub const ORBIT_MAX_RADIUS_M: f32 = 1.0e8;
/// Eccentricities from this one up are refused: Newton's derivative `1 − e cos E` falls
/// towards zero at periapsis and f32 accuracy degrades.
pub const ORBIT_MAX_ECCENTRICITY: f32 = 0.9;
/// Largest accepted `|dt|`: one day. Beyond it the f32 error (linear in ΔM) exceeds
/// ~200 m in LEO, and a two-body arc of a day is meaningless anyway.
pub const ORBIT_MAX_DT_S: f32 = 86_400.0;
/// Cap on Kepler iterations (safeguarded Newton; at most 9 measured over e < 0.9).
pub const KEPLER_MAX_ITERATIONS: u32 = 16;
/// A Newton step below this ends the iteration (rad of ΔE).
const KEPLER_STEP_TOL_RAD: f32 = 1e-5;
/// 2π in two parts: `TWO_PI_HI` has 8 significant bits so `k · TWO_PI_HI` is exact for
/// |k| < 2^16; `TWO_PI_LO` carries the rest (residual < 1e-10).
const TWO_PI_HI: f32 = 6.281_25;
const TWO_PI_LO: f32 = 1.935_307_2e-3;

/// Why no state was propagated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OrbitError {
    /// A position, velocity or time component is NaN or infinite.
    NonFinite,
    /// `|r0|` outside [[`ORBIT_MIN_RADIUS_M`], [`ORBIT_MAX_RADIUS_M`]].
    RadiusOutOfRange,
    /// `|dt|` above [`ORBIT_MAX_DT_S`].
    TimeOutOfRange,
    /// Parabolic or hyperbolic (escape) velocity: no ellipse.
    NotElliptic,
    /// Eccentricity at or above [`ORBIT_MAX_ECCENTRICITY`] (this includes rectilinear
    /// motion, e = 1, and a zero velocity).
    TooEccentric,
    /// Kepler's equation did not converge within [`KEPLER_MAX_ITERATIONS`] (not observed:
    /// the safeguarded iteration always converges for e < 0.9; kept as a typed fallback).
    NoConvergence,
}

impl core::fmt::Display for OrbitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "orbit propagation: {self:?}")
    }
}
#[cfg(feature = "std")]
impl std::error::Error for OrbitError {}

/// Position (m) and velocity (m/s) `dt_s` after the fix `(r0_m, v0_m_s)` (any inertial
/// frame centred on the Earth), two-body; `dt_s` may be negative (back-propagation).
pub fn propagate_two_body(r0_m: &Vec3, v0_m_s: &Vec3, dt_s: f32) -> Result<(Vec3, Vec3), OrbitError> {
    if !(all_finite(r0_m.as_slice()) && all_finite(v0_m_s.as_slice()) && dt_s.is_finite()) {
        return Err(OrbitError::NonFinite);
    }
    if !(libm::fabsf(dt_s) <= ORBIT_MAX_DT_S) {
        return Err(OrbitError::TimeOutOfRange);
    }
    // A finite but huge r0 squares to +inf: refused by the range test too.
    let l = norm(r0_m);
    if !(ORBIT_MIN_RADIUS_M..=ORBIT_MAX_RADIUS_M).contains(&l) {
        return Err(OrbitError::RadiusOutOfRange);
    }
    // Units: L = |r0| (m), T = √(L³/μ) (s), L/T (m/s).
    let t_unit = l * sqrt(l / MU_EARTH_M3_S2);
    let v_unit = l / t_unit;
    let r = r0_m / l;
    let v = v0_m_s / v_unit;
    let sigma = r.dot(&v);
    let alpha = 2.0 - v.norm_squared(); // L / a
    // `!(x > 0)` also catches NaN (from an overflowing huge velocity: -inf stays < 0).
    if !(alpha > 0.0) {
        return Err(OrbitError::NotElliptic);
    }
    let sqrt_alpha = sqrt(alpha);
    let e_cos = 1.0 - alpha;
    let e_sin = sigma * sqrt_alpha;
    let e2 = e_cos * e_cos + e_sin * e_sin;
    if !(e2 < ORBIT_MAX_ECCENTRICITY * ORBIT_MAX_ECCENTRICITY) {
        return Err(OrbitError::TooEccentric);
    }
    let ecc = sqrt(e2);
    // Mean anomaly change, reduced to about (−π, π]: the motion is 2π-periodic in ΔE.
    // |ΔM| ≤ 2^1.5 · 86,400 / 736 < 400 rad (α < 2, T ≥ 736 s at 6,000 km), so |k| < 64.
    let dm = alpha * sqrt_alpha * (dt_s / t_unit);
    let k = floor(dm * (0.5 * core::f32::consts::FRAC_1_PI) + 0.5);
    let m = (dm - k * TWO_PI_HI) - k * TWO_PI_LO;

    let (x, _iterations) = solve_kepler_delta(m, e_cos, e_sin, ecc).ok_or(OrbitError::NoConvergence)?;

    let (sh, ch) = sin_cos(0.5 * x);
    let sin_x = 2.0 * sh * ch;
    let one_m_cos = 2.0 * sh * sh;
    let a = 1.0 / alpha; // a / L
    let rr = (1.0 - one_m_cos) + one_m_cos * a + sigma * sin_x / sqrt_alpha; // |r| / L
    let f = 1.0 - one_m_cos * a;
    let g = sin_x / sqrt_alpha + sigma * one_m_cos * a;
    let fdot = -sin_x / (sqrt_alpha * rr);
    let gdot = 1.0 - one_m_cos * a / rr;
    let r1 = (r * f + v * g) * l;
    let v1 = (r * fdot + v * gdot) * v_unit;
    if all_finite(r1.as_slice()) && all_finite(v1.as_slice()) { Ok((r1, v1)) } else { Err(OrbitError::NonFinite) }
}

/// Longest `|dt|` the short step ([`propagate_short`]) takes, s: four 1 Hz GNSS fixes.
pub const SHORT_STEP_MAX_S: f32 = 4.0;
/// Bound on `|d³r/dt³|` of any elliptic orbit over a short step, m/s³ (see
/// [`propagate_short`]): `2 μ v / r³` with `r ≥ 5.95e6` m and `v < √(2μ / r)`.
pub const SHORT_STEP_JERK_MAX_M_S3: f32 = 0.0439;

/// Bound on the short step's truncation error against two-body motion, m:
/// `SHORT_STEP_JERK_MAX_M_S3 · |dt|³ / 6` (7.3 mm at 1 s, 0.47 m at 4 s).
pub fn short_step_truncation_m(dt_s: f32) -> f32 {
    let t = libm::fabsf(dt_s);
    SHORT_STEP_JERK_MAX_M_S3 * t * t * t / 6.0
}

/// Bound on `|d⁴r/dt⁴|` of any elliptic orbit over a short step, m/s⁴ (see
/// [`propagate_short`]): `(μ/r²)(24 v²/r² + 2μ/r³)` with `r ≥ 5.95e6` m, `v < 11.58 km/s`.
pub const SHORT_STEP_SNAP_MAX_M_S4: f32 = 1.07e-3;

/// Bound on the short step's velocity truncation against two-body motion, m/s:
/// `SHORT_STEP_SNAP_MAX_M_S4 · |dt|³ / 6` (0.18 mm/s at 1 s, 11.4 mm/s at 4 s).
pub fn short_step_velocity_truncation_m_s(dt_s: f32) -> f32 {
    let t = libm::fabsf(dt_s);
    SHORT_STEP_SNAP_MAX_M_S4 * t * t * t / 6.0
}

/// Position (m) and velocity (m/s) `dt_s` after the fix `(r0_m, v0_m_s)`, two-body, by the
/// second-order Taylor steps `r0 + v0 dt + ½ a0 dt²` and `v0 + a0 dt + ½ j0 dt²`
/// (`a0 = −μ r0 / |r0|³`, `j0 = −(μ/r³)(v0 − 3 r̂ (r̂·v0))` the jerk): a few dozen
/// operations where [`propagate_two_body`] solves Kepler's equation. For
/// `|dt| ≤` [`SHORT_STEP_MAX_S`] only.
///
/// Truncation (Taylor's remainder in integral form holds for vectors): at most
/// `max |r'''| |dt|³ / 6`. With `r''' = −μ (v − 3 r̂ (r̂·v)) / r³` and
/// `|v − 3 r̂ (r̂·v)| = √(4 v_r² + v_t²) ≤ 2 |v|`, `|r'''| ≤ 2 μ |v| / r³`. An elliptic orbit
/// keeps `v² < 2μ / r`; from `|r0| ≥` [`ORBIT_MIN_RADIUS_M`] it falls at most
/// `√(2μ / 5.95e6) · 4 s` = 46 km in 4 s, so `r ≥ 5.95e6` m, `v < 11.58 km/s` and
/// `|r'''| < 2 · 3.986e14 · 1.158e4 / 5.95e6³ = 0.0438` m/s³ ([`SHORT_STEP_JERK_MAX_M_S3`],
/// [`short_step_truncation_m`]). Rounding: the last addition to `r0`, half an ulp per axis
/// (≤ 0.43 m below |r| = 8,388 km), the displacement's own far less.
///
/// Velocity truncation: at most `max |r''''| |dt|³ / 6`. The f and g series (Battin §4.3:
/// `f₄ = (3uq − 15up² + u²)/24`, `g₄ = up/4` with `u = μ/r³`, `p = r·v/r²`,
/// `q = v²/r² − u`) give `r'''' = (3uq − 15up² + u²) r + 6up v`; with `|p| ≤ w = v/r`,
/// `|r''''| ≤ u r (24 w² + 2u)`, which over the same range is < 1.07e-3 m/s⁴
/// ([`SHORT_STEP_SNAP_MAX_M_S4`], [`short_step_velocity_truncation_m_s`]). Rounding: half
/// an ulp per axis of the result, ≤ 0.85 mm/s below 16.4 km/s.
pub fn propagate_short(r0_m: &Vec3, v0_m_s: &Vec3, dt_s: f32) -> Result<(Vec3, Vec3), OrbitError> {
    if !(all_finite(r0_m.as_slice()) && all_finite(v0_m_s.as_slice()) && dt_s.is_finite()) {
        return Err(OrbitError::NonFinite);
    }
    if !(libm::fabsf(dt_s) <= SHORT_STEP_MAX_S) {
        return Err(OrbitError::TimeOutOfRange);
    }
    let r2 = r0_m.norm_squared();
    let l = sqrt(r2);
    if !(ORBIT_MIN_RADIUS_M..=ORBIT_MAX_RADIUS_M).contains(&l) {
        return Err(OrbitError::RadiusOutOfRange);
    }
    let mu_over_r = MU_EARTH_M3_S2 / l;
    // v² < 2μ / r: the bound above needs an ellipse (`!(x < y)` also catches NaN).
    if !(v0_m_s.norm_squared() < 2.0 * mu_over_r) {
        return Err(OrbitError::NotElliptic);
    }
    // r0 + dt (v0 − ½ dt (μ / r³) r0): the displacement first, added to r0 once.
    let k = mu_over_r / r2;
    let half_k_dt = 0.5 * k * dt_s;
    let r1 = r0_m + (v0_m_s - r0_m * half_k_dt) * dt_s;
    // v0 − k dt (r0 + ½ dt (v0 − 3 p r0)), p = r0·v0 / r²: the change first, added once.
    let p = r0_m.dot(v0_m_s) / r2;
    let v1 = v0_m_s - (r0_m + (v0_m_s - r0_m * (3.0 * p)) * (0.5 * dt_s)) * (k * dt_s);
    if all_finite(r1.as_slice()) && all_finite(v1.as_slice()) { Ok((r1, v1)) } else { Err(OrbitError::NonFinite) }
}

/// Root `x = ΔE` of `x − c sin x + s (1 − cos x) = m` (`c = e cos E0`, `s = e sin E0`,
/// `e = √(c² + s²) < 1`): safeguarded Newton in the bracket `[m − 2e, m + 2e]`, which holds
/// the root because the sine terms differ from `x` by at most `2e`. `None` if no Newton
/// step fell below the tolerance within [`KEPLER_MAX_ITERATIONS`]; with the root, the
/// number of iterations used.
fn solve_kepler_delta(m: f32, c: f32, s: f32, e: f32) -> Option<(f32, u32)> {
    let pad = 2.0 * e + 1e-6;
    let (mut lo, mut hi) = (m - pad, m + pad);
    let mut x = if e < 0.3 {
        // First-order start: x ≈ m + c sin m − s (1 − cos m).
        let (sm, cm) = sin_cos(m);
        m + c * sm - s * (1.0 - cm)
    } else {
        // Danby's start for the absolute anomalies, E = M + 0.85 e sign(sin M) (Danby,
        // *Fundamentals of Celestial Mechanics*, 1988, §6.6), shifted by E0:
        // E0 = atan2(s, c), M = E0 − s + m.
        let e0 = atan2(s, c);
        let mean = e0 - s + m;
        let sign = if sin(mean) >= 0.0 { 1.0 } else { -1.0 };
        mean + 0.85 * e * sign - e0
    };
    if !(x > lo && x < hi) {
        x = m;
    }
    for it in 1..=KEPLER_MAX_ITERATIONS {
        let (sx, cx) = sin_cos(x);
        let fx = x - c * sx + s * (1.0 - cx) - m;
        if fx == 0.0 {
            return Some((x, it));
        }
        // F is increasing: the root is below x when F(x) > 0.
        if fx > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let dfx = 1.0 - c * cx + s * sx; // = 1 − e cos E ≥ 1 − e > 0.1
        let newton = x - fx / dfx;
        // Inclusive: a step that rounds to zero at a bracket end is convergence.
        if newton >= lo && newton <= hi {
            let step = newton - x;
            x = newton;
            if libm::fabsf(step) <= KEPLER_STEP_TOL_RAD {
                return Some((x, it));
            }
        } else {
            // Newton left the bracket (or NaN): bisect instead.
            x = 0.5 * (lo + hi);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Iterations used over a dense sweep of e in [0, 0.9), perigee phase and ΔM.
    #[test]
    fn kepler_iterations_over_a_sweep() {
        let mut worst = 0;
        let mut hist = [0u32; 17];
        for ie in 0..90 {
            let e = ie as f32 * 0.01;
            for ip in 0..64 {
                let e0 = ip as f32 * core::f32::consts::TAU / 64.0;
                let (s0, c0) = sin_cos(e0);
                for im in 0..200 {
                    let m = -core::f32::consts::PI + im as f32 * core::f32::consts::TAU / 200.0;
                    let (x, it) = solve_kepler_delta(m, e * c0, e * s0, e).unwrap();
                    let resid = x - e * c0 * sin_cos(x).0 + e * s0 * (1.0 - sin_cos(x).1) - m;
                    assert!(resid.abs() < 2e-6, "e {e} E0 {e0} m {m}: residual {resid}");
                    worst = worst.max(it);
                    hist[it as usize] += 1;
                }
            }
        }
        // When written: [0, 21544, 280852, 758371, 86827, 4238, 104, 50, 12, 2, 0, ...].
        assert!(hist.iter().take(5).sum::<u32>() * 1000 >= hist.iter().sum::<u32>() * 995);
        assert!(worst <= 10, "measured 9 when written");
    }

    /// f64 two-body acceleration and a fine RK4 (0.01 s steps: its error over 4 s is
    /// ~1e-12 of r): the independent truth for the short step.
    fn accel64(r: [f64; 3]) -> [f64; 3] {
        let n = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
        let k = -f64::from(MU_EARTH_M3_S2) / (n * n * n);
        [k * r[0], k * r[1], k * r[2]]
    }

    fn rk4_64(r0: &Vec3, v0: &Vec3, dt: f64) -> [f64; 6] {
        let mut y = [r0.x, r0.y, r0.z, v0.x, v0.y, v0.z].map(f64::from);
        let f = |y: &[f64; 6]| {
            let a = accel64([y[0], y[1], y[2]]);
            [y[3], y[4], y[5], a[0], a[1], a[2]]
        };
        let steps = (dt.abs() / 0.01).ceil().max(1.0) as usize;
        let h = dt / steps as f64;
        for _ in 0..steps {
            let add = |y: &[f64; 6], k: &[f64; 6], c: f64| core::array::from_fn(|i| y[i] + c * k[i]);
            let k1 = f(&y);
            let k2 = f(&add(&y, &k1, h / 2.0));
            let k3 = f(&add(&y, &k2, h / 2.0));
            let k4 = f(&add(&y, &k3, h));
            y = core::array::from_fn(|i| y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        }
        y
    }

    /// Fixes at periapsis, apoapsis and between, e from 0 to 0.8, the periapsis from
    /// 6,000 km (the fastest state the bound allows: 10.9 km/s) up.
    fn short_step_orbits() -> Vec<(Vec3, Vec3)> {
        let mu = f64::from(MU_EARTH_M3_S2);
        let mut out = Vec::new();
        for &(rp, e) in &[(6.995e6, 0.0), (6.6e6, 0.1), (6.0e6, 0.5), (6.0e6, 0.8), (7.0e6, 0.3)] {
            let p = rp * (1.0 + e);
            for k in 0..8 {
                let nu = f64::from(k) * core::f64::consts::TAU / 8.0;
                let (s, c) = nu.sin_cos();
                let r = p / (1.0 + e * c);
                let (vr, vt) = ((mu / p).sqrt() * e * s, (mu / p).sqrt() * (1.0 + e * c));
                // An inclined plane: x along the node, the orbit tilted by 98° about it.
                let (si, ci) = (98f64.to_radians().sin(), 98f64.to_radians().cos());
                let pos = [r * c, r * s * ci, r * s * si];
                let vel = [vr * c - vt * s, (vr * s + vt * c) * ci, (vr * s + vt * c) * si];
                out.push((Vec3::from(pos.map(|x| x as f32)), Vec3::from(vel.map(|x| x as f32))));
            }
        }
        out
    }

    /// The Taylor step against an f64 RK4 of the same (f32) fix: within the truncation
    /// bound `0.0439 |dt|³ / 6` plus the rounding of the final addition (half an ulp per
    /// axis: ≤ 0.43 m below 8,388 km) and of the displacement (16 ulps allowed); and in f64,
    /// the truncation alone within its bound.
    #[test]
    fn the_short_step_is_within_its_truncation_bound() {
        // Worst truncation / bound, worst f32 error, worst f32 error below 8,388 km.
        let mut worst = [0.0f64; 3];
        let mut worst_v = 0.0f64;
        for (r0, v0) in short_step_orbits() {
            for &dt in &[0.5f32, 1.0, 2.0, -1.0, 3.0, SHORT_STEP_MAX_S] {
                let truth = rk4_64(&r0, &v0, f64::from(dt));
                let dist = |x: [f64; 3]| (0..3).map(|i| (x[i] - truth[i]).powi(2)).sum::<f64>().sqrt();
                let dist_v = |x: [f64; 3]| (0..3).map(|i| (x[i] - truth[i + 3]).powi(2)).sum::<f64>().sqrt();
                let bound = f64::from(short_step_truncation_m(dt));
                // f64 Taylor: the truncation alone.
                let (r, v) = ([r0.x, r0.y, r0.z].map(f64::from), [v0.x, v0.y, v0.z].map(f64::from));
                let a = accel64(r);
                let d = f64::from(dt);
                let taylor64 = dist(core::array::from_fn(|i| r[i] + v[i] * d + 0.5 * a[i] * d * d));
                assert!(taylor64 <= bound, "f64 Taylor {taylor64} m > bound {bound} m (dt {dt})");
                // The velocity: f64 Taylor (the jerk by finite difference of the f64
                // acceleration along the RK4 arc, a second method) within its bound, and the
                // f32 step within that bound plus half an ulp per axis.
                let bound_v = f64::from(short_step_velocity_truncation_m_s(dt));
                let h = 1e-3;
                let (rp, rm) = (rk4_64(&r0, &v0, h), rk4_64(&r0, &v0, -h));
                let (ap, am) = (accel64([rp[0], rp[1], rp[2]]), accel64([rm[0], rm[1], rm[2]]));
                let jerk: [f64; 3] = core::array::from_fn(|i| (ap[i] - am[i]) / (2.0 * h));
                let taylor64_v = dist_v(core::array::from_fn(|i| v[i] + a[i] * d + 0.5 * jerk[i] * d * d));
                assert!(taylor64_v <= bound_v, "f64 Taylor velocity {taylor64_v} m/s > {bound_v} m/s (dt {dt})");
                // The flight's f32 step.
                let (got, got_v) = propagate_short(&r0, &v0, dt).unwrap();
                let half_ulp_v = |x: f32| 0.5 * f64::from(f32::from_bits(x.abs().to_bits() + 1) - x.abs());
                let rounding_v =
                    (half_ulp_v(got_v.x).powi(2) + half_ulp_v(got_v.y).powi(2) + half_ulp_v(got_v.z).powi(2)).sqrt()
                        + 1e-6 * f64::from(norm(&(got_v - v0)));
                let err_v = dist_v([got_v.x, got_v.y, got_v.z].map(f64::from));
                assert!(err_v <= bound_v + rounding_v, "f32 velocity {err_v} m/s > {bound_v} + {rounding_v} (dt {dt})");
                worst_v = worst_v.max(taylor64_v / bound_v);
                let err = dist([got.x, got.y, got.z].map(f64::from));
                // Half an ulp of each axis of the result, and 16 ulps of the displacement.
                let half_ulp = |x: f32| 0.5 * f64::from(f32::from_bits(x.abs().to_bits() + 1) - x.abs());
                let half_ulps = (half_ulp(got.x).powi(2) + half_ulp(got.y).powi(2) + half_ulp(got.z).powi(2)).sqrt();
                let rounding = half_ulps + 1e-6 * f64::from(norm(&(got - r0)));
                assert!(err <= bound + rounding, "f32 step {err} m > {bound} + {rounding} m (dt {dt})");
                let leo = if norm(&r0) < 8.0e6 { err } else { 0.0 };
                worst = [worst[0].max(taylor64 / bound), worst[1].max(err), worst[2].max(leo)];
            }
        }
        let [t, e, leo] = worst;
        println!(
            "short step: worst f64 truncation / bound {t:.3} (velocity {worst_v:.3}), f32 error {e:.3} m ({leo:.3} m from |r0| < 8,000 km)"
        );
    }

    /// The short step agrees with the Kepler step over its range (the two methods within
    /// the truncation bound and both roundings: the navigation's 4 m for Kepler's), and
    /// refuses what the Kepler step refuses for the bound's sake.
    #[test]
    fn the_short_step_matches_kepler_and_refuses_bad_input() {
        for (r0, v0) in short_step_orbits() {
            for &dt in &[1.0f32, SHORT_STEP_MAX_S] {
                let (taylor, taylor_v) = propagate_short(&r0, &v0, dt).unwrap();
                let (kepler, kepler_v) = propagate_two_body(&r0, &v0, dt).unwrap();
                // Velocity: the truncation, half an ulp per axis (≤ 0.85 mm/s) and Kepler's
                // 16 · 2⁻²⁴ · v · (1 + |ΔM|) (sim-host/core/tests/onboard_orbit.rs): 12 mm/s.
                let tol_v = short_step_velocity_truncation_m_s(dt) + 0.001 + 0.012;
                let dv = norm(&(taylor_v - kepler_v));
                assert!(dv <= tol_v, "dt {dt}: velocity {dv} m/s");
                // Rounding: half an ulp per axis of the short step's result (≤ 1.8 m out to
                // the 18,000 km apoapsis) and the navigation's 4 m for Kepler's.
                let tol = short_step_truncation_m(dt) + 1.8 + 4.0;
                assert!(norm(&(taylor - kepler)) <= tol, "dt {dt}: {} m", norm(&(taylor - kepler)));
            }
        }
        let (r, v) = (Vec3::new(7.0e6, 0.0, 0.0), Vec3::new(0.0, 7.5e3, 0.0));
        assert_eq!(propagate_short(&r, &v, 0.0), Ok((r, v)));
        assert_eq!(propagate_short(&r, &v, 4.001), Err(OrbitError::TimeOutOfRange));
        assert_eq!(propagate_short(&r, &v, f32::NAN), Err(OrbitError::NonFinite));
        assert_eq!(propagate_short(&Vec3::new(f32::NAN, 0.0, 0.0), &v, 1.0), Err(OrbitError::NonFinite));
        assert_eq!(propagate_short(&Vec3::new(5.9e6, 0.0, 0.0), &v, 1.0), Err(OrbitError::RadiusOutOfRange));
        // Escape speed at 7,000 km is 10.67 km/s.
        assert_eq!(propagate_short(&r, &Vec3::new(0.0, 10.7e3, 0.0), 1.0), Err(OrbitError::NotElliptic));
        assert_eq!(propagate_short(&r, &Vec3::new(0.0, f32::MAX, 0.0), 1.0), Err(OrbitError::NotElliptic));
    }
}
