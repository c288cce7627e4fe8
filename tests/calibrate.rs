//! `acq calibrate excavator|gtn|external`, `acq gp fit|predict` and `acq moo` from the
//! outside: the real binary, real solver processes (`fixtures/external/solver.sh`), the
//! files each run leaves behind checked against each other and against published or
//! independently computed numbers.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{acq, calibrate_external, parabola_study, path_arg, root, stderr, stdout};
use serde_json::Value;

// ---- helpers --------------------------------------------------------------------------

fn text(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&text(path)).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The keys of a JSON object, sorted.
fn keys(value: &Value) -> Vec<String> {
    let mut keys: Vec<String> = value
        .as_object()
        .unwrap_or_else(|| panic!("not an object: {value}"))
        .keys()
        .cloned()
        .collect();
    keys.sort();
    keys
}

fn sorted(names: &[&str]) -> Vec<String> {
    let mut names: Vec<String> = names.iter().map(|n| n.to_string()).collect();
    names.sort();
    names
}

fn number(value: &Value) -> f64 {
    value
        .as_f64()
        .unwrap_or_else(|| panic!("not a number: {value}"))
}

/// A CSV file (quoted cells allowed): its header and its data rows.
struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    fn read(path: &Path) -> Table {
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .from_path(path)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let header = reader
            .headers()
            .unwrap()
            .iter()
            .map(str::to_string)
            .collect();
        let rows = reader
            .records()
            .map(|r| r.unwrap().iter().map(str::to_string).collect())
            .collect();
        Table { header, rows }
    }

    fn index(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name} in {:?}", self.header))
    }

    fn cell<'a>(&self, row: &'a [String], name: &str) -> &'a str {
        &row[self.index(name)]
    }

    fn value(&self, row: &[String], name: &str) -> f64 {
        let cell = self.cell(row, name);
        cell.parse()
            .unwrap_or_else(|_| panic!("{name}: {cell:?} is not a number"))
    }

    fn column(&self, name: &str) -> Vec<f64> {
        self.rows.iter().map(|r| self.value(r, name)).collect()
    }
}

fn data_lines(path: &Path) -> usize {
    text(path).lines().count() - 1
}

fn largest(value: &Value) -> f64 {
    ["bucket", "arm", "boom"]
        .iter()
        .map(|k| number(&value[*k]))
        .fold(f64::NEG_INFINITY, f64::max)
}

/// `(done, from the log)` of a progress line
/// (`... 14/20 evaluations, best loss .., 0 failed, 14 from the log, 3 s`).
fn progress_counts(line: &str) -> (usize, usize) {
    let words: Vec<&str> = line.split_whitespace().collect();
    let parse = |word: &str| -> usize {
        word.parse()
            .unwrap_or_else(|_| panic!("{word:?} in the progress line {line:?}"))
    };
    let done = words
        .iter()
        .position(|w| *w == "evaluations,")
        .map(|i| parse(words[i - 1].split('/').next().unwrap()))
        .unwrap_or_else(|| panic!("not a progress line: {line:?}"));
    let reused = words
        .windows(4)
        .position(|w| w[1] == "from" && w[2] == "the" && w[3].starts_with("log"))
        .map(|i| parse(words[i]))
        .unwrap_or_else(|| panic!("not a progress line: {line:?}"));
    (done, reused)
}

/// The progress lines of a run's stderr.
fn progress_lines(stderr: &str) -> Vec<(usize, usize)> {
    stderr
        .lines()
        .filter(|l| l.contains(" evaluations, "))
        .map(progress_counts)
        .collect()
}

// ---- acq calibrate excavator --------------------------------------------------------

const CASE1: &str = "data/excavator/case1.toml";
const MEASURED_BAR: [(&str, f64); 3] = [("bucket", 116.89), ("arm", 193.46), ("boom", 73.35)];
const EXCAVATOR_INPUTS: [&str; 4] = [
    "bucket_stroke_mm",
    "arm_stroke_mm",
    "boom_stroke_mm",
    "force_angle_deg",
];

fn calibrate_excavator(out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "calibrate",
        "excavator",
        "--case",
        CASE1,
        "--out",
        path_arg(out),
    ];
    args.extend_from_slice(extra);
    acq(&args)
}

/// `[lower, upper]` of each uncertain input, as the case file gives them.
fn case1_bounds() -> BTreeMap<String, (f64, f64)> {
    let case: toml::Table = text(&root().join(CASE1)).parse().unwrap();
    case["bounds"]
        .as_table()
        .unwrap()
        .iter()
        .map(|(name, pair)| {
            let pair = pair.as_array().unwrap();
            let bound = |v: &toml::Value| v.as_float().or(v.as_integer().map(|i| i as f64));
            (
                name.clone(),
                (bound(&pair[0]).unwrap(), bound(&pair[1]).unwrap()),
            )
        })
        .collect()
}

