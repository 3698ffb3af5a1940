//! `sim-host view`: a run replayed in 3D in the browser (docs/viewer.md). One
//! self-contained page, `RUN_DIR/replay.html`: the viewer bundle (three.js and the scene,
//! built from `tools/viewer/` by `scripts/setup.sh` into `target/viewer/`) with the run's
//! data embedded — decimated to a bounded size ([`decimate`]), laid out as typed arrays
//! ([`layout`]), with the scene's geometry computed here ([`geometry`]). The page never
//! touches the network.

pub mod decimate;
pub mod geometry;
pub mod layout;
mod scene;

use anyhow::{Context, Result, anyhow, bail};
use layout::{Channel, Dtype};
use sim_core::recorder::output::read_run;
use sim_core::recorder::series::TimeSeries;
use sim_core::scenario::Scenario;
use std::path::{Path, PathBuf};

/// The page of a run is at most this large, bytes (the 14-day run's bound, issue 43).
pub const MAX_PAGE_BYTES: usize = 20_000_000;
/// Rows kept at most whatever their width (the page plays and plots every kept row).
pub const MAX_ROWS: usize = 200_000;
/// Bytes kept for the JSON beside the channels (summary, scene description, names).
const JSON_OVERHEAD_BYTES: usize = 256 * 1024;
/// Environment variable naming the viewer bundle instead of the default path.
pub const BUNDLE_ENV: &str = "ACS_VIEWER_BUNDLE";
/// The bundle's file name under `target/viewer/`.
pub const BUNDLE_FILE: &str = "replay-template.html";
/// The page's file name in the run directory.
pub const PAGE_FILE: &str = "replay.html";

/// Columns whose changes are kept exactly (step levels: modes, codes, flags).
pub const STEP_CHANNELS: [&str; 7] =
    ["mode", "status", "eclipse", "thrusters_on", "target_visible", "pointing_segment", "geo_eclipse"];

/// Where the page goes and what it is built from.
#[derive(Clone, Debug, Default)]
pub struct ViewOptions {
    /// The page (default `RUN_DIR/replay.html`).
    pub out: Option<PathBuf>,
    /// The viewer bundle (default: [`bundle_path`]).
    pub bundle: Option<PathBuf>,
    /// The scenario when the run's time series has none in its metadata (a CSV run).
    pub scenario: Option<PathBuf>,
    /// Page size bound (default [`MAX_PAGE_BYTES`]; tests use smaller ones).
    pub max_page_bytes: Option<usize>,
}

/// What was written.
#[derive(Clone, Debug)]
pub struct ViewReport {
    pub page: PathBuf,
    pub page_bytes: usize,
    pub rows_recorded: usize,
    pub rows_kept: usize,
    pub selection: decimate::Selection,
    pub geometry: geometry::Source,
}

/// The bundle: `$ACS_VIEWER_BUNDLE`, else `target/viewer/replay-template.html` beside the
/// running executable's `target/` (`target/release/sim-host`), else under the source tree
/// this binary was built from.
pub fn bundle_path() -> PathBuf {
    if let Some(p) = std::env::var_os(BUNDLE_ENV) {
        return PathBuf::from(p);
    }
    let beside_exe = std::env::current_exe()
        .ok()
        .and_then(|e| e.parent()?.parent().map(|t| t.join("viewer").join(BUNDLE_FILE)))
        .filter(|p| p.exists());
    beside_exe.unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/viewer").join(BUNDLE_FILE))
}

fn read_bundle(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|e| {
        anyhow!(
            "the 3D viewer bundle {} is missing ({e}): build it with `scripts/setup.sh` (npm ci and the bundle in \
             tools/viewer) or `npm --prefix tools/viewer ci && npm --prefix tools/viewer run build`, or point \
             {BUNDLE_ENV} at a built replay-template.html",
            path.display()
        )
    })
}

/// The run's scenario: from the time series' metadata, else the file given.
fn scenario_of(
    metadata: &std::collections::BTreeMap<String, String>,
    given: Option<&Path>,
) -> Result<Option<Scenario>> {
    if let Some(p) = given {
        return Ok(Some(Scenario::load(p)?));
    }
    match metadata.get("scenario_toml") {
        Some(text) => Ok(Some(Scenario::from_toml(text).context("the scenario in the time series' metadata")?)),
        None => Ok(None),
    }
}

/// A recorded column as a page channel: time and the quaternion as f64 (round-off is
/// what the tests compare), the rest as f32.
fn recorded_channel(name: &str, values: &[f64], rows: &[usize]) -> Channel {
    let dtype = if name == "t_s" || name.starts_with("q_") { Dtype::F64 } else { Dtype::F32 };
    let unit = sim_core::recorder::columns::unit(name).unwrap_or("").to_string();
    Channel { name: name.into(), unit, dtype, values: rows.iter().map(|&i| values[i]).collect() }
}

/// The number of rows that fit the page bound with these channel types.
fn rows_that_fit(max_page_bytes: usize, template_bytes: usize, dtypes: impl IntoIterator<Item = Dtype>) -> usize {
    let per_row = layout::bytes_per_row(dtypes).max(1);
    let room = max_page_bytes.saturating_sub(template_bytes + JSON_OVERHEAD_BYTES);
    (room / per_row).min(MAX_ROWS)
}

