//! The CAN frame as it appeared on one bus at one instant.
//!
//! One type covers classic CAN (data and remote frames, 0-8 bytes), CAN FD
//! (0-64 bytes with BRS/ESI) and error frames, plus the two facts a log
//! adds: a nanosecond timestamp and the interface name. It is `Copy` and
//! allocation-free so a decoder can move millions of them a second.

use std::fmt;

/// `CAN_EFF_FLAG`: marks a 29-bit id in a Linux `can_id` word.
pub const CAN_EFF_FLAG: u32 = 0x8000_0000;
/// `CAN_RTR_FLAG`: remote transmission request.
pub const CAN_RTR_FLAG: u32 = 0x4000_0000;
/// `CAN_ERR_FLAG`: error frame; the low 29 bits are the error class.
pub const CAN_ERR_FLAG: u32 = 0x2000_0000;
/// Largest 11-bit identifier.
pub const MAX_STANDARD_ID: u16 = 0x7FF;
/// Largest 29-bit identifier.
pub const MAX_EXTENDED_ID: u32 = 0x1FFF_FFFF;
/// Payload of a classic CAN frame, bytes.
pub const CLASSIC_MAX_LEN: usize = 8;
/// Payload of a CAN FD frame, bytes.
pub const FD_MAX_LEN: usize = 64;
/// The payload length of each CAN FD DLC (0-15), as every log format counts it.
pub const FD_DLC_LENGTHS: [usize; 16] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64];

/// CAN FD flag: bit rate switch.
pub const FD_FLAG_BRS: u8 = 0x01;
/// CAN FD flag: error state indicator.
pub const FD_FLAG_ESI: u8 = 0x02;
/// CAN FD flag: "this is an FD frame" (set by newer kernels and can-utils).
pub const FD_FLAG_FDF: u8 = 0x04;

/// The flags nibble of an FD frame built from scratch, with `FD_FLAG_FDF`
/// set as current kernels and candump do.
pub fn fd_flags(bit_rate_switch: bool, error_state: bool) -> u8 {
    FD_FLAG_FDF | u8::from(bit_rate_switch) | (u8::from(error_state) << 1)
}

/// An 11-bit (standard) or 29-bit (extended) CAN identifier.
///
/// Kept as two variants because `0x123` and `0x00000123` are different
/// frames on the wire and must survive a round trip through a log.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CanId {
    Standard(u16),
    Extended(u32),
}

impl CanId {
    /// A standard id, or `None` if it does not fit in 11 bits.
    #[inline]
    pub fn standard(id: u16) -> Option<Self> {
        (id <= MAX_STANDARD_ID).then_some(CanId::Standard(id))
    }

    /// An extended id, or `None` if it does not fit in 29 bits.
    #[inline]
    pub fn extended(id: u32) -> Option<Self> {
        (id <= MAX_EXTENDED_ID).then_some(CanId::Extended(id))
    }

    /// The identifier bits without any flag.
    pub fn raw(self) -> u32 {
        match self {
            CanId::Standard(id) => u32::from(id),
            CanId::Extended(id) => id,
        }
    }

    pub fn is_extended(self) -> bool {
        matches!(self, CanId::Extended(_))
    }

    /// The id with `CAN_EFF_FLAG` set for extended ids: the key DBC files
    /// and Linux use, unique across both id spaces.
    #[inline]
    pub fn key(self) -> u32 {
        match self {
            CanId::Standard(id) => u32::from(id),
            CanId::Extended(id) => id | CAN_EFF_FLAG,
        }
    }

    /// Inverse of [`CanId::key`].
    pub fn from_key(key: u32) -> Option<Self> {
        if key & CAN_EFF_FLAG != 0 {
            CanId::extended(key & !CAN_EFF_FLAG)
        } else {
            u16::try_from(key).ok().and_then(CanId::standard)
        }
    }
}

impl fmt::Display for CanId {
    /// `0x` + uppercase hex without leading zeros (the `acq decode` form).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "0x{:X}", self.raw())
    }
}

