//! The quarter model of a round tensile bar and its mesh.
//!
//! The model is the region `0 <= R <= radius(Z)`, `0 <= Z <= half length`
//! of the axisymmetric bar: symmetry on the axis (`u_r = 0` at R = 0) and
//! on the mid-gauge plane (`u_z = 0` at Z = 0), the end `Z = half length`
//! pulled by the prescribed displacement with its radius free. The test
//! files give the displacement over half the gauge, so the end is at half
//! the gauge length and its displacement is the test's.
//!
//! A smooth radius reduction at mid-length, `delta/2 (1 + cos(pi Z / L))`
//! of the radius, decides where the neck forms (at Z = 0) without changing
//! the curve before the force maximum. Elements are graded in Z, smallest
//! at the neck; nodes are numbered across the radius first, so the
//! stiffness matrix is banded with half-bandwidth `2 (radial elements) + 5`.

use serde::{Deserialize, Serialize};

/// The bar as tested.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BarGeometry {
    pub diameter_mm: f64,
    /// Length of the modelled half: the length the test's displacement is
    /// measured over (half the gauge).
    pub half_length_mm: f64,
    /// Radius reduction at the mid-gauge plane, as a fraction of the radius.
    pub imperfection: f64,
}

impl Default for BarGeometry {
    /// The P91 bars of the reference: diameter 4 mm, gauge 25 mm.
    fn default() -> Self {
        BarGeometry {
            diameter_mm: 4.0,
            half_length_mm: 12.5,
            imperfection: 0.001,
        }
    }
}

impl BarGeometry {
    /// Radius at axial position Z, mm.
    pub fn radius_mm(&self, z_mm: f64) -> f64 {
        let shape = 0.5 * (1.0 + (std::f64::consts::PI * z_mm / self.half_length_mm).cos());
        0.5 * self.diameter_mm * (1.0 - self.imperfection * shape)
    }

    /// Nominal cross-section, mm^2 (without the imperfection).
    pub fn area_mm2(&self) -> f64 {
        std::f64::consts::PI * 0.25 * self.diameter_mm * self.diameter_mm
    }

    pub fn validate(&self) -> Result<(), String> {
        if !(self.diameter_mm > 0.0 && self.diameter_mm.is_finite()) {
            return Err(format!(
                "diameter must be positive, got {} mm",
                self.diameter_mm
            ));
        }
        if !(self.half_length_mm > 0.0 && self.half_length_mm.is_finite()) {
            return Err(format!(
                "half length must be positive, got {} mm",
                self.half_length_mm
            ));
        }
        if !(0.0..0.5).contains(&self.imperfection) {
            return Err(format!(
                "imperfection must be in [0, 0.5), got {}",
                self.imperfection
            ));
        }
        Ok(())
    }
}

/// How finely the bar is meshed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshDensity {
    pub radial_elements: usize,
    pub axial_elements: usize,
    /// Length of the element at the end over the one at the neck (>= 1).
    pub axial_grading: f64,
}

impl Default for MeshDensity {
    fn default() -> Self {
        MeshDensity {
            radial_elements: 6,
            axial_elements: 30,
            axial_grading: 8.0,
        }
    }
}

impl MeshDensity {
    /// The most radial elements a mesh may have.
    pub const MAX_RADIAL: usize = 64;
    /// The most axial elements a mesh may have (with [`Self::MAX_RADIAL`],
    /// about 64,000 elements: more would take hours per simulation).
    pub const MAX_AXIAL: usize = 1000;

    /// `RADIALxAXIAL` element counts of the quarter model, e.g. `6x30`, with
    /// the default grading; the message says what was expected.
    pub fn parse(text: &str) -> Result<Self, String> {
        let expected = || {
            format!(
                "{text}: expected RADIALxAXIAL element counts, e.g. 6x30, with 1 to {} radial and 2 to {} axial elements",
                Self::MAX_RADIAL,
                Self::MAX_AXIAL
            )
        };
        let (radial, axial) = text.split_once('x').ok_or_else(expected)?;
        let radial: usize = radial.trim().parse().map_err(|_| expected())?;
        let axial: usize = axial.trim().parse().map_err(|_| expected())?;
        if !(1..=Self::MAX_RADIAL).contains(&radial) || !(2..=Self::MAX_AXIAL).contains(&axial) {
            return Err(expected());
        }
        Ok(MeshDensity {
            radial_elements: radial,
            axial_elements: axial,
            ..MeshDensity::default()
        })
    }
}

/// Nodes (R, Z) in mm and 4-node elements, counter-clockwise.
#[derive(Clone, Debug)]
pub struct Mesh {
    pub nodes_mm: Vec<[f64; 2]>,
    pub elements: Vec<[usize; 4]>,
    pub radial_elements: usize,
    pub axial_elements: usize,
}

