//! The Python package's binding, the extension module `acq._acq`: acq's
//! libraries called from Python. Tables cross as Arrow record batches
//! through the C data interface (pyarrow takes the buffers, nothing is
//! copied or printed in between); everything else as plain values. It
//! holds no logic of its own: what it calls is what the command line
//! calls, and the package's Python side (`python/acq/`) only names and
//! shapes the results.

use std::path::{Path, PathBuf};

use acq_analysis::decode::{decode_dbc_to_arrow, decode_rig_to_arrow, DbcDecodeOptions};
use acq_analysis::recording::Recording;
use acq_calib::evaluation::{clear_stop_request, request_stop};
use acq_drivers::dbc::DbcDatabase;
use acq_io::error::AcqError;
use acq_io::input::{load_rig, open_logs, open_session_log, BadLines, LogInput};
use acq_study::study::{Model, ModelRun};
use acq_workflows::calibrate::external::{self, CalibrateExternalOptions};
use arrow_pyarrow::{IntoPyArrow, Table};
use pyo3::exceptions::{PyKeyboardInterrupt, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// acq's errors as Python's: a bad argument, rig or spec and malformed
/// input are `ValueError`s (their messages name the file and line), a
/// failed read or write an `OSError`, an interrupted run a
/// `KeyboardInterrupt`.
fn python_error(error: AcqError) -> PyErr {
    let message = error.to_string();
    match error {
        AcqError::Config(_) | AcqError::Malformed(_) => PyValueError::new_err(message),
        AcqError::Interrupted(_) => PyKeyboardInterrupt::new_err(message),
        AcqError::Io { .. } => PyOSError::new_err(message),
    }
}

/// The logs to read and the rig that decodes them: a session directory's
/// raw logs and its copy of the rig (unless `rig` is given), else the log
/// file itself.
fn inputs_of(
    log: &Path,
    rig: Option<&Path>,
) -> Result<(Vec<LogInput>, Option<acq_drivers::rig::Rig>), AcqError> {
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

/// Decodes a log (candump, ASC, BLF, MF4) or a session directory through a
/// rig (`time_s`, `sensor`, `value`, `unit`) or DBC files (`time_s`,
/// `iface`, `can_id`, `message`, `signal`, `value`, `unit`[, `label`]):
/// the table `acq decode -o FILE.parquet` writes, as a `pyarrow.Table`.
#[pyfunction]
#[pyo3(signature = (log, rig=None, dbc=Vec::new(), labels=false, skip_bad=false))]
fn decode(
    py: Python<'_>,
    log: PathBuf,
    rig: Option<PathBuf>,
    dbc: Vec<PathBuf>,
    labels: bool,
    skip_bad: bool,
) -> PyResult<Py<PyAny>> {
    let bad_lines = if skip_bad {
        BadLines::Skip
    } else {
        BadLines::Stop
    };
    let decoded = py.detach(|| {
        let (mut inputs, rig) = inputs_of(&log, rig.as_deref())?;
        match (rig, dbc.is_empty()) {
            (Some(rig), true) => decode_rig_to_arrow(&mut inputs, &rig, bad_lines),
            (None, false) => {
                let (database, _warnings) =
                    DbcDatabase::load_all(&dbc).map_err(|e| AcqError::Config(e.to_string()))?;
                let options = DbcDecodeOptions { bad_lines, labels };
                decode_dbc_to_arrow(&mut inputs, &database, options)
            }
            (Some(_), false) => Err(AcqError::Config(
                "decode: give rig= or dbc=, not both (a session directory brings its rig)".into(),
            )),
            (None, true) => Err(AcqError::Config(format!(
                "decode: {} is a log: give rig= (a rig file) or dbc= (DBC files) to decode it",
                log.display()
            ))),
        }
    });
    let (schema, batches, _summary) = decoded.map_err(python_error)?;
    let table =
        Table::try_new(batches, schema).map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(table.into_pyarrow(py)?.unbind())
}

/// A Python callable as the study's model: called with the parameters and
/// the case's inputs as a dict of floats, it returns a dict of outputs (a
/// float, or for a curve a pair of sequences x and y). An exception is a
/// failed run, its traceback the log's reason.
struct PythonModel {
    callable: Py<PyAny>,
}

impl PythonModel {
    fn call(
        &self,
        py: Python<'_>,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> PyResult<ModelRun> {
        let arguments = PyDict::new(py);
        for (name, value) in inputs {
            arguments.set_item(name, value)?;
        }
        let outputs = self.callable.bind(py).call1((arguments,))?;
        let output = |name: &str| {
            outputs.get_item(name).map_err(|_| {
                PyValueError::new_err(format!(
                    "the model returned no output {name:?}: return a dict with a value for every output the spec observes"
                ))
            })
        };
        let scalars = scalars
            .iter()
            .map(|name| output(name)?.extract::<f64>())
            .collect::<PyResult<Vec<f64>>>()?;
        let curves = curves
            .iter()
            .map(|name| {
                let curve = output(name)?;
                let x: Vec<f64> = curve.get_item(0)?.extract()?;
                let y: Vec<f64> = curve.get_item(1)?.extract()?;
                if x.len() != y.len() {
                    return Err(PyValueError::new_err(format!(
                        "curve {name:?}: {} x values and {} y values",
                        x.len(),
                        y.len()
                    )));
                }
                Ok(x.into_iter().zip(y).collect())
            })
            .collect::<PyResult<Vec<Vec<(f64, f64)>>>>()?;
        Ok(ModelRun { scalars, curves })
    }
}

impl Model for PythonModel {
    fn run(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> Result<ModelRun, String> {
        Python::attach(|py| {
            self.call(py, inputs, scalars, curves).map_err(|error| {
                // The function itself ended with KeyboardInterrupt: the
                // user wants the study to stop, not a failed run.
                if error.is_instance_of::<PyKeyboardInterrupt>(py) {
                    request_stop();
                }
                let traceback = error
                    .traceback(py)
                    .and_then(|t| t.format().ok())
                    .unwrap_or_default();
                format!("Python: {traceback}{error}")
            })
        })
    }
}

/// Runs the study a spec describes into `out` (as `acq calibrate external
/// --spec SPEC --out OUT`): its progress on the terminal, its files in
/// `out`. With `model`, a Python callable is the model and the spec's
/// command (if any) is not run.
#[pyfunction]
#[pyo3(signature = (spec, out, seed=1, resume=false, model=None))]
fn calibrate(
    py: Python<'_>,
    spec: PathBuf,
    out: PathBuf,
    seed: u64,
    resume: bool,
    model: Option<Py<PyAny>>,
) -> PyResult<()> {
    let options = CalibrateExternalOptions {
        spec,
        out,
        resume,
        seed,
    };
    let out_dir = options.out.display().to_string();
    let result = match model {
        None => until_done_or_interrupted(py, || external::run(options)),
        Some(callable) => {
            let name = callable
                .bind(py)
                .getattr("__qualname__")
                .and_then(|n| n.extract::<String>())
                .unwrap_or_else(|_| "a Python callable".into());
            let model = PythonModel { callable };
            let name = format!("Python: {name}");
            until_done_or_interrupted(py, || external::run_with_model(options, &model, &name))
        }
    };
    result.map_err(|error| match error {
        AcqError::Interrupted(_) => PyKeyboardInterrupt::new_err(format!(
            "the study stopped; every finished run is in {out_dir}/evaluations.csv: calibrate(..., resume=True) continues it"
        )),
        other => python_error(other),
    })
}

/// Runs `work` (a study) on a thread of its own while this one, which
/// Python's signals reach, looks for Ctrl-C every 100 ms: then the study
/// starts no further run, the runs under way finish and are logged, and
/// the study ends as interrupted (resumable).
fn until_done_or_interrupted<W>(py: Python<'_>, work: W) -> Result<(), AcqError>
where
    W: FnOnce() -> Result<(), AcqError> + Send,
{
    clear_stop_request();
    let result = std::thread::scope(|scope| {
        let study = scope.spawn(work);
        while !study.is_finished() {
            if py.check_signals().is_err() {
                request_stop();
            }
            py.detach(|| std::thread::sleep(std::time::Duration::from_millis(100)));
        }
        study.join()
    });
    clear_stop_request();
    result.unwrap_or_else(|_| Err(AcqError::Config("the study's thread panicked".into())))
}

/// The package's version: acq's.
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _acq(module: &Bound<'_, PyModule>) -> PyResult<()> {
    module.add_function(wrap_pyfunction!(decode, module)?)?;
    module.add_function(wrap_pyfunction!(calibrate, module)?)?;
    module.add_function(wrap_pyfunction!(version, module)?)?;
    Ok(())
}
