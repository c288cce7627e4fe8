//! Bayesian optimisation that **minimises** a loss over the unit box.
//!
//! Each iteration fits a GP ([`crate::gp`]) to the losses seen so far and
//! proposes the point(s) that maximise an acquisition:
//!
//! - [`Acquisition::LowerConfidenceBound`]: `-(mu - kappa sigma)`, the
//!   minimising form of the published UCB `mu + kappa sigma` (kappa 2.5).
//!   The published code maximised `+MAPE`, i.e. searched for high error;
//!   here the sign is the right one, and the parameters live in the unit box
//!   (the published ones were unscaled, m spanning 0..800 beside f0 spanning
//!   0.0013..0.0015).
//! - [`Acquisition::ExpectedImprovement`] below the best loss, and its
//!   logarithm [`Acquisition::LogExpectedImprovement`] (Ament et al. 2023),
//!   which stays informative where EI underflows to 0.
//!
//! The acquisition is maximised by random sampling (`random_candidates`
//! uniform points plus Gaussian perturbations of the best points seen) and
//! then multistart L-BFGS-B ([`crate::optim`]) from the `local_starts` best
//! candidates, with the GP's analytic input gradients.
//!
//! A batch of q > 1 points per iteration (several simulator licences at
//! once) comes from the *kriging believer*: after each pick, the GP is refit
//! with its own mean at the pick as if observed, so the next pick goes
//! elsewhere.
//!
//! When the runs also return residuals (a curve's signed errors along its
//! length) and [`BoSettings::local_steps`] is set, local Gauss-Newton steps
//! in a trust region ([`crate::trust_region`]) replace the global ones
//! while the local search makes progress; the global steps come back when
//! its trust region has shrunk to nothing or its model sees no better
//! point.
//!
//! Losses are modelled as `ln(loss)` when all are positive (a MAPE spans
//! decades, and the interesting region is its low end), otherwise as is.
//! A failed evaluation is imputed pessimistically but locally: the GP of the
//! successful ones predicts it, and it enters the fit at its mean plus one
//! standard deviation. The search then does not propose it again (its
//! uncertainty is gone) without branding the whole neighbourhood as bad, as
//! imputing the worst loss seen would (a failure next to the optimum would
//! hide the optimum). The run stops at a target loss, at a maximum number of
//! evaluations, or when `patience` evaluations in a row improved the best
//! loss by less than `min_improvement` (relative).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::gp::{Gp, GpError, GpSettings, Kernel};
use crate::optim::{minimize_bounded, LbfgsSettings};
use crate::trust_region::{Run, TrustRegion, TrustRegionSettings};

/// What the next point should maximise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Acquisition {
    /// `-(mu - kappa sigma)`.
    LowerConfidenceBound { kappa: f64 },
    /// `E[max(best - y - xi, 0)]`.
    ExpectedImprovement { xi: f64 },
    /// `ln E[max(best - y - xi, 0)]`, computed without underflow.
    LogExpectedImprovement { xi: f64 },
}

impl std::str::FromStr for Acquisition {
    type Err = String;
    /// `ucb`, `ucb:KAPPA`, `ei`, `logei`.
    fn from_str(text: &str) -> Result<Self, String> {
        let (name, value) = text.split_once(':').unwrap_or((text, ""));
        let number = |default: f64| -> Result<f64, String> {
            if value.is_empty() {
                Ok(default)
            } else {
                value
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite() && *v >= 0.0)
                    .ok_or_else(|| format!("{value:?} is not a non-negative number"))
            }
        };
        match name {
            "ucb" | "lcb" => Ok(Acquisition::LowerConfidenceBound {
                kappa: number(2.5)?,
            }),
            "ei" => Ok(Acquisition::ExpectedImprovement { xi: number(0.0)? }),
            "logei" => Ok(Acquisition::LogExpectedImprovement { xi: number(0.0)? }),
            _ => Err(format!(
                "unknown acquisition {text:?}; use ucb[:KAPPA], ei[:XI] or logei[:XI]"
            )),
        }
    }
}

