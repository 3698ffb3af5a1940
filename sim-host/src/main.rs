//! `sim-host`: run attitude-control scenarios against the flight code.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use sim_core::link::{self, LinkKind, LinkOptions};
use sim_core::recorder::output;
use sim_core::recorder::parquet::RunMetadata;
use sim_core::recorder::summary::Summary;
use sim_core::scenario::{Controller, Scenario};
use sim_host::campaign::{Campaign, Shard};
use sim_host::fly::{Flown, FlyOptions, Verdict, Watch};
use sim_host::format;
use sim_host::timing;
use std::io::Write;
use std::path::{Path, PathBuf};

/// `println!` that does not panic when stdout is a closed pipe (`sim-host … | head`).
macro_rules! say {
    ($($t:tt)*) => {{
        let _ = writeln!(std::io::stdout().lock(), $($t)*);
    }};
}

#[derive(Parser)]
#[command(
    name = "sim-host",
    version,
    about = "Spacecraft attitude-control simulator: software- and processor-in-the-loop"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Analyze {
    /// Thruster control authority: the attainable-moment set of B (zonotope), its minimum
    /// and maximum authority, and every 1-, 2- and 3-thruster failure that loses
    /// three-axis authority.
    Thrusters {
        /// Scenario file (TOML, docs/scenario.md), e.g. scenarios/paper000/test1.toml.
        scenario: PathBuf,
        /// Print the table as JSON.
        #[arg(long)]
        json: bool,
        /// Largest number of simultaneous failures to examine.
        #[arg(long, default_value_t = 3)]
        max_failed: usize,
    },
}

