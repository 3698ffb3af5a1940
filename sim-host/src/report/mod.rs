//! `sim-host report`: every shipped scenario flown, each published outcome beside ours
//! with a verdict, the paper's figures redrawn, and the experiments that explain the gaps.
//!
//! Inputs: `scenarios/paper*/*.toml`, `scenarios/modes/*.toml` and
//! `scenarios/estimation/*.toml` (flown in-process, in parallel), `docs/outcomes.toml` (the published outcomes; the papers in our words: `docs/papers.md`), and the
//! experiments of [`experiments::ALL`]. Outputs in the chosen directory: `report.md`
//! (committed as `docs/results.md`; a test regenerates it and fails when it is stale),
//! `index.html` and `figures/`. No wall-clock figure enters the text, so the same tree
//! gives the same bytes.

pub mod determination;
pub mod experiment;
pub mod experiments;
pub mod margins;
pub mod metrics;
pub mod outcomes;
pub mod render;

use anyhow::{Context as _, Result, bail};
use experiment::{Block, Context, Experiment, Explains, par_map, sig};
use outcomes::{Row, Values, Verdict};
use render::Section;
use sim_core::recorder::output;
use sim_core::recorder::plots::{self, Figure};
use sim_core::runner::Summary;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What to report and where.
#[derive(Clone, Debug)]
pub struct Options {
    pub repo: PathBuf,
    pub out: PathBuf,
    /// Papers to include ("000" … "004", "modes", "estimation"); all when empty.
    pub papers: Vec<String>,
    pub jobs: usize,
    pub progress: bool,
}

/// What the report found (also written to disk).
pub struct Report {
    pub rows: Vec<Row>,
    pub experiments: BTreeMap<String, Experiment>,
    pub markdown: String,
}

/// Section title of each paper (SEEDS.md's subjects, shortened).
const PAPERS: &[(&str, &str)] = &[
    ("000", "Paper 000 — quaternion feedback and SR steering on a four-CMG air-bearing rig"),
    ("001", "Paper 001 — adaptive DMCS with the accurate reaction-wheel model"),
    ("002", "Paper 002 — LQR/LQG stabilisation and GSR manoeuvres with CMGs"),
    ("003", "Paper 003 — magnetic PD and LQR on an air-bearing rig and in orbit"),
    ("004", "Paper 004 — thruster allocation by linear programming, PWPF and failures"),
    ("modes", "Beyond the papers — the mode manager (cubesat mission)"),
    ("estimation", "Beyond the papers — attitude determination on board (MEKF, sun-safe)"),
];

/// The figures redrawn per paper (file names of `output::figures`), as the paper plots them.
fn figure_set(paper: &str) -> &'static [&'static str] {
    match paper {
        "000" | "002" => &["attitude.png", "gimbals.png", "torque.png", "singularity.png"],
        "001" => &["attitude.png", "wheels.png", "adaptive.png", "torque.png"],
        "003" => &["attitude.png", "magnetorquers.png", "environment.png"],
        "004" => &["attitude.png", "thrusters.png", "torque.png"],
        "estimation" => &["estimation.png", "modes.png", "attitude.png"],
        _ => &["modes.png", "estimation.png", "attitude.png", "wheels.png", "magnetorquers.png"],
    }
}

/// One shipped scenario: `paper000/test3` → paper "000", name "test3".
#[derive(Clone, Debug)]
struct Scn {
    paper: String,
    rel: String,
    path: PathBuf,
}

