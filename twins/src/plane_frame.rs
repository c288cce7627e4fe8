//! Planar Euler-Bernoulli frame finite elements.
//!
//! A linear-elastic, small-displacement model of a plane frame made of straight
//! two-node beam-column elements (axial stretching plus Euler-Bernoulli bending,
//! no shear deformation), three degrees of freedom per node: `ux`, `uy`, rotation.
//! The excavator twin uses it for the boom and the arm: each is a free body in
//! equilibrium under its pin forces and its own weight. The caller supports it
//! statically determinately (a pin plus a roller) only to remove the rigid-body
//! motion, so the support reactions come out at rounding level (a check that the
//! loads really balance) and the internal forces follow from statics alone.
//!
//! # Units and axes
//!
//! SI throughout: m, N, Pa, N·m, kg. Positions, loads and results are in the
//! body's own axes `x`, `y`; rotations and moments are positive counter-clockwise
//! (about `+z`, out of the plane).
//!
//! Each element has local axes: local `x` runs from its node `a` to its node `b`,
//! local `y` is local `x` rotated by +90°.
//!
//! # Sign convention for internal forces
//!
//! [`PlaneFrameSolution::internal_forces`] reports the stress resultants at a section a
//! fraction `xi` along an element, as they act on the part between node `a` and
//! the section (the cut face whose outward normal is local `+x`):
//!
//! - **axial** `N`: positive in tension;
//! - **moment** `M`: positive when it compresses the fibre on the local `+y` side:
//!   "sagging" for an element drawn left to right with `+y` up. On the cut face it
//!   is a counter-clockwise couple `+M`;
//! - **shear** `V = dM/dx`: the sum of the local-`y` forces acting on the part
//!   between node `a` and the section. On the cut face it is a force `-V` along
//!   local `y`. With a uniform load `q_y` per length, `dV/dx = q_y`.
//!
//! So a simply supported beam (left to right, `+y` up) under a downward load has
//! `M > 0` in span, `V > 0` near its left support and `V < 0` near its right one.
//!
//! # Loads
//!
//! Distributed loads are uniform per unit length *of the element* (not of its
//! projection), in body axes. Self weight comes from
//! [`PlaneFrameLoads::body_acceleration_m_s2`] times each element's mass per length
//! (density × area, see [`PlaneFrameBuilder::density`]): pass gravity as the field
//! vector in body axes, e.g. `[0.0, -9.81]` when body `+y` is up; for
//! d'Alembert inertia add minus the body's acceleration.
//!
//! # Exactness
//!
//! For a prismatic Euler-Bernoulli element, the cubic (bending) and linear
//! (axial) shape functions are exact homogeneous solutions, so with consistent
//! nodal loads the nodal displacements and element end forces are exact for end
//! loads and uniform distributed loads. Inside an element the internal forces
//! come from statics of the part between node `a` and the section (including the
//! `q x²/2` term of the distributed load), so they are exact as well. A tapered
//! member is modelled as prismatic steps: its displacements then approximate the
//! continuous taper, but on a statically determinate structure its internal
//! forces do not depend on the stiffness and stay exact.
//!
//! # Supports
//!
//! Supports remove degrees of freedom from the system rather than adding stiff
//! springs, so reactions and internal forces are good to rounding. A roller in an
//! arbitrary direction is handled by expressing that node's translations in the
//! roller's own frame (restrained direction, free direction), which turns the
//! constraint into a plain elimination.
//!
//! # Why the model is prefactored
//!
//! A body's geometry, sections and supports are fixed while the calibration
//! evaluates it for thousands of load cases (one per sample of a recording).
//! [`PlaneFrameBuilder::build`] therefore assembles the stiffness matrix and Cholesky
//! factors it once, O(n³); [`PlaneFrameModel::solve`] is then two triangular solves
//! (O(n²)) plus a pass over the elements, with a handful of allocations.
//!
//! # Example
//!
//! ```
//! use acq_twins::plane_frame::{PlaneFrameBuilder, PlaneFrameLoads, SectionProperties};
//!
//! // A 6 m simply supported beam under 1 kN/m downwards.
//! let section = SectionProperties { area_m2: 1e-2, second_moment_m4: 1e-4 };
//! let mut frame = PlaneFrameBuilder::new(210e9);
//! let left = frame.node([0.0, 0.0]);
//! let right = frame.node([6.0, 0.0]);
//! let beam = frame.element(left, right, section);
//! frame.pin_support(left);
//! frame.roller_support(right, [0.0, 1.0]);
//! let model = frame.build()?;
//!
//! let loads = PlaneFrameLoads { distributed: vec![(beam, [0.0, -1e3])], ..PlaneFrameLoads::default() };
//! let solution = model.solve(&loads);
//! let midspan = solution.internal_forces(beam, 0.5);
//! assert!((midspan.moment_nm - 1e3 * 6.0 * 6.0 / 8.0).abs() < 1e-6);
//! assert!((solution.reaction(right)[1] - 3e3).abs() < 1e-6);
//! # Ok::<(), acq_twins::plane_frame::PlaneFrameError>(())
//! ```

use std::fmt;

use nalgebra::{Cholesky, DMatrix, DVector, Dyn, Matrix6, Vector6};

/// Degrees of freedom per node: `ux`, `uy`, rotation.
const DOFS_PER_NODE: usize = 3;

/// A Cholesky pivot smaller than this fraction of the diagonal stiffness it
/// started from means the degree of freedom has (to rounding) no stiffness left
/// once the others are condensed out: the supports leave a mechanism.
///
/// A true mechanism leaves a ratio of order 1e-15 (rounding); real frames stay
/// far above 1e-12 unless members are absurdly slender (the ratio there scales
/// like (radius of gyration / length)² between axial and bending stiffness).
const MECHANISM_PIVOT_RATIO: f64 = 1e-12;

/// Two roller directions whose unit vectors have a cross product below this
/// restrain the same direction (one roller repeated, not a pin).
const PARALLEL_ROLLER_SIN: f64 = 1e-9;

/// An element shorter than this fraction of the frame's extent has zero length
/// to rounding.
const ZERO_LENGTH_RATIO: f64 = 1e-12;

/// An index handed out by a [`PlaneFrameBuilder`], in creation order from 0.
macro_rules! builder_id {
    ($(#[$doc:meta])* $name:ident, $label:literal) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub struct $name(usize);

        impl $name {
            /// Position in creation order, from 0.
            pub fn index(self) -> usize {
                self.0
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, concat!($label, " {}"), self.0)
            }
        }
    };
}

builder_id!(
    /// Index of a node in the [`PlaneFrameBuilder`] that created it.
    NodeId,
    "node"
);
builder_id!(
    /// Index of an element in the [`PlaneFrameBuilder`] that created it.
    ElementId,
    "element"
);

/// One nodal degree of freedom, as named in [`PlaneFrameError::Mechanism`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dof {
    /// Displacement along body `x`.
    X,
    /// Displacement along body `y`.
    Y,
    /// Rotation.
    Rotation,
    /// At a roller node: displacement across the roller's restrained direction.
    RollerTravel,
}

impl fmt::Display for Dof {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Dof::X => "x displacement",
            Dof::Y => "y displacement",
            Dof::Rotation => "rotation",
            Dof::RollerTravel => "roller travel",
        })
    }
}

/// Why a frame could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlaneFrameError {
    /// Young's modulus is not positive and finite.
    #[error("Young's modulus must be positive and finite, got {0} Pa")]
    InvalidYoungsModulus(f64),
    /// The density is negative or not finite.
    #[error("density must be non-negative and finite, got {0} kg/m^3")]
    InvalidDensity(f64),
    /// An element's mass per length is negative or not finite.
    #[error("{element}: linear density must be non-negative and finite, got {value} kg/m")]
    InvalidLinearDensity {
        /// The element.
        element: ElementId,
        /// The rejected mass per length, kg/m.
        value: f64,
    },
    /// A node position is not finite.
    #[error("{node} has a non-finite position {position_m:?} m")]
    InvalidNodePosition {
        /// The node.
        node: NodeId,
        /// Its position, m.
        position_m: [f64; 2],
    },
    /// A [`NodeId`] that this builder did not create.
    #[error("{0} does not belong to this frame")]
    UnknownNode(NodeId),
    /// An [`ElementId`] that this builder did not create.
    #[error("{0} does not belong to this frame")]
    UnknownElement(ElementId),
    /// An element whose ends coincide.
    #[error("{element} has zero length (from {a} to {b})")]
    ZeroLengthElement {
        /// The element.
        element: ElementId,
        /// Its first node.
        a: NodeId,
        /// Its second node.
        b: NodeId,
    },
    /// An element's section properties are not positive and finite.
    #[error("{element}: {reason}")]
    InvalidSection {
        /// The element.
        element: ElementId,
        /// Which property is wrong.
        reason: String,
    },
    /// A roller direction that is zero or not finite.
    #[error("roller support at {node} has no usable direction {direction:?}")]
    InvalidRollerDirection {
        /// The roller's node.
        node: NodeId,
        /// The direction given.
        direction: [f64; 2],
    },
    /// The supports leave a rigid-body motion or a node without stiffness.
    #[error(
        "the frame is a mechanism: the {dof} of {node} has no stiffness once the supports \
         are applied (check the supports, and that every node has an element)"
    )]
    Mechanism {
        /// The node where the factorisation found the zero stiffness (the motion
        /// usually involves more nodes).
        node: NodeId,
        /// Which of its degrees of freedom.
        dof: Dof,
    },
}

/// Cross-section properties of one element (prismatic per element).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SectionProperties {
    /// Cross-section area, m².
    pub area_m2: f64,
    /// Second moment of area for in-plane bending, m⁴.
    pub second_moment_m4: f64,
}

impl SectionProperties {
    /// Checks that both properties are positive and finite.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.area_m2.is_finite() && self.area_m2 > 0.0) {
            return Err(format!(
                "area_m2 must be positive and finite, got {}",
                self.area_m2
            ));
        }
        if !(self.second_moment_m4.is_finite() && self.second_moment_m4 > 0.0) {
            return Err(format!(
                "second_moment_m4 must be positive and finite, got {}",
                self.second_moment_m4
            ));
        }
        Ok(())
    }
}

/// A rectangular hollow (box) section: two flanges (top and bottom, thickness
/// `flange_thickness_m`, full width) and two webs (the sides, thickness
/// `web_thickness_m`, full height). The frame bends it about the horizontal axis,
/// i.e. in the plane of the height.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSection {
    /// Outer height (in the bending plane), m.
    pub height_m: f64,
    /// Outer width (out of the bending plane), m.
    pub width_m: f64,
    /// Thickness of the top and bottom plates, m.
    pub flange_thickness_m: f64,
    /// Thickness of the side plates, m.
    pub web_thickness_m: f64,
}

impl BoxSection {
    /// Width of the hollow, m.
    fn inner_width_m(&self) -> f64 {
        self.width_m - 2.0 * self.web_thickness_m
    }

    /// Height of the hollow, m.
    fn inner_height_m(&self) -> f64 {
        self.height_m - 2.0 * self.flange_thickness_m
    }

    /// Area, m²: `b h - (b - 2 tw)(h - 2 tf)`.
    pub fn area_m2(&self) -> f64 {
        self.width_m * self.height_m - self.inner_width_m() * self.inner_height_m()
    }

