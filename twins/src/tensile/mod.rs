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
pub mod solver;
mod split_band;

use serde::Serialize;

use element::{PointMaterial, PointResponse};
use gtn::{GtnMaterial, Mandel, MaterialState, Wanted};
use mesh::{BarGeometry, Mesh, MeshDensity};
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
        self.material.validate().map_err(|e| e.to_string())?;
        if !(settings.end_displacement_mm > 0.0 && settings.end_displacement_mm.is_finite()) {
            return Err(format!(
                "end displacement must be positive, got {} mm",
                settings.end_displacement_mm
            ));
        }
        let mesh = Mesh::new(&self.geometry, &self.mesh)?;
        Ok(Bar::new(mesh, self.material.clone()).pull(settings))
    }
}
