//! The DBC route to CSV: every row's constant part (`,0x123,Message,Signal,`
//! and `,unit`) built once per signal, so a row costs four `memcpy`s and a
//! value's shortest text. A candump log is cut into pieces of whole lines,
//! each parsed, decoded and made into rows on one of the cores, the rows
//! written in the log's order ([`in_order`]); the frames of other formats
//! are decoded on one thread and their rows made and written on another.

use std::ops::ControlFlow;

use acq_can::dbc::{DbcDatabase, PhysicalValue, ValueTextBuffer};
use acq_can::log::candump::read_whole_lines;
use acq_can::{CanId, IfaceName, LogFormat, ParseError, Place};
use acq_error::{AcqError, Result};
use acq_io::input::{
    end_of_log, on_bad_record, BadLines, EmptyLogs, LogInput, READ_BUFFER_BYTES, REPORTED_BAD_LINES,
};
use acq_io::output::{csv_field, Output};

use super::{
    decode_dbc_frames, decode_frame, DbcDecodeOptions, DbcRows, DecodeSummary, FrameAt, DBC_HEADER,
};

mod in_order;
use in_order::in_order;

/// Decodes every frame of `inputs` through `database` into `output` (CSV).
pub fn decode_with_dbc(
    inputs: &mut [LogInput],
    database: &DbcDatabase,
    options: DbcDecodeOptions,
    output: &mut Output,
) -> Result<DecodeSummary> {
    let pieces = CsvRowPieces::new(database, options.labels);
    output.buffer.extend_from_slice(DBC_HEADER.as_bytes());
    if options.labels {
        output.buffer.extend_from_slice(b",label");
    }
    output.buffer.push(b'\n');
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let route = if inputs
        .iter()
        .all(|input| input.format == LogFormat::Candump)
    {
        Route::InPieces {
            workers: cores,
            piece_bytes: PIECE_BYTES,
        }
    } else if options.labels || cores < 2 {
        Route::OneThread
    } else {
        Route::HandedOver
    };
    decode_to_csv(inputs, database, options, output, pieces, route)
}

/// How the rows are made (each route writes the same bytes).
#[derive(Clone, Copy, Debug)]
enum Route {
    /// Record by record on this thread.
    OneThread,
    /// Decoded on this thread, the rows made and written on another.
    HandedOver,
    /// Every log candump, cut into pieces of whole lines, each about
    /// `piece_bytes`, each decoded and made into rows on one of `workers`
    /// threads.
    InPieces { workers: usize, piece_bytes: usize },
}

/// A candump log's piece: about as much text as a core's second-level
/// cache holds with its rows (about 2.6 times the text on the bench's
/// log); large enough that handing pieces over costs nothing. The log's
/// read buffer, no larger, so that the pieces are read past it.
const PIECE_BYTES: usize = READ_BUFFER_BYTES;

/// [`decode_with_dbc`] after the header, by `route`.
fn decode_to_csv(
    inputs: &mut [LogInput],
    database: &DbcDatabase,
    options: DbcDecodeOptions,
    output: &mut Output,
    pieces: CsvRowPieces,
    route: Route,
) -> Result<DecodeSummary> {
    match route {
        Route::OneThread => {
            let mut sink = CsvDbcRows {
                output,
                pieces: &pieces,
                value_text: ValueTextBuffer::default(),
            };
            return decode_dbc_frames(inputs, database, options, &mut sink);
        }
        Route::InPieces {
            workers,
            piece_bytes,
        } => {
            let in_pieces = InPieces {
                database,
                options,
                pieces: &pieces,
                workers,
                piece_bytes,
            };
            let mut summary = DecodeSummary::default();
            for input in inputs.iter_mut() {
                in_pieces.decode(input, output, &mut summary)?;
            }
            return Ok(summary);
        }
        Route::HandedOver => {}
    }
    // Parsing and decoding on this thread, the rows made and written on
    // another: making them (the values' shortest text above all) is about
    // half of the work.
    let (full, runs) = std::sync::mpsc::sync_channel(RUNS_IN_FLIGHT);
    let (empty, spare) = std::sync::mpsc::channel();
    let (decoded, written) = std::thread::scope(|scope| {
        let pieces = &pieces;
        let writing = scope.spawn(move || write_decoded(runs, empty, pieces, output));
        let mut sink = HandingOver {
            current: DecodedFrames::default(),
            in_frame: false,
            full,
            spare,
        };
        let decoded = decode_dbc_frames(inputs, database, options, &mut sink);
        // What was decoded before an error is written, as on one thread.
        let last = sink.hand_over();
        drop(sink);
        let written = writing.join().expect("writing CSV rows does not panic");
        (decoded.and_then(|summary| last.map(|()| summary)), written)
    });
    // A writer's failure is the cause of a decoder stopped by it.
    written.and(decoded)
}

