//! `acq decode`: logs -> one CSV (or Parquet) row per decoded value, or MF4
//! channel groups (a message or a sensor each): [`decode_dbc`] and
//! [`decode_rig`] write any of them, picked by the output's name.
//!
//! Two routes: through DBC files (every signal of every known message) and
//! through a rig (each sensor in its own protocol). Both stream: memory does
//! not grow with the log. The DBC route to CSV is the throughput-critical
//! one ([`dbc_csv`]).

use std::collections::HashMap;
use std::io::Write;

use acq_can::canopen::{HeartbeatEvent, NmtState};
use acq_can::dbc::{push_shortest_f64, DbcDatabase, FrameDecodeError, PhysicalValue};
use acq_can::log::mf4_signals::{Mf4SignalWriter, SignalChannel, SignalGroup};
use acq_can::LogRecord;
use acq_can::{CanId, FrameKind, IfaceName};
use acq_error::{AcqError, Result};
use acq_io::input::{
    for_each_batch_read_beside, for_each_record, BadLines, EmptyLogs, LogInput, ScanCounts,
};
use acq_io::output::{CompleteOnlyFile, Output, TableOutput};
use acq_io::parquet_table::{ArrowSink, ColumnSpec, ColumnType, ParquetTable};
use acq_rig::sensors::{FrameUse, SensorDecoder, SensorEvent};
use acq_rig::Rig;

mod dbc_csv;
pub use dbc_csv::decode_with_dbc;

/// The fixed header of the DBC route.
pub const DBC_HEADER: &str = "time_s,iface,can_id,message,signal,value,unit";

/// What a decode run saw; printed to stderr as the summary.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct DecodeSummary {
    pub scan: ScanCounts,
    /// Frames with at least one value written.
    pub decoded: u64,
    /// Data frames whose id no DBC (or sensor) knows.
    pub unknown: u64,
    /// Frames shorter than their message, or with an undefined multiplexer value.
    pub undecodable: u64,
    pub error_frames: u64,
    pub remote_frames: u64,
    pub rows: u64,
    /// What the devices said of themselves (CANopen heartbeats: a node's
    /// state changed, or it fell silent), in time order, for the user.
    pub notes: Vec<String>,
    /// Those of `notes` a user must act on: not a node's normal start-up
    /// (boot-up, pre-operational, operational) but a node stopped, fallen
    /// back from operational, or silent. Python warns of these alone.
    pub warnings: Vec<String>,
}

impl DecodeSummary {
    /// Frames and lines that could not be used.
    pub fn bad(&self) -> u64 {
        self.scan.malformed_lines + self.undecodable
    }

    /// `other`'s counts added to these (a piece of a log's).
    fn add_counts(&mut self, other: &DecodeSummary) {
        self.scan.frames += other.scan.frames;
        self.scan.malformed_lines += other.scan.malformed_lines;
        self.decoded += other.decoded;
        self.unknown += other.unknown;
        self.undecodable += other.undecodable;
        self.error_frames += other.error_frames;
        self.remote_frames += other.remote_frames;
        self.rows += other.rows;
    }
}

impl std::fmt::Display for DecodeSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "frames read {}, decoded {}, unknown {}, bad {} ({} malformed lines, {} frames not matching their message), error frames {}, remote frames {}; {} values written",
            self.scan.frames,
            self.decoded,
            self.unknown,
            self.bad(),
            self.scan.malformed_lines,
            self.undecodable,
            self.error_frames,
            self.remote_frames,
            self.rows
        )
    }
}

/// What a DBC sink writes of the frame a value came from.
#[derive(Clone, Copy, Debug)]
pub struct FrameAt<'a> {
    pub timestamp_ns: i64,
    /// The timestamp as the log wrote it; empty where the frames were read
    /// a batch at a time ([`DbcRows::WANTS_TEXT`] is then false).
    pub timestamp_text: &'a [u8],
    pub iface: IfaceName,
    pub id: CanId,
}

