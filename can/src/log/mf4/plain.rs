//! Plain records: a data group whose CAN groups store every member as a
//! bit field, a constant or a field through a small table, DataBytes
//! fixed in the record and a float or integer master (what most loggers
//! write). Each member is then one load, a shift, a mask and an or, and
//! the data group's cursor decodes such a group's whole records in runs,
//! column by column, with no dispatch per member and a table from record
//! id to layout.
//! Whatever that loop does not take as ordinary (an unknown record id, a
//! raw value no table has, a length past its bytes, a cut) it leaves to
//! the careful path, which decodes the record or names its error: the
//! two agree on every record the loop takes.

use super::format::E_FIELD_VALUE;
use super::layout::*;
use crate::frame::{CanId, Direction, FrameKind};
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
    /// past the record, 64 bits or [`LANE_BYTES`].
    fn of(member: &Member, size: usize) -> Option<Self> {
        let bits = |field: &Field| {
            let end = field.byte + (field.bit + field.bits).div_ceil(8) as usize;
            (field.bit + field.bits <= 64
                && field.bits > 0
                && end <= size
                && field.byte < LANE_BYTES)
                .then(|| Lane {
                    byte: field.byte,
                    bit: field.bit,
                    mask: u64::MAX >> (64 - field.bits),
                    constant: 0,
                    table: None,
                })
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
        // `byte` is below LANE_BYTES (checked when made): the load needs
        // no bounds check.
        let at = self.byte % LANE_BYTES;
        let mut word = [0u8; 8];
        word.copy_from_slice(&window[at..at + 8]);
        let raw = (u64::from_le_bytes(word) >> self.bit) & self.mask | self.constant;
        match &self.table {
            None => Some(raw),
            Some(values) => values.get(raw as usize).copied().flatten(),
        }
    }
}

/// A lane's first byte is below this: python-can's records (and
/// loggers' like them) have their Dir and FD flags after 64 data bytes,
/// at bytes 80-83.
const LANE_BYTES: usize = 128;

/// The bytes a record's lanes read: the record and what follows it in
/// the buffer, 8 bytes past the last lane's first byte.
type Window = [u8; LANE_BYTES + 8];

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

    /// The frame but its time of the record at the start of `rest` (the
    /// buffer from the record on, at least a window); `None` where the
    /// careful path must look at it.
    #[inline(always)]
    fn shape(&self, rest: &[u8]) -> Option<Shape> {
        let window: &Window = rest.get(..size_of::<Window>())?.try_into().ok()?;
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
        let (id, kind, payload) = data_frame(
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
        Some(Shape {
            channel: self.channel.value(window)?,
            id,
            kind,
            direction,
            payload_len: payload.len() as u8,
        })
    }
}

/// The most records one run of [`PlainGroup::scan`] takes: its scratch
/// stays in the nearest caches and needs no fresh memory.
const RUN: usize = 2048;

/// A plain data group: each record id's layout, as the loop reads it.
#[derive(Debug)]
pub(super) struct PlainGroup {
    /// By the record's first byte (its id; 0 without ids): an index into
    /// `records`, `u8::MAX` for an id the group does not have.
    by_id: Box<[u8; 256]>,
    /// Each layout's record size and, for a CAN group, its index in
    /// `cans` (`None`: records the loop passes over).
    records: Vec<(usize, Option<u8>)>,
    cans: Vec<PlainRecord>,
    /// The records' size, if they all have one.
    one_size: Option<usize>,
    /// Scratch of one scan: each CAN record's body in the buffer and its
    /// index in `cans`, then its frame.
    places: Vec<(usize, u8)>,
    frames: Vec<Option<Shape>>,
    interfaces: Vec<u16>,
}

/// A record's frame but its time and payload bytes.
#[derive(Clone, Copy, Debug)]
struct Shape {
    channel: u64,
    id: CanId,
    kind: FrameKind,
    direction: Option<Direction>,
    payload_len: u8,
}

impl Shape {
    /// A stand-in the columns never take: every frame before a run's cut
    /// is whole.
    const NONE: Shape = Shape {
        channel: 0,
        id: CanId::Standard(0),
        kind: FrameKind::Data { len8_dlc: None },
        direction: None,
        payload_len: 0,
    };
}

