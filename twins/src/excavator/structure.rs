//! Boom and arm as box-section frame models: meshing the centreline, the
//! loads from the statics, and stresses at gauges and the von Mises maximum.
//!
//! Each body is a free body in equilibrium; the frame model is held by a pin
//! at its first pin and a roller at its last only to remove rigid motion, so
//! the support reactions are ~0 and the internal forces are those of statics.
//! Pins off the centreline (cylinder lugs) hang on massless bracket elements
//! from the nearest centreline point. The stiffness is factored once when
//! the body is built; an evaluation is one back-substitution. Where only
//! the gauges are wanted (a study at the rig), it is less: the frame is
//! linear, so each gauge's section forces are the sum of its responses to
//! unit loads at the few loaded nodes, solved once per body
//! ([`FlexibleBody::gauge_readings`]).

use std::sync::{Arc, OnceLock};

use crate::plane_frame::{
    BoxSection, ElementId, NodeId, PlaneFrameBuilder, PlaneFrameLoads, PlaneFrameModel,
    PlaneFrameSolution,
};

use super::geometry::{Face, Gauge, PointM, PointMass, Structure};
use super::kinematics::{cross, vec2, Vec2};

/// Two stations closer than this are one node, m: a gauge written to the
/// millimetre at a knee must not make a sliver element.
const SAME_STATION_M: f64 = 1e-4;

#[derive(Debug, Clone, Copy)]
struct BoxElement {
    element: ElementId,
    start_station_m: f64,
    end_station_m: f64,
    /// Sections at the von Mises check points `VON_MISES_XI`, blended once at build.
    check_sections: [BoxSection; 3],
}

/// Where along each element the von Mises stress is checked.
const VON_MISES_XI: [f64; 3] = [0.0, 0.5, 1.0];

#[derive(Debug, Clone, Copy)]
struct GaugeProbe {
    point: u32,
    element: ElementId,
    xi: f64,
    section: BoxSection,
    /// Signed distance from the section centre toward the element's local +y, m.
    fibre_m: f64,
}

/// A flexible body ready to evaluate.
#[derive(Debug, Clone)]
pub struct FlexibleBody {
    /// Shared by the bodies re-weighed from this one: the stiffness does
    /// not depend on the attached masses.
    model: Arc<PlaneFrameModel>,
    box_elements: Vec<BoxElement>,
    pin_nodes: Vec<NodeId>,
    /// Attached masses as (node, offset from node, kg), and where each is
    /// in the body frame.
    attached: Vec<(NodeId, Vec2, f64)>,
    attached_at_m: Vec<PointM>,
    gauges: Vec<GaugeProbe>,
    /// The gauges' responses to unit loads, made at the first
    /// [`FlexibleBody::gauge_readings`] and shared by the re-weighed
    /// bodies (same frame, same loaded nodes).
    gauge_influence: Arc<OnceLock<GaugeInfluence>>,
    /// The plates' own mass and first moment, kg and kg m.
    plates_mass_kg: f64,
    plates_first_moment_kg_m: Vec2,
    mass_kg: f64,
    centre_of_mass_m: Vec2,
}

/// What the section at one gauge carries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaugeReading {
    /// Measuring point number.
    pub point: u32,
    /// Axial force, kN; tension positive.
    pub axial_force_kn: f64,
    /// Bending moment, kN m; positive compresses the body's +y (top) side.
    pub bending_moment_knm: f64,
    /// Stress along the member at the gauge, MPa; tension positive.
    pub stress_mpa: f64,
}

/// Stresses of one load case, MPa.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyStresses {
    pub gauges: Vec<GaugeReading>,
    pub max_von_mises_mpa: f64,
    /// Largest support reaction relative to the largest pin force: ~0 when
    /// the loads balance (a check on the statics).
    pub support_reaction_ratio: f64,
}

