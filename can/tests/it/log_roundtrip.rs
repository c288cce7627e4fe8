//! Property tests of the log formats: candump logs round-trip every kind of
//! frame exactly, and neither reader panics on any input.

use crate::common;

use acq_can::frame::fd_flags;
use acq_can::log::asc::{AscReader, ERROR_FRAME_CLASS};
use acq_can::log::asc_write::AscWriter;
use acq_can::log::candump::{self, CandumpReader, CandumpWriter};
use acq_can::{Direction, Frame, FrameKind, IfaceName, ReadError};
use proptest::prelude::*;

const IFACES: [&str; 5] = ["can0", "can1", "vcan0", "slcan12", "excavator_fd"];

fn iface() -> impl Strategy<Value = IfaceName> + Clone {
    prop::sample::select(&IFACES[..]).prop_map(|name| IfaceName::new(name).unwrap())
}

/// Whole microseconds from 0 to 10^17 ns (the format's resolution).
fn timestamp() -> impl Strategy<Value = i64> + Clone {
    (0..100_000_000_000i64).prop_map(|micros| micros * 1_000)
}

/// Any valid frame: classic data (with a raw DLC 9-F on some 8-byte ones),
/// remote (the same), CAN FD with any flags nibble, error frames.
fn frame() -> impl Strategy<Value = Frame> {
    common::any_frame(timestamp(), iface())
}

fn write_all(frames: &[Frame]) -> Vec<u8> {
    let mut writer = CandumpWriter::new(Vec::new());
    for frame in frames {
        writer.write_frame(frame).unwrap();
    }
    writer.into_inner()
}

fn read_all(text: &[u8]) -> Vec<Frame> {
    let mut reader = CandumpReader::new(text);
    let mut frames = Vec::new();
    while let Some(record) = reader
        .next_record()
        .unwrap_or_else(|e| panic!("{e} in\n{}", String::from_utf8_lossy(text)))
    {
        frames.push(record.frame);
    }
    frames
}

/// Reads ASC text to the end, through parse errors; it must not panic.
fn drain_asc(bytes: &[u8]) -> usize {
    let mut reader = AscReader::new(bytes);
    let mut frames = 0;
    loop {
        match reader.next_record() {
            Ok(Some(_)) => frames += 1,
            Ok(None) | Err(ReadError::Io(_)) => return frames,
            Err(ReadError::Parse(_)) => {}
        }
    }
}

/// Text made of pieces of log lines, so that random inputs get deep into
/// the parsers rather than failing on the first byte.
fn pieces(pieces: &'static [&'static str], max: usize) -> impl Strategy<Value = String> {
    prop::collection::vec(prop::sample::select(pieces), 0..max).prop_map(|parts| parts.concat())
}

/// A candump line: mostly well-formed pieces in the right order, with
/// junk mixed in, so that many parse and the rest fail late.
fn candump_like() -> impl Strategy<Value = String> {
    let piece =
        |choices: &'static [&'static str]| prop::sample::select(choices).prop_map(str::to_owned);
    let start = prop_oneof![4 => piece(CANDUMP_STARTS), 1 => pieces(CANDUMP_PIECES, 6)];
    let id = prop_oneof![4 => piece(CANDUMP_IDS), 1 => pieces(CANDUMP_PIECES, 3)];
    let byte = prop_oneof![
        8 => prop::sample::select(CANDUMP_BYTES),
        1 => prop::sample::select(CANDUMP_DATA),
    ];
    let data = prop::collection::vec(byte, 0..8).prop_map(|p| p.concat());
    let junk = prop_oneof![4 => Just(String::new()), 1 => pieces(CANDUMP_PIECES, 4)];
    (
        start,
        id,
        piece(CANDUMP_SEPARATORS),
        data,
        junk,
        piece(CANDUMP_ENDS),
    )
        .prop_map(|(start, id, separator, data, junk, end)| {
            [start, id, separator, data, junk, end].concat()
        })
}

#[rustfmt::skip]
const CANDUMP_STARTS: &[&str] = &[
    "(1700000000.123456) can0 ", "(0.5) vcan0 ", "(1.000000)\tcan0\t", "(0000000001.000001) can1 ",
    "(1699999999.123456789) can0 ",
];

#[rustfmt::skip]
const CANDUMP_IDS: &[&str] = &[
    "123", "7FF", "000", "800", "18FEF100", "00000123", "1FFFFFFF", "20000004", "3FFFFFFF",
    "20000000", "12",
];

#[rustfmt::skip]
const CANDUMP_SEPARATORS: &[&str] = &[
    "#", "#", "##0", "##5", "##F", "##", "#R", "#r", "#R8_9",
];

#[rustfmt::skip]
const CANDUMP_BYTES: &[&str] = &["11", "AB", "00", "ff", "7e", "0011223344556677"];

