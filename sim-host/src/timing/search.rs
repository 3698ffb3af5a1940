//! Seeded (μ+λ) evolutionary search for the input that maximises the cost of one flight
//! step (see docs/timing.md).
//!
//! Genome: [`Input`]. Variation: Gaussian steps on a few frame values at a random scale
//! (log-uniform over 3.5 decades of the field's typical magnitude), structural mutations
//! (flip a valid bit; set a value to NaN, ±inf, ±1e30, f32::MAX, a subnormal, 0; align
//! the body rate and the attitude error with a thruster column or an attainable-set facet
//! normal, where the allocation does the most work; move the clock; grow, shrink or
//! repeat the prefix, up to a full MEKF state history; move one sensor's sample time —
//! late, at a node of the history, in the future, held — or the gyro increment; change
//! the commanded mode; flip a failure bit) and uniform crossover of the measured frames.
//! Generation 0 adds hand-made worst cases of the state history ([`history_inputs`]).
//! Selection: the μ costliest of parents and children.
//!
//! Reproducibility: the random stream is ChaCha8 seeded with `seed` and the flight code
//! is deterministic under lockstep, but the cost counter reads ±1 tick (40 instructions)
//! between runs, which can reorder near-ties in the selection: the search path is
//! reproducible up to that jitter. Use `max_evaluations` for a run that does not depend
//! on the machine's speed (the time budget then only guards).

use super::{Cost, Evaluator, FRAME_FIELDS, Input, MAX_PREFIX, N_FLOATS, Target, floats_mut};
use acs_flight::estimation::determination::{MAX_PROPAGATION_DT_S, MAX_PROPAGATION_PIECES};
use acs_flight::estimation::history::HISTORY_DEPTH;
use acs_flight::link::{SampleTimes, SensorFrame, valid};
use acs_flight::params::{AttitudeSource, Mode};
use anyhow::Result;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// Typical magnitude of each f32 gene (scale of the Gaussian steps), in frame order.
fn gene_scale(i: usize) -> f32 {
    let mut end = 0;
    for (name, n) in FRAME_FIELDS {
        end += n;
        if i < end {
            return match name {
                "q_ib_xyzw" | "rate_rad_s" | "css_output" => 0.5,
                "gyro_angle_rad" => 0.05,
                "wheel_speed_rad_s" => 300.0,
                "mag_field_t" => 5e-5,
                "gnss_pos_m" => 7e6,
                "gnss_vel_m_s" => 7.5e3,
                "gnss_j2000_s" => 86_400.0,
                _ => 1.0,
            };
        }
    }
    1.0
}

/// Whole days since J2000.0 that take the time and field models down unusual paths
/// (epoch, far past and future, overflow of the day count).
const SPECIAL_DAYS: [i32; 8] = [0, -1, -36_525, 36_525, 1_000_000, -1_000_000, i32::MAX, i32::MIN];

/// A plausible GNSS fix when the scenario's initial frame has none: a 7,000 km circular
/// equatorial orbit on 2026-03-20 (days since J2000.0).
const SYNTHETIC_FIX: ([f32; 3], [f32; 3], i32, f32) = ([7.0e6, 0.0, 0.0], [0.0, 7.546e3, 0.0], 9_575, 43_200.0);

/// Longest gap between two frames that the MEKF still propagates across (pieces of at
/// most `MAX_PROPAGATION_DT_S`), s, less half a piece (f32 rounding of the elapsed time).
fn longest_propagated_gap_s() -> f64 {
    (f64::from(MAX_PROPAGATION_PIECES) - 0.5) * f64::from(MAX_PROPAGATION_DT_S)
}

/// Values that take flight code down unusual paths (validation, guards, range reduction).
const SPECIAL: [f32; 12] =
    [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -0.0, 1e30, -1e30, f32::MAX, 1e-40, 1e6, -1e6, 1.0];

#[derive(Clone, Debug)]
pub struct SearchOptions {
    /// Wall-time budget of the search (evaluation of the seeds included).
    pub budget: Duration,
    pub seed: u64,
    /// Stop after this many evaluations even if time is left (machine-independent runs).
    pub max_evaluations: Option<u64>,
    /// μ (parents kept) and λ (children per generation).
    pub mu: usize,
    pub lambda: usize,
    /// Inputs evaluated in the first generation (e.g. the corpus).
    pub seeds: Vec<Input>,
    /// Extra directions to align demands with (e.g. worst LP demands), body axes.
    pub directions: Vec<[f32; 3]>,
}

impl Default for SearchOptions {
    fn default() -> Self {
        Self {
            budget: Duration::from_secs(20),
            seed: 1,
            max_evaluations: None,
            mu: 8,
            lambda: 16,
            seeds: Vec::new(),
            directions: Vec::new(),
        }
    }
}

/// An evaluated input.
#[derive(Clone, Debug)]
pub struct Found {
    pub input: Input,
    pub cost: Cost,
}

#[derive(Clone, Debug)]
pub struct SearchResult {
    pub worst: Found,
    /// Mean instructions over every accepted evaluation of the search.
    pub mean_instructions: f64,
    /// Mean instructions of the final population (the μ kept).
    pub population_mean: f64,
    /// The nominal input (initial state of the scenario) and its cost.
    pub nominal: Option<Cost>,
    pub evaluations: u64,
    /// Inputs the flight code refused at upload or mode command (failure masks, modes).
    pub rejected: u64,
    pub generations: u64,
    pub elapsed_s: f64,
    /// The costliest input whose costliest step ran in each mode (telemetry code).
    pub per_mode: BTreeMap<u8, Found>,
    /// The costliest input without extra failures (the scenario's own actuators).
    pub worst_no_failures: Option<Found>,
    /// The final population, costliest first.
    pub population: Vec<Found>,
}

