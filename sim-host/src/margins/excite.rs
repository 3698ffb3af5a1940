//! Where the loop is broken and one experiment through it (docs/margins.md, "Where the
//! loop is broken", "Excitation"): the operating point and its steadiness, the actuator
//! family's effectiveness there, and one sine step — an excited run and its unexcited twin
//! flown in lockstep from the same operating point, whose differences are the loop's
//! response to the excitation alone (sensor noise, disturbances and the operating point's
//! own slow motion cancel), summed into block DFTs until two consecutive blocks agree. The
//! loop closed, or broken open at the input ([`Method`]: the plant gets the excitation
//! alone, the blocks are fitted by [`super::fit`]).

use super::MarginError;
use super::analysis::C64;
use super::fit::SineRampFit;
use super::grid::Freq;
use acs_flight::link::{ActuatorCommand, status};
use sim_core::attitude::{Quat, Vec3};
use sim_core::plant::wheel::Fidelity;
use sim_core::recorder::series::Discard;
use sim_core::simulation::probe::{LoopInjection, Probe};

pub use sim_core::scenario::LoopPoint;

/// How the loop is measured (docs/margins.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// The loop stays closed: the excitation is added to the flight's command, `E = U + D`.
    #[default]
    Closed,
    /// The loop broken open at the actuator input: the plant receives the excitation alone
    /// (the flight's command is computed, recorded and not applied), `E = D`; the twin's
    /// plant receives nothing. Measures an unstable closed loop too ("Open-loop measurement").
    Open,
}

/// `sim-host margins --method`: a [`Method`], or `auto` (closed; open if the closed-loop
/// experiment diverges or saturates), which is `MarginOptions::method` `None`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum MethodChoice {
    #[default]
    Auto,
    Closed,
    Open,
}

impl MethodChoice {
    /// The method asked for (`None`: chosen by the measurement).
    pub fn method(self) -> Option<Method> {
        match self {
            MethodChoice::Auto => None,
            MethodChoice::Closed => Some(Method::Closed),
            MethodChoice::Open => Some(Method::Open),
        }
    }
}

/// The actuator family whose commands carry the excitation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    Wheels,
    Cmg,
    /// Torque `m × B`: only perpendicular to the field, measured with the field frozen at
    /// the operating point (docs/margins.md, "Magnetorquer loops").
    Magnetorquers,
}

impl Family {
    /// The family whose commands a scenario's loop goes through (CMGs before wheels before
    /// magnetorquers, as the flight allocates); `None`: thrusters only, or no actuator.
    pub fn of(sim: &Probe) -> Option<Family> {
        let craft = sim.craft();
        if craft.cmg.is_some() {
            Some(Family::Cmg)
        } else if !craft.wheels.is_empty() {
            Some(Family::Wheels)
        } else if !sim.magnetorquers().rods.is_empty() {
            Some(Family::Magnetorquers)
        } else {
            None
        }
    }
}

/// The axes the loop is measured on: the body axes, or (magnetorquers) two axes
/// perpendicular to the field at the operating point and the field's direction, about which
/// no torque can be made (its row and column of `L` are zero, and it has no margins).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopAxes {
    /// Rows: the loop axes in body axes; `None`: the body axes themselves.
    pub body: Option<[[f64; 3]; 3]>,
    /// The leading axes that carry torque (3, or 2 for magnetorquers).
    pub actuated: usize,
}

impl Default for LoopAxes {
    fn default() -> Self {
        Self { body: None, actuated: 3 }
    }
}

impl LoopAxes {
    /// Perpendicular to the field `b` (body axes, non-zero): `e1` the body axis most
    /// perpendicular to `b`, projected off it; `e2 = b̂ × e1`; `e3 = b̂`.
    pub fn perpendicular_to(b: &Vec3) -> Self {
        let bh = b.normalize();
        let k = (0..3).min_by(|i, j| bh[*i].abs().total_cmp(&bh[*j].abs())).unwrap_or(0);
        let e1 = (Vec3::ith(k, 1.0) - bh * bh[k]).normalize();
        let e2 = bh.cross(&e1);
        Self { body: Some([e1.into(), e2.into(), bh.into()]), actuated: 2 }
    }

