//! How sure the calibration is: the posterior of a study's parameters given
//! its measured values and their uncertainty, after the search.
//!
//! - [`likelihood`]: the density ([`likelihood::StudyPosterior`]): prior,
//!   measurement error (stated, or a noise scale of its own), and model
//!   [`discrepancy`] (constant, or a GP over the cases' inputs), each
//!   scale integrated out by a [`scale_grid`].
//! - Sampling by [`acq_algorithms::mcmc`]: a model that costs microseconds (the
//!   built-in excavator twin, [`super::study::Model::is_cheap`]) directly,
//!   the model run at every step; any other on an [`emulator`] of its
//!   logged runs, refined by real runs where the posterior lies.
//! - [`predictive`]: real model runs at posterior draws, for every fit and
//!   validation case, logged like every run (so they resume), and the
//!   intervals a new measurement should fall in.
//! - [`validation`]: the ASME V&V 20 statement for every validation case.
//! - [`report`]: the report's section (the table, the words, the corner
//!   plot) and the summary's keys.
//!
//! The run directory gets `posterior.csv` (every kept draw) and
//! `predictive.csv` (every predictive run's outputs).

use std::time::Instant;

use acq_algorithms::evaluation::{Evaluation, Evaluator, Simulator};
use acq_algorithms::mcmc::{sample, Chains, Marginal, SamplerProgress, SamplerSettings, Support};
use acq_error::{AcqError, Result};
use rand::SeedableRng;

use super::run_directory::{evaluation_error, write_text, RunDirectory};
use super::simulator::StudySimulator;
use super::study::{Measured, Model, Role, Study, CURVE_PARTS};

pub mod curve_parts;
pub mod discrepancy;
pub mod emulator;
mod factor_integral;
pub mod likelihood;
pub mod predictive;
pub mod report;
pub mod scale_grid;
pub mod sequential;
pub mod settings;
pub mod shared_errors;
pub mod validation;

pub use settings::{Discrepancy, PosteriorSettings};

use emulator::{refinement_points, Emulator, REFINE_RATIO, RUNS_PER_ROUND};
use likelihood::{standard_normal, Scales, StudyPosterior};
use predictive::Predictions;

/// The convergence a posterior's numbers need (Vehtari et al. 2021):
/// every R-hat below 1.01 and a bulk and a tail ESS of at least 100 per chain.
pub const RHAT_LIMIT: f64 = 1.01;
pub const ESS_PER_CHAIN: f64 = 100.0;

/// What the posterior stage found.
#[derive(Clone, Debug)]
pub struct PosteriorOutcome {
    pub density: StudyPosterior,
    /// The chains of the parameters, as sampled.
    pub chains: Chains,
    /// The columns: the parameters, then the scales drawn at each draw.
    pub names: Vec<String>,
    pub supports: Vec<Support>,
    /// `[chain][draw][column]`.
    pub draws: Vec<Vec<Vec<f64>>>,
    /// The scales at each draw, chain after chain.
    pub scales: Vec<Scales>,
    /// Per column.
    pub marginals: Vec<Marginal>,
    /// Each output's discrepancy `(mean, sd)`, in the order of
    /// [`StudyPosterior::outputs`].
    pub discrepancy: Vec<DiscrepancySummary>,
    pub predicted: Predictions,
    /// How it was sampled, in words.
    pub path: String,
    pub wall_s: f64,
    pub settings: PosteriorSettings,
}

impl PosteriorOutcome {
    /// The columns that have not converged, with why.
    pub fn unconverged(&self) -> Vec<String> {
        unconverged(&self.names, &self.marginals, self.settings.chains)
    }

    /// The index of column `name`.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }
}

/// The parts each fit curve is read as ([`CURVE_PARTS`]; 0 without one).
pub fn curve_parts_of(study: &Study) -> usize {
    if study
        .observations(Role::Fit)
        .iter()
        .any(|(case, o)| !case.priors && matches!(o.measured, Measured::Curve { .. }))
    {
        CURVE_PARTS
    } else {
        0
    }
}

/// Whether `study`'s posterior can be set up as `settings` ask: checked
/// when a spec is read, so a study that cannot have it fails before its
/// search, not after.
pub fn check_posterior(
    study: &Study,
    settings: &PosteriorSettings,
) -> std::result::Result<(), String> {
    StudyPosterior::new(study, settings.discrepancy, curve_parts_of(study)).map(|_| ())
}

