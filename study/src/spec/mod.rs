//! The spec of `acq calibrate external`: a study on a user's solver or
//! a built-in twin, as a TOML file. [`Spec::load`] reads it and checks it
//! section by section ([`checks`]), reads the measured values it names
//! ([`observations`]) and builds the [`Study`] ([`assemble`]); every problem
//! names the file, and the line of the `[[table]]` at fault.
//!
//! - [`schema`]: every key and its default;
//! - [`checks`]: one check per section;
//! - [`observations`]: measured values from the spec and from files;
//! - [`assemble`]: the cases, parameters and priors of the study.
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
//!                            # one run per parameter per Jacobian), or
//!                            # "multi-fidelity" (with [mesh_study]: cheap
//!                            # runs at cheap_mesh beside expensive ones at
//!                            # its calibrate_at; max_expensive bounds those)
//! residuals = "relative"     # or "normalised": scalars in standard uncertainties
//! start = "lhs"              # bo: lhs, sobol, l12, factorial, or a CSV file of points
//!                            # (l12 with 3 or fewer parameters: its 2^d distinct corners)
//! start_runs = 10
//! max_evals = 60
//! target_loss_pct = 1.0
//! loss = "mean"              # or "max", or "squares" (with priors: a MAP estimate)
//! deterministic = false      # bo with parallel > 1: synchronous batches, the
//!                            # result a function of the spec and seed alone
//!                            # (default: runs as they finish, no slot idles)
//! local_steps = true         # bo: trust-region Gauss-Newton steps on the
//!                            # residuals (each scalar's error, each curve's
//!                            # errors in 20 parts) between the global ones;
//!                            # false gives the published search alone
//! training_runs = 40         # surrogate-moo, with test_runs, population,
//! test_runs = 40             # generations, pareto_fraction, kernel,
//!                            # refine_tolerance, refine_rounds
//!
//! [posterior]                # optional: after the search, the posterior
//! draws = 1000               # kept draws per chain (100 to 1,000,000)
//! chains = 4                 # 1 to 64
//! discrepancy = "none"       # or "constant": an additive model error per
//!                            # output, the same in every case, its size
//!                            # estimated; or "gp": one that varies over the
//!                            # cases' inputs
//! predictive_runs = 50       # model runs at posterior draws, per case
//! refinement_runs = 20       # runs an emulated posterior may add where its
//!                            # emulator is unsure (0 to 1000)
//! seed = 1
//! # optional: a validate value's numerical uncertainty (V&V 20's u_num,
//! # from your mesh study), in its unit
//! numerical_uncertainty = { "pressure_bar.boom" = 0.4 }
//!
//! [mesh_study]               # optional: `acq mesh-study --spec SPEC --out DIR`
//! sizes = [0.4, 0.2, 0.1]    # element sizes, any unit; the command's {mesh}
//! at = { youngs_modulus_gpa = 205.0 }  # [default: each parameter's nominal]
//! calibrate_at = 0.1         # the size a calibration runs at [default: the smallest]
//! ```
//!
//! The posterior's likelihood takes each measured value's `uncertainty`;
//! where none is stated, a relative noise scale is estimated with the
//! parameters (`measurement_noise_pct`).
//!
//! A measured value read from an `acq extract` file takes the hold's mean;
//! its uncertainty is a number, `"std"` (the spread of the readings in the
//! hold), `"std_of_mean"` (the value's uncertainty budget, `u_c`: the
//! standard error of the mean with the sensors' certificates and accuracy;
//! each sensor's part shared by every hold it measured) or
//! `"scatter_of_mean"` (the standard error of the mean alone, std over the
//! square root of the effective sample count, each hold independent: what
//! `"std_of_mean"` was before budgets; the same where the rig states no
//! sensor record). Any observation may have a `weight` (1 by default) in
//! the loss and in TOPSIS.

use std::path::{Path, PathBuf};

use acq_error::AcqError;

use self::schema::{ExecutorSpec, MethodName, PosteriorSpec, Search, SpecFile};
use super::method::{BoMethod, LeastSquaresMethod, Method, MultiFidelityMethod};
use super::posterior::{check_posterior, PosteriorSettings};
use super::study::Study;
use super::surrogate_moo::SurrogateMooSettings;

pub mod assemble;
pub mod checks;
pub mod model;
pub mod observations;
pub mod problem;
pub mod schema;

pub use self::model::{
    BuiltinKeys, BuiltinModel, BuiltinModels, CommandSpec, KeyReader, ModelKind,
};
pub use self::problem::{SpecError, SpecProblem};

/// A checked spec: the model, the study, how to search it.
#[derive(Debug)]
pub struct Spec {
    pub model: ModelKind,
    pub study: Study,
    pub search: Search,
    /// `[posterior]`: the posterior stage, when asked for.
    pub posterior: Option<PosteriorSettings>,
    /// `[executor]`: where a command's runs happen.
    pub executor: ExecutorSpec,
    /// Runs in flight at once, from `parallel` or `[executor] parallel`.
    pub runs_at_once: usize,
    /// Where the spec's relative paths start.
    pub directory: PathBuf,
    /// `[emulator] save`: the file name of the emulator to leave in the
    /// run directory.
    pub save_emulator: Option<String>,
    /// `[mesh_study]`: the element sizes `acq mesh-study` runs; every
    /// case of a calibration gets `mesh = calibrate_at`.
    pub mesh_study: Option<crate::mesh_study::MeshStudySettings>,
}

