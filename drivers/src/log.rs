//! What every log reader yields, and a reader that picks the format itself.
//!
//! Readers are streaming "lending" readers: a [`LogRecord`] borrows the
//! reader's line buffer so the timestamp can be passed on exactly as written
//! without allocating, and memory stays constant whatever the log's size.

use std::io::{self, BufRead};

use crate::asc::AscReader;
use crate::candump::CandumpReader;
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

/// The log formats `acq` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LogFormat {
    /// can-utils `candump -L` / `canplayer` format.
    Candump,
    /// Vector ASCII log (`.asc`).
    Asc,
}

/// A reader of either format.
pub enum LogReader<R> {
    Candump(CandumpReader<R>),
    Asc(AscReader<R>),
}

impl<R: BufRead> LogReader<R> {
    /// Guesses the format from the first bytes of the input without
    /// consuming them: a candump log starts with `(`, anything else is
    /// taken for ASC (whose header starts with `date` or `base`).
    pub fn detect(mut input: R) -> io::Result<(Self, LogFormat)> {
        let looks_candump = {
            let head = input.fill_buf()?;
            let first = head.iter().find(|b| !b.is_ascii_whitespace());
            first.is_none_or(|&b| b == b'(' || b == b'#')
        };
        Ok(if looks_candump {
            (
                LogReader::Candump(CandumpReader::new(input)),
                LogFormat::Candump,
            )
        } else {
            (LogReader::Asc(AscReader::new(input)), LogFormat::Asc)
        })
    }

    pub fn with_format(input: R, format: LogFormat) -> Self {
        match format {
            LogFormat::Candump => LogReader::Candump(CandumpReader::new(input)),
            LogFormat::Asc => LogReader::Asc(AscReader::new(input)),
        }
    }

    /// The next frame; `Ok(None)` at the end of the log.
    #[inline]
    pub fn next_record(&mut self) -> Result<Option<LogRecord<'_>>, ReadError> {
        match self {
            LogReader::Candump(reader) => reader.next_record(),
            LogReader::Asc(reader) => reader.next_record(),
        }
    }
}
