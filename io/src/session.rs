//! The session directory `acq record` writes, and `session.toml`, its
//! description: when, where, what was on each bus, and how it ended.
//!
//! `raw.log` (or `raw.000.log`, `raw.001.log`, ... after rotation) holds
//! every frame in candump `-L` form; `session.toml` is rewritten atomically
//! (temp file, fsync, rename) at the start, every few seconds and at the end,
//! so it is always either the old or the new version, never half of one.
//! [`repair`] rebuilds it from the raw files after a crash.

use std::collections::BTreeMap;
use std::fs::{self, File};
use std::io::{self, BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use acq_can::bus_error::BusErrorReport;
use acq_can::log::candump::parse_line;
use acq_can::{CanId, Frame};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use acq_error::{AcqError, Result};

pub const SESSION_FILE: &str = "session.toml";
pub const FORMAT_VERSION: u32 = 1;

/// `session.toml`.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct SessionFile {
    pub session: SessionInfo,
    #[serde(default)]
    pub interface: Vec<InterfaceRecord>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rig: Option<RigCopy>,
    #[serde(default)]
    pub sensor: Vec<SensorRecord>,
    /// The logger files an imported session was made from (`acq import`),
    /// in time order; none for a recorded one.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub source: Vec<SourceLog>,
}

/// One logger file a session was imported from: where it was, its bytes'
/// hash, what it held.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct SourceLog {
    /// The path as given.
    pub path: String,
    /// `candump`, `asc`, `blf` or `mf4`.
    pub format: String,
    pub bytes: u64,
    pub sha256: String,
    /// Its copy in the session (`sources/NAME`), when kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub copy: Option<String>,
    pub frames: u64,
    /// The interfaces its frames were logged on, and those they were
    /// imported as (`can1 -> can0`).
    pub interfaces: Vec<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_frame_unix_ns: Option<i64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_frame_unix_ns: Option<i64>,
    /// Malformed records skipped (`--skip-bad`) and what the reader told
    /// (a cut record at the end of an unfinalized file).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct SessionInfo {
    pub format_version: u32,
    /// `acq <version>`.
    pub software: String,
    pub host: String,
    /// The command line that recorded it.
    pub command: String,
    pub started_utc: String,
    pub started_unix_ns: i64,
    /// When the stop was asked for (signal, duration): frames the kernel
    /// stamped up to this instant are in the raw files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop_requested_unix_ns: Option<i64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stopped_utc: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stopped_unix_ns: Option<i64>,
    /// `recording` while running; then how it ended: `signal SIGINT`,
    /// `duration reached`, `disk full: ...`, `repaired after ...`.
    pub ended: String,
    /// The raw candump files, in order.
    pub raw_files: Vec<String>,
    pub frames: u64,
    /// Frames the kernel dropped from full receive queues, all interfaces.
    pub dropped_by_kernel: u64,
    /// Free-form remarks (repair notes, warnings during the recording).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// One interface's traffic.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct InterfaceRecord {
    pub name: String,
    /// `kernel` (software receive timestamps), `hardware` (the
    /// controller's clock), `process`, `log` or `unknown` (repaired).
    pub timestamp_source: String,
    pub frames: u64,
    pub error_frames: u64,
    pub bus_off: u64,
    pub error_passive: u64,
    pub controller_overflow: u64,
    pub bus_errors: u64,
    /// SO_RXQ_OVFL: frames the kernel dropped because the queue was full.
    pub dropped_by_kernel: u64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_frame_unix_ns: Option<i64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_frame_unix_ns: Option<i64>,
    /// Periods the interface was down or gone.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub outage: Vec<Outage>,
    /// Frames per CAN id, keyed as candump writes the id (3 hex digits
    /// standard, 8 extended).
    pub frame_counts: BTreeMap<String, u64>,
}

#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Outage {
    pub down_unix_ns: i64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up_unix_ns: Option<i64>,
    pub reason: String,
}