    /// The names of the actuated axes in reports.
    pub fn names(&self) -> &'static [&'static str] {
        if self.body.is_none() { &["x", "y", "z"] } else { &["perp1", "perp2"] }
    }

    /// Loop axis `j` in body axes.
    pub fn direction(&self, j: usize) -> [f64; 3] {
        match &self.body {
            Some(a) => a[j],
            None => std::array::from_fn(|i| if i == j { 1.0 } else { 0.0 }),
        }
    }

    /// A vector in loop axes, in body axes.
    pub fn to_body(&self, v: [f64; 3]) -> [f64; 3] {
        match &self.body {
            Some(a) => std::array::from_fn(|i| (0..3).map(|j| a[j][i] * v[j]).sum()),
            None => v,
        }
    }

    /// A body vector in loop axes.
    pub fn to_loop(&self, v: [f64; 3]) -> [f64; 3] {
        match &self.body {
            Some(a) => a.map(|e| e[0] * v[0] + e[1] * v[1] + e[2] * v[2]),
            None => v,
        }
    }

    /// `eᵀ J e` for each loop axis (the diagonal itself for the body axes).
    pub fn inertia_along(&self, j: &nalgebra::Matrix3<f64>) -> [f64; 3] {
        match &self.body {
            Some(a) => a.map(|e| {
                let e = Vec3::from(e);
                e.dot(&(j * e))
            }),
            None => [j[(0, 0)], j[(1, 1)], j[(2, 2)]],
        }
    }
}

/// The actuators' effectiveness at the operating point: body torque per unit command of
/// each channel (wheels: `−a_i` per N m of motor torque, the reaction on the body; CMGs:
/// `−∂h/∂δ_i` per rad/s of gimbal rate, the steering Jacobian at the operating point's
/// gimbal angles; magnetorquers: `a_i × B` per A m² of rod dipole, the field at the
/// operating point), and the commands that make a body torque `d` (`B⁺ d`, with
/// `B⁺ = Bᵀ (B Bᵀ)⁻¹`; magnetorquers: the rods' pseudo-inverse of the dipole
/// `B × d / |B|²`, which makes `d` exactly when `d ⊥ B`).
#[derive(Clone, Debug)]
pub struct Effectiveness {
    pub family: Family,
    /// Column i of B.
    pub columns: Vec<[f64; 3]>,
    /// Row i of B⁺.
    pub pinv_rows: Vec<[f64; 3]>,
    /// Each channel's limit (N m of motor torque, rad/s of gimbal rate, A m² of dipole).
    pub limits: Vec<f64>,
    pub axes: LoopAxes,
}

/// The unsupported-family refusal.
const NO_FAMILY: &str = "margins break the loop at the command of reaction wheels, CMGs or magnetorquers; this \
                         scenario has none (thruster loops are out of scope: docs/margins.md)";

impl Effectiveness {
    /// At the simulation's current state. Thruster loops are out of scope.
    pub fn at(sim: &Probe) -> Result<Self, MarginError> {
        let (craft, state) = (sim.craft(), sim.state());
        let family = Family::of(sim).ok_or_else(|| MarginError::Unsupported(NO_FAMILY.into()))?;
        let (columns, limits): (Vec<[f64; 3]>, Vec<f64>) = match family {
            Family::Cmg => {
                let c = craft.cmg.as_ref().ok_or_else(|| MarginError::Unsupported(NO_FAMILY.into()))?;
                let cols = (0..c.units.len()).map(|i| (-c.jacobian_column(i, state.gimbal_rad[i])).into()).collect();
                (cols, vec![c.max_rate_rad_s; c.units.len()])
            }
            Family::Wheels => (
                craft.wheels.iter().map(|w| w.spin_axis.map(|a| -a)).collect(),
                craft.wheels.iter().map(|w| w.max_torque_nm).collect(),
            ),
            Family::Magnetorquers => return Self::magnetorquers(sim),
        };
        let b = nalgebra::DMatrix::from_fn(3, columns.len(), |i, j| columns[j][i]);
        let pinv_rows = pseudo_inverse_rows(&b).ok_or_else(|| MarginError::NotSteady {
            t_s: f64::NAN,
            reason: "the actuators cannot make torque about every axis at the operating point (rank < 3)".into(),
        })?;
        Ok(Self { family, columns, pinv_rows, limits, axes: LoopAxes::default() })
    }

