//! Planar rigid-body statics of the whole attachment as one linear system.
//!
//! Eleven bodies (boom, arm, bucket, side link, connecting link, and each
//! cylinder as a barrel and a rod) give 33 equilibrium equations. Twelve
//! hinges (2 unknowns each) and three prismatic joints (axial force, normal
//! force, couple) give 33 unknowns: the attachment is statically
//! determinate, so one LU solve gives every pin force. The prismatic joint's
//! axial force is the oil's net force on the piston, which is what the
//! chamber pressure balances.

use nalgebra::{Const, SMatrix, SVector, LU};

use super::inputs::CylinderName;
use super::kinematics::{cross, Pose, Vec2};

const BODIES: usize = 11;
const EQUATIONS: usize = 3 * BODIES;

/// A rigid body of the statics model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Body {
    Boom,
    Arm,
    Bucket,
    SideLink,
    ConnectingLink,
    Barrel(CylinderName),
    Rod(CylinderName),
}

impl Body {
    pub const ALL: [Body; BODIES] = [
        Body::Boom,
        Body::Arm,
        Body::Bucket,
        Body::SideLink,
        Body::ConnectingLink,
        // Cylinders in `CylinderName::ALL` order, as `index` counts them.
        Body::Barrel(CylinderName::Bucket),
        Body::Rod(CylinderName::Bucket),
        Body::Barrel(CylinderName::Arm),
        Body::Rod(CylinderName::Arm),
        Body::Barrel(CylinderName::Boom),
        Body::Rod(CylinderName::Boom),
    ];

    pub fn label(self) -> String {
        match self {
            Body::Boom => "boom".into(),
            Body::Arm => "arm".into(),
            Body::Bucket => "bucket".into(),
            Body::SideLink => "side link".into(),
            Body::ConnectingLink => "conn. link".into(),
            Body::Barrel(name) => format!("{name} barrel"),
            Body::Rod(name) => format!("{name} rod"),
        }
    }

    /// Position in [`Body::ALL`]: the body's equations are rows 3i..3i+3.
    fn index(self) -> usize {
        match self {
            Body::Boom => 0,
            Body::Arm => 1,
            Body::Bucket => 2,
            Body::SideLink => 3,
            Body::ConnectingLink => 4,
            Body::Barrel(name) => 5 + 2 * name.index(),
            Body::Rod(name) => 6 + 2 * name.index(),
        }
    }
}

/// A hinge: the force `on` receives from `from` (None: the fixed base).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Hinge {
    pub pin: Pin,
    pub on: Body,
    pub from: Option<Body>,
}

/// The named pins; `KSideLink` and `KConnectingLink` are the two hinges the
/// bucket cylinder's rod makes at the shared pin K.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Pin {
    A,
    C,
    D,
    B,
    E,
    F,
    G,
    H,
    I,
    KSideLink,
    KConnectingLink,
    L,
}

pub const HINGES: [Hinge; 12] = [
    Hinge {
        pin: Pin::A,
        on: Body::Boom,
        from: None,
    },
    Hinge {
        pin: Pin::C,
        on: Body::Barrel(CylinderName::Boom),
        from: None,
    },
    Hinge {
        pin: Pin::D,
        on: Body::Rod(CylinderName::Boom),
        from: Some(Body::Boom),
    },
    Hinge {
        pin: Pin::B,
        on: Body::Arm,
        from: Some(Body::Boom),
    },
    Hinge {
        pin: Pin::E,
        on: Body::Barrel(CylinderName::Arm),
        from: Some(Body::Boom),
    },
    Hinge {
        pin: Pin::F,
        on: Body::Rod(CylinderName::Arm),
        from: Some(Body::Arm),
    },
    Hinge {
        pin: Pin::G,
        on: Body::Bucket,
        from: Some(Body::Arm),
    },
    Hinge {
        pin: Pin::H,
        on: Body::Barrel(CylinderName::Bucket),
        from: Some(Body::Arm),
    },
    Hinge {
        pin: Pin::I,
        on: Body::SideLink,
        from: Some(Body::Arm),
    },
    Hinge {
        pin: Pin::KSideLink,
        on: Body::Rod(CylinderName::Bucket),
        from: Some(Body::SideLink),
    },
    Hinge {
        pin: Pin::KConnectingLink,
        on: Body::Rod(CylinderName::Bucket),
        from: Some(Body::ConnectingLink),
    },
    Hinge {
        pin: Pin::L,
        on: Body::ConnectingLink,
        from: Some(Body::Bucket),
    },
];

