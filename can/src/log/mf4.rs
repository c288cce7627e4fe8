//! ASAM MDF 4 (`.mf4`) bus logging: CAN frames as python-can's `MF4Writer`
//! (through asammdf), asammdf itself and [`super::mf4_write::Mf4Writer`]
//! write them.
//!
//! The layout was learnt from asammdf (`blocks/v4_blocks.py`,
//! `v4_constants.py`, `mdf_v4.py` `save`), python-can (`can/io/mf4.py`) and
//! files python-can 4.6.1 with asammdf 8.8 wrote; no code was copied. All
//! numbers are little-endian; blocks link to each other by absolute file
//! offsets:
//!
//! - Identification (64 bytes at 0): `MDF     `, version text, ..., the
//!   version number (u16, 4xx) at 28.
//! - Every other block: id `##XX` (4), reserved (4), length (u64, header
//!   included), link count (u64), the links (u64 each), then its data.
//! - `##HD` at 64: links first DG, ...; data start time (u64 ns since the
//!   epoch, UTC).
//! - `##DG` data group: links next DG, first CG, data, comment; data the
//!   record id size (u8: 0, 1, 2, 4 or 8). With several CGs the group is
//!   *unsorted*: each record starts with its CG's record id.
//! - `##CG` channel group: links next CG, first CN, ...; data record id
//!   (u64), cycle count (u64), flags (u16: 1 VLSD, 2 bus event), path
//!   separator (u16), 4 reserved, data bytes (u32), invalidation bytes (u32).
//!   A VLSD CG's records are a u32 length and that many bytes.
//! - `##CN` channel: links next CN, composition (the members of a
//!   structure), name (`##TX`), source, conversion (`##CC`), ...; data
//!   channel type (u8: 2 master), sync type, data type (u8: 0 unsigned, 2
//!   signed, 4 float, 10 byte array, all little-endian), bit offset (u8),
//!   byte offset (u32, in the record after its id), bit count (u32).
//! - `##CC` conversion: data type (u8: 0 identity, 1 linear), ..., value
//!   count (u16) at 6, then 2 f64 range, then the values (`a`, `b`: `a +
//!   b * raw`).
//! - Data: `##DT` (the records), `##DZ` (original id (2), zip type (u8: 0
//!   deflate, 1 transposed deflate), reserved, zip parameter (u32: the
//!   columns, i.e. the record size, of a transposed block), original length
//!   (u64), zipped length (u64), zlib data), `##DL` lists (links next DL,
//!   the blocks; data flags, 3 reserved, block count) and `##HL` (links
//!   first DL). The records run on across blocks.
//!
//! The bus-logging layout (ASAM MDF 4 "bus logging", as asammdf and
//! python-can write it): a CG whose channels are the master `t`/`time`
//! (seconds from the HD start time, f64 or an integer with a linear
//! conversion) and a structure `CAN_DataFrame` (or `CAN_RemoteFrame`,
//! `CAN_ErrorFrame`) whose members `.BusChannel`, `.ID`, `.IDE`, `.DLC`,
//! `.DataLength`, `.DataBytes`, `.Dir`, `.EDL`, `.BRS`, `.ESI` lie in the
//! record. python-can writes three sorted DGs (data, error, remote frames),
//! asammdf places their data blocks *before* the metadata; acq's writer one
//! unsorted DG with the metadata first.
//!
//! Reading from a stream: links may point backwards, but `acq` reads logs
//! from any [`BufRead`] (stdin too). The reader keeps the file's bytes from
//! the start up to the last metadata block it needs (all of an asammdf file,
//! whose metadata is at the end; only the head of acq's files) and then
//! streams the data blocks that lie beyond, one chunk at a time. When the
//! frames come from several DGs at once (python-can's files), every data
//! block is kept so the groups can be merged by time. Memory is thus bounded
//! by the input's size, never by a length field. Each group reads its next
//! `##DZ` block while it parses one, and a second thread inflates it
//! ([`super::inflate`]).
//!
//! Mapping: `BusChannel` N is interface `canN` (python-can writes its int
//! channel as is, and reads it back so); a group without one is `can0`.
//! `Dir` 0 is Rx, 1 Tx. `IDE` (or bit 31 of `ID`) says extended. A data
//! frame with `EDL` is CAN FD of `DataLength` bytes; a classic one with a
//! DLC above 8 keeps it as the raw DLC. An error frame is class
//! `CAN_ERR_BUSERROR` without details (MF4's error fields are not Linux's).
//! Times: the master value in ns (rounded) plus the HD start time.
//!
//! Loggers store the members in other ways too: a virtual channel (type
//! 6, no bits) whose conversion gives a constant, a field through a
//! conversion ([`super::mf4_conversion`]), `DataBytes` as a VLSD channel
//! (type 1) whose record holds a u64 offset into its signal data: `##SD`
//! blocks (or a `##DZ`/`##DL` of them) or the records of a VLSD channel
//! group in the same data group ([`SignalData`], read by a cursor of its
//! own over the same blocks, so a value may come before or after its
//! frame's record).
//!
//! Unfinalized files (`UnFinMF `, flags at byte 60 for what was never
//! written), recovered as asammdf does: 0x04, the last `##DT` runs to the
//! next block the metadata names or the file's end; 0x10, the data
//! blocks right after the last `##DL` are the list's too; 0x40, VLSD
//! values pair with records in order. A record cut off at the end is no
//! error there but a note ([`Mf4Reader::take_notes`]).
//!
//! Errors: an MF4 file's [`ParseError`] is at a byte offset
//! ([`Place::ByteOffset`]): that of the block where reading stopped (for a bad record, of the data block it
//! starts in). A malformed record is skipped; malformed metadata ends the
//! file. Not read: column storage (`##DV`), LZ4/Zstandard data blocks,
//! big-endian fields.

use std::io::{self, BufRead, Read};
use std::ops::Range;

use super::inflate::{InflateJob, Inflater};
use super::mf4_conversion::{Conversion, E_CONVERSION};
use super::record::{LogRecord, ParseError, Place, ReadError, TimeText};
use crate::frame::{
    fd_flags, CanId, Direction, Frame, IfaceName, CLASSIC_MAX_LEN, FD_DLC_LENGTHS, FD_MAX_LEN,
};

/// The first bytes of every MDF file.
pub const SIGNATURE: &[u8; 8] = b"MDF     ";
/// The identification of an MF4 file its writer has not finalized (a
/// logger whose power was cut, or one that never finalizes).
pub const UNFINALIZED_SIGNATURE: &[u8; 8] = b"UnFinMF ";
/// The largest metadata block acq reads.
/// Unfinalized flags (a u16 at byte 60): the last `##DT` block's length
/// was not written.
const UNFINALIZED_LAST_DT_LENGTH: u16 = 0x04;
/// Unfinalized flags: the last `##DL` block was not updated.
const UNFINALIZED_LAST_LIST: u16 = 0x10;
/// Unfinalized flags: the offsets of VLSD values were not written.
const UNFINALIZED_VLSD_OFFSETS: u16 = 0x40;
pub const MAX_METADATA_BYTES: u64 = 16 << 20;
/// The largest zipped data block acq inflates (asammdf writes 4 MiB ones).
pub const MAX_DZ_BYTES: u64 = 256 << 20;

/// Room kept before an inflated block's records for a record begun in the
/// block before, bytes.
const MAX_HEADROOM: usize = 4096;
const ID_BLOCK: u64 = 64;
const HEADER: u64 = 24;
const CHUNK: u64 = 1 << 20;
/// `CAN_ERR_BUSERROR`: the class of every error frame read from MF4.
pub const ERROR_FRAME_CLASS: u32 = 0x80;

const E_ID: &str =
    "an MDF 4 identification block: 'MDF     ' (or 'UnFinMF ') and a version number 400 to 499";
const E_BLOCK: &str = "a block with a '##' id, a length within the file and room for its links";
const E_HD: &str = "a '##HD' header block at byte 64";
const E_DG: &str = "a '##DG' data group with a record id size of 0, 1, 2, 4 or 8 bytes";
const E_CG: &str = "a '##CG' channel group";
const E_CN: &str = "a '##CN' channel";
const E_LOOP: &str = "a tree of groups and channels without loops";
const E_SORTED: &str = "one channel group in a data group without record ids";
const E_MASTER: &str =
    "a time master channel: a little-endian float or integer, with no or a linear '##CC' conversion";
const E_FIELD: &str =
    "bus-logging fields as little-endian unsigned integers of 1 to 64 bits inside the record";
const E_BYTES: &str = "a DataBytes channel: a byte array inside the record, or a VLSD channel of a u64 offset into its signal data";
const E_FIELD_VALUE: &str = "a bus-logging field whose conversion gives a whole number from 0 up";
const E_VLSD: &str =
    "a VLSD offset at the start of a value in the channel's signal data, offsets growing";
