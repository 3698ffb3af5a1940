//! `timeseries.parquet`: a run's time series as a typed, compressed, columnar file that
//! pyarrow, pandas and polars read as they are (docs/outputs.md).
//!
//! Every column is a REQUIRED DOUBLE named as the CSV header (NaN and the infinities are
//! stored as themselves); the file's key-value metadata holds the column units
//! ([`crate::recorder::columns::unit`]) and the run's metadata ([`RunMetadata`]). Written
//! with the low-level column writer (no Arrow: a small build): the rows are buffered into
//! a row group of at most [`ROW_GROUP_MAX_BYTES`] of values (and [`ROW_GROUP_MAX_ROWS`]
//! rows), which is written out when full, so memory does not grow with the run's length.
//! Values are BYTE_STREAM_SPLIT-encoded (the bytes of each significance together) and
//! compressed with LZ4_RAW, no dictionary, no statistics: within 5 % of zstd's size for
//! ~3/4 of its instructions, a pure-Rust codec (measured in docs/outputs.md).

use crate::recorder::series::TimeSeries;
use anyhow::{Context, Result, bail};
use bytes::Bytes;
pub use parquet::basic::{Compression, Encoding, ZstdLevel};
use parquet::basic::{EncodingMask, Repetition, Type as PhysicalType};
use parquet::column::page::{CompressedPage, Page, PageWriter};
use parquet::column::writer::ColumnCloseResult;
use parquet::data_type::DoubleType;
use parquet::file::metadata::{ColumnChunkMetaData, KeyValue};
use parquet::file::properties::{EnabledStatistics, WriterProperties};
use parquet::file::reader::{FileReader, RowGroupReader};
use parquet::file::serialized_reader::SerializedFileReader;
use parquet::file::writer::{SerializedFileWriter, SerializedPageWriter, TrackedWrite};
use parquet::schema::types::{ColumnDescPtr, Type};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;
use std::sync::Arc;

/// Version of the layout of `timeseries.parquet` (schema and metadata keys), stored in the
/// file as `format_version`.
pub const FORMAT_VERSION: u32 = 1;
/// Most bytes of values buffered before a row group is written (8 bytes per value).
pub const ROW_GROUP_MAX_BYTES: usize = 8 << 20;
/// Most rows of a row group.
pub const ROW_GROUP_MAX_ROWS: usize = 1 << 20;

/// How the values are compressed and encoded. [`ParquetOptions::default`] is the choice of
/// docs/outputs.md (LZ4_RAW, BYTE_STREAM_SPLIT); the build enables only that codec, the
/// others are for `benches/outputs.rs` (with `--features parquet/zstd,parquet/snap`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParquetOptions {
    pub compression: Compression,
    pub encoding: Encoding,
}

impl Default for ParquetOptions {
    fn default() -> Self {
        Self { compression: Compression::LZ4_RAW, encoding: Encoding::BYTE_STREAM_SPLIT }
    }
}

/// The inertial frame of every inertial-axes column (`inertial_frame` in the metadata;
/// docs/guidance.md, "Frames").
pub const INERTIAL_FRAME: &str = "the simulator's ECI: Earth-centred, z along the Earth's spin axis, x the mean \
    equinox of date, turning into the Earth-fixed frame by GMST (IAU 1982) of UT1; TEME for TLE (SGP4) orbits; \
    of date, not J2000 (precession and nutation are not modelled)";

/// What the file says about the run besides its columns (key-value metadata).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunMetadata {
    /// `name` of the scenario.
    pub scenario: String,
    /// The scenario file as given on the command line (empty when not from a file).
    pub scenario_path: String,
    /// `sensors.seed`.
    pub seed: u64,
    /// The scenario file's text (empty when not from a file).
    pub scenario_toml: String,
}

