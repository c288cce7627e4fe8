//! A user's solver as a study [`Model`]: a command run once per model run,
//! each in its own directory `DIR/runs/NNNNNN/` (its working directory:
//! solvers write fixed file names there, so parallel runs must not share
//! one). The directory holds `params.json` (`{"name": value, ...}`: the
//! parameters and the case's fixed inputs), the command's `stdout.txt` and
//! `stderr.txt`, the files of `link_files` (symbolic links) and
//! `copy_files` (copies), and what the command writes: the output file (a
//! JSON object `{"output": value, ...}` or a CSV with a header row and one
//! data row; nested JSON keys are named by path, `pressure_bar.boom`,
//! `gauges[0]`) and each curve's CSV.
//!
//! The command is an argument list (no shell) in which `{params}`, `{out}`,
//! `{dir}` and `{NAME}` (a parameter's or fixed input's value) are
//! replaced; the program or an argument that names a file next to the spec
//! is that file. A run that exits non-zero, times out (it is killed) or
//! leaves no readable output is retried `retries` times, then logged as
//! failed with the reason (the end of its stderr); it never ends the
//! study. Where a run happens is the [`acq_exec::executor`]'s business: a
//! child process, or a Slurm batch job ([`acq_exec::slurm`]), whose notes
//! (job id, queue wait, run time) `evaluations.csv` adds. A resumed study
//! re-attaches to the jobs of run directories the interrupted one left
//! (same `params.json`) instead of starting them again.

use std::collections::{HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Duration;

use serde_json::json;

use super::spec::observations::read_curve;
use super::spec::schema::CurveSpec;
use super::spec::CommandSpec;
use super::study::{append_notes, numbers_by_key_path, Model, ModelRun};
use acq_exec::executor::{Executor, Job};

#[derive(Clone, Copy)]
struct RunRequest<'a> {
    inputs: &'a [(String, f64)],
    /// `inputs` as the `params.json` the solver reads.
    params: &'a str,
    scalars: &'a [&'a str],
    curves: &'a [&'a str],
}

/// The user's solver: a command run once per model run.
pub struct CommandModel {
    spec: CommandSpec,
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

impl CommandModel {
    pub fn new(
        mut spec: CommandSpec,
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
        CommandModel {
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

    /// Where a run in `directory` writes its outputs and curves.
    fn files_of(&self, directory: &Path, curves: &[&str]) -> Result<RunFiles, String> {
        let output = acq_io::output::inside(directory, &self.spec.output_file, "output_file")
            .ok()
            .filter(|_| !self.spec.output_file.is_empty());
        let curves = curves
            .iter()
            .map(|name| {
                let spec = self
                    .spec
                    .curves
                    .iter()
                    .find(|c| c.name == *name)
                    .ok_or_else(|| format!("no [[curve]] named {name}"))?;
                let path = acq_io::output::inside(directory, &spec.file, "curve.file")
                    .map_err(|e| e.to_string())?;
                Ok((spec.clone(), path))
            })
            .collect::<Result<_, String>>()?;
        Ok(RunFiles { output, curves })
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
    ) -> Result<ModelRun, String> {
        let RunRequest {
            inputs,
            params,
            scalars,
            curves,
        } = *request;
        std::fs::create_dir_all(directory).map_err(|e| format!("{}: {e}", directory.display()))?;
        let params_path = directory.join("params.json");
        let files = self.files_of(directory, curves)?;
        if !prepared {
            std::fs::write(&params_path, params)
                .map_err(|e| format!("{}: {e}", params_path.display()))?;
            // A file left by an earlier attempt must not pass for this one's.
            let curve_paths = files.curves.iter().map(|(_, path)| path);
            for path in files.output.iter().chain(curve_paths) {
                let _ = std::fs::remove_file(path);
            }
            self.stage_files(directory)?;
        }
        let substitute = |argument: &str| -> String {
            let mut text = argument
                .replace("{params}", &params_path.display().to_string())
                .replace(
                    "{out}",
                    &files
                        .output
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
        files.read(scalars)
    }
}

/// The files a run leaves for acq to read.
struct RunFiles {
    /// The scalar outputs' file, when the spec names one.
    output: Option<PathBuf>,
    /// Each requested curve's spec and file.
    curves: Vec<(CurveSpec, PathBuf)>,
}

impl RunFiles {
    /// The `scalars` and the curves from the files of a finished run.
    fn read(&self, scalars: &[&str]) -> Result<ModelRun, String> {
        let scalars = match (&self.output, scalars.is_empty()) {
            (_, true) => Vec::new(),
            (Some(path), false) => read_outputs(path, scalars)?,
            (None, false) => return Err("the spec names no output_file".into()),
        };
        let curves = self
            .curves
            .iter()
            .map(|(c, path)| {
                read_curve(path, &c.x, &c.y).map_err(|e| format!("curve {}: {e}", c.name))
            })
            .collect::<Result<_, _>>()?;
        Ok(ModelRun { scalars, curves })
    }
}

/// A run's inputs as the `params.json` the solver reads.
fn params_json(inputs: &[(String, f64)]) -> String {
    let params: serde_json::Map<String, serde_json::Value> = inputs
        .iter()
        .map(|(name, v)| (name.clone(), json!(v)))
        .collect();
    serde_json::Value::Object(params).to_string()
}

impl Model for CommandModel {
    fn run(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> Result<ModelRun, String> {
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
    ) -> (Result<ModelRun, String>, Vec<String>) {
        let params = params_json(inputs);
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
            append_notes(&mut notes, run_notes);
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

    /// Read again from the latest run directory with these inputs whose
    /// files are whole: one more solver run can cost hours.
    fn run_again(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> Option<ModelRun> {
        let params = params_json(inputs);
        (1..=highest_run_number(&self.runs))
            .rev()
            .find_map(|number| {
                let directory = self.runs.join(format!("{number:06}"));
                let written = std::fs::read_to_string(directory.join("params.json")).ok()?;
                if written != params {
                    return None;
                }
                self.files_of(&directory, curves).ok()?.read(scalars).ok()
            })
    }
}

impl CommandModel {
    /// Links (`link_files`) and copies (`copy_files`) the solver's files
    /// from the spec's directory into a run directory.
    fn stage_files(&self, directory: &Path) -> Result<(), String> {
        let stage = |file: &String, copy: bool| -> Result<(), String> {
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
fn read_outputs(path: &Path, names: &[&str]) -> Result<Vec<f64>, String> {
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
