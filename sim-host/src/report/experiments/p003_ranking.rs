//! Paper 003, lab tests on the air-bearing rig: the magnetic LQR beat the PD (RMS error
//! 2.95° vs 5.4°), while in our simulation of the same rig the PD wins (≈ 2.0° vs 2.9°).
//! Which property of a real rig and lab, at a plausible level, changes the ranking?
//!
//! Each factor is swept alone for both laws (sensor noise, torquer dead band, pendulum
//! offset, a platform dipole in the lab field, a field error at the magnetometer, actuator
//! delay), then the combination the paper's text points to ("due to the small gains and
//! the external disturbances the oscillation is about −5°"): the sensor noise the paper
//! shows (±0.5°) plus a constant yaw disturbance, here a horizontal platform dipole across
//! the lab field.
//!
//! Metric: RMS of the attitude error (`error_deg`, all three axes, as in docs/results.md)
//! over the steady part of the run, t ≥ 600 s of 1200 s, sampled at the recorded 1 Hz.

use crate::report::experiment::{
    Block, Context, Experiment, Explains, columns, fly_recorded, par_map, sig, sweep_table,
};
use anyhow::{Context as _, Result, bail};
use sim_core::recorder::plots::{Figure, Panel, Series};
use sim_core::scenario::{Controller, MagnetometerSpec, RigSpec, Scenario};
use std::collections::BTreeMap;

/// Published lab RMS errors (paper 003, abstract and text): PD, LQR, deg.
pub const PAPER_RMS_PD_DEG: f64 = 5.4;
pub const PAPER_RMS_LQR_DEG: f64 = 2.95;
/// Start of the steady window, s (the PD has left its 97° slew by ~450 s).
pub const STEADY_FROM_S: f64 = 600.0;
/// `m g r` of the rig, paper 003 eq 28, N m (the `paper003` rig preset).
pub const MGR_EQ28_NM: [f64; 3] = [-0.004, -0.001, 0.5];
/// Paper 003's torquer dead band, A m².
pub const DEADBAND_AM2: [f64; 2] = [-1.26, 1.86];
/// Reference sensor noise: the paper's Euler-angle plots show ±0.5° of noise about the
/// equilibrium (taken as ±2σ); the rate noise of a MEMS gyro of that class at 10 Hz.
pub const REF_ATTITUDE_NOISE_DEG: f64 = 0.25;
pub const REF_RATE_NOISE_RAD_S: f64 = 3e-4;
/// Tolerance of "reproduces the paper's figure": relative.
pub const MATCH_TOL: f64 = 0.15;

/// The control law of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Law {
    Pd,
    Lqr,
}

/// One variant of the rig and lab (all zero / one: the shipped scenarios).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rig {
    pub attitude_noise_deg: f64,
    pub rate_noise_rad_s: f64,
    /// Dead band width as a multiple of the paper's −1.26 … +1.86 A m².
    pub deadband_scale: f64,
    /// Horizontal centre-of-mass offset (m g r_x, m g r_y) as a multiple of eq 28 …
    pub cm_scale: f64,
    /// … turned about the vertical by this angle, deg (0: eq 28's direction).
    pub cm_dir_deg: f64,
    /// Constant platform dipole along body y (across the lab field's horizontal part,
    /// which lies along x at yaw 0), A m²: a yaw torque `−m_y B_x` in the lab field.
    pub dipole_y_am2: f64,
    /// Field error (bias) of the magnetometer the dipole law uses, along x, T.
    pub field_error_x_t: f64,
    /// Pure delay of the dipole commands, s.
    pub delay_s: f64,
}

/// The rig as shipped (`scenarios/paper003/rig-*.toml`).
pub const PAPER_RIG: Rig = Rig {
    attitude_noise_deg: 0.0,
    rate_noise_rad_s: 0.0,
    deadband_scale: 1.0,
    cm_scale: 1.0,
    cm_dir_deg: 0.0,
    dipole_y_am2: 0.0,
    field_error_x_t: 0.0,
    delay_s: 0.0,
};

/// The paper's rig with the reference sensor noise.
pub const NOISY_RIG: Rig =
    Rig { attitude_noise_deg: REF_ATTITUDE_NOISE_DEG, rate_noise_rad_s: REF_RATE_NOISE_RAD_S, ..PAPER_RIG };

/// Steady-state figures of one run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Steady {
    /// RMS of the attitude error, deg.
    pub rms_deg: f64,
    /// Mean yaw (the controlled axis), deg.
    pub yaw_mean_deg: f64,
}

