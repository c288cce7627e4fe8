//! Record, replay, simulate and repair on the in-process bus: the same code
//! paths as on SocketCAN, minus the kernel (tests/vcan-vm covers that).

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Duration;

use acq_acquire::bus::memory::MemoryBus;
use acq_acquire::bus::{Bus, FrameSink};
use acq_acquire::record::status::StatusMode;
use acq_acquire::record::{self, RecordOptions, RecordSummary, StopReason};
use acq_acquire::replay::{self, Pacing, Routing};
use acq_acquire::simulate::scenario::Scenario;
use acq_acquire::simulate::Simulation;
use acq_can::log::candump::parse_line;
use acq_can::{CanId, Frame, IfaceName};
use acq_io::session;
use acq_rig::Rig;
use tokio::sync::oneshot;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn iface(name: &str) -> IfaceName {
    IfaceName::new(name).unwrap()
}

fn rig(name: &str) -> Rig {
    Rig::load(&root().join("fixtures/rigs").join(name)).unwrap()
}

/// Every frame of a session's raw files, in order.
fn raw_frames(dir: &Path) -> Vec<Frame> {
    let mut frames = Vec::new();
    for path in session::raw_files(dir).unwrap() {
        for line in fs::read_to_string(&path).unwrap().lines() {
            frames.push(parse_line(line.as_bytes()).unwrap().1);
        }
    }
    frames
}

/// What identifies a frame on the wire: interface, id, kind and bytes.
fn wire(frame: &Frame) -> (IfaceName, CanId, Vec<u8>) {
    (frame.iface, frame.id, frame.payload().to_vec())
}

fn options(interfaces: &[&str], rig: Option<Rig>, dir: &Path) -> RecordOptions {
    RecordOptions {
        interfaces: interfaces.iter().map(|n| iface(n)).collect(),
        rig,
        session_dir: dir.to_owned(),
        max_file_bytes: 1 << 30,
        nmt_start: false,
        status: StatusMode::Quiet,
        command_line: "test".into(),
        notes: Vec::new(),
        observer: None,
        messages: None,
    }
}

