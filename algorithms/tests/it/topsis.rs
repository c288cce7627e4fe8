//! TOPSIS against the textbook example, its invariances and its input errors.

use acq_algorithms::minimax::minimax_ranking;
use acq_algorithms::topsis::{topsis, topsis_normalised, Criterion, Normalisation, TopsisError};

use Criterion::{Benefit, Cost};

/// Hwang & Yoon (1981), "Multiple Attribute Decision Making: Methods and Applications",
/// Springer, the fighter-aircraft purchase example (repeated in Yoon & Hwang 1995, Sage):
/// maximum speed (Mach), ferry range (NM), maximum payload (lb), acquisition cost ($10^6,
/// a cost), reliability and manoeuvrability (rated 1-9).
fn aircraft() -> (Vec<Vec<f64>>, Vec<f64>, Vec<Criterion>) {
    (
        vec![
            vec![2.0, 1500.0, 20000.0, 5.5, 5.0, 9.0],
            vec![2.5, 2700.0, 18000.0, 6.5, 3.0, 5.0],
            vec![1.8, 2000.0, 21000.0, 4.5, 7.0, 7.0],
            vec![2.2, 1800.0, 20000.0, 5.0, 5.0, 5.0],
        ],
        vec![0.2, 0.1, 0.1, 0.1, 0.2, 0.3],
        vec![Benefit, Benefit, Benefit, Cost, Benefit, Benefit],
    )
}

#[test]
fn textbook_fighter_aircraft_example() {
    let (matrix, weights, criteria) = aircraft();
    let result = topsis(&matrix, &weights, &criteria).unwrap();
    // Published relative closeness C*: A1 0.643, A2 0.268, A3 0.613, A4 0.312.
    let published = [0.643, 0.268, 0.613, 0.312];
    for (ours, theirs) in result.closeness.iter().zip(published) {
        assert!((ours - theirs).abs() < 1e-3, "{ours} vs {theirs}");
    }
    assert_eq!(result.ranking, vec![0, 2, 3, 1]);
    assert_eq!(result.best, 0);
}

#[test]
fn weights_are_normalised() {
    let (matrix, weights, criteria) = aircraft();
    let doubled: Vec<f64> = weights.iter().map(|w| w * 2.0).collect();
    let a = topsis(&matrix, &weights, &criteria).unwrap();
    let b = topsis(&matrix, &doubled, &criteria).unwrap();
    for (x, y) in a.closeness.iter().zip(&b.closeness) {
        assert!((x - y).abs() < 1e-12);
    }
}

#[test]
fn scaling_a_column_changes_nothing() {
    let (matrix, weights, criteria) = aircraft();
    let reference = topsis(&matrix, &weights, &criteria).unwrap();
    for (column, factor) in [(1, 1.0e-3), (2, 1000.0), (3, 1.0e250)] {
        let scaled: Vec<Vec<f64>> = matrix
            .iter()
            .map(|row| {
                let mut row = row.clone();
                row[column] *= factor;
                row
            })
            .collect();
        let result = topsis(&scaled, &weights, &criteria).unwrap();
        for (x, y) in reference.closeness.iter().zip(&result.closeness) {
            assert!((x - y).abs() < 1e-12, "column {column}: {x} vs {y}");
        }
        assert_eq!(result.ranking, reference.ranking);
    }
}

#[test]
fn turning_every_benefit_into_a_cost_mirrors_the_closeness() {
    // Swapping benefit and cost swaps the ideal and anti-ideal, so S+ and S- trade places
    // and C becomes 1 - C: the ranking reverses.
    let (matrix, weights, criteria) = aircraft();
    let flipped: Vec<Criterion> = criteria
        .iter()
        .map(|c| match c {
            Benefit => Cost,
            Cost => Benefit,
        })
        .collect();
    let a = topsis(&matrix, &weights, &criteria).unwrap();
    let b = topsis(&matrix, &weights, &flipped).unwrap();
    for (x, y) in a.closeness.iter().zip(&b.closeness) {
        assert!((x + y - 1.0).abs() < 1e-12, "{x} + {y}");
    }
    let mut reversed = a.ranking.clone();
    reversed.reverse();
    assert_eq!(b.ranking, reversed);
}