#[rustfmt::skip]
const CANDUMP_DATA: &[&str] = &[
    "11", "AB", "00", "ff", "0011223344556677", ".", "_C", "_9", "_", "8", "R", "5",
];

#[rustfmt::skip]
const CANDUMP_ENDS: &[&str] = &[
    "", "", " R", " T", " X", " R T", "\t",
];

#[rustfmt::skip]
const CANDUMP_PIECES: &[&str] = &[
    "(", ")", "(1700000000.123456)", "(0.5)", "(99999999999999999999.1)", "1.", ".000001", " ",
    "\t", "can0", "vcan0", "#", "##", "R", "r", "_", "_C", "_9", ".", "0", "8", "F", "123", "7FF",
    "800", "18FEF100", "20000004", "3FFFFFFF", "E0000000", "11223344", "AB", "Z", " R", " T", " X",
    "\u{e9}",
];

/// ASC text: header-ish and event-ish lines of log-like pieces.
fn asc_like() -> impl Strategy<Value = String> {
    let line = (
        prop::sample::select(ASC_STARTS),
        prop::collection::vec(prop::sample::select(ASC_PIECES), 0..20),
    )
        .prop_map(|(start, parts)| format!("{start} {}\n", parts.join(" ")));
    prop::collection::vec(line, 0..12).prop_map(|lines| lines.concat())
}

#[rustfmt::skip]
const ASC_STARTS: &[&str] = &[
    "", "date Tue Mar 4 09:15:02.512 am 2025", "base hex timestamps absolute", "base dec",
    "timestamps relative", "Begin Triggerblock", "// c", "0.000000", "1.000000 1", "2.5 2",
    "3.25 CANFD 1 Rx", "4.0 CANFD 2 Tx", "9223372036.854775807 1", "\u{feff}date",
    "1.000000 1 123 Rx d 2", "0.5 2 18FEF100x Tx r", "5.0 1 7FF Rx d 8", "6.0 1 ErrorFrame",
    "3.25 CANFD 1 Rx 123 1 0 8 8", "4.0 CANFD 2 Tx 7FFx Name 1 1 9 12", "7.0 CANFD 3 Rx 5x 0 0 5 0",
];

#[rustfmt::skip]
const ASC_PIECES: &[&str] = &[
    "\r", "\t", "date", "Tue", "Mar", "Feb", "29", "4", "09:15:02.512", "12:00:00", "am", "pm",
    "2025", "2024", "base", "hex", "dec", "timestamps", "relative", "absolute", "internal",
    "events", "logged", "no", "Begin", "Triggerblock", "End", "//", "0.000000", "1.000000",
    "9223372036.854775807", "99999999999.9", "0.5", "1", "2", "0", "18446744073709551616", "CANFD",
    "Rx", "Tx", "TxRq", "d", "r", "8", "D", "F", "64", "12", "c", "FF", "00", "255", "123", "7FF",
    "800", "18FEF100x", "20000000x", "x", "ErrorFrame", "Statistic:", "Start", "Length", "=",
    "272000", "Name", "323000", "200050", "320000", "\u{e4}",
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn candump_logs_round_trip_every_frame(frames in prop::collection::vec(frame(), 0..40)) {
        let text = write_all(&frames);
        let mut pushed = Vec::new();
        for frame in &frames {
            candump::push_line(&mut pushed, frame).unwrap();
        }
        prop_assert_eq!(&pushed, &text, "CandumpWriter and push_line disagree");

        let read = read_all(&text);
        prop_assert_eq!(&read, &frames, "in\n{}", String::from_utf8_lossy(&text));
        prop_assert_eq!(write_all(&read), text);
    }

    #[test]
    fn asc_logs_round_trip_every_frame_they_can_hold(mut frames in prop::collection::vec(frame(), 0..40)) {
        frames.sort_by_key(|f| f.timestamp_ns);
        let mut writer = AscWriter::new(Vec::new());
        for frame in &frames {
            writer.write_frame(frame).unwrap();
        }
        let text = writer.finish().unwrap();
        let mut reader = AscReader::new(&text[..]);
        let mut read = Vec::new();
        while let Some(record) = reader
            .next_record()
            .unwrap_or_else(|e| panic!("{e} in\n{}", String::from_utf8_lossy(&text)))
        {
            read.push(record.frame);
        }
        // What ASC cannot hold: a missing direction (written Rx), an error
        // frame's class and details, an FD frame without the FDF flag.
        let expected: Vec<Frame> = frames
            .iter()
            .map(|frame| {
                let mut expected = *frame;
                match frame.kind {
                    FrameKind::Error { .. } => {
                        expected = Frame::error(frame.timestamp_ns, frame.iface, ERROR_FRAME_CLASS, &[]).unwrap();
                    }
                    FrameKind::Fd { flags } => {
                        // Padded with zeros to the next DLC step.
                        let steps = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64];
                        let length = *steps.iter().find(|&&l| l >= frame.payload().len()).unwrap();
                        let mut padded = frame.payload().to_vec();
                        padded.resize(length, 0);
                        expected = Frame::fd(frame.timestamp_ns, frame.iface, frame.id, fd_flags(flags & 1 != 0, flags & 2 != 0), &padded).unwrap();
                        expected.direction = Some(frame.direction.unwrap_or(Direction::Received));
                    }
                    _ => expected.direction = Some(frame.direction.unwrap_or(Direction::Received)),
                }
                expected
            })
            .collect();
        prop_assert_eq!(&read, &expected, "in\n{}", String::from_utf8_lossy(&text));
    }

    #[test]
    fn candump_parse_line_never_panics_on_bytes(bytes in prop::collection::vec(any::<u8>(), 0..160)) {
        let _ = candump::parse_line(&bytes);
    }

    #[test]
    fn asc_reader_never_panics_on_bytes(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        drain_asc(&bytes);
    }

    #[test]
    fn asc_reader_never_panics_on_log_like_text(text in asc_like()) {
        drain_asc(text.as_bytes());
    }
}

