//! The view of a recording going on: the recorder hands every batch of
//! frames to a [`LiveFeed`], which passes it on to a thread of its own over a
//! bounded queue. The thread decodes, fills the [`SessionView`] and runs the
//! hold stream. A full queue costs the view frames (counted, shown on the
//! page), never the recorder a wait.
//!
//! It also keeps every sensor's whole span (buckets doubling in length as
//! the session grows, a fixed memory) and, when the recording ends, writes
//! the session's `view-index.bin`: `acq view` then opens it at once.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use acq_acquire::record::status::Status;
use acq_acquire::record::RecordObserver;
use acq_analysis::extract::holds::HoldOptions;
use acq_analysis::extract::live::LiveHoldStream;
use acq_analysis::zero::{shown_lines, ZeroTaker, ZeroWindows, Zeroing};
use acq_can::log::candump::logged_timestamp_ns;
use acq_can::Frame;
use acq_io::session::SessionFile;
use acq_io::zero_record::ZeroRecord;
use acq_rig::sensors::{Sample, SensorDecoder, SensorEvent};
use acq_rig::Rig;

use crate::frames::FrameTable;
use crate::index;
use crate::model::{finish_recorded, TENSILE_NOTE};
use crate::model::{BusView, SessionView};
use crate::series::{MinMaxSeries, BUCKET_NS, WHOLE_SPAN_BUCKETS};

/// Batches the view may be behind the recorder (about 5 s at 2,000
/// frames/s in batches of 10; memory at most a few MB).
const QUEUE_BATCHES: usize = 1024;
/// The hold stream looks for newly closed holds this often.
const HOLD_CHECK: Duration = Duration::from_millis(100);
/// Live series: 10 minutes of the shortest buckets.
pub const LIVE_BUCKETS: usize = 60_000;

/// One session's model, shared by its feed and the server.
pub type SharedSession = Arc<Mutex<SessionView>>;

enum FeedEvent {
    Started(i64),
    Frames(Vec<Frame>),
    Status(Box<Status>),
    Finished(Option<Box<SessionFile>>),
}

/// Hands what the recorder sees to the view's thread; never blocks.
pub struct LiveFeed {
    queue: SyncSender<FeedEvent>,
    frames_not_shown: Arc<AtomicU64>,
    thread: Option<std::thread::JoinHandle<()>>,
}

/// A live view of one recording: the feed to give the recorder and the
/// model to give the server.
/// `session_dir`: where the index (and the zero record) is written.
/// `zero`: take each channel's zero in these windows (`acq record
/// --zero-before`); the page, the holds and the index then show zeroed
/// values, the first only once the before window has closed.
pub fn live_session(
    name: &str,
    rig: &Rig,
    hold_options: HoldOptions,
    load: Option<&str>,
    session_dir: Option<&Path>,
    zero: Option<ZeroWindows>,
) -> (LiveFeed, SharedSession) {
    let mut view = SessionView::new(name, rig, 0, BUCKET_NS, LIVE_BUCKETS);
    view.live = true;
    let shared = Arc::new(Mutex::new(view));
    let (queue, events) = mpsc::sync_channel(QUEUE_BATCHES);
    let frames_not_shown = Arc::new(AtomicU64::new(0));
    let thread = {
        let (rig, shared, lost) = (rig.clone(), shared.clone(), frames_not_shown.clone());
        let load = load.map(str::to_owned);
        let session_dir = session_dir.map(Path::to_path_buf);
        let name = name.to_string();
        std::thread::Builder::new()
            .name("acq-view".into())
            .spawn(move || {
                let feed = Feed {
                    name,
                    rig,
                    shared,
                    frames_not_shown: lost,
                    hold_options,
                    load,
                    session_dir,
                    zero,
                };
                feed.run(events)
            })
            .ok()
    };
    (
        LiveFeed {
            queue,
            frames_not_shown,
            thread,
        },
        shared,
    )
}

impl LiveFeed {
    fn offer(&self, event: FeedEvent, frames: usize) {
        if let Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) =
            self.queue.try_send(event)
        {
            self.frames_not_shown
                .fetch_add(frames as u64, Ordering::Relaxed);
        }
    }
}

impl RecordObserver for LiveFeed {
    fn started(&mut self, session: &SessionFile) {
        self.offer(FeedEvent::Started(session.session.started_unix_ns), 0);
    }

    fn frames(&mut self, _bus: usize, frames: &[Frame], _arrival_ns: i64) {
        self.offer(FeedEvent::Frames(frames.to_vec()), frames.len());
    }

