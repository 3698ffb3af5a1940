//! Scenario keys addressed by path: `spacecraft.inertia_kgm2`, `initial.euler_deg[2]`,
//! `spacecraft.inertia_kgm2[2][2]`, `actuators.thrusters.failures` — dotted table keys,
//! then zero-based array indices. Parsed once, when the campaign file is read.

use anyhow::{Result, anyhow, bail};
use std::fmt;

#[derive(Clone, Debug, PartialEq, Eq)]
enum Segment {
    Key(String),
    Index(usize),
}

/// A parsed key path.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KeyPath {
    text: String,
    segments: Vec<Segment>,
}

impl KeyPath {
    pub fn parse(text: &str) -> Result<Self> {
        let mut segments = Vec::new();
        for part in text.split('.') {
            let (name, mut rest) = part.find('[').map_or((part, ""), |i| (&part[..i], &part[i..]));
            let valid = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
            if name.is_empty() || !name.chars().all(valid) {
                bail!("key path `{text}`: `{part}` is not a table key (letters, digits, `_`, `-`)");
            }
            segments.push(Segment::Key(name.to_owned()));
            // `rest` is empty or a run of `[i]`: `[2]`, `[2][1]`, ...
            while !rest.is_empty() {
                let inner = rest.strip_prefix('[').ok_or_else(|| anyhow!("key path `{text}`: unexpected `{rest}`"))?;
                let (index, tail) =
                    inner.split_once(']').ok_or_else(|| anyhow!("key path `{text}`: unclosed `[` in `{part}`"))?;
                let i: usize =
                    index.parse().map_err(|_| anyhow!("key path `{text}`: `[{index}]` is not an array index"))?;
                segments.push(Segment::Index(i));
                rest = tail;
            }
        }
        Ok(Self { text: text.to_owned(), segments })
    }

    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// The last table key of the path (`euler_deg` in `initial.euler_deg[2]`).
    pub fn leaf_name(&self) -> &str {
        self.segments
            .iter()
            .rev()
            .find_map(|s| match s {
                Segment::Key(k) => Some(k.as_str()),
                Segment::Index(_) => None,
            })
            .unwrap_or("")
    }

    /// Whether the path ends in an array index (it addresses one element).
    pub fn ends_in_index(&self) -> bool {
        matches!(self.segments.last(), Some(Segment::Index(_)))
    }

    /// The addressed value. With `create`, a missing last table key is created as
    /// `Value::Boolean(false)` placeholder for the caller to overwrite (only `set` does),
    /// and a missing table on the way as an empty table (an optional section the base
    /// leaves out, e.g. `margins.at_s`, `spacecraft.inertia_change.factor`; the planner's
    /// parse check judges the result).
    pub fn get_mut<'a>(&self, root: &'a mut toml::Value, create: bool) -> Result<&'a mut toml::Value> {
        let mut v = root;
        let last = self.segments.len().saturating_sub(1);
        for (n, seg) in self.segments.iter().enumerate() {
            v = match seg {
                Segment::Key(k) => {
                    let t = v.as_table_mut().ok_or_else(|| self.err(n, "is not a table"))?;
                    if create && !t.contains_key(k) {
                        let table_next = matches!(self.segments.get(n + 1), Some(Segment::Key(_)));
                        if n == last {
                            t.insert(k.clone(), toml::Value::Boolean(false));
                        } else if table_next {
                            t.insert(k.clone(), toml::Value::Table(toml::map::Map::new()));
                        }
                    }
                    t.get_mut(k).ok_or_else(|| self.err(n, "does not exist in the base scenario"))?
                }
                Segment::Index(i) => {
                    let a = v.as_array_mut().ok_or_else(|| self.err(n, "is not an array"))?;
                    let len = a.len();
                    a.get_mut(*i).ok_or_else(|| self.err(n, &format!("is out of range (length {len})")))?
                }
            };
        }
        Ok(v)
    }

    /// The parent table of the last key (for siblings such as `euler_sequence`).
    pub fn parent_table<'a>(&self, root: &'a toml::Value) -> Option<&'a toml::value::Table> {
        let key_pos = self.segments.iter().rposition(|s| matches!(s, Segment::Key(_)))?;
        let mut v = root;
        for seg in &self.segments[..key_pos] {
            v = match seg {
                Segment::Key(k) => v.as_table()?.get(k)?,
                Segment::Index(i) => v.as_array()?.get(*i)?,
            };
        }
        v.as_table()
    }

    fn err(&self, upto: usize, why: &str) -> anyhow::Error {
        let mut s = String::new();
        for seg in &self.segments[..=upto] {
            match seg {
                Segment::Key(k) if s.is_empty() => s.push_str(k),
                Segment::Key(k) => {
                    s.push('.');
                    s.push_str(k);
                }
                Segment::Index(i) => s.push_str(&format!("[{i}]")),
            }
        }
        anyhow!("key `{}`: `{s}` {why}", self.text)
    }
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_keys_and_indices() {
        let p = KeyPath::parse("spacecraft.inertia_kgm2[2][1]").unwrap();
        assert_eq!(
            p.segments,
            vec![
                Segment::Key("spacecraft".into()),
                Segment::Key("inertia_kgm2".into()),
                Segment::Index(2),
                Segment::Index(1)
            ]
        );
        assert_eq!(p.leaf_name(), "inertia_kgm2");
        assert!(p.ends_in_index());
        for bad in ["", "a..b", "a[", "a[x]", "a[1]b", "a[-1]", "a b"] {
            assert!(KeyPath::parse(bad).is_err(), "{bad:?} accepted");
        }
    }

    #[test]
    fn addresses_values_and_reports_what_is_missing() {
        let mut v: toml::Value = toml::from_str("[initial]\neuler_deg = [1.0, 2.0, 3.0]\n").unwrap();
        let p = KeyPath::parse("initial.euler_deg[2]").unwrap();
        *p.get_mut(&mut v, false).unwrap() = toml::Value::Float(9.0);
        assert_eq!(v["initial"]["euler_deg"][2].as_float(), Some(9.0));
        let e = KeyPath::parse("initial.euler_deg[3]").unwrap().get_mut(&mut v, false).unwrap_err();
        assert!(e.to_string().contains("out of range"), "{e}");
        let e = KeyPath::parse("initial.rate_rad_s").unwrap().get_mut(&mut v, false).unwrap_err();
        assert!(e.to_string().contains("does not exist"), "{e}");
        assert!(KeyPath::parse("initial.rate_rad_s").unwrap().get_mut(&mut v, true).is_ok());
    }
}
