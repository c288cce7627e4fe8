//! `acq twin` and `acq sensitivity`: run a twin once, or sweep its uncertain
//! inputs one at a time. Glue between the command line, the twins crate and
//! [`crate::sensitivity`].

use std::path::PathBuf;

use acq_twins::excavator::case::{CaseFile, UncertainInput};
use acq_twins::excavator::geometry::Geometry;
use acq_twins::excavator::{CylinderName, Evaluation, Excavator, Inputs};
use clap::{Args, Subcommand};

use crate::error::{AcqError, Result};
use crate::output::Output;
use crate::plot::grid_svg;
use crate::sensitivity::{one_at_a_time, Factor, Response};

#[derive(Subcommand, Debug)]
pub enum TwinCommand {
    /// The excavator front attachment: pose, cylinder pressures, gauge stresses.
    Excavator(TwinExcavatorArgs),
    /// The round tensile bar with GTN damage: curve and MAPE against a test.
    Gtn(crate::tensile_cli::TwinGtnArgs),
}

#[derive(Args, Debug)]
pub struct ExcavatorModelArgs {
    /// Case file (TOML): tip force, bounds of the uncertain inputs (nominal =
    /// middle), optionally measured pressures and points.
    #[arg(long, value_name = "FILE")]
    pub case: PathBuf,
    /// Geometry file [default: the built-in DX55-class data/excavator/dx55.toml].
    #[arg(long, value_name = "FILE")]
    pub geometry: Option<PathBuf>,
}

#[derive(Args, Debug)]
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
}

#[derive(Subcommand, Debug)]
pub enum SensitivityCommand {
    /// One-at-a-time sweep of the excavator case's uncertain inputs.
    Excavator(SensitivityExcavatorArgs),
}

#[derive(Args, Debug)]
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

fn load_model(args: &ExcavatorModelArgs) -> Result<(CaseFile, Excavator)> {
    let case = CaseFile::load(&args.case).map_err(AcqError::Config)?;
    let geometry = match &args.geometry {
        Some(path) => Geometry::load(path).map_err(AcqError::Config)?,
        None => Geometry::dx55(),
    };
    let twin = Excavator::new(geometry).map_err(|e| AcqError::Config(e.to_string()))?;
    Ok((case, twin))
}

pub fn run_twin(command: TwinCommand) -> Result<()> {
    let args = match command {
        TwinCommand::Excavator(args) => args,
        TwinCommand::Gtn(args) => return crate::tensile_cli::run_twin_gtn(args),
    };
    let (case, twin) = load_model(&args.model)?;
    let mut inputs = case.nominal();
    let overrides = [
        (UncertainInput::BucketStroke, args.bucket_stroke),
        (UncertainInput::ArmStroke, args.arm_stroke),
        (UncertainInput::BoomStroke, args.boom_stroke),
        (UncertainInput::ForceAngle, args.angle),
    ];
    for (input, value) in overrides {
        if let Some(value) = value {
            input.apply(&mut inputs, value);
        }
    }
    if let Some(force) = args.force {
        inputs.tip_force_kn = force;
    }
    let evaluation = twin
        .evaluate(&inputs)
        .map_err(|e| AcqError::Config(format!("{}: {e}", case.name)))?;
    if args.json {
        println!("{}", evaluation_json(&evaluation));
    } else {
        print!("{}", evaluation_report(&case, &inputs, &twin, &evaluation));
    }
    Ok(())
}

/// The fixed `--json` object.
pub fn evaluation_json(evaluation: &Evaluation) -> serde_json::Value {
    let point = |p: &acq_twins::excavator::kinematics::Vec2| serde_json::json!([p.x, p.y]);
    let per_cylinder = |f: &dyn Fn(CylinderName) -> f64| serde_json::json!({"bucket": f(CylinderName::Bucket), "arm": f(CylinderName::Arm), "boom": f(CylinderName::Boom)});
    let pose = &evaluation.pose;
    serde_json::json!({
        "points": {"A": point(&pose.a), "B": point(&pose.b), "G": point(&pose.g), "J": point(&pose.j)},
        "pressure_bar": per_cylinder(&|name| evaluation.cylinder(name).loaded_chamber_pressure_bar),
        "cylinder_force_kN": per_cylinder(&|name| evaluation.cylinder(name).axial_force_kn),
        "gauge_stress_MPa": evaluation.gauges.iter().map(|g| g.stress_mpa).collect::<Vec<_>>(),
        "max_von_mises_MPa": {"boom": evaluation.boom.max_von_mises_mpa, "arm": evaluation.arm.max_von_mises_mpa},
    })
}

