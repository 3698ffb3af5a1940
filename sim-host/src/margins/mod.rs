//! `sim-host margins`: stability margins of the real flight loop, measured through the
//! flight step (docs/margins.md). The scenario is flown to an operating point, the loop
//! is broken at the actuator command (or the attitude measurement), sine steps measure
//! the 3×3 open-loop response up to the control Nyquist frequency, and the margins are
//! computed from it:
//! - [`excite`]: where the loop is broken, the operating point, one experiment;
//! - [`fit`]: the open-loop method's sine-on-a-ramp fit;
//! - [`grid`]: the leakage-free frequencies, the grid and its refinement;
//! - [`response`]: the experiments on worker threads, the response `L = −U E⁻¹`;
//! - [`freeze`]: adaptive laws (DMCS) measured at a frozen adaptation state;
//! - [`analysis`]: margins from a response (pure functions);
//! - [`report`]: `margins.json` and the console table;
//! - [`plots`]: `bode.png`, `nyquist.png`, `disk.png`;
//! - [`summary`]: `[margins]` in runs and campaigns, `summary.json` `margins`.

pub mod analysis;
pub mod excite;
pub mod fit;
pub mod freeze;
pub mod grid;
pub mod plots;
pub mod report;
pub mod response;
pub mod summary;

pub use excite::{LoopPoint, Method, MethodChoice};
pub use report::MarginReport;

use analysis::{C64, Cmat};
use excite::{Effectiveness, Experiment, Family, LoopAxes};
use grid::Freq;
use response::{Pool, Response, Setup};
use sim_core::environment::model::FrozenField;
use sim_core::link::{LinkKind, LinkOptions};
use sim_core::scenario::{OptionRefused, Resolved, Scenario, margin_check as check};
use std::time::Instant;

/// Why no margin could be measured.
#[derive(Clone, Debug, PartialEq)]
pub enum MarginError {
    /// The scenario could not be resolved or flown (the message says why).
    Flight(String),
    /// The scenario's loop is of a kind this measurement does not cover.
    Unsupported(String),
    /// The operating point is not a steady hold (saturation, a limit, an unsettled error).
    NotSteady { t_s: f64, reason: String },
    /// The loop is unstable at the operating point (divergent response).
    Unstable { reason: String },
    /// The sweep would cost more plant steps than `MarginOptions::max_plant_steps` allows.
    OverBudget(OverBudget),
    /// An option outside its range ([`MarginOptions::check`]), or a crossover hint that
    /// put the whole grid above the loop's crossover: named as its flag.
    Refused(OptionRefused),
}

/// A measurement refused over its plant-step budget: what it had charged, and the batch
/// that crossed the budget.
#[derive(Clone, Debug, PartialEq)]
pub struct OverBudget {
    pub spent_steps: u64,
    pub budget_steps: u64,
    /// The lowest frequency of the batch that crossed the budget, rad/s (it dominates the
    /// cost: the longest period).
    pub next_frequency_rad_s: f64,
    pub substeps: u64,
    /// Said after the message (the open-loop fallback's cause).
    pub context: String,
}

impl OverBudget {
    /// What makes the batch costly: its lowest frequency, period and the RK4 substeps.
    pub fn cost(&self) -> String {
        format!(
            "next frequency {:.3e} rad/s: a {:.0} s period, {} RK4 substeps per control step",
            self.next_frequency_rad_s,
            std::f64::consts::TAU / self.next_frequency_rad_s,
            self.substeps
        )
    }
}

impl MarginError {
    pub(crate) fn flight(e: anyhow::Error) -> Self {
        MarginError::Flight(format!("{e:#}"))
    }

    /// The command's exit status for this error: 1 flight/scenario error, 2 unsupported,
    /// over budget or an option refused (as the command line refuses a flag), 3 not a
    /// steady hold or unstable.
    pub fn exit_code(&self) -> i32 {
        match self {
            MarginError::Flight(_) => 1,
            MarginError::Unsupported(_) | MarginError::OverBudget(_) | MarginError::Refused(_) => 2,
            MarginError::NotSteady { .. } | MarginError::Unstable { .. } => 3,
        }
    }
}

