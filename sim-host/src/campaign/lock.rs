//! One runner per shard of a campaign directory: `campaign run DIR --shard K/S` holds
//! `DIR/.run-lock-K-of-S` while it flies. The file is created with `O_EXCL` and holds the
//! runner's pid, host and shard; the runner also holds an advisory lock (`flock`) on it,
//! which the kernel releases however the process ends, and removes the file on exit.
//!
//! - A second runner of the same shard, or of any shard of another count `S'` (whose runs
//!   overlap), refuses with the holder's pid and host.
//! - **Stale rule**: a lock file that no process holds the advisory lock on, and that
//!   carries a pid (written after locking), belongs to a runner that died without removing
//!   it (killed, node lost): it is removed and taken. An empty lock file that is not
//!   locked is a runner between its create and its lock — or, if it stays, a lock to
//!   remove by hand; the message says so.
//! - On a filesystem without advisory locks, an existing lock file is never taken
//!   over: remove it by hand once no runner is alive.

use anyhow::{Context, Result, anyhow, bail};
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Write};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// Shard `index` of `count` (0-based, as a job array's task index): runs `i` with
/// `i % count == index`, so that every shard gets runs from the whole campaign.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
}

impl Shard {
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    pub fn owns(&self, run: u32) -> bool {
        run % self.count == self.index
    }
}

impl FromStr for Shard {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Self> {
        let (k, n) = s.split_once('/').ok_or_else(|| anyhow!("--shard K/S (e.g. 0/4), got {s:?}"))?;
        let index: u32 = k.trim().parse().map_err(|_| anyhow!("--shard: {k:?} is not a shard index"))?;
        let count: u32 = n.trim().parse().map_err(|_| anyhow!("--shard: {n:?} is not a shard count"))?;
        if count == 0 || index >= count {
            bail!("--shard K/S needs 0 <= K < S (got {index}/{count})");
        }
        Ok(Shard { index, count })
    }
}

/// The lock of one shard, held while it lives (removed on drop).
#[derive(Debug)]
pub struct ShardLock {
    path: PathBuf,
    _file: File,
}

fn lock_name(shard: Shard) -> String {
    format!(".run-lock-{}-of-{}", shard.index, shard.count)
}

/// The shard of a lock file name, if it is one.
fn shard_of(name: &str) -> Option<Shard> {
    let (k, s) = name.strip_prefix(".run-lock-")?.split_once("-of-")?;
    Some(Shard { index: k.parse().ok()?, count: s.parse().ok()? })
}

fn host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname").map_or_else(|_| "unknown".into(), |h| h.trim().to_owned())
}

fn contents(f: &mut File) -> String {
    let mut s = String::new();
    let _ = f.read_to_string(&mut s);
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Whether the lock file at `path` is held: `Some(holder)` when it is (or may be),
/// `None` when it is stale (and then it has been removed).
fn held(path: &Path) -> Result<Option<String>> {
    let mut f = match File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e).with_context(|| format!("opening {}", path.display())),
    };
    let who = contents(&mut f);
    match f.try_lock() {
        Err(TryLockError::WouldBlock) => Ok(Some(who)),
        Err(TryLockError::Error(e)) => {
            Ok(Some(format!("{who} (advisory locks unsupported here: {e}; remove the file if no runner is alive)")))
        }
        Ok(()) if who.is_empty() => {
            Ok(Some("a runner that has not written its pid yet (remove the file if this persists)".into()))
        }
        Ok(()) => {
            // Stale: its runner died. Remove it only if the path still names this file
            // (another runner may have replaced it meanwhile).
            let same = std::fs::metadata(path)
                .ok()
                .zip(f.metadata().ok())
                .is_some_and(|(a, b)| a.ino() == b.ino() && a.dev() == b.dev());
            if same {
                std::fs::remove_file(path).with_context(|| format!("removing the stale lock {}", path.display()))?;
            }
            Ok(None)
        }
    }
}

