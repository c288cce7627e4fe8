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
    /// candump log, `12.345678` seconds from the start in an ASC file):
    /// ASCII digits, a dot, perhaps a minus sign. Bytes, not a `str`: a
    /// reader has checked them, and checking them again as UTF-8 was a
    /// thirtieth of a CSV decode.
    pub timestamp_text: &'a [u8],
    pub frame: Frame,
}

/// Where in a log a reader stopped: a text log's line, a binary log's
/// object or byte offset. Each is said in its own words, so that a byte
/// offset is never read as a line number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// A 1-based line of a text log (candump, ASC).
    Line(u64),
    /// A 1-based object of a BLF file (counting those inside containers).
    Object(u64),
    /// A byte offset from the start of a binary file (MF4's blocks).
    ByteOffset(u64),
}

impl Place {
    /// The number, whatever it counts (readers' places only grow).
    pub fn number(self) -> u64 {
        match self {
            Place::Line(n) | Place::Object(n) | Place::ByteOffset(n) => n,
        }
    }
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Place::Line(n) => write!(f, "line {n}"),
            Place::Object(n) => write!(f, "object {n}"),
            Place::ByteOffset(n) => write!(f, "byte offset {n}"),
        }
    }
}

/// A record that is not valid, and where.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{at}: expected {expected}{}", note.as_deref().map(|n| format!("; {n}")).unwrap_or_default())]
pub struct ParseError {
    /// Where the reader stopped.
    pub at: Place,
    /// What the reader expected there, in words.
    pub expected: &'static str,
    /// What was found instead, when the reader can say (how much of a cut
    /// file is missing).
    pub note: Option<String>,
}

impl ParseError {
    /// A line (1-based) that is not what `expected` says.
    pub fn new(line: u64, expected: &'static str) -> Self {
        ParseError::at(Place::Line(line), expected)
    }

    /// A place that is not what `expected` says.
    pub fn at(at: Place, expected: &'static str) -> Self {
        ParseError {
            at,
            expected,
            note: None,
        }
    }

    /// The line of a text log's error; `None` for a binary log's.
    pub fn line(&self) -> Option<u64> {
        match self.at {
            Place::Line(n) => Some(n),
            _ => None,
        }
    }

    /// The form every command reports: `file:line: expected ...` for a
    /// text log (as compilers write it, so that editors jump there),
    /// `file: byte offset N: expected ...` (or `object N`) for a binary one.
    pub fn in_file(&self, name: &str) -> String {
        let note = self
            .note
            .as_deref()
            .map(|n| format!("; {n}"))
            .unwrap_or_default();
        match self.at {
            Place::Line(n) => format!("{name}:{n}: expected {}{note}", self.expected),
            at => format!("{name}: {at}: expected {}{note}", self.expected),
        }
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

/// A binary log's time written out as `seconds.nanoseconds` (nine digits;
/// a minus sign before a negative time), for [`LogRecord::timestamp_text`].
/// The seconds change once in thousands of frames, so their digits are
/// kept and only the nanoseconds are rewritten.
#[derive(Debug, Default)]
pub(crate) struct TimeText {
    text: String,
    /// The sign and whole seconds `text` starts with, and how many bytes
    /// they take.
    seconds: Option<(bool, u64, usize)>,
}

impl TimeText {
    pub fn set(&mut self, ns: i64) -> &str {
        let negative = ns < 0;
        let magnitude = ns.unsigned_abs();
        let whole = magnitude / 1_000_000_000;
        let prefix = match self.seconds {
            Some((was_negative, was, prefix)) if was_negative == negative && was == whole => prefix,
            _ => {
                self.text.clear();
                if negative {
                    self.text.push('-');
                }
                self.text.push_str(itoa::Buffer::new().format(whole));
                self.seconds = Some((negative, whole, self.text.len()));
                self.text.len()
            }
        };
        self.text.truncate(prefix);
        let mut nanos = magnitude % 1_000_000_000;
        let mut digits = *b".000000000";
        for digit in digits[1..].iter_mut().rev() {
            *digit = b'0' + (nanos % 10) as u8;
            nanos /= 10;
        }
        // Only ASCII digits and a dot.
        self.text
            .push_str(std::str::from_utf8(&digits).unwrap_or_default());
        &self.text
    }
}

#[cfg(test)]
mod tests {
    use super::TimeText;

    #[test]
    fn times_are_sign_seconds_and_nine_digits() {
        let mut text = TimeText::default();
        for (ns, expected) in [
            (0, "0.000000000"),
            (1_500_000_000, "1.500000000"),
            (1_999_999_999, "1.999999999"),
            (2_000_000_001, "2.000000001"),
            (-1, "-0.000000001"),
            (-1_500_000_000, "-1.500000000"),
            (1_700_000_000_123_456_789, "1700000000.123456789"),
            (i64::MIN, "-9223372036.854775808"),
            (i64::MAX, "9223372036.854775807"),
        ] {
            assert_eq!(text.set(ns), expected);
            // Other nanoseconds in the same second: only they change.
            let whole = ns - ns % 1_000_000_000;
            let again = if ns < 0 { whole - 123 } else { whole + 123 };
            let fresh = TimeText::default().set(again).to_owned();
            assert_eq!(text.set(again), fresh);
            assert_eq!(fresh[..fresh.len() - 9], expected[..expected.len() - 9]);
        }
    }
}
