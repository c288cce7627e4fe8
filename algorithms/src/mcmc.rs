//! Draws from a posterior known up to a constant: adaptive random-walk
//! Metropolis, several chains in parallel, in an unconstrained space.
//!
//! - **Where coordinates live.** A bounded coordinate is sampled in its
//!   own units, a proposal past a bound refused (the posterior is zero
//!   there); a positive one as its logarithm (with the Jacobian in the
//!   target). A logit transform would give a posterior that reaches a
//!   bound an exponential tail, where a random walk crawls; folding a
//!   proposal back in at the bound would bias the chain, since a folded
//!   correlated step is not symmetric.
//! - **Warmup** (not kept): the proposal's covariance is the sample
//!   covariance of the chain's last window (windows of 25, 50, 100, ...
//!   steps, as Stan adapts its mass matrix), its scale is adapted towards
//!   the acceptance rate that is optimal for a random walk (Roberts and
//!   Rosenthal: 0.44 in one dimension, 0.234 in many), and a last pilot
//!   stretch with both frozen measures the integrated autocorrelation time
//!   `tau`. After warmup the kernel is fixed, so the kept draws are a
//!   Markov chain with the posterior as its stationary law.
//! - **Differential-evolution moves** (ter Braak and Vrugt 2008): after
//!   adaptation every other step, at random, proposes the chain's state
//!   plus the scaled difference of two of its own states from the
//!   adaptation's last quarter (one in ten at full length). The archive is
//!   frozen before the pilot, so the move is symmetric and exact; its
//!   steps follow the posterior's own shape where one Gaussian proposal
//!   cannot (a curved ridge, as an emulated FE model's posterior has: on
//!   the GTN twin's it doubled the effective samples per step).
//! - **Thinning**: one draw is kept every `ceil(tau / 2)` steps (the same
//!   for all chains), so a thousand kept draws are worth several hundred
//!   independent ones whatever the dimension.
//!
//! Written here, not taken from a crate: the models this engine samples
//! (a user's solver, an FE twin) give no gradients, so gradient samplers
//! (`nuts-rs`) would need finite differences of outputs that are not
//! smooth to that precision; a random walk needs only the density.

use faer::{Mat, Side};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::chain_diagnostics::{ess_bulk, ess_tail, hdi, mcse_mean, mcse_sd, rank_rhat};

/// Where one coordinate may lie.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Support {
    /// Strictly between two finite bounds.
    Interval { lower: f64, upper: f64 },
    /// Above zero.
    Positive,
    /// Anywhere.
    Real,
}

impl Support {
    /// The free coordinate of `x`.
    pub fn to_free(self, x: f64) -> f64 {
        match self {
            Support::Interval { .. } | Support::Real => x,
            Support::Positive => x.max(f64::MIN_POSITIVE).ln(),
        }
    }

    /// The value of free coordinate `z`.
    pub fn from_free(self, z: f64) -> f64 {
        match self {
            Support::Interval { .. } | Support::Real => z,
            Support::Positive => z.exp(),
        }
    }

    /// Whether free coordinate `z` lies in the support.
    pub fn holds(self, z: f64) -> bool {
        match self {
            Support::Interval { lower, upper } => (lower..=upper).contains(&z),
            Support::Positive | Support::Real => z.is_finite(),
        }
    }

    /// `ln |dx/dz|` at free coordinate `z`: the density of `z` is the
    /// density of `x` times it.
    pub fn log_jacobian(self, z: f64) -> f64 {
        match self {
            Support::Positive => z,
            Support::Interval { .. } | Support::Real => 0.0,
        }
    }
}

/// How many chains and draws.
#[derive(Clone, Debug, PartialEq)]
pub struct SamplerSettings {
    pub chains: usize,
    /// Kept draws per chain.
    pub draws: usize,
    /// Steps per chain before the first kept one (adaptation and pilot).
    pub warmup: usize,
    /// Steps per kept draw; `None`: `ceil(tau / 2)` from the pilot.
    pub thin: Option<usize>,
    pub seed: u64,
}

impl Default for SamplerSettings {
    fn default() -> Self {
        SamplerSettings {
            chains: 4,
            draws: 1000,
            warmup: 2000,
            thin: None,
            seed: 1,
        }
    }
}