/// How the optimisation runs.
#[derive(Clone, Debug)]
pub struct BoSettings {
    pub acquisition: Acquisition,
    /// Points proposed per iteration (kriging believer for q > 1).
    pub batch: usize,
    /// Random candidates per pick (the published N_R was 50,000).
    pub random_candidates: usize,
    /// L-BFGS-B starts per pick (the published N_O was 500).
    pub local_starts: usize,
    /// Stop when the best loss is at or below this.
    pub target_loss: Option<f64>,
    /// Stop after this many evaluations (the initial design included).
    pub max_evaluations: usize,
    /// Stop when this many evaluations in a row improved the best loss by
    /// less than `min_improvement` (relative); `None` never.
    pub patience: Option<usize>,
    pub min_improvement: f64,
    /// The surrogate; `input_bounds` is forced to the unit box.
    pub gp: GpSettings,
    /// Model `ln(loss)` when every loss is positive.
    pub log_transform: bool,
    pub seed: u64,
    /// Local trust-region steps on the runs' residuals between the global
    /// ones; `None`: global steps only.
    pub local_steps: Option<TrustRegionSettings>,
}

impl Default for BoSettings {
    fn default() -> Self {
        BoSettings {
            acquisition: Acquisition::LogExpectedImprovement { xi: 0.0 },
            batch: 1,
            random_candidates: 5_000,
            local_starts: 10,
            target_loss: None,
            max_evaluations: 100,
            patience: None,
            min_improvement: 1e-3,
            // Simulators are deterministic: the noise term only absorbs
            // rounding and the roughness of the loss, so it is kept small
            // (a large fitted noise smooths the optimum away).
            gp: GpSettings {
                kernel: Kernel::Matern52,
                ard: true,
                restarts: 3,
                noise_bounds: (1e-10, 1e-3),
                ..GpSettings::default()
            },
            log_transform: true,
            seed: 0,
            local_steps: None,
        }
    }
}

/// Why the optimisation stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Stop {
    TargetReached,
    MaxEvaluations,
    NoProgress,
}

impl Stop {
    /// Why, in words for a report ("it stopped when ...").
    pub fn words(self) -> &'static str {
        match self {
            Stop::TargetReached => "the target loss was reached",
            Stop::MaxEvaluations => "its budget of runs was spent",
            Stop::NoProgress => "the last runs no longer improved the best loss",
        }
    }
}

/// Why a proposal could not be made.
#[derive(Debug, thiserror::Error)]
pub enum BoError {
    #[error("Bayesian optimisation needs at least 2 successful evaluations to fit its GP; the initial design gave {0}")]
    TooFewObservations(usize),
    #[error("points must lie in the unit box of {dimensions} dimensions: {detail}")]
    BadPoint { dimensions: usize, detail: String },
    #[error("invalid settings: {0}")]
    Settings(String),
    #[error("the GP of the losses could not be fitted: {0}")]
    Gp(#[from] GpError),
}

/// One observation: a point of the unit box and its loss (`None`: failed).
#[derive(Clone, Debug, PartialEq)]
pub struct Observation {
    pub unit_point: Vec<f64>,
    pub loss: Option<f64>,
    /// The residuals behind the loss, for local steps (empty: none).
    pub residuals: Vec<f64>,
    /// Their slopes in the unit box, when the run gave them (see
    /// [`Outcome::slopes`]).
    pub slopes: Vec<f64>,
}

impl Observation {
    pub fn new(unit_point: Vec<f64>, outcome: Option<Outcome>) -> Self {
        let (loss, residuals, slopes) = match outcome {
            Some(outcome) => (Some(outcome.loss), outcome.residuals, outcome.slopes),
            None => (None, Vec::new(), Vec::new()),
        };
        Observation {
            unit_point,
            loss,
            residuals,
            slopes,
        }
    }
}

/// What a successful run gave: its loss, and optionally the residuals it
/// comes from (for [`BoSettings::local_steps`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    pub loss: f64,
    pub residuals: Vec<f64>,
    /// Each residual's derivative in each unit-box coordinate, row by row
    /// (residuals x dimensions), for a model differentiated along with its
    /// run; empty otherwise (the local steps then fit them to the runs).
    pub slopes: Vec<f64>,
}

