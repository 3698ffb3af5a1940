//! `timeseries.csv`: the text format of a run's time series, written and read back.
//!
//! A value is written as exactly the text of Rust's `Display` for `f64` (`format!("{x}")`:
//! the shortest digits that read back to the same bits, always positional — never an
//! exponent —, `-0` for negative zero, integers without `.0`); NaN and the infinities are
//! an empty field. `Display` spent ~3/4 of a fully recorded run's instructions, so the
//! digits come from `zmij` (Schubfach; faster than `ryu` here, docs/outputs.md) and are
//! laid out positionally by [`push_display`]; a test compares the two texts over
//! millions of random bit patterns and the edge cases.

use crate::recorder::series::TimeSeries;
use anyhow::{Context, Result, bail};
use std::io::Write;
use std::path::Path;

/// Most significant digits a shortest round-trip `f64` needs (17) plus headroom.
const MAX_DIGITS: usize = 32;

/// Appends to `out` the `Display` text of the finite `x` whose shortest round-trip text
/// (as `zmij` or `ryu` write it: optional `-`, digits with an optional `.`, optional
/// `e`/`E` exponent with an optional sign) is `shortest`.
pub fn push_display(out: &mut Vec<u8>, x: f64, shortest: &[u8]) {
    if may_tie(x) {
        return push_display_general(out, x, shortest);
    }
    let (negative, s) = match shortest.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, shortest),
    };
    // An exponent is at most a sign and three digits: its `e` is in the last five bytes.
    let tail = s.len().saturating_sub(5);
    match s[tail..].iter().rposition(|&b| b == b'e' || b == b'E').map(|i| tail + i) {
        // Positional already: only an integer's ".0" to drop.
        None => out.extend_from_slice(shortest.strip_suffix(b".0").unwrap_or(shortest)),
        Some(i) => {
            if !push_exponential(out, negative, &s[..i], parse_exponent(&s[i + 1..])) {
                push_display_general(out, x, shortest);
            }
        }
    }
}

/// The common exponential form `d[.ddd]e±X` (nonzero lead digit, no trailing zero) laid
/// out positionally; `false` (nothing written) for any other form.
fn push_exponential(out: &mut Vec<u8>, negative: bool, mantissa: &[u8], exp: i32) -> bool {
    let (lead, frac) = match mantissa {
        [d, b'.', frac @ ..] => (*d, frac),
        [d] => (*d, &[][..]),
        _ => return false,
    };
    if lead == b'0' || frac.last() == Some(&b'0') || frac.len() >= MAX_DIGITS {
        return false;
    }
    if negative {
        out.push(b'-');
    }
    if exp < 0 {
        out.extend_from_slice(b"0.");
        push_zeros(out, exp.unsigned_abs() as usize - 1);
        out.push(lead);
        out.extend_from_slice(frac);
    } else if (exp as usize) < frac.len() {
        let (int, rest) = frac.split_at(exp as usize);
        out.push(lead);
        out.extend_from_slice(int);
        out.push(b'.');
        out.extend_from_slice(rest);
    } else {
        out.push(lead);
        out.extend_from_slice(frac);
        push_zeros(out, exp as usize - frac.len());
    }
    true
}

/// Appends `n` zeros.
fn push_zeros(out: &mut Vec<u8>, n: usize) {
    const ZEROS: [u8; 64] = [b'0'; 64];
    let mut n = n;
    while n > 0 {
        let k = n.min(ZEROS.len());
        out.extend_from_slice(&ZEROS[..k]);
        n -= k;
    }
}

