//! A calibration study's spec over arbitrary text, loaded and checked as
//! `acq calibrate external --spec` loads it before any model run: every
//! table, its checks and the study it assembles. Files it names are looked
//! for beside it (a temporary directory holding only the spec). None may
//! panic. (Seed: the CalculiX example's spec.)
//!
//! The built-in models (acq-workflows' `calibrate::models`) are stood in
//! for by a registry that takes every name with every key, so that the
//! spec's own tables and checks are fuzzed past the model: pulling
//! acq-workflows into this build compiled most of acq again with coverage
//! (the fuzz build went from about 30 s to 376 s, 2026-12-03). The
//! registry's own checks are property-tested in
//! workflows/tests/it/input_properties.rs.

#![no_main]

use std::sync::OnceLock;

use acq_study::spec::schema::{ModelName, SpecFile};
use acq_study::spec::{BuiltinKeys, BuiltinModel, BuiltinModels, KeyReader, Spec};
use libfuzzer_sys::fuzz_target;

fn spec_path() -> &'static std::path::Path {
    static PATH: OnceLock<std::path::PathBuf> = OnceLock::new();
    PATH.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("acq-fuzz-spec-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join("spec.toml")
    })
}

/// Every built-in name resolves, with the keys the spec gives.
struct AnyBuiltinModel;

impl BuiltinModels for AnyBuiltinModel {
    fn misplaced_key(&self, _: &SpecFile, _: KeyReader) -> Option<String> {
        None
    }
    fn resolve(&self, name: ModelName, file: &SpecFile) -> Result<BuiltinModel, String> {
        Ok(BuiltinModel {
            name,
            keys: BuiltinKeys::of(file),
            element_size_unit: "mm",
            curve_units: Some(["mm", "kN"]),
        })
    }
}

fuzz_target!(|text: &str| {
    let path = spec_path();
    std::fs::write(path, text).unwrap();
    if let Ok(spec) = Spec::load(path, &AnyBuiltinModel) {
        let _ = spec.method(1);
    }
});
