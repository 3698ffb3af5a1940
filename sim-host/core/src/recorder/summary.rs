//! A run's summary (`summary.json`) and the online statistics of the attitude error it
//! reports, computed as the run goes (no stored history).

use super::pointing::MagnitudeQuantile;
use serde::Serialize;

/// Default attitude-error bound that defines the settle time, deg (`[performance]
/// settle_bound_deg`).
pub const SETTLE_BOUND_DEG: f64 = 1.0;

#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct StatusCounts {
    pub torque_limited: u64,
    pub rate_scaled: u64,
    pub angle_limited: u64,
    pub singular: u64,
    pub bad_input: u64,
    pub torque_shortfall: u64,
    pub alloc_fallback: u64,
    pub unrealised: u64,
    pub law_fault: u64,
    /// Steps the mode needed the fine attitude estimate or the navigation solution and
    /// had neither (safe command, `Status::NO_ESTIMATE`).
    pub no_estimate: u64,
}

/// How a run ended (`summary.json` `run_status`). Anything but `Ok` is a failed run:
/// `sim-host run` exits with status 3 and a campaign counts it against every requirement.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RunStatus {
    /// Flew to the end with a finite state.
    #[default]
    Ok,
    /// A plant, environment or flight-command quantity became non-finite: the run was
    /// stopped at that step.
    Diverged,
    /// The flight code refused the input of every step (`status_counts.bad_input` on each).
    AllRefused,
    /// The link delivered a reply that may have changed the result (a frame stepped twice
    /// or out of order, an unexpected reply: `link_anomalies.result_affected`).
    LinkAnomaly,
    /// A sensor's transport-delay queue overflowed and dropped samples
    /// (`sensor_samples_dropped` > 0): the flight code did not see the sensor the scenario
    /// describes. Zero by construction of the queues' cap; this says so if it ever is not.
    SamplesDropped,
    /// The flight was ok, but the stability margins `[margins]` asks for were not measured
    /// as a stable loop at a steady hold (`margins.status` is not `measured`): the run
    /// exits as `sim-host margins` would (3 not steady or unstable, 2 unsupported or over
    /// budget, 1 error) and a campaign counts it as a failed run (docs/margins.md).
    MarginsFailed,
    /// The flight code could not control for a material part of the run: after the
    /// start-up allowance ([`CONTROL_STARTUP_FRACTION`] of the steps, at most
    /// [`CONTROL_STARTUP_MAX_S`]), more than [`MAX_UNCONTROLLED_FRACTION`] of the steps
    /// held the safe command because the active mode lacked an input it needs
    /// (`status_counts.bad_input`: a sensor missing, lost or out of range; or
    /// `no_estimate`: the fine attitude estimate or the navigation solution).
    NoControl,
    /// A boresight was inside one of its `[[manoeuvre.keepout]]` cones (truth: true
    /// attitude, Sun and Earth) at a recorded step from `keepout_enforced_from_s` on
    /// (`keepout.violations`): the planned attitude did not keep a sensor safe.
    #[serde(rename = "keepout_violated")]
    KeepOutViolated,
    /// `[[timeline]]` segments were missed (not on target at their start) and the
    /// scenario does not allow it (`[performance] allow_missed_segments`).
    TimelineMissed,
    /// `[fdir]` declared a unit failed that had no injected fault (`fdir.false_alarms`).
    FdirFalseAlarm,
    /// With `[[faults]]`: the truth lost control through the last
    /// [`CONTROL_LOST_WINDOW_S`](crate::recorder::control_lost::CONTROL_LOST_WINDOW_S) of the
    /// run after a fault was injected, and the FDIR raised no event
    /// (`crate::recorder::control_lost`).
    ControlLost,
    /// With `[[faults]]`: the truth lost control the same way, the FDIR raised an event, and
    /// the flight did not end in a safe mode (detumble, sun-safe): the declared fault's
    /// recovery neither kept the pointing nor fell back to survival
    /// (`crate::recorder::control_lost`).
    RecoveryFailed,
    /// With `[[faults]]`: control was not lost, but the flight held (hold, or its one law
    /// without a mode manager) with the true error above the degraded-hold bound through
    /// the last window after a fault was injected, and the FDIR raised no event
    /// (`crate::recorder::control_lost`).
    PointingDegraded,
    /// With `[performance] propellant_budget_kg`: the thrusters used more propellant than
    /// the budget (`propellant_kg` above `propellant_budget_kg`), with or without faults; a
    /// run that also failed otherwise (a lost or degraded pointing among them) has that
    /// status instead (`crate::recorder::propellant`).
    PropellantExceeded,
}

/// Start-up allowance of the no-control check: the first tenth of the run's steps…
pub const CONTROL_STARTUP_FRACTION: f64 = 0.1;
/// …but at most this much flight time, s (a filter converges, a tracker locks, a field
/// model fills within it).
pub const CONTROL_STARTUP_MAX_S: f64 = 60.0;
/// After the allowance, a run with more than this fraction of its steps uncontrolled
/// (`bad_input` or `no_estimate`) fails with `no_control`.
pub const MAX_UNCONTROLLED_FRACTION: f64 = 0.1;

