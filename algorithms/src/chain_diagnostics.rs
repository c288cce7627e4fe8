//! Whether Markov chains have mixed: the rank-normalised split R-hat and
//! the bulk effective sample size of Vehtari, Gelman, Simpson, Carpenter
//! and Bürkner (2021, "Rank-normalization, folding, and localization: an
//! improved R-hat for assessing convergence of MCMC"), computed as ArviZ's
//! `rhat(method="rank")` and `ess(method="bulk")` compute them, so a
//! posterior's summary means what its readers expect.
//!
//! - Each chain is split in halves (the middle draw of an odd chain is
//!   left out), so a chain that drifts shows as two that disagree.
//! - Draws are rank-normalised: pooled ranks (ties averaged) mapped through
//!   the normal quantile of `(rank - 3/8) / (n + 1/4)`, so heavy tails and
//!   infinite variances do not break the diagnostics.
//! - R-hat is the larger of the bulk one (on the normalised draws) and the
//!   tail one (on the normalised distances from the median).
//! - The bulk ESS sums the chains' autocorrelations (variance-weighted
//!   across chains) with Geyer's initial positive and monotone sequences.
//!
//! - The tail ESS is the smaller of the ESS of the indicators `x <= q05`
//!   and `x <= q95` (split chains, not rank-normalised); the Monte-Carlo
//!   standard errors of the mean and the sd use the ESS of the draws and
//!   of their squared deviations; the HDI is the narrowest interval
//!   holding the share of the sorted draws (ArviZ's `ess(method="tail")`,
//!   `mcse(method="mean" | "sd")` and `hdi`).
//!
//! Written here: the `mcmc` crate (0.1) implements Stan's classic split
//! R-hat and ESS, not the rank-normalised ones. Checked against ArviZ in
//! `tests/chain_diagnostics.rs` of the workspace root.

use statrs::distribution::{ContinuousCDF, Normal};

/// The rank-normalised split R-hat of `chains` (each a chain's draws in
/// order, all of one length), the larger of bulk and tail. `None` with
/// fewer than 2 chains or 4 draws, chains of unequal length, or a draw that
/// is not finite.
pub fn rank_rhat(chains: &[Vec<f64>]) -> Option<f64> {
    if chains.len() < 2 || !valid(chains) {
        return None;
    }
    let split = split_chains(chains);
    let bulk = rhat(&rank_normalise(&split));
    let pooled: Vec<f64> = split.iter().flatten().copied().collect();
    let median = median(&pooled);
    let folded: Vec<Vec<f64>> = split
        .iter()
        .map(|chain| chain.iter().map(|x| (x - median).abs()).collect())
        .collect();
    let tail = rhat(&rank_normalise(&folded));
    Some(bulk.max(tail))
}

/// The bulk effective sample size of `chains` (rank-normalised split
/// chains). `None` with fewer than 4 draws per chain, chains of unequal
/// length, or a draw that is not finite.
pub fn ess_bulk(chains: &[Vec<f64>]) -> Option<f64> {
    if chains.is_empty() || !valid(chains) {
        return None;
    }
    Some(ess(&rank_normalise(&split_chains(chains))))
}

/// The tail effective sample size: the smaller of the ESS of the 5 % and
/// the 95 % quantile's indicator. `None` as [`ess_bulk`].
pub fn ess_tail(chains: &[Vec<f64>]) -> Option<f64> {
    if chains.is_empty() || !valid(chains) {
        return None;
    }
    let mut sorted: Vec<f64> = chains.iter().flatten().copied().collect();
    sorted.sort_by(f64::total_cmp);
    let ess_below = |p: f64| {
        let q = quantile(&sorted, p);
        let indicators: Vec<Vec<f64>> = chains
            .iter()
            .map(|c| c.iter().map(|x| if *x <= q { 1.0 } else { 0.0 }).collect())
            .collect();
        ess(&split_chains(&indicators))
    };
    Some(ess_below(0.05).min(ess_below(0.95)))
}

/// The Monte-Carlo standard error of the mean: the draws' sd over the root
/// of their ESS (split chains, not rank-normalised). `None` as
/// [`ess_bulk`].
pub fn mcse_mean(chains: &[Vec<f64>]) -> Option<f64> {
    if chains.is_empty() || !valid(chains) {
        return None;
    }
    let pooled: Vec<f64> = chains.iter().flatten().copied().collect();
    Some(sample_variance(&pooled).sqrt() / ess(&split_chains(chains)).sqrt())
}

