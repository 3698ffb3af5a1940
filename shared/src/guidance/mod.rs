//! Guidance: the commanded attitude, rate and angular acceleration the laws track, from
//! the parameter set's pointing ([`crate::params::GuidanceParams`], docs/guidance.md),
//! and the clock of the GSR steering dither.
//!
//! Per step:
//! 1. the pointing in force: `pointing`, or `otherwise` while a ground site gated by
//!    `min_elevation_rad` does not see the spacecraft ([`Guidance::branch`]);
//! 2. its frame: a fixed attitude in the inertial frame or LVLH ([`Target`]), or two-vector
//!    pointing ([`align`]): `primary_body` exactly along the primary direction,
//!    `secondary_body` as close to the secondary as that allows, the directions computed
//!    on board with their derivatives ([`directions`]), so the frame's angular rate and
//!    acceleration are exact ([`kinematics`]): the target's motion is fed forward;
//! 3. near-parallel directions hold the last good secondary constraint (counted);
//! 4. a change of pointing is blended into the new one over `transition_s` with a
//!    quintic smoothstep ([`blend`]), so the commanded attitude, rate and acceleration
//!    stay continuous.
//!
//! No heap, no loops beyond fixed small bounds; every failure has a documented fallback
//! (the last command, held) and a flag.

pub mod align;
pub mod blend;
pub mod directions;
pub mod keepout;
pub mod kinematics;
pub mod manoeuvre;
pub mod profile;
pub mod timeline;

use crate::estimation::navigation::NavSolution;
use crate::link::GuidanceTelemetry;
use crate::math::{Quat, Vec3, quat_from_xyzw, quat_normalized, quat_to_xyzw, rotate_ref_to_body};
use crate::params::{GuidanceParams, ManoeuvreParams, Pointing, SteeringLaw, SteeringParams, TargetFrame};
use crate::types::{Measurements, Setpoint};
use align::{AlignFrame, Aligned};
use blend::Blend;
use directions::{Epoch, Site};
use manoeuvre::{ConeEnv, Manoeuvre};

/// A fixed target attitude and the frame it is given in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Target {
    /// Target attitude (unit): relative to inertial, or to the reference frame.
    pub q: Quat,
    pub frame: TargetFrame,
}

impl Target {
    /// The target frame needs the on-board navigation solution (LVLH).
    pub fn needs_navigation(&self) -> bool {
        self.frame == TargetFrame::Reference
    }

    /// Commanded attitude and inertial rate (inertial axes) for these measurements.
    fn command(&self, m: &Measurements) -> (Quat, Vec3) {
        match self.frame {
            TargetFrame::Inertial => (self.q, Vec3::zeros()),
            TargetFrame::Reference => (m.q_ref * self.q, m.ref_rate_rad_s),
        }
    }
}

/// Guidance flags of one step (telemetry `GuidanceTelemetry::flags`).
pub mod flags {
    /// The gated pointing's site sees the spacecraft (above `min_elevation_rad`).
    pub const VISIBLE: u8 = 1 << 0;
    /// `otherwise` is in force (the site does not see the spacecraft).
    pub const OTHERWISE: u8 = 1 << 1;
    /// Near-parallel directions: the last good secondary constraint is held.
    pub const PARALLEL_FALLBACK: u8 = 1 << 2;
    /// A transition between pointings is being blended.
    pub const BLENDING: u8 = 1 << 3;
    /// The pointing could not be computed this step: the last command is held.
    pub const HELD: u8 = 1 << 4;
    /// A planned slew is being planned or flown.
    pub const SLEWING: u8 = 1 << 5;
    /// A slew (or a hold) was refused by the keep-out cones: the last safe command is held.
    pub const KEEPOUT_REFUSED: u8 = 1 << 6;
}

/// A step of the target's attitude beyond its own motion that starts a planned slew, rad
/// (0.57°; a tracked target moves less than 1e-3 rad beyond its rate in a step).
pub const TARGET_JUMP_RAD: f32 = 0.01;

/// The guided command of one step, inertial axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Guided {
    /// Commanded attitude, body → inertial.
    pub q: Quat,
    /// Angular rate and acceleration of the commanded frame, inertial axes.
    pub rate_rad_s: Vec3,
    pub accel_rad_s2: Vec3,
}