fn discover(repo: &Path, papers: &[String]) -> Result<Vec<Scn>> {
    let mut out = Vec::new();
    let dir = repo.join("scenarios");
    let mut dirs: Vec<_> = std::fs::read_dir(&dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    dirs.sort();
    for d in dirs {
        let Some(name) = d.file_name().and_then(|n| n.to_str()).map(str::to_owned) else { continue };
        let paper = match name.strip_prefix("paper") {
            Some(p) => p.to_owned(),
            None if name == "modes" || name == "estimation" => name.clone(),
            None => continue,
        };
        if !papers.is_empty() && !papers.contains(&paper) {
            continue;
        }
        let mut files: Vec<_> = std::fs::read_dir(&d)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        files.sort();
        for f in files {
            let stem = f.file_stem().and_then(|s| s.to_str()).unwrap_or_default().to_owned();
            out.push(Scn { paper: paper.clone(), rel: format!("{name}/{stem}"), path: f });
        }
    }
    Ok(out)
}

/// A flown scenario, digested: its numbers and the figures written for it.
struct Flown {
    scn: Scn,
    summary: Summary,
    values: BTreeMap<String, f64>,
    figures: Vec<(String, String)>,
}

fn fly_one(s: &Scn, fig_root: &Path) -> Result<Flown> {
    let sc = sim_core::scenario::Scenario::load(&s.path)?;
    let r = experiment::fly_recorded(&sc).with_context(|| format!("flying {}", s.rel))?;
    let dir_name = s.rel.replace('/', "-");
    let dir = fig_root.join(&dir_name);
    std::fs::create_dir_all(&dir)?;
    let wanted = figure_set(&s.paper);
    let thresholds = sc.modes.as_ref().map(|m| m.plot_thresholds()).unwrap_or_default();
    let figs: Vec<Figure> =
        output::figures_with(&thresholds).into_iter().filter(|f| wanted.contains(&f.file_name.as_str())).collect();
    let titles: BTreeMap<String, String> = figs.iter().map(|f| (f.file_name.clone(), f.title.clone())).collect();
    let written =
        plots::render(&dir, &output::with_plot_columns(&r.series), &figs, &plots::FigureContext::new(&sc.name))
            .with_context(|| format!("plotting {}", s.rel))?;
    let mut figures = Vec::new();
    for w in wanted {
        if written.iter().any(|p| p.file_name().is_some_and(|n| n == *w)) {
            figures.push((format!("{dir_name}/{w}"), titles.get(*w).cloned().unwrap_or_default()));
        }
    }
    let values = metrics::of_run(&r);
    Ok(Flown { scn: s.clone(), summary: r.summary, values, figures })
}

fn bar(total: u64, progress: bool) -> indicatif::ProgressBar {
    if !progress {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::new(total);
    b.set_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    b
}

/// Flies everything, runs the experiments, writes `report.md`, `index.html`, `figures/`.
pub fn generate(o: &Options) -> Result<Report> {
    let scns = discover(&o.repo, &o.papers)?;
    let exps: Vec<_> =
        experiments::ALL.iter().filter(|(_, p, _)| o.papers.is_empty() || o.papers.iter().any(|x| x == p)).collect();
    let fig_root = o.out.join("figures");
    std::fs::create_dir_all(&fig_root).with_context(|| format!("creating {}", fig_root.display()))?;
    let pb = bar((scns.len() + exps.len()) as u64, o.progress);
    pb.set_message("flying the shipped scenarios");
    let flown: Vec<Flown> = par_map(o.jobs, &scns, |s| {
        let r = fly_one(s, &fig_root);
        pb.inc(1);
        r
    })
    .into_iter()
    .collect::<Result<_>>()?;
    let mut experiments = BTreeMap::new();
    for (id, _, run) in exps {
        pb.set_message(format!("experiment {id}"));
        let fig_dir = fig_root.join(id);
        std::fs::create_dir_all(&fig_dir)?;
        let ctx = Context { repo: o.repo.clone(), fig_dir, jobs: o.jobs };
        let mut e = run(&ctx).with_context(|| format!("experiment {id}"))?;
        // Figure paths relative to figures/.
        for b in &mut e.blocks {
            if let Block::Figure { file, .. } = b {
                *file = format!("{id}/{file}");
            }
        }
        experiments.insert((*id).to_owned(), e);
        pb.inc(1);
    }
    pb.finish_and_clear();

    let runs: BTreeMap<String, BTreeMap<String, f64>> =
        flown.iter().map(|f| (f.scn.rel.clone(), f.values.clone())).collect();
    let all = outcomes::load(&o.repo.join("docs/outcomes.toml"))?;
    let selected: Vec<_> = all.into_iter().filter(|x| o.papers.is_empty() || o.papers.contains(&x.paper)).collect();
    let rows = outcomes::evaluate(&selected, &Values { runs: &runs, experiments: &experiments })?;
    if let Some(r) = rows.iter().find(|r| r.verdict == Verdict::DiffersOpen && r.outcome.experiment.is_none()) {
        bail!("outcome {}/{} differs and no experiment investigates it", r.outcome.paper, r.outcome.id);
    }
    let checks = (o.papers.is_empty() || o.papers.iter().any(|p| p == "estimation"))
        .then(|| Ok::<_, anyhow::Error>((determination::checks(&o.repo)?, determination::cost_table(&o.repo)?)))
        .transpose()
        .context("determination checks")?;
    pb.finish_and_clear();
    let targets: Vec<margins::Target> = scns
        .iter()
        .filter(|s| s.paper.len() == 3 && s.paper.bytes().all(|b| b.is_ascii_digit()))
        .map(|s| margins::Target { rel: s.rel.clone(), path: s.path.clone() })
        .collect();
    let margin_table = (!targets.is_empty()).then(|| margins::table(&targets, o.jobs));
    let mut doc = document(&flown, &rows, &experiments, &o.papers, checks);
    if let Some(t) = margin_table {
        doc.insert(1, margins_section(t));
    }
    let markdown = render::markdown(&doc);
    sim_core::files::write_atomic(&o.out.join("report.md"), markdown.as_bytes())?;
    sim_core::files::write_atomic(&o.out.join("index.html"), render::html(&doc, "Reproduction report").as_bytes())?;
    Ok(Report { rows, experiments, markdown })
}

fn opt(x: Option<f64>, digits: usize) -> String {
    x.map_or_else(|| "—".into(), |v| sig(v, digits))
}

/// The actuator figures of a run, whichever family it flies.
fn actuator_cell(s: &Summary) -> String {
    let mut parts = Vec::new();
    if let Some(v) = s.max_gimbal_rate_rad_s {
        parts.push(format!("peak gimbal rate {} rad/s", sig(v, 3)));
    }
    if let Some(v) = s.min_singularity_measure {
        parts.push(format!("min m {}", sig(v, 3)));
    }
    if let Some(v) = s.max_wheel_speed_rpm {
        parts.push(format!("wheels ≤ {} rpm", sig(v, 3)));
    }
    if let Some(v) = s.max_wheel_power_w {
        parts.push(format!("≤ {} W", sig(v, 3)));
    }
    if let Some(v) = s.propellant_kg {
        parts.push(format!("propellant {} kg", sig(v, 3)));
    }
    if let Some(v) = s.max_pulses {
        parts.push(format!("max pulses {v}"));
    }
    if !s.mode_transitions.is_empty() {
        parts.push(format!("{} mode transitions", s.mode_transitions.len()));
    }
    parts.join(", ")
}

/// The estimation figures of the runs that flew the MEKF (`None` when none did).
fn estimation_table(runs: &[&Flown]) -> Option<Block> {
    let rows: Vec<Vec<String>> = runs
        .iter()
        .filter_map(|f| {
            let s = &f.summary;
            let rms = s.estimation_error_rms_deg?;
            Some(vec![
                format!("`scenarios/{}.toml`", f.scn.rel),
                sig(rms, 3),
                opt(s.estimation_error_max_deg, 3),
                opt(s.bias_error_final_deg_h, 3),
                opt(s.nees_mean, 3),
                s.innovations_rejected.map_or_else(|| "—".into(), |n| n.to_string()),
                s.estimator_resets.map_or_else(|| "—".into(), |n| n.to_string()),
                s.final_mode.clone().unwrap_or_else(|| "—".into()),
            ])
        })
        .collect();
    (!rows.is_empty()).then(|| Block::Table {
        header: [
            "scenario",
            "estimation error RMS (°)",
            "max (°)",
            "bias error at end (°/h)",
            "mean NEES",
            "innovations rejected",
            "restarts",
            "final mode",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    })
}

/// A short figure caption: the file's name ("attitude"), the title kept for the HTML alt text.
fn title_word(file: &str, _title: &str) -> String {
    file.rsplit('/').next().unwrap_or(file).trim_end_matches(".png").to_owned()
}

/// The report's opening section: what it is, the verdict counts, one row per paper.
fn intro_section(rows: &[Row], papers: &[String]) -> Section {
    let count = |v: Verdict| rows.iter().filter(|r| r.verdict == v).count();
    let mut intro = vec![
        Block::Para(
            "Generated by `sim-host report --out DIR` (`scripts/report.sh` regenerates this file); do not edit by hand: \
             `sim-host/tests/report.rs` fails when this file differs from a fresh run. Every shipped scenario under \
             `scenarios/paper*/`, `scenarios/modes/` and `scenarios/estimation/` is flown in-process; each published outcome (the paper's \
             claim, listed in `docs/outcomes.toml`; each paper in our words in `docs/papers.md`) stands beside ours with the \
             check that decides *reproduced*; each difference names the experiment (below each paper) or the \
             analysis that explains it. Figures are written beside the generated `report.md` and `index.html` \
             (links here point into that directory). No wall-clock figure appears here: timing is in `docs/timing.md`; \
             verification that is not a reproduction is in `docs/verification.md`."
                .into(),
        ),
        Block::Para(format!(
            "**Verdicts: {} outcomes — {} reproduced, {} differ and are explained, {} differ and stay open** \
             (each open one names the experiment that ruled out its candidates).",
            rows.len(),
            count(Verdict::Reproduced),
            count(Verdict::DiffersExplained),
            count(Verdict::DiffersOpen)
        )),
    ];
    let mut summary_rows = Vec::new();
    for (p, title) in PAPERS {
        let rs: Vec<_> = rows.iter().filter(|r| r.outcome.paper == *p).collect();
        if rs.is_empty() {
            continue;
        }
        let c = |v: Verdict| rs.iter().filter(|r| r.verdict == v).count().to_string();
        summary_rows.push(vec![
            (*title).to_owned(),
            rs.len().to_string(),
            c(Verdict::Reproduced),
            c(Verdict::DiffersExplained),
            c(Verdict::DiffersOpen),
        ]);
    }
    intro.push(Block::Table {
        header: ["paper", "outcomes", "reproduced", "differs, explained", "differs, open"].map(String::from).to_vec(),
        rows: summary_rows,
    });
    // `--papers` narrows the report: its title says which it holds (issue 38).
    let title = if papers.is_empty() {
        "Reproduction report: the five source papers".to_owned()
    } else {
        format!(
            "Reproduction report: {} only",
            papers
                .iter()
                .map(|p| if p.bytes().all(|b| b.is_ascii_digit()) { format!("paper {p}") } else { p.clone() })
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    Section { level: 1, title, blocks: intro }
}

/// A paper's published outcomes beside ours.
fn outcomes_section(rs: &[&Row]) -> Section {
    let table = Block::Table {
        header: ["outcome", "paper", "ours", "reproduced if", "verdict", "basis"].map(String::from).to_vec(),
        rows: rs
            .iter()
            .map(|r| {
                let u = &r.outcome.unit;
                let ours = outcomes::with_unit(r.ours, r.outcome.digits, u);
                vec![
                    r.outcome.claim.clone(),
                    r.outcome.paper_value.clone(),
                    ours,
                    r.outcome.check.text(u),
                    r.verdict.text().to_owned(),
                    r.basis.clone(),
                ]
            })
            .collect(),
    };
    Section { level: 3, title: "Published outcomes".into(), blocks: vec![table] }
}

/// A paper's flown scenarios: the summary table, the estimation table (if any), the figures.
fn runs_section(runs: &[&Flown]) -> Section {
    let table = Block::Table {
        header: [
            "scenario",
            "final error (°)",
            "settle < 1° (s)",
            "RMS after settle (°)",
            "mean error, whole run (°)",
            "actuators",
        ]
        .map(String::from)
        .to_vec(),
        rows: runs
            .iter()
            .map(|f| {
                let s = &f.summary;
                vec![
                    format!("`scenarios/{}.toml`", f.scn.rel),
                    sig(s.final_error_deg, 3),
                    opt(s.settle_time_s, 4),
                    opt(s.rms_error_after_settle_deg, 3),
                    sig(s.mean_error_whole_run_deg, 3),
                    actuator_cell(s),
                ]
            })
            .collect(),
    };
    let mut blocks = vec![table];
    if let Some(t) = estimation_table(runs) {
        blocks.push(Block::Para(
            "On-board attitude determination against the simulator's truth, over the steps the MEKF ran \
             (`summary.json`; `sim_host::estimation::stats`): attitude error |δθ| (RMS, max), gyro-bias error \
             at the end, mean NEES with the filter's own 6×6 covariance (χ²₆: 6 for a consistent filter; \
             the tumble and coarse phases raise it), innovations the χ² gates rejected, filter restarts. \
             Closed-loop proofs: `sim-host/core/tests/estimation_closed_loop.rs`, `tests/tests/mode_manager.rs`; \
             the filter against an independent f64 MEKF and the Monte Carlo consistency runs: \
             `docs/verification.md`."
                .into(),
        ));
        blocks.push(t);
    }
    for f in runs {
        blocks.extend(f.figures.iter().map(|(file, title)| Block::Figure {
            file: file.clone(),
            caption: format!("`{}` {}", f.scn.rel, title_word(file, title)),
        }));
    }
    Section { level: 3, title: "Runs and figures".into(), blocks }
}

/// The estimation paper's determination checks and the flight-computer cost.
fn determination_sections(table: Block, cost: Block) -> [Section; 2] {
    let intro = Block::Para(
        "Flown for this report (`sim_host::report::determination`; the same criteria are asserted by \
         `sim-host/core/tests/estimation_closed_loop.rs`): hold on the MEKF against the same hold on an ideal \
         attitude (no filter, a noise-free star tracker, no gyro model), and the gyro-only error growth \
         through a star-tracker outage against the Farrenkopf bound (σv, σu the gyro's angle and rate \
         random walk, σb = √tr P_bb of the filter at the outage start)."
            .into(),
    );
    let checks = Section { level: 3, title: "Determination checks".into(), blocks: vec![intro, table] };
    let intro = Block::Para(
        "The whole flight step (estimation stage with the MEKF and the degree-12 field model, navigation, \
         mode logic, law, allocation) on the Cortex-M4F: the costliest input the worst-case search found, \
         counted in instructions on the QEMU firmware (`timing/corpus/`, `sim-host timing search`; method, \
         budgets and the cycle model in `docs/timing.md`). The MEKF step alone (propagation + tracker + Sun \
         + field) is measured separately by `tests/tests/estimation_target.rs` (`docs/verification.md`)."
            .into(),
    );
    [checks, Section { level: 3, title: "Cost on the flight computer".into(), blocks: vec![intro, cost] }]
}

/// An experiment: its question, blocks and conclusion.
fn experiment_section(e: &Experiment) -> Section {
    let mut blocks = vec![Block::Para(format!("**Question.** {}", e.question))];
    blocks.extend(e.blocks.iter().cloned());
    let verdict = match e.explains {
        Explains::Yes => "explains the gap",
        Explains::No => "does not explain the gap",
    };
    blocks.push(Block::Para(format!("**Conclusion ({verdict}).** {}", e.conclusion)));
    Section { level: 3, title: format!("Experiment `{}`: {}", e.id, e.title), blocks }
}

/// The stability margins of every paper scenario (`report::margins`).
fn margins_section(table: Block) -> Section {
    let intro = Block::Para(
        "Measured through the flight step by `sim-host margins SCENARIO` (docs/margins.md): the scenario flown \
         to its end (the settled hold), the loop broken at the actuator command, sine steps up to the control \
         Nyquist frequency. Each figure is the worst of the three axes (loop at a time); the multiloop disk \
         margin perturbs all axes at once (balanced, skew 0; α = 0.5 is ±4.4 dB and ±28°). A gain margin \
         shown ∞ has no phase crossing below Nyquist. Where a loop is not measured, the reason is given: an \
         operating point that is not a steady hold gets no number. Magnetorquer loops are measured at the \
         orbit instant with the field frozen, on the two axes perpendicular to it; paper 003's rods sit in \
         their dead band or its holds are not settled, and in orbit its frozen-instant loop has a slow or \
         unstable mode about the field (docs/margins.md, \"Magnetorquer loops\"). Dispersed over inertia \
         and delay: `campaigns/paper000-test3-margins.toml`."
            .into(),
    );
    Section { level: 2, title: "Stability margins of the paper scenarios".into(), blocks: vec![intro, table] }
}

fn document(
    flown: &[Flown],
    rows: &[Row],
    exps: &BTreeMap<String, Experiment>,
    papers: &[String],
    mut checks: Option<(Block, Block)>,
) -> Vec<Section> {
    let mut doc = vec![intro_section(rows, papers)];
    for (p, title) in PAPERS {
        if !papers.is_empty() && !papers.iter().any(|x| x == p) {
            continue;
        }
        let runs: Vec<&Flown> = flown.iter().filter(|f| f.scn.paper == *p).collect();
        let rs: Vec<&Row> = rows.iter().filter(|r| r.outcome.paper == *p).collect();
        let es: Vec<&Experiment> = exps.values().filter(|e| e.paper == *p).collect();
        if runs.is_empty() && rs.is_empty() && es.is_empty() {
            continue;
        }
        doc.push(Section { level: 2, title: (*title).to_owned(), blocks: vec![] });
        if !rs.is_empty() {
            doc.push(outcomes_section(&rs));
        }
        if !runs.is_empty() {
            doc.push(runs_section(&runs));
        }
        if *p == "estimation"
            && let Some((table, cost)) = checks.take()
        {
            doc.extend(determination_sections(table, cost));
        }
        doc.extend(es.into_iter().map(experiment_section));
    }
    doc
}
