//! Finite-strain kinematics of an axisymmetric body, and the logarithmic
//! strain with its exact derivative.
//!
//! Coordinates are (r, z, theta). A deformation gradient of an axisymmetric
//! deformation has five non-zero components, `F = [F_rr F_rz; F_zr F_zz]
//! (+) F_tt`, with `F_ij = d x_i / d X_j` and `F_tt = r / R`; a symmetric
//! tensor (b, tau, eps) has four, `[rr, zz, tt, rz]` (tensor components, the
//! shear counted once). Theta is always a principal direction, so the
//! spectral work is a closed-form 2 x 2 eigenproblem plus the hoop value.
//!
//! The elastic-predictor / return-mapping scheme (Eterovic-Bathe, Simo,
//! de Souza Neto et al. ch. 14) needs `eps_trial = 1/2 ln(b_trial)` with
//! `b_trial = F G F^T`, `G = C_p^-1` frozen over the step, and its
//! derivative with respect to F for the consistent tangent. The derivative
//! of the tensor logarithm is the Daleckii-Krein formula
//! `d ln(b)[H] = sum_ij g(l_i, l_j) (n_i . H n_j) n_i (x) n_j`, with
//! `g = (ln l_i - ln l_j) / (l_i - l_j)`, `g(l, l) = 1 / l`.

use nalgebra::{Matrix2, SMatrix, SVector};

/// Deformation-gradient components `[rr, rz, zr, zz, tt]`.
pub type Gradient = SVector<f64, 5>;
/// Symmetric-tensor components `[rr, zz, tt, rz]`.
pub type Symmetric = SVector<f64, 4>;

pub const RR: usize = 0;
pub const RZ: usize = 1;
pub const ZR: usize = 2;
pub const ZZ: usize = 3;
pub const TT: usize = 4;

/// The identity deformation gradient.
pub fn identity_gradient() -> Gradient {
    Gradient::new(1.0, 0.0, 0.0, 1.0, 1.0)
}

/// The identity as a symmetric tensor.
pub fn identity_symmetric() -> Symmetric {
    Symmetric::new(1.0, 1.0, 1.0, 0.0)
}

fn in_plane(f: &Gradient) -> Matrix2<f64> {
    Matrix2::new(f[RR], f[RZ], f[ZR], f[ZZ])
}

fn symmetric_in_plane(s: &Symmetric) -> Matrix2<f64> {
    Matrix2::new(s[0], s[3], s[3], s[1])
}

/// det F (the volume ratio J).
pub fn determinant(f: &Gradient) -> f64 {
    (f[RR] * f[ZZ] - f[RZ] * f[ZR]) * f[TT]
}

/// dJ/dF in gradient components: the cofactor `J F^-T`.
pub fn determinant_derivative(f: &Gradient) -> Gradient {
    let planar = f[RR] * f[ZZ] - f[RZ] * f[ZR];
    Gradient::new(
        f[ZZ] * f[TT],
        -f[ZR] * f[TT],
        -f[RZ] * f[TT],
        f[RR] * f[TT],
        planar,
    )
}

/// F^-1 in gradient components, or None when F is singular.
pub fn inverse(f: &Gradient) -> Option<Gradient> {
    let planar = f[RR] * f[ZZ] - f[RZ] * f[ZR];
    if planar == 0.0 || f[TT] == 0.0 || !planar.is_finite() {
        return None;
    }
    Some(Gradient::new(
        f[ZZ] / planar,
        -f[RZ] / planar,
        -f[ZR] / planar,
        f[RR] / planar,
        1.0 / f[TT],
    ))
}

/// `F S F^T` for a symmetric S.
pub fn push_forward(f: &Gradient, s: &Symmetric) -> Symmetric {
    let f2 = in_plane(f);
    let product = f2 * symmetric_in_plane(s) * f2.transpose();
    Symmetric::new(
        product[(0, 0)],
        product[(1, 1)],
        f[TT] * f[TT] * s[2],
        0.5 * (product[(0, 1)] + product[(1, 0)]),
    )
}

