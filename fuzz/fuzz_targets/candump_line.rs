//! `candump::parse_line` on arbitrary bytes; a line that parses must write
//! back and re-parse to the same frame (timestamps to the microsecond, the
//! format's resolution), and the second writing must be identical.

#![no_main]

use acq_can::log::candump;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The short way for the usual line reads what the long way reads.
    if let Some(usual) = candump::parse_usual_line(data) {
        match (acq_can::IfaceName::from_bytes(usual.iface), candump::parse_line(data)) {
            (Some(iface), Ok((_, frame))) => {
                assert_eq!(frame.timestamp_ns, usual.timestamp_ns);
                assert_eq!(frame.iface, iface);
                assert_eq!(frame.id, usual.id);
                assert_eq!(frame.payload(), &usual.data[..usual.len]);
                assert_eq!(frame.direction, usual.direction);
                assert!(matches!(frame.kind, acq_can::FrameKind::Data { len8_dlc: None }));
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
