//! Two fidelities of one model, a cheap and an expensive one (a coarse and
//! a fine mesh): one surrogate over both, and a search that picks each next
//! run *and its level* by expected improvement per second.
//!
//! **The surrogate** is autoregressive co-kriging (Kennedy and O'Hagan
//! 2000): `f_expensive(x) = rho f_cheap(x) + delta(x)`, with `f_cheap` and
//! the discrepancy `delta` independent Gaussian processes. It is fitted in
//! the recursive form of Le Gratiet and Garnier (2014), as SMT's MFK does:
//! a GP on the cheap runs, then a GP on `y_expensive - rho m_cheap(x)` at
//! the expensive points, with `rho` the value that maximises that GP's
//! marginal likelihood (in the data's units, so that likelihoods at
//! different `rho` compare). The cheap GP's mean stands in for a cheap run
//! at an expensive point that has none; where the expensive points are
//! also cheap points (nested designs, as the start design here is) the
//! recursive form is the full co-kriging posterior.
//!
//! **The choice of the next run** follows Huang et al.'s (2006) augmented
//! expected improvement, per second: an expensive run at `x` is worth
//! `EI(x) / cost_expensive`, where `EI` is the expected improvement of the
//! expensive prediction below the best expensive run. A cheap run banks
//! no improvement (the answer is an expensive run); it is worth what it
//! teaches: the part of `EI` that is uncertainty, `EI - max(best - m, 0)`,
//! times the correlation of the cheap and the expensive output at `x`
//! (`rho s_cheap / s_expensive`, nothing where the cheap output is
//! already known), over `cost_cheap`. Huang et al. weigh the whole `EI`
//! by the correlation; with a deterministic model that keeps choosing
//! cheap runs where the expensive prediction is already sure of a gain
//! (both standard deviations small, their ratio not), and an expensive
//! run there is what banks it.
//! The costs are the levels' measured mean wall times, updated after every
//! run. The point is where an expensive run gains most (maximised over
//! the unit box like Bayesian optimisation's acquisition, [`crate::bo`],
//! in logarithms); the level is the one with the larger gain per second
//! *there*, as in Kandasamy et al.'s (2016) MF-GP-UCB, which picks the
//! point by the target fidelity and the level by what is still unknown
//! at it. Scored anywhere, cheap runs would wander the box: with many
//! parameters somewhere is always unexplored, and cheaply so.
//!
//! With [`MultiFidelitySettings::local_steps`] and runs that return
//! residuals, local Gauss-Newton steps in a trust region
//! ([`crate::trust_region`]) come between the two-level steps once
//! [`MultiFidelitySettings::local_steps_after`] expensive runs are made:
//! the two levels look for the basin, the local steps descend it. Their
//! linear model is the expensive level's at the centre with the cheap
//! level's slopes (output space mapping: each cheap run's residuals
//! shifted by the two levels' difference at the centre), so the slopes
//! cost cheap runs and only the steps that may move the centre run
//! expensive.
//!
//! Losses are modelled as `ln(loss)` when every loss is positive, like
//! [`crate::bo`]. A failed run is left out of the fits; points within 0.02
//! (unit box) of a failed run of the same level are not proposed again.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::bo::{log_h, BoError, BoxSearch, Outcome, Stop};
use crate::gp::{Gp, GpError, GpSettings};
use crate::trust_region::{Run, TrustRegion, TrustRegionSettings};

/// A level of the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Fidelity {
    Cheap,
    Expensive,
}

/// A fitted co-kriging model of the expensive output.
#[derive(Clone, Debug)]
pub struct CoKriging {
    cheap: Gp,
    discrepancy: Gp,
    rho: f64,
}

/// The expensive output's prediction at a point, with its parts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoKrigingPrediction {
    pub mean: f64,
    /// Standard deviation of the expensive output.
    pub std: f64,
    /// Standard deviation of the cheap output.
    pub cheap_std: f64,
    /// Correlation of the cheap and the expensive output, in [0, 1].
    pub correlation: f64,
}

