//! Monte Carlo campaigns: a base scenario flown many times with dispersed parameters,
//! checked statistically against requirements.
//!
//! - [`spec`]: the campaign file, parsed and checked once (dispersions, requirements);
//! - [`path`]: scenario keys addressed by path (`initial.euler_deg[2]`);
//! - [`draw`]: per-(run, key) random streams, distributions, how a draw acts on a value;
//! - [`plan`]: every run's scenario written as a plain scenario file, and the manifest;
//! - [`exec`]: the runs of a shard, in-process on a thread pool, resumable;
//! - [`merge`]: statistics, requirement verdicts with confidence bounds, report, plots;
//! - [`stats`]: quantiles and binomial confidence bounds;
//! - [`slurm`]: a job-array script and a dependent merge job.
//!
//! The directory of a campaign: `manifest.json`, `runs/NNNNNN/scenario.toml` and
//! `result.json`, then `campaign.json`, `report.md` and `plots/` from the merge. See
//! `docs/campaigns.md`.

pub mod draw;
pub mod exec;
pub mod lock;
pub mod merge;
pub mod path;
pub mod plan;
pub mod slurm;
pub mod spec;
pub mod stats;

use std::collections::BTreeMap;

pub use exec::{RunRecord, RunStatus, ShardReport, run_shard, run_shard_until};
pub use lock::Shard;
pub use merge::{MergeOutcome, merge};
pub use plan::{Manifest, plan};
pub use spec::Campaign;

/// Results, manifests and reports are written through a temporary file and a rename.
pub use sim_core::files::write_atomic;

/// `runs/NNNNNN`: six digits (campaigns have at most a million runs).
pub fn run_dir_name(index: u32) -> String {
    format!("{index:06}")
}

/// The numeric leaves of a JSON value by key path (`a.b`, `c[2]`): numbers as `Some`,
/// nulls as `None`; strings, booleans and arrays of objects are left out.
pub fn flatten(v: &serde_json::Value) -> BTreeMap<String, Option<f64>> {
    fn walk(v: &serde_json::Value, prefix: &str, out: &mut BTreeMap<String, Option<f64>>) {
        match v {
            serde_json::Value::Number(x) => {
                out.insert(prefix.to_owned(), x.as_f64());
            }
            serde_json::Value::Null => {
                out.insert(prefix.to_owned(), None);
            }
            serde_json::Value::Object(m) => {
                for (k, x) in m {
                    let p = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                    walk(x, &p, out);
                }
            }
            serde_json::Value::Array(a) if a.iter().all(|x| x.is_number() || x.is_null()) => {
                for (i, x) in a.iter().enumerate() {
                    walk(x, &format!("{prefix}[{i}]"), out);
                }
            }
            _ => {}
        }
    }
    let mut out = BTreeMap::new();
    walk(v, "", &mut out);
    out
}
