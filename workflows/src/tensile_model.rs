//! The tensile twin set up from a test: the flow curve and Young's modulus
//! come from the test itself ([`acq_analysis::extract::tensile_props`]), the eight
//! calibrated GTN parameters from the caller; a run pulls the bar to the
//! test's last displacement and scores the curve with the published MAPE
//! ([`acq_analysis::loss::curve`]).
//!
//! This is what `acq twin gtn` runs once and what calibration runs many
//! times.

use std::time::Instant;

use acq_analysis::extract::tensile_props::{TensileProperties, TestPoint};
use acq_analysis::loss::curve::{curve_mape, CurveMape, CurveMapeOptions};
use acq_twins::tensile::flow_curve::FlowCurve;
use acq_twins::tensile::gtn::{Coalescence, Elasticity, GtnMaterial, GtnParameters};
use acq_twins::tensile::mesh::{BarGeometry, MeshDensity};
use acq_twins::tensile::sensitivity::ForceSensitivities;
use acq_twins::tensile::solver::{LoadingSettings, Outcome, PullResult};
use acq_twins::tensile::{TensileTwin, GTN_PARAMETER_NAMES};
use serde::Serialize;

/// Poisson's ratio of the steel (reference: nu = 0.3).
pub const POISSON_RATIO: f64 = 0.3;

/// The calibrated parameters, in the order of the reference's table.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct GtnInputs {
    pub q1: f64,
    pub q2: f64,
    pub q3: f64,
    /// Mean nucleation strain epsN.
    pub eps_n: f64,
    /// Nucleation strain spread sN.
    pub s_n: f64,
    /// Nucleated void volume fraction fN.
    pub f_n: f64,
    /// Initial porosity f0.
    pub f0: f64,
    /// Post-UTS slope of the flow curve m, MPa.
    pub m_mpa: f64,
    /// Optional coalescence (f_c, f_F).
    pub coalescence: Option<(f64, f64)>,
}

/// The parameter names `--param` takes, in order: the twin's, in which its
/// sensitivities are computed.
pub const PARAMETER_NAMES: [&str; 8] = GTN_PARAMETER_NAMES;

impl GtnInputs {
    /// Parses `q1=1.332,q2=0.9952,...`: all eight names once each, plus
    /// optionally `fc` and `fF` together.
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut values: [Option<f64>; 8] = [None; 8];
        let (mut critical, mut failure) = (None, None);
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (name, value) = item
                .split_once('=')
                .ok_or_else(|| format!("`{item}`: expected NAME=VALUE"))?;
            let (name, value) = (name.trim(), value.trim());
            let number: f64 = value
                .parse()
                .map_err(|_| format!("{name}: `{value}` is not a number"))?;
            if !number.is_finite() {
                return Err(format!("{name}: {value} is not finite"));
            }
            let slot = match name {
                "fc" => &mut critical,
                "fF" => &mut failure,
                _ => {
                    let index =
                        PARAMETER_NAMES
                            .iter()
                            .position(|n| *n == name)
                            .ok_or_else(|| {
                                format!(
                            "unknown parameter `{name}`; expected {} (and optionally fc, fF)",
                            PARAMETER_NAMES.join(", ")
                        )
                            })?;
                    &mut values[index]
                }
            };
            if slot.replace(number).is_some() {
                return Err(format!("{name} is given twice"));
            }
        }
        let missing: Vec<&str> = PARAMETER_NAMES
            .iter()
            .zip(&values)
            .filter(|(_, v)| v.is_none())
            .map(|(n, _)| *n)
            .collect();
        if !missing.is_empty() {
            return Err(format!("missing parameter(s): {}", missing.join(", ")));
        }
        let coalescence = match (critical, failure) {
            (Some(c), Some(f)) => Some((c, f)),
            (None, None) => None,
            _ => return Err("coalescence needs both fc and fF".into()),
        };
        let v = values.map(|v| v.unwrap_or(f64::NAN));
        Ok(GtnInputs {
            q1: v[0],
            q2: v[1],
            q3: v[2],
            eps_n: v[3],
            s_n: v[4],
            f_n: v[5],
            f0: v[6],
            m_mpa: v[7],
            coalescence,
        })
    }

    /// The eight parameters in [`PARAMETER_NAMES`] order, no coalescence.
    ///
    /// # Errors
    /// Not exactly eight values.
    /// Each parameter by its `--param` name, in [`PARAMETER_NAMES`]' order,
    /// then `fc` and `fF` with coalescence.
    pub fn named_values(&self) -> Vec<(String, f64)> {
        let values = [
            self.q1, self.q2, self.q3, self.eps_n, self.s_n, self.f_n, self.f0, self.m_mpa,
        ];
        let mut named: Vec<(String, f64)> = PARAMETER_NAMES
            .iter()
            .map(|name| name.to_string())
            .zip(values)
            .collect();
        if let Some((critical, failure)) = self.coalescence {
            named.extend([("fc".to_string(), critical), ("fF".to_string(), failure)]);
        }
        named
    }

    pub fn from_values(values: &[f64]) -> Result<Self, String> {
        let &[q1, q2, q3, eps_n, s_n, f_n, f0, m_mpa] = values else {
            return Err(format!(
                "{} values given; the GTN twin takes 8 ({})",
                values.len(),
                PARAMETER_NAMES.join(", ")
            ));
        };
        Ok(GtnInputs {
            q1,
            q2,
            q3,
            eps_n,
            s_n,
            f_n,
            f0,
            m_mpa,
            coalescence: None,
        })
    }

    fn parameters(&self) -> GtnParameters {
        GtnParameters {
            q1: self.q1,
            q2: self.q2,
            q3: self.q3,
            nucleation_mean_strain: self.eps_n,
            nucleation_std_strain: self.s_n,
            nucleated_void_fraction: self.f_n,
            initial_porosity: self.f0,
            coalescence: self.coalescence.map(|(critical, failure)| Coalescence {
                critical_porosity: critical,
                failure_porosity: failure,
            }),
        }
    }
}

