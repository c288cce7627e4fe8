//! What the whole chain must deliver, checked on an `acq demo` output
//! directory: the extracted means equal the scenarios' values within the
//! noise, the calibrated errors are at or below the stored expected ones
//! (`fixtures/expected/demo.toml`), and the report renders in Chromium.

use std::collections::BTreeMap;
use std::path::Path;

use super::root;

/// The scenario's hold value of every sensor.
pub fn scenario_holds(name: &str) -> BTreeMap<String, f64> {
    let text = std::fs::read_to_string(
        root()
            .join("fixtures/scenarios")
            .join(format!("{name}.toml")),
    )
    .unwrap();
    let scenario: toml::Table = text.parse().unwrap();
    scenario["sensor"]
        .as_table()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.clone(), v["hold"].as_float().unwrap()))
        .collect()
}

fn expected() -> toml::Table {
    std::fs::read_to_string(root().join("fixtures/expected/demo.toml"))
        .unwrap()
        .parse()
        .unwrap()
}

fn number(value: &serde_json::Value, what: &str) -> f64 {
    value
        .as_f64()
        .unwrap_or_else(|| panic!("{what}: not a number: {value}"))
}

/// Checks a demo's `demo.json` and files; `replayed` when the demo itself
/// played the sessions (then every frame sent must have been recorded).
pub fn check_demo_output(out: &Path, replayed: bool) {
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("demo.json")).unwrap()).unwrap();
    let expected = expected();

    // Acquisition: lossless.
    for (name, session) in summary["sessions"].as_object().unwrap() {
        let recorded = session["frames_recorded"].as_u64().unwrap();
        assert!(recorded > 1000, "{name}: {recorded} frames");
        if replayed {
            assert_eq!(
                session["frames_sent"].as_u64(),
                Some(recorded),
                "{name}: every frame played was recorded"
            );
        }
        assert_eq!(session["dropped_by_kernel"].as_u64(), Some(0), "{name}");
    }

    // Extraction: the scenario's values within the noise.
    for case in ["excavator_case1", "excavator_case2"] {
        let windows = summary["measured"][case].as_object().unwrap();
        assert_eq!(windows.len(), 1, "{case}: one hold: {windows:?}");
        let values = &windows["hold1"]["values"];
        for (sensor, hold) in scenario_holds(case) {
            let v = &values[&sensor];
            let mean = number(&v["mean"], &sensor);
            let half = number(&v["ci95_half_width"], &sensor);
            // The interval widened by the transducer's resolution (0.01 bar
            // steps) and 2 extra half-widths (about 1 in 10^5 when right).
            assert!(
                (mean - hold).abs() < 3.0 * half + 0.006,
                "{case} {sensor}: {mean} +- {half} vs the scenario's {hold}"
            );
        }
        let faulty = values["sg03"]["flags"].as_str().unwrap();
        if case == "excavator_case2" {
            assert_eq!(faulty, "pair:sg04", "the published faulty gauge is flagged");
        } else {
            assert_eq!(faulty, "");
        }
    }
    let curve = &summary["tensile_curve"];
    assert!((number(&curve["max_force_kN"], "max force") - 7.4597).abs() < 0.02);
    assert!((number(&curve["fracture_mm"], "fracture") - 2.607).abs() < 0.01);

    // Calibration: at or below the stored expected errors, and better than
    // the start.
    for case in ["excavator_case1", "excavator_case2"] {
        let result = &summary["excavator"][case];
        let limit = expected[case]["largest_error_optimal_pct"]
            .as_float()
            .unwrap();
        let before = number(&result["largest_error_initial_pct"], case);
        let after = number(&result["largest_error_optimal_pct"], case);
        assert!(
            after <= limit,
            "{case}: largest error {after} % > expected {limit} %"
        );
        assert!(after < before, "{case}: {before} % -> {after} %");
        let force = number(&result["force_kN"], case);
        let scenario_force = scenario_holds(case)["tip_force"];
        assert!(
            (force - scenario_force).abs() < 0.05,
            "{case}: the twin is loaded with the measured force ({force} vs {scenario_force})"
        );
    }
    let mape = number(&summary["gtn"]["best_mape"], "gtn");
    let limit = expected["gtn"]["best_mape"].as_float().unwrap();
    assert!(mape <= limit, "GTN MAPE {mape} % > expected {limit} %");

    // The report: Markdown links that resolve, and the HTML in a browser.
    let markdown = std::fs::read_to_string(out.join("report.md")).unwrap();
    let mut figures = 0;
    for part in markdown.split("](").skip(1) {
        let target = &part[..part.find(')').unwrap()];
        assert!(out.join(target).is_file(), "report.md links {target}");
        figures += 1;
    }
    assert!(figures >= 9, "{figures} figures linked");
    let page = super::browser::check_page(&out.join("report.html")).unwrap();
    assert!(
        page.console_errors.is_empty(),
        "console errors: {:?}",
        page.console_errors
    );
    assert_eq!(page.title, "acq demo report");
    let visible: Vec<_> = page.tables.iter().filter(|t| t.visible).collect();
    assert_eq!(visible.len(), page.tables.len(), "every table is shown");
    assert!(visible.len() >= 15, "{} tables", visible.len());
    let measured_rows: Vec<usize> = page
        .tables
        .iter()
        .filter(|t| t.first_header == "quantity")
        .map(|t| t.body_rows)
        .collect();
    assert_eq!(
        measured_rows.len(),
        2,
        "a measured table per excavator case"
    );
    assert!(measured_rows.iter().all(|&n| n >= 34), "{measured_rows:?}");
    assert!(
        page.visible_svgs >= figures,
        "{} plots shown",
        page.visible_svgs
    );
}
