//! Running a simulator: the [`Simulator`] trait every model implements (the
//! twins, a user's solver through the external adapter), and the
//! [`Evaluator`] that runs it in parallel and logs every evaluation.
//!
//! Every evaluation, successful or failed, is appended to the log
//! (`evaluations.csv`) as soon as it finishes, one whole line at a time,
//! flushed and synced: a run killed at any instant loses at most the
//! evaluations still running. A run started again with the same log
//! ([`Evaluator::resume`]) answers every point it has already evaluated from
//! the log instead of the simulator. The engine's proposals are
//! deterministic (seeded) and depend only on earlier results, which the log
//! gives back bit for bit (shortest round-trip decimal), so a resumed run
//! retraces the interrupted one and continues where it stopped.
//!
//! A failed evaluation (an error, a panic inside the simulator, non-finite
//! outputs) is logged with its reason and handed back as such; it never
//! ends the run.

use std::collections::HashMap;
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use serde::{Deserialize, Serialize};

/// One calibrated input: its name (with its unit, `bucket_stroke_mm`), its
/// box bounds, and the scale the search moves it on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Parameter {
    pub name: String,
    pub lower: f64,
    pub upper: f64,
    #[serde(default)]
    pub scale: Scale,
}

/// How a parameter's range maps onto the search's unit interval.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Scale {
    /// Equal steps in value: most inputs.
    #[default]
    Linear,
    /// Equal steps in ratio: a parameter known to its order of magnitude
    /// (a void fraction, a stiffness over decades). Needs `lower > 0`.
    Log,
}

impl Parameter {
    pub fn new(name: impl Into<String>, lower: f64, upper: f64) -> Self {
        Parameter {
            name: name.into(),
            lower,
            upper,
            scale: Scale::Linear,
        }
    }

    /// The same parameter searched on a log scale.
    pub fn with_scale(mut self, scale: Scale) -> Self {
        self.scale = scale;
        self
    }

    /// The middle of the range on its scale (the geometric mean on a log
    /// scale).
    pub fn midpoint(&self) -> f64 {
        match self.scale {
            Scale::Linear => 0.5 * (self.lower + self.upper),
            Scale::Log => self.from_unit(0.5),
        }
    }

    /// `x` mapped from the unit interval onto the range.
    pub fn from_unit(&self, unit: f64) -> f64 {
        match self.scale {
            Scale::Linear => self.lower + unit * (self.upper - self.lower),
            Scale::Log => self.lower * (self.upper / self.lower).powf(unit),
        }
    }

    /// Which bound `value` sits on, if it is within 1 % of the range of
    /// one (on the parameter's scale): there the optimum may lie outside
    /// the range, or the data may not pin the parameter at all.
    pub fn bound_reached(&self, value: f64) -> Option<&'static str> {
        let unit = self.to_unit(value);
        if unit < 0.01 {
            Some("lower bound")
        } else if unit > 0.99 {
            Some("upper bound")
        } else {
            None
        }
    }

    /// `x` mapped from the range onto the unit interval.
    pub fn to_unit(&self, value: f64) -> f64 {
        // A range that is empty (or NaN) maps to the middle.
        if self.upper.partial_cmp(&self.lower) != Some(std::cmp::Ordering::Greater) {
            return 0.5;
        }
        match self.scale {
            Scale::Linear => (value - self.lower) / (self.upper - self.lower),
            Scale::Log => (value / self.lower).ln() / (self.upper / self.lower).ln(),
        }
    }
}

/// A model the engine can calibrate: parameters in, named outputs out.
pub trait Simulator: Sync {
    /// The inputs, in the order `evaluate` takes them.
    fn parameters(&self) -> &[Parameter];
    /// The output names, in the order `evaluate` returns them.
    fn outputs(&self) -> &[String];
    /// One run. An `Err` says why the run failed (logged, never fatal).
    fn evaluate(&self, parameters: &[f64]) -> Result<Vec<f64>, String>;
    /// Text columns the log gets after `reason` for each evaluation:
    /// where and how it ran (a cluster's job ids and queue waits). None
    /// by default.
    fn note_columns(&self) -> &[String] {
        &[]
    }
    /// [`Simulator::evaluate`] with one note per [`Simulator::note_columns`].
    fn evaluate_noted(&self, parameters: &[f64]) -> (Result<Vec<f64>, String>, Vec<String>) {
        (self.evaluate(parameters), Vec::new())
    }
}

