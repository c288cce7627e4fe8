//! Checks of the comparison surrogates: exact reproduction of what each model family contains,
//! interpolation, and errors for data that cannot determine the model.

use acq_algorithms::gp::{FixedHyperparameters, Gp, GpSettings, Kernel};
use acq_algorithms::surrogate::{rmse, Polynomial, RadialBasis, Surrogate, SurrogateError};
use acq_algorithms::training_data::DataError;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_points(n: usize, d: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // Inputs in physical-looking ranges, not the unit box, so the scaling is exercised.
    (0..n)
        .map(|_| {
            (0..d)
                .map(|k| -3.0 + (k as f64 + 2.0) * 4.0 * rng.random::<f64>())
                .collect()
        })
        .collect()
}

/// A full cubic in three inputs, with every kind of term.
fn cubic(x: &[f64]) -> f64 {
    1.5 - 2.0 * x[0] + 0.5 * x[1] * x[2] + 0.25 * x[0].powi(3) - 0.1 * x[0] * x[1] * x[2]
        + 0.3 * x[2].powi(2) * x[1]
        - 0.05 * x[2].powi(3)
}

#[test]
fn cubic_polynomial_reproduces_a_cubic_exactly() {
    let inputs = random_points(40, 3, 1);
    let outputs: Vec<f64> = inputs.iter().map(|x| cubic(x)).collect();
    let model = Polynomial::fit(&inputs, &outputs, 3, None).expect("40 points for 20 terms");
    assert_eq!(model.n_terms(), 20);
    assert_eq!(model.name(), "polynomial-3");
    for x in random_points(100, 3, 2) {
        let expected = cubic(&x);
        assert!(
            (model.predict(&x) - expected).abs() < 1e-9 * expected.abs().max(1.0),
            "{x:?}: {} vs {expected}",
            model.predict(&x)
        );
    }
    // A quadratic cannot: its held-out error is visibly larger.
    let quadratic = Polynomial::fit(&inputs, &outputs, 2, None).expect("10 terms");
    let held_out = random_points(100, 3, 3);
    let truth: Vec<f64> = held_out.iter().map(|x| cubic(x)).collect();
    assert!(rmse(&model, &held_out, &truth) < 1e-9);
    assert!(rmse(&quadratic, &held_out, &truth) > 1e-3);
}

#[test]
fn linear_polynomial_is_the_least_squares_line() {
    // y = 2 + 3x with symmetric residuals +-1 at x = 0, 1, 2, 3 (+,-,-,+ cancel in both normal
    // equations): least squares recovers the line exactly.
    let inputs: Vec<Vec<f64>> = (0..4).map(|i| vec![i as f64]).collect();
    let noise = [1.0, -1.0, -1.0, 1.0];
    let outputs: Vec<f64> = (0..4).map(|i| 2.0 + 3.0 * i as f64 + noise[i]).collect();
    let model = Polynomial::fit(&inputs, &outputs, 1, None).expect("fit");
    assert!((model.predict(&[10.0]) - 32.0).abs() < 1e-12);
}

#[test]
fn rbf_interpolates_the_training_points() {
    let inputs = random_points(30, 3, 4);
    let outputs: Vec<f64> = inputs
        .iter()
        .map(|x| (x[0] * 0.7).sin() + x[1] * x[2] * 0.1)
        .collect();
    let model = RadialBasis::fit(&inputs, &outputs, None).expect("fit");
    assert_eq!(model.name(), "rbf-cubic");
    for (x, y) in inputs.iter().zip(&outputs) {
        assert!(
            (model.predict(x) - y).abs() < 1e-8,
            "{x:?}: {} vs {y}",
            model.predict(x)
        );
    }
    assert!(rmse(&model, &inputs, &outputs) < 1e-8);
}

#[test]
fn rbf_reproduces_linear_functions_exactly() {
    let inputs = random_points(25, 4, 5);
    let linear = |x: &[f64]| 0.3 - 1.2 * x[0] + 2.5 * x[1] - 0.4 * x[2] + 0.9 * x[3];
    let outputs: Vec<f64> = inputs.iter().map(|x| linear(x)).collect();
    let model = RadialBasis::fit(&inputs, &outputs, None).expect("fit");
    // Away from the training points too, including outside their box.
    let mut far = random_points(50, 4, 6);
    far.push(vec![30.0, -20.0, 5.0, 0.0]);
    for x in far {
        let expected = linear(&x);
        assert!(
            (model.predict(&x) - expected).abs() < 1e-8 * expected.abs().max(1.0),
            "{x:?}: {} vs {expected}",
            model.predict(&x)
        );
    }
}