impl From<f64> for Outcome {
    fn from(loss: f64) -> Self {
        Outcome {
            loss,
            residuals: Vec::new(),
            slopes: Vec::new(),
        }
    }
}

/// Picks each next point: the trust region's local step when it is its
/// turn, the acquisition's otherwise.
struct NextPoints {
    trust_region: Option<TrustRegion>,
}

impl NextPoints {
    fn new(settings: &BoSettings) -> Self {
        NextPoints {
            trust_region: settings.local_steps.clone().map(TrustRegion::new),
        }
    }

    fn propose(
        &mut self,
        observations: &[Observation],
        pending: &[Vec<f64>],
        settings: &BoSettings,
        iteration: u64,
    ) -> Result<Vec<Vec<f64>>, BoError> {
        let local = self.trust_region.as_mut().and_then(|trust_region| {
            let runs: Vec<Run<'_>> = observations
                .iter()
                .filter_map(|o| {
                    o.loss.map(|loss| Run {
                        unit_point: &o.unit_point,
                        loss,
                        residuals: &o.residuals,
                        slopes: &o.slopes,
                    })
                })
                .collect();
            trust_region.propose(&runs)
        });
        let Some(local) = local else {
            return propose_beside(observations, pending, settings, iteration);
        };
        let mut points = vec![local.clone()];
        if settings.batch > 1 {
            let mut beside = pending.to_vec();
            beside.push(local);
            let rest = BoSettings {
                batch: settings.batch - 1,
                ..settings.clone()
            };
            points.extend(propose_beside(observations, &beside, &rest, iteration)?);
        }
        Ok(points)
    }

    fn record(&mut self, observation: &Observation) {
        if let Some(trust_region) = &mut self.trust_region {
            trust_region.record(
                &observation.unit_point,
                observation.loss,
                &observation.residuals,
            );
        }
    }
}

/// The whole history of a run and how it ended.
#[derive(Clone, Debug)]
pub struct BoResult {
    pub observations: Vec<Observation>,
    /// Index of the best (lowest) loss.
    pub best: usize,
    pub stop: Stop,
    /// Evaluations made when the target was first reached.
    pub evaluations_to_target: Option<usize>,
}

