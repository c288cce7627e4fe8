//! Variance-based sensitivity: how much of a function's output variance each input
//! explains alone (first-order Sobol index) and with all its interactions (total index),
//! with bootstrap confidence intervals. Meant for cheap functions such as a surrogate: it
//! takes `base_samples * (dimensions + 2)` evaluations.
//!
//! Sampling after Saltelli et al. (2010), "Variance based sensitivity analysis of model
//! output. Design and estimator for the total sensitivity index", Comput. Phys. Commun.
//! 181: two independent N x d matrices A and B (the two halves of a 2d-dimensional
//! Owen-scrambled Sobol point set), and for each input i the matrix A_B^i, which is A with
//! column i taken from B. With V the variance of f over A and B together:
//!
//! - first order (Saltelli 2010): `S_i = mean(f(B) * (f(A_B^i) - f(A))) / V`, with f(B)
//!   centred on the mean (the same expectation, less variance)
//! - total (Jansen 1999): `ST_i = mean((f(A) - f(A_B^i))^2) / (2 V)`
//!
//! The confidence intervals are 95 % bootstrap percentile intervals: the N rows are
//! resampled with replacement and every estimate (V included) recomputed.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::moo::parallel::evaluate_all;

/// Bootstrap resamples behind the confidence intervals.
pub const BOOTSTRAP_RESAMPLES: usize = 500;

/// Fewest base samples accepted: below this the variance and the intervals are noise.
pub const MIN_BASE_SAMPLES: usize = 8;

/// Sobol indices of a function on the unit box.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SobolIndices {
    /// First-order index per input: the variance share it explains alone.
    pub first_order: Vec<f64>,
    /// Total index per input: its share including every interaction it takes part in.
    pub total: Vec<f64>,
    /// 95 % bootstrap interval (low, high) of each first-order index.
    pub first_order_ci: Vec<(f64, f64)>,
    /// 95 % bootstrap interval (low, high) of each total index.
    pub total_ci: Vec<(f64, f64)>,
    /// Function evaluations made: `base_samples * (dimensions + 2)`.
    pub evaluations: usize,
}

/// Why the indices cannot be estimated, and what to do.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SensitivityError {
    /// No input.
    #[error("sensitivity needs at least one input dimension; pass dimensions >= 1")]
    NoDimensions,
    /// Too few base samples.
    #[error("{given} base samples are too few; pass at least {min} (a power of two such as 1024 or 4096 is best)")]
    TooFewSamples {
        /// Base samples given.
        given: usize,
        /// The minimum.
        min: usize,
    },
    /// More evaluations than can be counted.
    #[error("base_samples x (dimensions + 2) overflows; ask for fewer samples")]
    TooManyEvaluations,
    /// The function returned NaN or an infinity.
    #[error("the function returned {value} at {x:?}; Sobol indices need finite outputs everywhere in the box (narrow the bounds or repair the model)")]
    NonFiniteOutput {
        /// The value returned.
        value: f64,
        /// The unit-box point where it happened.
        x: Vec<f64>,
    },
}