impl RunMetadata {
    /// The key-value pairs of the file: `units` (JSON object column → unit), `scenario`,
    /// `scenario_path`, `seed`, `scenario_toml`, `protocol_version` (of the link),
    /// `format_version` ([`FORMAT_VERSION`]) and `inertial_frame` ([`INERTIAL_FRAME`]).
    pub fn key_values(&self, columns: &[String]) -> Result<Vec<(String, String)>> {
        let units: serde_json::Map<String, serde_json::Value> =
            columns.iter().map(|c| (c.clone(), crate::recorder::columns::unit(c).unwrap_or("").into())).collect();
        Ok(vec![
            ("units".into(), serde_json::to_string(&units)?),
            ("scenario".into(), self.scenario.clone()),
            ("scenario_path".into(), self.scenario_path.clone()),
            ("seed".into(), self.seed.to_string()),
            ("scenario_toml".into(), self.scenario_toml.clone()),
            ("protocol_version".into(), acs_flight::link::PROTOCOL_VERSION.to_string()),
            ("format_version".into(), FORMAT_VERSION.to_string()),
            ("inertial_frame".into(), INERTIAL_FRAME.into()),
        ])
    }
}

/// Rows of one row group for `columns` columns (see [`ROW_GROUP_MAX_BYTES`]).
pub fn rows_per_group(columns: usize) -> usize {
    (ROW_GROUP_MAX_BYTES / (8 * columns.max(1))).clamp(1, ROW_GROUP_MAX_ROWS)
}

/// The writer settings.
fn properties(o: ParquetOptions, rows: usize, key_values: Vec<(String, String)>) -> Result<WriterProperties> {
    Ok(WriterProperties::builder()
        .set_compression(o.compression)
        .set_encoding(o.encoding)
        .set_dictionary_enabled(false)
        // No min/max statistics: ~10 instructions a value, and a time series is read whole.
        .set_statistics_enabled(EnabledStatistics::None)
        .set_max_row_group_row_count(Some(rows))
        .set_created_by(format!("sim-host {} (parquet-rs)", env!("CARGO_PKG_VERSION")))
        .set_key_value_metadata(Some(key_values.into_iter().map(|(k, v)| KeyValue::new(k, v)).collect()))
        .build())
}

/// Values of one data page (1 MiB of doubles, parquet-rs's default page size).
const PAGE_VALUES: usize = 1 << 17;

/// Streams rows into a Parquet file, one row group per [`rows_per_group`] rows.
///
/// With the default options (LZ4_RAW, BYTE_STREAM_SPLIT; also UNCOMPRESSED and PLAIN) the
/// pages are encoded here rather than by parquet-rs's column writer, which costs ~90
/// instructions a value (a copy into its buffer, a zeroed buffer and a byte-at-a-time
/// split per page, a zeroed compression buffer): each column of the group is split straight
/// out of the row buffer 8 values at a time ([`split_streams`]), compressed with lz4_flex
/// (the codec parquet-rs itself uses for LZ4_RAW), written as a v1 data page through
/// parquet-rs's page writer into one buffer for the group, and the column chunks are
/// appended to the file (`append_column`) with their metadata. Other codecs (the bench's
/// zstd, snappy) go through the column writer.
pub struct ParquetStream<W: Write + Send> {
    writer: SerializedFileWriter<W>,
    options: ParquetOptions,
    /// The rows of the row group being filled, one after the other (a row is one copy:
    /// cheaper than a push per column).
    rows: Vec<f64>,
    /// One column of the group, gathered from `rows` when the group is written (the column
    /// writer's path) or one page of it encoded (the direct path).
    column: Vec<f64>,
    page: Vec<u8>,
    columns: usize,
    rows_per_group: usize,
}

impl<W: Write + Send> ParquetStream<W> {
    /// Starts the file: `names` become the REQUIRED DOUBLE columns, `key_values` the file's
    /// key-value metadata.
    pub fn new(sink: W, names: &[String], key_values: Vec<(String, String)>) -> Result<Self> {
        Self::with_options(sink, names, key_values, ParquetOptions::default())
    }

