//! Output files written whole or not at all: a temporary file in the same directory, then
//! a rename over the destination, so that a reader (a resumed shard, a merge, a user) never
//! sees half a file and a failed write (a full disk) leaves the previous file, not an empty
//! one. Every error names the file.

use anyhow::{Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The temporary sibling of `path` used by [`write_atomic`] (hidden, unique to this
/// process and thread).
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("file");
    path.with_file_name(format!(".{name}.tmp-{}-{:?}", std::process::id(), std::thread::current().id()))
}

/// Writes `bytes` to `path` through [`temp_path`] and a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = temp_path(path);
    let written = std::fs::File::create(&tmp).and_then(|mut f| f.write_all(bytes));
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(e).with_context(|| format!("writing {}", path.display()));
    }
    rename(&tmp, path)
}

/// Renames `tmp` over `path` (removing `tmp` if that fails).
pub fn rename(tmp: &Path, path: &Path) -> Result<()> {
    std::fs::rename(tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(tmp);
        anyhow::Error::new(e).context(format!("writing {} (renaming {} over it)", path.display(), tmp.display()))
    })
}

/// Removes `path` if it exists (a previous run's output); an error names the file.
pub fn remove_if_present(path: &Path) -> Result<()> {
    match std::fs::remove_file(path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e).with_context(|| format!("removing the previous run's {}", path.display())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_atomic_write_keeps_the_old_file_and_names_the_new_one() {
        let tmp = tempfile::tempdir().unwrap();
        let p = tmp.path().join("summary.json");
        write_atomic(&p, b"old").unwrap();
        write_atomic(&p, b"new").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new");
        // The destination is a directory: the rename fails, the error names it, and no
        // temporary file is left behind.
        let d = tmp.path().join("dir.json");
        std::fs::create_dir(&d).unwrap();
        std::fs::write(d.join("x"), b"x").unwrap();
        let e = format!("{:#}", write_atomic(&d, b"data").unwrap_err());
        assert!(e.contains(&d.display().to_string()), "{e}");
        let left: Vec<_> = std::fs::read_dir(tmp.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(left.len(), 2, "{left:?}");
        // A directory that does not exist: the error names the file.
        let q = tmp.path().join("missing/summary.json");
        let e = format!("{:#}", write_atomic(&q, b"x").unwrap_err());
        assert!(e.contains(&q.display().to_string()), "{e}");
    }
}
