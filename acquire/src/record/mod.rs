//! `acq record`: every frame from one or more interfaces into a session
//! directory, with live status, until a signal, a duration, or the sources end.
//!
//! One tokio task per interface reads batches and hands them over a channel
//! to the writer loop, which counts, decodes (for the status) and writes
//! `raw.log`. Nothing received before a stop is lost: on a stop each reader
//! drains what its queue held up to the moment of the signal, and the writer
//! writes and syncs everything before `session.toml` is completed.

pub mod live;
pub mod rawlog;
pub mod status;

use std::fs;
use std::future::Future;
use std::path::{Path, PathBuf};
use std::time::Duration;

use acq_can::canopen::nmt_start_frame;
use acq_can::{Frame, IfaceName};
use acq_rig::{Rig, SensorSource};
use tokio::sync::{mpsc, watch};
use tokio::time::{interval, MissedTickBehavior};

use crate::bus::{now_ns, Bus, BusError, FrameSink, FrameSource, OpenError, RxInfo, MAX_BATCH};
use acq_error::{AcqError, Result};
use acq_io::session::{
    self, CopiedFile, InterfaceRecord, Outage, RigCopy, SessionFile, SessionInfo,
};
use live::Liveness;
use rawlog::RawLog;
use status::{BusStatus, SensorStatus, Status, StatusDisplay, StatusMode};

/// Raw lines reach the operating system at least this often.
pub const FLUSH_PERIOD: Duration = Duration::from_millis(100);
/// ... and the disk (fdatasync) this often.
const SYNC_EVERY_FLUSHES: u32 = 10;
const STATUS_PERIOD: Duration = Duration::from_millis(500);
/// `session.toml` is refreshed this often while recording.
const SESSION_REFRESH_FLUSHES: u32 = 50;
/// A reader that found fewer than MAX_BATCH / 4 frames waits this long
/// before reading again, so a steady stream costs a few wake-ups per
/// second instead of one per frame; a full batch is read again at once.
const COALESCE: Duration = Duration::from_millis(5);
const REOPEN_PERIOD: Duration = Duration::from_millis(250);
/// The file that holds disk space for the final `session.toml`.
const SPACE_RESERVE: &str = ".space-reserve";
const SPACE_RESERVE_BYTES: usize = 256 << 10;
/// After a stop, a reader that sees no frame for this long is drained.
const DRAIN_QUIET: Duration = Duration::from_millis(50);

/// What `acq record` was asked to do.
pub struct RecordOptions {
    pub interfaces: Vec<IfaceName>,
    pub rig: Option<Rig>,
    pub session_dir: PathBuf,
    pub max_file_bytes: u64,
    pub nmt_start: bool,
    pub status: StatusMode,
    pub command_line: String,
    /// Remarks to keep in `session.toml` (e.g. how rig buses were assigned).
    pub notes: Vec<String>,
    /// Who watches the recording as it happens (the live view), if anyone.
    pub observer: Option<Box<dyn RecordObserver>>,
    /// Lines from elsewhere (a study at the rig) to print above the status
    /// table at its next redraw, so the table does not overdraw them.
    pub messages: Option<std::sync::Mutex<std::sync::mpsc::Receiver<String>>>,
}

/// Watches a recording: every batch of frames as it is written, and every
/// status. The recorder calls it inline, so it must never block or wait:
/// a watcher that cannot keep up drops what it cannot take (and says so),
/// never the recorder.
pub trait RecordObserver: Send + Sync {
    /// The session exists: its start time is the origin of session seconds.
    fn started(&mut self, session: &SessionFile);
    /// Frames received on interface `bus` (index into the recorded
    /// interfaces), in the order they are written to `raw.log`.
    fn frames(&mut self, bus: usize, frames: &[Frame], arrival_ns: i64);
    /// The status the terminal shows, about twice a second.
    fn status(&mut self, status: &Status);
    /// The recording ended; `session.toml` is complete.
    fn finished(&mut self, session: &SessionFile);
}

