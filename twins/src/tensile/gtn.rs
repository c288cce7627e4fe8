//! Gurson-Tvergaard-Needleman (GTN) porous plasticity at one material point:
//! the implicit (backward-Euler) stress update of Aravas (1987) and its
//! consistent tangent, in small-strain form. The tensile twin calls it in
//! logarithmic-strain space (rotated frame), where the same algebra holds.
//!
//! # Notation
//!
//! Symmetric tensors are 6-vectors in **Mandel notation**
//! `[11, 22, 33, √2·23, √2·13, √2·12]` ([`Mandel`]), so `A:B` is a plain dot
//! product and a fourth-order tensor with minor symmetries is a plain 6×6
//! matrix ([`MandelTangent`]). Stress is positive in tension. Mean stress
//! `p = tr(σ)/3`, deviator `s = σ - p I`, von Mises stress `q = √(3/2 s:s)`.
//!
//! # Model
//!
//! - Isotropic elasticity: `σ = K tr(ε_e) I + 2G dev(ε_e)`.
//! - Yield function (f* the effective porosity, σ_y the matrix flow stress
//!   from [`FlowCurve`]):
//!   `Φ = (q/σ_y)² + 2 q1 f* cosh(3 q2 p / (2 σ_y)) - 1 - q3 f*² = 0`.
//! - Normality: `Δε_p = Δλ ∂Φ/∂σ = Δε_p^vol I/3 + Δε_q n`, `n = 3/2 s/q`.
//! - Matrix plastic work equivalence: `(1 - f) σ_y Δε_m = σ : Δε_p`.
//! - Porosity: growth plus strain-controlled nucleation,
//!   `Δf = (1 - f) tr(Δε_p) + A(ε_m) Δε_m`,
//!   `A = fN / (sN √(2π)) exp(-½ ((ε_m - εN)/sN)²)`.
//! - Coalescence (optional, Tvergaard-Needleman): `f* = f` below `f_c`,
//!   `f* = f_c + κ (f - f_c)` above, `κ = (f_u* - f_c)/(f_F - f_c)`.
//!
//! Void growth follows the sign of the mean stress (normality makes
//! `tr(Δε_p)` have the sign of `p`): voids grow under tension and close under
//! compression. Closure is self-limiting: the volumetric flow is proportional to
//! f*, so the implicit update keeps `f > 0`; iterates are also kept in
//! `[0, failure)`, and a porosity below [`NEGLIGIBLE_POROSITY`] is set to 0.
//! Nucleation needs `Δε_m > 0`, which the work equivalence guarantees.
//!
//! # Algorithm ([`GtnMaterial::update`])
//!
//! Elastic predictor `σ_tr = C : ε_tr`; if `Φ(p_tr, q_tr, σ_y(ε_m,n), f_n) <= tol`
//! the step is elastic. Otherwise the flow direction `n = 3/2 s_tr/q_tr` is
//! kept (it is exact for this yield function) and, with `p = p_tr - K Δε_p`,
//! `q = q_tr - 3G Δε_q`, Newton's method solves the four equations
//!
//! ```text
//! R1 = Δε_p ∂Φ/∂q - Δε_q ∂Φ/∂p                        = 0  (normality; times σ_y)
//! R2 = Φ(p, q, σ_y(ε_m), f*(f))                        = 0  (consistency)
//! R3 = (1 - f)(ε_m - ε_m,n) - (p Δε_p + q Δε_q)/σ_y    = 0  (work equivalence / σ_y)
//! R4 = f - f_n - (1 - f) Δε_p - A(ε_m)(ε_m - ε_m,n)    = 0  (porosity)
//! ```
//!
//! simultaneously for `(Δε_p, Δε_q, Δε_m, Δf)` (increments, not totals, so a
//! relative tolerance is meaningful for tiny steps) with the analytic Jacobian.
//! Everything, including the nucleation intensity `A`, is evaluated at `t_{n+1}`
//! (fully implicit); `dA/dε_m` is in the Jacobian. The start is a radial return
//! onto the yield surface of the state at `t_n`; a projected Newton step
//! (`Δε_q ∈ [0, q_tr/3G]`, `Δε_m >= 0`, `f ∈ [0, failure)`) with backtracking on
//! the residual norm globalises it.
//!
//! # Consistent tangent
//!
//! At convergence `R(x; p_tr, q_tr) = 0`, so `J dx = -∂R/∂p_tr dp_tr - ∂R/∂q_tr dq_tr`.
//! With `dp_tr = K I:dε`, `dq_tr = 2G n:dε` and `σ = p I + (2/3) q n`:
//!
//! ```text
//! D = I ⊗ dp/dε + (2/3) n ⊗ dq/dε + 2G (q/q_tr)(I_dev - (2/3) n ⊗ n)
//! ```
//!
//! D is symmetric only in the J2 limit; it is returned as is.
//!
//! # Kirchhoff stress in, Cauchy stress in the yield function
//!
//! At finite strain the element hands over the Kirchhoff stress `τ = J σ`
//! (the exponential-map integrator works in τ). The yield function and the
//! work equivalence of the reference are written in the Cauchy stress σ, and
//! a porous material changes volume (J = 1.05 at f = 5 %), so the difference
//! is not negligible after the peak. Φ is homogeneous of degree zero in
//! (σ, σ_y) and the work equivalence of degree one, so `Φ(τ/J, σ_y) =
//! Φ(τ, J σ_y)` and `σ : Δε_p = (1-f) σ_y Δε_m` becomes `τ : Δε_p = (1-f) J σ_y
//! Δε_m`: [`GtnMaterial::update_at_volume_ratio`] runs the same return mapping
//! with the flow stress (and its slope) scaled by the volume ratio J, and
//! returns `∂τ/∂J` for the element's tangent. [`GtnMaterial::update`] is the
//! small-strain case J = 1.
//!
//! # Failure
//!
//! A point fails when its porosity reaches [`FAILURE_FRACTION`] of
//! [`GtnParameters::failure_porosity`] (or the update would push it beyond):
//! it then carries no stress and has zero tangent for good; the caller adds a
//! residual stiffness.

use nalgebra::{Matrix3, Matrix4, SMatrix, SVector, Vector4};
use serde::{Deserialize, Serialize};

use super::flow_curve::FlowCurve;
use super::local_lu::LocalLu;

/// A symmetric second-order tensor in Mandel notation
/// `[11, 22, 33, √2·23, √2·13, √2·12]`.
pub type Mandel = SVector<f64, 6>;

/// A fourth-order tensor with minor symmetries in Mandel notation.
pub type MandelTangent = SMatrix<f64, 6, 6>;

/// A point fails once its porosity reaches this fraction of the failure
/// porosity: the remaining strength is then about 1 % of the matrix's and the
/// return mapping becomes ill-conditioned.
pub const FAILURE_FRACTION: f64 = 0.99;

/// A trial state with `Φ` at or below this (Φ is dimensionless, ~ relative
/// stress error × 2) is elastic.
pub const YIELD_TOLERANCE: f64 = 1e-10;

/// Newton stops when every residual, scaled to the size of the increments, is
/// below this; one more full Newton step then polishes to rounding.
pub const RESIDUAL_TOLERANCE: f64 = 1e-10;
/// A scaled residual this small needs no polishing step (see
/// `solve_return_mapping`): rounding, for the tangent's purpose.
const POLISHED_RESIDUAL: f64 = 1e-13;

/// A scaled residual this small is accepted when the Newton step no longer
/// changes any unknown beyond rounding (see `solve_return_mapping`).
const ROUNDING_FLOOR_RESIDUAL: f64 = 1e-6;

/// A porosity below this is zero. Voids that compression has closed to this
/// level mean nothing physically, yet their cosh term still yields at
/// |p| ~ 20-60 σ_y where the local equations lose all precision.
pub const NEGLIGIBLE_POROSITY: f64 = 1e-12;

/// A Newton step below this fraction of the increments is at rounding level.
const ROUNDING_STEP: f64 = 1e-13;

/// Newton iteration limit of the return mapping.
pub const MAX_ITERATIONS: usize = 50;

/// Strain increments below this are rounding, not plastic flow.
pub const NEGLIGIBLE_STRAIN: f64 = 1e-13;

/// Backtracking halvings tried per Newton step.
const MAX_LINE_SEARCH_HALVINGS: usize = 12;

/// `|3 q2 p / (2 σ_y)|` is clamped here so cosh cannot overflow (and products
/// of cosh values in the Jacobian stay finite); real solutions sit far below.
const COSH_ARGUMENT_LIMIT: f64 = 300.0;

/// A von Mises trial stress below this fraction of the flow stress is
/// hydrostatic: the flow direction is then undefined and taken as zero.
const HYDROSTATIC_RATIO: f64 = 1e-12;

