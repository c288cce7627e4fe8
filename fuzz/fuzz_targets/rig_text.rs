//! `Rig::parse` on arbitrary UTF-8: every section and sensor record
//! (certificate points fitted by least squares, accuracy, resolution),
//! then each sensor's conversion inverted and the budget arithmetic run
//! on a rig that loads. DBC files it names are not found (no base
//! directory), which is one of the errors it must report.

#![no_main]

use acq_rig::Rig;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|text: &str| {
    let Ok(rig) = Rig::parse(text, Path::new("fuzz.toml"), Path::new("/nonexistent")) else {
        return;
    };
    for sensor in &rig.sensors {
        let _ = sensor.conversion.invert(1.0);
        if let Some(curve) = &sensor.record.curve {
            let reading = curve.reading_at(1.0);
            let _ = curve.standard_uncertainty_at(reading);
        }
    }
});
