//! `acq calibrate`: a model fitted to measurements by the engine of
//! `acq_calib`, and what that leaves in the run directory.
//!
//! Every study goes one way: a preset ([`excavator`], [`gtn`]) or a spec
//! ([`external`] reading [`spec`]) builds a [`study::Study`] and a
//! [`study::Model`] (a built-in twin, [`builtin`], or a user's solver,
//! [`command_model`], run where an [`executor`] says: child processes or
//! [`slurm`]) and hands them to the one runner, [`study_runner`], with a
//! method (Bayesian optimisation through [`search`], [`surrogate_moo`], or
//! least squares). The runner logs every model run in `evaluations.csv`
//! ([`run_directory`]; resumable with `--resume`), checks the validation
//! cases, runs the [`identifiability`] analysis, and writes
//! `summary.json` ([`summary`]) and the report ([`report`]); a preset adds
//! its own through [`extras`]. Progress goes to stderr ([`progress`]).

pub mod builtin;
pub mod command_model;
pub mod error;
pub mod excavator;
pub mod executor;
pub mod external;
pub mod extras;
pub mod gtn;
pub mod identifiability;
pub mod method;
pub mod outcome;
pub mod posterior;
pub mod progress;
pub mod report;
pub mod run_directory;
pub mod saved_emulator;
pub mod search;
pub mod slurm;
pub mod spec;
pub mod study;
pub mod study_runner;
pub mod summary;
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
