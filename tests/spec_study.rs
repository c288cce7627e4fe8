//! The study runner from the outside: both published methods on a user's
//! solver (the external adapter wrapping acq's own twins gives the same
//! calibration as the built-in presets), several load cases with shared and
//! per-case parameters, validation cases, and measurement uncertainty.

mod common;

use std::path::{Path, PathBuf};

use common::{acq, external_summary, number, path_arg, root, stderr};
use serde_json::Value;

fn calibrate(kind: &str, args: &[&str]) -> std::process::Output {
    let mut all = vec!["calibrate", kind];
    all.extend_from_slice(args);
    acq(&all)
}

fn summary(run: &Path) -> Value {
    let text = std::fs::read_to_string(run.join("summary.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn acq_binary() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_acq"))
}

fn run_external(spec: &Path, out: &Path) -> Value {
    run_external_seeded(spec, out, "1")
}

fn run_external_seeded(spec: &Path, out: &Path, seed: &str) -> Value {
    external_summary(spec, out, &["--seed", seed])
}

/// Writes `text` as `wrapped.toml` in `dir` and runs it into `dir/wrapped`.
fn run_wrapped(dir: &Path, text: &str, seed: &str) -> (PathBuf, Value) {
    let spec_path = dir.join("wrapped.toml");
    std::fs::write(&spec_path, text).unwrap();
    let wrapped = dir.join("wrapped");
    let summary = run_external_seeded(&spec_path, &wrapped, seed);
    (wrapped, summary)
}

