//! Two-vector pointing ("align and constrain", 42's Point/Align; Markley & Crassidis
//! 2014 §5.2's TRIAD frame): a primary body axis `p_B` exactly along the primary
//! direction `P`, a secondary body axis `s_B` as close to the secondary direction `S` as
//! that allows. With the triads `E = [P̂, (P̂ × Ŝ)^, P̂ × (P̂ × Ŝ)^]` (inertial) and
//! `B = [p̂_B, (p̂_B × ŝ_B)^, …]` (body), the commanded attitude is `R = E Bᵀ`: it maps
//! `p_B` onto `P̂` exactly and `s_B` into the half-plane of `P̂` and `Ŝ`, which minimises
//! the angle between `R s_B` and `Ŝ`. Its rate and acceleration are those of `E`
//! ([`super::kinematics::FrameKin::rates`]); `B` is fixed in the body.
//!
//! Near-parallel directions (`|P̂ × Ŝ| < sin(threshold)`, either sense) leave the
//! rotation about `P̂` undetermined: the last good `e₂` is held (re-orthogonalised
//! against the moving `P̂`), so the commanded attitude stays continuous; the entry is
//! counted. Before any good `e₂`, the inertial axis least aligned with `P̂` stands in.

use super::Guided;
use super::directions::{Epoch, Site};
use super::kinematics::{FrameKin, VecKin};
use crate::math::f32m::sin;
use crate::math::{Mat3, Quat, Vec3, norm, quat_from_rotation_matrix};
use crate::params::{Direction, Pointing};
use crate::types::Measurements;

/// A pointing ready to evaluate: its fixed target, or its body triad and sites.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlignFrame {
    kind: Kind,
    /// Last good `e₂` (inertial), for the near-parallel fallback.
    last_e2: Option<Vec3>,
    in_fallback: bool,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Fixed(super::Target),
    Align {
        body: Mat3,
        primary: Direction,
        primary_site: Option<Site>,
        secondary: Direction,
        secondary_site: Option<Site>,
    },
    /// A parameter set that failed to build (cannot happen after validation).
    Invalid,
}

/// One evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aligned {
    pub guided: Guided,
    /// Primary direction (inertial unit), for two-vector pointing.
    pub primary_eci: Option<Vec3>,
    /// In the near-parallel fallback this step / entered it this step.
    pub parallel: bool,
    pub parallel_entered: bool,
}

fn site_of(d: &Direction) -> Option<Site> {
    match d {
        Direction::Ground { lat_rad, lon_rad, alt_m } => Some(Site::geodetic(*lat_rad, *lon_rad, *alt_m)),
        _ => None,
    }
}

/// Body triad `[p̂, (p̂ × ŝ)^, p̂ × (p̂ × ŝ)^]` as matrix columns.
fn body_triad(p: &[f32; 3], s: &[f32; 3]) -> Option<Mat3> {
    let f = FrameKin::from_two(&VecKin::constant(Vec3::from(*p)), &VecKin::constant(Vec3::from(*s)))?;
    Some(Mat3::from_columns(&[f.e1.x, f.e2.x, f.e3.x]))
}

impl AlignFrame {
    pub fn new(p: &Pointing) -> Self {
        let kind = match p {
            Pointing::Fixed { .. } => super::fixed_target(p).map_or(Kind::Invalid, Kind::Fixed),
            Pointing::Align { primary_body, primary, secondary_body, secondary } => {
                match body_triad(primary_body, secondary_body) {
                    Some(body) => Kind::Align {
                        body,
                        primary: *primary,
                        primary_site: site_of(primary),
                        secondary: *secondary,
                        secondary_site: site_of(secondary),
                    },
                    None => Kind::Invalid,
                }
            }
        };
        Self { kind, last_e2: None, in_fallback: false }
    }

