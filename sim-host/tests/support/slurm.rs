#![allow(dead_code)] // a test-support module: each test binary uses part of it
//! A real single-node Slurm cluster (slurmctld + slurmd + munged) started entirely under a
//! caller-supplied temporary directory, for integration tests that submit jobs with `sbatch`.
//!
//! Written against Debian 12's Slurm 22.05 and MUNGE 0.5.15 (`scripts/setup.sh` installs them).
//! The daemons write nothing outside the directory: they get `-f <dir>/slurm.conf` and every
//! path in it (state, spool, logs, PID files, the MUNGE socket and key) points into the
//! directory; the host's `/etc/slurm`, `/etc/munge` and any system Slurm/MUNGE daemons are not
//! used. Jobs run as the user running the tests, in the working directory given with
//! `--chdir` (default: the test process's), and inherit its environment.
//!
//! Expected noise in the logs, harmless here: `mpi/pmix ... can not load PMIx library`
//! (Debian builds the PMIx plugins; no MPI is used) and munged's
//! `Info: Unauthorized credential for client UID=0 GID=0` lines (jobs and RPCs still work).
//!
//! ```no_run
//! # fn main() -> anyhow::Result<()> {
//! use harness::LocalSlurm; // (in sim-host/tests/support/slurm.rs)
//! use std::time::Duration;
//! let dir = std::env::temp_dir().join("example");
//! let Some(slurm) = LocalSlurm::start(&dir)? else { return Ok(()) }; // not installed, not CI: skip
//! let array = slurm.sbatch(&["--array=0-2", "--wrap", "echo $SLURM_ARRAY_TASK_ID"])?;
//! let merge = slurm.sbatch(&[&format!("--dependency=afterany:{array}"), "--wrap", "true"])?;
//! slurm.wait_jobs_done(&[array, merge], Duration::from_secs(60))?;
//! assert!(slurm.job_records(array)?.iter().all(|r| r.state() == "COMPLETED"));
//! # Ok(()) }
//! // Dropping `slurm` cancels leftover jobs and stops the three daemons.
//! ```
//!
//! Daemons run in the foreground (`munged -F`, `slurmctld -D`, `slurmd -D`) as children of the
//! test process: the PID we hold is the one each daemon writes to its PID file, there is no
//! window between a fork and the PID file being written where a failed start would leak a
//! daemon, and the children are reaped. `Drop` stops them in reverse order with SIGTERM, waits
//! up to [`STOP_GRACE`], then SIGKILL — also when the test panics or `start` fails halfway
//! (the half-built value is dropped on the `?`).

#[path = "require_tool.rs"]
mod require_tool;

use anyhow::{Context, Result, anyhow, bail};
use require_tool::{Tool, require_tool};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs;
use std::io::{Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpListener};
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::thread;
use std::time::{Duration, Instant};

/// How long `start` waits for munged's socket and for the node to report `idle`.
pub const START_TIMEOUT: Duration = Duration::from_secs(30);
/// How long `Drop` waits after SIGTERM before SIGKILL.
pub const STOP_GRACE: Duration = Duration::from_secs(5);
/// Upper bound on any single client command (`sbatch`, `scontrol`, ...) run by the helpers.
pub const CLIENT_TIMEOUT: Duration = Duration::from_secs(20);

/// Binaries the harness needs; if any is missing, [`LocalSlurm::start`] fails under CI and
/// skips otherwise.
const REQUIRED: [&str; 7] = ["munged", "slurmctld", "slurmd", "sbatch", "scontrol", "sinfo", "scancel"];

/// Environment-variable prefixes read by the Slurm clients (e.g. `SQUEUE_FORMAT`,
/// `SBATCH_PARTITION`, or a `SLURM_JOB_ID` when the tests themselves run inside a Slurm
/// job). They are removed so the host's settings cannot leak into this cluster.
const SLURM_ENV_PREFIXES: [&str; 8] =
    ["SLURM_", "SBATCH_", "SQUEUE_", "SINFO_", "SCONTROL_", "SCANCEL_", "SALLOC_", "SRUN_"];

/// Job states after which Slurm never runs the job again.
const TERMINAL_STATES: [&str; 10] = [
    "COMPLETED",
    "FAILED",
    "CANCELLED",
    "TIMEOUT",
    "NODE_FAIL",
    "PREEMPTED",
    "BOOT_FAIL",
    "DEADLINE",
    "OUT_OF_MEMORY",
    "SPECIAL_EXIT",
];

