//! `acq calibrate`: the presets (excavator, GTN), a spec's study on a
//! user's solver, and a study at the rig over recorded sessions. The
//! arguments convert into the libraries' options structs; a run that
//! writes a run directory says how to resume it when interrupted.

use std::path::PathBuf;

use acq_algorithms::bo::Acquisition;
use acq_algorithms::gp::Kernel;
use acq_analysis::extract::measured::UncertaintyBasis;
use acq_error::Result;
use acq_study::posterior::Discrepancy;
use acq_study::surrogate_moo::Pick;
use acq_workflows::calibrate::excavator::{CalibrateExcavatorOptions, ExcavatorPosterior};
use acq_workflows::calibrate::external::CalibrateExternalOptions;
use acq_workflows::calibrate::gtn::CalibrateGtnOptions;
use acq_workflows::rig_study::offline::CalibrateRigOptions;
use acq_workflows::tensile_model::MeshOptions;
use clap::{Args, Subcommand};

/// `acq calibrate`: the presets and a spec's study, and a study at the rig
/// over recorded sessions.
#[derive(Subcommand, Debug)]
pub enum CalibrateCommand {
    /// Excavator front attachment: match the three cylinder pressures of a case.
    Excavator(CalibrateExcavatorArgs),
    /// GTN tensile twin: match a test's force-displacement curve.
    Gtn(CalibrateGtnArgs),
    /// A user's solver, run as a command per evaluation (spec file).
    External(CalibrateExternalArgs),
    /// A study at the rig over recorded sessions' holds; --next names the
    /// test point to run next.
    Rig(CalibrateRigArgs),
}

pub fn run_calibrate(command: CalibrateCommand) -> Result<()> {
    let run_directory = match &command {
        CalibrateCommand::Excavator(args) => Some(&args.out),
        CalibrateCommand::Gtn(args) => Some(&args.out),
        CalibrateCommand::External(args) => Some(&args.out),
        CalibrateCommand::Rig(_) => None,
    };
    if let Some(out) = run_directory {
        super::interrupt::say_how_to_resume_on_interrupt(out);
    }
    match command {
        CalibrateCommand::Excavator(args) => {
            acq_workflows::calibrate::excavator::run(args.into()).map(drop)
        }
        CalibrateCommand::Gtn(args) => acq_workflows::calibrate::gtn::run(args.into()).map(drop),
        CalibrateCommand::External(args) => acq_workflows::calibrate::external::run(args.into()),
        CalibrateCommand::Rig(args) => acq_workflows::rig_study::offline::run(args.into()),
    }
}