/// Where the DBC route's values go: CSV rows built from byte templates, a
/// Parquet table or MF4 channel groups. One frame's values, then
/// [`DbcRows::end_frame`].
pub trait DbcRows {
    /// Whether the sink writes the log's timestamp text (a CSV), so that
    /// the frames must be read record by record, not a batch at a time.
    const WANTS_TEXT: bool;
    fn value(
        &mut self,
        frame: FrameAt<'_>,
        message: usize,
        signal: usize,
        value: PhysicalValue,
        label: Option<&str>,
    );
    fn end_frame(&mut self) -> Result<()>;
    /// Whether [`DbcRows::value`] is given each value's label.
    fn wants_labels(&self) -> bool {
        false
    }
}

/// The DBC route's table as Parquet: the CSV's columns; `time_s` the
/// frame's UTC instant, `value` a float (an integer beyond 2^53 is rounded,
/// as in pandas), text columns dictionary-encoded.
pub struct DbcParquet {
    table: ParquetTable,
    /// Per message: its id; its `can_id` cell is the `can_id` column's
    /// choice of the same place.
    message_ids: Vec<CanId>,
    /// The `can_id` choices of frames matched by their PGN with an id of
    /// their own (J1939), and the `iface` choices, added as they come.
    other_ids: HashMap<CanId, usize>,
    ifaces: Vec<(IfaceName, usize)>,
    /// Per message: where its signals start in the `signal` and `unit`
    /// columns' choices (the database's signals, message by message).
    first_signal: Vec<usize>,
    labels: bool,
}

impl DbcParquet {
    pub fn create(output: Output, database: &DbcDatabase, labels: bool) -> Result<Self> {
        Self::with_table(database, labels, |columns| {
            ParquetTable::new(output, columns, &[]).map(ParquetTable::encoding_beside)
        })
    }

    /// The same table as Arrow record batches, handed to `sink`.
    pub fn to_arrow(
        database: &DbcDatabase,
        labels: bool,
        sink: Box<dyn ArrowSink>,
    ) -> Result<Self> {
        Self::with_table(database, labels, |columns| {
            ParquetTable::to_arrow(columns, &[], sink)
        })
    }

    fn with_table(
        database: &DbcDatabase,
        labels: bool,
        table: impl FnOnce(&[ColumnSpec]) -> Result<ParquetTable>,
    ) -> Result<Self> {
        let mut columns = vec![
            ColumnSpec::new("time_s", ColumnType::Time),
            ColumnSpec::new("iface", ColumnType::Text),
            ColumnSpec::new("can_id", ColumnType::Text),
            ColumnSpec::new("message", ColumnType::Text),
            ColumnSpec::new("signal", ColumnType::Text),
            ColumnSpec::new("value", ColumnType::Float),
            ColumnSpec::new("unit", ColumnType::Text),
        ];
        if labels {
            columns.push(ColumnSpec::new("label", ColumnType::Text).nullable());
        }
        let mut table = table(&columns)?;
        // The message, signal and unit of a row are the DBC's: given by
        // their place, not looked up by their text row by row.
        let messages = database.messages();
        table.text_choices(1, Vec::new());
        table.text_choices(2, messages.iter().map(|m| m.id.to_string()).collect());
        table.text_choices(3, messages.iter().map(|m| m.name.clone()).collect());
        let signals = || messages.iter().flat_map(|m| &m.signals);
        table.text_choices(4, signals().map(|s| s.name.clone()).collect());
        table.text_choices(6, signals().map(|s| s.unit.clone()).collect());
        Ok(DbcParquet {
            table,
            message_ids: messages.iter().map(|m| m.id).collect(),
            other_ids: HashMap::new(),
            ifaces: Vec::new(),
            first_signal: messages
                .iter()
                .scan(0, |first, m| {
                    let this = *first;
                    *first += m.signals.len();
                    Some(this)
                })
                .collect(),
            labels,
        })
    }

