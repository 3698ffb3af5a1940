//! Helpers shared by the integration tests.

use sim_host::link::in_process::InProcess;
use sim_host::runner::{self, RunResult};
use sim_host::scenario::Scenario;
use std::path::{Path, PathBuf};

/// Repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

pub fn scenario(rel: &str) -> Scenario {
    let p = repo().join("scenarios").join(rel);
    Scenario::load(&p).unwrap_or_else(|e| panic!("{}: {e:#}", p.display()))
}

pub fn run_in_process(sc: &Scenario) -> RunResult {
    runner::run(sc, &mut InProcess::new(), false).unwrap_or_else(|e| panic!("{}: {e:#}", sc.name))
}