struct Mutator<'a> {
    target: &'a Target,
    directions: Vec<[f32; 3]>,
    rng: ChaCha8Rng,
}

impl Mutator<'_> {
    fn normal(&mut self) -> f32 {
        let x: f64 = StandardNormal.sample(&mut self.rng);
        x as f32
    }

    fn unit(&mut self) -> f64 {
        self.rng.random::<f64>()
    }

    /// A frame of the input (the measured one or a prefix frame).
    fn pick_frame<'b>(&mut self, x: &'b mut Input) -> &'b mut SensorFrame {
        let n = x.prefix.len();
        let k = if n > 0 && self.unit() < 0.3 { self.rng.random_range(0..n) } else { n };
        if k < n { &mut x.prefix[k] } else { &mut x.frame }
    }

    /// One random mutation of `x` (operators drawn by weight).
    fn mutate(&mut self, x: &mut Input) {
        let op = self.rng.random_range(0..100u32);
        match op {
            0..34 => self.gaussian_steps(x),
            34..44 => {
                let i = self.rng.random_range(0..N_FLOATS);
                let s = SPECIAL[self.rng.random_range(0..SPECIAL.len())];
                let f = self.pick_frame(x);
                if let Some(g) = floats_mut(f).into_iter().nth(i) {
                    *g = s;
                }
            }
            44..52 => {
                // Any of the 8 valid bits (GNSS and CSS included).
                let b = self.rng.random_range(0..8);
                let f = self.pick_frame(x);
                f.valid ^= 1 << b;
            }
            52..66 => self.demand_along_direction(x),
            66..70 => {
                // The frame's clock; its samples keep their ages.
                let random = self.rng.random::<u64>() >> self.rng.random_range(0..64);
                let step = self.rng.random_range(0..3);
                let f = self.pick_frame(x);
                let t = match step {
                    0 => random,
                    1 => f.time_us.wrapping_add((self.target.dt_s * 1e6) as u64),
                    _ => 0,
                };
                retime(f, t);
            }
            70..76 => self.mutate_estimation(x),
            76..84 => self.mutate_prefix(x),
            84..94 => self.mutate_sample_times(x),
            94..97 if !self.target.modes.is_empty() => {
                let modes = &self.target.modes;
                x.mode = if self.unit() < 0.15 {
                    None
                } else {
                    Some((modes[self.rng.random_range(0..modes.len())], self.unit() < 0.7))
                };
            }
            94..100 if self.target.n_actuators > 0 => {
                x.failed_mask ^= 1 << self.rng.random_range(0..self.target.n_actuators.min(16));
            }
            _ => {
                let i = self.rng.random_range(0..N_FLOATS);
                let s = gene_scale(i) * self.normal();
                if let Some(g) = floats_mut(&mut x.frame).into_iter().nth(i) {
                    *g = s;
                }
            }
        }
    }

    /// Gaussian steps on 1-3 values at a log-uniform scale.
    fn gaussian_steps(&mut self, x: &mut Input) {
        let n = self.rng.random_range(1..=3);
        for _ in 0..n {
            let i = self.rng.random_range(0..N_FLOATS);
            let s = gene_scale(i) * 10f32.powf(-3.0 + 3.5 * self.unit() as f32);
            let d = s * self.normal();
            let f = self.pick_frame(x);
            let v = floats_mut(f);
            let g = v.into_iter().nth(i).expect("i < N_FLOATS");
            *g = if g.is_finite() { *g + d } else { d };
        }
        if self.unit() < 0.5 {
            normalise(&mut x.frame.q_ib_xyzw);
        }
    }

    /// Demand along a thruster column / facet normal: body rate and attitude error both
    /// along ±d, magnitudes log-uniform.
    fn demand_along_direction(&mut self, x: &mut Input) {
        let d = self.directions[self.rng.random_range(0..self.directions.len())];
        let sign = if self.unit() < 0.5 { -1.0 } else { 1.0 };
        let w = sign * 10f32.powf(-3.0 + 4.0 * self.unit() as f32);
        let th = (sign as f64) * std::f64::consts::PI * self.unit();
        let f = &mut x.frame;
        f.rate_rad_s = d.map(|c| c * w);
        if self.unit() < 0.7 {
            let (s, c) = (th / 2.0).sin_cos();
            f.q_ib_xyzw = [d[0] * s as f32, d[1] * s as f32, d[2] * s as f32, c as f32];
        }
    }

    /// The prefix: repeat the measured frame (loads integrators and the PWPF; up to
    /// `MAX_PREFIX` frames fill the MEKF's history; half the time 1-4 frames, which keeps
    /// the mean evaluation short), add a mutated copy, or drop a frame.
    fn mutate_prefix(&mut self, x: &mut Input) {
        match self.rng.random_range(0..3) {
            0 => {
                let n = if self.unit() < 0.5 {
                    self.rng.random_range(1..=4.min(MAX_PREFIX))
                } else {
                    self.rng.random_range(1..=MAX_PREFIX)
                };
                x.prefix = vec![x.frame; n];
            }
            1 if x.prefix.len() < MAX_PREFIX => {
                let mut f = x.frame;
                f.rate_rad_s = f.rate_rad_s.map(|r| r * (1.0 + 0.5 * self.normal()));
                x.prefix.push(f);
            }
            _ => {
                x.prefix.pop();
            }
        }
        let dt_us = (self.target.dt_s * 1e6) as u64;
        // Consistent clocks along the sequence (the measured frame last), each frame's
        // samples moved with it (same ages: every frame brings new samples).
        let n = x.prefix.len() as u64;
        for (k, p) in x.prefix.iter_mut().enumerate() {
            retime(p, x.frame.time_us.wrapping_sub((n - k as u64) * dt_us));
        }
    }

    /// Protocol 13's inputs: one sensor's sample time (any age up to beyond
    /// `max_sample_age_s` and the history, an earlier frame's gyro time — where the
    /// history's nodes lie —, the future, held from the frame before, or every sensor at
    /// the frame's time: all new at once) or the gyro increment (consistent with the rate,
    /// none, an absurd interval or angle).
    fn mutate_sample_times(&mut self, x: &mut Input) {
        let n = x.prefix.len();
        let k = if n > 0 && self.unit() < 0.3 { self.rng.random_range(0..n) } else { n };
        let earlier: Vec<SampleTimes> = x.prefix.iter().take(k).map(|p| p.sampled_at).collect();
        let sensor = self.rng.random_range(0..SENSORS);
        let op = self.rng.random_range(0..10u32);
        let age_us = 10f64.powf(6.8 * self.unit()) as u64;
        let ahead_us = 10f64.powf(7.0 * self.unit()) as u64;
        let dt_us = (self.target.dt_s * 1e6) as u64;
        let node = earlier.get(self.rng.random_range(0..earlier.len().max(1))).map(|t| t.gyro_us);
        let plus = self.rng.random_range(0..2u64);
        let (special, component) = (SPECIAL[self.rng.random_range(0..SPECIAL.len())], self.rng.random_range(0..3));
        let absurd = [1, u32::MAX, self.rng.random::<u32>()][self.rng.random_range(0..3)];
        let f = if k < n { &mut x.prefix[k] } else { &mut x.frame };
        let now = f.time_us;
        let held = earlier.last().map_or(now, |t| {
            let mut t = *t;
            *sample_time(&mut t, sensor)
        });
        match op {
            0 | 1 => *sample_time(&mut f.sampled_at, sensor) = now.saturating_sub(age_us),
            2 => *sample_time(&mut f.sampled_at, sensor) = node.map_or(now, |t| t.saturating_add(plus)),
            3 => {
                *sample_time(&mut f.sampled_at, sensor) =
                    if plus == 0 { now.saturating_add(ahead_us) } else { u64::MAX }
            }
            4 => *sample_time(&mut f.sampled_at, sensor) = held,
            5 => f.sampled_at = SampleTimes::all(now),
            6 | 7 => {
                // The increment of the rate over the interval since the previous frame's gyro.
                let since = earlier.last().map_or(dt_us, |t| f.sampled_at.gyro_us.wrapping_sub(t.gyro_us));
                f.gyro_interval_us = u32::try_from(since).unwrap_or(u32::MAX);
                let s = f.gyro_interval_us as f32 * 1e-6;
                f.gyro_angle_rad = f.rate_rad_s.map(|w| w * s);
            }
            8 => f.gyro_interval_us = if plus == 0 { 0 } else { absurd },
            _ => f.gyro_angle_rad[component] = special,
        }
    }

    /// The inputs of the estimation stage: a plausible GNSS fix (the scenario's first, or
    /// a synthetic one), the fix's day count, plausible coarse-sun-sensor outputs, or a
    /// clock gap before the measured frame up to the longest the MEKF propagates across.
    fn mutate_estimation(&mut self, x: &mut Input) {
        let nominal = self.target.nominal;
        match self.rng.random_range(0..4) {
            0 => {
                let (pos, vel, days, secs) = if nominal.valid & valid::GNSS != 0 {
                    (nominal.gnss_pos_m, nominal.gnss_vel_m_s, nominal.gnss_j2000_days, nominal.gnss_j2000_s)
                } else {
                    SYNTHETIC_FIX
                };
                let f = self.pick_frame(x);
                (f.gnss_pos_m, f.gnss_vel_m_s, f.gnss_j2000_days, f.gnss_j2000_s) = (pos, vel, days, secs);
                f.valid |= valid::GNSS;
            }
            1 => {
                let special = self.unit() < 0.2;
                let step = (10f64.powf(4.0 * self.unit()) as i32).max(1) * if self.unit() < 0.5 { -1 } else { 1 };
                let pick = SPECIAL_DAYS[self.rng.random_range(0..SPECIAL_DAYS.len())];
                let f = self.pick_frame(x);
                f.gnss_j2000_days = if special { pick } else { f.gnss_j2000_days.saturating_add(step) };
            }
            2 => {
                let out = if nominal.valid & valid::CSS != 0 && self.unit() < 0.5 {
                    nominal.css_output
                } else {
                    // Lit heads of a random Sun direction, with the default head layout.
                    let d = [self.normal(), self.normal(), self.normal()];
                    let mut o = [0.0f32; acs_flight::types::MAX_CSS_HEADS];
                    let normals = self.target.estimation.unwrap_or_default().css_normals_body;
                    for (o, n) in o.iter_mut().zip(normals) {
                        let dn = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-20);
                        *o = ((n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / dn).max(0.0);
                    }
                    o
                };
                let f = self.pick_frame(x);
                f.css_output = out;
                f.valid |= valid::CSS;
            }
            _ => {
                // A gap before the measured frame (a prefix frame added if there is none).
                if x.prefix.is_empty() {
                    x.prefix.push(x.frame);
                }
                let last = x.prefix.last().map_or(x.frame.time_us, |p| p.time_us);
                let gap_us = (longest_propagated_gap_s() * 1e6 * self.unit().sqrt()) as u64;
                retime(&mut x.frame, last.wrapping_add(gap_us));
            }
        }
    }

    /// Uniform crossover of the measured frames (the rest from `a`).
    fn cross(&mut self, a: &Input, b: &Input) -> Input {
        let mut c = a.clone();
        let fb = super::floats(&b.frame);
        for (g, v) in floats_mut(&mut c.frame).into_iter().zip(fb) {
            if self.unit() < 0.5 {
                *g = v;
            }
        }
        if self.unit() < 0.5 {
            c.frame.valid = b.frame.valid;
        }
        if self.unit() < 0.5 {
            c.frame.gnss_j2000_days = b.frame.gnss_j2000_days;
        }
        c
    }
}

