//! `acq calibrate external --spec FILE.toml --out DIR`: a study on a
//! user's own solver (a COMSOL or Abaqus batch job, a script) run as a
//! command once per evaluation and load case ([`acq_study::command_model`]),
//! or on a built-in twin (`model = "excavator"` or `model = "gtn"`,
//! [`super::models`]). The spec's keys are in [`acq_study::spec`].

use std::path::{Path, PathBuf};

use acq_error::{AcqError, Result};

use super::builtin::{ExcavatorModel, GtnModel};
use super::models::{self, Built, BUILTIN_MODELS};
use acq_exec::executor::{Executor, LocalExecutor};
use acq_exec::slurm::{SlurmExecutor, SlurmSettings};
use acq_study::command_model::CommandModel;
use acq_study::extras::{Extras, NoExtras};
use acq_study::method::{start_design, RunSettings};
use acq_study::outcome::StudyOutcome;
use acq_study::progress::ProgressObserver;
use acq_study::run_directory::{write_text, RunDirectory};
use acq_study::saved_emulator::{rows_of_study, SavedEmulator};
use acq_study::spec::schema::{ExecutorKind, ExecutorSpec};
use acq_study::spec::{ModelKind, Spec};
use acq_study::study::{Model, Study};
use acq_study::study_runner::run_study;

#[derive(Clone, Debug)]
pub struct CalibrateExternalOptions {
    /// The spec (TOML): command, parameters, cases or outputs with measured values, search.
    pub spec: PathBuf,
    /// Run directory: evaluations.csv, runs/, summary.json, report.md, plots.
    pub out: PathBuf,
    /// Continue the run in DIR: evaluations already in its log are not repeated.
    pub resume: bool,
    pub seed: u64,
}

pub fn run(args: CalibrateExternalOptions) -> Result<()> {
    run_spec(&args, Spec::load(&args.spec, &BUILTIN_MODELS)?, None, None)
}

/// A study of a model the caller brings (the Python package's `model=`,
/// named `name` in the report): the spec's cases, observations, search
/// and posterior on `model`; the spec needs no command, and one it has is
/// not run.
pub fn run_with_model(
    args: CalibrateExternalOptions,
    given: Option<(&dyn Model, &str)>,
    progress: Option<ProgressObserver<'_>>,
) -> Result<()> {
    let spec = match given {
        Some(_) => Spec::load_with_given_model(&args.spec, &BUILTIN_MODELS)?,
        None => Spec::load(&args.spec, &BUILTIN_MODELS)?,
    };
    run_spec(&args, spec, given, progress)
}

fn run_spec(
    args: &CalibrateExternalOptions,
    spec: Spec,
    given: Option<(&dyn Model, &str)>,
    progress: Option<ProgressObserver<'_>>,
) -> Result<()> {
    let method = spec.method(args.seed);
    // The start design is read before the run directory exists: a refused
    // design leaves nothing behind.
    let initial = start_design(&spec.study.search_parameters(), &method, &spec.directory)?;
    let settings = RunSettings {
        label: "calibrate external".into(),
        title: args.spec.display().to_string(),
        spec_directory: &spec.directory,
        parallel: spec.runs_at_once.max(1),
        resume: args.resume,
        posterior: spec.posterior.clone(),
        progress,
    };
    let (model, directory) = spec_model(&spec, args, given)?;
    let extras = model.extras(&spec, args);
    run_study(
        &spec.study,
        model.model(),
        &method,
        initial,
        &directory,
        &settings,
        extras.as_ref(),
    )?;
    Ok(())
}

/// `acq mesh-study --spec SPEC --out DIR`: the spec's model at each of
/// `[mesh_study] sizes` (the command's `{mesh}`), at its nominal
/// parameters or `[mesh_study] at`, and each scalar output's grid
/// convergence ([`acq_study::mesh_study`]). With `given`, a model the
/// caller brings (the Python package's).
pub fn run_mesh_study(
    args: &CalibrateExternalOptions,
    given: Option<(&dyn Model, &str)>,
) -> Result<acq_study::mesh_study::MeshStudyOutcome> {
    let spec = Spec::load_for_mesh_study(&args.spec, &BUILTIN_MODELS, given.is_some())?;
    let in_spec = |e: String| AcqError::Config(format!("{}: {e}", args.spec.display()));
    let Some(settings) = &spec.mesh_study else {
        return Err(in_spec(
            "no [mesh_study]: add one with sizes = [...] (three or more element sizes, which the command takes as {mesh})".into(),
        ));
    };
    let (model, directory) = spec_model(&spec, args, given)?;
    acq_study::mesh_study::run_mesh_study(
        &spec.study,
        settings,
        model.model(),
        &directory,
        spec.runs_at_once.max(1),
        args.resume,
    )
}

