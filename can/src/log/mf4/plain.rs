//! Plain records: a data group whose CAN groups store every member as a
//! bit field, a constant or a field through a small table, DataBytes
//! fixed in the record and a float or integer master (what most loggers
//! write). Each member is then one load, a shift, a mask and an or, and
//! the data group's cursor decodes such a group's whole records in one
//! loop with no dispatch per member and a table from record id to layout.
//! Whatever that loop does not take as ordinary (an unknown record id, a
//! raw value no table has, a length past its bytes, a cut) it leaves to
//! the careful path, which decodes the record or names its error: the
//! two agree on every record the loop takes.

use super::format::E_FIELD_VALUE;
use super::layout::*;
use crate::frame::{CanId, FrameKind};
use crate::log::batch::FrameBatch;

/// A member as `(the 8 bytes from `byte` >> bit) & mask | constant`: a
/// bit field has no constant, a constant no mask.
#[derive(Clone, Debug)]
struct Lane {
    byte: usize,
    bit: u32,
    mask: u64,
    constant: u64,
    /// A field's value through a conversion, by raw value (the raw value
    /// is below the table's length).
    table: Option<Box<[Option<u64>]>>,
}

impl Lane {
    const ZERO: Lane = Lane::constant(0);

    const fn constant(value: u64) -> Self {
        Lane {
            byte: 0,
            bit: 0,
            mask: 0,
            constant: value,
            table: None,
        }
    }

    /// A member as a lane of records of `size` bytes; `None` for one that
    /// needs more (a conversion per value, the record's index) or a field
    /// past the record or 64 bits.
    fn of(member: &Member, size: usize) -> Option<Self> {
        let bits = |field: &Field| {
            let end = field.byte + (field.bit + field.bits).div_ceil(8) as usize;
            (field.bit + field.bits <= 64 && field.bits > 0 && end <= size && field.byte < 64).then(
                || Lane {
                    byte: field.byte,
                    bit: field.bit,
                    mask: u64::MAX >> (64 - field.bits),
                    constant: 0,
                    table: None,
                },
            )
        };
        match member {
            Member::Bits(field) => bits(field),
            Member::Constant(value) => Some(Lane::constant(*value)),
            Member::Table { field, values } => Some(Lane {
                table: Some(values.clone()),
                ..bits(field)?
            }),
            Member::Converted { .. } | Member::Index(_) => None,
        }
    }

    /// The value in `window`, a record's first bytes and more; `None`
    /// where the table has no value.
    #[inline(always)]
    fn value(&self, window: &Window) -> Option<u64> {
        // `byte` is below 64 (checked when made): the load needs no
        // bounds check.
        let at = self.byte % 64;
        let mut word = [0u8; 8];
        word.copy_from_slice(&window[at..at + 8]);
        let raw = (u64::from_le_bytes(word) >> self.bit) & self.mask | self.constant;
        match &self.table {
            None => Some(raw),
            Some(values) => values.get(raw as usize).copied().flatten(),
        }
    }
}

/// The bytes a record's lanes read: the record and what follows it in
/// the buffer, 8 bytes past the last lane's first byte.
type Window = [u8; 72];

/// A plain CAN data-frame group's record, as lanes.
#[derive(Clone, Debug)]
struct PlainRecord {
    time: Time,
    channel: Lane,
    id: Lane,
    /// `None`: bit 31 of the id says it.
    ide: Option<Lane>,
    dlc: Lane,
    /// `None`: the length follows from the DLC.
    data_length: Option<Lane>,
    edl: Lane,
    brs: Lane,
    esi: Lane,
    dir: Option<Lane>,
    /// DataBytes' place in the record.
    bytes_at: usize,
    bytes_len: usize,
}

impl PlainRecord {
    fn of(size: usize, can: &CanLayout) -> Option<Self> {
        if can.frame_type != FrameType::Data {
            return None;
        }
        let time_fits = |byte: usize, bytes: usize| byte + bytes <= size;
        match can.time.kind {
            TimeKind::Float { bytes, .. } if time_fits(can.time.byte, bytes) => {}
            TimeKind::Integer { field, .. } if Lane::of(&Member::Bits(field), size).is_some() => {}
            _ => return None,
        }
        let lane = |member: &Option<Member>| match member {
            None => Some(None),
            Some(member) => Lane::of(member, size).map(Some),
        };
        let (bytes_at, bytes_len) = match can.data_bytes {
            Some(Bytes::Fixed { at, len }) if at + len <= size => (at, len),
            None => (0, 0),
            _ => return None,
        };
        Some(PlainRecord {
            time: can.time,
            channel: lane(&can.channel)?.unwrap_or(Lane::ZERO),
            id: lane(&can.id)?.unwrap_or(Lane::ZERO),
            ide: lane(&can.ide)?,
            dlc: lane(&can.dlc)?.unwrap_or(Lane::ZERO),
            data_length: lane(&can.data_length)?,
            edl: lane(&can.edl)?.unwrap_or(Lane::ZERO),
            brs: lane(&can.brs)?.unwrap_or(Lane::ZERO),
            esi: lane(&can.esi)?.unwrap_or(Lane::ZERO),
            dir: lane(&can.dir)?,
            bytes_at,
            bytes_len,
        })
    }

