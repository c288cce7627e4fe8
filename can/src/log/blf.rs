//! Vector BLF logs (`.blf`, "binary logging format"): what CANoe and
//! CANalyzer write by default, and python-can's `BLFWriter`.
//!
//! There is no public specification. The layout here is python-can's
//! (`can/io/blf.py`, itself from Toby Lorenz's `vector_blf`), read to learn
//! it; all sizes are little-endian:
//!
//! - File header: `LOGG`, its size (u32, 144 in the files seen), ..., the
//!   measurement start as a Windows `SYSTEMTIME` (8 u16: year, month,
//!   weekday, day, hour, minute, second, millisecond) at byte 40. The start
//!   has no time zone: it is taken as UTC, as the ASC date is.
//! - Then objects, each `LOBJ`, header size (u16), header version (u16),
//!   object size (u32, header included), object type (u32), padded to 4
//!   bytes after `object size`. A *log container* (type 10) holds more
//!   objects: compression method (u16: 0 none, 2 zlib), 6 bytes, the
//!   uncompressed size (u32), 4 bytes, then the data. An object may go on
//!   in the next container.
//! - Inside, an object's header goes on after the 16 common bytes: version
//!   1 is flags (u32), client index (u16), object version (u16), timestamp
//!   (u64); version 2 adds a timestamp status byte and an original timestamp
//!   (24 bytes). Flag 1 counts the timestamp in 10 us, else in ns, from the
//!   measurement start.
//!
//! Objects read (others, such as markers, LIN or Ethernet, are skipped):
//!
//! | type | object | what acq takes |
//! |---|---|---|
//! | 1, 86 | `CAN_MESSAGE`, `CAN_MESSAGE2` | channel (u16), flags (u8: 0x01 Tx, 0x80 remote), DLC (u8), id (u32, bit 31 extended), 8 data bytes |
//! | 100 | `CAN_FD_MESSAGE` | as above, then frame length (u32), bit count (u8), FD flags (u8: 0x01 EDL, 0x02 BRS, 0x04 ESI), valid bytes (u8), 5 bytes, 64 data bytes |
//! | 101 | `CAN_FD_MESSAGE_64` | channel (u8), DLC (u8), valid bytes (u8), tx count (u8), id (u32), frame length (u32), flags (u32: 0x0010 remote, 0x1000 EDL, 0x2000 BRS, 0x4000 ESI), 4 x u32 bit timing, bit count (u16), direction (u8, 1 = Tx), ext data offset (u8), CRC (u32), data |
//! | 2, 73 | `CAN_ERROR`, `CAN_ERROR_EXT` | channel (u16): an error frame of class `CAN_ERR_BUSERROR`, no details (as from ASC) |
//!
//! BLF channels are 1-based: channel N is interface `can{N-1}` (python-can's
//! convention). A data length above 8 on a classic frame is kept as the raw
//! DLC 9-15; an FD frame whose valid bytes are fewer than its DLC says is
//! padded with zeros, as CANoe does.
//!
//! Errors: a BLF file's [`ParseError`] is at an object ([`Place::Object`]): the number of the
//! object (1-based, counting those inside containers) where reading
//! stopped. A malformed object inside a container is skipped with the rest
//! of that container; a container that cannot be decompressed is skipped
//! whole. Memory stays bounded: the container being read, one read ahead
//! and inflating on a second thread meanwhile (zlib is a quarter of the
//! work), each at most [`MAX_CONTAINER_BYTES`].

use std::collections::VecDeque;
use std::io::{self, BufRead, Read};

use super::inflate::{InflateJob, Inflater};
use super::record::{LogRecord, ParseError, Place, ReadError, TimeText};
use crate::frame::{fd_flags, CanId, Direction, Frame, IfaceName, CLASSIC_MAX_LEN, FD_DLC_LENGTHS};

/// The first bytes of every BLF file.
pub const SIGNATURE: &[u8; 4] = b"LOGG";
/// The largest container (compressed or not) acq reads: Vector's are 128 KiB.
pub const MAX_CONTAINER_BYTES: usize = 64 << 20;