impl FlexibleBody {
    /// Meshes `structure`. `pins` are body-frame points: those on the
    /// centreline become its nodes, the others hang on brackets. The first
    /// pin gets the pin support, `roller_pin` the roller.
    pub fn build(
        structure: &Structure,
        pins: &[PointM],
        roller_pin: usize,
        gauges: &[&Gauge],
        youngs_modulus_pa: f64,
        density_kg_m3: f64,
    ) -> Result<FlexibleBody, String> {
        let centreline = Centreline::of(structure);
        let projections: Vec<(f64, Vec2)> =
            pins.iter().map(|&p| centreline.project(vec2(p))).collect();
        let stations_m = mesh_stations_m(structure, &centreline, &projections, gauges);

        let mut builder = PlaneFrameBuilder::new(youngs_modulus_pa);
        builder.density(density_kg_m3);
        let centreline_nodes: Vec<(f64, NodeId)> = stations_m
            .iter()
            .map(|&s| {
                let p = centreline.point_at(s);
                (s, builder.node([p.x, p.y]))
            })
            .collect();
        let box_elements = box_elements(&mut builder, structure, &centreline_nodes);
        let pin_nodes = pin_nodes(
            &mut builder,
            structure,
            pins,
            &projections,
            &centreline_nodes,
        );
        builder.pin_support(pin_nodes[0]);
        let span = vec2(pins[roller_pin]) - vec2(pins[0]);
        builder.roller_support(pin_nodes[roller_pin], [-span.y, span.x]);

        let node_positions: Vec<(NodeId, Vec2)> = centreline_nodes
            .iter()
            .map(|&(s, n)| (n, centreline.point_at(s)))
            .chain(pin_nodes.iter().zip(pins).map(|(&n, &p)| (n, vec2(p))))
            .collect();
        let attached = attached_masses(structure, &node_positions);
        let (plates_mass_kg, plates_first_moment_kg_m) =
            plates_mass_and_first_moment(structure, &centreline, &box_elements, density_kg_m3);
        let probes = gauge_probes(structure, gauges, &box_elements);

        let model = builder.build().map_err(|e| format!("frame model: {e}"))?;
        let mut body = FlexibleBody {
            model: Arc::new(model),
            box_elements,
            pin_nodes,
            attached,
            attached_at_m: structure.attached_mass.iter().map(|m| m.at_m).collect(),
            gauges: probes,
            gauge_influence: Arc::default(),
            plates_mass_kg,
            plates_first_moment_kg_m,
            mass_kg: 0.0,
            centre_of_mass_m: Vec2::zeros(),
        };
        body.weigh();
        Ok(body)
    }

    /// The body with the attached masses' values of `attached` (the same
    /// masses at the same places, other weights), its factored frame
    /// shared: a back-substitution's loads change, the stiffness does not.
    /// `None` when a mass was added, removed or moved: build the body anew.
    pub fn reweighed(&self, attached: &[PointMass]) -> Option<FlexibleBody> {
        if attached.len() != self.attached_at_m.len()
            || attached
                .iter()
                .zip(&self.attached_at_m)
                .any(|(mass, at)| mass.at_m != *at)
        {
            return None;
        }
        let mut body = self.clone();
        for (slot, mass) in body.attached.iter_mut().zip(attached) {
            slot.2 = mass.mass_kg;
        }
        body.weigh();
        Some(body)
    }

    /// The total mass and centre of mass from the plates' and the attached
    /// masses'.
    fn weigh(&mut self) {
        let mut mass_kg = self.plates_mass_kg;
        let mut first_moment = self.plates_first_moment_kg_m;
        for (&(_, _, kg), at) in self.attached.iter().zip(&self.attached_at_m) {
            mass_kg += kg;
            first_moment += vec2(*at) * kg;
        }
        self.mass_kg = mass_kg;
        self.centre_of_mass_m = first_moment / mass_kg;
    }

    pub fn mass_kg(&self) -> f64 {
        self.mass_kg
    }

    /// Centre of mass in the body frame, m.
    pub fn centre_of_mass_m(&self) -> Vec2 {
        self.centre_of_mass_m
    }

