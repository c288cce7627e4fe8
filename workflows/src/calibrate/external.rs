//! `acq calibrate external --spec FILE.toml --out DIR`: a study on a
//! user's own solver (a COMSOL or Abaqus batch job, a script), run as a
//! command once per evaluation and load case.
//!
//! Each run gets its own directory `DIR/runs/NNNNNN/`, which is the
//! command's working directory (solvers write fixed file names there, so
//! parallel runs must not share one), holding `params.json`
//! (`{"name": value, ...}`: the parameters and the case's fixed inputs),
//! the command's `stdout.txt` and `stderr.txt`, the files of `link_files`
//! (symbolic links) and `copy_files` (copies), and what the command
//! writes: the output file (a JSON object `{"output": value, ...}` or a CSV
//! with a header row and one data row; nested JSON keys are named by path,
//! `pressure_bar.boom`, `gauges[0]`) and each curve's CSV. The command is
//! an argument list (no shell) in which `{params}`, `{out}`, `{dir}` and
//! `{NAME}` (a parameter's or fixed input's value) are replaced; the
//! program or an argument that names a file next to the spec is that file.
//! A run that exits non-zero, times out (it is killed) or leaves no
//! readable output is retried `retries` times, then logged as failed with
//! the reason (the end of its stderr); it never ends the study. Where a
//! run happens is the [`super::executor`]'s business: a child process, or a
//! Slurm batch job ([`super::slurm`]), whose notes (job id, queue wait, run
//! time) `evaluations.csv` adds. A resumed study re-attaches to the jobs of
//! run directories the interrupted one left (same `params.json`) instead of
//! starting them again.
//!
//! The study ([`super::study`]): parameters shared by all cases or one
//! case's own; `[[case]]`s with a role (`fit` or `validate`), fixed inputs
//! and measured values; without `[[case]]`, the `[[output]]`s and
//! `[[curve]]`s are one fit case's observations. Two methods:
//! - `bo` (the tensile study's): the loss (weighted mean or largest of the
//!   errors) minimised by Bayesian optimisation from a space-filling start;
//! - `surrogate-moo` (the excavator study's): a GP per observation,
//!   NSGA-II over the errors, TOPSIS, the pick re-run
//!   ([`super::surrogate_moo`]).
//!
//! Instead of a command, `model = "excavator"` runs the built-in twin
//! ([`super::builtin`]): its inputs by name, geometry numbers by key path,
//! its outputs by key path of `acq twin excavator --json`.
//!
//! ```toml
//! command = ["sh", "solver.sh", "{params}", "{out}"]
//! output_file = "out.json"   # in the run directory
//! link_files = ["mesh.inp"]  # next to the spec; linked into each run directory
//! copy_files = []            # copied instead (for files the solver changes)
//! timeout_s = 600            # at most 10,000,000 s
//! retries = 1                # at most 100
//! parallel = 2               # solver licences, 1 to 256 (or under [executor])
//!
//! [executor]                 # optional: where the runs happen
//! kind = "slurm"             # or "local" (child processes, the default)
//! partition = "compute"      # slurm only, all optional:
//! account = "project42"
//! time_limit = "2:00:00"     # Slurm's format [default: timeout_s in minutes, + 1]
//! cpus_per_job = 4
//! memory_per_job = "8G"
//! sbatch_args = ["--qos=short"]
//! prelude = ["module load abaqus"]   # lines the job script runs before the solver
//!
//! [[parameter]]
//! name = "youngs_modulus_gpa"
//! lower = 180.0
//! upper = 220.0
//! scale = "linear"           # or "log"
//! nominal = 200.0            # optional: where the initial errors are shown
//!                            # [default: the prior's value, else the middle]
//! # case = "hot"             # optional: this case's own parameter
//! # prior = { value = 205.0, uncertainty = 5.0 }  # optional: a penalty in
//! #                          # standard deviations (needs residuals = "normalised")
//!
//! [[output]]                 # without [[case]]: the observations
//! name = "tip_deflection_mm"
//! measured = 12.5
//! uncertainty = 0.05         # optional, standard uncertainty (same unit)
//!
//! [[curve]]                  # optional, any number
//! name = "force_displacement"
//! file = "curve.csv"         # written by the solver in its run directory
//! x = "u_mm"                 # its columns
//! y = "f_kn"
//! measured_file = "test.csv" # next to the spec (without [[case]])
//! measured_x = "DISPLACEMENT"
//! measured_y = "FORCE"
//!
//! [[case]]                   # optional, any number
//! name = "cold"
//! role = "fit"               # or "validate": never seen by the search
//! inputs = { temperature_c = 20.0 }
//! [case.measured]
//! tip_deflection_mm = 12.5                                 # a value
//! tip_rotation_deg = { value = 1.2, uncertainty = 0.02 }   # with its uncertainty
//! boom_bar = { file = "measured.csv", quantity = "boom_loaded_pressure", hold = "hold1", uncertainty = "std" }
//! force_displacement = { file = "cold.csv", x = "DISPLACEMENT", y = "FORCE" }
//!
//! [search]
//! method = "bo"              # or "surrogate-moo", or "least-squares"
//!                            # (Levenberg-Marquardt from the nominal point,
//!                            # for cheap smooth models; max_evals counts
//!                            # one run per parameter per Jacobian)
//! residuals = "relative"     # or "normalised": scalars in standard uncertainties
//! start = "lhs"              # bo: lhs, sobol, l12, factorial, or a CSV file of points
//! start_runs = 10
//! max_evals = 60
//! target_loss_pct = 1.0
//! loss = "mean"              # or "max", or "squares" (with priors: a MAP estimate)
//! local_steps = true         # bo: trust-region Gauss-Newton steps on the
//!                            # residuals (each scalar's error, each curve's
//!                            # errors in 20 parts) between the global ones;
//!                            # false gives the published search alone
//! training_runs = 40         # surrogate-moo, with test_runs, population,
//! test_runs = 40             # generations, pareto_fraction, kernel,
//!                            # refine_tolerance, refine_rounds
//! ```
//!
//! A measured value read from an `acq extract` file takes the hold's mean;
//! its uncertainty is a number, `"std"` (the spread of the readings in the
//! hold) or `"std_of_mean"` (the standard error of the mean, std over the
//! square root of the effective sample count). Any observation may have a
//! `weight` (1 by default) in the loss and in TOPSIS.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Duration;