/// Standard normal density and distribution.
fn normal_pdf(z: f64) -> f64 {
    (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

fn normal_cdf(z: f64) -> f64 {
    0.5 * libm::erfc(-z / std::f64::consts::SQRT_2)
}

/// `ln h(z)` and `d ln h / dz` for `h(z) = phi(z) + z Phi(z)` (EI = sigma h).
/// Down to z = -10 directly (the cancellation in `phi + z Phi` costs at most
/// 2 digits there); below, the asymptotic series
/// `h ~ phi(z)/z^2 (1 - 3/z^2 + 15/z^4 - 105/z^6)` (relative error below
/// 945/z^8 = 1e-5) keeps it finite where phi and Phi underflow
/// (dh/dz = Phi).
pub(crate) fn log_h(z: f64) -> (f64, f64) {
    if z > -10.0 {
        let h = normal_pdf(z) + z * normal_cdf(z);
        (h.ln(), normal_cdf(z) / h)
    } else {
        let w = 1.0 / (z * z);
        let series = 1.0 - 3.0 * w + 15.0 * w * w - 105.0 * w * w * w;
        let log_pdf = -0.5 * z * z - 0.5 * (2.0 * std::f64::consts::PI).ln();
        let log_h = log_pdf - (z * z).ln() + series.ln();
        // Phi(z)/h(z) ~ |z| (1 - 1/z^2 + 3/z^4) / series, from the same series.
        let cdf_series = 1.0 - w + 3.0 * w * w - 15.0 * w * w * w;
        (log_h, -z * cdf_series / series)
    }
}

/// The acquisition (to maximise) and its gradient at `x`, given the GP of
/// the modelled losses and the best modelled loss.
fn acquisition_value(
    acquisition: Acquisition,
    gp: &Gp,
    best_modelled: f64,
    x: &[f64],
    gradient: Option<&mut [f64]>,
) -> f64 {
    let want_gradient = gradient.is_some();
    let (mean, std, mean_gradient, std_gradient) = if want_gradient {
        let p = gp.predict_with_gradient(x);
        (p.mean, p.std, p.mean_gradient, p.std_gradient)
    } else {
        let p = gp.predict(x);
        (p.mean, p.std, Vec::new(), Vec::new())
    };
    // d acquisition / d mean and / d std.
    let (value, by_mean, by_std) = match acquisition {
        Acquisition::LowerConfidenceBound { kappa } => (-(mean - kappa * std), -1.0, kappa),
        Acquisition::ExpectedImprovement { xi } | Acquisition::LogExpectedImprovement { xi } => {
            let improvement = best_modelled - mean - xi;
            let log = matches!(acquisition, Acquisition::LogExpectedImprovement { .. });
            if std <= 1e-12 {
                // No uncertainty: EI is the plain improvement.
                let ei = improvement.max(0.0);
                if log {
                    (ei.max(1e-300).ln(), -1.0 / ei.max(1e-300), 0.0)
                } else {
                    (ei, if ei > 0.0 { -1.0 } else { 0.0 }, 0.0)
                }
            } else {
                let z = improvement / std;
                if log {
                    let (log_h, cdf_over_h) = log_h(z);
                    // ln EI = ln std + ln h(z); dz/dmean = -1/std, dz/dstd = -z/std.
                    (
                        std.ln() + log_h,
                        -cdf_over_h / std,
                        1.0 / std - cdf_over_h * z / std,
                    )
                } else {
                    let (pdf, cdf) = (normal_pdf(z), normal_cdf(z));
                    (improvement * cdf + std * pdf, -cdf, pdf)
                }
            }
        }
    };
    if let Some(gradient) = gradient {
        for (k, g) in gradient.iter_mut().enumerate() {
            *g = by_mean * mean_gradient[k] + by_std * std_gradient[k];
        }
    }
    value
}

/// A unit-box point with its modelled loss.
type ModelledPoint = (Vec<f64>, f64);

/// The successful losses as modelled (log or identity), and the points
/// that failed.
fn modelled_losses(
    observations: &[Observation],
    log_transform: bool,
) -> (Vec<ModelledPoint>, Vec<Vec<f64>>) {
    let use_log = log_transform && observations.iter().filter_map(|o| o.loss).all(|l| l > 0.0);
    let mut successes = Vec::new();
    let mut failures = Vec::new();
    for o in observations {
        match o.loss {
            Some(loss) => {
                successes.push((o.unit_point.clone(), if use_log { loss.ln() } else { loss }))
            }
            None => failures.push(o.unit_point.clone()),
        }
    }
    (successes, failures)
}

fn fit(points: &[(Vec<f64>, f64)], settings: &GpSettings) -> Result<Gp, GpError> {
    let inputs: Vec<Vec<f64>> = points.iter().map(|p| p.0.clone()).collect();
    let outputs: Vec<f64> = points.iter().map(|p| p.1).collect();
    Gp::fit(&inputs, &outputs, settings)
}

/// The next `settings.batch` points of the unit box to evaluate.
///
/// # Errors
/// Fewer than 2 successful observations, points outside the unit box, a GP
/// that cannot be fitted.
pub fn propose(
    observations: &[Observation],
    settings: &BoSettings,
    iteration: u64,
) -> Result<Vec<Vec<f64>>, BoError> {
    propose_beside(observations, &[], settings, iteration)
}

/// The next `settings.batch` points, given points still being evaluated
/// (`pending`): each is believed to give the GP's mean there (kriging
/// believer), so the proposals keep away from them.
///
/// # Errors
/// As [`propose`].
pub fn propose_beside(
    observations: &[Observation],
    pending: &[Vec<f64>],
    settings: &BoSettings,
    iteration: u64,
) -> Result<Vec<Vec<f64>>, BoError> {
    let dimensions = observations.first().map_or(0, |o| o.unit_point.len());
    if dimensions == 0 {
        return Err(BoError::TooFewObservations(0));
    }
    for o in observations {
        if o.unit_point.len() != dimensions || o.unit_point.iter().any(|v| !(0.0..=1.0).contains(v))
        {
            return Err(BoError::BadPoint {
                dimensions,
                detail: format!("{:?}", o.unit_point),
            });
        }
    }
    let successes = observations.iter().filter(|o| o.loss.is_some()).count();
    if successes < 2 {
        return Err(BoError::TooFewObservations(successes));
    }
    if settings.batch == 0 || settings.local_starts == 0 && settings.random_candidates == 0 {
        return Err(BoError::Settings(
            "batch, and random candidates or local starts, must be at least 1".into(),
        ));
    }
    let gp_settings = GpSettings {
        input_bounds: Some(vec![(0.0, 1.0); dimensions]),
        seed: settings.gp.seed ^ iteration,
        ..settings.gp.clone()
    };
    let (mut points, failures) = modelled_losses(observations, settings.log_transform);
    let best_modelled = points.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed ^ iteration.wrapping_mul(0x9E37_79B9));
    let mut gp = fit(&points, &gp_settings)?;
    if !failures.is_empty() {
        for x in failures {
            let p = gp.predict(&x);
            points.push((x, p.mean + p.std));
        }
        gp = fit(&points, &gp_settings)?;
    }
    if !pending.is_empty() {
        gp = believe(&mut points, pending, &gp, &gp_settings)?;
    }
    let mut batch = Vec::with_capacity(settings.batch);
    for pick in 0..settings.batch {
        let x = maximise_acquisition(&gp, best_modelled, &points, settings, &mut rng);
        batch.push(x.clone());
        if pick + 1 < settings.batch {
            gp = believe(&mut points, &[x], &gp, &gp_settings)?;
        }
    }
    Ok(batch)
}

/// Kriging believer: pretends the GP's mean was observed at each of `xs`
/// (points proposed but not evaluated yet) and refits, so the next
/// proposal keeps away from them.
fn believe(
    points: &mut Vec<ModelledPoint>,
    xs: &[Vec<f64>],
    gp: &Gp,
    settings: &GpSettings,
) -> Result<Gp, GpError> {
    for x in xs {
        points.push((x.clone(), gp.predict(x).mean));
    }
    fit(
        points,
        &GpSettings {
            restarts: 1,
            ..settings.clone()
        },
    )
}

/// Random sampling, then L-BFGS-B from the best candidates.
fn maximise_acquisition(
    gp: &Gp,
    best_modelled: f64,
    points: &[(Vec<f64>, f64)],
    settings: &BoSettings,
    rng: &mut ChaCha8Rng,
) -> Vec<f64> {
    let acquisition = settings.acquisition;
    let search = BoxSearch {
        random_candidates: settings.random_candidates,
        local_starts: settings.local_starts,
    };
    let (_, mut best) = search.maximise(
        |x, gradient| acquisition_value(acquisition, gp, best_modelled, x, gradient),
        points,
        rng,
    );
    // Never propose a point already observed (a GP with no noise would
    // learn nothing): nudge it off by a tiny random step.
    let duplicate = points
        .iter()
        .any(|p| p.0.iter().zip(&best).all(|(a, b)| (a - b).abs() < 1e-9));
    if duplicate {
        for v in best.iter_mut() {
            *v = (*v + 1e-4 * standard_normal(rng)).clamp(0.0, 1.0);
        }
    }
    best
}

/// How an acquisition is maximised over the unit box.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoxSearch {
    pub random_candidates: usize,
    pub local_starts: usize,
}