/// Checks the parameters of a simulator: names unique and plain (they
/// become CSV columns), bounds finite and ordered.
pub fn validate_parameters(parameters: &[Parameter]) -> Result<(), EvaluationError> {
    if parameters.is_empty() {
        return Err(EvaluationError::Setup("no parameters to calibrate".into()));
    }
    for (i, p) in parameters.iter().enumerate() {
        if p.name.is_empty() || p.name.contains([',', '"', '\n', '\r']) {
            return Err(EvaluationError::Setup(format!(
                "parameter {} has the name {:?}; use letters, digits and underscores",
                i + 1,
                p.name
            )));
        }
        if parameters[..i].iter().any(|q| q.name == p.name) {
            return Err(EvaluationError::Setup(format!(
                "parameter {:?} is listed twice",
                p.name
            )));
        }
        if !(p.lower.is_finite() && p.upper.is_finite() && p.lower < p.upper) {
            return Err(EvaluationError::Setup(format!(
                "parameter {:?}: bounds must be finite with lower < upper, got {} .. {} (a calibrated parameter needs a range; a fixed value is no parameter)",
                p.name, p.lower, p.upper
            )));
        }
        if p.scale == Scale::Log && p.lower <= 0.0 {
            return Err(EvaluationError::Setup(format!(
                "parameter {:?}: a log scale needs lower > 0, got {}; use scale = \"linear\" or a positive lower bound",
                p.name, p.lower
            )));
        }
    }
    Ok(())
}

/// What one evaluation gave.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    /// 1-based, in the order evaluations finished (the log's order).
    pub id: usize,
    pub parameters: Vec<f64>,
    /// The outputs, or why there are none.
    pub outcome: Result<Vec<f64>, String>,
    pub wall_s: f64,
    /// Answered from the log of an earlier run.
    pub from_log: bool,
    /// One text per [`Simulator::note_columns`] (empty when it has none).
    pub notes: Vec<String>,
}

/// Why evaluations cannot be run or logged (the run stops; a failed
/// simulation is not one of these).
#[derive(Debug, thiserror::Error)]
pub enum EvaluationError {
    #[error("{0}")]
    Setup(String),
    /// [`request_stop`] was called: every finished run is in the log.
    #[error(
        "stopped on request; every finished run is in the log, and resuming continues from there"
    )]
    Stopped,
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}:{line}: {message}")]
    Log {
        path: PathBuf,
        line: usize,
        message: String,
    },
    #[error("{path} already exists; pass --resume to continue that run, or choose another output directory")]
    LogExists { path: PathBuf },
}

/// Bit pattern of a parameter vector: the key of the resume cache.
fn key(parameters: &[f64]) -> Vec<u64> {
    parameters.iter().map(|v| v.to_bits()).collect()
}

/// A value as the shortest decimal that reads back to the same bits.
fn format_value(value: f64) -> String {
    if value.is_finite() {
        let mut buffer = ryu::Buffer::new();
        buffer.format_finite(value).to_string()
    } else {
        String::new()
    }
}

/// Quotes a reason for a CSV cell (one line, quotes doubled).
fn csv_text(text: &str) -> String {
    let one_line: String = text
        .chars()
        .map(|c| if c == '\n' || c == '\r' { ' ' } else { c })
        .collect();
    format!("\"{}\"", one_line.replace('"', "\"\""))
}

/// The append-only log of evaluations.
struct Log {
    path: PathBuf,
    file: File,
}

impl Log {
    fn header(simulator: &dyn Simulator) -> String {
        let mut columns = vec!["id".to_string(), "status".into(), "wall_s".into()];
        columns.extend(simulator.parameters().iter().map(|p| p.name.clone()));
        columns.extend(simulator.outputs().iter().cloned());
        columns.push("reason".into());
        columns.extend(simulator.note_columns().iter().cloned());
        columns.join(",")
    }

