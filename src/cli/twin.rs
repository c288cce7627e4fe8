//! `acq twin` and `acq sensitivity`: dispatch to the twin runs of
//! [`acq_workflows::twin_excavator`] and [`acq_workflows::twin_gtn`].

use std::path::PathBuf;

use acq_io::error::Result;
use acq_workflows::twin_excavator::{
    ExcavatorModelOptions, SensitivityExcavatorOptions, TwinExcavatorOptions,
};
use acq_workflows::twin_gtn::TwinGtnArgs;
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
        TwinCommand::Gtn(args) => acq_workflows::twin_gtn::run(args),
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