/// First-order and total Sobol indices of `f` over the unit box `[0, 1]^dimensions` (the
/// caller scales to physical bounds inside `f`), from `base_samples` rows of A and B.
///
/// Samples come from an Owen-scrambled Sobol sequence seeded by `seed` when it can hold
/// them (2 x dimensions <= 256 and base_samples <= 65 536), otherwise from a seeded
/// pseudo-random generator; results are reproducible either way. Evaluations run in
/// parallel; the result does not depend on the number of threads.
///
/// A constant function has no variance to share out: every index and interval is 0.
/// Estimates are not clipped, so with few samples an index near 0 can come out slightly
/// negative; that is noise, as the interval shows.
pub fn sobol_indices<F>(
    f: F,
    dimensions: usize,
    base_samples: usize,
    seed: u64,
) -> Result<SobolIndices, SensitivityError>
where
    F: Fn(&[f64]) -> f64 + Sync,
{
    if dimensions == 0 {
        return Err(SensitivityError::NoDimensions);
    }
    if base_samples < MIN_BASE_SAMPLES {
        return Err(SensitivityError::TooFewSamples {
            given: base_samples,
            min: MIN_BASE_SAMPLES,
        });
    }
    let evaluations = dimensions
        .checked_add(2)
        .and_then(|blocks| blocks.checked_mul(base_samples))
        .ok_or(SensitivityError::TooManyEvaluations)?;

    let (a, b) = base_matrices(base_samples, dimensions, seed);
    let f_a = evaluate_finite(&a, &f)?;
    let f_b = evaluate_finite(&b, &f)?;
    let mut f_ab = Vec::with_capacity(dimensions);
    for input in 0..dimensions {
        // A with column `input` from B; built one input at a time to bound memory.
        let a_b: Vec<Vec<f64>> = a
            .iter()
            .zip(&b)
            .map(|(row_a, row_b)| {
                let mut row = row_a.clone();
                row[input] = row_b[input];
                row
            })
            .collect();
        f_ab.push(evaluate_finite(&a_b, &f)?);
    }

    let all_rows: Vec<usize> = (0..base_samples).collect();
    let (first_order, total) = estimate(&f_a, &f_b, &f_ab, &all_rows);

    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // A stream of its own, so the bootstrap never reuses the sampling's random numbers.
    rng.set_stream(1);
    let mut first_draws = vec![Vec::with_capacity(BOOTSTRAP_RESAMPLES); dimensions];
    let mut total_draws = vec![Vec::with_capacity(BOOTSTRAP_RESAMPLES); dimensions];
    let mut rows = vec![0; base_samples];
    for _ in 0..BOOTSTRAP_RESAMPLES {
        for row in rows.iter_mut() {
            *row = rng.random_range(0..base_samples);
        }
        let (first, tot) = estimate(&f_a, &f_b, &f_ab, &rows);
        for input in 0..dimensions {
            first_draws[input].push(first[input]);
            total_draws[input].push(tot[input]);
        }
    }
    Ok(SobolIndices {
        first_order,
        total,
        first_order_ci: first_draws.into_iter().map(percentile_interval).collect(),
        total_ci: total_draws.into_iter().map(percentile_interval).collect(),
        evaluations,
    })
}

/// The A and B matrices: halves of a scrambled Sobol point set when it fits, else uniform
/// pseudo-random rows.
fn base_matrices(n: usize, dimensions: usize, seed: u64) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let points = dimensions
        .checked_mul(2)
        .and_then(|columns| crate::doe::sobol_points(n, columns, Some(seed)).ok())
        .unwrap_or_else(|| crate::doe::random_uniform(n, 2 * dimensions, seed));
    points
        .into_iter()
        .map(|mut row| {
            let second = row.split_off(dimensions);
            (row, second)
        })
        .unzip()
}

fn evaluate_finite<F>(points: &[Vec<f64>], f: &F) -> Result<Vec<f64>, SensitivityError>
where
    F: Fn(&[f64]) -> f64 + Sync,
{
    let values = evaluate_all(points, f);
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(SensitivityError::NonFiniteOutput {
            value: values[index],
            x: points[index].clone(),
        }),
        None => Ok(values),
    }
}

/// First-order (Saltelli 2010) and total (Jansen) indices over the given rows (a bootstrap
/// resample may repeat rows).
fn estimate(f_a: &[f64], f_b: &[f64], f_ab: &[Vec<f64>], rows: &[usize]) -> (Vec<f64>, Vec<f64>) {
    let n = rows.len() as f64;
    let mean = rows.iter().map(|&j| f_a[j] + f_b[j]).sum::<f64>() / (2.0 * n);
    let variance = rows
        .iter()
        .map(|&j| (f_a[j] - mean).powi(2) + (f_b[j] - mean).powi(2))
        .sum::<f64>()
        / (2.0 * n);
    if variance <= 0.0 {
        return (vec![0.0; f_ab.len()], vec![0.0; f_ab.len()]);
    }
    f_ab.iter()
        .map(|f_abi| {
            let mut first = 0.0;
            let mut total = 0.0;
            for &j in rows {
                let change = f_abi[j] - f_a[j];
                // f(B) centred: same expectation (f(A_B^i) and f(A) share their mean),
                // far less noise when the output sits on a large offset.
                first += (f_b[j] - mean) * change;
                total += change * change;
            }
            (first / n / variance, total / (2.0 * n) / variance)
        })
        .unzip()
}

/// The 2.5 % and 97.5 % percentiles of bootstrap draws.
fn percentile_interval(mut draws: Vec<f64>) -> (f64, f64) {
    draws.sort_by(f64::total_cmp);
    let at = |fraction: f64| {
        let last = draws.len().saturating_sub(1);
        let index = ((fraction * last as f64).round() as usize).min(last);
        draws.get(index).copied().unwrap_or(0.0)
    };
    (at(0.025), at(0.975))
}