    /// [`ParquetStream::new`] with another codec or encoding.
    pub fn with_options(
        sink: W,
        names: &[String],
        key_values: Vec<(String, String)>,
        options: ParquetOptions,
    ) -> Result<Self> {
        let fields = names
            .iter()
            .map(|n| {
                Type::primitive_type_builder(n, PhysicalType::DOUBLE)
                    .with_repetition(Repetition::REQUIRED)
                    .build()
                    .map(Arc::new)
            })
            .collect::<parquet::errors::Result<Vec<_>>>()?;
        let schema = Arc::new(Type::group_type_builder("timeseries").with_fields(fields).build()?);
        let rows = rows_per_group(names.len());
        let writer = SerializedFileWriter::new(sink, schema, Arc::new(properties(options, rows, key_values)?))?;
        Ok(Self {
            writer,
            options,
            rows: Vec::with_capacity(rows * names.len()),
            column: Vec::new(),
            page: Vec::new(),
            columns: names.len(),
            rows_per_group: rows,
        })
    }

    /// Rows buffered in the row group being filled (always fewer than [`rows_per_group`]).
    pub fn buffered_rows(&self) -> usize {
        self.rows.len().checked_div(self.columns).unwrap_or(0)
    }

    /// Bytes buffered between rows: at most [`ROW_GROUP_MAX_BYTES`] for the group being
    /// filled plus one column of it (the page buffer). While a group is written its encoded
    /// column chunks are held too (freed after).
    pub fn buffered_capacity_bytes(&self) -> usize {
        8 * (self.rows.capacity() + self.column.capacity()) + self.page.capacity()
    }

    /// Buffers one row (one value per column), writing the row group out when it is full.
    pub fn push_row(&mut self, row: &[f64]) -> Result<()> {
        if row.len() != self.columns {
            bail!("a row of {} values for {} columns", row.len(), self.columns);
        }
        self.rows.extend_from_slice(row);
        if self.buffered_rows() >= self.rows_per_group {
            self.write_group()?;
        }
        Ok(())
    }

    fn direct(&self) -> bool {
        matches!(self.options.compression, Compression::LZ4_RAW | Compression::UNCOMPRESSED)
            && matches!(self.options.encoding, Encoding::BYTE_STREAM_SPLIT | Encoding::PLAIN)
    }

    fn write_group(&mut self) -> Result<()> {
        if self.buffered_rows() == 0 {
            return Ok(());
        }
        if self.direct() {
            self.write_group_direct()?
        } else {
            self.write_group_column_writer()?
        }
        self.rows.clear();
        Ok(())
    }

    /// The column writer's path (any codec and encoding parquet-rs has).
    fn write_group_column_writer(&mut self) -> Result<()> {
        let mut group = self.writer.next_row_group()?;
        let mut index = 0..self.columns;
        while let Some(mut column) = group.next_column()? {
            let c = index.next().context("more columns in the schema than buffered")?;
            self.column.clear();
            self.column.extend(self.rows.iter().skip(c).step_by(self.columns));
            column.typed::<DoubleType>().write_batch(&self.column, None, None)?;
            column.close()?;
        }
        group.close()?;
        Ok(())
    }

    /// The direct path: every column chunk of the group encoded into `chunks`, then
    /// appended to the file.
    fn write_group_direct(&mut self) -> Result<()> {
        let rows = self.buffered_rows();
        let descr = self.writer.schema_descr().columns().to_vec();
        let mut chunks = Vec::new();
        let mut closed = Vec::with_capacity(self.columns);
        {
            let mut sink = TrackedWrite::new(&mut chunks);
            for (c, d) in descr.into_iter().enumerate() {
                closed.push(self.encode_column(c, rows, d, &mut sink)?);
            }
            sink.flush()?;
        }
        let chunks = Bytes::from(chunks);
        let mut group = self.writer.next_row_group()?;
        for close in closed {
            group.append_column(&chunks, close)?;
        }
        group.close()?;
        Ok(())
    }