/// Starts a recording; the returned sender stops it.
fn start_recording(
    bus: &MemoryBus,
    options: RecordOptions,
) -> (oneshot::Sender<()>, tokio::task::JoinHandle<RecordSummary>) {
    let (stop_tx, stop_rx) = oneshot::channel::<()>();
    let bus = bus.clone();
    let handle = tokio::spawn(async move {
        let stop = async move {
            let _ = stop_rx.await;
            StopReason::Signal("TEST")
        };
        record::record(bus, options, stop).await.unwrap()
    });
    (stop_tx, handle)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_simulated_rig_is_recorded_frame_for_frame() {
    let bus = MemoryBus::new(1 << 17);
    bus.add(iface("vcan0"));
    bus.add(iface("vcan1"));
    let dir = tempfile::tempdir().unwrap();
    let session_dir = dir.path().join("session");
    let mut recording_rig = rig("excavator.toml");
    let mut notes = Vec::new();
    let interfaces = [iface("vcan0"), iface("vcan1")];
    notes.extend(recording_rig.assign_interfaces(&interfaces).unwrap());
    assert_eq!(notes.len(), 2, "{notes:?}");
    let mut opts = options(&["vcan0", "vcan1"], Some(recording_rig), &session_dir);
    opts.notes = notes;
    let (stop, recording) = start_recording(&bus, opts);
    tokio::time::sleep(Duration::from_millis(50)).await;

    let traffic_rig = rig("excavator.toml");
    let (scenario, curve) =
        Scenario::load(&root().join("fixtures/scenarios/excavator_case1.toml")).unwrap();
    let mut simulation = Simulation::new(&traffic_rig, scenario, curve, 3, 0).unwrap();
    let mut sent = Vec::new();
    let mut next = |_pass: usize| {
        let frame = simulation.next_frame();
        if let Some(f) = &frame {
            sent.push(*f);
        }
        Ok(frame)
    };
    let routing = Routing {
        map: vec![
            (iface("can0"), iface("vcan0")),
            (iface("can1"), iface("vcan1")),
        ],
        default: None,
    };
    let played = replay::play(&bus, &mut next, &routing, Pacing::AsFast, 1)
        .await
        .unwrap();
    assert_eq!(played.frames_sent as usize, sent.len());
    tokio::time::sleep(Duration::from_millis(100)).await;
    stop.send(()).unwrap();
    let summary = recording.await.unwrap();

    let recorded = raw_frames(&session_dir);
    assert_eq!(recorded.len(), sent.len(), "every frame sent is recorded");
    for name in ["vcan0", "vcan1"] {
        let bus_name = if name == "vcan0" { "can0" } else { "can1" };
        let want: Vec<_> = sent
            .iter()
            .filter(|f| f.iface.as_str() == bus_name)
            .map(|f| (f.id, f.payload().to_vec()))
            .collect();
        let got: Vec<_> = recorded
            .iter()
            .filter(|f| f.iface.as_str() == name)
            .map(|f| (f.id, f.payload().to_vec()))
            .collect();
        assert_eq!(got, want, "{name}: same frames in the same order");
    }
    let written = session::read(&session_dir).unwrap();
    assert_eq!(written, summary.session);
    assert_eq!(written.session.ended, "signal TEST");
    assert_eq!(written.session.frames as usize, sent.len());
    assert_eq!(written.session.dropped_by_kernel, 0);
    assert_eq!(written.session.notes.len(), 2);
    let vcan0 = &written.interface[0];
    assert_eq!(vcan0.timestamp_source, "process");
    assert_eq!(
        vcan0.frame_counts.get("1A5").copied().unwrap_or(0),
        sent.iter()
            .filter(|f| f.id == CanId::Standard(0x1A5))
            .count() as u64,
        "TPDO1 of node 0x25 counted"
    );
    // Every sensor of the rig was decoded live.
    assert_eq!(written.sensor.len(), 28);
    for sensor in &written.sensor {
        assert!(sensor.samples > 0, "{} never decoded", sensor.name);
    }
    let rig_copy = written.rig.as_ref().unwrap();
    let copied = session_dir.join(&rig_copy.file.copy);
    let copied_rig = Rig::load(&copied).expect("the copied rig loads on its own");
    assert_eq!(copied_rig.sensors.len(), 28);
    assert_eq!(rig_copy.dbc.len(), 1);
    let dbc_bytes = fs::read(session_dir.join(&rig_copy.dbc[0].copy)).unwrap();
    assert_eq!(session::sha256_hex(&dbc_bytes), rig_copy.dbc[0].sha256);
}

fn test_frame(i: u32) -> Frame {
    Frame::data(
        0,
        iface("vcan0"),
        CanId::Standard((i % 0x7FF) as u16),
        &i.to_le_bytes(),
    )
    .unwrap()
}

/// Sends `test_frame(i)` for every i on vcan0.
async fn send_test_frames(bus: &MemoryBus, range: std::ops::Range<u32>) {
    let mut sink = bus.open_sink(iface("vcan0")).unwrap();
    for i in range {
        sink.send(&test_frame(i)).await.unwrap();
    }
}

/// An in-process vcan0 with a recorder started on it (given time to open).
async fn recording_on_vcan0(
    capacity: usize,
    max_file_bytes: u64,
) -> (
    MemoryBus,
    tempfile::TempDir,
    oneshot::Sender<()>,
    tokio::task::JoinHandle<RecordSummary>,
) {
    let bus = MemoryBus::new(capacity);
    bus.add(iface("vcan0"));
    let dir = tempfile::tempdir().unwrap();
    let mut opts = options(&["vcan0"], None, dir.path());
    opts.max_file_bytes = max_file_bytes;
    let (stop, recording) = start_recording(&bus, opts);
    tokio::time::sleep(Duration::from_millis(50)).await;
    (bus, dir, stop, recording)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_interface_that_vanishes_is_reported_and_recording_resumes() {
    let (bus, dir, stop, recording) = recording_on_vcan0(4096, 1 << 30).await;
    send_test_frames(&bus, 0..10).await;
    tokio::time::sleep(Duration::from_millis(50)).await;
    let mut sink = bus.open_sink(iface("vcan0")).unwrap();
    bus.remove(iface("vcan0"));
    assert!(
        sink.send(&test_frame(99)).await.is_err(),
        "a removed interface refuses frames"
    );
    tokio::time::sleep(Duration::from_millis(300)).await;
    bus.add(iface("vcan0"));
    // The recorder reopens within its reopen period.
    tokio::time::sleep(Duration::from_millis(700)).await;
    send_test_frames(&bus, 10..20).await;
    tokio::time::sleep(Duration::from_millis(100)).await;
    stop.send(()).unwrap();
    let summary = recording.await.unwrap();
    let recorded: Vec<_> = raw_frames(dir.path()).iter().map(wire).collect();
    let sent: Vec<_> = (0..20).map(|i| wire(&test_frame(i))).collect();
    assert_eq!(recorded, sent);
    let outages = &summary.session.interface[0].outage;
    assert_eq!(outages.len(), 1, "{outages:?}");
    let outage = &outages[0];
    let up = outage.up_unix_ns.expect("the interface came back");
    assert!(up - outage.down_unix_ns >= 250_000_000, "{outage:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stop_writes_everything_already_received() {
    let (bus, dir, stop, recording) = recording_on_vcan0(1 << 16, 1 << 30).await;
    send_test_frames(&bus, 0..20_000).await;
    // Stop at once: the frames still queued were received before the stop.
    stop.send(()).unwrap();
    let summary = recording.await.unwrap();
    assert_eq!(raw_frames(dir.path()).len(), 20_000);
    assert_eq!(summary.session.session.frames, 20_000);
    assert!(summary.session.session.stopped_unix_ns.is_some());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_slow_reader_reports_its_drops() {
    // A queue of 64 frames and a burst of 5000 with the reader asleep
    // between batches: the loss is counted, like SO_RXQ_OVFL.
    let (bus, _dir, stop, recording) = recording_on_vcan0(64, 1 << 30).await;
    send_test_frames(&bus, 0..5000).await;
    tokio::time::sleep(Duration::from_millis(100)).await;
    stop.send(()).unwrap();
    let summary = recording.await.unwrap();
    let info = &summary.session.session;
    assert!(info.dropped_by_kernel > 0);
    assert_eq!(
        info.frames + info.dropped_by_kernel,
        5000,
        "recorded + dropped = sent"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rotation_splits_the_raw_log_without_losing_a_line() {
    let (bus, dir, stop, recording) = recording_on_vcan0(1 << 16, 20_000).await;
    let mut sink = bus.open_sink(iface("vcan0")).unwrap();
    for i in 0..3000 {
        sink.send(&test_frame(i)).await.unwrap();
        if i % 500 == 0 {
            tokio::time::sleep(Duration::from_millis(120)).await;
        }
    }
    tokio::time::sleep(Duration::from_millis(100)).await;
    stop.send(()).unwrap();
    let summary = recording.await.unwrap();
    let files = &summary.session.session.raw_files;
    assert!(files.len() >= 3, "{files:?}");
    assert_eq!(files[0], "raw.000.log");
    let recorded: Vec<_> = raw_frames(dir.path()).iter().map(wire).collect();
    let sent: Vec<_> = (0..3000).map(|i| wire(&test_frame(i))).collect();
    assert_eq!(recorded, sent);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn repair_rebuilds_a_killed_session() {
    let (bus, dir, stop, recording) = recording_on_vcan0(1 << 16, 1 << 30).await;
    send_test_frames(&bus, 0..100).await;
    tokio::time::sleep(Duration::from_millis(200)).await;
    stop.send(()).unwrap();
    let summary = recording.await.unwrap();
    // Make it look killed: session.toml still says "recording", the raw
    // file ends in half a line.
    let mut killed = summary.session.clone();
    killed.session.ended = "recording".into();
    killed.session.stopped_utc = None;
    killed.session.stopped_unix_ns = None;
    killed.session.frames = 7;
    session::write(dir.path(), &killed).unwrap();
    let raw = dir.path().join("raw.log");
    let mut text = fs::read(&raw).unwrap();
    text.extend_from_slice(b"(1700000000.000100) vcan0 12");
    fs::write(&raw, &text).unwrap();

    let report = session::repair(dir.path()).unwrap();
    assert_eq!(report.frames, 100);
    assert_eq!(report.truncated_bytes, 28);
    let repaired = session::read(dir.path()).unwrap();
    assert_eq!(repaired.session.frames, 100);
    assert!(
        repaired.session.ended.starts_with("interrupted"),
        "{}",
        repaired.session.ended
    );
    assert_eq!(
        repaired.session.started_unix_ns,
        summary.session.session.started_unix_ns
    );
    assert_eq!(repaired.interface[0].frames, 100);
    assert_eq!(repaired.interface[0].timestamp_source, "process");
    assert!(fs::read_to_string(&raw).unwrap().ends_with('\n'));
}

#[tokio::test(flavor = "current_thread")]
async fn a_timed_replay_never_sends_early_and_holds_its_schedule() {
    let bus = MemoryBus::new(4096);
    bus.add(iface("vcan0"));
    let mut receiver = bus.open_source(iface("vcan0")).unwrap();
    // 200 frames 2 ms apart, replayed at double speed: 1 ms apart.
    let log: Vec<Frame> = (0..200)
        .map(|i| {
            let mut frame = test_frame(i);
            frame.timestamp_ns = 1_700_000_000_000_000_000 + i64::from(i) * 2_000_000;
            frame
        })
        .collect();
    let mut position = 0;
    let summary = replay::play(
        &bus,
        |_| {
            position += 1;
            Ok(log.get(position - 1).copied())
        },
        &Routing::default(),
        Pacing::timed(2.0),
        1,
    )
    .await
    .unwrap();
    assert_eq!(summary.frames_sent, 200);
    let earliest = summary.timing.earliest_send_ns().unwrap();
    assert!(
        earliest >= 0,
        "a frame left {earliest} ns before its deadline"
    );
    // The schedule is absolute: the whole replay cannot take less than the
    // log's span at that speed.
    assert!(
        summary.elapsed >= Duration::from_micros(199 * 1000),
        "{:?}",
        summary.elapsed
    );
    let mut received = Vec::new();
    while received.len() < 200 {
        use acq_acquire::bus::FrameSource;
        receiver.recv_batch(&mut received).await.unwrap();
    }
    let wire_sent: Vec<_> = log.iter().map(wire).collect();
    let wire_got: Vec<_> = received.iter().map(wire).collect();
    assert_eq!(wire_got, wire_sent);
}

/// A rig whose records come from a sensor file: the session keeps a copy
/// of the file beside the rig's, with its hash, and the copied rig reads
/// the transducer's record from it on its own (the original may change or
/// go after the test).
/// A replay anchored at a recording's start (as the demo plays its
/// sessions) puts every frame at its log offset from the session's start,
/// to the microsecond the log keeps, on every run: the recording does not
/// depend on when the player's or the recorder's thread got to run. Before
/// frames were stamped with their scheduled time they arrived a few to a
/// few hundred microseconds late, differently each run.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_anchored_replay_records_every_frame_at_its_log_offset() {
    // 400 frames at irregular offsets (0.5 to 3.4 ms apart), the log's own
    // session starting 250.000321 ms before its first frame.
    let log_start_ns: i64 = 1_700_000_000_123_456_789;
    let mut offset_us: i64 = 250_000;
    let log: Vec<Frame> = (0..400u32)
        .map(|i| {
            offset_us += 500 + i64::from(i * 7919 % 2900);
            let mut frame = test_frame(i);
            frame.timestamp_ns = (log_start_ns + offset_us * 1_000).div_euclid(1_000) * 1_000;
            frame
        })
        .collect();
    let expected: Vec<i64> = log.iter().map(|f| f.timestamp_ns - log_start_ns).collect();
    for run in 0..2 {
        let (bus, dir, stop, recording) = recording_on_vcan0(1 << 16, 1 << 30).await;
        let started_ns = session::read(dir.path()).unwrap().session.started_unix_ns;
        let anchor = replay::Anchor {
            log_unix_ns: log_start_ns,
            wall_unix_ns: started_ns,
        };
        let mut position = 0;
        let player_bus = bus.clone();
        let frames = log.clone();
        // The player on a thread of its own, as in the demo.
        std::thread::spawn(move || {
            let runtime = acq_acquire::runtime(1).unwrap();
            runtime.block_on(replay::play(
                &player_bus,
                |_| {
                    position += 1;
                    Ok(frames.get(position - 1).copied())
                },
                &Routing::default(),
                Pacing::Timed {
                    speed: 1.0,
                    anchor: Some(anchor),
                },
                1,
            ))
        })
        .join()
        .unwrap()
        .unwrap();
        tokio::time::sleep(Duration::from_millis(100)).await;
        stop.send(()).unwrap();
        recording.await.unwrap();
        let recorded = raw_frames(dir.path());
        assert_eq!(
            recorded.iter().map(wire).collect::<Vec<_>>(),
            log.iter().map(wire).collect::<Vec<_>>(),
            "run {run}"
        );
        // The log keeps microseconds; the offsets are the log's, exactly.
        let offsets: Vec<i64> = recorded
            .iter()
            .map(|f| f.timestamp_ns - started_ns)
            .collect();
        let off: Vec<(usize, i64, i64)> = offsets
            .iter()
            .zip(&expected)
            .enumerate()
            .filter(|(_, (got, want))| (*got - *want).abs() >= 1_000)
            .map(|(i, (got, want))| (i, *got, *want))
            .take(5)
            .collect();
        assert!(
            off.is_empty(),
            "run {run}: (frame, offset ns, log offset ns) {off:?}"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_sensor_file_is_copied_into_the_session_beside_the_rig() {
    let bus = MemoryBus::new(1 << 10);
    bus.add(iface("vcan0"));
    let dir = tempfile::tempdir().unwrap();
    let session_dir = dir.path().join("session");
    let mut recording_rig = Rig::load(&root().join("examples/measurement-chain/rig.toml")).unwrap();
    let notes = recording_rig.assign_interfaces(&[iface("vcan0")]).unwrap();
    let mut opts = options(&["vcan0"], Some(recording_rig), &session_dir);
    opts.notes = notes;
    let (stop, recording) = start_recording(&bus, opts);
    tokio::time::sleep(Duration::from_millis(50)).await;
    stop.send(()).unwrap();
    let summary = recording.await.unwrap();
    let copy = summary.session.rig.as_ref().unwrap();
    let sensor_file = copy
        .sensor_file
        .as_ref()
        .expect("the sensor file is copied");
    assert_eq!(sensor_file.copy, "rig/sensors.toml");
    let bytes = fs::read(session_dir.join(&sensor_file.copy)).unwrap();
    assert_eq!(session::sha256_hex(&bytes), sensor_file.sha256);
    let copied = Rig::load(&session_dir.join(&copy.file.copy)).expect("the copy loads on its own");
    let transducer = copied.sensors[0].record.transducer.as_ref().unwrap();
    assert_eq!(transducer.serial, "EX-400-0001");
    assert!(
        transducer.entered_at.contains("session/rig/sensors.toml"),
        "{transducer:?}"
    );
    assert!(copied.sensors[0].record.curve.is_some());
}
