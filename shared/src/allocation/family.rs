//! One interface for every actuator family: [`ActuatorFamily`], implemented by
//! [`Actuators`] (an enum of the configured family, no `dyn`, no heap). Every family
//! returns one [`Allocation`]: the family's commands in full, the torque they realise,
//! saturation and status. CMG steering is one family like the others.

use super::cmg::{GimbalLimits, limit_rates, steer};
use super::effectiveness::cmg::{CmgPyramid, GimbalTrig};
use super::effectiveness::wheels::stored_momentum_nms;
use super::thruster::{Allocator, Bounds, Failures, Pwpf, PwpfParams};
use super::{AllocOutcome, AllocResult, AllocStatus, magnetorquers, wheels};
use crate::math::Vec3;
use crate::params::{
    ActuatorParams, MAX_THRUSTERS, MagnetorquerParams, ParamError, ParamField, ParamReason, SteeringParams,
    ThrusterMethod, ThrusterParams, WheelParams,
};
use crate::types::{Demand, MAX_WHEELS, Measurements, Setpoint, Status, Valid};

/// Thruster allocator at the configured capacity (`N + 1` LP columns: thrusters and λ).
pub type ThrusterAllocator = Allocator<MAX_THRUSTERS, { MAX_THRUSTERS + 1 }>;

// The thruster on/off mask is a `u16` on the wire: one bit per thruster.
const _: () = assert!(MAX_THRUSTERS <= u16::BITS as usize);
// Saturation and unrealised masks are `u32`: one bit per actuator of any family.
const _: () = assert!(MAX_THRUSTERS <= u32::BITS as usize);
const _: () = assert!(MAX_WHEELS <= u32::BITS as usize);

/// The commands of one family (all of them: nothing is narrowed away).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Commands {
    Cmg {
        gimbal_rate_rad_s: [f32; 4],
        /// `det(J₁ J₁ᵀ)`.
        singularity_measure: f32,
        /// SR weight α (0 for Moore-Penrose and for direct rate commands).
        alpha: f32,
    },
    Wheels {
        torque_nm: [f32; MAX_WHEELS],
    },
    Magnetorquers {
        dipole_am2: [f32; 3],
    },
    Thrusters {
        /// Allocated level in [0, 1] per thruster (the PWPF input).
        level: [f32; MAX_THRUSTERS],
        /// Bit i: thruster i open during the next control period.
        on: u16,
    },
}

/// What an allocation produced, for every family: the commands, the demand and the
/// [`AllocOutcome`] (read through `Deref`: `a.lambda` is `a.outcome.lambda`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Allocation {
    pub commands: Commands,
    /// The torque the allocation was asked for, N m (for direct gimbal-rate commands:
    /// what those rates do).
    pub demand_nm: Vec3,
    pub outcome: AllocOutcome,
    /// Status bits the family reports itself (CMG: rate scaling, angle limits,
    /// singularities).
    pub flags: Status,
}

impl core::ops::Deref for Allocation {
    type Target = AllocOutcome;
    fn deref(&self) -> &AllocOutcome {
        &self.outcome
    }
}

impl Allocation {
    fn from_result<const N: usize>(commands: Commands, demand_nm: &Vec3, r: &AllocResult<N>) -> Self {
        Self { commands, demand_nm: *demand_nm, outcome: r.outcome, flags: Status::empty() }
    }
}

/// Actuator momentum and per-step geometry, computed once per step from the
/// measurements (the laws use the momentum; the CMG steering reuses the trig).
#[derive(Clone, Copy, Debug)]
pub struct ActuatorState {
    /// Actuator momentum in body axes (gyroscopic terms), N m s.
    pub momentum_nms: Vec3,
    gimbal_trig: Option<GimbalTrig>,
}

/// An actuator family: from a demand to commands.
pub trait ActuatorFamily {
    /// Momentum and geometry for this step.
    fn observe(&self, m: &Measurements) -> ActuatorState;
    /// Allocate `demand` (the torque or, for CMGs, direct gimbal rates).
    fn allocate(
        &mut self,
        demand: &Demand,
        m: &Measurements,
        state: &ActuatorState,
        sp: &Setpoint,
        dt_s: f32,
    ) -> Allocation;
}

/// The CMG pyramid with its limits and steering law.
#[derive(Clone, Copy, Debug)]
pub struct CmgCluster {
    pub pyramid: CmgPyramid,
    pub limits: GimbalLimits,
    pub steering: SteeringParams,
}