/// The largest thinning the pilot may ask for: beyond it the chains are
/// stuck, and the diagnostics should say so rather than the run take
/// a hundred times longer.
pub const MAX_THIN: usize = 100;

/// The draws of every chain.
#[derive(Clone, Debug)]
pub struct Chains {
    /// `[chain][draw][coordinate]`, in the coordinates' own units.
    pub draws: Vec<Vec<Vec<f64>>>,
    /// The log density of each draw (as the caller computes it, without
    /// the free transform's Jacobian).
    pub log_density: Vec<Vec<f64>>,
    /// Each chain's share of accepted proposals after warmup.
    pub acceptance: Vec<f64>,
    /// Steps per kept draw.
    pub thin: usize,
    /// Evaluations of the density, all chains.
    pub evaluations: usize,
}

impl Chains {
    /// One coordinate's draws, chain by chain.
    pub fn coordinate(&self, index: usize) -> Vec<Vec<f64>> {
        self.draws
            .iter()
            .map(|chain| chain.iter().map(|draw| draw[index]).collect())
            .collect()
    }

    /// Every draw of every chain, chain after chain.
    pub fn pooled(&self) -> impl Iterator<Item = &Vec<f64>> {
        self.draws.iter().flatten()
    }

    /// The summary of each coordinate.
    pub fn summaries(&self) -> Vec<Marginal> {
        let dimensions = self
            .draws
            .first()
            .and_then(|c| c.first())
            .map_or(0, Vec::len);
        (0..dimensions)
            .map(|i| Marginal::of(&self.coordinate(i)))
            .collect()
    }
}

/// A coordinate's posterior in numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Marginal {
    pub mean: f64,
    /// Standard deviation of the draws.
    pub sd: f64,
    pub q05: f64,
    pub q50: f64,
    pub q95: f64,
    /// Rank-normalised split R-hat; NaN when it cannot be computed.
    pub rhat: f64,
    /// Bulk effective sample size; NaN when it cannot be computed.
    pub ess_bulk: f64,
    /// Tail effective sample size (of the 5 % and 95 % quantiles).
    pub ess_tail: f64,
    /// Monte-Carlo standard errors of the mean and of the sd.
    pub mcse_mean: f64,
    pub mcse_sd: f64,
    /// The 90 % highest-density interval.
    pub hdi90: (f64, f64),
}

impl Marginal {
    /// The summary of chains of one coordinate.
    pub fn of(chains: &[Vec<f64>]) -> Marginal {
        let pooled: Vec<f64> = chains.iter().flatten().copied().collect();
        let n = pooled.len() as f64;
        let mean = pooled.iter().sum::<f64>() / n;
        let sd = (pooled.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let mut sorted = pooled;
        sorted.sort_by(f64::total_cmp);
        Marginal {
            mean,
            sd,
            q05: quantile(&sorted, 0.05),
            q50: quantile(&sorted, 0.5),
            q95: quantile(&sorted, 0.95),
            rhat: rank_rhat(chains).unwrap_or(f64::NAN),
            ess_bulk: ess_bulk(chains).unwrap_or(f64::NAN),
            ess_tail: ess_tail(chains).unwrap_or(f64::NAN),
            mcse_mean: mcse_mean(chains).unwrap_or(f64::NAN),
            mcse_sd: mcse_sd(chains).unwrap_or(f64::NAN),
            hdi90: hdi(&sorted, 0.9).unwrap_or((f64::NAN, f64::NAN)),
        }
    }
}

pub use crate::chain_diagnostics::quantile;

/// Why no chain could be run.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SamplerError {
    #[error("{0}")]
    Settings(String),
    #[error(
        "chain {chain} starts where the posterior is zero ({start:?}); start it where the model runs and the prior holds"
    )]
    ZeroAtStart { chain: usize, start: Vec<f64> },
}

/// Where the sampler is, for a progress line.
#[derive(Clone, Copy, Debug)]
pub struct SamplerProgress {
    /// Steps taken and to take, all chains (warmup included; the total
    /// is known once warmup has set the thinning).
    pub steps: usize,
    pub total: usize,
    pub warming_up: bool,
}

