//! Arbitrary values in every field of an external spec and an excavator
//! case file: loading never panics, and whatever loads can be run without
//! a panic or an overflow (the checks are at the boundary, not later).

use std::path::Path;
use std::time::{Duration, Instant};

use acq_study::spec::{ModelKind, Spec};
use acq_study::study::{Measured, Role};
use acq_twins::excavator::case::CaseFile;
use acq_twins::excavator::geometry::Geometry;
use acq_twins::excavator::Excavator;
use acq_workflows::calibrate::models::BUILTIN_MODELS;
use proptest::prelude::*;

/// What careless hands put in a TOML value.
const NASTY: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e19",
    "1e300",
    "-5",
    "0",
    "1",
    "0.5",
    "18446744073709551615",
    "\"\"",
    "\"..\"",
    "\"../../evaluations.csv\"",
    "\"/etc/passwd\"",
    "\"voodoo\"",
    "\"lhs\"",
    "[]",
    "[1, 1]",
    "[121, 121]",
    "[5000, -5000]",
    "[nan, 1]",
    "true",
];

const SPEC: &str = r#"command = ["sh", "solver.sh", "{x}", "{out}"]
output_file = "out.json"
timeout_s = 10.0
retries = 1
parallel = 2

[[parameter]]
name = "x"
lower = 0.0
upper = 10.0

[[output]]
name = "y"
measured = 5.0

[search]
start = "lhs"
start_runs = 4
max_evals = 10
target_loss_pct = 1.0
loss = "mean"
"#;

/// The spec with the value of the `index`-th `key = value` line replaced.
fn with_value(text: &str, index: usize, value: &str) -> String {
    let mut seen = 0;
    text.lines()
        .map(|line| {
            if let Some((key, _)) = line.split_once(" = ") {
                seen += 1;
                if seen == index + 1 {
                    return format!("{key} = {value}");
                }
            }
            line.to_string()
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn assignments(text: &str) -> usize {
    text.lines().filter(|l| l.contains(" = ")).count()
}

#[test]
fn the_unedited_files_load() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("solver.sh"), "exit 0\n").unwrap();
    let path = dir.path().join("spec.toml");
    std::fs::write(&path, SPEC).unwrap();
    Spec::load(&path, &BUILTIN_MODELS).unwrap();
    // One nasty value at a time: each field is checked (1e19 s is no timeout).
    std::fs::write(&path, with_value(SPEC, 2, "1e19")).unwrap();
    assert!(Spec::load(&path, &BUILTIN_MODELS)
        .unwrap_err()
        .to_string()
        .contains("timeout_s"));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn any_spec_field_loads_or_is_refused_and_what_loads_runs(
        edits in prop::collection::vec((0..assignments(SPEC), 0..NASTY.len()), 1..4)
    ) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("solver.sh"), "exit 0\n").unwrap();
        let mut text = SPEC.to_string();
        for (field, value) in &edits {
            text = with_value(&text, *field, NASTY[*value]);
        }
        let path = dir.path().join("spec.toml");
        std::fs::write(&path, &text).unwrap();
        if let Ok(spec) = Spec::load(&path, &BUILTIN_MODELS) {
            // What the runner does with the numbers must not panic.
            let ModelKind::Command(command) = &spec.model else {
                return Err(TestCaseError::fail(format!("a command spec loaded as another model: {text}")));
            };
            let timeout = Duration::try_from_secs_f64(command.timeout_s);
            prop_assert!(timeout.is_ok(), "{text}");
            prop_assert!(Instant::now().checked_add(timeout.unwrap()).is_some(), "{text}");
            prop_assert!((1..=256).contains(&spec.runs_at_once), "{text}");
            prop_assert!(spec.search.max_evals <= 100_000, "{text}");
            let inside = acq_io::output::inside(Path::new("run"), &command.output_file, "output_file");
            prop_assert!(inside.is_ok(), "{text}");
            for (_, observation) in spec.study.observations(Role::Fit) {
                if let Measured::Scalar { value, .. } = observation.measured {
                    prop_assert!(value.is_finite() && value != 0.0, "{text}");
                }
            }
            for parameter in &spec.study.parameters {
                prop_assert!(parameter.search.lower < parameter.search.upper, "{text}");
            }
        }
    }

    #[test]
    fn any_case_field_parses_or_is_refused_and_what_parses_evaluates(
        edits in prop::collection::vec((0..12usize, 0..NASTY.len()), 1..4)
    ) {
        let case = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/excavator/case1.toml"),
        )
        .unwrap();
        let mut text = case;
        for (field, value) in &edits {
            text = with_value(&text, *field % assignments(&text), NASTY[*value]);
        }
        if let Ok(case) = CaseFile::parse(&text) {
            let twin = Excavator::new(Geometry::dx55()).unwrap();
            // Ok or a reason, never a panic; a tip force that parsed is in range.
            let _ = twin.evaluate(&case.nominal());
            prop_assert!(acq_twins::excavator::inputs::check_tip_force_kn(case.force_kn).is_ok());
        }
    }
}
