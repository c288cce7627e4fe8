//! Writing ASAM MDF 4 bus logs (`.mf4`) that python-can's `MF4Reader`
//! (asammdf) and acq's [`super::mf4::Mf4Reader`] read back as the same
//! frames. The layout is [`super::mf4`]'s, as python-can writes it, with two
//! differences that let a log of any length be written and read in constant
//! memory:
//!
//! - One *unsorted* data group (1-byte record ids) holds the three channel
//!   groups python-can writes, `CAN_DataFrame` (id 1), `CAN_ErrorFrame`
//!   (2) and `CAN_RemoteFrame` (3), so the records stay in the log's order.
//! - The metadata comes first; then one `##DT` block whose length and the
//!   groups' cycle counts are patched by [`Mf4Writer::finish`] (hence
//!   `Write + Seek`). Records go out in 256 KiB writes.
//!
//! Each group's record: master `t` (f64 seconds from the HD start time, the
//! first frame's time to the microsecond below it, as asammdf keeps the
//! start as a datetime with microseconds), then the structure's members as
//! python-can lays them out: `BusChannel` (u8), `ID` (u32), `IDE`, `DLC`,
//! `DataLength` (u8 each), `DataBytes` (64 bytes), `Dir`, `EDL`, `BRS`,
//! `ESI` (u8 each); the remote group has no data bytes and no FD flags.
//!
//! What survives: ids and their width, payloads, raw DLCs 9-15 of classic
//! frames, FD BRS/ESI, remote requested lengths, directions (none is
//! written Rx), timestamps to the ns while a frame is less than 2^51 ns
//! (26 days) after the first (f64 seconds). Interface `canN` (N <= 255) is
//! `BusChannel` N; other names get a free number and come back as `canN`.
//! Error frames are written as python-can writes them (ID 0, IDE 1, no data):
//! their Linux class and details are lost (read back as
//! `CAN_ERR_BUSERROR`). An FD payload whose length is not a DLC step is
//! padded with zeros to the next one.

use std::io::{self, Seek, Write};

use super::mf4_blocks::{Blocks, UnsortedData, CN_FLAG_BUS_EVENT};

use crate::frame::{
    CanId, Direction, Frame, FrameKind, IfaceName, FD_DLC_LENGTHS, FD_FLAG_BRS, FD_FLAG_ESI,
};

const DATA_RECORD: u8 = 1;
const ERROR_RECORD: u8 = 2;
const REMOTE_RECORD: u8 = 3;
/// Record bytes after the id: data and error frames, remote frames.
const FRAME_RECORD_BYTES: usize = 84;
const REMOTE_RECORD_BYTES: usize = 17;
/// CG flags: bus event, plain bus event (as python-can writes).
const CG_FLAGS: u16 = 0b110;

/// (name suffix, byte offset, bits, data type) of a structure member.
type Member = (&'static str, u32, u32, u8);

const FRAME_MEMBERS: [Member; 10] = [
    ("BusChannel", 8, 8, 0),
    ("ID", 9, 32, 0),
    ("IDE", 13, 8, 0),
    ("DLC", 14, 8, 0),
    ("DataLength", 15, 8, 0),
    ("DataBytes", 16, 512, 10),
    ("Dir", 80, 8, 0),
    ("EDL", 81, 8, 0),
    ("BRS", 82, 8, 0),
    ("ESI", 83, 8, 0),
];
const REMOTE_MEMBERS: [Member; 6] = [
    ("BusChannel", 8, 8, 0),
    ("ID", 9, 32, 0),
    ("IDE", 13, 8, 0),
    ("DLC", 14, 8, 0),
    ("DataLength", 15, 8, 0),
    ("Dir", 16, 8, 0),
];

/// A frame MF4 (as written here) cannot hold.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Mf4WriteError {
    #[error("more than 256 interfaces: BusChannel is one byte")]
    TooManyInterfaces,
    #[error("interface {0}: no free BusChannel number")]
    NoChannel(String),
}

impl From<Mf4WriteError> for io::Error {
    fn from(error: Mf4WriteError) -> Self {
        io::Error::new(io::ErrorKind::InvalidData, error)
    }
}

