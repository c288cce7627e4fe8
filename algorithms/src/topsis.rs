//! TOPSIS (Hwang & Yoon 1981): picking one alternative, e.g. one parameter set of a Pareto
//! front, by its closeness to the ideal point of weighted criteria.
//!
//! Steps: vector-normalise each criterion (column / its Euclidean norm), multiply by the
//! weights (normalised to sum 1), take the ideal (best of each column: the largest for a
//! benefit, the smallest for a cost) and the anti-ideal (the worst), measure each
//! alternative's Euclidean separations `S+` from the ideal and `S-` from the anti-ideal,
//! and rank by the relative closeness `C = S- / (S+ + S-)` in [0, 1], larger is better.
//!
//! The per-criterion normalisation is what makes criteria in different units comparable,
//! but it also re-weights them: a criterion that happens to spread widely over the
//! alternatives is shrunk more. When every criterion is in the same unit (relative errors
//! in %), [`Normalisation::Common`] divides all of them by one norm instead, so that equal
//! weights mean that one point of one criterion counts as much as one point of another.

/// Whether more of a criterion is better (benefit) or worse (cost, e.g. an error).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Criterion {
    /// Larger is better.
    Benefit,
    /// Smaller is better.
    Cost,
}

/// How the decision matrix is made unit-free before weighting.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Normalisation {
    /// Each criterion by its own Euclidean norm over the alternatives (Hwang & Yoon): for
    /// criteria in different units.
    #[default]
    PerCriterion,
    /// Every criterion by the one Euclidean norm of the whole matrix: for criteria in the
    /// same unit, whose scale must stay comparable.
    Common,
}

/// The TOPSIS result: closeness per alternative (row), and the rows best first.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Topsis {
    /// Relative closeness to the ideal, in [0, 1], one per row of the decision matrix.
    pub closeness: Vec<f64>,
    /// Row indices ordered by decreasing closeness; ties keep the lower index first.
    pub ranking: Vec<usize>,
    /// The row with the largest closeness (`ranking[0]`).
    pub best: usize,
}

/// Why a decision cannot be ranked, and what to fix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TopsisError {
    /// No alternative.
    #[error("the decision matrix has no alternative (row); pass at least one")]
    NoAlternatives,
    /// No criterion.
    #[error("the decision matrix has no criterion (column); pass at least one")]
    NoCriteria,
    /// A row of a different length than the first.
    #[error("row {row} of the decision matrix has {found} values, row 0 has {expected}; every alternative needs a value for every criterion")]
    RaggedRow {
        /// 0-based row.
        row: usize,
        /// Values in row 0.
        expected: usize,
        /// Values in this row.
        found: usize,
    },
    /// Weights not one per criterion.
    #[error("{found} weights for {expected} criteria; give one weight per column")]
    WeightCount {
        /// Criteria (columns).
        expected: usize,
        /// Weights given.
        found: usize,
    },
    /// Benefit/cost kinds not one per criterion.
    #[error("{found} benefit/cost kinds for {expected} criteria; give one per column")]
    CriterionCount {
        /// Criteria (columns).
        expected: usize,
        /// Kinds given.
        found: usize,
    },
    /// A negative or non-finite weight.
    #[error("weight {criterion} is {value}; weights must be finite and >= 0")]
    InvalidWeight {
        /// 0-based criterion.
        criterion: usize,
        /// The weight given.
        value: f64,
    },
    /// Every weight zero.
    #[error("all weights are 0; give at least one criterion a positive weight")]
    ZeroWeights,
    /// A NaN or infinite entry.
    #[error("decision matrix entry (row {row}, criterion {criterion}) is {value}; every value must be finite (drop or repair that alternative)")]
    NonFiniteValue {
        /// 0-based row.
        row: usize,
        /// 0-based criterion.
        criterion: usize,
        /// The value found.
        value: f64,
    },
}

/// Rank the rows of `decision_matrix` (alternatives x criteria) by TOPSIS.
///
/// `weights` (one per column, >= 0, not all 0) are normalised to sum 1, so only their
/// ratios matter; `criteria` says per column whether larger or smaller is better.
/// Negative values are allowed (vector normalisation keeps each column's order); a column
/// of zeros cannot tell alternatives apart and contributes nothing.
///
/// When every alternative has the same weighted values (`S+ = S- = 0` for all), no
/// alternative is closer to the ideal than another and each gets closeness 0.5: neither
/// at the ideal (1) nor at the anti-ideal (0).
pub fn topsis(
    decision_matrix: &[Vec<f64>],
    weights: &[f64],
    criteria: &[Criterion],
) -> Result<Topsis, TopsisError> {
    topsis_normalised(
        decision_matrix,
        weights,
        criteria,
        Normalisation::PerCriterion,
    )
}

