//! Number formatting of the tools' text outputs (the report and the campaign summary).
//! Both print significant digits, plain between 1e-3 and 1e6 and scientific outside; they
//! differ in their edge cases (zero, NaN, ±∞, the decade bounds), and each output is
//! committed or compared as it is, so both forms are kept, on one renderer.

/// `x` with `digits` significant digits, plain notation between 1e-3 and 1e6, else
/// scientific; `—` for NaN. Deterministic text for the committed report.
pub fn sig(x: f64, digits: usize) -> String {
    if x.is_nan() {
        return "—".into();
    }
    if x == 0.0 {
        return "0".into();
    }
    if !x.is_finite() {
        return if x > 0.0 { "∞".into() } else { "−∞".into() };
    }
    let digits = digits.max(1);
    let mag = x.abs().log10().floor() as i32;
    let decimals = (-3..6).contains(&mag).then(|| (digits as i32 - 1 - mag).max(0) as usize);
    plain_or_scientific(x, decimals, digits)
}

/// [`sig`] without trailing zeros in plain notation (`40`, `1.5`, `5.407e-5`): the console's
/// form, where a figure's digits should not suggest a precision it was not given with.
pub fn sig_short(x: f64, digits: usize) -> String {
    let s = sig(x, digits);
    let trim =
        |m: &str| if m.contains('.') { m.trim_end_matches('0').trim_end_matches('.').to_string() } else { m.into() };
    match s.split_once('e') {
        Some((mantissa, exp)) => format!("{}e{exp}", trim(mantissa)),
        None => trim(&s),
    }
}

/// The campaign summary's form: six significant digits, plain for `|x|` in [1e-3, 1e6)
/// (the bound tested on `|x|`, not on its decade) and for zero (`0.00000000`), else
/// scientific; NaN and ±∞ as Rust prints them (`NaN`, `inf`).
pub fn sig_campaign(x: f64) -> String {
    let a = x.abs();
    let plain = x == 0.0 || (1e-3..1e6).contains(&a);
    let decimals = plain.then(|| (5 - a.log10().floor().max(-3.0) as i32).clamp(0, 8) as usize);
    plain_or_scientific(x, decimals, 6)
}

/// `x` with `decimals` decimals, or (`None`) scientific with `digits` significant digits.
fn plain_or_scientific(x: f64, decimals: Option<usize>, digits: usize) -> String {
    match decimals {
        Some(decimals) => format!("{x:.decimals$}"),
        None => format!("{x:.prec$e}", prec = digits - 1),
    }
}

/// A nested value (flight parameters as serde writes them) as aligned `key  value` lines:
/// objects flattened into dotted paths (an enum's variant becomes a path element), arrays
/// of numbers kept on one line, numbers to 7 significant digits (what an f32 holds).
pub fn key_value_lines(v: &serde_json::Value) -> String {
    let mut rows = Vec::new();
    flatten("", v, &mut rows);
    let width = rows.iter().map(|(k, _)| k.chars().count()).max().unwrap_or(0);
    rows.iter().map(|(k, v)| format!("  {k:<width$}  {v}\n")).collect()
}

fn flatten(path: &str, v: &serde_json::Value, rows: &mut Vec<(String, String)>) {
    use serde_json::Value;
    let join = |k: &str| if path.is_empty() { k.to_string() } else { format!("{path}.{k}") };
    match v {
        Value::Object(m) if !m.is_empty() => m.iter().for_each(|(k, x)| flatten(&join(k), x, rows)),
        Value::Array(a) if !a.iter().all(is_inline) => {
            a.iter().enumerate().for_each(|(i, x)| flatten(&format!("{path}[{i}]"), x, rows))
        }
        _ => rows.push((path.to_string(), inline(v))),
    }
}