#[derive(Args, Debug)]
pub struct CalibrateExcavatorArgs {
    /// Case file (TOML) with bounds and measured pressures.
    #[arg(long, value_name = "FILE")]
    pub case: PathBuf,
    /// Measured values from `acq extract`: the loaded-chamber pressures
    /// (`<cylinder>_loaded_pressure`) replace the case's [measured], and the
    /// load (`--load-quantity`) replaces its force.
    #[arg(long, value_name = "measured.csv")]
    pub measured: Option<PathBuf>,
    /// The hold to use from the measured file [default: its only one].
    #[arg(long, value_name = "NAME", requires = "measured")]
    pub window: Option<String>,
    /// The measured quantity that is the force at the bucket tip (kN).
    #[arg(long, value_name = "QUANTITY", default_value = "tip_force")]
    pub load_quantity: String,
    /// Geometry file [default: the built-in DX55-class data/excavator/dx55.toml].
    #[arg(long, value_name = "FILE")]
    pub geometry: Option<PathBuf>,
    /// Run directory: evaluations.csv, summary.json, report.md, plots.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Latin-hypercube training runs of the twin.
    #[arg(long, default_value_t = 40, value_parser = clap::value_parser!(u32).range(5..=100_000))]
    pub training: u32,
    /// Random test runs for the surrogate comparison.
    #[arg(long, default_value_t = 40, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub test_runs: u32,
    /// NSGA-II population.
    #[arg(long, default_value_t = 400, value_parser = clap::value_parser!(u32).range(4..=1_000_000))]
    pub population: u32,
    /// NSGA-II generations (1 to 100,000).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub generations: u32,
    /// Largest share of the population on the first front.
    #[arg(long, default_value_t = 0.5)]
    pub pareto_fraction: f64,
    /// Weights of the bucket, arm and boom errors in the pick (`1 1 2` or
    /// `1,1,2`; non-negative, not all zero).
    // Negative numbers allowed: `--weights -1 1 1` reaches the check that
    // says what a weight may be, not clap's "unexpected argument".
    #[arg(long, value_delimiter = ',', num_args = 1..=3, allow_negative_numbers = true, default_values_t = [1.0, 1.0, 1.0])]
    pub weights: Vec<f64>,
    /// How one point of the Pareto front is picked: `minimax` (the point
    /// whose largest weighted error is least: what "largest error" judges),
    /// `topsis` (the published method; each error normalised by its own
    /// spread over the front, so an error that spreads widely, like the
    /// boom's, counts least) or `topsis-common` (TOPSIS with one norm for
    /// the three errors, which share a unit).
    #[arg(long, default_value = "minimax")]
    pub pick: Pick,
    /// GP kernel: se, matern12, matern32, matern52.
    #[arg(long, default_value = "se")]
    pub kernel: Kernel,
    /// Seed of the designs, the GP fits and NSGA-II.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Continue the run in DIR: evaluations already in its log are not repeated.
    #[arg(long)]
    pub resume: bool,
    /// Twin evaluations at once, 1 to 256 (a spec's limit) [default: the number of cores].
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..=256))]
    pub parallel: Option<u16>,
    /// After the search, sample the posterior of the inputs (4 chains of
    /// 1,000 draws, the twin run at every step) given the measured
    /// pressures' uncertainty: with --measured their budget (`u_c`: the
    /// transducers' certificates and accuracy with the readings' scatter;
    /// see --measurement-error), else a noise scale the posterior estimates. Writes posterior.csv and
    /// predictive.csv, and adds `posterior` and `predictive` to summary.json.
    #[arg(long)]
    pub posterior: bool,
    /// The model error the posterior allows for: `none`, or `constant` (an
    /// additive error per pressure, its size estimated). One case has no
    /// inputs to vary over: `gp` is for specs with several cases.
    #[arg(long, value_enum, default_value = "none", requires = "posterior")]
    pub discrepancy: PosteriorDiscrepancy,
    /// Kept posterior draws per chain (4 chains); an unconverged posterior
    /// is sampled once more, four times as long.
    #[arg(long, default_value_t = 1000, requires = "posterior", value_parser = parse_draws)]
    pub posterior_draws: usize,
    /// Which uncertainty of the measured pressures the study takes:
    /// `budget` (the file's `u_c`, where the rig states the transducers'
    /// accuracy or certificates; else the scatter) or `scatter` (the
    /// readings' scatter in the hold alone).
    #[arg(long, value_enum, default_value = "budget", requires = "measured")]
    pub measurement_error: MeasurementErrorArg,
}

/// `--measurement-error`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum MeasurementErrorArg {
    Budget,
    Scatter,
}

impl From<MeasurementErrorArg> for UncertaintyBasis {
    fn from(arg: MeasurementErrorArg) -> Self {
        match arg {
            MeasurementErrorArg::Budget => UncertaintyBasis::Budget,
            MeasurementErrorArg::Scatter => UncertaintyBasis::ReadingsScatter,
        }
    }
}

/// `--discrepancy`.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum PosteriorDiscrepancy {
    None,
    Constant,
}

