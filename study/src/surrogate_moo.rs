//! The excavator study's method, on any model: a design of experiments ->
//! one surrogate per output (a GP, compared with polynomials and a radial
//! basis function by RMSE on separate test runs) -> NSGA-II over the
//! objectives computed from the GP means -> TOPSIS picks one point of the
//! front -> the model is re-run there.
//!
//! The surrogates can be wrong where the front lies. While the re-run and
//! the GP disagree on an objective by more than a tolerance, the front's
//! best points (by the pick's ranking) become extra training runs and the
//! loop repeats, for a few rounds at most; every round is reported.
//!
//! Everything happens in the unit box of the parameters (their own scale,
//! linear or log), so a log-scale parameter is modelled and searched where
//! it varies evenly. Model runs go through the logging [`Evaluator`], so a
//! study is resumable: the designs are seeded and every later step depends
//! only on logged results.

use acq_algorithms::doe::{latin_hypercube, random_uniform};
use acq_algorithms::evaluation::{Evaluation, Evaluator, Parameter};
use acq_algorithms::gp::{Gp, GpSettings, Kernel};
use acq_algorithms::minimax::minimax_ranking;
use acq_algorithms::moo::{nsga2, Nsga2Result, Nsga2Settings};
use acq_algorithms::surrogate::{rmse, Polynomial, RadialBasis, Surrogate};
use acq_algorithms::topsis::{topsis_normalised, Criterion, Normalisation};
use acq_error::{AcqError, Result};

use super::run_directory::evaluation_error;
use super::search::{from_unit, to_unit};

/// How one point of the Pareto front is picked: `topsis` (the published
/// method: each objective normalised by its own spread over the front),
/// `topsis-common` (TOPSIS with one norm for all objectives, when they
/// share a unit) or `minimax` (the point whose largest weighted objective
/// is least: what a calibration judged by its worst error wants).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pick {
    Topsis(Normalisation),
    Minimax,
}

impl std::str::FromStr for Pick {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "topsis" => Ok(Pick::Topsis(Normalisation::PerCriterion)),
            "topsis-common" => Ok(Pick::Topsis(Normalisation::Common)),
            "minimax" => Ok(Pick::Minimax),
            other => Err(format!(
                "pick {other:?}: give topsis, topsis-common or minimax"
            )),
        }
    }
}

impl SurrogateMoo {
    /// How the pick was made, for a report: "the minimax pick (...)" or
    /// "the TOPSIS pick (closeness 0.640, ...)".
    pub fn pick_sentence(&self) -> String {
        let largest = self.front[self.pick]
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        match (self.picked_by, self.closeness) {
            (Pick::Minimax, _) => format!(
                "the minimax pick (least largest weighted objective; its largest objective on the GPs {largest:.3})"
            ),
            (Pick::Topsis(normalisation), closeness) => format!(
                "the TOPSIS pick ({} normalisation, closeness {:.3}; its largest objective on the GPs {largest:.3})",
                match normalisation {
                    Normalisation::PerCriterion => "per-objective",
                    Normalisation::Common => "common",
                },
                closeness.unwrap_or(f64::NAN)
            ),
        }
    }
}

impl std::fmt::Display for Pick {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Pick::Topsis(Normalisation::PerCriterion) => "topsis",
            Pick::Topsis(Normalisation::Common) => "topsis-common",
            Pick::Minimax => "minimax",
        })
    }
}

/// The method's knobs; the defaults are the published study's.
#[derive(Clone, Debug)]
pub struct SurrogateMooSettings {
    /// Maximin Latin-hypercube runs the surrogates learn from.
    pub training_runs: usize,
    /// Uniform random runs the surrogates are scored on.
    pub test_runs: usize,
    pub population: usize,
    pub generations: usize,
    /// Largest share of the NSGA-II population on the first front.
    pub pareto_fraction: f64,
    /// TOPSIS weights, one per objective (every objective is a cost).
    pub weights: Vec<f64>,
    /// How one point of the Pareto front is picked.
    pub pick: Pick,
    pub kernel: Kernel,
    pub seed: u64,
    /// Largest disagreement between the re-run and the GP on any
    /// objective, in the objectives' unit (percentage points), that ends
    /// the refinement.
    pub refine_tolerance: f64,
    /// Refinement rounds after the first pick, at most.
    pub refine_rounds: usize,
}

impl SurrogateMooSettings {
    /// The published settings for `objectives` equally weighted costs.
    pub fn published(objectives: usize, seed: u64) -> Self {
        SurrogateMooSettings {
            training_runs: 40,
            test_runs: 40,
            population: 400,
            generations: 100,
            pareto_fraction: 0.5,
            weights: vec![1.0; objectives],
            pick: Pick::Topsis(Normalisation::PerCriterion),
            kernel: Kernel::SquaredExponential,
            seed,
            refine_tolerance: 2.0,
            refine_rounds: 3,
        }
    }