#[test]
fn a_cost_column_prefers_the_smaller_value() {
    let matrix = vec![vec![3.0], vec![1.0], vec![2.0]];
    let cost = topsis(&matrix, &[1.0], &[Cost]).unwrap();
    assert_eq!(cost.best, 1);
    for (ours, expected) in cost.closeness.iter().zip([0.0, 1.0, 0.5]) {
        assert!((ours - expected).abs() < 1e-12, "{ours} vs {expected}");
    }
    let benefit = topsis(&matrix, &[1.0], &[Benefit]).unwrap();
    assert_eq!(benefit.best, 0);
}

#[test]
fn degenerate_decisions() {
    // All alternatives equal: nobody is closer to the ideal, everyone gets 0.5.
    let equal = vec![vec![1.0, 2.0]; 3];
    let result = topsis(&equal, &[1.0, 1.0], &[Benefit, Cost]).unwrap();
    assert_eq!(result.closeness, vec![0.5; 3]);
    assert_eq!(result.ranking, vec![0, 1, 2]);
    // One alternative.
    let single = topsis(&[vec![4.0, 5.0]], &[1.0, 1.0], &[Benefit, Cost]).unwrap();
    assert_eq!(single.best, 0);
    // A zero column and a zero weight contribute nothing.
    let matrix = vec![vec![0.0, 1.0, 9.0], vec![0.0, 2.0, 1.0]];
    let result = topsis(&matrix, &[1.0, 1.0, 0.0], &[Benefit, Benefit, Benefit]).unwrap();
    assert_eq!(result.best, 1);
    // Negative values keep their order.
    let negative = vec![vec![-3.0], vec![-1.0]];
    assert_eq!(topsis(&negative, &[1.0], &[Benefit]).unwrap().best, 1);
}

#[test]
fn input_errors() {
    let (matrix, weights, criteria) = aircraft();
    assert_eq!(
        topsis(&[], &weights, &criteria),
        Err(TopsisError::NoAlternatives)
    );
    assert_eq!(topsis(&[vec![]], &[], &[]), Err(TopsisError::NoCriteria));
    let mut ragged = matrix.clone();
    ragged[2].pop();
    assert!(matches!(
        topsis(&ragged, &weights, &criteria),
        Err(TopsisError::RaggedRow { row: 2, .. })
    ));
    assert!(matches!(
        topsis(&matrix, &weights[..5], &criteria),
        Err(TopsisError::WeightCount {
            expected: 6,
            found: 5
        })
    ));
    assert!(matches!(
        topsis(&matrix, &weights, &criteria[..4]),
        Err(TopsisError::CriterionCount {
            expected: 6,
            found: 4
        })
    ));
    let mut negative = weights.clone();
    negative[1] = -0.1;
    assert!(matches!(
        topsis(&matrix, &negative, &criteria),
        Err(TopsisError::InvalidWeight { criterion: 1, .. })
    ));
    let mut nan_weight = weights.clone();
    nan_weight[0] = f64::NAN;
    assert!(matches!(
        topsis(&matrix, &nan_weight, &criteria),
        Err(TopsisError::InvalidWeight { criterion: 0, .. })
    ));
    assert_eq!(
        topsis(&matrix, &[0.0; 6], &criteria),
        Err(TopsisError::ZeroWeights)
    );
    let mut with_nan = matrix.clone();
    with_nan[3][4] = f64::NAN;
    let error = topsis(&with_nan, &weights, &criteria).unwrap_err();
    assert!(matches!(
        error,
        TopsisError::NonFiniteValue {
            row: 3,
            criterion: 4,
            ..
        }
    ));
    assert!(error.to_string().contains("must be finite"));
    // Huge but finite weights do not overflow their sum.
    let huge = vec![f64::MAX; 6];
    assert!(topsis(&matrix, &huge, &criteria).is_ok());
}

