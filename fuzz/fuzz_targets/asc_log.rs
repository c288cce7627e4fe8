//! The ASC reader over arbitrary bytes, to the end of the input, through
//! parse errors: it must never panic, and what it yields must be sane.

#![no_main]

use acq_can::log::asc::AscReader;
use acq_can::ReadError;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut reader = AscReader::new(data);
    let mut last_line = 0;
    loop {
        match reader.next_record() {
            Ok(Some(record)) => {
                assert!(record.line > last_line);
                last_line = record.line;
                let text = record.timestamp_text;
                assert!(!text.is_empty() && text.iter().all(|&b| b.is_ascii_digit() || b == b'.'));
                assert!(record.frame.payload().len() <= 64);
            }
            Ok(None) | Err(ReadError::Io(_)) => break,
            Err(ReadError::Parse(e)) => {
                assert!(e.at.number() > last_line);
                last_line = e.at.number();
            }
        }
    }
});
