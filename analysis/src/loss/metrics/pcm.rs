//! Partial curve mapping (Witowski and Stander 2012), as
//! `similaritymeasures.pcm` 1.3.0 computes it (`norm_seg_length=False`),
//! but for which curve is mapped onto which:
//!
//! 1. Each curve's arc lengths (normalised units), each divided by its
//!    own total: both curves run from 0 to 1.
//! 2. The simulated curve is mapped onto the measured one at 200 offsets
//!    from 0 to the measured total less the simulated total (negative
//!    when the simulated curve is the longer; one offset when they are
//!    equal): each measured point at fraction `s` meets the simulated
//!    curve at fraction `s + offset`, linearly interpolated, its end
//!    points beyond its ends.
//! 3. At each offset, the trapezoid sum over the measured points of the
//!    pair distances, each segment weighed by the measured curve's
//!    *cumulative* fraction at its end (the library's definition, kept so
//!    values compare with Jekel et al.; it weighs the end of the curve
//!    more than its start).
//! 4. The smallest sum over the offsets.
//!
//! The library maps the shorter curve onto the longer instead; where the
//! measured curve is the longer the two are the same (`tests/curve_metrics.rs`
//! checks both). Where the lengths cross, the library's value jumps: a
//! simulation that fractures adds the length of its drop, and a search
//! that moves fracture across the test's would see a step in its loss
//! (`tests/curve_fracture.rs`). With the measured curve always the
//! reference, the value moves continuously.

use super::points::{
    arc_fractions, direction_at, interp, lerp, signed_distance, Matched, Pair, Points,
};

/// Offsets tried when the curves' lengths differ.
const OFFSETS: usize = 200;

/// The PCM value of two curves (normalised by the measured curve's range).
pub fn value(measured: &Points, simulated: &Points) -> f64 {
    Mapping::new(measured, simulated).best().1
}

/// The value and, at its best offset, each measured point with the point
/// of the simulated curve it meets.
pub fn matched(measured: &Points, simulated: &Points) -> Matched {
    let mapping = Mapping::new(measured, simulated);
    let (offset, value) = mapping.best();
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
            Pair {
                along: s,
                signed_distance: signed_distance(
                    [mapping.reference_x[k], mapping.reference_y[k]],
                    direction_at(measured, k),
                    mapped,
                ),
            }
        })
        .collect();
    Matched { value, pairs }
}

