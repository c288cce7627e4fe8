//! The axisymmetric 4-node F-bar element at finite strain, with its exact
//! tangent.
//!
//! - Bilinear quadrilateral in (R, Z), 2 x 2 Gauss points, total-Lagrangian
//!   bookkeeping (all gradients with respect to the undeformed mesh).
//! - F-bar (de Souza Neto, Peric, Dutko, Owen 1996): each Gauss point uses
//!   `F_bar = (J0 / J)^(1/3) F`, where J0 is the volume ratio at the element
//!   centre. The volume change is then constant over the element, which
//!   removes the volumetric locking of plastic (nearly isochoric) flow.
//! - Stress update: elastic predictor `b_trial = F_bar G F_bar^T` with
//!   `G = C_p^-1` from the last converged step, `eps_trial = 1/2 ln b_trial`,
//!   the material's small-strain return mapping in logarithmic strain space
//!   gives the Kirchhoff stress tau (exact for isotropic elasticity and flow,
//!   the exponential-map integrator), then `G_new = F_bar^-1 b_e F_bar^-T`.
//! - Virtual work in the current configuration with the F-bar Cauchy stress
//!   `sigma = tau / J0`, pulled back: `P = (J / J0) tau F^-T`, and
//!   `f = integral B^T P dV0` with `dV0 = 2 pi R dA`.
//! - The tangent is the exact derivative of that f with respect to the
//!   nodal displacements (chain rule through F_bar, the logarithm, the
//!   return mapping's consistent tangent and `F^-T`); a test compares it
//!   with finite differences. It is not symmetric.

use nalgebra::{SMatrix, SVector};

use super::kinematics::{
    self, determinant, determinant_derivative, inverse, log_strain, log_strain_with_derivative,
    push_forward, push_forward_derivative, stretch_from_log_strain, times_inverse_transpose,
    times_inverse_transpose_by_gradient, times_inverse_transpose_by_stress, Gradient, Symmetric,
};

/// The element maps (r, z, theta) to the material's (1, 2, 3).
pub use super::gtn::{Mandel, MandelTangent, Wanted};

/// Element nodal displacements `[u_r0, u_z0, u_r1, u_z1, ...]` in mm.
pub type ElementDisplacement = SVector<f64, 8>;
pub type ElementForce = SVector<f64, 8>;
pub type ElementStiffness = SMatrix<f64, 8, 8>;

/// What a material returns for one Gauss point and one step.
#[derive(Clone, Debug)]
pub struct PointResponse<S> {
    /// Kirchhoff stress, MPa.
    pub stress_mpa: Mandel,
    /// Elastic logarithmic strain after the step.
    pub elastic_strain: Mandel,
    /// d stress / d trial elastic strain (the consistent tangent), MPa.
    pub tangent_mpa: MandelTangent,
    /// ∂ stress / ∂ volume ratio at fixed trial strain, MPa (zero for a
    /// material whose Kirchhoff stress depends on the strain only).
    pub stress_by_volume_ratio_mpa: Mandel,
    pub state: S,
}

/// A material in logarithmic-strain space: a small-strain return mapping
/// driven by the trial elastic logarithmic strain, returning the Kirchhoff
/// stress. The volume ratio J = det F_bar is handed over for materials whose
/// yield condition is written in the Cauchy stress τ/J (GTN).
pub trait PointMaterial {
    type State: Copy + std::fmt::Debug;
    fn initial_state(&self) -> Self::State;
    /// `last` is the state this point's previous update gave (the last
    /// Newton iteration's, or the last step's): a material that solves a
    /// local problem may start from its solution. With
    /// [`Wanted::StressOnly`] the tangents may come back zero.
    fn update(
        &self,
        state: &Self::State,
        trial_elastic_strain: &Mandel,
        volume_ratio: f64,
        last: &Self::State,
        wanted: Wanted,
    ) -> Result<PointResponse<Self::State>, String>;
    /// Whether the point no longer carries load.
    fn has_failed(&self, state: &Self::State) -> bool;
}

/// The state a Gauss point carries between steps.
#[derive(Clone, Copy, Debug)]
pub struct GaussPointState<S> {
    /// `C_p^-1 = F_bar^-1 b_e F_bar^-T`, the plastic metric.
    pub plastic_metric: Symmetric,
    pub material: S,
    /// Kirchhoff stress of the last update (for output), MPa.
    pub stress_mpa: Symmetric,
}

