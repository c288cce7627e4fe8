//! `acq import`: a session made from logger files, as if `acq record` had
//! recorded it. A data logger rides on the machine for days and writes a
//! file every few minutes (several loggers, several buses); this joins them
//! into one session directory that every later command reads as it reads a
//! recorded one.
//!
//! - The frames of every file go to the session's `raw.log` (candump `-L`,
//!   rotated as `acq record` rotates it) in time order: the files are opened
//!   in the order of their first frames and merged frame by frame, so split
//!   files join end to end and two loggers' files interleave, with only
//!   the files that overlap in time open at once.
//! - Each logged interface becomes the session's interface of the same
//!   name, or the one `--bus LOGGED=SESSION` names; the rig's buses are
//!   matched to them as for a recording.
//! - The files are never modified: each is named in `session.toml`
//!   (`[[source]]`) with its SHA-256, size, frames, interfaces and time
//!   span, and copied byte for byte into `sources/` when asked.
//! - Gaps and overlaps between files on the same interface are named in the
//!   session's notes; a file given twice (the same bytes) is refused.
//! - `raw.log` is written under a temporary name and renamed, then
//!   `session.toml` is written last: an interrupted import leaves no
//!   session that looks whole.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BTreeSet, BinaryHeap};
use std::fs;
use std::path::{Path, PathBuf};

use acq_can::{Frame, IfaceName, LogFormat};
use acq_error::{AcqError, Result};
use acq_io::input::{open_log, LogInput};
use acq_io::session::{self, InterfaceRecord, SessionFile, SessionInfo, SourceLog};
use acq_rig::Rig;

use crate::record::{copy_rig, prepare_dir, rawlog::RawLog};

/// A gap between two files of one interface longer than this is named: a
/// logger splits its files without losing a frame, so a longer pause is a
/// power cycle or a missing file.
pub const NAMED_GAP_NS: i64 = 1_000_000_000;
/// An overlap longer than this is named: a recorder's frame times step
/// back by a fraction of a millisecond where its readers hand over, two
/// loggers on one bus overlap by minutes.
pub const NAMED_OVERLAP_NS: i64 = 10_000_000;

/// What `acq import` was asked to do.
pub struct ImportOptions {
    pub logs: Vec<PathBuf>,
    pub rig: Option<Rig>,
    pub session_dir: PathBuf,
    /// Logged interface -> the session's, for every file or for some.
    pub bus_map: Vec<BusMapping>,
    /// Copy each file into `sources/` (else only named, with its hash).
    pub copy_sources: bool,
    /// Skip malformed records (counted in the source's notes) instead of
    /// stopping at the first.
    pub skip_bad: bool,
    pub max_file_bytes: u64,
    pub command_line: String,
    /// Told as each file is opened in the merge (its number from 1, how
    /// many, its path): progress for a day of files.
    pub on_file: FileProgress,
}

/// Frames logged on one interface as the session's another, in every
/// file or in some (`--bus [FILES:]LOGGED=SESSION`).
pub use acq_rig::BusMapping;

/// Told as each file is opened: its number from 1, how many, its path.
pub type FileProgress = Box<dyn FnMut(usize, usize, &Path)>;

/// What an import made.
pub struct ImportSummary {
    pub session_dir: PathBuf,
    pub session: SessionFile,
}

/// One input file, scanned before the merge.
struct Scanned {
    path: PathBuf,
    format: LogFormat,
    sha256: String,
    bytes: u64,
    /// Its first frame's time: the order the files are opened in.
    first_ns: i64,
}

/// One file in the merge: its reader and its next frame.
struct Open {
    input: LogInput,
    source: usize,
}

