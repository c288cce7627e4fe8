//! Curve-matching metrics for curves that loop, drop or end early: partial
//! curve mapping ([`pcm`]), the discrete Fréchet distance ([`frechet`]),
//! dynamic time warping ([`dtw`]) and the area between the curves
//! ([`area`]), beside the MAPE of [`super::curve`].
//!
//! Each is computed as the `similaritymeasures` Python library (1.3.0;
//! Jekel et al. 2019, who compared them on such curves) computes it, to
//! rounding (`tests/curve_metrics.rs` checks 1,000 random pairs against it),
//! after one step the library leaves to its user:
//!
//! - **Both axes normalised by the measured curve's range**: `x' = (x -
//!   min x) / (max x - min x)` with the measured curve's min and max, the
//!   same for `y`, applied to both curves ([`Normalisation`]). No value
//!   then depends on units, and a millimetre of displacement weighs as
//!   much as a kilonewton of force would only by accident. (The library's
//!   PCM normalises so itself; its other metrics take the curves as given.)
//!
//! Neither curve needs to be a function of `x`: a loop (x goes back), a
//! force that drops to zero, either curve ending before the other, and
//! curves of different point counts are all compared point to point along
//! the curves, not on an x grid.
//!
//! Each metric also couples points of the two curves ([`Pair`]): the
//! warping path of DTW and Fréchet, the mapped points of PCM at its best
//! offset, the quadrilaterals of the area. A pair's **signed distance** is
//! the distance between its points (normalised units), positive when the
//! simulated point lies to the left of the measured curve's direction of
//! travel (above a curve that rises to the right), negative to its right.
//! [`residuals_by_part`] averages them over equal parts of the measured
//! curve's length: a vector of fixed length, whatever the point counts, for
//! the Gauss-Newton steps, the identifiability analysis and the posterior.

pub mod area;
pub mod dtw;
pub mod frechet;
pub mod pcm;
mod warp;

use std::fmt;
use std::str::FromStr;

/// A curve as `[x, y]` points in order along it.
pub type Points = [[f64; 2]];

/// How a simulated curve is scored against a measured one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CurveMetric {
    /// Mean absolute percentage error on a common x grid (the published
    /// tensile loss, [`super::curve`]), %.
    #[default]
    Mape,
    /// Partial curve mapping, normalised units x arc length.
    Pcm,
    /// Discrete Fréchet distance, normalised units.
    Frechet,
    /// Dynamic time warping: the sum of the coupled points' distances,
    /// normalised units.
    Dtw,
    /// Area between the curves, normalised units squared.
    Area,
}

impl CurveMetric {
    pub const ALL: [CurveMetric; 5] = [
        CurveMetric::Mape,
        CurveMetric::Pcm,
        CurveMetric::Frechet,
        CurveMetric::Dtw,
        CurveMetric::Area,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            CurveMetric::Mape => "mape",
            CurveMetric::Pcm => "pcm",
            CurveMetric::Frechet => "frechet",
            CurveMetric::Dtw => "dtw",
            CurveMetric::Area => "area",
        }
    }
}

impl fmt::Display for CurveMetric {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for CurveMetric {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        CurveMetric::ALL
            .into_iter()
            .find(|m| m.as_str() == text)
            .ok_or_else(|| {
                format!(
                    "no curve metric {text:?}: expected one of {}",
                    CurveMetric::ALL.map(CurveMetric::as_str).join(", ")
                )
            })
    }
}

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

/// The measured curve's range on both axes: what both curves are divided
/// by before any metric.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Normalisation {
    pub x_min: f64,
    pub x_range: f64,
    pub y_min: f64,
    pub y_range: f64,
}

impl Normalisation {
    /// From the measured curve (checked: at least 2 finite points, a
    /// range on both axes).
    pub fn of_measured(measured: &Points) -> Result<Normalisation, CurveMetricError> {
        check(measured, "measured")?;
        let (mut x_min, mut x_max) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut y_min, mut y_max) = (f64::INFINITY, f64::NEG_INFINITY);
        for &[x, y] in measured {
            x_min = x_min.min(x);
            x_max = x_max.max(x);
            y_min = y_min.min(y);
            y_max = y_max.max(y);
        }
        for (axis, min, max) in [("x", x_min, x_max), ("y", y_min, y_max)] {
            if !(max - min > 0.0 && (max - min).is_finite()) {
                return Err(CurveMetricError::NoRange { axis, value: min });
            }
        }
        Ok(Normalisation {
            x_min,
            x_range: x_max - x_min,
            y_min,
            y_range: y_max - y_min,
        })
    }

    pub fn apply(&self, curve: &Points) -> Vec<[f64; 2]> {
        curve
            .iter()
            .map(|&[x, y]| {
                [
                    (x - self.x_min) / self.x_range,
                    (y - self.y_min) / self.y_range,
                ]
            })
            .collect()
    }
}

