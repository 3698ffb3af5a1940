//! The text the timing commands print (`sim-host timing search`, `sim-host timing
//! replay`): a search's summary and each replayed entry, each step's cost beside its
//! budget. Write errors are ignored (a closed pipe, `sim-host … | head`, must not stop
//! the command, which still saves its corpus and reports its verdict).

use super::corpus::{BudgetFile, Replayed};
use super::search::{SearchResult, estimate_names, mode_name};
use super::{Cost, Target};
use anyhow::Result;
use std::io::Write;

/// `writeln!` that ignores write errors.
macro_rules! out {
    ($w:expr, $($t:tt)*) => {{
        let _ = writeln!($w, $($t)*);
    }};
}

/// A step's cost against the budget file: "ok: …", "OVER BUDGET: …" (and `failed` set),
/// or "no budget file".
pub fn budget_verdict(
    budget: Option<&BudgetFile>,
    scenario: &str,
    mode: &str,
    instructions: u64,
    dt_s: f64,
    failed: &mut bool,
) -> String {
    if let Some(b) = budget {
        let v = b.check(scenario, mode, instructions, dt_s);
        *failed |= !v.ok;
        format!("{}: {}", if v.ok { "ok" } else { "OVER BUDGET" }, v.message)
    } else {
        "no budget file".into()
    }
}

/// ", FDIR declared [...], costliest declaration step k: N instructions" (empty when FDIR
/// declared nothing).
pub fn fdir_text(c: &Cost) -> String {
    let mut s = String::new();
    let names = c.fdir.names();
    if !names.is_empty() {
        s += &format!(", FDIR declared [{names}]");
    }
    if let Some((k, n)) = c.declaration {
        s += &format!(", costliest declaration step {k}: {n} instructions");
    }
    s
}

/// Writes the summary of search `r` on target `t` (run with `seed`); returns whether a
/// reported step exceeds its budget.
pub fn write_search(
    w: &mut dyn Write,
    t: &Target,
    r: &SearchResult,
    seed: u64,
    budget: Option<&BudgetFile>,
) -> Result<bool> {
    let mut failed = false;
    out!(
        w,
        "{}: {} evaluations ({} refused) in {} generations, {:.1} s (seed {seed})",
        t.name,
        r.evaluations,
        r.rejected,
        r.generations,
        r.elapsed_s
    );
    if let Some(n) = r.nominal {
        out!(w, "  nominal input: {} instructions", n.instructions);
    }
    let c = &r.worst.cost;
    out!(
        w,
        "  worst: {} instructions (step {} of the sequence, mode {}, status {:#06x}, estimation [{}], \
         MEKF updates accepted/rejected/restarts {}/{}/{}, most history nodes replayed {}{}); {}",
        c.instructions,
        c.step,
        mode_name(c.mode),
        c.status,
        estimate_names(c.estimate_flags),
        c.mekf_accepted,
        c.mekf_rejected,
        c.mekf_resets,
        c.replayed_nodes,
        fdir_text(c),
        budget_verdict(budget, &t.name, mode_name(r.worst.cost.mode), r.worst.cost.instructions, t.dt_s, &mut failed)
    );
    out!(
        w,
        "  mean: {:.0} instructions over the evaluated inputs, {:.0} over the final population",
        r.mean_instructions,
        r.population_mean
    );
    if let Some(f) = r.worst_no_failures.as_ref().filter(|f| f.cost != r.worst.cost) {
        out!(w, "  worst without extra actuator failures: {} instructions", f.cost.instructions);
    }
    if !t.modes.is_empty() {
        for (code, f) in &r.per_mode {
            let name = mode_name(*code);
            out!(
                w,
                "  mode {name}: worst {} instructions (estimation [{}]); {}",
                f.cost.instructions,
                estimate_names(f.cost.estimate_flags),
                budget_verdict(budget, &t.name, name, f.cost.instructions, t.dt_s, &mut failed)
            );
        }
    }
    out!(w, "  worst input: {}", serde_json::to_string(&super::InputJson::from(&r.worst.input))?);
    Ok(failed)
}

/// Writes the replayed entries of the corpus of `scenario` (control period `dt_s`), each
/// against its budget; sets `failed` when one exceeds it.
pub fn write_replayed(
    w: &mut dyn Write,
    scenario: &str,
    replayed: &[Replayed],
    dt_s: f64,
    budget: Option<&BudgetFile>,
    failed: &mut bool,
) {
    for r in replayed {
        match r.measured {
            Some(m) => {
                let mode = mode_name(m.mode);
                out!(
                    w,
                    "  {:<16} {:>7} instructions (recorded {:>7}, {:+}), mode {mode}, estimation [{}], \
                     step {} status {:#06x}, MEKF updates accepted/rejected/restarts {}/{}/{}, history nodes replayed {}{}; {}",
                    r.label,
                    m.instructions,
                    r.recorded,
                    m.instructions as i64 - r.recorded as i64,
                    estimate_names(m.estimate_flags),
                    m.step,
                    m.status,
                    m.mekf_accepted,
                    m.mekf_rejected,
                    m.mekf_resets,
                    m.replayed_nodes,
                    fdir_text(&m),
                    budget_verdict(budget, scenario, mode, m.instructions, dt_s, failed)
                );
            }
            None => out!(w, "  {:<16} refused by the flight code (recorded {})", r.label, r.recorded),
        }
    }
}