/// [`push_display`] for any shortest text: the digits laid out positionally.
fn push_display_general(out: &mut Vec<u8>, x: f64, shortest: &[u8]) {
    let (negative, s) = match shortest.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, shortest),
    };
    let (mantissa, exp) = match s.iter().position(|&b| b == b'e' || b == b'E') {
        Some(i) => (&s[..i], parse_exponent(&s[i + 1..])),
        None => (s, 0),
    };
    let mut digits = [0u8; MAX_DIGITS];
    let (mut n, mut int_len) = (0usize, None);
    for &b in mantissa {
        if b == b'.' {
            int_len = Some(n);
        } else if n < MAX_DIGITS {
            digits[n] = b;
            n += 1;
        }
    }
    // The decimal point sits after `point` digits of `digits[start..n]`.
    let mut point = int_len.unwrap_or(n) as i32 + exp;
    let mut start = 0;
    while start < n && digits[start] == b'0' {
        start += 1;
        point -= 1;
    }
    while n > start && digits[n - 1] == b'0' {
        n -= 1;
    }
    if n > start && is_tie_rounded_down(x, &digits[start..n], point - (n - start) as i32) {
        // `Display` takes the upper of two equally near shortest candidates.
        let mut i = n;
        while i > start && digits[i - 1] == b'9' {
            digits[i - 1] = b'0';
            i -= 1;
        }
        if i > start {
            digits[i - 1] += 1;
        } else {
            // All nines: 10…0 (only reachable in theory; `start` is 0 or past a zero).
            digits.copy_within(start..n, start + 1);
            digits[start] = b'1';
            n += 1;
            point += 1;
        }
        while n > start && digits[n - 1] == b'0' {
            n -= 1;
        }
    }
    if negative {
        out.push(b'-');
    }
    let digits = &digits[start..n];
    if digits.is_empty() {
        out.push(b'0');
    } else if point <= 0 {
        out.extend_from_slice(b"0.");
        out.resize(out.len() + point.unsigned_abs() as usize, b'0');
        out.extend_from_slice(digits);
    } else if (point as usize) < digits.len() {
        let (int, frac) = digits.split_at(point as usize);
        out.extend_from_slice(int);
        out.push(b'.');
        out.extend_from_slice(frac);
    } else {
        out.extend_from_slice(digits);
        out.resize(out.len() + (point as usize - digits.len()), b'0');
    }
}

/// Whether `digits` × 10^`exp10` (the shortest digits of `x`) is the lower of two shortest
/// candidates exactly equally near `x`. `zmij` and `ryu` break such a tie to the even
/// digit, `Display` upwards (e.g. 2⁻²⁵ = 2.98023223876953125e-8: zmij 2.9802322387695312e-8,
/// `Display` …313). A tie needs the exact decimal expansion of `x` to be the digits then a
/// 5: with `x` = m 2^e (m odd, e < 0) that is m 5^-e × 10^e, so at most 18 significant
/// digits: -e ≤ 27 and m 5^-e = 10 digits + 5.
fn is_tie_rounded_down(x: f64, digits: &[u8], exp10: i32) -> bool {
    let (m, e) = odd_significand(x);
    if !(-27..0).contains(&e) || exp10 != e + 1 || digits.len() > 18 {
        return false;
    }
    let exact = u128::from(m) * 5u128.pow(e.unsigned_abs());
    let shown = digits.iter().fold(0u128, |d, &c| d * 10 + u128::from(c - b'0'));
    exact == shown * 10 + 5
}

/// `x` = m 2^e with m odd (m = 0 for zero).
fn odd_significand(x: f64) -> (u64, i32) {
    let bits = x.to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let fraction = bits & ((1 << 52) - 1);
    let (m, e) = if biased == 0 { (fraction, -1074) } else { (fraction | (1 << 52), biased - 1075) };
    if m == 0 { (0, 0) } else { (m >> m.trailing_zeros(), e + m.trailing_zeros() as i32) }
}

/// Whether two shortest candidates of `x` can be equally near it (see
/// [`is_tie_rounded_down`]): rare, values with few significant bits.
fn may_tie(x: f64) -> bool {
    let (m, e) = odd_significand(x);
    m != 0 && (-27..0).contains(&e)
}

