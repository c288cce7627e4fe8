//! A pose from the machine's inclinometers: the strokes at which the boom
//! (A->B), the arm (B->G) and the bucket (G->J) point where the
//! inclinometers say, each angle from +Y toward +Z as the rig's slope
//! sensors give it (degrees).
//!
//! Each cylinder moves only its own link relative to the one before (the
//! boom's stroke turns A->B; the arm's, B->G about B; the bucket's, G->J
//! about G), and over a cylinder's stroke range its link turns one way only
//! where the linkage reaches). So the three strokes come one after the
//! other, each the root of a monotonic function of one variable: bracketed
//! on 65 samples of the range, then bisected on [`Pose::solve`] to 1e-9 mm.

use super::geometry::Geometry;
use super::inputs::{CylinderName, Strokes};
use super::kinematics::{Pose, Vec2};

/// The three link inclinations, degrees from +Y toward +Z.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inclinations {
    /// A->B.
    pub boom_deg: f64,
    /// B->G.
    pub arm_deg: f64,
    /// G->J.
    pub bucket_deg: f64,
}

/// Why no pose has those inclinations.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InclinationError {
    #[error("the {cylinder} link at {wanted_deg:.2} deg lies outside what its stroke range reaches ({low_deg:.2} to {high_deg:.2} deg)")]
    OutOfReach {
        cylinder: CylinderName,
        wanted_deg: f64,
        low_deg: f64,
        high_deg: f64,
    },
    #[error("the {cylinder} cylinder reaches no pose over its stroke range here (the linkage is at a dead centre); its link's angle cannot be matched")]
    Unreachable { cylinder: CylinderName },
}

/// A link's inclination in a pose.
type LinkAngle = fn(&Pose) -> f64;

fn direction_deg(from: Vec2, to: Vec2) -> f64 {
    (to.y - from.y).atan2(to.x - from.x).to_degrees()
}

/// `a - b` in degrees, wrapped into (-180, 180].
fn difference_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

impl Inclinations {
    /// What the inclinometers read in `pose`.
    pub fn of(pose: &Pose) -> Inclinations {
        Inclinations {
            boom_deg: direction_deg(pose.a, pose.b),
            arm_deg: direction_deg(pose.b, pose.g),
            bucket_deg: direction_deg(pose.g, pose.j),
        }
    }

    /// The strokes of the pose with these inclinations.
    pub fn strokes(&self, geometry: &Geometry) -> Result<Strokes, InclinationError> {
        let middle = |name: CylinderName| {
            let [low, high] = geometry.cylinder(name).stroke_range_mm;
            0.5 * (low + high)
        };
        let mut strokes = Strokes {
            bucket_mm: middle(CylinderName::Bucket),
            arm_mm: middle(CylinderName::Arm),
            boom_mm: middle(CylinderName::Boom),
        };
        let links: [(CylinderName, f64, LinkAngle); 3] = [
            (CylinderName::Boom, self.boom_deg, |p| {
                direction_deg(p.a, p.b)
            }),
            (CylinderName::Arm, self.arm_deg, |p| direction_deg(p.b, p.g)),
            (CylinderName::Bucket, self.bucket_deg, |p| {
                direction_deg(p.g, p.j)
            }),
        ];
        for (cylinder, wanted_deg, angle_of) in links {
            let stroke = solve_one(geometry, &mut strokes, cylinder, wanted_deg, angle_of)?;
            strokes.set(cylinder, stroke);
        }
        Ok(strokes)
    }
}

/// The stroke of `cylinder` (the others as in `strokes`) at which
/// `angle_of` the pose is `wanted_deg`.
fn solve_one(
    geometry: &Geometry,
    strokes: &mut Strokes,
    cylinder: CylinderName,
    wanted_deg: f64,
    angle_of: LinkAngle,
) -> Result<f64, InclinationError> {
    let mut angle_at = |stroke_mm: f64| -> Option<f64> {
        strokes.set(cylinder, stroke_mm);
        Pose::solve(geometry, strokes)
            .ok()
            .map(|pose| difference_deg(angle_of(&pose), wanted_deg))
    };
    // Where a link is reachable at all can stop short of its range's ends
    // (a dead centre of the linkage): sample the range, bracket the root
    // between two reachable samples.
    let [low, high] = geometry.cylinder(cylinder).stroke_range_mm;
    const SAMPLES: usize = 64;
    let samples: Vec<(f64, Option<f64>)> = (0..=SAMPLES)
        .map(|k| {
            let stroke = low + (high - low) * k as f64 / SAMPLES as f64;
            (stroke, angle_at(stroke))
        })
        .collect();
    if let Some(&(stroke, _)) = samples.iter().find(|(_, v)| *v == Some(0.0)) {
        return Ok(stroke);
    }
    let bracket = samples
        .windows(2)
        .find_map(|pair| match (pair[0], pair[1]) {
            // A sign change across +-180 deg is the wrap, not the angle.
            ((a, Some(va)), (b, Some(vb)))
                if va.signum() != vb.signum() && (va - vb).abs() < 90.0 =>
            {
                Some((a, va, b))
            }
            _ => None,
        });
    let Some((low, at_low, high)) = bracket else {
        let reached: Vec<f64> = samples.iter().filter_map(|(_, v)| *v).collect();
        if reached.is_empty() {
            return Err(InclinationError::Unreachable { cylinder });
        }
        let (least, most) = reached
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(*v), hi.max(*v))
            });
        return Err(InclinationError::OutOfReach {
            cylinder,
            wanted_deg,
            low_deg: wanted_deg + least,
            high_deg: wanted_deg + most,
        });
    };
    let (mut a, mut b) = (low, high);
    let mut sign_a = at_low.signum();
    while b - a > 1e-9 {
        let middle = 0.5 * (a + b);
        let Some(value) = angle_at(middle) else {
            return Err(InclinationError::Unreachable { cylinder });
        };
        if value == 0.0 {
            return Ok(middle);
        }
        if value.signum() == sign_a {
            a = middle;
            sign_a = value.signum();
        } else {
            b = middle;
        }
    }
    Ok(0.5 * (a + b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angle_differences_wrap() {
        assert_eq!(difference_deg(179.0, -179.0), -2.0);
        assert_eq!(difference_deg(-179.0, 179.0), 2.0);
        assert_eq!(difference_deg(10.0, 10.0), 0.0);
    }
}