/// The Monte-Carlo standard error of the sd, from the ESS of the squared
/// deviations (the delta method on the variance's). `None` as
/// [`ess_bulk`].
pub fn mcse_sd(chains: &[Vec<f64>]) -> Option<f64> {
    if chains.is_empty() || !valid(chains) {
        return None;
    }
    let pooled: Vec<f64> = chains.iter().flatten().copied().collect();
    let m = mean(&pooled);
    let squared: Vec<Vec<f64>> = chains
        .iter()
        .map(|c| c.iter().map(|x| (x - m).powi(2)).collect())
        .collect();
    let pooled_squared: Vec<f64> = squared.iter().flatten().copied().collect();
    let variance = mean(&pooled_squared);
    let fourth = mean(&pooled_squared.iter().map(|s| s * s).collect::<Vec<_>>());
    let variance_of_variance = (fourth - variance * variance) / ess(&split_chains(&squared));
    Some((variance_of_variance / variance / 4.0).sqrt())
}

/// The narrowest interval holding `share` of the sorted draws `sorted`
/// (the first of the narrowest, as ArviZ's `hdi`); `None` with too few.
pub fn hdi(sorted: &[f64], share: f64) -> Option<(f64, f64)> {
    let n = sorted.len();
    let inside = (share * n as f64).floor() as usize;
    if n == 0 || inside >= n {
        return None;
    }
    let narrowest = (0..n - inside).min_by(|&a, &b| {
        (sorted[a + inside] - sorted[a]).total_cmp(&(sorted[b + inside] - sorted[b]))
    })?;
    Some((sorted[narrowest], sorted[narrowest + inside]))
}

/// The `p` quantile of sorted values, interpolated linearly between order
/// statistics (numpy's default and R's type 7, as ArviZ takes them).
pub fn quantile(sorted: &[f64], p: f64) -> f64 {
    match sorted.len() {
        0 => f64::NAN,
        1 => sorted[0],
        n => {
            let h = p.clamp(0.0, 1.0) * (n - 1) as f64;
            let below = h.floor() as usize;
            let above = (below + 1).min(n - 1);
            sorted[below] + (h - below as f64) * (sorted[above] - sorted[below])
        }
    }
}

/// At least 4 draws in each chain, all of one length, all finite.
fn valid(chains: &[Vec<f64>]) -> bool {
    let draws = chains[0].len();
    draws >= 4
        && chains
            .iter()
            .all(|c| c.len() == draws && c.iter().all(|x| x.is_finite()))
}

/// Each chain's first and last halves as chains of their own.
fn split_chains(chains: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let half = chains[0].len() / 2;
    let mut split = Vec::with_capacity(2 * chains.len());
    split.extend(chains.iter().map(|c| c[..half].to_vec()));
    split.extend(chains.iter().map(|c| c[c.len() - half..].to_vec()));
    split
}

/// Normal scores of the pooled ranks (ties get their average rank).
fn rank_normalise(chains: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let pooled: Vec<f64> = chains.iter().flatten().copied().collect();
    let n = pooled.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| pooled[a].total_cmp(&pooled[b]));
    let mut rank = vec![0.0; n];
    let mut start = 0;
    while start < n {
        let mut end = start + 1;
        while end < n && pooled[order[end]] == pooled[order[start]] {
            end += 1;
        }
        // Ranks start + 1 ..= end share their mean.
        let average = (start + 1 + end) as f64 / 2.0;
        for &index in &order[start..end] {
            rank[index] = average;
        }
        start = end;
    }
    let normal = Normal::standard();
    let score = |r: f64| normal.inverse_cdf((r - 0.375) / (n as f64 + 0.25));
    let mut scores = rank.into_iter().map(score);
    chains
        .iter()
        .map(|chain| scores.by_ref().take(chain.len()).collect())
        .collect()
}

/// The potential scale reduction of equal-length chains.
fn rhat(chains: &[Vec<f64>]) -> f64 {
    let draws = chains[0].len() as f64;
    let means: Vec<f64> = chains.iter().map(|c| mean(c)).collect();
    let within = chains
        .iter()
        .zip(&means)
        .map(|(c, m)| c.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (draws - 1.0))
        .sum::<f64>()
        / chains.len() as f64;
    let between = draws * sample_variance(&means);
    ((between / within + draws - 1.0) / draws).sqrt()
}