fn evaluation_report(
    case: &CaseFile,
    inputs: &Inputs,
    twin: &Excavator,
    evaluation: &Evaluation,
) -> String {
    use std::fmt::Write as _;
    let mut text = String::new();
    let s = &inputs.strokes;
    let _ = writeln!(text, "{} on {}", case.name, twin.geometry().name);
    let _ = writeln!(
        text,
        "inputs: bucket {} mm, arm {} mm, boom {} mm; tip force {} kN at {} deg\n",
        s.bucket_mm, s.arm_mm, s.boom_mm, inputs.tip_force_kn, inputs.tip_force_angle_deg
    );
    let _ = writeln!(
        text,
        "point  Y m      Z m      measured Y, Z       error mm"
    );
    let pose = &evaluation.pose;
    let measured = case.measured_points;
    for (name, p, m) in [
        ("A", pose.a, None),
        ("B", pose.b, measured.map(|m| m.B)),
        ("G", pose.g, measured.map(|m| m.G)),
        ("J", pose.j, measured.map(|m| m.J)),
    ] {
        match m {
            Some([y, z]) => {
                let error_mm = (p.x - y).hypot(p.y - z) * 1e3;
                let _ = writeln!(
                    text,
                    "{name:<6} {:<8.4} {:<8.4} {y:<8.3} {z:<10.3} {error_mm:.1}",
                    p.x, p.y
                );
            }
            None => {
                let _ = writeln!(text, "{name:<6} {:<8.4} {:<8.4}", p.x, p.y);
            }
        }
    }
    let _ = writeln!(
        text,
        "\ncylinder  force kN  chamber  pressure bar  measured bar  error %"
    );
    for name in CylinderName::ALL {
        let c = evaluation.cylinder(name);
        let chamber = match c.loaded_chamber {
            acq_twins::excavator::Chamber::Head => "head",
            acq_twins::excavator::Chamber::Rod => "rod",
        };
        let _ = write!(
            text,
            "{:<9} {:<9.2} {chamber:<8} {:<13.2}",
            name.as_str(),
            c.axial_force_kn,
            c.loaded_chamber_pressure_bar
        );
        if let Some(measured) = case.measured.map(|m| m.get(name)) {
            let error = (measured - c.loaded_chamber_pressure_bar).abs() / measured.abs() * 100.0;
            let _ = write!(text, " {measured:<13.2} {error:.2}");
        }
        text.push('\n');
    }
    let _ = writeln!(
        text,
        "\npin                 force on       from           Y kN      Z kN      |F| kN"
    );
    for (hinge, force) in acq_twins::excavator::statics::HINGES
        .iter()
        .zip(&evaluation.reactions.hinge_force_n)
    {
        let from = hinge.from.map_or("base".to_string(), |body| body.label());
        let _ = writeln!(
            text,
            "{:<19} {:<14} {:<14} {:<9.2} {:<9.2} {:.2}",
            hinge.pin.label(),
            hinge.on.label(),
            from,
            force.x * 1e-3,
            force.y * 1e-3,
            force.norm() * 1e-3
        );
    }
    let _ = writeln!(
        text,
        "\npoint  axial kN   moment kN m  stress MPa  (tension +; moment + compresses the top)"
    );
    for g in &evaluation.gauges {
        let _ = writeln!(
            text,
            "{:<6} {:<10.2} {:<12.3} {:.2}",
            g.point, g.axial_force_kn, g.bending_moment_knm, g.stress_mpa
        );
    }
    let yield_mpa = twin.geometry().material.yield_strength_mpa;
    let _ = writeln!(
        text,
        "\nmax von Mises: boom {:.2} MPa, arm {:.2} MPa (yield {yield_mpa} MPa)",
        evaluation.boom.max_von_mises_mpa, evaluation.arm.max_von_mises_mpa
    );
    text
}

