//! `acq tensile-props TEST.csv`: Young's modulus, Rp0.2, UTS, flow curve
//! and post-UTS slope bounds of a tensile test, as a report, JSON, a flow
//! curve CSV and an SVG. Glue between the command line and
//! [`acq_analysis::extract::tensile_props`], which documents the method.

use std::path::{Path, PathBuf};

use acq_analysis::extract::tensile_props::{read_test_csv, tensile_properties, SpecimenGeometry};
use acq_io::error::{AcqError, Result};
use acq_io::output::Output;
use acq_workflows::tensile_report::{
    comparison_svg, flow_curve_csv, properties_svg, report, simulated_curve_csv, twin_report,
};
use clap::Args;

#[derive(Args, Debug)]
pub struct TensilePropsArgs {
    /// Test curve CSV with DISPLACEMENT (mm) and FORCE (kN) columns (others ignored).
    #[arg(value_name = "TEST.csv")]
    pub test: PathBuf,
    /// Specimen diameter, mm.
    #[arg(long, value_name = "MM", default_value_t = 4.0)]
    pub diameter_mm: f64,
    /// Length the displacement is measured over (strain = u / this), mm;
    /// 12.5 = half the 25 mm gauge, as in the published half-model data.
    #[arg(long, value_name = "MM", default_value_t = 12.5)]
    pub strain_length_mm: f64,
    /// Print every result as one JSON object instead of the report.
    #[arg(long)]
    pub json: bool,
    /// Write the flow curve (PLASTIC_STRAIN,TRUE_STRESS_MPA) to this CSV.
    #[arg(short = 'o', long = "output", value_name = "FLOW.csv")]
    pub output: Option<PathBuf>,
    /// Draw the engineering curve and the flow curve with the m bounds.
    #[arg(long, value_name = "FILE.svg")]
    pub svg: Option<PathBuf>,
}