#[derive(Args, Debug)]
pub struct CalibrateGtnArgs {
    /// Test CSV with DISPLACEMENT [mm] and FORCE [kN] columns.
    #[arg(long, value_name = "TEST.csv")]
    pub test: PathBuf,
    /// Run directory: evaluations.csv, summary.json, report.md, curve and plots.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Largest number of simulations (the L12 start included).
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(13..=100_000))]
    pub max_evals: u32,
    /// Stop once the MAPE is at or below this, %.
    #[arg(long, default_value_t = 2.0)]
    pub target_mape: f64,
    /// Simulations proposed (and run in parallel) per iteration.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub batch: u32,
    /// Acquisition: logei, ei, ucb[:KAPPA] (the published one is ucb:2.5).
    #[arg(long, default_value = "logei")]
    pub acquisition: Acquisition,
    /// Also stop when this many simulations in a row improved the best MAPE by
    /// less than 0.1 % (relative).
    #[arg(long)]
    pub patience: Option<u32>,
    #[command(flatten)]
    pub mesh: MeshArgs,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Global Bayesian-optimisation steps only (the published search),
    /// without the local Gauss-Newton steps on the curve's errors.
    #[arg(long)]
    pub global_only: bool,
    /// Local steps whose slopes are fitted to the runs made, as for a
    /// solver that gives none [default: each run's own, which the twin
    /// computes along with the curve: fewer runs, each about four times
    /// dearer]
    #[arg(long)]
    pub fitted_slopes: bool,
    /// With --batch above 1: synchronous batches, so the result depends
    /// only on the test, the options and the seed (slots wait for the
    /// slowest simulation of each batch) [default: each new point as soon
    /// as a simulation ends, which machine load can steer].
    #[arg(long)]
    pub deterministic: bool,
    /// Continue the run in DIR: simulations already in its log are not repeated.
    #[arg(long)]
    pub resume: bool,
    /// After the search, sample the posterior of the eight parameters on a
    /// Gaussian-process emulator of the simulations (refined by at most 100
    /// more where the posterior lies), the curve read as 20 parts with a
    /// noise of its own, and run 10 simulations at posterior draws for the
    /// predictive band. Writes posterior.csv and predictive.csv, and adds
    /// `posterior` and `predictive` to summary.json.
    #[arg(long)]
    pub posterior: bool,
    /// Kept posterior draws per chain (4 chains); an unconverged posterior
    /// is sampled once more, four times as long.
    #[arg(long, default_value_t = 1000, requires = "posterior", value_parser = parse_draws)]
    pub posterior_draws: usize,
    /// Two levels: cheap runs at this coarser element size at the neck
    /// (mm) beside the fine ones at --element-mm. The fine runs start at
    /// the two best points of the cheap start design (the L12 design and
    /// the middle of the box); each local step
    /// descends the cheap level shifted onto the fine one (output space
    /// mapping) with cheap runs and checks its end with one fine run; when
    /// the local steps cannot go on, one surrogate over both levels
    /// (co-kriging) picks the next run and its level by expected
    /// improvement per second. The answer is the best fine run.
    #[arg(long, value_name = "MM", requires = "element_mm")]
    pub cheap_element_mm: Option<f64>,
    /// With --cheap-element-mm: fine runs at most (--max-evals counts both levels).
    #[arg(long, value_name = "N", requires = "cheap_element_mm")]
    pub max_fine_runs: Option<u32>,
}

/// The mesh options of the GTN commands: element counts, or an element
/// size at the neck (the size GTN parameters belong to).
#[derive(Clone, Debug, Args)]
pub struct MeshArgs {
    /// Mesh as RADIALxAXIAL elements of the quarter model, graded toward the neck.
    #[arg(long, value_name = "NRxNZ", default_value = "6x30")]
    pub mesh: String,
    /// Element size in the neck zone, mm (instead of --mesh): square
    /// elements there, graded coarser toward the pulled end. GTN softening
    /// depends on it, so calibrate at the size of the model the parameters
    /// are for.
    #[arg(long, value_name = "MM", conflicts_with = "mesh")]
    pub element_mm: Option<f64>,
    /// Length of the neck zone from the mid-gauge plane, mm, with
    /// --element-mm [default: one diameter]
    #[arg(long, value_name = "MM", requires = "element_mm")]
    pub neck_zone_mm: Option<f64>,
}

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

