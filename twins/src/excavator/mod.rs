//! The excavator front-attachment twin: a DX55-class boom, arm and bucket
//! with their linkage and cylinders.
//!
//! One evaluation: strokes -> pose ([`kinematics`]) -> every joint force
//! ([`statics`]) -> loaded-chamber pressures, and the boom and arm frame
//! models ([`structure`]) -> stresses at the strain gauges and the largest
//! von Mises stress. The geometry comes from a file ([`geometry`]); test
//! cases and their uncertain inputs from case files ([`case`]); the inputs
//! themselves and the twin's errors are in [`inputs`], which every other
//! module uses and which uses none of them.

pub mod case;
pub mod envelope;
pub mod geometry;
pub mod geometry_file;
pub mod inclinations;
pub mod inputs;
pub mod kinematics;
pub mod pose_fit;
pub mod statics;
pub mod structure;

use geometry::{Cylinder, Geometry, Member};
pub use inputs::{CylinderName, Inputs, Strokes, TwinError};
use kinematics::{vec2, Pose, Vec2};
use nalgebra::Rotation2;
use statics::{Body, FactoredStatics, Pin, PointLoad, Reactions};
use structure::{BodyStresses, FlexibleBody, GaugeReading};

/// Which chamber carries the load.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Chamber {
    /// Piston side: the cylinder pushes.
    Head,
    /// Annulus side: the cylinder pulls.
    Rod,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CylinderResult {
    /// Oil force along the axis, kN; positive pushes.
    pub axial_force_kn: f64,
    pub loaded_chamber: Chamber,
    /// The pressure that alone balances the axial force, bar.
    pub loaded_chamber_pressure_bar: f64,
    /// How far that pressure is above the relief pressure, bar (0 below
    /// it); `None` when the geometry gives no relief pressure.
    pub over_relief_bar: Option<f64>,
    pub length_m: f64,
}

/// Everything one evaluation gives.
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluation {
    pub pose: Pose,
    pub reactions: Reactions,
    /// In [`CylinderName::ALL`] order.
    pub cylinders: [CylinderResult; 3],
    /// Every gauge of boom and arm, by measuring point.
    pub gauges: Vec<GaugeReading>,
    pub boom: BodyStresses,
    pub arm: BodyStresses,
}

impl Evaluation {
    pub fn cylinder(&self, name: CylinderName) -> &CylinderResult {
        &self.cylinders[name.index()]
    }
}

/// What the rig's transducers see ([`Excavator::measurable_at`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Measurables {
    pub pose: Pose,
    /// In [`CylinderName::ALL`] order.
    pub cylinders: [CylinderResult; 3],
    /// Every gauge of boom and arm, by measuring point.
    pub gauges: Vec<GaugeReading>,
}

fn dead_centre() -> TwinError {
    TwinError::InvalidInput("the statics are singular at this pose (a dead centre)".into())
}

/// The boom's pins in frame-model order: A (pin support) first, B (roller).
const BOOM_PINS: [Pin; 4] = [Pin::A, Pin::B, Pin::D, Pin::E];
/// The arm's: B (pin support) first, G (roller).
const ARM_PINS: [Pin; 5] = [Pin::B, Pin::G, Pin::F, Pin::H, Pin::I];

/// A pose with its statics factored ([`Excavator::prepare`]).
#[derive(Debug, Clone)]
pub struct PreparedPose {
    strokes: Strokes,
    pub pose: Pose,
    statics: FactoredStatics,
}

impl PreparedPose {
    pub fn strokes(&self) -> Strokes {
        self.strokes
    }
}

/// A built twin: geometry plus factored boom and arm frame models.
#[derive(Debug)]
pub struct Excavator {
    geometry: Geometry,
    boom: FlexibleBody,
    arm: FlexibleBody,
}