    /// Magnetorquers in the field at the operating point: rank 2, the loop measured on the
    /// two axes perpendicular to the field.
    fn magnetorquers(sim: &Probe) -> Result<Self, MarginError> {
        let not_steady = |reason: &str| MarginError::NotSteady { t_s: f64::NAN, reason: reason.into() };
        let b = sim.field_body_t().filter(|b| b.iter().all(|x| x.is_finite()) && b.norm() > 0.0);
        let b = b.ok_or_else(|| not_steady("no magnetic field at the operating point"))?;
        let rods = &sim.magnetorquers().rods;
        let columns: Vec<[f64; 3]> = rods.iter().map(|r| Vec3::from(r.axis).cross(&b).into()).collect();
        let a = nalgebra::DMatrix::from_fn(3, rods.len(), |i, j| rods[j].axis[i]);
        let rods_pinv = pseudo_inverse_rows(&a).ok_or_else(|| not_steady("the rods do not span three axes"))?;
        // Dipole B × d / |B|² = [B×] d / |B|², then the rods' share of it.
        let bx = b.cross_matrix() / b.norm_squared();
        let pinv_rows = rods_pinv.iter().map(|r| (nalgebra::RowVector3::from(*r) * bx).transpose().into()).collect();
        let limits = rods.iter().map(|r| r.max_pos_am2.min(r.max_neg_am2)).collect();
        Ok(Self { family: Family::Magnetorquers, columns, pinv_rows, limits, axes: LoopAxes::perpendicular_to(&b) })
    }

    /// The command of each channel, as the plant receives it (f64 of the flight's f32).
    fn channels(&self, cmd: &ActuatorCommand) -> Vec<f64> {
        let n = self.columns.len();
        let c: &[f32] = match self.family {
            Family::Wheels => &cmd.wheel_torque_cmd_nm,
            Family::Cmg => &cmd.gimbal_rate_cmd_rad_s,
            Family::Magnetorquers => &cmd.dipole_cmd_am2,
        };
        c.iter().take(n).map(|x| f64::from(*x)).collect()
    }

    /// `B (c_a − c_b)`: the body torque of the difference of two commands.
    pub fn torque_difference(&self, a: &ActuatorCommand, b: &ActuatorCommand) -> [f64; 3] {
        let (ca, cb) = (self.channels(a), self.channels(b));
        let mut t = [0.0; 3];
        for (k, col) in self.columns.iter().enumerate() {
            let dc = ca[k] - cb[k];
            for i in 0..3 {
                t[i] += col[i] * dc;
            }
        }
        t
    }

    /// `B⁺ d` on the channels: the injection that adds the body torque `d`.
    pub fn injection(&self, d: [f64; 3]) -> LoopInjection {
        let mut inj = LoopInjection::default();
        for (k, row) in self.pinv_rows.iter().enumerate() {
            let c = row[0] * d[0] + row[1] * d[1] + row[2] * d[2];
            match self.family {
                Family::Wheels => inj.wheel_torque_nm[k] = c,
                Family::Cmg => inj.gimbal_rate_rad_s[k] = c,
                Family::Magnetorquers => inj.dipole_am2[k] = c,
            }
        }
        inj
    }

    /// The largest torque about loop axis `axis` whose injection keeps every channel within
    /// 5 % of its limit.
    pub fn amplitude_cap(&self, axis: usize) -> f64 {
        let e = self.axes.direction(axis);
        self.pinv_rows
            .iter()
            .zip(&self.limits)
            .map(|(r, lim)| (r[0] * e[0] + r[1] * e[1] + r[2] * e[2], lim))
            .filter(|(c, _)| *c != 0.0)
            .map(|(c, lim)| 0.05 * lim / c.abs())
            .fold(f64::INFINITY, f64::min)
    }
}

/// Rows of `Bᵀ (B Bᵀ)⁻¹` of a 3×n `b` (`None`: rank < 3).
fn pseudo_inverse_rows(b: &nalgebra::DMatrix<f64>) -> Option<Vec<[f64; 3]>> {
    let n = b.ncols();
    let bbt = nalgebra::Matrix3::from_fn(|i, j| (0..n).map(|k| b[(i, k)] * b[(j, k)]).sum::<f64>());
    let inv = bbt.try_inverse().filter(|_| bbt.determinant().abs() > 1e-12 * bbt.norm().powi(3))?;
    Some((0..n).map(|k| std::array::from_fn(|j| (0..3).map(|i| b[(i, k)] * inv[(i, j)]).sum::<f64>())).collect())
}