#[test]
fn too_few_or_degenerate_points_are_errors() {
    // Degree 2 in 3 inputs has 10 terms.
    let inputs = random_points(9, 3, 7);
    let outputs = vec![1.0; 9];
    assert_eq!(
        Polynomial::fit(&inputs, &outputs, 2, None),
        Err(SurrogateError::TooFewPoints {
            points: 9,
            terms: 10
        })
    );
    assert_eq!(
        Polynomial::fit(&inputs, &outputs, 4, None),
        Err(SurrogateError::InvalidDegree(4))
    );
    assert_eq!(
        Polynomial::fit(&inputs, &outputs, 0, None),
        Err(SurrogateError::InvalidDegree(0))
    );
    // Enough points, but all on the line x1 = x0: the terms in x1 are not determined.
    let on_a_line: Vec<Vec<f64>> = (0..12).map(|i| vec![i as f64, i as f64]).collect();
    let values: Vec<f64> = (0..12).map(|i| i as f64).collect();
    assert!(matches!(
        Polynomial::fit(&on_a_line, &values, 2, None),
        Err(SurrogateError::RankDeficient { .. })
    ));
    assert!(matches!(
        RadialBasis::fit(&on_a_line, &values, None),
        Err(SurrogateError::RankDeficient { .. })
    ));
    // RBF: needs d + 1 points, distinct.
    assert_eq!(
        RadialBasis::fit(&inputs[..3], &outputs[..3], None),
        Err(SurrogateError::TooFewPoints {
            points: 3,
            terms: 4
        })
    );
    let mut duplicated = inputs.clone();
    duplicated.push(inputs[2].clone());
    assert_eq!(
        RadialBasis::fit(&duplicated, &[outputs.clone(), vec![2.0]].concat(), None),
        Err(SurrogateError::DuplicatePoints {
            first: 2,
            second: 9
        })
    );
    // Shapes and values.
    assert!(matches!(
        RadialBasis::fit(&inputs, &outputs[..5], None),
        Err(SurrogateError::Data(DataError::LengthMismatch { .. }))
    ));
    assert_eq!(
        RadialBasis::fit(&[], &[], None),
        Err(SurrogateError::Data(DataError::NoInputs))
    );
    let mut with_nan = inputs.clone();
    with_nan[4][1] = f64::NAN;
    assert!(matches!(
        Polynomial::fit(&with_nan, &outputs, 1, None),
        Err(SurrogateError::Data(DataError::NonFiniteData {
            row: 4,
            ..
        }))
    ));
    let message = SurrogateError::TooFewPoints {
        points: 9,
        terms: 10,
    }
    .to_string();
    assert!(
        message.contains("add points or lower the degree"),
        "{message}"
    );
}

#[test]
fn explicit_input_bounds_set_the_box() {
    let inputs = random_points(30, 2, 10);
    let f = |x: &[f64]| 1.0 + 0.5 * x[0] - 0.25 * x[0] * x[1] + 0.1 * x[1] * x[1];
    let outputs: Vec<f64> = inputs.iter().map(|x| f(x)).collect();
    let bounds = vec![(-3.0, 5.0), (-3.0, 9.0)];
    // The same quadratic whatever the box: only the conditioning depends on it.
    let boxed = Polynomial::fit(&inputs, &outputs, 2, Some(&bounds)).expect("fit");
    let from_data = Polynomial::fit(&inputs, &outputs, 2, None).expect("fit");
    for x in random_points(20, 2, 11) {
        assert!((boxed.predict(&x) - f(&x)).abs() < 1e-9);
        assert!((from_data.predict(&x) - f(&x)).abs() < 1e-9);
    }
    let rbf = RadialBasis::fit(&inputs, &outputs, Some(&bounds)).expect("fit");
    assert!((rbf.predict(&inputs[3]) - outputs[3]).abs() < 1e-8);
    for bad in [
        vec![(0.0, 1.0)],
        vec![(0.0, 1.0), (2.0, 2.0)],
        vec![(0.0, 1.0), (f64::NAN, 1.0)],
    ] {
        assert!(matches!(
            Polynomial::fit(&inputs, &outputs, 1, Some(&bad)),
            Err(SurrogateError::InvalidBounds(_))
        ));
        assert!(matches!(
            RadialBasis::fit(&inputs, &outputs, Some(&bad)),
            Err(SurrogateError::InvalidBounds(_))
        ));
    }
}

#[test]
fn surrogates_compare_through_the_trait() {
    let inputs = random_points(30, 2, 8);
    let f = |x: &[f64]| (0.5 * x[0]).sin() + 0.1 * x[1] * x[1];
    let outputs: Vec<f64> = inputs.iter().map(|x| f(x)).collect();
    let held_out = random_points(200, 2, 9);
    let truth: Vec<f64> = held_out.iter().map(|x| f(x)).collect();
    let gp = Gp::fit(&inputs, &outputs, &GpSettings::default()).expect("gp");
    let models: Vec<Box<dyn Surrogate>> = vec![
        Box::new(gp.clone()),
        Box::new(Polynomial::fit(&inputs, &outputs, 2, None).expect("poly")),
        Box::new(RadialBasis::fit(&inputs, &outputs, None).expect("rbf")),
    ];
    for model in &models {
        let error = rmse(model.as_ref(), &held_out, &truth);
        assert!(
            error.is_finite() && error < 0.5,
            "{}: {error}",
            model.name()
        );
    }
    // The GP's trait prediction is its posterior mean.
    assert_eq!(
        Surrogate::predict(&gp, &held_out[0]),
        gp.predict(&held_out[0]).mean
    );
    assert_eq!(models[0].name(), "gp");
    // Wrong dimension: NaN, not a panic; rmse of nothing is NaN.
    assert!(models[1].predict(&[1.0]).is_nan());
    assert!(models[2].predict(&[1.0, f64::INFINITY]).is_nan());
    assert!(rmse(models[1].as_ref(), &[], &[]).is_nan());
    // A fixed GP is a surrogate too.
    let fixed = Gp::fit(
        &inputs,
        &outputs,
        &GpSettings {
            kernel: Kernel::SquaredExponential,
            fixed: Some(FixedHyperparameters {
                length_scales: vec![2.0],
                signal_variance: 1.0,
                noise_variance: 1e-8,
            }),
            ..GpSettings::default()
        },
    )
    .expect("fixed gp");
    assert!(rmse(&fixed, &inputs, &outputs) < 1e-3);
}
