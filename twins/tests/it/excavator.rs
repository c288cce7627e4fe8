//! The shipped DX55-class geometry against the published test, and the
//! statics against virtual work and equilibrium.

use std::path::PathBuf;

use acq_twins::excavator::case::CaseFile;
use acq_twins::excavator::geometry::Geometry;
use acq_twins::excavator::kinematics::Vec2;
use acq_twins::excavator::statics::Body;
use acq_twins::excavator::{Chamber, CylinderName, Excavator, Inputs, Strokes, TwinError};
use proptest::prelude::*;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../data/excavator")
        .join(name)
}

fn twin() -> Excavator {
    Excavator::new(Geometry::load(&data("dx55.toml")).unwrap()).unwrap()
}

fn inputs(bucket_mm: f64, arm_mm: f64, boom_mm: f64, force_kn: f64, angle_deg: f64) -> Inputs {
    Inputs {
        strokes: Strokes {
            bucket_mm,
            arm_mm,
            boom_mm,
        },
        tip_force_kn: force_kn,
        tip_force_angle_deg: angle_deg,
    }
}

#[test]
fn mid_range_strokes_reproduce_the_published_pose_within_5_mm() {
    let twin = twin();
    for file in ["case1.toml", "case2.toml"] {
        let case = CaseFile::load(&data(file)).unwrap();
        let measured = case
            .measured_points
            .expect("the shipped cases carry the pose");
        let pose = twin.pose(&case.nominal().strokes).unwrap();
        for (name, model, [y, z]) in [
            ("B", pose.b, measured.B),
            ("G", pose.g, measured.G),
            ("J", pose.j, measured.J),
        ] {
            let error_mm = (model - Vec2::new(y, z)).norm() * 1e3;
            assert!(
                error_mm < 5.0,
                "{file} {name}: {error_mm:.2} mm from the published point"
            );
        }
    }
}

#[test]
fn the_whole_published_stroke_range_evaluates() {
    let twin = twin();
    let steps = |low: f64, high: f64, n: usize| {
        (0..=n).map(move |k| low + (high - low) * k as f64 / n as f64)
    };
    let mut evaluated = 0;
    for boom in steps(250.0, 650.0, 8) {
        for arm in steps(0.0, 550.0, 11) {
            for bucket in steps(100.0, 400.0, 6) {
                for angle in [-110.0, -10.0, 0.0] {
                    let e = twin
                        .evaluate(&inputs(bucket, arm, boom, 40.6, angle))
                        .unwrap_or_else(|err| {
                            panic!("boom {boom} arm {arm} bucket {bucket}: {err}")
                        });
                    assert!(e
                        .cylinders
                        .iter()
                        .all(|c| c.loaded_chamber_pressure_bar.is_finite()));
                    assert!(e.gauges.iter().all(|g| g.stress_mpa.is_finite()));
                    evaluated += 1;
                }
            }
        }
    }
    assert_eq!(evaluated, 9 * 12 * 7 * 3);
}

