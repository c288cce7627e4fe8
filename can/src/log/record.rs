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
#[error("line {line}: expected {expected}{}", note.as_deref().map(|n| format!("; {n}")).unwrap_or_default())]
pub struct ParseError {
    /// 1-based line number.
    pub line: u64,
    /// What the reader expected there, in words.
    pub expected: &'static str,
    /// What was found instead, when the reader can say (how much of a cut
    /// file is missing).
    pub note: Option<String>,
}

impl ParseError {
    /// A line that is not what `expected` says.
    pub fn new(line: u64, expected: &'static str) -> Self {
        ParseError {
            line,
            expected,
            note: None,
        }
    }

    /// `file:line: expected ...`, the form every command reports.
    pub fn in_file(&self, name: &str) -> String {
        match &self.note {
            Some(note) => format!("{name}:{}: expected {}; {note}", self.line, self.expected),
            None => format!("{name}:{}: expected {}", self.line, self.expected),
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