/// The directory a spec's relative paths start from.
pub fn spec_directory(spec: &Path) -> PathBuf {
    spec.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// A spec file's text and its tables as written (types checked, nothing
/// else).
pub fn read_spec_file(path: &Path) -> Result<(String, SpecFile), SpecError> {
    let text = acq_io::input::read_text(path).map_err(|e| AcqError::open(path, e))?;
    acq_io::input::note_input(path);
    let file: SpecFile = toml::from_str(&text).map_err(|e| SpecError::Invalid {
        path: path.to_path_buf(),
        line: None,
        message: e.to_string(),
    })?;
    Ok((text, file))
}

/// A solver's posterior is sampled on an emulator of the search's runs,
/// which needs one run per parameter and two more: a search whose budget
/// cannot leave that many is refused before its first run, not after it.
fn emulator_has_runs(
    file: &SpecFile,
    model: &ModelKind,
    parameters: usize,
) -> Result<(), SpecProblem> {
    let needed = parameters + 2;
    let budget = match file.search.method {
        MethodName::Bo | MethodName::LeastSquares => file.search.max_evals,
        // The emulator learns from the expensive runs.
        MethodName::MultiFidelity => file.search.max_expensive.unwrap_or(file.search.max_evals),
        // Its training runs alone are checked against its own minimum.
        MethodName::SurrogateMoo => return Ok(()),
    };
    if matches!(model, ModelKind::Command(_) | ModelKind::Given) && budget < needed {
        return Err(SpecProblem::file(format!(
            "[posterior] samples on an emulator of the search's runs, which needs at least {needed} (one per parameter and two more); search.max_evals = {budget} leaves fewer: raise it to {needed} or more"
        )));
    }
    Ok(())
}

impl Spec {
    /// Reads and checks a spec and the measured files it names; errors
    /// name the file (and the line of the table at fault) and what to fix.
    pub fn load(path: &Path, builtins: &dyn BuiltinModels) -> Result<Spec, SpecError> {
        Self::load_for(path, builtins, false, true)
    }

    /// [`Spec::load`] for its mesh study (`acq mesh-study`), which comes
    /// before the u_num `[posterior] mesh_study` reads from it; with
    /// `given`, for a model the caller brings.
    pub fn load_for_mesh_study(
        path: &Path,
        builtins: &dyn BuiltinModels,
        given: bool,
    ) -> Result<Spec, SpecError> {
        Self::load_for(path, builtins, given, false)
    }

    /// [`Spec::load`] for a study whose caller brings the model (the
    /// Python package's `model=`): the spec needs no `command`, and one it
    /// has is not run.
    pub fn load_with_given_model(
        path: &Path,
        builtins: &dyn BuiltinModels,
    ) -> Result<Spec, SpecError> {
        Self::load_for(path, builtins, true, true)
    }

    fn load_for(
        path: &Path,
        builtins: &dyn BuiltinModels,
        given: bool,
        with_mesh_u_num: bool,
    ) -> Result<Spec, SpecError> {
        let (text, file) = read_spec_file(path)?;
        let located = |problem: SpecProblem| problem.located(path, &text);
        let directory = spec_directory(path);
        let model = checks::model(&file, given, builtins).map_err(located)?;
        checks::emulator(&file).map_err(located)?;
        checks::observations_given(&file).map_err(located)?;
        checks::runs(&file).map_err(located)?;
        let runs_at_once = checks::executor(&file).map_err(located)?;
        checks::files(&file, &directory).map_err(located)?;
        checks::search(&file.search).map_err(located)?;
        checks::posterior(&file).map_err(located)?;
        let mesh_study = checks::mesh_study(&file, &model).map_err(located)?;
        checks::multi_fidelity(&file.search, mesh_study.as_ref()).map_err(located)?;
        let mut study = assemble::study(&file, &directory, &model).map_err(located)?;
        if let Some(mesh) = &mesh_study {
            // A calibration runs every case at the one size.
            for case in study.cases.iter_mut().filter(|c| !c.priors) {
                case.inputs
                    .push((crate::mesh_study::MESH_INPUT.into(), mesh.calibrate_at));
            }
        }
        let fit = study.observations(crate::study::Role::Fit);
        if !fit.is_empty() && fit.iter().all(|(case, o)| case.priors || o.weight == 0.0) {
            return Err(located(SpecProblem::file(
                "every measured value and curve has weight 0: the search would have nothing to fit; give at least one a weight above 0",
            )));
        }
        let mut posterior = file.posterior.as_ref().map(PosteriorSpec::settings);
        let mesh_run = file
            .posterior
            .as_ref()
            .and_then(|p| p.mesh_study.as_ref())
            .filter(|_| with_mesh_u_num);
        if let (Some(settings), Some(run)) = (&mut posterior, mesh_run) {
            let size = mesh_study.as_ref().map(|m| m.calibrate_at);
            let found = crate::mesh_study::u_num_from_run(&directory.join(run), &study, size)
                .map_err(|e| located(SpecProblem::file(format!("posterior.mesh_study: {e}"))))?;
            for (key, u_num, source) in found {
                let name = key.rsplit('/').next().unwrap_or(&key).to_string();
                if settings
                    .numerical_uncertainty
                    .iter()
                    .any(|(k, _)| *k == name)
                {
                    return Err(located(SpecProblem::file(format!(
                        "posterior.numerical_uncertainty.{name:?} and posterior.mesh_study both give its u_num: keep one"
                    ))));
                }
                settings.numerical_uncertainty.push((key.clone(), u_num));
                settings.numerical_uncertainty_sources.push((key, source));
            }
        }
        if let Some(settings) = &posterior {
            check_posterior(&study, settings)
                .map_err(|message| located(SpecProblem::file(format!("[posterior]: {message}"))))?;
            emulator_has_runs(&file, &model, study.parameters.len()).map_err(located)?;
        }
        Ok(Spec {
            model,
            study,
            search: file.search,
            posterior,
            executor: file.executor,
            runs_at_once,
            directory,
            save_emulator: file.emulator.and_then(|e| e.save),
            mesh_study,
        })
    }

    /// The search method with its settings: the spec's, else the method's
    /// published defaults.
    pub fn method(&self, seed: u64) -> Method {
        let search = &self.search;
        match search.method {
            MethodName::SurrogateMoo => {
                let defaults = SurrogateMooSettings::published(self.study.weights().len(), seed);
                Method::SurrogateMoo(SurrogateMooSettings {
                    training_runs: search.training_runs.unwrap_or(defaults.training_runs),
                    test_runs: search.test_runs.unwrap_or(defaults.test_runs),
                    population: search.population.unwrap_or(defaults.population),
                    generations: search.generations.unwrap_or(defaults.generations),
                    pareto_fraction: search.pareto_fraction.unwrap_or(defaults.pareto_fraction),
                    weights: self.study.weights(),
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
            }
            MethodName::MultiFidelity => Method::MultiFidelity(MultiFidelityMethod {
                start: search.start.clone(),
                start_runs: search.start_runs,
                expensive_start_runs: search.expensive_start_runs(),
                // Checked at load: a multi-fidelity spec has both.
                cheap_mesh: search.cheap_mesh.unwrap_or(f64::NAN),
                expensive_mesh: self
                    .mesh_study
                    .as_ref()
                    .map_or(f64::NAN, |m| m.calibrate_at),
                max_evals: search.max_evals,
                max_expensive: search.max_expensive.unwrap_or(search.max_evals),
                target_loss: search.target_loss_pct,
                seed,
                local_steps: search.local_steps.unwrap_or(true),
            }),
            MethodName::LeastSquares => Method::LeastSquares(LeastSquaresMethod {
                max_evals: search.max_evals,
            }),
            MethodName::Bo => Method::Bo(BoMethod {
                start: search.start.clone(),
                start_runs: search.start_runs,
                max_evals: search.max_evals,
                target_loss: search.target_loss_pct,
                acquisition: search.acquisition.as_deref().and_then(|a| a.parse().ok()),
                patience: search.patience,
                batch: self.runs_at_once,
                seed,
                local_steps: search.local_steps.unwrap_or(true),
                deterministic: search.deterministic,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::spec::schema::ModelName;

    /// A program with no built-in model: the spec below names none.
    struct NoBuiltinModels;

    impl BuiltinModels for NoBuiltinModels {
        fn misplaced_key(&self, _: &SpecFile, _: KeyReader) -> Option<String> {
            None
        }
        fn resolve(&self, name: ModelName, _: &SpecFile) -> Result<BuiltinModel, String> {
            Err(format!("no built-in model {:?} here", name.name()))
        }
    }

    fn method_of(search: &str) -> Method {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("spec.toml");
        std::fs::write(
            &path,
            format!(
                "command = [\"true\"]\noutput_file = \"out.json\"\nparallel = 2\n\n[[parameter]]\nname = \"a\"\nlower = 1.0\nupper = 2.0\n\n[[output]]\nname = \"y\"\nmeasured = 1.0\n\n[search]\n{search}"
            ),
        )
        .unwrap();
        Spec::load(&path, &NoBuiltinModels).unwrap().method(1)
    }

    #[test]
    fn deterministic_asks_for_synchronous_batches_and_is_off_by_default() {
        let Method::Bo(default) = method_of("") else {
            panic!("bo is the default method")
        };
        assert!(!default.deterministic);
        assert_eq!(default.batch, 2);
        let Method::Bo(asked) = method_of("deterministic = true\n") else {
            panic!("bo is the default method")
        };
        assert!(asked.deterministic);
    }
}