    /// Model runs the method makes at most.
    pub fn budget(&self, parameters: usize) -> usize {
        1 + self.training_runs
            + self.test_runs
            + 1
            + self.refine_rounds * (refine_runs(parameters) + 1)
    }
}

/// Training runs added per refinement round.
fn refine_runs(parameters: usize) -> usize {
    (parameters + 1).max(5)
}

/// The surrogates compared per output, in the order of
/// [`SurrogateMoo::surrogate_rmse`].
pub const SURROGATE_NAMES: [&str; 5] = ["gp", "poly1", "poly2", "poly3", "rbf"];

/// One pick of the loop: how far the GP was from the model there.
#[derive(Clone, Debug)]
pub struct Round {
    /// Training runs the GPs of this round learned from.
    pub training_runs: usize,
    pub pick: Vec<f64>,
    /// Largest |objective(model) - objective(GP)| at the pick.
    pub disagreement: f64,
}

/// What the method found.
#[derive(Clone)]
pub struct SurrogateMoo {
    /// The model's outputs at the nominal point.
    pub nominal_outputs: Vec<f64>,
    /// The pick (parameter values) and the model's outputs there.
    pub optimal: Vec<f64>,
    pub optimal_outputs: Vec<f64>,
    /// The GP means at the pick.
    pub surrogate_at_optimal: Vec<f64>,
    /// (surrogate, RMSE per output on the test runs; NaN if it could not be fitted).
    pub surrogate_rmse: Vec<(String, Vec<f64>)>,
    /// The last round's front, as objective vectors, and the picked row.
    pub front: Vec<Vec<f64>>,
    pub pick: usize,
    /// How the pick was made, and its TOPSIS closeness (TOPSIS picks only).
    pub picked_by: Pick,
    pub closeness: Option<f64>,
    /// The last round's GPs, one per output, on unit-box inputs.
    pub gps: Vec<Gp>,
    pub test_runs: usize,
    pub failed_runs: usize,
    pub rounds: Vec<Round>,
}

/// Runs as (unit-box inputs, outputs), one row each.
type UnitRuns = (Vec<Vec<f64>>, Vec<Vec<f64>>);

/// The successful runs among `evaluations`: (unit-box inputs, outputs).
fn successful(parameters: &[Parameter], evaluations: &[Evaluation]) -> UnitRuns {
    evaluations
        .iter()
        .filter_map(|e| {
            let y = e.outcome.as_ref().ok()?;
            Some((to_unit(parameters, &e.parameters), y.clone()))
        })
        .unzip()
}

fn column(rows: &[Vec<f64>], k: usize) -> Vec<f64> {
    rows.iter().map(|r| r[k]).collect()
}

/// Runs the method. `objectives` maps a model's outputs to the costs
/// NSGA-II minimises (relative errors in %, curve MAPEs); `nominal` is the
/// point the initial errors are reported at.
pub fn surrogate_moo(
    evaluator: &mut Evaluator<'_>,
    parameters: &[Parameter],
    nominal: &[f64],
    objectives: &(dyn Fn(&[f64]) -> Vec<f64> + Sync),
    settings: &SurrogateMooSettings,
) -> Result<SurrogateMoo> {
    let dimensions = parameters.len();
    let output_names = evaluator.simulator().outputs().to_vec();
    let unit_box = vec![(0.0, 1.0); dimensions];
    let InitialRuns {
        nominal_outputs,
        mut train_x,
        mut train_y,
        test_x,
        test_y,
    } = initial_runs(evaluator, parameters, nominal, settings)?;
    let gp_settings = GpSettings {
        kernel: settings.kernel,
        ard: true,
        restarts: 5,
        seed: settings.seed,
        input_bounds: Some(unit_box.clone()),
        ..GpSettings::default()
    };
    let mut gps = fit_output_gps(&output_names, &gp_settings, &train_x, &train_y)?;
    let surrogate_rmse = compare_surrogates(&gps, &train_x, &train_y, &test_x, &test_y);

    let mut rounds = Vec::new();
    loop {
        let round = rounds.len();
        let front = pick_on_gp_front(&gps, objectives, &unit_box, settings, round)?;
        let pick_unit = front.moo.front[front.ranking[0]].x.clone();
        let pick = from_unit(parameters, &pick_unit);
        let rerun = evaluator
            .evaluate(std::slice::from_ref(&pick))
            .map_err(evaluation_error)?;
        let optimal_outputs = rerun[0].outcome.clone().map_err(|reason| {
            AcqError::Config(format!("the model fails at the calibrated point: {reason}"))
        })?;
        let surrogate_at_optimal = gp_means(&gps, &pick_unit);
        let disagreement = objectives(&optimal_outputs)
            .iter()
            .zip(objectives(&surrogate_at_optimal))
            .map(|(model, gp)| (model - gp).abs())
            .fold(0.0f64, f64::max);
        rounds.push(Round {
            training_runs: train_x.len(),
            pick: pick.clone(),
            disagreement,
        });
        let settled = !disagreement.is_finite() || disagreement <= settings.refine_tolerance;
        if settled || round >= settings.refine_rounds {
            let failed_runs = evaluator
                .evaluations()
                .iter()
                .filter(|e| e.outcome.is_err())
                .count();
            return Ok(SurrogateMoo {
                nominal_outputs,
                optimal: pick,
                optimal_outputs,
                surrogate_at_optimal,
                surrogate_rmse,
                front: front.objectives,
                pick: front.ranking[0],
                picked_by: settings.pick,
                closeness: front.closeness,
                gps,
                test_runs: test_x.len(),
                failed_runs,
                rounds,
            });
        }
        let (x, y) = runs_near_the_front(evaluator, parameters, &front, &train_x)?;
        train_x.extend(x);
        train_y.extend(y);
        train_x.push(pick_unit);
        train_y.push(optimal_outputs);
        gps = fit_output_gps(&output_names, &gp_settings, &train_x, &train_y)?;
    }
}

