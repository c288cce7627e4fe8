//! Where command output goes (`-` is stdout), with a large buffer written
//! out in chunks: the decode hot path appends bytes to a `Vec` and never
//! calls `write` per field.
//!
//! The one rule for every output path lives here:
//! - an output never replaces an input of the same command
//!   ([`crate::input::note_input`]; compared by canonical path and by file
//!   identity), checked before anything is created or renamed;
//! - a file appears under its name only when complete ([`Output::create_complete_only`]),
//!   and a refused or failed output leaves nothing behind (the `.partial` is
//!   removed when the output is dropped unfinished);
//! - a name that comes from a file's contents becomes a plain file name
//!   ([`file_name_part`]), and a relative path from a file stays inside the
//!   directory it belongs to ([`inside`]).

use std::borrow::Cow;
use std::fs::File;
use std::io::{self, Write};
use std::path::{Component, Path, PathBuf};

use crate::input::input_at;
use acq_error::{AcqError, Result};

const FLUSH_AT_BYTES: usize = 256 * 1024;
/// A block at least this large, with nothing pending, is written as it is
/// ([`Output::take_from`]): one write call either way.
const WRITE_THROUGH_BYTES: usize = 64 * 1024;

pub struct Output {
    name: String,
    sink: Box<dyn Write + Send>,
    /// Pending bytes; commands append here directly.
    pub buffer: Vec<u8>,
    /// Written to `.0`, renamed to `.1` once complete.
    rename: Option<(PathBuf, PathBuf)>,
}

impl Output {
    /// Creates the output file (or stdout for `-` / `None`).
    pub fn create(path: Option<&Path>) -> Result<Self> {
        let (name, sink): (String, Box<dyn Write + Send>) = match path {
            None => ("<stdout>".into(), Box::new(io::stdout())),
            Some(p) if p.as_os_str() == "-" => ("<stdout>".into(), Box::new(io::stdout())),
            Some(p) => (p.display().to_string(), Box::new(create_file(p)?)),
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
        refuse_input(path)?;
        refuse_link(path)?;
        if std::fs::metadata(path).is_ok_and(|meta| !meta.is_file()) {
            return Output::create(Some(path));
        }
        let (partial, file) = create_partial(path)?;
        let mut output = Output::to_writer(path.display().to_string(), Box::new(file));
        output.rename = Some((partial, path.to_path_buf()));
        Ok(output)
    }

    /// Output to any writer (tests, benchmarks).
    pub fn to_writer(name: impl Into<String>, sink: Box<dyn Write + Send>) -> Self {
        Output {
            name: name.into(),
            sink,
            buffer: Vec::with_capacity(FLUSH_AT_BYTES + 4096),
            rename: None,
        }
    }

    /// The name errors use: the path the file will have, or `<stdout>`.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Writes the buffer out once it is large; call after each record.
    #[inline]
    pub fn maybe_flush(&mut self) -> Result<()> {
        if self.buffer.len() >= FLUSH_AT_BYTES {
            self.write_buffer()?;
        }
        Ok(())
    }

    /// Moves `bytes` to the output after the pending ones, leaving `bytes`
    /// empty with its room kept. A large block with nothing pending goes
    /// to the sink as it is: copied through the buffer it was only more
    /// memory touched (a Parquet writer hands over whole row groups).
    pub fn take_from(&mut self, bytes: &mut Vec<u8>) -> Result<()> {
        if self.buffer.is_empty() && bytes.len() >= WRITE_THROUGH_BYTES {
            self.write_out(bytes)?;
            bytes.clear();
            return Ok(());
        }
        self.buffer.append(bytes);
        self.maybe_flush()
    }

    fn write_buffer(&mut self) -> Result<()> {
        // Taken for the call and put back, its room kept; emptied once written.
        let buffer = std::mem::take(&mut self.buffer);
        let written = self.write_out(&buffer);
        self.buffer = buffer;
        if written.is_ok() {
            self.buffer.clear();
        }
        written
    }

    /// Writes `bytes` to the sink; an error names the output.
    fn write_out(&mut self, bytes: &[u8]) -> Result<()> {
        self.sink
            .write_all(bytes)
            .map_err(|e| AcqError::io(format!("writing {}", self.name), e))
    }

    /// Writes everything out and flushes the sink.
    pub fn finish(mut self) -> Result<()> {
        self.write_buffer()?;
        self.sink
            .flush()
            .map_err(|e| AcqError::io(format!("writing {}", self.name), e))?;
        if let Some((partial, complete)) = self.rename.take() {
            // Closes the file before it is renamed.
            self.sink = Box::new(io::sink());
            give_complete_name(&partial, &complete)?;
        }
        Ok(())
    }
}

/// Renames a finished `.partial` to its name (never over an input); a
/// failure removes the `.partial`.
fn give_complete_name(partial: &Path, complete: &Path) -> Result<()> {
    let renamed = refuse_input(complete).and_then(|()| {
        std::fs::rename(partial, complete).map_err(|e| {
            AcqError::io(
                format!("renaming {} to {}", partial.display(), complete.display()),
                e,
            )
        })
    });
    if renamed.is_err() {
        let _ = std::fs::remove_file(partial);
    }
    renamed
}

/// What a table file is, from its name: `.parquet` is Parquet, `.mf4`
/// MF4 (signals as channel groups), anything else (and stdout) CSV.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TableFormat {
    Csv,
    Parquet,
    Mf4,
}

