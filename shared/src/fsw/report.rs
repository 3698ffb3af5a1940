//! The report step of `Fsw::step`: status from the law and the allocation, and the wire
//! [`ActuatorCommand`].

use crate::allocation::AllocStatus;
use crate::allocation::family::{Allocation, Commands};
use crate::control::sun_safe::SunSafePhase;
use crate::control::{LawOutput, LawStatus};
use crate::estimation::status::{EstimateStatus, FusionCounts, SampleAges};
use crate::link::{self, ActuatorCommand, EstimateTelemetry, LAW_TELEMETRY_LEN, law_slots};
use crate::math::{Vec3, norm, quat_to_xyzw};
use crate::modes::ModeManager;
use crate::types::Status;

/// One step's outcome before it is packed for the wire.
#[derive(Clone, Copy, Debug)]
pub struct Report<'a> {
    pub out: &'a LawOutput,
    pub alloc: &'a Allocation,
    pub status: Status,
    pub law: LawStatus,
}

/// The law's status in the wire's generic slot ([`law_slots`]).
pub fn law_telemetry(law: &LawStatus) -> [f32; LAW_TELEMETRY_LEN] {
    let mut t = [0.0; LAW_TELEMETRY_LEN];
    match law {
        LawStatus::Stateless => {}
        LawStatus::Dmcs { feedforward_gain, proportional_gain } => {
            put(&mut t, law_slots::DMCS_FEEDFORWARD_GAIN.start, feedforward_gain);
            put(&mut t, law_slots::DMCS_PROPORTIONAL_GAIN.start, proportional_gain.as_flattened());
        }
        LawStatus::SunSafe { phase, memory_age_s } => {
            let code = match phase {
                SunSafePhase::Pointing => 0.0,
                SunSafePhase::Searching => 1.0,
                SunSafePhase::EclipseHold => 2.0,
            };
            put(&mut t, law_slots::SUN_SAFE_PHASE, &[code]);
            put(&mut t, law_slots::SUN_SAFE_MEMORY_AGE_S, &[*memory_age_s]);
        }
    }
    t
}

/// Copies `values` into `t` from `start` (what does not fit is dropped: the slot layout is
/// a compile-time table, checked by the tests to fit).
fn put(t: &mut [f32; LAW_TELEMETRY_LEN], start: usize, values: &[f32]) {
    for (dst, v) in t.iter_mut().skip(start).zip(values) {
        *dst = *v;
    }
}

/// Status bits of an allocation outcome.
pub fn alloc_status(s: AllocStatus) -> Status {
    match s {
        AllocStatus::Ok => Status::empty(),
        AllocStatus::Scaled => Status::RATE_SCALED,
        AllocStatus::Singular => Status::SINGULAR,
        AllocStatus::Infeasible | AllocStatus::NonFinite | AllocStatus::IterationCap | AllocStatus::InternalError => {
            Status::ALLOC_FALLBACK
        }
    }
}

impl<'a> Report<'a> {
    /// `flags`: what the step found before allocating (`LAW_FAULT`).
    pub fn new(out: &'a LawOutput, alloc: &'a Allocation, flags: Status, law: LawStatus) -> Self {
        let mut status = flags | alloc.flags | alloc_status(alloc.status);
        if out.limited {
            status |= Status::TORQUE_LIMITED;
        }
        if alloc.unrealised != 0 {
            status |= Status::UNREALISED;
        }
        let (realised, demand) = (Vec3::from(alloc.realised), alloc.demand_nm);
        // Relative test: cubesat torques are ~1e-7 N m, so no absolute floor above round-off.
        if norm(&(realised - demand)) > 0.01 * norm(&demand) + 1e-12 {
            status |= Status::TORQUE_SHORTFALL;
        }
        Self { out, alloc, status, law }
    }

    /// The realised torque the LQG estimator propagates next step (zero if not finite).
    pub fn torque_for_estimator(&self) -> Vec3 {
        let realised = Vec3::from(self.alloc.realised);
        if realised.iter().all(|x| x.is_finite()) { realised } else { Vec3::zeros() }
    }

