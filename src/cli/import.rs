//! The command-line glue of `acq import`: logger files into a session.

use std::path::PathBuf;

use super::live::parse_size;
use acq_acquire::import::{self, BusMapping, ImportOptions};
use acq_error::{AcqError, Result};
use acq_io::session;
use clap::Args;

#[derive(Args, Debug)]
pub struct ImportArgs {
    /// The logger files (MF4, unfinalized too; BLF; ASC; candump -L), in any
    /// order: their frames are merged by time. Never modified.
    #[arg(value_name = "LOG", required = true)]
    pub logs: Vec<PathBuf>,
    /// The rig the frames were logged on; copied into the session, as
    /// `acq record --rig` does, so later commands need no --rig.
    #[arg(long, value_name = "RIG.toml")]
    pub rig: Option<PathBuf>,
    /// The session directory to make (must not hold a recording).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Import frames logged on LOGGED as interface SESSION (a logger's
    /// `can1` as the rig's `can0`); repeat for each bus. With FILES: (a
    /// file, or a folder of one logger's files) only in those files, so
    /// that two loggers that both log `can1` stay apart:
    /// `--bus logger_a:can1=can0 --bus logger_b:can1=can2`.
    #[arg(long = "bus", value_name = "[FILES:]LOGGED=SESSION", value_parser = clap::value_parser!(BusMapping))]
    pub bus_map: Vec<BusMapping>,
    /// Keep a byte-for-byte copy of each file in SESSION/sources/ (without
    /// it each is named in session.toml with its SHA-256).
    #[arg(long)]
    pub copy_sources: bool,
    /// Count malformed records and go on instead of stopping at the first.
    #[arg(long)]
    pub skip_bad: bool,
    /// Start a new raw file past this size (`1GiB`, `500MB`).
    #[arg(long, default_value = "1GiB", value_parser = parse_size)]
    pub max_file_size: u64,
}

pub fn run_import(args: ImportArgs) -> Result<()> {
    BusMapping::check(&args.bus_map, &args.logs).map_err(AcqError::Config)?;
    let rig = args
        .rig
        .as_deref()
        .map(acq_io::input::load_rig)
        .transpose()?;
    let summary = import::import(ImportOptions {
        logs: args.logs,
        rig,
        session_dir: args.out,
        bus_map: args.bus_map,
        copy_sources: args.copy_sources,
        skip_bad: args.skip_bad,
        max_file_bytes: args.max_file_size,
        command_line: std::env::args().collect::<Vec<_>>().join(" "),
        on_file: Box::new(|number, of, path| {
            eprintln!("acq import: [{number}/{of}] {}", path.display());
        }),
    })?;
    let info = &summary.session.session;
    for note in &info.notes {
        eprintln!("acq import: {note}");
    }
    let interfaces: Vec<String> = summary
        .session
        .interface
        .iter()
        .map(|i| format!("{} {} frames", i.name, i.frames))
        .collect();
    println!(
        "acq import: {} frames from {} file{} ({}), {} to {}, into {}",
        info.frames,
        summary.session.source.len(),
        if summary.session.source.len() == 1 {
            ""
        } else {
            "s"
        },
        interfaces.join(", "),
        info.started_utc,
        info.stopped_utc.as_deref().unwrap_or("-"),
        summary.session_dir.join(session::SESSION_FILE).display()
    );
    Ok(())
}
