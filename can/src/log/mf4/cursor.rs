//! The data of a data group read record by record: its data blocks (`##DT`,
//! `##DZ` inflated on a second thread, `##DL`/`##HL` lists, an unfinalized
//! file's open-ended last block), the records of each channel group by
//! record id, and a VLSD channel's values ([`SignalData`]).

use std::io::{self, BufRead};
use std::ops::Range;

use super::format::*;
use super::layout::*;
use super::plain::PlainGroup;
use super::source::*;
use crate::frame::Frame;
use crate::log::inflate::{InflateJob, Inflater};
use crate::log::record::ReadError;

/// How `##DZ` blocks are inflated: each group reads the block after the one
/// it parses as soon as that one is read whole, and sends it to the
/// inflater's thread. With one group that is the next block in the file; with
/// several every block is kept (see the module doc), so reading ahead never
/// goes back in the stream.
pub(super) struct Inflation {
    /// Started at the first block read ahead (once).
    pub(super) inflater: Option<Inflater>,
    pub(super) tried_to_start: bool,
    /// Inflated blocks received while waiting for another group's, by
    /// their file offset.
    pub(super) received: Vec<(u64, InflateJob)>,
    /// Jobs to reuse: no allocation per block.
    pub(super) spare: Vec<InflateJob>,
}