    fn append(&mut self, evaluation: &Evaluation, outputs: usize) -> Result<(), EvaluationError> {
        let mut cells = vec![
            evaluation.id.to_string(),
            if evaluation.outcome.is_ok() {
                "ok".into()
            } else {
                "failed".into()
            },
            format!("{:.3}", evaluation.wall_s),
        ];
        cells.extend(evaluation.parameters.iter().map(|&v| format_value(v)));
        match &evaluation.outcome {
            Ok(values) => {
                cells.extend(values.iter().map(|&v| format_value(v)));
                cells.push(String::new());
            }
            Err(reason) => {
                cells.extend(std::iter::repeat_n(String::new(), outputs));
                cells.push(csv_text(reason));
            }
        }
        cells.extend(evaluation.notes.iter().map(|note| csv_text(note)));
        let line = cells.join(",") + "\n";
        let io = |source| EvaluationError::Io {
            path: self.path.clone(),
            source,
        };
        self.file.write_all(line.as_bytes()).map_err(io)?;
        self.file.flush().map_err(io)?;
        // A whole line survives a power cut, not just a crash.
        self.file.sync_data().map_err(io)
    }
}

/// Set by [`request_stop`]: no evaluator starts another run.
static STOP_REQUESTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Asks every evaluator to start no further run and to end with
/// [`EvaluationError::Stopped`] once the runs under way are done (a run
/// that fails after the request is not logged: it was cut short, and a
/// resumed study runs it again). For a host that cannot end the process
/// on Ctrl-C, as the command line does: a Python session.
pub fn request_stop() {
    STOP_REQUESTED.store(true, std::sync::atomic::Ordering::SeqCst);
}

/// Takes back [`request_stop`], before the next study starts.
pub fn clear_stop_request() {
    STOP_REQUESTED.store(false, std::sync::atomic::Ordering::SeqCst);
}

fn stop_requested() -> bool {
    STOP_REQUESTED.load(std::sync::atomic::Ordering::SeqCst)
}

/// Runs a simulator on batches of points, in parallel, logging each result.
pub struct Evaluator<'a> {
    simulator: &'a dyn Simulator,
    log: Option<Mutex<Log>>,
    /// Results of an earlier run by parameter bits, consumed once each.
    earlier: HashMap<Vec<u64>, Vec<Evaluation>>,
    finished: Vec<Evaluation>,
    /// Id of the next fresh evaluation (the log's records come first).
    next_id: usize,
    parallel: usize,
    progress: Option<ProgressCallback<'a>>,
}

/// Called after every evaluation, from the worker threads.
type ProgressCallback<'a> = Box<dyn Fn(&Evaluation) + Sync + 'a>;

impl<'a> Evaluator<'a> {
    /// An evaluator without a log (tests, cheap surrogate studies).
    pub fn in_memory(
        simulator: &'a dyn Simulator,
        parallel: usize,
    ) -> Result<Self, EvaluationError> {
        validate_parameters(simulator.parameters())?;
        Ok(Evaluator {
            simulator,
            log: None,
            earlier: HashMap::new(),
            finished: Vec::new(),
            next_id: 1,
            parallel: parallel.max(1),
            progress: None,
        })
    }

    /// A new run logging to `path`, which must not exist yet.
    pub fn create(
        simulator: &'a dyn Simulator,
        path: &Path,
        parallel: usize,
    ) -> Result<Self, EvaluationError> {
        Self::open(simulator, path, parallel, false)
    }

    /// A run that continues the log at `path` (created if missing): points
    /// already evaluated there are answered from it.
    pub fn resume(
        simulator: &'a dyn Simulator,
        path: &Path,
        parallel: usize,
    ) -> Result<Self, EvaluationError> {
        Self::open(simulator, path, parallel, true)
    }

