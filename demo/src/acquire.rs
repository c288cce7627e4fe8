//! The demo's acquisition: recorded sessions played back onto a bus in real
//! time and recorded again from it, exactly as `acq replay` and `acq record`
//! do at a machine.
//!
//! On the in-process bus every session gets interfaces of its own, so all of
//! them play at once; on SocketCAN they share the interfaces given and play
//! one after another.

use std::path::{Path, PathBuf};
use std::time::Duration;

use acq_acquire::bus::Bus;
use acq_acquire::record::status::StatusMode;
use acq_acquire::record::{self, RecordObserver, RecordOptions, StopReason};
use acq_acquire::replay::{self, Anchor, LogFiles, Pacing, PlaySummary, Routing};
use acq_can::IfaceName;
use acq_error::{AcqError, Result};
use acq_io::session;
use acq_rig::Rig;

/// Frames still in flight when the player ends are drained this long
/// before the recorder stops.
const DRAIN: Duration = Duration::from_millis(300);

/// One session to play and record again.
#[derive(Clone, Debug)]
pub struct Playback {
    pub name: String,
    /// The recorded session that is played.
    pub source: PathBuf,
    /// Where the new recording goes.
    pub target: PathBuf,
    /// The interface each of the rig's buses is played and recorded on, in
    /// the rig's bus order.
    pub interfaces: Vec<IfaceName>,
}

/// What one playback did.
#[derive(Clone, Debug)]
pub struct Played {
    pub name: String,
    pub frames_sent: u64,
    pub frames_recorded: u64,
    pub dropped_by_kernel: u64,
    /// (median, p99, max) of the inter-frame timing error, µs.
    pub timing_error_us: Option<(f64, f64, f64)>,
}

/// The session's own copy of its rig (`rig/<name>.toml`).
pub fn session_rig(source: &Path) -> Result<Rig> {
    let recorded = session::read(source)?;
    let copy = recorded.rig.ok_or_else(|| {
        AcqError::Config(format!(
            "{}: the session was recorded without a rig; the demo needs one",
            source.display()
        ))
    })?;
    acq_io::input::load_rig(&acq_io::output::inside(
        source,
        &copy.file.copy,
        "session.toml [rig.file] copy",
    )?)
}

/// Each playback's live feed and page model.
pub type LiveViews = (Vec<Box<dyn RecordObserver>>, Vec<acq_view::SharedSession>);

/// The live page's feed (to give the recorder) and model (to give the
/// server) of each playback, decoded on the interfaces it is replayed on,
/// as the recorder does.
pub fn live_views(playbacks: &[Playback]) -> Result<LiveViews> {
    let mut feeds: Vec<Box<dyn RecordObserver>> = Vec::new();
    let mut shared = Vec::new();
    for playback in playbacks {
        let mut rig = session_rig(&playback.source)?;
        rig.assign_interfaces(&playback.interfaces)
            .map_err(AcqError::Config)?;
        let (feed, session) = acq_view::live_session(
            &playback.name,
            &rig,
            acq_analysis::extract::holds::HoldOptions::default(),
            None,
            Some(&playback.target),
            None,
        );
        feeds.push(Box::new(feed));
        shared.push(session);
    }
    Ok((feeds, shared))
}

/// Plays every session onto `bus` while recording it; `together` plays
/// them all at once (they must use distinct interfaces), else one by one.
/// Ctrl-C stops the recordings cleanly (files whole) and ends with an error.
/// `observers`: one per playback (the live view's feeds), or none.
pub fn play_and_record<B: Bus>(
    bus: B,
    playbacks: &[Playback],
    together: bool,
    observers: Vec<Box<dyn RecordObserver>>,
    interrupted: crate::Interrupted,
) -> Result<Vec<Played>> {
    let runtime = acq_acquire::runtime(2)?;
    let mut observers: Vec<Option<Box<dyn RecordObserver>>> =
        observers.into_iter().map(Some).collect();
    observers.resize_with(playbacks.len(), || None);
    if together {
        runtime.block_on(play_all(bus, playbacks, observers, interrupted))
    } else {
        let mut played = Vec::new();
        for (playback, observer) in playbacks.iter().zip(observers) {
            played.extend(runtime.block_on(play_all(
                bus.clone(),
                std::slice::from_ref(playback),
                vec![observer],
                interrupted,
            ))?);
        }
        Ok(played)
    }
}