/// The effective sample size of equal-length chains (Geyer's initial
/// positive and monotone sequences on the variance-weighted
/// autocorrelations).
fn ess(chains: &[Vec<f64>]) -> f64 {
    let (m, n) = (chains.len(), chains[0].len());
    let total = (m * n) as f64;
    let pooled = chains.iter().flatten();
    let (low, high) = pooled.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
        (l.min(x), h.max(x))
    });
    if high - low < 1e-15 {
        return total;
    }
    let autocovariances: Vec<Vec<f64>> = chains.iter().map(|c| autocovariance(c)).collect();
    let at_lag = |lag: usize| autocovariances.iter().map(|a| a[lag]).sum::<f64>() / m as f64;
    let nf = n as f64;
    let mean_variance = at_lag(0) * nf / (nf - 1.0);
    let mut variance_plus = mean_variance * (nf - 1.0) / nf;
    if m > 1 {
        let means: Vec<f64> = chains.iter().map(|c| mean(c)).collect();
        variance_plus += sample_variance(&means);
    }
    let rho = |lag: usize| 1.0 - (mean_variance - at_lag(lag)) / variance_plus;
    let mut rho_hat = vec![0.0; n];
    let mut even = 1.0;
    let mut odd = rho(1);
    rho_hat[0] = even;
    rho_hat[1] = odd;
    // Geyer's initial positive sequence.
    let mut t = 1;
    while t + 3 < n && even + odd > 0.0 {
        even = rho(t + 1);
        odd = rho(t + 2);
        if even + odd >= 0.0 {
            rho_hat[t + 1] = even;
            rho_hat[t + 2] = odd;
        }
        t += 2;
    }
    // The last lag kept, plus one: 0 when the sequence stopped at once
    // (ArviZ's `max_t` of -1).
    let end = t - 1;
    if even > 0.0 {
        rho_hat[end] = even;
    }
    // Geyer's initial monotone sequence.
    let mut t = 1;
    while t + 3 <= end {
        if rho_hat[t + 1] + rho_hat[t + 2] > rho_hat[t - 1] + rho_hat[t] {
            rho_hat[t + 1] = (rho_hat[t - 1] + rho_hat[t]) / 2.0;
            rho_hat[t + 2] = rho_hat[t + 1];
        }
        t += 2;
    }
    let tau = -1.0 + 2.0 * rho_hat[..end].iter().sum::<f64>() + rho_hat[end];
    total / tau.max(1.0 / total.log10())
}

/// `(1/n) sum_i (x_i - mean)(x_{i+k} - mean)` for every lag `k`.
fn autocovariance(chain: &[f64]) -> Vec<f64> {
    let n = chain.len();
    let m = mean(chain);
    let centred: Vec<f64> = chain.iter().map(|x| x - m).collect();
    (0..n)
        .map(|lag| {
            centred[..n - lag]
                .iter()
                .zip(&centred[lag..])
                .map(|(a, b)| a * b)
                .sum::<f64>()
                / n as f64
        })
        .collect()
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

fn sample_variance(values: &[f64]) -> f64 {
    let m = mean(values);
    values.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (values.len() as f64 - 1.0)
}

/// The median (the mean of the middle two for an even count).
pub(crate) fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    fn chains(count: usize, draws: usize, seed: u64, drift: f64) -> Vec<Vec<f64>> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..count)
            .map(|c| {
                (0..draws)
                    .map(|_| rng.random::<f64>() + drift * c as f64)
                    .collect()
            })
            .collect()
    }

    #[test]
    fn independent_draws_have_rhat_near_one_and_ess_near_their_count() {
        let draws = chains(4, 1000, 7, 0.0);
        let rhat = rank_rhat(&draws).unwrap();
        assert!((rhat - 1.0).abs() < 0.01, "R-hat {rhat}");
        let ess = ess_bulk(&draws).unwrap();
        assert!(
            (ess / 4000.0 - 1.0).abs() < 0.15,
            "ESS {ess} of 4000 independent draws"
        );
    }

    #[test]
    fn chains_in_different_places_have_a_large_rhat() {
        let draws = chains(4, 500, 8, 1.0);
        assert!(rank_rhat(&draws).unwrap() > 1.5);
    }

    #[test]
    fn too_few_draws_or_chains_or_a_nan_give_none() {
        assert_eq!(rank_rhat(&chains(1, 100, 1, 0.0)), None);
        assert_eq!(rank_rhat(&chains(2, 3, 1, 0.0)), None);
        let mut with_nan = chains(2, 10, 1, 0.0);
        with_nan[1][4] = f64::NAN;
        assert_eq!(ess_bulk(&with_nan), None);
        assert_eq!(ess_bulk(&[vec![1.0; 4], vec![1.0; 5]]), None);
        // A constant chain has every draw's worth.
        assert_eq!(ess_bulk(&[vec![2.0; 10], vec![2.0; 10]]), Some(20.0));
    }
}