#[derive(Subcommand)]
enum CampaignCmd {
    /// Draw every run of a campaign file into DIR: manifest.json and runs/NNNNNN/scenario.toml.
    Plan {
        /// Campaign file (TOML, docs/campaigns.md), e.g. campaigns/paper000-test3-dispersed.toml.
        campaign: PathBuf,
        #[arg(long)]
        out: PathBuf,
        /// Number of runs instead of the file's `runs`.
        #[arg(long)]
        runs: Option<u32>,
    },
    /// Fly the pending runs of a planned campaign (resumable), in-process on --jobs threads.
    Run {
        /// Campaign directory written by `campaign plan`.
        dir: PathBuf,
        /// Shard K of S (0-based, K < S): the runs i with i % S == K.
        #[arg(long, default_value = "0/1")]
        shard: Shard,
        /// Threads (default: every core).
        #[arg(long)]
        jobs: Option<usize>,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Statistics and requirement verdicts: campaign.json, report.md, plots/. Exit status 1
    /// when a requirement is not met or runs are missing.
    Merge {
        /// Campaign directory written by `campaign plan`.
        dir: PathBuf,
        #[arg(long)]
        no_plots: bool,
    },
    /// Write a Slurm job array (one task per shard) and a dependent merge job into DIR/slurm.
    Slurm {
        /// Campaign directory written by `campaign plan`.
        dir: PathBuf,
        #[arg(long)]
        shards: u32,
        #[arg(long)]
        partition: Option<String>,
        /// Time limit per array task, e.g. 00:30:00.
        #[arg(long)]
        time: Option<String>,
        /// Threads per shard.
        #[arg(long, default_value_t = 1)]
        cpus_per_task: u32,
    },
}

#[derive(Subcommand)]
enum TimingCmd {
    /// Search the inputs that maximise the instructions of one flight step on the QEMU
    /// firmware (lockstep); print worst and mean, optionally write the corpus (--out) and
    /// check the budget file. Exit status 1 when the worst exceeds its budget.
    Search {
        /// Scenario file (TOML, docs/scenario.md), e.g. scenarios/paper000/test1.toml.
        scenario: PathBuf,
        /// Wall-time budget of the search, s.
        #[arg(long, default_value_t = 20.0)]
        budget_seconds: f64,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Stop after this many evaluations (a result independent of the machine's speed).
        #[arg(long)]
        evaluations: Option<u64>,
        /// Write the corpus (worst inputs) to this JSON file.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Start from the entries of these corpus files too.
        #[arg(long = "seed-corpus")]
        seed_corpus: Vec<PathBuf>,
        /// Worst LP demands (JSON: arrays of 3 under keys containing "demand") to align
        /// the inputs with.
        #[arg(long)]
        demands: Option<PathBuf>,
        /// Budget file (default: timing/budget.toml when it exists).
        #[arg(long)]
        budget: Option<PathBuf>,
        /// Firmware ELF (default: firmware/target/.../release/acs-firmware).
        #[arg(long)]
        firmware: Option<PathBuf>,
    },
    /// Evaluate the hand-made FDIR seeds of a scenario with monitors on the QEMU firmware
    /// (docs/timing.md "FDIR seeds"): each seed's costliest step, what FDIR declared and
    /// the costliest declaration step.
    Seeds {
        /// Scenario file (TOML) with an [fdir] monitor.
        scenario: PathBuf,
        /// Write the seeds and their costs as a corpus file (for `timing replay`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Budget file (default: timing/budget.toml when it exists).
        #[arg(long)]
        budget: Option<PathBuf>,
        #[arg(long)]
        firmware: Option<PathBuf>,
    },
    /// Replay corpus files on the QEMU firmware, print the costs and check them against
    /// the budget file. Exit status 1 when one exceeds its budget.
    Replay {
        #[arg(required = true)]
        /// Corpus files to replay (timing/corpus/*.json, written by `timing search`).
        corpus: Vec<PathBuf>,
        /// Budget file (default: timing/budget.toml).
        #[arg(long)]
        budget: Option<PathBuf>,
        #[arg(long)]
        firmware: Option<PathBuf>,
    },
}

#[derive(Subcommand)]
enum Cmd {
    /// Run a scenario and write timeseries.parquet (or .csv), summary.json and PNG plots
    /// into --out.
    Run {
        /// Scenario file (TOML, docs/scenario.md), e.g. scenarios/paper000/test1.toml.
        scenario: PathBuf,
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// in-process | qemu | tcp:HOST:PORT | serial:DEV[@BAUD] (default: the scenario's, else in-process)
        #[arg(long)]
        link: Option<LinkKind>,
        /// Firmware ELF for --link qemu (default: firmware/target/.../release/acs-firmware).
        #[arg(long)]
        firmware: Option<PathBuf>,
        /// Skip the PNG figures.
        #[arg(long)]
        no_plots: bool,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
        /// Time-series file: parquet (timeseries.parquet) | csv (timeseries.csv).
        #[arg(long, default_value = "parquet")]
        format: output::Format,
        /// Also write the 3D replay page (replay.html, as `sim-host view`).
        #[arg(long)]
        view: bool,
    },
    /// Write the 3D replay of a run (RUN_DIR/replay.html: one self-contained page, no
    /// network; docs/viewer.md), or of one run of a merged campaign directory (--run).
    View {
        /// A run's output directory (timeseries.parquet / .csv, summary.json), or a campaign
        /// directory with --run.
        dir: PathBuf,
        /// Campaign run: `worst` (the first requirement's worst run) or its number; the run
        /// is flown again into runs/NNNNNN/out.
        #[arg(long)]
        run: Option<sim_host::view::CampaignRun>,
        /// Page to write (default DIR/replay.html).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Scenario file, for a run whose time series has none in its metadata (CSV).
        #[arg(long)]
        scenario: Option<PathBuf>,
    },
    /// Stability margins of the flight loop at an operating point, measured through the
    /// flight step (docs/margins.md): margins.json, bode.png, nyquist.png, disk.png in --out
    /// and a table. Exit status 2: loop not supported; 3: not a steady hold, or unstable.
    Margins {
        scenario: PathBuf,
        /// Operating point, s, in [0, duration_s] (default: the end of the scenario's duration).
        #[arg(long, allow_negative_numbers = true, value_parser = parse_at)]
        at: Option<f64>,
        /// Where the loop is broken: input (actuator command) | output (attitude measurement).
        #[arg(long = "loop", default_value = "input")]
        loop_point: sim_host::margins::LoopPoint,
        /// Print margins.json to stdout instead of the table.
        #[arg(long)]
        json: bool,
        /// Output directory (default: runs/<scenario>-margins).
        #[arg(long)]
        out: Option<PathBuf>,
        /// in-process | qemu (QEMU re-flies every experiment from t = 0).
        #[arg(long, default_value = "in-process")]
        link: LinkKind,
        /// Firmware ELF for --link qemu.
        #[arg(long)]
        firmware: Option<PathBuf>,
        /// Frequencies of the log-spaced grid, before refinement, in [5, 400] (with
        /// --no-refine, enough that adjacent ones are within 1.5x).
        #[arg(long, allow_negative_numbers = true, default_value_t = 40, value_parser = parse_grid_points)]
        grid_points: usize,
        /// Worker threads, in [1, 64].
        #[arg(long, allow_negative_numbers = true, default_value_t = 2, value_parser = parse_threads)]
        threads: usize,
        /// Attitude excitation aimed at, rad, in [1e-6, 1e-2].
        #[arg(long, allow_negative_numbers = true, default_value_t = 1e-4, value_parser = parse_amplitude)]
        amplitude_rad: f64,
        /// Crossover estimate, rad/s, below the control Nyquist frequency (skips the pilot
        /// sweep; the grid then starts at hint / 30 and must start below the crossover).
        #[arg(long, allow_negative_numbers = true, value_parser = parse_crossover_hint)]
        crossover_hint: Option<f64>,
        /// No refinement of crossings and peaks (needs a grid whose adjacent frequencies are
        /// within 1.5x: about 20 points over three decades).
        #[arg(long)]
        no_refine: bool,
        /// Re-fly every experiment from t = 0 even in-process (as under QEMU).
        #[arg(long)]
        refly: bool,
        /// Skip the PNG figures.
        #[arg(long)]
        no_plots: bool,
        /// closed | open (the loop broken at the actuator input, measures unstable loops)
        /// | auto (closed; open if the closed-loop experiment diverges or saturates).
        #[arg(long, value_enum, default_value_t)]
        method: sim_host::margins::MethodChoice,
        /// Refuse (exit 2) a sweep that would cost more plant (RK4) steps than this,
        /// counted before it runs (the report uses 1e7); default: no limit.
        #[arg(long, allow_negative_numbers = true, value_parser = parse_max_plant_steps)]
        max_plant_steps: Option<u64>,
        /// Measure an adaptive law (DMCS) as flown, adapting in every run, instead of at
        /// its frozen adaptation state (the default; docs/margins.md).
        #[arg(long)]
        adapting: bool,
    },
    /// Check a scenario file and print the flight parameters it uploads.
    Check {
        /// Scenario file (TOML, docs/scenario.md), e.g. scenarios/paper000/test1.toml.
        scenario: PathBuf,
    },
    /// Print the LQR gain of a `controller.type = "lqr"` scenario (computed as at load).
    Lqr {
        /// Scenario file (TOML, docs/scenario.md), e.g. scenarios/paper000/test1.toml.
        scenario: PathBuf,
    },
    /// Design analyses of a scenario's actuators.
    Analyze {
        #[command(subcommand)]
        what: Analyze,
    },
    /// The reproduction report: every shipped scenario flown, each published outcome beside
    /// ours with a verdict, the papers' figures redrawn, the experiments that explain the
    /// gaps. Writes DIR/report.md (= docs/results.md), DIR/index.html, DIR/figures/.
    Report {
        #[arg(long)]
        out: PathBuf,
        /// Papers to include, e.g. `000,004` (and `modes`); all by default.
        #[arg(long, value_delimiter = ',')]
        papers: Vec<String>,
        /// Worker threads (default: all cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// Repository root (scenarios/, docs/outcomes.toml); default: the current directory.
        #[arg(long, default_value = ".")]
        repo: PathBuf,
    },
    /// Monte Carlo campaigns: plan, run (locally or per shard), merge, Slurm scripts.
    Campaign {
        #[command(subcommand)]
        what: CampaignCmd,
    },
    /// Worst-case timing of the flight step on the firmware: search, corpus replay, budgets.
    Timing {
        #[command(subcommand)]
        what: TimingCmd,
    },
    /// Cortex-M4 cycle bounds per flight step: run the scenario against the QEMU firmware
    /// with the cycle plugin (tools/qemu-cycles) and print instructions, the cycle range and
    /// the instruction mix (docs/timing.md, "Cycles").
    Cycles {
        /// Scenario file (TOML, docs/scenario.md), e.g. scenarios/paper000/test1.toml.
        scenario: PathBuf,
        /// Firmware ELF (default: firmware/target/.../release/acs-firmware).
        #[arg(long)]
        firmware: Option<PathBuf>,
        /// Plugin .so (default: target/qemu-cycles/libcycles.so, built on demand).
        #[arg(long)]
        plugin: Option<PathBuf>,
        /// Flash wait states charged by the upper bound (STM32F405 at 168 MHz: 5).
        #[arg(long, default_value_t = sim_host::cycles::STM32F405_WAIT_STATES)]
        wait_states: u32,
        /// Simulate only this long instead of the scenario's duration_s.
        #[arg(long)]
        duration: Option<f64>,
        /// Also write the per-step figures (TSV) to this file.
        #[arg(long)]
        per_step: Option<PathBuf>,
        /// Print the statistics as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Compare two runs' time series (`timeseries.parquet` / `.csv` files or run
    /// directories) value by value, bit for bit: any two NaNs are equal, a NaN equals no
    /// infinity, and an empty CSV field (NaN or an infinity) matches any non-finite value
    /// (docs/outputs.md); exit status 1 at the first difference.
    CompareSeries {
        /// First run: its output directory, or a timeseries.parquet / .csv file.
        a: PathBuf,
        /// Second run, the same way.
        b: PathBuf,
    },
    /// Serve the flight code over TCP (a virtual flight computer for `--link tcp:ADDR`):
    /// one client at a time (others get "busy"), each session from power-on state.
    Serve {
        #[arg(long, default_value = "127.0.0.1:7878")]
        listen: String,
        /// Disconnect a client that sends nothing (or takes no reply) for this long, s.
        #[arg(long, default_value_t = link::serve::DEFAULT_IDLE_TIMEOUT.as_secs_f64())]
        idle_timeout_s: f64,
    },
}

/// The `sim-host margins` flags, parsed and range-checked by the checks `[margins]` and
/// `sim_host::margins::measure` use (`sim_core::scenario::margin_check`); what needs the
/// scenario (at_s against its duration, the hint against its Nyquist frequency, the grid
/// with --no-refine) is checked by `measure` before it flies. A refusal exits with status 2.
fn parse_number<T: std::str::FromStr>(s: &str) -> std::result::Result<T, String>
where
    T::Err: std::fmt::Display,
{
    s.trim().parse::<T>().map_err(|e| format!("{e}"))
}

fn parse_at(s: &str) -> std::result::Result<f64, String> {
    let t: f64 = parse_number(s)?;
    if t.is_finite() && t >= 0.0 { Ok(t) } else { Err("must be a time in [0, duration_s] s".into()) }
}

fn parse_grid_points(s: &str) -> std::result::Result<usize, String> {
    sim_core::scenario::margin_check::grid_points(parse_number(s)?).map_err(|e| e.why)
}

fn parse_threads(s: &str) -> std::result::Result<usize, String> {
    sim_core::scenario::margin_check::threads(parse_number(s)?).map_err(|e| e.why)
}

fn parse_amplitude(s: &str) -> std::result::Result<f64, String> {
    sim_core::scenario::margin_check::amplitude_rad(parse_number(s)?).map_err(|e| e.why)
}

fn parse_crossover_hint(s: &str) -> std::result::Result<f64, String> {
    sim_core::scenario::margin_check::crossover_hint(parse_number(s)?, None).map_err(|e| e.why)
}

fn parse_max_plant_steps(s: &str) -> std::result::Result<u64, String> {
    sim_core::scenario::margin_check::max_plant_steps(parse_number(s)?).map_err(|e| e.why)
}

/// `SIM_HOST_ASSUME_FREE_BYTES`: free space to assume on the output filesystem instead of
/// asking it (tests of the disk-space refusal).
fn assumed_free_bytes() -> Result<Option<u64>> {
    match std::env::var("SIM_HOST_ASSUME_FREE_BYTES") {
        Ok(v) => Ok(Some(v.trim().parse().with_context(|| format!("SIM_HOST_ASSUME_FREE_BYTES = {v:?}"))?)),
        Err(_) => Ok(None),
    }
}

/// A run that flew but failed (`run_status` not `ok` in its summary): exit status 3.
#[derive(Debug)]
struct RunFailed(String);

impl std::fmt::Display for RunFailed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for RunFailed {}

/// An error that ends the process with its own exit status (`sim-host run` with
/// `[margins]` not measured or not stable: `sim-host margins`'s status).
#[derive(Debug)]
struct ExitWith(u8, String);

impl std::fmt::Display for ExitWith {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.1)
    }
}

impl std::error::Error for ExitWith {}

/// Exit status of a run that completed but failed (diverged, every step refused).
const EXIT_RUN_FAILED: u8 = sim_host::fly::EXIT_RUN_FAILED;

/// Errors end the process with status 1 (3 for a failed run) and their cause chain on one
/// line (no backtrace, whatever `RUST_BACKTRACE` says: a bad scenario is the user's input,
/// not a bug).
fn main() -> std::process::ExitCode {
    match dispatch(Cli::parse().cmd) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            let _ = writeln!(std::io::stderr().lock(), "error: {e:#}");
            if let Some(m) = e.downcast_ref::<sim_host::margins::MarginError>() {
                std::process::ExitCode::from(m.exit_code() as u8)
            } else if let Some(ExitWith(code, _)) = e.downcast_ref::<ExitWith>() {
                std::process::ExitCode::from(*code)
            } else if e.downcast_ref::<RunFailed>().is_some() {
                std::process::ExitCode::from(EXIT_RUN_FAILED)
            } else {
                std::process::ExitCode::FAILURE
            }
        }
    }
}

