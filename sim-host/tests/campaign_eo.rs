//! The shipped EO-cubesat campaign (`campaigns/eo-cubesat-dispersed.toml`, issue 40),
//! flown reduced to 20 runs: its requirement keys (the boresight APE/RPE of the station
//! and target passes, `mission_pointings.pN`) exist and are finite in every run, each pass
//! happened in every run, and the merge's statistics and verdict figures equal those
//! recomputed here from the runs' `result.json` (quantiles by Hyndman & Fan type 7 written
//! separately, the Clopper–Pearson bound checked against the binomial tail it solves).

use sim_host::campaign::{self, Campaign, Shard};
use std::path::Path;

const RUNS: usize = 20;

/// A dotted summary key (`a.b.c`) in a JSON value.
fn at<'a>(v: &'a serde_json::Value, key: &str) -> &'a serde_json::Value {
    key.split('.').fold(v, |v, k| &v[k])
}

/// Type-7 quantile of sorted values: `h = (n − 1) p`, linear between neighbours.
fn quantile7(sorted: &[f64], p: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * p;
    let (lo, frac) = (h.floor() as usize, h - h.floor());
    let hi = (lo + 1).min(sorted.len() - 1);
    sorted[lo] + frac * (sorted[hi] - sorted[lo])
}

/// P(X ≥ k) for X ~ Binomial(n, p), summed term by term.
fn upper_tail(n: u64, k: u64, p: f64) -> f64 {
    let ln_choose = |j: u64| -> f64 { (1..=j).map(|i| ((n - j + i) as f64 / i as f64).ln()).sum() };
    (k..=n).map(|j| (ln_choose(j) + j as f64 * p.ln() + (n - j) as f64 * (1.0 - p).ln()).exp()).sum()
}

#[test]
fn eo_campaign_requirement_keys_exist_in_every_run_and_the_merge_recomputes() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let shipped = repo.join("campaigns/eo-cubesat-dispersed.toml");
    let c = Campaign::load(&shipped).unwrap();
    assert_eq!(c.file.runs, 200, "the shipped campaign flies 200 runs");
    let t = tempfile::tempdir().unwrap();
    let dir = t.path().join("c");
    // The planner's run-count override: the first 20 runs of the shipped campaign.
    let m = campaign::plan(&c, &dir, Some(RUNS as u32)).unwrap();
    assert_eq!(m.runs.len(), RUNS);
    campaign::run_shard(&dir, Shard::ALL, 2, false).unwrap();
    let merged = campaign::merge(&dir, false).unwrap().result;
    assert!(merged.errors.is_empty() && merged.missing.is_empty());

    let cj: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("campaign.json")).unwrap()).unwrap();
    let reqs = cj["requirements"].as_array().unwrap();
    assert_eq!(reqs.len(), 4);
    let summaries: Vec<serde_json::Value> = (0..RUNS)
        .map(|i| {
            let p = dir.join(format!("runs/{i:06}/result.json"));
            let r: serde_json::Value = serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap();
            r["summary"].clone()
        })
        .collect();
    // Both passes happened in every run: the station (p1) and the target (p2) saw the
    // spacecraft above their masks, and samples were taken after acquisition.
    for (i, s) in summaries.iter().enumerate() {
        for p in ["p1", "p2"] {
            let b = &s["mission_pointings"][p]["pointing"];
            assert!(b["segments"].as_u64().unwrap() >= 1, "run {i}: no {p} pass");
            assert!(b["primary_ape_deg"]["samples"].as_u64().unwrap() > 100, "run {i}: {p} pass without samples");
        }
    }
    for r in reqs {
        let key = r["key"].as_str().unwrap();
        assert!(key.starts_with("mission_pointings.p"), "{key}");
        let mut v: Vec<f64> = summaries
            .iter()
            .enumerate()
            .map(|(i, s)| at(s, key).as_f64().unwrap_or_else(|| panic!("run {i}: {key} missing or null")))
            .collect();
        assert!(v.iter().all(|x| x.is_finite() && *x > 0.0), "{key}: {v:?}");
        let threshold = r["value"].as_f64().unwrap();
        let passed = v.iter().filter(|x| **x < threshold).count() as u64;
        assert_eq!(r["passed"].as_u64().unwrap(), passed, "{key}");
        assert_eq!(r["runs"].as_u64().unwrap(), RUNS as u64, "{key}");

        let st = &cj["statistics"][key];
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        v.sort_by(f64::total_cmp);
        assert_eq!(st["n"].as_u64().unwrap(), RUNS as u64);
        assert_eq!(st["max"].as_f64().unwrap(), v[RUNS - 1], "{key} max");
        assert_eq!(st["min"].as_f64().unwrap(), v[0], "{key} min");
        for (name, p) in [("p50", 0.5), ("p95", 0.95), ("p99", 0.99)] {
            let want = quantile7(&v, p);
            let got = st[name].as_f64().unwrap();
            assert!((got - want).abs() <= 1e-12 * want, "{key} {name}: merge {got}, recomputed {want}");
        }
        let got = st["mean"].as_f64().unwrap();
        assert!((got - mean).abs() <= 1e-12 * mean, "{key} mean: merge {got}, recomputed {mean}");

        // The one-sided Clopper–Pearson bound p_L solves P(X >= k | n, p_L) = 1 - c.
        let c = r["confidence"].as_f64().unwrap();
        let lower = r["clopper_pearson_lower"].as_f64().unwrap();
        if passed == RUNS as u64 {
            let closed = (1.0 - c).powf(1.0 / RUNS as f64);
            assert!((lower - closed).abs() < 1e-9, "{key}: bound {lower}, closed form {closed}");
        }
        let tail = if passed == 0 { 1.0 } else { upper_tail(RUNS as u64, passed, lower) };
        assert!(passed == 0 || (tail - (1.0 - c)).abs() < 1e-6, "{key}: tail at the bound {tail}");
    }
}
