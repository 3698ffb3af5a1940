//! The map matches the tree, and the layering has no cycle:
//! - `docs/architecture.md` holds one generated table per crate, one row per module with
//!   the first sentence of its `//!` doc: regenerated from the tree and compared here
//!   (`UPDATE_DOCS=1 cargo test --release -p acs-tests --test architecture` rewrites
//!   the tables; a module without a `//!` doc fails);
//! - every repository path named in `README.md` and `docs/*.md` exists, and a
//!   `path:LINE` pointer names a line the file has;
//! - the top-level modules of every crate form a DAG (`crate::x` uses), and so do the
//!   workspace crates with their dev-dependencies (`cargo metadata`);
//! - so do the files of every crate: no file-level import circle, siblings' `super::`
//!   imports included (edges between a module and its own ancestors are structure, not
//!   imports, and are left out).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The crates whose modules the architecture document lists: (source root, crate name).
const CRATES: &[(&str, &str)] = &[
    ("shared/src", "acs-flight"),
    ("firmware/src", "acs-firmware"),
    ("sim-host/core/src", "sim-core"),
    ("sim-host/src", "sim-host"),
    ("sim-host/python/src", "acs-python"),
    ("tests/support/src", "acs-test-support"),
    ("tests/src", "acs-tests"),
    ("tools/elf-check/src", "elf-check"),
];

/// Every `.rs` file under `dir` (sorted), as paths relative to `dir`.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else { continue };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    out.sort();
    out
}

/// `estimation/mekf.rs` → `estimation::mekf`; `modes/mod.rs` → `modes`; `lib.rs` → crate root.
fn module_path(rel: &Path) -> String {
    let s = rel.with_extension("").to_string_lossy().replace('\\', "/");
    let s = s.strip_suffix("/mod").unwrap_or(&s).to_owned();
    match s.as_str() {
        "lib" | "main" => "(crate root)".into(),
        _ => s.replace('/', "::"),
    }
}