const OBJECT_SIGNATURE: &[u8; 4] = b"LOBJ";
const BASE_HEADER: usize = 16;
const FILE_HEADER_MIN: usize = 72;
const LOG_CONTAINER: u32 = 10;
const CONTAINER_HEADER: usize = 16;
const CAN_MESSAGE: u32 = 1;
const CAN_ERROR: u32 = 2;
const CAN_ERROR_EXT: u32 = 73;
const CAN_MESSAGE2: u32 = 86;
const CAN_FD_MESSAGE: u32 = 100;
const CAN_FD_MESSAGE_64: u32 = 101;
const TIME_TEN_MICROS: u32 = 0x1;
const ERROR_FRAME_CLASS: u32 = 0x80;

const E_HEADER: &str = "a BLF file header: 'LOGG' and a header size of at least 72 bytes";
const E_OBJECT: &str = "an object starting with 'LOBJ' and a size of at least its header";
const E_CONTAINER: &str =
    "a log container of at most 64 MiB, compressed with zlib (method 2) or not (0)";
const E_INFLATE: &str = "a log container whose zlib data inflates to its stated size";
const E_OBJECT_HEADER: &str = "an object header of version 1 (32 bytes) or 2 (40 bytes)";
const E_CAN_MESSAGE: &str =
    "a CAN message object with its 16 bytes of channel, flags, DLC, id and data";
const E_FD_MESSAGE: &str = "a CAN FD message object with its 84 bytes";
const E_FD64_MESSAGE: &str = "a CAN FD 64 message object with its 40-byte head and data";
const E_CHANNEL: &str = "a channel number of at least 1 (BLF channels are 1-based)";
const E_ID: &str = "an id of at most 0x7FF, or 0x1FFFFFFF with the extended bit";
const E_TIME: &str = "a timestamp that fits in a 64-bit nanosecond time";
const E_TRUNCATED: &str = "a whole object (the file ends inside one: cut short?)";
const E_HEADER_TRUNCATED: &str = "a whole file header (the file ends inside it: cut short?)";
const E_SHORT: &str =
    "as many bytes as the file header states (the file ends before them: cut short?)";

/// Streaming reader of BLF logs.
pub struct BlfReader<R> {
    input: R,
    started: bool,
    finished: bool,
    start_ns: i64,
    /// The current container's objects (after the tail of the previous one).
    data: Vec<u8>,
    pos: usize,
    /// Objects read so far, for error messages.
    objects: u64,
    /// The file's size as its header states it (0: not stated), and the
    /// bytes read so far: a file that ends before its stated size was cut.
    stated_size: u64,
    consumed: u64,
    time_text: TimeText,
    /// Containers read ahead, in file order.
    ahead: VecDeque<Ahead>,
    /// No more containers to read ahead (the end, or reading failed).
    input_ended: bool,
    /// The thread that inflates containers, started at the first.
    inflater: Option<Inflater>,
    /// Buffers to reuse: no allocation per container.
    spare_compressed: Vec<Vec<u8>>,
    spare_data: Vec<Vec<u8>>,
}

/// A container read ahead of the one being parsed.
struct Ahead {
    /// File-level objects read for it (itself, and skipped ones before it).
    objects: u64,
    content: Content,
}

enum Content {
    Ready(Vec<u8>),
    /// With the inflater, whose results come back in order.
    Inflating,
    Failed {
        failure: Failure,
        finishes: bool,
    },
    End,
}

enum Failure {
    Expected(&'static str),
    Io(io::Error),
}

/// A read that failed inside an object: the end of a truncated file is
/// malformed input, anything else an I/O error. Reading ends either way.
fn ended_inside(error: io::Error) -> Failure {
    match error.kind() {
        io::ErrorKind::UnexpectedEof => Failure::Expected(E_TRUNCATED),
        _ => Failure::Io(error),
    }
}

impl<R: BufRead> BlfReader<R> {
    pub fn new(input: R) -> Self {
        BlfReader {
            input,
            started: false,
            finished: false,
            start_ns: 0,
            data: Vec::new(),
            pos: 0,
            objects: 0,
            stated_size: 0,
            consumed: 0,
            time_text: TimeText::default(),
            ahead: VecDeque::new(),
            input_ended: false,
            inflater: None,
            spare_compressed: Vec::new(),
            spare_data: Vec::new(),
        }
    }

    /// Objects read so far (the "line" of an error).
    pub fn line(&self) -> u64 {
        self.objects
    }

    fn error(&self, expected: &'static str) -> ReadError {
        ReadError::Parse(ParseError::at(Place::Object(self.objects.max(1)), expected))
    }