const E_NO_ID: &str = "an ID field in a CAN data or remote frame group";
const E_DATA: &str = "a '##DT', '##DZ', '##DL' or '##HL' data block";
const E_DZ: &str = "a '##DZ' block of deflate (0) or transposed deflate (1) data whose inflated length is at most 256 MiB and what it states";
const E_ORDER: &str = "data blocks in file order after the metadata (a stream cannot go back)";
const E_RECORD_ID: &str = "a record id of one of the data group's channel groups";
const E_RECORD: &str = "a whole record (the data ends inside one)";
const E_CAN_ID: &str = "an id of at most 0x7FF, or 0x1FFFFFFF when IDE says extended";
const E_LENGTH: &str = "a data length the frame's DataBytes hold (0-8 classic, 0-64 FD)";
const E_TIME: &str = "a time that fits in a 64-bit nanosecond timestamp";
const E_CHANNEL: &str = "a BusChannel number that names an interface";
const E_TRUNCATED: &str = "a whole block (the file ends inside one)";

/// Streaming reader of MF4 bus logs.
pub struct Mf4Reader<R> {
    source: Source<R>,
    opened: bool,
    finished: bool,
    /// The HD start time, ns since the epoch.
    start_ns: i64,
    cursors: Vec<Cursor>,
    /// The next frame of each cursor (merged by time), with its "line".
    heads: Vec<Option<(Frame, u64)>>,
    time_text: TimeText,
    inflation: Inflation,
    /// The interfaces the frames were on, in the order first seen.
    interfaces: Vec<IfaceName>,
    /// What the metadata says that the reader must tell.
    file_notes: Vec<String>,
}

/// How `##DZ` blocks are inflated: each group reads the block after the one
/// it parses as soon as that one is read whole, and sends it to the
/// inflater's thread. With one group that is the next block in the file; with
/// several every block is kept (see the module doc), so reading ahead never
/// goes back in the stream.
struct Inflation {
    /// Started at the first block read ahead (once).
    inflater: Option<Inflater>,
    tried_to_start: bool,
    /// Inflated blocks received while waiting for another group's, by
    /// their file offset.
    received: Vec<(u64, InflateJob)>,
    /// Jobs to reuse: no allocation per block.
    spare: Vec<InflateJob>,
}

impl Inflation {
    /// The inflated block at `at`, sent earlier; `None` if the thread stopped.
    fn receive(&mut self, at: u64) -> Option<InflateJob> {
        if let Some(index) = self.received.iter().position(|(block, _)| *block == at) {
            return Some(self.received.swap_remove(index).1);
        }
        let inflater = self.inflater.as_ref()?;
        loop {
            let job = inflater.receive()?;
            if job.block == at {
                return Some(job);
            }
            self.received.push((job.block, job));
        }
    }
}

/// A data block whose header (and, for `##DZ`, data) has been read.
enum DataBlock {
    Dt {
        len: u64,
    },
    /// Read, not inflated yet.
    Dz(InflateJob),
}

/// The block after the current one, read ahead.
enum Ahead {
    Block(DataBlock),
    /// In the inflater's queue.
    Sent,
    Failed(&'static str),
}

/// The input and the bytes of it that are kept.
struct Source<R> {
    input: R,
    /// Bytes `0..kept.len()` of the file.
    kept: Vec<u8>,
    /// File offset of the next input byte: `kept.len()` until data streams.
    pos: u64,
    /// Every data block must stay in `kept` (several groups read at once).
    keep_all: bool,
    /// The offset of every block read as metadata.
    seen: Vec<u64>,
}

/// A metadata block in `kept`.
#[derive(Clone, Copy)]
struct Block {
    offset: u64,
    id: [u8; 4],
    links: usize,
    len: usize,
}

impl Block {
    fn link(&self, kept: &[u8], index: usize) -> u64 {
        if index >= self.links {
            return 0;
        }
        u64_at(kept, self.offset as usize + 24 + 8 * index).unwrap_or(0)
    }

    fn data<'a>(&self, kept: &'a [u8]) -> &'a [u8] {
        let start = self.offset as usize + 24 + 8 * self.links;
        kept.get(start..self.offset as usize + self.len)
            .unwrap_or(&[])
    }
}

impl<R: BufRead> Source<R> {
    /// Makes bytes `..end` readable in `kept`; `false` when the file ends
    /// first or they were streamed past.
    fn keep_to(&mut self, end: u64) -> io::Result<bool> {
        let have = self.kept.len() as u64;
        if end <= have {
            return Ok(true);
        }
        if self.pos != have {
            return Ok(false);
        }
        let want = end - have;
        // Grows only as bytes arrive: bounded by the input, not by `end`.
        let got = (&mut self.input).take(want).read_to_end(&mut self.kept)? as u64;
        self.pos += got;
        Ok(got == want)
    }

    /// The metadata block at `offset`, one of `ids`.
    fn block(
        &mut self,
        offset: u64,
        ids: &[&[u8; 4]],
        expected: &'static str,
    ) -> Result<Block, ReadError> {
        let error =
            |expected| ReadError::Parse(ParseError::at(Place::ByteOffset(offset), expected));
        if offset < ID_BLOCK || !self.keep_to(offset.saturating_add(HEADER))? {
            return Err(error(expected));
        }
        let at = offset as usize;
        let head = &self.kept[at..at + HEADER as usize];
        let mut id = [0u8; 4];
        id.copy_from_slice(&head[..4]);
        let len = u64_at(head, 8).unwrap_or(0);
        let links = u64_at(head, 16).unwrap_or(u64::MAX);
        if !ids.contains(&&id) {
            return Err(error(expected));
        }
        self.seen.push(offset);
        if len > MAX_METADATA_BYTES || links > (len.saturating_sub(HEADER)) / 8 {
            return Err(error(E_BLOCK));
        }
        if !self.keep_to(offset + len)? {
            return Err(error(E_TRUNCATED));
        }
        Ok(Block {
            offset,
            id,
            links: links as usize,
            len: len as usize,
        })
    }

    /// Appends up to `count` file bytes at `at` to `out`, fewer where the
    /// file ends first: how many.
    fn append_available(
        &mut self,
        at: u64,
        count: u64,
        out: &mut Vec<u8>,
    ) -> Result<u64, &'static str> {
        if self.keep_all {
            self.keep_to(at.saturating_add(count))
                .map_err(|_| E_TRUNCATED)?;
        }
        let have = self.kept.len() as u64;
        let mut got = 0;
        if at < have {
            let end = have.min(at + count);
            out.extend_from_slice(&self.kept[at as usize..end as usize]);
            got = end - at;
        }
        if got == count || self.keep_all {
            return Ok(got);
        }
        let at = at + got;
        if at < self.pos {
            return Err(E_ORDER);
        }
        let gap = at - self.pos;
        let skipped =
            io::copy(&mut (&mut self.input).take(gap), &mut io::sink()).map_err(|_| E_TRUNCATED)?;
        self.pos += skipped;
        if skipped < gap {
            return Ok(got);
        }
        let read = (&mut self.input)
            .take(count - got)
            .read_to_end(out)
            .map_err(|_| E_TRUNCATED)? as u64;
        self.pos += read;
        Ok(got + read)
    }

    /// Appends the `count` file bytes at `at` to `out`, from `kept` or the
    /// input (skipping forward to them).
    fn append(&mut self, at: u64, count: u64, out: &mut Vec<u8>) -> Result<(), &'static str> {
        let (mut at, mut count) = (at, count);
        if self.keep_all {
            match self.keep_to(at.saturating_add(count)) {
                Ok(true) => {}
                _ => return Err(E_TRUNCATED),
            }
        }
        let have = self.kept.len() as u64;
        if at < have {
            let end = have.min(at + count);
            out.extend_from_slice(&self.kept[at as usize..end as usize]);
            count -= end - at;
            at = end;
        }
        if count == 0 {
            return Ok(());
        }
        if at < self.pos {
            return Err(E_ORDER);
        }
        let gap = at - self.pos;
        match io::copy(&mut (&mut self.input).take(gap), &mut io::sink()) {
            Ok(skipped) if skipped == gap => self.pos = at,
            _ => return Err(E_TRUNCATED),
        }
        // `count` is at most a chunk, or a DZ block's stated size: read it
        // in chunks so a false size costs no memory.
        while count > 0 {
            let step = count.min(CHUNK);
            let before = out.len();
            out.resize(before + step as usize, 0);
            if self.input.read_exact(&mut out[before..]).is_err() {
                out.truncate(before);
                return Err(E_TRUNCATED);
            }
            self.pos += step;
            count -= step;
        }
        Ok(())
    }
}

/// An unsigned little-endian field of a record.
#[derive(Clone, Copy, Debug)]
struct Field {
    byte: usize,
    bit: u32,
    bits: u32,
}

