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
//! residuals, local steps come first from the expensive start design on,
//! and the two-level steps only when they cannot go on. A local step is
//! output space mapping in a trust region (Bandler et al. 2004; Koziel,
//! Bandler and Madsen 2006): near the best expensive run `c` the
//! expensive residuals are the cheap ones plus the levels' difference,
//! `r_e(x) ~ r_c(x) + d(c) + D (x - c)`, with `d(c)` measured at `c` (a
//! cheap run there) and its slopes `D` fitted to the other points both
//! levels ran. That surrogate is descended with cheap runs only (a trust
//! region of its own, [`crate::trust_region`], in a box around `c`), and
//! one expensive run checks where the descent ended: a check that beats
//! `c` moves the centre and grows the box, one that does not halves it.
//! The surrogate keeps the cheap level's curvature, which a linear model
//! of the expensive runs would need many expensive runs to learn, and
//! the correction `D` learns from the checks where the levels part.
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

    /// How far apart the levels' losses were where both ran: the number
    /// of such points and the median of |expensive loss - cheap loss|
    /// there (`None` without one). The local steps correct the cheap
    /// level by the difference at the centre and its slopes, so a large
    /// difference alone does no harm; it says how much the correction
    /// carries, which is what a user choosing the cheap mesh wants to see.
    pub fn level_loss_difference(&self) -> Option<LevelLossDifference> {
        let differences: Vec<f64> =
            self.runs
                .iter()
                .filter(|r| r.level == Fidelity::Expensive)
                .filter_map(|expensive| {
                    let cheap = self.runs.iter().find(|c| {
                        c.level == Fidelity::Cheap && c.unit_point == expensive.unit_point
                    })?;
                    Some((expensive.loss? - cheap.loss?).abs())
                })
                .collect();
        (!differences.is_empty()).then(|| LevelLossDifference {
            points: differences.len(),
            median: crate::chain_diagnostics::median(&differences),
        })
    }
}

/// The levels' losses compared at the points both ran
/// ([`MultiFidelityResult::level_loss_difference`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LevelLossDifference {
    pub points: usize,
    /// The median of |expensive loss - cheap loss|, in the loss's unit.
    pub median: f64,
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

/// Output space mapping in a trust region (Bandler et al. 2004; Koziel,
/// Bandler and Madsen 2006): the expensive level near the centre `c` is
/// the cheap level shifted by the two levels' difference there,
/// `r_e(x) ~ r_c(x) + (r_e(c) - r_c(c))`. That surrogate is descended with
/// cheap runs only (a trust region of its own on the shifted residuals,
/// inside the outer radius), and one expensive run checks where it ended:
/// an expensive run that beats the centre moves it (and the shift is
/// measured again there), one that does not halves the outer radius.
/// Unlike a linear model with the cheap slopes, the surrogate keeps the
/// cheap level's curvature, so one expensive run can check a long step.
#[derive(Clone, Debug)]
struct SurrogateDescent {
    settings: TrustRegionSettings,
    /// Half-width of the box the surrogate is descended in.
    radius: f64,
    inner: Option<InnerDescent>,
}

#[derive(Clone, Debug)]
struct InnerDescent {
    /// The expensive centre's point.
    centre: Vec<f64>,
    /// Its residuals.
    centre_residuals: Vec<f64>,
    shift: Vec<f64>,
    /// How the levels' difference changes away from the centre, fitted
    /// to the points both levels ran (rows: residuals).
    correction: Vec<Vec<f64>>,
    trust_region: TrustRegion,
    /// `runs.len()` when this descent began: its cheap runs come after.
    first_run: usize,
    cheap_runs: usize,
    budget: usize,
    /// The box (half-width, unit box) the shift is trusted in.
    radius: f64,
    absolute: bool,
}

/// What the descent compares residuals by: the loss the trust region's
/// settings stand for (see [`TrustRegionSettings::absolute`]).
fn measure(residuals: &[f64], absolute: bool) -> f64 {
    if absolute {
        residuals.iter().map(|r| r.abs()).sum()
    } else {
        residuals.iter().map(|r| r * r).sum()
    }
}

impl SurrogateDescent {
    fn new(settings: TrustRegionSettings) -> Self {
        SurrogateDescent {
            radius: settings.initial_radius,
            settings,
            inner: None,
        }
    }