/// A prediction with gradients, for the acquisition's optimiser.
struct PredictionWithGradient {
    mean: f64,
    std: f64,
    cheap_std: f64,
    mean_gradient: Vec<f64>,
    std_gradient: Vec<f64>,
    cheap_std_gradient: Vec<f64>,
}

/// Intervals of the coarse scan for `rho`, and golden-section steps
/// after it (the bracket of two intervals shrinks to 0.618^12 = 3e-3 of
/// its width).
const RHO_SCAN: usize = 20;
const RHO_STEPS: usize = 12;

impl CoKriging {
    /// Fits the model to `(point, output)` pairs of each level. Needs two
    /// cheap and two expensive outputs at least.
    ///
    /// # Errors
    /// Too few points, or a GP that cannot be fitted.
    pub fn fit(
        cheap: &[(Vec<f64>, f64)],
        expensive: &[(Vec<f64>, f64)],
        settings: &GpSettings,
    ) -> Result<CoKriging, GpError> {
        let (cheap_inputs, cheap_outputs) = split(cheap);
        let cheap_gp = Gp::fit(&cheap_inputs, &cheap_outputs, settings)?;
        let (inputs, outputs) = split(expensive);
        let cheap_at_expensive: Vec<f64> =
            inputs.iter().map(|x| cheap_gp.predict_mean(x)).collect();
        let dimensions = inputs.first().map_or(0, Vec::len);
        // A discrepancy seen at few points has one length scale: one per
        // input would be fitted to noise.
        let discrepancy_settings = GpSettings {
            ard: settings.ard && inputs.len() > 2 * dimensions,
            ..settings.clone()
        };
        let quick = GpSettings {
            restarts: 1,
            ..discrepancy_settings.clone()
        };
        let likelihood = |rho: f64, settings: &GpSettings| -> Option<(Gp, f64)> {
            let residuals: Vec<f64> = outputs
                .iter()
                .zip(&cheap_at_expensive)
                .map(|(y, m)| y - rho * m)
                .collect();
            let gp = Gp::fit(&inputs, &residuals, settings).ok()?;
            let h = gp.hyperparameters();
            let output_variance = h.signal_variance / h.signal_variance_standardised;
            // The fit's likelihood is of the standardised residuals; in
            // the data's units it is lower by n ln(their std).
            let in_data_units =
                gp.log_marginal_likelihood() - 0.5 * residuals.len() as f64 * output_variance.ln();
            in_data_units.is_finite().then_some((gp, in_data_units))
        };
        // A coarse scan first (the likelihood in rho can have more than
        // one hump with few expensive points, and the least-squares slope
        // is biased by the discrepancy), then golden section between the
        // best scan point's neighbours.
        let slope = least_squares_slope(&cheap_at_expensive, &outputs);
        let reach = slope.abs() + 1.0;
        let (lower, upper) = (-reach, 3.0 * reach);
        let step = (upper - lower) / RHO_SCAN as f64;
        let scan: Vec<f64> = (0..=RHO_SCAN)
            .map(|k| {
                likelihood(lower + k as f64 * step, &quick).map_or(f64::NEG_INFINITY, |(_, l)| l)
            })
            .collect();
        let top = (0..=RHO_SCAN)
            .max_by(|&a, &b| scan[a].total_cmp(&scan[b]))
            .unwrap_or(0);
        let rho = golden_section_maximum(
            |rho| likelihood(rho, &quick).map_or(f64::NEG_INFINITY, |(_, l)| l),
            lower + (top as f64 - 1.0) * step,
            lower + (top as f64 + 1.0) * step,
            RHO_STEPS,
        );
        let discrepancy = match likelihood(rho, &discrepancy_settings) {
            Some((gp, _)) => gp,
            None => {
                let residuals: Vec<f64> = outputs
                    .iter()
                    .zip(&cheap_at_expensive)
                    .map(|(y, m)| y - rho * m)
                    .collect();
                Gp::fit(&inputs, &residuals, &discrepancy_settings)?
            }
        };
        Ok(CoKriging {
            cheap: cheap_gp,
            discrepancy,
            rho,
        })
    }

