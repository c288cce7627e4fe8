//! The candump log format: what `candump -L` writes and `canplayer` reads.
//!
//! ```text
//! (1700000000.123456) can0 123#11223344            classic, 11-bit id
//! (1700000000.123457) can0 18FEF100#0102030405060708_C   29-bit id, raw DLC 12
//! (1700000000.123458) can0 123#R4                  remote frame, DLC 4
//! (1700000000.123459) can0 123##5112233            CAN FD, flags BRS|FDF
//! (1700000000.123460) can0 20000004#0000040000000000     error frame
//! (1700000000.123461) can0 123#1122 R              direction (candump -x)
//! ```
//!
//! Reader and writer follow can-utils' `lib.c` (`parse_canframe`,
//! `snprintf_canframe`) so that a log written here replays with
//! `canplayer` and a log from `candump -L` reads back byte-for-byte.
//! Reading is streaming: one reused line buffer, constant memory.

use std::io::{self, BufRead, Write};
use std::ops::ControlFlow;

use super::batch::FrameBatch;
use super::record::{LogRecord, ParseError, ReadError};
use crate::frame::{
    CanId, Direction, Frame, FrameFields, FrameKind, IfaceName, CAN_ERR_FLAG, CLASSIC_MAX_LEN,
    FD_MAX_LEN, MAX_EXTENDED_ID, MAX_STANDARD_ID,
};
use crate::{decimal, hex};

const E_CUT_LINE: &str =
    "a line ended by a newline (the file ends inside its last line: cut short?)";

/// Streaming reader of candump logs.
pub struct CandumpReader<R> {
    input: R,
    buffer: Vec<u8>,
    line: u64,
    /// The bytes of the line last returned, still in `input`'s buffer
    /// (the record borrows them); consumed when the next one is read.
    returned_bytes: usize,
    /// The last line's interface: the next line's is nearly always one of
    /// a few, and a name equal to it is not checked again.
    last_iface: Option<IfaceName>,
    /// Read in pieces: the start of the line the last piece ended inside.
    carried: Vec<u8>,
}

impl<R: BufRead> CandumpReader<R> {
    pub fn new(input: R) -> Self {
        CandumpReader {
            input,
            buffer: Vec::with_capacity(256),
            line: 0,
            returned_bytes: 0,
            last_iface: None,
            carried: Vec::new(),
        }
    }

    /// The next record; blank lines and `#` comment lines are skipped.
    /// `Ok(None)` at the end of the log. After an `Err(Parse)` the reader
    /// can go on with the next line.
    pub fn next_record(&mut self) -> Result<Option<LogRecord<'_>>, ReadError> {
        // The line is parsed where it lies in the input's buffer; only one
        // that buffer holds part of is copied out first (the careful way).
        let len = loop {
            self.input.consume(std::mem::take(&mut self.returned_bytes));
            let available = self.input.fill_buf()?;
            let Some(newline) = memchr::memchr(b'\n', available) else {
                return self.next_record_copied();
            };
            self.line += 1;
            self.returned_bytes = newline + 1;
            let len = trim_line_end(&available[..newline]).len();
            if len > 0 && available[0] != b'#' {
                break len;
            }
        };
        let line = self.line;
        // The bytes above, again: nothing was consumed since.
        let text = &self.input.fill_buf()?[..len];
        record(line, text, &mut self.last_iface)
    }

    /// [`CandumpReader::next_record`] for a line the input's buffer does
    /// not hold whole (or the log's last, cut before its newline): read
    /// into a line buffer of its own.
    fn next_record_copied(&mut self) -> Result<Option<LogRecord<'_>>, ReadError> {
        loop {
            self.buffer.clear();
            if self.input.read_until(b'\n', &mut self.buffer)? == 0 {
                return Ok(None);
            }
            self.line += 1;
            // A length, not a slice: a borrow held across the `continue`
            // would outlive the loop (the borrow checker's NLL limit).
            let len = trim_line_end(&self.buffer).len();
            if len == 0 || self.buffer[0] == b'#' {
                continue;
            }
            let line = self.line;
            // candump ends every line with a newline: a last line without
            // one was cut, and may read as a shorter frame than was logged.
            if self.buffer.last() != Some(&b'\n') {
                return Err(ReadError::Parse(ParseError::new(line, E_CUT_LINE)));
            }
            return record(line, &self.buffer[..len], &mut self.last_iface);
        }
    }

    /// Fills `batch` with the next frames, up to `max` in all (see
    /// [`crate::log::LogReader::next_batch`]); `false` at the end. The
    /// lines are parsed where they lie in the input's buffer, not copied
    /// into a line buffer first; a line the buffer holds only part of is
    /// read by [`CandumpReader::next_record`].
    pub fn next_batch(&mut self, batch: &mut FrameBatch, max: usize) -> Result<bool, ReadError> {
        let mut last_iface: Option<(IfaceName, u16)> = None;
        while batch.len() < max {
            self.input.consume(std::mem::take(&mut self.returned_bytes));
            let buffer = self.input.fill_buf()?;
            if buffer.is_empty() {
                return Ok(false);
            }
            let mut consumed = 0;
            let mut failure = None;
            for newline in memchr::memchr_iter(b'\n', buffer) {
                let text = trim_line_end(&buffer[consumed..newline]);
                consumed = newline + 1;
                self.line += 1;
                if text.is_empty() || text[0] == b'#' {
                    continue;
                }
                if let Some(usual) = parse_usual_line(text) {
                    let interface = match last_iface {
                        Some((iface, index)) if iface.as_bytes() == usual.iface => Some(index),
                        // Not a name Linux takes (`None`): parse_line says why.
                        _ => IfaceName::from_bytes(usual.iface).map(|iface| {
                            let index = batch.interface_index(iface);
                            last_iface = Some((iface, index));
                            index
                        }),
                    };
                    if let Some(interface) = interface {
                        batch.timestamp_ns.push(usual.timestamp_ns);
                        batch.interface.push(interface);
                        batch.id.push(usual.id);
                        batch.kind.push(FrameKind::Data { len8_dlc: None });
                        batch.direction.push(usual.direction);
                        batch.push_payload_of_eight(&usual.data, usual.len);
                        if batch.len() >= max {
                            break;
                        }
                        continue;
                    }
                }
                match parse_line(text) {
                    Ok((_, frame)) => {
                        let interface = match last_iface {
                            Some((iface, index)) if iface == frame.iface => index,
                            _ => {
                                let index = batch.interface_index(frame.iface);
                                last_iface = Some((frame.iface, index));
                                index
                            }
                        };
                        batch.push_on(&frame, interface);
                    }
                    Err(expected) => {
                        failure = Some(ParseError::new(self.line, expected));
                        break;
                    }
                }
                if batch.len() >= max {
                    break;
                }
            }
            if consumed == 0 {
                // Not one whole line in the buffer: this one the careful way.
                match self.next_record()? {
                    Some(record) => batch.push(&record.frame),
                    None => return Ok(false),
                }
                continue;
            }
            self.input.consume(consumed);
            if let Some(error) = failure {
                return Err(ReadError::Parse(error));
            }
        }
        Ok(true)
    }

    /// Lines read so far.
    pub fn line(&self) -> u64 {
        self.line
    }

    /// Appends the log's next whole lines to `out`, newlines included:
    /// the line the last piece ended inside, then what one read of up to
    /// `bytes` brings, up to its last newline (reading on where it holds
    /// none); at the end of the log, a last line without its newline as it
    /// is. The bytes appended; 0 at the end. For readers of a log in
    /// pieces, each piece's lines then read on their own
    /// ([`read_whole_lines`]): the lines are not parsed here, and
    /// [`CandumpReader::line`] does not move. A log read in pieces is read
    /// in pieces to its end: the line a piece ended inside waits here.
    ///
    /// The bytes go from the input straight into `out` where the input is
    /// a `BufReader` of at most `bytes` (it passes a read that large by its
    /// buffer): read into the buffer and copied out of it, they cost a
    /// decode about a twentieth of its time (BENCHMARKS.md).
    pub fn read_lines_into(&mut self, out: &mut Vec<u8>, bytes: usize) -> io::Result<usize> {
        self.input.consume(std::mem::take(&mut self.returned_bytes));
        let start = out.len();
        out.append(&mut self.carried);
        loop {
            let read_from = out.len();
            out.resize(read_from + bytes.max(1), 0);
            let read = loop {
                match self.input.read(&mut out[read_from..]) {
                    Ok(read) => break read,
                    Err(error) if error.kind() == io::ErrorKind::Interrupted => continue,
                    Err(error) => {
                        out.truncate(read_from);
                        return Err(error);
                    }
                }
            };
            out.truncate(read_from + read);
            if read == 0 {
                return Ok(out.len() - start);
            }
            if let Some(newline) = memchr::memrchr(b'\n', &out[read_from..]) {
                let end = read_from + newline + 1;
                self.carried.extend_from_slice(&out[end..]);
                out.truncate(end);
                return Ok(out.len() - start);
            }
        }
    }
}

