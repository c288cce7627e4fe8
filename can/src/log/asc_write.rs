//! Writing Vector ASC logs, in the layout python-can's `ASCWriter` uses (so
//! python-can's and acq's readers both take them):
//!
//! ```text
//! date Tue Nov 24 09:15:02.512 pm 2026
//! base hex  timestamps absolute
//! internal events logged
//! // version 9.0.0
//! Begin Triggerblock Tue Nov 24 09:15:02.512 pm 2026
//!    0.000000000 Start of measurement
//!    0.010214000 1  18FEF100x       Rx   d 8 FF FF 00 12 34 FF FF FF
//!    0.030441000 CANFD   2 Rx   1A3x                                   1 0 c 24 <24 bytes>        0    0     3000        0        0        0        0        0
//! End TriggerBlock
//! ```
//!
//! - The `date` is the first frame's time, to the millisecond below it (the
//!   header has millisecond resolution); every time after it is written in
//!   nanoseconds (9 decimals), so a frame's timestamp survives exactly.
//! - Interface `canN` is channel `N+1` (python-can's convention). Any other
//!   name gets the lowest free channel and a comment line `// acq channel K
//!   = NAME` before its first frame, which acq's reader uses to give the
//!   frames their name back; other readers skip comment lines.
//! - A frame without a direction is written `Rx`.
//! - A CAN FD payload whose length is not a DLC step (a candump log may
//!   hold one; the bus cannot) is padded with zeros to the next step.
//! - CAN FD frames carry the `<flags>` column: EDL (0x1000), BRS (0x2000),
//!   ESI (0x4000), as python-can writes them.
//! - Error frames are written `ErrorFrame`: ASC has no field for the Linux
//!   error class, detail bytes or direction, so they do not survive (the
//!   reader gives class `CAN_ERR_BUSERROR`, no details, no direction).

use std::io::{self, Write};

use crate::frame::{
    CanId, Direction, Frame, FrameKind, IfaceName, FD_DLC_LENGTHS, FD_FLAG_BRS, FD_FLAG_ESI,
};

const NANOS_PER_SECOND: i64 = 1_000_000_000;
const NANOS_PER_MILLI: i64 = 1_000_000;

/// A frame ASC cannot hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum AscWriteError {
    #[error("timestamp {0} ns is before 1970: an ASC date cannot say it")]
    BeforeEpoch(i64),
    #[error("timestamp {0} ns is earlier than the log's first frame: ASC times count forward from the date line")]
    BeforeStart(i64),
}

impl From<AscWriteError> for io::Error {
    fn from(error: AscWriteError) -> Self {
        io::Error::new(io::ErrorKind::InvalidData, error)
    }
}

/// Streaming ASC writer: the header goes out with the first frame;
/// [`AscWriter::finish`] ends the trigger block.
pub struct AscWriter<W: Write> {
    output: W,
    start_ns: Option<i64>,
    /// (interface, 1-based channel) in order of first appearance.
    channels: Vec<(IfaceName, u32)>,
    line: Vec<u8>,
}

impl<W: Write> AscWriter<W> {
    pub fn new(output: W) -> Self {
        AscWriter {
            output,
            start_ns: None,
            channels: Vec::new(),
            line: Vec::with_capacity(256),
        }
    }

    /// Appends one frame. Frames must come in time order from the first
    /// one's millisecond on (earlier ones are an error, nothing written).
    pub fn write_frame(&mut self, frame: &Frame) -> io::Result<()> {
        let start_ns = match self.start_ns {
            Some(start) => start,
            None => {
                if frame.timestamp_ns < 0 {
                    return Err(AscWriteError::BeforeEpoch(frame.timestamp_ns).into());
                }
                let start = frame.timestamp_ns - frame.timestamp_ns % NANOS_PER_MILLI;
                self.write_header(start)?;
                self.start_ns = Some(start);
                start
            }
        };
        let offset_ns = frame.timestamp_ns - start_ns;
        if offset_ns < 0 {
            return Err(AscWriteError::BeforeStart(frame.timestamp_ns).into());
        }
        let channel = self.channel(frame.iface)?;
        self.line.clear();
        push_time(&mut self.line, offset_ns);
        push_event(&mut self.line, channel, frame);
        self.output.write_all(&self.line)
    }

    /// The output, to take what was written so far (a buffer the caller
    /// drains).
    pub fn get_mut(&mut self) -> &mut W {
        &mut self.output
    }

