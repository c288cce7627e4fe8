//! `acq lake ingest`: sources (sessions and logger files) into the lake,
//! each once per content.
//!
//! A source is skipped when its manifest entry has its content's hash, the
//! same rig's, the same device and the files' current format; otherwise its samples are decoded
//! through the rig, written per sensor and UTC day, its holds found and
//! their measured values computed as `acq extract` does, every file
//! published by a rename, the files it no longer makes removed, and its
//! entry published last. Memory is bounded per open file (a reorder
//! window and the Parquet writer's row group), not by the source's length.

use std::collections::{HashMap, HashSet, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, MutexGuard};

use acq_analysis::extract::holds::HoldOptions;
use acq_analysis::extract::measured::write_measured_parquet_within;
use acq_analysis::extract::run::{extract_holds, HoldsReport, WindowChoice};
use acq_analysis::recording::clocks::offsets_ns;
use acq_analysis::recording::{Recording, SampleCounts};
use acq_error::{AcqError, Result};
use acq_io::output::Output;
use acq_io::parquet_table::{ColumnSpec, ColumnType, FileLayout, ParquetTable};
use acq_io::session;
use acq_rig::BusMapping;

use crate::layout::{self, HOLDS, MANIFEST_DIR, MEASURED, TABLES, TMP_DIR};
use crate::manifest::{self, Entry};
use crate::publish::{
    prepare_file, publish_file, publish_prepared_file, remove_published, ScratchDir,
};

/// Samples held back per file so that rows a little out of order (a
/// recorder's read batches interleave buses by a millisecond) are written
/// sorted by time. 2048 samples are 2.6 s of an 800 Hz sensor, 20 s of a
/// 100 Hz one: a later sample is a clock's jump, not a read's order, and is
/// counted (`out_of_order`). What is held back is encoded only when the
/// file ends, after the decoding, so a larger window lengthens that tail.
const REORDER_WINDOW: usize = 2048;

/// Rows of a samples file's row group: DuckDB's own row group size. Every
/// open file holds its row group's encoded pages until it is complete, so
/// this (times the sensors and days a source spans) bounds an ingest's
/// memory; and a row group is what engines skip by its statistics.
const ROW_GROUP_ROWS: usize = 122_880;

/// A samples file: read by every engine (Spark refuses split floats),
/// in row groups of [`ROW_GROUP_ROWS`] and pages of 4,096 rows (5 s of an
/// 800 Hz sensor: a time range prunes by the page index that finely),
/// written a page at a time (an ingest holds one file open per sensor).
const SAMPLES_LAYOUT: FileLayout = FileLayout {
    rows_per_group: Some(ROW_GROUP_ROWS),
    rows_per_page: Some(4096),
    rows_per_batch: Some(4096),
    ..FileLayout::FOR_EVERY_ENGINE
};

