//! J1939 transport protocol (J1939-21): parameter groups longer than 8
//! bytes travel as a connection-management frame (TP.CM, PGN 0xEC00) and
//! numbered data-transfer frames (TP.DT, PGN 0xEB00) of 7 bytes each. This
//! puts them back together.
//!
//! - **BAM** (broadcast announce, TP.CM control byte 32, to the global
//!   address): size (u16, 9-1785 bytes), packet count, 0xFF, PGN (u24), all
//!   little-endian; then the TP.DT packets 1..=count to the global address.
//! - **RTS/CTS** (control bytes 16 and 17, between two addresses): the
//!   sender's RTS announces size, packets and PGN; the receiver's CTS frames
//!   pace it; the TP.DT packets go to the receiver. acq only listens, so it
//!   follows the packets whatever the pacing; the end-of-message
//!   acknowledgement (19) needs no action.
//! - **Abort** (255) from either side drops the session.
//!
//! A session is one (sender, destination) pair: a new announcement replaces
//! an unfinished one, a packet out of sequence drops it, and so does a gap
//! of more than [`T1_NS`] between packets (J1939-21's T1, 750 ms). The
//! reassembled payload is cut to the announced size (the last packet's
//! padding bytes are 0xFF on the wire).

use crate::frame::CanId;
use crate::j1939::{J1939Id, GLOBAL_ADDRESS};

/// PGN of the connection-management frames.
pub const TP_CM_PGN: u32 = 0xEC00;
/// PGN of the data-transfer frames.
pub const TP_DT_PGN: u32 = 0xEB00;
/// Longest gap between two packets of one message (J1939-21 T1).
pub const T1_NS: i64 = 750_000_000;

const BAM: u8 = 32;
const RTS: u8 = 16;
const ABORT: u8 = 255;
const MIN_SIZE: usize = 9;
const MAX_SIZE: usize = 1785;
const PACKET_BYTES: usize = 7;

/// A parameter group put back together.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Reassembled {
    pub pgn: u32,
    pub source_address: u8,
    /// [`GLOBAL_ADDRESS`] for a BAM.
    pub destination_address: u8,
    pub data: Vec<u8>,
}

#[derive(Clone, Debug)]
struct Session {
    source_address: u8,
    destination_address: u8,
    pgn: u32,
    size: usize,
    packets: u8,
    next_sequence: u8,
    last_ns: i64,
    data: Vec<u8>,
}

/// The sessions under way on one bus.
#[derive(Clone, Debug, Default)]
pub struct Reassembler {
    sessions: Vec<Session>,
}

impl Reassembler {
    /// Feeds one frame; a TP.DT frame that completes a message returns it.
    /// Frames of other PGNs are ignored.
    pub fn on_frame(&mut self, id: J1939Id, payload: &[u8], time_ns: i64) -> Option<Reassembled> {
        match id.pgn {
            TP_CM_PGN => {
                self.on_connection_management(id, payload, time_ns);
                None
            }
            TP_DT_PGN => self.on_data_transfer(id, payload, time_ns),
            _ => None,
        }
    }

    fn position(&self, source: u8, destination: u8) -> Option<usize> {
        self.sessions
            .iter()
            .position(|s| s.source_address == source && s.destination_address == destination)
    }

    fn drop_session(&mut self, source: u8, destination: u8) {
        if let Some(index) = self.position(source, destination) {
            self.sessions.swap_remove(index);
        }
    }