/// The leading `//!` paragraphs of a file (at most two).
fn doc_paragraphs(text: &str) -> Vec<String> {
    let mut paras: Vec<String> = Vec::new();
    let mut cur = String::new();
    for line in text.lines() {
        let t = line.trim_start();
        let Some(d) = t.strip_prefix("//!") else {
            if paras.is_empty() && cur.is_empty() && (t.is_empty() || t.starts_with("#!") || t.starts_with("//")) {
                continue;
            }
            break;
        };
        let d = d.trim();
        if d.is_empty() {
            if !cur.is_empty() {
                paras.push(std::mem::take(&mut cur));
            }
            if paras.len() == 2 {
                break;
            }
            continue;
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(d);
    }
    if !cur.is_empty() && paras.len() < 2 {
        paras.push(cur);
    }
    paras
}

/// The first sentence of a paragraph: up to a full stop followed by a capital (not after
/// an abbreviation such as "e.g." or "eq.").
fn first_sentence(p: &str) -> &str {
    const ABBREV: &[&str] = &["e.g", "i.e", "cf", "eq", "eqs", "vs", "al", "Fig", "fig", "ch", "No"];
    for (i, _) in p.match_indices(". ") {
        let next = p[i + 2..].chars().next();
        let word = p[..i].rsplit([' ', '(']).next().unwrap_or("");
        if next.is_some_and(|c| c.is_uppercase() || c == '`' || c == '[') && !ABBREV.contains(&word) {
            return &p[..=i];
        }
    }
    p
}

/// One line for a module: the first sentence of its `//!` doc; a bare title ("Estimation")
/// is followed by the first sentence of the next paragraph.
fn doc_line(text: &str) -> Option<String> {
    let paras = doc_paragraphs(text);
    let first = paras.first()?;
    let title = !first.contains(". ") && !first.ends_with('.') && first.len() < 60;
    let line = match paras.get(1) {
        Some(next) if title => format!("{} — {}", first.trim_end_matches(':'), first_sentence(next)),
        _ => first_sentence(first).to_owned(),
    };
    Some(line.replace('|', "\\|"))
}

/// The generated table of one crate, or the modules that have no `//!` doc.
fn module_table(src: &str) -> Result<String, Vec<String>> {
    let dir = repo().join(src);
    let mut rows = Vec::new();
    let mut undocumented = Vec::new();
    let mut files = rust_files(&dir);
    files.sort_by_key(|rel| module_path(rel).replace("(crate root)", ""));
    for rel in files {
        // Test-only files and `#[path]` includes are not modules of the product.
        if rel.components().any(|c| c.as_os_str() == "tests") || rel.ends_with("tests.rs") {
            continue;
        }
        let text = std::fs::read_to_string(dir.join(&rel)).unwrap();
        match doc_line(&text) {
            Some(d) => rows.push(format!("| `{}` | {} |", module_path(&rel), d)),
            None => undocumented.push(format!("{src}/{}", rel.display())),
        }
    }
    if !undocumented.is_empty() {
        return Err(undocumented);
    }
    Ok(format!("| module | what it is (its `//!` doc) |\n|---|---|\n{}\n", rows.join("\n")))
}

fn begin_marker(src: &str) -> String {
    format!(
        "<!-- modules {src}: generated from the tree by tests/tests/architecture.rs (UPDATE_DOCS=1 regenerates) -->\n"
    )
}
const END_MARKER: &str = "<!-- end modules -->";

#[test]
fn architecture_document_lists_every_module_with_its_doc() {
    let path = repo().join("docs/architecture.md");
    let mut doc = std::fs::read_to_string(&path).unwrap();
    let mut problems = Vec::new();
    for (src, _) in CRATES {
        if !repo().join(src).is_dir() {
            problems.push(format!("{src}: listed in CRATES but not in the tree"));
            continue;
        }
        let table = match module_table(src) {
            Ok(t) => t,
            Err(missing) => {
                problems.push(format!("modules without a `//!` doc: {}", missing.join(", ")));
                continue;
            }
        };
        let begin = begin_marker(src);
        let Some(b) = doc.find(&begin) else {
            problems.push(format!("docs/architecture.md has no generated table for {src}"));
            continue;
        };
        let start = b + begin.len();
        let end = start + doc[start..].find(END_MARKER).expect("end marker after a begin marker");
        if doc[start..end] != table {
            if std::env::var_os("UPDATE_DOCS").is_some() {
                doc.replace_range(start..end, &table);
            } else {
                problems.push(format!("the module table of {src} is stale"));
            }
        }
    }
    if std::env::var_os("UPDATE_DOCS").is_some() {
        std::fs::write(&path, &doc).unwrap();
    }
    assert!(
        problems.is_empty(),
        "{}\n(UPDATE_DOCS=1 cargo test --release -p acs-tests --test architecture regenerates the tables)",
        problems.join("\n")
    );
}

/// A repository path named in a markdown text: `` `dir/...` `` spans and `](dir/...)`
/// links, with an optional `#anchor` (a symbol of a source file, a heading of a document)
/// or a `:LINE` suffix (refused: line numbers rot with every edit).
struct Pointer {
    path: String,
    anchor: Option<String>,
    line_suffix: bool,
}

fn path_pointers(text: &str) -> Vec<Pointer> {
    const ROOTS: &[&str] = &[
        "shared/",
        "sim-host/",
        "firmware/",
        "tests/",
        "tools/",
        "scripts/",
        "scenarios/",
        "docs/",
        "campaigns/",
        "timing/",
        ".ci/",
    ];
    let mut out = Vec::new();
    for token in text
        .split(['`', '(', ')', ' ', '\n', '[', ']', '"', '\'', ','])
        .filter(|t| ROOTS.iter().any(|r| t.starts_with(r)))
    {
        let (token, anchor) = match token.split_once('#') {
            Some((p, a)) => (p, Some(a.trim_end_matches(['.', ';', ':']).to_owned())),
            None => (token, None),
        };
        let (path, line_suffix) = match token.split_once(':') {
            Some((p, l)) => (p, l.starts_with(|c: char| c.is_ascii_digit())),
            None => (token, false),
        };
        let path = path.trim_end_matches(['.', ';', ':']);
        // Globs, placeholders, output folders and build outputs are patterns, not pointers.
        if path.contains(['*', '<', '{', '$'])
            || path.contains("/out")
            || path.contains("/target/")
            || path.contains("..")
        {
            continue;
        }
        out.push(Pointer { path: path.to_owned(), anchor, line_suffix });
    }
    out
}

/// Whether `anchor` names something in `text`: a symbol of a source file (as a word), or a
/// heading of a markdown document (its words, case and `-`/space insensitive).
fn anchor_found(path: &str, text: &str, anchor: &str) -> bool {
    if path.ends_with(".md") {
        let norm = |s: &str| s.to_lowercase().replace(['-', '`'], " ").split_whitespace().collect::<Vec<_>>().join(" ");
        let want = norm(anchor);
        return text.lines().filter(|l| l.starts_with('#')).any(|h| norm(h.trim_start_matches('#')).contains(&want));
    }
    text.match_indices(anchor).any(|(i, _)| {
        let before = text[..i].chars().next_back();
        let after = text[i + anchor.len()..].chars().next();
        let word = |c: Option<char>| c.is_some_and(|c| c.is_alphanumeric() || c == '_');
        !word(before) && !word(after)
    })
}

#[test]
fn every_path_the_documents_name_exists() {
    let mut docs: Vec<PathBuf> = vec![repo().join("README.md")];
    for e in std::fs::read_dir(repo().join("docs")).unwrap().flatten() {
        if e.path().extension().is_some_and(|x| x == "md") {
            docs.push(e.path());
        }
    }
    docs.sort();
    let mut dead = Vec::new();
    let mut checked = 0;
    for d in &docs {
        let text = std::fs::read_to_string(d).unwrap();
        let name = d.strip_prefix(repo()).unwrap_or(d).display().to_string();
        for p in path_pointers(&text) {
            checked += 1;
            let full = repo().join(&p.path);
            if !full.exists() {
                dead.push(format!("{name}: `{}` does not exist", p.path));
            } else if p.line_suffix {
                dead.push(format!("{name}: `{}:LINE`: line numbers rot, point at a symbol (`path#symbol`)", p.path));
            } else if let Some(a) = &p.anchor {
                let target = std::fs::read_to_string(&full).unwrap_or_default();
                if !anchor_found(&p.path, &target, a) {
                    dead.push(format!("{name}: `{}#{a}`: no such symbol or heading there", p.path));
                }
            }
        }
    }
    assert!(checked > 100, "the scan found only {checked} pointers: the parser is broken");
    assert!(dead.is_empty(), "{} dead pointers:\n{}", dead.len(), dead.join("\n"));
}

#[test]
fn pointer_checks_catch_what_they_should() {
    let ps = path_pointers("see `shared/src/lib.rs#Fsw`, `docs/protocol.md:12` and [x](scripts/nope.sh)");
    assert_eq!(ps.len(), 3);
    assert_eq!(ps[0].anchor.as_deref(), Some("Fsw"));
    assert!(ps[1].line_suffix);
    assert!(!repo().join(&ps[2].path).exists());
    assert!(anchor_found("a.rs", "pub use fsw::Fsw;", "Fsw"));
    assert!(!anchor_found("a.rs", "pub struct FswX;", "Fsw"));
    assert!(anchor_found("a.md", "# T\n## The wire `frame` format\n", "wire-frame"));
}

/// Edges `module → modules it uses` between the top-level modules of the crate at `src`.
fn module_graph(src: &str) -> BTreeMap<String, BTreeSet<String>> {
    let dir = repo().join(src);
    let files = rust_files(&dir);
    let top = |rel: &Path| {
        rel.components().next().map(|c| c.as_os_str().to_string_lossy().trim_end_matches(".rs").to_owned())
    };
    let mods: BTreeSet<String> = files.iter().filter_map(|r| top(r)).filter(|m| m != "lib" && m != "main").collect();
    let mut g: BTreeMap<String, BTreeSet<String>> = mods.iter().map(|m| (m.clone(), BTreeSet::new())).collect();
    for rel in &files {
        let Some(m) = top(rel).filter(|m| mods.contains(m)) else { continue };
        let text = std::fs::read_to_string(dir.join(rel)).unwrap();
        // Unit tests may reach across layers; the product may not.
        let product = text.split("#[cfg(test)]\nmod tests").next().unwrap_or("");
        for line in product.lines().map(|l| l.split("//").next().unwrap_or("")) {
            for (i, _) in line.match_indices("crate::") {
                let rest = &line[i + "crate::".len()..];
                let names: Vec<&str> = match rest.strip_prefix('{') {
                    Some(group) => group.split('}').next().unwrap_or("").split(',').collect(),
                    None => vec![rest],
                };
                for n in names {
                    let n: String = n.trim().chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                    if n != m && mods.contains(&n) {
                        g.get_mut(&m).unwrap().insert(n);
                    }
                }
            }
        }
    }
    g
}

/// The strongly connected components with more than one node (Tarjan).
fn cycles(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct T<'a> {
        g: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a str) {
        let i = t.index.len();
        t.index.insert(v, i);
        t.low.insert(v, i);
        t.stack.push(v);
        for w in t.g.get(v).into_iter().flatten() {
            let w = w.as_str();
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if t.stack.contains(&w) {
                let iw = t.index[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if t.low[v] == t.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = t.stack.pop() {
                comp.push(w.to_owned());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                t.out.push(comp);
            }
        }
    }
    let mut t = T { g, index: BTreeMap::new(), low: BTreeMap::new(), stack: Vec::new(), out: Vec::new() };
    for v in g.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}

#[test]
fn cycle_finder_finds_a_planted_cycle() {
    let g: BTreeMap<String, BTreeSet<String>> =
        [("a", vec!["b"]), ("b", vec!["c"]), ("c", vec!["a"]), ("d", vec!["a"])]
            .into_iter()
            .map(|(k, v)| (k.to_owned(), v.into_iter().map(str::to_owned).collect()))
            .collect();
    assert_eq!(cycles(&g), vec![vec!["a".to_owned(), "b".into(), "c".into()]]);
}

#[test]
fn module_layering_of_every_crate_has_no_cycle() {
    let mut found = Vec::new();
    for (src, name) in CRATES {
        if !repo().join(src).is_dir() {
            continue;
        }
        let g = module_graph(src);
        assert!(!g.is_empty() || *src == "tests/src", "{src}: no modules found");
        for c in cycles(&g) {
            found.push(format!("{name}: {}", c.join(" ↔ ")));
        }
    }
    assert!(found.is_empty(), "module cycles:\n{}", found.join("\n"));
}

#[test]
fn crate_graph_with_dev_dependencies_has_no_cycle() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = std::process::Command::new(cargo)
        .args(["metadata", "--format-version", "1", "--no-deps", "--offline"])
        .current_dir(repo())
        .output()
        .expect("cargo metadata runs");
    assert!(out.status.success(), "cargo metadata: {}", String::from_utf8_lossy(&out.stderr));
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let packages = meta["packages"].as_array().unwrap();
    let names: BTreeSet<String> = packages.iter().map(|p| p["name"].as_str().unwrap().to_owned()).collect();
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for p in packages {
        let deps = p["dependencies"].as_array().unwrap();
        let e = g.entry(p["name"].as_str().unwrap().to_owned()).or_default();
        for d in deps.iter().filter_map(|d| d["name"].as_str()).filter(|d| names.contains(*d)) {
            e.insert(d.to_owned());
        }
    }
    assert!(g.len() >= 4, "workspace packages: {:?}", g.keys());
    assert!(g["sim-host"].contains("sim-core"), "the tools crate is built on the core: {:?}", g["sim-host"]);
    assert!(!g["sim-core"].contains("sim-host"), "the core must not depend on its tools");
    assert!(cycles(&g).is_empty(), "crate cycles: {:?}", cycles(&g));
}

/// The module paths a `use` tree names: `a::{b, c::{d, e as f}}` → `a::b`, `a::c::d`,
/// `a::c::e` (renames and globs dropped to their path).
fn flatten_use(tree: &str) -> Vec<String> {
    // Drop renames (`e as f` → `e`) while the words are still apart, then the whitespace.
    let mut words = tree.split_whitespace().peekable();
    let mut kept = String::new();
    while let Some(w) = words.next() {
        if w == "as" {
            // The new name, and whatever punctuation closes it.
            let name = words.next().unwrap_or("");
            kept.push_str(name.trim_start_matches(|c: char| c.is_alphanumeric() || c == '_'));
        } else {
            kept.push_str(w);
        }
    }
    let tree = kept;
    let mut out = Vec::new();
    fn walk(prefix: &str, t: &str, out: &mut Vec<String>) {
        // Split `t` at top-level commas.
        let (mut depth, mut start) = (0i32, 0usize);
        let mut parts = Vec::new();
        for (i, ch) in t.char_indices() {
            match ch {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    parts.push(&t[start..i]);
                    start = i + 1;
                }
                _ => {}
            }
        }
        parts.push(&t[start..]);
        for part in parts.into_iter().filter(|p| !p.is_empty()) {
            match part.find("::{") {
                Some(i) if part.ends_with('}') => {
                    let head = &part[..i];
                    let inner = &part[i + 3..part.len() - 1];
                    let p = if prefix.is_empty() { head.to_owned() } else { format!("{prefix}::{head}") };
                    walk(&p, inner, out);
                }
                _ => {
                    let part = part.trim_end_matches("::*");
                    out.push(if prefix.is_empty() { part.to_owned() } else { format!("{prefix}::{part}") });
                }
            }
        }
    }
    let tree = tree.strip_prefix('{').and_then(|t| t.strip_suffix('}')).unwrap_or(&tree);
    walk("", tree, &mut out);
    out
}

