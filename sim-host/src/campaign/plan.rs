//! `sim-host campaign plan`: every run's scenario drawn from the campaign, written as a
//! plain scenario file (`runs/NNNNNN/scenario.toml`, every key explicit) that re-runs
//! alone with `sim-host run`, and `manifest.json` with every drawn value.

use super::draw;
use super::spec::{Campaign, CampaignFile, MAX_RUNS};
use super::{flatten, run_dir_name, write_atomic};
use anyhow::{Context, Result, anyhow, bail};
use serde::{Deserialize, Serialize};
use sim_core::scenario::{MarginsSpec, Scenario};
use std::collections::BTreeMap;
use std::path::Path;

/// Version of the manifest and result formats.
pub const FORMAT: u32 = 1;

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Manifest {
    pub format: u32,
    pub sim_host_version: String,
    /// The campaign file as read (`runs` as planned).
    pub campaign: CampaignFile,
    /// Name of the base scenario.
    pub base_scenario: String,
    /// The numeric keys of a run's summary (requirements and statistics address them).
    pub summary_keys: Vec<String>,
    pub runs: Vec<PlannedRun>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct PlannedRun {
    pub index: u32,
    /// The run's scenario, relative to the campaign directory.
    pub scenario: String,
    /// What was drawn, per dispersed key.
    pub draws: BTreeMap<String, serde_json::Value>,
}

impl Manifest {
    pub fn load(dir: &Path) -> Result<Self> {
        let p = dir.join("manifest.json");
        let text = std::fs::read_to_string(&p)
            .with_context(|| format!("reading {} (plan the campaign first: sim-host campaign plan)", p.display()))?;
        let m: Manifest = serde_json::from_str(&text).with_context(|| format!("parsing {}", p.display()))?;
        if m.format != FORMAT {
            bail!("{}: format {} (this sim-host reads {FORMAT})", p.display(), m.format);
        }
        Ok(m)
    }

    /// The campaign, checked again (requirements for run and merge; its `base_path` is
    /// not used after planning).
    pub fn campaign(&self) -> Result<Campaign> {
        Campaign::from_file(self.campaign.clone(), Path::new("."))
    }
}

/// The summary keys of the base scenario: flown for one control step in-process. With
/// `[margins]` in the base or drawn by a dispersion (`margins.…`), the `margins` keys too.
fn probe_summary_keys(base: &Scenario, campaign: &Campaign) -> Result<Vec<String>> {
    let mut sc = base.clone();
    sc.duration_s = 1.0 / sc.timing.control_rate_hz;
    let mut summary = sim_core::runner::fly(&sc).context("a one-step run of the base scenario")?;
    // `[margins]` adds its keys (not measured here: the probe only names them).
    let drawn = campaign.dispersions.iter().any(|d| d.key.to_string().starts_with("margins."));
    let request = match base.margin_request()? {
        None if drawn => Some(Scenario { margins: Some(MarginsSpec::default()), ..base.clone() }.margin_request()?),
        r => Some(r),
    };
    if let Some(req) = request.flatten() {
        let probe = Err(crate::margins::MarginError::Flight("key probe".into()));
        summary.margins = Some(crate::margins::summary::summarize(&req, &probe));
    }
    Ok(flatten(&serde_json::to_value(&summary)?).into_keys().collect())
}

/// Refuses a drawn scenario that is not a scenario file at all: a key the format does not
/// know (`spacecraft.nonexistent_key`), a value of the wrong type. Only the structure is
/// checked here (ranges and physics are the run's: an invalid draw is a run in error).
fn check_structure(body: &str, index: u32, campaign: &Campaign) -> Result<()> {
    if let Err(e) = toml::from_str::<Scenario>(body) {
        let keys: Vec<&str> = campaign.dispersions.iter().map(|d| d.key.as_str()).collect();
        bail!(
            "run {index}: the drawn scenario is not a valid scenario file ({}); dispersed keys: {}",
            e.message(),
            keys.join(", ")
        );
    }
    Ok(())
}

/// Plans the campaign into `out`; `runs` overrides the file's run count. Planning the same
/// campaign again into the same directory rewrites identical files and keeps the results;
/// a different campaign there is refused.
pub fn plan(campaign: &Campaign, out: &Path, runs: Option<u32>) -> Result<Manifest> {
    let mut file = campaign.file.clone();
    if let Some(n) = runs {
        if n == 0 || n > MAX_RUNS {
            bail!("--runs: 1..={MAX_RUNS} (got {n})");
        }
        file.runs = n;
    }
    let base = Scenario::load(&campaign.base_path).context("base scenario")?;
    let summary_keys = probe_summary_keys(&base, campaign)?;
    for r in &campaign.requirements {
        if !summary_keys.contains(&r.key) {
            bail!("requirement `{}`: `{}` is not a numeric key of the run summary ({})", r.name, r.key, {
                let near: Vec<&str> =
                    summary_keys.iter().map(String::as_str).filter(|k| !k.contains('[')).take(60).collect();
                near.join(", ")
            });
        }
    }
    // Every key explicit: defaults materialised, so any key can be addressed.
    let base_value = toml::Value::try_from(&base).context("materialising the base scenario")?;
    let mut runs_planned = Vec::with_capacity(file.runs as usize);
    let runs_dir = out.join("runs");
    std::fs::create_dir_all(&runs_dir).with_context(|| format!("creating {}", runs_dir.display()))?;
    if out.join("manifest.json").exists() {
        let old = Manifest::load(out)?;
        if old.campaign != file {
            bail!("{} holds the plan of another campaign (remove it or choose another --out)", out.display());
        }
    }
    for index in 0..file.runs {
        let mut v = base_value.clone();
        let mut draws = BTreeMap::new();
        for d in &campaign.dispersions {
            let mut rng = draw::stream(file.seed, index, d.key.as_str());
            let drawn =
                draw::apply(d, &mut v, &mut rng).with_context(|| format!("dispersion `{}` in run {index}", d.key))?;
            draws.insert(d.key.as_str().to_owned(), drawn);
        }
        let mut text = format!(
            "# Run {index} of campaign `{}` ({} runs, master seed {}), planned by sim-host campaign plan.\n\
             # Every key is explicit; the drawn values:\n",
            file.name, file.runs, file.seed
        );
        for (k, d) in &draws {
            text += &format!("#   {k}: {d}\n");
        }
        let body = toml::to_string(&v).map_err(|e| anyhow!("writing run {index}'s scenario: {e}"))?;
        check_structure(&body, index, campaign)?;
        text += &body;
        let rel = format!("runs/{}/scenario.toml", run_dir_name(index));
        let path = out.join(&rel);
        let run_dir = path.parent().unwrap_or(out);
        std::fs::create_dir_all(run_dir).with_context(|| format!("creating {}", run_dir.display()))?;
        write_atomic(&path, text.as_bytes())?;
        runs_planned.push(PlannedRun { index, scenario: rel, draws });
    }
    let manifest = Manifest {
        format: FORMAT,
        sim_host_version: env!("CARGO_PKG_VERSION").to_owned(),
        campaign: file,
        base_scenario: base.name.clone(),
        summary_keys,
        runs: runs_planned,
    };
    write_atomic(&out.join("manifest.json"), serde_json::to_string_pretty(&manifest)?.as_bytes())?;
    Ok(manifest)
}