impl std::fmt::Display for MarginError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MarginError::Flight(m) => write!(f, "{m}"),
            MarginError::Unsupported(m) => write!(f, "not supported: {m}"),
            MarginError::NotSteady { t_s, reason } if t_s.is_finite() => {
                write!(f, "the operating point is not a steady hold (t = {t_s:.3} s): {reason}; no margin measured")
            }
            MarginError::NotSteady { reason, .. } => {
                write!(f, "the operating point is not a steady hold: {reason}; no margin measured")
            }
            MarginError::Unstable { reason } => write!(f, "unstable at operating point: {reason}"),
            MarginError::Refused(r) => write!(f, "{r}"),
            MarginError::OverBudget(o) => write!(
                f,
                "not measured: the sweep would cost at least {:.3e} plant steps, over the budget of {:.3e} ({}); \
                 `sim-host margins` has no budget unless given --max-plant-steps{}",
                o.spent_steps,
                o.budget_steps,
                o.cost(),
                o.context
            ),
        }
    }
}

impl std::error::Error for MarginError {}

/// How to measure.
#[derive(Clone, Debug)]
pub struct MarginOptions {
    /// Time of the operating point, s (default: the scenario's duration).
    pub at_s: Option<f64>,
    pub point: LoopPoint,
    pub link: LinkKind,
    pub link_options: LinkOptions,
    /// Frequencies of the log-spaced grid (before refinement).
    pub grid_points: usize,
    /// Worker threads.
    pub threads: usize,
    /// Attitude excitation aimed at, rad (the amplitude rule, docs/margins.md).
    pub amplitude_rad: f64,
    /// Crossover estimate, rad/s: skips the pilot sweep.
    pub crossover_hint_rad_s: Option<f64>,
    /// Refine crossings and peaks with extra frequencies.
    pub refine: bool,
    /// Re-fly every experiment from t = 0 even when the link can be forked (what a QEMU
    /// measurement does; the same bits).
    pub refly: bool,
    /// Closed or open loop; `None` (auto): closed, open if the closed-loop experiment
    /// diverges or saturates at a steady operating point (docs/margins.md).
    pub method: Option<Method>,
    /// Most plant (RK4) steps the frequency sweep may cost, counted before it runs from the
    /// crossover estimate (each experiment's wait and two blocks, three axes); `None`: no
    /// limit. The report sets one so that it stays minutes long (a cost, not wall time:
    /// the same verdict on every machine).
    pub max_plant_steps: Option<u64>,
    /// Measure an adaptive law (DMCS) at its frozen adaptation state ([`freeze`], the
    /// default); `false`: as flown, adapting in each run.
    pub freeze_adaptation: bool,
}

impl MarginOptions {
    /// Every option within its range, for a scenario of `duration_s` flown at the control
    /// period `dt_s` (the checks the scenario's `[margins]` and the command line's flags use:
    /// [`sim_core::scenario::margin_check`]); the refusal names the flag.
    pub fn check(&self, duration_s: f64, dt_s: f64) -> Result<(), OptionRefused> {
        check::at_s(self.at_s.unwrap_or(duration_s), duration_s)?;
        check::grid_points(self.grid_points)?;
        check::threads(self.threads)?;
        check::amplitude_rad(self.amplitude_rad)?;
        if let Some(w) = self.crossover_hint_rad_s {
            check::crossover_hint(w, Some(dt_s))?;
        }
        if let Some(n) = self.max_plant_steps {
            check::max_plant_steps(n)?;
        }
        Ok(())
    }
}

impl Default for MarginOptions {
    fn default() -> Self {
        Self {
            at_s: None,
            point: LoopPoint::Input,
            link: LinkKind::InProcess,
            link_options: LinkOptions::default(),
            grid_points: 40,
            threads: 2,
            amplitude_rad: 1e-4,
            crossover_hint_rad_s: None,
            refine: true,
            refly: false,
            method: None,
            max_plant_steps: None,
            freeze_adaptation: true,
        }
    }
}

/// Closed-loop time constants waited before measuring (docs/margins.md, "Transient").
const WAIT_CROSSOVER_PERIODS: f64 = 10.0;
/// Least block length, in closed-loop time constants `1/ωc`.
const BLOCK_CROSSOVER_PERIODS: f64 = 2.0;
/// Most blocks per experiment.
const MAX_BLOCKS: u32 = 8;
/// Grid lower end: the crossover estimate divided by this.
const GRID_BELOW_CROSSOVER: f64 = 30.0;
/// Refinement stops when a bracket is narrower than this (relative).
const REFINE_WIDTH: f64 = 1e-3;
const REFINE_ROUNDS: usize = 8;

