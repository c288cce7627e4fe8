//! What a channel group's records hold: the bus-logging members found by
//! name in its channels, each a bit field, a constant or a field through
//! a conversion; the time master; DataBytes in the record or as VLSD; and
//! the decoding of one record into a [`Frame`].

use std::io::BufRead;

use super::conversion::*;
use super::format::*;
use super::source::*;
use crate::frame::{
    fd_flags, CanId, Direction, FrameKind, IfaceName, CLASSIC_MAX_LEN, FD_DLC_LENGTHS, FD_MAX_LEN,
    MAX_EXTENDED_ID, MAX_STANDARD_ID,
};
use crate::log::batch::FrameBatch;
use crate::log::record::{ParseError, Place, ReadError};

/// An unsigned little-endian field of a record.
#[derive(Clone, Copy, Debug)]
pub(super) struct Field {
    pub(super) byte: usize,
    pub(super) bit: u32,
    pub(super) bits: u32,
}

impl Field {
    #[inline(always)]
    pub(super) fn read(&self, record: &[u8]) -> u64 {
        // Whole bytes, the fields bus logging writes: no shifting.
        if self.bit == 0 {
            match self.bits {
                8 => return record.get(self.byte).map_or(0, |&b| u64::from(b)),
                32 => return u32_at(record, self.byte).map_or(0, u64::from),
                _ => {}
            }
        }
        // Any field within 8 bytes of the record: one unaligned load.
        if self.bit + self.bits <= 64 {
            if let Some(bytes) = record.get(self.byte..self.byte + 8) {
                let mut word = [0u8; 8];
                word.copy_from_slice(bytes);
                let mask = u64::MAX.checked_shr(64 - self.bits).unwrap_or(0);
                return (u64::from_le_bytes(word) >> self.bit) & mask;
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
pub(super) enum Member {
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
pub(super) const TABLE_BITS: u32 = 8;

impl Member {
    pub(super) fn new(field: Option<Field>, conversion: Option<Conversion>) -> Option<Self> {
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
    #[inline(always)]
    pub(super) fn value(&self, record: &[u8], index: u64) -> Result<u64, &'static str> {
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
pub(super) fn whole(value: f64) -> Option<u64> {
    let rounded = value.round();
    ((value - rounded).abs() <= 1e-9 * rounded.abs().max(1.0) && (0.0..1.8e19).contains(&rounded))
        .then_some(rounded as u64)
}

/// How the master channel gives seconds.
#[derive(Clone, Copy, Debug)]
pub(super) enum TimeKind {
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
pub(super) struct Scale {
    pub(super) a: f64,
    pub(super) b: f64,
    pub(super) ns_per_unit: Option<f64>,
}

impl Scale {
    pub(super) fn new(a: f64, b: f64) -> Self {
        let ns = b * 1e9;
        let whole = a == 0.0 && (1.0..=1e12).contains(&ns) && ns.fract() == 0.0;
        Scale {
            a,
            b,
            ns_per_unit: whole.then_some(ns),
        }
    }

    #[inline(always)]
    pub(super) fn ns(self, value: f64) -> Option<i64> {
        match self.ns_per_unit {
            Some(ns) => whole_ns(value * ns),
            None => seconds_to_ns(self.a + self.b * value),
        }
    }
}

#[derive(Clone, Copy, Debug)]
pub(super) struct Time {
    pub(super) byte: usize,
    pub(super) kind: TimeKind,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum FrameType {
    Data,
    Remote,
    Error,
}

/// Where a CAN group's fields lie in its records.
#[derive(Clone, Debug)]
pub(super) struct CanLayout {
    pub(super) frame_type: FrameType,
    pub(super) time: Time,
    pub(super) channel: Option<Member>,
    pub(super) id: Option<Member>,
    pub(super) ide: Option<Member>,
    pub(super) dlc: Option<Member>,
    pub(super) data_length: Option<Member>,
    pub(super) data_bytes: Option<Bytes>,
    pub(super) dir: Option<Member>,
    pub(super) edl: Option<Member>,
    pub(super) brs: Option<Member>,
    pub(super) esi: Option<Member>,
    /// Records of this group read so far: a virtual member's raw value.
    pub(super) records: u64,
}

/// Where a frame's DataBytes are.
#[derive(Clone, Copy, Debug)]
pub(super) enum Bytes {
    /// Inside the record: byte offset and length.
    Fixed { at: usize, len: usize },
    /// Variable length signal data: the record holds a u64 offset (at this
    /// byte) into the stream of the data group's `signals[signal]`.
    Vlsd { at: usize, signal: usize },
}

#[derive(Clone, Debug)]
pub(super) enum Layout {
    /// Records acq does not read, of this many bytes.
    Skip(usize),
    /// VLSD records: a u32 length, then the bytes.
    Vlsd,
    Can(usize, Box<CanLayout>),
}

impl Layout {
    /// The size of its records, `None` for VLSD records (each its own).
    pub(super) fn record_bytes(&self) -> Option<usize> {
        match self {
            Layout::Skip(size) | Layout::Can(size, _) => Some(*size),
            Layout::Vlsd => None,
        }
    }
}

/// A channel's fields as far as the layout needs them.
pub(super) struct Channel {
    pub(super) offset: u64,
    pub(super) name: Vec<u8>,
    pub(super) channel_type: u8,
    pub(super) data_type: u8,
    pub(super) bit: u32,
    pub(super) byte: u64,
    pub(super) bits: u64,
    pub(super) conversion: u64,
    /// Its `##SD` blocks or VLSD `##CG` (a VLSD channel's).
    pub(super) signal_data: u64,
}

/// The record layout of a channel group.
///
/// A VLSD DataBytes channel's signal data (the link to its `##SD` blocks
/// or VLSD channel group) is pushed on `signals`; its layout names the
/// index.
pub(super) fn group_layout<R: BufRead>(
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
pub(super) fn group_channels<R: BufRead>(
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
pub(super) fn text<R: BufRead>(
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
pub(super) fn bytes_layout(
    c: &Channel,
    data_bytes: u32,
    signals: &mut Vec<u64>,
) -> Result<Bytes, ReadError> {
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
pub(super) fn read_conversion<R: BufRead>(
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
pub(super) fn int_field(c: &Channel, data_bytes: u32, signed_ok: u8) -> Result<Field, ReadError> {
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

pub(super) fn time_layout<R: BufRead>(
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

/// One record's frame, its fields checked, before it becomes a [`Frame`]
/// or a row of a [`crate::log::batch::FrameBatch`].
pub(super) struct FrameParts<'a> {
    pub(super) timestamp_ns: i64,
    /// The `BusChannel` value ([`channel_iface`] names it).
    pub(super) channel: u64,
    pub(super) id: CanId,
    pub(super) kind: FrameKind,
    pub(super) direction: Option<Direction>,
    pub(super) payload: &'a [u8],
}

impl FrameParts<'_> {
    /// This frame onto the batch's columns, on its `interface` (an index
    /// into the batch's interfaces).
    #[inline(always)]
    pub(super) fn push_onto(&self, batch: &mut FrameBatch, interface: u16) {
        batch.push_parts(
            self.timestamp_ns,
            interface,
            self.id,
            self.kind,
            self.direction,
            self.payload,
        );
    }
}

/// An error frame's details: MF4's error fields are not Linux's.
const NO_ERROR_DETAILS: [u8; CLASSIC_MAX_LEN] = [0; CLASSIC_MAX_LEN];

/// The frame one bus-logging record holds, the `index`th of its group;
/// `signal` its VLSD DataBytes.
#[inline(always)]
pub(super) fn decode<'a>(
    record: &'a [u8],
    layout: &CanLayout,
    index: u64,
    signal: Option<&'a [u8]>,
    start_ns: i64,
) -> Result<FrameParts<'a>, &'static str> {
    // Inlined: a call per member was a quarter of the reading time.
    #[inline(always)]
    fn read_member(
        member: &Option<Member>,
        record: &[u8],
        index: u64,
    ) -> Result<Option<u64>, &'static str> {
        match member {
            Some(member) => member.value(record, index).map(Some),
            None => Ok(None),
        }
    }
    let timestamp_ns = time_ns(record, &layout.time, index, start_ns).ok_or(E_TIME)?;
    let channel = read_member(&layout.channel, record, index)?.unwrap_or(0);
    let raw_id = read_member(&layout.id, record, index)?.unwrap_or(0);
    let extended = match read_member(&layout.ide, record, index)? {
        Some(ide) => ide != 0,
        None => raw_id & 0x8000_0000 != 0,
    };
    let bits = (raw_id & 0x1FFF_FFFF) as u32;
    let dlc = read_member(&layout.dlc, record, index)?
        .unwrap_or(0)
        .min(15) as u8;
    let len8_dlc = (dlc > 8).then_some(dlc);
    let (id, kind, payload): (CanId, FrameKind, &[u8]) = match layout.frame_type {
        FrameType::Error => (
            CanId::Extended(ERROR_FRAME_CLASS),
            FrameKind::Error {
                class: ERROR_FRAME_CLASS,
            },
            &NO_ERROR_DETAILS,
        ),
        FrameType::Remote => {
            let requested_len = dlc.min(CLASSIC_MAX_LEN as u8);
            let kind = FrameKind::Remote {
                requested_len,
                len8_dlc,
            };
            (can_id(bits, extended)?, kind, &[])
        }
        FrameType::Data => {
            let fd = read_member(&layout.edl, record, index)?.unwrap_or(0) != 0;
            let data_length = read_member(&layout.data_length, record, index)?;
            let bytes = match (layout.data_bytes, signal) {
                (Some(Bytes::Fixed { at, len }), _) => &record[at..at + len],
                (Some(Bytes::Vlsd { .. }), Some(signal)) => signal,
                _ => &[],
            };
            data_frame(bits, extended, dlc, fd, data_length, bytes, || {
                Ok((
                    read_member(&layout.brs, record, index)?.unwrap_or(0) != 0,
                    read_member(&layout.esi, record, index)?.unwrap_or(0) != 0,
                ))
            })?
        }
    };
    let direction = read_member(&layout.dir, record, index)?.map(direction);
    Ok(FrameParts {
        timestamp_ns,
        channel,
        id,
        kind,
        direction,
        payload,
    })
}

/// A `Dir` member's value: 0 received, else transmitted.
#[inline(always)]
pub(super) fn direction(dir: u64) -> Direction {
    if dir == 0 {
        Direction::Received
    } else {
        Direction::Transmitted
    }
}

/// A data frame from its members' values: `bits` of its id, `dlc` (at
/// most 15), EDL, DataLength if stored, its DataBytes (`bytes`, the
/// length stored or from the DLC taken from them), and BRS and ESI, read
/// only for a CAN FD frame.
#[inline(always)]
pub(super) fn data_frame(
    bits: u32,
    extended: bool,
    dlc: u8,
    fd: bool,
    data_length: Option<u64>,
    bytes: &[u8],
    flags: impl FnOnce() -> Result<(bool, bool), &'static str>,
) -> Result<(CanId, FrameKind, &[u8]), &'static str> {
    let id = can_id(bits, extended)?;
    let from_dlc = if fd {
        FD_DLC_LENGTHS[usize::from(dlc)]
    } else {
        usize::from(dlc).min(CLASSIC_MAX_LEN)
    };
    let len = data_length.map_or(from_dlc, |n| n.min(255) as usize);
    let max = if fd { FD_MAX_LEN } else { CLASSIC_MAX_LEN };
    if len > bytes.len() || len > max {
        return Err(E_LENGTH);
    }
    let kind = if fd {
        let (bit_rate_switch, error_state) = flags()?;
        FrameKind::Fd {
            flags: fd_flags(bit_rate_switch, error_state) & 0x0F,
        }
    } else {
        FrameKind::Data {
            len8_dlc: (dlc > 8 && len == CLASSIC_MAX_LEN).then_some(dlc),
        }
    };
    Ok((id, kind, &bytes[..len]))
}

#[inline(always)]
pub(super) fn time_ns(record: &[u8], time: &Time, index: u64, start_ns: i64) -> Option<i64> {
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

pub(super) fn seconds_to_ns(seconds: f64) -> Option<i64> {
    whole_ns(seconds * 1e9)
}

/// Nanoseconds rounded to a whole number that fits an i64.
#[inline]
pub(super) fn whole_ns(ns: f64) -> Option<i64> {
    // i64::MAX as f64 rounds up to 2^63: exclude it. NaN is outside too.
    if !(-9.2e18..=9.2e18).contains(&ns) {
        return None;
    }
    // Rounded half away from zero as `f64::round`, without its call (a
    // tenth of the reading time): the truncation is exact, and so is the
    // fraction left (an f64 minus its integer part).
    let truncated = ns as i64;
    let fraction = ns - truncated as f64;
    Some(truncated + i64::from(fraction >= 0.5) - i64::from(fraction <= -0.5))
}

#[inline(always)]
pub(super) fn can_id(bits: u32, extended: bool) -> Result<CanId, &'static str> {
    // Without a branch on the id's kind: a logger's standard and extended
    // frames interleave, and a mispredicted branch per frame was a tenth
    // of the reading time.
    let max = if extended {
        MAX_EXTENDED_ID
    } else {
        u32::from(MAX_STANDARD_ID)
    };
    if bits > max {
        return Err(E_CAN_ID);
    }
    Ok(if extended {
        CanId::Extended(bits)
    } else {
        CanId::Standard(bits as u16)
    })
}

/// `BusChannel` N -> interface `canN` (no allocation: it runs per frame).
pub(super) fn channel_iface(channel: u64) -> Result<IfaceName, &'static str> {
    let mut digits = itoa::Buffer::new();
    let digits = digits.format(channel).as_bytes();
    let mut name = [0u8; 3 + 20];
    name[..3].copy_from_slice(b"can");
    name[3..3 + digits.len()].copy_from_slice(digits);
    IfaceName::from_bytes(&name[..3 + digits.len()]).ok_or(E_CHANNEL)
}
