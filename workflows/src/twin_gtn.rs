//! `acq twin gtn`: one simulation of a tensile test's GTN twin with given
//! parameters, scored against the test (or run on an explicit flow curve),
//! or the same parameters at several element sizes (mesh convergence).
//! Its report, CSV and plot through [`crate::tensile_report`].

use std::path::Path;
use std::path::PathBuf;

use acq_analysis::extract::tensile_props::{read_test_csv, tensile_properties, SpecimenGeometry};
use acq_error::{AcqError, Result};
use acq_io::output::Output;

use crate::tensile_model::MeshOptions;
use crate::tensile_report::{
    comparison_svg, file_name, labelled_comparison_svg, simulated_curve_csv, twin_report,
};

/// `acq twin gtn`: one simulation of a test with given GTN parameters.
#[derive(Clone, Debug)]
pub struct TwinGtnOptions {
    /// Test curve CSV with DISPLACEMENT (mm) and FORCE (kN) columns: the
    /// flow curve and E come from it (unless `flow_curve` gives them), and
    /// the simulation is scored on it.
    pub test: Option<PathBuf>,
    /// An explicit flow curve instead of the test's: a CSV with
    /// PLASTIC_STRAIN and TRUE_STRESS_MPA columns from plastic strain 0
    /// (m extends it past its last point). With `test`, the test is only
    /// the reference the curve is scored and drawn against.
    pub flow_curve: Option<PathBuf>,
    /// Young's modulus with `flow_curve`, MPa (210,000 unless told).
    pub youngs_mpa: f64,
    /// How far to pull with `flow_curve`, mm [default: the test's last displacement].
    pub end_mm: Option<f64>,
    /// Radius reduction at the mid-gauge plane that seeds the neck, as a
    /// fraction of the radius (cosine-shaped along the half length).
    pub imperfection: f64,
    /// The eight GTN parameters, e.g.
    /// q1=1.332,q2=0.9952,q3=2.295,epsN=0.29,sN=0.1671,fN=0.03869,f0=0.00137,m=534.1
    /// (m in MPa; add fc=..,fF=.. for coalescence).
    pub param: String,
    /// Write the simulated curve (DISPLACEMENT,FORCE,NECK_DIAMETER,FAILED_POINTS).
    pub output: Option<PathBuf>,
    /// Print {"mape", "failed_early", "points", "wall_s"} instead of the report.
    pub json: bool,
    /// Draw the test and simulated curves.
    pub svg: Option<PathBuf>,
    pub mesh: MeshOptions,
    /// Mesh convergence instead of one run: the same parameters at each of
    /// these element sizes in the neck (mm, e.g. 0.33,0.18,0.12,0.09); a
    /// table of MAPE, maximum force and where the bar broke, and with
    /// `svg` the curves overlaid. Needs `test`.
    pub convergence: Vec<f64>,
    /// With `convergence`: the directory to write the mesh study to
    /// (summary.json, report.md, plots), as `acq mesh-study` does.
    pub out: Option<PathBuf>,
    /// Output interval of the simulated curve, mm: also the largest load step once the bar stops hardening steeply (the return mapping is first order in the step: after the maximum force the curve depends on it).
    pub step_mm: f64,
    /// Specimen diameter, mm.
    pub diameter_mm: f64,
    /// Length the displacement is measured over (the modelled half), mm.
    pub strain_length_mm: f64,
}