    /// The next CAN frame; other objects are skipped. `Ok(None)` at the end.
    /// After an `Err(Parse)` the reader goes on with the next object it can
    /// find (or ends).
    pub fn next_record(&mut self) -> Result<Option<LogRecord<'_>>, ReadError> {
        if !self.started {
            self.started = true;
            self.read_file_header()?;
        }
        loop {
            match self.next_in_container() {
                Ok(Some(frame)) => {
                    return Ok(Some(LogRecord {
                        line: self.objects,
                        timestamp_text: self.time_text.set(frame.timestamp_ns).as_bytes(),
                        frame,
                    }));
                }
                Ok(None) => {}
                Err(expected) => {
                    // Skip the rest of this container.
                    self.pos = self.data.len();
                    return Err(self.error(expected));
                }
            }
            if self.finished || !self.read_container()? {
                self.finished = true;
                // An object begun in the last container that never went on.
                let rest = &self.data[self.pos.min(self.data.len())..];
                if rest.windows(4).take(4).any(|w| w == OBJECT_SIGNATURE) {
                    self.pos = self.data.len();
                    return Err(self.error(E_TRUNCATED));
                }
                return Ok(None);
            }
        }
    }

    fn read_file_header(&mut self) -> Result<(), ReadError> {
        let mut head = [0u8; FILE_HEADER_MIN];
        if let Err(error) = self.input.read_exact(&mut head) {
            self.finished = true;
            return match error.kind() {
                io::ErrorKind::UnexpectedEof => Err(self.error(E_HEADER)),
                _ => Err(ReadError::Io(error)),
            };
        }
        let size = u32_at(&head, 4).unwrap_or(0) as usize;
        if &head[..4] != SIGNATURE || !(FILE_HEADER_MIN..=MAX_CONTAINER_BYTES).contains(&size) {
            self.finished = true;
            return Err(self.error(E_HEADER));
        }
        if let Err(error) = skip(&mut self.input, (size - FILE_HEADER_MIN) as u64) {
            self.finished = true;
            return match error.kind() {
                io::ErrorKind::UnexpectedEof => Err(self.error(E_HEADER_TRUNCATED)),
                _ => Err(ReadError::Io(error)),
            };
        }
        self.consumed = size as u64;
        self.stated_size = u64_at(&head, 16).unwrap_or(0);
        let field = |index: usize| u16_at(&head, 40 + 2 * index).unwrap_or(0);
        self.start_ns = system_time_ns([
            field(0),
            field(1),
            field(3),
            field(4),
            field(5),
            field(6),
            field(7),
        ]);
        Ok(())
    }

    /// Makes the next log container's objects current (after what is left
    /// of the last one). `false` at the end. One container is read ahead
    /// and inflated on the inflater's thread while this one is parsed.
    fn read_container(&mut self) -> Result<bool, ReadError> {
        while self.ahead.len() < 2 && !self.input_ended {
            let container = self.read_ahead();
            self.input_ended = matches!(
                container.content,
                Content::End | Content::Failed { finishes: true, .. }
            );
            self.ahead.push_back(container);
        }
        let Some(container) = self.ahead.pop_front() else {
            return Ok(false);
        };
        // Errors name the object where reading stopped, as if read in turn.
        self.objects += container.objects;
        let bytes = match container.content {
            Content::End => return Ok(false),
            Content::Ready(bytes) => bytes,
            Content::Inflating => {
                let Some(job) = self.inflater.as_ref().and_then(Inflater::receive) else {
                    self.finished = true;
                    return Err(ReadError::Io(io::Error::other("the BLF inflater stopped")));
                };
                self.spare_compressed.push(job.compressed);
                if !job.inflated {
                    self.spare_data.push(job.out);
                    return Err(self.error(E_INFLATE));
                }
                job.out
            }
            Content::Failed { failure, finishes } => {
                self.finished |= finishes;
                return Err(match failure {
                    Failure::Expected(E_SHORT) => ReadError::Parse(ParseError {
                        note: Some(format!(
                            "its header states {} bytes, it ends after {} ({} missing)",
                            self.stated_size,
                            self.consumed,
                            self.stated_size - self.consumed
                        )),
                        ..ParseError::at(Place::Object(self.objects.max(1)), E_SHORT)
                    }),
                    Failure::Expected(expected) => self.error(expected),
                    Failure::Io(error) => ReadError::Io(error),
                });
            }
        };
        // Keep the unread tail of the last container: an object may span two.
        self.data.drain(..self.pos.min(self.data.len()));
        self.pos = 0;
        self.data.extend_from_slice(&bytes);
        self.spare_data.push(bytes);
        Ok(true)
    }