use acq_analysis::extract::measured::read_measured;
use acq_calib::bo::Acquisition;
use acq_calib::doe::read_design_csv;
use acq_calib::evaluation::{Parameter, Scale};
use acq_calib::gp::Kernel;
use acq_io::error::{AcqError, Result};
use acq_twins::excavator::geometry::GeometryTemplate;
use clap::Args;
use serde::Deserialize;
use serde_json::json;

use super::builtin::ExcavatorModel;
use super::executor::{Executor, Job, LocalExecutor};
use super::slurm::{SlurmExecutor, SlurmSettings};
use super::study::{
    numbers_by_key_path, Case, LossKind, Measured, Model, ModelRun, Observation, Prior, Residuals,
    Role, Study, StudyParameter,
};
use super::study_runner::{self, Method, RunSettings};
use super::surrogate_moo::{Pick, SurrogateMooSettings};

#[derive(Args, Debug)]
pub struct CalibrateExternalArgs {
    /// The spec (TOML): command, parameters, cases or outputs with measured values, search.
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
    /// `"command"` (a user's solver, the default) or a built-in twin:
    /// `"excavator"`.
    #[serde(default = "default_model")]
    pub model: String,
    /// The built-in excavator's geometry file, next to the spec [default:
    /// the shipped DX55-class file].
    pub geometry: Option<String>,
    /// Re-fit the excavator's pose numbers to the published poses when a
    /// geometry number changes.
    #[serde(default = "default_refit_poses")]
    pub refit_poses: bool,
    /// Program and arguments; placeholders `{params}`, `{out}`, `{dir}`, `{NAME}`.
    #[serde(default)]
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
    /// Runs at a time on the local executor (`[executor] parallel` is the
    /// same, for any executor).
    pub parallel: Option<usize>,
    /// Where the runs happen: `local` (child processes) or `slurm`.
    #[serde(default)]
    pub executor: ExecutorSpec,
    #[serde(rename = "parameter")]
    pub parameters: Vec<SpecParameter>,
    #[serde(rename = "output", default)]
    pub outputs: Vec<MeasuredOutput>,
    #[serde(rename = "curve", default)]
    pub curves: Vec<CurveSpec>,
    #[serde(rename = "case", default)]
    pub cases: Vec<CaseSpec>,
    #[serde(default)]
    pub search: Search,
    /// The study the spec defines, built by [`Spec::load`].
    #[serde(skip)]
    study: Option<Study>,
    /// Runs in flight at once, from `parallel` or `[executor] parallel`.
    #[serde(skip)]
    runs_at_once: usize,
}

fn default_model() -> String {
    "command".into()
}

fn default_refit_poses() -> bool {
    true
}

fn default_timeout_s() -> f64 {
    3600.0
}

/// `[executor]`: where the solver runs.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExecutorSpec {
    /// `"local"` [default] or `"slurm"`.
    pub kind: Option<String>,
    /// Runs (jobs) in flight at once [default: 1].
    pub parallel: Option<usize>,
    pub partition: Option<String>,
    pub account: Option<String>,
    /// Slurm's time limit per job, in Slurm's format.
    pub time_limit: Option<String>,
    pub cpus_per_job: Option<u32>,
    /// Slurm's `--mem` per job (`4G`).
    pub memory_per_job: Option<String>,
    #[serde(default)]
    pub sbatch_args: Vec<String>,
    /// Lines the job script runs before the solver.
    #[serde(default)]
    pub prelude: Vec<String>,
}

impl ExecutorSpec {
    fn is_slurm(&self) -> bool {
        self.kind.as_deref() == Some("slurm")
    }

    /// Checks the section; `top_parallel` is the spec's top-level
    /// `parallel`.
    fn check(&self, top_parallel: Option<usize>) -> std::result::Result<usize, String> {
        match self.kind.as_deref() {
            None | Some("local" | "slurm") => {}
            Some(other) => {
                return Err(format!(
                    "[executor] kind = {other:?}: use \"local\" (child processes of acq) or \"slurm\" (batch jobs)"
                ))
            }
        }
        let slurm_only = [
            ("partition", self.partition.is_some()),
            ("account", self.account.is_some()),
            ("time_limit", self.time_limit.is_some()),
            ("cpus_per_job", self.cpus_per_job.is_some()),
            ("memory_per_job", self.memory_per_job.is_some()),
            ("sbatch_args", !self.sbatch_args.is_empty()),
            ("prelude", !self.prelude.is_empty()),
        ];
        if !self.is_slurm() {
            if let Some((name, _)) = slurm_only.iter().find(|(_, given)| *given) {
                return Err(format!(
                    "[executor] {name} is a Slurm option; add kind = \"slurm\" or leave it out"
                ));
            }
        }
        if let Some(limit) = &self.time_limit {
            let slurm_format = !limit.is_empty()
                && limit
                    .chars()
                    .all(|c| c.is_ascii_digit() || c == ':' || c == '-')
                || matches!(limit.as_str(), "UNLIMITED" | "INFINITE");
            if !slurm_format {
                return Err(format!(
                    "[executor] time_limit = {limit:?}: give Slurm's format, minutes (\"30\"), \"H:MM:SS\" or \"D-HH:MM:SS\""
                ));
            }
        }
        if self.cpus_per_job == Some(0) {
            return Err("[executor] cpus_per_job = 0: give at least 1".into());
        }
        let parallel = match (top_parallel, self.parallel) {
            (Some(top), Some(own)) if top != own => {
                return Err(format!(
                "parallel = {top} and [executor] parallel = {own}: give it once, under [executor]"
            ))
            }
            (top, own) => own.or(top).unwrap_or(1),
        };
        if !(1..=MAX_PARALLEL).contains(&parallel) {
            return Err(format!(
                "parallel = {parallel}: give 1 to {MAX_PARALLEL} runs at a time"
            ));
        }
        Ok(parallel)
    }