/// Plays `playbacks` onto `bus` while recording them again: the recorders
/// first, then the players, then the recorders stopped once the players end.
async fn play_all<B: Bus>(
    bus: B,
    playbacks: &[Playback],
    observers: Vec<Option<Box<dyn RecordObserver>>>,
    interrupted: crate::Interrupted,
) -> Result<Vec<Played>> {
    // Ctrl-C is caught from here on (see below).
    let interrupted = interrupted();
    // 1. Every recorder listening before any frame is sent.
    let (recorders, routings) = start_recorders(&bus, playbacks, observers)?;
    wait_until_recorders_started(playbacks).await?;
    let anchors = anchors(playbacks)?;

    // 2. The players, each on a thread of its own: they wait on the wall
    // clock with blocking sleeps, and the recorders must never wait behind them.
    let (interrupt_tx, interrupt_rx) = tokio::sync::watch::channel(false);
    let players = start_players(&bus, playbacks, routings, anchors, &interrupt_rx)?;
    // Ctrl-C: the players stop sending and the recordings end as after a
    // normal end, every file whole.
    let signal_watch = tokio::spawn(async move {
        interrupted.await;
        let _ = interrupt_tx.send(true);
    });
    let summaries = join_players(players).await?;
    signal_watch.abort();
    let interrupted = *interrupt_rx.borrow();
    tokio::time::sleep(DRAIN).await;

    // 3. The recorders stop and complete their sessions.
    let played = stop_recorders(playbacks, recorders, summaries, interrupted).await?;
    if interrupted {
        return Err(AcqError::Interrupted(
            "interrupted during the replay; the sessions recorded so far are whole".into(),
        ));
    }
    Ok(played)
}

/// A recording under way: its task and the sender that stops it.
type Recorder = (
    tokio::task::JoinHandle<Result<record::RecordSummary>>,
    tokio::sync::oneshot::Sender<StopReason>,
);

/// Starts a recorder on each playback's interfaces, with the session's own
/// rig, and returns them with each playback's routing; an error when a
/// rig's buses and the interfaces given do not pair up.
fn start_recorders<B: Bus>(
    bus: &B,
    playbacks: &[Playback],
    observers: Vec<Option<Box<dyn RecordObserver>>>,
) -> Result<(Vec<Recorder>, Vec<Routing>)> {
    let mut recorders = Vec::new();
    let mut routings = Vec::new();
    for (playback, observer) in playbacks.iter().zip(observers) {
        let mut rig = session_rig(&playback.source)?;
        if rig.buses.len() != playback.interfaces.len() {
            return Err(AcqError::Config(format!(
                "{}: its rig has {} bus(es) but {} interface(s) were given; give one per bus",
                playback.name,
                rig.buses.len(),
                playback.interfaces.len()
            )));
        }
        routings.push(Routing::for_rig(&rig, &playback.interfaces)?);
        let notes = rig
            .assign_interfaces(&playback.interfaces)
            .map_err(AcqError::Config)?;
        let options = RecordOptions {
            interfaces: playback.interfaces.clone(),
            rig: Some(rig),
            session_dir: playback.target.clone(),
            max_file_bytes: 1 << 30,
            nmt_start: false,
            status: StatusMode::Quiet,
            command_line: format!("acq demo (replay of {})", playback.source.display()),
            notes,
            observer,
            messages: None,
        };
        let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<StopReason>();
        let recorder_bus = bus.clone();
        let task = tokio::spawn(async move {
            let stop = async move { stop_rx.await.unwrap_or(StopReason::Signal("SIGINT")) };
            record::record(recorder_bus, options, stop).await
        });
        recorders.push((task, stop_tx));
    }
    Ok((recorders, routings))
}

