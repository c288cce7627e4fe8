//! ASAM MDF 4 files of signals rather than frames: decoded or aligned
//! values as channel groups with units, as asammdf, CANape and MDF viewers
//! show them. Each group has a master channel `t` (f64 seconds from the
//! header's start time, unit `s`) and one f64 channel per signal with its
//! unit; a missing value (a gap, a signal its frame did not carry, a sample
//! the device marked invalid) has its invalidation bit set, and holds NaN
//! for readers that ignore the bits. The layout is [`super::mf4_blocks`]':
//! one unsorted data group, metadata first, so any length is written in
//! constant memory.
//!
//! Record of a group with n channels: the record id (1 byte, or 2 with more
//! than 255 groups), `t`, the n values (8 bytes each), then ceil(n / 8)
//! invalidation bytes (bit i of byte i / 8 for channel i, set = invalid).

use std::io::{self, Seek, Write};

use super::mf4_blocks::{Blocks, UnsortedData, CN_FLAG_INVALIDATION_BIT_VALID, DATA_TYPE_FLOAT_LE};

/// One signal of a group.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SignalChannel {
    pub name: String,
    pub unit: String,
}

/// A channel group: signals recorded at the same instants (one CAN message,
/// one sensor, the aligned table).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SignalGroup {
    pub name: String,
    pub channels: Vec<SignalChannel>,
}

/// Streaming writer of signal groups.
pub struct Mf4SignalWriter<W: Write + Seek> {
    output: W,
    groups: Vec<SignalGroup>,
    comment: Option<String>,
    record_id_bytes: usize,
    /// The start time and the records, once the metadata is written.
    layout: Option<(i64, UnsortedData)>,
}

impl<W: Write + Seek> Mf4SignalWriter<W> {
    /// A writer of these groups at the output's start; `comment` (the
    /// provenance a CSV writes as `#` lines) becomes the data group's
    /// comment. At most 65,535 groups.
    pub fn new(output: W, groups: Vec<SignalGroup>, comment: Option<String>) -> io::Result<Self> {
        let record_id_bytes = match groups.len() {
            0..=255 => 1,
            256..=65_535 => 2,
            n => {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!("{n} channel groups: an MF4 file of acq's holds at most 65,535"),
                ))
            }
        };
        Ok(Mf4SignalWriter {
            output,
            groups,
            comment,
            record_id_bytes,
            layout: None,
        })
    }

    /// Appends one record of `group` at `time_ns` (ns since the epoch);
    /// `values` has one entry per channel of the group.
    pub fn write(&mut self, group: usize, time_ns: i64, values: &[Option<f64>]) -> io::Result<()> {
        let channels = self.groups[group].channels.len();
        debug_assert_eq!(values.len(), channels);
        if self.layout.is_none() {
            self.write_metadata(time_ns)?;
        }
        let Some((start_ns, data)) = &mut self.layout else {
            return Err(io::ErrorKind::Other.into());
        };
        let record_id = group + 1;
        let size = self.record_id_bytes + 8 * (1 + channels) + channels.div_ceil(8);
        let at = data.records.len();
        data.records.resize(at + size, 0);
        let record = &mut data.records[at..];
        record[..self.record_id_bytes]
            .copy_from_slice(&(record_id as u16).to_le_bytes()[..self.record_id_bytes]);
        let record = &mut record[self.record_id_bytes..];
        let offset_s = (i128::from(time_ns) - i128::from(*start_ns)) as f64 / 1e9;
        record[..8].copy_from_slice(&offset_s.to_le_bytes());
        let invalidation = 8 * (1 + channels);
        for (i, value) in values.iter().take(channels).enumerate() {
            let bytes = value.unwrap_or(f64::NAN).to_le_bytes();
            record[8 * (1 + i)..8 * (2 + i)].copy_from_slice(&bytes);
            if value.is_none() {
                record[invalidation + i / 8] |= 1 << (i % 8);
            }
        }
        data.record_added(&mut self.output, record_id, size)
    }

    /// Writes what is buffered, patches lengths and counts; returns the
    /// output at its end. A writer without records still writes the groups.
    pub fn finish(mut self) -> io::Result<W> {
        if self.layout.is_none() {
            self.write_metadata(0)?;
        }
        if let Some((_, data)) = self.layout.take() {
            data.finish(&mut self.output)?;
        }
        Ok(self.output)
    }

    fn write_metadata(&mut self, first_ns: i64) -> io::Result<()> {
        // asammdf keeps the start as a datetime with microseconds.
        let start_ns = first_ns.max(0) - first_ns.max(0) % 1000;
        let mut blocks = Blocks::new();
        let dg = blocks.header_and_data_group(start_ns, self.record_id_bytes as u8);
        if let Some(comment) = &self.comment {
            let text = blocks.text(b"##TX", comment);
            blocks.link(dg, 3, text);
        }
        let time_name = blocks.text(b"##TX", "t");
        let seconds = blocks.text(b"##TX", "s");
        let mut cg_at = Vec::with_capacity(self.groups.len());
        let mut previous_group = None;
        for (index, group) in self.groups.iter().enumerate() {
            let channels = group.channels.len();
            let cg = blocks.channel_group(
                index as u64 + 1,
                0,
                8 * (1 + channels as u32),
                channels.div_ceil(8) as u32,
            );
            cg_at.push(cg);
            match previous_group {
                None => blocks.link(dg, 1, cg),
                Some(previous) => blocks.link(previous, 0, cg),
            }
            previous_group = Some(cg);
            let name = blocks.text(b"##TX", &group.name);
            blocks.link(cg, 2, name);
            // The master: channel type 2, synchronised on time (1).
            let master = blocks.channel(2, 1, DATA_TYPE_FLOAT_LE, 0, 64, 0);
            blocks.link(master, 2, time_name);
            blocks.link(master, 6, seconds);
            blocks.link(cg, 1, master);
            let mut previous = master;
            for (i, channel) in group.channels.iter().enumerate() {
                let cn = blocks.channel_with_invalidation_bit(
                    0,
                    0,
                    DATA_TYPE_FLOAT_LE,
                    8 * (1 + i as u32),
                    64,
                    CN_FLAG_INVALIDATION_BIT_VALID,
                    i as u32,
                );
                let name = blocks.text(b"##TX", &channel.name);
                blocks.link(cn, 2, name);
                if !channel.unit.is_empty() {
                    let unit = blocks.text(b"##TX", &channel.unit);
                    blocks.link(cn, 6, unit);
                }
                blocks.link(previous, 0, cn);
                previous = cn;
            }
        }
        let data = UnsortedData::start(&mut self.output, blocks, dg, cg_at)?;
        self.layout = Some((start_ns, data));
        Ok(())
    }
}