    /// Second moment of area about the horizontal centroidal axis, m⁴:
    /// `(b h³ - (b - 2 tw)(h - 2 tf)³) / 12`.
    pub fn second_moment_m4(&self) -> f64 {
        (self.width_m * self.height_m.powi(3)
            - self.inner_width_m() * self.inner_height_m().powi(3))
            / 12.0
    }

    /// First moment of area of the half section above the neutral axis about
    /// that axis, m³: `(b h² - (b - 2 tw)(h - 2 tf)²) / 8`.
    pub fn first_moment_at_neutral_axis_m3(&self) -> f64 {
        (self.width_m * self.height_m.powi(2)
            - self.inner_width_m() * self.inner_height_m().powi(2))
            / 8.0
    }

    /// Shear stress at the neutral axis (where it peaks) in the two webs, Pa:
    /// `V Q / (I · 2 tw)`. Has the sign of `shear_force_n`.
    pub fn shear_stress_at_neutral_axis_pa(&self, shear_force_n: f64) -> f64 {
        shear_force_n * self.first_moment_at_neutral_axis_m3()
            / (self.second_moment_m4() * 2.0 * self.web_thickness_m)
    }

    /// Area and second moment, for [`PlaneFrameBuilder::element`].
    pub fn properties(&self) -> SectionProperties {
        SectionProperties {
            area_m2: self.area_m2(),
            second_moment_m4: self.second_moment_m4(),
        }
    }

    /// The section a fraction `t` of the way from `self` (`t = 0`) to `other`
    /// (`t = 1`), every dimension interpolated linearly: a tapered member's
    /// section at a station.
    pub fn linear_blend(&self, other: &BoxSection, t: f64) -> BoxSection {
        let lerp = |a: f64, b: f64| a + t * (b - a);
        BoxSection {
            height_m: lerp(self.height_m, other.height_m),
            width_m: lerp(self.width_m, other.width_m),
            flange_thickness_m: lerp(self.flange_thickness_m, other.flange_thickness_m),
            web_thickness_m: lerp(self.web_thickness_m, other.web_thickness_m),
        }
    }

    /// Checks that every dimension is positive and finite and that the plates
    /// leave a hollow (`2 tf < h`, `2 tw < b`); the message names the culprit.
    pub fn validate(&self) -> Result<(), String> {
        for (name, value) in [
            ("height_m", self.height_m),
            ("width_m", self.width_m),
            ("flange_thickness_m", self.flange_thickness_m),
            ("web_thickness_m", self.web_thickness_m),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(format!(
                    "box section {name} must be positive and finite, got {value}"
                ));
            }
        }
        if 2.0 * self.flange_thickness_m >= self.height_m {
            return Err(format!(
                "box section flanges meet: 2 × flange_thickness_m ({}) must be less than height_m ({})",
                self.flange_thickness_m, self.height_m
            ));
        }
        if 2.0 * self.web_thickness_m >= self.width_m {
            return Err(format!(
                "box section webs meet: 2 × web_thickness_m ({}) must be less than width_m ({})",
                self.web_thickness_m, self.width_m
            ));
        }
        Ok(())
    }
}

/// A support as declared; combined per node at build time.
#[derive(Clone, Copy, Debug)]
enum Support {
    Pin,
    Roller { direction: [f64; 2] },
    Fixed,
}

/// How a node's translation is restrained, after combining its supports.
#[derive(Clone, Copy, Debug, Default)]
enum Translation {
    #[default]
    Free,
    /// Restrained along this unit vector only.
    Along([f64; 2]),
    Fixed,
}