impl<S: Copy> GaussPointState<S> {
    pub fn new(material: S) -> Self {
        GaussPointState {
            plastic_metric: kinematics::identity_symmetric(),
            material,
            stress_mpa: Symmetric::zeros(),
        }
    }
}

/// Why an element could not be evaluated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ElementError {
    #[error("element turned inside out (J = {volume_ratio:.3e})")]
    InsideOut { volume_ratio: f64 },
    #[error("material update failed: {0}")]
    Material(String),
}

const GAUSS: f64 = 0.577_350_269_189_625_8;
const POINTS: [(f64, f64); 4] = [
    (-GAUSS, -GAUSS),
    (GAUSS, -GAUSS),
    (GAUSS, GAUSS),
    (-GAUSS, GAUSS),
];

/// One element's reference geometry, precomputed: the gradient operators
/// at the Gauss points and at the centre, and the integration weights.
#[derive(Clone, Debug)]
pub struct ElementShape {
    gauss: [SMatrix<f64, 5, 8>; 4],
    weights_mm3: [f64; 4],
    centre: SMatrix<f64, 5, 8>,
}

/// Gradient operator `B` (5 x 8) such that `F - I = B u`, and the radius,
/// Jacobian determinant at (xi, eta). Nodes counter-clockwise in (R, Z).
fn gradient_operator(nodes: &[[f64; 2]; 4], xi: f64, eta: f64) -> (SMatrix<f64, 5, 8>, f64, f64) {
    let shape = [
        0.25 * (1.0 - xi) * (1.0 - eta),
        0.25 * (1.0 + xi) * (1.0 - eta),
        0.25 * (1.0 + xi) * (1.0 + eta),
        0.25 * (1.0 - xi) * (1.0 + eta),
    ];
    let d_xi = [
        -0.25 * (1.0 - eta),
        0.25 * (1.0 - eta),
        0.25 * (1.0 + eta),
        -0.25 * (1.0 + eta),
    ];
    let d_eta = [
        -0.25 * (1.0 - xi),
        -0.25 * (1.0 + xi),
        0.25 * (1.0 + xi),
        0.25 * (1.0 - xi),
    ];
    let (mut r_xi, mut r_eta, mut z_xi, mut z_eta, mut radius) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for a in 0..4 {
        r_xi += d_xi[a] * nodes[a][0];
        r_eta += d_eta[a] * nodes[a][0];
        z_xi += d_xi[a] * nodes[a][1];
        z_eta += d_eta[a] * nodes[a][1];
        radius += shape[a] * nodes[a][0];
    }
    let jacobian = r_xi * z_eta - r_eta * z_xi;
    let mut operator = SMatrix::<f64, 5, 8>::zeros();
    for a in 0..4 {
        let d_r = (z_eta * d_xi[a] - z_xi * d_eta[a]) / jacobian;
        let d_z = (-r_eta * d_xi[a] + r_xi * d_eta[a]) / jacobian;
        operator[(kinematics::RR, 2 * a)] = d_r;
        operator[(kinematics::RZ, 2 * a)] = d_z;
        operator[(kinematics::ZR, 2 * a + 1)] = d_r;
        operator[(kinematics::ZZ, 2 * a + 1)] = d_z;
        operator[(kinematics::TT, 2 * a)] = shape[a] / radius;
    }
    (operator, radius, jacobian)
}

impl ElementShape {
    /// Nodes counter-clockwise in (R, Z), mm; every Gauss point off the axis.
    pub fn new(nodes: &[[f64; 2]; 4]) -> Self {
        let mut gauss = [SMatrix::<f64, 5, 8>::zeros(); 4];
        let mut weights_mm3 = [0.0; 4];
        for (k, &(xi, eta)) in POINTS.iter().enumerate() {
            let (operator, radius, jacobian) = gradient_operator(nodes, xi, eta);
            gauss[k] = operator;
            weights_mm3[k] = 2.0 * std::f64::consts::PI * radius * jacobian;
        }
        let (centre, _, _) = gradient_operator(nodes, 0.0, 0.0);
        ElementShape {
            gauss,
            weights_mm3,
            centre,
        }
    }