    /// The command of this pointing now; `None` when it cannot be computed (no
    /// navigation for a direction that needs it, degenerate geometry).
    pub fn command(&mut self, m: &Measurements, epoch: Option<&Epoch>, threshold_rad: f32) -> Option<Aligned> {
        match self.kind {
            Kind::Fixed(t) => {
                let (q, rate) = t.command(m);
                let guided = Guided { q, rate_rad_s: rate, accel_rad_s2: Vec3::zeros() };
                Some(Aligned { guided, primary_eci: None, parallel: false, parallel_entered: false })
            }
            Kind::Align { body, primary, primary_site, secondary, secondary_site } => {
                let e = epoch;
                let p = direction(e, &primary, primary_site.as_ref())?.unit()?;
                let s = direction(e, &secondary, secondary_site.as_ref())?;
                self.align(&body, &p, &s, threshold_rad)
            }
            Kind::Invalid => None,
        }
    }

    /// The commanded attitude at a (future) epoch, from the epoch alone: a fixed LVLH
    /// attitude takes its frame from the epoch's position and velocity. For checks ahead
    /// of time (the timeline's arming); `None` when it cannot be computed.
    pub fn attitude_at(&mut self, epoch: &Epoch, threshold_rad: f32) -> Option<Quat> {
        match self.kind {
            Kind::Fixed(t) => match t.frame {
                crate::params::TargetFrame::Inertial => Some(t.q),
                crate::params::TargetFrame::Reference => {
                    let l = crate::models::lvlh::lvlh(&epoch.r_m, &epoch.v_m_s).ok()?;
                    Some(l.q_eci_lvlh * t.q)
                }
            },
            Kind::Align { body, primary, primary_site, secondary, secondary_site } => {
                let p = direction(Some(epoch), &primary, primary_site.as_ref())?.unit()?;
                let s = direction(Some(epoch), &secondary, secondary_site.as_ref())?;
                self.align(&body, &p, &s, threshold_rad).map(|a| a.guided.q)
            }
            Kind::Invalid => None,
        }
    }

    fn align(&mut self, body: &Mat3, p: &VecKin, s: &VecKin, threshold_rad: f32) -> Option<Aligned> {
        let s_unit = s.unit()?;
        let parallel = !(norm(&p.x.cross(&s_unit.x)) >= sin(threshold_rad));
        let secondary = if parallel {
            // Hold the last good e₂: a secondary along e₂_last × p̂ gives
            // e₂ = (p̂ × (e₂_last × p̂))^ = e₂_last re-orthogonalised against p̂.
            let held = self.last_e2.unwrap_or_else(|| least_aligned_axis(&p.x));
            VecKin::constant(held).cross(p)
        } else {
            s_unit
        };
        let frame = FrameKin::from_two(p, &secondary)?;
        let entered = parallel && !self.in_fallback;
        self.in_fallback = parallel;
        self.last_e2 = Some(frame.e2.x);
        let e = Mat3::from_columns(&[frame.e1.x, frame.e2.x, frame.e3.x]);
        let q: Quat = quat_from_rotation_matrix(&(e * body.transpose()))?;
        let (rate, accel) = frame.rates();
        let guided = Guided { q, rate_rad_s: rate, accel_rad_s2: accel };
        Some(Aligned { guided, primary_eci: Some(p.x), parallel, parallel_entered: entered })
    }
}

fn direction(e: Option<&Epoch>, d: &Direction, site: Option<&Site>) -> Option<VecKin> {
    match (d, e) {
        (Direction::Celestial { .. }, _) => Epoch::celestial(d),
        (_, Some(e)) => e.direction(d, site),
        (_, None) => None,
    }
}

/// The inertial axis least aligned with `p` (a deterministic stand-in for `e₂`).
fn least_aligned_axis(p: &Vec3) -> Vec3 {
    let a = p.map(libm::fabsf);
    if a.x <= a.y && a.x <= a.z {
        Vec3::x()
    } else if a.y <= a.z {
        Vec3::y()
    } else {
        Vec3::z()
    }
}