/// One daemon started by the harness.
struct Daemon {
    name: &'static str,
    child: Child,
    log: PathBuf,
}

/// A running single-node cluster; see the module documentation.
pub struct LocalSlurm {
    dir: PathBuf,
    conf: PathBuf,
    ctld_port: u16,
    slurmd_port: u16,
    /// Started daemons in start order (munged, slurmctld, slurmd); stopped in reverse.
    daemons: Vec<Daemon>,
    /// How long `start` took until the node was idle (all attempts).
    startup: Duration,
}

/// One record of `scontrol -o show job <id>` (an array job gives one record per task).
#[derive(Debug, Clone)]
pub struct JobRecord {
    /// `Key=Value` fields as printed by scontrol (`JobId`, `ArrayTaskId`, `JobState`, `StartTime`, ...).
    pub fields: BTreeMap<String, String>,
}

impl JobRecord {
    /// A field, or "" if absent.
    pub fn get(&self, key: &str) -> &str {
        self.fields.get(key).map_or("", String::as_str)
    }
    /// `JobState`, e.g. `PENDING`, `RUNNING`, `COMPLETED`, `FAILED`.
    pub fn state(&self) -> &str {
        self.get("JobState")
    }
    /// `ArrayTaskId` (`None` for a non-array job or a not yet split range like `0-2`).
    pub fn array_task_id(&self) -> Option<u32> {
        self.get("ArrayTaskId").parse().ok()
    }
    /// True once Slurm will never run this record again.
    pub fn is_terminal(&self) -> bool {
        TERMINAL_STATES.contains(&self.state())
    }
}

fn parse_record(line: &str) -> JobRecord {
    let mut fields = BTreeMap::new();
    let mut last: Option<String> = None;
    for tok in line.split_whitespace() {
        match tok.split_once('=') {
            Some((k, v)) if k.starts_with(|c: char| c.is_ascii_uppercase()) => {
                fields.insert(k.to_string(), v.to_string());
                last = Some(k.to_string());
            }
            // A value with spaces (e.g. a Command path): glue it back onto the previous field.
            _ => {
                if let Some(v) = last.as_ref().and_then(|k| fields.get_mut(k)) {
                    v.push(' ');
                    v.push_str(tok);
                }
            }
        }
    }
    JobRecord { fields }
}

/// Finds a program on PATH or in the sbin directories (daemons live in /usr/sbin, which is
/// not on a non-root user's PATH).
fn find_program(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .chain(["/usr/sbin", "/sbin", "/usr/local/sbin"].map(PathBuf::from))
        .map(|d| d.join(name))
        .find(|p| p.is_file())
}

/// Runs `cmd` with stdout/stderr captured, killing it if it takes longer than `timeout`.
pub fn output_with_timeout(cmd: &mut Command, timeout: Duration) -> Result<Output> {
    let desc = format!("{cmd:?}");
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| format!("spawning {desc}"))?;
    let mut out = child.stdout.take().context("stdout pipe")?;
    let mut err = child.stderr.take().context("stderr pipe")?;
    let t_out = thread::spawn(move || {
        let mut b = Vec::new();
        let _ = out.read_to_end(&mut b);
        b
    });
    let t_err = thread::spawn(move || {
        let mut b = Vec::new();
        let _ = err.read_to_end(&mut b);
        b
    });
    let deadline = Instant::now() + timeout;
    let status = loop {
        if let Some(s) = child.try_wait()? {
            break s;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            bail!("{desc} did not finish within {timeout:?}");
        }
        thread::sleep(Duration::from_millis(20));
    };
    let stdout = t_out.join().map_err(|_| anyhow!("stdout reader panicked"))?;
    let stderr = t_err.join().map_err(|_| anyhow!("stderr reader panicked"))?;
    Ok(Output { status, stdout, stderr })
}

/// Last `n` lines of a file (or a note that it cannot be read).
fn tail(path: &Path, n: usize) -> String {
    match fs::read(path) {
        Ok(b) => {
            let s = String::from_utf8_lossy(&b);
            let lines: Vec<&str> = s.lines().collect();
            lines[lines.len().saturating_sub(n)..].join("\n")
        }
        Err(e) => format!("({}: {e})", path.display()),
    }
}

