//! Re-fitting the fitted pose numbers of a changed geometry: the shipped
//! file's numbers come back, and a moved pin still meets the published poses.

use acq_twins::excavator::geometry::{Geometry, GeometryTemplate};
use acq_twins::excavator::kinematics::Pose;
use acq_twins::excavator::pose_fit::{published_poses, refit_poses};
use acq_twins::excavator::CylinderName;

#[test]
fn refitting_the_shipped_geometry_gives_back_its_numbers() {
    // dx55.toml's pose numbers came from the same two poses by a scratch
    // root search that took the joint angles from mean link lengths; here
    // they come from each case's own points. The published points are
    // given to the millimetre (joint angles to about 6e-4 rad), so the two
    // fits may differ far below that: the boom's and arm's barrel pins by
    // 0.1 mm, their retracted lengths likewise. The bucket cylinder stands
    // nearly along its rod end's travel, so there a tiny angle difference
    // slides H along the travel by millimetres (and the retracted length
    // with it, the cylinder's stroke-angle relation all but unchanged):
    // 15 mm.
    let file = Geometry::dx55();
    let mut geometry = file.clone();
    refit_poses(&mut geometry, &published_poses()).unwrap();
    let close = |got: [f64; 2], file: [f64; 2], tolerance: f64, what: &str| {
        let distance = (got[0] - file[0]).hypot(got[1] - file[1]);
        assert!(distance <= tolerance, "{what}: {got:?} vs {file:?}");
    };
    close(
        geometry.base.boom_cylinder_pin_m,
        file.base.boom_cylinder_pin_m,
        1e-4,
        "C",
    );
    close(
        geometry.boom.arm_cylinder_pin_m,
        file.boom.arm_cylinder_pin_m,
        1e-4,
        "E",
    );
    close(
        geometry.arm.bucket_cylinder_pin_m,
        file.arm.bucket_cylinder_pin_m,
        0.015,
        "H",
    );
    for (name, tolerance) in [
        (CylinderName::Boom, 1e-4),
        (CylinderName::Arm, 1e-4),
        (CylinderName::Bucket, 0.015),
    ] {
        let (got, want) = (
            geometry.cylinder(name).retracted_length_m,
            file.cylinder(name).retracted_length_m,
        );
        assert!(
            (got - want).abs() <= tolerance,
            "{name} retracted: {got} vs {want}"
        );
    }
    // The rod pins are the file's.
    assert_eq!(
        geometry.boom.boom_cylinder_pin_m,
        file.boom.boom_cylinder_pin_m
    );
    assert_eq!(geometry.arm.arm_cylinder_pin_m, file.arm.arm_cylinder_pin_m);
    assert_eq!(geometry.bucket.link_pin_m, file.bucket.link_pin_m);
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
    // A barrel pin moves only along its rod pin's travel: the boom's (its
    // rod pin D turns about A, so the travel is nearly vertical) keeps its
    // distance across that line.
    let travel = {
        let angles = poses.map(|p| p.joint_angles_rad()[0]);
        let d = moved.boom.boom_cylinder_pin_m;
        let at = |a: f64| {
            [
                d[0] * a.cos() - d[1] * a.sin(),
                d[0] * a.sin() + d[1] * a.cos(),
            ]
        };
        let (p, q) = (at(angles[0]), at(angles[1]));
        let n = (p[0] - q[0]).hypot(p[1] - q[1]);
        [(p[0] - q[0]) / n, (p[1] - q[1]) / n]
    };
    let across = |c: [f64; 2]| -c[0] * travel[1] + c[1] * travel[0];
    assert!((across(refitted.base.boom_cylinder_pin_m) - across([0.20, -0.45])).abs() < 1e-12);
    // The rod pins stay where they were put.
    assert_eq!(
        refitted.boom.boom_cylinder_pin_m,
        moved.boom.boom_cylinder_pin_m
    );
    assert_eq!(
        refitted.arm.arm_cylinder_pin_m,
        moved.arm.arm_cylinder_pin_m
    );
}

#[test]
fn a_stroke_change_beyond_the_rod_pins_travel_is_refused_with_the_reason() {
    // A rod pin 5 cm from A travels about 2 cm between the poses: the
    // boom cylinder cannot change its length by the published 186 mm.
    let template = GeometryTemplate::dx55();
    let mut short = template
        .with(&[
            ("boom.boom_cylinder_pin_m[0]", 0.05),
            ("boom.boom_cylinder_pin_m[1]", 0.0),
        ])
        .unwrap();
    let error = refit_poses(&mut short, &published_poses()).unwrap_err();
    assert!(
        error.contains("boom joint") && error.contains("rod pin moves only"),
        "{error}"
    );
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
    let file = Geometry::dx55();
    assert_eq!(
        template.value("bucket.mass_kg").unwrap(),
        file.bucket.mass_kg
    );
    assert_eq!(
        template.value("base.boom_cylinder_pin_m[1]").unwrap(),
        file.base.boom_cylinder_pin_m[1]
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