    /// The scale factor from the cheap to the expensive output.
    pub fn rho(&self) -> f64 {
        self.rho
    }

    /// The GP of the cheap output.
    pub fn cheap(&self) -> &Gp {
        &self.cheap
    }

    /// The fitted observation-noise variance of the expensive output (the
    /// discrepancy's, and the cheap level's scaled by rho squared), in
    /// its units squared.
    pub fn noise_variance(&self) -> f64 {
        self.discrepancy.hyperparameters().noise_variance
            + self.rho.powi(2) * self.cheap.hyperparameters().noise_variance
    }

    /// The expensive output at `x`.
    pub fn predict(&self, x: &[f64]) -> CoKrigingPrediction {
        let cheap = self.cheap.predict(x);
        let discrepancy = self.discrepancy.predict(x);
        let scaled_cheap_variance = (self.rho * cheap.std).powi(2);
        let std = (scaled_cheap_variance + discrepancy.std.powi(2)).sqrt();
        CoKrigingPrediction {
            mean: self.rho * cheap.mean + discrepancy.mean,
            std,
            cheap_std: cheap.std,
            correlation: if std > 0.0 {
                scaled_cheap_variance.sqrt() / std
            } else {
                0.0
            },
        }
    }

    fn predict_with_gradient(&self, x: &[f64]) -> PredictionWithGradient {
        let cheap = self.cheap.predict_with_gradient(x);
        let discrepancy = self.discrepancy.predict_with_gradient(x);
        let rho = self.rho;
        let std = ((rho * cheap.std).powi(2) + discrepancy.std.powi(2)).sqrt();
        let mean_gradient = cheap
            .mean_gradient
            .iter()
            .zip(&discrepancy.mean_gradient)
            .map(|(c, d)| rho * c + d)
            .collect();
        let std_gradient = cheap
            .std_gradient
            .iter()
            .zip(&discrepancy.std_gradient)
            .map(|(c, d)| {
                if std > 0.0 {
                    (rho * rho * cheap.std * c + discrepancy.std * d) / std
                } else {
                    0.0
                }
            })
            .collect();
        PredictionWithGradient {
            mean: rho * cheap.mean + discrepancy.mean,
            std,
            cheap_std: cheap.std,
            mean_gradient,
            std_gradient,
            cheap_std_gradient: cheap.std_gradient,
        }
    }

    /// `ln` of what a run of `level` at `x` is expected to gain below
    /// `best` (see [`propose`]), and its gradient when asked for.
    fn log_gain(&self, level: Fidelity, best: f64, x: &[f64], gradient: Option<&mut [f64]>) -> f64 {
        const FLOOR: f64 = 1e-12;
        let p = self.predict_with_gradient(x);
        let std = p.std.max(FLOOR);
        let z = (best - p.mean) / std;
        let cheap = level == Fidelity::Cheap;
        // EI = std h(z). A cheap run banks nothing: it is worth the part
        // of EI that is uncertainty, EI - max(best - mean, 0) = std h(-|z|)
        // (h(z) - z = h(-z)), times the correlation.
        let (argument, sign) = if cheap && z > 0.0 {
            (-z, -1.0)
        } else {
            (z, 1.0)
        };
        let (log_h, cdf_over_h) = log_h(argument);
        // d ln h / dz, then dz/dmean = -1/std, dz/dstd = -z/std.
        let by_z = sign * cdf_over_h;
        let mut value = std.ln() + log_h;
        let by_mean = -by_z / std;
        let by_std = 1.0 / std - by_z * z / std;
        let cheap_std = p.cheap_std.max(FLOOR);
        if cheap {
            // ln corr = ln |rho| + ln s_cheap - ln s_expensive.
            value += self.rho.abs().max(FLOOR).ln() + cheap_std.ln() - std.ln();
        }
        if let Some(gradient) = gradient {
            for (k, g) in gradient.iter_mut().enumerate() {
                *g = by_mean * p.mean_gradient[k] + by_std * p.std_gradient[k];
                if cheap {
                    *g += p.cheap_std_gradient[k] / cheap_std - p.std_gradient[k] / std;
                }
            }
        }
        value
    }
}

