//! `cargo bench -p sim-host --bench campaign`: the shipped 1,000-run paper 000 test 3
//! campaign, in-process, end to end — plan, run on every core, merge (with plots) — and
//! the per-run overhead beyond the simulation itself.
//!
//! Not a test: it prints figures. The overhead is measured by flying the same 1,000
//! planned scenarios again, already parsed, on one thread with nothing written
//! (`sim_core::runner::fly`), and comparing with the campaign's run phase on the same number of
//! threads: overhead per run = (threads × run-phase wall − Σ flight wall) / runs.

use sim_core::scenario::Scenario;
use sim_host::campaign::{self, Campaign, Shard};
use std::path::Path;
use std::time::Instant;

fn main() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../campaigns/paper000-test3-dispersed.toml");
    let c = Campaign::load(&file).expect("campaign");
    let tmp = std::env::temp_dir().join(format!("sim-host-campaign-bench-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());

    let t0 = Instant::now();
    let m = campaign::plan(&c, &tmp, None).expect("plan");
    let plan_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let r = campaign::run_shard(&tmp, Shard::ALL, threads, false).expect("run");
    let run_s = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let merged = campaign::merge(&tmp, true).expect("merge");
    let merge_s = t2.elapsed().as_secs_f64();
    let total = t0.elapsed().as_secs_f64();
    let n = m.runs.len();
    assert_eq!(r.ran, n);

    // The simulation alone: the same scenarios, parsed beforehand, one thread, no files.
    let scenarios: Vec<Scenario> =
        m.runs.iter().map(|run| Scenario::load(&tmp.join(&run.scenario)).expect("scenario")).collect();
    let t3 = Instant::now();
    for sc in &scenarios {
        sim_core::runner::fly(sc).expect("flight");
    }
    let fly_s = t3.elapsed().as_secs_f64();
    let overhead_ms = (threads as f64 * run_s - fly_s) / n as f64 * 1e3;

    println!("campaign {} ({n} runs of {}, {threads} threads)", m.campaign.name, m.base_scenario);
    println!("  plan   {plan_s:>7.3} s");
    println!(
        "  run    {run_s:>7.3} s  ({:.0} runs/min; {} ok, {} missed, {} errors)",
        n as f64 / run_s * 60.0,
        r.ok,
        r.requirement_failed,
        r.errors
    );
    println!("  merge  {merge_s:>7.3} s  ({} files)", merged.files.len());
    println!("  total  {total:>7.3} s  ({:.0} runs/min end to end)", n as f64 / total * 60.0);
    println!("  flight alone, 1 thread: {fly_s:.3} s = {:.3} ms/run", fly_s / n as f64 * 1e3);
    println!("  overhead per run beyond the flight (parse, set-up, result file): {overhead_ms:.3} ms");
    let _ = std::fs::remove_dir_all(&tmp);
}
