//! Keep-out cones seen by the truth (with `[manoeuvre]` and an orbit): each boresight's
//! margin to each of its cones from the true attitude, the true Sun and the true Earth
//! (angle to the cone's edge, deg, negative inside), the flight's slew phase and counters,
//! and over the run the smallest margin per boresight and cone (docs/outputs.md).

use crate::attitude::{Quat, Vec3};
use crate::sensors::star_tracker::ExclusionGeometry;
use acs_flight::link::GuidanceTelemetry;
use nalgebra::UnitQuaternion;
use serde::Serialize;
use std::collections::BTreeMap;

/// One boresight and its cones, f64.
#[derive(Clone, Debug, PartialEq)]
pub struct Cone {
    pub name: String,
    pub boresight_body: Vec3,
    pub sun_half_angle_rad: Option<f64>,
    pub earth_margin_rad: Option<f64>,
}

impl Cone {
    /// `(sun, earth)` margins, rad, at the true attitude `q_ib` (body → inertial).
    pub fn margins_rad(&self, q_ib: &Quat, g: &ExclusionGeometry) -> (Option<f64>, Option<f64>) {
        let b = UnitQuaternion::from_quaternion(*q_ib) * self.boresight_body;
        let angle = |u: &Vec3| b.dot(&u.normalize()).clamp(-1.0, 1.0).acos();
        let sun = self.sun_half_angle_rad.map(|h| angle(&g.sun_ref) - h);
        let earth = self.earth_margin_rad.map(|m| angle(&g.nadir_ref) - g.earth_half_angle_rad - m);
        (sun, earth)
    }
}

/// The column names of the group: per boresight its Sun then Earth margin (those it has),
/// then the flight's slew phase, slews planned and refused (all reasons) and its own
/// smallest margin of the commanded attitude. No cones: no group.
pub fn column_names(cones: &[Cone]) -> Vec<String> {
    let mut v = Vec::new();
    if cones.is_empty() {
        return v;
    }
    for c in cones {
        if c.sun_half_angle_rad.is_some() {
            v.push(format!("keepout_{}_sun_margin_deg", c.name));
        }
        if c.earth_margin_rad.is_some() {
            v.push(format!("keepout_{}_earth_margin_deg", c.name));
        }
    }
    v.extend(["slew_phase", "slews_planned", "slews_refused", "keepout_margin_flight_deg"].map(String::from));
    v
}

/// The run's smallest margins and the flight's counters.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct KeepOutSummary {
    /// `"<boresight>.sun"` / `"<boresight>.earth"` → smallest margin over the run, deg
    /// (negative: the boresight was inside; null: never evaluated).
    pub min_margin_deg: BTreeMap<String, Option<f64>>,
    /// Steps with a boresight inside one of its cones (truth).
    pub steps_inside: u64,
    /// Of those, the steps from `[manoeuvre] keepout_enforced_from_s` on (any fails the run).
    pub violations: u64,
    /// The first of them: when, which cone (`"<boresight>.sun"`), how deep, deg (negative).
    pub first_violation: Option<KeepOutViolation>,
    pub slews_planned: u16,
    pub slews_with_waypoint: u16,
    /// Refused by reason: target in a cone, no path, no geometry.
    pub slews_refused: [u16; 3],
}

/// A boresight inside a cone at a recorded step.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct KeepOutViolation {
    pub t_s: f64,
    pub cone: String,
    pub margin_deg: f64,
}

/// Online statistics of the group.
#[derive(Clone, Debug)]
pub struct KeepOutStats {
    cones: Vec<Cone>,
    /// Per cone `(sun, earth)` smallest margin so far, rad.
    min: Vec<(f64, f64)>,
    steps_inside: u64,
    enforced_from_s: f64,
    violations: u64,
    first_violation: Option<KeepOutViolation>,
    last: GuidanceTelemetry,
}

impl KeepOutStats {
    /// `enforced_from_s`: a step inside a cone from then on is a violation.
    pub fn new(cones: Vec<Cone>, enforced_from_s: f64) -> Self {
        let min = vec![(f64::INFINITY, f64::INFINITY); cones.len()];
        Self {
            cones,
            min,
            steps_inside: 0,
            enforced_from_s,
            violations: 0,
            first_violation: None,
            last: GuidanceTelemetry::default(),
        }
    }