/// Two distinct free TCP ports on 127.0.0.1. Both listeners are held until both are chosen
/// (so they differ), then released for the daemons. Another process could take a port in
/// between; `start` retries with fresh ports if a daemon then fails to bind.
fn free_ports() -> Result<(u16, u16)> {
    let a = TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?;
    let b = TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?;
    Ok((a.local_addr()?.port(), b.local_addr()?.port()))
}

/// CPUs of this machine as slurmd sees them (`slurmd -C`), else `available_parallelism`.
/// Declaring more CPUs than slurmd detects would drain the node.
fn cpu_count(slurmd: &Path) -> u32 {
    let detected = output_with_timeout(Command::new(slurmd).arg("-C"), Duration::from_secs(10)).ok().and_then(|o| {
        String::from_utf8_lossy(&o.stdout)
            .split_whitespace()
            .find_map(|t| t.strip_prefix("CPUs=").and_then(|v| v.parse().ok()))
    });
    detected.unwrap_or_else(|| thread::available_parallelism().map_or(1, |n| n.get() as u32))
}

fn current_user() -> Result<String> {
    let o = output_with_timeout(Command::new("id").arg("-un"), Duration::from_secs(5))?;
    let u = String::from_utf8_lossy(&o.stdout).trim().to_string();
    if !o.status.success() || u.is_empty() {
        bail!("`id -un` failed: {}", String::from_utf8_lossy(&o.stderr));
    }
    Ok(u)
}

/// Writes a fresh 1024-byte MUNGE key, mode 0400, owned by the current user (munged
/// refuses a key readable by group or others).
fn write_munge_key(path: &Path) -> Result<()> {
    let mut key = [0u8; 1024];
    fs::File::open("/dev/urandom")?.read_exact(&mut key)?;
    let mut f = fs::OpenOptions::new().write(true).create_new(true).mode(0o400).open(path)?;
    f.write_all(&key)?;
    Ok(())
}

/// Generates `slurm.conf`. Every choice here is for a throw-away, single-user, loopback-only
/// test cluster; see the comments in the generated file.
fn slurm_conf(dir: &Path, cluster: &str, user: &str, ctld_port: u16, slurmd_port: u16, cpus: u32) -> String {
    let d = dir.display();
    format!(
        "\
# Generated by acs-tests (tests/src/slurm.rs) for a throw-away single-node test cluster.
ClusterName={cluster}
# Loopback only: the controller and the node are this machine, reached as localhost /
# 127.0.0.1, and CommunicationParameters below stop both daemons from binding INADDR_ANY,
# so the test cluster is never reachable from the network.
SlurmctldHost=localhost
SlurmctldPort={ctld_port}
SlurmdPort={slurmd_port}
CommunicationParameters=NoCtldInAddrAny,NoInAddrAny
# Both daemons run as the user running the tests (root not required; jobs run as that user).
SlurmUser={user}
SlurmdUser={user}
# Private munged (started by the harness with its own key); cred/munge also uses AuthInfo.
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={d}/munge.socket
# All state under the test directory.
StateSaveLocation={d}/state
SlurmdSpoolDir={d}/spool
SlurmctldPidFile={d}/slurmctld.pid
SlurmdPidFile={d}/slurmd.pid
SlurmctldLogFile={d}/slurmctld.log
SlurmdLogFile={d}/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
# No cgroups (unavailable or read-only in containers and for non-root users): processes are
# tracked through /proc parent links and tasks are not confined or bound.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
# No accounting database (slurmdbd) and no per-job usage sampling.
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
# First-in first-out scheduling (no backfill pass needed); jobs share the node CPU by CPU.
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
# Keep finished jobs in the controller for an hour: without accounting storage,
# `scontrol show job` is the only way to read a finished job's state and times.
MinJobAge=3600
# Run the full scheduling pass every second instead of every 60 s: job completions and
# satisfied dependencies are then acted on within ~1-2 s (saves ~2 s per wave of jobs).
SchedulerParameters=sched_interval=1
# A node that registers with a valid configuration goes back to service.
ReturnToService=2
# Short waits: cancelled jobs get SIGKILL 5 s after SIGTERM.
KillWait=5
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
MessageTimeout=10
NodeName=localhost NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
"
    )
}

