//! Keeping a changed geometry true to the published poses.
//!
//! The published study gives the pins B, G and J at two poses (Cases 1 and
//! 2, with their strokes), so each joint's angle is known at two strokes.
//! Two numbers per cylinder are fitted so that the twin meets both: where
//! its barrel pin sits along one line, and its retracted length. The rod
//! pins (D on the boom, F on the arm, and the bucket linkage's K through L
//! and the links) stay where the file or a study puts them.
//!
//! Why the barrel pin: between the two poses the rod pin moves from R1 to
//! R2 (in the barrel pin's body frame) and the cylinder's length changes by
//! the stroke difference. The barrel pin must therefore lie on the
//! hyperbola branch `|R1 - X| - |R2 - X| = stroke difference` with foci R1
//! and R2. A line along R1 - R2 crosses that branch exactly once whenever
//! the rod pin travels farther than the cylinder's length changes (which
//! a real linkage must), so the fit always has its one answer: the barrel
//! pin is moved along that line through where the file put it. (Fitting
//! the rod pin's angle instead has no answer for most moves of the pins:
//! a search over them kept failing.) The retracted length then follows.
//!
//! The bucket cylinder drives a four-bar: its rod end K is the point at the
//! side link's length from I and the connecting link's from L, on the side
//! where L lies to the left of K -> G, as [`Pose::solve`] assembles it.
//!
//! The result is checked with [`Pose::solve`] itself (the joint angles to
//! 1e-9 rad), so the fit and the twin cannot disagree.

use super::case::CaseFile;
use super::geometry::{Geometry, PointM};
use super::inputs::{CylinderName, Strokes};
use super::kinematics::{cross, vec2, Pose, Vec2};
use nalgebra::Rotation2;

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

/// Largest joint-angle error the check accepts, rad.
const TOLERANCE_RAD: f64 = 1e-9;

fn rotate(angle_rad: f64, local: Vec2) -> Vec2 {
    Rotation2::new(angle_rad) * local
}