    fn status(&mut self, status: &Status) {
        self.offer(FeedEvent::Status(Box::new(status.clone())), 0);
    }

    fn finished(&mut self, session: &SessionFile) {
        // The last frames must be in before the holds are closed: wait for room.
        let _ = self
            .queue
            .send(FeedEvent::Finished(Some(Box::new(session.clone()))));
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// The feed's thread: what it was given to work with.
struct Feed {
    name: String,
    rig: Rig,
    shared: SharedSession,
    frames_not_shown: Arc<AtomicU64>,
    hold_options: HoldOptions,
    load: Option<String>,
    session_dir: Option<PathBuf>,
    zero: Option<ZeroWindows>,
}

/// The zero being taken live: samples wait in `pending` until the before
/// window has closed, then go on zeroed.
struct LiveZero {
    taker: ZeroTaker,
    pending: Vec<Sample>,
    zeroing: Option<Zeroing>,
    /// The before window was no rest: nothing is zeroed or written.
    refused: bool,
}

/// What the zero's record is called in a session written by the recorder.
const TAKEN_LIVE: &str = "acq record --zero-before";

impl LiveZero {
    /// `samples` as they may be shown: none while the before window is
    /// open, then the ones waiting and these, zeroed. `closed` is called
    /// once with the record when the window closes.
    fn pass(&mut self, samples: &mut Vec<Sample>, mut closed: impl FnMut(ZeroRecord)) {
        if self.refused {
            return;
        }
        for sample in samples.iter() {
            self.taker.push(sample);
        }
        if self.zeroing.is_none() {
            self.pending.append(samples);
            if !self.taker.before_closed() {
                return;
            }
            // A window that is no rest gives no zero (a load's start taken
            // for a transducer's offset would shift every value after it).
            let moved = self.taker.not_at_rest_before();
            if !moved.is_empty() {
                eprintln!(
                    "acq: warning: no zero taken: the --zero-before window is no rest for {} channel(s):\n  {}\n  the values are kept as read; take the zero from a rest with acq zero SESSION --before (a shorter window)",
                    moved.len(),
                    shown_lines(&moved)
                );
                self.refused = true;
                *samples = std::mem::take(&mut self.pending);
                return;
            }
            let record = self.taker.record(TAKEN_LIVE);
            self.zeroing = Some(Zeroing::new(self.taker.rig(), &record));
            closed(record);
            *samples = std::mem::take(&mut self.pending);
        }
        if let Some(zeroing) = &self.zeroing {
            samples.iter_mut().for_each(|s| zeroing.apply(s));
        }
    }

    /// After the last frame: the samples still waiting, zeroed, and the
    /// record if it is not the one [`LiveZero::pass`] gave (the before
    /// window closed only now, or an after window was asked for).
    fn finish(mut self) -> (Vec<Sample>, Option<ZeroRecord>) {
        let mut pending = std::mem::take(&mut self.pending);
        if self.refused {
            return (pending, None);
        }
        if !self.taker.before_closed() {
            // The recording ended inside the window: judged as it stands.
            let moved = self.taker.not_at_rest_before();
            if !moved.is_empty() {
                eprintln!(
                    "acq: warning: no zero taken: the recording ended inside the --zero-before window, which is no rest for {} channel(s):\n  {}",
                    moved.len(),
                    shown_lines(&moved)
                );
                return (pending, None);
            }
        }
        let mut record = self.taker.record(TAKEN_LIVE);
        // The record given when the before window closed holds the after
        // window as it stood then: one asked for is always written anew.
        let changed = self.zeroing.is_none() || record.after_s.is_some();
        let moved = self.taker.not_at_rest_after();
        if !moved.is_empty() {
            eprintln!(
                "acq: warning: the --zero-after window is no rest for {} channel(s):\n  {}\n  the zero is the before window's alone (no zero return); take both with acq zero SESSION --before ... --after (a shorter window)",
                moved.len(),
                shown_lines(&moved)
            );
            record.after_s = None;
            record
                .sensors
                .iter_mut()
                .for_each(|sensor| sensor.after = None);
        }
        let zeroing = self
            .zeroing
            .get_or_insert_with(|| Zeroing::new(self.taker.rig(), &record));
        pending.iter_mut().for_each(|s| zeroing.apply(s));
        (pending, changed.then_some(record))
    }
}

/// `frames`' samples into `samples` (cleared first), at the times raw.log
/// keeps, so that the holds equal acq extract's; each frame into `table`
/// (session time from `t0_ns`).
fn decode(
    decoder: &mut SensorDecoder,
    frames: &[Frame],
    samples: &mut Vec<Sample>,
    table: &mut FrameTable,
    t0_ns: i64,
) {
    samples.clear();
    let mut sensors = Vec::new();
    for frame in frames {
        let mut frame = *frame;
        frame.timestamp_ns = logged_timestamp_ns(frame.timestamp_ns);
        sensors.clear();
        let used = decoder.decode(&frame, |event| {
            if let SensorEvent::Sample(sample) = event {
                sensors.push(sample.sensor);
                samples.push(sample);
            }
        });
        table.see(
            &frame,
            (frame.timestamp_ns - t0_ns) as f64 / 1e9,
            used,
            &sensors,
        );
    }
}

/// The recorder's status on the page: the buses and each sensor's silence.
fn show_status(view: &mut SessionView, status: &Status, frames_not_shown: u64) {
    view.elapsed_s = status.elapsed_s;
    view.frames_not_shown = frames_not_shown;
    view.buses = status
        .buses
        .iter()
        .map(|b| BusView {
            iface: b.iface.clone(),
            state: b.state.to_string(),
            frames_per_s: b.frames_per_s,
            frames: b.frames,
            kernel_drops: b.dropped_by_kernel,
            error_frames: b.error_frames,
        })
        .collect();
    for (sensor, live) in view.sensors.iter_mut().zip(&status.sensors) {
        sensor.silent = live.silent;
        sensor.silence_reason = live.reason;
    }
}

/// What the feed keeps of every sample it shows: each sensor's whole span
/// (for the index) and its last sample's time.
struct Shown {
    whole: Vec<MinMaxSeries>,
    last_sample_ns: Vec<Option<i64>>,
}

impl Shown {
    fn show(
        &mut self,
        samples: &[Sample],
        t0: i64,
        view: &mut SessionView,
        mut holds: Option<&mut LiveHoldStream>,
    ) {
        for sample in samples {
            self.last_sample_ns[sample.sensor] = Some(sample.time_ns);
            if let Some(value) = sample.value {
                self.whole[sample.sensor].push(sample.time_ns - t0, value);
            }
            view.push(sample.sensor, sample.time_ns, sample.value);
            if let Some(stream) = holds.as_deref_mut() {
                stream.push(*sample);
            }
        }
    }
}

impl Feed {
    /// Writes the zero record into the session (at once: a crash later
    /// keeps it), and hands it to the hold stream.
    fn keep_zero(&self, record: ZeroRecord, holds: Option<&mut LiveHoldStream>) {
        if let Some(dir) = &self.session_dir {
            if let Err(e) = acq_io::zero_record::write(dir, &record) {
                eprintln!(
                    "acq: warning: cannot write {}: {e}; take the zero again offline with acq zero",
                    dir.join(acq_io::zero_record::ZERO_FILE).display()
                );
            }
        }
        if let Some(stream) = holds {
            stream.set_zero(record);
        }
    }

    fn run(self, events: Receiver<FeedEvent>) {
        let Feed {
            rig,
            shared,
            frames_not_shown,
            hold_options,
            load,
            ..
        } = &self;
        let mut decoder = SensorDecoder::new(rig);
        let mut holds: Option<LiveHoldStream> = None;
        let mut zero: Option<LiveZero> = None;
        let mut samples = Vec::new();
        let mut shown = Shown {
            whole: rig
                .sensors
                .iter()
                .map(|_| MinMaxSeries::whole(BUCKET_NS, WHOLE_SPAN_BUCKETS as usize))
                .collect(),
            last_sample_ns: vec![None; rig.sensors.len()],
        };
        let mut t0 = 0;
        let mut table = FrameTable::default();
        let mut last_check = Instant::now();
        loop {
            let event = match events.recv_timeout(HOLD_CHECK) {
                Ok(event) => Some(event),
                Err(RecvTimeoutError::Timeout) => None,
                Err(RecvTimeoutError::Disconnected) => Some(FeedEvent::Finished(None)),
            };
            let lock = || shared.lock().unwrap_or_else(|p| p.into_inner());
            match event {
                Some(FeedEvent::Started(started)) => {
                    t0 = started;
                    let mut view = lock();
                    view.started_unix_ns = t0;
                    if view.xy.is_some() && load.is_none() {
                        view.holds_note = Some(TENSILE_NOTE.into());
                    } else {
                        match LiveHoldStream::new(rig, load.as_deref(), *hold_options, t0) {
                            Ok(stream) => {
                                view.load_sensor = Some(stream.load_sensor().to_string());
                                holds = Some(stream);
                            }
                            Err(error) => view.holds_note = Some(format!("no holds: {error}")),
                        }
                    }
                    zero = self.zero.map(|windows| LiveZero {
                        taker: ZeroTaker::new(rig, windows, t0),
                        pending: Vec::new(),
                        zeroing: None,
                        refused: false,
                    });
                }
                Some(FeedEvent::Frames(frames)) => {
                    decode(&mut decoder, &frames, &mut samples, &mut table, t0);
                    if let Some(zero) = zero.as_mut() {
                        zero.pass(&mut samples, |record| {
                            self.keep_zero(record, holds.as_mut())
                        });
                    }
                    shown.show(&samples, t0, &mut lock(), holds.as_mut());
                }
                Some(FeedEvent::Status(status)) => {
                    show_status(
                        &mut lock(),
                        &status,
                        frames_not_shown.load(Ordering::Relaxed),
                    );
                }
                Some(FeedEvent::Finished(session)) => {
                    if let Some(zero) = zero.take() {
                        let (pending, record) = zero.finish();
                        if let Some(record) = record {
                            self.keep_zero(record, holds.as_mut());
                        }
                        shown.show(&pending, t0, &mut lock(), holds.as_mut());
                    }
                    let mut view = lock();
                    view.frames = table.clone();
                    if let Some(stream) = holds.as_mut() {
                        stream.finish();
                        view.set_holds(stream.holds());
                    }
                    view.live = false;
                    view.frames_not_shown = frames_not_shown.load(Ordering::Relaxed);
                    // Once it has ended, the session reads as acq view reads
                    // it: each bus's mean rate, and silent only the sensors
                    // that stopped before the others (not every one, as the
                    // last live status has it once the bus went quiet).
                    if let Some(session) = &session {
                        finish_recorded(&mut view, &self.rig, session, &shown.last_sample_ns);
                    }
                    if let Some(session) = session {
                        self.write_index(
                            &view,
                            shown.whole,
                            holds.as_ref(),
                            &session,
                            &shown.last_sample_ns,
                        );
                    }
                    return;
                }
                None => {}
            }
            if last_check.elapsed() >= HOLD_CHECK {
                last_check = Instant::now();
                // The trace is copied, not shared: its rows change with
                // every frame, the page looks ten times a second.
                lock().frames = table.clone();
                if let Some(stream) = holds.as_mut() {
                    if stream.update() {
                        lock().set_holds(stream.holds());
                    }
                }
            }
        }
    }

    /// The recorded session's page, as `acq view` would build it from the
    /// recording, into its `view-index.bin`. Not written when a hold lost
    /// its values or none was found (acq view then reads the recording),
    /// or when the view missed frames. A tensile test has no holds
    /// (`stream` is `None`): its page is the curve.
    fn write_index(
        &self,
        live: &SessionView,
        mut whole: Vec<MinMaxSeries>,
        stream: Option<&LiveHoldStream>,
        session: &SessionFile,
        last_sample_ns: &[Option<i64>],
    ) {
        let Some(dir) = &self.session_dir else {
            return;
        };
        let holds_lost = match stream {
            Some(stream) => {
                stream.holds().is_empty() || stream.holds().iter().any(|h| h.values.is_none())
            }
            None => live.xy.is_none(),
        };
        if holds_lost || live.frames_not_shown > 0 {
            return;
        }
        let bucket_ns = whole
            .iter()
            .map(MinMaxSeries::bucket_ns)
            .max()
            .unwrap_or(BUCKET_NS);
        let mut view = SessionView::new(&self.name, &self.rig, live.started_unix_ns, bucket_ns, 1);
        for ((sensor, mut series), shown) in view
            .sensors
            .iter_mut()
            .zip(whole.drain(..))
            .zip(&live.sensors)
        {
            series.coarsen_to(bucket_ns);
            sensor.series = series;
            sensor.last_value = shown.last_value;
        }
        match stream {
            Some(stream) => view.set_holds(stream.holds()),
            None => view.holds_note = live.holds_note.clone(),
        }
        view.load_sensor = live.load_sensor.clone();
        view.frames = live.frames.clone();
        if let (Some(xy), Some(shown)) = (view.xy.as_mut(), live.xy.as_ref()) {
            xy.points = shown.points.clone();
        }
        finish_recorded(&mut view, &self.rig, session, last_sample_ns);
        let _ = index::save(dir, &index::key(dir, session), &view);
    }
}