/// The base scenario of a law with `rig` applied.
pub fn variant(ctx: &Context, law: Law, rig: &Rig) -> Result<Scenario> {
    let mut sc = ctx.scenario(match law {
        Law::Pd => "paper003/rig-pd.toml",
        Law::Lqr => "paper003/rig-lqr.toml",
    })?;
    sc.sensors.attitude_noise_deg = rig.attitude_noise_deg;
    sc.sensors.rate_noise_rad_s = rig.rate_noise_rad_s;
    let m = sc.actuators.magnetorquers.as_mut().context("rig scenario without magnetorquers")?;
    m.deadband_am2 = Some(DEADBAND_AM2.map(|x| x * rig.deadband_scale));
    m.delay_s = rig.delay_s;
    if rig.cm_scale != 1.0 || rig.cm_dir_deg != 0.0 {
        // The LQR stays designed on eq 28 (what the paper estimated); only the plant's
        // balance changes: freeze the design's gain before moving the CM.
        if matches!(sc.controller, Some(Controller::Lqr { .. })) {
            let k = sc.lqr_design()?.gain;
            let k: [[f64; 6]; 3] = std::array::from_fn(|i| k.get(i).copied().unwrap_or_default());
            if let Some(Controller::Lqr { gain, q_diag, r_diag, .. }) = sc.controller.as_mut() {
                *gain = Some(k);
                *q_diag = None;
                *r_diag = None;
            }
        }
        let (s, c) = rig.cm_dir_deg.to_radians().sin_cos();
        let [x, y, z] = MGR_EQ28_NM;
        let (x, y) = (rig.cm_scale * (c * x - s * y), rig.cm_scale * (s * x + c * y));
        let r: &mut RigSpec = sc.rig.as_mut().context("rig scenario without [rig]")?;
        r.mgr_nm = Some([x, y, z]);
    }
    sc.spacecraft.residual_dipole_am2 = [0.0, rig.dipole_y_am2, 0.0];
    if rig.field_error_x_t != 0.0 {
        sc.sensors.magnetometer =
            Some(MagnetometerSpec { bias_t: [rig.field_error_x_t, 0.0, 0.0], ..Default::default() });
    }
    Ok(sc)
}

/// Flies `law` on `rig` and reduces the run to its steady figures.
pub fn steady(ctx: &Context, law: Law, rig: &Rig) -> Result<Steady> {
    let run = fly_recorded(&variant(ctx, law, rig)?)?;
    let s = &run.series;
    let (Some(t), Some(e), Some(yaw)) = (s.col("t_s"), s.col("error_deg"), s.col("yaw_deg")) else {
        bail!("run without t_s / error_deg / yaw_deg");
    };
    let (mut n, mut e2, mut ys) = (0usize, 0.0, 0.0);
    for ((&t, &e), &y) in t.iter().zip(e).zip(yaw) {
        if t >= STEADY_FROM_S {
            n += 1;
            e2 += e * e;
            ys += y;
        }
    }
    if n == 0 {
        bail!("run shorter than {STEADY_FROM_S} s");
    }
    Ok(Steady { rms_deg: (e2 / n as f64).sqrt(), yaw_mean_deg: ys / n as f64 })
}

/// Flies every (law, rig) pair on `ctx.jobs` threads: results in order.
fn fly_all(ctx: &Context, runs: &[(Law, Rig)]) -> Result<Vec<Steady>> {
    par_map(ctx.jobs, runs, |(law, rig)| steady(ctx, *law, rig)).into_iter().collect()
}

/// One factor swept alone: name, reference value (unit in the text), and how a level
/// (multiple of the reference) changes the rig.
struct Factor {
    column: &'static str,
    title: &'static str,
    reference: &'static str,
    apply: fn(f64) -> Rig,
    /// Signed factor: swept at −level as well.
    signed: bool,
}

const LEVELS: [f64; 6] = [0.0, 0.5, 1.0, 2.0, 3.0, 4.0];

fn factors() -> [Factor; 7] {
    [
        Factor {
            column: "att",
            title: "attitude-sensor noise (1σ)",
            reference: "0.25°",
            apply: |k| Rig { attitude_noise_deg: k * REF_ATTITUDE_NOISE_DEG, ..PAPER_RIG },
            signed: false,
        },
        Factor {
            column: "rate",
            title: "rate noise (1σ)",
            reference: "3e-4 rad/s",
            apply: |k| Rig { rate_noise_rad_s: k * REF_RATE_NOISE_RAD_S, ..PAPER_RIG },
            signed: false,
        },
        Factor {
            column: "db",
            title: "torquer dead band width",
            reference: "−1.26 … +1.86 A m²",
            apply: |k| Rig { deadband_scale: k, ..PAPER_RIG },
            signed: false,
        },
        Factor {
            column: "cm",
            title: "horizontal CM offset (m g r_x, m g r_y)",
            reference: "eq 28: (−0.004, −0.001) N m",
            apply: |k| Rig { cm_scale: k, ..PAPER_RIG },
            signed: false,
        },
        Factor {
            column: "dip",
            title: "platform dipole across the lab field (m_y)",
            reference: "1 A m²",
            apply: |k| Rig { dipole_y_am2: k, ..PAPER_RIG },
            signed: true,
        },
        Factor {
            column: "bias",
            title: "field error at the magnetometer (along the horizontal field)",
            reference: "2.5 µT",
            apply: |k| Rig { field_error_x_t: k * 2.5e-6, ..PAPER_RIG },
            signed: true,
        },
        Factor {
            column: "delay",
            title: "torquer command delay",
            reference: "0.25 s",
            apply: |k| Rig { delay_s: k * 0.25, ..PAPER_RIG },
            signed: false,
        },
    ]
}

/// Dipoles of the combination sweep, A m².
const COMBO_DIPOLES_AM2: [f64; 17] =
    [-4.0, -3.5, -3.0, -2.5, -2.0, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0];
/// CM-offset directions of the two-unknown grid, deg (0 is in the combination sweep).
const GRID_DIRS_DEG: [f64; 7] = [45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0];
const GRID_DIPOLES_AM2: [f64; 6] = [-4.0, -3.0, -2.0, 2.0, 3.0, 4.0];
const DIRS_DEG: [f64; 8] = [0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0];

/// Where `f` (sampled at increasing `xs`) first crosses zero going outwards from index
/// `from` in direction `step` (±1), linearly interpolated; NaN if it does not.
fn crossing(xs: &[f64], f: &[f64], from: usize, step: isize) -> f64 {
    let mut i = from;
    loop {
        let Some(j) = i.checked_add_signed(step).filter(|&j| j < xs.len()) else { return f64::NAN };
        let (fi, fj) = (f[i], f[j]);
        if fi == 0.0 {
            return xs[i];
        }
        if fi.signum() != fj.signum() {
            return xs[i] + (xs[j] - xs[i]) * fi / (fi - fj);
        }
        i = j;
    }
}