impl Excavator {
    pub fn new(geometry: Geometry) -> Result<Excavator, TwinError> {
        let e = geometry.youngs_modulus_pa();
        let rho = geometry.material.density_kg_m3;
        let gauges_on = |member: Member| {
            geometry
                .gauges
                .iter()
                .filter(|g| g.member == member)
                .collect::<Vec<_>>()
        };
        let build = |name: &str, structure, pins: &[[f64; 2]], member| {
            FlexibleBody::build(structure, pins, 1, &gauges_on(member), e, rho)
                .map_err(|m| TwinError::Geometry(format!("{name}: {m}")))
        };
        // Pin support first, roller second (index 1): A and B, then B and G.
        let boom = build(
            "boom",
            &geometry.boom.structure,
            &[
                [0.0, 0.0],
                geometry.boom.arm_pin_m,
                geometry.boom.boom_cylinder_pin_m,
                geometry.boom.arm_cylinder_pin_m,
            ],
            Member::Boom,
        )?;
        let arm = build(
            "arm",
            &geometry.arm.structure,
            &[
                [0.0, 0.0],
                geometry.arm.bucket_pin_m,
                geometry.arm.arm_cylinder_pin_m,
                geometry.arm.bucket_cylinder_pin_m,
                geometry.arm.side_link_pin_m,
            ],
            Member::Arm,
        )?;
        Ok(Excavator {
            geometry,
            boom,
            arm,
        })
    }

    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    /// The twin with the mass numbers in `values` changed (by key path, as
    /// [`Geometry::set_mass_number`] takes them), built in microseconds:
    /// the boom's and arm's factored frames are shared, since a mass sets
    /// loads, not stiffness. An error names a path that is not a mass
    /// number, or a value the geometry cannot hold.
    pub fn with_masses(&self, values: &[(&str, f64)]) -> Result<Excavator, TwinError> {
        let mut geometry = self.geometry.clone();
        for &(path, value) in values {
            geometry
                .set_mass_number(path, value)
                .ok_or_else(|| {
                    TwinError::Geometry(format!(
                        "{path} is not a mass number: build the twin anew to change it"
                    ))
                })?
                .map_err(TwinError::Geometry)?;
        }
        let reweigh = |body: &FlexibleBody, structure: &geometry::Structure, name: &str| {
            body.reweighed(&structure.attached_mass)
                .ok_or_else(|| TwinError::Geometry(format!("{name}: its attached masses moved")))
        };
        Ok(Excavator {
            boom: reweigh(&self.boom, &geometry.boom.structure, "boom")?,
            arm: reweigh(&self.arm, &geometry.arm.structure, "arm")?,
            geometry,
        })
    }

    /// Mass of the boom and the arm as their frame models carry it, kg.
    pub fn structure_masses_kg(&self) -> (f64, f64) {
        (self.boom.mass_kg(), self.arm.mass_kg())
    }

