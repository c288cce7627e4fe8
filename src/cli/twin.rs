//! `acq twin` and `acq sensitivity`: dispatch to the twin runs of
//! [`acq_workflows::twin_excavator`] and [`acq_workflows::twin_gtn`].

use std::path::PathBuf;

use acq_error::Result;
use acq_workflows::twin_excavator::{
    ExcavatorModelOptions, SensitivityExcavatorOptions, TwinExcavatorOptions,
};
use acq_workflows::twin_gtn::TwinGtnOptions;

use super::calibrate::MeshArgs;
use clap::Subcommand;

#[derive(Subcommand, Debug)]
pub enum TwinCommand {
    /// The excavator front attachment: pose, cylinder pressures, gauge stresses.
    Excavator(TwinExcavatorArgs),
    /// The round tensile bar with GTN damage: curve and MAPE against a test.
    Gtn(TwinGtnArgs),
}

#[derive(Subcommand, Debug)]
pub enum SensitivityCommand {
    /// One-at-a-time sweep of the excavator case's uncertain inputs.
    Excavator(SensitivityExcavatorArgs),
}

pub fn run_twin(command: TwinCommand) -> Result<()> {
    match command {
        TwinCommand::Excavator(args) => acq_workflows::twin_excavator::run_twin(args.into()),
        TwinCommand::Gtn(args) => acq_workflows::twin_gtn::run(args.into()),
    }
}

pub fn run_sensitivity(command: SensitivityCommand) -> Result<()> {
    let SensitivityCommand::Excavator(args) = command;
    acq_workflows::twin_excavator::run_sensitivity(args.into())
}

#[derive(clap::Args, Debug)]
pub struct ExcavatorModelArgs {
    /// Case file (TOML): tip force, bounds of the uncertain inputs (nominal =
    /// middle), optionally measured pressures and points.
    #[arg(long, value_name = "FILE")]
    pub case: PathBuf,
    /// Geometry file [default: the built-in DX55-class data/excavator/dx55.toml].
    #[arg(long, value_name = "FILE")]
    pub geometry: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
pub struct TwinExcavatorArgs {
    #[command(flatten)]
    pub model: ExcavatorModelArgs,
    /// Bucket cylinder stroke, mm [default: the case's nominal].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    pub bucket_stroke: Option<f64>,
    /// Arm cylinder stroke, mm [default: the case's nominal].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    pub arm_stroke: Option<f64>,
    /// Boom cylinder stroke, mm [default: the case's nominal].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    pub boom_stroke: Option<f64>,
    /// Tip force, kN [default: the case's].
    #[arg(long, value_name = "KN", allow_negative_numbers = true)]
    pub force: Option<f64>,
    /// Tip force direction, degrees from +Y (forward) toward +Z (up) [default: the case's nominal].
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub angle: Option<f64>,
    /// Print one JSON object instead of the tables.
    #[arg(long)]
    pub json: bool,
    /// Also give the working envelope over the stroke ranges: maximum
    /// reach, digging depth and dump height (needs the foot pin's place,
    /// base.foot_pin_above_ground_m and base.foot_pin_ahead_of_swing_axis_m).
    #[arg(long)]
    pub envelope: bool,
}

#[derive(clap::Args, Debug)]
pub struct SensitivityExcavatorArgs {
    #[command(flatten)]
    pub model: ExcavatorModelArgs,
    /// Values per input, bounds included.
    #[arg(long, default_value_t = 21, value_parser = clap::value_parser!(u32).range(2..=10_000))]
    pub points: u32,
    /// The table (CSV) [default: <case name>-sensitivity.csv].
    #[arg(short = 'o', long = "output", value_name = "CSV")]
    pub output: Option<PathBuf>,
    /// The plot [default: the table's name with .svg].
    #[arg(long, value_name = "SVG")]
    pub svg: Option<PathBuf>,
}

/// `acq twin gtn`: one simulation of a test with given GTN parameters.
#[derive(clap::Args, Debug)]
pub struct TwinGtnArgs {
    /// Test curve CSV with DISPLACEMENT (mm) and FORCE (kN) columns: the
    /// flow curve and E come from it (unless --flow-curve gives them), and
    /// the simulation is scored on it.
    #[arg(long, value_name = "TEST.csv", required_unless_present = "flow_curve")]
    pub test: Option<PathBuf>,
    /// An explicit flow curve instead of the test's: a CSV with
    /// PLASTIC_STRAIN and TRUE_STRESS_MPA columns from plastic strain 0
    /// (m extends it past its last point). With --test, the test is only
    /// the reference the curve is scored and drawn against.
    #[arg(long, value_name = "FLOW.csv")]
    pub flow_curve: Option<PathBuf>,
    /// Young's modulus with --flow-curve, MPa.
    #[arg(
        long,
        value_name = "MPA",
        default_value_t = 210_000.0,
        requires = "flow_curve"
    )]
    pub youngs_mpa: f64,
    /// How far to pull with --flow-curve, mm [default: the test's last displacement].
    #[arg(long, value_name = "MM", requires = "flow_curve")]
    pub end_mm: Option<f64>,
    /// Radius reduction at the mid-gauge plane that seeds the neck, as a
    /// fraction of the radius (cosine-shaped along the half length).
    #[arg(long, value_name = "FRACTION", default_value_t = 0.001)]
    pub imperfection: f64,
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
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Mesh convergence instead of one run: the same parameters at each of
    /// these element sizes in the neck (mm, e.g. 0.33,0.18,0.12,0.09); a
    /// table of MAPE, maximum force and where the bar broke, and with
    /// --svg the curves overlaid. Needs --test.
    #[arg(
        long,
        value_name = "MM,...",
        value_delimiter = ',',
        num_args = 1..,
        conflicts_with_all = ["mesh", "element_mm", "output", "flow_curve"],
        requires = "test"
    )]
    pub convergence: Vec<f64>,
    /// With --convergence: also write the mesh study as `acq mesh-study`
    /// does, DIR/summary.json (`mesh_study`: max_force_kn, mape_pct and,
    /// when every size broke, fracture_mm; `mesh_study_curves`: the force
    /// curve part by part), report.md and its plots. A spec's `[posterior]
    /// mesh_study = DIR` reads it.
    #[arg(long, value_name = "DIR", requires = "convergence")]
    pub out: Option<PathBuf>,
    /// Output interval of the simulated curve, mm: also the largest load step once the bar stops hardening steeply (the return mapping is first order in the step: after the maximum force the curve depends on it).
    #[arg(long, value_name = "MM", default_value_t = 0.01)]
    pub step_mm: f64,
    /// Specimen diameter, mm.
    #[arg(long, value_name = "MM", default_value_t = 4.0)]
    pub diameter_mm: f64,
    /// Length the displacement is measured over (the modelled half), mm.
    #[arg(long, value_name = "MM", default_value_t = 12.5)]
    pub strain_length_mm: f64,
}

