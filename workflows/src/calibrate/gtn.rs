//! `acq calibrate gtn`: the GTN parameters of a tensile test.
//!
//! The flow curve and E come from the test ([`crate::tensile_model`]); the
//! eight GTN parameters are searched in the published bounds (m up to the
//! test's own bound) by Bayesian optimisation of the curve MAPE, starting
//! from the published 12-run two-level orthogonal array. The parameters are
//! scaled to the unit box and the MAPE is minimised (the published code did
//! neither). The run stops at the target MAPE or the evaluation budget.

use std::path::{Path, PathBuf};

use acq_analysis::extract::tensile_props::{
    read_test_csv, tensile_properties, SpecimenGeometry, TestPoint,
};
use acq_calib::bo::Acquisition;
use acq_calib::evaluation::{Evaluation, Parameter};
use acq_io::error::{AcqError, Result};
use acq_report::document::{Document, Figure, Table};
use acq_report::plot::{chart_svg, Chart, Series, SeriesStyle};
use clap::Args;
use serde_json::json;

use super::builtin::{GtnModel, GTN_CURVE};
use super::identifiability::write_identifiability;
use super::report::{write_report, write_text};
use super::run_directory::RunDirectory;
use super::search::{distinct_best, scored};
use super::study::{Case, LossKind, Measured, Observation, Residuals, Role, Study, StudyParameter};
use super::study_runner::{calibrate_study, start_design, BoMethod, Found, Method, RunSettings};
use crate::abaqus_material::abaqus_material_block;
use crate::tensile_model::{GtnInputs, MeshArgs, ModelSettings, TensileModel, PARAMETER_NAMES};

#[derive(Args, Debug)]
pub struct CalibrateGtnArgs {
    /// Test CSV with DISPLACEMENT [mm] and FORCE [kN] columns.
    #[arg(long, value_name = "TEST.csv")]
    pub test: PathBuf,
    /// Run directory: evaluations.csv, summary.json, report.md, curve and plots.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Largest number of simulations (the L12 start included).
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(13..=100_000))]
    pub max_evals: u32,
    /// Stop once the MAPE is at or below this, %.
    #[arg(long, default_value_t = 2.0)]
    pub target_mape: f64,
    /// Simulations proposed (and run in parallel) per iteration.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub batch: u32,
    /// Acquisition: logei, ei, ucb[:KAPPA] (the published one is ucb:2.5).
    #[arg(long, default_value = "logei")]
    pub acquisition: Acquisition,
    /// Also stop when this many simulations in a row improved the best MAPE by
    /// less than 0.1 % (relative).
    #[arg(long)]
    pub patience: Option<u32>,
    #[command(flatten)]
    pub mesh: MeshArgs,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Global Bayesian-optimisation steps only (the published search),
    /// without the local Gauss-Newton steps on the curve's errors.
    #[arg(long)]
    pub global_only: bool,
    /// Continue the run in DIR: simulations already in its log are not repeated.
    #[arg(long)]
    pub resume: bool,
}

/// The published search box (reference table); m's upper bound comes from
/// the test.
pub fn parameters(m_upper_mpa: f64) -> Vec<Parameter> {
    let bounds = [
        (0.9, 1.6),
        (0.9, 1.1),
        (0.81, 2.56),
        (0.25, 0.40),
        (0.10, 0.20),
        (0.03, 0.09),
        (0.0013, 0.0015),
        (0.0, m_upper_mpa),
    ];
    PARAMETER_NAMES
        .iter()
        .zip(bounds)
        .map(|(name, (lower, upper))| Parameter::new(*name, lower, upper))
        .collect()
}

/// The test as a study of the GTN twin: the eight parameters (nominal:
/// the middle of the box) and one fit case whose observation is the test's
/// curve, scored by the curve MAPE (logged as `mape_pct`).
pub fn test_study(parameters: &[Parameter], test: &[TestPoint]) -> Study {
    Study {
        parameters: parameters
            .iter()
            .map(|p| StudyParameter {
                search: p.clone(),
                input: p.name.clone(),
                case: None,
                nominal: p.midpoint(),
                prior: None,
            })
            .collect(),
        cases: vec![Case {
            name: "test".into(),
            role: Role::Fit,
            priors: false,
            inputs: Vec::new(),
            observations: vec![Observation {
                name: "mape_pct".into(),
                output: GTN_CURVE.into(),
                measured: Measured::Curve {
                    points: test
                        .iter()
                        .map(|p| (p.displacement_mm, p.force_kn))
                        .collect(),
                },
                weight: 1.0,
                source: "the test".into(),
            }],
        }],
        named_cases: false,
        residuals: Residuals::Relative,
        loss: LossKind::Mean,
    }
}

/// What the calibration found, besides the files it wrote.
#[derive(Clone, Debug)]
pub struct GtnCalibration {
    pub best_mape_pct: f64,
    /// MAPE before and after the test's maximum force, %.
    pub best_split_pct: Option<(f64, f64)>,
    pub best_params: Vec<(String, f64)>,
    pub evaluations: usize,
    pub evaluations_to_target: Option<usize>,
    pub wall_s: f64,
    /// The report (also written as report.md and report.html).
    pub report: Document,
}

