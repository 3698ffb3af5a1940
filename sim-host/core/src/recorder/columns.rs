//! The columns of a run's time series: a fixed block ([`Col`]) then one optional group per
//! actuator family and environment model present ([`Layout`]). The names, the order of
//! the values in a row and the units ([`unit`]) are defined here only.

/// The columns every run records, in order (index = position in the row).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(usize)]
pub enum Col {
    T,
    Qx,
    Qy,
    Qz,
    Qw,
    Roll,
    Pitch,
    Yaw,
    RollTarget,
    PitchTarget,
    YawTarget,
    RateX,
    RateY,
    RateZ,
    DemandX,
    DemandY,
    DemandZ,
    RealisedX,
    RealisedY,
    RealisedZ,
    AppliedX,
    AppliedY,
    AppliedZ,
    Error,
    Status,
    StepCost,
}

impl Col {
    /// Number of fixed columns.
    pub const COUNT: usize = Col::StepCost as usize + 1;

    pub const fn index(self) -> usize {
        self as usize
    }

    /// The CSV header of the column.
    pub const fn name(self) -> &'static str {
        FIXED[self as usize]
    }

    /// Attitude quaternion, `[x, y, z, w]`.
    pub const Q: [Col; 4] = [Col::Qx, Col::Qy, Col::Qz, Col::Qw];
    /// Euler angles `[roll, pitch, yaw]`, deg, and their targets.
    pub const EULER: [Col; 3] = [Col::Roll, Col::Pitch, Col::Yaw];
    pub const EULER_TARGET: [Col; 3] = [Col::RollTarget, Col::PitchTarget, Col::YawTarget];
    /// Body rate, x y z.
    pub const RATE: [Col; 3] = [Col::RateX, Col::RateY, Col::RateZ];
    /// Torque demanded by the flight code, realised by the actuators, applied to the body.
    pub const DEMAND: [Col; 3] = [Col::DemandX, Col::DemandY, Col::DemandZ];
    pub const REALISED: [Col; 3] = [Col::RealisedX, Col::RealisedY, Col::RealisedZ];
    pub const APPLIED: [Col; 3] = [Col::AppliedX, Col::AppliedY, Col::AppliedZ];
}

const FIXED: [&str; Col::COUNT] = [
    "t_s",
    "q_x",
    "q_y",
    "q_z",
    "q_w",
    "roll_deg",
    "pitch_deg",
    "yaw_deg",
    "roll_target_deg",
    "pitch_target_deg",
    "yaw_target_deg",
    "rate_x_rad_s",
    "rate_y_rad_s",
    "rate_z_rad_s",
    "torque_demand_x_nm",
    "torque_demand_y_nm",
    "torque_demand_z_nm",
    "torque_realised_x_nm",
    "torque_realised_y_nm",
    "torque_realised_z_nm",
    "torque_applied_x_nm",
    "torque_applied_y_nm",
    "torque_applied_z_nm",
    "error_deg",
    "status",
    "step_cost_insns",
];

/// Per-wheel quantities, in column order.
pub const WHEEL_QUANTITIES: [&str; 6] = ["speed_rpm", "current_a", "voltage_v", "power_w", "friction_nm", "torque_nm"];
/// Environment torque groups, in column order.
pub const ENV_TORQUES: [&str; 6] = ["gravity_gradient", "drag", "srp", "magnetic", "rig", "external"];

/// The estimation group, in column order.
pub const ESTIMATION: [&str; 14] = [
    "est_error_deg",
    "est_sigma_deg",
    "est_bias_error_deg_h",
    "est_bias_sigma_deg_h",
    "est_nees",
    "est_rejected",
    "est_resets",
    "est_age_gyro_s",
    "est_age_tracker_s",
    "est_age_sun_s",
    "est_age_mag_s",
    "est_fused",
    "est_fused_late",
    "est_refused",
];