/// Iterates of the porosity stay below this fraction of the failure porosity
/// (the yield function degenerates at the failure porosity itself).
const POROSITY_CAP_FRACTION: f64 = 1.0 - 1e-9;

const SQRT_2: f64 = std::f64::consts::SQRT_2;

/// Mandel vector of a second-order tensor (its symmetric part).
pub fn mandel_from_tensor(tensor: &Matrix3<f64>) -> Mandel {
    let sym = |i: usize, j: usize| 0.5 * (tensor[(i, j)] + tensor[(j, i)]);
    Mandel::new(
        tensor[(0, 0)],
        tensor[(1, 1)],
        tensor[(2, 2)],
        SQRT_2 * sym(1, 2),
        SQRT_2 * sym(0, 2),
        SQRT_2 * sym(0, 1),
    )
}

/// Symmetric tensor of a Mandel vector.
pub fn tensor_from_mandel(mandel: &Mandel) -> Matrix3<f64> {
    let t23 = mandel[3] / SQRT_2;
    let t13 = mandel[4] / SQRT_2;
    let t12 = mandel[5] / SQRT_2;
    Matrix3::new(
        mandel[0], t12, t13, //
        t12, mandel[1], t23, //
        t13, t23, mandel[2],
    )
}

/// The second-order identity in Mandel notation.
pub fn identity_mandel() -> Mandel {
    Mandel::new(1.0, 1.0, 1.0, 0.0, 0.0, 0.0)
}

/// The deviatoric projector `I_dev = I_sym - (1/3) I ⊗ I` in Mandel notation.
pub fn deviatoric_projector() -> MandelTangent {
    let identity = identity_mandel();
    MandelTangent::identity() - identity * identity.transpose() / 3.0
}

/// Mean stress `p = tr(σ)/3` (MPa).
pub fn mean_stress_mpa(stress_mpa: &Mandel) -> f64 {
    (stress_mpa[0] + stress_mpa[1] + stress_mpa[2]) / 3.0
}

/// Deviator `s = σ - p I`.
pub fn deviator(tensor: &Mandel) -> Mandel {
    tensor - identity_mandel() * mean_stress_mpa(tensor)
}

/// Von Mises stress `q = √(3/2 s:s)` (MPa).
pub fn von_mises_stress_mpa(stress_mpa: &Mandel) -> f64 {
    (1.5 * deviator(stress_mpa).norm_squared()).sqrt()
}

/// The GTN yield function
/// `Φ = (q/σ_y)² + 2 q1 f* cosh(3 q2 p/(2 σ_y)) - 1 - q3 f*²` (dimensionless;
/// negative inside the yield surface). The cosh argument is clamped at ±300 so
/// the value stays finite.
pub fn yield_function(
    parameters: &GtnParameters,
    mean_stress_mpa: f64,
    von_mises_stress_mpa: f64,
    flow_stress_mpa: f64,
    effective_porosity: f64,
) -> f64 {
    let ratio = von_mises_stress_mpa / flow_stress_mpa;
    if effective_porosity == 0.0 && mean_stress_mpa.is_finite() {
        // Von Mises: the cosh term is zero (its argument is clamped finite).
        return ratio * ratio - 1.0;
    }
    let beta = cosh_argument(parameters.q2, mean_stress_mpa, flow_stress_mpa);
    ratio * ratio + 2.0 * parameters.q1 * effective_porosity * beta.cosh()
        - 1.0
        - parameters.q3 * effective_porosity * effective_porosity
}

/// `(sinh x, cosh x)` from one `exp_m1`, accurate near 0 too: the return
/// mapping needs both at every evaluation, and two calls were 5 % of a run.
fn sinh_cosh(x: f64) -> (f64, f64) {
    let grown = x.exp_m1();
    let shrunk = -grown / (1.0 + grown);
    (0.5 * (grown - shrunk), 1.0 + 0.5 * (grown + shrunk))
}

fn cosh_argument(q2: f64, mean_stress_mpa: f64, flow_stress_mpa: f64) -> f64 {
    (1.5 * q2 * mean_stress_mpa / flow_stress_mpa).clamp(-COSH_ARGUMENT_LIMIT, COSH_ARGUMENT_LIMIT)
}

/// Why a material parameter was rejected; each message names the parameter.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParameterError {
    /// Young's modulus not finite or not positive.
    #[error("Young's modulus must be finite and > 0 MPa, got {0}")]
    YoungsModulus(f64),
    /// Poisson's ratio outside (-1, 0.5).
    #[error("Poisson ratio must be in (-1, 0.5) for a stable isotropic solid, got {0}")]
    PoissonRatio(f64),
    /// q1 not finite or not positive.
    #[error("GTN q1 must be finite and > 0, got {0}")]
    Q1(f64),
    /// q2 not finite or not positive.
    #[error("GTN q2 must be finite and > 0, got {0}")]
    Q2(f64),
    /// q3 not finite or negative.
    #[error("GTN q3 must be finite and >= 0, got {0}")]
    Q3(f64),
    /// epsN not finite.
    #[error("nucleation mean strain epsN must be finite, got {0}")]
    NucleationMeanStrain(f64),
    /// sN not finite or not positive.
    #[error("nucleation strain standard deviation sN must be finite and > 0, got {0}")]
    NucleationStdStrain(f64),
    /// fN not finite, negative, or 1 or more (a volume fraction).
    #[error("nucleated void volume fraction fN must be finite, >= 0 and below 1, got {0}")]
    NucleatedVoidFraction(f64),
    /// f0 not finite, negative, or at/above the failure porosity.
    #[error(
        "initial porosity f0 must be finite, >= 0 and below the failure porosity {failure_porosity}, got {value}"
    )]
    InitialPorosity {
        /// The f0 given.
        value: f64,
        /// The failure porosity of the parameter set.
        failure_porosity: f64,
    },
    /// f_c not finite, not positive, or not below the ultimate effective porosity.
    #[error(
        "coalescence critical porosity f_c must be finite, > 0 and below the ultimate effective porosity f_u* = {ultimate_effective_porosity}, got {value}"
    )]
    CriticalPorosity {
        /// The f_c given.
        value: f64,
        /// f_u* of the parameter set.
        ultimate_effective_porosity: f64,
    },
    /// f_F not finite, not above f_c, or not below 1.
    #[error(
        "coalescence failure porosity f_F must be finite, > f_c = {critical_porosity} and < 1, got {value}"
    )]
    CoalescenceFailurePorosity {
        /// The f_F given.
        value: f64,
        /// The f_c given.
        critical_porosity: f64,
    },
}

/// Why a stress update failed. The update never returns NaN and never panics.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GtnError {
    /// The material parameters are out of range.
    #[error("invalid material: {0}")]
    InvalidParameters(#[from] ParameterError),
    /// A trial strain component is NaN or infinite.
    #[error("trial elastic strain component {component} is not finite ({value})")]
    NonFiniteTrialStrain {
        /// Mandel index of the component.
        component: usize,
        /// Its value.
        value: f64,
    },
    /// The state at `t_n` is not a state the model can reach.
    #[error(
        "material state must have a finite matrix plastic strain >= 0 and a porosity in [0, 1), got {matrix_plastic_strain} and {porosity}"
    )]
    InvalidState {
        /// Its matrix plastic strain.
        matrix_plastic_strain: f64,
        /// Its porosity.
        porosity: f64,
    },
    /// The volume ratio handed over is not a volume ratio.
    #[error("volume ratio J must be finite and positive, got {volume_ratio}")]
    InvalidVolumeRatio {
        /// The value received.
        volume_ratio: f64,
    },
    /// Newton's method did not reach the tolerance; cut the step.
    #[error(
        "GTN return mapping did not converge in {iterations} iterations (scaled residual {residual:e}); cut the load step"
    )]
    NotConverged {
        /// Iterations done.
        iterations: usize,
        /// Scaled residual norm at the last iterate.
        residual: f64,
    },
}

/// Isotropic linear elasticity.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Elasticity {
    /// Young's modulus E (MPa).
    pub youngs_modulus_mpa: f64,
    /// Poisson's ratio ν.
    pub poisson_ratio: f64,
}

impl Elasticity {
    /// Checks `E > 0` and `-1 < ν < 0.5` (positive definite stiffness).
    ///
    /// # Errors
    /// The parameter out of range.
    pub fn validate(&self) -> Result<(), ParameterError> {
        if !(self.youngs_modulus_mpa.is_finite() && self.youngs_modulus_mpa > 0.0) {
            return Err(ParameterError::YoungsModulus(self.youngs_modulus_mpa));
        }
        if !(self.poisson_ratio > -1.0 && self.poisson_ratio < 0.5) {
            return Err(ParameterError::PoissonRatio(self.poisson_ratio));
        }
        Ok(())
    }

