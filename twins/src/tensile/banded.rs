//! A banded matrix and its LU factorisation with partial pivoting
//! (the LAPACK `gbtrf`/`gbtrs` scheme).
//!
//! The tensile bar's nodes are numbered across the radius first, so every
//! element couples degrees of freedom at most a few radial rows
//! apart (`2 (radial elements) + 5`); the F-bar tangent is not symmetric, and past the force maximum it
//! need not be positive definite, so the solver pivots. With `kl` sub- and
//! `ku` super-diagonals the factorisation costs `n kl (kl + ku)` flops:
//! about 3 Mflop for the default mesh, far below the cost of the stress
//! updates, and 14 Mflop for 0.09 mm elements in the neck (22 x 44).
//!
//! Why by hand: the bar is a long strip numbered across its width, where a
//! band is already close to the best elimination order. faer's sparse LU
//! (COLAMD ordering, its symbolic analysis done once and reused by every
//! Newton iteration) was measured slower on the 0.09 mm mesh: 16.7 s a run
//! against 14.8 s for this LU before its update loops were vectorised, and
//! 10.3 s after (BENCHMARKS.md, "GTN solver").

/// A square matrix stored by diagonals, with room for the fill-in that
/// pivoting creates (`kl` extra super-diagonals).
#[derive(Clone, Debug)]
pub struct BandedMatrix {
    size: usize,
    lower: usize,
    upper: usize,
    /// Row-major: row `i` holds columns `i - lower ..= i + upper + lower`
    /// at offsets `0 ..= 2 lower + upper`.
    entries: Vec<f64>,
}

/// The factorisation failed: a zero pivot, the matrix is singular.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("the stiffness matrix is singular (zero pivot in column {column})")]
pub struct SingularMatrix {
    pub column: usize,
}

impl BandedMatrix {
    /// A zero matrix of `size` with `lower` sub- and `upper` super-diagonals.
    pub fn zeros(size: usize, lower: usize, upper: usize) -> Self {
        BandedMatrix {
            size,
            lower,
            upper,
            entries: vec![0.0; size * Self::width_for(lower, upper)],
        }
    }

    fn width_for(lower: usize, upper: usize) -> usize {
        2 * lower + upper + 1
    }

    fn width(&self) -> usize {
        Self::width_for(self.lower, self.upper)
    }

    pub fn size(&self) -> usize {
        self.size
    }

    /// Whether (row, column) is inside the declared band.
    pub fn in_band(&self, row: usize, column: usize) -> bool {
        row < self.size
            && column < self.size
            && column + self.lower >= row
            && column <= row + self.upper
    }

    fn offset(&self, row: usize, column: usize) -> usize {
        row * self.width() + (column + self.lower - row)
    }

    /// Sets every entry to zero, keeping the storage.
    pub fn clear(&mut self) {
        self.entries.fill(0.0);
    }

    /// Adds `value` at (row, column), which must be inside the band.
    pub fn add(&mut self, row: usize, column: usize, value: f64) {
        debug_assert!(
            self.in_band(row, column),
            "({row}, {column}) outside the band"
        );
        let at = self.offset(row, column);
        self.entries[at] += value;
    }

    pub fn get(&self, row: usize, column: usize) -> f64 {
        if self.in_band(row, column) {
            self.entries[self.offset(row, column)]
        } else {
            0.0
        }
    }

    /// Replaces row and column `dof` by the identity: the degree of freedom
    /// is prescribed. Each removed column entry times the prescribed value
    /// is moved to the right-hand side.
    pub fn prescribe(&mut self, dof: usize, value: f64, rhs: &mut [f64]) {
        let first = dof.saturating_sub(self.upper);
        let last = (dof + self.lower).min(self.size - 1);
        for (row, rhs_row) in rhs.iter_mut().enumerate().take(last + 1).skip(first) {
            if row != dof {
                let at = self.offset(row, dof);
                *rhs_row -= self.entries[at] * value;
                self.entries[at] = 0.0;
            }
        }
        let row_first = dof.saturating_sub(self.lower);
        let row_last = (dof + self.upper).min(self.size - 1);
        for column in row_first..=row_last {
            let at = self.offset(dof, column);
            self.entries[at] = 0.0;
        }
        let at = self.offset(dof, dof);
        self.entries[at] = 1.0;
        rhs[dof] = value;
    }