/// How the chains' proposal begins.
#[derive(Clone, Copy, Debug)]
pub enum InitialProposal<'a> {
    /// A guess of each free coordinate's posterior spread (a tenth of it
    /// or ten times it costs warmup, not correctness); warmup learns the
    /// covariance from the chains.
    Scales(&'a [f64]),
    /// A covariance of the free coordinates that already has the
    /// posterior's shape (an earlier posterior's, when each update adds
    /// data to the last): warmup adapts its scale and re-learns the shape
    /// only from a long window.
    Covariance(&'a [Vec<f64>]),
}

/// Samples `log_density` (of the coordinates in their own units, `-inf`
/// where zero) over `support`, one chain from each of `starts`.
/// `initial_scale` is a guess of each free coordinate's posterior spread
/// (a tenth of it or ten times it costs warmup, not correctness).
pub fn sample<F>(
    log_density: F,
    support: &[Support],
    starts: &[Vec<f64>],
    initial_scale: &[f64],
    settings: &SamplerSettings,
    progress: &(dyn Fn(SamplerProgress) + Sync),
) -> Result<Chains, SamplerError>
where
    F: Fn(&[f64]) -> f64 + Sync,
{
    let mut chains = warm_up(
        &log_density,
        support,
        starts,
        InitialProposal::Scales(initial_scale),
        settings,
        progress,
    )?;
    Ok(chains.draw(settings.draws, progress))
}

/// Chains after warmup: their kernels fixed, ready to draw.
pub struct WarmChains<'a> {
    target: FreeTarget<'a>,
    chains: Vec<ChainState>,
    /// Steps per kept draw.
    pub thin: usize,
    /// Steps taken so far, all chains, warmup included.
    steps: usize,
    warmup_steps: usize,
    kept: Chains,
}

/// Warms up one chain from each of `starts` on `log_density` over
/// `support` ([`sample`] is this and one [`WarmChains::draw`]).
pub fn warm_up<'a>(
    log_density: &'a (dyn Fn(&[f64]) -> f64 + Sync),
    support: &'a [Support],
    starts: &[Vec<f64>],
    proposal: InitialProposal<'_>,
    settings: &SamplerSettings,
    progress: &(dyn Fn(SamplerProgress) + Sync),
) -> Result<WarmChains<'a>, SamplerError> {
    check(support, starts, proposal, settings)?;
    let target = FreeTarget {
        log_density,
        support,
    };
    let factor = proposal_factor(proposal, support.len());
    let first_window = match proposal {
        InitialProposal::Scales(_) => FIRST_WINDOW,
        InitialProposal::Covariance(_) => FIRST_WINDOW_WARM,
    };
    let steps = std::sync::atomic::AtomicUsize::new(0);
    let warmup_total = settings.chains * settings.warmup;
    let tick = || {
        let done = steps.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        if done % 1000 == 0 {
            progress(SamplerProgress {
                steps: done,
                total: warmup_total,
                warming_up: true,
            });
        }
    };
    let mut chains: Vec<ChainState> = starts
        .iter()
        .enumerate()
        .map(|(index, start)| ChainState::new(&target, index, start, &factor, settings.seed))
        .collect::<Result<_, _>>()?;
    std::thread::scope(|scope| {
        for chain in chains.iter_mut() {
            let target = &target;
            let tick = &tick;
            scope.spawn(move || chain.warm_up(target, settings.warmup, first_window, tick));
        }
    });
    let thin = settings.thin.unwrap_or_else(|| {
        let tau = chains.iter().map(|c| c.pilot_tau).fold(1.0f64, f64::max);
        ((tau / 2.0).ceil() as usize).clamp(1, MAX_THIN)
    });
    let kept = Chains {
        draws: vec![Vec::new(); chains.len()],
        log_density: vec![Vec::new(); chains.len()],
        acceptance: vec![0.0; chains.len()],
        thin,
        evaluations: 0,
    };
    Ok(WarmChains {
        target,
        chains,
        thin,
        steps: warmup_total,
        warmup_steps: warmup_total,
        kept,
    })
}

