//! The environment of one run: orbit (or none: a lab rig), Earth rotation, magnetic field
//! and disturbance torques, sampled into an [`EnvSnapshot`] at a time.
//!
//! Everything in a snapshot is a function of time only (position, velocity, field in the
//! reference frame, LVLH); the torques combine it with the attitude of the moment. The
//! plant integrates with a snapshot at every RK4 stage time — `t`, `t + h/2` (stages 2
//! and 3), `t + h` (stage 4, which is the next step's stage 1) — so the environment
//! torques are as accurate as the attitude: holding one snapshot over a step would make
//! the error first order in the step (issue 9). [`SnapshotCache`] keeps the last
//! snapshots so each of those times is evaluated once: two new evaluations per RK4 step,
//! and the control step's own snapshot (the sensors') is the last stage of the step
//! before. Stage times get only what the dynamics use ([`Parts`]): the orbit state, and
//! the field only with a dipole on board; the LVLH frame is added at control steps.

use super::frames::{EarthRotation, q_lvlh_to_eci, rot_lvlh_to_eci};
use super::magnetic::MagneticField;
use super::orbit::OrbitPropagator;
use super::torques::{Disturbances, TorqueBreakdown};
use crate::attitude::{Quat, Vec3};
use anyhow::{Result, anyhow};
use nalgebra::UnitQuaternion;

/// Where the magnetic field comes from.
#[derive(Clone, Debug)]
pub enum FieldSource {
    None,
    /// Constant field in the reference frame (a lab rig), T.
    Fixed(Vec3),
    /// Earth model along the orbit (ECI).
    Model(MagneticField),
    /// The field frozen at one instant (stability margins at an orbit instant,
    /// docs/margins.md "Magnetorquer loops"): constant in the frame the spacecraft holds.
    Frozen(FrozenField),
}

/// A field frozen at an instant, T: constant in the reference frame (ECI or the lab: an
/// inertial hold), or in LVLH (an LVLH hold: the field keeps the direction it had relative
/// to the orbiting frame, so the body sees a constant field at the hold while the orbit,
/// gravity gradient and LVLH rate go on).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FrozenField {
    Reference(Vec3),
    Lvlh(Vec3),
}

#[derive(Clone, Debug)]
pub struct Environment {
    pub orbit: Option<OrbitPropagator>,
    pub earth: EarthRotation,
    pub field: FieldSource,
    /// Gravity gradient, drag, SRP, external; the residual dipole is handled with the
    /// torquers (it is a dipole in the same field).
    pub disturbances: Disturbances,
}

impl Environment {
    /// Julian date (UT1) at simulation time `t_s`, for the Sun ephemeris (J2000.0 at
    /// t = 0 without an epoch).
    pub fn julian_date(&self, t_s: f64) -> f64 {
        (match self.earth {
            EarthRotation::Gmst { jd_ut1_epoch } => jd_ut1_epoch,
            EarthRotation::Simple { .. } => 2_451_545.0,
        }) + t_s / 86_400.0
    }

    /// Whether the spacecraft at ECI position `r_m` is in the Earth's (cylindrical) shadow
    /// at `t_s`.
    pub fn in_eclipse(&self, t_s: f64, r_m: &Vec3) -> bool {
        crate::environment::torques::in_shadow_cylindrical(
            r_m,
            &crate::environment::torques::sun_position_eci(self.julian_date(t_s)),
        )
    }
}

/// The environment at one time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnvSnapshot {
    pub t_s: f64,
    /// ECI position and velocity.
    pub orbit: Option<(Vec3, Vec3)>,
    /// Field in the reference frame (ECI, or the lab), T.
    pub b_ref_t: Option<Vec3>,
    /// LVLH → ECI, and the LVLH frame's angular velocity in ECI axes.
    pub q_lvlh: Option<Quat>,
    pub lvlh_rate_ref: Vec3,
}

/// The parts of a snapshot beyond the orbit state, which the dynamics need only sometimes:
/// the field only with a dipole on board, the LVLH frame only at control steps (sensors,
/// targets, telemetry).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Parts {
    pub field: bool,
    pub lvlh: bool,
}

impl Parts {
    pub const ALL: Parts = Parts { field: true, lvlh: true };

    fn covers(&self, need: Parts) -> bool {
        (self.field || !need.field) && (self.lvlh || !need.lvlh)
    }
}

impl Environment {
    pub fn snapshot(&mut self, t_s: f64) -> Result<EnvSnapshot> {
        self.snapshot_parts(t_s, Parts::ALL)
    }

    /// The orbit state at `t_s` and the `parts` asked for (the others left at their
    /// defaults); each part is the same as in the full [`Self::snapshot`].
    pub fn snapshot_parts(&mut self, t_s: f64, parts: Parts) -> Result<EnvSnapshot> {
        let mut s = EnvSnapshot { t_s, ..Default::default() };
        if let Some(o) = self.orbit.as_mut() {
            let (r, v) = o.try_state_at(t_s).map_err(|e| anyhow!("orbit at t = {t_s} s: {e:?}"))?;
            s.orbit = Some((r, v));
        }
        self.complete(&mut s, parts)?;
        Ok(s)
    }

