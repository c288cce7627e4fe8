//! `acq calibrate excavator`: the published workflow for the excavator twin.
//!
//! 1. The twin at the case's nominal inputs (the initial errors), 40 maximin
//!    Latin-hypercube training runs and 40 random test runs over the case's
//!    bounds, all logged in `evaluations.csv`.
//! 2. One GP per cylinder pressure (squared-exponential, one length scale per
//!    input), and for comparison polynomials of degree 1-3 and a radial
//!    basis function interpolant; each scored by its RMSE on the test runs.
//! 3. NSGA-II on the GP means over the three relative errors
//!    `|measured - model| / |measured|` (population 400, 100 generations,
//!    Pareto fraction 0.5).
//! 4. One point of the front is picked (equal weights by default, every
//!    error a cost) and the twin re-run there; the real errors are reported.
//!    The default pick is minimax, the point whose largest error is least,
//!    since a calibration is judged by its worst pressure. The published
//!    TOPSIS (`--pick topsis`) normalises each error by its own spread over
//!    the front: the boom pressure moves about 12 bar per degree of load
//!    angle, its error spreads over 0-50 %, so TOPSIS counts a point of it
//!    about five times less than one of the arm's and settles on 19 % boom
//!    error in Case 1 (5.9 % with minimax).

use std::path::{Path, PathBuf};

use acq_algorithms::evaluation::{Parameter, Simulator};
use acq_algorithms::gp::Kernel;
use acq_analysis::extract::measured::{read_measured, UncertaintyBasis};
use acq_error::{AcqError, Result};
use acq_report::document::{Document, Table};
use acq_twins::excavator::case::{CaseFile, MeasuredPressures, UncertainInput};
use acq_twins::excavator::geometry::GeometryTemplate;
use acq_twins::excavator::CylinderName;
use serde_json::{json, Map, Value};

use super::builtin::ExcavatorModel;
use acq_study::extras::{Extras, Section};
use acq_study::method::{Method, RunSettings};
use acq_study::outcome::{Found, StudyOutcome};
use acq_study::posterior::{Discrepancy, PosteriorSettings};
use acq_study::run_directory::{default_parallelism, RunDirectory};
use acq_study::simulator::StudySimulator;
use acq_study::study::{
    Case, LossKind, Measured, Observation, Residuals, Role, SharedError, Study, StudyParameter,
};
use acq_study::study_runner::run_study;
use acq_study::surrogate_moo::{Pick, SurrogateMoo, SurrogateMooSettings};

/// The settings of `acq calibrate excavator`; [`CalibrateExcavatorOptions::published`]
/// gives the published workflow's.
#[derive(Clone, Debug)]
pub struct CalibrateExcavatorOptions {
    /// Case file (TOML) with bounds and measured pressures.
    pub case: PathBuf,
    /// Measured values from `acq extract`: the loaded-chamber pressures
    /// (`<cylinder>_loaded_pressure`) replace the case's `[measured]`, and
    /// the load (`load_quantity`) replaces its force.
    pub measured: Option<PathBuf>,
    /// The hold to use from the measured file; `None` takes its only one.
    pub window: Option<String>,
    /// The measured quantity that is the force at the bucket tip (kN).
    pub load_quantity: String,
    /// Which uncertainty of the measured pressures the study takes: their
    /// budget (the transducers' accuracy with the readings' scatter) or
    /// the scatter alone.
    pub measurement_error: UncertaintyBasis,
    /// Geometry file; `None` is the built-in DX55-class one.
    pub geometry: Option<PathBuf>,
    /// Run directory: evaluations.csv, summary.json, report.md, plots.
    pub out: PathBuf,
    /// Latin-hypercube training runs of the twin.
    pub training_runs: u32,
    /// Random test runs for the surrogate comparison.
    pub test_runs: u32,
    /// NSGA-II population and generations.
    pub population: u32,
    pub generations: u32,
    /// Largest share of the population on the first front, in (0, 1].
    pub pareto_fraction: f64,
    /// Weights of the bucket, arm and boom errors in the pick.
    pub weights: Vec<f64>,
    /// How one point of the Pareto front is picked.
    pub pick: Pick,
    pub kernel: Kernel,
    /// Seed of the designs, the GP fits and NSGA-II.
    pub seed: u64,
    /// Continue the run in `out`: evaluations already in its log are not repeated.
    pub resume: bool,
    /// Twin evaluations at once; `None` is the number of cores.
    pub parallel: Option<usize>,
    /// After the search, the posterior of the inputs with this model error
    /// and this many kept draws per chain.
    pub posterior: Option<ExcavatorPosterior>,
}