/// What the experiments share: the control period, the inertia diagonal, the amplitude
/// caps and the rules.
struct Plan {
    dt: f64,
    /// RK4 steps per control period.
    substeps: u64,
    /// `MarginOptions::max_plant_steps`, and the plant steps charged so far.
    budget: Option<u64>,
    spent: std::cell::Cell<u64>,
    point: LoopPoint,
    method: Method,
    /// `eᵀ J e` about each loop axis, and the loop axes.
    inertia_diag: [f64; 3],
    axes: LoopAxes,
    cap: [f64; 3],
    amplitude_rad: f64,
}

impl Plan {
    /// Sine-step amplitude about `axis` at `w`, with the crossover estimate `wc`: at the
    /// input, the torque that moves the attitude by about `amplitude_rad` (`J ω²` above the
    /// crossover, the loop's stiffness `≈ J ωc²` below it; open loop: the free inertia's
    /// `J ω²` at every frequency), capped so that no actuator channel exceeds 5 % of its
    /// limit; at the output, `amplitude_rad` itself.
    fn amplitude(&self, axis: usize, w: f64, wc: f64) -> f64 {
        let stiffness = match self.method {
            Method::Closed => w.max(wc).powi(2),
            Method::Open => w * w,
        };
        match self.point {
            LoopPoint::Input => (self.amplitude_rad * self.inertia_diag[axis] * stiffness).min(self.cap[axis]),
            LoopPoint::Output => self.amplitude_rad,
        }
    }

    /// The experiment of frequency `f` on `axis` with crossover estimate `wc`.
    fn experiment(&self, f: Freq, axis: usize, wc: f64) -> Experiment {
        let steps = |periods: f64| (periods / (wc * self.dt)).ceil().max(1.0) as u64;
        let block_min = steps(BLOCK_CROSSOVER_PERIODS);
        Experiment {
            freq: f,
            axis,
            amplitude: self.amplitude(axis, f.rad_s(self.dt), wc),
            wait_steps: steps(WAIT_CROSSOVER_PERIODS),
            block_steps: f.n * block_min.div_ceil(f.n),
            max_blocks: MAX_BLOCKS,
        }
    }

    /// One experiment per actuated loop axis.
    fn per_axis(&self, f: Freq, wc: f64) -> Vec<Experiment> {
        (0..self.axes.actuated).map(|j| self.experiment(f, j, wc)).collect()
    }

    /// The three columns of one frequency from its experiments (one per actuated axis): an
    /// axis no actuator can torque (magnetorquers: along the field) gets `U = 0`, `E = e_j`,
    /// so `L` has a zero row and column there.
    fn columns(&self, measured: &[excite::Column]) -> [excite::Column; 3] {
        std::array::from_fn(|j| {
            measured.get(j).copied().unwrap_or_else(|| {
                let mut e = [C64::default(); 3];
                e[j] = C64::new(1.0, 0.0);
                excite::Column { u: [C64::default(); 3], e, blocks: 0, converged: true, peak_attitude_rad: 0.0 }
            })
        })
    }

    /// Charges `xs` to the budget before they run: each experiment's wait and two blocks
    /// (the fewest it can take) in plant steps. Over the budget: `OverBudget`, before any
    /// of them flies, so the verdict does not depend on the machine.
    fn charge(&self, xs: &[Experiment]) -> Result<(), MarginError> {
        let Some(budget) = self.budget else { return Ok(()) };
        let cost = xs
            .iter()
            .map(|e| e.wait_steps.saturating_add(e.block_steps.saturating_mul(2)))
            .fold(0u64, u64::saturating_add)
            .saturating_mul(self.substeps);
        let spent = self.spent.get().saturating_add(cost);
        self.spent.set(spent);
        if spent <= budget {
            return Ok(());
        }
        let lowest = xs.iter().map(|e| e.freq.rad_s(self.dt)).fold(f64::INFINITY, f64::min);
        Err(MarginError::OverBudget(OverBudget {
            spent_steps: spent,
            budget_steps: budget,
            next_frequency_rad_s: lowest,
            substeps: self.substeps,
            context: String::new(),
        }))
    }
}