/// d(F S F^T)/dF for a fixed symmetric S, as a 4 x 5 matrix.
pub fn push_forward_derivative(f: &Gradient, s: &Symmetric) -> SMatrix<f64, 4, 5> {
    let f2 = in_plane(f);
    let s2 = symmetric_in_plane(s);
    let mut derivative = SMatrix::<f64, 4, 5>::zeros();
    // In-plane: d(F S F^T)[E] = E S F^T + F S E^T for each unit E.
    for (column, (i, j)) in [(RR, (0, 0)), (RZ, (0, 1)), (ZR, (1, 0)), (ZZ, (1, 1))] {
        let mut unit = Matrix2::zeros();
        unit[(i, j)] = 1.0;
        let variation = unit * s2 * f2.transpose() + f2 * s2 * unit.transpose();
        derivative[(0, column)] = variation[(0, 0)];
        derivative[(1, column)] = variation[(1, 1)];
        derivative[(3, column)] = variation[(0, 1)];
    }
    derivative[(2, TT)] = 2.0 * f[TT] * s[2];
    derivative
}

/// `S^-1` of a symmetric tensor, or None when singular.
pub fn symmetric_inverse(s: &Symmetric) -> Option<Symmetric> {
    let planar = s[0] * s[1] - s[3] * s[3];
    if planar == 0.0 || s[2] == 0.0 || !planar.is_finite() {
        return None;
    }
    Some(Symmetric::new(
        s[1] / planar,
        s[0] / planar,
        1.0 / s[2],
        -s[3] / planar,
    ))
}

/// `F^-1 S F^-T`: pulls a spatial symmetric tensor back.
pub fn pull_back(f_inverse: &Gradient, s: &Symmetric) -> Symmetric {
    push_forward(f_inverse, s)
}

/// Spectral decomposition of the in-plane block: eigenvalues (largest
/// first) and the rotation whose columns are the eigenvectors.
fn in_plane_spectrum(s: &Symmetric) -> ([f64; 2], Matrix2<f64>) {
    let mean = 0.5 * (s[0] + s[1]);
    let half_difference = 0.5 * (s[0] - s[1]);
    // Strains and stresses are far from overflow: no hypot needed.
    let radius = (half_difference * half_difference + s[3] * s[3]).sqrt();
    // The rotation by half the angle whose cosine and sine are these,
    // without trigonometric calls (they were 4 % of a run); each branch
    // takes the root of an argument of at least one half, so stays exact.
    let (cos_double, sin_double) = if radius > 0.0 {
        (half_difference / radius, s[3] / radius)
    } else {
        (1.0, 0.0)
    };
    let (sin, cos) = if cos_double >= 0.0 {
        let cos = (0.5 * (1.0 + cos_double)).sqrt();
        (0.5 * sin_double / cos, cos)
    } else {
        let sin = (0.5 * (1.0 - cos_double)).sqrt().copysign(sin_double);
        (sin, 0.5 * sin_double / sin)
    };
    (
        [mean + radius, mean - radius],
        Matrix2::new(cos, -sin, sin, cos),
    )
}

fn from_principal(values: [f64; 2], hoop: f64, rotation: &Matrix2<f64>) -> Symmetric {
    let diagonal = Matrix2::new(values[0], 0.0, 0.0, values[1]);
    let tensor = rotation * diagonal * rotation.transpose();
    Symmetric::new(
        tensor[(0, 0)],
        tensor[(1, 1)],
        hoop,
        0.5 * (tensor[(0, 1)] + tensor[(1, 0)]),
    )
}

/// Divided difference of ln: `(ln a - ln b) / (a - b)`, `1 / a` when equal.
fn log_divided_difference(a: f64, b: f64) -> f64 {
    let relative = (a - b) / (a + b);
    if relative.abs() < 1e-4 {
        // Series of 2 atanh(x)/x / (a+b) around x = 0: exact to O(x^4).
        let x2 = relative * relative;
        2.0 / (a + b) * (1.0 + x2 / 3.0 + x2 * x2 / 5.0)
    } else {
        (a.ln() - b.ln()) / (a - b)
    }
}

/// The logarithmic strain `1/2 ln(b)` of a symmetric positive-definite b.
/// None when b is not positive definite.
pub fn log_strain(b: &Symmetric) -> Option<Symmetric> {
    log_strain_and_spectrum(b).map(|(strain, _, _)| strain)
}