    /// Writes the footer; the file is complete.
    pub fn finish(self) -> Result<u64> {
        self.table.finish()
    }
}

impl DbcRows for DbcParquet {
    const WANTS_TEXT: bool = false;

    #[inline]
    fn value(
        &mut self,
        frame: FrameAt<'_>,
        message: usize,
        signal: usize,
        value: PhysicalValue,
        label: Option<&str>,
    ) {
        let signal_choice = self.first_signal[message] + signal;
        let table = &mut self.table;
        table.time_ns(0, frame.timestamp_ns);
        let iface = match self.ifaces.iter().find(|(name, _)| *name == frame.iface) {
            Some(&(_, choice)) => choice,
            None => {
                let choice = table.add_choice(1, frame.iface.as_str());
                self.ifaces.push((frame.iface, choice));
                choice
            }
        };
        table.choice(1, iface);
        // A J1939 frame matched by its PGN keeps its own id: its source
        // address tells two ECUs that send one PGN apart.
        if frame.id == self.message_ids[message] {
            table.choice(2, message);
        } else {
            let choice = *self
                .other_ids
                .entry(frame.id)
                .or_insert_with(|| table.add_choice(2, &frame.id.to_string()));
            table.choice(2, choice);
        }
        table.choice(3, message);
        table.choice(4, signal_choice);
        table.float(5, Some(value.as_f64()));
        table.choice(6, signal_choice);
        if self.labels {
            table.text(7, label);
        }
        table.end_row_in_callback();
    }

    #[inline]
    fn end_frame(&mut self) -> Result<()> {
        self.table.check()
    }

    fn wants_labels(&self) -> bool {
        self.labels
    }
}

/// The DBC route's values as MF4: a channel group per message (its
/// signals, with units), a record per decoded frame, a signal the frame
/// did not carry (another multiplexer page) invalid. Frames of one id on
/// several interfaces share the message's group. A J1939 message's group
/// has one more channel, [`SOURCE_ADDRESS_CHANNEL`]: matched by PGN, its
/// frames come from any source address, and two ECUs sending one PGN stay
/// apart by it.
pub struct DbcMf4 {
    writer: Option<Mf4SignalWriter<CompleteOnlyFile>>,
    name: String,
    /// The message of the frame being decoded, its time and values.
    pending: Option<(usize, i64)>,
    values: Vec<Option<f64>>,
    /// Each message's channels (its signals, then a J1939 message's source
    /// address).
    channel_counts: Vec<usize>,
    j1939: Vec<bool>,
}

/// The channel of a J1939 message's group that holds each frame's source
/// address (the id's low byte).
pub const SOURCE_ADDRESS_CHANNEL: &str = "source_address";

impl DbcMf4 {
    pub fn create(file: CompleteOnlyFile, name: &str, database: &DbcDatabase) -> Result<Self> {
        let groups: Vec<SignalGroup> = database
            .messages()
            .iter()
            .map(|m| SignalGroup {
                name: m.name.clone(),
                channels: m
                    .signals
                    .iter()
                    .map(|s| SignalChannel {
                        name: s.name.clone(),
                        unit: s.unit.clone(),
                    })
                    .chain(m.j1939_pgn.map(|_| SignalChannel {
                        name: SOURCE_ADDRESS_CHANNEL.into(),
                        unit: String::new(),
                    }))
                    .collect(),
            })
            .collect();
        Ok(DbcMf4 {
            channel_counts: groups.iter().map(|g| g.channels.len()).collect(),
            writer: Some(mf4_writer(file, name, groups)?),
            name: name.to_string(),
            pending: None,
            values: Vec::new(),
            j1939: database
                .messages()
                .iter()
                .map(|m| m.j1939_pgn.is_some())
                .collect(),
        })
    }

    /// Patches lengths and counts; the file is complete.
    pub fn finish(mut self) -> Result<()> {
        finish_mf4(self.writer.take(), &self.name)
    }
}

impl DbcRows for DbcMf4 {
    const WANTS_TEXT: bool = false;