/// Streaming MF4 writer: the metadata goes out with the first frame,
/// [`Mf4Writer::finish`] patches the lengths and counts.
pub struct Mf4Writer<W: Write + Seek> {
    output: W,
    /// Set when the metadata is written.
    layout: Option<Written>,
    /// (interface, BusChannel) in order of first appearance.
    channels: Vec<(IfaceName, u8)>,
}

/// The start time and the records after the metadata.
struct Written {
    start_ns: i64,
    data: UnsortedData,
}

impl<W: Write + Seek> Mf4Writer<W> {
    /// A writer at the output's current position, which must be its start
    /// (MF4 links are absolute offsets).
    pub fn new(output: W) -> Self {
        Mf4Writer {
            output,
            layout: None,
            channels: Vec::new(),
        }
    }

    /// Appends one frame.
    pub fn write_frame(&mut self, frame: &Frame) -> io::Result<()> {
        if self.layout.is_none() {
            self.write_metadata(frame.timestamp_ns)?;
        }
        let channel = self.channel(frame.iface)?;
        let Some(Written { start_ns, data }) = &mut self.layout else {
            return Err(io::ErrorKind::Other.into());
        };
        let start_ns = *start_ns;
        let offset_s = (i128::from(frame.timestamp_ns) - i128::from(start_ns)) as f64 / 1e9;
        let (record_id, size) = match frame.kind {
            FrameKind::Remote { .. } => (REMOTE_RECORD, REMOTE_RECORD_BYTES),
            FrameKind::Error { .. } => (ERROR_RECORD, FRAME_RECORD_BYTES),
            FrameKind::Data { .. } | FrameKind::Fd { .. } => (DATA_RECORD, FRAME_RECORD_BYTES),
        };
        let at = data.records.len();
        data.records.resize(at + 1 + size, 0);
        let record = &mut data.records[at..];
        record[0] = record_id;
        let record = &mut record[1..];
        record[..8].copy_from_slice(&offset_s.to_le_bytes());
        record[8] = channel;
        let transmitted = frame.direction == Some(Direction::Transmitted);
        let (id, extended) = match frame.id {
            CanId::Standard(id) => (u32::from(id), false),
            CanId::Extended(id) => (id, true),
        };
        match frame.kind {
            FrameKind::Error { .. } => {
                // python-can's error messages have the default (extended) IDE.
                record[13] = 1;
                record[80] = u8::from(transmitted);
            }
            FrameKind::Remote {
                requested_len,
                len8_dlc,
            } => {
                record[9..13].copy_from_slice(&id.to_le_bytes());
                record[13] = u8::from(extended);
                record[14] = len8_dlc.unwrap_or(requested_len);
                record[16] = u8::from(transmitted);
            }
            FrameKind::Data { len8_dlc } => {
                let payload = frame.payload();
                record[9..13].copy_from_slice(&id.to_le_bytes());
                record[13] = u8::from(extended);
                record[14] = len8_dlc.unwrap_or(payload.len() as u8);
                record[15] = payload.len() as u8;
                record[16..16 + payload.len()].copy_from_slice(payload);
                record[80] = u8::from(transmitted);
            }
            FrameKind::Fd { flags } => {
                let payload = frame.payload();
                let dlc = FD_DLC_LENGTHS
                    .iter()
                    .position(|&step| step >= payload.len())
                    .unwrap_or(15);
                record[9..13].copy_from_slice(&id.to_le_bytes());
                record[13] = u8::from(extended);
                record[14] = dlc as u8;
                record[15] = FD_DLC_LENGTHS[dlc] as u8;
                record[16..16 + payload.len()].copy_from_slice(payload);
                record[80] = u8::from(transmitted);
                record[81] = 1;
                record[82] = u8::from(flags & FD_FLAG_BRS != 0);
                record[83] = u8::from(flags & FD_FLAG_ESI != 0);
            }
        }
        data.record_added(&mut self.output, usize::from(record_id), 1 + size)
    }

    /// Writes what is buffered, patches the `##DT` length and the cycle
    /// counts, and returns the output (positioned at its end).
    pub fn finish(mut self) -> io::Result<W> {
        if self.layout.is_none() {
            self.write_metadata(0)?;
        }
        if let Some(written) = self.layout.take() {
            written.data.finish(&mut self.output)?;
        }
        Ok(self.output)
    }