proptest! {
    // About one line in ten parses: run many.
    #![proptest_config(ProptestConfig::with_cases(4096))]

    #[test]
    fn candump_lines_that_parse_write_back_and_reparse(line in candump_like()) {
        if let Ok((_, frame)) = candump::parse_line(line.as_bytes()) {
            let mut written = Vec::new();
            candump::push_line(&mut written, &frame).unwrap();
            let written_line = written.strip_suffix(b"\n").unwrap();
            let (_, again) = candump::parse_line(written_line)
                .unwrap_or_else(|e| panic!("{line:?} wrote {written:?}, which fails: {e}"));
            // The writer keeps microseconds only.
            let mut expected = frame;
            expected.timestamp_ns -= expected.timestamp_ns % 1_000;
            prop_assert_eq!(again, expected, "{:?}", line);
        }
    }
}

/// A candump log read to its end record by record: the frames and, for
/// each malformed line, its line number.
fn records_and_errors(text: &[u8]) -> (Vec<Frame>, Vec<u64>) {
    let mut reader = CandumpReader::new(text);
    let (mut frames, mut errors) = (Vec::new(), Vec::new());
    loop {
        match reader.next_record() {
            Ok(Some(record)) => frames.push(record.frame),
            Ok(None) | Err(ReadError::Io(_)) => return (frames, errors),
            Err(ReadError::Parse(error)) => errors.push(error.at.number()),
        }
    }
}

/// The same, a batch of up to `max` frames at a time through a buffer of
/// `capacity` bytes, so that lines straddle the buffer's refills.
fn batches_and_errors(text: &[u8], capacity: usize, max: usize) -> (Vec<Frame>, Vec<u64>) {
    let mut reader = CandumpReader::new(std::io::BufReader::with_capacity(capacity, text));
    let mut batch = acq_can::FrameBatch::default();
    let (mut frames, mut errors) = (Vec::new(), Vec::new());
    loop {
        batch.clear();
        let read = reader.next_batch(&mut batch, max);
        frames.extend((0..batch.len()).map(|index| batch.frame(index)));
        match read {
            Ok(true) => {}
            Ok(false) | Err(ReadError::Io(_)) => return (frames, errors),
            Err(ReadError::Parse(error)) => errors.push(error.at.number()),
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// Lines well-formed and not, blank, comments, CRLF, a last line cut
    /// or not: read in batches, the same frames and the same errors at the
    /// same lines as record by record.
    #[test]
    fn candump_batches_read_as_records(
        lines in prop::collection::vec(
            prop_oneof![
                6 => frame().prop_map(|frame| {
                    let mut line = Vec::new();
                    candump::push_line(&mut line, &frame).unwrap();
                    String::from_utf8(line).unwrap()
                }),
                2 => candump_like().prop_map(|line| line + "\n"),
                1 => prop::sample::select(&["\n", "# comment\n", "\r\n", "  \n"][..]).prop_map(str::to_owned),
            ],
            0..30,
        ),
        cut in any::<bool>(),
        capacity in 1usize..200,
        max in 1usize..8,
    ) {
        let mut text = lines.concat().into_bytes();
        if cut && text.len() > 1 {
            text.truncate(text.len() - 1);
        }
        let expected = records_and_errors(&text);
        prop_assert_eq!(batches_and_errors(&text, capacity, max), expected, "in\n{}", String::from_utf8_lossy(&text));
    }
}

#[test]
fn the_asc_generator_makes_frames() {
    // Guards the generator above: its pieces do form frame lines.
    use proptest::strategy::ValueTree;
    let mut runner = proptest::test_runner::TestRunner::deterministic();
    let frames: usize = (0..200)
        .map(|_| {
            drain_asc(
                asc_like()
                    .new_tree(&mut runner)
                    .unwrap()
                    .current()
                    .as_bytes(),
            )
        })
        .sum();
    assert!(frames > 20, "only {frames} frames in 200 texts");
}