    /// Undeformed volume of the ring the element sweeps, mm^3.
    pub fn volume_mm3(&self) -> f64 {
        self.weights_mm3.iter().sum()
    }
}

fn gradient_of(operator: &SMatrix<f64, 5, 8>, displacement: &ElementDisplacement) -> Gradient {
    kinematics::identity_gradient() + operator * displacement
}

/// Tensor components `[rr, zz, tt, rz]` of a Mandel vector (r, z, theta = 1, 2, 3).
pub fn symmetric_from_mandel(mandel: &Mandel) -> Symmetric {
    Symmetric::new(
        mandel[0],
        mandel[1],
        mandel[2],
        mandel[5] / std::f64::consts::SQRT_2,
    )
}

pub fn mandel_from_symmetric(symmetric: &Symmetric) -> Mandel {
    Mandel::new(
        symmetric[0],
        symmetric[1],
        symmetric[2],
        0.0,
        0.0,
        symmetric[3] * std::f64::consts::SQRT_2,
    )
}

/// The Mandel tangent as a map between tensor components `[rr, zz, tt, rz]`.
fn tangent_on_components(tangent: &MandelTangent) -> SMatrix<f64, 4, 4> {
    const INDEX: [usize; 4] = [0, 1, 2, 5];
    let mut map = SMatrix::<f64, 4, 4>::zeros();
    for (row, &i) in INDEX.iter().enumerate() {
        for (column, &j) in INDEX.iter().enumerate() {
            let scale = match (row == 3, column == 3) {
                (false, true) => std::f64::consts::SQRT_2,
                (true, false) => std::f64::consts::FRAC_1_SQRT_2,
                _ => 1.0,
            };
            map[(row, column)] = tangent[(i, j)] * scale;
        }
    }
    map
}

/// Internal force, tangent and the trial Gauss-point states of one element.
pub struct ElementResponse<S> {
    pub force_n: ElementForce,
    pub stiffness_n_per_mm: ElementStiffness,
    pub states: [GaussPointState<S>; 4],
}

/// Evaluates one element at the trial displacement from the converged
/// states of the last step.
/// `states` are the points' states at the last converged step, `last` what
/// their previous update gave (see [`PointMaterial::update`]).
pub fn evaluate<M: PointMaterial>(
    shape: &ElementShape,
    material: &M,
    states: &[GaussPointState<M::State>; 4],
    last: &[GaussPointState<M::State>; 4],
    displacement: &ElementDisplacement,
) -> Result<ElementResponse<M::State>, ElementError> {
    let mut response = ElementResponse {
        force_n: ElementForce::zeros(),
        stiffness_n_per_mm: ElementStiffness::zeros(),
        states: *states,
    };
    evaluate_into::<true, M>(
        shape,
        material,
        states,
        last,
        displacement,
        ElementOutput {
            force_n: &mut response.force_n,
            stiffness_n_per_mm: &mut response.stiffness_n_per_mm,
            states: &mut response.states,
        },
    )?;
    Ok(response)
}

/// Where [`evaluate_into`] writes one element's results: a solver's
/// buffers, kept from one assembly to the next. An element's results are
/// about a kilobyte, and moving them through a `Result`, a `Vec` and the
/// assembly's state vector took 5 % of a 0.09 mm run.
pub struct ElementOutput<'a, S> {
    pub force_n: &'a mut ElementForce,
    /// Written only with the tangent.
    pub stiffness_n_per_mm: &'a mut ElementStiffness,
    pub states: &'a mut [GaussPointState<S>; 4],
}

