//! `DbcDatabase::parse` on arbitrary UTF-8 (this runs the `can-dbc` parser
//! too), then every message of a database that loads is decoded from a
//! full and from a short payload.

#![no_main]

use acq_can::dbc::DbcDatabase;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|text: &str| {
    let Ok((database, _warnings)) = DbcDatabase::parse(text, "fuzz.dbc") else {
        return;
    };
    let full = [0xA5u8; 64];
    for message in database.messages() {
        for payload in [&full[..], &full[..message.size.min(64)], &full[..1]] {
            let _ = message.decode(payload, |_, value| {
                let _ = value.as_f64();
            });
            for index in 0..message.signals.len() {
                let _ = message.decode_signal(payload, index);
            }
        }
    }
});
