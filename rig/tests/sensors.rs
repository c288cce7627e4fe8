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
    // Every heartbeat of the rig's own node is its protocol (the page
    // lists it as such, not as "no sensor of the rig"), the first (a
    // change of state) and the ones after (none).
    assert_eq!(
        decoder.decode(&beat(0), |e| events.push(e)),
        FrameUse::Protocol
    );
    assert_eq!(
        decoder.decode(&beat(500_000_000), |e| events.push(e)),
        FrameUse::Protocol
    );
    let stranger = Frame::data(0, iface("can0"), CanId::Standard(0x77F), &[0x05]).unwrap();
    assert_eq!(decoder.decode(&stranger, |_| {}), FrameUse::Unknown);
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

proptest! {
    /// A batch decodes as its frames one by one: the same events in the
    /// same order, each with its frame's index. The frames mix the
    /// excavator's ids (DBC, CANopen PDOs and heartbeats) with strangers,
    /// remote and error frames and J1939 transport packets, on its two
    /// buses and an interface it does not have.
    #[test]
    fn a_batch_decodes_as_its_frames_one_by_one(
        frames in proptest::collection::vec(
            (0u8..3, 0u8..5, any::<u32>(), proptest::collection::vec(any::<u8>(), 0..=8), 0i64..10_000_000_000),
            1..300,
        )
    ) {
        let rig = excavator();
        // PDOs and heartbeats of nodes 0x21 and 0x26, two DAQ messages;
        // inclinations (PGN 61481) from 0xE2 and 0xE3, a BAM and a packet.
        let known_ids = [0x1A1, 0x1A6, 0x721, 0x726, 0x300, 0x315];
        let known_extended = [0x18F0_29E2, 0x18F0_29E3, 0x1CEC_FFE2, 0x1CEB_FFE2];
        let frames: Vec<Frame> = frames
            .into_iter()
            .map(|(bus, kind, raw, payload, time)| {
                let on = iface(["can0", "can1", "vcan9"][usize::from(bus)]);
                match kind {
                    0 => Frame::data(time, on, CanId::Standard(known_ids[raw as usize % known_ids.len()]), &payload),
                    1 => Frame::data(time, on, CanId::Standard((raw & 0x7FF) as u16), &payload),
                    2 if raw % 2 == 0 => Frame::data(time, on, CanId::Extended(known_extended[(raw / 2) as usize % 4]), &payload),
                    2 => Frame::data(time, on, CanId::Extended(raw & 0x1FFF_FFFF), &payload),
                    3 => Frame::remote(time, on, CanId::Standard((raw & 0x7FF) as u16), (raw % 9) as u8),
                    _ => Frame::error(time, on, raw & 0xFF, &payload),
                }
                .unwrap()
            })
            .collect();
        let mut one_by_one = Vec::new();
        let mut decoder = SensorDecoder::new(&rig);
        for (index, frame) in frames.iter().enumerate() {
            decoder.decode(frame, |event| one_by_one.push((index, event)));
        }
        let mut batch = acq_can::FrameBatch::default();
        for frame in &frames {
            batch.push(frame);
        }
        let mut batched = Vec::new();
        SensorDecoder::new(&rig).decode_batch(&batch, |index, event| batched.push((index, event)));
        prop_assert_eq!(batched, one_by_one);
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

/// One sensor's samples from one frame.
fn samples_of(rig: &Rig, frame: &Frame) -> Vec<(usize, Option<f64>)> {
    let mut decoder = SensorDecoder::new(rig);
    let mut samples = Vec::new();
    decoder.decode(frame, |event| {
        if let SensorEvent::Sample(sample) = event {
            samples.push((sample.sensor, sample.value));
        }
    });
    samples
}

#[test]
fn a_sensor_of_any_quantity_keeps_its_own_unit() {
    // An engine's speed (J1939 EEC1, SPN 190: 0.125 rpm a bit at byte 4)
    // and its coolant's temperature (ET1, SPN 110: 1 degC a bit, -40),
    // from the engine controller at source address 0x00.
    let text = r#"
[[bus]]
name = "machine"
iface = "can0"
bitrate = 250000
dbc = ["j1939_source_fe.dbc"]

[[sensor]]
name = "engine_speed"
kind = "other"
bus = "machine"
rate_hz = 100
dbc = { message = "EEC1", signal = "EngineSpeed" }

[[sensor]]
name = "coolant_temperature"
kind = "other"
unit = "degC"
bus = "machine"
rate_hz = 1
j1939 = { pgn = 65262, source_address = 0x00, start_bit = 0, length_bits = 8, resolution = 1.0, offset = -40.0 }
range = [-40, 210]
"#;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/dbc");
    let rig = Rig::parse(text, Path::new("engine.toml"), &root).unwrap();
    // The DBC signal states rpm; the rig file states degC; neither is
    // converted, for acq knows no physics of either.
    assert_eq!(rig.sensors[0].unit(), "rpm");
    assert_eq!(rig.sensors[1].unit(), "degC");
    assert!(!rig.sensors[0].zero_at_rest && !rig.sensors[1].zero_at_rest);
    // 1,500 rpm = 12,000 bits = 0x2EE0, little-endian at byte 3 (bit 24).
    // The DBC declares EEC1 from 0xFE at priority 3; the controller sends
    // from 0x00 at priority 6: a J1939 DBC matches by PGN, as `acq decode`
    // and asammdf match it.
    let eec1_from = |source_address: u32| {
        Frame::data(
            0,
            iface("can0"),
            CanId::extended(0x18F0_0400 | source_address).unwrap(),
            &[0xF0, 0x7D, 0x7D, 0xE0, 0x2E, 0x00, 0xF0, 0x7D],
        )
        .unwrap()
    };
    assert_eq!(samples_of(&rig, &eec1_from(0x00)), [(0, Some(1500.0))]);
    assert_eq!(samples_of(&rig, &eec1_from(0xFE)), [(0, Some(1500.0))]);
    // Taken from one controller only, another's frames are none of its.
    let one_source = text.replace(
        r#"signal = "EngineSpeed" }"#,
        r#"signal = "EngineSpeed", source_address = 0x00 }"#,
    );
    let rig_one = Rig::parse(&one_source, Path::new("engine.toml"), &root).unwrap();
    assert_eq!(samples_of(&rig_one, &eec1_from(0x00)), [(0, Some(1500.0))]);
    assert_eq!(samples_of(&rig_one, &eec1_from(0x17)), []);
    // 85 degC = 125 bits.
    let et1 = Frame::data(
        0,
        iface("can0"),
        CanId::extended(0x18FE_EE00).unwrap(),
        &[125, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF],
    )
    .unwrap();
    assert_eq!(samples_of(&rig, &et1), [(1, Some(85.0))]);
}

#[test]
fn a_sensor_of_any_quantity_without_a_unit_is_refused_with_what_to_write() {
    let text = r#"
[[bus]]
name = "machine"
iface = "can0"
bitrate = 250000

[[sensor]]
name = "engine_speed"
kind = "other"
bus = "machine"
rate_hz = 100
j1939 = { pgn = 61444, source_address = 0x00, start_bit = 24, length_bits = 16, resolution = 0.125, offset = 0.0 }
"#;
    let error = Rig::parse(text, Path::new("engine.toml"), Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(error.contains("engine.toml:7"), "{error}");
    assert!(error.contains("kind \"other\" needs its unit"), "{error}");
    assert!(error.contains("unit = \"rpm\""), "{error}");
    // An empty unit says nothing either.
    let empty = text.replace("kind = \"other\"", "kind = \"other\"\nunit = \" \"");
    let error = Rig::parse(&empty, Path::new("engine.toml"), Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(error.contains("needs its unit"), "{error}");
}

#[test]
fn a_source_address_on_a_message_that_is_not_j1939_is_refused() {
    let text = r#"
[[bus]]
name = "daq"
iface = "can1"
bitrate = 500000
dbc = ["somat_excavator.dbc"]

[[sensor]]
name = "tip_force"
kind = "force"
bus = "daq"
rate_hz = 100
dbc = { message = "DAQ_Force", signal = "TipForce", source_address = 0x00 }
"#;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/dbc");
    let error = Rig::parse(text, Path::new("daq.toml"), &root)
        .unwrap_err()
        .to_string();
    assert!(error.contains("daq.toml:8"), "{error}");
    assert!(
        error.contains("source_address is for a J1939 message"),
        "{error}"
    );
    assert!(error.contains("remove source_address"), "{error}");
}
