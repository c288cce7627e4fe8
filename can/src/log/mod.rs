//! CAN log files: one module per format, the record type they all yield, and
//! the choice of reader for an input.
//!
//! - [`record`]: [`LogRecord`], [`ParseError`], [`ReadError`]; what every
//!   reader yields. It depends on no reader.
//! - [`candump`], [`asc`], [`blf`], [`mf4`]: the readers (and the candump
//!   writer); each depends only on [`record`] and the frame types.
//!   [`asc_write`], [`mf4_write`]: the ASC and MF4 writers; [`mf4_signals`]:
//!   MF4 files of decoded or aligned signals; [`mf4_blocks`]: the MF4
//!   layout both MF4 writers share.
//! - this module: [`LogFormat`] and [`LogReader`], which detects the format
//!   and dispatches. A new format is a new module beside the readers and one
//!   arm here.
//!
//! Readers are streaming "lending" readers: a [`LogRecord`] borrows the
//! reader's line buffer so the timestamp can be passed on exactly as written
//! without allocating, and memory stays constant whatever the log's size.

pub mod asc;
pub mod asc_write;
pub mod blf;
pub mod candump;
mod inflate;
pub mod mf4;
pub mod mf4_blocks;
pub mod mf4_signals;
pub mod mf4_write;
pub mod record;

use std::io::{self, BufRead};

pub use record::{LogRecord, ParseError, ReadError};

use asc::AscReader;
use blf::BlfReader;
use candump::CandumpReader;
use mf4::Mf4Reader;

/// The log formats `acq` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LogFormat {
    /// can-utils `candump -L` / `canplayer` format.
    Candump,
    /// Vector ASCII log (`.asc`).
    Asc,
    /// Vector binary log (`.blf`).
    Blf,
    /// ASAM MDF 4 bus logging (`.mf4`).
    Mf4,
}

/// A reader of either format.
pub enum LogReader<R> {
    Candump(CandumpReader<R>),
    Asc(AscReader<R>),
    Blf(BlfReader<R>),
    Mf4(Mf4Reader<R>),
}

impl<R: BufRead> LogReader<R> {
    /// Guesses the format from the first bytes of the input without
    /// consuming them: a BLF file starts with `LOGG`, an MF4 file with
    /// `MDF     ` (its identification block), a candump log with
    /// `(`, anything else is taken for ASC (whose header starts with `date`
    /// or `base`).
    pub fn detect(mut input: R) -> io::Result<(Self, LogFormat)> {
        let (looks_blf, looks_mf4, looks_candump) = {
            let head = input.fill_buf()?;
            let first = head.iter().find(|b| !b.is_ascii_whitespace());
            (
                head.starts_with(blf::SIGNATURE),
                head.starts_with(mf4::SIGNATURE),
                first.is_none_or(|&b| b == b'(' || b == b'#'),
            )
        };
        Ok(if looks_mf4 {
            (LogReader::Mf4(Mf4Reader::new(input)), LogFormat::Mf4)
        } else if looks_blf {
            (LogReader::Blf(BlfReader::new(input)), LogFormat::Blf)
        } else if looks_candump {
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
            LogFormat::Blf => LogReader::Blf(BlfReader::new(input)),
            LogFormat::Mf4 => LogReader::Mf4(Mf4Reader::new(input)),
        }
    }

    /// The next frame; `Ok(None)` at the end of the log.
    #[inline]
    pub fn next_record(&mut self) -> Result<Option<LogRecord<'_>>, ReadError> {
        match self {
            LogReader::Candump(reader) => reader.next_record(),
            LogReader::Asc(reader) => reader.next_record(),
            LogReader::Blf(reader) => reader.next_record(),
            LogReader::Mf4(reader) => reader.next_record(),
        }
    }
}