/// The runs before any surrogate: the model at the nominal point, and the
/// successful training and test runs (unit-box inputs, outputs).
struct InitialRuns {
    nominal_outputs: Vec<f64>,
    train_x: Vec<Vec<f64>>,
    train_y: Vec<Vec<f64>>,
    test_x: Vec<Vec<f64>>,
    test_y: Vec<Vec<f64>>,
}

/// Runs the nominal point, the seeded Latin-hypercube training design and
/// the uniform test design as one batch; an error when the nominal run
/// fails or too few training runs succeed for a surrogate.
fn initial_runs(
    evaluator: &mut Evaluator<'_>,
    parameters: &[Parameter],
    nominal: &[f64],
    settings: &SurrogateMooSettings,
) -> Result<InitialRuns> {
    let dimensions = parameters.len();
    let to_values = |units: &[Vec<f64>]| -> Vec<Vec<f64>> {
        units.iter().map(|u| from_unit(parameters, u)).collect()
    };
    let training_points = to_values(&latin_hypercube(
        settings.training_runs,
        dimensions,
        settings.seed,
    ));
    let test_points = to_values(&random_uniform(
        settings.test_runs,
        dimensions,
        settings.seed.wrapping_add(1),
    ));
    let mut batch = vec![nominal.to_vec()];
    batch.extend(training_points.iter().cloned());
    batch.extend(test_points.iter().cloned());
    let results = evaluator.evaluate(&batch).map_err(evaluation_error)?;
    let nominal_outputs = results[0].outcome.clone().map_err(|reason| {
        AcqError::Config(format!("the model fails at the nominal point: {reason}"))
    })?;
    let (train_x, train_y) = successful(parameters, &results[1..1 + training_points.len()]);
    let (test_x, test_y) = successful(parameters, &results[1 + training_points.len()..]);
    if train_x.len() < dimensions + 2 {
        return Err(AcqError::Config(format!(
            "only {} of {} training runs of the model succeeded; a surrogate needs at least {}. Check the bounds",
            train_x.len(),
            training_points.len(),
            dimensions + 2
        )));
    }
    Ok(InitialRuns {
        nominal_outputs,
        train_x,
        train_y,
        test_x,
        test_y,
    })
}

/// One GP per output, fitted to the training runs.
fn fit_output_gps(
    output_names: &[String],
    gp_settings: &GpSettings,
    x: &[Vec<f64>],
    y: &[Vec<f64>],
) -> Result<Vec<Gp>> {
    (0..output_names.len())
        .map(|k| {
            Gp::fit(x, &column(y, k), gp_settings)
                .map_err(|e| AcqError::Config(format!("GP of output {}: {e}", output_names[k])))
        })
        .collect()
}

/// The GP means at a unit-box point: the surrogate's outputs.
fn gp_means(gps: &[Gp], unit: &[f64]) -> Vec<f64> {
    gps.iter().map(|gp| gp.predict(unit).mean).collect()
}

/// One round's Pareto front on the GPs and its rows best first.
struct GpFront {
    moo: Nsga2Result,
    /// The front as objective vectors.
    objectives: Vec<Vec<f64>>,
    /// The front's rows best first by the pick.
    ranking: Vec<usize>,
    /// The TOPSIS closeness of the first (TOPSIS picks only).
    closeness: Option<f64>,
}