impl WarmChains<'_> {
    /// `draws` more kept draws per chain, one every `thin` steps, after
    /// those drawn before: every draw so far.
    pub fn draw(&mut self, draws: usize, progress: &(dyn Fn(SamplerProgress) + Sync)) -> Chains {
        let thin = self.thin;
        let before = self.steps;
        let total = before + self.chains.len() * draws * thin;
        let steps = std::sync::atomic::AtomicUsize::new(before);
        let tick = || {
            let done = steps.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            if done % 1000 == 0 {
                progress(SamplerProgress {
                    steps: done,
                    total,
                    warming_up: false,
                });
            }
        };
        let target = &self.target;
        let kept: Vec<(Vec<Vec<f64>>, Vec<f64>, f64)> = std::thread::scope(|scope| {
            let handles: Vec<_> = self
                .chains
                .iter_mut()
                .map(|chain| {
                    let tick = &tick;
                    scope.spawn(move || chain.keep(target, draws, thin, tick))
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("a chain does not panic"))
                .collect()
        });
        let drawn_before = self.kept.draws.first().map_or(0, Vec::len) as f64;
        for (k, (draws_k, densities, acceptance)) in kept.into_iter().enumerate() {
            // The acceptance over every kept step, old and new.
            let weight = draws as f64 / (drawn_before + draws as f64);
            self.kept.acceptance[k] += weight * (acceptance - self.kept.acceptance[k]);
            self.kept.draws[k].extend(draws_k);
            self.kept.log_density[k].extend(densities);
        }
        self.steps = total;
        self.kept.evaluations = self.chains.iter().map(|c| c.evaluations).sum();
        progress(SamplerProgress {
            steps: total,
            total,
            warming_up: false,
        });
        self.kept.clone()
    }

    /// Steps taken in warmup, all chains.
    pub fn warmup_steps(&self) -> usize {
        self.warmup_steps
    }
}

/// The proposal's lower Cholesky factor (row-major): of the covariance,
/// or the diagonal of the scales (a covariance that is not positive
/// definite falls back to its diagonal's square roots).
fn proposal_factor(proposal: InitialProposal<'_>, d: usize) -> Vec<f64> {
    let mut factor = vec![0.0; d * d];
    let diagonal = |factor: &mut Vec<f64>, scales: &mut dyn Iterator<Item = f64>| {
        for (i, s) in scales.enumerate() {
            factor[i * d + i] = s;
        }
    };
    match proposal {
        InitialProposal::Scales(scales) => diagonal(&mut factor, &mut scales.iter().copied()),
        InitialProposal::Covariance(covariance) => {
            let matrix = Mat::<f64>::from_fn(d, d, |i, j| covariance[i][j]);
            match matrix.llt(Side::Lower) {
                Ok(llt) => {
                    let lower = llt.L();
                    for i in 0..d {
                        for j in 0..=i {
                            factor[i * d + j] = lower[(i, j)];
                        }
                    }
                }
                Err(_) => diagonal(&mut factor, &mut (0..d).map(|i| covariance[i][i].sqrt())),
            }
        }
    }
    factor
}

/// The first covariance window's steps: from a guess of scales, and from
/// a covariance with the posterior's shape (a short window's estimate
/// would be worse than it).
const FIRST_WINDOW: usize = 25;
const FIRST_WINDOW_WARM: usize = 100;