impl LocalSlurm {
    /// Starts munged, slurmctld and slurmd under `dir` (which must exist, be private to the
    /// caller — e.g. a `tempfile::TempDir` — and have a short path without whitespace) and
    /// waits until the node is idle. When the Slurm or MUNGE binaries are not installed
    /// (`scripts/setup.sh` installs them): fails under CI, else returns `Ok(None)` after
    /// saying so loudly ([`require_tool`]).
    pub fn start(dir: &Path) -> Result<Option<LocalSlurm>> {
        let t0 = Instant::now();
        let mut missing = Vec::new();
        let mut bins = BTreeMap::new();
        for name in REQUIRED {
            match find_program(name) {
                Some(p) => {
                    bins.insert(name, p);
                }
                None => missing.push(name),
            }
        }
        let found = if missing.is_empty() { Ok(()) } else { Err(format!("missing {}", missing.join(", "))) };
        if require_tool(Tool::Slurm, found).is_none() {
            return Ok(None);
        }
        let dir = dir.canonicalize().with_context(|| format!("test directory {}", dir.display()))?;
        let dir_str = dir.to_str().context("test directory path is not UTF-8")?;
        if dir_str.contains(char::is_whitespace) {
            bail!("test directory {dir_str:?} contains whitespace, which slurm.conf cannot express");
        }
        // sun_path is 108 bytes including the NUL.
        if dir.join("cluster9/munge.socket.lock").as_os_str().len() > 107 {
            bail!("test directory {dir_str:?} is too long for a Unix socket path");
        }
        // Each attempt gets its own subdirectory `cluster<N>` (see `dir()`). Retry only when a
        // daemon lost a race for one of the ports we picked.
        let mut attempt = 0;
        loop {
            attempt += 1;
            let sub = dir.join(format!("cluster{attempt}"));
            fs::create_dir(&sub).with_context(|| format!("creating {}", sub.display()))?;
            match Self::start_in(&sub, &bins) {
                Ok(mut s) => {
                    s.startup = t0.elapsed();
                    return Ok(Some(s));
                }
                Err(e) if attempt < 3 && format!("{e:#}").contains("Address already in use") => {
                    let first = e.to_string();
                    let first = first.lines().next().unwrap_or("");
                    eprintln!("LocalSlurm: port collision in {} ({first}), retrying with new ports", sub.display());
                }
                Err(e) => return Err(e),
            }
        }
    }

    fn start_in(dir: &Path, bins: &BTreeMap<&str, PathBuf>) -> Result<LocalSlurm> {
        let user = current_user()?;
        let (ctld_port, slurmd_port) = free_ports()?;
        let mut s = LocalSlurm {
            dir: dir.to_path_buf(),
            conf: dir.join("slurm.conf"),
            ctld_port,
            slurmd_port,
            daemons: Vec::new(),
            startup: Duration::ZERO,
        };
        // From here on, any `?` drops `s`, which stops whatever was already started.
        for sub in ["state", "spool"] {
            fs::create_dir(dir.join(sub))?;
        }
        write_munge_key(&dir.join("munge.key"))?;
        let cpus = cpu_count(&bins["slurmd"]);
        let cluster = format!("acs{}", ctld_port);
        fs::write(&s.conf, slurm_conf(dir, &cluster, &user, ctld_port, slurmd_port, cpus))?;

        // munged: --force because the caller's temp dir is typically 0700 and munged wants
        // the socket's directory to be searchable by everyone (it warns instead with -f); only
        // this user's daemons and clients use the socket.
        let sock = dir.join("munge.socket");
        s.spawn(
            "munged",
            Command::new(&bins["munged"])
                .arg("-F")
                .arg("--force")
                .arg(format!("--socket={}", sock.display()))
                .arg(format!("--key-file={}", dir.join("munge.key").display()))
                .arg(format!("--pid-file={}", dir.join("munged.pid").display()))
                .arg(format!("--log-file={}", dir.join("munged.log").display()))
                .arg(format!("--seed-file={}", dir.join("munged.seed").display())),
        )?;
        s.wait_until("munged socket", START_TIMEOUT, |_| Ok(sock.exists()))?;

        let conf = s.conf.clone();
        s.spawn("slurmctld", Command::new(&bins["slurmctld"]).arg("-D").arg("-f").arg(&conf))?;
        s.spawn("slurmd", Command::new(&bins["slurmd"]).arg("-D").arg("-N").arg("localhost").arg("-f").arg(&conf))?;
        s.wait_until("node localhost idle", START_TIMEOUT, |s| {
            let o = output_with_timeout(
                s.command("sinfo").args(["-h", "-N", "-n", "localhost", "-o", "%T"]),
                CLIENT_TIMEOUT,
            )?;
            Ok(o.status.success() && String::from_utf8_lossy(&o.stdout).trim() == "idle")
        })?;
        Ok(s)
    }

