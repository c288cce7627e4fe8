//! `candump::parse_line` on arbitrary bytes; a line that parses must write
//! back and re-parse to the same frame (timestamps to the microsecond, the
//! format's resolution), and the second writing must be identical. The
//! bytes as lines held in memory read as the streaming reader reads them.

#![no_main]

use std::cell::RefCell;
use std::ops::ControlFlow;

use acq_can::log::candump;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // Lines in memory, read as the streaming reader reads them.
    let in_memory = RefCell::new(Vec::new());
    let lines = candump::read_whole_lines(
        data,
        |frame| {
            let fields = frame.fields;
            let read = (
                frame.line,
                frame.timestamp_text.to_vec(),
                frame.iface,
                frame.direction,
            );
            in_memory.borrow_mut().push(Ok((
                read,
                fields.timestamp_ns,
                fields.id,
                fields.kind,
                fields.payload.to_vec(),
            )));
        },
        |error| {
            in_memory.borrow_mut().push(Err(error));
            ControlFlow::Continue(())
        },
    );
    let mut reader = candump::CandumpReader::new(data);
    let mut streamed = Vec::new();
    loop {
        match reader.next_record() {
            Ok(Some(record)) => {
                let frame = &record.frame;
                let read = (
                    record.line,
                    record.timestamp_text.to_vec(),
                    frame.iface,
                    frame.direction,
                );
                streamed.push(Ok((
                    read,
                    frame.timestamp_ns,
                    frame.id,
                    frame.kind,
                    frame.payload().to_vec(),
                )));
            }
            Ok(None) => break,
            Err(acq_can::ReadError::Parse(error)) => streamed.push(Err(error)),
            Err(error) => panic!("a slice read: {error}"),
        }
    }
    assert_eq!(
        in_memory.into_inner(),
        streamed,
        "{:?}",
        String::from_utf8_lossy(data)
    );
    assert_eq!(lines, reader.line());

    // The short way for the usual line reads what the long way reads.
    if let Some(usual) = candump::parse_usual_line(data) {
        match (
            acq_can::IfaceName::from_bytes(usual.iface),
            candump::parse_line(data),
        ) {
            (Some(iface), Ok((_, frame))) => {
                assert_eq!(frame.timestamp_ns, usual.timestamp_ns);
                assert_eq!(frame.iface, iface);
                assert_eq!(frame.id, usual.id);
                assert_eq!(frame.payload(), &usual.data[..usual.len]);
                assert_eq!(frame.direction, usual.direction);
                assert!(matches!(
                    frame.kind,
                    acq_can::FrameKind::Data { len8_dlc: None }
                ));
            }
            (None, Err(_)) => {}
            (iface, parsed) => panic!(
                "{:?}: the short way read {usual:?} (interface {iface:?}), parse_line {parsed:?}",
                String::from_utf8_lossy(data)
            ),
        }
    }
    let Ok((timestamp, frame)) = candump::parse_line(data) else {
        return;
    };
    assert!(timestamp.0 <= timestamp.1 && timestamp.1 <= data.len());

    let mut written = Vec::new();
    candump::push_line(&mut written, &frame).expect("a parsed timestamp is never negative");
    let line = written
        .strip_suffix(b"\n")
        .expect("push_line ends the line");
    let (_, again) = candump::parse_line(line).unwrap_or_else(|e| {
        panic!(
            "{:?} was written as {:?}, which does not parse: {e}",
            String::from_utf8_lossy(data),
            String::from_utf8_lossy(line)
        )
    });
    let mut expected = frame;
    expected.timestamp_ns -= expected.timestamp_ns % 1_000;
    assert_eq!(again, expected, "{:?}", String::from_utf8_lossy(data));

    let mut rewritten = Vec::new();
    candump::push_line(&mut rewritten, &again).expect("same timestamp as before");
    assert_eq!(rewritten, written);
});
