//! A study at the rig on holds the virtual rig computes from the twin at a
//! known truth: the levels every sensor reads (`virtual_rig::hold_levels`),
//! each hold's mean off by its standard error, as `acq extract` gives it.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use acq_analysis::extract::measured::MeasuredValue;
use acq_analysis::extract::quantities::RigQuantities;
use acq_rig::Rig;
use acq_twins::excavator::geometry::GeometryTemplate;
use acq_twins::excavator::inclinations::Inclinations;
use acq_workflows::rig_study::tracker::Tracker;
use acq_workflows::rig_study::RigStudy;
use acq_workflows::virtual_rig::{hold_levels, synthetic_hold, RigSensors, TestPoint};
use rand::SeedableRng;

const STUDY: &str = "../examples/excavator-rig/study.toml";

fn rig() -> RigQuantities {
    RigQuantities::of(&Rig::load(Path::new("../fixtures/rigs/excavator.toml")).unwrap())
}

/// The hidden truth: every parameter of the example off its prior's value.
const TRUTH: [(&str, f64); 4] = [
    ("bucket.mass_kg", 215.0),
    ("bucket.centre_of_mass_m[0]", 0.42),
    ("boom.structure.attached_mass[4].mass_kg", 70.0),
    ("arm.structure.attached_mass[5].mass_kg", 25.0),
];

/// What `acq extract` gives for a hold at `point` of the twin at `truth`.
fn hold(
    rig: &RigQuantities,
    truth: &[(&str, f64)],
    point: &TestPoint,
    rng: &mut rand_chacha::ChaCha8Rng,
) -> Vec<MeasuredValue> {
    let geometry =
        GeometryTemplate::parse(&std::fs::read_to_string("../data/excavator/dx55.toml").unwrap())
            .unwrap()
            .with(truth)
            .unwrap();
    let sensors = RigSensors::of_rig(
        rig,
        "tip_force",
        ["boom_inclination", "arm_inclination", "bucket_inclination"],
    );
    let levels = hold_levels(&geometry, &sensors, &BTreeMap::new(), point).unwrap();
    synthetic_hold(rig, &levels, 600, rng)
}

/// The test point of a candidate of the study.
fn candidate_point(study: &RigStudy, values: &[f64]) -> TestPoint {
    let value = |name: &str| {
        let k = study
            .candidates
            .names
            .iter()
            .position(|n| n == name)
            .unwrap();
        values[k]
    };
    TestPoint {
        inclinations: Inclinations {
            boom_deg: value("boom_inclination_deg"),
            arm_deg: value("arm_inclination_deg"),
            bucket_deg: value("bucket_inclination_deg"),
        },
        tip_force_kn: value("force_kN"),
        tip_force_angle_deg: -10.0,
    }
}

#[test]
fn the_example_loads_with_reachable_candidates() {
    let study = RigStudy::load(Path::new(STUDY), &rig()).unwrap();
    assert!(study.candidates.points.len() > 50);
    assert!(
        study.candidates.dropped > 0,
        "some grid poses are out of reach"
    );
}

/// Four holds at candidates spread over the envelope: every parameter's
/// 90 % interval holds the truth, and the bucket's mass is identified.
#[test]
fn holds_at_a_known_truth_narrow_every_interval_around_it() {
    let rig = rig();
    let study = Arc::new(RigStudy::load(Path::new(STUDY), &rig).unwrap());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let candidates = &study.candidates.points;
    let points: Vec<TestPoint> = [
        0,
        candidates.len() / 3,
        2 * candidates.len() / 3,
        candidates.len() - 1,
    ]
    .iter()
    .map(|&k| candidate_point(&study, &candidates[k]))
    .collect();
    let holds: Vec<(String, Vec<MeasuredValue>)> = points
        .iter()
        .enumerate()
        .map(|(k, p)| (format!("hold{}", k + 1), hold(&rig, &TRUTH, p, &mut rng)))
        .collect();
    let mut tracker = Tracker::new(study.clone());
    let mut panels = Vec::new();
    let start = std::time::Instant::now();
    let mut last = Instant::now();
    tracker.update(&holds, &mut |panel| {
        eprintln!(
            "update: {:.2} s, posterior {:.2} s",
            last.elapsed().as_secs_f64(),
            panel.json["wall_s"].as_f64().unwrap_or(0.0)
        );
        last = Instant::now();
        panels.push(panel.clone())
    });
    eprintln!(
        "{} holds in {:.2} s",
        holds.len(),
        start.elapsed().as_secs_f64()
    );
    assert_eq!(panels.len(), holds.len());
    for line in &panels.last().unwrap().words {
        eprintln!("{line}");
    }
    let posterior = tracker.posterior().unwrap();
    assert_eq!(posterior.holds_used, 4);
    for (p, (name, truth)) in posterior.parameters.iter().zip(TRUTH) {
        assert_eq!(p.name, name);
        assert!(
            p.q05 <= truth && truth <= p.q95,
            "{name}: truth {truth} outside [{}, {}]",
            p.q05,
            p.q95
        );
    }
    // The bucket's mass moves every cylinder's force at every pose: four
    // holds pin it down.
    assert!(
        posterior.parameters[0].width_ratio() < 0.5,
        "{:?}",
        posterior.parameters[0]
    );
    let json = &panels.last().unwrap().json;
    assert_eq!(json["holds_used"], 4);
    assert!(json["next"]["inputs"]["boom_inclination_deg"].is_number());
    assert!(json["parameters"]["bucket.mass_kg"]["q05"].is_number());
}

