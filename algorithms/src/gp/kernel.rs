//! The stationary correlation functions k(r) of the Gaussian process, as functions of the
//! scaled distance r = |(x - x') / length_scale|, with the derivative factor needed for the
//! hyperparameter and input gradients.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::error::GpError;

/// Correlation family. All have k(0) = 1; the signal variance multiplies them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Kernel {
    /// exp(-r^2 / 2): infinitely smooth sample paths.
    SquaredExponential,
    /// Matern nu = 1/2, exp(-r): continuous, nowhere differentiable paths.
    Matern12,
    /// Matern nu = 3/2, (1 + sqrt3 r) exp(-sqrt3 r): once differentiable paths.
    Matern32,
    /// Matern nu = 5/2, (1 + sqrt5 r + 5/3 r^2) exp(-sqrt5 r): twice differentiable paths,
    /// the usual choice for engineering responses.
    Matern52,
}

const SQRT_3: f64 = 1.732_050_807_568_877_2;
const SQRT_5: f64 = 2.236_067_977_499_79;

impl Kernel {
    /// The names accepted by `FromStr` and printed by `Display`.
    pub const NAMES: [&'static str; 4] = ["se", "matern12", "matern32", "matern52"];

    /// Returns `(k(r), g(r))` from the squared scaled distance, where `g(r) = -k'(r) / r`.
    ///
    /// `g` is what every gradient needs: d k / d log(l_k) = g(r) (dx_k / l_k)^2 and
    /// d k / d x_k = -g(r) (x_k - x'_k) / l_k^2. Written this way it has no 0/0 at r = 0 for
    /// the smooth kernels; for Matern 1/2 (g = exp(-r)/r) the r = 0 value is set to 0, the
    /// limit of every product it enters (those carry a factor dx^2 <= r^2 or |dx| <= r).
    #[inline(always)]
    pub(crate) fn value_and_slope(self, r_squared: f64) -> (f64, f64) {
        match self {
            Kernel::SquaredExponential => {
                let k = exp_nonpositive(-0.5 * r_squared);
                (k, k)
            }
            Kernel::Matern12 => {
                let r = r_squared.sqrt();
                let e = exp_nonpositive(-r);
                (e, if r > 0.0 { e / r } else { 0.0 })
            }
            Kernel::Matern32 => {
                let r = r_squared.sqrt();
                let e = exp_nonpositive(-SQRT_3 * r);
                ((1.0 + SQRT_3 * r) * e, 3.0 * e)
            }
            Kernel::Matern52 => {
                let r = r_squared.sqrt();
                let e = exp_nonpositive(-SQRT_5 * r);
                (
                    (1.0 + SQRT_5 * r + (5.0 / 3.0) * r_squared) * e,
                    (5.0 / 3.0) * (1.0 + SQRT_5 * r) * e,
                )
            }
        }
    }

    /// k(r) alone, from the squared scaled distance.
    #[inline(always)]
    pub(crate) fn value(self, r_squared: f64) -> f64 {
        match self {
            Kernel::SquaredExponential => exp_nonpositive(-0.5 * r_squared),
            Kernel::Matern12 => exp_nonpositive(-r_squared.sqrt()),
            Kernel::Matern32 => {
                let r = r_squared.sqrt();
                (1.0 + SQRT_3 * r) * exp_nonpositive(-SQRT_3 * r)
            }
            Kernel::Matern52 => {
                let r = r_squared.sqrt();
                (1.0 + SQRT_5 * r + (5.0 / 3.0) * r_squared) * exp_nonpositive(-SQRT_5 * r)
            }
        }
    }

    /// Fills `values[i] = k(r_i)` and `slopes[i] = g(r_i)` from `r_squared[i]`. The kernel
    /// branch is taken once, outside the loop, so the loop body is straight-line code the
    /// compiler vectorises.
    #[inline(always)]
    pub(crate) fn fill_values_and_slopes(
        self,
        r_squared: &[f64],
        values: &mut [f64],
        slopes: &mut [f64],
    ) {
        macro_rules! fill {
            ($kernel:expr) => {
                for ((v, g), r2) in values.iter_mut().zip(slopes.iter_mut()).zip(r_squared) {
                    (*v, *g) = $kernel.value_and_slope(*r2);
                }
            };
        }
        match self {
            Kernel::SquaredExponential => fill!(Kernel::SquaredExponential),
            Kernel::Matern12 => fill!(Kernel::Matern12),
            Kernel::Matern32 => fill!(Kernel::Matern32),
            Kernel::Matern52 => fill!(Kernel::Matern52),
        }
    }

    /// Fills `values[i] = k(r_i)` from `r_squared[i]` (see `fill_values_and_slopes`).
    #[inline(always)]
    pub(crate) fn fill_values(self, r_squared: &[f64], values: &mut [f64]) {
        macro_rules! fill {
            ($kernel:expr) => {
                for (v, r2) in values.iter_mut().zip(r_squared) {
                    *v = $kernel.value(*r2);
                }
            };
        }
        match self {
            Kernel::SquaredExponential => fill!(Kernel::SquaredExponential),
            Kernel::Matern12 => fill!(Kernel::Matern12),
            Kernel::Matern32 => fill!(Kernel::Matern32),
            Kernel::Matern52 => fill!(Kernel::Matern52),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Kernel::SquaredExponential => "se",
            Kernel::Matern12 => "matern12",
            Kernel::Matern32 => "matern32",
            Kernel::Matern52 => "matern52",
        }
    }
}

/// e^x for x <= 0, within 2 ulp of the correctly rounded value, and branch-free so that the
/// kernel loops vectorise (a call to the C library's `exp` cannot; it was a sixth of the fit
/// time). Arguments below -708 return e^-708 ~ 3e-308 instead of a subnormal: a correlation
/// that small is zero for every purpose here. Positive arguments are clamped to 0.
///
/// Method: x = k ln2 + r with |r| <= ln2 / 2 (Cody-Waite split of ln2, exact products for
/// |k| < 2^20), e^r by its Taylor series to degree 13 (truncation below 1e-17), times 2^k
/// assembled in the exponent bits.
#[inline(always)]
pub(crate) fn exp_nonpositive(x: f64) -> f64 {
    const LN2_HIGH: f64 = 6.931_471_803_691_238e-1;
    const LN2_LOW: f64 = 1.908_214_929_270_587_7e-10;
    // Adding 1.5 * 2^52 rounds to an integer held in the low mantissa bits.
    const ROUNDER: f64 = 6_755_399_441_055_744.0;
    let x = x.clamp(-708.0, 0.0);
    let shifted = x * std::f64::consts::LOG2_E + ROUNDER;
    let k = shifted - ROUNDER;
    let r = (x - k * LN2_HIGH) - k * LN2_LOW;
    let mut p = 1.0 / 6_227_020_800.0;
    p = p * r + 1.0 / 479_001_600.0;
    p = p * r + 1.0 / 39_916_800.0;
    p = p * r + 1.0 / 3_628_800.0;
    p = p * r + 1.0 / 362_880.0;
    p = p * r + 1.0 / 40_320.0;
    p = p * r + 1.0 / 5_040.0;
    p = p * r + 1.0 / 720.0;
    p = p * r + 1.0 / 120.0;
    p = p * r + 1.0 / 24.0;
    p = p * r + 1.0 / 6.0;
    p = p * r + 0.5;
    p = p * r + 1.0;
    p = p * r + 1.0;
    // k (two's complement, from the rounder's low bits) + bias into the exponent field.
    let k_bits = shifted.to_bits().wrapping_sub(ROUNDER.to_bits());
    let two_to_k = f64::from_bits(k_bits.wrapping_add(1023) << 52);
    p * two_to_k
}

impl fmt::Display for Kernel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Kernel {
    type Err = GpError;

    /// Accepts "se", "matern12", "matern32", "matern52" (any case).
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        match text.trim().to_ascii_lowercase().as_str() {
            "se" => Ok(Kernel::SquaredExponential),
            "matern12" => Ok(Kernel::Matern12),
            "matern32" => Ok(Kernel::Matern32),
            "matern52" => Ok(Kernel::Matern52),
            _ => Err(GpError::UnknownKernel(text.to_string())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_exp_matches_the_library_exp() {
        let mut worst = 0.0f64;
        for i in 0..200_000 {
            // Down to -708, where the library exp is still a normal number.
            let x = -(i as f64) * 3.54e-3 - 1e-9 * i as f64;
            let exact = x.exp();
            let error = ((exp_nonpositive(x) - exact) / exact).abs();
            worst = worst.max(error);
        }
        assert!(worst < 4.5e-16, "worst relative error {worst:e}");
        assert_eq!(exp_nonpositive(0.0), 1.0);
        assert_eq!(exp_nonpositive(-0.0), 1.0);
        assert!(exp_nonpositive(f64::NEG_INFINITY) < 1e-300);
    }
}