/// The strain, and the in-plane eigenvalues and rotation of b.
fn log_strain_and_spectrum(b: &Symmetric) -> Option<(Symmetric, [f64; 2], Matrix2<f64>)> {
    let (values, rotation) = in_plane_spectrum(b);
    if !(values[1] > 0.0 && b[2] > 0.0 && values[0].is_finite()) {
        return None;
    }
    let logs = [values[0].ln(), values[1].ln()];
    let strain = from_principal([0.5 * logs[0], 0.5 * logs[1]], 0.5 * b[2].ln(), &rotation);
    Some((strain, values, rotation))
}

/// [`log_strain`] and its derivative `d eps / d b` (4 x 4; the rz column is
/// the variation of the shared rz = zr component).
pub fn log_strain_with_derivative(b: &Symmetric) -> Option<(Symmetric, SMatrix<f64, 4, 4>)> {
    let (strain, values, rotation) = log_strain_and_spectrum(b)?;
    let divided = [
        [
            1.0 / values[0],
            log_divided_difference(values[0], values[1]),
        ],
        [
            log_divided_difference(values[0], values[1]),
            1.0 / values[1],
        ],
    ];
    let mut derivative = SMatrix::<f64, 4, 4>::zeros();
    for (column, unit) in [
        (0, Matrix2::new(1.0, 0.0, 0.0, 0.0)),
        (1, Matrix2::new(0.0, 0.0, 0.0, 1.0)),
        (3, Matrix2::new(0.0, 1.0, 1.0, 0.0)),
    ] {
        let mut principal = rotation.transpose() * unit * rotation;
        for i in 0..2 {
            for j in 0..2 {
                principal[(i, j)] *= 0.5 * divided[i][j];
            }
        }
        let variation = rotation * principal * rotation.transpose();
        derivative[(0, column)] = variation[(0, 0)];
        derivative[(1, column)] = variation[(1, 1)];
        derivative[(3, column)] = 0.5 * (variation[(0, 1)] + variation[(1, 0)]);
    }
    derivative[(2, 2)] = 0.5 / b[2];
    Some((strain, derivative))
}

/// `b = exp(2 eps)`: the left Cauchy-Green tensor of a logarithmic strain.
pub fn stretch_from_log_strain(strain: &Symmetric) -> Symmetric {
    let (values, rotation) = in_plane_spectrum(strain);
    from_principal(
        [(2.0 * values[0]).exp(), (2.0 * values[1]).exp()],
        (2.0 * strain[2]).exp(),
        &rotation,
    )
}

/// `S F^-T` in gradient components (the first Piola-Kirchhoff form of a
/// Kirchhoff stress when scaled by nothing else).
pub fn times_inverse_transpose(s: &Symmetric, f_inverse: &Gradient) -> Gradient {
    let product = symmetric_in_plane(s) * in_plane(f_inverse).transpose();
    Gradient::new(
        product[(0, 0)],
        product[(0, 1)],
        product[(1, 0)],
        product[(1, 1)],
        s[2] * f_inverse[TT],
    )
}

/// d(S F^-T)/dS at fixed F (5 x 4).
pub fn times_inverse_transpose_by_stress(f_inverse: &Gradient) -> SMatrix<f64, 5, 4> {
    let mut derivative = SMatrix::<f64, 5, 4>::zeros();
    for column in 0..4 {
        let mut unit = Symmetric::zeros();
        unit[column] = 1.0;
        derivative.set_column(column, &times_inverse_transpose(&unit, f_inverse));
    }
    derivative
}