    /// Reads file-level objects up to the next log container and reads it,
    /// or starts inflating it.
    fn read_ahead(&mut self) -> Ahead {
        let mut objects = 0;
        let failed = |objects: u64, failure: Failure, finishes: bool| Ahead {
            objects,
            content: Content::Failed { failure, finishes },
        };
        loop {
            let mut base = [0u8; BASE_HEADER];
            match read_or_end(&mut self.input, &mut base) {
                Ok(true) => {}
                // A clean end between objects, unless the header says
                // more must follow.
                Ok(false) if self.consumed < self.stated_size => {
                    return failed(objects + 1, Failure::Expected(E_SHORT), true);
                }
                Ok(false) => {
                    return Ahead {
                        objects,
                        content: Content::End,
                    }
                }
                Err(error) => return failed(objects + 1, ended_inside(error), true),
            }
            objects += 1;
            let size = u32_at(&base, 8).unwrap_or(0) as usize;
            let kind = u32_at(&base, 12).unwrap_or(0);
            if &base[..4] != OBJECT_SIGNATURE || size < BASE_HEADER {
                // Without a size the next object cannot be found.
                return failed(objects, Failure::Expected(E_OBJECT), true);
            }
            // The body, then `size % 4` padding bytes (as Vector and
            // python-can write them).
            let body = (size - BASE_HEADER) as u64;
            let padding = (size % 4) as u64;
            self.consumed = self.consumed.saturating_add(size as u64 + padding);
            if kind != LOG_CONTAINER {
                if let Err(error) = skip(&mut self.input, body + padding) {
                    return failed(objects, ended_inside(error), true);
                }
                continue;
            }
            if body < CONTAINER_HEADER as u64 || body > MAX_CONTAINER_BYTES as u64 {
                return match skip(&mut self.input, body + padding) {
                    Ok(()) => failed(objects, Failure::Expected(E_CONTAINER), false),
                    Err(error) => failed(objects, ended_inside(error), true),
                };
            }
            let mut header = [0u8; CONTAINER_HEADER];
            if let Err(error) = self.input.read_exact(&mut header) {
                return failed(objects, ended_inside(error), true);
            }
            let method = u16_at(&header, 0).unwrap_or(u16::MAX);
            let uncompressed = u32_at(&header, 8).unwrap_or(0) as usize;
            let stored = body as usize - CONTAINER_HEADER;
            let content = match method {
                0 => {
                    let mut bytes = self.spare_data.pop().unwrap_or_default();
                    bytes.clear();
                    bytes.resize(stored, 0);
                    if let Err(error) = self.input.read_exact(&mut bytes) {
                        return failed(objects, ended_inside(error), true);
                    }
                    Content::Ready(bytes)
                }
                // Deflate shrinks by at most about 1032 to 1: a larger claim
                // is not this container's (and is not worth the memory).
                2 if uncompressed <= MAX_CONTAINER_BYTES
                    && uncompressed <= stored.saturating_mul(1032).saturating_add(1024) =>
                {
                    let mut compressed = self.spare_compressed.pop().unwrap_or_default();
                    compressed.clear();
                    compressed.resize(stored, 0);
                    if let Err(error) = self.input.read_exact(&mut compressed) {
                        return failed(objects, ended_inside(error), true);
                    }
                    let job = InflateJob {
                        stream: 0..compressed.len(),
                        compressed,
                        out: self.spare_data.pop().unwrap_or_default(),
                        uncompressed,
                        ..InflateJob::default()
                    };
                    if self.inflater.is_none() {
                        self.inflater = Inflater::start("blf-inflate");
                    }
                    let unsent = match &self.inflater {
                        Some(inflater) => inflater.send(job),
                        None => Some(job),
                    };
                    match unsent {
                        None => Content::Inflating,
                        Some(mut job) => {
                            // No thread: inflate here.
                            job.run();
                            self.spare_compressed.push(job.compressed);
                            if job.inflated {
                                Content::Ready(job.out)
                            } else {
                                self.spare_data.push(job.out);
                                Content::Failed {
                                    failure: Failure::Expected(E_INFLATE),
                                    finishes: false,
                                }
                            }
                        }
                    }
                }
                _ => {
                    return match skip(&mut self.input, stored as u64 + padding) {
                        Ok(()) => failed(objects, Failure::Expected(E_CONTAINER), false),
                        Err(error) => failed(objects, ended_inside(error), true),
                    };
                }
            };
            if let Err(error) = skip(&mut self.input, padding) {
                return failed(objects, ended_inside(error), true);
            }
            return Ahead { objects, content };
        }
    }

