//! The bar's stiffness equations cut in two at a row of nodes across the
//! bar: each half a banded block factored at the same time as the other,
//! the cut's unknowns last, through their dense Schur complement.
//!
//! Why: the band LU is the Newton step's one serial part, a third of a
//! run's wall time at 0.09 mm elements (the element evaluations are spread
//! over the cores). Ordered `[near half, far half, cut]`, the matrix is
//!
//! ```text
//! [ A   0   Ac ]    A, B banded (the far half numbered from its end,
//! [ 0   B   Bc ]    so both meet the cut at their last rows);
//! [ Ca  Cb  S  ]    Ac, Bc, Ca, Cb only there; S dense, 2 (radial + 1) wide.
//! ```
//!
//! Each half is factored with its cut columns carried along and its cut
//! rows eliminated by its pivots, on a thread each; then
//! `S - Ca A^-1 Ac - Cb B^-1 Bc` is solved, then each half's back
//! substitution. The arithmetic is the same on one thread or two, so the
//! results do not depend on the thread count. Pivoting stays within a
//! half (a cut row is never a half's pivot), which a stiffness matrix,
//! whose diagonal dominates within each half, does not miss.

use nalgebra::{DMatrix, DVector};

use super::banded::{BandedMatrix, Coupling, Factored, SingularMatrix};

/// Fewer node rows than this and the matrix is not cut.
const MIN_NODE_ROWS_TO_CUT: usize = 8;

/// The stiffness matrix in the order above; rows and columns are the
/// degrees of freedom's global numbers in every method.
#[derive(Clone)]
pub struct SplitBandMatrix {
    size: usize,
    /// The cut's degrees of freedom, `cut.start..cut.end`.
    cut: std::ops::Range<usize>,
    /// The near half (`0..cut.start`) and the far half (`cut.end..size`,
    /// reversed).
    halves: [Half; 2],
    /// The cut's own block, row-major.
    cut_block: Vec<f64>,
    band: usize,
    parallel: bool,
}

#[derive(Clone)]
struct Half {
    matrix: BandedMatrix,
    /// The half's rows' entries in the cut's columns (its last rows).
    to_cut: Coupling,
    /// The cut rows' entries in the half's last `reach` columns, row-major.
    from_cut: Vec<f64>,
    reach: usize,
}

/// Where a global degree of freedom is.
#[derive(Clone, Copy)]
enum Place {
    Half(usize, usize),
    Cut(usize),
}

impl SplitBandMatrix {
    /// A zero matrix of `size` unknowns numbered node row by node row,
    /// `per_node_row` to a row, coupled at most `band` apart. Cut when there
    /// are enough node rows, else one block (the cut empty, the far half
    /// empty).
    pub fn zeros(size: usize, per_node_row: usize, band: usize, parallel: bool) -> Self {
        let node_rows = size / per_node_row;
        let (cut_start, cut_end) = if node_rows >= MIN_NODE_ROWS_TO_CUT {
            let middle = node_rows / 2;
            (middle * per_node_row, (middle + 1) * per_node_row)
        } else {
            (size, size)
        };
        let half = |length: usize| {
            // Coupled rows: the last `band`; a pivot's swap reaches `band`
            // further up.
            let first_row = length.saturating_sub(2 * band);
            let reach = length.min(band);
            let cut = cut_end - cut_start;
            Half {
                matrix: BandedMatrix::zeros(length, band, band),
                to_cut: Coupling::zeros(length, first_row, cut),
                from_cut: vec![0.0; cut * reach],
                reach,
            }
        };
        let cut = cut_end - cut_start;
        SplitBandMatrix {
            size,
            cut: cut_start..cut_end,
            halves: [half(cut_start), half(size - cut_end)],
            cut_block: vec![0.0; cut * cut],
            band,
            parallel,
        }
    }

    fn place(&self, dof: usize) -> Place {
        if dof < self.cut.start {
            Place::Half(0, dof)
        } else if dof < self.cut.end {
            Place::Cut(dof - self.cut.start)
        } else {
            Place::Half(1, self.size - 1 - dof)
        }
    }