    #[inline]
    fn value(
        &mut self,
        frame: FrameAt<'_>,
        message: usize,
        signal: usize,
        value: PhysicalValue,
        _label: Option<&str>,
    ) {
        if self.pending.is_none() {
            self.pending = Some((message, frame.timestamp_ns));
            self.values.clear();
            self.values.resize(self.channel_counts[message], None);
            if self.j1939[message] {
                let source_address = frame.id.raw() & 0xFF;
                self.values[self.channel_counts[message] - 1] = Some(f64::from(source_address));
            }
        }
        self.values[signal] = Some(value.as_f64());
    }

    #[inline]
    fn end_frame(&mut self) -> Result<()> {
        match (self.pending.take(), self.writer.as_mut()) {
            (Some((message, time_ns)), Some(writer)) => writer
                .write(message, time_ns, &self.values)
                .map_err(|e| AcqError::io(format!("writing {}", self.name), e)),
            _ => Ok(()),
        }
    }
}

fn mf4_writer(
    file: CompleteOnlyFile,
    name: &str,
    groups: Vec<SignalGroup>,
) -> Result<Mf4SignalWriter<CompleteOnlyFile>> {
    Mf4SignalWriter::new(file, groups, Some("decoded by acq".into()))
        .map_err(|e| AcqError::Config(format!("{name}: {e}")))
}

fn finish_mf4(writer: Option<Mf4SignalWriter<CompleteOnlyFile>>, name: &str) -> Result<()> {
    match writer {
        Some(writer) => writer
            .finish()
            .map_err(|e| AcqError::io(format!("writing {name}"), e))?
            .finish(),
        None => Ok(()),
    }
}

/// Options of the DBC route.
#[derive(Clone, Copy, Debug)]
pub struct DbcDecodeOptions {
    pub bad_lines: BadLines,
    /// Append a `label` column with the value-table label.
    pub labels: bool,
}

/// Decodes every frame of `inputs` through `database` into `sink` (CSV
/// rows, a [`DbcParquet`] or a [`DbcMf4`]; finish it also after an error:
/// what was decoded is kept, as in a CSV). A sink that does not write the
/// log's text is given the frames a batch at a time, read on a thread of
/// their own where a second core is free.
pub fn decode_dbc_frames<S: DbcRows>(
    inputs: &mut [LogInput],
    database: &DbcDatabase,
    options: DbcDecodeOptions,
    sink: &mut S,
) -> Result<DecodeSummary> {
    let mut summary = DecodeSummary::default();
    let mut scan = ScanCounts::default();
    if S::WANTS_TEXT {
        for_each_record(
            inputs,
            options.bad_lines,
            EmptyLogs::Refuse,
            &mut scan,
            |_, record| decode_record(database, &mut summary, sink, record),
        )?;
    } else {
        for_each_batch_read_beside(
            inputs,
            options.bad_lines,
            EmptyLogs::Refuse,
            &mut scan,
            |_, batch| {
                for index in 0..batch.len() {
                    let at = FrameAt {
                        timestamp_ns: batch.timestamp_ns[index],
                        timestamp_text: b"",
                        iface: batch.interfaces[usize::from(batch.interface[index])],
                        id: batch.id[index],
                    };
                    let payload = batch.payload(index);
                    decode_frame(database, &mut summary, sink, at, batch.kind[index], payload)?;
                }
                Ok(())
            },
        )?;
    }
    summary.scan = scan;
    Ok(summary)
}

/// A log record's values into `sink` (its timestamp's text with them),
/// counted in `summary`.
#[inline]
pub(crate) fn decode_record(
    database: &DbcDatabase,
    summary: &mut DecodeSummary,
    sink: &mut impl DbcRows,
    record: &LogRecord<'_>,
) -> Result<()> {
    let frame = &record.frame;
    let at = FrameAt {
        timestamp_ns: frame.timestamp_ns,
        timestamp_text: record.timestamp_text,
        iface: frame.iface,
        id: frame.id,
    };
    decode_frame(database, summary, sink, at, frame.kind, frame.payload())
}