    /// The next CAN frame in the current container, `Ok(None)` when it needs
    /// the next container.
    fn next_in_container(&mut self) -> Result<Option<Frame>, &'static str> {
        loop {
            // Objects start 4-byte aligned after the previous one's size:
            // skip up to 3 padding bytes before the signature.
            let rest = &self.data[self.pos.min(self.data.len())..];
            let Some(offset) = rest.windows(4).take(4).position(|w| w == OBJECT_SIGNATURE) else {
                if rest.len() >= 8 {
                    return Err(E_OBJECT);
                }
                return Ok(None);
            };
            let start = self.pos + offset;
            let data = &self.data[start..];
            if data.len() < BASE_HEADER {
                self.pos = start;
                return Ok(None);
            }
            let header_version = u16_at(data, 6).ok_or(E_OBJECT)?;
            let size = u32_at(data, 8).ok_or(E_OBJECT)? as usize;
            let kind = u32_at(data, 12).ok_or(E_OBJECT)?;
            if size < BASE_HEADER {
                return Err(E_OBJECT);
            }
            if data.len() < size {
                self.pos = start;
                return Ok(None); // goes on in the next container
            }
            self.objects += 1;
            self.pos = start + size;
            let object = &data[..size];
            if !matches!(
                kind,
                CAN_MESSAGE
                    | CAN_MESSAGE2
                    | CAN_FD_MESSAGE
                    | CAN_FD_MESSAGE_64
                    | CAN_ERROR
                    | CAN_ERROR_EXT
            ) {
                continue;
            }
            let (flags, timestamp, body) = match header_version {
                1 => (
                    u32_at(object, 16).ok_or(E_OBJECT_HEADER)?,
                    u64_at(object, 24).ok_or(E_OBJECT_HEADER)?,
                    object.get(32..).ok_or(E_OBJECT_HEADER)?,
                ),
                2 => (
                    u32_at(object, 16).ok_or(E_OBJECT_HEADER)?,
                    u64_at(object, 24).ok_or(E_OBJECT_HEADER)?,
                    object.get(40..).ok_or(E_OBJECT_HEADER)?,
                ),
                _ => return Err(E_OBJECT_HEADER),
            };
            let offset_ns = if flags == TIME_TEN_MICROS {
                timestamp.checked_mul(10_000)
            } else {
                Some(timestamp)
            };
            let timestamp_ns = offset_ns
                .and_then(|ns| i64::try_from(ns).ok())
                .and_then(|ns| self.start_ns.checked_add(ns))
                .ok_or(E_TIME)?;
            return parse_frame(kind, body, timestamp_ns).map(Some);
        }
    }
}

fn parse_frame(kind: u32, body: &[u8], timestamp_ns: i64) -> Result<Frame, &'static str> {
    match kind {
        CAN_MESSAGE | CAN_MESSAGE2 => {
            let channel = u16_at(body, 0).ok_or(E_CAN_MESSAGE)?;
            let flags = *body.get(2).ok_or(E_CAN_MESSAGE)?;
            let dlc = *body.get(3).ok_or(E_CAN_MESSAGE)? & 0x0F;
            let id = can_id(u32_at(body, 4).ok_or(E_CAN_MESSAGE)?)?;
            let data = body.get(8..16).ok_or(E_CAN_MESSAGE)?;
            let iface = channel_iface(u64::from(channel))?;
            let len = usize::from(dlc).min(CLASSIC_MAX_LEN);
            let mut frame = if flags & 0x80 != 0 {
                Frame::remote(timestamp_ns, iface, id, len as u8).map_err(|_| E_CAN_MESSAGE)?
            } else {
                Frame::data(timestamp_ns, iface, id, &data[..len]).map_err(|_| E_CAN_MESSAGE)?
            };
            if dlc > 8 {
                frame.set_len8_dlc(dlc).map_err(|_| E_CAN_MESSAGE)?;
            }
            frame.direction = Some(direction(flags & 0x01 != 0));
            Ok(frame)
        }
        CAN_FD_MESSAGE | CAN_FD_MESSAGE_64 => {
            let expected = if kind == CAN_FD_MESSAGE {
                E_FD_MESSAGE
            } else {
                E_FD64_MESSAGE
            };
            let (channel, raw_id, object) = fd_object(kind, body).ok_or(expected)?;
            let iface = channel_iface(channel)?;
            frame_of(timestamp_ns, iface, can_id(raw_id)?, object).ok_or(expected)
        }
        _ => {
            // CAN_ERROR, CAN_ERROR_EXT: the channel is the first u16 of both.
            let channel = u16_at(body, 0).ok_or(E_CAN_MESSAGE)?;
            let iface = channel_iface(u64::from(channel))?;
            Frame::error(timestamp_ns, iface, ERROR_FRAME_CLASS, &[]).map_err(|_| E_CAN_MESSAGE)
        }
    }
}

