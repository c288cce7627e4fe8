//! Reads a log (any format acq reads, detected from its content) and prints
//! its frames, or with `--count` how many and how fast (`--batch`: read
//! column by column, [`LogReader::next_batch`]), or with `--mf4 OUT`
//! writes them to OUT as MF4: a check, a measurement and a seed maker that
//! need only acq-can built.
//!
//!     cargo run --release -p acq-can --example log_frames -- [--count [--batch] | --mf4 OUT] FILE

use std::fs::File;
use std::io::BufReader;
use std::time::Instant;

use acq_can::log::mf4_write::Mf4Writer;
use acq_can::{FrameBatch, LogReader, ReadError};

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let count_only = args.iter().any(|a| a == "--count");
    let batched = args.iter().any(|a| a == "--batch");
    args.retain(|a| a != "--count" && a != "--batch");
    let mut mf4 = match args.iter().position(|a| a == "--mf4") {
        Some(at) if at + 1 < args.len() => {
            let out = args.remove(at + 1);
            args.remove(at);
            let file = File::create(&out).unwrap_or_else(|e| panic!("{out}: {e}"));
            Some(Mf4Writer::new(std::io::BufWriter::new(file)))
        }
        _ => None,
    };
    let Some(path) = args.first() else {
        eprintln!("usage: log_frames [--count [--batch] | --mf4 OUT] FILE");
        std::process::exit(2);
    };
    let started = Instant::now();
    let file = File::open(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let len = file.metadata().map(|meta| meta.len()).ok();
    let (mut reader, format) =
        LogReader::detect(BufReader::with_capacity(256 * 1024, file)).expect("read");
    if let Some(len) = len {
        reader.expect_len(len);
    }
    let mut frames = 0u64;
    let mut batch = FrameBatch::default();
    let mut more = true;
    while batched && more {
        batch.clear();
        let next = reader.next_batch(&mut batch, 1 << 16);
        frames += batch.len() as u64;
        match next {
            Ok(next) => more = next,
            Err(ReadError::Parse(e)) => eprintln!("{}", e.in_file(path)),
            Err(ReadError::Io(e)) => panic!("{path}: {e}"),
        }
    }
    while !batched && more {
        match reader.next_record() {
            Ok(Some(record)) => {
                frames += 1;
                if let Some(writer) = &mut mf4 {
                    writer.write_frame(&record.frame).expect("write");
                } else if !count_only {
                    println!(
                        "{} {:?}",
                        String::from_utf8_lossy(record.timestamp_text),
                        record.frame
                    );
                }
            }
            Ok(None) => more = false,
            Err(ReadError::Parse(e)) => eprintln!("{}", e.in_file(path)),
            Err(ReadError::Io(e)) => panic!("{path}: {e}"),
        }
    }
    if let Some(writer) = mf4 {
        writer.finish().expect("write");
    }
    if count_only {
        let seconds = started.elapsed().as_secs_f64();
        println!(
            "{format:?} {frames} frames in {seconds:.4} s: {:.0} frames/s",
            frames as f64 / seconds
        );
    }
}
