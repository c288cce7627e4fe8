//! The command-line glue of `acq lake`: a campaign's sessions and logger
//! files as one Parquet dataset.

use std::path::PathBuf;

use acq_error::{AcqError, Result};
use acq_lake::ingest::{self, IngestOptions, Outcome};
use clap::{Args, Subcommand};

#[derive(Subcommand, Debug)]
pub enum LakeCommand {
    /// Decode sessions and logger files into the lake: samples per device, sensor and UTC day, holds and measured values; a source already in it with the same content is skipped.
    Ingest(IngestArgs),
}

#[derive(Args, Debug)]
pub struct IngestArgs {
    /// Session directories (acq record, acq import) and logger files
    /// (candump -L, Vector ASC or BLF, ASAM MF4). Never modified.
    #[arg(value_name = "INPUT", required = true)]
    pub inputs: Vec<PathBuf>,
    /// The rig that decodes every input.
    #[arg(long, value_name = "RIG.toml")]
    pub rig: PathBuf,
    /// The lake's directory (made if missing).
    #[arg(long, value_name = "DIR")]
    pub lake: PathBuf,
    /// The machine the inputs come from: the `device` partition
    /// [default: the rig file's name].
    #[arg(long, value_name = "NAME")]
    pub device: Option<String>,
}

pub fn run_lake(command: LakeCommand) -> Result<()> {
    match command {
        LakeCommand::Ingest(args) => run_ingest(args),
    }
}

fn run_ingest(args: IngestArgs) -> Result<()> {
    let options = IngestOptions {
        lake: args.lake.clone(),
        rig: args.rig,
        device: args.device,
    };
    let started = std::time::Instant::now();
    let reports = ingest::ingest(&args.inputs, &options, |report| {
        let source = report.source.display();
        match &report.outcome {
            Outcome::Unchanged => {
                eprintln!("acq lake: {source}: unchanged since its ingest, skipped")
            }
            Outcome::Ingested { replaced, entry } => {
                let verb = if *replaced {
                    "changed, ingested again"
                } else {
                    "ingested"
                };
                eprintln!(
                    "acq lake: {source}: {verb}: {} samples into {} files",
                    entry.samples,
                    entry.files.len()
                );
                for note in &entry.notes {
                    eprintln!("acq lake:   {note}");
                }
            }
            Outcome::Failed(why) => eprintln!("acq lake: {source}: not ingested: {why}"),
        }
    })?;
    let failed = reports
        .iter()
        .filter(|r| matches!(r.outcome, Outcome::Failed(_)))
        .count();
    let ingested = reports
        .iter()
        .filter(|r| matches!(r.outcome, Outcome::Ingested { .. }))
        .count();
    eprintln!(
        "acq lake: {} source(s): {ingested} ingested, {} unchanged, {failed} not ingested, in {:.1} s",
        reports.len(),
        reports.len() - ingested - failed,
        started.elapsed().as_secs_f64()
    );
    println!("lake: {}", args.lake.display());
    if failed > 0 {
        return Err(AcqError::Config(format!(
            "{failed} of {} source(s) not ingested (each said above); the others are in the lake",
            reports.len()
        )));
    }
    Ok(())
}