/// Sensors with a sample time in `SampleTimes`.
const SENSORS: usize = 6;

/// Sample time of sensor `i` (gyro, star tracker, fine Sun, CSS, magnetometer, GNSS).
fn sample_time(t: &mut SampleTimes, i: usize) -> &mut u64 {
    match i {
        0 => &mut t.gyro_us,
        1 => &mut t.star_tracker_us,
        2 => &mut t.sun_sensor_us,
        3 => &mut t.css_us,
        4 => &mut t.magnetometer_us,
        _ => &mut t.gnss_us,
    }
}

/// Moves the frame's clock to `t` and every sample time with it (the samples keep their
/// ages; modular, as the genome's clocks may be anything).
fn retime(f: &mut SensorFrame, t: u64) {
    let d = t.wrapping_sub(f.time_us);
    f.time_us = t;
    for i in 0..SENSORS {
        let s = sample_time(&mut f.sampled_at, i);
        *s = s.wrapping_add(d);
    }
}

fn normalise(q: &mut [f32; 4]) {
    let n = q.iter().map(|x| x * x).sum::<f32>().sqrt();
    if n.is_finite() && n > 1e-20 {
        for x in q.iter_mut() {
            *x /= n;
        }
    }
}

/// Length of the sweep's fixed estimation sequences (prefix frames before the measured one).
const SWEEP_PREFIX: usize = 4;