impl Pin {
    pub fn position(self, pose: &Pose) -> Vec2 {
        match self {
            Pin::A => pose.a,
            Pin::B => pose.b,
            Pin::C => pose.c,
            Pin::D => pose.d,
            Pin::E => pose.e,
            Pin::F => pose.f,
            Pin::G => pose.g,
            Pin::H => pose.h,
            Pin::I => pose.i,
            Pin::KSideLink | Pin::KConnectingLink => pose.k,
            Pin::L => pose.l,
        }
    }

    pub fn label(self) -> &'static str {
        match self {
            Pin::A => "A",
            Pin::B => "B",
            Pin::C => "C",
            Pin::D => "D",
            Pin::E => "E",
            Pin::F => "F",
            Pin::G => "G",
            Pin::H => "H",
            Pin::I => "I",
            Pin::KSideLink => "K_side_link",
            Pin::KConnectingLink => "K_connecting_link",
            Pin::L => "L",
        }
    }
}

/// A force (N, machine axes) applied at a point (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointLoad {
    pub body: Body,
    pub at_m: Vec2,
    pub force_n: Vec2,
}

/// The cylinder's joint between barrel and rod: what the rod receives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CylinderJoint {
    /// Oil force on the rod along the axis, N; positive pushes (extends).
    pub axial_force_n: f64,
    /// Guide force across the axis, N (from the barrel's and rod's weight).
    pub normal_force_n: f64,
    /// Guide couple, N m.
    pub couple_nm: f64,
    /// Unit axis from barrel pin to rod pin.
    pub axis: Vec2,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Reactions {
    /// Force (N) on `HINGES[k].on` from `HINGES[k].from`, in hinge order.
    pub hinge_force_n: [Vec2; 12],
    /// In `CylinderName::ALL` order.
    pub cylinders: [CylinderJoint; 3],
}

impl Reactions {
    pub fn hinge(&self, pin: Pin) -> Vec2 {
        let k = HINGES
            .iter()
            .position(|h| h.pin == pin)
            .expect("every pin is a hinge");
        self.hinge_force_n[k]
    }

    pub fn cylinder(&self, name: CylinderName) -> &CylinderJoint {
        &self.cylinders[name.index()]
    }

    /// Net force and moment (about the origin) on one body from its joints
    /// and the given loads: zero in equilibrium. Summed joint by joint,
    /// independently of the assembled matrix, so it checks the solve.
    pub fn resultant(&self, pose: &Pose, loads: &[PointLoad], body: Body) -> (Vec2, f64) {
        let mut force = Vec2::zeros();
        let mut moment = 0.0;
        let mut couple = 0.0;
        let mut add = |at: Vec2, f: Vec2| {
            force += f;
            moment += cross(&at, &f);
        };
        for (hinge, &f) in HINGES.iter().zip(&self.hinge_force_n) {
            let at = hinge.pin.position(pose);
            if hinge.on == body {
                add(at, f);
            }
            if hinge.from == Some(body) {
                add(at, -f);
            }
        }
        for name in CylinderName::ALL {
            let joint = self.cylinder(name);
            let (_, rod_pin) = pose.cylinder_pins(name);
            let normal = Vec2::new(-joint.axis.y, joint.axis.x);
            let f = joint.axis * joint.axial_force_n + normal * joint.normal_force_n;
            if body == Body::Rod(name) {
                add(rod_pin, f);
                couple += joint.couple_nm;
            }
            if body == Body::Barrel(name) {
                add(rod_pin, -f);
                couple -= joint.couple_nm;
            }
        }
        for load in loads.iter().filter(|l| l.body == body) {
            add(load.at_m, load.force_n);
        }
        (force, moment + couple)
    }
}

/// Solves for every joint force; None if the system is singular (a dead
/// centre the kinematics margin let through).
pub fn solve(pose: &Pose, loads: &[PointLoad]) -> Option<Reactions> {
    FactoredStatics::at(pose).solve(loads)
}