/// The record of line number `line`, `text` without its end; `last_iface`
/// the interface of the line before, if it was a usual one.
fn record<'t>(
    line: u64,
    text: &'t [u8],
    last_iface: &mut Option<IfaceName>,
) -> Result<Option<LogRecord<'t>>, ReadError> {
    if let Some((usual, iface)) = usual_line_on(text, last_iface) {
        if let Ok(mut frame) = Frame::data(
            usual.timestamp_ns,
            iface,
            usual.id,
            &usual.data[..usual.len],
        ) {
            frame.direction = usual.direction;
            return Ok(Some(LogRecord {
                line,
                // Digits and a dot.
                timestamp_text: &text[1..usual.timestamp_end],
                frame,
            }));
        }
    }
    match parse_line(text) {
        Ok((timestamp, frame)) => Ok(Some(LogRecord {
            line,
            // The timestamp was checked to be ASCII digits and a dot.
            timestamp_text: &text[timestamp.0..timestamp.1],
            frame,
        })),
        Err(expected) => Err(ReadError::Parse(ParseError::new(line, expected))),
    }
}

/// A usual line's fields and its interface (`last_iface` the line
/// before's, then this one's): `None` for a line of another shape, or
/// with a name no interface has, which [`parse_line`] reads.
#[inline]
fn usual_line_on<'t>(
    text: &'t [u8],
    last_iface: &mut Option<IfaceName>,
) -> Option<(UsualLine<'t>, IfaceName)> {
    let usual = parse_usual_line(text)?;
    let iface = match *last_iface {
        Some(last) if last.is(usual.iface) => Some(last),
        _ => IfaceName::from_bytes(usual.iface),
    };
    *last_iface = iface;
    Some((usual, iface?))
}

/// A frame of a candump text held in memory, given where it lies: a usual
/// line's fields with no [`Frame`] built. Building one (its 64 bytes
/// zeroed and filled, then moved out through the reader's result) and
/// reading it back cost a CSV decode more than the line's parse did
/// (BENCHMARKS.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineFrame<'t> {
    /// 1-based line number within the text.
    pub line: u64,
    /// The timestamp as the line writes it, as in [`LogRecord`].
    pub timestamp_text: &'t [u8],
    pub iface: IfaceName,
    pub direction: Option<Direction>,
    pub fields: FrameFields<'t>,
}

