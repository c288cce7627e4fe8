//! The MF4 reader over arbitrary bytes, to the end of the input, through
//! parse errors: it must never panic or loop, and what it yields must be
//! sane. (Seeds: python-can's MF4 files, stored, deflated and transposed,
//! and one of acq's writer.)

#![no_main]

use acq_can::log::mf4::Mf4Reader;
use acq_can::ReadError;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut reader = Mf4Reader::new(data);
    // Each frame or error is a record of at least one byte, of the input or
    // of what its DZ blocks inflate to (deflate: at most about 1032 to 1).
    let most = data.len().saturating_mul(1100) + 4;
    for _ in 0..most {
        match reader.next_record() {
            Ok(Some(record)) => {
                let text = record.timestamp_text;
                assert!(
                    !text.is_empty()
                        && text.bytes().all(|b| b.is_ascii_digit() || b == b'.' || b == b'-')
                );
                assert!(record.frame.payload().len() <= 64);
            }
            Ok(None) | Err(ReadError::Io(_)) => return,
            Err(ReadError::Parse(_)) => {}
        }
    }
    panic!("the reader did not end within {most} records on {} bytes", data.len());
});