fn dispatch(cmd: Cmd) -> Result<()> {
    match cmd {
        Cmd::Run { scenario, out, link, firmware, no_plots, quiet, format, view } => {
            let flown = run(&scenario, &out, link, firmware, RunOptions { no_plots, quiet, format });
            // A failed run (exit 3) still gets its page: it says so.
            let failed = matches!(&flown, Err(e) if e.downcast_ref::<RunFailed>().is_some());
            if view && (flown.is_ok() || failed) {
                view_run(&out, &sim_host::view::ViewOptions::default())?;
            }
            flown
        }
        Cmd::View { dir, run, out, scenario } => {
            let opts = sim_host::view::ViewOptions { out, scenario, ..Default::default() };
            match run {
                None => view_run(&dir, &opts),
                Some(which) => view_campaign_run(&dir, which, &opts),
            }
        }
        Cmd::Lqr { scenario } => lqr(&scenario),
        Cmd::Analyze { what: Analyze::Thrusters { scenario, json, max_failed } } => {
            analyze_thrusters(&scenario, json, max_failed)
        }
        Cmd::Serve { listen, idle_timeout_s } => {
            let idle_timeout = std::time::Duration::try_from_secs_f64(idle_timeout_s)
                .ok()
                .filter(|d| !d.is_zero())
                .with_context(|| format!("--idle-timeout-s {idle_timeout_s}: must be a positive number of seconds"))?;
            let l = std::net::TcpListener::bind(&listen).with_context(|| format!("binding {listen}"))?;
            eprintln!("flight code listening on {} (idle timeout {idle_timeout_s} s)", l.local_addr()?);
            link::serve::serve_with(l, &link::serve::ServeOptions { idle_timeout, max_sessions: None })
        }
        Cmd::Check { scenario } => check(&scenario),
        Cmd::Margins {
            scenario,
            at,
            loop_point,
            json,
            out,
            link,
            firmware,
            grid_points,
            threads,
            amplitude_rad,
            crossover_hint,
            no_refine,
            refly,
            no_plots,
            method,
            max_plant_steps,
            adapting,
        } => {
            let opts = sim_host::margins::MarginOptions {
                at_s: at,
                point: loop_point,
                link,
                link_options: LinkOptions { firmware, ..Default::default() },
                grid_points,
                threads,
                amplitude_rad,
                crossover_hint_rad_s: crossover_hint,
                refine: !no_refine,
                refly,
                method: method.method(),
                max_plant_steps,
                freeze_adaptation: !adapting,
            };
            margins(&scenario, &opts, json, out, no_plots)
        }
        Cmd::CompareSeries { a, b } => {
            let (ra, rb) = (output::read_run(&a)?, output::read_run(&b)?);
            let (x, y) = (&ra.series, &rb.series);
            if let Some(d) = output::first_difference_by(x, y, output::Equality::of(&ra, &rb)) {
                anyhow::bail!("{} and {} differ: {d}", a.display(), b.display());
            }
            say!("identical: {} rows of {} columns", x.len(), x.names.len());
            Ok(())
        }
        Cmd::Cycles { scenario, firmware, plugin, wait_states, duration, per_step, json } => {
            cycles(&scenario, firmware, plugin, wait_states, duration, per_step, json)
        }
        Cmd::Campaign { what } => campaign(what),
        Cmd::Report { out, papers, jobs, repo } => report(out, papers, jobs, repo),
        Cmd::Timing { what } => timing(what),
    }
}