/// Inputs and outputs of `(point, output)` pairs.
fn split(points: &[(Vec<f64>, f64)]) -> (Vec<Vec<f64>>, Vec<f64>) {
    points.iter().cloned().unzip()
}

/// The slope of the least-squares line of `y` on `x` (1 when `x` does not vary).
fn least_squares_slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mean_x, mean_y) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mean_x) * (b - mean_y);
        sxx += (a - mean_x) * (a - mean_x);
    }
    if sxx > 0.0 && (sxy / sxx).is_finite() {
        sxy / sxx
    } else {
        1.0
    }
}

/// Where `f` is largest on `[lower, upper]`, by golden-section search.
fn golden_section_maximum(f: impl Fn(f64) -> f64, lower: f64, upper: f64, steps: usize) -> f64 {
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (lower, upper);
    let mut c = b - ratio * (b - a);
    let mut d = a + ratio * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..steps {
        if fc >= fd {
            b = d;
            d = c;
            fd = fc;
            c = b - ratio * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + ratio * (b - a);
            fd = f(d);
        }
    }
    if fc >= fd {
        c
    } else {
        d
    }
}

/// How the two-level search runs.
#[derive(Clone, Debug)]
pub struct MultiFidelitySettings {
    /// Stop after this many runs, both levels and the start designs included.
    pub max_evaluations: usize,
    /// Stop after this many expensive runs.
    pub max_expensive: usize,
    /// Stop when the best expensive loss is at or below this.
    pub target_loss: Option<f64>,
    /// Random candidates per level and pick.
    pub random_candidates: usize,
    /// L-BFGS-B starts per level and pick.
    pub local_starts: usize,
    /// Both levels' GPs (`input_bounds` is the unit box).
    pub gp: GpSettings,
    /// Model `ln(loss)` when every loss is positive.
    pub log_transform: bool,
    pub seed: u64,
    /// Local trust-region steps at the expensive level on its runs'
    /// residuals, between the two-level steps (as in [`crate::bo`]);
    /// `None`: two-level steps only.
    pub local_steps: Option<TrustRegionSettings>,
    /// Expensive runs (the start design's included) before the first
    /// local step: the two levels look for the basin first.
    pub local_steps_after: usize,
}

impl Default for MultiFidelitySettings {
    fn default() -> Self {
        MultiFidelitySettings {
            max_evaluations: 200,
            max_expensive: 50,
            target_loss: None,
            random_candidates: 5_000,
            local_starts: 10,
            // Bayesian optimisation's: simulators are deterministic.
            gp: crate::bo::BoSettings::default().gp,
            log_transform: true,
            seed: 0,
            local_steps: None,
            local_steps_after: 0,
        }
    }
}

/// One run of either level.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LevelRun {
    pub level: Fidelity,
    pub unit_point: Vec<f64>,
    /// `None`: the run failed.
    pub loss: Option<f64>,
    /// The residuals behind the loss, for local steps (empty: none).
    #[serde(skip)]
    pub residuals: Vec<f64>,
    pub wall_s: f64,
}

/// The whole two-level history and how it ended.
#[derive(Clone, Debug)]
pub struct MultiFidelityResult {
    pub runs: Vec<LevelRun>,
    /// Index in `runs` of the best expensive run.
    pub best: usize,
    pub stop: Stop,
    /// Runs made when the target was first reached by an expensive run.
    pub evaluations_to_target: Option<usize>,
    /// The measured mean wall time of a cheap and of an expensive run, s.
    pub cost_s: [f64; 2],
    /// The last fit's `rho` (None when no fit was made).
    pub rho: Option<f64>,
}

