//! Issue 36: the README's `cargo build --release -p sim-host`, the Python package's build
//! (maturin builds `acs-python` alone) and the test suite's `cargo test --workspace` must
//! compile every shared dependency with the same features, or each builds the whole tree
//! again under new hashes (16 min on a loaded 2-core machine, measured).
//!
//! Cargo enables a dependency's features from the packages a command selects, so the three
//! agree only while `sim-host/Cargo.toml` enables what the others add (its "feature
//! alignment" lines). The truth here is Cargo's own resolver (`cargo tree -e features`),
//! not a list kept by hand: for every package the builds share, the feature sets must be
//! equal.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

/// `package version` → the feature sets it is built with, as `cargo tree` resolves them for
/// `selection` (the packages a command selects and the dependency kinds it builds). A
/// package can be built more than once (e.g. `serde` for the target and, with fewer
/// features, for a build script): each instance is one set, so their order in the tree
/// does not matter.
fn resolved_features(selection: &[&str]) -> BTreeMap<String, BTreeSet<String>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = Command::new(cargo)
        .current_dir(&root)
        .args(["tree", "--locked", "--offline", "--prefix", "none", "--no-dedupe", "-f", "{p}\t{f}"])
        .args(selection)
        .output()
        .expect("cargo tree runs");
    assert!(out.status.success(), "cargo tree {selection:?}: {}", String::from_utf8_lossy(&out.stderr));
    let mut map = BTreeMap::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let (package, features) = line.split_once('\t').unwrap_or((line, ""));
        // `name vX.Y.Z (path)` → `name vX.Y.Z`
        let key: String = package.split_whitespace().take(2).collect::<Vec<_>>().join(" ");
        if !key.is_empty() {
            map.entry(key).or_insert_with(BTreeSet::new).insert(features.trim().to_string());
        }
    }
    map
}

/// Packages both maps hold with different features.
fn differences(a: &BTreeMap<String, BTreeSet<String>>, b: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
    a.iter().filter_map(|(k, fa)| b.get(k).filter(|fb| *fb != fa).map(|fb| format!("{k}: {fa:?} vs {fb:?}"))).collect()
}

#[test]
fn the_cli_the_python_package_and_the_workspace_build_dependencies_with_the_same_features() {
    let cli = resolved_features(&["-e", "normal,build", "-p", "sim-host"]);
    let python = resolved_features(&["-e", "normal,build", "-p", "acs-python"]);
    // The test suite's build: every member, dev-dependencies included.
    let workspace = resolved_features(&["-e", "normal,build,dev", "--workspace"]);
    assert!(
        cli.len() > 50 && python.len() > cli.len(),
        "cargo tree listed {} and {} packages",
        cli.len(),
        python.len()
    );
    let d = differences(&cli, &python);
    assert!(
        d.is_empty(),
        "`cargo build -p sim-host` and the Python package's build resolve different features, so \
         `pip install ./sim-host/python` rebuilds the tree; align them in sim-host/Cargo.toml:\n{}",
        d.join("\n")
    );
    let d = differences(&python, &workspace);
    assert!(
        d.is_empty(),
        "the Python package and `cargo test --workspace` resolve different features:\n{}",
        d.join("\n")
    );
}