    /// Bulk modulus `K = E / (3 (1 - 2ν))` (MPa).
    pub fn bulk_modulus_mpa(&self) -> f64 {
        self.youngs_modulus_mpa / (3.0 * (1.0 - 2.0 * self.poisson_ratio))
    }

    /// Shear modulus `G = E / (2 (1 + ν))` (MPa).
    pub fn shear_modulus_mpa(&self) -> f64 {
        self.youngs_modulus_mpa / (2.0 * (1.0 + self.poisson_ratio))
    }

    /// Stiffness `C = 3K I_vol + 2G I_dev` in Mandel notation (MPa).
    pub fn stiffness_mpa(&self) -> MandelTangent {
        let identity = identity_mandel();
        let volumetric = identity * identity.transpose() / 3.0;
        volumetric * (3.0 * self.bulk_modulus_mpa())
            + deviatoric_projector() * (2.0 * self.shear_modulus_mpa())
    }
}

/// Tvergaard-Needleman coalescence: accelerated effective porosity above f_c.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Coalescence {
    /// Critical porosity f_c where coalescence starts.
    pub critical_porosity: f64,
    /// Porosity f_F at which the effective porosity reaches f_u* (failure).
    pub failure_porosity: f64,
}

/// GTN parameters: yield-surface fitting constants, nucleation, initial
/// porosity, optional coalescence.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GtnParameters {
    /// q1: porosity weight of the cosh term.
    pub q1: f64,
    /// q2: pressure sensitivity inside the cosh.
    pub q2: f64,
    /// q3: porosity-squared term (q1² in the original model; calibrated freely
    /// in the P91 study, where q3 > q1²).
    pub q3: f64,
    /// εN: mean matrix plastic strain of nucleation.
    pub nucleation_mean_strain: f64,
    /// sN: standard deviation of the nucleation strain.
    pub nucleation_std_strain: f64,
    /// fN: total volume fraction of nucleated voids.
    pub nucleated_void_fraction: f64,
    /// f0: initial porosity.
    pub initial_porosity: f64,
    /// Tvergaard-Needleman coalescence, if modelled.
    pub coalescence: Option<Coalescence>,
}

impl GtnParameters {
    /// The literature's usual set: Tvergaard's q1 = 1.5, q2 = 1, q3 = q1²
    /// and Chu and Needleman's strain-controlled nucleation (εN = 0.3,
    /// sN = 0.1, fN = 0.04), with the given initial porosity and no
    /// coalescence.
    pub fn tvergaard_chu_needleman(initial_porosity: f64) -> Self {
        Self {
            q1: 1.5,
            q2: 1.0,
            q3: 2.25,
            nucleation_mean_strain: 0.3,
            nucleation_std_strain: 0.1,
            nucleated_void_fraction: 0.04,
            initial_porosity,
            coalescence: None,
        }
    }

    /// A parameter set that reduces GTN to von Mises (J2) plasticity:
    /// `f0 = fN = 0`, no coalescence (q's = 1, nucleation constants arbitrary).
    pub fn von_mises() -> Self {
        Self {
            q1: 1.0,
            q2: 1.0,
            q3: 1.0,
            nucleation_mean_strain: 0.3,
            nucleation_std_strain: 0.1,
            nucleated_void_fraction: 0.0,
            initial_porosity: 0.0,
            coalescence: None,
        }
    }

    /// Physical-range check.
    ///
    /// `q3 > q1²` is allowed (the P91 calibration has it): the yield surface
    /// then never shrinks to a point and, without coalescence, the failure
    /// porosity is 1.
    ///
    /// # Errors
    /// The first parameter out of range: q1 <= 0, q2 <= 0, q3 < 0, εN not
    /// finite, sN <= 0, fN < 0, f0 < 0 or f0 >= failure porosity, coalescence
    /// with f_c <= 0 or f_c >= f_u*, f_F <= f_c or f_F >= 1; any non-finite value.
    pub fn validate(&self) -> Result<(), ParameterError> {
        if !(self.q1.is_finite() && self.q1 > 0.0) {
            return Err(ParameterError::Q1(self.q1));
        }
        if !(self.q2.is_finite() && self.q2 > 0.0) {
            return Err(ParameterError::Q2(self.q2));
        }
        if !(self.q3.is_finite() && self.q3 >= 0.0) {
            return Err(ParameterError::Q3(self.q3));
        }
        if !self.nucleation_mean_strain.is_finite() {
            return Err(ParameterError::NucleationMeanStrain(
                self.nucleation_mean_strain,
            ));
        }
        if !(self.nucleation_std_strain.is_finite() && self.nucleation_std_strain > 0.0) {
            return Err(ParameterError::NucleationStdStrain(
                self.nucleation_std_strain,
            ));
        }
        if !(self.nucleated_void_fraction.is_finite()
            && (0.0..1.0).contains(&self.nucleated_void_fraction))
        {
            return Err(ParameterError::NucleatedVoidFraction(
                self.nucleated_void_fraction,
            ));
        }
        if let Some(coalescence) = self.coalescence {
            let ultimate = self.ultimate_effective_porosity();
            let critical = coalescence.critical_porosity;
            if !(critical.is_finite() && critical > 0.0 && critical < ultimate) {
                return Err(ParameterError::CriticalPorosity {
                    value: critical,
                    ultimate_effective_porosity: ultimate,
                });
            }
            let failure = coalescence.failure_porosity;
            if !(failure.is_finite() && failure > critical && failure < 1.0) {
                return Err(ParameterError::CoalescenceFailurePorosity {
                    value: failure,
                    critical_porosity: critical,
                });
            }
        }
        let failure_porosity = self.failure_porosity();
        let f0 = self.initial_porosity;
        if !(f0.is_finite() && f0 >= 0.0 && f0 < failure_porosity) {
            return Err(ParameterError::InitialPorosity {
                value: f0,
                failure_porosity,
            });
        }
        Ok(())
    }

    /// The effective porosity `f_u*` at which the yield surface shrinks to a
    /// point: the smaller root of `1 - 2 q1 f + q3 f² = 0` (`1/q1` when
    /// `q3 = q1²`, `1/(2 q1)` when `q3 = 0`). When `q3 > q1²` there is no real
    /// root and the Tvergaard-Needleman value `1/q1` is used.
    pub fn ultimate_effective_porosity(&self) -> f64 {
        let discriminant = self.q1 * self.q1 - self.q3;
        if discriminant >= 0.0 {
            // Rationalised root: no cancellation when q3 -> 0.
            1.0 / (self.q1 + discriminant.sqrt())
        } else {
            1.0 / self.q1
        }
    }

    /// `(f*, df*/df)`: the effective porosity of porosity `f`. Without
    /// coalescence `f* = f`; with it, `f* = f_c + κ (f - f_c)` for `f >= f_c`,
    /// `κ = (f_u* - f_c)/(f_F - f_c)`.
    pub fn effective_porosity(&self, porosity: f64) -> (f64, f64) {
        match self.coalescence {
            Some(coalescence) if porosity >= coalescence.critical_porosity => {
                let critical = coalescence.critical_porosity;
                let acceleration = (self.ultimate_effective_porosity() - critical)
                    / (coalescence.failure_porosity - critical);
                (
                    critical + acceleration * (porosity - critical),
                    acceleration,
                )
            }
            _ => (porosity, 1.0),
        }
    }

    /// The porosity at which the material fails: `f_F` with coalescence;
    /// without, the porosity where the yield surface shrinks to a point (see
    /// [`Self::ultimate_effective_porosity`]), capped at 1, and 1 when
    /// `q3 > q1²` (the surface never vanishes; the matrix is used up at f = 1).
    pub fn failure_porosity(&self) -> f64 {
        match self.coalescence {
            Some(coalescence) => coalescence.failure_porosity,
            None if self.q1 * self.q1 >= self.q3 => self.ultimate_effective_porosity().min(1.0),
            None => 1.0,
        }
    }

    /// `(A, dA/dε_m)`: the strain-controlled nucleation intensity
    /// `A = fN/(sN √(2π)) exp(-½ ((ε_m - εN)/sN)²)` and its slope.
    pub fn nucleation_intensity(&self, matrix_plastic_strain: f64) -> (f64, f64) {
        let std = self.nucleation_std_strain;
        let z = (matrix_plastic_strain - self.nucleation_mean_strain) / std;
        let intensity = self.nucleated_void_fraction / (std * (2.0 * std::f64::consts::PI).sqrt())
            * (-0.5 * z * z).exp();
        (intensity, -intensity * z / std)
    }
}