impl BoxSearch {
    /// The maximum of `value(x, gradient)` (the gradient written when
    /// asked for) over the unit box, and where: random candidates plus
    /// perturbations of the five lowest of `points` (point, modelled loss),
    /// then L-BFGS-B from the best candidates. A NaN value counts as
    /// minus infinity.
    pub(crate) fn maximise(
        &self,
        value: impl Fn(&[f64], Option<&mut [f64]>) -> f64,
        points: &[(Vec<f64>, f64)],
        rng: &mut ChaCha8Rng,
    ) -> (f64, Vec<f64>) {
        let dimensions = points[0].0.len();
        let mut candidates: Vec<Vec<f64>> = (0..self.random_candidates)
            .map(|_| (0..dimensions).map(|_| rng.random::<f64>()).collect())
            .collect();
        // Local candidates around the best points: the optimum of a smooth
        // loss is usually near its best observations.
        let mut order: Vec<usize> = (0..points.len()).collect();
        order.sort_by(|&a, &b| points[a].1.total_cmp(&points[b].1));
        for &i in order.iter().take(5) {
            for scale in [0.01, 0.05, 0.15] {
                for _ in 0..20 {
                    let x: Vec<f64> = points[i]
                        .0
                        .iter()
                        .map(|&v| (v + scale * standard_normal(rng)).clamp(0.0, 1.0))
                        .collect();
                    candidates.push(x);
                }
            }
        }
        let mut scored: Vec<(f64, Vec<f64>)> = candidates
            .into_iter()
            .map(|x| {
                let v = value(&x, None);
                (if v.is_nan() { f64::NEG_INFINITY } else { v }, x)
            })
            .collect();
        scored.sort_by(|a, b| b.0.total_cmp(&a.0));
        let lower = vec![0.0; dimensions];
        let upper = vec![1.0; dimensions];
        let lbfgs = LbfgsSettings {
            max_iterations: 100,
            gradient_tolerance: 1e-8,
            relative_tolerance: 1e-12,
            ..LbfgsSettings::default()
        };
        let mut best = scored[0].clone();
        for (_, start) in scored.iter().take(self.local_starts.max(1)) {
            let minimum = minimize_bounded(
                |x, gradient| {
                    let v = value(x, Some(&mut *gradient));
                    for g in gradient.iter_mut() {
                        *g = -*g;
                    }
                    -v
                },
                start,
                &lower,
                &upper,
                &lbfgs,
            );
            if let Ok(minimum) = minimum {
                if -minimum.value > best.0 {
                    best = (-minimum.value, minimum.x);
                }
            }
        }
        best
    }
}

