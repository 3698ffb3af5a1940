//! A shipped scenario copied into a test's directory: its top-level `duration_s` set and at
//! most one text edit applied (the edit must match, so a renamed key fails the test instead
//! of silently testing the unedited scenario).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Writes `shipped` (a path from the repository root) with `duration_s` and `edit`
/// (`(from, to)`, first occurrence) to `dir/<stem>-<n>.toml` (`n` unique in the process, so
/// several copies can share a directory) and returns that path.
pub fn scenario(dir: &Path, shipped: &str, duration_s: f64, edit: Option<(&str, &str)>) -> PathBuf {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut text = std::fs::read_to_string(repo.join(shipped)).unwrap();
    if let Some((from, to)) = edit {
        assert!(text.contains(from), "{shipped} has no `{from}`");
        text = text.replacen(from, to, 1);
    }
    let mut out = String::new();
    for line in text.lines() {
        if line.starts_with("duration_s") {
            out += &format!("duration_s = {duration_s:?}\n");
        } else {
            out += line;
            out.push('\n');
        }
    }
    static N: AtomicUsize = AtomicUsize::new(0);
    let stem = Path::new(shipped).file_stem().unwrap().to_string_lossy();
    let p = dir.join(format!("{stem}-{}.toml", N.fetch_add(1, Ordering::Relaxed)));
    std::fs::write(&p, out).unwrap();
    p
}