/// Thrusters: LP allocator, bounds, method and PWPF modulator.
#[derive(Clone, Debug)]
pub struct ThrusterSet {
    pub alloc: ThrusterAllocator,
    pub bounds: Bounds<MAX_THRUSTERS>,
    pub method: ThrusterMethod,
    pub pwpf: Pwpf<MAX_THRUSTERS>,
}

/// The configured actuator family.
#[derive(Clone, Debug)]
pub enum Actuators {
    Cmg(CmgCluster),
    Wheels(WheelParams),
    Magnetorquers(MagnetorquerParams),
    Thrusters(ThrusterSet),
}

impl Actuators {
    /// The family of a validated parameter set (`dt_s`: control period, for PWPF).
    // Not inlined into `Configured::build`: its temporaries would sum into the build's
    // frame on the firmware's deepest stack chain (docs/firmware.md "Stack").
    #[inline(never)]
    pub fn from_params(p: &ActuatorParams, dt_s: f32) -> Result<Self, ParamError> {
        Ok(match p {
            ActuatorParams::Cmg { cmg, steering } => Self::Cmg(CmgCluster {
                pyramid: CmgPyramid::new(cmg.skew_rad, cmg.h0_nms),
                limits: GimbalLimits::from(cmg),
                steering: *steering,
            }),
            ActuatorParams::Wheels(w) => Self::Wheels(*w),
            ActuatorParams::Magnetorquers(mt) => Self::Magnetorquers(*mt),
            ActuatorParams::Thrusters(t) => Self::Thrusters(ThrusterSet::new(t, dt_s)?),
        })
    }

    /// Validity bits the family's measurements need.
    pub fn required(&self) -> Valid {
        match self {
            Self::Cmg(_) => Valid::GIMBALS,
            Self::Wheels(_) => Valid::WHEELS,
            Self::Magnetorquers(_) => Valid::MAG,
            Self::Thrusters(_) => Valid::empty(),
        }
    }

    /// The CMG steering parameters, if this is a CMG cluster (guidance's dither clock).
    pub fn steering(&self) -> Option<&SteeringParams> {
        match self {
            Self::Cmg(c) => Some(&c.steering),
            _ => None,
        }
    }
}

impl ActuatorFamily for Actuators {
    fn observe(&self, m: &Measurements) -> ActuatorState {
        match self {
            Self::Cmg(c) => c.observe(m),
            Self::Wheels(w) => {
                let h = stored_momentum_nms(w, &m.wheel_speed_rad_s);
                ActuatorState { momentum_nms: h, gimbal_trig: None }
            }
            Self::Magnetorquers(_) | Self::Thrusters(_) => {
                ActuatorState { momentum_nms: Vec3::zeros(), gimbal_trig: None }
            }
        }
    }

    fn allocate(
        &mut self,
        demand: &Demand,
        m: &Measurements,
        state: &ActuatorState,
        sp: &Setpoint,
        dt_s: f32,
    ) -> Allocation {
        let u = demand.torque_nm();
        match self {
            Self::Cmg(c) => c.allocate(demand, m, state, sp, dt_s),
            Self::Wheels(w) => {
                let r = wheels::allocate(w, &m.wheel_speed_rad_s, &u);
                Allocation::from_result(Commands::Wheels { torque_nm: r.u }, &u, &r)
            }
            Self::Magnetorquers(mt) => {
                let r = magnetorquers::allocate(mt, &m.mag_field_t, &u);
                Allocation::from_result(Commands::Magnetorquers { dipole_am2: r.u }, &u, &r)
            }
            Self::Thrusters(t) => t.allocate(&u),
        }
    }
}

impl ActuatorFamily for CmgCluster {
    fn observe(&self, m: &Measurements) -> ActuatorState {
        let t = GimbalTrig::new(&m.gimbal_angle_rad);
        ActuatorState { momentum_nms: self.pyramid.momentum(&t), gimbal_trig: Some(t) }
    }