/// The guidance group (with `[guidance]`), in column order: the truth's pointing errors,
/// the primary direction in body axes, the gate site's view, the segment, the flight's
/// guidance telemetry, and the true orbit state, Sun and Earth angle (ECI).
pub const GUIDANCE: [&str; 29] = [
    "pointing_primary_error_deg",
    "pointing_secondary_error_deg",
    "guidance_error_deg",
    "target_body_x",
    "target_body_y",
    "target_body_z",
    "target_elevation_deg",
    "target_visible",
    "pointing_segment",
    "pointing_parallel",
    "guidance_flags",
    "guidance_switches",
    "guidance_parallel_events",
    "guidance_rate_cmd_x_rad_s",
    "guidance_rate_cmd_y_rad_s",
    "guidance_rate_cmd_z_rad_s",
    "guidance_accel_cmd_x_rad_s2",
    "guidance_accel_cmd_y_rad_s2",
    "guidance_accel_cmd_z_rad_s2",
    "r_eci_x_m",
    "r_eci_y_m",
    "r_eci_z_m",
    "v_eci_x_m_s",
    "v_eci_y_m_s",
    "v_eci_z_m_s",
    "sun_eci_x",
    "sun_eci_y",
    "sun_eci_z",
    "earth_angle_rad",
];

/// Columns without a unit ("1"): quaternion components, codes, counts, gains, ratios.
/// Checked before the suffixes ([`UNIT_SUFFIXES`]), which they could otherwise match
/// (`q_w` is not in watts, `singularity_m` not in metres).
const DIMENSIONLESS: [&str; 36] = [
    "fdir_failed_wheels",
    "fault_active",
    "timeline_segment",
    "slew_phase",
    "slews_planned",
    "slews_refused",
    "eclipse",
    "target_body_x",
    "target_body_y",
    "target_body_z",
    "target_visible",
    "pointing_segment",
    "pointing_parallel",
    "guidance_flags",
    "guidance_switches",
    "guidance_parallel_events",
    "sun_eci_x",
    "sun_eci_y",
    "sun_eci_z",
    "q_x",
    "q_y",
    "q_z",
    "q_w",
    "status",
    "mode",
    "singularity_m",
    "steering_alpha",
    "thrusters_on",
    "pulses_total",
    "est_nees",
    "est_rejected",
    "est_resets",
    "est_fused",
    "est_fused_late",
    "est_refused",
    "momentum_events",
];

/// The unit of a column from its name's suffix (first match; longer suffixes first).
const UNIT_SUFFIXES: [(&str, &str); 18] = [
    ("_rad_s2", "rad/s^2"),
    ("_rad_s", "rad/s"),
    ("_m_s", "m/s"),
    ("_deg_h", "deg/h"),
    ("_insns", "instructions"),
    ("_nms", "N m s"),
    ("_am2", "A m^2"),
    ("_rpm", "rpm"),
    ("_deg", "deg"),
    ("_rad", "rad"),
    ("_nm", "N m"),
    ("_kg", "kg"),
    ("_s", "s"),
    ("_a", "A"),
    ("_v", "V"),
    ("_w", "W"),
    ("_t", "T"),
    ("_m", "m"),
];

/// The unit of a recorded column (`"1"`: dimensionless), `None` for a name this module
/// does not define. The one place units are derived (the Parquet file's `units`).
pub fn unit(name: &str) -> Option<&'static str> {
    let gain_or_level =
        name.starts_with("adaptive_gain_") || (name.starts_with("thruster") && name.ends_with("_level"));
    if DIMENSIONLESS.contains(&name) || gain_or_level {
        return Some("1");
    }
    UNIT_SUFFIXES.iter().find(|(suffix, _)| name.ends_with(suffix)).map(|(_, u)| *u)
}