/// Status bits that say the loop is not linear at this step (`RATE_SCALED`: the
/// allocation scaled its commands to the actuators' limits, named per family by
/// [`scaled_label`]).
const NONLINEAR: [(u16, &str); 10] = [
    (status::TORQUE_LIMITED, "torque limited"),
    (status::RATE_SCALED, "commands scaled"),
    (status::ANGLE_LIMITED, "gimbal angle limited"),
    (status::SINGULAR, "CMG near a singularity"),
    (status::BAD_INPUT, "input refused"),
    (status::TORQUE_SHORTFALL, "torque shortfall (saturated allocation)"),
    (status::ALLOC_FALLBACK, "allocation fallback"),
    (status::UNREALISED, "torque not realised"),
    (status::LAW_FAULT, "law fault"),
    (status::NO_ESTIMATE, "no attitude estimate"),
];

/// What the allocation's `RATE_SCALED` bit means for `family`: it scales the commands of
/// whichever actuators it allocates to their limits.
fn scaled_label(family: Option<Family>) -> &'static str {
    match family {
        Some(Family::Cmg) => "gimbal rates scaled",
        Some(Family::Wheels) => "wheel torques scaled to their limit",
        Some(Family::Magnetorquers) => "dipoles scaled to their limit",
        None => "commands scaled",
    }
}

/// The names of the nonlinear status bits a command of `family`'s loop carries, if any.
/// Magnetorquers: the torque along the field is never made (the allocation reports it as a
/// shortfall and a scaled command at every step: the loop's rank, not a saturation), so a
/// rod at its dipole limit (`saturated`) is what says the loop left its linear range.
pub fn nonlinear_status(cmd: &ActuatorCommand, family: Option<Family>) -> Option<String> {
    let expected = match family {
        Some(Family::Magnetorquers) => status::TORQUE_SHORTFALL | status::RATE_SCALED,
        _ => 0,
    };
    let mut set: Vec<&str> = NONLINEAR
        .iter()
        .filter(|(b, _)| cmd.status & b & !expected != 0)
        .map(|(b, n)| if *b == status::RATE_SCALED { scaled_label(family) } else { *n })
        .collect();
    if family == Some(Family::Magnetorquers) && cmd.saturated != 0 {
        set.push("magnetorquer at its dipole limit");
    }
    (!set.is_empty()).then(|| set.join(", "))
}

/// Relative margin over a limit before a command counts as beyond it: the f32 rounding of a
/// flight command the allocation scaled to the limit itself (2⁻²⁴ ≈ 6e-8 relative).
const F32_LIMIT_TOLERANCE: f64 = 1e-6;

/// Fraction of its speed limit beyond which a wheel is not linear (the ideal model's torque
/// fades over the last 1 %, the accurate model's speed limiter acts near it).
const WHEEL_SPEED_FRACTION: f64 = 0.95;

/// A wheel within 5 % of its speed limit, if any.
fn wheel_speed_limit(sim: &Probe) -> Option<String> {
    let (craft, s) = (sim.craft(), sim.state());
    craft.wheels.iter().zip(s.wheels.iter()).enumerate().find_map(|(i, (p, ws))| {
        let w = ws.h_abs_nms / p.inertia_kgm2 - Vec3::from(p.spin_axis).dot(&s.w);
        (w.abs() > WHEEL_SPEED_FRACTION * p.max_speed_rad_s)
            .then(|| format!("wheel {} at {:.0} % of its speed limit", i + 1, 100.0 * w.abs() / p.max_speed_rad_s))
    })
}

/// A wheel that makes the loop nonlinear at the operating point, if any: within 5 % of its
/// speed limit, or inside its Coulomb-friction band (relative speed below three times the
/// friction model's sign-smoothing speed: stiction, where the friction torque flips with
/// the sign of the speed).
fn wheel_nonlinear(sim: &Probe) -> Option<String> {
    if let Some(r) = wheel_speed_limit(sim) {
        return Some(r);
    }
    let (craft, s) = (sim.craft(), sim.state());
    craft.wheels.iter().zip(s.wheels.iter()).enumerate().find_map(|(i, (p, ws))| {
        let w = ws.h_abs_nms / p.inertia_kgm2 - Vec3::from(p.spin_axis).dot(&s.w);
        (p.fidelity == Fidelity::Accurate && p.coulomb_nm > 0.0 && w.abs() < 3.0 * p.sign_smoothing_rad_s).then(|| {
            format!(
                "wheel {} at {w:.2e} rad/s, inside its Coulomb-friction band (±{:.2e} rad/s): the friction torque \
                 ({} N m) is not linear there (stiction); choose an --at where the wheels spin",
                i + 1,
                3.0 * p.sign_smoothing_rad_s,
                p.coulomb_nm
            )
        })
    })
}