    /// The entry at (row, column) to change, if it is inside the band.
    pub fn entry_mut(&mut self, row: usize, column: usize) -> Option<&mut f64> {
        if self.in_band(row, column) {
            let at = self.offset(row, column);
            Some(&mut self.entries[at])
        } else {
            None
        }
    }

    /// Solves `A x = rhs` in place (the matrix is overwritten by its
    /// factors). Partial pivoting within the band.
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SingularMatrix> {
        let factored = self.factor(&mut Coupling::none())?;
        self.forward(&factored, rhs);
        self.back_substitute(&factored, rhs);
        Ok(())
    }

    /// Factors the matrix in place (`P A = L U`, L's multipliers where the
    /// eliminated entries were) and carries the `coupling` columns along
    /// (`L^-1 P` applied to them). What [`BandedMatrix::forward`] and the
    /// back substitution need is returned: one factorisation serves any
    /// number of right-hand sides.
    pub(crate) fn factor(&mut self, coupling: &mut Coupling) -> Result<Factored, SingularMatrix> {
        let n = self.size;
        let scale = largest_magnitude(&self.entries);
        let tiny = scale * f64::EPSILON * 16.0;
        // The last column row k of U holds: `filled_to` when k was the
        // pivot (the back substitution skips the zeros after it).
        let mut last_in_row = vec![0; n];
        let mut pivot_rows = vec![0; n];
        // The last column any row at or above the pivot may hold: `k +
        // upper` until a swap brings up a row from below (LAPACK gbtf2's
        // `ju`). A stiffness matrix rarely needs one, so the updates stay
        // `upper` wide instead of `upper + lower`.
        let mut filled_to = 0;
        for k in 0..n {
            let last_row = (k + self.lower).min(n - 1);
            let mut pivot_row = k;
            let mut pivot_abs = self.get(k, k).abs();
            for row in k + 1..=last_row {
                let value = self.entries[self.offset(row, k)].abs();
                if value > pivot_abs {
                    pivot_abs = value;
                    pivot_row = row;
                }
            }
            if pivot_abs <= tiny || !pivot_abs.is_finite() {
                return Err(SingularMatrix { column: k });
            }
            filled_to = filled_to.max(pivot_row + self.upper).min(n - 1);
            let last_column = filled_to;
            last_in_row[k] = last_column;
            pivot_rows[k] = pivot_row;
            if pivot_row != k {
                for column in k..=last_column {
                    let a = self.offset(k, column);
                    let b = self.offset(pivot_row, column);
                    self.entries.swap(a, b);
                }
                coupling.swap_rows(k, pivot_row);
            }
            let pivot_base = self.offset(k, k);
            let below = Elimination {
                pivot_base,
                // Row k + 1's entry in column k: one row on, one place back.
                first_row_base: pivot_base + self.width() - 1,
                row_step: self.width() - 1,
                rows: last_row - k,
                span: last_column - k,
            };
            eliminate(&mut self.entries, &below);
            if coupling.holds(k) {
                for row in k + 1..=last_row {
                    let factor = self.entries[self.offset(row, k)];
                    coupling.subtract(row, k, factor);
                }
            }
        }
        Ok(Factored {
            last_in_row,
            pivot_rows,
        })
    }