/// Reads `text`, whole candump lines held in memory (a piece that
/// [`CandumpReader::read_lines_into`] gave), as a [`CandumpReader`] over
/// it reads them: blank and `#` lines skipped, a last line without its
/// newline refused as cut short. Each frame goes to `frame`, each
/// malformed line's error to `malformed`, which says whether to read on.
/// Gives the lines read: all of `text`'s, or up to the malformed one where
/// `malformed` stopped.
pub fn read_whole_lines(
    text: &[u8],
    mut frame: impl FnMut(LineFrame<'_>),
    mut malformed: impl FnMut(ParseError) -> ControlFlow<()>,
) -> u64 {
    let mut last_iface = None;
    let mut line = 0;
    let mut start = 0;
    let newline = NewlineSearch::new();
    loop {
        let rest = match text.get(start..) {
            Some(rest) if !rest.is_empty() => rest,
            _ => break,
        };
        let (whole, ended) = match newline.find(rest) {
            Some(end) => (&rest[..end], true),
            None => (rest, false),
        };
        start += whole.len() + 1;
        line += 1;
        let text = trim_line_end(whole);
        if text.is_empty() || text[0] == b'#' {
            continue;
        }
        let read = if ended {
            line_frame(line, text, &mut last_iface, &mut frame)
        } else {
            Err(ParseError::new(line, E_CUT_LINE))
        };
        if let Err(error) = read {
            if malformed(error).is_break() {
                break;
            }
        }
    }
    line
}

/// The search for a line's end: SSE2's, straight, on x86-64 (every x86-64
/// processor has it). `memchr`'s own dispatch, to AVX2 through a function
/// pointer at each call, cost more than the search of a candump line of
/// about 46 bytes did (BENCHMARKS.md).
#[derive(Clone, Copy)]
struct NewlineSearch {
    #[cfg(target_arch = "x86_64")]
    sse2: Option<memchr::arch::x86_64::sse2::memchr::One>,
}

impl NewlineSearch {
    fn new() -> Self {
        NewlineSearch {
            #[cfg(target_arch = "x86_64")]
            sse2: memchr::arch::x86_64::sse2::memchr::One::new(b'\n'),
        }
    }

    /// Where the first newline of `text` is.
    #[inline(always)]
    fn find(&self, text: &[u8]) -> Option<usize> {
        #[cfg(target_arch = "x86_64")]
        if let Some(sse2) = &self.sse2 {
            return sse2.find(text);
        }
        memchr::memchr(b'\n', text)
    }
}

/// Line `line`'s frame (`text` without its end) given to `frame`, read as
/// [`record`] reads it.
#[inline]
fn line_frame(
    line: u64,
    text: &[u8],
    last_iface: &mut Option<IfaceName>,
    frame: &mut impl FnMut(LineFrame<'_>),
) -> Result<(), ParseError> {
    // Each read where it is kept until `frame` has it: one call of `frame`,
    // which the caller's loop then holds.
    let (usual, parsed);
    let read = if let Some((fields, iface)) = usual_line_on(text, last_iface) {
        usual = fields;
        LineFrame {
            line,
            timestamp_text: &text[1..usual.timestamp_end],
            iface,
            direction: usual.direction,
            fields: FrameFields {
                timestamp_ns: usual.timestamp_ns,
                id: usual.id,
                kind: FrameKind::Data { len8_dlc: None },
                payload: &usual.data[..usual.len],
            },
        }
    } else {
        let timestamp;
        (timestamp, parsed) =
            parse_line(text).map_err(|expected| ParseError::new(line, expected))?;
        LineFrame {
            line,
            timestamp_text: &text[timestamp.0..timestamp.1],
            iface: parsed.iface,
            direction: parsed.direction,
            fields: parsed.fields(),
        }
    };
    frame(read);
    Ok(())
}

#[inline]
fn trim_line_end(line: &[u8]) -> &[u8] {
    let mut end = line.len();
    while end > 0 && matches!(line[end - 1], b'\n' | b'\r' | b' ' | b'\t') {
        end -= 1;
    }
    &line[..end]
}

/// Parses one log line (without its newline). Returns the byte range of the
/// timestamp text and the frame, or what was expected where parsing stopped.
pub fn parse_line(line: &[u8]) -> Result<((usize, usize), Frame), &'static str> {
    const TIMESTAMP: &str = "a timestamp '(seconds.microseconds)' at the start of the line";
    if line.first() != Some(&b'(') {
        return Err(TIMESTAMP);
    }
    let close = position(line, |b| b == b')').ok_or(TIMESTAMP)?;
    let timestamp_ns = parse_timestamp(&line[1..close]).ok_or(TIMESTAMP)?;

    let mut rest = &line[close + 1..];
    let iface = next_field(&mut rest).ok_or("an interface name after the timestamp")?;
    let iface =
        IfaceName::from_bytes(iface).ok_or("an interface name of 1-15 printable characters")?;
    let frame_text = next_field(&mut rest).ok_or("a frame 'ID#DATA' after the interface")?;
    let mut frame = parse_frame(frame_text, timestamp_ns, iface)?;
    match next_field(&mut rest) {
        None => {}
        Some(b"R") => frame.direction = Some(Direction::Received),
        Some(b"T") => frame.direction = Some(Direction::Transmitted),
        Some(_) => return Err("the end of the line or a direction 'R'/'T' after the frame"),
    }
    if next_field(&mut rest).is_some() {
        return Err("the end of the line after the direction");
    }
    Ok(((1, close), frame))
}

/// A line of the shape nearly every line of a log has: `(SECONDS.FRACTION)
/// IFACE ID#DATA`, one space between the fields, a classic data frame of
/// 0-8 bytes (no remote, error or CAN FD frame, no `.` or `_` in the
/// data), perhaps a direction ` R`/` T`. Its fields as [`parse_line`]
/// reads them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UsualLine<'a> {
    pub timestamp_ns: i64,
    /// Where the timestamp's `)` is: its text is `line[1..timestamp_end]`.
    pub timestamp_end: usize,
    /// Not checked: [`IfaceName::from_bytes`] has the last word.
    pub iface: &'a [u8],
    pub id: CanId,
    pub data: [u8; CLASSIC_MAX_LEN],
    pub len: usize,
    pub direction: Option<Direction>,
}

/// [`parse_line`] for a line of [`UsualLine`]'s shape, in one pass with no
/// frame built: `None` for any other line (which [`parse_line`] then
/// reads, or says what is wrong with). Where it gives a line, it gives
/// what [`parse_line`] gives: a property test and the fuzz target hold it
/// to that.
#[inline(always)]
pub fn parse_usual_line(line: &[u8]) -> Option<UsualLine<'_>> {
    let (&open, rest) = line.split_first()?;
    if open != b'(' {
        return None;
    }
    let (timestamp_ns, at) = match candump_timestamp(rest) {
        Some(read) => read,
        None => general_timestamp(rest)?,
    };
    // `rest` starts after the '('.
    let timestamp_end = 1 + at;
    let rest = &rest[at + 2..];

    // The interface, a space.
    let iface_len = rest.iter().position(|&b| b == b' ' || b == b'\t')?;
    if rest[iface_len] != b' ' {
        return None;
    }
    let iface = &rest[..iface_len];
    let rest = &rest[iface_len + 1..];

    // The id: 3 or 8 hex digits, then '#'.
    let hash = rest[..rest.len().min(9)].iter().position(|&b| b == b'#')?;
    let id_value = hex::parse_u32(&rest[..hash])?;
    let id = match hash {
        3 if id_value <= u32::from(MAX_STANDARD_ID) => CanId::Standard(id_value as u16),
        8 if id_value <= MAX_EXTENDED_ID => CanId::Extended(id_value),
        _ => return None,
    };
    let rest = &rest[hash + 1..];

    // Pairs of hex digits up to the end or a direction.
    let (digits, direction) = match rest {
        [digits @ .., b' ', b'R'] => (digits, Some(Direction::Received)),
        [digits @ .., b' ', b'T'] => (digits, Some(Direction::Transmitted)),
        digits => (digits, None),
    };
    let mut data = [0u8; CLASSIC_MAX_LEN];
    hex::read_pairs(digits, &mut data)?;
    let len = digits.len() / 2;
    Some(UsualLine {
        timestamp_ns,
        timestamp_end,
        iface,
        id,
        data,
        len,
        direction,
    })
}