    fn open(
        simulator: &'a dyn Simulator,
        path: &Path,
        parallel: usize,
        resume: bool,
    ) -> Result<Self, EvaluationError> {
        validate_parameters(simulator.parameters())?;
        let header = Log::header(simulator);
        let io = |source| EvaluationError::Io {
            path: path.to_path_buf(),
            source,
        };
        let exists = path.exists();
        if exists && !resume {
            return Err(EvaluationError::LogExists {
                path: path.to_path_buf(),
            });
        }
        let mut earlier: HashMap<Vec<u64>, Vec<Evaluation>> = HashMap::new();
        let mut file = OpenOptions::new()
            .create(true)
            .read(true)
            .append(true)
            .open(path)
            .map_err(io)?;
        let mut next_id = 1;
        if exists {
            let (records, whole_length) = read_log(path, &header, simulator)?;
            // A line cut by a crash is dropped, so the next one starts clean.
            if file.metadata().map_err(io)?.len() != whole_length {
                file.set_len(whole_length).map_err(io)?;
                file.seek(SeekFrom::End(0)).map_err(io)?;
            }
            next_id = records.len() + 1;
            for record in records {
                earlier
                    .entry(key(&record.parameters))
                    .or_default()
                    .push(record);
            }
        }
        if !exists || next_id == 1 && file.metadata().map_err(io)?.len() == 0 {
            file.write_all(format!("{header}\n").as_bytes())
                .map_err(io)?;
            file.sync_data().map_err(io)?;
        }
        Ok(Evaluator {
            simulator,
            log: Some(Mutex::new(Log {
                path: path.to_path_buf(),
                file,
            })),
            earlier,
            finished: Vec::new(),
            next_id,
            parallel: parallel.max(1),
            progress: None,
        })
    }

    /// Calls `progress` after every evaluation (from the worker threads).
    pub fn with_progress(mut self, progress: impl Fn(&Evaluation) + Sync + 'a) -> Self {
        self.progress = Some(Box::new(progress));
        self
    }

    pub fn simulator(&self) -> &dyn Simulator {
        self.simulator
    }

    /// Every evaluation of this run so far (including those from the log).
    pub fn evaluations(&self) -> &[Evaluation] {
        &self.finished
    }

    /// Evaluations answered from the log of an earlier run.
    pub fn reused(&self) -> usize {
        self.finished.iter().filter(|e| e.from_log).count()
    }

    /// Evaluates `points` (parameter vectors in the simulator's order),
    /// `parallel` at a time; returns them in the order of `points`.
    ///
    /// # Errors
    /// Only when the log cannot be written: a failed simulation is an
    /// `Evaluation` with an `Err` outcome.
    pub fn evaluate(&mut self, points: &[Vec<f64>]) -> Result<Vec<Evaluation>, EvaluationError> {
        let n_parameters = self.simulator.parameters().len();
        let mut results: Vec<Option<Evaluation>> = vec![None; points.len()];
        let mut pending = Vec::new();
        for (index, point) in points.iter().enumerate() {
            if point.len() != n_parameters {
                return Err(EvaluationError::Setup(format!(
                    "a point has {} values; the simulator takes {n_parameters}",
                    point.len()
                )));
            }
            let reused = self
                .earlier
                .get_mut(&key(point))
                .and_then(|list| (!list.is_empty()).then(|| list.remove(0)));
            match reused {
                Some(mut evaluation) => {
                    evaluation.from_log = true;
                    if let Some(progress) = &self.progress {
                        progress(&evaluation);
                    }
                    results[index] = Some(evaluation);
                }
                None => pending.push(index),
            }
        }

        let next_id = Mutex::new(self.next_id);
        let queue = Mutex::new(pending.into_iter());
        let done = Mutex::new(Vec::new());
        let failure: Mutex<Option<EvaluationError>> = Mutex::new(None);
        let workers = self.parallel.min(points.len()).max(1);
        std::thread::scope(|scope| {
            for _ in 0..workers {
                scope.spawn(|| {
                    let stopped = || {
                        if let Ok(mut slot) = failure.lock() {
                            slot.get_or_insert(EvaluationError::Stopped);
                        }
                    };
                    while let Some(index) = queue.lock().map_or(None, |mut q| q.next()) {
                        if stop_requested() {
                            stopped();
                            break;
                        }
                        let point = &points[index];
                        let start = Instant::now();
                        let (outcome, notes) = run_simulator(self.simulator, point);
                        let wall_s = start.elapsed().as_secs_f64();
                        if outcome.is_err() && stop_requested() {
                            stopped();
                            break;
                        }
                        // The id and the log line are taken together so the log
                        // is in id order.
                        let Ok(mut id) = next_id.lock() else { break };
                        let evaluation = Evaluation {
                            id: *id,
                            parameters: point.clone(),
                            outcome,
                            wall_s,
                            from_log: false,
                            notes,
                        };
                        *id += 1;
                        if let Some(log) = &self.log {
                            let written = log.lock().map_err(|_| {
                                EvaluationError::Setup("the log writer panicked".into())
                            });
                            let written = written.and_then(|mut log| {
                                log.append(&evaluation, self.simulator.outputs().len())
                            });
                            if let Err(error) = written {
                                if let Ok(mut slot) = failure.lock() {
                                    slot.get_or_insert(error);
                                }
                                break;
                            }
                        }
                        drop(id);
                        if let Some(progress) = &self.progress {
                            progress(&evaluation);
                        }
                        if let Ok(mut done) = done.lock() {
                            done.push((index, evaluation));
                        }
                    }
                });
            }
        });
        self.next_id = next_id.into_inner().unwrap_or(self.next_id);
        if let Some(error) = failure.into_inner().ok().flatten() {
            return Err(error);
        }
        for (index, evaluation) in done.into_inner().unwrap_or_default() {
            results[index] = Some(evaluation);
        }
        let results: Vec<Evaluation> = results.into_iter().flatten().collect();
        if results.len() != points.len() {
            return Err(EvaluationError::Setup(
                "an evaluation worker stopped unexpectedly".into(),
            ));
        }
        self.finished.extend(results.iter().cloned());
        Ok(results)
    }