/// The rig and DBC files, copied into `rig/` with their hashes.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct RigCopy {
    pub name: String,
    pub file: CopiedFile,
    #[serde(default)]
    pub dbc: Vec<CopiedFile>,
    /// The sensor file its sensors' records come from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor_file: Option<CopiedFile>,
}

#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct CopiedFile {
    /// Where it was copied from.
    pub source: String,
    /// The copy, relative to the session directory.
    pub copy: String,
    pub sha256: String,
    /// The copy's own hash where its bytes differ from the source's (a rig
    /// file whose DBC and sensor-file paths were reduced to names); absent
    /// in sessions written before 2026-12-04.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub copy_sha256: Option<String>,
}

impl RigCopy {
    /// Checks that each copy in the session directory `dir` still has the
    /// bytes session.toml recorded: a copy changed after it was written
    /// (by hand, or to point at files elsewhere) is refused, naming it.
    pub fn check_unchanged(&self, dir: &Path) -> Result<()> {
        let copies = std::iter::once((&self.file, self.file.copy_sha256.as_deref()))
            .chain(self.dbc.iter().map(|c| (c, Some(c.sha256.as_str()))))
            .chain(
                self.sensor_file
                    .iter()
                    .map(|c| (c, Some(c.sha256.as_str()))),
            );
        for (copy, recorded) in copies {
            let Some(recorded) = recorded else { continue };
            let path = crate::output::inside(dir, &copy.copy, "a copy session.toml names")?;
            let (now, _) = sha256_file(&path).map_err(|e| AcqError::open(&path, e))?;
            if now != recorded {
                return Err(AcqError::Config(format!(
                    "{}: not the bytes {} recorded (sha256 {recorded}, now {now}): the session's copy was changed after it was written; restore it, or give the rig to use with --rig RIG.toml",
                    path.display(),
                    dir.join(SESSION_FILE).display()
                )));
            }
        }
        Ok(())
    }
}

/// What the live decoder saw of one sensor.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct SensorRecord {
    pub name: String,
    pub unit: String,
    pub expected_rate_hz: f64,
    pub samples: u64,
    /// Samples per second between the first and last sample.
    pub observed_rate_hz: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_value: Option<f64>,
    /// Silent at the end of the recording (no sample within 3 periods, or heartbeat lost).
    pub silent_at_end: bool,
    /// How many times it went silent.
    pub silences: u64,
}

/// The id text candump writes: 3 hex digits for 11-bit ids, 8 for 29-bit.
pub fn id_key(id: CanId) -> String {
    match id {
        CanId::Standard(id) => format!("{id:03X}"),
        CanId::Extended(id) => format!("{id:08X}"),
    }
}

impl InterfaceRecord {
    pub fn new(name: &str, timestamp_source: &str) -> Self {
        InterfaceRecord {
            name: name.to_owned(),
            timestamp_source: timestamp_source.to_owned(),
            ..Default::default()
        }
    }

    /// Counts one frame; returns the error report of an error frame.
    pub fn count(&mut self, frame: &Frame) -> Option<BusErrorReport> {
        self.frames += 1;
        self.first_frame_unix_ns.get_or_insert(frame.timestamp_ns);
        self.last_frame_unix_ns = Some(frame.timestamp_ns);
        if let Some(report) = BusErrorReport::from_frame(frame) {
            self.error_frames += 1;
            self.bus_off += u64::from(report.bus_off);
            self.error_passive += u64::from(report.error_passive);
            self.controller_overflow += u64::from(report.controller_overflow);
            self.bus_errors += u64::from(report.bus_error);
            return Some(report);
        }
        *self.frame_counts.entry(id_key(frame.id)).or_default() += 1;
        None
    }
}

/// RFC 3339 UTC with microseconds.
pub fn utc_text(unix_ns: i64) -> String {
    let time = UNIX_EPOCH + Duration::from_nanos(u64::try_from(unix_ns).unwrap_or(0));
    humantime::format_rfc3339_micros(time).to_string()
}

