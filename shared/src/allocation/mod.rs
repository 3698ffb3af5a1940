//! Actuator allocation: from a body-torque demand to actuator commands, with one
//! result type for every family (PX4-style: one interface, several methods, saturation
//! reported back to the controller).
//!
//! Effectiveness (geometry: what commands do to the body) is kept apart from the
//! allocation methods that invert it, as in PX4:
//! - [`effectiveness`]: the CMG pyramid (paper 000 eqs 4, 6-8) and the wheel array
//!   (paper 001 eq 5);
//! - [`wheels`]: reaction-wheel pseudo-inverse with null-space momentum management;
//! - [`cmg`]: the CMG steering laws (paper 000 eqs 11-14, GSR);
//! - [`magnetorquers`]: the cross-product dipole law (paper 003 eqs 21-22);
//! - [`thruster`]: bounded-variable simplex LP (paper 004) and PWPF modulation.
//!
//! [`family`] puts every family behind one trait ([`family::ActuatorFamily`]) with one
//! result ([`family::Allocation`]); the CMG steering ([`cmg`]) is one of them.

pub mod cmg;
pub mod effectiveness;
pub mod family;
pub mod magnetorquers;
pub mod thruster;
pub mod wheels;

/// Number of controlled axes (moments about x, y, z).
pub const AXES: usize = 3;

/// Allocation outcome.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AllocStatus {
    /// Demand attained: `B u = m_d` within the LP tolerances, `λ = 1`.
    Ok,
    /// Not attainable: `B u = λ m_d` with `0 <= λ < 1` (direction kept).
    Scaled,
    /// No admissible `u` keeps the direction (bounds inconsistent, or stuck-on /
    /// rate-limited thrusters force a moment off the demanded ray). Fallback used.
    Infeasible,
    /// Non-finite input (`m_d`, `B`, limits, rate data). Fallback used.
    NonFinite,
    /// The simplex hit its iteration cap. Fallback used.
    IterationCap,
    /// The actuator geometry cannot produce torque about some axis (rank < 3: CMG
    /// singularity, too few healthy wheels, |B| ≈ 0 for magnetorquers). Best effort.
    Singular,
    /// A logic error inside the allocator (an index out of range): detected, not turned
    /// into a plausible wrong number. Fallback used, reported as `ALLOC_FALLBACK`.
    InternalError,
}

/// What an allocation achieved, for every method and family: everything but the
/// commands. Embedded in [`AllocResult`] and [`family::Allocation`], which both
/// dereference to it (`r.lambda`, `r.status`, … read the outcome).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AllocOutcome {
    /// Body torque the commands produce, N m (`B u` for thrusters).
    pub realised: [f32; AXES],
    /// Demand minus realised, N m.
    pub shortfall: [f32; AXES],
    /// Fraction of the demand achieved along its direction (1 when `Ok`).
    pub lambda: f32,
    /// Bit `i`: actuator `i` (0-based) at its lower bound.
    pub sat_low: u32,
    /// Bit `i`: actuator `i` at its upper bound.
    pub sat_high: u32,
    /// Bit `i`: actuator `i` was commanded but cannot realise it (magnetorquer
    /// dead band, wheel at its speed limit); its share is missing from `realised`.
    pub unrealised: u32,
    /// Simplex iterations (pivots + bound flips) over all LPs of the call; passes of
    /// the iterative wheel / magnetorquer laws; 1 for CMG steering.
    pub iterations: u16,
    pub status: AllocStatus,
}

impl AllocOutcome {
    /// Fraction of `demand` realised along its direction, `realised·demand / |demand|²`
    /// limited to [0, 1]; 1 for a zero demand. A NaN stays NaN (the caller's finiteness
    /// checks see it); never panics.
    // Written out: `f32::clamp` is disallowed in flight code (clippy.toml).
    #[allow(clippy::manual_clamp)]
    pub fn fraction_along(realised: &crate::math::Vec3, demand: &crate::math::Vec3) -> f32 {
        let dn = demand.norm_squared();
        if dn > 0.0 {
            let f = realised.dot(demand) / dn;
            if f > 1.0 {
                1.0
            } else if f < 0.0 {
                0.0
            } else {
                f
            }
        } else {
            1.0
        }
    }

    /// Nothing realised yet: the whole demand as shortfall, status `Ok`.
    pub fn nothing_realised(demand_nm: &crate::math::Vec3) -> Self {
        Self {
            realised: [0.0; AXES],
            shortfall: (*demand_nm).into(),
            lambda: 0.0,
            sat_low: 0,
            sat_high: 0,
            unrealised: 0,
            iterations: 0,
            status: AllocStatus::Ok,
        }
    }
}

/// Result of every allocation method: the commands and their [`AllocOutcome`]
/// (read through `Deref`: `r.lambda` is `r.outcome.lambda`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AllocResult<const N: usize> {
    /// Actuator commands: thrust levels (units of the bounds), wheel torques (N m on
    /// the rotor), dipoles (A m²) or gimbal rates (rad/s).
    pub u: [f32; N],
    pub outcome: AllocOutcome,
}

impl<const N: usize> core::ops::Deref for AllocResult<N> {
    type Target = AllocOutcome;
    fn deref(&self) -> &AllocOutcome {
        &self.outcome
    }
}

impl<const N: usize> AllocResult<N> {
    /// Nothing commanded yet: zero commands, the whole demand as shortfall, status `Ok`.
    pub fn nothing_realised(demand_nm: &crate::math::Vec3) -> Self {
        Self { u: [0.0; N], outcome: AllocOutcome::nothing_realised(demand_nm) }
    }
}

#[cfg(test)]
mod fraction_tests {
    use super::AllocOutcome;
    use crate::math::Vec3;

    #[test]
    fn fraction_along_is_the_projection_limited_to_unit_and_never_panics() {
        let d = Vec3::new(2.0, 0.0, 0.0);
        // Projection 0.5 of the demand, plus a perpendicular part that does not count.
        assert_eq!(AllocOutcome::fraction_along(&Vec3::new(1.0, 3.0, 0.0), &d), 0.5);
        assert_eq!(AllocOutcome::fraction_along(&Vec3::new(5.0, 0.0, 0.0), &d), 1.0);
        assert_eq!(AllocOutcome::fraction_along(&Vec3::new(-1.0, 0.0, 0.0), &d), 0.0);
        assert_eq!(AllocOutcome::fraction_along(&Vec3::new(1.0, 0.0, 0.0), &Vec3::zeros()), 1.0);
        assert!(AllocOutcome::fraction_along(&Vec3::new(f32::NAN, 0.0, 0.0), &d).is_nan());
        // A NaN demand has no positive norm: treated as zero demand, no panic.
        assert_eq!(AllocOutcome::fraction_along(&Vec3::zeros(), &Vec3::new(f32::NAN, 0.0, 0.0)), 1.0);
    }
}
