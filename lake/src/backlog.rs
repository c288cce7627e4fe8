//! `acq lake ingest --slurm`: a backlog too large for one machine as
//! Slurm jobs, each an ordinary ingest of a slice of the sources.
//!
//! The sources are dealt into slices of about equal bytes (largest first,
//! each to the lightest slice), and each slice runs as one job of acq's
//! Slurm executor: `acq lake ingest --list <slice>/inputs.txt` on a
//! compute node, into the same lake. That is safe because an ingest only
//! ever touches its own sources' files and entries (named by the source's
//! id, one slice per source), writes in a scratch directory of its own
//! process and publishes by rename; so the jobs need nothing from each
//! other, and the lake they leave is the one a single ingest of the whole
//! backlog leaves.
//!
//! Resumable: a slice's directory is named by its inputs, the rig and the
//! device, so the same command again finds the same directories. A job
//! still queued or running there is re-attached (not submitted twice); a
//! finished one is run again, and its ingest skips every source already
//! in the lake with the same content, so only what failed or changed is
//! decoded. The executor cancels the jobs on Ctrl-C.

use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Duration;

use acq_error::{AcqError, Result};
use acq_exec::executor::{Executor, Job};
use acq_exec::slurm::{forget_finished_job, SlurmExecutor, SlurmSettings};
use acq_io::output::Output;
use acq_rig::BusMapping;
use sha2::{Digest, Sha256};

use crate::ingest::{canonical_buses, device_of, IngestOptions};
use crate::layout::SLURM_DIR;

/// How the backlog runs on the cluster.
#[derive(Clone, Debug)]
pub struct SlurmIngest {
    /// Jobs (slices of the sources); fewer when there are fewer sources.
    pub slices: usize,
    /// Partition, account, time limit, cpus per job (each job's `--jobs`)
    /// as for a study's `[executor]`.
    pub settings: SlurmSettings,
    /// acq's own wait for a job before it cancels it.
    pub timeout: Duration,
    /// The acq binary the jobs run (this one; compute nodes must see it
    /// at the same path, as they see the lake and the sources).
    pub acq: PathBuf,
}

/// How one slice's job went.
#[derive(Clone, Debug)]
pub struct SliceReport {
    /// Its directory under `_slurm/`: the job script, the list of its
    /// sources, the ingest's stdout and stderr.
    pub directory: PathBuf,
    pub sources: usize,
    pub bytes: u64,
    /// `Err`: why the job failed (the ingest's exit status and the end of
    /// its stderr, or the cluster's verdict).
    pub outcome: std::result::Result<(), String>,
    /// The executor's notes: job id, queue wait, run time.
    pub notes: Vec<(String, String)>,
}

/// Ingests `inputs` as Slurm jobs, calling `on_slice` as each job ends;
/// `Err` before any job is submitted (a missing source, no Slurm).
pub fn ingest_on_slurm(
    inputs: &[PathBuf],
    options: &IngestOptions,
    slurm: &SlurmIngest,
    on_slice: impl FnMut(&SliceReport) + Send,
) -> Result<Vec<SliceReport>> {
    let sized = sized_sources(inputs)?;
    let executor = SlurmExecutor::new(slurm.settings.clone())
        .map_err(|e| AcqError::Config(format!("--slurm: {e}")))?;
    let lake = &options.lake;
    acq_io::output::create_dir(lake)?;
    let lake = std::fs::canonicalize(lake)
        .map_err(|e| AcqError::io(format!("opening the lake {}", lake.display()), e))?;
    let rig = std::fs::canonicalize(&options.rig)
        .map_err(|e| AcqError::io(format!("opening the rig {}", options.rig.display()), e))?;
    let device = device_of(options);
    let buses = canonical_buses(&options.buses, inputs)?;
    let jobs_per_slice = slurm.settings.cpus_per_job.unwrap_or(1).max(1);

    let mut slices = Vec::new();
    for slice in deal(sized, slurm.slices) {
        let list: String = slice
            .iter()
            .map(|(path, _)| format!("{}\n", path.display()))
            .collect();
        // A scope none of the slice's sources is under is not the job's.
        let buses: Vec<&BusMapping> = buses
            .iter()
            .filter(|m| m.files.is_none() || slice.iter().any(|(path, _)| m.covers(path)))
            .collect();
        let key = format!("{list}{}\n{device}\n{buses:?}\n", rig.display());
        let digest = Sha256::digest(key.as_bytes());
        let name: String = digest[..8].iter().map(|b| format!("{b:02x}")).collect();
        let directory = lake.join(SLURM_DIR).join(name);
        acq_io::output::create_dir(&directory)?;
        let list_file = directory.join("inputs.txt");
        Output::write_complete(&list_file, list.as_bytes())?;
        forget_finished_job(&directory);
        let mut argv: Vec<String> = [
            slurm.acq.display().to_string(),
            "lake".into(),
            "ingest".into(),
            "--list".into(),
            list_file.display().to_string(),
            "--rig".into(),
            rig.display().to_string(),
            "--lake".into(),
            lake.display().to_string(),
            "--device".into(),
            device.clone(),
            "--jobs".into(),
            jobs_per_slice.to_string(),
        ]
        .into();
        // Scopes canonical: the job's list names its sources so.
        for mapping in buses {
            argv.extend(["--bus".to_string(), mapping.to_string()]);
        }
        let bytes = slice.iter().map(|(_, bytes)| bytes).sum();
        slices.push((directory, argv, slice.len(), bytes));
    }

    let on_slice = Mutex::new(on_slice);
    let reports = std::thread::scope(|scope| {
        let running: Vec<_> = slices
            .iter()
            .map(|(directory, argv, sources, bytes)| {
                let (executor, on_slice) = (&executor, &on_slice);
                scope.spawn(move || {
                    let execution = executor.execute(&Job {
                        argv,
                        directory,
                        timeout: slurm.timeout,
                    });
                    let report = SliceReport {
                        directory: directory.clone(),
                        sources: *sources,
                        bytes: *bytes,
                        outcome: execution.outcome,
                        notes: executor
                            .note_columns()
                            .iter()
                            .cloned()
                            .zip(execution.notes)
                            .collect(),
                    };
                    (on_slice.lock().unwrap_or_else(|e| e.into_inner()))(&report);
                    report
                })
            })
            .collect();
        running
            .into_iter()
            .map(|job| job.join().expect("a slice's thread does not panic"))
            .collect()
    });
    Ok(reports)
}

