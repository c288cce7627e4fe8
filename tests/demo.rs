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
    gtn_line_marks_the_bounds(&stdout(&output), &out);
    the_guide_quotes_this_demo(&stdout(&output));

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

/// The figures README.md and docs/src/demo.md give for the demo are the
/// ones it prints: on the in-process bus the demo gives the same numbers on
/// every run, so a figure the guide quotes cannot drift from the code (or
/// from another run, on a busy machine or a quiet one).
fn the_guide_quotes_this_demo(said: &str) {
    let words = [
        "none", "one", "two", "three", "four", "five", "six", "seven", "eight",
    ];
    let mut figures = Vec::new();
    for line in said.lines() {
        // "case1: largest error 22.07 % -> 5.87 % at the search's pick ..."
        if let Some((_, rest)) = line.split_once(": largest error ") {
            figures.push(rest.split(" at ").next().unwrap().to_string());
        }
        // "best MAPE 1.736 % after 16 simulations (4.9 s)"
        if let Some(rest) = line.strip_prefix("best MAPE ") {
            figures.push(rest.split(" (").next().unwrap().to_string());
        }
    }
    // "on a bound of its range: q2, q3, epsN, sN, fN, f0 (of 8 parameters): ..."
    let gtn_bounds = said
        .lines()
        .filter(|l| l.starts_with("on a bound of its range: q"))
        .find_map(|l| l.split_once(": ")?.1.split_once(" (of "))
        .map(|(names, _)| names.split(", ").count())
        .expect("the GTN stage names the parameters on a bound");
    figures.push(format!(
        "{} of its eight parameters on a bound",
        words[gtn_bounds]
    ));
    assert_eq!(figures.len(), 4, "{said}");
    for page in ["README.md", "docs/src/demo.md"] {
        let text = std::fs::read_to_string(common::root().join(page)).unwrap();
        let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
        for figure in &figures {
            // demo.md leaves the bounds to the report.
            if page.ends_with("demo.md") && figure.contains("on a bound") {
                continue;
            }
            assert!(
                text.contains(figure.as_str()),
                "{page} does not quote the demo's `{figure}`"
            );
        }
    }
}

/// The GTN stage's parameters line marks each parameter calibrated within
/// 1 % of a bound of its published range (tensile-gtn.md's table; m is
/// left out, its upper bound comes from the test's own curve), and the line
/// before it names them: a point on six bounds is no estimate, and the terminal
/// must not read as if it were one.
fn gtn_line_marks_the_bounds(said: &str, out: &std::path::Path) {
    let lines: Vec<&str> = said.lines().collect();
    let at = lines
        .iter()
        .position(|l| l.starts_with("calibrated: q1 = "))
        .unwrap_or_else(|| panic!("no GTN parameters line in:\n{said}"));
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("tensile_p91_20c/calibration/summary.json")).unwrap(),
    )
    .unwrap();
    let mut on_bounds = 0;
    for &(name, lower, upper) in common::GTN_BOUNDS.iter().filter(|(name, ..)| *name != "m") {
        let value = summary["best_params"][name].as_f64().unwrap();
        let unit = (value - lower) / (upper - lower);
        let item = lines[at]
            .split(", ")
            .map(|i| i.trim_start_matches("calibrated: "))
            .find(|i| i.starts_with(&format!("{name} = ")))
            .unwrap_or_else(|| panic!("{name} missing: {}", lines[at]));
        let expected = if unit < 0.01 {
            Some("(lower bound)")
        } else if unit > 0.99 {
            Some("(upper bound)")
        } else {
            None
        };
        on_bounds += usize::from(expected.is_some());
        match expected {
            Some(mark) => assert!(
                item.ends_with(mark),
                "{item}: {value} in [{lower}, {upper}]"
            ),
            None => assert!(
                !item.contains("bound"),
                "{item}: {value} in [{lower}, {upper}]"
            ),
        }
    }
    // m as the line marks it (its range is the preset's, from the curve).
    let m_marked = lines[at]
        .split(", ")
        .any(|i| i.starts_with("m = ") && i.ends_with("bound)"));
    let counted = on_bounds + usize::from(m_marked);
    if counted > 0 {
        let named = lines[at - 1]
            .strip_prefix("on a bound of its range: ")
            .and_then(|rest| rest.split(" (of 8 parameters)").next())
            .unwrap_or_else(|| panic!("no bound line before: {}", lines[at - 1]));
        assert_eq!(named.split(", ").count(), counted, "{}", lines[at - 1]);
    }
}
