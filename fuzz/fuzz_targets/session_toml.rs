//! A session directory's own files over arbitrary text: `session.toml`
//! (and the rig copy's path it names, which must stay inside the
//! session), `zero.toml` and `shunt.toml`, each read as every command
//! reads them. None may panic. (Seed: a shipped session's session.toml.)

#![no_main]

use std::sync::OnceLock;

use acq_io::{session, shunt_record, zero_record};
use libfuzzer_sys::fuzz_target;

/// One directory for the whole run: each input rewrites its files.
fn dir() -> &'static std::path::Path {
    static DIR: OnceLock<std::path::PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("acq-fuzz-session-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    })
}

fuzz_target!(|text: &str| {
    let dir = dir();
    for name in [
        session::SESSION_FILE,
        zero_record::ZERO_FILE,
        shunt_record::SHUNT_FILE,
    ] {
        std::fs::write(dir.join(name), text).unwrap();
    }
    if let Ok(read) = session::read(dir) {
        if let Some(copy) = &read.rig {
            if let Ok(path) = acq_io::output::inside(dir, &copy.file.copy, "copy") {
                assert!(path.starts_with(dir));
            }
        }
    }
    if let Ok(Some(zero)) = zero_record::read(dir) {
        for sensor in &zero.sensors {
            let _ = (
                sensor.offset(),
                sensor.zero_return(),
                sensor.before.std_of_mean(),
            );
        }
    }
    let _ = shunt_record::read(dir);
});