impl Mesh {
    pub fn new(geometry: &BarGeometry, density: &MeshDensity) -> Result<Self, String> {
        geometry.validate()?;
        let MeshDensity {
            radial_elements,
            axial_elements,
            axial_grading,
        } = *density;
        if radial_elements == 0 || axial_elements == 0 {
            return Err("the mesh needs at least one element in each direction".into());
        }
        if !(axial_grading >= 1.0 && axial_grading.is_finite()) {
            return Err(format!("axial grading must be >= 1, got {axial_grading}"));
        }
        let z_positions = graded_positions(geometry.half_length_mm, axial_elements, axial_grading);
        let columns = radial_elements + 1;
        let mut nodes_mm = Vec::with_capacity(columns * (axial_elements + 1));
        for &z in &z_positions {
            let radius = geometry.radius_mm(z);
            for i in 0..columns {
                nodes_mm.push([radius * i as f64 / radial_elements as f64, z]);
            }
        }
        let mut elements = Vec::with_capacity(radial_elements * axial_elements);
        for j in 0..axial_elements {
            for i in 0..radial_elements {
                let first = j * columns + i;
                elements.push([first, first + 1, first + 1 + columns, first + columns]);
            }
        }
        Ok(Mesh {
            nodes_mm,
            elements,
            radial_elements,
            axial_elements,
        })
    }

    pub fn node_count(&self) -> usize {
        self.nodes_mm.len()
    }

    /// Largest distance between the degrees of freedom of one element.
    pub fn half_bandwidth(&self) -> usize {
        2 * self.radial_elements + 5
    }

    /// Nodes on the axis (R = 0).
    pub fn axis_nodes(&self) -> impl Iterator<Item = usize> + '_ {
        (0..=self.axial_elements).map(move |j| j * (self.radial_elements + 1))
    }

    /// Nodes on the mid-gauge plane (Z = 0), axis first.
    pub fn symmetry_plane_nodes(&self) -> std::ops::Range<usize> {
        0..self.radial_elements + 1
    }

    /// Nodes on the pulled end.
    pub fn end_nodes(&self) -> std::ops::Range<usize> {
        let columns = self.radial_elements + 1;
        self.axial_elements * columns..(self.axial_elements + 1) * columns
    }

    /// The outer node of the mid-gauge plane: its radius is the neck's.
    pub fn neck_surface_node(&self) -> usize {
        self.radial_elements
    }
}

/// `count + 1` positions from 0 to `length`, element lengths growing
/// geometrically so the last is `grading` times the first.
fn graded_positions(length: f64, count: usize, grading: f64) -> Vec<f64> {
    let ratio = if count > 1 {
        grading.powf(1.0 / (count - 1) as f64)
    } else {
        1.0
    };
    let mut positions = Vec::with_capacity(count + 1);
    let mut position = 0.0;
    let mut size = 1.0;
    positions.push(0.0);
    for _ in 0..count {
        position += size;
        positions.push(position);
        size *= ratio;
    }
    let scale = length / position;
    for p in &mut positions {
        *p *= scale;
    }
    positions[count] = length;
    positions
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn graded_mesh_spans_the_bar_with_the_asked_grading() {
        let geometry = BarGeometry::default();
        let mesh = Mesh::new(
            &geometry,
            &MeshDensity {
                radial_elements: 4,
                axial_elements: 10,
                axial_grading: 5.0,
            },
        )
        .unwrap();
        assert_eq!(mesh.node_count(), 5 * 11);
        assert_eq!(mesh.elements.len(), 40);
        let z: Vec<f64> = (0..=10).map(|j| mesh.nodes_mm[j * 5][1]).collect();
        assert_eq!(z[0], 0.0);
        assert_eq!(z[10], 12.5);
        let first = z[1] - z[0];
        let last = z[10] - z[9];
        assert!((last / first - 5.0).abs() < 1e-9);
        // The neck radius carries the imperfection, the end does not.
        assert!((mesh.nodes_mm[mesh.neck_surface_node()][0] - 2.0 * (1.0 - 0.001)).abs() < 1e-12);
        assert!((mesh.nodes_mm[mesh.end_nodes().last().unwrap()][0] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn element_dofs_fit_the_half_bandwidth() {
        let mesh = Mesh::new(&BarGeometry::default(), &MeshDensity::default()).unwrap();
        for element in &mesh.elements {
            let lowest = element.iter().min().unwrap() * 2;
            let highest = element.iter().max().unwrap() * 2 + 1;
            assert!(highest - lowest <= mesh.half_bandwidth());
        }
    }

    #[test]
    fn bad_meshes_are_refused() {
        let geometry = BarGeometry::default();
        assert!(Mesh::new(
            &geometry,
            &MeshDensity {
                radial_elements: 0,
                ..Default::default()
            }
        )
        .is_err());
        assert!(Mesh::new(
            &geometry,
            &MeshDensity {
                axial_grading: 0.5,
                ..Default::default()
            }
        )
        .is_err());
        assert!(Mesh::new(
            &BarGeometry {
                imperfection: -0.1,
                ..geometry
            },
            &MeshDensity::default()
        )
        .is_err());
    }
}
