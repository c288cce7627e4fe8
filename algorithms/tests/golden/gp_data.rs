// The small data set of algorithms/tests/it/gp.rs, tests/calibrate.rs and
// algorithms/tests/golden/gp_sklearn.py (included by both tests, so it is written once).

const TRAIN_X: [[f64; 2]; 12] = [
    [0.10, 0.70],
    [0.35, 0.20],
    [0.80, 0.90],
    [0.55, 0.45],
    [0.95, 0.15],
    [0.20, 0.30],
    [0.65, 0.75],
    [0.40, 0.95],
    [0.05, 0.05],
    [0.75, 0.35],
    [0.30, 0.60],
    [0.90, 0.55],
];
/// Includes a training point (row 1), a corner and a point outside the data's box.
const QUERY_X: [[f64; 2]; 5] = [
    [0.50, 0.50],
    [0.35, 0.20],
    [0.00, 1.00],
    [1.30, -0.20],
    [0.62, 0.33],
];

/// The function sampled at `TRAIN_X`.
fn smooth(x: &[f64]) -> f64 {
    (3.0 * x[0]).sin() + (2.0 * x[1]).cos() + x[0] * x[1]
}
