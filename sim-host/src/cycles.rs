//! Cortex-M4 cycle bounds per flight step, from the instruction mix the firmware executes
//! under QEMU (see docs/timing.md, "Cycles").
//!
//! QEMU counts instructions, not cycles. The TCG plugin in `tools/qemu-cycles`
//! (GPL-2.0-or-later, built by `tools/qemu-cycles/build.sh`; this crate only starts QEMU
//! with it and reads its text output) classifies every executed instruction of every
//! `Fsw::step` call and writes, per step, the instruction count, a lower and an upper
//! cycle bound (Cortex-M4 TRM timings; upper: STM32F405 flash wait states the ART
//! accelerator may fail to hide) and the instruction mix. [`CyclesLink`] is a QEMU link
//! that pairs each [`StepReport`] with that line; [`measure_frames`] runs a recorded
//! sequence of sensor frames through it (for the worst-case search).

use acs_flight::link::{FswMsg, HostMsg, SensorFrame, StepReport};
use anyhow::{Context, Result, bail};
use sim_core::link::qemu::QemuLink;
use sim_core::link::{FlightLink, LinkInfo};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// STM32F405 core clock used for the µs figures (RM0090: 168 MHz maximum).
pub const STM32F405_HZ: f64 = 168e6;
/// Flash wait states of the STM32F405 at 168 MHz, 2.7–3.6 V (RM0090 table 10).
pub const STM32F405_WAIT_STATES: u32 = 5;

/// One `Fsw::step` as the plugin saw it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepCycles {
    pub instructions: u64,
    pub cycles_lower: u64,
    pub cycles_upper: u64,
    /// Executions per class and the extra counters, by the plugin's column names (`alu`,
    /// `load`, `fp_div`, …, `taken`, `soft_float`, `soft_float_calls`, …).
    pub mix: BTreeMap<String, u64>,
}

impl StepCycles {
    pub fn get(&self, k: &str) -> u64 {
        self.mix.get(k).copied().unwrap_or(0)
    }
    fn sum(&self, ks: &[&str]) -> u64 {
        ks.iter().map(|k| self.get(k)).sum()
    }
    /// VFP instructions (arithmetic, moves, loads/stores).
    pub fn fp(&self) -> u64 {
        self.sum(&["fp", "fp_mov2", "fp_mac", "fp_div", "fp_load", "fp_store", "fp_ldm_stm"])
    }
    /// Loads and stores, integer and VFP, single and multiple.
    pub fn loads_stores(&self) -> u64 {
        self.sum(&["load", "store", "ldrd", "ldm_stm", "fp_load", "fp_store", "fp_ldm_stm"])
    }
    /// Branches (including table branches), taken or not.
    pub fn branches(&self) -> u64 {
        self.sum(&["branch", "tbb"])
    }
    /// Instructions executed inside compiler-builtins soft-float routines (f64 emulation).
    pub fn soft_float(&self) -> u64 {
        self.get("soft_float")
    }
}

/// The plugin's output: a header line, then one line per step.
fn parse_line(header: &[String], line: &str) -> Result<StepCycles> {
    let vals: Vec<&str> = line.trim_end().split('\t').collect();
    if vals.len() != header.len() {
        bail!("cycles plugin line has {} fields, header {}: {line:?}", vals.len(), header.len());
    }
    let mut s = StepCycles::default();
    for (k, v) in header.iter().zip(vals) {
        let v: u64 = v.parse().with_context(|| format!("cycles plugin field {k} = {v:?}"))?;
        match k.as_str() {
            "window" => {}
            "instructions" => s.instructions = v,
            "cycles_lower" => s.cycles_lower = v,
            "cycles_upper" => s.cycles_upper = v,
            _ => {
                s.mix.insert(k.clone(), v);
            }
        }
    }
    Ok(s)
}

/// All step lines of a complete plugin output file (header first).
pub fn parse_output(text: &str) -> Result<Vec<StepCycles>> {
    let mut lines = text.lines();
    let header: Vec<String> =
        lines.next().context("empty cycles plugin output")?.split('\t').map(str::to_string).collect();
    lines.filter(|l| !l.is_empty()).map(|l| parse_line(&header, l)).collect()
}

