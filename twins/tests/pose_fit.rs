//! Re-fitting the fitted pose numbers of a changed geometry: the shipped
//! file's numbers come back, and a moved pin still meets the published poses.

use acq_twins::excavator::geometry::{Geometry, GeometryTemplate};
use acq_twins::excavator::kinematics::Pose;
use acq_twins::excavator::pose_fit::{published_poses, refit_poses, refit_poses_from};
use acq_twins::excavator::CylinderName;

fn angle_deg(point: [f64; 2]) -> f64 {
    point[1].atan2(point[0]).to_degrees()
}

#[test]
fn refitting_the_shipped_geometry_gives_back_its_fitted_numbers() {
    // dx55.toml's fitted numbers came from the same two poses by a scratch
    // root search that took the joint angles from mean link lengths; here
    // they come from each case's own points. The published points are
    // given to the millimetre (joint angles to about 6e-4 rad), so the two
    // fits may differ far below that: 1e-3 deg (7 um at F's 0.4 m lever)
    // and 10 um of cylinder length.
    let mut geometry = Geometry::dx55();
    refit_poses(&mut geometry, &published_poses()).unwrap();
    let close = |got: f64, file: f64, tolerance: f64, what: &str| {
        assert!((got - file).abs() <= tolerance, "{what}: {got} vs {file}");
    };
    close(
        angle_deg(geometry.boom.boom_cylinder_pin_m),
        -6.4247,
        1e-3,
        "D angle",
    );
    close(
        angle_deg(geometry.arm.arm_cylinder_pin_m),
        141.2606,
        1e-3,
        "F angle",
    );
    close(
        angle_deg(geometry.bucket.link_pin_m),
        89.7842,
        1e-3,
        "L angle",
    );
    close(
        geometry.cylinder.boom.retracted_length_m,
        1.030794,
        1e-5,
        "boom retracted",
    );
    close(
        geometry.cylinder.arm.retracted_length_m,
        1.019190,
        1e-5,
        "arm retracted",
    );
    close(
        geometry.cylinder.bucket.retracted_length_m,
        0.897668,
        1e-5,
        "bucket retracted",
    );
}

#[test]
fn moved_pins_are_refitted_so_the_published_poses_still_hold() {
    let template = GeometryTemplate::dx55();
    let moved = template
        .with(&[
            ("base.boom_cylinder_pin_m[0]", 0.20),
            ("base.boom_cylinder_pin_m[1]", -0.45),
            ("boom.arm_cylinder_pin_m[1]", 0.55),
            ("arm.bucket_cylinder_pin_m[0]", 0.30),
        ])
        .unwrap();
    let poses = published_poses();
    // Before the re-fit the poses are off: the check below would fail.
    let off = Pose::solve(&moved, &poses[0].strokes).unwrap();
    assert!((off.b.x - poses[0].b[0]).abs() + (off.b.y - poses[0].b[1]).abs() > 0.01);
    let mut refitted = moved.clone();
    refit_poses(&mut refitted, &poses).unwrap();
    for pose in &poses {
        let solved = Pose::solve(&refitted, &pose.strokes).unwrap();
        let target = pose.joint_angles_rad();
        let got = [
            solved.boom_angle_rad,
            solved.arm_angle_rad - solved.boom_angle_rad,
            solved.bucket_angle_rad - solved.arm_angle_rad,
        ];
        for (g, t) in got.iter().zip(target) {
            assert!((g - t).abs() < 1e-8, "{got:?} vs {target:?}");
        }
        // The pins then sit where the file's fit put them (within 5 mm of
        // the published points, as tests/excavator.rs checks for the file).
        for (point, published) in [(solved.b, pose.b), (solved.g, pose.g), (solved.j, pose.j)] {
            let distance = (point.x - published[0]).hypot(point.y - published[1]);
            assert!(distance < 0.005, "{point:?} vs {published:?}");
        }
    }
    // The moved pins themselves stay where they were put.
    assert_eq!(refitted.base.boom_cylinder_pin_m, [0.20, -0.45]);
    assert_eq!(refitted.arm.bucket_cylinder_pin_m[0], 0.30);

    // Started from a nearby fitted geometry (a search's previous point),
    // the fit lands on the same numbers.
    let mut warm = moved.clone();
    refit_poses_from(&mut warm, &poses, Some(&template.with(&[]).unwrap())).unwrap();
    for (a, b) in [
        (
            warm.boom.boom_cylinder_pin_m,
            refitted.boom.boom_cylinder_pin_m,
        ),
        (warm.arm.arm_cylinder_pin_m, refitted.arm.arm_cylinder_pin_m),
        (warm.bucket.link_pin_m, refitted.bucket.link_pin_m),
    ] {
        assert!(
            (a[0] - b[0]).abs() + (a[1] - b[1]).abs() < 1e-9,
            "{a:?} vs {b:?}"
        );
    }
    for name in CylinderName::ALL {
        let (a, b) = (
            warm.cylinder(name).retracted_length_m,
            refitted.cylinder(name).retracted_length_m,
        );
        assert!((a - b).abs() < 1e-9, "{name}: {a} vs {b}");
    }
}