/// At least 2 points, all finite.
fn check(curve: &Points, name: &'static str) -> Result<(), CurveMetricError> {
    if curve.len() < 2 {
        return Err(CurveMetricError::TooFewPoints {
            curve: name,
            points: curve.len(),
        });
    }
    match curve
        .iter()
        .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        Some(index) => Err(CurveMetricError::NotFinite {
            curve: name,
            index,
            x: curve[index][0],
            y: curve[index][1],
        }),
        None => Ok(()),
    }
}

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

/// `simulated` scored against `measured` (both in their own units) by one
/// of the coupling metrics; MAPE is not one ([`super::curve::curve_mape`]
/// computes it on its x grid).
pub fn matched(
    metric: CurveMetric,
    measured: &Points,
    simulated: &Points,
) -> Result<Matched, CurveMetricError> {
    let scale = Normalisation::of_measured(measured)?;
    check(simulated, "simulated")?;
    let measured = scale.apply(measured);
    let simulated = scale.apply(simulated);
    match metric {
        CurveMetric::Pcm => Ok(pcm::matched(&measured, &simulated)),
        CurveMetric::Frechet => frechet::matched(&measured, &simulated),
        CurveMetric::Dtw => dtw::matched(&measured, &simulated),
        CurveMetric::Mape => Err(CurveMetricError::NotCoupling),
        CurveMetric::Area => Ok(area::matched(&measured, &simulated)),
    }
}

/// The pairs' signed distances averaged over `parts` equal parts of the
/// measured curve's length (by [`Pair::along`]); a part no pair falls in
/// takes its nearest pair's distance, so the vector always has `parts`
/// entries and moves continuously as the simulated curve does.
pub fn residuals_by_part(pairs: &[Pair], parts: usize) -> Vec<f64> {
    let parts = parts.max(1);
    let mut sums = vec![(0.0, 0usize); parts];
    for pair in pairs {
        let part = ((pair.along.clamp(0.0, 1.0) * parts as f64) as usize).min(parts - 1);
        sums[part].0 += pair.signed_distance;
        sums[part].1 += 1;
    }
    (0..parts)
        .map(|part| match sums[part] {
            (sum, count) if count > 0 => sum / count as f64,
            _ => {
                let centre = (part as f64 + 0.5) / parts as f64;
                pairs
                    .iter()
                    .min_by(|a, b| {
                        (a.along - centre)
                            .abs()
                            .total_cmp(&(b.along - centre).abs())
                    })
                    .map_or(0.0, |p| p.signed_distance)
            }
        })
        .collect()
}

/// Each point's arc length from the start over the curve's whole length,
/// and that length (every fraction 0 for a curve of no length).
fn arc_fractions(curve: &Points) -> (Vec<f64>, f64) {
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

fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1])).sqrt()
}

/// `|to - at|`, signed by the side of `direction` (through `at`) that `to`
/// lies on: positive on its left. A point on the line, or no direction,
/// counts as left.
fn signed_distance(at: [f64; 2], direction: [f64; 2], to: [f64; 2]) -> f64 {
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
fn direction_at(curve: &Points, i: usize) -> [f64; 2] {
    let before = curve[i.saturating_sub(1)];
    let after = curve[(i + 1).min(curve.len() - 1)];
    [after[0] - before[0], after[1] - before[1]]
}

/// The pairs of a point-to-point coupling `(measured index, simulated
/// index)` (DTW's and Fréchet's warping path).
fn pairs_of_path(measured: &Points, simulated: &Points, path: &[(usize, usize)]) -> Vec<Pair> {
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
pub(crate) fn interp(x: f64, xp: &[f64], fp: &[f64]) -> f64 {
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
pub(crate) fn lerp(x: f64, xp: &[f64], fp: &[f64], j: usize) -> f64 {
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
pub(crate) fn segment_at(x: f64, xp: &[f64]) -> usize {
    xp.partition_point(|&k| k <= x)
        .saturating_sub(1)
        .min(xp.len() - 2)
}