/// Why a run failed (`summary.json` `failure`; null for a run that is ok).
#[derive(Clone, Debug, Serialize, PartialEq)]
#[serde(untagged)]
pub enum Failure {
    /// The first non-finite quantity and the time of the control step that saw it, s.
    Diverged { t_s: f64, quantity: String },
    /// Why the run counts as refused.
    Refused { reason: String },
    /// Which link anomalies may have changed the result.
    Link { reason: String },
    /// Which sensors' samples the simulator lost.
    Sensors { reason: String },
    /// Why the margins `[margins]` asks for are not those of a stable loop at a steady hold
    /// (`margins.status` and `margins.reason`).
    Margins { reason: String },
    /// How many steps after the start-up allowance were uncontrolled, and why.
    Control { reason: String },
    /// Which boresight entered which cone (truth), first when and how deep, and for how
    /// many steps (`[manoeuvre] keepout_enforced_from_s` on).
    KeepOut { reason: String },
    /// How many timeline segments were missed.
    Timeline { reason: String },
    /// Which healthy unit FDIR declared failed, when and by which test.
    Fdir { reason: String },
    /// Since when control was lost (truth), and how far at the end.
    ControlLost { reason: String },
    /// Which FDIR events were raised, since when control was lost (truth), and the mode the
    /// flight ended in.
    RecoveryFailed { reason: String },
    /// Since when the hold was off by more than the degraded-hold bound (truth), and how far
    /// at the end.
    PointingDegraded { reason: String },
    /// How much propellant the thrusters used against the budget.
    Propellant { reason: String },
}

/// `summary.json` `timeline` (with `[[timeline]]`): the flight code's counters at the end.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct TimelineSummary {
    pub segments: usize,
    /// On target at their start / not (late, refused, skipped).
    pub met: u16,
    pub missed: u16,
    /// Not started by the end of the run.
    pub pending: u32,
    /// When the flight code armed it, s (after the first step with navigation).
    pub armed_at_s: Option<f64>,
    /// `[performance] allow_missed_segments`: a missed segment does not fail the run.
    pub allow_missed: bool,
}