/// One frame's values into `sink`, counted in `summary`.
#[inline]
pub(crate) fn decode_frame(
    database: &DbcDatabase,
    summary: &mut DecodeSummary,
    sink: &mut impl DbcRows,
    at: FrameAt<'_>,
    kind: FrameKind,
    payload: &[u8],
) -> Result<()> {
    match kind {
        FrameKind::Error { .. } => summary.error_frames += 1,
        FrameKind::Remote { .. } => summary.remote_frames += 1,
        FrameKind::Data { .. } | FrameKind::Fd { .. } => {
            let Some(index) = database.message_index(at.id) else {
                summary.unknown += 1;
                return Ok(());
            };
            let message = &database.messages()[index];
            let mut written = 0u64;
            let result = message.decode(payload, |signal, value| {
                let label = if sink.wants_labels() {
                    message.signals[signal].label(payload)
                } else {
                    None
                };
                sink.value(at, index, signal, value, label);
                written += 1;
            });
            match result {
                Ok(()) => {
                    summary.decoded += 1;
                    summary.rows += written;
                }
                // Refused before anything was written.
                Err(
                    FrameDecodeError::Short { .. } | FrameDecodeError::UnknownMultiplexerValue(_),
                ) => {
                    summary.undecodable += 1;
                }
            }
            sink.end_frame()?;
        }
    }
    Ok(())
}

/// Decodes every frame of `inputs` through `database` into `output`: CSV
/// rows, a Parquet table or MF4 channel groups (`name` titles them). What
/// was decoded before a bad line stopped the run is written out first.
pub fn decode_dbc(
    inputs: &mut [LogInput],
    database: &DbcDatabase,
    options: DbcDecodeOptions,
    output: TableOutput,
    name: &str,
) -> Result<DecodeSummary> {
    match output {
        TableOutput::Csv(mut output) => {
            let summary = decode_with_dbc(inputs, database, options, &mut output);
            let streamed = output.name() == "<stdout>";
            written(summary, name, streamed, || output.finish())
        }
        TableOutput::Parquet(output) => {
            let mut sink = DbcParquet::create(output, database, options.labels)?;
            let summary = decode_dbc_frames(inputs, database, options, &mut sink);
            written(summary, name, false, || sink.finish().map(drop))
        }
        TableOutput::Arrow(arrow) => {
            let mut sink = DbcParquet::to_arrow(database, options.labels, arrow)?;
            let summary = decode_dbc_frames(inputs, database, options, &mut sink);
            // Streamed: the rows before an error went out; the error is as is.
            written(summary, name, true, || sink.finish().map(drop))
        }
        TableOutput::Mf4(file) => {
            let mut sink = DbcMf4::create(file, name, database)?;
            let summary = decode_dbc_frames(inputs, database, options, &mut sink);
            written(summary, name, false, || sink.finish())
        }
    }
}

/// The decode's summary once its output is finished. A decode that
/// stopped leaves no file under the output's name (a derived file appears
/// only when complete; the unfinished output is dropped with its
/// `.partial`); on stdout the rows before the error have streamed.
fn written(
    summary: Result<DecodeSummary>,
    name: &str,
    streamed: bool,
    finish: impl FnOnce() -> Result<()>,
) -> Result<DecodeSummary> {
    match summary {
        Ok(summary) => finish().map(|()| summary),
        Err(error) if streamed => {
            let _ = finish();
            Err(error)
        }
        Err(AcqError::Malformed(message)) => Err(AcqError::Malformed(format!(
            "{message}; {name} is not written (--skip-bad decodes past bad lines and counts them)"
        ))),
        Err(error) => Err(error),
    }
}

/// Prints the summary line to stderr.
pub fn report(summary: &DecodeSummary) {
    let mut stderr = std::io::stderr().lock();
    for note in &summary.notes {
        let _ = writeln!(stderr, "acq decode: {note}");
    }
    let _ = writeln!(stderr, "acq decode: {summary}");
}

