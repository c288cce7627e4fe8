//! A recording as the rig's samples: a session directory (its raw files in
//! order, its start time, its copy of the rig) or a log file, decoded frame
//! by frame through the rig, each bus's clock offset removed so every sample
//! is on the reference clock.
//!
//! This is where the chain turns from frames into samples; everything
//! downstream (align, extract) sees only [`Sample`]s.
//!
//! - [`clocks`]: each bus's clock offset (given, or estimated by [`offset`]).
//! - [`zeroing`]: the session's zero record subtracted from every sample.

pub mod clocks;
pub mod offset;
pub mod zeroing;

use std::path::{Path, PathBuf};

use acq_can::{Frame, IfaceName};
use acq_error::{AcqError, Result};
use acq_io::input::{
    for_each_batch, for_each_record, open_log, open_session_log, BadLines, EmptyLogs, LogInput,
    ScanCounts,
};
use acq_io::session::{self, SessionFile};
use acq_io::shunt_record::{self, ShuntRecord};
use acq_io::zero_record::{self, ZeroRecord};
use acq_rig::sensors::{FrameUse, Sample, SensorDecoder, SensorEvent};
use acq_rig::Rig;

use zeroing::Zeroing;

/// A session directory or a log, with the rig that decodes it.
pub struct Recording {
    /// The path as given, for messages.
    pub label: String,
    pub logs: Vec<PathBuf>,
    pub session: Option<SessionFile>,
    pub rig: Rig,
    /// How the rig was matched to the recording (remapped interfaces).
    pub notes: Vec<String>,
    /// The session's zero record (`zero.toml`), if it was zeroed.
    pub zero: Option<ZeroRecord>,
    /// Its offsets, subtracted from every sample [`Recording::for_each_sample`] gives.
    pub zeroing: Zeroing,
    /// The session's shunt checks (`shunt.toml`), if any channel was checked.
    pub shunt: Option<ShuntRecord>,
    /// Their gains, per rig sensor: each value is multiplied by its
    /// channel's after the zero is subtracted.
    gains: Vec<Option<f64>>,
    /// Whether a pass has said that the raw log holds fewer frames than
    /// session.toml counts (said once, not once a pass).
    said_short: std::sync::atomic::AtomicBool,
}

impl Recording {
    /// Opens the session directory `path` with the rig it was recorded
    /// with, for a command that takes no rig of its own: a log (which
    /// carries none) is refused as not a session, without suggesting a
    /// `--rig` the command does not have.
    pub fn open_session(path: &Path) -> Result<Recording> {
        if !path.is_dir() {
            return Err(AcqError::Config(format!(
                "{}: not a session directory; give a directory acq record wrote (it keeps the rig the log was recorded with; a log alone has no rig)",
                path.display()
            )));
        }
        Recording::open(path, None)
    }