#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Summary {
    pub scenario: String,
    /// `ok`, `diverged`, `all_refused`, `link_anomaly`, `samples_dropped`, `no_control` or
    /// `margins_failed` (see [`RunStatus`]).
    pub run_status: RunStatus,
    /// Null when `run_status` is `ok`.
    pub failure: Option<Failure>,
    pub link: String,
    /// 0 in-process, 1 QEMU mps2-an386, 2 STM32F405; null for open-loop runs.
    pub board: Option<u8>,
    pub steps: u64,
    pub sim_time_s: f64,
    pub control_rate_hz: f64,
    pub dynamics_rate_hz: f64,
    /// Principal angle between the true and the target attitude at the end, deg.
    pub final_error_deg: f64,
    /// Time after which the error stays below `settle_bound_deg`; `null` if it never does.
    pub settle_time_s: Option<f64>,
    pub settle_bound_deg: f64,
    /// Start of the window after settle: `settle_time_s` + `[performance]
    /// settle_dwell_s` (default: the settle time again), s; null if the run never settles.
    pub after_settle_from_s: Option<f64>,
    /// Largest error over [`after_settle_from_s`, end], deg; null if the run never settles
    /// or the window is empty.
    pub max_error_after_settle_deg: Option<f64>,
    /// Mean error over the whole run, deg.
    pub mean_error_whole_run_deg: f64,
    /// RMS error over [`after_settle_from_s`, end], deg; null as the maximum (the
    /// whole-run figures are in `pointing`).
    pub rms_error_after_settle_deg: Option<f64>,
    /// The error's quantile at `[performance] confidence` over [`after_settle_from_s`,
    /// end] (the hold's APE, principal angle), deg; null as the maximum.
    pub ape_after_settle_deg: Option<f64>,
    /// Euler angles relative to the target's frame (inertial, lab or LVLH), deg.
    pub final_euler_deg: [f64; 3],
    pub target_euler_deg: [f64; 3],
    pub final_rate_rad_s: [f64; 3],
    /// Largest commanded gimbal rate, rad/s (null without CMGs).
    pub max_gimbal_rate_rad_s: Option<f64>,
    /// Smallest `det(J₁ J₁ᵀ)` of the true gimbal angles (unit rotor momentum).
    pub min_singularity_measure: Option<f64>,
    pub max_wheel_speed_rpm: Option<f64>,
    /// Largest |power| of any wheel, W: electrical (paper 001 eq 30) for accurate wheels,
    /// mechanical shaft power `ω_w ḣ_a` for ideal ones.
    pub max_wheel_power_w: Option<f64>,
    /// Largest motor current of any wheel, A: accurate wheels only (null for ideal ones,
    /// which have no motor model).
    pub max_wheel_current_a: Option<f64>,
    pub propellant_kg: Option<f64>,
    /// `[performance] propellant_budget_kg` (absent without a budget): `propellant_kg` above
    /// it fails the run (`propellant_exceeded`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub propellant_budget_kg: Option<f64>,
    /// Most valve openings of any single thruster.
    pub max_pulses: Option<u32>,
    /// Largest `Fsw::step` cost in instructions (QEMU) — `null` when not measured.
    pub max_step_instructions: Option<u64>,
    pub mean_step_instructions: Option<f64>,
    /// Largest `Fsw::step` cost in raw counter ticks (any board that measures).
    pub max_step_ticks: Option<u32>,
    /// Mean and largest wall (host) or counter (board) time of `Fsw::step`, µs; null
    /// under QEMU, whose virtual clock is not the MCU's (`sim-host cycles` bounds them).
    pub mean_step_us: Option<f64>,
    pub max_step_us: Option<f64>,
    /// With thrusters: mean time per control step of the flight code (control law,
    /// LP allocation, PWPF — the LP dominates), µs, on the link's clock.
    pub allocation_us_per_call: Option<f64>,
    pub status_counts: StatusCounts,
    /// Every change of the flight mode (empty without `[modes]`).
    pub mode_transitions: Vec<ModeTransition>,
    pub final_mode: Option<String>,
    /// Sensor samples the simulator's latency queues dropped at their cap (any: the run
    /// fails with `run_status` `samples_dropped`).
    pub sensor_samples_dropped: u64,
    pub frames_dropped_flight: u32,
    pub frames_dropped_host: u32,
    /// Duplicate, late and unexpected replies and refused frames on the link, and whether
    /// they may have changed the result (docs/protocol.md "Link anomalies").
    pub link_anomalies: crate::link::LinkAnomalies,
    /// With the MEKF (`[estimation]`): RMS and largest attitude-estimation error against
    /// the truth, deg; gyro-bias error at the end, deg/h; mean NEES (6 for a consistent
    /// filter); innovations the chi-square gates rejected; filter restarts. Absent
    /// otherwise. The error and NEES figures are over the steps where the filter ran
    /// (`estimation_steps`, of `steps` + 1 flight steps).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub estimation_error_rms_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub estimation_error_max_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias_error_final_deg_h: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nees_mean: Option<f64>,
    /// Flight steps where the filter ran: what the figures above are over.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub estimation_steps: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub innovations_rejected: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub estimator_resets: Option<u16>,
    /// With the MEKF: samples fused (late among them), refused by reason, the largest
    /// sample age per sensor ([`SampleFusion`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sample_fusion: Option<SampleFusion>,
    /// Wall time of the run loop, s (streaming `timeseries.csv` included when the CLI
    /// records to disk; plots and summary excluded).
    pub wall_time_s: f64,
    pub real_time_factor: f64,
    /// Stored momentum, wheel speeds against their limit, momentum FDIR events and the
    /// pointing by day (with `[momentum]` or the momentum FDIR on; docs/momentum.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub momentum: Option<crate::recorder::momentum::MomentumSummary>,
    /// With `[manoeuvre]` keep-out cones and an orbit: the smallest margin per boresight
    /// and cone (truth), steps inside, slews planned and refused (docs/outputs.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub keepout: Option<crate::recorder::keepout::KeepOutSummary>,
    /// Pointing-performance indices (APE, MPE, RPE, PDE, stability) of the body-axis
    /// attitude error over `[performance] from_s` to the end, at its confidence level
    /// (docs/pointing.md).
    pub pointing: crate::recorder::pointing::PointingSummary,
    /// With `[modes]` or `[guidance]`: APE and RPE per pointing segment (a span of one
    /// mode, one pointing and one branch of it), the primary (boresight) error apart,
    /// each with its window (docs/pointing.md, "Per segment").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pointing_segments: Option<Vec<crate::recorder::segments::SegmentSummary>>,
    /// Segments beyond the listed cap (`recorder::segments::MAX_LISTED_SEGMENTS`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pointing_segments_unlisted: Option<u64>,
    /// With `[modes]` or `[guidance]`: the segments' figures pooled by mission pointing
    /// (`p0` the scenario's, `pN` the N-th ground command that sets a pointing), each
    /// branch apart: the same keys in every run of a scenario (docs/pointing.md, "Per
    /// mission pointing").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mission_pointings: Option<crate::recorder::segments::MissionPointings>,
    /// With `[[timeline]]`: segments met, missed and pending (docs/scenario.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timeline: Option<TimelineSummary>,
    /// With `[margins]`: the stability margins measured through the flight step at the
    /// operating point (`sim-host margins`, docs/margins.md), worst over the axes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub margins: Option<MarginSummary>,
    /// With `[[faults]]`: each injected fault, when it acted, and (future work) when the
    /// flight code detected it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub faults: Option<Vec<crate::faults::FaultRecord>>,
    /// With `[fdir]`: the flight's FDIR events (docs/fdir.md "Wiring").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fdir: Option<crate::recorder::fdir::FdirSummary>,
}

impl Summary {
    /// Records the `[margins]` measurement of this run: `margins`, and, when it is not a
    /// stable loop measured at a steady hold (`status` other than `measured`), a flight that
    /// was ok becomes `run_status` `margins_failed` with the margins' reason as its `failure`
    /// (an earlier failure of the flight itself stays the run's status).
    pub fn record_margins(&mut self, m: MarginSummary) {
        if m.status != MarginStatus::Measured && self.run_status == RunStatus::Ok {
            let status = serde_json::to_value(m.status).ok().and_then(|v| v.as_str().map(str::to_owned));
            let reason = format!(
                "margins {}: {}",
                status.unwrap_or_default(),
                m.reason.as_deref().unwrap_or("not a stable loop at a steady hold")
            );
            self.run_status = RunStatus::MarginsFailed;
            self.failure = Some(Failure::Margins { reason });
        }
        self.margins = Some(m);
    }
}