/// The loop's actuators at a limit on the plant side at the last step, if any: the commands
/// the plant received (the flight's, with the excitation added) beyond a wheel's motor-torque
/// limit, a gimbal's rate limit or a rod's dipole limit, a non-zero rod command inside its
/// dead band, a gimbal at an angle stop, and any wheel within 5 % of its speed limit. The
/// flight's status bits see only its own command, and within the limits it was given.
pub fn actuator_limit(sim: &Probe, family: Option<Family>) -> Option<String> {
    let (craft, c) = (sim.craft(), sim.plant_commands());
    let beyond = |what: &str, i: usize, x: f64, unit: &str, lim: f64| {
        format!("{what} {} command {x:.4e} {unit} beyond its {lim:.4e} {unit} limit", i + 1)
    };
    // A flight command scaled to exactly its limit reads back from f32 a few ulps over it.
    let over = |x: f64, lim: f64| x.abs() > lim * (1.0 + F32_LIMIT_TOLERANCE);
    let found = match family {
        Some(Family::Wheels) => craft.wheels.iter().zip(c.wheel_torque_nm).enumerate().find_map(|(i, (p, x))| {
            let lim = match p.fidelity {
                Fidelity::Ideal => p.max_torque_nm,
                Fidelity::Accurate => p.max_torque_nm.min(p.max_current_a * p.torque_constant_nm_per_a),
            };
            over(x, lim).then(|| beyond("wheel", i, x, "N m", lim))
        }),
        Some(Family::Cmg) => craft.cmg.as_ref().and_then(|g| {
            let delta = &sim.state().gimbal_rad;
            g.units.iter().enumerate().find_map(|(i, _)| {
                let x = c.gimbal_rate_rad_s[i];
                let stop = g.angle_limits_rad.is_some_and(|(lo, hi)| delta[i] <= lo || delta[i] >= hi);
                if over(x, g.max_rate_rad_s) {
                    Some(beyond("gimbal", i, x, "rad/s", g.max_rate_rad_s))
                } else {
                    stop.then(|| format!("gimbal {} at its angle stop", i + 1))
                }
            })
        }),
        Some(Family::Magnetorquers) => {
            sim.magnetorquers().rods.iter().zip(c.dipole_am2).enumerate().find_map(|(i, (r, x))| {
                if over(x.max(0.0), r.max_pos_am2) || over(x.min(0.0), r.max_neg_am2) {
                    Some(format!("magnetorquer {} at its dipole limit (command {x:.4e} A m^2)", i + 1))
                } else {
                    (x != 0.0 && x > r.deadband_lo_am2 && x < r.deadband_hi_am2).then(|| {
                        format!(
                            "magnetorquer {} command {x:.4e} A m^2 inside its dead band: torque not realised",
                            i + 1
                        )
                    })
                }
            })
        }
        None => None,
    };
    found.or_else(|| wheel_speed_limit(sim))
}

/// Flies `sim` from where it is to control step `k_op` (the operating point): every step
/// from `check_from` on must be free of saturation flags and of actuators at a limit
/// ([`actuator_limit`]), and at the end the attitude error must be within
/// `settle_bound_deg` (at `k_op = 0`, that of the initial state) and no wheel near its
/// speed limit or in stiction.
pub fn fly_to(sim: &mut Probe, k_op: u64, check_from: u64, settle_bound_deg: f64) -> Result<(), MarginError> {
    sim.extend_to(u64::MAX / 4);
    let family = Family::of(sim);
    let dt = sim.control_period_s();
    while sim.steps_done() < k_op {
        sim.step(&mut Discard).map_err(MarginError::flight)?;
        let t = (sim.steps_done() - 1) as f64 * dt;
        if let Some(f) = sim.failure() {
            return Err(MarginError::Unstable {
                reason: format!("the flight diverged before the operating point: {f:?}"),
            });
        }
        if sim.steps_done() > check_from
            && let Some(reason) =
                sim.last_step().and_then(|(c, _)| nonlinear_status(c, family)).or_else(|| actuator_limit(sim, family))
        {
            return Err(MarginError::NotSteady { t_s: t, reason });
        }
    }
    let t = k_op as f64 * dt;
    let err = sim.last_step().map_or_else(|| sim.attitude_error_now_deg(), |(_, e)| *e);
    if !(err <= settle_bound_deg) {
        let reason =
            format!("attitude error {err:.4} deg above the settle bound {settle_bound_deg} deg: not a settled hold");
        return Err(MarginError::NotSteady { t_s: t, reason });
    }
    wheel_nonlinear(sim).map_or(Ok(()), |reason| Err(MarginError::NotSteady { t_s: t, reason }))
}