/// Closeness of each row by the plain definition, on the raw values (no normalisation),
/// all criteria costs and equally weighted: the independent reference for `Common`.
fn plain_closeness_of_costs(matrix: &[Vec<f64>]) -> Vec<f64> {
    let columns = matrix[0].len();
    let ideal: Vec<f64> = (0..columns)
        .map(|c| matrix.iter().map(|r| r[c]).fold(f64::INFINITY, f64::min))
        .collect();
    let anti: Vec<f64> = (0..columns)
        .map(|c| {
            matrix
                .iter()
                .map(|r| r[c])
                .fold(f64::NEG_INFINITY, f64::max)
        })
        .collect();
    let distance = |row: &[f64], to: &[f64]| {
        row.iter()
            .zip(to)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    matrix
        .iter()
        .map(|row| {
            let (plus, minus) = (distance(row, &ideal), distance(row, &anti));
            minus / (plus + minus)
        })
        .collect()
}

/// Relative errors in % of three pressures on a front that stretches far along the
/// third: the shape a calibration front takes when one error is very sensitive.
fn errors_front() -> Vec<Vec<f64>> {
    vec![
        vec![0.8, 4.4, 19.0],
        vec![0.8, 6.7, 0.8],
        vec![0.1, 0.2, 50.0],
        vec![3.0, 9.0, 0.0],
        vec![1.5, 5.5, 10.0],
        vec![0.2, 1.0, 40.0],
        vec![0.5, 2.0, 35.0],
        vec![0.4, 3.0, 30.0],
        vec![0.1, 0.5, 45.0],
    ]
}

#[test]
fn common_normalisation_is_topsis_on_the_raw_values() {
    let matrix = errors_front();
    let result = topsis_normalised(&matrix, &[1.0; 3], &[Cost; 3], Normalisation::Common).unwrap();
    for (ours, plain) in result
        .closeness
        .iter()
        .zip(plain_closeness_of_costs(&matrix))
    {
        assert!((ours - plain).abs() < 1e-12, "{ours} vs {plain}");
    }
    // On the raw values the balanced point (largest error 6.7 %) is closest.
    assert_eq!(result.best, 1);
    // Scaling every criterion by one factor changes nothing.
    let scaled: Vec<Vec<f64>> = matrix
        .iter()
        .map(|row| row.iter().map(|v| v * 1.0e-200).collect())
        .collect();
    let again = topsis_normalised(&scaled, &[1.0; 3], &[Cost; 3], Normalisation::Common).unwrap();
    for (x, y) in result.closeness.iter().zip(&again.closeness) {
        assert!((x - y).abs() < 1e-12);
    }
}

#[test]
fn per_criterion_normalisation_shrinks_the_criterion_that_spreads_most() {
    // The third error spreads over 0-50 %, the others over 0-9 %: normalised per
    // criterion, one point of the third counts about five times less, and the pick is
    // the point with 19 % on it. This is why same-unit errors are normalised together.
    let matrix = errors_front();
    let per_criterion = topsis(&matrix, &[1.0; 3], &[Cost; 3]).unwrap();
    let default =
        topsis_normalised(&matrix, &[1.0; 3], &[Cost; 3], Normalisation::default()).unwrap();
    assert_eq!(per_criterion, default);
    assert_ne!(per_criterion.best, 1);
    let largest = |row: usize| matrix[row].iter().copied().fold(0.0, f64::max);
    assert!(largest(per_criterion.best) > 2.0 * largest(1));
}

#[test]
fn the_minimax_pick_has_the_least_largest_error() {
    let matrix = errors_front();
    let ranking = minimax_ranking(&matrix, &[1.0; 3]).unwrap();
    let pick = ranking[0];
    let largest = |row: &Vec<f64>| row.iter().copied().fold(0.0, f64::max);
    let least = matrix.iter().map(largest).fold(f64::INFINITY, f64::min);
    assert_eq!(largest(&matrix[pick]), least);
    assert_eq!(pick, 1);
    for pair in ranking.windows(2) {
        assert!(largest(&matrix[pair[0]]) <= largest(&matrix[pair[1]]));
    }
    // Weights scale the errors before the largest is taken: with the third error
    // weighted down by 10, (0.4, 3, 30) counts as 3 and wins over (0.8, 6.7, 0.8).
    assert_eq!(minimax_ranking(&matrix, &[1.0, 1.0, 0.1]).unwrap()[0], 7);
    // Only the weights' ratios matter.
    assert_eq!(minimax_ranking(&matrix, &[2.0, 2.0, 0.2]).unwrap()[0], 7);
    assert_eq!(
        minimax_ranking(&matrix, &[0.0; 3]).unwrap_err(),
        TopsisError::ZeroWeights
    );
    assert_eq!(
        minimax_ranking(&[], &[1.0]).unwrap_err(),
        TopsisError::NoAlternatives
    );
}
