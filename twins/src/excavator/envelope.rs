//! The working envelope: how far, how deep and how high the bucket reaches
//! over the cylinders' whole stroke ranges, as a catalogue states it.
//!
//! Catalogue figures are measured from the machine, not from the boom foot
//! pin A, so the geometry places A: its height above the ground and its
//! distance ahead of the swing axis (`[base]`). With these, for the strokes
//! in `stroke_range_mm`:
//!
//! - **maximum reach**: the largest horizontal distance from the swing axis
//!   to the bucket tip J, at any height;
//! - **maximum digging depth**: the deepest J below the ground;
//! - **maximum dump height**: the highest J with the bucket fully opened
//!   (its cylinder at the lower stroke limit) and hanging from its pin (J
//!   no higher than G, the cutting edge the bucket's lowest point), over
//!   boom and arm strokes.
//!
//! Each is a maximum of the closed-form pose over the box of
//! strokes: a coarse grid, then golden-section searches along each stroke
//! in turn from the best grid point, until no stroke moves. The optimum's
//! value is stationary in the strokes (or on a stroke limit, exact), so the
//! result is smooth in the geometry: a least-squares identification can
//! take its differences.

use super::geometry::Geometry;
use super::inputs::{CylinderName, Strokes, TwinError};
use super::kinematics::Pose;

/// The catalogue's envelope of a geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorkingEnvelope {
    pub max_reach_m: f64,
    pub reach_strokes: Strokes,
    pub max_digging_depth_m: f64,
    pub depth_strokes: Strokes,
    pub max_dump_height_m: f64,
    pub dump_strokes: Strokes,
}

/// Grid points per stroke before the line searches.
const GRID: usize = 9;
/// Line-search rounds over all strokes at most.
const ROUNDS: usize = 40;

/// The envelope, or why it cannot be had (A not placed, or no stroke
/// combination the linkage reaches).
pub fn working_envelope(geometry: &Geometry) -> Result<WorkingEnvelope, TwinError> {
    let (Some(height_m), Some(ahead_m)) = (
        geometry.base.foot_pin_above_ground_m,
        geometry.base.foot_pin_ahead_of_swing_axis_m,
    ) else {
        return Err(TwinError::Geometry(
            "the working envelope needs the boom foot pin's place on the machine: give base.foot_pin_above_ground_m and base.foot_pin_ahead_of_swing_axis_m".into(),
        ));
    };
    let range = |name: CylinderName| geometry.cylinder(name).stroke_range_mm;
    let tip = |strokes: &Strokes| Pose::solve(geometry, strokes).ok().map(|p| p.j);
    let all = [CylinderName::Boom, CylinderName::Arm, CylinderName::Bucket];
    let none_reached = |what: &str| {
        TwinError::Geometry(format!(
            "no stroke combination in the stroke ranges gives a pose, so the {what} cannot be found; check stroke_range_mm and retracted_length_m"
        ))
    };

    let (reach, reach_strokes) = maximise(&all, &range, &mut |s| tip(s).map(|j| j.x))
        .ok_or_else(|| none_reached("reach"))?;
    let (depth, depth_strokes) = maximise(&all, &range, &mut |s| tip(s).map(|j| -j.y))
        .ok_or_else(|| none_reached("digging depth"))?;
    let opened_mm = range(CylinderName::Bucket)[0];
    let (dump, dump_strokes) =
        dump_height(geometry, &range, opened_mm).ok_or_else(|| none_reached("dump height"))?;
    Ok(WorkingEnvelope {
        max_reach_m: ahead_m + reach,
        reach_strokes,
        max_digging_depth_m: depth - height_m,
        depth_strokes,
        max_dump_height_m: height_m + dump,
        dump_strokes: Strokes {
            bucket_mm: opened_mm,
            ..dump_strokes
        },
    })
}

/// The largest `f` over the strokes `free` may take in their ranges (the
/// others at their lower limits); `None` where the linkage does not close.
fn maximise(
    free: &[CylinderName],
    range: &dyn Fn(CylinderName) -> [f64; 2],
    f: &mut dyn FnMut(&Strokes) -> Option<f64>,
) -> Option<(f64, Strokes)> {
    let mut at = Strokes {
        bucket_mm: range(CylinderName::Bucket)[0],
        arm_mm: range(CylinderName::Arm)[0],
        boom_mm: range(CylinderName::Boom)[0],
    };
    // The grid: every combination of GRID points per free stroke.
    let mut best: Option<(f64, Strokes)> = None;
    let combinations = GRID.pow(free.len() as u32);
    for index in 0..combinations {
        let mut rest = index;
        let mut strokes = at;
        for &name in free {
            let [low, high] = range(name);
            let k = rest % GRID;
            rest /= GRID;
            strokes.set(name, low + (high - low) * k as f64 / (GRID - 1) as f64);
        }
        if let Some(value) = f(&strokes) {
            if best.is_none_or(|(b, _)| value > b) {
                best = Some((value, strokes));
            }
        }
    }
    let (mut value, found) = best?;
    at = found;
    // Golden-section searches along each stroke, one grid cell either side.
    let half_width: Vec<f64> = free
        .iter()
        .map(|&name| {
            let [low, high] = range(name);
            (high - low) / (GRID - 1) as f64
        })
        .collect();
    for _ in 0..ROUNDS {
        let mut moved = 0.0f64;
        for (slot, &name) in free.iter().enumerate() {
            let [low, high] = range(name);
            let centre = at.get(name);
            let (a, b) = (
                (centre - half_width[slot]).max(low),
                (centre + half_width[slot]).min(high),
            );
            let mut along = |x: f64| {
                let mut s = at;
                s.set(name, x);
                f(&s).unwrap_or(f64::NEG_INFINITY)
            };
            let (x, v) = golden_section_max(&mut along, a, b, 1e-10 * (high - low));
            if v > value {
                moved = moved.max((x - centre).abs() / (high - low));
                value = v;
                at.set(name, x);
            }
        }
        if moved < 1e-9 {
            break;
        }
    }
    Some((value, at))
}