    /// Spawns a foreground daemon with a clean Slurm environment; stdout/stderr go to
    /// `<name>.out` in the directory.
    fn spawn(&mut self, name: &'static str, cmd: &mut Command) -> Result<()> {
        let out = fs::File::create(self.dir.join(format!("{name}.out")))?;
        self.clean_env(cmd);
        let child = cmd
            .stdin(Stdio::null())
            .stdout(out.try_clone()?)
            .stderr(out)
            .spawn()
            .with_context(|| format!("spawning {name}"))?;
        self.daemons.push(Daemon { name, child, log: self.dir.join(format!("{name}.log")) });
        Ok(())
    }

    /// Polls `ready` every 100 ms until true; fails early if a daemon exits and after `timeout`.
    fn wait_until(
        &mut self,
        what: &str,
        timeout: Duration,
        mut ready: impl FnMut(&Self) -> Result<bool>,
    ) -> Result<()> {
        let deadline = Instant::now() + timeout;
        loop {
            let mut exited = None;
            for d in &mut self.daemons {
                if let Some(st) = d.child.try_wait()? {
                    exited = Some((d.name, st));
                    break;
                }
            }
            if let Some((name, st)) = exited {
                bail!("{name} exited ({st}) while waiting for {what}\n{}", self.diagnostics());
            }
            if ready(self)? {
                return Ok(());
            }
            if Instant::now() > deadline {
                bail!("timed out after {timeout:?} waiting for {what}\n{}", self.diagnostics());
            }
            thread::sleep(Duration::from_millis(100));
        }
    }

    fn clean_env(&self, cmd: &mut Command) {
        for (k, _) in std::env::vars_os() {
            if let Some(k) = k.to_str()
                && SLURM_ENV_PREFIXES.iter().any(|p| k.starts_with(p))
            {
                cmd.env_remove(k);
            }
        }
        cmd.env("SLURM_CONF", &self.conf);
    }

    /// A command for a Slurm client (`sbatch`, `squeue`, `scontrol`, `scancel`, `sinfo`, ...)
    /// that talks to this cluster: `SLURM_CONF` points to its slurm.conf and the caller's
    /// `SLURM_*`/`SBATCH_*`/`SQUEUE_*`... variables are removed. Jobs inherit the submitting
    /// environment (sbatch's default `--export=ALL`) and working directory unless told otherwise.
    /// The command has no timeout of its own: run it with [`output_with_timeout`].
    pub fn command(&self, program: &str) -> Command {
        let mut cmd = Command::new(find_program(program).unwrap_or_else(|| PathBuf::from(program)));
        self.clean_env(&mut cmd);
        cmd
    }

    /// Runs a client command to completion (bounded by [`CLIENT_TIMEOUT`]), failing with its
    /// stderr if it exits non-zero; returns stdout.
    pub fn run(&self, program: &str, args: &[&str]) -> Result<String> {
        let o = output_with_timeout(self.command(program).args(args), CLIENT_TIMEOUT)?;
        if !o.status.success() {
            bail!("{program} {args:?}: {}\n{}", o.status, String::from_utf8_lossy(&o.stderr));
        }
        Ok(String::from_utf8_lossy(&o.stdout).into_owned())
    }

    /// `sbatch --parsable <args>`; returns the job id (for an array, the array job id).
    pub fn sbatch(&self, args: &[&str]) -> Result<u32> {
        let out = self.run("sbatch", &[&["--parsable"][..], args].concat())?;
        // --parsable prints "<id>" or "<id>;<cluster>".
        let id = out.trim().split(';').next().unwrap_or("");
        id.parse().with_context(|| format!("sbatch printed {out:?}, expected a job id"))
    }

