//! The tensile twin: an axisymmetric finite-strain finite-element model of a
//! round tensile bar whose material is Gurson-Tvergaard-Needleman porous
//! plasticity.
//!
//! - [`flow_curve`]: the matrix flow stress vs plastic strain (table + slope m).
//! - [`gtn`]: the GTN material point (Aravas return mapping, consistent tangent).
//! - [`kinematics`]: axisymmetric deformation gradients, the logarithmic
//!   strain and its derivative.
//! - [`element`]: the 4-node F-bar element with its exact tangent.
//! - [`mesh`]: the quarter model of the bar (symmetry on the axis and the
//!   mid-gauge plane), graded toward the neck.
//! - [`banded`]: the banded LU solver of the stiffness equations
//!   (`split_band`: the bar's, cut in two halves factored at once);
//!   `local_lu`: the return mapping's 4 x 4 systems.
//! - [`solver`]: displacement-controlled Newton with step cutting, the
//!   force-displacement curve and how the run ended.
//! - [`sensitivity`]: the curve's derivatives in the material's parameters,
//!   computed along with the pull (direct differentiation).
//!
//! [`TensileTwin`] ties them together: geometry + mesh + material in, a
//! force (kN) vs end displacement (mm) curve out, the same quantities as the
//! test files.

pub mod banded;
pub mod element;
pub mod flow_curve;
pub mod gtn;
pub mod kinematics;
mod local_lu;
pub mod mesh;
pub mod sensitivity;
pub mod solver;
mod split_band;

use serde::Serialize;

use element::{PointMaterial, PointResponse};
use gtn::{GtnMaterial, Mandel, MaterialState, Wanted};
use mesh::{BarGeometry, Mesh, MeshDensity};
use sensitivity::{ForceSensitivities, ParameterisedMaterial, INTERNAL_VARIABLES};
use solver::{Bar, LoadingSettings, PullResult};

/// Stiffness a failed point keeps, as a fraction of the elastic one: enough
/// to keep the stiffness matrix regular once a layer of elements has broken,
/// too little to carry load (it adds no stress, only a tangent).
const FAILED_POINT_STIFFNESS_FRACTION: f64 = 1e-6;

impl PointMaterial for GtnMaterial {
    type State = MaterialState;

    fn initial_state(&self) -> MaterialState {
        MaterialState::initial(&self.parameters)
    }

    fn update(
        &self,
        state: &MaterialState,
        trial_elastic_strain: &Mandel,
        volume_ratio: f64,
        last: &MaterialState,
        wanted: Wanted,
    ) -> Result<PointResponse<MaterialState>, String> {
        let update = self
            .update_starting_from(state, trial_elastic_strain, volume_ratio, last, wanted)
            .map_err(|e| e.to_string())?;
        let tangent_mpa = if update.state.failed && wanted == Wanted::WithTangent {
            self.elasticity.stiffness_mpa() * FAILED_POINT_STIFFNESS_FRACTION
        } else {
            update.tangent_mpa
        };
        Ok(PointResponse {
            stress_mpa: update.stress_mpa,
            elastic_strain: update.elastic_strain,
            tangent_mpa,
            stress_by_volume_ratio_mpa: update.stress_by_volume_ratio_mpa,
            state: update.state,
        })
    }

    fn has_failed(&self, state: &MaterialState) -> bool {
        state.failed
    }
}

/// The GTN parameters a curve is differentiated in, in
/// [`ParameterisedMaterial`]'s order: the yield surface's q1, q2, q3, the
/// nucleation's εN, sN, fN, the initial porosity f0, and the flow curve's
/// slope m (MPa) past its table.
pub const GTN_PARAMETER_NAMES: [&str; 8] = ["q1", "q2", "q3", "epsN", "sN", "fN", "f0", "m"];

/// The smallest magnitude each parameter's difference step is taken
/// relative to (a parameter at zero still gets a step of its scale).
const GTN_PARAMETER_SCALES: [f64; 8] = [1.0, 1.0, 1.0, 0.1, 0.01, 1e-3, 1e-4, 10.0];

