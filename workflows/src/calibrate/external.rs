//! `acq calibrate external --spec FILE.toml --out DIR`: the engine on a
//! user's own solver (a COMSOL or Abaqus batch job, a script), run as a
//! command once per evaluation.
//!
//! Each evaluation gets its own directory `DIR/runs/NNNNNN/`, which is the
//! command's working directory (solvers write fixed file names there, so
//! parallel runs must not share one), holding `params.json`
//! (`{"name": value, ...}`), the command's `stdout.txt` and `stderr.txt`,
//! the files of `link_files` (symbolic links) and `copy_files` (copies),
//! and the output file the command writes: a JSON object
//! `{"output": value, ...}` or a CSV with a header row and one data row.
//! The command is an argument list (no shell) in which `{params}`, `{out}`,
//! `{dir}` and `{NAME}` (a parameter's value) are replaced; the program or
//! an argument that names a file next to the spec is that file (resolved
//! against the spec's directory, whatever the working directory). A run that
//! exits non-zero, times out (it is killed) or leaves no readable output
//! is retried `retries` times, then logged as failed with the reason (the
//! end of its stderr); it never ends the calibration.
//!
//! The loss is the mean (or largest) of the errors, in %: each scalar
//! output's relative error against its measured value, and each curve's
//! MAPE against its measured curve (`[[curve]]`: the solver writes a CSV in
//! its run directory; the error is the published curve MAPE of
//! [`acq_analysis::loss::curve`], the same as the GTN calibration's). It is
//! minimised by Bayesian optimisation from a space-filling start.
//!
//! ```toml
//! command = ["sh", "solver.sh", "{params}", "{out}"]
//! output_file = "out.json"   # in the run directory
//! link_files = ["mesh.inp"]  # next to the spec; linked into each run directory
//! copy_files = []            # copied instead (for files the solver changes)
//! timeout_s = 600            # at most 10,000,000 s
//! retries = 1                # at most 100
//! parallel = 2               # solver licences, 1 to 256
//!
//! [[parameter]]
//! name = "youngs_modulus_gpa"
//! lower = 180.0
//! upper = 220.0
//!
//! [[output]]
//! name = "tip_deflection_mm"
//! measured = 12.5
//!
//! [[curve]]                  # optional, any number
//! name = "force_displacement"
//! file = "curve.csv"         # written by the solver in its run directory
//! x = "u_mm"                 # its columns
//! y = "f_kn"
//! measured_file = "test.csv" # next to the spec
//! measured_x = "DISPLACEMENT"
//! measured_y = "FORCE"
//!
//! [search]
//! start = "lhs"              # lhs, sobol, l12, factorial, or a CSV file of points
//! start_runs = 10
//! max_evals = 60
//! target_loss_pct = 1.0
//! loss = "mean"              # or "max"
//! ```

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use acq_analysis::loss::curve::{curve_mape, CurveMapeOptions};
use acq_calib::bo::BoSettings;
use acq_calib::doe::{
    full_factorial, latin_hypercube, orthogonal_array_l12, read_design_csv, sobol_points,
    two_level_to_unit,
};
use acq_calib::evaluation::{Parameter, Simulator};
use acq_io::error::{AcqError, Result};
use acq_report::document::{Document, Figure, Table};
use acq_report::plot::{chart_svg, Chart, Series, SeriesStyle};
use clap::Args;
use serde::Deserialize;
use serde_json::json;

use super::progress::Progress;
use super::report::{write_report, write_text};
use super::run_directory::RunDirectory;
use super::search::{distinct_best, minimise_logged, scored, to_unit};