/// The time of a timestamp as candump writes it, `SSSSSSSSSS.UUUUUU) `
/// (`rest` after the `(`): in ns, and where its `)` is. Sixteen digits
/// read eight at a time; `None` for any other shape.
#[inline(always)]
fn candump_timestamp(rest: &[u8]) -> Option<(i64, usize)> {
    let text: &[u8; 19] = rest.get(..19)?.try_into().ok()?;
    if text[10] != b'.' || text[17] != b')' || text[18] != b' ' {
        return None;
    }
    let [first, second, ..] = *text;
    let seconds_high = [b'0', b'0', b'0', b'0', b'0', b'0', first, second];
    let seconds_low: [u8; 8] = text[2..10].try_into().ok()?;
    let micros: [u8; 8] = [
        b'0', b'0', text[11], text[12], text[13], text[14], text[15], text[16],
    ];
    let seconds = i64::from(decimal::eight_digits(seconds_high)?) * 100_000_000
        + i64::from(decimal::eight_digits(seconds_low)?);
    let micros = i64::from(decimal::eight_digits(micros)?);
    // Ten digits of seconds pass i64's nanoseconds past 9,223,372,036.
    let timestamp_ns = seconds
        .checked_mul(1_000_000_000)?
        .checked_add(micros * 1_000)?;
    Some((timestamp_ns, 17))
}

/// The time of any timestamp [`parse_line`] reads, `SECONDS.FRACTION) `
/// (`rest` after the `(`; 1-12 and 1-9 digits): in ns, and where its `)`
/// is.
fn general_timestamp(rest: &[u8]) -> Option<(i64, usize)> {
    // Each run read one digit past its longest, no further: more would
    // overflow, and is refused anyway.
    let mut whole: i64 = 0;
    let mut at = 0;
    while let Some(&d) = rest.get(at).filter(|d| d.is_ascii_digit() && at <= 12) {
        whole = whole * 10 + i64::from(d - b'0');
        at += 1;
    }
    if !(1..=12).contains(&at) || rest.get(at) != Some(&b'.') {
        return None;
    }
    let fraction_start = at + 1;
    let mut nanos: i64 = 0;
    at = fraction_start;
    while let Some(&d) = rest
        .get(at)
        .filter(|d| d.is_ascii_digit() && at - fraction_start <= 9)
    {
        nanos = nanos * 10 + i64::from(d - b'0');
        at += 1;
    }
    let fraction_digits = at - fraction_start;
    if !(1..=9).contains(&fraction_digits) || rest.get(at..at + 2) != Some(b") ") {
        return None;
    }
    nanos *= 10i64.pow(9 - fraction_digits as u32);
    let timestamp_ns = whole.checked_mul(1_000_000_000)?.checked_add(nanos)?;
    Some((timestamp_ns, at))
}

/// Where the first byte of a field of a few bytes meets `wanted`. A plain
/// loop, not memchr: on a timestamp or an id, memchr's call and dispatch
/// are most of its cost (its entry points were a tenth of a CSV decode's
/// profile, the line's newline search included).
#[inline]
fn position(field: &[u8], wanted: impl Fn(u8) -> bool) -> Option<usize> {
    field.iter().position(|&b| wanted(b))
}

/// The next field of `rest` between spaces and tabs, `rest` moved past it.
#[inline]
fn next_field<'a>(rest: &mut &'a [u8]) -> Option<&'a [u8]> {
    let start = position(rest, |b| b != b' ' && b != b'\t')?;
    let field = &rest[start..];
    let len = position(field, |b| b == b' ' || b == b'\t').unwrap_or(field.len());
    *rest = &field[len..];
    Some(&field[..len])
}

/// `seconds.fraction` (1-9 fraction digits) -> ns since the epoch.
fn parse_timestamp(text: &[u8]) -> Option<i64> {
    let dot = position(text, |b| b == b'.')?;
    let (seconds, fraction) = (&text[..dot], &text[dot + 1..]);
    if seconds.is_empty() || seconds.len() > 12 || fraction.is_empty() || fraction.len() > 9 {
        return None;
    }
    let mut whole: i64 = 0;
    for &d in seconds {
        if !d.is_ascii_digit() {
            return None;
        }
        whole = whole * 10 + i64::from(d - b'0');
    }
    let mut nanos: i64 = 0;
    for &d in fraction {
        if !d.is_ascii_digit() {
            return None;
        }
        nanos = nanos * 10 + i64::from(d - b'0');
    }
    nanos *= 10i64.pow(9 - fraction.len() as u32);
    whole.checked_mul(1_000_000_000)?.checked_add(nanos)
}

