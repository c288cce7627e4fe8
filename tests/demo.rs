//! `acq demo`: the whole chain on the shipped sessions, on the in-process
//! bus, checked end to end (tests/common/pipeline.rs), and its output
//! directory handling. The same chain on a real vcan is in tests/vcan.rs.

mod common;

use common::{acq, stderr, stdout};

#[test]
fn the_demo_runs_the_whole_chain_and_its_report_renders() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let out_text = out.to_str().unwrap();
    let output = acq(&["demo", "--out", out_text]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert_eq!(
        stdout(&output).lines().last(),
        Some(format!("report: {out_text}/report.html").as_str()),
        "it says where the report is"
    );
    common::pipeline::check_demo_output(&out, true);

    // A second run replaces its own earlier output...
    let output = acq(&[
        "demo",
        "--out",
        out_text,
        "--sessions",
        &format!("{out_text}/sessions"),
    ]);
    assert!(
        !output.status.success(),
        "the sessions to analyse are inside the directory it clears"
    );
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    let copy = dir.path().join("recorded");
    std::fs::rename(out.join("sessions"), &copy).unwrap();
    let output = acq(&[
        "demo",
        "--out",
        out_text,
        "--sessions",
        copy.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    common::pipeline::check_demo_output(&out, false);
    assert!(
        !out.join("sessions").exists(),
        "nothing of the first run is left"
    );

    // ...but never a directory it did not write.
    let other = dir.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("notes.txt"), "mine").unwrap();
    let output = acq(&["demo", "--out", other.to_str().unwrap(), "--acquire-only"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("not a previous demo's output"),
        "{}",
        stderr(&output)
    );
    assert_eq!(
        std::fs::read_to_string(other.join("notes.txt")).unwrap(),
        "mine"
    );
}

#[test]
fn bad_demo_arguments_say_what_is_expected() {
    let output = acq(&[
        "demo",
        "--iface",
        "vcan0",
        "--acquire-only",
        "--out",
        "/nonexistent-acq/x",
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("give two interfaces"),
        "{}",
        stderr(&output)
    );
    let output = acq(&["demo", "--data", "/tmp", "--out", "/nonexistent-acq/x"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("no fixtures/sessions"),
        "{}",
        stderr(&output)
    );
}