    /// Column `c` of the buffered group as one column chunk (pages of [`PAGE_VALUES`]).
    fn encode_column(
        &mut self,
        c: usize,
        rows: usize,
        descr: ColumnDescPtr,
        sink: &mut TrackedWrite<&mut Vec<u8>>,
    ) -> Result<ColumnCloseResult> {
        let start = sink.bytes_written();
        let mut pages = SerializedPageWriter::new(sink);
        let (mut compressed, mut uncompressed) = (0, 0);
        for first in (0..rows).step_by(PAGE_VALUES) {
            let n = PAGE_VALUES.min(rows - first);
            let values = &self.rows[first * self.columns..(first + n) * self.columns];
            match self.options.encoding {
                Encoding::BYTE_STREAM_SPLIT => split_streams(values, self.columns, c, &mut self.page),
                _ => {
                    self.page.clear();
                    self.page.extend(values.iter().skip(c).step_by(self.columns).flat_map(|x| x.to_le_bytes()));
                }
            }
            let buf = match self.options.compression {
                Compression::LZ4_RAW => lz4_flex::block::compress(&self.page),
                _ => self.page.clone(),
            };
            let page = Page::DataPage {
                buf: Bytes::from(buf),
                num_values: u32::try_from(n)?,
                encoding: self.options.encoding,
                def_level_encoding: Encoding::RLE,
                rep_level_encoding: Encoding::RLE,
                statistics: None,
            };
            let spec = pages.write_page(CompressedPage::new(page, self.page.len()))?;
            compressed += spec.compressed_size;
            uncompressed += spec.uncompressed_size;
        }
        let metadata = ColumnChunkMetaData::builder(descr)
            .set_compression(self.options.compression)
            .set_encodings_mask(EncodingMask::new_from_encodings([Encoding::RLE, self.options.encoding].iter()))
            .set_total_compressed_size(i64::try_from(compressed)?)
            .set_total_uncompressed_size(i64::try_from(uncompressed)?)
            .set_num_values(i64::try_from(rows)?)
            .set_data_page_offset(i64::try_from(start)?)
            .build()?;
        Ok(ColumnCloseResult {
            bytes_written: compressed as u64,
            rows_written: rows as u64,
            metadata,
            bloom_filter: None,
            column_index: None,
            offset_index: None,
        })
    }

    /// Writes the last row group and the footer; returns the sink (flushed).
    pub fn finish(mut self) -> Result<W> {
        self.write_group()?;
        Ok(self.writer.into_inner()?)
    }
}

/// Column `c` of the row-major `rows` (`columns` values a row) BYTE_STREAM_SPLIT into
/// `out` (its previous content replaced): byte 0 (least significant) of every value, then
/// byte 1, ..., byte 7. Eight values at a time: their 8 × 8 bytes transposed in three
/// swaps of 4-, 2- and 1-byte blocks (SWAR), each stream's 8 bytes stored as one word.
/// `out` is only resized, not cleared: every byte is overwritten, and the columns of a row
/// group have the same length, so it is zeroed once per group size, not once per column.
pub fn split_streams(rows: &[f64], columns: usize, c: usize, out: &mut Vec<u8>) {
    let n = rows.len() / columns;
    out.resize(8 * n, 0);
    let whole = n - n % 8;
    let blocks = rows.chunks_exact(8 * columns);
    let tail = blocks.remainder();
    {
        // The eight streams, each walked 8 bytes at a time (zipped: no index, no bounds
        // check in the loop).
        let mut s = out.chunks_exact_mut(n.max(1)).map(|s| s[..whole].chunks_exact_mut(8));
        let mut next = || s.next().unwrap_or_else(|| <&mut [u8]>::default().chunks_exact_mut(8));
        let (s0, s1, s2, s3, s4, s5, s6, s7) = (next(), next(), next(), next(), next(), next(), next(), next());
        let dst = s0.zip(s1).zip(s2).zip(s3).zip(s4).zip(s5).zip(s6).zip(s7);
        for (block, (((((((d0, d1), d2), d3), d4), d5), d6), d7)) in blocks.zip(dst) {
            let w = transpose_bytes(std::array::from_fn(|i| block[i * columns + c].to_bits()));
            for (d, w) in [d0, d1, d2, d3, d4, d5, d6, d7].into_iter().zip(w) {
                d.copy_from_slice(&w.to_le_bytes());
            }
        }
    }
    for (r, v) in tail.iter().skip(c).step_by(columns).enumerate() {
        for (j, b) in v.to_bits().to_le_bytes().into_iter().enumerate() {
            out[j * n + whole + r] = b;
        }
    }
}