/// What the measurement went through, for the report.
#[derive(Clone, Debug, Default)]
pub struct Measured {
    pub response: Response,
    pub crossover_estimate_rad_s: f64,
    pub pilot_frequencies: usize,
    pub refined_frequencies: usize,
    pub amplitudes: Vec<f64>,
    /// Experiments run, and those that never became periodic.
    pub experiments: usize,
    pub unsettled: usize,
    /// The method of the response, and why it is not the one asked for (auto's fallback).
    pub method: Method,
    pub method_note: Option<String>,
    /// The axes the response is in.
    pub axes: LoopAxes,
    /// Magnetorquers: the field frozen at the operating point, in words.
    pub field_note: Option<String>,
}

/// Measures the margins of `scenario` (docs/margins.md).
pub fn measure(scenario: &Scenario, opts: &MarginOptions) -> Result<MarginReport, MarginError> {
    let start = Instant::now();
    let resolved = Resolved::try_from(scenario).map_err(MarginError::flight)?;
    let dt = resolved.clock.dt;
    let settle = resolved.performance.settle_bound_deg;
    let substeps = u64::from(resolved.clock.substeps.max(1));
    drop(resolved);
    opts.check(scenario.duration_s, dt).map_err(MarginError::Refused)?;
    let at_s = opts.at_s.unwrap_or(scenario.duration_s);
    let k_op = (at_s / dt).round() as u64;
    let mut setup = Setup {
        scenario,
        link: opts.link.clone(),
        link_options: opts.link_options.clone(),
        k_op,
        check_from: k_op.saturating_sub((k_op / 10).max(1)),
        settle_bound_deg: settle,
        point: opts.point,
        effectiveness: None,
        method: Method::Closed,
        fork: false,
        freeze_adaptation: false,
    };
    // The operating point once here: is it a steady hold, what do the actuators make there
    // (an actuator family out of scope is said before flying).
    let mut link = sim_core::link::open(&opts.link, &opts.link_options).map_err(MarginError::flight)?;
    let resolved = Resolved::try_from(scenario).map_err(MarginError::flight)?;
    let start_sim = sim_core::simulation::probe::Probe::new(resolved, link.as_mut()).map_err(MarginError::flight)?;
    if let Err(e @ MarginError::Unsupported(_)) = Effectiveness::at(&start_sim) {
        return Err(e);
    }
    if Family::of(&start_sim) == Some(Family::Magnetorquers) {
        magnetorquers_supported(scenario, opts)?;
    }
    drop(start_sim);
    let mut sim = setup.fly(link.as_mut())?;
    let frozen = if opts.freeze_adaptation { freeze::freeze(&mut sim)? } else { None };
    setup.freeze_adaptation = frozen.is_some();
    let eff = Effectiveness::at(&sim)?;
    let j = sim.craft().inertia;
    let axes = eff.axes;
    let field_note = (eff.family == Family::Magnetorquers).then(|| frozen_field_note(&sim));
    setup.fork = sim.fork_link().is_some() && !opts.refly;
    drop(sim);
    drop(link);
    let plan = Plan {
        dt,
        substeps,
        budget: opts.max_plant_steps,
        spent: std::cell::Cell::new(0),
        point: opts.point,
        method: Method::Closed,
        inertia_diag: axes.inertia_along(&j),
        axes,
        cap: std::array::from_fn(|a| eff.amplitude_cap(a)),
        amplitude_rad: opts.amplitude_rad,
    };
    setup.effectiveness = Some(eff);
    let (mut measured, experiments) =
        measure_with_fallback(&mut setup, plan, opts).map_err(|e| freeze::said_frozen(e, frozen.as_ref()))?;
    measured.field_note = field_note;
    let mut report = report::build(scenario, opts, at_s, dt, &measured, experiments, start.elapsed().as_secs_f64())?;
    report.adaptation = frozen;
    Ok(report)
}