/// PD's closed-form stall yaw for a dead-band edge `edge_am2` (A m²) and a lab field
/// `b_t` (x north, z vertical): the cross-product law (eq 22) turns a yaw demand
/// `kp ψ` into a dipole `kp ψ B_x / |B|²` along y, which stays inside the dead band
/// while `|ψ| < edge |B|² / (kp B_x)`, rad. The same expression with a platform dipole
/// `m_y` for `edge` is the yaw at which the commanded rod dipole cancels it (the PD's
/// steady offset under that disturbance).
pub fn pd_yaw_rad(edge_am2: f64, kp_z: f64, b_t: [f64; 3]) -> f64 {
    let b2 = b_t.iter().map(|x| x * x).sum::<f64>();
    edge_am2 * b2 / (kp_z * b_t[0])
}

/// Every run (PD and LQR in turn), and where each part of the list starts.
struct Flights {
    steady: Vec<Steady>,
    /// End of the factor sweeps (start of the CM-direction sweep).
    n_factor: usize,
    /// End of the direction sweep (start of the combination sweep).
    n_dir: usize,
    /// End of the combination sweep (start of the two-unknown grid).
    n_combo: usize,
}

impl Flights {
    fn at(&self, i: usize) -> Result<Steady> {
        self.steady.get(i).copied().context("missing run")
    }
}

/// Flies each factor alone, the CM direction, the combination and the two-unknown grid.
fn fly(ctx: &Context, fs: &[Factor]) -> Result<Flights> {
    // 1. Each factor alone, both laws.
    let mut runs: Vec<(Law, Rig)> = Vec::new();
    for f in fs {
        // Order per level: PD, LQR at +k, then (signed factors) PD, LQR at −k.
        for &k in &LEVELS {
            runs.extend([Law::Pd, Law::Lqr].map(|law| (law, (f.apply)(k))));
            if f.signed && k > 0.0 {
                runs.extend([Law::Pd, Law::Lqr].map(|law| (law, (f.apply)(-k))));
            }
        }
    }
    let n_factor = runs.len();
    // 2. CM-offset direction alone.
    for &d in &DIRS_DEG {
        for law in [Law::Pd, Law::Lqr] {
            runs.push((law, Rig { cm_dir_deg: d, ..PAPER_RIG }));
        }
    }
    let n_dir = runs.len();
    // 3. The combination: reference sensor noise + platform dipole, paper's CM offset.
    for &m in &COMBO_DIPOLES_AM2 {
        for law in [Law::Pd, Law::Lqr] {
            runs.push((law, Rig { dipole_y_am2: m, ..NOISY_RIG }));
        }
    }
    let n_combo = runs.len();
    // 4. Both magnitudes: the combination with the (unmeasured) CM direction as well.
    for &d in &GRID_DIRS_DEG {
        for &m in &GRID_DIPOLES_AM2 {
            for law in [Law::Pd, Law::Lqr] {
                runs.push((law, Rig { dipole_y_am2: m, cm_dir_deg: d, ..NOISY_RIG }));
            }
        }
    }
    let steady = fly_all(ctx, &runs)?;
    Ok(Flights { steady, n_factor, n_dir, n_combo })
}

/// Per factor (by column), per level: steady RMS of PD, LQR at +level and PD, LQR at
/// −level (NaN for unsigned factors), deg.
type FactorRms = BTreeMap<&'static str, Vec<[f64; 4]>>;

/// The factor sweeps' RMS errors.
fn analyse_factors(fl: &Flights, fs: &[Factor]) -> Result<FactorRms> {
    let mut idx = 0usize;
    let mut factor_rms: FactorRms = BTreeMap::new();
    for f in fs {
        let mut v = Vec::new();
        for &k in &LEVELS {
            let (pd, lqr) = (fl.at(idx)?, fl.at(idx + 1)?);
            idx += 2;
            let (mut npd, mut nlqr) = (f64::NAN, f64::NAN);
            if f.signed && k > 0.0 {
                npd = fl.at(idx)?.rms_deg;
                nlqr = fl.at(idx + 1)?.rms_deg;
                idx += 2;
            } else if f.signed {
                (npd, nlqr) = (pd.rms_deg, lqr.rms_deg);
            }
            v.push([pd.rms_deg, lqr.rms_deg, npd, nlqr]);
        }
        factor_rms.insert(f.column, v);
    }
    debug_assert_eq!(idx, fl.n_factor);
    Ok(factor_rms)
}

/// The combination sweep (reference noise + platform dipole) and where it crosses.
struct Combo {
    pd_rms_deg: Vec<f64>,
    lqr_rms_deg: Vec<f64>,
    pd_yaw_mean_deg: Vec<f64>,
    /// Index of the zero dipole in [`COMBO_DIPOLES_AM2`].
    zero: usize,
    /// Dipoles beyond which the LQR wins.
    flip_dipole_am2_pos: f64,
    flip_dipole_am2_neg: f64,
    /// Dipoles at which the PD reaches the paper's RMS.
    pd_match_dipole_am2_pos: f64,
    pd_match_dipole_am2_neg: f64,
    /// The LQR's RMS at those dipoles (linear interpolation), deg.
    lqr_rms_deg_at_pd_match_pos: f64,
    lqr_rms_deg_at_pd_match_neg: f64,
}

