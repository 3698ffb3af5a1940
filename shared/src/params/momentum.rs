//! Momentum-management parameters (the outer loop in [`crate::control::momentum`]).

use super::{
    MAX_THRUSTERS, ParamError, ParamField, ParamReason, ThrusterMethod, ThrusterParams, check_finite, check_range, err,
    flat,
};
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// How the stored momentum is unloaded (when `enabled`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum UnloadMethod {
    /// Cross-product law on the magnetorquers (continuous).
    Magnetic,
    /// Momentum dump through the thruster LP allocation (`dump_*` fields), started above
    /// `dump_start_nms` and ended below `dump_stop_nms` (hysteresis).
    Thrusters,
}

/// Unloading of the stored actuator momentum (wheels or CMG cluster), magnetic or by
/// thruster dump, and the magnetometer's torquer-field correction. Carried by every mode's parameter set; a mode
/// whose actuator family stores no momentum must leave `enabled` false.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MomentumParams {
    /// Run the unloading law in this mode.
    pub enabled: bool,
    /// Cross-product law gain `k`, 1/s: the unloading torque is `-k h_err⊥B` before
    /// saturation (time constant `1/k` for the component perpendicular to the field).
    pub gain_per_s: f32,
    /// No unloading while `|h - h_target|` is below this, N m s.
    pub deadband_nms: f32,
    /// Commanded stored momentum, body axes, N m s (zero or a bias).
    pub target_nms: [f32; 3],
    /// Largest dipole per torquer rod (symmetric), A m²; the dipole is scaled as a whole
    /// (direction kept) to respect it.
    pub max_dipole_am2: [f32; 3],
    /// The spacecraft's residual dipole as known on board, body axes, A m²: the torquers
    /// cancel it (within their limit) and the feed-forward counts it.
    pub residual_dipole_am2: [f32; 3],
    /// Field of the torquers at the magnetometer per unit dipole, T per A m² (row = field
    /// axis): the flight code subtracts `C · m_last` from the magnetometer before using it
    /// (all zero: no correction). Applied in every mode whose parameter set carries it.
    pub mag_coupling_t_per_am2: [[f32; 3]; 3],
    /// Below this field magnitude the law commands nothing, T.
    pub min_field_t: f32,
    /// Magnetic (the fields above) or thruster dump (the `dump_*` fields below).
    pub method: UnloadMethod,
    /// Dump gain `k_dump`, 1/s: the dump torque is `-k_dump h_err` before its cap.
    pub dump_gain_per_s: f32,
    /// Largest dump torque (norm; the vector is scaled, direction kept), N m.
    pub dump_torque_max_nm: f32,
    /// A dump starts when `|h - h_target|` exceeds this, N m s.
    pub dump_start_nms: f32,
    /// A dump ends when `|h - h_target|` falls below this, N m s (`< dump_start_nms`).
    pub dump_stop_nms: f32,
    /// The thrusters that dump (a wheel or CMG mode has no thruster family of its own).
    pub dump_thrusters: ThrusterParams,
    /// Bit i: torquer rod i failed — the unloading dipole is realised by the others
    /// (params version 14; as [`super::MagnetorquerParams::failed_mask`]).
    pub failed_rods_mask: u8,
}

/// Largest magnitude of a torquer-to-magnetometer coupling coefficient, T per A m² (the
/// Earth's field is ~5e-5 T: a larger coupling would swamp it at any useful dipole).
pub const MAX_MAG_COUPLING_T_PER_AM2: f32 = 1.0e-2;

/// No thrusters (the `dump_thrusters` of a magnetic or disabled set).
pub const NO_THRUSTERS: ThrusterParams = ThrusterParams {
    count: 0,
    torque_nm: [[0.0; MAX_THRUSTERS]; 3],
    method: ThrusterMethod::DirectionPreserving,
    pwpf_km: 0.0,
    pwpf_tm_s: 0.0,
    pwpf_u_on: 0.0,
    pwpf_u_off: 0.0,
    failed_mask: 0,
};

impl MomentumParams {
    /// Off, no magnetometer correction.
    pub const OFF: Self = Self {
        enabled: false,
        gain_per_s: 0.0,
        deadband_nms: 0.0,
        target_nms: [0.0; 3],
        max_dipole_am2: [0.0; 3],
        residual_dipole_am2: [0.0; 3],
        mag_coupling_t_per_am2: [[0.0; 3]; 3],
        min_field_t: 1e-7,
        method: UnloadMethod::Magnetic,
        dump_gain_per_s: 0.0,
        dump_torque_max_nm: 0.0,
        dump_start_nms: 0.0,
        dump_stop_nms: 0.0,
        dump_thrusters: NO_THRUSTERS,
        failed_rods_mask: 0,
    };

    /// Thruster dump selected and enabled.
    pub fn dumps(&self) -> bool {
        self.enabled && self.method == UnloadMethod::Thrusters
    }

