//! Opening the logs named on a command line (`-` is stdin) and walking
//! their records with the bad-line policy every command shares; and the
//! list of every file this command reads ([`note_input`]), which
//! [`crate::output`] consults so that no output replaces an input.

use std::fs::File;
use std::io::{self, BufRead, BufReader};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{channel, sync_channel, Receiver, SyncSender};
use std::sync::Mutex;

use acq_can::{FrameBatch, LogFormat, LogReader, LogRecord, ParseError, ReadError};
use acq_rig::Rig;

use acq_error::{AcqError, Result};

/// A log's read buffer. A candump log read in pieces of at least this
/// much is read past it, straight into the pieces
/// ([`LogInput::read_candump_lines`]).
pub const READ_BUFFER_BYTES: usize = 128 * 1024;

/// A file this command reads: the name it was given by, and its identity.
struct InputFile {
    path: PathBuf,
    canonical: Option<PathBuf>,
    /// (device, inode): the same file under another name or a hard link.
    identity: Option<(u64, u64)>,
}

/// Every input of this process. One list for the whole command, so that
/// every writer checks against every reader, whichever crate opened it.
static INPUTS: Mutex<Vec<InputFile>> = Mutex::new(Vec::new());

/// Notes `path` as an input of this command: no output may replace it.
/// Call it where a file is opened or found for reading; `-` (stdin) and
/// paths that do not exist are ignored.
pub fn note_input(path: &Path) {
    if path.as_os_str() == "-" {
        // Standard input redirected from a file is that file: an output
        // must not replace it either. /dev/stdin names whatever fd 0 is.
        note_input(Path::new("/dev/stdin"));
        return;
    }
    let Ok(metadata) = std::fs::metadata(path) else {
        return;
    };
    let file = InputFile {
        path: path.to_path_buf(),
        canonical: path.canonicalize().ok(),
        identity: Some((metadata.dev(), metadata.ino())),
    };
    if let Ok(mut inputs) = INPUTS.lock() {
        // Noted once: a file read again (the live page's every refresh, a
        // fuzzer's every input) does not grow the list.
        if !inputs
            .iter()
            .any(|known| known.identity == file.identity && known.path == file.path)
        {
            inputs.push(file);
        }
    }
}

/// The input (as it was named) that `path` would replace, if any: the same
/// canonical path or the same file (device and inode).
pub fn input_at(path: &Path) -> Option<PathBuf> {
    let metadata = std::fs::metadata(path).ok()?;
    let identity = (metadata.dev(), metadata.ino());
    let canonical = path.canonicalize().ok();
    let inputs = INPUTS.lock().ok()?;
    inputs
        .iter()
        .find(|input| {
            input.identity == Some(identity)
                || (canonical.is_some() && input.canonical == canonical)
        })
        .map(|input| input.path.clone())
}

/// One opened log.
pub struct LogInput {
    /// The name used in messages: the path, or `<stdin>`.
    pub name: String,
    /// What its first bytes said it is.
    pub format: LogFormat,
    reader: LogReader<Box<dyn BufRead + Send>>,
    /// What its reader told at the end, besides errors (printed too).
    notes: Vec<String>,
}

/// Opens every log up front, so a missing file fails before any output.
pub fn open_logs(paths: &[PathBuf]) -> Result<Vec<LogInput>> {
    if paths.iter().filter(|p| p.as_os_str() == "-").count() > 1 {
        return Err(AcqError::Config(
            "stdin ('-') can be given only once".into(),
        ));
    }
    paths.iter().map(|p| open_log(p)).collect()
}

/// A log read from any buffered reader (tests, benchmarks, pipes).
pub fn log_from_reader(name: impl Into<String>, raw: Box<dyn BufRead + Send>) -> Result<LogInput> {
    let name = name.into();
    let (reader, format) = LogReader::detect(raw).map_err(|e| match e {
        ReadError::Parse(error) => AcqError::Malformed(error.in_file(&name)),
        ReadError::Io(error) => AcqError::io(format!("reading {name}"), error),
    })?;
    Ok(LogInput {
        name,
        format,
        reader,
        notes: Vec::new(),
    })
}

/// A log whose format is detected from its first bytes.
pub fn open_log(path: &Path) -> Result<LogInput> {
    open_log_as(path, None)
}

/// A session's raw file: candump, as `acq record` writes it, whatever its
/// first bytes look like (a damaged one is then reported as candump, not
/// guessed to be another format).
pub fn open_session_log(path: &Path) -> Result<LogInput> {
    open_log_as(path, Some(LogFormat::Candump))
}