/// A standard normal draw (Box-Muller).
pub(crate) fn standard_normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Runs the whole optimisation: evaluates `initial` (unit-box points), then
/// proposes and evaluates batches until a stop criterion holds. `evaluate`
/// gets a batch of unit-box points and returns each loss, or [`Outcome`]
/// with residuals (`None`: failed); its error ends the run.
///
/// # Errors
/// The evaluator's error, or a proposal that cannot be made.
pub fn minimise<E: From<BoError>, O: Into<Outcome>>(
    initial: Vec<Vec<f64>>,
    mut evaluate: impl FnMut(&[Vec<f64>]) -> Result<Vec<Option<O>>, E>,
    settings: &BoSettings,
) -> Result<BoResult, E> {
    let mut observations: Vec<Observation> = Vec::new();
    let mut evaluations_to_target = None;
    let target = settings.target_loss;
    let mut next_points = NextPoints::new(settings);
    let record = |points: Vec<Vec<f64>>,
                  outcomes: Vec<Option<O>>,
                  next_points: &mut NextPoints,
                  observations: &mut Vec<Observation>,
                  evaluations_to_target: &mut Option<usize>| {
        for (unit_point, outcome) in points.into_iter().zip(outcomes) {
            let observation = Observation::new(unit_point, outcome.map(Into::into));
            let loss = observation.loss;
            next_points.record(&observation);
            observations.push(observation);
            let reached = target.is_some_and(|t| loss.is_some_and(|l| l <= t));
            if evaluations_to_target.is_none() && reached {
                *evaluations_to_target = Some(observations.len());
            }
        }
    };
    let initial: Vec<Vec<f64>> = initial
        .into_iter()
        .take(settings.max_evaluations.max(1))
        .collect();
    let losses = evaluate(&initial)?;
    record(
        initial,
        losses,
        &mut next_points,
        &mut observations,
        &mut evaluations_to_target,
    );

    let mut best_so_far = f64::INFINITY;
    let mut since_progress = 0usize;
    let mut iteration = 0u64;
    let stop = loop {
        let best = observations
            .iter()
            .filter_map(|o| o.loss)
            .fold(f64::INFINITY, f64::min);
        if evaluations_to_target.is_some() {
            break Stop::TargetReached;
        }
        if observations.len() >= settings.max_evaluations {
            break Stop::MaxEvaluations;
        }
        if best < best_so_far - settings.min_improvement * best_so_far.abs() {
            best_so_far = best;
            since_progress = 0;
        }
        if settings.patience.is_some_and(|p| since_progress >= p) {
            break Stop::NoProgress;
        }
        iteration += 1;
        let room = settings.max_evaluations - observations.len();
        let batch_settings = BoSettings {
            batch: settings.batch.min(room),
            ..settings.clone()
        };
        let points = next_points
            .propose(&observations, &[], &batch_settings, iteration)
            .map_err(E::from)?;
        let count = points.len();
        let losses = evaluate(&points)?;
        record(
            points,
            losses,
            &mut next_points,
            &mut observations,
            &mut evaluations_to_target,
        );
        since_progress += count;
    };
    Ok(BoResult {
        best: best_index(&observations),
        observations,
        stop,
        evaluations_to_target,
    })
}