impl Translation {
    fn with_roller(self, direction: [f64; 2]) -> Self {
        match self {
            Translation::Free => Translation::Along(direction),
            Translation::Along(existing)
                if cross(existing, direction).abs() < PARALLEL_ROLLER_SIN =>
            {
                Translation::Along(existing)
            }
            // Two rollers in different directions hold the node like a pin.
            Translation::Along(_) | Translation::Fixed => Translation::Fixed,
        }
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct NodeRestraint {
    translation: Translation,
    rotation_fixed: bool,
}

#[derive(Clone, Copy, Debug)]
struct ElementSpec {
    nodes: [NodeId; 2],
    section: SectionProperties,
}

/// Collects nodes, elements and supports, then assembles and factors the
/// stiffness once in [`build`](PlaneFrameBuilder::build).
///
/// Nothing is checked until `build`, which reports the first problem found.
#[derive(Clone, Debug)]
pub struct PlaneFrameBuilder {
    youngs_modulus_pa: f64,
    density_kg_m3: f64,
    nodes: Vec<[f64; 2]>,
    elements: Vec<ElementSpec>,
    linear_densities: Vec<(ElementId, f64)>,
    supports: Vec<(NodeId, Support)>,
}

impl PlaneFrameBuilder {
    /// An empty frame of one material with Young's modulus `youngs_modulus_pa`
    /// and density 0 (weightless until [`density`](PlaneFrameBuilder::density)).
    pub fn new(youngs_modulus_pa: f64) -> Self {
        PlaneFrameBuilder {
            youngs_modulus_pa,
            density_kg_m3: 0.0,
            nodes: Vec::new(),
            elements: Vec::new(),
            linear_densities: Vec::new(),
            supports: Vec::new(),
        }
    }

    /// Sets the material density, kg/m³: every element's mass per length is
    /// `density_kg_m3 × area_m2` (whether added before or after this call)
    /// unless overridden by [`element_linear_density`](PlaneFrameBuilder::element_linear_density).
    pub fn density(&mut self, density_kg_m3: f64) -> &mut Self {
        self.density_kg_m3 = density_kg_m3;
        self
    }

    /// Adds a node at `position_m` in body axes.
    pub fn node(&mut self, position_m: [f64; 2]) -> NodeId {
        self.nodes.push(position_m);
        NodeId(self.nodes.len() - 1)
    }

    /// Adds a prismatic element from node `a` to node `b`; its local `x` axis
    /// runs from `a` to `b`.
    pub fn element(&mut self, a: NodeId, b: NodeId, section: SectionProperties) -> ElementId {
        self.elements.push(ElementSpec {
            nodes: [a, b],
            section,
        });
        ElementId(self.elements.len() - 1)
    }

    /// Overrides one element's mass per length, kg/m (e.g. to carry the mass of
    /// parts that add no stiffness). The last call for an element wins.
    pub fn element_linear_density(
        &mut self,
        element: ElementId,
        linear_density_kg_per_m: f64,
    ) -> &mut Self {
        self.linear_densities
            .push((element, linear_density_kg_per_m));
        self
    }

    /// Fixes the node's `ux` and `uy`.
    pub fn pin_support(&mut self, node: NodeId) {
        self.supports.push((node, Support::Pin));
    }

    /// Fixes the node's displacement along `direction` (any non-zero length;
    /// normalised at build). The reaction acts along that direction.
    pub fn roller_support(&mut self, node: NodeId, direction: [f64; 2]) {
        self.supports.push((node, Support::Roller { direction }));
    }

    /// Fixes the node's `ux`, `uy` and rotation (a clamp).
    pub fn fixed_support(&mut self, node: NodeId) {
        self.supports.push((node, Support::Fixed));
    }

    /// Validates the frame, assembles the global stiffness, eliminates the
    /// supported degrees of freedom and Cholesky-factors what is left.
    ///
    /// Fails on bad material or geometry data, or when the supports leave a
    /// mechanism (including a node that no element stiffens).
    pub fn build(self) -> Result<PlaneFrameModel, PlaneFrameError> {
        if !(self.youngs_modulus_pa.is_finite() && self.youngs_modulus_pa > 0.0) {
            return Err(PlaneFrameError::InvalidYoungsModulus(
                self.youngs_modulus_pa,
            ));
        }
        if !(self.density_kg_m3.is_finite() && self.density_kg_m3 >= 0.0) {
            return Err(PlaneFrameError::InvalidDensity(self.density_kg_m3));
        }
        for (i, &position_m) in self.nodes.iter().enumerate() {
            if !position_m.iter().all(|c| c.is_finite()) {
                return Err(PlaneFrameError::InvalidNodePosition {
                    node: NodeId(i),
                    position_m,
                });
            }
        }
        let elements = self.build_elements()?;
        let restraints = self.resolve_supports()?;

        // Number the degrees of freedom. A roller node's translations are taken
        // in the roller's frame (restrained direction first), so the roller is a
        // plain elimination like every other support.
        let node_count = self.nodes.len();
        let mut roller_directions = vec![None; node_count];
        let mut free_dofs = Vec::new();
        let mut fixed_dofs = Vec::new();
        for (node, restraint) in restraints.iter().enumerate() {
            let (x_fixed, y_fixed) = match restraint.translation {
                Translation::Free => (false, false),
                Translation::Along(direction) => {
                    roller_directions[node] = Some(direction);
                    (true, false)
                }
                Translation::Fixed => (true, true),
            };
            for (offset, fixed) in [x_fixed, y_fixed, restraint.rotation_fixed]
                .into_iter()
                .enumerate()
            {
                let dof = DOFS_PER_NODE * node + offset;
                if fixed {
                    fixed_dofs.push(dof);
                } else {
                    free_dofs.push(dof);
                }
            }
        }

        let dof_count = DOFS_PER_NODE * node_count;
        let mut stiffness = DMatrix::<f64>::zeros(dof_count, dof_count);
        for element in &elements {
            let k = element.global_stiffness();
            let dofs = element.dofs();
            for (r, &i) in dofs.iter().enumerate() {
                for (c, &j) in dofs.iter().enumerate() {
                    stiffness[(i, j)] += k[(r, c)];
                }
            }
        }
        for (node, direction) in roller_directions.iter().enumerate() {
            if let Some(direction) = direction {
                rotate_into_roller_frame(&mut stiffness, DOFS_PER_NODE * node, *direction);
            }
        }

        let free_stiffness = stiffness.select_rows(&free_dofs).select_columns(&free_dofs);
        let free_fixed_stiffness = stiffness
            .select_rows(&free_dofs)
            .select_columns(&fixed_dofs);
        let diagonal = free_stiffness.diagonal();
        let mechanism_at = |j: usize| {
            let dof = free_dofs[j];
            let node = dof / DOFS_PER_NODE;
            let kind = match (dof % DOFS_PER_NODE, roller_directions[node].is_some()) {
                (0, _) => Dof::X,
                (1, true) => Dof::RollerTravel,
                (1, false) => Dof::Y,
                _ => Dof::Rotation,
            };
            PlaneFrameError::Mechanism {
                node: NodeId(node),
                dof: kind,
            }
        };
        // A vanishing pivot is replaced by the smallest positive number instead
        // of aborting, so the scan below can name the first degree of freedom
        // without stiffness; pivots after it are garbage but never read.
        let cholesky = Cholesky::new_with_substitute(free_stiffness, f64::MIN_POSITIVE)
            .ok_or_else(|| mechanism_at(0))?;
        let factor = cholesky.l_dirty();
        for j in 0..free_dofs.len() {
            let pivot = factor[(j, j)];
            // Written so that NaN fails too.
            if !(diagonal[j] > 0.0 && pivot * pivot >= MECHANISM_PIVOT_RATIO * diagonal[j]) {
                return Err(mechanism_at(j));
            }
        }

        Ok(PlaneFrameModel {
            nodes: self.nodes,
            elements,
            roller_directions,
            free_dofs,
            fixed_dofs,
            cholesky,
            free_fixed_stiffness,
        })
    }

    fn build_elements(&self) -> Result<Vec<Element>, PlaneFrameError> {
        let mut linear_density_overrides = vec![None; self.elements.len()];
        for &(element, value) in &self.linear_densities {
            let slot = linear_density_overrides
                .get_mut(element.0)
                .ok_or(PlaneFrameError::UnknownElement(element))?;
            if !(value.is_finite() && value >= 0.0) {
                return Err(PlaneFrameError::InvalidLinearDensity { element, value });
            }
            *slot = Some(value);
        }

        let extent_m = bounding_box_diagonal_m(&self.nodes);
        let mut elements = Vec::with_capacity(self.elements.len());
        for (i, spec) in self.elements.iter().enumerate() {
            let id = ElementId(i);
            let [a, b] = spec.nodes;
            for node in [a, b] {
                if node.0 >= self.nodes.len() {
                    return Err(PlaneFrameError::UnknownNode(node));
                }
            }
            spec.section
                .validate()
                .map_err(|reason| PlaneFrameError::InvalidSection {
                    element: id,
                    reason,
                })?;
            let (pa, pb) = (self.nodes[a.0], self.nodes[b.0]);
            let delta = [pb[0] - pa[0], pb[1] - pa[1]];
            let length_m = delta[0].hypot(delta[1]);
            if a == b || length_m <= ZERO_LENGTH_RATIO * extent_m {
                return Err(PlaneFrameError::ZeroLengthElement { element: id, a, b });
            }
            let linear_density_kg_per_m =
                linear_density_overrides[i].unwrap_or(self.density_kg_m3 * spec.section.area_m2);
            elements.push(Element::new(
                [a.0, b.0],
                length_m,
                [delta[0] / length_m, delta[1] / length_m],
                self.youngs_modulus_pa * spec.section.area_m2,
                self.youngs_modulus_pa * spec.section.second_moment_m4,
                linear_density_kg_per_m,
            ));
        }
        Ok(elements)
    }

    fn resolve_supports(&self) -> Result<Vec<NodeRestraint>, PlaneFrameError> {
        let mut restraints = vec![NodeRestraint::default(); self.nodes.len()];
        for &(node, support) in &self.supports {
            let restraint = restraints
                .get_mut(node.0)
                .ok_or(PlaneFrameError::UnknownNode(node))?;
            match support {
                Support::Pin => restraint.translation = Translation::Fixed,
                Support::Fixed => {
                    restraint.translation = Translation::Fixed;
                    restraint.rotation_fixed = true;
                }
                Support::Roller { direction } => {
                    let norm = direction[0].hypot(direction[1]);
                    if !(norm.is_finite() && norm > 0.0) {
                        return Err(PlaneFrameError::InvalidRollerDirection { node, direction });
                    }
                    let unit = [direction[0] / norm, direction[1] / norm];
                    restraint.translation = restraint.translation.with_roller(unit);
                }
            }
        }
        Ok(restraints)
    }
}

/// One element as the model needs it: geometry, stiffness, mass.
#[derive(Clone, Debug)]
struct Element {
    nodes: [usize; 2],
    length_m: f64,
    /// Unit vector from node `a` to node `b` in body axes: (cos, sin) of the
    /// element's angle.
    axis: [f64; 2],
    linear_density_kg_per_m: f64,
    /// Local stiffness times the body-to-local rotation: maps the element's
    /// body-axes nodal displacements straight to local end forces.
    local_stiffness_from_body: Matrix6<f64>,
}

impl Element {
    fn new(
        nodes: [usize; 2],
        length_m: f64,
        axis: [f64; 2],
        axial_rigidity_n: f64,
        flexural_rigidity_n_m2: f64,
        linear_density_kg_per_m: f64,
    ) -> Self {
        let local = local_stiffness(length_m, axial_rigidity_n, flexural_rigidity_n_m2);
        Element {
            nodes,
            length_m,
            axis,
            linear_density_kg_per_m,
            local_stiffness_from_body: local * rotation_to_local(axis),
        }
    }

    /// Global (body-axes) degree-of-freedom numbers of the six element dofs.
    fn dofs(&self) -> [usize; 6] {
        let [a, b] = self.nodes.map(|n| DOFS_PER_NODE * n);
        [a, a + 1, a + 2, b, b + 1, b + 2]
    }

    /// `Tᵀ k T`: the element stiffness in body axes.
    fn global_stiffness(&self) -> Matrix6<f64> {
        rotation_to_local(self.axis).transpose() * self.local_stiffness_from_body
    }

    /// A body-axes vector in local axes.
    fn to_local(&self, v: [f64; 2]) -> [f64; 2] {
        components_along(self.axis, v)
    }

    /// Local nodal loads equivalent (in virtual work) to the uniform local load
    /// `[qx, qy]` per length: `qL/2` at each end and `±qy L²/12` as moments.
    /// The fixed-end forces are their negatives.
    fn equivalent_nodal_loads(&self, [qx, qy]: [f64; 2]) -> Vector6<f64> {
        let l = self.length_m;
        Vector6::new(
            qx * l / 2.0,
            qy * l / 2.0,
            qy * l * l / 12.0,
            qx * l / 2.0,
            qy * l / 2.0,
            -qy * l * l / 12.0,
        )
    }
}

/// The 6×6 stiffness of a prismatic Euler-Bernoulli beam-column in local axes,
/// dofs `[u_a, v_a, θ_a, u_b, v_b, θ_b]`.
fn local_stiffness(
    length_m: f64,
    axial_rigidity_n: f64,
    flexural_rigidity_n_m2: f64,
) -> Matrix6<f64> {
    let l = length_m;
    let ea = axial_rigidity_n / l;
    let k1 = 12.0 * flexural_rigidity_n_m2 / (l * l * l);
    let k2 = 6.0 * flexural_rigidity_n_m2 / (l * l);
    let k3 = 4.0 * flexural_rigidity_n_m2 / l;
    let k4 = 2.0 * flexural_rigidity_n_m2 / l;
    #[rustfmt::skip]
    let k = Matrix6::new(
         ea, 0.0, 0.0, -ea, 0.0, 0.0,
        0.0,  k1,  k2, 0.0, -k1,  k2,
        0.0,  k2,  k3, 0.0, -k2,  k4,
        -ea, 0.0, 0.0,  ea, 0.0, 0.0,
        0.0, -k1, -k2, 0.0,  k1, -k2,
        0.0,  k2,  k4, 0.0, -k2,  k3,
    );
    k
}

/// `T`, mapping an element's body-axes dofs to local dofs (rotations unchanged).
fn rotation_to_local([c, s]: [f64; 2]) -> Matrix6<f64> {
    let mut t = Matrix6::zeros();
    for node in [0, 3] {
        t[(node, node)] = c;
        t[(node, node + 1)] = s;
        t[(node + 1, node)] = -s;
        t[(node + 1, node + 1)] = c;
        t[(node + 2, node + 2)] = 1.0;
    }
    t
}

/// Re-expresses the translations of the node whose x dof is `dof` in the frame
/// (roller direction `d`, `d` rotated +90°): `K ← R K Rᵀ` on those two rows and
/// columns, with `R` the orthogonal 2×2 rotation with rows `d` and `d⊥`.
fn rotate_into_roller_frame(stiffness: &mut DMatrix<f64>, dof: usize, direction: [f64; 2]) {
    for col in 0..stiffness.ncols() {
        let rotated = components_along(
            direction,
            [stiffness[(dof, col)], stiffness[(dof + 1, col)]],
        );
        stiffness[(dof, col)] = rotated[0];
        stiffness[(dof + 1, col)] = rotated[1];
    }
    for row in 0..stiffness.nrows() {
        let rotated = components_along(
            direction,
            [stiffness[(row, dof)], stiffness[(row, dof + 1)]],
        );
        stiffness[(row, dof)] = rotated[0];
        stiffness[(row, dof + 1)] = rotated[1];
    }
}

/// Components of body-axes `v` along the unit vector `[c, s]` and along that
/// vector rotated by +90°.
fn components_along([c, s]: [f64; 2], v: [f64; 2]) -> [f64; 2] {
    [c * v[0] + s * v[1], -s * v[0] + c * v[1]]
}

/// Inverse of [`components_along`]: the body-axes vector with those components.
fn vector_from_components([c, s]: [f64; 2], v: [f64; 2]) -> [f64; 2] {
    [c * v[0] - s * v[1], s * v[0] + c * v[1]]
}

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn bounding_box_diagonal_m(points: &[[f64; 2]]) -> f64 {
    let mut min = [f64::INFINITY; 2];
    let mut max = [f64::NEG_INFINITY; 2];
    for p in points {
        for axis in 0..2 {
            min[axis] = min[axis].min(p[axis]);
            max[axis] = max[axis].max(p[axis]);
        }
    }
    if points.is_empty() {
        0.0
    } else {
        (max[0] - min[0]).hypot(max[1] - min[1])
    }
}

/// An assembled, supported and factored frame, ready to solve load cases.
#[derive(Clone, Debug)]
pub struct PlaneFrameModel {
    nodes: Vec<[f64; 2]>,
    elements: Vec<Element>,
    /// Per node: the roller direction whose frame its translation dofs use.
    roller_directions: Vec<Option<[f64; 2]>>,
    free_dofs: Vec<usize>,
    fixed_dofs: Vec<usize>,
    /// Factor of the stiffness restricted to the free dofs.
    cholesky: Cholesky<f64, Dyn>,
    /// Stiffness coupling free rows to fixed columns (by symmetry, the fixed
    /// rows' free part, stored so that each fixed dof's row is a contiguous
    /// column): gives the reactions.
    free_fixed_stiffness: DMatrix<f64>,
}

impl PlaneFrameModel {
    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Number of elements.
    pub fn element_count(&self) -> usize {
        self.elements.len()
    }

    /// A node's position in body axes, m.
    ///
    /// # Panics
    /// If `node` does not belong to this model.
    pub fn node_position_m(&self, node: NodeId) -> [f64; 2] {
        self.nodes[node.0]
    }

    /// An element's length, m.
    ///
    /// # Panics
    /// If `element` does not belong to this model.
    pub fn element_length_m(&self, element: ElementId) -> f64 {
        self.elements[element.0].length_m
    }

    /// An element's end nodes `[a, b]`.
    ///
    /// # Panics
    /// If `element` does not belong to this model.
    pub fn element_nodes(&self, element: ElementId) -> [NodeId; 2] {
        self.elements[element.0].nodes.map(NodeId)
    }

    /// Solves one load case with the stored factorisation.
    ///
    /// # Panics
    /// If `loads` names a node or element that does not belong to this model.
    pub fn solve(&self, loads: &PlaneFrameLoads) -> PlaneFrameSolution {
        let dof_count = DOFS_PER_NODE * self.nodes.len();

        // Each element's uniform load per length, body axes for now; the end
        // forces are filled in once the displacements are known.
        let mut elements: Vec<ElementResult> = self
            .elements
            .iter()
            .map(|e| ElementResult {
                length_m: e.length_m,
                end_forces_local: [0.0; 6],
                load_local_n_per_m: loads
                    .body_acceleration_m_s2
                    .map(|a| e.linear_density_kg_per_m * a),
            })
            .collect();
        for &(element, q) in &loads.distributed {
            let load = &mut elements[element.0].load_local_n_per_m;
            load[0] += q[0];
            load[1] += q[1];
        }

        let mut force = vec![0.0; dof_count];
        for &(node, load) in &loads.nodal {
            let first = DOFS_PER_NODE * node.0;
            for (slot, value) in force[first..first + DOFS_PER_NODE].iter_mut().zip(load) {
                *slot += value;
            }
        }
        for (element, result) in self.elements.iter().zip(&mut elements) {
            let load = &mut result.load_local_n_per_m;
            *load = element.to_local(*load);
            let local = element.equivalent_nodal_loads(*load);
            let body = rotation_to_local(element.axis).tr_mul(&local);
            for (k, dof) in element.dofs().into_iter().enumerate() {
                force[dof] += body[k];
            }
        }
        self.for_each_roller(|dof, direction| {
            let rotated = components_along(direction, [force[dof], force[dof + 1]]);
            force[dof..dof + 2].copy_from_slice(&rotated);
        });

        let mut free_displacement = DVector::from_iterator(
            self.free_dofs.len(),
            self.free_dofs.iter().map(|&d| force[d]),
        );
        self.cholesky.solve_mut(&mut free_displacement);

        let mut displacement = vec![0.0; dof_count];
        for (&dof, &value) in self.free_dofs.iter().zip(free_displacement.iter()) {
            displacement[dof] = value;
        }
        // The load vector becomes the reactions: R = K u - F on the fixed dofs
        // (whose own displacement is zero), nothing on the free ones.
        let mut reaction = force;
        for &dof in &self.free_dofs {
            reaction[dof] = 0.0;
        }
        for (k, &dof) in self.fixed_dofs.iter().enumerate() {
            let stiffness_times_u = self.free_fixed_stiffness.column(k).dot(&free_displacement);
            reaction[dof] = stiffness_times_u - reaction[dof];
        }
        self.for_each_roller(|dof, direction| {
            for vector in [&mut displacement, &mut reaction] {
                let body = vector_from_components(direction, [vector[dof], vector[dof + 1]]);
                vector[dof..dof + 2].copy_from_slice(&body);
            }
        });

        for (element, result) in self.elements.iter().zip(&mut elements) {
            let body = Vector6::from_iterator(element.dofs().map(|d| displacement[d]));
            let end_forces = element.local_stiffness_from_body * body
                - element.equivalent_nodal_loads(result.load_local_n_per_m);
            result.end_forces_local = end_forces.into();
        }

        PlaneFrameSolution {
            displacement,
            reaction,
            elements,
        }
    }

    /// Calls `f(x dof, roller direction)` for every roller node.
    fn for_each_roller(&self, mut f: impl FnMut(usize, [f64; 2])) {
        for (node, direction) in self.roller_directions.iter().enumerate() {
            if let Some(direction) = direction {
                f(DOFS_PER_NODE * node, *direction);
            }
        }
    }
}

/// Loads in body axes.
#[derive(Clone, Debug, Default)]
pub struct PlaneFrameLoads {
    /// Nodal loads `[fx_n, fy_n, moment_nm]` (moment counter-clockwise); several
    /// entries for one node add up.
    pub nodal: Vec<(NodeId, [f64; 3])>,
    /// Uniform load per unit length on every element, e.g. gravity: each
    /// element's mass per length (see [`PlaneFrameBuilder::density`]) times this
    /// acceleration field `[ax, ay]`, m/s².
    pub body_acceleration_m_s2: [f64; 2],
    /// Extra uniform loads per unit length of one element `[qx, qy]`, N/m, body
    /// axes; several entries for one element add up.
    pub distributed: Vec<(ElementId, [f64; 2])>,
}

/// Stress resultants at a section of an element, acting on the part between
/// node `a` and the section (see the [module docs](self) for the convention).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InternalForces {
    /// Axial force, N; positive in tension.
    pub axial_n: f64,
    /// Shear force, N; `dM/dx`, the sum of local-`y` forces on the part between
    /// node `a` and the section.
    pub shear_n: f64,
    /// Bending moment, N·m; positive when it compresses the local `+y` fibre.
    pub moment_nm: f64,
}

#[derive(Clone, Copy, Debug)]
struct ElementResult {
    length_m: f64,
    /// Local forces that the nodes apply to the element, `[Fx_a, Fy_a, M_a, Fx_b, Fy_b, M_b]`.
    end_forces_local: [f64; 6],
    /// The element's uniform load per length in local axes.
    load_local_n_per_m: [f64; 2],
}

/// The result of one load case.
#[derive(Clone, Debug)]
pub struct PlaneFrameSolution {
    /// Body axes, three entries per node.
    displacement: Vec<f64>,
    /// Body axes, three entries per node; zero where free.
    reaction: Vec<f64>,
    elements: Vec<ElementResult>,
}

impl PlaneFrameSolution {
    /// A node's `[ux_m, uy_m, rotation_rad]` in body axes (rotation
    /// counter-clockwise).
    ///
    /// # Panics
    /// If `node` does not belong to the solved model.
    pub fn displacement(&self, node: NodeId) -> [f64; 3] {
        node_triple(&self.displacement, node)
    }

