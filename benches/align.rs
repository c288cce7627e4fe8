//! Throughput and memory of the aligner (issue target: one hour of 25
//! channels at 1 kHz, 90 million samples, in under 5 s on this machine,
//! memory flat in the session's length).
//!
//! `cargo bench --bench align` streams generated samples (25 channels at
//! 1 kHz, +-100 us jitter, 1 in 1000 dropped, sensors interleaved in
//! time order as a recorder writes them) through the aligner onto a
//! 100 Hz grid and the CSV writer into a discarding sink. The generator
//! alone is timed too, so the aligner's own share is known. Sessions of
//! 0.25, 1 and 2 hours run in turn; peak RSS after each shows whether
//! memory grows with the length.
//!
//! Decoding the frames is measured by `cargo bench --bench decode`.

use std::time::Instant;

use acq::align::table::{Column, CsvTable};
use acq::align::{Aligner, ChannelSpec, GridSpec};
use acq::output::Output;
use acq_drivers::rig::Interpolation;

const CHANNELS: usize = 25;
const RATE_HZ: f64 = 1000.0;

/// Calls `emit(channel, time_ns, value)` for `seconds` of traffic.
fn generate(seconds: u64, mut emit: impl FnMut(usize, i64, f64)) {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let period_ns = (1e9 / RATE_HZ) as i64;
    let ticks = seconds as i64 * RATE_HZ as i64;
    for tick in 0..ticks {
        let base = tick * period_ns;
        for channel in 0..CHANNELS {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            if state % 1000 == 0 {
                continue; // a dropped frame
            }
            let jitter = (state >> 20) as i64 % 200_001 - 100_000;
            let value = channel as f64 * 10.0 + ((state >> 40) as f64) * 1e-9;
            // Stagger channels within the period, as frames on a bus are.
            emit(channel, base + channel as i64 * 30_000 + jitter, value);
        }
    }
}

fn peak_rss_kib() -> i64 {
    nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_SELF)
        .map(|u| u.max_rss())
        .unwrap_or(-1)
}

fn main() {
    // `cargo bench` passes --bench; nothing else to parse.
    let hours_list = [0.25, 1.0, 2.0];
    println!("align benchmark: {CHANNELS} channels at {RATE_HZ} Hz -> 100 Hz grid, CSV to a discarding sink");
    for hours in hours_list {
        let seconds = (hours * 3600.0) as u64;
        let samples = seconds as f64 * RATE_HZ * CHANNELS as f64;

        let started = Instant::now();
        let mut checksum = 0.0;
        generate(seconds, |c, t, v| {
            checksum += v + (t + c as i64) as f64 * 1e-18
        });
        let generator_s = started.elapsed().as_secs_f64();

        let columns: Vec<Column> = (0..CHANNELS)
            .map(|i| Column {
                name: format!("channel{i:02}"),
                unit: "bar".into(),
            })
            .collect();
        let table = CsvTable::new(
            Output::to_writer("sink", Box::new(std::io::sink())),
            &["benchmark".into()],
            &columns,
            100.0,
        )
        .unwrap();
        let grid = GridSpec {
            t0_ns: 0,
            rate_hz: 100.0,
            first_row: 0,
            last_row: None,
            lateness_ns: 500_000_000,
        };
        let specs = vec![
            ChannelSpec {
                interpolation: Interpolation::Linear,
                max_gap_ns: 3_000_000,
            };
            CHANNELS
        ];
        let started = Instant::now();
        let mut aligner = Aligner::new(grid, &specs, table);
        let mut largest_pending = 0;
        let mut pushed = 0u64;
        generate(seconds, |c, t, v| {
            aligner.push(c, t, Some(v)).unwrap();
            pushed += 1;
            if pushed % 1_000_000 == 0 {
                largest_pending = largest_pending.max(aligner.pending_rows());
            }
        });
        let (_, stats) = aligner.finish().unwrap();
        let total_s = started.elapsed().as_secs_f64();
        let rows = stats[0].rows_with_value + stats[0].rows_without_value;
        println!(
            "{hours:>5} h: {:.1} M samples aligned + written in {total_s:.2} s ({:.1} M samples/s; generator alone {generator_s:.2} s), {rows} rows, at most {largest_pending} rows pending, peak RSS {} KiB (checksum {checksum:.3e})",
            samples / 1e6,
            samples / total_s / 1e6,
            peak_rss_kib()
        );
    }
}