/// Whether the margins of `[margins]` were measured as a stable loop at a steady hold, or
/// why not. Anything but `Measured` is a failed run (`run_status` `margins_failed`; exit
/// status as `sim-host margins`'s: 1 `error`, 2 `unsupported` or `over_budget`, 3
/// `not_steady` or `unstable`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MarginStatus {
    /// Measured at a steady hold, and stable: every crossover's phase margin positive and
    /// the multiloop disk margin positive.
    Measured,
    /// The operating point is not a steady hold (saturation, stiction, unsettled error,
    /// a response that never becomes periodic), at the operating point or during an
    /// experiment (an actuator at its limit): no figure.
    NotSteady,
    /// The loop is unstable: it diverged while being measured (no figure), or it was
    /// measured (open loop, or closed) with a negative phase margin — the figures are then
    /// those of the unstable loop, beside `stable: false`, and say how far it is from stable.
    Unstable,
    /// A loop this measurement does not cover (thrusters; a magnetorquer loop at the output or
    /// with the magnetometer in the estimator).
    Unsupported,
    /// The sweep would cost more plant steps than the caller's budget (the report's).
    OverBudget,
    Error,
}

/// Where a stability-margin measurement breaks the flight loop: `[margins] loop` (the
/// scenario's request re-exports it: `crate::scenario::LoopPoint`), `sim-host margins
/// --loop`, and the `loop` of the `summary.json` `margins` it fills (docs/margins.md).
/// Defined here, beside the summary, because the scenario already depends on the recorder
/// (it builds its column layout), not the other way round.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LoopPoint {
    /// At the actuator command: body torque added to the flight's command through the
    /// actuators' effectiveness.
    #[default]
    Input,
    /// At the attitude measurement: a small rotation added to the attitude sample.
    Output,
}

impl LoopPoint {
    /// The spelling of the TOML key and of the command-line flag.
    pub fn name(self) -> &'static str {
        match self {
            LoopPoint::Input => "input",
            LoopPoint::Output => "output",
        }
    }
}

impl std::str::FromStr for LoopPoint {
    type Err = String;

    /// `input` or `output`, exactly (as `[margins] loop` spells them).
    fn from_str(s: &str) -> Result<Self, String> {
        [LoopPoint::Input, LoopPoint::Output]
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| format!("{s:?}: expected input or output"))
    }
}

/// `summary.json` `margins`: the scalars a campaign disperses over and requires, each the
/// worst over the three axes (loop-at-a-time), plus the multiloop disk margin. A figure is
/// a number only beside `status` `measured` (a stable loop), or `unstable` with `stable:
/// false` (a loop measured unstable: its figures say how far); `null` when not measured
/// (`reason` says why) or infinite (gain margins with no phase crossing, below the control
/// Nyquist frequency).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MarginSummary {
    pub status: MarginStatus,
    pub reason: Option<String>,
    /// Operating point, s, and where the loop was broken.
    pub at_s: f64,
    #[serde(rename = "loop")]
    pub loop_point: LoopPoint,
    /// `closed` (the excitation added to the flight's command) or `open` (the loop broken
    /// open: an unstable closed loop is measured that way); null when not measured.
    pub method: Option<String>,
    /// Every axis has positive phase margins at its crossovers and the multiloop disk
    /// margin is positive; null when not measured.
    pub stable: Option<bool>,
    /// Smallest phase margin of any axis, deg.
    pub phase_margin_deg: Option<f64>,
    /// Gain reduction tolerated (dB, < 0): the one closest to 0 dB over the axes.
    pub gain_margin_low_db: Option<f64>,
    /// Gain increase tolerated (dB, > 0): the smallest over the axes.
    pub gain_margin_high_db: Option<f64>,
    /// Smallest delay margin, s.
    pub delay_margin_s: Option<f64>,
    /// Highest gain-crossover frequency of any axis, rad/s.
    pub crossover_rad_s: Option<f64>,
    /// Largest sensitivity peak |S| of any axis, dB.
    pub sensitivity_peak_db: Option<f64>,
    /// Smallest loop-at-a-time disk margin α (balanced, skew 0).
    pub disk_alpha: Option<f64>,
    /// Multiloop disk margin α (D-scaled μ bound): all axes perturbed at once.
    pub multiloop_disk_alpha: Option<f64>,
}

/// What the flight estimator did with the sensor samples over a run (`summary.json`
/// `sample_fusion`, with the MEKF; filled by `crate::estimation::stats`): samples fused at
/// their own time (of them, late: taken before the filter's newest time and carried
/// forward through its history; after a wait: taken after it, fused when the gyro caught
/// up), refused by reason, still waiting for the gyro at the end, and the largest sample
/// age per sensor, s (−1: never sampled).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SampleFusion {
    pub fused: u32,
    pub fused_late: u32,
    pub fused_after_wait: u32,
    pub waiting_at_end: u16,
    /// Dropped while waiting for the gyro (its wait queue full, or the filter stopped).
    pub refused_dropped_waiting: u32,
    pub refused_too_old: u32,
    pub refused_from_the_future: u32,
    pub refused_out_of_order: u32,
    pub refused_bad_input: u32,
    pub max_replayed_nodes: u16,
    pub max_age_gyro_s: f32,
    pub max_age_tracker_s: f32,
    pub max_age_sun_s: f32,
    pub max_age_mag_s: f32,
}

