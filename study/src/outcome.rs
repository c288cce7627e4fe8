//! What a study found: the method's own result, the calibrated point and
//! its errors, every evaluation, the identifiability analysis and the
//! calibrated curves. The runner makes it; the summary, the report and a
//! preset's extras read it.

use acq_algorithms::evaluation::{Evaluation, Parameter};
use acq_algorithms::least_squares::LeastSquaresResult;
use acq_metrology::grid_convergence::GridConvergence;

use super::identifiability::{local_verdict, Identifiability};
use super::posterior::report::posterior_verdict;
use super::posterior::PosteriorOutcome;
use super::study::{ObservationError, Study};
use super::verdict::{Evidence, ParameterVerdict};

/// What a study found.
pub struct StudyOutcome {
    pub found: Found,
    /// The calibrated point (search vector) and the fit outputs there.
    pub calibrated: Vec<f64>,
    pub calibrated_outputs: Vec<f64>,
    pub fit_errors: Vec<ObservationError>,
    pub validation_errors: Vec<ObservationError>,
    /// Every fit evaluation, from the log or run now.
    pub evaluations: Vec<Evaluation>,
    /// The same with each curve's signed errors in parts after the
    /// observations, when the search logged them (Bayesian optimisation
    /// with local steps); empty otherwise. The posterior's emulator of a
    /// curve learns from them.
    pub evaluations_with_curve_parts: Vec<Evaluation>,
    /// A two-level search's coarse runs, as the posterior's emulator
    /// learns from them (curve parts included when logged); empty
    /// otherwise.
    pub coarse_evaluations: Vec<Evaluation>,
    pub failed: usize,
    pub wall_s: f64,
    pub identifiability: Option<Identifiability>,
    /// The model's note columns (where each run happened), as logged.
    pub note_columns: Vec<String>,
    /// Each observed curve at the calibrated point, fit and validate cases.
    pub curves: Vec<CalibratedCurve>,
    /// The posterior stage's result, when the study asked for it.
    pub posterior: Option<PosteriorOutcome>,
}

impl StudyOutcome {
    /// Each search parameter's one verdict ([`crate::verdict`]), in the
    /// study's order.
    pub fn verdicts(&self, study: &Study) -> Vec<ParameterVerdict> {
        parameter_verdicts(
            &study.search_parameters(),
            &self.calibrated,
            self.identifiability.as_ref(),
            self.posterior.as_ref(),
        )
    }

    /// The calibrated parameters by name.
    pub fn calibrated_by_name(&self, study: &Study) -> Vec<(String, f64)> {
        study
            .parameters
            .iter()
            .map(|p| p.search.name.clone())
            .zip(self.calibrated.iter().copied())
            .collect()
    }
}

/// An observed curve and the calibrated model's.
#[derive(Clone, Debug)]
pub struct CalibratedCurve {
    pub case: String,
    pub name: String,
    pub measured: Vec<(f64, f64)>,
    /// The column names or quantities of x and y.
    pub axes: [String; 2],
    /// How the curve is scored.
    pub metric: acq_analysis::loss::metrics::CurveMetric,
    /// None when the model cannot give it again without a new run (a
    /// solver's run directory that is gone).
    pub model: Option<Vec<(f64, f64)>>,
}

/// What a method found.
pub enum Found {
    Bo(acq_algorithms::bo::BoResult),
    /// A two-level search: the outcome's evaluations are its expensive runs.
    MultiFidelity(Box<MultiFidelityFound>),
    Moo(Box<super::surrogate_moo::SurrogateMoo>),
    LeastSquares(Box<LeastSquaresFound>),
}

impl Found {
    pub fn gps(&self) -> Option<&[acq_algorithms::gp::Gp]> {
        match self {
            Found::Moo(moo) => Some(&moo.gps),
            Found::Bo(_) | Found::MultiFidelity(_) | Found::LeastSquares(_) => None,
        }
    }
}

