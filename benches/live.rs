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

mod common;

use std::time::Instant;

use acq_acquire::bus::memory::MemoryBus;
use acq_acquire::bus::{Bus, FrameSource};
use acq_acquire::replay::{self, Pacing, Routing};
use acq_can::{CanId, Frame};
use common::{cpu_seconds, four_bus_bus, four_bus_rig, iface, produce, record_while_producing};

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
            Pacing::timed(1.0),
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

fn recording_cost(seconds: f64) {
    let rig = four_bus_rig();

    // Baseline: the traffic alone.
    let bus = four_bus_bus();
    let (cpu0, wall0) = (cpu_seconds(), Instant::now());
    let sent = produce(bus, rig.clone(), seconds, 1, None).join().unwrap();
    let baseline = (cpu_seconds() - cpu0) / wall0.elapsed().as_secs_f64();

    // The same traffic recorded.
    let (total, sent_recorded) = record_while_producing(&rig, None, seconds, 1, None);
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