    /// The force and moment `[fx_n, fy_n, moment_nm]` the supports apply to the
    /// node, in body axes; zero for unsupported nodes and free components. A
    /// roller's reaction lies along its direction.
    ///
    /// # Panics
    /// If `node` does not belong to the solved model.
    pub fn reaction(&self, node: NodeId) -> [f64; 3] {
        node_triple(&self.reaction, node)
    }

    /// Stress resultants at the fraction `xi` in `[0, 1]` of the way from the
    /// element's node `a` to its node `b`: the element's end forces, then statics
    /// of the part between node `a` and the section under the element's uniform
    /// load. Exact for Euler-Bernoulli with uniform loads.
    ///
    /// # Panics
    /// If `element` does not belong to the solved model.
    pub fn internal_forces(&self, element: ElementId, xi: f64) -> InternalForces {
        debug_assert!((0.0..=1.0).contains(&xi), "xi {xi} outside [0, 1]");
        let result = &self.elements[element.0];
        let x = xi * result.length_m;
        let [fx_a, fy_a, m_a, ..] = result.end_forces_local;
        let [qx, qy] = result.load_local_n_per_m;
        InternalForces {
            axial_n: -fx_a - qx * x,
            shear_n: fy_a + qy * x,
            moment_nm: -m_a + fy_a * x + qy * x * x / 2.0,
        }
    }
}

fn node_triple(values: &[f64], node: NodeId) -> [f64; 3] {
    let first = DOFS_PER_NODE * node.0;
    [values[first], values[first + 1], values[first + 2]]
}

#[cfg(test)]
mod tests {
    use std::f64::consts::{PI, TAU};

    use proptest::prelude::*;

    use super::*;

    const E_PA: f64 = 210e9;
    const STEEL_KG_M3: f64 = 7850.0;
    const RELATIVE_TOLERANCE: f64 = 1e-9;
    const SECTION: SectionProperties = SectionProperties {
        area_m2: 8e-3,
        second_moment_m4: 3e-5,
    };
    const EI: f64 = E_PA * 3e-5;
    const EA: f64 = E_PA * 8e-3;

    /// `|actual - expected| <= 1e-9 × max(|expected|, scale)`: relative, with
    /// `scale` standing in where the expected value is (near) zero.
    #[track_caller]
    fn assert_close(actual: f64, expected: f64, scale: f64, what: &str) {
        let tolerance = RELATIVE_TOLERANCE * expected.abs().max(scale.abs());
        assert!(
            (actual - expected).abs() <= tolerance,
            "{what}: got {actual:e}, expected {expected:e} (difference {:e}, tolerance {tolerance:e})",
            actual - expected
        );
    }

    /// Local axes of a member at `angle_rad` to body x.
    #[derive(Clone, Copy)]
    struct Axes {
        x: [f64; 2],
        y: [f64; 2],
    }

    impl Axes {
        fn at(angle_rad: f64) -> Self {
            let (s, c) = angle_rad.sin_cos();
            Axes {
                x: [c, s],
                y: [-s, c],
            }
        }

        /// Body-axes vector from local components.
        fn body(&self, [lx, ly]: [f64; 2]) -> [f64; 2] {
            [
                lx * self.x[0] + ly * self.y[0],
                lx * self.x[1] + ly * self.y[1],
            ]
        }

        /// Local components of a body-axes vector.
        fn local(&self, v: [f64; 2]) -> [f64; 2] {
            [dot(v, self.x), dot(v, self.y)]
        }

        /// Body-axes nodal load from local force components and a moment.
        fn load(&self, local_force: [f64; 2], moment_nm: f64) -> [f64; 3] {
            let [fx, fy] = self.body(local_force);
            [fx, fy, moment_nm]
        }

        /// Local `[u, v, rotation]` of a body-axes displacement or reaction.
        fn local3(&self, [x, y, r]: [f64; 3]) -> [f64; 3] {
            let [lx, ly] = self.local([x, y]);
            [lx, ly, r]
        }
    }

    fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
        a[0] * b[0] + a[1] * b[1]
    }

    /// A straight member of `n` equal elements from `origin` along `axes.x`.
    struct Member {
        nodes: Vec<NodeId>,
        elements: Vec<ElementId>,
        length_m: f64,
    }

    impl Member {
        fn add(
            frame: &mut PlaneFrameBuilder,
            origin: [f64; 2],
            axes: Axes,
            length_m: f64,
            n: usize,
        ) -> Self {
            Self::add_with(frame, origin, axes, length_m, n, |_| SECTION)
        }

        fn add_with(
            frame: &mut PlaneFrameBuilder,
            origin: [f64; 2],
            axes: Axes,
            length_m: f64,
            n: usize,
            section: impl Fn(usize) -> SectionProperties,
        ) -> Self {
            let nodes: Vec<NodeId> = (0..=n)
                .map(|i| {
                    let x = length_m * i as f64 / n as f64;
                    frame.node([origin[0] + x * axes.x[0], origin[1] + x * axes.x[1]])
                })
                .collect();
            let elements = nodes
                .windows(2)
                .enumerate()
                .map(|(i, w)| frame.element(w[0], w[1], section(i)))
                .collect();
            Member {
                nodes,
                elements,
                length_m,
            }
        }

        fn first(&self) -> NodeId {
            self.nodes[0]
        }

        fn last(&self) -> NodeId {
            *self.nodes.last().unwrap()
        }

        fn x_of_node(&self, i: usize) -> f64 {
            self.length_m * i as f64 / (self.nodes.len() - 1) as f64
        }
    }

    #[track_caller]
    fn assert_internal(
        solution: &PlaneFrameSolution,
        member: &Member,
        expected: impl Fn(f64) -> [f64; 3],
        force_scale: f64,
        moment_scale: f64,
    ) {
        assert_internal_by_element(
            solution,
            member,
            |_, x| expected(x),
            force_scale,
            moment_scale,
        );
    }

    /// As [`assert_internal`], for expectations that jump at a node: `expected`
    /// also gets the element's index along the member.
    #[track_caller]
    fn assert_internal_by_element(
        solution: &PlaneFrameSolution,
        member: &Member,
        expected: impl Fn(usize, f64) -> [f64; 3],
        force_scale: f64,
        moment_scale: f64,
    ) {
        let element_length = member.length_m / member.elements.len() as f64;
        for (i, &element) in member.elements.iter().enumerate() {
            for xi in [0.0, 0.25, 0.5, 0.8, 1.0] {
                let x = (i as f64 + xi) * element_length;
                let [n, v, m] = expected(i, x);
                let got = solution.internal_forces(element, xi);
                let at = format!("{element} xi {xi} (x = {x} m)");
                assert_close(got.axial_n, n, force_scale, &format!("axial at {at}"));
                assert_close(got.shear_n, v, force_scale, &format!("shear at {at}"));
                assert_close(got.moment_nm, m, moment_scale, &format!("moment at {at}"));
            }
        }
    }

