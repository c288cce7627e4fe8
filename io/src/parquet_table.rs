//! Tables as Apache Parquet, for pandas, polars, DuckDB and Spark users: the
//! columns of the CSV a command writes, under the same names, with
//! - each column's unit in its Arrow field metadata (`unit`), so it survives
//!   into `pyarrow.Schema.field(name).metadata` and polars/DuckDB schemas;
//! - time as a timestamp column (UTC, nanoseconds), not seconds as text;
//! - text that repeats (interface, message, signal, unit) dictionary-encoded:
//!   pandas reads it as a categorical;
//! - the CSV's `#` comment lines as the file's key-value metadata
//!   (`acq.comments`).
//!
//! The same rows can go to an [`ArrowSink`] as Arrow record batches
//! instead ([`ParquetTable::to_arrow`]), as they are made: the Python
//! package hands them to pyarrow through the Arrow C data interface, the
//! table a file would have held, streamed.
//!
//! It streams, as the CSV path does. Rows go into Arrow builders; every
//! [`BATCH_ROWS`] rows (or a layout's own count) they become a record batch for
//! the Parquet writer, which writes a row group out once it holds about
//! [`ROW_GROUP_CELLS`] cells. So
//! memory is bounded by the table's width, never by its length. The encoded
//! bytes go through an [`Output`]: the file appears under its name only when
//! complete, like every file acq writes.
//!
//! Encodings are chosen per column type for sensor data: times are evenly
//! spaced or nearly so (delta encoding stores a few bits per row); float
//! values are split into byte streams (`BYTE_STREAM_SPLIT`), which lets zstd
//! compress the sign, exponent and upper mantissa bytes that vary slowly in a
//! physical signal and the all-zero low bytes of a float32 reading held as
//! f64.

use std::collections::HashMap;
use std::sync::Arc;

use arrow_array::builder::{
    BooleanBuilder, Float64Builder, Int64Builder, PrimitiveBuilder, StringDictionaryBuilder,
    TimestampMicrosecondBuilder, TimestampNanosecondBuilder,
};
use arrow_array::types::{ArrowPrimitiveType, Int32Type};
use arrow_array::{
    Array, ArrayRef, DictionaryArray, Int32Array, PrimitiveArray, RecordBatch, StringArray,
};
use arrow_schema::{DataType, Field, Schema, SchemaRef, TimeUnit};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, Encoding, ZstdLevel};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::schema::types::ColumnPath;

use crate::output::Output;
use crate::parquet_columns::ColumnWiseWriter;
use acq_error::{AcqError, Result};

pub use crate::arrow_sink::{ArrowBatch, ArrowSchema, ArrowSink};

/// Rows collected in the builders before they go to the Parquet writer.
pub const BATCH_ROWS: usize = 16 * 1024;
/// Cells (rows x columns) in a row group: about 32 MiB of f64 before encoding.
pub const ROW_GROUP_CELLS: usize = 4 * 1024 * 1024;
/// The key of the file metadata that holds the CSV's comment lines.
pub const COMMENTS_KEY: &str = "acq.comments";
/// The key of each column's unit in its Arrow field metadata.
pub const UNIT_KEY: &str = "unit";

/// How a table's file is laid out where callers differ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FileLayout {
    /// Rows per row group; `None`: about [`ROW_GROUP_CELLS`] cells. The
    /// writer holds a row group's encoded pages until it is complete, so a
    /// caller with many files open at once bounds its memory with this.
    pub rows_per_group: Option<usize>,
    /// Rows per data page at most; `None`: parquet's default (20,000).
    /// A page is encoded and compressed once full, so smaller pages spread
    /// that work over the writing instead of leaving it to a file's end.
    pub rows_per_page: Option<usize>,
    /// Rows per record batch; `None`: [`BATCH_ROWS`]. A table of many
    /// files open at once takes fewer: each file's builders are then small
    /// enough to be reused from the allocator's free lists batch after
    /// batch, where builders of 128 kB each came as fresh pages.
    pub rows_per_batch: Option<usize>,
    /// Float columns BYTE_STREAM_SPLIT (zstd then compresses noisy values
    /// better) rather than PLAIN. Apache Spark 4.0's Parquet reader refuses
    /// that encoding ("Unsupported encoding: BYTE_STREAM_SPLIT"); PLAIN is
    /// read by every engine.
    pub split_floats: bool,
    /// Time columns in microseconds, not nanoseconds: Spark's timestamps
    /// are microseconds and its reader refuses TIMESTAMP(NANOS). A CAN
    /// frame's stamp (SocketCAN, candump) is a whole microsecond anyway.
    pub time_in_microseconds: bool,
}

impl Default for FileLayout {
    fn default() -> Self {
        FileLayout {
            rows_per_group: None,
            rows_per_page: None,
            rows_per_batch: None,
            split_floats: true,
            time_in_microseconds: false,
        }
    }
}

