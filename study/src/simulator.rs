//! The study as the engine sees it: [`StudySimulator`] runs the model
//! for every case of a role (cases of the same inputs share one run,
//! [`crate::shared_runs`]) and returns one value per observation, a curve's
//! errors in parts for a search's local steps, and, when the model gives
//! them, those parts' slopes in the search parameters (kept beside the
//! outputs in [`PartSlopesLog`]).

use acq_algorithms::evaluation::{Parameter, Scale, Simulator};
use acq_analysis::loss::curve::{CurveLossError, CurveMapeOptions, TestCurve};
use acq_analysis::loss::metrics::CurveMetric;

use crate::part_slopes::PartSlopesLog;
use crate::shared_runs::SharedRuns;
use crate::study::{coupled_curve, CurveSlopes, Measured, Model, Role, Study};

/// The model over the cases of one role, as the engine sees it.
pub struct StudySimulator<'a> {
    pub(crate) study: &'a Study,
    model: &'a dyn Model,
    role: Role,
    pub(crate) parameters: Vec<Parameter>,
    outputs: Vec<String>,
    pub(crate) curve_parts: usize,
    /// Also each curve part's slope in each search parameter, kept
    /// beside the outputs (see [`StudySimulator::with_part_slopes`]).
    part_slopes: Option<PartSlopesLog>,
    /// Each measured curve scored by MAPE, by case and observation index,
    /// checked and interpolated once for every run to compare with
    /// (`None` for other observations, and for a curve the MAPE refuses:
    /// each run then says why), with the grid points of its own.
    measured_curves: Vec<Vec<Option<(TestCurve, usize)>>>,
}

impl<'a> StudySimulator<'a> {
    pub fn new(study: &'a Study, model: &'a dyn Model, role: Role) -> Self {
        let measured_curves = study
            .cases
            .iter()
            .map(|case| {
                case.observations
                    .iter()
                    .map(|observation| match &observation.measured {
                        Measured::Curve {
                            points,
                            metric: CurveMetric::Mape,
                            ..
                        } => TestCurve::new(points).ok().map(|test| {
                            let own_points = test.parts(CurveMapeOptions::default(), usize::MAX);
                            (test, own_points)
                        }),
                        _ => None,
                    })
                    .collect()
            })
            .collect();
        StudySimulator {
            study,
            model,
            role,
            parameters: study.search_parameters(),
            outputs: study.output_keys(role),
            curve_parts: 0,
            part_slopes: None,
            measured_curves,
        }
    }

    /// Also keeps, for each run, each curve part's slope in each search
    /// parameter's coordinate of the unit box (per the parameter's range on
    /// its scale), when the model [`Model::gives_slopes`] and every fit
    /// observation is a curve scored by MAPE: a search's local steps then
    /// take their model from the run itself ([`StudySimulator::take_part_slopes`],
    /// [`Study::local_residual_slopes`]). They are not outputs: the
    /// evaluation log's columns stay the observations and parts, and a run
    /// read back from it finds its slopes in `log`. Call after
    /// [`StudySimulator::with_curve_parts`].
    pub fn with_part_slopes(mut self, log: PartSlopesLog) -> Self {
        if self.wants_part_slopes() {
            self.part_slopes = Some(log);
        }
        self
    }

    /// Whether [`StudySimulator::with_part_slopes`] would keep slopes: the
    /// model gives them, the curves have parts, and every fit observation
    /// is a curve scored by MAPE.
    pub fn wants_part_slopes(&self) -> bool {
        let observations = self.study.observations(self.role);
        let all_mape_curves = !observations.is_empty()
            && observations.iter().all(|(case, observation)| {
                !case.priors
                    && matches!(
                        observation.measured,
                        Measured::Curve {
                            metric: CurveMetric::Mape,
                            ..
                        }
                    )
            });
        self.curve_parts > 0 && self.model.gives_slopes() && all_mape_curves
    }

    /// The part slopes of the run at `values` (curve by curve, part by
    /// part, a row of the search parameters each), once; empty when the
    /// run gave none or they were taken.
    pub fn take_part_slopes(&self, values: &[f64]) -> Vec<f64> {
        self.part_slopes
            .as_ref()
            .map(|log| log.take(values))
            .unwrap_or_default()
    }