impl Field {
    #[inline]
    fn read(&self, record: &[u8]) -> u64 {
        // Whole bytes, the fields bus logging writes: no shifting.
        if self.bit == 0 {
            match self.bits {
                8 => return record.get(self.byte).map_or(0, |&b| u64::from(b)),
                32 => return u32_at(record, self.byte).map_or(0, u64::from),
                _ => {}
            }
        }
        let mut word = [0u8; 16];
        let bytes = ((self.bit + self.bits).div_ceil(8)) as usize;
        if let Some(source) = record.get(self.byte..self.byte + bytes) {
            word[..bytes].copy_from_slice(source);
        }
        let value = u128::from_le_bytes(word) >> self.bit;
        (value & ((1u128 << self.bits) - 1)) as u64
    }
}

/// Where a bus-logging member's value comes from: loggers store the same
/// member as a bit field, a constant, or a field through a conversion.
#[derive(Clone, Debug)]
enum Member {
    /// A bit field's raw value.
    Bits(Field),
    /// A virtual channel of one value, or a field whose conversion gives
    /// one whatever its raw value.
    Constant(u64),
    /// A field of at most 16 bits through a conversion, looked up: the
    /// value of every raw value, `None` where it is no whole number.
    Table {
        field: Field,
        values: Box<[Option<u64>]>,
    },
    /// A wider field through a conversion.
    Converted {
        field: Field,
        conversion: Conversion,
    },
    /// A virtual channel: its conversion of the record's index in its
    /// group.
    Index(Conversion),
}

/// Widest field whose conversion is tabulated per raw value.
const TABLE_BITS: u32 = 8;

impl Member {
    fn new(field: Option<Field>, conversion: Option<Conversion>) -> Option<Self> {
        let conversion = conversion.filter(|c| *c != Conversion::Identity);
        let constant = conversion.as_ref().and_then(Conversion::constant);
        Some(match (field, conversion, constant) {
            (_, Some(_), Some(value)) => Member::Constant(whole(value)?),
            (Some(field), None, _) => Member::Bits(field),
            (Some(field), Some(conversion), None) if field.bits <= TABLE_BITS => Member::Table {
                field,
                values: (0..1u64 << field.bits)
                    .map(|raw| whole(conversion.apply(raw as f64, true)))
                    .collect(),
            },
            (Some(field), Some(conversion), None) => Member::Converted { field, conversion },
            (None, Some(conversion), None) => Member::Index(conversion),
            // A virtual channel without a conversion is its record index.
            (None, None, _) => Member::Index(Conversion::Identity),
        })
    }

    /// The member's value in `record`, the `index`th of its group.
    #[inline]
    fn value(&self, record: &[u8], index: u64) -> Result<u64, &'static str> {
        match self {
            Member::Bits(field) => Ok(field.read(record)),
            Member::Constant(value) => Ok(*value),
            Member::Table { field, values } => values
                .get(field.read(record) as usize)
                .copied()
                .flatten()
                .ok_or(E_FIELD_VALUE),
            Member::Converted { field, conversion } => {
                whole(conversion.apply(field.read(record) as f64, true)).ok_or(E_FIELD_VALUE)
            }
            Member::Index(conversion) => {
                whole(conversion.apply(index as f64, true)).ok_or(E_FIELD_VALUE)
            }
        }
    }
}

/// A conversion's result as a field's value: a whole number from 0 up.
fn whole(value: f64) -> Option<u64> {
    let rounded = value.round();
    ((value - rounded).abs() <= 1e-9 * rounded.abs().max(1.0) && (0.0..1.8e19).contains(&rounded))
        .then_some(rounded as u64)
}

/// How the master channel gives seconds.
#[derive(Clone, Copy, Debug)]
enum TimeKind {
    /// A virtual master: the record's index in its group through a linear
    /// conversion.
    Index(Scale),
    /// A little-endian float (8 or 4 bytes) through `a + b * value` to
    /// seconds (a logger's f64 of nanoseconds has b = 1e-9).
    Float { bytes: usize, scale: Scale },
    /// Raw integer (signed when `true`) times `ns_per_unit`, plus `offset_s`.
    Integer {
        signed: bool,
        field: Field,
        ns_per_unit: Option<i64>,
        a: f64,
        b: f64,
    },
}

/// A linear conversion to seconds, `a + b * value`, kept exact where it
/// is a whole number of nanoseconds per unit.
#[derive(Clone, Copy, Debug)]
struct Scale {
    a: f64,
    b: f64,
    ns_per_unit: Option<f64>,
}

impl Scale {
    fn new(a: f64, b: f64) -> Self {
        let ns = b * 1e9;
        let whole = a == 0.0 && (1.0..=1e12).contains(&ns) && ns.fract() == 0.0;
        Scale {
            a,
            b,
            ns_per_unit: whole.then_some(ns),
        }
    }