/// d(S F^-T)/dF at fixed S (5 x 5): `-S F^-T dF^T F^-T`.
pub fn times_inverse_transpose_by_gradient(
    s: &Symmetric,
    f_inverse: &Gradient,
) -> SMatrix<f64, 5, 5> {
    let s2 = symmetric_in_plane(s);
    let inv_t = in_plane(f_inverse).transpose();
    let mut derivative = SMatrix::<f64, 5, 5>::zeros();
    for (column, (i, j)) in [(RR, (0, 0)), (RZ, (0, 1)), (ZR, (1, 0)), (ZZ, (1, 1))] {
        let mut unit = Matrix2::zeros();
        unit[(i, j)] = 1.0;
        let variation = -(s2 * inv_t * unit.transpose() * inv_t);
        derivative[(RR, column)] = variation[(0, 0)];
        derivative[(RZ, column)] = variation[(0, 1)];
        derivative[(ZR, column)] = variation[(1, 0)];
        derivative[(ZZ, column)] = variation[(1, 1)];
    }
    derivative[(TT, TT)] = -s[2] * f_inverse[TT] * f_inverse[TT];
    derivative
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_gradient() -> Gradient {
        Gradient::new(1.12, 0.07, -0.04, 0.93, 1.05)
    }

    fn numeric_columns<const R: usize, const C: usize>(
        at: SVector<f64, C>,
        f: impl Fn(&SVector<f64, C>) -> SVector<f64, R>,
    ) -> SMatrix<f64, R, C> {
        let mut derivative = SMatrix::<f64, R, C>::zeros();
        for column in 0..C {
            let step = 1e-6;
            let mut plus = at;
            let mut minus = at;
            plus[column] += step;
            minus[column] -= step;
            derivative.set_column(column, &((f(&plus) - f(&minus)) / (2.0 * step)));
        }
        derivative
    }

    #[test]
    fn log_strain_of_a_principal_stretch_is_the_log() {
        let b = Symmetric::new(1.21, 0.81, 1.1, 0.0);
        let strain = log_strain(&b).unwrap();
        assert!((strain[0] - 1.1_f64.ln()).abs() < 1e-15);
        assert!((strain[1] - 0.9_f64.ln()).abs() < 1e-15);
        assert!((strain[2] - 0.5 * 1.1_f64.ln()).abs() < 1e-15);
        assert!(strain[3].abs() < 1e-15);
    }

    #[test]
    fn log_and_exp_are_inverse_including_shear() {
        let f = sample_gradient();
        let b = push_forward(&f, &identity_symmetric());
        let strain = log_strain(&b).unwrap();
        let back = stretch_from_log_strain(&strain);
        assert!((back - b).norm() < 1e-14);
    }

    #[test]
    fn log_strain_derivative_matches_finite_differences() {
        for b in [
            Symmetric::new(1.3, 0.8, 1.1, 0.2),
            Symmetric::new(1.0, 1.0, 1.0, 0.0),
            Symmetric::new(1.0, 1.0 + 1e-9, 0.7, 0.0),
            Symmetric::new(2.4, 0.5, 0.6, -0.3),
        ] {
            let (strain, analytic) = log_strain_with_derivative(&b).unwrap();
            assert_eq!(Some(strain), log_strain(&b));
            let numeric = numeric_columns(b, |x| log_strain(x).unwrap());
            assert!(
                (analytic - numeric).norm() < 1e-8,
                "{b}: {analytic} vs {numeric}"
            );
        }
    }

    #[test]
    fn push_forward_and_piola_derivatives_match_finite_differences() {
        let s = Symmetric::new(1.2, 0.9, 1.05, 0.1);
        let f = sample_gradient();
        let numeric = numeric_columns(f, |x| push_forward(x, &s));
        assert!((push_forward_derivative(&f, &s) - numeric).norm() < 1e-8);

        let f_inverse = inverse(&f).unwrap();
        let numeric = numeric_columns(f, |x| times_inverse_transpose(&s, &inverse(x).unwrap()));
        assert!((times_inverse_transpose_by_gradient(&s, &f_inverse) - numeric).norm() < 1e-8);

        let numeric = numeric_columns(f, |x| determinant(x) * Gradient::repeat(1.0));
        let analytic = determinant_derivative(&f);
        for column in 0..5 {
            assert!((numeric[(0, column)] - analytic[column]).abs() < 1e-8);
        }
    }

    #[test]
    fn inverse_is_the_inverse() {
        let f = sample_gradient();
        let f_inverse = inverse(&f).unwrap();
        let product = in_plane(&f) * in_plane(&f_inverse);
        assert!((product - Matrix2::identity()).norm() < 1e-15);
        assert!((f[TT] * f_inverse[TT] - 1.0).abs() < 1e-15);
        assert!(inverse(&Gradient::new(1.0, 2.0, 0.5, 1.0, 1.0)).is_none());
    }
}
