//! Keeping a changed geometry true to the published poses.
//!
//! The published study gives the pins B, G and J at two poses (Cases 1 and
//! 2, with their strokes). Each joint's rod pin angle on its moving body (D
//! on the boom, F on the arm, L on the bucket; their distance from the
//! joint is kept) and its cylinder's retracted length are fitted so that
//! the twin puts the joint at the published angle in both poses: two
//! equations, two unknowns per joint. A geometry whose lever pins were
//! moved (a calibration parameter, a user's own file) is re-fitted here, so
//! the published poses still hold.
//!
//! The forward model is [`Pose::solve`] itself, so the fit and the twin
//! cannot disagree. The joints are solved in order (boom, then the arm
//! relative to the boom, then the bucket relative to the arm); each is a
//! damped Newton iteration with a finite-difference Jacobian.

use super::case::CaseFile;
use super::geometry::{Geometry, PointM};
use super::inputs::{CylinderName, Strokes};
use super::kinematics::Pose;

/// A published pose: the strokes and the measured pins B, G and J (m, machine frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferencePose {
    pub strokes: Strokes,
    pub b: PointM,
    pub g: PointM,
    pub j: PointM,
}

impl ReferencePose {
    /// A case file's nominal strokes and measured points, if it has them.
    pub fn from_case(case: &CaseFile) -> Option<ReferencePose> {
        let points = case.measured_points?;
        Some(ReferencePose {
            strokes: case.nominal().strokes,
            b: points.B,
            g: points.G,
            j: points.J,
        })
    }

    /// The joint angles the pose shows, rad: the boom's (A->B from +Y), the
    /// arm's relative to the boom, the bucket's relative to the arm.
    pub fn joint_angles_rad(&self) -> [f64; 3] {
        let direction = |from: PointM, to: PointM| (to[1] - from[1]).atan2(to[0] - from[0]);
        let boom = direction([0.0, 0.0], self.b);
        let arm = direction(self.b, self.g);
        let bucket = direction(self.g, self.j);
        [boom, wrap(arm - boom), wrap(bucket - arm)]
    }
}

/// The published study's two poses (Cases 1 and 2, `data/excavator/`).
pub fn published_poses() -> [ReferencePose; 2] {
    [super::case::CASE1_TOML, super::case::CASE2_TOML].map(|text| {
        let case = CaseFile::parse(text).expect("the shipped cases are valid (tested)");
        ReferencePose::from_case(&case).expect("the shipped cases have measured points")
    })
}

/// An angle in (-pi, pi].
fn wrap(angle: f64) -> f64 {
    let turned = angle.rem_euclid(std::f64::consts::TAU);
    if turned > std::f64::consts::PI {
        turned - std::f64::consts::TAU
    } else {
        turned
    }
}

/// The twin's joint angles at `strokes`, as [`ReferencePose::joint_angles_rad`].
fn joint_angles_rad(geometry: &Geometry, strokes: &Strokes) -> Result<[f64; 3], String> {
    let pose = Pose::solve(geometry, strokes).map_err(|e| e.to_string())?;
    Ok([
        pose.boom_angle_rad,
        wrap(pose.arm_angle_rad - pose.boom_angle_rad),
        wrap(pose.bucket_angle_rad - pose.arm_angle_rad),
    ])
}

/// The joint driven by each cylinder, in the order of the joint angles.
const JOINTS: [CylinderName; 3] = [CylinderName::Boom, CylinderName::Arm, CylinderName::Bucket];

/// The fitted rod pin of a joint's cylinder, on its moving body.
fn rod_pin(geometry: &mut Geometry, joint: CylinderName) -> &mut PointM {
    match joint {
        CylinderName::Boom => &mut geometry.boom.boom_cylinder_pin_m,
        CylinderName::Arm => &mut geometry.arm.arm_cylinder_pin_m,
        CylinderName::Bucket => &mut geometry.bucket.link_pin_m,
    }
}

/// Sets a joint's two fitted numbers: the rod pin's angle (its distance
/// from the joint kept) and the cylinder's retracted length.
fn set_unknowns(geometry: &mut Geometry, joint: CylinderName, angle_rad: f64, retracted_m: f64) {
    let before = geometry.clone();
    let pin = rod_pin(geometry, joint);
    let radius = pin[0].hypot(pin[1]);
    *pin = [radius * angle_rad.cos(), radius * angle_rad.sin()];
    geometry.cylinder_mut(joint).retracted_length_m = retracted_m;
    geometry.carry_pins(&before);
}

fn unknowns(geometry: &mut Geometry, joint: CylinderName) -> [f64; 2] {
    let retracted = geometry.cylinder(joint).retracted_length_m;
    let pin = rod_pin(geometry, joint);
    [pin[1].atan2(pin[0]), retracted]
}