    /// The forward half of a solve: `rhs` becomes `L^-1 P rhs`, with the
    /// factorisation's row swaps and multipliers in its order (LAPACK
    /// `gbtrs`).
    pub(crate) fn forward(&self, factored: &Factored, rhs: &mut [f64]) {
        let n = self.size;
        for k in 0..n {
            let pivot_row = factored.pivot_rows[k];
            if pivot_row != k {
                rhs.swap(k, pivot_row);
            }
            let pivot_value = rhs[k];
            if pivot_value == 0.0 {
                continue;
            }
            let last_row = (k + self.lower).min(n - 1);
            // Column k's multipliers: one row on, one place back each.
            let multipliers = self
                .entries
                .iter()
                .skip(self.offset(k, k) + self.width() - 1)
                .step_by((self.width() - 1).max(1));
            for (value, multiplier) in rhs[k + 1..=last_row].iter_mut().zip(multipliers) {
                *value -= multiplier * pivot_value;
            }
        }
    }

    /// U's row k: its entries after the diagonal, and the diagonal.
    pub(crate) fn upper_row(&self, factored: &Factored, k: usize) -> (&[f64], f64) {
        let base = self.offset(k, k);
        let span = factored.last_in_row[k] - k;
        (&self.entries[base + 1..=base + span], self.entries[base])
    }

    /// The back half of a solve: `rhs` holds `L^-1 P b` (less the coupled
    /// unknowns' share) and becomes `x`.
    pub(crate) fn back_substitute(&self, factored: &Factored, rhs: &mut [f64]) {
        for k in (0..self.size).rev() {
            let (row, diagonal) = self.upper_row(factored, k);
            let known = &rhs[k + 1..=k + row.len()];
            rhs[k] = (rhs[k] - dot(row, known)) / diagonal;
        }
    }
}

/// What a factorisation leaves for the back substitution.
pub(crate) struct Factored {
    /// The last column each row of U holds.
    last_in_row: Vec<usize>,
    /// The row swapped with row k before column k was eliminated.
    pivot_rows: Vec<usize>,
}

impl Factored {
    /// How many rows the pivoting swapped.
    #[cfg(test)]
    pub(crate) fn swaps(&self) -> usize {
        self.pivot_rows
            .iter()
            .enumerate()
            .filter(|(k, row)| k != *row)
            .count()
    }
}

/// Columns of other unknowns carried through a factorisation (see
/// `split_band`): dense, for the rows from `first_row` on only, since the
/// rows before hold zeros there and keep them.
#[derive(Clone)]
pub(crate) struct Coupling {
    first_row: usize,
    columns: usize,
    /// Row-major, `(size - first_row) x columns`.
    pub(crate) entries: Vec<f64>,
}

impl Coupling {
    fn none() -> Self {
        Coupling {
            first_row: usize::MAX,
            columns: 0,
            entries: Vec::new(),
        }
    }

    pub(crate) fn zeros(size: usize, first_row: usize, columns: usize) -> Self {
        Coupling {
            first_row,
            columns,
            entries: vec![0.0; (size - first_row) * columns],
        }
    }

    pub(crate) fn holds(&self, row: usize) -> bool {
        row >= self.first_row && self.columns > 0
    }

    pub(crate) fn row(&self, row: usize) -> &[f64] {
        let start = (row - self.first_row) * self.columns;
        &self.entries[start..start + self.columns]
    }

    pub(crate) fn row_mut(&mut self, row: usize) -> &mut [f64] {
        let start = (row - self.first_row) * self.columns;
        &mut self.entries[start..start + self.columns]
    }

    fn swap_rows(&mut self, a: usize, b: usize) {
        match (self.holds(a), self.holds(b)) {
            (true, true) => {
                for column in 0..self.columns {
                    let first = (a - self.first_row) * self.columns + column;
                    let second = (b - self.first_row) * self.columns + column;
                    self.entries.swap(first, second);
                }
            }
            (false, false) => {}
            // The rows before `first_row` hold zeros: a row with entries
            // cannot move there (the caller sizes the coupling for that).
            _ => debug_assert!(
                self.holds(b) && self.row(b).iter().all(|v| *v == 0.0),
                "a coupled row moved above the coupling's first row"
            ),
        }
    }