    /// One recorded row's values (as [`column_names`]) at the true attitude, time `t_s`.
    pub fn row(
        &mut self,
        t_s: f64,
        q_ib: &Quat,
        g: Option<&ExclusionGeometry>,
        telemetry: &GuidanceTelemetry,
        out: &mut Vec<f64>,
    ) {
        // The deepest cone entered this step: (margin, rad; cone index; Sun?).
        let mut deepest: Option<(f64, usize, bool)> = None;
        for (i, (c, m)) in self.cones.iter().zip(self.min.iter_mut()).enumerate() {
            let (sun, earth) = g.map_or((None, None), |g| c.margins_rad(q_ib, g));
            let pairs = [(c.sun_half_angle_rad, sun, &mut m.0, true), (c.earth_margin_rad, earth, &mut m.1, false)];
            for (has, x, min, is_sun) in pairs {
                if has.is_none() {
                    continue;
                }
                out.push(x.map_or(f64::NAN, f64::to_degrees));
                if let Some(x) = x {
                    *min = min.min(x);
                    if x < 0.0 && deepest.is_none_or(|d| x < d.0) {
                        deepest = Some((x, i, is_sun));
                    }
                }
            }
        }
        if let Some((x, i, is_sun)) = deepest {
            self.steps_inside += 1;
            if t_s >= self.enforced_from_s {
                self.violations += 1;
                if self.first_violation.is_none() {
                    let name = self.cones.get(i).map_or("?", |c| c.name.as_str());
                    let cone = format!("{name}.{}", if is_sun { "sun" } else { "earth" });
                    self.first_violation = Some(KeepOutViolation { t_s, cone, margin_deg: x.to_degrees() });
                }
            }
        }
        let t = telemetry;
        let refused: u16 = t.slews_refused.iter().fold(0, |a, b| a.saturating_add(*b));
        out.extend([f64::from(t.slew_phase), f64::from(t.slews_planned), f64::from(refused)]);
        out.push(if t.keepout_margin_rad.is_finite() {
            f64::from(t.keepout_margin_rad).to_degrees()
        } else {
            f64::NAN
        });
        self.last = *t;
    }

    /// Why the run fails: a boresight inside a cone from the enforcement time on (`None`:
    /// no violation).
    pub fn violation_reason(&self) -> Option<String> {
        let f = self.first_violation.as_ref()?;
        Some(format!(
            "a boresight entered its keep-out cone: `{}` {:.3} deg inside at t = {:.3} s, {} recorded steps inside \
             from t = {} s on (truth; summary.json keepout)",
            f.cone, -f.margin_deg, f.t_s, self.violations, self.enforced_from_s
        ))
    }

    pub fn summary(&self) -> KeepOutSummary {
        let mut min_margin_deg = BTreeMap::new();
        let deg = |x: f64| x.is_finite().then(|| x.to_degrees());
        for (c, m) in self.cones.iter().zip(&self.min) {
            if c.sun_half_angle_rad.is_some() {
                min_margin_deg.insert(format!("{}.sun", c.name), deg(m.0));
            }
            if c.earth_margin_rad.is_some() {
                min_margin_deg.insert(format!("{}.earth", c.name), deg(m.1));
            }
        }
        KeepOutSummary {
            min_margin_deg,
            steps_inside: self.steps_inside,
            violations: self.violations,
            first_violation: self.first_violation.clone(),
            slews_planned: self.last.slews_planned,
            slews_with_waypoint: self.last.slews_with_waypoint,
            slews_refused: self.last.slews_refused,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Margins against a closed form: boresight body +y, the body turned by α about z puts
    /// it at (−sin α, cos α, 0); Sun along +x: angle 90° + α; Earth centre along −y with
    /// angular radius 60°: angle 180° − α, minus 60° and the margin.
    #[test]
    fn margins_are_the_angle_to_the_cone_edge() {
        let c = Cone {
            name: "st".into(),
            boresight_body: Vec3::y(),
            sun_half_angle_rad: Some(30f64.to_radians()),
            earth_margin_rad: Some(10f64.to_radians()),
        };
        let g = ExclusionGeometry {
            sun_ref: Vec3::x(),
            nadir_ref: -Vec3::y(),
            earth_half_angle_rad: 60f64.to_radians(),
            earth_lit: true,
        };
        for alpha in [-120.0f64, -60.0, 0.0, 45.0] {
            let q = UnitQuaternion::from_axis_angle(&Vec3::z_axis(), alpha.to_radians()).into_inner();
            let (sun, earth) = c.margins_rad(&q, &g);
            let sun_expect = (90.0 + alpha).abs().to_radians() - 30f64.to_radians();
            let earth_expect = (180.0 - alpha.abs()).to_radians() - 70f64.to_radians();
            assert!((sun.unwrap() - sun_expect).abs() < 1e-12, "α {alpha}");
            assert!((earth.unwrap() - earth_expect).abs() < 1e-12, "α {alpha}");
        }
        assert_eq!(column_names(&[c])[..2], ["keepout_st_sun_margin_deg", "keepout_st_earth_margin_deg"]);
    }
}