/// [`evaluate`] into the caller's storage, with the tangent only if
/// `TANGENT` (otherwise `stiffness_n_per_mm` is left as it was): a
/// convergence check needs the forces only. After an error the output
/// holds nothing meaningful.
pub fn evaluate_into<const TANGENT: bool, M: PointMaterial>(
    shape: &ElementShape,
    material: &M,
    states: &[GaussPointState<M::State>; 4],
    last: &[GaussPointState<M::State>; 4],
    displacement: &ElementDisplacement,
    output: ElementOutput<'_, M::State>,
) -> Result<(), ElementError> {
    let centre_gradient = gradient_of(&shape.centre, displacement);
    let centre_volume_ratio = determinant(&centre_gradient);
    if centre_volume_ratio <= 0.0 || !centre_volume_ratio.is_finite() {
        return Err(ElementError::InsideOut {
            volume_ratio: centre_volume_ratio,
        });
    }
    let centre_sensitivity = determinant_derivative(&centre_gradient) / centre_volume_ratio;

    let force = output.force_n;
    *force = ElementForce::zeros();
    let stiffness = output.stiffness_n_per_mm;
    if TANGENT {
        *stiffness = ElementStiffness::zeros();
    }
    for k in 0..4 {
        let operator = &shape.gauss[k];
        let gradient = gradient_of(operator, displacement);
        let volume_ratio = determinant(&gradient);
        let gradient_inverse = match inverse(&gradient) {
            Some(inverse) if volume_ratio > 0.0 => inverse,
            _ => return Err(ElementError::InsideOut { volume_ratio }),
        };
        let sensitivity = determinant_derivative(&gradient) / volume_ratio;
        let scale = (centre_volume_ratio / volume_ratio).cbrt();
        let modified = gradient * scale;

        let plastic_metric = states[k].plastic_metric;
        let trial_stretch = push_forward(&modified, &plastic_metric);
        // A convergence check needs no derivative.
        let (trial_strain, log_derivative) = if TANGENT {
            log_strain_with_derivative(&trial_stretch)
        } else {
            log_strain(&trial_stretch).map(|strain| (strain, SMatrix::zeros()))
        }
        .ok_or(ElementError::InsideOut { volume_ratio })?;
        let response = material
            .update(
                &states[k].material,
                &mandel_from_symmetric(&trial_strain),
                centre_volume_ratio,
                &last[k].material,
                if TANGENT {
                    Wanted::WithTangent
                } else {
                    Wanted::StressOnly
                },
            )
            .map_err(ElementError::Material)?;
        let kirchhoff = symmetric_from_mandel(&response.stress_mpa);
        let ratio = volume_ratio / centre_volume_ratio;
        let nominal = times_inverse_transpose(&kirchhoff, &gradient_inverse);
        let weight = shape.weights_mm3[k];
        *force += operator.transpose() * (nominal * (ratio * weight));
        if TANGENT {
            // d tau / d F_bar (4 x 5).
            let stress_by_modified = tangent_on_components(&response.tangent_mpa)
                * log_derivative
                * push_forward_derivative(&modified, &plastic_metric);

            let by_stress = times_inverse_transpose_by_stress(&gradient_inverse);
            let by_gradient = times_inverse_transpose_by_gradient(&kirchhoff, &gradient_inverse);
            let through_modified = by_stress * stress_by_modified;
            let modified_column = modified;
            let identity = SMatrix::<f64, 5, 5>::identity();
            let by_own = (nominal * sensitivity.transpose()
                + through_modified
                    * scale
                    * (identity - modified_column * sensitivity.transpose() / (3.0 * scale))
                + by_gradient)
                * ratio;
            // det F_bar = J0: the material's dependence on the volume ratio goes
            // through the centre, dJ0/dF_centre = J0 centre_sensitivity.
            let stress_by_volume_ratio =
                symmetric_from_mandel(&response.stress_by_volume_ratio_mpa);
            let by_centre = (-nominal * centre_sensitivity.transpose()
                + through_modified * modified_column * centre_sensitivity.transpose() / 3.0
                + by_stress
                    * stress_by_volume_ratio
                    * (centre_volume_ratio * centre_sensitivity.transpose()))
                * ratio;

            *stiffness +=
                operator.transpose() * (by_own * operator + by_centre * shape.centre) * weight;
        }

        let elastic_stretch =
            stretch_from_log_strain(&symmetric_from_mandel(&response.elastic_strain));
        let modified_inverse =
            inverse(&modified).ok_or(ElementError::InsideOut { volume_ratio })?;
        output.states[k] = GaussPointState {
            plastic_metric: kinematics::pull_back(&modified_inverse, &elastic_stretch),
            material: response.state,
            stress_mpa: kirchhoff,
        };
    }
    Ok(())
}

/// Isotropic Hencky hyperelasticity (`tau = lambda tr(eps) I + 2 mu eps`):
/// the element's reference material, exact in closed form for uniform
/// stretches.
#[derive(Clone, Copy, Debug)]
pub struct Hencky {
    pub youngs_modulus_mpa: f64,
    pub poisson_ratio: f64,
}