    /// Add `parts` to a snapshot that holds the orbit state of its time.
    fn complete(&self, s: &mut EnvSnapshot, parts: Parts) -> Result<()> {
        if parts.lvlh
            && let Some((r, v)) = s.orbit
        {
            s.q_lvlh = Some(*q_lvlh_to_eci(&r, &v).quaternion());
            s.lvlh_rate_ref = r.cross(&v) / r.norm_squared();
        }
        if parts.field {
            let t_s = s.t_s;
            s.b_ref_t = match (&self.field, s.orbit) {
                (FieldSource::Fixed(b), _) => Some(*b),
                (FieldSource::Model(m), Some((r, _))) => {
                    Some(m.b_eci_t(&r, t_s).map_err(|e| anyhow!("magnetic field at t = {t_s} s: {e:?}"))?)
                }
                (FieldSource::Frozen(FrozenField::Reference(b)), _) => Some(*b),
                (FieldSource::Frozen(FrozenField::Lvlh(b)), Some((r, v))) => Some(rot_lvlh_to_eci(&r, &v) * b),
                _ => None,
            };
        }
        Ok(())
    }

    /// [`Self::snapshot_parts`] through `cache`: a cached instant is completed with the
    /// parts it lacks.
    pub fn snapshot_cached(&mut self, t_s: f64, parts: Parts, cache: &mut SnapshotCache) -> Result<EnvSnapshot> {
        if let Some(i) = cache.find(t_s) {
            let (s, has) = cache.entries[i].as_mut().expect("found");
            if !has.covers(parts) {
                let missing = Parts { field: parts.field && !has.field, lvlh: parts.lvlh && !has.lvlh };
                self.complete(s, missing)?;
                has.field |= parts.field;
                has.lvlh |= parts.lvlh;
            }
            return Ok(*s);
        }
        let s = self.snapshot_parts(t_s, parts)?;
        cache.insert(s, parts);
        Ok(s)
    }

    /// Freezes the field at its value in `snap` (the environment at the instant to freeze):
    /// in LVLH (`in_lvlh`, needs an orbit) or in the reference frame. `None` (and nothing
    /// changed) without a field or, in LVLH, without an orbit.
    pub fn freeze_field(&mut self, snap: &EnvSnapshot, in_lvlh: bool) -> Option<FrozenField> {
        let b = snap.b_ref_t?;
        let frozen = if in_lvlh {
            let (r, v) = snap.orbit?;
            FrozenField::Lvlh(rot_lvlh_to_eci(&r, &v).transpose() * b)
        } else {
            FrozenField::Reference(b)
        };
        self.field = FieldSource::Frozen(frozen);
        Some(frozen)
    }

    /// Environmental torques on the body at time `t_s` and attitude `q`, with `snap` the
    /// environment at `t_s` (the SRP Sun position is evaluated at `t_s` here).
    pub fn torques(&self, t_s: f64, q: &Quat, snap: &EnvSnapshot) -> TorqueBreakdown {
        let uq = UnitQuaternion::new_unchecked(*q);
        match snap.orbit {
            Some((r, v)) => self.disturbances.torques_b(t_s, &r, &v, &uq, None),
            None => {
                let ext = self.disturbances.external.eval(t_s);
                TorqueBreakdown { external: ext, total: ext, ..Default::default() }
            }
        }
    }
}

/// The last few snapshots, by time, with the parts each holds: an RK4 step asks for `t`,
/// `t + h/2`, `t + h` and the next step (or control step) starts at `t + h` again. Times within a relative 1e-12
/// (a few thousand ulps: `t + j h` and `t + (j + 1) h` computed differently) are the same
/// instant — at 10⁵ s that is 0.1 µs, under a millimetre of orbit. The cache belongs to
/// one environment: clear it when the environment is replaced.
#[derive(Clone, Debug, Default)]
pub struct SnapshotCache {
    entries: [Option<(EnvSnapshot, Parts)>; 3],
    next: usize,
}

impl SnapshotCache {
    const SAME_INSTANT_REL: f64 = 1e-12;

    fn find(&self, t_s: f64) -> Option<usize> {
        let tol = Self::SAME_INSTANT_REL * t_s.abs().max(1.0);
        self.entries.iter().position(|e| e.as_ref().is_some_and(|(s, _)| (s.t_s - t_s).abs() <= tol))
    }

    fn insert(&mut self, s: EnvSnapshot, parts: Parts) {
        self.entries[self.next] = Some((s, parts));
        self.next = (self.next + 1) % self.entries.len();
    }

    pub fn clear(&mut self) {
        *self = Self::default();
    }
}