impl MultiFidelityResult {
    /// The runs of one level.
    pub fn count(&self, level: Fidelity) -> usize {
        self.runs.iter().filter(|r| r.level == level).count()
    }
}

/// Measured mean wall time of each level's runs (the other's when one
/// has none yet; 1 s when neither has), floored at a microsecond.
fn measured_costs(runs: &[LevelRun]) -> [f64; 2] {
    let mean = |level| {
        let times: Vec<f64> = runs
            .iter()
            .filter(|r| r.level == level && r.wall_s.is_finite())
            .map(|r| r.wall_s)
            .collect();
        (!times.is_empty()).then(|| times.iter().sum::<f64>() / times.len() as f64)
    };
    let (cheap, expensive) = (mean(Fidelity::Cheap), mean(Fidelity::Expensive));
    let cheap_s = cheap.or(expensive).unwrap_or(1.0).max(1e-6);
    let expensive_s = expensive.or(cheap).unwrap_or(1.0).max(1e-6);
    [cheap_s, expensive_s]
}

/// The successful runs of a level as (point, modelled loss).
fn modelled(runs: &[LevelRun], level: Fidelity, use_log: bool) -> Vec<(Vec<f64>, f64)> {
    runs.iter()
        .filter(|r| r.level == level)
        .filter_map(|r| {
            r.loss
                .map(|l| (r.unit_point.clone(), if use_log { l.ln() } else { l }))
        })
        .collect()
}