/// The posterior `acq calibrate excavator` samples after its search.
#[derive(Clone, Copy, Debug)]
pub struct ExcavatorPosterior {
    pub discrepancy: Discrepancy,
    /// Kept draws per chain (4 chains).
    pub draws_per_chain: usize,
}

impl ExcavatorPosterior {
    /// Kept draws per chain unless told otherwise.
    pub const DRAWS_PER_CHAIN: usize = 1000;
}

impl CalibrateExcavatorOptions {
    /// The published workflow (Latin-hypercube training runs, GP per
    /// pressure, NSGA-II, minimax pick) on `case` into `out`.
    pub fn published(case: &Path, out: &Path) -> Self {
        CalibrateExcavatorOptions {
            case: case.to_path_buf(),
            measured: None,
            window: None,
            load_quantity: "tip_force".into(),
            measurement_error: UncertaintyBasis::Budget,
            geometry: None,
            out: out.to_path_buf(),
            training_runs: 40,
            test_runs: 40,
            population: 400,
            generations: 100,
            pareto_fraction: 0.5,
            weights: vec![1.0; 3],
            pick: Pick::Minimax,
            kernel: Kernel::SquaredExponential,
            seed: 1,
            resume: false,
            parallel: None,
            posterior: None,
        }
    }
}

/// The calibrated load magnitude's name, when the case bounds it.
const FORCE_PARAMETER: &str = "force_kN";

/// A case file as a study of the built-in twin: the uncertain inputs (and
/// the load, when bounded) as parameters with the bounds' middles (the
/// case's force) as nominal, and the three loaded-chamber pressures
/// (`<cylinder>_pressure_bar`) as the observations of one fit case, with
/// their standard uncertainties where known, each with the parts its
/// transducers share (in [`CylinderName::ALL`]'s order).
pub fn case_study(
    case: &CaseFile,
    measured: &MeasuredPressures,
    uncertainties_bar: [Option<(f64, Vec<SharedError>)>; 3],
) -> Study {
    let mut parameters: Vec<StudyParameter> = UncertainInput::ALL
        .iter()
        .map(|&input| {
            let [lower, upper] = case.bounds.get(input);
            let search = Parameter::new(input.name(), lower, upper);
            StudyParameter {
                input: input.name().to_string(),
                case: None,
                nominal: search.midpoint(),
                prior: None,
                search,
            }
        })
        .collect();
    let mut inputs = Vec::new();
    match case.bounds.force_kn {
        Some([lower, upper]) => parameters.push(StudyParameter {
            search: Parameter::new(FORCE_PARAMETER, lower, upper),
            input: FORCE_PARAMETER.to_string(),
            case: None,
            nominal: case.force_kn,
            prior: None,
        }),
        None => inputs.push((FORCE_PARAMETER.to_string(), case.force_kn)),
    }
    Study {
        parameters,
        cases: vec![Case {
            name: case.name.clone(),
            role: Role::Fit,
            priors: false,
            inputs,
            observations: CylinderName::ALL
                .iter()
                .zip(uncertainties_bar)
                .map(|(&cylinder, uncertainty)| Observation {
                    // The log's column names of earlier versions.
                    name: format!("{cylinder}_pressure_bar"),
                    output: format!("pressure_bar.{cylinder}"),
                    measured: Measured::Scalar {
                        value: measured.get(cylinder),
                        uncertainty: uncertainty.as_ref().map(|(u, _)| *u),
                    },
                    weight: 1.0,
                    source: format!("measured {cylinder} pressure"),
                    shared: uncertainty.map(|(_, shared)| shared).unwrap_or_default(),
                })
                .collect(),
        }],
        named_cases: false,
        residuals: Residuals::Relative,
        // The progress line shows the largest pressure error.
        loss: LossKind::Max,
    }
}