/// Parses `ID#DATA` (the frame field of a log line, also `cansend` syntax).
pub fn parse_frame(
    text: &[u8],
    timestamp_ns: i64,
    iface: IfaceName,
) -> Result<Frame, &'static str> {
    const ID: &str = "an id of 3 hex digits (11-bit) or 8 hex digits (29-bit) before '#'";
    let hash = position(text, |b| b == b'#').ok_or(ID)?;
    let id_value = hex::parse_u32(&text[..hash]).ok_or(ID)?;
    let rest = &text[hash + 1..];
    let id = match hash {
        3 => CanId::Standard(
            u16::try_from(id_value)
                .ok()
                .filter(|&v| v <= MAX_STANDARD_ID)
                .ok_or("an 11-bit id (at most 7FF)")?,
        ),
        8 if id_value & CAN_ERR_FLAG != 0 => {
            let class = id_value & !CAN_ERR_FLAG;
            if class > MAX_EXTENDED_ID {
                return Err("an error-frame id of at most 3FFFFFFF");
            }
            let details = parse_data(rest, CLASSIC_MAX_LEN)?;
            if details.1.is_some() {
                return Err("no '_<dlc>' escape on an error frame");
            }
            return Frame::error(timestamp_ns, iface, class, &details.0[..details.2])
                .map_err(|_| "at most 8 data bytes in an error frame");
        }
        8 => CanId::Extended(
            Some(id_value)
                .filter(|&v| v <= MAX_EXTENDED_ID)
                .ok_or("a 29-bit id (at most 1FFFFFFF) or an error frame (20000000 set)")?,
        ),
        _ => return Err(ID),
    };

    match rest.first() {
        Some(b'R' | b'r') => parse_remote(&rest[1..], timestamp_ns, iface, id),
        Some(b'#') => {
            let flags = rest
                .get(1)
                .and_then(|&d| hex::nibble(d))
                .ok_or("one hex digit of CAN FD flags after '##'")?;
            let (data, len8, len) = parse_data(&rest[2..], FD_MAX_LEN)?;
            if len8.is_some() {
                return Err("no '_<dlc>' escape on a CAN FD frame");
            }
            Frame::fd(timestamp_ns, iface, id, flags, &data[..len])
                .map_err(|_| "at most 64 data bytes in a CAN FD frame")
        }
        _ => {
            let (data, len8, len) = parse_data(rest, CLASSIC_MAX_LEN)?;
            let mut frame = Frame::data(timestamp_ns, iface, id, &data[..len])
                .map_err(|_| "at most 8 data bytes in a classic CAN frame")?;
            if let Some(dlc) = len8 {
                frame
                    .set_len8_dlc(dlc)
                    .map_err(|_| "a raw DLC 9-F after '_', only with 8 data bytes")?;
            }
            Ok(frame)
        }
    }
}

fn parse_remote(
    rest: &[u8],
    timestamp_ns: i64,
    iface: IfaceName,
    id: CanId,
) -> Result<Frame, &'static str> {
    const DLC: &str = "nothing, or a DLC 0-8 (and '_<raw dlc>' after 8), after 'R'";
    let (requested, len8) = match rest {
        [] => (0, None),
        [d] => (hex::nibble(*d).filter(|&v| v <= 8).ok_or(DLC)?, None),
        [b'8', b'_', raw] => (8, Some(hex::nibble(*raw).ok_or(DLC)?)),
        _ => return Err(DLC),
    };
    let mut frame = Frame::remote(timestamp_ns, iface, id, requested).map_err(|_| DLC)?;
    if let Some(dlc) = len8 {
        frame.set_len8_dlc(dlc).map_err(|_| DLC)?;
    }
    Ok(frame)
}

/// Hex byte pairs, optionally separated by '.', at most `max` bytes, then an
/// optional `_<raw dlc>`. Returns (buffer, raw dlc, length).
fn parse_data(
    text: &[u8],
    max: usize,
) -> Result<([u8; FD_MAX_LEN], Option<u8>, usize), &'static str> {
    const DATA: &str = "data as pairs of hex digits after '#'";
    let mut data = [0u8; FD_MAX_LEN];
    let mut len = 0;
    let mut i = 0;
    while i < text.len() {
        match text[i] {
            b'.' => i += 1,
            b'_' => {
                let dlc = match &text[i + 1..] {
                    [d] => hex::nibble(*d).ok_or("a hex raw DLC after '_'")?,
                    _ => return Err("exactly one hex digit (the raw DLC) after '_'"),
                };
                if len != CLASSIC_MAX_LEN {
                    return Err("'_<dlc>' only after exactly 8 data bytes");
                }
                return Ok((data, Some(dlc), len));
            }
            high => {
                let high = hex::nibble(high).ok_or(DATA)?;
                let low = text
                    .get(i + 1)
                    .and_then(|&d| hex::nibble(d))
                    .ok_or("an even number of hex digits in the data")?;
                if len == max {
                    return Err(if max == CLASSIC_MAX_LEN {
                        "at most 8 data bytes in a classic CAN frame"
                    } else {
                        "at most 64 data bytes in a CAN FD frame"
                    });
                }
                data[len] = (high << 4) | low;
                len += 1;
                i += 2;
            }
        }
    }
    Ok((data, None, len))
}

/// Appends the frame field (`ID#DATA`) exactly as can-utils prints it.
pub fn push_frame(out: &mut Vec<u8>, frame: &Frame) {
    match frame.kind {
        FrameKind::Error { class } => hex::push_fixed(out, class | CAN_ERR_FLAG, 8),
        _ => match frame.id {
            CanId::Standard(id) => hex::push_fixed(out, u32::from(id), 3),
            CanId::Extended(id) => hex::push_fixed(out, id, 8),
        },
    }
    out.push(b'#');
    let push_dlc_escape = |out: &mut Vec<u8>, len8: Option<u8>| {
        if let Some(dlc) = len8 {
            out.push(b'_');
            out.push(hex::upper_digit(dlc));
        }
    };
    match frame.kind {
        FrameKind::Remote {
            requested_len,
            len8_dlc,
        } => {
            out.push(b'R');
            if requested_len > 0 {
                out.push(hex::upper_digit(requested_len));
                push_dlc_escape(out, len8_dlc);
            }
        }
        FrameKind::Fd { flags } => {
            out.push(b'#');
            out.push(hex::upper_digit(flags));
            frame.payload().iter().for_each(|&b| hex::push_byte(out, b));
        }
        FrameKind::Data { len8_dlc } => {
            frame.payload().iter().for_each(|&b| hex::push_byte(out, b));
            push_dlc_escape(out, len8_dlc);
        }
        FrameKind::Error { .. } => frame.payload().iter().for_each(|&b| hex::push_byte(out, b)),
    }
}

/// A timestamp as a `candump -L` line keeps it: whole microseconds, cut
/// (not rounded); what the recorder writes, so what any pass over
/// `raw.log` reads back. A negative one is written as 0.
pub fn logged_timestamp_ns(timestamp_ns: i64) -> i64 {
    timestamp_ns.max(0) / 1_000 * 1_000
}

/// Appends one full log line (with newline) in `candump -L` form.
/// Timestamps are written in microseconds (the format's resolution);
/// a negative timestamp cannot be written and is an error.
pub fn push_line(out: &mut Vec<u8>, frame: &Frame) -> Result<(), NegativeTimestamp> {
    if frame.timestamp_ns < 0 {
        return Err(NegativeTimestamp(frame.timestamp_ns));
    }
    let seconds = frame.timestamp_ns / 1_000_000_000;
    let micros = (frame.timestamp_ns % 1_000_000_000) / 1_000;
    out.push(b'(');
    let mut digits = itoa::Buffer::new();
    let seconds_text = digits.format(seconds).as_bytes();
    out.extend(std::iter::repeat_n(
        b'0',
        10usize.saturating_sub(seconds_text.len()),
    ));
    out.extend_from_slice(seconds_text);
    out.push(b'.');
    let micros_text = digits.format(micros).as_bytes();
    out.extend(std::iter::repeat_n(b'0', 6 - micros_text.len()));
    out.extend_from_slice(micros_text);
    out.extend_from_slice(b") ");
    out.extend_from_slice(frame.iface.as_bytes());
    out.push(b' ');
    push_frame(out, frame);
    match frame.direction {
        Some(Direction::Received) => out.extend_from_slice(b" R"),
        Some(Direction::Transmitted) => out.extend_from_slice(b" T"),
        None => {}
    }
    out.push(b'\n');
    Ok(())
}