/// Telemetry of guidance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GuidanceReport {
    pub flags: u8,
    /// Primary target direction, inertial (unit); zero for a fixed attitude.
    pub primary_eci: Vec3,
    /// Entries into the near-parallel fallback, pointing switches, steps held (saturating).
    pub parallel_events: u16,
    pub switches: u16,
    pub held_steps: u16,
}

/// Which of the two pointings of a parameter set is in force.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Branch {
    Main,
    Otherwise,
}

/// Guidance of one parameter set, with its state across steps.
#[derive(Clone, Debug, PartialEq)]
pub struct Guidance {
    params: GuidanceParams,
    /// Precomputed ground site of the gate (`min_elevation_rad`) and of each pointing.
    gate_site: Option<Site>,
    main: AlignFrame,
    otherwise: AlignFrame,
    branch: Branch,
    last: Option<Guided>,
    blend: Option<Blend>,
    /// A change handed over outside a step (ground command, mode switch): its blend starts
    /// at the next step's clock (the handover has no time of its own).
    blend_pending: bool,
    /// Planned slews and keep-out cones; a switch waits for the next step to plan.
    manoeuvre: Manoeuvre,
    slew_pending: bool,
    /// Flight clock of `last`, µs.
    last_us: Option<u64>,
    report: GuidanceReport,
}

impl Guidance {
    /// Guidance for validated parameters.
    // Not inlined into `Configured::build`: its temporaries would sum into the build's
    // frame on the firmware's deepest stack chain (docs/firmware.md "Stack").
    #[inline(never)]
    pub fn new(params: &GuidanceParams, manoeuvre: &ManoeuvreParams) -> Self {
        let gate_site = params
            .min_elevation_rad
            .and_then(|_| params.pointing.primary_site())
            .map(|(lat, lon, alt)| Site::geodetic(lat, lon, alt));
        Self {
            params: *params,
            gate_site,
            main: AlignFrame::new(&params.pointing),
            otherwise: AlignFrame::new(&params.otherwise),
            branch: Branch::Main,
            last: None,
            blend: None,
            blend_pending: false,
            manoeuvre: Manoeuvre::new(manoeuvre),
            slew_pending: false,
            last_us: None,
            report: GuidanceReport::default(),
        }
    }

    pub fn params(&self) -> &GuidanceParams {
        &self.params
    }

    pub fn needs_navigation(&self) -> bool {
        self.params.needs_navigation()
    }

    pub fn report(&self) -> GuidanceReport {
        self.report
    }

    /// The slew planner (its counters, phase and latest refusal).
    pub fn manoeuvre(&self) -> &Manoeuvre {
        &self.manoeuvre
    }

    /// The wire telemetry of the last step.
    pub fn telemetry(&self) -> GuidanceTelemetry {
        let g =
            self.last.unwrap_or(Guided { q: Quat::identity(), rate_rad_s: Vec3::zeros(), accel_rad_s2: Vec3::zeros() });
        GuidanceTelemetry {
            flags: self.report.flags,
            q_cmd_xyzw: quat_to_xyzw(&g.q),
            rate_cmd_rad_s: g.rate_rad_s.into(),
            accel_cmd_rad_s2: g.accel_rad_s2.into(),
            primary_eci: self.report.primary_eci.into(),
            parallel_events: self.report.parallel_events,
            switches: self.report.switches,
            keepout_margin_rad: self.manoeuvre.last_margin_rad,
            slews_planned: self.manoeuvre.counters.planned,
            slews_with_waypoint: self.manoeuvre.counters.with_waypoint,
            slews_refused: self.manoeuvre.counters.refused,
            slew_phase: self.manoeuvre.last_phase,
            slew_refusal: self.manoeuvre.last_refusal.map_or(0, |r| r.code()),
        }
    }

    /// A new pointing (ground command): blended in from the current command.
    pub fn set_params(&mut self, params: &GuidanceParams) {
        let (last, last_us, report, manoeuvre) = (self.last, self.last_us, self.report, self.manoeuvre);
        let p = manoeuvre.params();
        *self = Self::new(params, &p);
        self.manoeuvre.counters = manoeuvre.counters;
        self.manoeuvre.last_refusal = manoeuvre.last_refusal;
        self.last = last;
        self.last_us = last_us;
        self.report = report;
        self.start_blend_next_step();
    }