/// The fixed inputs every search starts from: the nominal frame, attitude errors of 0.1,
/// 1 and 3 rad about each body axis and each thruster direction with rates of 0.01 and
/// 0.3 rad/s, every valid bit cleared in turn (GNSS and CSS included), each mode locked,
/// two sequences for the stateful estimation stage: the nominal frame stepped
/// `SWEEP_PREFIX + 1` times one control period apart (filter initialised on the first,
/// propagated and updated on the rest), and the same with the GNSS fix only in the first
/// frame and the longest gap the MEKF still propagates across before the measured frame;
/// and for a scenario on the MEKF the state history's worst cases ([`history_inputs`]).
/// (Also the "fixed sweep" the search is compared with: see [`sweep`].)
pub fn sweep_inputs(t: &Target) -> Vec<Input> {
    let base = t.nominal_input();
    let mut v = vec![base.clone()];
    let mut dirs = vec![[1.0f32, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    dirs.extend(t.directions.iter().take(8));
    for d in dirs {
        for th in [0.1f32, 1.0, 3.0] {
            for w in [0.01f32, 0.3] {
                let mut x = base.clone();
                let (s, c) = (th / 2.0).sin_cos();
                x.frame.q_ib_xyzw = [d[0] * s, d[1] * s, d[2] * s, c];
                x.frame.rate_rad_s = d.map(|c| c * w);
                v.push(x);
            }
        }
    }
    for b in 0..8 {
        let mut x = base.clone();
        x.frame.valid &= !(1 << b);
        v.push(x);
    }
    let dt_us = (t.dt_s * 1e6).round() as u64;
    let at = |k: u64| {
        let mut f = base.frame;
        retime(&mut f, base.frame.time_us + k * dt_us);
        f
    };
    let mut x = base.clone();
    x.prefix = (0..SWEEP_PREFIX as u64).map(at).collect();
    x.frame = at(SWEEP_PREFIX as u64);
    v.push(x.clone());
    for p in x.prefix.iter_mut().skip(1) {
        p.valid &= !valid::GNSS;
    }
    x.frame.valid &= !valid::GNSS;
    let last = x.prefix.last().map_or(0, |p| p.time_us);
    retime(&mut x.frame, last + (longest_propagated_gap_s() * 1e6) as u64);
    v.push(x);
    for m in &t.modes {
        let mut x = base.clone();
        x.mode = Some((*m, true));
        v.push(x);
    }
    v.extend(history_inputs(t));
    v.extend(fdir_inputs(t).into_iter().map(|(_, x)| x));
    v
}

/// A fault a hand-made FDIR seed injects from its onset frame on ([`fdir_inputs`]).
#[derive(Clone, Copy, Debug)]
enum SeedFault {
    None,
    /// The tracker's attitude turned 180° about its boresight; Sun and field stay true.
    TrackerFlip,
    /// The tracker repeats its onset quaternion (fresh time tags).
    TrackerFrozen,
    /// Gyro axis `0` repeats its onset rate.
    GyroStuck(usize),
    /// Gyro axis `0` reads `1` rad/s more: the tracker's innovations grow linearly.
    GyroBias(usize, f64),
    /// Wheel `0`'s speed runs away by `1` rad/s per frame from the first frame on, whatever
    /// its torque command.
    WheelRunaway(usize, f32),
}

/// Frames before the measured one at which [`fdir_inputs`] start their faults: room for
/// the k-of-n windows (tracker 3 of 4, stuck after 3 repeats, bias 3 of 4 in the shipped
/// scenarios) and the steps after the declaration (restart, fallback) in the sequence.
const FDIR_ONSET_BEFORE_END: usize = 8;

/// Hand-made FDIR seeds (scenarios with a monitor only): `MAX_PREFIX` frames and the
/// measured one, one control period apart, of a live spacecraft — the true attitude turns
/// slowly (2.7e-3 rad/s) plus a small dither per axis, so no sensor repeats a value; the tracker reads the true attitude, the
/// Sun and the field turn with it in body axes, the gyro increment matches the rate — and
/// one fault from frame `MAX_PREFIX − FDIR_ONSET_BEFORE_END` on that drives one monitor to
/// its declaration within the sequence: tracker flipped or frozen (star-tracker monitor),
/// a gyro axis stuck (stuck test), a gyro bias step of 0.01 and 0.002 rad/s (bias-step
/// test), a wheel running away from its command (wheel residual). The wheel speeds are
/// static inputs, not following the commands: every wheel the flight code commands is
/// declared within the window (the live sequence included). Named, for
/// `sim-host timing seeds`.
pub fn fdir_inputs(t: &Target) -> Vec<(String, Input)> {
    let m = t.monitors();
    if !m.any() {
        return Vec::new();
    }
    let mut faults = vec![("live".to_string(), SeedFault::None)];
    if m.tracker {
        faults.push(("tracker-flip".into(), SeedFault::TrackerFlip));
        faults.push(("tracker-frozen".into(), SeedFault::TrackerFrozen));
    }
    for a in 0..3 {
        if m.gyro {
            faults.push((format!("gyro-stuck-{a}"), SeedFault::GyroStuck(a)));
        }
        if m.bias_step {
            for b in [0.01, 0.002] {
                faults.push((format!("gyro-bias-{a}-{b}"), SeedFault::GyroBias(a, b)));
            }
        }
    }
    if m.wheels {
        for i in 0..t.wheel_count().min(acs_flight::types::MAX_WHEELS) {
            faults.push((format!("wheel-runaway-{i}"), SeedFault::WheelRunaway(i, 5.0)));
        }
    }
    // With a mode table, each also entered in hold (not locked): the wheels fly there (the
    // wheel monitor judges only them) and a declaration can make the manager fall back.
    let hold = t.modes.contains(&Mode::Hold).then_some((Mode::Hold, false));
    let mut v = Vec::new();
    for (name, f) in faults {
        let x = fdir_sequence(t, f);
        if let Some(mode) = hold {
            v.push((format!("{name}@hold"), Input { mode: Some(mode), ..x.clone() }));
        }
        v.push((name, x));
    }
    v
}

/// The live sequence of [`fdir_inputs`] with `fault` from its onset frame on.
fn fdir_sequence(t: &Target, fault: SeedFault) -> Input {
    use nalgebra::{Unit, UnitQuaternion, Vector3};
    let n = MAX_PREFIX;
    let onset = n - FDIR_ONSET_BEFORE_END;
    let base = t.nominal;
    let dt_s = t.dt_s;
    let dt_us = ((dt_s * 1e6).round() as u64).max(1);
    let [x, y, z, w] = base.q_ib_xyzw.map(f64::from);
    let q0 = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
    let q0 = if q0.coords.iter().all(|c| c.is_finite()) { q0 } else { UnitQuaternion::identity() };
    // Slow (0.05 rad over the sequence): the CSS outputs, kept at the nominal frame's,
    // stay within a few degrees of the Sun, well inside the tracker monitor's witness limit.
    let w0 = Vector3::new(2e-3, -1.5e-3, 1e-3);
    // Inertial Sun and field: the nominal frame's, carried by the nominal attitude.
    let sun_i = q0 * Vector3::from(base.sun_dir.map(f64::from));
    let mag_i = q0 * Vector3::from(base.mag_field_t.map(f64::from));
    let boresight = t.estimation.map_or([0.0, 0.0, 1.0], |e| e.tracker_boresight_body).map(f64::from);
    let flip = UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::from(boresight)), std::f64::consts::PI);
    let (mut q, mut frames) = (q0, Vec::with_capacity(n + 1));
    let (mut q_onset, mut rate_onset) = (q0, w0);
    for k in 0..=n {
        // A dither of distinct consecutive values per axis (k·(a+3) mod 7, a+3 coprime to
        // 7): no gyro axis repeats.
        let rate = w0 + Vector3::from_fn(|a, _| 2e-5 * (((k * (a + 3)) % 7) as f64 - 3.0));
        if k > 0 {
            q *= UnitQuaternion::from_scaled_axis(rate * dt_s);
        }
        if k == onset {
            (q_onset, rate_onset) = (q, rate);
        }
        let on = k >= onset;
        let mut f = base;
        retime(&mut f, base.time_us + k as u64 * dt_us);
        f.valid |= valid::ATTITUDE | valid::RATE;
        let q_meas = match fault {
            SeedFault::TrackerFlip if on => q * flip,
            SeedFault::TrackerFrozen if on => q_onset,
            _ => q,
        };
        let c = q_meas.coords;
        f.q_ib_xyzw = [c[0] as f32, c[1] as f32, c[2] as f32, c[3] as f32];
        let mut gyro = rate;
        match fault {
            SeedFault::GyroStuck(a) if on => gyro[a] = rate_onset[a],
            SeedFault::GyroBias(a, b) if on => gyro[a] += b,
            _ => {}
        }
        f.rate_rad_s = gyro.map(|r| r as f32).into();
        f.gyro_angle_rad = (gyro * dt_s).map(|r| r as f32).into();
        f.gyro_interval_us = u32::try_from(dt_us).unwrap_or(u32::MAX);
        let body = |v: Vector3<f64>| -> [f32; 3] { (q.inverse() * v).map(|c| c as f32).into() };
        f.sun_dir = body(sun_i);
        f.mag_field_t = body(mag_i);
        // From the first frame on: the other wheels, held at the nominal speeds whatever
        // their commands, are declared within a few steps too.
        if let SeedFault::WheelRunaway(i, step) = fault
            && let Some(s) = f.wheel_speed_rad_s.get_mut(i)
        {
            *s += step * k as f32;
        }
        frames.push(f);
    }
    let frame = frames.pop().unwrap_or(base);
    Input { mode: None, failed_mask: 0, prefix: frames, frame }
}

