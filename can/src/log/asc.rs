//! Vector ASC logs (`.asc`): what CANalyzer, CANoe and python-can write.
//!
//! ```text
//! date Tue Mar 4 09:15:02.512 am 2025              measurement start (local time)
//! base hex  timestamps absolute                    number base, time mode
//! internal events logged
//! // version 17.3.0
//! Begin Triggerblock Tue Mar 4 09:15:02.512 am 2025
//!    0.000000 Start of measurement                 event, skipped
//!    0.010214 1  18FEF100x       Rx   d 8 FF FF 00 12 34 FF FF FF  Length = 272000 BitCount = 141 ID = 419361024x
//!    0.010498 1  181             Tx   d 2 A0 0F    classic data, 11-bit id
//!    0.025100 1  601             Rx   r 8          remote frame, DLC 8
//!    0.030441 CANFD   3 Rx   1A3x  BoomPressures  1 0 c 24 <24 bytes> 155000 240 323000 ...
//!    0.031002 1  ErrorFrame                        error frame
//!    1.000000 1  Statistic: D 812 R 1 XD 406 XR 0 E 2 O 0 B 21.45%   skipped
//! End TriggerBlock
//! ```
//!
//! What is read:
//! - Header lines: `date <weekday> <month> <day> <hh:mm:ss[.fff]> [am|pm] <year>`
//!   (English month names, and the German `Mär`/`Mrz`/`Mai`/`Okt`/`Dez` CANoe
//!   writes on a German Windows; the weekday is not checked), `base hex|dec`,
//!   `timestamps absolute|relative` (on the `base` line or its own),
//!   `[no] internal events logged`, `// comments`, `Begin Triggerblock ...`,
//!   `End TriggerBlock`. The date has no time zone in the file: it is taken
//!   as UTC. Without a `date` line, times count from 0; a `date` line that
//!   cannot be read is an error at its line.
//! - Classic frames `<time> <ch> <id>[x] <Rx|Tx> d <dlc> <bytes...> [Length = ...
//!   BitCount = ... ID = ...]`; a DLC 9-F carries 8 bytes and is kept as the
//!   raw DLC ([`FrameKind::Data`](crate::frame::FrameKind::Data)`{ len8_dlc }`).
//! - Remote frames `<time> <ch> <id>[x] <Rx|Tx> r [dlc]` (no DLC means 0).
//! - Error frames `<time> <ch> ErrorFrame ...` and `<time> CANFD <ch> <Rx|Tx>
//!   ErrorFrame ...`: the ASC details are not decoded; the frame gets the
//!   class [`ERROR_FRAME_CLASS`] (`CAN_ERR_BUSERROR`) and zero detail bytes.
//! - CAN FD frames `<time> CANFD <ch> <Rx|Tx> <id>[x] [<name>] <brs> <esi>
//!   <dlc> <data length> <bytes...> <duration> <bit count> <flags> ...`. As in
//!   python-can, the token after the id is a symbolic name unless it is all
//!   digits. When the hex `<flags>` column is there, its EDL bit (0x1000)
//!   tells an FD frame from a classic frame logged on an FD channel, and
//!   its remote bit (0x10) marks a classic remote frame; without it, a data
//!   length of 0 with a DLC above 0 is a remote frame (python-can's rule).
//! - `base dec` reads ids, DLCs and data bytes in decimal; the FD data
//!   length is always decimal.
//! - `timestamps relative`: every event's time is a delta to the previous
//!   event (frame or not), and they are summed.
//!
//! Channels are 1-based in ASC; channel `N` becomes interface `can{N-1}`
//! (python-can's convention: channel 1 is `can0`), unless a comment line
//! `// acq channel N = NAME` (written by acq's [`super::asc_write`]) named it. `Rx`/`Tx` become
//! [`Direction::Received`]/[`Direction::Transmitted`].
//!
//! Every other line that starts with a time (`Start of measurement`, `CAN 1
//! Status:...`, `Statistic:`, `J1939TP ...`, `SV: ...`, `Log trigger event`,
//! `TxRq` transmit requests, ...) is an event that is skipped. A line that
//! is recognisably a CAN frame (a channel number, then an id or a direction,
//! or `CANFD <ch> <Rx|Tx>`) but malformed is a [`ParseError`] saying what
//! was expected, and so is a line that is neither a header line nor starts
//! with a time. The reader goes on after either.
//!
//! Not read: symbolic-only ids (logs written with "symbolic" ids instead of
//! numbers are parse errors), the ASC details of error frames, LIN/FlexRay/
//! Ethernet events (skipped), and the time zone (see above). Like the
//! candump reader it is streaming: one reused line buffer, constant memory.

use std::io::BufRead;

use super::record::{LogRecord, ParseError, ReadError};
use crate::frame::{
    fd_flags, CanId, Direction, Frame, IfaceName, CLASSIC_MAX_LEN, FD_DLC_LENGTHS, FD_MAX_LEN,
};
use crate::hex;

/// Error class given to ASC error frames: `CAN_ERR_BUSERROR` (the ASC line
/// says that an error frame was on the bus, not which Linux class it is).
pub const ERROR_FRAME_CLASS: u32 = 0x80;

/// Bits of the `<flags>` column of a CAN FD line (Vector's `CAN_FD_MESSAGE_64`).
const FLAG_REMOTE: u32 = 0x0010;
const FLAG_EDL: u32 = 0x1000;

const NANOS_PER_SECOND: i64 = 1_000_000_000;

const E_LINE: &str =
    "a header line (date, base, timestamps, internal events logged, //, Begin/End Triggerblock) or an event line starting with a time";
const E_TIME: &str =
    "a time 'seconds.fraction' (1-9 fraction digits) at the start of the event line";
const E_TIME_RANGE: &str = "a time that fits in a 64-bit nanosecond timestamp";
const E_DATE: &str =
    "a date header like `date Tue Mar 4 09:15:02.512 am 2025` (or delete the line: times then count from 0)";
const E_BASE: &str = "'hex' or 'dec' after 'base'";
const E_TIMESTAMPS: &str = "'absolute' or 'relative' after 'timestamps'";
const E_CHANNEL: &str = "a channel number of at least 1 (ASC channels are 1-based)";
const E_ID: &str = "an id (hex, decimal with 'base dec'), with a trailing 'x' for 29 bits";
const E_STANDARD_ID: &str =
    "an 11-bit id (at most 0x7FF) or a 29-bit id marked with a trailing 'x'";
const E_EXTENDED_ID: &str = "a 29-bit id (at most 0x1FFFFFFF) before 'x'";
const E_DIRECTION: &str = "a direction 'Rx' or 'Tx' after the id";
const E_KIND: &str = "'d' (data frame) or 'r' (remote frame) after the direction";
const E_DLC: &str = "a DLC 0-F (0-15 with 'base dec') after 'd'";
const E_DATA: &str =
    "one data byte (two hex digits, 0-255 with 'base dec') for each byte the DLC gives";
const E_EXTRA_DATA: &str = "no more data bytes than the DLC gives";
const E_FD_ID: &str =
    "an id (hex, decimal with 'base dec') or 'ErrorFrame' after the CAN FD direction";
