#![allow(dead_code)] // a test-support module: each test binary uses part of it
//! The one rule for tests that need a tool outside Cargo — QEMU (`qemu-system-arm`), the
//! QEMU cycle plugin, the firmware ELF, Slurm, the browser: [`require_tool`].
//!
//! - `CI` set (and not `0`/`false`; `.ci/run` sets it): a missing tool FAILS the test, with
//!   a message naming the command that installs or builds it.
//! - Otherwise (a developer's run): the test passes without testing, but says so loudly —
//!   one `SKIPPED (tool missing): …` line on stderr (not captured by the test harness) and
//!   one line appended to [`skip_log`] (`target/skipped-tests.log` at the repository root),
//!   which `scripts/test.sh` empties when it starts and sums up in one line when it ends
//!   (with plain `cargo test` the lines accumulate: delete the file to start afresh).
//!
//! One file for both test crates (sim-host's tests and acs-tests): sim-host's tests include
//! it with `#[path]`, acs-tests re-exports it (neither crate can depend on the other).

use std::fmt::Display;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A tool a test needs, with the command that provides it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tool {
    /// `qemu-system-arm` (processor-in-the-loop, timing, stack, watchdog, cycles).
    Qemu,
    /// The QEMU cycle plugin (tools/qemu-cycles: needs a C compiler and a QEMU that loads it).
    CyclePlugin,
    /// The QEMU firmware ELF (`firmware/target/thumbv7em-none-eabihf/release/acs-firmware`).
    FirmwareElf,
    /// A single-node Slurm with MUNGE (slurmctld, slurmd, slurm-client, munge).
    Slurm,
    /// The 3D replay's browser tests: `node`, Debian's Chromium, playwright-core in
    /// tools/viewer/node_modules and the viewer bundle in target/viewer.
    Browser,
}

impl Tool {
    /// What is missing, in words.
    pub fn name(self) -> &'static str {
        match self {
            Tool::Qemu => "qemu-system-arm",
            Tool::CyclePlugin => "QEMU cycle plugin",
            Tool::FirmwareElf => "QEMU firmware ELF",
            Tool::Slurm => "Slurm/MUNGE",
            Tool::Browser => "node, Chromium and the viewer bundle",
        }
    }
    /// The command that installs or builds it.
    pub fn install(self) -> &'static str {
        match self {
            Tool::Qemu => "scripts/setup.sh (apt-get install qemu-system-arm)",
            Tool::CyclePlugin => "scripts/setup.sh (a C compiler; builds tools/qemu-cycles)",
            Tool::FirmwareElf => "scripts/firmware.sh build (after scripts/setup.sh)",
            Tool::Slurm => "scripts/setup.sh (apt-get install slurmctld slurmd slurm-client munge)",
            Tool::Browser => {
                "scripts/setup.sh (apt-get install nodejs npm chromium; npm ci and the bundle in tools/viewer)"
            }
        }
    }
}

/// The value `found` holds when the tool is there. When it is missing (`Err(why)`): under CI
/// panics (the test fails), else prints one loud line, logs the skip to [`skip_log`] and
/// returns `None` — the caller then returns without testing.
pub fn require_tool<T, E: Display>(tool: Tool, found: Result<T, E>) -> Option<T> {
    let why = match found {
        // one line, whatever the tool printed (the log holds one line per skip)
        Ok(v) => return Some(v),
        Err(why) => why.to_string().lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" / "),
    };
    let test = current_test();
    if under_ci() {
        panic!("{test}: {} missing under CI ({why}); install it with {}", tool.name(), tool.install());
    }
    // `[tool] test: why; …`: scripts/test.sh counts the skips per tool from the brackets.
    let line = format!("[{}] {test}: {why}; {} provides it", tool.name(), tool.install());
    // Straight to the process's stderr: libtest captures `eprintln!` of passing tests.
    let _ = writeln!(std::io::stderr(), "SKIPPED (tool missing): {line}");
    let log = skip_log();
    let logged = log.parent().map_or(Ok(()), std::fs::create_dir_all).and_then(|()| {
        let mut f = std::fs::OpenOptions::new().create(true).append(true).open(&log)?;
        // One write per line: O_APPEND keeps concurrent tests' lines whole.
        f.write_all(format!("{line}\n").as_bytes())
    });
    if let Err(e) = logged {
        let _ = writeln!(std::io::stderr(), "SKIPPED (tool missing): could not append to {}: {e}", log.display());
    }
    None
}

/// `Ok` when `qemu-system-arm --version` runs.
pub fn qemu() -> Result<(), String> {
    match std::process::Command::new("qemu-system-arm").arg("--version").output() {
        Ok(o) if o.status.success() => Ok(()),
        Ok(o) => Err(format!("`qemu-system-arm --version` exited with {}", o.status)),
        Err(e) => Err(format!("`qemu-system-arm --version`: {e}")),
    }
}

/// Where skips are logged: `target/skipped-tests.log` at the repository root (whatever
/// `CARGO_TARGET_DIR` says, so that `scripts/test.sh` finds it).
pub fn skip_log() -> PathBuf {
    // Both including crates sit one level below the repository root.
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/skipped-tests.log")
}

/// Whether the tests run under CI: `CI` set, not empty, `0` or `false`.
pub fn under_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !matches!(v.trim().to_ascii_lowercase().as_str(), "" | "0" | "false"))
}

/// `binary::test` of the running test (libtest names each test's thread after the test).
fn current_test() -> String {
    let exe = std::env::current_exe().ok();
    let stem = exe.as_ref().and_then(|p| p.file_stem()).map(|s| s.to_string_lossy().into_owned());
    // test binaries are `<name>-<hash>`
    let binary = stem.map(|s| s.rsplit_once('-').map_or(s.clone(), |(n, _)| n.to_string())).unwrap_or_default();
    let thread = std::thread::current();
    match thread.name() {
        Some(t) if t != "main" => format!("{binary}::{t}"),
        _ => binary,
    }
}