impl Hencky {
    pub fn tangent(&self) -> MandelTangent {
        let e = self.youngs_modulus_mpa;
        let nu = self.poisson_ratio;
        let lame = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let shear = e / (2.0 * (1.0 + nu));
        let mut tangent = MandelTangent::identity() * (2.0 * shear);
        for i in 0..3 {
            for j in 0..3 {
                tangent[(i, j)] += lame;
            }
        }
        tangent
    }
}

impl PointMaterial for Hencky {
    type State = ();
    fn initial_state(&self) {}
    fn update(
        &self,
        _: &(),
        trial_elastic_strain: &Mandel,
        _volume_ratio: f64,
        _last: &(),
        _wanted: Wanted,
    ) -> Result<PointResponse<()>, String> {
        let tangent = self.tangent();
        Ok(PointResponse {
            stress_mpa: tangent * trial_elastic_strain,
            elastic_strain: *trial_elastic_strain,
            tangent_mpa: tangent,
            stress_by_volume_ratio_mpa: Mandel::zeros(),
            state: (),
        })
    }
    fn has_failed(&self, _: &()) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const NODES: [[f64; 2]; 4] = [[0.4, 1.0], [1.1, 1.05], [1.15, 1.6], [0.35, 1.5]];

    fn displacement() -> ElementDisplacement {
        ElementDisplacement::from_column_slice(&[0.03, -0.02, -0.05, 0.04, 0.02, 0.09, 0.01, 0.07])
    }

    /// A J2 material with linear hardening in log strain, enough to test the
    /// element's chain rule through a plastic, non-trivial tangent.
    struct LinearJ2 {
        elastic: Hencky,
        yield_mpa: f64,
        hardening_mpa: f64,
    }

    impl PointMaterial for LinearJ2 {
        type State = f64;
        fn initial_state(&self) -> f64 {
            0.0
        }
        fn update(
            &self,
            plastic: &f64,
            trial: &Mandel,
            _volume_ratio: f64,
            _last: &f64,
            _wanted: Wanted,
        ) -> Result<PointResponse<f64>, String> {
            let c = self.elastic.tangent();
            let shear = c[(3, 3)] / 2.0;
            let stress = c * trial;
            let mean = (stress[0] + stress[1] + stress[2]) / 3.0;
            let mut deviator = stress;
            for i in 0..3 {
                deviator[i] -= mean;
            }
            let von_mises = (1.5 * deviator.norm_squared()).sqrt();
            let flow = self.yield_mpa + self.hardening_mpa * plastic;
            if von_mises <= flow {
                return Ok(PointResponse {
                    stress_mpa: stress,
                    elastic_strain: *trial,
                    tangent_mpa: c,
                    stress_by_volume_ratio_mpa: Mandel::zeros(),
                    state: *plastic,
                });
            }
            let increment = (von_mises - flow) / (3.0 * shear + self.hardening_mpa);
            let direction = deviator * (1.5 / von_mises);
            let factor = 1.0 - 3.0 * shear * increment / von_mises;
            let mut new_stress = deviator * factor;
            for i in 0..3 {
                new_stress[i] += mean;
            }
            let mut deviatoric_projection = MandelTangent::identity();
            for i in 0..3 {
                for j in 0..3 {
                    deviatoric_projection[(i, j)] -= 1.0 / 3.0;
                }
            }
            let unit = deviator / deviator.norm();
            let tangent =
                c - deviatoric_projection * (2.0 * shear) * (3.0 * shear * increment / von_mises)
                    + (unit * unit.transpose())
                        * (2.0 * shear)
                        * (3.0 * shear * increment / von_mises
                            - 3.0 * shear / (3.0 * shear + self.hardening_mpa));
            Ok(PointResponse {
                stress_mpa: new_stress,
                elastic_strain: *trial - direction * increment,
                tangent_mpa: tangent,
                stress_by_volume_ratio_mpa: Mandel::zeros(),
                state: plastic + increment,
            })
        }
        fn has_failed(&self, _: &f64) -> bool {
            false
        }
    }

