//! Laying out an ASAM MDF 4 file for writing, shared by the bus-log writer
//! ([`super::mf4_write`]) and the signal writer ([`super::mf4_signals`]);
//! the block layout is [`super::mf4`]'s module doc.
//!
//! Both write the same shape, which lets a file of any length be written in
//! constant memory: the identification and header, one *unsorted* data
//! group (every record starts with its channel group's id) whose metadata
//! comes first, then one `##DT` block of records. [`UnsortedData`] buffers
//! the records and, at the end, patches the `##DT` length and each channel
//! group's cycle count (hence `Write + Seek`).

use std::io::{self, Seek, SeekFrom, Write};

/// Records go out in writes of about this size.
pub const FLUSH_BYTES: usize = 256 << 10;
/// `##CN` flag: the channel belongs to a bus event.
pub const CN_FLAG_BUS_EVENT: u32 = 1 << 10;
/// `##CN` flag: the channel's invalidation bit is valid.
pub const CN_FLAG_INVALIDATION_BIT_VALID: u32 = 1 << 1;
/// `##CN` data types.
pub const DATA_TYPE_UNSIGNED_LE: u8 = 0;
pub const DATA_TYPE_FLOAT_LE: u8 = 4;
pub const DATA_TYPE_BYTE_ARRAY: u8 = 10;

/// The metadata being laid out: the file's bytes from offset 0.
pub struct Blocks {
    pub bytes: Vec<u8>,
}

impl Default for Blocks {
    fn default() -> Self {
        Self::new()
    }
}

impl Blocks {
    /// The 64-byte identification block of an MDF 4.10 file.
    pub fn new() -> Self {
        let mut bytes = Vec::with_capacity(16 << 10);
        bytes.extend_from_slice(b"MDF     4.10    acq     ");
        bytes.extend_from_slice(&[0u8; 4]);
        bytes.extend_from_slice(&410u16.to_le_bytes());
        bytes.resize(64, 0);
        Blocks { bytes }
    }

    /// Appends a block with `links` zero links and `data`, padded to 8
    /// bytes; its file offset.
    pub fn add(&mut self, id: &[u8; 4], links: usize, data: &[u8]) -> u64 {
        let at = self.bytes.len();
        let len = 24 + 8 * links + data.len();
        let padded = len.div_ceil(8) * 8;
        self.bytes.extend_from_slice(id);
        self.bytes.extend_from_slice(&[0u8; 4]);
        // A `##DT` block's length is patched at the end; padding is part of
        // other blocks (as asammdf writes text blocks).
        let stated = if id == b"##DT" { len } else { padded };
        self.bytes.extend_from_slice(&(stated as u64).to_le_bytes());
        self.bytes.extend_from_slice(&(links as u64).to_le_bytes());
        self.bytes.resize(at + 24 + 8 * links, 0);
        self.bytes.extend_from_slice(data);
        self.bytes.resize(at + padded, 0);
        at as u64
    }

    /// A `##TX` or `##MD` block holding `text`.
    pub fn text(&mut self, id: &[u8; 4], text: &str) -> u64 {
        let mut data = text.as_bytes().to_vec();
        data.push(0);
        self.add(id, 0, &data)
    }

    /// A `##CN` block (8 links: next, composition, name, source,
    /// conversion, data, unit, comment).
    pub fn channel(
        &mut self,
        channel_type: u8,
        sync_type: u8,
        data_type: u8,
        byte: u32,
        bits: u32,
        flags: u32,
    ) -> u64 {
        self.channel_with_invalidation_bit(channel_type, sync_type, data_type, byte, bits, flags, 0)
    }

    /// [`Blocks::channel`] with the position of its invalidation bit (set
    /// `CN_FLAG_INVALIDATION_BIT_VALID` in `flags` for it to count).
    #[allow(clippy::too_many_arguments)]
    pub fn channel_with_invalidation_bit(
        &mut self,
        channel_type: u8,
        sync_type: u8,
        data_type: u8,
        byte: u32,
        bits: u32,
        flags: u32,
        invalidation_bit: u32,
    ) -> u64 {
        let mut data = [0u8; 72];
        data[0] = channel_type;
        data[1] = sync_type;
        data[2] = data_type;
        data[4..8].copy_from_slice(&byte.to_le_bytes());
        data[8..12].copy_from_slice(&bits.to_le_bytes());
        data[12..16].copy_from_slice(&flags.to_le_bytes());
        data[16..20].copy_from_slice(&invalidation_bit.to_le_bytes());
        self.add(b"##CN", 8, &data)
    }