/// The budget file given, else `timing/budget.toml` under the repository if it exists.
fn budget_file(given: Option<PathBuf>) -> Result<Option<timing::corpus::BudgetFile>> {
    let path = match given {
        Some(p) => p,
        None => {
            let p = timing::corpus::repo_root().join("timing/budget.toml");
            if !p.exists() {
                return Ok(None);
            }
            p
        }
    };
    Ok(Some(timing::corpus::BudgetFile::load(&path)?))
}

/// The scenario file of a corpus: as stored (relative to the repository root or the
/// working directory).
fn corpus_scenario(c: &timing::corpus::Corpus) -> PathBuf {
    let p = PathBuf::from(&c.scenario_file);
    if p.exists() { p } else { timing::corpus::repo_root().join(p) }
}

/// `sim-host timing search`: the search, its summary, the corpus (with `out`).
fn timing_search(what: TimingCmd) -> Result<()> {
    use timing::corpus::Corpus;
    use timing::search::SearchOptions;
    let TimingCmd::Search { scenario, budget_seconds, seed, evaluations, out, seed_corpus, demands, budget, firmware } =
        what
    else {
        anyhow::bail!("not a timing search");
    };
    let budget = budget_file(budget)?;
    let target = timing::Target::load(&scenario)?;
    let mut seeds = Vec::new();
    for c in &seed_corpus {
        let c = Corpus::load(c)?;
        for e in &c.entries {
            seeds.push(e.input.input()?);
        }
    }
    let directions = match &demands {
        Some(p) => timing::corpus::demand_directions(p)?,
        None => Vec::new(),
    };
    let mut l = link::qemu::QemuLink::start(firmware.as_deref())?;
    let mut ev = timing::Evaluator::new(target, &mut l)?;
    let opts = SearchOptions {
        budget: std::time::Duration::from_secs_f64(budget_seconds.max(0.0)),
        seed,
        max_evaluations: evaluations,
        seeds,
        directions,
        ..SearchOptions::default()
    };
    let r = timing::search::search(&mut ev, &opts)?;
    let t = &ev.target;
    let failed = timing::text::write_search(&mut std::io::stdout(), t, &r, seed, budget.as_ref())?;
    if let Some(out) = out {
        let file = scenario.display().to_string();
        Corpus::from_search(&file, &t.name, seed, budget_seconds, &r).save(&out)?;
        say!("  wrote {}", out.display());
    }
    if failed {
        anyhow::bail!("{}: the searched worst exceeds the budget", t.name);
    }
    Ok(())
}

/// `sim-host timing replay`: every corpus entry measured again against its budget.
fn timing_replay(corpus: &[PathBuf], budget: Option<PathBuf>, firmware: Option<PathBuf>) -> Result<()> {
    let budget = budget_file(budget)?;
    let mut l = link::qemu::QemuLink::start(firmware.as_deref())?;
    let mut failed = false;
    for path in corpus {
        let c = timing::corpus::Corpus::load(path)?;
        let target = timing::Target::load(&corpus_scenario(&c))?;
        let dt = target.dt_s;
        let mut ev = timing::Evaluator::new(target, &mut l)?;
        say!("{} ({}):", c.scenario, path.display());
        let replayed = timing::corpus::replay(&mut ev, &c)?;
        timing::text::write_replayed(&mut std::io::stdout(), &c.scenario, &replayed, dt, budget.as_ref(), &mut failed);
    }
    if budget.is_none() {
        anyhow::bail!("no budget file (timing/budget.toml or --budget)");
    }
    if failed {
        anyhow::bail!("a replayed step exceeds its budget");
    }
    Ok(())
}

