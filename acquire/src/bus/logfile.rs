//! A log file as a bus: a source yields the frames a log recorded on one
//! interface, as fast as they are read, with their recorded timestamps; a
//! sink appends candump `-L` lines with the frames' own timestamps (the
//! simulator writes its virtual-time traffic through it).

use std::fs::File;
use std::io::{self, BufReader, BufWriter};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use acq_can::log::candump::CandumpWriter;
use acq_can::{Frame, IfaceName, LogReader, ReadError};

use super::{Bus, BusError, FrameSink, FrameSource, OpenError, RxInfo, MAX_BATCH};

type SharedWriter = Arc<Mutex<CandumpWriter<BufWriter<File>>>>;

/// Reads from `input`, writes to `output` (created when the first sink opens).
#[derive(Clone)]
pub struct LogFileBus {
    input: Option<PathBuf>,
    output: Option<SharedWriter>,
}

impl LogFileBus {
    /// A bus whose sources read `path`.
    pub fn reading(path: &Path) -> Self {
        LogFileBus {
            input: Some(path.to_owned()),
            output: None,
        }
    }

    /// A bus whose sent frames go to a new candump log at `path` (never an
    /// input of this command: [`acq_io::output::create_file`]).
    pub fn writing(path: &Path) -> acq_error::Result<Self> {
        let file = acq_io::output::create_file(path)?;
        Ok(LogFileBus {
            input: None,
            output: Some(Arc::new(Mutex::new(CandumpWriter::new(BufWriter::new(
                file,
            ))))),
        })
    }

    /// Flushes what the sinks wrote.
    pub fn flush(&self) -> io::Result<()> {
        match &self.output {
            Some(writer) => writer.lock().unwrap_or_else(|e| e.into_inner()).flush(),
            None => Ok(()),
        }
    }
}

pub struct LogFileSource {
    name: String,
    iface: IfaceName,
    reader: LogReader<BufReader<File>>,
}

pub struct LogFileSink {
    iface: IfaceName,
    writer: SharedWriter,
}

fn io_error(iface: IfaceName, source: io::Error) -> OpenError {
    OpenError::Io {
        iface: iface.to_string(),
        source,
    }
}

impl Bus for LogFileBus {
    type Source = LogFileSource;
    type Sink = LogFileSink;

    fn open_source(&self, iface: IfaceName) -> Result<LogFileSource, OpenError> {
        let unsupported =
            || io::Error::new(io::ErrorKind::Unsupported, "this log bus is write-only");
        let path = self
            .input
            .as_ref()
            .ok_or_else(|| io_error(iface, unsupported()))?;
        let file = File::open(path).map_err(|e| io_error(iface, e))?;
        let (reader, _) = LogReader::detect(BufReader::new(file)).map_err(|e| match e {
            ReadError::Io(e) => io_error(iface, e),
            ReadError::Parse(error) => io_error(
                iface,
                io::Error::new(
                    io::ErrorKind::InvalidData,
                    error.in_file(&path.display().to_string()),
                ),
            ),
        })?;
        Ok(LogFileSource {
            name: path.display().to_string(),
            iface,
            reader,
        })
    }

    fn open_sink(&self, iface: IfaceName) -> Result<LogFileSink, OpenError> {
        let unsupported =
            || io::Error::new(io::ErrorKind::Unsupported, "this log bus is read-only");
        let writer = self
            .output
            .clone()
            .ok_or_else(|| io_error(iface, unsupported()))?;
        Ok(LogFileSink { iface, writer })
    }
}

impl FrameSource for LogFileSource {
    async fn recv_batch(&mut self, out: &mut Vec<Frame>) -> Result<RxInfo, BusError> {
        let start = out.len();
        while out.len() - start < MAX_BATCH {
            match self.reader.next_record() {
                Ok(Some(record)) if record.frame.iface == self.iface => out.push(record.frame),
                Ok(Some(_)) => {}
                Ok(None) if out.len() > start => break,
                Ok(None) => return Err(BusError::Closed),
                Err(ReadError::Parse(error)) => {
                    let detail = error.in_file(&self.name);
                    return Err(BusError::Io {
                        iface: self.iface.to_string(),
                        source: io::Error::new(io::ErrorKind::InvalidData, detail),
                    });
                }
                Err(ReadError::Io(source)) => {
                    return Err(BusError::Io {
                        iface: self.iface.to_string(),
                        source,
                    })
                }
            }
        }
        Ok(RxInfo::default())
    }

    fn timestamp_source(&self) -> &'static str {
        "log"
    }
}

impl FrameSink for LogFileSink {
    async fn send(&mut self, frame: &Frame) -> Result<(), BusError> {
        let mut frame = *frame;
        frame.iface = self.iface;
        let mut writer = self.writer.lock().unwrap_or_else(|e| e.into_inner());
        writer.write_frame(&frame).map_err(|source| BusError::Io {
            iface: self.iface.to_string(),
            source,
        })
    }
}

impl Drop for LogFileSink {
    fn drop(&mut self) {
        // The last sink's frames must reach the file even without an explicit flush.
        if let Ok(mut writer) = self.writer.lock() {
            let _ = writer.flush();
        }
    }
}