pub fn run_tensile_props(args: TensilePropsArgs) -> Result<()> {
    for (name, value) in [
        ("--diameter-mm", args.diameter_mm),
        ("--strain-length-mm", args.strain_length_mm),
    ] {
        if !(value.is_finite() && value > 0.0) {
            return Err(AcqError::Config(format!(
                "{name} must be a positive length in mm, got {value}"
            )));
        }
    }
    let geometry = SpecimenGeometry {
        diameter_mm: args.diameter_mm,
        strain_length_mm: args.strain_length_mm,
    };
    let points = read_test_csv(&args.test)?;
    let properties = tensile_properties(&points, geometry)
        .map_err(|e| AcqError::Malformed(format!("{}: {e}", args.test.display())))?;

    if let Some(path) = &args.output {
        Output::write_complete(
            path,
            flow_curve_csv(&properties.flow_curve.points).as_bytes(),
        )?;
    }
    if let Some(path) = &args.svg {
        let title = format!("{}: tensile properties", file_name(&args.test));
        Output::write_complete(
            path,
            properties_svg(&title, &points, &properties).as_bytes(),
        )?;
    }
    // Through Output, so `acq tensile-props ... | head` ends quietly.
    let mut stdout = Output::create(None)?;
    if args.json {
        let json = serde_json::to_string_pretty(&properties)
            .map_err(|e| AcqError::Config(format!("cannot write JSON: {e}")))?;
        stdout.buffer.extend_from_slice(json.as_bytes());
        stdout.buffer.push(b'\n');
    } else {
        let text = report(&file_name(&args.test), &properties);
        stdout.buffer.extend_from_slice(text.as_bytes());
    }
    stdout.finish()?;
    Ok(())
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

/// `acq twin gtn`: one simulation of a test with given GTN parameters.
#[derive(Args, Debug)]
pub struct TwinGtnArgs {
    /// Test curve CSV with DISPLACEMENT (mm) and FORCE (kN) columns: the
    /// flow curve and E come from it, and the simulation is scored on it.
    #[arg(long, value_name = "TEST.csv")]
    pub test: PathBuf,
    /// The eight GTN parameters, e.g.
    /// q1=1.332,q2=0.9952,q3=2.295,epsN=0.29,sN=0.1671,fN=0.03869,f0=0.00137,m=534.1
    /// (m in MPa; add fc=..,fF=.. for coalescence).
    #[arg(long, value_name = "NAME=VALUE,...")]
    pub param: String,
    /// Write the simulated curve (DISPLACEMENT,FORCE,NECK_DIAMETER,FAILED_POINTS).
    #[arg(short = 'o', long = "output", value_name = "curve.csv")]
    pub output: Option<PathBuf>,
    /// Print {"mape", "failed_early", "points", "wall_s"} instead of the report.
    #[arg(long)]
    pub json: bool,
    /// Draw the test and simulated curves.
    #[arg(long, value_name = "FILE.svg")]
    pub svg: Option<PathBuf>,
    /// Mesh as RADIALxAXIAL elements of the quarter model.
    #[arg(long, value_name = "NRxNZ", default_value = "6x30")]
    pub mesh: String,
    /// Output interval of the simulated curve, also the largest load step, mm.
    #[arg(long, value_name = "MM", default_value_t = 0.01)]
    pub step_mm: f64,
    /// Specimen diameter, mm.
    #[arg(long, value_name = "MM", default_value_t = 4.0)]
    pub diameter_mm: f64,
    /// Length the displacement is measured over (the modelled half), mm.
    #[arg(long, value_name = "MM", default_value_t = 12.5)]
    pub strain_length_mm: f64,
}

fn parse_mesh(text: &str) -> Result<acq_twins::tensile::mesh::MeshDensity> {
    acq_twins::tensile::mesh::MeshDensity::parse(text)
        .map_err(|e| AcqError::Config(format!("--mesh {e}")))
}

pub fn run_twin_gtn(args: TwinGtnArgs) -> Result<()> {
    use acq_workflows::tensile_model::{GtnInputs, ModelSettings, TensileModel};
    let inputs =
        GtnInputs::parse(&args.param).map_err(|e| AcqError::Config(format!("--param: {e}")))?;
    if !(args.step_mm > 0.0 && args.step_mm <= 1.0) {
        return Err(AcqError::Config(format!(
            "--step-mm must be in (0, 1] mm, got {}",
            args.step_mm
        )));
    }
    let mut settings = ModelSettings {
        mesh: parse_mesh(&args.mesh)?,
        output_interval_mm: args.step_mm,
        ..Default::default()
    };
    settings.geometry.diameter_mm = args.diameter_mm;
    let geometry = SpecimenGeometry {
        diameter_mm: args.diameter_mm,
        strain_length_mm: args.strain_length_mm,
    };
    if !(geometry.diameter_mm > 0.0 && geometry.strain_length_mm > 0.0) {
        return Err(AcqError::Config(
            "--diameter-mm and --strain-length-mm must be positive".into(),
        ));
    }
    let points = read_test_csv(&args.test)?;
    let properties = tensile_properties(&points, geometry)
        .map_err(|e| AcqError::Malformed(format!("{}: {e}", args.test.display())))?;
    let model = TensileModel::new(points, properties, settings);
    // Parameters out of range are a usage error (exit 2), before any work.
    model
        .twin(&inputs)
        .map_err(|e| AcqError::Config(format!("--param: {e}")))?;
    let run = model
        .run(&inputs)
        .map_err(|e| AcqError::Config(e.to_string()))?;
    if let acq_twins::tensile::solver::Outcome::NotConverged {
        displacement_mm,
        reason,
    } = &run.result.outcome
    {
        eprintln!(
            "acq: the simulation did not converge beyond u = {displacement_mm:.4} mm ({reason}); the rest of the curve counts as zero force"
        );
    }
    if let Some(path) = &args.output {
        Output::write_complete(path, simulated_curve_csv(&run.result.curve).as_bytes())?;
    }
    if let Some(path) = &args.svg {
        let title = format!(
            "{}: GTN twin vs test (MAPE {:.3} %)",
            file_name(&args.test),
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
        twin_report(&file_name(&args.test), &model, &inputs, &run)
    };
    stdout.buffer.extend_from_slice(text.as_bytes());
    stdout.finish()?;
    Ok(())
}