pub fn run(args: CalibrateGtnArgs) -> Result<GtnCalibration> {
    if !(args.target_mape.is_finite() && args.target_mape >= 0.0) {
        return Err(AcqError::Config(
            "--target-mape must be a number >= 0".into(),
        ));
    }
    let mesh = args
        .mesh
        .density(&ModelSettings::default().geometry)
        .map_err(AcqError::Config)?;
    let points = read_test_csv(&args.test)?;
    let properties = tensile_properties(&points, SpecimenGeometry::default())
        .map_err(|e| AcqError::Malformed(format!("{}: {e}", args.test.display())))?;
    let m_upper = properties.post_uts_slope.upper_bound_mpa;
    let model = TensileModel::new(
        points.clone(),
        properties,
        ModelSettings {
            mesh,
            ..ModelSettings::default()
        },
    );
    let parameters = parameters(m_upper.max(1.0));
    let study = test_study(&parameters, &points);
    let model = GtnModel::new(model);
    let directory = RunDirectory::create(&args.out)?;
    let method = Method::Bo(BoMethod {
        start: "l12".into(),
        start_runs: 12,
        max_evals: args.max_evals as usize,
        target_loss: Some(args.target_mape),
        acquisition: Some(args.acquisition),
        patience: args.patience.map(|p| p as usize),
        batch: args.batch as usize,
        seed: args.seed,
        local_steps: !args.global_only,
    });
    let Method::Bo(bo) = &method else {
        unreachable!("the GTN preset runs Bayesian optimisation")
    };
    let settings = RunSettings {
        label: "calibrate gtn".into(),
        title: args.test.display().to_string(),
        spec_directory: Path::new("."),
        parallel: args.batch as usize,
        resume: args.resume,
    };
    let start_design = start_design(&parameters, bo, settings.spec_directory)?;
    let outcome = calibrate_study(&study, &model, &method, start_design, &directory, &settings)?;
    let Found::Bo(result) = &outcome.found else {
        unreachable!("the GTN preset runs Bayesian optimisation")
    };
    let wall_s = outcome.wall_s;
    let evaluations = scored(&outcome.evaluations, |y| y[0]);
    let Some(&(best, best_mape)) = evaluations.iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
        return Err(AcqError::Config("no simulation succeeded".into()));
    };
    let best_values = best.parameters.clone();
    let best_params: serde_json::Map<String, serde_json::Value> = parameters
        .iter()
        .zip(&best_values)
        .map(|(p, v)| (p.name.clone(), json!(v)))
        .collect();
    let summary = json!({
        "best_mape": best_mape,
        "evaluations": outcome.evaluations.len(),
        "evaluations_to_target": result.evaluations_to_target,
        "best_params": best_params,
        "wall_s": wall_s,
        "mesh": model.tensile_model().settings.mesh_json(),
    });
    write_text(&directory.file("summary.json"), &format!("{summary:#}\n"))?;

    // The calibrated curve against the test.
    let inputs = GtnInputs::from_values(&best_values).map_err(AcqError::Config)?;
    let best_run = model
        .tensile_model()
        .run(&inputs)
        .map_err(AcqError::Config)?;
    // The material for the user's own solver, with the element size it belongs to.
    let twin = model
        .tensile_model()
        .twin(&inputs)
        .map_err(AcqError::Config)?;
    let provenance = [
        format!(
            "GTN material calibrated by acq on {} (MAPE {best_mape:.3} %).",
            args.test.display()
        ),
        format!(
            "It belongs to this mesh: {}.",
            model.tensile_model().settings.mesh_sentence()
        ),
    ];
    write_text(
        &directory.file("abaqus_material.inp"),
        &abaqus_material_block("ACQ_GTN", &twin.material, &provenance),
    )?;
    let mut curve = String::from("DISPLACEMENT,FORCE\n");
    for p in &best_run.result.curve {
        curve.push_str(&format!("{},{}\n", p.displacement_mm, p.force_kn));
    }
    write_text(&directory.file("curve.csv"), &curve)?;
    let chart = Chart::new(
        format!(
            "{}: measured vs calibrated (MAPE {best_mape:.3} %)",
            args.test.display()
        ),
        "displacement [mm]",
        "force [kN]",
    )
    .with_series(
        Series::new(
            "test",
            points
                .iter()
                .map(|p| (p.displacement_mm, p.force_kn))
                .collect(),
        )
        .with_style(SeriesStyle::Markers),
    )
    .with_series(Series::new(
        "calibrated twin",
        best_run
            .result
            .curve
            .iter()
            .map(|p| (p.displacement_mm, p.force_kn))
            .collect(),
    ));
    let mut best_so_far = f64::INFINITY;
    let mut running = Vec::new();
    let mut each = Vec::new();
    for e in &outcome.evaluations {
        if let Ok(y) = &e.outcome {
            best_so_far = best_so_far.min(y[0]);
            each.push((e.id as f64, y[0]));
        }
        running.push((e.id as f64, best_so_far));
    }
    let loss_chart = Chart::new("MAPE per simulation", "simulation", "MAPE [%]")
        .with_series(Series::new("simulation", each).with_style(SeriesStyle::Markers))
        .with_series(Series::new("best so far", running))
        .with_reference_line(args.target_mape, format!("target {} %", args.target_mape));

    // Non-uniqueness: distinct parameter sets near the best.
    let near: Vec<(&Evaluation, f64)> = evaluations
        .iter()
        .copied()
        .filter(|(_, mape)| *mape <= 1.25 * best_mape + 0.25)
        .collect();
    let candidates = distinct_best(&parameters, &near, 5, 0.25);
    let split = best_run
        .mape
        .split
        .map(|s| (s.before_percent, s.after_percent));
    let mut report = Document::new();
    report
        .heading(1, format!("GTN calibration of {}", args.test.display()))
        .paragraph(format!(
            "Best MAPE {best_mape:.3} % (before the maximum force {:.3} %, after {:.3} %) after {} simulations; \
             target {} % {}; {:.1} s. Stopped: {:?}.",
            split.map_or(f64::NAN, |s| s.0),
            split.map_or(f64::NAN, |s| s.1),
            outcome.evaluations.len(),
            args.target_mape,
            result
                .evaluations_to_target
                .map_or_else(|| "not reached".to_string(), |n| format!("reached at simulation {n}")),
            wall_s,
            result.stop,
        ))
        .paragraph(format!(
            "Mesh: {}. GTN softening depends on the element size at the neck: these parameters belong to it (`--element-mm`). For your own solver, the material is in `abaqus_material.inp` (Abaqus keywords; units N, mm, MPa).",
            model.tensile_model().settings.mesh_sentence()
        ))
        .heading(2, "Best parameters");
    let mut table = Table::new(&["parameter", "lower", "upper", "best", "position in range"]);
    for (p, v) in parameters.iter().zip(&best_values) {
        table.row(vec![
            p.name.clone(),
            format!("{}", p.lower),
            format!("{}", p.upper),
            format!("{v:.5}"),
            format!("{:.0} %", 100.0 * p.to_unit(*v)),
        ]);
    }
    report
        .table(table)
        .figure(Figure {
            file: "curve.svg".into(),
            caption: "measured vs calibrated force-displacement curve".into(),
            svg: chart_svg(&chart, 720.0, 440.0),
        })
        .figure(Figure {
            file: "loss.svg".into(),
            caption: "MAPE per simulation".into(),
            svg: chart_svg(&loss_chart, 720.0, 420.0),
        })
        .heading(
            2,
            "Not one answer: distinct parameter sets within 1.25 x best + 0.25 points of MAPE",
        )
        .paragraph(format!(
            "{} simulations lie that close; the best {} that are at least 0.25 apart in the unit box:",
            near.len(),
            candidates.len()
        ));
    let mut header = vec!["simulation", "MAPE [%]"];
    header.extend(PARAMETER_NAMES);
    let mut table = Table::new(&header);
    for c in &candidates {
        let mut cells = vec![c.evaluation_id.to_string(), format!("{:.3}", c.loss)];
        cells.extend(c.parameters.iter().map(|v| format!("{v:.4}")));
        table.row(cells);
    }
    report.table(table);
    if candidates.len() < 2 {
        report.paragraph(
            "The run stopped as soon as it reached the target, before it could map the region \
             of good fits. For that picture, run on with a lower `--target-mape` (0 runs the whole \
             budget) and `--resume` into the same directory: nothing is repeated.",
        );
    }
    let mut spread = Table::new(&[
        "parameter",
        "min among them",
        "max among them",
        "spread / range",
    ]);
    for (k, p) in parameters.iter().enumerate() {
        let values: Vec<f64> = candidates.iter().map(|c| c.parameters[k]).collect();
        let (low, high) = values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                (l.min(v), h.max(v))
            });
        spread.row(vec![
            p.name.clone(),
            format!("{low:.4}"),
            format!("{high:.4}"),
            format!("{:.0} %", 100.0 * (p.to_unit(high) - p.to_unit(low)).abs()),
        ]);
    }
    report.table(spread);
    write_identifiability(&mut report, &outcome.identifiability, &parameters);
    write_report(&directory, &report, "GTN calibration")?;
    println!(
        "best MAPE {best_mape:.3} % after {} simulations ({:.1} s); report in {}",
        outcome.evaluations.len(),
        wall_s,
        directory.file("report.md").display()
    );
    Ok(GtnCalibration {
        best_mape_pct: best_mape,
        best_split_pct: split,
        best_params: parameters
            .iter()
            .map(|p| p.name.clone())
            .zip(best_values.iter().copied())
            .collect(),
        evaluations: outcome.evaluations.len(),
        evaluations_to_target: result.evaluations_to_target,
        wall_s,
        report,
    })
}