fn analyse_combo(fl: &Flights) -> Result<Combo> {
    let mut combo_pd = Vec::new();
    let mut combo_lqr = Vec::new();
    let mut combo_pd_yaw = Vec::new();
    for i in 0..COMBO_DIPOLES_AM2.len() {
        let (p, l) = (fl.at(fl.n_dir + 2 * i)?, fl.at(fl.n_dir + 2 * i + 1)?);
        combo_pd.push(p.rms_deg);
        combo_lqr.push(l.rms_deg);
        combo_pd_yaw.push(p.yaw_mean_deg);
    }
    let zero = COMBO_DIPOLES_AM2.iter().position(|&m| m == 0.0).context("no zero dipole")?;
    let diff: Vec<f64> = combo_pd.iter().zip(&combo_lqr).map(|(p, l)| p - l).collect();
    let flip_pos = crossing(&COMBO_DIPOLES_AM2, &diff, zero, 1);
    let flip_neg = crossing(&COMBO_DIPOLES_AM2, &diff, zero, -1);
    let to_paper: Vec<f64> = combo_pd.iter().map(|p| p - PAPER_RMS_PD_DEG).collect();
    let pd_match_pos = crossing(&COMBO_DIPOLES_AM2, &to_paper, zero, 1);
    let pd_match_neg = crossing(&COMBO_DIPOLES_AM2, &to_paper, zero, -1);
    // LQR at the dipoles where the PD matches the paper (linear interpolation).
    let interp = |x: f64, ys: &[f64]| -> f64 {
        let xs = &COMBO_DIPOLES_AM2;
        xs.windows(2)
            .zip(ys.windows(2))
            .find(|(w, _)| x >= w[0] && x <= w[1])
            .map_or(f64::NAN, |(w, y)| y[0] + (y[1] - y[0]) * (x - w[0]) / (w[1] - w[0]))
    };
    let lqr_at_pd_match_pos = interp(pd_match_pos, &combo_lqr);
    let lqr_at_pd_match_neg = interp(pd_match_neg, &combo_lqr);
    Ok(Combo {
        pd_rms_deg: combo_pd,
        lqr_rms_deg: combo_lqr,
        pd_yaw_mean_deg: combo_pd_yaw,
        zero,
        flip_dipole_am2_pos: flip_pos,
        flip_dipole_am2_neg: flip_neg,
        pd_match_dipole_am2_pos: pd_match_pos,
        pd_match_dipole_am2_neg: pd_match_neg,
        lqr_rms_deg_at_pd_match_pos: lqr_at_pd_match_pos,
        lqr_rms_deg_at_pd_match_neg: lqr_at_pd_match_neg,
    })
}

/// A candidate of the two-unknown grid: (CM direction deg, dipole A m², PD RMS deg, LQR RMS deg).
type Candidate = (f64, f64, f64, f64);

/// Largest relative miss of a candidate against the two published figures.
fn miss(c: &Candidate) -> f64 {
    ((c.2 / PAPER_RMS_PD_DEG - 1.0).abs()).max((c.3 / PAPER_RMS_LQR_DEG - 1.0).abs())
}

/// The two-unknown grid (with the combination sweep at 0°).
struct GridBest {
    /// Closest candidate to both published figures.
    best: Candidate,
    both_within_tol: bool,
    /// Candidates with |m_y| ∈ {3, 4} A m², and those of them where the LQR wins.
    n_strong: usize,
    n_strong_flipped: usize,
}

fn analyse_grid(fl: &Flights, combo: &Combo) -> Result<GridBest> {
    let mut cands: Vec<Candidate> = Vec::new();
    for (i, &m) in COMBO_DIPOLES_AM2.iter().enumerate() {
        cands.push((0.0, m, combo.pd_rms_deg[i], combo.lqr_rms_deg[i]));
    }
    let mut g = fl.n_combo;
    for &d in &GRID_DIRS_DEG {
        for &m in &GRID_DIPOLES_AM2 {
            cands.push((d, m, fl.at(g)?.rms_deg, fl.at(g + 1)?.rms_deg));
            g += 2;
        }
    }
    let best = cands.iter().min_by(|a, b| miss(a).total_cmp(&miss(b))).copied().context("empty grid")?;
    let both_within_tol = miss(&best) <= MATCH_TOL;
    // |m_y| ∈ {3, 4} A m² at each of the eight directions.
    let strong = |c: &&Candidate| c.1.abs() >= 3.0 && c.1.fract() == 0.0;
    let n_strong_flipped = cands.iter().filter(strong).filter(|c| c.3 < c.2).count();
    let n_strong = cands.iter().filter(strong).count();
    Ok(GridBest { best, both_within_tol, n_strong, n_strong_flipped })
}

/// The shipped PD's lab field and yaw gain, for the closed forms.
struct PdRig {
    lab_field_t: [f64; 3],
    kp_z: f64,
}

fn pd_rig(ctx: &Context) -> Result<PdRig> {
    let base = variant(ctx, Law::Pd, &PAPER_RIG)?;
    let b_lab = base.environment.lab_field_t.context("rig without lab_field_t")?;
    let kp_z = match &base.controller {
        Some(Controller::EulerPd { kp_nm, .. }) => kp_nm[2],
        _ => bail!("rig-pd.toml is not an Euler PD"),
    };
    Ok(PdRig { lab_field_t: b_lab, kp_z })
}