/// The mappings with each scope made canonical, as sources' paths are
/// (and as a Slurm job, started elsewhere, takes them), checked against
/// the inputs: a logged interface mapped twice in one scope, or a scope
/// that names no file or holds none of the inputs, is an error that says
/// so.
pub(crate) fn canonical_buses(buses: &[BusMapping], inputs: &[PathBuf]) -> Result<Vec<BusMapping>> {
    let canonical = buses
        .iter()
        .map(|mapping| {
            let files = match &mapping.files {
                None => None,
                Some(files) => Some(std::fs::canonicalize(files).map_err(|e| {
                    AcqError::Config(format!("--bus {mapping}: {} ({e})", files.display()))
                })?),
            };
            Ok(BusMapping {
                files,
                ..mapping.clone()
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let inputs: Vec<PathBuf> = inputs
        .iter()
        .filter_map(|input| std::fs::canonicalize(input).ok())
        .collect();
    BusMapping::check(&canonical, &inputs).map_err(AcqError::Config)?;
    Ok(canonical)
}

/// The `(logged, rig)` pairs of the log at `path` (canonical).
fn logged_pairs(buses: &[BusMapping], path: &Path) -> Vec<(String, String)> {
    BusMapping::for_file(buses, path)
        .into_iter()
        .map(|(logged, rig)| (logged.to_string(), rig.to_string()))
        .collect()
}

/// Every log's mapping against the rig before anything is written: a bus
/// the rig does not have, or two of its buses on one logged interface, is
/// an error that names the pair (and the file, where a scope made it).
fn check_buses_against_rig(buses: &[BusMapping], inputs: &[PathBuf], rig: &Path) -> Result<()> {
    if buses.is_empty() {
        return Ok(());
    }
    let rig = acq_io::input::load_rig(rig)?;
    let mut checked = HashSet::new();
    let general = logged_pairs(buses, Path::new(""));
    let logs = inputs
        .iter()
        .filter_map(|input| std::fs::canonicalize(input).ok())
        .filter(|path| !path.is_dir());
    for (path, pairs) in std::iter::once((None, general))
        .chain(logs.map(|path| (Some(path.clone()), logged_pairs(buses, &path))))
    {
        if pairs.is_empty() || !checked.insert(pairs.clone()) {
            continue;
        }
        rig.clone()
            .take_logged_interfaces(&pairs)
            .map_err(|e| match path {
                Some(path) if buses.iter().any(|m| m.files.is_some()) => {
                    AcqError::Config(format!("{}: {e}", path.display()))
                }
                _ => AcqError::Config(e),
            })?;
    }
    Ok(())
}

/// What to ingest into which lake.
#[derive(Clone, Debug)]
pub struct IngestOptions {
    pub lake: PathBuf,
    /// The rig that decodes every source.
    pub rig: PathBuf,
    /// The `device` partition; `None`: the rig file's name (one rig file
    /// per machine).
    pub device: Option<String>,
    /// Frames a log has on a mapping's `logged` interface are the rig's bus
    /// on its `session` interface (a logger's `can1` as the rig's `can0`),
    /// in every log or in those under its `files`. Sessions know their
    /// interfaces and take none.
    pub buses: Vec<BusMapping>,
    /// Sources decoded at once, each on a thread of its own; 0: one per
    /// core of this machine. A source's memory is bounded (see the module
    /// doc), so memory grows with this, not with the backlog.
    pub jobs: usize,
}

/// What became of one source.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// Its entry has its content's hash: nothing written.
    Unchanged,
    /// Decoded and published; `replaced` when an earlier content's files
    /// were in the lake.
    Ingested { replaced: bool, entry: Box<Entry> },
    /// Not ingested, and why (the lake keeps what it had of it); the
    /// other sources go on.
    Failed(String),
}

#[derive(Clone, Debug, PartialEq)]
pub struct SourceReport {
    pub source: PathBuf,
    pub outcome: Outcome,
}

/// The device partition of `options`: as given, else the rig file's name.
pub fn device_of(options: &IngestOptions) -> String {
    match &options.device {
        Some(device) => device.clone(),
        None => options
            .rig
            .file_stem()
            .map_or("rig".into(), |s| s.to_string_lossy().into_owned()),
    }
}

/// Ingests `inputs` into the lake, `options.jobs` sources at a time,
/// calling `on_source` as each is done; the reports in the inputs' order,
/// one per distinct source (an input named twice is ingested once).
///
/// # Errors
/// The lake cannot be written, or Ctrl-C: the sources under way stop, and
/// what was published stays whole.
pub fn ingest(
    inputs: &[PathBuf],
    options: &IngestOptions,
    on_source: impl FnMut(&SourceReport) + Send,
) -> Result<Vec<SourceReport>> {
    let lake = options.lake.as_path();
    let rig = std::fs::canonicalize(&options.rig)
        .map_err(|e| AcqError::io(format!("opening the rig {}", options.rig.display()), e))?;
    let (rig_blake3, _) = manifest::content_hash(&[&rig])
        .map_err(|e| AcqError::io(format!("reading {}", rig.display()), e))?;
    let buses = canonical_buses(&options.buses, inputs)?;
    check_buses_against_rig(&buses, inputs, &rig)?;
    acq_io::output::create_dir(lake)?;
    for dir in [MANIFEST_DIR, TMP_DIR] {
        acq_io::output::create_dir(&lake.join(dir))?;
    }
    let ingest = Ingest {
        lake,
        tmp: ScratchDir::new(lake)?,
        device: device_of(options),
        rig,
        rig_blake3,
        leftovers: Mutex::new(None),
        buses,
    };
    let mut seen = HashSet::new();
    let inputs: Vec<&PathBuf> = inputs
        .iter()
        .filter(|input| seen.insert(std::fs::canonicalize(input).unwrap_or((*input).clone())))
        .collect();
    let jobs = match options.jobs {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        jobs => jobs,
    }
    .min(inputs.len())
    .max(1);
    let next = AtomicUsize::new(0);
    let reports = Mutex::new(vec![None; inputs.len()]);
    let first_error = Mutex::new(None);
    let on_source = Mutex::new(on_source);
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| loop {
                let index = next.fetch_add(1, Ordering::SeqCst);
                if index >= inputs.len() || lock(&first_error).is_some() {
                    break;
                }
                match ingest.one(inputs[index]) {
                    Ok(report) => {
                        (lock(&on_source))(&report);
                        lock(&reports)[index] = Some(report);
                    }
                    Err(e) => {
                        lock(&first_error).get_or_insert(e);
                        break;
                    }
                }
            });
        }
    });
    if let Some(e) = first_error.into_inner().unwrap_or_else(|e| e.into_inner()) {
        return Err(e);
    }
    let reports = reports.into_inner().unwrap_or_else(|e| e.into_inner());
    Ok(reports.into_iter().flatten().collect())
}