#[test]
fn a_moved_pin_carries_its_lug_and_the_member_keeps_its_stations_shares() {
    // F is the arm centreline's first vertex and carries a boss: moving it
    // moves both, and the sections and gauges keep their share of the
    // longer centreline, so the file stays valid.
    let template = GeometryTemplate::dx55();
    let before = template.with(&[]).unwrap();
    let moved = template
        .with(&[("arm.arm_cylinder_pin_m[0]", -0.40)])
        .unwrap();
    let f = moved.arm.arm_cylinder_pin_m;
    assert_eq!(moved.arm.structure.centreline_m[0], f);
    assert!(moved
        .arm
        .structure
        .attached_mass
        .iter()
        .any(|m| m.at_m == f));
    let stretch = moved.arm.structure.length_m() / before.arm.structure.length_m();
    assert!(stretch > 1.01, "{stretch}");
    let last = |g: &acq_twins::excavator::geometry::Geometry| {
        g.arm.structure.section.last().unwrap().station_m
    };
    let share = |g: &acq_twins::excavator::geometry::Geometry| last(g) / g.arm.structure.length_m();
    assert!((share(&moved) - share(&before)).abs() < 1e-12);
    for (a, b) in moved.gauges.iter().zip(&before.gauges) {
        let expected = match a.member {
            acq_twins::excavator::geometry::Member::Arm => b.station_m * stretch,
            acq_twins::excavator::geometry::Member::Boom => b.station_m,
        };
        assert!((a.station_m - expected).abs() < 1e-12, "gauge {}", a.point);
    }
}

#[test]
fn key_paths_name_numbers_of_the_file_and_nothing_else() {
    let template = GeometryTemplate::dx55();
    assert_eq!(template.value("bucket.mass_kg").unwrap(), 150.0);
    assert_eq!(
        template.value("base.boom_cylinder_pin_m[1]").unwrap(),
        -0.40
    );
    assert_eq!(template.value("gauge[2].station_m").unwrap(), 1.0);
    let geometry = template.with(&[("bucket.mass_kg", 180.0)]).unwrap();
    assert_eq!(geometry.bucket.mass_kg, 180.0);
    for wrong in [
        "bucket.mass",
        "bucket",
        "name",
        "base.boom_cylinder_pin_m[2]",
        "base.boom_cylinder_pin_m[x]",
        "gauge[2",
        "",
    ] {
        assert!(template.value(wrong).is_err(), "{wrong}");
    }
    // A number the file's checks refuse is refused here too.
    let error = template.with(&[("bucket.mass_kg", -1.0)]).unwrap_err();
    assert!(error.contains("bucket.mass_kg"), "{error}");
}