    /// The next run and its level, or `None` when it is the two-level
    /// search's turn (the outer radius has collapsed).
    fn next(&mut self, runs: &[LevelRun]) -> Option<(Fidelity, Vec<f64>)> {
        if self.radius < self.settings.min_radius {
            return None;
        }
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
        if self
            .inner
            .as_ref()
            .is_none_or(|inner| inner.centre != centre.unit_point)
        {
            let [cheap_s, expensive_s] = measured_costs(runs);
            let correction = level_difference_slopes(runs, centre, cheap_at_centre, self.radius);
            self.inner = Some(InnerDescent {
                correction,
                centre: centre.unit_point.clone(),
                centre_residuals: centre.residuals.clone(),
                shift: level_difference(centre, cheap_at_centre),
                trust_region: TrustRegion::new(TrustRegionSettings {
                    initial_radius: self.radius / 2.0,
                    max_radius: self.radius,
                    ..self.settings.clone()
                }),
                first_run: runs.len(),
                radius: self.radius,
                absolute: self.settings.absolute,
                cheap_runs: 0,
                budget: inner_budget(cheap_s, expensive_s),
            });
        }
        let inner = self.inner.as_mut()?;
        if inner.cheap_runs < inner.budget {
            if let Some(point) = inner.propose(runs) {
                inner.cheap_runs += 1;
                return Some((Fidelity::Cheap, point));
            }
        }
        // The surrogate's descent is over: check its end expensively.
        let centre_measure = measure(&inner.centre_residuals, inner.absolute);
        let end = runs[inner.first_run..]
            .iter()
            .filter(|r| {
                r.level == Fidelity::Cheap
                    && r.residuals.len() == inner.shift.len()
                    && inner.in_box(&r.unit_point)
            })
            .map(|r| {
                (
                    r,
                    measure(&inner.shifted(&r.residuals, &r.unit_point), inner.absolute),
                )
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .filter(|(_, measure)| *measure < centre_measure)
            .map(|(r, _)| r.unit_point.clone());
        let checked = runs
            .iter()
            .any(|r| r.level == Fidelity::Expensive && Some(&r.unit_point) == end.as_ref());
        self.inner = None;
        match end {
            Some(end) if !checked => Some((Fidelity::Expensive, end)),
            _ => {
                // Nothing the surrogate finds below the centre: a smaller box.
                self.radius /= 2.0;
                self.next(runs)
            }
        }
    }

    /// The outcome of an expensive check: a run that beats the centre
    /// grows the box, one that does not halves it.
    fn record_expensive(&mut self, improved: bool) {
        self.radius = match (improved, self.radius < self.settings.min_radius) {
            // A two-level step found a better centre after the box had
            // collapsed: descend again from there, as the one-level trust
            // region resumes.
            (true, true) => self.settings.initial_radius / 2.0,
            (true, false) => (2.0 * self.radius).min(self.settings.max_radius),
            (false, _) => self.radius / 2.0,
        };
    }
}

/// The successful runs of `level` with as many residuals as `like`,
/// other than the one at `except`.
fn successful_with_residuals<'a>(
    runs: &'a [LevelRun],
    level: Fidelity,
    like: &'a [f64],
    except: &'a [f64],
) -> impl Iterator<Item = &'a LevelRun> + 'a {
    runs.iter().filter(move |r| {
        r.level == level
            && r.loss.is_some()
            && r.residuals.len() == like.len()
            && r.unit_point != except
    })
}

/// The expensive run's residuals less the cheap run's at the same point.
fn level_difference(expensive: &LevelRun, cheap: &LevelRun) -> Vec<f64> {
    expensive
        .residuals
        .iter()
        .zip(&cheap.residuals)
        .map(|(e, c)| e - c)
        .collect()
}

/// The slopes of the levels' difference `r_e - r_c` at the centre, by the
/// trust region's weighted regression on every other point both levels
/// ran (empty when there is none).
fn level_difference_slopes(
    runs: &[LevelRun],
    centre: &LevelRun,
    cheap_at_centre: &LevelRun,
    radius: f64,
) -> Vec<Vec<f64>> {
    let others =
        |level| successful_with_residuals(runs, level, &centre.residuals, &centre.unit_point);
    let pairs: Vec<(Vec<f64>, Vec<f64>)> = others(Fidelity::Expensive)
        .filter_map(|e| {
            runs.iter()
                .find(|c| {
                    c.level == Fidelity::Cheap
                        && c.loss.is_some()
                        && c.unit_point == e.unit_point
                        && c.residuals.len() == e.residuals.len()
                })
                .map(|c| (e.unit_point.clone(), level_difference(e, c)))
        })
        .collect();
    if pairs.is_empty() {
        return Vec::new();
    }
    let at_centre = level_difference(centre, cheap_at_centre);
    let centre_run = Run {
        unit_point: &centre.unit_point,
        loss: 0.0,
        residuals: &at_centre,
        slopes: &[],
    };
    let others: Vec<Run<'_>> = pairs
        .iter()
        .map(|(point, residuals)| Run {
            unit_point: point,
            loss: 0.0,
            residuals,
            slopes: &[],
        })
        .collect();
    let others: Vec<&Run<'_>> = others.iter().collect();
    crate::trust_region::fit_jacobian(&centre_run, &others, radius)
}

/// The share of an expensive run's time the cheap runs of one descent
/// may take (measured costs): each local step then costs at most one and
/// a half expensive runs.
const INNER_COST_SHARE: f64 = 0.5;

/// Cheap runs per expensive check: as many as cost half an expensive run
/// (the descent then costs at most one and a half expensive runs a step),
/// at least two.
fn inner_budget(cheap_s: f64, expensive_s: f64) -> usize {
    ((INNER_COST_SHARE * expensive_s / cheap_s).floor() as usize).max(2)
}

impl InnerDescent {
    fn in_box(&self, point: &[f64]) -> bool {
        point
            .iter()
            .zip(&self.centre)
            .all(|(x, c)| (x - c).abs() <= self.radius * (1.0 + 1e-9))
    }