/// [`topsis`] with a choice of [`Normalisation`].
pub fn topsis_normalised(
    decision_matrix: &[Vec<f64>],
    weights: &[f64],
    criteria: &[Criterion],
    normalisation: Normalisation,
) -> Result<Topsis, TopsisError> {
    let columns = validate(decision_matrix, weights, criteria)?;
    let weights = normalised_weights(weights);
    let column_norms: Vec<f64> = (0..columns)
        .map(|column| column_norm(decision_matrix, column))
        .collect();
    let common_norm = {
        // sqrt of the sum of squared column norms, scaled so squaring cannot overflow.
        let largest = column_norms.iter().copied().fold(0.0, f64::max);
        if largest == 0.0 {
            0.0
        } else {
            largest
                * column_norms
                    .iter()
                    .map(|n| (n / largest).powi(2))
                    .sum::<f64>()
                    .sqrt()
        }
    };

    // Weighted, normalised matrix, column by column. A column of zeros stays 0.
    let mut weighted: Vec<Vec<f64>> = vec![vec![0.0; columns]; decision_matrix.len()];
    for (column, weight) in weights.iter().enumerate() {
        let norm = match normalisation {
            Normalisation::PerCriterion => column_norms[column],
            Normalisation::Common => common_norm,
        };
        if norm == 0.0 {
            continue;
        }
        for (target, row) in weighted.iter_mut().zip(decision_matrix) {
            target[column] = row[column] / norm * weight;
        }
    }

    let mut ideal = vec![0.0; columns];
    let mut anti_ideal = vec![0.0; columns];
    for column in 0..columns {
        let values = weighted.iter().map(|row| row[column]);
        let highest = values.clone().fold(f64::NEG_INFINITY, f64::max);
        let lowest = values.fold(f64::INFINITY, f64::min);
        (ideal[column], anti_ideal[column]) = match criteria[column] {
            Criterion::Benefit => (highest, lowest),
            Criterion::Cost => (lowest, highest),
        };
    }

    let distance = |row: &[f64], target: &[f64]| {
        row.iter()
            .zip(target)
            .map(|(v, t)| (v - t) * (v - t))
            .sum::<f64>()
            .sqrt()
    };
    let closeness: Vec<f64> = weighted
        .iter()
        .map(|row| {
            let to_ideal = distance(row, &ideal);
            let to_anti_ideal = distance(row, &anti_ideal);
            let total = to_ideal + to_anti_ideal;
            if total > 0.0 {
                to_anti_ideal / total
            } else {
                0.5
            }
        })
        .collect();
    let mut ranking: Vec<usize> = (0..closeness.len()).collect();
    ranking.sort_by(|&a, &b| closeness[b].total_cmp(&closeness[a]).then(a.cmp(&b)));
    let best = ranking[0];
    Ok(Topsis {
        closeness,
        ranking,
        best,
    })
}

/// The column's Euclidean norm, computed on values divided by the largest magnitude so
/// that squaring cannot overflow (TOPSIS is scale-free, so 1e200 is a legitimate value).
fn column_norm(matrix: &[Vec<f64>], column: usize) -> f64 {
    let largest = matrix
        .iter()
        .map(|row| row[column].abs())
        .fold(0.0, f64::max);
    if largest == 0.0 {
        return 0.0;
    }
    let scaled: f64 = matrix
        .iter()
        .map(|row| (row[column] / largest).powi(2))
        .sum();
    largest * scaled.sqrt()
}

/// Weights divided by their sum, computed via the largest weight so the sum cannot
/// overflow. `validate` has ensured they are finite, >= 0 and not all 0.
fn normalised_weights(weights: &[f64]) -> Vec<f64> {
    let largest = weights.iter().copied().fold(0.0, f64::max);
    let relative: Vec<f64> = weights.iter().map(|w| w / largest).collect();
    let sum: f64 = relative.iter().sum();
    relative.iter().map(|w| w / sum).collect()
}

/// Check shapes and values; return the number of criteria.
pub(crate) fn validate(
    decision_matrix: &[Vec<f64>],
    weights: &[f64],
    criteria: &[Criterion],
) -> Result<usize, TopsisError> {
    let first = decision_matrix.first().ok_or(TopsisError::NoAlternatives)?;
    let columns = first.len();
    if columns == 0 {
        return Err(TopsisError::NoCriteria);
    }
    for (row, values) in decision_matrix.iter().enumerate() {
        if values.len() != columns {
            return Err(TopsisError::RaggedRow {
                row,
                expected: columns,
                found: values.len(),
            });
        }
        if let Some((criterion, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(TopsisError::NonFiniteValue {
                row,
                criterion,
                value,
            });
        }
    }
    if weights.len() != columns {
        return Err(TopsisError::WeightCount {
            expected: columns,
            found: weights.len(),
        });
    }
    if criteria.len() != columns {
        return Err(TopsisError::CriterionCount {
            expected: columns,
            found: criteria.len(),
        });
    }
    if let Some((criterion, &value)) = weights
        .iter()
        .enumerate()
        .find(|(_, w)| !(w.is_finite() && **w >= 0.0))
    {
        return Err(TopsisError::InvalidWeight { criterion, value });
    }
    if weights.iter().all(|&w| w == 0.0) {
        return Err(TopsisError::ZeroWeights);
    }
    Ok(columns)
}
