//! A data group's frames column by column ([`Cursor::next_batch`]): the
//! whole records in the cursor's buffer decoded in one loop into a
//! [`FrameBatch`], with no call per record; whatever needs more (a block's
//! end, a cut, a VLSD value not in the buffer) is left to the one-record
//! path ([`Cursor::next_parts`]).

use std::io::BufRead;
use std::ops::Range;

use super::cursor::{record_id, Cursor, Inflation, MAX_VALUE_AHEAD};
use super::format::*;
use super::layout::*;
use super::source::*;
use crate::frame::IfaceName;
use crate::log::batch::FrameBatch;
use crate::log::record::ReadError;

impl Cursor {
    /// Fills `batch` with this group's next frames, up to `max` in all;
    /// `false` at the end of the group. After an error the frames before
    /// it are in `batch`.
    pub(super) fn next_batch<R: BufRead>(
        &mut self,
        source: &mut Source<R>,
        inflation: &mut Inflation,
        start_ns: i64,
        batch: &mut FrameBatch,
        max: usize,
        interfaces_seen: &mut Vec<IfaceName>,
    ) -> Result<bool, ReadError> {
        // Bus channels change rarely from frame to frame: the last one's
        // interface is kept, not looked up.
        let mut interfaces = Interfaces {
            known: Vec::new(),
            seen: interfaces_seen,
        };
        while batch.len() < max {
            // The whole records in `buf`, without a call each (plain ones
            // first, by the loop made for them); then one record the
            // careful way (a block's end, a cut, a VLSD value elsewhere,
            // an unknown record id).
            self.reserve(batch, max);
            if let Some(plain) = self.plain.as_deref_mut() {
                let (pos, records) = plain.scan(
                    &self.buf,
                    self.record_id_bytes,
                    self.start,
                    batch,
                    max,
                    start_ns,
                    |channel, batch| interfaces.index_of(channel, batch).ok(),
                );
                self.start = pos;
                self.records_read += records;
            }
            // After the plain loop, the record it stopped at (an error
            // frame, say), then the plain loop again.
            let careful_max = match self.plain {
                Some(_) => max.min(batch.len() + 1),
                None => max,
            };
            self.scan_batch(batch, careful_max, start_ns, &mut interfaces)?;
            if batch.len() >= max {
                break;
            }
            let Some((parts, line)) = self.next_parts(source, inflation, start_ns)? else {
                return Ok(false);
            };
            let interface = interfaces.index(parts.channel, batch, line)?;
            parts.push_onto(batch, interface);
        }
        Ok(true)
    }

    /// Room in `batch` for the frames of the whole records in `buf`: at
    /// most one per smallest record, and its bytes.
    fn reserve(&self, batch: &mut FrameBatch, max: usize) {
        let smallest = self
            .layouts
            .iter()
            // A VLSD record is its length and at least nothing.
            .map(|(_, layout)| layout.record_bytes().unwrap_or(4))
            .min()
            .unwrap_or(1);
        let bytes = self.buf.len().saturating_sub(self.start);
        let frames =
            (bytes / (self.record_id_bytes + smallest).max(1)).min(max.saturating_sub(batch.len()));
        batch.reserve(frames, bytes.min(frames * 64));
    }