/// Why a recording stopped.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StopReason {
    Signal(&'static str),
    /// Stopped by its caller for the reason given (e.g. "replay finished").
    Requested(&'static str),
    Duration,
    /// Every source ended (log-file sources).
    SourcesEnded,
    /// Writing failed (disk full): the message says what happened.
    WriteFailed(String),
}

impl StopReason {
    fn describe(&self) -> String {
        match self {
            StopReason::Signal(name) => format!("signal {name}"),
            StopReason::Requested(reason) => reason.to_string(),
            StopReason::Duration => "duration reached".into(),
            StopReason::SourcesEnded => "all sources ended".into(),
            StopReason::WriteFailed(message) => format!("write failed: {message}"),
        }
    }
}

/// What a finished recording reports.
#[derive(Debug)]
pub struct RecordSummary {
    pub session_dir: PathBuf,
    pub session: SessionFile,
    pub stop: StopReason,
}

enum Event {
    Frames {
        bus: usize,
        frames: Vec<Frame>,
        info: RxInfo,
    },
    Down {
        bus: usize,
        at_ns: i64,
        reason: String,
    },
    Up {
        bus: usize,
        at_ns: i64,
    },
    Failed {
        bus: usize,
        error: String,
    },
}

/// Opens every interface, then records until `stop` resolves (or the
/// sources end, or writing fails).
pub async fn record<B: Bus>(
    bus: B,
    mut options: RecordOptions,
    stop: impl Future<Output = StopReason>,
) -> Result<RecordSummary> {
    // Open everything first: a missing interface fails before any file exists.
    let mut sources = Vec::new();
    for &iface in &options.interfaces {
        sources.push(bus.open_source(iface).map_err(open_error)?);
    }
    let observer = options.observer.take();
    let timestamp_sources: Vec<&'static str> = sources
        .iter()
        .map(|source| source.timestamp_source())
        .collect();
    let (stop_tx, stop_rx) = watch::channel::<Option<i64>>(None);
    let mut recorder = Recorder::start(&options, &timestamp_sources, observer, stop_tx)?;

    let (events_tx, mut events) = mpsc::channel::<Event>(1024);
    for (index, source) in sources.into_iter().enumerate() {
        let iface = options.interfaces[index];
        tokio::spawn(read_interface(
            bus.clone(),
            iface,
            index,
            source,
            events_tx.clone(),
            stop_rx.clone(),
        ));
    }
    drop(events_tx);

    recorder.observe_start();
    if options.nmt_start {
        send_nmt_start(&bus, &options, &mut recorder.display).await;
    }
    let mut flush_tick = interval(FLUSH_PERIOD);
    flush_tick.set_missed_tick_behavior(MissedTickBehavior::Delay);
    let mut status_tick = interval(STATUS_PERIOD);
    status_tick.set_missed_tick_behavior(MissedTickBehavior::Delay);
    tokio::pin!(stop);
    loop {
        tokio::select! {
            // Timers before frames: under a flood the flush (every 100 ms)
            // and the status must still run.
            biased;
            reason = &mut stop, if recorder.stop_reason.is_none() => recorder.stop(reason),
            _ = flush_tick.tick() => recorder.flush_tick(),
            _ = status_tick.tick() => recorder.status_tick(),
            event = events.recv() => {
                let Some(event) = event else { break };
                recorder.on_event(event)?;
            }
        }
    }
    recorder.finish()
}

/// The recording's state between the reader tasks and the files: the
/// session being described, the raw log, what each bus did, the status.
struct Recorder<'a> {
    options: &'a RecordOptions,
    dir: &'a Path,
    session: SessionFile,
    raw: RawLog,
    /// The file that keeps room for the final `session.toml`.
    reserve: PathBuf,
    display: StatusDisplay,
    observer: Option<Box<dyn RecordObserver>>,
    /// Each sensor's last value and silence, with a rig.
    liveness: Option<Liveness<'a>>,
    buses: Vec<BusState>,
    started_ns: i64,
    last_status_ns: i64,
    flushes: u32,
    /// Tells the readers the time of the stop, so they drain and end.
    stop_tx: watch::Sender<Option<i64>>,
    stop_reason: Option<StopReason>,
}