/// Which optional groups a run records (in this order after the fixed block).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Layout {
    /// DMCS adaptive gains (3).
    pub adaptive_gains: bool,
    /// Flight mode (1).
    pub mode: bool,
    /// The flight code's own attitude error (closed loop) (1).
    pub flight_error: bool,
    /// CMG gimbal angles, rates, singularity measure, SR weight (10).
    pub cmg: bool,
    /// Six quantities per wheel.
    pub wheels: usize,
    /// Commanded and realised magnetorquer dipoles (6).
    pub magnetorquers: bool,
    /// Valve mask, propellant, pulses and one level per thruster (0 = none).
    pub thrusters: usize,
    /// Magnetic field in body axes (3).
    pub field: bool,
    /// Environment and rig torque breakdown (18).
    pub env_torques: bool,
    /// The flight MEKF against the truth: attitude and bias errors and the filter's own
    /// σ, NEES, rejected innovations and restarts so far (NaN while the MEKF is not
    /// running; `sim_host::estimation::stats`); the age of each sensor's newest sample at
    /// the step (NaN without one) and the samples fused, fused late and refused so far
    /// (14).
    pub estimation: bool,
    /// Stored actuator momentum (truth) in body and inertial axes and its norm, the
    /// torquers' torque `m_rods × B`, the flight code's momentum FDIR event count (11;
    /// with `[momentum]` or the momentum FDIR on).
    pub momentum: bool,
    /// 1 while the spacecraft is in the Earth's shadow, else 0 (1; with an orbit and an
    /// environment model: the figures shade those spans).
    pub eclipse: bool,
    /// The pointing's truth and the flight's guidance telemetry, the true orbit state, Sun
    /// and Earth angle ([`GUIDANCE`]; with `[guidance]`).
    pub guidance: bool,
    /// With `[manoeuvre]` keep-out cones and an orbit: the columns of
    /// [`crate::recorder::keepout::column_names`] (empty: none).
    pub keepout: Vec<String>,
    /// With `[[faults]]`: `fault_active`, the bitmask of the entries in force at the step
    /// (bit i: `faults[i]`) (1).
    pub faults: bool,
    /// With `[[timeline]]`: the flight's timeline segment in force, index + 1 (0: none
    /// yet) (1).
    pub timeline: bool,
    /// With `[fdir.wheels]`, the wheel count: the wheels the flight's FDIR dropped (bit
    /// mask), each wheel's torque residual and their threshold (n + 2; 0 = none).
    pub fdir_wheels: usize,
    /// With `[fdir.magnetometer]`: the monitor's residual `|B_meas| − |B_model|` and its
    /// threshold, T (2).
    pub fdir_magnetometer: bool,
    /// With `[fdir.gnss]`: the monitor's residual `|r_fix − r_pred|` and its threshold, m
    /// (2).
    pub fdir_gnss: bool,
}

fn xyz(f: impl Fn(&str) -> String) -> [String; 3] {
    ["x", "y", "z"].map(f)
}