    fn shifted(&self, residuals: &[f64], point: &[f64]) -> Vec<f64> {
        let step: Vec<f64> = point.iter().zip(&self.centre).map(|(x, c)| x - c).collect();
        residuals
            .iter()
            .zip(&self.shift)
            .enumerate()
            .map(|(k, (c, s))| {
                let slope = self.correction.get(k).map_or(0.0, |row| {
                    row.iter().zip(&step).map(|(d, dx)| d * dx).sum::<f64>()
                });
                c + s + slope
            })
            .collect()
    }

    /// The inner trust region's next cheap run on the shifted residuals
    /// of every cheap run (the centre's own is the expensive one).
    fn propose(&mut self, runs: &[LevelRun]) -> Option<Vec<f64>> {
        if let Some(last) = runs.last() {
            if last.level == Fidelity::Cheap && last.residuals.len() == self.shift.len() {
                let shifted = self.shifted(&last.residuals, &last.unit_point);
                self.trust_region.record(
                    &last.unit_point,
                    Some(measure(&shifted, self.absolute)),
                    &shifted,
                );
            } else if last.level == Fidelity::Cheap {
                self.trust_region.record(&last.unit_point, None, &[]);
            }
        }
        let shifted: Vec<(&[f64], Vec<f64>)> =
            successful_with_residuals(runs, Fidelity::Cheap, &self.shift, &self.centre)
                .map(|r| {
                    (
                        r.unit_point.as_slice(),
                        self.shifted(&r.residuals, &r.unit_point),
                    )
                })
                .collect();
        let centre_measure = measure(&self.centre_residuals, self.absolute);
        let mut model_runs: Vec<Run<'_>> = vec![Run {
            unit_point: &self.centre,
            loss: centre_measure,
            residuals: &self.centre_residuals,
            slopes: &[],
        }];
        // Runs outside the box lend their slopes, never the centre: the
        // shift is the levels' difference at the expensive centre, and
        // says nothing far from it.
        model_runs.extend(shifted.iter().map(|(point, residuals)| Run {
            unit_point: point,
            loss: if self.in_box(point) {
                measure(residuals, self.absolute)
            } else {
                f64::INFINITY
            },
            residuals,
            slopes: &[],
        }));
        self.trust_region.propose(&model_runs)
    }
}

/// Where the expensive start design runs.
#[derive(Clone, Debug, PartialEq)]
pub enum ExpensiveStart {
    /// These points (best a subset of the cheap start design: nested).
    Points(Vec<Vec<f64>>),
    /// The cheap start design's points with the lowest cheap losses, this
    /// many: where the local steps start from.
    BestCheap(usize),
}