/// Internal variables of a material point.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct MaterialState {
    /// Equivalent plastic strain of the matrix ε_m.
    pub matrix_plastic_strain: f64,
    /// Void volume fraction f.
    pub porosity: f64,
    /// The point has failed: it carries no stress any more.
    pub failed: bool,
    /// The return mapping's solution `(Δε_p, Δε_q, Δε_m, Δf)` in the update
    /// that gave this state (zero after an elastic one): where the next
    /// update of the point starts ([`GtnMaterial::update_starting_from`]).
    /// Not a physical variable: equality ignores it.
    #[serde(skip)]
    pub last_increments: [f64; 4],
}

impl PartialEq for MaterialState {
    fn eq(&self, other: &Self) -> bool {
        self.matrix_plastic_strain == other.matrix_plastic_strain
            && self.porosity == other.porosity
            && self.failed == other.failed
    }
}

impl MaterialState {
    /// The virgin state: no plastic strain, porosity f0.
    pub fn initial(parameters: &GtnParameters) -> Self {
        Self {
            matrix_plastic_strain: 0.0,
            porosity: parameters.initial_porosity,
            failed: false,
            last_increments: [0.0; 4],
        }
    }
}

/// Result of one stress update.
#[derive(Clone, Debug, PartialEq)]
pub struct StressUpdate {
    /// Stress σ_{n+1} (MPa).
    pub stress_mpa: Mandel,
    /// Elastic strain ε_e,{n+1} = ε_tr - Δε_p (zero for a failed point).
    pub elastic_strain: Mandel,
    /// Consistent (algorithmic) tangent dσ_{n+1}/dε_tr (MPa); zero for a
    /// failed point.
    pub tangent_mpa: MandelTangent,
    /// `∂σ_{n+1}/∂J` at fixed trial strain (MPa), from the volume ratio's
    /// scaling of the flow stress; zero for an elastic or failed point.
    pub stress_by_volume_ratio_mpa: Mandel,
    /// Internal variables at t_{n+1}.
    pub state: MaterialState,
    /// Plastic flow happened in this step (including the step that failed the
    /// point; not for a point that had failed before).
    pub plastic: bool,
}

/// A GTN material: elasticity, porous-plasticity parameters, matrix flow curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GtnMaterial {
    /// Isotropic elasticity.
    pub elasticity: Elasticity,
    /// GTN parameters.
    pub parameters: GtnParameters,
    /// Matrix flow stress.
    pub flow: FlowCurve,
}

/// What an update returns besides the stress and the state: a global
/// Newton iteration's convergence check needs the stress only, and the
/// tangent is half the work of a plastic point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wanted {
    /// The tangents come back zero.
    StressOnly,
    WithTangent,
}

/// Which local solver a plastic step takes (a unit test compares them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum LocalSolver {
    /// Von Mises plasticity's one equation where the point has no voids and
    /// nucleates none ([`von_mises_step`]); the four equations otherwise.
    Specialised,
    /// The four equations always.
    #[cfg_attr(not(test), allow(dead_code))]
    General,
}

/// The return-mapping unknowns `(Δε_p, Δε_q, Δε_m, Δf)`.
type Unknowns = Vector4<f64>;

/// Residual, Jacobian and the partials the tangent needs, at one iterate.
struct LocalEvaluation {
    residual: Vector4<f64>,
    jacobian: Matrix4<f64>,
    d_residual_d_trial_mean: Vector4<f64>,
    d_residual_d_trial_von_mises: Vector4<f64>,
    mean_stress_mpa: f64,
    von_mises_mpa: f64,
    flow_stress_mpa: f64,
    /// ∂Φ/∂p · σ_y = 3 q1 q2 f* sinh(β), for the hydrostatic tangent limit.
    scaled_d_phi_d_mean: f64,
    /// ∂R/∂σ_y at fixed unknowns (for the volume-ratio sensitivity).
    d_residual_d_flow_stress: Vector4<f64>,
}

/// The local problem of one plastic step: everything fixed during Newton.
struct ReturnMapping<'a> {
    parameters: &'a GtnParameters,
    flow: &'a FlowCurve,
    bulk_mpa: f64,
    three_shear_mpa: f64,
    trial_mean_mpa: f64,
    trial_von_mises_mpa: f64,
    matrix_plastic_strain_n: f64,
    porosity_n: f64,
    porosity_cap: f64,
    /// No voids at t_n and no nucleation: von Mises plasticity exactly.
    void_free: bool,
    /// The volume ratio J that scales the matrix flow stress (see the module
    /// doc: Cauchy stress in the yield function, Kirchhoff stress solved for).
    volume_ratio: f64,
}

