//! A calibration study on any model: the parameters (shared by all load
//! cases, or one case's own), the cases (each with fixed inputs,
//! observations and a role, `fit` or `validate`), and how a model run is
//! scored against the observations.
//!
//! The search sees one simulator: `simulator::StudySimulator` for the fit cases. Its
//! parameters are the search vector (shared parameters, then each case's
//! own, named `case/parameter`); one evaluation runs the model once per
//! fit case and returns one value per observation: a scalar's model value,
//! or a curve's MAPE against its measured curve (the published procedure,
//! [`acq_analysis::loss::curve`]). Those values are what `evaluations.csv`
//! logs, so a resumed study needs no model output beyond them. Validation
//! cases are a second simulator over the same search vector, run only at
//! the calibrated point: the search never sees them.
//!
//! Errors: a scalar's relative error `100 |model - measured| / |measured|`
//! (the excavator study's), a curve's MAPE. With `residuals =
//! "normalised"`, each scalar's error is `|model - measured| / u` instead
//! (u its standard uncertainty), so the loss is in standard uncertainties,
//! and chi-square `sum ((model - measured) / u)^2` says whether the
//! calibrated model agrees with the measurement within what the
//! instruments can tell.

use acq_algorithms::evaluation::Parameter;
use acq_analysis::loss::metrics::{matched, points_of, residuals_by_part, CurveMetric};
pub use acq_metrology::budget::SharedError;
use serde_json::{json, Map, Value};

