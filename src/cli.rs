//! The `acq` command line: argument definitions and dispatch to the library.

use std::path::PathBuf;

use acq_drivers::dbc::DbcDatabase;
use acq_drivers::rig::Rig;
use clap::{Args, Parser, Subcommand};

use crate::decode::{self, DbcDecodeOptions};
use crate::error::{AcqError, Result};
use crate::input::{open_logs, BadLines};
use crate::output::Output;

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
    /// Decode CAN logs (candump -L or Vector ASC) to CSV, through DBC files or a rig.
    Decode(DecodeArgs),
    /// Validate a rig file and explain every problem found.
    CheckRig(CheckRigArgs),
    /// Record CAN interfaces into a session directory, with live status.
    Record(crate::live_cli::RecordArgs),
    /// Play a log back onto CAN interfaces with its original timing.
    Replay(crate::live_cli::ReplayArgs),
    /// Put a rig's simulated sensors on CAN interfaces, or into a log.
    Simulate(crate::live_cli::SimulateArgs),
    /// Put every sensor of a session (or log) on one time base, gaps flagged.
    Align(crate::offline_cli::AlignArgs),
    /// Measured values per steady hold (or a tensile curve) from a session.
    Extract(crate::offline_cli::ExtractArgs),
    /// Work on recorded session directories.
    #[command(subcommand)]
    Session(crate::live_cli::SessionCommand),
    /// Run a digital twin once at a case's inputs (or overrides).
    #[command(subcommand)]
    Twin(crate::twin_cli::TwinCommand),
    /// One-at-a-time sensitivity of a twin's outputs to its uncertain inputs.
    #[command(subcommand)]
    Sensitivity(crate::twin_cli::SensitivityCommand),
    /// Young's modulus, yield, UTS, flow curve and post-UTS slope bounds of a tensile test.
    TensileProps(crate::tensile_cli::TensilePropsArgs),
    /// Fit a twin (or your own solver) to measurements: DoE, surrogates, NSGA-II + TOPSIS, BO.
    #[command(subcommand)]
    Calibrate(crate::calibrate::CalibrateCommand),
    /// Gaussian-process regression on a CSV: fit a model, predict with it.
    #[command(subcommand)]
    Gp(crate::engine_cli::GpCommand),
    /// The whole chain on the shipped sessions: replay, record, align, extract, calibrate, report.
    Demo(crate::demo::DemoArgs),
    /// NSGA-II on a built-in benchmark problem (ZDT1-3, DTLZ2): the final front as CSV.
    Moo(crate::engine_cli::MooArgs),
}

#[derive(Args, Debug)]
pub struct DecodeArgs {
    /// Log files to decode, in order; `-` reads stdin.
    #[arg(required = true, value_name = "LOG")]
    pub logs: Vec<PathBuf>,
    /// DBC file(s); output: time_s,iface,can_id,message,signal,value,unit.
    #[arg(
        long = "dbc",
        value_name = "FILE",
        required_unless_present = "rig",
        conflicts_with = "rig"
    )]
    pub dbc: Vec<PathBuf>,
    /// Rig file; output: time_s,sensor,value,unit.
    #[arg(long, value_name = "RIG.toml")]
    pub rig: Option<PathBuf>,
    /// Output CSV file; `-` or absent writes to stdout.
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: Option<PathBuf>,
    /// Count malformed lines and go on instead of stopping at the first.
    #[arg(long)]
    pub skip_bad: bool,
    /// Add a `label` column with the DBC value-table label of each value.
    #[arg(long, conflicts_with = "rig")]
    pub labels: bool,
}

#[derive(Args, Debug)]
pub struct CheckRigArgs {
    /// The rig file to check.
    #[arg(value_name = "RIG.toml")]
    pub rig: PathBuf,
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Decode(args) => run_decode(args),
        Command::Align(args) => crate::offline_cli::run_align(args),
        Command::Extract(args) => crate::offline_cli::run_extract(args),
        Command::CheckRig(args) => run_check_rig(args),
        Command::Record(args) => crate::live_cli::run_record(args),
        Command::Replay(args) => crate::live_cli::run_replay(args),
        Command::Simulate(args) => crate::live_cli::run_simulate(args),
        Command::Session(command) => crate::live_cli::run_session(command),
        Command::Twin(command) => crate::twin_cli::run_twin(command),
        Command::Sensitivity(command) => crate::twin_cli::run_sensitivity(command),
        Command::TensileProps(args) => crate::tensile_cli::run_tensile_props(args),
        Command::Calibrate(command) => crate::calibrate::run(command),
        Command::Gp(command) => crate::engine_cli::run_gp(command),
        Command::Moo(args) => crate::engine_cli::run_moo(args),
        Command::Demo(args) => crate::demo::run(args),
    }
}

fn bad_lines(skip_bad: bool) -> BadLines {
    if skip_bad {
        BadLines::Skip
    } else {
        BadLines::Stop
    }
}

fn run_decode(args: DecodeArgs) -> Result<()> {
    let mut inputs = open_logs(&args.logs)?;
    if let Some(rig_path) = &args.rig {
        let rig = load_rig(rig_path)?;
        let mut output = Output::create(args.output.as_deref())?;
        let summary =
            decode::decode_with_rig(&mut inputs, &rig, bad_lines(args.skip_bad), &mut output);
        return finish(summary, output);
    }
    let (database, warnings) =
        DbcDatabase::load_all(&args.dbc).map_err(|e| AcqError::Config(e.to_string()))?;
    for warning in warnings {
        eprintln!("acq: warning: {}", warning.0);
    }
    let mut output = Output::create(args.output.as_deref())?;
    let options = DbcDecodeOptions {
        bad_lines: bad_lines(args.skip_bad),
        labels: args.labels,
    };
    let summary = decode::decode_with_dbc(&mut inputs, &database, options, &mut output);
    finish(summary, output)
}

/// Flushes what was decoded even when decoding stopped at a bad line, then
/// reports the summary.
fn finish(summary: Result<decode::DecodeSummary>, output: Output) -> Result<()> {
    let flushed = output.finish();
    let summary = summary?;
    flushed?;
    decode::report(&summary);
    Ok(())
}

fn run_check_rig(args: CheckRigArgs) -> Result<()> {
    let rig = load_rig(&args.rig)?;
    print!("{}", rig.explain());
    Ok(())
}

/// Loads a rig; every problem in it is a configuration error (exit 2).
pub fn load_rig(path: &std::path::Path) -> Result<Rig> {
    let rig = Rig::load(path).map_err(|e| AcqError::Config(e.to_string()))?;
    for warning in &rig.warnings {
        eprintln!("acq: warning: {warning}");
    }
    Ok(rig)
}