/// The `use` statements and inline `crate::`/`super::`/`self::` paths of a file's product
/// code (before its `#[cfg(test)] mod tests`), each as a path from the crate root.
fn file_imports(module: &str, is_mod_file: bool, text: &str) -> Vec<Vec<String>> {
    let product = text.split("#[cfg(test)]\nmod tests").next().unwrap_or("");
    let code: String = product.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n");
    // The module a `super::` resolves against: a `mod.rs` file *is* its directory's module.
    let own: Vec<&str> = if module == "(crate root)" { vec![] } else { module.split("::").collect() };
    let parent = |n: usize| -> Vec<String> {
        let base = if is_mod_file { own.len() } else { own.len().saturating_sub(1) };
        own[..base.saturating_sub(n.saturating_sub(1))].iter().map(|s| s.to_string()).collect()
    };
    let resolve = |path: &str| -> Option<Vec<String>> {
        let segs: Vec<&str> = path.split("::").filter(|s| !s.is_empty()).collect();
        let first = *segs.first()?;
        let (mut base, rest): (Vec<String>, &[&str]) = match first {
            "crate" => (vec![], &segs[1..]),
            "super" => {
                let n = segs.iter().take_while(|s| **s == "super").count();
                (parent(n), &segs[n..])
            }
            "self" => (if is_mod_file { own.iter().map(|s| s.to_string()).collect() } else { parent(0) }, &segs[1..]),
            _ => return None,
        };
        base.extend(rest.iter().map(|s| s.to_string()));
        Some(base)
    };
    let mut out = Vec::new();
    // `use` statements (possibly over several lines), flattened.
    for stmt in code.split(';') {
        let Some(i) = stmt.find("use ") else { continue };
        let before = stmt[..i].trim_end();
        if !(before.is_empty()
            || before.ends_with("pub")
            || before.ends_with(')')
            || before.ends_with('}')
            || before.ends_with('\n'))
        {
            continue;
        }
        for p in flatten_use(&stmt[i + 4..]) {
            if let Some(r) = resolve(&p) {
                out.push(r);
            }
        }
    }
    // Inline paths in expressions and types.
    for prefix in ["crate::", "super::", "self::"] {
        for (i, _) in code.match_indices(prefix) {
            if code[..i].ends_with(|c: char| c.is_alphanumeric() || c == '_' || c == ':') {
                continue;
            }
            let path: String =
                code[i..].chars().take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':').collect();
            if let Some(r) = resolve(&path) {
                out.push(r);
            }
        }
    }
    out
}