    #[track_caller]
    fn assert_local_displacements(
        solution: &PlaneFrameSolution,
        member: &Member,
        axes: Axes,
        expected: impl Fn(f64) -> [f64; 3],
        scale: [f64; 3],
    ) {
        for (i, &node) in member.nodes.iter().enumerate() {
            let x = member.x_of_node(i);
            let got = axes.local3(solution.displacement(node));
            let want = expected(x);
            for (k, name) in ["u", "v", "rotation"].into_iter().enumerate() {
                assert_close(got[k], want[k], scale[k], &format!("{name} at x = {x} m"));
            }
        }
    }

    #[track_caller]
    fn assert_reaction(
        solution: &PlaneFrameSolution,
        node: NodeId,
        axes: Axes,
        expected_local: [f64; 3],
        scale: [f64; 3],
    ) {
        let got = axes.local3(solution.reaction(node));
        for (k, name) in ["fx", "fy", "moment"].into_iter().enumerate() {
            assert_close(
                got[k],
                expected_local[k],
                scale[k],
                &format!("reaction {name} at {node}"),
            );
        }
    }

    // ---- 1, 2, 5: cantilevers -------------------------------------------

    fn check_cantilever_tip_load(angle_rad: f64) {
        let (length, p) = (4.0, 1500.0);
        let axes = Axes::at(angle_rad);
        let mut frame = PlaneFrameBuilder::new(E_PA);
        let member = Member::add(&mut frame, [1.0, -2.0], axes, length, 8);
        frame.fixed_support(member.first());
        let model = frame.build().unwrap();
        let loads = PlaneFrameLoads {
            nodal: vec![(member.last(), axes.load([0.0, p], 0.0))],
            ..Default::default()
        };
        let solution = model.solve(&loads);

        let tip = axes.local3(solution.displacement(member.last()));
        assert_close(
            tip[1],
            p * length.powi(3) / (3.0 * EI),
            0.0,
            "tip deflection PL³/3EI",
        );
        assert_close(
            tip[2],
            p * length.powi(2) / (2.0 * EI),
            0.0,
            "tip rotation PL²/2EI",
        );
        let scale = [
            p * length / EA,
            p * length.powi(3) / EI,
            p * length.powi(2) / EI,
        ];
        assert_local_displacements(
            &solution,
            &member,
            axes,
            |x| {
                [
                    0.0,
                    p * x * x * (3.0 * length - x) / (6.0 * EI),
                    p * x * (2.0 * length - x) / (2.0 * EI),
                ]
            },
            scale,
        );
        assert_close(
            solution.internal_forces(member.elements[0], 0.0).moment_nm,
            p * length,
            0.0,
            "root moment PL",
        );
        assert_internal(
            &solution,
            &member,
            |x| [0.0, -p, p * (length - x)],
            p,
            p * length,
        );
        assert_reaction(
            &solution,
            member.first(),
            axes,
            [0.0, -p, -p * length],
            [p, p, p * length],
        );
    }

    fn check_cantilever_tip_moment(angle_rad: f64) {
        let (length, m0) = (3.0, 2500.0);
        let axes = Axes::at(angle_rad);
        let mut frame = PlaneFrameBuilder::new(E_PA);
        let member = Member::add(&mut frame, [0.0, 0.0], axes, length, 5);
        frame.fixed_support(member.first());
        let model = frame.build().unwrap();
        let loads = PlaneFrameLoads {
            nodal: vec![(member.last(), [0.0, 0.0, m0])],
            ..Default::default()
        };
        let solution = model.solve(&loads);

        let scale = [m0 / EA, m0 * length * length / EI, m0 * length / EI];
        assert_local_displacements(
            &solution,
            &member,
            axes,
            |x| [0.0, m0 * x * x / (2.0 * EI), m0 * x / EI],
            scale,
        );
        assert_internal(&solution, &member, |_| [0.0, 0.0, m0], m0 / length, m0);
        assert_reaction(
            &solution,
            member.first(),
            axes,
            [0.0, 0.0, -m0],
            [m0 / length, m0 / length, m0],
        );
    }

    fn check_cantilever_uniform_load(angle_rad: f64) {
        let (length, w) = (5.0, 2000.0);
        let axes = Axes::at(angle_rad);
        let mut frame = PlaneFrameBuilder::new(E_PA);
        let member = Member::add(&mut frame, [0.0, 0.0], axes, length, 7);
        frame.fixed_support(member.first());
        let model = frame.build().unwrap();
        let q = axes.body([0.0, -w]);
        let loads = PlaneFrameLoads {
            distributed: member.elements.iter().map(|&e| (e, q)).collect(),
            ..Default::default()
        };
        let solution = model.solve(&loads);

        let tip = axes.local3(solution.displacement(member.last()));
        assert_close(
            tip[1],
            -w * length.powi(4) / (8.0 * EI),
            0.0,
            "tip deflection qL⁴/8EI",
        );
        let l = length;
        let scale = [w * l * l / EA, w * l.powi(4) / EI, w * l.powi(3) / EI];
        assert_local_displacements(
            &solution,
            &member,
            axes,
            |x| {
                [
                    0.0,
                    -w * x * x * (6.0 * l * l - 4.0 * l * x + x * x) / (24.0 * EI),
                    -w * x * (3.0 * l * l - 3.0 * l * x + x * x) / (6.0 * EI),
                ]
            },
            scale,
        );
        assert_close(
            solution.internal_forces(member.elements[0], 0.0).moment_nm,
            -w * l * l / 2.0,
            0.0,
            "root moment",
        );
        // Mid-element stations exercise the q x²/2 term.
        assert_internal(
            &solution,
            &member,
            |x| [0.0, w * (l - x), -w * (l - x).powi(2) / 2.0],
            w * l,
            w * l * l,
        );
        assert_reaction(
            &solution,
            member.first(),
            axes,
            [0.0, w * l, w * l * l / 2.0],
            [w * l, w * l, w * l * l],
        );
    }

    #[test]
    fn cantilever_under_tip_load_and_tip_moment() {
        check_cantilever_tip_load(0.0);
        check_cantilever_tip_moment(0.0);
    }

    #[test]
    fn cantilever_under_uniform_load() {
        check_cantilever_uniform_load(0.0);
    }

    // ---- 3, 5: simply supported beams -------------------------------------

    /// Pin at the start; roller across the member at the end (or, with
    /// `two_rollers_for_pin`, the pin replaced by two rollers in different
    /// directions).
    fn simply_supported(
        angle_rad: f64,
        length_m: f64,
        n: usize,
        two_rollers_for_pin: bool,
    ) -> (PlaneFrameModel, Member, Axes) {
        let axes = Axes::at(angle_rad);
        let mut frame = PlaneFrameBuilder::new(E_PA);
        let member = Member::add(&mut frame, [-3.0, 0.5], axes, length_m, n);
        if two_rollers_for_pin {
            frame.roller_support(member.first(), [1.0, 0.0]);
            frame.roller_support(member.first(), [2.0, 2.0]);
        } else {
            frame.pin_support(member.first());
        }
        // Any length and sense: the builder normalises it.
        let [dx, dy] = axes.y;
        frame.roller_support(member.last(), [-2.5 * dx, -2.5 * dy]);
        (frame.build().unwrap(), member, axes)
    }

    fn check_simply_supported_uniform_load(angle_rad: f64) {
        let (l, w) = (6.0, 3000.0);
        for (n, two_rollers_for_pin) in [(5, false), (6, false), (5, true)] {
            let (model, member, axes) = simply_supported(angle_rad, l, n, two_rollers_for_pin);
            let q = axes.body([0.0, -w]);
            let loads = PlaneFrameLoads {
                distributed: member.elements.iter().map(|&e| (e, q)).collect(),
                ..Default::default()
            };
            let solution = model.solve(&loads);

            let scale = [w * l * l / EA, w * l.powi(4) / EI, w * l.powi(3) / EI];
            assert_local_displacements(
                &solution,
                &member,
                axes,
                |x| {
                    [
                        0.0,
                        -w * x * (l.powi(3) - 2.0 * l * x * x + x.powi(3)) / (24.0 * EI),
                        -w * (l.powi(3) - 6.0 * l * x * x + 4.0 * x.powi(3)) / (24.0 * EI),
                    ]
                },
                scale,
            );
            let start = axes.local3(solution.displacement(member.first()));
            let end = axes.local3(solution.displacement(member.last()));
            assert_close(
                start[2],
                -w * l.powi(3) / (24.0 * EI),
                0.0,
                "end rotation qL³/24EI",
            );
            assert_close(
                end[2],
                w * l.powi(3) / (24.0 * EI),
                0.0,
                "end rotation qL³/24EI",
            );
            if n % 2 == 0 {
                let mid = axes.local3(solution.displacement(member.nodes[n / 2]));
                assert_close(
                    mid[1],
                    -5.0 * w * l.powi(4) / (384.0 * EI),
                    0.0,
                    "midspan deflection 5qL⁴/384EI",
                );
            } else {
                let mid = solution.internal_forces(member.elements[n / 2], 0.5);
                assert_close(
                    mid.moment_nm,
                    w * l * l / 8.0,
                    0.0,
                    "midspan moment qL²/8 inside an element",
                );
            }
            assert_internal(
                &solution,
                &member,
                |x| [0.0, w * (l / 2.0 - x), w * x * (l - x) / 2.0],
                w * l,
                w * l * l,
            );
            let force_scale = [w * l; 3];
            assert_reaction(
                &solution,
                member.first(),
                axes,
                [0.0, w * l / 2.0, 0.0],
                force_scale,
            );
            assert_reaction(
                &solution,
                member.last(),
                axes,
                [0.0, w * l / 2.0, 0.0],
                force_scale,
            );
        }
    }

    fn check_simply_supported_central_load(angle_rad: f64) {
        let (l, p) = (6.0, 8000.0);
        let (model, member, axes) = simply_supported(angle_rad, l, 6, false);
        let loads = PlaneFrameLoads {
            nodal: vec![(member.nodes[3], axes.load([0.0, -p], 0.0))],
            ..Default::default()
        };
        let solution = model.solve(&loads);

        let mid = axes.local3(solution.displacement(member.nodes[3]));
        assert_close(
            mid[1],
            -p * l.powi(3) / (48.0 * EI),
            0.0,
            "midspan deflection PL³/48EI",
        );
        assert_close(
            solution.internal_forces(member.elements[2], 1.0).moment_nm,
            p * l / 4.0,
            0.0,
            "moment PL/4",
        );
        assert_internal_by_element(
            &solution,
            &member,
            |element, x| {
                let from_near_end = x.min(l - x);
                // The shear jumps at the loaded node, the end of element 2.
                let shear = if element < 3 { p / 2.0 } else { -p / 2.0 };
                [0.0, shear, p * from_near_end / 2.0]
            },
            p,
            p * l,
        );
        assert_reaction(&solution, member.first(), axes, [0.0, p / 2.0, 0.0], [p; 3]);
        assert_reaction(&solution, member.last(), axes, [0.0, p / 2.0, 0.0], [p; 3]);
    }

    #[test]
    fn simply_supported_under_uniform_and_central_point_load() {
        check_simply_supported_uniform_load(0.0);
        check_simply_supported_central_load(0.0);
    }

    // ---- 4: axial bar ------------------------------------------------------