    /// Solves the frame for pin forces (N, body frame, in `pins` order) and
    /// gravity (m/s^2, body frame).
    pub fn solve(&self, pin_forces_n: &[Vec2], gravity_m_s2: Vec2) -> PlaneFrameSolution {
        let mut loads = PlaneFrameLoads {
            nodal: Vec::with_capacity(pin_forces_n.len() + self.attached.len()),
            body_acceleration_m_s2: [gravity_m_s2.x, gravity_m_s2.y],
            distributed: Vec::new(),
        };
        for (&node, force) in self.pin_nodes.iter().zip(pin_forces_n) {
            loads.nodal.push((node, [force.x, force.y, 0.0]));
        }
        for &(node, offset, mass_kg) in &self.attached {
            let weight = gravity_m_s2 * mass_kg;
            loads
                .nodal
                .push((node, [weight.x, weight.y, cross(&offset, &weight)]));
        }
        self.model.solve(&loads)
    }

    /// Gauge stresses, von Mises maximum and the support check for one load case.
    pub fn stresses(&self, pin_forces_n: &[Vec2], gravity_m_s2: Vec2) -> BodyStresses {
        let solution = self.solve(pin_forces_n, gravity_m_s2);
        let gauges = self
            .gauges
            .iter()
            .map(|probe| {
                let forces = solution.internal_forces(probe.element, probe.xi);
                probe.reading(forces.axial_n, forces.moment_nm)
            })
            .collect();
        let mut max_von_mises_pa: f64 = 0.0;
        for element in &self.box_elements {
            for (xi, section) in VON_MISES_XI.into_iter().zip(&element.check_sections) {
                let forces = solution.internal_forces(element.element, xi);
                max_von_mises_pa = max_von_mises_pa.max(section_von_mises_pa(
                    section,
                    forces.axial_n,
                    forces.shear_n,
                    forces.moment_nm,
                ));
            }
        }
        let largest_pin_force = pin_forces_n.iter().map(|f| f.norm()).fold(0.0, f64::max);
        let largest_reaction = self
            .pin_nodes
            .iter()
            .map(|&n| {
                let r = solution.reaction(n);
                r[0].hypot(r[1])
            })
            .fold(0.0, f64::max);
        BodyStresses {
            gauges,
            max_von_mises_mpa: max_von_mises_pa * 1e-6,
            support_reaction_ratio: largest_reaction / largest_pin_force.max(f64::MIN_POSITIVE),
        }
    }
}

impl FlexibleBody {
    /// The gauges alone, for pin forces (N, body frame, in `pins` order)
    /// and gravity (m/s^2, body frame): what [`FlexibleBody::stresses`]
    /// gives in `gauges`, equal to rounding, by superposing the responses
    /// to unit loads instead of a back-substitution and a scan of every
    /// element (a few hundred multiplications instead of some 10^5).
    pub fn gauge_readings(&self, pin_forces_n: &[Vec2], gravity_m_s2: Vec2) -> Vec<GaugeReading> {
        let influence = self
            .gauge_influence
            .get_or_init(|| GaugeInfluence::solve(self));
        let gauge_count = self.gauges.len();
        // Each gauge's [axial N, moment N m].
        let mut section = vec![[0.0; 2]; gauge_count];
        let mut add = |responses: &[[f64; 2]], amount: f64| {
            for (sum, response) in section.iter_mut().zip(responses) {
                sum[0] += response[0] * amount;
                sum[1] += response[1] * amount;
            }
        };
        for (axis, acceleration) in [gravity_m_s2.x, gravity_m_s2.y].into_iter().enumerate() {
            add(influence.per_acceleration(axis, gauge_count), acceleration);
        }
        for (slot, force) in influence.pin_slots.iter().zip(pin_forces_n) {
            for (component, amount) in [force.x, force.y].into_iter().enumerate() {
                add(
                    influence.per_unit_load(*slot, component, gauge_count),
                    amount,
                );
            }
        }
        for (slot, &(_, offset, mass_kg)) in influence.attached_slots.iter().zip(&self.attached) {
            let weight = gravity_m_s2 * mass_kg;
            let load = [weight.x, weight.y, cross(&offset, &weight)];
            for (component, amount) in load.into_iter().enumerate() {
                add(
                    influence.per_unit_load(*slot, component, gauge_count),
                    amount,
                );
            }
        }
        self.gauges
            .iter()
            .zip(section)
            .map(|(probe, [axial_n, moment_nm])| probe.reading(axial_n, moment_nm))
            .collect()
    }
}