impl Layout {
    pub fn names(&self) -> Vec<String> {
        let mut v: Vec<String> = FIXED.iter().map(|s| s.to_string()).collect();
        if self.adaptive_gains {
            v.extend(xyz(|a| format!("adaptive_gain_{a}")));
        }
        if self.mode {
            v.push("mode".into());
        }
        if self.flight_error {
            v.push("flight_error_deg".into());
        }
        if self.cmg {
            v.extend((1..=4).map(|i| format!("gimbal{i}_deg")));
            v.extend((1..=4).map(|i| format!("gimbal_rate{i}_rad_s")));
            v.extend(["singularity_m".into(), "steering_alpha".into()]);
        }
        for i in 1..=self.wheels {
            v.extend(WHEEL_QUANTITIES.map(|q| format!("wheel{i}_{q}")));
        }
        if self.magnetorquers {
            v.extend(xyz(|a| format!("dipole_cmd_{a}_am2")));
            v.extend(xyz(|a| format!("dipole_{a}_am2")));
        }
        if self.thrusters > 0 {
            v.extend(["thrusters_on".into(), "propellant_kg".into(), "pulses_total".into()]);
            v.extend((1..=self.thrusters).map(|i| format!("thruster{i}_level")));
        }
        if self.field {
            v.extend(xyz(|a| format!("b_body_{a}_t")));
        }
        if self.env_torques {
            for g in ENV_TORQUES {
                v.extend(xyz(|a| format!("torque_{g}_{a}_nm")));
            }
        }
        if self.estimation {
            v.extend(ESTIMATION.iter().map(|s| s.to_string()));
        }
        if self.momentum {
            v.extend(xyz(|a| format!("h_body_{a}_nms")));
            v.extend(xyz(|a| format!("h_inertial_{a}_nms")));
            v.push("h_norm_nms".into());
            v.extend(xyz(|a| format!("torque_unload_{a}_nm")));
            v.push("momentum_events".into());
        }
        if self.eclipse {
            v.push("eclipse".into());
        }
        if self.guidance {
            v.extend(GUIDANCE.iter().map(|s| s.to_string()));
        }
        v.extend(self.keepout.iter().cloned());
        if self.faults {
            v.push("fault_active".into());
        }
        if self.timeline {
            v.push("timeline_segment".into());
        }
        if self.fdir_wheels > 0 {
            v.push("fdir_failed_wheels".into());
            v.extend((1..=self.fdir_wheels).map(|i| format!("wheel{i}_residual_nm")));
            v.push("wheel_residual_threshold_nm".into());
        }
        if self.fdir_magnetometer {
            v.extend(["mag_residual_t".into(), "mag_residual_threshold_t".into()]);
        }
        if self.fdir_gnss {
            v.extend(["gnss_residual_m".into(), "gnss_residual_threshold_m".into()]);
            v.extend(["gnss_velocity_residual_m_s".into(), "gnss_velocity_residual_threshold_m_s".into()]);
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_indices_match_the_names() {
        let names = Layout::default().names();
        assert_eq!(names.len(), Col::COUNT);
        assert_eq!(names[Col::T.index()], "t_s");
        assert_eq!(names[Col::Error.index()], "error_deg");
        assert_eq!(names[Col::AppliedZ.index()], "torque_applied_z_nm");
        assert_eq!(names[Col::StepCost.index()], "step_cost_insns");
        for (i, n) in names.iter().enumerate() {
            assert_eq!(FIXED[i], n);
        }
        assert_eq!(Col::RATE.map(Col::name), ["rate_x_rad_s", "rate_y_rad_s", "rate_z_rad_s"]);
        assert_eq!(Col::EULER_TARGET[2].name(), "yaw_target_deg");
    }

    #[test]
    fn groups_follow_in_order() {
        let l = Layout { cmg: true, wheels: 2, thrusters: 1, env_torques: true, ..Layout::default() };
        let names = l.names();
        assert_eq!(names.len(), Col::COUNT + 10 + 12 + 4 + 18);
        assert_eq!(names[Col::COUNT], "gimbal1_deg");
        assert_eq!(names[Col::COUNT + 10 + 6], "wheel2_speed_rpm");
        assert_eq!(names.last().unwrap(), "torque_external_z_nm");
        let names = Layout { estimation: true, ..l }.names();
        assert_eq!(names.len(), Col::COUNT + 10 + 12 + 4 + 18 + 14);
        assert_eq!(names[Col::COUNT + 44], "est_error_deg");
        assert_eq!(names[Col::COUNT + 44 + 6], "est_resets");
        assert_eq!(names.last().unwrap(), "est_refused");
    }

    fn every_group() -> Layout {
        Layout {
            adaptive_gains: true,
            mode: true,
            flight_error: true,
            cmg: true,
            wheels: 6,
            magnetorquers: true,
            thrusters: 12,
            field: true,
            env_torques: true,
            estimation: true,
            momentum: true,
            eclipse: true,
            guidance: true,
            keepout: crate::recorder::keepout::column_names(&[crate::recorder::keepout::Cone {
                name: "st".into(),
                boresight_body: crate::attitude::Vec3::z(),
                sun_half_angle_rad: Some(0.5),
                earth_margin_rad: Some(0.1),
            }]),
            faults: true,
            timeline: true,
            fdir_wheels: 4,
            fdir_magnetometer: true,
            fdir_gnss: true,
        }
    }

    #[test]
    fn every_column_has_a_unit() {
        for name in every_group().names() {
            assert!(unit(&name).is_some(), "{name} has no unit");
        }
        let units = |names: &[&str]| names.iter().map(|n| unit(n).unwrap()).collect::<Vec<_>>();
        assert_eq!(
            units(&["t_s", "q_w", "rate_x_rad_s", "wheel2_power_w", "singularity_m"]),
            ["s", "1", "rad/s", "W", "1"]
        );
        assert_eq!(
            units(&["h_norm_nms", "est_bias_error_deg_h", "b_body_z_t", "dipole_cmd_x_am2"]),
            ["N m s", "deg/h", "T", "A m^2"]
        );
        assert_eq!(
            units(&["thruster12_level", "adaptive_gain_z", "wheel1_current_a", "torque_srp_y_nm"]),
            ["1", "1", "A", "N m"]
        );
        assert_eq!(unit("no_unit_here"), None);
    }
}
