//! `cargo bench -p sim-core --bench outputs [-- NAME]`: size and cost of the time-series
//! file formats (docs/outputs.md) on the ideal-wheel slew of `benches/ideal-wheel-slew.toml`
//! (12,001 rows, every step recorded): CSV and Parquet with each codec and value encoding
//! compiled in. With NAME, writes only that format once (for `valgrind --tool=callgrind
//! --toggle-collect=*outputs*write_file*`).
//!
//! Not a test: it prints figures.

use sim_core::link::in_process::InProcess;
use sim_core::recorder::csv::{CsvRows, push_display};
use sim_core::recorder::parquet::{Compression, Encoding, ParquetOptions, ParquetStream, ZstdLevel};
use sim_core::recorder::series::TimeSeries;
use sim_core::runner;
use sim_core::scenario::Scenario;
use std::hint::black_box;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// How a CSV value is formatted: the `zmij` formatter of `CsvRows` (what runs write),
/// `ryu` then the same layout, or `Display` itself (before).
#[derive(Clone, Copy)]
enum CsvFloat {
    Zmij,
    Ryu,
    Display,
}

/// A format compared.
#[derive(Clone, Copy)]
enum Format {
    Csv(CsvFloat),
    Parquet(ParquetOptions),
}

/// The formats compared, by name.
fn formats() -> Vec<(String, Format)> {
    let mut v = vec![
        ("csv".to_string(), Format::Csv(CsvFloat::Zmij)),
        ("csv-ryu".to_string(), Format::Csv(CsvFloat::Ryu)),
        ("csv-display".to_string(), Format::Csv(CsvFloat::Display)),
    ];
    let codecs = [
        ("zstd1", Compression::ZSTD(ZstdLevel::try_new(1).expect("level"))),
        ("zstd3", Compression::ZSTD(ZstdLevel::try_new(3).expect("level"))),
        ("lz4raw", Compression::LZ4_RAW),
        ("snappy", Compression::SNAPPY),
        ("none", Compression::UNCOMPRESSED),
    ];
    for (c, compression) in codecs {
        for (e, encoding) in [("bss", Encoding::BYTE_STREAM_SPLIT), ("plain", Encoding::PLAIN)] {
            v.push((format!("parquet-{c}-{e}"), Format::Parquet(ParquetOptions { compression, encoding })));
        }
    }
    v
}

/// One CSV line with the values formatted by `ryu` or `Display`.
fn csv_line(out: &mut Vec<u8>, row: &[f64], how: CsvFloat, ryu: &mut ryu::Buffer) {
    for (i, x) in row.iter().enumerate() {
        if i > 0 {
            out.push(b',');
        }
        if x.is_finite() {
            match how {
                CsvFloat::Ryu => push_display(out, *x, ryu.format_finite(*x).as_bytes()),
                _ => {
                    let _ = write!(out, "{x}");
                }
            }
        }
    }
    out.push(b'\n');
}

/// Writes the whole series in one format into memory; the bytes.
#[inline(never)]
fn write_file(ts: &TimeSeries, format: Format) -> Option<Vec<u8>> {
    let mut row = Vec::with_capacity(ts.cols.len());
    match format {
        Format::Csv(how) => {
            let (mut out, mut rows, mut ryu) = (Vec::new(), CsvRows::default(), ryu::Buffer::new());
            for r in 0..ts.len() {
                row.clear();
                row.extend(ts.cols.iter().map(|c| c[r]));
                match how {
                    CsvFloat::Zmij => rows.write_row(&mut out, &row).ok()?,
                    _ => csv_line(&mut out, &row, how, &mut ryu),
                }
            }
            Some(out)
        }
        Format::Parquet(o) => {
            let mut w = ParquetStream::with_options(Vec::new(), &ts.names, Vec::new(), o).ok()?;
            for r in 0..ts.len() {
                row.clear();
                row.extend(ts.cols.iter().map(|c| c[r]));
                w.push_row(&row).ok()?;
            }
            w.finish().ok()
        }
    }
}

fn main() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/ideal-wheel-slew.toml");
    let sc = Scenario::load(&path).expect("scenario");
    let mut link = InProcess::new();
    let ts = runner::run(&sc, &mut link, false).expect("run").series;
    let only = std::env::args().nth(1).filter(|a| !a.starts_with('-'));
    let values = (ts.len() * ts.cols.len()) as f64;
    println!("{} rows x {} columns", ts.len(), ts.cols.len());
    for (name, format) in formats() {
        if only.as_ref().is_some_and(|o| *o != name) {
            continue;
        }
        let runs = if only.is_some() { 1 } else { 5 };
        let mut best = f64::INFINITY;
        let mut size = None;
        for _ in 0..runs {
            let t = Instant::now();
            size = black_box(write_file(&ts, format)).map(|b| b.len());
            best = best.min(t.elapsed().as_secs_f64());
        }
        match size {
            Some(bytes) => println!(
                "{name:<24} {bytes:>10} B {:>6.2} B/value {:>7.1} ns/value",
                bytes as f64 / values,
                best * 1e9 / values
            ),
            None => println!("{name:<24} (codec not compiled in)"),
        }
    }
}
