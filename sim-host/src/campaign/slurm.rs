//! `sim-host campaign slurm`: a Slurm job array whose task index is the shard
//! (`--shard $SLURM_ARRAY_TASK_ID/S`) and a merge job that waits for the whole array
//! (`--dependency=afterany:`), so the merge runs, and reports missing runs, even when a
//! shard failed. No distribution layer of our own: the scheduler hands out the index.

use super::plan::Manifest;
use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};

pub struct SlurmOptions {
    pub shards: u32,
    pub partition: Option<String>,
    /// Wall-time limit per array task (`--time`, e.g. `00:30:00`).
    pub time: Option<String>,
    /// Threads per shard (`--cpus-per-task`; the run uses `$SLURM_CPUS_PER_TASK`).
    pub cpus_per_task: u32,
    /// The `sim-host` the jobs run (default: this executable); `$SIM_HOST` overrides it
    /// at submission.
    pub sim_host: PathBuf,
}

/// Single-quotes `s` for a POSIX shell.
fn sh_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

fn sbatch_value(s: &str, what: &str) -> Result<()> {
    if s.is_empty() || s.chars().any(|c| c.is_whitespace() || c == '\'' || c == '"') {
        bail!("{what} {s:?}: no spaces or quotes");
    }
    Ok(())
}

/// The optional `#SBATCH` lines (partition, time limit), checked.
fn sbatch_head(o: &SlurmOptions) -> Result<String> {
    let mut head = String::new();
    if let Some(p) = &o.partition {
        sbatch_value(p, "--partition")?;
        head += &format!("#SBATCH --partition={p}\n");
    }
    if let Some(t) = &o.time {
        sbatch_value(t, "--time")?;
        head += &format!("#SBATCH --time={t}\n");
    }
    Ok(head)
}

/// What the three scripts are made of: job name, campaign directory, `sim-host` path,
/// the optional `#SBATCH` lines.
struct ScriptParts<'a> {
    name: &'a str,
    dir: &'a str,
    sim_host: &'a str,
    head: &'a str,
}

/// The texts of `array.sbatch`, `merge.sbatch` and `submit.sh`.
fn script_texts(p: &ScriptParts, o: &SlurmOptions) -> [(&'static str, String); 3] {
    let (name, d, sim, head) = (p.name, p.dir, p.sim_host, p.head);
    let s = o.shards;
    let array = format!(
        "#!/bin/bash\n\
         # Runs of campaign `{name}`: one array task per shard (task index = shard index).\n\
         #SBATCH --job-name={name}-runs\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --cpus-per-task={cpus}\n\
         #SBATCH --output={d}/slurm/logs/runs-%A_%a.out\n\
         {head}\
         set -euo pipefail\n\
         SIM_HOST=\"${{SIM_HOST:-{sim_q}}}\"\n\
         exec \"$SIM_HOST\" campaign run {dq} --shard \"${{SLURM_ARRAY_TASK_ID}}/{s}\" --jobs \"${{SLURM_CPUS_PER_TASK:-1}}\" --quiet\n",
        last = s - 1,
        cpus = o.cpus_per_task,
        sim_q = sim,
        dq = sh_quote(d),
    );
    let merge = format!(
        "#!/bin/bash\n\
         # Merge of campaign `{name}`: submitted with --dependency=afterany:<array job>.\n\
         #SBATCH --job-name={name}-merge\n\
         #SBATCH --cpus-per-task=1\n\
         #SBATCH --output={d}/slurm/logs/merge-%j.out\n\
         {head}\
         set -euo pipefail\n\
         SIM_HOST=\"${{SIM_HOST:-{sim}}}\"\n\
         exec \"$SIM_HOST\" campaign merge {dq}\n",
        dq = sh_quote(d),
    );
    let submit = format!(
        "#!/bin/bash\n\
         # Submits the runs of campaign `{name}` as a {s}-task job array, then its merge.\n\
         set -euo pipefail\n\
         cd {dq}/slurm\n\
         runs=$(sbatch --parsable array.sbatch)\n\
         runs=${{runs%%;*}}\n\
         merge=$(sbatch --parsable --dependency=afterany:\"$runs\" merge.sbatch)\n\
         merge=${{merge%%;*}}\n\
         echo \"runs: job array $runs ({s} shards); merge: job $merge (after the whole array)\"\n\
         echo \"$runs $merge\" > jobs\n",
        dq = sh_quote(d),
    );
    [("array.sbatch", array), ("merge.sbatch", merge), ("submit.sh", submit)]
}

/// Writes `slurm/array.sbatch`, `slurm/merge.sbatch` and `slurm/submit.sh` into the
/// campaign directory; returns their paths.
pub fn write_scripts(dir: &Path, o: &SlurmOptions) -> Result<Vec<PathBuf>> {
    let manifest = Manifest::load(dir)?;
    if o.shards == 0 || o.shards as usize > manifest.runs.len() {
        bail!("--shards: 1..={} (the campaign's runs), got {}", manifest.runs.len(), o.shards);
    }
    if o.cpus_per_task == 0 {
        bail!("--cpus-per-task must be >= 1");
    }
    let dir = std::fs::canonicalize(dir).with_context(|| format!("resolving {}", dir.display()))?;
    let d = dir.to_str().context("the campaign directory's path is not UTF-8")?;
    let sim = o.sim_host.to_str().context("the sim-host path is not UTF-8")?;
    let name: String = manifest
        .campaign
        .name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '-' })
        .collect();
    let head = sbatch_head(o)?;
    let slurm = dir.join("slurm");
    let logs = slurm.join("logs");
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    let texts = script_texts(&ScriptParts { name: &name, dir: d, sim_host: sim, head: &head }, o);
    let mut files = Vec::new();
    for (file, text) in texts {
        let p = slurm.join(file);
        sim_core::files::write_atomic(&p, text.as_bytes())?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755))
                .with_context(|| format!("making {} executable", p.display()))?;
        }
        files.push(p);
    }
    Ok(files)
}