/// What the frozen field is (the magnetorquer loop's operating point).
fn frozen_field_note(sim: &sim_core::simulation::probe::Probe) -> String {
    let b = sim.field_body_t().unwrap_or_default();
    let frame = match sim.frozen_field() {
        Some(FrozenField::Lvlh(_)) => "LVLH (the orbit, gravity gradient and LVLH rate go on)",
        _ => "the reference frame",
    };
    format!(
        "magnetic field frozen at the operating point, constant in {frame}: |B| = {:.4e} T along body [{:.4}, {:.4}, \
         {:.4}]; no torque about it (its row and column of L are zero), the loop is the 2x2 one perpendicular to it",
        b.norm(),
        b.x / b.norm(),
        b.y / b.norm(),
        b.z / b.norm()
    )
}

/// A magnetorquer loop is measured at the actuator input with the field frozen: the
/// attitude estimate must not rest on the magnetometer (its on-board field model would
/// disagree with the frozen field).
fn magnetorquers_supported(scenario: &Scenario, opts: &MarginOptions) -> Result<(), MarginError> {
    if opts.point == LoopPoint::Output {
        return Err(MarginError::Unsupported(
            "a magnetorquer loop is measured at the actuator input only (--loop input): no torque can be made \
             along the field, so an attitude excitation about it is not a loop"
                .into(),
        ));
    }
    if scenario.estimation.as_ref().and_then(|e| e.magnetometer_sigma_deg).is_some_and(|s| s > 0.0) {
        return Err(MarginError::Unsupported(
            "the estimator fuses the magnetometer: with the field frozen for the measurement its on-board field \
             model would disagree with the sensor (docs/margins.md, \"Magnetorquer loops\")"
                .into(),
        ));
    }
    Ok(())
}

/// The sweep with the method asked for; auto: closed loop, and open loop if the closed-loop
/// experiments diverge or saturate (the operating point was a steady hold: the closed loop
/// amplifies the excitation), saying so in the report.
fn measure_with_fallback(
    setup: &mut Setup,
    mut plan: Plan,
    opts: &MarginOptions,
) -> Result<(Measured, u64), MarginError> {
    let method = opts.method.unwrap_or(Method::Closed);
    if method == Method::Open && opts.point == LoopPoint::Output {
        return Err(MarginError::Unsupported(
            "the open-loop method breaks the loop at the actuator input only (--loop input)".into(),
        ));
    }
    let run = |setup: &Setup, plan: &Plan| {
        Pool::with(setup, opts.threads, |pool| {
            let m = sweep(pool, plan, opts);
            (m, pool.experiments)
        })
    };
    (setup.method, plan.method) = (method, method);
    let (measured, experiments) = run(setup, &plan);
    let closed_failure = match measured {
        Err(e) if opts.method.is_none() && opts.point == LoopPoint::Input && excite::closed_loop_diverged(&e) => e,
        m => return Ok((m?, experiments)),
    };
    (setup.method, plan.method) = (Method::Open, Method::Open);
    let (measured, more) = run(setup, &plan);
    let mut m = measured.map_err(|e| with_context(e, &closed_failure))?;
    let why = match &closed_failure {
        MarginError::NotSteady { reason, .. } | MarginError::Unstable { reason } => {
            reason.trim_end_matches(": lower --amplitude-rad")
        }
        _ => "",
    };
    m.method_note = Some(format!(
        "measured with the loop broken open: with the loop closed, the excitation of a steady hold diverged or \
         saturated ({why})"
    ));
    Ok((m, experiments + more))
}

/// The open-loop fallback's error, with the closed-loop failure that led to it.
fn with_context(e: MarginError, closed: &MarginError) -> MarginError {
    let add = |r: String| format!("{r} (open loop, after the closed-loop experiment failed: {closed})");
    match e {
        MarginError::NotSteady { t_s, reason } => MarginError::NotSteady { t_s, reason: add(reason) },
        MarginError::Unstable { reason } => MarginError::Unstable { reason: add(reason) },
        MarginError::Flight(r) => MarginError::Flight(add(r)),
        MarginError::Unsupported(r) => MarginError::Unsupported(add(r)),
        MarginError::OverBudget(o) => MarginError::OverBudget(OverBudget { context: add(o.context), ..o }),
        refused @ MarginError::Refused(_) => refused,
    }
}