/// The plugin shared object: `$ACS_QEMU_CYCLES_PLUGIN`, else `target/qemu-cycles/libcycles.so`.
pub fn plugin_path() -> PathBuf {
    if let Ok(p) = std::env::var("ACS_QEMU_CYCLES_PLUGIN") {
        return PathBuf::from(p);
    }
    repo_root().join("target/qemu-cycles/libcycles.so")
}

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Builds the plugin if its sources are newer (needs a C compiler); returns its path.
pub fn build_plugin() -> Result<PathBuf> {
    let out = plugin_path();
    let script = repo_root().join("tools/qemu-cycles/build.sh");
    let st = std::process::Command::new("bash")
        .arg(&script)
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .status()
        .with_context(|| format!("running {}", script.display()))?;
    if !st.success() {
        bail!("{} failed ({st}): is a C compiler installed (apt-get install gcc)?", script.display());
    }
    Ok(out)
}

/// Plugin settings.
#[derive(Clone, Debug)]
pub struct CyclesOptions {
    /// Plugin `.so` (default [`plugin_path`], built on demand).
    pub plugin: Option<PathBuf>,
    /// Flash wait states charged by the upper bound.
    pub wait_states: u32,
}

impl Default for CyclesOptions {
    fn default() -> Self {
        Self { plugin: None, wait_states: STM32F405_WAIT_STATES }
    }
}

/// A QEMU link with the cycle plugin: every [`FlightLink::step`] also reads the plugin's
/// line for that step (written before the firmware sends its reply).
pub struct CyclesLink {
    qemu: QemuLink,
    out: PathBuf,
    reader: BufReader<std::fs::File>,
    header: Vec<String>,
    pending: String,
    /// Per step, in order: the plugin's figures.
    pub steps: Vec<StepCycles>,
    /// Per step, in order: the firmware's own cost (counter ticks).
    pub firmware_ticks: Vec<u32>,
    /// What the firmware said at hello.
    pub info: Option<LinkInfo>,
}

impl CyclesLink {
    pub fn start(firmware: Option<&Path>, opts: &CyclesOptions) -> Result<Self> {
        let plugin = match &opts.plugin {
            Some(p) => p.clone(),
            None => build_plugin()?,
        };
        let out = std::env::temp_dir().join(format!(
            "acs-cycles-{}-{}.tsv",
            std::process::id(),
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos())
        ));
        let arg = format!("{},out={},ws={}", plugin.display(), out.display(), opts.wait_states);
        let qemu =
            QemuLink::start_with(firmware, sim_core::link::qemu::QemuClock::Lockstep, &["-plugin".to_string(), arg])?;
        // QEMU may open the link's socket before it installs the plugin (which creates the file).
        let deadline = Instant::now() + Duration::from_secs(10);
        let file = loop {
            match std::fs::File::open(&out) {
                Ok(f) => break f,
                Err(_) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(5)),
                Err(e) => return Err(e).with_context(|| format!("cycles plugin output {}", out.display())),
            }
        };
        let mut me = Self {
            qemu,
            out,
            reader: BufReader::new(file),
            header: Vec::new(),
            pending: String::new(),
            steps: Vec::new(),
            firmware_ticks: Vec::new(),
            info: None,
        };
        let h = me.next_line()?;
        me.header = h.trim_end().split('\t').map(str::to_string).collect();
        if me.header.first().map(String::as_str) != Some("window") {
            bail!("cycles plugin: unexpected header {h:?}");
        }
        Ok(me)
    }

    /// The next complete line of the plugin's output (waits up to 5 s for it).
    fn next_line(&mut self) -> Result<String> {
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            let n = self.reader.read_line(&mut self.pending)?;
            if self.pending.ends_with('\n') {
                return Ok(std::mem::take(&mut self.pending));
            }
            if n == 0 {
                if Instant::now() > deadline {
                    bail!("cycles plugin: no line for step {} in {}", self.steps.len(), self.out.display());
                }
                std::thread::sleep(Duration::from_millis(1));
            }
        }
    }
}