    fn on_connection_management(&mut self, id: J1939Id, payload: &[u8], time_ns: i64) {
        let Some(&control) = payload.first() else {
            return;
        };
        match control {
            BAM | RTS => {
                let destination = if control == BAM {
                    GLOBAL_ADDRESS
                } else {
                    id.destination_address
                };
                // A new announcement replaces what the pair had under way.
                self.drop_session(id.source_address, destination);
                let (Some(size), Some(&packets), Some(pgn)) = (
                    payload
                        .get(1..3)
                        .map(|b| usize::from(u16::from_le_bytes([b[0], b[1]]))),
                    payload.get(3),
                    payload
                        .get(5..8)
                        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], 0])),
                ) else {
                    return;
                };
                let consistent = (MIN_SIZE..=MAX_SIZE).contains(&size)
                    && usize::from(packets) == size.div_ceil(PACKET_BYTES)
                    && (control == RTS || id.destination_address == GLOBAL_ADDRESS);
                if consistent {
                    self.sessions.push(Session {
                        source_address: id.source_address,
                        destination_address: destination,
                        pgn,
                        size,
                        packets,
                        next_sequence: 1,
                        last_ns: time_ns,
                        data: Vec::with_capacity(usize::from(packets) * PACKET_BYTES),
                    });
                }
            }
            ABORT => {
                // Either side may abort: the receiver's abort names the
                // sender as its destination.
                self.drop_session(id.source_address, id.destination_address);
                self.drop_session(id.destination_address, id.source_address);
            }
            _ => {} // CTS and end-of-message acknowledgement: only pacing
        }
    }

    fn on_data_transfer(
        &mut self,
        id: J1939Id,
        payload: &[u8],
        time_ns: i64,
    ) -> Option<Reassembled> {
        let index = self.position(id.source_address, id.destination_address)?;
        let session = &mut self.sessions[index];
        let in_time = time_ns.saturating_sub(session.last_ns) <= T1_NS;
        let (Some(&sequence), Some(bytes)) = (payload.first(), payload.get(1..)) else {
            self.sessions.swap_remove(index);
            return None;
        };
        if !in_time || sequence != session.next_sequence || bytes.len() < PACKET_BYTES {
            self.sessions.swap_remove(index);
            return None;
        }
        session.data.extend_from_slice(&bytes[..PACKET_BYTES]);
        session.last_ns = time_ns;
        if sequence < session.packets {
            session.next_sequence = sequence + 1;
            return None;
        }
        let mut done = self.sessions.swap_remove(index);
        done.data.truncate(done.size);
        Some(Reassembled {
            pgn: done.pgn,
            source_address: done.source_address,
            destination_address: done.destination_address,
            data: done.data,
        })
    }
}

