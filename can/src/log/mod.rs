//! CAN log files: one module per format, the record type they all yield, and
//! the choice of reader for an input.
//!
//! - [`record`]: [`LogRecord`], [`ParseError`], [`ReadError`]; what every
//!   reader yields. It depends on no reader. [`batch`]: [`FrameBatch`],
//!   frames column by column, which [`LogReader::next_batch`] fills.
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
pub mod batch;
pub mod blf;
pub mod candump;
mod inflate;
pub mod mf4;
pub mod mf4_blocks;
pub mod mf4_signals;
pub mod mf4_write;
pub mod record;

use std::io::BufRead;

pub use batch::{FrameBatch, MAX_BATCH_FRAMES};
pub use record::{LogRecord, ParseError, Place, ReadError};

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

/// What the first bytes of an input say it is.
#[derive(Debug, PartialEq, Eq)]
enum Sniffed {
    Format(LogFormat),
    /// Not a CAN log acq reads: what it is, and what to do.
    Refused(String),
}

/// A CANedge logger's container around an MF4 file (`.MFC` compressed,
/// `.MFE` or `.MFM` encrypted): 12 bytes of magic, then the container's
/// version, its type and sub-type (CSS Electronics' mdf4-converters,
/// `GenericFile`).
const CANEDGE_CONTAINER: &[u8; 12] = b"Generic File";

/// What the input's first bytes say (at most a buffer's worth; 20 bytes
/// suffice for every signature).
fn sniff(head: &[u8]) -> Sniffed {
    let first = head.iter().find(|b| !b.is_ascii_whitespace());
    // MDF 3 shares MDF 4's first bytes; its version text (bytes 8..16)
    // starts with 3.
    if head.starts_with(mf4::SIGNATURE) && head.get(8) == Some(&b'3') {
        return Sniffed::Refused(format!(
            "an MDF file of version {:?}, not MDF 4: acq reads MDF 4 bus logging (convert it to MF4 with asammdf)",
            String::from_utf8_lossy(head.get(8..16).unwrap_or_default()).trim()
        ));
    }
    if head.starts_with(mf4::SIGNATURE) || head.starts_with(mf4::UNFINALIZED_SIGNATURE) {
        return Sniffed::Format(LogFormat::Mf4);
    }
    if head.starts_with(blf::SIGNATURE) {
        return Sniffed::Format(LogFormat::Blf);
    }
    if head.starts_with(CANEDGE_CONTAINER) {
        let what = match head.get(14) {
            Some(0x22) => "a CANedge logger's compressed MF4 container (.MFC, heatshrink): convert it to MF4 with CSS Electronics' mdf2finalized (or to candump with mdf2socketcan), then read that",
            Some(0x11) => "a CANedge logger's encrypted MF4 container (.MFE/.MFM, AES-GCM): decrypt and convert it with CSS Electronics' mdf2finalized and the device's password, then read that",
            _ => "a CANedge logger's container of an unknown type: convert it with CSS Electronics' mdf2finalized, then read that",
        };
        return Sniffed::Refused(what.into());
    }
    if first.is_none_or(|&b| b == b'(' || b == b'#') {
        return Sniffed::Format(LogFormat::Candump);
    }
    // Text, but none of the above: ASC's reader says what its header
    // lacks. Binary bytes are no ASC.
    if head.iter().take(4096).any(|&b| b == 0) {
        let shown: Vec<String> = head.iter().take(8).map(|b| format!("{b:02x}")).collect();
        return Sniffed::Refused(format!(
            "binary data (first bytes {}) that no format acq reads starts with",
            shown.join(" ")
        ));
    }
    Sniffed::Format(LogFormat::Asc)
}

/// What a log must start with, for the message of a refused one.
const E_LOG_FORMAT: &str = "a CAN log acq reads: MF4 ('MDF     ' or 'UnFinMF '), BLF ('LOGG'), candump ('(') or Vector ASC (text)";

impl<R: BufRead> LogReader<R> {
    /// Tells the format from the first bytes of the input without
    /// consuming them: an MF4 file starts with `MDF     ` (`UnFinMF ` when
    /// its writer could not finalize it), a BLF file with `LOGG`, a candump
    /// log with `(`; other text is taken for ASC (whose header starts with
    /// `date` or `base`). A logger's container, an MDF 3 file or binary
    /// data of no known format is refused at byte offset 0, saying what it
    /// is and what converts it.
    pub fn detect(mut input: R) -> Result<(Self, LogFormat), ReadError> {
        let sniffed = sniff(input.fill_buf()?);
        match sniffed {
            Sniffed::Format(format) => Ok((LogReader::with_format(input, format), format)),
            Sniffed::Refused(what) => Err(ReadError::Parse(ParseError {
                note: Some(format!("found {what}")),
                ..ParseError::at(Place::ByteOffset(0), E_LOG_FORMAT)
            })),
        }
    }

