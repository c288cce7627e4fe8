//! `raw.log`: every recorded frame as a candump `-L` line, written so that a
//! crash never leaves more than the last 100 ms unwritten and never leaves a
//! half line (a failed write is cut back to the last whole line).

use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use acq_can::log::candump::push_line;
use acq_can::Frame;

/// The rotating raw candump log of one session.
pub struct RawLog {
    dir: PathBuf,
    max_file_bytes: u64,
    file: File,
    /// Bytes of the current file known to be whole lines on disk.
    file_bytes: u64,
    /// Files written, in order (names relative to `dir`).
    files: Vec<String>,
    pending: Vec<u8>,
    pub frames: u64,
    pub bytes: u64,
    /// Frames whose timestamp was before 1970 (written as 0): hardware
    /// clocks that count from power-on.
    pub clamped_timestamps: u64,
}

pub const SINGLE_NAME: &str = "raw.log";

fn rotated_name(index: usize) -> String {
    format!("raw.{index:03}.log")
}

fn create(path: &Path) -> io::Result<File> {
    OpenOptions::new().write(true).create_new(true).open(path)
}

impl RawLog {
    /// Creates `raw.log` in `dir`; files rotate past `max_file_bytes`.
    pub fn create(dir: &Path, max_file_bytes: u64) -> io::Result<Self> {
        let file = create(&dir.join(SINGLE_NAME))?;
        Ok(RawLog {
            dir: dir.to_owned(),
            max_file_bytes: max_file_bytes.max(1),
            file,
            file_bytes: 0,
            files: vec![SINGLE_NAME.to_owned()],
            pending: Vec::with_capacity(1 << 20),
            frames: 0,
            bytes: 0,
            clamped_timestamps: 0,
        })
    }

    /// Formats a frame into the pending buffer (written by [`RawLog::flush`]).
    pub fn push(&mut self, frame: &Frame) {
        if push_line(&mut self.pending, frame).is_err() {
            let mut zero = *frame;
            zero.timestamp_ns = 0;
            self.clamped_timestamps += 1;
            // A zero timestamp always formats.
            let _ = push_line(&mut self.pending, &zero);
        }
        self.frames += 1;
    }

    /// Lines formatted but not yet written.
    pub fn pending_lines(&self) -> u64 {
        self.pending.iter().filter(|&&b| b == b'\n').count() as u64
    }

    pub fn pending_bytes(&self) -> usize {
        self.pending.len()
    }

    /// Writes the pending lines to the operating system (survives a killed
    /// process, not a power cut: see [`RawLog::sync`]). On failure (disk
    /// full) the file is cut back to its last whole line and the pending
    /// lines are kept, so nothing on disk is corrupt.
    pub fn flush(&mut self) -> io::Result<()> {
        if self.pending.is_empty() {
            return Ok(());
        }
        if self.file_bytes > 0 && self.file_bytes + self.pending.len() as u64 > self.max_file_bytes
        {
            self.rotate()?;
        }
        if let Err(error) = self.file.write_all(&self.pending) {
            let _ = self.file.set_len(self.file_bytes);
            return Err(error);
        }
        self.file_bytes += self.pending.len() as u64;
        self.bytes += self.pending.len() as u64;
        self.pending.clear();
        Ok(())
    }

    /// Forces what was written to the disk (fdatasync).
    pub fn sync(&mut self) -> io::Result<()> {
        self.file.sync_data()
    }

    fn rotate(&mut self) -> io::Result<()> {
        self.file.sync_all()?;
        if self.files.len() == 1 && self.files[0] == SINGLE_NAME {
            // The first rotation gives the first file its number.
            fs::rename(self.dir.join(SINGLE_NAME), self.dir.join(rotated_name(0)))?;
            self.files[0] = rotated_name(0);
        }
        let name = rotated_name(self.files.len());
        self.file = create(&self.dir.join(&name))?;
        self.files.push(name);
        self.file_bytes = 0;
        File::open(&self.dir)?.sync_all()
    }

    pub fn files(&self) -> &[String] {
        &self.files
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use acq_can::{CanId, IfaceName};

    fn frame(i: i64) -> Frame {
        let iface = IfaceName::new("vcan0").unwrap();
        Frame::data(
            1_700_000_000_000_000_000 + i * 1000,
            iface,
            CanId::Standard(0x100),
            &[i as u8; 8],
        )
        .unwrap()
    }

    #[test]
    fn rotation_keeps_every_line_in_order() {
        let dir = tempfile::tempdir().unwrap();
        let mut log = RawLog::create(dir.path(), 300).unwrap();
        for i in 0..20 {
            log.push(&frame(i));
            log.flush().unwrap();
        }
        assert!(log.files().len() > 2, "{:?}", log.files());
        assert_eq!(log.files()[0], "raw.000.log");
        let mut text = String::new();
        for name in log.files() {
            let part = fs::read_to_string(dir.path().join(name)).unwrap();
            assert!(part.len() <= 300, "{name} has {} bytes", part.len());
            text.push_str(&part);
        }
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 20);
        assert!(lines[19].ends_with("100#1313131313131313"), "{}", lines[19]);
        assert!(!dir.path().join("raw.log").exists());
    }

    #[test]
    fn a_failed_write_leaves_whole_lines() {
        // /dev/full fails every write with ENOSPC, like a full disk.
        let Ok(full) = OpenOptions::new().write(true).open("/dev/full") else {
            panic!("/dev/full is missing");
        };
        let dir = tempfile::tempdir().unwrap();
        let mut log = RawLog::create(dir.path(), u64::MAX).unwrap();
        log.push(&frame(1));
        log.flush().unwrap();
        log.file = full;
        log.push(&frame(2));
        let error = log.flush().unwrap_err();
        assert_eq!(error.raw_os_error(), Some(28), "{error}");
        assert!(log.pending_bytes() > 0, "unwritten lines must be kept");
        let text = fs::read_to_string(dir.path().join("raw.log")).unwrap();
        assert_eq!(text.lines().count(), 1);
        assert!(text.ends_with('\n'));
    }
}