/// What the runs show.
struct Findings {
    factor_rms: FactorRms,
    dir_pd_rms_deg: Vec<f64>,
    dir_lqr_rms_deg: Vec<f64>,
    combo: Combo,
    grid: GridBest,
    rig: PdRig,
    /// Baseline PD yaw mean, deg.
    pd_yaw_mean_deg_baseline: f64,
    /// Dipole at which the PD's closed-form offset is the paper's RMS, A m².
    dipole_for_paper_pd_am2: f64,
    /// Dead-band scale and CM-offset scale that flip the ranking noise-free.
    flip_deadband_scale: f64,
    flip_cm_scale: f64,
    /// The ranking flips within the combination sweep.
    flips: bool,
    /// Smallest |dipole| that flips it, A m².
    flip_min_am2: f64,
    /// Horizontal lab field, T.
    b_h_t: f64,
}

impl Findings {
    /// A factor's RMS at a level: col 0 PD, 1 LQR, 2 PD (−), 3 LQR (−).
    fn fr(&self, c: &str, level: usize, col: usize) -> Result<f64> {
        self.factor_rms.get(c).and_then(|v| v.get(level)).and_then(|r| r.get(col)).copied().context("factor")
    }
}

fn analyse(ctx: &Context, fl: &Flights, fs: &[Factor]) -> Result<Findings> {
    let factor_rms = analyse_factors(fl, fs)?;
    // Direction sweep.
    let mut dir_pd = Vec::new();
    let mut dir_lqr = Vec::new();
    for i in 0..DIRS_DEG.len() {
        dir_pd.push(fl.at(fl.n_factor + 2 * i)?.rms_deg);
        dir_lqr.push(fl.at(fl.n_factor + 2 * i + 1)?.rms_deg);
    }
    let combo = analyse_combo(fl)?;
    let grid = analyse_grid(fl, &combo)?;
    // Closed forms for the PD (the shipped rig's lab field and kp_z).
    let rig = pd_rig(ctx)?;
    let dipole_for_paper_pd_am2 = PAPER_RMS_PD_DEG.to_radians() / pd_yaw_rad(1.0, rig.kp_z, rig.lab_field_t);
    let mut fd = Findings {
        factor_rms,
        dir_pd_rms_deg: dir_pd,
        dir_lqr_rms_deg: dir_lqr,
        flips: combo.flip_dipole_am2_pos.is_finite() || combo.flip_dipole_am2_neg.is_finite(),
        flip_min_am2: [combo.flip_dipole_am2_pos.abs(), combo.flip_dipole_am2_neg.abs()]
            .into_iter()
            .filter(|x| x.is_finite())
            .fold(f64::NAN, f64::min),
        b_h_t: rig.lab_field_t[0].hypot(rig.lab_field_t[1]),
        combo,
        grid,
        rig,
        pd_yaw_mean_deg_baseline: fl.at(0)?.yaw_mean_deg,
        dipole_for_paper_pd_am2,
        flip_deadband_scale: f64::NAN,
        flip_cm_scale: f64::NAN,
    };
    // Single factors that flip the ranking noise-free (levels outward from the paper's, 1×).
    let diff_of =
        |c: &str| -> Result<Vec<f64>> { (0..LEVELS.len()).map(|i| Ok(fd.fr(c, i, 0)? - fd.fr(c, i, 1)?)).collect() };
    let flip_db = crossing(&LEVELS, &diff_of("db")?, 2, 1);
    let flip_cm = crossing(&LEVELS, &diff_of("cm")?, 2, -1);
    (fd.flip_deadband_scale, fd.flip_cm_scale) = (flip_db, flip_cm);
    Ok(fd)
}

/// The named findings.
fn named(fd: &Findings) -> Result<BTreeMap<String, f64>> {
    let (c, g, rig) = (&fd.combo, &fd.grid, &fd.rig);
    let (kp_z, b_lab) = (rig.kp_z, rig.lab_field_t);
    let stall_lo_deg = pd_yaw_rad(-DEADBAND_AM2[0], kp_z, b_lab).to_degrees();
    let mut findings = BTreeMap::new();
    let mut put = |k: &str, v: f64| {
        findings.insert(k.to_owned(), v);
    };
    put("rms_deg_pd_baseline", fd.fr("att", 0, 0)?);
    put("rms_deg_lqr_baseline", fd.fr("att", 0, 1)?);
    put("rms_deg_pd_no_deadband", fd.fr("db", 0, 0)?);
    put("rms_deg_lqr_no_deadband", fd.fr("db", 0, 1)?);
    put("rms_deg_pd_deadband_x2", fd.fr("db", 3, 0)?);
    put("rms_deg_lqr_no_cm_offset", fd.fr("cm", 0, 1)?);
    put("rms_deg_pd_no_cm_offset", fd.fr("cm", 0, 0)?);
    put("rms_deg_pd_ref_noise", c.pd_rms_deg[c.zero]);
    put("rms_deg_lqr_ref_noise", c.lqr_rms_deg[c.zero]);
    put("rms_deg_pd_att_noise_1deg", fd.fr("att", 5, 0)?);
    put("rms_deg_lqr_att_noise_1deg", fd.fr("att", 5, 1)?);
    put("rms_deg_lqr_delay_1s", fd.fr("delay", 5, 1)?);
    put("rms_deg_pd_delay_1s", fd.fr("delay", 5, 0)?);
    put("yaw_deg_pd_baseline_mean", fd.pd_yaw_mean_deg_baseline);
    put("yaw_deg_pd_stall_closed_form", -stall_lo_deg);
    put("ranking_flips", if fd.flips { 1.0 } else { 0.0 });
    put("flip_deadband_scale", fd.flip_deadband_scale);
    put("flip_cm_offset_scale", fd.flip_cm_scale);
    put("flip_dipole_am2_pos", c.flip_dipole_am2_pos);
    put("flip_dipole_am2_neg", c.flip_dipole_am2_neg);
    put("flip_yaw_torque_nm", fd.flip_min_am2 * fd.b_h_t);
    put("pd_match_dipole_am2_pos", c.pd_match_dipole_am2_pos);
    put("pd_match_dipole_am2_neg", c.pd_match_dipole_am2_neg);
    put("pd_match_dipole_am2_closed_form", fd.dipole_for_paper_pd_am2);
    put("rms_deg_lqr_at_pd_match_pos", c.lqr_rms_deg_at_pd_match_pos);
    put("rms_deg_lqr_at_pd_match_neg", c.lqr_rms_deg_at_pd_match_neg);
    put("rms_deg_pd_best", g.best.2);
    put("rms_deg_lqr_best", g.best.3);
    put("best_dipole_am2", g.best.1);
    put("best_cm_dir_deg", g.best.0);
    put("best_rel_miss", miss(&g.best));
    put("both_magnitudes_within_tol", if g.both_within_tol { 1.0 } else { 0.0 });
    put("grid_flipped_share_dipole_ge_3", g.n_strong_flipped as f64 / g.n_strong.max(1) as f64);
    put("yaw_deg_pd_dipole_3_mean", c.pd_yaw_mean_deg[COMBO_DIPOLES_AM2.iter().position(|&m| m == 3.0).unwrap_or(0)]);
    put("yaw_deg_pd_dipole_3_closed_form", -pd_yaw_rad(3.0, kp_z, b_lab).to_degrees());
    Ok(findings)
}

