//! `acq record --rig` on the in-process bus, as the binary runs it: the
//! recorder on a runtime of its own, stopped when the test says so.
#![allow(dead_code)]

use std::path::Path;
use std::time::{Duration, Instant};

use acq_acquire::bus::memory::MemoryBus;
use acq_acquire::record::status::StatusMode;
use acq_acquire::record::{self, RecordObserver, RecordOptions, RecordSummary, StopReason};
use acq_acquire::replay::{play, Pacing, Routing};
use acq_acquire::simulate::Simulation;
use acq_can::frame::IfaceName;
use acq_rig::Rig;

/// An in-process bus with the interfaces `names`, and those interfaces.
pub fn memory_bus(names: &[&str]) -> (MemoryBus, Vec<IfaceName>) {
    let interfaces: Vec<IfaceName> = names.iter().map(|n| IfaceName::new(n).unwrap()).collect();
    let bus = MemoryBus::new(1 << 16);
    for iface in &interfaces {
        bus.add(*iface);
    }
    (bus, interfaces)
}

/// A recording going on.
pub struct MemoryRecorder {
    pub runtime: tokio::runtime::Runtime,
    stop: tokio::sync::oneshot::Sender<StopReason>,
    recorder: tokio::task::JoinHandle<acq_error::Result<RecordSummary>>,
}

impl MemoryRecorder {
    /// Starts recording `interfaces` of `bus` into `session_dir` through
    /// `rig` (its interfaces already assigned, `notes` what that said),
    /// and returns once the session exists.
    pub fn start(
        bus: &MemoryBus,
        rig: &Rig,
        interfaces: &[IfaceName],
        notes: Vec<String>,
        session_dir: &Path,
        observer: Box<dyn RecordObserver>,
        command_line: &str,
    ) -> MemoryRecorder {
        let runtime = acq_acquire::runtime(2).unwrap();
        let options = RecordOptions {
            interfaces: interfaces.to_vec(),
            rig: Some(rig.clone()),
            session_dir: session_dir.to_path_buf(),
            max_file_bytes: 1 << 30,
            nmt_start: false,
            status: StatusMode::Quiet,
            command_line: command_line.into(),
            notes,
            observer: Some(observer),
            messages: None,
        };
        let (stop, stop_rx) = tokio::sync::oneshot::channel::<StopReason>();
        let recorder = runtime.spawn(record::record(bus.clone(), options, async move {
            stop_rx.await.unwrap_or(StopReason::Signal("SIGINT"))
        }));
        let started = Instant::now();
        while !session_dir.join("session.toml").exists() {
            assert!(
                started.elapsed() < Duration::from_secs(10),
                "the recorder did not start"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
        MemoryRecorder {
            runtime,
            stop,
            recorder,
        }
    }

    /// Plays `simulation` onto `bus` in real time, as `acq simulate --iface`
    /// does, while the recorder records.
    pub fn play_live(&self, bus: &MemoryBus, routing: &Routing, simulation: &mut Simulation) {
        self.play_live_at(bus, routing, simulation, 1.0);
    }

    /// [`MemoryRecorder::play_live`] `speed` times as fast: the recorder's
    /// clock sees the scenario's times divided by `speed`.
    pub fn play_live_at(
        &self,
        bus: &MemoryBus,
        routing: &Routing,
        simulation: &mut Simulation,
        speed: f64,
    ) {
        self.runtime
            .block_on(play(
                bus,
                |_| Ok(simulation.next_frame()),
                routing,
                Pacing::timed(speed),
                1,
            ))
            .unwrap();
    }

    /// Ends the recording as `--duration` would, and waits for its end.
    pub fn stop(self) -> RecordSummary {
        let _ = self.stop.send(StopReason::Duration);
        self.runtime.block_on(self.recorder).unwrap().unwrap()
    }
}