/// What the status shows of one bus besides its session record.
struct BusState {
    up: bool,
    last_error: Option<String>,
    dropped_by_kernel: u64,
    frames_at_last_status: u64,
}

impl<'a> Recorder<'a> {
    /// The session directory with its `session.toml`, the reserve and an
    /// empty raw log.
    fn start(
        options: &'a RecordOptions,
        timestamp_sources: &[&'static str],
        observer: Option<Box<dyn RecordObserver>>,
        stop_tx: watch::Sender<Option<i64>>,
    ) -> Result<Self> {
        let dir = options.session_dir.as_path();
        prepare_dir(dir)?;
        // In the raw log's resolution (whole microseconds), so that a
        // frame's offset from the start is exactly what the log says.
        let started_ns = now_ns().div_euclid(1_000) * 1_000;
        let session = SessionFile {
            session: SessionInfo {
                format_version: session::FORMAT_VERSION,
                software: format!("acq {}", env!("CARGO_PKG_VERSION")),
                host: session::host_name(),
                command: options.command_line.clone(),
                started_utc: session::utc_text(started_ns),
                started_unix_ns: started_ns,
                ended: "recording".into(),
                raw_files: vec![rawlog::SINGLE_NAME.into()],
                notes: options.notes.clone(),
                ..Default::default()
            },
            interface: options
                .interfaces
                .iter()
                .zip(timestamp_sources)
                .map(|(iface, source)| InterfaceRecord::new(iface.as_str(), source))
                .collect(),
            rig: options
                .rig
                .as_ref()
                .map(|rig| copy_rig(rig, dir))
                .transpose()?,
            sensor: Vec::new(),
            source: Vec::new(),
        };
        // Room kept for the final session.toml: freed at the end, so a full
        // disk still gets a complete description of what was recorded.
        let reserve = dir.join(SPACE_RESERVE);
        acq_io::output::write_fresh(&reserve, &vec![0u8; SPACE_RESERVE_BYTES])
            .map_err(|e| AcqError::io(format!("creating {}", reserve.display()), e))?;
        let raw = RawLog::create(dir, options.max_file_bytes).map_err(|e| {
            AcqError::io(
                format!("creating {}", dir.join(rawlog::SINGLE_NAME).display()),
                e,
            )
        })?;
        write_session(dir, &session)?;
        Ok(Recorder {
            options,
            dir,
            session,
            raw,
            reserve,
            display: StatusDisplay::new(options.status),
            observer,
            liveness: options
                .rig
                .as_ref()
                .map(|rig| Liveness::new(rig, started_ns)),
            buses: options
                .interfaces
                .iter()
                .map(|_| BusState {
                    up: true,
                    last_error: None,
                    dropped_by_kernel: 0,
                    frames_at_last_status: 0,
                })
                .collect(),
            started_ns,
            last_status_ns: started_ns,
            flushes: 0,
            stop_tx,
            stop_reason: None,
        })
    }

    fn observe_start(&mut self) {
        if let Some(observer) = self.observer.as_mut() {
            observer.started(&self.session);
        }
    }

    /// The caller asked to stop: the readers drain what came before now.
    fn stop(&mut self, reason: StopReason) {
        let at_ns = now_ns();
        let _ = self.stop_tx.send(Some(at_ns));
        self.session.session.stop_requested_unix_ns = Some(at_ns);
        self.stop_reason = Some(reason);
    }

    fn write_failed(&self) -> bool {
        matches!(self.stop_reason, Some(StopReason::WriteFailed(_)))
    }

    /// Raw lines to the operating system; now and then to the disk, and
    /// `session.toml` refreshed.
    fn flush_tick(&mut self) {
        self.flush_or_stop();
        self.flushes = self.flushes.wrapping_add(1);
        if self.flushes % SYNC_EVERY_FLUSHES == 0 && !self.write_failed() {
            let _ = self.raw.sync();
        }
        if self.flushes % SESSION_REFRESH_FLUSHES == 0 && self.stop_reason.is_none() {
            let _ = session::write(self.dir, &self.snapshot());
        }
    }

    fn flush_or_stop(&mut self) {
        flush_or_stop(
            &mut self.raw,
            &mut self.stop_reason,
            &self.stop_tx,
            &mut self.display,
        );
    }

    fn snapshot(&self) -> SessionFile {
        let dropped: Vec<u64> = self.buses.iter().map(|b| b.dropped_by_kernel).collect();
        snapshot(&self.session, &self.raw, &dropped, &self.liveness)
    }

    /// The status, to the terminal and the observer.
    fn status_tick(&mut self) {
        let now = now_ns();
        if let Some(live) = self.liveness.as_mut() {
            live.tick(now);
        }
        let interval_s = ((now - self.last_status_ns) as f64 * 1e-9).max(1e-3);
        self.last_status_ns = now;
        let status = Status {
            elapsed_s: (now - self.started_ns) as f64 * 1e-9,
            session_dir: self.dir.display().to_string(),
            frames: self.raw.frames,
            bytes_written: self.raw.bytes,
            buses: self
                .session
                .interface
                .iter()
                .zip(self.buses.iter_mut())
                .map(|(record, bus)| {
                    let rate = (record.frames - bus.frames_at_last_status) as f64 / interval_s;
                    bus.frames_at_last_status = record.frames;
                    BusStatus {
                        iface: record.name.clone(),
                        state: if bus.up { "up" } else { "down" },
                        frames_per_s: (rate * 10.0).round() / 10.0,
                        frames: record.frames,
                        dropped_by_kernel: bus.dropped_by_kernel,
                        error_frames: record.error_frames,
                        last_error: bus.last_error.clone(),
                    }
                })
                .collect(),
            sensors: self
                .liveness
                .as_ref()
                .map(|live| {
                    live.sensors
                        .iter()
                        .map(|s| SensorStatus {
                            name: s.name.clone(),
                            value: s.last_value,
                            unit: s.unit.clone(),
                            age_s: s.age_s(now).map(|a| (a * 1000.0).round() / 1000.0),
                            silent: s.silent,
                            reason: s.silent.then(|| s.silence_reason()),
                        })
                        .collect()
                })
                .unwrap_or_default(),
        };
        if let Some(messages) = &self.options.messages {
            let lines: Vec<String> = messages
                .lock()
                .map(|m| m.try_iter().collect())
                .unwrap_or_default();
            for line in lines {
                self.display.message(&line);
            }
        }
        self.display.show(&status);
        if let Some(observer) = self.observer.as_mut() {
            observer.status(&status);
        }
    }

    /// What a reader reported: frames to the raw log (and the observer),
    /// or its interface going down, coming back, or failing.
    fn on_event(&mut self, event: Event) -> Result<()> {
        let interfaces = &self.options.interfaces;
        match event {
            Event::Frames { bus, frames, info } => {
                let arrival_ns = now_ns();
                if let Some(observer) = self.observer.as_mut() {
                    observer.frames(bus, &frames, arrival_ns);
                }
                let record = &mut self.session.interface[bus];
                for frame in &frames {
                    if let Some(report) = record.count(frame) {
                        self.buses[bus].last_error = Some(report.describe());
                    }
                    if let Some(live) = self.liveness.as_mut() {
                        live.on_frame(frame, arrival_ns);
                    }
                    self.raw.push(frame);
                }
                if let Some(total) = info.dropped_total {
                    self.buses[bus].dropped_by_kernel = total;
                }
            }
            Event::Down { bus, at_ns, reason } => {
                self.buses[bus].up = false;
                self.session.interface[bus].outage.push(Outage {
                    down_unix_ns: at_ns,
                    up_unix_ns: None,
                    reason: reason.clone(),
                });
                self.display.message(&format!(
                    "{}: {reason}; recording goes on and resumes when it returns",
                    interfaces[bus]
                ));
                write_session(self.dir, &self.snapshot())?;
            }
            Event::Up { bus, at_ns } => {
                self.buses[bus].up = true;
                if let Some(outage) = self.session.interface[bus].outage.last_mut() {
                    outage.up_unix_ns = Some(at_ns);
                }
                self.display
                    .message(&format!("{}: back up, recording resumed", interfaces[bus]));
            }
            Event::Failed { bus, error } => {
                self.display
                    .message(&format!("{}: reader stopped: {error}", interfaces[bus]));
                self.session
                    .session
                    .notes
                    .push(format!("{}: reader stopped: {error}", interfaces[bus]));
            }
        }
        if self.raw.pending_bytes() > 4 << 20 {
            self.flush_or_stop();
        }
        Ok(())
    }

    /// Every reader has finished: write and sync the rest, and complete
    /// `session.toml`.
    fn finish(mut self) -> Result<RecordSummary> {
        let stop = self.stop_reason.clone().unwrap_or(StopReason::SourcesEnded);
        let mut final_stop = stop.clone();
        if !matches!(stop, StopReason::WriteFailed(_)) {
            if let Err(error) = self.raw.flush().and_then(|()| self.raw.sync()) {
                final_stop = StopReason::WriteFailed(error.to_string());
            }
        }
        if let StopReason::WriteFailed(_) = final_stop {
            let lost = self.raw.pending_lines();
            self.session.session.notes.push(format!(
                "{lost} frames received after the write failure could not be written"
            ));
        }
        let stopped_ns = now_ns();
        let mut finished = self.snapshot();
        finished.session.stopped_unix_ns = Some(stopped_ns);
        finished.session.stopped_utc = Some(session::utc_text(stopped_ns));
        finished.session.ended = final_stop.describe();
        if self.raw.clamped_timestamps > 0 {
            finished.session.notes.push(format!(
                "{} frames had timestamps before 1970 (a hardware clock counting from power-on) and were written with time 0",
                self.raw.clamped_timestamps
            ));
        }
        let _ = fs::remove_file(&self.reserve);
        write_session(self.dir, &finished)?;
        if let Some(observer) = self.observer.as_mut() {
            observer.finished(&finished);
        }
        Ok(RecordSummary {
            session_dir: self.dir.to_path_buf(),
            session: finished,
            stop: final_stop,
        })
    }
}

fn flush_or_stop(
    raw: &mut RawLog,
    stop_reason: &mut Option<StopReason>,
    stop_tx: &watch::Sender<Option<i64>>,
    display: &mut StatusDisplay,
) {
    if matches!(stop_reason, Some(StopReason::WriteFailed(_))) {
        return;
    }
    if let Err(error) = raw.flush() {
        let message = format!(
            "writing the raw log failed ({error}); stopping, everything written so far is intact"
        );
        display.message(&message);
        *stop_reason = Some(StopReason::WriteFailed(error.to_string()));
        let _ = stop_tx.send(Some(now_ns()));
    }
}

fn snapshot(
    session: &SessionFile,
    raw: &RawLog,
    dropped: &[u64],
    liveness: &Option<Liveness<'_>>,
) -> SessionFile {
    let mut copy = session.clone();
    copy.session.raw_files = raw.files().to_vec();
    copy.session.frames = raw.frames;
    for (record, &count) in copy.interface.iter_mut().zip(dropped) {
        record.dropped_by_kernel = count;
    }
    copy.session.dropped_by_kernel = dropped.iter().sum();
    copy.sensor = liveness.as_ref().map(|l| l.records()).unwrap_or_default();
    copy
}

fn write_session(dir: &Path, session: &SessionFile) -> Result<()> {
    session::write(dir, session).map_err(|e| {
        AcqError::io(
            format!("writing {}", dir.join(session::SESSION_FILE).display()),
            e,
        )
    })
}

/// One interface's reader: batches to the writer, reopening after the
/// interface went away, draining its queue after a stop.
async fn read_interface<B: Bus>(
    bus: B,
    iface: IfaceName,
    index: usize,
    mut source: B::Source,
    events: mpsc::Sender<Event>,
    mut stop: watch::Receiver<Option<i64>>,
) {
    loop {
        let mut frames = Vec::with_capacity(MAX_BATCH);
        let stopping = *stop.borrow();
        let received = match stopping {
            None => tokio::select! {
                received = source.recv_batch(&mut frames) => received,
                _ = stop.changed() => continue,
            },
            Some(_) => {
                match tokio::time::timeout(DRAIN_QUIET, source.recv_batch(&mut frames)).await {
                    Ok(received) => received,
                    Err(_) => return, // drained
                }
            }
        };
        match received {
            Ok(info) => {
                let full = frames.len() >= MAX_BATCH;
                let mut done = false;
                if let Some(stop_ns) = stopping {
                    // Frames stamped after the stop were not received before it.
                    if source.timestamp_source() != "hardware" {
                        let before = frames.len();
                        frames.retain(|f| f.timestamp_ns <= stop_ns);
                        done = frames.len() < before;
                    }
                }
                if !frames.is_empty()
                    && events
                        .send(Event::Frames {
                            bus: index,
                            frames,
                            info,
                        })
                        .await
                        .is_err()
                {
                    return;
                }
                if done {
                    return;
                }
                if !full && stopping.is_none() {
                    tokio::select! {
                        _ = tokio::time::sleep(COALESCE) => {}
                        _ = stop.changed() => {}
                    }
                }
            }
            Err(BusError::Closed) => return,
            Err(BusError::Down { .. }) => {
                let _ = events
                    .send(Event::Down {
                        bus: index,
                        at_ns: now_ns(),
                        reason: "interface went down or disappeared".into(),
                    })
                    .await;
                loop {
                    if stop.borrow().is_some() {
                        return;
                    }
                    tokio::select! {
                        _ = tokio::time::sleep(REOPEN_PERIOD) => {}
                        _ = stop.changed() => return,
                    }
                    if let Ok(reopened) = bus.open_source(iface) {
                        source = reopened;
                        let _ = events
                            .send(Event::Up {
                                bus: index,
                                at_ns: now_ns(),
                            })
                            .await;
                        break;
                    }
                }
            }
            Err(error) => {
                let _ = events
                    .send(Event::Failed {
                        bus: index,
                        error: error.to_string(),
                    })
                    .await;
                return;
            }
        }
    }
}

/// NMT "start all nodes" on every bus that has CANopen sensors (every
/// interface when there is no rig).
async fn send_nmt_start<B: Bus>(bus: &B, options: &RecordOptions, display: &mut StatusDisplay) {
    let targets: Vec<IfaceName> = match &options.rig {
        None => options.interfaces.clone(),
        Some(rig) => options
            .interfaces
            .iter()
            .copied()
            .filter(|iface| {
                rig.sensors.iter().any(|s| {
                    matches!(s.source, SensorSource::Canopen { .. })
                        && (rig.buses.len() == 1 || rig.buses[s.bus].iface == *iface)
                })
            })
            .collect(),
    };
    for iface in targets {
        let result = match bus.open_sink(iface) {
            Ok(mut sink) => sink
                .send(&nmt_start_frame(iface, 0))
                .await
                .map_err(|e| e.to_string()),
            Err(error) => Err(error.to_string()),
        };
        match result {
            Ok(()) => display.message(&format!("{iface}: sent NMT start (all nodes)")),
            Err(error) => display.message(&format!("{iface}: could not send NMT start: {error}")),
        }
    }
}

fn open_error(error: OpenError) -> AcqError {
    match error {
        OpenError::Io { iface, source } => AcqError::io(format!("opening {iface}"), source),
        other => AcqError::Config(other.to_string()),
    }
}

pub(crate) fn prepare_dir(dir: &Path) -> Result<()> {
    fs::create_dir_all(dir).map_err(|e| AcqError::io(format!("creating {}", dir.display()), e))?;
    if dir.join(rawlog::SINGLE_NAME).exists() || dir.join("raw.000.log").exists() {
        return Err(AcqError::Config(format!(
            "{} already holds a recording; choose another --out directory",
            dir.display()
        )));
    }
    Ok(())
}

/// Copies the rig, its DBC files and its sensor file into `DIR/rig/`,
/// rewriting their paths in the copy so that `--rig DIR/rig/NAME.toml`
/// works on its own.
pub(crate) fn copy_rig(rig: &Rig, dir: &Path) -> Result<RigCopy> {
    let rig_dir = dir.join("rig");
    fs::create_dir_all(&rig_dir)
        .map_err(|e| AcqError::io(format!("creating {}", rig_dir.display()), e))?;
    let read = |path: &Path| fs::read(path).map_err(|e| AcqError::open(path, e));
    let copy_beside = |path: &Path| -> Result<CopiedFile> {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let bytes = read(path)?;
        let copy = rig_dir.join(&name);
        acq_io::output::write_fresh(&copy, &bytes)
            .map_err(|e| AcqError::io(format!("writing {}", copy.display()), e))?;
        Ok(CopiedFile {
            source: path.display().to_string(),
            copy: format!("rig/{name}"),
            sha256: session::sha256_hex(&bytes),
            copy_sha256: None,
        })
    };
    let mut dbc = Vec::new();
    let mut seen = std::collections::BTreeSet::new();
    for bus in &rig.buses {
        for path in &bus.dbc_files {
            if seen.insert(path.file_name().map(|n| n.to_os_string())) {
                dbc.push(copy_beside(path)?);
            }
        }
    }
    let sensor_file = rig.sensor_file.as_deref().map(copy_beside).transpose()?;
    let bytes = read(&rig.path)?;
    let name = rig
        .path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "rig.toml".into());
    let text = String::from_utf8_lossy(&bytes);
    let rewritten = rewrite_dbc_paths(&text).unwrap_or_else(|| text.into_owned());
    let copy = rig_dir.join(&name);
    acq_io::output::write_fresh(&copy, rewritten.as_bytes())
        .map_err(|e| AcqError::io(format!("writing {}", copy.display()), e))?;
    Ok(RigCopy {
        name: rig.name.clone(),
        file: CopiedFile {
            source: rig.path.display().to_string(),
            copy: format!("rig/{name}"),
            sha256: session::sha256_hex(&bytes),
            copy_sha256: Some(session::sha256_hex(rewritten.as_bytes())),
        },
        dbc,
        sensor_file,
    })
}