impl TableFormat {
    pub fn of(path: &Path) -> Self {
        let extension = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match extension.as_deref() {
            Some("parquet") => TableFormat::Parquet,
            Some("mf4") => TableFormat::Mf4,
            _ => TableFormat::Csv,
        }
    }
}

/// Refuses an `.mf4` name for a table that is not signals over time.
pub fn refuse_mf4_table(path: &Path, what: &str) -> Result<()> {
    if TableFormat::of(path) == TableFormat::Mf4 {
        return Err(AcqError::Config(format!(
            "{}: the {what} are a table, not signals over time: write .csv or .parquet (MF4 output is for acq decode and acq align)",
            path.display()
        )));
    }
    Ok(())
}

/// Where a table goes, opened by the format its name gives: CSV and
/// Parquet stream through an [`Output`], MF4 seeks back at the end.
pub enum TableOutput {
    Csv(Output),
    Parquet(Output),
    Mf4(CompleteOnlyFile),
    /// The Parquet file's columns as Arrow record batches, handed over as
    /// they are made (the Python package's tables).
    Arrow(Box<dyn crate::arrow_sink::ArrowSink>),
}

impl TableOutput {
    /// Opens `path` (`-` is CSV on stdout); each appears under its name only
    /// when complete.
    pub fn create(path: &Path) -> Result<Self> {
        Ok(match TableFormat::of(path) {
            TableFormat::Csv => TableOutput::Csv(Output::create_complete_only(path)?),
            TableFormat::Parquet => TableOutput::Parquet(Output::create_complete_only(path)?),
            TableFormat::Mf4 => TableOutput::Mf4(CompleteOnlyFile::create(path, "an MF4 file")?),
        })
    }
}

/// A regular file written as `NAME.partial` and renamed by
/// [`CompleteOnlyFile::finish`], for writers that seek back (an MF4 log
/// patches its block lengths at the end), which an [`Output`] cannot.
/// Dropped unfinished, it removes the `.partial`.
pub struct CompleteOnlyFile {
    /// `None` once finished.
    file: Option<File>,
    partial: PathBuf,
    complete: PathBuf,
}

impl CompleteOnlyFile {
    pub fn create(path: &Path, what: &str) -> Result<Self> {
        refuse_input(path)?;
        refuse_link(path)?;
        if std::fs::metadata(path).is_ok_and(|meta| !meta.is_file()) {
            return Err(AcqError::Config(format!(
                "{}: {what} must go to a regular file (it is written, then completed in place)",
                path.display()
            )));
        }
        let (partial, file) = create_partial(path)?;
        Ok(CompleteOnlyFile {
            file: Some(file),
            partial,
            complete: path.to_path_buf(),
        })
    }

    /// The `.partial` file to write and seek in.
    pub fn file(&mut self) -> &mut File {
        self.file.as_mut().expect("written before finish")
    }

    /// Closes the file, then gives it its name.
    pub fn finish(mut self) -> Result<()> {
        // Closes the file before it is renamed.
        drop(self.file.take());
        let (partial, complete) = (
            std::mem::take(&mut self.partial),
            std::mem::take(&mut self.complete),
        );
        give_complete_name(&partial, &complete)
    }
}

/// Writers that seek take the file itself (an MF4 writer owns its output).
impl Write for CompleteOnlyFile {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        self.file().write(bytes)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.file().flush()
    }
}

impl io::Seek for CompleteOnlyFile {
    fn seek(&mut self, position: io::SeekFrom) -> io::Result<u64> {
        self.file().seek(position)
    }
}

impl Drop for CompleteOnlyFile {
    fn drop(&mut self) {
        if self.file.is_some() {
            let _ = std::fs::remove_file(&self.partial);
        }
    }
}