/// A model a study calibrates: named inputs in, the requested scalar
/// outputs and curves out. Implemented by a user's solver run as a command
/// (the external adapter) and by the built-in twins.
pub trait Model: Sync {
    /// One run with `inputs` (parameters and a case's fixed inputs, by
    /// name). Returns `scalars` and `curves` (as `(x, y)` points) in the
    /// order asked, or why the run failed.
    fn run(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> Result<ModelRun, String>;

    /// Text columns about where each run happened (a cluster's job id,
    /// queue wait and run time), logged with every evaluation. None for a
    /// model that runs inside acq.
    fn note_columns(&self) -> &[String] {
        &[]
    }

    /// [`Model::run`] with one note per [`Model::note_columns`].
    fn run_noted(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> (Result<ModelRun, String>, Vec<String>) {
        (self.run(inputs, scalars, curves), Vec::new())
    }

    /// A short status of the runs under way (`2 pending, 1 running`) for
    /// the progress line, when the model has one.
    fn status(&self) -> Option<String> {
        None
    }

    /// The model's own standard error of each of `scalars` at `inputs`:
    /// an emulator's latent standard deviation there, large where its runs
    /// did not reach. `None` for a model that is the thing itself.
    fn own_error_sd(&self, _inputs: &[(String, f64)], _scalars: &[&str]) -> Option<Vec<f64>> {
        None
    }

    /// Whether a run costs so little (microseconds, inside acq) that a
    /// posterior can be sampled on the model itself, hundreds of thousands
    /// of runs, rather than on an emulator of its logged runs.
    fn is_cheap(&self) -> bool {
        false
    }

    /// Whether [`Model::run_with_slopes`] gives the curves' slopes in the
    /// inputs (a model differentiated along with its run).
    fn gives_slopes(&self) -> bool {
        false
    }

    /// [`Model::run`], and each curve's slopes in the inputs, for a model
    /// that [`Model::gives_slopes`]: none by default.
    fn run_with_slopes(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> Result<(ModelRun, Vec<CurveSlopes>), String> {
        self.run(inputs, scalars, curves)
            .map(|run| (run, Vec::new()))
    }

    /// The run at `inputs` again, for the report (the calibrated curves):
    /// a model inside acq runs it; a solver answers from the files of a
    /// run it already made there, or None, since one more run of it can
    /// cost hours.
    fn run_again(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> Option<ModelRun> {
        self.run(inputs, scalars, curves).ok()
    }
}

/// How many parts of a curve the local steps of a search and the
/// posterior see: enough to tell the elastic rise, the hardening, the
/// necking and the drop apart.
pub const CURVE_PARTS: usize = 20;

/// A curve's slopes in a model's inputs: for each input (by name) the
/// derivative of the curve's y at each of its points, per unit of the
/// input. An input not listed does not move the curve.
pub type CurveSlopes = Vec<(String, Vec<f64>)>;

/// What one model run gave.
#[derive(Clone, Debug, Default)]
pub struct ModelRun {
    pub scalars: Vec<f64>,
    pub curves: Vec<Vec<(f64, f64)>>,
}

/// What a case is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// The search fits the parameters to it.
    Fit,
    /// Checked at the calibrated parameters only: the search never sees it.
    Validate,
}

impl Role {
    pub fn name(self) -> &'static str {
        match self {
            Role::Fit => "fit",
            Role::Validate => "validate",
        }
    }
}

/// What was measured.
#[derive(Clone, Debug)]
pub enum Measured {
    /// A value with its standard uncertainty, if known (same unit).
    Scalar {
        value: f64,
        uncertainty: Option<f64>,
    },
    /// A curve the model's curve of the same name is compared with, the
    /// names of its x and y (columns, or quantities with units), and how
    /// (MAPE on an x grid unless the spec says otherwise).
    Curve {
        points: Vec<(f64, f64)>,
        axes: [String; 2],
        metric: CurveMetric,
    },
}

/// The old meaning of `"std_of_mean"`: the readings' scatter in the hold
/// only (std over the square root of the effective sample count), each
/// hold's error independent of every other's.
pub const SCATTER_OF_MEAN: &str = "scatter_of_mean";

/// One observation of a case.
#[derive(Clone, Debug)]
pub struct Observation {
    /// Its name in logs, summaries and reports.
    pub name: String,
    /// The model output (or curve) it is compared with; usually `name`.
    pub output: String,
    pub measured: Measured,
    /// Its weight in the loss and in TOPSIS (1 unless given).
    pub weight: f64,
    /// Where the measured value came from, for the report.
    pub source: String,
    /// The parts of its uncertainty that recur in other observations
    /// (a transducer's calibration, the same in every hold it measured;
    /// part of the stated uncertainty, not added to it). A posterior takes
    /// each source's as one error over every observation it is in.
    pub shared: Vec<SharedError>,
}

impl Observation {
    /// A scalar's measured value and its stated standard uncertainty.
    pub fn stated_scalar(&self) -> Option<(f64, f64)> {
        match self.measured {
            Measured::Scalar {
                value,
                uncertainty: Some(u),
            } => Some((value, u)),
            _ => None,
        }
    }
}

/// One load case.
#[derive(Clone, Debug)]
pub struct Case {
    pub name: String,
    pub role: Role,
    /// Fixed inputs, passed to the model like parameters.
    pub inputs: Vec<(String, f64)>,
    pub observations: Vec<Observation>,
    /// The parameters' priors ([`Case::priors`]): each observation is a
    /// parameter's own value, answered from the search point without a
    /// model run.
    pub priors: bool,
}

/// A parameter's prior: where class-typical values lie, and how far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prior {
    pub value: f64,
    /// One standard deviation, in the parameter's unit.
    pub uncertainty: f64,
}

impl Case {
    /// A load case whose observations the model answers.
    pub fn new(name: impl Into<String>, role: Role, observations: Vec<Observation>) -> Self {
        Case {
            name: name.into(),
            role,
            inputs: Vec::new(),
            observations,
            priors: false,
        }
    }

    /// The fit case "prior" holding one observation per parameter with a
    /// prior: a penalty for straying from it, scored like any measured
    /// value (so a MAP estimate with `loss = "squares"` and normalised
    /// residuals). `None` when no parameter has one.
    pub fn priors(parameters: &[StudyParameter]) -> Option<Case> {
        let observations: Vec<Observation> = parameters
            .iter()
            .filter_map(|p| {
                let prior = p.prior?;
                Some(Observation {
                    name: p.search.name.clone(),
                    output: p.search.name.clone(),
                    measured: Measured::Scalar {
                        value: prior.value,
                        uncertainty: Some(prior.uncertainty),
                    },
                    weight: 1.0,
                    source: "prior".into(),
                    shared: Vec::new(),
                })
            })
            .collect();
        (!observations.is_empty()).then(|| Case {
            priors: true,
            ..Case::new("prior", Role::Fit, observations)
        })
    }
}

/// One parameter of the study.
#[derive(Clone, Debug)]
pub struct StudyParameter {
    /// In the search vector: `name`, or `case/name` for a case's own.
    pub search: Parameter,
    /// The name the model receives.
    pub input: String,
    /// The case it belongs to (index into the study's cases); `None` when shared.
    pub case: Option<usize>,
    /// The value the initial errors are reported at.
    pub nominal: f64,
    /// Where it is expected to lie, when known (a penalty for leaving it).
    pub prior: Option<Prior>,
}

/// How residuals become errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Residuals {
    /// `100 |model - measured| / |measured|`, in %.
    Relative,
    /// `|model - measured| / u`, in standard uncertainties.
    Normalised,
}