/// (channel, raw id, frame fields) of a `CAN_FD_MESSAGE` or
/// `CAN_FD_MESSAGE_64` body: the two layouts of one kind of frame.
fn fd_object(kind: u32, body: &[u8]) -> Option<(u64, u32, FdObject<'_>)> {
    if kind == CAN_FD_MESSAGE {
        let flags = *body.get(2)?;
        let fd = *body.get(13)?;
        Some((
            u64::from(u16_at(body, 0)?),
            u32_at(body, 4)?,
            FdObject {
                remote: flags & 0x80 != 0,
                transmitted: flags & 0x01 != 0,
                edl: fd & 0x01 != 0,
                brs: fd & 0x02 != 0,
                esi: fd & 0x04 != 0,
                dlc: *body.get(3)? & 0x0F,
                valid: usize::from(*body.get(14)?),
                data: body.get(20..84)?,
            },
        ))
    } else {
        let head = body.get(..40)?;
        let flags = u32_at(head, 12)?;
        Some((
            u64::from(head[0]),
            u32_at(head, 4)?,
            FdObject {
                remote: flags & 0x0010 != 0,
                transmitted: head[34] != 0,
                edl: flags & 0x1000 != 0,
                brs: flags & 0x2000 != 0,
                esi: flags & 0x4000 != 0,
                dlc: head[1] & 0x0F,
                valid: usize::from(head[2]),
                data: &body[40..],
            },
        ))
    }
}

/// What an FD-capable object says about its frame.
struct FdObject<'a> {
    remote: bool,
    transmitted: bool,
    edl: bool,
    brs: bool,
    esi: bool,
    dlc: u8,
    valid: usize,
    data: &'a [u8],
}

/// A classic or FD frame from an FD-capable object: without EDL it is a
/// classic frame on an FD channel.
fn frame_of(timestamp_ns: i64, iface: IfaceName, id: CanId, object: FdObject<'_>) -> Option<Frame> {
    let mut frame = if !object.edl {
        let len = usize::from(object.dlc).min(CLASSIC_MAX_LEN);
        let mut frame = if object.remote {
            Frame::remote(timestamp_ns, iface, id, len as u8).ok()?
        } else {
            let mut payload = [0u8; CLASSIC_MAX_LEN];
            let available = object.data.len().min(len);
            payload[..available].copy_from_slice(&object.data[..available]);
            Frame::data(timestamp_ns, iface, id, &payload[..len]).ok()?
        };
        if object.dlc > 8 {
            frame.set_len8_dlc(object.dlc).ok()?;
        }
        frame
    } else {
        let len = FD_DLC_LENGTHS[usize::from(object.dlc)];
        let mut payload = [0u8; 64];
        let available = object.data.len().min(object.valid).min(len);
        payload[..available].copy_from_slice(&object.data[..available]);
        Frame::fd(
            timestamp_ns,
            iface,
            id,
            fd_flags(object.brs, object.esi),
            &payload[..len],
        )
        .ok()?
    };
    frame.direction = Some(direction(object.transmitted));
    Some(frame)
}

fn direction(transmitted: bool) -> Direction {
    if transmitted {
        Direction::Transmitted
    } else {
        Direction::Received
    }
}

fn can_id(raw: u32) -> Result<CanId, &'static str> {
    if raw & 0x8000_0000 != 0 {
        CanId::extended(raw & 0x1FFF_FFFF).ok_or(E_ID)
    } else {
        u16::try_from(raw)
            .ok()
            .and_then(CanId::standard)
            .ok_or(E_ID)
    }
}