    /// Decodes the whole records that are in `buf` into `batch` (up to
    /// `max` frames), stopping before one that needs more than `buf` holds:
    /// more bytes, a VLSD value not passed in it, an unknown record id.
    fn scan_batch(
        &mut self,
        batch: &mut FrameBatch,
        max: usize,
        start_ns: i64,
        interfaces: &mut Interfaces<'_>,
    ) -> Result<(), ReadError> {
        let id_bytes = self.record_id_bytes;
        let line = self.block_offset;
        let end = self.buf.len();
        let mut pos = self.start;
        self.vlsd_last.iter_mut().for_each(|last| *last = None);
        while batch.len() < max && pos + id_bytes <= end {
            let index = if id_bytes == 0 {
                0
            } else {
                let record_id = record_id(&self.buf[pos..], id_bytes);
                match self.layouts.iter().position(|(id, _)| *id == record_id) {
                    Some(index) => index,
                    None => break,
                }
            };
            let body = pos + id_bytes;
            let size = match self.layouts.get(index) {
                Some((_, Layout::Skip(size) | Layout::Can(size, _))) => *size,
                Some((_, Layout::Vlsd)) => match u32_at(&self.buf, body) {
                    Some(len) => 4 + len as usize,
                    None => break,
                },
                None => break,
            };
            if body + size > end {
                break;
            }
            let range = body..body + size;
            let Layout::Can(_, can) = &self.layouts[index].1 else {
                if matches!(self.layouts[index].1, Layout::Vlsd) {
                    let at = self.vlsd_offsets[index];
                    self.vlsd_offsets[index] += size as u64;
                    self.vlsd_last[index] = Some((at, range.clone()));
                }
                pos = range.end;
                self.records_read += 1;
                continue;
            };
            let record = &self.buf[range.clone()];
            let signal = match can.data_bytes {
                Some(Bytes::Vlsd { at, signal }) => {
                    let offset = u64_at(record, at).unwrap_or(u64::MAX);
                    let data = &self.signals[signal];
                    if !data.in_band || data.in_order {
                        break;
                    }
                    match &self.vlsd_last[data.group] {
                        Some((value_at, value)) if *value_at == offset => {
                            Some(&self.buf[value.start + 4..value.end])
                        }
                        // The last value passed before this scan (none
                        // in it: a value before the last is no value).
                        None if self.vlsd_kept[data.group].0 == offset => {
                            Some(&self.vlsd_kept[data.group].1[..])
                        }
                        _ => match self.value_in_buf(range.end, data.group, offset) {
                            Some(value) => Some(&self.buf[value]),
                            None => break,
                        },
                    }
                }
                _ => None,
            };
            let group_index = can.records;
            pos = range.end;
            self.records_read += 1;
            let decoded = decode(record, can, group_index, signal, start_ns)
                .and_then(|parts| Ok((interfaces.index_of(parts.channel, batch)?, parts)));
            if let Layout::Can(_, can) = &mut self.layouts[index].1 {
                can.records += 1;
            }
            match decoded {
                Ok((interface, parts)) => parts.push_onto(batch, interface),
                Err(expected) => {
                    self.start = pos;
                    return Err(parse(line, expected));
                }
            }
        }
        self.start = pos;
        self.keep_vlsd_values();
        Ok(())
    }

    /// The bytes of the value at `offset` of the VLSD group `group` in the
    /// whole records of `buf` from `from` on (its record comes after its
    /// frame's), without reading them.
    fn value_in_buf(&self, from: usize, group: usize, offset: u64) -> Option<Range<usize>> {
        let id_bytes = self.record_id_bytes;
        let mut value_at = self.vlsd_offsets[group];
        let mut pos = from;
        while pos + id_bytes <= self.buf.len() && pos - from < MAX_VALUE_AHEAD {
            let id = record_id(&self.buf[pos..], id_bytes);
            let index = match id_bytes {
                0 => 0,
                _ => self.layouts.iter().position(|(known, _)| *known == id)?,
            };
            let body = pos + id_bytes;
            let size = match &self.layouts.get(index)?.1 {
                Layout::Skip(size) | Layout::Can(size, _) => *size,
                Layout::Vlsd => 4 + u32_at(&self.buf, body)? as usize,
            };
            if body + size > self.buf.len() {
                return None;
            }
            if index == group {
                if value_at == offset {
                    return Some(body + 4..body + size);
                }
                value_at += size as u64;
                if value_at > offset {
                    return None;
                }
            }
            pos = body + size;
        }
        None
    }

    /// Copies each VLSD group's last value passed in `buf` out of it: the
    /// record that points to it may come after `buf` is refilled.
    pub(super) fn keep_vlsd_values(&mut self) {
        for (last, kept) in self.vlsd_last.iter_mut().zip(&mut self.vlsd_kept) {
            if let Some((at, range)) = last.take() {
                kept.0 = at;
                kept.1.clear();
                kept.1
                    .extend_from_slice(&self.buf[range.start + 4..range.end]);
            }
        }
    }
}

/// The interfaces of a batch's frames: each bus channel's index is kept,
/// not looked up per frame (a logger's buses interleave frame by frame),
/// and each new one is told to the reader.
pub(super) struct Interfaces<'a> {
    /// The bus channels met in this batch and their interface's index.
    known: Vec<(u64, u16)>,
    seen: &'a mut Vec<IfaceName>,
}

/// The bus channels one batch keeps indices of; more are looked up.
const KNOWN_CHANNELS: usize = 16;

impl Interfaces<'_> {
    /// The index in `batch.interfaces` of bus channel `channel`.
    #[inline(always)]
    fn index_of(&mut self, channel: u64, batch: &mut FrameBatch) -> Result<u16, &'static str> {
        if let Some(&(_, interface)) = self.known.iter().find(|(known, _)| *known == channel) {
            return Ok(interface);
        }
        let iface = channel_iface(channel)?;
        if !self.seen.contains(&iface) {
            self.seen.push(iface);
        }
        let interface = batch.interface_index(iface);
        if self.known.len() < KNOWN_CHANNELS {
            self.known.push((channel, interface));
        }
        Ok(interface)
    }

    fn index(&mut self, channel: u64, batch: &mut FrameBatch, line: u64) -> Result<u16, ReadError> {
        self.index_of(channel, batch)
            .map_err(|expected| parse(line, expected))
    }
}