/// A magnetic law at an orbit instant: the field frozen from the operating point on
/// (docs/margins.md, "Magnetorquer loops"), so the loop is time-invariant over the
/// experiments; nothing for the other families.
pub fn freeze_field(sim: &mut Probe) -> Result<(), MarginError> {
    if Family::of(sim) == Some(Family::Magnetorquers) && sim.freeze_field().is_none() {
        return Err(MarginError::NotSteady { t_s: sim.sim_time_s(), reason: "no magnetic field to freeze".into() });
    }
    Ok(())
}

/// One sine step: frequency, excited axis, amplitude (N m at the input, rad at the
/// output), the steps to wait before measuring, the block length (a multiple of the
/// frequency's `n`) and the most blocks to measure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Experiment {
    pub freq: Freq,
    pub axis: usize,
    pub amplitude: f64,
    pub wait_steps: u64,
    pub block_steps: u64,
    pub max_blocks: u32,
}

/// What one experiment measured: the DFT at its frequency of the loop's output `U` (the
/// commanded body torque, or the true attitude) and of the total input `E = U + D` (open
/// loop: `E = D`, both from the sine-on-a-ramp fit), each a 3-vector (a column of the 3×3
/// response), over the last block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Column {
    pub u: [C64; 3],
    pub e: [C64; 3],
    pub blocks: u32,
    pub converged: bool,
    /// Largest true attitude difference between the excited run and its twin, rad.
    pub peak_attitude_rad: f64,
}

/// The excitation's envelope: a raised-cosine ramp from 0 to 1 over the first `ramp`
/// steps, then 1. With the cosine wave (no mean rate impulse into a double integrator),
/// it keeps the onset transient small, so the wait before measuring is mostly spent on
/// what little there is.
fn onset(k: u64, ramp: u64) -> f64 {
    if k >= ramp { 1.0 } else { 0.5 * (1.0 - (std::f64::consts::PI * k as f64 / ramp as f64).cos()) }
}

/// The rotation vector (body axes, rad) from `a` to `b`: `2 vec(a* ⊗ b)`, shortest way.
fn rotation_between(a: &Quat, b: &Quat) -> [f64; 3] {
    let d = a.conjugate() * b;
    let s = if d.w < 0.0 { -2.0 } else { 2.0 };
    [s * d.i, s * d.j, s * d.k]
}

/// A block's DFTs of the loop output and the total input.
struct Block {
    u: [C64; 3],
    e: [C64; 3],
}

fn norm3(v: &[C64; 3]) -> f64 {
    v.iter().map(|z| z.norm_sqr()).sum::<f64>().sqrt()
}

/// The excitation about the experiment's axis at step `k` (N m at the input, rad at the
/// output). Closed loop: `a cos(ω t_k)` under the raised-cosine onset. Open loop: the same
/// wave at once, its first sample halved, because held over `[t_k, t_k + T)` it then
/// integrates to a zero-mean rate: `Σ_{k<N} cos(kωT) − ½ = sin((N − ½)ωT) / (2 sin(ωT/2))`,
/// so the free double integrator gets no ramp from the onset, only a constant attitude
/// offset (docs/margins.md, "Open-loop measurement"; the same as starting the
/// half-sample-shifted wave `cos(ω(k + ½)T)`, which would vanish at the Nyquist frequency).
fn excitation(x: &Experiment, k: u64, method: Method) -> [f64; 3] {
    let envelope = match method {
        Method::Closed => onset(k, x.wait_steps / 2),
        Method::Open if k == 0 => 0.5,
        Method::Open => 1.0,
    };
    let mut d = [0.0; 3];
    d[x.axis] = x.amplitude * envelope * x.freq.phase(k).cos();
    d
}