fn parse_exponent(s: &[u8]) -> i32 {
    let (negative, digits) = match s.split_first() {
        Some((b'-', rest)) => (true, rest),
        Some((b'+', rest)) => (false, rest),
        _ => (false, s),
    };
    let e = digits.iter().fold(0i32, |e, &d| e * 10 + i32::from(d - b'0'));
    if negative { -e } else { e }
}

/// Writes rows of `timeseries.csv` (see the module documentation for the number format).
#[derive(Default)]
pub struct CsvRows {
    line: Vec<u8>,
    shortest: zmij::Buffer,
}

impl CsvRows {
    /// Appends the CSV text of `x` to `out` (nothing for NaN and the infinities).
    fn push_value(&mut self, x: f64) {
        if x.is_finite() {
            push_display(&mut self.line, x, self.shortest.format_finite(x).as_bytes());
        }
    }

    /// Writes `row` as one CSV line (values separated by commas, `\n` at the end).
    pub fn write_row(&mut self, w: &mut impl Write, row: &[f64]) -> std::io::Result<()> {
        self.line.clear();
        for (i, x) in row.iter().enumerate() {
            if i > 0 {
                self.line.push(b',');
            }
            self.push_value(*x);
        }
        self.line.push(b'\n');
        w.write_all(&self.line)
    }
}

/// Writes `row` as one CSV line (values separated by commas, `\n` at the end).
pub fn write_csv_row(w: &mut impl Write, row: &[f64]) -> std::io::Result<()> {
    CsvRows::default().write_row(w, row)
}

impl TimeSeries {
    /// CSV with a header line; numbers as `Display` writes them, NaN as empty.
    pub fn write_csv(&self, w: &mut impl Write) -> std::io::Result<()> {
        writeln!(w, "{}", self.names.join(","))?;
        let (mut rows, mut row) = (CsvRows::default(), Vec::with_capacity(self.cols.len()));
        for r in 0..self.len() {
            row.clear();
            row.extend(self.cols.iter().map(|c| c[r]));
            rows.write_row(w, &row)?;
        }
        Ok(())
    }
}

/// Reads a `timeseries.csv` (header line, then one row per line; an empty field is NaN).
pub fn read_csv(path: &Path) -> Result<TimeSeries> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse_csv(&text).with_context(|| format!("reading {}", path.display()))
}

