//! Pose from cylinder strokes, in closed form.
//!
//! Boom and arm: each cylinder closes a triangle (pivot, barrel pin, rod
//! pin) whose third side is the cylinder length, so the joint angle follows
//! from the law of cosines. Bucket: the cylinder drives the four-bar (arm,
//! side link, connecting link, bucket) through two such triangles: the
//! shared pin K from the side link and the cylinder, then the bucket's
//! link pin L from the connecting link and the bucket pin G.
//!
//! A triangle with an apex angle near 0 or 180 degrees is a dead centre:
//! the joint's mechanical advantage vanishes and the statics become
//! singular, so such poses are refused with the cylinder named.

use nalgebra::{Rotation2, Vector2};

use super::geometry::{Geometry, PointM};
use super::inputs::{CylinderName, Strokes, TwinError};

pub type Vec2 = Vector2<f64>;

pub fn vec2(point: PointM) -> Vec2 {
    Vec2::new(point[0], point[1])
}

/// z-component of the planar cross product (moment of `force` at `arm`).
pub fn cross(arm: &Vec2, force: &Vec2) -> f64 {
    arm.x * force.y - arm.y * force.x
}

/// Every pin of the attachment in machine coordinates (m), and body angles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Boom foot pin (origin).
    pub a: Vec2,
    /// Boom-arm pin.
    pub b: Vec2,
    /// Boom cylinder barrel pin on the base.
    pub c: Vec2,
    /// Boom cylinder rod pin on the boom.
    pub d: Vec2,
    /// Arm cylinder barrel pin on the boom.
    pub e: Vec2,
    /// Arm cylinder rod pin on the arm.
    pub f: Vec2,
    /// Arm-bucket pin.
    pub g: Vec2,
    /// Bucket cylinder barrel pin on the arm.
    pub h: Vec2,
    /// Side link pin on the arm.
    pub i: Vec2,
    /// Bucket cylinder rod, side link and connecting link pin.
    pub k: Vec2,
    /// Connecting link pin on the bucket.
    pub l: Vec2,
    /// Bucket tip.
    pub j: Vec2,
    /// Body x-axis angles from +Y toward +Z, rad.
    pub boom_angle_rad: f64,
    pub arm_angle_rad: f64,
    pub bucket_angle_rad: f64,
}

/// Which side of the directed base line the apex lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    Left,
    Right,
}

/// The apex X of the triangle on base p -> q with |X - p| = from_p and
/// |X - q| = from_q, on the given side; None when the sides cannot close or
/// the apex angle is within `margin_rad` of a dead centre.
fn apex(p: Vec2, q: Vec2, from_p: f64, from_q: f64, side: Side, margin_rad: f64) -> Option<Vec2> {
    let base = q - p;
    let base_length = base.norm();
    let along =
        (from_p * from_p - from_q * from_q + base_length * base_length) / (2.0 * base_length);
    let height_squared = from_p * from_p - along * along;
    if height_squared.is_nan() || height_squared <= 0.0 {
        return None;
    }
    let height = height_squared.sqrt();
    // Apex angle between X->p and X->q: sin = base * height / (from_p * from_q).
    let sin_apex = base_length * height / (from_p * from_q);
    if sin_apex < margin_rad.sin() {
        return None;
    }
    let unit = base / base_length;
    let normal = Vec2::new(-unit.y, unit.x);
    let sign = match side {
        Side::Left => 1.0,
        Side::Right => -1.0,
    };
    Some(p + unit * along + normal * (sign * height))
}

fn angle(v: Vec2) -> f64 {
    v.y.atan2(v.x)
}

fn place(origin: Vec2, angle_rad: f64, local: PointM) -> Vec2 {
    origin + Rotation2::new(angle_rad) * vec2(local)
}

