//! The `acq` command line: argument definitions and dispatch to the libraries.
//! One file per command group; each command is glue over a library call.

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

mod budget;
mod calibrate;
mod convert;
mod decode;
mod demo;
mod engine;
mod import;
mod interrupt;
mod lake;
mod live;
mod offline;
mod rig_study;
mod shunt;
mod tensile;
mod twin;
mod view;
mod zero;

use acq_error::Result;

/// The command line as given. Every option that takes a value takes a
/// negative number too: `--weights 1 1 -1` is a weight that the command
/// refuses with its reason, not an unknown option `-1`.
pub fn parse() -> Cli {
    let argv = negative_lists_attached(std::env::args_os().collect());
    let matches = numbers_may_be_negative(Cli::command()).get_matches_from(argv);
    Cli::from_arg_matches(&matches).unwrap_or_else(|error| error.exit())
}

/// `--weights -1,1,1` as `--weights=-1,1,1`: clap takes `-1` alone for a
/// negative number, but a comma list starting with a minus for a flag it
/// does not know. Joined, the list reaches the check that says what a
/// value may be. No flag of acq looks like a number.
fn negative_lists_attached(argv: Vec<std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    let is_negative_list = |token: &str| {
        token.starts_with('-')
            && token.contains(',')
            && token.split(',').all(|n| n.trim().parse::<f64>().is_ok())
    };
    let mut joined: Vec<std::ffi::OsString> = Vec::with_capacity(argv.len());
    for token in argv {
        let attach = match (joined.last().and_then(|p| p.to_str()), token.to_str()) {
            (Some(option), Some(value)) => {
                option.starts_with("--")
                    && option != "--"
                    && !option.contains('=')
                    && is_negative_list(value)
            }
            _ => false,
        };
        match joined.last_mut() {
            Some(option) if attach => {
                option.push("=");
                option.push(&token);
            }
            _ => joined.push(token),
        }
    }
    joined
}

fn numbers_may_be_negative(command: clap::Command) -> clap::Command {
    command
        .mut_args(|arg| {
            if arg.get_action().takes_values() {
                arg.allow_negative_numbers(true)
            } else {
                arg
            }
        })
        .mut_subcommands(numbers_may_be_negative)
}