/// The parameters, the model's settings and the specimen `args` give,
/// checked before any work.
fn prepared(
    args: &TwinGtnOptions,
) -> Result<(
    crate::tensile_model::GtnInputs,
    crate::tensile_model::ModelSettings,
    SpecimenGeometry,
)> {
    use crate::tensile_model::{GtnInputs, ModelSettings};
    let inputs =
        GtnInputs::parse(&args.param).map_err(|e| AcqError::Config(format!("--param: {e}")))?;
    if !(args.step_mm > 0.0 && args.step_mm <= 1.0) {
        return Err(AcqError::Config(format!(
            "--step-mm must be in (0, 1] mm, got {}",
            args.step_mm
        )));
    }
    let mut settings = ModelSettings {
        output_interval_mm: args.step_mm,
        ..Default::default()
    };
    settings.geometry.diameter_mm = args.diameter_mm;
    settings.geometry.half_length_mm = args.strain_length_mm;
    settings.mesh = args
        .mesh
        .density(&settings.geometry)
        .map_err(AcqError::Config)?;
    let geometry = SpecimenGeometry {
        diameter_mm: args.diameter_mm,
        strain_length_mm: args.strain_length_mm,
    };
    if !(geometry.diameter_mm > 0.0 && geometry.strain_length_mm > 0.0) {
        return Err(AcqError::Config(
            "--diameter-mm and --strain-length-mm must be positive".into(),
        ));
    }
    settings.geometry.imperfection = args.imperfection;
    settings
        .geometry
        .validate()
        .map_err(|e| AcqError::Config(format!("--imperfection: {e}")))?;
    Ok((inputs, settings, geometry))
}

/// The twin of `test` (its flow curve and E from the test itself), with
/// the parameters checked against their ranges.
fn test_model(
    test: &Path,
    settings: crate::tensile_model::ModelSettings,
    geometry: SpecimenGeometry,
    inputs: &crate::tensile_model::GtnInputs,
) -> Result<crate::tensile_model::TensileModel> {
    let points = read_test_csv(test)?;
    let properties = tensile_properties(&points, geometry)
        .map_err(|e| AcqError::Malformed(format!("{}: {e}", test.display())))?;
    let model = crate::tensile_model::TensileModel::new(points, properties, settings);
    // Parameters out of range are a usage error (exit 2), before any work.
    model
        .twin(inputs)
        .map_err(|e| AcqError::Config(format!("--param: {e}")))?;
    Ok(model)
}

fn no_test() -> AcqError {
    AcqError::Config(
        "give the test (--test TEST.csv), or a flow curve (--flow-curve FLOW.csv)".into(),
    )
}

/// One simulation of `args.test` with `args.param` (what `acq twin gtn
/// --test` reports): the model, with the test it is scored on, and the run.
pub fn simulate_test(
    args: &TwinGtnOptions,
) -> Result<(
    crate::tensile_model::TensileModel,
    crate::tensile_model::TensileRun,
)> {
    let (inputs, settings, geometry) = prepared(args)?;
    let test = args.test.as_deref().ok_or_else(no_test)?;
    let model = test_model(test, settings, geometry, &inputs)?;
    let run = run_once(&model, &inputs)?;
    Ok((model, run))
}

fn run_once(
    model: &crate::tensile_model::TensileModel,
    inputs: &crate::tensile_model::GtnInputs,
) -> Result<crate::tensile_model::TensileRun> {
    let run = model
        .run(inputs)
        .map_err(|e| AcqError::Config(e.to_string()))?;
    say_if_not_converged(&run.result.outcome);
    Ok(run)
}

pub fn run(args: TwinGtnOptions) -> Result<()> {
    let (inputs, settings, geometry) = prepared(&args)?;
    if let Some(flow_path) = &args.flow_curve {
        return run_twin_gtn_with_flow_curve(&args, flow_path, &inputs, settings, geometry);
    }
    let test = args.test.as_deref().ok_or_else(no_test)?;
    let model = test_model(test, settings, geometry, &inputs)?;
    if !args.convergence.is_empty() {
        return run_mesh_convergence(&args, test, &model, &inputs);
    }
    let run = run_once(&model, &inputs)?;
    if let Some(path) = &args.output {
        Output::write_complete(path, simulated_curve_csv(&run.result.curve).as_bytes())?;
    }
    if let Some(path) = &args.svg {
        let title = format!(
            "{}: GTN twin vs test (MAPE {:.3} %)",
            file_name(test),
            run.mape.mape_percent
        );
        Output::write_complete(
            path,
            comparison_svg(&title, &model.test, &run.result.curve).as_bytes(),
        )?;
    }
    let mut stdout = Output::create(None)?;
    let text = if args.json {
        format!(
            "{}\n",
            serde_json::json!({
                "mape": run.mape.mape_percent,
                "failed_early": run.failed_early,
                "points": run.result.curve.len(),
                "wall_s": run.wall_s,
            })
        )
    } else {
        twin_report(&file_name(test), &model, &inputs, &run)
    };
    stdout.buffer.extend_from_slice(text.as_bytes());
    stdout.finish()?;
    Ok(())
}

