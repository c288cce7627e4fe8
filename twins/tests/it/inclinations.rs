//! A pose from the inclinometers: the strokes found from the links'
//! inclinations give back those inclinations, over the whole stroke box,
//! and the published poses' measured pins give strokes within the published
//! bounds of their cases.

use acq_twins::excavator::geometry::Geometry;
use acq_twins::excavator::inclinations::{InclinationError, Inclinations};
use acq_twins::excavator::kinematics::Pose;
use acq_twins::excavator::pose_fit::published_poses;
use acq_twins::excavator::{CylinderName, Strokes};

#[test]
fn strokes_from_inclinations_round_trip_over_the_stroke_box() {
    let geometry = Geometry::dx55();
    let range = |name: CylinderName| geometry.cylinder(name).stroke_range_mm;
    let steps = 7;
    let at = |name: CylinderName, k: usize| {
        let [low, high] = range(name);
        // Inside the ends, where a pose is reachable.
        low + (high - low) * (0.02 + 0.96 * k as f64 / (steps - 1) as f64)
    };
    let mut checked = 0;
    for i in 0..steps {
        for j in 0..steps {
            for k in 0..steps {
                let strokes = Strokes {
                    bucket_mm: at(CylinderName::Bucket, i),
                    arm_mm: at(CylinderName::Arm, j),
                    boom_mm: at(CylinderName::Boom, k),
                };
                let Ok(pose) = Pose::solve(&geometry, &strokes) else {
                    continue;
                };
                let found = Inclinations::of(&pose)
                    .strokes(&geometry)
                    .unwrap_or_else(|e| panic!("{strokes:?}: {e}"));
                for name in CylinderName::ALL {
                    assert!(
                        (found.get(name) - strokes.get(name)).abs() < 1e-6,
                        "{name}: {found:?} vs {strokes:?}"
                    );
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 300, "only {checked} reachable poses");
}

#[test]
fn the_published_poses_pins_give_strokes_within_their_cases_bounds() {
    // The published points are given to the millimetre; the cases' stroke
    // bounds are +-5 mm around the nominal strokes.
    let geometry = Geometry::dx55();
    for reference in published_poses() {
        let direction =
            |from: [f64; 2], to: [f64; 2]| (to[1] - from[1]).atan2(to[0] - from[0]).to_degrees();
        let inclinations = Inclinations {
            boom_deg: direction([0.0, 0.0], reference.b),
            arm_deg: direction(reference.b, reference.g),
            bucket_deg: direction(reference.g, reference.j),
        };
        let found = inclinations.strokes(&geometry).unwrap();
        for name in CylinderName::ALL {
            let (got, nominal) = (found.get(name), reference.strokes.get(name));
            eprintln!("{name}: {got:.2} mm from the pins, {nominal} mm published");
            assert!(
                (got - nominal).abs() <= 5.0,
                "{name}: {got:.2} mm from the pins, published {nominal} mm"
            );
        }
    }
}

#[test]
fn a_link_angle_no_stroke_reaches_is_refused_naming_the_cylinder() {
    let geometry = Geometry::dx55();
    let error = Inclinations {
        boom_deg: 170.0,
        arm_deg: -40.0,
        bucket_deg: -40.0,
    }
    .strokes(&geometry)
    .unwrap_err();
    assert!(
        matches!(
            error,
            InclinationError::OutOfReach {
                cylinder: CylinderName::Boom,
                ..
            }
        ),
        "{error}"
    );
    assert!(error.to_string().contains("boom"), "{error}");
}