    /// Runs evaluations as slots free up instead of in batches: `body`
    /// starts points ([`AsyncRuns::start`]) and takes results as they
    /// finish ([`AsyncRuns::next_done`]), so a search can propose the next
    /// point the moment a run ends and no slot waits for a batch's slowest
    /// run. Every result is logged as it is taken.
    ///
    /// A resumed run replays its log deterministically: a started point
    /// the log already holds is answered from it, and while any such point
    /// is in flight, `next_done` returns the one logged first, which is the
    /// order the interrupted run saw them finish in. So the same proposals
    /// follow, up to where the log ends.
    pub fn run_async<R>(
        &mut self,
        slots: usize,
        body: impl FnOnce(&mut AsyncRuns<'_, 'a>) -> R,
    ) -> R {
        let simulator = self.simulator;
        let (job_sender, job_receiver) = std::sync::mpsc::channel::<(u64, Vec<f64>)>();
        let job_receiver = Mutex::new(job_receiver);
        std::thread::scope(|scope| {
            let (result_sender, result_receiver) = std::sync::mpsc::channel();
            for _ in 0..slots.max(1) {
                let result_sender = result_sender.clone();
                let job_receiver = &job_receiver;
                scope.spawn(move || loop {
                    let job = match job_receiver.lock() {
                        Ok(receiver) => receiver.recv(),
                        Err(_) => break,
                    };
                    let Ok((ticket, point)) = job else { break };
                    let start = Instant::now();
                    let (outcome, notes) = run_simulator(simulator, &point);
                    let wall_s = start.elapsed().as_secs_f64();
                    if result_sender
                        .send((ticket, outcome, wall_s, notes))
                        .is_err()
                    {
                        break;
                    }
                });
            }
            drop(result_sender);
            let mut runs = AsyncRuns {
                evaluator: self,
                jobs: Some(job_sender.clone()),
                results: result_receiver,
                in_flight: Vec::new(),
                next_ticket: 0,
            };
            let result = body(&mut runs);
            // Closing the queue lets the workers end once their runs do.
            runs.jobs = None;
            drop(job_sender);
            result
        })
    }
}

/// One point started by [`AsyncRuns::start`].
struct InFlight {
    ticket: u64,
    point: Vec<f64>,
    /// Its result in the log of an earlier run, if there is one.
    logged: Option<Evaluation>,
}

/// What a worker of [`Evaluator::run_async`] sends back: the ticket of
/// the point, its outcome, wall time and notes.
type RunResult = (u64, Result<Vec<f64>, String>, f64, Vec<String>);