/// The `count` points of `runs` with the lowest losses (failed runs last).
fn best_points(runs: &[LevelRun], count: usize) -> Vec<Vec<f64>> {
    let mut scored: Vec<&LevelRun> = runs.iter().filter(|r| r.loss.is_some()).collect();
    scored.sort_by(|a, b| {
        a.loss
            .unwrap_or(f64::INFINITY)
            .total_cmp(&b.loss.unwrap_or(f64::INFINITY))
    });
    scored
        .into_iter()
        .take(count)
        .map(|r| r.unit_point.clone())
        .collect()
}

/// Runs the two-level search: the cheap start design, the expensive one,
/// then one run at a time, level and point by the local steps
/// ([`MultiFidelitySettings::local_steps`]) or by [`propose`], until a
/// stop holds. `evaluate` runs unit-box points at a level and returns
/// each loss (`None`: failed) and wall time; its error ends the search.
///
/// # Errors
/// The evaluator's error, or a proposal that cannot be made.
pub fn minimise<E: From<BoError>>(
    cheap_start: Vec<Vec<f64>>,
    expensive_start: ExpensiveStart,
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
    let expensive_start = match expensive_start {
        ExpensiveStart::Points(points) => points,
        ExpensiveStart::BestCheap(count) => best_points(&runs, count),
    };
    run(
        Fidelity::Expensive,
        expensive_start,
        &mut runs,
        &mut evaluations_to_target,
    )?;
    let mut descent = settings.local_steps.clone().map(SurrogateDescent::new);
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
        let local = descent.as_mut().and_then(|descent| descent.next(&runs));
        let best_before = runs
            .iter()
            .filter(|r| r.level == Fidelity::Expensive)
            .filter_map(|r| r.loss)
            .fold(f64::INFINITY, f64::min);
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
        if let (Some(descent), Fidelity::Expensive) = (&mut descent, last.level) {
            descent.record_expensive(last.loss.is_some_and(|l| l < best_before));
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

    #[test]
    fn the_levels_are_compared_only_where_both_ran_and_succeeded() {
        let run = |level, x: f64, loss: Option<f64>| LevelRun {
            level,
            unit_point: vec![x],
            loss,
            residuals: Vec::new(),
            wall_s: 1.0,
        };
        let mut result = MultiFidelityResult {
            runs: vec![
                run(Fidelity::Cheap, 0.1, Some(1.0)),
                run(Fidelity::Cheap, 0.2, Some(4.5)),
                run(Fidelity::Cheap, 0.3, Some(2.0)),
                run(Fidelity::Cheap, 0.4, None),
                run(Fidelity::Expensive, 0.1, Some(3.0)),
                run(Fidelity::Expensive, 0.2, Some(5.0)),
                run(Fidelity::Expensive, 0.4, Some(9.0)),
                run(Fidelity::Expensive, 0.5, Some(7.0)),
            ],
            best: 4,
            stop: Stop::MaxEvaluations,
            evaluations_to_target: None,
            cost_s: [1.0, 1.0],
            rho: None,
        };
        // |3 - 1| and |5 - 4.5|: 0.3 has no expensive run, 0.4's cheap
        // run failed, 0.5 has no cheap run.
        assert_eq!(
            result.level_loss_difference(),
            Some(LevelLossDifference {
                points: 2,
                median: 1.25
            })
        );
        result.runs.truncate(4);
        assert_eq!(result.level_loss_difference(), None);
    }

    #[test]
    fn the_box_grows_halves_and_restarts_after_it_collapsed() {
        let settings = TrustRegionSettings::default();
        let mut descent = SurrogateDescent::new(settings.clone());
        descent.record_expensive(true);
        assert_eq!(descent.radius, 2.0 * settings.initial_radius);
        descent.record_expensive(true);
        descent.record_expensive(true);
        assert_eq!(
            descent.radius, settings.max_radius,
            "never past the largest box"
        );
        descent.record_expensive(false);
        assert_eq!(descent.radius, settings.max_radius / 2.0);
        // Collapsed: the two-level steps' runs that find nothing better
        // leave it so; one that beats the centre restarts the descent at
        // half the first box, as the one-level trust region resumes.
        descent.radius = settings.min_radius / 2.0;
        descent.record_expensive(false);
        assert!(descent.radius < settings.min_radius);
        descent.record_expensive(true);
        assert_eq!(descent.radius, settings.initial_radius / 2.0);
    }
}