/// One candump log decoded in pieces: the lines of a piece read where
/// they lie ([`read_whole_lines`]), their rows made where the piece is worked on, the
/// pieces' rows, counts and malformed lines taken in the log's order.
struct InPieces<'a> {
    database: &'a DbcDatabase,
    options: DbcDecodeOptions,
    pieces: &'a CsvRowPieces,
    workers: usize,
    piece_bytes: usize,
}

/// A piece of a candump log: its text, then what its lines became.
#[derive(Default)]
struct LogPiece {
    text: Vec<u8>,
    rows: Vec<u8>,
    summary: DecodeSummary,
    /// The lines of `text`.
    lines: u64,
    /// Its first malformed lines, numbered within the piece (a piece
    /// stops at its first where a malformed line stops the decode).
    bad: Vec<ParseError>,
    bad_lines: u64,
}

/// Malformed lines of a piece kept to be reported one by one: no more
/// are reported of the whole log.
const BAD_LINES_KEPT: usize = REPORTED_BAD_LINES as usize;

impl InPieces<'_> {
    fn decode(
        &self,
        input: &mut LogInput,
        output: &mut Output,
        summary: &mut DecodeSummary,
    ) -> Result<()> {
        let name = input.name.clone();
        let before = (summary.scan.frames, summary.scan.malformed_lines);
        let mut lines_before = 0;
        in_order(
            self.workers,
            2 * self.workers + 2,
            |piece: &mut LogPiece| {
                piece.text.clear();
                match input.read_candump_lines(&mut piece.text, self.piece_bytes) {
                    Some(read) => read.map(|bytes| bytes > 0),
                    None => Err(AcqError::Config(format!(
                        "{name}: not a candump log, read as one"
                    ))),
                }
            },
            |piece| self.decode_piece(piece),
            |piece| {
                // The rows before a malformed line that stops the decode too.
                output.take_from(&mut piece.rows)?;
                summary.add_counts(&piece.summary);
                let reported = piece.bad.len() as u64;
                for mut error in piece.bad.drain(..) {
                    if let Place::Line(line) = error.at {
                        error.at = Place::Line(lines_before + line);
                    }
                    on_bad_record(&name, error, self.options.bad_lines, &mut summary.scan)?;
                }
                summary.scan.malformed_lines += piece.bad_lines - reported;
                lines_before += piece.lines;
                Ok(())
            },
        )?;
        end_of_log(input, &summary.scan, before, EmptyLogs::Refuse)
    }

    /// The piece's lines read, decoded and made into rows.
    fn decode_piece(&self, piece: &mut LogPiece) {
        piece.rows.clear();
        piece.bad.clear();
        piece.bad_lines = 0;
        let summary = &mut piece.summary;
        *summary = DecodeSummary::default();
        let mut sink = CsvDbcRows {
            output: &mut piece.rows,
            pieces: self.pieces,
            value_text: ValueTextBuffer::default(),
        };
        let (bad, bad_lines) = (&mut piece.bad, &mut piece.bad_lines);
        piece.lines = read_whole_lines(
            &piece.text,
            |frame| {
                summary.scan.frames += 1;
                let at = FrameAt {
                    timestamp_ns: frame.fields.timestamp_ns,
                    timestamp_text: frame.timestamp_text,
                    iface: frame.iface,
                    id: frame.fields.id,
                };
                // Rows into memory: no error to give.
                let _ = decode_frame(
                    self.database,
                    summary,
                    &mut sink,
                    at,
                    frame.fields.kind,
                    frame.fields.payload,
                );
            },
            |error| {
                *bad_lines += 1;
                if bad.len() < BAD_LINES_KEPT {
                    bad.push(error);
                }
                if self.options.bad_lines == BadLines::Stop {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            },
        );
    }
}

/// Runs of decoded values ahead of the CSV thread at most.
const RUNS_IN_FLIGHT: usize = 4;

/// Row pieces of one signal that do not change from frame to frame.
struct SignalRow {
    /// `,0x123,Message,Signal,`
    middle: Vec<u8>,
    /// Where `,Message,Signal,` starts in `middle`: a J1939 frame matched
    /// by its PGN writes its own id before it.
    after_id: usize,
    /// `,unit`, and the line's end where rows have no label column (one
    /// byte fewer to add a row: the rows are most of a decode's work).
    tail: Vec<u8>,
    /// `middle` and `tail` zero-padded, where they fit: a row is made in
    /// place from those ([`push_in_place`]).
    padded: Option<PaddedRow>,
}