#[test]
fn excavator_summary_has_the_fixed_shape_and_does_not_worsen_the_fit() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let output = calibrate_excavator(&out, &[]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(
        stdout(&output).contains("largest error"),
        "{}",
        stdout(&output)
    );

    let summary = json(&out.join("summary.json"));
    assert_eq!(
        keys(&summary),
        sorted(&[
            "errors_initial_pct",
            "errors_optimal_pct",
            "optimal",
            "surrogate_rmse_bar",
            "evaluations"
        ])
    );
    let cylinders = sorted(&["bucket", "arm", "boom"]);
    assert_eq!(keys(&summary["errors_initial_pct"]), cylinders);
    assert_eq!(keys(&summary["errors_optimal_pct"]), cylinders);
    assert_eq!(keys(&summary["optimal"]), sorted(&EXCAVATOR_INPUTS));
    // The line before the report's path gives each calibrated input with
    // its value, as the summary has it to 6 significant figures; the last
    // line is the HTML report's path.
    let said = stdout(&output);
    let mut lines = said.lines().rev();
    let report = lines.next().unwrap();
    assert!(
        report.starts_with("report: ") && report.ends_with("report.html"),
        "{report}"
    );
    let last = lines.next().unwrap();
    assert!(last.starts_with("calibrated: "), "{last}");
    for input in EXCAVATOR_INPUTS {
        let value = summary["optimal"][input].as_f64().unwrap();
        let shown = last
            .split(&format!("{input} = "))
            .nth(1)
            .and_then(|rest| rest.split([',', ' ']).next())
            .unwrap_or_else(|| panic!("{input} in {last}"));
        let shown: f64 = shown.parse().unwrap();
        assert!(
            (shown - value).abs() <= 1e-5 * value.abs().max(1.0),
            "{input}: {last}"
        );
    }
    let rmse = &summary["surrogate_rmse_bar"];
    assert_eq!(
        keys(rmse),
        sorted(&["gp", "poly1", "poly2", "poly3", "rbf"])
    );
    for surrogate in ["gp", "poly1", "poly2", "poly3", "rbf"] {
        assert_eq!(keys(&rmse[surrogate]), cylinders, "{surrogate}");
    }

    // The calibrated inputs lie in the case's box.
    let bounds = case1_bounds();
    assert_eq!(bounds.len(), 4);
    for (name, (lower, upper)) in &bounds {
        let value = number(&summary["optimal"][name]);
        assert!(
            *lower <= value && value <= *upper,
            "{name} = {value} outside [{lower}, {upper}]"
        );
    }
    // The pick is no worse than the nominal (largest of the three errors).
    let initial = largest(&summary["errors_initial_pct"]);
    let optimal = largest(&summary["errors_optimal_pct"]);
    assert!(optimal <= initial, "{optimal} % > {initial} %");
    // 1 nominal + 40 training + 40 test + 1 re-run of the pick.
    assert_eq!(summary["evaluations"], 82);
    // The GP beats a plane where the pressure is smooth in the inputs.
    for cylinder in ["arm", "bucket"] {
        let gp = number(&rmse["gp"][cylinder]);
        let poly1 = number(&rmse["poly1"][cylinder]);
        assert!(gp < poly1, "{cylinder}: GP RMSE {gp} >= poly1 {poly1}");
    }

    // The log agrees with the summary: the nominal run gives the initial errors, the last
    // run is the re-run at the pick and gives the optimal errors.
    let log = Table::read(&out.join("evaluations.csv"));
    let mut header = vec!["id", "status", "wall_s"];
    header.extend(EXCAVATOR_INPUTS);
    header.extend([
        "bucket_pressure_bar",
        "arm_pressure_bar",
        "boom_pressure_bar",
        "reason",
    ]);
    assert_eq!(log.header, header);
    assert_eq!(log.rows.len(), 82);
    let errors_of = |row: &[String]| -> Vec<(String, f64)> {
        MEASURED_BAR
            .iter()
            .map(|(name, measured)| {
                let model = log.value(row, &format!("{name}_pressure_bar"));
                (
                    name.to_string(),
                    100.0 * (measured - model).abs() / measured,
                )
            })
            .collect()
    };
    let nominal = log
        .rows
        .iter()
        .find(|row| {
            bounds
                .iter()
                .all(|(name, (lower, upper))| log.value(row, name) == 0.5 * (lower + upper))
        })
        .expect("the nominal run is in the log");
    for (name, error) in errors_of(nominal) {
        let reported = number(&summary["errors_initial_pct"][&name]);
        assert!(
            (error - reported).abs() < 1e-9,
            "{name}: {error} vs {reported}"
        );
    }
    let last = log.rows.last().unwrap();
    assert_eq!(log.cell(last, "id"), "82");
    assert_eq!(log.cell(last, "status"), "ok");
    for name in EXCAVATOR_INPUTS {
        assert_eq!(
            log.value(last, name),
            number(&summary["optimal"][name]),
            "{name}"
        );
    }
    for (name, error) in errors_of(last) {
        let reported = number(&summary["errors_optimal_pct"][&name]);
        assert!(
            (error - reported).abs() < 1e-9,
            "{name}: {error} vs {reported}"
        );
    }

    let report = common::report::read(&out);
    for (_, measured) in MEASURED_BAR {
        assert!(
            report.contains(&format!("{measured:.2}")),
            "{measured} not in\n{report}"
        );
    }
    // One verdict per input: each input's row there carries the local
    // verdict of the identifiability table, its largest Sobol index, and
    // words that agree with both.
    let section = &report[report
        .find("### One verdict per input")
        .expect("the section")..];
    let cells = |text: &str, name: &str| -> Vec<String> {
        let row = text
            .lines()
            .find(|l| l.starts_with(&format!("| {name} |")))
            .unwrap_or_else(|| panic!("{name}"));
        row.trim_matches('|')
            .split('|')
            .map(|c| c.trim().to_string())
            .collect()
    };
    let local_table = &report[report
        .find("| parameter | loss change along its range")
        .unwrap()..];
    // Within 1 % of its range of a bound, as the terminal's line says.
    let optimal_on_a_bound = |name: &str| {
        let (lower, upper) = bounds[name];
        let unit = (summary["optimal"][name].as_f64().unwrap() - lower) / (upper - lower);
        !(0.01..=0.99).contains(&unit)
    };
    for name in EXCAVATOR_INPUTS {
        let one = cells(section, name);
        let local = cells(local_table, name);
        // The calibrated point's word and the one verdict, the same in
        // both tables.
        assert_eq!(one[2], local[3], "{name}: {one:?} against {local:?}");
        assert!(
            one[3].starts_with(&local[4]),
            "{name}: {one:?} against {local:?}"
        );
        let sobol: f64 = one[1].split(' ').next().unwrap().parse().unwrap();
        // A value on a bound is said to be there, whatever the point's
        // word; otherwise the verdict is the point's.
        let on_bound = optimal_on_a_bound(name);
        assert_eq!(one[3].starts_with("on its"), on_bound, "{name}: {one:?}");
        if !on_bound {
            assert!(one[3].starts_with(&one[2]), "{name}: {one:?}");
        }
        if one[2] == "not identified" && !on_bound {
            let says_it_matters = one[3].contains("it moves the outputs, but");
            assert_eq!(says_it_matters, sobol >= 0.05, "{name}: {one:?}");
        }
    }
    for svg in ["pareto.svg", "loss.svg"] {
        let plot = text(&out.join(svg));
        assert!(
            plot.starts_with("<svg"),
            "{svg}: {}",
            &plot[..plot.len().min(80)]
        );
        assert!(plot.trim_end().ends_with("</svg>"), "{svg}");
    }
}

