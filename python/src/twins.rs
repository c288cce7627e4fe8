//! The twins for Python: one run of the excavator twin at a case (its
//! outputs as `acq twin excavator --json` prints them) and one GTN
//! simulation of a tensile test (its score, and the simulated and test
//! curves as columns). Values cross as JSON text and lists; the package's
//! Python side makes dicts and NumPy arrays of them.

use std::path::PathBuf;

use acq_workflows::tensile_model::MeshOptions;
use acq_workflows::twin_excavator::{run_case, ExcavatorModelOptions, TwinExcavatorOptions};
use acq_workflows::twin_gtn::{simulate_test, TwinGtnOptions};
use pyo3::prelude::*;

use crate::python_error;

/// The excavator twin at `case`'s nominal inputs, any of them set: the
/// JSON object `acq twin excavator --json` prints.
#[pyfunction]
#[pyo3(signature = (case, geometry, bucket_stroke_mm, arm_stroke_mm, boom_stroke_mm, force_kn, angle_deg, envelope))]
#[allow(clippy::too_many_arguments)]
pub fn twin_excavator(
    py: Python<'_>,
    case: PathBuf,
    geometry: Option<PathBuf>,
    bucket_stroke_mm: Option<f64>,
    arm_stroke_mm: Option<f64>,
    boom_stroke_mm: Option<f64>,
    force_kn: Option<f64>,
    angle_deg: Option<f64>,
    envelope: bool,
) -> PyResult<String> {
    let options = TwinExcavatorOptions {
        model: ExcavatorModelOptions { case, geometry },
        bucket_stroke_mm,
        arm_stroke_mm,
        boom_stroke_mm,
        force_kn,
        angle_deg,
        json: true,
        envelope,
    };
    let run = py.detach(|| run_case(&options)).map_err(python_error)?;
    Ok(run.json().to_string())
}

/// A curve's columns, each a list of floats.
type Columns = Vec<Vec<f64>>;

/// One GTN run of a tensile test, as `acq twin gtn --test TEST --param
/// PARAM`: `(summary JSON, simulated columns, test columns)`.
#[pyfunction]
#[pyo3(signature = (test, param, mesh, element_mm, neck_zone_mm, step_mm, diameter_mm, strain_length_mm, imperfection))]
#[allow(clippy::too_many_arguments)]
pub fn twin_gtn(
    py: Python<'_>,
    test: PathBuf,
    param: String,
    mesh: String,
    element_mm: Option<f64>,
    neck_zone_mm: Option<f64>,
    step_mm: f64,
    diameter_mm: f64,
    strain_length_mm: f64,
    imperfection: f64,
) -> PyResult<(String, Columns, Columns)> {
    let options = TwinGtnOptions {
        test: Some(test),
        flow_curve: None,
        youngs_mpa: 210_000.0,
        end_mm: None,
        imperfection,
        param,
        output: None,
        json: true,
        svg: None,
        mesh: MeshOptions {
            mesh,
            element_mm,
            neck_zone_mm,
        },
        convergence: Vec::new(),
        out: None,
        step_mm,
        diameter_mm,
        strain_length_mm,
    };
    let (model, run) = py
        .detach(|| simulate_test(&options))
        .map_err(python_error)?;
    let curve = &run.result.curve;
    let simulated = vec![
        curve.iter().map(|p| p.displacement_mm).collect(),
        curve.iter().map(|p| p.force_kn).collect(),
        curve.iter().map(|p| p.neck_diameter_mm).collect(),
        curve.iter().map(|p| p.failed_points as f64).collect(),
    ];
    let test = vec![
        model.test.iter().map(|p| p.displacement_mm).collect(),
        model.test.iter().map(|p| p.force_kn).collect(),
    ];
    let summary = serde_json::json!({
        "mape_pct": run.mape.mape_percent,
        "failed_early": run.failed_early,
        "converged": !matches!(run.result.outcome, acq_twins::tensile::solver::Outcome::NotConverged { .. }),
        "wall_s": run.wall_s,
        "mesh": {
            "radial_elements": model.settings.mesh.radial_elements,
            "axial_elements": model.settings.mesh.axial_elements,
        },
    });
    Ok((summary.to_string(), simulated, test))
}