impl GaugeProbe {
    /// The gauge's reading from its section's axial force and moment.
    fn reading(&self, axial_n: f64, moment_nm: f64) -> GaugeReading {
        let stress_pa = axial_n / self.section.area_m2()
            - moment_nm * self.fibre_m / self.section.second_moment_m4();
        GaugeReading {
            point: self.point,
            axial_force_kn: axial_n * 1e-3,
            bending_moment_knm: moment_nm * 1e-3,
            stress_mpa: stress_pa * 1e-6,
        }
    }
}

/// Each gauge's section forces `[axial N, moment N m]` per unit load at
/// every node a load reaches (the pins and the attached masses' nodes: a
/// newton along x and y, a newton metre) and per unit body acceleration
/// (m/s^2 along x and y, the plates' own weight). Solved with the body's
/// own frame, one back-substitution per unit load.
#[derive(Debug)]
struct GaugeInfluence {
    /// `responses[(slot * 3 + component) * gauges + gauge]`, slots first,
    /// then the two accelerations at slot `nodes.len()`.
    responses: Vec<[f64; 2]>,
    /// The slot of each pin and of each attached mass.
    pin_slots: Vec<usize>,
    attached_slots: Vec<usize>,
}

impl GaugeInfluence {
    fn solve(body: &FlexibleBody) -> GaugeInfluence {
        let mut nodes: Vec<NodeId> = Vec::new();
        let mut slot_of = |node: NodeId| match nodes.iter().position(|&n| n == node) {
            Some(slot) => slot,
            None => {
                nodes.push(node);
                nodes.len() - 1
            }
        };
        let pin_slots: Vec<usize> = body.pin_nodes.iter().map(|&n| slot_of(n)).collect();
        let attached_slots: Vec<usize> = body.attached.iter().map(|a| slot_of(a.0)).collect();
        let section_forces = |loads: &PlaneFrameLoads| {
            let solution = body.model.solve(loads);
            body.gauges.iter().map(move |probe| {
                let forces = solution.internal_forces(probe.element, probe.xi);
                [forces.axial_n, forces.moment_nm]
            })
        };
        let mut responses = Vec::with_capacity((nodes.len() * 3 + 2) * body.gauges.len());
        for &node in &nodes {
            for component in 0..3 {
                let mut unit = [0.0; 3];
                unit[component] = 1.0;
                responses.extend(section_forces(&PlaneFrameLoads {
                    nodal: vec![(node, unit)],
                    ..PlaneFrameLoads::default()
                }));
            }
        }
        for axis in 0..2 {
            let mut unit = [0.0; 2];
            unit[axis] = 1.0;
            responses.extend(section_forces(&PlaneFrameLoads {
                body_acceleration_m_s2: unit,
                ..PlaneFrameLoads::default()
            }));
        }
        GaugeInfluence {
            responses,
            pin_slots,
            attached_slots,
        }
    }

    fn per_unit_load(&self, slot: usize, component: usize, gauges: usize) -> &[[f64; 2]] {
        let start = (slot * 3 + component) * gauges;
        &self.responses[start..start + gauges]
    }

    /// Per unit acceleration along `axis`: stored after every slot's three.
    fn per_acceleration(&self, axis: usize, gauges: usize) -> &[[f64; 2]] {
        let start = self.responses.len() - (2 - axis) * gauges;
        &self.responses[start..start + gauges]
    }
}

/// Largest von Mises stress on a box section: the flanges' outer fibres
/// (bending + axial, no shear at a free surface) and the webs at the neutral
/// axis (axial + the largest shear).
pub fn section_von_mises_pa(
    section: &BoxSection,
    axial_n: f64,
    shear_n: f64,
    moment_nm: f64,
) -> f64 {
    let axial_pa = axial_n / section.area_m2();
    let bending_pa = moment_nm.abs() * 0.5 * section.height_m / section.second_moment_m4();
    let shear_pa = section.shear_stress_at_neutral_axis_pa(shear_n);
    let fibres = axial_pa.abs() + bending_pa;
    let neutral_axis = (axial_pa * axial_pa + 3.0 * shear_pa * shear_pa).sqrt();
    fibres.max(neutral_axis)
}

