//! `[mesh_study]`: a spec's model run at several element sizes at one
//! parameter point, and per scalar output the grid convergence
//! ([`acq_metrology::grid_convergence`]): the observed order, the
//! extrapolated value, the fine grid's GCI and the `u_num` V&V 20 takes.
//!
//! The size reaches the model as the input `mesh` (a command's `{mesh}`).
//! The runs go through the study's evaluator: logged in `evaluations.csv`
//! with the parameters and the size, run `parallel` at a time on the
//! spec's executor, resumable, stopped by Ctrl-C like a calibration's.
//! The run directory gets `summary.json` (`mesh_study`), `report.md` and
//! one convergence plot per output.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::time::Instant;

use acq_calib::evaluation::Parameter;
use acq_io::error::{AcqError, Result};
use acq_metrology::grid_convergence::{grid_convergence, GridConvergence};
use acq_report::plot::{chart_svg, Chart, ReferenceLine, Series, SeriesStyle};
use serde_json::Value;

pub use crate::outcome::{MeshStudyOutcome, OutputConvergence};
use crate::progress::Progress;
use crate::run_directory::{write_text, RunDirectory};
use crate::study::{Measured, Model, Role, Study, StudyParameter, StudySimulator};

/// The model input that carries the element size (`{mesh}`).
pub const MESH_INPUT: &str = "mesh";

/// `[mesh_study]`, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshStudySettings {
    /// As the spec lists them (at least three, distinct, positive).
    pub sizes: Vec<f64>,
    /// Parameter values by input name, where the nominal one is not wanted.
    pub at: BTreeMap<String, f64>,
    /// The size a calibration of the spec runs at.
    pub calibrate_at: f64,
}

/// The study a mesh study runs: every case (fit and validate alike) at
/// the parameter point, the size a parameter of its own.
fn sized_study(study: &Study, sizes: &[f64]) -> Study {
    let mut sized = with_mesh_parameter(study, sizes);
    sized.cases.retain(|case| !case.priors);
    for case in &mut sized.cases {
        case.role = Role::Fit;
    }
    sized
}

/// `study` with the element size a parameter of its own, last, spanning
/// `sizes`: each run says its size (a column `mesh` in the log), and the
/// cases' own `mesh` input gives way to it.
pub(crate) fn with_mesh_parameter(study: &Study, sizes: &[f64]) -> Study {
    let mut sized = study.clone();
    for case in &mut sized.cases {
        case.inputs.retain(|(name, _)| name != MESH_INPUT);
    }
    let (smallest, largest) = sizes.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &h| {
        (lo.min(h), hi.max(h))
    });
    sized.parameters.push(StudyParameter {
        search: Parameter::new(MESH_INPUT, smallest, largest),
        input: MESH_INPUT.into(),
        case: None,
        nominal: smallest,
        prior: None,
    });
    sized
}

/// The parameter point: each parameter's nominal value, or `at`'s.
fn point(study: &Study, settings: &MeshStudySettings) -> Vec<(String, f64)> {
    study
        .parameters
        .iter()
        .map(|p| {
            let value = settings.at.get(&p.input).copied().unwrap_or(p.nominal);
            (p.search.name.clone(), value)
        })
        .collect()
}