/// A change of the flight mode as reported in telemetry.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ModeTransition {
    /// Time of the first step the new mode commanded, s.
    pub t_s: f64,
    pub from: String,
    pub to: String,
    /// Why the flight code switched (`acs_flight::modes::Reason`).
    pub reason: String,
}

/// Online statistics of the attitude error: final, mean, settle time (the time after
/// which the error stays below the bound: one control period after the last sample at or
/// above it) and, over the window *after settle* — from the settle time plus a dwell to
/// the end — the RMS, the maximum and the APE (the error's quantile at the run's
/// confidence). The dwell (`[performance] settle_dwell_s`; by default the length of the
/// last excursion above the bound, from its first sample above to the settle time, so the
/// transient gets as long again to die out — a dip below the bound shorter than the
/// excursion after it, an overshoot, does not split the transient) keeps the end of the
/// transient out: right
/// after the last crossing the error is just below the bound, so a window starting there
/// would report the bound, not the hold (issue 38). The accumulators of the window restart at every exceedance, and sums run in
/// time order, so the figures are bit-identical to those of the whole stored history.
///
/// A non-finite error (NaN) is never "below the bound": it counts as an exceedance (the run
/// has not settled at that time) and propagates into the mean, RMS and final error, so a
/// run that saw one reports them as NaN (`null` in JSON), never as a small number.
#[derive(Clone, Debug)]
pub struct ErrorStats {
    dt: f64,
    bound: f64,
    /// `[performance] settle_dwell_s` (`None`: the last excursion's length).
    dwell: Option<f64>,
    /// Time of the first sample of the current (or last) excursion above the bound.
    above_since: f64,
    /// Time of the first sample of the current stay below the bound.
    below_since: f64,
    /// The excursion before the current one: its start, and the stay below between them.
    prev_above_since: f64,
    dip_s: f64,
    /// A sample was at or above the bound (the "excursion" a run starts in is none).
    had_excursion: bool,
    /// The previous sample was at or above the bound.
    was_above: bool,
    /// Confidence of the APE after settle.
    confidence: f64,
    /// Time of the last sample at or above the bound (the run starts "above": 0).
    last_above: f64,
    /// Samples at `t >= settle_from` count as settled (`last_above + dt`).
    settle_from: f64,
    /// Samples at `t >= after_from` (`settle_from` + the dwell) are in the window.
    after_from: f64,
    last: f64,
    n: u64,
    sum: f64,
    n_after: u64,
    sum_sq_after: f64,
    max_after: f64,
    ape_after: MagnitudeQuantile,
}

/// The larger of `a` and `b`, NaN if either is NaN (`f64::max` ignores a NaN operand,
/// which would hide a non-finite sample behind the finite extreme of the others).
pub fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() { f64::NAN } else { a.max(b) }
}

/// The smaller of `a` and `b`, NaN if either is NaN (see [`nan_max`]).
pub fn nan_min(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() { f64::NAN } else { a.min(b) }
}

/// The error figures of a run (see [`ErrorStats`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorFigures {
    pub final_error_deg: f64,
    pub settle_time_s: Option<f64>,
    /// Start of the window after settle (`settle_time_s` + the dwell); `null` if the run
    /// never settles.
    pub after_settle_from_s: Option<f64>,
    /// Over [`after_settle_from_s`, end]; `null` if the run never settles or the window
    /// holds no sample (the dwell reaches past the end).
    pub max_error_after_settle_deg: Option<f64>,
    pub mean_error_whole_run_deg: f64,
    pub rms_error_after_settle_deg: Option<f64>,
    pub ape_after_settle_deg: Option<f64>,
}

impl ErrorStats {
    /// `dwell_s`: the window after settle starts this long after the settle time (`None`:
    /// the length of the last excursion above the bound); `confidence`: of its APE, in
    /// (0, 1]. The run starts in an excursion at t = 0.
    pub fn new(dt: f64, bound: f64, dwell_s: Option<f64>, confidence: f64) -> Self {
        let settle_from = 0.0 + dt;
        Self {
            dt,
            bound,
            dwell: dwell_s,
            above_since: 0.0,
            below_since: 0.0,
            prev_above_since: 0.0,
            dip_s: f64::INFINITY,
            had_excursion: false,
            was_above: true,
            confidence,
            last_above: 0.0,
            settle_from,
            after_from: f64::INFINITY,
            last: f64::NAN,
            n: 0,
            sum: 0.0,
            n_after: 0,
            sum_sq_after: 0.0,
            max_after: 0.0,
            ape_after: MagnitudeQuantile::new(),
        }
    }