/// NSGA-II over the objectives of the GP means (seeded by the round), and
/// the front ranked by TOPSIS or minimax.
fn pick_on_gp_front(
    gps: &[Gp],
    objectives: &(dyn Fn(&[f64]) -> Vec<f64> + Sync),
    unit_box: &[(f64, f64)],
    settings: &SurrogateMooSettings,
    round: usize,
) -> Result<GpFront> {
    let nsga_settings = Nsga2Settings {
        population: settings.population,
        generations: settings.generations,
        pareto_fraction: settings.pareto_fraction,
        seed: settings.seed.wrapping_add(round as u64),
        ..Nsga2Settings::default()
    };
    let moo = nsga2(|u| objectives(&gp_means(gps, u)), unit_box, &nsga_settings)
        .map_err(|e| AcqError::Config(e.to_string()))?;
    if moo.front.is_empty() {
        return Err(AcqError::Config(
            "NSGA-II found no finite Pareto point".into(),
        ));
    }
    let front: Vec<Vec<f64>> = moo.front.iter().map(|i| i.objectives.clone()).collect();
    let criteria = vec![Criterion::Cost; front[0].len()];
    let (ranking, closeness) = match settings.pick {
        Pick::Topsis(normalisation) => {
            topsis_normalised(&front, &settings.weights, &criteria, normalisation)
                .map(|t| (t.ranking, Some(t.closeness[t.best])))
        }
        Pick::Minimax => minimax_ranking(&front, &settings.weights).map(|r| (r, None)),
    }
    .map_err(|e| AcqError::Config(e.to_string()))?;
    Ok(GpFront {
        moo,
        objectives: front,
        ranking,
        closeness,
    })
}

/// Teaches the GPs where the front is: runs the front's best points after
/// the pick, by the pick's ranking, that are not training runs yet, and
/// returns the successful ones (unit-box inputs, outputs).
fn runs_near_the_front(
    evaluator: &mut Evaluator<'_>,
    parameters: &[Parameter],
    front: &GpFront,
    train_x: &[Vec<f64>],
) -> Result<UnitRuns> {
    let mut extra: Vec<Vec<f64>> = front
        .ranking
        .iter()
        .skip(1)
        .map(|&row| from_unit(parameters, &front.moo.front[row].x))
        .filter(|x| !train_x.contains(&to_unit(parameters, x)))
        .take(refine_runs(parameters.len()))
        .collect();
    extra.dedup();
    let added = evaluator.evaluate(&extra).map_err(evaluation_error)?;
    Ok(successful(parameters, &added))
}

/// RMSE on the test runs of each surrogate kind, per output.
fn compare_surrogates(
    gps: &[Gp],
    train_x: &[Vec<f64>],
    train_y: &[Vec<f64>],
    test_x: &[Vec<f64>],
    test_y: &[Vec<f64>],
) -> Vec<(String, Vec<f64>)> {
    let unit_box = vec![(0.0, 1.0); train_x.first().map_or(0, Vec::len)];
    let mut rows: Vec<Vec<f64>> = vec![Vec::new(); SURROGATE_NAMES.len()];
    for (k, gp) in gps.iter().enumerate() {
        let y = column(train_y, k);
        let truth = column(test_y, k);
        let mut candidates: Vec<Option<Box<dyn Surrogate>>> = vec![Some(Box::new(gp.clone()))];
        for degree in 1..=3 {
            candidates.push(
                Polynomial::fit(train_x, &y, degree, Some(&unit_box))
                    .ok()
                    .map(|p| Box::new(p) as Box<dyn Surrogate>),
            );
        }
        candidates.push(
            RadialBasis::fit(train_x, &y, Some(&unit_box))
                .ok()
                .map(|r| Box::new(r) as Box<dyn Surrogate>),
        );
        for (row, candidate) in rows.iter_mut().zip(&candidates) {
            row.push(match candidate {
                Some(s) if !test_x.is_empty() => rmse(s.as_ref(), test_x, &truth),
                _ => f64::NAN,
            });
        }
    }
    SURROGATE_NAMES
        .iter()
        .map(|name| name.to_string())
        .zip(rows)
        .collect()
}

/// The refinement rounds in one sentence for a report.
pub fn rounds_sentence(rounds: &[Round]) -> String {
    let each: Vec<String> = rounds
        .iter()
        .map(|r| {
            // Significant digits: a disagreement of 4e-5 is no "0.000".
            format!(
                "{} ({})",
                acq_report::number::significant(r.disagreement, 2),
                acq_report::number::count(r.training_runs, "training run")
            )
        })
        .collect();
    match rounds.len() {
        0 => String::new(),
        1 => format!(
            "At the pick the model and the GPs agreed within {} on every objective.",
            each[0]
        ),
        n => format!(
            "The GPs were refined {} time(s) near the front; the largest model-GP disagreement on an objective at each pick: {}.",
            n - 1,
            each.join(", ")
        ),
    }
}