    fn check_tangent<M: PointMaterial>(material: &M, states: [GaussPointState<M::State>; 4]) {
        let shape = ElementShape::new(&NODES);
        let u = displacement();
        let analytic = evaluate(&shape, material, &states, &states, &u)
            .unwrap()
            .stiffness_n_per_mm;
        let mut numeric = ElementStiffness::zeros();
        for column in 0..8 {
            let step = 1e-7;
            let mut plus = u;
            let mut minus = u;
            plus[column] += step;
            minus[column] -= step;
            let difference = evaluate(&shape, material, &states, &states, &plus)
                .unwrap()
                .force_n
                - evaluate(&shape, material, &states, &states, &minus)
                    .unwrap()
                    .force_n;
            numeric.set_column(column, &(difference / (2.0 * step)));
        }
        let error = (analytic - numeric).norm() / numeric.norm();
        assert!(
            error < 1e-6,
            "tangent error {error:e}\n{analytic}\n{numeric}"
        );
    }

    #[test]
    fn tangent_is_the_derivative_of_the_force_hencky() {
        let material = Hencky {
            youngs_modulus_mpa: 200_000.0,
            poisson_ratio: 0.3,
        };
        let mut states = [GaussPointState::new(()); 4];
        // A non-trivial plastic metric, as after earlier plastic steps.
        for (k, state) in states.iter_mut().enumerate() {
            state.plastic_metric = Symmetric::new(1.02 + 0.01 * k as f64, 0.97, 1.01, 0.015);
        }
        check_tangent(&material, states);
    }

    #[test]
    fn tangent_is_the_derivative_of_the_force_plastic() {
        let material = LinearJ2 {
            elastic: Hencky {
                youngs_modulus_mpa: 200_000.0,
                poisson_ratio: 0.3,
            },
            yield_mpa: 400.0,
            hardening_mpa: 1000.0,
        };
        let states = [GaussPointState::new(0.01); 4];
        check_tangent(&material, states);
    }

    /// GTN with porosity: the stress depends on the volume ratio (Cauchy
    /// stress in the yield function), which adds a term through the centre.
    #[test]
    fn tangent_is_the_derivative_of_the_force_gtn() {
        use crate::tensile::flow_curve::FlowCurve;
        use crate::tensile::gtn::{Elasticity, GtnMaterial, GtnParameters, MaterialState};
        let material = GtnMaterial::new(
            Elasticity {
                youngs_modulus_mpa: 207_000.0,
                poisson_ratio: 0.3,
            },
            GtnParameters::tvergaard_chu_needleman(0.002),
            FlowCurve::new(vec![0.0, 0.05, 0.1], vec![400.0, 520.0, 600.0], 500.0).unwrap(),
        )
        .unwrap();
        let mut states = [GaussPointState::new(MaterialState {
            matrix_plastic_strain: 0.2,
            porosity: 0.03,
            failed: false,
            last_increments: [0.0; 4],
        }); 4];
        for (k, state) in states.iter_mut().enumerate() {
            state.plastic_metric = Symmetric::new(1.02 + 0.01 * k as f64, 0.97, 1.01, 0.015);
        }
        let shape = ElementShape::new(&NODES);
        let response = evaluate(&shape, &material, &states, &states, &displacement()).unwrap();
        assert!(
            response.states.iter().all(|s| s.material.porosity > 0.03),
            "the check needs plastic, dilating points: {:?}",
            response.states
        );
        check_tangent(&material, states);
    }

    #[test]
    fn rigid_translation_gives_no_force_and_volume_is_a_ring() {
        let shape = ElementShape::new(&[[1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0]]);
        let expected = std::f64::consts::PI * (4.0 - 1.0);
        assert!((shape.volume_mm3() - expected).abs() < 1e-12);
        let material = Hencky {
            youngs_modulus_mpa: 200_000.0,
            poisson_ratio: 0.3,
        };
        // Axial translation (radial translation is not rigid for a ring).
        let u = ElementDisplacement::from_column_slice(&[0.0, 0.3, 0.0, 0.3, 0.0, 0.3, 0.0, 0.3]);
        let response = evaluate(
            &shape,
            &material,
            &[GaussPointState::new(()); 4],
            &[GaussPointState::new(()); 4],
            &u,
        )
        .unwrap();
        assert!(response.force_n.norm() < 1e-9);
    }
}
