//! Helpers shared by the acq-can integration tests.
// Each test crate uses a different subset of these.
#![allow(dead_code)]

use acq_can::dbc::PhysicalValue;
use acq_can::{CanId, Direction, Frame, IfaceName};
use proptest::prelude::*;

pub fn can_id() -> impl Strategy<Value = CanId> {
    prop_oneof![
        (0..=0x7FFu16).prop_map(CanId::Standard),
        (0..=0x1FFF_FFFFu32).prop_map(CanId::Extended),
    ]
}

/// Any valid frame at a time and on an interface the strategies give:
/// classic data (with a raw DLC 9-F on some 8-byte ones), remote (the
/// same), CAN FD with any flags nibble, error frames; with or without a
/// direction.
pub fn any_frame<T, I>(time: T, iface: I) -> impl Strategy<Value = Frame>
where
    T: Strategy<Value = i64> + Clone + 'static,
    I: Strategy<Value = IfaceName> + Clone + 'static,
{
    let data = (
        time.clone(),
        iface.clone(),
        can_id(),
        prop::collection::vec(any::<u8>(), 0..=8),
        prop::option::of(9..=15u8),
    )
        .prop_map(|(ts, iface, id, payload, len8)| {
            let mut frame = Frame::data(ts, iface, id, &payload).unwrap();
            if let (8, Some(dlc)) = (payload.len(), len8) {
                frame.set_len8_dlc(dlc).unwrap();
            }
            frame
        });
    let remote = (
        time.clone(),
        iface.clone(),
        can_id(),
        0..=8u8,
        prop::option::of(9..=15u8),
    )
        .prop_map(|(ts, iface, id, requested, len8)| {
            let mut frame = Frame::remote(ts, iface, id, requested).unwrap();
            if let (8, Some(dlc)) = (requested, len8) {
                frame.set_len8_dlc(dlc).unwrap();
            }
            frame
        });
    let fd = (
        time.clone(),
        iface.clone(),
        can_id(),
        0..=15u8,
        prop::collection::vec(any::<u8>(), 0..=64),
    )
        .prop_map(|(ts, iface, id, flags, payload)| {
            Frame::fd(ts, iface, id, flags, &payload).unwrap()
        });
    let error = (time, iface, 0..=0x1FFF_FFFFu32, any::<[u8; 8]>())
        .prop_map(|(ts, iface, class, details)| Frame::error(ts, iface, class, &details).unwrap());
    let direction = prop::option::of(prop_oneof![
        Just(Direction::Received),
        Just(Direction::Transmitted)
    ]);
    (prop_oneof![data, remote, fd, error], direction).prop_map(|(mut frame, direction)| {
        frame.direction = direction;
        frame
    })
}

/// True when our value is the value Python's `repr` printed (cantools'
/// output): an int for an int, the same bits for a float.
pub fn same_value(ours: PhysicalValue, theirs: &str) -> bool {
    let is_python_int = theirs.bytes().all(|b| b.is_ascii_digit() || b == b'-');
    match ours {
        PhysicalValue::Integer(v) => is_python_int && theirs.parse::<i128>() == Ok(v),
        PhysicalValue::Float(v) => {
            let expected: f64 = match theirs {
                "nan" => f64::NAN,
                "inf" => f64::INFINITY,
                "-inf" => f64::NEG_INFINITY,
                text => text.parse().unwrap(),
            };
            !is_python_int
                && (v.to_bits() == expected.to_bits() || (v.is_nan() && expected.is_nan()))
        }
    }
}

#[path = "../../../../tests/common/peers.rs"]
mod peers;

/// The python of the peers' scratch virtualenv NAME
/// (tests/peers/venvs/NAME.txt), under cargo's `CARGO_TARGET_TMPDIR` as
/// the root's tests have them.
pub fn peer_python(name: &str) -> std::path::PathBuf {
    let repo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    peers::peer_python(
        &repo,
        std::path::Path::new(env!("CARGO_TARGET_TMPDIR")),
        name,
    )
}