#[test]
fn strokes_out_of_range_and_bad_numbers_are_errors_naming_the_cylinder() {
    let twin = twin();
    let err = twin
        .evaluate(&inputs(121.0, 210.0, 900.0, 40.6, -10.0))
        .unwrap_err();
    assert!(
        matches!(
            err,
            TwinError::StrokeOutOfRange {
                cylinder: CylinderName::Boom,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(
        err.to_string().contains("boom cylinder stroke 900 mm"),
        "{err}"
    );
    let err = twin
        .evaluate(&inputs(-5.0, 210.0, 467.0, 40.6, -10.0))
        .unwrap_err();
    assert!(err.to_string().starts_with("bucket cylinder"), "{err}");
    let err = twin
        .evaluate(&inputs(121.0, f64::NAN, 467.0, 40.6, -10.0))
        .unwrap_err();
    assert!(matches!(err, TwinError::InvalidInput(_)), "{err:?}");
}

#[test]
fn a_stroke_at_a_dead_centre_is_refused_with_the_cylinder_named() {
    // Widen the boom cylinder's range past the linkage: A, C and D line up
    // (the boom straight above its cylinder) where the cylinder is as long
    // as |AC| + |AD|, by the closed form.
    let mut geometry = Geometry::dx55();
    let norm = |p: [f64; 2]| p[0].hypot(p[1]);
    let in_line_mm = (norm(geometry.base.boom_cylinder_pin_m)
        + norm(geometry.boom.boom_cylinder_pin_m)
        - geometry.cylinder.boom.retracted_length_m)
        * 1e3;
    geometry.cylinder.boom.stroke_range_mm = [0.0, in_line_mm + 200.0];
    let twin = Excavator::new(geometry).unwrap();
    // Just short of the line (inside the dead-centre margin), and beyond
    // it (the linkage cannot be assembled).
    for stroke in [in_line_mm - 0.5, in_line_mm + 100.0] {
        let err = twin
            .evaluate(&inputs(121.0, 210.0, stroke, 40.6, -10.0))
            .unwrap_err();
        assert_eq!(
            err,
            TwinError::DeadCentre {
                cylinder: CylinderName::Boom,
                stroke_mm: stroke
            }
        );
    }
    assert!(twin
        .evaluate(&inputs(121.0, 210.0, 467.0, 40.6, -10.0))
        .is_ok());
}

/// Work of the external loads (gravity, tip) per metre of one cylinder's
/// stroke, by a fourth-order central difference of the load points.
fn external_work_per_metre(twin: &Excavator, base: &Inputs, cylinder: CylinderName) -> f64 {
    let h_mm = 0.01;
    let positions = |offset_mm: f64| {
        let mut moved = *base;
        moved
            .strokes
            .set(cylinder, base.strokes.get(cylinder) + offset_mm);
        let pose = twin.pose(&moved.strokes).unwrap();
        twin.loads(&pose, &moved)
    };
    let (p2, p1, m1, m2) = (
        positions(2.0 * h_mm),
        positions(h_mm),
        positions(-h_mm),
        positions(-2.0 * h_mm),
    );
    let h_m = h_mm * 1e-3;
    let mut work = 0.0;
    for k in 0..p1.len() {
        let velocity =
            (-p2[k].at_m + p1[k].at_m * 8.0 - m1[k].at_m * 8.0 + m2[k].at_m) / (12.0 * h_m);
        work += p1[k].force_n.dot(&velocity);
    }
    work
}

#[test]
fn virtual_work_of_each_cylinder_balances_the_loads_to_1e_9() {
    let twin = twin();
    for case in ["case1.toml", "case2.toml"] {
        let base = CaseFile::load(&data(case)).unwrap().nominal();
        let evaluation = twin.evaluate(&base).unwrap();
        for cylinder in CylinderName::ALL {
            // A stroke increase dS under the oil force F does F dS of work;
            // in equilibrium the loads do the opposite.
            let oil_n = evaluation.cylinder(cylinder).axial_force_kn * 1e3;
            let loads = external_work_per_metre(&twin, &base, cylinder);
            let relative = (oil_n + loads).abs() / oil_n.abs();
            assert!(
                relative < 1e-9,
                "{case} {cylinder}: oil {oil_n} N vs loads {loads} N/m, relative {relative:e}"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn every_body_is_in_equilibrium_and_the_frame_models_balance(
        bucket in 100.0..400.0f64,
        arm in 0.0..550.0f64,
        boom in 250.0..650.0f64,
        force in 0.0..80.0f64,
        angle in -180.0..180.0f64,
    ) {
        let twin = twin();
        let inputs = inputs(bucket, arm, boom, force, angle);
        let e = twin.evaluate(&inputs).unwrap();
        let loads = twin.loads(&e.pose, &inputs);
        let scale = e.reactions.hinge_force_n.iter().map(|f| f.norm()).fold(1.0, f64::max);
        for body in Body::ALL {
            let (force, moment) = e.reactions.resultant(&e.pose, &loads, body);
            prop_assert!(force.norm() < 1e-9 * scale, "{body:?}: net force {force:?} N");
            // Moments about the origin: arms up to ~6 m.
            prop_assert!(moment.abs() < 1e-9 * scale * 6.0, "{body:?}: net moment {moment} N m");
        }
        // The frame models carry exactly the loads the statics put on them:
        // the pin and roller that hold them react nothing.
        prop_assert!(e.boom.support_reaction_ratio < 1e-9, "boom {}", e.boom.support_reaction_ratio);
        prop_assert!(e.arm.support_reaction_ratio < 1e-9, "arm {}", e.arm.support_reaction_ratio);
        // The loaded chamber follows the force's sign.
        for c in &e.cylinders {
            let expected = if c.axial_force_kn >= 0.0 { Chamber::Head } else { Chamber::Rod };
            prop_assert_eq!(c.loaded_chamber, expected);
        }
    }
}

#[test]
fn pressure_is_the_axial_force_over_the_loaded_area() {
    let twin = twin();
    let e = twin
        .evaluate(&CaseFile::load(&data("case2.toml")).unwrap().nominal())
        .unwrap();
    let boom = e.cylinder(CylinderName::Boom);
    assert_eq!(
        boom.loaded_chamber,
        Chamber::Rod,
        "Case 2 pulls the boom cylinder"
    );
    let bore = |name: CylinderName| twin.geometry().cylinder(name).bore_mm;
    let annulus_mm2 =
        std::f64::consts::PI / 4.0 * (bore(CylinderName::Boom).powi(2) - 60.0f64.powi(2));
    let expected_bar = boom.axial_force_kn.abs() * 1e3 / annulus_mm2 * 10.0;
    assert!((boom.loaded_chamber_pressure_bar - expected_bar).abs() < 1e-9 * expected_bar);
    let arm = e.cylinder(CylinderName::Arm);
    let head_mm2 = std::f64::consts::PI / 4.0 * bore(CylinderName::Arm).powi(2);
    assert_eq!(arm.loaded_chamber, Chamber::Head);
    assert!(
        (arm.loaded_chamber_pressure_bar - arm.axial_force_kn * 1e3 / head_mm2 * 10.0).abs() < 1e-9
    );
}

#[test]
fn symmetric_side_gauges_read_the_same_and_the_tip_load_moves_the_stresses() {
    let twin = twin();
    let case = CaseFile::load(&data("case1.toml")).unwrap();
    let loaded = twin.evaluate(&case.nominal()).unwrap();
    let stress = |e: &acq_twins::excavator::Evaluation, point: u32| {
        e.gauges
            .iter()
            .find(|g| g.point == point)
            .unwrap()
            .stress_mpa
    };
    assert_eq!(loaded.gauges.len(), 18);
    assert_eq!(stress(&loaded, 3), stress(&loaded, 4));
    let mut unloaded_inputs = case.nominal();
    unloaded_inputs.tip_force_kn = 0.0;
    let unloaded = twin.evaluate(&unloaded_inputs).unwrap();
    assert!(loaded.arm.max_von_mises_mpa > 2.0 * unloaded.arm.max_von_mises_mpa);
    assert!(loaded.arm.max_von_mises_mpa < twin.geometry().material.yield_strength_mpa);
}

#[test]
fn the_frame_models_weigh_what_the_file_says() {
    // Box plates by hand from the file's sections (trapezoid rule on the
    // area, which is quadratic along the taper, so only close) plus the
    // attached masses.
    let twin = twin();
    let geometry = twin.geometry();
    let density = geometry.material.density_kg_m3;
    let by_hand = |s: &acq_twins::excavator::geometry::Structure| -> f64 {
        let area = |t: &acq_twins::excavator::geometry::Station| {
            2.0 * t.width_m * t.flange_thickness_m
                + 2.0 * (t.height_m - 2.0 * t.flange_thickness_m) * t.web_thickness_m
        };
        let plates: f64 = s
            .section
            .windows(2)
            .map(|pair| {
                0.5 * (area(&pair[0]) + area(&pair[1])) * (pair[1].station_m - pair[0].station_m)
            })
            .sum::<f64>()
            * density;
        plates + s.attached_mass.iter().map(|m| m.mass_kg).sum::<f64>()
    };
    let (boom_kg, arm_kg) = twin.structure_masses_kg();
    let boom_expected = by_hand(&geometry.boom.structure);
    let arm_expected = by_hand(&geometry.arm.structure);
    assert!(
        (boom_kg - boom_expected).abs() < 5.0,
        "boom {boom_kg} kg vs {boom_expected}"
    );
    assert!(
        (arm_kg - arm_expected).abs() < 5.0,
        "arm {arm_kg} kg vs {arm_expected}"
    );
}

#[test]
fn geometry_and_case_errors_name_the_problem() {
    let bad = Geometry::parse(&acq_twins::excavator::geometry::DX55_TOML.replace(
        "[cylinder.boom]\nbore_mm = ",
        "[cylinder.boom]\nbore_mm = -1.0 # ",
    ))
    .unwrap_err();
    assert!(
        bad.contains("cylinder.boom.bore_mm must be positive"),
        "{bad}"
    );
    let typo = Geometry::parse(
        &acq_twins::excavator::geometry::DX55_TOML
            .replace("rod_mm = 60.0", "rod_diameter_mm = 60.0"),
    )
    .unwrap_err();
    assert!(
        typo.contains("rod_diameter_mm") && typo.contains("line"),
        "{typo}"
    );
    let case = std::fs::read_to_string(data("case1.toml")).unwrap();
    let err =
        CaseFile::parse(&case.replace("arm_stroke_mm = [205, 215]", "arm_stroke_mm = [215, 205]"))
            .unwrap_err();
    assert!(err.contains("bounds.arm_stroke_mm"), "{err}");
    let err = CaseFile::parse(&case.replace("force_kN = 40.6", "force_kn = 40.6")).unwrap_err();
    assert!(err.contains("force_kn"), "{err}");
}

#[test]
fn a_pressure_above_the_relief_is_reported_as_its_excess() {
    let mut geometry = Geometry::load(&data("dx55.toml")).unwrap();
    let mut case2 = CaseFile::load(&data("case2.toml")).unwrap().nominal();
    case2.tip_force_kn = 41.0;
    let e = Excavator::new(geometry.clone())
        .unwrap()
        .evaluate(&case2)
        .unwrap();
    let relief = geometry.relief_pressure_bar.unwrap();
    for c in &e.cylinders {
        let excess = (c.loaded_chamber_pressure_bar - relief).max(0.0);
        assert_eq!(c.over_relief_bar, Some(excess));
    }
    assert!(
        e.cylinders.iter().any(|c| c.over_relief_bar.unwrap() > 0.0),
        "the 41 kN working load in the Case-2 pose is beyond the relief"
    );
    geometry.relief_pressure_bar = None;
    let e = Excavator::new(geometry).unwrap().evaluate(&case2).unwrap();
    assert!(e.cylinders.iter().all(|c| c.over_relief_bar.is_none()));
}

#[test]
fn the_working_envelope_is_the_extreme_of_a_dense_stroke_grid() {
    // Independently of the envelope's own search: a dense grid over the
    // strokes (41 per cylinder) never beats it, and comes within a few
    // millimetres of it (the grid's spacing).
    use acq_twins::excavator::envelope::working_envelope;
    use acq_twins::excavator::kinematics::Pose;
    let geometry = Geometry::load(&data("dx55.toml")).unwrap();
    let envelope = working_envelope(&geometry).unwrap();
    let height = geometry.base.foot_pin_above_ground_m.unwrap();
    let ahead = geometry.base.foot_pin_ahead_of_swing_axis_m.unwrap();
    let range = |name: CylinderName| geometry.cylinder(name).stroke_range_mm;
    let steps = 40;
    let at = |name: CylinderName, k: usize| {
        let [low, high] = range(name);
        low + (high - low) * k as f64 / steps as f64
    };
    let (mut reach, mut depth, mut dump) = (f64::MIN, f64::MIN, f64::MIN);
    for i in 0..=steps {
        for j in 0..=steps {
            for k in 0..=steps {
                let strokes = Strokes {
                    boom_mm: at(CylinderName::Boom, i),
                    arm_mm: at(CylinderName::Arm, j),
                    bucket_mm: at(CylinderName::Bucket, k),
                };
                let Ok(pose) = Pose::solve(&geometry, &strokes) else {
                    continue;
                };
                reach = reach.max(ahead + pose.j.x);
                depth = depth.max(-pose.j.y - height);
            }
        }
    }
    // The dump height's maximum lies on the curve where J comes level with
    // G, which a grid meets only between its points: a finer grid over
    // boom and arm (the bucket opened).
    let fine = 200;
    let at_fine = |name: CylinderName, k: usize| {
        let [low, high] = range(name);
        low + (high - low) * k as f64 / fine as f64
    };
    for i in 0..=fine {
        for j in 0..=fine {
            let strokes = Strokes {
                boom_mm: at_fine(CylinderName::Boom, i),
                arm_mm: at_fine(CylinderName::Arm, j),
                bucket_mm: range(CylinderName::Bucket)[0],
            };
            if let Ok(pose) = Pose::solve(&geometry, &strokes) {
                if pose.j.y <= pose.g.y {
                    dump = dump.max(height + pose.j.y);
                }
            }
        }
    }
    for (name, searched, grid, within) in [
        ("reach", envelope.max_reach_m, reach, 0.02),
        ("depth", envelope.max_digging_depth_m, depth, 0.02),
        ("dump height", envelope.max_dump_height_m, dump, 0.03),
    ] {
        assert!(
            grid <= searched + 1e-9,
            "{name}: grid {grid} beats {searched}"
        );
        assert!(
            searched - grid < within,
            "{name}: {searched} vs grid {grid}"
        );
    }
    let dumped = Pose::solve(&geometry, &envelope.dump_strokes).unwrap();
    assert!(dumped.j.y <= dumped.g.y + 1e-12);
    assert!((height + dumped.j.y - envelope.max_dump_height_m).abs() < 1e-12);
    // The strokes it names give the value it names.
    let pose = Pose::solve(&geometry, &envelope.reach_strokes).unwrap();
    assert!((ahead + pose.j.x - envelope.max_reach_m).abs() < 1e-12);
    // Without A's place on the machine there is no envelope, and the
    // error says what to add.
    let mut unplaced = geometry.clone();
    unplaced.base.foot_pin_above_ground_m = None;
    let error = working_envelope(&unplaced).unwrap_err().to_string();
    assert!(error.contains("base.foot_pin_above_ground_m"), "{error}");
}

/// A twin re-weighed in place of rebuilt (the rig's sampler changes only
/// masses from step to step) evaluates to the bit as one built from the
/// file with those masses; a number that is not a mass is refused.
#[test]
fn a_twin_reweighed_equals_one_built_with_the_masses() {
    use acq_twins::excavator::geometry::GeometryTemplate;
    let template =
        GeometryTemplate::parse(&std::fs::read_to_string(data("dx55.toml")).unwrap()).unwrap();
    let base = Excavator::new(template.with(&[]).unwrap()).unwrap();
    let sets: [&[(&str, f64)]; 3] = [
        &[
            ("bucket.mass_kg", 215.0),
            ("bucket.centre_of_mass_m[0]", 0.42),
        ],
        &[
            ("boom.structure.attached_mass[4].mass_kg", 70.0),
            ("arm.structure.attached_mass[5].mass_kg", 0.0),
            ("side_link.mass_kg", 9.0),
            ("cylinder.arm.rod_mass_kg", 31.0),
        ],
        &[
            ("bucket.centre_of_mass_m[1]", -0.1),
            ("connecting_link.mass_kg", 12.5),
            ("cylinder.boom.barrel_mass_kg", 60.0),
        ],
    ];
    for values in sets {
        let reweighed = base.with_masses(values).unwrap();
        let built = Excavator::new(template.with(values).unwrap()).unwrap();
        assert_eq!(reweighed.structure_masses_kg(), built.structure_masses_kg());
        for case in [
            inputs(300.0, 400.0, 500.0, 40.0, -10.0),
            inputs(100.0, 550.0, 200.0, 5.0, 30.0),
        ] {
            assert_eq!(
                reweighed.evaluate(&case).unwrap(),
                built.evaluate(&case).unwrap(),
                "{values:?}"
            );
        }
    }
    for (path, value) in [
        ("boom.arm_pin_m[0]", 2.9),
        ("bucket.mass_kg", -1.0),
        ("bucket.mass_kg", f64::NAN),
        ("boom.structure.attached_mass[99].mass_kg", 1.0),
    ] {
        let err = base.with_masses(&[(path, value)]).unwrap_err().to_string();
        assert!(err.contains(path), "{path}: {err}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// What the rig's transducers see, from unit-load responses superposed
    /// ([`Excavator::measurable_at`]), equals the full evaluation's
    /// back-substitution to rounding: the cylinders to the bit (the same
    /// statics), every gauge within 1e-9 of the largest section force. On
    /// a re-weighed twin, whose bodies share the base twin's responses.
    #[test]
    fn the_gauges_by_superposition_equal_the_frame_solved(
        bucket in 100.0..400.0f64,
        arm in 0.0..550.0f64,
        boom in 250.0..650.0f64,
        force in 0.0..80.0f64,
        angle in -180.0..180.0f64,
        bucket_kg in 80.0..350.0f64,
        boom_attached_kg in 0.0..200.0f64,
        arm_attached_kg in 0.0..120.0f64,
    ) {
        let base = twin();
        let reweighed = base
            .with_masses(&[
                ("bucket.mass_kg", bucket_kg),
                ("boom.structure.attached_mass[4].mass_kg", boom_attached_kg),
                ("arm.structure.attached_mass[5].mass_kg", arm_attached_kg),
            ])
            .unwrap();
        let case = inputs(bucket, arm, boom, force, angle);
        let prepared = reweighed.prepare(&case.strokes).unwrap();
        let full = reweighed.evaluate_at(&prepared, &case).unwrap();
        let seen = reweighed.measurable_at(&prepared, &case).unwrap();
        prop_assert_eq!(seen.pose, full.pose);
        prop_assert_eq!(seen.cylinders, full.cylinders);
        prop_assert_eq!(seen.gauges.len(), full.gauges.len());
        let largest = |f: fn(&acq_twins::excavator::structure::GaugeReading) -> f64| {
            full.gauges.iter().map(|g| f(g).abs()).fold(1e-3, f64::max)
        };
        let axial_scale = largest(|g| g.axial_force_kn);
        let moment_scale = largest(|g| g.bending_moment_knm);
        let stress_scale = largest(|g| g.stress_mpa);
        for (s, f) in seen.gauges.iter().zip(&full.gauges) {
            prop_assert_eq!(s.point, f.point);
            prop_assert!((s.axial_force_kn - f.axial_force_kn).abs() <= 1e-9 * axial_scale, "{s:?} vs {f:?}");
            prop_assert!((s.bending_moment_knm - f.bending_moment_knm).abs() <= 1e-9 * moment_scale, "{s:?} vs {f:?}");
            prop_assert!((s.stress_mpa - f.stress_mpa).abs() <= 1e-9 * stress_scale, "{s:?} vs {f:?}");
        }
    }
}