impl Drop for CyclesLink {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.out);
    }
}

impl FlightLink for CyclesLink {
    fn name(&self) -> String {
        "qemu+cycles".into()
    }
    fn hello(&mut self) -> Result<LinkInfo> {
        let i = self.qemu.hello()?;
        self.info = Some(i.clone());
        Ok(i)
    }
    fn request(&mut self, msg: &HostMsg) -> Result<FswMsg> {
        self.qemu.request(msg)
    }
    fn step(&mut self, frame: &SensorFrame) -> Result<StepReport> {
        let r = self.qemu.step(frame)?;
        let line = self.next_line()?;
        let c = parse_line(&self.header, &line)?;
        self.steps.push(c);
        self.firmware_ticks.push(r.step_cost_ticks);
        Ok(r)
    }
    fn frames_dropped_host(&self) -> u32 {
        self.qemu.frames_dropped_host()
    }
    fn anomalies(&self) -> sim_core::link::LinkAnomalies {
        self.qemu.anomalies()
    }
}

/// One step of [`measure_frames`].
#[derive(Clone, Debug)]
pub struct StepMeasure {
    pub report: StepReport,
    /// The firmware's own count: cost ticks × instructions per tick (±40 on QEMU).
    pub firmware_instructions: Option<f64>,
    pub cycles: StepCycles,
}

/// Boots the firmware under QEMU with the plugin, runs `setup` (parameter / mode-table
/// upload, …) after hello, then steps every frame of `frames`; returns per step the
/// report, the firmware's instruction count and the plugin's figures.
pub fn measure_frames(
    firmware: Option<&Path>,
    opts: &CyclesOptions,
    setup: &mut dyn FnMut(&mut dyn FlightLink) -> Result<()>,
    frames: &[SensorFrame],
) -> Result<Vec<StepMeasure>> {
    let mut link = CyclesLink::start(firmware, opts)?;
    let info = link.hello()?;
    setup(&mut link)?;
    let mut out = Vec::with_capacity(frames.len());
    for (k, f) in frames.iter().enumerate() {
        let report = link.step(f).with_context(|| format!("frame {k}"))?;
        let cycles = link.steps.last().cloned().context("no cycles line")?;
        let firmware_instructions = info.instructions_per_tick.map(|ipt| f64::from(report.step_cost_ticks) * ipt);
        out.push(StepMeasure { report, firmware_instructions, cycles });
    }
    Ok(out)
}

/// Runs a closed-loop scenario against the QEMU firmware with the plugin; returns the
/// run's summary, the plugin's figures per step and the firmware's instruction counts.
pub fn run_scenario(
    sc: &sim_core::scenario::Scenario,
    firmware: Option<&Path>,
    opts: &CyclesOptions,
) -> Result<(sim_core::recorder::summary::Summary, Vec<StepCycles>, Vec<f64>)> {
    if !sc.closed_loop() {
        bail!("{}: open-loop scenario, the flight code does not run", sc.name);
    }
    let mut link = CyclesLink::start(firmware, opts)?;
    let mut sink = sim_core::recorder::series::Discard;
    let summary = sim_core::runner::run_recorded(sc, &mut link, false, &mut sink)?;
    let ipt = link.info.as_ref().and_then(|i| i.instructions_per_tick).unwrap_or(f64::NAN);
    let fw = link.firmware_ticks.iter().map(|&t| f64::from(t) * ipt).collect();
    Ok((summary, std::mem::take(&mut link.steps), fw))
}

/// Worst and mean of a per-step figure.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WorstMean {
    pub worst: f64,
    pub mean: f64,
}

impl WorstMean {
    pub fn of(xs: impl Iterator<Item = f64>) -> Self {
        let (mut worst, mut sum, mut n) = (f64::NEG_INFINITY, 0.0, 0usize);
        for x in xs {
            worst = worst.max(x);
            sum += x;
            n += 1;
        }
        if n == 0 { Self::default() } else { Self { worst, mean: sum / n as f64 } }
    }
}