    /// `row -= factor * pivot` in the coupling columns.
    fn subtract(&mut self, row: usize, pivot: usize, factor: f64) {
        if factor == 0.0 {
            return;
        }
        let (pivot_start, row_start) = (
            (pivot - self.first_row) * self.columns,
            (row - self.first_row) * self.columns,
        );
        let (before, from_row) = self.entries.split_at_mut(row_start);
        let pivot_entries = &before[pivot_start..pivot_start + self.columns];
        for (target, value) in from_row[..self.columns].iter_mut().zip(pivot_entries) {
            *target -= factor * value;
        }
    }
}

/// The largest `|entry|` (NaN ignored, as `f64::max` does), in lanes the
/// compiler vectorises: the same number as one running maximum, since the
/// maximum does not depend on the order. A pass over the whole storage
/// before every factorisation.
fn largest_magnitude(entries: &[f64]) -> f64 {
    const LANES: usize = 8;
    let mut lanes = [0.0_f64; LANES];
    let chunks = entries.chunks_exact(LANES);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (lane, value) in lanes.iter_mut().zip(chunk) {
            *lane = lane.max(value.abs());
        }
    }
    rest.iter()
        .chain(&lanes)
        .fold(0.0_f64, |largest, value| largest.max(value.abs()))
}

/// `Σ a_i x_i` in four running sums: one sum's chain of additions is the
/// back substitution's bound (each waits for the last), four overlap. A
/// fixed order, so the result does not vary from run to run.
fn dot(a: &[f64], x: &[f64]) -> f64 {
    let mut sums = [0.0_f64; 4];
    let chunks = a.chunks_exact(4).zip(x.chunks_exact(4));
    for (a4, x4) in chunks {
        for lane in 0..4 {
            sums[lane] += a4[lane] * x4[lane];
        }
    }
    let done = a.len() - a.len() % 4;
    let tail: f64 = a[done..].iter().zip(&x[done..]).map(|(a, x)| a * x).sum();
    (sums[0] + sums[1]) + (sums[2] + sums[3]) + tail
}

/// One pivot's elimination: the rows below it, each at `row_step` from
/// the last in the storage (a row's entry in the pivot's column).
struct Elimination {
    pivot_base: usize,
    first_row_base: usize,
    row_step: usize,
    rows: usize,
    /// Columns after the pivot's that the pivot row holds.
    span: usize,
}

/// Subtracts the pivot row from each row below it, storing the factor in
/// the pivot's column. Nearly all of the factorisation's time: the one loop
/// compiled twice (see [`eliminate`]).
#[inline(always)]
fn eliminate_rows(entries: &mut [f64], below: &Elimination) {
    let pivot = entries[below.pivot_base];
    let span = below.span;
    for i in 1..=below.rows {
        let row_base = below.first_row_base + (i - 1) * below.row_step;
        let factor = entries[row_base] / pivot;
        if factor == 0.0 {
            continue;
        }
        entries[row_base] = factor;
        // Columns after the pivot sit at consecutive offsets in both rows
        // (row storage is contiguous in the column). The pivot row is stored
        // before this one, so the two slices are disjoint: the compiler
        // vectorises the update.
        let (before, from_row) = entries.split_at_mut(row_base);
        let pivot_row = &before[below.pivot_base + 1..below.pivot_base + 1 + span];
        let target = &mut from_row[1..=span];
        for (t, p) in target.iter_mut().zip(pivot_row) {
            *t -= factor * p;
        }
    }
}

/// [`eliminate_rows`] in 256-bit vectors where the processor has them:
/// a release build targets the x86-64 baseline (SSE2, two numbers an
/// instruction), and the updates are most of a tensile run's serial time
/// (a third of its wall at 0.09 mm elements, BENCHMARKS.md). Every entry
/// gets the same multiply and subtract in the same order either way (Rust
/// never fuses them), so both give the same bits.
fn eliminate(entries: &mut [f64], below: &Elimination) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the only requirement `target_feature` adds is that the
        // processor has the feature, checked on the line above.
        unsafe { eliminate_avx2(entries, below) };
        return;
    }
    eliminate_rows(entries, below);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn eliminate_avx2(entries: &mut [f64], below: &Elimination) {
    eliminate_rows(entries, below);
}