/// How the errors become one loss (Bayesian optimisation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LossKind {
    /// Their weighted mean.
    Mean,
    /// The largest.
    Max,
    /// The weighted mean of their squares: with normalised residuals and
    /// priors, a maximum a-posteriori estimate (chi-square over n).
    Squares,
}

/// A whole study.
#[derive(Clone, Debug)]
pub struct Study {
    pub parameters: Vec<StudyParameter>,
    pub cases: Vec<Case>,
    /// False for a study without `[[case]]`: one implicit fit case, and
    /// outputs keyed by their plain names.
    pub named_cases: bool,
    pub residuals: Residuals,
    pub loss: LossKind,
}

/// The error of one observation at a model run.
#[derive(Clone, Debug)]
pub struct ObservationError {
    pub case: String,
    pub role: Role,
    /// `case/name`, or `name` without named cases.
    pub key: String,
    pub name: String,
    pub measured: Option<f64>,
    pub model: f64,
    /// Relative error or MAPE, %; NaN (null in summary.json) for a curve
    /// scored by a coupling metric, whose value (in `model`) is no
    /// percentage.
    pub error_pct: f64,
    /// `(model - measured) / u`, when the uncertainty is known.
    pub normalised: Option<f64>,
    /// A curve's metric (its value is `model`); `None` for a scalar.
    pub curve_metric: Option<CurveMetric>,
}

impl Study {
    /// The search vector's parameters.
    pub fn search_parameters(&self) -> Vec<Parameter> {
        self.parameters.iter().map(|p| p.search.clone()).collect()
    }