/// Statistics over the steps of a run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CycleStats {
    pub steps: usize,
    pub instructions: WorstMean,
    pub cycles_lower: WorstMean,
    pub cycles_upper: WorstMean,
    /// Shares of all executed step instructions.
    pub fp_share: f64,
    pub load_store_share: f64,
    pub branch_share: f64,
    pub taken_share: f64,
    pub soft_float_share: f64,
    pub soft_float_calls_per_step: f64,
    pub vdiv_vsqrt_per_step: f64,
}

impl CycleStats {
    pub fn of(steps: &[StepCycles]) -> Self {
        let tot = |f: &dyn Fn(&StepCycles) -> u64| steps.iter().map(f).sum::<u64>() as f64;
        let n_insn = tot(&|s| s.instructions).max(1.0);
        let n = steps.len().max(1) as f64;
        Self {
            steps: steps.len(),
            instructions: WorstMean::of(steps.iter().map(|s| s.instructions as f64)),
            cycles_lower: WorstMean::of(steps.iter().map(|s| s.cycles_lower as f64)),
            cycles_upper: WorstMean::of(steps.iter().map(|s| s.cycles_upper as f64)),
            fp_share: tot(&|s| s.fp()) / n_insn,
            load_store_share: tot(&|s| s.loads_stores()) / n_insn,
            branch_share: tot(&|s| s.branches()) / n_insn,
            taken_share: tot(&|s| s.get("taken")) / n_insn,
            soft_float_share: tot(&|s| s.soft_float()) / n_insn,
            soft_float_calls_per_step: tot(&|s| s.get("soft_float_calls")) / n,
            vdiv_vsqrt_per_step: tot(&|s| s.get("fp_div")) / n,
        }
    }
}

/// The per-step table of `sim-host cycles --per-step FILE`: tab-separated, one row per
/// step (firmware instructions `fw`, the plugin's counts, bounds and instruction mix).
pub fn per_step_table(steps: &[StepCycles], fw: &[f64]) -> String {
    let mut t = String::from("step\tfirmware_instructions\tinstructions\tcycles_lower\tcycles_upper");
    let keys: Vec<String> = steps.first().map(|s| s.mix.keys().cloned().collect()).unwrap_or_default();
    for k in &keys {
        t += &format!("\t{k}");
    }
    t.push('\n');
    for (k, (s, f)) in steps.iter().zip(fw).enumerate() {
        t += &format!("{k}\t{f}\t{}\t{}\t{}", s.instructions, s.cycles_lower, s.cycles_upper);
        for key in &keys {
            t += &format!("\t{}", s.get(key));
        }
        t.push('\n');
    }
    t
}

/// What `sim-host cycles` reports of a run: the statistics of its steps on the STM32F405.
pub struct CyclesReport {
    pub scenario: String,
    pub control_rate_hz: f64,
    pub wait_states: u32,
    pub stats: CycleStats,
    /// The firmware's own instruction counts per step.
    pub firmware_instructions: WorstMean,
}

impl CyclesReport {
    /// The report of a run (`run_scenario`'s summary, steps and firmware counts).
    pub fn of(
        summary: &sim_core::recorder::summary::Summary,
        steps: &[StepCycles],
        fw: &[f64],
        wait_states: u32,
    ) -> Self {
        Self {
            scenario: summary.scenario.clone(),
            control_rate_hz: summary.control_rate_hz,
            wait_states,
            stats: CycleStats::of(steps),
            firmware_instructions: WorstMean::of(fw.iter().copied()),
        }
    }

    fn period_us(&self) -> f64 {
        1e6 / self.control_rate_hz
    }