/// `acq twin gtn --convergence SIZES`: the table (or JSON) and the plot.
fn run_mesh_convergence(
    args: &TwinGtnOptions,
    test: &Path,
    model: &crate::tensile_model::TensileModel,
    inputs: &crate::tensile_model::GtnInputs,
) -> Result<()> {
    use crate::mesh_convergence::{
        convergence_svg, convergence_table, grid_convergence_lines, mesh_convergence,
        mesh_study_outcome,
    };
    let start = std::time::Instant::now();
    // Every size is checked before the first (slow) run.
    for &size in &args.convergence {
        acq_twins::tensile::mesh::MeshDensity::by_element_size(
            &model.settings.geometry,
            size,
            args.mesh.neck_zone_mm,
        )
        .map_err(|e| AcqError::Config(format!("--convergence {size}: {e}")))?;
    }
    let runs = mesh_convergence(
        model,
        inputs,
        &args.convergence,
        args.mesh.neck_zone_mm,
        |run| {
            eprintln!(
                "acq twin gtn: {} mm elements ({}x{}): MAPE {:.3} % in {:.1} s",
                run.element_mm,
                run.mesh.radial_elements,
                run.mesh.axial_elements,
                run.mape_pct,
                run.wall_s
            );
        },
    )
    .map_err(AcqError::Config)?;
    let outcome = mesh_study_outcome(&runs, inputs.named_values()).map_err(AcqError::Malformed)?;
    if let Some(out) = &args.out {
        let directory = acq_study::run_directory::RunDirectory::create(out)?;
        acq_study::mesh_study::write_results(
            &outcome,
            &args.convergence,
            &directory,
            start.elapsed().as_secs_f64(),
        )?;
    }
    if let Some(path) = &args.svg {
        let test_points: Vec<(f64, f64)> = model
            .test
            .iter()
            .map(|p| (p.displacement_mm, p.force_kn))
            .collect();
        let title = format!(
            "{}: GTN twin at {} element sizes",
            file_name(test),
            runs.len()
        );
        Output::write_complete(
            path,
            convergence_svg(&title, &test_points, &runs).as_bytes(),
        )?;
    }
    let text = if args.json {
        let sizes: Vec<serde_json::Value> = runs
            .iter()
            .map(|run| {
                serde_json::json!({
                    "element_mm": run.element_mm,
                    "radial_elements": run.mesh.radial_elements,
                    "axial_elements": run.mesh.axial_elements,
                    "mape": run.mape_pct,
                    "max_force_kn": run.max_force_kn,
                    "fracture_mm": run.fracture_mm,
                    "wall_s": run.wall_s,
                })
            })
            .collect();
        format!("{}\n", serde_json::Value::Array(sizes))
    } else {
        format!(
            "GTN twin mesh convergence: {}\n{}{}",
            file_name(test),
            convergence_table(&runs),
            grid_convergence_lines(&outcome)
        )
    };
    let mut stdout = Output::create(None)?;
    stdout.buffer.extend_from_slice(text.as_bytes());
    stdout.finish()?;
    Ok(())
}

fn say_if_not_converged(outcome: &acq_twins::tensile::solver::Outcome) {
    if let acq_twins::tensile::solver::Outcome::NotConverged {
        displacement_mm,
        reason,
    } = outcome
    {
        eprintln!(
            "acq: the simulation did not converge beyond u = {displacement_mm:.4} mm ({reason}); the rest of the curve counts as zero force"
        );
    }
}