/// The highest J with the bucket opened and J no higher than G: for each
/// boom stroke, the best arm stroke on the side of the arm range where J
/// hangs below G (found by bisection where the two meet, then a golden
/// section), and the best boom stroke by a grid and a golden section. A
/// search over both strokes at once would stall on the curve J = G.
fn dump_height(
    geometry: &Geometry,
    range: &dyn Fn(CylinderName) -> [f64; 2],
    opened_mm: f64,
) -> Option<(f64, Strokes)> {
    let [arm_low, arm_high] = range(CylinderName::Arm);
    let [boom_low, boom_high] = range(CylinderName::Boom);
    let strokes = |boom_mm: f64, arm_mm: f64| Strokes {
        bucket_mm: opened_mm,
        arm_mm,
        boom_mm,
    };
    // J's height, and how far it is above G, or None off the linkage.
    let tip = |boom_mm: f64, arm_mm: f64| {
        let pose = Pose::solve(geometry, &strokes(boom_mm, arm_mm)).ok()?;
        Some((pose.j.y, pose.j.y - pose.g.y))
    };
    let best_arm = |boom_mm: f64| -> Option<(f64, f64)> {
        let value = |arm_mm: f64| match tip(boom_mm, arm_mm) {
            Some((height, above)) if above <= 0.0 => height,
            _ => f64::NEG_INFINITY,
        };
        let (at, cell) = best_on_grid(&value, arm_low, arm_high)?;
        // The bracket one cell either side, cut where J comes level with G.
        let mut ends = [(at - cell).max(arm_low), (at + cell).min(arm_high)];
        for end in &mut ends {
            if value(*end) == f64::NEG_INFINITY {
                let (mut inside, mut outside) = (at, *end);
                while (outside - inside).abs() > 1e-10 * (arm_high - arm_low) {
                    let middle = 0.5 * (inside + outside);
                    if value(middle) == f64::NEG_INFINITY {
                        outside = middle;
                    } else {
                        inside = middle;
                    }
                }
                *end = inside;
            }
        }
        let (arm_mm, height) = golden_section_max(
            &mut |x| value(x),
            ends[0],
            ends[1],
            1e-10 * (arm_high - arm_low),
        );
        Some((arm_mm, height))
    };
    let along_boom = |boom_mm: f64| best_arm(boom_mm).map_or(f64::NEG_INFINITY, |(_, h)| h);
    let (at, cell) = best_on_grid(&along_boom, boom_low, boom_high)?;
    let (boom_mm, height) = golden_section_max(
        &mut |x| along_boom(x),
        (at - cell).max(boom_low),
        (at + cell).min(boom_high),
        1e-10 * (boom_high - boom_low),
    );
    let (arm_mm, _) = best_arm(boom_mm)?;
    Some((height, strokes(boom_mm, arm_mm)))
}

/// The best of GRID evenly spaced points of [low, high] and the spacing,
/// or None where `f` is nowhere above minus infinity.
fn best_on_grid(f: &dyn Fn(f64) -> f64, low: f64, high: f64) -> Option<(f64, f64)> {
    let cell = (high - low) / (GRID - 1) as f64;
    let (at, best) = (0..GRID)
        .map(|k| low + cell * k as f64)
        .map(|x| (x, f(x)))
        .fold(
            (low, f64::NEG_INFINITY),
            |b, c| if c.1 > b.1 { c } else { b },
        );
    (best > f64::NEG_INFINITY).then_some((at, cell))
}

/// The maximum of a unimodal `f` on [a, b], with the ends tried too (a
/// maximum on a stroke limit is exact).
fn golden_section_max(f: &mut dyn FnMut(f64) -> f64, a: f64, b: f64, tolerance: f64) -> (f64, f64) {
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let ends = [(a, f(a)), (b, f(b))];
    let (mut a, mut b) = (a, b);
    let mut c = b - ratio * (b - a);
    let mut d = a + ratio * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    while (b - a).abs() > tolerance {
        if fc > fd {
            b = d;
            d = c;
            fd = fc;
            c = b - ratio * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + ratio * (b - a);
            fd = f(d);
        }
    }
    let inner = if fc > fd { (c, fc) } else { (d, fd) };
    ends.into_iter()
        .chain([inner])
        .fold((f64::NAN, f64::NEG_INFINITY), |best, (x, v)| {
            if v > best.1 {
                (x, v)
            } else {
                best
            }
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_section_finds_an_interior_and_a_boundary_maximum() {
        let (x, v) = golden_section_max(&mut |x| -(x - 0.3).powi(2), 0.0, 1.0, 1e-10);
        assert!((x - 0.3).abs() < 1e-8 && v.abs() < 1e-15);
        let (x, _) = golden_section_max(&mut |x| x, 0.0, 1.0, 1e-10);
        assert_eq!(x, 1.0);
    }
}