/// The fixed header of the rig route.
pub const RIG_HEADER: &str = "time_s,sensor,value,unit";

/// Where the rig route's samples go.
pub trait RigRows {
    fn sample(&mut self, record: &LogRecord<'_>, sensor: usize, value: Option<f64>);
    fn end_frame(&mut self) -> Result<()>;
}

struct CsvRigRows<'a> {
    output: &'a mut Output,
    /// Per sensor: `,sensor,` and `,unit\n`.
    rows: Vec<(Vec<u8>, Vec<u8>)>,
}

impl RigRows for CsvRigRows<'_> {
    #[inline]
    fn sample(&mut self, record: &LogRecord<'_>, sensor: usize, value: Option<f64>) {
        let (middle, tail) = &self.rows[sensor];
        let buffer = &mut self.output.buffer;
        buffer.extend_from_slice(record.timestamp_text);
        buffer.extend_from_slice(middle);
        if let Some(value) = value {
            push_shortest_f64(buffer, value);
        }
        buffer.extend_from_slice(tail);
    }

    #[inline]
    fn end_frame(&mut self) -> Result<()> {
        self.output.maybe_flush()
    }
}

/// The rig route's table as Parquet: `time_s` (UTC instant), `sensor`,
/// `value` (null for a missing sample), `unit`.
pub struct RigParquet {
    table: ParquetTable,
    /// Per sensor: name and unit.
    sensors: Vec<(String, String)>,
}

impl RigParquet {
    const COLUMNS: [(&'static str, ColumnType, bool); 4] = [
        ("time_s", ColumnType::Time, false),
        ("sensor", ColumnType::Text, false),
        ("value", ColumnType::Float, true),
        ("unit", ColumnType::Text, false),
    ];

    fn columns() -> Vec<ColumnSpec> {
        Self::COLUMNS
            .iter()
            .map(|&(name, column_type, nullable)| {
                let column = ColumnSpec::new(name, column_type);
                if nullable {
                    column.nullable()
                } else {
                    column
                }
            })
            .collect()
    }

    pub fn create(output: Output, rig: &Rig) -> Result<Self> {
        Ok(Self::with_table(
            rig,
            ParquetTable::new(output, &Self::columns(), &[])?,
        ))
    }

    /// The same table as Arrow record batches, handed to `sink`.
    pub fn to_arrow(rig: &Rig, sink: Box<dyn ArrowSink>) -> Result<Self> {
        Ok(Self::with_table(
            rig,
            ParquetTable::to_arrow(&Self::columns(), &[], sink)?,
        ))
    }

    fn with_table(rig: &Rig, table: ParquetTable) -> Self {
        RigParquet {
            table,
            sensors: rig
                .sensors
                .iter()
                .map(|s| (s.name.clone(), s.unit().to_string()))
                .collect(),
        }
    }

    /// Writes the footer; the file is complete.
    pub fn finish(self) -> Result<u64> {
        self.table.finish()
    }
}

impl RigRows for RigParquet {
    #[inline]
    fn sample(&mut self, record: &LogRecord<'_>, sensor: usize, value: Option<f64>) {
        let (name, unit) = &self.sensors[sensor];
        self.table.time_ns(0, record.frame.timestamp_ns);
        self.table.text(1, Some(name));
        self.table.float(2, value);
        self.table.text(3, Some(unit));
        self.table.end_row_in_callback();
    }

    #[inline]
    fn end_frame(&mut self) -> Result<()> {
        self.table.check()
    }
}

/// The rig route's samples as MF4: a channel group per sensor (one channel,
/// its unit), a missing sample invalid.
pub struct RigMf4 {
    writer: Option<Mf4SignalWriter<CompleteOnlyFile>>,
    name: String,
    failed: Option<AcqError>,
}

impl RigMf4 {
    pub fn create(file: CompleteOnlyFile, name: &str, rig: &Rig) -> Result<Self> {
        let groups = rig
            .sensors
            .iter()
            .map(|s| SignalGroup {
                name: s.name.clone(),
                channels: vec![SignalChannel {
                    name: s.name.clone(),
                    unit: s.unit().to_string(),
                }],
            })
            .collect();
        Ok(RigMf4 {
            writer: Some(mf4_writer(file, name, groups)?),
            name: name.to_string(),
            failed: None,
        })
    }