    /// Forget the state (a new configuration or mode): the next step commands its
    /// pointing directly unless [`Self::continue_from`] hands over a command.
    pub fn reset(&mut self) {
        self.last = None;
        self.blend = None;
        self.blend_pending = false;
        self.slew_pending = false;
        self.last_us = None;
        self.branch = Branch::Main;
    }

    /// Take over from `previous` (the command of the pointing that ran before, e.g. the
    /// previous mode's): the change is blended.
    pub fn continue_from(&mut self, previous: Option<Guided>) {
        self.last = previous;
        self.start_blend_next_step();
    }

    pub fn last(&self) -> Option<Guided> {
        self.last
    }

    /// Count the switch now; the blend starts at the next step's clock.
    /// With planned slews the next step plans one from the command in force instead.
    fn start_blend_next_step(&mut self) {
        self.blend = None;
        self.report.switches = self.report.switches.saturating_add(1);
        if self.manoeuvre.enabled() && self.last.is_some() {
            self.slew_pending = true;
        } else {
            self.blend_pending = true;
        }
    }

    fn start_blend(&mut self, time_us: u64) {
        self.blend_pending = false;
        self.report.switches = self.report.switches.saturating_add(1);
        if self.manoeuvre.enabled() && self.last.is_some() {
            self.blend = None;
            self.slew_pending = true;
            return;
        }
        self.blend = self.blend_from_last(time_us);
    }

    fn blend_from_last(&self, time_us: u64) -> Option<Blend> {
        match (self.last, self.params.transition_s > 0.0) {
            (Some(from), true) => Some(Blend::new(from, time_us, self.params.transition_s)),
            _ => None,
        }
    }

    /// The set point of one step; `steering`: the CMG steering law, if any (its dither).
    pub fn setpoint(
        &mut self,
        m: &Measurements,
        nav: Option<&NavSolution>,
        steering: Option<&SteeringParams>,
        time_us: u64,
    ) -> Setpoint {
        let g = self.guide(m, nav, time_us);
        // In body axes through the measured attitude, as the laws' error dynamics use them;
        // a zero vector stays exactly +0 (an inertial hold commands the bits it always did).
        let body = |v: &Vec3| if *v == Vec3::zeros() { Vec3::zeros() } else { rotate_ref_to_body(&m.q, v) };
        Setpoint {
            q_cmd: g.q,
            rate_cmd_rad_s: body(&g.rate_rad_s),
            accel_cmd_rad_s2: body(&g.accel_rad_s2),
            // A planned slew's profile acceleration is always fed forward.
            feedforward: self.params.feedforward || self.manoeuvre.enabled(),
            dither_time_s: steering.map_or(0.0, |s| dither_time_s(s, time_us)),
        }
    }

    /// The commanded attitude and rate (body axes) the mode logic judges the error
    /// against, without advancing guidance: a fixed attitude evaluated now, two-vector
    /// pointing's last command (one step old; identity before the first).
    pub fn reference(&self, m: &Measurements) -> (Quat, Vec3) {
        let body = |v: &Vec3| if *v == Vec3::zeros() { Vec3::zeros() } else { rotate_ref_to_body(&m.q, v) };
        let fixed = match self.branch {
            Branch::Main => fixed_target(&self.params.pointing),
            Branch::Otherwise => fixed_target(&self.params.otherwise),
        };
        match (fixed, self.last) {
            (Some(t), _) => {
                let (q, w) = t.command(m);
                (q, body(&w))
            }
            (None, Some(g)) => (g.q, body(&g.rate_rad_s)),
            (None, None) => (Quat::identity(), Vec3::zeros()),
        }
    }

