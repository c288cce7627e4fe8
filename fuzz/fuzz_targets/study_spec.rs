//! A calibration study's spec over arbitrary text, loaded and checked as
//! `acq calibrate external --spec` loads it before any model run: every
//! table, its checks and the study it assembles. Files it names are looked
//! for beside it (a temporary directory holding only the spec). None may
//! panic. (Seed: the CalculiX example's spec.)

#![no_main]

use std::sync::OnceLock;

use acq_study::spec::Spec;
use libfuzzer_sys::fuzz_target;

fn spec_path() -> &'static std::path::Path {
    static PATH: OnceLock<std::path::PathBuf> = OnceLock::new();
    PATH.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("acq-fuzz-spec-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join("spec.toml")
    })
}

fuzz_target!(|text: &str| {
    let path = spec_path();
    std::fs::write(path, text).unwrap();
    if let Ok(spec) = Spec::load(path) {
        let _ = spec.method(1);
    }
});