    /// Opens `path` (a session directory or a log). The rig is `rig_path`,
    /// else the session's own copy of the rig it was recorded with.
    pub fn open(path: &Path, rig_path: Option<&Path>) -> Result<Recording> {
        let label = path.display().to_string();
        let (logs, session) = if path.is_dir() {
            let session = session::read(path).map_err(|e| {
                AcqError::Config(format!(
                    "{label} is a directory but not a session ({e}); give a session directory written by acq record, or a log file"
                ))
            })?;
            let logs = session::raw_files(path)?;
            if logs.is_empty() {
                return Err(AcqError::Config(format!(
                    "session {label} has no raw.log; nothing to read"
                )));
            }
            (logs, Some(session))
        } else if path.is_file() || path.as_os_str() == "-" {
            (vec![path.to_path_buf()], None)
        } else {
            return Err(AcqError::Config(format!(
                "{label}: no such session directory or log file"
            )));
        };
        let rig_file = match (rig_path, &session) {
            (Some(rig), _) => rig.to_path_buf(),
            (None, Some(session)) => match &session.rig {
                // A path from session.toml stays inside the session.
                Some(copy) => acq_io::output::inside(
                    path,
                    &copy.file.copy,
                    &format!(
                        "{} [rig.file] copy",
                        path.join(session::SESSION_FILE).display()
                    ),
                )?,
                None => {
                    return Err(AcqError::Config(format!(
                        "session {label} was recorded without a rig; give one with --rig RIG.toml"
                    )))
                }
            },
            (None, None) => {
                return Err(AcqError::Config(
                    "a log carries no rig; give one with --rig RIG.toml".into(),
                ))
            }
        };
        // The session's own copy: unchanged since it was written, and every
        // file it names inside its folder.
        let copy = match (rig_path, &session) {
            (None, Some(session)) => session.rig.as_ref(),
            _ => None,
        };
        if let Some(copy) = copy {
            copy.check_unchanged(path)?;
        }
        let mut rig = Rig::load(&rig_file).map_err(|e| AcqError::Config(e.to_string()))?;
        if copy.is_some() {
            refuse_files_outside(&rig, &rig_file)?;
        }
        acq_io::input::note_rig_inputs(&rig);
        let mut notes = Vec::new();
        if let Some(session) = &session {
            let interfaces: Vec<IfaceName> = session
                .interface
                .iter()
                .filter_map(|i| IfaceName::new(&i.name))
                .collect();
            if !interfaces.is_empty() {
                notes = rig
                    .assign_interfaces(&interfaces)
                    .map_err(|e| AcqError::Config(format!("{}: {e}", rig_file.display())))?;
            }
        }
        let (zero, shunt) = match &session {
            Some(_) => (zero_record::read(path)?, shunt_record::read(path)?),
            None => (None, None),
        };
        let gains = rig
            .sensors
            .iter()
            .map(|s| Some(shunt.as_ref()?.sensor(&s.name)?.gain))
            .collect();
        let zeroing = zero
            .as_ref()
            .map(|record| Zeroing::new(&rig, record))
            .unwrap_or_default();
        Ok(Recording {
            label,
            logs,
            session,
            rig,
            notes,
            zero,
            zeroing,
            shunt,
            gains,
            said_short: std::sync::atomic::AtomicBool::new(false),
        })
    }

    /// The session's start, unix ns, when the recording is a session.
    pub fn session_start_unix_ns(&self) -> Option<i64> {
        self.session.as_ref().map(|s| s.session.started_unix_ns)
    }

    /// Index of the rig sensor called `name`, or a message listing them.
    pub fn sensor_index(&self, name: &str) -> Result<usize> {
        self.rig.sensor(name).map(|(i, _)| i).ok_or_else(|| {
            let names: Vec<&str> = self.rig.sensors.iter().map(|s| s.name.as_str()).collect();
            AcqError::Config(format!(
                "the rig has no sensor '{name}' (sensors: {})",
                names.join(", ")
            ))
        })
    }

    /// The error of a pass that decoded no sample of any rig sensor: the
    /// recording was most likely made on another rig.
    pub fn no_rig_sample(&self) -> AcqError {
        AcqError::Config(format!(
            "{}: no sample of any rig sensor in the recording; is it the right rig ({})?",
            self.label,
            self.rig.path.display()
        ))
    }

    /// Decodes every frame and calls `on_sample` with each sample, its time
    /// moved onto the reference clock (`t - clock_offset_ns[bus]`), its
    /// channel's zero subtracted when the session was zeroed, then its
    /// shunt check's gain applied when the channel was checked.
    pub fn for_each_sample(
        &self,
        clock_offset_ns: &[i64],
        counts: &mut SampleCounts,
        mut on_sample: impl FnMut(Sample) -> Result<()>,
    ) -> Result<()> {
        if self.zeroing.is_empty() && self.gains.iter().all(Option::is_none) {
            return self.for_each_raw_sample(clock_offset_ns, counts, on_sample);
        }
        self.for_each_raw_sample(clock_offset_ns, counts, |mut sample| {
            self.zero_and_gain(&mut sample);
            on_sample(sample)
        })
    }

