//! A posterior updated as data come: each update starts where the last
//! one ended (a study at the rig adds a hold at a time).
//!
//! The first update is sampled as a study's posterior is: a full warmup
//! from scales around a centre. Each later one starts its chains at draws of
//! the last posterior, its proposal at their covariance, its thinning at
//! the autocorrelation time its chains showed; a short warmup then adapts
//! the proposal's scale to the new data (and its shape, from one long
//! window). The chains draw in blocks until every coordinate has
//! converged ([`super::RHAT_LIMIT`], [`super::ESS_PER_CHAIN`]) or
//! [`MAX_BLOCKS`] blocks are drawn, so a posterior that mixes well costs a
//! block and one that does not costs what it needs, not a fresh run four
//! times as long.
//!
//! Every step is a function of the data and the last update, so the same
//! holds in the same order give the same posterior, live or offline.

use acq_algorithms::evaluation::Simulator;
use acq_algorithms::mcmc::{warm_up, Chains, InitialProposal, SamplerSettings, MAX_THIN};
use acq_algorithms::next_point::draws_moments;
use acq_error::{AcqError, Result};

use super::likelihood::StudyPosterior;
use super::{
    chain_starts, initial_scale, inside, log_density_of, sampler_settings, unconverged,
    PosteriorSettings,
};
use crate::simulator::StudySimulator;
use crate::study::{Model, Role, Study};

/// Warmup steps per chain of an update after the first.
pub const WARM_WARMUP: usize = 600;
/// Blocks of half the study's draws an update may draw after its first.
pub const MAX_BLOCKS: usize = 6;

/// Where the next update starts: the last posterior's draws (chain after
/// chain, in the coordinates' own units) and its chains' integrated
/// autocorrelation time, steps.
#[derive(Clone, Debug, PartialEq)]
pub struct WarmStart {
    pub draws: Vec<Vec<f64>>,
    pub tau_steps: f64,
}

/// An update's chains, what it did in words, and the start of the next.
pub struct Update {
    pub chains: Chains,
    pub how: String,
    pub next: WarmStart,
}

/// The posterior of `study` on a cheap model, sampled directly: from
/// `centre` with a full warmup when `warm` is `None`, else from the last
/// update.
pub fn sample_sequentially(
    study: &Study,
    model: &dyn Model,
    settings: &PosteriorSettings,
    centre: &[f64],
    warm: Option<&WarmStart>,
) -> Result<Update> {
    let density = StudyPosterior::new(study, settings.discrepancy, 0).map_err(AcqError::Config)?;
    let simulator = StudySimulator::new(study, model, Role::Fit);
    let support = density.support();
    let d = support.len();
    let at = |point: &[f64]| simulator.evaluate(point).ok().map(|o| (o, Vec::new()));
    let log_density = log_density_of(&density, &at);
    let cold = sampler_settings(settings, d);
    let (sampler, starts, covariance) = match warm {
        Some(warm) if warm.draws.len() >= 2 * d + 2 => {
            let sampler = SamplerSettings {
                warmup: WARM_WARMUP,
                thin: Some(((warm.tau_steps / 2.0).ceil() as usize).clamp(1, MAX_THIN)),
                ..cold.clone()
            };
            let starts = warm_starts(&warm.draws, sampler.chains, &log_density);
            let free: Vec<Vec<f64>> = warm
                .draws
                .iter()
                .map(|x| support.iter().zip(x).map(|(s, &v)| s.to_free(v)).collect())
                .collect();
            let covariance = draws_moments(&free)
                .map(|(_, c)| c)
                .filter(|c| (0..d).all(|i| c[i][i].is_finite() && c[i][i] > 0.0));
            (sampler, starts, covariance)
        }
        _ => (cold, None, None),
    };
    let starts = match starts {
        Some(starts) => starts,
        None => {
            let centre: Vec<f64> = centre
                .iter()
                .zip(&support)
                .map(|(&x, s)| inside(*s, x))
                .collect();
            chain_starts(&density, &centre, &sampler, &log_density)?
        }
    };
    let scales: Vec<f64> = support.iter().map(|s| initial_scale(*s)).collect();
    let proposal = match &covariance {
        Some(covariance) => InitialProposal::Covariance(covariance),
        None => InitialProposal::Scales(&scales),
    };
    let quiet = |_| {};
    let mut chains = warm_up(&log_density, &support, &starts, proposal, &sampler, &quiet)
        .map_err(|e| AcqError::Config(format!("posterior: {e}")))?;
    let block = (sampler.draws / 2).max(4);
    let mut drawn = chains.draw(sampler.draws, &quiet);
    let names: Vec<String> = density.coordinates.iter().map(|c| c.name.clone()).collect();
    let mut blocks = 0;
    let mut open = unconverged(&names, &drawn.summaries(), sampler.chains);
    while !open.is_empty() && blocks < MAX_BLOCKS {
        drawn = chains.draw(block, &quiet);
        blocks += 1;
        open = unconverged(&names, &drawn.summaries(), sampler.chains);
    }
    let per_chain = drawn.draws.first().map_or(0, Vec::len);
    let least_ess = drawn
        .summaries()
        .iter()
        .map(|m| m.ess_bulk)
        .filter(|e| e.is_finite() && *e > 0.0)
        .fold(f64::INFINITY, f64::min);
    let kept_steps = (per_chain * drawn.thin * sampler.chains) as f64;
    let tau_steps = if least_ess.is_finite() {
        (kept_steps / least_ess).max(1.0)
    } else {
        (2 * drawn.thin) as f64
    };
    let mut how = format!(
        "{} chains of {per_chain} kept draws, one every {} steps, after {} warmup steps {} ({} model runs)",
        sampler.chains,
        drawn.thin,
        sampler.warmup,
        if covariance.is_some() {
            "from the last posterior"
        } else {
            "from the prior"
        },
        drawn.evaluations
    );
    if !open.is_empty() {
        how.push_str(&format!(
            "; not converged after {} draws per chain: {}",
            per_chain,
            open.join(", ")
        ));
    } else if blocks > 0 {
        how.push_str(&format!("; {blocks} block(s) more until converged"));
    }
    Ok(Update {
        next: WarmStart {
            draws: drawn.pooled().cloned().collect(),
            tau_steps,
        },
        chains: drawn,
        how,
    })
}

/// One start per chain from the last posterior's draws, spread evenly
/// through them (each chain's share of the pool), each moved on to the
/// next draw while the new posterior is zero there; `None` when too few
/// have a positive density.
fn warm_starts(
    draws: &[Vec<f64>],
    chains: usize,
    log_density: &dyn Fn(&[f64]) -> f64,
) -> Option<Vec<Vec<f64>>> {
    let n = draws.len();
    (0..chains)
        .map(|k| {
            let first = (2 * k + 1) * n / (2 * chains);
            (0..n)
                .map(|offset| &draws[(first + offset) % n])
                .find(|x| log_density(x) > f64::NEG_INFINITY)
                .cloned()
        })
        .collect()
}
