//! Partial curve mapping (Witowski and Stander 2012), as
//! `similaritymeasures.pcm` 1.5.0 computes it (`norm_seg_length=False`),
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
    arc_fractions, direction_at, distance, lerp, signed_distance, Matched, Pair, Points,
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
    // `np.interp` at each measured fraction plus the offset, which only
    // grows with k: its segment is found by walking on, not by a search.
    let xp = &mapping.other_fraction;
    let last = xp.len() - 1;
    let mut segment = 0;
    let pairs = mapping
        .reference_fraction
        .iter()
        .enumerate()
        .map(|(k, &s)| {
            let at = s + offset;
            let mapped = if at < xp[0] {
                [mapping.other_x[0], mapping.other_y[0]]
            } else if at >= xp[last] {
                [mapping.other_x[last], mapping.other_y[last]]
            } else {
                while segment + 1 < last && xp[segment + 1] <= at {
                    segment += 1;
                }
                [
                    lerp(at, xp, &mapping.other_x, segment),
                    lerp(at, xp, &mapping.other_y, segment),
                ]
            };
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
    /// Each point's distance's weight in the trapezoid sum: half the
    /// fraction at the end of each of its one or two segments.
    point_weights: Vec<f64>,
    other_x: Vec<f64>,
    other_y: Vec<f64>,
    other_fraction: Vec<f64>,
    /// Per segment of the other curve, what the walk and the
    /// interpolation read, side by side: its start and `np.interp`'s
    /// slopes of x and y over the fraction (made once: the same bits as
    /// made per point).
    segments: Vec<Segment>,
    /// Every slope finite, so that no interpolated point is NaN and the
    /// sum needs no check for `np.interp`'s fallbacks.
    finite_slopes: bool,
    /// `before_start[k]`: the weighted distances of measured points
    /// `0..k` to the other curve's start; `past_end[k]`: those of points
    /// `k..` to its end.
    before_start: Vec<f64>,
    past_end: Vec<f64>,
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
        let n = measured_fraction.len();
        let point_weights: Vec<f64> = (0..n)
            .map(|k| {
                let before = if k >= 1 { measured_fraction[k] } else { 0.0 };
                let after = if k + 1 < n {
                    measured_fraction[k + 1]
                } else {
                    0.0
                };
                0.5 * (before + after)
            })
            .collect();
        let segments: Vec<Segment> = (0..simulated_fraction.len() - 1)
            .map(|j| {
                let width = simulated_fraction[j + 1] - simulated_fraction[j];
                Segment {
                    fraction: simulated_fraction[j],
                    x: sx[j],
                    y: sy[j],
                    slope_x: (sx[j + 1] - sx[j]) / width,
                    slope_y: (sy[j + 1] - sy[j]) / width,
                }
            })
            .collect();
        let weighted_distance_to =
            |point: [f64; 2], k: usize| point_weights[k] * distance([mx[k], my[k]], point);
        let start = [sx[0], sy[0]];
        let end = [sx[sx.len() - 1], sy[sy.len() - 1]];
        let mut before_start = vec![0.0; n + 1];
        for k in 0..n {
            before_start[k + 1] = before_start[k] + weighted_distance_to(start, k);
        }
        let mut past_end = vec![0.0; n + 1];
        for k in (0..n).rev() {
            past_end[k] = past_end[k + 1] + weighted_distance_to(end, k);
        }
        Mapping {
            before_start,
            past_end,
            reference_x: mx,
            reference_y: my,
            reference_fraction: measured_fraction,
            point_weights,
            other_x: sx,
            other_y: sy,
            other_fraction: simulated_fraction,
            finite_slopes: segments
                .iter()
                .all(|s| s.slope_x.is_finite() && s.slope_y.is_finite()),
            segments,
            other_total: simulated_total,
            largest_offset: measured_total - simulated_total,
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
    /// bound (Piyavskii's rule). The minimum found is the one of summing
    /// every offset, as the library does (to rounding: the bound carries a
    /// relative slack of 1e-9).
    ///
    /// Every sum is summed whole. Stopping a sum once it passed the best
    /// looks cheaper but is not: a stopped sum is only known to exceed the
    /// best, a bound that rules out none of its neighbours, and on the
    /// benchmark's pulls it took 80 sums, most of them nearly whole, where
    /// whole sums take about 28 (1.7 times faster, `cargo bench --bench
    /// curve_metrics`).
    fn best(&self) -> (f64, f64) {
        let offsets = if self.largest_offset == 0.0 {
            vec![0.0]
        } else {
            linspace(0.0, self.largest_offset, OFFSETS)
        };
        let weights: f64 = self.point_weights.iter().sum();
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
            let sum = if self.finite_slopes {
                self.sum_at::<false>(offsets[next])
            } else {
                self.sum_at::<true>(offsets[next])
            };
            if sum < best.1 || (sum == best.1 && next < best_index) {
                best = (offsets[next], sum);
                best_index = next;
            }
            for (i, bound) in lower.iter_mut().enumerate() {
                *bound = bound.max(sum - lipschitz * (offsets[i] - offsets[next]).abs());
            }
        }
        best
    }

    /// The trapezoid sum at `offset`. `FALLBACKS`: check each
    /// interpolated point for `np.interp`'s NaN fallbacks (only a curve
    /// with a segment of nearly no length needs it; the check costs a
    /// sixth of the time).
    ///
    /// The measured points whose mapped point lies past either end of the
    /// other curve meet that end whatever the offset, so their part of the
    /// sum is read from sums made once; only the points between walk along
    /// the other curve, reading one `Segment` each.
    fn sum_at<const FALLBACKS: bool>(&self, offset: f64) -> f64 {
        let xp = &self.other_fraction;
        let last = xp.len() - 1;
        let fraction = &self.reference_fraction;
        // The same comparisons as np.interp's, on the same sums: the
        // points before the other curve's start, on it, past its end.
        let on_from = fraction.partition_point(|&s| s + offset < xp[0]);
        let past_from = fraction
            .partition_point(|&s| s + offset < xp[last])
            .max(on_from);
        let mut sum = self.before_start[on_from] + self.past_end[past_from];
        let mut segment = self.segments.len() - 1;
        let between = on_from..past_from;
        let points = fraction[between.clone()]
            .iter()
            .zip(&self.reference_x[between.clone()])
            .zip(&self.reference_y[between.clone()])
            .zip(&self.point_weights[between])
            .rev();
        for (((&s, measured_x), measured_y), weight) in points {
            // At `s + offset`, which only falls as k does: the segment is
            // found by walking back, not by a search.
            let at = s + offset;
            while self.segments[segment].fraction > at {
                segment -= 1;
            }
            let knot = self.segments[segment];
            let along = at - knot.fraction;
            let (mut x, mut y) = (knot.slope_x * along + knot.x, knot.slope_y * along + knot.y);
            if FALLBACKS && (x.is_nan() || y.is_nan()) {
                x = lerp(at, xp, &self.other_x, segment);
                y = lerp(at, xp, &self.other_y, segment);
            }
            let (dx, dy) = (measured_x - x, measured_y - y);
            sum += weight * (dx * dx + dy * dy).sqrt();
        }
        sum
    }
}

/// A segment of the other curve: its start, and `np.interp`'s slopes.
#[derive(Clone, Copy, Debug)]
struct Segment {
    fraction: f64,
    x: f64,
    y: f64,
    slope_x: f64,
    slope_y: f64,
}

/// `np.linspace(start, stop, count)`: `start + i * step`, the last exactly
/// `stop`.
fn linspace(start: f64, stop: f64, count: usize) -> Vec<f64> {
    let step = (stop - start) / (count - 1) as f64;
    let mut values: Vec<f64> = (0..count).map(|i| i as f64 * step + start).collect();
    values[count - 1] = stop;
    values
}