/// The mesh of the GTN commands: element counts, or an element size at
/// the neck (the size GTN parameters belong to).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshOptions {
    /// RADIALxAXIAL elements of the quarter model, graded toward the neck.
    pub mesh: String,
    /// Element size in the neck zone, mm (instead of `mesh`).
    pub element_mm: Option<f64>,
    /// Length of the neck zone from the mid-gauge plane, mm, with
    /// `element_mm`; `None` is one diameter.
    pub neck_zone_mm: Option<f64>,
}

impl Default for MeshOptions {
    fn default() -> Self {
        MeshOptions {
            mesh: "6x30".into(),
            element_mm: None,
            neck_zone_mm: None,
        }
    }
}

impl MeshOptions {
    /// The mesh these options ask for on `geometry`; the message names the
    /// option and what was expected.
    pub fn density(&self, geometry: &BarGeometry) -> Result<MeshDensity, String> {
        match self.element_mm {
            Some(element_mm) => {
                MeshDensity::by_element_size(geometry, element_mm, self.neck_zone_mm)
                    .map_err(|e| format!("--element-mm: {e}"))
            }
            None if self.neck_zone_mm.is_some() => {
                Err("--neck-zone-mm sets the zone of --element-mm: give --element-mm too".into())
            }
            None => MeshDensity::parse(&self.mesh).map_err(|e| format!("--mesh {e}")),
        }
    }
}

impl ModelSettings {
    /// The mesh in words, with the element size at the neck that GTN
    /// results belong to.
    pub fn mesh_sentence(&self) -> String {
        let (radial_mm, axial_mm) = self.mesh.neck_element_mm(&self.geometry);
        let zone = match &self.mesh.neck_zone {
            Some(zone) => format!(
                "square elements of {radial_mm:.4} mm over a neck zone of {} mm, graded to {:.3} mm at the end",
                zone.length_mm,
                axial_mm * self.mesh.axial_grading
            ),
            None => format!(
                "neck elements {radial_mm:.4} mm radial x {axial_mm:.4} mm axial, graded {}x toward the end",
                self.mesh.axial_grading
            ),
        };
        format!(
            "quarter bar {} x {} elements (F-bar, finite strain), {zone}",
            self.mesh.radial_elements, self.mesh.axial_elements
        )
    }

    /// The mesh for a summary: counts, the element size at the neck (the
    /// size GTN parameters belong to) and the neck zone (null for a mesh
    /// given by counts).
    pub fn mesh_json(&self) -> serde_json::Value {
        let (radial_mm, axial_mm) = self.mesh.neck_element_mm(&self.geometry);
        serde_json::json!({
            "radial_elements": self.mesh.radial_elements,
            "axial_elements": self.mesh.axial_elements,
            "neck_element_radial_mm": radial_mm,
            "neck_element_axial_mm": axial_mm,
            "neck_zone_mm": self.mesh.neck_zone.map(|zone| zone.length_mm),
        })
    }
}