/// Largest joint-angle error the fit accepts, rad (about 6e-10 deg): tight,
/// so that a search's finite differences see the geometry, not where
/// the iteration happened to stop.
const TOLERANCE_RAD: f64 = 1e-11;
const MAX_ITERATIONS: usize = 60;

/// Re-fits `geometry`'s rod pin angles and retracted lengths so that both
/// reference poses hold. An error says which joint cannot reach them.
pub fn refit_poses(geometry: &mut Geometry, poses: &[ReferencePose; 2]) -> Result<(), String> {
    refit_poses_from(geometry, poses, None)
}

/// [`refit_poses`], starting each joint's Newton iteration from the fitted
/// numbers of `near` (a geometry fitted before, close to this one: a
/// search's previous point), where it converges in a step or two even
/// when the pins have moved far from the file's. Should that fail, from
/// the geometry's own numbers.
pub fn refit_poses_from(
    geometry: &mut Geometry,
    poses: &[ReferencePose; 2],
    near: Option<&Geometry>,
) -> Result<(), String> {
    if let Some(near) = near {
        let mut warm = geometry.clone();
        for joint in JOINTS {
            let mut near = near.clone();
            let [angle, retracted] = unknowns(&mut near, joint);
            set_unknowns(&mut warm, joint, angle, retracted);
        }
        if fit_joints(&mut warm, poses).is_ok() {
            *geometry = warm;
            return Ok(());
        }
    }
    fit_joints(geometry, poses)
}

fn fit_joints(geometry: &mut Geometry, poses: &[ReferencePose; 2]) -> Result<(), String> {
    let targets = poses.map(|p| p.joint_angles_rad());
    for (index, &joint) in JOINTS.iter().enumerate() {
        let residual = |geometry: &Geometry| -> Result<[f64; 2], String> {
            let mut out = [0.0; 2];
            for (k, pose) in poses.iter().enumerate() {
                out[k] =
                    wrap(joint_angles_rad(geometry, &pose.strokes)?[index] - targets[k][index]);
            }
            Ok(out)
        };
        let cannot = |why: String| {
            format!(
                "the {joint} joint cannot be fitted to the published poses with these pins ({why}); move the {joint} cylinder's pins back toward the class-typical places"
            )
        };
        let mut x = unknowns(geometry, joint);
        let mut r = residual(geometry).map_err(cannot)?;
        let mut iteration = 0;
        while r[0].abs().max(r[1].abs()) > TOLERANCE_RAD {
            iteration += 1;
            if iteration > MAX_ITERATIONS {
                return Err(cannot(format!(
                    "no convergence after {MAX_ITERATIONS} Newton steps, angle error {:.2e} rad",
                    r[0].abs().max(r[1].abs())
                )));
            }
            // Finite-difference Jacobian in (angle, length).
            let steps = [1e-7, 1e-7];
            let mut jacobian = [[0.0; 2]; 2];
            for column in 0..2 {
                let mut trial = geometry.clone();
                let mut moved = x;
                moved[column] += steps[column];
                set_unknowns(&mut trial, joint, moved[0], moved[1]);
                let shifted = residual(&trial).map_err(cannot)?;
                for row in 0..2 {
                    jacobian[row][column] = (shifted[row] - r[row]) / steps[column];
                }
            }
            let det = jacobian[0][0] * jacobian[1][1] - jacobian[0][1] * jacobian[1][0];
            if !det.is_finite() || det.abs() < 1e-14 {
                return Err(cannot(
                    "the two poses do not tell the pin's angle from the cylinder's length".into(),
                ));
            }
            let step = [
                (jacobian[1][1] * r[0] - jacobian[0][1] * r[1]) / det,
                (jacobian[0][0] * r[1] - jacobian[1][0] * r[0]) / det,
            ];
            // Damped: halve the step until the residual falls and the
            // linkage still closes.
            let mut scale = 1.0;
            loop {
                let candidate = [x[0] - scale * step[0], x[1] - scale * step[1]];
                let mut trial = geometry.clone();
                set_unknowns(&mut trial, joint, candidate[0], candidate[1]);
                if let Ok(next) = residual(&trial) {
                    if next[0].abs().max(next[1].abs()) < r[0].abs().max(r[1].abs()) {
                        *geometry = trial;
                        x = candidate;
                        r = next;
                        break;
                    }
                }
                scale *= 0.5;
                if scale < 1e-6 {
                    return Err(cannot(format!(
                        "the Newton step found no better point; angle error {:.2e} rad",
                        r[0].abs().max(r[1].abs())
                    )));
                }
            }
        }
    }
    Ok(())
}