    /// The stored entry at (row, column); `None` where the order above
    /// holds a structural zero or the band ends.
    fn entry_mut(&mut self, row: usize, column: usize) -> Option<&mut f64> {
        let cut = self.cut.len();
        match (self.place(row), self.place(column)) {
            (Place::Half(h, r), Place::Half(g, c)) if h == g => {
                self.halves[h].matrix.entry_mut(r, c)
            }
            (Place::Half(h, r), Place::Cut(c)) => {
                let coupling = &mut self.halves[h].to_cut;
                coupling.holds(r).then(|| &mut coupling.row_mut(r)[c])
            }
            (Place::Cut(r), Place::Half(h, c)) => {
                let half = &mut self.halves[h];
                let first = half.matrix.size() - half.reach;
                (c >= first).then(|| &mut half.from_cut[r * half.reach + c - first])
            }
            (Place::Cut(r), Place::Cut(c)) => Some(&mut self.cut_block[r * cut + c]),
            _ => None,
        }
    }

    /// Adds `value` at (row, column), which must be stored (an element
    /// couples degrees of freedom at most `band` apart).
    pub fn add(&mut self, row: usize, column: usize, value: f64) {
        match self.entry_mut(row, column) {
            Some(entry) => *entry += value,
            None => debug_assert!(false, "({row}, {column}) is not stored"),
        }
    }

    /// Adds an element's matrix at its degrees of freedom. An element off
    /// the cut lies in one half, whose band takes it directly.
    pub fn add_element(&mut self, dofs: &[usize; 8], values: &nalgebra::SMatrix<f64, 8, 8>) {
        let places = dofs.map(|dof| self.place(dof));
        if let Place::Half(half, _) = places[0] {
            let locals = places.map(|place| match place {
                Place::Half(h, local) if h == half => Some(local),
                _ => None,
            });
            if locals.iter().all(Option::is_some) {
                let matrix = &mut self.halves[half].matrix;
                for (a, row) in locals.iter().flatten().enumerate() {
                    for (b, column) in locals.iter().flatten().enumerate() {
                        matrix.add(*row, *column, values[(a, b)]);
                    }
                }
                return;
            }
        }
        for (a, &row) in dofs.iter().enumerate() {
            for (b, &column) in dofs.iter().enumerate() {
                self.add(row, column, values[(a, b)]);
            }
        }
    }

    /// Sets every entry to zero, keeping the storage.
    pub fn clear(&mut self) {
        for half in &mut self.halves {
            half.matrix.clear();
            half.to_cut.entries.fill(0.0);
            half.from_cut.fill(0.0);
        }
        self.cut_block.fill(0.0);
    }

    /// Replaces row and column `dof` by the identity: the degree of freedom
    /// is prescribed, each removed column entry times the value moved to
    /// the right-hand side (as [`BandedMatrix::prescribe`]).
    pub fn prescribe(&mut self, dof: usize, value: f64, rhs: &mut [f64]) {
        let first = dof.saturating_sub(self.band);
        let last = (dof + self.band).min(self.size - 1);
        for (other, rhs_other) in rhs.iter_mut().enumerate().take(last + 1).skip(first) {
            if other == dof {
                continue;
            }
            if let Some(entry) = self.entry_mut(other, dof) {
                *rhs_other -= *entry * value;
                *entry = 0.0;
            }
            if let Some(entry) = self.entry_mut(dof, other) {
                *entry = 0.0;
            }
        }
        if let Some(entry) = self.entry_mut(dof, dof) {
            *entry = 1.0;
        }
        rhs[dof] = value;
    }

    /// Solves `A x = rhs` in place (the matrix is overwritten).
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SingularMatrix> {
        let factors = self.factor()?;
        self.solve_factored(&factors, rhs);
        Ok(())
    }

