//! The GTN return mapping's 4 x 4 local systems: Gaussian elimination with
//! partial pivoting, written out for the fixed size.
//!
//! Why by hand: every plastic Gauss point factors its local Jacobian once
//! per Newton iteration and once more for its tangent, millions of times a
//! run. nalgebra's `lu()` is generic over the size (views, permutation
//! sequences) and took 13 % of a tensile run's CPU with its `solve`; this
//! one keeps the 16 numbers in registers and divides once a column. The
//! pivots are nalgebra's (the largest entry of the column, the first of
//! equals; a column without one is singular, and so is the solve).

use nalgebra::{Matrix4, Vector4};

/// The factors of `P A = L U`: L below the diagonal (its unit diagonal
/// implied), U on and above it, the rows in pivot order.
#[derive(Clone, Copy, Debug)]
pub struct LocalLu {
    factors: [[f64; 4]; 4],
    /// Row `i` of the factors came from row `rows[i]` of the matrix.
    rows: [usize; 4],
    /// `1 / U[i][i]`.
    reciprocals: [f64; 4],
}

impl LocalLu {
    /// Factors `matrix`; `None` when a column has no non-zero pivot (the
    /// matrix is singular). Non-finite entries pass through to the
    /// solution, as nalgebra's would.
    pub fn new(matrix: &Matrix4<f64>) -> Option<Self> {
        let mut a: [[f64; 4]; 4] = std::array::from_fn(|i| std::array::from_fn(|j| matrix[(i, j)]));
        let mut rows = [0, 1, 2, 3];
        let mut reciprocals = [0.0; 4];
        for k in 0..4 {
            // The pivot by compare-and-swap down the column: every index is
            // a constant once the loops unroll, so the rows stay in
            // registers (a swap with the pivot's index found first went
            // through memory, and cost most of the factorisation). The rows
            // below the pivot end in another order than one swap leaves
            // them, which changes nothing: each is eliminated alike.
            for i in k + 1..4 {
                if a[i][k].abs() > a[k][k].abs() {
                    a.swap(k, i);
                    rows.swap(k, i);
                }
            }
            if a[k][k] == 0.0 {
                return None;
            }
            let pivot = a[k];
            // One division a column instead of one a row: the chain of
            // eliminations is latency-bound, and a division is its slowest link.
            let reciprocal = 1.0 / pivot[k];
            reciprocals[k] = reciprocal;
            for row in a.iter_mut().skip(k + 1) {
                let factor = row[k] * reciprocal;
                row[k] = factor;
                for j in k + 1..4 {
                    row[j] -= factor * pivot[j];
                }
            }
        }
        Some(LocalLu {
            factors: a,
            rows,
            reciprocals,
        })
    }

    /// `x` with `A x = rhs`.
    pub fn solve(&self, rhs: &Vector4<f64>) -> Vector4<f64> {
        let a = &self.factors;
        let mut x = [0.0; 4];
        for i in 0..4 {
            let mut sum = rhs[self.rows[i]];
            for j in 0..i {
                sum -= a[i][j] * x[j];
            }
            x[i] = sum;
        }
        for i in (0..4).rev() {
            let mut sum = x[i];
            for j in i + 1..4 {
                sum -= a[i][j] * x[j];
            }
            x[i] = sum * self.reciprocals[i];
        }
        Vector4::new(x[0], x[1], x[2], x[3])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_as_nalgebra_does_to_rounding_including_systems_that_need_a_row_swap() {
        let matrices = [
            Matrix4::new(
                2.0, 1.0, -1.0, 0.5, //
                -3.0, -1.0, 2.0, 1.0, //
                -2.0, 1.0, 2.0, -0.3, //
                0.7, 0.2, -0.1, 4.0,
            ),
            // A zero in the first pivot's place, and rows of very different sizes.
            Matrix4::new(
                0.0, 3.0e5, 1.0, 2.0, //
                1.0e-3, 2.0, 0.0, 1.0, //
                4.0, -1.0, 7.0e4, 0.0, //
                -0.0, 0.0, 1.0, 1.0e-6,
            ),
        ];
        let rhs = Vector4::new(1.0, -2.0, 0.5, 3.0);
        for matrix in matrices {
            let expected = matrix.lu().solve(&rhs).expect("regular");
            let solved = LocalLu::new(&matrix).expect("regular").solve(&rhs);
            let residual = (matrix * solved - rhs).norm();
            assert!(residual < 1e-9 * rhs.norm(), "residual {residual}");
            for i in 0..4 {
                assert!(
                    (solved[i] - expected[i]).abs() <= 1e-12 * expected[i].abs().max(1e-9),
                    "{i}: {} against nalgebra's {}",
                    solved[i],
                    expected[i]
                );
            }
        }
    }

    #[test]
    fn a_singular_matrix_has_no_factors_and_nan_passes_through() {
        let mut singular = Matrix4::identity();
        singular[(2, 2)] = 0.0;
        assert!(LocalLu::new(&singular).is_none());
        assert!(singular.lu().solve(&Vector4::zeros()).is_none());

        let mut with_nan = Matrix4::identity();
        with_nan[(1, 1)] = f64::NAN;
        let solved = LocalLu::new(&with_nan)
            .expect("NaN is not a zero pivot")
            .solve(&Vector4::repeat(1.0));
        assert!(solved[1].is_nan());
    }
}
