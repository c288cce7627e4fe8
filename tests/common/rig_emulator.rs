//! The stand-in user's solver of fixtures/rig-emulator (boom.sh), run as
//! the truth behind a hold: shared by tests/rig_study.rs and
//! benches/rig_emulator.rs.

use std::path::Path;

/// boom.sh in `dir` at `truth` (its eight parameters in order) for one
/// hold's conditions: the four gauge stresses, by name.
pub fn user_solver(
    dir: &Path,
    truth: &[f64; 8],
    incl_deg: f64,
    force_kn: f64,
) -> serde_json::Value {
    let out = dir.join("truth-out.json");
    let mut args: Vec<String> = vec!["boom.sh".into()];
    args.extend(truth.iter().map(|x| x.to_string()));
    args.extend([incl_deg.to_string(), force_kn.to_string()]);
    args.push(out.display().to_string());
    let status = std::process::Command::new("sh")
        .args(&args)
        .current_dir(dir)
        .status()
        .unwrap();
    assert!(status.success(), "boom.sh failed");
    serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap()
}
