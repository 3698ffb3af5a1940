//! The worker pool of the seeded fuzz tests (`sim-host/tests/fault_fuzz.rs`,
//! `scenario_fuzz.rs`, `margins_fuzz.rs`): every case judged once, a few at a time, each in
//! its own directory, the verdicts handed back in case order — so a seed gives the same
//! cases and the same report whatever the threads' timing.

use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Runs `judge(case, dir)` on every case of `all` on `workers` threads (at least one); each
/// case gets a fresh directory `root/case{i}`, created before and removed after it. Returns
/// `(i, verdict)` for every case, in case order.
pub fn run_cases<C: Sync, V: Send>(
    all: &[C],
    workers: usize,
    root: &Path,
    judge: impl Fn(&C, &Path) -> V + Sync,
) -> Vec<(usize, V)> {
    let next = AtomicUsize::new(0);
    let verdicts = Mutex::new(Vec::with_capacity(all.len()));
    std::thread::scope(|s| {
        for _ in 0..workers.max(1) {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::SeqCst);
                    let Some(c) = all.get(i) else { break };
                    let dir = root.join(format!("case{i}"));
                    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
                    let v = judge(c, &dir);
                    std::fs::remove_dir_all(&dir).ok();
                    verdicts.lock().unwrap_or_else(|p| p.into_inner()).push((i, v));
                }
            });
        }
    });
    let mut v = verdicts.into_inner().unwrap_or_else(|p| p.into_inner());
    v.sort_by_key(|(i, _)| *i);
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every case judged exactly once, in its own fresh directory, handed back in order,
    /// whatever the number of workers.
    #[test]
    fn every_case_once_in_order_each_in_a_fresh_directory() {
        let root = std::env::temp_dir().join(format!("acs-run-cases-{}", std::process::id()));
        let cases: Vec<u64> = (0..37).map(|i| i * i).collect();
        for workers in [0, 1, 3] {
            let v = run_cases(&cases, workers, &root, |c, dir| {
                let fresh = std::fs::read_dir(dir).unwrap().next().is_none();
                std::fs::write(dir.join("x"), c.to_string()).unwrap();
                (*c, fresh, dir.file_name().unwrap().to_string_lossy().into_owned())
            });
            assert_eq!(v.len(), cases.len());
            for (k, (i, (c, fresh, name))) in v.iter().enumerate() {
                assert_eq!((*i, *c, *fresh, name.as_str()), (k, cases[k], true, format!("case{k}").as_str()));
            }
            assert!(std::fs::read_dir(&root).map_or(true, |mut d| d.next().is_none()), "directories removed");
        }
        std::fs::remove_dir_all(&root).ok();
    }
}
