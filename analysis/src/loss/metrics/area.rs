//! The area between the curves (Jekel et al. 2018), as
//! `similaritymeasures.area_between_two_curves` 1.5.0 computes it:
//!
//! 1. The curve with fewer points gets points until both have as many:
//!    each at the middle (in x) of its currently longest segment, its y
//!    interpolated linearly in x along that segment.
//! 2. Point `i - 1` and `i` of both curves make a quadrilateral (in the
//!    order measured `i - 1`, measured `i`, simulated `i`, simulated
//!    `i - 1`).
//! 3. Where the curves cross between two points that quadrilateral
//!    crosses itself; it is re-ordered until it is simple, as the paper
//!    and the library's `makeQuad` do: the first two vertices swapped, else
//!    the second and third ([`quadrilateral_area`]). Its area by the
//!    shoelace formula.
//! 4. The sum of the quadrilaterals' areas.
//!
//! (Before 1.5.0 the library's test `is_simple_quad(...) is False` was
//! never true of the numpy bool it got, so step 3 never ran and a crossing
//! quadrilateral counted the difference of its two lobes; acq followed
//! that until it was fixed.)
//!
//! A quadrilateral's pair is its measured side's middle, at the
//! quadrilateral's *signed* area (shoelace, in the order measured `i - 1`,
//! measured `i`, simulated `i`, simulated `i - 1`: positive when the
//! simulated side lies left of the measured direction of travel) over its
//! two sides' mean length: the mean gap there. The residuals keep the
//! signed lobes rather than the re-ordered area: signed, a pair passes
//! through zero where the curves cross, continuously as the parameters
//! move, where the re-ordered area jumps when the crossing passes a point
//! (a derivative the Gauss-Newton steps and the posterior would follow into
//! a kink). The value reported is the published one.

use super::points::{arc_fractions, direction_at, distance, interp, Matched, Pair, Points};

/// The area between two curves (normalised by the measured curve's range).
pub fn value(measured: &Points, simulated: &Points) -> f64 {
    let (long, short, _) = equal_counts(measured, simulated);
    (1..long.len())
        .map(|i| quadrilateral_area([long[i - 1], long[i], short[i], short[i - 1]]))
        .sum()
}

/// The area and each quadrilateral's pair.
pub fn matched(measured: &Points, simulated: &Points) -> Matched {
    let (long, short, short_is_measured) = equal_counts(measured, simulated);
    let (measured_side, simulated_side) = if short_is_measured {
        (&short, &long)
    } else {
        (&long, &short)
    };
    let along = arc_fractions(measured_side).0;
    let mut value = 0.0;
    let pairs = (1..long.len())
        .map(|i| {
            value += quadrilateral_area([long[i - 1], long[i], short[i], short[i - 1]]);
            let (m0, m1) = (measured_side[i - 1], measured_side[i]);
            let (s0, s1) = (simulated_side[i - 1], simulated_side[i]);
            let signed = signed_area([m0, m1, s1, s0]);
            let sides = 0.5 * (distance(m0, m1) + distance(s0, s1));
            let mut gap = if sides > 0.0 { signed / sides } else { 0.0 };
            // A measured side of no length has no direction of its own:
            // the side of the curve's direction there decides.
            if distance(m0, m1) == 0.0 {
                let direction = direction_at(measured_side, i);
                let middle = [0.5 * (s0[0] + s1[0]), 0.5 * (s0[1] + s1[1])];
                let left = direction[0] * (middle[1] - m0[1]) - direction[1] * (middle[0] - m0[0]);
                gap = gap.abs().copysign(if left < 0.0 { -1.0 } else { 1.0 });
            }
            Pair {
                along: 0.5 * (along[i - 1] + along[i]),
                signed_distance: gap,
            }
        })
        .collect();
    Matched { value, pairs }
}

