//! What the live benchmarks share: the four-bus rig on the in-process bus,
//! its simulated traffic sent in real time, the process's CPU time.
#![allow(dead_code)]

use std::path::Path;
use std::thread;
use std::time::{Duration, Instant};

use acq_acquire::bus::memory::MemoryBus;
use acq_acquire::bus::{Bus, FrameSink};
use acq_acquire::record::status::StatusMode;
use acq_acquire::record::{RecordObserver, RecordOptions};
use acq_acquire::simulate::scenario::Scenario;
use acq_acquire::simulate::Simulation;
use acq_can::{CanId, Frame, IfaceName};
use acq_rig::Rig;
use nix::sys::resource::{getrusage, UsageWho};

/// DAQ_Force (0x300): TipForce, float32 at bit 0, kN.
pub const MARKER_ID: CanId = CanId::Standard(0x300);

pub fn iface(name: &str) -> IfaceName {
    IfaceName::new(name).unwrap()
}

/// User and system CPU seconds of this process so far.
pub fn cpu_seconds() -> f64 {
    let usage = getrusage(UsageWho::RUSAGE_SELF).unwrap();
    let seconds = |t: nix::sys::time::TimeVal| t.tv_sec() as f64 + t.tv_usec() as f64 * 1e-6;
    seconds(usage.user_time()) + seconds(usage.system_time())
}

pub fn four_bus_rig() -> Rig {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    Rig::load(&root.join("fixtures/rigs/bench_four_buses.toml")).unwrap()
}

pub fn four_interfaces() -> Vec<IfaceName> {
    (0..4).map(|b| iface(&format!("vcan{b}"))).collect()
}

/// The in-process bus with the four interfaces.
pub fn four_bus_bus() -> MemoryBus {
    let bus = MemoryBus::new(1 << 16);
    for i in four_interfaces() {
        bus.add(i);
    }
    bus
}

/// Recording the four buses with live decode, quiet.
pub fn record_options(
    rig: &Rig,
    session_dir: &Path,
    observer: Option<Box<dyn RecordObserver>>,
) -> RecordOptions {
    RecordOptions {
        interfaces: four_interfaces(),
        rig: Some(rig.clone()),
        session_dir: session_dir.to_path_buf(),
        max_file_bytes: 1 << 30,
        nmt_start: false,
        status: StatusMode::Quiet,
        command_line: "bench".into(),
        notes: Vec::new(),
        observer,
        messages: None,
    }
}

/// Sends every `every`-th frame of the four-bus simulation in real time
/// from its own thread for `seconds` (the scenario repeated as needed). With `mark`, bus 0's force frames
/// carry their send time as the value (s since `mark`, mod 90).
pub fn produce(
    bus: MemoryBus,
    rig: Rig,
    seconds: f64,
    every: u64,
    mark: Option<Instant>,
) -> thread::JoinHandle<u64> {
    thread::spawn(move || {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let (scenario, curve) =
            Scenario::load(&root.join("fixtures/scenarios/bench_four_buses.toml")).unwrap();
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        runtime.block_on(async {
            let mut sinks: Vec<_> = four_interfaces()
                .into_iter()
                .map(|i| bus.open_sink(i).unwrap())
                .collect();
            let start = Instant::now();
            let mut sent = 0u64;
            let mut index = 0u64;
            // The scenario (11 s) again and again for a longer window.
            let mut start_ns = 0;
            'window: loop {
                let mut simulation =
                    Simulation::new(&rig, scenario.clone(), curve.clone(), 1, start_ns).unwrap();
                while let Some(mut frame) = simulation.next_frame() {
                    index += 1;
                    start_ns = frame.timestamp_ns + 1_000_000;
                    if index % every != 0 {
                        continue;
                    }
                    let due = Duration::from_nanos(frame.timestamp_ns as u64);
                    if due.as_secs_f64() > seconds {
                        break 'window;
                    }
                    // Sleep in 1 ms steps: frames go out in small bursts, as from a DAQ.
                    let now = start.elapsed();
                    if due > now + Duration::from_millis(1) {
                        thread::sleep(due - now);
                    }
                    let bus_index = usize::from(frame.iface.as_str().as_bytes()[4] - b'0');
                    if let (0, true, Some(epoch)) = (bus_index, frame.id == MARKER_ID, mark) {
                        let value = (epoch.elapsed().as_secs_f64() % 90.0) as f32;
                        let mut data = frame.payload().to_vec();
                        data[..4].copy_from_slice(&value.to_le_bytes());
                        frame =
                            Frame::data(frame.timestamp_ns, frame.iface, frame.id, &data).unwrap();
                    }
                    sinks[bus_index].send(&frame).await.unwrap();
                    sent += 1;
                }
            }
            sent
        })
    })
}

/// Records the four buses (with `observer`) while [`produce`] sends; the
/// process's CPU share of one core over the sending, and the frames sent
/// (every one of them recorded: checked).
pub fn record_while_producing(
    rig: &Rig,
    observer: Option<Box<dyn RecordObserver>>,
    seconds: f64,
    every: u64,
    mark: Option<Instant>,
) -> (f64, u64) {
    let dir = tempfile::tempdir().unwrap();
    let bus = four_bus_bus();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let options = record_options(rig, &dir.path().join("session"), observer);
    let recording = runtime.spawn(acq_acquire::record::record(
        bus.clone(),
        options,
        async move {
            let _ = stop_rx.await;
            acq_acquire::record::StopReason::Signal("BENCH")
        },
    ));
    thread::sleep(Duration::from_millis(300));
    let (cpu0, wall0) = (cpu_seconds(), Instant::now());
    let sent = produce(bus, rig.clone(), seconds, every, mark)
        .join()
        .unwrap();
    thread::sleep(Duration::from_millis(200));
    let share = (cpu_seconds() - cpu0) / wall0.elapsed().as_secs_f64();
    stop_tx.send(()).unwrap();
    let summary = runtime.block_on(recording).unwrap().unwrap();
    assert_eq!(summary.session.session.frames, sent, "every frame recorded");
    (share, sent)
}