fn check(
    support: &[Support],
    starts: &[Vec<f64>],
    proposal: InitialProposal<'_>,
    settings: &SamplerSettings,
) -> Result<(), SamplerError> {
    let problem = |what: &str| Err(SamplerError::Settings(what.into()));
    if support.is_empty() {
        return problem("nothing to sample: no coordinate");
    }
    if settings.chains == 0 || settings.draws < 4 {
        return problem("give at least one chain and 4 draws");
    }
    if settings.warmup < 100 {
        return problem("give at least 100 warmup steps: the proposal needs them to adapt");
    }
    if settings.thin == Some(0) {
        return problem("thin must be at least 1");
    }
    if starts.len() != settings.chains {
        return problem("give one start per chain");
    }
    if starts.iter().any(|s| s.len() != support.len()) {
        return problem("every start needs one value per coordinate");
    }
    match proposal {
        InitialProposal::Scales(initial_scale) => {
            if initial_scale.len() != support.len() {
                return problem("the initial scale needs one value per coordinate");
            }
            if initial_scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
                return problem("the initial scale must be finite and above 0");
            }
        }
        InitialProposal::Covariance(covariance) => {
            let d = support.len();
            if covariance.len() != d || covariance.iter().any(|row| row.len() != d) {
                return problem(
                    "the initial covariance must be square, one row and column per coordinate",
                );
            }
            if covariance.iter().flatten().any(|c| !c.is_finite())
                || (0..d).any(|i| covariance[i][i] <= 0.0)
            {
                return problem("the initial covariance must be finite with a positive diagonal");
            }
        }
    }
    for s in support {
        if let Support::Interval { lower, upper } = s {
            if !(lower.is_finite() && upper.is_finite() && lower < upper) {
                return problem("an interval's bounds must be finite, the lower below the upper");
            }
        }
    }
    Ok(())
}

/// The density of the free coordinates.
struct FreeTarget<'a> {
    log_density: &'a (dyn Fn(&[f64]) -> f64 + Sync),
    support: &'a [Support],
}

impl FreeTarget<'_> {
    fn values(&self, free: &[f64]) -> Vec<f64> {
        free.iter()
            .zip(self.support)
            .map(|(&z, s)| s.from_free(z))
            .collect()
    }

    /// `(log density of the free point, of the values)`.
    fn evaluate(&self, free: &[f64]) -> (f64, f64) {
        if !free.iter().zip(self.support).all(|(&z, s)| s.holds(z)) {
            return (f64::NEG_INFINITY, f64::NEG_INFINITY);
        }
        let density = (self.log_density)(&self.values(free));
        if density.is_nan() || density == f64::NEG_INFINITY {
            return (f64::NEG_INFINITY, f64::NEG_INFINITY);
        }
        let jacobian: f64 = free
            .iter()
            .zip(self.support)
            .map(|(&z, s)| s.log_jacobian(z))
            .sum();
        (density + jacobian, density)
    }
}

/// One chain: where it is and its proposal.
struct ChainState {
    rng: ChaCha8Rng,
    free: Vec<f64>,
    /// Log density at `free`: of the free point, and of the values.
    log_target: f64,
    log_density: f64,
    /// The proposal's covariance's Cholesky factor (row-major, lower) and
    /// the log of its scale.
    factor: Vec<f64>,
    log_scale: f64,
    /// Past states of the adaptation's last quarter (free coordinates), frozen
    /// before the pilot: the differences the DE moves take.
    archive: Vec<Vec<f64>>,
    pilot_tau: f64,
    evaluations: usize,
}

impl ChainState {
    fn new(
        target: &FreeTarget<'_>,
        index: usize,
        start: &[f64],
        factor: &[f64],
        seed: u64,
    ) -> Result<Self, SamplerError> {
        let free: Vec<f64> = start
            .iter()
            .zip(target.support)
            .map(|(&x, s)| s.to_free(x))
            .collect();
        let (log_target, log_density) = target.evaluate(&free);
        if log_target == f64::NEG_INFINITY {
            return Err(SamplerError::ZeroAtStart {
                chain: index + 1,
                start: start.to_vec(),
            });
        }
        let d = free.len();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(index as u64 + 1);
        Ok(ChainState {
            rng,
            free,
            log_target,
            log_density,
            factor: factor.to_vec(),
            log_scale: optimal_scale(d).ln(),
            archive: Vec::new(),
            pilot_tau: 1.0,
            evaluations: 1,
        })
    }

