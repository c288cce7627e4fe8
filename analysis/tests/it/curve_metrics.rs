//! The curve metrics on closed forms: a straight measured curve and a
//! copy moved a distance `d` across it, where every metric has a value by
//! hand; the signs of the residuals; the normalisation; and no input that
//! panics. The comparison with `similaritymeasures` itself is
//! `tests/curve_metrics.rs` at the workspace root.

use acq_analysis::loss::metrics::{
    matched, residuals_by_part, CurveMetric, CurveMetricError, Normalisation,
};
use proptest::prelude::*;

/// `n` points from (0, 0) to (10 mm, 50 kN), and the same moved by `d`
/// (normalised units) perpendicular to it, to its left when `d > 0`.
fn parallel(n: usize, d: f64) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let measured: Vec<[f64; 2]> = (0..n)
        .map(|k| {
            let t = k as f64 / (n - 1) as f64;
            [10.0 * t, 50.0 * t]
        })
        .collect();
    // In normalised units the curve is the diagonal; its left normal is
    // (-1, 1) / sqrt 2.
    let s = d / std::f64::consts::SQRT_2;
    let simulated = measured
        .iter()
        .map(|&[x, y]| [x - 10.0 * s, y + 50.0 * s])
        .collect();
    (measured, simulated)
}

fn close(actual: f64, expected: f64, what: &str) {
    assert!(
        (actual - expected).abs() <= 1e-12 * expected.abs().max(1.0),
        "{what}: {actual} against {expected}"
    );
}

#[test]
fn a_curve_moved_across_itself_has_each_metric_s_closed_form() {
    for (n, d) in [(2, 0.1), (11, 0.05), (101, -0.02)] {
        let (measured, simulated) = parallel(n, d);
        let gap = d.abs();
        let expected = [
            // Every coupling holds the first points' pair, d apart; the
            // diagonal holds no pair farther.
            (CurveMetric::Frechet, gap),
            // At least n pairs, each at least d apart; the diagonal's are.
            (CurveMetric::Dtw, n as f64 * gap),
            // A parallelogram of length sqrt 2 and height d.
            (CurveMetric::Area, std::f64::consts::SQRT_2 * gap),
            // Equal lengths: one offset, d at every point, the k-th
            // segment weighed by k / (n - 1): d n / 2.
            (CurveMetric::Pcm, gap * n as f64 / 2.0),
        ];
        for (metric, value) in expected {
            let result = matched(metric, &measured, &simulated).unwrap();
            close(result.value, value, &format!("{metric} n={n} d={d}"));
            assert!(!result.pairs.is_empty());
            for pair in &result.pairs {
                close(pair.signed_distance, d, &format!("{metric} pair {pair:?}"));
                assert!((0.0..=1.0).contains(&pair.along), "{pair:?}");
            }
            let parts = residuals_by_part(&result.pairs, 4);
            assert_eq!(parts.len(), 4);
            for part in parts {
                close(part, d, &format!("{metric} part"));
            }
        }
    }
}

/// The same curves in other units, or shifted, score the same: the
/// metrics see only the measured curve's range.
#[test]
fn no_metric_depends_on_units() {
    let measured: Vec<[f64; 2]> = (0..40)
        .map(|k| {
            let t = k as f64 / 39.0;
            [t, (3.0 * t).sin()]
        })
        .collect();
    let simulated: Vec<[f64; 2]> = (0..25)
        .map(|k| {
            let t = k as f64 / 24.0 * 0.8;
            [t, 1.1 * (3.0 * t).sin() + 0.02]
        })
        .collect();
    let rescale = |c: &[[f64; 2]]| -> Vec<[f64; 2]> {
        c.iter()
            .map(|&[x, y]| [1e3 * x + 5.0, 1e-3 * y - 7.0])
            .collect()
    };
    for metric in [
        CurveMetric::Pcm,
        CurveMetric::Frechet,
        CurveMetric::Dtw,
        CurveMetric::Area,
    ] {
        let a = matched(metric, &measured, &simulated).unwrap().value;
        let b = matched(metric, &rescale(&measured), &rescale(&simulated))
            .unwrap()
            .value;
        assert!((a - b).abs() <= 1e-9 * a.abs(), "{metric}: {a} against {b}");
        assert!(a > 0.0, "{metric}");
    }
}

#[test]
fn bad_curves_are_errors_that_say_what() {
    let good = [[0.0, 0.0], [1.0, 1.0], [2.0, 3.0]];
    let flat = [[0.0, 2.0], [1.0, 2.0]];
    let nan = [[0.0, 0.0], [f64::NAN, 1.0]];
    assert!(matches!(
        matched(CurveMetric::Dtw, &[[0.0, 0.0]], &good),
        Err(CurveMetricError::TooFewPoints {
            curve: "measured",
            points: 1
        })
    ));
    assert!(matches!(
        matched(CurveMetric::Dtw, &good, &nan),
        Err(CurveMetricError::NotFinite {
            curve: "simulated",
            index: 1,
            ..
        })
    ));
    let error = matched(CurveMetric::Area, &flat, &good).unwrap_err();
    assert!(error.to_string().contains("y does not vary"), "{error}");
    assert!(matches!(
        matched(CurveMetric::Mape, &good, &good),
        Err(CurveMetricError::NotCoupling)
    ));
    assert!(Normalisation::of_measured(&good).is_ok());
    assert_eq!("frechet".parse::<CurveMetric>(), Ok(CurveMetric::Frechet));
    let unknown = "l2".parse::<CurveMetric>().unwrap_err();
    assert!(
        unknown.contains("mape, pcm, frechet, dtw, area"),
        "{unknown}"
    );
}

fn curve() -> impl Strategy<Value = Vec<[f64; 2]>> {
    prop::collection::vec(
        prop_oneof![
            Just([0.0, 0.0]),
            (-1e3..1e3f64, -1e3..1e3f64).prop_map(|(x, y)| [x, y]),
            any::<(f64, f64)>().prop_map(|(x, y)| [x, y]),
        ],
        0..30,
    )
}

proptest! {
    /// No pair of curves panics any metric; a value is finite or an error.
    #[test]
    fn no_curves_panic(measured in curve(), simulated in curve(), parts in 0usize..6) {
        for metric in CurveMetric::ALL {
            if let Ok(result) = matched(metric, &measured, &simulated) {
                let residuals = residuals_by_part(&result.pairs, parts);
                prop_assert_eq!(residuals.len(), parts.max(1));
                if measured.iter().chain(&simulated).all(|p| p[0].abs() < 1e6 && p[1].abs() < 1e6) {
                    prop_assert!(result.value.is_finite() && result.value >= 0.0, "{metric}: {}", result.value);
                }
            }
        }
    }
}
