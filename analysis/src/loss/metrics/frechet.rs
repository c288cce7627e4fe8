//! The discrete Fréchet distance: over the monotone couplings of the two
//! curves' points from both first points to both last ones, the smallest
//! largest pair distance (Eiter and Mannila 1994; `similaritymeasures.
//! frechet_dist` with p = 2). The "dog leash" length: one bad stretch
//! decides it, however good the rest.
//!
//! Written here rather than taken from `geo` (`FrechetDistance`): the
//! signed residuals need the coupling, and `geo` returns the distance
//! only; the value shares its dynamic programme with DTW.

use super::points::{pairs_of_path, CurveMetricError, Matched, Points};
use super::warp::{self, Accumulate};

/// The discrete Fréchet distance of two curves (as given: normalise
/// first), in O(n m) time and O(n + m) memory.
pub fn distance(measured: &Points, simulated: &Points) -> f64 {
    warp::value(measured, simulated, Accumulate::Max)
}

/// The distance and the pairs of a coupling that attains it.
pub fn matched(measured: &Points, simulated: &Points) -> Result<Matched, CurveMetricError> {
    let (value, path) = warp::path(measured, simulated, Accumulate::Max)?;
    Ok(Matched {
        value,
        pairs: pairs_of_path(measured, simulated, &path),
    })
}