/// A lock whose holder panicked is still good: each guarded value is
/// whole between statements.
fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(|e| e.into_inner())
}

/// One ingest's lake, rig and device, shared by its threads.
struct Ingest<'a> {
    lake: &'a Path,
    tmp: ScratchDir,
    rig: PathBuf,
    rig_blake3: String,
    device: String,
    /// Files of each source id, listed once when a source without an entry
    /// first needs them.
    leftovers: Mutex<Option<HashMap<String, Vec<PathBuf>>>>,
    /// Their scopes canonical, as the sources' paths are.
    buses: Vec<BusMapping>,
}

impl Ingest<'_> {
    /// The `(logged, rig)` interface pairs a source takes (a log's; a
    /// session's none).
    fn pairs_of(&self, source: &Source) -> Vec<(String, String)> {
        if source.is_session {
            return Vec::new();
        }
        logged_pairs(&self.buses, &source.path)
    }

    /// [`Ingest::pairs_of`] as the source's entry keeps them.
    fn buses_of(&self, source: &Source) -> Vec<String> {
        self.pairs_of(source)
            .iter()
            .map(|(logged, rig)| format!("{logged}={rig}"))
            .collect()
    }

    /// One source: skipped, ingested or failed; `Err` only when the lake
    /// cannot be written or on Ctrl-C.
    fn one(&self, input: &Path) -> Result<SourceReport> {
        let failed = |source: PathBuf, e: AcqError| SourceReport {
            source,
            outcome: Outcome::Failed(e.to_string()),
        };
        let source = match Source::locate(input) {
            Ok(source) => source,
            Err(e) => return Ok(failed(input.to_path_buf(), e)),
        };
        let lake = self.lake;
        let earlier = manifest::read(lake, &source.id)?;
        let decoded = match &earlier {
            Some(entry) => {
                let content = match source.content() {
                    Ok(content) => content,
                    Err(e) => return Ok(failed(source.path, e)),
                };
                if entry.format == manifest::FORMAT
                    && entry.blake3 == content.0
                    && entry.rig_blake3 == self.rig_blake3
                    && entry.device == self.device
                    && entry.buses == self.buses_of(&source)
                {
                    return Ok(SourceReport {
                        source: source.path,
                        outcome: Outcome::Unchanged,
                    });
                }
                source.decode_into(self, content)
            }
            // A source the lake has not seen is hashed while it is decoded,
            // on another core: both read it, neither waits for the other.
            None => std::thread::scope(|scope| {
                let hashing = scope.spawn(|| source.content());
                let decoded = source.decode_into(self, (String::new(), 0));
                let content = hashing.join().expect("hashing does not panic")?;
                decoded.map(|entry| Entry {
                    blake3: content.0,
                    bytes: content.1,
                    ..entry
                })
            }),
        };
        // Files of this id without an entry: an ingest killed before its
        // entry was published. They go as an earlier entry's do.
        let old_files = || -> Vec<PathBuf> {
            match &earlier {
                Some(entry) => entry.files.clone(),
                None => lock(&self.leftovers)
                    .get_or_insert_with(|| files_by_id(lake))
                    .remove(&source.id)
                    .unwrap_or_default(),
            }
        };
        let outcome = match decoded {
            Ok(mut entry) => {
                entry.rig_blake3 = self.rig_blake3.clone();
                let replaced = replace(lake, &self.tmp, &source.id, &entry, old_files())?;
                Outcome::Ingested {
                    replaced: replaced || earlier.is_some(),
                    entry: Box::new(entry),
                }
            }
            // A source that cannot be read or decoded (another rig's, a
            // damaged file) is said and left out, its entry (if any) and
            // files as they were; Ctrl-C stops the ingest.
            Err(e @ AcqError::Interrupted(_)) => return Err(e),
            Err(e) => Outcome::Failed(e.to_string()),
        };
        Ok(SourceReport {
            source: source.path,
            outcome,
        })
    }
}

