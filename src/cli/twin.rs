//! `acq twin` and `acq sensitivity`: dispatch to the twin runs of
//! [`acq_workflows::twin_excavator`] and [`acq_workflows::twin_gtn`].

use acq_io::error::Result;
use acq_workflows::twin_excavator::{SensitivityExcavatorArgs, TwinExcavatorArgs};
use acq_workflows::twin_gtn::TwinGtnArgs;
use clap::Subcommand;

#[derive(Subcommand, Debug)]
pub enum TwinCommand {
    /// The excavator front attachment: pose, cylinder pressures, gauge stresses.
    Excavator(TwinExcavatorArgs),
    /// The round tensile bar with GTN damage: curve and MAPE against a test.
    Gtn(TwinGtnArgs),
}

#[derive(Subcommand, Debug)]
pub enum SensitivityCommand {
    /// One-at-a-time sweep of the excavator case's uncertain inputs.
    Excavator(SensitivityExcavatorArgs),
}

pub fn run_twin(command: TwinCommand) -> Result<()> {
    match command {
        TwinCommand::Excavator(args) => acq_workflows::twin_excavator::run_twin(args),
        TwinCommand::Gtn(args) => acq_workflows::twin_gtn::run(args),
    }
}

pub fn run_sensitivity(command: SensitivityCommand) -> Result<()> {
    let SensitivityCommand::Excavator(args) = command;
    acq_workflows::twin_excavator::run_sensitivity(args)
}
