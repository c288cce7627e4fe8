//! `acq decode` and `acq check-rig`: logs to CSV or Parquet through DBC files or a rig,
//! and a rig file explained. Glue over [`acq_analysis::decode`] and
//! [`acq_drivers::rig`].

use std::path::PathBuf;

use acq_analysis::decode::{self, DbcDecodeOptions, DbcMf4, DbcParquet, RigMf4, RigParquet};
use acq_drivers::dbc::DbcDatabase;
use acq_io::error::{AcqError, Result};
use acq_io::input::{load_rig, open_logs, BadLines};
use acq_io::output::{Output, TableFormat, TableOutput};
use clap::Args;

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
    /// Output file: CSV; Parquet when the name ends in `.parquet` (the same
    /// columns, time as a UTC timestamp); MF4 for `.mf4` (a channel group
    /// per message or sensor, with units). Parquet and MF4 appear whole or
    /// not at all. `-` or absent writes CSV to stdout.
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

fn bad_lines(skip_bad: bool) -> BadLines {
    if skip_bad {
        BadLines::Skip
    } else {
        BadLines::Stop
    }
}

pub fn run_decode(args: DecodeArgs) -> Result<()> {
    let mut inputs = open_logs(&args.logs)?;
    let table = match args.output.as_deref() {
        Some(path) if TableFormat::of(path) != TableFormat::Csv => Some(TableOutput::create(path)?),
        _ => None,
    };
    let name = args
        .output
        .as_deref()
        .map(|p| p.display().to_string())
        .unwrap_or_default();
    let skip = bad_lines(args.skip_bad);
    if let Some(rig_path) = &args.rig {
        let rig = load_rig(rig_path)?;
        return match table {
            Some(TableOutput::Parquet(output)) => {
                let mut sink = RigParquet::create(output, &rig)?;
                let summary = decode::decode_rig_frames(&mut inputs, &rig, skip, &mut sink);
                finish(summary, sink.finish().map(|_| ()))
            }
            Some(TableOutput::Mf4(file)) => {
                let mut sink = RigMf4::create(file, &name, &rig)?;
                let summary = decode::decode_rig_frames(&mut inputs, &rig, skip, &mut sink);
                finish(summary, sink.finish())
            }
            _ => {
                let mut output = Output::create(args.output.as_deref())?;
                let summary = decode::decode_with_rig(&mut inputs, &rig, skip, &mut output);
                finish(summary, output.finish())
            }
        };
    }
    let (database, warnings) =
        DbcDatabase::load_all(&args.dbc).map_err(|e| AcqError::Config(e.to_string()))?;
    for dbc in &args.dbc {
        acq_io::input::note_input(dbc);
    }
    for warning in warnings {
        eprintln!("acq: warning: {}", warning.0);
    }
    let options = DbcDecodeOptions {
        bad_lines: skip,
        labels: args.labels,
    };
    match table {
        Some(TableOutput::Parquet(output)) => {
            let mut sink = DbcParquet::create(output, &database, args.labels)?;
            let summary = decode::decode_dbc_frames(&mut inputs, &database, options, &mut sink);
            finish(summary, sink.finish().map(|_| ()))
        }
        Some(TableOutput::Mf4(file)) => {
            let mut sink = DbcMf4::create(file, &name, &database)?;
            let summary = decode::decode_dbc_frames(&mut inputs, &database, options, &mut sink);
            finish(summary, sink.finish())
        }
        _ => {
            let mut output = Output::create(args.output.as_deref())?;
            let summary = decode::decode_with_dbc(&mut inputs, &database, options, &mut output);
            finish(summary, output.finish())
        }
    }
}

/// Keeps what was decoded even when decoding stopped at a bad line (the
/// output is `flushed` first), then reports the summary.
fn finish(summary: Result<decode::DecodeSummary>, flushed: Result<()>) -> Result<()> {
    let summary = summary?;
    flushed?;
    decode::report(&summary);
    Ok(())
}

pub fn run_check_rig(args: CheckRigArgs) -> Result<()> {
    let rig = load_rig(&args.rig)?;
    print!("{}", rig.explain());
    Ok(())
}
