//! Paper 000, test 3: the rig's manoeuvre took "about 10 s", "about a third" of test 1,
//! and test 1 kept "a small steady error, below the AHRS's 2° dynamic accuracy". Our ideal
//! run settles (< 1°) in 4.7 s. This experiment adds, one at a time over plausible ranges
//! and then together, the rig effects the paper names (section "test 1": air-bearing
//! friction, gravity torque from the CM offset, AHRS accuracy, non-ideal CMGs, no input
//! filtering, system delay) and asks which of them move test 3 to ~10 s, the test-3/test-1
//! ratio to ~1/3 and the steady error to the rig's scale.
//!
//! Settle metrics. `settle_true`: the project's (true error stays < 1° from then on).
//! `settle_plot`: the time after which the yaw stays within 1° of its own final value —
//! what a reader of the paper's yaw-vs-time figure calls the end of the manoeuvre (the
//! curve stops moving; a steady offset is reported separately as the steady error). The
//! rig's plots show the AHRS yaw; the eye averages its white error and a slowly varying
//! error shifts the curve without changing when it flattens, so `settle_plot` on the true
//! yaw is the figure's reading.

use crate::report::experiment::{Block, Context, Experiment, Explains, columns, fly_recorded, par_map, sig};
use anyhow::{Context as _, Result};
use sim_core::recorder::plots::{Figure, Panel, Series};
use sim_core::scenario::{RigSpec, Scenario, StarTrackerSpec};
use std::collections::BTreeMap;

/// Paper 000's figures for test 3 and the ratio to test 1 (`docs/papers.md`, paper 000).
pub const PAPER_SETTLE_S: f64 = 10.0;
pub const PAPER_RATIO: f64 = 1.0 / 3.0;
/// The paper's bound on the steady error: below the AHRS's dynamic accuracy, deg.
pub const PAPER_STEADY_BOUND_DEG: f64 = 2.0;
/// Tolerances of the verdict: "about 10 s" and "about a third".
pub const SETTLE_TOL_S: f64 = 2.5;
pub const RATIO_TOL: f64 = 0.1;
/// Band of `settle_plot`, deg, and the window of the steady error (last seconds of a run).
pub const PLOT_BAND_DEG: f64 = 1.0;
pub const STEADY_WINDOW_S: f64 = 5.0;

/// Servo parameters assumed when a sweep needs a servo: gimbal + rotor inertia about the
/// gimbal axis (rotor spin inertia h0 / 5000 rpm = 1.2e-3 kg m², about a transverse axis
/// about half, plus the gimbal frame), and the servo time constant of the friction sweep.
pub const GIMBAL_INERTIA_KGM2: f64 = 2e-3;
pub const FRICTION_SWEEP_TAU_S: f64 = 0.05;

/// One rig effect: a scenario key swept over six levels (the first: none).
struct Effect {
    key: &'static str,
    label: &'static str,
    unit: &'static str,
    levels: [f64; 6],
    apply: fn(&mut Scenario, f64),
}

fn rig(sc: &mut Scenario) -> &mut RigSpec {
    sc.rig.get_or_insert_with(|| RigSpec {
        preset: Some("paper000".into()),
        mgr_nm: None,
        roll_limit_deg: None,
        pitch_limit_deg: None,
        viscous_friction_nms: [0.0; 3],
        coulomb_friction_nm: [0.0; 3],
    })
}

fn set_servo(sc: &mut Scenario, tau: f64, friction_nm: f64) {
    if let Some(c) = sc.actuators.cmg.as_mut() {
        c.servo_time_constant_s = Some(tau);
        c.gimbal_inertia_kgm2 = Some(GIMBAL_INERTIA_KGM2);
        c.gimbal_friction_nm = friction_nm;
    }
}

fn star_tracker(sc: &mut Scenario) -> &mut StarTrackerSpec {
    sc.sensors.star_tracker.get_or_insert_with(Default::default)
}

