//! Partial curve mapping (Witowski and Stander 2012), as
//! `similaritymeasures.pcm` 1.3.0 computes it (`norm_seg_length=False`):
//!
//! 1. Each curve's arc lengths (normalised units), each divided by its
//!    own total: both curves run from 0 to 1.
//! 2. The curve with the longer total length is the reference; the other
//!    is mapped onto it at 200 offsets from 0 to the difference of the two
//!    totals (one offset when they are equal): each reference point at
//!    fraction `s` meets the other curve at fraction `s + offset`,
//!    linearly interpolated, its end point past its end.
//! 3. At each offset, the trapezoid sum over the reference's points of
//!    the pair distances, each segment weighed by the reference's
//!    *cumulative* fraction at its end (the library's definition, kept so
//!    values compare with Jekel et al.; it weighs the end of the curve
//!    more than its start).
//! 4. The smallest sum over the offsets.
//!
//! Not symmetric: which curve is the reference depends on their lengths.

use super::{
    arc_fractions, direction_at, interp, segment_at, signed_distance, Matched, Pair, Points,
};

/// Offsets tried when the curves' lengths differ.
const OFFSETS: usize = 200;

/// The PCM value of two curves (normalised by the measured curve's range).
pub fn value(measured: &Points, simulated: &Points) -> f64 {
    Mapping::new(measured, simulated).best().1
}

/// The value and, at its best offset, each reference point with the point
/// of the other curve it meets.
pub fn matched(measured: &Points, simulated: &Points) -> Matched {
    let mapping = Mapping::new(measured, simulated);
    let (offset, value) = mapping.best();
    let measured_along = arc_fractions(measured).0;
    let pairs = mapping
        .reference_fraction
        .iter()
        .enumerate()
        .map(|(k, &s)| {
            let at = s + offset;
            let mapped = [
                interp(at, &mapping.other_fraction, &mapping.other_x),
                interp(at, &mapping.other_fraction, &mapping.other_y),
            ];
            let reference_point = [mapping.reference_x[k], mapping.reference_y[k]];
            if mapping.reference_is_measured {
                Pair {
                    along: measured_along[k],
                    signed_distance: signed_distance(
                        reference_point,
                        direction_at(measured, k),
                        mapped,
                    ),
                }
            } else {
                // The mapped point lies on the measured curve: its segment
                // gives the direction, its fraction the place.
                let segment = segment_at(at, &mapping.other_fraction);
                Pair {
                    along: measured_along[segment]
                        + (measured_along[segment + 1] - measured_along[segment])
                            * segment_share(at, &mapping.other_fraction, segment),
                    signed_distance: signed_distance(
                        mapped,
                        [
                            measured[segment + 1][0] - measured[segment][0],
                            measured[segment + 1][1] - measured[segment][1],
                        ],
                        reference_point,
                    ),
                }
            }
        })
        .collect();
    Matched { value, pairs }
}

/// The two curves as the library lays them out.
struct Mapping {
    reference_is_measured: bool,
    reference_x: Vec<f64>,
    reference_y: Vec<f64>,
    /// Cumulative arc length over the total, per point.
    reference_fraction: Vec<f64>,
    other_x: Vec<f64>,
    other_y: Vec<f64>,
    other_fraction: Vec<f64>,
    /// The difference of the totals (unnormalised), the largest offset.
    largest_offset: f64,
}

impl Mapping {
    fn new(measured: &Points, simulated: &Points) -> Mapping {
        let (measured_fraction, measured_total) = arc_fractions(measured);
        let (simulated_fraction, simulated_total) = arc_fractions(simulated);
        let columns = |curve: &Points| -> (Vec<f64>, Vec<f64>) {
            (
                curve.iter().map(|p| p[0]).collect(),
                curve.iter().map(|p| p[1]).collect(),
            )
        };
        let (mx, my) = columns(measured);
        let (sx, sy) = columns(simulated);
        if simulated_total > measured_total {
            Mapping {
                reference_is_measured: false,
                reference_x: sx,
                reference_y: sy,
                reference_fraction: simulated_fraction,
                other_x: mx,
                other_y: my,
                other_fraction: measured_fraction,
                largest_offset: simulated_total - measured_total,
            }
        } else {
            Mapping {
                reference_is_measured: true,
                reference_x: mx,
                reference_y: my,
                reference_fraction: measured_fraction,
                other_x: sx,
                other_y: sy,
                other_fraction: simulated_fraction,
                largest_offset: measured_total - simulated_total,
            }
        }
    }

    /// `(offset, sum)` of the smallest sum (the first of equal ones).
    fn best(&self) -> (f64, f64) {
        let offsets = if self.largest_offset == 0.0 {
            vec![0.0]
        } else {
            linspace(0.0, self.largest_offset, OFFSETS)
        };
        let n = self.reference_fraction.len();
        let mut distances = vec![0.0; n];
        let mut best = (0.0, f64::INFINITY);
        for offset in offsets {
            for (k, d) in distances.iter_mut().enumerate() {
                let at = self.reference_fraction[k] + offset;
                let x = interp(at, &self.other_fraction, &self.other_x);
                let y = interp(at, &self.other_fraction, &self.other_y);
                let (dy, dx) = (self.reference_y[k] - y, self.reference_x[k] - x);
                *d = (dy * dy + dx * dx).sqrt();
            }
            let sum: f64 = (1..n)
                .map(|k| 0.5 * (distances[k - 1] + distances[k]) * self.reference_fraction[k])
                .sum();
            // np.min: NaN wins; a NaN sum only from NaN input, refused earlier.
            if sum < best.1 {
                best = (offset, sum);
            }
        }
        best
    }
}

/// `np.linspace(start, stop, count)`: `start + i * step`, the last exactly
/// `stop`.
fn linspace(start: f64, stop: f64, count: usize) -> Vec<f64> {
    let step = (stop - start) / (count - 1) as f64;
    let mut values: Vec<f64> = (0..count).map(|i| i as f64 * step + start).collect();
    values[count - 1] = stop;
    values
}

/// How far into interval `j` the fraction `x` lies, 0 to 1.
fn segment_share(x: f64, xp: &[f64], j: usize) -> f64 {
    let width = xp[j + 1] - xp[j];
    if width > 0.0 {
        ((x - xp[j]) / width).clamp(0.0, 1.0)
    } else {
        0.0
    }
}