/// How much longer an unconverged posterior is sampled, once.
const EXTENSION: usize = 4;

/// Each of `names` whose marginal has not converged, with its R-hat and
/// bulk and tail ESS.
fn unconverged(names: &[String], marginals: &[Marginal], chains: usize) -> Vec<String> {
    let needed = ESS_PER_CHAIN * chains as f64;
    names
        .iter()
        .zip(marginals)
        .filter_map(|(name, m)| {
            let rhat_ok = m.rhat < RHAT_LIMIT || chains < 2;
            // Both ESS, as Vehtari et al. (2021) ask: the bulk for the
            // centre, the tail for the 90 % intervals the verdicts read.
            let ess_ok = m.ess_bulk >= needed && m.ess_tail >= needed;
            (!(rhat_ok && ess_ok)).then(|| {
                format!(
                    "{name} (R-hat {:.3}, bulk ESS {:.0}, tail ESS {:.0})",
                    m.rhat, m.ess_bulk, m.ess_tail
                )
            })
        })
        .collect()
}

/// What the search left for the posterior: the calibrated point (the
/// chains start around it) and every fit run (an emulator learns from them).
pub struct SearchResult<'a> {
    pub calibrated: &'a [f64],
    pub evaluations: &'a [Evaluation],
    /// A two-level search's coarse runs (same outputs), which the
    /// emulator learns from too; empty otherwise.
    pub coarse_evaluations: &'a [Evaluation],
}

/// The model's fit outputs at a point and each observation's emulator
/// variance (empty for the model itself); `None` where it fails.
pub(crate) type ModelAt<'a> = dyn Fn(&[f64]) -> Option<(Vec<f64>, Vec<f64>)> + Sync + 'a;

/// Samples the posterior of `study` around the search's result and runs
/// the predictive runs; writes `posterior.csv` and `predictive.csv`.
#[allow(clippy::too_many_arguments)]
pub fn run_posterior(
    study: &Study,
    model: &dyn Model,
    search: &SearchResult<'_>,
    settings: &PosteriorSettings,
    directory: &RunDirectory,
    parallel: usize,
    resume: bool,
) -> Result<PosteriorOutcome> {
    let start = Instant::now();
    let curve_parts = curve_parts_of(study);
    let density =
        StudyPosterior::new(study, settings.discrepancy, curve_parts).map_err(AcqError::Config)?;
    let simulator = StudySimulator::new(study, model, Role::Fit).with_curve_parts(curve_parts);
    let centre: Vec<f64> = search
        .calibrated
        .iter()
        .zip(&density.coordinates)
        .map(|(&x, c)| inside(c.support, x))
        .collect();
    let direct = |point: &[f64]| simulator.evaluate(point).ok().map(|o| (o, Vec::new()));
    let emulator;
    let (at, how): (&ModelAt<'_>, String) = if model.is_cheap() {
        (
            &direct,
            "sampled directly (the model run at every step)".into(),
        )
    } else {
        let (refined, how) = refined_emulator(
            &density, &simulator, search, &centre, settings, directory, parallel, resume,
        )?;
        emulator = refined;
        (&|point: &[f64]| Some(emulator.predict(point)), how)
    };
    let (chains, sampler, extended) = sample_converged(&density, at, &centre, settings)?;
    let outputs = outputs_at_draws(&chains, at);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(settings.seed.wrapping_add(3));
    let scales: Vec<Scales> = outputs
        .iter()
        .map(|o| match o {
            Some((outputs, emulator)) => density.draw_scales(outputs, emulator, &mut rng),
            None => Scales::default(),
        })
        .collect();
    let mut names: Vec<String> = density.coordinates.iter().map(|c| c.name.clone()).collect();
    names.extend(density.scale_names());
    let mut supports = density.support();
    supports.extend(density.scale_supports());
    let mut pooled_scales = scales.iter();
    let draws: Vec<Vec<Vec<f64>>> = chains
        .draws
        .iter()
        .map(|chain| {
            chain
                .iter()
                .map(|draw| {
                    let scale = pooled_scales.next();
                    let mut row = draw.clone();
                    row.extend(scale.and_then(|s| s.noise_pct));
                    if let Some(scale) = scale {
                        for (factor, correlation) in
                            scale.curve_factor.iter().zip(&scale.curve_correlation)
                        {
                            row.extend([*factor, *correlation]);
                        }
                        row.extend(scale.discrepancy.iter().map(|d| d.tau));
                        row.extend(scale.discrepancy.iter().filter_map(|d| d.length));
                    }
                    row.resize(names.len(), f64::NAN);
                    row
                })
                .collect()
        })
        .collect();
    let marginals: Vec<Marginal> = (0..names.len())
        .map(|i| {
            let column: Vec<Vec<f64>> = draws
                .iter()
                .map(|chain| chain.iter().map(|d| d[i]).collect())
                .collect();
            Marginal::of(&column)
        })
        .collect();
    write_posterior_csv(&directory.file("posterior.csv"), &names, &draws, &chains)?;
    let discrepancy = discrepancy_moments(&density, &scales, settings.seed.wrapping_add(5));
    let predicted = predictive::predictive_runs(
        study, model, &density, &chains, &scales, settings, directory, parallel, resume,
    )?;
    Ok(PosteriorOutcome {
        path: format!(
            "{how}: {} chains of {} kept draws, one every {} steps after {} warmup steps (acceptance {:.2}){extended}",
            settings.chains,
            sampler.draws,
            chains.thin,
            sampler.warmup,
            chains.acceptance.iter().sum::<f64>() / chains.acceptance.len() as f64,
        ),
        density,
        chains,
        names,
        supports,
        draws,
        scales,
        marginals,
        discrepancy,
        predicted,
        wall_s: start.elapsed().as_secs_f64(),
        settings: PosteriorSettings {
            draws: sampler.draws,
            ..settings.clone()
        },
    })
}