/// The measured curve (the reference) and the simulated one mapped onto it.
struct Mapping {
    reference_x: Vec<f64>,
    reference_y: Vec<f64>,
    /// Cumulative arc length over the total, per point.
    reference_fraction: Vec<f64>,
    other_x: Vec<f64>,
    other_y: Vec<f64>,
    other_fraction: Vec<f64>,
    /// Per segment of the other curve, `np.interp`'s slopes of x and y
    /// over the fraction (made once: the same bits as made per point).
    other_slopes: Vec<[f64; 2]>,
    /// The other curve's length (normalised units).
    other_total: f64,
    /// The measured total less the simulated (unnormalised): the offset
    /// farthest from 0.
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
        let mapping = Mapping {
            reference_x: mx,
            reference_y: my,
            reference_fraction: measured_fraction,
            other_x: sx,
            other_y: sy,
            other_fraction: simulated_fraction,
            other_total: simulated_total,
            largest_offset: measured_total - simulated_total,
            other_slopes: Vec::new(),
        };
        let fraction = &mapping.other_fraction;
        let other_slopes = (0..fraction.len() - 1)
            .map(|j| {
                let width = fraction[j + 1] - fraction[j];
                [
                    (mapping.other_x[j + 1] - mapping.other_x[j]) / width,
                    (mapping.other_y[j + 1] - mapping.other_y[j]) / width,
                ]
            })
            .collect();
        Mapping {
            other_slopes,
            ..mapping
        }
    }

    /// `(offset, sum)` of the smallest sum over the offsets.
    ///
    /// Not every offset is summed: as the offset moves by `h`, each
    /// mapped point moves along the other curve by at most `h` times that
    /// curve's length, so a sum changes by at most `h` times that length
    /// times the sum of the weights (a Lipschitz constant). An offset whose
    /// bound from the sums already known exceeds the best sum cannot be
    /// the minimum and is skipped; the next summed is the one of lowest
    /// bound (Piyavskii's rule), and a sum stops as soon as it exceeds the
    /// best. The minimum found is the one of summing every offset, as the
    /// library does (to rounding: the bound carries a relative slack of
    /// 1e-9).
    fn best(&self) -> (f64, f64) {
        let offsets = if self.largest_offset == 0.0 {
            vec![0.0]
        } else {
            linspace(0.0, self.largest_offset, OFFSETS)
        };
        let weights: f64 = self.reference_fraction.iter().skip(1).sum();
        let lipschitz = self.other_total * weights * (1.0 + 1e-9);
        let mut lower = vec![f64::NEG_INFINITY; offsets.len()];
        let mut summed = vec![false; offsets.len()];
        let mut best = (0.0, f64::INFINITY);
        let mut best_index = usize::MAX;
        // The unsummed offset of lowest bound (the first of equal ones),
        // while it may still beat the best.
        while let Some(next) = (0..offsets.len())
            .filter(|&i| !summed[i])
            .min_by(|&a, &b| lower[a].total_cmp(&lower[b]))
            .filter(|&i| lower[i] <= best.1)
        {
            summed[next] = true;
            let (sum, complete) = self.sum_at(offsets[next], best.1);
            if complete && (sum < best.1 || (sum == best.1 && next < best_index)) {
                best = (offsets[next], sum);
                best_index = next;
            }
            // An incomplete sum is still a lower bound of the whole.
            for (i, bound) in lower.iter_mut().enumerate() {
                *bound = bound.max(sum - lipschitz * (offsets[i] - offsets[next]).abs());
            }
        }
        best
    }

    /// The trapezoid sum at `offset`, and whether it is complete: it stops
    /// once past `stop_above` (its terms are never negative). Summed from
    /// the end, where the weights are largest, so that a sum that will
    /// exceed the best does so within its first terms.
    fn sum_at(&self, offset: f64, stop_above: f64) -> (f64, bool) {
        let xp = &self.other_fraction;
        let last = xp.len() - 1;
        let mut segment = last - 1;
        let mut next_distance = 0.0;
        let mut sum = 0.0;
        for (k, &fraction) in self.reference_fraction.iter().enumerate().rev() {
            // `np.interp` at `fraction + offset`, which only falls as k
            // does: the segment is found by walking back, not by a search.
            let at = fraction + offset;
            let (x, y) = if at < xp[0] {
                (self.other_x[0], self.other_y[0])
            } else if at >= xp[last] {
                (self.other_x[last], self.other_y[last])
            } else {
                while xp[segment] > at {
                    segment -= 1;
                }
                let [slope_x, slope_y] = self.other_slopes[segment];
                let along = at - xp[segment];
                let (x, y) = (
                    slope_x * along + self.other_x[segment],
                    slope_y * along + self.other_y[segment],
                );
                if x.is_nan() || y.is_nan() {
                    // A segment of (nearly) no length: np.interp's fallbacks.
                    (
                        lerp(at, xp, &self.other_x, segment),
                        lerp(at, xp, &self.other_y, segment),
                    )
                } else {
                    (x, y)
                }
            };
            let (dy, dx) = (self.reference_y[k] - y, self.reference_x[k] - x);
            let distance = (dy * dy + dx * dx).sqrt();
            if k + 1 < self.reference_fraction.len() {
                sum += 0.5 * (distance + next_distance) * self.reference_fraction[k + 1];
                if sum > stop_above {
                    return (sum, false);
                }
            }
            next_distance = distance;
        }
        (sum, true)
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
