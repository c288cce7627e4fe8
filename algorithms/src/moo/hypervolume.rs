//! The hypervolume indicator: the volume dominated by a front and bounded by a reference
//! point (minimisation), exact for one to three objectives.

use super::MooError;

/// The volume of the set of points that some member of `front` dominates and that
/// dominate `reference`, i.e. the union of the boxes `[p, reference]` (minimisation).
///
/// Exact: a sort and sweep in 2-D, a sweep over the third objective with an incrementally
/// updated 2-D staircase in 3-D (O(n^2) at worst, milliseconds for thousands of points).
/// Points not strictly better than the reference in every objective add nothing, nor do
/// dominated points or points with a NaN or `+inf` (a failed evaluation). A point at
/// `-inf` is an error (its volume is infinite), and so are more than 3 objectives.
pub fn hypervolume(front: &[Vec<f64>], reference: &[f64]) -> Result<f64, MooError> {
    if reference.is_empty() || !reference.iter().all(|r| r.is_finite()) {
        return Err(MooError::InvalidReference {
            reference: reference.to_vec(),
        });
    }
    if reference.len() > 3 {
        return Err(MooError::TooManyObjectives {
            objectives: reference.len(),
        });
    }
    let mut inside: Vec<&[f64]> = Vec::with_capacity(front.len());
    for (index, point) in front.iter().enumerate() {
        if point.len() != reference.len() {
            return Err(MooError::DimensionMismatch {
                index,
                expected: reference.len(),
                found: point.len(),
            });
        }
        if point.contains(&f64::NEG_INFINITY) {
            return Err(MooError::UnboundedPoint { index });
        }
        // NaN and +inf fail the comparison, so a failed evaluation adds nothing.
        if point.iter().zip(reference).all(|(p, r)| p < r) {
            inside.push(point);
        }
    }
    Ok(match reference.len() {
        1 => inside
            .iter()
            .map(|p| reference[0] - p[0])
            .fold(0.0, f64::max),
        2 => area(&mut inside, reference[0], reference[1]),
        _ => volume(&mut inside, reference),
    })
}

/// The 2-D dominated area: sweep by the first objective, adding the horizontal strip each
/// new best second objective opens up.
fn area(points: &mut [&[f64]], reference_x: f64, reference_y: f64) -> f64 {
    points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    let mut lowest_y = reference_y;
    let mut total = 0.0;
    for point in points.iter() {
        if point[1] < lowest_y {
            total += (reference_x - point[0]) * (lowest_y - point[1]);
            lowest_y = point[1];
        }
    }
    total
}

/// The 3-D dominated volume: sweep up the third objective; between two consecutive third
/// coordinates the cross-section is the 2-D area of the points below, kept as a staircase
/// (first objective ascending, second strictly descending) that each point updates.
fn volume(points: &mut [&[f64]], reference: &[f64]) -> f64 {
    points.sort_by(|a, b| a[2].total_cmp(&b[2]));
    let (reference_x, reference_y, reference_z) = (reference[0], reference[1], reference[2]);
    let mut staircase: Vec<(f64, f64)> = Vec::with_capacity(points.len());
    let mut section = 0.0;
    let mut total = 0.0;
    for (k, point) in points.iter().enumerate() {
        section +=
            insert_into_staircase(&mut staircase, point[0], point[1], reference_x, reference_y);
        let next_z = points.get(k + 1).map_or(reference_z, |next| next[2]);
        total += section * (next_z - point[2]);
    }
    total
}

/// Add `(x, y)` to a 2-D staircase and return the area this adds to its dominated region.
fn insert_into_staircase(
    staircase: &mut Vec<(f64, f64)>,
    x: f64,
    y: f64,
    reference_x: f64,
    reference_y: f64,
) -> f64 {
    // The last step at or left of x has the lowest y among them: if it is at or below y,
    // the new point is dominated.
    let at_or_left = staircase.partition_point(|&(sx, _)| sx <= x);
    if at_or_left > 0 && staircase[at_or_left - 1].1 <= y {
        return 0.0;
    }
    // Steps the new point dominates: x at or right of it and y at or above it.
    let start = staircase.partition_point(|&(sx, _)| sx < x);
    let end = start + staircase[start..].partition_point(|&(_, sy)| sy >= y);
    // Under the old staircase, the height over [x, next step right of the dominated ones)
    // falls from the step left of x through each dominated step; the new point lowers all
    // of it to y.
    let mut height = if start > 0 {
        staircase[start - 1].1
    } else {
        reference_y
    };
    let mut left = x;
    let mut gained = 0.0;
    for &(sx, sy) in &staircase[start..end] {
        gained += (sx - left) * (height - y);
        left = sx;
        height = sy;
    }
    let right = staircase.get(end).map_or(reference_x, |&(sx, _)| sx);
    gained += (right - left) * (height - y);
    staircase.splice(start..end, std::iter::once((x, y)));
    gained
}