/// Removes the files of a source's earlier content that its new one no
/// longer makes, then publishes its entry; whether any were removed.
fn replace(
    lake: &Path,
    scratch: &ScratchDir,
    id: &str,
    entry: &Entry,
    mut old_files: Vec<PathBuf>,
) -> Result<bool> {
    let kept: HashSet<&PathBuf> = entry.files.iter().collect();
    old_files.retain(|f| !kept.contains(f));
    for file in &old_files {
        remove_published(&lake.join(file))?;
    }
    manifest::publish(lake, scratch, id, entry)?;
    Ok(!old_files.is_empty())
}

/// A source to ingest: where it is, what it is, the files it is made of.
struct Source {
    path: PathBuf,
    id: String,
    is_session: bool,
    files: Vec<PathBuf>,
}

impl Source {
    fn locate(input: &Path) -> Result<Source> {
        let path = std::fs::canonicalize(input).map_err(|e| {
            AcqError::Config(format!(
                "{}: no such session directory or log file ({e})",
                input.display()
            ))
        })?;
        let is_session = path.is_dir();
        let files = if is_session {
            let mut files = vec![path.join(session::SESSION_FILE)];
            files.extend(session::raw_files(&path)?);
            files
        } else {
            vec![path.clone()]
        };
        Ok(Source {
            id: manifest::source_id(&path),
            path,
            is_session,
            files,
        })
    }

    /// Its content's hash and its bytes.
    fn content(&self) -> Result<(String, u64)> {
        let paths: Vec<&Path> = self.files.iter().map(PathBuf::as_path).collect();
        manifest::content_hash(&paths)
            .map_err(|e| AcqError::io(format!("reading {}", self.path.display()), e))
    }

    /// Decodes the source through `rig` and publishes its files; the entry
    /// that says what they are (not yet published).
    fn decode_into(&self, ingest: &Ingest<'_>, (blake3, bytes): (String, u64)) -> Result<Entry> {
        let (lake, tmp, rig, device) = (ingest.lake, &ingest.tmp, &ingest.rig, &ingest.device);
        let mut recording = Recording::open(&self.path, Some(rig)).map_err(|e| match e {
            AcqError::Config(text) => AcqError::Config(format!("{}: {text}", self.path.display())),
            other => other,
        })?;
        if !self.is_session {
            recording
                .rig
                .take_logged_interfaces(&ingest.pairs_of(self))
                .map_err(AcqError::Config)?;
        }
        let session_name = self
            .path
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let source_text = self.path.display().to_string();
        let within = Within {
            session: &session_name,
            source: &source_text,
        };
        let mut files = Vec::new();
        // The holds and their measured values read the source again, on
        // another core while its samples are written.
        let (written, holds) = std::thread::scope(|scope| {
            let holds = scope.spawn(|| {
                extract_holds(
                    &recording,
                    &WindowChoice::Auto(HoldOptions::default()),
                    None,
                    &[],
                )
            });
            let written =
                write_samples(&recording, lake, tmp, device, &self.id, &within, &mut files);
            (written, holds.join().expect("finding holds does not panic"))
        });
        let (samples, out_of_order) = written?;
        let mut notes = Vec::new();
        match holds {
            Ok(report) if !report.windows.is_empty() => {
                let holds = layout::table_file(HOLDS, device, &self.id);
                write_holds(&report, &tmp.file(&holds), &within)?;
                files.push(publish_file(tmp, lake, &holds)?);
                let measured = layout::table_file(MEASURED, device, &self.id);
                let pairs = [("session", within.session), ("source_file", within.source)];
                write_measured_parquet_within(
                    Output::create_complete_only(&tmp.file(&measured))?,
                    &report.values,
                    &pairs,
                )?;
                files.push(publish_file(tmp, lake, &measured)?);
            }
            Ok(report) => notes.push(format!(
                "no steady hold of {} found: no holds or measured values",
                report.load_sensor
            )),
            Err(e) => notes.push(format!("no holds or measured values: {e}")),
        }
        files.sort();
        Ok(Entry {
            format: manifest::FORMAT,
            source: self.path.clone(),
            kind: if self.is_session { "session" } else { "log" }.into(),
            blake3,
            bytes,
            rig: rig.to_path_buf(),
            rig_blake3: String::new(),
            device: device.to_string(),
            buses: ingest.buses_of(self),
            session: session_name,
            ingested_utc: session::utc_text(now_unix_ns()),
            samples,
            out_of_order,
            files,
            notes,
        })
    }
}

