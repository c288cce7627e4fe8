//! The rig route on arbitrary traffic: no panic, no non-finite value, and
//! frames matched to buses by interface.

use std::path::Path;

use acq_can::j1939_tp::bam_frames;
use acq_can::{CanId, Frame, IfaceName};
use acq_rig::sensors::{FrameUse, SensorDecoder, SensorEvent};
use acq_rig::Rig;
use proptest::prelude::*;

fn excavator() -> Rig {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    Rig::load(&root.join("fixtures/rigs/excavator.toml")).unwrap()
}

fn iface(name: &str) -> IfaceName {
    IfaceName::new(name).unwrap()
}

#[test]
fn frames_match_buses_by_interface() {
    let rig = excavator();
    let mut decoder = SensorDecoder::new(&rig);
    let pressure = Frame::data(
        0,
        iface("can0"),
        CanId::Standard(0x1A5),
        &7335i32.to_le_bytes(),
    )
    .unwrap();
    let mut samples = Vec::new();
    let used = decoder.decode(&pressure, |e| samples.push(e));
    assert_eq!(used, FrameUse::Decoded);
    let SensorEvent::Sample(sample) = samples[0] else {
        panic!("{samples:?}")
    };
    assert_eq!(
        (rig.sensors[sample.sensor].name.as_str(), sample.value),
        ("boom_head_pressure", Some(73.35))
    );
    // The same id on the DAQ bus, or on a bus the rig does not have, is no sensor.
    for other in ["can1", "can7"] {
        let frame = Frame::data(0, iface(other), CanId::Standard(0x1A5), &[0; 8]).unwrap();
        assert_eq!(decoder.decode(&frame, |_| {}), FrameUse::Unknown, "{other}");
    }
    // A PDO too short for its mapping is undecodable, not a value.
    let short = Frame::data(0, iface("can0"), CanId::Standard(0x1A5), &[1, 2]).unwrap();
    assert_eq!(decoder.decode(&short, |_| {}), FrameUse::Undecodable);
}

#[test]
fn heartbeat_loss_is_reported_once_per_silence() {
    let rig = excavator();
    let mut decoder = SensorDecoder::new(&rig);
    let beat = |t: i64| Frame::data(t, iface("can0"), CanId::Standard(0x725), &[0x05]).unwrap();
    let mut events = Vec::new();
    decoder.decode(&beat(0), |e| events.push(e));
    decoder.check_heartbeats(2_000_000_000, |e| events.push(e));
    let losses = |events: &[SensorEvent]| {
        events
            .iter()
            .filter(|e| {
                matches!(
                    e,
                    SensorEvent::Heartbeat {
                        event: acq_can::canopen::HeartbeatEvent::Lost { node: 0x25, .. },
                        ..
                    }
                )
            })
            .count()
    };
    assert_eq!(losses(&events), 0, "within 3 periods");
    decoder.check_heartbeats(3_100_000_000, |e| events.push(e));
    decoder.check_heartbeats(4_000_000_000, |e| events.push(e));
    assert_eq!(losses(&events), 1);
}

proptest! {
    #[test]
    fn arbitrary_frames_never_panic_or_give_non_finite_values(
        frames in proptest::collection::vec(
            (0u8..3, any::<bool>(), any::<u32>(), proptest::collection::vec(any::<u8>(), 0..=8), any::<i64>()),
            1..200,
        )
    ) {
        let rig = excavator();
        let mut decoder = SensorDecoder::new(&rig);
        for (bus, extended, raw_id, payload, time) in frames {
            let id = if extended { CanId::Extended(raw_id & 0x1FFF_FFFF) } else { CanId::Standard((raw_id & 0x7FF) as u16) };
            let frame = Frame::data(time, iface(["can0", "can1", "vcan9"][usize::from(bus)]), id, &payload).unwrap();
            decoder.decode(&frame, |event| {
                if let SensorEvent::Sample(sample) = event {
                    assert!(sample.value.is_none_or(f64::is_finite), "{sample:?}");
                }
            });
            decoder.check_heartbeats(time, |_| {});
        }
    }
}

/// A rig whose inclination comes in a 20-byte J1939 parameter group, by the
/// transport protocol: 24 bits at byte 10 (past the first 8 bytes).
fn long_pgn_rig() -> Rig {
    let text = r#"
[[bus]]
name = "hydraulics"
iface = "can0"
bitrate = 250000

[[sensor]]
name = "boom_inclination"
kind = "inclination"
bus = "hydraulics"
rate_hz = 10
j1939 = { pgn = 65000, source_address = 0xE2, start_bit = 80, length_bits = 24, resolution = 3.0517578125e-5, offset = -250.0 }
"#;
    Rig::parse(text, Path::new("long_pgn.toml"), Path::new(".")).unwrap()
}

#[test]
fn a_j1939_group_longer_than_8_bytes_is_reassembled_and_decoded() {
    let rig = long_pgn_rig();
    let mut decoder = SensorDecoder::new(&rig);
    // 12.5 deg = (raw * 2^-15) - 250  ->  raw = 8_601_600 = 0x834000.
    let mut data = vec![0xFFu8; 20];
    data[10..13].copy_from_slice(&[0x00, 0x40, 0x83]);
    let mut uses = Vec::new();
    let mut samples = Vec::new();
    for (k, (id, payload)) in bam_frames(65000, 7, 0xE2, &data)
        .unwrap()
        .into_iter()
        .enumerate()
    {
        let frame = Frame::data(k as i64 * 50_000_000, iface("can0"), id, &payload).unwrap();
        uses.push(decoder.decode(&frame, |e| {
            if let SensorEvent::Sample(sample) = e {
                samples.push(sample);
            }
        }));
    }
    // The announcement and the first two packets are protocol; the last
    // packet completes the group and gives the value, at its time.
    assert_eq!(
        uses,
        [
            FrameUse::Protocol,
            FrameUse::Protocol,
            FrameUse::Protocol,
            FrameUse::Decoded
        ]
    );
    assert_eq!(samples.len(), 1);
    assert_eq!(samples[0].time_ns, 150_000_000);
    assert_eq!(samples[0].value, Some(12.5));
    // From another source address it is no value of this sensor.
    let mut decoder = SensorDecoder::new(&rig);
    let mut other = 0;
    for (id, payload) in bam_frames(65000, 7, 0xE3, &data).unwrap() {
        let frame = Frame::data(0, iface("can0"), id, &payload).unwrap();
        decoder.decode(&frame, |e| {
            other += usize::from(matches!(e, SensorEvent::Sample(_)))
        });
    }
    assert_eq!(other, 0);
}