/// The factor sweeps' table rows: factor, level, PD, LQR (and both at −level).
fn factor_rows(fs: &[Factor], fd: &Findings) -> Result<Vec<Vec<String>>> {
    let mut rows = Vec::new();
    for f in fs {
        let v = fd.factor_rms.get(f.column).context("factor")?;
        for (&k, r) in LEVELS.iter().zip(v) {
            let [pd, lqr, npd, nlqr] = *r;
            rows.push(vec![
                f.title.to_owned(),
                format!("{} × {}", sig(k, 2), f.reference),
                sig(pd, 3),
                sig(lqr, 3),
                if f.signed { sig(npd, 3) } else { String::new() },
                if f.signed { sig(nlqr, 3) } else { String::new() },
            ]);
        }
    }
    Ok(rows)
}

/// Steady RMS against each factor's level, one panel per factor.
fn figure_factors(ctx: &Context, fs: &[Factor], fd: &Findings) -> Result<Block> {
    let mut fig_cols: Vec<(String, Vec<f64>)> = vec![("level".into(), LEVELS.to_vec())];
    for f in fs {
        let v = fd.factor_rms.get(f.column).context("factor")?;
        fig_cols.push((format!("{}_pd", f.column), v.iter().map(|r| r[0]).collect()));
        fig_cols.push((format!("{}_lqr", f.column), v.iter().map(|r| r[1]).collect()));
        if f.signed {
            fig_cols.push((format!("{}_pd_neg", f.column), v.iter().map(|r| r[2]).collect()));
            fig_cols.push((format!("{}_lqr_neg", f.column), v.iter().map(|r| r[3]).collect()));
        }
    }
    let fig_cols_ref: Vec<(&str, Vec<f64>)> = fig_cols.iter().map(|(n, v)| (n.as_str(), v.clone())).collect();
    let ts = columns(&fig_cols_ref);
    let panels = fs
        .iter()
        .map(|f| {
            let mut series = vec![
                Series { column: format!("{}_pd", f.column), label: "PD".into(), dashed: false },
                Series { column: format!("{}_lqr", f.column), label: "LQR".into(), dashed: false },
            ];
            if f.signed {
                series[0].label = "PD (+)".into();
                series[1].label = "LQR (+)".into();
                series.push(Series { column: format!("{}_pd_neg", f.column), label: "PD (−)".into(), dashed: true });
                series
                    .push(Series { column: format!("{}_lqr_neg", f.column), label: "LQR (−)".into(), dashed: true });
            }
            Panel {
                title: format!("{}; reference {}", f.title, f.reference),
                y_label: "RMS error [deg]".into(),
                series,
                log_y: false,
                ..Default::default()
            }
        })
        .collect();
    ctx.figure(
        &ts,
        Figure {
            file_name: "p003_factors.png".into(),
            title: "Paper 003 rig: steady RMS error vs each factor alone".into(),
            x: "level".into(),
            x_label: "factor level [× reference]".into(),
            panels,
            ..Default::default()
        },
        "Steady RMS attitude error (t ≥ 600 s) of the PD and the LQR on the paper-003 rig, each \
         factor alone at 0 … 4 × a plausible reference level (panel titles); signed factors at \
         both signs (dashed: negative). Only a constant yaw disturbance (the platform dipole in the \
         lab field) moves the PD past the LQR.",
    )
}

