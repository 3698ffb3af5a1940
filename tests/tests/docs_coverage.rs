//! Issue 22: every key the scenario parser accepts is documented in `docs/scenario.md`.
//!
//! The keys are not listed by hand (a list would go stale with the parser it checks): they
//! are discovered from the parser itself. Into each table of each shipped scenario a probe
//! key is inserted; the parser's refusal ("unknown field `…`, expected one of `a`, `b`, …")
//! names every field that table accepts. Fields absent from the file are probed the same way
//! as an empty table (a struct answers with its own list), a one-table array (a list of
//! structs) or, for a table with a `type` tag, once per variant the tag accepts ("unknown
//! variant …, expected one of …"). What the parser accepts is therefore what is checked.
//!
//! A key counts as documented when its name appears in code formatting inside the section
//! of `docs/scenario.md` whose `## ` heading names its table (the longest matching prefix,
//! e.g. `[sensors]` for `sensors.gyro.rate_hz`), and, where the section documents it in a
//! table row, that row gives a default (a non-empty second cell: a value, "required" or
//! "none").

use sim_core::scenario::Scenario;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use toml::{Table, Value};

const PROBE: &str = "zz_probe_key";

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn shipped_scenarios() -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut dirs = vec![repo().join("scenarios")];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "toml") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The backticked names after "expected" in a serde refusal (`None`: not such a refusal).
fn expected_names(message: &str, what: &str) -> Option<Vec<String>> {
    let at = message.find(what)?;
    let rest = &message[at..];
    let tail = &rest[rest.find("expected")?..];
    let tail = tail.lines().next().unwrap_or("");
    let names: Vec<String> = tail.split('`').skip(1).step_by(2).map(str::to_string).collect();
    Some(names)
}

/// Parses `doc` and returns the refusal's message ("" if it parsed).
fn refusal(doc: &Table) -> String {
    let text = toml::to_string(doc).unwrap();
    match Scenario::from_toml(&text) {
        Ok(_) => String::new(),
        Err(e) => format!("{e:#}"),
    }
}

/// `doc` with `value` at `path` (tables created on the way).
fn with(doc: &Table, path: &[String], value: Value) -> Table {
    let mut d = doc.clone();
    let mut t = &mut d;
    for (i, p) in path.iter().enumerate() {
        if i + 1 == path.len() {
            t.insert(p.clone(), value);
            break;
        }
        let next = t.entry(p.clone()).or_insert_with(|| Value::Table(Table::new()));
        t = match next {
            Value::Table(x) => x,
            Value::Array(a) => match a.first_mut() {
                Some(Value::Table(x)) => x,
                _ => return d,
            },
            _ => return d,
        };
    }
    d
}

fn probe_table(fields: BTreeMap<String, Value>) -> Value {
    let mut t: Table = fields.into_iter().collect();
    t.insert(PROBE.into(), Value::Integer(0));
    Value::Table(t)
}

struct Discovery {
    /// Documented-key path (dots, no indices) → found.
    keys: BTreeSet<String>,
    seen: BTreeSet<(String, String)>,
}

impl Discovery {
    /// The fields of the table at `path` in `doc` (given `fields` already in it), recursing
    /// into each field that is itself a table, a list of tables or a tagged enum.
    fn table(&mut self, doc: &Table, path: &[String], fields: BTreeMap<String, Value>, depth: usize) {
        let key = path.join(".");
        let tag = fields.get("type").and_then(Value::as_str).unwrap_or("").to_string();
        // Done once per table and tag, once the parser named its fields (a failed probe,
        // e.g. a list probed as a table, does not count).
        if depth > 6 || self.seen.contains(&(key.clone(), tag.clone())) {
            return;
        }
        if !tag.is_empty() && tag != PROBE {
            self.keys.insert(format!("{key}.type"));
            self.variants(doc, path, &fields, depth);
        }
        let probed = match probe_table(fields.clone()) {
            Value::Table(root) if path.is_empty() => root,
            t => place(doc, path, t),
        };
        let msg = refusal(&probed);
        let Some(names) = expected_names(&msg, &format!("unknown field `{PROBE}`")) else { return };
        self.seen.insert((key, tag));
        for name in names {
            let mut sub = path.to_vec();
            sub.push(name.clone());
            self.keys.insert(sub.join("."));
            self.field(doc, &sub, depth);
        }
    }

