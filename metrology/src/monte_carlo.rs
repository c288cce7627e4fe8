//! Propagation of distributions by Monte Carlo (JCGM 101:2008, GUM
//! Supplement 1): the check of the first-order law where a model is not
//! linear in its inputs.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal, StudentT};

/// What is known of one input.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InputDistribution {
    /// A normal distribution (a standard uncertainty with infinite
    /// degrees of freedom).
    Normal {
        mean: f64,
        standard_uncertainty: f64,
    },
    /// A limit `+-half_width` about `mean` (an accuracy class).
    Rectangular { mean: f64, half_width: f64 },
    /// A Type A estimate with `dof` degrees of freedom: the scaled and
    /// shifted t-distribution of JCGM 101 6.4.9.
    StudentT {
        mean: f64,
        standard_uncertainty: f64,
        dof: f64,
    },
}

impl InputDistribution {
    fn draw(&self, rng: &mut ChaCha8Rng) -> f64 {
        match *self {
            InputDistribution::Normal {
                mean,
                standard_uncertainty,
            } => {
                let z: f64 = StandardNormal.sample(rng);
                mean + standard_uncertainty * z
            }
            InputDistribution::Rectangular { mean, half_width } => {
                mean + half_width * (2.0 * rng.random::<f64>() - 1.0)
            }
            InputDistribution::StudentT {
                mean,
                standard_uncertainty,
                dof,
            } => {
                let t = StudentT::new(dof).map_or(0.0, |d| d.sample(rng));
                mean + standard_uncertainty * t
            }
        }
    }
}

/// The output's distribution, summarised as JCGM 101 7.
#[derive(Clone, Debug, PartialEq)]
pub struct MonteCarloResult {
    pub mean: f64,
    pub standard_uncertainty: f64,
    /// The probabilistically symmetric 95 % coverage interval.
    pub interval_95: [f64; 2],
    pub draws: usize,
}

/// `draws` values of `model` at inputs drawn from `inputs` (seeded, so a
/// run is repeatable); `None` for fewer than two draws or a model that
/// gave a non-finite value.
pub fn propagate(
    inputs: &[InputDistribution],
    model: impl Fn(&[f64]) -> f64,
    draws: usize,
    seed: u64,
) -> Option<MonteCarloResult> {
    if draws < 2 {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut point = vec![0.0; inputs.len()];
    let mut values = Vec::with_capacity(draws);
    for _ in 0..draws {
        for (x, input) in point.iter_mut().zip(inputs) {
            *x = input.draw(&mut rng);
        }
        let y = model(&point);
        if !y.is_finite() {
            return None;
        }
        values.push(y);
    }
    let n = draws as f64;
    let mean = values.iter().sum::<f64>() / n;
    let variance = values.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / (n - 1.0);
    values.sort_by(f64::total_cmp);
    let at = |p: f64| values[((p * n) as usize).min(draws - 1)];
    Some(MonteCarloResult {
        mean,
        standard_uncertainty: variance.sqrt(),
        interval_95: [at(0.025), at(0.975)],
        draws,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::budget::{rectangular, Budget, Contribution};

    const DRAWS: usize = 1_000_000;

    #[test]
    fn on_a_linear_model_monte_carlo_equals_the_law_of_propagation() {
        // y = 2 a - 3 b, a normal with u = 0.1, b rectangular +-0.2:
        // u_c^2 = (2 * 0.1)^2 + (3 * 0.2 / sqrt(3))^2 = 0.04 + 0.12.
        let law = Budget {
            contributions: vec![
                Contribution {
                    source: "a".into(),
                    standard_uncertainty: 0.1,
                    sensitivity: 2.0,
                    dof: None,
                    shared_by: None,
                },
                Contribution {
                    source: "b".into(),
                    standard_uncertainty: rectangular(0.2),
                    sensitivity: -3.0,
                    dof: None,
                    shared_by: None,
                },
            ],
        }
        .combined();
        assert!((law - 0.16f64.sqrt()).abs() < 1e-15);
        let inputs = [
            InputDistribution::Normal {
                mean: 5.0,
                standard_uncertainty: 0.1,
            },
            InputDistribution::Rectangular {
                mean: 1.0,
                half_width: 0.2,
            },
        ];
        let mc = propagate(&inputs, |x| 2.0 * x[0] - 3.0 * x[1], DRAWS, 7).unwrap();
        // The sample std of 1e6 draws is within 0.1 % of the truth with
        // odds of about 20 to 1 (its relative spread is 1/sqrt(2N) = 0.07 %);
        // 0.3 % is four such spreads.
        assert!(
            (mc.standard_uncertainty - law).abs() < 0.003 * law,
            "{mc:?}"
        );
        assert!(
            (mc.mean - 7.0).abs() < 4.0 * law / (DRAWS as f64).sqrt(),
            "{mc:?}"
        );
        assert!(mc.interval_95[0] < 7.0 && mc.interval_95[1] > 7.0);
    }

    #[test]
    fn on_a_product_monte_carlo_finds_what_the_first_order_law_leaves_out() {
        // y = a b, a and b normal with mean 1 and u = 0.5. The first-order
        // law: u^2 = 0.5^2 + 0.5^2 = 0.5 (u = 0.7071). The exact variance of
        // a product of independent normals: mu_a^2 s_b^2 + mu_b^2 s_a^2 +
        // s_a^2 s_b^2 = 0.5625 (u = 0.75): the law is 5.7 % low here.
        let inputs = [InputDistribution::Normal {
            mean: 1.0,
            standard_uncertainty: 0.5,
        }; 2];
        let mc = propagate(&inputs, |x| x[0] * x[1], DRAWS, 11).unwrap();
        // The product's tails are heavier than a normal's: its sample std
        // spreads more (about 0.2 % here); 1 % is five such spreads.
        assert!((mc.standard_uncertainty - 0.75).abs() < 0.0075, "{mc:?}");
        let first_order = 0.5f64.sqrt();
        assert!(mc.standard_uncertainty > 1.05 * first_order);
    }

    #[test]
    fn a_t_input_has_the_spread_of_its_degrees_of_freedom() {
        // A scaled t with nu = 5: std = u sqrt(nu / (nu - 2)) = 1.291 u.
        let inputs = [InputDistribution::StudentT {
            mean: 0.0,
            standard_uncertainty: 1.0,
            dof: 5.0,
        }];
        let mc = propagate(&inputs, |x| x[0], DRAWS, 3).unwrap();
        assert!(
            (mc.standard_uncertainty - (5.0f64 / 3.0).sqrt()).abs() < 0.02,
            "{mc:?}"
        );
        assert_eq!(propagate(&inputs, |x| x[0], 1, 3), None);
        assert_eq!(propagate(&inputs, |_| f64::NAN, 10, 3), None);
    }
}
