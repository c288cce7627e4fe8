//! Vector ASC logs (placeholder being written: see `log.rs` for the interface).

use std::io::BufRead;

use crate::log::{LogRecord, ReadError};

/// Streaming reader of Vector ASC logs.
pub struct AscReader<R> {
    input: R,
}

impl<R: BufRead> AscReader<R> {
    pub fn new(input: R) -> Self {
        AscReader { input }
    }

    pub fn next_record(&mut self) -> Result<Option<LogRecord<'_>>, ReadError> {
        let _ = &mut self.input;
        Ok(None)
    }
}
