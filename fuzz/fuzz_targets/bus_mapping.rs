//! `BusMapping` (`--bus [FILES:]LOGGED=RIG`) from arbitrary text; a mapping
//! that parses must write back as text that parses to the same mapping,
//! and write back the same again.

#![no_main]

use acq_rig::BusMapping;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(mapping) = text.parse::<BusMapping>() else {
        return;
    };
    let written = mapping.to_string();
    let again: BusMapping = written
        .parse()
        .unwrap_or_else(|e| panic!("{text:?} was written as {written:?}, which does not parse: {e}"));
    assert_eq!(again, mapping, "{text:?}");
    assert_eq!(again.to_string(), written);
});
