//! Guidance parameters (params version 11): what the spacecraft points where
//! ([`crate::guidance`], docs/guidance.md). One [`GuidanceParams`] per parameter set (per
//! mode of a mode table); the ground replaces the mission modes' pointing with
//! `HostMsg::SetPointing`.

use super::{ParamError, ParamField, ParamReason, TargetFrame, check_finite, check_range, err};
use crate::math::{Vec3, norm, quat_from_xyzw};
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// Tolerance on the unit length of body axes and target quaternions.
pub const UNIT_TOL: f32 = 1e-3;
/// Smallest angle between the primary and the secondary body axes, rad (1°): closer than
/// that the secondary constrains nothing.
pub const MIN_BODY_AXES_ANGLE_RAD: f32 = 0.017_453_3;
/// Range of the near-parallel threshold, rad (0.1° … 45°).
pub const PARALLEL_THRESHOLD_RANGE_RAD: (f32, f32) = (0.001_745_33, core::f32::consts::FRAC_PI_4);
/// Longest pointing transition, s.
pub const MAX_TRANSITION_S: f32 = 3_600.0;
/// Largest |UT1 − on-board clock|, s (DUT1 ≤ 0.9 s plus the GNSS scale's ≤ 40 s offset).
pub const MAX_UT1_OFFSET_S: f32 = 100.0;
/// Ground sites: altitude range above the ellipsoid, m.
pub const SITE_ALT_RANGE_M: (f32, f32) = (-1_000.0, 100_000.0);

/// What a body axis is pointed at; every one is computed on board
/// ([`crate::guidance::directions`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Direction {
    /// Towards the Earth's centre.
    Nadir,
    /// Down the WGS-84 ellipsoid normal through the spacecraft.
    NadirGeodetic,
    /// Away from the Earth's centre.
    Zenith,
    /// Along the inertial orbit velocity.
    Velocity,
    AntiVelocity,
    /// Along the orbit's angular momentum `r × v`.
    OrbitNormal,
    AntiOrbitNormal,
    /// The Sun (on-board ephemeris, from the spacecraft).
    Sun,
    /// A point on the rotating Earth: WGS-84 geodetic latitude and longitude (east), rad,
    /// height above the ellipsoid, m.
    Ground {
        lat_rad: f32,
        lon_rad: f32,
        alt_m: f32,
    },
    /// A fixed inertial direction: right ascension and declination, rad.
    Celestial {
        ra_rad: f32,
        dec_rad: f32,
    },
}

impl Direction {
    /// Needs the navigation solution (all but a celestial direction).
    pub fn needs_navigation(&self) -> bool {
        !matches!(self, Self::Celestial { .. })
    }

    fn validate(&self) -> Result<(), ParamError> {
        match *self {
            Self::Ground { lat_rad, lon_rad, alt_m } => {
                check_range(
                    ParamField::Pointing,
                    lat_rad,
                    -core::f32::consts::FRAC_PI_2,
                    core::f32::consts::FRAC_PI_2,
                )?;
                check_range(ParamField::Pointing, lon_rad, -7.0, 7.0)?;
                check_range(ParamField::Pointing, alt_m, SITE_ALT_RANGE_M.0, SITE_ALT_RANGE_M.1)
            }
            Self::Celestial { ra_rad, dec_rad } => {
                check_range(ParamField::Pointing, ra_rad, -7.0, 7.0)?;
                check_range(ParamField::Pointing, dec_rad, -core::f32::consts::FRAC_PI_2, core::f32::consts::FRAC_PI_2)
            }
            _ => Ok(()),
        }
    }
}

/// One pointing.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Pointing {
    /// A fixed attitude, scalar-last `[x, y, z, w]`, relative to `frame` (inertial, or
    /// LVLH from the navigation solution).
    Fixed { q_xyzw: [f32; 4], frame: TargetFrame },
    /// Two-vector pointing (align and constrain): `primary_body` exactly along `primary`,
    /// `secondary_body` as close to `secondary` as that allows. Body axes unit, at least
    /// [`MIN_BODY_AXES_ANGLE_RAD`] apart.
    Align { primary_body: [f32; 3], primary: Direction, secondary_body: [f32; 3], secondary: Direction },
}