/// Runs the model at every size and studies each scalar output.
pub fn run_mesh_study(
    study: &Study,
    settings: &MeshStudySettings,
    model: &dyn Model,
    directory: &RunDirectory,
    parallel: usize,
    resume: bool,
) -> Result<MeshStudyOutcome> {
    let start = Instant::now();
    let sized = sized_study(study, &settings.sizes);
    let at = point(study, settings);
    let simulator = StudySimulator::new(&sized, model, Role::Fit);
    let progress = Progress::new("mesh study", settings.sizes.len());
    let mut evaluator = directory
        .evaluator(&simulator, parallel, resume)?
        .with_progress(|e| progress.record(None, e.outcome.is_err(), e.from_log));
    let points: Vec<Vec<f64>> = settings
        .sizes
        .iter()
        .map(|&h| at.iter().map(|(_, v)| *v).chain([h]).collect())
        .collect();
    let evaluations = evaluator
        .evaluate(&points)
        .map_err(crate::run_directory::evaluation_error)?;
    progress.finish();
    let keys = sized.output_keys(Role::Fit);
    let scalar_keys: Vec<String> = sized
        .observations(Role::Fit)
        .into_iter()
        .filter(|(_, o)| matches!(o.measured, Measured::Scalar { .. }))
        .map(|(case, o)| sized.key(case, o))
        .collect();
    let mut outputs = Vec::new();
    for key in scalar_keys {
        let column = keys.iter().position(|k| *k == key).unwrap_or(0);
        let mut sizes = Vec::new();
        let mut values = Vec::new();
        let mut failed_sizes = Vec::new();
        for (h, evaluation) in settings.sizes.iter().zip(&evaluations) {
            match &evaluation.outcome {
                Ok(outputs) => {
                    sizes.push(*h);
                    values.push(outputs[column]);
                }
                Err(_) => failed_sizes.push(*h),
            }
        }
        let convergence = if sizes.len() >= 3 {
            Some(
                grid_convergence(&sizes, &values)
                    .map_err(|e| AcqError::Malformed(format!("{key}: {e}")))?,
            )
        } else {
            None
        };
        outputs.push(OutputConvergence {
            key,
            convergence,
            failed_sizes,
        });
    }
    let failed = evaluations.iter().filter(|e| e.outcome.is_err()).count();
    let outcome = MeshStudyOutcome {
        outputs,
        at,
        evaluations: evaluations.len(),
        failed,
    };
    write_results(
        &outcome,
        &settings.sizes,
        directory,
        start.elapsed().as_secs_f64(),
    )?;
    Ok(outcome)
}