/// Hand-made worst cases of the MEKF's state history (`estimation::history`, scenarios on
/// the MEKF only): `MAX_PREFIX` frames, then the measured one, one step apart (the
/// scenario's period, and faster clocks that put the frames of a full history with 0 to 3
/// sample nodes per frame just inside `max_sample_latency_s`: the flight code sets no
/// minimum step), each frame's samples new at its own time, the tracker and gyro
/// valid, and the gyro increment consistent with the rate. Variants:
/// - every sensor new at once in every frame (the measured one included);
/// - one sensor (tracker, fine Sun, CSS, magnetometer, GNSS, gyro) held at the first frame's
///   sample through the prefix, then late in the measured frame at the time of an earlier
///   frame where the oldest node of the full history lies — with 0 to 3 sample nodes per
///   frame besides the propagation node, frame `⌊((1 + m)·n + 1 − HISTORY_DEPTH)/(1 + m)⌋`,
///   i.e. maximum replay, when that frame is within `max_sample_latency_s` (older samples
///   are refused), and the oldest frame within it (for the CSS the fine Sun is cleared in
///   the measured frame, as the flight code prefers it);
/// - the tracker held, then tracker, CSS and magnetometer all late in the measured frame
///   (three replays in one step).
pub fn history_inputs(t: &Target) -> Vec<Input> {
    let Some(est) = t.estimation.filter(|e| e.source == AttitudeSource::Mekf) else {
        return Vec::new();
    };
    let n = MAX_PREFIX as u64;
    let base = t.nominal;
    let dt_us = ((t.dt_s * 1e6).round() as u64).max(1);
    let max_age_us = f64::from(est.max_sample_age_s) * 1e6;
    // A sample older than the latency horizon behind now is refused before any replay.
    let latency_us = f64::from(est.max_sample_latency_s) * 1e6;
    // Frames holding the full history with m = 0..3 sample nodes per frame besides the
    // propagation node.
    let frames_of_history = |m: u64| (HISTORY_DEPTH as u64 - 1).div_ceil(1 + m);
    // Faster clocks (the flight code sets no minimum step): for each m, the full history's
    // frames one step inside the latency horizon, so its oldest node can take a late sample.
    let mut steps: Vec<u64> = (0..4u64)
        .map(|m| ((latency_us.min(0.5 * max_age_us) / (frames_of_history(m) + 1) as f64) as u64).clamp(1, dt_us))
        .chain([dt_us])
        .collect();
    steps.sort_unstable();
    steps.dedup();
    let mut v = Vec::new();
    for step_us in steps {
        let frame_at = |k: u64| {
            let mut f = base;
            retime(&mut f, base.time_us + k * step_us);
            // The tracker and the gyro valid even where the scenario starts without them
            // (the mission: the tracker locks later): the filter starts on the first frame.
            f.valid |= valid::ATTITUDE | valid::RATE;
            f.gyro_interval_us = u32::try_from(step_us).unwrap_or(u32::MAX);
            f.gyro_angle_rad = f.rate_rad_s.map(|w| w * step_us as f32 * 1e-6);
            f
        };
        // Sensor `held` keeps the first frame's sample time through the sequence.
        let sequence = |held: Option<usize>| {
            let hold = |mut f: SensorFrame| {
                if let Some(s) = held {
                    *sample_time(&mut f.sampled_at, s) = *sample_time(&mut frame_at(0).sampled_at, s);
                }
                f
            };
            Input {
                mode: None,
                failed_mask: 0,
                prefix: (0..n).map(|k| hold(frame_at(k))).collect(),
                frame: hold(frame_at(n)),
            }
        };
        v.push(sequence(None));
        // Frames where the oldest node lies with m = 0..3 sample nodes per frame, and the
        // oldest frame within the latency horizon; a frame beyond the horizon only gives
        // refused samples (too old), so it is left out.
        let horizon = n.saturating_sub((latency_us.min(0.9 * max_age_us) / step_us as f64) as u64);
        let mut oldest: Vec<u64> = (0..4u64)
            .map(|m| ((1 + m) * n + 1).saturating_sub(HISTORY_DEPTH as u64) / (1 + m))
            .filter(|&j| j >= horizon)
            .chain([horizon])
            .map(|j| j.clamp(1, n - 1))
            .collect();
        oldest.sort_unstable();
        oldest.dedup();
        for &j in &oldest {
            let t_j = frame_at(j).time_us;
            for s in 0..SENSORS {
                let mut x = sequence(Some(s));
                *sample_time(&mut x.frame.sampled_at, s) = t_j;
                if s == 3 {
                    x.frame.valid = (x.frame.valid & !valid::SUN) | valid::CSS;
                }
                v.push(x);
            }
            let mut x = sequence(Some(1));
            x.frame.valid = (x.frame.valid & !valid::SUN) | valid::CSS;
            x.frame.sampled_at.star_tracker_us = t_j;
            x.frame.sampled_at.css_us = t_j + 1;
            x.frame.sampled_at.magnetometer_us = t_j + 2;
            v.push(x);
        }
    }
    v
}