/// The sampler's settings for `settings` in `dimensions` coordinates.
fn sampler_settings(settings: &PosteriorSettings, dimensions: usize) -> SamplerSettings {
    SamplerSettings {
        chains: settings.chains,
        draws: settings.draws,
        // The proposal's covariance needs more steps to settle in more dimensions.
        warmup: settings.draws.max(2000).max(500 * dimensions),
        thin: None,
        seed: settings.seed,
    }
}

/// Samples `density` with the outputs from `at`, the chains started
/// around `centre`; when a column has not converged, once more four times
/// as long. The chains, the sampler as last run, and a sentence on the
/// extension (empty without one).
pub(crate) fn sample_converged(
    density: &StudyPosterior,
    at: &ModelAt<'_>,
    centre: &[f64],
    settings: &PosteriorSettings,
) -> Result<(Chains, SamplerSettings, String)> {
    let mut sampler = sampler_settings(settings, density.coordinates.len());
    let mut chains = sample_on(density, at, centre, &sampler, "posterior")?;
    let coordinates: Vec<String> = density.coordinates.iter().map(|c| c.name.clone()).collect();
    let mut extended = String::new();
    let first = unconverged(&coordinates, &chains.summaries(), sampler.chains);
    if !first.is_empty() {
        // Once, four times as long: a slowly mixing posterior (a ridge the
        // random walk crawls along) usually converges so; the report says
        // whether it did.
        extended = format!(
            "; extended to {} draws per chain, since after {} {} had not converged",
            EXTENSION * sampler.draws,
            sampler.draws,
            first.join(", ")
        );
        eprintln!("posterior: not converged yet{extended}");
        sampler.draws *= EXTENSION;
        sampler.seed = sampler.seed.wrapping_add(1);
        chains = sample_on(density, at, centre, &sampler, "posterior (extended)")?;
    }
    Ok((chains, sampler, extended))
}

/// The log posterior density at a point: the prior's, plus the
/// likelihood of the model's outputs there from `at` (`-inf` where the
/// prior is zero or the model does not run).
fn log_density_of<'a>(
    density: &'a StudyPosterior,
    at: &'a ModelAt<'a>,
) -> impl Fn(&[f64]) -> f64 + Sync + 'a {
    move |point: &[f64]| -> f64 {
        let prior = density.log_prior(point);
        if prior == f64::NEG_INFINITY {
            return prior;
        }
        match at(point) {
            Some((outputs, emulator)) => prior + density.log_likelihood(&outputs, &emulator),
            None => f64::NEG_INFINITY,
        }
    }
}