/// `sim-host timing seeds`: every FDIR seed of the scenario measured once.
fn timing_seeds(
    scenario: &Path,
    out: Option<PathBuf>,
    budget: Option<PathBuf>,
    firmware: Option<PathBuf>,
) -> Result<()> {
    let budget = budget_file(budget)?;
    let target = timing::Target::load(scenario)?;
    let seeds = timing::search::fdir_inputs(&target);
    if seeds.is_empty() {
        anyhow::bail!("{}: no FDIR monitor in the scenario, no FDIR seeds", target.name);
    }
    let mut l = link::qemu::QemuLink::start(firmware.as_deref())?;
    let mut ev = timing::Evaluator::new(target, &mut l)?;
    let (name, dt) = (ev.target.name.clone(), ev.target.dt_s);
    say!("{name} ({}): monitors {:?}", scenario.display(), ev.target.monitors());
    let mut failed = false;
    let mut entries = Vec::new();
    for (label, x) in seeds {
        let measured = ev.evaluate(&x)?;
        if let Some(cost) = measured {
            entries.push(timing::corpus::Entry::new(label.clone(), &timing::search::Found { input: x, cost }));
        }
        let r = timing::corpus::Replayed { label, recorded: 0, measured };
        timing::text::write_replayed(&mut std::io::stdout(), &name, &[r], dt, budget.as_ref(), &mut failed);
    }
    if let Some(out) = out {
        let worst = entries.iter().map(|e| e.instructions).max().unwrap_or(0);
        let c = timing::corpus::Corpus {
            scenario: name.clone(),
            scenario_file: scenario.display().to_string(),
            seed: 0,
            budget_seconds: 0.0,
            evaluations: ev.evaluations,
            generations: 0,
            worst_instructions: worst,
            mean_instructions: entries.iter().map(|e| e.instructions as f64).sum::<f64>() / entries.len().max(1) as f64,
            population_mean_instructions: 0.0,
            nominal_instructions: None,
            entries,
        };
        c.save(&out)?;
        say!("  wrote {}", out.display());
    }
    if failed {
        anyhow::bail!("an FDIR seed's step exceeds its budget");
    }
    Ok(())
}

/// `sim-host timing …`.
fn timing(what: TimingCmd) -> Result<()> {
    match what {
        TimingCmd::Seeds { scenario, out, budget, firmware } => timing_seeds(&scenario, out, budget, firmware),
        TimingCmd::Replay { corpus, budget, firmware } => timing_replay(&corpus, budget, firmware),
        search @ TimingCmd::Search { .. } => timing_search(search),
    }
}

/// `sim-host cycles`: per-step instructions and Cortex-M4 cycle bounds on the QEMU firmware.
fn cycles(
    scenario: &Path,
    firmware: Option<PathBuf>,
    plugin: Option<PathBuf>,
    wait_states: u32,
    duration: Option<f64>,
    per_step: Option<PathBuf>,
    json: bool,
) -> Result<()> {
    use sim_host::cycles::{CyclesOptions, CyclesReport, per_step_table, run_scenario};
    let mut sc = Scenario::load(scenario)?;
    warn_deprecated(&sc);
    if let Some(d) = duration {
        sc.duration_s = d;
    }
    let opts = CyclesOptions { plugin, wait_states };
    let (summary, steps, fw) = run_scenario(&sc, firmware.as_deref(), &opts)?;
    if let Some(p) = &per_step {
        sim_core::files::write_atomic(p, per_step_table(&steps, &fw).as_bytes())?;
    }
    let report = CyclesReport::of(&summary, &steps, &fw, wait_states);
    if json {
        say!("{}", serde_json::to_string_pretty(&report.json())?);
    } else {
        report.write_text(&mut std::io::stdout());
    }
    Ok(())
}

/// `sim-host campaign …`.
fn campaign(what: CampaignCmd) -> Result<()> {
    match what {
        CampaignCmd::Plan { campaign, out, runs } => {
            let c = Campaign::load(&campaign)?;
            let m = sim_host::campaign::plan(&c, &out, runs)?;
            say!(
                "{}: planned {} of {} ({}, {}) in {}",
                m.campaign.name,
                counted(m.runs.len(), "run"),
                m.base_scenario,
                counted(m.campaign.dispersions.len(), "dispersion"),
                counted(m.campaign.requirements.len(), "requirement"),
                out.display()
            );
        }
        CampaignCmd::Run { dir, shard, jobs, quiet } => {
            let jobs = jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())).max(1);
            let start = std::time::Instant::now();
            let r = sim_host::campaign::run_shard(&dir, shard, jobs, !quiet)?;
            say!(
                "shard {}/{}: {} runs, {} already done, ran {} in {:.1} s on {jobs} threads: {} ok, {} missed a requirement, \
                 {} diverged, {} refused by the flight code, {} margins failed, {} not controlled, {} control lost unnoticed, {} recovery failed, \
                 {} pointing degraded unnoticed, {} propellant exceeded, {} errors",
                shard.index,
                shard.count,
                r.assigned,
                r.skipped,
                r.ran,
                start.elapsed().as_secs_f64(),
                r.ok,
                r.requirement_failed,
                r.diverged,
                r.all_refused,
                r.margins_failed,
                r.no_control,
                r.control_lost,
                r.recovery_failed,
                r.pointing_degraded,
                r.propellant_exceeded,
                r.errors
            );
        }
        CampaignCmd::Merge { dir, no_plots } => {
            let m = sim_host::campaign::merge(&dir, !no_plots)?;
            let r = &m.result;
            say!(
                "{}: {}/{} runs completed ({} ok, {} missed a requirement, {} diverged, {} refused by the flight code, \
                 {} margins failed, {} not controlled, {} control lost unnoticed, {} recovery failed, \
                 {} pointing degraded unnoticed, {} propellant exceeded, {} errors)",
                r.campaign,
                r.completed,
                r.runs,
                r.ok,
                r.requirement_failed,
                r.diverged.len(),
                r.all_refused.len(),
                r.margins_failed.len(),
                r.no_control.len(),
                r.control_lost.len(),
                r.recovery_failed.len(),
                r.pointing_degraded.len(),
                r.propellant_exceeded.len(),
                r.errors.len()
            );
            for q in &r.requirements {
                say!("  {}", q.statement);
            }
            for (what, runs) in [
                ("missing", &r.missing),
                ("diverged", &r.diverged),
                ("all steps refused", &r.all_refused),
                ("margins failed", &r.margins_failed),
                ("not controlled", &r.no_control),
                ("control lost unnoticed", &r.control_lost),
                ("recovery failed", &r.recovery_failed),
                ("pointing degraded unnoticed", &r.pointing_degraded),
                ("propellant exceeded", &r.propellant_exceeded),
            ] {
                if !runs.is_empty() {
                    let shown: Vec<String> = runs.iter().take(20).map(u32::to_string).collect();
                    say!("  {what} runs ({}): {}", runs.len(), shown.join(", "));
                }
            }
            for f in &m.files {
                say!("  wrote {}", f.display());
            }
            if !r.passed() {
                anyhow::bail!("campaign {} failed: see {}", r.campaign, dir.join("report.md").display());
            }
        }
        CampaignCmd::Slurm { dir, shards, partition, time, cpus_per_task } => {
            let sim_host = std::env::current_exe().context("locating this sim-host")?;
            let o = sim_host::campaign::slurm::SlurmOptions { shards, partition, time, cpus_per_task, sim_host };
            for f in sim_host::campaign::slurm::write_scripts(&dir, &o)? {
                say!("wrote {}", f.display());
            }
            say!("submit with: {}", dir.join("slurm/submit.sh").display());
        }
    }
    Ok(())
}