/// A signal's constant row pieces padded with zeros to fixed lengths:
/// each copied whole, a few moves, where a copy of its own length is a
/// call of `memcpy` (five such calls a row were a tenth of a decode).
struct PaddedRow {
    middle: [u8; PADDED_MIDDLE],
    middle_len: usize,
    tail: [u8; PADDED_TAIL],
    tail_len: usize,
}

const PADDED_MIDDLE: usize = 48;
const PADDED_TAIL: usize = 16;
/// A row's timestamp and value at most, to be made in place.
const SHORT_PART: usize = 32;

impl PaddedRow {
    fn new(middle: &[u8], tail: &[u8]) -> Option<Self> {
        if middle.len() > PADDED_MIDDLE || tail.len() > PADDED_TAIL {
            return None;
        }
        let mut padded = PaddedRow {
            middle: [0; PADDED_MIDDLE],
            middle_len: middle.len(),
            tail: [0; PADDED_TAIL],
            tail_len: tail.len(),
        };
        padded.middle[..middle.len()].copy_from_slice(middle);
        padded.tail[..tail.len()].copy_from_slice(tail);
        Some(padded)
    }
}

/// Room at a row's end for its parts' fixed-length copies
/// ([`put_short`], [`PaddedRow`]), each part's end past the last's.
const ROW_ROOM_BYTES: usize =
    SHORT_PART + 1 + IfaceName::MAX_LEN + PADDED_MIDDLE + SHORT_PART + PADDED_TAIL;

/// Copies `part`, at most [`SHORT_PART`] bytes, into `row` at `at` in two
/// copies of a fixed length that overlap (as `memcpy` does inside, without
/// its call); gives where it ends. Bytes past that end may be written.
#[inline(always)]
fn put_short(row: &mut [u8; ROW_ROOM_BYTES], at: usize, part: &[u8]) -> usize {
    let len = part.len();
    let to = &mut row[at..at + SHORT_PART];
    if len >= 16 {
        to[..16].copy_from_slice(&part[..16]);
        to[len - 16..len].copy_from_slice(&part[len - 16..]);
    } else if len >= 8 {
        to[..8].copy_from_slice(&part[..8]);
        to[len - 8..len].copy_from_slice(&part[len - 8..]);
    } else if len >= 4 {
        to[..4].copy_from_slice(&part[..4]);
        to[len - 4..len].copy_from_slice(&part[len - 4..]);
    } else if len >= 2 {
        // Short integers' text (`0`, `42`, `255`) is common.
        to[..2].copy_from_slice(&part[..2]);
        to[len - 2..len].copy_from_slice(&part[len - 2..]);
    } else if let Some(&byte) = part.first() {
        to[0] = byte;
    }
    at + len
}

/// The constant pieces of every signal's CSV row, and how a row is made.
struct CsvRowPieces {
    /// Per message, per signal.
    rows: Vec<Vec<SignalRow>>,
    /// Per message, its id.
    message_ids: Vec<CanId>,
    /// Whether rows end with a label column.
    labels: bool,
}

impl CsvRowPieces {
    fn new(database: &DbcDatabase, labels: bool) -> Self {
        let line_end = if labels { "" } else { "\n" };
        let rows = database
            .messages()
            .iter()
            .map(|message| {
                message
                    .signals
                    .iter()
                    .map(|signal| {
                        let middle = format!(
                            ",{},{},{},",
                            message.id,
                            csv_field(&message.name),
                            csv_field(&signal.name)
                        )
                        .into_bytes();
                        let tail = format!(",{}{line_end}", csv_field(&signal.unit)).into_bytes();
                        SignalRow {
                            padded: PaddedRow::new(&middle, &tail),
                            middle,
                            after_id: 1 + message.id.to_string().len(),
                            tail,
                        }
                    })
                    .collect()
            })
            .collect();
        CsvRowPieces {
            rows,
            message_ids: database.messages().iter().map(|m| m.id).collect(),
            labels,
        }
    }