/// Parses the text of a `timeseries.csv` (see [`read_csv`]).
pub fn parse_csv(text: &str) -> Result<TimeSeries> {
    let mut lines = text.lines();
    let header = lines.next().context("no header line")?;
    let names: Vec<String> = header.split(',').map(str::to_owned).collect();
    let mut ts = TimeSeries::with_columns(names, 0);
    let mut row = Vec::with_capacity(ts.names.len());
    for (i, line) in lines.enumerate() {
        row.clear();
        for field in line.split(',') {
            row.push(if field.is_empty() {
                f64::NAN
            } else {
                field.parse::<f64>().with_context(|| format!("line {}: bad number {field:?}", i + 2))?
            });
        }
        if row.len() != ts.names.len() {
            bail!("line {}: {} fields, the header has {}", i + 2, row.len(), ts.names.len());
        }
        ts.push_row(&row);
    }
    Ok(ts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use acs_test_support::rng::SplitMix64;

    fn fast(x: f64) -> String {
        let mut out = Vec::new();
        CsvRows::default().write_row(&mut out, &[x]).unwrap();
        out.pop();
        String::from_utf8(out).unwrap()
    }

    fn via_ryu(x: f64) -> String {
        let mut out = Vec::new();
        push_display(&mut out, x, ryu::Buffer::new().format_finite(x).as_bytes());
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn csv_values_are_shortest_round_trip_and_nan_is_empty() {
        let mut out = Vec::new();
        write_csv_row(&mut out, &[0.1, -2.0, f64::NAN, 1e-7, f64::INFINITY, 3.0]).unwrap();
        assert_eq!(String::from_utf8(out).unwrap(), "0.1,-2,,0.0000001,,3\n");
    }

    fn edge_cases() -> Vec<f64> {
        let mut v = vec![
            0.0,
            -0.0,
            1e-7,
            1e21,
            1e22,
            1e23,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            f64::EPSILON,
            f64::from_bits(1),
            f64::from_bits(0x000f_ffff_ffff_ffff),
            5e-324,
            2.2250738585072014e-308,
            0.1,
            0.2 + 0.1,
            1.0 / 3.0,
            123456.789,
            9007199254740993.0,
        ];
        v.extend((0..=53).map(|k| 2f64.powi(k)));
        v.extend((0..=53).map(|k| 2f64.powi(k) - 1.0));
        v.extend((0..=53).map(|k| 2f64.powi(k) + 1.0));
        v.extend((-1074..=1023).map(|k| 2f64.powi(k)));
        v.extend((-323..=308).map(|k| format!("1e{k}").parse::<f64>().unwrap()));
        v.extend((-323..=308).map(|k| format!("9.999999999999999e{k}").parse::<f64>().unwrap()));
        v.extend((0..=1_000_000).step_by(997).map(f64::from));
        // Few significant bits times a negative power of two: where exact ties between two
        // shortest candidates are.
        for m in (1..4000u32).step_by(2) {
            v.extend((1..=40).map(|e| f64::from(m) * 2f64.powi(-e)));
        }
        v.extend(v.clone().iter().map(|x| -x));
        v.retain(|x| x.is_finite());
        v
    }

    #[test]
    fn the_fast_text_is_display_for_the_edge_cases() {
        for x in edge_cases() {
            assert_eq!(fast(x), format!("{x}"), "{x:e} ({:#x})", x.to_bits());
            assert_eq!(via_ryu(x), format!("{x}"), "ryu {x:e} ({:#x})", x.to_bits());
        }
    }

    /// The independent truth: `Display` itself, over millions of random bit patterns
    /// (every exponent, subnormals included) and of random values of the magnitudes runs
    /// record.
    #[test]
    fn the_fast_text_is_display_for_random_bit_patterns() {
        let mut rng = SplitMix64(0x2026_1126);
        let mut line = Vec::new();
        let mut rows = CsvRows::default();
        for i in 0..3_000_000u32 {
            let x = if i % 2 == 0 {
                f64::from_bits(rng.next_u64())
            } else {
                rng.normal() * 10f64.powi(rng.below(24) as i32 - 12)
            };
            line.clear();
            rows.write_row(&mut line, &[x]).unwrap();
            line.pop();
            let expected = if x.is_finite() { format!("{x}") } else { String::new() };
            assert_eq!(line, expected.as_bytes(), "{x:e} ({:#x})", x.to_bits());
            if i % 16 == 0 && x.is_finite() {
                assert_eq!(via_ryu(x), expected, "ryu {x:e} ({:#x})", x.to_bits());
            }
        }
    }

    #[test]
    fn csv_reads_back_to_the_same_bits() {
        let names = vec!["t_s".to_string(), "x".to_string()];
        let mut ts = TimeSeries::with_columns(names, 3);
        for row in [[0.0, f64::NAN], [0.1, -0.0], [1e-300, f64::MAX]] {
            ts.push_row(&row);
        }
        let mut text = Vec::new();
        ts.write_csv(&mut text).unwrap();
        let back = parse_csv(std::str::from_utf8(&text).unwrap()).unwrap();
        assert_eq!(back.names, ts.names);
        for (a, b) in back.cols.iter().zip(&ts.cols) {
            assert_eq!(
                a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                b.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
            );
        }
        assert!(parse_csv("a,b\n1\n").is_err());
        assert!(parse_csv("a\nx\n").is_err());
    }
}