/// Makes a session of logger files (see the module doc).
pub fn import(mut options: ImportOptions) -> Result<ImportSummary> {
    let session_dir = options.session_dir.clone();
    let dir = session_dir.as_path();
    let mut scanned = scan(&options.logs, options.skip_bad)?;
    scanned.sort_by_key(|s| s.first_ns);
    prepare_dir(dir)?;
    let mut sources: Vec<SourceLog> = scanned
        .iter()
        .map(|s| SourceLog {
            path: s.path.display().to_string(),
            format: format_name(s.format).into(),
            bytes: s.bytes,
            sha256: s.sha256.clone(),
            ..Default::default()
        })
        .collect();
    let temporary = dir.join(".import");
    let written = write_raw_log(&temporary, &scanned, &mut options, &mut sources);
    let Written {
        interfaces,
        raw_files,
    } = match written {
        Ok(written) => written,
        Err(error) => {
            let _ = fs::remove_dir_all(&temporary);
            return Err(error);
        }
    };
    let mut notes = gaps_and_overlaps(&sources);
    let names: Vec<IfaceName> = interfaces.iter().map(|(name, _)| *name).collect();
    let mut rig = options.rig;
    if let Some(rig) = &mut rig {
        let assigned = rig.assign_interfaces(&names).map_err(|e| {
            AcqError::Config(format!(
                "{}: {e}; the files' frames were on {}: map the logged interfaces onto the rig's with --bus LOGGED=RIG, or --bus FOLDER:LOGGED=RIG where two loggers log under one name",
                rig.path.display(),
                names.iter().map(IfaceName::as_str).collect::<Vec<_>>().join(", ")
            ))
        });
        match assigned {
            Ok(assigned) => notes.extend(assigned),
            Err(error) => {
                let _ = fs::remove_dir_all(&temporary);
                return Err(error);
            }
        }
    }
    // The raw files move into the session only once whole.
    for name in &raw_files {
        fs::rename(temporary.join(name), dir.join(name))
            .map_err(|e| AcqError::io(format!("moving {name} into {}", dir.display()), e))?;
    }
    fs::remove_dir(&temporary)
        .map_err(|e| AcqError::io(format!("removing {}", temporary.display()), e))?;
    if options.copy_sources {
        copy_sources(dir, &scanned, &mut sources)?;
    }
    let interfaces: Vec<InterfaceRecord> =
        interfaces.into_iter().map(|(_, record)| record).collect();
    let first = interfaces
        .iter()
        .filter_map(|i| i.first_frame_unix_ns)
        .min()
        .unwrap_or(0);
    let last = interfaces.iter().filter_map(|i| i.last_frame_unix_ns).max();
    let frames = interfaces.iter().map(|i| i.frames).sum();
    let session = SessionFile {
        session: SessionInfo {
            format_version: session::FORMAT_VERSION,
            software: format!("acq {}", env!("CARGO_PKG_VERSION")),
            host: session::host_name(),
            command: options.command_line,
            started_utc: session::utc_text(first),
            started_unix_ns: first,
            stop_requested_unix_ns: None,
            stopped_utc: last.map(session::utc_text),
            stopped_unix_ns: last,
            ended: format!(
                "imported from {} logger file{} (acq import)",
                sources.len(),
                if sources.len() == 1 { "" } else { "s" }
            ),
            raw_files,
            frames,
            dropped_by_kernel: 0,
            notes,
        },
        interface: interfaces,
        rig: rig.as_ref().map(|rig| copy_rig(rig, dir)).transpose()?,
        sensor: Vec::new(),
        source: sources,
    };
    session::write_toml_file(
        dir,
        session::SESSION_FILE,
        "# Written by acq import from logger files; see docs/src/live.md, \"A session from logger files\".\n",
        &session,
    )
    .map_err(|e| {
        AcqError::io(
            format!("writing {}", dir.join(session::SESSION_FILE).display()),
            e,
        )
    })?;
    Ok(ImportSummary {
        session_dir: dir.to_owned(),
        session,
    })
}

/// Writes the frames of every file, merged by time, to a raw log in the
/// fresh folder `temporary`: each interface's counts (by name) and the raw
/// files' names. Each source learns its interfaces.
fn write_raw_log(
    temporary: &Path,
    scanned: &[Scanned],
    options: &mut ImportOptions,
    sources: &mut [SourceLog],
) -> Result<Written> {
    // A fresh folder (what an interrupted import left is cleared): nothing
    // in it can be a link the raw log would follow.
    if fs::symlink_metadata(temporary).is_ok() {
        fs::remove_dir_all(temporary)
            .map_err(|e| AcqError::io(format!("clearing {}", temporary.display()), e))?;
    }
    fs::create_dir(temporary)
        .map_err(|e| AcqError::io(format!("creating {}", temporary.display()), e))?;
    let mut raw = RawLog::create(temporary, options.max_file_bytes).map_err(|e| {
        AcqError::io(
            format!("creating the raw log in {}", temporary.display()),
            e,
        )
    })?;
    // A handful of buses: searched, not hashed, per frame.
    let mut interfaces: Vec<(IfaceName, InterfaceRecord)> = Vec::new();
    // Per file, each (logged, session) interface pair its frames had.
    let mut logged: Vec<Vec<(IfaceName, IfaceName)>> = vec![Vec::new(); scanned.len()];
    // Each file's mapping, found once: the first pair for an interface wins.
    let maps: Vec<Vec<(IfaceName, IfaceName)>> = scanned
        .iter()
        .map(|file| BusMapping::for_file(&options.bus_map, &file.path))
        .collect();
    let on_file = &mut *options.on_file;
    merge(
        scanned,
        options.skip_bad,
        sources,
        on_file,
        |source, mut frame| {
            let logged_on = frame.iface;
            frame.iface = maps[source]
                .iter()
                .find(|(from, _)| *from == logged_on)
                .map_or(logged_on, |(_, to)| *to);
            if !logged[source].contains(&(logged_on, frame.iface)) {
                logged[source].push((logged_on, frame.iface));
            }
            let record = match interfaces.iter().position(|(name, _)| *name == frame.iface) {
                Some(index) => &mut interfaces[index].1,
                None => {
                    let record = InterfaceRecord::new(frame.iface.as_str(), "log");
                    interfaces.push((frame.iface, record));
                    &mut interfaces.last_mut().expect("just pushed").1
                }
            };
            record.count(&frame);
            raw.push(&frame);
            if raw.pending_bytes() >= 1 << 20 {
                raw.flush()
                    .map_err(|e| AcqError::io("writing the raw log", e))?;
            }
            Ok(())
        },
    )?;
    interfaces.sort_by(|a, b| a.0.as_str().cmp(b.0.as_str()));
    raw.flush()
        .and_then(|()| raw.sync())
        .map_err(|e| AcqError::io("writing the raw log", e))?;
    for (source, pairs) in sources.iter_mut().zip(&logged) {
        source.interfaces = pairs
            .iter()
            .map(|(from, to)| match from == to {
                true => from.to_string(),
                false => format!("{from} -> {to}"),
            })
            .collect();
    }
    Ok(Written {
        interfaces,
        raw_files: raw.files().to_vec(),
    })
}

