//! `acq calibrate`: the workflows that fit a model to measurements with the
//! engine of `acq_calib`, and what they leave in the run directory.
//!
//! - [`excavator`]: DoE -> GP per pressure -> NSGA-II on the GP -> TOPSIS ->
//!   the pick re-run on the twin.
//! - [`gtn`]: flow curve from the test, L12 start, Bayesian optimisation of
//!   the curve MAPE.
//! - [`external`]: the same engine on a user's solver run as a command.
//!
//! Every workflow writes `evaluations.csv` as it goes (resumable with
//! `--resume`), then `summary.json` (the fixed interface), `report.md`, `report.html` and
//! SVG plots. Progress goes to stderr.
//!
//! Shared by the workflows, and using none of them: [`run_directory`] (where
//! a run's files go, its logging evaluator) and [`search`] (the unit box,
//! Bayesian optimisation through the log, the best distinct candidates).

pub mod builtin;
pub mod excavator;
pub mod executor;
pub mod external;
pub mod gtn;
pub mod identifiability;
pub mod progress;
pub mod report;
pub mod run_directory;
pub mod search;
pub mod slurm;
pub mod study;
pub mod study_runner;
pub mod surrogate_moo;

use clap::Subcommand;

use acq_io::error::Result;

#[derive(Subcommand, Debug)]
pub enum CalibrateCommand {
    /// Excavator front attachment: match the three cylinder pressures of a case.
    Excavator(excavator::CalibrateExcavatorArgs),
    /// GTN tensile twin: match a test's force-displacement curve.
    Gtn(gtn::CalibrateGtnArgs),
    /// A user's solver, run as a command per evaluation (spec file).
    External(external::CalibrateExternalArgs),
}

pub fn run(command: CalibrateCommand) -> Result<()> {
    let out = match &command {
        CalibrateCommand::Excavator(args) => &args.out,
        CalibrateCommand::Gtn(args) => &args.out,
        CalibrateCommand::External(args) => &args.out,
    };
    run_directory::say_how_to_resume_on_interrupt(out);
    match command {
        CalibrateCommand::Excavator(args) => excavator::run(args).map(drop),
        CalibrateCommand::Gtn(args) => gtn::run(args).map(drop),
        CalibrateCommand::External(args) => external::run(args),
    }
}
