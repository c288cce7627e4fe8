//! Curve-matching metrics for curves that loop, drop or end early: partial
//! curve mapping ([`pcm`]), the discrete Fréchet distance ([`frechet`]),
//! dynamic time warping ([`dtw`]) and the area between the curves
//! ([`area`]), beside the MAPE of [`super::curve`].
//!
//! Each is computed as the `similaritymeasures` Python library (1.5.0;
//! Jekel et al. 2019, who compared them on such curves) computes it, to
//! rounding (`tests/curve_metrics.rs` checks 1,000 random pairs against it),
//! but for PCM's choice of reference ([`pcm`]: the measured curve always,
//! so that the value is continuous where a fracture makes the simulated
//! curve the longer), and after one step the library leaves to its user:
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
mod points;
mod warp;

use std::fmt;
use std::str::FromStr;

use points::arc_fractions;
pub use points::{CurveMetricError, Matched, Pair, Points, MAX_CELLS};

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

    /// The metric whose coupling gives this one's signed residuals in a
    /// study (the local steps, the identifiability analysis and the
    /// posterior read them): DTW's for PCM and Fréchet, each other metric's
    /// own.
    ///
    /// Fréchet's coupling is held only at its largest distance, so its other
    /// pairs go anywhere that distance allows; PCM's maps points by the
    /// fraction of arc length, which a noisy measured curve's zig-zag
    /// stretches. Posteriors read from either were too narrow (90 %
    /// intervals held the truth in 68 to 88 % of 400 replicates, `cargo
    /// bench --bench curve_coverage`), and from DTW's coupling they hold it
    /// as often as DTW's own (96 %). The area keeps its own: on the tune
    /// set of `cargo bench --bench curve_study_generalisation` its search
    /// reached the truth's value within 30 runs in 14 of 16 tests with its
    /// own coupling, 7 with DTW's.
    pub fn residual_coupling(self) -> CurveMetric {
        match self {
            CurveMetric::Pcm | CurveMetric::Frechet => CurveMetric::Dtw,
            other => other,
        }
    }

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

/// How far from the measured curve, in its ranges, a simulated point may
/// lie: farther, the metrics' sums of squares would overflow, and no fit
/// is that far off.
const MAX_NORMALISED: f64 = 1e12;

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
    let normalised = scale.apply(simulated);
    if let Some(index) = normalised
        .iter()
        .position(|p| !(p[0].abs() <= MAX_NORMALISED && p[1].abs() <= MAX_NORMALISED))
    {
        return Err(CurveMetricError::OutOfScale {
            index,
            x: simulated[index][0],
            y: simulated[index][1],
        });
    }
    let simulated = normalised;
    match metric {
        CurveMetric::Pcm => Ok(pcm::matched(&measured, &simulated)),
        CurveMetric::Frechet => frechet::matched(&measured, &simulated),
        CurveMetric::Dtw => dtw::matched(&measured, &simulated),
        CurveMetric::Mape => Err(CurveMetricError::NotCoupling),
        CurveMetric::Area => Ok(area::matched(&measured, &simulated)),
    }
}

/// A curve kept as `(x, y)` pairs (as a study and MAPE keep them) as the
/// metrics take it.
pub fn points_of(curve: &[(f64, f64)]) -> Vec<[f64; 2]> {
    curve.iter().map(|&(x, y)| [x, y]).collect()
}

/// Every metric of `simulated` against `measured`, in
/// [`CurveMetric::ALL`]'s order: MAPE by [`super::curve::curve_mape`]
/// (default options), the others by [`matched`]; each an error where the
/// curves do not allow it (MAPE of a loop, a measured curve with no range).
pub fn every_metric(
    measured: &[(f64, f64)],
    simulated: &[(f64, f64)],
) -> Vec<(CurveMetric, Result<f64, String>)> {
    CurveMetric::ALL
        .into_iter()
        .map(|metric| (metric, score(metric, measured, simulated)))
        .collect()
}

/// `simulated` scored against `measured` by `metric`: MAPE by
/// [`super::curve::curve_mape`] (default options), the others by
/// [`matched`]; the error says why the curves do not allow it.
pub fn score(
    metric: CurveMetric,
    measured: &[(f64, f64)],
    simulated: &[(f64, f64)],
) -> Result<f64, String> {
    match metric {
        CurveMetric::Mape => super::curve::curve_mape(
            measured,
            simulated,
            super::curve::CurveMapeOptions::default(),
        )
        .map(|m| m.mape_percent)
        .map_err(|e| e.to_string()),
        _ => matched(metric, &points_of(measured), &points_of(simulated))
            .map(|m| m.value)
            .map_err(|e| e.to_string()),
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

/// How precisely the measured curve itself gives each of the `parts` of
/// [`residuals_by_part`], in % of its range (as a study scales the parts):
/// its noise over the square root of its points in the part.
///
/// The noise is estimated once from the second differences of the
/// normalised coordinates (white noise of sd s gives them a variance of
/// 6 s^2; a smooth curve's are nearly constant within a part, so each
/// part's mean is taken out), pooled over both axes and the parts, and
/// taken to be the same across the curve as along it. A noiseless
/// (simulated) measured curve gets a floor of 1e-9.
pub fn measured_scatter_by_part(
    measured: &Points,
    parts: usize,
) -> Result<Vec<f64>, CurveMetricError> {
    let scale = Normalisation::of_measured(measured)?;
    let curve = scale.apply(measured);
    let parts = parts.max(1);
    let along = arc_fractions(&curve).0;
    let part_of = |f: f64| ((f.clamp(0.0, 1.0) * parts as f64) as usize).min(parts - 1);
    let mut counts = vec![0usize; parts];
    for &f in &along {
        counts[part_of(f)] += 1;
    }
    let (mut squares, mut degrees) = (0.0, 0usize);
    for axis in 0..2 {
        let mut by_part: Vec<Vec<f64>> = vec![Vec::new(); parts];
        for (k, w) in curve.windows(3).enumerate() {
            by_part[part_of(along[k + 1])].push(w[2][axis] - 2.0 * w[1][axis] + w[0][axis]);
        }
        for second in by_part.iter().filter(|d| d.len() >= 2) {
            let mean = second.iter().sum::<f64>() / second.len() as f64;
            squares += second.iter().map(|d| (d - mean).powi(2)).sum::<f64>();
            degrees += second.len() - 1;
        }
    }
    let noise = if degrees > 0 {
        (squares / degrees as f64 / 6.0).sqrt()
    } else {
        // Parts of fewer than three points each: the curve read whole.
        let axis = |a: usize| curve.iter().map(|p| p[a]).collect::<Vec<f64>>();
        super::curve::short_curve_noise(&[&axis(0), &axis(1)]).unwrap_or(0.0)
    }
    .max(1e-9);
    Ok(counts
        .into_iter()
        .map(|n| 100.0 * noise / (n.max(1) as f64).sqrt())
        .collect())
}
