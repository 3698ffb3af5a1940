//! The reproduction report (`sim-host report`): the committed `docs/results.md` is what a
//! fresh run of this tree generates, every outcome has a verdict, every difference names
//! the experiment or analysis behind it, and every figure the HTML shows exists.

use sim_host::report::experiment::repo_root;
use sim_host::report::outcomes::Verdict;
use sim_host::report::{Options, generate};

fn first_difference(a: &str, b: &str) -> String {
    let (la, lb): (Vec<_>, Vec<_>) = (a.lines().collect(), b.lines().collect());
    for i in 0..la.len().max(lb.len()) {
        let (x, y) = (la.get(i).copied().unwrap_or("<end>"), lb.get(i).copied().unwrap_or("<end>"));
        if x != y {
            return format!("line {}:\n  committed: {x}\n  fresh:     {y}", i + 1);
        }
    }
    "trailing bytes".into()
}

#[test]
fn committed_results_match_a_fresh_report() {
    let dir = tempfile::tempdir().expect("tempdir");
    let repo = repo_root();
    let r = generate(&Options {
        repo: repo.clone(),
        out: dir.path().to_path_buf(),
        papers: vec![],
        jobs: 2,
        progress: false,
    })
    .expect("report");

    // Every difference is investigated: explained, or open with the experiment that tried.
    for row in &r.rows {
        if row.verdict != Verdict::Reproduced {
            assert!(
                row.outcome.experiment.is_some() || row.outcome.explanation.is_some(),
                "{}/{} differs with nothing behind it",
                row.outcome.paper,
                row.outcome.id
            );
        }
        if row.verdict == Verdict::DiffersOpen {
            assert!(
                row.outcome.experiment.is_some(),
                "{}/{} open without an experiment",
                row.outcome.paper,
                row.outcome.id
            );
        }
    }
    // Every paper has outcomes, and every experiment is referenced by at least one outcome.
    for p in ["000", "001", "002", "003", "004"] {
        assert!(r.rows.iter().any(|x| x.outcome.paper == p), "paper {p} has no outcome");
    }
    for id in r.experiments.keys() {
        let used = r.rows.iter().any(|x| x.outcome.experiment.as_deref() == Some(id.as_str()))
            || r.rows.iter().any(|x| matches!(&x.outcome.ours, sim_host::report::outcomes::Source::Experiment { experiment, .. } if experiment == id));
        assert!(used, "experiment {id} is not referenced by any outcome");
    }

    // Every figure the page shows exists.
    let html = std::fs::read_to_string(dir.path().join("index.html")).expect("index.html");
    let mut n = 0;
    for part in html.split("src=\"").skip(1) {
        let file = part.split('"').next().unwrap_or_default();
        assert!(dir.path().join(file).is_file(), "index.html shows {file}, which was not written");
        n += 1;
    }
    assert!(n >= 40, "only {n} figures in the page");

    let committed = std::fs::read_to_string(repo.join("docs/results.md")).expect("docs/results.md");
    assert!(
        committed == r.markdown,
        "docs/results.md is stale against a fresh report (regenerate: scripts/report.sh): first difference at {}",
        first_difference(&committed, &r.markdown)
    );
}

#[test]
fn papers_filter_keeps_only_those_papers() {
    let dir = tempfile::tempdir().expect("tempdir");
    let r = generate(&Options {
        repo: repo_root(),
        out: dir.path().to_path_buf(),
        papers: vec!["002".into()],
        jobs: 2,
        progress: false,
    })
    .expect("report");
    assert!(!r.rows.is_empty());
    assert!(r.rows.iter().all(|x| x.outcome.paper == "002"));
    assert!(r.markdown.contains("## Paper 002"));
    assert!(!r.markdown.contains("## Paper 000") && !r.markdown.contains("## Beyond the papers"));
    // The title says the report holds one paper, not "the five source papers" (issue 38).
    assert!(r.markdown.contains("Reproduction report: paper 002 only"), "{}", &r.markdown[..200.min(r.markdown.len())]);
}