/// A body's centreline: the polyline and its vertices' arc-length stations, m.
struct Centreline {
    vertices: Vec<Vec2>,
    vertex_stations_m: Vec<f64>,
}

impl Centreline {
    /// The centreline of `structure`, its stations measured from the first vertex.
    fn of(structure: &Structure) -> Centreline {
        let vertices: Vec<Vec2> = structure.centreline_m.iter().map(|&p| vec2(p)).collect();
        let vertex_stations_m = cumulative_lengths(&vertices);
        Centreline {
            vertices,
            vertex_stations_m,
        }
    }

    /// The point at an arc-length station.
    fn point_at(&self, station_m: f64) -> Vec2 {
        point_at(&self.vertices, &self.vertex_stations_m, station_m)
    }

    /// Closest point to `p`: (station, foot).
    fn project(&self, p: Vec2) -> (f64, Vec2) {
        project(&self.vertices, &self.vertex_stations_m, p)
    }
}

/// The stations of the centreline's nodes, m: the vertices, the pins' feet
/// and the gauges, each interval cut into elements no longer than the
/// structure's element length. Vertices keep their exact stations; other
/// stations near one snap to it.
fn mesh_stations_m(
    structure: &Structure,
    centreline: &Centreline,
    projections: &[(f64, Vec2)],
    gauges: &[&Gauge],
) -> Vec<f64> {
    let vertex_stations = &centreline.vertex_stations_m;
    let mut stations: Vec<f64> = vertex_stations.clone();
    let extra = projections
        .iter()
        .map(|&(s, _)| s)
        .chain(gauges.iter().map(|g| g.station_m));
    stations.extend(extra.filter(|s| {
        vertex_stations
            .iter()
            .all(|v| (v - s).abs() >= SAME_STATION_M)
    }));
    stations.sort_by(f64::total_cmp);
    stations.dedup_by(|b, a| (*b - *a).abs() < SAME_STATION_M);
    let mut refined = vec![stations[0]];
    for pair in stations.windows(2) {
        let parts = ((pair[1] - pair[0]) / structure.element_length_m)
            .ceil()
            .max(1.0) as usize;
        for k in 1..=parts {
            refined.push(pair[0] + (pair[1] - pair[0]) * k as f64 / parts as f64);
        }
    }
    refined
}

/// The centreline node at `station_m` (the first not before it, or the last).
fn centreline_node_at(centreline_nodes: &[(f64, NodeId)], station_m: f64) -> NodeId {
    let k = centreline_nodes.partition_point(|&(s, _)| s < station_m - SAME_STATION_M);
    centreline_nodes[k.min(centreline_nodes.len() - 1)].1
}

/// One box-section element between each pair of consecutive centreline
/// nodes, its section taken at its middle and at the von Mises check points.
fn box_elements(
    builder: &mut PlaneFrameBuilder,
    structure: &Structure,
    centreline_nodes: &[(f64, NodeId)],
) -> Vec<BoxElement> {
    let mut box_elements = Vec::new();
    for pair in centreline_nodes.windows(2) {
        let (start, a) = pair[0];
        let (end, b) = pair[1];
        let section = structure.section_at(0.5 * (start + end));
        let element = builder.element(a, b, section.properties());
        let check_sections =
            VON_MISES_XI.map(|xi| structure.section_at(start + xi * (end - start)));
        box_elements.push(BoxElement {
            element,
            start_station_m: start,
            end_station_m: end,
            check_sections,
        });
    }
    box_elements
}

/// Each pin's node: the centreline node at its foot when it lies on the
/// centreline, else a lug node hung on a massless bracket from there.
fn pin_nodes(
    builder: &mut PlaneFrameBuilder,
    structure: &Structure,
    pins: &[PointM],
    projections: &[(f64, Vec2)],
    centreline_nodes: &[(f64, NodeId)],
) -> Vec<NodeId> {
    let mut pin_nodes = Vec::new();
    for (&pin, &(station, foot)) in pins.iter().zip(projections) {
        let on_line = centreline_node_at(centreline_nodes, station);
        if (vec2(pin) - foot).norm() < 1e-6 {
            pin_nodes.push(on_line);
        } else {
            let lug = builder.node(pin);
            let bracket = builder.element(on_line, lug, structure.section_at(station).properties());
            builder.element_linear_density(bracket, 0.0);
            pin_nodes.push(lug);
        }
    }
    pin_nodes
}