const E_BRS: &str = "a bit rate switch flag 0 or 1 after the CAN FD id (and symbolic name)";
const E_ESI: &str = "an error state flag 0 or 1 after the bit rate switch flag";
const E_FD_DLC: &str = "a CAN FD DLC 0-F (0-15 with 'base dec') after the error state flag";
const E_FD_LEN: &str = "a decimal data length 0-64 after the CAN FD DLC";
const E_FD_LEN_MATCH: &str =
    "a data length that matches the DLC (DLC 9-F: 12, 16, 20, 24, 32, 48, 64 bytes)";
const E_CLASSIC_LEN_MATCH: &str =
    "a data length that matches the DLC (at most 8) on a classic frame (flags without EDL)";
const E_REMOTE_LEN: &str = "a data length of 0 on a remote frame";
const E_END_BLOCK: &str =
    "an 'End TriggerBlock' line (the file ends inside its trigger block: cut short?)";

/// Streaming reader of Vector ASC logs.
pub struct AscReader<R> {
    input: R,
    buffer: Vec<u8>,
    state: State,
}

impl<R: BufRead> AscReader<R> {
    pub fn new(input: R) -> Self {
        AscReader {
            input,
            buffer: Vec::with_capacity(256),
            state: State::default(),
        }
    }

    /// The next frame; header lines, blank lines and non-frame events are
    /// skipped. `Ok(None)` at the end of the log. After an `Err(Parse)` the
    /// reader can go on with the next line.
    pub fn next_record(&mut self) -> Result<Option<LogRecord<'_>>, ReadError> {
        loop {
            self.buffer.clear();
            if self.input.read_until(b'\n', &mut self.buffer)? == 0 {
                // A block begun and never ended, or a header that no block
                // followed: the log was cut (said once).
                if std::mem::take(&mut self.state.in_trigger_block)
                    | std::mem::take(&mut self.state.awaiting_block)
                {
                    let line = self.state.line.saturating_add(1);
                    return Err(ReadError::Parse(ParseError::new(line, E_END_BLOCK)));
                }
                return Ok(None);
            }
            self.state.line = self.state.line.saturating_add(1);
            let line = self.state.line;
            match self.state.parse_line(&self.buffer) {
                Ok(Parsed::Skip) => continue,
                Ok(Parsed::Frame { time, frame }) => {
                    self.state.awaiting_block = false;
                    // The time was checked to be ASCII digits and a dot.
                    let text = self.buffer.get(time.0..time.1).unwrap_or_default();
                    return Ok(Some(LogRecord {
                        line,
                        timestamp_text: text,
                        frame,
                    }));
                }
                Err(expected) => return Err(ReadError::Parse(ParseError::new(line, expected))),
            }
        }
    }

    /// Lines read so far.
    pub fn line(&self) -> u64 {
        self.state.line
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
enum Base {
    #[default]
    Hex,
    Dec,
}

/// What the header said so far, and the clock.
#[derive(Debug, Default)]
struct State {
    line: u64,
    base: Base,
    relative: bool,
    /// The `date` line as ns since the epoch (0 without one).
    start_ns: i64,
    /// Time of the last event since the start, ns (the running sum of the
    /// deltas with `timestamps relative`).
    clock_ns: i64,
    /// Channels named by `// acq channel K = NAME` comments (acq's writer).
    named_channels: Vec<(u64, IfaceName)>,
    /// Inside `Begin Triggerblock` .. `End TriggerBlock`.
    in_trigger_block: bool,
    /// A header line was read and no block or frame yet.
    awaiting_block: bool,
}

enum Parsed {
    Skip,
    /// A frame, with the byte range of its time text in the line.
    Frame {
        time: (usize, usize),
        frame: Frame,
    },
}

impl State {
    fn parse_line(&mut self, buffer: &[u8]) -> Result<Parsed, &'static str> {
        let mut tokens = Tokens::new(buffer);
        if self.line == 1 && buffer.starts_with(b"\xEF\xBB\xBF") {
            tokens.pos = 3; // UTF-8 byte order mark
        }
        let Some((start, end)) = tokens.next_range() else {
            return Ok(Parsed::Skip);
        };
        let first = buffer.get(start..end).unwrap_or_default();
        if first.starts_with(b"//") {
            self.channel_name_comment(first, tokens);
            return Ok(Parsed::Skip);
        }
        if first.first().is_some_and(u8::is_ascii_digit) {
            return self.event(first, (start, end), tokens);
        }
        self.header(first, tokens)
    }

    /// `// acq channel K = NAME`: channel K's frames get interface NAME.
    /// Any other comment, or one that does not parse, is only a comment.
    fn channel_name_comment(&mut self, first: &[u8], mut tokens: Tokens<'_>) {
        if first != b"//" {
            return;
        }
        let (Some(b"acq"), Some(b"channel"), Some(number), Some(b"="), Some(name), None) = (
            tokens.next(),
            tokens.next(),
            tokens.next(),
            tokens.next(),
            tokens.next(),
            tokens.next(),
        ) else {
            return;
        };
        let (Some(channel), Some(iface)) = (parse_decimal(number, 20), IfaceName::from_bytes(name))
        else {
            return;
        };
        self.named_channels.retain(|&(c, _)| c != channel);
        self.named_channels.push((channel, iface));
    }

    /// The interface of ASC channel `text`: its `// acq channel` name, or
    /// `can{N-1}`.
    fn iface_of(&self, text: &[u8]) -> Result<IfaceName, &'static str> {
        if let Some(channel) = parse_decimal(text, 20) {
            if let Some(&(_, iface)) = self.named_channels.iter().find(|&&(c, _)| c == channel) {
                return Ok(iface);
            }
        }
        channel_iface(text)
    }

    fn header(&mut self, keyword: &[u8], mut tokens: Tokens<'_>) -> Result<Parsed, &'static str> {
        let is = |token: Option<&[u8]>, word: &str| {
            token.is_some_and(|t| t.eq_ignore_ascii_case(word.as_bytes()))
        };
        if keyword.eq_ignore_ascii_case(b"date") || keyword.eq_ignore_ascii_case(b"base") {
            self.awaiting_block = true;
        }
        if keyword.eq_ignore_ascii_case(b"date") {
            // A date that cannot be read would put the log in 1970 without a
            // word; the user can fix or delete the line.
            self.start_ns = parse_date(tokens).ok_or(E_DATE)?;
        } else if keyword.eq_ignore_ascii_case(b"base") {
            self.base = match tokens.next() {
                Some(t) if t.eq_ignore_ascii_case(b"hex") => Base::Hex,
                Some(t) if t.eq_ignore_ascii_case(b"dec") => Base::Dec,
                _ => return Err(E_BASE),
            };
            if is(tokens.next(), "timestamps") {
                self.timestamps(tokens.next())?;
            }
        } else if keyword.eq_ignore_ascii_case(b"timestamps") {
            self.timestamps(tokens.next())?;
        } else if keyword.eq_ignore_ascii_case(b"internal")
            || (keyword.eq_ignore_ascii_case(b"no") && is(tokens.next(), "internal"))
        {
            // Nothing in these lines changes how frames read.
        } else if (keyword.eq_ignore_ascii_case(b"begin") || keyword.eq_ignore_ascii_case(b"end"))
            && is(tokens.next(), "triggerblock")
        {
            // A log whose block never ends was cut short.
            self.in_trigger_block = keyword.eq_ignore_ascii_case(b"begin");
            self.awaiting_block = false;
        } else {
            return Err(E_LINE);
        }
        Ok(Parsed::Skip)
    }

    fn timestamps(&mut self, mode: Option<&[u8]>) -> Result<(), &'static str> {
        self.relative = match mode {
            Some(t) if t.eq_ignore_ascii_case(b"absolute") => false,
            Some(t) if t.eq_ignore_ascii_case(b"relative") => true,
            _ => return Err(E_TIMESTAMPS),
        };
        Ok(())
    }

    /// A line that starts with a time: a frame, or some other event.
    fn event(
        &mut self,
        time_text: &[u8],
        time: (usize, usize),
        mut tokens: Tokens<'_>,
    ) -> Result<Parsed, &'static str> {
        let time_ns = parse_time(time_text).ok_or(E_TIME)?;
        let clock = if self.relative {
            self.clock_ns.checked_add(time_ns).ok_or(E_TIME_RANGE)?
        } else {
            time_ns
        };
        self.clock_ns = clock;
        let timestamp_ns = self.start_ns.checked_add(clock).ok_or(E_TIME_RANGE)?;

        let Some(second) = tokens.next() else {
            return Ok(Parsed::Skip);
        };
        let frame = if second.eq_ignore_ascii_case(b"CANFD") {
            match self.fd_frame(tokens, timestamp_ns)? {
                Some(frame) => frame,
                None => return Ok(Parsed::Skip),
            }
        } else if is_digits(second) {
            let mut ahead = tokens.clone();
            let third = ahead.next();
            let fourth = ahead.next();
            match third {
                Some(t) if t.eq_ignore_ascii_case(b"ErrorFrame") => {
                    Frame::error(timestamp_ns, self.iface_of(second)?, ERROR_FRAME_CLASS, &[])
                        .map_err(|_| E_CHANNEL)?
                }
                // A transmit request, not a frame on the bus.
                Some(_) if fourth.is_some_and(|t| t.eq_ignore_ascii_case(b"TxRq")) => {
                    return Ok(Parsed::Skip)
                }
                Some(t)
                    if fourth.and_then(parse_direction).is_some()
                        || looks_like_id(t, self.base) =>
                {
                    self.classic_frame(second, tokens, timestamp_ns)?
                }
                // Statistic:, J1939TP, ... on a channel.
                _ => return Ok(Parsed::Skip),
            }
        } else {
            // Start of measurement, CAN 1 Status:..., SV:, Log trigger event, ...
            return Ok(Parsed::Skip);
        };
        Ok(Parsed::Frame { time, frame })
    }

    /// `<id>[x] <Rx|Tx> d <dlc> <bytes...>` or `<id>[x] <Rx|Tx> r [dlc]`.
    fn classic_frame(
        &self,
        channel: &[u8],
        mut tokens: Tokens<'_>,
        timestamp_ns: i64,
    ) -> Result<Frame, &'static str> {
        let iface = self.iface_of(channel)?;
        let id = parse_id(tokens.next().ok_or(E_ID)?, self.base)?;
        let direction = tokens.next().and_then(parse_direction).ok_or(E_DIRECTION)?;
        let kind = tokens.next().ok_or(E_KIND)?;
        let mut frame = if kind.eq_ignore_ascii_case(b"d") {
            let dlc = tokens
                .next()
                .and_then(|t| parse_dlc(t, self.base))
                .ok_or(E_DLC)?;
            let len = usize::from(dlc).min(CLASSIC_MAX_LEN);
            let mut payload = [0u8; CLASSIC_MAX_LEN];
            for byte in payload.iter_mut().take(len) {
                *byte = tokens
                    .next()
                    .and_then(|t| parse_byte(t, self.base))
                    .ok_or(E_DATA)?;
            }
            if tokens
                .peek()
                .and_then(|t| parse_byte(t, self.base))
                .is_some()
            {
                return Err(E_EXTRA_DATA);
            }
            let mut frame = Frame::data(
                timestamp_ns,
                iface,
                id,
                payload.get(..len).unwrap_or_default(),
            )
            .map_err(|_| E_DATA)?;
            if dlc > 8 {
                frame.set_len8_dlc(dlc).map_err(|_| E_DLC)?;
            }
            frame
        } else if kind.eq_ignore_ascii_case(b"r") {
            let dlc = match tokens.peek().and_then(|t| parse_dlc(t, self.base)) {
                Some(dlc) => {
                    tokens.next();
                    dlc
                }
                None => 0,
            };
            remote_frame(timestamp_ns, iface, id, dlc)?
        } else {
            return Err(E_KIND);
        };
        frame.direction = Some(direction);
        Ok(frame)
    }

    /// The rest of a `CANFD` line; `None` for a CAN FD event that is not a
    /// frame.
    fn fd_frame(
        &self,
        mut tokens: Tokens<'_>,
        timestamp_ns: i64,
    ) -> Result<Option<Frame>, &'static str> {
        let (Some(channel), Some(third)) = (tokens.next(), tokens.next()) else {
            return Ok(None);
        };
        if !is_digits(channel) {
            return Ok(None);
        }
        let iface = self.iface_of(channel)?;
        if third.eq_ignore_ascii_case(b"ErrorFrame") {
            return Frame::error(timestamp_ns, iface, ERROR_FRAME_CLASS, &[])
                .map(Some)
                .map_err(|_| E_CHANNEL);
        }
        let Some(direction) = parse_direction(third) else {
            return Ok(None);
        };
        let id_text = tokens.next().ok_or(E_FD_ID)?;
        if id_text.eq_ignore_ascii_case(b"ErrorFrame") {
            let mut frame =
                Frame::error(timestamp_ns, iface, ERROR_FRAME_CLASS, &[]).map_err(|_| E_CHANNEL)?;
            frame.direction = Some(direction);
            return Ok(Some(frame));
        }
        let id = parse_id(id_text, self.base).map_err(|e| if e == E_ID { E_FD_ID } else { e })?;
        let mut brs = tokens.next().ok_or(E_BRS)?;
        if !is_digits(brs) {
            // A symbolic name.
            brs = tokens.next().ok_or(E_BRS)?;
        }
        let brs = parse_flag(brs).ok_or(E_BRS)?;
        let esi = tokens.next().and_then(parse_flag).ok_or(E_ESI)?;
        let dlc = tokens
            .next()
            .and_then(|t| parse_dlc(t, self.base))
            .ok_or(E_FD_DLC)?;
        let len = tokens
            .next()
            .and_then(|t| parse_decimal(t, 2))
            .and_then(|v| usize::try_from(v).ok())
            .filter(|&v| v <= FD_MAX_LEN)
            .ok_or(E_FD_LEN)?;
        let mut payload = [0u8; FD_MAX_LEN];
        for byte in payload.iter_mut().take(len) {
            *byte = tokens
                .next()
                .and_then(|t| parse_byte(t, self.base))
                .ok_or(E_DATA)?;
        }
        let payload = payload.get(..len).unwrap_or_default();
        // <duration> <bit count> <flags>: the flags only if the two before
        // them are numbers too.
        let flags = match (tokens.next(), tokens.next(), tokens.next()) {
            (Some(duration), Some(bits), Some(flags)) if is_digits(duration) && is_digits(bits) => {
                hex::parse_u32(flags)
            }
            _ => None,
        };
        let dlc_len = FD_DLC_LENGTHS.get(usize::from(dlc)).copied();
        let mut frame = match flags {
            Some(flags) if flags & FLAG_EDL == 0 && flags & FLAG_REMOTE != 0 => {
                if len != 0 {
                    return Err(E_REMOTE_LEN);
                }
                remote_frame(timestamp_ns, iface, id, dlc)?
            }
            Some(flags) if flags & FLAG_EDL == 0 => {
                if len != usize::from(dlc).min(CLASSIC_MAX_LEN) {
                    return Err(E_CLASSIC_LEN_MATCH);
                }
                let mut frame = Frame::data(timestamp_ns, iface, id, payload)
                    .map_err(|_| E_CLASSIC_LEN_MATCH)?;
                if dlc > 8 {
                    frame.set_len8_dlc(dlc).map_err(|_| E_CLASSIC_LEN_MATCH)?;
                }
                frame
            }
            None if len == 0 && dlc > 0 => remote_frame(timestamp_ns, iface, id, dlc)?,
            _ => {
                if dlc_len != Some(len) {
                    return Err(E_FD_LEN_MATCH);
                }
                Frame::fd(timestamp_ns, iface, id, fd_flags(brs, esi), payload)
                    .map_err(|_| E_FD_LEN)?
            }
        };
        frame.direction = Some(direction);
        Ok(Some(frame))
    }
}