#[test]
fn the_excavator_method_on_a_wrapped_twin_gives_the_built_in_calibration() {
    // The user's "solver" is `acq twin excavator --json`, read through the
    // nested key paths of its JSON. Same seed, same designs, same GPs: the
    // study runner must reproduce `acq calibrate excavator` number for number.
    let dir = tempfile::tempdir().unwrap();
    let case = root().join("data/excavator/case1.toml");
    let builtin = dir.path().join("builtin");
    let output = calibrate(
        "excavator",
        &[
            "--case",
            path_arg(&case),
            "--out",
            path_arg(&builtin),
            "--seed",
            "3",
        ],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let expected = summary(&builtin);

    let case_text = std::fs::read_to_string(&case).unwrap();
    let bounds: toml::Table = toml::from_str(&case_text).unwrap();
    let bound = |name: &str| -> (f64, f64) {
        let pair = bounds["bounds"][name].as_array().unwrap();
        let get = |v: &toml::Value| v.as_float().or(v.as_integer().map(|i| i as f64)).unwrap();
        (get(&pair[0]), get(&pair[1]))
    };
    let measured = &bounds["measured"];
    let mut spec = format!(
        r#"command = ["sh", "-c", "\"$0\" twin excavator --case \"$1\" --bucket-stroke \"$2\" --arm-stroke \"$3\" --boom-stroke \"$4\" --angle \"$5\" --json > out.json", "{acq}", "{case}", "{{bucket_stroke_mm}}", "{{arm_stroke_mm}}", "{{boom_stroke_mm}}", "{{force_angle_deg}}"]
output_file = "out.json"
parallel = 2
"#,
        acq = acq_binary().display(),
        case = case.display()
    );
    for name in [
        "bucket_stroke_mm",
        "arm_stroke_mm",
        "boom_stroke_mm",
        "force_angle_deg",
    ] {
        let (lower, upper) = bound(name);
        spec.push_str(&format!(
            "\n[[parameter]]\nname = \"{name}\"\nlower = {lower:?}\nupper = {upper:?}\n"
        ));
    }
    for cylinder in ["bucket", "arm", "boom"] {
        let value = measured[&format!("{cylinder}_bar")].as_float().unwrap();
        spec.push_str(&format!(
            "\n[[output]]\nname = \"pressure_bar.{cylinder}\"\nmeasured = {value:?}\n"
        ));
    }
    // The preset picks minimax; a spec's default is the published TOPSIS.
    spec.push_str("\n[search]\nmethod = \"surrogate-moo\"\npick = \"minimax\"\n");
    let (wrapped, got) = run_wrapped(dir.path(), &spec, "3");

    let close = |a: f64, b: f64, what: &str| {
        assert!(
            (a - b).abs() <= 1e-9 * a.abs().max(1.0),
            "{what}: built-in {a}, wrapped {b}"
        );
    };
    for cylinder in ["bucket", "arm", "boom"] {
        let key = format!("pressure_bar.{cylinder}");
        for which in ["errors_initial_pct", "errors_optimal_pct"] {
            close(
                number(&expected, &[which, cylinder]),
                number(&got, &[which, &key]),
                &format!("{which} {cylinder}"),
            );
        }
        close(
            number(&expected, &["surrogate_rmse_bar", "gp", cylinder]),
            number(&got, &["surrogate_rmse", "gp", &key]),
            &format!("GP RMSE {cylinder}"),
        );
    }
    for name in [
        "bucket_stroke_mm",
        "arm_stroke_mm",
        "boom_stroke_mm",
        "force_angle_deg",
    ] {
        close(
            number(&expected, &["optimal", name]),
            number(&got, &["optimal", name]),
            name,
        );
    }
    assert_eq!(expected["evaluations"], got["evaluations"]);
    let report = common::report::read(&wrapped);
    assert!(report.contains("Identifiability"), "{report}");
    assert!(wrapped.join("pareto.svg").exists());
}

#[test]
fn the_tensile_method_on_a_wrapped_twin_gives_the_built_in_calibration() {
    // The user's solver is `acq twin gtn -o curve.csv`; its curve is scored by
    // the same curve MAPE, and Bayesian optimisation starts from the same L12
    // and takes the same local steps on the curve's parts.
    let dir = tempfile::tempdir().unwrap();
    let test = root().join("data/tensile/P91_20_2_DF_SS.csv");
    assert!(test.exists(), "{}", test.display());
    let builtin = dir.path().join("builtin");
    let common = ["--mesh", "3x12", "--max-evals", "16", "--seed", "2"];
    // A wrapped solver gives no slopes: the built-in search fits its
    // local steps' slopes to the runs too.
    let mut args = vec![
        "--test",
        path_arg(&test),
        "--out",
        path_arg(&builtin),
        "--fitted-slopes",
    ];
    args.extend_from_slice(&common);
    let output = calibrate("gtn", &args);
    assert!(output.status.success(), "{}", stderr(&output));
    let expected = summary(&builtin);

    let names = ["q1", "q2", "q3", "epsN", "sN", "fN", "f0", "m"];
    let params: Vec<String> = names.iter().map(|n| format!("{n}={{{n}}}")).collect();
    let mut spec = format!(
        r#"command = ["{acq}", "twin", "gtn", "--test", "{test}", "--mesh", "3x12", "--param", "{params}", "-o", "curve.csv"]
parallel = 1
"#,
        acq = acq_binary().display(),
        test = test.display(),
        params = params.join(",")
    );
    // The bounds as the built-in run reports them (m's comes from the test).
    let report = common::report::read(&builtin);
    let bound = |name: &str| -> (f64, f64) {
        let row = report
            .lines()
            .find(|l| l.starts_with(&format!("| {name} |")))
            .unwrap_or_else(|| panic!("no row {name} in\n{report}"));
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        (cells[2].parse().unwrap(), cells[3].parse().unwrap())
    };
    for name in names {
        let (lower, upper) = bound(name);
        spec.push_str(&format!(
            "\n[[parameter]]\nname = \"{name}\"\nlower = {lower:?}\nupper = {upper:?}\n"
        ));
    }
    spec.push_str(&format!(
        r#"
[[curve]]
name = "force_displacement"
file = "curve.csv"
x = "DISPLACEMENT"
y = "FORCE"
measured_file = "{test}"
measured_x = "DISPLACEMENT"
measured_y = "FORCE"

[search]
method = "bo"
start = "l12"
max_evals = 16
target_loss_pct = 2.0
local_steps = true
"#,
        test = test.display()
    ));
    let (_, got) = run_wrapped(dir.path(), &spec, "2");
    let best = number(&expected, &["best_mape"]);
    let wrapped_best = number(&got, &["best_loss_pct"]);
    assert!(
        (best - wrapped_best).abs() <= 1e-9 * best,
        "best MAPE: built-in {best}, wrapped {wrapped_best}"
    );
    for name in names {
        let a = number(&expected, &["best_params", name]);
        let b = number(&got, &["best_params", name]);
        assert!(
            (a - b).abs() <= 1e-9 * a.abs().max(1e-3),
            "{name}: {a} vs {b}"
        );
    }
    assert_eq!(expected["evaluations"], got["evaluations"]);
}

/// A spring seated with an offset: deflection `u = F / k + d + s F^2` (mm,
/// kN), measured at two loads per case. The stiffness k is shared, the
/// seating offset d is each case's own, s is the softening the real spring
/// has (a fixed input: 0 makes the wrong, linear model).
const SPRING: &str = r#"awk -v k="$1" -v d="$2" -v f1="$3" -v f2="$4" -v s="$5" 'BEGIN {
    printf "{\"u_low_mm\": %.17g, \"u_high_mm\": %.17g}\n", f1 / k + d + s * f1 * f1, f2 / k + d + s * f2 * f2
}' > out.json
"#;

const TRUE_K: f64 = 2.5;
const TRUE_S: f64 = 0.002;

fn spring_deflection(force_kn: f64, offset_mm: f64) -> f64 {
    force_kn / TRUE_K + offset_mm + TRUE_S * force_kn * force_kn
}