/// Edges `file → files it imports` of the crate at `dir` (module paths; the longest
/// module prefix of each imported path), leaving out edges between a module and its own
/// ancestors.
fn file_graph(dir: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let files = rust_files(dir);
    let modules: BTreeSet<String> = files.iter().map(|r| module_path(r)).collect();
    let mut g: BTreeMap<String, BTreeSet<String>> = modules.iter().map(|m| (m.clone(), BTreeSet::new())).collect();
    let is_ancestor = |a: &str, b: &str| b.starts_with(&format!("{a}::"));
    for rel in &files {
        let m = module_path(rel);
        let is_mod = rel.file_name().is_some_and(|n| n == "mod.rs" || n == "lib.rs" || n == "main.rs");
        let text = std::fs::read_to_string(dir.join(rel)).unwrap();
        for path in file_imports(&m, is_mod, &text) {
            // The longest prefix that is a file of this crate.
            let target = (1..=path.len()).rev().map(|n| path[..n].join("::")).find(|p| modules.contains(p));
            let Some(t) = target else { continue };
            if t == m || m == "(crate root)" || is_ancestor(&t, &m) || is_ancestor(&m, &t) {
                continue;
            }
            g.get_mut(&m).unwrap().insert(t);
        }
    }
    g
}

#[test]
fn file_cycle_finder_finds_a_planted_circle_between_siblings() {
    let dir = std::env::temp_dir().join(format!("acs-arch-planted-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("alloc")).unwrap();
    std::fs::write(dir.join("lib.rs"), "pub mod alloc;\n").unwrap();
    std::fs::write(dir.join("alloc/mod.rs"), "pub mod lp;\npub mod zono;\nuse lp::Solver;\n").unwrap();
    std::fs::write(dir.join("alloc/lp.rs"), "use super::zono::{clampf, Bounds};\npub struct Solver;\n").unwrap();
    std::fs::write(
        dir.join("alloc/zono.rs"),
        "pub fn clampf() {}\npub struct Bounds;\nfn f() { super::lp::Solver; }\n",
    )
    .unwrap();
    let g = file_graph(&dir);
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(cycles(&g), vec![vec!["alloc::lp".to_owned(), "alloc::zono".into()]], "{g:?}");
    // A parent using its child and the child using the parent is structure, not a circle.
    assert!(g["alloc"].is_empty() || !g["alloc"].contains("alloc::lp"), "{g:?}");
}

#[test]
fn use_trees_flatten_to_paths() {
    assert_eq!(flatten_use("super::{a, b::{C, d::E}}"), vec!["super::a", "super::b::C", "super::b::d::E"]);
    assert_eq!(flatten_use("crate::x::*"), vec!["crate::x"]);
    assert_eq!(flatten_use("super::{a as b, c::D as E}"), vec!["super::a", "super::c::D"]);
}

#[test]
fn no_crate_has_a_file_level_import_circle() {
    let mut found = Vec::new();
    for (src, name) in CRATES {
        let dir = repo().join(src);
        if !dir.is_dir() {
            continue;
        }
        for c in cycles(&file_graph(&dir)) {
            found.push(format!("{name}: {}", c.join(" ↔ ")));
        }
    }
    assert!(found.is_empty(), "file-level import circles:\n{}", found.join("\n"));
}