/// The equilibrium equations of every body at one pose, factored. Their
/// left side (where each joint force acts) depends on the pose alone, so
/// one factorisation serves every load at that pose: a sampler that moves
/// masses solves each hold's pose once.
#[derive(Clone, Debug)]
pub struct FactoredStatics {
    lu: LU<f64, Const<EQUATIONS>, Const<EQUATIONS>>,
    axes: [Vec2; 3],
}

impl FactoredStatics {
    pub fn at(pose: &Pose) -> FactoredStatics {
        let mut matrix = SMatrix::<f64, EQUATIONS, EQUATIONS>::zeros();

        // Column `column` holds a unit force component along `direction` at `at`
        // acting on `body` with `sign`.
        type Equations = SMatrix<f64, EQUATIONS, EQUATIONS>;
        fn put(
            matrix: &mut Equations,
            body: Body,
            column: usize,
            at: Vec2,
            direction: Vec2,
            sign: f64,
        ) {
            let row = 3 * body.index();
            matrix[(row, column)] += sign * direction.x;
            matrix[(row + 1, column)] += sign * direction.y;
            matrix[(row + 2, column)] += sign * cross(&at, &direction);
        }
        let (unit_y, unit_z) = (Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0));
        for (k, hinge) in HINGES.iter().enumerate() {
            let at = hinge.pin.position(pose);
            for (component, direction) in [unit_y, unit_z].into_iter().enumerate() {
                put(&mut matrix, hinge.on, 2 * k + component, at, direction, 1.0);
                if let Some(from) = hinge.from {
                    put(&mut matrix, from, 2 * k + component, at, direction, -1.0);
                }
            }
        }
        let mut axes = [Vec2::zeros(); 3];
        for name in CylinderName::ALL {
            let (barrel_pin, rod_pin) = pose.cylinder_pins(name);
            let axis = (rod_pin - barrel_pin).normalize();
            axes[name.index()] = axis;
            let normal = Vec2::new(-axis.y, axis.x);
            let first = 2 * HINGES.len() + 3 * name.index();
            for (offset, direction) in [axis, normal].into_iter().enumerate() {
                put(
                    &mut matrix,
                    Body::Rod(name),
                    first + offset,
                    rod_pin,
                    direction,
                    1.0,
                );
                put(
                    &mut matrix,
                    Body::Barrel(name),
                    first + offset,
                    rod_pin,
                    direction,
                    -1.0,
                );
            }
            matrix[(3 * Body::Rod(name).index() + 2, first + 2)] += 1.0;
            matrix[(3 * Body::Barrel(name).index() + 2, first + 2)] -= 1.0;
        }
        FactoredStatics {
            lu: matrix.lu(),
            axes,
        }
    }

    /// Every joint force under `loads`; None if the equations are singular.
    pub fn solve(&self, loads: &[PointLoad]) -> Option<Reactions> {
        let axes = self.axes;
        let mut rhs = SVector::<f64, EQUATIONS>::zeros();
        for load in loads {
            let row = 3 * load.body.index();
            rhs[row] -= load.force_n.x;
            rhs[row + 1] -= load.force_n.y;
            rhs[row + 2] -= cross(&load.at_m, &load.force_n);
        }

        let solution = self.lu.solve(&rhs)?;
        if solution.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let mut hinge_force_n = [Vec2::zeros(); 12];
        for (k, force) in hinge_force_n.iter_mut().enumerate() {
            *force = Vec2::new(solution[2 * k], solution[2 * k + 1]);
        }
        let cylinders = CylinderName::ALL.map(|name| {
            let first = 2 * HINGES.len() + 3 * name.index();
            CylinderJoint {
                axial_force_n: solution[first],
                normal_force_n: solution[first + 1],
                couple_nm: solution[first + 2],
                axis: axes[name.index()],
            }
        });
        Some(Reactions {
            hinge_force_n,
            cylinders,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::Body;

    #[test]
    fn index_is_the_position_in_all() {
        for (position, body) in Body::ALL.into_iter().enumerate() {
            assert_eq!(body.index(), position, "{body:?}");
        }
    }
}
