//! The report of `acq twin excavator`: one evaluation of the excavator twin as
//! text tables (pose, cylinder pressures, pin forces, gauge stresses) and as
//! the fixed `--json` object.

use acq_twins::excavator::case::CaseFile;
use acq_twins::excavator::envelope::WorkingEnvelope;
use acq_twins::excavator::kinematics::Pose;
use acq_twins::excavator::structure::GaugeReading;
use acq_twins::excavator::{
    CylinderName, CylinderResult, Evaluation, Excavator, Inputs, Measurables,
};

/// The fixed `--json` object.
pub fn evaluation_json(evaluation: &Evaluation) -> serde_json::Value {
    let mut json = outputs_json(&evaluation.pose, &evaluation.cylinders, &evaluation.gauges);
    json["max_von_mises_MPa"] = serde_json::json!({"boom": evaluation.boom.max_von_mises_mpa, "arm": evaluation.arm.max_von_mises_mpa});
    json
}

/// [`evaluation_json`] of what the rig's transducers see: the same keys
/// but `max_von_mises_MPa`.
pub fn measurables_json(measurables: &Measurables) -> serde_json::Value {
    outputs_json(
        &measurables.pose,
        &measurables.cylinders,
        &measurables.gauges,
    )
}

/// One number of [`measurables_json`] by its key path, read without
/// making the JSON (a study at the rig reads a few per run, millions of
/// runs an hour). `None` for a path it does not know: look in the JSON
/// then, which also says what there is.
pub fn measurable_number(measurables: &Measurables, key_path: &str) -> Option<f64> {
    let cylinder = |name: &str| -> Option<&CylinderResult> {
        let name = CylinderName::ALL.into_iter().find(|c| c.as_str() == name)?;
        Some(&measurables.cylinders[name.index()])
    };
    let (head, rest) = key_path.split_once(['.', '['])?;
    match head {
        "pressure_bar" => cylinder(rest).map(|c| c.loaded_chamber_pressure_bar),
        "cylinder_force_kN" => cylinder(rest).map(|c| c.axial_force_kn),
        "pressure_over_relief_bar" => cylinder(rest).and_then(|c| c.over_relief_bar),
        "gauge_stress_MPa" => {
            let index: usize = rest.strip_suffix(']')?.parse().ok()?;
            measurables.gauges.get(index).map(|g| g.stress_mpa)
        }
        "points" => {
            let (point, axis) = rest.split_once('[')?;
            let axis: usize = axis.strip_suffix(']')?.parse().ok()?;
            let pose = &measurables.pose;
            let at = match point {
                "A" => pose.a,
                "B" => pose.b,
                "G" => pose.g,
                "J" => pose.j,
                _ => return None,
            };
            (axis < 2).then(|| at[axis])
        }
        _ => None,
    }
}

fn outputs_json(
    pose: &Pose,
    cylinders: &[CylinderResult; 3],
    gauges: &[GaugeReading],
) -> serde_json::Value {
    let point = |p: &acq_twins::excavator::kinematics::Vec2| serde_json::json!([p.x, p.y]);
    let per_cylinder = |f: &dyn Fn(&CylinderResult) -> f64| {
        let of = |name: CylinderName| f(&cylinders[name.index()]);
        serde_json::json!({"bucket": of(CylinderName::Bucket), "arm": of(CylinderName::Arm), "boom": of(CylinderName::Boom)})
    };
    serde_json::json!({
        "points": {"A": point(&pose.a), "B": point(&pose.b), "G": point(&pose.g), "J": point(&pose.j)},
        "pressure_bar": per_cylinder(&|c| c.loaded_chamber_pressure_bar),
        "cylinder_force_kN": per_cylinder(&|c| c.axial_force_kn),
        "gauge_stress_MPa": gauges.iter().map(|g| g.stress_mpa).collect::<Vec<_>>(),
    })
}

/// The working envelope as `acq twin excavator --envelope --json` writes it.
pub fn envelope_json(envelope: &WorkingEnvelope) -> serde_json::Value {
    let strokes = |s: &acq_twins::excavator::Strokes| serde_json::json!({"bucket_mm": s.bucket_mm, "arm_mm": s.arm_mm, "boom_mm": s.boom_mm});
    serde_json::json!({
        "envelope": {
            "max_reach_m": envelope.max_reach_m,
            "max_digging_depth_m": envelope.max_digging_depth_m,
            "max_dump_height_m": envelope.max_dump_height_m,
            "strokes": {
                "max_reach": strokes(&envelope.reach_strokes),
                "max_digging_depth": strokes(&envelope.depth_strokes),
                "max_dump_height": strokes(&envelope.dump_strokes),
            }
        }
    })
}