/// A directory name for a session started now: `2026-11-21T10-15-30Z`.
pub fn default_dir_name(now: SystemTime) -> String {
    let text = humantime::format_rfc3339_seconds(now).to_string();
    text.replace(':', "-")
}

pub fn host_name() -> String {
    nix::unistd::gethostname()
        .map(|h| h.to_string_lossy().into_owned())
        .unwrap_or_else(|_| "unknown".into())
}

pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The SHA-256 of a file's bytes (hex) and its length, read in pieces.
pub fn sha256_file(path: &Path) -> io::Result<(String, u64)> {
    sha256_files(&[path])
}

/// The SHA-256 of the files' bytes one after the other (hex), and their
/// total length: what changes when any of them does.
pub fn sha256_files(paths: &[&Path]) -> io::Result<(String, u64)> {
    let mut hasher = Sha256::new();
    let mut buffer = vec![0u8; 1 << 20];
    let mut bytes = 0u64;
    for path in paths {
        let mut file = File::open(path)?;
        loop {
            let read = file.read(&mut buffer)?;
            if read == 0 {
                break;
            }
            hasher.update(&buffer[..read]);
            bytes += read as u64;
        }
    }
    let hex = hasher
        .finalize()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    Ok((hex, bytes))
}

/// Writes `session.toml` atomically and durably.
pub fn write(dir: &Path, session: &SessionFile) -> io::Result<()> {
    write_toml_file(
        dir,
        SESSION_FILE,
        "# Written by acq record; see README.md \"Session directory\".\n",
        session,
    )
}

/// Writes `value` as TOML to `dir/name` after a `header` comment,
/// atomically (a temporary file renamed) and durably (file and directory
/// synced): a crash leaves the old file or the new one, never half of one.
/// The temporary is created afresh, so a link standing at its name is
/// never written through, and the rename replaces a link at `name`.
pub fn write_toml_file<T: serde::Serialize>(
    dir: &Path,
    name: &str,
    header: &str,
    value: &T,
) -> io::Result<()> {
    let text = toml::to_string(value).map_err(io::Error::other)?;
    let temporary = dir.join(format!(".{name}.tmp"));
    {
        let mut file = crate::output::create_fresh(&temporary)?;
        file.write_all(header.as_bytes())?;
        file.write_all(text.as_bytes())?;
        file.sync_all()?;
    }
    fs::rename(&temporary, dir.join(name))?;
    File::open(dir)?.sync_all()
}

/// Reads `dir/name` written by [`write_toml_file`]; `None` when it is not
/// there. A damaged file's error ends with `remedy`.
pub fn read_toml_file<T: serde::de::DeserializeOwned>(
    dir: &Path,
    name: &str,
    remedy: &str,
) -> Result<Option<T>> {
    let path = dir.join(name);
    if fs::metadata(&path).is_ok_and(|m| !m.is_file()) {
        return Err(AcqError::Config(format!(
            "{}: not a regular file; {remedy}",
            path.display()
        )));
    }
    let text = match fs::read_to_string(&path) {
        Ok(text) => {
            crate::input::note_input(&path);
            text
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(AcqError::open(&path, e)),
    };
    toml::from_str(&text).map(Some).map_err(|e| {
        // Another of the user's files at the record's name (a rig named
        // `shunt.toml`): said for what it is, never with advice to delete.
        match other_kind_of_file(&text) {
            Some(kind) => AcqError::Config(format!(
                "{}: this is {kind}, not the record acq keeps under the name {name}; move it out of the session (a session's rig lives in rig/) and run the command again",
                path.display()
            )),
            None => AcqError::Malformed(format!("{}: {e}; {remedy}", path.display())),
        }
    })
}

/// What a TOML text is when it is one of the user's own files: a rig (its
/// `[[bus]]` or `[[sensor]]`), a session's session.toml, a study spec.
fn other_kind_of_file(text: &str) -> Option<&'static str> {
    let table: toml::Table = toml::from_str(text).ok()?;
    if table.contains_key("bus") || table.contains_key("sensor") {
        Some("a rig file (it has [[bus]] or [[sensor]])")
    } else if table.contains_key("session") {
        Some("a session's session.toml")
    } else if table.contains_key("parameter") || table.contains_key("case") {
        Some("a study spec (it has [[parameter]] or [[case]])")
    } else {
        None
    }
}