fn open_log_as(path: &Path, format: Option<LogFormat>) -> Result<LogInput> {
    let (name, raw, len): (String, Box<dyn BufRead + Send>, _) = if path.as_os_str() == "-" {
        note_input(path);
        (
            "<stdin>".into(),
            Box::new(BufReader::with_capacity(READ_BUFFER_BYTES, io::stdin())),
            None,
        )
    } else {
        let file = File::open(path).map_err(|e| AcqError::open(path, e))?;
        note_input(path);
        let len = file.metadata().map(|meta| meta.len()).ok();
        (
            path.display().to_string(),
            Box::new(BufReader::with_capacity(READ_BUFFER_BYTES, file)),
            len,
        )
    };
    let mut log = match format {
        Some(format) => LogInput {
            name,
            format,
            reader: LogReader::with_format(raw, format),
            notes: Vec::new(),
        },
        None => log_from_reader(name, raw)?,
    };
    if let Some(len) = len {
        log.reader.expect_len(len);
    }
    Ok(log)
}

impl LogInput {
    /// The next frame; a malformed line stops with `file:line: expected ...`.
    pub fn next_frame(&mut self) -> Result<Option<acq_can::Frame>> {
        match self.reader.next_record() {
            Ok(Some(record)) => Ok(Some(record.frame)),
            Ok(None) => {
                self.print_notes();
                Ok(None)
            }
            Err(ReadError::Parse(error)) => Err(AcqError::Malformed(error.in_file(&self.name))),
            Err(ReadError::Io(error)) => Err(AcqError::io(format!("reading {}", self.name), error)),
        }
    }
}

impl LogInput {
    /// Appends the next whole lines of a candump log to `out`: what a
    /// read of up to `bytes` brings, cut at its last newline (see
    /// [`acq_can::log::candump::CandumpReader::read_lines_into`]); 0 at the
    /// end. `None` for a log of another format. Reads of at least
    /// [`READ_BUFFER_BYTES`] go straight into `out`.
    pub fn read_candump_lines(&mut self, out: &mut Vec<u8>, bytes: usize) -> Option<Result<usize>> {
        match &mut self.reader {
            LogReader::Candump(reader) => Some(
                reader
                    .read_lines_into(out, bytes)
                    .map_err(|e| AcqError::io(format!("reading {}", self.name), e)),
            ),
            _ => None,
        }
    }

    /// Prints what the reader tells that is no error (`acq: FILE: ...`),
    /// and keeps it.
    fn print_notes(&mut self) {
        for note in self.reader.take_notes() {
            eprintln!("acq: {}: {note}", self.name);
            self.notes.push(note);
        }
    }

    /// What the reader told besides errors (a record cut at the end of an
    /// unfinalized MF4 file), once the log has ended.
    pub fn notes(&self) -> &[String] {
        &self.notes
    }
}

/// What to do with a malformed line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BadLines {
    /// Stop with `file:line: expected ...` (exit 3).
    Stop,
    /// Count it and go on (`--skip-bad`).
    Skip,
}

/// What a log that gives no frame is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmptyLogs {
    /// An error (a file the user named: nothing read is never a success).
    Refuse,
    /// Nothing to report (a session's raw log of a bus that stayed quiet).
    Allow,
}

/// Counts of the walk over the logs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScanCounts {
    pub frames: u64,
    pub malformed_lines: u64,
}

/// How many malformed lines are reported one by one before only counting.
pub const REPORTED_BAD_LINES: u64 = 10;

/// A log's malformed record found by a reader of its own (a piece of a
/// candump log read on another thread), under the bad-line policy every
/// walk over the logs shares: an error, or counted and reported.
pub fn on_bad_record(
    name: &str,
    error: ParseError,
    bad_lines: BadLines,
    counts: &mut ScanCounts,
) -> Result<()> {
    on_read_error(name, ReadError::Parse(error), bad_lines, counts)
}

/// A log read to its end by readers of its own: its notes printed, and
/// an error if it gave no frame since `before` (the counts of frames and
/// malformed records then) where `empty_logs` refuses one.
pub fn end_of_log(
    input: &mut LogInput,
    counts: &ScanCounts,
    before: (u64, u64),
    empty_logs: EmptyLogs,
) -> Result<()> {
    input.print_notes();
    refuse_if_empty(input, counts, before, empty_logs)
}