/// The combination sweep against the platform dipole, with the PD's closed form.
fn figure_combo(ctx: &Context, fd: &Findings) -> Result<Block> {
    let (kp_z, b_lab) = (fd.rig.kp_z, fd.rig.lab_field_t);
    let n = COMBO_DIPOLES_AM2.len();
    let ts3 =
        columns(&[
            ("m_y", COMBO_DIPOLES_AM2.to_vec()),
            ("pd", fd.combo.pd_rms_deg.clone()),
            ("lqr", fd.combo.lqr_rms_deg.clone()),
            ("paper_pd", vec![PAPER_RMS_PD_DEG; n]),
            ("paper_lqr", vec![PAPER_RMS_LQR_DEG; n]),
            (
                "pd_closed",
                COMBO_DIPOLES_AM2
                    .iter()
                    .map(|&m| {
                        if m.abs() >= -DEADBAND_AM2[0] {
                            pd_yaw_rad(m.abs(), kp_z, b_lab).to_degrees()
                        } else {
                            f64::NAN
                        }
                    })
                    .collect(),
            ),
        ]);
    ctx.figure(
        &ts3,
        Figure {
            file_name: "p003_combination.png".into(),
            title: "Paper 003 rig: sensor noise + platform dipole in the lab field".into(),
            x: "m_y".into(),
            x_label: "platform dipole across the lab field m_y [A m²]".into(),
            panels: vec![Panel {
                title: format!(
                    "attitude noise {REF_ATTITUDE_NOISE_DEG}° and rate noise {REF_RATE_NOISE_RAD_S} rad/s (1σ), dead band and CM offset of the paper"
                ),
                y_label: "RMS error [deg]".into(),
                series: vec![
                    Series { column: "pd".into(), label: "PD".into(), dashed: false },
                    Series { column: "lqr".into(), label: "LQR".into(), dashed: false },
                    Series { column: "paper_pd".into(), label: "paper PD 5.4°".into(), dashed: true },
                    Series { column: "paper_lqr".into(), label: "paper LQR 2.95°".into(), dashed: true },
                    Series { column: "pd_closed".into(), label: "PD offset, closed form".into(), dashed: true },
                ],
                log_y: false,
                ..Default::default()
            }],
            ..Default::default()
        },
        "With the paper's sensor noise, a constant platform dipole across the lab field (a yaw \
         torque m_y B_h) drives the PD's error up linearly (closed form: the yaw at which the \
         commanded rod dipole cancels m_y) while the high-gain LQR holds; the ranking flips beyond \
         the crossings.",
    )
}

/// Steady RMS against the direction of the horizontal CM offset.
fn figure_cm_direction(ctx: &Context, fd: &Findings) -> Result<Block> {
    let ts2 =
        columns(&[("dir", DIRS_DEG.to_vec()), ("pd", fd.dir_pd_rms_deg.clone()), ("lqr", fd.dir_lqr_rms_deg.clone())]);
    ctx.figure(
        &ts2,
        Figure {
            file_name: "p003_cm_direction.png".into(),
            title: "Paper 003 rig: direction of the horizontal CM offset".into(),
            x: "dir".into(),
            x_label: "horizontal CM offset turned about the vertical [deg] (0: eq 28)".into(),
            panels: vec![Panel {
                title: "|m g r_h| of eq 28, no noise, no disturbance".into(),
                y_label: "RMS error [deg]".into(),
                series: vec![
                    Series { column: "pd".into(), label: "PD".into(), dashed: false },
                    Series { column: "lqr".into(), label: "LQR".into(), dashed: false },
                ],
                log_y: false,
                ..Default::default()
            }],
            ..Default::default()
        },
        "The LQR's steady error is set by the rig's balance: its roll/pitch gains saturate the \
         torquers against the pendulum, and the direction of the residual tilt decides the yaw \
         error left; the PD barely notices.",
    )
}

/// The report's blocks: set-up, factor table and figures, combination, grid.
fn render(ctx: &Context, fs: &[Factor], fd: &Findings) -> Result<Vec<Block>> {
    let rows = factor_rows(fs, fd)?;
    let fig1 = figure_factors(ctx, fs, fd)?;
    let fig3 = figure_combo(ctx, fd)?;
    let fig2 = figure_cm_direction(ctx, fd)?;
    let best = fd.grid.best;
    let mut blocks = vec![Block::Para(format!(
        "Both laws fly the shipped scenarios `paper003/rig-pd.toml` and `rig-lqr.toml` (1200 s, \
         10 Hz) with one factor changed at a time; the metric is the RMS of the attitude error \
         over t ≥ {STEADY_FROM_S} s. Noise runs use seed 1 (a second seed moves the RMS by < 0.1°)."
    ))];
    blocks.push(Block::Table {
        header: ["factor", "level", "PD RMS [deg]", "LQR RMS [deg]", "PD (−) [deg]", "LQR (−) [deg]"]
            .iter()
            .map(|s| (*s).to_owned())
            .collect(),
        rows,
    });
    blocks.push(fig1);
    blocks.push(fig2);
    let (combo_pd, combo_lqr) = (&fd.combo.pd_rms_deg, &fd.combo.lqr_rms_deg);
    let combo_rows: Vec<Vec<f64>> =
        (0..COMBO_DIPOLES_AM2.len()).map(|i| vec![COMBO_DIPOLES_AM2[i], combo_pd[i], combo_lqr[i]]).collect();
    blocks.push(Block::Para(
        "Combination: the reference sensor noise plus a platform dipole m_y across the lab field:".into(),
    ));
    blocks.push(sweep_table(&["m_y [A m²]", "PD RMS [deg]", "LQR RMS [deg]"], &combo_rows, 3));
    blocks.push(fig3);
    blocks.push(Block::Para(format!(
        "Both magnitudes at once need a second unknown, the direction of the horizontal CM offset on \
         the test day (the paper balanced the platform by hand before each test). Over dipoles \
         ±2 … ±4 A m² and directions 0 … 315°, the closest pair is PD {}° / LQR {}° at m_y = {} A m², \
         direction {}° (largest relative miss {}; tolerance {}).",
        sig(best.2, 3),
        sig(best.3, 3),
        sig(best.1, 2),
        sig(best.0, 3),
        sig(miss(&best), 2),
        sig(MATCH_TOL, 2),
    )));
    Ok(blocks)
}