/// The largest cost over [`sweep_inputs`] (the baseline a search must reach).
pub fn sweep(ev: &mut Evaluator) -> Result<Option<Found>> {
    let mut best: Option<Found> = None;
    for x in sweep_inputs(&ev.target) {
        if let Some(c) = ev.evaluate(&x)?
            && best.as_ref().is_none_or(|b| c.instructions > b.cost.instructions)
        {
            best = Some(Found { input: x, cost: c });
        }
    }
    Ok(best)
}

/// What the search keeps of every evaluation besides the population: the running sum
/// for the mean, the refused inputs, the costliest per mode and without failures.
#[derive(Default)]
struct Tally {
    sum_instructions: f64,
    n_ok: u64,
    rejected: u64,
    per_mode: BTreeMap<u8, Found>,
    no_fail: Option<Found>,
}

impl Tally {
    /// Records the cost `c` of `x` (`None`: refused) and adds it to `pop`.
    fn record(&mut self, x: Input, c: Option<Cost>, pop: &mut Vec<Found>) {
        let Some(c) = c else {
            self.rejected += 1;
            return;
        };
        self.sum_instructions += c.instructions as f64;
        self.n_ok += 1;
        let e = self.per_mode.entry(c.mode);
        let f = Found { input: x, cost: c };
        if f.input.failed_mask == 0 && self.no_fail.as_ref().is_none_or(|b| c.instructions > b.cost.instructions) {
            self.no_fail = Some(f.clone());
        }
        match e {
            std::collections::btree_map::Entry::Vacant(v) => {
                v.insert(f.clone());
            }
            std::collections::btree_map::Entry::Occupied(mut o) => {
                if c.instructions > o.get().cost.instructions {
                    o.insert(f.clone());
                }
            }
        }
        pop.push(f);
    }
}