/// Refuses a study that cannot work, before any model run and before its
/// run directory exists: measured pressures that are not finite positive
/// numbers (errors are relative to them), a calibrated input without a
/// range, and bounds the twin cannot be evaluated at (every corner of the
/// box is tried: a stroke beyond its cylinder's range fails there).
fn check_before_the_first_run(
    case_path: &std::path::Path,
    measured: &MeasuredPressures,
    simulator: &StudySimulator<'_>,
) -> Result<()> {
    let problem = |what: String| AcqError::Config(format!("{}: {what}", case_path.display()));
    for name in CylinderName::ALL {
        let pressure = measured.get(name);
        if !(pressure.is_finite() && pressure > 0.0) {
            return Err(problem(format!(
                "the measured {name} pressure is {pressure} bar; give the loaded chamber's pressure, a finite number above 0 (errors are relative to it)"
            )));
        }
    }
    let parameters = simulator.parameters();
    acq_algorithms::evaluation::validate_parameters(parameters)
        .map_err(|e| problem(format!("bounds: {e}")))?;
    for corner in 0..1usize << parameters.len() {
        let values: Vec<f64> = parameters
            .iter()
            .enumerate()
            .map(|(i, p)| {
                if corner >> i & 1 == 1 {
                    p.upper
                } else {
                    p.lower
                }
            })
            .collect();
        if let Err(reason) = simulator.evaluate(&values) {
            let at: Vec<String> = parameters
                .iter()
                .zip(&values)
                .map(|(p, v)| format!("{} = {v}", p.name))
                .collect();
            return Err(problem(format!(
                "the twin cannot be evaluated at a corner of the bounds ({}): {reason}; narrow the bounds",
                at.join(", ")
            )));
        }
    }
    Ok(())
}

/// `|measured - model| / |measured|` in %, per cylinder.
fn relative_errors_pct(measured: &MeasuredPressures, model_bar: &[f64]) -> Vec<f64> {
    CylinderName::ALL
        .iter()
        .zip(model_bar)
        .map(|(&name, &model)| {
            let m = measured.get(name);
            100.0 * (m - model).abs() / m.abs()
        })
        .collect()
}

/// What the calibration found, besides the files it wrote.
#[derive(Clone, Debug)]
pub struct ExcavatorCalibration {
    pub case: String,
    /// The tip force the twin was loaded with, and where it came from.
    pub force_kn: f64,
    pub force_source: String,
    /// Per cylinder (bucket, arm, boom), bar and %.
    pub measured_bar: Vec<f64>,
    pub nominal_bar: Vec<f64>,
    pub calibrated_bar: Vec<f64>,
    pub errors_initial_pct: Vec<f64>,
    pub errors_optimal_pct: Vec<f64>,
    /// The calibrated inputs, named with their units.
    pub optimal: Vec<(String, f64)>,
    pub evaluations: usize,
    pub wall_s: f64,
    /// The report (also written as report.md and report.html).
    pub report: Document,
}

/// The measured pressures and load of one hold of a measured-values file.
struct MeasuredHold {
    window: String,
    pressures: MeasuredPressures,
    /// Each pressure's standard uncertainty with its shared parts, in the
    /// order of [`CylinderName::ALL`].
    uncertainties_bar: [Option<(f64, Vec<SharedError>)>; 3],
    force_kn: Option<f64>,
}

fn measured_hold(
    path: &Path,
    window: Option<&str>,
    load_quantity: &str,
    basis: UncertaintyBasis,
) -> Result<MeasuredHold> {
    let values = read_measured(path)?;
    let mut windows: Vec<&str> = values.iter().map(|v| v.window.as_str()).collect();
    windows.dedup();
    let window = match window {
        Some(w) if windows.contains(&w) => w.to_string(),
        Some(w) => {
            return Err(AcqError::Config(format!(
                "{}: no window '{w}'; it has {}",
                path.display(),
                windows.join(", ")
            )))
        }
        None if windows.len() == 1 => windows[0].to_string(),
        None => {
            return Err(AcqError::Config(format!(
                "{}: {} windows ({}); choose one with --window",
                path.display(),
                windows.len(),
                windows.join(", ")
            )))
        }
    };
    type WithUncertainty = (f64, Option<(f64, Vec<SharedError>)>);
    let mean = |quantity: &str, unit: &str| -> Result<Option<WithUncertainty>> {
        let Some(value) = values
            .iter()
            .find(|v| v.window == window && v.quantity == quantity)
        else {
            return Ok(None);
        };
        if value.unit != unit {
            return Err(AcqError::Config(format!(
                "{}: {quantity} is in {}, expected {unit}",
                path.display(),
                value.unit
            )));
        }
        if !value.is_usable() {
            return Err(AcqError::Config(format!(
                "{}: {quantity} in {window} is not fit to calibrate against (flags '{}': {}); \
                 fix the channel or give the value in the case file instead",
                path.display(),
                value.flags.join(";"),
                value.note
            )));
        }
        Ok(value
            .stats
            .mean
            .map(|m| (m, value.standard_uncertainty(basis))))
    };
    let pressure = |cylinder: CylinderName| -> Result<WithUncertainty> {
        let quantity = format!("{cylinder}_loaded_pressure");
        mean(&quantity, "bar")?.ok_or_else(|| {
            AcqError::Config(format!(
                "{}: no {quantity} in {window}; the rig needs a [[cylinder]] named {cylinder} \
                 with its head and rod pressure sensors",
                path.display()
            ))
        })
    };
    let [bucket, arm, boom] = CylinderName::ALL.map(pressure);
    let (bucket, arm, boom) = (bucket?, arm?, boom?);
    Ok(MeasuredHold {
        pressures: MeasuredPressures {
            bucket_bar: bucket.0,
            arm_bar: arm.0,
            boom_bar: boom.0,
        },
        uncertainties_bar: [bucket.1, arm.1, boom.1],
        force_kn: mean(load_quantity, "kN")?.map(|(m, _)| m),
        window,
    })
}