#[derive(Args, Debug)]
pub struct CalibrateExternalArgs {
    /// The spec (TOML): command, parameters, outputs with measured values, search.
    #[arg(long, value_name = "FILE.toml")]
    pub spec: PathBuf,
    /// Run directory: evaluations.csv, runs/, summary.json, report.md, plots.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Continue the run in DIR: evaluations already in its log are not repeated.
    #[arg(long)]
    pub resume: bool,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// Program and arguments; placeholders `{params}`, `{out}`, `{dir}`, `{NAME}`.
    pub command: Vec<String>,
    /// File the command writes, relative to the run directory (.json or
    /// .csv); needed when there are scalar outputs.
    #[serde(default)]
    pub output_file: String,
    /// Files next to the spec each run needs, linked into its directory.
    #[serde(default)]
    pub link_files: Vec<String>,
    /// Files next to the spec each run needs a copy of.
    #[serde(default)]
    pub copy_files: Vec<String>,
    #[serde(default = "default_timeout_s")]
    pub timeout_s: f64,
    #[serde(default)]
    pub retries: u32,
    #[serde(default = "default_parallel")]
    pub parallel: usize,
    #[serde(rename = "parameter")]
    pub parameters: Vec<Parameter>,
    #[serde(rename = "output", default)]
    pub outputs: Vec<MeasuredOutput>,
    #[serde(rename = "curve", default)]
    pub curves: Vec<MeasuredCurve>,
    #[serde(default)]
    pub search: Search,
}

fn default_timeout_s() -> f64 {
    3600.0
}

fn default_parallel() -> usize {
    1
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasuredOutput {
    pub name: String,
    pub measured: f64,
}

/// A curve the solver writes, compared with a measured one by curve MAPE.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasuredCurve {
    pub name: String,
    /// The CSV the solver writes in its run directory.
    pub file: String,
    /// Its x and y column names.
    pub x: String,
    pub y: String,
    /// The measured curve, a CSV next to the spec, and its column names.
    pub measured_file: String,
    pub measured_x: String,
    pub measured_y: String,
    /// The measured points, read when the spec is loaded.
    #[serde(skip)]
    pub measured: Vec<(f64, f64)>,
}

/// The points of columns `x` and `y` of a CSV with a header row; errors
/// name the file and line.
fn read_curve(path: &Path, x: &str, y: &str) -> std::result::Result<Vec<(f64, f64)>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let rows = read_design_csv(&text, &[x, y]).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(rows.iter().map(|row| (row[0], row[1])).collect())
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Search {
    #[serde(default = "default_start")]
    pub start: String,
    #[serde(default = "default_start_runs")]
    pub start_runs: usize,
    #[serde(default = "default_max_evals")]
    pub max_evals: usize,
    pub target_loss_pct: Option<f64>,
    #[serde(default = "default_loss")]
    pub loss: String,
}

impl Default for Search {
    fn default() -> Self {
        Search {
            start: default_start(),
            start_runs: default_start_runs(),
            max_evals: default_max_evals(),
            target_loss_pct: None,
            loss: default_loss(),
        }
    }
}

fn default_start() -> String {
    "lhs".into()
}
fn default_start_runs() -> usize {
    10
}
fn default_max_evals() -> usize {
    60
}
fn default_loss() -> String {
    "mean".into()
}

/// Limits of a spec's numbers: beyond them a value is a typo, and some
/// (a timeout past `Instant`'s range) would panic.
const MAX_TIMEOUT_S: f64 = 1e7;
const MAX_RETRIES: u32 = 100;
const MAX_PARALLEL: usize = 256;
const MAX_EVALUATIONS: usize = 100_000;
/// The built-in start designs of `search.start`.
const START_DESIGNS: [&str; 4] = ["lhs", "sobol", "l12", "factorial"];