const EFFECTS: [Effect; 8] = [
    Effect {
        key: "latency",
        label: "sensor latency (attitude and rate)",
        unit: "s",
        levels: [0.0, 0.05, 0.1, 0.2, 0.3, 0.5],
        apply: |sc, x| sc.sensors.latency_s = x,
    },
    Effect {
        key: "servo_lag",
        label: "gimbal servo time constant",
        unit: "s",
        levels: [0.0, 0.02, 0.05, 0.1, 0.15, 0.2],
        apply: |sc, x| {
            if x > 0.0 {
                set_servo(sc, x, 0.0);
            }
        },
    },
    Effect {
        key: "gimbal_friction",
        label: "gimbal bearing Coulomb friction (servo τ 0.05 s)",
        unit: "N m",
        levels: [0.0, 0.001, 0.002, 0.003, 0.004, 0.005],
        apply: |sc, x| set_servo(sc, FRICTION_SWEEP_TAU_S, x),
    },
    Effect {
        key: "bearing_viscous",
        label: "air-bearing viscous friction",
        unit: "N m s",
        levels: [0.0, 0.01, 0.1, 0.3, 0.6, 1.0],
        apply: |sc, x| rig(sc).viscous_friction_nms = [x; 3],
    },
    Effect {
        key: "bearing_coulomb",
        label: "air-bearing Coulomb friction",
        unit: "N m",
        levels: [0.0, 0.005, 0.01, 0.02, 0.05, 0.1],
        apply: |sc, x| rig(sc).coulomb_friction_nm = [x; 3],
    },
    Effect {
        key: "cm_offset",
        label: "CM offset along body y (m g r, roll torque)",
        unit: "N m",
        levels: [0.0, 0.0025, 0.005, 0.01, 0.02, 0.04],
        apply: |sc, x| rig(sc).mgr_nm = Some([0.0, x, 0.0]),
    },
    Effect {
        key: "ahrs_noise",
        label: "AHRS white error per axis, 1σ",
        unit: "deg",
        levels: [0.0, 0.25, 0.5, 1.0, 1.5, 2.0],
        apply: |sc, x| star_tracker(sc).noise_deg = x,
    },
    Effect {
        key: "ahrs_slow_error",
        label: "AHRS slowly varying (constant) yaw error",
        unit: "deg",
        levels: [0.0, 0.25, 0.5, 1.0, 1.5, 2.0],
        apply: |sc, x| star_tracker(sc).bias_deg = [0.0, 0.0, x],
    },
];

/// The combination "all effects": every effect at a plausible value (AHRS: the paper's 2°
/// dynamic accuracy as white error, and 0.5° of slowly varying error; the gimbal friction
/// is swept, see [`COMBO_FRICTION_NM`]).
pub const ALL_EFFECTS: [(&str, f64); 6] = [
    ("latency", 0.1),
    ("bearing_viscous", 0.01),
    ("bearing_coulomb", 0.01),
    ("cm_offset", 0.005),
    ("ahrs_noise", 2.0),
    ("ahrs_slow_error", 0.5),
];
/// Gimbal friction levels flown with all the other effects (servo τ 0.05 s throughout).
pub const COMBO_FRICTION_NM: [f64; 6] = [0.0, 0.002, 0.004, 0.006, 0.008, 0.01];
/// The named combination of the verdict: index into [`COMBO_FRICTION_NM`] (the one
/// parameter fitted to the paper's three figures; every seed must meet them).
pub const NAMED_FRICTION: usize = 4;
/// Noise seeds flown for every combination.
pub const SEEDS: [u64; 5] = [1, 2, 3, 4, 5];

fn effect(key: &str) -> Option<&'static Effect> {
    EFFECTS.iter().find(|e| e.key == key)
}

/// All effects, with gimbal friction `friction_nm`, noise seed `seed`.
fn apply_all(sc: &mut Scenario, friction_nm: f64, seed: u64) {
    for (k, x) in ALL_EFFECTS {
        if let Some(e) = effect(k) {
            (e.apply)(sc, x);
        }
    }
    set_servo(sc, FRICTION_SWEEP_TAU_S, friction_nm);
    sc.sensors.seed = seed;
}

/// The figures of one run.
#[derive(Clone, Debug)]
pub struct Metrics {
    /// True error < 1° from then on (summary), `None`: never.
    pub settle_true_s: Option<f64>,
    /// Yaw within [`PLOT_BAND_DEG`] of its final value from then on; `None`: still moving.
    pub settle_plot_s: Option<f64>,
    /// Mean true error over the last [`STEADY_WINDOW_S`], deg.
    pub steady_error_deg: f64,
    pub final_error_deg: f64,
    /// Time after which the true error stays below each of [`BANDS_DEG`].
    pub settle_bands_s: Vec<Option<f64>>,
    pub t: Vec<f64>,
    pub yaw_deg: Vec<f64>,
}

/// Bands of the ideal-response table, deg.
pub const BANDS_DEG: [f64; 4] = [1.0, 0.1, 0.01, 0.001];

/// The time after which `x < bound` holds at every later sample (`None`: not at the end).
pub fn settle_after(t: &[f64], x: &[f64], bound: f64) -> Option<f64> {
    match x.iter().rposition(|v| !(*v < bound)) {
        None => t.first().copied(),
        Some(i) => t.get(i + 1).copied(),
    }
}

