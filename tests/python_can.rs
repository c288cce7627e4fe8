//! acq's logs against python-can, the reference most test engineers already
//! run: python-can reads every ASC file `acq convert` writes as the frames
//! of the source log, and acq reads python-can's ASC, BLF and candump files
//! as the frames python-can wrote (MF4: `can/tests/it/mf4.rs`).
//! python-can lives in a scratch virtualenv the test makes (never a
//! dependency of acq); without it the test fails.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{acq, path_arg, stderr, EVERY_KIND_OF_FRAME as SOURCE};

/// The scratch virtualenv with python-can.
fn python() -> PathBuf {
    common::scratch_python("can-logs")
}

/// python-can's frames of a log, one JSON object each.
fn python_can_frames(python: &Path, log: &Path) -> Vec<serde_json::Value> {
    let output = Command::new(python)
        .arg(common::root().join("tests/python_can/frames.py"))
        .args(["read", path_arg(log)])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    String::from_utf8_lossy(&output.stdout)
        .lines()
        .map(|line| serde_json::from_str(line).unwrap())
        .collect()
}

#[test]
fn python_can_and_acq_read_each_others_asc_as_the_source_frames() {
    let python = python();
    let dir = tempfile::tempdir().unwrap();
    let source = dir.path().join("source.log");
    std::fs::write(&source, SOURCE).unwrap();
    let expected = python_can_frames(&python, &source);
    assert_eq!(expected.len(), 10);

    // acq writes ASC; python-can reads the source's frames from it.
    let ours = dir.path().join("acq.asc");
    let output = acq(&["convert", path_arg(&source), "-o", path_arg(&ours)]);
    assert!(output.status.success(), "{}", stderr(&output));
    let read = python_can_frames(&python, &ours);
    assert_eq!(read.len(), expected.len());
    for (got, want) in read.iter().zip(&expected) {
        assert_eq!(got, want, "python-can on acq's ASC");
    }

    // python-can writes ASC; acq reads it and writes candump: the source.
    acq_reads_what_python_can_wrote(&python, &source, "asc");

    // And acq's own round trip, candump -> ASC -> candump, is exact.
    let again = dir.path().join("again.log");
    let output = acq(&["convert", path_arg(&ours), "-o", path_arg(&again)]);
    assert!(output.status.success(), "{}", stderr(&output));
    // (An ASC error frame has no direction.)
    assert_eq!(
        std::fs::read_to_string(&again).unwrap(),
        SOURCE
            .replace("20000080#0000000000000000 R", "20000080#0000000000000000")
            .replace("010#DEADBEEF\n", "010#DEADBEEF R\n")
    );
}

/// python-can writes the source as `format`; acq converts that to candump,
/// which must be the source. python-can dates an ASC file when it writes it
/// and rounds a BLF start to the millisecond, so times agree relative to the
/// first frame (BLF within 2 us: python-can's float arithmetic). Neither
/// format keeps an error frame's class, details or
/// direction: acq reads one as CAN_ERR_BUSERROR with zero details.
fn acq_reads_what_python_can_wrote(python: &Path, source: &Path, format: &str) {
    let dir = source.parent().unwrap();
    let theirs = dir.join(format!("python-can.{format}"));
    let output = Command::new(python)
        .arg(common::root().join("tests/python_can/frames.py"))
        .args([format, path_arg(source), path_arg(&theirs)])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    let back = dir.join(format!("back-from-{format}.log"));
    let output = acq(&["convert", path_arg(&theirs), "-o", path_arg(&back)]);
    assert!(output.status.success(), "{format}: {}", stderr(&output));
    let back_text = std::fs::read_to_string(&back).unwrap();
    let split = |line: &str| -> (f64, String) {
        let (time, rest) = line.split_once(' ').unwrap();
        (
            time.trim_matches(|c| c == '(' || c == ')').parse().unwrap(),
            rest.to_string(),
        )
    };
    let (first_back, _) = split(back_text.lines().next().unwrap());
    let (first_source, _) = split(SOURCE.lines().next().unwrap());
    for (line, (got, want)) in back_text.lines().zip(SOURCE.lines()).enumerate() {
        let ((got_time, got_rest), (want_time, want_rest)) = (split(got), split(want));
        let offset_us = |t: f64, first: f64| ((t - first) * 1e6).round();
        // python-can stores BLF times as int((t - start) * 1e9) of float
        // epoch seconds, whose last bits are worth 0.24 us, and candump
        // keeps whole microseconds: within 2 us. ASC keeps them exactly.
        let tolerance_us = if format == "blf" { 2.0 } else { 0.0 };
        let difference = offset_us(got_time, first_back) - offset_us(want_time, first_source);
        assert!(
            difference.abs() <= tolerance_us,
            "{format} line {}: {got} is {difference} us off",
            line + 1
        );
        if want.contains(" 20000080#") {
            assert_eq!(got_rest, "can0 20000080#0000000000000000", "{format}");
        } else if want_rest.ends_with(" R") || want_rest.ends_with(" T") {
            assert_eq!(got_rest, want_rest, "{format} line {}", line + 1);
        } else {
            // python-can writes a frame without a direction as received.
            assert_eq!(
                got_rest,
                format!("{want_rest} R"),
                "{format} line {}",
                line + 1
            );
        }
    }
    assert_eq!(
        back_text.lines().count(),
        SOURCE.lines().count(),
        "{format}"
    );
}

#[test]
fn acq_reads_python_can_blf_as_the_source_frames() {
    let python = python();
    let dir = tempfile::tempdir().unwrap();
    let source = dir.path().join("source.log");
    std::fs::write(&source, SOURCE).unwrap();
    acq_reads_what_python_can_wrote(&python, &source, "blf");
}

/// python-can's candump writer keeps less than candump does (a remote
/// frame's length, the FD flags but BRS, an error frame's channel and
/// bytes), so the check is against python-can's own reading of its file:
/// acq reads python-can's candump log as the frames python-can sees in it.
#[test]
fn acq_reads_python_can_candump_as_python_can_does() {
    let python = python();
    let dir = tempfile::tempdir().unwrap();
    let source = dir.path().join("source.log");
    std::fs::write(&source, SOURCE).unwrap();
    let theirs = dir.path().join("python-can.log");
    let output = Command::new(&python)
        .arg(common::root().join("tests/python_can/frames.py"))
        .args(["log", path_arg(&source), path_arg(&theirs)])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    let back = dir.path().join("back.log");
    let output = acq(&["convert", path_arg(&theirs), "-o", path_arg(&back)]);
    assert!(output.status.success(), "{}", stderr(&output));
    let expected = python_can_frames(&python, &theirs);
    assert_eq!(expected.len(), SOURCE.lines().count());
    assert_eq!(python_can_frames(&python, &back), expected);
}
