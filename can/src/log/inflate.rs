//! zlib blocks inflated on a second thread, in the order they are sent:
//! BLF log containers and MF4 `##DZ` blocks. Inflating (and un-transposing
//! MF4's transposed blocks) is a third to a half of reading a compressed
//! log, so the readers send the block after the one they parse and it is
//! ready when they get there. Memory stays at a few blocks.
//!
//! One [`InflateJob`] type and one [`Inflater`] thread serve both formats:
//! the readers differ in where the zlib stream sits in a block and whether
//! its bytes are transposed, which are fields of the job.

use std::ops::Range;
use std::sync::mpsc;

use flate2::{Decompress, FlushDecompress, Status};

/// One block's zlib data to inflate, and where to.
#[derive(Default)]
pub(crate) struct InflateJob {
    /// The block as read; the zlib stream is `compressed[stream]`.
    pub compressed: Vec<u8>,
    pub stream: Range<usize>,
    /// The length the block states: a stream that does not end at exactly
    /// this length is not the block's.
    pub uncompressed: usize,
    /// MF4 transposed deflate: the record size (the stream holds byte 0 of
    /// every record, then byte 1, ...); 0 when not transposed.
    pub transposed_columns: usize,
    /// Bytes left free before the inflated ones in `out`, for the reader
    /// to put the start of a record that began in the previous block.
    pub headroom: usize,
    /// `headroom` bytes, then the inflated (and un-transposed) ones, when
    /// `inflated`.
    pub out: Vec<u8>,
    pub inflated: bool,
    /// Which block this is, for a reader with several in flight (MF4: its
    /// file offset).
    pub block: u64,
    /// Where a transposed block is inflated before it is un-transposed.
    pub scratch: Vec<u8>,
}

impl InflateJob {
    /// Inflates in one call (and un-transposes), to `out[headroom..]`.
    pub fn run(&mut self) {
        let stream = self.compressed.get(self.stream.clone()).unwrap_or(&[]);
        let mut inflater = Decompress::new(true);
        self.out.clear();
        self.out.resize(self.headroom, 0);
        if self.transposed_columns == 0 {
            // Into the spare capacity: no zeroing first.
            self.out.reserve(self.uncompressed);
            let inflated = inflater.decompress_vec(stream, &mut self.out, FlushDecompress::Finish);
            self.inflated = matches!(inflated, Ok(Status::StreamEnd))
                && inflater.total_out() == self.uncompressed as u64;
            return;
        }
        self.scratch.clear();
        self.scratch.reserve(self.uncompressed);
        let inflated = inflater.decompress_vec(stream, &mut self.scratch, FlushDecompress::Finish);
        self.inflated = matches!(inflated, Ok(Status::StreamEnd))
            && inflater.total_out() == self.uncompressed as u64;
        if self.inflated {
            // `columns` runs of `lines` bytes, then the rest as is.
            let columns = self.transposed_columns;
            let runs = self.uncompressed / columns * columns;
            self.out.resize(self.headroom + self.uncompressed, 0);
            let records = &mut self.out[self.headroom..];
            untranspose(
                &self.scratch[..runs],
                &mut records[..runs],
                runs / columns,
                columns,
            );
            records[runs..].copy_from_slice(&self.scratch[runs..]);
        }
    }
}

/// A thread that inflates jobs in the order they are sent. It ends when the
/// reader (the sender) is dropped.
pub(crate) struct Inflater {
    jobs: mpsc::Sender<InflateJob>,
    done: mpsc::Receiver<InflateJob>,
}