impl Drop for Output {
    /// An output dropped before [`Output::finish`] (an error, a refused
    /// option) leaves no `.partial` behind.
    fn drop(&mut self) {
        if let Some((partial, _)) = self.rename.take() {
            let _ = std::fs::remove_file(partial);
        }
    }
}

/// Refuses an output path that names an input of this command.
pub fn refuse_input(path: &Path) -> Result<()> {
    match input_at(path) {
        Some(input) => Err(AcqError::Config(format!(
            "refusing to write {}: it is {}, an input of this command; choose another output name",
            path.display(),
            input.display()
        ))),
        None => Ok(()),
    }
}

/// Creates (or truncates) an output file that is written in place: never
/// an input of this command. Every writer that does not go through
/// [`Output`] creates its files here.
pub fn create_file(path: &Path) -> Result<File> {
    refuse_input(path)?;
    refuse_link(path)?;
    let created = match std::fs::symlink_metadata(path) {
        // A regular file: replaced by a new one, so that another name of
        // the same file (a hard link) keeps what it held.
        Ok(meta) if meta.is_file() => create_fresh(path),
        _ => File::create(path),
    };
    created.map_err(|e| match std::fs::metadata(path) {
        Ok(meta) if meta.is_dir() => AcqError::Config(format!(
            "cannot create {}: it is a directory; give a file name",
            path.display()
        )),
        _ => AcqError::Config(format!("cannot create {}: {e}", path.display())),
    })
}

/// Refuses an output path that is a symbolic link to a regular file (or to
/// nothing): acq never writes through a link. A link to a device or a FIFO
/// (`/dev/stdout`) is where the user sends the output, and is kept.
fn refuse_link(path: &Path) -> Result<()> {
    let is_link = std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink());
    if is_link && std::fs::metadata(path).is_ok_and(|target| !target.is_file()) {
        return Ok(());
    }
    if is_link {
        return Err(AcqError::Config(format!(
            "{} is a symbolic link{}: acq does not write through links; remove it, or give the file it points to",
            path.display(),
            std::fs::read_link(path).map_or(String::new(), |to| format!(" to {}", to.display()))
        )));
    }
    Ok(())
}

/// Creates `path` afresh for writing: whatever file stands at that name (a
/// file a crash left, a link someone placed) is unlinked first, never
/// written through, and the file is created exclusively (`O_EXCL`: a link
/// placed in between makes it fail, not follow).
pub fn create_fresh(path: &Path) -> io::Result<File> {
    match std::fs::symlink_metadata(path) {
        Ok(meta) if !meta.is_dir() => std::fs::remove_file(path)?,
        _ => {}
    }
    File::options().write(true).create_new(true).open(path)
}

/// `PATH.partial`, created afresh: where a file is written before it gets
/// its name.
fn create_partial(path: &Path) -> Result<(PathBuf, File)> {
    let mut partial = path.as_os_str().to_owned();
    partial.push(".partial");
    let partial = PathBuf::from(partial);
    let file = create_fresh(&partial)
        .map_err(|e| AcqError::Config(format!("cannot create {}: {e}", partial.display())))?;
    Ok((partial, file))
}

/// Writes `bytes` to a file created afresh at `path` ([`create_fresh`]).
pub fn write_fresh(path: &Path, bytes: &[u8]) -> io::Result<()> {
    create_fresh(path)?.write_all(bytes)
}

/// Creates an output directory (and its parents) if missing; an existing
/// file of that name is a usage error that says so.
pub fn create_dir(path: &Path) -> Result<()> {
    if std::fs::metadata(path).is_ok_and(|meta| !meta.is_dir()) {
        return Err(AcqError::Config(format!(
            "{} exists and is not a directory: give a directory to write into",
            path.display()
        )));
    }
    std::fs::create_dir_all(path)
        .map_err(|e| AcqError::io(format!("creating {}", path.display()), e))
}

/// Refuses to write about `bytes` into the directory of `path` when its
/// file system has less free space, with both figures: better than a disk
/// that fills up halfway (and fills it for every other program too).
pub fn refuse_if_disk_too_small(path: &Path, bytes: u64, what: &str) -> Result<()> {
    let dir = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    let Ok(stats) = nix::sys::statvfs::statvfs(dir) else {
        return Ok(()); // unknown: the write itself will tell
    };
    // The field types are u64 here but narrower on some 32-bit targets.
    #[allow(clippy::useless_conversion)]
    let free = u64::from(stats.blocks_available()).saturating_mul(u64::from(stats.fragment_size()));
    if bytes > free {
        return Err(AcqError::Config(format!(
            "{what} would need about {:.1} GB in {}, which has {:.1} GB free; shorten it or write elsewhere",
            bytes as f64 / 1e9,
            dir.display(),
            free as f64 / 1e9
        )));
    }
    Ok(())
}