/// What [`write_raw_log`] wrote.
struct Written {
    /// Each session interface's counts, by name.
    interfaces: Vec<(IfaceName, InterfaceRecord)>,
    raw_files: Vec<String>,
}

/// Each file's hash, size, format and first frame; a file given twice is
/// refused.
fn scan(paths: &[PathBuf], skip_bad: bool) -> Result<Vec<Scanned>> {
    if paths.is_empty() {
        return Err(AcqError::Config(
            "no logger file given: acq import LOG... --out SESSION".into(),
        ));
    }
    let mut scanned: Vec<Scanned> = Vec::with_capacity(paths.len());
    for path in paths {
        if path.as_os_str() == "-" || !fs::metadata(path).is_ok_and(|m| m.is_file()) {
            return Err(AcqError::Config(format!(
                "{}: not a regular file; acq import reads logger files (MF4, BLF, ASC, candump), not stdin, folders or devices",
                path.display()
            )));
        }
        let (sha256, bytes) = session::sha256_file(path).map_err(|e| AcqError::open(path, e))?;
        if let Some(twin) = scanned.iter().find(|s| s.sha256 == sha256) {
            return Err(AcqError::Config(format!(
                "{}: the same bytes as {}: a file given twice would count its frames twice",
                path.display(),
                twin.path.display()
            )));
        }
        let mut input = open_log(path)?;
        let mut skipped = 0;
        let first = loop {
            match input.next_frame() {
                Err(AcqError::Malformed(_)) if skip_bad => skipped += 1,
                other => break other?,
            }
        };
        let Some(first_ns) = first.map(|frame| frame.timestamp_ns) else {
            return Err(acq_io::input::no_frame_read(&input.name, skipped));
        };
        scanned.push(Scanned {
            path: path.clone(),
            format: input.format,
            sha256,
            bytes,
            first_ns,
        });
    }
    Ok(scanned)
}

/// Every frame of the files (sorted by their first frame), merged by time:
/// a file is opened when the merge reaches its first frame, so files that
/// follow each other are read one at a time. Frames of equal time keep the
/// files' order.
fn merge(
    scanned: &[Scanned],
    skip_bad: bool,
    sources: &mut [SourceLog],
    on_file: &mut dyn FnMut(usize, usize, &Path),
    mut on_frame: impl FnMut(usize, Frame) -> Result<()>,
) -> Result<()> {
    let mut open: Vec<Option<Open>> = (0..scanned.len()).map(|_| None).collect();
    // (time, file, frame): the earliest frame of each open file.
    let mut heads: BinaryHeap<Reverse<(i64, usize)>> = BinaryHeap::new();
    let mut frames_of: Vec<Option<Frame>> = vec![None; scanned.len()];
    let mut next_to_open = 0;
    loop {
        let earliest = heads.peek().map(|Reverse((time, _))| *time);
        if next_to_open < scanned.len()
            && earliest.is_none_or(|t| scanned[next_to_open].first_ns <= t)
        {
            let source = next_to_open;
            next_to_open += 1;
            on_file(next_to_open, scanned.len(), &scanned[source].path);
            let mut file = Open {
                input: open_log(&scanned[source].path)?,
                source,
            };
            if let Some(frame) = next_frame(&mut file, skip_bad, sources)? {
                heads.push(Reverse((frame.timestamp_ns, source)));
                frames_of[source] = Some(frame);
            }
            open[source] = Some(file);
            continue;
        }
        let Some(Reverse((_, source))) = heads.pop() else {
            return Ok(());
        };
        let Some(frame) = frames_of[source].take() else {
            continue;
        };
        let record = &mut sources[source];
        record.frames += 1;
        record.first_frame_unix_ns.get_or_insert(frame.timestamp_ns);
        record.last_frame_unix_ns = Some(frame.timestamp_ns);
        on_frame(source, frame)?;
        let Some(file) = open[source].as_mut() else {
            continue;
        };
        match next_frame(file, skip_bad, sources)? {
            Some(next) => {
                heads.push(Reverse((next.timestamp_ns, source)));
                frames_of[source] = Some(next);
            }
            // Closed: its reader's memory goes with it.
            None => open[source] = None,
        }
    }
}