/// A classic remote frame for a DLC 0-15 (9-15 request 8 bytes and are kept
/// as the raw DLC).
fn remote_frame(
    timestamp_ns: i64,
    iface: IfaceName,
    id: CanId,
    dlc: u8,
) -> Result<Frame, &'static str> {
    let requested = dlc.min(CLASSIC_MAX_LEN as u8);
    let mut frame = Frame::remote(timestamp_ns, iface, id, requested).map_err(|_| E_DLC)?;
    if dlc > 8 {
        frame.set_len8_dlc(dlc).map_err(|_| E_DLC)?;
    }
    Ok(frame)
}

/// Whitespace-separated tokens of a line, with their byte ranges.
#[derive(Clone)]
struct Tokens<'a> {
    text: &'a [u8],
    pos: usize,
}

impl<'a> Tokens<'a> {
    fn new(text: &'a [u8]) -> Self {
        Tokens { text, pos: 0 }
    }

    fn next_range(&mut self) -> Option<(usize, usize)> {
        let rest = self.text.get(self.pos..)?;
        let start = self.pos + rest.iter().position(|b| !b.is_ascii_whitespace())?;
        let rest = self.text.get(start..)?;
        let end = start
            + rest
                .iter()
                .position(u8::is_ascii_whitespace)
                .unwrap_or(rest.len());
        self.pos = end;
        Some((start, end))
    }