    /// The nominal point of the search vector.
    pub fn nominal(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.nominal).collect()
    }

    pub fn cases_with(&self, role: Role) -> impl Iterator<Item = (usize, &Case)> {
        self.cases
            .iter()
            .enumerate()
            .filter(move |(_, c)| c.role == role)
    }

    /// The key of an observation in logs and summaries.
    pub fn key(&self, case: &Case, observation: &Observation) -> String {
        if case.priors {
            format!("prior/{}", observation.name)
        } else if self.named_cases {
            format!("{}/{}", case.name, observation.name)
        } else {
            observation.name.clone()
        }
    }

    /// The keys of the `role` simulator's outputs (the observations'), in
    /// order: the columns of its log.
    pub fn output_keys(&self, role: Role) -> Vec<String> {
        self.observations(role)
            .into_iter()
            .map(|(case, observation)| self.key(case, observation))
            .collect()
    }

    /// The observations of the cases with `role`, in output order.
    pub fn observations(&self, role: Role) -> Vec<(&Case, &Observation)> {
        self.cases_with(role)
            .flat_map(|(_, case)| case.observations.iter().map(move |o| (case, o)))
            .collect()
    }

    /// Each observation's error at outputs of the `role` simulator.
    pub fn errors(&self, role: Role, outputs: &[f64]) -> Vec<ObservationError> {
        self.observations(role)
            .into_iter()
            .zip(outputs)
            .map(|((case, observation), &model)| {
                let (measured, error_pct, normalised, curve_metric) = match &observation.measured {
                    Measured::Scalar { value, uncertainty } => (
                        Some(*value),
                        100.0 * (model - value).abs() / value.abs(),
                        uncertainty.map(|u| (model - value) / u),
                        None,
                    ),
                    // The logged value of a curve is its metric's already;
                    // only MAPE's is a percentage.
                    Measured::Curve { metric, .. } => {
                        let error_pct = if *metric == CurveMetric::Mape {
                            model
                        } else {
                            f64::NAN
                        };
                        (None, error_pct, None, Some(*metric))
                    }
                };
                ObservationError {
                    case: case.name.clone(),
                    role: case.role,
                    key: self.key(case, observation),
                    name: observation.name.clone(),
                    measured,
                    model,
                    error_pct,
                    normalised,
                    curve_metric,
                }
            })
            .collect()
    }

    /// Whether the local steps should read the residuals as a sum of
    /// absolute values (a mean or largest error over scalars and MAPE
    /// curves) rather than of squares.
    ///
    /// A curve scored by a coupling metric says no: its residuals are the
    /// mean signed distances over parts of the curve, while its loss sums
    /// the distances of every pair (or takes the largest). Near the best
    /// fit each part's mean is measurement noise, and weighing the parts by
    /// `1 / |r|` would steer by that noise; their squares are the least
    /// squares fit of the curve. (`cargo bench --bench
    /// curve_study_generalisation`, tune set, BENCHMARKS.md.)
    pub fn local_steps_in_absolute_values(&self) -> bool {
        self.loss != LossKind::Squares
            && !self.observations(Role::Fit).iter().any(|(_, o)| {
                matches!(o.measured, Measured::Curve { metric, .. } if metric != CurveMetric::Mape)
            })
    }

    /// The costs the search minimises, one per fit observation: relative
    /// errors (%) and MAPEs, or scalars in standard uncertainties.
    ///
    /// Called for every surrogate point NSGA-II tries, so it builds no
    /// [`ObservationError`]s (their names would be allocated each time).
    pub fn objectives(&self, outputs: &[f64]) -> Vec<f64> {
        self.cases_with(Role::Fit)
            .flat_map(|(_, case)| &case.observations)
            .zip(outputs)
            .map(|(observation, &model)| match &observation.measured {
                Measured::Scalar {
                    value,
                    uncertainty: Some(u),
                } if self.residuals == Residuals::Normalised => (model - value).abs() / u,
                Measured::Scalar { value, .. } => 100.0 * (model - value).abs() / value.abs(),
                // The logged value of a curve is its MAPE already.
                Measured::Curve { .. } => model,
            })
            .collect()
    }

    /// The unit of each of [`Study::objectives`]: `u` (standard
    /// uncertainties) or `%`.
    pub fn objective_units(&self) -> Vec<&'static str> {
        self.cases_with(Role::Fit)
            .flat_map(|(_, case)| &case.observations)
            .map(|observation| match &observation.measured {
                Measured::Scalar {
                    uncertainty: Some(_),
                    ..
                } if self.residuals == Residuals::Normalised => "standard uncertainties",
                _ => "%",
            })
            .collect()
    }

    /// The signed residuals a least-squares search squares and sums, one
    /// per fit observation: a scalar's `(model - measured) / u` with
    /// normalised residuals, else its signed relative error in %; a
    /// curve's MAPE. Each is scaled by the square root of its weight, so
    /// the sum of squares is [`LossKind::Squares`]'s weighted sum.
    pub fn residuals(&self, outputs: &[f64]) -> Vec<f64> {
        self.cases_with(Role::Fit)
            .flat_map(|(_, case)| &case.observations)
            .zip(outputs)
            .map(|(observation, &model)| {
                let residual = match &observation.measured {
                    Measured::Scalar {
                        value,
                        uncertainty: Some(u),
                    } if self.residuals == Residuals::Normalised => (model - value) / u,
                    Measured::Scalar { value, .. } => 100.0 * (model - value) / value.abs(),
                    Measured::Curve { .. } => model,
                };
                residual * observation.weight.sqrt()
            })
            .collect()
    }

    /// The residuals of a search's local steps, from fit outputs of a
    /// simulator `StudySimulator::with_curve_parts(parts)`: each scalar
    /// as in [`Study::residuals`], each curve as its `parts` signed errors
    /// (%) scaled by `sqrt(weight / parts)`, so that a curve off by e %
    /// everywhere counts as a scalar off by e %. Empty when the outputs
    /// hold no parts.
    pub fn local_residuals(&self, outputs: &[f64], parts: usize) -> Vec<f64> {
        let observations = self.observations(Role::Fit);
        let curves = observations
            .iter()
            .filter(|(_, o)| matches!(o.measured, Measured::Curve { .. }))
            .count();
        if outputs.len() != observations.len() + curves * parts {
            return Vec::new();
        }
        let scalars = self.residuals(&outputs[..observations.len()]);
        let mut part_values = outputs[observations.len()..].chunks(parts.max(1));
        let mut residuals = Vec::with_capacity(outputs.len());
        for ((_, observation), scalar) in observations.iter().zip(scalars) {
            match &observation.measured {
                Measured::Scalar { .. } => residuals.push(scalar),
                Measured::Curve { .. } => {
                    let scale = (observation.weight / parts as f64).sqrt();
                    let values = part_values.next().unwrap_or_default();
                    residuals.extend(values.iter().map(|v| v * scale));
                }
            }
        }
        residuals
    }

    /// The slopes of [`Study::local_residuals`] in the unit box, row by row
    /// (residuals x search parameters), from a run's part slopes
    /// (`StudySimulator::take_part_slopes`): each scaled as its part's
    /// residual is. Empty when there are none, all are zero (the model
    /// could not give them for this run) or any is not finite: the local
    /// steps then fit their model to the runs.
    pub fn local_residual_slopes(&self, slopes: &[f64], parts: usize) -> Vec<f64> {
        let observations = self.observations(Role::Fit);
        let dimensions = self.parameters.len();
        let all_curves = observations
            .iter()
            .all(|(_, o)| matches!(o.measured, Measured::Curve { .. }));
        if !all_curves || parts == 0 || slopes.len() != observations.len() * parts * dimensions {
            return Vec::new();
        }
        if !slopes.iter().all(|v| v.is_finite()) || slopes.iter().all(|v| *v == 0.0) {
            return Vec::new();
        }
        observations
            .iter()
            .zip(slopes.chunks(parts * dimensions))
            .flat_map(|((_, observation), rows)| {
                let scale = (observation.weight / parts as f64).sqrt();
                rows.iter().map(move |v| v * scale)
            })
            .collect()
    }

    /// The weights of the fit observations.
    pub fn weights(&self) -> Vec<f64> {
        self.observations(Role::Fit)
            .iter()
            .map(|(_, o)| o.weight)
            .collect()
    }

    /// The scalar loss of fit outputs: the weighted mean or the largest objective.
    pub fn loss(&self, outputs: &[f64]) -> f64 {
        let objectives = self.objectives(outputs);
        match self.loss {
            LossKind::Max => objectives.iter().fold(0.0f64, |a, &b| a.max(b)),
            LossKind::Mean | LossKind::Squares => {
                let power = if self.loss == LossKind::Squares { 2 } else { 1 };
                let weights = self.weights();
                let total: f64 = weights.iter().sum();
                objectives
                    .iter()
                    .zip(&weights)
                    .map(|(e, w)| e.powi(power) * w)
                    .sum::<f64>()
                    / total
            }
        }
    }

    /// The search vector's values as one case's model inputs: the shared
    /// parameters, the case's own, then its fixed inputs.
    pub fn inputs_of(&self, case_index: usize, values: &[f64]) -> Vec<(String, f64)> {
        let case = &self.cases[case_index];
        self.parameters
            .iter()
            .zip(values)
            .filter(|(p, _)| p.case.is_none() || p.case == Some(case_index))
            .map(|(p, &v)| (p.input.clone(), v))
            .chain(case.inputs.iter().cloned())
            .collect()
    }
}

