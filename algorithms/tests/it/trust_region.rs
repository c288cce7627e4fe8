//! Local trust-region steps on residuals (`BoSettings::local_steps`) against
//! a least-squares problem with a known minimum: the extended Rosenbrock
//! function, whose curved valley a GP of the scalar loss crawls along and a
//! Gauss-Newton model of the residuals follows.

use acq_algorithms::bo::{minimise, BoError, BoSettings, Outcome};
use acq_algorithms::doe::latin_hypercube;
use acq_algorithms::trust_region::TrustRegionSettings;

/// Extended Rosenbrock on the unit box (x = -2 + 4 u), pairs
/// `(10 (x2 - x1^2), 1 - x1)`; all residuals vanish at x = 1 (u = 0.75).
fn rosenbrock_residuals(u: &[f64]) -> Vec<f64> {
    let x: Vec<f64> = u.iter().map(|v| -2.0 + 4.0 * v).collect();
    x.chunks(2)
        .flat_map(|pair| [10.0 * (pair[1] - pair[0] * pair[0]), 1.0 - pair[0]])
        .collect()
}

/// The best loss of a run on the 6-D problem: `loss` of the residuals,
/// 10 Latin-hypercube points then 70 steps. Runs with x1 beyond 1.6 fail
/// (a solver that does not converge there).
fn best_loss(local_steps: Option<TrustRegionSettings>, loss: fn(&[f64]) -> f64) -> f64 {
    let settings = BoSettings {
        max_evaluations: 80,
        seed: 4,
        local_steps,
        ..BoSettings::default()
    };
    let result = minimise::<BoError, Outcome>(
        latin_hypercube(10, 6, 3),
        |batch| {
            Ok(batch
                .iter()
                .map(|u| {
                    let residuals = rosenbrock_residuals(u);
                    (-2.0 + 4.0 * u[0] <= 1.6).then(|| Outcome {
                        loss: loss(&residuals),
                        residuals,
                    })
                })
                .collect())
        },
        &settings,
    )
    .unwrap();
    assert_eq!(result.observations.len(), 80);
    result.observations[result.best].loss.unwrap()
}

fn sum_of_squares(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

fn sum_of_absolutes(r: &[f64]) -> f64 {
    r.iter().map(|v| v.abs()).sum()
}

#[test]
fn local_steps_follow_the_valley_the_global_search_crawls_along() {
    let global = best_loss(None, sum_of_squares);
    let local = best_loss(Some(TrustRegionSettings::default()), sum_of_squares);
    assert!(local < 1e-6, "local steps: {local}, global only: {global}");
    assert!(
        global > 100.0 * local,
        "local steps: {local}, global only: {global}"
    );
}

#[test]
fn absolute_weights_minimise_a_sum_of_absolute_values() {
    let settings = TrustRegionSettings {
        absolute: true,
        ..TrustRegionSettings::default()
    };
    let global = best_loss(None, sum_of_absolutes);
    let local = best_loss(Some(settings), sum_of_absolutes);
    // Slower than squares (the weights follow the kinks of |r|; measured
    // 0.67 after 80 runs, the global search 6.2), but well ahead.
    assert!(local < 1.0, "local steps: {local}, global only: {global}");
    assert!(
        global > 5.0 * local,
        "local steps: {local}, global only: {global}"
    );
}
