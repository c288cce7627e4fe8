//! The shipped DX55-class geometry against the published test, and the
//! statics against virtual work and equilibrium.

use std::path::PathBuf;

use acq_twins::excavator::case::CaseFile;
use acq_twins::excavator::geometry::Geometry;
use acq_twins::excavator::Excavator;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../data/excavator")
        .join(name)
}

fn twin() -> Excavator {
    Excavator::new(Geometry::load(&data("dx55.toml")).unwrap()).unwrap()
}

#[test]
fn print_cases() {
    let twin = twin();
    for file in ["case1.toml", "case2.toml"] {
        let case = CaseFile::load(&data(file)).unwrap();
        let e = twin.evaluate(&case.nominal()).unwrap();
        println!("{file}: B {:?} G {:?} J {:?}", e.pose.b, e.pose.g, e.pose.j);
        for c in &e.cylinders {
            println!("  {:?}", c);
        }
        println!("  gauges {:?}", e.gauge_stress_mpa);
        println!(
            "  boom vm {} arm vm {} reac {} {}",
            e.boom.max_von_mises_mpa,
            e.arm.max_von_mises_mpa,
            e.boom.support_reaction_ratio,
            e.arm.support_reaction_ratio
        );
        println!("  masses {:?}", twin.structure_masses_kg());
    }
}
