//! The dynamic programme DTW and the discrete Fréchet distance share: a
//! cumulative cost over the `n x m` grid of point pairs, each cell from the
//! best of its three predecessors, and the warping path back from the last
//! cell. The value needs two rows (O(n + m) memory); the path keeps each
//! cell's choice in 2 bits (O(n m) bits: 250 kB for two 1,000-point
//! curves), since the coupling is what the signed residuals are made of.
//!
//! A row is a chain: each cell waits for the one to its left. Its time is
//! that chain's, so the rows are made two at a time, a cell of each in
//! turn (two chains side by side), with the distances before and the
//! choices after in loops of their own. Every cell is the same number as
//! the whole matrix's (the tests compare them to the bit).

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
    let mut rows = Rows::new(b);
    rows.first(a[0], accumulate);
    let mut pairs = a[1..].chunks_exact(2);
    for pair in &mut pairs {
        rows.make_two(pair[0], pair[1], accumulate);
        rows.advance_two();
    }
    for &point in pairs.remainder() {
        rows.make_current(point, accumulate);
        rows.advance();
    }
    rows.last_cost()
}

/// Rows of the grid's cumulative costs: the row before, and the one or
/// two being made; the other curve's points by coordinate.
struct Rows {
    /// `b`'s abscissae and ordinates, each in a slice of its own: the
    /// distances of a row are then a loop of its own, out of the chain of
    /// dependent cells.
    xs: Vec<f64>,
    ys: Vec<f64>,
    costs: Vec<f64>,
    costs_below: Vec<f64>,
    previous: Vec<f64>,
    current: Vec<f64>,
    below: Vec<f64>,
}

impl Rows {
    fn new(b: &Points) -> Rows {
        let m = b.len();
        Rows {
            xs: b.iter().map(|point| point[0]).collect(),
            ys: b.iter().map(|point| point[1]).collect(),
            costs: vec![0.0; m],
            costs_below: vec![0.0; m],
            previous: vec![0.0; m],
            current: vec![0.0; m],
            below: vec![0.0; m],
        }
    }

    /// The first row, into `previous`: along `b` from `(0, 0)`.
    fn first(&mut self, point: [f64; 2], accumulate: Accumulate) {
        row_costs(point, &self.xs, &self.ys, &mut self.costs);
        let mut left = self.costs[0];
        self.previous[0] = left;
        for (cell, &cost) in self.previous[1..].iter_mut().zip(&self.costs[1..]) {
            left = accumulate.step(left, cost);
            *cell = left;
        }
    }

    /// The row of `point` into `current`, from `previous`.
    fn make_current(&mut self, point: [f64; 2], accumulate: Accumulate) {
        row_costs(point, &self.xs, &self.ys, &mut self.costs);
        // A loop for each way of accumulating, none deciding per cell.
        match accumulate {
            Accumulate::Sum => self.accumulate_current(|best, cost| best + cost),
            Accumulate::Max => {
                self.accumulate_current(|best, cost| Accumulate::Max.step(best, cost))
            }
        }
    }

    #[inline(always)]
    fn accumulate_current(&mut self, step: impl Fn(f64, f64) -> f64) {
        let m = self.current.len();
        let (previous, costs, current) = (
            &self.previous[..m],
            &self.costs[..m],
            &mut self.current[..m],
        );
        // The cell to the left is carried in a register: read back from
        // memory, each cell waited for its store.
        let mut left = step(previous[0], costs[0]);
        current[0] = left;
        for j in 1..m {
            // The row's own neighbour last: the one value each cell waits
            // for goes through one comparison, not two. Costs are never -0
            // or NaN (distances of finite points, their sums and maxima),
            // so the order of the comparisons cannot change the smallest.
            let best = smaller(smaller(previous[j], previous[j - 1]), left);
            left = step(best, costs[j]);
            current[j] = left;
        }
    }