/// The session and source file every row of a source carries.
struct Within<'a> {
    session: &'a str,
    source: &'a str,
}

/// The samples table's columns, those constant in a file with their text;
/// the partitions add device, sensor, date.
fn sample_columns(unit: &str, within: &Within<'_>) -> Vec<ColumnSpec> {
    vec![
        ColumnSpec::new("time", ColumnType::Time),
        ColumnSpec::new("value", ColumnType::Float).nullable(),
        ColumnSpec::constant_text("unit", unit),
        ColumnSpec::constant_text("session", within.session),
        ColumnSpec::constant_text("source_file", within.source),
    ]
}

/// Writes the recording's samples, one file per sensor and UTC day, into
/// `tmp` and publishes each: their paths go to `files`; the rows written
/// and those out of time order come back.
///
/// The frames are decoded on this thread and the files written on one
/// thread per core, each writing the files of its share of the sensors;
/// the samples are handed over in chunks. Encoding and compressing the
/// Parquet files costs about twice the decoding (a profile of a 60 s,
/// 76-signal log), so on two cores one writer was the whole ingest's
/// critical path.
fn write_samples(
    recording: &Recording,
    lake: &Path,
    tmp: &ScratchDir,
    device: &str,
    id: &str,
    within: &Within<'_>,
    files: &mut Vec<PathBuf>,
) -> Result<(u64, u64)> {
    let offsets = offsets_ns(&recording.clock_offsets(&[])?);
    let mut counts = SampleCounts::default();
    let writers = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(recording.rig.sensors.len())
        .max(1);
    // Set when decoding failed: the writers drop their files unfinished
    // (they would never be published) instead of encoding their last rows.
    let abandoned = AtomicBool::new(false);
    let (decoded, written) = std::thread::scope(|scope| {
        let mut handing_over = Vec::with_capacity(writers);
        let mut writing = Vec::with_capacity(writers);
        let abandoned = &abandoned;
        for _ in 0..writers {
            let (full, to_write) = std::sync::mpsc::sync_channel::<Chunk>(CHUNKS_IN_FLIGHT);
            let (empty, spare) = std::sync::mpsc::channel::<Vec<Row>>();
            writing.push(scope.spawn(move || {
                let mut open = DaySensorFiles::new(recording, tmp, device, id, within);
                for (sensor, mut rows) in to_write {
                    open.push(sensor, &rows)?;
                    rows.clear();
                    // The decoder may have ended: a chunk not taken back is freed.
                    let _ = empty.send(rows);
                }
                if abandoned.load(Ordering::SeqCst) {
                    return Ok(Vec::new());
                }
                open.finish(lake)
            }));
            handing_over.push((full, spare));
        }
        // Each sensor's rows gather here until a chunk is full; a sensor's
        // writer is looked up, not divided for, per sample.
        let mut gathering: Vec<Vec<Row>> = vec![Vec::new(); recording.rig.sensors.len()];
        let writer_of: Vec<usize> = (0..gathering.len())
            .map(|sensor| sensor % writers)
            .collect();
        let decoded = recording.for_each_sample(&offsets, &mut counts, |sample| {
            let rows = &mut gathering[sample.sensor];
            rows.push(Row {
                time_ns: sample.time_ns,
                value: sample.value.unwrap_or(f64::NAN),
            });
            if rows.len() >= CHUNK_ROWS {
                let (full, spare) = &handing_over[writer_of[sample.sensor]];
                let next = spare
                    .try_recv()
                    .unwrap_or_else(|_| Vec::with_capacity(CHUNK_ROWS));
                // A closed channel: the writer failed, and says why below.
                full.send((sample.sensor, std::mem::replace(rows, next)))
                    .map_err(|_| {
                        AcqError::Malformed("a samples' writer stopped before the decoder".into())
                    })?;
            }
            Ok(())
        });
        if decoded.is_err() {
            abandoned.store(true, Ordering::SeqCst);
        }
        for (sensor, rows) in gathering.into_iter().enumerate() {
            if decoded.is_ok() && !rows.is_empty() {
                let _ = handing_over[writer_of[sensor]].0.send((sensor, rows));
            }
        }
        drop(handing_over);
        let written: Result<Vec<_>> = writing
            .into_iter()
            .map(|writer| writer.join().expect("writing samples does not panic"))
            .collect();
        (decoded, written)
    });
    // A writer's failure is the cause of a decoder stopped by it.
    let finished = match (decoded, written) {
        (_, Err(e)) | (Err(e), _) => return Err(e),
        (Ok(()), Ok(finished)) => finished,
    };
    let mut finished: Vec<_> = finished.into_iter().flatten().collect();
    if finished.is_empty() {
        return Err(recording.no_rig_sample());
    }
    // Published in the order of their paths, whichever writer wrote them.
    finished.sort();
    let (mut samples, mut out_of_order) = (0, 0);
    for (relative, rows, late) in finished {
        samples += rows;
        out_of_order += late;
        files.push(publish_prepared_file(tmp, lake, &relative)?);
    }
    Ok((samples, out_of_order))
}