/// The 8 × 8 byte matrix `a` (word i, byte j) transposed (word j, byte i): the off-diagonal
/// 4 × 4 blocks swapped, then the 2 × 2 blocks within them, then the single bytes.
fn transpose_bytes(a: [u64; 8]) -> [u64; 8] {
    let [mut a0, mut a1, mut a2, mut a3, mut a4, mut a5, mut a6, mut a7] = a;
    fn swap(x: &mut u64, y: &mut u64, shift: u32, mask: u64) {
        let t = ((*x >> shift) ^ *y) & mask;
        *x ^= t << shift;
        *y ^= t;
    }
    const M32: u64 = 0x0000_0000_FFFF_FFFF;
    const M16: u64 = 0x0000_FFFF_0000_FFFF;
    const M8: u64 = 0x00FF_00FF_00FF_00FF;
    swap(&mut a0, &mut a4, 32, M32);
    swap(&mut a1, &mut a5, 32, M32);
    swap(&mut a2, &mut a6, 32, M32);
    swap(&mut a3, &mut a7, 32, M32);
    swap(&mut a0, &mut a2, 16, M16);
    swap(&mut a1, &mut a3, 16, M16);
    swap(&mut a4, &mut a6, 16, M16);
    swap(&mut a5, &mut a7, 16, M16);
    swap(&mut a0, &mut a1, 8, M8);
    swap(&mut a2, &mut a3, 8, M8);
    swap(&mut a4, &mut a5, 8, M8);
    swap(&mut a6, &mut a7, 8, M8);
    [a0, a1, a2, a3, a4, a5, a6, a7]
}

/// Reads a `timeseries.parquet` (every column a REQUIRED DOUBLE): the columns and the
/// file's key-value metadata.
pub fn read_parquet(path: &Path) -> Result<(TimeSeries, BTreeMap<String, String>)> {
    let file = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    read_parquet_from(file).with_context(|| format!("reading {}", path.display()))
}

fn read_parquet_from(file: std::fs::File) -> Result<(TimeSeries, BTreeMap<String, String>)> {
    let reader = SerializedFileReader::new(file)?;
    let meta = reader.metadata().file_metadata();
    let key_values = meta.key_value_metadata().map_or_else(BTreeMap::new, |kv| {
        kv.iter().map(|k| (k.key.clone(), k.value.clone().unwrap_or_default())).collect()
    });
    let schema = meta.schema_descr();
    for c in schema.columns() {
        if c.physical_type() != PhysicalType::DOUBLE || c.max_def_level() != 0 || c.max_rep_level() != 0 {
            bail!("column {} is not a REQUIRED DOUBLE", c.name());
        }
    }
    let names = schema.columns().iter().map(|c| c.name().to_owned()).collect();
    let rows = usize::try_from(meta.num_rows()).context("row count")?;
    let mut ts = TimeSeries::with_columns(names, rows);
    for g in 0..reader.num_row_groups() {
        read_group(reader.get_row_group(g)?.as_ref(), &mut ts)?;
    }
    Ok((ts, key_values))
}