impl ReturnMapping<'_> {
    /// `(J σ_y, J dσ_y/dε_m)` at a matrix plastic strain.
    fn flow_stress_mpa(&self, matrix_plastic_strain: f64) -> (f64, f64) {
        let (flow_stress, hardening) = self.flow.flow_stress_mpa(matrix_plastic_strain);
        (
            self.volume_ratio * flow_stress,
            self.volume_ratio * hardening,
        )
    }

    fn evaluate(&self, x: &Unknowns) -> LocalEvaluation {
        let params = self.parameters;
        let (q1, q2, q3) = (params.q1, params.q2, params.q3);
        let (d_vol, d_dev, d_matrix, d_porosity) = (x[0], x[1], x[2], x[3]);
        let bulk = self.bulk_mpa;
        let three_shear = self.three_shear_mpa;

        let p = self.trial_mean_mpa - bulk * d_vol;
        let q = self.trial_von_mises_mpa - three_shear * d_dev;
        let matrix_strain = self.matrix_plastic_strain_n + d_matrix;
        let porosity = self.porosity_n + d_porosity;
        let (sy, hardening) = self.flow_stress_mpa(matrix_strain);
        let (f_star, d_f_star) = params.effective_porosity(porosity);
        let (nucleation, d_nucleation) = params.nucleation_intensity(matrix_strain);

        let beta = cosh_argument(q2, p, sy);
        let (sinh_beta, cosh_beta) = sinh_cosh(beta);

        // a = σ_y ∂Φ/∂q, b = σ_y ∂Φ/∂p: the normality residual times σ_y is
        // dimensionless-per-strain and stays O(1) per unit increment.
        let a = 2.0 * q / sy;
        let b = 3.0 * q1 * q2 * f_star * sinh_beta;
        let da_dq = 2.0 / sy;
        let da_dsy = -a / sy;
        let db_dp = 3.0 * q1 * q2 * f_star * cosh_beta * 1.5 * q2 / sy;
        let db_dsy = -3.0 * q1 * q2 * f_star * cosh_beta * beta / sy;
        let db_df_star = 3.0 * q1 * q2 * sinh_beta;

        let phi = (q / sy) * (q / sy) + 2.0 * q1 * f_star * cosh_beta - 1.0 - q3 * f_star * f_star;
        let phi_p = b / sy;
        let phi_q = a / sy;
        let phi_sy = -2.0 * q * q / (sy * sy * sy) - 2.0 * q1 * f_star * sinh_beta * beta / sy;
        let phi_f_star = 2.0 * q1 * cosh_beta - 2.0 * q3 * f_star;

        let work_per_sy = (p * d_vol + q * d_dev) / sy;
        let matrix_fraction = 1.0 - porosity;

        let residual = Vector4::new(
            d_vol * a - d_dev * b,
            phi,
            matrix_fraction * d_matrix - work_per_sy,
            d_porosity - matrix_fraction * d_vol - nucleation * d_matrix,
        );
        #[rustfmt::skip]
        let jacobian = Matrix4::new(
            a + bulk * d_dev * db_dp,
            -three_shear * d_vol * da_dq - b,
            hardening * (d_vol * da_dsy - d_dev * db_dsy),
            -d_dev * db_df_star * d_f_star,
            //
            -bulk * phi_p,
            -three_shear * phi_q,
            hardening * phi_sy,
            d_f_star * phi_f_star,
            //
            -(p - bulk * d_vol) / sy,
            -(q - three_shear * d_dev) / sy,
            matrix_fraction + work_per_sy * hardening / sy,
            -d_matrix,
            //
            -matrix_fraction,
            0.0,
            -(d_nucleation * d_matrix + nucleation),
            1.0 + d_vol,
        );
        LocalEvaluation {
            residual,
            jacobian,
            d_residual_d_trial_mean: Vector4::new(-d_dev * db_dp, phi_p, -d_vol / sy, 0.0),
            d_residual_d_trial_von_mises: Vector4::new(d_vol * da_dq, phi_q, -d_dev / sy, 0.0),
            mean_stress_mpa: p,
            von_mises_mpa: q,
            flow_stress_mpa: sy,
            scaled_d_phi_d_mean: b,
            d_residual_d_flow_stress: Vector4::new(
                d_vol * da_dsy - d_dev * db_dsy,
                phi_sy,
                work_per_sy / sy,
                0.0,
            ),
        }
    }

    /// Keeps an iterate physical: `0 <= Δε_q <= q_tr/3G` (q >= 0),
    /// `Δε_m >= 0`, `0 <= f < failure`.
    fn project(&self, x: &Unknowns) -> Unknowns {
        let max_dev = self.trial_von_mises_mpa / self.three_shear_mpa;
        if self.void_free {
            // f = 0 and no nucleation: the exact solution has no volumetric
            // flow and no porosity; pinning them gives the J2 result exactly.
            return Unknowns::new(0.0, x[1].clamp(0.0, max_dev), x[2].max(0.0), 0.0);
        }
        Unknowns::new(
            x[0],
            x[1].clamp(0.0, max_dev),
            x[2].max(0.0),
            x[3].clamp(-self.porosity_n, self.porosity_cap - self.porosity_n),
        )
    }

    /// Residual norm with R1, R3, R4 (strain-sized) divided by `strain_scale`.
    fn scaled_norm(residual: &Vector4<f64>, strain_scale: f64) -> f64 {
        let scale = strain_scale.max(f64::MIN_POSITIVE);
        (residual[0] / scale)
            .abs()
            .max(residual[1].abs())
            .max((residual[2] / scale).abs())
            .max((residual[3] / scale).abs())
    }

    /// Size of the strain increments, at least [`NEGLIGIBLE_STRAIN`]: a trial
    /// a hair outside the surface starts at x = 0, and dividing residuals by
    /// a zero scale would make every candidate step look infinitely bad.
    fn strain_scale(x: &Unknowns) -> f64 {
        x[0].abs()
            .max(x[1].abs())
            .max(x[2].abs())
            .max(NEGLIGIBLE_STRAIN)
    }

    fn merit(residual: &Vector4<f64>, strain_scale: f64) -> f64 {
        let scale = strain_scale.max(f64::MIN_POSITIVE);
        let scaled = Vector4::new(
            residual[0] / scale,
            residual[1],
            residual[2] / scale,
            residual[3] / scale,
        );
        scaled.norm_squared()
    }

    /// Start: without voids the J2 radial return; otherwise the radial
    /// scaling `(p, q) = t (p_tr, q_tr)` onto the yield surface of the state at
    /// t_n, then work equivalence and porosity evolution explicitly from it.
    fn initial_guess(&self) -> Unknowns {
        let params = self.parameters;
        let (sy, _) = self.flow_stress_mpa(self.matrix_plastic_strain_n);
        let (f_star, _) = params.effective_porosity(self.porosity_n);
        let (p_tr, q_tr) = (self.trial_mean_mpa, self.trial_von_mises_mpa);
        if f_star <= 0.0 {
            // No voids: the J2 radial return with the current hardening slope,
            // no volumetric flow (a volumetric start would invent porosity).
            let (_, hardening) = self.flow_stress_mpa(self.matrix_plastic_strain_n);
            let d_dev = ((q_tr - sy) / (self.three_shear_mpa + hardening)).max(0.0);
            let matrix_fraction = 1.0 - self.porosity_n;
            let d_matrix = (q_tr - self.three_shear_mpa * d_dev) * d_dev / (matrix_fraction * sy);
            let (nucleation, _) = params.nucleation_intensity(self.matrix_plastic_strain_n);
            return self.project(&Unknowns::new(0.0, d_dev, d_matrix, nucleation * d_matrix));
        }
        let scale = {
            // Along the ray Φ(t) is convex with Φ(0) < 0, so Newton from a
            // point with Φ >= 0 descends monotonically onto the root. Starting
            // at the hydrostatic yield pressure avoids crawling down a huge cosh.
            let hydrostatic_cosh =
                ((1.0 + params.q3 * f_star * f_star) / (2.0 * params.q1 * f_star)).max(1.0);
            let hydrostatic_beta = hydrostatic_cosh.acosh();
            let trial_beta = 1.5 * params.q2 * p_tr / sy;
            let mut t = if trial_beta.abs() > hydrostatic_beta {
                hydrostatic_beta / trial_beta.abs()
            } else {
                1.0
            };
            for _ in 0..40 {
                let beta = (t * trial_beta).clamp(-COSH_ARGUMENT_LIMIT, COSH_ARGUMENT_LIMIT);
                let ratio = t * q_tr / sy;
                let phi = ratio * ratio + 2.0 * params.q1 * f_star * beta.cosh()
                    - 1.0
                    - params.q3 * f_star * f_star;
                let slope =
                    2.0 * ratio * q_tr / sy + 2.0 * params.q1 * f_star * trial_beta * beta.sinh();
                if phi.abs() < 1e-6 || slope.is_nan() || slope <= 0.0 {
                    break;
                }
                t = (t - phi / slope).clamp(0.0, 1.0);
            }
            t
        };
        let matrix_fraction = 1.0 - self.porosity_n;
        // Volumetric flow needs voids: compression cannot close more than
        // f_n, and the implicit closure is gradual, so start at most half way
        // (a start with the voids fully closed has no pressure dependence).
        let half_closure = -0.5 * self.porosity_n / matrix_fraction;
        let d_vol = ((1.0 - scale) * p_tr / self.bulk_mpa).max(half_closure);
        let d_dev = (1.0 - scale) * q_tr / self.three_shear_mpa;
        let work = (p_tr - self.bulk_mpa * d_vol) * d_vol + scale * q_tr * d_dev;
        let d_matrix = (work / (matrix_fraction * sy)).max(0.0);
        let (nucleation, _) = params.nucleation_intensity(self.matrix_plastic_strain_n);
        let d_porosity = matrix_fraction * d_vol + nucleation * d_matrix;
        self.project(&Unknowns::new(d_vol, d_dev, d_matrix, d_porosity))
    }
}

/// Outcome of the Newton loop: the converged unknowns with the evaluation
/// there, or `None` when the porosity was driven to the failure limit.
type LocalSolution = Option<(Unknowns, LocalEvaluation)>;

impl GtnMaterial {
    /// A validated material.
    ///
    /// # Errors
    /// The first parameter out of range.
    pub fn new(
        elasticity: Elasticity,
        parameters: GtnParameters,
        flow: FlowCurve,
    ) -> Result<Self, ParameterError> {
        let material = Self {
            elasticity,
            parameters,
            flow,
        };
        material.validate()?;
        Ok(material)
    }

    /// Checks elasticity and GTN parameters (the flow curve checks itself when
    /// built).
    ///
    /// # Errors
    /// The first parameter out of range.
    pub fn validate(&self) -> Result<(), ParameterError> {
        self.elasticity.validate()?;
        self.parameters.validate()
    }

    /// Porosity at which a point is declared failed.
    pub fn failure_trigger_porosity(&self) -> f64 {
        FAILURE_FRACTION * self.parameters.failure_porosity()
    }

    /// Yield function of a stress at a state (dimensionless, <= 0 admissible).
    pub fn yield_function_at(&self, stress_mpa: &Mandel, state: &MaterialState) -> f64 {
        let (sy, _) = self.flow.flow_stress_mpa(state.matrix_plastic_strain);
        let (f_star, _) = self.parameters.effective_porosity(state.porosity);
        yield_function(
            &self.parameters,
            mean_stress_mpa(stress_mpa),
            von_mises_stress_mpa(stress_mpa),
            sy,
            f_star,
        )
    }

    /// One implicit (backward-Euler) step: given the state at t_n and the
    /// trial elastic strain `ε_tr = ε_e,n + Δε`, returns the state at t_{n+1},
    /// the stress, the elastic strain and the consistent tangent.
    ///
    /// A failed point (or one whose porosity reaches the failure trigger in
    /// this step) returns zero stress, zero elastic strain, zero tangent and
    /// `failed = true`.
    ///
    /// # Errors
    /// Invalid parameters, a non-finite trial strain, an impossible state, or
    /// a return mapping that did not converge (cut the step).
    pub fn update(
        &self,
        state_n: &MaterialState,
        trial_elastic_strain: &Mandel,
    ) -> Result<StressUpdate, GtnError> {
        self.update_at_volume_ratio(state_n, trial_elastic_strain, 1.0)
    }

