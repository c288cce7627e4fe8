//! The input and the part of it that is kept: metadata blocks read by
//! offset, data streamed past once they are no longer needed (see the
//! module doc of [`super`]), and the little-endian readers every block
//! needs.

use std::io::{self, BufRead, Read};

use super::format::*;
use crate::log::record::{ParseError, Place, ReadError};

/// The input and the bytes of it that are kept.
pub(super) struct Source<R> {
    pub(super) input: R,
    /// Bytes `0..kept.len()` of the file.
    pub(super) kept: Vec<u8>,
    /// File offset of the next input byte: `kept.len()` until data streams.
    pub(super) pos: u64,
    /// Every data block must stay in `kept` (several groups read at once).
    pub(super) keep_all: bool,
    /// The offset of every block read as metadata.
    pub(super) seen: Vec<u64>,
    /// The input's length in bytes, if its opener knows it.
    pub(super) input_len: Option<u64>,
}

/// A metadata block in `kept`.
#[derive(Clone, Copy)]
pub(super) struct Block {
    pub(super) offset: u64,
    pub(super) id: [u8; 4],
    pub(super) links: usize,
    pub(super) len: usize,
}

impl Block {
    pub(super) fn link(&self, kept: &[u8], index: usize) -> u64 {
        if index >= self.links {
            return 0;
        }
        u64_at(kept, self.offset as usize + 24 + 8 * index).unwrap_or(0)
    }

    pub(super) fn data<'a>(&self, kept: &'a [u8]) -> &'a [u8] {
        let start = self.offset as usize + 24 + 8 * self.links;
        kept.get(start..self.offset as usize + self.len)
            .unwrap_or(&[])
    }
}

impl<R: BufRead> Source<R> {
    /// Keeps every data block read from now on (several groups are read
    /// side by side), in one allocation where the input's length is
    /// known: not in one that doubles as it grows, which copies what was
    /// read each time and touches twice the memory.
    pub(super) fn keep_everything(&mut self) {
        self.keep_all = true;
        self.room_for_all();
    }

    /// Room in `kept` for the whole input, if its length is known.
    fn room_for_all(&mut self) {
        if let Some(len) = self.input_len {
            // Only room: a length the input does not have costs no memory
            // touched, and one the allocator refuses is grown to as read.
            let len = usize::try_from(len).unwrap_or(usize::MAX);
            let _ = self
                .kept
                .try_reserve_exact(len.saturating_sub(self.kept.len()));
        }
    }

    /// Makes bytes `..end` readable in `kept`; `false` when the file ends
    /// first or they were streamed past.
    pub(super) fn keep_to(&mut self, end: u64) -> io::Result<bool> {
        let have = self.kept.len() as u64;
        if end <= have {
            return Ok(true);
        }
        if self.pos != have {
            return Ok(false);
        }
        let want = end - have;
        if end > self.kept.capacity() as u64 {
            // Metadata after the data (as asammdf writes it) keeps the
            // whole file: in one allocation where its length is known.
            self.room_for_all();
        }
        // Grows only as bytes arrive: bounded by the input, not by `end`.
        let got = (&mut self.input).take(want).read_to_end(&mut self.kept)? as u64;
        self.pos += got;
        Ok(got == want)
    }

    /// The metadata block at `offset`, one of `ids`.
    pub(super) fn block(
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
    pub(super) fn append_available(
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
    pub(super) fn append(
        &mut self,
        at: u64,
        count: u64,
        out: &mut Vec<u8>,
    ) -> Result<(), &'static str> {
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
            // Read into the vector's spare room: no zeroing first.
            out.reserve(step as usize);
            match (&mut self.input).take(step).read_to_end(out) {
                Ok(read) if read as u64 == step => {}
                _ => {
                    out.truncate(before);
                    return Err(E_TRUNCATED);
                }
            }
            self.pos += step;
            count -= step;
        }
        Ok(())
    }
}