    /// One Metropolis step; the acceptance probability. Once the archive
    /// is frozen, every other step (at random) is a differential-evolution
    /// move (ter Braak and Vrugt 2008): the difference of two archived
    /// states, scaled, so the step follows the posterior's own shape,
    /// and one in ten of them at full length, a jump across it. Drawn
    /// from a fixed archive the difference is as likely as its negative,
    /// so the move is symmetric and the Metropolis ratio stands.
    fn step(&mut self, target: &FreeTarget<'_>) -> f64 {
        let d = self.free.len();
        let proposal: Vec<f64> = if self.archive.len() >= ARCHIVE_MIN
            && self.rng.random::<f64>() < DE_SHARE
        {
            let n = self.archive.len();
            let first = self.rng.random_range(0..n);
            let second = (first + self.rng.random_range(1..n)) % n;
            let gamma = if self.rng.random::<f64>() < 0.1 {
                1.0
            } else {
                optimal_scale(2 * d)
            };
            let (a, b) = (&self.archive[first], &self.archive[second]);
            (0..d)
                .map(|i| self.free[i] + gamma * (a[i] - b[i]))
                .collect()
        } else {
            let normal: Vec<f64> = (0..d).map(|_| self.rng.sample(StandardNormal)).collect();
            let scale = self.log_scale.exp();
            (0..d)
                .map(|i| {
                    let row = &self.factor[i * d..i * d + i + 1];
                    self.free[i] + scale * row.iter().zip(&normal).map(|(l, n)| l * n).sum::<f64>()
                })
                .collect()
        };
        let (log_target, log_density) = target.evaluate(&proposal);
        self.evaluations += 1;
        let ratio = log_target - self.log_target;
        let accept = if ratio.is_nan() {
            0.0
        } else {
            ratio.min(0.0).exp()
        };
        if self.rng.random::<f64>() < accept {
            self.free = proposal;
            self.log_target = log_target;
            self.log_density = log_density;
        }
        accept
    }

    /// Adapts the proposal for 70 % of `steps`: the first 15 % of those
    /// find the scale from wherever the chain started, the next 75 % learn
    /// the covariance window by window (each window twice the last, the
    /// last stretched to the end), the last 10 % the scale for the final
    /// covariance. Then a pilot with both frozen measures the
    /// autocorrelation time.
    fn warm_up(
        &mut self,
        target: &FreeTarget<'_>,
        steps: usize,
        first_window: usize,
        tick: &dyn Fn(),
    ) {
        let d = self.free.len();
        let adapting = steps * 7 / 10;
        let (windows_from, windows_to) = (adapting * 15 / 100, adapting * 90 / 100);
        let goal = optimal_acceptance(d);
        let mut window: Vec<Vec<f64>> = Vec::new();
        let mut window_length = first_window;
        let mut since_reset = 0usize;
        // From the last quarter of adaptation: the chain has left where it
        // started by then, and its states are the posterior's shape.
        let archive_from = adapting * 3 / 4;
        let archive_every = ((adapting - archive_from) / ARCHIVE_SIZE).max(1);
        // The archive fills while adapting and only then takes part: the
        // scale adapts to the random-walk steps alone.
        let mut archive = Vec::new();
        for step in 0..adapting {
            let accept = self.step(target);
            tick();
            if step >= archive_from && step % archive_every == 0 {
                archive.push(self.free.clone());
            }
            since_reset += 1;
            // Robbins-Monro on the scale; the gain fades within a window.
            self.log_scale += (accept - goal) / (since_reset as f64).powf(0.6);
            if !(windows_from..windows_to).contains(&step) {
                continue;
            }
            window.push(self.free.clone());
            let left = windows_to - step - 1;
            if (window.len() >= window_length && left >= 2 * window_length) || left == 0 {
                if window.len() > d + 1 {
                    self.adopt_covariance(&window);
                    since_reset = 0;
                }
                window.clear();
                window_length *= 2;
            }
        }
        self.archive = archive;
        let pilot: Vec<Vec<f64>> = (adapting..steps)
            .map(|_| {
                self.step(target);
                tick();
                self.free.clone()
            })
            .collect();
        self.pilot_tau = (0..d)
            .filter_map(|i| {
                let coordinate: Vec<f64> = pilot.iter().map(|z| z[i]).collect();
                ess_bulk(&[coordinate]).map(|ess| pilot.len() as f64 / ess.max(1.0))
            })
            .fold(1.0, f64::max);
    }

