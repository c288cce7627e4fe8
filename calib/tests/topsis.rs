//! TOPSIS against the textbook example, its invariances and its input errors.

use acq_calib::topsis::{topsis, Criterion, TopsisError};

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