    pub fn with_format(input: R, format: LogFormat) -> Self {
        match format {
            LogFormat::Candump => LogReader::Candump(CandumpReader::new(input)),
            LogFormat::Asc => LogReader::Asc(AscReader::new(input)),
            LogFormat::Blf => LogReader::Blf(BlfReader::new(input)),
            LogFormat::Mf4 => LogReader::Mf4(Mf4Reader::new(input)),
        }
    }

    /// Tells the reader the input's length in bytes, where its opener
    /// knows it (a file's metadata): an MF4 file read group by group side
    /// by side is then kept in memory in one allocation.
    pub fn expect_len(&mut self, bytes: u64) {
        if let LogReader::Mf4(reader) = self {
            reader.expect_len(bytes);
        }
    }

    /// What the reader has to tell that is no error (a record cut off at
    /// the end of an unfinalized MF4 file), taken once.
    pub fn take_notes(&mut self) -> Vec<String> {
        match self {
            LogReader::Mf4(reader) => reader.take_notes(),
            _ => Vec::new(),
        }
    }

    /// Reads up to `max` more frames into `batch`, column by column;
    /// `Ok(false)` once the log has ended. A batch holds at most
    /// [`MAX_BATCH_FRAMES`]: clear it between calls. After an `Err` the
    /// frames read before it are in `batch`, and reading goes on as after
    /// [`LogReader::next_record`]'s.
    pub fn next_batch(&mut self, batch: &mut FrameBatch, max: usize) -> Result<bool, ReadError> {
        let end = batch.len().saturating_add(max).min(MAX_BATCH_FRAMES);
        match self {
            LogReader::Mf4(reader) => return reader.next_batch(batch, end),
            LogReader::Candump(reader) => return reader.next_batch(batch, end),
            _ => {}
        }
        while batch.len() < end {
            match self.next_record()? {
                Some(record) => batch.push(&record.frame),
                None => return Ok(false),
            }
        }
        Ok(true)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_format_is_told_by_its_first_bytes() {
        let cases: [(&[u8], LogFormat); 6] = [
            (b"MDF     4.10    ", LogFormat::Mf4),
            (b"UnFinMF 4.11    ", LogFormat::Mf4),
            (b"LOGG\x90\x00\x00\x00", LogFormat::Blf),
            (b"(1700000000.000000) can0 123#", LogFormat::Candump),
            (b"\n\n", LogFormat::Candump),
            (
                b"date Mon Nov 24 10:00:00.000 am 2025\nbase hex",
                LogFormat::Asc,
            ),
        ];
        for (head, format) in cases {
            assert_eq!(sniff(head), Sniffed::Format(format), "{head:?}");
        }
    }

    #[test]
    fn a_container_an_mdf3_file_and_binary_data_are_refused_by_name() {
        let mut compressed = b"Generic File".to_vec();
        compressed.extend_from_slice(&[1, 0, 0x22, 0x01, 0, 0, 0, 1]);
        let mut encrypted = compressed.clone();
        encrypted[14] = 0x11;
        let said = |head: &[u8]| match sniff(head) {
            Sniffed::Refused(what) => what,
            other => panic!("{head:?} read as {other:?}"),
        };
        assert!(said(&compressed).contains(".MFC") && said(&compressed).contains("mdf2finalized"));
        assert!(said(&encrypted).contains("password"));
        assert!(said(b"MDF     3.30    ").contains("\"3.30\""));
        assert!(said(b"\x7fELF\x02\x01\x01\x00").contains("7f 45 4c 46"));
        let error = match LogReader::detect(&compressed[..]) {
            Err(ReadError::Parse(error)) => error,
            other => panic!("{:?}", other.map(|(_, format)| format)),
        };
        let message = error.in_file("00000001.MFC");
        assert!(
            message.starts_with("00000001.MFC: byte offset 0: expected a CAN log acq reads")
                && message.contains("found a CANedge logger's compressed MF4 container"),
            "{message}"
        );
    }
}
