//! The BLF reader over arbitrary bytes, to the end of the input, through
//! parse errors: it must never panic or loop, and what it yields must be
//! sane. (Seeds: python-can's BLF files, zlib and stored containers.)

#![no_main]

use acq_can::log::blf::BlfReader;
use acq_can::ReadError;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut reader = BlfReader::new(data);
    let mut last_object = 0;
    // Each frame or error is an object of at least 16 bytes, of the input or
    // of what its containers inflate to (zlib: at most about 1032 to 1).
    let most = data.len().saturating_mul(1100) / 16 + 4;
    for _ in 0..most {
        match reader.next_record() {
            Ok(Some(record)) => {
                assert!(record.line >= last_object);
                last_object = record.line;
                let text = record.timestamp_text;
                assert!(!text.is_empty() && text.iter().all(|&b| b.is_ascii_digit() || b == b'.'));
                assert!(record.frame.timestamp_ns >= 0);
                assert!(record.frame.payload().len() <= 64);
            }
            Ok(None) | Err(ReadError::Io(_)) => return,
            Err(ReadError::Parse(e)) => {
                assert!(e.at.number() >= last_object);
                last_object = e.at.number();
            }
        }
    }
    panic!(
        "the reader did not end within {most} records on {} bytes",
        data.len()
    );
});