/// How far a measured load may lie from the case's stated force and still
/// be its load case: a tenth (a load case is set by its load; the same
/// load held again agrees within a few per cent).
const SAME_LOAD_CASE_FRACTION: f64 = 0.1;

/// Measured values of another load case are refused before any run: the
/// measured load (`force_kn`) more than [`SAME_LOAD_CASE_FRACTION`] from the
/// case's `force_kN`, or outside its bounds where the case calibrates it.
fn check_same_load_case(
    case_path: &Path,
    case: &CaseFile,
    force_kn: f64,
    measured_source: &str,
    args: &CalibrateExcavatorOptions,
) -> Result<()> {
    let stated = match case.bounds.force_kn {
        Some([lower, upper]) if (lower..=upper).contains(&force_kn) => return Ok(()),
        Some([lower, upper]) => format!("bounds its force_kN to [{lower}, {upper}] kN"),
        None if (force_kn - case.force_kn).abs()
            <= SAME_LOAD_CASE_FRACTION * case.force_kn.abs() =>
        {
            return Ok(())
        }
        None => format!(
            "states force_kN = {} kN ({:.0} % apart)",
            case.force_kn,
            100.0 * (force_kn - case.force_kn).abs() / case.force_kn.abs().max(f64::MIN_POSITIVE)
        ),
    };
    Err(AcqError::Config(format!(
        "{measured_source}: the load {} is {force_kn:.2} kN, but the case file {} ('{}') {stated}: \
         the measured values look like another load case's. Give the case file of the hold that \
         was measured (or correct the case's force_kN to the load applied)",
        args.load_quantity,
        case_path.display(),
        case.name,
    )))
}

/// The search's settings checked before any run: three usable weights,
/// the run counts in their ranges, a Pareto fraction in (0, 1].
fn check_search_settings(args: &CalibrateExcavatorOptions) -> Result<()> {
    if args.weights.len() != 3
        || args.weights.iter().any(|w| !(w.is_finite() && *w >= 0.0))
        || args.weights.iter().sum::<f64>() <= 0.0
    {
        let given: Vec<String> = args.weights.iter().map(f64::to_string).collect();
        return Err(AcqError::Config(format!(
            "--weights {}: give three weights (bucket, arm, boom) that are non-negative and not all zero, e.g. --weights 1 1 2",
            given.join(" ")
        )));
    }
    super::check_counts(&[
        ("--training", args.training_runs, 5..=100_000),
        ("--test-runs", args.test_runs, 1..=100_000),
        ("--population", args.population, 4..=1_000_000),
    ])?;
    if !(args.pareto_fraction > 0.0 && args.pareto_fraction <= 1.0) {
        return Err(AcqError::Config(
            "--pareto-fraction must lie in (0, 1]".into(),
        ));
    }
    Ok(())
}