/// BLF channel `N` (1-based) -> interface `can{N-1}` (no allocation: it
/// runs for every frame).
fn channel_iface(channel: u64) -> Result<IfaceName, &'static str> {
    let index = channel.checked_sub(1).ok_or(E_CHANNEL)?;
    let mut digits = itoa::Buffer::new();
    let digits = digits.format(index).as_bytes();
    let mut name = [0u8; 3 + 20];
    name[..3].copy_from_slice(b"can");
    name[3..3 + digits.len()].copy_from_slice(digits);
    IfaceName::from_bytes(&name[..3 + digits.len()]).ok_or(E_CHANNEL)
}

/// ns since the epoch of a `SYSTEMTIME` (year, month, day, hour, minute,
/// second, millisecond), taken as UTC; 0 when it is not a date (python-can
/// writes zeros for logs without absolute time).
fn system_time_ns(fields: [u16; 7]) -> i64 {
    let [year, month, day, hour, minute, second, millis] = fields.map(i64::from);
    if !(1970..=9999).contains(&year)
        || !(1..=12).contains(&month)
        || !(1..=31).contains(&day)
        || hour > 23
        || minute > 59
        || second > 59
        || millis > 999
    {
        return 0;
    }
    // Howard Hinnant's days_from_civil.
    let y = if month <= 2 { year - 1 } else { year };
    let era = y.div_euclid(400);
    let year_of_era = y - era * 400;
    let month_index = (month + 9) % 12;
    let day_of_year = (153 * month_index + 2) / 5 + day - 1;
    let day_of_era = year_of_era * 365 + year_of_era / 4 - year_of_era / 100 + day_of_year;
    let days = era * 146_097 + day_of_era - 719_468;
    // Past 2262 the nanoseconds do not fit in an i64: not a date either.
    (days * 86_400 + hour * 3600 + minute * 60 + second)
        .checked_mul(1000)
        .and_then(|ms| ms.checked_add(millis))
        .and_then(|ms| ms.checked_mul(1_000_000))
        .unwrap_or(0)
}

fn u16_at(bytes: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(bytes.get(at..at + 2)?.try_into().ok()?))
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?))
}

fn u64_at(bytes: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(bytes.get(at..at + 8)?.try_into().ok()?))
}

/// Reads and drops `count` bytes; fewer before the end is `UnexpectedEof`
/// (a file cut inside what it skips).
fn skip(input: &mut impl Read, count: u64) -> io::Result<()> {
    let skipped = io::copy(&mut input.take(count), &mut io::sink())?;
    if skipped < count {
        return Err(io::ErrorKind::UnexpectedEof.into());
    }
    Ok(())
}

/// Fills `buffer`: `Ok(false)` when the input ends before its first byte
/// (a clean end), `UnexpectedEof` when it ends inside it.
fn read_or_end(input: &mut impl Read, buffer: &mut [u8]) -> io::Result<bool> {
    let mut filled = 0;
    while filled < buffer.len() {
        match input.read(&mut buffer[filled..]) {
            Ok(0) if filled == 0 => return Ok(false),
            Ok(0) => return Err(io::ErrorKind::UnexpectedEof.into()),
            Ok(read) => filled += read,
            Err(error) if error.kind() == io::ErrorKind::Interrupted => {}
            Err(error) => return Err(error),
        }
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn system_times_are_utc_dates() {
        assert_eq!(system_time_ns([1970, 1, 1, 0, 0, 0, 0]), 0);
        // 2026-11-24 21:15:02.512
        assert_eq!(
            system_time_ns([2026, 11, 24, 21, 15, 2, 512]),
            1_795_554_902_512_000_000
        );
        assert_eq!(system_time_ns([0, 0, 0, 0, 0, 0, 0]), 0);
        assert_eq!(system_time_ns([2024, 13, 1, 0, 0, 0, 0]), 0);
        assert_eq!(system_time_ns([9999, 12, 31, 23, 59, 59, 999]), 0);
    }

    #[test]
    fn garbage_and_truncation_are_errors_not_panics() {
        for bytes in [&b""[..], b"LOGG", b"LOGG\x90\0\0\0", b"not a blf file at all, just text here........................................................"] {
            let mut reader = BlfReader::new(bytes);
            for _ in 0..4 {
                if let Ok(None) = reader.next_record() {
                    break;
                }
            }
        }
    }
}