    /// [`Recording::for_each_sample`], and after each frame's samples the
    /// frame itself (as logged, on its own bus's clock) with what it was
    /// to the rig: for a view of the raw frames beside the signals.
    pub fn for_each_event(
        &self,
        clock_offset_ns: &[i64],
        counts: &mut SampleCounts,
        mut on_event: impl FnMut(RecordingEvent<'_>) -> Result<()>,
    ) -> Result<()> {
        self.for_each_raw_event(clock_offset_ns, counts, |mut event| {
            if let RecordingEvent::Sample(sample) = &mut event {
                self.zero_and_gain(sample);
            }
            on_event(event)
        })
    }

    /// A sample's channel zero subtracted, then its shunt gain applied.
    fn zero_and_gain(&self, sample: &mut Sample) {
        self.zeroing.apply(sample);
        if let (Some(Some(gain)), Some(value)) =
            (self.gains.get(sample.sensor), sample.value.as_mut())
        {
            *value *= gain;
        }
    }

    /// [`Recording::for_each_sample`] without the zero and the gains: the
    /// values as the channels sent them (through the rig's conversion).
    /// The frames are read and decoded a batch at a time.
    pub fn for_each_raw_sample(
        &self,
        clock_offset_ns: &[i64],
        counts: &mut SampleCounts,
        mut on_sample: impl FnMut(Sample) -> Result<()>,
    ) -> Result<()> {
        let (mut inputs, empty_logs) = self.open_inputs()?;
        let mut decoder = SensorDecoder::new(&self.rig);
        let offset_ns = self.offsets_by_sensor(clock_offset_ns);
        let mut scan = ScanCounts::default();
        let mut failure = None;
        for_each_batch(
            &mut inputs,
            BadLines::Skip,
            empty_logs,
            &mut scan,
            |_, batch| {
                decoder.decode_batch(batch, |_, event| {
                    Self::pass_on(event, &offset_ns, counts, &mut failure, &mut on_sample);
                });
                failure.take().map_or(Ok(()), Err)
            },
        )?;
        self.end_pass(&scan, counts)
    }

    /// A decoded sample, on the reference clock and counted, to `on_sample`,
    /// unless an earlier one failed: the first failure is kept.
    #[inline]
    fn pass_on(
        event: SensorEvent,
        offset_ns_by_sensor: &[i64],
        counts: &mut SampleCounts,
        failure: &mut Option<AcqError>,
        on_sample: &mut impl FnMut(Sample) -> Result<()>,
    ) {
        if failure.is_some() {
            return;
        }
        if let SensorEvent::Sample(sample) = event {
            let sample = Self::on_reference_clock(sample, offset_ns_by_sensor, counts);
            if let Err(e) = on_sample(sample) {
                *failure = Some(e);
            }
        }
    }

    /// A pass's frame counts kept, and checked against the session's.
    fn end_pass(&self, scan: &ScanCounts, counts: &mut SampleCounts) -> Result<()> {
        counts.frames = scan.frames;
        counts.malformed_lines = scan.malformed_lines;
        self.check_frame_count(scan)
    }

    /// The recording's logs opened, and whether one may give no frame: a
    /// session's quiet bus leaves an empty raw log, a log the user named
    /// must give frames. A session's raw files are candump, as acq record
    /// wrote them: read as such, not guessed from their first bytes.
    fn open_inputs(&self) -> Result<(Vec<LogInput>, EmptyLogs)> {
        let inputs = self
            .logs
            .iter()
            .map(|p| match self.session {
                Some(_) => open_session_log(p),
                None => open_log(p),
            })
            .collect::<Result<Vec<_>>>()?;
        let empty_logs = match self.session {
            Some(_) => EmptyLogs::Allow,
            None => EmptyLogs::Refuse,
        };
        Ok((inputs, empty_logs))
    }

    /// Each sensor's bus's clock offset (`clock_offset_ns[bus]`, 0 where
    /// none is given): looked up per sample by sensor, as the rig's sensor
    /// records are too large to read for every sample.
    fn offsets_by_sensor(&self, clock_offset_ns: &[i64]) -> Vec<i64> {
        self.rig
            .sensors
            .iter()
            .map(|s| clock_offset_ns.get(s.bus).copied().unwrap_or(0))
            .collect()
    }

    /// A decoded sample on the reference clock, counted.
    #[inline]
    fn on_reference_clock(
        mut sample: Sample,
        offset_ns_by_sensor: &[i64],
        counts: &mut SampleCounts,
    ) -> Sample {
        sample.time_ns -= offset_ns_by_sensor[sample.sensor];
        counts.samples += 1;
        if sample.value.is_none() {
            counts.missing_values += 1;
        }
        sample
    }

    fn for_each_raw_event(
        &self,
        clock_offset_ns: &[i64],
        counts: &mut SampleCounts,
        mut on_event: impl FnMut(RecordingEvent<'_>) -> Result<()>,
    ) -> Result<()> {
        let (mut inputs, empty_logs) = self.open_inputs()?;
        let mut decoder = SensorDecoder::new(&self.rig);
        let offset_ns = self.offsets_by_sensor(clock_offset_ns);
        let mut scan = ScanCounts::default();
        let mut failure = None;
        // A recording cut by a crash can end in half a line: count, go on.
        for_each_record(
            &mut inputs,
            BadLines::Skip,
            empty_logs,
            &mut scan,
            |_, record| {
                let mut on_sample = |sample| on_event(RecordingEvent::Sample(sample));
                let used = decoder.decode(&record.frame, |event| {
                    Self::pass_on(event, &offset_ns, counts, &mut failure, &mut on_sample);
                });
                if failure.is_none() {
                    if let Err(e) = on_event(RecordingEvent::Frame(&record.frame, used)) {
                        failure = Some(e);
                    }
                }
                failure.take().map_or(Ok(()), Err)
            },
        )?;
        self.end_pass(&scan, counts)
    }

    /// A session's raw log against the frames its session.toml counts: a
    /// log with none of them is refused (it was emptied or replaced, and
    /// would show an empty recording); one with fewer is said, once.
    fn check_frame_count(&self, scan: &ScanCounts) -> Result<()> {
        let Some(session) = &self.session else {
            return Ok(());
        };
        let counted = session.session.frames;
        if scan.frames >= counted {
            return Ok(());
        }
        let unread = if scan.malformed_lines > 0 {
            format!(
                " ({} line(s) could not be read as candump)",
                scan.malformed_lines
            )
        } else {
            String::new()
        };
        if scan.frames == 0 {
            return Err(AcqError::Malformed(format!(
                "session {}: its raw log holds no frame where session.toml counts {counted}{unread}: the log was emptied or replaced after recording; restore raw.log from a copy of the session",
                self.label
            )));
        }
        if !self
            .said_short
            .swap(true, std::sync::atomic::Ordering::Relaxed)
        {
            eprintln!(
                "acq: warning: session {}: its raw log holds {} frames where session.toml counts {counted}{unread}: the log was cut after recording; what follows reads the frames it holds",
                self.label, scan.frames
            );
        }
        Ok(())
    }
}

/// What a pass over a recording gives, in recording order: a frame's
/// samples, then the frame.
#[derive(Clone, Copy, Debug)]
pub enum RecordingEvent<'a> {
    Sample(Sample),
    /// A frame as logged (its own bus's clock), and what it was to the rig.
    Frame(&'a Frame, FrameUse),
}

/// What reading a recording saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SampleCounts {
    pub frames: u64,
    pub malformed_lines: u64,
    pub samples: u64,
    /// Samples the device marked as error / not available.
    pub missing_values: u64,
}

impl std::fmt::Display for SampleCounts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} frames, {} samples ({} marked missing by their device), {} malformed lines skipped",
            self.frames, self.samples, self.missing_values, self.malformed_lines
        )
    }
}

/// A session's rig copy names its DBC and sensor files beside it (the
/// recorder wrote them there): a path that leads out of its folder was put
/// there by hand and is refused, naming the rig file.
fn refuse_files_outside(rig: &Rig, rig_file: &Path) -> Result<()> {
    let folder = rig_file.parent().unwrap_or(Path::new("."));
    let named = rig
        .buses
        .iter()
        .flat_map(|bus| bus.dbc_files.iter())
        .chain(rig.sensor_file.iter());
    for file in named {
        let beside = file.strip_prefix(folder).is_ok_and(|rest| {
            rest.components()
                .all(|c| matches!(c, std::path::Component::Normal(_)))
        });
        if !beside {
            return Err(AcqError::Config(format!(
                "{}: names {}, outside the session's rig folder; a session's rig copy names only the files copied beside it: restore the copy, or give the rig to use with --rig RIG.toml",
                rig_file.display(),
                file.display()
            )));
        }
    }
    Ok(())
}
