//! `[mesh_study]`: a spec's model run at several element sizes at one
//! parameter point, and per scalar output the grid convergence
//! ([`acq_metrology::grid_convergence`]): the observed order, the
//! extrapolated value, the fine grid's GCI and the `u_num` V&V 20 takes.
//!
//! The size reaches the model as the input `mesh` (a command's `{mesh}`).
//! The runs go through the study's evaluator: logged in `evaluations.csv`
//! with the parameters and the size, run `parallel` at a time on the
//! spec's executor, resumable, stopped by Ctrl-C like a calibration's.
//! The run directory gets `summary.json` (`mesh_study`), `report.html`
//! and `report.md`, and one convergence plot per output.

use std::collections::BTreeMap;
use std::time::Instant;

use acq_algorithms::evaluation::Parameter;
use acq_error::{AcqError, Result};
use acq_metrology::grid_convergence::{grid_convergence, Convergence, GridConvergence};
use acq_report::document::{Document, Figure, Table};
use acq_report::number::{plain, significant};
use acq_report::plot::{chart_svg, Chart, ReferenceLine, Series, SeriesStyle};
use serde_json::Value;

pub use crate::outcome::{CurveConvergence, MeshStudyOutcome, OutputConvergence};
use crate::progress::Progress;
use crate::report::write_report;
use crate::run_directory::{write_text, RunDirectory};
use crate::simulator::StudySimulator;
use crate::study::{Measured, Model, Role, Study, StudyParameter};

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
    /// The sizes' unit (`"mm"`), for the plots' axes.
    pub size_unit: Option<String>,
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
        let values: Vec<(f64, Option<f64>)> = settings
            .sizes
            .iter()
            .zip(&evaluations)
            .map(|(h, e)| (*h, e.outcome.as_ref().ok().map(|y| y[column])))
            .collect();
        outputs.push(output_convergence(key, &values)?);
    }
    let curves = curve_convergences(&sized, model, &points, &evaluations)?;
    let failed = evaluations.iter().filter(|e| e.outcome.is_err()).count();
    let outcome = MeshStudyOutcome {
        outputs,
        curves,
        at,
        evaluations: evaluations.len(),
        failed,
        size_unit: settings.size_unit.clone(),
    };
    write_results(
        &outcome,
        &settings.sizes,
        directory,
        start.elapsed().as_secs_f64(),
    )?;
    Ok(outcome)
}

/// One output's grid convergence from its value at each size (`None`:
/// the run at that size failed).
pub fn output_convergence(key: String, values: &[(f64, Option<f64>)]) -> Result<OutputConvergence> {
    let (mut sizes, mut found, mut failed_sizes) = (Vec::new(), Vec::new(), Vec::new());
    for (h, value) in values {
        match value {
            Some(v) => {
                sizes.push(*h);
                found.push(*v);
            }
            None => failed_sizes.push(*h),
        }
    }
    let convergence = if sizes.len() >= 3 {
        Some(
            grid_convergence(&sizes, &found)
                .map_err(|e| AcqError::Malformed(format!("{key}: {e}")))?,
        )
    } else {
        None
    };
    Ok(OutputConvergence {
        key,
        convergence,
        failed_sizes,
    })
}

/// Parts a curve is compared in, along the x range every size's curve spans.
pub const CURVE_PARTS_COMPARED: usize = 10;

/// Each observed curve at every size, compared part by part: the curve's
/// mean over each of [`CURVE_PARTS_COMPARED`] equal spans of x (the range
/// all sizes' curves cover) is an output of its own, with its own grid
/// convergence. A curve with a kink that moves with the mesh (a neck, a
/// fracture) converges in some parts and not in others, which one number
/// for the whole curve would hide.
fn curve_convergences(
    sized: &Study,
    model: &dyn Model,
    points: &[Vec<f64>],
    evaluations: &[acq_algorithms::evaluation::Evaluation],
) -> Result<Vec<CurveConvergence>> {
    let mut found = Vec::new();
    for (case_index, case) in sized.cases.iter().enumerate() {
        for observation in &case.observations {
            let Measured::Curve { axes, .. } = &observation.measured else {
                continue;
            };
            let key = sized.key(case, observation);
            let curves: Vec<(f64, Vec<(f64, f64)>)> = points
                .iter()
                .zip(evaluations)
                .filter(|(_, e)| e.outcome.is_ok())
                .filter_map(|(point, _)| {
                    let inputs = sized.inputs_of(case_index, point);
                    let run = model.run_again(&inputs, &[], &[observation.output.as_str()])?;
                    let size = *point.last()?;
                    Some((size, run.curves.into_iter().next()?))
                })
                .filter(|(_, curve)| curve.len() >= 2)
                .collect();
            found.push(curve_convergence(key, axes.clone(), curves)?);
        }
    }
    Ok(found)
}