    /// The rows of `point` and `point_below` into `current` and `below`,
    /// from `previous`, a cell of each in turn: each row is a chain of
    /// cells that wait for the one to their left, and two chains side by
    /// side take the time of one. Every cell as [`Rows::make_current`]
    /// makes it.
    fn make_two(&mut self, point: [f64; 2], point_below: [f64; 2], accumulate: Accumulate) {
        row_costs(point, &self.xs, &self.ys, &mut self.costs);
        row_costs(point_below, &self.xs, &self.ys, &mut self.costs_below);
        match accumulate {
            Accumulate::Sum => self.accumulate_two(|best, cost| best + cost),
            Accumulate::Max => self.accumulate_two(|best, cost| Accumulate::Max.step(best, cost)),
        }
    }

    #[inline(always)]
    fn accumulate_two(&mut self, step: impl Fn(f64, f64) -> f64) {
        let m = self.current.len();
        let (previous, costs, costs_below) = (
            &self.previous[..m],
            &self.costs[..m],
            &self.costs_below[..m],
        );
        let (current, below) = (&mut self.current[..m], &mut self.below[..m]);
        let mut left = step(previous[0], costs[0]);
        current[0] = left;
        let mut left_below = step(left, costs_below[0]);
        below[0] = left_below;
        for j in 1..m {
            let diagonal_below = left;
            left = step(
                smaller(smaller(previous[j], previous[j - 1]), left),
                costs[j],
            );
            current[j] = left;
            let best_below = smaller(smaller(left, diagonal_below), left_below);
            left_below = step(best_below, costs_below[j]);
            below[j] = left_below;
        }
    }

    /// The row made becomes the row before the next.
    fn advance(&mut self) {
        std::mem::swap(&mut self.previous, &mut self.current);
    }

    /// The lower of the two rows made becomes the row before the next.
    fn advance_two(&mut self) {
        std::mem::swap(&mut self.previous, &mut self.below);
    }

    /// The last cell of the last row made.
    fn last_cost(&self) -> f64 {
        self.previous[self.previous.len() - 1]
    }
}

/// The distances of `point` to the points `(xs[k], ys[k])`, by
/// [`distance`]'s formula.
fn row_costs(point: [f64; 2], xs: &[f64], ys: &[f64], costs: &mut [f64]) {
    let m = costs.len();
    let (xs, ys) = (&xs[..m], &ys[..m]);
    for k in 0..m {
        costs[k] = distance(point, [xs[k], ys[k]]);
    }
}