/// `sim-host view RUN_DIR`: the replay page and one line about it.
fn view_run(dir: &Path, opts: &sim_host::view::ViewOptions) -> Result<()> {
    let r = sim_host::view::write_replay(dir, opts)?;
    say!(
        "  wrote {} ({:.1} MB; {} of {} rows{}; {})",
        r.page.display(),
        r.page_bytes as f64 / 1e6,
        r.rows_kept,
        r.rows_recorded,
        if r.selection.buckets > 0 {
            format!(", decimated over {} buckets", r.selection.buckets)
        } else {
            String::new()
        },
        r.geometry.describe()
    );
    if r.selection.transition_rows_dropped > 0 {
        eprintln!(
            "warning: {} rows of step-channel transitions did not fit the page's bound (the page says so)",
            r.selection.transition_rows_dropped
        );
    }
    Ok(())
}

/// `sim-host view CAMPAIGN_DIR --run worst|N`: the run flown again from its scenario file
/// into `runs/NNNNNN/out` (as `campaign merge`'s re-run command does), then its page.
fn view_campaign_run(dir: &Path, which: sim_host::view::CampaignRun, opts: &sim_host::view::ViewOptions) -> Result<()> {
    let index = sim_host::view::campaign_run_index(dir, which)?;
    let run_dir = dir.join("runs").join(sim_host::campaign::run_dir_name(index));
    let scenario = run_dir.join("scenario.toml");
    if !scenario.exists() {
        anyhow::bail!("{}: no such run in the campaign", scenario.display());
    }
    let out = run_dir.join("out");
    say!("campaign run {index}: flying {} into {}", scenario.display(), out.display());
    let o = RunOptions { no_plots: true, quiet: true, format: output::Format::Parquet };
    let flown = run(&scenario, &out, None, None, o);
    if let Err(e) = &flown
        && e.downcast_ref::<RunFailed>().is_none()
    {
        return flown;
    }
    view_run(&out, opts)?;
    flown
}

/// What `sim-host run` writes besides the run's result.
struct RunOptions {
    no_plots: bool,
    quiet: bool,
    format: output::Format,
}

/// `sim-host run`: the run streamed into `out`, then the one-line summary.
fn run(scenario: &Path, out: &Path, link: Option<LinkKind>, firmware: Option<PathBuf>, o: RunOptions) -> Result<()> {
    let RunOptions { no_plots, quiet, format } = o;
    // A previous run's outputs go first: whatever happens next, the directory never shows
    // them beside (or instead of) this run's.
    output::clear_previous(out)?;
    let text = sim_core::scenario::read_capped(scenario)?;
    let sc = Scenario::from_toml(&text).with_context(|| format!("scenario {}", scenario.display()))?;
    let metadata = RunMetadata {
        scenario: sc.name.clone(),
        scenario_path: scenario.display().to_string(),
        seed: sc.sensors.seed,
        scenario_toml: text,
    };
    let opts = FlyOptions {
        link,
        link_options: LinkOptions { firmware, ..Default::default() },
        margin_threads: FlyOptions::machine_threads(),
    };
    let mut rec = output::RunOutput::new(out, !no_plots)
        .format(format)
        .metadata(metadata)
        .mode_thresholds(sc.modes.as_ref().map(|m| m.plot_thresholds()).unwrap_or_default())
        .assume_free_bytes(assumed_free_bytes()?);
    let watch = if quiet { Watch::Quiet } else { Watch::Bar };
    let Flown { summary, margins } = sim_host::fly::fly(&sc, &opts, &mut rec, watch)?;
    let margin_files = match &margins {
        Some(report) => write_margins(out, report, no_plots)?.1,
        None => Vec::new(),
    };
    let files = rec.finish(&summary)?;
    say!("{}", summary_line(&summary));
    if let Some(m) = &summary.margins {
        say!("  {}", sim_host::margins::summary::line(m));
    }
    for m in &summary.mode_transitions {
        say!("  t = {:>9.2} s: {} -> {} ({})", m.t_s, m.from, m.to, m.reason);
    }
    for l in segment_lines(&summary) {
        say!("  {l}");
    }
    for f in files.iter().chain(&margin_files) {
        say!("  wrote {}", f.display());
    }
    let a = &summary.link_anomalies;
    if *a != link::LinkAnomalies::default() {
        eprintln!("warning: link anomalies: {}", serde_json::to_string(a)?);
    }
    run_verdict(&summary)
}