    /// Also outputs, after the observations, each curve's signed errors
    /// in `parts` consecutive runs of its grid (`KEY.partNN`), for a
    /// search's local steps ([`Study::local_residuals`]).
    pub fn with_curve_parts(mut self, parts: usize) -> Self {
        self.curve_parts = parts;
        if parts > 0 {
            for (case, observation) in self.study.observations(self.role) {
                if matches!(observation.measured, Measured::Curve { .. }) {
                    let key = self.study.key(case, observation);
                    self.outputs
                        .extend((1..=parts).map(|part| format!("{key}.part{part:02}")));
                }
            }
        }
        self
    }
}

impl Simulator for StudySimulator<'_> {
    fn parameters(&self) -> &[Parameter] {
        &self.parameters
    }
    fn outputs(&self) -> &[String] {
        &self.outputs
    }
    fn note_columns(&self) -> &[String] {
        self.model.note_columns()
    }
    fn evaluate(&self, values: &[f64]) -> Result<Vec<f64>, String> {
        self.evaluate_noted(values).0
    }
    /// Each case's run in turn; a note column holds the notes of every
    /// case's run, space-separated.
    fn evaluate_noted(&self, values: &[f64]) -> (Result<Vec<f64>, String>, Vec<String>) {
        let mut notes = vec![String::new(); self.model.note_columns().len()];
        let outcome = self.evaluate_cases(values, &mut notes);
        (outcome, notes)
    }
}

impl StudySimulator<'_> {
    fn evaluate_cases(&self, values: &[f64], notes: &mut [String]) -> Result<Vec<f64>, String> {
        let mut outputs = Vec::with_capacity(self.outputs.len());
        let mut curve_parts: Vec<f64> = Vec::new();
        let mut part_slopes: Vec<f64> = Vec::new();
        let mut shared = SharedRuns::new(self.study, self.role, values);
        shared.with_slopes = self.part_slopes.is_some();
        for (index, case) in self.study.cases_with(self.role) {
            if case.priors {
                for observation in &case.observations {
                    let at = self
                        .parameters
                        .iter()
                        .position(|p| p.name == observation.output)
                        .ok_or_else(|| {
                            format!("a prior of no parameter: {}", observation.output)
                        })?;
                    outputs.push(values[at]);
                }
                continue;
            }
            let in_case = |reason: String| {
                if self.study.named_cases {
                    format!("case {}: {reason}", case.name)
                } else {
                    reason
                }
            };
            let (case_scalars, case_curves, case_slopes) = shared
                .outputs_of(index, self.model, notes)
                .map_err(in_case)?;
            let (mut scalar, mut curve) = (case_scalars.into_iter(), case_curves.into_iter());
            let mut slopes = case_slopes.into_iter();
            for (observation_index, observation) in case.observations.iter().enumerate() {
                outputs.push(match &observation.measured {
                    Measured::Scalar { .. } => scalar
                        .next()
                        .ok_or_else(|| in_case("the model returned too few outputs".into()))?,
                    Measured::Curve { points, metric, .. } => {
                        let simulated = curve
                            .next()
                            .ok_or_else(|| in_case("the model returned too few curves".into()))?;
                        let curve_slopes = slopes.next().flatten();
                        let in_curve = |e: CurveLossError| {
                            let hint = if matches!(e, CurveLossError::Decreasing { .. }) {
                                " (MAPE compares on an x grid; for a curve whose x goes back, give the curve metric = \"pcm\", \"frechet\", \"dtw\" or \"area\")"
                            } else {
                                ""
                            };
                            in_case(format!("curve {}: {e}{hint}", observation.name))
                        };
                        if *metric != CurveMetric::Mape {
                            let (value, parts) =
                                coupled_curve(*metric, points, simulated, self.curve_parts)
                                    .map_err(|e| {
                                        in_case(format!("curve {}: {e}", observation.name))
                                    })?;
                            curve_parts.extend(parts);
                            value
                        } else {
                            let owned;
                            let (test, own_points) = match &self.measured_curves[index]
                                [observation_index]
                            {
                                Some((test, own_points)) => (test, *own_points),
                                None => {
                                    owned = TestCurve::new(points).map_err(in_curve)?;
                                    (&owned, usize::MAX)
                                }
                            };
                            let options = CurveMapeOptions::default();
                            if self.curve_parts == 0 {
                                test.mape(simulated, options).map_err(in_curve)?.mape_percent
                            } else {
                                // No more parts than the measured curve has
                                // points of its own: a finer simulation's
                                // extra ones would be parts the likelihood
                                // reads no scatter for.
                                let part_count = self.curve_parts.min(own_points);
                                let (mape, mut parts) = test
                                    .errors_by_part(simulated, options, part_count)
                                    .map_err(in_curve)?;
                                if self.part_slopes.is_some() {
                                    part_slopes.extend(self.parts_by_parameter(
                                        (index, values),
                                        test,
                                        simulated,
                                        curve_slopes,
                                        (&parts, part_count),
                                    ));
                                }
                                // A grid shorter than the parts: the last part
                                // repeats (the likelihood reads it once).
                                let last = parts.last().copied().unwrap_or(0.0);
                                parts.resize(self.curve_parts, last);
                                curve_parts.extend(parts);
                                mape.mape_percent
                            }
                        }
                    }
                });
            }
        }
        outputs.extend(curve_parts);
        if let Some(log) = &self.part_slopes {
            log.record(values, part_slopes);
        }
        Ok(outputs)
    }
}