    /// One row, its line end included (`label` its label column's, if rows
    /// have one).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn push(
        &self,
        value_text: &mut ValueTextBuffer,
        buffer: &mut Vec<u8>,
        timestamp_text: &[u8],
        iface: &IfaceName,
        id: CanId,
        message: usize,
        signal: usize,
        value: PhysicalValue,
        label: Option<&str>,
    ) {
        let row = &self.rows[message][signal];
        let in_place = match &row.padded {
            Some(padded) if id == self.message_ids[message] => {
                push_in_place(buffer, value_text, timestamp_text, iface, padded, value)
            }
            _ => false,
        };
        if !in_place {
            buffer.extend_from_slice(timestamp_text);
            buffer.push(b',');
            buffer.extend_from_slice(iface.as_bytes());
            if id == self.message_ids[message] {
                buffer.extend_from_slice(&row.middle);
            } else {
                buffer.push(b',');
                buffer.extend_from_slice(id.to_string().as_bytes());
                buffer.extend_from_slice(&row.middle[row.after_id..]);
            }
            value.push_shortest(buffer);
            buffer.extend_from_slice(&row.tail);
        }
        if self.labels {
            buffer.push(b',');
            if let Some(label) = label {
                buffer.extend_from_slice(csv_field(label).as_bytes());
            }
            buffer.push(b'\n');
        }
    }
}

/// Appends the row up to its tail to `buffer`, made where it ends in
/// copies of fixed lengths, where its timestamp and value are at most
/// [`SHORT_PART`] bytes and its value's text needs no mending (the value
/// written in `value_text`); `false`, nothing appended, otherwise.
#[inline(always)]
fn push_in_place(
    buffer: &mut Vec<u8>,
    value_text: &mut ValueTextBuffer,
    timestamp_text: &[u8],
    iface: &IfaceName,
    padded: &PaddedRow,
    value: PhysicalValue,
) -> bool {
    let Some(value) = value.shortest_text(value_text) else {
        return false;
    };
    if timestamp_text.len() > SHORT_PART || value.len() > SHORT_PART {
        return false;
    }
    let start = buffer.len();
    // Room made with stores of a constant length, then cut to the row:
    // no call of `memcpy` for the row.
    buffer.extend_from_slice(&[0; ROW_ROOM_BYTES]);
    let Ok(row) = <&mut [u8; ROW_ROOM_BYTES]>::try_from(&mut buffer[start..]) else {
        buffer.truncate(start);
        return false;
    };
    let mut at = put_short(row, 0, timestamp_text);
    row[at] = b',';
    at += 1;
    row[at..at + IfaceName::MAX_LEN].copy_from_slice(iface.zero_padded());
    at += iface.as_bytes().len();
    row[at..at + PADDED_MIDDLE].copy_from_slice(&padded.middle);
    at += padded.middle_len;
    at = put_short(row, at, value);
    row[at..at + PADDED_TAIL].copy_from_slice(&padded.tail);
    at += padded.tail_len;
    buffer.truncate(start + at);
    true
}

/// Where rows are made: the output's buffer, written out as it fills, or
/// a piece's rows in memory.
trait RowBuffer {
    fn rows(&mut self) -> &mut Vec<u8>;
    fn end_frame(&mut self) -> Result<()>;
}

impl RowBuffer for Output {
    fn rows(&mut self) -> &mut Vec<u8> {
        &mut self.buffer
    }
    fn end_frame(&mut self) -> Result<()> {
        self.maybe_flush()
    }
}

impl RowBuffer for Vec<u8> {
    fn rows(&mut self) -> &mut Vec<u8> {
        self
    }
    fn end_frame(&mut self) -> Result<()> {
        Ok(())
    }
}

/// The CSV rows made where the frames are decoded.
struct CsvDbcRows<'a, B: RowBuffer> {
    output: &'a mut B,
    pieces: &'a CsvRowPieces,
    value_text: ValueTextBuffer,
}

impl<B: RowBuffer> DbcRows for CsvDbcRows<'_, B> {
    const WANTS_TEXT: bool = true;

    #[inline]
    fn value(
        &mut self,
        frame: FrameAt<'_>,
        message: usize,
        signal: usize,
        value: PhysicalValue,
        label: Option<&str>,
    ) {
        let buffer = self.output.rows();
        let timestamp = frame.timestamp_text;
        self.pieces.push(
            &mut self.value_text,
            buffer,
            timestamp,
            &frame.iface,
            frame.id,
            message,
            signal,
            value,
            label,
        );
    }

    #[inline]
    fn end_frame(&mut self) -> Result<()> {
        self.output.end_frame()
    }

    fn wants_labels(&self) -> bool {
        self.pieces.labels
    }
}

/// Values decoded from a run of frames, handed from the decoding thread to
/// the one that makes and writes their CSV rows.
#[derive(Default)]
struct DecodedFrames {
    /// The frames' timestamps as the log writes them, one after another.
    timestamps: Vec<u8>,
    frames: Vec<DecodedFrame>,
    /// `(signal, value)`, frame after frame.
    values: Vec<(u32, PhysicalValue)>,
}