/// The directory a spec's relative paths start from.
fn spec_directory(spec: &Path) -> PathBuf {
    spec.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

impl Spec {
    /// Reads and checks a spec; errors name the file and what to fix.
    pub fn load(path: &Path) -> Result<Spec> {
        let text = std::fs::read_to_string(path).map_err(|e| AcqError::open(path, e))?;
        acq_io::input::note_input(path);
        let spec: Spec = toml::from_str(&text)
            .map_err(|e| AcqError::Config(format!("{}: {e}", path.display())))?;
        let problem = |message: String| AcqError::Config(format!("{}: {message}", path.display()));
        if spec.command.is_empty() {
            return Err(problem(
                "command is empty; give the program and its arguments".into(),
            ));
        }
        if spec.outputs.is_empty() && spec.curves.is_empty() {
            return Err(problem(
                "no [[output]] with a measured value and no [[curve]] to compare".into(),
            ));
        }
        if !spec.outputs.is_empty() && spec.output_file.is_empty() {
            return Err(problem(
                "output_file: name the file the command writes its outputs to".into(),
            ));
        }
        let mut names: Vec<&str> = spec.outputs.iter().map(|o| o.name.as_str()).collect();
        names.extend(spec.curves.iter().map(|c| c.name.as_str()));
        for (i, name) in names.iter().enumerate() {
            if names[..i].contains(name) {
                return Err(problem(format!(
                    "the output or curve name {name:?} is given twice"
                )));
            }
        }
        if let Some(o) = spec
            .outputs
            .iter()
            .find(|o| !(o.measured.is_finite() && o.measured != 0.0))
        {
            return Err(problem(format!(
                "output {}: measured must be a finite non-zero number (errors are relative to it)",
                o.name
            )));
        }
        if !(spec.timeout_s.is_finite() && spec.timeout_s > 0.0 && spec.timeout_s <= MAX_TIMEOUT_S)
        {
            return Err(problem(format!(
                "timeout_s = {}: give seconds above 0 and at most {MAX_TIMEOUT_S} (116 days)",
                spec.timeout_s
            )));
        }
        if spec.retries > MAX_RETRIES {
            return Err(problem(format!(
                "retries = {}: at most {MAX_RETRIES}",
                spec.retries
            )));
        }
        if !(1..=MAX_PARALLEL).contains(&spec.parallel) {
            return Err(problem(format!(
                "parallel = {}: give 1 to {MAX_PARALLEL} runs at a time",
                spec.parallel
            )));
        }
        let any_run = Path::new("runs/000001");
        if !spec.output_file.is_empty() {
            acq_io::output::inside(any_run, &spec.output_file, "output_file")
                .map_err(|e| problem(e.to_string()))?;
        }
        let spec_directory = spec_directory(path);
        let mut spec = spec;
        for curve in &mut spec.curves {
            acq_io::output::inside(any_run, &curve.file, "curve.file")
                .map_err(|e| problem(e.to_string()))?;
            let measured_path = spec_directory.join(&curve.measured_file);
            acq_io::input::note_input(&measured_path);
            curve.measured = read_curve(&measured_path, &curve.measured_x, &curve.measured_y)
                .map_err(|e| AcqError::Malformed(format!("curve {}: {e}", curve.name)))?;
            if curve.measured.len() < 2 {
                return Err(AcqError::Malformed(format!(
                    "curve {}: {} has {} point(s); a measured curve needs at least 2",
                    curve.name,
                    measured_path.display(),
                    curve.measured.len()
                )));
            }
        }
        for (what, files) in [
            ("link_files", &spec.link_files),
            ("copy_files", &spec.copy_files),
        ] {
            for file in files {
                acq_io::output::inside(any_run, file, what).map_err(|e| problem(e.to_string()))?;
                let source = spec_directory.join(file);
                if !source.exists() {
                    return Err(problem(format!(
                        "{what}: {} does not exist (paths are relative to the spec)",
                        source.display()
                    )));
                }
                acq_io::input::note_input(&source);
            }
        }
        if !START_DESIGNS.contains(&spec.search.start.as_str())
            && !spec.search.start.ends_with(".csv")
        {
            return Err(problem(format!(
                "search.start = {:?}: use one of {}, or a CSV file of points (name ending in .csv, next to the spec)",
                spec.search.start,
                START_DESIGNS.join(", ")
            )));
        }
        if !matches!(spec.search.loss.as_str(), "mean" | "max") {
            return Err(problem(format!(
                "search.loss {:?}: use mean or max",
                spec.search.loss
            )));
        }
        if !(3..=MAX_EVALUATIONS).contains(&spec.search.max_evals)
            || !(2..=MAX_EVALUATIONS).contains(&spec.search.start_runs)
        {
            return Err(problem(format!(
                "search: give max_evals from 3 and start_runs from 2, each at most {MAX_EVALUATIONS} (got {} and {})",
                spec.search.max_evals, spec.search.start_runs
            )));
        }
        acq_calib::evaluation::validate_parameters(&spec.parameters)
            .map_err(|e| problem(e.to_string()))?;
        Ok(spec)
    }
}

/// The user's solver as the engine sees it.
pub struct ExternalSimulator {
    spec: Spec,
    /// Where relative program and file paths in the spec start.
    spec_directory: PathBuf,
    runs: PathBuf,
    outputs: Vec<String>,
    counter: AtomicUsize,
}

impl ExternalSimulator {
    pub fn new(mut spec: Spec, spec_directory: PathBuf, runs: PathBuf) -> Self {
        let highest = highest_run_number(&runs);
        let outputs = spec
            .outputs
            .iter()
            .map(|o| o.name.clone())
            .chain(spec.curves.iter().map(|c| c.name.clone()))
            .collect();
        // The runs start in their own directories: a program or argument that
        // names a file next to the spec must still find it.
        for argument in &mut spec.command {
            let next_to_spec = spec_directory.join(&*argument);
            if !argument.contains('{')
                && Path::new(argument).is_relative()
                && next_to_spec.is_file()
            {
                if let Ok(absolute) = next_to_spec.canonicalize() {
                    *argument = absolute.display().to_string();
                }
            }
        }
        ExternalSimulator {
            spec,
            spec_directory,
            runs,
            outputs,
            // A resumed run numbers on after the directories already there,
            // so the interrupted run's files are kept.
            counter: AtomicUsize::new(highest),
        }
    }

    fn run_once(&self, values: &[f64], directory: &Path) -> std::result::Result<Vec<f64>, String> {
        std::fs::create_dir_all(directory).map_err(|e| format!("{}: {e}", directory.display()))?;
        let params: serde_json::Map<String, serde_json::Value> = self
            .spec
            .parameters
            .iter()
            .zip(values)
            .map(|(p, v)| (p.name.clone(), json!(v)))
            .collect();
        let params_path = directory.join("params.json");
        std::fs::write(&params_path, serde_json::Value::Object(params).to_string())
            .map_err(|e| format!("{}: {e}", params_path.display()))?;
        let output_path = acq_io::output::inside(directory, &self.spec.output_file, "output_file")
            .ok()
            .filter(|_| !self.spec.output_file.is_empty());
        let curve_paths = self
            .spec
            .curves
            .iter()
            .map(|c| acq_io::output::inside(directory, &c.file, "curve.file"))
            .collect::<Result<Vec<_>>>()
            .map_err(|e| e.to_string())?;
        // A file left by an earlier attempt must not pass for this one's.
        for path in output_path.iter().chain(&curve_paths) {
            let _ = std::fs::remove_file(path);
        }
        self.stage_files(directory)?;
        let substitute = |argument: &str| -> String {
            let mut text = argument
                .replace("{params}", &params_path.display().to_string())
                .replace(
                    "{out}",
                    &output_path
                        .as_ref()
                        .map_or_else(String::new, |p| p.display().to_string()),
                )
                .replace("{dir}", &directory.display().to_string());
            for (p, v) in self.spec.parameters.iter().zip(values) {
                text = text.replace(&format!("{{{}}}", p.name), &v.to_string());
            }
            text
        };
        let arguments: Vec<String> = self.spec.command.iter().map(|a| substitute(a)).collect();
        let stdout =
            std::fs::File::create(directory.join("stdout.txt")).map_err(|e| e.to_string())?;
        let stderr =
            std::fs::File::create(directory.join("stderr.txt")).map_err(|e| e.to_string())?;
        let mut child = Command::new(&arguments[0])
            .args(&arguments[1..])
            .current_dir(directory)
            .stdin(Stdio::null())
            .stdout(stdout)
            .stderr(stderr)
            .spawn()
            .map_err(|e| format!("cannot start {:?}: {e}", arguments[0]))?;
        let deadline = Instant::now() + Duration::from_secs_f64(self.spec.timeout_s);
        let status = loop {
            match child.try_wait() {
                Ok(Some(status)) => break status,
                Ok(None) if Instant::now() >= deadline => {
                    // A solver started through a shell or a wrapper has
                    // children of its own: kill the whole tree, leaves first.
                    kill_process_tree(child.id());
                    let _ = child.kill();
                    let _ = child.wait();
                    return Err(format!(
                        "timed out after {} s (killed)",
                        self.spec.timeout_s
                    ));
                }
                Ok(None) => std::thread::sleep(Duration::from_millis(20)),
                Err(e) => return Err(format!("waiting for the solver: {e}")),
            }
        };
        if !status.success() {
            let tail = std::fs::read_to_string(directory.join("stderr.txt")).unwrap_or_default();
            let tail: String = tail
                .lines()
                .rev()
                .take(3)
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .collect::<Vec<_>>()
                .join(" / ");
            return Err(format!("the solver exited with {status}: {tail}"));
        }
        let scalar_names = &self.outputs[..self.spec.outputs.len()];
        let mut values = match &output_path {
            Some(path) => read_outputs(path, scalar_names)?,
            None => Vec::new(),
        };
        for (curve, path) in self.spec.curves.iter().zip(&curve_paths) {
            let simulated = read_curve(path, &curve.x, &curve.y)
                .map_err(|e| format!("curve {}: {e}", curve.name))?;
            let mape = curve_mape(&curve.measured, &simulated, CurveMapeOptions::default())
                .map_err(|e| format!("curve {}: {e}", curve.name))?;
            values.push(mape.mape_percent);
        }
        Ok(values)
    }
}

impl ExternalSimulator {
    /// Links (`link_files`) and copies (`copy_files`) the solver's files
    /// from the spec's directory into a run directory.
    fn stage_files(&self, directory: &Path) -> std::result::Result<(), String> {
        let stage = |file: &String, copy: bool| -> std::result::Result<(), String> {
            let source = self
                .spec_directory
                .join(file)
                .canonicalize()
                .map_err(|e| format!("{file} (next to the spec): {e}"))?;
            let target = directory.join(file);
            if let Some(parent) = target.parent() {
                std::fs::create_dir_all(parent)
                    .map_err(|e| format!("{}: {e}", parent.display()))?;
            }
            let _ = std::fs::remove_file(&target);
            let done = if copy {
                std::fs::copy(&source, &target).map(drop)
            } else {
                std::os::unix::fs::symlink(&source, &target)
            };
            done.map_err(|e| {
                format!(
                    "staging {} in {}: {e}",
                    source.display(),
                    directory.display()
                )
            })
        };
        for file in &self.spec.link_files {
            stage(file, false)?;
        }
        for file in &self.spec.copy_files {
            stage(file, true)?;
        }
        Ok(())
    }
}

/// The largest `NNNNNN` among the run directories (0 if none).
fn highest_run_number(runs: &Path) -> usize {
    std::fs::read_dir(runs)
        .map(|entries| {
            entries
                .filter_map(|e| e.ok()?.file_name().to_str()?.parse::<usize>().ok())
                .max()
                .unwrap_or(0)
        })
        .unwrap_or(0)
}

/// SIGKILL to every descendant of `root` (found through /proc), deepest
/// first. The solver stays in acq's process group, so Ctrl-C on the
/// terminal still reaches it; a timeout has to find its children itself.
fn kill_process_tree(root: u32) {
    let parent_of = |pid: u32| -> Option<u32> {
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
        // The command name in parentheses may hold spaces: parse after it.
        let after = stat.rsplit_once(')')?.1;
        after.split_whitespace().nth(1)?.parse().ok()
    };
    let all: Vec<u32> = std::fs::read_dir("/proc")
        .map(|entries| {
            entries
                .filter_map(|e| e.ok()?.file_name().to_str()?.parse().ok())
                .collect()
        })
        .unwrap_or_default();
    let mut tree = vec![root];
    let mut index = 0;
    while index < tree.len() {
        let parent = tree[index];
        tree.extend(
            all.iter()
                .copied()
                .filter(|&pid| parent_of(pid) == Some(parent)),
        );
        index += 1;
    }
    for &pid in tree.iter().skip(1).rev() {
        if let Ok(pid) = i32::try_from(pid) {
            let _ = nix::sys::signal::kill(
                nix::unistd::Pid::from_raw(pid),
                nix::sys::signal::Signal::SIGKILL,
            );
        }
    }
}

/// The outputs from a JSON object or a one-row CSV, by name.
fn read_outputs(path: &Path, names: &[String]) -> std::result::Result<Vec<f64>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("the solver left no output {}: {e}", path.display()))?;
    let is_json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let values: std::collections::HashMap<String, f64> = if is_json {
        let value: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| format!("{}: not JSON: {e}", path.display()))?;
        value
            .as_object()
            .ok_or_else(|| format!("{}: expected a JSON object of outputs", path.display()))?
            .iter()
            .filter_map(|(k, v)| Some((k.clone(), v.as_f64()?)))
            .collect()
    } else {
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header = lines.next().unwrap_or("");
        let row = lines
            .next()
            .ok_or_else(|| format!("{}: a header and one data row expected", path.display()))?;
        header
            .split(',')
            .zip(row.split(','))
            .filter_map(|(h, v)| Some((h.trim().to_string(), v.trim().parse().ok()?)))
            .collect()
    };
    let lookup = |name: &str| values.get(name).copied();
    names
        .iter()
        .map(|name| {
            lookup(name).ok_or_else(|| format!("{}: no number for output {name}", path.display()))
        })
        .collect()
}