/// `acq mesh-study --spec SPEC --out DIR`.
#[derive(Args, Debug)]
pub struct MeshStudyArgs {
    /// The spec (TOML) with [mesh_study] sizes and a command that takes {mesh}.
    #[arg(long, value_name = "FILE.toml")]
    pub spec: PathBuf,
    /// Run directory: evaluations.csv, runs/, summary.json (mesh_study), report.md, plots.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Continue the run in DIR: sizes already in its log are not run again.
    #[arg(long)]
    pub resume: bool,
}

pub fn run_mesh_study(args: MeshStudyArgs) -> Result<()> {
    super::interrupt::say_how_to_resume_on_interrupt(&args.out);
    let options = CalibrateExternalOptions {
        spec: args.spec,
        out: args.out,
        resume: args.resume,
        seed: 1,
    };
    let outcome = acq_workflows::calibrate::external::run_mesh_study(&options, None)?;
    // No result without a number: a study whose runs gave fewer than three
    // values says nothing of convergence, and is no success.
    let gave = outcome.evaluations - outcome.failed;
    if gave < 3 {
        return Err(acq_error::AcqError::Config(format!(
            "{}: {gave} of {} runs gave a value ({} failed; their logs are in {}): a mesh study needs three sizes that run; give sizes the model takes",
            options.spec.display(),
            outcome.evaluations,
            outcome.failed,
            options.out.display()
        )));
    }
    for output in &outcome.outputs {
        match &output.convergence {
            Some(study) => println!("{}: {study}", output.key),
            None => println!("{}: fewer than three sizes gave a value", output.key),
        }
    }
    println!(
        "{} runs ({} failed); summary.json and report.md in {}",
        outcome.evaluations,
        outcome.failed,
        options.out.display()
    );
    Ok(())
}

#[derive(Args, Debug)]
pub struct CalibrateRigArgs {
    /// Session directories written by acq record (their holds, in order).
    #[arg(value_name = "SESSION_DIR", required = true)]
    pub sessions: Vec<PathBuf>,
    /// The study at the rig (docs/src/study-at-the-rig.md).
    #[arg(long, value_name = "STUDY.toml")]
    pub study: PathBuf,
    /// Print the test point to run next: the candidate expected to narrow
    /// the posterior most.
    #[arg(long)]
    pub next: bool,
    /// Write the study's last state (what the page shows as `study`) as JSON.
    #[arg(short = 'o', long = "output", value_name = "OUT.json")]
    pub output: Option<PathBuf>,
}

impl From<CalibrateExcavatorArgs> for CalibrateExcavatorOptions {
    fn from(args: CalibrateExcavatorArgs) -> Self {
        CalibrateExcavatorOptions {
            case: args.case,
            measured: args.measured,
            window: args.window,
            load_quantity: args.load_quantity,
            measurement_error: args.measurement_error.into(),
            geometry: args.geometry,
            out: args.out,
            training_runs: args.training,
            test_runs: args.test_runs,
            population: args.population,
            generations: args.generations,
            pareto_fraction: args.pareto_fraction,
            weights: args.weights,
            pick: args.pick,
            kernel: args.kernel,
            seed: args.seed,
            resume: args.resume,
            parallel: args.parallel.map(usize::from),
            posterior: args.posterior.then_some(ExcavatorPosterior {
                discrepancy: match args.discrepancy {
                    PosteriorDiscrepancy::None => Discrepancy::None,
                    PosteriorDiscrepancy::Constant => Discrepancy::Constant,
                },
                draws_per_chain: args.posterior_draws,
            }),
        }
    }
}