/// A sample's time and value, as a samples file holds them: 16 bytes,
/// where an `Option<f64>` made it 24. Every sample passes through two
/// buffers of these (a sensor's chunk, its file's reorder window): a
/// third less to move and to hold in cache.
#[derive(Clone, Copy, Debug)]
struct Row {
    time_ns: i64,
    /// NaN for no value: a decoded sample's value is finite or none.
    value: f64,
}

impl Row {
    fn value(&self) -> Option<f64> {
        (!self.value.is_nan()).then_some(self.value)
    }
}

/// One sensor's rows, handed from the decoder to its files' writer.
type Chunk = (usize, Vec<Row>);

/// Rows of one sensor handed over at a time: the decoder gathers every
/// sensor's (76 of them on the bench's rig: 1.9 MB) and a writer takes a
/// chunk's rows into its file in one copy.
const CHUNK_ROWS: usize = 1024;

/// Chunks decoded ahead of a writer at most: the decoder waits beyond
/// (12 MB a writer). Sensors of one rate fill their chunks together, and
/// a writer's work comes in bursts (a page of each of its files encoded
/// and compressed at once): with 64, the decoder waited on one writer
/// while the other had nothing to do, and a quarter of two cores stayed
/// idle through an ingest; with 512 neither waits.
const CHUNKS_IN_FLIGHT: usize = 512;

/// The samples files of one source being written, one per sensor and UTC
/// day, each opened at its first sample.
struct DaySensorFiles<'a> {
    recording: &'a Recording,
    tmp: &'a ScratchDir,
    device: &'a str,
    id: &'a str,
    within: &'a Within<'a>,
    files: Vec<SampleFile>,
    /// Each file's index in `files` by (sensor, day).
    by_sensor_day: HashMap<(usize, i64), usize>,
    /// Each sensor's current day, as the times it spans, and its file's
    /// index: a sample of the same day as its sensor's last, nearly all of
    /// them, finds its file here by two comparisons.
    current: Vec<Option<(std::ops::Range<i64>, usize)>>,
}

impl<'a> DaySensorFiles<'a> {
    fn new(
        recording: &'a Recording,
        tmp: &'a ScratchDir,
        device: &'a str,
        id: &'a str,
        within: &'a Within<'a>,
    ) -> Self {
        DaySensorFiles {
            recording,
            tmp,
            device,
            id,
            within,
            files: Vec::new(),
            by_sensor_day: HashMap::new(),
            current: vec![None; recording.rig.sensors.len()],
        }
    }