/// A block's estimate of the loop output's and the total input's sinusoids: the DFT over
/// the block (closed loop: blind to a constant), or the sine-on-a-ramp fit (open loop).
enum Estimator {
    Dft { acc: Block, len: u64, pushed: u64 },
    Fit(Box<SineRampFit<6>>),
}

impl Estimator {
    fn new(method: Method, len: u64) -> Self {
        match method {
            Method::Closed => {
                Estimator::Dft { acc: Block { u: [C64::default(); 3], e: [C64::default(); 3] }, len, pushed: 0 }
            }
            Method::Open => Estimator::Fit(Box::new(SineRampFit::new(len))),
        }
    }

    /// Adds step k: phase `ω t_k`, loop output `u`, excitation `d`.
    fn push(&mut self, phase: f64, u: &[f64; 3], d: &[f64; 3]) {
        match self {
            Estimator::Dft { acc, pushed, .. } => {
                let w = C64::from_polar(1.0, -phase);
                for i in 0..3 {
                    acc.u[i] += w * u[i];
                    acc.e[i] += w * (u[i] + d[i]);
                }
                *pushed += 1;
            }
            Estimator::Fit(f) => f.push(phase, &[u[0], u[1], u[2], d[0], d[1], d[2]]),
        }
    }

    /// The block, once complete (the estimator restarts for the next one).
    fn take(&mut self) -> Option<Result<Block, MarginError>> {
        let done = match self {
            Estimator::Dft { acc, len, pushed } if *pushed >= *len => {
                let n = *len as f64;
                Ok(Block { u: acc.u.map(|z| z / n), e: acc.e.map(|z| z / n) })
            }
            Estimator::Fit(f) if f.is_full() => {
                f.solve().map(|z| Block { u: [z[0], z[1], z[2]], e: [z[3], z[4], z[5]] }).ok_or_else(|| {
                    MarginError::Unstable { reason: "the open-loop fit is singular (block too short)".into() }
                })
            }
            _ => return None,
        };
        *self = match self {
            Estimator::Dft { len, .. } => Estimator::new(Method::Closed, *len),
            Estimator::Fit(f) => Estimator::new(Method::Open, f.block_len()),
        };
        Some(done)
    }
}

/// The injection of the excitation `d` at `point` (open loop: replacing the command).
fn injection(point: LoopPoint, eff: Option<&Effectiveness>, d: [f64; 3], method: Method) -> LoopInjection {
    let mut inj = match (point, eff) {
        (LoopPoint::Input, Some(eff)) => eff.injection(d),
        _ => LoopInjection { attitude_rad: d, ..LoopInjection::default() },
    };
    inj.replace_commands = method == Method::Open;
    inj
}

/// Runs experiment `x` on `exc` and its twin `twin` (both at the same operating point),
/// the loop closed or broken open (`method`, input loop only).
pub fn run(
    exc: &mut Probe,
    twin: &mut Probe,
    point: LoopPoint,
    eff: Option<&Effectiveness>,
    method: Method,
    x: &Experiment,
) -> Result<Column, MarginError> {
    let dt = exc.control_period_s();
    let t0 = exc.steps_done() as f64 * dt;
    // Excitation and response in the loop's axes (the body axes but for magnetorquers).
    let axes = eff.map(|e| e.axes).unwrap_or_default();
    if method == Method::Open {
        twin.set_injection(Some(injection(point, eff, [0.0; 3], method)));
    }
    let mut est = Estimator::new(method, x.block_steps);
    let mut blocks: Vec<f64> = Vec::new();
    let mut last: Option<Block> = None;
    let mut peak: f64 = 0.0;
    let mut converged = x.max_blocks == 1;
    let total = x.wait_steps + u64::from(x.max_blocks) * x.block_steps;
    for k in 0..total {
        let d = excitation(x, k, method);
        let y = rotation_between(&twin.state().q, &exc.state().q);
        peak = peak.max(Vec3::from(y).norm());
        exc.set_injection(Some(injection(point, eff, axes.to_body(d), method)));
        exc.step(&mut Discard).map_err(MarginError::flight)?;
        twin.step(&mut Discard).map_err(MarginError::flight)?;
        let t = t0 + k as f64 * dt;
        let (ce, ct) = check_step(exc, twin, t, eff.map(|e| e.family))?;
        let du = match (point, eff) {
            (LoopPoint::Input, Some(eff)) => axes.to_loop(eff.torque_difference(&ce, &ct)),
            _ => y,
        };
        if !du.iter().all(|v| v.is_finite() && v.abs() < 1e6 * x.amplitude) {
            return Err(MarginError::Unstable {
                reason: format!("the response to the excitation diverges at t = {t:.3} s"),
            });
        }
        if k < x.wait_steps {
            continue;
        }
        est.push(x.freq.phase(k), &du, &d);
        let Some(b) = est.take().transpose()? else { continue };
        blocks.push(norm3(&b.u));
        grows(&blocks, x.amplitude, t)?;
        let settled = last.as_ref().is_some_and(|p| {
            let diff: [C64; 3] = std::array::from_fn(|i| b.u[i] - p.u[i]);
            norm3(&diff) <= SETTLED_RELATIVE * norm3(&b.u) + SETTLED_FLOOR * x.amplitude
        });
        last = Some(b);
        if settled {
            converged = true;
            break;
        }
    }
    exc.set_injection(None);
    twin.set_injection(None);
    let b = last.ok_or_else(|| MarginError::Unstable { reason: "no block measured".into() })?;
    Ok(Column { u: b.u, e: b.e, blocks: blocks.len() as u32, converged, peak_attitude_rad: peak })
}