/// The spec's model, built and checked, for `calibrate external` and
/// `mesh-study` alike: the one place a spec's `model` becomes a model.
enum SpecModel<'a> {
    Excavator(Box<ExcavatorModel>),
    Gtn(Box<GtnModel>),
    Command {
        model: Box<CommandModel>,
        command: String,
    },
    Given {
        model: &'a dyn Model,
        name: &'a str,
    },
}

impl SpecModel<'_> {
    fn model(&self) -> &dyn Model {
        match self {
            SpecModel::Excavator(model) => model.as_ref(),
            SpecModel::Gtn(model) => model.as_ref(),
            SpecModel::Command { model, .. } => model.as_ref(),
            SpecModel::Given { model, .. } => *model,
        }
    }

    /// What a study of this model leaves besides its report: the
    /// calibrated geometry of the excavator twin, the emulator of a
    /// user's model.
    fn extras(&self, spec: &Spec, args: &CalibrateExternalOptions) -> Box<dyn Extras + '_> {
        let emulator = |name: &str| {
            Box::new(EmulatorExtras {
                save: spec.save_emulator.clone(),
                model: name.to_string(),
                seed: args.seed,
            })
        };
        match self {
            SpecModel::Excavator(model) => Box::new(GeometryExtras {
                model: model.as_ref(),
                spec: args.spec.display().to_string(),
            }),
            SpecModel::Gtn(_) => Box::new(NoExtras),
            SpecModel::Command { command, .. } => emulator(command),
            SpecModel::Given { name, .. } => emulator(name),
        }
    }
}

/// Builds the spec's model and checks it before the run directory exists
/// (a built-in twin is cheap: every case is tried at the nominal point,
/// so a wrong name is refused at once), then creates the directory.
fn spec_model<'a>(
    spec: &Spec,
    args: &CalibrateExternalOptions,
    given: Option<(&'a dyn Model, &'a str)>,
) -> Result<(SpecModel<'a>, RunDirectory)> {
    let in_spec = |e: String| AcqError::Config(format!("{}: {e}", args.spec.display()));
    let model = match &spec.model {
        ModelKind::Builtin(builtin) => {
            match models::build(builtin, &spec.directory, &spec.study, in_spec)? {
                Built::Excavator(model) => SpecModel::Excavator(model),
                Built::Gtn(model) => SpecModel::Gtn(model),
            }
        }
        ModelKind::Command(command) => {
            let (model, directory) = command_model(spec, command, args)?;
            let command = command.command.join(" ");
            return Ok((
                SpecModel::Command {
                    model: Box::new(model),
                    command,
                },
                directory,
            ));
        }
        ModelKind::Given => {
            let Some((model, name)) = given else {
                return Err(in_spec(
                    "a spec for a given model was read without one".into(),
                ));
            };
            SpecModel::Given { model, name }
        }
    };
    Ok((model, run_directory(args)?))
}

/// The run directory, created: never the spec's own folder nor one that
/// holds the spec, where a run's outputs would lie among its inputs.
fn run_directory(args: &CalibrateExternalOptions) -> Result<RunDirectory> {
    let spec_folder = args
        .spec
        .parent()
        .map(|p| {
            if p.as_os_str().is_empty() {
                Path::new(".")
            } else {
                p
            }
        })
        .and_then(|p| std::fs::canonicalize(p).ok());
    if let (Some(spec_folder), Ok(out)) = (spec_folder, std::fs::canonicalize(&args.out)) {
        if spec_folder.starts_with(&out) {
            return Err(AcqError::Config(format!(
                "--out {}: it holds the spec {}, so the run's outputs would lie among its inputs; give a folder of its own (e.g. {})",
                args.out.display(),
                args.spec.display(),
                out.join("run").display()
            )));
        }
    }
    // A folder of other files is no run directory: a run's files would mix
    // with them (evaluations.csv of an earlier run is resumed or refused by
    // the evaluator, which says how).
    if !args.resume && !args.out.join("evaluations.csv").exists() {
        if let Ok(entries) = std::fs::read_dir(&args.out) {
            let held = entries.count();
            if held > 0 {
                return Err(AcqError::Config(format!(
                    "--out {}: it holds {held} file(s) and no run to resume; give a new or empty folder, where the run's evaluations.csv, summary.json and report are written",
                    args.out.display()
                )));
            }
        }
    }
    RunDirectory::create(&args.out)
}