    fn ns(self, value: f64) -> Option<i64> {
        match self.ns_per_unit {
            Some(ns) => whole_ns(value * ns),
            None => seconds_to_ns(self.a + self.b * value),
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Time {
    byte: usize,
    kind: TimeKind,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FrameType {
    Data,
    Remote,
    Error,
}

/// Where a CAN group's fields lie in its records.
#[derive(Clone, Debug)]
struct CanLayout {
    frame_type: FrameType,
    time: Time,
    channel: Option<Member>,
    id: Option<Member>,
    ide: Option<Member>,
    dlc: Option<Member>,
    data_length: Option<Member>,
    data_bytes: Option<Bytes>,
    dir: Option<Member>,
    edl: Option<Member>,
    brs: Option<Member>,
    esi: Option<Member>,
    /// Records of this group read so far: a virtual member's raw value.
    records: u64,
}

/// Where a frame's DataBytes are.
#[derive(Clone, Copy, Debug)]
enum Bytes {
    /// Inside the record: byte offset and length.
    Fixed { at: usize, len: usize },
    /// Variable length signal data: the record holds a u64 offset (at this
    /// byte) into the stream of the data group's `signals[signal]`.
    Vlsd { at: usize, signal: usize },
}

#[derive(Clone, Debug)]
enum Layout {
    /// Records acq does not read, of this many bytes.
    Skip(usize),
    /// VLSD records: a u32 length, then the bytes.
    Vlsd,
    Can(usize, Box<CanLayout>),
}

/// The records of one data group.
struct Cursor {
    record_id_bytes: usize,
    layouts: Vec<(u64, Layout)>,
    blocks: Vec<u64>,
    next_block: usize,
    /// File offset of the data block being read (error "lines").
    block_offset: u64,
    /// The rest of the `##DT` being read: file offsets `next..end`.
    dt_next: u64,
    dt_end: u64,
    buf: Vec<u8>,
    start: usize,
    done: bool,
    /// The next block (its file offset), read ahead.
    ahead: Option<(u64, Ahead)>,
    /// The longest fixed-size record with its id: room kept before a
    /// block's records for one that began in the block before.
    longest_record: usize,
    /// The last `##DT` block's length was never written (an unfinalized
    /// file's flag 0x04): it runs to the next block or the file's end.
    open_ended: bool,
    /// Every block the metadata names, ascending: the one after an
    /// open-ended block is where it ends.
    known_blocks: Vec<u64>,
    /// The block being read is the open-ended one.
    in_open_ended_block: bool,
    /// Records read, of every group.
    records_read: u64,
    /// What the reader should tell (a cut record).
    notes: Vec<String>,
    /// The VLSD DataBytes channels' values, by the index in
    /// [`Bytes::Vlsd`].
    signals: Vec<SignalData>,
}

impl Cursor {
    fn new(record_id_bytes: usize, layouts: Vec<(u64, Layout)>, blocks: Vec<u64>) -> Self {
        let longest_record = record_id_bytes
            + layouts
                .iter()
                .map(|(_, layout)| match layout {
                    Layout::Skip(size) | Layout::Can(size, _) => *size,
                    Layout::Vlsd => 0,
                })
                .max()
                .unwrap_or(0);
        Cursor {
            record_id_bytes,
            layouts,
            block_offset: blocks.first().copied().unwrap_or(0),
            blocks,
            next_block: 0,
            dt_next: 0,
            dt_end: 0,
            buf: Vec::new(),
            start: 0,
            done: false,
            ahead: None,
            longest_record,
            open_ended: false,
            known_blocks: Vec::new(),
            in_open_ended_block: false,
            records_read: 0,
            notes: Vec::new(),
            signals: Vec::new(),
        }
    }
}

impl<R: BufRead> Mf4Reader<R> {
    pub fn new(input: R) -> Self {
        Mf4Reader {
            source: Source {
                input,
                kept: Vec::new(),
                pos: 0,
                keep_all: false,
                seen: Vec::new(),
            },
            opened: false,
            finished: false,
            start_ns: 0,
            cursors: Vec::new(),
            heads: Vec::new(),
            time_text: TimeText::default(),
            interfaces: Vec::new(),
            file_notes: Vec::new(),
            inflation: Inflation {
                inflater: None,
                tried_to_start: false,
                received: Vec::new(),
                spare: Vec::new(),
            },
        }
    }

    /// The next CAN frame, merged across data groups by time; `Ok(None)` at
    /// the end. After an `Err(Parse)` in a record the reader goes on with
    /// the next record; after one in the metadata it ends.
    pub fn next_record(&mut self) -> Result<Option<LogRecord<'_>>, ReadError> {
        if self.finished {
            return Ok(None);
        }
        if !self.opened {
            self.opened = true;
            if let Err(error) = self.open() {
                self.finished = true;
                return Err(error);
            }
        }
        if let [cursor] = &mut self.cursors[..] {
            // One group (acq's files, loggers'): nothing to merge.
            if cursor.done {
                self.finished = true;
                return Ok(None);
            }
            let next = cursor.next_frame(&mut self.source, &mut self.inflation, self.start_ns)?;
            let Some((frame, line)) = next else {
                cursor.done = true;
                self.finished = true;
                return Ok(None);
            };
            return Ok(Some(self.record(frame, line)));
        }
        for index in 0..self.cursors.len() {
            if self.heads[index].is_none() && !self.cursors[index].done {
                let next = self.cursors[index].next_frame(
                    &mut self.source,
                    &mut self.inflation,
                    self.start_ns,
                );
                match next {
                    Ok(Some(head)) => self.heads[index] = Some(head),
                    Ok(None) => self.cursors[index].done = true,
                    Err(error) => return Err(error),
                }
            }
        }
        let earliest = self
            .heads
            .iter()
            .enumerate()
            .filter_map(|(index, head)| head.as_ref().map(|(frame, _)| (frame.timestamp_ns, index)))
            .min();
        let Some((_, index)) = earliest else {
            self.finished = true;
            return Ok(None);
        };
        let Some((frame, line)) = self.heads[index].take() else {
            return Ok(None);
        };
        Ok(Some(self.record(frame, line)))
    }

    /// What the reader has to tell that is no error, taken once: a cut
    /// record at the end of an unfinalized file.
    pub fn take_notes(&mut self) -> Vec<String> {
        let mut notes: Vec<String> = std::mem::take(&mut self.file_notes);
        if self.finished && !self.interfaces.is_empty() {
            // How the file's bus numbers became interface names, said once:
            // loggers count buses from 1, a rig's interfaces often from 0.
            let names: Vec<&str> = self.interfaces.iter().map(|i| i.as_str()).collect();
            notes.push(format!(
                "MF4 BusChannel N read as interface canN (no BusChannel: can0): frames on {}",
                names.join(", ")
            ));
            self.interfaces.clear();
        }
        for cursor in &mut self.cursors {
            notes.append(&mut cursor.notes);
            for signal in &mut cursor.signals {
                notes.append(&mut signal.cursor.notes);
            }
        }
        notes
    }

    /// The record of `frame`, its time written out as seconds.
    fn record(&mut self, frame: Frame, line: u64) -> LogRecord<'_> {
        if self.interfaces.last() != Some(&frame.iface) && !self.interfaces.contains(&frame.iface) {
            self.interfaces.push(frame.iface);
        }
        LogRecord {
            line,
            timestamp_text: self.time_text.set(frame.timestamp_ns),
            frame,
        }
    }

    /// Reads the metadata: which groups hold CAN frames, where their fields
    /// and data blocks are.
    fn open(&mut self) -> Result<(), ReadError> {
        let source = &mut self.source;
        let id_error = || ReadError::Parse(ParseError::at(Place::ByteOffset(0), E_ID));
        if !source.keep_to(ID_BLOCK)?
            || (&source.kept[..8] != SIGNATURE && &source.kept[..8] != UNFINALIZED_SIGNATURE)
        {
            return Err(id_error());
        }
        let version = u16_at(&source.kept, 28).unwrap_or(0);
        if !(400..500).contains(&version) {
            return Err(id_error());
        }
        // An unfinalized file (its writer was cut off, or a logger that
        // never finalizes): its flags say which fields were never written.
        let unfinalized = if &source.kept[..8] == UNFINALIZED_SIGNATURE {
            u16_at(&source.kept, 60).unwrap_or(0)
        } else {
            0
        };
        let hd = source.block(ID_BLOCK, &[b"##HD"], E_HD)?;
        if hd.links < 1 || hd.data(&source.kept).len() < 8 {
            return Err(parse(ID_BLOCK, E_HD));
        }
        // A start past 2262 does not fit: taken as no absolute time.
        self.start_ns = u64_at(hd.data(&source.kept), 0)
            .and_then(|ns| i64::try_from(ns).ok())
            .unwrap_or(0);
        // Time flags: bit 0, the start is local time (its zone unknown);
        // bit 1, the zone and daylight offsets are valid (the start is UTC).
        let time_flags = hd.data(&source.kept).get(12).copied().unwrap_or(0);
        if time_flags & 1 != 0 && time_flags & 2 == 0 {
            self.file_notes.push(
                "the MF4 header's start time is local time of an unknown zone: taken as UTC".into(),
            );
        }
        let mut visited = rustc_hash::FxHashSet::default();
        let mut dg_at = hd.link(&source.kept, 0);
        let mut cursors = Vec::new();
        while dg_at != 0 {
            if !visited.insert(dg_at) {
                return Err(parse(dg_at, E_LOOP));
            }
            let dg = source.block(dg_at, &[b"##DG"], E_DG)?;
            let record_id_bytes = dg.data(&source.kept).first().copied().unwrap_or(u8::MAX);
            if !matches!(record_id_bytes, 0 | 1 | 2 | 4 | 8) || dg.links < 3 {
                return Err(parse(dg_at, E_DG));
            }
            let mut layouts = Vec::new();
            // Each channel group's offset: a VLSD channel links to its
            // signal data's group by offset.
            let mut group_offsets = Vec::new();
            let mut signal_links = Vec::new();
            let mut cg_at = dg.link(&source.kept, 1);
            while cg_at != 0 {
                if !visited.insert(cg_at) {
                    return Err(parse(cg_at, E_LOOP));
                }
                let cg = source.block(cg_at, &[b"##CG"], E_CG)?;
                let layout = group_layout(source, &cg, &mut visited, &mut signal_links)?;
                let data = cg.data(&source.kept);
                layouts.push((u64_at(data, 0).unwrap_or(0), layout));
                group_offsets.push(cg_at);
                cg_at = cg.link(&source.kept, 0);
            }
            if record_id_bytes == 0 && layouts.len() > 1 {
                return Err(parse(dg_at, E_SORTED));
            }
            let reads_can = layouts.iter().any(|(_, l)| matches!(l, Layout::Can(..)));
            let data_at = dg.link(&source.kept, 2);
            if reads_can && data_at != 0 {
                let mut blocks = Vec::new();
                let unlisted = unfinalized & UNFINALIZED_LAST_LIST != 0;
                data_blocks(source, data_at, &mut blocks, &mut visited, unlisted)?;
                let mut cursor = Cursor::new(usize::from(record_id_bytes), layouts, blocks);
                for link in signal_links {
                    let signal = signal_data(
                        source,
                        link,
                        &cursor,
                        &group_offsets,
                        &mut visited,
                        unlisted,
                    )?;
                    cursor.signals.push(signal);
                }
                cursors.push(cursor);
            }
            dg_at = dg.link(&source.kept, 0);
        }
        if unfinalized & UNFINALIZED_LAST_DT_LENGTH != 0 {
            let mut known: Vec<u64> = visited
                .iter()
                .copied()
                .chain(source.seen.iter().copied())
                .collect();
            known.sort_unstable();
            known.dedup();
            for cursor in &mut cursors {
                cursor.open_ended = true;
                cursor.known_blocks = known.clone();
                for signal in &mut cursor.signals {
                    signal.cursor.open_ended = true;
                    signal.cursor.known_blocks = known.clone();
                }
            }
        }
        for signal in cursors.iter_mut().flat_map(|c| c.signals.iter_mut()) {
            signal.in_order = unfinalized & UNFINALIZED_VLSD_OFFSETS != 0;
        }
        // Several groups, or a group and its signal data, are read side by
        // side: none can be streamed past.
        source.keep_all = cursors.len() > 1 || cursors.iter().any(|c| !c.signals.is_empty());
        self.heads = vec![None; cursors.len()];
        self.cursors = cursors;
        Ok(())
    }
}

fn parse(offset: u64, expected: &'static str) -> ReadError {
    ReadError::Parse(ParseError::at(Place::ByteOffset(offset), expected))
}

/// The signal data a VLSD channel links to (`link`): a VLSD channel
/// group of its own data group (`cursor`'s), or `##SD` blocks.
fn signal_data<R: BufRead>(
    source: &mut Source<R>,
    link: u64,
    cursor: &Cursor,
    group_offsets: &[u64],
    visited: &mut rustc_hash::FxHashSet<u64>,
    unlisted_after_list: bool,
) -> Result<SignalData, ReadError> {
    let reader = |cursor: Cursor, group: usize| SignalData {
        cursor,
        group,
        next_offset: 0,
        last: None,
        in_order: false,
    };
    if let Some(group) = group_offsets.iter().position(|&at| at == link) {
        if !matches!(cursor.layouts[group].1, Layout::Vlsd) {
            return Err(parse(link, E_BYTES));
        }
        // The same records, read again for this group's values only.
        let layouts = cursor
            .layouts
            .iter()
            .map(|(id, layout)| {
                let layout = match layout {
                    Layout::Can(size, _) => Layout::Skip(*size),
                    other => other.clone(),
                };
                (*id, layout)
            })
            .collect();
        return Ok(reader(
            Cursor::new(cursor.record_id_bytes, layouts, cursor.blocks.clone()),
            group,
        ));
    }
    let mut blocks = Vec::new();
    data_blocks(source, link, &mut blocks, visited, unlisted_after_list)?;
    Ok(reader(Cursor::new(0, vec![(0, Layout::Vlsd)], blocks), 0))
}

/// The data blocks under `at` (a data block, or a list of them), in order.
/// With `unlisted_after_list` (an unfinalized file's flag 0x10: the last
/// `##DL` was not updated), the data blocks that follow the last list in
/// the file, one after the other, are its too (as asammdf finalizes it).
fn data_blocks<R: BufRead>(
    source: &mut Source<R>,
    at: u64,
    blocks: &mut Vec<u64>,
    visited: &mut rustc_hash::FxHashSet<u64>,
    unlisted_after_list: bool,
) -> Result<(), ReadError> {
    let mut last_list_end = None;
    data_blocks_listed(source, at, blocks, visited, &mut last_list_end)?;
    let Some(mut next) = last_list_end.filter(|_| unlisted_after_list) else {
        return Ok(());
    };
    loop {
        next = next.next_multiple_of(8);
        if !source.keep_to(next.saturating_add(HEADER))? {
            return Ok(());
        }
        let head = &source.kept[next as usize..next as usize + HEADER as usize];
        let len = u64_at(head, 8).unwrap_or(0);
        let is_data = matches!(&head[..4], b"##DT" | b"##DZ" | b"##SD");
        if !is_data || len < HEADER || !source.keep_to(next.saturating_add(len))? {
            return Ok(());
        }
        if !visited.insert(next) {
            return Err(parse(next, E_LOOP));
        }
        blocks.push(next);
        next += len;
    }
}

/// The data blocks a data block or list at `at` names; where the last
/// `##DL` ends.
fn data_blocks_listed<R: BufRead>(
    source: &mut Source<R>,
    at: u64,
    blocks: &mut Vec<u64>,
    visited: &mut rustc_hash::FxHashSet<u64>,
    last_list_end: &mut Option<u64>,
) -> Result<(), ReadError> {
    let mut list_at = at;
    // HL -> DL chain; DL -> DL chain; DT/DZ alone.
    let mut first = true;
    while list_at != 0 {
        if !visited.insert(list_at) {
            return Err(parse(list_at, E_LOOP));
        }
        // A data block's header only: its data may be large.
        if !source.keep_to(list_at.saturating_add(HEADER))? || list_at < ID_BLOCK {
            return Err(parse(list_at, E_DATA));
        }
        let id = &source.kept[list_at as usize..list_at as usize + 4];
        match id {
            b"##DT" | b"##DZ" | b"##SD" if first => {
                blocks.push(list_at);
                return Ok(());
            }
            b"##HL" if first => {
                let hl = source.block(list_at, &[b"##HL"], E_DATA)?;
                list_at = hl.link(&source.kept, 0);
            }
            b"##DL" => {
                let dl = source.block(list_at, &[b"##DL"], E_DATA)?;
                *last_list_end = Some(list_at + dl.len as u64);
                let count = u32_at(dl.data(&source.kept), 4).unwrap_or(0) as usize;
                for index in 0..count.min(dl.links.saturating_sub(1)) {
                    let block = dl.link(&source.kept, 1 + index);
                    if block != 0 {
                        blocks.push(block);
                    }
                }
                list_at = dl.link(&source.kept, 0);
            }
            _ => return Err(parse(list_at, E_DATA)),
        }
        first = false;
    }
    Ok(())
}

/// A channel's fields as far as the layout needs them.
struct Channel {
    offset: u64,
    name: Vec<u8>,
    channel_type: u8,
    data_type: u8,
    bit: u32,
    byte: u64,
    bits: u64,
    conversion: u64,
    /// Its `##SD` blocks or VLSD `##CG` (a VLSD channel's).
    signal_data: u64,
}

/// The record layout of a channel group.
///
/// A VLSD DataBytes channel's signal data (the link to its `##SD` blocks
/// or VLSD channel group) is pushed on `signals`; its layout names the
/// index.
fn group_layout<R: BufRead>(
    source: &mut Source<R>,
    cg: &Block,
    visited: &mut rustc_hash::FxHashSet<u64>,
    signals: &mut Vec<u64>,
) -> Result<Layout, ReadError> {
    let data = cg.data(&source.kept);
    let (Some(flags), Some(data_bytes), Some(inval_bytes)) =
        (u16_at(data, 16), u32_at(data, 24), u32_at(data, 28))
    else {
        return Err(parse(cg.offset, E_CG));
    };
    if flags & 1 != 0 {
        return Ok(Layout::Vlsd);
    }
    let record_bytes = data_bytes as usize + inval_bytes as usize;
    let channels = group_channels(source, cg, visited)?;
    let frame_type = channels.iter().find_map(|c| {
        let base = c.name.split(|&b| b == b'.').next().unwrap_or(&[]);
        match base {
            b"CAN_DataFrame" => Some(FrameType::Data),
            b"CAN_RemoteFrame" => Some(FrameType::Remote),
            b"CAN_ErrorFrame" => Some(FrameType::Error),
            _ => None,
        }
    });
    let Some(frame_type) = frame_type else {
        return Ok(Layout::Skip(record_bytes));
    };
    let Some(master) = channels.iter().find(|c| matches!(c.channel_type, 2 | 3)) else {
        return Err(parse(cg.offset, E_MASTER));
    };
    let time = time_layout(source, master, data_bytes)?;
    // `CAN_DataFrame.ID`, or `ID` alone as some writers name members.
    let member = |name: &[u8]| {
        channels.iter().find(|c| {
            c.name == name
                || c.name
                    .iter()
                    .rposition(|&b| b == b'.')
                    .is_some_and(|dot| &c.name[dot + 1..] == name)
        })
    };
    let mut field = |name: &[u8]| -> Result<Option<Member>, ReadError> {
        let Some(c) = member(name) else {
            return Ok(None);
        };
        let conversion = read_conversion(source, c.conversion, c.offset)?;
        // A virtual channel (type 6) has no bits: its value is its
        // conversion of the record's index.
        let bits = match c.channel_type {
            6 => None,
            _ => Some(int_field(c, data_bytes, 0)?),
        };
        Member::new(bits, conversion)
            .map(Some)
            .ok_or_else(|| parse(c.offset, E_FIELD_VALUE))
    };
    let layout = CanLayout {
        frame_type,
        time,
        channel: field(b"BusChannel")?,
        id: field(b"ID")?,
        ide: field(b"IDE")?,
        dlc: field(b"DLC")?,
        data_length: field(b"DataLength")?,
        data_bytes: match member(b"DataBytes") {
            None => None,
            Some(c) => Some(bytes_layout(c, data_bytes, signals)?),
        },
        dir: field(b"Dir")?,
        edl: field(b"EDL")?,
        brs: field(b"BRS")?,
        esi: field(b"ESI")?,
        records: 0,
    };
    if layout.id.is_none() && frame_type != FrameType::Error {
        return Err(parse(cg.offset, E_NO_ID));
    }
    Ok(Layout::Can(record_bytes, Box::new(layout)))
}

/// Every channel of a channel group, members of structures included.
fn group_channels<R: BufRead>(
    source: &mut Source<R>,
    cg: &Block,
    visited: &mut rustc_hash::FxHashSet<u64>,
) -> Result<Vec<Channel>, ReadError> {
    let mut channels = Vec::new();
    let mut pending = vec![cg.link(&source.kept, 1)];
    while let Some(mut cn_at) = pending.pop() {
        while cn_at != 0 {
            if !visited.insert(cn_at) {
                return Err(parse(cn_at, E_LOOP));
            }
            let cn = source.block(cn_at, &[b"##CN"], E_CN)?;
            let fields = cn.data(&source.kept);
            if fields.len() < 16 || cn.links < 5 {
                return Err(parse(cn_at, E_CN));
            }
            let name_at = cn.link(&source.kept, 2);
            let composition = cn.link(&source.kept, 1);
            let mut channel = Channel {
                offset: cn_at,
                name: Vec::new(),
                channel_type: fields[0],
                data_type: fields[2],
                bit: u32::from(fields[3]),
                byte: u64::from(u32_at(fields, 4).unwrap_or(0)),
                bits: u64::from(u32_at(fields, 8).unwrap_or(0)),
                conversion: cn.link(&source.kept, 4),
                signal_data: cn.link(&source.kept, 5),
            };
            let next = cn.link(&source.kept, 0);
            if name_at != 0 {
                channel.name = text(source, name_at, E_CN)?;
            }
            channels.push(channel);
            if composition != 0
                && source.block(composition, &[b"##CN", b"##CA"], E_CN)?.id == *b"##CN"
            {
                pending.push(composition);
            }
            cn_at = next;
        }
    }
    Ok(channels)
}

/// The text of the `##TX` block at `at`, up to its first NUL.
fn text<R: BufRead>(
    source: &mut Source<R>,
    at: u64,
    expected: &'static str,
) -> Result<Vec<u8>, ReadError> {
    let tx = source.block(at, &[b"##TX"], expected)?;
    let text = tx.data(&source.kept);
    let end = text.iter().position(|&b| b == 0).unwrap_or(text.len());
    Ok(text[..end].to_vec())
}

/// A DataBytes channel: a byte array in the record, or a VLSD channel
/// whose record holds a u64 offset into its signal data.
fn bytes_layout(c: &Channel, data_bytes: u32, signals: &mut Vec<u64>) -> Result<Bytes, ReadError> {
    let len = c.bits / 8;
    let in_record = c.bit == 0 && c.bits % 8 == 0 && c.byte + len <= u64::from(data_bytes);
    match (c.channel_type, c.data_type) {
        (0, 10) if in_record => Ok(Bytes::Fixed {
            at: c.byte as usize,
            len: len as usize,
        }),
        (1, 10) if in_record && len == 8 && c.signal_data != 0 => {
            signals.push(c.signal_data);
            Ok(Bytes::Vlsd {
                at: c.byte as usize,
                signal: signals.len() - 1,
            })
        }
        _ => Err(parse(c.offset, E_BYTES)),
    }
}

/// The conversion at `at` (0: none), of the channel at `channel`.
fn read_conversion<R: BufRead>(
    source: &mut Source<R>,
    at: u64,
    channel: u64,
) -> Result<Option<Conversion>, ReadError> {
    if at == 0 {
        return Ok(None);
    }
    let cc = source.block(at, &[b"##CC"], E_CONVERSION)?;
    // An algebraic conversion's formula: its first reference's text.
    let formula_at = cc.link(&source.kept, 4);
    let formula = match formula_at {
        0 => None,
        _ => text(source, formula_at, E_CONVERSION).ok(),
    };
    Conversion::parse(cc.data(&source.kept), || formula)
        .map(Some)
        .map_err(|expected| {
            ReadError::Parse(ParseError {
                note: Some(format!("the conversion at byte offset {at}")),
                ..ParseError::at(Place::ByteOffset(channel), expected)
            })
        })
}

/// An unsigned (or, with `signed_ok`, signed) little-endian integer field
/// inside `data_bytes`.
fn int_field(c: &Channel, data_bytes: u32, signed_ok: u8) -> Result<Field, ReadError> {
    let fits = c.bit < 8
        && (1..=64).contains(&c.bits)
        && c.channel_type != 1
        && (c.data_type == 0 || (signed_ok != 0 && c.data_type == 2))
        && c.byte + (u64::from(c.bit) + c.bits).div_ceil(8) <= u64::from(data_bytes);
    if !fits {
        return Err(parse(c.offset, E_FIELD));
    }
    Ok(Field {
        byte: c.byte as usize,
        bit: c.bit,
        bits: c.bits as u32,
    })
}

fn time_layout<R: BufRead>(
    source: &mut Source<R>,
    master: &Channel,
    data_bytes: u32,
) -> Result<Time, ReadError> {
    let error = || parse(master.offset, E_MASTER);
    let (a, b) = match read_conversion(source, master.conversion, master.offset)? {
        None | Some(Conversion::Identity) => (0.0, 1.0),
        Some(Conversion::Linear { offset, factor }) => (offset, factor),
        Some(_) => return Err(error()),
    };
    if master.channel_type == 3 {
        // A virtual master: its conversion of the record's index.
        return Ok(Time {
            byte: 0,
            kind: TimeKind::Index(Scale::new(a, b)),
        });
    }
    let inside = |bytes: u64| master.byte + bytes <= u64::from(data_bytes);
    let kind = match (master.data_type, master.bits) {
        (4, 64 | 32) if master.bit == 0 && inside(master.bits / 8) => {
            if !a.is_finite() || !b.is_finite() {
                return Err(error());
            }
            TimeKind::Float {
                bytes: master.bits as usize / 8,
                scale: Scale::new(a, b),
            }
        }
        (0 | 2, _) => {
            let field = int_field(master, data_bytes, 1)?;
            // An exact number of ns per unit (1e-9, 1e-6, 1e-5 s...) keeps
            // integer times exact.
            let ns = b * 1e9;
            let ns_per_unit =
                (a == 0.0 && (1.0..=1e12).contains(&ns) && ns.fract() == 0.0).then_some(ns as i64);
            if !a.is_finite() || !b.is_finite() {
                return Err(error());
            }
            TimeKind::Integer {
                signed: master.data_type == 2,
                field,
                ns_per_unit,
                a,
                b,
            }
        }
        _ => return Err(error()),
    };
    Ok(Time {
        byte: master.byte as usize,
        kind,
    })
}

impl Cursor {
    /// Makes `need` bytes available at `buf[start..]`; `false` at the end of
    /// the group's data.
    fn fill<R: BufRead>(
        &mut self,
        need: usize,
        source: &mut Source<R>,
        inflation: &mut Inflation,
    ) -> Result<bool, ReadError> {
        while self.buf.len() - self.start < need {
            if self.start > 0 {
                self.buf.drain(..self.start);
                self.start = 0;
            }
            if self.dt_next < self.dt_end {
                let count = (self.dt_end - self.dt_next).min(CHUNK);
                let at = self.dt_next;
                if self.in_open_ended_block {
                    let got = source
                        .append_available(at, count, &mut self.buf)
                        .map_err(|expected| self.fail(expected))?;
                    self.dt_next += got;
                    if got < count {
                        self.dt_end = self.dt_next;
                    }
                    continue;
                }
                self.dt_next += count;
                source
                    .append(at, count, &mut self.buf)
                    .map_err(|expected| self.fail(expected))?;
                continue;
            }
            let Some(&at) = self.blocks.get(self.next_block) else {
                return Ok(false);
            };
            self.next_block += 1;
            self.block_offset = at;
            let ahead = match self.ahead.take() {
                Some((ahead_at, ahead)) if ahead_at == at => ahead,
                _ => match read_block(at, source, &mut inflation.spare, self.longest_record) {
                    Ok(block) => Ahead::Block(block),
                    Err(expected) => Ahead::Failed(expected),
                },
            };
            let inflated = match ahead {
                Ahead::Failed(expected) => return Err(self.fail(expected)),
                Ahead::Block(DataBlock::Dt { len }) => {
                    self.dt_next = at + HEADER;
                    self.dt_end = at.saturating_add(len);
                    if self.open_ended && self.next_block == self.blocks.len() {
                        // Its length was never written: up to the next
                        // block the metadata knows, or the file's end.
                        let next = self.known_blocks.partition_point(|&known| known <= at);
                        self.dt_end = self.known_blocks.get(next).copied().unwrap_or(u64::MAX);
                        self.in_open_ended_block = true;
                    }
                    continue;
                }
                Ahead::Block(DataBlock::Dz(mut job)) => {
                    // This block is read whole: the next can be read (and
                    // inflated) while this one is parsed.
                    self.read_ahead(source, inflation);
                    job.run();
                    job
                }
                Ahead::Sent => {
                    let Some(job) = inflation.receive(at) else {
                        self.done = true;
                        return Err(ReadError::Io(io::Error::other("the MF4 inflater stopped")));
                    };
                    self.read_ahead(source, inflation);
                    job
                }
            };
            self.take_inflated(inflated, inflation)?;
        }
        Ok(true)
    }

    /// Reads the block after the current one and sends it to the inflater
    /// (see [`Inflation`]).
    fn read_ahead<R: BufRead>(&mut self, source: &mut Source<R>, inflation: &mut Inflation) {
        let Some(&at) = self.blocks.get(self.next_block) else {
            return;
        };
        if self.ahead.is_some() {
            return;
        }
        if !inflation.tried_to_start {
            inflation.tried_to_start = true;
            inflation.inflater = Inflater::start("mf4-inflate");
        }
        // Without a thread (one core, fuzzing) the block is read ahead all
        // the same, and inflated when it is reached.
        let ahead = match read_block(at, source, &mut inflation.spare, self.longest_record) {
            Ok(DataBlock::Dz(job)) => match &inflation.inflater {
                Some(inflater) => match inflater.send(job) {
                    None => Ahead::Sent,
                    Some(job) => Ahead::Block(DataBlock::Dz(job)),
                },
                None => Ahead::Block(DataBlock::Dz(job)),
            },
            Ok(block) => Ahead::Block(block),
            Err(expected) => Ahead::Failed(expected),
        };
        self.ahead = Some((at, ahead));
    }

    fn fail(&mut self, expected: &'static str) -> ReadError {
        if expected == E_TRUNCATED || expected == E_ORDER {
            self.done = true;
        }
        parse(self.block_offset, expected)
    }

    /// Appends an inflated `##DZ` block's records to `buf`: its buffer
    /// becomes `buf`, with the start of a record begun in the block before
    /// copied into its headroom.
    fn take_inflated(
        &mut self,
        mut job: InflateJob,
        inflation: &mut Inflation,
    ) -> Result<(), ReadError> {
        if !job.inflated {
            inflation.spare.push(job);
            return Err(self.fail(E_DZ));
        }
        // A record begun in the last block goes in the headroom before the
        // new block's records: no copy of the block.
        let leftover = self.buf.len() - self.start;
        if leftover <= job.headroom {
            let begin = job.headroom - leftover;
            job.out[begin..job.headroom].copy_from_slice(&self.buf[self.start..]);
            std::mem::swap(&mut self.buf, &mut job.out);
            self.start = begin;
        } else {
            self.buf.extend_from_slice(&job.out[job.headroom..]);
        }
        inflation.spare.push(job);
        Ok(())
    }

    /// The next record: its group's index in `layouts`, where its bytes
    /// are in `buf` (after its record id), and the data block it starts in.
    fn next_record<R: BufRead>(
        &mut self,
        source: &mut Source<R>,
        inflation: &mut Inflation,
    ) -> Result<Option<(usize, Range<usize>, u64)>, ReadError> {
        let id_bytes = self.record_id_bytes;
        if !self.fill(id_bytes.max(1), source, inflation)? {
            if self.buf.len() > self.start {
                return self.cut(id_bytes.max(1));
            }
            return Ok(None);
        }
        let head = &self.buf[self.start..self.start + id_bytes];
        let mut word = [0u8; 8];
        word[..id_bytes].copy_from_slice(head);
        let record_id = u64::from_le_bytes(word);
        let index = if id_bytes == 0 {
            (!self.layouts.is_empty()).then_some(0)
        } else {
            self.layouts.iter().position(|(id, _)| *id == record_id)
        };
        let Some(index) = index else {
            // Without its size the next record cannot be found.
            self.done = true;
            if self.in_open_ended_block {
                // What the writer had not written yet (zeros, or an
                // unfinished record): the end of the data, as asammdf
                // reads it, named unless it is a block's zero padding.
                let rest = &self.buf[self.start..];
                let padding =
                    rest.len() < 8 && rest.iter().all(|&b| b == 0) && self.dt_next >= self.dt_end;
                if !padding {
                    self.notes.push(format!(
                        "unfinalized MF4: its last data block ends in bytes that are no record (record id {record_id}); the {} whole records before them are read",
                        self.records_read
                    ));
                }
                self.start = self.buf.len();
                return Ok(None);
            }
            return Err(parse(self.block_offset, E_RECORD_ID));
        };
        let size = match &self.layouts[index].1 {
            Layout::Skip(size) | Layout::Can(size, _) => *size,
            Layout::Vlsd => {
                if !self.fill(id_bytes + 4, source, inflation)? {
                    return self.cut(id_bytes + 4);
                }
                let len = u32_at(&self.buf, self.start + id_bytes).unwrap_or(0);
                4 + len as usize
            }
        };
        let line = self.block_offset;
        if !self.fill(id_bytes + size, source, inflation)? {
            return self.cut(id_bytes + size);
        }
        let record_start = self.start + id_bytes;
        self.start = record_start + size;
        self.records_read += 1;
        Ok(Some((index, record_start..record_start + size, line)))
    }

    /// The data ended inside a record of `need` bytes: an error in a
    /// finalized file; in an unfinalized one, whose writer was cut off,
    /// the end of its records, named in a note.
    fn cut<T>(&mut self, need: usize) -> Result<Option<T>, ReadError> {
        let have = self.buf.len() - self.start;
        self.start = self.buf.len();
        self.done = true;
        if !self.open_ended {
            return Err(parse(self.block_offset, E_RECORD));
        }
        self.notes.push(format!(
            "unfinalized MF4 cut off inside a record: its last {have} bytes are not a whole record ({need} bytes); the {} whole records before it are read",
            self.records_read
        ));
        Ok(None)
    }

    /// The next CAN frame of this group and its "line".
    fn next_frame<R: BufRead>(
        &mut self,
        source: &mut Source<R>,
        inflation: &mut Inflation,
        start_ns: i64,
    ) -> Result<Option<(Frame, u64)>, ReadError> {
        loop {
            let Some((index, range, line)) = self.next_record(source, inflation)? else {
                return Ok(None);
            };
            let Layout::Can(_, can) = &mut self.layouts[index].1 else {
                continue;
            };
            let record = &self.buf[range];
            let group_index = can.records;
            can.records += 1;
            let signal = match can.data_bytes {
                Some(Bytes::Vlsd { at, signal }) => {
                    let offset = u64_at(record, at).unwrap_or(u64::MAX);
                    let value = self.signals[signal]
                        .value_at(offset, source, inflation)
                        .map_err(|expected| parse(line, expected))?;
                    Some(value)
                }
                _ => None,
            };
            return decode(record, can, group_index, signal, start_ns)
                .map(|frame| Some((frame, line)))
                .map_err(|expected| parse(line, expected));
        }
    }
}

/// The values of one VLSD channel: a stream of `u32 length, bytes`, each
/// value at its offset from the stream's start. The stream is the
/// channel's `##SD` blocks (plain, zipped or listed), or the records of a
/// VLSD channel group in the same data group; a cursor of its own reads it,
/// so a value may come before or after the record that points to it.
struct SignalData {
    cursor: Cursor,
    /// The VLSD group's index in the cursor's layouts.
    group: usize,
    /// The offset of the next value.
    next_offset: u64,
    /// The last value read: its offset and bytes (in the cursor's `buf`).
    last: Option<(u64, Range<usize>)>,
    /// The offsets were never written (an unfinalized file's flag 0x40):
    /// the values pair with the records in order.
    in_order: bool,
}

impl SignalData {
    /// The value at `offset`: offsets grow from record to record (a value
    /// may be read twice).
    fn value_at<R: BufRead>(
        &mut self,
        offset: u64,
        source: &mut Source<R>,
        inflation: &mut Inflation,
    ) -> Result<&[u8], &'static str> {
        if let Some((at, range)) = &self.last {
            if *at == offset && !self.in_order {
                return Ok(&self.cursor.buf[range.start + 4..range.end]);
            }
        }
        if offset < self.next_offset && !self.in_order {
            return Err(E_VLSD);
        }
        // Reading on moves the cursor's bytes: the last value's range is
        // stale from here, whatever the read gives.
        self.last = None;
        loop {
            let Some((index, range, _)) = self
                .cursor
                .next_record(source, inflation)
                .map_err(|_| E_VLSD)?
            else {
                return Err(E_VLSD);
            };
            if index != self.group {
                continue;
            }
            let at = self.next_offset;
            self.next_offset += range.len() as u64;
            if at == offset || self.in_order {
                self.last = Some((at, range.clone()));
                return Ok(&self.cursor.buf[range.start + 4..range.end]);
            }
            if at > offset {
                return Err(E_VLSD);
            }
        }
    }
}

/// Reads the header of the data block at `at`, and a `##DZ` block's data
/// (checked, not inflated).
fn read_block<R: BufRead>(
    at: u64,
    source: &mut Source<R>,
    spare: &mut Vec<InflateJob>,
    headroom: usize,
) -> Result<DataBlock, &'static str> {
    const DZ_HEAD: u64 = 24;
    let mut header = Vec::with_capacity(HEADER as usize);
    source.append(at, HEADER, &mut header)?;
    let len = u64_at(&header, 8).unwrap_or(0);
    let links = u64_at(&header, 16).unwrap_or(u64::MAX);
    if len < HEADER || links != 0 {
        return Err(E_DATA);
    }
    match &header[..4] {
        b"##DT" | b"##SD" => return Ok(DataBlock::Dt { len }),
        b"##DZ" => {}
        _ => return Err(E_DATA),
    }
    if len < HEADER + DZ_HEAD || len - HEADER - DZ_HEAD > MAX_DZ_BYTES {
        return Err(E_DZ);
    }
    let mut job = spare.pop().unwrap_or_default();
    job.compressed.clear();
    if let Err(expected) = source.append(at + HEADER, len - HEADER, &mut job.compressed) {
        spare.push(job);
        return Err(expected);
    }
    let head = &job.compressed;
    let zip_type = head[2];
    let columns = u32_at(head, 4).unwrap_or(0) as usize;
    let original = u64_at(head, 8).unwrap_or(u64::MAX);
    let zipped = u64_at(head, 16).unwrap_or(u64::MAX);
    let stored = len - HEADER - DZ_HEAD;
    if !matches!(&head[..2], b"DT" | b"SD")
        || zip_type > 1
        || (zip_type == 1 && columns == 0)
        || zipped > stored
        || original > MAX_DZ_BYTES
        || original > zipped.saturating_mul(1032).saturating_add(1024)
    {
        spare.push(job);
        return Err(E_DZ);
    }
    job.stream = DZ_HEAD as usize..(DZ_HEAD + zipped) as usize;
    job.uncompressed = original as usize;
    job.transposed_columns = if zip_type == 1 { columns } else { 0 };
    // Bus-logging records are tens of bytes; a longer one (a field says
    // how long, not the data) is copied across instead.
    job.headroom = headroom.min(MAX_HEADROOM);
    job.block = at;
    Ok(DataBlock::Dz(job))
}