/// How finely the bar is modelled and pulled.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ModelSettings {
    pub mesh: MeshDensity,
    pub geometry: BarGeometry,
    pub output_interval_mm: f64,
}

impl Default for ModelSettings {
    fn default() -> Self {
        ModelSettings {
            mesh: MeshDensity::default(),
            geometry: BarGeometry::default(),
            output_interval_mm: LoadingSettings::to(1.0).output_interval_mm,
        }
    }
}

/// The twin of a flow curve given as (plastic strain, true stress MPa)
/// pairs from 0 plastic strain, Young's modulus (MPa; Poisson's ratio
/// 0.3), one GTN parameter set (m extends the table past its last point)
/// and the bar and mesh of `settings`. Parameters out of their physical
/// range are an error naming the parameter.
pub fn build_twin(
    flow_table: &[(f64, f64)],
    youngs_modulus_mpa: f64,
    inputs: &GtnInputs,
    settings: &ModelSettings,
) -> Result<TensileTwin, String> {
    let flow = FlowCurve::new(
        flow_table.iter().map(|p| p.0).collect(),
        flow_table.iter().map(|p| p.1).collect(),
        inputs.m_mpa,
    )
    .map_err(|e| format!("flow curve: {e}"))?;
    let elasticity = Elasticity {
        youngs_modulus_mpa,
        poisson_ratio: POISSON_RATIO,
    };
    let material =
        GtnMaterial::new(elasticity, inputs.parameters(), flow).map_err(|e| e.to_string())?;
    Ok(TensileTwin {
        geometry: settings.geometry,
        mesh: settings.mesh,
        material,
    })
}

/// The header of an explicit flow curve file.
pub const FLOW_CURVE_COLUMNS: [&str; 2] = ["PLASTIC_STRAIN", "TRUE_STRESS_MPA"];

