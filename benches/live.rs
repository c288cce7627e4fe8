//! Live-acquisition benchmarks on the host, in-process bus (the host kernel
//! has no CAN; benches/vcan-bench measures the same on a real vcan in the VM):
//!
//! 1. Replay timing: 2,000 frames 1 ms apart played on an absolute
//!    schedule; the inter-frame error against the log (target: median
//!    under 100 us).
//! 2. Recording cost: four buses at 8,000 frames/s each recorded with live
//!    decode of 76 sensors; the recorder's CPU share of one core is the
//!    process CPU minus that of the same traffic with no recorder.
//!
//! `cargo bench --bench live` (ACQ_BENCH_SECONDS sets the window, default 10).

use std::path::Path;
use std::thread;
use std::time::{Duration, Instant};

use acq_acquire::bus::memory::MemoryBus;
use acq_acquire::bus::{Bus, FrameSink, FrameSource};
use acq_acquire::record::status::StatusMode;
use acq_acquire::record::{self, RecordOptions, StopReason};
use acq_acquire::replay::{self, Pacing, Routing};
use acq_acquire::simulate::scenario::Scenario;
use acq_acquire::simulate::Simulation;
use acq_drivers::rig::Rig;
use acq_drivers::{CanId, Frame, IfaceName};
use nix::sys::resource::{getrusage, UsageWho};

fn iface(name: &str) -> IfaceName {
    IfaceName::new(name).unwrap()
}

fn cpu_seconds() -> f64 {
    let usage = getrusage(UsageWho::RUSAGE_SELF).unwrap();
    let seconds = |t: nix::sys::time::TimeVal| t.tv_sec() as f64 + t.tv_usec() as f64 * 1e-6;
    seconds(usage.user_time()) + seconds(usage.system_time())
}

fn replay_timing() {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    runtime.block_on(async {
        let bus = MemoryBus::new(1 << 14);
        bus.add(iface("vcan0"));
        let mut receiver = bus.open_source(iface("vcan0")).unwrap();
        let t0 = 1_700_000_000_000_000_000i64;
        let log: Vec<Frame> = (0..2000u32)
            .map(|i| {
                Frame::data(t0 + i64::from(i) * 1_000_000, iface("can0"), CanId::Standard(0x100), &i.to_le_bytes())
                    .unwrap()
            })
            .collect();
        let mut position = 0;
        let summary = replay::play(
            &bus,
            |_| {
                position += 1;
                Ok(log.get(position - 1).copied())
            },
            &Routing { map: Vec::new(), default: Some(iface("vcan0")) },
            Pacing::Timed { speed: 1.0 },
            1,
        )
        .await
        .unwrap();
        let mut received = Vec::new();
        while received.len() < log.len() {
            receiver.recv_batch(&mut received).await.unwrap();
        }
        // Independent of the player's own bookkeeping: the bus's send stamps.
        let mut errors_us: Vec<f64> = received
            .windows(2)
            .map(|w| ((w[1].timestamp_ns - w[0].timestamp_ns) - 1_000_000).abs() as f64 / 1e3)
            .collect();
        errors_us.sort_by(f64::total_cmp);
        let drift_us = ((received.last().unwrap().timestamp_ns - received[0].timestamp_ns) - 1_999_000_000).abs() as f64 / 1e3;
        println!(
            "replay timing, 2000 frames at 1 kHz: inter-frame |error| median {:.1} us, p99 {:.1} us, max {:.1} us; span drift {:.1} us; elapsed {:.3} s",
            errors_us[errors_us.len() / 2],
            errors_us[errors_us.len() * 99 / 100],
            errors_us[errors_us.len() - 1],
            drift_us,
            summary.elapsed.as_secs_f64()
        );
    });
}

/// Sends the four-bus simulation in real time from its own thread for `seconds`.
fn produce(bus: MemoryBus, rig: Rig, seconds: f64) -> thread::JoinHandle<u64> {
    thread::spawn(move || {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let (scenario, curve) =
            Scenario::load(&root.join("fixtures/scenarios/bench_four_buses.toml")).unwrap();
        let mut simulation = Simulation::new(&rig, scenario, curve, 1, 0).unwrap();
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        runtime.block_on(async {
            let mut sinks: Vec<_> = (0..4)
                .map(|b| bus.open_sink(iface(&format!("vcan{b}"))).unwrap())
                .collect();
            let start = Instant::now();
            let mut sent = 0u64;
            while let Some(frame) = simulation.next_frame() {
                let due = Duration::from_nanos(frame.timestamp_ns as u64);
                if due.as_secs_f64() > seconds {
                    break;
                }
                // Sleep in 1 ms steps: frames go out in small bursts, as from a DAQ.
                let now = start.elapsed();
                if due > now + Duration::from_millis(1) {
                    thread::sleep(due - now);
                }
                let bus_index = frame.iface.as_str().as_bytes()[4] - b'0';
                sinks[usize::from(bus_index)].send(&frame).await.unwrap();
                sent += 1;
            }
            sent
        })
    })
}

fn recording_cost(seconds: f64) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let rig = Rig::load(&root.join("fixtures/rigs/bench_four_buses.toml")).unwrap();
    let interfaces: Vec<IfaceName> = (0..4).map(|b| iface(&format!("vcan{b}"))).collect();
    let new_bus = || {
        let bus = MemoryBus::new(1 << 16);
        for &i in &interfaces {
            bus.add(i);
        }
        bus
    };

    // Baseline: the traffic alone.
    let bus = new_bus();
    let (cpu0, wall0) = (cpu_seconds(), Instant::now());
    let sent = produce(bus, rig.clone(), seconds).join().unwrap();
    let baseline = (cpu_seconds() - cpu0) / wall0.elapsed().as_secs_f64();

    // The same traffic recorded.
    let dir = tempfile::tempdir().unwrap();
    let bus = new_bus();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let options = RecordOptions {
        interfaces: interfaces.clone(),
        rig: Some(rig.clone()),
        session_dir: dir.path().join("session"),
        max_file_bytes: 1 << 30,
        nmt_start: false,
        status: StatusMode::Quiet,
        command_line: "bench".into(),
        notes: Vec::new(),
        observer: None,
    };
    let recording = runtime.spawn(record::record(bus.clone(), options, async move {
        let _ = stop_rx.await;
        StopReason::Signal("BENCH")
    }));
    thread::sleep(Duration::from_millis(200));
    let (cpu0, wall0) = (cpu_seconds(), Instant::now());
    let sent_recorded = produce(bus, rig, seconds).join().unwrap();
    thread::sleep(Duration::from_millis(200));
    let total = (cpu_seconds() - cpu0) / wall0.elapsed().as_secs_f64();
    stop_tx.send(()).unwrap();
    let summary = runtime.block_on(recording).unwrap().unwrap();
    assert_eq!(
        summary.session.session.frames, sent_recorded,
        "every frame recorded"
    );
    println!(
        "recording 4 buses x 8000 frames/s with live decode: {} frames in {seconds:.0} s ({:.0} frames/s); recorder CPU {:.2} % of one core (process {:.2} % minus traffic alone {:.2} %)",
        sent_recorded,
        sent as f64 / seconds,
        100.0 * (total - baseline),
        100.0 * total,
        100.0 * baseline
    );
}

fn main() {
    let seconds: f64 = std::env::var("ACQ_BENCH_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10.0);
    replay_timing();
    recording_cost(seconds);
}