    /// The report as JSON (`--json`).
    pub fn json(&self) -> serde_json::Value {
        let (st, fw_stats, period_us) = (&self.stats, self.firmware_instructions, self.period_us());
        let us = |c: f64| c / STM32F405_HZ * 1e6;
        serde_json::json!({
            "scenario": self.scenario,
            "steps": st.steps,
            "control_rate_hz": self.control_rate_hz,
            "wait_states": self.wait_states,
            "cpu_hz": STM32F405_HZ,
            "firmware_instructions": {"worst": fw_stats.worst, "mean": fw_stats.mean},
            "instructions": {"worst": st.instructions.worst, "mean": st.instructions.mean},
            "cycles_lower": {"worst": st.cycles_lower.worst, "mean": st.cycles_lower.mean},
            "cycles_upper": {"worst": st.cycles_upper.worst, "mean": st.cycles_upper.mean},
            "us_worst": [us(st.cycles_lower.worst), us(st.cycles_upper.worst)],
            "period_fraction_worst": [us(st.cycles_lower.worst) / period_us, us(st.cycles_upper.worst) / period_us],
            "mix": {
                "fp": st.fp_share, "load_store": st.load_store_share, "branch": st.branch_share,
                "taken": st.taken_share, "soft_float": st.soft_float_share,
                "soft_float_calls_per_step": st.soft_float_calls_per_step,
                "vdiv_vsqrt_per_step": st.vdiv_vsqrt_per_step,
            },
        })
    }

    /// Writes the report as text; write errors are ignored (a closed pipe must not stop
    /// the command).
    pub fn write_text(&self, w: &mut dyn std::io::Write) {
        let (st, fw_stats, period_us) = (&self.stats, self.firmware_instructions, self.period_us());
        let us = |c: f64| c / STM32F405_HZ * 1e6;
        let mut say = |line: std::fmt::Arguments| {
            let _ = writeln!(w, "{line}");
        };
        say(format_args!(
            "{}: {} steps at {} Hz (period {:.0} us), STM32F405 at {:.0} MHz, {} wait states",
            self.scenario,
            st.steps,
            self.control_rate_hz,
            period_us,
            STM32F405_HZ / 1e6,
            self.wait_states
        ));
        say(format_args!("                         worst        mean"));
        say(format_args!("  instructions (fw)  {:>10.0}  {:>10.0}", fw_stats.worst, fw_stats.mean));
        say(format_args!("  instructions       {:>10.0}  {:>10.0}", st.instructions.worst, st.instructions.mean));
        say(format_args!("  cycles lower       {:>10.0}  {:>10.0}", st.cycles_lower.worst, st.cycles_lower.mean));
        say(format_args!("  cycles upper       {:>10.0}  {:>10.0}", st.cycles_upper.worst, st.cycles_upper.mean));
        for (name, w) in [
            ("worst", (st.cycles_lower.worst, st.cycles_upper.worst)),
            ("mean", (st.cycles_lower.mean, st.cycles_upper.mean)),
        ] {
            say(format_args!(
                "  {name:<5} {:.1}–{:.1} us = {:.3}–{:.3} % of the period",
                us(w.0),
                us(w.1),
                100.0 * us(w.0) / period_us,
                100.0 * us(w.1) / period_us
            ));
        }
        say(format_args!(
            "  mix: FP {:.1} %, loads/stores {:.1} %, branches {:.1} % (taken {:.1} %), soft-float {:.1} % ({:.1} calls/step), VDIV/VSQRT {:.1}/step",
            100.0 * st.fp_share,
            100.0 * st.load_store_share,
            100.0 * st.branch_share,
            100.0 * st.taken_share,
            100.0 * st.soft_float_share,
            st.soft_float_calls_per_step,
            st.vdiv_vsqrt_per_step
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_plugin_lines() {
        let h: Vec<String> =
            ["window", "instructions", "cycles_lower", "cycles_upper", "fp", "soft_float"].map(String::from).into();
        let s = parse_line(&h, "3\t100\t120\t250\t7\t2\n").unwrap();
        assert_eq!((s.instructions, s.cycles_lower, s.cycles_upper, s.fp(), s.soft_float()), (100, 120, 250, 7, 2));
        assert!(parse_line(&h, "3\t100\t120\n").is_err());
        assert!(parse_line(&h, "3\t100\t120\t2x0\t7\t2").is_err());
        let w = WorstMean::of([1.0, 3.0, 2.0].into_iter());
        assert_eq!((w.worst, w.mean), (3.0, 2.0));
    }
}