/// What kind of frame this is, with the fields only that kind has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FrameKind {
    /// Classic data frame. `len8_dlc` is the raw DLC 9..=15 some controllers
    /// send with an 8-byte payload (the candump `_<dlc>` escape), else `None`.
    Data { len8_dlc: Option<u8> },
    /// Classic remote frame: no payload, only a requested length.
    Remote {
        requested_len: u8,
        len8_dlc: Option<u8>,
    },
    /// CAN FD data frame; `flags` holds the BRS/ESI/FDF nibble exactly as
    /// received, so a log written back is byte-identical.
    Fd { flags: u8 },
    /// Error frame; `class` is the `CAN_ERR_*` class mask (the id bits),
    /// the 8 data bytes carry the details (see `can/error.h`).
    Error { class: u32 },
}

/// A Linux interface name (at most 15 bytes, like `IFNAMSIZ - 1`), stored
/// inline so frames need no allocation.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct IfaceName {
    len: u8,
    bytes: [u8; IfaceName::MAX_LEN],
}

impl IfaceName {
    pub const MAX_LEN: usize = 15;

    /// `None` if `name` is empty, longer than 15 bytes, or holds whitespace,
    /// `/` or control characters (Linux rejects those too).
    pub fn new(name: &str) -> Option<Self> {
        Self::from_bytes(name.as_bytes())
    }

    pub fn from_bytes(name: &[u8]) -> Option<Self> {
        if name.is_empty()
            || name.len() > Self::MAX_LEN
            || name
                .iter()
                .any(|&b| b <= b' ' || b == b'/' || b == b':' || b >= 0x7F)
        {
            return None;
        }
        let mut bytes = [0u8; Self::MAX_LEN];
        bytes[..name.len()].copy_from_slice(name);
        Some(IfaceName {
            len: name.len() as u8,
            bytes,
        })
    }

    /// The name's bytes (printable ASCII).
    #[inline]
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    /// Whether `name` is this name: compared in two fixed-length pieces
    /// that overlap, where a compare of the name's own length is a call
    /// (of `memcmp`, a twentieth of a candump line's parse).
    #[inline(always)]
    pub fn is(&self, name: &[u8]) -> bool {
        fn pieces<const N: usize>(bytes: &[u8]) -> ([u8; N], [u8; N]) {
            let len = bytes.len();
            let first = bytes[..N].try_into().unwrap_or([0; N]);
            let last = bytes[len - N..].try_into().unwrap_or([0; N]);
            (first, last)
        }
        let own = self.as_bytes();
        if name.len() != own.len() {
            return false;
        }
        match own.len() {
            8.. => pieces::<8>(own) == pieces::<8>(name),
            4.. => pieces::<4>(own) == pieces::<4>(name),
            _ => own == name,
        }
    }

    /// The name's bytes, then zeros to [`IfaceName::MAX_LEN`]: copied
    /// whole, a fixed length, where a copy of the name's own length is a
    /// call (the name is [`IfaceName::as_bytes`]'s length long).
    #[inline]
    pub fn zero_padded(&self) -> &[u8; IfaceName::MAX_LEN] {
        &self.bytes
    }

    pub fn as_str(&self) -> &str {
        // Only printable ASCII is ever stored (checked in `from_bytes`).
        std::str::from_utf8(&self.bytes[..usize::from(self.len)]).unwrap_or("?")
    }
}

impl fmt::Debug for IfaceName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

impl fmt::Display for IfaceName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Direction a frame travelled, when the log says (candump `-x`: `R`/`T`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Direction {
    Received,
    Transmitted,
}

/// One frame with its reception time and interface.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Frame {
    /// Nanoseconds since the Unix epoch (or since the log's start when the
    /// log has no absolute time).
    pub timestamp_ns: i64,
    pub iface: IfaceName,
    /// For error frames this is `Extended(class)`; use [`FrameKind::Error`].
    pub id: CanId,
    pub kind: FrameKind,
    pub direction: Option<Direction>,
    len: u8,
    data: [u8; FD_MAX_LEN],
}

/// What a decoder reads of one frame, borrowed from a [`Frame`] or from
/// a row of a [`crate::FrameBatch`]: a batch's frame is decoded where it
/// lies, never copied into a `Frame` first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameFields<'a> {
    pub timestamp_ns: i64,
    pub id: CanId,
    pub kind: FrameKind,
    pub payload: &'a [u8],
}