    /// The window's covariance (shrunk a little towards its diagonal, as
    /// Stan regularises its mass matrix) as the proposal's; the scale
    /// starts again from the random walk's optimum. A window without a
    /// move in some coordinate keeps the proposal it has.
    fn adopt_covariance(&mut self, window: &[Vec<f64>]) {
        let (n, d) = (window.len(), self.free.len());
        let mean: Vec<f64> = (0..d)
            .map(|i| window.iter().map(|z| z[i]).sum::<f64>() / n as f64)
            .collect();
        let covariance = Mat::<f64>::from_fn(d, d, |i, j| {
            window
                .iter()
                .map(|z| (z[i] - mean[i]) * (z[j] - mean[j]))
                .sum::<f64>()
                / (n as f64 - 1.0)
        });
        if (0..d).any(|i| !(covariance[(i, i)].is_finite() && covariance[(i, i)] > 0.0)) {
            return;
        }
        let weight = n as f64 / (n as f64 + 5.0);
        let shrunk = Mat::<f64>::from_fn(d, d, |i, j| {
            let c = covariance[(i, j)];
            if i == j {
                c
            } else {
                weight * c
            }
        });
        let Ok(llt) = shrunk.llt(Side::Lower) else {
            return;
        };
        let lower = llt.L();
        for i in 0..d {
            for j in 0..d {
                self.factor[i * d + j] = if j <= i { lower[(i, j)] } else { 0.0 };
            }
        }
        self.log_scale = optimal_scale(d).ln();
    }

    /// `draws` kept draws, one every `thin` steps: `(draws, their log
    /// densities, the acceptance rate)`.
    fn keep(
        &mut self,
        target: &FreeTarget<'_>,
        draws: usize,
        thin: usize,
        tick: &dyn Fn(),
    ) -> (Vec<Vec<f64>>, Vec<f64>, f64) {
        let mut kept = Vec::with_capacity(draws);
        let mut densities = Vec::with_capacity(draws);
        let mut accepted = 0.0;
        for _ in 0..draws {
            for _ in 0..thin {
                accepted += self.step(target);
                tick();
            }
            kept.push(target.values(&self.free));
            densities.push(self.log_density);
        }
        (kept, densities, accepted / (draws * thin) as f64)
    }
}

/// States the DE moves draw from, and the fewest they need.
const ARCHIVE_SIZE: usize = 1000;
const ARCHIVE_MIN: usize = 20;
/// The share of steps that are DE moves once the archive is frozen.
const DE_SHARE: f64 = 0.5;

/// The random walk's optimal step for a Gaussian target, relative to its
/// covariance: `2.38 / sqrt(d)` (Roberts, Gelman and Gilks 1997).
fn optimal_scale(dimensions: usize) -> f64 {
    2.38 / (dimensions as f64).sqrt()
}

