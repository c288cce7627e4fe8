//! The view index reader (`view-index.bin`, beside a session) over
//! arbitrary bytes: it must never panic, and a view it accepts must be
//! drawable: its series, span, holds, sensors, curve and raw frames as JSON. (Seed: the
//! index `acq view` writes for the shipped tensile session.)

#![no_main]

use std::path::Path;
use std::sync::OnceLock;

use acq_view::model::SessionView;
use libfuzzer_sys::fuzz_target;

/// The tensile session's sensors, nothing in them yet.
fn fresh() -> &'static SessionView {
    static VIEW: OnceLock<SessionView> = OnceLock::new();
    VIEW.get_or_init(|| {
        let rig = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../fixtures/sessions/tensile_p91_20c/rig/tensile.toml");
        let rig = acq_rig::Rig::load(&rig).expect("the shipped rig");
        SessionView::new("fuzz", &rig, 0, 10_000_000, 16)
    })
}

fuzz_target!(|data: &[u8]| {
    if let Some((_, view)) = acq_view::index::parse(data, fresh().clone()) {
        let _ = view.span_s();
        let _ = view.series_json(-1e12, 1e12, 500);
        let _ = view.series_json(0.0, 1.0, 3);
        let _ = view.holds_json(None);
        let _ = view.sensors_json(Some("s"));
        let _ = view.xy_json();
        let _ = view.frames_json(None);
    }
});