    fn peek(&self) -> Option<&'a [u8]> {
        self.clone().next()
    }
}

impl<'a> Iterator for Tokens<'a> {
    type Item = &'a [u8];

    fn next(&mut self) -> Option<&'a [u8]> {
        let (start, end) = self.next_range()?;
        self.text.get(start..end)
    }
}

fn is_digits(text: &[u8]) -> bool {
    !text.is_empty() && text.iter().all(u8::is_ascii_digit)
}

/// A decimal number of at most `max_digits` digits.
fn parse_decimal(text: &[u8], max_digits: usize) -> Option<u64> {
    if !is_digits(text) || text.len() > max_digits {
        return None;
    }
    text.iter().try_fold(0u64, |acc, &d| {
        acc.checked_mul(10)?.checked_add(u64::from(d - b'0'))
    })
}

/// `seconds.fraction` (1-9 fraction digits) -> ns.
fn parse_time(text: &[u8]) -> Option<i64> {
    let dot = memchr::memchr(b'.', text)?;
    let seconds = text.get(..dot)?;
    let fraction = text.get(dot + 1..)?;
    if fraction.len() > 9 {
        return None;
    }
    let whole = i64::try_from(parse_decimal(seconds, 19)?).ok()?;
    let nanos = i64::try_from(parse_decimal(fraction, 9)?).ok()?;
    let scale = 10i64.checked_pow(u32::try_from(9 - fraction.len()).ok()?)?;
    whole
        .checked_mul(NANOS_PER_SECOND)?
        .checked_add(nanos.checked_mul(scale)?)
}

fn parse_direction(text: &[u8]) -> Option<Direction> {
    if text.eq_ignore_ascii_case(b"Rx") {
        Some(Direction::Received)
    } else if text.eq_ignore_ascii_case(b"Tx") {
        Some(Direction::Transmitted)
    } else {
        None
    }
}

fn parse_flag(text: &[u8]) -> Option<bool> {
    match text {
        b"0" => Some(false),
        b"1" => Some(true),
        _ => None,
    }
}

/// ASC channel `N` (1-based) -> interface `can{N-1}`.
fn channel_iface(text: &[u8]) -> Result<IfaceName, &'static str> {
    let number = parse_decimal(text, 20)
        .and_then(|n| n.checked_sub(1))
        .ok_or(E_CHANNEL)?;
    let mut digits = itoa::Buffer::new();
    let digits = digits.format(number).as_bytes();
    let mut name = [0u8; IfaceName::MAX_LEN];
    let len = 3 + digits.len();
    let slot = name.get_mut(..len).ok_or(E_CHANNEL)?;
    slot.get_mut(..3).ok_or(E_CHANNEL)?.copy_from_slice(b"can");
    slot.get_mut(3..).ok_or(E_CHANNEL)?.copy_from_slice(digits);
    IfaceName::from_bytes(slot).ok_or(E_CHANNEL)
}

/// Digits of an id (hex or decimal per `base`), optionally ending in `x`.
fn looks_like_id(text: &[u8], base: Base) -> bool {
    let digits = match text.split_last() {
        Some((b'x' | b'X', rest)) => rest,
        _ => text,
    };
    !digits.is_empty()
        && match base {
            Base::Hex => digits.iter().all(u8::is_ascii_hexdigit),
            Base::Dec => digits.iter().all(u8::is_ascii_digit),
        }
}

fn parse_id(text: &[u8], base: Base) -> Result<CanId, &'static str> {
    let (digits, extended) = match text.split_last() {
        Some((b'x' | b'X', rest)) => (rest, true),
        _ => (text, false),
    };
    let value = match base {
        Base::Hex => hex::parse_u32(digits),
        Base::Dec => parse_decimal(digits, 10).and_then(|v| u32::try_from(v).ok()),
    }
    .ok_or(E_ID)?;
    if extended {
        CanId::extended(value).ok_or(E_EXTENDED_ID)
    } else {
        u16::try_from(value)
            .ok()
            .and_then(CanId::standard)
            .ok_or(E_STANDARD_ID)
    }
}