    /// Ends the trigger block (an empty log still gets its header) and
    /// returns the output, flushed.
    pub fn finish(mut self) -> io::Result<W> {
        if self.start_ns.is_none() {
            self.write_header(0)?;
        }
        self.output.write_all(b"End TriggerBlock\n")?;
        self.output.flush()?;
        Ok(self.output)
    }

    fn write_header(&mut self, start_ns: i64) -> io::Result<()> {
        let date = asc_date(start_ns);
        write!(
            self.output,
            "date {date}\nbase hex  timestamps absolute\ninternal events logged\n// version 9.0.0\n// written by acq\nBegin Triggerblock {date}\n   0.000000000 Start of measurement\n"
        )
    }

    /// The interface's channel; a new non-`canN` name is announced first.
    fn channel(&mut self, iface: IfaceName) -> io::Result<u32> {
        if let Some(&(_, channel)) = self.channels.iter().find(|(name, _)| *name == iface) {
            return Ok(channel);
        }
        let taken = |channel: u32, channels: &[(IfaceName, u32)]| {
            channels.iter().any(|&(_, c)| c == channel)
        };
        let natural = natural_channel(iface).filter(|&c| !taken(c, &self.channels));
        let channel = match natural {
            Some(channel) => channel,
            None => {
                let channel = (1..).find(|&c| !taken(c, &self.channels)).unwrap_or(1);
                writeln!(self.output, "// acq channel {channel} = {}", iface.as_str())?;
                channel
            }
        };
        self.channels.push((iface, channel));
        Ok(channel)
    }
}

/// `canN` -> channel N+1, the channel the reader maps back to it.
fn natural_channel(iface: IfaceName) -> Option<u32> {
    let digits = iface.as_str().strip_prefix("can")?;
    if digits.is_empty()
        || !digits.bytes().all(|b| b.is_ascii_digit())
        || digits.starts_with('0') && digits.len() > 1
    {
        return None;
    }
    digits.parse::<u32>().ok()?.checked_add(1)
}

/// `   12.345678901 `: seconds with 9 decimals, right-aligned as python-can's.
fn push_time(line: &mut Vec<u8>, offset_ns: i64) {
    let seconds = offset_ns / NANOS_PER_SECOND;
    let nanos = offset_ns % NANOS_PER_SECOND;
    let _ = write!(line, "{seconds:>4}.{nanos:09} ");
}

fn push_id(line: &mut Vec<u8>, id: CanId) -> usize {
    let start = line.len();
    let _ = match id {
        CanId::Standard(raw) => write!(line, "{raw:X}"),
        CanId::Extended(raw) => write!(line, "{raw:X}x"),
    };
    line.len() - start
}

fn push_bytes(line: &mut Vec<u8>, bytes: &[u8]) {
    for byte in bytes {
        let _ = write!(line, " {byte:02X}");
    }
}

fn direction(frame: &Frame) -> &'static str {
    match frame.direction {
        Some(Direction::Transmitted) => "Tx",
        _ => "Rx",
    }
}

/// `<ch>  <id>[x]<pad> <dir> <d|r> <dlc>`: a classic frame up to its bytes.
fn push_classic(line: &mut Vec<u8>, channel: u32, frame: &Frame, kind: char, dlc: u8) {
    let _ = write!(line, "{channel}  ");
    let width = push_id(line, frame.id);
    let _ = write!(
        line,
        "{:pad$} {:<4} {kind} {dlc:X}",
        "",
        direction(frame),
        pad = 15usize.saturating_sub(width)
    );
}