impl PlainGroup {
    /// The group of these layouts, if its record ids are one byte or none
    /// and its data frames' records are plain. Its other CAN groups' records
    /// (error and remote frames, which python-can writes beside the data
    /// frames, and are rare in a log) stop the loop and go the careful way,
    /// as an unknown record id does.
    pub(super) fn of(record_id_bytes: usize, layouts: &[(u64, Layout)]) -> Option<Self> {
        if record_id_bytes > 1 || layouts.is_empty() || layouts.len() >= usize::from(u8::MAX) {
            return None;
        }
        let mut by_id = Box::new([u8::MAX; 256]);
        let mut records = Vec::with_capacity(layouts.len());
        let mut cans = Vec::new();
        for (id, layout) in layouts {
            let record = match layout {
                Layout::Skip(size) => (*size, None),
                Layout::Can(size, can) => match PlainRecord::of(*size, can) {
                    Some(plain) => {
                        cans.push(plain);
                        (*size, Some((cans.len() - 1) as u8))
                    }
                    None if can.frame_type != FrameType::Data && record_id_bytes == 1 => continue,
                    None => return None,
                },
                Layout::Vlsd => return None,
            };
            if record.0 == 0 {
                return None;
            }
            match record_id_bytes {
                0 => by_id.fill(0),
                _ => *by_id.get_mut(usize::try_from(*id).ok()?)? = records.len() as u8,
            }
            records.push(record);
        }
        if cans.is_empty() {
            return None;
        }
        let one_size = Some(records[0].0).filter(|size| records.iter().all(|r| r.0 == *size));
        Some(PlainGroup {
            one_size,
            by_id,
            records,
            cans,
            places: Vec::new(),
            frames: Vec::new(),
            interfaces: Vec::new(),
        })
    }