impl Inflation {
    /// The inflated block at `at`, sent earlier; `None` if the thread stopped.
    pub(super) fn receive(&mut self, at: u64) -> Option<InflateJob> {
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
pub(super) enum DataBlock {
    Dt {
        len: u64,
    },
    /// Read, not inflated yet.
    Dz(InflateJob),
}

/// The block after the current one, read ahead.
pub(super) enum Ahead {
    Block(DataBlock),
    /// In the inflater's queue.
    Sent,
    Failed(&'static str),
}

/// The records of one data group.
pub(super) struct Cursor {
    pub(super) record_id_bytes: usize,
    pub(super) layouts: Vec<(u64, Layout)>,
    pub(super) blocks: Vec<u64>,
    pub(super) next_block: usize,
    /// File offset of the data block being read (error "lines").
    pub(super) block_offset: u64,
    /// The rest of the `##DT` being read: file offsets `next..end`.
    pub(super) dt_next: u64,
    pub(super) dt_end: u64,
    pub(super) buf: Vec<u8>,
    pub(super) start: usize,
    pub(super) done: bool,
    /// The next block (its file offset), read ahead.
    pub(super) ahead: Option<(u64, Ahead)>,
    /// The longest fixed-size record with its id: room kept before a
    /// block's records for one that began in the block before.
    pub(super) longest_record: usize,
    /// The last `##DT` block's length was never written (an unfinalized
    /// file's flag 0x04): it runs to the next block or the file's end.
    pub(super) open_ended: bool,
    /// Every block the metadata names, ascending: the one after an
    /// open-ended block is where it ends.
    pub(super) known_blocks: Vec<u64>,
    /// The block being read is the open-ended one.
    pub(super) in_open_ended_block: bool,
    /// Records read, of every group.
    pub(super) records_read: u64,
    /// What the reader should tell (a cut record).
    pub(super) notes: Vec<String>,
    /// The VLSD DataBytes channels' values, by the index in
    /// [`Bytes::Vlsd`].
    pub(super) signals: Vec<SignalData>,
    /// Per layout, a VLSD group's values passed so far: the offset of its
    /// next value in its stream.
    pub(super) vlsd_offsets: Vec<u64>,
    /// Per layout, a VLSD group's last value passed in this
    /// [`Cursor::scan_batch`]: its offset and bytes in `buf`.
    pub(super) vlsd_last: Vec<Option<(u64, Range<usize>)>>,
    /// Per layout, a VLSD group's last value passed before: its offset
    /// and a copy of its bytes (`u64::MAX`: none), for a frame whose
    /// record comes after a refill of `buf`.
    pub(super) vlsd_kept: Vec<(u64, Vec<u8>)>,
    /// A frame's record copied aside while its value is found ahead.
    pub(super) aside: Vec<u8>,
    /// The layouts as the plain records' loop reads them, if they are.
    pub(super) plain: Option<Box<PlainGroup>>,
}

impl Cursor {
    pub(super) fn new(
        record_id_bytes: usize,
        layouts: Vec<(u64, Layout)>,
        blocks: Vec<u64>,
    ) -> Self {
        let longest_record = record_id_bytes
            + layouts
                .iter()
                .filter_map(|(_, layout)| layout.record_bytes())
                .max()
                .unwrap_or(0);
        Cursor {
            record_id_bytes,
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
            vlsd_offsets: vec![0; layouts.len()],
            vlsd_last: vec![None; layouts.len()],
            vlsd_kept: vec![(u64::MAX, Vec::new()); layouts.len()],
            aside: Vec::new(),
            plain: PlainGroup::of(record_id_bytes, &layouts).map(Box::new),
            layouts,
        }
    }
}

/// The signal data a VLSD channel links to (`link`): a VLSD channel
/// group of its own data group (`cursor`'s), or `##SD` blocks.
pub(super) fn signal_data<R: BufRead>(
    source: &mut Source<R>,
    link: u64,
    cursor: &Cursor,
    group_offsets: &[u64],
    visited: &mut rustc_hash::FxHashSet<u64>,
    unlisted_after_list: bool,
) -> Result<SignalData, ReadError> {
    let reader = |cursor: Cursor, group: usize, in_band: bool| SignalData {
        cursor,
        group,
        in_band,
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
            true,
        ));
    }
    let mut blocks = Vec::new();
    data_blocks(source, link, &mut blocks, visited, unlisted_after_list)?;
    Ok(reader(
        Cursor::new(0, vec![(0, Layout::Vlsd)], blocks),
        0,
        false,
    ))
}

/// The data blocks under `at` (a data block, or a list of them), in order.
/// With `unlisted_after_list` (an unfinalized file's flag 0x10: the last
/// `##DL` was not updated), the data blocks that follow the last list in
/// the file, one after the other, are its too (as asammdf finalizes it).
pub(super) fn data_blocks<R: BufRead>(
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
pub(super) fn data_blocks_listed<R: BufRead>(
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

impl Cursor {
    /// Makes `need` bytes available at `buf[start..]`; `false` at the end of
    /// the group's data.
    pub(super) fn fill<R: BufRead>(
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
    pub(super) fn read_ahead<R: BufRead>(
        &mut self,
        source: &mut Source<R>,
        inflation: &mut Inflation,
    ) {
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

    pub(super) fn fail(&mut self, expected: &'static str) -> ReadError {
        if expected == E_TRUNCATED || expected == E_ORDER {
            self.done = true;
        }
        parse(self.block_offset, expected)
    }

    /// Appends an inflated `##DZ` block's records to `buf`: its buffer
    /// becomes `buf`, with the start of a record begun in the block before
    /// copied into its headroom.
    pub(super) fn take_inflated(
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
    pub(super) fn next_record<R: BufRead>(
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
        let record_id = record_id(&self.buf[self.start..], id_bytes);
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
    pub(super) fn cut<T>(&mut self, need: usize) -> Result<Option<T>, ReadError> {
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
    pub(super) fn next_frame<R: BufRead>(
        &mut self,
        source: &mut Source<R>,
        inflation: &mut Inflation,
        start_ns: i64,
    ) -> Result<Option<(Frame, u64)>, ReadError> {
        let Some((parts, line)) = self.next_parts(source, inflation, start_ns)? else {
            return Ok(None);
        };
        let iface = channel_iface(parts.channel).map_err(|expected| parse(line, expected))?;
        let mut frame = Frame::from_parts(
            parts.timestamp_ns,
            iface,
            parts.id,
            parts.kind,
            parts.payload,
        );
        frame.direction = parts.direction;
        Ok(Some((frame, line)))
    }

    /// The fields of this group's next CAN frame and its "line".
    #[inline]
    pub(super) fn next_parts<R: BufRead>(
        &mut self,
        source: &mut Source<R>,
        inflation: &mut Inflation,
        start_ns: i64,
    ) -> Result<Option<(FrameParts<'_>, u64)>, ReadError> {
        loop {
            let Some((index, range, line)) = self.next_record(source, inflation)? else {
                return Ok(None);
            };
            let data_bytes = match &self.layouts[index].1 {
                Layout::Can(_, can) => can.data_bytes,
                Layout::Vlsd => {
                    let at = self.vlsd_offsets[index];
                    self.vlsd_offsets[index] += range.len() as u64;
                    self.vlsd_last[index] = Some((at, range));
                    self.keep_vlsd_values();
                    continue;
                }
                Layout::Skip(_) => continue,
            };
            // A value in the group's own records that has not passed yet
            // comes after its frame's record: found ahead, the record
            // copied aside first (finding it may move `buf`).
            let mut record_aside = false;
            if let Some(Bytes::Vlsd { at, signal }) = data_bytes {
                let data = &self.signals[signal];
                let group = data.group;
                let offset = u64_at(&self.buf[range.clone()], at).unwrap_or(u64::MAX);
                if data.in_band && !data.in_order && self.vlsd_kept[group].0 != offset {
                    self.aside.clear();
                    self.aside.extend_from_slice(&self.buf[range.clone()]);
                    record_aside = true;
                    if !self.value_ahead(group, offset, source, inflation)? {
                        if let Layout::Can(_, can) = &mut self.layouts[index].1 {
                            can.records += 1;
                        }
                        return Err(parse(line, E_VLSD));
                    }
                }
            }
            let Layout::Can(_, can) = &mut self.layouts[index].1 else {
                continue;
            };
            let record = if record_aside {
                &self.aside[..]
            } else {
                &self.buf[range]
            };
            let group_index = can.records;
            can.records += 1;
            let signal = match can.data_bytes {
                Some(Bytes::Vlsd { signal, .. })
                    if self.signals[signal].in_band && !self.signals[signal].in_order =>
                {
                    // Passed already, or found ahead: the group's records
                    // are not read a second time.
                    Some(&self.vlsd_kept[self.signals[signal].group].1[..])
                }
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
                .map(|parts| Some((parts, line)))
                .map_err(|expected| parse(line, expected));
        }
    }

    /// Finds the value at `offset` of the VLSD group `group` among the
    /// records after `start`, which stay unread, and keeps it in
    /// `vlsd_kept`; `false` where the group's values pass `offset`, the
    /// data ends or [`MAX_VALUE_AHEAD`] bytes come first.
    fn value_ahead<R: BufRead>(
        &mut self,
        group: usize,
        offset: u64,
        source: &mut Source<R>,
        inflation: &mut Inflation,
    ) -> Result<bool, ReadError> {
        let id_bytes = self.record_id_bytes;
        // From `start`: filling may move the bytes.
        let mut ahead = 0;
        let mut value_at = self.vlsd_offsets[group];
        while ahead < MAX_VALUE_AHEAD {
            if !self.fill(ahead + id_bytes.max(1), source, inflation)? {
                return Ok(false);
            }
            let id = record_id(&self.buf[self.start + ahead..], id_bytes);
            let index = match id_bytes {
                0 => 0,
                _ => match self.layouts.iter().position(|(known, _)| *known == id) {
                    Some(index) => index,
                    None => return Ok(false),
                },
            };
            let size = match self.layouts.get(index) {
                Some((_, Layout::Skip(size) | Layout::Can(size, _))) => *size,
                Some((_, Layout::Vlsd)) => {
                    if !self.fill(ahead + id_bytes + 4, source, inflation)? {
                        return Ok(false);
                    }
                    4 + u32_at(&self.buf, self.start + ahead + id_bytes).unwrap_or(0) as usize
                }
                None => return Ok(false),
            };
            if !self.fill(ahead + id_bytes + size, source, inflation)? {
                return Ok(false);
            }
            if index == group {
                if value_at == offset {
                    let body = self.start + ahead + id_bytes;
                    let kept = &mut self.vlsd_kept[group];
                    kept.0 = offset;
                    kept.1.clear();
                    kept.1.extend_from_slice(&self.buf[body + 4..body + size]);
                    return Ok(true);
                }
                value_at += size as u64;
                if value_at > offset {
                    return Ok(false);
                }
            }
            ahead += id_bytes + size;
        }
        Ok(false)
    }
}

/// How far [`Cursor::value_ahead`] looks for a value that comes after its
/// frame's record (loggers write it right after).
pub(super) const MAX_VALUE_AHEAD: usize = 1 << 20;

/// The record id of `id_bytes` (0, 1, 2, 4 or 8) that `record` starts with.
#[inline]
pub(super) fn record_id(record: &[u8], id_bytes: usize) -> u64 {
    // Each width its own load: a copy of a variable length into a word
    // and its load stalled the reading of unsorted groups.
    match id_bytes {
        1 => record.first().map_or(0, |&b| u64::from(b)),
        2 => u16_at(record, 0).map_or(0, u64::from),
        4 => u32_at(record, 0).map_or(0, u64::from),
        8 => u64_at(record, 0).unwrap_or(0),
        _ => 0,
    }
}

/// The values of one VLSD channel: a stream of `u32 length, bytes`, each
/// value at its offset from the stream's start. The stream is the
/// channel's `##SD` blocks (plain, zipped or listed), or the records of a
/// VLSD channel group in the same data group; a cursor of its own reads it,
/// so a value may come before or after the record that points to it.
pub(super) struct SignalData {
    pub(super) cursor: Cursor,
    /// The VLSD group's index in the cursor's layouts.
    pub(super) group: usize,
    /// The values are records of the data group that points to them (a
    /// VLSD channel group), not `##SD` blocks: the data group's own cursor
    /// passes them too ([`Cursor::scan_batch`]).
    pub(super) in_band: bool,
    /// The offset of the next value.
    pub(super) next_offset: u64,
    /// The last value read: its offset and bytes (in the cursor's `buf`).
    pub(super) last: Option<(u64, Range<usize>)>,
    /// The offsets were never written (an unfinalized file's flag 0x40):
    /// the values pair with the records in order.
    pub(super) in_order: bool,
}

impl SignalData {
    /// The value at `offset`: offsets grow from record to record (a value
    /// may be read twice).
    pub(super) fn value_at<R: BufRead>(
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
pub(super) fn read_block<R: BufRead>(
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