/// Two consecutive blocks agree when their loop-output DFTs differ by less than this part
/// of the last one, plus this part of the excitation amplitude (the floor keeps f32
/// round-off in a loop output far below the excitation, `|L| ≪ 1`, from holding an
/// experiment open).
const SETTLED_RELATIVE: f64 = 2e-3;
const SETTLED_FLOOR: f64 = 1e-5;

/// The response grows block after block (three in a row, each over twice the last).
fn grows(blocks: &[f64], amplitude: f64, t: f64) -> Result<(), MarginError> {
    // A stable loop answers with |U| = |T D| of the order of the excitation: growth far
    // beyond it, block after block, is divergence (below that: a slow transient).
    if let [.., a, b, c] = blocks
        && *b > 2.0 * a
        && *c > 2.0 * b
        && *c > 100.0 * amplitude
    {
        return Err(MarginError::Unstable {
            reason: format!("the response to the excitation grows without bound (t = {t:.3} s)"),
        });
    }
    Ok(())
}

/// Both runs still finite; the twin free of saturation and of actuators at a limit
/// ([`actuator_limit`]: else the operating point is not a steady hold), the excited run too
/// (else the excitation is too large to stay linear).
fn check_step(
    exc: &Probe,
    twin: &Probe,
    t: f64,
    family: Option<Family>,
) -> Result<(ActuatorCommand, ActuatorCommand), MarginError> {
    if let Some(f) = [exc.failure(), twin.failure()].into_iter().flatten().next() {
        return Err(MarginError::Unstable { reason: format!("the flight diverged during an experiment: {f:?}") });
    }
    let (Some((ce, _)), Some((ct, _))) = (exc.last_step(), twin.last_step()) else {
        return Err(MarginError::Unstable { reason: format!("no flight command at t = {t:.3} s") });
    };
    if let Some(r) = nonlinear_status(ct, family).or_else(|| actuator_limit(twin, family)) {
        return Err(MarginError::NotSteady {
            t_s: t,
            reason: format!("the operating point does not stay a steady hold: {r}"),
        });
    }
    if let Some(r) = nonlinear_status(ce, family).or_else(|| actuator_limit(exc, family)) {
        return Err(MarginError::NotSteady {
            t_s: t,
            reason: format!("{EXCITATION_NONLINEAR} ({r}): lower --amplitude-rad"),
        });
    }
    Ok((*ce, *ct))
}

/// The start of the reason of an excited run that leaves the linear range while its twin
/// holds (a closed loop that amplifies the excitation, or too large an excitation).
const EXCITATION_NONLINEAR: &str = "the excitation drives the loop out of its linear range";

/// The closed-loop experiment failed in a way the open-loop one can measure through: the
/// excited run diverged, grew or saturated while the operating point held.
pub fn closed_loop_diverged(e: &MarginError) -> bool {
    match e {
        MarginError::Unstable { .. } => true,
        MarginError::NotSteady { reason, .. } => reason.starts_with(EXCITATION_NONLINEAR),
        _ => false,
    }
}