/// Calls `on_record` for every frame of every log, in order.
pub fn for_each_record(
    inputs: &mut [LogInput],
    bad_lines: BadLines,
    empty_logs: EmptyLogs,
    counts: &mut ScanCounts,
    mut on_record: impl FnMut(&str, &LogRecord<'_>) -> Result<()>,
) -> Result<()> {
    for input in inputs.iter_mut() {
        let (frames_before, skipped_before) = (counts.frames, counts.malformed_lines);
        loop {
            match input.reader.next_record() {
                Ok(Some(record)) => {
                    counts.frames += 1;
                    on_record(&input.name, &record)?;
                }
                Ok(None) => {
                    input.print_notes();
                    break;
                }
                Err(error) => on_read_error(&input.name, error, bad_lines, counts)?,
            }
        }
        refuse_if_empty(input, counts, (frames_before, skipped_before), empty_logs)?;
    }
    Ok(())
}

/// A log that gave no frame since `before` (the counts of frames and
/// malformed records then), where `empty_logs` refuses one: never an empty
/// success, with --skip-bad either: an empty table would read as
/// "measured nothing".
fn refuse_if_empty(
    input: &LogInput,
    counts: &ScanCounts,
    (frames_before, skipped_before): (u64, u64),
    empty_logs: EmptyLogs,
) -> Result<()> {
    if counts.frames == frames_before && empty_logs == EmptyLogs::Refuse {
        return Err(no_frame_read(
            &input.name,
            counts.malformed_lines - skipped_before,
        ));
    }
    Ok(())
}

/// How many frames [`for_each_batch`] reads at a time: enough that a
/// batch's own cost vanishes, few enough that its columns stay in cache.
pub const BATCH_FRAMES: usize = 4096;

/// [`for_each_record`], a batch of frames at a time (column by column,
/// [`FrameBatch`]): for a caller that needs each frame's fields only, not
/// its text. The same frames in the same order, the same counts and the
/// same errors.
pub fn for_each_batch(
    inputs: &mut [LogInput],
    bad_lines: BadLines,
    empty_logs: EmptyLogs,
    counts: &mut ScanCounts,
    mut on_batch: impl FnMut(&str, &FrameBatch) -> Result<()>,
) -> Result<()> {
    walk_batches(inputs, bad_lines, empty_logs, counts, |_, name, batch| {
        on_batch(name, &batch)?;
        Ok(Some(batch))
    })
}

/// Batches read ahead of [`for_each_batch_read_beside`]'s caller at most.
const BATCHES_AHEAD: usize = 4;

/// [`for_each_batch`] with the logs read on a thread of their own where a
/// second core is free: the next batch is read while the caller works
/// through this one. The same batches in the same order, the same counts
/// and the same errors, after the caller has had every frame read before
/// the error. A failure of the caller stops the reading.
pub fn for_each_batch_read_beside(
    inputs: &mut [LogInput],
    bad_lines: BadLines,
    empty_logs: EmptyLogs,
    counts: &mut ScanCounts,
    mut on_batch: impl FnMut(&str, &FrameBatch) -> Result<()>,
) -> Result<()> {
    if std::thread::available_parallelism().map_or(1, |n| n.get()) < 2 {
        return for_each_batch(inputs, bad_lines, empty_logs, counts, on_batch);
    }
    let names: Vec<String> = inputs.iter().map(|input| input.name.clone()).collect();
    let (full, batches) = sync_channel::<(usize, FrameBatch)>(BATCHES_AHEAD);
    // Batches come back empty, to be filled again.
    let (empty, spare) = channel::<FrameBatch>();
    let start = *counts;
    let (read, handled) = std::thread::scope(|scope| {
        let reading =
            scope.spawn(move || read_batches(inputs, bad_lines, empty_logs, start, full, spare));
        let mut handled = Ok(());
        for (log, batch) in &batches {
            handled = on_batch(&names[log], &batch);
            if handled.is_err() {
                break;
            }
            let _ = empty.send(batch);
        }
        // The reader stops at its next batch, finding nobody to take it.
        drop(batches);
        let read = reading.join().expect("reading a log does not panic");
        (read, handled)
    });
    handled?;
    *counts = read?;
    Ok(())
}

/// The reading side of [`for_each_batch_read_beside`]: each batch sent
/// to `full`. Returns the counts, or the error that stopped it; `Ok` early
/// where the caller stopped taking batches.
fn read_batches(
    inputs: &mut [LogInput],
    bad_lines: BadLines,
    empty_logs: EmptyLogs,
    mut counts: ScanCounts,
    full: SyncSender<(usize, FrameBatch)>,
    spare: Receiver<FrameBatch>,
) -> Result<ScanCounts> {
    walk_batches(
        inputs,
        bad_lines,
        empty_logs,
        &mut counts,
        |log, _, batch| {
            Ok(full
                .send((log, batch))
                .ok()
                .map(|()| spare.try_recv().unwrap_or_default()))
        },
    )?;
    Ok(counts)
}

/// Every log read a batch at a time, each filled batch handed to `deliver`
/// (with its log's place and name), which gives back the batch to fill
/// next, or `None` to stop reading.
fn walk_batches(
    inputs: &mut [LogInput],
    bad_lines: BadLines,
    empty_logs: EmptyLogs,
    counts: &mut ScanCounts,
    mut deliver: impl FnMut(usize, &str, FrameBatch) -> Result<Option<FrameBatch>>,
) -> Result<()> {
    let mut batch = FrameBatch::default();
    for (log, input) in inputs.iter_mut().enumerate() {
        let (frames_before, skipped_before) = (counts.frames, counts.malformed_lines);
        // Each log's interfaces are its own, and a reader may keep the
        // index it gave an interface from batch to batch: every batch
        // starts with the log's interfaces so far.
        let mut interfaces = Vec::new();
        loop {
            batch.clear();
            batch.interfaces = std::mem::take(&mut interfaces);
            let read = input.reader.next_batch(&mut batch, BATCH_FRAMES);
            interfaces.clone_from(&batch.interfaces);
            // The frames before a malformed record are the log's too.
            if !batch.is_empty() {
                counts.frames += batch.len() as u64;
                match deliver(log, &input.name, std::mem::take(&mut batch))? {
                    Some(next) => batch = next,
                    None => return Ok(()),
                }
            }
            match read {
                Ok(true) => {}
                Ok(false) => {
                    input.print_notes();
                    break;
                }
                Err(error) => on_read_error(&input.name, error, bad_lines, counts)?,
            }
        }
        refuse_if_empty(input, counts, (frames_before, skipped_before), empty_logs)?;
    }
    Ok(())
}

/// A read error of `input`: a malformed record stops the walk or is
/// counted and skipped, as `bad_lines` says; an I/O error stops it.
fn on_read_error(
    name: &str,
    error: ReadError,
    bad_lines: BadLines,
    counts: &mut ScanCounts,
) -> Result<()> {
    match error {
        ReadError::Parse(error) => {
            let message = error.in_file(name);
            match bad_lines {
                BadLines::Stop => Err(AcqError::Malformed(message)),
                BadLines::Skip => {
                    counts.malformed_lines += 1;
                    if counts.malformed_lines <= REPORTED_BAD_LINES {
                        eprintln!("acq: skipped {message}");
                    }
                    Ok(())
                }
            }
        }
        ReadError::Io(error) => Err(AcqError::io(format!("reading {name}"), error)),
    }
}

/// A log that gave no frame (`skipped` malformed records aside): malformed
/// input, saying what to check.
pub fn no_frame_read(name: &str, skipped: u64) -> AcqError {
    let skipped = match skipped {
        0 => String::new(),
        1 => " (its 1 malformed record skipped)".into(),
        n => format!(" (its {n} malformed records skipped)"),
    };
    AcqError::Malformed(format!(
        "{name}: no CAN frame read from it{skipped}: is it a log of frames, in a format acq reads (candump, ASC, BLF, MF4)?"
    ))
}

/// Reads a small CSV file whose header must be `expected` (cells trimmed):
/// its records with their 1-based line numbers. Errors name the file and
/// line and say what was expected.
pub fn read_csv_records(path: &Path, expected: &[&str]) -> Result<Vec<(u64, csv::StringRecord)>> {
    read_csv_records_of_any(path, &[expected]).map(|(_, records)| records)
}

/// The largest text file acq reads whole (a spec, a measured curve, a
/// case, a saved emulator): far above any real one, far below memory.
pub const MAX_TEXT_BYTES: u64 = 1 << 30;

/// A text file the user named, read whole: only a regular file (a FIFO or
/// a device would block or never end) of at most [`MAX_TEXT_BYTES`]. The
/// drop-in for `std::fs::read_to_string` wherever a path comes from the
/// user or a file of theirs.
pub fn read_text(path: &Path) -> io::Result<String> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(io::Error::other(
            "not a regular file (a FIFO or a device would block or never end); give a file",
        ));
    }
    if meta.len() > MAX_TEXT_BYTES {
        return Err(io::Error::other(format!(
            "{} bytes, more than the {MAX_TEXT_BYTES} a text input of acq may hold",
            meta.len()
        )));
    }
    std::fs::read_to_string(path)
}