fn write_results(
    outcome: &MeshStudyOutcome,
    spec_sizes: &[f64],
    directory: &RunDirectory,
    wall_s: f64,
) -> Result<()> {
    let summary = crate::summary::mesh_study_summary(outcome, spec_sizes, wall_s);
    write_text(
        &directory.file("summary.json"),
        &format!(
            "{}\n",
            serde_json::to_string_pretty(&summary).unwrap_or_default()
        ),
    )?;
    let mut report = String::from("# Mesh study\n\n");
    let _ = writeln!(
        report,
        "At {}. The element size reaches the model as `{MESH_INPUT}`; per output, the grid convergence of Celik et al. 2008 (three sizes) or its least-squares form (Eça and Hoekstra 2014, more sizes). `u_num` is the GCI without its factor of safety, as V&V 20 takes it.\n",
        outcome
            .at
            .iter()
            .map(|(n, v)| format!("{n} = {v}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    report.push_str("| output | convergence | order | extrapolated | e_a % | e_ext % | GCI_fine % | u_num |\n|---|---|---|---|---|---|---|---|\n");
    let text = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{v:.4}"));
    for (index, output) in outcome.outputs.iter().enumerate() {
        let Some(study) = &output.convergence else {
            let _ = writeln!(
                report,
                "| {} | not enough runs | - | - | - | - | - | - |",
                output.key
            );
            continue;
        };
        let _ = writeln!(
            report,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            output.key,
            study.convergence.name(),
            text(study.order),
            text(study.extrapolated),
            text(study.e_a_pct),
            text(study.e_ext_pct),
            text(study.gci_fine_pct),
            text(study.standard_uncertainty()),
        );
        let plot = format!("mesh_study_{}.svg", index + 1);
        write_text(&directory.file(&plot), &convergence_svg(&output.key, study))?;
        let _ = writeln!(report, "\n![{}]({plot})\n\n{}\n", output.key, study.note);
    }
    write_text(&directory.file("report.md"), &report)
}

/// The values over the element size, with the extrapolated value at size
/// zero and the fine value's GCI band.
fn convergence_svg(key: &str, study: &GridConvergence) -> String {
    let mut chart = Chart::new(
        format!("{key}: {} convergence", study.convergence.name()),
        "element size",
        key,
    );
    let points: Vec<(f64, f64)> = study
        .sizes
        .iter()
        .copied()
        .zip(study.values.iter().copied())
        .collect();
    chart
        .series
        .push(Series::new("runs", points).with_style(SeriesStyle::LineAndMarkers));
    if let Some(extrapolated) = study.extrapolated {
        chart.series.push(
            Series::new(
                "extrapolated to size 0",
                vec![(0.0, extrapolated), (study.sizes[0], study.values[0])],
            )
            .with_style(SeriesStyle::Dashed),
        );
    }
    if let Some(gci) = study.gci_fine_pct {
        let half = gci / 100.0 * study.values[0].abs();
        for (label, y) in [
            ("fine + GCI", study.values[0] + half),
            ("fine - GCI", study.values[0] - half),
        ] {
            chart.reference_lines.push(ReferenceLine::new(y, label));
        }
    }
    chart_svg(&chart, 640.0, 400.0)
}

/// Each validate value's `u_num` from a finished mesh study of the same
/// spec (`run_dir/summary.json`): `(case/name, u_num, where it came
/// from)`. A value the mesh study has no number for is refused with its
/// reason, never taken as 0.
pub fn u_num_from_run(
    run_dir: &std::path::Path,
    study: &Study,
    size: Option<f64>,
) -> std::result::Result<Vec<(String, f64, String)>, String> {
    let path = run_dir.join("summary.json");
    let text = std::fs::read_to_string(&path).map_err(|e| {
        format!(
            "{}: {e}: run `acq mesh-study --spec SPEC --out {}` first",
            path.display(),
            run_dir.display()
        )
    })?;
    let summary: Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let Some(outputs) = summary.get("mesh_study").and_then(Value::as_object) else {
        return Err(format!(
            "{}: no mesh_study in it: name the run directory of `acq mesh-study`",
            path.display()
        ));
    };
    let mut found = Vec::new();
    for (index, case) in study.cases_with(Role::Validate) {
        for observation in &study.cases[index].observations {
            if !matches!(observation.measured, Measured::Scalar { .. }) {
                continue;
            }
            let key = format!("{}/{}", case.name, observation.name);
            // The mesh study keys outputs by case when the spec names cases.
            let entry = outputs.get(&key).or_else(|| outputs.get(&observation.name));
            let Some(entry) = entry else {
                return Err(format!(
                    "{}: no output {key}: run the mesh study on this spec",
                    path.display()
                ));
            };
            // The size the calibration runs at: a coarser one than the
            // study's finest has its own, larger u_num.
            let at_size = size.map(|h| {
                let sizes = entry.get("sizes").and_then(Value::as_array);
                let index = sizes.and_then(|s| s.iter().position(|v| v.as_f64() == Some(h)));
                index.and_then(|i| entry.get("u_num_by_size")?.get(i)?.as_f64())
            });
            let u_num = match at_size {
                Some(u) => u,
                None => entry.get("u_num").and_then(Value::as_f64),
            };
            let Some(u_num) = u_num else {
                return Err(format!(
                    "{}: {key} has no u_num ({} convergence: {}); refine the sizes, or state posterior.numerical_uncertainty",
                    path.display(),
                    entry.get("convergence").and_then(Value::as_str).unwrap_or("no"),
                    entry.get("note").and_then(Value::as_str).unwrap_or("")
                ));
            };
            let gci = entry
                .get("gci_fine_pct")
                .and_then(Value::as_f64)
                .unwrap_or(f64::NAN);
            let convergence = entry
                .get("convergence")
                .and_then(Value::as_str)
                .unwrap_or("");
            let at = size.map_or_else(String::new, |h| format!(" at size {h}"));
            found.push((
                key,
                u_num,
                format!(
                    "mesh study {}{at} ({convergence}, GCI_fine {gci:.3} %)",
                    run_dir.display()
                ),
            ));
        }
    }
    Ok(found)
}