/// Generation 0: the seeds, the sweep, then random variations of the nominal input, at
/// least `n` inputs.
fn generation0(m: &mut Mutator, opts: &SearchOptions, n: usize) -> Vec<Input> {
    let target = m.target;
    let mut gen0: Vec<Input> = opts.seeds.clone();
    gen0.extend(sweep_inputs(target));
    while gen0.len() < n {
        let mut x = target.nominal_input();
        for _ in 0..m.rng.random_range(1..=4) {
            m.mutate(&mut x);
        }
        gen0.push(x);
    }
    gen0
}

/// `lambda` children of the (sorted) population: binary tournament, crossover with
/// probability 0.15, then 1 + geometric(0.5) mutations.
fn children(m: &mut Mutator, pop: &[Found], lambda: usize) -> Vec<Input> {
    let mut children = Vec::with_capacity(lambda);
    for _ in 0..lambda {
        let pick = |m: &mut Mutator| {
            let (i, j) = (m.rng.random_range(0..pop.len()), m.rng.random_range(0..pop.len()));
            i.min(j) // the costlier of two (pop is sorted)
        };
        let a = pick(m);
        let mut x = if m.unit() < 0.15 {
            let b = pick(m);
            m.cross(&pop[a].input, &pop[b].input)
        } else {
            pop[a].input.clone()
        };
        // 1 + geometric(0.5) mutations.
        m.mutate(&mut x);
        while m.unit() < 0.5 {
            m.mutate(&mut x);
        }
        children.push(x);
    }
    children
}

/// Keeps the `mu` costliest. Stable: among equal costs the earlier (older) input stays.
fn keep(pop: &mut Vec<Found>, mu: usize) {
    pop.sort_by_key(|f| std::cmp::Reverse(f.cost.instructions));
    pop.truncate(mu);
}

/// Runs the search on `ev` (see the module documentation).
pub fn search(ev: &mut Evaluator, opts: &SearchOptions) -> Result<SearchResult> {
    let start = Instant::now();
    let target = ev.target.clone();
    let mut directions = target.directions.clone();
    directions.extend(opts.directions.iter().copied());
    let mut m = Mutator { target: &target, directions, rng: ChaCha8Rng::seed_from_u64(opts.seed) };
    let (mu, lambda) = (opts.mu.max(1), opts.lambda.max(1));
    let out_of_budget =
        |ev: &Evaluator| start.elapsed() >= opts.budget || opts.max_evaluations.is_some_and(|n| ev.evaluations >= n);
    let mut tally = Tally::default();
    let mut pop: Vec<Found> = Vec::new();
    let nominal = ev.evaluate(&target.nominal_input())?;
    for x in generation0(&mut m, opts, mu + lambda) {
        if out_of_budget(ev) && !pop.is_empty() {
            break;
        }
        let c = ev.evaluate(&x)?;
        tally.record(x, c, &mut pop);
    }
    keep(&mut pop, mu);
    anyhow::ensure!(!pop.is_empty(), "{}: the flight code refused every input", target.name);
    let mut generations = 0;
    while !out_of_budget(ev) {
        for x in children(&mut m, &pop, lambda) {
            let c = ev.evaluate(&x)?;
            tally.record(x, c, &mut pop);
        }
        keep(&mut pop, mu);
        generations += 1;
    }
    let population_mean = pop.iter().map(|f| f.cost.instructions as f64).sum::<f64>() / pop.len() as f64;
    Ok(SearchResult {
        worst: pop[0].clone(),
        mean_instructions: tally.sum_instructions / tally.n_ok.max(1) as f64,
        population_mean,
        nominal,
        evaluations: ev.evaluations,
        rejected: tally.rejected,
        generations,
        elapsed_s: start.elapsed().as_secs_f64(),
        per_mode: tally.per_mode,
        worst_no_failures: tally.no_fail,
        population: pop,
    })
}

/// A mode's name from its telemetry code ("none" without a mode table).
pub fn mode_name(code: u8) -> &'static str {
    Mode::from_code(code).map_or("none", Mode::name)
}