    /// A `type`-tagged table: every variant's fields.
    fn variants(&mut self, doc: &Table, path: &[String], fields: &BTreeMap<String, Value>, depth: usize) {
        let mut f = fields.clone();
        f.insert("type".into(), Value::String(PROBE.into()));
        let msg = refusal(&place(doc, path, Value::Table(f.into_iter().collect())));
        for v in expected_names(&msg, &format!("unknown variant `{PROBE}`")).unwrap_or_default() {
            let only: BTreeMap<String, Value> = [("type".to_string(), Value::String(v))].into();
            self.table(doc, path, only, depth + 1);
        }
    }

    /// A field: a struct (probe it as a table), a list of structs, or a leaf.
    fn field(&mut self, doc: &Table, sub: &[String], depth: usize) {
        let existing = lookup(doc, sub);
        match existing {
            Some(Value::Table(t)) => {
                let fields = t.iter().map(|(k, v)| (k.clone(), v.clone())).collect();
                self.table(doc, sub, fields, depth + 1);
            }
            Some(Value::Array(a)) if matches!(a.first(), Some(Value::Table(_))) => {
                let Some(Value::Table(t)) = a.first() else { return };
                let fields: BTreeMap<String, Value> = t.iter().map(|(k, v)| (k.clone(), v.clone())).collect();
                let one = with(doc, sub, Value::Array(vec![Value::Table(Table::new())]));
                self.table(&one, sub, fields, depth + 1);
            }
            Some(_) => {}
            None => {
                let empty = with(doc, sub, Value::Table(Table::new()));
                self.table(&empty, sub, BTreeMap::new(), depth + 1);
                let list = with(doc, sub, Value::Array(vec![Value::Table(Table::new())]));
                self.table(&list, sub, BTreeMap::new(), depth + 1);
            }
        }
    }
}

/// `doc` with the table `t` at `path`, as the one element of a list where `doc` has a list
/// of tables there (`[[commands]]`).
fn place(doc: &Table, path: &[String], t: Value) -> Table {
    match lookup(doc, path) {
        Some(Value::Array(_)) => with(doc, path, Value::Array(vec![t])),
        _ => with(doc, path, t),
    }
}

fn lookup<'a>(doc: &'a Table, path: &[String]) -> Option<&'a Value> {
    let (last, head) = path.split_last()?;
    let mut t = doc;
    for p in head {
        t = match t.get(p)? {
            Value::Table(x) => x,
            Value::Array(a) => a.first()?.as_table()?,
            _ => return None,
        };
    }
    t.get(last)
}

/// Every key any shipped scenario's parser accepts.
fn accepted_keys() -> BTreeSet<String> {
    let mut d = Discovery { keys: BTreeSet::new(), seen: BTreeSet::new() };
    for p in shipped_scenarios() {
        let doc: Table = toml::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
        let top = doc.iter().map(|(k, v)| (k.clone(), v.clone())).collect();
        d.table(&doc, &[], top, 0);
    }
    d.keys
}

/// `docs/scenario.md` split at `## ` headings: (table paths the heading names, body).
fn sections(doc: &str) -> Vec<(Vec<String>, String)> {
    let mut out: Vec<(Vec<String>, String)> = vec![(vec!["(preamble)".to_string()], String::new())];
    for line in doc.lines() {
        if let Some(h) = line.strip_prefix("## ") {
            let names = h.split('`').skip(1).step_by(2).map(|s| s.trim_matches(|c| c == '[' || c == ']').to_string());
            let mut names: Vec<String> = names.collect();
            if names.is_empty() || h.starts_with("Top level") {
                names.push(String::new());
            }
            out.push((names, String::new()));
        } else if let Some(last) = out.last_mut() {
            last.1 += line;
            last.1.push('\n');
        }
    }
    out
}

