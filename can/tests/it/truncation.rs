//! A log cut short is never read as complete: every file of every format,
//! cut at every byte (text logs: inside their last line, or before the end
//! of their trigger block), reads either all of its frames or stops with an
//! error. A cut that silently gave fewer frames would be data missing
//! without a word (the BLF reader did so for a file cut inside its header
//! or an object's).

use std::path::Path;

use acq_can::log::{LogReader, ReadError};

/// Frames read, and whether reading stopped at an error.
fn read(bytes: &[u8]) -> (usize, bool) {
    let Ok((mut reader, _)) = LogReader::detect(bytes) else {
        return (0, true);
    };
    let mut frames = 0;
    let mut failed = false;
    // Readers go on after a parse error; a cut file must give at least one.
    for _ in 0..100_000 {
        match reader.next_record() {
            Ok(Some(_)) => frames += 1,
            Ok(None) => return (frames, failed),
            Err(ReadError::Parse(_) | ReadError::Io(_)) => failed = true,
        }
    }
    panic!("no end after 100,000 records");
}

/// Every cut from 1 byte on (an empty file states nothing); `at_line_ends`
/// also at the end of a line (where a candump log, which has no structure
/// beyond its lines, is a complete shorter log).
fn every_cut_is_complete_or_an_error(name: &str, bytes: &[u8], at_line_ends: bool) {
    let (whole, failed) = read(bytes);
    assert!(!failed && whole > 0, "{name}: the whole file must read");
    for cut in 1..bytes.len() {
        if !at_line_ends && bytes[cut - 1] == b'\n' {
            continue;
        }
        let (frames, failed) = read(&bytes[..cut]);
        assert!(
            failed || frames == whole,
            "{name} cut at byte {cut} of {}: {frames} of {whole} frames and no error",
            bytes.len()
        );
    }
}

fn seed(path: &str) -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../fuzz/seeds")
            .join(path),
    )
    .unwrap()
}

#[test]
fn blf_cut_anywhere_is_complete_or_an_error() {
    for file in ["python_can_stored.blf", "python_can_zlib.blf"] {
        every_cut_is_complete_or_an_error(file, &seed(&format!("blf_log/{file}")), true);
    }
}

#[test]
fn mf4_cut_anywhere_is_complete_or_an_error() {
    for file in [
        "acq.mf4",
        "python_can_stored.mf4",
        "python_can_deflate.mf4",
        "python_can_transposed.mf4",
    ] {
        every_cut_is_complete_or_an_error(file, &seed(&format!("mf4_log/{file}")), true);
    }
}

#[test]
fn text_logs_cut_anywhere_are_complete_or_an_error() {
    let candump = "(1763719200.000100) can0 123#11223344\n\
                   (1763719200.000250) can1 1ABCDEF0#0102030405060708\n\
                   (1763719200.003000) can0 321##5AABBCCDDEEFF001122334455\n";
    every_cut_is_complete_or_an_error("candump", candump.as_bytes(), false);
    let asc = "date Tue Mar 4 09:15:02.512 am 2025\n\
               base hex  timestamps absolute\n\
               Begin Triggerblock Tue Mar 4 09:15:02.512 am 2025\n\
               \x20  0.010214 1  18FEF100x       Rx   d 8 FF FF 00 12 34 FF FF FF\n\
               \x20  0.011000 1  181             Tx   d 2 A0 0F\n\
               End TriggerBlock\n";
    every_cut_is_complete_or_an_error("asc", asc.as_bytes(), true);
}