impl ShardLock {
    /// Takes the lock of `shard` on the campaign directory `dir`, or refuses naming the
    /// runner that holds it or an overlapping shard.
    pub fn acquire(dir: &Path, shard: Shard) -> Result<Self> {
        let path = dir.join(lock_name(shard));
        for _ in 0..3 {
            let mut file = match OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(f) => f,
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    if let Some(who) = held(&path)? {
                        bail!(
                            "{} is locked by another `campaign run` of shard {}/{} ({who}): wait for it, or remove \
                             the lock file if that runner is gone (see docs/campaigns.md, \"Locks\")",
                            dir.display(),
                            shard.index,
                            shard.count
                        );
                    }
                    continue; // stale lock removed: try again
                }
                Err(e) => return Err(e).with_context(|| format!("creating the lock {}", path.display())),
            };
            // Unsupported advisory locks: the O_EXCL file alone guards (never taken over).
            if let Err(TryLockError::WouldBlock) = file.try_lock() {
                bail!("{}: another runner locked it as it was created; try again", path.display());
            }
            let me = format!("pid {}\nhost {}\nshard {}/{}\n", std::process::id(), host(), shard.index, shard.count);
            file.write_all(me.as_bytes()).with_context(|| format!("writing the lock {}", path.display()))?;
            let lock = ShardLock { path, _file: file };
            lock.refuse_overlaps(dir, shard)?;
            return Ok(lock);
        }
        bail!("{}: could not take the lock (it changed hands three times)", path.display())
    }

    /// Refuses when a live runner holds a shard of another count (their runs overlap).
    fn refuse_overlaps(&self, dir: &Path, shard: Shard) -> Result<()> {
        let entries = std::fs::read_dir(dir).with_context(|| format!("listing {}", dir.display()))?;
        for e in entries.flatten() {
            let name = e.file_name();
            let Some(other) = name.to_str().and_then(shard_of) else { continue };
            if other.count == shard.count {
                continue;
            }
            if let Some(who) = held(&e.path())? {
                bail!(
                    "{}: a `campaign run` of shard {}/{} is running ({who}); shards of {} and of {} overlap",
                    dir.display(),
                    other.index,
                    other.count,
                    other.count,
                    shard.count
                );
            }
        }
        Ok(())
    }
}

impl Drop for ShardLock {
    fn drop(&mut self) {
        // Removed while still locked, so no other runner sees it unlocked and takes it.
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_runner_per_shard_overlaps_refused_stale_locks_taken() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        let all = Shard::ALL;
        let a = ShardLock::acquire(d, all).unwrap();
        let held_by = std::fs::read_to_string(d.join(".run-lock-0-of-1")).unwrap();
        assert!(held_by.contains(&format!("pid {}", std::process::id())), "{held_by}");
        // The same shard again: refused naming the holder (a second open file description
        // of the same process conflicts like another process's).
        let e = ShardLock::acquire(d, all).unwrap_err().to_string();
        assert!(e.contains("locked by another") && e.contains(&format!("pid {}", std::process::id())), "{e}");
        // A shard of another count overlaps: refused (and its own lock file removed).
        let e = ShardLock::acquire(d, Shard { index: 1, count: 2 }).unwrap_err().to_string();
        assert!(e.contains("overlap"), "{e}");
        assert!(!d.join(".run-lock-1-of-2").exists());
        drop(a);
        assert!(!d.join(".run-lock-0-of-1").exists(), "removed on exit");
        // Shards of one count run side by side.
        let s0 = ShardLock::acquire(d, Shard { index: 0, count: 2 }).unwrap();
        let s1 = ShardLock::acquire(d, Shard { index: 1, count: 2 }).unwrap();
        drop((s0, s1));
        // A stale lock (its runner died: a pid, no advisory lock held) is taken over.
        std::fs::write(d.join(".run-lock-0-of-1"), "pid 4000000\nhost elsewhere\nshard 0/1\n").unwrap();
        let b = ShardLock::acquire(d, all).unwrap();
        let now = std::fs::read_to_string(d.join(".run-lock-0-of-1")).unwrap();
        assert!(now.contains(&format!("pid {}", std::process::id())), "{now}");
        drop(b);
        // An empty unlocked file (a runner between create and lock) is not taken over.
        std::fs::write(d.join(".run-lock-0-of-1"), "").unwrap();
        assert!(ShardLock::acquire(d, all).is_err());
    }
}