/// One curve at each size (`(size, points)`), compared part by part (see
/// [`curve_convergences`]); no parts with fewer than three sizes.
pub fn curve_convergence(
    key: String,
    axes: [String; 2],
    curves: Vec<(f64, Vec<(f64, f64)>)>,
) -> Result<CurveConvergence> {
    let mut parts = Vec::new();
    if curves.len() >= 3 {
        let sizes: Vec<f64> = curves.iter().map(|(h, _)| *h).collect();
        for (x_from, x_to, means) in curve_part_means(&curves, CURVE_PARTS_COMPARED) {
            let values: Vec<(f64, Option<f64>)> = sizes
                .iter()
                .zip(means)
                .map(|(h, m)| (*h, Some(m)))
                .collect();
            let name = format!("{key} mean over {} {x_from:.4} .. {x_to:.4}", axes[0]);
            parts.push((x_from, x_to, output_convergence(name, &values)?));
        }
    }
    Ok(CurveConvergence {
        key,
        axes,
        curves,
        parts,
    })
}

/// Each of `parts` equal spans of the x range every curve covers, with
/// each curve's mean over it (in the curves' order): `(x from, x to,
/// means)`. Empty when the curves share no range (or a curve has fewer
/// than two points).
pub fn curve_part_means(
    curves: &[(f64, Vec<(f64, f64)>)],
    parts: usize,
) -> Vec<(f64, f64, Vec<f64>)> {
    if parts == 0 || curves.iter().any(|(_, c)| c.len() < 2) {
        return Vec::new();
    }
    let from = curves
        .iter()
        .map(|(_, c)| c[0].0)
        .fold(f64::NEG_INFINITY, f64::max);
    let to = curves
        .iter()
        .map(|(_, c)| c[c.len() - 1].0)
        .fold(f64::INFINITY, f64::min);
    if from.partial_cmp(&to) != Some(std::cmp::Ordering::Less) {
        return Vec::new();
    }
    let means: Vec<Vec<f64>> = curves
        .iter()
        .map(|(_, curve)| part_means(curve, from, to, parts))
        .collect();
    let width = (to - from) / parts as f64;
    (0..parts)
        .map(|part| {
            (
                from + part as f64 * width,
                from + (part + 1) as f64 * width,
                means.iter().map(|m| m[part]).collect(),
            )
        })
        .collect()
}

/// The mean of the curve's linear interpolant over each of `parts` equal
/// spans of `[from, to]` (x increasing; a point outside is clamped to
/// the nearest end), by exact integration of the pieces.
fn part_means(curve: &[(f64, f64)], from: f64, to: f64, parts: usize) -> Vec<f64> {
    let at = |x: f64| -> f64 {
        let i = curve.partition_point(|p| p.0 < x);
        if i == 0 {
            return curve[0].1;
        }
        if i >= curve.len() {
            return curve[curve.len() - 1].1;
        }
        let (a, b) = (curve[i - 1], curve[i]);
        if b.0 > a.0 {
            a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0)
        } else {
            b.1
        }
    };
    let width = (to - from) / parts as f64;
    (0..parts)
        .map(|k| {
            let (lo, hi) = (from + k as f64 * width, from + (k + 1) as f64 * width);
            // The trapezoid rule over the interpolant's own nodes is exact.
            let mut xs = vec![lo];
            xs.extend(curve.iter().map(|p| p.0).filter(|x| *x > lo && *x < hi));
            xs.push(hi);
            let area: f64 = xs
                .windows(2)
                .map(|w| 0.5 * (at(w[0]) + at(w[1])) * (w[1] - w[0]))
                .sum();
            area / (hi - lo)
        })
        .collect()
}