/// A run as its page is built from it: the recorded rows, the time series' metadata, the
/// summary (`None`: a run that stopped with an error) and the scenario (`None`: no body,
/// actuators or orbit in the scene).
pub struct RunData {
    pub series: TimeSeries,
    pub metadata: std::collections::BTreeMap<String, String>,
    pub summary: Option<serde_json::Value>,
    pub scenario: Option<Scenario>,
}

/// Writes the replay page of the run in `run_dir` (`RUN_DIR/replay.html` unless `o.out`).
pub fn write_replay(run_dir: &Path, o: &ViewOptions) -> Result<ViewReport> {
    let run = read_run(run_dir)?;
    let summary = read_summary(run_dir)?;
    let scenario = scenario_of(&run.metadata, o.scenario.as_deref())?;
    let out = o.out.clone().unwrap_or_else(|| run_dir.join(PAGE_FILE));
    let data = RunData { series: run.series, metadata: run.metadata, summary, scenario };
    write_page(&data, run_dir, &out, o)
}

/// Writes the replay page of `run` to `out`; `source` names the run on the page (its
/// directory, or what the Python package says).
pub fn write_page(run: &RunData, source: &Path, out: &Path, o: &ViewOptions) -> Result<ViewReport> {
    let template = read_bundle(&o.bundle.clone().unwrap_or_else(bundle_path))?;
    let (ts, sc) = (&run.series, run.scenario.as_ref());
    let n = ts.len();
    if n == 0 {
        bail!("{}: the time series has no rows", source.display());
    }
    let max_page = o.max_page_bytes.unwrap_or(MAX_PAGE_BYTES);
    let mut dtypes: Vec<Dtype> = ts.names.iter().map(|c| recorded_channel(c, &[], &[]).dtype).collect();
    // The geometry channels at most (geometry::channels): 16 f64, 4 f32.
    dtypes.extend([Dtype::F64; 16].into_iter().chain([Dtype::F32; 4]));
    let max_rows = rows_that_fit(max_page, template.len(), dtypes);
    let selection = select_rows(ts, max_rows);
    let rows = &selection.rows;
    let (geometry, orbit) = geometry::orbit(sc, ts, rows)?;
    let target = geometry::target(sc, ts, rows, &orbit);
    let mut channels: Vec<Channel> =
        ts.names.iter().zip(&ts.cols).map(|(name, col)| recorded_channel(name, col, rows)).collect();
    channels.extend(geometry::channels(&orbit, target.as_deref()));
    let doc = scene::document(&scene::Inputs {
        run_dir: source,
        summary: run.summary.as_ref(),
        scenario: sc,
        metadata: &run.metadata,
        channels: &channels,
        rows_recorded: n,
        selection: &selection,
        geometry: &geometry,
    })?;
    let page = layout::fill_template(&template, &serde_json::to_string(&doc)?)?;
    if page.len() > max_page {
        bail!("the replay page would be {} bytes, over its bound of {max_page}", page.len());
    }
    sim_core::files::write_atomic(out, page.as_bytes())?;
    Ok(ViewReport {
        page: out.to_path_buf(),
        page_bytes: page.len(),
        rows_recorded: n,
        rows_kept: rows.len(),
        selection: selection.clone(),
        geometry,
    })
}

/// `summary.json` of the run (`None` when the directory has none: a run that stopped
/// with an error, or a bare time-series file).
fn read_summary(run_dir: &Path) -> Result<Option<serde_json::Value>> {
    let dir = if run_dir.is_dir() { run_dir.to_path_buf() } else { run_dir.parent().unwrap_or(run_dir).to_path_buf() };
    let path = dir.join("summary.json");
    if !path.exists() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    Ok(Some(serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?))
}

/// The decimation of the recorded rows: step channels kept exactly, extremes of the rest.
fn select_rows(ts: &TimeSeries, max_rows: usize) -> decimate::Selection {
    let steps: Vec<&[f64]> = STEP_CHANNELS.iter().filter_map(|c| ts.col(c)).collect();
    let signals: Vec<&[f64]> = ts
        .names
        .iter()
        .zip(&ts.cols)
        .filter(|(name, _)| name.as_str() != "t_s" && !STEP_CHANNELS.contains(&name.as_str()))
        .map(|(_, c)| c.as_slice())
        .collect();
    decimate::select(ts.len(), &steps, &signals, max_rows.max(4 + 4 * signals.len()))
}

/// A campaign run to open: the worst of the first requirement in `campaign.json`, or run N.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CampaignRun {
    Worst,
    Index(u32),
}

impl std::str::FromStr for CampaignRun {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "worst" => Ok(CampaignRun::Worst),
            n => n.parse().map(CampaignRun::Index).map_err(|_| format!("--run {s}: expected worst or a run number")),
        }
    }
}

/// The run index `which` names in a merged campaign directory.
pub fn campaign_run_index(dir: &Path, which: CampaignRun) -> Result<u32> {
    match which {
        CampaignRun::Index(i) => Ok(i),
        CampaignRun::Worst => {
            let path = dir.join("campaign.json");
            let text = std::fs::read_to_string(&path)
                .with_context(|| format!("reading {} (run `sim-host campaign merge` first)", path.display()))?;
            let v: serde_json::Value =
                serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
            let first = v["requirements"].as_array().and_then(|r| r.first());
            let run = first.and_then(|r| r["worst"].get(0)?.get("run")?.as_u64());
            let run = run.ok_or_else(|| {
                anyhow!("{}: no requirement with a worst run; name the run with --run N", path.display())
            })?;
            u32::try_from(run).context("run number")
        }
    }
}