    /// Factors the matrix in place: what [`SplitBandMatrix::solve_factored`]
    /// needs to solve for any number of right-hand sides, each at the cost
    /// of two band substitutions.
    pub fn factor(&mut self) -> Result<SplitFactors, SingularMatrix> {
        let cut = self.cut.clone();
        let size = self.size;
        let [near, far] = &mut self.halves;
        let (near_done, far_done) = if self.parallel {
            rayon::join(|| near.factor(), || far.factor())
        } else {
            (near.factor(), far.factor())
        };
        let (near_factored, near_cut) = near_done?;
        let (far_factored, far_cut) = far_done.map_err(|e| SingularMatrix {
            column: size - 1 - e.column,
        })?;

        // The cut: its block less both halves' shares, factored densely.
        let width = cut.len();
        let schur = (width > 0)
            .then(|| {
                let schur = DMatrix::from_fn(width, width, |r, c| {
                    self.cut_block[r * width + c]
                        + near_cut.share[r * width + c]
                        + far_cut.share[r * width + c]
                });
                let lu = schur.lu();
                lu.is_invertible()
                    .then_some(lu)
                    .ok_or(SingularMatrix { column: cut.start })
            })
            .transpose()?;
        Ok(SplitFactors {
            halves: [
                (near_factored, near_cut.factors),
                (far_factored, far_cut.factors),
            ],
            schur,
        })
    }

    /// Solves `A x = rhs` in place with the factors of this matrix.
    pub fn solve_factored(&self, factors: &SplitFactors, rhs: &mut [f64]) {
        let cut = self.cut.clone();
        let mut near_rhs = rhs[..cut.start].to_vec();
        let mut far_rhs: Vec<f64> = rhs[cut.end..].iter().rev().copied().collect();
        let [near, far] = &self.halves;
        let [near_factors, far_factors] = &factors.halves;
        let near_cut_rhs = near.forward(near_factors, &mut near_rhs);
        let far_cut_rhs = far.forward(far_factors, &mut far_rhs);
        let cut_solution = match &factors.schur {
            Some(lu) => {
                let mut cut_rhs = DVector::from_fn(cut.len(), |r, _| {
                    rhs[cut.start + r] + near_cut_rhs[r] + far_cut_rhs[r]
                });
                let solved = lu.solve_mut(&mut cut_rhs);
                debug_assert!(solved, "checked invertible when factored");
                cut_rhs
            }
            None => DVector::zeros(0),
        };
        let cut_solution = cut_solution.as_slice();
        if self.parallel {
            rayon::join(
                || near.back_substitute(&near_factors.0, &mut near_rhs, cut_solution),
                || far.back_substitute(&far_factors.0, &mut far_rhs, cut_solution),
            );
        } else {
            near.back_substitute(&near_factors.0, &mut near_rhs, cut_solution);
            far.back_substitute(&far_factors.0, &mut far_rhs, cut_solution);
        }
        rhs[..cut.start].copy_from_slice(&near_rhs);
        rhs[cut.clone()].copy_from_slice(cut_solution);
        for (global, value) in rhs[cut.end..].iter_mut().rev().zip(&far_rhs) {
            *global = *value;
        }
    }
}

/// A [`SplitBandMatrix`]'s factorisation: each half's, with the multipliers
/// that eliminated the cut rows' entries in it, and the cut's.
pub struct SplitFactors {
    halves: [(Factored, Vec<f64>); 2],
    schur: Option<nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>>,
}

/// A half's share of the cut's block (row-major) and the multipliers that
/// eliminated the cut rows' entries in the half's last columns (row-major,
/// a cut row's `reach` at a time).
struct CutShare {
    share: Vec<f64>,
    factors: Vec<f64>,
}