    /// The wire command answering sensor frame `seq`.
    pub fn command(&self, seq: u32) -> ActuatorCommand {
        let a = self.alloc;
        let mut cmd = ActuatorCommand {
            seq,
            torque_demand_nm: a.demand_nm.into(),
            torque_realised_nm: a.realised,
            attitude_error_rad: self.out.error_angle_rad,
            alloc_iterations: a.iterations,
            law_telemetry: law_telemetry(&self.law),
            saturated: a.sat_low | a.sat_high,
            status: self.status.bits(),
            ..Default::default()
        };
        match a.commands {
            Commands::Cmg { gimbal_rate_rad_s, singularity_measure, alpha } => {
                cmd.gimbal_rate_cmd_rad_s = gimbal_rate_rad_s;
                cmd.singularity_measure = singularity_measure;
                cmd.steering_alpha = alpha;
            }
            Commands::Wheels { torque_nm } => cmd.wheel_torque_cmd_nm = torque_nm,
            Commands::Magnetorquers { dipole_am2 } => cmd.dipole_cmd_am2 = dipole_am2,
            Commands::Thrusters { level, on } => {
                cmd.thruster_level = level;
                cmd.thruster_on = on;
            }
        }
        cmd
    }
}

/// Mode in force, why, and how many transitions so far.
pub fn mode_telemetry(cmd: &mut ActuatorCommand, mgr: &ModeManager) {
    cmd.mode = mgr.mode.code();
    cmd.mode_reason = mgr.reason as u8;
    cmd.mode_transitions = mgr.transitions;
    cmd.momentum_events = mgr.momentum_events;
    cmd.momentum_keepup_events = mgr.keepup_events;
    cmd.gimbal_events = mgr.gimbal_events;
    if mgr.momentum_alarm() || mgr.slow_alarm() {
        cmd.status |= Status::MOMENTUM_SATURATION.bits();
    }
}

/// The estimation stage's report of the step as the wire carries it (zeros for what the
/// stage does not have: no estimate, no running filter).
pub fn estimate_telemetry(s: &EstimateStatus) -> EstimateTelemetry {
    let mut t = EstimateTelemetry::default();
    pack_estimate(&mut t, s);
    t
}

/// [`estimate_telemetry`] written over every field of `t` in place (the command's own
/// field: no zeroing and copy of the 48-word struct on the step's hot path).
pub fn pack_estimate(t: &mut EstimateTelemetry, s: &EstimateStatus) {
    t.q_est_xyzw = s.q_est.map_or([0.0; 4], |q| quat_to_xyzw(&q));
    t.accepted = s.accepted;
    t.rejected = s.rejected;
    t.resets = s.resets;
    t.flags = s.flags.bits();
    t.sample_age_s = sample_ages(&s.sample_age_s);
    t.fusion = fusion_counters(&s.fusion);
    match &s.filter {
        Some(f) => {
            t.bias_est_rad_s = f.bias_rad_s.into();
            t.covariance_upper = f.covariance_upper;
            t.since_update_s = f.since_update_s;
            t.last_nis = f.last_nis;
        }
        None => {
            t.bias_est_rad_s = [0.0; 3];
            t.covariance_upper = [0.0; 21];
            t.since_update_s = 0.0;
            t.last_nis = 0.0;
        }
    }
}

fn sample_ages(a: &SampleAges) -> link::SampleAges {
    link::SampleAges { gyro: a.gyro, star_tracker: a.star_tracker, sun: a.sun, magnetometer: a.magnetometer }
}

fn fusion_counters(c: &FusionCounts) -> link::FusionCounters {
    link::FusionCounters {
        fused_now: c.fused_now,
        fused_late: c.fused_late,
        too_old: c.too_old,
        from_the_future: c.from_the_future,
        out_of_order: c.out_of_order,
        bad_input: c.bad_input,
        max_replayed_nodes: c.max_replayed_nodes,
        fused_after_wait: c.fused_after_wait,
        dropped_waiting: c.dropped_waiting,
        waiting: c.waiting,
    }
}

