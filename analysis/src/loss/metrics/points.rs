//! What the metrics share: curves as points, the pairs a coupling makes
//! and their signed distances, the errors, and `np.interp` as the
//! library computes it.

/// A curve as `[x, y]` points in order along it.
pub type Points = [[f64; 2]];

/// Why two curves cannot be compared.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CurveMetricError {
    #[error("the {curve} curve has {points} point(s); at least 2 are needed")]
    TooFewPoints { curve: &'static str, points: usize },
    #[error("the {curve} curve's point {index} is not finite ({x}, {y})")]
    NotFinite {
        curve: &'static str,
        index: usize,
        x: f64,
        y: f64,
    },
    #[error("the measured curve's {axis} does not vary (every point at {value}): there is no range to normalise by")]
    NoRange { axis: &'static str, value: f64 },
    #[error("the simulated curve's point {index} ({x}, {y}) lies more than 10^12 of the measured curve's range away from it: check the units and columns of both curves")]
    OutOfScale { index: usize, x: f64, y: f64 },
    #[error("MAPE compares on an x grid, not by coupling points: use curve_mape")]
    NotCoupling,
    #[error("{measured} x {simulated} points would need {cells} cells of coupling; thin the curves to at most {MAX_CELLS} (a few thousand points each)")]
    TooLarge {
        measured: usize,
        simulated: usize,
        cells: usize,
    },
}

/// Largest `n x m` a coupling is computed for (2 bits a cell: 32 MB).
pub const MAX_CELLS: usize = 1 << 27;

/// A measured point (or a point on a measured segment) coupled to a
/// simulated one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    /// Where along the measured curve: its arc length up to the point over
    /// the curve's whole length (normalised units), 0 to 1.
    pub along: f64,
    /// The distance between the two points, normalised units; positive
    /// when the simulated point lies left of the measured curve's
    /// direction of travel.
    pub signed_distance: f64,
}

/// A metric's value and its coupling.
#[derive(Clone, Debug, PartialEq)]
pub struct Matched {
    pub value: f64,
    pub pairs: Vec<Pair>,
}

/// Each point's arc length from the start over the curve's whole length,
/// and that length (every fraction 0 for a curve of no length).
pub(super) fn arc_fractions(curve: &Points) -> (Vec<f64>, f64) {
    let mut cumulative = Vec::with_capacity(curve.len());
    let mut total = 0.0;
    cumulative.push(0.0);
    for pair in curve.windows(2) {
        total += distance(pair[0], pair[1]);
        cumulative.push(total);
    }
    if total > 0.0 {
        for value in &mut cumulative {
            *value /= total;
        }
    }
    (cumulative, total)
}

pub(super) fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1])).sqrt()
}

/// `|to - at|`, signed by the side of `direction` (through `at`) that `to`
/// lies on: positive on its left. A point on the line, or no direction,
/// counts as left.
pub(super) fn signed_distance(at: [f64; 2], direction: [f64; 2], to: [f64; 2]) -> f64 {
    let offset = [to[0] - at[0], to[1] - at[1]];
    let side = direction[0] * offset[1] - direction[1] * offset[0];
    let length = distance(at, to);
    if side < 0.0 {
        -length
    } else {
        length
    }
}

/// The direction of travel at point `i` of a curve: from its previous
/// point to its next (one-sided at the ends).
pub(super) fn direction_at(curve: &Points, i: usize) -> [f64; 2] {
    let before = curve[i.saturating_sub(1)];
    let after = curve[(i + 1).min(curve.len() - 1)];
    [after[0] - before[0], after[1] - before[1]]
}

/// The pairs of a point-to-point coupling `(measured index, simulated
/// index)` (DTW's and Fréchet's warping path).
pub(super) fn pairs_of_path(
    measured: &Points,
    simulated: &Points,
    path: &[(usize, usize)],
) -> Vec<Pair> {
    let along = arc_fractions(measured).0;
    path.iter()
        .map(|&(i, j)| Pair {
            along: along[i],
            signed_distance: signed_distance(measured[i], direction_at(measured, i), simulated[j]),
        })
        .collect()
}

/// `np.interp(x, xp, fp)`: linear between the knots, the end values
/// outside them.
pub(super) fn interp(x: f64, xp: &[f64], fp: &[f64]) -> f64 {
    let last = xp.len() - 1;
    if x < xp[0] {
        return fp[0];
    }
    if x >= xp[last] {
        return fp[last];
    }
    lerp(x, xp, fp, segment_at(x, xp))
}

/// `np.interp`'s value inside knot interval `j`, its NaN fallbacks too.
#[inline(always)]
pub(super) fn lerp(x: f64, xp: &[f64], fp: &[f64], j: usize) -> f64 {
    let slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]);
    let value = slope * (x - xp[j]) + fp[j];
    if value.is_nan() {
        let again = slope * (x - xp[j + 1]) + fp[j + 1];
        if again.is_nan() && fp[j] == fp[j + 1] {
            return fp[j];
        }
        return again;
    }
    value
}

/// The knot interval `j` with `xp[j] <= x < xp[j + 1]` (clamped to the
/// first and last interval).
pub(super) fn segment_at(x: f64, xp: &[f64]) -> usize {
    xp.partition_point(|&k| k <= x)
        .saturating_sub(1)
        .min(xp.len() - 2)
}