    /// The frame of the record at the start of `rest` (the buffer from the
    /// record on); `None` where the careful path must look at it.
    #[inline(always)]
    fn frame<'a>(&self, rest: &'a [u8], start_ns: i64) -> Option<FrameParts<'a>> {
        // The last records of the buffer: the careful path.
        let window: &Window = rest.get(..72)?.try_into().ok()?;
        // The index is read by no plain member or master.
        let timestamp_ns = time_ns(rest, &self.time, 0, start_ns)?;
        let raw_id = self.id.value(window)?;
        let extended = match &self.ide {
            Some(ide) => ide.value(window)? != 0,
            None => raw_id & 0x8000_0000 != 0,
        };
        let dlc = self.dlc.value(window)?.min(15) as u8;
        let data_length = match &self.data_length {
            Some(lane) => Some(lane.value(window)?),
            None => None,
        };
        let bytes = rest.get(self.bytes_at..self.bytes_at + self.bytes_len)?;
        let fd = self.edl.value(window)? != 0;
        let flag = |lane: &Lane| {
            lane.value(window)
                .map(|value| value != 0)
                .ok_or(E_FIELD_VALUE)
        };
        let flags = || Ok((flag(&self.brs)?, flag(&self.esi)?));
        let (id, kind, payload): (CanId, FrameKind, &[u8]) = data_frame(
            (raw_id & 0x1FFF_FFFF) as u32,
            extended,
            dlc,
            fd,
            data_length,
            bytes,
            flags,
        )
        .ok()?;
        let direction = match &self.dir {
            Some(dir) => Some(direction(dir.value(window)?)),
            None => None,
        };
        Some(FrameParts {
            timestamp_ns,
            channel: self.channel.value(window)?,
            id,
            kind,
            direction,
            payload,
        })
    }
}

/// A plain data group: each record id's layout, as the loop reads it.
#[derive(Debug)]
pub(super) struct PlainGroup {
    /// By the record's first byte (its id; 0 without ids): an index into
    /// `records`, `u8::MAX` for an id the group does not have.
    by_id: Box<[u8; 256]>,
    /// Each layout's record size and, for a CAN group, its lanes (`None`:
    /// records the loop passes over).
    records: Vec<(usize, Option<PlainRecord>)>,
}

impl PlainGroup {
    /// The group of these layouts, if every one is plain and its record
    /// ids are one byte or none.
    pub(super) fn of(record_id_bytes: usize, layouts: &[(u64, Layout)]) -> Option<Self> {
        if record_id_bytes > 1 || layouts.is_empty() || layouts.len() >= usize::from(u8::MAX) {
            return None;
        }
        let mut by_id = Box::new([u8::MAX; 256]);
        let mut records = Vec::with_capacity(layouts.len());
        for (index, (id, layout)) in layouts.iter().enumerate() {
            let record = match layout {
                Layout::Skip(size) => (*size, None),
                Layout::Can(size, can) => (*size, Some(PlainRecord::of(*size, can)?)),
                Layout::Vlsd => return None,
            };
            if record.0 == 0 {
                return None;
            }
            records.push(record);
            match record_id_bytes {
                0 => by_id.fill(0),
                _ => *by_id.get_mut(usize::try_from(*id).ok()?)? = index as u8,
            }
        }
        Some(PlainGroup { by_id, records })
    }
}

impl PlainGroup {
    /// Decodes the whole records in `buf` from `pos` on into `batch` (up
    /// to `max` frames), with record ids of `id_bytes`, stopping before
    /// one that is not whole or not ordinary (see the module's doc).
    /// Returns where it stopped and the records it read.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn scan(
        &self,
        buf: &[u8],
        id_bytes: usize,
        mut pos: usize,
        batch: &mut FrameBatch,
        max: usize,
        start_ns: i64,
        mut interface_of: impl FnMut(u64, &mut FrameBatch) -> Option<u16>,
    ) -> (usize, u64) {
        let mut records = 0u64;
        while batch.len() < max && pos < buf.len() {
            let slot = self.by_id[usize::from(buf[pos])];
            let Some((size, record)) = self.records.get(usize::from(slot)) else {
                break;
            };
            let body = pos + id_bytes;
            if body + size > buf.len() {
                break;
            }
            if let Some(record) = record {
                let rest = &buf[body..];
                let Some(parts) = record.frame(rest, start_ns) else {
                    break;
                };
                let Some(interface) = interface_of(parts.channel, batch) else {
                    break;
                };
                parts.push_onto(batch, interface);
            }
            pos = body + size;
            records += 1;
        }
        (pos, records)
    }
}