/// The rig text with every `[[bus]] dbc` path and its `[rig] sensor_file`
/// reduced to its file name.
fn rewrite_dbc_paths(text: &str) -> Option<String> {
    let mut document: toml_edit::DocumentMut = text.parse().ok()?;
    let buses = document.get_mut("bus")?.as_array_of_tables_mut()?;
    for bus in buses.iter_mut() {
        let Some(item) = bus.get_mut("dbc") else {
            continue;
        };
        let base = |value: &toml_edit::Value| {
            value.as_str().map(|p| {
                Path::new(p)
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default()
            })
        };
        if let Some(value) = item.as_value_mut() {
            if let Some(array) = value.as_array_mut() {
                for element in array.iter_mut() {
                    if let Some(name) = base(element) {
                        *element = toml_edit::Value::from(name);
                    }
                }
            } else if let Some(name) = base(value) {
                *value = toml_edit::Value::from(name);
            }
        }
    }
    // The sensor file is copied beside the rig too.
    if let Some(value) = document
        .get_mut("rig")
        .and_then(|rig| rig.get_mut("sensor_file"))
        .and_then(|item| item.as_value_mut())
    {
        if let Some(name) = value
            .as_str()
            .and_then(|p| Path::new(p).file_name())
            .map(|n| n.to_string_lossy().into_owned())
        {
            *value = toml_edit::Value::from(name);
        }
    }
    Some(document.to_string())
}
