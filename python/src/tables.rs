//! Tables for Python: decoded logs, aligned sessions, measured holds and
//! tensile curves, as the command line's Parquet files hold them, handed
//! to pyarrow as Arrow record batches.
//!
//! Each table is made on a thread of its own and streamed through a
//! bounded channel ([`stream_table`]): Python reads a batch while the next
//! is decoded, and at most [`BATCHES_IN_FLIGHT`] wait, so a log of any
//! length streams in bounded memory (`decode_batches`). The functions that
//! return a whole `pyarrow.Table` collect the same stream.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};

use acq_analysis::align::run::{align_recording, AlignOptions, GapTolerance, TimePoint};
use acq_analysis::decode::{decode_dbc, decode_rig, DbcDecodeOptions};
use acq_analysis::extract::holds::HoldOptions;
use acq_analysis::extract::measured::measured_to_arrow;
use acq_analysis::extract::run::{extract_holds, extract_tensile, specimen, WindowChoice};
use acq_analysis::extract::tensile::curve_to_arrow;
use acq_analysis::recording::Recording;
use acq_can::dbc::DbcDatabase;
use acq_error::AcqError;
use acq_io::input::{load_rig, open_logs, open_session_log, BadLines, LogInput};
use acq_io::output::TableOutput;
use acq_io::parquet_table::{ArrowBatch, ArrowSchema, ArrowSink};
use acq_rig::Interpolation;
use arrow_array::RecordBatchReader;
use arrow_pyarrow::{IntoPyArrow, Table};
use arrow_schema::ArrowError;
use pyo3::exceptions::{PyUserWarning, PyValueError};
use pyo3::prelude::*;

use crate::python_error;

/// Batches decoded ahead of the reader: enough to keep both threads busy,
/// few enough (16 Ki rows each) that memory stays a few MB.
const BATCHES_IN_FLIGHT: usize = 2;

/// What the worker thread sends: the schema first, then batches, then
/// the notes of a finished table; a failure ends the stream instead.
enum Piece {
    Schema(ArrowSchema),
    Batch(ArrowBatch),
    Notes(Vec<String>),
    Failed(AcqError),
}

/// The sending end, as the libraries' [`ArrowSink`].
struct ChannelSink(SyncSender<Piece>);

fn reader_gone() -> AcqError {
    AcqError::Interrupted("the table's reader was closed".into())
}

impl ArrowSink for ChannelSink {
    fn schema(&mut self, schema: ArrowSchema) -> Result<(), AcqError> {
        self.0
            .send(Piece::Schema(schema))
            .map_err(|_| reader_gone())
    }
    fn batch(&mut self, batch: ArrowBatch) -> Result<(), AcqError> {
        self.0.send(Piece::Batch(batch)).map_err(|_| reader_gone())
    }
}

/// A table arriving from its worker thread. Dropped before the end, it
/// closes the channel and the worker stops at its next batch.
pub struct StreamedTable {
    schema: ArrowSchema,
    pieces: Receiver<Piece>,
}

impl StreamedTable {
    /// The next batch; notes met on the way are Python warnings.
    fn next_batch(&mut self) -> Option<Result<ArrowBatch, AcqError>> {
        loop {
            return match self.pieces.recv() {
                Ok(Piece::Batch(batch)) => Some(Ok(batch)),
                Ok(Piece::Failed(error)) => Some(Err(error)),
                Ok(Piece::Notes(notes)) => {
                    Python::attach(|py| warn_all(py, &notes));
                    continue;
                }
                Ok(Piece::Schema(_)) => continue,
                Err(_) => None,
            };
        }
    }

    /// The whole table as a `pyarrow.Table`; a failure is Python's error.
    pub fn collect(mut self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let batches = py.detach(|| {
            let mut batches = Vec::new();
            while let Some(batch) = self.next_batch() {
                batches.push(batch?);
            }
            Ok::<_, AcqError>(batches)
        });
        let table = Table::try_new(batches.map_err(python_error)?, self.schema.clone())
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(table.into_pyarrow(py)?.unbind())
    }

    /// The stream as a `pyarrow.RecordBatchReader`.
    pub fn into_reader(self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let reader: Box<dyn RecordBatchReader + Send> = Box::new(self);
        Ok(reader.into_pyarrow(py)?.unbind())
    }
}

impl Iterator for StreamedTable {
    type Item = Result<ArrowBatch, ArrowError>;

    fn next(&mut self) -> Option<Self::Item> {
        // An error crosses the C stream interface as its text; pyarrow
        // raises it as ArrowInvalid, a ValueError.
        self.next_batch()
            .map(|piece| piece.map_err(|e| ArrowError::ExternalError(Box::new(e))))
    }
}

impl RecordBatchReader for StreamedTable {
    fn schema(&self) -> ArrowSchema {
        self.schema.clone()
    }
}