pub fn run_sensitivity(command: SensitivityCommand) -> Result<()> {
    let SensitivityCommand::Excavator(args) = command;
    let (case, twin) = load_model(&args.model)?;
    let factors: Vec<Factor> = UncertainInput::ALL
        .iter()
        .map(|&input| Factor {
            name: input.name().into(),
            unit: input.unit().into(),
            bounds: case.bounds.get(input),
            nominal: case.bounds.nominal(input),
        })
        .collect();
    let mut responses: Vec<Response> = CylinderName::ALL
        .iter()
        .map(|name| Response {
            name: format!("{name}_pressure"),
            unit: "bar".into(),
        })
        .collect();
    responses.push(Response {
        name: "boom_max_von_mises".into(),
        unit: "MPa".into(),
    });
    responses.push(Response {
        name: "arm_max_von_mises".into(),
        unit: "MPa".into(),
    });
    for gauge in &twin.geometry().gauges {
        responses.push(Response {
            name: format!("gauge{:02}_stress", gauge.point),
            unit: "MPa".into(),
        });
    }
    let nominal = case.nominal();
    let sweep = one_at_a_time(&factors, &responses, args.points as usize, |values| {
        let mut inputs = nominal;
        for (input, &value) in UncertainInput::ALL.iter().zip(values) {
            input.apply(&mut inputs, value);
        }
        let evaluation = twin.evaluate(&inputs).map_err(|e| e.to_string())?;
        let mut outputs: Vec<f64> = CylinderName::ALL
            .iter()
            .map(|&name| evaluation.cylinder(name).loaded_chamber_pressure_bar)
            .collect();
        outputs.push(evaluation.boom.max_von_mises_mpa);
        outputs.push(evaluation.arm.max_von_mises_mpa);
        outputs.extend(evaluation.gauges.iter().map(|g| g.stress_mpa));
        Ok(outputs)
    });

    let csv_path = args
        .output
        .unwrap_or_else(|| PathBuf::from(format!("{}-sensitivity.csv", case.name)));
    let svg_path = args.svg.unwrap_or_else(|| csv_path.with_extension("svg"));
    Output::write_complete(&csv_path, sweep.to_csv().as_bytes())?;
    let measured = case.measured;
    let charts = sweep.charts(&[0, 1, 2, 3, 4], |r| {
        let name = *CylinderName::ALL.get(r)?;
        measured.map(|m| (m.get(name), format!("measured {} bar", m.get(name))))
    });
    let title = format!(
        "{}: one-at-a-time sensitivity ({} values per input, others nominal)",
        case.name, args.points
    );
    Output::write_complete(
        &svg_path,
        grid_svg(&title, &charts, 3, 420.0, 300.0).as_bytes(),
    )?;

    // The swing of each headline output over each input's range.
    let swings = sweep.swings();
    println!(
        "{}: output swing (max - min) as each input crosses its bounds, others nominal",
        case.name
    );
    print!("{:<18}", "input");
    for response in &responses[..5] {
        print!(" {:>22}", format!("{} {}", response.name, response.unit));
    }
    println!();
    for (factor, row) in factors.iter().zip(&swings) {
        print!("{:<18}", factor.name);
        for swing in &row[..5] {
            match swing {
                Some(value) => print!(" {value:>22.3}"),
                None => print!(" {:>22}", "failed"),
            }
        }
        println!();
    }
    let failed = sweep.failed_runs();
    if failed > 0 {
        eprintln!(
            "acq: {failed} of {} runs failed; their reasons are in {}",
            sweep.runs.len(),
            csv_path.display()
        );
    }
    eprintln!(
        "acq: wrote {} and {}",
        csv_path.display(),
        svg_path.display()
    );
    Ok(())
}
