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
use acq_drivers::log::candump::logged_timestamp_ns;
use acq_drivers::rig::Rig;
use acq_drivers::sensors::{SensorDecoder, SensorEvent};
use acq_drivers::Frame;
use acq_io::session::SessionFile;

use crate::index;
use crate::model::finish_recorded;
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
/// `session_dir`: where the index is written when the recording ends.
pub fn live_session(
    name: &str,
    rig: &Rig,
    hold_options: HoldOptions,
    load: Option<&str>,
    session_dir: Option<&Path>,
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
}

impl Feed {
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
        let mut samples = Vec::new();
        let mut whole: Vec<MinMaxSeries> = rig
            .sensors
            .iter()
            .map(|_| MinMaxSeries::whole(BUCKET_NS, WHOLE_SPAN_BUCKETS as usize))
            .collect();
        let mut last_sample_ns: Vec<Option<i64>> = vec![None; rig.sensors.len()];
        let mut t0 = 0;
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
                    match LiveHoldStream::new(rig, load.as_deref(), *hold_options, t0) {
                        Ok(stream) => {
                            view.load_sensor = Some(stream.load_sensor().to_string());
                            holds = Some(stream);
                        }
                        Err(error) => view.holds_note = Some(format!("no holds: {error}")),
                    }
                }
                Some(FeedEvent::Frames(frames)) => {
                    samples.clear();
                    for frame in &frames {
                        // Times as raw.log keeps them, so that holds equal acq extract's.
                        let mut frame = *frame;
                        frame.timestamp_ns = logged_timestamp_ns(frame.timestamp_ns);
                        decoder.decode(&frame, |event| {
                            if let SensorEvent::Sample(sample) = event {
                                samples.push(sample);
                            }
                        });
                    }
                    for sample in &samples {
                        last_sample_ns[sample.sensor] = Some(sample.time_ns);
                        if let Some(value) = sample.value {
                            whole[sample.sensor].push(sample.time_ns - t0, value);
                        }
                    }
                    let mut view = lock();
                    for sample in &samples {
                        view.push(sample.sensor, sample.time_ns, sample.value);
                        if let Some(stream) = holds.as_mut() {
                            stream.push(*sample);
                        }
                    }
                }
                Some(FeedEvent::Status(status)) => {
                    let mut view = lock();
                    view.elapsed_s = status.elapsed_s;
                    view.frames_not_shown = frames_not_shown.load(Ordering::Relaxed);
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
                Some(FeedEvent::Finished(session)) => {
                    let mut view = lock();
                    if let Some(stream) = holds.as_mut() {
                        stream.finish();
                        view.set_holds(stream.holds());
                    }
                    view.live = false;
                    view.frames_not_shown = frames_not_shown.load(Ordering::Relaxed);
                    if let (Some(session), Some(stream)) = (session, &holds) {
                        self.write_index(&view, whole, stream, &session, &last_sample_ns);
                    }
                    return;
                }
                None => {}
            }
            if last_check.elapsed() >= HOLD_CHECK {
                last_check = Instant::now();
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
    /// or when the view missed frames.
    fn write_index(
        &self,
        live: &SessionView,
        mut whole: Vec<MinMaxSeries>,
        stream: &LiveHoldStream,
        session: &SessionFile,
        last_sample_ns: &[Option<i64>],
    ) {
        let Some(dir) = &self.session_dir else {
            return;
        };
        if stream.holds().is_empty()
            || stream.holds().iter().any(|h| h.values.is_none())
            || live.frames_not_shown > 0
        {
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
        view.set_holds(stream.holds());
        view.load_sensor = live.load_sensor.clone();
        if let (Some(xy), Some(shown)) = (view.xy.as_mut(), live.xy.as_ref()) {
            xy.points = shown.points.clone();
        }
        finish_recorded(&mut view, &self.rig, session, last_sample_ns);
        let _ = index::save(dir, &index::key(dir, session), &view);
    }
}