    /// `rows` of `sensor`, each into its day's file.
    fn push(&mut self, sensor: usize, mut rows: &[Row]) -> Result<()> {
        while let Some(&Row {
            time_ns: first_ns, ..
        }) = rows.first()
        {
            let (times, index) = match &self.current[sensor] {
                Some((times, index)) if times.contains(&first_ns) => (times.clone(), *index),
                _ => {
                    let day = first_ns.div_euclid(NS_PER_DAY);
                    let index = self.file_of(sensor, day, first_ns)?;
                    // Saturated at the ends of i64's range, where the day's
                    // sample times still lie inside.
                    let times =
                        day.saturating_mul(NS_PER_DAY)..(day + 1).saturating_mul(NS_PER_DAY);
                    self.current[sensor] = Some((times.clone(), index));
                    (times, index)
                }
            };
            // The rows up to the first of another day: nearly always all.
            let same_day = rows
                .iter()
                .position(|row| !times.contains(&row.time_ns))
                .unwrap_or(rows.len());
            self.files[index].push(&rows[..same_day])?;
            rows = &rows[same_day..];
        }
        Ok(())
    }

    /// Finishes every file: each one's place, rows and rows out of order,
    /// the file ready to be published. A finished file is flushed to disk
    /// on a thread of its own while the next is encoded: the flush waits
    /// on the disk (about 1 ms a file here), the encoding on the CPU.
    fn finish(self, lake: &Path) -> Result<Vec<(PathBuf, u64, u64)>> {
        let tmp = self.tmp;
        std::thread::scope(|scope| {
            let (to_flush, flushing) = std::sync::mpsc::channel::<PathBuf>();
            let flusher = scope.spawn(move || -> Result<()> {
                for relative in flushing {
                    prepare_file(tmp, lake, &relative)?;
                }
                Ok(())
            });
            let finished = self
                .files
                .into_iter()
                .map(|file| {
                    let finished = file.finish()?;
                    // A closed channel: the flusher failed, and says why below.
                    let _ = to_flush.send(finished.0.clone());
                    Ok(finished)
                })
                .collect::<Result<Vec<_>>>();
            drop(to_flush);
            let flushed = flusher.join().expect("flushing files does not panic");
            let finished = finished?;
            flushed.map(|()| finished)
        })
    }

    /// The index of the file of `sensor` on `day`, opened if new.
    fn file_of(&mut self, sensor: usize, day: i64, time_ns: i64) -> Result<usize> {
        if let Some(index) = self.by_sensor_day.get(&(sensor, day)) {
            return Ok(*index);
        }
        let sensor_spec = &self.recording.rig.sensors[sensor];
        let relative = layout::samples_file(
            self.device,
            &sensor_spec.name,
            &layout::utc_date(time_ns),
            self.id,
        );
        let file = SampleFile::create(self.tmp, relative, sensor_spec.unit(), self.within)?;
        self.files.push(file);
        let index = self.files.len() - 1;
        self.by_sensor_day.insert((sensor, day), index);
        Ok(index)
    }
}

const NS_PER_DAY: i64 = 86_400_000_000_000;

/// One sensor's samples of one day being written, sorted through a
/// reorder window.
struct SampleFile {
    table: ParquetTable,
    relative: PathBuf,
    /// The rows held back, oldest first: rows leave at the front as they
    /// come in at the back, and nothing held is moved.
    pending: VecDeque<Row>,
    /// `pending` is in time order: each chunk is checked as it comes (a
    /// sensor's samples nearly always are), and the window is sorted only
    /// when one was not.
    pending_sorted: bool,
    last_written_ns: Option<i64>,
    rows: u64,
    out_of_order: u64,
}

impl SampleFile {
    fn create(
        tmp: &ScratchDir,
        relative: PathBuf,
        unit: &str,
        within: &Within<'_>,
    ) -> Result<SampleFile> {
        let output = Output::create_complete_only(&tmp.file(&relative))?;
        let columns = sample_columns(unit, within);
        let table = ParquetTable::with_layout(output, &columns, &[], SAMPLES_LAYOUT)?;
        Ok(SampleFile {
            table,
            relative,
            pending: VecDeque::with_capacity(2 * REORDER_WINDOW + CHUNK_ROWS),
            pending_sorted: true,
            last_written_ns: None,
            rows: 0,
            out_of_order: 0,
        })
    }

    fn push(&mut self, rows: &[Row]) -> Result<()> {
        let after_pending = match (self.pending.back(), rows.first()) {
            (Some(last), Some(first)) => last.time_ns <= first.time_ns,
            _ => true,
        };
        self.pending_sorted =
            self.pending_sorted && after_pending && rows.is_sorted_by_key(|row| row.time_ns);
        self.pending.extend(rows);
        while self.pending.len() >= 2 * REORDER_WINDOW {
            self.write_oldest(REORDER_WINDOW)?;
        }
        Ok(())
    }