/// Samples the density with the model's outputs from `at`, the chains
/// started around `centre`, a progress line every tenth of the steps.
fn sample_on(
    density: &StudyPosterior,
    at: &ModelAt<'_>,
    centre: &[f64],
    sampler: &SamplerSettings,
    label: &str,
) -> Result<Chains> {
    let log_density = log_density_of(density, at);
    let starts = chain_starts(density, centre, sampler, &log_density)?;
    let start = Instant::now();
    let printed = std::sync::atomic::AtomicUsize::new(0);
    let progress = |p: SamplerProgress| {
        // A line every tenth of each phase keeps a CI log short (the
        // sampling's tenths counted after the warmup's).
        let tenth = p.steps * 10 / p.total.max(1) + if p.warming_up { 0 } else { 100 };
        if printed.fetch_max(tenth + 1, std::sync::atomic::Ordering::Relaxed) <= tenth {
            eprintln!(
                "{label}: {} {}/{} steps, {:.0} s",
                if p.warming_up { "warmup" } else { "sampling" },
                p.steps,
                p.total,
                start.elapsed().as_secs_f64()
            );
        }
    };
    sample(
        log_density,
        &density.support(),
        &starts,
        &density
            .support()
            .into_iter()
            .map(initial_scale)
            .collect::<Vec<_>>(),
        sampler,
        &progress,
    )
    .map_err(|e| AcqError::Config(format!("posterior: {e}")))
}

/// The emulator of the search's runs, refined where the posterior lies
/// ([`emulator`]): the refinement runs go through the logging evaluator
/// (`posterior_refinement.csv`, resumable, on the study's executor).
/// Returns it with a sentence on how it was made.
#[allow(clippy::too_many_arguments)]
fn refined_emulator(
    density: &StudyPosterior,
    simulator: &StudySimulator<'_>,
    search: &SearchResult<'_>,
    centre: &[f64],
    settings: &PosteriorSettings,
    directory: &RunDirectory,
    parallel: usize,
    resume: bool,
) -> Result<(Emulator, String)> {
    let parameters = simulator.parameters().to_vec();
    let log = directory.file("posterior_refinement.csv");
    let mut evaluator = if resume {
        Evaluator::resume(simulator, &log, parallel)
    } else {
        Evaluator::create(simulator, &log, parallel)
    }
    .map_err(evaluation_error)?;
    let outputs = simulator.outputs().len();
    let mut runs: Vec<Evaluation> = search
        .evaluations
        .iter()
        .filter(|e| e.outcome.as_ref().is_ok_and(|y| y.len() == outputs))
        .cloned()
        .collect();
    if !density.curves.is_empty() && runs.len() < parameters.len() + 2 {
        return Err(AcqError::Config(format!(
            "posterior: the emulator of a curve learns from the search's runs with the curve's errors in parts, and the search logged {} of them; use method = \"bo\" with local_steps (the default), whose runs log them",
            runs.len()
        )));
    }
    let mut spent = 0;
    let mut round = 0u64;
    loop {
        let emulator = Emulator::fit(
            &parameters,
            density,
            &runs,
            search.coarse_evaluations,
            settings.seed,
        )
        .map_err(|e| AcqError::Config(format!("posterior: {e}")))?;
        let pilot = SamplerSettings {
            chains: settings.chains,
            draws: 250,
            warmup: 1000,
            thin: None,
            seed: settings.seed.wrapping_add(round),
        };
        let chains = sample_on(
            density,
            &|point: &[f64]| Some(emulator.predict(point)),
            centre,
            &pilot,
            "posterior (emulator check)",
        )?;
        let scales = typical_scales(density, &runs, settings.seed);
        let budget = settings.refinement_runs.saturating_sub(spent);
        let (points, at_95) = refinement_points(
            &emulator,
            density,
            &chains,
            &scales,
            // A tenth of a large budget per round: each round refits the
            // GPs and samples again.
            RUNS_PER_ROUND
                .max(parallel)
                .max(settings.refinement_runs / 10)
                .min(budget),
        );
        eprintln!(
            "posterior: emulator of {} runs; its sd at 95 % of the draws is {at_95:.2} of the measurement's (enough below {REFINE_RATIO}; beside it the runs' own scatter {:.2}); {} refinement runs so far",
            emulator.runs, emulator.scatter_ratio(density, &scales), spent
        );
        if points.is_empty() {
            let coarse = if emulator.coarse_runs > 0 {
                format!(
                    ", co-kriging over the search's {} coarse-mesh runs as well",
                    emulator.coarse_runs
                )
            } else {
                String::new()
            };
            let how = format!(
                "sampled on a Gaussian-process emulator of the model ({} runs: the search's and {spent} refinement runs where the posterior lies{coarse}; its sd at 95 % of the draws is {at_95:.2} of the measurement's{}",
                emulator.runs,
                if at_95 > REFINE_RATIO {
                    format!(", above the {REFINE_RATIO} aimed at: the {} refinement runs are spent, so the intervals carry the emulator's doubt", settings.refinement_runs)
                } else {
                    String::new()
                },
            );
            let scatter = emulator.scatter_ratio(density, &scales);
            let how = if scatter > REFINE_RATIO {
                format!("{how}; the runs' own scatter, or a jump the emulator cannot follow, adds up to {scatter:.2} of the measurement's sd, which the likelihood carries)")
            } else {
                format!("{how})")
            };
            return Ok((emulator, how));
        }
        let evaluations = evaluator.evaluate(&points).map_err(evaluation_error)?;
        spent += points.len();
        runs.extend(evaluations);
        round += 1;
    }
}