fn push_event(line: &mut Vec<u8>, channel: u32, frame: &Frame) {
    match frame.kind {
        FrameKind::Error { .. } => {
            let _ = writeln!(line, "{channel}  ErrorFrame");
        }
        FrameKind::Data { len8_dlc } => {
            let payload = frame.payload();
            push_classic(
                line,
                channel,
                frame,
                'd',
                len8_dlc.unwrap_or(payload.len() as u8),
            );
            push_bytes(line, payload);
            line.push(b'\n');
        }
        FrameKind::Remote {
            requested_len,
            len8_dlc,
        } => {
            push_classic(line, channel, frame, 'r', len8_dlc.unwrap_or(requested_len));
            line.push(b'\n');
        }
        FrameKind::Fd { flags } => {
            let brs = u8::from(flags & FD_FLAG_BRS != 0);
            let esi = u8::from(flags & FD_FLAG_ESI != 0);
            let dlc = fd_dlc(frame.payload().len());
            // A length between two DLC steps goes out padded with zeros to
            // the DLC's, as the bus carries it (the kernel pads the same).
            let mut padded = [0u8; 64];
            let length = FD_DLC_LENGTHS[usize::from(dlc)];
            padded[..frame.payload().len()].copy_from_slice(frame.payload());
            let payload = &padded[..length];
            let asc_flags = 0x1000 | (u32::from(brs) << 13) | (u32::from(esi) << 14);
            let _ = write!(line, "CANFD {channel:>3} {:<4} ", direction(frame));
            let width = push_id(line, frame.id);
            let _ = write!(
                line,
                "{:pad$}  {:>32} {brs} {esi} {dlc:x} {:>2}",
                "",
                "",
                payload.len(),
                pad = 8usize.saturating_sub(width)
            );
            push_bytes(line, payload);
            // duration, bit count, flags, CRC, four bit-timing words.
            let _ = writeln!(
                line,
                " {:>8} {:>4} {asc_flags:>8X} {:>8} {:>8} {:>8} {:>8} {:>8}",
                0, 0, 0, 0, 0, 0, 0
            );
        }
    }
}

/// The CAN FD DLC of a payload length: the smallest that holds it.
fn fd_dlc(len: usize) -> u8 {
    FD_DLC_LENGTHS.iter().position(|&l| l >= len).unwrap_or(15) as u8
}

/// `Tue Nov 24 09:15:02.512 pm 2026` for ns since the epoch (UTC), as the
/// `date` and `Begin Triggerblock` lines write it.
fn asc_date(ns: i64) -> String {
    const WEEKDAYS: [&str; 7] = ["Thu", "Fri", "Sat", "Sun", "Mon", "Tue", "Wed"];
    const MONTHS: [&str; 12] = [
        "Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec",
    ];
    let seconds = ns.div_euclid(NANOS_PER_SECOND);
    let millis = ns.rem_euclid(NANOS_PER_SECOND) / NANOS_PER_MILLI;
    let days = seconds.div_euclid(86_400);
    let of_day = seconds.rem_euclid(86_400);
    let (year, month, day) = civil_from_days(days);
    let hour = of_day / 3600;
    let (hour12, meridian) = match hour {
        0 => (12, "am"),
        1..=11 => (hour, "am"),
        12 => (12, "pm"),
        _ => (hour - 12, "pm"),
    };
    format!(
        "{} {} {day} {hour12:02}:{:02}:{:02}.{millis:03} {meridian} {year}",
        WEEKDAYS[days.rem_euclid(7) as usize],
        MONTHS[(month - 1) as usize],
        of_day / 60 % 60,
        of_day % 60,
    )
}

/// (year, month 1-12, day 1-31) of days since 1970-01-01 (Howard Hinnant's
/// `civil_from_days`, proleptic Gregorian).
fn civil_from_days(days: i64) -> (i64, i64, i64) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let day_of_era = z.rem_euclid(146_097);
    let year_of_era =
        (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let month_index = (5 * day_of_year + 2) / 153;
    let day = day_of_year - (153 * month_index + 2) / 5 + 1;
    let month = if month_index < 10 {
        month_index + 3
    } else {
        month_index - 9
    };
    let year = year_of_era + era * 400 + i64::from(month <= 2);
    (year, month, day)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_are_written_as_vector_writes_them() {
        assert_eq!(asc_date(0), "Thu Jan 1 12:00:00.000 am 1970");
        // 2026-11-24 21:15:02.512 UTC, a Tuesday.
        let ns = (1_795_554_902_i64 * 1000 + 512) * NANOS_PER_MILLI;
        assert_eq!(asc_date(ns), "Tue Nov 24 09:15:02.512 pm 2026");
        // Leap day, noon.
        let ns = 951_825_600 * NANOS_PER_SECOND; // 2000-02-29 12:00:00
        assert_eq!(asc_date(ns), "Tue Feb 29 12:00:00.000 pm 2000");
    }

    #[test]
    fn channels_follow_python_can_and_announce_other_names() {
        assert_eq!(natural_channel(IfaceName::new("can0").unwrap()), Some(1));
        assert_eq!(natural_channel(IfaceName::new("can12").unwrap()), Some(13));
        assert_eq!(natural_channel(IfaceName::new("vcan0").unwrap()), None);
        assert_eq!(natural_channel(IfaceName::new("can01").unwrap()), None);
        assert_eq!(natural_channel(IfaceName::new("can").unwrap()), None);
    }
}