/// The spring study: cases A and B (low loads) fit k and their offsets, case
/// C (ten times the load) validates. `model_softening` is what the model is
/// told s is.
fn spring_spec(dir: &Path, model_softening: f64) -> PathBuf {
    std::fs::write(dir.join("spring.sh"), SPRING).unwrap();
    let cases = [
        ("A", "fit", 2.0, 4.0, 0.3),
        ("B", "fit", 3.0, 6.0, -0.2),
        ("C", "validate", 20.0, 40.0, 0.1),
    ];
    let mut spec = String::from(
        r#"command = ["sh", "spring.sh", "{k_kn_per_mm}", "{offset_mm}", "{f_low_kn}", "{f_high_kn}", "{softening}"]
output_file = "out.json"
parallel = 2

[[parameter]]
name = "k_kn_per_mm"
lower = 1.0
upper = 5.0

[[parameter]]
name = "offset_mm"
case = "A"
lower = -1.0
upper = 1.0

[[parameter]]
name = "offset_mm"
case = "B"
lower = -1.0
upper = 1.0

[search]
method = "surrogate-moo"
"#,
    );
    for (name, role, low, high, offset) in cases {
        // The validate case's offset was measured (it is not calibrated).
        let offset_input = if role == "validate" {
            format!(", offset_mm = {offset:?}")
        } else {
            String::new()
        };
        spec.push_str(&format!(
            "\n[[case]]\nname = \"{name}\"\nrole = \"{role}\"\ninputs = {{ f_low_kn = {low:?}, f_high_kn = {high:?}, softening = {model_softening:?}{offset_input} }}\nmeasured = {{ u_low_mm = {:?}, u_high_mm = {:?} }}\n",
            spring_deflection(low, offset),
            spring_deflection(high, offset)
        ));
    }
    let path = dir.join("spring.toml");
    std::fs::write(&path, spec).unwrap();
    path
}

#[test]
fn a_shared_parameter_is_recovered_from_two_fit_cases_and_checked_on_a_validate_case() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spring_spec(dir.path(), TRUE_S);
    let out = dir.path().join("run");
    let got = run_external(&spec, &out);
    // The model is exact at the truth and each deflection is smooth in the
    // parameters, so the GPs are nearly exact and every error can reach 0 at
    // once. k follows from the difference of two deflections (about 1 mm out
    // of 1-3 mm): k within 1 % means each deflection within about 0.3 %.
    let k = number(&got, &["optimal", "k_kn_per_mm"]);
    assert!((k - TRUE_K).abs() < 0.01 * TRUE_K, "k = {k}");
    let offset_a = number(&got, &["optimal", "A/offset_mm"]);
    assert!((offset_a - 0.3).abs() < 0.05, "offset A = {offset_a}");
    assert_eq!(got["cases"]["C"]["role"], "validate");
    assert_eq!(got["cases"]["A"]["role"], "fit");
    let validation = number(&got, &["cases", "C", "errors_pct", "u_high_mm"]);
    assert!(validation < 2.0, "validate error {validation} %: {got:#}");
    // The search never saw case C: its runs are only in validation.csv.
    let log = std::fs::read_to_string(out.join("evaluations.csv")).unwrap();
    assert!(!log.contains("C/"), "{}", log.lines().next().unwrap());
    let validation_log = std::fs::read_to_string(out.join("validation.csv")).unwrap();
    assert_eq!(validation_log.lines().count(), 2, "{validation_log}");
    let report = common::report::read(&out);
    assert!(report.contains("Validation cases"), "{report}");
    assert!(report.contains("about as well"), "{report}");

    // The HTML report as a reader sees it, in a real Chromium: no console
    // error, every table and plot shown.
    let page = common::browser::check_page(&out.join("report.html"))
        .unwrap_or_else(|e| panic!("browser check failed: {e}"));
    assert!(page.console_errors.is_empty(), "{:?}", page.console_errors);
    assert!(
        page.tables.iter().all(|t| t.visible && t.body_rows > 0),
        "{:?}",
        page.tables
    );
    let headers: Vec<&str> = page
        .tables
        .iter()
        .map(|t| t.first_header.as_str())
        .collect();
    for wanted in ["case", "parameter", "correlation", "surrogate"] {
        assert!(headers.contains(&wanted), "{headers:?}");
    }
    // Identifiability, Pareto front and loss plots.
    assert!(page.visible_svgs >= 3, "{} plots shown", page.visible_svgs);

    // Resumed, the study retraces itself from its logs: no model run again,
    // the same answer.
    std::fs::remove_file(out.join("summary.json")).unwrap();
    let runs_before = std::fs::read_dir(out.join("runs")).unwrap().count();
    let output = calibrate(
        "external",
        &[
            "--spec",
            path_arg(&spec),
            "--out",
            path_arg(&out),
            "--resume",
        ],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    assert_eq!(
        std::fs::read_dir(out.join("runs")).unwrap().count(),
        runs_before
    );
    let again = summary(&out);
    assert_eq!(again["optimal"], got["optimal"]);
    assert_eq!(again["cases"], got["cases"]);
}

