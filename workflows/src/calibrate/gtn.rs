//! `acq calibrate gtn`: the GTN parameters of a tensile test.
//!
//! The flow curve and E come from the test ([`crate::tensile_model`]); the
//! eight GTN parameters are searched in the published bounds (m up to the
//! test's own bound) by Bayesian optimisation of the curve MAPE, starting
//! from the published 12-run two-level orthogonal array. The parameters are
//! scaled to the unit box and the MAPE is minimised (the published code did
//! neither). The run stops at the target MAPE or the evaluation budget.

use std::path::{Path, PathBuf};

use acq_algorithms::bo::Acquisition;
use acq_algorithms::evaluation::Parameter;
use acq_analysis::extract::tensile_props::{
    read_test_csv, tensile_properties, SpecimenGeometry, TestPoint,
};
use acq_analysis::loss::curve::{curve_mape, CurveMapeOptions, SplitMape};
use acq_analysis::loss::metrics::CurveMetric;
use acq_error::{AcqError, Result};
use acq_report::document::Document;
use serde_json::{json, Map, Value};

use super::builtin::{GtnModel, GTN_CURVE};
use crate::abaqus_material::abaqus_material_block;
use crate::tensile_model::{GtnInputs, MeshOptions, ModelSettings, TensileModel, PARAMETER_NAMES};
use acq_study::extras::{Extras, Section};
use acq_study::method::{start_design, BoMethod, Method, MultiFidelityMethod, RunSettings};
use acq_study::outcome::{Found, StudyOutcome};
use acq_study::posterior::PosteriorSettings;
use acq_study::run_directory::{write_text, RunDirectory};
use acq_study::study::{
    Case, LossKind, Measured, Observation, Residuals, Role, Study, StudyParameter,
};
use acq_study::study_runner::run_study;

/// The settings of `acq calibrate gtn`; [`CalibrateGtnOptions::new`]
/// gives the command's defaults.
#[derive(Clone, Debug)]
pub struct CalibrateGtnOptions {
    /// Test CSV with DISPLACEMENT [mm] and FORCE [kN] columns.
    pub test: PathBuf,
    /// Run directory: evaluations.csv, summary.json, report.md, curve and plots.
    pub out: PathBuf,
    /// Largest number of simulations (the L12 start included), 13 to 100,000.
    pub max_evals: u32,
    /// Stop once the MAPE is at or below this, %.
    pub target_mape_pct: f64,
    /// Simulations proposed (and run in parallel) per iteration, 1 to 64.
    pub batch: u32,
    pub acquisition: Acquisition,
    /// Also stop when this many simulations in a row improved the best
    /// MAPE by less than 0.1 % (relative).
    pub patience: Option<u32>,
    pub mesh: MeshOptions,
    pub seed: u64,
    /// Global Bayesian-optimisation steps only (the published search),
    /// without the local Gauss-Newton steps on the curve's errors.
    pub global_only: bool,
    /// Local steps whose slopes are fitted to the runs made, not the
    /// twin's own (computed along with each run: fewer runs, each dearer).
    pub fitted_slopes: bool,
    /// With `batch` above 1: synchronous batches, so the result depends
    /// only on the test, the options and the seed.
    pub deterministic: bool,
    /// Continue the run in `out`: simulations already in its log are not repeated.
    pub resume: bool,
    /// After the search, the posterior of the eight parameters with this
    /// many kept draws per chain (4 chains).
    pub posterior_draws_per_chain: Option<usize>,
    /// Two levels: cheap runs at this element size (mm) beside the
    /// expensive ones at `mesh.element_mm`, searched together.
    pub cheap_element_mm: Option<f64>,
    /// With two levels, expensive runs at most (`max_evals` counts both).
    pub max_fine_runs: Option<u32>,
}

impl CalibrateGtnOptions {
    /// Kept posterior draws per chain unless told otherwise.
    pub const POSTERIOR_DRAWS_PER_CHAIN: usize = 1000;

    /// The command's defaults on `test` into `out`: up to 200 simulations
    /// to a MAPE of 2 %, one at a time, log expected improvement.
    pub fn new(test: &Path, out: &Path) -> Self {
        CalibrateGtnOptions {
            test: test.to_path_buf(),
            out: out.to_path_buf(),
            max_evals: 200,
            target_mape_pct: 2.0,
            batch: 1,
            acquisition: Acquisition::LogExpectedImprovement { xi: 0.0 },
            patience: None,
            mesh: MeshOptions::default(),
            seed: 1,
            global_only: false,
            fitted_slopes: false,
            deterministic: false,
            resume: false,
            posterior_draws_per_chain: None,
            cheap_element_mm: None,
            max_fine_runs: None,
        }
    }
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
                    axes: ["displacement [mm]".into(), "force [kN]".into()],
                    metric: CurveMetric::Mape,
                },
                weight: 1.0,
                source: "the test".into(),
                shared: Vec::new(),
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