    /// Every value finite and in range; enabled needs a positive gain and dipole limit.
    pub fn validate(&self) -> Result<(), ParamError> {
        use ParamField as F;
        check_range(F::Momentum, self.gain_per_s, 0.0, 10.0)?;
        check_range(F::Momentum, self.deadband_nms, 0.0, 1.0e6)?;
        check_finite(F::Momentum, &self.target_nms)?;
        check_finite(F::Momentum, &self.residual_dipole_am2)?;
        check_finite(F::Momentum, &flat(&self.mag_coupling_t_per_am2))?;
        if flat(&self.mag_coupling_t_per_am2).iter().any(|c| libm::fabsf(*c) > MAX_MAG_COUPLING_T_PER_AM2) {
            return Err(err(F::Momentum, ParamReason::OutOfRange));
        }
        for m in self.max_dipole_am2 {
            check_range(F::Momentum, m, 0.0, 1.0e4)?;
        }
        check_range(F::Momentum, self.min_field_t, 1e-9, 1.0)?;
        super::actuator::check_rod_mask(self.failed_rods_mask)?;
        self.validate_dump()?;
        if self.enabled
            && self.method == UnloadMethod::Magnetic
            && (self.gain_per_s <= 0.0 || self.max_dipole_am2.iter().any(|m| *m <= 0.0))
        {
            return Err(err(F::Momentum, ParamReason::OutOfRange));
        }
        Ok(())
    }
}

impl MomentumParams {
    /// The thruster-dump fields (`ParamField::MomentumDump`); the thruster set itself is
    /// checked only when the dump is selected (else it must be empty or valid).
    fn validate_dump(&self) -> Result<(), ParamError> {
        use ParamField as F;
        let bad = err(F::MomentumDump, ParamReason::OutOfRange);
        check_range(F::MomentumDump, self.dump_gain_per_s, 0.0, 10.0)?;
        check_range(F::MomentumDump, self.dump_torque_max_nm, 0.0, 1.0e4)?;
        check_range(F::MomentumDump, self.dump_start_nms, 0.0, 1.0e6)?;
        check_range(F::MomentumDump, self.dump_stop_nms, 0.0, 1.0e6)?;
        if self.dump_thrusters.count != 0 {
            self.dump_thrusters.validate().map_err(|_| bad)?;
        }
        if !self.dumps() {
            return Ok(());
        }
        let positive = self.dump_gain_per_s > 0.0 && self.dump_torque_max_nm > 0.0;
        if !positive || self.dump_stop_nms >= self.dump_start_nms || self.dump_thrusters.count == 0 {
            return Err(bad);
        }
        Ok(())
    }
}

impl Default for MomentumParams {
    fn default() -> Self {
        Self::OFF
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_names_the_momentum_field() {
        assert_eq!(MomentumParams::OFF.validate(), Ok(()));
        let on = MomentumParams { enabled: true, gain_per_s: 0.01, max_dipole_am2: [0.1; 3], ..MomentumParams::OFF };
        assert_eq!(on.validate(), Ok(()));
        for bad in [
            MomentumParams { gain_per_s: 0.0, ..on },
            MomentumParams { gain_per_s: f32::NAN, ..on },
            MomentumParams { max_dipole_am2: [0.1, 0.0, 0.1], ..on },
            MomentumParams { deadband_nms: -1.0, ..on },
            MomentumParams { target_nms: [f32::INFINITY, 0.0, 0.0], ..on },
            MomentumParams { mag_coupling_t_per_am2: [[1.0, 0.0, 0.0], [0.0; 3], [0.0; 3]], ..on },
            MomentumParams { min_field_t: 0.0, ..on },
        ] {
            assert_eq!(bad.validate().unwrap_err().field, ParamField::Momentum, "{bad:?}");
        }
    }

    #[test]
    fn dump_validation_names_the_dump_field() {
        let thr = ThrusterParams {
            count: 2,
            torque_nm: {
                let mut b = [[0.0; MAX_THRUSTERS]; 3];
                b[0][0] = 1.0;
                b[0][1] = -1.0;
                b
            },
            pwpf_km: 4.5,
            pwpf_tm_s: 0.15,
            pwpf_u_on: 0.45,
            pwpf_u_off: 0.15,
            ..NO_THRUSTERS
        };
        let on = MomentumParams {
            enabled: true,
            method: UnloadMethod::Thrusters,
            dump_gain_per_s: 0.1,
            dump_torque_max_nm: 0.5,
            dump_start_nms: 1.0,
            dump_stop_nms: 0.1,
            dump_thrusters: thr,
            ..MomentumParams::OFF
        };
        // No magnetic fields needed for a thruster dump.
        assert_eq!(on.validate(), Ok(()));
        assert!(on.dumps() && !MomentumParams::OFF.dumps());
        for bad in [
            MomentumParams { dump_gain_per_s: 0.0, ..on },
            MomentumParams { dump_gain_per_s: f32::NAN, ..on },
            MomentumParams { dump_torque_max_nm: 0.0, ..on },
            MomentumParams { dump_torque_max_nm: -1.0, ..on },
            MomentumParams { dump_stop_nms: 1.0, ..on },
            MomentumParams { dump_start_nms: f32::INFINITY, ..on },
            MomentumParams { dump_thrusters: NO_THRUSTERS, ..on },
            MomentumParams { dump_thrusters: ThrusterParams { pwpf_u_off: 0.5, ..thr }, ..on },
        ] {
            assert_eq!(bad.validate().unwrap_err().field, ParamField::MomentumDump, "{bad:?}");
        }
        // Disabled: the dump fields are not required.
        assert_eq!(MomentumParams { enabled: false, dump_thrusters: NO_THRUSTERS, ..on }.validate(), Ok(()));
    }
}