impl Simulator for ExternalSimulator {
    fn parameters(&self) -> &[Parameter] {
        &self.spec.parameters
    }
    fn outputs(&self) -> &[String] {
        &self.outputs
    }
    fn evaluate(&self, values: &[f64]) -> std::result::Result<Vec<f64>, String> {
        let mut reasons = Vec::new();
        for attempt in 0..=self.spec.retries {
            let number = self.counter.fetch_add(1, Ordering::SeqCst) + 1;
            let directory = self.runs.join(format!("{number:06}"));
            match self.run_once(values, &directory) {
                Ok(outputs) => return Ok(outputs),
                Err(reason) => reasons.push(format!("attempt {}: {reason}", attempt + 1)),
            }
        }
        Err(reasons.join("; "))
    }
}

/// The errors in %, scalar outputs (relative to their measured values)
/// then curves (their MAPE, already in %), and the loss: their mean or
/// largest.
fn errors_pct(spec: &Spec, outputs: &[f64]) -> (Vec<f64>, f64) {
    let scalars = spec.outputs.len();
    let errors: Vec<f64> = spec
        .outputs
        .iter()
        .zip(outputs)
        .map(|(o, &y)| 100.0 * (o.measured - y).abs() / o.measured.abs())
        .chain(outputs.iter().skip(scalars).copied())
        .collect();
    let loss = if spec.search.loss == "max" {
        errors.iter().fold(0.0f64, |a, &b| a.max(b))
    } else {
        errors.iter().sum::<f64>() / errors.len() as f64
    };
    (errors, loss)
}