    fn slurm_settings(&self) -> SlurmSettings {
        SlurmSettings {
            partition: self.partition.clone(),
            account: self.account.clone(),
            time_limit: self.time_limit.clone(),
            cpus_per_job: self.cpus_per_job,
            memory_per_job: self.memory_per_job.clone(),
            sbatch_args: self.sbatch_args.clone(),
            prelude: self.prelude.clone(),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpecParameter {
    pub name: String,
    pub lower: f64,
    pub upper: f64,
    #[serde(default)]
    pub scale: Scale,
    /// Where the initial errors are reported [default: the middle].
    pub nominal: Option<f64>,
    /// The case this parameter belongs to [default: shared by all].
    pub case: Option<String>,
    /// Where class-typical values lie: `{ value, uncertainty }`, a penalty
    /// in standard deviations for straying from it.
    pub prior: Option<PriorSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PriorSpec {
    pub value: f64,
    pub uncertainty: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasuredOutput {
    pub name: String,
    pub measured: f64,
    pub uncertainty: Option<f64>,
    pub weight: Option<f64>,
}

/// A curve the solver writes, compared with a measured one by curve MAPE.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurveSpec {
    pub name: String,
    /// The CSV the solver writes in its run directory.
    pub file: String,
    /// Its x and y column names.
    pub x: String,
    pub y: String,
    /// Without cases: the measured curve, a CSV next to the spec, and its
    /// column names.
    pub measured_file: Option<String>,
    pub measured_x: Option<String>,
    pub measured_y: Option<String>,
    pub weight: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseSpec {
    pub name: String,
    #[serde(default = "default_role")]
    pub role: String,
    #[serde(default)]
    pub inputs: BTreeMap<String, f64>,
    #[serde(default)]
    pub measured: toml::Table,
}

fn default_role() -> String {
    "fit".into()
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Search {
    #[serde(default = "default_method")]
    pub method: String,
    #[serde(default = "default_residuals")]
    pub residuals: String,
    #[serde(default = "default_start")]
    pub start: String,
    #[serde(default = "default_start_runs")]
    pub start_runs: usize,
    #[serde(default = "default_max_evals")]
    pub max_evals: usize,
    pub target_loss_pct: Option<f64>,
    #[serde(default = "default_loss")]
    pub loss: String,
    pub acquisition: Option<String>,
    pub patience: Option<usize>,
    pub training_runs: Option<usize>,
    pub test_runs: Option<usize>,
    pub population: Option<usize>,
    pub generations: Option<usize>,
    pub pareto_fraction: Option<f64>,
    pub kernel: Option<String>,
    pub refine_tolerance: Option<f64>,
    pub refine_rounds: Option<usize>,
    /// Bayesian optimisation: local Gauss-Newton steps on the residuals
    /// (each curve's errors along its length) between the global ones.
    /// Default: on (measured on the CalculiX example, curve and scalars,
    /// and on the GTN preset: BENCHMARKS.md, "Local steps").
    pub local_steps: Option<bool>,
    /// How the surrogate-MOO search picks its front point: "topsis"
    /// (default, the published method), "topsis-common" or "minimax".
    pub pick: Option<String>,
}

impl Default for Search {
    fn default() -> Self {
        toml::from_str("").expect("every search field has a default")
    }
}

fn default_method() -> String {
    "bo".into()
}
fn default_residuals() -> String {
    "relative".into()
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

/// The points of columns `x` and `y` of a CSV with a header row; errors
/// name the file and line.
fn read_curve(path: &Path, x: &str, y: &str) -> std::result::Result<Vec<(f64, f64)>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let rows = read_design_csv(&text, &[x, y]).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(rows.iter().map(|row| (row[0], row[1])).collect())
}

/// A measured curve next to the spec, at least two points.
fn measured_curve(
    spec_directory: &Path,
    name: &str,
    file: &str,
    x: &str,
    y: &str,
) -> Result<Vec<(f64, f64)>> {
    let path = spec_directory.join(file);
    acq_io::input::note_input(&path);
    let points =
        read_curve(&path, x, y).map_err(|e| AcqError::Malformed(format!("curve {name}: {e}")))?;
    if points.len() < 2 {
        return Err(AcqError::Malformed(format!(
            "curve {name}: {} has {} point(s); a measured curve needs at least 2",
            path.display(),
            points.len()
        )));
    }
    Ok(points)
}

/// The 1-based line of the `index`-th `[[header]]` table in a spec, for
/// messages about it.
fn table_line(text: &str, header: &str, index: usize) -> usize {
    text.lines()
        .enumerate()
        .filter(|(_, line)| line.trim() == header)
        .nth(index)
        .map_or(1, |(number, _)| number + 1)
}

fn weight_of(weight: Option<f64>, what: &str) -> std::result::Result<f64, String> {
    match weight {
        None => Ok(1.0),
        Some(w) if (0.0..=1e6).contains(&w) => Ok(w),
        Some(w) => Err(format!("{what}: weight = {w}; give a number from 0 to 1e6")),
    }
}

fn scalar(
    name: &str,
    value: f64,
    uncertainty: Option<f64>,
    weight: f64,
    source: String,
) -> std::result::Result<Observation, String> {
    // A 0 is only meaningful in standard uncertainties (a one-sided
    // penalty's target); relative errors divide by the value.
    if !(value.is_finite() && (value != 0.0 || uncertainty.is_some())) {
        return Err(format!(
            "{name}: measured must be a finite non-zero number (errors are relative to it; a 0 needs an uncertainty and residuals = \"normalised\"), got {value}"
        ));
    }
    if let Some(u) = uncertainty {
        if !(u.is_finite() && u > 0.0) {
            return Err(format!(
                "{name}: uncertainty = {u}; give the standard uncertainty, a finite number above 0, in the value's unit"
            ));
        }
    }
    Ok(Observation {
        name: name.to_string(),
        output: name.to_string(),
        measured: Measured::Scalar { value, uncertainty },
        weight,
        source,
    })
}

/// One entry of a case's `measured` table.
fn case_observation(
    spec: &Spec,
    spec_directory: &Path,
    name: &str,
    entry: &toml::Value,
) -> std::result::Result<Observation, String> {
    let number = |v: &toml::Value| v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
    if let Some(value) = number(entry) {
        return scalar(name, value, None, 1.0, "spec".into());
    }
    let table = entry.as_table().ok_or_else(|| {
        format!("{name}: give a number, or a table with value, file (+ quantity), or file (+ x, y) for a curve")
    })?;
    let text = |key: &str| -> std::result::Result<Option<String>, String> {
        match table.get(key) {
            None => Ok(None),
            Some(v) => v
                .as_str()
                .map(|s| Some(s.to_string()))
                .ok_or_else(|| format!("{name}: {key} must be a string")),
        }
    };
    let allowed: &[&str] = if table.contains_key("value") {
        &["value", "uncertainty", "weight"]
    } else if table.contains_key("quantity") {
        &["file", "quantity", "hold", "uncertainty", "weight"]
    } else {
        &["file", "x", "y", "weight"]
    };
    if let Some(key) = table.keys().find(|k| !allowed.contains(&k.as_str())) {
        return Err(format!(
            "{name}: unknown key {key:?}; this kind of measured value takes {}",
            allowed.join(", ")
        ));
    }
    let weight = match table.get("weight") {
        None => 1.0,
        Some(v) => weight_of(
            Some(number(v).ok_or_else(|| format!("{name}: weight must be a number"))?),
            name,
        )?,
    };
    if let Some(value) = table.get("value") {
        let value = number(value).ok_or_else(|| format!("{name}: value must be a number"))?;
        let uncertainty = match table.get("uncertainty") {
            None => None,
            Some(u) => Some(number(u).ok_or_else(|| {
                format!("{name}: uncertainty must be a number (the standard uncertainty)")
            })?),
        };
        return scalar(name, value, uncertainty, weight, "spec".into());
    }
    let file = text("file")?.ok_or_else(|| {
        format!("{name}: give value = ..., or file = ... with quantity (a measured-values file) or x and y (a curve)")
    })?;
    let path = spec_directory.join(&file);
    if let Some(quantity) = text("quantity")? {
        return measured_value_from_file(
            name,
            &path,
            &quantity,
            text("hold")?.as_deref(),
            table.get("uncertainty"),
            weight,
        );
    }
    let (Some(x), Some(y)) = (text("x")?, text("y")?) else {
        return Err(format!(
            "{name}: a measured curve needs x and y (its column names in {file})"
        ));
    };
    if !spec.curves.iter().any(|c| c.name == name) {
        return Err(format!(
            "{name}: a measured curve, but no [[curve]] named {name:?} says which file the solver writes it to"
        ));
    }
    let points = measured_curve(spec_directory, name, &file, &x, &y).map_err(|e| e.to_string())?;
    Ok(Observation {
        name: name.to_string(),
        output: name.to_string(),
        measured: Measured::Curve { points },
        weight,
        source: file,
    })
}

/// A measured value from an `acq extract` measured-values file.
fn measured_value_from_file(
    name: &str,
    path: &Path,
    quantity: &str,
    hold: Option<&str>,
    uncertainty: Option<&toml::Value>,
    weight: f64,
) -> std::result::Result<Observation, String> {
    let values = read_measured(path).map_err(|e| format!("{name}: {e}"))?;
    let mut holds: Vec<&str> = values.iter().map(|v| v.window.as_str()).collect();
    holds.dedup();
    let hold = match hold {
        Some(h) => h.to_string(),
        None if holds.len() == 1 => holds[0].to_string(),
        None => {
            return Err(format!(
                "{name}: {} has {} holds ({}); name one with hold = \"...\"",
                path.display(),
                holds.len(),
                holds.join(", ")
            ))
        }
    };
    let Some(value) = values
        .iter()
        .find(|v| v.window == hold && v.quantity == quantity)
    else {
        return Err(if holds.contains(&hold.as_str()) {
            format!(
                "{name}: {} has no {quantity} in hold {hold}",
                path.display()
            )
        } else {
            format!(
                "{name}: {} has no hold {hold:?}; it has {}",
                path.display(),
                holds.join(", ")
            )
        });
    };
    if !value.is_usable() {
        return Err(format!(
            "{name}: {quantity} in {hold} of {} is not fit to calibrate against (flags '{}': {})",
            path.display(),
            value.flags.join(";"),
            value.note
        ));
    }
    let mean = value
        .stats
        .mean
        .ok_or_else(|| format!("{name}: {quantity} in {hold} has no mean"))?;
    let standard = |what: &str| -> std::result::Result<f64, String> {
        let std = value.stats.std.ok_or_else(|| {
            format!("{name}: {quantity} in {hold} has no std (fewer than 2 samples)")
        })?;
        Ok(match what {
            "std" => std,
            _ => std / value.stats.n_eff.max(1.0).sqrt(),
        })
    };
    let uncertainty = match uncertainty {
        None => None,
        Some(toml::Value::String(s)) if s == "std" || s == "std_of_mean" => Some(standard(s)?),
        Some(v) => match v.as_float().or_else(|| v.as_integer().map(|i| i as f64)) {
            Some(u) => Some(u),
            None => {
                return Err(format!(
                    "{name}: uncertainty = {v}; give a number, \"std\" or \"std_of_mean\""
                ))
            }
        },
    };
    scalar(
        name,
        mean,
        uncertainty,
        weight,
        format!("{} ({hold}, {quantity} [{}])", path.display(), value.unit),
    )
}

impl Spec {
    /// Reads and checks a spec and the measured files it names; errors
    /// name the file (and the line of the table at fault) and what to fix.
    pub fn load(path: &Path) -> Result<Spec> {
        let text = std::fs::read_to_string(path).map_err(|e| AcqError::open(path, e))?;
        acq_io::input::note_input(path);
        let mut spec: Spec = toml::from_str(&text)
            .map_err(|e| AcqError::Config(format!("{}: {e}", path.display())))?;
        let problem = |message: String| AcqError::Config(format!("{}: {message}", path.display()));
        let at = |header: &str, index: usize, message: String| {
            AcqError::Config(format!(
                "{}:{}: {message}",
                path.display(),
                table_line(&text, header, index)
            ))
        };
        match spec.model.as_str() {
            "command" if spec.command.is_empty() => {
                return Err(problem(
                    "command is empty; give the program and its arguments".into(),
                ))
            }
            "command" if spec.geometry.is_some() => {
                return Err(problem(
                    "geometry belongs to model = \"excavator\"; a command reads its own files".into(),
                ))
            }
            "command" => {}
            "excavator" if !spec.command.is_empty() => {
                return Err(problem(
                    "model = \"excavator\" runs the built-in twin; leave out command".into(),
                ))
            }
            "excavator" if !spec.curves.is_empty() => {
                return Err(problem(
                    "the excavator twin gives no curves; observe its numbers by key path (pressure_bar.boom)".into(),
                ))
            }
            "excavator" => {}
            other => {
                return Err(problem(format!(
                    "model = {other:?}: use \"command\" (your solver) or \"excavator\" (the built-in twin)"
                )))
            }
        }
        if spec.cases.is_empty() && spec.outputs.is_empty() && spec.curves.is_empty() {
            return Err(problem(
                "no [[output]] with a measured value, no [[curve]] to compare and no [[case]]"
                    .into(),
            ));
        }
        if !spec.cases.is_empty() && !spec.outputs.is_empty() {
            return Err(at(
                "[[output]]",
                0,
                "with [[case]], give each case's measured values in its `measured` table instead of [[output]]".into(),
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
        spec.runs_at_once = spec
            .executor
            .check(spec.parallel)
            .map_err(|e| at("[executor]", 0, e))?;
        if spec.model == "excavator" && spec.executor.is_slurm() {
            return Err(at(
                "[executor]",
                0,
                "model = \"excavator\" runs inside acq; a Slurm executor is for a command".into(),
            ));
        }
        let any_run = Path::new("runs/000001");
        if !spec.output_file.is_empty() {
            acq_io::output::inside(any_run, &spec.output_file, "output_file")
                .map_err(|e| problem(e.to_string()))?;
        }
        for curve in &spec.curves {
            acq_io::output::inside(any_run, &curve.file, "curve.file")
                .map_err(|e| problem(e.to_string()))?;
        }
        let spec_directory = spec_directory(path);
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
        spec.check_search().map_err(problem)?;

        // The cases and their observations.
        let mut cases = Vec::new();
        if spec.cases.is_empty() {
            let mut observations = Vec::new();
            for (index, o) in spec.outputs.iter().enumerate() {
                let weight =
                    weight_of(o.weight, &o.name).map_err(|e| at("[[output]]", index, e))?;
                observations.push(
                    scalar(&o.name, o.measured, o.uncertainty, weight, "spec".into())
                        .map_err(|e| at("[[output]]", index, format!("output {e}")))?,
                );
            }
            for (index, c) in spec.curves.iter().enumerate() {
                let (Some(file), Some(x), Some(y)) =
                    (&c.measured_file, &c.measured_x, &c.measured_y)
                else {
                    return Err(at(
                        "[[curve]]",
                        index,
                        format!(
                            "curve {}: give measured_file, measured_x and measured_y (the measured curve to compare with)",
                            c.name
                        ),
                    ));
                };
                let weight = weight_of(c.weight, &c.name).map_err(|e| at("[[curve]]", index, e))?;
                observations.push(Observation {
                    name: c.name.clone(),
                    output: c.name.clone(),
                    measured: Measured::Curve {
                        points: measured_curve(&spec_directory, &c.name, file, x, y)?,
                    },
                    weight,
                    source: file.clone(),
                });
            }
            cases.push(Case {
                name: "the test".into(),
                role: Role::Fit,
                inputs: Vec::new(),
                observations,
                priors: false,
            });
        }
        for (index, c) in spec.curves.iter().enumerate() {
            if !spec.cases.is_empty() && c.measured_file.is_some() {
                return Err(at(
                    "[[curve]]",
                    index,
                    format!("curve {}: with [[case]], the measured curve goes in each case's measured table ({} = {{ file = ..., x = ..., y = ... }})", c.name, c.name),
                ));
            }
        }
        for (index, c) in spec.cases.iter().enumerate() {
            let here =
                |message: String| at("[[case]]", index, format!("case {}: {message}", c.name));
            if c.name.is_empty() || c.name.contains(['/', ',', '"', '\n']) {
                return Err(here(
                    "give a name of letters, digits and underscores".into(),
                ));
            }
            if spec.cases[..index].iter().any(|d| d.name == c.name) {
                return Err(here("the name is given twice".into()));
            }
            let role = match c.role.as_str() {
                "fit" => Role::Fit,
                "validate" => Role::Validate,
                other => {
                    return Err(here(format!(
                        "role = {other:?}; use \"fit\" or \"validate\""
                    )))
                }
            };
            if c.measured.is_empty() {
                return Err(here(format!(
                    "no measured values; a {} case needs at least one observation",
                    role.name()
                )));
            }
            for (name, value) in &c.inputs {
                if !value.is_finite() {
                    return Err(here(format!(
                        "input {name} = {value}; give a finite number"
                    )));
                }
                let calibrated_here = |p: &SpecParameter| {
                    &p.name == name && p.case.as_ref().is_none_or(|case| case == &c.name)
                };
                if spec.parameters.iter().any(calibrated_here) {
                    return Err(here(format!(
                        "input {name} is also a [[parameter]]; a value is either fixed or calibrated"
                    )));
                }
            }
            let observations = c
                .measured
                .iter()
                .map(|(name, entry)| case_observation(&spec, &spec_directory, name, entry))
                .collect::<std::result::Result<Vec<_>, _>>()
                .map_err(|e| here(format!("measured {e}")))?;
            if observations
                .iter()
                .any(|o| matches!(o.measured, Measured::Scalar { .. }))
                && spec.output_file.is_empty()
                && spec.model == "command"
            {
                return Err(problem(
                    "output_file: name the file the command writes its outputs to".into(),
                ));
            }
            cases.push(Case {
                name: c.name.clone(),
                role,
                inputs: c.inputs.iter().map(|(k, v)| (k.clone(), *v)).collect(),
                observations,
                priors: false,
            });
        }
        if cases.iter().all(|c| c.role != Role::Fit) {
            return Err(problem(
                "every case is a validate case; the search needs at least one fit case".into(),
            ));
        }
        if spec.cases.is_empty()
            && !spec.outputs.is_empty()
            && spec.output_file.is_empty()
            && spec.model == "command"
        {
            return Err(problem(
                "output_file: name the file the command writes its outputs to".into(),
            ));
        }

        // The parameters: shared, or one fit case's own.
        let mut parameters = Vec::new();
        for (index, p) in spec.parameters.iter().enumerate() {
            let case = match &p.case {
                None => None,
                Some(name) => {
                    let Some(found) = cases.iter().position(|c| &c.name == name) else {
                        return Err(at(
                            "[[parameter]]",
                            index,
                            format!(
                                "parameter {}: case = {name:?} names no [[case]]; the cases are {}",
                                p.name,
                                cases
                                    .iter()
                                    .map(|c| c.name.as_str())
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            ),
                        ));
                    };
                    if cases[found].role == Role::Validate {
                        return Err(at(
                            "[[parameter]]",
                            index,
                            format!(
                                "parameter {}: case {name} is a validate case, which the search never sees; give its value as a fixed input",
                                p.name
                            ),
                        ));
                    }
                    Some(found)
                }
            };
            let search_name = match &p.case {
                Some(case) => format!("{case}/{}", p.name),
                None => p.name.clone(),
            };
            let search = Parameter::new(search_name, p.lower, p.upper).with_scale(p.scale);
            // Without a nominal, a prior's value (where the parameter is
            // expected), else the middle of the range.
            let nominal = p
                .nominal
                .or(p.prior.as_ref().map(|prior| prior.value))
                .unwrap_or_else(|| search.midpoint());
            if !(nominal >= p.lower && nominal <= p.upper) {
                return Err(at(
                    "[[parameter]]",
                    index,
                    format!(
                        "parameter {}: nominal = {nominal} lies outside {} .. {}",
                        p.name, p.lower, p.upper
                    ),
                ));
            }
            let prior = match &p.prior {
                None => None,
                Some(prior) if prior.value.is_finite()
                    && prior.uncertainty.is_finite()
                    && prior.uncertainty > 0.0 =>
                {
                    Some(Prior {
                        value: prior.value,
                        uncertainty: prior.uncertainty,
                    })
                }
                Some(prior) => {
                    return Err(at(
                        "[[parameter]]",
                        index,
                        format!(
                            "parameter {}: prior = {{ value = {}, uncertainty = {} }}: give a finite value and an uncertainty above 0",
                            p.name, prior.value, prior.uncertainty
                        ),
                    ))
                }
            };
            parameters.push(StudyParameter {
                search,
                input: p.name.clone(),
                case,
                nominal,
                prior,
            });
        }
        for (index, p) in spec.parameters.iter().enumerate() {
            let clash = spec.parameters[..index].iter().any(|q| {
                q.name == p.name && (q.case.is_none() || p.case.is_none() || q.case == p.case)
            });
            if clash {
                return Err(at(
                    "[[parameter]]",
                    index,
                    format!("parameter {} is listed twice for the same case", p.name),
                ));
            }
        }
        if let Some(priors) = Case::priors(&parameters) {
            if let Some(index) = spec.cases.iter().position(|c| c.name == priors.name) {
                return Err(at(
                    "[[case]]",
                    index,
                    "the case name \"prior\" is taken by the parameters' priors; rename the case"
                        .into(),
                ));
            }
            if spec.search.residuals != "normalised" {
                return Err(problem(
                    "a [[parameter]] prior is a penalty in standard deviations: set search.residuals = \"normalised\" (and give the measured values their uncertainties)".into(),
                ));
            }
            cases.push(priors);
        }
        let search_parameters: Vec<Parameter> =
            parameters.iter().map(|p| p.search.clone()).collect();
        acq_calib::evaluation::validate_parameters(&search_parameters)
            .map_err(|e| problem(e.to_string()))?;
        let residuals = match spec.search.residuals.as_str() {
            "relative" => Residuals::Relative,
            _ => Residuals::Normalised,
        };
        if residuals == Residuals::Normalised {
            if let Some((case, o)) = cases.iter().find_map(|c| {
                c.observations
                    .iter()
                    .find(|o| {
                        matches!(
                            o.measured,
                            Measured::Scalar {
                                uncertainty: None,
                                ..
                            }
                        )
                    })
                    .map(|o| (c, o))
            }) {
                return Err(problem(format!(
                    "search.residuals = \"normalised\" divides by each value's uncertainty, and {} of {} has none; give it one",
                    o.name, case.name
                )));
            }
        } else if let Some((case, o)) = cases.iter().find_map(|c| {
            c.observations
                .iter()
                .find(|o| matches!(o.measured, Measured::Scalar { value, .. } if value == 0.0))
                .map(|o| (c, o))
        }) {
            return Err(problem(format!(
                "{} of {} is measured as 0, and relative errors divide by it; use search.residuals = \"normalised\" (its uncertainty is the scale)",
                o.name, case.name
            )));
        }
        spec.study = Some(Study {
            parameters,
            named_cases: !spec.cases.is_empty(),
            cases,
            residuals,
            loss: match spec.search.loss.as_str() {
                "max" => LossKind::Max,
                "squares" => LossKind::Squares,
                _ => LossKind::Mean,
            },
        });
        Ok(spec)
    }

    fn check_search(&self) -> std::result::Result<(), String> {
        let search = &self.search;
        if !matches!(
            search.method.as_str(),
            "bo" | "surrogate-moo" | "least-squares"
        ) {
            return Err(format!(
                "search.method = {:?}: use \"bo\", \"surrogate-moo\" or \"least-squares\"",
                search.method
            ));
        }
        if !matches!(search.residuals.as_str(), "relative" | "normalised") {
            return Err(format!(
                "search.residuals = {:?}: use \"relative\" or \"normalised\"",
                search.residuals
            ));
        }
        if !START_DESIGNS.contains(&search.start.as_str()) && !search.start.ends_with(".csv") {
            return Err(format!(
                "search.start = {:?}: use one of {}, or a CSV file of points (name ending in .csv, next to the spec)",
                search.start,
                START_DESIGNS.join(", ")
            ));
        }
        if !matches!(search.loss.as_str(), "mean" | "max" | "squares") {
            return Err(format!(
                "search.loss {:?}: use mean, max or squares",
                search.loss
            ));
        }
        if !(3..=MAX_EVALUATIONS).contains(&search.max_evals)
            || !(2..=MAX_EVALUATIONS).contains(&search.start_runs)
        {
            return Err(format!(
                "search: give max_evals from 3 and start_runs from 2, each at most {MAX_EVALUATIONS} (got {} and {})",
                search.max_evals, search.start_runs
            ));
        }
        if let Some(text) = &search.acquisition {
            text.parse::<Acquisition>()
                .map_err(|e| format!("search.acquisition = {text:?}: {e}"))?;
        }
        if let Some(text) = &search.kernel {
            text.parse::<Kernel>()
                .map_err(|e| format!("search.kernel = {text:?}: {e}"))?;
        }
        if let Some(text) = &search.pick {
            text.parse::<Pick>()
                .map_err(|e| format!("search.pick: {e}"))?;
        }
        let counts = [
            ("training_runs", search.training_runs, 3),
            ("test_runs", search.test_runs, 0),
            ("population", search.population, 4),
            ("generations", search.generations, 0),
            ("refine_rounds", search.refine_rounds, 0),
            ("patience", search.patience, 1),
        ];
        for (name, value, least) in counts {
            if let Some(value) = value {
                if !(least..=MAX_EVALUATIONS).contains(&value) {
                    return Err(format!(
                        "search.{name} = {value}: give {least} to {MAX_EVALUATIONS}"
                    ));
                }
            }
        }
        if let Some(f) = search.pareto_fraction {
            if !(f > 0.0 && f <= 1.0) {
                return Err(format!(
                    "search.pareto_fraction = {f}: give a number in (0, 1]"
                ));
            }
        }
        if let Some(t) = search.refine_tolerance {
            if !(t.is_finite() && t >= 0.0) {
                return Err(format!("search.refine_tolerance = {t}: give a number >= 0"));
            }
        }
        if let Some(t) = search.target_loss_pct {
            if !(t.is_finite() && t >= 0.0) {
                return Err(format!("search.target_loss_pct = {t}: give a number >= 0"));
            }
        }
        Ok(())
    }

    /// Runs in flight at once (`parallel`, or `[executor] parallel`).
    pub fn runs_at_once(&self) -> usize {
        self.runs_at_once
    }

    /// The study this spec defines.
    pub fn study(&self) -> &Study {
        self.study.as_ref().expect("Spec::load builds the study")
    }

    /// The search method with its settings.
    fn method(&self, seed: u64) -> Method {
        let search = &self.search;
        if search.method == "surrogate-moo" {
            let defaults = SurrogateMooSettings::published(self.study().weights().len(), seed);
            Method::SurrogateMoo(SurrogateMooSettings {
                training_runs: search.training_runs.unwrap_or(defaults.training_runs),
                test_runs: search.test_runs.unwrap_or(defaults.test_runs),
                population: search.population.unwrap_or(defaults.population),
                generations: search.generations.unwrap_or(defaults.generations),
                pareto_fraction: search.pareto_fraction.unwrap_or(defaults.pareto_fraction),
                weights: self.study().weights(),
                pick: search
                    .pick
                    .as_deref()
                    .and_then(|p| p.parse().ok())
                    .unwrap_or(defaults.pick),
                kernel: search
                    .kernel
                    .as_deref()
                    .and_then(|k| k.parse().ok())
                    .unwrap_or(defaults.kernel),
                seed,
                refine_tolerance: search.refine_tolerance.unwrap_or(defaults.refine_tolerance),
                refine_rounds: search.refine_rounds.unwrap_or(defaults.refine_rounds),
            })
        } else if search.method == "least-squares" {
            Method::LeastSquares(study_runner::LeastSquaresMethod {
                max_evals: search.max_evals,
            })
        } else {
            Method::Bo(study_runner::BoMethod {
                start: search.start.clone(),
                start_runs: search.start_runs,
                max_evals: search.max_evals,
                target_loss: search.target_loss_pct,
                acquisition: search.acquisition.as_deref().and_then(|a| a.parse().ok()),
                patience: search.patience,
                batch: self.runs_at_once,
                seed,
                local_steps: search.local_steps.unwrap_or(true),
            })
        }
    }
}

/// What one model run is asked for.
#[derive(Clone, Copy)]
struct RunRequest<'a> {
    inputs: &'a [(String, f64)],
    /// `inputs` as the `params.json` the solver reads.
    params: &'a str,
    scalars: &'a [&'a str],
    curves: &'a [&'a str],
}

/// The user's solver: a command run once per model run.
pub struct ExternalModel {
    spec: Spec,
    /// Where relative program and file paths in the spec start.
    spec_directory: PathBuf,
    runs: PathBuf,
    counter: AtomicUsize,
    executor: Box<dyn Executor>,
    /// Run directories of an interrupted run that hold a job the executor
    /// re-attaches to, by their `params.json`, oldest first: a resumed
    /// study that asks for the same inputs gets that job's result instead
    /// of a new run.
    unfinished: Mutex<HashMap<String, VecDeque<PathBuf>>>,
}

impl ExternalModel {
    pub fn new(
        mut spec: Spec,
        spec_directory: PathBuf,
        runs: PathBuf,
        executor: Box<dyn Executor>,
        resume: bool,
    ) -> Self {
        let highest = highest_run_number(&runs);
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
        let mut unfinished: HashMap<String, VecDeque<PathBuf>> = HashMap::new();
        // Only a resumed study asks again for what an interrupted one
        // started; a new one never re-attaches to a stray directory.
        for number in (1..=highest).filter(|_| resume) {
            let directory = runs.join(format!("{number:06}"));
            if executor.holds_job(&directory) {
                if let Ok(params) = std::fs::read_to_string(directory.join("params.json")) {
                    unfinished.entry(params).or_default().push_back(directory);
                }
            }
        }
        ExternalModel {
            spec,
            spec_directory,
            runs,
            // A resumed run numbers on after the directories already there,
            // so the interrupted run's files are kept.
            counter: AtomicUsize::new(highest),
            executor,
            unfinished: Mutex::new(unfinished),
        }
    }

    /// One run of `request` in `directory`; `prepared` when the directory
    /// already holds this run's job (a resumed run re-attaching to it).
    /// The executor's notes go to `notes`, whatever the outcome.
    fn run_once(
        &self,
        request: &RunRequest<'_>,
        directory: &Path,
        prepared: bool,
        notes: &mut Vec<String>,
    ) -> std::result::Result<ModelRun, String> {
        let RunRequest {
            inputs,
            params,
            scalars,
            curves,
        } = *request;
        std::fs::create_dir_all(directory).map_err(|e| format!("{}: {e}", directory.display()))?;
        let params_path = directory.join("params.json");
        let output_path = acq_io::output::inside(directory, &self.spec.output_file, "output_file")
            .ok()
            .filter(|_| !self.spec.output_file.is_empty());
        let curve_specs: Vec<&CurveSpec> = curves
            .iter()
            .map(|name| {
                self.spec
                    .curves
                    .iter()
                    .find(|c| c.name == *name)
                    .ok_or_else(|| format!("no [[curve]] named {name}"))
            })
            .collect::<std::result::Result<_, _>>()?;
        let curve_paths = curve_specs
            .iter()
            .map(|c| acq_io::output::inside(directory, &c.file, "curve.file"))
            .collect::<Result<Vec<_>>>()
            .map_err(|e| e.to_string())?;
        if !prepared {
            std::fs::write(&params_path, params)
                .map_err(|e| format!("{}: {e}", params_path.display()))?;
            // A file left by an earlier attempt must not pass for this one's.
            for path in output_path.iter().chain(&curve_paths) {
                let _ = std::fs::remove_file(path);
            }
            self.stage_files(directory)?;
        }
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
            for (name, v) in inputs {
                text = text.replace(&format!("{{{name}}}"), &v.to_string());
            }
            text
        };
        let argv: Vec<String> = self.spec.command.iter().map(|a| substitute(a)).collect();
        let execution = self.executor.execute(&Job {
            argv: &argv,
            directory,
            timeout: Duration::from_secs_f64(self.spec.timeout_s),
        });
        *notes = execution.notes;
        execution.outcome?;
        let scalars = match (&output_path, scalars.is_empty()) {
            (_, true) => Vec::new(),
            (Some(path), false) => read_outputs(path, scalars)?,
            (None, false) => return Err("the spec names no output_file".into()),
        };
        let curves = curve_specs
            .iter()
            .zip(&curve_paths)
            .map(|(c, path)| {
                read_curve(path, &c.x, &c.y).map_err(|e| format!("curve {}: {e}", c.name))
            })
            .collect::<std::result::Result<_, _>>()?;
        Ok(ModelRun { scalars, curves })
    }
}

impl Model for ExternalModel {
    fn run(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> std::result::Result<ModelRun, String> {
        self.run_noted(inputs, scalars, curves).0
    }

    fn note_columns(&self) -> &[String] {
        self.executor.note_columns()
    }

    /// Each attempt's notes, space-separated per column.
    fn run_noted(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> (std::result::Result<ModelRun, String>, Vec<String>) {
        let params: serde_json::Map<String, serde_json::Value> = inputs
            .iter()
            .map(|(name, v)| (name.clone(), json!(v)))
            .collect();
        let params = serde_json::Value::Object(params).to_string();
        let mut notes = vec![String::new(); self.note_columns().len()];
        let mut reasons = Vec::new();
        for attempt in 0..=self.spec.retries {
            let held = self
                .unfinished
                .lock()
                .ok()
                .and_then(|mut unfinished| unfinished.get_mut(&params)?.pop_front());
            let directory = held.clone().unwrap_or_else(|| {
                let number = self.counter.fetch_add(1, Ordering::SeqCst) + 1;
                self.runs.join(format!("{number:06}"))
            });
            let mut run_notes = Vec::new();
            let request = RunRequest {
                inputs,
                params: &params,
                scalars,
                curves,
            };
            let outcome = self.run_once(&request, &directory, held.is_some(), &mut run_notes);
            for (note, run_note) in notes.iter_mut().zip(run_notes) {
                if !note.is_empty() && !run_note.is_empty() {
                    note.push(' ');
                }
                note.push_str(&run_note);
            }
            match outcome {
                Ok(run) => return (Ok(run), notes),
                Err(reason) => reasons.push(format!("attempt {}: {reason}", attempt + 1)),
            }
        }
        (Err(reasons.join("; ")), notes)
    }

    fn status(&self) -> Option<String> {
        self.executor.status()
    }
}

impl ExternalModel {
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

/// The outputs from a JSON object or a one-row CSV, by name.
fn read_outputs(path: &Path, names: &[&str]) -> std::result::Result<Vec<f64>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("the solver left no output {}: {e}", path.display()))?;
    let is_json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let values: std::collections::HashMap<String, f64> = if is_json {
        let value: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| format!("{}: not JSON: {e}", path.display()))?;
        if !value.is_object() {
            return Err(format!(
                "{}: expected a JSON object of outputs",
                path.display()
            ));
        }
        numbers_by_key_path(&value)
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

pub fn run(args: CalibrateExternalArgs) -> Result<()> {
    let spec = Spec::load(&args.spec)?;
    let spec_directory = spec_directory(&args.spec);
    let method = spec.method(args.seed);
    let study = spec.study().clone();
    // The start design is read before the run directory exists: a refused
    // design leaves nothing behind.
    let initial = match &method {
        Method::Bo(bo) => {
            study_runner::start_design(&study.search_parameters(), bo, &spec_directory)?
        }
        Method::SurrogateMoo(_) | Method::LeastSquares(_) => Vec::new(),
    };
    let parallel = spec.runs_at_once.max(1);
    let settings = RunSettings {
        label: "calibrate external".into(),
        title: args.spec.display().to_string(),
        spec_directory: &spec_directory,
        parallel,
        resume: args.resume,
    };
    if spec.model == "excavator" {
        let template = match &spec.geometry {
            Some(file) => {
                let path = spec_directory.join(file);
                let text = std::fs::read_to_string(&path).map_err(|e| AcqError::open(&path, e))?;
                acq_io::input::note_input(&path);
                GeometryTemplate::parse(&text)
                    .map_err(|e| AcqError::Config(format!("{}: {e}", path.display())))?
            }
            None => GeometryTemplate::dx55(),
        };
        let model = ExcavatorModel::new(template, spec.refit_poses)
            .map_err(|e| AcqError::Config(format!("{}: geometry: {e}", args.spec.display())))?;
        // The twin is cheap: every case is tried at the nominal point before
        // the run directory exists, so a wrong name is refused at once.
        study_runner::check_at_nominal(&study, &model)
            .map_err(|e| AcqError::Config(format!("{}: {e}", args.spec.display())))?;
        let directory = super::run_directory::RunDirectory::create(&args.out)?;
        let outcome =
            study_runner::calibrate_study(&study, &model, &method, initial, &directory, &settings)?;
        study_runner::write_study(&study, &outcome, &directory, &settings)?;
        // A study of geometry numbers leaves the geometry it found.
        let uncertainties = outcome
            .identifiability
            .as_ref()
            .and_then(|a| a.standard_uncertainties(&study.search_parameters()));
        let file = model
            .calibrated_geometry_file(
                &study,
                &outcome.calibrated,
                uncertainties.as_deref(),
                &args.spec.display().to_string(),
            )
            .map_err(|e| AcqError::Config(format!("writing the calibrated geometry: {e}")))?;
        if let Some(text) = file {
            let path = directory.file("geometry.toml");
            super::report::write_text(&path, &text)?;
            println!("the calibrated geometry is in {}", path.display());
        }
        return Ok(());
    }
    let executor: Box<dyn Executor> = if spec.executor.is_slurm() {
        Box::new(
            SlurmExecutor::new(spec.executor.slurm_settings())
                .map_err(|e| AcqError::Config(format!("{}: {e}", args.spec.display())))?,
        )
    } else {
        Box::new(LocalExecutor)
    };
    let directory = super::run_directory::RunDirectory::create(&args.out)?;
    let runs = std::fs::canonicalize(&directory.path)
        .map_err(|e| AcqError::io(format!("resolving {}", directory.path.display()), e))?
        .join("runs");
    let model = ExternalModel::new(spec, spec_directory.clone(), runs, executor, args.resume);
    study_runner::run_study(&study, &model, &method, initial, &directory, &settings)
}
