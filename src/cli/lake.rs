//! The command-line glue of `acq lake`: a campaign's sessions and logger
//! files as one Parquet dataset.

use std::path::PathBuf;

use acq_error::{AcqError, Result};
use std::io::Write;

use acq_io::output::{CompleteOnlyFile, TableFormat};
use acq_lake::ingest::{self, IngestOptions, Outcome};
use acq_lake::query::{self, Sink};
use clap::{Args, Subcommand};

#[derive(Subcommand, Debug)]
pub enum LakeCommand {
    /// Decode sessions and logger files into the lake: samples per device, sensor and UTC day, holds and measured values; a source already in it with the same content is skipped.
    Ingest(IngestArgs),
    /// Run SQL over the lake with Apache DataFusion (tables `samples`, `holds`, `measured`; partitions as columns): CSV with a header on stdout, or to -o FILE (CSV, or Parquet for `.parquet`).
    Query(QueryArgs),
    /// The measured values of the lake's sessions (all, or those --where selects) as one file that acq calibrate reads: acq extract's columns led by the session, each window named session/window.
    Extract(ExtractArgs),
}

#[derive(Args, Debug)]
pub struct ExtractArgs {
    /// The lake's directory.
    #[arg(value_name = "DIR")]
    pub lake: PathBuf,
    /// Which rows: SQL over the `measured` table's columns, e.g. "device = 'dx55-2' AND session LIKE 'case%'" (quote "window" and "U95").
    #[arg(long = "where", value_name = "SQL")]
    pub predicate: Option<String>,
    /// The measured-values file to write (CSV).
    #[arg(short = 'o', long = "output", value_name = "FILE.csv")]
    pub output: PathBuf,
}

#[derive(Args, Debug)]
pub struct QueryArgs {
    /// The lake's directory.
    #[arg(value_name = "DIR")]
    pub lake: PathBuf,
    /// The query, e.g. "SELECT sensor, avg(value) FROM samples WHERE device = 'dx55-2' GROUP BY sensor".
    #[arg(value_name = "SQL")]
    pub sql: String,
    /// Write the rows here (CSV, or Parquet for `.parquet`; whole or not at all) instead of CSV on stdout.
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: Option<PathBuf>,
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
        LakeCommand::Query(args) => run_query(args),
        LakeCommand::Extract(args) => run_extract(args),
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
                    "ingested again, its earlier files replaced"
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

fn run_query(args: QueryArgs) -> Result<()> {
    let runtime = acq_acquire::runtime(2)?;
    let Some(path) = args.output.as_deref().filter(|p| p.as_os_str() != "-") else {
        let mut out = std::io::BufWriter::new(std::io::stdout().lock());
        runtime.block_on(query::query(&args.lake, &args.sql, Sink::Csv(&mut out)))?;
        return out
            .flush()
            .map_err(|e| AcqError::io("writing to stdout", e));
    };
    let format = TableFormat::of(path);
    if format == TableFormat::Mf4 {
        return Err(AcqError::Config(format!(
            "{}: a query's rows go to CSV or Parquet (.csv, .parquet), not MF4",
            path.display()
        )));
    }
    let mut file = CompleteOnlyFile::create(path, "a query's rows")?;
    let rows = {
        let mut out = std::io::BufWriter::new(file.file());
        let sink = match format {
            TableFormat::Parquet => Sink::Parquet(&mut out),
            _ => Sink::Csv(&mut out),
        };
        let rows = runtime.block_on(query::query(&args.lake, &args.sql, sink))?;
        out.flush()
            .map_err(|e| AcqError::io(format!("writing {}", path.display()), e))?;
        rows
    };
    file.finish()?;
    eprintln!("acq lake: {rows} row(s) written to {}", path.display());
    Ok(())
}

fn run_extract(args: ExtractArgs) -> Result<()> {
    let path = args.output.as_path();
    if TableFormat::of(path) != TableFormat::Csv || path.as_os_str() == "-" {
        return Err(AcqError::Config(format!(
            "{}: acq lake extract writes a measured-values CSV file (FILE.csv), as acq extract does",
            path.display()
        )));
    }
    let runtime = acq_acquire::runtime(2)?;
    let mut file = CompleteOnlyFile::create(path, "the measured values")?;
    let rows = {
        let mut out = std::io::BufWriter::new(file.file());
        let rows = runtime.block_on(query::extract(
            &args.lake,
            args.predicate.as_deref(),
            Sink::Csv(&mut out),
        ))?;
        out.flush()
            .map_err(|e| AcqError::io(format!("writing {}", path.display()), e))?;
        rows
    };
    file.finish()?;
    eprintln!(
        "acq lake: {rows} measured value(s) written to {}",
        path.display()
    );
    Ok(())
}