/// Relative forward-difference step of the material's derivatives (see
/// [`sensitivity`]).
const RELATIVE_DIFFERENCE_STEP: f64 = 1e-6;

impl ParameterisedMaterial for GtnMaterial {
    fn parameter_names(&self) -> Vec<&'static str> {
        GTN_PARAMETER_NAMES.to_vec()
    }

    fn moved(&self, index: usize, step: f64) -> Result<Self, String> {
        let mut material = self.clone();
        let parameters = &mut material.parameters;
        match index {
            0 => parameters.q1 += step,
            1 => parameters.q2 += step,
            2 => parameters.q3 += step,
            3 => parameters.nucleation_mean_strain += step,
            4 => parameters.nucleation_std_strain += step,
            5 => parameters.nucleated_void_fraction += step,
            6 => parameters.initial_porosity += step,
            7 => {
                material.flow = self
                    .flow
                    .with_post_uts_slope_mpa(self.flow.post_uts_slope_mpa() + step)
                    .map_err(|e| e.to_string())?;
            }
            _ => return Err(format!("no parameter {index}")),
        }
        material.validate().map_err(|e| e.to_string())?;
        Ok(material)
    }

    fn difference_step(&self, index: usize) -> f64 {
        let p = &self.parameters;
        let value = [
            p.q1,
            p.q2,
            p.q3,
            p.nucleation_mean_strain,
            p.nucleation_std_strain,
            p.nucleated_void_fraction,
            p.initial_porosity,
            self.flow.post_uts_slope_mpa(),
        ]
        .get(index)
        .copied()
        .unwrap_or(1.0);
        let scale = GTN_PARAMETER_SCALES.get(index).copied().unwrap_or(1.0);
        RELATIVE_DIFFERENCE_STEP * value.abs().max(scale)
    }

    fn internal_variables(state: &MaterialState) -> [f64; INTERNAL_VARIABLES] {
        [state.matrix_plastic_strain, state.porosity]
    }

    fn with_internal_variables_moved(
        state: &MaterialState,
        by: [f64; INTERNAL_VARIABLES],
    ) -> MaterialState {
        MaterialState {
            matrix_plastic_strain: state.matrix_plastic_strain + by[0],
            porosity: state.porosity + by[1],
            ..*state
        }
    }
}

/// The bar, its mesh and its material.
#[derive(Clone, Debug, Serialize)]
pub struct TensileTwin {
    pub geometry: BarGeometry,
    pub mesh: MeshDensity,
    pub material: GtnMaterial,
}

impl TensileTwin {
    /// Pulls the bar to `settings.end_displacement_mm` (or fracture).
    ///
    /// # Errors
    /// Geometry or mesh out of range, or material parameters out of their
    /// physical range: the message says which.
    pub fn pull(&self, settings: &LoadingSettings) -> Result<PullResult, String> {
        Ok(self.bar(settings)?.pull(settings))
    }

    /// [`TensileTwin::pull`], and the force's derivative in each of
    /// [`GTN_PARAMETER_NAMES`] at each point of the curve.
    ///
    /// # Errors
    /// As [`TensileTwin::pull`]; the sensitivities' own error (a parameter
    /// that cannot be moved, a singular tangent) comes with the curve.
    pub fn pull_with_sensitivities(
        &self,
        settings: &LoadingSettings,
    ) -> Result<(PullResult, Result<ForceSensitivities, String>), String> {
        Ok(self.bar(settings)?.pull_with_sensitivities(settings))
    }

    fn bar(&self, settings: &LoadingSettings) -> Result<Bar<GtnMaterial>, String> {
        self.material.validate().map_err(|e| e.to_string())?;
        if !(settings.end_displacement_mm > 0.0 && settings.end_displacement_mm.is_finite()) {
            return Err(format!(
                "end displacement must be positive, got {} mm",
                settings.end_displacement_mm
            ));
        }
        let mesh = Mesh::new(&self.geometry, &self.mesh)?;
        Ok(Bar::new(mesh, self.material.clone()))
    }
}
