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
//! Part 2 (`ACQ_BENCH_E2E=1`, writes a 1.3 GB log to a temporary
//! directory) times the real binary end to end: `acq align LOG --rig RIG`
//! on one hour of those 25 channels as a DAQ sends them, float32 signals in
//! two CAN FD frames per millisecond (16 + 9 channels), candump `-L` text.
//! That includes reading the text and decoding every frame.

use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use acq_analysis::align::table::{Column, CsvTable, ParquetAlignedTable};
use acq_analysis::align::{Aligner, ChannelSpec, GridSpec, RowSink};
use acq_error::AcqError;
use acq_io::output::Output;
use acq_io::output::TableFormat;
use acq_rig::Interpolation;

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

/// One hour of DAQ traffic as candump -L, with its DBC and rig.
fn write_fd_session(dir: &Path, seconds: u64) {
    let mut dbc = String::from("VERSION \"\"\n\nNS_ :\n\tSIG_VALTYPE_\n\nBS_:\n\nBU_: DAQ\n\n");
    let mut valtypes = String::new();
    let mut rig =
        String::from("[[bus]]\nname = \"daq\"\niface = \"can0\"\ndbc = [\"daq_fd.dbc\"]\n\n");
    for (id, name, first, count, bytes) in
        [(1792, "DAQ_FD_A", 1, 16, 64), (1793, "DAQ_FD_B", 17, 9, 48)]
    {
        dbc.push_str(&format!("BO_ {id} {name}: {bytes} DAQ\n"));
        for k in 0..count {
            let channel = first + k;
            dbc.push_str(&format!(
                " SG_ CH{channel:02} : {}|32@1- (1,0) [0|0] \"bar\" Vector__XXX\n",
                32 * k
            ));
            valtypes.push_str(&format!("SIG_VALTYPE_ {id} CH{channel:02} : 1;\n"));
            rig.push_str(&format!(
                "[[sensor]]\nname = \"channel{channel:02}\"\nkind = \"pressure\"\nrate_hz = 1000\ndbc = {{ message = \"{name}\", signal = \"CH{channel:02}\" }}\n\n"
            ));
        }
        dbc.push('\n');
    }
    dbc.push_str(&valtypes);
    std::fs::write(dir.join("daq_fd.dbc"), dbc).unwrap();
    std::fs::write(dir.join("rig.toml"), rig).unwrap();
    let mut out = std::io::BufWriter::with_capacity(
        1 << 20,
        std::fs::File::create(dir.join("fd.log")).unwrap(),
    );
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let hex = b"0123456789ABCDEF";
    let mut line = Vec::with_capacity(200);
    for tick in 0..seconds * 1000 {
        let t_us = 1_795_000_000_000_000u64 + tick * 1000;
        for (id, count, bytes) in [(0x700, 16, 64), (0x701, 9, 48)] {
            line.clear();
            let _ = write!(
                line,
                "({}.{:06}) can0 {:03X}##1",
                t_us / 1_000_000,
                t_us % 1_000_000,
                id
            );
            let mut payload = [0u8; 64];
            for k in 0..count {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let value = 100.0f32 + k as f32 + (state >> 44) as f32 * 1e-6;
                payload[4 * k..4 * k + 4].copy_from_slice(&value.to_le_bytes());
            }
            for b in &payload[..bytes] {
                line.push(hex[(b >> 4) as usize]);
                line.push(hex[(b & 15) as usize]);
            }
            line.push(b'\n');
            out.write_all(&line).unwrap();
        }
    }
    out.flush().unwrap();
}