/// `acq twin gtn --flow-curve FLOW.csv`: the twin of an explicit flow
/// curve (for a comparison with another FE code on the same material),
/// scored and drawn against `--test` when one is given.
fn run_twin_gtn_with_flow_curve(
    args: &TwinGtnOptions,
    flow_path: &Path,
    inputs: &crate::tensile_model::GtnInputs,
    settings: crate::tensile_model::ModelSettings,
    geometry: SpecimenGeometry,
) -> Result<()> {
    use crate::tensile_model::{build_twin, read_flow_curve};
    use acq_analysis::loss::curve::{curve_mape, CurveMapeOptions};
    let table = read_flow_curve(flow_path).map_err(AcqError::Malformed)?;
    acq_io::input::note_input(flow_path);
    if !(args.youngs_mpa.is_finite() && args.youngs_mpa > 0.0 && args.youngs_mpa <= 1e7) {
        return Err(AcqError::Config(format!(
            "--youngs-mpa {}: give a modulus above 0 and at most 1e7 MPa",
            args.youngs_mpa
        )));
    }
    // `settings` carry the specimen's geometry and the mesh on it already.
    let twin = build_twin(&table, args.youngs_mpa, inputs, &settings)
        .map_err(|e| AcqError::Config(format!("--param: {e}")))?;
    let reference = match &args.test {
        Some(path) => Some(read_test_csv(path)?),
        None => None,
    };
    let end_mm = match (args.end_mm, &reference) {
        (Some(end), _) => end,
        (None, Some(points)) => points.iter().map(|p| p.displacement_mm).fold(0.0, f64::max),
        (None, None) => {
            return Err(AcqError::Config(
                "--flow-curve without --test: say how far to pull with --end-mm".into(),
            ))
        }
    };
    if !(end_mm.is_finite() && end_mm > 0.0 && end_mm <= geometry.strain_length_mm) {
        return Err(AcqError::Config(format!(
            "--end-mm {end_mm}: pull more than 0 and at most the modelled length, {} mm",
            geometry.strain_length_mm
        )));
    }
    let mut loading = acq_twins::tensile::solver::LoadingSettings::to(end_mm);
    loading.output_interval_mm = args.step_mm;
    let start = std::time::Instant::now();
    let result = twin.pull(&loading).map_err(AcqError::Config)?;
    let wall_s = start.elapsed().as_secs_f64();
    say_if_not_converged(&result.outcome);
    if let Some(path) = &args.output {
        Output::write_complete(path, simulated_curve_csv(&result.curve).as_bytes())?;
    }
    let curve: Vec<(f64, f64)> = result
        .curve
        .iter()
        .map(|p| (p.displacement_mm, p.force_kn))
        .collect();
    let mape = match &reference {
        Some(points) => {
            let test: Vec<(f64, f64)> = points
                .iter()
                .map(|p| (p.displacement_mm, p.force_kn))
                .collect();
            Some(
                curve_mape(&test, &curve, CurveMapeOptions::default())
                    .map_err(|e| AcqError::Malformed(format!("--test: {e}")))?
                    .mape_percent,
            )
        }
        None => None,
    };
    if let (Some(path), Some(points)) = (&args.svg, &reference) {
        let reference = args
            .test
            .as_deref()
            .and_then(Path::file_stem)
            .map_or_else(|| "reference".into(), |s| s.to_string_lossy().into_owned());
        let title = format!(
            "acq twin of {} vs {reference} (MAPE {:.3} %)",
            file_name(flow_path),
            mape.unwrap_or(f64::NAN)
        );
        Output::write_complete(
            path,
            labelled_comparison_svg(&title, &reference, points, &result.curve).as_bytes(),
        )?;
    }
    let (u_at_max, max_force) = curve
        .iter()
        .copied()
        .fold((0.0, f64::NEG_INFINITY), |best, p| {
            if p.1 > best.1 {
                p
            } else {
                best
            }
        });
    let summary = serde_json::json!({
        "mape": mape,
        "max_force_kn": max_force,
        "u_at_max_force_mm": u_at_max,
        "points": result.curve.len(),
        "wall_s": wall_s,
    });
    let mut stdout = Output::create(None)?;
    stdout
        .buffer
        .extend_from_slice(format!("{summary:#}\n").as_bytes());
    stdout.finish()
}