/// A DLC 0-15: one or two hex digits, or a decimal number with `base dec`.
fn parse_dlc(text: &[u8], base: Base) -> Option<u8> {
    let value = match base {
        Base::Hex if text.len() <= 2 => hex::parse_u32(text)?,
        Base::Hex => return None,
        Base::Dec => u32::try_from(parse_decimal(text, 2)?).ok()?,
    };
    u8::try_from(value).ok().filter(|&v| v <= 15)
}

/// A data byte: one or two hex digits, or 0-255 with `base dec`.
fn parse_byte(text: &[u8], base: Base) -> Option<u8> {
    match base {
        Base::Hex if text.len() <= 2 => u8::try_from(hex::parse_u32(text)?).ok(),
        Base::Hex => None,
        Base::Dec => u8::try_from(parse_decimal(text, 3)?).ok(),
    }
}

/// The `date` header after the keyword, as ns since the Unix epoch (the
/// file's local time taken as UTC); `None` if it does not parse.
fn parse_date(mut tokens: Tokens<'_>) -> Option<i64> {
    let _weekday = tokens.next()?;
    let month = month_number(tokens.next()?)?;
    let day = parse_decimal(tokens.next()?, 2)?;
    let time = tokens.next()?;
    let mut next = tokens.next()?;
    let meridian = if next.eq_ignore_ascii_case(b"am") {
        next = tokens.next()?;
        Some(false)
    } else if next.eq_ignore_ascii_case(b"pm") {
        next = tokens.next()?;
        Some(true)
    } else {
        None
    };
    if next.len() != 4 {
        return None;
    }
    let year = i64::try_from(parse_decimal(next, 4)?).ok()?;
    if year == 0 || day == 0 || day > days_in_month(year, month) {
        return None;
    }

    let mut parts = time.splitn(3, |&b| b == b':');
    let hour = parse_decimal(parts.next()?, 2)?;
    let minute = parse_decimal(parts.next()?, 2)?;
    let seconds_text = parts.next()?;
    let (seconds, nanos) = match memchr::memchr(b'.', seconds_text) {
        Some(dot) => {
            let seconds = parse_decimal(seconds_text.get(..dot)?, 2)?;
            (
                seconds,
                u64::try_from(parse_time(seconds_text)?.checked_rem(NANOS_PER_SECOND)?).ok()?,
            )
        }
        None => (parse_decimal(seconds_text, 2)?, 0),
    };
    let hour = match meridian {
        None if hour <= 23 => hour,
        Some(pm) if (1..=12).contains(&hour) => hour % 12 + if pm { 12 } else { 0 },
        _ => return None,
    };
    if minute > 59 || seconds > 59 {
        return None;
    }
    let days = days_from_civil(year, month, day)?;
    let seconds = days
        .checked_mul(86_400)?
        .checked_add(i64::try_from(hour * 3600 + minute * 60 + seconds).ok()?)?;
    seconds
        .checked_mul(NANOS_PER_SECOND)?
        .checked_add(i64::try_from(nanos).ok()?)
}

/// 1-12 from an English month name or abbreviation (any case), or one of
/// the German abbreviations that differ (`Mär`, `Mrz`, `Mai`, `Okt`, `Dez`).
fn month_number(name: &[u8]) -> Option<u64> {
    const ENGLISH: [&str; 12] = [
        "january",
        "february",
        "march",
        "april",
        "may",
        "june",
        "july",
        "august",
        "september",
        "october",
        "november",
        "december",
    ];
    const GERMAN: [(&[u8], u64); 5] = [
        ("mär".as_bytes(), 3),
        (b"mrz", 3),
        (b"mai", 5),
        (b"okt", 10),
        (b"dez", 12),
    ];
    let lower = name.to_ascii_lowercase();
    for (number, full) in (1u64..).zip(ENGLISH) {
        let full = full.as_bytes();
        if lower == full
            || full.get(..3) == Some(lower.as_slice())
            || (number == 9 && lower == b"sept")
        {
            return Some(number);
        }
    }
    GERMAN
        .iter()
        .find(|(abbreviation, _)| lower == *abbreviation)
        .map(|&(_, number)| number)
}

fn is_leap_year(year: i64) -> bool {
    (year % 4 == 0 && year % 100 != 0) || year % 400 == 0
}

fn days_in_month(year: i64, month: u64) -> u64 {
    match month {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        2 if is_leap_year(year) => 29,
        2 => 28,
        _ => 0,
    }
}