    /// The error at time `t` (non-decreasing from call to call).
    pub fn push(&mut self, t: f64, err: f64) {
        self.last = err;
        self.n += 1;
        self.sum += err;
        // `!(err < bound)`: NaN is an exceedance (`err >= bound` is false for NaN).
        if !(err < self.bound) {
            if !self.was_above {
                // A new excursion; whether it continues the one before is decided when
                // it ends (`excursion_ended`).
                let dip = if self.had_excursion { t - self.below_since } else { f64::INFINITY };
                (self.prev_above_since, self.dip_s) = (self.above_since, dip);
                self.above_since = t;
            }
            (self.was_above, self.had_excursion) = (true, true);
            self.last_above = t;
            self.settle_from = t + self.dt;
            self.after_from = f64::INFINITY;
            // Only a window that received samples needs clearing (a run above the bound
            // step after step costs nothing here).
            if self.n_after > 0 {
                (self.n_after, self.sum_sq_after, self.max_after) = (0, 0.0, 0.0);
                self.ape_after.clear();
            }
        } else {
            if self.was_above {
                self.excursion_ended(t);
            }
            self.was_above = false;
            if t >= self.after_from {
                self.n_after += 1;
                self.sum_sq_after += err * err;
                self.max_after = nan_max(self.max_after, err);
                self.ape_after.push(err);
            }
        }
    }

    /// The excursion above the bound ended at `t`: a dip below before it shorter than
    /// the excursion itself was an overshoot of the same transient (the two are one),
    /// and the window after settle starts the dwell after the settle time.
    fn excursion_ended(&mut self, t: f64) {
        if self.dip_s < t - self.above_since {
            self.above_since = self.prev_above_since;
        }
        self.below_since = t;
        self.after_from = self.settle_from + self.dwell.unwrap_or(self.settle_from - self.above_since);
    }