#[test]
fn a_wrong_model_fits_its_cases_but_fails_its_validate_case_and_the_report_says_so() {
    // A linear spring (s = 0) calibrated at low loads, where softening adds
    // under 2 % to the deflection, cannot predict ten times the load: there
    // s F^2 = 3.2 mm of 19 mm.
    let dir = tempfile::tempdir().unwrap();
    let spec = spring_spec(dir.path(), 0.0);
    let out = dir.path().join("run");
    let got = run_external(&spec, &out);
    let fit = number(&got, &["cases", "A", "errors_pct", "u_high_mm"]);
    let validation = number(&got, &["cases", "C", "errors_pct", "u_high_mm"]);
    assert!(fit < 3.0, "fit error {fit} %");
    assert!(validation > 10.0, "validate error {validation} %");
    let report = common::report::read(&out);
    assert!(report.contains("does not carry over"), "{report}");
}

/// Standard normal deviates from a fixed seed (Box-Muller on an LCG), so the
/// test's noise is reproducible without a dependency.
fn normal_deviates(count: usize, mut state: u64) -> Vec<f64> {
    let mut uniform = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..count)
        .map(|_| {
            let (a, b) = (uniform(), uniform());
            (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
        })
        .collect()
}

/// `line.sh A B` in `dir`: writes `out.json` with `y<i> = A x_i + B`.
fn write_line_solver(dir: &Path, xs: &[f64]) {
    let mut script = String::from("awk -v a=\"$1\" -v b=\"$2\" 'BEGIN { printf \"{\"; ");
    for (i, x) in xs.iter().enumerate() {
        let comma = if i + 1 < xs.len() { "," } else { "" };
        script.push_str(&format!(
            "printf \"\\\"y{i}\\\": %.17g{comma}\", a * {x:?} + b; "
        ));
    }
    script.push_str("print \"}\" }' > out.json\n");
    std::fs::write(dir.join("line.sh"), script).unwrap();
}

#[test]
fn chi_square_of_a_fit_to_noisy_data_is_close_to_the_number_of_observations() {
    // A line y = a x + b observed at 30 points with Gaussian noise of known
    // sigma. The least-squares chi-square is computed here in closed form
    // (weighted linear regression); the study must get close to it, and it
    // must lie in the chi-square distribution's bulk for 28 degrees of
    // freedom. With the uncertainty understated five times, the report must
    // say the misfit is more than the instruments explain.
    let (a, b, sigma) = (1.5, 4.0, 0.2);
    let xs: Vec<f64> = (1..=30).map(|i| f64::from(i) * 0.5).collect();
    let noise = normal_deviates(xs.len(), 7);
    let ys: Vec<f64> = xs
        .iter()
        .zip(&noise)
        .map(|(x, n)| a * x + b + sigma * n)
        .collect();
    // Least squares with equal weights.
    let n = xs.len() as f64;
    let (sx, sy) = (xs.iter().sum::<f64>(), ys.iter().sum::<f64>());
    let sxx = xs.iter().map(|x| x * x).sum::<f64>();
    let sxy = xs.iter().zip(&ys).map(|(x, y)| x * y).sum::<f64>();
    let slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    let intercept = (sy - slope * sx) / n;
    let chi2_min: f64 = xs
        .iter()
        .zip(&ys)
        .map(|(x, y)| ((y - slope * x - intercept) / sigma).powi(2))
        .sum();
    let dof = n - 2.0;
    assert!(
        (chi2_min - dof).abs() < 4.0 * (2.0 * dof).sqrt(),
        "the test data: chi2 {chi2_min}"
    );

    for (stated_sigma, agrees) in [(sigma, true), (sigma / 5.0, false)] {
        let dir = tempfile::tempdir().unwrap();
        write_line_solver(dir.path(), &xs);
        // One run at a time: with more, Bayesian optimisation proposes as
        // runs finish, so its path (and these bounds) would depend on the
        // machine's load.
        let mut spec = String::from(
            r#"command = ["sh", "line.sh", "{a}", "{b}"]
output_file = "out.json"
parallel = 1

[[parameter]]
name = "a"
lower = 0.5
upper = 3.0

[[parameter]]
name = "b"
lower = 2.0
upper = 6.0

[search]
method = "bo"
residuals = "normalised"
start_runs = 10
max_evals = 60
"#,
        );
        for (i, y) in ys.iter().enumerate() {
            spec.push_str(&format!(
                "\n[[output]]\nname = \"y{i}\"\nmeasured = {y:?}\nuncertainty = {stated_sigma:?}\n"
            ));
        }
        let spec_path = dir.path().join("line.toml");
        std::fs::write(&spec_path, spec).unwrap();
        let out = dir.path().join("run");
        let got = run_external(&spec_path, &out);
        let chi2 = number(&got, &["chi_square", "value"]);
        assert_eq!(got["chi_square"]["observations"], 30);
        let scale = (sigma / stated_sigma).powi(2);
        // BO minimises the mean |residual|, not its square: its chi-square is
        // at least the least-squares one and, near that optimum, close to it.
        assert!(
            chi2 >= chi2_min * scale * (1.0 - 1e-9) && chi2 <= chi2_min * scale * 1.25 + 2.0,
            "chi2 {chi2}, least squares {}",
            chi2_min * scale
        );
        let report = common::report::read(&out);
        assert_eq!(
            report.contains("within what the instruments can tell"),
            agrees,
            "{report}"
        );
        // Identifiability against weighted linear regression's closed form:
        // sigma_a = s / sqrt(Sxx), sigma_b = s sqrt(1/n + mean^2 / Sxx),
        // corr(a, b) = -mean / sqrt(Sxx / n + mean^2), with s the stated
        // uncertainty. The analysis differentiates GPs fitted to the
        // logged runs of a plane: within 5 %.
        let identified: Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("identifiability.json")).unwrap(),
        )
        .unwrap();
        let mean = sx / n;
        let spread_xx = sxx - n * mean * mean;
        let expected = [
            ("a", stated_sigma / spread_xx.sqrt()),
            (
                "b",
                stated_sigma * (1.0 / n + mean * mean / spread_xx).sqrt(),
            ),
        ];
        for (name, sigma) in expected {
            let got_sigma = number(&identified, &["standard_uncertainty", name]);
            assert!(
                (got_sigma - sigma).abs() < 0.05 * sigma,
                "{name}: {got_sigma} vs closed form {sigma}"
            );
        }
        let rho = number(&identified, &["correlation", "a", "b"]);
        let expected_rho = -mean / (spread_xx / n + mean * mean).sqrt();
        assert!((rho - expected_rho).abs() < 0.02, "{rho} vs {expected_rho}");
    }
}

