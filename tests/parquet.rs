//! `-o X.parquet` on decode, align and extract, read by the tools a test
//! engineer's colleagues use: pyarrow (pandas, DuckDB, Spark's Arrow path)
//! and polars (an independent Parquet reader). Every table must equal the
//! CSV acq writes for the same command, cell for cell, with time as a UTC
//! timestamp and units in the column metadata (tests/parquet/compare.py).
//! The readers live in a scratch virtualenv the test makes (never a
//! dependency of acq); without it the test fails.

mod common;
// `acq lake ingest`, read by the same engines and DuckDB.
#[path = "parquet/lake.rs"]
mod lake;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{acq, path_arg, stderr};

/// The scratch virtualenv with the readers.
fn python() -> PathBuf {
    common::scratch_python("parquet")
}

/// Runs acq twice, to `NAME.csv` and `NAME.parquet`, and has the readers
/// compare the two. Returns compare.py's `rows R columns C nulls N`.
fn both_ways(python: &Path, dir: &Path, name: &str, args: &[&str], time: &str) -> Vec<u64> {
    let mut written = Vec::new();
    for extension in ["csv", "parquet"] {
        let path = dir.join(format!("{name}.{extension}"));
        let mut full: Vec<&str> = args.to_vec();
        full.extend(["-o", path_arg(&path)]);
        let output = acq(&full);
        assert!(output.status.success(), "{full:?}: {}", stderr(&output));
        assert!(
            !dir.join(format!("{name}.{extension}.partial")).exists(),
            "a .partial was left"
        );
        written.push(path);
    }
    let parquet = std::fs::read(&written[1]).unwrap();
    assert!(parquet.starts_with(b"PAR1") && parquet.ends_with(b"PAR1"));
    let output = Command::new(python)
        .arg(common::root().join("tests/parquet/compare.py"))
        .args([path_arg(&written[1]), path_arg(&written[0]), time])
        .output()
        .unwrap();
    assert!(output.status.success(), "{name}: {}", stderr(&output));
    let text = String::from_utf8_lossy(&output.stdout);
    let numbers: Vec<u64> = text
        .split_whitespace()
        .filter_map(|word| word.parse().ok())
        .collect();
    assert_eq!(numbers.len(), 3, "{text}");
    numbers
}

#[test]
fn parquet_tables_equal_the_csv_in_pyarrow_and_polars() {
    let python = python();
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let log = "fixtures/logs/excavator_case1.log";

    // decode, DBC route with labels: text, floats, a nullable label.
    let [rows, columns, nulls] = both_ways(
        &python,
        dir,
        "dbc",
        &[
            "decode",
            log,
            "--dbc",
            "fixtures/dbc/somat_excavator.dbc",
            "--labels",
        ],
        "absolute",
    )[..] else {
        unreachable!()
    };
    assert_eq!(columns, 8);
    assert!(rows > 50 && nulls > 0, "{rows} rows, {nulls} nulls");

    // decode, rig route.
    let numbers = both_ways(
        &python,
        dir,
        "rig",
        &["decode", log, "--rig", "fixtures/rigs/excavator.toml"],
        "absolute",
    );
    assert!(numbers[0] > 50 && numbers[1] == 4, "{numbers:?}");

    // align at 2 kHz: 30,000 rows, more than one batch; gaps are nulls.
    let numbers = both_ways(
        &python,
        dir,
        "aligned",
        &[
            "align",
            "fixtures/sessions/excavator_case1",
            "--rate",
            "2000",
        ],
        "relative",
    );
    assert!(numbers[0] > 20_000, "{numbers:?}");
    assert!(numbers[2] > 0, "a recording's start has gaps: {numbers:?}");

    // extract: the measured values of the holds, and a tensile curve.
    let numbers = both_ways(
        &python,
        dir,
        "measured",
        &["extract", "fixtures/sessions/excavator_case2"],
        "absolute",
    );
    // 17 columns: the statistics, the budget's u_c, k, U95 and shared
    // parts, flags, note.
    assert!(numbers[0] > 5 && numbers[1] == 17, "{numbers:?}");
    let numbers = both_ways(
        &python,
        dir,
        "curve",
        &["extract", "fixtures/sessions/tensile_p91_20c", "--tensile"],
        "absolute",
    );
    assert!(numbers[0] > 100 && numbers[1] == 6, "{numbers:?}");
}

#[test]
fn a_parquet_decode_stopped_by_a_bad_line_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bad.log");
    let good =
        std::fs::read_to_string(common::root().join("fixtures/logs/excavator_case1.log")).unwrap();
    std::fs::write(&log, format!("{good}(1763719300.0) can0 12G#00\n")).unwrap();
    let out = dir.path().join("out.parquet");
    let output = acq(&[
        "decode",
        path_arg(&log),
        "--rig",
        "fixtures/rigs/excavator.toml",
        "-o",
        path_arg(&out),
    ]);
    assert_eq!(output.status.code(), Some(3), "{}", stderr(&output));
    let lines = good.lines().count();
    assert!(
        stderr(&output).contains(&format!("bad.log:{}:", lines + 1)),
        "{}",
        stderr(&output)
    );
    // A derived file appears only when complete: neither the table nor
    // its .partial is left, and the message says so.
    assert!(!out.exists() && !dir.path().join("out.parquet.partial").exists());
    assert!(
        stderr(&output).contains("is not written"),
        "{}",
        stderr(&output)
    );
}