/// The measurement's scales the emulator's doubt is weighed against:
/// each the median of its draws at the real runs the posterior favours
/// most (the best tenth, at least five), where the model's values are
/// exact. Drawn on the emulator instead, the emulator's own variance would
/// take up the residuals and shrink the noise scales it is weighed
/// against, so refinement would chase a moving target.
fn typical_scales(density: &StudyPosterior, runs: &[Evaluation], seed: u64) -> Scales {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut scored: Vec<(f64, &Vec<f64>)> = runs
        .iter()
        .filter_map(|run| {
            let outputs = run.outcome.as_ref().ok()?;
            let value = density.log_prior(&run.parameters) + density.log_likelihood(outputs, &[]);
            value.is_finite().then_some((value, outputs))
        })
        .collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    scored.truncate((scored.len() / 10).max(5));
    let mut drawn: Vec<Scales> = Vec::new();
    for (_, outputs) in &scored {
        for _ in 0..20 {
            drawn.push(density.draw_scales(outputs, &[], &mut rng));
        }
    }
    let median = |values: Vec<f64>| {
        let mut values = values;
        values.sort_by(f64::total_cmp);
        acq_algorithms::mcmc::quantile(&values, 0.5)
    };
    Scales {
        noise_pct: density
            .noise
            .then(|| median(drawn.iter().filter_map(|s| s.noise_pct).collect())),
        curve_factor: (0..density.curves.len())
            .map(|c| median(drawn.iter().map(|s| s.curve_factor[c]).collect()))
            .collect(),
        curve_correlation: Vec::new(),
        discrepancy: Vec::new(),
    }
}

/// `value` moved at least 1 % of the interval inside it (its middle when
/// it is not a number).
fn inside(support: Support, value: f64) -> f64 {
    match support {
        Support::Interval { lower, upper } => {
            let margin = 0.01 * (upper - lower);
            if value.is_finite() {
                value.clamp(lower + margin, upper - margin)
            } else {
                (lower + upper) / 2.0
            }
        }
        _ => value,
    }
}

/// A first guess of a free coordinate's posterior spread: a twentieth of
/// an interval, a tenth in a logarithm or an unbounded coordinate (the
/// warmup adapts it by orders of magnitude if need be).
fn initial_scale(support: Support) -> f64 {
    match support {
        Support::Interval { lower, upper } => 0.05 * (upper - lower),
        Support::Positive | Support::Real => 0.1,
    }
}