/// No study file panics the loader: any entry of `[holds.inputs]`,
/// `[holds.observe]` or `[candidates]` replaced by any TOML value (numbers
/// out of range or not finite, strings, lists, tables, nested junk) gives
/// a study or an error, never a panic.
mod careless_input {
    use super::*;
    use proptest::prelude::*;

    fn value() -> impl Strategy<Value = String> {
        let leaf = prop_oneof![
            any::<f64>().prop_map(|x| format!("{x:?}").replace("inf", "inf").replace("NaN", "nan")),
            any::<i64>().prop_map(|x| x.to_string()),
            "[a-z_\\[\\]0-9.]{0,12}".prop_map(|s| format!("{s:?}")),
            Just("{ from = 1e308, to = -1e308, steps = 100000 }".to_string()),
            Just("{ from = 0.0, to = 1.0, steps = 0 }".to_string()),
            Just("[]".to_string()),
            Just("{ quantity = \"tip_force\", uncertainty = -1.0 }".to_string()),
            Just("{ quantity = \"sg01\", instrument = nan }".to_string()),
            Just("{ quantity = 3 }".to_string()),
            Just("true".to_string()),
        ];
        leaf.prop_recursive(2, 8, 4, |inner| {
            prop_oneof![
                prop::collection::vec(inner.clone(), 0..4)
                    .prop_map(|v| format!("[{}]", v.join(", "))),
                (inner.clone(), inner)
                    .prop_map(|(a, b)| format!("{{ quantity = {a}, uncertainty = {b} }}")),
            ]
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
        #[test]
        fn any_entry_gives_a_study_or_an_error(line in 0usize..14, replacement in value()) {
            let geometry = std::fs::canonicalize("../data/excavator/dx55.toml").unwrap();
            let text = std::fs::read_to_string(STUDY).unwrap().replace(
                "\"../../data/excavator/dx55.toml\"",
                &format!("{geometry:?}"),
            );
            // The entries of [holds.inputs], [holds.observe] and [candidates].
            let entries: Vec<usize> = text
                .lines()
                .enumerate()
                .filter(|(_, l)| l.contains(" = ") && (l.contains("_deg") || l.contains("force_kN") || l.starts_with('"')))
                .map(|(k, _)| k)
                .collect();
            prop_assert!(entries.len() >= 12, "the example's entries: {entries:?}");
            let target = entries[line % entries.len()];
            let changed: Vec<String> = text
                .lines()
                .enumerate()
                .map(|(k, l)| {
                    if k == target {
                        let key = l.split(" = ").next().unwrap();
                        format!("{key} = {replacement}")
                    } else {
                        l.to_string()
                    }
                })
                .collect();
            let dir = tempfile::tempdir().unwrap();
            // The file as it is loads: what fails below fails for the entry.
            let path = dir.path().join("as_is.toml");
            std::fs::write(&path, &text).unwrap();
            prop_assert!(RigStudy::load(&path, &rig()).is_ok());
            let path = dir.path().join("study.toml");
            std::fs::write(&path, changed.join("\n")).unwrap();
            let _ = RigStudy::load(&path, &rig());
        }
    }
}