/// Attached masses go to the nearest node with their transfer moment:
/// (node, offset from the node, kg).
fn attached_masses(
    structure: &Structure,
    node_positions: &[(NodeId, Vec2)],
) -> Vec<(NodeId, Vec2, f64)> {
    structure
        .attached_mass
        .iter()
        .map(|mass| {
            let at = vec2(mass.at_m);
            let (node, position) = node_positions
                .iter()
                .min_by(|x, y| (x.1 - at).norm().total_cmp(&(y.1 - at).norm()))
                .expect("nodes exist");
            (*node, at - position, mass.mass_kg)
        })
        .collect()
}

/// The plates' own mass and first moment, kg and kg m, element by element
/// at each element's middle section.
fn plates_mass_and_first_moment(
    structure: &Structure,
    centreline: &Centreline,
    box_elements: &[BoxElement],
    density_kg_m3: f64,
) -> (f64, Vec2) {
    let mut plates_mass_kg = 0.0;
    let mut plates_first_moment_kg_m = Vec2::zeros();
    for element in box_elements {
        let middle = 0.5 * (element.start_station_m + element.end_station_m);
        let section = structure.section_at(middle);
        let m =
            density_kg_m3 * section.area_m2() * (element.end_station_m - element.start_station_m);
        plates_mass_kg += m;
        plates_first_moment_kg_m += centreline.point_at(middle) * m;
    }
    (plates_mass_kg, plates_first_moment_kg_m)
}

/// Each gauge's place in the mesh: its element, where along it, its section
/// and the fibre it reads.
fn gauge_probes(
    structure: &Structure,
    gauges: &[&Gauge],
    box_elements: &[BoxElement],
) -> Vec<GaugeProbe> {
    gauges
        .iter()
        .map(|gauge| {
            let k = box_elements
                .iter()
                .position(|e| gauge.station_m < e.end_station_m - SAME_STATION_M)
                .unwrap_or(box_elements.len() - 1);
            let element = box_elements[k];
            let xi = ((gauge.station_m - element.start_station_m)
                / (element.end_station_m - element.start_station_m))
                .clamp(0.0, 1.0);
            let section = structure.section_at(gauge.station_m);
            let fibre_m = match gauge.face {
                Face::Top => 0.5 * section.height_m,
                Face::Bottom => -0.5 * section.height_m,
                Face::LeftSide | Face::RightSide => gauge.offset_m,
            };
            GaugeProbe {
                point: gauge.point,
                element: element.element,
                xi,
                section,
                fibre_m,
            }
        })
        .collect()
}

fn cumulative_lengths(vertices: &[Vec2]) -> Vec<f64> {
    let mut stations = vec![0.0];
    for pair in vertices.windows(2) {
        stations.push(stations.last().copied().unwrap_or(0.0) + (pair[1] - pair[0]).norm());
    }
    stations
}

/// The point at an arc-length station on the polyline.
fn point_at(vertices: &[Vec2], stations: &[f64], station: f64) -> Vec2 {
    let k = stations
        .partition_point(|&s| s <= station)
        .clamp(1, vertices.len() - 1);
    let t = (station - stations[k - 1]) / (stations[k] - stations[k - 1]);
    vertices[k - 1] + (vertices[k] - vertices[k - 1]) * t.clamp(0.0, 1.0)
}

/// Closest point of the polyline to `p`: (station, foot).
fn project(vertices: &[Vec2], stations: &[f64], p: Vec2) -> (f64, Vec2) {
    let mut best = (f64::INFINITY, 0.0, vertices[0]);
    for (k, pair) in vertices.windows(2).enumerate() {
        let segment = pair[1] - pair[0];
        let t = ((p - pair[0]).dot(&segment) / segment.norm_squared()).clamp(0.0, 1.0);
        let foot = pair[0] + segment * t;
        let distance = (p - foot).norm();
        if distance < best.0 - 1e-12 {
            best = (distance, stations[k] + t * segment.norm(), foot);
        }
    }
    (best.1, best.2)
}