impl StudySimulator<'_> {
    /// A curve's parts' slopes in each search parameter, part by part
    /// (`curve_parts` rows of the parameters' count): the curve's slopes
    /// in the model's inputs carried through the parts' errors. The
    /// errors are a function of the simulated points alone, so each
    /// parameter's column is their difference along the curve's slope,
    /// a step of a millionth of the force (no model run); then per unit
    /// of the unit box's coordinate. Zero where the model gave none (all
    /// zeros are no slopes to [`Study::local_residual_slopes`]).
    pub(crate) fn parts_by_parameter(
        &self,
        (case_index, values): (usize, &[f64]),
        test: &TestCurve,
        simulated: &[(f64, f64)],
        curve_slopes: Option<&CurveSlopes>,
        (parts, part_count): (&[f64], usize),
    ) -> Vec<f64> {
        let dimensions = self.parameters.len();
        let mut by_parameter = vec![vec![0.0; parts.len()]; dimensions];
        let largest_force = simulated.iter().fold(0.0_f64, |a, p| a.max(p.1.abs()));
        for (j, parameter) in self.study.parameters.iter().enumerate().take(dimensions) {
            let Some(curve_slopes) = curve_slopes else {
                break;
            };
            let applies = parameter.case.is_none() || parameter.case == Some(case_index);
            let slope = curve_slopes
                .iter()
                .find(|(input, _)| applies && *input == parameter.input)
                .map(|(_, by_point)| by_point.as_slice());
            let Some(slope) = slope.filter(|s| s.len() == simulated.len()) else {
                // An input the curve does not move with.
                by_parameter[j] = vec![0.0; parts.len()];
                continue;
            };
            let largest_slope = slope.iter().fold(0.0_f64, |a, s| a.max(s.abs()));
            if largest_slope == 0.0 || !largest_slope.is_finite() {
                continue;
            }
            let step = 1e-6 * largest_force.max(f64::MIN_POSITIVE) / largest_slope;
            let moved: Vec<(f64, f64)> = simulated
                .iter()
                .zip(slope)
                .map(|(&(x, y), s)| (x, y + step * s))
                .collect();
            if let Ok((_, moved_parts)) =
                test.errors_by_part(&moved, CurveMapeOptions::default(), part_count)
            {
                if moved_parts.len() == parts.len() {
                    let per_unit = match (self.parameters.get(j), values.get(j)) {
                        (Some(search), Some(&value)) => match search.scale {
                            Scale::Linear => search.upper - search.lower,
                            Scale::Log => value * (search.upper / search.lower).ln(),
                        },
                        _ => 0.0,
                    };
                    by_parameter[j] = moved_parts
                        .iter()
                        .zip(parts)
                        .map(|(a, b)| (a - b) / step * per_unit)
                        .collect();
                }
            }
        }
        // Rows of the parts (the last repeated, as the parts are).
        (0..self.curve_parts)
            .flat_map(|part| {
                let part = part.min(parts.len().saturating_sub(1));
                by_parameter
                    .iter()
                    .map(move |column| column.get(part).copied().unwrap_or(0.0))
                    .collect::<Vec<_>>()
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::StudySimulator;
    use crate::part_slopes::PartSlopesLog;
    use crate::study::{
        Case, CurveSlopes, LossKind, Measured, Model, ModelRun, Observation, Residuals, Role,
        Study, StudyParameter,
    };
    use acq_algorithms::evaluation::{Parameter, Simulator};
    use acq_analysis::loss::metrics::CurveMetric;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// `a = x + load`, `b = 2 x`, `c = 3 y`, counting its runs.
    struct Counted {
        runs: AtomicUsize,
    }

    impl Model for Counted {
        fn run(
            &self,
            inputs: &[(String, f64)],
            scalars: &[&str],
            _curves: &[&str],
        ) -> Result<ModelRun, String> {
            self.runs.fetch_add(1, Ordering::SeqCst);
            let input = |name: &str| {
                inputs
                    .iter()
                    .find(|(n, _)| n == name)
                    .map_or(0.0, |(_, v)| *v)
            };
            let scalars = scalars
                .iter()
                .map(|name| match *name {
                    "a" => Ok(input("x") + input("load")),
                    "b" => Ok(2.0 * input("x")),
                    "c" => Ok(3.0 * input("y")),
                    other => Err(format!("no output {other}")),
                })
                .collect::<Result<_, String>>()?;
            Ok(ModelRun {
                scalars,
                curves: Vec::new(),
            })
        }
    }

    fn observed(outputs: &[&str]) -> Vec<Observation> {
        outputs
            .iter()
            .map(|output| Observation {
                name: output.to_string(),
                output: output.to_string(),
                measured: Measured::Scalar {
                    value: 1.0,
                    uncertainty: None,
                },
                weight: 1.0,
                source: String::new(),
                shared: Vec::new(),
            })
            .collect()
    }

    /// Two cases with the same inputs (the CalculiX bar's hardening and
    /// neck) share one run that answers both; a case with an input of its
    /// own runs on its own; every case gets what it would have alone.
    #[test]
    fn cases_with_the_same_inputs_share_one_run() {
        let mut loaded = Case::new("loaded", Role::Fit, observed(&["a"]));
        loaded.inputs = vec![("load".into(), 10.0)];
        let study = Study {
            parameters: ["x", "y"]
                .map(|name| StudyParameter {
                    search: Parameter::new(name, 0.0, 1.0),
                    input: name.into(),
                    case: None,
                    nominal: 0.5,
                    prior: None,
                })
                .to_vec(),
            cases: vec![
                Case::new("hardening", Role::Fit, observed(&["a", "b"])),
                loaded,
                Case::new("neck", Role::Fit, observed(&["c", "a"])),
            ],
            named_cases: true,
            residuals: Residuals::Relative,
            loss: LossKind::Mean,
        };
        let model = Counted {
            runs: AtomicUsize::new(0),
        };
        let simulator = StudySimulator::new(&study, &model, Role::Fit);
        let outputs = simulator.evaluate(&[0.25, 0.5]).unwrap();
        assert_eq!(outputs, vec![0.25, 0.5, 10.25, 1.5, 0.25]);
        assert_eq!(model.runs.load(Ordering::SeqCst), 2);
    }

    /// `y = a exp(-b x)` on x = 0 .. 4 mm, with its slopes in a and b.
    struct DecayCurve;

    impl Model for DecayCurve {
        fn run(
            &self,
            inputs: &[(String, f64)],
            scalars: &[&str],
            curves: &[&str],
        ) -> Result<ModelRun, String> {
            Ok(self.run_with_slopes(inputs, scalars, curves)?.0)
        }

        fn gives_slopes(&self) -> bool {
            true
        }

        fn run_with_slopes(
            &self,
            inputs: &[(String, f64)],
            _scalars: &[&str],
            curves: &[&str],
        ) -> Result<(ModelRun, Vec<CurveSlopes>), String> {
            let input = |name: &str| inputs.iter().find(|(n, _)| n == name).map(|(_, v)| *v);
            let (Some(a), Some(b)) = (input("a"), input("b")) else {
                return Err("a and b".into());
            };
            let x: Vec<f64> = (0..=80).map(|i| 0.05 * f64::from(i)).collect();
            let curve: Vec<(f64, f64)> = x.iter().map(|&x| (x, a * (-b * x).exp())).collect();
            let by_a = x.iter().map(|&x| (-b * x).exp()).collect();
            let by_b = x.iter().map(|&x| -a * x * (-b * x).exp()).collect();
            let slopes = vec![("a".to_string(), by_a), ("b".to_string(), by_b)];
            Ok((
                ModelRun {
                    scalars: Vec::new(),
                    curves: curves.iter().map(|_| curve.clone()).collect(),
                },
                curves.iter().map(|_| slopes.clone()).collect(),
            ))
        }
    }

    /// The local residuals' slopes a run gives equal central differences
    /// of the local residuals over the unit box: the chain through the
    /// curve's parts, the curve's weight and a log-scaled parameter's box.
    #[test]
    fn a_run_s_part_slopes_are_the_differences_of_its_local_residuals() {
        use acq_algorithms::evaluation::Scale;
        let measured: Vec<(f64, f64)> = (0..=40)
            .map(|i| {
                let x = 0.1 * f64::from(i);
                (x, 1.2 * (-0.4 * x).exp() * (1.0 + 0.01 * (3.0 * x).sin()))
            })
            .collect();
        let mut b = Parameter::new("b", 0.1, 1.0);
        b.scale = Scale::Log;
        let study = Study {
            parameters: [("a", Parameter::new("a", 0.5, 2.0)), ("b", b)]
                .map(|(input, search)| StudyParameter {
                    search,
                    input: input.into(),
                    case: None,
                    nominal: 0.5,
                    prior: None,
                })
                .to_vec(),
            cases: vec![Case::new(
                "decay",
                Role::Fit,
                vec![Observation {
                    name: "force".into(),
                    output: "force".into(),
                    measured: Measured::Curve {
                        points: measured,
                        axes: ["x".into(), "y".into()],
                        metric: CurveMetric::Mape,
                    },
                    weight: 2.0,
                    source: String::new(),
                    shared: Vec::new(),
                }],
            )],
            named_cases: false,
            residuals: Residuals::Relative,
            loss: LossKind::Mean,
        };
        let parts = 20;
        let dir = tempfile::tempdir().unwrap();
        let names = vec!["a".to_string(), "b".to_string()];
        let log = PartSlopesLog::open(&dir.path().join("s.csv"), &names, false).unwrap();
        let simulator = StudySimulator::new(&study, &DecayCurve, Role::Fit)
            .with_curve_parts(parts)
            .with_part_slopes(log);
        // The slopes are kept beside the outputs, not among them.
        assert_eq!(simulator.outputs().len(), 1 + parts);
        let parameters = study.search_parameters();
        let values_at = |unit: &[f64]| -> Vec<f64> {
            parameters
                .iter()
                .zip(unit)
                .map(|(p, &u)| p.from_unit(u))
                .collect()
        };
        let at = |unit: &[f64]| simulator.evaluate(&values_at(unit)).unwrap();
        let centre = [0.3, 0.7];
        let outputs = at(&centre);
        let part_slopes = simulator.take_part_slopes(&values_at(&centre));
        assert_eq!(part_slopes.len(), parts * 2);
        assert!(simulator.take_part_slopes(&values_at(&centre)).is_empty());
        // A resumed search reads them back from the file.
        let again = PartSlopesLog::open(&dir.path().join("s.csv"), &names, true).unwrap();
        assert_eq!(again.take(&values_at(&centre)), part_slopes);
        let slopes = study.local_residual_slopes(&part_slopes, parts);
        let residuals = study.local_residuals(&outputs, parts);
        assert_eq!(slopes.len(), residuals.len() * 2);
        let h = 1e-5;
        for j in 0..2 {
            let moved = |by: f64| {
                let mut unit = centre;
                unit[j] += by;
                study.local_residuals(&at(&unit), parts)
            };
            let (up, down) = (moved(h), moved(-h));
            for k in 0..residuals.len() {
                let difference = (up[k] - down[k]) / (2.0 * h);
                let slope = slopes[k * 2 + j];
                assert!(
                    (slope - difference).abs() <= 1e-5 * difference.abs().max(1.0),
                    "residual {k}, parameter {j}: slope {slope}, difference {difference}"
                );
            }
        }
    }
}