/// `relative` (a path a file gave, e.g. a spec's `output_file`) under `dir`,
/// refused when it would leave `dir`: absolute, or with a `..` component.
/// `what` names the setting in the message.
pub fn inside(dir: &Path, relative: &str, what: &str) -> Result<PathBuf> {
    let path = Path::new(relative);
    let leaves = relative.is_empty()
        || path
            .components()
            .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir));
    if leaves {
        return Err(AcqError::Config(format!(
            "{what} = {relative:?}: give a relative path inside {} (no '..', not absolute)",
            dir.display()
        )));
    }
    Ok(dir.join(path))
}

/// A name from a file's contents (a case name, a parameter name) as one
/// plain file-name part: characters other than letters, digits, `-`, `_`
/// and `.` become `_`, and leading dots go, so it can neither name another
/// directory nor hide; an empty result is `unnamed`.
pub fn file_name_part(name: &str) -> String {
    let safe: String = name
        .chars()
        .map(|c| {
            if c.is_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect();
    let safe = safe.trim_start_matches('.');
    if safe.is_empty() {
        "unnamed".into()
    } else {
        safe.to_string()
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
    #[test]
    fn a_table_format_comes_from_the_extension() {
        use super::TableFormat;
        use std::path::Path;
        assert_eq!(
            TableFormat::of(Path::new("a.parquet")),
            TableFormat::Parquet
        );
        assert_eq!(
            TableFormat::of(Path::new("A.PARQUET")),
            TableFormat::Parquet
        );
        assert_eq!(TableFormat::of(Path::new("a.mf4")), TableFormat::Mf4);
        assert_eq!(TableFormat::of(Path::new("a.csv")), TableFormat::Csv);
        assert_eq!(TableFormat::of(Path::new("-")), TableFormat::Csv);
        assert_eq!(TableFormat::of(Path::new("parquet")), TableFormat::Csv);
    }

    use super::{create_file, csv_field, file_name_part, inside, Output};
    use std::io::Read;
    use std::os::unix::fs::FileTypeExt;
    use std::path::Path;

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
    fn an_output_never_replaces_an_input_whatever_its_name() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("same.log");
        std::fs::write(&input, "(1.0) can0 123#00\n").unwrap();
        crate::input::note_input(&input);
        let link = dir.path().join("link.log");
        std::fs::hard_link(&input, &link).unwrap();
        let dotted = dir.path().join(".").join("same.log");
        for name in [&input, &link, &dotted] {
            let error = Output::create(Some(name)).err().expect("refused");
            assert!(
                error.to_string().contains("an input of this command"),
                "{error}"
            );
            assert!(Output::create_complete_only(name).is_err());
            assert!(create_file(name).is_err());
        }
        assert_eq!(
            std::fs::read_to_string(&input).unwrap(),
            "(1.0) can0 123#00\n"
        );
        assert!(Output::create(Some(&dir.path().join("other.csv"))).is_ok());
    }

    #[test]
    fn an_unfinished_output_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        let mut output = Output::create_complete_only(&path).unwrap();
        output.buffer.extend_from_slice(b"half");
        drop(output);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn paths_from_files_stay_inside() {
        let dir = Path::new("/runs/000001");
        assert_eq!(
            inside(dir, "out/result.json", "output_file").unwrap(),
            dir.join("out/result.json")
        );
        for bad in [
            "",
            "/etc/passwd",
            "../../evaluations.csv",
            "a/../../b",
            "..",
        ] {
            let error = inside(dir, bad, "output_file").unwrap_err().to_string();
            assert!(error.contains("output_file"), "{error}");
        }
        assert_eq!(file_name_part("../../../elsewhere/x"), "_.._.._elsewhere_x");
        assert_eq!(file_name_part("case 1"), "case_1");
        assert_eq!(file_name_part("..."), "unnamed");
        assert_eq!(file_name_part("Fall_2-Ä.b"), "Fall_2-Ä.b");
    }

    #[test]
    fn work_larger_than_the_free_disk_is_refused_with_both_figures() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.log");
        let error = super::refuse_if_disk_too_small(&path, u64::MAX, "the log")
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("the log would need about") && error.contains("GB free"),
            "{error}"
        );
        assert!(super::refuse_if_disk_too_small(&path, 1, "the log").is_ok());
        assert!(!path.exists());
    }

    #[test]
    fn quotes_only_when_needed() {
        assert_eq!(csv_field("kN"), "kN");
        assert_eq!(csv_field("N,m"), "\"N,m\"");
        assert_eq!(csv_field("a\"b"), "\"a\"\"b\"");
    }
}