/// What a two-level search found, and the levels' element sizes.
pub struct MultiFidelityFound {
    pub result: acq_algorithms::multi_fidelity::MultiFidelityResult,
    /// The `mesh` input of the cheap and the expensive level.
    pub meshes: [f64; 2],
}

impl MultiFidelityFound {
    /// What the search did, for `summary.json`.
    pub fn summary_json(&self) -> serde_json::Value {
        use acq_algorithms::multi_fidelity::Fidelity;
        let result = &self.result;
        serde_json::json!({
            "cheap_mesh": self.meshes[0],
            "expensive_mesh": self.meshes[1],
            "cheap_runs": result.count(Fidelity::Cheap),
            "expensive_runs": result.count(Fidelity::Expensive),
            "cheap_run_s": result.cost_s[0],
            "expensive_run_s": result.cost_s[1],
            "rho": result.rho,
            "stop": result.stop,
            "level_loss_difference": result.level_loss_difference(),
        })
    }
}

/// What a least-squares search found, and where it started.
pub struct LeastSquaresFound {
    pub result: LeastSquaresResult,
    /// The fit outputs at the nominal point (the search's start).
    pub nominal_outputs: Vec<f64>,
}

/// One output's study, with where its values came from.
#[derive(Clone, Debug)]
pub struct OutputConvergence {
    /// The output's key (`name`, or `case/name`).
    pub key: String,
    /// `None` where fewer than three sizes gave a value.
    pub convergence: Option<GridConvergence>,
    /// The sizes whose run failed.
    pub failed_sizes: Vec<f64>,
}

/// A curve at each size, compared part by part.
#[derive(Clone, Debug)]
pub struct CurveConvergence {
    /// The curve's key (`name`, or `case/name`).
    pub key: String,
    pub axes: [String; 2],
    /// (size, the model's curve at it).
    pub curves: Vec<(f64, Vec<(f64, f64)>)>,
    /// (x from, x to, the curve's mean there at each size): empty when
    /// fewer than three sizes gave the curve.
    pub parts: Vec<(f64, f64, OutputConvergence)>,
}

/// What a mesh study found.
#[derive(Clone, Debug)]
pub struct MeshStudyOutcome {
    pub outputs: Vec<OutputConvergence>,
    /// Each observed curve, part by part.
    pub curves: Vec<CurveConvergence>,
    /// The parameter point, by search name.
    pub at: Vec<(String, f64)>,
    pub evaluations: usize,
    pub failed: usize,
    /// The unit of the element sizes, for the plots' axes (None: not given).
    pub size_unit: Option<String>,
}

/// Each parameter's one verdict, in the order of `parameters`.
fn parameter_verdicts(
    parameters: &[Parameter],
    calibrated: &[f64],
    identifiability: Option<&Identifiability>,
    posterior: Option<&PosteriorOutcome>,
) -> Vec<ParameterVerdict> {
    parameters
        .iter()
        .enumerate()
        .map(|(j, p)| {
            let from_posterior = posterior.and_then(|posterior| {
                let column = posterior.column(&p.name)?;
                let m = &posterior.marginals[column];
                // The side either end of the 90 % interval reaches.
                let side = [m.q05, m.q95]
                    .into_iter()
                    .find_map(|end| p.bound_reached(end));
                Some(posterior_verdict(posterior, column, side))
            });
            let (words, evidence) = if let Some(words) = from_posterior {
                (words, Evidence::Posterior)
            } else if let Some(side) = calibrated.get(j).and_then(|&v| p.bound_reached(v)) {
                (
                    format!("on its {side}: the search stopped there, and the optimum may lie beyond it (widen the range, or check the model)"),
                    Evidence::Bound,
                )
            } else if let Some(analysis) = identifiability {
                (local_verdict(analysis, j).to_string(), Evidence::CalibratedPoint)
            } else {
                ("no verdict: too few successful runs to judge it".to_string(), Evidence::None)
            };
            ParameterVerdict {
                name: p.name.clone(),
                words,
                evidence,
            }
        })
        .collect()
}