pub fn run(args: CalibrateExcavatorOptions) -> Result<ExcavatorCalibration> {
    let mut case = CaseFile::load(&args.case).map_err(AcqError::Config)?;
    acq_io::input::note_input(&args.case);
    let mut force_source = format!("case file {}", args.case.display());
    let mut measured_source = force_source.clone();
    let mut uncertainties_bar = [None, None, None];
    if let Some(path) = &args.measured {
        let hold = measured_hold(
            path,
            args.window.as_deref(),
            &args.load_quantity,
            args.measurement_error,
        )?;
        measured_source = format!("{} ({})", path.display(), hold.window);
        case.measured = Some(hold.pressures);
        uncertainties_bar = hold.uncertainties_bar;
        match hold.force_kn {
            Some(force) if force > 0.0 => {
                check_same_load_case(&args.case, &case, force, &measured_source, &args)?;
                case.force_kn = force;
                force_source = format!("{} mean in {measured_source}", args.load_quantity);
            }
            _ => eprintln!(
                "acq: {} has no usable positive {}; the case's force {} kN is used",
                path.display(),
                args.load_quantity,
                case.force_kn
            ),
        }
    }
    let measured = case.measured.ok_or_else(|| {
        AcqError::Config(format!(
            "{}: the case has no [measured] pressures (bucket_bar, arm_bar, boom_bar) to calibrate against",
            args.case.display()
        ))
    })?;
    check_search_settings(&args)?;
    let template = match &args.geometry {
        Some(path) => {
            let text = acq_io::input::read_text(path).map_err(|e| AcqError::open(path, e))?;
            GeometryTemplate::parse(&text)
                .map_err(|e| AcqError::Config(format!("{}: {e}", path.display())))?
        }
        None => GeometryTemplate::dx55(),
    };
    // No geometry number is calibrated here, so nothing is re-fitted.
    let model = ExcavatorModel::new(template, false).map_err(AcqError::Config)?;
    let study = case_study(&case, &measured, uncertainties_bar);
    check_before_the_first_run(
        &args.case,
        &measured,
        &StudySimulator::new(&study, &model, Role::Fit),
    )?;
    let directory = RunDirectory::create(&args.out)?;
    let method = Method::SurrogateMoo(SurrogateMooSettings {
        training_runs: args.training_runs as usize,
        test_runs: args.test_runs as usize,
        population: args.population as usize,
        generations: args.generations as usize,
        pareto_fraction: args.pareto_fraction,
        weights: args.weights.clone(),
        pick: args.pick,
        kernel: args.kernel,
        ..SurrogateMooSettings::published(CylinderName::ALL.len(), args.seed)
    });
    let extras = ExcavatorExtras {
        case: case.name.clone(),
        pick: args.pick,
        weights: args.weights.clone(),
        force_kn: case.force_kn,
        force_source: force_source.clone(),
        measured_source,
        measured,
        out: args.out.clone(),
    };
    let run = run_study(
        &study,
        &model,
        &method,
        Vec::new(),
        &directory,
        &RunSettings {
            label: format!("calibrate {}", case.name),
            title: args.case.display().to_string(),
            spec_directory: Path::new("."),
            parallel: args.parallel.unwrap_or_else(default_parallelism),
            resume: args.resume,
            progress: None,
            posterior: args.posterior.map(|posterior| PosteriorSettings {
                discrepancy: posterior.discrepancy,
                draws: posterior.draws_per_chain,
                seed: args.seed,
                ..PosteriorSettings::default()
            }),
        },
        &extras,
    )?;
    let moo = surrogate_moo_of(&run.outcome);
    Ok(ExcavatorCalibration {
        case: case.name.clone(),
        force_kn: case.force_kn,
        force_source,
        measured_bar: CylinderName::ALL.iter().map(|c| measured.get(*c)).collect(),
        nominal_bar: moo.nominal_outputs.clone(),
        calibrated_bar: moo.optimal_outputs.clone(),
        errors_initial_pct: relative_errors_pct(&measured, &moo.nominal_outputs),
        errors_optimal_pct: relative_errors_pct(&measured, &moo.optimal_outputs),
        optimal: run.outcome.calibrated_by_name(&study),
        evaluations: run.outcome.evaluations.len(),
        wall_s: run.outcome.wall_s,
        report: run.report,
    })
}

/// What the preset's surrogate-MOO search found.
fn surrogate_moo_of(outcome: &StudyOutcome) -> &SurrogateMoo {
    match &outcome.found {
        Found::Moo(moo) => moo,
        Found::Bo(_) | Found::MultiFidelity(_) | Found::LeastSquares(_) => {
            unreachable!("the excavator preset runs surrogate-moo")
        }
    }
}