/// Chi-square of the errors with a known uncertainty: `(sum z^2, count)`.
pub fn chi_square(errors: &[ObservationError]) -> Option<(f64, usize)> {
    let z: Vec<f64> = errors.iter().filter_map(|e| e.normalised).collect();
    (!z.is_empty()).then(|| (z.iter().map(|z| z * z).sum(), z.len()))
}

/// A curve scored by a coupling metric: its value, and `parts` signed
/// residuals along the measured curve in % of its range (100 times the
/// mean signed distance over each part: like MAPE's parts in %, so a
/// local step weighs them alike), from the coupling of the metric's
/// [`CurveMetric::residual_coupling`]. `(x, y)` points as the study keeps
/// them.
pub fn coupled_curve(
    metric: CurveMetric,
    measured: &[(f64, f64)],
    simulated: &[(f64, f64)],
    parts: usize,
) -> Result<(f64, Vec<f64>), acq_analysis::loss::metrics::CurveMetricError> {
    let (measured, simulated) = (points_of(measured), points_of(simulated));
    let result = matched(metric, &measured, &simulated)?;
    let parts = if parts == 0 {
        Vec::new()
    } else {
        let coupling = metric.residual_coupling();
        let pairs = if coupling == metric {
            result.pairs
        } else {
            matched(coupling, &measured, &simulated)?.pairs
        };
        residuals_by_part(&pairs, parts)
            .into_iter()
            .map(|r| 100.0 * r)
            .collect()
    };
    Ok((result.value, parts))
}