impl FileLayout {
    /// Files every engine reads as they are, Spark included.
    pub const FOR_EVERY_ENGINE: FileLayout = FileLayout {
        rows_per_group: None,
        rows_per_page: None,
        rows_per_batch: None,
        split_floats: false,
        time_in_microseconds: true,
    };
}

/// The type of a column's values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColumnType {
    /// A UTC instant, nanoseconds since the Unix epoch.
    Time,
    Float,
    Integer,
    /// Text that repeats (dictionary-encoded).
    Text,
    Flag,
}

/// One column of a table.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ColumnSpec {
    pub name: String,
    pub column_type: ColumnType,
    pub unit: Option<String>,
    /// Whether a cell may be empty (null).
    pub nullable: bool,
    /// The text every row of a text column holds (a file's session, its
    /// source, a sensor's unit): set once instead of per row, and in a file
    /// encoded once per row group. The row's setter is then a bug.
    pub constant: Option<String>,
}

impl ColumnSpec {
    pub fn new(name: impl Into<String>, column_type: ColumnType) -> Self {
        ColumnSpec {
            name: name.into(),
            column_type,
            unit: None,
            nullable: false,
            constant: None,
        }
    }

    /// The column's unit (none for an empty string).
    pub fn unit(mut self, unit: &str) -> Self {
        self.unit = (!unit.is_empty()).then(|| unit.to_string());
        self
    }

    pub fn nullable(mut self) -> Self {
        self.nullable = true;
        self
    }

    /// A text column holding `value` in every row ([`ColumnSpec::constant`]).
    pub fn constant_text(name: impl Into<String>, value: &str) -> Self {
        ColumnSpec {
            constant: Some(value.to_string()),
            ..ColumnSpec::new(name, ColumnType::Text)
        }
    }

    fn field(&self, layout: &FileLayout) -> Field {
        let data_type = match self.column_type {
            ColumnType::Time if layout.time_in_microseconds => {
                DataType::Timestamp(TimeUnit::Microsecond, Some("UTC".into()))
            }
            ColumnType::Time => DataType::Timestamp(TimeUnit::Nanosecond, Some("UTC".into())),
            ColumnType::Float => DataType::Float64,
            ColumnType::Integer => DataType::Int64,
            ColumnType::Text => {
                DataType::Dictionary(Box::new(DataType::Int32), Box::new(DataType::Utf8))
            }
            ColumnType::Flag => DataType::Boolean,
        };
        let metadata: HashMap<String, String> = self
            .unit
            .iter()
            .map(|unit| (UNIT_KEY.to_string(), unit.clone()))
            .collect();
        Field::new(&self.name, data_type, self.nullable).with_metadata(metadata)
    }
}

enum ColumnBuilder {
    Time(TimestampNanosecondBuilder),
    /// A time column of a file in microseconds ([`FileLayout`]): given in
    /// nanoseconds, rounded down, so that the order is kept.
    TimeMicros(TimestampMicrosecondBuilder),
    Float(Float64Builder),
    Integer(Int64Builder),
    Text(StringDictionaryBuilder<Int32Type>),
    /// A text column with one value in every row
    /// ([`ColumnSpec::constant`]): its batch is the value once and a key
    /// per row, with no lookup per row. The keys are made (and checked)
    /// once, and each batch takes a slice of them.
    Constant {
        value: Arc<StringArray>,
        keys: Option<DictionaryArray<Int32Type>>,
    },
    /// A text column whose values come from a list fixed before the first
    /// row ([`ParquetTable::text_choices`]), each row naming one by its
    /// place in the list: no hashing and comparing of the text per row.
    Choice(ChoiceColumn),
    Flag(BooleanBuilder),
}

impl ColumnBuilder {
    fn new(spec: &ColumnSpec, layout: &FileLayout, batch_rows: usize) -> Self {
        if let Some(value) = &spec.constant {
            return ColumnBuilder::Constant {
                value: Arc::new(StringArray::from(vec![value.as_str()])),
                keys: None,
            };
        }
        match spec.column_type {
            ColumnType::Time if layout.time_in_microseconds => ColumnBuilder::TimeMicros(
                TimestampMicrosecondBuilder::with_capacity(batch_rows).with_timezone("UTC"),
            ),
            ColumnType::Time => ColumnBuilder::Time(
                TimestampNanosecondBuilder::with_capacity(batch_rows).with_timezone("UTC"),
            ),
            ColumnType::Float => ColumnBuilder::Float(Float64Builder::with_capacity(batch_rows)),
            ColumnType::Integer => ColumnBuilder::Integer(Int64Builder::with_capacity(batch_rows)),
            ColumnType::Text => ColumnBuilder::Text(StringDictionaryBuilder::new()),
            ColumnType::Flag => ColumnBuilder::Flag(BooleanBuilder::with_capacity(batch_rows)),
        }
    }

