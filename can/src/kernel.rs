//! The Linux SocketCAN wire layout: `struct can_frame` (16 bytes) and
//! `struct canfd_frame` (72 bytes) as `read`/`write` on a raw CAN socket
//! exchange them, in host byte order.
//!
//! Converting by hand (instead of through the socketcan crate's frame types)
//! keeps every bit the kernel hands over: the raw DLC 9..15 of classic frames
//! (`len8_dlc`), the FD flags byte as received, and error frames' class and
//! detail bytes, so a frame recorded is the frame written to `raw.log`.

use crate::frame::{
    CanId, Frame, FrameKind, IfaceName, CAN_EFF_FLAG, CAN_ERR_FLAG, CAN_RTR_FLAG, MAX_EXTENDED_ID,
    MAX_STANDARD_ID,
};

/// `sizeof(struct can_frame)`.
pub const CAN_MTU: usize = 16;
/// `sizeof(struct canfd_frame)`.
pub const CANFD_MTU: usize = 72;

/// Why bytes from a socket are not a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum KernelFrameError {
    #[error("read {0} bytes; a CAN socket returns 16 (classic) or 72 (FD)")]
    BadSize(usize),
    #[error("length {len} exceeds the {max} bytes of a {what} frame")]
    BadLength {
        len: u8,
        max: u8,
        what: &'static str,
    },
}

/// Parses the bytes of one `read`/`recvmsg` on a CAN_RAW socket.
pub fn parse(bytes: &[u8], iface: IfaceName, timestamp_ns: i64) -> Result<Frame, KernelFrameError> {
    let size = bytes.len();
    if size != CAN_MTU && size != CANFD_MTU {
        return Err(KernelFrameError::BadSize(size));
    }
    let raw_id = u32::from_ne_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
    let len = bytes[4];
    let id = if raw_id & CAN_EFF_FLAG != 0 {
        CanId::Extended(raw_id & MAX_EXTENDED_ID)
    } else {
        CanId::Standard((raw_id as u16) & MAX_STANDARD_ID)
    };
    let too_long = |max: u8, what| KernelFrameError::BadLength { len, max, what };
    if size == CANFD_MTU {
        if len > 64 {
            return Err(too_long(64, "CAN FD"));
        }
        let data = &bytes[8..8 + usize::from(len)];
        return Frame::fd(timestamp_ns, iface, id, bytes[5], data)
            .map_err(|_| too_long(64, "CAN FD"));
    }
    if len > 8 {
        return Err(too_long(8, "classic"));
    }
    let len8_dlc = bytes[7];
    let data = &bytes[8..8 + usize::from(len)];
    let mut frame = if raw_id & CAN_ERR_FLAG != 0 {
        Frame::error(timestamp_ns, iface, raw_id & MAX_EXTENDED_ID, &bytes[8..16])
    } else if raw_id & CAN_RTR_FLAG != 0 {
        Frame::remote(timestamp_ns, iface, id, len)
    } else {
        Frame::data(timestamp_ns, iface, id, data)
    }
    .map_err(|_| too_long(8, "classic"))?;
    if len == 8 && (9..=15).contains(&len8_dlc) && !frame.is_error() {
        // Only classic 8-byte frames carry a raw DLC; anything else is padding.
        let _ = frame.set_len8_dlc(len8_dlc);
    }
    Ok(frame)
}

/// The bytes to `write` for `frame`: 16 for classic, remote and error
/// frames, 72 for FD. Returns the buffer and the length to write.
pub fn encode(frame: &Frame) -> ([u8; CANFD_MTU], usize) {
    let mut bytes = [0u8; CANFD_MTU];
    let mut raw_id = match frame.id {
        CanId::Standard(id) => u32::from(id),
        CanId::Extended(id) => id | CAN_EFF_FLAG,
    };
    let payload = frame.payload();
    let size = match frame.kind {
        FrameKind::Data { len8_dlc } => {
            bytes[7] = len8_dlc.unwrap_or(0);
            CAN_MTU
        }
        FrameKind::Remote {
            requested_len,
            len8_dlc,
        } => {
            raw_id |= CAN_RTR_FLAG;
            bytes[4] = requested_len;
            bytes[7] = len8_dlc.unwrap_or(0);
            CAN_MTU
        }
        FrameKind::Fd { flags } => {
            // As received: a 72-byte write is FD by its size, and kernels
            // from 6.2 add the FDF flag themselves.
            bytes[5] = flags;
            CANFD_MTU
        }
        FrameKind::Error { class } => {
            raw_id = class | CAN_ERR_FLAG | CAN_EFF_FLAG;
            CAN_MTU
        }
    };
    if !matches!(frame.kind, FrameKind::Remote { .. }) {
        bytes[4] = payload.len() as u8;
    }
    bytes[..4].copy_from_slice(&raw_id.to_ne_bytes());
    bytes[8..8 + payload.len()].copy_from_slice(payload);
    (bytes, size)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{FD_FLAG_BRS, FD_FLAG_FDF};

    fn vcan0() -> IfaceName {
        IfaceName::new("vcan0").unwrap()
    }

    fn round_trip(frame: Frame) {
        let (bytes, size) = encode(&frame);
        let back = parse(&bytes[..size], frame.iface, frame.timestamp_ns).unwrap();
        assert_eq!(back, frame);
    }

    #[test]
    fn every_kind_round_trips() {
        round_trip(Frame::data(5, vcan0(), CanId::Standard(0x7FF), &[1, 2, 3]).unwrap());
        round_trip(Frame::data(5, vcan0(), CanId::Extended(0x18FEF100), &[]).unwrap());
        let mut raw_dlc = Frame::data(5, vcan0(), CanId::Standard(0x1), &[9; 8]).unwrap();
        raw_dlc.set_len8_dlc(0xC).unwrap();
        round_trip(raw_dlc);
        round_trip(Frame::remote(5, vcan0(), CanId::Standard(0x123), 4).unwrap());
        round_trip(Frame::error(5, vcan0(), 0x44, &[0, 0x10, 0, 0, 0, 0, 3, 200]).unwrap());
    }

    #[test]
    fn fd_flags_go_out_as_received() {
        for flags in [FD_FLAG_BRS, FD_FLAG_BRS | FD_FLAG_FDF, 0x08] {
            let frame = Frame::fd(5, vcan0(), CanId::Standard(0x10), flags, &[7; 12]).unwrap();
            let (bytes, size) = encode(&frame);
            assert_eq!((size, bytes[5]), (CANFD_MTU, flags));
            assert_eq!(parse(&bytes[..size], vcan0(), 5).unwrap(), frame);
        }
    }

    #[test]
    fn wrong_sizes_and_lengths_are_errors() {
        assert_eq!(
            parse(&[0; 15], vcan0(), 0),
            Err(KernelFrameError::BadSize(15))
        );
        let mut bytes = [0u8; CAN_MTU];
        bytes[4] = 9;
        assert!(parse(&bytes, vcan0(), 0).is_err());
        let mut fd = [0u8; CANFD_MTU];
        fd[4] = 65;
        assert!(parse(&fd, vcan0(), 0).is_err());
    }
}