/// Which predecessor each cell of `row` took, `above` the row before it:
/// in a pass of its own once the row is known, so that no cell waits for
/// another's choice.
fn row_choices(above: &[f64], row: &[f64], choices: &mut [u8]) {
    let m = row.len();
    let (above, choices) = (&above[..m], &mut choices[..m]);
    choices[0] = UP;
    for j in 1..m {
        let (up, diagonal, left) = (above[j], above[j - 1], row[j - 1]);
        let best = smaller(smaller(up, diagonal), left);
        // UP where up is best, else LEFT where left is, else DIAGONAL;
        // without branches, which the data would keep mispredicting.
        choices[j] = u8::from(up != best) * (1 + u8::from(left != best));
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
    let mut choices = Choices::new(n, m);
    let mut rows = Rows::new(b);
    let mut choices_of_row = vec![0u8; m];
    rows.first(a[0], accumulate);
    choices_of_row[1..].fill(LEFT);
    choices.set_row(0, &choices_of_row);
    let mut i = 1;
    while i < n {
        if i + 1 < n {
            rows.make_two(a[i], a[i + 1], accumulate);
            row_choices(&rows.previous, &rows.current, &mut choices_of_row);
            choices.set_row(i, &choices_of_row);
            row_choices(&rows.current, &rows.below, &mut choices_of_row);
            choices.set_row(i + 1, &choices_of_row);
            rows.advance_two();
            i += 2;
        } else {
            rows.make_current(a[i], accumulate);
            row_choices(&rows.previous, &rows.current, &mut choices_of_row);
            choices.set_row(i, &choices_of_row);
            rows.advance();
            i += 1;
        }
    }
    let mut path = Vec::with_capacity(n + m);
    let (mut i, mut j) = (n - 1, m - 1);
    path.push((i, j));
    while i > 0 || j > 0 {
        match choices.get(i, j) {
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
    Ok((rows.last_cost(), path))
}

/// 2 bits a cell, the cells row after row (no room between rows: a
/// curve of one or two points against a long one takes no more words
/// than its cells need).
struct Choices {
    words: Vec<u64>,
    columns: usize,
}

impl Choices {
    fn new(rows: usize, columns: usize) -> Choices {
        Choices {
            words: vec![0; (rows * columns).div_ceil(32)],
            columns,
        }
    }

    /// The choices of row `i`'s cells, in order: one at a time up to the
    /// next whole word, then 32 to a word.
    fn set_row(&mut self, i: usize, row: &[u8]) {
        let first = i * self.columns;
        let unaligned = ((32 - first % 32) % 32).min(row.len());
        for (k, &choice) in row[..unaligned].iter().enumerate() {
            let cell = first + k;
            self.words[cell / 32] |= u64::from(choice) << (2 * (cell % 32));
        }
        let aligned = row[unaligned..].chunks(32);
        let words = &mut self.words[(first + unaligned) / 32..];
        for (word, cells) in words.iter_mut().zip(aligned) {
            *word |= cells
                .iter()
                .enumerate()
                .fold(0, |word, (k, &choice)| word | u64::from(choice) << (2 * k));
        }
    }

    fn get(&self, i: usize, j: usize) -> u8 {
        let cell = i * self.columns + j;
        ((self.words[cell / 32] >> (2 * (cell % 32))) & 3) as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The textbook programme: the whole `n x m` matrix of cumulative
    /// costs, the path walked back through it by the stated order of ties.
    fn whole_matrix(a: &Points, b: &Points, accumulate: Accumulate) -> (f64, Vec<(usize, usize)>) {
        let (n, m) = (a.len(), b.len());
        let mut total = vec![vec![0.0; m]; n];
        for i in 0..n {
            for j in 0..m {
                let cost = distance(a[i], b[j]);
                total[i][j] = match (i, j) {
                    (0, 0) => cost,
                    (0, _) => accumulate.step(total[0][j - 1], cost),
                    (_, 0) => accumulate.step(total[i - 1][0], cost),
                    _ => {
                        let best = total[i - 1][j]
                            .min(total[i][j - 1])
                            .min(total[i - 1][j - 1]);
                        accumulate.step(best, cost)
                    }
                };
            }
        }
        let (mut i, mut j) = (n - 1, m - 1);
        let mut path = vec![(i, j)];
        while i > 0 || j > 0 {
            if j == 0 {
                i -= 1;
            } else if i == 0 {
                j -= 1;
            } else {
                let (up, left, diagonal) = (total[i - 1][j], total[i][j - 1], total[i - 1][j - 1]);
                let best = up.min(left).min(diagonal);
                if up == best {
                    i -= 1;
                } else if left == best {
                    j -= 1;
                } else {
                    i -= 1;
                    j -= 1;
                }
            }
            path.push((i, j));
        }
        path.reverse();
        (total[n - 1][m - 1], path)
    }

    /// Curves of up to 70 points (rows that start anywhere in a word and
    /// span up to three) on a coarse grid, so that equal costs and ties
    /// between predecessors are common.
    fn curve() -> impl Strategy<Value = Vec<[f64; 2]>> {
        proptest::collection::vec((0u8..6, 0u8..6), 1..70).prop_map(|points| {
            points
                .into_iter()
                .map(|(x, y)| [f64::from(x) * 0.5, f64::from(y)])
                .collect()
        })
    }

    proptest! {
        #[test]
        fn the_rows_and_their_choices_give_the_whole_matrix_s_cost_and_path(
            a in curve(),
            b in curve(),
            sum in any::<bool>(),
        ) {
            let accumulate = if sum { Accumulate::Sum } else { Accumulate::Max };
            let (cost, reference_path) = whole_matrix(&a, &b, accumulate);
            let (path_cost, path) = super::path(&a, &b, accumulate).unwrap();
            prop_assert_eq!(value(&a, &b, accumulate).to_bits(), cost.to_bits());
            prop_assert_eq!(path_cost.to_bits(), cost.to_bits());
            prop_assert_eq!(path, reference_path);
        }
    }
}