/// Pilot (unless hinted), grid, refinement.
fn sweep(pool: &mut Pool, plan: &Plan, opts: &MarginOptions) -> Result<Measured, MarginError> {
    let mut m = Measured { method: plan.method, axes: plan.axes, ..Measured::default() };
    m.crossover_estimate_rad_s = match opts.crossover_hint_rad_s {
        Some(w) => w,
        None => pilot(pool, plan, &mut m)?,
    };
    let wc = m.crossover_estimate_rad_s;
    let grid = grid::log_grid(wc / GRID_BELOW_CROSSOVER, opts.grid_points, plan.dt);
    if !opts.refine {
        let (lo, hi) = (grid::lowest(wc / GRID_BELOW_CROSSOVER, plan.dt), std::f64::consts::PI / plan.dt);
        check::unrefined_spacing(opts.grid_points, lo, hi).map_err(MarginError::Refused)?;
    }
    measure_frequencies(pool, plan, &grid, wc, &mut m)?;
    unsettled(&m)?;
    if let Some(hint) = opts.crossover_hint_rad_s {
        crossover_in_grid(&m, plan, hint)?;
    }
    if opts.refine {
        for _ in 0..REFINE_ROUNDS {
            let new: Vec<Freq> = refinement_points(&m.response, plan.dt);
            if new.is_empty() {
                break;
            }
            m.refined_frequencies += new.len();
            measure_frequencies(pool, plan, &new, wc, &mut m)?;
        }
    }
    Ok(m)
}

/// A hinted grid must start below the loop's crossover, as the pilot's does: every actuated
/// axis's `|l_i|` above 1 at the lowest grid frequency (an attitude loop — a double
/// integrator under its law — has its gain crossover above it). Otherwise the crossover
/// lies below the grid and no margin on the grid is the loop's.
fn crossover_in_grid(m: &Measured, plan: &Plan, hint: f64) -> Result<(), MarginError> {
    let (Some(f), Some(l)) = (m.response.freqs.first(), m.response.l.first()) else { return Ok(()) };
    let Some(s) = analysis::sensitivity(l) else { return Ok(()) };
    let w = f.rad_s(plan.dt);
    for (i, name) in plan.axes.names().iter().enumerate().take(plan.axes.actuated) {
        let g = analysis::loop_at_a_time(&s, i).norm();
        if !(g > 1.0) {
            return Err(MarginError::Refused(OptionRefused {
                option: sim_core::scenario::MarginOption::CrossoverHint,
                value: format!("{hint}"),
                why: format!(
                    "the grid starts above the loop's gain crossover (axis {name}: |l| = {g:.4} at its lowest frequency \
                     {w:.5} rad/s, the hint / {GRID_BELOW_CROSSOVER}): no margin on it would be the loop's; give a hint \
                     nearer the crossover, or none (the pilot sweep finds it)"
                ),
            }));
        }
    }
    Ok(())
}

/// More than a tenth of the experiments so far (the pilot's excepted: it waits on a guess)
/// never became
/// periodic: the loop is not linear and time-invariant at this operating point.
fn unsettled(m: &Measured) -> Result<(), MarginError> {
    let (n, total) = (m.unsettled, m.experiments);
    // Magnetorquers: nothing holds the attitude about the frozen field; in orbit, gravity
    // gradient and the orbit-rate coupling leave a mode there unstable, undamped or slow.
    let along_field = if m.axes.body.is_some() {
        "; with the field frozen no torque acts about it, and in orbit the attitude about the field has only \
         gravity-gradient and orbit-rate dynamics (unstable, undamped or far slower than the crossover: docs/margins.md, \"Magnetorquer loops\")"
    } else {
        ""
    };
    if n * 10 > total {
        return Err(MarginError::NotSteady {
            t_s: f64::NAN,
            reason: format!(
                "the response to the excitation did not become periodic in {n} of {total} experiments \
                 ({MAX_BLOCKS} blocks): the loop is not linear and time-invariant at this operating point \
                 (friction, a limit cycle, an orbit-periodic plant) or has a mode much slower than its \
                 crossover{along_field}"
            ),
        });
    }
    Ok(())
}

fn measure_frequencies(
    pool: &mut Pool,
    plan: &Plan,
    fs: &[Freq],
    wc: f64,
    m: &mut Measured,
) -> Result<(), MarginError> {
    let xs: Vec<Experiment> = fs.iter().flat_map(|f| plan.per_axis(*f, wc)).collect();
    plan.charge(&xs)?;
    let cols = pool.run(&xs)?;
    m.experiments += cols.len();
    m.unsettled += cols.iter().filter(|c| !c.converged).count();
    m.amplitudes.extend(xs.iter().map(|x| x.amplitude));
    for (f, c) in fs.iter().zip(cols.chunks_exact(plan.axes.actuated)) {
        m.response.insert(*f, plan.columns(c), plan.dt)?;
    }
    Ok(())
}