/// The next run and its level: the larger gain per second of the two.
///
/// # Errors
/// Fewer than two successful runs of a level, or a GP that cannot be fitted.
pub fn propose(
    runs: &[LevelRun],
    settings: &MultiFidelitySettings,
    iteration: u64,
) -> Result<(Fidelity, Vec<f64>, CoKriging), BoError> {
    let use_log = settings.log_transform && runs.iter().filter_map(|r| r.loss).all(|l| l > 0.0);
    let cheap = modelled(runs, Fidelity::Cheap, use_log);
    let expensive = modelled(runs, Fidelity::Expensive, use_log);
    let fewest = cheap.len().min(expensive.len());
    if fewest < 2 {
        return Err(BoError::TooFewObservations(fewest));
    }
    let dimensions = cheap[0].0.len();
    let gp = GpSettings {
        input_bounds: Some(vec![(0.0, 1.0); dimensions]),
        seed: settings.gp.seed ^ iteration,
        ..settings.gp.clone()
    };
    let model = CoKriging::fit(&cheap, &expensive, &gp)?;
    let best = expensive.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let [cheap_s, expensive_s] = measured_costs(runs);
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed ^ iteration.wrapping_mul(0x9E37_79B9));
    let search = BoxSearch {
        random_candidates: settings.random_candidates,
        local_starts: settings.local_starts,
    };
    let near_failed = |level: Fidelity, x: &[f64]| {
        runs.iter()
            .filter(|r| r.level == level && r.loss.is_none())
            .any(|r| distance(&r.unit_point, x) < 0.02)
    };
    // The point: where an expensive run gains most.
    let (expensive_log_gain, x) = search.maximise(
        |x, gradient| {
            if near_failed(Fidelity::Expensive, x) {
                return f64::NEG_INFINITY;
            }
            model.log_gain(Fidelity::Expensive, best, x, gradient)
        },
        &expensive,
        &mut rng,
    );
    // The level: a cheap run there first when what it teaches is worth
    // more per second than what an expensive run banks.
    let cheap_log_gain = if near_failed(Fidelity::Cheap, &x) {
        f64::NEG_INFINITY
    } else {
        model.log_gain(Fidelity::Cheap, best, &x, None)
    };
    let level = if cheap_log_gain - cheap_s.ln() > expensive_log_gain - expensive_s.ln() {
        Fidelity::Cheap
    } else {
        Fidelity::Expensive
    };
    Ok((level, x, model))
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (p - q).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// The next local step and its level, or `None` when it is the two-level
/// search's turn.
///
/// The trust region's linear model of the residuals is the expensive
/// level's at its centre (the best expensive run) with the cheap level's
/// slopes: each cheap run enters with its residuals shifted by the
/// difference of the two levels at the centre (output space mapping),
/// with an infinite loss so that it never becomes the centre. The
/// slopes then cost cheap runs: a geometry step (a run that only
/// improves the model's view) runs cheap, and so does the first run at a
/// new centre, which the shift needs; only the steps that may move the
/// centre run expensive.
fn local_step(trust_region: &mut TrustRegion, runs: &[LevelRun]) -> Option<(Fidelity, Vec<f64>)> {
    let centre = runs
        .iter()
        .filter(|r| r.level == Fidelity::Expensive && !r.residuals.is_empty())
        .filter_map(|r| r.loss.map(|loss| (r, loss)))
        .min_by(|a, b| a.1.total_cmp(&b.1))?
        .0;
    let cheap_at_centre = runs.iter().find(|r| {
        r.level == Fidelity::Cheap
            && r.unit_point == centre.unit_point
            && r.residuals.len() == centre.residuals.len()
    });
    let Some(cheap_at_centre) = cheap_at_centre else {
        let failed_there = runs
            .iter()
            .any(|r| r.level == Fidelity::Cheap && r.unit_point == centre.unit_point);
        return (!failed_there).then(|| (Fidelity::Cheap, centre.unit_point.clone()));
    };
    let shift: Vec<f64> = centre
        .residuals
        .iter()
        .zip(&cheap_at_centre.residuals)
        .map(|(e, c)| e - c)
        .collect();
    let shifted: Vec<Vec<f64>> = runs
        .iter()
        .map(|r| match r.level {
            Fidelity::Cheap if r.residuals.len() == shift.len() && r.loss.is_some() => {
                r.residuals.iter().zip(&shift).map(|(c, s)| c + s).collect()
            }
            _ => Vec::new(),
        })
        .collect();
    let model_runs: Vec<Run<'_>> = runs
        .iter()
        .zip(&shifted)
        .filter_map(|(r, shifted)| match r.level {
            Fidelity::Expensive => r.loss.map(|loss| Run {
                unit_point: &r.unit_point,
                loss,
                residuals: &r.residuals,
            }),
            Fidelity::Cheap if !shifted.is_empty() && r.unit_point != centre.unit_point => {
                Some(Run {
                    unit_point: &r.unit_point,
                    loss: f64::INFINITY,
                    residuals: shifted,
                })
            }
            Fidelity::Cheap => None,
        })
        .collect();
    let point = trust_region.propose(&model_runs)?;
    let level = if trust_region.pending_is_geometry() {
        Fidelity::Cheap
    } else {
        Fidelity::Expensive
    };
    Some((level, point))
}