    /// All records the controller holds for job `id` (one per array task once the array is
    /// split; a pending array shows one record with `ArrayTaskId=0-2`). Works for finished jobs
    /// for [`MinJobAge`](https://slurm.schedmd.com/slurm.conf.html#OPT_MinJobAge) = 1 h.
    pub fn job_records(&self, id: u32) -> Result<Vec<JobRecord>> {
        let out = self.run("scontrol", &["-o", "show", "job", &id.to_string()])?;
        let recs: Vec<JobRecord> = out.lines().filter(|l| !l.trim().is_empty()).map(parse_record).collect();
        if recs.is_empty() {
            bail!("scontrol show job {id} printed nothing");
        }
        Ok(recs)
    }

    /// Polls every 250 ms until every record of every job in `ids` is in a terminal state
    /// (COMPLETED, FAILED, CANCELLED, TIMEOUT, ...). On timeout, the error carries the queue,
    /// the jobs' records and the tails of the daemons' logs.
    pub fn wait_jobs_done(&self, ids: &[u32], timeout: Duration) -> Result<()> {
        let deadline = Instant::now() + timeout;
        loop {
            let mut all_done = true;
            for &id in ids {
                if !self.job_records(id)?.iter().all(JobRecord::is_terminal) {
                    all_done = false;
                    break;
                }
            }
            if all_done {
                return Ok(());
            }
            if Instant::now() > deadline {
                let mut msg = format!("jobs {ids:?} not done after {timeout:?}\n");
                for &id in ids {
                    let _ = writeln!(msg, "--- scontrol show job {id}");
                    match self.run("scontrol", &["show", "job", &id.to_string()]) {
                        Ok(s) => msg.push_str(&s),
                        Err(e) => msg.push_str(&format!("{e:#}\n")),
                    }
                }
                msg.push_str(&self.diagnostics());
                bail!(msg);
            }
            thread::sleep(Duration::from_millis(250));
        }
    }

    /// The directory holding slurm.conf, logs, state and spool: `<dir given to start>/cluster<N>`.
    pub fn dir(&self) -> &Path {
        &self.dir
    }
    /// Path of the generated slurm.conf.
    pub fn conf(&self) -> &Path {
        &self.conf
    }
    /// TCP ports of slurmctld and slurmd (both bound to 127.0.0.1).
    pub fn ports(&self) -> (u16, u16) {
        (self.ctld_port, self.slurmd_port)
    }
    /// How long `start` took until the node was idle.
    pub fn startup_time(&self) -> Duration {
        self.startup
    }
    /// `(name, pid)` of the running daemons.
    pub fn daemon_pids(&self) -> Vec<(&'static str, u32)> {
        self.daemons.iter().map(|d| (d.name, d.child.id())).collect()
    }

    /// TCP and UDP sockets in LISTEN state (TCP) or bound (UDP) that belong to the daemons,
    /// found by matching the socket inodes in `/proc/<pid>/fd` against `/proc/net/{tcp,tcp6,udp,udp6}`.
    pub fn listening_sockets(&self) -> Result<Vec<(&'static str, SocketAddr)>> {
        let mut inode_owner = BTreeMap::new();
        for (name, pid) in self.daemon_pids() {
            for e in fs::read_dir(format!("/proc/{pid}/fd"))? {
                let Ok(target) = fs::read_link(e?.path()) else { continue };
                let t = target.to_string_lossy();
                if let Some(ino) = t.strip_prefix("socket:[").and_then(|r| r.strip_suffix(']')) {
                    inode_owner.insert(ino.to_string(), name);
                }
            }
        }
        let mut found = Vec::new();
        for (table, v6, listen_state) in
            [("tcp", false, Some("0A")), ("tcp6", true, Some("0A")), ("udp", false, None), ("udp6", true, None)]
        {
            let Ok(text) = fs::read_to_string(format!("/proc/net/{table}")) else { continue };
            for line in text.lines().skip(1) {
                let f: Vec<&str> = line.split_whitespace().collect();
                if f.len() < 10 || listen_state.is_some_and(|s| f[3] != s) {
                    continue;
                }
                if let Some(&name) = inode_owner.get(f[9]) {
                    found.push((name, parse_proc_addr(f[1], v6)?));
                }
            }
        }
        Ok(found)
    }