    /// [`GtnMaterial::update_at_volume_ratio`], whose return mapping starts
    /// from the solution of the update that gave `last` (the same point's,
    /// an iteration or a step before) when there was one. Global Newton
    /// iterations change a point's trial strain little, so that start is
    /// close: 4 local iterations become about 2 (see BENCHMARKS.md). Should
    /// Newton fail from there, the usual start is taken, so the result is
    /// the same solution to the local tolerance.
    ///
    /// # Errors
    /// As [`GtnMaterial::update_at_volume_ratio`].
    pub fn update_starting_from(
        &self,
        state_n: &MaterialState,
        trial_elastic_strain: &Mandel,
        volume_ratio: f64,
        last: &MaterialState,
        wanted: Wanted,
    ) -> Result<StressUpdate, GtnError> {
        let start = Unknowns::from(last.last_increments);
        let start =
            (start != Unknowns::zeros() && start.iter().all(|v| v.is_finite())).then_some(start);
        self.update_with_start(
            state_n,
            trial_elastic_strain,
            volume_ratio,
            start,
            wanted,
            LocalSolver::Specialised,
        )
    }

    /// [`GtnMaterial::update`] at finite strain: the stress solved for is the
    /// Kirchhoff stress τ of a point whose volume ratio is `volume_ratio`
    /// (J = det F), the yield function sees the Cauchy stress τ/J (see the
    /// module doc).
    ///
    /// # Errors
    /// As [`GtnMaterial::update`], and a volume ratio that is not positive.
    pub fn update_at_volume_ratio(
        &self,
        state_n: &MaterialState,
        trial_elastic_strain: &Mandel,
        volume_ratio: f64,
    ) -> Result<StressUpdate, GtnError> {
        self.update_with_start(
            state_n,
            trial_elastic_strain,
            volume_ratio,
            None,
            Wanted::WithTangent,
            LocalSolver::Specialised,
        )
    }

    fn update_with_start(
        &self,
        state_n: &MaterialState,
        trial_elastic_strain: &Mandel,
        volume_ratio: f64,
        start: Option<Unknowns>,
        wanted: Wanted,
        solver: LocalSolver,
    ) -> Result<StressUpdate, GtnError> {
        self.validate()?;
        if !(volume_ratio.is_finite() && volume_ratio > 0.0) {
            return Err(GtnError::InvalidVolumeRatio { volume_ratio });
        }
        if let Some((component, &value)) = trial_elastic_strain
            .iter()
            .enumerate()
            .find(|(_, value)| !value.is_finite())
        {
            return Err(GtnError::NonFiniteTrialStrain { component, value });
        }
        let matrix_strain_n = state_n.matrix_plastic_strain;
        let porosity_n = state_n.porosity;
        if !(matrix_strain_n.is_finite()
            && matrix_strain_n >= 0.0
            && porosity_n.is_finite()
            && (0.0..1.0).contains(&porosity_n))
        {
            return Err(GtnError::InvalidState {
                matrix_plastic_strain: matrix_strain_n,
                porosity: porosity_n,
            });
        }
        if state_n.failed || porosity_n >= self.failure_trigger_porosity() {
            return Ok(failed_update(state_n, false));
        }
        let porosity_n = if porosity_n < NEGLIGIBLE_POROSITY {
            0.0
        } else {
            porosity_n
        };

        let bulk = self.elasticity.bulk_modulus_mpa();
        let shear = self.elasticity.shear_modulus_mpa();
        // σ = K tr(ε) I + 2G dev(ε), without the 6 x 6 stiffness.
        let trial_mean =
            bulk * (trial_elastic_strain[0] + trial_elastic_strain[1] + trial_elastic_strain[2]);
        let trial_deviator = deviator(trial_elastic_strain) * (2.0 * shear);
        let trial_stress = identity_mandel() * trial_mean + trial_deviator;
        let mut trial_von_mises = (1.5 * trial_deviator.norm_squared()).sqrt();

        let (sy_n, _) = self.flow.flow_stress_mpa(matrix_strain_n);
        let sy_n = volume_ratio * sy_n;
        let (f_star_n, _) = self.parameters.effective_porosity(porosity_n);
        let trial_phi = yield_function(
            &self.parameters,
            trial_mean,
            trial_von_mises,
            sy_n,
            f_star_n,
        );
        if trial_phi <= YIELD_TOLERANCE {
            return Ok(StressUpdate {
                stress_mpa: trial_stress,
                elastic_strain: *trial_elastic_strain,
                tangent_mpa: match wanted {
                    Wanted::StressOnly => MandelTangent::zeros(),
                    Wanted::WithTangent => self.elasticity.stiffness_mpa(),
                },
                stress_by_volume_ratio_mpa: Mandel::zeros(),
                state: MaterialState {
                    last_increments: [0.0; 4],
                    ..*state_n
                },
                plastic: false,
            });
        }

        // n = 3/2 s_tr/q_tr; for a hydrostatic trial it is undefined and the
        // deviatoric flow is zero.
        let hydrostatic = trial_von_mises <= HYDROSTATIC_RATIO * sy_n;
        let flow_direction = if hydrostatic {
            trial_von_mises = 0.0;
            Mandel::zeros()
        } else {
            trial_deviator * (1.5 / trial_von_mises)
        };

        let problem = ReturnMapping {
            parameters: &self.parameters,
            flow: &self.flow,
            bulk_mpa: bulk,
            three_shear_mpa: 3.0 * shear,
            trial_mean_mpa: trial_mean,
            trial_von_mises_mpa: trial_von_mises,
            matrix_plastic_strain_n: matrix_strain_n,
            porosity_n,
            porosity_cap: POROSITY_CAP_FRACTION * self.parameters.failure_porosity(),
            void_free: porosity_n == 0.0 && self.parameters.nucleated_void_fraction == 0.0,
            volume_ratio,
        };
        if problem.void_free && !hydrostatic && solver == LocalSolver::Specialised {
            return von_mises_step(&problem, &trial_deviator, &flow_direction, shear, wanted);
        }
        let warm = start.and_then(|start| {
            match solve_return_mapping(&problem, self.failure_trigger_porosity(), start) {
                Ok(Some(solution)) => Some(solution),
                // Failure or no convergence from there: decided from the
                // usual start, as without one.
                _ => None,
            }
        });
        let solution = match warm {
            Some(solution) => Some(solution),
            None => solve_return_mapping(
                &problem,
                self.failure_trigger_porosity(),
                problem.initial_guess(),
            )?,
        };
        let Some((x, evaluation)) = solution else {
            return Ok(failed_update(state_n, true));
        };
        let porosity = porosity_n + x[3];
        let porosity = if porosity < NEGLIGIBLE_POROSITY {
            0.0
        } else {
            porosity
        };
        if porosity >= self.failure_trigger_porosity() {
            return Ok(failed_update(state_n, true));
        }

        let p = evaluation.mean_stress_mpa;
        let q = evaluation.von_mises_mpa;
        // s = (q/q_tr) s_tr. In the hydrostatic limit the ratio follows from
        // R1 = 0: q/q_tr = 1/(1 + 6G Δε_p/(σ_y b)).
        let deviator_ratio = if hydrostatic {
            let b = evaluation.scaled_d_phi_d_mean;
            let denominator =
                1.0 + 2.0 * problem.three_shear_mpa * x[0] / (evaluation.flow_stress_mpa * b);
            if b != 0.0 && denominator.is_finite() && denominator > 0.0 {
                1.0 / denominator
            } else {
                1.0
            }
        } else {
            q / trial_von_mises
        };
        let (stress, elastic_strain) =
            stress_and_elastic_strain(p, &trial_deviator, deviator_ratio, bulk, shear);

        let (tangent, stress_by_volume_ratio) = match wanted {
            Wanted::StressOnly => (MandelTangent::zeros(), Mandel::zeros()),
            Wanted::WithTangent => {
                // One factorisation of the local Jacobian serves both sensitivities.
                let lu = LocalLu::new(&evaluation.jacobian).ok_or(GtnError::NotConverged {
                    iterations: MAX_ITERATIONS,
                    residual: f64::INFINITY,
                })?;
                (
                    consistent_tangent(
                        &problem,
                        &evaluation,
                        &lu,
                        &flow_direction,
                        shear,
                        deviator_ratio,
                    ),
                    volume_ratio_sensitivity(&problem, &evaluation, &lu, &flow_direction),
                )
            }
        };

        let update = StressUpdate {
            stress_mpa: stress,
            elastic_strain,
            tangent_mpa: tangent,
            stress_by_volume_ratio_mpa: stress_by_volume_ratio,
            state: MaterialState {
                matrix_plastic_strain: matrix_strain_n + x[2],
                porosity,
                failed: false,
                last_increments: x.into(),
            },
            plastic: true,
        };
        finite_or_not_converged(update, MAX_ITERATIONS)
    }
}

fn failed_update(state_n: &MaterialState, plastic: bool) -> StressUpdate {
    StressUpdate {
        stress_mpa: Mandel::zeros(),
        elastic_strain: Mandel::zeros(),
        tangent_mpa: MandelTangent::zeros(),
        stress_by_volume_ratio_mpa: Mandel::zeros(),
        state: MaterialState {
            matrix_plastic_strain: state_n.matrix_plastic_strain,
            porosity: state_n.porosity,
            failed: true,
            last_increments: [0.0; 4],
        },
        plastic,
    }
}