    fn check_axial(angle_rad: f64) {
        let (l, p, q) = (2.5, 40e3, 5e3);
        let axes = Axes::at(angle_rad);

        // Clamped, end load P: u = Px/EA, N = P.
        let mut frame = PlaneFrameBuilder::new(E_PA);
        let member = Member::add(&mut frame, [0.0, 1.0], axes, l, 4);
        frame.fixed_support(member.first());
        let model = frame.build().unwrap();
        let solution = model.solve(&PlaneFrameLoads {
            nodal: vec![(member.last(), axes.load([p, 0.0], 0.0))],
            ..Default::default()
        });
        let tip = axes.local3(solution.displacement(member.last()));
        assert_close(tip[0], p * l / EA, 0.0, "PL/EA");
        let scale = [p * l / EA, p * l / EA, p / EA];
        assert_local_displacements(&solution, &member, axes, |x| [p * x / EA, 0.0, 0.0], scale);
        assert_internal(&solution, &member, |_| [p, 0.0, 0.0], p, p * l);

        // Clamped, uniform axial load q: u = q(Lx - x²/2)/EA, N = q(L - x).
        let loads = PlaneFrameLoads {
            distributed: member
                .elements
                .iter()
                .map(|&e| (e, axes.body([q, 0.0])))
                .collect(),
            ..Default::default()
        };
        let solution = model.solve(&loads);
        let scale = [q * l * l / EA, q * l * l / EA, q * l / EA];
        assert_local_displacements(
            &solution,
            &member,
            axes,
            |x| [q * (l * x - x * x / 2.0) / EA, 0.0, 0.0],
            scale,
        );
        assert_internal(
            &solution,
            &member,
            |x| [q * (l - x), 0.0, 0.0],
            q * l,
            q * l * l,
        );

        // Pin and a roller across the bar: the roller end slides freely along it.
        let mut frame = PlaneFrameBuilder::new(E_PA);
        let member = Member::add(&mut frame, [0.0, 1.0], axes, l, 3);
        frame.pin_support(member.first());
        frame.roller_support(member.last(), axes.y);
        let solution = frame.build().unwrap().solve(&PlaneFrameLoads {
            nodal: vec![(member.last(), axes.load([p, 0.0], 0.0))],
            ..Default::default()
        });
        assert_close(
            axes.local3(solution.displacement(member.last()))[0],
            p * l / EA,
            0.0,
            "PL/EA, pin and roller",
        );
        assert_internal(&solution, &member, |_| [p, 0.0, 0.0], p, p * l);
        assert_reaction(&solution, member.first(), axes, [-p, 0.0, 0.0], [p; 3]);
        assert_reaction(&solution, member.last(), axes, [0.0, 0.0, 0.0], [p; 3]);
    }

    #[test]
    fn axial_bar() {
        check_axial(0.0);
    }

    // ---- 5: everything again, rotated ---------------------------------------

    #[test]
    fn rotated_members_give_the_same_local_results() {
        for degrees in [37.0, -121.0] {
            let angle = f64::to_radians(degrees);
            check_cantilever_tip_load(angle);
            check_cantilever_tip_moment(angle);
            check_cantilever_uniform_load(angle);
            check_simply_supported_uniform_load(angle);
            check_simply_supported_central_load(angle);
            check_axial(angle);
        }
    }

    // ---- 6: a free body with self-equilibrated loads ------------------------

    /// An L-shaped body A(0,0) - B(4,0) - C(4,3), pinned at A and on a vertical
    /// roller at C, loaded by P at C along +x, (−P, −Q) at A and +Q at B with
    /// Q = 3P/4, which balance. Section cuts by hand:
    /// - AB at x from A (local x = body x, local y = body y), part A..cut holds
    ///   only the load at A: N = P, V = −Q, M = −Q x.
    /// - BC at s from B (local x = body y, local y = −body x), part A..cut holds
    ///   the loads at A and B, resultant (−P, 0), moment about the cut
    ///   (4, s): 4Q − sP, so N = 0, V = P, M = −(3 − s) P.
    #[test]
    fn free_body_under_balanced_loads_has_no_reactions_and_hand_statics() {
        let p = 10e3;
        let q = 0.75 * p;
        let mut frame = PlaneFrameBuilder::new(E_PA);
        let ab = Member::add(&mut frame, [0.0, 0.0], Axes::at(0.0), 4.0, 3);
        let bc_nodes: Vec<NodeId> = [1.0, 2.0, 3.0]
            .into_iter()
            .map(|y| frame.node([4.0, y]))
            .collect();
        let mut bc_chain = vec![ab.last()];
        bc_chain.extend(&bc_nodes);
        let bc_elements: Vec<ElementId> = bc_chain
            .windows(2)
            .map(|w| frame.element(w[0], w[1], SECTION))
            .collect();
        let bc = Member {
            nodes: bc_chain,
            elements: bc_elements,
            length_m: 3.0,
        };
        frame.pin_support(ab.first());
        frame.roller_support(bc.last(), [0.0, 1.0]);
        let model = frame.build().unwrap();
        let loads = PlaneFrameLoads {
            nodal: vec![
                (bc.last(), [p, 0.0, 0.0]),
                (ab.first(), [-p, -q, 0.0]),
                (ab.last(), [0.0, q, 0.0]),
            ],
            ..Default::default()
        };
        let solution = model.solve(&loads);

        for node in [ab.first(), bc.last()] {
            for (k, value) in solution.reaction(node).into_iter().enumerate() {
                assert_close(value, 0.0, p, &format!("reaction {k} at {node}"));
            }
        }
        assert_internal(&solution, &ab, |x| [p, -q, -q * x], p, p * 4.0);
        assert_internal(&solution, &bc, |s| [0.0, p, -(3.0 - s) * p], p, p * 4.0);
    }

    // ---- 7: gravity ------------------------------------------------------------

    #[test]
    fn gravity_from_density_equals_the_equivalent_distributed_load() {
        let g = [0.0, -9.81];
        let sections = [
            SectionProperties {
                area_m2: 9e-3,
                second_moment_m4: 4e-5,
            },
            SectionProperties {
                area_m2: 7e-3,
                second_moment_m4: 3e-5,
            },
            SectionProperties {
                area_m2: 5e-3,
                second_moment_m4: 2e-5,
            },
        ];
        let mut frame = PlaneFrameBuilder::new(E_PA);
        frame.density(STEEL_KG_M3);
        let nodes = [[0.0, 0.0], [1.5, 1.0], [3.0, 1.2], [4.0, 0.4]].map(|p| frame.node(p));
        let elements: Vec<ElementId> = nodes
            .windows(2)
            .zip(sections)
            .map(|(w, s)| frame.element(w[0], w[1], s))
            .collect();
        frame.fixed_support(nodes[0]);
        let model = frame.build().unwrap();

        let by_gravity = model.solve(&PlaneFrameLoads {
            body_acceleration_m_s2: g,
            ..Default::default()
        });
        let distributed = elements
            .iter()
            .zip(sections)
            .map(|(&e, s)| {
                (
                    e,
                    [
                        STEEL_KG_M3 * s.area_m2 * g[0],
                        STEEL_KG_M3 * s.area_m2 * g[1],
                    ],
                )
            })
            .collect();
        let by_distributed = model.solve(&PlaneFrameLoads {
            distributed,
            ..Default::default()
        });

        let weight = STEEL_KG_M3 * 9e-3 * 9.81 * 5.0;
        for &node in &nodes {
            let (a, b) = (
                by_gravity.displacement(node),
                by_distributed.displacement(node),
            );
            let scale = by_distributed
                .displacement(nodes[3])
                .map(f64::abs)
                .into_iter()
                .fold(0.0, f64::max);
            for k in 0..3 {
                assert_close(a[k], b[k], scale, "displacement");
                assert_close(
                    by_gravity.reaction(node)[k],
                    by_distributed.reaction(node)[k],
                    weight * 4.0,
                    "reaction",
                );
            }
        }
        let total_weight: f64 = elements
            .iter()
            .zip(sections)
            .map(|(&e, s)| STEEL_KG_M3 * s.area_m2 * 9.81 * model.element_length_m(e))
            .sum();
        assert_close(
            by_gravity.reaction(nodes[0])[1],
            total_weight,
            0.0,
            "root reaction carries the weight",
        );
        for &element in &elements {
            for xi in [0.0, 0.3, 0.5, 1.0] {
                let (a, b) = (
                    by_gravity.internal_forces(element, xi),
                    by_distributed.internal_forces(element, xi),
                );
                assert_close(a.axial_n, b.axial_n, weight, "axial");
                assert_close(a.shear_n, b.shear_n, weight, "shear");
                assert_close(a.moment_nm, b.moment_nm, weight * 4.0, "moment");
            }
        }
    }

    #[test]
    fn self_weight_of_a_horizontal_cantilever_and_linear_density_override() {
        let (l, g) = (4.0, 9.81);
        let w = STEEL_KG_M3 * SECTION.area_m2 * g;
        let mut frame = PlaneFrameBuilder::new(E_PA);
        let member = Member::add(&mut frame, [0.0, 0.0], Axes::at(0.0), l, 4);
        frame.fixed_support(member.first());
        // Set after the elements: still applies to them.
        frame.density(STEEL_KG_M3);
        let model = frame.clone().build().unwrap();
        let solution = model.solve(&PlaneFrameLoads {
            body_acceleration_m_s2: [0.0, -g],
            ..Default::default()
        });
        assert_close(
            solution.internal_forces(member.elements[0], 0.0).moment_nm,
            -w * l * l / 2.0,
            0.0,
            "root moment",
        );
        assert_close(
            solution.displacement(member.last())[1],
            -w * l.powi(4) / (8.0 * EI),
            0.0,
            "tip deflection",
        );

        // 100 kg/m on the last element instead of steel.
        frame.element_linear_density(member.elements[3], 100.0);
        let model = frame.build().unwrap();
        let with_override = model.solve(&PlaneFrameLoads {
            body_acceleration_m_s2: [0.0, -g],
            ..Default::default()
        });
        let mut distributed: Vec<(ElementId, [f64; 2])> = member.elements[..3]
            .iter()
            .map(|&e| (e, [0.0, -w]))
            .collect();
        distributed.push((member.elements[3], [0.0, -100.0 * g]));
        let by_hand = model.solve(&PlaneFrameLoads {
            body_acceleration_m_s2: [0.0, 0.0],
            distributed,
            ..Default::default()
        });
        let expected = by_hand.internal_forces(member.elements[0], 0.0).moment_nm;
        assert_close(
            with_override
                .internal_forces(member.elements[0], 0.0)
                .moment_nm,
            expected,
            0.0,
            "override",
        );
    }

    // ---- 8: tapered member -------------------------------------------------------

    const ROOT: BoxSection = BoxSection {
        height_m: 0.6,
        width_m: 0.35,
        flange_thickness_m: 0.02,
        web_thickness_m: 0.012,
    };
    const TIP: BoxSection = BoxSection {
        height_m: 0.3,
        width_m: 0.3,
        flange_thickness_m: 0.015,
        web_thickness_m: 0.01,
    };

