//! The variation operators of NSGA-II: bounded simulated binary crossover (SBX) and bounded
//! polynomial mutation, as in Deb's reference C code (nsga2-v1.1) and pymoo 0.6.
//!
//! Both work per variable inside `[lower, upper]`, never leave it, and leave a fixed
//! variable (`lower == upper`) alone.

use rand::RngExt;
use rand_chacha::ChaCha8Rng;

/// Parents closer than this in a variable are not crossed in it (the spread would be 0).
const SAME_VALUE: f64 = 1.0e-14;

/// Chance that SBX touches a given variable of a crossed pair (Deb's code and pymoo: 0.5).
const CROSSOVER_PER_VARIABLE: f64 = 0.5;

/// Bounded SBX of two parents into two children (in place of copies of the parents).
///
/// Each variable is crossed with probability 0.5; the children then swap that variable
/// with probability 0.5, so neither child is biased towards one parent.
pub(crate) fn simulated_binary_crossover(
    child_a: &mut [f64],
    child_b: &mut [f64],
    bounds: &[(f64, f64)],
    eta: f64,
    rng: &mut ChaCha8Rng,
) {
    for ((a, b), &(lower, upper)) in child_a.iter_mut().zip(child_b.iter_mut()).zip(bounds) {
        if !rng.random_bool(CROSSOVER_PER_VARIABLE) {
            continue;
        }
        if (*a - *b).abs() <= SAME_VALUE || lower >= upper {
            continue;
        }
        let (y1, y2) = if *a < *b { (*a, *b) } else { (*b, *a) };
        let spread = y2 - y1;
        let random: f64 = rng.random();
        let spread_factor = |beta: f64| {
            // The spread distribution truncated to keep the child inside the bounds.
            let alpha = 2.0 - beta.powf(-(eta + 1.0));
            if random <= 1.0 / alpha {
                (random * alpha).powf(1.0 / (eta + 1.0))
            } else {
                (1.0 / (2.0 - random * alpha)).powf(1.0 / (eta + 1.0))
            }
        };
        let beta_low = 1.0 + 2.0 * (y1 - lower) / spread;
        let c1 = 0.5 * ((y1 + y2) - spread_factor(beta_low) * spread);
        let beta_high = 1.0 + 2.0 * (upper - y2) / spread;
        let c2 = 0.5 * ((y1 + y2) + spread_factor(beta_high) * spread);
        let (c1, c2) = (clamp(c1, lower, upper), clamp(c2, lower, upper));
        if rng.random_bool(0.5) {
            *a = c2;
            *b = c1;
        } else {
            *a = c1;
            *b = c2;
        }
    }
}

/// Bounded polynomial mutation: each variable mutates with `probability`, by a perturbation
/// whose distribution shrinks near the bounds so the result stays inside.
pub(crate) fn polynomial_mutation(
    x: &mut [f64],
    bounds: &[(f64, f64)],
    eta: f64,
    probability: f64,
    rng: &mut ChaCha8Rng,
) {
    let exponent = 1.0 / (eta + 1.0);
    for (value, &(lower, upper)) in x.iter_mut().zip(bounds) {
        if !rng.random_bool(probability) || lower >= upper {
            continue;
        }
        let width = upper - lower;
        let delta_low = (*value - lower) / width;
        let delta_high = (upper - *value) / width;
        let random: f64 = rng.random();
        let shift = if random <= 0.5 {
            let room = 1.0 - delta_low;
            let v = 2.0 * random + (1.0 - 2.0 * random) * room.powf(eta + 1.0);
            v.powf(exponent) - 1.0
        } else {
            let room = 1.0 - delta_high;
            let v = 2.0 * (1.0 - random) + 2.0 * (random - 0.5) * room.powf(eta + 1.0);
            1.0 - v.powf(exponent)
        };
        *value = clamp(*value + shift * width, lower, upper);
    }
}

/// `value` inside `[lower, upper]`; NaN (which the formulas cannot produce from finite
/// inputs, but a guard costs nothing) goes to the middle.
fn clamp(value: f64, lower: f64, upper: f64) -> f64 {
    if value.is_nan() {
        0.5 * (lower + upper)
    } else {
        value.clamp(lower, upper)
    }
}
