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
//! conversion ([`conversion`]), `DataBytes` as a VLSD channel
//! (type 1) whose record holds a u64 offset into its signal data: `##SD`
//! blocks (or a `##DZ`/`##DL` of them), read by a cursor of their own
//! ([`SignalData`]), or the records of a VLSD channel group in the same
//! data group, taken as the group's records pass (a value before its
//! frame's record is kept, one after it is found ahead), so the data is
//! read once and streamed.
//!
//! Frames come one by one ([`Mf4Reader::next_record`]) or column by column
//! ([`Mf4Reader::next_batch`]): the whole records in the cursor's buffer
//! are then decoded in one loop, with no call per record.
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

use std::io::BufRead;

mod columns;
mod conversion;
mod cursor;
mod format;
mod layout;
mod plain;
mod source;

use cursor::*;
use format::*;
use layout::*;
use source::*;

pub use format::{
    ERROR_FRAME_CLASS, MAX_DZ_BYTES, MAX_METADATA_BYTES, SIGNATURE, UNFINALIZED_SIGNATURE,
};

use super::batch::FrameBatch;
use super::record::{LogRecord, ParseError, Place, ReadError, TimeText};
use crate::frame::{Frame, IfaceName};

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

impl<R: BufRead> Mf4Reader<R> {
    pub fn new(input: R) -> Self {
        Mf4Reader {
            source: Source {
                input,
                kept: Vec::new(),
                pos: 0,
                keep_all: false,
                seen: Vec::new(),
                input_len: None,
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
        if !self.opened_and_not_finished()? {
            return Ok(None);
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

    /// Fills `batch` with the next frames up to `max` in all (see
    /// [`crate::log::LogReader::next_batch`]); `false` at the end.
    pub fn next_batch(&mut self, batch: &mut FrameBatch, max: usize) -> Result<bool, ReadError> {
        if !self.opened_and_not_finished()? {
            return Ok(false);
        }
        if let [cursor] = &mut self.cursors[..] {
            // One group: its records decoded straight into the columns.
            if cursor.done {
                self.finished = true;
                return Ok(false);
            }
            let source = &mut self.source;
            let more = cursor.next_batch(
                source,
                &mut self.inflation,
                self.start_ns,
                batch,
                max,
                &mut self.interfaces,
            )?;
            if !more {
                cursor.done = true;
                self.finished = true;
            }
            return Ok(more);
        }
        while batch.len() < max {
            match self.next_record()? {
                Some(record) => batch.push(&record.frame),
                None => return Ok(false),
            }
        }
        Ok(true)
    }

    /// Opens the file at the first call; `false` once it has ended.
    fn opened_and_not_finished(&mut self) -> Result<bool, ReadError> {
        if self.finished {
            return Ok(false);
        }
        if !self.opened {
            self.opened = true;
            if let Err(error) = self.open() {
                self.finished = true;
                return Err(error);
            }
        }
        Ok(true)
    }

    /// Tells the reader the input's length (a file's, from its metadata):
    /// a file whose groups are read side by side is then kept in memory
    /// in one allocation (`Source::keep_everything`).
    pub fn expect_len(&mut self, bytes: u64) {
        self.source.input_len = Some(bytes);
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
            timestamp_text: self.time_text.set(frame.timestamp_ns).as_bytes(),
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
        if read_side_by_side(&cursors) {
            source.keep_everything();
        }
        self.heads = vec![None; cursors.len()];
        self.cursors = cursors;
        Ok(())
    }
}

/// Several groups, or a group and its `##SD` signal data, are read side by
/// side: none can be streamed past. (A VLSD channel group's values are
/// read as the data group's own records pass, in one reading:
/// `Cursor::next_parts`.)
fn read_side_by_side(cursors: &[Cursor]) -> bool {
    cursors.len() > 1
        || cursors
            .iter()
            .flat_map(|c| c.signals.iter())
            .any(|signal| !signal.in_band || signal.in_order)
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
    fn nanoseconds_round_half_away_from_zero_as_f64_round() {
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            2.5,
            -2.5,
            0.49999999999999994,
            1e15 + 0.5,
        ];
        values.extend([
            4503599627370495.5,
            4503599627370497.0,
            9.1e18,
            -9.1e18,
            123456.789,
        ]);
        for value in values {
            assert_eq!(whole_ns(value), Some(value.round() as i64), "{value}");
        }
        for value in [f64::NAN, f64::INFINITY, 9.3e18, -9.3e18] {
            assert_eq!(whole_ns(value), None, "{value}");
        }
        let field = |byte, bit, bits| Field { byte, bit, bits };
        assert_eq!(field(0, 3, 0).read(&[0xFF; 16]), 0);
        assert_eq!(field(2, 7, 57).read(&[0xFF; 16]), (1 << 57) - 1);
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
