//! `cargo bench -p sim-core --bench lp_worst`: seeded worst-case search of the thruster-LP
//! flight step (paper 004) on the emulated Cortex-M4F (QEMU lockstep: step cost =
//! instructions). Not a test: it prints figures and writes the worst demands found.
//!
//! For each configuration (method × failure mask) the search evaluates a fixed seed set
//! — random directions, thruster columns `b_i`, facet normals `±b_i × b_j`, facet normals
//! tilted by 1e-6..1e-2 (near-degenerate), the known worst demands of `timing/lp-worst-demands.json`
//! — at log-spaced magnitudes 1e-3..1e3 N m, then runs a (μ + λ) evolutionary search:
//! the `MU` costliest demands are mutated (direction tilt of random log-scale 1e-6..0.3,
//! magnitude × 2^N(0, 1), sometimes snapped to a column or facet normal) for `GENS`
//! generations. The mean is over the fixed seed set (not biased towards the worst).
//!
//! The DCM-PD law makes the demand `Kd ∘ ω` at zero attitude error, so a demand is set
//! through the measured rate (as `rtf.rs`'s `allocation_sweep`); the controller's torque
//! limit (100 N m per axis) clips larger demands.
//!
//! Measured (30 generations, seed 1; `timing/lp-worst-demands.json`): direction-preserving
//! nominal worst 51,960 → 42,760 instructions (mean 33,401 → 29,519), Bodson nominal
//! 28,960 → 27,120; the step without allocation costs ~3,700.
//! Solver overhead cut (10 generations, seed 1, same bits): direction-preserving nominal
//! worst 42,840 → 37,760 (mean 29,582 → 25,555), failed [1, 4] 35,280 → 30,760, failed
//! [1, 3, 7] 29,960 → 25,800; Bodson nominal 27,200 → 25,160 (mean 22,612 → 20,681).
//!
//! Environment: `ACS_FIRMWARE_ELF` (default: the QEMU build), `LP_WORST_SEED` (default 1),
//! `LP_WORST_GENS` (default 40), `LP_WORST_OUT` (JSON of the worst demands, default none),
//! `LP_WORST_LABEL` (tag written into the JSON, default "current"), `LP_WORST_PROBE`
//! (`mx,my,mz;…`: only print the cost of these demands, in every configuration).

use acs_flight::link::{SensorFrame, valid};
use acs_flight::params::{ActuatorParams, FlightParams};
use acs_test_support::rng::SplitMix64 as Rng;
use acs_test_support::vec3::cross;
use sim_core::link::FlightLink;
use sim_core::link::qemu::QemuLink;
use sim_core::scenario::Scenario;
use std::path::{Path, PathBuf};

const MU: usize = 12;
const CHILDREN: usize = 48;

fn normalise(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-300);
    v.map(|x| x / n)
}

/// A direction uniform on the sphere: three normal draws, normalised.
fn unit(rng: &mut Rng) -> [f64; 3] {
    normalise([rng.normal(), rng.normal(), rng.normal()])
}

fn tilt(d: &[f64; 3], eps: f64, rng: &mut Rng) -> [f64; 3] {
    let r = unit(rng);
    normalise([d[0] + eps * r[0], d[1] + eps * r[1], d[2] + eps * r[2]])
}

struct Config {
    label: String,
    scenario: &'static str,
    method: &'static str,
    failed_1based: Vec<usize>,
}

struct Eval<'a> {
    link: QemuLink,
    kd: [f64; 3],
    seq: u32,
    _p: std::marker::PhantomData<&'a ()>,
}

impl Eval<'_> {
    /// Instructions of one flight step with demand `m` (N m).
    fn cost(&mut self, m: &[f64; 3]) -> u64 {
        let w: [f32; 3] = std::array::from_fn(|k| (m[k] / self.kd[k]) as f32);
        let f = SensorFrame {
            rate_rad_s: w,
            valid: valid::ATTITUDE | valid::RATE,
            ..SensorFrame::empty(self.seq, u64::from(self.seq) * 10_000)
        };
        self.seq += 1;
        let r = self.link.step(&f).expect("step");
        u64::from(r.step_cost_ticks) * 40 // 25 MHz counter, 1 instruction per ns
    }
}