/// Each note as a `UserWarning` (`warnings.simplefilter` and pytest's
/// `recwarn` see them; a script shows each once).
fn warn_all(py: Python<'_>, notes: &[String]) {
    let category = py.get_type::<PyUserWarning>();
    for note in notes {
        if let Ok(text) = std::ffi::CString::new(format!("acq: {note}")) {
            // A warning turned into an error by the user's filter has
            // nowhere to go from here: it is dropped, as a print would be.
            let _ = PyErr::warn(py, &category, &text, 1);
        }
    }
}

/// Runs `work` on a thread of its own, its table streamed back and the
/// notes it returns warned of at the end. An error before the table
/// starts (a missing file, a bad rig) is raised here.
pub fn stream_table<W>(py: Python<'_>, work: W) -> PyResult<StreamedTable>
where
    W: FnOnce(Box<dyn ArrowSink>) -> Result<Vec<String>, AcqError> + Send + 'static,
{
    let (sender, pieces) = sync_channel(BATCHES_IN_FLIGHT);
    let failures = sender.clone();
    std::thread::Builder::new()
        .name("acq-table".into())
        .spawn(move || {
            let last = match work(Box::new(ChannelSink(sender))) {
                Ok(notes) => Piece::Notes(notes),
                Err(error) => Piece::Failed(error),
            };
            let _ = failures.send(last);
        })
        .map_err(|e| PyValueError::new_err(format!("cannot start the table's thread: {e}")))?;
    let (first, pieces) = py.detach(move || (pieces.recv(), pieces));
    match first {
        Ok(Piece::Schema(schema)) => Ok(StreamedTable { schema, pieces }),
        Ok(Piece::Failed(error)) => Err(python_error(error)),
        Ok(Piece::Batch(_) | Piece::Notes(_)) | Err(_) => Err(PyValueError::new_err(
            "bug: the table's thread sent no schema before its rows",
        )),
    }
}

/// The logs to read and the rig that decodes them: a session directory's
/// raw logs and its copy of the rig (unless `rig` is given), else the log
/// file itself.
fn inputs_of(
    log: &Path,
    rig: Option<&Path>,
) -> Result<(Vec<LogInput>, Option<acq_rig::Rig>), AcqError> {
    if log.is_dir() {
        let recording = Recording::open_session(log)?;
        let inputs = recording
            .logs
            .iter()
            .map(|path| open_session_log(path))
            .collect::<Result<Vec<_>, _>>()?;
        let rig = match rig {
            Some(path) => load_rig(path)?,
            None => recording.rig,
        };
        return Ok((inputs, Some(rig)));
    }
    let inputs = open_logs(&[log.to_path_buf()])?;
    Ok((inputs, rig.map(load_rig).transpose()?))
}

/// What `decode` and `decode_batches` read.
pub struct DecodeRequest {
    pub log: PathBuf,
    pub rig: Option<PathBuf>,
    pub dbc: Vec<PathBuf>,
    pub labels: bool,
    pub skip_bad: bool,
}

/// Decodes a log (candump, ASC, BLF, MF4) or a session directory through a
/// rig (`time_s`, `sensor`, `value`, `unit`) or DBC files (`time_s`,
/// `iface`, `can_id`, `message`, `signal`, `value`, `unit`[, `label`]):
/// the table `acq decode -o FILE.parquet` writes, streamed.
pub fn decode_stream(py: Python<'_>, request: DecodeRequest) -> PyResult<StreamedTable> {
    stream_table(py, move |sink| {
        let bad_lines = if request.skip_bad {
            BadLines::Skip
        } else {
            BadLines::Stop
        };
        let (mut inputs, rig) = inputs_of(&request.log, request.rig.as_deref())?;
        let name = request.log.display().to_string();
        let output = TableOutput::Arrow(sink);
        match (rig, request.dbc.is_empty()) {
            (Some(rig), true) => decode_rig(&mut inputs, &rig, bad_lines, output, &name),
            (None, false) => {
                let (database, _warnings) = DbcDatabase::load_all(&request.dbc)
                    .map_err(|e| AcqError::Config(e.to_string()))?;
                let options = DbcDecodeOptions {
                    bad_lines,
                    labels: request.labels,
                };
                decode_dbc(&mut inputs, &database, options, output, &name)
            }
            (Some(_), false) => Err(AcqError::Config(
                "decode: give rig= or dbc=, not both (a session directory brings its rig)".into(),
            )),
            (None, true) => Err(AcqError::Config(format!(
                "decode: {name} is a log: give rig= (a rig file) or dbc= (DBC files) to decode it"
            ))),
        }
        // A node's normal start-up is no warning: what to act on is.
        .map(|summary| summary.warnings)
    })
}

/// What `align` reads, and how (`acq align`'s options).
pub struct AlignRequest {
    pub input: PathBuf,
    pub rig: Option<PathBuf>,
    pub rate_hz: f64,
    pub method: Option<String>,
    pub max_gap: String,
    pub start: Option<String>,
    pub end: Option<String>,
    pub filter_hz: Option<f64>,
    pub clock_offsets_ms: Vec<(String, f64)>,
}

fn interpolation(name: &str) -> Result<Interpolation, AcqError> {
    [
        Interpolation::Linear,
        Interpolation::Hold,
        Interpolation::Nearest,
    ]
    .into_iter()
    .find(|method| method.name() == name)
    .ok_or_else(|| {
        AcqError::Config(format!(
            "method={name:?}: give \"linear\", \"hold\" or \"nearest\" (None: each sensor's own)"
        ))
    })
}

/// A session on one time base (`acq align -o FILE.parquet`): `time_s`,
/// then per sensor `NAME [UNIT]` and `NAME_gap`; the CSV's comment lines
/// in the schema's metadata (`acq.comments`).
pub fn align_stream(py: Python<'_>, request: AlignRequest) -> PyResult<StreamedTable> {
    stream_table(py, move |sink| {
        let recording = Recording::open(&request.input, request.rig.as_deref())?;
        let config = |what: &str, error: String| AcqError::Config(format!("{what}: {error}"));
        let options = AlignOptions {
            rate_hz: request.rate_hz,
            method: request.method.as_deref().map(interpolation).transpose()?,
            max_gap: GapTolerance::parse(&request.max_gap).map_err(|e| config("max_gap", e))?,
            from: request
                .start
                .as_deref()
                .map(TimePoint::parse)
                .transpose()
                .map_err(|e| config("start", e))?,
            to: request
                .end
                .as_deref()
                .map(TimePoint::parse)
                .transpose()
                .map_err(|e| config("end", e))?,
            filter_hz: request.filter_hz,
            clock_offsets_ms: request.clock_offsets_ms,
        };
        let summary = align_recording(&recording, &options, TableOutput::Arrow(sink))?;
        Ok(summary.notes)
    })
}

/// What `holds` reads, and how (`acq extract`'s options; `None`: its
/// default).
pub struct HoldsRequest {
    pub input: PathBuf,
    pub rig: Option<PathBuf>,
    pub windows: Option<PathBuf>,
    pub load: Option<String>,
    pub steady_std: Option<f64>,
    pub steady_window_s: Option<f64>,
    pub min_hold_s: Option<f64>,
    pub settle_s: Option<f64>,
    pub min_load: Option<f64>,
    pub clock_offsets_ms: Vec<(String, f64)>,
}

fn seconds_to_ns(what: &str, seconds: f64) -> Result<i64, AcqError> {
    if seconds.is_finite() && (0.0..=1e9).contains(&seconds) {
        Ok((seconds * 1e9).round() as i64)
    } else {
        Err(AcqError::Config(format!(
            "{what}={seconds}: give seconds, at least 0"
        )))
    }
}

/// The measured values of a session's holds (`acq extract -o
/// FILE.parquet`): per window and quantity the mean, its scatter and its
/// uncertainty budget (`u_c`, `k`, `U95`, the shared errors).
pub fn holds_table(py: Python<'_>, request: HoldsRequest) -> PyResult<StreamedTable> {
    stream_table(py, move |sink| {
        let recording = Recording::open(&request.input, request.rig.as_deref())?;
        let choice = match request.windows {
            Some(file) => WindowChoice::File(file),
            None => {
                let defaults = HoldOptions::default();
                let ns = |what, value: Option<f64>, default| {
                    value.map_or(Ok(default), |s| seconds_to_ns(what, s))
                };
                WindowChoice::Auto(HoldOptions {
                    window_ns: ns(
                        "steady_window_s",
                        request.steady_window_s,
                        defaults.window_ns,
                    )?
                    .max(1),
                    steady_std: request.steady_std,
                    min_hold_ns: ns("min_hold_s", request.min_hold_s, defaults.min_hold_ns)?,
                    settle_ns: ns("settle_s", request.settle_s, defaults.settle_ns)?,
                    min_load_fraction: request.min_load.unwrap_or(defaults.min_load_fraction),
                })
            }
        };
        let report = extract_holds(
            &recording,
            &choice,
            request.load.as_deref(),
            &request.clock_offsets_ms,
        )?;
        measured_to_arrow(&report.values, sink)?;
        Ok(report.notes())
    })
}

/// What `tensile_curve` reads (`acq extract --tensile`'s options).
pub struct CurveRequest {
    pub input: PathBuf,
    pub rig: Option<PathBuf>,
    pub force: Option<String>,
    pub displacement: Option<String>,
    pub diameter_mm: Option<f64>,
    pub gauge_length_mm: Option<f64>,
    pub clock_offsets_ms: Vec<(String, f64)>,
}

/// A tensile test's force-displacement curve (`acq extract --tensile -o
/// FILE.parquet`), with engineering and (to the maximum force) true
/// strain and stress.
pub fn curve_table(py: Python<'_>, request: CurveRequest) -> PyResult<StreamedTable> {
    stream_table(py, move |sink| {
        let recording = Recording::open(&request.input, request.rig.as_deref())?;
        let specimen = specimen(&recording, request.diameter_mm, request.gauge_length_mm)?;
        let report = extract_tensile(
            &recording,
            request.force.as_deref(),
            request.displacement.as_deref(),
            &request.clock_offsets_ms,
        )?;
        curve_to_arrow(&report.curve, &specimen, sink)?;
        Ok(report.curve.notes.clone())
    })
}
