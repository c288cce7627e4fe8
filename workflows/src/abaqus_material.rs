//! The calibrated GTN material as an Abaqus input block, for the user's own
//! model: `*MATERIAL`, `*ELASTIC`, `*PLASTIC` (the matrix flow table, carried
//! on with the calibrated post-UTS slope), `*POROUS METAL PLASTICITY`
//! (q1, q2, q3 and the initial relative density), `*VOID NUCLEATION` and,
//! with coalescence, `*POROUS FAILURE CRITERIA`.
//!
//! Keywords and data lines as the Abaqus Keywords Reference gives them
//! (pages "*POROUS METAL PLASTICITY", "*VOID NUCLEATION", "*POROUS FAILURE
//! CRITERIA"; the table data in order as in abqpy, haiiliin/abqpy
//! `src/abaqus/Material/Plastic/Metal/Porous/{PorousMetalPlasticity,
//! VoidNucleation,PorousFailureCriteria}.py`):
//! - `*ELASTIC`: Young's modulus, Poisson's ratio.
//! - `*PLASTIC`: yield stress, plastic strain; one pair per line, the first at
//!   plastic strain 0. Abaqus holds the stress constant past the last pair,
//!   so the table ends with a point on the calibrated slope m at plastic
//!   strain [`LAST_PLASTIC_STRAIN`], beyond any strain a tensile bar reaches.
//! - `*POROUS METAL PLASTICITY, RELATIVE DENSITY=r0`: q1, q2, q3. The
//!   parameter is the initial relative density `r0 = 1 - f0`, not f0.
//! - `*VOID NUCLEATION`: epsN (mean nucleation strain), sN (its standard
//!   deviation), fN (volume fraction of nucleating voids).
//! - `*POROUS FAILURE CRITERIA`: fF (void fraction at failure), fc (critical
//!   void fraction). Abaqus/Explicit only.
//!
//! Units are acq's: N, mm, MPa (with tonne and s, consistent in Abaqus).

use std::fmt::Write as _;

use acq_twins::tensile::gtn::GtnMaterial;

/// Plastic strain of the last `*PLASTIC` pair, on the post-UTS slope.
pub const LAST_PLASTIC_STRAIN: f64 = 2.0;

/// The material block. `name`: the `*MATERIAL` name (letters, digits and
/// underscores); `provenance`: comment lines written first (what it was
/// calibrated on, the element size it belongs to).
pub fn abaqus_material_block(name: &str, material: &GtnMaterial, provenance: &[String]) -> String {
    let mut text = String::new();
    for line in provenance {
        let _ = writeln!(text, "** {line}");
    }
    let _ = writeln!(text, "** Units: N, mm, MPa.");
    let _ = writeln!(text, "*MATERIAL, NAME={name}");
    let _ = writeln!(text, "*ELASTIC");
    let _ = writeln!(
        text,
        "{}, {}",
        material.elasticity.youngs_modulus_mpa, material.elasticity.poisson_ratio
    );
    let _ = writeln!(text, "*PLASTIC");
    let flow = &material.flow;
    for (strain, stress) in flow.plastic_strain().iter().zip(flow.true_stress_mpa()) {
        let _ = writeln!(text, "{stress}, {strain}");
    }
    let last_strain = flow.plastic_strain().last().copied().unwrap_or(0.0);
    if last_strain < LAST_PLASTIC_STRAIN {
        let (stress, _) = flow.flow_stress_mpa(LAST_PLASTIC_STRAIN);
        let _ = writeln!(text, "{stress}, {LAST_PLASTIC_STRAIN}");
    }
    let parameters = &material.parameters;
    let _ = writeln!(
        text,
        "*POROUS METAL PLASTICITY, RELATIVE DENSITY={}",
        1.0 - parameters.initial_porosity
    );
    let _ = writeln!(
        text,
        "{}, {}, {}",
        parameters.q1, parameters.q2, parameters.q3
    );
    let _ = writeln!(text, "*VOID NUCLEATION");
    let _ = writeln!(
        text,
        "{}, {}, {}",
        parameters.nucleation_mean_strain,
        parameters.nucleation_std_strain,
        parameters.nucleated_void_fraction
    );
    if let Some(coalescence) = &parameters.coalescence {
        let _ = writeln!(
            text,
            "** Abaqus/Explicit only. Past fc acq accelerates the porosity toward f_u*, the smaller\n\
             ** root of 1 - 2 q1 f + q3 f^2 (1/q1 when q3 >= q1^2): compare with your solver's\n\
             ** definition before comparing curves past the onset of coalescence."
        );
        let _ = writeln!(text, "*POROUS FAILURE CRITERIA");
        let _ = writeln!(
            text,
            "{}, {}",
            coalescence.failure_porosity, coalescence.critical_porosity
        );
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use acq_twins::tensile::flow_curve::FlowCurve;
    use acq_twins::tensile::gtn::{Coalescence, Elasticity, GtnParameters};

    fn material(coalescence: Option<Coalescence>) -> GtnMaterial {
        let parameters = GtnParameters {
            coalescence,
            ..GtnParameters::tvergaard_chu_needleman(0.002)
        };
        let flow = FlowCurve::new(vec![0.0, 0.1], vec![400.0, 500.0], 250.0).unwrap();
        let elasticity = Elasticity {
            youngs_modulus_mpa: 210_000.0,
            poisson_ratio: 0.3,
        };
        GtnMaterial::new(elasticity, parameters, flow).unwrap()
    }

    #[test]
    fn the_block_has_each_keyword_once_and_the_slope_carried_on() {
        let text = abaqus_material_block("ACQ_GTN", &material(None), &["calibrated".into()]);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "** calibrated");
        assert!(lines.contains(&"*MATERIAL, NAME=ACQ_GTN"));
        assert!(lines.contains(&"210000, 0.3"));
        // 400 at 0, 500 at 0.1, then m = 250 MPa to plastic strain 2: 975 MPa.
        let plastic = lines.iter().position(|l| *l == "*PLASTIC").unwrap();
        assert_eq!(
            &lines[plastic + 1..plastic + 4],
            ["400, 0", "500, 0.1", "975, 2"]
        );
        assert!(lines.contains(&"*POROUS METAL PLASTICITY, RELATIVE DENSITY=0.998"));
        assert!(lines.contains(&"1.5, 1, 2.25"));
        assert!(lines.contains(&"0.3, 0.1, 0.04"));
        assert!(!text.contains("*POROUS FAILURE CRITERIA"));
        let with = abaqus_material_block(
            "ACQ_GTN",
            &material(Some(Coalescence {
                critical_porosity: 0.02,
                failure_porosity: 0.15,
            })),
            &[],
        );
        let lines: Vec<&str> = with.lines().collect();
        let failure = lines
            .iter()
            .position(|l| *l == "*POROUS FAILURE CRITERIA")
            .unwrap();
        assert_eq!(lines[failure + 1], "0.15, 0.02");
    }
}
