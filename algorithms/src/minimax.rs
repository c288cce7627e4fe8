//! The minimax pick: the alternative (a Pareto point) whose largest weighted cost is least.
//!
//! TOPSIS ranks by Euclidean closeness to an ideal point, so it trades a large error on one
//! criterion for small ones on the others. When the figure of merit is the largest error
//! (a calibration judged by its worst pressure), the pick that serves it is the weighted
//! Chebyshev one: minimise `max_j w_j * x_ij` over the rows, the weights scaled so the
//! largest is 1 (equal weights: the plain largest error). On a Pareto front this is a
//! Pareto point, and it is the front's point nearest to the ideal 0 in the max norm.

use crate::topsis::{validate, Criterion, TopsisError};

/// The rows of `decision_matrix` (alternatives x costs) ordered by their largest weighted
/// cost, least first; ties keep the lower index first. `weights`: one per column, >= 0,
/// not all 0. The pick is `ranking[0]`.
pub fn minimax_ranking(
    decision_matrix: &[Vec<f64>],
    weights: &[f64],
) -> Result<Vec<usize>, TopsisError> {
    let columns = decision_matrix.first().map_or(0, Vec::len);
    validate(decision_matrix, weights, &vec![Criterion::Cost; columns])?;
    let largest_weight = weights.iter().copied().fold(0.0, f64::max);
    let worst: Vec<f64> = decision_matrix
        .iter()
        .map(|row| {
            row.iter()
                .zip(weights)
                .map(|(cost, weight)| cost * (weight / largest_weight))
                .fold(f64::NEG_INFINITY, f64::max)
        })
        .collect();
    let mut ranking: Vec<usize> = (0..decision_matrix.len()).collect();
    ranking.sort_by(|&a, &b| worst[a].total_cmp(&worst[b]).then(a.cmp(&b)));
    Ok(ranking)
}