/// Iteration limit of [`von_mises_step`]: Newton inside a bracket that
/// bisection keeps needs a handful; 200 bisections span any bracket of
/// finite numbers down to adjacent doubles.
const MAX_VON_MISES_ITERATIONS: usize = 200;

/// The plastic step of a point without voids that nucleates none. Its
/// porosity stays zero (growth needs voids), so the four equations reduce
/// to von Mises plasticity's one: `q_tr - 3G Δε_q = J σ_y(ε_m,n + Δε_q)`,
/// with `Δε_m = Δε_q` from the work equivalence at `q = J σ_y`. Newton's
/// method solves it inside the bracket `[0, q_tr / 3G]`, and a step that
/// would leave the bracket (at a kink of a piecewise-linear flow curve) is
/// a bisection instead; the tangent is the closed form of the general one
/// with `Δε_p = Δf = 0`:
///
/// ```text
/// D = K I ⊗ I + 2G θ I_dev + (4G/3) (JH/(3G + JH) - θ) n ⊗ n,  θ = q/q_tr
/// ∂τ/∂J = 2G σ_y / (3G + JH) n
/// ```
///
/// The general solver reaches the same solution and tangent (a unit test
/// compares the two); this one builds and factors no 4 x 4 system, which
/// were most of a damage-free bar's material work.
fn von_mises_step(
    problem: &ReturnMapping<'_>,
    trial_deviator: &Mandel,
    flow_direction: &Mandel,
    shear_mpa: f64,
    wanted: Wanted,
) -> Result<StressUpdate, GtnError> {
    let three_shear = problem.three_shear_mpa;
    let trial_von_mises = problem.trial_von_mises_mpa;
    let matrix_strain_n = problem.matrix_plastic_strain_n;
    // g(Δ) = q_tr - 3G Δ - J σ_y(ε_m,n + Δ): positive at 0 (the trial
    // yields), negative where q would reach 0.
    let excess = |increment: f64| {
        let (flow_stress, hardening) = problem.flow_stress_mpa(matrix_strain_n + increment);
        (
            trial_von_mises - three_shear * increment - flow_stress,
            three_shear + hardening,
        )
    };
    let (mut low, mut high) = (0.0, trial_von_mises / three_shear);
    let (first_excess, first_slope) = excess(0.0);
    // The radial return on the first segment: exact unless the step
    // crosses a knot of the flow curve.
    let mut increment = first_excess / first_slope;
    if !(increment > low && increment < high) {
        increment = 0.5 * (low + high);
    }
    let mut converged = false;
    let mut last_excess = first_excess;
    for _ in 0..MAX_VON_MISES_ITERATIONS {
        let (value, slope) = excess(increment);
        last_excess = value;
        if !value.is_finite() {
            break;
        }
        if value == 0.0 {
            converged = true;
            break;
        }
        if value > 0.0 {
            low = increment;
        } else {
            high = increment;
        }
        // slope = -dg/dΔ = 3G + JH.
        let newton = increment + value / slope;
        let next = if slope > 0.0 && newton > low && newton < high {
            newton
        } else {
            0.5 * (low + high)
        };
        // At rounding: the next iterate is the same double or its neighbour.
        let settled = (next - increment).abs() <= 2.0 * f64::EPSILON * increment.abs();
        increment = next;
        if settled || high - low <= 2.0 * f64::EPSILON * high {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(GtnError::NotConverged {
            iterations: MAX_VON_MISES_ITERATIONS,
            residual: (last_excess / trial_von_mises).abs(),
        });
    }

    let (flow_stress, hardening) = problem.flow_stress_mpa(matrix_strain_n + increment);
    let mean = problem.trial_mean_mpa;
    let bulk = problem.bulk_mpa;
    let deviator_ratio = (trial_von_mises - three_shear * increment) / trial_von_mises;
    let (stress, elastic_strain) =
        stress_and_elastic_strain(mean, trial_deviator, deviator_ratio, bulk, shear_mpa);
    let identity = identity_mandel();
    let (tangent, stress_by_volume_ratio) = match wanted {
        Wanted::StressOnly => (MandelTangent::zeros(), Mandel::zeros()),
        Wanted::WithTangent => {
            let stiffness = three_shear + hardening;
            let two_shear = 2.0 * shear_mpa;
            let along_flow = (2.0 / 3.0) * two_shear * (hardening / stiffness - deviator_ratio);
            let tangent = identity * identity.transpose() * bulk
                + deviatoric_projector() * (two_shear * deviator_ratio)
                + flow_direction * flow_direction.transpose() * along_flow;
            // J scales σ_y and its slope: dΔ/dJ = -σ_y / (3G + JH).
            let unscaled_flow_stress = flow_stress / problem.volume_ratio;
            let by_volume_ratio = flow_direction * (two_shear * unscaled_flow_stress / stiffness);
            (tangent, by_volume_ratio)
        }
    };
    let update = StressUpdate {
        stress_mpa: stress,
        elastic_strain,
        tangent_mpa: tangent,
        stress_by_volume_ratio_mpa: stress_by_volume_ratio,
        state: MaterialState {
            matrix_plastic_strain: matrix_strain_n + increment,
            porosity: 0.0,
            failed: false,
            last_increments: [0.0, increment, increment, 0.0],
        },
        plastic: true,
    };
    finite_or_not_converged(update, MAX_VON_MISES_ITERATIONS)
}

/// The returned stress `p I + (q/q_tr) s_tr` and its elastic strain
/// `C⁻¹ σ`: consistent with the stress by construction.
fn stress_and_elastic_strain(
    mean_mpa: f64,
    trial_deviator: &Mandel,
    deviator_ratio: f64,
    bulk_mpa: f64,
    shear_mpa: f64,
) -> (Mandel, Mandel) {
    let identity = identity_mandel();
    (
        identity * mean_mpa + trial_deviator * deviator_ratio,
        identity * (mean_mpa / (3.0 * bulk_mpa))
            + trial_deviator * (deviator_ratio / (2.0 * shear_mpa)),
    )
}

/// The update if every number in it is finite; a local solve that ended on
/// an overflow did not converge.
fn finite_or_not_converged(
    update: StressUpdate,
    iterations: usize,
) -> Result<StressUpdate, GtnError> {
    let all_finite = update.stress_mpa.iter().all(|v| v.is_finite())
        && update.elastic_strain.iter().all(|v| v.is_finite())
        && update.tangent_mpa.iter().all(|v| v.is_finite())
        && update
            .stress_by_volume_ratio_mpa
            .iter()
            .all(|v| v.is_finite())
        && update.state.matrix_plastic_strain.is_finite();
    if all_finite {
        Ok(update)
    } else {
        Err(GtnError::NotConverged {
            iterations,
            residual: f64::INFINITY,
        })
    }
}

/// Projected Newton with backtracking on the scaled residual.
fn solve_return_mapping(
    problem: &ReturnMapping<'_>,
    failure_trigger_porosity: f64,
    start: Unknowns,
) -> Result<LocalSolution, GtnError> {
    let mut x = problem.project(&start);
    let mut evaluation = problem.evaluate(&x);
    let mut max_porosity = problem.porosity_n + x[3];
    let mut residual_norm = f64::INFINITY;

    for iteration in 1..=MAX_ITERATIONS {
        residual_norm =
            ReturnMapping::scaled_norm(&evaluation.residual, ReturnMapping::strain_scale(&x));
        if residual_norm <= POLISHED_RESIDUAL {
            // Already where a polishing step would take it.
            return Ok(Some((x, evaluation)));
        }
        let converged = residual_norm <= RESIDUAL_TOLERANCE;
        let Some(step) =
            LocalLu::new(&evaluation.jacobian).map(|lu| lu.solve(&-evaluation.residual))
        else {
            return if max_porosity >= failure_trigger_porosity {
                Ok(None)
            } else {
                Err(GtnError::NotConverged {
                    iterations: iteration,
                    residual: residual_norm,
                })
            };
        };
        // Rounding floor: when f is tiny (voids closed by compression) it is
        // the small difference f_n + Δf and Φ cannot be evaluated more
        // accurately than ~1e-16 f_n / f; a step at rounding level of every
        // unknown means nothing better exists.
        let strain_scale = ReturnMapping::strain_scale(&x);
        let porosity_scale = strain_scale.max(problem.porosity_n);
        let at_rounding = (0..3).all(|i| step[i].abs() <= ROUNDING_STEP * strain_scale)
            && step[3].abs() <= ROUNDING_STEP * porosity_scale
            && residual_norm <= ROUNDING_FLOOR_RESIDUAL;
        if converged || at_rounding {
            // Newton converges quadratically here: one more full step takes the
            // error from ~tolerance to rounding (the tangent check needs it).
            let polished = problem.project(&(x + step));
            let polished_evaluation = problem.evaluate(&polished);
            let polished_norm = ReturnMapping::scaled_norm(
                &polished_evaluation.residual,
                ReturnMapping::strain_scale(&polished),
            );
            if polished_norm.is_finite() && polished_norm <= residual_norm {
                return Ok(Some((polished, polished_evaluation)));
            }
            return Ok(Some((x, evaluation)));
        }

        // The merit scales the strain-like residuals by the current
        // increments, like the convergence test, so rounding in Φ never
        // dominates it.
        let merit_scale = strain_scale;
        let merit = ReturnMapping::merit(&evaluation.residual, merit_scale);
        let mut fraction = 1.0;
        let mut best: Option<(f64, Unknowns, LocalEvaluation)> = None;
        for _ in 0..MAX_LINE_SEARCH_HALVINGS {
            let candidate = problem.project(&(x + step * fraction));
            let candidate_evaluation = problem.evaluate(&candidate);
            let candidate_merit = ReturnMapping::merit(&candidate_evaluation.residual, merit_scale);
            let finite = candidate_merit.is_finite()
                && candidate_evaluation.jacobian.iter().all(|v| v.is_finite());
            if finite {
                let sufficient = candidate_merit <= (1.0 - 1e-4 * fraction) * merit;
                if best.as_ref().is_none_or(|(m, _, _)| candidate_merit < *m) {
                    best = Some((candidate_merit, candidate, candidate_evaluation));
                }
                if sufficient {
                    break;
                }
            }
            fraction *= 0.5;
        }
        // Without sufficient decrease take the best step tried, so Newton can
        // still get past a kink of the piecewise-linear flow curve.
        let Some((_, next, next_evaluation)) = best else {
            return Err(GtnError::NotConverged {
                iterations: iteration,
                residual: residual_norm,
            });
        };
        x = next;
        evaluation = next_evaluation;
        max_porosity = max_porosity.max(problem.porosity_n + x[3]);
    }
    if max_porosity >= failure_trigger_porosity {
        return Ok(None);
    }
    Err(GtnError::NotConverged {
        iterations: MAX_ITERATIONS,
        residual: residual_norm,
    })
}

/// `∂σ/∂J` at fixed trial strain: J scales σ_y (and its slope) only, so
/// `J dx/dJ = -∂R/∂σ_y σ_y` with σ_y the scaled flow stress, and
/// `dσ = -K dΔε_p I - (2/3) 3G dΔε_q n`.
fn volume_ratio_sensitivity(
    problem: &ReturnMapping<'_>,
    evaluation: &LocalEvaluation,
    lu: &LocalLu,
    flow_direction: &Mandel,
) -> Mandel {
    let d_residual_d_volume_ratio =
        evaluation.d_residual_d_flow_stress * (evaluation.flow_stress_mpa / problem.volume_ratio);
    let dx = lu.solve(&-d_residual_d_volume_ratio);
    identity_mandel() * (-problem.bulk_mpa * dx[0])
        + flow_direction * (-(2.0 / 3.0) * problem.three_shear_mpa * dx[1])
}

/// `dσ/dε_tr` by the implicit function theorem on the converged local system.
fn consistent_tangent(
    problem: &ReturnMapping<'_>,
    evaluation: &LocalEvaluation,
    lu: &LocalLu,
    flow_direction: &Mandel,
    shear_mpa: f64,
    deviator_ratio: f64,
) -> MandelTangent {
    let dx_d_trial_mean = lu.solve(&-evaluation.d_residual_d_trial_mean);
    let dx_d_trial_von_mises = lu.solve(&-evaluation.d_residual_d_trial_von_mises);
    let bulk = problem.bulk_mpa;
    let three_shear = problem.three_shear_mpa;

    let dp_d_trial_mean = 1.0 - bulk * dx_d_trial_mean[0];
    let dp_d_trial_von_mises = -bulk * dx_d_trial_von_mises[0];
    let dq_d_trial_mean = -three_shear * dx_d_trial_mean[1];
    let dq_d_trial_von_mises = 1.0 - three_shear * dx_d_trial_von_mises[1];

    // dp_tr/dε = K I, dq_tr/dε = 2G n.
    let identity = identity_mandel();
    let two_shear = 2.0 * shear_mpa;
    let dp_d_strain =
        identity * (bulk * dp_d_trial_mean) + flow_direction * (two_shear * dp_d_trial_von_mises);
    let dq_d_strain =
        identity * (bulk * dq_d_trial_mean) + flow_direction * (two_shear * dq_d_trial_von_mises);

    let direction_change = (deviatoric_projector()
        - flow_direction * flow_direction.transpose() * (2.0 / 3.0))
        * (two_shear * deviator_ratio);
    identity * dp_d_strain.transpose()
        + flow_direction * dq_d_strain.transpose() * (2.0 / 3.0)
        + direction_change
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tensile::banded::uniform_numbers;
    use crate::tensile::flow_curve::FlowCurve;

    /// Von Mises points (no voids, no nucleation) with the specialised step
    /// and with the four-equation solver: the same state, stress and
    /// tangents, on a flow table whose knots the steps cross, with a volume
    /// ratio away from one, and past the table's end (the post-UTS line).
    #[test]
    fn the_von_mises_step_equals_the_general_solver() {
        let flow = FlowCurve::new(
            vec![0.0, 0.005, 0.01, 0.02, 0.04, 0.06, 0.09],
            vec![404.0, 440.0, 468.0, 512.0, 573.0, 615.0, 650.0],
            534.0,
        )
        .unwrap();
        let elasticity = Elasticity {
            youngs_modulus_mpa: 207_011.0,
            poisson_ratio: 0.3,
        };
        let material = GtnMaterial::new(elasticity, GtnParameters::von_mises(), flow).unwrap();
        let mut uniform = uniform_numbers(0x51DE);
        let (mut plastic, mut crossing) = (0, 0);
        for sample in 0..2000 {
            let state = MaterialState {
                matrix_plastic_strain: 0.06 * (uniform() + 1.0),
                ..MaterialState::initial(&material.parameters)
            };
            let magnitude = 0.0005 + 0.01 * (uniform() + 1.0);
            let mut strain = Mandel::from_fn(|_, _| uniform());
            strain *= magnitude / strain.norm();
            let volume_ratio = 1.0 + 0.05 * uniform();
            let update = |solver| {
                material.update_with_start(
                    &state,
                    &strain,
                    volume_ratio,
                    None,
                    Wanted::WithTangent,
                    solver,
                )
            };
            let specialised = update(LocalSolver::Specialised).unwrap();
            let general = update(LocalSolver::General).unwrap();
            assert_eq!(specialised.plastic, general.plastic, "sample {sample}");
            if !specialised.plastic {
                assert_eq!(specialised, general, "sample {sample}");
                continue;
            }
            plastic += 1;
            let increment = specialised.state.matrix_plastic_strain - state.matrix_plastic_strain;
            let knots = material.flow.plastic_strain();
            if knots.iter().any(|&knot| {
                state.matrix_plastic_strain < knot && knot < state.matrix_plastic_strain + increment
            }) {
                crossing += 1;
            }
            let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= 1e-10 * scale;
            assert!(
                close(
                    specialised.state.matrix_plastic_strain,
                    general.state.matrix_plastic_strain,
                    increment
                ),
                "sample {sample}: ε_m {} against {}",
                specialised.state.matrix_plastic_strain,
                general.state.matrix_plastic_strain
            );
            assert_eq!(specialised.state.porosity, general.state.porosity);
            let pairs: [(&str, &[f64], &[f64]); 3] = [
                (
                    "σ",
                    specialised.stress_mpa.as_slice(),
                    general.stress_mpa.as_slice(),
                ),
                (
                    "D",
                    specialised.tangent_mpa.as_slice(),
                    general.tangent_mpa.as_slice(),
                ),
                (
                    "∂τ/∂J",
                    specialised.stress_by_volume_ratio_mpa.as_slice(),
                    general.stress_by_volume_ratio_mpa.as_slice(),
                ),
            ];
            for (name, ours, theirs) in pairs {
                let scale = theirs.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                for (a, b) in ours.iter().zip(theirs) {
                    assert!(
                        close(*a, *b, scale),
                        "sample {sample}: {name} {a} against {b}"
                    );
                }
            }
        }
        assert!(plastic >= 1000, "only {plastic} plastic samples");
        assert!(crossing >= 200, "only {crossing} steps across a knot");
    }
}