/// Runs the two-level search: the cheap start design, the expensive one
/// (best a subset of the cheap one: nested), then one run at a time,
/// level and point by [`propose`], until a stop holds. `evaluate` runs
/// unit-box points at a level and returns each loss (`None`: failed) and
/// wall time; its error ends the search.
///
/// # Errors
/// The evaluator's error, or a proposal that cannot be made.
pub fn minimise<E: From<BoError>>(
    cheap_start: Vec<Vec<f64>>,
    expensive_start: Vec<Vec<f64>>,
    mut evaluate: impl FnMut(Fidelity, &[Vec<f64>]) -> Result<Vec<(Option<Outcome>, f64)>, E>,
    settings: &MultiFidelitySettings,
) -> Result<MultiFidelityResult, E> {
    let mut runs: Vec<LevelRun> = Vec::new();
    let mut evaluations_to_target = None;
    let mut rho = None;
    let reached = |loss: Option<f64>| {
        settings
            .target_loss
            .is_some_and(|t| loss.is_some_and(|l| l <= t))
    };
    let mut run = |level: Fidelity,
                   points: Vec<Vec<f64>>,
                   runs: &mut Vec<LevelRun>,
                   evaluations_to_target: &mut Option<usize>|
     -> Result<(), E> {
        let outcomes = evaluate(level, &points)?;
        for (unit_point, (outcome, wall_s)) in points.into_iter().zip(outcomes) {
            let (loss, residuals) = match outcome {
                Some(outcome) => (Some(outcome.loss), outcome.residuals),
                None => (None, Vec::new()),
            };
            runs.push(LevelRun {
                level,
                unit_point,
                loss,
                residuals,
                wall_s,
            });
            if level == Fidelity::Expensive && evaluations_to_target.is_none() && reached(loss) {
                *evaluations_to_target = Some(runs.len());
            }
        }
        Ok(())
    };
    run(
        Fidelity::Cheap,
        cheap_start,
        &mut runs,
        &mut evaluations_to_target,
    )?;
    run(
        Fidelity::Expensive,
        expensive_start,
        &mut runs,
        &mut evaluations_to_target,
    )?;
    let mut trust_region = settings.local_steps.clone().map(TrustRegion::new);
    if let Some(trust_region) = &mut trust_region {
        for run in runs.iter().filter(|r| r.level == Fidelity::Expensive) {
            trust_region.record(&run.unit_point, run.loss, &run.residuals);
        }
    }
    let mut iteration = 0u64;
    let stop = loop {
        if evaluations_to_target.is_some() {
            break Stop::TargetReached;
        }
        let expensive_runs = runs
            .iter()
            .filter(|r| r.level == Fidelity::Expensive)
            .count();
        if runs.len() >= settings.max_evaluations || expensive_runs >= settings.max_expensive {
            break Stop::MaxEvaluations;
        }
        iteration += 1;
        let local = match &mut trust_region {
            Some(trust_region) if expensive_runs >= settings.local_steps_after => {
                local_step(trust_region, &runs)
            }
            _ => None,
        };
        let (level, point) = match local {
            Some(step) => step,
            None => {
                let (level, point, model) = propose(&runs, settings, iteration).map_err(E::from)?;
                rho = Some(model.rho());
                (level, point)
            }
        };
        run(level, vec![point], &mut runs, &mut evaluations_to_target)?;
        let last = runs.last().expect("a run was just made");
        if let Some(trust_region) = &mut trust_region {
            trust_region.record(&last.unit_point, last.loss, &last.residuals);
        }
    };
    let best = runs
        .iter()
        .enumerate()
        .filter(|(_, r)| r.level == Fidelity::Expensive)
        .filter_map(|(i, r)| r.loss.map(|l| (i, l)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0, |(i, _)| i);
    Ok(MultiFidelityResult {
        cost_s: measured_costs(&runs),
        runs,
        best,
        stop,
        evaluations_to_target,
        rho,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_section_finds_the_top_of_a_parabola() {
        let top = golden_section_maximum(|x| -(x - 0.3).powi(2), -1.0, 2.0, 40);
        assert!((top - 0.3).abs() < 1e-6, "{top}");
    }

    #[test]
    fn the_least_squares_slope_of_a_line_is_its_slope() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let y: Vec<f64> = x.iter().map(|v| 2.5 * v - 1.0).collect();
        assert!((least_squares_slope(&x, &y) - 2.5).abs() < 1e-12);
        assert_eq!(least_squares_slope(&[1.0, 1.0], &[0.0, 2.0]), 1.0);
    }

    #[test]
    fn the_costs_are_each_levels_mean_wall_time() {
        let run = |level, wall_s| LevelRun {
            level,
            unit_point: vec![0.5],
            loss: Some(1.0),
            residuals: Vec::new(),
            wall_s,
        };
        let runs = [
            run(Fidelity::Cheap, 0.1),
            run(Fidelity::Cheap, 0.3),
            run(Fidelity::Expensive, 4.0),
        ];
        assert_eq!(measured_costs(&runs), [0.2, 4.0]);
        assert_eq!(measured_costs(&runs[..2]), [0.2, 0.2]);
    }
}