/// A user's solver on the spec's executor, its runs in `args.out/runs/`,
/// and the run directory, created.
fn command_model(
    spec: &Spec,
    command: &acq_study::spec::CommandSpec,
    args: &CalibrateExternalOptions,
) -> Result<(CommandModel, RunDirectory)> {
    let executor = executor(&spec.executor)
        .map_err(|e| AcqError::Config(format!("{}: {e}", args.spec.display())))?;
    let directory = run_directory(args)?;
    let runs = std::fs::canonicalize(&directory.path)
        .map_err(|e| AcqError::io(format!("resolving {}", directory.path.display()), e))?
        .join("runs");
    let model = CommandModel::new(
        command.clone(),
        spec.directory.clone(),
        runs,
        executor,
        args.resume,
    );
    Ok((model, directory))
}

/// A study of a user's solver with `[emulator] save` leaves an emulator of
/// it over its parameters and its cases' inputs, fitted to the search's
/// runs, for a study at the rig to load.
struct EmulatorExtras {
    save: Option<String>,
    model: String,
    seed: u64,
}

impl Extras for EmulatorExtras {
    fn files(&self, study: &Study, outcome: &StudyOutcome, directory: &RunDirectory) -> Result<()> {
        let Some(name) = &self.save else {
            return Ok(());
        };
        let (columns, rows) = rows_of_study(study, &outcome.evaluations);
        let emulator = SavedEmulator::fit(&self.model, columns, &rows, self.seed)
            .map_err(|e| AcqError::Config(format!("[emulator] save: {e}")))?;
        let path = directory.file(name);
        emulator
            .save(&path)
            .map_err(|e| AcqError::Config(format!("[emulator] save: {e}")))?;
        let worst = emulator
            .outputs
            .iter()
            .map(|o| format!("{} {:.3e}", o.name, o.error_sd))
            .collect::<Vec<_>>()
            .join(", ");
        println!(
            "the emulator of {} runs is in {} (its error at runs left out: {worst})",
            rows.len(),
            path.display()
        );
        Ok(())
    }
}

/// Where a command's runs happen.
fn executor(spec: &ExecutorSpec) -> std::result::Result<Box<dyn Executor>, String> {
    Ok(match spec.kind {
        ExecutorKind::Local => Box::new(LocalExecutor),
        ExecutorKind::Slurm => Box::new(
            SlurmExecutor::new(SlurmSettings {
                partition: spec.partition.clone(),
                account: spec.account.clone(),
                time_limit: spec.time_limit.clone(),
                cpus_per_job: spec.cpus_per_job,
                memory_per_job: spec.memory_per_job.clone(),
                sbatch_args: spec.sbatch_args.clone(),
                prelude: spec.prelude.clone(),
            })
            .map_err(|e| e.to_string())?,
        ),
    })
}

/// A study of the built-in twin's geometry numbers leaves the geometry it
/// found, each changed number with where it came from.
struct GeometryExtras<'a> {
    model: &'a ExcavatorModel,
    spec: String,
}

impl Extras for GeometryExtras<'_> {
    fn files(&self, study: &Study, outcome: &StudyOutcome, directory: &RunDirectory) -> Result<()> {
        let uncertainties = outcome
            .identifiability
            .as_ref()
            .and_then(|a| a.standard_uncertainties(&study.search_parameters()));
        let file = self
            .model
            .calibrated_geometry_file(
                study,
                &outcome.calibrated,
                uncertainties.as_deref(),
                &self.spec,
            )
            .map_err(|e| AcqError::Config(format!("writing the calibrated geometry: {e}")))?;
        if let Some(text) = file {
            let path = directory.file("geometry.toml");
            write_text(&path, &text)?;
            println!("the calibrated geometry is in {}", path.display());
        }
        Ok(())
    }
}