    /// Decodes the whole records in `buf` from `pos` on into `batch` (up
    /// to `max` frames), with record ids of `id_bytes`, stopping before
    /// one that is not whole or not ordinary (see the module's doc).
    /// Returns where it stopped and the records it read.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn scan(
        &mut self,
        buf: &[u8],
        id_bytes: usize,
        mut pos: usize,
        batch: &mut FrameBatch,
        max: usize,
        start_ns: i64,
        mut interface_of: impl FnMut(u64, &mut FrameBatch) -> Option<u16>,
    ) -> (usize, u64) {
        let mut records = 0;
        loop {
            let room = max.saturating_sub(batch.len()).min(RUN);
            let (end, passed, go_on) =
                self.run(buf, id_bytes, pos, batch, room, start_ns, &mut interface_of);
            pos = end;
            records += passed;
            if !go_on || batch.len() >= max {
                return (pos, records);
            }
        }
    }

    /// [`PlainGroup::scan`] of up to `room` CAN records; `true` with it
    /// if the records after them may be plain too (it stopped at `room`,
    /// not at a record it could not take).
    ///
    /// Column by column: a walk finds the records, then each column is
    /// filled for all of them in a loop of its own (no growth check per
    /// value, few values live at once); a record one column cannot take
    /// cuts every column before it.
    #[allow(clippy::too_many_arguments)]
    fn run(
        &mut self,
        buf: &[u8],
        id_bytes: usize,
        pos: usize,
        batch: &mut FrameBatch,
        room: usize,
        start_ns: i64,
        interface_of: &mut impl FnMut(u64, &mut FrameBatch) -> Option<u16>,
    ) -> (usize, u64, bool) {
        let (end, records, blocked) = self.walk(buf, id_bytes, pos, room);
        let (cans, places) = (&self.cans, &self.places);
        let mut taken = places.len();
        let first = batch.len();
        batch
            .timestamp_ns
            .extend(places.iter().enumerate().map(|(index, &(body, can))| {
                let time = &cans[usize::from(can)].time;
                time_ns(&buf[body..], time, 0, start_ns).unwrap_or_else(|| {
                    taken = taken.min(index);
                    0
                })
            }));
        self.frames.clear();
        // Each record's frame as it comes, a record the loop cannot take
        // as `None` (replaced after: choosing in the loop between a frame
        // and a stand-in cost a stalled copy per record).
        self.frames.extend(
            places
                .iter()
                .map(|&(body, can)| cans[usize::from(can)].shape(&buf[body..])),
        );
        if let Some(index) = self.frames.iter().position(Option::is_none) {
            taken = taken.min(index);
        }
        let frames = &self.frames[..taken];
        // The interfaces last: a bus first met past the cut is not one
        // this batch has seen. A logger's buses interleave frame by
        // frame: each small bus channel's interface is kept by its value,
        // not looked up.
        let mut by_channel = [None::<u16>; 16];
        self.interfaces.clear();
        self.interfaces
            .extend(frames.iter().flatten().map_while(|frame| {
                let known = usize::try_from(frame.channel)
                    .ok()
                    .and_then(|channel| by_channel.get_mut(channel));
                match known {
                    Some(Some(interface)) => Some(*interface),
                    Some(slot) => Some(*slot.insert(interface_of(frame.channel, batch)?)),
                    None => interface_of(frame.channel, batch),
                }
            }));
        taken = self.interfaces.len();
        batch.interface.extend_from_slice(&self.interfaces);
        let frames = &self.frames[..taken];
        batch.timestamp_ns.truncate(first + taken);
        let frames = || frames.iter().map(|frame| frame.unwrap_or(Shape::NONE));
        batch.id.extend(frames().map(|frame| frame.id));
        batch.kind.extend(frames().map(|frame| frame.kind));
        batch
            .direction
            .extend(frames().map(|frame| frame.direction));
        for (frame, &(body, can)) in frames().zip(places) {
            let at = body + cans[usize::from(can)].bytes_at;
            let len = usize::from(frame.payload_len);
            match buf
                .get(at..at + 8)
                .and_then(|eight| <&[u8; 8]>::try_from(eight).ok())
            {
                Some(eight) if len <= 8 => batch.push_payload_of_eight(eight, len),
                _ => batch.push_payload(&buf[at..at + len]),
            }
        }
        if taken == places.len() {
            return (end, records, !blocked);
        }
        // Cut at a record: it and what follows are the careful path's.
        let cut_body = places[taken].0;
        let cut = records - self.records_after(buf, id_bytes, cut_body, end);
        (cut_body - id_bytes, cut, false)
    }

    /// Walks the whole records from `pos` on (each with a window of bytes from its
    /// start in `buf`, up to `room` records) into `places`; returns where
    /// it stopped, how many records it passed and `true` if it stopped
    /// before `room` (at the buffer's end or a record id it does not know).
    fn walk(
        &mut self,
        buf: &[u8],
        id_bytes: usize,
        mut pos: usize,
        room: usize,
    ) -> (usize, u64, bool) {
        self.places.clear();
        let mut records = 0u64;
        // Records of one size: where each starts does not wait for the
        // one before it to be looked up.
        if let Some(size) = self.one_size {
            let step = id_bytes + size;
            let span = id_bytes + size.max(size_of::<Window>());
            let whole = match buf.len().checked_sub(pos + span) {
                Some(past) => past / step + 1,
                None => 0,
            };
            for start in (pos..).step_by(step).take(whole.min(room)) {
                let slot = self.by_id[usize::from(buf[start])];
                let Some(&(_, can)) = self.records.get(usize::from(slot)) else {
                    return (pos, records, true);
                };
                if let Some(can) = can {
                    self.places.push((start + id_bytes, can));
                }
                records += 1;
                pos = start + step;
            }
            return (pos, records, whole <= room);
        }
        while records < room as u64 {
            let Some(&first) = buf.get(pos) else {
                return (pos, records, true);
            };
            let slot = self.by_id[usize::from(first)];
            let Some(&(size, can)) = self.records.get(usize::from(slot)) else {
                return (pos, records, true);
            };
            let body = pos + id_bytes;
            if body + size.max(size_of::<Window>()) > buf.len() {
                return (pos, records, true);
            }
            if let Some(can) = can {
                self.places.push((body, can));
            }
            pos = body + size;
            records += 1;
        }
        (pos, records, false)
    }

    /// The records from the one whose body is at `from` to `end`.
    fn records_after(&self, buf: &[u8], id_bytes: usize, from: usize, end: usize) -> u64 {
        let mut pos = from - id_bytes;
        let mut records = 0;
        while pos < end {
            let slot = self.by_id[usize::from(buf[pos])];
            pos += id_bytes + self.records[usize::from(slot)].0;
            records += 1;
        }
        records
    }
}