impl Half {
    /// Factors the half, carrying its cut columns; then eliminates the cut
    /// rows' entries in its columns with its pivots: what that subtracts
    /// from the cut's block, and the multipliers, which do the same to a
    /// right-hand side.
    fn factor(&mut self) -> Result<(Factored, CutShare), SingularMatrix> {
        let width = self.from_cut.len() / self.reach.max(1);
        let mut share = vec![0.0; width * width];
        let mut factors = vec![0.0; width * self.reach];
        let factored = self.matrix.factor(&mut self.to_cut)?;
        let size = self.matrix.size();
        let first = size - self.reach;
        for row in 0..width {
            let cut_row = &mut self.from_cut[row * self.reach..(row + 1) * self.reach];
            let share_row = &mut share[row * width..(row + 1) * width];
            for k in first..size {
                let (upper, diagonal) = self.matrix.upper_row(&factored, k);
                let factor = cut_row[k - first] / diagonal;
                factors[row * self.reach + k - first] = factor;
                if factor == 0.0 {
                    continue;
                }
                for (target, value) in cut_row[k - first + 1..].iter_mut().zip(upper) {
                    *target -= factor * value;
                }
                for (target, value) in share_row.iter_mut().zip(self.to_cut.row(k)) {
                    *target -= factor * value;
                }
            }
        }
        Ok((factored, CutShare { share, factors }))
    }

    /// The forward half of a solve: `rhs` becomes `L^-1 P rhs`; what the
    /// cut rows' elimination subtracts from the cut's right-hand side.
    fn forward(&self, (factored, factors): &(Factored, Vec<f64>), rhs: &mut [f64]) -> Vec<f64> {
        self.matrix.forward(factored, rhs);
        let size = self.matrix.size();
        let first = size - self.reach;
        factors
            .chunks_exact(self.reach.max(1))
            .map(|row| {
                let mut share = 0.0;
                for (k, factor) in (first..size).zip(row) {
                    if *factor != 0.0 {
                        share -= factor * rhs[k];
                    }
                }
                share
            })
            .collect()
    }