/// The exit of a run that flew: its failure, else its `[margins]` verdict.
fn run_verdict(summary: &Summary) -> Result<()> {
    match sim_host::fly::verdict(summary) {
        Verdict::Ok => Ok(()),
        Verdict::Failed(message) => Err(RunFailed(message).into()),
        Verdict::Margins { exit_code, message } => Err(ExitWith(exit_code, message).into()),
    }
}

/// `margins.json` and (unless `no_plots`) the figures of `report` in `out`, each written
/// whole or not at all; returns the JSON text and the files written.
fn write_margins(
    out: &Path,
    report: &sim_host::margins::MarginReport,
    no_plots: bool,
) -> Result<(String, Vec<PathBuf>)> {
    let path = out.join("margins.json");
    let text = serde_json::to_string_pretty(report)?;
    sim_core::files::write_atomic(&path, text.as_bytes())?;
    let mut files = vec![path];
    if !no_plots {
        files.extend(sim_host::margins::plots::write(out, report)?);
    }
    Ok((text, files))
}

/// The one-line result of a run: figures to 4 significant digits, counts as integers, and
/// only the quantities the run has.
fn summary_line(s: &Summary) -> String {
    use sim_host::format::sig_short as sig;
    let mut line = format!(
        "{}: {} steps over {} s on {}; final error {} deg, settle (< {} deg) {}, RTF {}x",
        s.scenario,
        s.steps,
        sig(s.sim_time_s, 6),
        s.link,
        sig(s.final_error_deg, 4),
        sig(s.settle_bound_deg, 3),
        s.settle_time_s.map_or("never".into(), |t| format!("{} s", sig(t, 4))),
        sig(s.real_time_factor, 3)
    );
    let p = &s.pointing;
    let pc = percent(p.confidence);
    // The hold first, its window named (issue 38: a headline over the whole run included
    // the slew and the detumble).
    line += &match (s.after_settle_from_s, s.ape_after_settle_deg) {
        (Some(from), Some(ape)) => {
            format!("; APE {pc} % after settle (hold, {}–{} s) {} deg", sig(from, 6), sig(s.sim_time_s, 6), sig(ape, 4))
        }
        (Some(from), None) => {
            format!("; APE after settle: none (its window starts at {} s, after the end)", sig(from, 6))
        }
        (None, _) => "; APE after settle: none (never settled)".into(),
    };
    if let Some(ape) = p.ape_deg.total {
        let window = if p.from_s > 0.0 { "from" } else { "whole run" };
        line += &format!("; APE {pc} % ({window} {}–{} s) {} deg", sig(p.from_s, 6), sig(s.sim_time_s, 6), sig(ape, 4));
    }
    let opt =
        |name: &str, v: Option<f64>, unit: &str| v.map(|x| format!("; {name} {}{unit}", sig(x, 4))).unwrap_or_default();
    line += &opt("min m", s.min_singularity_measure, "");
    line += &opt("max gimbal rate", s.max_gimbal_rate_rad_s, " rad/s");
    line += &opt("max wheel speed", s.max_wheel_speed_rpm, " rpm");
    line += &opt("max wheel power", s.max_wheel_power_w, " W");
    line += &opt("propellant", s.propellant_kg, " kg");
    let count = |name: &str, v: Option<u64>| v.map(|x| format!("; {name} {x}")).unwrap_or_default();
    line += &count("max pulses", s.max_pulses.map(u64::from));
    line += &count("max instructions/step", s.max_step_instructions);
    line
}

/// Most pointing segments the console lists (all are in `summary.json`).
const CONSOLE_SEGMENTS: usize = 12;

/// One line per pointing segment (the longest [`CONSOLE_SEGMENTS`], in time order): its
/// mode, pointing and branch, its window, and its APE and RPE at the run's confidence (the
/// primary axis apart).
fn segment_lines(s: &Summary) -> Vec<String> {
    use sim_host::format::sig_short as sig;
    let Some(segs) = &s.pointing_segments else { return Vec::new() };
    let pc = percent(s.pointing.confidence);
    let mut longest: Vec<usize> = (0..segs.len()).collect();
    longest.sort_by(|a, b| (segs[*b].end_s - segs[*b].start_s).total_cmp(&(segs[*a].end_s - segs[*a].start_s)));
    longest.truncate(CONSOLE_SEGMENTS);
    longest.sort_unstable();
    let fig = |v: Option<f64>| v.map_or("-".to_string(), |x| sig(x, 3));
    let mut out: Vec<String> = longest
        .iter()
        .map(|&i| {
            let g = &segs[i];
            let mode = g.mode.as_deref().map(|m| format!("{m} · ")).unwrap_or_default();
            let branch = if g.branch == "otherwise" { " (otherwise)" } else { "" };
            let from = if g.from_s > g.start_s { format!(" (from {} s)", sig(g.from_s, 6)) } else { String::new() };
            let mut l = format!(
                "segment {i} {mode}{}{branch}, {}–{} s{from}: APE {} / RPE {} deg",
                g.pointing,
                sig(g.start_s, 6),
                sig(g.end_s, 6),
                fig(g.ape_deg.total),
                fig(g.rpe_deg.total)
            );
            if let (Some(a), Some(r)) = (&g.primary_ape_deg, &g.primary_rpe_deg) {
                l += &format!("; boresight APE {} / RPE {} deg", fig(a.total), fig(r.total));
            }
            l
        })
        .collect();
    if let Some(first) = out.first_mut() {
        *first = format!("pointing per segment at {pc} %: {first}");
    }
    let hidden = segs.len() - longest.len() + s.pointing_segments_unlisted.unwrap_or(0) as usize;
    if hidden > 0 {
        out.push(format!("… {hidden} more segments (summary.json pointing_segments)"));
    }
    out
}

/// `0.95` → `"95"`: a confidence level as the percentage in an index's name.
fn percent(confidence: f64) -> String {
    sim_host::format::sig_short(confidence * 100.0, 4)
}

/// `"1 requirement"`, `"2 requirements"`.
fn counted(n: usize, noun: &str) -> String {
    if n == 1 { format!("1 {noun}") } else { format!("{n} {noun}s") }
}