/// The frame one bus-logging record holds, the `index`th of its group;
/// `signal` its VLSD DataBytes.
fn decode(
    record: &[u8],
    layout: &CanLayout,
    index: u64,
    signal: Option<&[u8]>,
    start_ns: i64,
) -> Result<Frame, &'static str> {
    let read = |member: &Option<Member>| -> Result<Option<u64>, &'static str> {
        member.as_ref().map(|m| m.value(record, index)).transpose()
    };
    let timestamp_ns = time_ns(record, &layout.time, index, start_ns).ok_or(E_TIME)?;
    let iface = channel_iface(read(&layout.channel)?.unwrap_or(0))?;
    let raw_id = read(&layout.id)?.unwrap_or(0);
    let extended = match read(&layout.ide)? {
        Some(ide) => ide != 0,
        None => raw_id & 0x8000_0000 != 0,
    };
    let bits = (raw_id & 0x1FFF_FFFF) as u32;
    let dlc = read(&layout.dlc)?.unwrap_or(0).min(15) as u8;
    let mut frame = match layout.frame_type {
        FrameType::Error => {
            Frame::error(timestamp_ns, iface, ERROR_FRAME_CLASS, &[]).map_err(|_| E_LENGTH)?
        }
        FrameType::Remote => {
            let id = can_id(bits, extended)?;
            let len = dlc.min(CLASSIC_MAX_LEN as u8);
            let mut frame = Frame::remote(timestamp_ns, iface, id, len).map_err(|_| E_LENGTH)?;
            if dlc > 8 {
                frame.set_len8_dlc(dlc).map_err(|_| E_LENGTH)?;
            }
            frame
        }
        FrameType::Data => {
            let id = can_id(bits, extended)?;
            let fd = read(&layout.edl)?.unwrap_or(0) != 0;
            let from_dlc = if fd {
                FD_DLC_LENGTHS[usize::from(dlc)]
            } else {
                usize::from(dlc).min(CLASSIC_MAX_LEN)
            };
            let len = read(&layout.data_length)?.map_or(from_dlc, |n| n.min(255) as usize);
            let bytes = match (layout.data_bytes, signal) {
                (Some(Bytes::Fixed { at, len }), _) => &record[at..at + len],
                (Some(Bytes::Vlsd { .. }), Some(signal)) => signal,
                _ => &[],
            };
            let max = if fd { FD_MAX_LEN } else { CLASSIC_MAX_LEN };
            if len > bytes.len() || len > max {
                return Err(E_LENGTH);
            }
            if fd {
                let flags = fd_flags(
                    read(&layout.brs)?.unwrap_or(0) != 0,
                    read(&layout.esi)?.unwrap_or(0) != 0,
                );
                Frame::fd(timestamp_ns, iface, id, flags, &bytes[..len]).map_err(|_| E_LENGTH)?
            } else {
                let mut frame =
                    Frame::data(timestamp_ns, iface, id, &bytes[..len]).map_err(|_| E_LENGTH)?;
                if dlc > 8 && len == 8 {
                    frame.set_len8_dlc(dlc).map_err(|_| E_LENGTH)?;
                }
                frame
            }
        }
    };
    frame.direction = read(&layout.dir)?.map(|dir| {
        if dir == 0 {
            Direction::Received
        } else {
            Direction::Transmitted
        }
    });
    Ok(frame)
}