/// Reads an explicit flow curve: a CSV with `PLASTIC_STRAIN` and
/// `TRUE_STRESS_MPA` columns (others ignored), the first row at plastic
/// strain 0. Errors name the file and line.
pub fn read_flow_curve(path: &std::path::Path) -> Result<Vec<(f64, f64)>, String> {
    let text = acq_io::input::read_text(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let rows = acq_algorithms::doe::read_csv_columns(
        &text,
        &FLOW_CURVE_COLUMNS,
        "point of the flow curve",
    )
    .map_err(|e| format!("{}: {e}", path.display()))?;
    let table: Vec<(f64, f64)> = rows.iter().map(|r| (r[0], r[1])).collect();
    // The same checks the twin makes, with the file's name on them.
    FlowCurve::new(
        table.iter().map(|p| p.0).collect(),
        table.iter().map(|p| p.1).collect(),
        0.0,
    )
    .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(table)
}

/// A test, ready to be simulated with any parameter set.
#[derive(Clone, Debug)]
pub struct TensileModel {
    pub test: Vec<TestPoint>,
    pub properties: TensileProperties,
    pub settings: ModelSettings,
}

/// One simulation scored against the test.
#[derive(Clone, Debug, Serialize)]
pub struct TensileRun {
    pub mape: CurveMape,
    /// The run ended (fracture or no convergence) before the test's last
    /// displacement; the rest of the curve counts as zero force.
    pub failed_early: bool,
    pub result: PullResult,
    pub wall_s: f64,
}

impl TensileModel {
    /// The model of `test` (its properties already computed from it); the
    /// bar's diameter and half length are the test's specimen.
    pub fn new(
        test: Vec<TestPoint>,
        properties: TensileProperties,
        mut settings: ModelSettings,
    ) -> Self {
        settings.geometry.diameter_mm = properties.diameter_mm;
        settings.geometry.half_length_mm = properties.strain_length_mm;
        // A mesh by element size follows the specimen (if it cannot, the
        // simulation says why).
        if let Ok(mesh) = settings.mesh.on(&settings.geometry) {
            settings.mesh = mesh;
        }
        TensileModel {
            test,
            properties,
            settings,
        }
    }

    /// The twin for one parameter set; parameters out of their physical
    /// range are an error naming the parameter.
    pub fn twin(&self, inputs: &GtnInputs) -> Result<TensileTwin, String> {
        let flow = &self.properties.flow_curve.points;
        let table: Vec<(f64, f64)> = flow
            .iter()
            .map(|p| (p.plastic_strain, p.true_stress_mpa))
            .collect();
        build_twin(
            &table,
            self.properties.youngs_modulus_mpa,
            inputs,
            &self.settings,
        )
    }

    /// The test's last displacement, mm: where the simulation stops.
    pub fn end_displacement_mm(&self) -> f64 {
        self.test
            .iter()
            .map(|p| p.displacement_mm)
            .fold(0.0, f64::max)
    }

    /// Simulates one parameter set up to the test's last displacement,
    /// without scoring it.
    pub fn pull(&self, inputs: &GtnInputs) -> Result<PullResult, String> {
        let twin = self.twin(inputs)?;
        twin.pull(&self.loading())
    }

    /// [`TensileModel::pull`], and the force's derivative in each of
    /// [`PARAMETER_NAMES`] at each point of the curve, kN per unit of the
    /// parameter, computed along with the run (see
    /// `acq_twins::tensile::sensitivity`). The sensitivities' own error
    /// comes with the curve.
    pub fn pull_with_sensitivities(
        &self,
        inputs: &GtnInputs,
    ) -> Result<(PullResult, Result<ForceSensitivities, String>), String> {
        let twin = self.twin(inputs)?;
        twin.pull_with_sensitivities(&self.loading())
    }

    fn loading(&self) -> LoadingSettings {
        let mut loading = LoadingSettings::to(self.end_displacement_mm());
        loading.output_interval_mm = self.settings.output_interval_mm;
        loading
    }

    /// Simulates and scores one parameter set.
    pub fn run(&self, inputs: &GtnInputs) -> Result<TensileRun, String> {
        let end = self.end_displacement_mm();
        let start = Instant::now();
        let result = self.pull(inputs)?;
        let wall_s = start.elapsed().as_secs_f64();
        let test: Vec<(f64, f64)> = self
            .test
            .iter()
            .map(|p| (p.displacement_mm, p.force_kn))
            .collect();
        let simulation: Vec<(f64, f64)> = result
            .curve
            .iter()
            .map(|p| (p.displacement_mm, p.force_kn))
            .collect();
        let options = CurveMapeOptions {
            split_at_mm: Some(self.properties.uts.displacement_mm),
            ..CurveMapeOptions::default()
        };
        let mape = curve_mape(&test, &simulation, options).map_err(|e| e.to_string())?;
        let failed_early = match &result.outcome {
            Outcome::ReachedEnd => false,
            Outcome::Fractured { displacement_mm }
            | Outcome::NotConverged {
                displacement_mm, ..
            } => *displacement_mm < end,
        };
        Ok(TensileRun {
            mape,
            failed_early,
            result,
            wall_s,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_parse_by_name_in_any_order() {
        let inputs = GtnInputs::parse(
            "m=534.1,q1=1.332,q2=0.9952,q3=2.295,epsN=0.29,sN=0.1671,fN=0.03869,f0=0.00137",
        )
        .unwrap();
        assert_eq!(inputs.q1, 1.332);
        assert_eq!(inputs.m_mpa, 534.1);
        assert_eq!(inputs.f0, 0.00137);
        assert_eq!(inputs.coalescence, None);
        let with =
            GtnInputs::parse("q1=1,q2=1,q3=1,epsN=0.3,sN=0.1,fN=0.04,f0=0.001,m=100,fc=0.1,fF=0.2")
                .unwrap();
        assert_eq!(with.coalescence, Some((0.1, 0.2)));
    }

    #[test]
    fn bad_parameter_lists_say_what_is_wrong() {
        let all = "q1=1,q2=1,q3=1,epsN=0.3,sN=0.1,fN=0.04,f0=0.001,m=100";
        for (text, expected) in [
            ("q1=1,q2=1", "missing parameter(s): q3, epsN, sN, fN, f0, m"),
            (&format!("{all},q1=2") as &str, "q1 is given twice"),
            (&format!("{all},qq=2"), "unknown parameter `qq`"),
            (&format!("{all},fc=0.1"), "coalescence needs both fc and fF"),
            ("q1=abc", "q1: `abc` is not a number"),
            ("q1", "`q1`: expected NAME=VALUE"),
            (&all.replace("m=100", "m=inf"), "m: inf is not finite"),
        ] {
            let error = GtnInputs::parse(text).unwrap_err();
            assert!(error.contains(expected), "{text}: {error}");
        }
    }
}