    /// The interface's BusChannel: `canN` is N unless taken, else the lowest
    /// free number.
    fn channel(&mut self, iface: IfaceName) -> Result<u8, Mf4WriteError> {
        if let Some(&(_, channel)) = self.channels.iter().find(|(name, _)| *name == iface) {
            return Ok(channel);
        }
        if self.channels.len() >= 256 {
            return Err(Mf4WriteError::TooManyInterfaces);
        }
        let taken =
            |channel: u8, channels: &[(IfaceName, u8)]| channels.iter().any(|&(_, c)| c == channel);
        let natural = iface
            .as_str()
            .strip_prefix("can")
            .filter(|digits| !digits.is_empty() && (digits == &"0" || !digits.starts_with('0')))
            .and_then(|digits| digits.parse::<u8>().ok())
            .filter(|&c| !taken(c, &self.channels));
        let channel = match natural {
            Some(channel) => channel,
            None => (0..=255u8)
                .find(|&c| !taken(c, &self.channels))
                .ok_or_else(|| Mf4WriteError::NoChannel(iface.as_str().to_string()))?,
        };
        self.channels.push((iface, channel));
        Ok(channel)
    }

    /// Writes the identification, header and group metadata and the `##DT`
    /// header.
    fn write_metadata(&mut self, first_ns: i64) -> io::Result<()> {
        let start_ns = first_ns.max(0) - first_ns.max(0) % 1000;
        let mut blocks = Blocks::new();
        let dg = blocks.header_and_data_group(start_ns, 1);
        let can = blocks.text(b"##TX", "CAN");
        let si = blocks.add(b"##SI", 3, &[2, 2, 0, 0, 0, 0, 0, 0]);
        blocks.link(si, 0, can);
        let time_name = blocks.text(b"##TX", "t");
        let seconds = blocks.text(b"##TX", "s");
        let groups: [(&str, u8, usize, &[Member]); 3] = [
            (
                "CAN_DataFrame",
                DATA_RECORD,
                FRAME_RECORD_BYTES,
                &FRAME_MEMBERS,
            ),
            (
                "CAN_ErrorFrame",
                ERROR_RECORD,
                FRAME_RECORD_BYTES,
                &FRAME_MEMBERS,
            ),
            (
                "CAN_RemoteFrame",
                REMOTE_RECORD,
                REMOTE_RECORD_BYTES,
                &REMOTE_MEMBERS,
            ),
        ];
        let mut cg_at = vec![0u64; 3];
        let mut previous_cg = None;
        for (index, (name, record_id, size, members)) in groups.into_iter().enumerate() {
            let cg = blocks.channel_group(u64::from(record_id), CG_FLAGS, size as u32, 0);
            cg_at[index] = cg;
            match previous_cg {
                None => blocks.link(dg, 1, cg),
                Some(previous) => blocks.link(previous, 0, cg),
            }
            previous_cg = Some(cg);
            blocks.link(cg, 2, can);
            blocks.link(cg, 3, si);
            let master = blocks.channel(2, 1, 4, 0, 64, 0);
            blocks.link(master, 2, time_name);
            blocks.link(master, 6, seconds);
            blocks.link(cg, 1, master);
            let structure = blocks.channel(0, 0, 10, 8, (size as u32 - 8) * 8, CN_FLAG_BUS_EVENT);
            let structure_name = blocks.text(b"##TX", name);
            blocks.link(structure, 2, structure_name);
            blocks.link(structure, 3, si);
            blocks.link(master, 0, structure);
            let mut previous = None;
            for &(member, byte, bits, data_type) in members {
                let cn = blocks.channel(0, 0, data_type, byte, bits, CN_FLAG_BUS_EVENT);
                let member_name = blocks.text(b"##TX", &format!("{name}.{member}"));
                blocks.link(cn, 2, member_name);
                match previous {
                    None => blocks.link(structure, 1, cn),
                    Some(previous) => blocks.link(previous, 0, cn),
                }
                previous = Some(cn);
            }
        }
        let data = UnsortedData::start(&mut self.output, blocks, dg, cg_at)?;
        self.layout = Some(Written { start_ns, data });
        Ok(())
    }
}