/// Re-fits `geometry`'s barrel pins (each along its rod pin's travel) and
/// retracted lengths so that both reference poses hold. An error says
/// which joint cannot reach them, and why.
pub fn refit_poses(geometry: &mut Geometry, poses: &[ReferencePose; 2]) -> Result<(), String> {
    let before = geometry.clone();
    let angles = poses.map(|p| p.joint_angles_rad());
    let stroke_m = |k: usize, name: CylinderName| poses[k].strokes.get(name) * 1e-3;
    let cannot = |joint: CylinderName, why: String| {
        format!(
            "the {joint} joint cannot be fitted to the published poses with these pins ({why}); move its pins back toward the class-typical places"
        )
    };

    // Sets a joint's barrel pin and retracted length from its rod pin's
    // two places (in the barrel pin's body frame).
    let fit = |geometry: &mut Geometry, joint: CylinderName, rod: [Vec2; 2]| {
        let pin = barrel_pin(geometry, joint);
        let (x, retracted) =
            solve_barrel(vec2(*pin), rod, [stroke_m(0, joint), stroke_m(1, joint)])
                .map_err(|why| cannot(joint, why))?;
        *pin = [x.x, x.y];
        geometry.cylinder_mut(joint).retracted_length_m = retracted;
        Ok::<(), String>(())
    };

    // Boom, in the machine frame: D turns with the boom about A.
    let d_local = vec2(geometry.boom.boom_cylinder_pin_m);
    fit(
        geometry,
        CylinderName::Boom,
        [0, 1].map(|k| rotate(angles[k][0], d_local)),
    )?;

    // Arm, in the boom frame: F turns with the arm about B.
    let b = vec2(geometry.boom.arm_pin_m);
    let f_local = vec2(geometry.arm.arm_cylinder_pin_m);
    fit(
        geometry,
        CylinderName::Arm,
        [0, 1].map(|k| b + rotate(angles[k][1], f_local)),
    )?;

    // Bucket, in the arm frame: L turns with the bucket about G, and the
    // links place K.
    let g = vec2(geometry.arm.bucket_pin_m);
    let i = vec2(geometry.arm.side_link_pin_m);
    let l_local = vec2(geometry.bucket.link_pin_m);
    let mut rod = [Vec2::zeros(); 2];
    for (k, angle) in angles.iter().enumerate() {
        let l = g + rotate(angle[2], l_local);
        rod[k] = link_pin(
            i,
            geometry.side_link.length_m,
            l,
            geometry.connecting_link.length_m,
            g,
        )
        .ok_or_else(|| {
            cannot(
                CylinderName::Bucket,
                format!(
                    "the side link ({} m) and the connecting link ({} m) do not meet in the Case-{} pose",
                    geometry.side_link.length_m,
                    geometry.connecting_link.length_m,
                    k + 1
                ),
            )
        })?;
    }
    fit(geometry, CylinderName::Bucket, rod)?;
    geometry.carry_pins(&before);

    // The twin itself must now stand in both poses.
    for (k, pose) in poses.iter().enumerate() {
        let got = joint_angles_rad(geometry, &pose.strokes).map_err(|why| {
            cannot(
                CylinderName::Boom,
                format!(
                    "the fitted linkage does not assemble in the Case-{} pose: {why}",
                    k + 1
                ),
            )
        })?;
        for (index, joint) in JOINTS.iter().enumerate() {
            let error = wrap(got[index] - angles[k][index]).abs();
            if error > TOLERANCE_RAD {
                return Err(cannot(
                    *joint,
                    format!(
                        "it assembles on its other side in the Case-{} pose, {error:.2e} rad off",
                        k + 1
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// A cylinder's barrel pin, on the body it is fixed to (the base, the
/// boom, the arm).
fn barrel_pin(geometry: &mut Geometry, joint: CylinderName) -> &mut PointM {
    match joint {
        CylinderName::Boom => &mut geometry.base.boom_cylinder_pin_m,
        CylinderName::Arm => &mut geometry.boom.arm_cylinder_pin_m,
        CylinderName::Bucket => &mut geometry.arm.bucket_cylinder_pin_m,
    }
}

/// The barrel pin on the line through `start` along the rod pin's travel
/// `rod[0] - rod[1]` where the cylinder's length changes by the stroke
/// difference, and the retracted length there.
fn solve_barrel(start: Vec2, rod: [Vec2; 2], stroke_m: [f64; 2]) -> Result<(Vec2, f64), String> {
    let travel = rod[0] - rod[1];
    let span = travel.norm();
    let change = stroke_m[0] - stroke_m[1];
    // NaN (a degenerate travel) is refused too.
    if change.abs() >= span * (1.0 - 1e-9) || span.is_nan() {
        return Err(format!(
            "its length must change by {:.1} mm between the poses, but its rod pin moves only {:.1} mm",
            change.abs() * 1e3,
            span * 1e3
        ));
    }
    let along = travel / span;
    // Falls from +span - change to -span - change along the line.
    let mismatch = |t: f64| {
        let x = start + along * t;
        (rod[0] - x).norm() - (rod[1] - x).norm() - change
    };
    let (mut low, mut high) = (-1.0, 1.0);
    while mismatch(low) < 0.0 && low > -1e3 {
        low *= 2.0;
    }
    while mismatch(high) > 0.0 && high < 1e3 {
        high *= 2.0;
    }
    if mismatch(low) < 0.0 || mismatch(high) > 0.0 {
        return Err("no barrel pin place on its line meets both poses".into());
    }
    while high - low > 1e-13 {
        let middle = 0.5 * (low + high);
        if mismatch(middle) > 0.0 {
            low = middle;
        } else {
            high = middle;
        }
    }
    let x = start + along * (0.5 * (low + high));
    let retracted = (rod[0] - x).norm() - stroke_m[0];
    if retracted <= 0.0 || retracted.is_nan() {
        return Err(format!("the retracted length would be {retracted:.3} m"));
    }
    Ok((x, retracted))
}

/// K: at `side` from I and `connecting` from L, with L to the left of
/// K -> G (the side [`Pose::solve`] assembles).
fn link_pin(i: Vec2, side: f64, l: Vec2, connecting: f64, g: Vec2) -> Option<Vec2> {
    let base = l - i;
    let d = base.norm();
    let along = (side * side - connecting * connecting + d * d) / (2.0 * d);
    let height_squared = side * side - along * along;
    if height_squared <= 0.0 || height_squared.is_nan() {
        return None;
    }
    let unit = base / d;
    let normal = Vec2::new(-unit.y, unit.x);
    [1.0, -1.0]
        .into_iter()
        .map(|sign| i + unit * along + normal * (sign * height_squared.sqrt()))
        .find(|k| cross(&(g - k), &(l - k)) > 0.0)
}