fn read_group(group: &dyn RowGroupReader, ts: &mut TimeSeries) -> Result<()> {
    let rows = usize::try_from(group.metadata().num_rows()).context("row count")?;
    for (i, col) in ts.cols.iter_mut().enumerate() {
        let mut reader = parquet::column::reader::get_typed_column_reader::<DoubleType>(group.get_column_reader(i)?);
        let before = col.len();
        let (records, _, _) = reader.read_records(rows, None, None, col)?;
        if records != rows || col.len() != before + rows {
            bail!("column {i}: {records} values in a row group of {rows} rows");
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(n: usize) -> Vec<String> {
        (0..n).map(|i| format!("c{i}_s")).collect()
    }

    #[test]
    fn columns_and_metadata_read_back_bit_for_bit() {
        let names = names(3);
        let meta = RunMetadata { scenario: "x".into(), seed: 7, ..RunMetadata::default() };
        let mut w = ParquetStream::new(Vec::new(), &names, meta.key_values(&names).unwrap()).unwrap();
        let rows = [[0.0, f64::NAN, -0.0], [1e-310, f64::INFINITY, f64::NEG_INFINITY], [0.1, f64::MAX, -1.5]];
        for r in &rows {
            w.push_row(r).unwrap();
        }
        let bytes = w.finish().unwrap();
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.parquet");
        std::fs::write(&p, bytes).unwrap();
        let (ts, kv) = read_parquet(&p).unwrap();
        assert_eq!(ts.names, names);
        for (c, col) in ts.cols.iter().enumerate() {
            let expected: Vec<u64> = rows.iter().map(|r| r[c].to_bits()).collect();
            assert_eq!(col.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), expected);
        }
        assert_eq!(kv["scenario"], "x");
        assert_eq!(kv["seed"], "7");
        assert_eq!(kv["format_version"], FORMAT_VERSION.to_string());
        assert_eq!(kv["protocol_version"], acs_flight::link::PROTOCOL_VERSION.to_string());
        let units: BTreeMap<String, String> = serde_json::from_str(&kv["units"]).unwrap();
        assert_eq!(units["c0_s"], "s");
        assert!(w_rejects_a_short_row());
    }

    fn w_rejects_a_short_row() -> bool {
        let mut w = ParquetStream::new(Vec::new(), &names(2), Vec::new()).unwrap();
        w.push_row(&[1.0]).is_err()
    }

    /// Both encodings and both codecs of the direct page encoding read back bit for bit:
    /// random bit patterns, a row count not a multiple of 8, several row groups (the byte
    /// transpose's blocks and its tail).
    #[test]
    fn every_value_reads_back_whatever_the_encoding() {
        let mut x = 0x9E37_79B9_7F4A_7C15_u64;
        let mut random = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            f64::from_bits(x)
        };
        let cols = 600;
        let total = 2 * rows_per_group(cols) + 13;
        let rows: Vec<Vec<f64>> = (0..total).map(|_| (0..cols).map(|_| random()).collect()).collect();
        for compression in [Compression::LZ4_RAW, Compression::UNCOMPRESSED] {
            for encoding in [Encoding::BYTE_STREAM_SPLIT, Encoding::PLAIN] {
                let names = names(cols);
                let o = ParquetOptions { compression, encoding };
                let mut w = ParquetStream::with_options(Vec::new(), &names, Vec::new(), o).unwrap();
                for r in &rows {
                    w.push_row(r).unwrap();
                }
                let dir = tempfile::tempdir().unwrap();
                let p = dir.path().join("t.parquet");
                std::fs::write(&p, w.finish().unwrap()).unwrap();
                let (ts, _) = read_parquet(&p).unwrap();
                assert_eq!(ts.len(), total);
                for (c, col) in ts.cols.iter().enumerate() {
                    assert!(col.iter().zip(&rows).all(|(a, r)| a.to_bits() == r[c].to_bits()), "{o:?} column {c}");
                }
            }
        }
    }

    /// Memory does not grow with the run: the buffered rows never exceed one row group
    /// (≤ 8 MiB of values), and every full group is written out.
    #[test]
    fn the_buffer_is_bounded_by_one_row_group() {
        let cols = 400;
        let cap = rows_per_group(cols);
        assert!(cap * cols * 8 <= ROW_GROUP_MAX_BYTES && cap >= 1);
        let names = names(cols);
        let mut w = ParquetStream::new(Vec::new(), &names, Vec::new()).unwrap();
        let total = 2 * cap + cap / 3;
        let row: Vec<f64> = (0..cols).map(|i| i as f64).collect();
        for _ in 0..total {
            w.push_row(&row).unwrap();
            assert!(w.buffered_rows() < cap);
            assert!(w.buffered_capacity_bytes() <= ROW_GROUP_MAX_BYTES + 8 * cap);
        }
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.parquet");
        std::fs::write(&p, w.finish().unwrap()).unwrap();
        let reader = SerializedFileReader::new(std::fs::File::open(&p).unwrap()).unwrap();
        assert_eq!(reader.num_row_groups(), 3);
        let (ts, _) = read_parquet(&p).unwrap();
        assert_eq!(ts.len(), total);
        assert!(ts.cols.iter().zip(&row).all(|(c, x)| c.iter().all(|y| y == x)));
    }
}
