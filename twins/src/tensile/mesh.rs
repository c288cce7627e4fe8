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
    /// A zone of square elements at the neck, graded coarser beyond it
    /// (then `axial_grading` is what that gives, not an input).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub neck_zone: Option<NeckZone>,
}

impl Default for MeshDensity {
    fn default() -> Self {
        MeshDensity {
            radial_elements: 6,
            axial_elements: 30,
            axial_grading: 8.0,
            neck_zone: None,
        }
    }
}

/// Uniform elements of one size over a zone from the mid-gauge plane, where
/// the neck forms and the damage localises: the element size GTN results
/// belong to.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NeckZone {
    /// Element size in the zone, radial and axial, mm.
    pub element_mm: f64,
    /// Length of the zone from the mid-gauge plane, mm.
    pub length_mm: f64,
}

impl NeckZone {
    /// The zone's length as a multiple of the bar's diameter. The damage
    /// localises within about a radius of the mid-gauge plane; from half a
    /// diameter on, a longer zone changes the Dataset-1 MAPE by less than
    /// 0.03 points at 0.09 and 0.18 mm elements, the size of what moving the
    /// zone's end by an element does (BENCHMARKS.md, "Mesh by element size").
    pub const LENGTH_IN_DIAMETERS: f64 = 0.5;
    /// Beyond the zone each element is at most this much longer than the
    /// one before it (a smooth grading keeps the F-bar elements accurate).
    pub const GROWTH: f64 = 1.15;
    /// Beyond the zone an element is at most this many times longer than
    /// it is wide: the bar deforms uniformly there, which bilinear elements
    /// of any aspect ratio represent exactly, but the neck spreads a little
    /// past the zone.
    pub const MAX_ASPECT_RATIO: f64 = 10.0;
    /// The smallest element size accepted, mm.
    pub const MIN_ELEMENT_MM: f64 = 0.02;
}

impl MeshDensity {
    /// The most radial elements a mesh may have.
    pub const MAX_RADIAL: usize = 64;
    /// The most axial elements a mesh may have (with [`Self::MAX_RADIAL`],
    /// about 64,000 elements: more would take hours per simulation).
    pub const MAX_AXIAL: usize = 1000;

    /// A mesh of square elements of about `element_mm` in a neck zone of
    /// `zone_mm` (by default [`NeckZone::LENGTH_IN_DIAMETERS`] diameters),
    /// graded coarser toward the pulled end; the counts follow. The radial
    /// count is the radius over the size, rounded (so the size is met
    /// within half an element over the radius).
    pub fn by_element_size(
        geometry: &BarGeometry,
        element_mm: f64,
        zone_mm: Option<f64>,
    ) -> Result<Self, String> {
        geometry.validate()?;
        let radius = 0.5 * geometry.diameter_mm;
        if !(element_mm.is_finite() && (NeckZone::MIN_ELEMENT_MM..=radius).contains(&element_mm)) {
            return Err(format!(
                "element size {element_mm} mm: expected {} mm to the radius, {radius} mm",
                NeckZone::MIN_ELEMENT_MM
            ));
        }
        let zone_mm = zone_mm.unwrap_or(NeckZone::LENGTH_IN_DIAMETERS * geometry.diameter_mm);
        if !(zone_mm.is_finite() && zone_mm >= element_mm && zone_mm <= geometry.half_length_mm) {
            return Err(format!(
                "neck zone {zone_mm} mm: expected one element ({element_mm} mm) to the half length ({} mm)",
                geometry.half_length_mm
            ));
        }
        let radial_elements = ((radius / element_mm).round() as usize).max(1);
        let zone = NeckZone {
            element_mm,
            length_mm: zone_mm,
        };
        let positions = neck_zone_positions(geometry.half_length_mm, &zone);
        let axial_elements = positions.len() - 1;
        if radial_elements > Self::MAX_RADIAL || axial_elements > Self::MAX_AXIAL {
            return Err(format!(
                "element size {element_mm} mm needs {radial_elements}x{axial_elements} elements; at most {}x{}",
                Self::MAX_RADIAL,
                Self::MAX_AXIAL
            ));
        }
        let first = positions[1] - positions[0];
        let last = positions[axial_elements] - positions[axial_elements - 1];
        Ok(MeshDensity {
            radial_elements,
            axial_elements,
            axial_grading: last / first,
            neck_zone: Some(zone),
        })
    }

    /// This mesh on another bar: a mesh by element size is derived again (its
    /// counts follow the bar's radius and length); one by counts stays.
    pub fn on(&self, geometry: &BarGeometry) -> Result<Self, String> {
        match &self.neck_zone {
            Some(zone) => Self::by_element_size(geometry, zone.element_mm, Some(zone.length_mm)),
            None => Ok(*self),
        }
    }

    /// The element size at the neck, radial and axial, mm.
    pub fn neck_element_mm(&self, geometry: &BarGeometry) -> (f64, f64) {
        let radial = 0.5 * geometry.diameter_mm / self.radial_elements as f64;
        let axial = match &self.neck_zone {
            Some(zone) => neck_zone_positions(geometry.half_length_mm, zone)[1],
            None => graded_positions(
                geometry.half_length_mm,
                self.axial_elements,
                self.axial_grading,
            )[1],
        };
        (radial, axial)
    }

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
            neck_zone,
        } = *density;
        if radial_elements == 0 || axial_elements == 0 {
            return Err("the mesh needs at least one element in each direction".into());
        }
        if !(axial_grading >= 1.0 && axial_grading.is_finite()) {
            return Err(format!("axial grading must be >= 1, got {axial_grading}"));
        }
        let z_positions = match &neck_zone {
            Some(zone) => {
                let positions = neck_zone_positions(geometry.half_length_mm, zone);
                if positions.len() != axial_elements + 1 {
                    return Err(format!(
                        "a neck zone of {} mm elements over {} mm gives {} axial elements, not {axial_elements}",
                        zone.element_mm,
                        zone.length_mm,
                        positions.len() - 1
                    ));
                }
                positions
            }
            None => graded_positions(geometry.half_length_mm, axial_elements, axial_grading),
        };
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