/// Refuses a path that names something other than a regular file (a
/// FIFO, a device, a directory) before it is read: such a read blocks or
/// never ends. A path that does not exist passes: opening it says so.
pub fn refuse_non_file(path: &Path, what: &str) -> Result<()> {
    match std::fs::metadata(path) {
        Ok(meta) if !meta.is_file() => Err(AcqError::Config(format!(
            "{}: not a regular file; give the {what} as a file",
            path.display()
        ))),
        _ => Ok(()),
    }
}

/// As [`read_csv_records`], for a file whose header is one of `headers`
/// (a format that gained columns, newest first): which one, and the rows.
pub fn read_csv_records_of_any(
    path: &Path,
    headers: &[&[&str]],
) -> Result<(usize, Vec<(u64, csv::StringRecord)>)> {
    refuse_non_file(path, "table")?;
    note_input(path);
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .from_path(path)
        .map_err(|e| AcqError::Config(format!("cannot open {}: {e}", path.display())))?;
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| AcqError::Malformed(format!("{}:1: {e}", path.display())))?
        .iter()
        .map(str::to_string)
        .collect();
    let Some(which) = headers.iter().position(|expected| header == *expected) else {
        return Err(AcqError::Malformed(format!(
            "{}:1: expected the header {}, found {}",
            path.display(),
            headers.first().map(|h| h.join(",")).unwrap_or_default(),
            header.join(",")
        )));
    };
    let records = reader
        .records()
        .map(|record| {
            let record = record.map_err(|e| {
                let line = e.position().map_or(0, |p| p.line());
                AcqError::Malformed(format!("{}:{line}: {e}", path.display()))
            })?;
            Ok((record.position().map_or(0, |p| p.line()), record))
        })
        .collect::<Result<_>>()?;
    Ok((which, records))
}

