//! Reads the CANalyzer-style sample log and checks every frame in it.

use std::fs::File;
use std::io::BufReader;
use std::path::PathBuf;

use acq_can::frame::fd_flags;
use acq_can::log::asc::{AscReader, ERROR_FRAME_CLASS};
use acq_can::{CanId, Direction, FrameKind, IfaceName, LogFormat, LogReader};

/// `date Tue Mar 4 09:15:02.512 am 2025`, taken as UTC.
const START_NS: i64 = 1_741_079_702_512_000_000;

fn sample_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/logs/excavator_sample.asc")
}

struct Expected {
    line: u64,
    time: &'static str,
    iface: &'static str,
    id: CanId,
    kind: FrameKind,
    direction: Option<Direction>,
    payload: Vec<u8>,
}

#[rustfmt::skip]
fn expected() -> Vec<Expected> {
    use Direction::{Received as Rx, Transmitted as Tx};
    let data = |len8_dlc| FrameKind::Data { len8_dlc };
    let error = FrameKind::Error {
        class: ERROR_FRAME_CLASS,
    };
    let e = |line, time, iface, id, kind, direction, payload: &[u8]| Expected {
        line,
        time,
        iface,
        id,
        kind,
        direction,
        payload: payload.to_vec(),
    };
    vec![
        e(10, "0.010214", "can0", CanId::Extended(0x18FE_F100), data(None), Some(Rx),
          &[0xFF, 0xFF, 0x00, 0x12, 0x34, 0xFF, 0xFF, 0xFF]),
        e(11, "0.010498", "can0", CanId::Standard(0x181), data(None), Some(Rx),
          &[0xA0, 0x0F, 0x00, 0x00, 0x10, 0x27, 0x00, 0x00]),
        e(12, "0.012870", "can0", CanId::Standard(0x281), data(None), Some(Rx),
          &[0xE8, 0x03, 0xF4, 0x01, 0x00, 0x00]),
        e(13, "0.015003", "can1", CanId::Extended(0x0CFE_6C17), data(None), Some(Rx),
          &[0x00, 0x7D, 0xFF, 0xFF, 0x00, 0x00, 0xFF, 0xFF]),
        e(14, "0.020117", "can0", CanId::Standard(0x701), data(None), Some(Rx), &[0x05]),
        e(15, "0.025100", "can0", CanId::Standard(0x601),
          FrameKind::Remote { requested_len: 8, len8_dlc: None }, Some(Tx), &[]),
        e(16, "0.030441", "can2", CanId::Extended(0x1A3),
          FrameKind::Fd { flags: fd_flags(true, false) }, Some(Rx),
          &[0x1F, 0x40, 0x00, 0x00, 0x88, 0x13, 0x00, 0x00, 0xE8, 0x03, 0x00, 0x00,
            0x10, 0x27, 0x00, 0x00, 0x64, 0x00, 0xC8, 0x00, 0x2C, 0x01, 0x90, 0x01]),
        // A classic frame on the FD channel (flags 0x320000: no EDL).
        e(17, "0.030612", "can2", CanId::Standard(0x0C1), data(None), Some(Rx),
          &[0x10, 0x00, 0x20, 0x00, 0x30, 0x00, 0x40, 0x00]),
        e(18, "0.031002", "can0", CanId::Extended(ERROR_FRAME_CLASS), error, None, &[0; 8]),
        e(19, "0.031502", "can1", CanId::Extended(ERROR_FRAME_CLASS), error, None, &[0; 8]),
        e(25, "1.020311", "can0", CanId::Extended(0x18FE_F100), data(None), Some(Rx),
          &[0xFF, 0xFF, 0x00, 0x13, 0x34, 0xFF, 0xFF, 0xFF]),
        e(26, "1.020600", "can0", CanId::Standard(0x3FF), data(Some(0xD)), Some(Tx),
          &[0x55, 0xAA, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06]),
    ]
}

#[test]
fn every_frame_of_the_sample_reads_back() {
    let file = File::open(sample_path()).expect("fixtures/logs/excavator_sample.asc");
    let mut reader = AscReader::new(BufReader::new(file));
    let mut count = 0;
    for want in expected() {
        let record = reader
            .next_record()
            .unwrap_or_else(|e| panic!("before line {}: {e}", want.line))
            .unwrap_or_else(|| panic!("log ended before line {}", want.line));
        let at = format!("line {}", want.line);
        assert_eq!(record.line, want.line, "{at}");
        assert_eq!(record.timestamp_text, want.time.as_bytes(), "{at}");
        let seconds: f64 = want.time.parse().unwrap();
        let offset_ns = (seconds * 1e9).round() as i64;
        let frame = record.frame;
        assert_eq!(frame.timestamp_ns, START_NS + offset_ns, "{at}");
        assert_eq!(frame.iface, IfaceName::new(want.iface).unwrap(), "{at}");
        assert_eq!(frame.id, want.id, "{at}");
        assert_eq!(frame.kind, want.kind, "{at}");
        assert_eq!(frame.direction, want.direction, "{at}");
        assert_eq!(frame.payload(), want.payload.as_slice(), "{at}");
        count += 1;
    }
    assert!(
        reader.next_record().unwrap().is_none(),
        "no frame after line 26"
    );
    assert_eq!(count, 12);
    assert_eq!(reader.line(), 27);
}

#[test]
fn log_reader_detects_the_sample_as_asc() {
    let file = File::open(sample_path()).unwrap();
    let (mut reader, format) = LogReader::detect(BufReader::new(file)).unwrap();
    assert_eq!(format, LogFormat::Asc);
    let mut frames = 0;
    while let Some(record) = reader.next_record().unwrap() {
        assert!(record.frame.timestamp_ns >= START_NS);
        frames += 1;
    }
    assert_eq!(frames, 12);
}