pub fn evaluation_report(
    case: &CaseFile,
    inputs: &Inputs,
    twin: &Excavator,
    evaluation: &Evaluation,
) -> String {
    use std::fmt::Write as _;
    let mut text = String::new();
    let s = &inputs.strokes;
    let _ = writeln!(text, "{} on {}", case.name, twin.geometry().name);
    let _ = writeln!(
        text,
        "inputs: bucket {} mm, arm {} mm, boom {} mm; tip force {} kN at {} deg\n",
        s.bucket_mm, s.arm_mm, s.boom_mm, inputs.tip_force_kn, inputs.tip_force_angle_deg
    );
    let _ = writeln!(
        text,
        "point  Y m      Z m      measured Y, Z       error mm"
    );
    let pose = &evaluation.pose;
    let measured = case.measured_points;
    for (name, p, m) in [
        ("A", pose.a, None),
        ("B", pose.b, measured.map(|m| m.B)),
        ("G", pose.g, measured.map(|m| m.G)),
        ("J", pose.j, measured.map(|m| m.J)),
    ] {
        match m {
            Some([y, z]) => {
                let error_mm = (p.x - y).hypot(p.y - z) * 1e3;
                let _ = writeln!(
                    text,
                    "{name:<6} {:<8.4} {:<8.4} {y:<8.3} {z:<10.3} {error_mm:.1}",
                    p.x, p.y
                );
            }
            None => {
                let _ = writeln!(text, "{name:<6} {:<8.4} {:<8.4}", p.x, p.y);
            }
        }
    }
    let _ = writeln!(
        text,
        "\ncylinder  force kN  chamber  pressure bar  measured bar  error %"
    );
    for name in CylinderName::ALL {
        let c = evaluation.cylinder(name);
        let chamber = match c.loaded_chamber {
            acq_twins::excavator::Chamber::Head => "head",
            acq_twins::excavator::Chamber::Rod => "rod",
        };
        let _ = write!(
            text,
            "{:<9} {:<9.2} {chamber:<8} {:<13.2}",
            name.as_str(),
            c.axial_force_kn,
            c.loaded_chamber_pressure_bar
        );
        if let Some(measured) = case.measured.map(|m| m.get(name)) {
            let error = (measured - c.loaded_chamber_pressure_bar).abs() / measured.abs() * 100.0;
            let _ = write!(text, " {measured:<13.2} {error:.2}");
        }
        text.push('\n');
    }
    if let Some(relief) = twin.geometry().relief_pressure_bar {
        for name in CylinderName::ALL {
            let c = evaluation.cylinder(name);
            if c.over_relief_bar.is_some_and(|over| over > 0.0) {
                let _ = writeln!(
                    text,
                    "warning: the {name} cylinder needs {:.0} bar, above the relief pressure of {relief:.0} bar: the machine could not hold this load",
                    c.loaded_chamber_pressure_bar
                );
            }
        }
    }
    let _ = writeln!(
        text,
        "\npin                 force on       from           Y kN      Z kN      |F| kN"
    );
    for (hinge, force) in acq_twins::excavator::statics::HINGES
        .iter()
        .zip(&evaluation.reactions.hinge_force_n)
    {
        let from = hinge.from.map_or("base".to_string(), |body| body.label());
        let _ = writeln!(
            text,
            "{:<19} {:<14} {:<14} {:<9.2} {:<9.2} {:.2}",
            hinge.pin.label(),
            hinge.on.label(),
            from,
            force.x * 1e-3,
            force.y * 1e-3,
            force.norm() * 1e-3
        );
    }
    let _ = writeln!(
        text,
        "\npoint  axial kN   moment kN m  stress MPa  (tension +; moment + compresses the top)"
    );
    for g in &evaluation.gauges {
        let _ = writeln!(
            text,
            "{:<6} {:<10.2} {:<12.3} {:.2}",
            g.point, g.axial_force_kn, g.bending_moment_knm, g.stress_mpa
        );
    }
    let yield_mpa = twin.geometry().material.yield_strength_mpa;
    let _ = writeln!(
        text,
        "\nmax von Mises: boom {:.2} MPa, arm {:.2} MPa (yield {yield_mpa} MPa)",
        evaluation.boom.max_von_mises_mpa, evaluation.arm.max_von_mises_mpa
    );
    text
}
