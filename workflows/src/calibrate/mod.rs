//! `acq calibrate excavator|gtn|external`: the presets and a spec's entry,
//! each building a study of `acq_study` and handing it to its one runner.
//!
//! A preset ([`excavator`], [`gtn`]) or a spec ([`external`], reading
//! `acq_study::spec`) builds a `Study` and a model: a built-in twin
//! ([`builtin`]) or a user's solver (`acq_study::command_model`, run where
//! an `acq_exec` executor says). What only a preset shows goes through
//! `acq_study::extras`.

pub mod builtin;
pub mod excavator;
pub mod external;
pub mod gtn;
pub mod models;

use acq_error::{AcqError, Result};

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