/// The runs of [`Evaluator::run_async`].
pub struct AsyncRuns<'e, 'a> {
    evaluator: &'e mut Evaluator<'a>,
    jobs: Option<std::sync::mpsc::Sender<(u64, Vec<f64>)>>,
    results: std::sync::mpsc::Receiver<RunResult>,
    in_flight: Vec<InFlight>,
    next_ticket: u64,
}

impl AsyncRuns<'_, '_> {
    /// Points started and not yet taken by `next_done`.
    pub fn in_flight(&self) -> Vec<Vec<f64>> {
        self.in_flight.iter().map(|f| f.point.clone()).collect()
    }

    /// Starts `point` (answered from the log when it is there).
    pub fn start(&mut self, point: Vec<f64>) -> Result<(), EvaluationError> {
        if stop_requested() {
            return Err(EvaluationError::Stopped);
        }
        let n_parameters = self.evaluator.simulator.parameters().len();
        if point.len() != n_parameters {
            return Err(EvaluationError::Setup(format!(
                "a point has {} values; the simulator takes {n_parameters}",
                point.len()
            )));
        }
        let ticket = self.next_ticket;
        self.next_ticket += 1;
        let logged = self
            .evaluator
            .earlier
            .get_mut(&key(&point))
            .and_then(|list| (!list.is_empty()).then(|| list.remove(0)));
        if logged.is_none() {
            let sent = self
                .jobs
                .as_ref()
                .map(|jobs| jobs.send((ticket, point.clone())));
            if !matches!(sent, Some(Ok(()))) {
                return Err(EvaluationError::Setup(
                    "the evaluation workers stopped unexpectedly".into(),
                ));
            }
        }
        self.in_flight.push(InFlight {
            ticket,
            point,
            logged,
        });
        Ok(())
    }

    /// The next finished evaluation (logged before it is returned), or
    /// `None` when nothing is in flight.
    pub fn next_done(&mut self) -> Result<Option<Evaluation>, EvaluationError> {
        if self.in_flight.is_empty() {
            return Ok(None);
        }
        // From the log first, in the order it was written.
        let logged = self
            .in_flight
            .iter()
            .enumerate()
            .filter_map(|(i, f)| f.logged.as_ref().map(|e| (i, e.id)))
            .min_by_key(|&(_, id)| id)
            .map(|(i, _)| i);
        let evaluation = match logged {
            Some(index) => {
                let flight = self.in_flight.remove(index);
                let mut evaluation = flight.logged.unwrap_or_else(|| unreachable!());
                evaluation.from_log = true;
                evaluation
            }
            None => {
                let (ticket, outcome, wall_s, notes) = self.results.recv().map_err(|_| {
                    EvaluationError::Setup("the evaluation workers stopped unexpectedly".into())
                })?;
                if outcome.is_err() && stop_requested() {
                    return Err(EvaluationError::Stopped);
                }
                let index = self
                    .in_flight
                    .iter()
                    .position(|f| f.ticket == ticket)
                    .ok_or_else(|| EvaluationError::Setup("a result nobody asked for".into()))?;
                let flight = self.in_flight.remove(index);
                let evaluation = Evaluation {
                    id: self.evaluator.next_id,
                    parameters: flight.point,
                    outcome,
                    wall_s,
                    from_log: false,
                    notes,
                };
                self.evaluator.next_id += 1;
                if let Some(log) = &self.evaluator.log {
                    let outputs = self.evaluator.simulator.outputs().len();
                    log.lock()
                        .map_err(|_| EvaluationError::Setup("the log writer panicked".into()))?
                        .append(&evaluation, outputs)?;
                }
                evaluation
            }
        };
        if let Some(progress) = &self.evaluator.progress {
            progress(&evaluation);
        }
        self.evaluator.finished.push(evaluation.clone());
        Ok(Some(evaluation))
    }
}

/// One simulator call, with a panic or a wrong answer turned into a
/// failure.
fn run_simulator(
    simulator: &dyn Simulator,
    point: &[f64],
) -> (Result<Vec<f64>, String>, Vec<String>) {
    let columns = simulator.note_columns().len();
    let (outcome, mut notes) = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        simulator.evaluate_noted(point)
    }))
    .unwrap_or_else(|payload| (Err(panic_message(payload.as_ref())), Vec::new()));
    // One note per column, whatever the simulator gave.
    notes.resize(columns, String::new());
    (checked_outputs(simulator, outcome), notes)
}