/// A frame stamped before 1970 cannot be written in candump format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("timestamp {0} ns is before 1970; candump logs cannot hold it")]
pub struct NegativeTimestamp(pub i64);

/// Buffered candump log writer.
pub struct CandumpWriter<W: Write> {
    output: W,
    line: Vec<u8>,
}

impl<W: Write> CandumpWriter<W> {
    pub fn new(output: W) -> Self {
        CandumpWriter {
            output,
            line: Vec::with_capacity(192),
        }
    }

    pub fn write_frame(&mut self, frame: &Frame) -> io::Result<()> {
        self.line.clear();
        push_line(&mut self.line, frame)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
        self.output.write_all(&self.line)
    }

    pub fn flush(&mut self) -> io::Result<()> {
        self.output.flush()
    }

    pub fn into_inner(self) -> W {
        self.output
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A data frame's time, interface, id, payload and direction.
    type DataFrameFields = (i64, IfaceName, CanId, Vec<u8>, Option<Direction>);

    /// What [`parse_line`] makes of a line, in [`UsualLine`]'s terms.
    fn as_parse_line_reads(line: &[u8]) -> Option<DataFrameFields> {
        let (_, frame) = parse_line(line).ok()?;
        matches!(frame.kind, FrameKind::Data { len8_dlc: None }).then(|| {
            (
                frame.timestamp_ns,
                frame.iface,
                frame.id,
                frame.payload().to_vec(),
                frame.direction,
            )
        })
    }

    /// Lines near the usual shape: each part usual or one of its
    /// near misses (a field too long or short, another separator, a byte
    /// that is not a digit, another kind of frame).
    fn near_usual_line() -> impl proptest::strategy::Strategy<Value = Vec<u8>> {
        use proptest::prelude::*;
        // The usual part most of the time, so that most lines have one or
        // two parts off the usual shape.
        let seconds = prop_oneof![
            12 => "[0-9]{1,12}",
            1 => Just(String::new()),
            1 => "[0-9]{13}",
            1 => "9{12}",
            1 => "[0-9]{3}[ a+-][0-9]{2}",
            // candump's own ten digits, read eight at a time: some with a
            // byte next to the digits (`/`, `:`) or beyond nine digits.
            6 => "[0-9]{10}",
            2 => "[0-9]{0,9}[/:a ][0-9]{0,9}",
            1 => "9{10}",
        ];
        let fraction = prop_oneof![
            12 => "[0-9]{1,9}",
            1 => Just(String::new()),
            1 => "[0-9]{10}",
            1 => "[0-9]x",
            6 => "[0-9]{6}",
            2 => "[0-9]{0,5}[/:a][0-9]{0,5}",
        ];
        let gap = prop_oneof![12 => Just(" "), 1 => Just("  "), 1 => Just("\t"), 1 => Just("")];
        let iface = prop_oneof![
            12 => "[a-z]{1,4}[0-9]",
            1 => "[a-z]{16}",
            1 => "ca/n0",
            1 => "c\u{e9}n",
            1 => "c\\)n0",
        ];
        let id = prop_oneof![
            6 => "[0-7][0-9A-Fa-f]{2}",
            1 => "[89A-F][0-9A-F]{2}",
            6 => "[01][0-9A-F]{7}",
            1 => "[2-9A-F][0-9A-F]{7}",
            1 => "[0-9A-F]{1,2}",
            1 => "[0-9A-F]{4,7}",
            1 => "[0-9A-F]{9}",
            1 => "1G3",
        ];
        let data = prop_oneof![
            12 => "([0-9A-Fa-f]{2}){0,8}",
            1 => "([0-9A-F]{2}){9}",
            1 => "[0-9A-F]{3}",
            1 => "[0-9A-F]{2}\\.[0-9A-F]{2}",
            1 => "([0-9A-F]{2}){8}_[0-9A-F]",
            1 => "R[0-8]?",
            1 => "#[0-9A-F]([0-9A-F]{2}){0,12}",
            1 => "[0-9A-F]{2}G[0-9A-F]",
        ];
        let tail = prop_oneof![
            8 => Just(""),
            2 => Just(" R"),
            2 => Just(" T"),
            1 => Just(" X"),
            1 => Just(" R T"),
            1 => Just("\tT"),
            1 => Just(" "),
        ];
        (seconds, fraction, gap.clone(), iface, gap, id, data, tail).prop_map(
            |(seconds, fraction, gap1, iface, gap2, id, data, tail)| {
                format!("({seconds}.{fraction}){gap1}{iface}{gap2}{id}#{data}{tail}").into_bytes()
            },
        )
    }

    static SHORT_WAY_TAKEN: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

    #[test]
    fn the_property_test_takes_the_short_way_often() {
        // Its own run of the property, counted.
        the_usual_line_reads_as_parse_line_reads_it();
        let taken = SHORT_WAY_TAKEN.load(std::sync::atomic::Ordering::Relaxed);
        // About 1,940 expected from the weights above (a tenth of the
        // lines); 1,000 is more than 20 standard deviations below.
        assert!(
            taken > 1_000,
            "the short way taken {taken} times in 20,000 lines"
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(20_000))]
        #[test]
        fn the_usual_line_reads_as_parse_line_reads_it(line in near_usual_line()) {
            if let Some(usual) = parse_usual_line(&line) {
                SHORT_WAY_TAKEN.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let iface = IfaceName::from_bytes(usual.iface);
                let fast = iface.map(|iface| {
                    (usual.timestamp_ns, iface, usual.id, usual.data[..usual.len].to_vec(), usual.direction)
                });
                if let Ok(((1, end), _)) = parse_line(&line) {
                    proptest::prop_assert_eq!(end, usual.timestamp_end);
                }
                // A name Linux refuses: parse_line is asked, and refuses it.
                match fast {
                    Some(fast) => proptest::prop_assert_eq!(Some(fast), as_parse_line_reads(&line)),
                    None => proptest::prop_assert!(parse_line(&line).is_err()),
                }
            }
        }
    }