#[test]
fn an_uncertain_load_magnitude_is_calibrated_like_the_strokes() {
    // The measured pressures are the twin's own at 30 kN, with strokes and
    // angle known to within +-0.5 mm / +-0.5 deg. The case states 40 kN but
    // lets the load range over 20-45 kN: the calibration must find the
    // load. The pressures are linear in the load, so the only confusion
    // left comes from the narrow angle range (half a degree turns the
    // load's lever arm by about one percent): within 3 % is a fair bound.
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("unknown_load.toml");
    let bounds = "[bounds]\nbucket_stroke_mm = [120.5, 121.5]\narm_stroke_mm = [209.5, 210.5]\nboom_stroke_mm = [466.5, 467.5]\nforce_angle_deg = [-10.5, -9.5]\nforce_kN = [20.0, 45.0]\n";
    std::fs::write(
        &case,
        format!("name = \"unknown_load\"\nforce_kN = 40.0\n{bounds}"),
    )
    .unwrap();
    let output = acq(&[
        "twin",
        "excavator",
        "--case",
        path_arg(&case),
        "--force",
        "30",
        "--json",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let twin: Value = serde_json::from_slice(&output.stdout).unwrap();
    let pressure = |name: &str| number(&twin, &["pressure_bar", name]);
    std::fs::write(
        &case,
        format!(
            "name = \"unknown_load\"\nforce_kN = 40.0\n{bounds}[measured]\nbucket_bar = {:?}\narm_bar = {:?}\nboom_bar = {:?}\n",
            pressure("bucket"),
            pressure("arm"),
            pressure("boom")
        ),
    )
    .unwrap();
    let out = dir.path().join("run");
    let output = calibrate(
        "excavator",
        &["--case", path_arg(&case), "--out", path_arg(&out)],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let got = summary(&out);
    let force = number(&got, &["optimal", "force_kN"]);
    assert!((force - 30.0).abs() < 0.03 * 30.0, "force {force} kN");
    // At the stated 40 kN the pressures are well off (the load is a third
    // too high; gravity carries the rest of each pressure); at the found
    // load the twin reproduces its own pressures.
    let largest = |key: &str| {
        ["bucket", "arm", "boom"]
            .iter()
            .map(|c| number(&got, &[key, c]))
            .fold(0.0f64, f64::max)
    };
    assert!(largest("errors_initial_pct") > 10.0, "{got:#}");
    assert!(largest("errors_optimal_pct") < 1.0, "{got:#}");
}

/// The twin's loaded-chamber pressures (bucket, arm, boom) with the
/// geometry numbers at these key paths, the poses re-fitted.
fn twin_pressures(geometry: &[(&str, f64)], strokes: [f64; 3], angle_deg: f64) -> [f64; 3] {
    use acq_twins::excavator::geometry::GeometryTemplate;
    use acq_twins::excavator::pose_fit::{published_poses, refit_poses};
    use acq_twins::excavator::{CylinderName, Excavator, Inputs, Strokes};
    let mut changed = GeometryTemplate::dx55().with(geometry).unwrap();
    refit_poses(&mut changed, &published_poses()).unwrap();
    let twin = Excavator::new(changed).unwrap();
    let evaluation = twin
        .evaluate(&Inputs {
            strokes: Strokes {
                bucket_mm: strokes[0],
                arm_mm: strokes[1],
                boom_mm: strokes[2],
            },
            tip_force_kn: 40.6,
            tip_force_angle_deg: angle_deg,
        })
        .unwrap();
    CylinderName::ALL.map(|c| evaluation.cylinder(c).loaded_chamber_pressure_bar)
}

#[test]
fn geometry_numbers_of_the_built_in_twin_are_identified_from_two_cases() {
    // The truth: a heavier bucket (180 kg, the file says 150) and the boom
    // cylinder's base pin 3 cm lower. The "measurement" is the twin at the
    // truth (poses re-fitted) in the two published poses; a third pose,
    // the boom raised and the arm in, validates.
    let truth = [
        ("bucket.mass_kg", 180.0),
        ("base.boom_cylinder_pin_m[1]", -0.43),
    ];
    let poses = [
        ("case1", "fit", [121.0, 210.0, 467.0], -10.0),
        ("case2", "fit", [371.0, 35.0, 281.0], -5.0),
        ("raised", "validate", [250.0, 120.0, 600.0], -20.0),
    ];
    let mut spec = String::from(
        r#"model = "excavator"

[[parameter]]
name = "bucket.mass_kg"
lower = 100.0
upper = 250.0

[[parameter]]
name = "base.boom_cylinder_pin_m[1]"
lower = -0.50
upper = -0.34

[search]
method = "surrogate-moo"
"#,
    );
    for (name, role, strokes, angle) in poses {
        let [bucket, arm, boom] = twin_pressures(&truth, strokes, angle);
        spec.push_str(&format!(
            "\n[[case]]\nname = \"{name}\"\nrole = \"{role}\"\ninputs = {{ bucket_stroke_mm = {:?}, arm_stroke_mm = {:?}, boom_stroke_mm = {:?}, force_angle_deg = {angle:?}, force_kN = 40.6 }}\nmeasured = {{ \"pressure_bar.bucket\" = {bucket:?}, \"pressure_bar.arm\" = {arm:?}, \"pressure_bar.boom\" = {boom:?} }}\n",
            strokes[0], strokes[1], strokes[2]
        ));
    }
    let dir = tempfile::tempdir().unwrap();
    let spec_path = dir.path().join("geometry.toml");
    std::fs::write(&spec_path, spec).unwrap();
    let out = dir.path().join("run");
    let got = run_external(&spec_path, &out);
    let mass = number(&got, &["optimal", "bucket.mass_kg"]);
    let pin = number(&got, &["optimal", "base.boom_cylinder_pin_m[1]"]);
    // The twin is its own truth here, so only the surrogates limit the
    // answer: 2 % of the mass (3.6 kg) and 5 mm of pin height are far
    // coarser than they are, and far finer than the nominal file's error.
    assert!((mass - 180.0).abs() < 0.02 * 180.0, "bucket mass {mass} kg");
    assert!(
        (pin + 0.43).abs() < 0.005,
        "boom cylinder base pin z {pin} m"
    );
    let validation = number(
        &got,
        &["cases", "raised", "errors_pct", "pressure_bar.boom"],
    );
    assert!(validation < 1.0, "validate error {validation} %");
}

#[test]
fn a_users_mistakes_in_a_study_spec_name_the_file_line_and_fix() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("solver.sh"), "exit 0\n").unwrap();
    std::fs::write(dir.path().join("curve.csv"), "time_s,load\n0,0\n1,1\n").unwrap();
    std::fs::write(
        dir.path().join("measured.csv"),
        "window,start_s,end_s,quantity,unit,mean,std,n,n_eff,ci95_low,ci95_high,flags,note\n\
         hold1,0,1,boom_loaded_pressure,bar,73.4,0.3,100,100,73.3,73.5,,\n",
    )
    .unwrap();
    let head = r#"command = ["sh", "solver.sh"]
output_file = "out.json"

[[curve]]
name = "fd"
file = "fd.csv"
x = "u"
y = "f"

[[parameter]]
name = "k"
lower = 1.0
upper = 2.0
"#;
    let fit = "[[case]]\nname = \"a\"\nmeasured = { y = 1.0 }\n";
    let validate = "[[case]]\nname = \"v\"\nrole = \"validate\"\nmeasured = { y = 2.0 }\n";
    let cases: [(&str, String, &[&str]); 9] = [
        (
            "unknown_case",
            format!("{head}\n[[parameter]]\nname = \"d\"\ncase = \"b\"\nlower = 0.0\nupper = 1.0\n\n{fit}"),
            &["unknown_case.toml:15:", "case = \"b\" names no [[case]]", "the cases are a"],
        ),
        (
            "curve_columns",
            format!("{head}\n[[case]]\nname = \"a\"\nmeasured = {{ fd = {{ file = \"curve.csv\", x = \"u_mm\", y = \"f_kn\" }} }}\n"),
            &["curve_columns.toml:15:", "curve.csv", "u_mm"],
        ),
        (
            "missing_hold",
            format!("{head}\n[[case]]\nname = \"a\"\nmeasured = {{ p = {{ file = \"measured.csv\", quantity = \"boom_loaded_pressure\", hold = \"hold9\" }} }}\n"),
            &["missing_hold.toml:15:", "no hold \"hold9\"", "hold1"],
        ),
        (
            "empty_validate",
            format!("{head}\n{fit}\n[[case]]\nname = \"v\"\nrole = \"validate\"\n"),
            &["empty_validate.toml:19:", "case v", "validate case needs at least one observation"],
        ),
        (
            "prior_without_uncertainty",
            format!("{head}\n[[parameter]]\nname = \"d\"\nlower = 0.0\nupper = 1.0\nprior = {{ value = 0.5, uncertainty = 0.0 }}\n\n{fit}"),
            &["prior_without_uncertainty.toml:15:", "parameter d", "uncertainty above 0"],
        ),
        (
            "prior_relative",
            format!("{head}\n[[parameter]]\nname = \"d\"\nlower = 0.0\nupper = 1.0\nprior = {{ value = 0.5, uncertainty = 0.1 }}\n\n{fit}"),
            &["prior_relative.toml", "standard deviations", "residuals = \"normalised\""],
        ),
        (
            "executor_twice",
            format!("parallel = 2\n{head}\n[executor]\nparallel = 3\n\n{fit}"),
            &["executor_twice.toml", "parallel = 2 and [executor] parallel = 3", "give it once"],
        ),
        (
            "numerical_of_a_fit_value",
            format!("{head}\n{fit}\n{validate}\n[posterior]\nnumerical_uncertainty = {{ z = 0.1 }}\n"),
            &["numerical_of_a_fit_value.toml", "numerical_uncertainty.\"z\"", "no validate case measures it", "\"y\""],
        ),
        (
            "gp_without_inputs",
            format!("{head}\n{fit}\n[[case]]\nname = \"b\"\nmeasured = {{ y = 1.5 }}\n\n[posterior]\ndiscrepancy = \"gp\"\n"),
            &["gp_without_inputs.toml", "discrepancy = \"gp\"", "use discrepancy = \"constant\""],
        ),
    ];
    for (name, text, wanted) in cases {
        let spec = dir.path().join(format!("{name}.toml"));
        std::fs::write(&spec, &text).unwrap();
        let out = dir.path().join(format!("run_{name}"));
        let output = calibrate(
            "external",
            &["--spec", path_arg(&spec), "--out", path_arg(&out)],
        );
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{name}: {message}");
        for part in wanted {
            assert!(
                message.contains(part),
                "{name}: {part:?} not in {message}\n{text}"
            );
        }
        assert!(!out.exists(), "{name}: a run directory was made");
    }
}

#[test]
fn a_prior_pulls_a_parameter_to_the_closed_form_map_estimate() {
    // y = a x + b seen at x = 1, 2, 3 with sigma 0.5, exactly on the line
    // a = 1.5, b = 4; b also has a prior 3.0 +- 0.4. Minimising the squares
    // of the normalised residuals, prior included, is the Gaussian MAP
    // estimate: the normal equations (X^T X / s^2 + P) p = X^T y / s^2 + P p0
    // with P = diag(0, 1 / 0.4^2), whose inverse is the posterior
    // covariance. Without the prior b would be 4; with it, b moves about
    // two of its posterior deviations toward 3.
    let xs = [1.0f64, 2.0, 3.0];
    let (sigma, prior_b, prior_sigma) = (0.5f64, 3.0f64, 0.4f64);
    let ys: Vec<f64> = xs.iter().map(|x| 1.5 * x + 4.0).collect();
    let w = 1.0 / (sigma * sigma);
    let p = 1.0 / (prior_sigma * prior_sigma);
    let sxx: f64 = xs.iter().map(|x| x * x).sum::<f64>() * w;
    let sx: f64 = xs.iter().sum::<f64>() * w;
    let s1 = xs.len() as f64 * w + p;
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| x * y).sum::<f64>() * w;
    let sy: f64 = ys.iter().sum::<f64>() * w + p * prior_b;
    let det = sxx * s1 - sx * sx;
    let (map_a, map_b) = ((s1 * sxy - sx * sy) / det, (sxx * sy - sx * sxy) / det);
    let (sigma_a, sigma_b) = ((s1 / det).sqrt(), (sxx / det).sqrt());
    assert!(
        (map_b - 4.0).abs() > 2.0 * sigma_b,
        "the prior must matter here"
    );

    // Bayesian optimisation gets within a tenth of a posterior deviation
    // on this smooth bowl; least squares lands on the closed form, and its
    // Jacobian gives the posterior deviations to within the finite
    // differences.
    for (method, keys, tolerance_sigma, spread_tolerance) in [
        ("bo", "best_params", 0.1, 0.05),
        ("least-squares", "optimal", 1e-4, 1e-3),
    ] {
        let dir = tempfile::tempdir().unwrap();
        write_line_solver(dir.path(), &xs);
        let mut spec = format!(
            r#"command = ["sh", "line.sh", "{{a}}", "{{b}}"]
output_file = "out.json"
parallel = 1

[[parameter]]
name = "a"
lower = 0.5
upper = 3.0

[[parameter]]
name = "b"
lower = 2.0
upper = 6.0
prior = {{ value = {prior_b:?}, uncertainty = {prior_sigma:?} }}

[search]
method = "{method}"
residuals = "normalised"
loss = "squares"
start_runs = 10
max_evals = 60
"#
        );
        for (i, y) in ys.iter().enumerate() {
            spec.push_str(&format!(
                "\n[[output]]\nname = \"y{i}\"\nmeasured = {y:?}\nuncertainty = {sigma:?}\n"
            ));
        }
        let spec_path = dir.path().join("line.toml");
        std::fs::write(&spec_path, spec).unwrap();
        let out = dir.path().join("run");
        let got = run_external(&spec_path, &out);
        let (a, b) = (number(&got, &[keys, "a"]), number(&got, &[keys, "b"]));
        assert!(
            (a - map_a).abs() < tolerance_sigma * sigma_a,
            "{method}: a {a} vs MAP {map_a}"
        );
        assert!(
            (b - map_b).abs() < tolerance_sigma * sigma_b,
            "{method}: b {b} vs MAP {map_b}"
        );
        // The prior is scored and reported like a measured value.
        assert_eq!(got["chi_square"]["observations"], 4);
        let report = common::report::read(&out);
        assert!(
            report.contains("| prior | b | 3 |"),
            "{method}: the report lists the prior"
        );
        // Identifiability is the posterior: the closed form's deviations.
        let identified: Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("identifiability.json")).unwrap(),
        )
        .unwrap();
        for (name, expected) in [("a", sigma_a), ("b", sigma_b)] {
            let got_sigma = number(&identified, &["standard_uncertainty", name]);
            assert!(
                (got_sigma - expected).abs() < spread_tolerance * expected,
                "{method}: {name}: {got_sigma} vs posterior {expected}"
            );
        }
    }
}

