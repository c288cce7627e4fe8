//! Where command output goes (`-` is stdout), with a large buffer written
//! out in chunks: the decode hot path appends bytes to a `Vec` and never
//! calls `write` per field.

use std::borrow::Cow;
use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use crate::error::{AcqError, Result};

const FLUSH_AT_BYTES: usize = 256 * 1024;

pub struct Output {
    name: String,
    sink: Box<dyn Write>,
    /// Pending bytes; commands append here directly.
    pub buffer: Vec<u8>,
    /// Written to `.0`, renamed to `.1` once complete.
    rename: Option<(PathBuf, PathBuf)>,
}

impl Output {
    /// Creates the output file (or stdout for `-` / `None`).
    pub fn create(path: Option<&Path>) -> Result<Self> {
        let (name, sink): (String, Box<dyn Write>) = match path {
            None => ("<stdout>".into(), Box::new(io::stdout().lock())),
            Some(p) if p.as_os_str() == "-" => ("<stdout>".into(), Box::new(io::stdout().lock())),
            Some(p) => (
                p.display().to_string(),
                Box::new(File::create(p).map_err(|e| {
                    AcqError::Config(format!("cannot create {}: {e}", p.display()))
                })?),
            ),
        };
        Ok(Output::to_writer(name, sink))
    }

    /// Writes `contents` to `path` through [`Output::create_complete_only`]:
    /// the whole file appears at once, or none.
    pub fn write_complete(path: &Path, contents: &[u8]) -> Result<()> {
        let mut output = Self::create_complete_only(path)?;
        output.buffer.extend_from_slice(contents);
        output.finish()
    }

    /// A file that appears under its name only once complete: written as
    /// `NAME.partial`, renamed by [`Output::finish`]. A crash or an error
    /// leaves no file that looks finished. `-` is stdout. A path that
    /// exists and is not a regular file (`/dev/null`, a FIFO) is written in
    /// place: renaming over it would replace the device with a file.
    pub fn create_complete_only(path: &Path) -> Result<Self> {
        if path.as_os_str() == "-" {
            return Output::create(None);
        }
        if std::fs::metadata(path).is_ok_and(|meta| !meta.is_file()) {
            return Output::create(Some(path));
        }
        let mut partial = path.as_os_str().to_owned();
        partial.push(".partial");
        let partial = PathBuf::from(partial);
        let mut output = Output::create(Some(&partial))?;
        output.name = path.display().to_string();
        output.rename = Some((partial, path.to_path_buf()));
        Ok(output)
    }

    /// Output to any writer (tests, benchmarks).
    pub fn to_writer(name: impl Into<String>, sink: Box<dyn Write>) -> Self {
        Output {
            name: name.into(),
            sink,
            buffer: Vec::with_capacity(FLUSH_AT_BYTES + 4096),
            rename: None,
        }
    }

    /// Writes the buffer out once it is large; call after each record.
    #[inline]
    pub fn maybe_flush(&mut self) -> Result<()> {
        if self.buffer.len() >= FLUSH_AT_BYTES {
            self.write_buffer()?;
        }
        Ok(())
    }

    fn write_buffer(&mut self) -> Result<()> {
        self.sink
            .write_all(&self.buffer)
            .map_err(|e| AcqError::io(format!("writing {}", self.name), e))?;
        self.buffer.clear();
        Ok(())
    }

    /// Writes everything out and flushes the sink.
    pub fn finish(mut self) -> Result<()> {
        self.write_buffer()?;
        self.sink
            .flush()
            .map_err(|e| AcqError::io(format!("writing {}", self.name), e))?;
        if let Some((partial, complete)) = self.rename.take() {
            drop(self.sink);
            std::fs::rename(&partial, &complete).map_err(|e| {
                AcqError::io(
                    format!("renaming {} to {}", partial.display(), complete.display()),
                    e,
                )
            })?;
        }
        Ok(())
    }
}

/// A CSV field, quoted only when it must be (RFC 4180).
pub fn csv_field(text: &str) -> Cow<'_, str> {
    if text.contains([',', '"', '\n', '\r']) {
        Cow::Owned(format!("\"{}\"", text.replace('"', "\"\"")))
    } else {
        Cow::Borrowed(text)
    }
}

#[cfg(test)]
mod tests {
    use super::{csv_field, Output};
    use std::io::Read;
    use std::os::unix::fs::FileTypeExt;

    #[test]
    fn a_fifo_is_written_in_place_not_replaced_by_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("out.fifo");
        nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::S_IRWXU).unwrap();
        let reader_path = fifo.clone();
        let reader = std::thread::spawn(move || {
            let mut text = String::new();
            std::fs::File::open(reader_path)
                .unwrap()
                .read_to_string(&mut text)
                .unwrap();
            text
        });
        let mut output = Output::create_complete_only(&fifo).unwrap();
        output.buffer.extend_from_slice(b"a,b\n");
        output.finish().unwrap();
        assert_eq!(reader.join().unwrap(), "a,b\n");
        assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
        assert!(!dir.path().join("out.fifo.partial").exists());
    }

    #[test]
    fn quotes_only_when_needed() {
        assert_eq!(csv_field("kN"), "kN");
        assert_eq!(csv_field("N,m"), "\"N,m\"");
        assert_eq!(csv_field("a\"b"), "\"a\"\"b\"");
    }
}