/// Days since 1970-01-01 of a proleptic Gregorian date (Howard Hinnant's
/// `days_from_civil`); `month` 1-12, `day` 1-31.
fn days_from_civil(year: i64, month: u64, day: u64) -> Option<i64> {
    let month = i64::try_from(month).ok()?;
    let day = i64::try_from(day).ok()?;
    let year = if month <= 2 {
        year.checked_sub(1)?
    } else {
        year
    };
    let era = year.div_euclid(400);
    let year_of_era = year.rem_euclid(400); // 0..=399
    let month_from_march = (month + 9) % 12; // March = 0
    let day_of_year = (153 * month_from_march + 2) / 5 + day - 1; // 0..=365
    let day_of_era = year_of_era * 365 + year_of_era / 4 - year_of_era / 100 + day_of_year;
    era.checked_mul(146_097)?
        .checked_add(day_of_era)?
        .checked_sub(719_468)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameKind;

    const HEADER: &str = "date Tue Mar 4 09:15:02.512 am 2025\nbase hex  timestamps absolute\ninternal events logged\n// version 17.3.0\nBegin Triggerblock Tue Mar 4 09:15:02.512 am 2025\n   0.000000 Start of measurement\n";
    const START_NS: i64 = 1_741_079_702_512_000_000;

    fn iface(name: &str) -> IfaceName {
        IfaceName::new(name).unwrap()
    }

    /// All results of reading `log` and the end of its trigger block:
    /// frames with their line and time text, or the parse error.
    fn read_all(log: &str) -> Vec<Result<(u64, String, Frame), ParseError>> {
        read_whole(&format!("{log}End TriggerBlock\n"))
    }

    /// All results of reading `log` as it is.
    fn read_whole(log: &str) -> Vec<Result<(u64, String, Frame), ParseError>> {
        let mut reader = AscReader::new(log.as_bytes());
        let mut out = Vec::new();
        loop {
            match reader.next_record() {
                Ok(Some(record)) => out.push(Ok((
                    record.line,
                    String::from_utf8_lossy(record.timestamp_text).into_owned(),
                    record.frame,
                ))),
                Ok(None) => return out,
                Err(ReadError::Parse(e)) => out.push(Err(e)),
                Err(ReadError::Io(e)) => panic!("{e}"),
            }
        }
    }

    /// The single frame of `HEADER` + `line`.
    fn frame(line: &str) -> Frame {
        frame_with(HEADER, line)
    }

    fn frame_with(header: &str, line: &str) -> Frame {
        let results = read_all(&format!("{header}{line}\n"));
        match results.as_slice() {
            [Ok((_, _, frame))] => *frame,
            other => panic!("{line}: {other:?}"),
        }
    }

    fn error_of(line: &str) -> &'static str {
        let results = read_all(&format!("{HEADER}{line}\n"));
        match results.as_slice() {
            [Err(e)] => e.expected,
            other => panic!("{line}: expected one error, got {other:?}"),
        }
    }

    #[test]
    fn a_log_cut_inside_its_trigger_block_is_an_error_after_its_frames() {
        let log = format!("{HEADER}   0.010214 1  181             Tx   d 2 A0 0F\n");
        let results = read_whole(&log);
        assert_eq!(results.len(), 2, "{results:?}");
        assert!(results[0].is_ok());
        let error = results[1].clone().unwrap_err();
        assert_eq!((error.line(), error.expected), (Some(8), E_END_BLOCK));
        // Ended, it reads whole; without a block, nothing is missing.
        assert!(read_all(&log).iter().all(Result::is_ok));
        assert_eq!(read_whole("   0.1 1  181 Tx d 0\n").len(), 1);
    }

    #[test]
    fn classic_data_frames() {
        let log = format!(
            "{HEADER}   0.010214 1  18FEF100x       Rx   d 8 FF FF 00 12 34 FF FF FF  Length = 272000 BitCount = 141 ID = 419361024x\n\
             \t12.345678 2 7ff Tx d 0\n"
        );
        let results = read_all(&log);
        let (line, text, frame) = results[0].clone().unwrap();
        assert_eq!((line, text.as_str()), (7, "0.010214"));
        assert_eq!(frame.timestamp_ns, START_NS + 10_214_000);
        assert_eq!(frame.iface, iface("can0"));
        assert_eq!(frame.id, CanId::Extended(0x18FE_F100));
        assert_eq!(frame.kind, FrameKind::Data { len8_dlc: None });
        assert_eq!(frame.direction, Some(Direction::Received));
        assert_eq!(
            frame.payload(),
            &[0xFF, 0xFF, 0x00, 0x12, 0x34, 0xFF, 0xFF, 0xFF]
        );

        let (line, text, frame) = results[1].clone().unwrap();
        assert_eq!((line, text.as_str()), (8, "12.345678"));
        assert_eq!(frame.timestamp_ns, START_NS + 12_345_678_000);
        assert_eq!(
            (frame.iface, frame.id),
            (iface("can1"), CanId::Standard(0x7FF))
        );
        assert_eq!(frame.direction, Some(Direction::Transmitted));
        assert!(frame.payload().is_empty());
        assert_eq!(results.len(), 2);
    }

    #[test]
    fn classic_dlc_above_8_keeps_the_raw_dlc() {
        let frame = frame("  13.258671 1  3FF             Tx   d D 55 AA 01 02 03 04 05 06  Length = 232016 BitCount = 119 ID = 1023");
        assert_eq!(
            frame.kind,
            FrameKind::Data {
                len8_dlc: Some(0xD)
            }
        );
        assert_eq!(frame.payload(), &[0x55, 0xAA, 1, 2, 3, 4, 5, 6]);
    }

    #[test]
    fn remote_frames() {
        let frame = frame("   2.510001 2 100 Rx r");
        assert_eq!(
            frame.kind,
            FrameKind::Remote {
                requested_len: 0,
                len8_dlc: None
            }
        );
        assert_eq!(
            (frame.iface, frame.id),
            (iface("can1"), CanId::Standard(0x100))
        );
        let frame = self::frame("   2.520002 3 200 Tx r Length = 1704000 BitCount = 145 ID = 512");
        assert_eq!(
            frame.kind,
            FrameKind::Remote {
                requested_len: 0,
                len8_dlc: None
            }
        );
        assert_eq!(frame.direction, Some(Direction::Transmitted));
        let frame =
            self::frame("   2.584921 4 300x Rx r 8 Length = 1704000 BitCount = 145 ID = 768x");
        assert_eq!(
            frame.kind,
            FrameKind::Remote {
                requested_len: 8,
                len8_dlc: None
            }
        );
        assert_eq!(frame.id, CanId::Extended(0x300));
        let frame = self::frame("   2.584921 4 300 Rx r F");
        assert_eq!(
            frame.kind,
            FrameKind::Remote {
                requested_len: 8,
                len8_dlc: Some(15)
            }
        );
        assert!(frame.payload().is_empty());
    }

    #[test]
    fn error_frames() {
        let log = format!(
            "{HEADER}   2.501000 1 ErrorFrame\n   3.501000 1 ErrorFrame ECC: 10100010\n   4.501000 2 ErrorFrame Flags = 0xe CodeExt = 0x20a2 Code = 0x82 ID = 0 DLC = 0 Position = 5 Length = 11300\n  30.806898 CANFD   5 Tx ErrorFrame Not Acknowledge error, dominant error flag fffe c7 31ca Arb. 556 44 0 0 f 64 00 00 1331984 11 0 46500250 460a0250 20011736 20010205\n"
        );
        let frames: Vec<Frame> = read_all(&log).into_iter().map(|r| r.unwrap().2).collect();
        assert_eq!(frames.len(), 4);
        for frame in &frames {
            assert_eq!(
                frame.kind,
                FrameKind::Error {
                    class: ERROR_FRAME_CLASS
                }
            );
            assert_eq!(frame.payload(), &[0; 8]);
        }
        assert_eq!(
            (frames[0].iface, frames[0].direction),
            (iface("can0"), None)
        );
        assert_eq!(frames[2].iface, iface("can1"));
        assert_eq!(frames[3].iface, iface("can4"));
        assert_eq!(frames[3].direction, Some(Direction::Transmitted));
        assert_eq!(frames[3].timestamp_ns, START_NS + 30_806_898_000);
    }

    #[test]
    fn can_fd_frames_with_and_without_a_symbolic_name() {
        let frame = frame("   0.045522 CANFD   62 Rx         7d  BrakeSnData_4                    1 0 8  8 01 1b d6 d0 8a 1f d7 f6   104812  132   323000 a800f6c9 46500250 4b140250 20011736 2001040d");
        assert_eq!(frame.iface, iface("can61"));
        assert_eq!(frame.id, CanId::Standard(0x7D));
        assert_eq!(
            frame.kind,
            FrameKind::Fd {
                flags: fd_flags(true, false)
            }
        );
        assert_eq!(
            frame.payload(),
            &[0x01, 0x1B, 0xD6, 0xD0, 0x8A, 0x1F, 0xD7, 0xF6]
        );
        assert_eq!(frame.direction, Some(Direction::Received));

        let frame = self::frame("   0.045636 CANFD   62 Rx         88                                   0 1 8  8 00 00 f6 90 00 00 00 00   105812  137   323000 d001b0b3 46500250 4b140250 20011736 2001040d");
        assert_eq!(
            frame.kind,
            FrameKind::Fd {
                flags: fd_flags(false, true)
            }
        );
        assert_eq!(frame.id, CanId::Standard(0x88));

        let data: Vec<String> = (0..64).map(|i| format!("{i:02x}")).collect();
        let frame = self::frame(&format!(
            "  24.986902 CANFD   7 Tx        716x                                  1 0 f 64 {}        0    0     3000        0        0        0        0        0",
            data.join(" ")
        ));
        assert_eq!(frame.id, CanId::Extended(0x716));
        assert_eq!(frame.payload(), (0..64).collect::<Vec<u8>>().as_slice());
        assert_eq!(frame.direction, Some(Direction::Transmitted));

        // python-can's writer output, without the trailing columns.
        let frame = self::frame(
            "   1.000000 CANFD   1 Rx 123 1 1 9 12 00 01 02 03 04 05 06 07 08 09 0A 0B",
        );
        assert_eq!(
            frame.kind,
            FrameKind::Fd {
                flags: fd_flags(true, true)
            }
        );
        assert_eq!(frame.payload().len(), 12);
    }

    #[test]
    fn can_fd_lines_of_classic_frames_follow_the_flags() {
        // EDL clear, remote bit set: a classic remote frame.
        let frame = frame("  30.300981 CANFD   3 Tx     50005x                                0 1 5 0 140000 73 200050 7a60 46500250 460a0250 20011736 20010205");
        assert_eq!(
            frame.kind,
            FrameKind::Remote {
                requested_len: 5,
                len8_dlc: None
            }
        );
        assert_eq!(
            (frame.iface, frame.id),
            (iface("can2"), CanId::Extended(0x50005))
        );
        // EDL clear: a classic data frame on an FD channel.
        let frame = self::frame("   1.000000 CANFD   3 Rx 0C1 0 0 8 8 01 02 03 04 05 06 07 08   130000  111   320000 0 0 0 0 0");
        assert_eq!(frame.kind, FrameKind::Data { len8_dlc: None });
        assert_eq!(frame.payload(), &[1, 2, 3, 4, 5, 6, 7, 8]);
        // No flags column, length 0 with a DLC: python-can's remote rule.
        let frame = self::frame("   1.000000 CANFD   3 Rx 0C1 0 0 3 0");
        assert_eq!(
            frame.kind,
            FrameKind::Remote {
                requested_len: 3,
                len8_dlc: None
            }
        );
        // An empty FD frame.
        let frame = self::frame("   1.000000 CANFD   3 Rx 0C1 0 0 0 0");
        assert_eq!(
            frame.kind,
            FrameKind::Fd {
                flags: fd_flags(false, false)
            }
        );
    }

    #[test]
    fn other_events_are_skipped() {
        let log = format!(
            "{HEADER}   0.015991 CAN 1 Status:chip status error passive - TxErr: 132 RxErr: 0\n\
             1.015991 1  Statistic: D 0 R 0 XD 0 XR 0 E 0 O 0 B 0.00%\n\
             1.016000 1  Chip Statistic: BusLoad 0.00 Errors 0\n\
             3.297743 1  J1939TP FEE3p        6    0  0   -   Rx   d 23 A0 0F A6 60 3B D1 40 1F DE 80 25 DF C0 2B E1 00 4B FF FF 3C 0F 00\n\
             3.3 SV: 5 0 1 ::Rig::Load = 12.5\n\
             3.4 Log trigger event\n\
             3.5 1 123 TxRq d 1 00\n\
             3.6 CANFD 1 BusStatistic 12\n\
             3.7\n\
             \n\
             End TriggerBlock\n\
             no internal events logged\n"
        );
        assert!(read_all(&log).is_empty());
    }

    #[test]
    fn decimal_base_reads_ids_dlcs_and_bytes_in_decimal() {
        let header = "date Tue Mar 4 09:15:02.512 am 2025\nbase dec  timestamps absolute\n";
        let frame = frame_with(header, "1.0 1 291 Rx d 3 1 255 16");
        assert_eq!(frame.id, CanId::Standard(291));
        assert_eq!(frame.payload(), &[1, 255, 16]);
        let frame = frame_with(header, "1.0 1 419361024x Rx d 12 1 2 3 4 5 6 7 8");
        assert_eq!(frame.id, CanId::Extended(0x18FE_F100));
        assert_eq!(frame.kind, FrameKind::Data { len8_dlc: Some(12) });
        let frame = frame_with(
            header,
            "1.0 CANFD 2 Tx 2047 Name 1 0 9 12 0 1 2 3 4 5 6 7 8 9 10 200",
        );
        assert_eq!(
            (frame.iface, frame.id),
            (iface("can1"), CanId::Standard(0x7FF))
        );
        assert_eq!(frame.payload()[11], 200);
        // Hex digits are not decimal.
        let results = read_all(&format!(
            "{header}1.0 1 1A Rx d 1 00\n1.0 1 123 Rx d 1 FF\n"
        ));
        assert_eq!(results[0].as_ref().unwrap_err().expected, E_ID);
        assert_eq!(results[1].as_ref().unwrap_err().expected, E_DATA);
    }

    #[test]
    fn relative_timestamps_add_up() {
        let log = "date Sat Sep 30 15:06:13.191 2017\nbase hex timestamps relative\n\
                   0.000000 Start of measurement\n\
                   0.500000 1 123 Rx d 1 01\n\
                   0.250000 1 Statistic: D 0 R 0\n\
                   1.000001 1 124 Rx d 1 02\n";
        let frames = read_all(log);
        let start = 1_506_783_973_191_000_000;
        let (_, text, first) = frames[0].clone().unwrap();
        assert_eq!(
            (text.as_str(), first.timestamp_ns),
            ("0.500000", start + 500_000_000)
        );
        let (_, text, second) = frames[1].clone().unwrap();
        assert_eq!(
            (text.as_str(), second.timestamp_ns),
            ("1.000001", start + 1_750_001_000)
        );

        let log = "timestamps relative\n1.5 1 123 Rx d 0\n1.5 1 123 Rx d 0\n";
        let stamps: Vec<i64> = read_all(log)
            .into_iter()
            .map(|r| r.unwrap().2.timestamp_ns)
            .collect();
        assert_eq!(stamps, [1_500_000_000, 3_000_000_000]);
    }

    #[test]
    fn date_header_variants() {
        let date = |line: &str| {
            parse_date({
                let mut tokens = Tokens::new(line.as_bytes());
                tokens.next();
                tokens
            })
        };
        assert_eq!(date("date Tue Mar 4 09:15:02.512 am 2025"), Some(START_NS));
        assert_eq!(
            date("date Sam Sep 30 15:06:13.191 2017"),
            Some(1_506_783_973_191_000_000)
        );
        assert_eq!(
            date("date Thu Apr 28 10:44:52.480 am 2022"),
            Some(1_651_142_692_480_000_000)
        );
        assert_eq!(
            date("date Tue May 27 04:09:35.000 pm 2014"),
            Some(1_401_206_975_000_000_000)
        );
        assert_eq!(
            date("date Thu Feb 29 12:00:00 am 2024"),
            Some(1_709_164_800_000_000_000)
        );
        assert_eq!(
            date("date Tue Dec 31 11:59:59 PM 2024"),
            Some(1_735_689_599_000_000_000)
        );
        assert_eq!(
            date("date Sat January 1 00:00:00 2000"),
            Some(946_684_800_000_000_000)
        );
        assert_eq!(date("date Di Mär 4 09:15:02.512 2025"), Some(START_NS));
        assert_eq!(date("date Thu Jan 1 00:00:00.000000001 1970"), Some(1));
        for bad in [
            "date",
            "date Tue Mar 4 09:15:02 2025x",
            "date Tue Foo 4 09:15:02 2025",
            "date Fri Feb 29 09:15:02 2025",
            "date Tue Mar 4 24:00:00 2025",
            "date Tue Mar 4 00:00:00 pm 2025",
            "date Tue Mar 4 13:00:00 pm 2025",
            "date Tue Mar 4 09:60:00 2025",
            "date Tue Mar 4 09:15 2025",
            "date Tue Mar 4 09:15:02.1234567890 2025",
        ] {
            assert_eq!(date(bad), None, "{bad}");
        }
        assert_eq!(days_from_civil(1970, 1, 1), Some(0));
        assert_eq!(days_from_civil(2000, 3, 1), Some(11_017));
        assert_eq!(days_from_civil(1969, 12, 31), Some(-1));

        // A date line that cannot be read is an error at its line, not 1970.
        let results = read_all("date soon\n1.25 1 123 Rx d 0\n");
        match &results[0] {
            Err(error) => assert!(
                error.line() == Some(1) && error.expected.contains("date header"),
                "{error:?}"
            ),
            other => panic!("{other:?}"),
        }
        // Without a date line, times count from 0.
        let frame = frame_with("", "1.25 1 123 Rx d 0");
        assert_eq!(frame.timestamp_ns, 1_250_000_000);
    }

    #[test]
    fn malformed_lines_say_what_was_expected() {
        let cases: &[(&str, &str)] = &[
            ("1.0 0 123 Rx d 0", E_CHANNEL),
            ("1.0 1 123 d 8 00", E_DIRECTION),
            ("1.0 1 123 Rz d 0", E_DIRECTION),
            ("1.0 1 800 Rx d 0", E_STANDARD_ID),
            ("1.0 1 20000000x Rx d 0", E_EXTENDED_ID),
            ("1.0 1 123456789x Rx d 0", E_ID),
            ("1.0 1 Motor Rx d 0", E_ID),
            ("1.0 1 123 Rx q 0", E_KIND),
            ("1.0 1 123 Rx", E_KIND),
            ("1.0 1 123 Rx d", E_DLC),
            ("1.0 1 123 Rx d G", E_DLC),
            ("1.0 1 123 Rx d 10", E_DLC),
            ("1.0 1 123 Rx d 3 00 11", E_DATA),
            ("1.0 1 123 Rx d 2 00 1G", E_DATA),
            ("1.0 1 123 Rx d 1 100", E_DATA),
            ("1.0 1 123 Rx d 1 00 11", E_EXTRA_DATA),
            ("1.0 CANFD 1 Rx", E_FD_ID),
            ("1.0 CANFD 1 Rx Name 1 0 8 8", E_FD_ID),
            ("1.0 CANFD 0 Rx 123 1 0 0 0", E_CHANNEL),
            ("1.0 CANFD 1 Rx 123 Name 2 0 0 0", E_BRS),
            ("1.0 CANFD 1 Rx 123 Name", E_BRS),
            ("1.0 CANFD 1 Rx 123 1 x 0 0", E_ESI),
            ("1.0 CANFD 1 Rx 123 1 0 g 0", E_FD_DLC),
            ("1.0 CANFD 1 Rx 123 1 0 f 65", E_FD_LEN),
            ("1.0 CANFD 1 Rx 123 1 0 f 6x", E_FD_LEN),
            ("1.0 CANFD 1 Rx 123 1 0 9 12 00", E_DATA),
            ("1.0 CANFD 1 Rx 123 1 0 9 8 00 00 00 00 00 00 00 00", E_FD_LEN_MATCH),
            ("1.0 CANFD 1 Rx 123 1 0 5 1 00 0 0 200050", E_REMOTE_LEN),
            ("1.0 CANFD 1 Rx 123 1 0 5 3 00 01 02 0 0 0", E_CLASSIC_LEN_MATCH),
            ("1.0 CANFD 1 Rx 123 1 0 c 24 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 0 0 0", E_CLASSIC_LEN_MATCH),
            ("1.0. 1 123 Rx d 0", E_TIME),
            ("1 1 123 Rx d 0", E_TIME),
            ("1.0123456789 1 123 Rx d 0", E_TIME),
            ("99999999999.0 1 123 Rx d 0", E_TIME),
            ("9000000000.0 1 123 Rx d 0", E_TIME_RANGE),
            ("base oct", E_BASE),
            ("base hex timestamps sideways", E_TIMESTAMPS),
            ("timestamps", E_TIMESTAMPS),
            ("hello world", E_LINE),
            ("Begin", E_LINE),
        ];
        for (line, expected) in cases {
            assert_eq!(error_of(line), *expected, "{line}");
        }
    }

    #[test]
    fn the_reader_goes_on_after_an_error_and_numbers_lines() {
        let log = "\u{feff}date Tue Mar 4 09:15:02.512 am 2025\r\nbase hex  timestamps absolute\r\n1.0 1 123 Rx d 9\r\n2.0 1 124 Rx d 1 AA\r\n";
        let results = read_all(log);
        assert_eq!(results[0], Err(ParseError::new(3, E_DATA)));
        let (line, text, frame) = results[1].clone().unwrap();
        assert_eq!(
            (line, text.as_str(), frame.payload()),
            (4, "2.0", &[0xAA][..])
        );
        assert_eq!(frame.timestamp_ns, START_NS + 2_000_000_000);
        assert_eq!(results.len(), 2);
    }

    #[test]
    fn extreme_values_are_errors_not_panics() {
        for line in [
            "9223372036.854775807 1 123 Rx d 0",
            "9223372036.854775808 1 123 Rx d 0",
            "18446744073709551616.0 1 123 Rx d 0",
            "1.0 99999999999999999999999 123 Rx d 0",
            "1.0 4294967296 123 Rx d 0",
            "1.0 CANFD 99999999999999999999 Rx 1 1 0 0 0",
            "1.0 1 FFFFFFFFFx Rx d 0",
        ] {
            let _ = read_all(&format!("{HEADER}{line}\n"));
            let _ = read_all(&format!("timestamps relative\n{line}\n{line}\n"));
        }
        // Interface names have at most 15 bytes: channels up to 10^12.
        let frame = frame("1.0 1000000000000 123 Rx d 0");
        assert_eq!(frame.iface, iface("can999999999999"));
        assert_eq!(error_of("1.0 10000000000000 123 Rx d 0"), E_CHANNEL);
        assert_eq!(error_of("1.0 18446744073709551616 123 Rx d 0"), E_CHANNEL);
    }
}
