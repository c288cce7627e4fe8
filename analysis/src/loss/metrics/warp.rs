//! The dynamic programme DTW and the discrete Fréchet distance share: a
//! cumulative cost over the `n x m` grid of point pairs, each cell from the
//! best of its three predecessors, and the warping path back from the last
//! cell. The value needs two rows (O(n + m) memory); the path keeps each
//! cell's choice in 2 bits (O(n m) bits: 250 kB for two 1,000-point
//! curves), since the coupling is what the signed residuals are made of.

use super::{distance, CurveMetricError, Points, MAX_CELLS};

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
            Accumulate::Max => before.max(cost),
        }
    }
}

/// Which predecessor a cell took.
const UP: u8 = 0; // (i - 1, j)
const LEFT: u8 = 1; // (i, j - 1)
const DIAGONAL: u8 = 2; // (i - 1, j - 1)

/// The last cell's cumulative cost, in O(n + m) memory.
pub(super) fn value(a: &Points, b: &Points, accumulate: Accumulate) -> f64 {
    let m = b.len();
    let mut previous = vec![0.0; m];
    let mut current = vec![0.0; m];
    previous[0] = distance(a[0], b[0]);
    for j in 1..m {
        previous[j] = accumulate.step(previous[j - 1], distance(a[0], b[j]));
    }
    for &point in &a[1..] {
        current[0] = accumulate.step(previous[0], distance(point, b[0]));
        for j in 1..m {
            let best = previous[j].min(current[j - 1]).min(previous[j - 1]);
            current[j] = accumulate.step(best, distance(point, b[j]));
        }
        std::mem::swap(&mut previous, &mut current);
    }
    previous[m - 1]
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
    previous[0] = distance(a[0], b[0]);
    for j in 1..m {
        previous[j] = accumulate.step(previous[j - 1], distance(a[0], b[j]));
        choices.set(j, LEFT);
    }
    for (i, &point) in a.iter().enumerate().skip(1) {
        current[0] = accumulate.step(previous[0], distance(point, b[0]));
        choices.set(i * m, UP);
        for j in 1..m {
            let (up, left, diagonal) = (previous[j], current[j - 1], previous[j - 1]);
            let best = up.min(left).min(diagonal);
            let choice = if up == best {
                UP
            } else if left == best {
                LEFT
            } else {
                DIAGONAL
            };
            choices.set(i * m + j, choice);
            current[j] = accumulate.step(best, distance(point, b[j]));
        }
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

    fn set(&mut self, cell: usize, choice: u8) {
        let (word, shift) = (cell / 32, 2 * (cell % 32));
        self.0[word] = (self.0[word] & !(3 << shift)) | (u64::from(choice) << shift);
    }

    fn get(&self, cell: usize) -> u8 {
        ((self.0[cell / 32] >> (2 * (cell % 32))) & 3) as u8
    }
}