    /// Patches lengths and counts; the file is complete.
    pub fn finish(mut self) -> Result<()> {
        finish_mf4(self.writer.take(), &self.name)
    }
}

impl RigRows for RigMf4 {
    #[inline]
    fn sample(&mut self, record: &LogRecord<'_>, sensor: usize, value: Option<f64>) {
        if let Some(writer) = self.writer.as_mut() {
            if let Err(e) = writer.write(sensor, record.frame.timestamp_ns, &[value]) {
                self.failed
                    .get_or_insert(AcqError::io(format!("writing {}", self.name), e));
            }
        }
    }

    #[inline]
    fn end_frame(&mut self) -> Result<()> {
        self.failed.take().map_or(Ok(()), Err)
    }
}

/// Decodes every frame of `inputs` through the rig's sensors into `output`
/// (CSV). A missing sample (J1939 "not available"/"error") is a row with an
/// empty value; CANopen heartbeat changes and losses are reported on stderr.
pub fn decode_with_rig(
    inputs: &mut [LogInput],
    rig: &Rig,
    bad_lines: BadLines,
    output: &mut Output,
) -> Result<DecodeSummary> {
    output.buffer.extend_from_slice(RIG_HEADER.as_bytes());
    output.buffer.push(b'\n');
    let mut sink = CsvRigRows {
        output,
        rows: rig
            .sensors
            .iter()
            .map(|s| {
                (
                    format!(",{},", s.name).into_bytes(),
                    format!(",{}\n", s.unit()).into_bytes(),
                )
            })
            .collect(),
    };
    decode_rig_frames(inputs, rig, bad_lines, &mut sink)
}

/// Decodes every frame of `inputs` through the rig's sensors into
/// `output`: CSV rows, a Parquet table or MF4 channel groups (`name`
/// titles them). What was decoded before a bad line stopped the run is
/// written out first.
pub fn decode_rig(
    inputs: &mut [LogInput],
    rig: &Rig,
    bad_lines: BadLines,
    output: TableOutput,
    name: &str,
) -> Result<DecodeSummary> {
    match output {
        TableOutput::Csv(mut output) => {
            let summary = decode_with_rig(inputs, rig, bad_lines, &mut output);
            let streamed = output.name() == "<stdout>";
            written(summary, name, streamed, || output.finish())
        }
        TableOutput::Parquet(output) => {
            let mut sink = RigParquet::create(output, rig)?;
            let summary = decode_rig_frames(inputs, rig, bad_lines, &mut sink);
            written(summary, name, false, || sink.finish().map(drop))
        }
        TableOutput::Arrow(arrow) => {
            let mut sink = RigParquet::to_arrow(rig, arrow)?;
            let summary = decode_rig_frames(inputs, rig, bad_lines, &mut sink);
            // Streamed: the rows before an error went out; the error is as is.
            written(summary, name, true, || sink.finish().map(drop))
        }
        TableOutput::Mf4(file) => {
            let mut sink = RigMf4::create(file, name, rig)?;
            let summary = decode_rig_frames(inputs, rig, bad_lines, &mut sink);
            written(summary, name, false, || sink.finish())
        }
    }
}

/// Decodes every frame of `inputs` through the rig's sensors into `sink`
/// (a [`RigParquet`] or [`RigMf4`]; finish it also after an error).
pub fn decode_rig_frames(
    inputs: &mut [LogInput],
    rig: &Rig,
    bad_lines: BadLines,
    sink: &mut impl RigRows,
) -> Result<DecodeSummary> {
    let mut decoder = SensorDecoder::new(rig);
    let mut summary = DecodeSummary::default();
    let mut last_time_ns = None;
    let mut heartbeats: Vec<(usize, HeartbeatEvent)> = Vec::new();
    for_each_record(
        inputs,
        bad_lines,
        EmptyLogs::Refuse,
        &mut summary.scan,
        |_, record| {
            last_time_ns = Some(record.frame.timestamp_ns);
            let used = decoder.decode(&record.frame, |event| match event {
                SensorEvent::Sample(sample) => {
                    sink.sample(record, sample.sensor, sample.value);
                    summary.rows += 1;
                }
                SensorEvent::Heartbeat { bus, event } => heartbeats.push((bus, event)),
            });
            match used {
                FrameUse::Decoded => summary.decoded += 1,
                FrameUse::Unknown => summary.unknown += 1,
                FrameUse::Undecodable => summary.undecodable += 1,
                FrameUse::Protocol => {}
                FrameUse::NotData => match record.frame.kind {
                    FrameKind::Error { .. } => summary.error_frames += 1,
                    _ => summary.remote_frames += 1,
                },
            }
            sink.end_frame()
        },
    )?;
    if let Some(end) = last_time_ns {
        decoder.check_heartbeats(end, |event| {
            if let SensorEvent::Heartbeat { bus, event } = event {
                heartbeats.push((bus, event));
            }
        });
    }
    let mut start_up = NodesStartingUp::default();
    for (bus, event) in heartbeats {
        let note = describe_heartbeat(rig, &decoder, bus, event);
        if !start_up.is_normal(bus, &event) {
            summary.warnings.push(note.clone());
        }
        summary.notes.push(note);
    }
    Ok(summary)
}

/// Which heartbeat events are a node's normal start-up (boot-up,
/// pre-operational before it has been operational, operational): said,
/// but nothing to act on. Anything else (stopped, a fall back from
/// operational, an undefined state, silence) is.
#[derive(Default)]
struct NodesStartingUp {
    /// The (bus, node) pairs that have been operational.
    operational: Vec<(usize, u8)>,
}

impl NodesStartingUp {
    fn is_normal(&mut self, bus: usize, event: &HeartbeatEvent) -> bool {
        let &HeartbeatEvent::StateChanged { node, state, .. } = event else {
            return false;
        };
        let was_operational = self.operational.contains(&(bus, node));
        match state {
            NmtState::BootUp => {
                // A reboot starts it up again.
                self.operational.retain(|&known| known != (bus, node));
                true
            }
            NmtState::PreOperational => !was_operational,
            NmtState::Operational => {
                if !was_operational {
                    self.operational.push((bus, node));
                }
                true
            }
            NmtState::Stopped | NmtState::Unknown(_) => false,
        }
    }
}

fn describe_heartbeat(
    rig: &Rig,
    decoder: &SensorDecoder<'_>,
    bus: usize,
    event: HeartbeatEvent,
) -> String {
    let sensors_on = |node: u8| {
        let names: Vec<&str> = decoder
            .node_sensors(bus, node)
            .map(|i| rig.sensors[i].name.as_str())
            .collect();
        names.join(", ")
    };
    let seconds = |ns: i64| ns as f64 / 1e9;
    match event {
        HeartbeatEvent::StateChanged {
            node,
            state,
            time_ns,
        } => {
            format!(
                "{:.6}: CANopen node 0x{node:02X} ({}) is {state:?}",
                seconds(time_ns),
                sensors_on(node)
            )
        }
        HeartbeatEvent::Lost {
            node,
            last_seen_ns,
            time_ns,
        } => format!(
            "{:.6}: CANopen node 0x{node:02X} ({}) LOST: no heartbeat since {}",
            seconds(time_ns),
            sensors_on(node),
            last_seen_ns
                .map(|t| format!("{:.6}", seconds(t)))
                .unwrap_or_else(|| "the start".into())
        ),
    }
}
