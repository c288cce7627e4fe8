//! The MF4 reader over arbitrary bytes, to the end of the input, through
//! parse errors: it must never panic or loop, and what it yields must be
//! sane; read column by column, in batches of 3, it must yield the same
//! frames and errors. (Seeds: python-can's MF4 files, stored, deflated and
//! transposed, and one of acq's writer.)

#![no_main]

use acq_can::log::mf4::Mf4Reader;
use acq_can::{Frame, FrameBatch, ReadError};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut reader = Mf4Reader::new(data);
    // Each frame or error is a record of at least one byte, of the input or
    // of what its DZ blocks inflate to (deflate: at most about 1032 to 1).
    let most = data.len().saturating_mul(1100) + 4;
    let mut frames: Vec<Frame> = Vec::new();
    let mut errors = 0;
    let mut ended = false;
    for _ in 0..most {
        match reader.next_record() {
            Ok(Some(record)) => {
                frames.push(record.frame);
                let text = record.timestamp_text;
                assert!(
                    !text.is_empty()
                        && text
                            .iter()
                            .all(|&b| b.is_ascii_digit() || b == b'.' || b == b'-')
                );
                assert!(record.frame.payload().len() <= 64);
            }
            Ok(None) | Err(ReadError::Io(_)) => {
                ended = true;
                break;
            }
            Err(ReadError::Parse(_)) => errors += 1,
        }
    }
    assert!(
        ended,
        "the reader did not end within {most} records on {} bytes",
        data.len()
    );
    let mut reader = Mf4Reader::new(data);
    let mut batch = FrameBatch::default();
    let mut batched: Vec<Frame> = Vec::new();
    let mut batch_errors = 0;
    for _ in 0..most {
        batch.clear();
        let next = reader.next_batch(&mut batch, 3);
        batched.extend((0..batch.len()).map(|index| batch.frame(index)));
        match next {
            Ok(true) => {}
            Ok(false) | Err(ReadError::Io(_)) => break,
            Err(ReadError::Parse(_)) => batch_errors += 1,
        }
    }
    assert_eq!(batched, frames, "column by column");
    assert_eq!(batch_errors, errors, "column by column");
});