/// The file's next frame; a malformed record stops the import, or with
/// `skip_bad` is counted in its source's notes.
fn next_frame(file: &mut Open, skip_bad: bool, sources: &mut [SourceLog]) -> Result<Option<Frame>> {
    let mut skipped = 0u64;
    let frame = loop {
        match file.input.next_frame() {
            Ok(frame) => break frame,
            Err(AcqError::Malformed(message)) if skip_bad => {
                skipped += 1;
                if skipped <= 3 {
                    eprintln!("acq: skipped {message}");
                }
            }
            Err(error) => return Err(error),
        }
    };
    let notes = &mut sources[file.source].notes;
    if skipped > 0 {
        notes.push(format!("{skipped} malformed records skipped (--skip-bad)"));
    }
    if frame.is_none() {
        notes.extend(file.input.notes().iter().cloned());
    }
    Ok(frame)
}

/// Gaps longer than [`NAMED_GAP_NS`] and overlaps longer than
/// [`NAMED_OVERLAP_NS`] between consecutive files on one interface (of the
/// session).
fn gaps_and_overlaps(sources: &[SourceLog]) -> Vec<String> {
    let mut by_interface: BTreeMap<&str, Vec<&SourceLog>> = BTreeMap::new();
    for source in sources {
        for interface in &source.interfaces {
            let session_name = interface.rsplit(" -> ").next().unwrap_or(interface);
            by_interface.entry(session_name).or_default().push(source);
        }
    }
    let mut notes = Vec::new();
    for (interface, files) in by_interface {
        for pair in files.windows(2) {
            let (before, after) = (pair[0], pair[1]);
            let (Some(end), Some(start)) = (before.last_frame_unix_ns, after.first_frame_unix_ns)
            else {
                continue;
            };
            let seconds = (start - end) as f64 / 1e9;
            if start - end > NAMED_GAP_NS {
                notes.push(format!(
                    "{interface}: a gap of {seconds:.3} s between {} (last frame {}) and {} (first frame {})",
                    before.path,
                    session::utc_text(end),
                    after.path,
                    session::utc_text(start)
                ));
            } else if end - start > NAMED_OVERLAP_NS {
                notes.push(format!(
                    "{interface}: {} and {} overlap by {:.3} s: their frames are interleaved by time (two loggers on one bus, or one file a copy of part of the other?)",
                    before.path, after.path, -seconds
                ));
            }
        }
    }
    notes
}

/// Copies each file into `DIR/sources/` byte for byte (names made unique).
fn copy_sources(dir: &Path, scanned: &[Scanned], sources: &mut [SourceLog]) -> Result<()> {
    // A new folder and new files: a link standing in the way is never
    // followed.
    let folder = dir.join("sources");
    fs::create_dir(&folder)
        .map_err(|e| AcqError::io(format!("creating {}", folder.display()), e))?;
    let mut taken = BTreeSet::new();
    for (file, source) in scanned.iter().zip(sources.iter_mut()) {
        let name = file
            .path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "log".into());
        let mut unique = name.clone();
        let mut number = 1;
        while !taken.insert(unique.clone()) {
            number += 1;
            unique = format!("{number}-{name}");
        }
        let copy = folder.join(&unique);
        let copied = fs::File::open(&file.path).and_then(|mut from| {
            let mut to = fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&copy)?;
            std::io::copy(&mut from, &mut to)?;
            to.sync_all()
        });
        copied.map_err(|e| {
            AcqError::io(
                format!("copying {} to {}", file.path.display(), copy.display()),
                e,
            )
        })?;
        let (sha256, _) = session::sha256_file(&copy).map_err(|e| AcqError::open(&copy, e))?;
        if sha256 != file.sha256 {
            return Err(AcqError::io(
                format!("copying {}", file.path.display()),
                std::io::Error::other(format!(
                    "the copy {} differs from the file read (did it change during the import?)",
                    copy.display()
                )),
            ));
        }
        source.copy = Some(format!("sources/{unique}"));
    }
    Ok(())
}

fn format_name(format: LogFormat) -> &'static str {
    match format {
        LogFormat::Candump => "candump",
        LogFormat::Asc => "asc",
        LogFormat::Blf => "blf",
        LogFormat::Mf4 => "mf4",
    }
}
