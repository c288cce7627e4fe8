//! `acq tensile-props TEST.csv`: Young's modulus, Rp0.2, UTS, flow curve
//! and post-UTS slope bounds of a tensile test, as a report, JSON, a flow
//! curve CSV and an SVG. Glue between the command line and
//! [`acq_analysis::extract::tensile_props`], which documents the method.

use std::path::PathBuf;

use acq_analysis::extract::tensile_props::{read_test_csv, tensile_properties, SpecimenGeometry};
use acq_error::{AcqError, Result};
use acq_io::output::Output;
use acq_workflows::tensile_report::{file_name, flow_curve_csv, properties_svg, report};
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