/// A frame with at least one value: where its timestamp and values end.
struct DecodedFrame {
    timestamp_end: usize,
    iface: IfaceName,
    id: CanId,
    message: usize,
    values_end: usize,
}

/// Values decoded before they go to the CSV thread.
const HANDOVER_VALUES: usize = 16 * 1024;

/// The decoding thread's side: values collected, handed over in runs of
/// [`HANDOVER_VALUES`].
struct HandingOver {
    current: DecodedFrames,
    in_frame: bool,
    full: std::sync::mpsc::SyncSender<DecodedFrames>,
    spare: std::sync::mpsc::Receiver<DecodedFrames>,
}

impl HandingOver {
    fn hand_over(&mut self) -> Result<()> {
        let next = self.spare.try_recv().unwrap_or_default();
        // Closed: the CSV thread could not write, and says why.
        self.full
            .send(std::mem::replace(&mut self.current, next))
            .map_err(|_| AcqError::Malformed("the CSV writer stopped".into()))
    }
}

impl DbcRows for HandingOver {
    const WANTS_TEXT: bool = true;

    #[inline]
    fn value(
        &mut self,
        frame: FrameAt<'_>,
        message: usize,
        signal: usize,
        value: PhysicalValue,
        _label: Option<&str>,
    ) {
        let current = &mut self.current;
        if !self.in_frame {
            self.in_frame = true;
            current.timestamps.extend_from_slice(frame.timestamp_text);
            current.frames.push(DecodedFrame {
                timestamp_end: current.timestamps.len(),
                iface: frame.iface,
                id: frame.id,
                message,
                values_end: 0,
            });
        }
        current.values.push((signal as u32, value));
    }

    #[inline]
    fn end_frame(&mut self) -> Result<()> {
        if std::mem::take(&mut self.in_frame) {
            if let Some(frame) = self.current.frames.last_mut() {
                frame.values_end = self.current.values.len();
            }
            if self.current.values.len() >= HANDOVER_VALUES {
                self.hand_over()?;
            }
        }
        Ok(())
    }
}