impl Pointing {
    /// Identity attitude in the inertial frame.
    pub const INERTIAL_IDENTITY: Self = Self::Fixed { q_xyzw: [0.0, 0.0, 0.0, 1.0], frame: TargetFrame::Inertial };

    pub fn needs_navigation(&self) -> bool {
        match self {
            Self::Fixed { frame, .. } => *frame == TargetFrame::Reference,
            Self::Align { primary, secondary, .. } => primary.needs_navigation() || secondary.needs_navigation(),
        }
    }

    /// The ground site of the primary direction, if it is one.
    pub fn primary_site(&self) -> Option<(f32, f32, f32)> {
        match self {
            Self::Align { primary: Direction::Ground { lat_rad, lon_rad, alt_m }, .. } => {
                Some((*lat_rad, *lon_rad, *alt_m))
            }
            _ => None,
        }
    }

    pub fn validate(&self) -> Result<(), ParamError> {
        match self {
            Self::Fixed { q_xyzw, .. } => {
                check_finite(ParamField::Target, q_xyzw)?;
                let n = norm(&quat_from_xyzw(*q_xyzw).coords);
                if (n - 1.0).abs() > UNIT_TOL {
                    return Err(err(ParamField::Target, ParamReason::NotUnitQuaternion));
                }
                Ok(())
            }
            Self::Align { primary_body, primary, secondary_body, secondary } => {
                let (p, s) = (unit_axis(primary_body)?, unit_axis(secondary_body)?);
                if !(norm(&p.cross(&s)) >= crate::math::f32m::sin(MIN_BODY_AXES_ANGLE_RAD)) {
                    return Err(err(ParamField::PointingAxes, ParamReason::OutOfRange));
                }
                primary.validate()?;
                secondary.validate()
            }
        }
    }
}

/// A unit body axis (within [`UNIT_TOL`]).
fn unit_axis(v: &[f32; 3]) -> Result<Vec3, ParamError> {
    check_finite(ParamField::PointingAxes, v)?;
    let a = Vec3::from(*v);
    let n = norm(&a);
    if (n - 1.0).abs() > UNIT_TOL {
        return Err(err(ParamField::PointingAxes, ParamReason::OutOfRange));
    }
    Ok(a / n)
}

/// What one parameter set points at, and how (a wire type).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GuidanceParams {
    pub pointing: Pointing,
    /// With a ground primary: `pointing` applies while the site sees the spacecraft at
    /// least this high above its horizon (rad, in [−π/2, π/2]); `otherwise` below.
    /// `None`: `pointing` always.
    pub min_elevation_rad: Option<f32>,
    /// The pointing while the site does not see the spacecraft (before and after a pass).
    pub otherwise: Pointing,
    /// A change of pointing (visibility, mode, ground command) is blended over this long,
    /// s, in [0, [`MAX_TRANSITION_S`]] (0: a step).
    pub transition_s: f32,
    /// Primary and secondary directions closer than this to parallel (or anti-parallel)
    /// hold the last good secondary constraint instead (rad).
    pub parallel_threshold_rad: f32,
    /// UT1 − on-board clock, s: the Earth's rotation angle is taken at on-board time plus
    /// this (uploaded from the ground: DUT1 and the GNSS time scale's offset).
    pub ut1_minus_clock_s: f32,
    /// Feed the commanded frame's angular acceleration forward as torque (laws that
    /// support it: quaternion feedback), so tracking a moving target leaves no lag.
    pub feedforward: bool,
}

impl GuidanceParams {
    /// A fixed attitude in `frame` (what a parameter set pointed at before params 11).
    pub const fn fixed(q_xyzw: [f32; 4], frame: TargetFrame) -> Self {
        Self {
            pointing: Pointing::Fixed { q_xyzw, frame },
            min_elevation_rad: None,
            otherwise: Pointing::INERTIAL_IDENTITY,
            transition_s: 0.0,
            parallel_threshold_rad: 0.087_266_46,
            ut1_minus_clock_s: 0.0,
            feedforward: false,
        }
    }

    pub fn needs_navigation(&self) -> bool {
        self.pointing.needs_navigation() || (self.min_elevation_rad.is_some() && self.otherwise.needs_navigation())
    }