    /// A `##CG` channel group (6 links: next, first channel, acquisition
    /// name, source, sample reduction, comment).
    pub fn channel_group(
        &mut self,
        record_id: u64,
        flags: u16,
        data_bytes: u32,
        invalidation_bytes: u32,
    ) -> u64 {
        let mut data = [0u8; 32];
        data[..8].copy_from_slice(&record_id.to_le_bytes());
        data[16..18].copy_from_slice(&flags.to_le_bytes());
        data[18..20].copy_from_slice(&u16::from(b'.').to_le_bytes());
        data[24..28].copy_from_slice(&data_bytes.to_le_bytes());
        data[28..32].copy_from_slice(&invalidation_bytes.to_le_bytes());
        self.add(b"##CG", 6, &data)
    }

    /// Sets link `index` of the block at `block` to `target`.
    pub fn link(&mut self, block: u64, index: usize, target: u64) {
        let at = block as usize + 24 + 8 * index;
        self.bytes[at..at + 8].copy_from_slice(&target.to_le_bytes());
    }

    /// The header (`##HD` with the start time in ns since the epoch, UTC,
    /// and a `##FH` history entry naming acq) and one unsorted `##DG` with
    /// record ids of `record_id_bytes` (1 or 2); returns the DG's offset.
    pub fn header_and_data_group(&mut self, start_ns: i64, record_id_bytes: u8) -> u64 {
        let hd = self.add(b"##HD", 6, &{
            let mut data = [0u8; 32];
            data[..8].copy_from_slice(&(start_ns.max(0) as u64).to_le_bytes());
            data
        });
        let fh = self.add(b"##FH", 2, &[0u8; 16]);
        let fh_comment = self.text(
            b"##MD",
            concat!(
                "<FHcomment>\n<TX>created</TX>\n<tool_id>acq</tool_id>\n",
                "<tool_vendor>acq</tool_vendor>\n<tool_version>",
                env!("CARGO_PKG_VERSION"),
                "</tool_version>\n</FHcomment>"
            ),
        );
        self.link(fh, 1, fh_comment);
        self.link(hd, 1, fh);
        let dg = self.add(b"##DG", 4, &[record_id_bytes, 0, 0, 0, 0, 0, 0, 0]);
        self.link(hd, 0, dg);
        dg
    }
}

/// The records of the one unsorted data group, streamed after the metadata.
pub struct UnsortedData {
    /// File offset of the `##DT` block.
    dt_at: u64,
    /// File offsets of the channel groups, by record id - 1.
    cg_at: Vec<u64>,
    cycles: Vec<u64>,
    pub records: Vec<u8>,
    data_bytes: u64,
}

impl UnsortedData {
    /// Adds the `##DT` block to `blocks`, links it from `dg` and writes the
    /// metadata out; `cg_at` are the groups' offsets by record id - 1.
    pub fn start<W: Write>(
        output: &mut W,
        mut blocks: Blocks,
        dg: u64,
        cg_at: Vec<u64>,
    ) -> io::Result<Self> {
        let dt_at = blocks.add(b"##DT", 0, &[]);
        blocks.link(dg, 2, dt_at);
        output.write_all(&blocks.bytes)?;
        Ok(UnsortedData {
            dt_at,
            cycles: vec![0; cg_at.len()],
            cg_at,
            records: Vec::with_capacity(FLUSH_BYTES + 1024),
            data_bytes: 0,
        })
    }

    /// Counts a record of `bytes` (its id included) just appended to
    /// `records` for the group of `record_id`, and writes out what is
    /// buffered once it is large.
    pub fn record_added<W: Write>(
        &mut self,
        output: &mut W,
        record_id: usize,
        bytes: usize,
    ) -> io::Result<()> {
        self.cycles[record_id - 1] += 1;
        self.data_bytes += bytes as u64;
        if self.records.len() >= FLUSH_BYTES {
            output.write_all(&self.records)?;
            self.records.clear();
        }
        Ok(())
    }

    /// Writes what is buffered, patches the `##DT` length and the cycle
    /// counts, pads the file to 8 bytes and leaves the output at its end.
    pub fn finish<W: Write + Seek>(self, output: &mut W) -> io::Result<()> {
        output.write_all(&self.records)?;
        let end = self.dt_at + 24 + self.data_bytes;
        output.seek(SeekFrom::Start(self.dt_at + 8))?;
        output.write_all(&(24 + self.data_bytes).to_le_bytes())?;
        for (cg_at, cycles) in self.cg_at.iter().zip(&self.cycles) {
            // The cycle count follows the 6 links and the record id.
            output.seek(SeekFrom::Start(cg_at + 24 + 6 * 8 + 8))?;
            output.write_all(&cycles.to_le_bytes())?;
        }
        output.seek(SeekFrom::Start(end))?;
        // Blocks are 8-byte aligned: pad the end of the file too.
        let padding = (8 - end % 8) % 8;
        output.write_all(&[0u8; 8][..padding as usize])?;
        output.flush()
    }
}