impl Inflater {
    /// `None` on a single core, or if no thread can be started: the reader
    /// then inflates in turn. Fuzzing inflates in turn too: a thread per
    /// input would make it ten times slower, and the reader's logic is the
    /// same either way.
    pub fn start(name: &str) -> Option<Self> {
        if cfg!(fuzzing) || std::thread::available_parallelism().map_or(1, |n| n.get()) < 2 {
            return None;
        }
        let (jobs, incoming) = mpsc::channel::<InflateJob>();
        let (finished, done) = mpsc::channel();
        std::thread::Builder::new()
            .name(name.into())
            .spawn(move || {
                for mut job in incoming {
                    job.run();
                    if finished.send(job).is_err() {
                        break;
                    }
                }
            })
            .ok()?;
        Some(Inflater { jobs, done })
    }

    /// Sends a job; gives it back if the thread has stopped.
    pub fn send(&self, job: InflateJob) -> Option<InflateJob> {
        self.jobs.send(job).err().map(|unsent| unsent.0)
    }

    /// The oldest job sent and not yet received, inflated; `None` if the
    /// thread has stopped.
    pub fn receive(&self) -> Option<InflateJob> {
        self.done.recv().ok()
    }
}

/// Undoes a transposed block: `columns` runs of `lines` bytes (byte `c` of
/// every record, then byte `c + 1`, ...) back into `lines` records of
/// `columns` bytes. Eight records by eight columns at a time, transposed
/// in registers (three rounds of swaps between words): a byte at a time,
/// this was a quarter of reading python-can's MF4 files.
pub(crate) fn untranspose(runs: &[u8], records: &mut [u8], lines: usize, columns: usize) {
    let word = |at: usize| {
        let mut bytes = [0u8; 8];
        bytes.copy_from_slice(&runs[at..at + 8]);
        u64::from_le_bytes(bytes)
    };
    let full_lines = lines - lines % 8;
    let full_columns = columns - columns % 8;
    for first_line in (0..full_lines).step_by(8) {
        for first_column in (0..full_columns).step_by(8) {
            // x[i] byte j: column first_column + i, line first_line + j.
            let mut x: [u64; 8] =
                std::array::from_fn(|i| word((first_column + i) * lines + first_line));
            transpose_8x8(&mut x);
            // Now x[j] byte i: line first_line + j, column first_column + i.
            for (j, row) in x.iter().enumerate() {
                let at = (first_line + j) * columns + first_column;
                records[at..at + 8].copy_from_slice(&row.to_le_bytes());
            }
        }
        for column in full_columns..columns {
            for line in first_line..first_line + 8 {
                records[line * columns + column] = runs[column * lines + line];
            }
        }
    }
    for line in full_lines..lines {
        for column in 0..columns {
            records[line * columns + column] = runs[column * lines + line];
        }
    }
}

/// Transposes the 8 x 8 byte matrix whose row i is `x[i]` (byte j at bit
/// 8 j): swaps of 4-byte, 2-byte and 1-byte blocks between rows.
fn transpose_8x8(x: &mut [u64; 8]) {
    for (distance, bits, mask) in [
        (4, 32, 0x0000_0000_FFFF_FFFFu64),
        (2, 16, 0x0000_FFFF_0000_FFFF),
        (1, 8, 0x00FF_00FF_00FF_00FF),
    ] {
        for i in 0..8 {
            if i & distance == 0 {
                let (a, b) = (x[i], x[i + distance]);
                x[i] = (a & mask) | ((b & mask) << bits);
                x[i + distance] = ((a >> bits) & mask) | (b & !mask);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn untranspose_is_the_bytewise_definition_for_any_shape() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        for (lines, columns) in [(0, 5), (1, 1), (7, 9), (8, 8), (16, 85), (61, 17), (64, 3)] {
            let runs: Vec<u8> = (0..lines * columns)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    state as u8
                })
                .collect();
            let mut expected = vec![0u8; lines * columns];
            for column in 0..columns {
                for line in 0..lines {
                    expected[line * columns + column] = runs[column * lines + line];
                }
            }
            let mut records = vec![0u8; lines * columns];
            untranspose(&runs, &mut records, lines, columns);
            assert_eq!(records, expected, "{lines} lines of {columns} bytes");
        }
    }
}