/// Notes every file a loaded rig was read from as an input: the rig, its
/// DBC files and its sensor file (a session's copies of them included).
pub fn note_rig_inputs(rig: &Rig) {
    note_input(&rig.path);
    for bus in &rig.buses {
        for dbc in &bus.dbc_files {
            note_input(dbc);
        }
    }
    if let Some(sensor_file) = &rig.sensor_file {
        note_input(sensor_file);
    }
}

/// Loads a rig; every problem in it is a configuration error (exit 2).
pub fn load_rig(path: &Path) -> Result<Rig> {
    note_input(path);
    let rig = Rig::load(path).map_err(|e| AcqError::Config(e.to_string()))?;
    note_rig_inputs(&rig);
    for warning in &rig.warnings {
        eprintln!("acq: warning: {warning}");
    }
    Ok(rig)
}

/// The longest duration any option takes, s (about 31 years): beyond it a
/// number is a typo, and nanosecond timestamps would overflow.
pub const MAX_DURATION_S: f64 = 1e9;

/// A duration as a command line or a file gives it: `0.2s`, `1.5s`, or
/// what humantime reads (`50ms`, `2min`, `1h 30min`). Never negative, never
/// longer than [`MAX_DURATION_S`]; the message says what was expected.
pub fn parse_duration(text: &str) -> std::result::Result<std::time::Duration, String> {
    let trimmed = text.trim();
    let expected = || {
        format!(
            "{text:?}: give a duration such as 3s, 500ms, 1.5s or 1h 30min (0 to {MAX_DURATION_S} s)"
        )
    };
    let seconds = match trimmed
        .strip_suffix('s')
        .and_then(|n| n.parse::<f64>().ok())
    {
        Some(seconds) => seconds,
        None => humantime::parse_duration(trimmed)
            .map_err(|_| expected())?
            .as_secs_f64(),
    };
    if !(0.0..=MAX_DURATION_S).contains(&seconds) {
        return Err(expected());
    }
    Ok(std::time::Duration::from_secs_f64(seconds))
}

#[cfg(test)]
mod tests {
    use super::{input_at, note_input, INPUTS};

    /// A file read again and again (each refresh of the live page, each
    /// input of a fuzzer) is noted once: the list does not grow.
    #[test]
    fn a_file_noted_again_is_noted_once() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rig.toml");
        std::fs::write(&path, "x").unwrap();
        for _ in 0..1000 {
            note_input(&path);
        }
        let noted = INPUTS
            .lock()
            .unwrap()
            .iter()
            .filter(|input| input.path == path)
            .count();
        assert_eq!(noted, 1);
        assert_eq!(input_at(&path), Some(path));
    }
}