/// One start per chain around `centre`: a random step of about twice
/// [`initial_scale`] in each free coordinate, halved until the posterior
/// is positive there.
fn chain_starts(
    density: &StudyPosterior,
    centre: &[f64],
    settings: &SamplerSettings,
    log_density: &dyn Fn(&[f64]) -> f64,
) -> Result<Vec<Vec<f64>>> {
    if log_density(centre) == f64::NEG_INFINITY {
        return Err(AcqError::Config(
            "posterior: the model does not run at the calibrated point, or it lies outside the prior; the chains have nowhere to start".into(),
        ));
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(settings.seed);
    let support = density.support();
    Ok((0..settings.chains)
        .map(|_| {
            let step: Vec<f64> = support
                .iter()
                .map(|s| initial_scale(*s) * 2.0 * standard_normal(&mut rng))
                .collect();
            let mut shrink = 1.0;
            for _ in 0..10 {
                let point: Vec<f64> = centre
                    .iter()
                    .zip(&support)
                    .zip(&step)
                    .map(|((&x, s), &dz)| s.from_free(s.to_free(x) + shrink * dz))
                    .collect();
                if log_density(&point) > f64::NEG_INFINITY {
                    return point;
                }
                shrink /= 2.0;
            }
            centre.to_vec()
        })
        .collect())
}

/// The fit outputs (and emulator variances) at every kept draw, chain
/// after chain, on every core.
fn outputs_at_draws(chains: &Chains, at: &ModelAt<'_>) -> Vec<Option<(Vec<f64>, Vec<f64>)>> {
    let draws: Vec<&Vec<f64>> = chains.pooled().collect();
    let workers = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = draws.len().div_ceil(workers).max(1);
    std::thread::scope(|scope| {
        let handles: Vec<_> = draws
            .chunks(chunk)
            .map(|part| scope.spawn(move || part.iter().map(|point| at(point)).collect::<Vec<_>>()))
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_default())
            .collect()
    })
}

/// One output's discrepancy over the draws, at one site.
#[derive(Clone, Debug, PartialEq)]
pub struct DiscrepancySummary {
    /// The output (and with `gp` the case: `case/output`).
    pub key: String,
    /// The index of its output in [`StudyPosterior::outputs`].
    pub output: usize,
    /// The mean of its conditional means, and by the law of total
    /// variance the sd (mean conditional variance plus the variance of
    /// the means).
    pub mean: f64,
    pub sd: f64,
    /// Its 90 % interval, from one draw of it per posterior draw.
    pub q05: f64,
    pub q95: f64,
}

/// Each output's discrepancy over the draws, at each of its sites.
fn discrepancy_moments(
    density: &StudyPosterior,
    scales: &[Scales],
    seed: u64,
) -> Vec<DiscrepancySummary> {
    let drawn: Vec<&Scales> = scales
        .iter()
        .filter(|s| !s.discrepancy.is_empty())
        .collect();
    let n = drawn.len().max(1) as f64;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut summaries = Vec::new();
    for (k, output) in density.outputs.iter().enumerate() {
        for (site, case) in output.sites().into_iter().enumerate() {
            let at = |s: &Scales| s.discrepancy[k].at_sites[site];
            let mean = drawn.iter().map(|s| at(s).0).sum::<f64>() / n;
            let spread = drawn.iter().map(|s| (at(s).0 - mean).powi(2)).sum::<f64>() / n;
            let within = drawn.iter().map(|s| at(s).1).sum::<f64>() / n;
            let mut samples: Vec<f64> = drawn
                .iter()
                .map(|s| at(s).0 + at(s).1.sqrt() * standard_normal(&mut rng))
                .collect();
            samples.sort_by(f64::total_cmp);
            summaries.push(DiscrepancySummary {
                key: if case.is_empty() {
                    output.output.clone()
                } else {
                    format!("{case}/{}", output.output)
                },
                output: k,
                mean,
                sd: (within + spread).sqrt(),
                q05: acq_algorithms::mcmc::quantile(&samples, 0.05),
                q95: acq_algorithms::mcmc::quantile(&samples, 0.95),
            });
        }
    }
    summaries
}

/// `posterior.csv`: `chain`, `draw`, every column by name,
/// `log_posterior` (of the parameters, up to a constant).
fn write_posterior_csv(
    path: &std::path::Path,
    names: &[String],
    draws: &[Vec<Vec<f64>>],
    chains: &Chains,
) -> Result<()> {
    let mut text = String::from("chain,draw");
    for name in names {
        text.push(',');
        text.push_str(name);
    }
    text.push_str(",log_posterior\n");
    for (chain, (rows, densities)) in draws.iter().zip(&chains.log_density).enumerate() {
        for (draw, (values, log_density)) in rows.iter().zip(densities).enumerate() {
            text.push_str(&format!("{},{}", chain + 1, draw + 1));
            for value in values {
                text.push_str(&format!(",{value}"));
            }
            text.push_str(&format!(",{log_density}\n"));
        }
    }
    write_text(path, &text)
}
