//! The dynamic programme DTW and the discrete Fréchet distance share: a
//! cumulative cost over the `n x m` grid of point pairs, each cell from the
//! best of its three predecessors, and the warping path back from the last
//! cell. The value needs two rows (O(n + m) memory); the path keeps each
//! cell's choice in 2 bits (O(n m) bits: 250 kB for two 1,000-point
//! curves), since the coupling is what the signed residuals are made of.

use super::points::{distance, CurveMetricError, Points, MAX_CELLS};

/// How a cell's cumulative cost follows from its best predecessor's and
/// its own pair distance.
#[derive(Clone, Copy)]
pub(super) enum Accumulate {
    /// DTW: the sum along the path.
    Sum,
    /// Fréchet: the largest along the path.
    Max,
}

impl Accumulate {
    #[inline(always)]
    fn step(self, before: f64, cost: f64) -> f64 {
        match self {
            Accumulate::Sum => before + cost,
            Accumulate::Max => {
                if cost > before {
                    cost
                } else {
                    before
                }
            }
        }
    }
}

/// The smaller of two costs. Costs are never NaN (the curves are checked
/// finite), so this skips `f64::min`'s NaN handling, a third of the
/// inner loop's instructions.
#[inline(always)]
fn smaller(a: f64, b: f64) -> f64 {
    if b < a {
        b
    } else {
        a
    }
}

/// Which predecessor a cell took.
const UP: u8 = 0; // (i - 1, j)
const LEFT: u8 = 1; // (i, j - 1)
                    // 2: the diagonal, (i - 1, j - 1): any other choice.

/// The last cell's cumulative cost, in O(n + m) memory.
pub(super) fn value(a: &Points, b: &Points, accumulate: Accumulate) -> f64 {
    let m = b.len();
    let mut previous = vec![0.0; m];
    let mut current = vec![0.0; m];
    let mut costs = vec![0.0; m];
    row_costs(a[0], b, &mut costs);
    previous[0] = costs[0];
    for j in 1..m {
        previous[j] = accumulate.step(previous[j - 1], costs[j]);
    }
    for &point in &a[1..] {
        row_costs(point, b, &mut costs);
        current[0] = accumulate.step(previous[0], costs[0]);
        for j in 1..m {
            let best = smaller(smaller(previous[j], current[j - 1]), previous[j - 1]);
            current[j] = accumulate.step(best, costs[j]);
        }
        std::mem::swap(&mut previous, &mut current);
    }
    previous[m - 1]
}

/// The distances of `point` to every point of `b`: a loop of its own, so
/// that its square roots vectorise and stay out of the row's chain of
/// dependent minima.
fn row_costs(point: [f64; 2], b: &Points, costs: &mut [f64]) {
    for (cost, &other) in costs.iter_mut().zip(b) {
        *cost = distance(point, other);
    }
}

/// The last cell's cumulative cost and the path to it, from `(0, 0)` to
/// `(n - 1, m - 1)`. Of equal predecessors the path takes `(i - 1, j)`,
/// then `(i, j - 1)`, then the diagonal: the order `similaritymeasures`'
/// `dtw_path` walks back in.
pub(super) fn path(
    a: &Points,
    b: &Points,
    accumulate: Accumulate,
) -> Result<(f64, Vec<(usize, usize)>), CurveMetricError> {
    let (n, m) = (a.len(), b.len());
    let cells = n.saturating_mul(m);
    if cells > MAX_CELLS {
        return Err(CurveMetricError::TooLarge {
            measured: n,
            simulated: m,
            cells,
        });
    }
    let mut choices = Choices::new(cells);
    let mut previous = vec![0.0; m];
    let mut current = vec![0.0; m];
    let mut costs = vec![0.0; m];
    let mut row_choices = vec![0u8; m];
    row_costs(a[0], b, &mut costs);
    previous[0] = costs[0];
    for j in 1..m {
        previous[j] = accumulate.step(previous[j - 1], costs[j]);
        row_choices[j] = LEFT;
    }
    choices.set_row(0, &row_choices);
    for (i, &point) in a.iter().enumerate().skip(1) {
        row_costs(point, b, &mut costs);
        current[0] = accumulate.step(previous[0], costs[0]);
        row_choices[0] = UP;
        for j in 1..m {
            let (up, left, diagonal) = (previous[j], current[j - 1], previous[j - 1]);
            let best = smaller(smaller(up, left), diagonal);
            // UP where up is best, else LEFT where left is, else DIAGONAL;
            // without branches, which the data would keep mispredicting.
            row_choices[j] = u8::from(up != best) * (1 + u8::from(left != best));
            current[j] = accumulate.step(best, costs[j]);
        }
        choices.set_row(i * m, &row_choices);
        std::mem::swap(&mut previous, &mut current);
    }
    let mut path = Vec::with_capacity(n + m);
    let (mut i, mut j) = (n - 1, m - 1);
    path.push((i, j));
    while i > 0 || j > 0 {
        match choices.get(i * m + j) {
            UP => i -= 1,
            LEFT => j -= 1,
            _ => {
                i -= 1;
                j -= 1;
            }
        }
        path.push((i, j));
    }
    path.reverse();
    Ok((previous[m - 1], path))
}

/// 2 bits a cell.
struct Choices(Vec<u64>);

impl Choices {
    fn new(cells: usize) -> Choices {
        Choices(vec![0; cells.div_ceil(32)])
    }

    /// The choices of the cells from `first` on, in order.
    fn set_row(&mut self, first: usize, row: &[u8]) {
        for (k, &choice) in row.iter().enumerate() {
            let cell = first + k;
            let (word, shift) = (cell / 32, 2 * (cell % 32));
            self.0[word] |= u64::from(choice) << shift;
        }
    }

    fn get(&self, cell: usize) -> u8 {
        ((self.0[cell / 32] >> (2 * (cell % 32))) & 3) as u8
    }
}