fn time_ns(record: &[u8], time: &Time, index: u64, start_ns: i64) -> Option<i64> {
    let offset_ns = match time.kind {
        TimeKind::Index(scale) => scale.ns(index as f64)?,
        TimeKind::Float { bytes: 8, scale } => scale.ns(f64_at(record, time.byte)?)?,
        TimeKind::Float { scale, .. } => scale.ns(f64::from(f32::from_le_bytes(
            record.get(time.byte..time.byte + 4)?.try_into().ok()?,
        )))?,
        TimeKind::Integer {
            signed,
            field,
            ns_per_unit,
            a,
            b,
        } => {
            let raw = field.read(record);
            let value = if signed && field.bits < 64 && raw >> (field.bits - 1) & 1 != 0 {
                (raw | (u64::MAX << field.bits)) as i64
            } else if signed {
                raw as i64
            } else {
                i64::try_from(raw).ok()?
            };
            match ns_per_unit {
                Some(ns) => value.checked_mul(ns)?,
                None => seconds_to_ns(a + b * value as f64)?,
            }
        }
    };
    start_ns.checked_add(offset_ns)
}

fn seconds_to_ns(seconds: f64) -> Option<i64> {
    whole_ns(seconds * 1e9)
}

/// Nanoseconds rounded to a whole number that fits an i64.
fn whole_ns(ns: f64) -> Option<i64> {
    let ns = ns.round();
    // i64::MAX as f64 rounds up to 2^63: exclude it.
    (ns.is_finite() && (-9.2e18..=9.2e18).contains(&ns)).then_some(ns as i64)
}

