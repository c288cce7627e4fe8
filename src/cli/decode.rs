//! `acq decode` and `acq check-rig`: logs to CSV or Parquet through DBC files or a rig,
//! and a rig file explained. Glue over [`acq_analysis::decode`] and
//! [`acq_rig`].

use std::path::PathBuf;

use acq_analysis::decode::{self, DbcDecodeOptions};
use acq_can::dbc::{DbcDatabase, IdMatching};
use acq_error::{AcqError, Result};
use acq_io::input::{load_rig, open_logs, BadLines};
use acq_io::output::TableOutput;
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
    /// Match frames to DBC messages by their exact id only. Without it, a
    /// DBC that declares J1939 (`ProtocolType "J1939"`, or a message's
    /// `VFrameFormat` `J1939PG`) matches its messages by PGN, from any
    /// source address and priority; `can_id` then holds the frame's id.
    #[arg(long, conflicts_with = "rig")]
    pub exact_ids: bool,
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
    let path = args.output.unwrap_or_else(|| PathBuf::from("-"));
    let name = path.display().to_string();
    let skip = bad_lines(args.skip_bad);
    let summary = if let Some(rig_path) = &args.rig {
        let rig = load_rig(rig_path)?;
        decode::decode_rig(&mut inputs, &rig, skip, TableOutput::create(&path)?, &name)?
    } else {
        let (mut database, warnings) =
            DbcDatabase::load_all(&args.dbc).map_err(|e| AcqError::Config(e.to_string()))?;
        if args.exact_ids {
            database.set_id_matching(IdMatching::ExactIds);
        }
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
        decode::decode_dbc(
            &mut inputs,
            &database,
            options,
            TableOutput::create(&path)?,
            &name,
        )?
    };
    decode::report(&summary);
    Ok(())
}

pub fn run_check_rig(args: CheckRigArgs) -> Result<()> {
    let rig = load_rig(&args.rig)?;
    print!("{}", rig.explain());
    println!("calibration (today {}):", today());
    for line in rig.calibration_status(&today()) {
        println!("  {line}");
    }
    Ok(())
}

/// Today's date in UTC, `YYYY-MM-DD`: what a certificate's due date is
/// compared with.
pub fn today() -> String {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
    acq_io::session::utc_text(now).chars().take(10).collect()
}