impl From<ExcavatorModelArgs> for ExcavatorModelOptions {
    fn from(args: ExcavatorModelArgs) -> Self {
        ExcavatorModelOptions {
            case: args.case,
            geometry: args.geometry,
        }
    }
}

impl From<TwinExcavatorArgs> for TwinExcavatorOptions {
    fn from(args: TwinExcavatorArgs) -> Self {
        TwinExcavatorOptions {
            model: args.model.into(),
            bucket_stroke_mm: args.bucket_stroke,
            arm_stroke_mm: args.arm_stroke,
            boom_stroke_mm: args.boom_stroke,
            force_kn: args.force,
            angle_deg: args.angle,
            json: args.json,
            envelope: args.envelope,
        }
    }
}

impl From<SensitivityExcavatorArgs> for SensitivityExcavatorOptions {
    fn from(args: SensitivityExcavatorArgs) -> Self {
        SensitivityExcavatorOptions {
            model: args.model.into(),
            points: args.points,
            output: args.output,
            svg: args.svg,
        }
    }
}

impl From<TwinGtnArgs> for TwinGtnOptions {
    fn from(args: TwinGtnArgs) -> Self {
        TwinGtnOptions {
            test: args.test,
            flow_curve: args.flow_curve,
            youngs_mpa: args.youngs_mpa,
            end_mm: args.end_mm,
            imperfection: args.imperfection,
            param: args.param,
            output: args.output,
            json: args.json,
            svg: args.svg,
            mesh: args.mesh.into(),
            convergence: args.convergence,
            out: args.out,
            step_mm: args.step_mm,
            diameter_mm: args.diameter_mm,
            strain_length_mm: args.strain_length_mm,
        }
    }
}