impl From<CalibrateGtnArgs> for CalibrateGtnOptions {
    fn from(args: CalibrateGtnArgs) -> Self {
        CalibrateGtnOptions {
            test: args.test,
            out: args.out,
            max_evals: args.max_evals,
            target_mape_pct: args.target_mape,
            batch: args.batch,
            acquisition: args.acquisition,
            patience: args.patience,
            mesh: args.mesh.into(),
            seed: args.seed,
            global_only: args.global_only,
            fitted_slopes: args.fitted_slopes,
            deterministic: args.deterministic,
            resume: args.resume,
            posterior_draws_per_chain: args.posterior.then_some(args.posterior_draws),
            cheap_element_mm: args.cheap_element_mm,
            max_fine_runs: args.max_fine_runs,
        }
    }
}

impl From<MeshArgs> for MeshOptions {
    fn from(args: MeshArgs) -> Self {
        MeshOptions {
            mesh: args.mesh,
            element_mm: args.element_mm,
            neck_zone_mm: args.neck_zone_mm,
        }
    }
}

impl From<CalibrateExternalArgs> for CalibrateExternalOptions {
    fn from(args: CalibrateExternalArgs) -> Self {
        CalibrateExternalOptions {
            spec: args.spec,
            out: args.out,
            resume: args.resume,
            seed: args.seed,
        }
    }
}

impl From<CalibrateRigArgs> for CalibrateRigOptions {
    fn from(args: CalibrateRigArgs) -> Self {
        CalibrateRigOptions {
            sessions: args.sessions,
            study: args.study,
            next: args.next,
            output: args.output,
        }
    }
}

/// `--posterior-draws`: as a spec's `[posterior] draws`, 100 (R-hat and
/// the ESS need a hundred at least) to the spec's largest.
fn parse_draws(text: &str) -> std::result::Result<usize, String> {
    let max = acq_study::posterior::settings::MAX_DRAWS;
    match text.parse::<usize>() {
        Ok(draws) if (100..=max).contains(&draws) => Ok(draws),
        _ => Err(format!(
            "give 100 to {max} kept draws per chain (R-hat and ESS need a hundred at least; a million per chain is already hours)"
        )),
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use clap::Parser;

    use super::*;

    /// The command line's defaults are the library's: a preset run from
    /// the terminal and one run by the demo or a bench are the same run.
    #[test]
    fn the_command_lines_defaults_are_the_librarys() {
        #[derive(Parser)]
        struct Command {
            #[command(subcommand)]
            calibrate: CalibrateCommand,
        }
        let parsed = |argv: &[&str]| Command::parse_from(argv).calibrate;
        let (case, test, out) = (
            Path::new("case.toml"),
            Path::new("test.csv"),
            Path::new("run"),
        );
        let CalibrateCommand::Excavator(excavator) =
            parsed(&["acq", "excavator", "--case", "case.toml", "--out", "run"])
        else {
            panic!("parsed as another preset")
        };
        assert_eq!(
            format!("{:?}", CalibrateExcavatorOptions::from(excavator)),
            format!("{:?}", CalibrateExcavatorOptions::published(case, out))
        );
        let CalibrateCommand::Gtn(gtn) =
            parsed(&["acq", "gtn", "--test", "test.csv", "--out", "run"])
        else {
            panic!("parsed as another preset")
        };
        assert_eq!(
            format!("{:?}", CalibrateGtnOptions::from(gtn)),
            format!("{:?}", CalibrateGtnOptions::new(test, out))
        );
        let CalibrateCommand::Excavator(with_posterior) = parsed(&[
            "acq",
            "excavator",
            "--case",
            "case.toml",
            "--out",
            "run",
            "--posterior",
        ]) else {
            panic!("parsed as another preset")
        };
        let posterior = CalibrateExcavatorOptions::from(with_posterior)
            .posterior
            .expect("--posterior asks for one");
        assert_eq!(
            posterior.draws_per_chain,
            ExcavatorPosterior::DRAWS_PER_CHAIN
        );
        assert_eq!(posterior.discrepancy, Discrepancy::None);
    }
}
