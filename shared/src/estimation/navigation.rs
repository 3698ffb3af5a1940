//! On-board navigation: the last GNSS fix, carried forward between fixes, and what
//! guidance and attitude determination derive from it (time, LVLH).
//!
//! A fix ([`GnssFix`], from `SensorFrame::gnss_*` flagged `Valid::GNSS`) is accepted when finite and
//! plausible (|r| within [6,000 km, 100,000 km], |v| < 20 km/s, a valid J2000 time). Between
//! fixes the position and velocity are propagated from the last fix over its age in one
//! closed-form two-body step ([`crate::models::orbit`], no accumulated rounding); time is
//! the fix's GNSS time plus the on-board clock's elapsed `time_us`. A fix older than
//! [`MAX_FIX_AGE_S`] (or one the propagation refuses) gives no solution: LVLH pointing
//! then stops commanding (`Status::NO_ESTIMATE`) rather than follow a stale orbit.

use crate::math::{Quat, Vec3, norm, rotate_body_to_ref};
use crate::models::lvlh::lvlh;
use crate::models::orbit::{SHORT_STEP_MAX_S, propagate_short, propagate_two_body};
use crate::models::time::J2000Time;
use crate::types::{GnssFix, PredictedFix};

/// Longest time a fix is carried forward, s (three LEO orbits). Two-body propagation
/// ignores J2: from a 617 km fix it is 3.5 km off after 600 s and 108 km (0.9° of LVLH)
/// after one orbit (sim-host/core/tests/onboard_orbit.rs); f32 rounding adds < 4 m. Beyond
/// three orbits the frame is no longer worth pointing at.
pub const MAX_FIX_AGE_S: f32 = 18_000.0;

/// A navigation solution at the step's time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavSolution {
    /// Inertial position and velocity, m, m/s.
    pub r_m: Vec3,
    pub v_m_s: Vec3,
    pub time: J2000Time,
    /// LVLH → inertial, and the LVLH frame's angular velocity in inertial axes, rad/s
    /// (what guidance composes a `Reference` target with).
    pub q_lvlh: Quat,
    pub lvlh_rate_rad_s: Vec3,
    /// Age of the fix it was propagated from, s (0: a fresh fix).
    pub fix_age_s: f32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Fix {
    r_m: Vec3,
    v_m_s: Vec3,
    time: J2000Time,
    time_us: u64,
}

/// The navigation state: the last accepted fix.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Navigation {
    fix: Option<Fix>,
    /// Fixes refused as implausible (saturating).
    pub refused: u32,
}

fn accept(g: &GnssFix) -> Option<Fix> {
    let (r, v) = (g.pos_eci_m, g.vel_eci_m_s);
    let (rn, vn) = (norm(&r), norm(&v));
    if !(rn.is_finite() && vn.is_finite() && (6.0e6..=1.0e8).contains(&rn) && vn < 2.0e4) {
        return None;
    }
    let time = J2000Time::new(g.j2000_days, g.j2000_s)?;
    Some(Fix { r_m: r, v_m_s: v, time, time_us: g.time_us })
}

impl Navigation {
    pub const fn new() -> Self {
        Self { fix: None, refused: 0 }
    }

    /// Take this step's fix (if any) and return the solution at the step's time `time_us`.
    pub fn update(&mut self, time_us: u64, gnss: Option<&GnssFix>) -> Option<NavSolution> {
        if let Some(g) = gnss {
            match accept(g) {
                Some(x) => self.fix = Some(x),
                None => self.refused = self.refused.saturating_add(1),
            }
        }
        let (r, v, time, age_s) = self.state_at(time_us)?;
        let frame = lvlh(&r, &v).ok()?;
        Some(NavSolution {
            r_m: r,
            v_m_s: v,
            time,
            q_lvlh: frame.q_eci_lvlh,
            lvlh_rate_rad_s: rotate_body_to_ref(&frame.q_eci_lvlh, &frame.rate_lvlh_rad_s),
            fix_age_s: age_s,
        })
    }

    /// Position (inertial, m) and time the last fix gives at `time_us` — the same numbers
    /// as [`Navigation::update`] at that time without a new fix — for the reference models
    /// to evaluate ahead of time (`super::references`). `None` like `update`.
    pub fn predict(&self, time_us: u64) -> Option<(Vec3, J2000Time)> {
        self.state_at(time_us).map(|(r, _, time, _)| (r, time))
    }

    /// The last fix's position and velocity carried to `time_us` and the time it was
    /// carried over: what the GNSS monitor judges a new fix against
    /// ([`crate::fdir::gnss`]). Up to [`SHORT_STEP_MAX_S`] (the usual 1 s between fixes) by
    /// the Taylor step [`propagate_short`] (within 0.47 m and 11 mm/s of two-body motion,
    /// rounding 0.43 m and 0.85 mm/s in LEO), beyond it by `update`'s Kepler step. `None` when there is no fix,
    /// the clock went back, or the step refuses the fix (and, beyond the short step, like
    /// `update`).
    pub fn predict_fix(&self, time_us: u64) -> Option<PredictedFix> {
        let (fix, age_us, age_s) = self.age_at(time_us)?;
        let (r_m, v_m_s) = if age_us == 0 {
            (fix.r_m, fix.v_m_s)
        } else if age_s <= SHORT_STEP_MAX_S {
            propagate_short(&fix.r_m, &fix.v_m_s, age_s).ok()?
        } else {
            let (r, v, _, _) = carried(&fix, age_us, age_s)?;
            (r, v)
        };
        Some(PredictedFix { r_m, v_m_s, dt_s: age_s })
    }

    /// The last fix and its age at `time_us`, µs and s (`None` past [`MAX_FIX_AGE_S`]).
    fn age_at(&self, time_us: u64) -> Option<(Fix, u64, f32)> {
        let fix = self.fix?;
        // A step older than the fix (clock reset): no solution until the next fix.
        let age_us = time_us.checked_sub(fix.time_us)?;
        #[allow(clippy::cast_precision_loss)] // µs → s: f32 keeps 1e-7 relative
        let age_s = age_us as f32 * 1.0e-6;
        if !(age_s <= MAX_FIX_AGE_S) {
            return None;
        }
        Some((fix, age_us, age_s))
    }

    /// Position, velocity, time and fix age at `time_us`, propagated from the last fix.
    fn state_at(&self, time_us: u64) -> Option<(Vec3, Vec3, J2000Time, f32)> {
        let (fix, age_us, age_s) = self.age_at(time_us)?;
        carried(&fix, age_us, age_s)
    }

    pub fn reset(&mut self) {
        *self = Self::default();
    }
}

/// The fix carried over its age by the Kepler step: position, velocity, time and age.
fn carried(fix: &Fix, age_us: u64, age_s: f32) -> Option<(Vec3, Vec3, J2000Time, f32)> {
    let (r, v) =
        if age_us == 0 { (fix.r_m, fix.v_m_s) } else { propagate_two_body(&fix.r_m, &fix.v_m_s, age_s).ok()? };
    let time = fix.time.add_seconds(age_s)?;
    Some((r, v, time, age_s))
}