/// The conclusion paragraph.
fn conclusion(fd: &Findings) -> Result<String> {
    let (c, best, both_within_tol) = (&fd.combo, fd.grid.best, fd.grid.both_within_tol);
    let (kp_z, b_lab) = (fd.rig.kp_z, fd.rig.lab_field_t);
    Ok(format!(
        "One named effect accounts for the ranking and the PD's magnitude: a constant yaw \
         disturbance torque, here a platform dipole across the 47 µT lab field (torquer-core \
         remanence, batteries, steel; equally any parasitic torque of the bearing or the air). \
         The low-gain PD rests where its rod dipole cancels it, m_y |B|²/(kp_z B_x) = {per_am2}° \
         per A m² (the paper's own account: small gains and external disturbances, oscillation \
         about −5°), while the high-gain LQR holds. With the paper's sensor noise the LQR wins \
         beyond m_y = {fp} or {fn} A m² (yaw torque {ft} N m) and the PD reaches 5.4° at \
         |m_y| ≈ {pm} A m² (closed form {pmc} A m², {tq} N m). The other factors do not explain \
         it: sensor noise dithers the PD through the dead band and lowers its error ({pdn}° with \
         the reference noise vs {pd0}° without: with the paper's noise our PD would be far better \
         than 5.4°); a command delay hurts only the LQR; a field error at the magnetometer of up \
         to 10 µT moves both without flipping; a dead band ≥ {dbf} × the paper's, or a rig \
         balanced better than {cmf} × eq 28 (the LQR's error comes from the roll/pitch imbalance \
         its large gains fight: {lqr_bal}° when balanced) flips the ranking noise-free, but neither \
         brings the PD near 5.4° at a plausible level. At the paper's CM offset the LQR sits at \
         {lp}° or {ln}° at the PD-matching dipole, depending on its sign, bracketing 2.95°; {both} \
         The flip is not robust to the balance: over the eight CM directions with |m_y| ≥ 3 A m² \
         the LQR wins in {share} % of the cases.",
        per_am2 = sig(pd_yaw_rad(1.0, kp_z, b_lab).to_degrees(), 3),
        fp = sig(c.flip_dipole_am2_pos, 2),
        fn = sig(c.flip_dipole_am2_neg, 2),
        ft = sig(fd.flip_min_am2 * fd.b_h_t, 2),
        pm = sig(c.pd_match_dipole_am2_pos.abs().min(c.pd_match_dipole_am2_neg.abs()), 2),
        pmc = sig(fd.dipole_for_paper_pd_am2, 3),
        tq = sig(fd.dipole_for_paper_pd_am2 * b_lab[0], 2),
        pdn = sig(c.pd_rms_deg[c.zero], 3),
        pd0 = sig(fd.fr("att", 0, 0)?, 3),
        dbf = sig(fd.flip_deadband_scale, 2),
        cmf = sig(fd.flip_cm_scale, 2),
        lqr_bal = sig(fd.fr("cm", 0, 1)?, 2),
        lp = sig(c.lqr_rms_deg_at_pd_match_pos, 3),
        ln = sig(c.lqr_rms_deg_at_pd_match_neg, 3),
        share = sig(100.0 * fd.grid.n_strong_flipped as f64 / fd.grid.n_strong.max(1) as f64, 2),
        both = if both_within_tol {
            format!(
                "both magnitudes are matched within {} % (PD {}°, LQR {}°, m_y = {} A m²) only by also \
                 choosing the unmeasured direction of the CM offset ({}° from eq 28's; the paper balanced \
                 the platform by hand before each test), so the ranking and the PD's 5.4° are explained, \
                 the LQR's 2.95° is consistent but fitted.",
                sig(MATCH_TOL * 100.0, 2),
                sig(best.2, 3),
                sig(best.3, 3),
                sig(best.1, 2),
                sig(best.0, 3)
            )
        } else {
            format!(
                "no tested combination matches both magnitudes within {} % (closest: PD {}°, LQR {}°): \
                 the ranking and the PD's magnitude are explained, the LQR's is not.",
                sig(MATCH_TOL * 100.0, 2),
                sig(best.2, 3),
                sig(best.3, 3)
            )
        },
    ))
}

pub fn run(ctx: &Context) -> Result<Experiment> {
    let fs = factors();
    let flights = fly(ctx, &fs)?;
    let fd = analyse(ctx, &flights, &fs)?;
    let blocks = render(ctx, &fs, &fd)?;
    let conclusion = conclusion(&fd)?;
    let (pd0, lqr0) = (fd.fr("att", 0, 0)?, fd.fr("att", 0, 1)?);
    Ok(Experiment {
        id: "p003-ranking",
        paper: "003",
        title: "Why the magnetic LQR beats the PD on the paper-003 rig".into(),
        question: format!(
            "On the air-bearing rig the paper measured RMS 5.4° (PD) vs 2.95° (LQR); our simulation \
             of the same rig gives {}° (PD) vs {}° (LQR), the opposite ranking. Which plausible \
             property of the rig or lab flips it, and does it reproduce both magnitudes?",
            sig(pd0, 3),
            sig(lqr0, 3)
        ),
        blocks,
        findings: named(&fd)?,
        conclusion,
        explains: if fd.flips && fd.grid.both_within_tol { Explains::Yes } else { Explains::No },
    })
}