    pub fn validate(&self) -> Result<(), ParamError> {
        self.pointing.validate()?;
        if let Some(e) = self.min_elevation_rad {
            let half = core::f32::consts::FRAC_PI_2;
            check_range(ParamField::Pointing, e, -half, half)?;
            if self.pointing.primary_site().is_none() {
                return Err(err(ParamField::Pointing, ParamReason::OutOfRange));
            }
            self.otherwise.validate()?;
        }
        check_range(ParamField::Pointing, self.transition_s, 0.0, MAX_TRANSITION_S)?;
        let (lo, hi) = PARALLEL_THRESHOLD_RANGE_RAD;
        check_range(ParamField::Pointing, self.parallel_threshold_rad, lo, hi)?;
        check_range(ParamField::Pointing, self.ut1_minus_clock_s, -MAX_UT1_OFFSET_S, MAX_UT1_OFFSET_S)
    }
}

/// Most keep-out boresights of a parameter set.
pub const MAX_KEEPOUT_CONES: usize = 4;
/// Largest planning margin, rad (10°).
pub const MAX_PLANNING_MARGIN_RAD: f32 = 0.174_532_9;

/// A body-fixed boresight that must stay out of the Sun's and the Earth's keep-out cones.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct KeepOutCone {
    /// Boresight, body axes (unit).
    pub boresight_body: [f32; 3],
    /// Half-angle of the cone about the Sun, rad, in (0, π/2]; 0: no Sun cone.
    pub sun_half_angle_rad: f32,
    /// Margin beyond the Earth's disc (its angular radius from the orbit altitude), rad, in
    /// [0, π/2]; negative: no Earth cone.
    pub earth_margin_rad: f32,
}

impl KeepOutCone {
    pub const NONE: Self = Self { boresight_body: [0.0, 0.0, 1.0], sun_half_angle_rad: 0.0, earth_margin_rad: -1.0 };
}

/// Planned slews: rate and acceleration limits, keep-out cones (params version 12).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ManoeuvreParams {
    /// A change of pointing is a planned, limited slew (instead of guidance's blend).
    pub enabled: bool,
    /// Slew rate and angular acceleration limits, rad/s and rad/s² (> 0 when enabled).
    pub max_rate_rad_s: f32,
    pub max_accel_rad_s2: f32,
    /// Cones `0..cone_count` are in force.
    pub cones: [KeepOutCone; MAX_KEEPOUT_CONES],
    pub cone_count: u8,
    /// Added to every cone when a slew is planned (the path's moving ends), rad.
    pub planning_margin_rad: f32,
}

impl ManoeuvreParams {
    pub const OFF: Self = Self {
        enabled: false,
        max_rate_rad_s: 0.0,
        max_accel_rad_s2: 0.0,
        cones: [KeepOutCone::NONE; MAX_KEEPOUT_CONES],
        cone_count: 0,
        planning_margin_rad: 0.0,
    };

    /// The cones in force.
    pub fn active_cones(&self) -> &[KeepOutCone] {
        self.cones.get(..usize::from(self.cone_count)).unwrap_or(&[])
    }

    pub fn validate(&self) -> Result<(), ParamError> {
        let bad = |reason| err(ParamField::Manoeuvre, reason);
        if usize::from(self.cone_count) > MAX_KEEPOUT_CONES {
            return Err(bad(ParamReason::OutOfRange));
        }
        if self.enabled {
            check_range(ParamField::Manoeuvre, self.max_rate_rad_s, 1.0e-6, 1.0)?;
            check_range(ParamField::Manoeuvre, self.max_accel_rad_s2, 1.0e-7, 1.0)?;
        }
        check_range(ParamField::Manoeuvre, self.planning_margin_rad, 0.0, MAX_PLANNING_MARGIN_RAD)?;
        let half = core::f32::consts::FRAC_PI_2;
        for c in self.active_cones() {
            unit_axis(&c.boresight_body).map_err(|_| bad(ParamReason::OutOfRange))?;
            check_range(ParamField::Manoeuvre, c.sun_half_angle_rad, 0.0, half)?;
            check_finite(ParamField::Manoeuvre, &[c.earth_margin_rad])?;
            if c.earth_margin_rad > half {
                return Err(bad(ParamReason::OutOfRange));
            }
        }
        Ok(())
    }
}