fn fly_metrics(sc: &Scenario) -> Result<Metrics> {
    let mut sc = sc.clone();
    sc.timing.output_every = 1;
    let r = fly_recorded(&sc)?;
    let col = |n: &str| r.series.col(n).map(<[f64]>::to_vec).with_context(|| format!("column {n}"));
    let (t, err, yaw) = (col("t_s")?, col("error_deg")?, col("yaw_deg")?);
    let t_end = t.last().copied().unwrap_or(0.0);
    let mean_after = |x: &[f64], from: f64| {
        let v: Vec<f64> = t.iter().zip(x).filter(|(ti, _)| **ti >= from).map(|(_, v)| *v).collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let yaw_final = mean_after(&yaw, t_end - 2.0);
    let dev: Vec<f64> = yaw.iter().map(|y| (y - yaw_final).abs()).collect();
    Ok(Metrics {
        settle_true_s: r.summary.settle_time_s,
        settle_plot_s: settle_after(&t, &dev, PLOT_BAND_DEG),
        steady_error_deg: mean_after(&err, t_end - STEADY_WINDOW_S),
        final_error_deg: r.summary.final_error_deg,
        settle_bands_s: BANDS_DEG.iter().map(|b| settle_after(&t, &err, *b)).collect(),
        t,
        yaw_deg: yaw,
    })
}

fn opt(x: Option<f64>) -> f64 {
    x.unwrap_or(f64::NAN)
}

fn cell(x: Option<f64>, digits: usize) -> String {
    x.map_or_else(|| "never".into(), |v| sig(v, digits))
}

/// Test-3 / test-1 ratio of the plot settle times (`None` when either never settles).
fn ratio(t3: &Metrics, t1: &Metrics) -> Option<f64> {
    Some(t3.settle_plot_s? / t1.settle_plot_s?)
}

/// Whether a (test 3, test 1) pair reproduces the paper: test 3 ≈ 10 s, ratio ≈ 1/3,
/// test 1's steady error on the rig's scale (≤ the AHRS's 2°).
pub fn reproduces(settle3_s: f64, ratio31: f64, steady1_deg: f64) -> bool {
    (settle3_s - PAPER_SETTLE_S).abs() <= SETTLE_TOL_S
        && (ratio31 - PAPER_RATIO).abs() <= RATIO_TOL
        && steady1_deg <= PAPER_STEADY_BOUND_DEG
}

/// Gimbal-rate dead zone of the first-order servo with Coulomb friction: the steady rate
/// deficit τ T_f / I_g (`plant::cmg`), deg/s.
pub fn dead_zone_deg_s(friction_nm: f64) -> f64 {
    (FRICTION_SWEEP_TAU_S * friction_nm / GIMBAL_INERTIA_KGM2).to_degrees()
}

/// A number as it appears in finding keys: two significant digits, `.` → `p`.
pub fn key_num(x: f64) -> String {
    sig(x, 2).replace('.', "p")
}

/// Every flight's metrics: the one-at-a-time sweeps (tests 3 and 1 per level), then the
/// combinations (per friction level and seed).
struct Flights {
    metrics: Vec<Metrics>,
    /// Number of sweep flights (start of the combinations).
    n_sweep: usize,
}

impl Flights {
    /// Effect `e` at level `level` on test `test` (0: test 3, 1: test 1).
    fn sweep(&self, e: usize, level: usize, test: usize) -> &Metrics {
        &self.metrics[(e * 6 + level) * 2 + test]
    }
    /// All effects with friction `fi` and seed `si` on test `test`.
    fn combo(&self, fi: usize, si: usize, test: usize) -> &Metrics {
        &self.metrics[self.n_sweep + (fi * SEEDS.len() + si) * 2 + test]
    }
    fn ideal3(&self) -> &Metrics {
        self.sweep(0, 0, 0)
    }
    fn ideal1(&self) -> &Metrics {
        self.sweep(0, 0, 1)
    }
    /// The named combination, seed 1: (test 3, test 1).
    fn named(&self) -> (&Metrics, &Metrics) {
        (self.combo(NAMED_FRICTION, 0, 0), self.combo(NAMED_FRICTION, 0, 1))
    }
}

/// Flies every effect alone on tests 3 and 1, then all effects per friction level and seed.
fn fly(ctx: &Context) -> Result<Flights> {
    let base3 = ctx.scenario("paper000/test3.toml")?;
    let base1 = ctx.scenario("paper000/test1.toml")?;
    let bases = [&base3, &base1];

    // Every flight: (test index, scenario). Sweeps first, then the combinations.
    let mut runs: Vec<(usize, Scenario)> = Vec::new();
    for e in &EFFECTS {
        for &x in &e.levels {
            for (i, b) in bases.iter().enumerate() {
                let mut sc = (*b).clone();
                (e.apply)(&mut sc, x);
                runs.push((i, sc));
            }
        }
    }
    let n_sweep = runs.len();
    for &tf in &COMBO_FRICTION_NM {
        for &seed in &SEEDS {
            for b in bases {
                let mut sc = b.clone();
                apply_all(&mut sc, tf, seed);
                runs.push((0, sc));
            }
        }
    }
    let out: Vec<Result<Metrics>> = par_map(ctx.jobs, &runs, |(_, sc)| fly_metrics(sc));
    let metrics: Vec<Metrics> = out.into_iter().collect::<Result<_>>()?;
    Ok(Flights { metrics, n_sweep })
}

/// One friction level of the combinations: (min, mean, max) over the seeds, and whether
/// every seed meets the paper's three figures.
struct Combo {
    settle_plot_s: (f64, f64, f64),
    ratio: (f64, f64, f64),
    steady3_max_deg: f64,
    steady1_deg: (f64, f64, f64),
    all_ok: bool,
}

/// (min, mean, max) of `v`.
fn stats(v: &[f64]) -> (f64, f64, f64) {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (lo, v.iter().sum::<f64>() / v.len().max(1) as f64, hi)
}

/// Per friction level, the spread over the seeds.
fn combos(fl: &Flights) -> Vec<Combo> {
    (0..COMBO_FRICTION_NM.len())
        .map(|fi| {
            let runs: Vec<(&Metrics, &Metrics)> =
                (0..SEEDS.len()).map(|si| (fl.combo(fi, si, 0), fl.combo(fi, si, 1))).collect();
            let settle: Vec<f64> = runs.iter().map(|(a, _)| opt(a.settle_plot_s)).collect();
            let ratios: Vec<f64> = runs.iter().map(|(a, b)| opt(ratio(a, b))).collect();
            let steady1: Vec<f64> = runs.iter().map(|(_, b)| b.steady_error_deg).collect();
            let all_ok = runs.iter().all(|(a, b)| match (a.settle_plot_s, ratio(a, b)) {
                (Some(s), Some(r)) => reproduces(s, r, b.steady_error_deg),
                _ => false,
            });
            Combo {
                settle_plot_s: stats(&settle),
                ratio: stats(&ratios),
                steady3_max_deg: runs.iter().map(|(a, _)| a.steady_error_deg).fold(f64::NEG_INFINITY, f64::max),
                steady1_deg: stats(&steady1),
                all_ok,
            }
        })
        .collect()
}

/// The ideal runs' and the one-at-a-time sweeps' findings.
fn sweep_findings(fl: &Flights, f: &mut BTreeMap<String, f64>) {
    let (ideal3, ideal1) = (fl.ideal3(), fl.ideal1());
    f.insert("settle_s_ideal".to_owned(), opt(ideal3.settle_true_s));
    f.insert("settle_plot_s_ideal".to_owned(), opt(ideal3.settle_plot_s));
    f.insert("settle_s_test1_ideal".to_owned(), opt(ideal1.settle_true_s));
    f.insert("steady_error_deg_ideal".to_owned(), ideal3.steady_error_deg);
    f.insert("ratio_test3_test1_ideal".to_owned(), opt(ratio(ideal3, ideal1)));
    for (b, band) in BANDS_DEG.iter().enumerate() {
        let (s3, s1) = (opt(ideal3.settle_bands_s[b]), opt(ideal1.settle_bands_s[b]));
        f.insert(format!("settle_s_ideal_band_{}deg", key_num(*band)), s3);
        f.insert(format!("settle_s_test1_ideal_band_{}deg", key_num(*band)), s1);
        f.insert(format!("ratio_test3_test1_ideal_band_{}deg", key_num(*band)), s3 / s1);
    }
    for (ei, e) in EFFECTS.iter().enumerate() {
        for li in 1..6 {
            let (a, b) = (fl.sweep(ei, li, 0), fl.sweep(ei, li, 1));
            let tag = format!("{}_{}", e.key, key_num(e.levels[li]));
            f.insert(format!("settle_s_{tag}"), opt(a.settle_true_s));
            f.insert(format!("settle_plot_s_{tag}"), opt(a.settle_plot_s));
            f.insert(format!("steady_error_deg_{tag}"), a.steady_error_deg);
            f.insert(format!("final_error_deg_{tag}"), a.final_error_deg);
            f.insert(format!("steady_error_deg_test1_{tag}"), b.steady_error_deg);
            f.insert(format!("ratio_test3_test1_{tag}"), opt(ratio(a, b)));
        }
    }
}

/// The combinations' findings.
fn combo_findings(fl: &Flights, combos: &[Combo], f: &mut BTreeMap<String, f64>) {
    let named = &combos[NAMED_FRICTION];
    let (a1, b1) = fl.named();
    let tf_named = COMBO_FRICTION_NM[NAMED_FRICTION];
    f.insert("gimbal_friction_nm_all_effects".to_owned(), tf_named);
    f.insert("gimbal_dead_zone_deg_s_all_effects".to_owned(), dead_zone_deg_s(tf_named));
    f.insert("settle_s_all_effects".to_owned(), opt(a1.settle_plot_s));
    f.insert("settle_true_s_all_effects".to_owned(), opt(a1.settle_true_s));
    f.insert("settle_s_test1_all_effects".to_owned(), opt(b1.settle_plot_s));
    f.insert("steady_error_deg_all_effects".to_owned(), a1.steady_error_deg);
    f.insert("steady_error_deg_test1_all_effects".to_owned(), b1.steady_error_deg);
    f.insert("ratio_test3_test1_all_effects".to_owned(), opt(ratio(a1, b1)));
    f.insert("settle_s_all_effects_min_over_seeds".to_owned(), named.settle_plot_s.0);
    f.insert("settle_s_all_effects_max_over_seeds".to_owned(), named.settle_plot_s.2);
    f.insert("ratio_test3_test1_all_effects_min_over_seeds".to_owned(), named.ratio.0);
    f.insert("ratio_test3_test1_all_effects_max_over_seeds".to_owned(), named.ratio.2);
    f.insert("steady_error_deg_all_effects_max_over_seeds".to_owned(), named.steady3_max_deg);
    f.insert("steady_error_deg_test1_all_effects_max_over_seeds".to_owned(), named.steady1_deg.2);
    for (fi, c) in combos.iter().enumerate() {
        let tag = key_num(COMBO_FRICTION_NM[fi]);
        f.insert(format!("settle_s_all_effects_gimbal_friction_{tag}_mean_over_seeds"), c.settle_plot_s.1);
        f.insert(format!("ratio_test3_test1_all_effects_gimbal_friction_{tag}_mean_over_seeds"), c.ratio.1);
        f.insert(format!("steady_error_deg_test1_all_effects_gimbal_friction_{tag}_max_over_seeds"), c.steady1_deg.2);
        f.insert(format!("reproduces_all_seeds_gimbal_friction_{tag}"), if c.all_ok { 1.0 } else { 0.0 });
    }
}

/// What the runs show.
struct Findings {
    map: BTreeMap<String, f64>,
    combos: Vec<Combo>,
    /// Friction levels at which every seed meets the paper, N m.
    ok_friction_nm: Vec<f64>,
}

fn analyse(fl: &Flights) -> Findings {
    let mut map = BTreeMap::new();
    sweep_findings(fl, &mut map);
    let combos = combos(fl);
    combo_findings(fl, &combos, &mut map);
    let ok_friction_nm: Vec<f64> =
        COMBO_FRICTION_NM.iter().zip(&combos).filter(|(_, c)| c.all_ok).map(|(x, _)| *x).collect();
    // "Never settled" is a missing finding (the tables say "never").
    map.retain(|_, v| v.is_finite());
    Findings { map, combos, ok_friction_nm }
}

/// The set-up paragraph, the sweep table and the sweep figure.
fn render_sweeps(ctx: &Context, fl: &Flights) -> Result<Vec<Block>> {
    let mut rows = vec![row("none (ideal)", "", fl.ideal3(), fl.ideal1())];
    for (ei, e) in EFFECTS.iter().enumerate() {
        for li in 1..6 {
            let (a, b) = (fl.sweep(ei, li, 0), fl.sweep(ei, li, 1));
            rows.push(row(e.label, &format!("{} {}", sig(e.levels[li], 2), e.unit), a, b));
        }
    }
    let mut blocks = Vec::new();
    blocks.push(Block::Para(format!(
        "Each effect is flown alone on tests 3 and 1 (scenarios `paper000/test3.toml`, `test1.toml`) \
         at five levels, then all together at a plausible mid value. `settle true` is the project's \
         settle time (true error below 1° from then on); `settle plot` is when the yaw stays within \
         {PLOT_BAND_DEG}° of its own final value — the end of the manoeuvre as read off the paper's \
         yaw plot (the rig's AHRS yaw: the eye averages its white error, a slowly varying error shifts \
         the curve without changing when it flattens). Steady error: mean true error over the last \
         {STEADY_WINDOW_S} s. The servo-based rows assume a gimbal inertia of {GIMBAL_INERTIA_KGM2} kg m²; \
         the friction row a servo time constant of {FRICTION_SWEEP_TAU_S} s, so a friction T_f is a \
         gimbal-rate dead zone τ T_f / I_g ({} deg/s per mN m).",
        sig(dead_zone_deg_s(1e-3), 3)
    )));
    let header = [
        "effect",
        "level",
        "test 3 settle true (s)",
        "test 3 settle plot (s)",
        "test 3 steady error (deg)",
        "test 1 settle plot (s)",
        "test 1 steady error (deg)",
        "ratio 3/1 (plot)",
    ];
    blocks.push(Block::Table { header: header.iter().map(|s| (*s).to_owned()).collect(), rows });
    blocks.push(figure_sweeps(ctx, fl)?);
    Ok(blocks)
}

/// Test-3 settle and test-1 steady error against each effect's level (x = level index).
fn figure_sweeps(ctx: &Context, fl: &Flights) -> Result<Block> {
    let lvl: Vec<f64> = (0..6).map(|i| i as f64).collect();
    let mut cols: Vec<(String, Vec<f64>)> = vec![("level".into(), lvl)];
    for (ei, e) in EFFECTS.iter().enumerate() {
        cols.push((format!("settle3_{}", e.key), (0..6).map(|l| opt(fl.sweep(ei, l, 0).settle_plot_s)).collect()));
        cols.push((format!("steady1_{}", e.key), (0..6).map(|l| fl.sweep(ei, l, 1).steady_error_deg).collect()));
    }
    let named_cols: Vec<(&str, Vec<f64>)> = cols.iter().map(|(n, v)| (n.as_str(), v.clone())).collect();
    let ts = columns(&named_cols);
    let series = |prefix: &str| {
        EFFECTS
            .iter()
            .map(|e| Series { column: format!("{prefix}_{}", e.key), label: e.key.into(), dashed: false })
            .collect::<Vec<_>>()
    };
    ctx.figure(
        &ts,
        Figure {
            file_name: "p000_rig_sweeps.png".into(),
            title: "Paper 000: rig effects one at a time".into(),
            x: "level".into(),
            x_label: "sweep level (0 = ideal … 5 = largest; values in the table)".into(),
            panels: vec![
                Panel {
                    title: "test 3: settle (yaw within 1° of its final value)".into(),
                    y_label: "s".into(),
                    series: series("settle3"),
                    log_y: false,
                    ..Default::default()
                },
                Panel {
                    title: "test 1: steady error (true, last 5 s)".into(),
                    y_label: "deg".into(),
                    series: series("steady1"),
                    log_y: false,
                    ..Default::default()
                },
            ],
            ..Default::default()
        },
        "Test-3 settle time (top) and test-1 steady error (bottom) against each effect's level; a \
         missing point: the yaw never stops moving by 1°.",
    )
}

/// The ideal response read at tighter bands.
fn render_bands(fl: &Flights) -> Vec<Block> {
    let (ideal3, ideal1) = (fl.ideal3(), fl.ideal1());
    vec![
        Block::Para(
            "Ideal response read at tighter bands (true error): the asymptotic decay rates are ζωn = \
             0.99 /s (test 3) and 0.329 /s (test 1), ratio 0.332."
                .into(),
        ),
        Block::Table {
            header: vec!["band (deg)".into(), "test 3 (s)".into(), "test 1 (s)".into(), "ratio 3/1".into()],
            rows: BANDS_DEG
                .iter()
                .enumerate()
                .map(|(b, band)| {
                    let (s3, s1) = (ideal3.settle_bands_s[b], ideal1.settle_bands_s[b]);
                    vec![sig(*band, 1), cell(s3, 3), cell(s1, 3), s3.zip(s1).map_or("—".into(), |(a, b)| sig(a / b, 2))]
                })
                .collect(),
        },
    ]
}

/// The combinations' paragraph and table.
fn render_combos(combos: &[Combo]) -> Vec<Block> {
    let combo_rows: Vec<Vec<String>> = COMBO_FRICTION_NM
        .iter()
        .zip(combos)
        .map(|(tf, c)| {
            let range = |x: (f64, f64, f64), d: usize| format!("{} ({}–{})", sig(x.1, d), sig(x.0, d), sig(x.2, d));
            vec![
                sig(tf * 1e3, 2),
                sig(dead_zone_deg_s(*tf), 2),
                range(c.settle_plot_s, 3),
                range(c.ratio, 2),
                sig(c.steady3_max_deg, 2),
                range(c.steady1_deg, 2),
                if c.all_ok { "yes".into() } else { "no".into() },
            ]
        })
        .collect();
    let para = Block::Para(format!(
        "All effects together ({}; servo τ {FRICTION_SWEEP_TAU_S} s), gimbal friction swept, seeds {}–{}: \
         mean (min–max) over the seeds. \"meets\": every seed within 10 ± {SETTLE_TOL_S} s, ratio 1/3 ± \
         {RATIO_TOL} and test-1 steady error ≤ {PAPER_STEADY_BOUND_DEG}°.",
        ALL_EFFECTS
            .iter()
            .map(|(k, x)| format!("{k} {} {}", sig(*x, 2), effect(k).map_or("", |e| e.unit)))
            .collect::<Vec<_>>()
            .join(", "),
        SEEDS[0],
        SEEDS[SEEDS.len() - 1]
    ));
    let header = [
        "gimbal friction (mN m)",
        "dead zone (deg/s)",
        "test 3 settle plot (s)",
        "ratio 3/1",
        "test 3 steady error, max (deg)",
        "test 1 steady error (deg)",
        "meets",
    ];
    vec![para, Block::Table { header: header.iter().map(|s| (*s).to_owned()).collect(), rows: combo_rows }]
}

/// The combinations against gimbal friction, beside the paper's figures.
fn figure_combos(ctx: &Context, combos: &[Combo]) -> Result<Block> {
    let fr = columns(&[
        ("friction_mnm", COMBO_FRICTION_NM.iter().map(|x| x * 1e3).collect()),
        ("settle_mean", combos.iter().map(|c| c.settle_plot_s.1).collect()),
        ("settle_min", combos.iter().map(|c| c.settle_plot_s.0).collect()),
        ("settle_max", combos.iter().map(|c| c.settle_plot_s.2).collect()),
        ("settle_paper", vec![PAPER_SETTLE_S; COMBO_FRICTION_NM.len()]),
        ("ratio_mean", combos.iter().map(|c| c.ratio.1).collect()),
        ("ratio_paper", vec![PAPER_RATIO; COMBO_FRICTION_NM.len()]),
        ("steady1_max", combos.iter().map(|c| c.steady1_deg.2).collect()),
        ("steady_bound", vec![PAPER_STEADY_BOUND_DEG; COMBO_FRICTION_NM.len()]),
    ]);
    let sd = |c: &str, l: &str, dashed: bool| Series { column: c.into(), label: l.into(), dashed };
    ctx.figure(
        &fr,
        Figure {
            file_name: "p000_rig_combination.png".into(),
            title: "Paper 000: all rig effects, gimbal friction swept".into(),
            x: "friction_mnm".into(),
            x_label: "gimbal bearing friction [mN m]".into(),
            panels: vec![
                Panel {
                    title: "test 3 settle (plot reading), over seeds".into(),
                    y_label: "s".into(),
                    series: vec![
                        sd("settle_mean", "mean", false),
                        sd("settle_min", "min", false),
                        sd("settle_max", "max", false),
                        sd("settle_paper", "paper: ~10 s", true),
                    ],
                    log_y: false,
                    ..Default::default()
                },
                Panel {
                    title: "ratio test 3 / test 1".into(),
                    y_label: "-".into(),
                    series: vec![sd("ratio_mean", "mean over seeds", false), sd("ratio_paper", "paper: ~1/3", true)],
                    log_y: false,
                    ..Default::default()
                },
                Panel {
                    title: "test 1 steady error (true), max over seeds".into(),
                    y_label: "deg".into(),
                    series: vec![sd("steady1_max", "max", false), sd("steady_bound", "paper: < 2° (AHRS)", true)],
                    log_y: false,
                    ..Default::default()
                },
            ],
            ..Default::default()
        },
        "With every other effect present, the gimbal friction alone moves test 3 from its ideal timing to \
         the paper's ~10 s and the ratio to ~1/3; dashed: the paper's figures.",
    )
}

/// Yaw vs time, ideal vs all effects (test 1 is longer: test 3 padded with NaN).
fn figure_yaw(ctx: &Context, fl: &Flights) -> Result<Block> {
    let (ideal3, ideal1) = (fl.ideal3(), fl.ideal1());
    let (a1, b1) = fl.named();
    let t1 = ideal1.t.clone();
    let yaw = columns(&[
        ("t_s", t1),
        ("yaw3_ideal", ideal3.yaw_deg.clone()),
        ("yaw3_all", a1.yaw_deg.clone()),
        ("yaw1_ideal", ideal1.yaw_deg.clone()),
        ("yaw1_all", b1.yaw_deg.clone()),
    ]);
    let s = |c: &str, l: &str| Series { column: c.into(), label: l.into(), dashed: false };
    ctx.figure(
        &yaw,
        Figure {
            file_name: "p000_rig_yaw.png".into(),
            title: "Paper 000: yaw, ideal vs all rig effects (true attitude)".into(),
            x: "t_s".into(),
            x_label: "time [s]".into(),
            panels: vec![
                Panel {
                    title: "test 3 (ζ 0.9, ωn 1.1)".into(),
                    y_label: "yaw [deg]".into(),
                    series: vec![s("yaw3_ideal", "ideal"), s("yaw3_all", "all effects")],
                    log_y: false,
                    ..Default::default()
                },
                Panel {
                    title: "test 1 (ζ 0.47, ωn 0.7)".into(),
                    y_label: "yaw [deg]".into(),
                    series: vec![s("yaw1_ideal", "ideal"), s("yaw1_all", "all effects")],
                    log_y: false,
                    ..Default::default()
                },
            ],
            ..Default::default()
        },
        "True yaw of tests 3 and 1, ideal rig vs all effects (seed 1).",
    )
}

/// The report's blocks: sweeps, tighter bands, combinations, yaw.
fn render(ctx: &Context, fl: &Flights, fd: &Findings) -> Result<Vec<Block>> {
    let mut blocks = render_sweeps(ctx, fl)?;
    blocks.extend(render_bands(fl));
    blocks.extend(render_combos(&fd.combos));
    blocks.push(figure_combos(ctx, &fd.combos)?);
    blocks.push(figure_yaw(ctx, fl)?);
    Ok(blocks)
}

/// The conclusion paragraph.
fn conclusion(fl: &Flights, fd: &Findings) -> String {
    let (ideal3, ideal1) = (fl.ideal3(), fl.ideal1());
    let (a1, b1) = fl.named();
    let named = &fd.combos[NAMED_FRICTION];
    let tf_named = COMBO_FRICTION_NM[NAMED_FRICTION];
    let ok_text = match (fd.ok_friction_nm.first(), fd.ok_friction_nm.last()) {
        (Some(lo), Some(hi)) => format!("{}–{} mN m", sig(lo * 1e3, 2), sig(hi * 1e3, 2)),
        _ => "no level".into(),
    };
    format!(
        "Ideal: test 3 settles in {} s, test 1 in {} s, ratio {} (both within a few per cent of the \
         linear ζ/ωn response; test 3 a little slower because its initial torque demand exceeds the \
         cluster's). One at a time, sensor latency ≤ 0.3 s, servo lag ≤ 0.2 s, air-bearing viscous \
         friction and a white AHRS error ≤ 2° move test 3 by under 1 s; air-bearing Coulomb friction, \
         a CM offset and a slowly varying AHRS error leave the timing alone and set the steady error \
         (within the stiction band 2T_c/K, at 2 asin(m g r / 2ωn² I), and equal to the AHRS error). \
         Only gimbal-bearing friction — with a first-order rate servo, a gimbal-rate dead zone τ T_f / I_g — \
         turns the end of the manoeuvre into a slow stick-slip approach; alone it does so erratically \
         ({} s at 2 mN m, {} s at 3 mN m), with the other effects present (their noise dithers the \
         dead zone) smoothly. With all effects and {} mN m of gimbal friction (dead zone {} deg/s) test 3 \
         ends at {} s ({}–{} s over five seeds), test 1 at {} s, ratio {} ({}–{}), steady error {} deg \
         on test 3 and {} deg on test 1 (max {}): the paper's ~10 s, ~1/3 and sub-2° steady error. {} \
         Levels meeting all three on every seed: {ok_text}. The friction level is one fitted parameter \
         (the paper gives no servo data); its dead zone is the uncertain part, as a servo with \
         integral action would remove it. The paper's statement that measured gimbal angles and \
         torques exceeded the theory is consistent with it.",
        sig(opt(ideal3.settle_true_s), 3),
        sig(opt(ideal1.settle_true_s), 3),
        sig(opt(ratio(ideal3, ideal1)), 2),
        cell(fl.sweep(2, 2, 0).settle_plot_s, 2),
        cell(fl.sweep(2, 3, 0).settle_plot_s, 2),
        sig(tf_named * 1e3, 2),
        sig(dead_zone_deg_s(tf_named), 3),
        sig(opt(a1.settle_plot_s), 3),
        sig(named.settle_plot_s.0, 3),
        sig(named.settle_plot_s.2, 3),
        sig(opt(b1.settle_plot_s), 3),
        sig(opt(ratio(a1, b1)), 2),
        sig(named.ratio.0, 2),
        sig(named.ratio.2, 2),
        sig(a1.steady_error_deg, 2),
        sig(b1.steady_error_deg, 2),
        sig(named.steady1_deg.2, 2),
        if named.all_ok {
            "Every seed meets them within the stated tolerances, so this named combination reproduces \
             the paper; without the gimbal friction the same effects leave test 3 at its ideal timing."
        } else {
            "Not every seed meets them within the stated tolerances, so the combination is not claimed \
             to reproduce the paper."
        }
    )
}

pub fn run(ctx: &Context) -> Result<Experiment> {
    let flights = fly(ctx)?;
    let findings = analyse(&flights);
    let blocks = render(ctx, &flights, &findings)?;
    let conclusion = conclusion(&flights, &findings);
    let explains = if findings.combos[NAMED_FRICTION].all_ok { Explains::Yes } else { Explains::No };
    Ok(Experiment {
        id: "p000-rig-effects",
        paper: "000",
        title: "Paper 000, test 3: which rig effects make the manoeuvre take ~10 s?".into(),
        question: format!(
            "The rig's test 3 took about 10 s, about a third of test 1, with a small steady error; our \
             ideal run settles in {} s (test 1: {} s). Which of the rig effects the paper names bring \
             ours to the paper's figures?",
            sig(opt(flights.ideal3().settle_true_s), 3),
            sig(opt(flights.ideal1().settle_true_s), 3)
        ),
        blocks,
        findings: findings.map,
        conclusion,
        explains,
    })
}

fn row(name: &str, level: &str, a: &Metrics, b: &Metrics) -> Vec<String> {
    vec![
        name.to_owned(),
        level.to_owned(),
        cell(a.settle_true_s, 3),
        cell(a.settle_plot_s, 3),
        sig(a.steady_error_deg, 2),
        cell(b.settle_plot_s, 3),
        sig(b.steady_error_deg, 2),
        cell(ratio(a, b), 2),
    ]
}