/// Reads `session.toml`.
pub fn read(dir: &Path) -> Result<SessionFile> {
    let path = dir.join(SESSION_FILE);
    if fs::metadata(&path).is_ok_and(|m| !m.is_file()) {
        return Err(AcqError::Config(format!(
            "{}: not a regular file; a session's session.toml is the file acq record wrote",
            path.display()
        )));
    }
    let text = fs::read_to_string(&path).map_err(|e| AcqError::open(&path, e))?;
    toml::from_str(&text).map_err(|e| AcqError::Malformed(format!("{}: {e}", path.display())))
}

/// The raw files of a session directory in recording order.
pub fn raw_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let entries = fs::read_dir(dir).map_err(|e| AcqError::open(dir, e))?;
    let mut rotated = Vec::new();
    let mut single = None;
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name == "raw.log" {
            single = Some(entry.path());
        } else if let Some(number) = name
            .strip_prefix("raw.")
            .and_then(|rest| rest.strip_suffix(".log"))
            .filter(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
        {
            rotated.push((number.parse::<u64>().unwrap_or(u64::MAX), entry.path()));
        }
    }
    rotated.sort();
    let mut files: Vec<PathBuf> = rotated.into_iter().map(|(_, p)| p).collect();
    files.extend(single);
    for file in &files {
        // A FIFO or a device would block the reader or never end.
        if !fs::metadata(file).is_ok_and(|m| m.is_file()) {
            return Err(AcqError::Config(format!(
                "{}: not a regular file; a session's raw logs are the files acq record wrote",
                file.display()
            )));
        }
        crate::input::note_input(file);
    }
    crate::input::note_input(&dir.join(SESSION_FILE));
    Ok(files)
}

/// What [`repair`] did.
#[derive(Debug, Default)]
pub struct RepairReport {
    pub frames: u64,
    pub files: usize,
    /// Bytes of an unfinished last line cut off (a crash mid-write).
    pub truncated_bytes: u64,
    pub malformed_lines: u64,
}