#[test]
fn the_shipped_excavator_geometry_is_what_the_identification_gives() {
    // data/excavator/identify.toml identifies the twin's geometry from the
    // published evidence; data/excavator/dx55.toml must be its result, so
    // anyone can re-run it and get the shipped file's numbers.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("identify");
    let summary = run_external(&root().join("data/excavator/identify.toml"), &out);
    assert_eq!(summary["stop"], "converged", "{summary:#}");
    // The published model's six nominal pressures, within 5 % (the identification's target).
    for case in ["case1", "case2"] {
        for cylinder in ["bucket", "arm", "boom"] {
            let error = number(
                &summary,
                &[
                    "errors_optimal_pct",
                    &format!("{case}/pressure_bar.{cylinder}"),
                ],
            );
            assert!(error < 5.0, "{case} {cylinder}: {error} %");
        }
    }
    // The written geometry: every changed number says where it came from,
    // and it is the shipped file, number for number.
    let written_text = std::fs::read_to_string(out.join("geometry.toml")).unwrap();
    assert!(written_text.contains("# identified,") || written_text.contains("  # identified"));
    assert!(written_text.contains("fitted to the published poses"));
    let numbers = |text: &str| -> Vec<(String, f64)> {
        fn walk(value: &toml::Value, path: String, out: &mut Vec<(String, f64)>) {
            match value {
                toml::Value::Float(x) => out.push((path, *x)),
                toml::Value::Integer(i) => out.push((path, *i as f64)),
                toml::Value::Table(t) => {
                    for (k, v) in t {
                        walk(v, format!("{path}.{k}"), out);
                    }
                }
                toml::Value::Array(a) => {
                    for (i, v) in a.iter().enumerate() {
                        walk(v, format!("{path}[{i}]"), out);
                    }
                }
                _ => {}
            }
        }
        let mut out = Vec::new();
        walk(
            &toml::from_str::<toml::Value>(text).unwrap(),
            String::new(),
            &mut out,
        );
        out
    };
    let shipped = std::fs::read_to_string(root().join("data/excavator/dx55.toml")).unwrap();
    let (written, shipped) = (numbers(&written_text), numbers(&shipped));
    assert_eq!(written.len(), shipped.len());
    for ((path, a), (other, b)) in written.iter().zip(&shipped) {
        assert_eq!(path, other);
        assert!(
            (a - b).abs() <= 1e-9 * a.abs().max(1.0),
            "{path}: identified {a}, shipped {b}"
        );
    }
}

/// The report check's number finder: a raw float is found, a short one, a
/// small one with few digits, a version and an identifier are not.
#[test]
fn long_numbers_are_found_and_versions_are_not() {
    assert_eq!(
        common::report::long_numbers(
            "a 116.88459379999991 b 116.9 c 0.000012345678 d 1.5.0 e x1.123456789"
        ),
        vec!["116.88459379999991".to_string()]
    );
    assert_eq!(
        common::report::long_numbers("12345678.9"),
        vec!["12345678.9".to_string()]
    );
    assert!(common::report::long_numbers("1234567.8 and 1795295563").is_empty());
}