    /// Gravity and the tip load as point loads on the bodies, for a pose.
    pub fn loads(&self, pose: &Pose, inputs: &Inputs) -> Vec<PointLoad> {
        let g = &self.geometry;
        let weight = |mass_kg: f64| Vec2::new(0.0, -g.material.gravity_m_s2 * mass_kg);
        let on_boom = |local: Vec2| pose.a + Rotation2::new(pose.boom_angle_rad) * local;
        let on_arm = |local: Vec2| pose.b + Rotation2::new(pose.arm_angle_rad) * local;
        let on_bucket = |local: Vec2| pose.g + Rotation2::new(pose.bucket_angle_rad) * local;
        let mut loads = vec![
            PointLoad {
                body: Body::Boom,
                at_m: on_boom(self.boom.centre_of_mass_m()),
                force_n: weight(self.boom.mass_kg()),
            },
            PointLoad {
                body: Body::Arm,
                at_m: on_arm(self.arm.centre_of_mass_m()),
                force_n: weight(self.arm.mass_kg()),
            },
            PointLoad {
                body: Body::Bucket,
                at_m: on_bucket(vec2(g.bucket.centre_of_mass_m)),
                force_n: weight(g.bucket.mass_kg),
            },
            PointLoad {
                body: Body::Bucket,
                at_m: pose.j,
                force_n: inputs.tip_force_n(),
            },
            PointLoad {
                body: Body::SideLink,
                at_m: (pose.i + pose.k) * 0.5,
                force_n: weight(g.side_link.mass_kg),
            },
            PointLoad {
                body: Body::ConnectingLink,
                at_m: (pose.k + pose.l) * 0.5,
                force_n: weight(g.connecting_link.mass_kg),
            },
        ];
        for name in CylinderName::ALL {
            let cylinder = self.cylinder(name);
            let (barrel_pin, rod_pin) = pose.cylinder_pins(name);
            let axis = (rod_pin - barrel_pin).normalize();
            loads.push(PointLoad {
                body: Body::Barrel(name),
                at_m: barrel_pin + axis * cylinder.barrel_centre_from_pin_m,
                force_n: weight(cylinder.barrel_mass_kg),
            });
            loads.push(PointLoad {
                body: Body::Rod(name),
                at_m: rod_pin - axis * cylinder.rod_centre_from_pin_m,
                force_n: weight(cylinder.rod_mass_kg),
            });
        }
        loads
    }

    fn cylinder(&self, name: CylinderName) -> &Cylinder {
        self.geometry.cylinder(name)
    }

    /// Pose only (cheap): for pose checks and sweeps.
    pub fn pose(&self, strokes: &Strokes) -> Result<Pose, TwinError> {
        Pose::solve(&self.geometry, strokes)
    }

    /// One full evaluation.
    pub fn evaluate(&self, inputs: &Inputs) -> Result<Evaluation, TwinError> {
        inputs.check()?;
        self.evaluate_at(&self.prepare(&inputs.strokes)?, inputs)
    }

    /// The pose of `strokes` with its statics factored: what every
    /// evaluation at those strokes shares, whatever the loads and masses
    /// (it depends on the linkage alone, so a twin re-weighed with
    /// [`Excavator::with_masses`] can use it too).
    pub fn prepare(&self, strokes: &Strokes) -> Result<PreparedPose, TwinError> {
        let pose = Pose::solve(&self.geometry, strokes)?;
        Ok(PreparedPose {
            strokes: *strokes,
            statics: FactoredStatics::at(&pose),
            pose,
        })
    }

    /// [`Excavator::evaluate`] at a prepared pose; `inputs.strokes` must
    /// be the pose's.
    pub fn evaluate_at(
        &self,
        prepared: &PreparedPose,
        inputs: &Inputs,
    ) -> Result<Evaluation, TwinError> {
        let (reactions, cylinders) = self.statics_at(prepared, inputs)?;
        let [boom_pins, arm_pins, gravity] = self.pin_forces(&prepared.pose, &reactions);
        let boom = self.boom.stresses(&boom_pins, gravity[0]);
        let arm = self.arm.stresses(&arm_pins, gravity[1]);
        let mut gauges: Vec<GaugeReading> =
            boom.gauges.iter().chain(&arm.gauges).copied().collect();
        gauges.sort_by_key(|g| g.point);
        Ok(Evaluation {
            pose: prepared.pose,
            reactions,
            cylinders,
            gauges,
            boom,
            arm,
        })
    }

    /// What the rig's transducers see at a prepared pose (the cylinders
    /// and the gauges), without the von Mises scan and the support check:
    /// the same numbers as [`Excavator::evaluate_at`] to rounding, in a
    /// fraction of its time (a study at the rig runs it per hold and step).
    pub fn measurable_at(
        &self,
        prepared: &PreparedPose,
        inputs: &Inputs,
    ) -> Result<Measurables, TwinError> {
        let (reactions, cylinders) = self.statics_at(prepared, inputs)?;
        let [boom_pins, arm_pins, gravity] = self.pin_forces(&prepared.pose, &reactions);
        let mut gauges = self.boom.gauge_readings(&boom_pins, gravity[0]);
        gauges.extend(self.arm.gauge_readings(&arm_pins, gravity[1]));
        gauges.sort_by_key(|g| g.point);
        Ok(Measurables {
            pose: prepared.pose,
            cylinders,
            gauges,
        })
    }