/// The estimation stage's telemetry flags by name (`acs_flight::link::estimate_flags`):
/// "att" attitude available, "mekf" filter running, "nav" navigation solution, "eclipse",
/// "sun" Sun seen; "-" for none.
pub fn estimate_names(flags: u16) -> String {
    use acs_flight::link::estimate_flags as e;
    let names: Vec<&str> = [
        (e::ATTITUDE, "att"),
        (e::MEKF, "mekf"),
        (e::NAVIGATION, "nav"),
        (e::ECLIPSE, "eclipse"),
        (e::SUN_SEEN, "sun"),
    ]
    .into_iter()
    .filter(|(b, _)| flags & b != 0)
    .map(|(_, n)| n)
    .collect();
    if names.is_empty() { "-".into() } else { names.join(" ") }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The step scales follow the frame's field layout: a marker written into each field
    /// of a frame is found at an index whose scale is that field's.
    #[test]
    fn gene_scales_follow_the_frame_layout() {
        type Set = fn(&mut SensorFrame);
        let cases: [(Set, f32); 5] = [
            (|f| f.wheel_speed_rad_s[0] = 123.0, 300.0),
            (|f| f.css_output[5] = 123.0, 0.5),
            (|f| f.gnss_pos_m[2] = 123.0, 7e6),
            (|f| f.gnss_vel_m_s[0] = 123.0, 7.5e3),
            (|f| f.gnss_j2000_s = 123.0, 86_400.0),
        ];
        for (set, scale) in cases {
            let mut f = SensorFrame::empty(0, 0);
            set(&mut f);
            let i = super::super::floats(&f).iter().position(|x| *x == 123.0).unwrap();
            assert_eq!(gene_scale(i), scale, "gene {i}");
        }
    }

    /// The FDIR seeds of the 3U mission with every monitor: the live sequence repeats no
    /// gyro axis and no quaternion between frames (the repeat tests stay quiet), and the
    /// tracker's attitude carries every frame's field and Sun to the same inertial ones; the flip seed's tracker differs from the live one by exactly a
    /// half turn about the boresight from its onset on (checked through the rotation
    /// matrix: the boresight kept, a perpendicular axis reversed), the stuck seed repeats
    /// one axis, the bias seed's gyro reads the live rate plus the step.
    #[test]
    fn fdir_seeds_inject_one_fault_on_a_live_sequence() {
        use nalgebra::{UnitQuaternion, Vector3};
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let t = Target::load(&root.join("campaigns/base-3u-every-monitor.toml")).unwrap();
        let seeds: BTreeMap<String, Input> = fdir_inputs(&t).into_iter().collect();
        let frames = |x: &Input| x.prefix.iter().chain([&x.frame]).copied().collect::<Vec<_>>();
        let quat = |f: &SensorFrame| {
            let [x, y, z, w] = f.q_ib_xyzw.map(f64::from);
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
        };
        let live = frames(&seeds["live"]);
        assert_eq!(live.len(), MAX_PREFIX + 1);
        for p in live.windows(2) {
            assert!((0..3).all(|a| p[0].rate_rad_s[a] != p[1].rate_rad_s[a]), "a gyro axis repeats");
            assert!((0..4).any(|i| p[0].q_ib_xyzw[i] != p[1].q_ib_xyzw[i]), "the tracker repeats");
        }
        let v = |a: [f32; 3]| Vector3::from(a.map(f64::from));
        for f in &live {
            // The tracker's attitude puts the inertial field and Sun where the frame
            // measures them (relative to the magnitude, f32 rounding).
            for (b, b0) in [(f.mag_field_t, live[0].mag_field_t), (f.sun_dir, live[0].sun_dir)] {
                let scale = v(b0).norm().max(1e-30);
                assert!((quat(f) * v(b) - quat(&live[0]) * v(b0)).norm() / scale < 1e-5);
            }
        }
        let onset = MAX_PREFIX - FDIR_ONSET_BEFORE_END;
        let b = Vector3::from(t.estimation.unwrap().tracker_boresight_body.map(f64::from));
        let perp = b.cross(&Vector3::x()).try_normalize(1e-6).unwrap_or_else(|| b.cross(&Vector3::y()).normalize());
        for (k, (f, l)) in frames(&seeds["tracker-flip"]).iter().zip(&live).enumerate() {
            let d = (quat(l).inverse() * quat(f)).to_rotation_matrix();
            let flipped = k >= onset;
            assert!((d * b - b).norm() < 1e-5, "frame {k}: boresight moved");
            let want = if flipped { -perp } else { perp };
            assert!((d * perp - want).norm() < 1e-5, "frame {k}: flipped {flipped}");
        }
        let stuck = frames(&seeds["gyro-stuck-1"]);
        assert!(stuck[onset..].iter().all(|f| f.rate_rad_s[1] == stuck[onset].rate_rad_s[1]));
        assert!(stuck[..onset].iter().zip(&live).all(|(f, l)| f.rate_rad_s == l.rate_rad_s));
        let bias = frames(&seeds["gyro-bias-2-0.01"]);
        for (k, (f, l)) in bias.iter().zip(&live).enumerate() {
            let step = if k >= onset { 0.01 } else { 0.0 };
            assert!((f64::from(f.rate_rad_s[2] - l.rate_rad_s[2]) - step).abs() < 1e-6, "frame {k}");
        }
        assert!(seeds.contains_key("wheel-runaway-0") && seeds.contains_key("tracker-frozen"));
    }

    /// The CLI's names of the estimation flags.
    #[test]
    fn estimate_flags_by_name() {
        use acs_flight::link::estimate_flags as e;
        assert_eq!(estimate_names(0), "-");
        assert_eq!(estimate_names(e::MEKF | e::NAVIGATION | e::ATTITUDE), "att mekf nav");
    }
}