impl Pose {
    /// Solves the pose; a stroke outside the cylinder's range, or a pose the
    /// linkage cannot reach or reaches at a dead centre, names the cylinder.
    pub fn solve(geometry: &Geometry, strokes: &Strokes) -> Result<Pose, TwinError> {
        let margin = geometry.dead_centre_margin_deg.to_radians();
        let length_m = |name: CylinderName| -> Result<f64, TwinError> {
            let cylinder = geometry.cylinder(name);
            let stroke_mm = strokes.get(name);
            let [low, high] = cylinder.stroke_range_mm;
            if !(low..=high).contains(&stroke_mm) {
                return Err(TwinError::StrokeOutOfRange {
                    cylinder: name,
                    stroke_mm,
                    range_mm: [low, high],
                });
            }
            Ok(cylinder.retracted_length_m + stroke_mm * 1e-3)
        };
        let unreachable = |name: CylinderName| TwinError::DeadCentre {
            cylinder: name,
            stroke_mm: strokes.get(name),
        };

        // Boom: triangle A (pivot), C (base pin), D (on the boom); D lies
        // counter-clockwise of C as seen from A.
        let a = Vec2::zeros();
        let c = vec2(geometry.base.boom_cylinder_pin_m);
        let d_local = vec2(geometry.boom.boom_cylinder_pin_m);
        let d = apex(
            a,
            c,
            d_local.norm(),
            length_m(CylinderName::Boom)?,
            Side::Left,
            margin,
        )
        .ok_or_else(|| unreachable(CylinderName::Boom))?;
        let boom_angle_rad = angle(d) - angle(d_local);
        let on_boom = |local: PointM| place(a, boom_angle_rad, local);
        let b = on_boom(geometry.boom.arm_pin_m);
        let e = on_boom(geometry.boom.arm_cylinder_pin_m);

        // Arm: triangle B (pivot), E (barrel pin on the boom), F (on the arm's
        // tail); F lies clockwise of E as seen from B.
        let f_local = vec2(geometry.arm.arm_cylinder_pin_m);
        let f = apex(
            b,
            e,
            f_local.norm(),
            length_m(CylinderName::Arm)?,
            Side::Right,
            margin,
        )
        .ok_or_else(|| unreachable(CylinderName::Arm))?;
        let arm_angle_rad = angle(f - b) - angle(f_local);
        let on_arm = |local: PointM| place(b, arm_angle_rad, local);
        let g = on_arm(geometry.arm.bucket_pin_m);
        let h = on_arm(geometry.arm.bucket_cylinder_pin_m);
        let i = on_arm(geometry.arm.side_link_pin_m);

        // Bucket four-bar: K from the side link (I) and the cylinder (H), on
        // the far side of the arm; then L from the connecting link (K) and G.
        let k = apex(
            i,
            h,
            geometry.side_link.length_m,
            length_m(CylinderName::Bucket)?,
            Side::Right,
            margin,
        )
        .ok_or_else(|| unreachable(CylinderName::Bucket))?;
        let l_local = vec2(geometry.bucket.link_pin_m);
        let l = apex(
            k,
            g,
            geometry.connecting_link.length_m,
            l_local.norm(),
            Side::Left,
            margin,
        )
        .ok_or_else(|| unreachable(CylinderName::Bucket))?;
        let bucket_angle_rad = angle(l - g) - angle(l_local);
        let j = place(g, bucket_angle_rad, geometry.bucket.tip_m);

        Ok(Pose {
            a,
            b,
            c,
            d,
            e,
            f,
            g,
            h,
            i,
            k,
            l,
            j,
            boom_angle_rad,
            arm_angle_rad,
            bucket_angle_rad,
        })
    }

    /// Barrel pin and rod pin of a cylinder.
    pub fn cylinder_pins(&self, name: CylinderName) -> (Vec2, Vec2) {
        match name {
            CylinderName::Boom => (self.c, self.d),
            CylinderName::Arm => (self.e, self.f),
            CylinderName::Bucket => (self.h, self.k),
        }
    }
}