/// Numbers uniform in [-1, 1) from a seed, the same on every machine: the
/// tests' matrices.
#[cfg(test)]
pub(crate) fn uniform_numbers(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    fn random_banded(
        n: usize,
        lower: usize,
        upper: usize,
        seed: u64,
    ) -> (BandedMatrix, DMatrix<f64>) {
        let mut next = uniform_numbers(seed);
        let mut banded = BandedMatrix::zeros(n, lower, upper);
        let mut dense = DMatrix::zeros(n, n);
        for row in 0..n {
            for column in row.saturating_sub(lower)..=(row + upper).min(n - 1) {
                let value = next();
                banded.add(row, column, value);
                dense[(row, column)] = value;
            }
        }
        (banded, dense)
    }

    #[test]
    fn matches_dense_lu_including_zero_diagonals_that_need_pivoting() {
        for (n, lower, upper, seed) in [(40, 3, 2, 1), (57, 5, 5, 2), (12, 1, 4, 3), (30, 6, 1, 4)]
        {
            let (mut banded, mut dense) = random_banded(n, lower, upper, seed);
            // A zero on the diagonal forces a row swap.
            for k in (0..n).step_by(3) {
                dense[(k, k)] = 0.0;
                let at = banded.offset(k, k);
                banded.entries[at] = 0.0;
            }
            let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
            let expected = dense
                .clone()
                .lu()
                .solve(&DVector::from_vec(rhs.clone()))
                .unwrap();
            let mut x = rhs.clone();
            banded.solve_in_place(&mut x).unwrap();
            let residual = &dense * DVector::from_vec(x.clone()) - DVector::from_vec(rhs);
            assert!(residual.norm() < 1e-9, "residual {}", residual.norm());
            for i in 0..n {
                assert!((x[i] - expected[i]).abs() < 1e-8 * (1.0 + expected[i].abs()));
            }
        }
    }

    #[test]
    fn matches_dense_lu_without_swaps_and_with_a_late_one() {
        // Diagonally dominant (no row swap: the updates stay `upper` wide),
        // then the same with one zero pivot near the end (the width grows
        // from there on).
        for late_zero in [None, Some(33)] {
            let (n, lower, upper) = (45, 4, 3);
            let (mut banded, mut dense) = random_banded(n, lower, upper, 11);
            for k in 0..n {
                let value = if Some(k) == late_zero { 0.0 } else { 10.0 };
                dense[(k, k)] = value;
                let at = banded.offset(k, k);
                banded.entries[at] = value;
            }
            let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.71).cos()).collect();
            let mut x = rhs.clone();
            banded.solve_in_place(&mut x).unwrap();
            let residual = &dense * DVector::from_vec(x) - DVector::from_vec(rhs);
            assert!(
                residual.norm() < 1e-10,
                "{late_zero:?}: residual {}",
                residual.norm()
            );
        }
    }

    #[test]
    fn prescribed_dofs_take_their_value_and_move_columns_to_the_rhs() {
        let (mut banded, dense) = random_banded(20, 2, 2, 9);
        let mut rhs = vec![1.0; 20];
        banded.prescribe(7, 0.25, &mut rhs);
        banded.solve_in_place(&mut rhs).unwrap();
        assert_eq!(rhs[7], 0.25);
        // The other rows satisfy the original equations with x7 = 0.25.
        let x = DVector::from_vec(rhs.clone());
        let r = &dense * x;
        for row in (0..20).filter(|&r| r != 7) {
            assert!((r[row] - 1.0).abs() < 1e-9, "row {row}: {}", r[row]);
        }
    }

    #[test]
    fn a_singular_matrix_is_an_error_not_a_nan() {
        let mut matrix = BandedMatrix::zeros(4, 1, 1);
        matrix.add(0, 0, 1.0);
        matrix.add(1, 1, 1.0);
        let mut rhs = vec![1.0; 4];
        assert_eq!(
            matrix.solve_in_place(&mut rhs),
            Err(SingularMatrix { column: 2 })
        );
    }
}