    /// The figures of a run that ended at `sim_time` (the time of the last sample).
    pub fn figures(&self, sim_time: f64) -> ErrorFigures {
        let settle_time_s = (self.last_above < sim_time).then_some(self.settle_from);
        let window = settle_time_s.filter(|_| self.n_after > 0);
        ErrorFigures {
            final_error_deg: if self.n == 0 { f64::NAN } else { self.last },
            settle_time_s,
            after_settle_from_s: settle_time_s.map(|_| self.after_from),
            max_error_after_settle_deg: window.map(|_| self.max_after),
            mean_error_whole_run_deg: self.sum / self.n.max(1) as f64,
            rms_error_after_settle_deg: window.map(|_| (self.sum_sq_after / self.n_after as f64).sqrt()),
            ape_after_settle_deg: window.and_then(|_| self.ape_after.quantile(self.confidence)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The definitions applied to the whole stored history: the settle time one period
    /// after the last sample at or above the bound, the window after settle from there
    /// plus the dwell (default: the last excursion's length, from its first sample above
    /// the bound to the settle time), its APE the nearest-rank quantile.
    fn from_history(errors: &[(f64, f64)], dt: f64, bound: f64, dwell: Option<f64>, sim_time: f64) -> ErrorFigures {
        let last_above = errors.iter().filter(|e| e.1 >= bound).map(|e| e.0).fold(0.0, f64::max);
        let settle = (last_above < sim_time).then_some(last_above + dt);
        // The excursions: maximal runs of samples above the bound (NaN counts as above;
        // the run starts in one at t = 0), a run merged into the one before when the stay
        // below between them is shorter than the run itself (an overshoot).
        let mut runs: Vec<(f64, f64)> = Vec::new(); // (start, first time below after it)
        let mut k = 0;
        while k < errors.len() {
            let above = |j: usize| !(errors[j].1 < bound);
            if !above(k) {
                k += 1;
                continue;
            }
            let start = if runs.is_empty() && k == 0 { 0.0 } else { errors[k].0 };
            while k < errors.len() && above(k) {
                k += 1;
            }
            let end = errors.get(k).map_or(f64::INFINITY, |e| e.0);
            match runs.last_mut() {
                Some(prev) if start - prev.1 < end - start => prev.1 = end,
                _ => runs.push((start, end)),
            }
        }
        let since = runs.last().map_or(0.0, |r| r.0);
        let from = settle.map(|s| s + dwell.unwrap_or(s - since));
        let after: Vec<f64> = errors.iter().filter(|(t, _)| from.is_some_and(|f| *t >= f)).map(|e| e.1).collect();
        let window = from.filter(|_| !after.is_empty());
        let mut sorted = after.clone();
        sorted.sort_by(f64::total_cmp);
        let rank = (0.95 * sorted.len() as f64).ceil() as usize;
        ErrorFigures {
            final_error_deg: errors.last().map_or(f64::NAN, |e| e.1),
            settle_time_s: settle,
            after_settle_from_s: from,
            max_error_after_settle_deg: window.map(|_| after.iter().fold(0.0f64, |a, e| a.max(*e))),
            mean_error_whole_run_deg: errors.iter().map(|e| e.1).sum::<f64>() / errors.len().max(1) as f64,
            rms_error_after_settle_deg: window
                .map(|_| (after.iter().map(|e| e * e).sum::<f64>() / after.len() as f64).sqrt()),
            ape_after_settle_deg: window.map(|_| sorted[rank.max(1) - 1]),
        }
    }

    #[test]
    fn online_figures_equal_those_of_the_history() {
        let dt = 0.1;
        let mut lcg = acs_test_support::rng::Lcg64(7);
        let mut rnd = || lcg.uniform();
        for case in 0..40 {
            let steps = 1 + case * 37;
            // A decaying error with noise that crosses the 1-degree bound now and then;
            // in some cases the last sample is above the bound (never settles).
            let errors: Vec<(f64, f64)> = (0..=steps)
                .map(|k| {
                    let t = k as f64 * dt;
                    let base = 5.0 * (-(k as f64) / (steps as f64 / 3.0)).exp();
                    let last_up = case % 4 == 0 && k == steps;
                    (t, if last_up { 2.0 } else { base + 1.5 * rnd() * rnd() })
                })
                .collect();
            let sim_time = steps as f64 * dt;
            // The default dwell, none, and one that may reach past the end.
            let dwell = [None, Some(0.0), Some(3.0)][case % 3];
            let mut s = ErrorStats::new(dt, 1.0, dwell, 0.95);
            for (t, e) in &errors {
                s.push(*t, *e);
            }
            let (a, b) = (s.figures(sim_time), from_history(&errors, dt, 1.0, dwell, sim_time));
            assert_eq!(a.settle_time_s, b.settle_time_s, "case {case}");
            assert_eq!(a.after_settle_from_s, b.after_settle_from_s, "case {case}");
            // Bit for bit: the sums run in time order in both.
            for (x, y) in [
                (a.final_error_deg, b.final_error_deg),
                (a.mean_error_whole_run_deg, b.mean_error_whole_run_deg),
                (a.rms_error_after_settle_deg.unwrap_or(-1.0), b.rms_error_after_settle_deg.unwrap_or(-1.0)),
                (a.max_error_after_settle_deg.unwrap_or(-1.0), b.max_error_after_settle_deg.unwrap_or(-1.0)),
            ] {
                assert_eq!(x.to_bits(), y.to_bits(), "case {case}: {x} vs {y}");
            }
            // The APE is the upper edge of the histogram bin of the exact quantile: never
            // below it, above it by less than one bin (and never above the maximum).
            match (a.ape_after_settle_deg, b.ape_after_settle_deg) {
                (Some(x), Some(y)) => assert!(y <= x && x <= y * MagnitudeQuantile::RATIO, "case {case}: {x} vs {y}"),
                (x, y) => assert_eq!(x, y, "case {case}"),
            }
        }
    }

    /// The figures after settle describe the hold, not the end of the transient: on
    /// `e(t) = e0 exp(−t/τ) + a |sin ωt|` (a decaying transient plus a known bounded
    /// "noise" of amplitude `a`, far below the bound), the settle time lies where the
    /// closed form puts the last crossing, `τ ln(e0 / b)` to `τ ln(e0 / (b − a))`; over
    /// the window after it (dwell long enough for the transient to fall below 1e-4 a) the
    /// maximum is `a` (0.5 %: the sampled peak of |sin|), the RMS `a/√2` (1 %: whole
    /// periods up to one), the 95 % APE `a sin(0.95 π/2)` (the quantile of a|sin| over
    /// whole periods; 1 %: one bin, 0.39 %, and the partial period). The last crossing
    /// alone (no dwell) would report a maximum just below the bound, 20 times `a`.
    #[test]
    fn figures_after_settle_match_the_closed_form_of_a_decaying_transient() {
        let (e0, tau, b, a, w, dt) = (5.0, 10.0, 1.0, 0.05, 2.0 * std::f64::consts::PI / 7.0, 0.01);
        let t_end = 400.0;
        let e = |t: f64| e0 * (-t / tau).exp() + a * (w * t).sin().abs();
        // Transient below 1e-4 a after settle + dwell: t > τ ln(e0 / (1e-4 a)).
        let dwell = tau * (e0 / (1e-4 * a)).ln();
        let stats = |dwell: Option<f64>| {
            let mut s = ErrorStats::new(dt, b, dwell, 0.95);
            let n = (t_end / dt).round() as u64;
            for k in 0..=n {
                s.push(k as f64 * dt, e(k as f64 * dt));
            }
            s.figures(n as f64 * dt)
        };
        let f = stats(Some(dwell));
        let ts = f.settle_time_s.unwrap();
        let (lo, hi) = (tau * (e0 / b).ln(), tau * (e0 / (b - a)).ln() + dt);
        assert!(ts > lo && ts <= hi, "settle {ts} outside [{lo}, {hi}]");
        assert_eq!(f.after_settle_from_s, Some(ts + dwell));
        let max = f.max_error_after_settle_deg.unwrap();
        let rms = f.rms_error_after_settle_deg.unwrap();
        let ape = f.ape_after_settle_deg.unwrap();
        let ape_closed = a * (0.95 * std::f64::consts::FRAC_PI_2).sin();
        eprintln!(
            "settle {ts} s in [{lo:.3}, {hi:.3}]; max {max:.5} (a {a}), rms {rms:.5} (a/√2 {:.5}), APE {ape:.5} ({ape_closed:.5})",
            a / 2f64.sqrt()
        );
        assert!((max / a - 1.0).abs() < 5e-3, "max {max} vs {a}");
        assert!((rms / (a / 2f64.sqrt()) - 1.0).abs() < 1e-2, "rms {rms}");
        assert!((ape / ape_closed - 1.0).abs() < 1e-2, "APE {ape} vs {ape_closed}");
        // Without a dwell the window starts at the last crossing: the bound, not the hold.
        let last_crossing = stats(Some(0.0)).max_error_after_settle_deg.unwrap();
        assert!(last_crossing > 0.9 * b, "{last_crossing}");
        // The default dwell (the excursion's length: here the settle time again, the run
        // starts above the bound) leaves e0 exp(−2 ts/τ) ≈ b²/e0 of the transient.
        let d = stats(None);
        assert_eq!(d.after_settle_from_s, Some(2.0 * d.settle_time_s.unwrap()));
        let m = d.max_error_after_settle_deg.unwrap();
        let residue = e0 * (-2.0 * d.settle_time_s.unwrap() / tau).exp();
        assert!(m >= a * 0.995 && m <= residue + a, "{m} vs {residue} + {a}");
        // A late excursion (the error above the bound for 3 s from 300 s, as after a new
        // target): the default dwell is that excursion's length, not the time since t = 0.
        let mut s = ErrorStats::new(dt, b, None, 0.95);
        let n = (t_end / dt).round() as u64;
        for k in 0..=n {
            let t = k as f64 * dt;
            s.push(t, if (300.0..303.0).contains(&t) { 2.0 } else { a });
        }
        let late = s.figures(n as f64 * dt);
        let ts = late.settle_time_s.unwrap();
        assert!((ts - 303.0).abs() < 1e-9, "{ts}");
        assert!((late.after_settle_from_s.unwrap() - 306.0).abs() < 1e-6, "{late:?}");
        // A dwell past the end: an empty window, its figures null (not 0), its start said.
        let past = stats(Some(1e6));
        assert!(past.after_settle_from_s.is_some() && past.max_error_after_settle_deg.is_none());
        assert!(past.rms_error_after_settle_deg.is_none() && past.ape_after_settle_deg.is_none());
    }

    /// Statistics of `errors` sampled every `dt` from 0, ended at the last sample, with
    /// the window after settle starting at the settle time (no dwell).
    fn stats_of(errors: &[f64], dt: f64) -> ErrorFigures {
        let mut s = ErrorStats::new(dt, 1.0, Some(0.0), 0.95);
        for (k, e) in errors.iter().enumerate() {
            s.push(k as f64 * dt, *e);
        }
        s.figures((errors.len() - 1) as f64 * dt)
    }

    #[test]
    fn a_nan_error_is_never_below_the_bound() {
        let dt = 0.5;
        // Settled from t = 1.0 (last exceedance at 0.5), then NaN at the last sample: the
        // run has not settled, and nothing is reported as a small number.
        let f = stats_of(&[3.0, 2.0, 0.5, 0.25, f64::NAN], dt);
        assert_eq!(f.settle_time_s, None);
        assert_eq!(f.max_error_after_settle_deg, None);
        assert!(
            f.final_error_deg.is_nan() && f.mean_error_whole_run_deg.is_nan() && f.rms_error_after_settle_deg.is_none(),
            "{f:?}"
        );
        // NaN as the very first sample and everything below the bound after it: the NaN
        // counts as an exceedance at t = 0, so the settle time is one period later (not 0
        // or "before the first sample"), and the mean stays NaN.
        let f = stats_of(&[f64::NAN, 0.5, 0.25, 0.125], dt);
        assert_eq!(f.settle_time_s, Some(dt));
        assert_eq!(f.max_error_after_settle_deg, Some(0.5));
        assert!(f.mean_error_whole_run_deg.is_nan());
        assert_eq!(f.final_error_deg, 0.125);
        // NaN in the middle: the settle time restarts after it (the last exceedance is the
        // NaN at t = 1.0), and the post-settle RMS covers the two samples after it only.
        let f = stats_of(&[0.5, 0.5, f64::NAN, 0.6, 0.8], dt);
        assert_eq!(f.settle_time_s, Some(1.5));
        assert_eq!(f.max_error_after_settle_deg, Some(0.8));
        assert_eq!(f.rms_error_after_settle_deg, Some(((0.36f64 + 0.64) / 2.0).sqrt()));
        // An infinite error is an exceedance like any other.
        assert_eq!(stats_of(&[0.5, f64::INFINITY], dt).settle_time_s, None);
    }

    #[test]
    fn nan_extremes_propagate_where_f64_max_would_hide_them() {
        assert_eq!(f64::max(1.0, f64::NAN), 1.0, "the trap: f64::max drops the NaN");
        assert!(nan_max(1.0, f64::NAN).is_nan() && nan_max(f64::NAN, 1.0).is_nan());
        assert!(nan_min(1.0, f64::NAN).is_nan() && nan_min(f64::NAN, -1.0).is_nan());
        assert_eq!(nan_max(-2.0, 3.0), 3.0);
        assert_eq!(nan_min(-2.0, 3.0), -2.0);
        let folded = [0.1, f64::NAN, 0.3].iter().fold(0.0, |a, x| nan_max(a, *x));
        assert!(folded.is_nan());
    }
}