#[test]
fn excavator_picks_minimax_by_default_and_topsis_on_request() {
    // Same seed, same designs and GPs, same front: only the pick differs.
    let dir = tempfile::tempdir().unwrap();
    let minimax = dir.path().join("minimax");
    let topsis = dir.path().join("topsis");
    let output = calibrate_excavator(&minimax, &[]);
    assert!(output.status.success(), "{}", stderr(&output));
    let output = calibrate_excavator(&topsis, &["--pick", "topsis"]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(common::report::read(&minimax).contains("the minimax pick"));
    assert!(common::report::read(&topsis).contains("the TOPSIS pick (per-objective normalisation"));
    // The minimax pick has the least largest error on the GPs' front; the twin
    // re-run there agrees with the GPs within a few hundredths of a percent.
    let largest_minimax = largest(&json(&minimax.join("summary.json"))["errors_optimal_pct"]);
    let largest_topsis = largest(&json(&topsis.join("summary.json"))["errors_optimal_pct"]);
    assert!(
        largest_minimax <= largest_topsis + 0.1,
        "minimax {largest_minimax} % > TOPSIS {largest_topsis} %"
    );

    let output = calibrate_excavator(&dir.path().join("bad"), &["--pick", "best"]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("give topsis, topsis-common or minimax"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn excavator_resume_reuses_every_evaluation_and_reproduces_the_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let first = calibrate_excavator(&out, &["--seed", "7"]);
    assert!(first.status.success(), "{}", stderr(&first));
    let summary = std::fs::read(out.join("summary.json")).unwrap();
    let log = std::fs::read(out.join("evaluations.csv")).unwrap();
    assert_eq!(progress_lines(&stderr(&first)).last(), Some(&(82, 0)));

    let second = calibrate_excavator(&out, &["--seed", "7", "--resume"]);
    assert!(second.status.success(), "{}", stderr(&second));
    // Progress: every evaluation so far answered from the log.
    let progress = progress_lines(&stderr(&second));
    assert!(
        progress.iter().all(|(done, reused)| done == reused),
        "{progress:?}"
    );
    assert_eq!(progress.last(), Some(&(82, 82)), "{}", stderr(&second));
    // Nothing re-run, nothing appended, and the same answer to the byte.
    assert_eq!(data_lines(&out.join("evaluations.csv")), 82);
    assert_eq!(std::fs::read(out.join("evaluations.csv")).unwrap(), log);
    assert_eq!(
        String::from_utf8(std::fs::read(out.join("summary.json")).unwrap()).unwrap(),
        String::from_utf8(summary).unwrap()
    );

    // A new run into the same directory would mix two runs in one log.
    let third = calibrate_excavator(&out, &["--seed", "7"]);
    assert_eq!(third.status.code(), Some(2), "{}", stderr(&third));
    assert!(stderr(&third).contains("--resume"), "{}", stderr(&third));
    assert_eq!(std::fs::read(out.join("evaluations.csv")).unwrap(), log);
}

#[test]
fn excavator_case_without_measured_pressures_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("unmeasured.toml");
    let original = text(&root().join(CASE1));
    let mut kept = Vec::new();
    let mut skipping = false;
    for line in original.lines() {
        if line.starts_with('[') {
            skipping = line.starts_with("[measured]");
        }
        if !skipping {
            kept.push(line);
        }
    }
    let stripped = kept.join("\n") + "\n";
    assert!(!stripped.contains("arm_bar") && stripped.contains("[bounds]"));
    std::fs::write(&case, stripped).unwrap();
    let out = dir.path().join("run");
    let output = acq(&[
        "calibrate",
        "excavator",
        "--case",
        path_arg(&case),
        "--out",
        path_arg(&out),
    ]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    let message = stderr(&output);
    assert!(
        message.contains("[measured]") && message.contains("unmeasured.toml"),
        "{message}"
    );
    assert!(!out.exists(), "no run directory for a case that cannot run");
}

// ---- acq calibrate gtn --------------------------------------------------------------

const TEST_CSV: &str = "data/tensile/P91_20_2_DF_SS.csv";
use common::GTN_BOUNDS;
/// The standard L12 array, first 8 columns (1 = lower bound, 2 = upper).
const L12: [[u8; 8]; 12] = [
    [1, 1, 1, 1, 1, 1, 1, 1],
    [1, 1, 1, 1, 1, 2, 2, 2],
    [1, 1, 2, 2, 2, 1, 1, 1],
    [1, 2, 1, 2, 2, 1, 2, 2],
    [1, 2, 2, 1, 2, 2, 1, 2],
    [1, 2, 2, 2, 1, 2, 2, 1],
    [2, 1, 2, 2, 1, 1, 2, 2],
    [2, 1, 2, 1, 2, 2, 2, 1],
    [2, 1, 1, 2, 2, 2, 1, 2],
    [2, 2, 2, 1, 1, 1, 1, 2],
    [2, 2, 1, 2, 1, 2, 1, 1],
    [2, 2, 1, 1, 2, 1, 2, 1],
];

/// `acq calibrate gtn` on a coarse 3 x 12 mesh (fast), unless `extra` gives
/// the mesh by element size.
fn calibrate_gtn(out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "calibrate",
        "gtn",
        "--test",
        TEST_CSV,
        "--out",
        path_arg(out),
    ];
    if !extra
        .iter()
        .any(|a| a.starts_with("--element-mm") || a.starts_with("--mesh"))
    {
        args.extend(["--mesh", "3x12"]);
    }
    args.extend_from_slice(extra);
    acq(&args)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * b.abs().max(1.0)
}

#[test]
fn gtn_small_budget_starts_from_l12_and_resumes_to_a_target() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let output = calibrate_gtn(&out, &["--max-evals", "14"]);
    assert!(output.status.success(), "{}", stderr(&output));

    let summary = json(&out.join("summary.json"));
    assert_eq!(
        keys(&summary),
        sorted(&[
            "best_mape",
            "evaluations",
            "evaluations_to_target",
            "best_params",
            "wall_s",
            "mesh"
        ])
    );
    assert_eq!(summary["evaluations"], 14);
    // A mesh given by counts: 3 x 12, 2 mm / 3 across the radius.
    assert_eq!(summary["mesh"]["radial_elements"], 3);
    assert_eq!(summary["mesh"]["axial_elements"], 12);
    assert!((number(&summary["mesh"]["neck_element_radial_mm"]) - 2.0 / 3.0).abs() < 1e-12);
    assert_eq!(summary["mesh"]["neck_zone_mm"], Value::Null);
    match &summary["evaluations_to_target"] {
        Value::Null => {}
        n => assert!(n.as_u64().is_some_and(|n| (1..=14).contains(&n)), "{n}"),
    }
    assert!(number(&summary["wall_s"]) > 0.0);
    let names: Vec<&str> = GTN_BOUNDS.iter().map(|b| b.0).collect();
    assert_eq!(keys(&summary["best_params"]), sorted(&names));
    for (name, lower, upper) in GTN_BOUNDS {
        let value = number(&summary["best_params"][name]);
        assert!(
            lower - 1e-12 <= value && value <= upper + 1e-12,
            "{name} = {value} outside [{lower}, {upper}]"
        );
    }

    let log = Table::read(&out.join("evaluations.csv"));
    assert_eq!(log.rows.len(), 14);
    assert!(log.rows.iter().all(|r| log.cell(r, "status") == "ok"));
    let mape = log.column("mape_pct");
    let best = mape.iter().copied().fold(f64::INFINITY, f64::min);
    assert_eq!(number(&summary["best_mape"]), best);
    let best_row = &log.rows[mape.iter().position(|&m| m == best).unwrap()];
    for name in &names {
        assert_eq!(
            log.value(best_row, name),
            number(&summary["best_params"][*name])
        );
    }
    // The first 12 runs are the L12 design: every parameter on one of its bounds.
    for (run, levels) in L12.iter().enumerate() {
        let row = &log.rows[run];
        assert_eq!(log.cell(row, "id"), (run + 1).to_string());
        for ((name, lower, upper), level) in GTN_BOUNDS.iter().zip(levels) {
            let value = log.value(row, name);
            let expected = if *level == 1 { *lower } else { *upper };
            assert!(close(value, expected), "run {}: {name} = {value}", run + 1);
        }
    }
    // The search then leaves the corners.
    assert!(log.rows[12..].iter().any(|row| {
        GTN_BOUNDS.iter().any(|(name, lower, upper)| {
            let v = log.value(row, name);
            !close(v, *lower) && !close(v, *upper)
        })
    }));

    for file in ["curve.csv", "curve.svg", "loss.svg", "report.md"] {
        assert!(out.join(file).is_file(), "{file} missing");
    }
    let curve = Table::read(&out.join("curve.csv"));
    assert_eq!(curve.header, ["DISPLACEMENT", "FORCE"]);
    assert!(curve.rows.len() > 10);
    assert!(text(&out.join("curve.svg")).starts_with("<svg"));
    assert!(text(&out.join("loss.svg")).starts_with("<svg"));

    // Resumed with a target of exactly the best MAPE: every simulation comes from the
    // log, and the run stops at the one that reached it (or after the L12 start).
    let target = format!("{best}");
    let first_reaching = 1 + mape.iter().position(|&m| m <= best).unwrap();
    let resumed = calibrate_gtn(
        &out,
        &["--max-evals", "20", "--target-mape", &target, "--resume"],
    );
    assert!(resumed.status.success(), "{}", stderr(&resumed));
    let summary = json(&out.join("summary.json"));
    assert_eq!(
        summary["evaluations_to_target"].as_u64(),
        Some(first_reaching as u64)
    );
    let evaluations = first_reaching.max(12);
    assert_eq!(summary["evaluations"].as_u64(), Some(evaluations as u64));
    assert_eq!(number(&summary["best_mape"]), best);
    assert_eq!(data_lines(&out.join("evaluations.csv")), 14);
    let progress = progress_lines(&stderr(&resumed));
    assert!(!progress.is_empty(), "{}", stderr(&resumed));
    assert!(
        progress.iter().all(|(done, reused)| done == reused),
        "{progress:?}"
    );
}

#[test]
fn gtn_calibrates_at_the_element_size_asked_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let output = calibrate_gtn(&out, &["--element-mm", "0.25", "--max-evals", "13"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let summary = json(&out.join("summary.json"));
    let mesh = &summary["mesh"];
    // 2 mm radius / 0.25 mm; a zone of half the 4 mm diameter, 8 elements long.
    assert_eq!(mesh["radial_elements"], 8);
    assert_eq!(number(&mesh["neck_element_radial_mm"]), 0.25);
    assert!((number(&mesh["neck_element_axial_mm"]) - 0.25).abs() < 1e-12);
    assert_eq!(number(&mesh["neck_zone_mm"]), 2.0);
    let axial = mesh["axial_elements"].as_u64().unwrap();
    assert!((9..30).contains(&axial), "{axial} axial elements");
    let report = common::report::read(&out);
    assert!(
        report.contains("square elements of 0.2500 mm over a neck zone of 2 mm"),
        "{report}"
    );

    // The Abaqus block, read back by a parser of its own, against summary.json
    // and `acq tensile-props` (modulus and flow table).
    let inp = text(&out.join("abaqus_material.inp"));
    assert!(inp.contains("0.2500 mm"), "{inp}");
    let block = abaqus_keywords(&inp);
    let names: Vec<&str> = block.iter().map(|k| k.0.as_str()).collect();
    assert_eq!(
        names,
        [
            "*MATERIAL",
            "*ELASTIC",
            "*PLASTIC",
            "*POROUS METAL PLASTICITY",
            "*VOID NUCLEATION"
        ]
    );
    let best = |name: &str| number(&summary["best_params"][name]);
    let keyword = |name: &str| block.iter().find(|k| k.0 == name).unwrap();
    let porous = keyword("*POROUS METAL PLASTICITY");
    let relative_density: f64 = porous.1["RELATIVE DENSITY"].parse().unwrap();
    assert_eq!(relative_density, 1.0 - best("f0"));
    assert_eq!(porous.2, [vec![best("q1"), best("q2"), best("q3")]]);
    assert_eq!(
        keyword("*VOID NUCLEATION").2,
        [vec![best("epsN"), best("sN"), best("fN")]]
    );
    let props: Value =
        serde_json::from_str(&stdout(&acq(&["tensile-props", TEST_CSV, "--json"]))).unwrap();
    assert_eq!(
        keyword("*ELASTIC").2,
        [vec![number(&props["youngs_modulus_mpa"]), 0.3]]
    );
    let flow_csv = dir.path().join("flow.csv");
    let output = acq(&["tensile-props", TEST_CSV, "-o", path_arg(&flow_csv)]);
    assert!(output.status.success(), "{}", stderr(&output));
    let flow = Table::read(&flow_csv);
    let plastic = &keyword("*PLASTIC").2;
    // (stress, strain) pairs: the test's flow table, then one point on slope m.
    assert_eq!(plastic.len(), flow.rows.len() + 1);
    for (pair, row) in plastic.iter().zip(&flow.rows) {
        assert_eq!(pair[1], flow.value(row, "PLASTIC_STRAIN"));
        assert_eq!(pair[0], flow.value(row, "TRUE_STRESS_MPA"));
    }
    let (before, last) = (&plastic[plastic.len() - 2], &plastic[plastic.len() - 1]);
    let slope = (last[0] - before[0]) / (last[1] - before[1]);
    assert!(
        (slope - best("m")).abs() <= 1e-9 * best("m").max(1.0),
        "{slope} vs {}",
        best("m")
    );
}

/// An Abaqus input block as (keyword, its parameters, its data lines), with
/// comment lines (`**`) dropped: the reader the export is checked with.
type Keyword = (String, BTreeMap<String, String>, Vec<Vec<f64>>);
fn abaqus_keywords(text: &str) -> Vec<Keyword> {
    let mut keywords: Vec<Keyword> = Vec::new();
    for line in text.lines().map(str::trim).filter(|l| !l.is_empty()) {
        if line.starts_with("**") {
            continue;
        }
        if let Some(rest) = line.strip_prefix('*') {
            let mut parts = rest.split(',').map(str::trim);
            let name = format!("*{}", parts.next().unwrap().to_uppercase());
            let parameters = parts
                .map(|p| {
                    let (key, value) = p.split_once('=').unwrap_or((p, ""));
                    (key.trim().to_uppercase(), value.trim().to_string())
                })
                .collect();
            keywords.push((name, parameters, Vec::new()));
        } else {
            let values = line
                .split(',')
                .map(|v| v.trim().parse::<f64>().unwrap_or_else(|_| panic!("{line}")))
                .collect();
            keywords
                .last_mut()
                .expect("data before any keyword")
                .2
                .push(values);
        }
    }
    keywords
}

#[test]
fn gtn_stops_at_the_first_simulation_that_reaches_the_target() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let output = calibrate_gtn(&out, &["--target-mape", "100", "--max-evals", "20"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let summary = json(&out.join("summary.json"));
    let log = Table::read(&out.join("evaluations.csv"));
    let mape = log.column("mape_pct");
    let first_reaching = 1 + mape
        .iter()
        .position(|&m| m <= 100.0)
        .expect("a MAPE below 100 %");
    let to_target = summary["evaluations_to_target"]
        .as_u64()
        .unwrap_or_else(|| panic!("target not reached: {summary}")) as usize;
    assert_eq!(to_target, first_reaching);
    // The L12 start is one batch; after it, one simulation at a time.
    let evaluations = summary["evaluations"].as_u64().unwrap() as usize;
    assert_eq!(evaluations, to_target.max(12));
    assert_eq!(mape.len(), evaluations);
    assert!(evaluations < 20);
    assert_eq!(
        number(&summary["best_mape"]),
        mape.iter().copied().fold(f64::INFINITY, f64::min)
    );
}

#[test]
fn gtn_bad_mesh_and_budget_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let output = acq(&[
        "calibrate",
        "gtn",
        "--test",
        TEST_CSV,
        "--out",
        path_arg(&out),
        "--mesh",
        "3x",
    ]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("--mesh 3x"), "{}", stderr(&output));
    // An element size beyond the radius, or with --mesh, is refused.
    for (extra, why) in [
        (
            &["--element-mm", "3"][..],
            "--element-mm: element size 3 mm",
        ),
        (
            &["--element-mm", "0.001"][..],
            "expected 0.02 mm to the radius",
        ),
        (
            &["--element-mm", "0.2", "--mesh", "6x30"][..],
            "cannot be used with",
        ),
        (&["--neck-zone-mm", "2"][..], "--element-mm"),
    ] {
        let output = calibrate_gtn(&out, extra);
        assert_eq!(
            output.status.code(),
            Some(2),
            "{extra:?}: {}",
            stderr(&output)
        );
        assert!(
            stderr(&output).contains(why),
            "{extra:?}: {}",
            stderr(&output)
        );
    }
    // The budget must cover the 12-run start and at least one search step.
    let output = calibrate_gtn(&out, &["--max-evals", "12"]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("--max-evals"),
        "{}",
        stderr(&output)
    );
    assert!(!out.exists());
}

// ---- acq calibrate external -----------------------------------------------------------

fn solver() -> PathBuf {
    root().join("fixtures/external/solver.sh")
}

/// `start` and `end` lines the solver wrote to the call log.
fn solver_calls(log: &Path) -> (usize, usize) {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let count = |word: &str| text.lines().filter(|l| l.starts_with(word)).count();
    (count("start "), count("end "))
}

#[test]
fn external_solver_failures_and_timeouts_are_logged_not_fatal() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let spec = root().join("fixtures/external/spec.toml");
    let output = calibrate_external(&spec, &out, &[]);
    assert!(output.status.success(), "{}", stderr(&output));

    let summary = json(&out.join("summary.json"));
    assert_eq!(
        keys(&summary),
        sorted(&[
            "best_loss_pct",
            "evaluations",
            "failed",
            "evaluations_to_target",
            "best_params",
            "best_outputs",
            "wall_s"
        ])
    );
    assert_eq!(summary["evaluations"], 20);
    assert_eq!(summary["evaluations_to_target"], Value::Null);

    let log = Table::read(&out.join("evaluations.csv"));
    assert_eq!(
        log.header,
        ["id", "status", "wall_s", "x_mm", "y_deg", "out1", "out2", "reason"]
    );
    assert_eq!(log.rows.len(), 20);
    let ids: Vec<String> = log
        .rows
        .iter()
        .map(|r| log.cell(r, "id").to_string())
        .collect();
    let expected: Vec<String> = (1..=20).map(|i| i.to_string()).collect();
    assert_eq!(ids, expected);
    let failed: Vec<&Vec<String>> = log
        .rows
        .iter()
        .filter(|r| log.cell(r, "status") == "failed")
        .collect();
    assert_eq!(summary["failed"].as_u64(), Some(failed.len() as u64));
    // The 8-run Latin hypercube has one x in each eighth of [0, 10]: one in the solver's
    // failure band [6.25, 7.5), one in its hanging band [8.75, 10].
    let reasons: Vec<&str> = failed.iter().map(|r| log.cell(r, "reason")).collect();
    assert!(
        reasons
            .iter()
            .any(|r| r.contains("exit status: 3") && r.contains("no convergence")),
        "{reasons:?}"
    );
    assert!(
        reasons.iter().any(|r| r.contains("timed out")),
        "{reasons:?}"
    );
    // The hung solver's child (a `sleep 5` under the shell) was killed with
    // it: no timed-out run leaves a process behind.
    let mut hung = 0;
    for entry in std::fs::read_dir(out.join("runs")).unwrap() {
        let pid_file = entry.unwrap().path().join("hung.pid");
        if let Ok(pid) = std::fs::read_to_string(&pid_file) {
            hung += 1;
            let stat = std::fs::read_to_string(format!("/proc/{}/stat", pid.trim()));
            // Gone, or a zombie waiting for init to reap it.
            let alive = stat.is_ok_and(|s| {
                s.rsplit_once(')')
                    .is_some_and(|(_, rest)| !rest.trim_start().starts_with('Z'))
            });
            assert!(
                !alive,
                "the timed-out solver's child {} still runs",
                pid.trim()
            );
        }
    }
    assert!(hung >= 1, "no run hit the fixture's hang band");
    for row in &failed {
        let x = log.value(row, "x_mm");
        assert!((6.25..7.5).contains(&x) || x >= 8.75, "x_mm {x} failed");
        assert!(log.cell(row, "out1").is_empty() && log.cell(row, "out2").is_empty());
    }
    // Successful runs carry the solver's function of their parameters.
    let mut best_loss = f64::INFINITY;
    for row in log.rows.iter().filter(|r| log.cell(r, "status") == "ok") {
        let (x, y) = (log.value(row, "x_mm"), log.value(row, "y_deg"));
        let (out1, out2) = (log.value(row, "out1"), log.value(row, "out2"));
        assert!((out1 - ((x - 3.0).powi(2) + 10.0)).abs() < 1e-9, "{row:?}");
        assert!((out2 - (2.0 * y + x)).abs() < 1e-9, "{row:?}");
        assert!(log.cell(row, "reason").is_empty());
        let loss = 50.0 * ((out1 - 10.0).abs() / 10.0 + (out2 - 5.0).abs() / 5.0);
        best_loss = best_loss.min(loss);
    }
    let reported = number(&summary["best_loss_pct"]);
    assert!(
        (reported - best_loss).abs() < 1e-9,
        "{reported} vs {best_loss}"
    );
    // The search closes in on the optimum at (3, 1) (the best start run is ~40 % off).
    assert!(reported < 5.0, "best loss {reported} %");
    let x = number(&summary["best_params"]["x_mm"]);
    let y = number(&summary["best_params"]["y_deg"]);
    assert!((0.0..=10.0).contains(&x) && (-5.0..=5.0).contains(&y));
    assert!((number(&summary["best_outputs"]["out1"]) - ((x - 3.0).powi(2) + 10.0)).abs() < 1e-9);

    // No retries: one solver call per evaluation; the failed ones never finished.
    let (starts, ends) = solver_calls(&out.join("runs/calls.log"));
    assert_eq!(starts, 20);
    assert_eq!(ends, 20 - failed.len());
    // One run directory per call, holding the parameters it was given.
    let mut given: Vec<(u64, u64)> = (1..=20)
        .map(|n| {
            let params = json(&out.join(format!("runs/{n:06}/params.json")));
            assert_eq!(keys(&params), sorted(&["x_mm", "y_deg"]));
            (
                number(&params["x_mm"]).to_bits(),
                number(&params["y_deg"]).to_bits(),
            )
        })
        .collect();
    let mut logged: Vec<(u64, u64)> = log
        .rows
        .iter()
        .map(|r| {
            (
                log.value(r, "x_mm").to_bits(),
                log.value(r, "y_deg").to_bits(),
            )
        })
        .collect();
    given.sort_unstable();
    logged.sort_unstable();
    assert_eq!(given, logged);
    assert!(!out.join("runs/000021").exists());
    assert!(text(&out.join("loss.svg")).starts_with("<svg"));
    assert!(common::report::read(&out).contains("out1"));
}

#[test]
fn external_run_interrupted_by_sigint_resumes_without_repeating_logged_runs() {
    use std::os::unix::process::CommandExt;

    use nix::sys::signal::{kill, signal, SigHandler, Signal};
    use nix::unistd::Pid;

    let dir = tempfile::tempdir().unwrap();
    // The fixture solver, 0.2 s per run, on a box that avoids its failure bands.
    let spec = dir.path().join("slow.toml");
    std::fs::write(
        &spec,
        format!(
            r#"command = ["sh", "{}", "{{x_mm}}", "{{y_deg}}", "{{out}}", "{{dir}}/../calls.log", "0.2"]
output_file = "out.json"
timeout_s = 30
parallel = 2

[[parameter]]
name = "x_mm"
lower = 0.0
upper = 6.0

[[parameter]]
name = "y_deg"
lower = -5.0
upper = 5.0

[[output]]
name = "out1"
measured = 10.0

[[output]]
name = "out2"
measured = 5.0

[search]
start = "lhs"
start_runs = 8
max_evals = 20
"#,
            solver().display()
        ),
    )
    .unwrap();
    let out = dir.path().join("run");
    let log = out.join("evaluations.csv");
    let calls = out.join("runs/calls.log");

    let mut command = Command::new(env!("CARGO_BIN_EXE_acq"));
    command
        .args([
            "calibrate",
            "external",
            "--spec",
            path_arg(&spec),
            "--out",
            path_arg(&out),
        ])
        .current_dir(root())
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(dir.path().join("stderr.txt")).unwrap());
    // Tests started as a background job of a non-interactive shell inherit an ignored
    // SIGINT, and exec keeps it ignored: give acq the default action, as on a terminal.
    // SAFETY: only sigaction (async-signal-safe) runs between fork and exec.
    unsafe {
        command.pre_exec(|| {
            signal(Signal::SIGINT, SigHandler::SigDfl)
                .map(drop)
                .map_err(std::io::Error::from)
        });
    }
    let mut child = command.spawn().unwrap();
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        let logged = std::fs::read_to_string(&log)
            .map(|t| t.lines().count().saturating_sub(1))
            .unwrap_or(0);
        if logged >= 5 {
            break;
        }
        if let Some(status) = child.try_wait().unwrap() {
            panic!("acq ended ({status}) before 5 evaluations were logged");
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("no 5 evaluations logged in 120 s");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    kill(Pid::from_raw(child.id() as i32), Signal::SIGINT).unwrap();
    let status = child.wait().unwrap();
    assert_eq!(
        status.code(),
        Some(130),
        "an interrupted run exits 130: {status}"
    );
    let said = std::fs::read_to_string(dir.path().join("stderr.txt")).unwrap();
    assert!(
        said.contains("interrupted") && said.contains("--resume"),
        "an interrupted run says how to continue: {said}"
    );

    // The solver runs that were in flight finish on their own; wait until every started
    // call has ended and the count has settled.
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut settled = 0;
    let mut previous = (usize::MAX, usize::MAX);
    while settled < 10 {
        let now = solver_calls(&calls);
        if now.0 == now.1 && now == previous {
            settled += 1;
        } else {
            settled = 0;
        }
        previous = now;
        assert!(
            Instant::now() < deadline,
            "solver calls never settled: {now:?}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let calls_before = previous.0;
    let run_files = |dir: &Path| -> std::collections::BTreeMap<String, String> {
        std::fs::read_dir(dir.join("runs"))
            .unwrap()
            .filter_map(|e| {
                let path = e.unwrap().path().join("params.json");
                let name = path.parent()?.file_name()?.to_str()?.to_string();
                Some((name, std::fs::read_to_string(&path).ok()?))
            })
            .collect()
    };
    let runs_before = run_files(&out);
    let interrupted = text(&log);
    let logged = interrupted.lines().count() - 1;
    assert!(
        (5..20).contains(&logged),
        "{logged} evaluations logged before the interrupt"
    );
    assert!(calls_before >= logged);

    let output = calibrate_external(&spec, &out, &["--resume"]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert_eq!(
        progress_lines(&stderr(&output)).last(),
        Some(&(20, logged)),
        "{}",
        stderr(&output)
    );
    let resumed = text(&log);
    assert!(resumed.starts_with(&interrupted), "the log was rewritten");
    let table = Table::read(&log);
    let ids: Vec<String> = table.rows.iter().map(|r| r[0].clone()).collect();
    let expected: Vec<String> = (1..=20).map(|i| i.to_string()).collect();
    assert_eq!(ids, expected);
    assert!(table.rows.iter().all(|r| table.cell(r, "status") == "ok"));
    // Every logged evaluation came from the log; only the rest (and the runs lost in
    // flight) called the solver again.
    let (calls_after, ends_after) = solver_calls(&calls);
    assert_eq!(calls_after, calls_before + 20 - logged);
    assert_eq!(ends_after, calls_after);
    assert_eq!(json(&out.join("summary.json"))["evaluations"], 20);
    // The interrupted run's directories are kept as they were; the resumed
    // run numbers on after them.
    let runs_after = run_files(&out);
    for (name, params) in &runs_before {
        assert_eq!(
            runs_after.get(name),
            Some(params),
            "runs/{name} was overwritten"
        );
    }
    assert_eq!(runs_after.len(), runs_before.len() + 20 - logged);
}

#[test]
fn external_spec_errors_exit_2_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let good = text(&root().join("fixtures/external/spec.toml"));
    let without_outputs = {
        let mut kept = Vec::new();
        let mut skipping = false;
        for line in good.lines() {
            if line.starts_with('[') {
                skipping = line == "[[output]]";
            }
            if !skipping {
                kept.push(line);
            }
        }
        kept.join("\n")
    };
    assert!(!without_outputs.contains("measured"));
    let cases = [
        (
            "unknown_key.toml",
            format!("colour = \"red\"\n{good}"),
            "colour",
        ),
        (
            "empty_command.toml",
            good.lines()
                .map(|l| {
                    if l.starts_with("command") {
                        "command = []"
                    } else {
                        l
                    }
                })
                .collect::<Vec<_>>()
                .join("\n"),
            "command is empty",
        ),
        ("no_output.toml", without_outputs, "output"),
        (
            "bad_pick.toml",
            good.replace("[search]", "[search]\npick = \"best\""),
            "give topsis, topsis-common or minimax",
        ),
    ];
    for (name, spec_text, why) in cases {
        let spec = dir.path().join(name);
        std::fs::write(&spec, spec_text).unwrap();
        let out = dir.path().join(format!("run_{name}"));
        let output = calibrate_external(&spec, &out, &[]);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{name}: {message}");
        assert!(message.contains(name), "{name}: {message}");
        assert!(message.contains(why), "{name}: {message}");
        assert!(!out.exists(), "{name}: a run directory was created");
    }
}

// ---- acq gp fit / predict -------------------------------------------------------------

include!("../algorithms/tests/golden/gp_data.rs");

/// scikit-learn 1.9.1: GaussianProcessRegressor(ConstantKernel(1.7, "fixed") * K,
/// alpha=1e-3, optimizer=None, normalize_y=False); its std is the latent one, as acq's.
/// Kernel, `--fixed` values, means, stds (from `algorithms/tests/it/gp.rs`).
type Golden = (&'static str, &'static str, [f64; 5], [f64; 5]);
const GOLDEN: [Golden; 5] = [
    (
        "se",
        "0.4,0.7,1.7,1e-3",
        [
            1.7931799505805222,
            1.8586268247352482,
            -0.15369417425194487,
            0.3656361747965702,
            1.9468134127075694,
        ],
        [
            0.03053689928235394,
            0.030781183812292744,
            0.281663167611994,
            0.7146647134011842,
            0.03771081346731238,
        ],
    ),
    (
        "se",
        "0.5,1.7,1e-3",
        [
            1.7959995201348544,
            1.8561197750311598,
            -0.105495241320682,
            0.3540559448689836,
            1.953313938483916,
        ],
        [
            0.0292413108600734,
            0.031183886758704683,
            0.33990516822391004,
            0.6949034158011238,
            0.03476354206491609,
        ],
    ),
    (
        "matern12",
        "0.4,0.7,1.7,1e-3",
        [
            1.7477116433127433,
            1.857970412236193,
            0.37285449610841487,
            0.5187941873696016,
            1.8080568630974247,
        ],
        [
            0.5990764756317907,
            0.03160203738102981,
            1.0226997031631615,
            1.2128254719643934,
            0.6900537653950342,
        ],
    ),
    (
        "matern32",
        "0.4,0.7,1.7,1e-3",
        [
            1.7979850373864925,
            1.857914831634328,
            0.15990361788058988,
            0.4988944698953361,
            1.914517636876852,
        ],
        [
            0.1995451005013041,
            0.031565966112687416,
            0.7461101417741858,
            1.122536047361825,
            0.273391655048546,
        ],
    ),
    (
        "matern52",
        "0.4,0.7,1.7,1e-3",
        [
            1.7972013536825666,
            1.8578876807433242,
            0.07004040577491832,
            0.48912243529277055,
            1.9301005524825512,
        ],
        [
            0.10260279178537447,
            0.03151210178048967,
            0.601249550467936,
            1.0554621105089828,
            0.14914999110770177,
        ],
    ),
];

/// train.csv (a, b, y; an unused column in between) and points.csv (b before a).
fn gp_data(dir: &Path) -> (PathBuf, PathBuf) {
    let train = dir.join("train.csv");
    let mut csv = String::from("a,note,b,y\n");
    for x in &TRAIN_X {
        csv.push_str(&format!("{},unused,{},{}\n", x[0], x[1], smooth(x)));
    }
    std::fs::write(&train, csv).unwrap();
    let points = dir.join("points.csv");
    let mut csv = String::from("b,a\n");
    for x in &QUERY_X {
        csv.push_str(&format!("{},{}\n", x[1], x[0]));
    }
    std::fs::write(&points, csv).unwrap();
    (train, points)
}

fn gp_fit(train: &Path, model: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "gp",
        "fit",
        "--train",
        path_arg(train),
        "--inputs",
        "a,b",
        "--output",
        "y",
        "-o",
        path_arg(model),
    ];
    args.extend_from_slice(extra);
    acq(&args)
}

/// `acq gp predict`: the rows of mean,std.
fn gp_predict(model: &Path, points: &Path, out: &Path) -> Vec<(f64, f64)> {
    let output = acq(&[
        "gp",
        "predict",
        "--model",
        path_arg(model),
        "--points",
        path_arg(points),
        "-o",
        path_arg(out),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let table = Table::read(out);
    assert_eq!(table.header, ["mean", "std"]);
    table
        .rows
        .iter()
        .map(|r| (table.value(r, "mean"), table.value(r, "std")))
        .collect()
}

#[test]
fn gp_with_fixed_hyperparameters_matches_scikit_learn() {
    let dir = tempfile::tempdir().unwrap();
    let (train, points) = gp_data(dir.path());
    for (case, (kernel, fixed, means, stds)) in GOLDEN.iter().enumerate() {
        let model = dir.path().join(format!("model{case}.json"));
        let fixed_arg = format!("--fixed={fixed}");
        let output = gp_fit(&train, &model, &["--kernel", kernel, &fixed_arg]);
        assert!(
            output.status.success(),
            "{kernel} {fixed}: {}",
            stderr(&output)
        );
        assert!(
            stderr(&output).contains("GP on 12 points"),
            "{}",
            stderr(&output)
        );
        let predictions = gp_predict(&model, &points, &dir.path().join(format!("out{case}.csv")));
        assert_eq!(predictions.len(), QUERY_X.len());
        for (q, (mean, std)) in predictions.iter().enumerate() {
            assert!(
                (mean - means[q]).abs() < 1e-8,
                "{kernel} {fixed} query {q}: mean {mean} vs sklearn {}",
                means[q]
            );
            assert!(
                (std - stds[q]).abs() < 1e-8,
                "{kernel} {fixed} query {q}: std {std} vs sklearn {}",
                stds[q]
            );
        }
    }
}

#[test]
fn gp_fitted_model_round_trips_and_reproduces_its_training_data() {
    let dir = tempfile::tempdir().unwrap();
    let (train, _) = gp_data(dir.path());
    let model = dir.path().join("model.json");
    let output = gp_fit(
        &train,
        &model,
        &["--ard", "--kernel", "matern52", "--seed", "3"],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let saved = json(&model);
    assert_eq!(saved["inputs"], serde_json::json!(["a", "b"]));
    assert_eq!(saved["output"], "y");
    let at_training = dir.path().join("at_training.csv");
    let predictions = gp_predict(&model, &train, &at_training);
    assert_eq!(predictions.len(), TRAIN_X.len());
    let span = 2.0; // the outputs span about 1.6
    for (x, (mean, std)) in TRAIN_X.iter().zip(&predictions) {
        let y = smooth(x);
        assert!((mean - y).abs() < 0.02 * span, "{x:?}: {mean} vs {y}");
        assert!(
            std.is_finite() && *std >= 0.0 && *std < 0.1 * span,
            "{x:?}: std {std}"
        );
    }
    // Far outside the data the GP is less sure than at its training points.
    let far = dir.path().join("far.csv");
    std::fs::write(&far, "a,b\n3.0,-2.0\n").unwrap();
    let far_std = gp_predict(&model, &far, &dir.path().join("far_out.csv"))[0].1;
    let worst_training_std = predictions.iter().map(|p| p.1).fold(0.0, f64::max);
    assert!(
        far_std > worst_training_std,
        "{far_std} vs {worst_training_std}"
    );
}

#[test]
fn gp_usage_and_data_errors_have_their_exit_codes() {
    let dir = tempfile::tempdir().unwrap();
    let (train, _) = gp_data(dir.path());
    let model = dir.path().join("model.json");
    // Two inputs: 1 or 2 length scales, then two variances; 3 length scales is neither.
    let output = gp_fit(&train, &model, &["--fixed", "0.5,0.8,0.9,1.5,1e-6"]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("--fixed"), "{}", stderr(&output));
    let output = gp_fit(&train, &model, &["--fixed", "1.5,1e-6"]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(!model.exists());

    // A column that is not there: the file and the header line.
    let output = acq(&[
        "gp",
        "fit",
        "--train",
        path_arg(&train),
        "--inputs",
        "a,c",
        "--output",
        "y",
        "-o",
        path_arg(&model),
    ]);
    assert_eq!(output.status.code(), Some(3), "{}", stderr(&output));
    let message = stderr(&output);
    assert!(
        message.contains("train.csv") && message.contains("line 1") && message.contains("'c'"),
        "{message}"
    );
    // A bad cell: the file and its line.
    let broken = dir.path().join("broken.csv");
    std::fs::write(&broken, "a,b,y\n0.1,0.2,0.3\n0.4,oops,0.5\n").unwrap();
    let output = gp_fit(&broken, &model, &[]);
    assert_eq!(output.status.code(), Some(3), "{}", stderr(&output));
    let message = stderr(&output);
    assert!(
        message.contains("broken.csv") && message.contains("line 3") && message.contains("oops"),
        "{message}"
    );
    // Points without the model's columns.
    let fixed = gp_fit(&train, &model, &["--fixed", "0.5,1.7,1e-3"]);
    assert!(fixed.status.success(), "{}", stderr(&fixed));
    let wrong = dir.path().join("wrong.csv");
    std::fs::write(&wrong, "a,z\n0.1,0.2\n").unwrap();
    let output = acq(&[
        "gp",
        "predict",
        "--model",
        path_arg(&model),
        "--points",
        path_arg(&wrong),
        "-o",
        path_arg(&dir.path().join("p.csv")),
    ]);
    assert_eq!(output.status.code(), Some(3), "{}", stderr(&output));
    assert!(stderr(&output).contains("wrong.csv"), "{}", stderr(&output));
}

// ---- acq moo ----------------------------------------------------------------------------

fn moo(problem: &str, out: &Path) -> std::process::Output {
    acq(&[
        "moo",
        "--problem",
        problem,
        "--pop",
        "40",
        "--gens",
        "50",
        "--seed",
        "3",
        "-o",
        path_arg(out),
    ])
}

fn front(path: &Path, objectives: usize) -> Vec<Vec<f64>> {
    let table = Table::read(path);
    let header: Vec<String> = (1..=objectives).map(|k| format!("f{k}")).collect();
    assert_eq!(table.header, header);
    table
        .rows
        .iter()
        .map(|r| r.iter().map(|c| c.parse::<f64>().unwrap()).collect())
        .collect()
}

fn dominates(a: &[f64], b: &[f64]) -> bool {
    a.iter().zip(b).all(|(x, y)| x <= y) && a.iter().zip(b).any(|(x, y)| x < y)
}

/// The reported hypervolume from the stderr line.
fn reported_hypervolume(message: &str) -> f64 {
    let after = message
        .split("hypervolume ")
        .nth(1)
        .unwrap_or_else(|| panic!("no hypervolume in {message:?}"));
    after
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap_or_else(|_| panic!("no number after hypervolume in {message:?}"))
}

#[test]
fn moo_zdt1_front_is_non_dominated_with_its_hypervolume() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("front.csv");
    let output = moo("zdt1", &out);
    assert!(output.status.success(), "{}", stderr(&output));
    let points = front(&out, 2);
    assert!(points.len() >= 10, "{} points", points.len());
    for (i, a) in points.iter().enumerate() {
        assert!((0.0..=1.0).contains(&a[0]), "f1 = {}", a[0]);
        // ZDT1: f2 = g (1 - sqrt(f1 / g)) with g >= 1, never below the true front.
        assert!(
            a[1] >= 1.0 - a[0].sqrt() - 1e-12,
            "{a:?} below the Pareto front"
        );
        for (j, b) in points.iter().enumerate() {
            assert!(i == j || !dominates(b, a), "{b:?} dominates {a:?}");
        }
    }
    // The hypervolume against (1.1, 1.1), computed here by a sweep over f1.
    let mut inside: Vec<&Vec<f64>> = points.iter().filter(|p| p[0] < 1.1 && p[1] < 1.1).collect();
    inside.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let mut volume = 0.0;
    let mut ceiling = 1.1;
    for p in inside {
        if p[1] < ceiling {
            volume += (1.1 - p[0]) * (ceiling - p[1]);
            ceiling = p[1];
        }
    }
    let reported = reported_hypervolume(&stderr(&output));
    assert!(volume > 0.0);
    assert!((reported - volume).abs() < 1e-6, "{reported} vs {volume}");
}

#[test]
fn moo_dtlz2_has_three_objectives_and_unknown_problems_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("front.csv");
    let output = moo("dtlz2", &out);
    assert!(output.status.success(), "{}", stderr(&output));
    let volume = reported_hypervolume(&stderr(&output));
    assert!(volume > 0.0 && volume < 1.1f64.powi(3), "{volume}");
    let points = front(&out, 3);
    assert!(points.len() >= 10);
    for (i, a) in points.iter().enumerate() {
        // DTLZ2: the objectives lie on a sphere of radius 1 + g >= 1, in the positive octant.
        assert!(a.iter().all(|&f| f >= 0.0), "{a:?}");
        let radius = a.iter().map(|f| f * f).sum::<f64>().sqrt();
        assert!(radius >= 1.0 - 1e-9, "{a:?} inside the unit sphere");
        for (j, b) in points.iter().enumerate() {
            assert!(i == j || !dominates(b, a), "{b:?} dominates {a:?}");
        }
    }

    let missing = dir.path().join("none.csv");
    let output = moo("zdt9", &missing);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("zdt9"), "{}", stderr(&output));
    assert!(!missing.exists());
}

#[test]
fn parallel_solver_runs_each_work_in_their_own_directory_with_the_files_they_need() {
    // A solver as FE solvers are: it reads its input deck from the working
    // directory and writes a fixed file name there (job.dat) before its result.
    // Two runs sharing a directory would read each other's job.dat.
    let dir = tempfile::tempdir().unwrap();
    let spec_dir = dir.path().join("model");
    std::fs::create_dir(&spec_dir).unwrap();
    std::fs::write(spec_dir.join("deck.inp"), "scale 2\n").unwrap();
    std::fs::write(
        spec_dir.join("fixed.sh"),
        r#"read -r word scale < deck.inp
echo "$1" > job.dat
sleep 0.3
v=$(cat job.dat)
awk -v v="$v" -v s="$scale" 'BEGIN { printf "{\"y\": %.17g}\n", v * s }' > out.json
"#,
    )
    .unwrap();
    let spec = spec_dir.join("spec.toml");
    std::fs::write(
        &spec,
        r#"command = ["sh", "fixed.sh", "{x}"]
output_file = "out.json"
link_files = ["deck.inp"]
timeout_s = 20
parallel = 2

[[parameter]]
name = "x"
lower = 1.0
upper = 2.0

[[output]]
name = "y"
measured = 3.0

[search]
start = "lhs"
start_runs = 4
max_evals = 6
"#,
    )
    .unwrap();
    let out = dir.path().join("run");
    // From another working directory: the spec's files are found all the same.
    let output = Command::new(env!("CARGO_BIN_EXE_acq"))
        .args(["calibrate", "external", "--spec"])
        .arg(&spec)
        .arg("--out")
        .arg(&out)
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    let log = Table::read(&out.join("evaluations.csv"));
    assert_eq!(log.rows.len(), 6);
    for row in &log.rows {
        assert_eq!(log.cell(row, "status"), "ok", "{row:?}");
        let (x, y) = (log.value(row, "x"), log.value(row, "y"));
        assert!((y - 2.0 * x).abs() < 1e-9, "run with x = {x} returned {y}");
    }
    let runs: Vec<PathBuf> = std::fs::read_dir(out.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(runs.len(), 6);
    for run in &runs {
        assert!(run.join("job.dat").is_file(), "{}", run.display());
        let deck = run.join("deck.inp");
        assert!(deck.symlink_metadata().unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read_to_string(deck).unwrap(), "scale 2\n");
    }
    assert!(!spec_dir.join("job.dat").exists() && !dir.path().join("job.dat").exists());
}

#[test]
fn an_external_solver_can_return_a_curve_scored_by_the_curve_mape() {
    // The closed form of common::parabola_study: MAPE = 50 |2 - a| %.
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("model");
    std::fs::create_dir(&model).unwrap();
    let spec = parabola_study(
        &model,
        "start = \"lhs\"\nstart_runs = 4\nmax_evals = 12\ntarget_loss_pct = 0.5\n",
    );
    // The units name the report's axes.
    let text = std::fs::read_to_string(&spec).unwrap().replace(
        "measured_y = \"FORCE\"\n",
        "measured_y = \"FORCE\"\nx_unit = \"mm\"\ny_unit = \"kN\"\n",
    );
    std::fs::write(&spec, text).unwrap();
    let out = dir.path().join("run");
    let output = calibrate_external(&spec, &out, &[]);
    assert!(output.status.success(), "{}", stderr(&output));
    let log = Table::read(&out.join("evaluations.csv"));
    // A BO study takes local steps by default, on the curve's signed
    // errors in 20 parts, which the log keeps for --resume.
    let parts: Vec<String> = (1..=20)
        .map(|k| format!("force_displacement.part{k:02}"))
        .collect();
    let mut header = vec!["id", "status", "wall_s", "a", "force_displacement"];
    header.extend(parts.iter().map(String::as_str));
    header.push("reason");
    assert_eq!(log.header, header);
    for row in &log.rows {
        assert_eq!(log.cell(row, "status"), "ok", "{row:?}");
        let a = log.value(row, "a");
        let mape = log.value(row, "force_displacement");
        assert!(
            (mape - 50.0 * (2.0 - a).abs()).abs() < 1e-6,
            "a = {a}: MAPE {mape}, closed form {}",
            50.0 * (2.0 - a).abs()
        );
        // Every point misses by the same signed (a - 2) / 2, so every part does.
        for part in &parts {
            let signed = log.value(row, part);
            assert!(
                (signed - 50.0 * (a - 2.0)).abs() < 1e-6,
                "a = {a}: {part} {signed}, closed form {}",
                50.0 * (a - 2.0)
            );
        }
    }
    let summary = json(&out.join("summary.json"));
    let best = summary["best_params"]["a"].as_f64().unwrap();
    let loss = summary["best_loss_pct"].as_f64().unwrap();
    assert!((loss - 50.0 * (2.0 - best).abs()).abs() < 1e-6, "{summary}");
    assert!(loss < 0.5, "BO reached {loss} % (target 0.5 %): {summary}");
    assert_eq!(
        summary["best_outputs"]["force_displacement"].as_f64(),
        Some(loss)
    );
    // The report draws the calibrated curve against the measured one, read
    // back from the best run's directory (no extra run), and says how far
    // it misses along it: everywhere |2 - a| / 2, so the largest error is
    // the MAPE.
    let report = common::report::read(&out);
    let line = report
        .lines()
        .find(|l| l.starts_with("force_displacement (the test): MAPE"))
        .unwrap_or_else(|| panic!("no curve paragraph in\n{report}"));
    let number_after = |label: &str| -> f64 {
        let rest = &line[line.find(label).unwrap() + label.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    for label in ["MAPE ", "largest error "] {
        let reported = number_after(label);
        assert!(
            (reported - loss).abs() < 1e-3,
            "{label}{reported} against {loss}: {line}"
        );
    }
    let svg = std::fs::read_to_string(out.join("curve.svg")).unwrap();
    assert!(svg.contains("measured") && svg.contains("calibrated model"));
    assert!(
        svg.contains("DISPLACEMENT [mm]") && svg.contains("FORCE [kN]"),
        "axes without their units"
    );
    let runs = std::fs::read_dir(out.join("runs")).unwrap().count();
    assert_eq!(runs, log.rows.len(), "a run was made for the report");
}