pub fn run(args: CalibrateGtnOptions) -> Result<GtnCalibration> {
    super::check_counts(&[
        ("--max-evals", args.max_evals, 13..=100_000),
        ("--batch", args.batch, 1..=64),
    ])?;
    if !(args.target_mape_pct.is_finite() && args.target_mape_pct >= 0.0) {
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
    let model = GtnModel::new(model)
        .with_neck_zone_mm(args.mesh.neck_zone_mm)
        .with_own_slopes(!args.fitted_slopes);
    let method = gtn_method(&args)?;
    let directory = RunDirectory::create(&args.out)?;
    let settings = RunSettings {
        label: "calibrate gtn".into(),
        title: args.test.display().to_string(),
        spec_directory: Path::new("."),
        parallel: args.batch as usize,
        resume: args.resume,
        progress: None,
        posterior: args
            .posterior_draws_per_chain
            .map(|draws| PosteriorSettings {
                // A simulation takes about a second: ten draws give the band.
                predictive_runs: 10,
                // A simulation takes under a second: more runs buy a closer
                // emulator cheaply.
                refinement_runs: 100,
                draws,
                seed: args.seed,
                ..PosteriorSettings::default()
            }),
    };
    let start_design = start_design(&parameters, &method, settings.spec_directory)?;
    let extras = GtnExtras {
        model: &model,
        test: args.test.clone(),
        target_mape: args.target_mape_pct,
    };
    let run = run_study(
        &study,
        &model,
        &method,
        start_design,
        &directory,
        &settings,
        &extras,
    )?;
    let outcome = &run.outcome;
    Ok(GtnCalibration {
        best_mape_pct: study.loss(&outcome.calibrated_outputs),
        best_split_pct: extras
            .split(outcome)
            .map(|s| (s.before_percent, s.after_percent)),
        best_params: outcome.calibrated_by_name(&study),
        evaluations: outcome.evaluations.len(),
        evaluations_to_target: evaluations_to_target(&outcome.found),
        wall_s: outcome.wall_s,
        report: run.report,
    })
}

/// Bayesian optimisation from the published L12 design; with a cheap
/// element size, the two-level search whose expensive start is the two
/// best points at the cheap level of the design and the middle of the box
/// (the local steps start from the better; without them, the design's
/// first six rows).
fn gtn_method(args: &CalibrateGtnOptions) -> Result<Method> {
    let Some(cheap_mm) = args.cheap_element_mm else {
        if args.max_fine_runs.is_some() {
            return Err(AcqError::Config(
                "--max-fine-runs bounds the fine runs of a two-level calibration: give --cheap-element-mm too".into(),
            ));
        }
        return Ok(Method::Bo(BoMethod {
            start: "l12".into(),
            start_runs: 12,
            max_evals: args.max_evals as usize,
            target_loss: Some(args.target_mape_pct),
            acquisition: Some(args.acquisition),
            patience: args.patience.map(|p| p as usize),
            batch: args.batch as usize,
            seed: args.seed,
            local_steps: !args.global_only,
            deterministic: args.deterministic,
        }));
    };
    let Some(fine_mm) = args.mesh.element_mm else {
        return Err(AcqError::Config(
            "--cheap-element-mm is the cheap level beside the fine one: give --element-mm, the size the parameters are for".into(),
        ));
    };
    if !(cheap_mm.is_finite() && cheap_mm > fine_mm) {
        return Err(AcqError::Config(format!(
            "--cheap-element-mm {cheap_mm} must be coarser (larger) than --element-mm {fine_mm}"
        )));
    }
    let max_evals = args.max_evals as usize;
    Ok(Method::MultiFidelity(MultiFidelityMethod {
        start: "l12".into(),
        start_runs: 12,
        // With local steps, the fewest co-kriging can fit: they start at
        // once from the better. Without, half the design for co-kriging.
        expensive_start_runs: if args.global_only { 6 } else { 2 },
        cheap_mesh: cheap_mm,
        expensive_mesh: fine_mm,
        max_evals,
        max_expensive: args.max_fine_runs.map_or(max_evals, |n| n as usize),
        target_loss: Some(args.target_mape_pct),
        seed: args.seed,
        local_steps: !args.global_only,
    }))
}

/// Runs made when the target was reached, by either search.
fn evaluations_to_target(found: &Found) -> Option<usize> {
    match found {
        Found::Bo(result) => result.evaluations_to_target,
        Found::MultiFidelity(mf) => mf.result.evaluations_to_target,
        Found::Moo(_) | Found::LeastSquares(_) => None,
    }
}

/// What the GTN preset adds: the MAPE before and after the maximum force,
/// the mesh the parameters belong to, the calibrated curve as CSV and the
/// material as an Abaqus block.
struct GtnExtras<'a> {
    model: &'a GtnModel,
    test: PathBuf,
    target_mape: f64,
}