    fn allocate(
        &mut self,
        demand: &Demand,
        m: &Measurements,
        state: &ActuatorState,
        sp: &Setpoint,
        dt_s: f32,
    ) -> Allocation {
        let t = state.gimbal_trig.unwrap_or_else(|| GimbalTrig::new(&m.gimbal_angle_rad));
        let (p, l) = (&self.pyramid, &self.limits);
        match demand {
            Demand::GimbalRates(rates) => {
                let mut r = *rates;
                for (i, x) in r.iter_mut().enumerate() {
                    if l.failed_mask & (1 << i) != 0 {
                        *x = 0.0;
                    }
                }
                let flags = limit_rates(&mut r, &m.gimbal_angle_rad, l, dt_s);
                let realised = p.torque_on_body(&t, &m.rate_rad_s, &r);
                let j1 = p.unit_jacobian(&t);
                let singularity_measure = (j1 * j1.transpose()).determinant();
                let cmd = Commands::Cmg { gimbal_rate_rad_s: r, singularity_measure, alpha: 0.0 };
                // The law's demand is what its rates do.
                cmg_allocation(cmd, &realised, &realised, flags)
            }
            Demand::Torque(u) => {
                let out =
                    steer(p, &self.steering, l, &t, &m.gimbal_angle_rad, &m.rate_rad_s, u, dt_s, sp.dither_time_s);
                let realised = p.torque_on_body(&t, &m.rate_rad_s, &out.gimbal_rate_rad_s);
                let cmd = Commands::Cmg {
                    gimbal_rate_rad_s: out.gimbal_rate_rad_s,
                    singularity_measure: out.singularity_measure,
                    alpha: out.alpha,
                };
                cmg_allocation(cmd, &realised, u, out.status)
            }
        }
    }
}

/// The CMG steering reports its own status bits (RATE_SCALED, SINGULAR, …): the
/// allocation status proper is `Ok`.
fn cmg_allocation(commands: Commands, realised: &Vec3, demand: &Vec3, flags: Status) -> Allocation {
    let short = demand - realised;
    let outcome = AllocOutcome {
        realised: (*realised).into(),
        shortfall: short.into(),
        lambda: AllocOutcome::fraction_along(realised, demand),
        sat_low: 0,
        sat_high: 0,
        unrealised: 0,
        iterations: 1,
        status: AllocStatus::Ok,
    };
    Allocation { commands, demand_nm: *demand, outcome, flags }
}

impl ThrusterSet {
    pub fn new(t: &ThrusterParams, dt_s: f32) -> Result<Self, ParamError> {
        let bad = |field| ParamError { field, reason: ParamReason::OutOfRange };
        let n = usize::from(t.count).min(MAX_THRUSTERS);
        let mut u_max = [0.0f32; MAX_THRUSTERS];
        for x in u_max.iter_mut().take(n) {
            *x = 1.0;
        }
        let alloc = ThrusterAllocator::new(t.torque_nm, [0.0; MAX_THRUSTERS], u_max);
        let failures = Failures { failed: u32::from(t.failed_mask), stuck_on: 0 };
        let bounds = alloc.bounds(None, failures);
        let pp = PwpfParams { km: t.pwpf_km, tm: t.pwpf_tm_s, u_on: t.pwpf_u_on, u_off: t.pwpf_u_off, u_m: 1.0 };
        let pwpf = Pwpf::new(pp, dt_s).ok_or(bad(ParamField::Pwpf))?;
        Ok(Self { alloc, bounds, method: t.method, pwpf })
    }

    /// Body torque of the thrusters open in `on` (bit i: thruster i) at full thrust, N m:
    /// what the plant receives over the next period (valve delays aside).
    pub fn pulse_torque_nm(&self, on: u16) -> Vec3 {
        let b = self.alloc.b();
        let mut t = Vec3::zeros();
        for j in 0..MAX_THRUSTERS {
            if u32::from(on) & super::thruster::lp::bit_of(j) != 0 {
                for (tk, row) in t.iter_mut().zip(b.iter()) {
                    *tk += row.get(j).copied().unwrap_or(0.0);
                }
            }
        }
        t
    }

    /// Allocate the torque `u` (LP), then modulate (PWPF).
    pub fn allocate(&mut self, u: &Vec3) -> Allocation {
        let d: [f32; 3] = (*u).into();
        let r = match self.method {
            ThrusterMethod::DirectionPreserving => self.alloc.direction_preserving(&d, &self.bounds),
            ThrusterMethod::Bodson => self.alloc.bodson(&d, &self.bounds),
        };
        // Cannot fail: the PWPF mask has one bit per thruster and MAX_THRUSTERS <= 16
        // (asserted above). Documented fallback anyway: all valves closed.
        let on = u16::try_from(self.pwpf.step(&r.u)).unwrap_or(0);
        Allocation::from_result(Commands::Thrusters { level: r.u, on }, u, &r)
    }
}