/// Each run's notes after the notes already there, space-separated per
/// column: an evaluation of several cases, or several attempts, notes
/// every job it ran.
pub fn append_notes(notes: &mut [String], run_notes: Vec<String>) {
    for (note, run_note) in notes.iter_mut().zip(run_notes) {
        if !note.is_empty() && !run_note.is_empty() {
            note.push(' ');
        }
        note.push_str(&run_note);
    }
}

/// `{case: {"role", "errors_pct": {output: %}}}` of the summary.
pub fn cases_json(errors: &[ObservationError]) -> Value {
    let mut cases = Map::new();
    for error in errors {
        let entry = cases
            .entry(error.case.clone())
            .or_insert_with(|| json!({"role": error.role.name(), "errors_pct": {}}));
        entry["errors_pct"][&error.name] = json!(error.error_pct);
    }
    Value::Object(cases)
}

/// `{key: %}` of the summary.
pub fn errors_json(errors: &[ObservationError]) -> Value {
    Value::Object(
        errors
            .iter()
            .map(|e| (e.key.clone(), json!(e.error_pct)))
            .collect(),
    )
}

/// The numbers of a JSON value by key path: `{"pressure_bar": {"boom":
/// 73.4}}` gives `pressure_bar.boom`, array items `name[0]`, so a solver's
/// nested output needs no rewriting.
/// The number at one key path of `value` (`cylinder_force_kN.boom`,
/// `gauge_stress_MPa[9]`): what [`numbers_by_key_path`] holds under that
/// path, found without flattening the rest.
pub fn number_at_key_path(value: &Value, path: &str) -> Option<f64> {
    let mut at = value;
    for part in path.split('.') {
        let (key, mut rest) = part.split_once('[').map_or((part, ""), |(k, r)| (k, r));
        at = at.as_object()?.get(key)?;
        while !rest.is_empty() {
            let (index, after) = rest.split_once(']')?;
            at = at.as_array()?.get(index.parse::<usize>().ok()?)?;
            rest = after.strip_prefix('[').unwrap_or(after);
        }
    }
    at.as_f64()
}

pub fn numbers_by_key_path(value: &Value) -> std::collections::HashMap<String, f64> {
    let mut numbers = std::collections::HashMap::new();
    flatten_json("", value, &mut numbers);
    numbers
}

fn flatten_json(prefix: &str, value: &Value, into: &mut std::collections::HashMap<String, f64>) {
    match value {
        Value::Object(map) => {
            for (key, item) in map {
                let path = if prefix.is_empty() {
                    key.clone()
                } else {
                    format!("{prefix}.{key}")
                };
                flatten_json(&path, item, into);
            }
        }
        Value::Array(items) => {
            for (index, item) in items.iter().enumerate() {
                flatten_json(&format!("{prefix}[{index}]"), item, into);
            }
        }
        other => {
            if let Some(number) = other.as_f64() {
                into.insert(prefix.to_string(), number);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{coupled_curve, matched, points_of, CurveMetric};

    #[test]
    fn pcm_and_frechet_steer_by_the_dtw_coupling_and_keep_their_own_value() {
        // A noisy measured arc and a taller simulated one on another grid.
        let measured: Vec<(f64, f64)> = (0..40)
            .map(|i| {
                let t = f64::from(i) / 39.0;
                (t, (3.0 * t).sin() + 0.02 * (f64::from(i * 7 % 5) - 2.0))
            })
            .collect();
        let simulated: Vec<(f64, f64)> = (0..55)
            .map(|i| {
                let t = f64::from(i) / 54.0;
                (t, 1.1 * (3.0 * t).sin())
            })
            .collect();
        let (_, dtw_parts) = coupled_curve(CurveMetric::Dtw, &measured, &simulated, 8).unwrap();
        for metric in [CurveMetric::Pcm, CurveMetric::Frechet] {
            let (value, parts) = coupled_curve(metric, &measured, &simulated, 8).unwrap();
            assert_eq!(parts, dtw_parts, "{metric}");
            let own = matched(metric, &points_of(&measured), &points_of(&simulated)).unwrap();
            assert_eq!(value, own.value, "{metric}");
        }
        let (_, area_parts) = coupled_curve(CurveMetric::Area, &measured, &simulated, 8).unwrap();
        assert_ne!(area_parts, dtw_parts);
    }
}