/// The estimation stage's monitors' part of the FDIR telemetry (nothing without them:
/// their state stays empty).
pub(super) fn sensor_fdir(t: &mut crate::link::FdirTelemetry, d: &crate::estimation::determination::Determination) {
    use crate::fdir::tracker::TrackerFault;
    let (tracker, gyro, bias, mag) =
        (d.tracker_monitor(), d.gyro_monitor(), d.bias_monitor(), d.magnetometer_monitor());
    let gnss = d.gnss_monitor();
    let failed = tracker.failed();
    t.events = t
        .events
        .saturating_add(tracker.events())
        .saturating_add(gyro.events())
        .saturating_add(bias.events())
        .saturating_add(mag.events())
        .saturating_add(gnss.events());
    t.gyro_bias_steps = bias.events();
    if let Some(step) = bias.last() {
        t.gyro_bias_step_rad_s = step.rate_rad_s.into();
        t.gyro_bias_axes = step.axis.map_or(0, |i| 1u8.checked_shl(u32::from(i)).unwrap_or(0));
    }
    let tracker_bit = if failed.is_some() { crate::link::FAILED_STAR_TRACKER } else { 0 };
    let mag_bit = if mag.magnitude_failed() { crate::link::FAILED_MAGNETOMETER } else { 0 };
    // Bit 0 the tracker, bits 1-3 the gyro axes, 4-6 the magnetometer axes, 7 its
    // magnitude test: a u8.
    t.failed_sensors = tracker_bit | (gyro.failed_axes() & 0b111) << 1 | (mag.stuck_axes() & 0b111) << 4 | mag_bit;
    t.tracker_frozen = failed == Some(TrackerFault::Frozen);
    t.tracker_witness_rad = tracker.last_witness_rad();
    (t.mag_residual_t, t.mag_threshold_t) = mag.last_residual_t();
    t.gnss_failed = gnss.failed();
    t.gyro_erratic_axes = gyro.erratic_axes();
    (t.gnss_residual_m, t.gnss_threshold_m) = gnss.last_residual_m();
    (t.gnss_velocity_residual_m_s, t.gnss_velocity_threshold_m_s) = gnss.last_velocity_residual_m_s();
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimation::status::{EstimateFlags, FilterStatus};
    use crate::link::estimate_flags;

    /// Each law's values land in its slots and read back through the ground's readers
    /// (that the slots fit and do not overlap is a compile-time check in `law_slots`).
    #[test]
    fn law_status_packs_into_its_slots() {
        use law_slots::*;
        let ff = [1.5, -2.5, 3.5];
        let kp = [[4.0, 5.0], [6.0, 7.0], [8.0, 9.0]];
        let t = law_telemetry(&LawStatus::Dmcs { feedforward_gain: ff, proportional_gain: kp });
        assert_eq!(dmcs_feedforward_gain(&t), ff);
        assert_eq!(dmcs_proportional_gain(&t), kp);
        // The readers agree with the ranges (written apart: destructuring vs ranges).
        assert_eq!(t.get(DMCS_FEEDFORWARD_GAIN), Some(&ff[..]));
        assert_eq!(t.get(DMCS_PROPORTIONAL_GAIN), Some(kp.as_flattened()));
        let s = law_telemetry(&LawStatus::SunSafe { phase: SunSafePhase::EclipseHold, memory_age_s: 12.25 });
        assert_eq!((s[SUN_SAFE_PHASE], s[SUN_SAFE_MEMORY_AGE_S]), (2.0, 12.25));
        assert_eq!(s.iter().filter(|x| **x != 0.0).count(), 2);
        assert_eq!(law_telemetry(&LawStatus::Stateless), [0.0; LAW_TELEMETRY_LEN]);
    }

    /// The stage's flags carry the wire's bits, one for one.
    #[test]
    fn estimate_flags_are_the_wire_bits() {
        let pairs = [
            (EstimateFlags::ATTITUDE, estimate_flags::ATTITUDE),
            (EstimateFlags::MEKF, estimate_flags::MEKF),
            (EstimateFlags::NAVIGATION, estimate_flags::NAVIGATION),
            (EstimateFlags::ECLIPSE, estimate_flags::ECLIPSE),
            (EstimateFlags::SUN_SEEN, estimate_flags::SUN_SEEN),
        ];
        for (mine, wire) in pairs {
            assert_eq!(mine.bits(), wire);
        }
        assert_eq!(EstimateFlags::all().bits(), pairs.iter().fold(0, |a, p| a | p.1));
    }

    /// Every field lands in its wire field (distinct values, so a swap shows); without a
    /// filter or an estimate the wire carries zeros.
    #[test]
    fn estimate_telemetry_packs_every_field() {
        let q = crate::math::Quat::new(0.5, 0.5, -0.5, 0.5);
        let mut cov = [0.0; 21];
        for (k, c) in cov.iter_mut().enumerate() {
            *c = k as f32 + 0.25;
        }
        let fusion = FusionCounts {
            fused_now: 1,
            fused_late: 2,
            too_old: 3,
            from_the_future: 4,
            out_of_order: 5,
            bad_input: 6,
            max_replayed_nodes: 7,
            fused_after_wait: 8,
            dropped_waiting: 9,
            waiting: 10,
        };
        let s = EstimateStatus {
            q_est: Some(q),
            filter: Some(FilterStatus {
                bias_rad_s: Vec3::new(1e-3, -2e-3, 3e-3),
                covariance_upper: cov,
                since_update_s: 0.75,
                last_nis: 2.5,
            }),
            accepted: 11,
            rejected: 12,
            resets: 13,
            flags: EstimateFlags::MEKF | EstimateFlags::ECLIPSE,
            sample_age_s: SampleAges { gyro: 0.1, star_tracker: 0.2, sun: -1.0, magnetometer: 0.4 },
            fusion,
        };
        let t = estimate_telemetry(&s);
        assert_eq!(t.q_est_xyzw, [0.5, -0.5, 0.5, 0.5]);
        assert_eq!(t.bias_est_rad_s, [1e-3, -2e-3, 3e-3]);
        assert_eq!(t.covariance_upper, cov);
        assert_eq!((t.since_update_s, t.last_nis), (0.75, 2.5));
        assert_eq!((t.accepted, t.rejected, t.resets), (11, 12, 13));
        assert_eq!(t.flags, estimate_flags::MEKF | estimate_flags::ECLIPSE);
        let a = t.sample_age_s;
        assert_eq!([a.gyro, a.star_tracker, a.sun, a.magnetometer], [0.1, 0.2, -1.0, 0.4]);
        let f = t.fusion;
        let got = [
            f.fused_now,
            f.fused_late,
            f.too_old,
            f.from_the_future,
            f.out_of_order,
            f.bad_input,
            u32::from(f.max_replayed_nodes),
            f.fused_after_wait,
            f.dropped_waiting,
            u32::from(f.waiting),
        ];
        assert_eq!(got, [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]);
        let empty = estimate_telemetry(&EstimateStatus { q_est: None, filter: None, ..s });
        assert_eq!(empty.q_est_xyzw, [0.0; 4]);
        assert_eq!((empty.bias_est_rad_s, empty.covariance_upper), ([0.0; 3], [0.0; 21]));
        assert_eq!((empty.since_update_s, empty.last_nis), (0.0, 0.0));
        // Written in place over a command that carried the full report: every field
        // overwritten (a field left out would keep the old value here).
        let mut over = t;
        pack_estimate(&mut over, &EstimateStatus { q_est: None, filter: None, ..s });
        assert_eq!(over, empty);
    }
}