/// `summary.json` (its `mesh_study` and `mesh_study_curves`), the report
/// (`report.html` and `report.md`, as every run's) and the plots of a
/// mesh study, in `directory`.
pub fn write_results(
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
    let mut report = Document::new();
    report.heading(1, "Mesh study");
    report.paragraph(format!(
        "At {}. The element size reaches the model as `{MESH_INPUT}`{}; per output, the grid convergence of Celik et al. 2008 (three sizes) or its least-squares form (Eça and Hoekstra 2014, more sizes). `u_num` is the GCI without its factor of safety, as V&V 20 takes it. Values that agree within round-off (a relative spread of at most {}) are mesh-independent: no order, and their spread as `u_num`.",
        outcome
            .at
            .iter()
            .map(|(n, v)| format!("{n} = {v}"))
            .collect::<Vec<_>>()
            .join(", "),
        outcome
            .size_unit
            .as_ref()
            .map_or_else(String::new, |unit| format!(" (in {unit})")),
        acq_metrology::grid_convergence::ROUND_OFF_RELATIVE
    ));
    // Significant figures, not decimals: a u_num of 1.4e-4 must not read
    // 0.0001, and the extrapolated value keeps the digits its GCI tells.
    let text = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| significant(v, 4));
    let value_text = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| significant(v, 7));
    let mut table = Table::new(&[
        "output",
        "convergence",
        "order",
        "extrapolated",
        "e_a %",
        "e_ext %",
        "GCI_fine %",
        "u_num",
    ]);
    // The whole table first: a plot between its rows would end it.
    let mut figures = Vec::new();
    for (index, output) in outcome.outputs.iter().enumerate() {
        let Some(study) = &output.convergence else {
            let mut row = vec![output.key.clone(), "not enough runs".into()];
            row.extend(std::iter::repeat_n("-".to_string(), 6));
            table.row(row);
            continue;
        };
        table.row(vec![
            output.key.clone(),
            study.convergence.name().into(),
            text(study.order),
            value_text(study.extrapolated),
            text(study.e_a_pct),
            text(study.e_ext_pct),
            text(study.gci_fine_pct),
            text(study.standard_uncertainty()),
        ]);
        figures.push((
            Figure {
                file: format!("mesh_study_{}.svg", index + 1),
                caption: output.key.clone(),
                svg: convergence_svg(&output.key, study, outcome.size_unit.as_deref()),
            },
            study.note.clone(),
        ));
    }
    report.table(table);
    for (figure, note) in figures {
        report.figure(figure);
        report.paragraph(note);
    }
    write_curves(&mut report, outcome);
    write_report(directory, &report, "Mesh study")
}

/// Each curve at every size in one plot, and its parts' convergence.
fn write_curves(report: &mut Document, outcome: &MeshStudyOutcome) {
    for (index, curve) in outcome.curves.iter().enumerate() {
        report.heading(2, format!("Curve {}, part by part", curve.key));
        let mut chart = Chart::new(
            format!("{} at each element size", curve.key),
            curve.axes[0].clone(),
            curve.axes[1].clone(),
        );
        for (size, points) in &curve.curves {
            chart
                .series
                .push(Series::new(format!("size {size}"), points.clone()));
        }
        report.figure(Figure {
            file: format!("mesh_study_curve_{}.svg", index + 1),
            caption: curve.key.clone(),
            svg: chart_svg(&chart, 640.0, 400.0),
        });
        if curve.parts.is_empty() {
            report.paragraph("Fewer than three sizes gave the curve: no part is compared.");
            continue;
        }
        report.paragraph(format!(
            "The curve's mean over each part of {} (the range every size's curve covers):",
            curve.axes[0]
        ));
        let from = format!("{} from", curve.axes[0]);
        let mut table = Table::new(&[&from, "to", "convergence", "order", "GCI_fine %", "u_num"]);
        let text = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| significant(v, 4));
        for (x_from, x_to, part) in &curve.parts {
            let mut row = vec![plain(*x_from, 6), plain(*x_to, 6)];
            match &part.convergence {
                Some(study) => row.extend([
                    study.convergence.name().to_string(),
                    text(study.order),
                    text(study.gci_fine_pct),
                    text(study.standard_uncertainty()),
                ]),
                None => row.extend(["not enough runs".into(), "-".into(), "-".into(), "-".into()]),
            }
            table.row(row);
        }
        report.table(table);
    }
}

/// The values over the element size, with the extrapolated value at size
/// zero and the fine value's GCI band.
fn convergence_svg(key: &str, study: &GridConvergence, size_unit: Option<&str>) -> String {
    let size_axis = match size_unit {
        Some(unit) => format!("element size [{unit}]"),
        None => "element size (unit not stated: [mesh_study] unit)".to_string(),
    };
    let title = match study.convergence {
        Convergence::MeshIndependent => format!("{key}: mesh-independent (equal within round-off)"),
        other => format!("{key}: {} convergence", other.name()),
    };
    let mut chart = Chart::new(title, size_axis, key);
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