    /// The guided command (inertial axes), with the branch, fallback and blend applied.
    pub fn guide(&mut self, m: &Measurements, nav: Option<&NavSolution>, time_us: u64) -> Guided {
        let epoch = nav.map(|n| Epoch {
            r_m: n.r_m,
            v_m_s: n.v_m_s,
            time: n.time,
            ut1_minus_clock_s: self.params.ut1_minus_clock_s,
        });
        if self.blend_pending {
            self.blend_pending = false;
            self.blend = self.blend_from_last(time_us);
        }
        let mut flags = self.update_branch(epoch.as_ref(), time_us);
        let frame = match self.branch {
            Branch::Main => &mut self.main,
            Branch::Otherwise => &mut self.otherwise,
        };
        let computed = frame.command(m, epoch.as_ref(), self.params.parallel_threshold_rad);
        let target = match computed {
            Some(Aligned { guided, primary_eci, parallel_entered, parallel }) => {
                if parallel {
                    flags |= flags::PARALLEL_FALLBACK;
                }
                if parallel_entered {
                    self.report.parallel_events = self.report.parallel_events.saturating_add(1);
                }
                self.report.primary_eci = primary_eci.unwrap_or_else(Vec3::zeros);
                Some(guided)
            }
            None => None,
        };
        let Some(target) = target.or(self.last) else {
            // Nothing computed and nothing to hold (the first step without navigation):
            // the caller's validation refuses such steps; identity keeps the loop going.
            self.report.flags = flags | flags::HELD;
            return Guided { q: Quat::identity(), rate_rad_s: Vec3::zeros(), accel_rad_s2: Vec3::zeros() };
        };
        if computed.is_none() {
            flags |= flags::HELD;
            self.report.held_steps = self.report.held_steps.saturating_add(1);
        }
        let out = match self.slew(&target, epoch.as_ref(), time_us, &mut flags) {
            Some(g) => g,
            None => match self.blend.as_mut().and_then(|b| b.apply(&target, time_us)) {
                Some(g) => {
                    flags |= flags::BLENDING;
                    g
                }
                None => {
                    self.blend = None;
                    target
                }
            },
        };
        self.report.flags = flags;
        self.last = Some(out);
        self.last_us = Some(time_us);
        out
    }

    /// The planned slew's command this step, if one is planned or flown (or the target
    /// was refused by the keep-out cones).
    fn slew(&mut self, target: &Guided, epoch: Option<&Epoch>, time_us: u64, flags: &mut u8) -> Option<Guided> {
        if !self.manoeuvre.enabled() {
            return None;
        }
        let idle = !self.manoeuvre.busy() && self.manoeuvre.refusal().is_none();
        if self.slew_pending || (idle && self.target_jumped(target, time_us)) {
            self.slew_pending = false;
            if let Some(from) = self.last {
                self.manoeuvre.begin(&from, target);
            }
        }
        let env = epoch.and_then(cone_env);
        let out = self.manoeuvre.step(target, self.last.as_ref(), env.as_ref(), time_us);
        if self.manoeuvre.busy() {
            *flags |= flags::SLEWING;
        }
        if self.manoeuvre.refusal().is_some() {
            *flags |= flags::KEEPOUT_REFUSED;
        }
        out
    }

    /// The target stepped away from the command in force carried on at its rate (by more
    /// than [`TARGET_JUMP_RAD`]): leaving the near-parallel fallback turns a two-vector
    /// frame by up to 180° about its boresight at once. With planned slews that turn is
    /// planned, not stepped.
    fn target_jumped(&self, target: &Guided, time_us: u64) -> bool {
        let (Some(last), Some(last_us)) = (self.last, self.last_us) else { return false };
        let Some(dt) = crate::estimation::history::span_s(last_us, time_us) else { return false };
        let carried = blend::quat_exp(&(last.rate_rad_s * dt)) * last.q;
        crate::math::rotation_angle(&(target.q * carried.conjugate())) > TARGET_JUMP_RAD
    }

    /// Visibility of the gated site and the branch it selects; a change starts a blend.
    fn update_branch(&mut self, epoch: Option<&Epoch>, time_us: u64) -> u8 {
        let (Some(site), Some(min_el)) = (self.gate_site, self.params.min_elevation_rad) else {
            return 0;
        };
        // Without navigation the visibility is unknown: keep the branch in force.
        let Some(sin_el) = epoch.and_then(|e| e.elevation_sine(&site)) else {
            return if self.branch == Branch::Otherwise { flags::OTHERWISE } else { 0 };
        };
        let visible = sin_el >= crate::math::f32m::sin(min_el);
        let branch = if visible { Branch::Main } else { Branch::Otherwise };
        if branch != self.branch {
            self.branch = branch;
            self.start_blend(time_us);
        }
        match branch {
            Branch::Main => flags::VISIBLE,
            Branch::Otherwise => flags::OTHERWISE,
        }
    }
}

/// The fixed-attitude command of `pointing` (for a `Fixed` pointing), normalised.
pub(crate) fn fixed_target(pointing: &Pointing) -> Option<Target> {
    match pointing {
        Pointing::Fixed { q_xyzw, frame } => {
            Some(Target { q: quat_normalized(&quat_from_xyzw(*q_xyzw))?, frame: *frame })
        }
        Pointing::Align { .. } => None,
    }
}