    /// Writes the `count` oldest rows held back, in time order.
    fn write_oldest(&mut self, count: usize) -> Result<()> {
        if !self.pending_sorted {
            // Stable: rows of one time keep the order they came in.
            self.pending
                .make_contiguous()
                .sort_by_key(|row| row.time_ns);
            self.pending_sorted = true;
        }
        let count = count.min(self.pending.len());
        let Some(first) = self.pending.front() else {
            return Ok(());
        };
        let mut last_ns = self.last_written_ns.unwrap_or(first.time_ns);
        // The window's two runs in memory, each written as a slice: the
        // builders' loops over a slice need no call per row.
        let (front, back) = self.pending.as_slices();
        let front = &front[..count.min(front.len())];
        let back = &back[..count - front.len()];
        for rows in [front, back] {
            for row in rows {
                self.out_of_order += u64::from(row.time_ns < last_ns);
                last_ns = row.time_ns;
            }
            self.table.times_ns(0, rows.iter().map(|row| row.time_ns));
            self.table.floats(1, rows.iter().map(Row::value));
        }
        self.last_written_ns = Some(last_ns);
        self.table.end_rows(count)?;
        self.pending.drain(..count);
        self.rows += count as u64;
        Ok(())
    }

    /// Writes what is held back and closes the file (still in `_tmp/`):
    /// its place in the lake, its rows and those out of time order.
    fn finish(mut self) -> Result<(PathBuf, u64, u64)> {
        self.write_oldest(self.pending.len())?;
        self.table.finish()?;
        Ok((self.relative, self.rows, self.out_of_order))
    }
}

/// The holds table's columns.
fn hold_columns() -> Vec<ColumnSpec> {
    let text = |name: &str| ColumnSpec::new(name, ColumnType::Text);
    vec![
        text("session"),
        text("source_file"),
        text("hold"),
        ColumnSpec::new("start", ColumnType::Time),
        ColumnSpec::new("end", ColumnType::Time),
        ColumnSpec::new("start_s", ColumnType::Float).unit("s"),
        ColumnSpec::new("end_s", ColumnType::Float).unit("s"),
        text("load_sensor"),
    ]
}

/// The holds of `report` to `path`: their times as instants and as seconds
/// from the session's start (as `acq extract` gives them).
fn write_holds(report: &HoldsReport, path: &Path, within: &Within<'_>) -> Result<()> {
    let mut table = ParquetTable::with_layout(
        Output::create_complete_only(path)?,
        &hold_columns(),
        &[],
        FileLayout::FOR_EVERY_ENGINE,
    )?;
    for window in &report.windows {
        table.text(0, Some(within.session));
        table.text(1, Some(within.source));
        table.text(2, Some(&window.name));
        table.time_ns(3, window.start_ns);
        table.time_ns(4, window.end_ns);
        table.float(5, Some((window.start_ns - report.t0_ns) as f64 / 1e9));
        table.float(6, Some((window.end_ns - report.t0_ns) as f64 / 1e9));
        table.text(7, Some(&report.load_sensor));
        table.end_row()?;
    }
    table.finish().map(|_| ())
}

/// The lake's files by source id (their name), relative to the lake.
fn files_by_id(lake: &Path) -> HashMap<String, Vec<PathBuf>> {
    let mut by_id: HashMap<String, Vec<PathBuf>> = HashMap::new();
    let mut dirs: Vec<PathBuf> = TABLES.iter().map(|t| lake.join(t)).collect();
    while let Some(dir) = dirs.pop() {
        let Ok(listing) = std::fs::read_dir(&dir) else {
            continue;
        };
        for item in listing.flatten() {
            let path = item.path();
            if path.is_dir() {
                dirs.push(path);
            } else if let (Some(id), Ok(relative)) = (
                path.file_name()
                    .and_then(|n| n.to_str())
                    .and_then(|n| n.strip_suffix(".parquet")),
                path.strip_prefix(lake),
            ) {
                by_id
                    .entry(id.to_string())
                    .or_default()
                    .push(relative.to_path_buf());
            }
        }
    }
    by_id
}

fn now_unix_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}