/// Why a frame could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("payload of {len} bytes is longer than the {max} bytes a {what} frame carries")]
    TooLong {
        len: usize,
        max: usize,
        what: &'static str,
    },
    #[error("raw DLC {0} is not in 9..=15 (the only values the `_<dlc>` escape carries)")]
    BadLen8Dlc(u8),
    #[error("error class 0x{0:X} does not fit in 29 bits")]
    BadErrorClass(u32),
}

impl Frame {
    fn with_payload(
        timestamp_ns: i64,
        iface: IfaceName,
        id: CanId,
        kind: FrameKind,
        payload: &[u8],
        max: usize,
        what: &'static str,
    ) -> Result<Self, FrameError> {
        if payload.len() > max {
            return Err(FrameError::TooLong {
                len: payload.len(),
                max,
                what,
            });
        }
        Ok(Frame::from_parts(timestamp_ns, iface, id, kind, payload))
    }

    /// A frame of fields already checked (a reader's, a batch's): the
    /// payload is cut at 64 bytes, the most any kind carries.
    pub(crate) fn from_parts(
        timestamp_ns: i64,
        iface: IfaceName,
        id: CanId,
        kind: FrameKind,
        payload: &[u8],
    ) -> Self {
        let payload = &payload[..payload.len().min(FD_MAX_LEN)];
        let mut data = [0u8; FD_MAX_LEN];
        data[..payload.len()].copy_from_slice(payload);
        Frame {
            timestamp_ns,
            iface,
            id,
            kind,
            direction: None,
            len: payload.len() as u8,
            data,
        }
    }

    /// Classic data frame, 0-8 bytes.
    pub fn data(
        timestamp_ns: i64,
        iface: IfaceName,
        id: CanId,
        payload: &[u8],
    ) -> Result<Self, FrameError> {
        let kind = FrameKind::Data { len8_dlc: None };
        Self::with_payload(
            timestamp_ns,
            iface,
            id,
            kind,
            payload,
            CLASSIC_MAX_LEN,
            "classic CAN",
        )
    }

    /// CAN FD frame, 0-64 bytes; `flags` as in `canfd_frame.flags`.
    pub fn fd(
        timestamp_ns: i64,
        iface: IfaceName,
        id: CanId,
        flags: u8,
        payload: &[u8],
    ) -> Result<Self, FrameError> {
        let kind = FrameKind::Fd {
            flags: flags & 0x0F,
        };
        Self::with_payload(timestamp_ns, iface, id, kind, payload, FD_MAX_LEN, "CAN FD")
    }

    /// Classic remote frame requesting `requested_len` (0-8) bytes.
    pub fn remote(
        timestamp_ns: i64,
        iface: IfaceName,
        id: CanId,
        requested_len: u8,
    ) -> Result<Self, FrameError> {
        if usize::from(requested_len) > CLASSIC_MAX_LEN {
            return Err(FrameError::TooLong {
                len: usize::from(requested_len),
                max: CLASSIC_MAX_LEN,
                what: "remote",
            });
        }
        let kind = FrameKind::Remote {
            requested_len,
            len8_dlc: None,
        };
        Self::with_payload(timestamp_ns, iface, id, kind, &[], 0, "remote")
    }

    /// Error frame of class `class` (`CAN_ERR_*` bits) with its 8 detail bytes
    /// (fewer are zero-padded, as the kernel always sends 8).
    pub fn error(
        timestamp_ns: i64,
        iface: IfaceName,
        class: u32,
        details: &[u8],
    ) -> Result<Self, FrameError> {
        if class > MAX_EXTENDED_ID {
            return Err(FrameError::BadErrorClass(class));
        }
        let mut frame = Self::with_payload(
            timestamp_ns,
            iface,
            CanId::Extended(class),
            FrameKind::Error { class },
            details,
            CLASSIC_MAX_LEN,
            "error",
        )?;
        frame.len = CLASSIC_MAX_LEN as u8;
        Ok(frame)
    }

    /// Sets the raw DLC (9..=15) of a classic frame with 8 bytes (data or remote).
    pub fn set_len8_dlc(&mut self, dlc: u8) -> Result<(), FrameError> {
        if !(9..=15).contains(&dlc) {
            return Err(FrameError::BadLen8Dlc(dlc));
        }
        match &mut self.kind {
            FrameKind::Data { len8_dlc } if self.len == 8 => *len8_dlc = Some(dlc),
            FrameKind::Remote {
                requested_len: 8,
                len8_dlc,
            } => *len8_dlc = Some(dlc),
            _ => return Err(FrameError::BadLen8Dlc(dlc)),
        }
        Ok(())
    }

