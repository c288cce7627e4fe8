//! The command-line glue of `acq lake`: a campaign's sessions and logger
//! files as one Parquet dataset.

use std::path::PathBuf;

use acq_error::{AcqError, Result};
use std::io::Write;

use acq_exec::slurm::SlurmSettings;
use acq_io::output::{CompleteOnlyFile, TableFormat};
use acq_lake::backlog::{self, SlurmIngest};
use acq_lake::ingest::{self, IngestOptions, Outcome};
use acq_lake::query::{self, Sink};
use acq_rig::BusMapping;
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
    #[arg(value_name = "INPUT", required_unless_present = "list")]
    pub inputs: Vec<PathBuf>,
    /// More inputs, one path a line (a backlog listed by `find`); blank
    /// lines and lines starting with # are skipped.
    #[arg(long, value_name = "FILE")]
    pub list: Option<PathBuf>,
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
    /// Frames logged on LOGGED are the rig's bus on interface RIG (a
    /// logger's `can1` as the rig's `can0`), in every log given; repeat for
    /// each bus. With FILES: (a file, or a folder of one logger's files)
    /// only in those logs, so that two loggers that both log `can1` stay
    /// apart: `--bus logger_a:can1=can0 --bus logger_b:can1=can2`.
    /// Sessions know their interfaces and take none.
    #[arg(long = "bus", value_name = "[FILES:]LOGGED=RIG", value_parser = clap::value_parser!(BusMapping))]
    pub buses: Vec<BusMapping>,
    /// Sources decoded at once on this machine [default: one per core];
    /// with --slurm, in each job (its cpus).
    #[arg(long, value_name = "N")]
    pub jobs: Option<usize>,
    /// Run the ingest as Slurm jobs, each a slice of the inputs, from a
    /// login node whose compute nodes see the inputs, the lake and this
    /// acq at the same paths. The same command again resumes: running
    /// jobs are re-attached, sources already in the lake skipped.
    #[arg(long)]
    pub slurm: bool,
    /// With --slurm: the number of jobs (slices of about equal bytes).
    #[arg(long, value_name = "N", default_value_t = 16, requires = "slurm")]
    pub slices: usize,
    /// With --slurm: the partition to submit to.
    #[arg(long, value_name = "NAME", requires = "slurm")]
    pub partition: Option<String>,
    /// With --slurm: the account to charge.
    #[arg(long, value_name = "NAME", requires = "slurm")]
    pub account: Option<String>,
    /// With --slurm: each job's time limit in minutes; acq cancels a job
    /// that runs longer.
    #[arg(long, value_name = "MINUTES", default_value_t = 24 * 60, requires = "slurm")]
    pub time_limit: u64,
}

pub fn run_lake(command: LakeCommand) -> Result<()> {
    match command {
        LakeCommand::Ingest(args) => run_ingest(args),
        LakeCommand::Query(args) => run_query(args),
        LakeCommand::Extract(args) => run_extract(args),
    }
}

fn run_ingest(args: IngestArgs) -> Result<()> {
    let mut inputs = args.inputs.clone();
    if let Some(list) = &args.list {
        inputs.extend(read_list(list)?);
    }
    let options = IngestOptions {
        lake: args.lake.clone(),
        rig: args.rig.clone(),
        device: args.device.clone(),
        buses: args.buses.clone(),
        jobs: args.jobs.unwrap_or(0),
    };
    if args.slurm {
        return run_ingest_on_slurm(&inputs, &options, &args);
    }
    let started = std::time::Instant::now();
    let reports = ingest::ingest(&inputs, &options, |report| {
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
    if failed == reports.len() {
        return Err(AcqError::Config(format!(
            "none of the {failed} source(s) ingested (each said above)"
        )));
    }
    if failed > 0 {
        return Err(AcqError::Config(format!(
            "{failed} of {} source(s) not ingested (each said above); the others are in the lake",
            reports.len()
        )));
    }
    Ok(())
}

fn run_ingest_on_slurm(
    inputs: &[PathBuf],
    options: &IngestOptions,
    args: &IngestArgs,
) -> Result<()> {
    let slurm = SlurmIngest {
        slices: args.slices,
        settings: SlurmSettings {
            partition: args.partition.clone(),
            account: args.account.clone(),
            cpus_per_job: Some(args.jobs.unwrap_or(1).max(1) as u32),
            ..SlurmSettings::default()
        },
        timeout: std::time::Duration::from_secs(args.time_limit.saturating_mul(60)),
        acq: std::env::current_exe()
            .map_err(|e| AcqError::io("finding acq's own binary for the jobs".to_string(), e))?,
    };
    let started = std::time::Instant::now();
    let reports = backlog::ingest_on_slurm(inputs, options, &slurm, |slice| {
        let notes: Vec<String> = slice
            .notes
            .iter()
            .filter(|(_, value)| !value.is_empty())
            .map(|(name, value)| format!("{name} {value}"))
            .collect();
        let what = format!(
            "acq lake: slice {} ({} source(s), {:.1} MB; {})",
            slice.directory.display(),
            slice.sources,
            slice.bytes as f64 / 1e6,
            notes.join(", ")
        );
        match &slice.outcome {
            Ok(()) => eprintln!("{what}: done"),
            Err(why) => eprintln!("{what}: failed: {why}"),
        }
    })?;
    let failed = reports.iter().filter(|r| r.outcome.is_err()).count();
    eprintln!(
        "acq lake: {} job(s): {} done, {failed} failed, in {:.1} s",
        reports.len(),
        reports.len() - failed,
        started.elapsed().as_secs_f64()
    );
    println!("lake: {}", options.lake.display());
    if failed > 0 {
        return Err(AcqError::Config(format!(
            "{failed} of {} job(s) failed (each said above, its output in its directory); \
             the same command again runs them again and skips what is in the lake",
            reports.len()
        )));
    }
    Ok(())
}

/// The paths of a list file, relative ones taken from the list's
/// directory.
fn read_list(list: &std::path::Path) -> Result<Vec<PathBuf>> {
    let text = std::fs::read_to_string(list)
        .map_err(|e| AcqError::io(format!("reading the list {}", list.display()), e))?;
    let base = list.parent().unwrap_or(std::path::Path::new("."));
    Ok(text
        .lines()
        .map(str::trim)
        .filter(|line| !line.is_empty() && !line.starts_with('#'))
        .map(|line| base.join(line))
        .collect())
}

fn run_query(args: QueryArgs) -> Result<()> {
    let Some(path) = args.output.as_deref().filter(|p| p.as_os_str() != "-") else {
        let mut out = std::io::BufWriter::new(std::io::stdout().lock());
        query::query(&args.lake, &args.sql, Sink::Csv(&mut out))?;
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
        let rows = query::query(&args.lake, &args.sql, sink)?;
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
    let mut file = CompleteOnlyFile::create(path, "the measured values")?;
    let rows = {
        let mut out = std::io::BufWriter::new(file.file());
        let rows = query::extract(&args.lake, args.predicate.as_deref(), Sink::Csv(&mut out))?;
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