/// The frames of a BAM of `data` (9-1785 bytes) as parameter group `pgn`
/// from `source_address`: `(id, payload)` of the TP.CM then each TP.DT, the
/// last packet padded with 0xFF. None for a size out of range or an id that
/// cannot be built (priority above 7, PGN over 18 bits).
pub fn bam_frames(
    pgn: u32,
    priority: u8,
    source_address: u8,
    data: &[u8],
) -> Option<Vec<(CanId, [u8; 8])>> {
    if !(MIN_SIZE..=MAX_SIZE).contains(&data.len()) || pgn > 0x3_FFFF {
        return None;
    }
    let to_all = |pgn| {
        J1939Id {
            priority,
            pgn,
            source_address,
            destination_address: GLOBAL_ADDRESS,
        }
        .to_can_id()
    };
    let size = (data.len() as u16).to_le_bytes();
    let group = pgn.to_le_bytes();
    let packets = data.len().div_ceil(PACKET_BYTES) as u8;
    let mut frames = vec![(
        to_all(TP_CM_PGN)?,
        [
            BAM, size[0], size[1], packets, 0xFF, group[0], group[1], group[2],
        ],
    )];
    let transfer = to_all(TP_DT_PGN)?;
    for (index, chunk) in data.chunks(PACKET_BYTES).enumerate() {
        let mut payload = [0xFF; 8];
        payload[0] = index as u8 + 1;
        payload[1..=chunk.len()].copy_from_slice(chunk);
        frames.push((transfer, payload));
    }
    Some(frames)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(pgn: u32, source: u8, destination: u8) -> J1939Id {
        J1939Id {
            priority: 7,
            pgn,
            source_address: source,
            destination_address: destination,
        }
    }

    /// The frames of a BAM of `data` (PGN `pgn`) from `source`, ids split.
    fn bam(pgn: u32, source: u8, data: &[u8]) -> Vec<(J1939Id, Vec<u8>)> {
        bam_frames(pgn, 7, source, data)
            .unwrap()
            .into_iter()
            .map(|(id, payload)| (J1939Id::from_can_id(id).unwrap(), payload.to_vec()))
            .collect()
    }

    fn feed(
        reassembler: &mut Reassembler,
        frames: &[(J1939Id, Vec<u8>)],
        step_ns: i64,
    ) -> Vec<Reassembled> {
        frames
            .iter()
            .enumerate()
            .filter_map(|(k, (id, payload))| reassembler.on_frame(*id, payload, k as i64 * step_ns))
            .collect()
    }

    #[test]
    fn a_bam_comes_back_whole_and_cut_to_its_size() {
        let data: Vec<u8> = (0..20).collect();
        let mut reassembler = Reassembler::default();
        let done = feed(&mut reassembler, &bam(0xFEE3, 0x00, &data), 50_000_000);
        assert_eq!(
            done,
            [Reassembled {
                pgn: 0xFEE3,
                source_address: 0x00,
                destination_address: GLOBAL_ADDRESS,
                data
            }]
        );
        assert!(reassembler.sessions.is_empty());
    }

    #[test]
    fn rts_cts_follows_the_packets_to_the_receiver() {
        let data: Vec<u8> = (100..116).collect(); // 16 bytes, 3 packets
        let (sender, receiver) = (0x21, 0x3D);
        let mut frames = vec![
            (
                id(TP_CM_PGN, sender, receiver),
                vec![RTS, 16, 0, 3, 3, 0x00, 0xCA, 0x00],
            ),
            // The receiver's CTS: pacing only.
            (
                id(TP_CM_PGN, receiver, sender),
                vec![17, 3, 1, 0xFF, 0xFF, 0x00, 0xCA, 0x00],
            ),
        ];
        for (k, chunk) in data.chunks(7).enumerate() {
            let mut payload = vec![k as u8 + 1];
            payload.extend_from_slice(chunk);
            payload.resize(8, 0xFF);
            frames.push((id(TP_DT_PGN, sender, receiver), payload));
        }
        let mut reassembler = Reassembler::default();
        let done = feed(&mut reassembler, &frames, 1_000_000);
        assert_eq!(done.len(), 1);
        assert_eq!(done[0].pgn, 0xCA00);
        assert_eq!(done[0].destination_address, receiver);
        assert_eq!(done[0].data, data);
    }

    #[test]
    fn gaps_aborts_and_bad_announcements_give_nothing() {
        let data: Vec<u8> = (0..20).collect();
        let frames = bam(0xFEE3, 0x00, &data);
        // A packet lost.
        let mut lost = frames.clone();
        lost.remove(2);
        assert!(feed(&mut Reassembler::default(), &lost, 1_000).is_empty());
        // Packets more than T1 apart.
        assert!(feed(&mut Reassembler::default(), &frames, T1_NS + 1).is_empty());
        // An abort before the last packet.
        let mut aborted = frames.clone();
        aborted.insert(
            3,
            (
                id(TP_CM_PGN, 0x00, GLOBAL_ADDRESS),
                vec![ABORT, 1, 0xFF, 0xFF, 0xFF, 0xE3, 0xFE, 0x00],
            ),
        );
        assert!(feed(&mut Reassembler::default(), &aborted, 1_000).is_empty());
        // A packet count that does not match the size.
        let mut wrong = frames.clone();
        wrong[0].1[3] = 4;
        assert!(feed(&mut Reassembler::default(), &wrong, 1_000).is_empty());
        // Truncated and empty frames.
        let mut reassembler = Reassembler::default();
        for payload in [&[][..], &[BAM][..], &[BAM, 20][..], &[1][..]] {
            assert!(reassembler
                .on_frame(id(TP_CM_PGN, 0, GLOBAL_ADDRESS), payload, 0)
                .is_none());
            assert!(reassembler
                .on_frame(id(TP_DT_PGN, 0, GLOBAL_ADDRESS), payload, 0)
                .is_none());
        }
    }

    proptest::proptest! {
        #[test]
        fn any_group_of_9_to_1785_bytes_comes_back(
            data in proptest::collection::vec(proptest::prelude::any::<u8>(), 9..=1785),
            source in proptest::prelude::any::<u8>(),
        ) {
            let done = feed(&mut Reassembler::default(), &bam(0x1_FEE3, source, &data), 10_000_000);
            proptest::prop_assert_eq!(done.len(), 1);
            proptest::prop_assert_eq!(&done[0].data, &data);
            proptest::prop_assert_eq!(done[0].pgn, 0x1_FEE3);
        }

        #[test]
        fn arbitrary_frames_never_panic(
            frames in proptest::collection::vec(
                (proptest::prelude::any::<bool>(), proptest::prelude::any::<u8>(), proptest::prelude::any::<u8>(),
                 proptest::collection::vec(proptest::prelude::any::<u8>(), 0..9), 0i64..2_000_000_000),
                0..60)
        ) {
            let mut reassembler = Reassembler::default();
            for (cm, source, destination, payload, time) in frames {
                let pgn = if cm { TP_CM_PGN } else { TP_DT_PGN };
                if let Some(done) = reassembler.on_frame(id(pgn, source, destination), &payload, time) {
                    proptest::prop_assert!((MIN_SIZE..=MAX_SIZE).contains(&done.data.len()));
                }
            }
        }
    }

    #[test]
    fn two_senders_interleave() {
        let a: Vec<u8> = (0..9).collect();
        let b: Vec<u8> = (50..80).collect();
        let (fa, fb) = (bam(0xFEE3, 0x01, &a), bam(0xFECA, 0x02, &b));
        let mut frames = Vec::new();
        for k in 0..fa.len().max(fb.len()) {
            frames.extend(fa.get(k).cloned());
            frames.extend(fb.get(k).cloned());
        }
        let done = feed(&mut Reassembler::default(), &frames, 1_000);
        assert_eq!(done.len(), 2);
        assert_eq!((done[0].source_address, &done[0].data), (0x01, &a));
        assert_eq!((done[1].source_address, &done[1].data), (0x02, &b));
    }
}