/// The CSV thread's side: the rows of each run of frames, written.
fn write_decoded(
    runs: std::sync::mpsc::Receiver<DecodedFrames>,
    empty: std::sync::mpsc::Sender<DecodedFrames>,
    pieces: &CsvRowPieces,
    output: &mut Output,
) -> Result<()> {
    let mut value_text = ValueTextBuffer::default();
    for mut run in runs {
        let (mut timestamp_start, mut values_start) = (0, 0);
        for frame in &run.frames {
            let timestamp = &run.timestamps[timestamp_start..frame.timestamp_end];
            for &(signal, value) in &run.values[values_start..frame.values_end] {
                let buffer = &mut output.buffer;
                let (iface, id) = (&frame.iface, frame.id);
                pieces.push(
                    &mut value_text,
                    buffer,
                    timestamp,
                    iface,
                    id,
                    frame.message,
                    signal as usize,
                    value,
                    None,
                );
            }
            (timestamp_start, values_start) = (frame.timestamp_end, frame.values_end);
        }
        output.maybe_flush()?;
        run.timestamps.clear();
        run.frames.clear();
        run.values.clear();
        // The decoder may have ended: a run not taken back is freed.
        let _ = empty.send(run);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use acq_io::input::{open_log, BadLines};
    use std::io::Write;
    use std::sync::{Arc, Mutex};

    /// Bytes written, kept; failing once `fail_after` bytes are.
    #[derive(Clone)]
    struct Kept {
        bytes: Arc<Mutex<Vec<u8>>>,
        fail_after: usize,
    }

    impl Write for Kept {
        fn write(&mut self, data: &[u8]) -> std::io::Result<usize> {
            let mut bytes = self.bytes.lock().unwrap();
            if bytes.len() + data.len() > self.fail_after {
                return Err(std::io::Error::other("the disk is full"));
            }
            bytes.extend_from_slice(data);
            Ok(data.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// Any value: integers of any size, floats of any bits (NaN, the
    /// infinities, subnormals, from 1e15 up), and floats as a DBC's
    /// scaling makes them.
    fn any_value() -> impl proptest::strategy::Strategy<Value = PhysicalValue> {
        use proptest::prelude::*;
        prop_oneof![
            any::<i128>().prop_map(PhysicalValue::Integer),
            (-100_000i128..100_000).prop_map(PhysicalValue::Integer),
            any::<u64>().prop_map(|bits| PhysicalValue::Float(f64::from_bits(bits))),
            any::<f32>().prop_map(|v| PhysicalValue::Float(f64::from(v))),
            (-1e17..1e17f64).prop_map(PhysicalValue::Float),
        ]
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config::with_cases(4000))]

        /// A row made in place is the row made part by part, after what
        /// the buffer held; it is made in place wherever its parts fit
        /// their room, and otherwise nothing is appended.
        #[test]
        fn a_row_made_in_place_is_the_row_made_part_by_part(
            before in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..70),
            timestamp_text in "[0-9.]{0,40}",
            iface in "[a-z0-9_.-]{1,15}",
            middle in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..60),
            tail in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..24),
            value in any_value(),
        ) {
            let iface = IfaceName::new(&iface).unwrap();
            let padded = PaddedRow::new(&middle, &tail);
            let mut buffer = before.clone();
            let in_place = match &padded {
                Some(padded) => push_in_place(
                    &mut buffer,
                    &mut ValueTextBuffer::default(),
                    timestamp_text.as_bytes(),
                    &iface,
                    padded,
                    value,
                ),
                None => false,
            };
            let fits = match value {
                PhysicalValue::Integer(v) => v.to_string().len() <= SHORT_PART,
                PhysicalValue::Float(v) => v.abs() < 1e15,
            };
            proptest::prop_assert_eq!(
                in_place,
                middle.len() <= PADDED_MIDDLE
                    && tail.len() <= PADDED_TAIL
                    && timestamp_text.len() <= SHORT_PART
                    && fits
            );
            let mut expected = before;
            if in_place {
                expected.extend_from_slice(timestamp_text.as_bytes());
                expected.push(b',');
                expected.extend_from_slice(iface.as_bytes());
                expected.extend_from_slice(&middle);
                value.push_shortest(&mut expected);
                expected.extend_from_slice(&tail);
            }
            proptest::prop_assert_eq!(buffer, expected);
        }
    }

    /// A J1939 log: EEC1 from its DBC's source address and from another
    /// (a row with the frame's own id), CCVS1, an unknown id, a remote and
    /// an error frame, a short frame; a malformed line after `bad_at`
    /// frames if given.
    fn log(dir: &std::path::Path, frames: usize, bad_at: Option<usize>) -> std::path::PathBuf {
        let mut text = String::new();
        for k in 0..frames {
            if bad_at == Some(k) {
                text.push_str("(1700000000.5) can0 not a frame\n");
            }
            let time = format!("(1700000000.{:06})", k % 1_000_000);
            let line = match k % 7 {
                0 => format!("{time} can0 0CF004FE#0000{:04X}00000000", k % 65_536),
                1 => format!("{time} can1 0CF00400#00001234{:02X}000000", k % 256),
                2 => format!("{time} can0 18FEF1FE#00{:04X}0000000000", (k * 31) % 65_536),
                3 => format!("{time} can0 123#DEADBEEF"),
                4 => format!("{time} can0 0CF004FE#R"),
                5 => format!("{time} can0 20000080#0000000000000000"),
                _ => format!("{time} can1 0CF00401#0011"),
            };
            text.push_str(&line);
            text.push('\n');
        }
        let path = dir.join(format!("j1939-{frames}-{bad_at:?}.log"));
        std::fs::write(&path, text).unwrap();
        path
    }

    fn j1939_database() -> DbcDatabase {
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../fixtures/dbc/j1939_source_fe.dbc"),
        )
        .unwrap();
        DbcDatabase::parse(&text, "j1939_source_fe.dbc").unwrap().0
    }

    fn decode(
        path: &std::path::Path,
        bad_lines: BadLines,
        route: Route,
        fail_after: usize,
    ) -> (Result<DecodeSummary>, Vec<u8>) {
        let database = j1939_database();
        let kept = Kept {
            bytes: Arc::default(),
            fail_after,
        };
        let mut output = Output::to_writer("kept", Box::new(kept.clone()));
        output.buffer.extend_from_slice(DBC_HEADER.as_bytes());
        output.buffer.push(b'\n');
        let options = DbcDecodeOptions {
            bad_lines,
            labels: false,
        };
        let mut inputs = vec![open_log(path).unwrap()];
        let pieces = CsvRowPieces::new(&database, options.labels);
        let result = decode_to_csv(&mut inputs, &database, options, &mut output, pieces, route);
        let _ = output.finish();
        let bytes = kept.bytes.lock().unwrap().clone();
        (result, bytes)
    }

    /// Every route, and pieces of several sizes on one to three threads:
    /// pieces of a line or two, pieces that cut a run of bad lines.
    const ROUTES: [Route; 6] = [
        Route::OneThread,
        Route::HandedOver,
        Route::InPieces {
            workers: 1,
            piece_bytes: 100,
        },
        Route::InPieces {
            workers: 2,
            piece_bytes: 1,
        },
        Route::InPieces {
            workers: 2,
            piece_bytes: 4096,
        },
        Route::InPieces {
            workers: 3,
            piece_bytes: PIECE_BYTES,
        },
    ];

    #[test]
    fn every_route_writes_what_one_thread_writes() {
        let dir = tempfile::tempdir().unwrap();
        // Many hand-overs, a last short one; a bad line in the middle.
        let whole = log(dir.path(), 12 * HANDOVER_VALUES + 123, None);
        let broken = log(
            dir.path(),
            12 * HANDOVER_VALUES + 123,
            Some(7 * HANDOVER_VALUES + 5),
        );
        for (path, bad_lines) in [
            (&whole, BadLines::Stop),
            (&broken, BadLines::Skip),
            (&broken, BadLines::Stop),
        ] {
            let (one, one_bytes) = decode(path, bad_lines, Route::OneThread, usize::MAX);
            assert!(one_bytes.len() > 200_000, "{}", one_bytes.len());
            for route in ROUTES {
                let (two, two_bytes) = decode(path, bad_lines, route, usize::MAX);
                assert!(
                    one_bytes == two_bytes,
                    "{path:?} {bad_lines:?} {route:?}: the CSVs differ"
                );
                same_summary_or_error(one.as_ref(), two);
            }
        }
        let text =
            String::from_utf8(decode(&whole, BadLines::Stop, ROUTES[5], usize::MAX).1).unwrap();
        // EEC1 from 0x00 as its own id, from 0xFE as the DBC's.
        assert!(
            text.contains(",can1,0xCF00400,EEC1,EngineSpeed,"),
            "{}",
            &text[..400]
        );
        assert!(
            text.contains(",can0,0xCF004FE,EEC1,EngineSpeed,"),
            "{}",
            &text[..400]
        );
    }

    fn same_summary_or_error(
        one: std::result::Result<&DecodeSummary, &AcqError>,
        two: Result<DecodeSummary>,
    ) {
        match (one, two) {
            (Ok(one), Ok(two)) => {
                assert_eq!(one, &two);
                assert!(one.rows > 3 * HANDOVER_VALUES as u64, "{one:?}");
                assert!(
                    one.unknown > 0 && one.remote_frames > 0 && one.undecodable > 0,
                    "{one:?}"
                );
            }
            (Err(one), Err(two)) => {
                assert_eq!(one.to_string(), two.to_string());
                assert!(one.to_string().contains("expected"), "{one}");
            }
            (one, two) => panic!("{one:?} against {two:?}"),
        }
    }

    #[test]
    fn many_malformed_lines_are_counted_and_the_first_stops_on_every_route() {
        let dir = tempfile::tempdir().unwrap();
        let good = std::fs::read_to_string(log(dir.path(), 3000, None)).unwrap();
        let mut text = String::new();
        for (k, line) in good.lines().enumerate() {
            text.push_str(line);
            text.push('\n');
            if k % 97 == 5 {
                text.push_str("(1700000000.5) can0 12G#00\n");
            }
        }
        // The last line cut short: malformed too.
        text.push_str("(1700000001.000000) can0 0CF004FE#00");
        let path = dir.path().join("many-bad.log");
        std::fs::write(&path, text).unwrap();
        for bad_lines in [BadLines::Skip, BadLines::Stop] {
            let (one, one_bytes) = decode(&path, bad_lines, Route::OneThread, usize::MAX);
            match (&one, bad_lines) {
                (Ok(summary), BadLines::Skip) => assert_eq!(summary.scan.malformed_lines, 32),
                (Err(error), BadLines::Stop) => {
                    assert!(error.to_string().contains("many-bad.log:7:"), "{error}")
                }
                (other, _) => panic!("{other:?}"),
            }
            for route in ROUTES {
                let (two, two_bytes) = decode(&path, bad_lines, route, usize::MAX);
                assert!(
                    one_bytes == two_bytes,
                    "{bad_lines:?} {route:?}: the CSVs differ"
                );
                match (&one, two) {
                    (Ok(one), Ok(two)) => assert_eq!(one, &two, "{route:?}"),
                    (Err(one), Err(two)) => assert_eq!(one.to_string(), two.to_string()),
                    (one, two) => panic!("{route:?}: {one:?} against {two:?}"),
                }
            }
        }
    }

    /// Record batches kept.
    #[derive(Clone, Default)]
    struct Batches(Arc<Mutex<Vec<acq_io::arrow_sink::ArrowBatch>>>);

    impl acq_io::arrow_sink::ArrowSink for Batches {
        fn schema(&mut self, _: acq_io::arrow_sink::ArrowSchema) -> Result<()> {
            Ok(())
        }
        fn batch(&mut self, batch: acq_io::arrow_sink::ArrowBatch) -> Result<()> {
            self.0.lock().unwrap().push(batch);
            Ok(())
        }
    }

    /// A row as (time text, iface, can_id, message, signal, value's bits, unit).
    type Row = (String, String, String, String, String, u64, String);

    fn csv_rows(bytes: &[u8]) -> Vec<Row> {
        let text = std::str::from_utf8(bytes).unwrap();
        text.lines()
            .skip(1)
            .map(|line| {
                let f: Vec<&str> = line.split(',').collect();
                let value: f64 = f[5].parse().unwrap();
                let text = |k: usize| f[k].to_string();
                (
                    text(0),
                    text(1),
                    text(2),
                    text(3),
                    text(4),
                    value.to_bits(),
                    text(6),
                )
            })
            .collect()
    }

    /// The rows of the table the Python package and `-o FILE.parquet` get:
    /// the frames read a batch at a time, on a thread of their own.
    fn arrow_rows(
        path: &std::path::Path,
        bad_lines: BadLines,
    ) -> (Result<DecodeSummary>, Vec<Row>) {
        use arrow_array::cast::AsArray;
        use arrow_array::types::{Float64Type, Int32Type, TimestampNanosecondType};
        let database = j1939_database();
        let kept = Batches::default();
        let mut sink =
            super::super::DbcParquet::to_arrow(&database, false, Box::new(kept.clone())).unwrap();
        let options = DbcDecodeOptions {
            bad_lines,
            labels: false,
        };
        let mut inputs = vec![open_log(path).unwrap()];
        let result = decode_dbc_frames(&mut inputs, &database, options, &mut sink);
        sink.finish().unwrap();
        let mut rows = Vec::new();
        for batch in kept.0.lock().unwrap().iter() {
            let text = |k: usize, row: usize| {
                let column = batch.column(k).as_dictionary::<Int32Type>();
                let key = column.keys().value(row) as usize;
                column.values().as_string::<i32>().value(key).to_string()
            };
            let times = batch.column(0).as_primitive::<TimestampNanosecondType>();
            let values = batch.column(5).as_primitive::<Float64Type>();
            for row in 0..batch.num_rows() {
                let ns = times.value(row);
                let time = format!("{}.{:06}", ns / 1_000_000_000, ns % 1_000_000_000 / 1_000);
                rows.push((
                    time,
                    text(1, row),
                    text(2, row),
                    text(3, row),
                    text(4, row),
                    values.value(row).to_bits(),
                    text(6, row),
                ));
            }
        }
        (result, rows)
    }

    #[test]
    fn frames_read_a_batch_at_a_time_beside_make_the_csv_s_rows() {
        let dir = tempfile::tempdir().unwrap();
        // Many batches of frames; a bad line in the middle.
        let whole = log(dir.path(), 9 * 4096 + 17, None);
        let broken = log(dir.path(), 9 * 4096 + 17, Some(5 * 4096 + 3));
        for (path, bad_lines) in [
            (&whole, BadLines::Stop),
            (&broken, BadLines::Skip),
            (&broken, BadLines::Stop),
        ] {
            let (by_record, csv) = decode(path, bad_lines, Route::OneThread, usize::MAX);
            let (by_batch, rows) = arrow_rows(path, bad_lines);
            let csv = csv_rows(&csv);
            assert!(csv.len() > 5_000, "{}", csv.len());
            assert!(csv == rows, "{path:?} {bad_lines:?}: the rows differ");
            match (by_record, by_batch) {
                (Ok(one), Ok(two)) => assert_eq!(one, two),
                (Err(one), Err(two)) => assert_eq!(one.to_string(), two.to_string()),
                (one, two) => panic!("{one:?} against {two:?}"),
            }
        }
    }

    #[test]
    fn a_writer_that_fails_stops_the_decode_with_its_own_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = log(dir.path(), 20 * HANDOVER_VALUES, None);
        for route in ROUTES {
            let (result, bytes) = decode(&path, BadLines::Stop, route, 1 << 20);
            let error = result.unwrap_err().to_string();
            assert!(error.contains("the disk is full"), "{route:?}: {error}");
            assert!(bytes.len() <= 1 << 20);
        }
    }
}
