//! `acq twin excavator` and `acq sensitivity excavator`: the excavator twin
//! at a case's inputs (pressures, gauge stresses, the working envelope), and
//! one-at-a-time sweeps of its uncertain inputs.

use std::path::PathBuf;

use acq_error::{AcqError, Result};
use acq_io::output::Output;
use acq_report::plot::grid_svg;
use acq_twins::excavator::case::{CaseFile, UncertainInput};
use acq_twins::excavator::envelope::working_envelope;
use acq_twins::excavator::geometry::Geometry;
use acq_twins::excavator::{CylinderName, Excavator};

use crate::excavator_report::{envelope_json, evaluation_json, evaluation_report};
use crate::sensitivity::{one_at_a_time, Factor, Response};

/// The twin a command runs: a case and the machine's geometry.
#[derive(Clone, Debug)]
pub struct ExcavatorModelOptions {
    /// Case file (TOML): tip force, bounds of the uncertain inputs
    /// (nominal = middle), optionally measured pressures and points.
    pub case: PathBuf,
    /// Geometry file; `None` is the built-in DX55-class data/excavator/dx55.toml.
    pub geometry: Option<PathBuf>,
}

/// One run of the twin at the case's nominal inputs, any of them set.
#[derive(Clone, Debug)]
pub struct TwinExcavatorOptions {
    pub model: ExcavatorModelOptions,
    /// Bucket, arm and boom cylinder strokes, mm (`None`: the case's nominal).
    pub bucket_stroke_mm: Option<f64>,
    pub arm_stroke_mm: Option<f64>,
    pub boom_stroke_mm: Option<f64>,
    /// Tip force, kN (`None`: the case's).
    pub force_kn: Option<f64>,
    /// Tip force direction, degrees from +Y (forward) toward +Z (up)
    /// (`None`: the case's nominal).
    pub angle_deg: Option<f64>,
    /// One JSON object on stdout instead of the tables.
    pub json: bool,
    /// Also the working envelope over the stroke ranges.
    pub envelope: bool,
}

/// A one-at-a-time sweep of the case's uncertain inputs.
#[derive(Clone, Debug)]
pub struct SensitivityExcavatorOptions {
    pub model: ExcavatorModelOptions,
    /// Values per input, bounds included (2 to 10,000).
    pub points: u32,
    /// The table (CSV); `None`: `<case name>-sensitivity.csv`.
    pub output: Option<PathBuf>,
    /// The plot; `None`: the table's name with .svg.
    pub svg: Option<PathBuf>,
}

/// The values per input of a sweep that acq accepts.
pub const SENSITIVITY_POINTS: std::ops::RangeInclusive<u32> = 2..=10_000;

fn load_model(args: &ExcavatorModelOptions) -> Result<(CaseFile, Excavator)> {
    let case = CaseFile::load(&args.case).map_err(AcqError::Config)?;
    acq_io::input::note_input(&args.case);
    let geometry = match &args.geometry {
        Some(path) => Geometry::load(path).map_err(AcqError::Config)?,
        None => Geometry::dx55(),
    };
    let twin = Excavator::new(geometry).map_err(|e| AcqError::Config(e.to_string()))?;
    Ok((case, twin))
}

/// The twin at a case's nominal inputs with the overrides of
/// [`TwinExcavatorOptions`]: its pressures, forces and gauge stresses as
/// `acq twin excavator --json` prints them (with the working envelope if
/// asked), and what the text report needs.
pub struct CaseRun {
    pub case: CaseFile,
    pub twin: Excavator,
    pub inputs: acq_twins::excavator::Inputs,
    pub evaluation: acq_twins::excavator::Evaluation,
    pub envelope: Option<acq_twins::excavator::envelope::WorkingEnvelope>,
}

impl CaseRun {
    pub fn json(&self) -> serde_json::Value {
        let mut json = evaluation_json(&self.evaluation);
        if let Some(envelope) = &self.envelope {
            json["envelope"] = envelope_json(envelope)["envelope"].take();
        }
        json
    }
}

pub fn run_case(args: &TwinExcavatorOptions) -> Result<CaseRun> {
    let (case, twin) = load_model(&args.model)?;
    let mut inputs = case.nominal();
    let overrides = [
        (UncertainInput::BucketStroke, args.bucket_stroke_mm),
        (UncertainInput::ArmStroke, args.arm_stroke_mm),
        (UncertainInput::BoomStroke, args.boom_stroke_mm),
        (UncertainInput::ForceAngle, args.angle_deg),
    ];
    for (input, value) in overrides {
        if let Some(value) = value {
            input.apply(&mut inputs, value);
        }
    }
    if let Some(force) = args.force_kn {
        inputs.tip_force_kn = force;
    }
    let evaluation = twin
        .evaluate(&inputs)
        .map_err(|e| AcqError::Config(format!("{}: {e}", case.name)))?;
    let envelope = if args.envelope {
        Some(working_envelope(twin.geometry()).map_err(|e| AcqError::Config(e.to_string()))?)
    } else {
        None
    };
    Ok(CaseRun {
        case,
        twin,
        inputs,
        evaluation,
        envelope,
    })
}

pub fn run_twin(args: TwinExcavatorOptions) -> Result<()> {
    let run = run_case(&args)?;
    let CaseRun {
        case,
        twin,
        inputs,
        evaluation,
        envelope,
    } = &run;
    if args.json {
        println!("{}", run.json());
    } else {
        print!("{}", evaluation_report(case, inputs, twin, evaluation));
        if let Some(e) = &envelope {
            let strokes = |s: &acq_twins::excavator::Strokes| {
                format!(
                    "bucket {:.0}, arm {:.0}, boom {:.0} mm",
                    s.bucket_mm, s.arm_mm, s.boom_mm
                )
            };
            println!("\nworking envelope (over the stroke ranges)");
            println!(
                "max reach from the swing axis   {:.3} m  at {}",
                e.max_reach_m,
                strokes(&e.reach_strokes)
            );
            println!(
                "max digging depth below ground  {:.3} m  at {}",
                e.max_digging_depth_m,
                strokes(&e.depth_strokes)
            );
            println!(
                "max dump height (bucket opened) {:.3} m  at {}",
                e.max_dump_height_m,
                strokes(&e.dump_strokes)
            );
        }
    }
    Ok(())
}

pub fn run_sensitivity(args: SensitivityExcavatorOptions) -> Result<()> {
    if !SENSITIVITY_POINTS.contains(&args.points) {
        return Err(AcqError::Config(format!(
            "a sweep takes {} to {} values per input, got {}",
            SENSITIVITY_POINTS.start(),
            SENSITIVITY_POINTS.end(),
            args.points
        )));
    }
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

    let csv_path = args.output.unwrap_or_else(|| {
        PathBuf::from(format!(
            "{}-sensitivity.csv",
            acq_io::output::file_name_part(&case.name)
        ))
    });
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
