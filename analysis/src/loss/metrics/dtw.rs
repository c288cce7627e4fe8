//! Dynamic time warping: the smallest sum of point-pair distances over
//! the monotone couplings of the two curves' points that start at both
//! first points and end at both last ones (Senin 2008; `similaritymeasures.
//! dtw` with the Euclidean distance). Every point is coupled at least once,
//! so a curve that ends early is charged for the distance of the other's
//! tail to its last point. The value grows with the point counts.

use super::points::{pairs_of_path, CurveMetricError, Matched, Points};
use super::warp::{self, Accumulate};

/// The DTW distance of two curves (as given: normalise first), in O(n m)
/// time and O(n + m) memory.
pub fn distance(measured: &Points, simulated: &Points) -> f64 {
    warp::value(measured, simulated, Accumulate::Sum)
}

/// The distance and its warping path's pairs.
pub fn matched(measured: &Points, simulated: &Points) -> Result<Matched, CurveMetricError> {
    let (value, path) = warp::path(measured, simulated, Accumulate::Sum)?;
    Ok(Matched {
        value,
        pairs: pairs_of_path(measured, simulated, &path),
    })
}