fn can_id(bits: u32, extended: bool) -> Result<CanId, &'static str> {
    if extended {
        CanId::extended(bits).ok_or(E_CAN_ID)
    } else {
        u16::try_from(bits)
            .ok()
            .and_then(CanId::standard)
            .ok_or(E_CAN_ID)
    }
}

/// `BusChannel` N -> interface `canN` (no allocation: it runs per frame).
fn channel_iface(channel: u64) -> Result<IfaceName, &'static str> {
    let mut digits = itoa::Buffer::new();
    let digits = digits.format(channel).as_bytes();
    let mut name = [0u8; 3 + 20];
    name[..3].copy_from_slice(b"can");
    name[3..3 + digits.len()].copy_from_slice(digits);
    IfaceName::from_bytes(&name[..3 + digits.len()]).ok_or(E_CHANNEL)
}

fn u16_at(bytes: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(
        bytes.get(at..at.checked_add(2)?)?.try_into().ok()?,
    ))
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(
        bytes.get(at..at.checked_add(4)?)?.try_into().ok()?,
    ))
}

fn u64_at(bytes: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(
        bytes.get(at..at.checked_add(8)?)?.try_into().ok()?,
    ))
}

fn f64_at(bytes: &[u8], at: usize) -> Option<f64> {
    u64_at(bytes, at).map(f64::from_bits)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_read_bits_little_endian() {
        let record = [0xAB, 0xCD, 0xEF, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07];
        let field = |byte, bit, bits| Field { byte, bit, bits }.read(&record);
        assert_eq!(field(0, 0, 8), 0xAB);
        assert_eq!(field(0, 4, 8), 0xDA);
        assert_eq!(field(1, 0, 16), 0xEFCD);
        assert_eq!(field(0, 0, 64), 0x0504_0302_01EF_CDAB);
        assert_eq!(field(1, 7, 64), 0x0E0C_0A08_0604_03DF);
    }

    #[test]
    fn garbage_and_truncation_are_errors_not_panics() {
        for bytes in [
            &b""[..],
            b"MDF     ",
            b"MDF     4.10    amdf8.8.\0\0\0\0\x9a\x01",
            b"not an mdf file at all, just text here..............................................",
        ] {
            let mut reader = Mf4Reader::new(bytes);
            for _ in 0..4 {
                if let Ok(None) = reader.next_record() {
                    break;
                }
            }
        }
    }
}