    /// `x = U^-1 (y - U_cut x_cut)`.
    fn back_substitute(&self, factored: &Factored, rhs: &mut [f64], cut_solution: &[f64]) {
        for (k, value) in rhs.iter_mut().enumerate() {
            if self.to_cut.holds(k) {
                let coupled: f64 = self
                    .to_cut
                    .row(k)
                    .iter()
                    .zip(cut_solution)
                    .map(|(a, x)| a * x)
                    .sum();
                *value -= coupled;
            }
        }
        self.matrix.back_substitute(factored, rhs);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A matrix shaped like the bar's: `per_node_row` unknowns a node row,
    /// each coupled with its own node row and the next, diagonally strong.
    fn bar_like(node_rows: usize, per_node_row: usize, seed: u64) -> DMatrix<f64> {
        let size = node_rows * per_node_row;
        let mut next = crate::tensile::banded::uniform_numbers(seed);
        DMatrix::from_fn(size, size, |r, c| {
            let (node_r, node_c) = (r / per_node_row, c / per_node_row);
            if node_r.abs_diff(node_c) > 1 || r.abs_diff(c) > 2 * per_node_row {
                0.0
            } else if r == c {
                8.0 * per_node_row as f64 + next()
            } else {
                next()
            }
        })
    }

    fn split_of(dense: &DMatrix<f64>, per_node_row: usize, parallel: bool) -> SplitBandMatrix {
        let size = dense.nrows();
        let band = 2 * per_node_row;
        let mut split = SplitBandMatrix::zeros(size, per_node_row, band, parallel);
        for r in 0..size {
            for c in 0..size {
                if dense[(r, c)] != 0.0 {
                    split.add(r, c, dense[(r, c)]);
                }
            }
        }
        split
    }

    #[test]
    fn solves_as_a_dense_lu_does_cut_or_not_on_one_thread_or_two() {
        for (node_rows, per_node_row, seed) in [(12, 4, 1), (9, 6, 2), (5, 4, 3), (20, 2, 4)] {
            let dense = bar_like(node_rows, per_node_row, seed);
            let size = dense.nrows();
            let rhs: Vec<f64> = (0..size).map(|i| (i as f64 * 0.37).sin()).collect();
            let expected = dense
                .clone()
                .lu()
                .solve(&DVector::from_vec(rhs.clone()))
                .expect("regular");
            let mut answers = Vec::new();
            for parallel in [false, true] {
                let mut split = split_of(&dense, per_node_row, parallel);
                let mut x = rhs.clone();
                split.solve_in_place(&mut x).expect("regular");
                for i in 0..size {
                    assert!(
                        (x[i] - expected[i]).abs() < 1e-10 * (1.0 + expected[i].abs()),
                        "{node_rows} x {per_node_row}, unknown {i}: {} against {}",
                        x[i],
                        expected[i]
                    );
                }
                answers.push(x);
            }
            assert_eq!(answers[0], answers[1], "the thread count changed the bits");
        }
    }

    #[test]
    fn one_factorisation_solves_many_right_hand_sides_with_pivots_in_both_halves() {
        let (node_rows, per_node_row) = (12, 4);
        let mut dense = bar_like(node_rows, per_node_row, 5);
        let size = dense.nrows();
        // Weak diagonals away from the cut: rows swap in both halves.
        for dof in [2, 9, 13, size - 3, size - 10] {
            dense[(dof, dof)] = 0.01;
        }
        let mut factored = split_of(&dense, per_node_row, true);
        let factors = factored.factor().expect("regular");
        for (half, (factors, _)) in factors.halves.iter().enumerate() {
            assert!(factors.swaps() > 0, "half {half} swapped no rows");
        }
        for seed in 0..4 {
            let rhs: Vec<f64> = (0..size)
                .map(|i| (i as f64 * 0.37 + seed as f64).sin())
                .collect();
            let expected = dense
                .clone()
                .lu()
                .solve(&DVector::from_vec(rhs.clone()))
                .expect("regular");
            let mut x = rhs.clone();
            factored.solve_factored(&factors, &mut x);
            for i in 0..size {
                assert!(
                    (x[i] - expected[i]).abs() < 1e-9 * (1.0 + expected[i].abs()),
                    "right-hand side {seed}, unknown {i}: {} against {}",
                    x[i],
                    expected[i]
                );
            }
            // The same bits as a factorisation of its own.
            let mut alone = rhs.clone();
            split_of(&dense, per_node_row, false)
                .solve_in_place(&mut alone)
                .expect("regular");
            assert_eq!(x, alone, "right-hand side {seed}");
        }
    }

    #[test]
    fn prescribed_dofs_in_either_half_and_in_the_cut_take_their_values() {
        let (node_rows, per_node_row) = (12, 4);
        let dense = bar_like(node_rows, per_node_row, 7);
        let size = dense.nrows();
        let mut split = split_of(&dense, per_node_row, true);
        let mut rhs = vec![1.0; size];
        // Near half, the cut (node row 6), the far half's last node row.
        let prescribed = [(1, 0.5), (25, -0.25), (26, 0.125), (size - 2, 2.0)];
        for &(dof, value) in &prescribed {
            split.prescribe(dof, value, &mut rhs);
        }
        split.solve_in_place(&mut rhs).expect("regular");
        let x = DVector::from_vec(rhs.clone());
        for &(dof, value) in &prescribed {
            assert_eq!(x[dof], value);
        }
        let product = &dense * &x;
        for row in (0..size).filter(|r| prescribed.iter().all(|(dof, _)| dof != r)) {
            assert!(
                (product[row] - 1.0).abs() < 1e-9,
                "row {row}: {}",
                product[row]
            );
        }
    }

    #[test]
    fn a_singular_half_is_an_error_naming_a_global_column() {
        let (node_rows, per_node_row) = (12, 4);
        let mut dense = bar_like(node_rows, per_node_row, 9);
        let size = dense.nrows();
        // The far half's last unknown decoupled and zero: singular there.
        for i in 0..size {
            dense[(size - 1, i)] = 0.0;
            dense[(i, size - 1)] = 0.0;
        }
        let mut split = split_of(&dense, per_node_row, false);
        let mut rhs = vec![1.0; size];
        let error = split.solve_in_place(&mut rhs).expect_err("singular");
        assert_eq!(error.column, size - 1);
    }
}