/// Numbers, strings, booleans, null and arrays of those (nested) print on one line.
fn is_inline(v: &serde_json::Value) -> bool {
    match v {
        serde_json::Value::Object(m) => m.is_empty(),
        serde_json::Value::Array(a) => a.iter().all(is_inline),
        _ => true,
    }
}

fn inline(v: &serde_json::Value) -> String {
    use serde_json::Value;
    match v {
        Value::Number(n) => {
            n.as_f64().map_or_else(|| n.to_string(), |x| if n.is_f64() { sig_short(x, 7) } else { n.to_string() })
        }
        Value::String(s) => s.clone(),
        Value::Array(a) => format!("[{}]", a.iter().map(inline).collect::<Vec<_>>().join(", ")),
        Value::Object(_) => "{}".into(),
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_value_lines_flatten_objects_and_keep_number_arrays_inline() {
        let v = serde_json::json!({
            "rate_hz": 100.0,
            "gains": {"Pd": {"k": [0.1f32, 2.0, 3.0], "n": 4}},
            "m": [[1.0, 0.0], [0.0, 1.0]],
            "wheels": [{"axis": [1.0, 0.0, 0.0]}, {"axis": [0.0, 1.0, 0.0]}],
            "name": "x",
        });
        let text = key_value_lines(&v);
        let lines: Vec<&str> = text.lines().map(str::trim).collect();
        // Values start in one column: after the longest key and two spaces.
        assert!(text.lines().all(|l| l.get(18..19).is_some_and(|c| c != " ")), "{text}");
        assert!(lines.iter().any(|l| l.starts_with("gains.Pd.k ") && l.ends_with(" [0.1, 2, 3]")), "{text}");
        assert!(lines.iter().any(|l| l.starts_with("gains.Pd.n") && l.ends_with(" 4")), "{text}");
        assert!(lines.iter().any(|l| l.starts_with("m ") && l.ends_with("[[1, 0], [0, 1]]")), "{text}");
        assert!(lines.iter().any(|l| l.starts_with("wheels[1].axis") && l.ends_with("[0, 1, 0]")), "{text}");
        assert!(lines.iter().any(|l| l.starts_with("rate_hz") && l.ends_with(" 100")), "{text}");
        assert_eq!(lines.len(), 7, "{text}");
    }

    #[test]
    fn sig_short_trims_only_plain_decimals() {
        assert_eq!(sig_short(40.0, 6), "40");
        assert_eq!(sig_short(1.0, 3), "1");
        assert_eq!(sig_short(11.34, 4), "11.34");
        assert_eq!(sig_short(1500.0, 4), "1500");
        assert_eq!(sig_short(5.407e-5, 4), "5.407e-5");
        assert_eq!(sig_short(1e-6, 7), "1e-6");
        assert_eq!(sig_short(2.5e7, 4), "2.5e7");
        assert_eq!(sig_short(0.0, 4), "0");
    }

    #[test]
    fn sig_formats() {
        assert_eq!(sig(4.7299999, 3), "4.73");
        assert_eq!(sig(0.0521, 2), "0.052");
        assert_eq!(sig(127.0, 3), "127");
        assert_eq!(sig(1234.6, 3), "1235");
        assert_eq!(sig(1.5e-7, 2), "1.5e-7");
        assert_eq!(sig(f64::NAN, 2), "—");
        assert_eq!((sig(0.0, 3), sig(f64::NEG_INFINITY, 3)), ("0".into(), "−∞".into()));
    }

    /// Where the campaign form differs from the report's: zero, non-finite values.
    #[test]
    fn campaign_form() {
        assert_eq!(sig_campaign(1234.5678), "1234.57");
        assert_eq!(sig_campaign(0.012345), "0.0123450");
        assert_eq!(sig_campaign(2.5e7), "2.50000e7");
        assert_eq!(sig_campaign(0.0), "0.00000000");
        assert_eq!((sig_campaign(f64::NAN), sig_campaign(f64::INFINITY)), ("NaN".into(), "inf".into()));
    }
}