/// The index of the lowest loss (0 when none succeeded).
fn best_index(observations: &[Observation]) -> usize {
    observations
        .iter()
        .enumerate()
        .filter_map(|(i, o)| o.loss.map(|l| (i, l)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0, |(i, _)| i)
}

/// A finished unit-box point and its outcome (`None`: the run failed).
pub type Finished = (Vec<f64>, Option<Outcome>);

/// Where [`minimise_as_they_finish`] runs its points: start one, and take
/// whichever running point finishes next.
pub trait RunsAsTheyFinish<E> {
    /// Starts evaluating a unit-box point.
    fn start(&mut self, unit_point: Vec<f64>) -> Result<(), E>;
    /// The next point to finish and its loss (`None`: it failed), or
    /// `None` when nothing is running.
    fn next_done(&mut self) -> Result<Option<Finished>, E>;
}

/// [`minimise`] with `slots` evaluations always running: the start design
/// fills the slots, and whenever one finishes the next point is proposed
/// at once, beside the points still running ([`propose_beside`]). No slot
/// waits for the slowest run of a batch. With one slot it proposes exactly
/// as [`minimise`] with batches of one.
///
/// The stop criteria are those of [`minimise`]; points still running when
/// one holds are waited for and recorded.
///
/// # Errors
/// The runner's error, or a proposal that cannot be made.
pub fn minimise_as_they_finish<E: From<BoError>>(
    initial: Vec<Vec<f64>>,
    runs: &mut impl RunsAsTheyFinish<E>,
    slots: usize,
    settings: &BoSettings,
) -> Result<BoResult, E> {
    let slots = slots.max(1);
    let mut observations: Vec<Observation> = Vec::new();
    let mut evaluations_to_target = None;
    let mut queue: std::collections::VecDeque<Vec<f64>> = initial
        .into_iter()
        .take(settings.max_evaluations.max(1))
        .collect();
    let mut running: Vec<Vec<f64>> = Vec::new();
    let mut stop = None;
    let mut best_so_far = f64::INFINITY;
    let mut since_progress = 0usize;
    let mut iteration = 0u64;
    let one_at_a_time = BoSettings {
        batch: 1,
        ..settings.clone()
    };
    let mut next_points = NextPoints::new(settings);
    loop {
        while stop.is_none()
            && running.len() < slots
            && observations.len() + running.len() < settings.max_evaluations
        {
            let point = match queue.pop_front() {
                Some(point) => point,
                None if observations.iter().filter(|o| o.loss.is_some()).count() >= 2 => {
                    iteration += 1;
                    let mut proposed = next_points
                        .propose(&observations, &running, &one_at_a_time, iteration)
                        .map_err(E::from)?;
                    proposed.remove(0)
                }
                // The start design has not given two successes yet: wait.
                None => break,
            };
            runs.start(point.clone())?;
            running.push(point);
        }
        let Some((unit_point, outcome)) = runs.next_done()? else {
            break;
        };
        if let Some(index) = running.iter().position(|p| *p == unit_point) {
            running.remove(index);
        }
        let observation = Observation::new(unit_point, outcome);
        let loss = observation.loss;
        next_points.record(&observation);
        observations.push(observation);
        if queue.is_empty() {
            since_progress += 1;
        }
        if evaluations_to_target.is_none()
            && settings
                .target_loss
                .is_some_and(|t| loss.is_some_and(|l| l <= t))
        {
            evaluations_to_target = Some(observations.len());
            stop.get_or_insert(Stop::TargetReached);
        }
        let best = observations
            .iter()
            .filter_map(|o| o.loss)
            .fold(f64::INFINITY, f64::min);
        if best < best_so_far - settings.min_improvement * best_so_far.abs() {
            best_so_far = best;
            since_progress = 0;
        }
        if settings.patience.is_some_and(|p| since_progress >= p) {
            stop.get_or_insert(Stop::NoProgress);
        }
        if observations.len() >= settings.max_evaluations {
            stop.get_or_insert(Stop::MaxEvaluations);
        }
        if running.is_empty()
            && queue.is_empty()
            && stop.is_none()
            && observations.iter().filter(|o| o.loss.is_some()).count() < 2
        {
            return Err(E::from(BoError::TooFewObservations(
                observations.iter().filter(|o| o.loss.is_some()).count(),
            )));
        }
    }
    Ok(BoResult {
        best: best_index(&observations),
        observations,
        stop: stop.unwrap_or(Stop::MaxEvaluations),
        evaluations_to_target,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `ln h(z)` and `Phi(z)/h(z)` from mpmath at 50 digits.
    #[test]
    fn log_h_matches_high_precision_values() {
        let golden = [
            (1.0, 0.080_026_218_849_306_94, 0.776_638_725_201_739_3),
            (-3.0, -7.869_686_059_603_028, 3.532_337_517_625_16),
            (-8.0, -37.122_364_261_692_63, 8.239_396_506_840_07),
            (-12.0, -77.909_100_545_007_35, 12.163_352_571_585_74),
            (-30.0, -457.724_653_760_598, 30.066_446_154_162_42),
        ];
        for (z, log_h_expected, ratio_expected) in golden {
            let (log_h_value, ratio) = log_h(z);
            assert!(
                (log_h_value - log_h_expected).abs() < 1e-5 * log_h_expected.abs().max(1.0),
                "z {z}: {log_h_value} vs {log_h_expected}"
            );
            assert!(
                (ratio - ratio_expected).abs() < 1e-5 * ratio_expected,
                "z {z}: {ratio} vs {ratio_expected}"
            );
        }
    }
}
