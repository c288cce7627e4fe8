//! Frames column by column: what a reader fills many frames at a time
//! ([`super::LogReader::next_batch`]), where one [`Frame`] per call would
//! spend more on moving the frame than on reading it.
//!
//! Each column holds one field of every frame, in the order read; a frame's
//! payload is a slice of one byte buffer. The layout is Arrow's (a value
//! column per field, a byte buffer with offsets), so a batch becomes a
//! table without a per-frame step.

use crate::frame::{CanId, Direction, Frame, FrameFields, FrameKind, IfaceName};

/// Frames read from a log, one column per field.
#[derive(Clone, Debug, Default)]
pub struct FrameBatch {
    /// As [`Frame::timestamp_ns`].
    pub timestamp_ns: Vec<i64>,
    /// Each frame's interface, an index into [`FrameBatch::interfaces`].
    pub interface: Vec<u16>,
    /// The interfaces seen, in the order first seen. They stay on
    /// [`FrameBatch::clear`], so an index means the same interface in every
    /// batch of a reader.
    pub interfaces: Vec<IfaceName>,
    pub id: Vec<CanId>,
    pub kind: Vec<FrameKind>,
    pub direction: Vec<Option<Direction>>,
    /// Where each frame's payload ends in [`FrameBatch::payload`]; it
    /// starts where the frame before's ends.
    pub payload_end: Vec<u32>,
    pub payload: Vec<u8>,
}

/// The most frames one batch is filled with, whatever is asked: 64 bytes a
/// frame at most keeps the payload's offsets far inside `u32`.
pub const MAX_BATCH_FRAMES: usize = 1 << 20;

impl FrameBatch {
    pub fn len(&self) -> usize {
        self.timestamp_ns.len()
    }

    pub fn is_empty(&self) -> bool {
        self.timestamp_ns.is_empty()
    }

    /// Empties the columns (keeping their memory and the interfaces).
    pub fn clear(&mut self) {
        self.timestamp_ns.clear();
        self.interface.clear();
        self.id.clear();
        self.kind.clear();
        self.direction.clear();
        self.payload_end.clear();
        self.payload.clear();
    }

    /// The index of `iface` in [`FrameBatch::interfaces`], added if new.
    pub fn interface_index(&mut self, iface: IfaceName) -> u16 {
        match self.interfaces.iter().position(|known| *known == iface) {
            Some(index) => index as u16,
            None => {
                self.interfaces.push(iface);
                (self.interfaces.len() - 1) as u16
            }
        }
    }

    pub fn push(&mut self, frame: &Frame) {
        let interface = self.interface_index(frame.iface);
        self.push_on(frame, interface);
    }

    /// Appends `frame` as received on interface `interface`, an index the
    /// caller had from [`FrameBatch::interface_index`].
    #[inline]
    pub(crate) fn push_on(&mut self, frame: &Frame, interface: u16) {
        self.push_parts(
            frame.timestamp_ns,
            interface,
            frame.id,
            frame.kind,
            frame.direction,
            frame.payload(),
        );
    }

    /// Room for `frames` more frames and `payload_bytes` more payload
    /// bytes, so that a reader's loop does not grow the columns one by one.
    pub(crate) fn reserve(&mut self, frames: usize, payload_bytes: usize) {
        self.timestamp_ns.reserve(frames);
        self.interface.reserve(frames);
        self.id.reserve(frames);
        self.kind.reserve(frames);
        self.direction.reserve(frames);
        self.payload_end.reserve(frames);
        self.payload.reserve(payload_bytes);
    }

    /// Appends one frame's fields; `payload` is at most 64 bytes (a
    /// reader's frame is checked before).
    #[inline(always)]
    pub(crate) fn push_parts(
        &mut self,
        timestamp_ns: i64,
        interface: u16,
        id: CanId,
        kind: FrameKind,
        direction: Option<Direction>,
        payload: &[u8],
    ) {
        self.timestamp_ns.push(timestamp_ns);
        self.interface.push(interface);
        self.id.push(id);
        self.kind.push(kind);
        self.direction.push(direction);
        self.push_payload(payload);
    }

    /// Appends the first `len` of `eight` bytes as one frame's payload: a
    /// copy of a known length and a cut, where a copy of any other
    /// length is a call to memcpy.
    #[inline(always)]
    pub(crate) fn push_payload_of_eight(&mut self, eight: &[u8; 8], len: usize) {
        let start = self.payload.len();
        self.payload.extend_from_slice(eight);
        self.payload.truncate(start + len);
        self.payload_end.push(self.payload.len() as u32);
    }

    /// Appends one frame's payload (at most 64 bytes), the other columns
    /// being filled by the caller.
    #[inline(always)]
    pub(crate) fn push_payload(&mut self, payload: &[u8]) {
        // Most frames carry 8 bytes: a copy of a known length is one
        // store, where any other length is a call to memcpy.
        match <&[u8; 8]>::try_from(payload) {
            Ok(eight) => self.payload.extend_from_slice(eight),
            Err(_) => self.payload.extend_from_slice(payload),
        }
        self.payload_end.push(self.payload.len() as u32);
    }

    /// The payload of frame `index`.
    #[inline]
    pub fn payload(&self, index: usize) -> &[u8] {
        let start = match index {
            0 => 0,
            _ => self.payload_end[index - 1] as usize,
        };
        &self.payload[start..self.payload_end[index] as usize]
    }

    /// What a decoder reads of frame `index`, where it lies.
    #[inline]
    pub fn fields(&self, index: usize) -> FrameFields<'_> {
        FrameFields {
            timestamp_ns: self.timestamp_ns[index],
            id: self.id[index],
            kind: self.kind[index],
            payload: self.payload(index),
        }
    }

    /// Frame `index` as one [`Frame`].
    pub fn frame(&self, index: usize) -> Frame {
        let mut frame = Frame::from_parts(
            self.timestamp_ns[index],
            self.interfaces[usize::from(self.interface[index])],
            self.id[index],
            self.kind[index],
            self.payload(index),
        );
        frame.direction = self.direction[index];
        frame
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::fd_flags;

    #[test]
    fn a_frame_comes_back_as_it_went_in() {
        let can1 = IfaceName::new("can1").unwrap();
        let can2 = IfaceName::new("can2").unwrap();
        let mut remote = Frame::remote(3, can1, CanId::Standard(0x7FF), 8).unwrap();
        remote.set_len8_dlc(13).unwrap();
        let mut fd = Frame::fd(
            2,
            can2,
            CanId::Extended(0x1234),
            fd_flags(true, false),
            &[7; 48],
        )
        .unwrap();
        fd.direction = Some(Direction::Transmitted);
        let frames = [
            Frame::data(1, can1, CanId::Standard(0x123), &[1, 2, 3]).unwrap(),
            fd,
            remote,
            Frame::error(4, can2, 0x80, &[]).unwrap(),
        ];
        let mut batch = FrameBatch::default();
        for frame in &frames {
            batch.push(frame);
        }
        assert_eq!(batch.len(), 4);
        assert_eq!(batch.interfaces, [can1, can2]);
        for (index, frame) in frames.iter().enumerate() {
            assert_eq!(batch.frame(index), *frame);
            assert_eq!(batch.fields(index), frame.fields());
        }
        batch.clear();
        assert!(batch.is_empty());
        assert_eq!(batch.interface_index(can2), 1);
    }
}
