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

use acq_io::error::{AcqError, Result};

/// Refuses a count outside its range (`(option, value, range)`), in the
/// words the command line uses, before anything runs.
fn check_counts(counts: &[(&str, u32, std::ops::RangeInclusive<u32>)]) -> Result<()> {
    for (option, value, range) in counts {
        if !range.contains(value) {
            return Err(AcqError::Config(format!(
                "{option} {value}: give a number in {}..={}",
                range.start(),
                range.end()
            )));
        }
    }
    Ok(())
}