    #[test]
    fn the_usual_lines_are_read_the_short_way() {
        let usual: &[&[u8]] = &[
            b"(1700000000.123456) can0 123#11223344",
            b"(0.1) vcan0 1FFFFFFF#",
            b"(1700000000.123456789) can0 7FF#0011223344556677 T",
            b"(1.000000) c)n0 000#aBcD R",
        ];
        for line in usual {
            let fast = parse_usual_line(line).unwrap();
            let (_, frame) = parse_line(line).unwrap();
            assert_eq!(fast.timestamp_ns, frame.timestamp_ns);
            assert_eq!(fast.iface, frame.iface.as_bytes());
            assert_eq!((fast.id, frame.direction), (frame.id, fast.direction));
            assert_eq!(&fast.data[..fast.len], frame.payload());
        }
        let other: &[&[u8]] = &[
            b"(1700000000.123456) can0 123#R",
            b"(1700000000.123456) can0 123##1AA",
            b"(1700000000.123456) can0 20000004#0000040000000000",
            b"(1700000000.123456) can0 123#11.22",
            b"(1700000000.123456) can0 123#1122334455667788_C",
            b"(1700000000.123456)  can0 123#11",
            b"(1700000000.123456) can0 800#11",
            b"(1700000000.1234567890) can0 123#11",
            // More digits than an i64 holds (the fuzzer's find).
            b"(0.33333333333333333333333333333333333333333) can0 123#11",
            b"(33333333333333333333333333333333333333333.0) can0 123#11",
        ];
        for line in other {
            assert_eq!(
                parse_usual_line(line),
                None,
                "{}",
                String::from_utf8_lossy(line)
            );
        }
    }

    fn round_trip(line: &str) -> Frame {
        let (_, frame) = parse_line(line.as_bytes()).unwrap_or_else(|e| panic!("{line}: {e}"));
        let mut out = Vec::new();
        push_line(&mut out, &frame).unwrap();
        assert_eq!(String::from_utf8(out).unwrap(), format!("{line}\n"));
        frame
    }

    #[test]
    fn every_kind_of_line_round_trips_byte_for_byte() {
        let frame = round_trip("(1700000000.123456) can0 123#11223344");
        assert_eq!(frame.id, CanId::Standard(0x123));
        assert_eq!(frame.payload(), &[0x11, 0x22, 0x33, 0x44]);
        assert_eq!(frame.timestamp_ns, 1_700_000_000_123_456_000);

        let frame = round_trip("(0000000001.000001) vcan0 00000123#");
        assert_eq!(frame.id, CanId::Extended(0x123));
        assert!(frame.payload().is_empty());

        let frame = round_trip("(1700000000.000000) can1 18FEF100#0102030405060708_C");
        assert_eq!(frame.kind, FrameKind::Data { len8_dlc: Some(12) });

        let frame = round_trip("(1700000000.000000) can0 123#R");
        assert_eq!(
            frame.kind,
            FrameKind::Remote {
                requested_len: 0,
                len8_dlc: None
            }
        );
        let frame = round_trip("(1700000000.000000) can0 123#R4");
        assert_eq!(
            frame.kind,
            FrameKind::Remote {
                requested_len: 4,
                len8_dlc: None
            }
        );
        round_trip("(1700000000.000000) can0 123#R8_9");

        let frame = round_trip("(1700000000.000000) can0 123##5112233");
        assert_eq!(frame.kind, FrameKind::Fd { flags: 5 });
        round_trip("(1700000000.000000) can0 00000456##0");
        let long = "AB".repeat(64);
        round_trip(&format!("(1700000000.000000) can0 7FF##4{long}"));

        let frame = round_trip("(1700000000.000000) can0 20000004#0000040000000000");
        assert_eq!(frame.kind, FrameKind::Error { class: 4 });

        let frame = round_trip("(1700000000.000000) can0 123#1122 T");
        assert_eq!(frame.direction, Some(Direction::Transmitted));
        round_trip("(1700000000.000000) can0 123#1122 R");
    }

    #[test]
    fn tolerated_variants_read_like_can_utils() {
        let (_, frame) = parse_line(b"(1.5) can0 123#11.22.33").unwrap();
        assert_eq!(frame.timestamp_ns, 1_500_000_000);
        assert_eq!(frame.payload(), &[0x11, 0x22, 0x33]);
        let (_, frame) = parse_line(b"(1.000000)   can0   1ab#r").unwrap();
        assert_eq!(frame.id, CanId::Standard(0x1AB));
        let (range, _) = parse_line(b"(1699999999.000001) can0 123#").unwrap();
        assert_eq!(range, (1, 18));
    }

    #[test]
    fn malformed_lines_say_what_was_expected() {
        let cases: &[(&str, &str)] = &[
            ("1.0 can0 123#", "timestamp"),
            ("(1.x) can0 123#", "timestamp"),
            ("(1.0)", "interface"),
            ("(1.0) can0", "frame"),
            ("(1.0) can0 12#00", "3 hex digits"),
            ("(1.0) can0 800#00", "11-bit"),
            ("(1.0) can0 123#001", "even number"),
            ("(1.0) can0 123#001122334455667788", "at most 8"),
            ("(1.0) can0 123#0011_9", "exactly 8"),
            ("(1.0) can0 123#0011223344556677_3", "9-F"),
            ("(1.0) can0 123#R9", "DLC 0-8"),
            ("(1.0) can0 123##", "flags"),
            ("(1.0) can0 123#00 X", "direction"),
            ("(1.0) can0 60000000#00", "error-frame id"),
            ("(1.0) can0 40000000#00", "29-bit id"),
            ("(1.0) can0 123#zz", "hex"),
        ];
        for (line, needle) in cases {
            let err = parse_line(line.as_bytes()).unwrap_err();
            assert!(
                err.contains(needle),
                "{line}: got '{err}', wanted '{needle}'"
            );
        }
    }