/// The sections that may document the table `table` (dotted), most specific first: the
/// one whose heading names it, one whose text names it as `[table]` (a table documented
/// inside another's section, like `[open_loop]` under `[controller]`), the section of a
/// top-level table of the same name as its last part (`modes.hold.target` is a
/// `[target]`), then those of its prefixes.
fn sections_of<'a>(table: &[&str], sections: &'a [(Vec<String>, String)]) -> Vec<&'a (Vec<String>, String)> {
    let by_heading = |p: String| sections.iter().filter(move |(names, _)| names.contains(&p));
    let by_mention = |p: String| sections.iter().filter(move |(_, body)| body.contains(&format!("`[{p}]`")));
    let full = table.join(".");
    let mut out: Vec<_> = by_heading(full.clone()).chain(by_mention(full)).collect();
    if let (Some(last), true) = (table.last(), table.len() > 1) {
        out.extend(by_heading(last.to_string()));
    }
    for n in (1..table.len()).rev() {
        let prefix = table[..n].join(".");
        out.extend(by_heading(prefix.clone()).chain(by_mention(prefix)));
    }
    if table.is_empty() {
        out.extend(by_heading(String::new()));
    }
    out
}

/// Why `key` is not documented in `sections`, or `None` if it is. `tables`: the keys that
/// are tables themselves (documented by a `[key]` heading or mention anywhere).
fn undocumented(key: &str, sections: &[(Vec<String>, String)], tables: &BTreeSet<String>) -> Option<String> {
    let heads_or_mentions = sections.iter().any(|(n, b)| n.iter().any(|x| x == key) || b.contains(&format!("[{key}]")));
    if heads_or_mentions && (tables.contains(key) || !key.contains('.')) {
        return None;
    }
    let parts: Vec<&str> = key.split('.').collect();
    let leaf = parts.last().copied().unwrap_or("");
    let candidates = sections_of(&parts[..parts.len() - 1], sections);
    let named = |s: &&str| s.split(|c: char| !(c.is_alphanumeric() || c == '_')).any(|w| w == leaf);
    let Some((_, body)) = candidates.iter().find(|(_, body)| body.split('`').skip(1).step_by(2).any(|s| named(&s)))
    else {
        let names: Vec<&Vec<String>> = candidates.iter().map(|(n, _)| n).collect();
        return Some(format!("{key}: not named in the sections {names:?}"));
    };
    let row = body
        .lines()
        .find(|l| l.starts_with("| `") && l.split('|').nth(1).is_some_and(|c| c.contains(&format!("`{leaf}`"))));
    if let Some(row) = row
        && row.split('|').nth(2).is_none_or(|c| c.trim().is_empty())
    {
        return Some(format!("{key}: its table row gives no default: {row}"));
    }
    None
}

#[test]
fn every_key_the_parser_accepts_is_documented() {
    let keys = accepted_keys();
    // The discovery itself must work: these are known keys of four different kinds (a
    // top-level leaf, a nested struct, a tagged enum's variant field, a list of structs).
    for k in ["duration_s", "actuators.wheels.max_torque_nm", "controller.wn_rad_s", "commands.at_s"] {
        assert!(keys.contains(k), "discovery missed {k}; found {} keys: {keys:?}", keys.len());
    }
    assert!(keys.len() > 200, "only {} keys discovered", keys.len());
    let doc = std::fs::read_to_string(repo().join("docs/scenario.md")).unwrap();
    let secs = sections(&doc);
    let tables: BTreeSet<String> = keys.iter().filter_map(|k| k.rsplit_once('.').map(|(t, _)| t.to_string())).collect();
    let missing: Vec<String> = keys.iter().filter_map(|k| undocumented(k, &secs, &tables)).collect();
    assert!(
        missing.is_empty(),
        "{} of {} keys undocumented in docs/scenario.md:\n{}",
        missing.len(),
        keys.len(),
        missing.join("\n")
    );
}

#[test]
fn the_coverage_check_notices_an_undocumented_key() {
    let doc = "## `[actuators.wheels]`\n\n| key | default | meaning |\n|---|---|---|\n| `max_torque_nm` | | N m |\n| `inertia_kgm2` | 0.1 | kg m² |\n";
    let secs = sections(doc);
    let none = BTreeSet::new();
    assert!(undocumented("actuators.wheels.inertia_kgm2", &secs, &none).is_none());
    assert!(undocumented("actuators.wheels.max_torque_nm", &secs, &none).is_some_and(|w| w.contains("no default")));
    assert!(undocumented("actuators.wheels.layout", &secs, &none).is_some_and(|w| w.contains("not named")));
}
