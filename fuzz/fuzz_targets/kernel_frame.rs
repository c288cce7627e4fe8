//! `kernel::parse` on arbitrary socket bytes: never panics, and a frame it
//! accepts encodes back to bytes that parse to the same frame.

#![no_main]

use acq_can::kernel;
use acq_can::IfaceName;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let iface = IfaceName::new("vcan0").expect("valid name");
    let Ok(frame) = kernel::parse(data, iface, 1) else {
        return;
    };
    let (bytes, size) = kernel::encode(&frame);
    assert_eq!(size, data.len(), "the MTU is kept");
    let again = kernel::parse(&bytes[..size], iface, 1).expect("encoded bytes parse");
    assert_eq!(again, frame);
});
