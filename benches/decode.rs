//! Throughput and memory of `acq decode` through a DBC (issue target: at
//! least 3 million frames/s on one core; memory flat in the log's size).
//!
//! `cargo bench --bench decode` runs both parts:
//! 1. in-process: a generated candump log (excavator DAQ traffic, float32
//!    signals, 2 per frame) held in memory, decoded to a discarding sink;
//!    best of 5 runs, frames/s on the one core the decoder uses;
//! 2. the real binary fed by a pipe with `ACQ_BENCH_STREAM_GB` GB of log
//!    (default 1; 5 for the streaming-memory check), peak RSS read from /proc.
//!
//! Results go to stdout in the form BENCHMARKS.md records.

use std::io::{BufRead, Cursor, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Instant;

use acq_analysis::decode::{decode_with_dbc, DbcDecodeOptions};
use acq_can::dbc::DbcDatabase;
use acq_io::input::{log_from_reader, BadLines};
use acq_io::output::Output;

const DBC: &str = "fixtures/dbc/somat_excavator.dbc";

/// Deterministic DAQ traffic: the 10 messages of the DBC in turn, 100 us
/// apart, with slowly varying float32 payloads.
fn generate(frames: usize, out: &mut Vec<u8>) {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    for i in 0..frames {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let t_us = 1_763_719_200_000_000u64 + i as u64 * 100;
        let id = if i % 10 == 0 { 0x300 } else { 0x30F + i % 10 };
        let a = ((state & 0xFFFF) as f32 - 32768.0) / 40.0;
        let b = (((state >> 16) & 0xFFFF) as f32 - 32768.0) / 40.0;
        let mut data = [0u8; 8];
        data[..4].copy_from_slice(&a.to_le_bytes());
        data[4..].copy_from_slice(&b.to_le_bytes());
        let _ = write!(
            out,
            "({:010}.{:06}) can1 {:03X}#",
            t_us / 1_000_000,
            t_us % 1_000_000,
            id
        );
        for byte in data {
            let _ = write!(out, "{byte:02X}");
        }
        out.push(b'\n');
    }
}

fn in_process(database: &DbcDatabase) {
    let frames = 2_000_000;
    let mut log = Vec::with_capacity(frames * 50);
    generate(frames, &mut log);
    let log: &'static [u8] = log.leak();
    let mut best = f64::MAX;
    let mut rows = 0;
    for _ in 0..5 {
        let reader: Box<dyn BufRead + Send> = Box::new(Cursor::new(log));
        let mut inputs = vec![log_from_reader("bench", reader).unwrap()];
        let mut output = Output::to_writer("sink", Box::new(std::io::sink()));
        let options = DbcDecodeOptions {
            bad_lines: BadLines::Stop,
            labels: false,
        };
        let start = Instant::now();
        let summary = decode_with_dbc(&mut inputs, database, options, &mut output).unwrap();
        output.finish().unwrap();
        best = best.min(start.elapsed().as_secs_f64());
        assert_eq!(summary.decoded, frames as u64);
        rows = summary.rows;
    }
    println!(
        "in-process: {frames} frames ({:.1} MB, {rows} values) in {:.3} s = {:.2} M frames/s (best of 5)",
        log.len() as f64 / 1e6,
        best,
        frames as f64 / best / 1e6
    );
}

fn peak_rss_kib(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

fn streamed(gigabytes: f64) {
    let binary = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/release/acq");
    if !binary.exists() {
        println!("streamed: skipped, build target/release/acq first (cargo build --release)");
        return;
    }
    let mut child = Command::new(&binary)
        .args(["decode", "-", "--dbc", DBC, "-o", "/dev/null"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    let mut stdin = child.stdin.take().unwrap();
    let mut chunk = Vec::new();
    generate(200_000, &mut chunk);
    let target = (gigabytes * 1e9) as u64;
    let mut written = 0u64;
    let mut samples = Vec::new();
    let start = Instant::now();
    while written < target {
        stdin.write_all(&chunk).unwrap();
        written += chunk.len() as u64;
        if let Some(kib) = peak_rss_kib(pid) {
            if samples
                .last()
                .is_none_or(|&(w, _)| written - w > target / 10)
            {
                samples.push((written, kib));
            }
        }
    }
    let final_peak = peak_rss_kib(pid).unwrap_or(0);
    drop(stdin);
    let output = child.wait_with_output().unwrap();
    let elapsed = start.elapsed().as_secs_f64();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let frames = written / (chunk.len() as u64 / 200_000);
    println!(
        "streamed: {:.2} GB ({} M frames) through a pipe in {:.1} s ({:.2} M frames/s incl. generation); peak RSS {:.1} MB",
        written as f64 / 1e9,
        frames / 1_000_000,
        elapsed,
        frames as f64 / elapsed / 1e6,
        final_peak as f64 / 1024.0
    );
    let trail: Vec<String> = samples
        .iter()
        .map(|(w, k)| format!("{:.2} GB: {:.1} MB", *w as f64 / 1e9, *k as f64 / 1024.0))
        .collect();
    println!("streamed: peak RSS as the log grew: {}", trail.join(", "));
}

fn main() {
    // `cargo bench` passes --bench; nothing to parse.
    std::env::set_current_dir(env!("CARGO_MANIFEST_DIR")).unwrap();
    let (database, _) = DbcDatabase::load(Path::new(DBC)).unwrap();
    in_process(&database);
    let gigabytes = std::env::var("ACQ_BENCH_STREAM_GB")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1.0);
    streamed(gigabytes);
}