fn known_worst(root: &Path, config: &str) -> Vec<[f64; 3]> {
    let Ok(txt) = std::fs::read_to_string(root.join("timing/lp-worst-demands.json")) else { return vec![] };
    let Ok(v) = serde_json::from_str::<serde_json::Value>(&txt) else { return vec![] };
    let mut out = vec![];
    for e in v["rows"].as_array().into_iter().flatten() {
        if e["config"].as_str() == Some(config)
            && let Some(d) = e["demand_nm"].as_array()
            && d.len() == 3
        {
            out.push([d[0].as_f64().unwrap_or(0.0), d[1].as_f64().unwrap_or(0.0), d[2].as_f64().unwrap_or(0.0)]);
        }
    }
    out
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let seed: u64 = std::env::var("LP_WORST_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
    let gens: usize = std::env::var("LP_WORST_GENS").ok().and_then(|s| s.parse().ok()).unwrap_or(40);
    let label = std::env::var("LP_WORST_LABEL").unwrap_or_else(|_| "current".into());
    let elf: Option<PathBuf> = std::env::var("ACS_FIRMWARE_ELF").ok().map(PathBuf::from);
    let configs = [
        Config { label: "dp-nominal".into(), scenario: "dp-nominal.toml", method: "DP", failed_1based: vec![] },
        Config { label: "dp-fail-1-4".into(), scenario: "dp-fail-1-4.toml", method: "DP", failed_1based: vec![1, 4] },
        Config {
            label: "dp-fail-1-3-7".into(),
            scenario: "dp-fail-1-3-7.toml",
            method: "DP",
            failed_1based: vec![1, 3, 7],
        },
        Config {
            label: "bodson-nominal".into(),
            scenario: "bodson-nominal.toml",
            method: "Bodson",
            failed_1based: vec![],
        },
        Config {
            label: "bodson-fail-1-4".into(),
            scenario: "bodson-fail-1-4.toml",
            method: "Bodson",
            failed_1based: vec![1, 4],
        },
        Config {
            label: "bodson-fail-1-3-7".into(),
            scenario: "bodson-nominal.toml",
            method: "Bodson",
            failed_1based: vec![1, 3, 7],
        },
    ];
    let mut json_rows = vec![];
    for cfg in &configs {
        let mut rng = Rng(seed ^ 0x5EED_0000 ^ (cfg.label.len() as u64) << 32);
        let sc = Scenario::load(&root.join("scenarios/paper004").join(cfg.scenario)).expect("scenario");
        let mut params: FlightParams = sc.flight_params().expect("params");
        if let ActuatorParams::Thrusters(t) = &mut params.actuator {
            t.failed_mask = cfg.failed_1based.iter().fold(0u16, |m, i| m | (1 << (i - 1)));
        }
        let b = sc.thruster_set().expect("thrusters").torque_matrix();
        // QEMU under a loaded machine occasionally misses the first reply: retry.
        let link = (0..3)
            .find_map(|_| {
                let mut l = QemuLink::start(elf.as_deref()).ok()?;
                l.hello().ok()?;
                l.upload(&params).ok()?;
                Some(l)
            })
            .expect("qemu link (3 attempts)");
        let mut ev = Eval { link, kd: [-42.0, -91.0, -91.0], seq: 0, _p: std::marker::PhantomData };
        if let Ok(probe) = std::env::var("LP_WORST_PROBE") {
            // `mx,my,mz;mx,my,mz;…`: the cost of these demands only (each twice, to
            // show the step cost does not depend on the previous step).
            for d in probe.split(';').filter(|t| !t.is_empty()) {
                let v: Vec<f64> = d.split(',').map(|x| x.trim().parse().expect("number")).collect();
                let m = [v[0], v[1], v[2]];
                let (c1, c2) = (ev.cost(&m), ev.cost(&m));
                println!("{} demand {m:?}: {c1} / {c2} instructions", cfg.label);
            }
            continue;
        }

        // Seed directions.
        let mut dirs: Vec<[f64; 3]> = (0..60).map(|_| unit(&mut rng)).collect();
        let mut special: Vec<[f64; 3]> = vec![];
        for (i, bi) in b.iter().enumerate() {
            special.push(normalise(*bi));
            special.push(normalise(bi.map(|x| -x)));
            for bj in &b[i + 1..] {
                let n = normalise(cross(bi, bj));
                if n.iter().all(|x| x.is_finite()) && n.iter().any(|x| *x != 0.0) {
                    special.push(n);
                    special.push(n.map(|x| -x));
                }
            }
        }
        for s in special.clone() {
            dirs.push(s);
            let e = 10f64.powf(-6.0 + 4.0 * rng.uniform());
            dirs.push(tilt(&s, e, &mut rng));
        }
        let mags: Vec<f64> = (0..7).map(|k| 10f64.powi(k - 3)).collect(); // 1e-3 .. 1e3
        let mut pop: Vec<(u64, [f64; 3])> = vec![];
        let (mut sum, mut n) = (0u128, 0u64);
        for d in &dirs {
            for &mg in &mags {
                let m = d.map(|x| x * mg * 10f64.powf(rng.uniform() - 0.5));
                let c = ev.cost(&m);
                sum += u128::from(c);
                n += 1;
                pop.push((c, m));
            }
        }
        let seed_worst = pop.iter().map(|p| p.0).max().unwrap_or(0);
        // The evolutionary-search find (dp-nominal), for every configuration.
        let mut known = known_worst(&root, &cfg.label);
        known.push([0.44, 0.32, -19.1]);
        for m in known {
            let c = ev.cost(&m);
            pop.push((c, m));
        }
        // (μ + λ) evolution.
        for _ in 0..gens {
            pop.sort_by_key(|p| std::cmp::Reverse(p.0));
            pop.truncate(MU);
            let parents: Vec<[f64; 3]> = pop.iter().map(|p| p.1).collect();
            for k in 0..CHILDREN {
                let p = parents[k % parents.len()];
                let mg = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                let d = if rng.uniform() < 0.1 {
                    tilt(
                        &special[(rng.next_u64() % special.len() as u64) as usize],
                        10f64.powf(-6.0 + 5.0 * rng.uniform()),
                        &mut rng,
                    )
                } else {
                    tilt(&normalise(p), 10f64.powf(-6.0 + 5.5 * rng.uniform()), &mut rng)
                };
                let mg2 =
                    (mg * 2f64.powf(rng.normal() * if rng.uniform() < 0.5 { 0.05 } else { 1.0 })).clamp(1e-3, 1e3);
                let m = d.map(|x| x * mg2);
                let c = ev.cost(&m);
                pop.push((c, m));
            }
        }
        pop.sort_by_key(|p| std::cmp::Reverse(p.0));
        let evals = ev.seq;
        println!(
            "qemu Cortex-M4F {label} {} ({} method, failed {:?}): searched worst {} instructions per flight step (seed set worst {seed_worst}), mean {:.0} over {n} seed demands; {evals} steps evaluated",
            cfg.label,
            cfg.method,
            cfg.failed_1based,
            pop[0].0,
            sum as f64 / n as f64
        );
        for (c, m) in pop.iter().take(3) {
            println!("    {c:>6}  demand [{:.6e}, {:.6e}, {:.6e}] N m", m[0], m[1], m[2]);
        }
        for (c, m) in pop.iter().take(5) {
            json_rows.push(serde_json::json!({
                "config": cfg.label, "scenario": format!("scenarios/paper004/{}", cfg.scenario),
                "method": cfg.method, "failed_1based": cfg.failed_1based, "demand_nm": m,
                "instructions": c, "firmware": label,
            }));
        }
        json_rows.push(serde_json::json!({"config": cfg.label, "summary": true, "firmware": label,
            "worst_instructions": pop[0].0, "mean_instructions_seed_set": sum as f64 / n as f64, "seed_demands": n, "evaluations": evals}));
    }
    if let Ok(out) = std::env::var("LP_WORST_OUT") {
        std::fs::write(&out, serde_json::to_string_pretty(&serde_json::json!({ "rows": json_rows })).expect("json"))
            .expect("write");
        println!("wrote {out}");
    }
}