    /// Simpson's rule with `intervals` (even) intervals.
    fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, intervals: usize) -> f64 {
        let h = (b - a) / intervals as f64;
        let inner: f64 = (1..intervals)
            .map(|i| f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 })
            .sum();
        (f(a) + inner + f(b)) * h / 3.0
    }

    #[test]
    fn tapered_cantilever_has_exact_moments_and_converging_deflection() {
        let (l, p) = (5.0, 2e4);
        let axes = Axes::at(0.4);
        let second_moment = |x: f64| ROOT.linear_blend(&TIP, x / l).second_moment_m4();
        // Unit-load method: δ = ∫ M m / EI with M = P(L - x), m = L - x.
        let continuous = simpson(
            |x| p * (l - x).powi(2) / (E_PA * second_moment(x)),
            0.0,
            l,
            2000,
        );

        let mut errors = Vec::new();
        for n in [4, 16, 64] {
            let element_length = l / n as f64;
            let section = |i: usize| {
                ROOT.linear_blend(&TIP, (i as f64 + 0.5) / n as f64)
                    .properties()
            };
            let mut frame = PlaneFrameBuilder::new(E_PA);
            let member = Member::add_with(&mut frame, [0.0, 0.0], axes, l, n, section);
            frame.fixed_support(member.first());
            let solution = frame.build().unwrap().solve(&PlaneFrameLoads {
                nodal: vec![(member.last(), axes.load([0.0, p], 0.0))],
                ..Default::default()
            });

            // Statically determinate: the moment ignores the stiffness.
            assert_internal(&solution, &member, |x| [0.0, -p, p * (l - x)], p, p * l);

            // The same integrals, piece by piece over the prismatic steps, in closed form.
            let (mut deflection, mut rotation) = (0.0, 0.0);
            for i in 0..n {
                let ei = E_PA * section(i).second_moment_m4;
                let (near, far) = (
                    l - i as f64 * element_length,
                    l - (i + 1) as f64 * element_length,
                );
                deflection += p * (near.powi(3) - far.powi(3)) / (3.0 * ei);
                rotation += p * (near.powi(2) - far.powi(2)) / (2.0 * ei);
            }
            let tip = axes.local3(solution.displacement(member.last()));
            assert_close(tip[1], deflection, 0.0, "stepwise tip deflection");
            assert_close(tip[2], rotation, 0.0, "stepwise tip rotation");
            errors.push((tip[1] - continuous).abs() / continuous);
        }
        // Midpoint sections: second-order convergence to the continuous taper.
        assert!(
            errors[1] < errors[0] / 10.0 && errors[2] < errors[1] / 10.0,
            "errors {errors:?}"
        );
        assert!(errors[2] < 1e-4, "errors {errors:?}");
    }

    // ---- 9: box sections -----------------------------------------------------------

    #[test]
    fn box_section_properties_by_hand() {
        let section = BoxSection {
            height_m: 0.5,
            width_m: 0.3,
            flange_thickness_m: 0.02,
            web_thickness_m: 0.015,
        };
        // 0.3 × 0.5 − 0.27 × 0.46
        assert_close(section.area_m2(), 0.0258, 0.0, "area");
        // Flanges 2 (0.3 × 0.02³/12 + 0.3 × 0.02 × 0.24²) + webs 2 × 0.015 × 0.46³/12
        assert_close(section.second_moment_m4(), 9.3494e-4, 0.0, "second moment");
        // Flange 0.3 × 0.02 × 0.24 + two webs 0.015 × 0.23²/2
        assert_close(
            section.first_moment_at_neutral_axis_m3(),
            2.2335e-3,
            0.0,
            "first moment",
        );
        assert_close(
            section.shear_stress_at_neutral_axis_pa(1e5),
            1e5 * 2.2335e-3 / (9.3494e-4 * 0.03),
            0.0,
            "shear stress",
        );
        assert_eq!(
            section.properties(),
            SectionProperties {
                area_m2: section.area_m2(),
                second_moment_m4: section.second_moment_m4()
            }
        );
        assert_eq!(section.validate(), Ok(()));

        let blend = ROOT.linear_blend(&TIP, 0.25);
        assert_close(blend.height_m, 0.525, 0.0, "blended height");
        assert_close(blend.width_m, 0.3375, 0.0, "blended width");
        assert_close(blend.flange_thickness_m, 0.01875, 0.0, "blended flange");
        assert_close(blend.web_thickness_m, 0.0115, 0.0, "blended web");
        assert_eq!(ROOT.linear_blend(&TIP, 0.0), ROOT);
        assert_eq!(ROOT.linear_blend(&TIP, 1.0), TIP);

        let parsed: BoxSection = toml::from_str(
            "height_m = 0.5\nwidth_m = 0.3\nflange_thickness_m = 0.02\nweb_thickness_m = 0.015\n",
        )
        .unwrap();
        assert_eq!(parsed, section);
        assert!(toml::from_str::<BoxSection>("height_m = 0.5\nwidth_m = 0.3\nflange_thickness_m = 0.02\nweb_thickness_m = 0.015\nheigth_m = 1.0\n").is_err());
    }

    #[test]
    fn box_section_validation_names_the_problem() {
        let good = BoxSection {
            height_m: 0.5,
            width_m: 0.3,
            flange_thickness_m: 0.02,
            web_thickness_m: 0.015,
        };
        let cases = [
            (
                BoxSection {
                    height_m: -0.5,
                    ..good
                },
                "height_m",
            ),
            (
                BoxSection {
                    width_m: 0.0,
                    ..good
                },
                "width_m",
            ),
            (
                BoxSection {
                    flange_thickness_m: f64::NAN,
                    ..good
                },
                "flange_thickness_m",
            ),
            (
                BoxSection {
                    web_thickness_m: f64::INFINITY,
                    ..good
                },
                "web_thickness_m",
            ),
            (
                BoxSection {
                    flange_thickness_m: 0.25,
                    ..good
                },
                "flanges meet",
            ),
            (
                BoxSection {
                    web_thickness_m: 0.2,
                    ..good
                },
                "webs meet",
            ),
        ];
        for (section, expected) in cases {
            let message = section.validate().unwrap_err();
            assert!(message.contains(expected), "{section:?}: {message}");
        }
    }

    // ---- 10: builder errors -----------------------------------------------------------

    fn beam(
        supports: impl FnOnce(&mut PlaneFrameBuilder, NodeId, NodeId),
    ) -> Result<PlaneFrameModel, PlaneFrameError> {
        let mut frame = PlaneFrameBuilder::new(E_PA);
        let a = frame.node([0.0, 0.0]);
        let b = frame.node([2.0, 0.0]);
        frame.element(a, b, SECTION);
        supports(&mut frame, a, b);
        frame.build()
    }

    #[test]
    fn mechanisms_are_errors_not_panics() {
        let unsupported = beam(|_, _, _| {}).unwrap_err();
        assert!(
            matches!(unsupported, PlaneFrameError::Mechanism { .. }),
            "{unsupported}"
        );
        assert!(unsupported.to_string().contains("mechanism"));

        // Free to turn about the pin; found at the last pivot.
        let pin_only = beam(|f, a, _| f.pin_support(a)).unwrap_err();
        assert_eq!(
            pin_only,
            PlaneFrameError::Mechanism {
                node: NodeId(1),
                dof: Dof::Rotation
            }
        );

        // The roller's reaction passes through the pin: free to rotate about it.
        let aligned = beam(|f, a, b| {
            f.pin_support(a);
            f.roller_support(b, [1.0, 0.0]);
        })
        .unwrap_err();
        assert!(
            matches!(aligned, PlaneFrameError::Mechanism { .. }),
            "{aligned}"
        );

        // A node that no element stiffens.
        let mut frame = PlaneFrameBuilder::new(E_PA);
        let a = frame.node([0.0, 0.0]);
        let b = frame.node([2.0, 0.0]);
        let loose = frame.node([1.0, 1.0]);
        frame.element(a, b, SECTION);
        frame.fixed_support(a);
        frame.pin_support(loose);
        assert_eq!(
            frame.build().unwrap_err(),
            PlaneFrameError::Mechanism {
                node: loose,
                dof: Dof::Rotation
            }
        );

        // Two parallel rollers are one roller, not a pin.
        let parallel = beam(|f, a, b| {
            f.roller_support(a, [0.0, 1.0]);
            f.roller_support(a, [0.0, -3.0]);
            f.roller_support(b, [0.0, 1.0]);
        })
        .unwrap_err();
        assert!(
            matches!(parallel, PlaneFrameError::Mechanism { .. }),
            "{parallel}"
        );

        assert!(beam(|f, a, b| {
            f.pin_support(a);
            f.roller_support(b, [0.0, 1.0]);
        })
        .is_ok());
    }

    #[test]
    fn bad_data_is_an_error() {
        let supported = |f: &mut PlaneFrameBuilder, a, b| {
            f.pin_support(a);
            f.roller_support(b, [0.0, 1.0]);
        };

        let mut frame = PlaneFrameBuilder::new(E_PA);
        let a = frame.node([1.0, 1.0]);
        let b = frame.node([1.0, 1.0]);
        frame.element(a, b, SECTION);
        supported(&mut frame, a, b);
        assert!(matches!(
            frame.build(),
            Err(PlaneFrameError::ZeroLengthElement { .. })
        ));

        let mut frame = PlaneFrameBuilder::new(E_PA);
        let a = frame.node([0.0, 0.0]);
        let b = frame.node([1.0, 0.0]);
        frame.element(a, b, SECTION);
        frame.element(b, b, SECTION);
        supported(&mut frame, a, b);
        assert_eq!(
            frame.build().unwrap_err(),
            PlaneFrameError::ZeroLengthElement {
                element: ElementId(1),
                a: b,
                b
            }
        );

        for section in [
            SectionProperties {
                area_m2: 0.0,
                ..SECTION
            },
            SectionProperties {
                second_moment_m4: f64::NAN,
                ..SECTION
            },
            SectionProperties {
                area_m2: -1.0,
                ..SECTION
            },
        ] {
            let mut frame = PlaneFrameBuilder::new(E_PA);
            let a = frame.node([0.0, 0.0]);
            let b = frame.node([1.0, 0.0]);
            frame.element(a, b, section);
            supported(&mut frame, a, b);
            let error = frame.build().unwrap_err();
            assert!(
                matches!(error, PlaneFrameError::InvalidSection { .. }),
                "{error}"
            );
        }

        let mut frame = PlaneFrameBuilder::new(0.0);
        let a = frame.node([0.0, 0.0]);
        let b = frame.node([1.0, 0.0]);
        frame.element(a, b, SECTION);
        supported(&mut frame, a, b);
        assert_eq!(
            frame.clone().build().unwrap_err(),
            PlaneFrameError::InvalidYoungsModulus(0.0)
        );

        let mut frame = PlaneFrameBuilder::new(E_PA);
        frame.density(-1.0);
        assert_eq!(
            frame.build().unwrap_err(),
            PlaneFrameError::InvalidDensity(-1.0)
        );

        let roller = beam(|f, a, b| {
            f.pin_support(a);
            f.roller_support(b, [0.0, 0.0]);
        });
        assert!(matches!(
            roller,
            Err(PlaneFrameError::InvalidRollerDirection { .. })
        ));

        let mut frame = PlaneFrameBuilder::new(E_PA);
        let a = frame.node([0.0, 0.0]);
        let b = frame.node([1.0, f64::NAN]);
        frame.element(a, b, SECTION);
        assert!(matches!(
            frame.build(),
            Err(PlaneFrameError::InvalidNodePosition { .. })
        ));

        // An id from another, larger frame.
        let mut other = PlaneFrameBuilder::new(E_PA);
        let foreign = (0..5).map(|i| other.node([i as f64, 0.0])).last().unwrap();
        let mut frame = PlaneFrameBuilder::new(E_PA);
        let a = frame.node([0.0, 0.0]);
        frame.element(a, foreign, SECTION);
        assert_eq!(
            frame.build().unwrap_err(),
            PlaneFrameError::UnknownNode(foreign)
        );

        let mut frame = PlaneFrameBuilder::new(E_PA);
        let a = frame.node([0.0, 0.0]);
        let b = frame.node([1.0, 0.0]);
        let element = frame.element(a, b, SECTION);
        frame.fixed_support(a);
        frame.element_linear_density(element, f64::NAN);
        assert!(matches!(
            frame.build(),
            Err(PlaneFrameError::InvalidLinearDensity { .. })
        ));
    }

    #[test]
    fn solutions_superpose_and_the_model_is_reusable() {
        let (model, member, _) = simply_supported(0.3, 5.0, 4, false);
        let a = PlaneFrameLoads {
            nodal: vec![(member.nodes[1], [1e3, -2e3, 500.0])],
            ..Default::default()
        };
        let b = PlaneFrameLoads {
            distributed: vec![(member.elements[2], [300.0, -700.0])],
            body_acceleration_m_s2: [1.0, -9.81],
            ..Default::default()
        };
        let both = PlaneFrameLoads {
            nodal: a.nodal.clone(),
            distributed: b.distributed.clone(),
            body_acceleration_m_s2: b.body_acceleration_m_s2,
        };
        let (sa, sb, sab) = (model.solve(&a), model.solve(&b), model.solve(&both));
        assert_eq!(model.node_count(), 5);
        assert_eq!(model.element_count(), 4);
        for &e in &member.elements {
            let (fa, fb, fab) = (
                sa.internal_forces(e, 0.4),
                sb.internal_forces(e, 0.4),
                sab.internal_forces(e, 0.4),
            );
            assert_close(
                fab.moment_nm,
                fa.moment_nm + fb.moment_nm,
                1e4,
                "superposed moment",
            );
        }
        for &n in &member.nodes {
            for k in 0..3 {
                let scale = 1e-6;
                assert_close(
                    sab.displacement(n)[k],
                    sa.displacement(n)[k] + sb.displacement(n)[k],
                    scale,
                    "superposed displacement",
                );
            }
        }
    }

    // ---- property: random free bodies ---------------------------------------------------

    #[derive(Clone, Debug)]
    struct FreeBody {
        heading_rad: f64,
        /// (length m, kink from the previous segment rad), one per element.
        segments: Vec<(f64, f64)>,
        root: BoxSection,
        tip: BoxSection,
        /// One per node, before balancing.
        nodal: Vec<[f64; 3]>,
        /// One per element, N/m body axes.
        distributed: Vec<[f64; 2]>,
        acceleration_m_s2: [f64; 2],
        /// Roller direction relative to the pin-to-roller line.
        roller_angle_rad: f64,
        cut: (usize, f64),
    }

    fn box_section() -> impl Strategy<Value = BoxSection> {
        (0.25..0.8f64, 0.15..0.5f64, 0.006..0.03f64, 0.006..0.03f64).prop_map(
            |(height_m, width_m, flange_thickness_m, web_thickness_m)| BoxSection {
                height_m,
                width_m,
                flange_thickness_m,
                web_thickness_m,
            },
        )
    }

    fn free_body() -> impl Strategy<Value = FreeBody> {
        (2usize..8).prop_flat_map(|n| {
            (
                0.0..TAU,
                prop::collection::vec((0.4..2.0f64, -0.6..0.6f64), n),
                box_section(),
                box_section(),
                prop::collection::vec(
                    (-2e5..2e5f64, -2e5..2e5f64, -1e5..1e5f64).prop_map(|(x, y, m)| [x, y, m]),
                    n + 1,
                ),
                prop::collection::vec((-2e4..2e4f64, -2e4..2e4f64).prop_map(|(x, y)| [x, y]), n),
                (-15.0..15.0f64, -15.0..15.0f64).prop_map(|(x, y)| [x, y]),
                0.5..(PI - 0.5),
                (0..n, 0.0..=1.0f64),
            )
                .prop_map(
                    |(
                        heading_rad,
                        segments,
                        root,
                        tip,
                        nodal,
                        distributed,
                        acceleration_m_s2,
                        roller_angle_rad,
                        cut,
                    )| {
                        FreeBody {
                            heading_rad,
                            segments,
                            root,
                            tip,
                            nodal,
                            distributed,
                            acceleration_m_s2,
                            roller_angle_rad,
                            cut,
                        }
                    },
                )
        })
    }

    /// Section-cut statics on a chain (element `i` joins node `i` to node
    /// `i + 1`): the stress resultants at `xi` along `element` from the loads and
    /// reactions on node 0's side, in the module's sign convention.
    fn chain_cut(
        positions: &[[f64; 2]],
        element_loads: &[[f64; 2]],
        nodal: &[[f64; 3]],
        reactions: &[[f64; 3]],
        element: usize,
        xi: f64,
    ) -> InternalForces {
        let segment = |k: usize| {
            let (a, b) = (positions[k], positions[k + 1]);
            let length = (b[0] - a[0]).hypot(b[1] - a[1]);
            (a, length, [(b[0] - a[0]) / length, (b[1] - a[1]) / length])
        };
        let (a, length, ex) = segment(element);
        let ey = [-ex[1], ex[0]];
        let cut = [a[0] + xi * length * ex[0], a[1] + xi * length * ex[1]];
        let mut force = [0.0; 2];
        let mut moment = 0.0;
        let mut add = |point: [f64; 2], f: [f64; 2], m: f64| {
            force[0] += f[0];
            force[1] += f[1];
            moment += cross([point[0] - cut[0], point[1] - cut[1]], f) + m;
        };
        for node in 0..=element {
            for load in [nodal[node], reactions[node]] {
                add(positions[node], [load[0], load[1]], load[2]);
            }
        }
        for (k, q) in element_loads[..=element].iter().enumerate() {
            let (start, length, axis) = segment(k);
            let loaded = if k == element { xi * length } else { length };
            let centre = [
                start[0] + loaded / 2.0 * axis[0],
                start[1] + loaded / 2.0 * axis[1],
            ];
            add(centre, [q[0] * loaded, q[1] * loaded], 0.0);
        }
        // The far side acts on this part with (−force, −moment) at the cut:
        // N ex − V ey and the couple M.
        InternalForces {
            axial_n: -dot(force, ex),
            shear_n: dot(force, ey),
            moment_nm: -moment,
        }
    }

    proptest! {
        #[test]
        fn random_free_body_balances_and_matches_section_cuts(body in free_body()) {
            let n = body.segments.len();
            let mut positions = vec![[0.7, -0.4]];
            let mut heading = body.heading_rad;
            for &(length, kink) in &body.segments {
                heading += kink;
                let last = *positions.last().unwrap();
                positions.push([last[0] + length * heading.cos(), last[1] + length * heading.sin()]);
            }
            let sections: Vec<SectionProperties> = (0..n)
                .map(|i| body.root.linear_blend(&body.tip, (i as f64 + 0.5) / n as f64).properties())
                .collect();
            let lengths: Vec<f64> = body.segments.iter().map(|s| s.0).collect();
            let element_loads: Vec<[f64; 2]> = (0..n)
                .map(|i| {
                    let mass = STEEL_KG_M3 * sections[i].area_m2;
                    [body.distributed[i][0] + mass * body.acceleration_m_s2[0], body.distributed[i][1] + mass * body.acceleration_m_s2[1]]
                })
                .collect();

            // Balance the random loads with a force across the pin-to-roller line
            // at the roller end and a force at the pin end, like pin forces do.
            let mut nodal = body.nodal.clone();
            let origin = positions[0];
            let mut total = [0.0; 2];
            let mut moment = 0.0;
            let mut add = |point: [f64; 2], f: [f64; 2], m: f64| {
                total[0] += f[0];
                total[1] += f[1];
                moment += cross([point[0] - origin[0], point[1] - origin[1]], f) + m;
            };
            for (p, load) in positions.iter().zip(&nodal) {
                add(*p, [load[0], load[1]], load[2]);
            }
            for i in 0..n {
                let centre = [(positions[i][0] + positions[i + 1][0]) / 2.0, (positions[i][1] + positions[i + 1][1]) / 2.0];
                add(centre, [element_loads[i][0] * lengths[i], element_loads[i][1] * lengths[i]], 0.0);
            }
            let span = [positions[n][0] - origin[0], positions[n][1] - origin[1]];
            let alpha = -moment / dot(span, span);
            let at_end = [-alpha * span[1], alpha * span[0]];
            nodal[n][0] += at_end[0];
            nodal[n][1] += at_end[1];
            nodal[0][0] -= total[0] + at_end[0];
            nodal[0][1] -= total[1] + at_end[1];

            let mut frame = PlaneFrameBuilder::new(E_PA);
            frame.density(STEEL_KG_M3);
            let nodes: Vec<NodeId> = positions.iter().map(|&p| frame.node(p)).collect();
            let elements: Vec<ElementId> =
                (0..n).map(|i| frame.element(nodes[i], nodes[i + 1], sections[i])).collect();
            frame.pin_support(nodes[0]);
            let roller_angle = span[1].atan2(span[0]) + body.roller_angle_rad;
            frame.roller_support(nodes[n], [roller_angle.cos(), roller_angle.sin()]);
            let model = frame.build().unwrap();
            let loads = PlaneFrameLoads {
                nodal: nodes.iter().zip(&nodal).map(|(&node, &load)| (node, load)).collect(),
                distributed: elements.iter().zip(&body.distributed).map(|(&e, &q)| (e, q)).collect(),
                body_acceleration_m_s2: body.acceleration_m_s2,
            };
            let solution = model.solve(&loads);

            let extent = bounding_box_diagonal_m(&positions);
            let force_scale: f64 = nodal.iter().map(|l| l[0].hypot(l[1])).sum::<f64>()
                + element_loads.iter().zip(&lengths).map(|(q, l)| q[0].hypot(q[1]) * l).sum::<f64>();
            let moment_scale = force_scale * extent + nodal.iter().map(|l| l[2].abs()).sum::<f64>();

            let reactions: Vec<[f64; 3]> = nodes.iter().map(|&node| solution.reaction(node)).collect();
            for (node, reaction) in nodes.iter().zip(&reactions) {
                for (k, &value) in reaction.iter().enumerate() {
                    let scale = if k == 2 { moment_scale } else { force_scale };
                    prop_assert!(value.abs() <= RELATIVE_TOLERANCE * scale, "reaction {k} at {node}: {value:e} vs scale {scale:e}");
                }
            }

            let mut stations: Vec<(usize, f64)> = (0..n).flat_map(|e| [(e, 0.0), (e, 1.0)]).collect();
            stations.push(body.cut);
            for (element, xi) in stations {
                let got = solution.internal_forces(elements[element], xi);
                let want = chain_cut(&positions, &element_loads, &nodal, &reactions, element, xi);
                for (name, g, w, scale) in [
                    ("axial", got.axial_n, want.axial_n, force_scale),
                    ("shear", got.shear_n, want.shear_n, force_scale),
                    ("moment", got.moment_nm, want.moment_nm, moment_scale),
                ] {
                    prop_assert!(
                        (g - w).abs() <= RELATIVE_TOLERANCE * scale,
                        "{name} at element {element} xi {xi}: got {g:e}, cut gives {w:e} (scale {scale:e})"
                    );
                }
            }
        }
    }
}
