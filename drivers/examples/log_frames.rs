//! Reads a log (any format acq reads, detected from its content) and prints
//! its frames, or with `--count` how many and how fast: a check and a
//! measurement that need only acq-drivers built.
//!
//!     cargo run --release -p acq-drivers --example log_frames -- [--count] FILE

use std::fs::File;
use std::io::BufReader;
use std::time::Instant;

use acq_drivers::{LogReader, ReadError};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let count_only = args.iter().any(|a| a == "--count");
    let Some(path) = args.iter().find(|a| *a != "--count") else {
        eprintln!("usage: log_frames [--count] FILE");
        std::process::exit(2);
    };
    let started = Instant::now();
    let file = File::open(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let (mut reader, format) =
        LogReader::detect(BufReader::with_capacity(256 * 1024, file)).expect("read");
    let mut frames = 0u64;
    loop {
        match reader.next_record() {
            Ok(Some(record)) => {
                frames += 1;
                if !count_only {
                    println!("{} {:?}", record.timestamp_text, record.frame);
                }
            }
            Ok(None) => break,
            Err(ReadError::Parse(e)) => eprintln!("{path}:{}: expected {}", e.line, e.expected),
            Err(ReadError::Io(e)) => panic!("{path}: {e}"),
        }
    }
    if count_only {
        let seconds = started.elapsed().as_secs_f64();
        println!(
            "{format:?} {frames} frames in {seconds:.3} s: {:.0} frames/s",
            frames as f64 / seconds
        );
    }
}