/// The crossover estimate: sine steps descending from the Nyquist frequency by factors of
/// 3 until every axis's `|L_jj|` exceeds 2, each with the crossover assumed at its own
/// frequency; the estimate is the lowest axis's crossing of `|L_jj| = 1` (log-interpolated).
fn pilot(pool: &mut Pool, plan: &Plan, m: &mut Measured) -> Result<f64, MarginError> {
    let nyquist = std::f64::consts::PI / plan.dt;
    let mut prev: Option<(f64, [f64; 3])> = None;
    let mut crossing: [Option<f64>; 3] = [None; 3];
    for level in 1..=14 {
        let w = nyquist / 3f64.powi(level);
        let f = Freq::near(w, plan.dt);
        let w = f.rad_s(plan.dt);
        let xs = plan.per_axis(f, w);
        plan.charge(&xs)?;
        let cols = pool.run(&xs)?;
        m.pilot_frequencies += 1;
        let n = plan.axes.actuated;
        let gains: [f64; 3] =
            std::array::from_fn(
                |j| if j < n { response::diagonal_estimate(&cols[j], j).norm() } else { f64::INFINITY },
            );
        if let Some((wp, gp)) = prev {
            for j in 0..n {
                if crossing[j].is_none() && gp[j] < 1.0 && gains[j] >= 1.0 {
                    let t = gp[j].ln() / (gp[j].ln() - gains[j].ln());
                    crossing[j] = Some((wp.ln() + t * (w.ln() - wp.ln())).exp());
                }
            }
        }
        if gains.iter().all(|g| *g > 2.0) {
            break;
        }
        prev = Some((w, gains));
    }
    crossing.iter().flatten().copied().reduce(f64::min).ok_or_else(|| MarginError::Unstable {
        reason: "no gain crossover found between the Nyquist frequency and 3^-14 of it".into(),
    })
}

/// Sensitivities `S = (I + L)⁻¹` of a response (`None` entries: singular).
pub fn sensitivities(r: &Response) -> Vec<Option<Cmat>> {
    r.l.iter().map(analysis::sensitivity).collect()
}

/// The next frequencies to measure: secant points of every crossover and phase-crossing
/// bracket of each axis's loop-at-a-time `l_i`, and parabola vertices of the peaks of
/// `|s_i|`, `|t_i|`, `|s_i − 1/2|` and the multiloop μ bound, that are not measured yet.
fn refinement_points(r: &Response, dt: f64) -> Vec<Freq> {
    let w = r.rad_s(dt);
    let s: Vec<Cmat> = match sensitivities(r).into_iter().collect::<Option<Vec<_>>>() {
        Some(s) => s,
        None => return Vec::new(),
    };
    let mut want: Vec<f64> = Vec::new();
    for i in 0..3 {
        let l: Vec<C64> = s.iter().map(|m| analysis::loop_at_a_time(m, i)).collect();
        want.extend(grid::refine_zeros(&w, &grid::log_gain(&l), REFINE_WIDTH));
        want.extend(grid::refine_zeros(&w, &grid::phase_sine(&l), REFINE_WIDTH));
        let one = C64::new(1.0, 0.0);
        for y in [
            s.iter().map(|m| m[i][i].norm()).collect::<Vec<f64>>(),
            s.iter().map(|m| (one - m[i][i]).norm()).collect(),
            s.iter().map(|m| (m[i][i] - 0.5).norm()).collect(),
        ] {
            want.extend(grid::refine_peak(&w, &y, REFINE_WIDTH));
        }
    }
    let mu: Vec<f64> = s.iter().map(|m| analysis::mu_upper_bound(&analysis::disk_matrix(m)).0).collect();
    want.extend(grid::refine_peak(&w, &mu, REFINE_WIDTH));
    let mut fs: Vec<Freq> = want.into_iter().map(|w| Freq::near(w, dt)).filter(|f| !r.contains(f)).collect();
    fs.sort_by(|a, b| a.rad_s(dt).total_cmp(&b.rad_s(dt)));
    fs.dedup();
    fs
}