/// The GSR dither phase only matters modulo its period: reduce the clock there so f32
/// keeps full resolution for ever.
pub fn dither_time_s(p: &SteeringParams, time_us: u64) -> f32 {
    match p.law {
        SteeringLaw::GeneralizedSr { omega_rad_s, .. } if omega_rad_s > 0.0 => {
            // Float → integer `as` saturates (and maps NaN to 0); ω > 0 keeps it positive.
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let period_us = ((core::f32::consts::TAU / omega_rad_s) * 1.0e6) as u64;
            time_us.checked_rem(period_us.max(1)).unwrap_or(0) as f32 * 1.0e-6
        }
        _ => 0.0,
    }
}

/// The keep-out geometry at an epoch: the Sun (on-board ephemeris, from the spacecraft),
/// nadir, the Earth's angular radius and the orbit rate.
pub(crate) fn cone_env(e: &Epoch) -> Option<ConeEnv> {
    let sun = e.direction(&crate::params::Direction::Sun, None)?.unit()?.x;
    let r = crate::math::norm(&e.r_m);
    let nadir = -e.r_m / r;
    let earth_radius_rad = keepout::earth_angular_radius_rad(&e.r_m)?;
    let orbit_rate_rad_s = crate::math::norm(&e.r_m.cross(&e.v_m_s)) / (r * r);
    let env = ConeEnv { sun, nadir, earth_radius_rad, orbit_rate_rad_s };
    (nadir.iter().all(|x| x.is_finite()) && orbit_rate_rad_s.is_finite()).then_some(env)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{EulerSeq, quat_from_euler, rotation_angle};

    fn measurements() -> Measurements {
        Measurements {
            q: Quat::identity(),
            rate_rad_s: Vec3::zeros(),
            gimbal_angle_rad: [0.0; 4],
            wheel_speed_rad_s: [0.0; crate::types::MAX_WHEELS],
            mag_field_t: Vec3::zeros(),
            q_ref: Quat::identity(),
            ref_rate_rad_s: Vec3::zeros(),
            sun_body: None,
            eclipse: false,
        }
    }

    fn inertial(euler_rad: [f32; 3], transition_s: f32) -> GuidanceParams {
        let q = quat_from_euler(euler_rad, EulerSeq::Zyx321);
        GuidanceParams { transition_s, ..GuidanceParams::fixed(quat_to_xyzw(&q), TargetFrame::Inertial) }
    }

    /// A ground command long after start (1000 s ≫ transition_s) is blended from the
    /// command in force: the first step after it commands the old attitude (within one
    /// step's progress of the smoothstep), the blend flag is up, and `transition_s` later
    /// the new attitude exactly. (Regression: the blend used to start at clock 0, so a
    /// command after `transition_s` stepped.)
    #[test]
    fn a_late_set_pointing_is_blended_from_the_command_in_force() {
        let m = measurements();
        let old = inertial([0.0, 0.0, 0.0], 20.0);
        let new = inertial([0.0, 0.0, 1.0], 20.0);
        let mut g = Guidance::new(&old, &ManoeuvreParams::OFF);
        let t0 = 1_000_000_000u64;
        let q_old = g.guide(&m, None, t0).q;
        g.set_params(&new);
        let first = g.guide(&m, None, t0 + 250_000);
        // The blend starts at this step: s(0) = 0, the old command.
        assert!(rotation_angle(&(first.q * q_old.conjugate())) < 1e-6, "{first:?}");
        assert!(g.report().flags & flags::BLENDING != 0);
        let mid = g.guide(&m, None, t0 + 250_000 + 10_000_000);
        // Halfway, s = 1/2: half the 1 rad turn.
        assert!((rotation_angle(&(mid.q * q_old.conjugate())) - 0.5).abs() < 1e-4, "{mid:?}");
        let end = g.guide(&m, None, t0 + 250_000 + 20_000_000);
        let q_new = quat_from_euler([0.0, 0.0, 1.0], EulerSeq::Zyx321);
        assert!(rotation_angle(&(end.q * q_new.conjugate())) < 1e-6);
        assert!(g.report().flags & flags::BLENDING == 0);
        assert_eq!(g.report().switches, 1);
    }
}
