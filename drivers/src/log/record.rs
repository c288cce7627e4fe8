//! What every log reader yields: a record borrowed from the reader's line
//! buffer, and the errors of reading one. No reader is named here, so every
//! reader can depend on this module and nothing depends back.

use std::io;

use crate::frame::Frame;

/// One frame read from a log.
#[derive(Debug)]
pub struct LogRecord<'a> {
    /// 1-based line number in the log.
    pub line: u64,
    /// The timestamp exactly as the log writes it (`1700000000.123456` in a
    /// candump log, `12.345678` seconds from the start in an ASC file).
    pub timestamp_text: &'a str,
    pub frame: Frame,
}

/// A line that is not a valid record.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("line {line}: expected {expected}")]
pub struct ParseError {
    /// 1-based line number.
    pub line: u64,
    /// What the reader expected there, in words.
    pub expected: &'static str,
}

impl ParseError {
    /// `file:line: expected ...`, the form every command reports.
    pub fn in_file(&self, name: &str) -> String {
        format!("{name}:{}: expected {}", self.line, self.expected)
    }
}

/// Reading a log failed: the file could not be read, or a line is malformed.
/// After a `Parse` error the reader can go on with the next line.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error(transparent)]
    Io(#[from] io::Error),
    #[error(transparent)]
    Parse(#[from] ParseError),
}