    #[test]
    fn reader_streams_and_numbers_lines() {
        let log = "(1.000000) can0 123#01\n\n# comment\n(2.000000) can0 124#02\r\nbad line\n(3.000000) can0 125#03\n";
        let mut reader = CandumpReader::new(log.as_bytes());
        let first = reader.next_record().unwrap().unwrap();
        assert_eq!((first.line, first.timestamp_text), (1, &b"1.000000"[..]));
        let second = reader.next_record().unwrap().unwrap();
        assert_eq!((second.line, second.frame.payload()), (4, &[2u8][..]));
        match reader.next_record() {
            Err(ReadError::Parse(e)) => assert_eq!(e.line(), Some(5)),
            other => panic!("expected a parse error, got {other:?}"),
        }
        assert_eq!(reader.next_record().unwrap().unwrap().line, 6);
        assert!(reader.next_record().unwrap().is_none());
    }

    proptest::proptest! {
        /// Pieces of whole lines, through read buffers of any size against
        /// the pieces' (passed by or not): together the log byte for byte;
        /// each but the last ending at a newline; none longer than the
        /// line carried into it and what one read brings.
        #[test]
        fn a_log_read_in_pieces_is_the_log_in_whole_lines(
            lines in proptest::collection::vec("[ -~]{0,40}", 0..40),
            cut_last in proptest::bool::ANY,
            bytes in 1usize..100,
            buffer in 1usize..64,
        ) {
            let mut log = lines.join("\n").into_bytes();
            if !cut_last && !lines.is_empty() {
                log.push(b'\n');
            }
            let longest_line = lines.iter().map(String::len).max().unwrap_or(0);
            let mut reader =
                CandumpReader::new(std::io::BufReader::with_capacity(buffer, log.as_slice()));
            let mut pieces = Vec::new();
            loop {
                let mut piece = Vec::new();
                let read = reader.read_lines_into(&mut piece, bytes).unwrap();
                proptest::prop_assert_eq!(read, piece.len());
                if read == 0 {
                    break;
                }
                pieces.push(piece);
            }
            proptest::prop_assert_eq!(pieces.concat(), log.clone());
            for (k, piece) in pieces.iter().enumerate() {
                let last = k + 1 == pieces.len();
                proptest::prop_assert!(last || piece.ends_with(b"\n"));
                proptest::prop_assert!(
                    piece.len() <= longest_line + 1 + bytes,
                    "{:?}", String::from_utf8_lossy(piece)
                );
            }
        }
    }

    /// A frame as a reader gives it: its line, timestamp text, interface,
    /// direction and fields (its payload copied).
    type FrameRead = (
        u64,
        Vec<u8>,
        IfaceName,
        Option<Direction>,
        i64,
        CanId,
        FrameKind,
        Vec<u8>,
    );

    /// What a reader gives of a text: each frame, or a malformed line's
    /// error; then the lines read.
    type LineReads = (Vec<Result<FrameRead, ParseError>>, u64);

    fn read_as_frame(frame: LineFrame<'_>) -> FrameRead {
        let fields = frame.fields;
        (
            frame.line,
            frame.timestamp_text.to_vec(),
            frame.iface,
            frame.direction,
            fields.timestamp_ns,
            fields.id,
            fields.kind,
            fields.payload.to_vec(),
        )
    }

    fn read_by_the_streaming_reader(log: &[u8], stop: bool) -> LineReads {
        let mut reader = CandumpReader::new(log);
        let mut reads = Vec::new();
        loop {
            match reader.next_record() {
                Ok(Some(record)) => reads.push(Ok(read_as_frame(LineFrame {
                    line: record.line,
                    timestamp_text: record.timestamp_text,
                    iface: record.frame.iface,
                    direction: record.frame.direction,
                    fields: record.frame.fields(),
                }))),
                Ok(None) => break,
                Err(ReadError::Parse(error)) => {
                    reads.push(Err(error));
                    if stop {
                        break;
                    }
                }
                Err(ReadError::Io(error)) => panic!("a slice read: {error}"),
            }
        }
        (reads, reader.line())
    }

    fn read_in_memory(log: &[u8], stop: bool) -> LineReads {
        let reads = std::cell::RefCell::new(Vec::new());
        let lines = read_whole_lines(
            log,
            |frame| reads.borrow_mut().push(Ok(read_as_frame(frame))),
            |error| {
                reads.borrow_mut().push(Err(error));
                if stop {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            },
        );
        (reads.into_inner(), lines)
    }

    #[test]
    fn whole_lines_in_memory_read_as_the_streaming_reader_reads_them() {
        let log = b"(1.000000) can0 123#01\n\n# comment\n(2.000000) can0 124#02 R\r\nbad line\n(1700000000.123456) can1 18FEF100#0102030405060708_C\n(3.000000) can0 125#03";
        for stop in [false, true] {
            let (reads, lines) = read_in_memory(log, stop);
            assert_eq!(
                (reads.clone(), lines),
                read_by_the_streaming_reader(log, stop)
            );
            let errors: Vec<u64> = reads
                .iter()
                .filter_map(|read| read.as_ref().err())
                .map(|e| match e.at {
                    crate::Place::Line(line) => line,
                    _ => 0,
                })
                .collect();
            if stop {
                assert_eq!((reads.len(), errors, lines), (3, vec![5], 5));
            } else {
                // The last line, without its newline, is cut short.
                assert_eq!((reads.len(), errors, lines), (5, vec![5, 7], 7));
                assert_eq!(reads[1].as_ref().unwrap().3, Some(Direction::Received));
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2_000))]
        /// Whole lines held in memory, usual, near usual, blank, comments
        /// and any text, CRLF or not, the last cut or not: read as the
        /// streaming reader reads them, frame for frame and error for
        /// error, stopping at the first malformed line or not.
        #[test]
        fn any_lines_in_memory_read_as_the_streaming_reader_reads_them(
            lines in proptest::collection::vec(
                proptest::prop_oneof![
                    4 => near_usual_line(),
                    1 => proptest::strategy::Strategy::prop_map("[ -~]{0,40}", String::into_bytes),
                    1 => proptest::prelude::Just(b"# a comment".to_vec()),
                    1 => proptest::prelude::Just(Vec::new()),
                ],
                0..30,
            ),
            crlf in proptest::bool::ANY,
            cut_last in proptest::bool::ANY,
            stop in proptest::bool::ANY,
        ) {
            let end: &[u8] = if crlf { b"\r\n" } else { b"\n" };
            let mut log = lines.join(end);
            if !cut_last && !lines.is_empty() {
                log.extend_from_slice(end);
            }
            proptest::prop_assert_eq!(read_in_memory(&log, stop), read_by_the_streaming_reader(&log, stop));
        }
    }
}