/// Waits until every recorder has written its session.toml (its interfaces
/// are open), 10 s at most each.
async fn wait_until_recorders_started(playbacks: &[Playback]) -> Result<()> {
    for playback in playbacks {
        let started = std::time::Instant::now();
        while !playback.target.join("session.toml").exists() {
            if started.elapsed() > Duration::from_secs(10) {
                return Err(AcqError::Config(format!(
                    "the recorder of {} did not start within 10 s",
                    playback.name
                )));
            }
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    }
    Ok(())
}

/// Each playback's schedule: the recorded session's start played at the
/// new recording's start, so that every frame keeps its offset from the
/// session's start. On the in-process bus frames are stamped with their
/// scheduled time, and the demo's recordings, hence its numbers, are the
/// same on every run; on SocketCAN the kernel stamps them on arrival.
fn anchors(playbacks: &[Playback]) -> Result<Vec<Anchor>> {
    playbacks
        .iter()
        .map(|playback| {
            Ok(Anchor {
                log_unix_ns: session::read(&playback.source)?.session.started_unix_ns,
                wall_unix_ns: session::read(&playback.target)?.session.started_unix_ns,
            })
        })
        .collect()
}

/// Starts a player thread per playback, replaying its raw logs in real
/// time from its anchor along its routing until they end or `interrupted`
/// turns true.
fn start_players<B: Bus>(
    bus: &B,
    playbacks: &[Playback],
    routings: Vec<Routing>,
    anchors: Vec<Anchor>,
    interrupted: &tokio::sync::watch::Receiver<bool>,
) -> Result<Vec<std::thread::JoinHandle<Result<PlaySummary>>>> {
    let mut players = Vec::new();
    for ((playback, routing), anchor) in playbacks.iter().zip(routings).zip(anchors) {
        let raw_files = session::raw_files(&playback.source)?;
        if raw_files.is_empty() {
            return Err(AcqError::Config(format!(
                "{}: no raw log to play",
                playback.source.display()
            )));
        }
        let player_bus = bus.clone();
        let interrupted = interrupted.clone();
        players.push(std::thread::spawn(move || -> Result<PlaySummary> {
            let mut log = LogFiles::open(raw_files)?;
            let runtime = acq_acquire::runtime(1)?;
            let next = |pass: usize| -> Result<Option<acq_can::Frame>> {
                if *interrupted.borrow() {
                    return Ok(None);
                }
                log.next_frame(pass)
            };
            runtime.block_on(replay::play(
                &player_bus,
                next,
                &routing,
                Pacing::Timed {
                    speed: 1.0,
                    anchor: Some(anchor),
                },
                1,
            ))
        }));
    }
    Ok(players)
}

/// Each player's summary, in order, waited for off the runtime's threads.
async fn join_players(
    players: Vec<std::thread::JoinHandle<Result<PlaySummary>>>,
) -> Result<Vec<PlaySummary>> {
    let mut summaries = Vec::new();
    for player in players {
        let summary = tokio::task::spawn_blocking(move || player.join())
            .await
            .map_err(|e| AcqError::Config(format!("the player failed: {e}")))?
            .map_err(|_| AcqError::Config("the player panicked".into()))??;
        summaries.push(summary);
    }
    Ok(summaries)
}

/// Stops every recorder (as interrupted, or as the replay finished), waits
/// for its session, and says what each playback did.
async fn stop_recorders(
    playbacks: &[Playback],
    recorders: Vec<Recorder>,
    summaries: Vec<PlaySummary>,
    interrupted: bool,
) -> Result<Vec<Played>> {
    let mut played = Vec::new();
    for ((playback, (task, stop)), summary) in playbacks.iter().zip(recorders).zip(summaries) {
        let _ = stop.send(if interrupted {
            StopReason::Signal("SIGINT")
        } else {
            StopReason::Requested("replay finished")
        });
        let recorded = task.await.map_err(|e| {
            AcqError::Config(format!("the recorder of {} failed: {e}", playback.name))
        })??;
        let info = &recorded.session.session;
        played.push(Played {
            name: playback.name.clone(),
            frames_sent: summary.frames_sent,
            frames_recorded: info.frames,
            dropped_by_kernel: info.dropped_by_kernel,
            timing_error_us: summary.timing.interval_error_us(),
        });
    }
    Ok(played)
}