/// The curve with more points (the measured one when they have as many)
/// and the other with points inserted until it has as many; whether the
/// other is the measured one.
fn equal_counts(measured: &Points, simulated: &Points) -> (Vec<[f64; 2]>, Vec<[f64; 2]>, bool) {
    let (long, mut short, short_is_measured) = if measured.len() < simulated.len() {
        (simulated.to_vec(), measured.to_vec(), true)
    } else {
        (measured.to_vec(), simulated.to_vec(), false)
    };
    let mut arcs: Vec<f64> = short.windows(2).map(|w| distance(w[0], w[1])).collect();
    while short.len() < long.len() {
        // np.argmax: the first of the longest.
        let longest = arcs
            .iter()
            .enumerate()
            .fold(0, |best, (k, &arc)| if arc > arcs[best] { k } else { best });
        let (start, end) = (short[longest], short[longest + 1]);
        let (a, b) = (start[0], end[0]);
        let new_x = (b + a) / 2.0;
        let new_y = if a < b {
            interp(new_x, &[a, b], &[start[1], end[1]])
        } else {
            interp(new_x, &[b, a], &[end[1], start[1]])
        };
        short.insert(longest + 1, [new_x, new_y]);
        arcs[longest] = distance(start, [new_x, new_y]);
        arcs.insert(longest + 1, distance([new_x, new_y], end));
    }
    (long, short, short_is_measured)
}

/// The area of a quadrilateral made simple first, as the library's
/// `makeQuad` does: the vertices as given if the quadrilateral is simple,
/// else with the first two swapped, else in the order 0, 2, 1, 3 (the
/// area of that last order whether or not it is simple, as the library).
pub fn quadrilateral_area(quad: [[f64; 2]; 4]) -> f64 {
    let [a, b, c, d] = quad;
    let order = [[a, b, c, d], [b, a, c, d], [a, c, b, d]]
        .into_iter()
        .find(|q| is_simple(*q))
        .unwrap_or([a, c, b, d]);
    signed_area(order).abs()
}

/// The library's `is_simple_quad`: the cross products of consecutive
/// sides; simple when more than two of them have the sign (zero counting
/// for either) of the majority.
fn is_simple(quad: [[f64; 2]; 4]) -> bool {
    let side = |k: usize| {
        let (from, to) = (quad[k], quad[(k + 1) % 4]);
        [to[0] - from[0], to[1] - from[1]]
    };
    let cross: [f64; 4] = std::array::from_fn(|k| {
        let (u, v) = (side(k), side((k + 1) % 4));
        u[0] * v[1] - u[1] * v[0]
    });
    let positive = cross.iter().filter(|c| **c > 0.0).count();
    let negative = cross.iter().filter(|c| **c < 0.0).count();
    let agreeing = if positive < negative {
        cross.iter().filter(|c| **c <= 0.0).count()
    } else {
        cross.iter().filter(|c| **c >= 0.0).count()
    };
    agreeing > 2
}

/// The shoelace formula, signed: positive counter-clockwise (the
/// library's `poly_area`, `0.5 |x . roll(y) - y . roll(x)|`, is its
/// absolute value).
fn signed_area(quad: [[f64; 2]; 4]) -> f64 {
    let x = quad.map(|p| p[0]);
    let y = quad.map(|p| p[1]);
    let x_rolled_y = x[0] * y[3] + x[1] * y[0] + x[2] * y[1] + x[3] * y[2];
    let y_rolled_x = y[0] * x[3] + y[1] * x[0] + y[2] * x[1] + y[3] * x[2];
    0.5 * (y_rolled_x - x_rolled_y)
}

#[cfg(test)]
mod tests {
    use super::quadrilateral_area;

    /// Closed forms: a simple quadrilateral keeps its order (a trapezoid of
    /// parallel sides 1 and 3, height 2: area 4, in either direction); a
    /// bow tie (two curves crossing at the middle) is re-ordered into the
    /// square of its four points (area 1, where its signed lobes cancel to
    /// 0); one that needs the first swap (measured and simulated sides
    /// joined the wrong way round) becomes the rectangle (area 2).
    #[test]
    fn a_crossing_quadrilateral_is_made_simple_before_its_area() {
        let trapezoid = [[0.0, 0.0], [3.0, 0.0], [2.0, 2.0], [1.0, 2.0]];
        assert!((quadrilateral_area(trapezoid) - 4.0).abs() < 1e-15);
        let mut reversed = trapezoid;
        reversed.reverse();
        assert!((quadrilateral_area(reversed) - 4.0).abs() < 1e-15);
        let bow_tie = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
        assert!((quadrilateral_area(bow_tie) - 1.0).abs() < 1e-15);
        let swapped = [[2.0, 0.0], [0.0, 0.0], [2.0, 1.0], [0.0, 1.0]];
        assert!((quadrilateral_area(swapped) - 2.0).abs() < 1e-15);
    }
}