    /// The payload (empty for remote frames).
    #[inline]
    pub fn payload(&self) -> &[u8] {
        &self.data[..usize::from(self.len)]
    }

    /// Its fields as a decoder reads them.
    #[inline]
    pub fn fields(&self) -> FrameFields<'_> {
        FrameFields {
            timestamp_ns: self.timestamp_ns,
            id: self.id,
            kind: self.kind,
            payload: self.payload(),
        }
    }

    pub fn is_error(&self) -> bool {
        matches!(self.kind, FrameKind::Error { .. })
    }

    pub fn is_fd(&self) -> bool {
        matches!(self.kind, FrameKind::Fd { .. })
    }
}

impl fmt::Debug for Frame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Frame")
            .field("timestamp_ns", &self.timestamp_ns)
            .field("iface", &self.iface)
            .field("id", &self.id)
            .field("kind", &self.kind)
            .field("direction", &self.direction)
            .field("payload", &self.payload())
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn can0() -> IfaceName {
        IfaceName::new("can0").unwrap()
    }

    proptest::proptest! {
        /// A name is `is` exactly the bytes it is, whatever they are
        /// compared with (other names, longer or shorter, any bytes).
        #[test]
        fn a_name_is_its_own_bytes_and_no_others(
            name in "[!-.0-9;-~]{1,15}",
            other in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..20),
            cut in 0usize..16,
        ) {
            let iface = IfaceName::new(&name).unwrap();
            proptest::prop_assert!(iface.is(name.as_bytes()));
            proptest::prop_assert_eq!(iface.is(&other), other == name.as_bytes());
            let cut = &name.as_bytes()[..cut.min(name.len())];
            proptest::prop_assert_eq!(iface.is(cut), cut == name.as_bytes());
            let mut changed = name.clone().into_bytes();
            let at = cut.len().min(changed.len() - 1);
            changed[at] ^= 1;
            proptest::prop_assert!(!iface.is(&changed));
            proptest::prop_assert_eq!(&iface.zero_padded()[..name.len()], name.as_bytes());
            proptest::prop_assert!(iface.zero_padded()[name.len()..].iter().all(|&b| b == 0));
        }
    }

    #[test]
    fn ids_keep_their_space() {
        assert_ne!(CanId::Standard(0x123).key(), CanId::Extended(0x123).key());
        assert_eq!(CanId::from_key(0x8000_0123), Some(CanId::Extended(0x123)));
        assert_eq!(CanId::standard(0x800), None);
        assert_eq!(CanId::extended(0x2000_0000), None);
        assert_eq!(CanId::Extended(0x18FEF100).to_string(), "0x18FEF100");
    }

    #[test]
    fn payload_limits_are_enforced() {
        assert!(Frame::data(0, can0(), CanId::Standard(1), &[0; 9]).is_err());
        assert!(Frame::fd(0, can0(), CanId::Standard(1), FD_FLAG_BRS, &[0; 64]).is_ok());
        assert!(Frame::fd(0, can0(), CanId::Standard(1), 0, &[0; 65]).is_err());
        let error = Frame::error(0, can0(), 0x40, &[1, 2]).unwrap();
        assert_eq!(error.payload(), &[1, 2, 0, 0, 0, 0, 0, 0]);
    }

    #[test]
    fn iface_names_follow_linux_rules() {
        assert!(IfaceName::new("vcan0").is_some());
        assert!(IfaceName::new("a_very_long_name0").is_none());
        assert!(IfaceName::new("can 0").is_none());
        assert!(IfaceName::new("").is_none());
    }

    #[test]
    fn len8_dlc_only_on_full_classic_frames() {
        let mut frame = Frame::data(0, can0(), CanId::Standard(1), &[0; 8]).unwrap();
        assert!(frame.set_len8_dlc(0xF).is_ok());
        assert!(frame.set_len8_dlc(8).is_err());
        let mut short = Frame::data(0, can0(), CanId::Standard(1), &[0; 7]).unwrap();
        assert!(short.set_len8_dlc(9).is_err());
    }
}