/// `sim-host lqr`: the scenario's controller, or every LQR/LQG mode of its mode table.
fn lqr(scenario: &Path) -> Result<()> {
    let sc = Scenario::load(scenario)?;
    let mut laws = Vec::new();
    if let Some(c) = &sc.controller {
        laws.push((String::new(), c.clone()));
    }
    if let Some(m) = &sc.modes {
        for (mode, spec) in m.slots() {
            if let Some(s) = spec.filter(|s| matches!(s.controller, Controller::Lqr { .. } | Controller::Lqg { .. })) {
                laws.push((format!(" (mode {})", mode.name()), s.controller.clone()));
            }
        }
    }
    if laws.is_empty() {
        anyhow::bail!("{}: no lqr or lqg controller", sc.name);
    }
    for (label, c) in laws {
        let d = sc.lqr_design_of(&c)?;
        say!("{}{label}: LQR on the {} model, K (N m per [rad, rad, rad, rad/s, rad/s, rad/s]):", sc.name, d.model);
        for row in d.gain {
            say!("  [{}]", row.map(|x| format!("{x:>12.5e}")).join(", "));
        }
        if !d.closed_loop_eigenvalues.is_empty() {
            say!("closed-loop eigenvalues of A - B K:");
            for e in &d.closed_loop_eigenvalues {
                say!("  {:>12.5e} {:+.5e} i", e.re, e.im);
            }
            say!("relative CARE residual {:.2e}", d.residual);
        }
    }
    Ok(())
}

/// `sim-host analyze thrusters`.
fn analyze_thrusters(scenario: &Path, json: bool, max_failed: usize) -> Result<()> {
    let sc = Scenario::load(scenario)?;
    let set = sc.thruster_set().context("the scenario has no [actuators.thrusters]")?;
    let b = set.torque_matrix();
    let table = sim_host::analysis::thrusters::failure_table(&b, &vec![1.0; b.len()], max_failed.min(b.len()));
    if json {
        say!("{}", serde_json::to_string_pretty(&table)?);
    } else {
        say!("{}: {} thrusters, torque at full thrust (N m)", sc.name, b.len());
        say!("{}", sim_host::analysis::thrusters::render_table(&table));
    }
    Ok(())
}

/// `sim-host check`: the flight parameters (or mode table) the scenario uploads.
fn report(out: PathBuf, papers: Vec<String>, jobs: Option<usize>, repo: PathBuf) -> Result<()> {
    let jobs = jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from)).max(1);
    let progress = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let opts = sim_host::report::Options { repo, out: out.clone(), papers, jobs, progress };
    let r = sim_host::report::generate(&opts)?;
    let n = |v: sim_host::report::outcomes::Verdict| r.rows.iter().filter(|x| x.verdict == v).count();
    use sim_host::report::outcomes::Verdict::*;
    say!(
        "{} outcomes: {} reproduced, {} differ (explained), {} differ (open); {} experiments",
        r.rows.len(),
        n(Reproduced),
        n(DiffersExplained),
        n(DiffersOpen),
        r.experiments.len()
    );
    say!("wrote {} and {}", out.join("report.md").display(), out.join("index.html").display());
    Ok(())
}

fn check(scenario: &Path) -> Result<()> {
    let sc = Scenario::load(scenario)?;
    warn_deprecated(&sc);
    let sum = |p: &acs_flight::params::FlightParams| p.checksum().map_err(|e| anyhow::anyhow!("{e}"));
    let head = format!(
        "{}: ok, {} steps ({} s at {} Hz control, {} dynamics substeps)",
        sc.name,
        sc.steps(),
        format::sig_short(sc.duration_s, 6),
        format::sig_short(sc.timing.control_rate_hz, 6),
        sc.timing.dynamics_substeps
    );
    if let Some(t) = sc.mode_table()? {
        say!("{head}; mode table of {} modes", t.slots.len());
        for (mode, p) in &t.slots {
            say!("\nmode {}: flight parameters to upload (checksum {:#010x}):", mode.name(), sum(p)?);
            say!("{}", table(p)?.trim_end());
        }
        say!("\nmode manager:");
        say!("{}", table(&t.manager)?.trim_end());
    } else if sc.closed_loop() {
        let p = sc.flight_params()?;
        say!("{head}\nflight parameters to upload (checksum {:#010x}):", sum(&p)?);
        say!("{}", table(&p)?.trim_end());
    } else {
        say!("{head}; open loop, no flight parameters");
    }
    Ok(())
}

/// What `check` prints of a parameter set: one aligned `key  value` line per field.
fn table<T: serde::Serialize>(p: &T) -> Result<String> {
    Ok(format::key_value_lines(&serde_json::to_value(p)?))
}

/// Prints the scenario's deprecated spellings as warnings (stderr).
fn warn_deprecated(sc: &Scenario) {
    for w in &sc.deprecations {
        eprintln!("warning: {}: {w}", sc.name);
    }
}

/// `sim-host margins`: measure, write margins.json and the figures, print the table (or
/// the JSON). A loop measured with a negative margin exits with status 3 after writing.
fn margins(
    path: &Path,
    opts: &sim_host::margins::MarginOptions,
    json: bool,
    out: Option<PathBuf>,
    no_plots: bool,
) -> Result<()> {
    let sc = Scenario::load(path)?;
    let out = out.unwrap_or_else(|| PathBuf::from("runs").join(format!("{}-margins", sc.name)));
    // A previous measurement's outputs go first: a refused one leaves none beside it.
    output::clear_files(&out, &output::MARGIN_FILES)?;
    let report = sim_host::margins::measure(&sc, opts)?;
    if let Some(note) = report.method_note.as_ref().filter(|_| json) {
        eprintln!("note: {note}");
    }
    if let Some(a) = report.adaptation.as_ref().filter(|_| json) {
        eprintln!("note: {}", a.note);
    }
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let (text, files) = write_margins(&out, &report, no_plots)?;
    if json {
        say!("{text}");
    } else {
        say!("{}", sim_host::margins::report::table(&report));
        for f in files {
            say!("  wrote {}", f.display());
        }
    }
    if !report.stable {
        return Err(
            RunFailed("a measured margin is negative: the loop is not stable at the operating point".into()).into()
        );
    }
    Ok(())
}