/// Each distinct source with its size in bytes (a session's: its files'),
/// or an error naming every input that is not there.
fn sized_sources(inputs: &[PathBuf]) -> Result<Vec<(PathBuf, u64)>> {
    let mut missing = Vec::new();
    let mut sized: Vec<(PathBuf, u64)> = Vec::new();
    for input in inputs {
        let Ok(path) = std::fs::canonicalize(input) else {
            missing.push(input.display().to_string());
            continue;
        };
        let bytes = if path.is_dir() {
            std::fs::read_dir(&path).map_or(0, |listing| {
                listing
                    .flatten()
                    .filter_map(|item| item.metadata().ok())
                    .filter(std::fs::Metadata::is_file)
                    .map(|metadata| metadata.len())
                    .sum()
            })
        } else {
            std::fs::metadata(&path).map_or(0, |metadata| metadata.len())
        };
        sized.push((path, bytes));
    }
    if !missing.is_empty() {
        return Err(AcqError::Config(format!(
            "no such session directory or log file: {} (nothing submitted)",
            missing.join(", ")
        )));
    }
    sized.sort();
    sized.dedup_by(|a, b| a.0 == b.0);
    Ok(sized)
}

/// The sources dealt into at most `slices` slices of about equal bytes,
/// largest first, each to the slice with the fewest bytes so far (ties:
/// the first); every slice sorted by path, so the same backlog always
/// gives the same slices.
fn deal(mut sized: Vec<(PathBuf, u64)>, slices: usize) -> Vec<Vec<(PathBuf, u64)>> {
    let slices = slices.clamp(1, sized.len().max(1));
    sized.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    let mut dealt: Vec<(u64, Vec<(PathBuf, u64)>)> = vec![(0, Vec::new()); slices];
    for source in sized {
        let lightest = dealt
            .iter_mut()
            .min_by_key(|(bytes, _)| *bytes)
            .expect("at least one slice");
        lightest.0 += source.1;
        lightest.1.push(source);
    }
    dealt
        .into_iter()
        .map(|(_, mut slice)| {
            slice.sort();
            slice
        })
        .filter(|slice| !slice.is_empty())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_backlog_is_dealt_into_slices_of_about_equal_bytes() {
        let sized: Vec<(PathBuf, u64)> = [9, 7, 6, 5, 4, 3, 2]
            .iter()
            .enumerate()
            .map(|(i, &bytes)| (PathBuf::from(format!("/logs/{i}.mf4")), bytes))
            .collect();
        let slices = deal(sized.clone(), 3);
        let totals: Vec<u64> = slices
            .iter()
            .map(|s| s.iter().map(|(_, b)| b).sum())
            .collect();
        // 9, 7, 6 open the slices; 5 joins 6, 4 joins 7, 3 joins 9, 2 the
        // first of the two at 11.
        assert_eq!(totals, vec![12, 13, 11]);
        let mut all: Vec<_> = slices.concat();
        all.sort();
        assert_eq!(all, sized);
        assert_eq!(
            deal(sized.clone(), 3),
            slices,
            "the same backlog, the same slices"
        );
        assert_eq!(deal(sized.clone(), 50).len(), 7, "no empty slice");
        assert_eq!(deal(Vec::new(), 4).len(), 0);
    }
}
