//! The environment of one run: orbit (or none: a lab rig), Earth rotation, magnetic field
//! and disturbance torques, sampled once per dynamics step into an [`EnvSnapshot`].
//!
//! The orbit position changes by metres within a dynamics step, so torques that depend
//! on it (gravity gradient, drag, SRP, the field) use the snapshot taken at the start of
//! the step while the attitude inside the RK4 stages stays exact.

use super::frames::{EarthRotation, q_lvlh_to_eci};
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

/// The environment at the start of a dynamics step.
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

impl Environment {
    pub fn snapshot(&mut self, t_s: f64) -> Result<EnvSnapshot> {
        let mut s = EnvSnapshot { t_s, ..Default::default() };
        if let Some(o) = self.orbit.as_mut() {
            let (r, v) = o.try_state_at(t_s).map_err(|e| anyhow!("orbit at t = {t_s} s: {e:?}"))?;
            s.orbit = Some((r, v));
            s.q_lvlh = Some(*q_lvlh_to_eci(&r, &v).quaternion());
            s.lvlh_rate_ref = r.cross(&v) / r.norm_squared();
        }
        s.b_ref_t = match (&self.field, s.orbit) {
            (FieldSource::Fixed(b), _) => Some(*b),
            (FieldSource::Model(m), Some((r, _))) => {
                Some(m.b_eci_t(&r, t_s).map_err(|e| anyhow!("magnetic field at t = {t_s} s: {e:?}"))?)
            }
            _ => None,
        };
        Ok(s)
    }

    /// Environmental torques on the body at time `t_s` (inside a step) and attitude `q`.
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