/// Rebuilds `session.toml` from the raw files after a crash or kill: counts
/// every frame again, keeps what the old session file knew (start, host,
/// rig), marks how it ended, and cuts an unfinished last line so the raw
/// file replays cleanly.
pub fn repair(dir: &Path) -> Result<RepairReport> {
    let files = raw_files(dir)?;
    if files.is_empty() {
        return Err(AcqError::Config(format!(
            "{}: no raw.log or raw.NNN.log: not a session directory",
            dir.display()
        )));
    }
    let mut session = read(dir).unwrap_or_default();
    let mut report = RepairReport {
        files: files.len(),
        ..Default::default()
    };
    let mut interfaces: BTreeMap<String, InterfaceRecord> = BTreeMap::new();
    let old: BTreeMap<String, InterfaceRecord> = session
        .interface
        .iter()
        .map(|i| (i.name.clone(), i.clone()))
        .collect();
    for path in &files {
        report.truncated_bytes += cut_unfinished_line(path)?;
        let file = File::open(path).map_err(|e| AcqError::open(path, e))?;
        let mut reader = BufReader::new(file);
        let mut line = Vec::new();
        loop {
            line.clear();
            let n = reader
                .read_until(b'\n', &mut line)
                .map_err(|e| AcqError::io(format!("reading {}", path.display()), e))?;
            if n == 0 {
                break;
            }
            let text = line.strip_suffix(b"\n").unwrap_or(&line);
            let text = text.strip_suffix(b"\r").unwrap_or(text);
            match parse_line(text) {
                Ok((_, frame)) => {
                    let name = frame.iface.to_string();
                    let record = interfaces.entry(name.clone()).or_insert_with(|| {
                        let source = old
                            .get(&name)
                            .map_or("unknown", |o| o.timestamp_source.as_str());
                        let mut fresh = InterfaceRecord::new(&name, source);
                        if let Some(o) = old.get(&name) {
                            fresh.dropped_by_kernel = o.dropped_by_kernel;
                            fresh.outage = o.outage.clone();
                        }
                        fresh
                    });
                    record.count(&frame);
                    report.frames += 1;
                }
                Err(_) if line.iter().all(u8::is_ascii_whitespace) => {}
                Err(_) => report.malformed_lines += 1,
            }
        }
    }
    let first = interfaces
        .values()
        .filter_map(|i| i.first_frame_unix_ns)
        .min();
    let last = interfaces
        .values()
        .filter_map(|i| i.last_frame_unix_ns)
        .max();
    let info = &mut session.session;
    let previous_end = std::mem::take(&mut info.ended);
    if info.software.is_empty() {
        info.format_version = FORMAT_VERSION;
        info.software = format!("acq {}", env!("CARGO_PKG_VERSION"));
        info.host = "unknown".into();
        info.started_unix_ns = first.unwrap_or(0);
        info.started_utc = utc_text(info.started_unix_ns);
    }
    info.ended = if previous_end.is_empty() || previous_end == "recording" {
        "interrupted; session.toml rebuilt by `acq session repair` from the raw files".into()
    } else {
        format!("{previous_end}; session.toml rebuilt by `acq session repair`")
    };
    if let Some(last) = last {
        info.stopped_unix_ns = Some(last);
        info.stopped_utc = Some(utc_text(last));
    }
    info.raw_files = files
        .iter()
        .map(|p| {
            p.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        })
        .collect();
    info.frames = report.frames;
    info.dropped_by_kernel = interfaces.values().map(|i| i.dropped_by_kernel).sum();
    if report.truncated_bytes > 0 {
        info.notes.push(format!(
            "repair cut {} bytes of an unfinished last line",
            report.truncated_bytes
        ));
    }
    if report.malformed_lines > 0 {
        info.notes.push(format!(
            "repair found {} malformed lines",
            report.malformed_lines
        ));
    }
    session.interface = interfaces.into_values().collect();
    write(dir, &session)
        .map_err(|e| AcqError::io(format!("writing {}", dir.join(SESSION_FILE).display()), e))?;
    Ok(report)
}

/// Truncates a file after its last newline; returns the bytes cut.
fn cut_unfinished_line(path: &Path) -> Result<u64> {
    let io_error = |e| AcqError::io(format!("repairing {}", path.display()), e);
    let mut file = fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(path)
        .map_err(io_error)?;
    let length = file.metadata().map_err(io_error)?.len();
    if length == 0 {
        return Ok(0);
    }
    // Lines are short; the last newline is within the last few KiB unless the tail is garbage.
    let mut keep = 0;
    let mut end = length;
    let mut chunk = vec![0u8; 4096];
    while end > 0 {
        let start = end.saturating_sub(chunk.len() as u64);
        let size = (end - start) as usize;
        file.seek(SeekFrom::Start(start)).map_err(io_error)?;
        file.read_exact(&mut chunk[..size]).map_err(io_error)?;
        if let Some(position) = chunk[..size].iter().rposition(|&b| b == b'\n') {
            keep = start + position as u64 + 1;
            break;
        }
        end = start;
    }
    if keep < length {
        file.set_len(keep).map_err(io_error)?;
        file.sync_all().map_err(io_error)?;
    }
    Ok(length - keep)
}