/// What the excavator preset shows besides every study's report: where
/// the measured pressures and the load came from, the published pressure
/// table, and its summary's names (errors and RMSE per cylinder).
struct ExcavatorExtras {
    case: String,
    /// How the front point was picked, and the weights, for the report.
    pick: Pick,
    weights: Vec<f64>,
    force_kn: f64,
    force_source: String,
    measured_source: String,
    measured: MeasuredPressures,
    out: PathBuf,
}

impl Extras for ExcavatorExtras {
    /// The published report's names: the inputs with the pick, RMSEs in bar.
    fn heading(&self, section: Section, common: String) -> String {
        match section {
            Section::Parameters => format!(
                "Calibrated inputs ({} pick, weights {:?})",
                self.pick, self.weights
            ),
            Section::Surrogates => format!("{common} [bar]"),
            Section::Candidates => common,
        }
    }

    fn title(&self, _settings: &RunSettings<'_>) -> (String, String) {
        (
            format!("Calibration of the excavator twin: {}", self.case),
            format!("Excavator calibration {}", self.case),
        )
    }

    fn sections(
        &self,
        _study: &Study,
        outcome: &StudyOutcome,
        report: &mut Document,
    ) -> Result<()> {
        let moo = surrogate_moo_of(outcome);
        let errors_initial = relative_errors_pct(&self.measured, &moo.nominal_outputs);
        let errors_optimal = relative_errors_pct(&self.measured, &moo.optimal_outputs);
        report
            .paragraph(format!(
                "Run directory `{}`. Measured pressures from {}; tip force {:.2} kN from {}.",
                self.out.display(),
                self.measured_source,
                self.force_kn,
                self.force_source,
            ))
            .heading(2, "Pressures");
        let mut table = Table::new(&[
            "cylinder",
            "measured [bar]",
            "model at nominal [bar]",
            "model at calibrated [bar]",
            "GP at calibrated [bar]",
            "error nominal [%]",
            "error calibrated [%]",
        ]);
        for (k, name) in CylinderName::ALL.iter().enumerate() {
            table.row(vec![
                name.to_string(),
                format!("{:.2}", self.measured.get(*name)),
                format!("{:.2}", moo.nominal_outputs[k]),
                format!("{:.2}", moo.optimal_outputs[k]),
                format!("{:.2}", moo.surrogate_at_optimal[k]),
                format!("{:.2}", errors_initial[k]),
                format!("{:.2}", errors_optimal[k]),
            ]);
        }
        report.table(table).paragraph(format!(
            "Largest error: {:.2} % at nominal, {:.2} % calibrated.",
            largest(&errors_initial),
            largest(&errors_optimal),
        ));
        Ok(())
    }

    /// The published summary: errors and RMSEs by cylinder, the
    /// calibrated inputs, the run count.
    fn summary(
        &self,
        _study: &Study,
        outcome: &StudyOutcome,
        common: Map<String, Value>,
    ) -> Map<String, Value> {
        let moo = surrogate_moo_of(outcome);
        let per_cylinder = |values: &[f64]| -> Value {
            json!({"bucket": values[0], "arm": values[1], "boom": values[2]})
        };
        let rmse: Map<String, Value> = moo
            .surrogate_rmse
            .iter()
            .map(|(name, row)| (name.clone(), per_cylinder(row)))
            .collect();
        let mut summary = Map::new();
        summary.insert(
            "errors_initial_pct".into(),
            per_cylinder(&relative_errors_pct(&self.measured, &moo.nominal_outputs)),
        );
        summary.insert(
            "errors_optimal_pct".into(),
            per_cylinder(&relative_errors_pct(&self.measured, &moo.optimal_outputs)),
        );
        summary.insert("surrogate_rmse_bar".into(), Value::Object(rmse));
        for key in ["optimal", "evaluations"] {
            summary.insert(key.into(), common[key].clone());
        }
        summary
    }

    fn closing_line(&self, _study: &Study, outcome: &StudyOutcome) -> Option<String> {
        let moo = surrogate_moo_of(outcome);
        Some(format!(
            "{}: largest error {:.2} % -> {:.2} % at the search's pick ({})",
            self.case,
            largest(&relative_errors_pct(&self.measured, &moo.nominal_outputs)),
            largest(&relative_errors_pct(&self.measured, &moo.optimal_outputs)),
            acq_report::number::count(outcome.evaluations.len(), "twin run"),
        ))
    }
}

fn largest(errors: &[f64]) -> f64 {
    errors.iter().fold(0.0f64, |a, &b| a.max(b))
}
