//! Sobol indices against closed forms: the Ishigami function and a linear function.

use std::f64::consts::PI;

use acq_algorithms::sobol_indices::{sobol_indices, SensitivityError, SobolIndices};

/// Ishigami & Homma (1990) with a = 7, b = 0.1, inputs uniform on [-pi, pi] (mapped from
/// the unit box here).
fn ishigami(unit: &[f64]) -> f64 {
    let x: Vec<f64> = unit.iter().map(|u| -PI + 2.0 * PI * u).collect();
    x[0].sin() + 7.0 * x[1].sin().powi(2) + 0.1 * x[2].powi(4) * x[0].sin()
}

/// Closed-form indices of the Ishigami function for a = 7, b = 0.1 (e.g. Saltelli et al.
/// 2008, "Global Sensitivity Analysis: The Primer", or SALib's documentation).
const ISHIGAMI_FIRST: [f64; 3] = [0.3139, 0.4424, 0.0];
const ISHIGAMI_TOTAL: [f64; 3] = [0.5576, 0.4424, 0.2437];

fn assert_close(name: &str, ours: &[f64], truth: &[f64], tolerance: f64) {
    for (input, (o, t)) in ours.iter().zip(truth).enumerate() {
        assert!(
            (o - t).abs() < tolerance,
            "{name}[{input}] = {o}, expected {t} +- {tolerance}"
        );
    }
}

#[test]
fn ishigami_indices_match_the_closed_form() {
    let result = sobol_indices(ishigami, 3, 4096, 1).unwrap();
    assert_eq!(result.evaluations, 4096 * 5);
    assert_close("first order", &result.first_order, &ISHIGAMI_FIRST, 0.02);
    assert_close("total", &result.total, &ISHIGAMI_TOTAL, 0.02);
    // The intervals bracket the estimate, are narrow, and (at this size) hold the truth
    // within their own width.
    for (input, (&(low, high), &estimate)) in result
        .first_order_ci
        .iter()
        .zip(&result.first_order)
        .enumerate()
    {
        assert!(
            low <= estimate && estimate <= high,
            "S{input}: {low} {estimate} {high}"
        );
        assert!(high - low < 0.1, "S{input} interval {low}..{high}");
        let width = high - low;
        assert!(
            (low - width..=high + width).contains(&ISHIGAMI_FIRST[input]),
            "S{input}"
        );
    }
    for (input, (&(low, high), &estimate)) in result.total_ci.iter().zip(&result.total).enumerate()
    {
        assert!(
            low <= estimate && estimate <= high,
            "ST{input}: {low} {estimate} {high}"
        );
        assert!(high - low < 0.1, "ST{input} interval {low}..{high}");
    }
}

#[test]
fn ishigami_across_seeds() {
    for seed in 2..5 {
        let result = sobol_indices(ishigami, 3, 2048, seed).unwrap();
        assert_close("first order", &result.first_order, &ISHIGAMI_FIRST, 0.03);
        assert_close("total", &result.total, &ISHIGAMI_TOTAL, 0.03);
    }
}

#[test]
fn linear_function_indices_are_the_squared_coefficient_shares() {
    // f = sum a_i x_i with independent uniform x_i: Var = sum a_i^2 / 12, no interaction,
    // so S_i = ST_i = a_i^2 / sum a^2. An offset changes nothing.
    let coefficients = [1.0, 2.0, 3.0, 0.0];
    let linear = |x: &[f64]| 1000.0 + x.iter().zip(&coefficients).map(|(v, a)| v * a).sum::<f64>();
    let result = sobol_indices(linear, 4, 4096, 7).unwrap();
    let sum_squares: f64 = coefficients.iter().map(|a| a * a).sum();
    let truth: Vec<f64> = coefficients.iter().map(|a| a * a / sum_squares).collect();
    assert_close("first order", &result.first_order, &truth, 0.01);
    assert_close("total", &result.total, &truth, 0.01);
    // The input with no effect has exactly zero total index (f(A_B^i) = f(A)).
    assert_eq!(result.total[3], 0.0);
}

#[test]
fn reproducible_by_seed() {
    let a = sobol_indices(ishigami, 3, 256, 9).unwrap();
    let b = sobol_indices(ishigami, 3, 256, 9).unwrap();
    assert_eq!(a, b);
    let c = sobol_indices(ishigami, 3, 256, 10).unwrap();
    assert_ne!(a, c);
}

#[test]
fn many_inputs_fall_back_to_pseudo_random_sampling() {
    // 2 x 150 columns exceed the scrambled sequence's 256: still estimated, still seeded.
    let only_first = |x: &[f64]| x[0];
    let result = sobol_indices(only_first, 150, 512, 3).unwrap();
    // Pseudo-random rows converge slower than Sobol points: check against the interval.
    let (low, high) = result.first_order_ci[0];
    assert!(low <= 1.0 && 1.0 <= high, "S0 interval {low}..{high}");
    assert!(
        (result.first_order[0] - 1.0).abs() < 0.15,
        "{}",
        result.first_order[0]
    );
    assert!((result.total[0] - 1.0).abs() < 0.05, "{}", result.total[0]);
    assert!(result.total[1..].iter().all(|&t| t == 0.0));
    assert_eq!(result, sobol_indices(only_first, 150, 512, 3).unwrap());
}

#[test]
fn constant_function_has_zero_indices() {
    let result: SobolIndices = sobol_indices(|_| 4.2, 2, 64, 1).unwrap();
    assert_eq!(result.first_order, vec![0.0; 2]);
    assert_eq!(result.total, vec![0.0; 2]);
    assert_eq!(result.total_ci, vec![(0.0, 0.0); 2]);
}

#[test]
fn errors() {
    assert_eq!(
        sobol_indices(|x| x[0], 0, 64, 1),
        Err(SensitivityError::NoDimensions)
    );
    assert_eq!(
        sobol_indices(|x| x[0], 2, 4, 1),
        Err(SensitivityError::TooFewSamples { given: 4, min: 8 })
    );
    assert_eq!(
        sobol_indices(|x| x[0], usize::MAX, 64, 1),
        Err(SensitivityError::TooManyEvaluations)
    );
    let failing = sobol_indices(|x| if x[0] > 0.5 { f64::NAN } else { x[0] }, 2, 64, 1);
    match failing {
        Err(SensitivityError::NonFiniteOutput { value, x }) => {
            assert!(value.is_nan());
            assert!(x[0] > 0.5);
        }
        other => panic!("expected a non-finite output error, got {other:?}"),
    }
}
