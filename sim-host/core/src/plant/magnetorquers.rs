//! Magnetorquers (paper 003): per-rod dead band and asymmetric saturation, residual
//! dipole, torque `τ = m × B`.
//!
//! Paper 003 (section on the rig, in Persian) says only: the dipole is limited to
//! +12.26 / −11.76 A m², and "these actuators have a magnetic hysteresis (remanence)
//! effect and no dipole can be produced between −1.26 and +1.86 A m²". It gives no loop
//! shape, remanence or switching history, so the "hysteresis" is modelled exactly as
//! described: a memoryless, asymmetric dead band. Everything here is therefore **pure**
//! (no state): call [`MagnetorquerSet::realised`] when the command changes (or every RK4
//! stage, same result) and [`MagnetorquerSet::torque`] with the field at the stage.
//! Note that the paper's word for the cubesat's "residual dipole" (table 1) is the same
//! Persian word (پسماند); that one is a constant body dipole, `residual_dipole_am2`.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

type Vec3 = Vector3<f64>;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MagnetorquerSpec {
    /// Unit rod axis, body.
    pub axis: [f64; 3],
    /// Largest positive dipole, A m².
    pub max_pos_am2: f64,
    /// Largest negative dipole as a positive magnitude, A m².
    pub max_neg_am2: f64,
    /// Dead band `(lo, hi)`, A m², `lo ≤ 0 ≤ hi`: a command strictly inside gives 0.
    pub deadband_lo_am2: f64,
    pub deadband_hi_am2: f64,
}