/// The acceptance rate that goes with it: 0.44 in one dimension, falling
/// to 0.234 from about five.
fn optimal_acceptance(dimensions: usize) -> f64 {
    match dimensions {
        1 => 0.44,
        2 => 0.35,
        3 | 4 => 0.28,
        _ => 0.234,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_progress(_: SamplerProgress) {}

    #[test]
    fn free_coordinates_round_trip_and_their_jacobian_is_the_derivative() {
        for support in [
            Support::Interval {
                lower: -2.0,
                upper: 5.0,
            },
            Support::Positive,
            Support::Real,
        ] {
            for x in [0.3, 1.0, 4.9] {
                let z = support.to_free(x);
                assert!((support.from_free(z) - x).abs() < 1e-12);
                let h = 1e-6;
                let derivative = (support.from_free(z + h) - support.from_free(z - h)) / (2.0 * h);
                assert!(
                    (support.log_jacobian(z) - derivative.ln()).abs() < 1e-7,
                    "{support:?} at {x}"
                );
            }
        }
    }

    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        let sorted = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(quantile(&sorted, 0.5), 3.0);
        assert_eq!(quantile(&sorted, 0.05), 1.2);
        assert_eq!(quantile(&sorted, 1.0), 5.0);
    }

    /// A correlated Gaussian: the draws' mean and covariance agree with
    /// the density's within a few Monte-Carlo standard errors, and the
    /// chains have mixed.
    #[test]
    fn a_correlated_gaussian_is_sampled_with_its_moments() {
        let (mean, sd, rho) = ([1.0, -3.0], [0.5, 2.0], 0.9);
        let log_density = |x: &[f64]| {
            let a = (x[0] - mean[0]) / sd[0];
            let b = (x[1] - mean[1]) / sd[1];
            -(a * a - 2.0 * rho * a * b + b * b) / (2.0 * (1.0 - rho * rho))
        };
        let settings = SamplerSettings::default();
        let chains = sample(
            log_density,
            &[Support::Real, Support::Real],
            &vec![vec![0.0, 0.0]; settings.chains],
            &[1.0, 1.0],
            &settings,
            &no_progress,
        )
        .unwrap();
        let summaries = chains.summaries();
        for (i, s) in summaries.iter().enumerate() {
            assert!(s.rhat < 1.01, "R-hat {}", s.rhat);
            assert!(s.ess_bulk > 400.0, "ESS {}", s.ess_bulk);
            assert!(
                (s.mean - mean[i]).abs() < 4.0 * s.mcse_mean,
                "mean {} of {}",
                s.mean,
                mean[i]
            );
            assert!((s.sd / sd[i] - 1.0).abs() < 0.1, "sd {} of {}", s.sd, sd[i]);
        }
        let n = chains.pooled().count() as f64;
        let correlation = chains
            .pooled()
            .map(|x| (x[0] - summaries[0].mean) * (x[1] - summaries[1].mean))
            .sum::<f64>()
            / (n - 1.0)
            / (summaries[0].sd * summaries[1].sd);
        assert!(
            (correlation - rho).abs() < 0.03,
            "correlation {correlation}"
        );
    }

    /// A uniform density on an interval: the free transform's Jacobian is
    /// what makes the draws uniform, up to the bounds.
    #[test]
    fn a_flat_density_on_an_interval_gives_uniform_draws() {
        let settings = SamplerSettings {
            seed: 3,
            ..SamplerSettings::default()
        };
        let chains = sample(
            |_: &[f64]| 0.0,
            &[Support::Interval {
                lower: 2.0,
                upper: 4.0,
            }],
            &vec![vec![3.0]; settings.chains],
            &[1.0],
            &settings,
            &no_progress,
        )
        .unwrap();
        let s = chains.summaries()[0];
        // Uniform on [2, 4]: mean 3, sd 2 / sqrt(12), 5 % and 95 % at 2.1 and 3.9.
        assert!((s.mean - 3.0).abs() < 4.0 * s.mcse_mean);
        assert!((s.sd - 2.0 / 12f64.sqrt()).abs() < 0.03);
        assert!((s.q05 - 2.1).abs() < 0.05 && (s.q95 - 3.9).abs() < 0.05);
    }

    #[test]
    fn a_start_outside_the_posterior_or_bad_settings_are_refused() {
        let settings = SamplerSettings {
            chains: 1,
            ..SamplerSettings::default()
        };
        let outside = sample(
            |x: &[f64]| if x[0] > 0.0 { 0.0 } else { f64::NEG_INFINITY },
            &[Support::Real],
            &[vec![-1.0]],
            &[1.0],
            &settings,
            &no_progress,
        );
        assert!(matches!(
            outside,
            Err(SamplerError::ZeroAtStart { chain: 1, .. })
        ));
        let few = SamplerSettings {
            draws: 2,
            ..settings.clone()
        };
        let refused = sample(
            |_: &[f64]| 0.0,
            &[Support::Real],
            &[vec![0.0]],
            &[1.0],
            &few,
            &no_progress,
        );
        assert!(matches!(refused, Err(SamplerError::Settings(_))));
    }

    #[test]
    fn the_same_seed_gives_the_same_draws() {
        let settings = SamplerSettings {
            chains: 2,
            draws: 50,
            warmup: 200,
            ..SamplerSettings::default()
        };
        let run = || {
            sample(
                |x: &[f64]| -x[0] * x[0] / 2.0,
                &[Support::Real],
                &[vec![0.0], vec![1.0]],
                &[1.0],
                &settings,
                &no_progress,
            )
            .unwrap()
            .draws
        };
        assert_eq!(run(), run());
    }
}