    /// Every joint force at a prepared pose, and the cylinders' from them.
    fn statics_at(
        &self,
        prepared: &PreparedPose,
        inputs: &Inputs,
    ) -> Result<(Reactions, [CylinderResult; 3]), TwinError> {
        inputs.check()?;
        if prepared.strokes != inputs.strokes {
            return Err(TwinError::InvalidInput(format!(
                "the pose was prepared for strokes {:?}, not {:?}",
                prepared.strokes, inputs.strokes
            )));
        }
        let pose = prepared.pose;
        let loads = self.loads(&pose, inputs);
        let reactions = prepared.statics.solve(&loads).ok_or_else(dead_centre)?;

        let cylinders = CylinderName::ALL.map(|name| {
            let cylinder = self.cylinder(name);
            let joint = reactions.cylinder(name);
            let (barrel_pin, rod_pin) = pose.cylinder_pins(name);
            let (loaded_chamber, area_m2) = if joint.axial_force_n >= 0.0 {
                (Chamber::Head, cylinder.head_area_m2())
            } else {
                (Chamber::Rod, cylinder.annulus_area_m2())
            };
            let pressure_bar = joint.axial_force_n.abs() / area_m2 * 1e-5;
            CylinderResult {
                axial_force_kn: joint.axial_force_n * 1e-3,
                loaded_chamber,
                loaded_chamber_pressure_bar: pressure_bar,
                over_relief_bar: self
                    .geometry
                    .relief_pressure_bar
                    .map(|relief| (pressure_bar - relief).max(0.0)),
                length_m: (rod_pin - barrel_pin).norm(),
            }
        });
        Ok((reactions, cylinders))
    }

    /// The force each flexible body receives at each of its pins, and
    /// gravity, in the boom's and the arm's own frames: `[boom's pin
    /// forces, arm's pin forces, [gravity on the boom, on the arm]]`.
    fn pin_forces(&self, pose: &Pose, reactions: &Reactions) -> [Vec<Vec2>; 3] {
        let gravity = Vec2::new(0.0, -self.geometry.material.gravity_m_s2);
        let into_frame = |angle_rad: f64, v: Vec2| Rotation2::new(-angle_rad) * v;
        let on_body = |body: Body, pins: &[Pin], angle_rad: f64| -> Vec<Vec2> {
            pins.iter()
                .map(|&pin| {
                    let hinge = statics::HINGES
                        .iter()
                        .find(|h| h.pin == pin)
                        .expect("pin is a hinge");
                    let force = reactions.hinge(pin);
                    let force = if hinge.on == body { force } else { -force };
                    into_frame(angle_rad, force)
                })
                .collect()
        };
        [
            on_body(Body::Boom, &BOOM_PINS, pose.boom_angle_rad),
            on_body(Body::Arm, &ARM_PINS, pose.arm_angle_rad),
            vec![
                into_frame(pose.boom_angle_rad, gravity),
                into_frame(pose.arm_angle_rad, gravity),
            ],
        ]
    }
}

impl Geometry {
    pub fn cylinder(&self, name: CylinderName) -> &Cylinder {
        match name {
            CylinderName::Bucket => &self.cylinder.bucket,
            CylinderName::Arm => &self.cylinder.arm,
            CylinderName::Boom => &self.cylinder.boom,
        }
    }

    pub fn cylinder_mut(&mut self, name: CylinderName) -> &mut Cylinder {
        match name {
            CylinderName::Bucket => &mut self.cylinder.bucket,
            CylinderName::Arm => &mut self.cylinder.arm,
            CylinderName::Boom => &mut self.cylinder.boom,
        }
    }
}