    fn finish(&mut self, rows: usize, batch_rows: usize) -> ArrayRef {
        // A finished builder starts again with no room: the next batch's
        // is reserved at once, not grown (and copied) to it in steps.
        match self {
            ColumnBuilder::Time(b) => Arc::new(finish_and_reserve(b, batch_rows)),
            ColumnBuilder::TimeMicros(b) => Arc::new(finish_and_reserve(b, batch_rows)),
            ColumnBuilder::Float(b) => Arc::new(finish_and_reserve(b, batch_rows)),
            ColumnBuilder::Integer(b) => Arc::new(finish_and_reserve(b, batch_rows)),
            ColumnBuilder::Text(b) => Arc::new(b.finish()),
            ColumnBuilder::Constant { value, keys } => {
                let keys = match keys {
                    Some(keys) if keys.len() >= rows => keys,
                    _ => keys.insert(DictionaryArray::<Int32Type>::new(
                        Int32Array::from(vec![0; rows.max(batch_rows)]),
                        value.clone(),
                    )),
                };
                Arc::new(keys.slice(0, rows))
            }
            ColumnBuilder::Choice(column) => Arc::new(column.finish()),
            ColumnBuilder::Flag(b) => Arc::new(b.finish()),
        }
    }
}

/// The builder's array; room for a batch of `batch_rows` in it afterwards.
fn finish_and_reserve<T: ArrowPrimitiveType>(
    builder: &mut PrimitiveBuilder<T>,
    batch_rows: usize,
) -> PrimitiveArray<T> {
    let array = builder.finish();
    *builder =
        PrimitiveBuilder::with_capacity(batch_rows).with_data_type(array.data_type().clone());
    array
}

/// The batch being built of a [`ColumnBuilder::Choice`] column. Its
/// dictionary holds the choices the batch used, in the order of their
/// first use, as arrow's dictionary builder makes it: the arrays are the
/// same, only the lookups are gone.
struct ChoiceColumn {
    choices: Vec<String>,
    /// Per choice, the first choice of the same text: a dictionary holds
    /// each text once, as the dictionary builder's does.
    first_alike: Vec<usize>,
    /// Per choice, its key in the batch being built (`-1`: not used yet).
    key_of_choice: Vec<i32>,
    /// The choices in the batch's dictionary, in key order.
    used: Vec<usize>,
    keys: Vec<i32>,
}

impl ChoiceColumn {
    #[inline]
    fn append(&mut self, choice: usize) {
        let choice = self.first_alike[choice];
        let mut key = self.key_of_choice[choice];
        if key < 0 {
            key = self.used.len() as i32;
            self.key_of_choice[choice] = key;
            self.used.push(choice);
        }
        self.keys.push(key);
    }

    fn add(&mut self, text: &str) -> usize {
        let index = self.choices.len();
        let first = self.choices.iter().position(|c| c == text);
        self.first_alike.push(first.unwrap_or(index));
        self.key_of_choice.push(-1);
        self.choices.push(text.to_string());
        index
    }

    fn finish(&mut self) -> DictionaryArray<Int32Type> {
        let values = StringArray::from_iter_values(self.used.iter().map(|&c| &self.choices[c]));
        for &choice in &self.used {
            self.key_of_choice[choice] = -1;
        }
        self.used.clear();
        let keys = Int32Array::from(std::mem::replace(
            &mut self.keys,
            Vec::with_capacity(BATCH_ROWS),
        ));
        DictionaryArray::new(keys, Arc::new(values))
    }
}

/// A Parquet table being written, one row at a time: set each column of a
/// row with the method of its type, then [`ParquetTable::end_row`].
///
/// Calling a column's setter with the wrong type is a bug in the caller
/// (the columns are fixed by code, never by input) and panics.
pub struct ParquetTable {
    destination: Destination,
    schema: SchemaRef,
    columns: Vec<ColumnBuilder>,
    rows_in_batch: usize,
    /// Rows that make a record batch.
    batch_rows: usize,
    rows: u64,
    /// A failure met where it could not be returned ([`ParquetTable::end_row_in_callback`]).
    failed: Option<AcqError>,
}

/// Where the record batches go.
enum Destination {
    /// Encoded as Parquet into a file.
    File { writer: FileWriter, output: Output },
    /// Handed over as they are made, for a caller that takes Arrow itself.
    Arrow(Box<dyn ArrowSink>),
    /// Encoded as Parquet into a file on a thread of its own
    /// ([`ParquetTable::encoding_beside`]).
    Encoder(EncoderThread),
}

/// The thread that encodes a table's batches, and the way to it. Dropped
/// unfinished (its maker failed), it closes the way and waits for the
/// thread to drop the incomplete file: nothing is left behind when the
/// process ends right after.
struct EncoderThread {
    /// `None` once closed.
    batches: Option<std::sync::mpsc::SyncSender<ToEncoder>>,
    /// `None` once joined, or when it could not start.
    thread: Option<std::thread::JoinHandle<Result<()>>>,
    name: String,
}