/// Why a simulator panicked, from the panic's payload.
fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    let message = payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| (*s).to_string()))
        .unwrap_or_else(|| "unknown panic".into());
    format!("the simulator panicked: {message}")
}

/// A simulator's answer with a wrong count or a non-finite value turned
/// into a failure.
fn checked_outputs(
    simulator: &dyn Simulator,
    outcome: Result<Vec<f64>, String>,
) -> Result<Vec<f64>, String> {
    let outputs = simulator.outputs().len();
    let outcome = outcome?;
    if outcome.len() != outputs {
        return Err(format!(
            "the simulator returned {} values; {outputs} outputs were expected",
            outcome.len()
        ));
    }
    if let Some(i) = outcome.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "output {} is not finite ({})",
            simulator.outputs()[i],
            outcome[i]
        ));
    }
    Ok(outcome)
}

/// Reads a log: its records, and the length of its whole lines (a last
/// line without a newline was cut by a crash and is not a record).
fn read_log(
    path: &Path,
    header: &str,
    simulator: &dyn Simulator,
) -> Result<(Vec<Evaluation>, u64), EvaluationError> {
    let io = |source| EvaluationError::Io {
        path: path.to_path_buf(),
        source,
    };
    let log_error = |line: usize, message: String| EvaluationError::Log {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut reader = BufReader::new(File::open(path).map_err(io)?);
    let mut records = Vec::new();
    let mut whole_length = 0u64;
    let mut bytes = Vec::new();
    let mut number = 0;
    let n_parameters = simulator.parameters().len();
    let n_outputs = simulator.outputs().len();
    let n_notes = simulator.note_columns().len();
    loop {
        bytes.clear();
        let read = reader.read_until(b'\n', &mut bytes).map_err(io)?;
        if read == 0 || bytes.last() != Some(&b'\n') {
            break;
        }
        number += 1;
        whole_length += read as u64;
        let text = std::str::from_utf8(&bytes).map_err(|_| {
            log_error(
                number,
                "not text (invalid UTF-8): the log is damaged; repair or delete this line, or start a new run without --resume".into(),
            )
        })?;
        let text = text.trim_end_matches(['\n', '\r']);
        if number == 1 {
            if text != header {
                return Err(log_error(
                    1,
                    format!(
                        "this log is of another setup: its columns are\n  {text}\nbut this run has\n  {header}\nchoose another output directory"
                    ),
                ));
            }
            continue;
        }
        let cells = split_csv_line(text);
        let expected = 3 + n_parameters + n_outputs + 1 + n_notes;
        if cells.len() != expected {
            return Err(log_error(
                number,
                format!("expected {expected} cells, found {}", cells.len()),
            ));
        }
        let number_at = |i: usize| -> Result<f64, EvaluationError> {
            cells[i]
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    log_error(
                        number,
                        format!("cell {} ({:?}) is not a number", i + 1, cells[i]),
                    )
                })
        };
        let parameters = (3..3 + n_parameters)
            .map(number_at)
            .collect::<Result<Vec<_>, _>>()?;
        let outcome = match cells[1].as_str() {
            "ok" => Ok((3 + n_parameters..3 + n_parameters + n_outputs)
                .map(number_at)
                .collect::<Result<Vec<_>, _>>()?),
            "failed" => Err(cells[3 + n_parameters + n_outputs].clone()),
            other => {
                return Err(log_error(
                    number,
                    format!("status must be ok or failed, found {other:?}"),
                ))
            }
        };
        records.push(Evaluation {
            id: records.len() + 1,
            parameters,
            outcome,
            wall_s: cells[2].parse().unwrap_or(0.0),
            from_log: true,
            notes: cells[expected - n_notes..].to_vec(),
        });
    }
    Ok((records, whole_length))
}

/// Splits one CSV line; quoted cells may hold commas and doubled quotes.
fn split_csv_line(line: &str) -> Vec<String> {
    let mut cells = Vec::new();
    let mut cell = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cell.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => cells.push(std::mem::take(&mut cell)),
            _ => cell.push(c),
        }
    }
    cells.push(cell);
    cells
}