#[derive(Parser, Debug)]
#[command(
    name = "acq",
    version,
    about = "Sensor-data acquisition bridge and calibration core for digital-twin validation",
    after_help = "Exit codes: 0 success, 1 I/O failure, 2 usage or configuration error, 3 malformed input."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Decode CAN logs (candump -L, Vector ASC or BLF, ASAM MF4) to CSV, Parquet or MF4, through DBC files or a rig.
    Decode(decode::DecodeArgs),
    /// Convert a CAN log (candump -L, Vector ASC or BLF, ASAM MF4) to candump -L, ASC or MF4, by OUT's extension.
    Convert(convert::ConvertArgs),
    /// Validate a rig file and explain every problem found.
    CheckRig(decode::CheckRigArgs),
    /// The uncertainty budget of one value of a sensor, as its rig states it.
    Budget(budget::BudgetArgs),
    /// Record CAN interfaces into a session directory, with live status.
    Record(live::RecordArgs),
    /// Make a session of logger files (MF4, BLF, ASC, candump), as if recorded: frames merged by time, the rig copied, the files named with their hashes.
    Import(import::ImportArgs),
    /// Serve the live page over recorded sessions: every signal, holds marked.
    View(view::ViewCommandArgs),
    /// Play a log back onto CAN interfaces with its original timing.
    Replay(live::ReplayArgs),
    /// Put a rig's simulated sensors on CAN interfaces, or into a log.
    Simulate(live::SimulateArgs),
    /// Put every sensor of a session (or log) on one time base, gaps flagged.
    Align(offline::AlignArgs),
    /// Measured values per steady hold (or a tensile curve) from a session.
    Extract(offline::ExtractArgs),
    /// Take a session's zero from a rest state before (and after) the test.
    Zero(zero::ZeroArgs),
    /// Check a strain channel's recorded shunt step; a session keeps the gain.
    Shunt(shunt::ShuntArgs),
    /// Work on recorded session directories.
    #[command(subcommand)]
    Session(live::SessionCommand),
    /// Run a digital twin once at a case's inputs (or overrides).
    #[command(subcommand)]
    Twin(twin::TwinCommand),
    /// One-at-a-time sensitivity of a twin's outputs to its uncertain inputs.
    #[command(subcommand)]
    Sensitivity(twin::SensitivityCommand),
    /// Young's modulus, yield, UTS, flow curve and post-UTS slope bounds of a tensile test.
    TensileProps(tensile::TensilePropsArgs),
    /// Fit a twin (or your own solver) to measurements: DoE, surrogates, NSGA-II + TOPSIS, BO.
    #[command(subcommand)]
    Calibrate(calibrate::CalibrateCommand),
    /// A spec's solver at several element sizes ([mesh_study] sizes, its {mesh}): each output's observed order, extrapolated value and GCI, the u_num of V&V 20.
    MeshStudy(calibrate::MeshStudyArgs),
    /// Gaussian-process regression on a CSV: fit a model, predict with it.
    #[command(subcommand)]
    Gp(engine::GpCommand),
    /// The whole chain on the shipped sessions: replay, record, align, extract, calibrate, report.
    Demo(demo::DemoArgs),
    /// NSGA-II on a built-in benchmark problem (ZDT1-3, DTLZ2): the final front as CSV.
    Moo(engine::MooArgs),
    /// A campaign's sessions and logger files as one Parquet dataset (a Hive-partitioned lake).
    #[command(subcommand)]
    Lake(lake::LakeCommand),
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Decode(args) => decode::run_decode(args),
        Command::Lake(command) => lake::run_lake(command),
        Command::Convert(args) => convert::run_convert(args),
        Command::Align(args) => offline::run_align(args),
        Command::Extract(args) => offline::run_extract(args),
        Command::Zero(args) => zero::run_zero(args),
        Command::Shunt(args) => shunt::run_shunt(args),
        Command::CheckRig(args) => decode::run_check_rig(args),
        Command::Budget(args) => budget::run_budget(args),
        Command::Record(args) => live::run_record(args),
        Command::Import(args) => import::run_import(args),
        Command::Replay(args) => live::run_replay(args),
        Command::View(args) => view::run_view(args),
        Command::Simulate(args) => live::run_simulate(args),
        Command::Session(command) => live::run_session(command),
        Command::Twin(command) => twin::run_twin(command),
        Command::Sensitivity(command) => twin::run_sensitivity(command),
        Command::TensileProps(args) => tensile::run_tensile_props(args),
        Command::Calibrate(command) => calibrate::run_calibrate(command),
        Command::MeshStudy(args) => calibrate::run_mesh_study(args),
        Command::Gp(command) => engine::run_gp(command),
        Command::Moo(args) => engine::run_moo(args),
        Command::Demo(args) => demo::run_demo(args),
    }
}

#[cfg(test)]
mod tests {
    use super::negative_lists_attached;

    #[test]
    fn a_negative_comma_list_is_attached_to_its_option_and_nothing_else_is() {
        let args =
            |line: &str| -> Vec<std::ffi::OsString> { line.split(' ').map(Into::into).collect() };
        assert_eq!(
            negative_lists_attached(args("acq calibrate excavator --weights -1,1,1 --out x")),
            args("acq calibrate excavator --weights=-1,1,1 --out x")
        );
        for unchanged in [
            "acq calibrate excavator --weights -1 1 1",
            "acq calibrate excavator --weights=1,-1,1",
            "acq decode -- -1,2",
            "acq decode x.log -o -1,a",
        ] {
            assert_eq!(negative_lists_attached(args(unchanged)), args(unchanged));
        }
    }
}