fn start_design(spec: &Spec, spec_directory: &Path, seed: u64) -> Result<Vec<Vec<f64>>> {
    let d = spec.parameters.len();
    let n = spec.search.start_runs;
    let config = |e: String| AcqError::Config(format!("search.start: {e}"));
    Ok(match spec.search.start.as_str() {
        "lhs" => latin_hypercube(n, d, seed),
        "sobol" => sobol_points(n, d, Some(seed)).map_err(|e| config(e.to_string()))?,
        "l12" => two_level_to_unit(&orthogonal_array_l12(d).map_err(|e| config(e.to_string()))?),
        "factorial" => full_factorial(&vec![2; d]).map_err(|e| config(e.to_string()))?,
        file => {
            let path = spec_directory.join(file);
            let text = std::fs::read_to_string(&path).map_err(|e| AcqError::open(&path, e))?;
            acq_io::input::note_input(&path);
            let names: Vec<&str> = spec.parameters.iter().map(|p| p.name.as_str()).collect();
            let points = read_design_csv(&text, &names)
                .map_err(|e| AcqError::Malformed(format!("{}: {e}", path.display())))?;
            points
                .iter()
                .map(|p| to_unit(&spec.parameters, p))
                .collect()
        }
    })
}

pub fn run(args: CalibrateExternalArgs) -> Result<()> {
    let spec = Spec::load(&args.spec)?;
    let spec_directory = spec_directory(&args.spec);
    // The start design is read before the run directory exists: a refused
    // design leaves nothing behind.
    let initial = start_design(&spec, &spec_directory, args.seed)?;
    let directory = RunDirectory::create(&args.out)?;
    let runs = std::fs::canonicalize(&directory.path)
        .map_err(|e| AcqError::io(format!("resolving {}", directory.path.display()), e))?
        .join("runs");
    let parallel = spec.parallel.max(1);
    let budget = spec.search.max_evals;
    let target = spec.search.target_loss_pct;
    let simulator = ExternalSimulator::new(spec, spec_directory, runs);
    let spec = &simulator.spec;
    let parameters = spec.parameters.clone();
    let progress = Progress::new("calibrate external", budget);
    let start = Instant::now();
    let mut evaluator = directory
        .evaluator(&simulator, parallel, args.resume)?
        .with_progress(|e| {
            let loss = e.outcome.as_ref().ok().map(|y| errors_pct(spec, y).1);
            progress.record(loss, e.outcome.is_err(), e.from_log);
        });
    let settings = BoSettings {
        batch: parallel,
        target_loss: target,
        max_evaluations: budget,
        seed: args.seed,
        ..BoSettings::default()
    };
    let result = minimise_logged(
        &mut evaluator,
        &parameters,
        initial,
        |y| errors_pct(spec, y).1,
        &settings,
    );
    progress.finish();
    if evaluator.evaluations().iter().all(|e| e.outcome.is_err()) {
        if let Some(first) = evaluator.evaluations().first() {
            let reason = first.outcome.as_ref().err().cloned().unwrap_or_default();
            return Err(AcqError::Config(format!(
                "none of the {} solver runs succeeded; the first failed with: {reason}. Each run's stdout.txt and stderr.txt are in {}, every reason in {}",
                evaluator.evaluations().len(),
                simulator.runs.display(),
                directory.file("evaluations.csv").display()
            )));
        }
    }
    let result = result?;
    let wall_s = start.elapsed().as_secs_f64();
    let scored = scored(evaluator.evaluations(), |y| errors_pct(spec, y).1);
    let failed = evaluator
        .evaluations()
        .iter()
        .filter(|e| e.outcome.is_err())
        .count();
    let Some(&(best, best_loss)) = scored.iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
        return Err(AcqError::Config(format!(
            "none of the {} solver runs succeeded; see {}",
            evaluator.evaluations().len(),
            directory.file("evaluations.csv").display()
        )));
    };
    let best_outputs = best.outcome.clone().unwrap_or_default();
    let (best_errors, _) = errors_pct(spec, &best_outputs);
    let summary = json!({
        "best_loss_pct": best_loss,
        "evaluations": evaluator.evaluations().len(),
        "failed": failed,
        "evaluations_to_target": result.evaluations_to_target,
        "best_params": parameters.iter().zip(&best.parameters).map(|(p, v)| (p.name.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
        "best_outputs": simulator.outputs.iter().zip(&best_outputs).map(|(name, v)| (name.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
        "wall_s": wall_s,
    });
    write_text(&directory.file("summary.json"), &format!("{summary:#}\n"))?;

    let mut best_so_far = f64::INFINITY;
    let mut running = Vec::new();
    let mut each = Vec::new();
    for e in evaluator.evaluations() {
        if let Ok(y) = &e.outcome {
            let loss = errors_pct(spec, y).1;
            best_so_far = best_so_far.min(loss);
            each.push((e.id as f64, loss));
        }
        running.push((e.id as f64, best_so_far));
    }
    let chart = Chart::new("Loss per solver run", "evaluation", "loss [%]")
        .with_series(Series::new("run", each).with_style(SeriesStyle::Markers))
        .with_series(Series::new("best so far", running));

    let mut report = Document::new();
    report
        .heading(1, format!("Calibration with {}", args.spec.display()))
        .paragraph(format!(
            "Best loss ({} relative error) {best_loss:.4} % after {} runs ({failed} failed), {wall_s:.1} s; stopped: {:?}.",
            spec.search.loss,
            evaluator.evaluations().len(),
            result.stop
        ))
        .heading(2, "Outputs");
    let mut table = Table::new(&["output", "measured", "best run", "error [%]"]);
    for ((o, y), e) in spec.outputs.iter().zip(&best_outputs).zip(&best_errors) {
        table.row(vec![
            o.name.clone(),
            format!("{}", o.measured),
            format!("{y:.6}"),
            format!("{e:.3}"),
        ]);
    }
    let scalars = spec.outputs.len();
    for (c, e) in spec.curves.iter().zip(best_errors.iter().skip(scalars)) {
        table.row(vec![
            format!("{} (curve)", c.name),
            c.measured_file.clone(),
            format!("{} vs {}", c.file, c.measured_file),
            format!("{e:.3} (MAPE)"),
        ]);
    }
    report.table(table).heading(2, "Parameters");
    let mut table = Table::new(&["parameter", "lower", "upper", "best"]);
    for (p, v) in parameters.iter().zip(&best.parameters) {
        table.row(vec![
            p.name.clone(),
            format!("{}", p.lower),
            format!("{}", p.upper),
            format!("{v:.6}"),
        ]);
    }
    report.table(table);
    let candidates = distinct_best(&parameters, &scored, 5, 0.25);
    report.heading(
        2,
        "Distinct good parameter sets (at least 0.25 apart in the unit box)",
    );
    let mut header = vec!["run".to_string(), "loss [%]".to_string()];
    header.extend(parameters.iter().map(|p| p.name.clone()));
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut table = Table::new(&header);
    for c in &candidates {
        let mut cells = vec![c.evaluation_id.to_string(), format!("{:.4}", c.loss)];
        cells.extend(c.parameters.iter().map(|v| format!("{v:.5}")));
        table.row(cells);
    }
    report.table(table).figure(Figure {
        file: "loss.svg".into(),
        caption: "loss per solver run".into(),
        svg: chart_svg(&chart, 720.0, 420.0),
    });
    write_report(&directory, &report, "External calibration")?;
    println!(
        "best loss {best_loss:.4} % after {} runs ({failed} failed); report in {}",
        evaluator.evaluations().len(),
        directory.file("report.md").display()
    );
    Ok(())
}