/// Axial node positions from 0 to `length`: the zone's length cut into
/// elements of about its element size, then elements growing by at most
/// [`NeckZone::GROWTH`] each, up to [`NeckZone::MAX_ASPECT_RATIO`] element
/// sizes, and all of them beyond the zone shrunk by one factor (by at most
/// one element's share) so that the last ends at `length`.
fn neck_zone_positions(length: f64, zone: &NeckZone) -> Vec<f64> {
    let zone_length = zone.length_mm.min(length);
    let zone_count = ((zone_length / zone.element_mm).round() as usize).max(1);
    let size = zone_length / zone_count as f64;
    let mut positions: Vec<f64> = (0..=zone_count)
        .map(|j| zone_length * j as f64 / zone_count as f64)
        .collect();
    let rest = length - zone_length;
    if rest <= 1e-9 * length {
        positions[zone_count] = length;
        return positions;
    }
    let largest = NeckZone::MAX_ASPECT_RATIO * size;
    let mut sizes = Vec::new();
    let (mut covered, mut next) = (0.0, size);
    while covered < rest {
        next = (next * NeckZone::GROWTH).min(largest);
        sizes.push(next);
        covered += next;
    }
    // <= 1: shrinking keeps every growth within the limit.
    let stretch = rest / covered;
    let mut position = zone_length;
    for element in sizes {
        position += element * stretch;
        positions.push(position);
    }
    let last = positions.len() - 1;
    positions[last] = length;
    positions
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
                neck_zone: None,
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
    fn a_mesh_by_element_size_has_square_elements_in_the_zone_and_grades_smoothly() {
        let geometry = BarGeometry::default();
        for (element_mm, zone_mm) in [
            (0.09, None),
            (0.18, Some(4.0)),
            (0.33, None),
            (0.05, Some(1.0)),
        ] {
            let density = MeshDensity::by_element_size(&geometry, element_mm, zone_mm).unwrap();
            let zone = density.neck_zone.unwrap();
            let mesh = Mesh::new(&geometry, &density).unwrap();
            let columns = density.radial_elements + 1;
            let z: Vec<f64> = (0..=density.axial_elements)
                .map(|j| mesh.nodes_mm[j * columns][1])
                .collect();
            let sizes: Vec<f64> = z.windows(2).map(|w| w[1] - w[0]).collect();
            let radial = 2.0 / density.radial_elements as f64;
            // Across the radius: the size asked, within half an element.
            assert!(
                (radial - element_mm).abs() <= 0.5 * radial,
                "{element_mm}: radial {radial}"
            );
            // In the zone: uniform, within rounding of the zone into elements.
            let in_zone = (zone.length_mm / element_mm).round() as usize;
            for size in &sizes[..in_zone] {
                assert!((size - zone.length_mm / in_zone as f64).abs() < 1e-12);
            }
            assert!((z[in_zone] - zone.length_mm).abs() < 1e-12);
            // Beyond: growing by at most the growth factor (the stretch to fit
            // the half length only shrinks them), never longer than the aspect
            // ratio allows, ending at the half length.
            for pair in sizes[in_zone - 1..].windows(2) {
                assert!(
                    pair[1] <= pair[0] * NeckZone::GROWTH * (1.0 + 1e-9) + 1e-12,
                    "{pair:?}"
                );
                assert!(pair[1] > 0.0);
            }
            let largest = sizes.iter().copied().fold(0.0, f64::max);
            assert!(
                largest <= NeckZone::MAX_ASPECT_RATIO * element_mm * 1.5,
                "{largest}"
            );
            assert_eq!(z[density.axial_elements], 12.5);
            let (neck_radial, neck_axial) = density.neck_element_mm(&geometry);
            assert!((neck_radial - radial).abs() < 1e-12);
            assert!((neck_axial - sizes[0]).abs() < 1e-12);
        }
        // The default zone is half the diameter.
        let density = MeshDensity::by_element_size(&geometry, 0.1, None).unwrap();
        assert_eq!(density.neck_zone.unwrap().length_mm, 2.0);
    }

    #[test]
    fn element_sizes_and_zones_out_of_range_are_refused() {
        let geometry = BarGeometry::default();
        for (element_mm, zone_mm, why) in [
            (0.0, None, "expected 0.02 mm to the radius"),
            (f64::NAN, None, "expected 0.02 mm to the radius"),
            (2.5, None, "expected 0.02 mm to the radius"),
            (0.1, Some(0.05), "neck zone 0.05 mm"),
            (0.1, Some(13.0), "neck zone 13 mm"),
            (0.02, Some(12.5), "at most 64x1000"),
        ] {
            let error = MeshDensity::by_element_size(&geometry, element_mm, zone_mm).unwrap_err();
            assert!(error.contains(why), "{element_mm} {zone_mm:?}: {error}");
        }
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