fn end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let seconds = 3600;
    let started = Instant::now();
    write_fd_session(dir.path(), seconds);
    let log = dir.path().join("fd.log");
    let size = std::fs::metadata(&log).unwrap().len();
    println!(
        "end to end: wrote {:.2} GB of candump -L (1 h, 25 float32 channels at 1 kHz in 2 CAN FD frames/ms) in {:.1} s",
        size as f64 / 1e9,
        started.elapsed().as_secs_f64()
    );
    let binary = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/release/acq");
    let mut results = Vec::new();
    // Each format twice, interleaved: the machine is shared, so compare
    // runs made side by side.
    for name in [
        "aligned.csv",
        "aligned.parquet",
        "aligned.csv",
        "aligned.parquet",
    ] {
        let table = dir.path().join(name);
        let started = Instant::now();
        let output = Command::new(&binary)
            .arg("align")
            .arg(&log)
            .arg("--rig")
            .arg(dir.path().join("rig.toml"))
            .arg("-o")
            .arg(&table)
            .output()
            .expect("build the binary first: cargo build --release");
        let wall_s = started.elapsed().as_secs_f64();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let rss = nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_CHILDREN)
            .map(|u| u.max_rss())
            .unwrap_or(-1);
        let bytes = std::fs::metadata(&table).unwrap().len();
        println!(
            "end to end: acq align (read + decode + align + write 100 Hz {name}) of 90 M samples: {wall_s:.2} s, {:.1} MB, peak RSS of any child so far {rss} KiB; {}",
            bytes as f64 / 1e6,
            String::from_utf8_lossy(&output.stderr).trim()
        );
        results.push((wall_s, bytes));
    }
    let csv_s = results[0].0.min(results[2].0);
    let parquet_s = results[1].0.min(results[3].0);
    println!(
        "end to end: Parquet / CSV wall time {:.3} (best of 2 each: {parquet_s:.2} / {csv_s:.2} s); CSV / Parquet size {:.2} ({} / {} bytes)",
        parquet_s / csv_s,
        results[0].1 as f64 / results[1].1 as f64,
        results[0].1,
        results[1].1
    );
}

/// Counts what a table writes, and drops it.
struct CountingSink(std::sync::Arc<std::sync::atomic::AtomicU64>);

impl Write for CountingSink {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0
            .fetch_add(bytes.len() as u64, std::sync::atomic::Ordering::Relaxed);
        Ok(bytes.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Aligns `hours` of generated traffic into a CSV or Parquet table whose
/// bytes are counted and dropped; prints one line.
fn align_hours(hours: f64, format: TableFormat) {
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
    let grid = GridSpec {
        t0_ns: 1_795_000_000_000_000_000,
        rate_hz: 100.0,
        first_row: 0,
        last_row: None,
        lateness_ns: 500_000_000,
    };
    let bytes = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let output = Output::to_writer("sink", Box::new(CountingSink(bytes.clone())));
    let comments = ["benchmark".to_string()];
    let table: Box<dyn RowSink<Error = AcqError>> = match format {
        TableFormat::Csv => {
            Box::new(CsvTable::new(output, &comments, &columns, grid.rate_hz).unwrap())
        }
        TableFormat::Parquet => {
            Box::new(ParquetAlignedTable::new(output, &comments, &columns, grid).unwrap())
        }
        TableFormat::Mf4 => unreachable!("the benchmark writes CSV and Parquet"),
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
        aligner.push(c, grid.t0_ns + t, Some(v)).unwrap();
        pushed += 1;
        if pushed % 1_000_000 == 0 {
            largest_pending = largest_pending.max(aligner.pending_rows());
        }
    });
    let (_, stats) = aligner.finish().unwrap();
    let total_s = started.elapsed().as_secs_f64();
    let rows = stats[0].rows_with_value + stats[0].rows_without_value;
    println!(
        "{format:?} {hours:>5} h: {:.1} M samples aligned + written in {total_s:.2} s ({:.1} M samples/s; generator alone {generator_s:.2} s), {rows} rows, {:.1} MB written, at most {largest_pending} rows pending, peak RSS {} KiB (checksum {checksum:.3e})",
        samples / 1e6,
        samples / total_s / 1e6,
        bytes.load(std::sync::atomic::Ordering::Relaxed) as f64 / 1e6,
        peak_rss_kib()
    );
}

fn main() {
    if std::env::var_os("ACQ_BENCH_E2E").is_some() {
        end_to_end();
        return;
    }
    println!("align benchmark: {CHANNELS} channels at {RATE_HZ} Hz -> 100 Hz grid, into a CSV or Parquet table whose bytes are counted and dropped");
    for format in [TableFormat::Csv, TableFormat::Parquet] {
        for hours in [0.25, 1.0, 2.0] {
            align_hours(hours, format);
        }
    }
}