impl MagnetorquerSpec {
    /// Pure: dipole the rod produces for a command (A m²). Non-finite commands give 0.
    pub fn realised(&self, cmd_am2: f64) -> f64 {
        if !cmd_am2.is_finite() || (cmd_am2 > self.deadband_lo_am2 && cmd_am2 < self.deadband_hi_am2) {
            0.0
        } else {
            cmd_am2.clamp(-self.max_neg_am2, self.max_pos_am2)
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MagnetorquerSet {
    pub rods: Vec<MagnetorquerSpec>,
    /// Constant spacecraft dipole, body, A m² (always present, rods on or off).
    pub residual_dipole_am2: [f64; 3],
    /// Transport delay of the rod commands, whole control periods (driver, bus, coil
    /// current rise lumped as a pure delay; 0 = the command acts in its own period).
    #[serde(default)]
    pub delay_steps: usize,
}

impl MagnetorquerSet {
    fn triad(max_pos: f64, max_neg: f64, lo: f64, hi: f64, residual: [f64; 3]) -> Self {
        let rod = |axis| MagnetorquerSpec {
            axis,
            max_pos_am2: max_pos,
            max_neg_am2: max_neg,
            deadband_lo_am2: lo,
            deadband_hi_am2: hi,
        };
        Self {
            rods: vec![rod([1.0, 0.0, 0.0]), rod([0.0, 1.0, 0.0]), rod([0.0, 0.0, 1.0])],
            residual_dipole_am2: residual,
            delay_steps: 0,
        }
    }

    /// Paper 003 air-bearing rig: three body-axis rods, +12.26 / −11.76 A m², dead band
    /// −1.26 … +1.86 A m². The rig's residual dipole is not given: zero.
    pub fn paper003_rig() -> Self {
        Self::triad(12.26, 11.76, -1.26, 1.86, [0.0; 3])
    }

    /// Paper 003 orbit simulation (table 1): ±0.06 A m² per axis, no dead band given,
    /// residual dipole [0, 0, 0.001] A m².
    pub fn paper003_cubesat() -> Self {
        Self::triad(0.06, 0.06, 0.0, 0.0, [0.0, 0.0, 0.001])
    }

    /// Pure: dipole each rod actually produces for per-rod commands (A m²). Missing
    /// commands count as 0.
    pub fn realised(&self, cmd_am2: &[f64]) -> Vec<f64> {
        self.rods.iter().enumerate().map(|(i, r)| r.realised(cmd_am2.get(i).copied().unwrap_or(0.0))).collect()
    }

    /// Pure: body dipole of the rods alone (A m²), e.g. for magnetometer coupling.
    pub fn rod_dipole_am2(&self, realised: &[f64]) -> [f64; 3] {
        self.rods.iter().zip(realised).map(|(r, &m)| Vec3::from(r.axis) * m).sum::<Vec3>().into()
    }

    /// Pure: total body dipole `m` (rods + residual, A m²) and torque `m × B` (N m) for
    /// the field `b_body_t` (tesla, body axes).
    pub fn torque(&self, realised: &[f64], b_body_t: &[f64; 3]) -> ([f64; 3], [f64; 3]) {
        let m = Vec3::from(self.rod_dipole_am2(realised)) + Vec3::from(self.residual_dipole_am2);
        (m.into(), m.cross(&Vec3::from(*b_body_t)).into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dead_band_gives_nothing() {
        let s = MagnetorquerSet::paper003_rig();
        for c in [-1.25, -0.5, 0.0, 0.3, 1.0, 1.85] {
            assert_eq!(s.realised(&[c, c, c]), vec![0.0; 3], "{c}");
        }
        // Edges and just outside produce the command.
        assert_eq!(s.realised(&[-1.26, 1.86, 1.9]), vec![-1.26, 1.86, 1.9]);
        assert_eq!(s.realised(&[f64::NAN]), vec![0.0; 3]);
    }

    #[test]
    fn saturation_is_per_axis_and_asymmetric() {
        let s = MagnetorquerSet::paper003_rig();
        assert_eq!(s.realised(&[20.0, -20.0, 5.0]), vec![12.26, -11.76, 5.0]);
        assert_eq!(s.realised(&[-12.0, 12.0, -11.0]), vec![-11.76, 12.0, -11.0]);
        let c = MagnetorquerSet::paper003_cubesat();
        assert_eq!(c.realised(&[0.1, -0.1, 0.01]), vec![0.06, -0.06, 0.01]);
    }

    #[test]
    fn torque_is_m_cross_b() {
        let s = MagnetorquerSet::paper003_rig();
        // m = (2, -3, 4) A m², B = (20, 5, -40) µT:
        // m × B = (my Bz - mz By, mz Bx - mx Bz, mx By - my Bx)
        //       = (120 - 20, 80 + 80, 10 + 60) µN m = (100, 160, 70) µN m.
        let b = [20e-6, 5e-6, -40e-6];
        let m = s.realised(&[2.0, -3.0, 4.0]);
        let (dip, tq) = s.torque(&m, &b);
        assert_eq!(dip, [2.0, -3.0, 4.0]);
        let want = [100e-6, 160e-6, 70e-6];
        for k in 0..3 {
            assert!((tq[k] - want[k]).abs() < 1e-18, "{tq:?}");
        }
        // Paper 003: full dipole in a ~50 µT lab field gives a torque of order 8e-4 N m.
        let (_, t) = s.torque(&s.realised(&[0.0, 13.0, 0.0]), &[50e-6, 0.0, 0.0]);
        assert!((t[2] + 12.26 * 50e-6).abs() < 1e-15);
        // A skewed rod projects along its axis.
        let skew = MagnetorquerSet {
            rods: vec![MagnetorquerSpec { axis: [0.6, 0.8, 0.0], ..s.rods[0] }],
            residual_dipole_am2: [0.0; 3],
            delay_steps: 0,
        };
        assert_eq!(skew.rod_dipole_am2(&skew.realised(&[5.0])), [3.0, 4.0, 0.0]);
    }

    #[test]
    fn residual_alone() {
        let c = MagnetorquerSet::paper003_cubesat();
        let b = [30e-6, -10e-6, 20e-6];
        let (m, t) = c.torque(&c.realised(&[0.0; 3]), &b);
        assert_eq!(m, [0.0, 0.0, 0.001]);
        // (0, 0, mz) × B = (-mz By, mz Bx, 0)
        assert_eq!(t, [0.001 * 10e-6, 0.001 * 30e-6, 0.0]);
    }
}