impl GtnExtras<'_> {
    /// The calibrated curve (the study's one curve).
    fn curve<'o>(&self, outcome: &'o StudyOutcome) -> Option<&'o [(f64, f64)]> {
        outcome.curves.first()?.model.as_deref()
    }

    /// The calibrated curve's MAPE before and after the test's maximum force.
    fn split(&self, outcome: &StudyOutcome) -> Option<SplitMape> {
        let tensile = self.model.tensile_model();
        let test: Vec<(f64, f64)> = tensile
            .test
            .iter()
            .map(|p| (p.displacement_mm, p.force_kn))
            .collect();
        let options = CurveMapeOptions {
            split_at_mm: Some(tensile.properties.uts.displacement_mm),
            ..CurveMapeOptions::default()
        };
        curve_mape(&test, self.curve(outcome)?, options).ok()?.split
    }
}

impl Extras for GtnExtras<'_> {
    /// The published report's names.
    fn heading(&self, section: Section, common: String) -> String {
        match section {
            Section::Parameters => "Best parameters".into(),
            Section::Candidates => {
                "Not one answer: distinct parameter sets within 1.25 x best + 0.25 points of MAPE"
                    .into()
            }
            Section::Surrogates => common,
        }
    }

    fn title(&self, _settings: &RunSettings<'_>) -> (String, String) {
        (
            format!("GTN calibration of {}", self.test.display()),
            "GTN calibration".into(),
        )
    }

    fn sections(&self, study: &Study, outcome: &StudyOutcome, report: &mut Document) -> Result<()> {
        let to_target = evaluations_to_target(&outcome.found);
        let split = self.split(outcome);
        report
            .paragraph(format!(
                "Best MAPE {:.3} % (before the maximum force {:.3} %, after {:.3} %) after {} simulations; \
                 target {} % {}.",
                study.loss(&outcome.calibrated_outputs),
                split.map_or(f64::NAN, |s| s.before_percent),
                split.map_or(f64::NAN, |s| s.after_percent),
                outcome.evaluations.len(),
                self.target_mape,
                to_target
                    .map_or_else(|| "not reached".to_string(), |n| format!("reached at simulation {n}")),
            ))
            .paragraph(format!(
                "Mesh: {}. GTN softening depends on the element size at the neck: these parameters belong to it (`--element-mm`). For your own solver, the material is in `abaqus_material.inp` (Abaqus keywords; units N, mm, MPa).",
                self.model.tensile_model().settings.mesh_sentence()
            ));
        Ok(())
    }

    /// The published summary: the best MAPE and parameters, the run
    /// counts, the mesh they belong to.
    fn summary(
        &self,
        study: &Study,
        outcome: &StudyOutcome,
        common: Map<String, Value>,
    ) -> Map<String, Value> {
        let mut summary = Map::new();
        summary.insert(
            "best_mape".into(),
            json!(study.loss(&outcome.calibrated_outputs)),
        );
        summary.insert(
            "mesh".into(),
            self.model.tensile_model().settings.mesh_json(),
        );
        for key in [
            "best_params",
            "evaluations",
            "evaluations_to_target",
            "wall_s",
        ] {
            summary.insert(key.into(), common[key].clone());
        }
        if let Some(two_levels) = common.get("multi_fidelity") {
            summary.insert("multi_fidelity".into(), two_levels.clone());
        }
        summary
    }

    fn files(&self, study: &Study, outcome: &StudyOutcome, directory: &RunDirectory) -> Result<()> {
        let inputs = GtnInputs::from_values(&outcome.calibrated).map_err(AcqError::Config)?;
        // The material for the user's own solver, with the element size it belongs to.
        let tensile = self.model.tensile_model();
        let twin = tensile.twin(&inputs).map_err(AcqError::Config)?;
        let provenance = [
            format!(
                "GTN material calibrated by acq on {} (MAPE {:.3} %).",
                self.test.display(),
                study.loss(&outcome.calibrated_outputs)
            ),
            format!(
                "It belongs to this mesh: {}.",
                tensile.settings.mesh_sentence()
            ),
        ];
        write_text(
            &directory.file("abaqus_material.inp"),
            &abaqus_material_block("ACQ_GTN", &twin.material, &provenance),
        )?;
        let curve = self.curve(outcome).ok_or_else(|| {
            AcqError::Config("the GTN twin gave no curve at the calibrated parameters".into())
        })?;
        let mut text = String::from("DISPLACEMENT,FORCE\n");
        for (displacement_mm, force_kn) in curve {
            text.push_str(&format!("{displacement_mm},{force_kn}\n"));
        }
        write_text(&directory.file("curve.csv"), &text)
    }

    fn closing_line(&self, study: &Study, outcome: &StudyOutcome) -> Option<String> {
        let simulations = match &outcome.found {
            Found::MultiFidelity(mf) => format!(
                "{} fine simulations (and {} cheap ones at {} mm)",
                outcome.evaluations.len(),
                mf.result
                    .count(acq_algorithms::multi_fidelity::Fidelity::Cheap),
                mf.meshes[0]
            ),
            _ => acq_report::number::count(outcome.evaluations.len(), "simulation"),
        };
        Some(format!(
            "best MAPE {:.3} % after {simulations} ({:.1} s)",
            study.loss(&outcome.calibrated_outputs),
            outcome.wall_s,
        ))
    }
}