    /// Tails of the daemons' logs and their exit status, for error messages.
    pub fn diagnostics(&self) -> String {
        let mut s = String::new();
        for d in &self.daemons {
            // In the foreground, munged logs to stderr only; slurmctld/slurmd log to both.
            // A daemon that dies early (e.g. bind failure) may only have written to stderr.
            let has_log = fs::metadata(&d.log).is_ok_and(|m| m.len() > 0);
            let log = if has_log { d.log.clone() } else { self.dir.join(format!("{}.out", d.name)) };
            let _ = writeln!(s, "--- {} (pid {}) {}:\n{}", d.name, d.child.id(), log.display(), tail(&log, 25));
        }
        s
    }
}

/// Parses `0100007F:1F90` (IPv4) or the 32-hex-digit IPv6 form of /proc/net/tcp6.
fn parse_proc_addr(s: &str, v6: bool) -> Result<SocketAddr> {
    let (ip, port) = s.split_once(':').context("proc net address")?;
    let port = u16::from_str_radix(port, 16)?;
    // The kernel prints each 32-bit word in host (little-endian on x86/ARM) byte order.
    let words: Vec<[u8; 4]> = (0..ip.len() / 8)
        .map(|i| u32::from_str_radix(&ip[i * 8..i * 8 + 8], 16).map(|w| w.to_le_bytes()))
        .collect::<Result<_, _>>()?;
    let addr = if v6 {
        let b: Vec<u8> = words.concat();
        let arr: [u8; 16] = b.try_into().map_err(|_| anyhow!("bad IPv6 {ip}"))?;
        std::net::IpAddr::from(arr)
    } else {
        std::net::IpAddr::from(*words.first().context("empty IPv4")?)
    };
    Ok(SocketAddr::new(addr, port))
}

fn alive(child: &mut Child) -> bool {
    matches!(child.try_wait(), Ok(None))
}

impl Drop for LocalSlurm {
    /// Cancels any leftover job (slurmd does not kill running job steps when it stops), then
    /// stops slurmd, slurmctld and munged: SIGTERM, up to [`STOP_GRACE`], then SIGKILL.
    fn drop(&mut self) {
        let ctld_up = self.daemons.iter_mut().any(|d| d.name == "slurmctld" && alive(&mut d.child));
        if ctld_up && let Ok(user) = current_user() {
            let _ = output_with_timeout(self.command("scancel").args(["-u", &user]), Duration::from_secs(10));
            // Give the steps a moment to be signalled before slurmd goes away.
            let deadline = Instant::now() + STOP_GRACE;
            while Instant::now() < deadline {
                match self.run("squeue", &["-h", "-o", "%i"]) {
                    Ok(out) if out.trim().is_empty() => break,
                    Ok(_) => thread::sleep(Duration::from_millis(200)),
                    Err(_) => break,
                }
            }
        }
        while let Some(mut d) = self.daemons.pop() {
            if !alive(&mut d.child) {
                continue;
            }
            let pid = d.child.id().to_string();
            let _ = Command::new("kill").args(["-TERM", &pid]).stderr(Stdio::null()).status();
            let deadline = Instant::now() + STOP_GRACE;
            while alive(&mut d.child) && Instant::now() < deadline {
                thread::sleep(Duration::from_millis(50));
            }
            if alive(&mut d.child) {
                eprintln!("LocalSlurm: {} (pid {pid}) ignored SIGTERM for {STOP_GRACE:?}; SIGKILL", d.name);
                let _ = d.child.kill();
            }
            let _ = d.child.wait();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_scontrol_records() {
        let r = parse_record(
            "JobId=5 ArrayJobId=4 ArrayTaskId=1 JobName=wrap JobState=COMPLETED Reason=None \
             NtasksPerN:B:S:C=0:0:*:* Command=/tmp/a b.sh WorkDir=/tmp",
        );
        assert_eq!(r.state(), "COMPLETED");
        assert_eq!(r.array_task_id(), Some(1));
        assert_eq!(r.get("Command"), "/tmp/a b.sh");
        assert_eq!(r.get("WorkDir"), "/tmp");
        assert!(r.is_terminal());
    }

    #[test]
    fn parses_proc_net_addresses() {
        assert_eq!(parse_proc_addr("0100007F:1F90", false).unwrap(), "127.0.0.1:8080".parse().unwrap());
        assert_eq!(
            parse_proc_addr("00000000000000000000000001000000:0016", true).unwrap(),
            "[::1]:22".parse().unwrap()
        );
    }
}