impl EncoderThread {
    fn send(&mut self, batch: RecordBatch) -> Result<()> {
        match &self.batches {
            Some(batches) if batches.send(ToEncoder::Batch(batch)).is_ok() => Ok(()),
            _ => Err(self.failure()),
        }
    }

    /// Tells the thread to complete the file, and waits until it has.
    fn finish(&mut self) -> Result<()> {
        if let Some(batches) = self.batches.take() {
            let _ = batches.send(ToEncoder::Finish);
        }
        match self.thread.take().map(std::thread::JoinHandle::join) {
            Some(Ok(finished)) => finished,
            Some(Err(_)) | None => Err(self.failure()),
        }
    }

    /// Why the thread stopped taking batches: its own error.
    fn failure(&mut self) -> AcqError {
        self.batches = None;
        match self.thread.take().map(std::thread::JoinHandle::join) {
            Some(Ok(Err(error))) => error,
            _ => AcqError::Malformed(format!("{}: the Parquet encoder stopped", self.name)),
        }
    }
}

impl Drop for EncoderThread {
    fn drop(&mut self) {
        self.batches = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// What the encoding thread is given.
enum ToEncoder {
    Batch(RecordBatch),
    /// The last batch was sent: write the footer, complete the file.
    Finish,
}

/// Batches made ahead of the encoding thread at most.
const BATCHES_IN_FLIGHT: usize = 2;

/// The encoding thread: batches into the file until told to finish it. A
/// table dropped unfinished (its maker failed) closes the channel
/// instead, and the file is left incomplete, so it never appears.
fn encode(
    batches: std::sync::mpsc::Receiver<ToEncoder>,
    mut writer: FileWriter,
    mut output: Output,
) -> Result<()> {
    for message in batches {
        match message {
            ToEncoder::Batch(batch) => {
                writer
                    .write(&batch)
                    .map_err(|e| parquet_error(&output, e))?;
                pass_on_encoded(&mut writer, &mut output)?;
            }
            ToEncoder::Finish => {
                writer.finish().map_err(|e| parquet_error(&output, e))?;
                pass_on_encoded(&mut writer, &mut output)?;
                return output.finish();
            }
        }
    }
    Ok(())
}

impl Destination {
    fn name(&self) -> &str {
        match self {
            Destination::File { output, .. } => output.name(),
            Destination::Arrow(_) => "the Arrow table",
            Destination::Encoder(encoder) => &encoder.name,
        }
    }
}

fn schema_of(columns: &[ColumnSpec], layout: &FileLayout) -> SchemaRef {
    Arc::new(Schema::new(
        columns.iter().map(|c| c.field(layout)).collect::<Vec<_>>(),
    ))
}

impl ParquetTable {
    /// A table whose batches go to `sink` (the same columns, units and
    /// types as the file), its schema first; `comments` (the CSV's `#`
    /// lines) in the schema's metadata, where pyarrow also puts a file's.
    pub fn to_arrow(
        columns: &[ColumnSpec],
        comments: &[String],
        mut sink: Box<dyn ArrowSink>,
    ) -> Result<Self> {
        let mut schema = schema_of(columns, &FileLayout::default());
        if !comments.is_empty() {
            let metadata = HashMap::from([(COMMENTS_KEY.to_string(), comments.join("\n"))]);
            schema = Arc::new(schema.as_ref().clone().with_metadata(metadata));
        }
        sink.schema(schema.clone())?;
        Ok(ParquetTable {
            destination: Destination::Arrow(sink),
            schema,
            columns: columns
                .iter()
                .map(|c| ColumnBuilder::new(c, &FileLayout::default(), BATCH_ROWS))
                .collect(),
            rows_in_batch: 0,
            batch_rows: BATCH_ROWS,
            rows: 0,
            failed: None,
        })
    }

    /// Starts a table in `output` with these columns; `comments` are the
    /// CSV's `#` lines (file metadata).
    pub fn new(output: Output, columns: &[ColumnSpec], comments: &[String]) -> Result<Self> {
        Self::with_layout(output, columns, comments, FileLayout::default())
    }

    /// [`ParquetTable::new`] with the row groups and float encoding of
    /// `layout`.
    pub fn with_layout(
        output: Output,
        columns: &[ColumnSpec],
        comments: &[String],
        layout: FileLayout,
    ) -> Result<Self> {
        let rows_per_group = layout
            .rows_per_group
            .unwrap_or_else(|| (ROW_GROUP_CELLS / columns.len().max(1)).clamp(BATCH_ROWS, 1 << 20));
        let batch_rows = layout.rows_per_batch.unwrap_or(BATCH_ROWS).max(1);
        let schema = schema_of(columns, &layout);
        let mut properties = WriterProperties::builder()
            .set_compression(Compression::ZSTD(ZstdLevel::default()))
            .set_max_row_group_row_count(Some(rows_per_group))
            .set_data_page_row_count_limit(
                layout
                    .rows_per_page
                    .unwrap_or(parquet::file::properties::DEFAULT_DATA_PAGE_ROW_COUNT_LIMIT),
            )
            .set_created_by(format!("acq {}", env!("CARGO_PKG_VERSION")));
        if !comments.is_empty() {
            properties = properties.set_key_value_metadata(Some(vec![KeyValue::new(
                COMMENTS_KEY.to_string(),
                comments.join("\n"),
            )]));
        }
        for column in columns {
            let path = ColumnPath::from(column.name.as_str());
            // Not compressed: a time column, whose bit-packed deltas are
            // nearly all noise (a logger's jitter: zstd took a tenth of its
            // time on them and saved 5 % of the column); and a constant
            // column, whose pages are one run of one dictionary key, a few
            // bytes, where a column's compressor held two zstd contexts
            // (about 350 kB allocated) for nothing.
            if column.column_type == ColumnType::Time || column.constant.is_some() {
                properties =
                    properties.set_column_compression(path.clone(), Compression::UNCOMPRESSED);
            }
            let encoding = match column.column_type {
                ColumnType::Time | ColumnType::Integer => Encoding::DELTA_BINARY_PACKED,
                ColumnType::Float if layout.split_floats => Encoding::BYTE_STREAM_SPLIT,
                ColumnType::Float => Encoding::PLAIN,
                ColumnType::Text | ColumnType::Flag => continue,
            };
            properties = properties
                .set_column_dictionary_enabled(path.clone(), false)
                .set_column_encoding(path, encoding);
        }
        let writer = ArrowWriter::try_new(Vec::new(), schema.clone(), Some(properties.build()))
            .map_err(|e| parquet_error(&output, e))?;
        let constants: Vec<Option<Arc<str>>> = columns
            .iter()
            .map(|c| c.constant.as_deref().map(Arc::from))
            .collect();
        let writer = if constants.iter().any(Option::is_some) {
            let by_column =
                ColumnWiseWriter::new(writer, schema.clone(), constants, rows_per_group)
                    .map_err(|e| parquet_error(&output, e))?;
            FileWriter::ByColumn(Box::new(by_column))
        } else {
            FileWriter::ByRow(Box::new(writer))
        };
        Ok(ParquetTable {
            destination: Destination::File { writer, output },
            columns: columns
                .iter()
                .map(|c| ColumnBuilder::new(c, &layout, batch_rows))
                .collect(),
            schema,
            rows_in_batch: 0,
            batch_rows,
            rows: 0,
            failed: None,
        })
    }

    /// Rows written so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// The same file, its batches encoded on a thread of its own while the
    /// caller makes the next (Parquet's encoding and zstd are about half
    /// of a decode to Parquet). For a table written alone: each table so
    /// made has its thread. A table that is not a file is as it was.
    pub fn encoding_beside(self) -> Self {
        let destination = match self.destination {
            Destination::File { writer, output } => {
                let name = output.name().to_string();
                let (batches, to_encode) = std::sync::mpsc::sync_channel(BATCHES_IN_FLIGHT);
                // A thread that cannot start drops the file unwritten: the
                // first batch then fails, saying so.
                let thread = std::thread::Builder::new()
                    .name("parquet-encoder".into())
                    .spawn(move || encode(to_encode, writer, output))
                    .ok();
                Destination::Encoder(EncoderThread {
                    batches: Some(batches),
                    thread,
                    name,
                })
            }
            other => other,
        };
        ParquetTable {
            destination,
            ..self
        }
    }

    #[inline]
    pub fn time_ns(&mut self, column: usize, time_ns: i64) {
        match &mut self.columns[column] {
            ColumnBuilder::Time(b) => b.append_value(time_ns),
            ColumnBuilder::TimeMicros(b) => b.append_value(time_ns.div_euclid(1000)),
            _ => self.wrong_type(column, "a time"),
        }
    }

    /// Many rows' times at once, for [`ParquetTable::end_rows`]: one
    /// column type's dispatch for all of them, not one per row.
    pub fn times_ns(&mut self, column: usize, times_ns: impl IntoIterator<Item = i64>) {
        match &mut self.columns[column] {
            // Extended as a whole (reserved once), not appended row by row.
            ColumnBuilder::Time(b) => b.extend_from_iter_option(times_ns.into_iter().map(Some)),
            ColumnBuilder::TimeMicros(b) => {
                b.extend_from_iter_option(times_ns.into_iter().map(|t| Some(t.div_euclid(1000))));
            }
            _ => self.wrong_type(column, "a time"),
        }
    }

    /// Many rows' values at once, for [`ParquetTable::end_rows`].
    pub fn floats(&mut self, column: usize, values: impl IntoIterator<Item = Option<f64>>) {
        match &mut self.columns[column] {
            ColumnBuilder::Float(b) => b.extend_from_iter_option(values),
            _ => self.wrong_type(column, "a float"),
        }
    }

    #[inline]
    pub fn float(&mut self, column: usize, value: Option<f64>) {
        match &mut self.columns[column] {
            ColumnBuilder::Float(b) => b.append_option(value),
            _ => self.wrong_type(column, "a float"),
        }
    }

    #[inline]
    pub fn integer(&mut self, column: usize, value: Option<i64>) {
        match &mut self.columns[column] {
            ColumnBuilder::Integer(b) => b.append_option(value),
            _ => self.wrong_type(column, "an integer"),
        }
    }

    #[inline]
    pub fn text(&mut self, column: usize, value: Option<&str>) {
        match &mut self.columns[column] {
            ColumnBuilder::Text(b) => b.append_option(value),
            _ => self.wrong_type(column, "text"),
        }
    }

    /// Fixes the values a text column can take, before the first row
    /// (a DBC's message and signal names and units); each row then gives
    /// one by its place in `choices` ([`ParquetTable::choice`]), and its
    /// per-row text setter is a bug. The column reads as any text column.
    pub fn text_choices(&mut self, column: usize, choices: Vec<String>) {
        match &self.columns[column] {
            ColumnBuilder::Text(_) | ColumnBuilder::Choice(_) => {
                let mut first_of_text: HashMap<&str, usize> = HashMap::new();
                let first_alike = choices
                    .iter()
                    .enumerate()
                    .map(|(k, text)| *first_of_text.entry(text).or_insert(k))
                    .collect();
                self.columns[column] = ColumnBuilder::Choice(ChoiceColumn {
                    first_alike,
                    key_of_choice: vec![-1; choices.len()],
                    choices,
                    used: Vec::new(),
                    keys: Vec::with_capacity(BATCH_ROWS),
                });
            }
            _ => self.wrong_type(column, "text"),
        }
    }

    /// Adds a value to a column of [`ParquetTable::text_choices`] (one its
    /// list did not foresee: an interface's name, a J1939 frame's own id)
    /// and returns its place, for [`ParquetTable::choice`] from then on.
    pub fn add_choice(&mut self, column: usize, text: &str) -> usize {
        match &mut self.columns[column] {
            ColumnBuilder::Choice(c) => c.add(text),
            _ => self.wrong_type(column, "a column of choices"),
        }
    }

    /// The row's value of a column of [`ParquetTable::text_choices`]: the
    /// choice at `index` in its list.
    #[inline]
    pub fn choice(&mut self, column: usize, index: usize) {
        match &mut self.columns[column] {
            ColumnBuilder::Choice(c) => c.append(index),
            _ => self.wrong_type(column, "a column of choices"),
        }
    }

    #[inline]
    pub fn flag(&mut self, column: usize, value: bool) {
        match &mut self.columns[column] {
            ColumnBuilder::Flag(b) => b.append_value(value),
            _ => self.wrong_type(column, "a flag"),
        }
    }

    #[cold]
    fn wrong_type(&self, column: usize, what: &str) -> ! {
        panic!(
            "bug: column {} ({}) of {} is not {what}",
            column,
            self.schema.field(column).name(),
            self.destination.name()
        )
    }

    /// Ends the row: every column must have had its value set.
    #[inline]
    pub fn end_row(&mut self) -> Result<()> {
        self.rows += 1;
        self.rows_in_batch += 1;
        if self.rows_in_batch >= self.batch_rows {
            self.write_batch()?;
        }
        Ok(())
    }

    /// Ends `rows` rows whose columns were each set at once
    /// ([`ParquetTable::times_ns`], [`ParquetTable::floats`]); a batch may
    /// then hold more than a batch's rows.
    pub fn end_rows(&mut self, rows: usize) -> Result<()> {
        self.rows += rows as u64;
        self.rows_in_batch += rows;
        if self.rows_in_batch >= self.batch_rows {
            self.write_batch()?;
        }
        Ok(())
    }

    /// [`ParquetTable::end_row`] where an error cannot be returned (in a
    /// decoder's callback): a failure is kept for [`ParquetTable::check`].
    #[inline]
    pub fn end_row_in_callback(&mut self) {
        if let Err(error) = self.end_row() {
            self.failed.get_or_insert(error);
        }
    }

    /// The first failure of [`ParquetTable::end_row_in_callback`] since the last check.
    pub fn check(&mut self) -> Result<()> {
        self.failed.take().map_or(Ok(()), Err)
    }

    fn write_batch(&mut self) -> Result<()> {
        if self.rows_in_batch == 0 {
            return Ok(());
        }
        let rows = self.rows_in_batch;
        let arrays: Vec<ArrayRef> = self
            .columns
            .iter_mut()
            .map(|column| column.finish(rows, self.batch_rows))
            .collect();
        self.rows_in_batch = 0;
        let batch = RecordBatch::try_new(self.schema.clone(), arrays)
            .map_err(|e| AcqError::Malformed(format!("{}: {e}", self.destination.name())))?;
        match &mut self.destination {
            Destination::File { writer, output } => {
                writer.write(&batch).map_err(|e| parquet_error(output, e))?;
                pass_on_encoded(writer, output)
            }
            Destination::Arrow(sink) => sink.batch(batch),
            Destination::Encoder(encoder) => encoder.send(batch),
        }
    }

    /// Writes the last rows and the footer, and completes the file (an
    /// Arrow table: hands over its last batch).
    pub fn finish(mut self) -> Result<u64> {
        self.check()?;
        self.write_batch()?;
        match self.destination {
            Destination::File {
                mut writer,
                mut output,
            } => {
                writer.finish().map_err(|e| parquet_error(&output, e))?;
                pass_on_encoded(&mut writer, &mut output)?;
                output.finish()?;
            }
            Destination::Encoder(mut encoder) => encoder.finish()?,
            Destination::Arrow(_) => {}
        }
        Ok(self.rows)
    }
}

/// A file's Parquet writer: Arrow's, or one a column at a time where some
/// columns are constant ([`ColumnWiseWriter`]).
enum FileWriter {
    ByRow(Box<ArrowWriter<Vec<u8>>>),
    ByColumn(Box<ColumnWiseWriter>),
}

impl FileWriter {
    fn write(&mut self, batch: &RecordBatch) -> parquet::errors::Result<()> {
        match self {
            FileWriter::ByRow(writer) => writer.write(batch),
            FileWriter::ByColumn(writer) => writer.write(batch),
        }
    }

    fn finish(&mut self) -> parquet::errors::Result<()> {
        match self {
            FileWriter::ByRow(writer) => writer.finish().map(|_| ()),
            FileWriter::ByColumn(writer) => writer.finish(),
        }
    }

    fn inner_mut(&mut self) -> &mut Vec<u8> {
        match self {
            FileWriter::ByRow(writer) => writer.inner_mut(),
            FileWriter::ByColumn(writer) => writer.inner_mut(),
        }
    }
}

/// Moves what the Parquet writer has encoded into the output, in order.
fn pass_on_encoded(writer: &mut FileWriter, output: &mut Output) -> Result<()> {
    let encoded = writer.inner_mut();
    if encoded.is_empty() {
        return Ok(());
    }
    output.take_from(encoded)
}

fn parquet_error(output: &Output, error: parquet::errors::ParquetError) -> AcqError {
    AcqError::io(
        format!("writing Parquet {}", output.name()),
        std::io::Error::other(error),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
    use parquet::file::reader::{FileReader, SerializedFileReader};

    /// The batches of an Arrow table, kept.
    struct Batches(std::sync::Arc<std::sync::Mutex<Vec<RecordBatch>>>);

    impl ArrowSink for Batches {
        fn schema(&mut self, _: SchemaRef) -> Result<()> {
            Ok(())
        }
        fn batch(&mut self, batch: RecordBatch) -> Result<()> {
            self.0.lock().unwrap().push(batch);
            Ok(())
        }
    }

    fn table_choices(table: &ParquetTable) -> usize {
        match &table.columns[0] {
            ColumnBuilder::Choice(c) => c.choices.len(),
            _ => 0,
        }
    }

    #[test]
    fn a_column_of_choices_makes_the_dictionary_builders_arrays() {
        // Choices in an order that is not their list's, some never used, one
        // repeated in the list (once added late), over more rows than a
        // batch holds.
        let choices: Vec<String> = ["bar", "kN", "", "mm", "unused", "bar", "late"]
            .iter()
            .map(|c| c.to_string())
            .collect();
        let picks: Vec<usize> = (0..BATCH_ROWS * 2 + 77)
            .map(|row| {
                let early = [3, 0, 2, 1, 0, 3][(row * row + row / 5) % 6];
                // The late ones from the second batch on.
                match (row > BATCH_ROWS + 5, row % 11) {
                    (true, 0) => 5,
                    (true, 1) => 6,
                    _ => early,
                }
            })
            .collect();
        let tables = [true, false].map(|by_choice| {
            let kept = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
            let columns = [ColumnSpec::new("unit", ColumnType::Text)];
            let mut table =
                ParquetTable::to_arrow(&columns, &[], Box::new(Batches(kept.clone()))).unwrap();
            // The last two choices come in late, as an interface's name
            // does: added on their first use.
            let foreseen = choices.len() - 2;
            if by_choice {
                table.text_choices(0, choices[..foreseen].to_vec());
            }
            for &pick in &picks {
                if by_choice {
                    if pick >= foreseen && table_choices(&table) <= pick {
                        for late in &choices[table_choices(&table)..=pick] {
                            table.add_choice(0, late);
                        }
                    }
                    table.choice(0, pick);
                } else {
                    table.text(0, Some(&choices[pick]));
                }
                table.end_row().unwrap();
            }
            table.finish().unwrap();
            let batches = kept.lock().unwrap().clone();
            batches
        });
        assert_eq!(tables[0].len(), 3);
        for (by_choice, by_text) in tables[0].iter().zip(&tables[1]) {
            let dictionary = |batch: &RecordBatch| {
                let column = batch.column(0).as_any();
                let array = column.downcast_ref::<DictionaryArray<Int32Type>>().unwrap();
                (array.keys().clone(), array.values().to_data())
            };
            assert_eq!(dictionary(by_choice), dictionary(by_text));
        }
    }

    #[test]
    fn a_table_encoded_beside_is_the_same_file_and_none_unless_finished() {
        let dir = tempfile::tempdir().unwrap();
        let columns = [
            ColumnSpec::new("time_s", ColumnType::Time),
            ColumnSpec::new("signal", ColumnType::Text),
            ColumnSpec::new("value", ColumnType::Float).nullable(),
        ];
        let write = |name: &str, beside: bool, rows: usize, finish: bool| {
            let path = dir.path().join(name);
            let output = Output::create_complete_only(&path).unwrap();
            let mut table = ParquetTable::new(output, &columns, &["c".into()]).unwrap();
            if beside {
                table = table.encoding_beside();
            }
            for row in 0..rows {
                table.time_ns(0, 1_700_000_000_000_000_000 + row as i64 * 1_000_000);
                table.text(1, Some(["SG01", "SG02", "Force"][row % 3]));
                table.float(2, (row % 5 != 0).then_some(row as f64 / 7.0));
                table.end_row().unwrap();
            }
            if finish {
                assert_eq!(table.finish().unwrap(), rows as u64);
            }
            path
        };
        // Several batches and a short last one.
        let rows = 3 * BATCH_ROWS + 17;
        let here = std::fs::read(write("here.parquet", false, rows, true)).unwrap();
        let beside = std::fs::read(write("beside.parquet", true, rows, true)).unwrap();
        assert!(here.len() > 10_000);
        assert!(here == beside, "the files differ");
        assert!(!write("dropped.parquet", true, rows, false).exists());
        let empty = std::fs::read(write("empty.parquet", true, 0, true)).unwrap();
        assert_eq!(
            empty,
            std::fs::read(write("empty-here.parquet", false, 0, true)).unwrap()
        );
    }

    #[test]
    fn a_long_table_is_written_in_row_groups_and_reads_back_equal() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.parquet");
        // 128 float columns: a row group holds ROW_GROUP_CELLS / 129 rows.
        let mut columns = vec![ColumnSpec::new("time_s", ColumnType::Time)];
        columns.extend((0..128).map(|k| {
            ColumnSpec::new(format!("c{k} [bar]"), ColumnType::Float)
                .unit("bar")
                .nullable()
        }));
        let rows = 70_000u64;
        let value =
            |row: u64, k: usize| (row % 7 != k as u64 % 7).then_some(row as f64 * 0.5 + k as f64);
        let output = Output::create_complete_only(&path).unwrap();
        let mut table = ParquetTable::new(output, &columns, &["session x".into()]).unwrap();
        for row in 0..rows {
            table.time_ns(0, 1_000_000_000 + row as i64 * 10_000_000);
            for k in 0..128 {
                table.float(1 + k, value(row, k));
            }
            table.end_row().unwrap();
        }
        assert!(!path.exists(), "the file appears only when complete");
        assert_eq!(table.finish().unwrap(), rows);

        let reader = SerializedFileReader::new(std::fs::File::open(&path).unwrap()).unwrap();
        let metadata = reader.metadata();
        assert!(
            metadata.num_row_groups() >= 2,
            "{}",
            metadata.num_row_groups()
        );
        let comments = metadata
            .file_metadata()
            .key_value_metadata()
            .unwrap()
            .iter()
            .find(|kv| kv.key == COMMENTS_KEY)
            .and_then(|kv| kv.value.clone());
        assert_eq!(comments.as_deref(), Some("session x"));

        let builder =
            ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(&path).unwrap()).unwrap();
        let schema = builder.schema().clone();
        assert_eq!(
            schema.field(5).metadata().get(UNIT_KEY).map(String::as_str),
            Some("bar")
        );
        let mut row = 0u64;
        for batch in builder.build().unwrap() {
            let batch = batch.unwrap();
            let times = batch
                .column(0)
                .as_any()
                .downcast_ref::<arrow_array::TimestampNanosecondArray>()
                .unwrap();
            let c5 = batch
                .column(6)
                .as_any()
                .downcast_ref::<arrow_array::Float64Array>()
                .unwrap();
            for i in 0..batch.num_rows() {
                assert_eq!(times.value(i), 1_000_000_000 + row as i64 * 10_000_000);
                let got = (!arrow_array::Array::is_null(c5, i)).then(|| c5.value(i));
                assert_eq!(got, value(row, 5), "row {row}");
                row += 1;
            }
        }
        assert_eq!(row, rows);
    }
}
