//! What every part of the reader shares: the file's signatures and limits,
//! the messages of what was expected, the error at a byte offset, and the
//! little-endian readers.

use crate::log::record::{ParseError, Place, ReadError};

/// The first bytes of every MDF file.
pub const SIGNATURE: &[u8; 8] = b"MDF     ";
/// The identification of an MF4 file its writer has not finalized (a
/// logger whose power was cut, or one that never finalizes).
pub const UNFINALIZED_SIGNATURE: &[u8; 8] = b"UnFinMF ";
/// The largest metadata block acq reads.
/// Unfinalized flags (a u16 at byte 60): the last `##DT` block's length
/// was not written.
pub(super) const UNFINALIZED_LAST_DT_LENGTH: u16 = 0x04;
/// Unfinalized flags: the last `##DL` block was not updated.
pub(super) const UNFINALIZED_LAST_LIST: u16 = 0x10;
/// Unfinalized flags: the offsets of VLSD values were not written.
pub(super) const UNFINALIZED_VLSD_OFFSETS: u16 = 0x40;
pub const MAX_METADATA_BYTES: u64 = 16 << 20;
/// The largest zipped data block acq inflates (asammdf writes 4 MiB ones).
pub const MAX_DZ_BYTES: u64 = 256 << 20;

/// Room kept before an inflated block's records for a record begun in the
/// block before, bytes.
pub(super) const MAX_HEADROOM: usize = 4096;
pub(super) const ID_BLOCK: u64 = 64;
pub(super) const HEADER: u64 = 24;
pub(super) const CHUNK: u64 = 1 << 20;
/// `CAN_ERR_BUSERROR`: the class of every error frame read from MF4.
pub const ERROR_FRAME_CLASS: u32 = 0x80;

pub(super) const E_ID: &str =
    "an MDF 4 identification block: 'MDF     ' (or 'UnFinMF ') and a version number 400 to 499";
pub(super) const E_BLOCK: &str =
    "a block with a '##' id, a length within the file and room for its links";
pub(super) const E_HD: &str = "a '##HD' header block at byte 64";
pub(super) const E_DG: &str = "a '##DG' data group with a record id size of 0, 1, 2, 4 or 8 bytes";
pub(super) const E_CG: &str = "a '##CG' channel group";
pub(super) const E_CN: &str = "a '##CN' channel";
pub(super) const E_LOOP: &str = "a tree of groups and channels without loops";
pub(super) const E_SORTED: &str = "one channel group in a data group without record ids";
pub(super) const E_MASTER: &str =
    "a time master channel: a little-endian float or integer, or a virtual master, with no or a linear '##CC' conversion";
pub(super) const E_FIELD: &str =
    "bus-logging fields as little-endian unsigned integers of 1 to 64 bits inside the record";
pub(super) const E_BYTES: &str = "a DataBytes channel: a byte array inside the record, or a VLSD channel of a u64 offset into its signal data";
pub(super) const E_FIELD_VALUE: &str =
    "a bus-logging field whose conversion gives a whole number from 0 up";
pub(super) const E_VLSD: &str =
    "a VLSD offset at the start of a value in the channel's signal data, offsets growing";
pub(super) const E_NO_ID: &str = "an ID field in a CAN data or remote frame group";
pub(super) const E_DATA: &str = "a '##DT', '##SD', '##DZ', '##DL' or '##HL' data block";
pub(super) const E_DZ: &str = "a '##DZ' block of deflate (0) or transposed deflate (1) data whose inflated length is at most 256 MiB and what it states";
pub(super) const E_ORDER: &str =
    "data blocks in file order after the metadata (a stream cannot go back)";
pub(super) const E_RECORD_ID: &str = "a record id of one of the data group's channel groups";
pub(super) const E_RECORD: &str = "a whole record (the data ends inside one)";
pub(super) const E_CAN_ID: &str = "an id of at most 0x7FF, or 0x1FFFFFFF when IDE says extended";
pub(super) const E_LENGTH: &str = "a data length the frame's DataBytes hold (0-8 classic, 0-64 FD)";
pub(super) const E_TIME: &str = "a time that fits in a 64-bit nanosecond timestamp";
pub(super) const E_CHANNEL: &str = "a BusChannel number that names an interface";
pub(super) const E_TRUNCATED: &str = "a whole block (the file ends inside one)";

pub(super) fn parse(offset: u64, expected: &'static str) -> ReadError {
    ReadError::Parse(ParseError::at(Place::ByteOffset(offset), expected))
}

#[inline]
pub(super) fn u16_at(bytes: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(
        bytes.get(at..at.checked_add(2)?)?.try_into().ok()?,
    ))
}

#[inline]
pub(super) fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(
        bytes.get(at..at.checked_add(4)?)?.try_into().ok()?,
    ))
}

#[inline]
pub(super) fn u64_at(bytes: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(
        bytes.get(at..at.checked_add(8)?)?.try_into().ok()?,
    ))
}

#[inline]
pub(super) fn f64_at(bytes: &[u8], at: usize) -> Option<f64> {
    u64_at(bytes, at).map(f64::from_bits)
}
