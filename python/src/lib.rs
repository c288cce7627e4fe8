//! The Python package's binding, the extension module `acq._acq`: acq's
//! libraries called from Python. Tables cross as Arrow record batches
//! through the C data interface (pyarrow takes the buffers, nothing is
//! copied or printed in between); everything else as plain values. It
//! holds no logic of its own: what it calls is what the command line
//! calls, and the package's Python side (`python/acq/`) only names and
//! shapes the results.

mod tables;
mod twins;

use std::path::PathBuf;

use acq_algorithms::evaluation::{clear_stop_request, request_stop};
use acq_error::AcqError;
use acq_study::progress::ProgressSnapshot;
use acq_study::study::{Model, ModelRun};
use acq_workflows::calibrate::external::{self, CalibrateExternalOptions};
use pyo3::exceptions::{
    PyFileNotFoundError, PyKeyboardInterrupt, PyOSError, PyPermissionError, PyValueError,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tables::{AlignRequest, CurveRequest, DecodeRequest, HoldsRequest};

/// acq's errors as Python's: a bad argument, rig or spec and malformed
/// input are `ValueError`s (their messages name the file and line), a file
/// that cannot be opened and a failed read or write an `OSError` (a
/// missing one `FileNotFoundError`), an interrupted run a
/// `KeyboardInterrupt`.
fn python_error(error: AcqError) -> PyErr {
    // The engine's messages name the command line's options; a Python user
    // passes keyword arguments.
    let message = error
        .to_string()
        .replace("--resume", "resume=True")
        .replace("--out ", "out=");
    match error {
        AcqError::Config(_) | AcqError::Malformed(_) => PyValueError::new_err(message),
        AcqError::Interrupted(_) => PyKeyboardInterrupt::new_err(message),
        // FileNotFoundError, PermissionError...: the OSError subclass of
        // its errno, as Python's own open() raises.
        AcqError::Open(failure) => match failure.source.kind() {
            std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
            std::io::ErrorKind::PermissionDenied => PyPermissionError::new_err(message),
            _ => PyOSError::new_err(message),
        },
        AcqError::Io { .. } => PyOSError::new_err(message),
    }
}

/// Decodes a log or a session directory: one `pyarrow.Table` (the table
/// `acq decode -o FILE.parquet` writes), or with `stream` the same rows as
/// a `pyarrow.RecordBatchReader`, decoded while Python reads them.
#[pyfunction]
#[pyo3(signature = (log, rig=None, dbc=Vec::new(), labels=false, skip_bad=false, stream=false))]
fn decode(
    py: Python<'_>,
    log: PathBuf,
    rig: Option<PathBuf>,
    dbc: Vec<PathBuf>,
    labels: bool,
    skip_bad: bool,
    stream: bool,
) -> PyResult<Py<PyAny>> {
    let request = DecodeRequest {
        log,
        rig,
        dbc,
        labels,
        skip_bad,
    };
    let table = tables::decode_stream(py, request)?;
    if stream {
        table.into_reader(py)
    } else {
        table.collect(py)
    }
}

/// A session on one time base, as `acq align -o FILE.parquet` writes it.
#[pyfunction]
#[pyo3(signature = (input, rig, rate_hz, method, max_gap, start, end, filter_hz, clock_offsets_ms))]
#[allow(clippy::too_many_arguments)]
fn align(
    py: Python<'_>,
    input: PathBuf,
    rig: Option<PathBuf>,
    rate_hz: f64,
    method: Option<String>,
    max_gap: String,
    start: Option<String>,
    end: Option<String>,
    filter_hz: Option<f64>,
    clock_offsets_ms: Vec<(String, f64)>,
) -> PyResult<Py<PyAny>> {
    let request = AlignRequest {
        input,
        rig,
        rate_hz,
        method,
        max_gap,
        start,
        end,
        filter_hz,
        clock_offsets_ms,
    };
    tables::align_stream(py, request)?.collect(py)
}

/// A session's holds as measured values, as `acq extract -o FILE.parquet`
/// writes them.
#[pyfunction]
#[pyo3(signature = (input, rig, windows, load, steady_std, steady_window_s, min_hold_s, settle_s, min_load, clock_offsets_ms))]
#[allow(clippy::too_many_arguments)]
fn holds(
    py: Python<'_>,
    input: PathBuf,
    rig: Option<PathBuf>,
    windows: Option<PathBuf>,
    load: Option<String>,
    steady_std: Option<f64>,
    steady_window_s: Option<f64>,
    min_hold_s: Option<f64>,
    settle_s: Option<f64>,
    min_load: Option<f64>,
    clock_offsets_ms: Vec<(String, f64)>,
) -> PyResult<Py<PyAny>> {
    let request = HoldsRequest {
        input,
        rig,
        windows,
        load,
        steady_std,
        steady_window_s,
        min_hold_s,
        settle_s,
        min_load,
        clock_offsets_ms,
    };
    tables::holds_table(py, request)?.collect(py)
}

/// A tensile test's curve, as `acq extract --tensile -o FILE.parquet`
/// writes it.
#[pyfunction]
#[pyo3(signature = (input, rig, force, displacement, diameter_mm, gauge_length_mm, clock_offsets_ms))]
#[allow(clippy::too_many_arguments)]
fn tensile_curve(
    py: Python<'_>,
    input: PathBuf,
    rig: Option<PathBuf>,
    force: Option<String>,
    displacement: Option<String>,
    diameter_mm: Option<f64>,
    gauge_length_mm: Option<f64>,
    clock_offsets_ms: Vec<(String, f64)>,
) -> PyResult<Py<PyAny>> {
    let request = CurveRequest {
        input,
        rig,
        force,
        displacement,
        diameter_mm,
        gauge_length_mm,
        clock_offsets_ms,
    };
    tables::curve_table(py, request)?.collect(py)
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
#[pyo3(signature = (spec, out, seed=1, resume=false, model=None, progress=None))]
fn calibrate(
    py: Python<'_>,
    spec: PathBuf,
    out: PathBuf,
    seed: u64,
    resume: bool,
    model: Option<Py<PyAny>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<()> {
    let options = CalibrateExternalOptions {
        spec,
        out,
        resume,
        seed,
    };
    let out_dir = options.out.display().to_string();
    let model = model.map(|callable| {
        let name = callable
            .bind(py)
            .getattr("__qualname__")
            .and_then(|n| n.extract::<String>())
            .unwrap_or_else(|_| "a Python callable".into());
        (PythonModel { callable }, format!("Python: {name}"))
    });
    let observer = progress.map(|callable| {
        move |snapshot: &ProgressSnapshot| {
            Python::attach(|py| tell_progress(py, &callable, snapshot));
        }
    });
    let result = until_done_or_interrupted(py, || {
        let given = model
            .as_ref()
            .map(|(model, name)| (model as &dyn Model, name.as_str()));
        let observer = observer
            .as_ref()
            .map(|o| o as &(dyn Fn(&ProgressSnapshot) + Sync));
        external::run_with_model(options, given, observer)
    });
    result.map_err(|error| match error {
        AcqError::Interrupted(_) => PyKeyboardInterrupt::new_err(format!(
            "the study stopped; every finished run is in {out_dir}/evaluations.csv: calibrate(..., resume=True) continues it"
        )),
        other => python_error(other),
    })
}

/// Runs the mesh study a spec's `[mesh_study]` describes into `out` (as
/// `acq mesh-study --spec SPEC --out OUT`); with `model`, a Python callable
/// is the model and gets the element size as the input `mesh`.
#[pyfunction]
#[pyo3(signature = (spec, out, resume=false, model=None))]
fn mesh_study(
    py: Python<'_>,
    spec: PathBuf,
    out: PathBuf,
    resume: bool,
    model: Option<Py<PyAny>>,
) -> PyResult<()> {
    let options = CalibrateExternalOptions {
        spec,
        out,
        resume,
        seed: 1,
    };
    let model = model.map(|callable| PythonModel { callable });
    let result = until_done_or_interrupted(py, || {
        let given = model
            .as_ref()
            .map(|model| (model as &dyn Model, "a Python callable"));
        external::run_mesh_study(&options, given).map(drop)
    });
    result.map_err(python_error)
}

/// Calls the user's progress function with the line's numbers as a dict.
/// An exception in it is reported as unraisable (printed, as Python does
/// for one in a callback) and the study goes on.
fn tell_progress(py: Python<'_>, callable: &Py<PyAny>, snapshot: &ProgressSnapshot) {
    let told = (|| {
        let numbers = PyDict::new(py);
        numbers.set_item("done", snapshot.done)?;
        numbers.set_item("total", snapshot.total)?;
        numbers.set_item("failed", snapshot.failed)?;
        numbers.set_item("reused", snapshot.reused)?;
        numbers.set_item("best_loss", snapshot.best_loss)?;
        numbers.set_item("elapsed_s", snapshot.elapsed_s)?;
        callable.bind(py).call1((numbers,)).map(drop)
    })();
    if let Err(error) = told {
        error.write_unraisable(py, Some(callable.bind(py)));
    }
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
    // A study's progress lines through Python's sys.stderr: a notebook
    // shows it, and the process's file descriptor 2 it does not.
    acq_study::progress::route_lines(Some(Box::new(|text: &str| {
        Python::attach(|py| {
            if let Ok(stderr) = py.import("sys").and_then(|sys| sys.getattr("stderr")) {
                let _ = stderr.call_method1("write", (text,));
                let _ = stderr.call_method0("flush");
            }
        });
    })));
    module.add_function(wrap_pyfunction!(decode, module)?)?;
    module.add_function(wrap_pyfunction!(align, module)?)?;
    module.add_function(wrap_pyfunction!(holds, module)?)?;
    module.add_function(wrap_pyfunction!(tensile_curve, module)?)?;
    module.add_function(wrap_pyfunction!(twins::twin_excavator, module)?)?;
    module.add_function(wrap_pyfunction!(twins::twin_gtn, module)?)?;
    module.add_function(wrap_pyfunction!(calibrate, module)?)?;
    module.add_function(wrap_pyfunction!(mesh_study, module)?)?;
    module.add_function(wrap_pyfunction!(version, module)?)?;
    Ok(())
}
