//! SAE J1939: the 29-bit identifier, parameter groups and SPN values.
//!
//! An identifier splits into priority (3 bits), the parameter group number
//! (PGN: data page bits + PDU format + PDU specific), and the source address.
//! When the PDU format is below 240 (PDU1) the PDU-specific byte is a
//! destination address and not part of the PGN; from 240 up (PDU2) it is
//! a group extension and the message is broadcast.
//! SPN raw values at the top of their range mean "error" or "not available"
//! (J1939-71); those become missing samples, never numbers.

use crate::bits::BitField;
use crate::frame::CanId;

/// The global (broadcast) destination address.
pub const GLOBAL_ADDRESS: u8 = 0xFF;

/// The parts of a J1939 identifier.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct J1939Id {
    pub priority: u8,
    pub pgn: u32,
    pub source_address: u8,
    /// `GLOBAL_ADDRESS` for PDU2 (broadcast) messages.
    pub destination_address: u8,
}

impl J1939Id {
    /// Splits an extended id; J1939 uses only 29-bit ids.
    #[inline]
    pub fn from_can_id(id: CanId) -> Option<Self> {
        let CanId::Extended(raw) = id else {
            return None;
        };
        let priority = ((raw >> 26) & 0x7) as u8;
        let data_pages = (raw >> 24) & 0x3; // EDP and DP
        let pdu_format = (raw >> 16) & 0xFF;
        let pdu_specific = ((raw >> 8) & 0xFF) as u8;
        let source_address = (raw & 0xFF) as u8;
        let (pgn, destination_address) = if pdu_format < 240 {
            ((data_pages << 16) | (pdu_format << 8), pdu_specific)
        } else {
            (
                (data_pages << 16) | (pdu_format << 8) | u32::from(pdu_specific),
                GLOBAL_ADDRESS,
            )
        };
        Some(J1939Id {
            priority,
            pgn,
            source_address,
            destination_address,
        })
    }

    /// Builds the 29-bit id (the inverse of [`J1939Id::from_can_id`]).
    /// For a PDU1 PGN the destination goes in the PDU-specific byte.
    pub fn to_can_id(self) -> Option<CanId> {
        if self.priority > 7 || self.pgn > 0x3_FFFF {
            return None;
        }
        let pdu_format = (self.pgn >> 8) & 0xFF;
        let pdu_specific = if pdu_format < 240 {
            if self.pgn & 0xFF != 0 {
                return None; // a PDU1 PGN has a zero low byte
            }
            u32::from(self.destination_address)
        } else {
            self.pgn & 0xFF
        };
        let raw = (u32::from(self.priority) << 26)
            | ((self.pgn & 0x3_FF00) << 8)
            | (pdu_specific << 8)
            | u32::from(self.source_address);
        CanId::extended(raw)
    }
}

/// What an SPN's raw value means.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpnRaw {
    Valid(u64),
    /// The sender reports an error for this parameter.
    Error,
    /// The sender does not have the parameter.
    NotAvailable,
    /// In the reserved band between valid values and the error indicator.
    Reserved,
}

/// Classifies a raw value of `length_bits` bits by J1939-71's ranges.
///
/// Fields of 8 bits and more: the top byte 0xFB..=0xFD is reserved, 0xFE is
/// the error indicator, 0xFF "not available". Shorter discrete fields: all
/// ones is "not available", all ones but the lowest bit is "error".
pub fn classify(raw: u64, length_bits: u32) -> SpnRaw {
    if length_bits == 0 || length_bits > 64 {
        return SpnRaw::Reserved;
    }
    if length_bits < 8 {
        let all_ones = (1u64 << length_bits) - 1;
        return match raw {
            r if r == all_ones => SpnRaw::NotAvailable,
            r if length_bits >= 2 && r == all_ones - 1 => SpnRaw::Error,
            r => SpnRaw::Valid(r),
        };
    }
    match (raw >> (length_bits - 8)) & 0xFF {
        0xFF => SpnRaw::NotAvailable,
        0xFE => SpnRaw::Error,
        0xFB..=0xFD => SpnRaw::Reserved,
        _ => SpnRaw::Valid(raw),
    }
}

/// A suspect parameter: where it is in the PGN's data and how it scales.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spn {
    pub field: BitField,
    /// Physical units per bit.
    pub resolution: f64,
    pub offset: f64,
}

impl Spn {
    /// The physical value, or `None` when the payload is short or the
    /// sender marked it error / not available / reserved.
    #[inline]
    pub fn value(&self, payload: &[u8]) -> Option<f64> {
        match classify(self.field.extract(payload)?, self.field.length_bits()) {
            SpnRaw::Valid(raw) => Some(raw as f64 * self.resolution + self.offset),
            _ => None,
        }
    }

    /// Encodes a physical value (for simulators); `None` outside the valid range.
    pub fn encode(&self, value: f64, payload: &mut [u8]) -> Option<()> {
        let raw = ((value - self.offset) / self.resolution).round();
        if !(raw >= 0.0 && raw < 2f64.powi(self.field.length_bits() as i32)) {
            return None;
        }
        let raw = raw as u64;
        matches!(classify(raw, self.field.length_bits()), SpnRaw::Valid(_)).then_some(())?;
        self.field.insert(payload, raw)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_pdu2_and_pdu1_ids() {
        // EEC1 from the engine: priority 3, PGN 61444, SA 0.
        let eec1 = J1939Id::from_can_id(CanId::Extended(0x0CF0_0400)).unwrap();
        assert_eq!(
            eec1,
            J1939Id {
                priority: 3,
                pgn: 61444,
                source_address: 0,
                destination_address: 0xFF
            }
        );
        // Slope sensor information 2 (PGN 61481) from SA 0xE2.
        let ssi2 = J1939Id::from_can_id(CanId::Extended(0x18F0_29E2)).unwrap();
        assert_eq!((ssi2.pgn, ssi2.source_address), (61481, 0xE2));
        // PDU1: request (PGN 59904) to 0x21 from 0xF9.
        let request = J1939Id::from_can_id(CanId::Extended(0x18EA_21F9)).unwrap();
        assert_eq!(
            (
                request.pgn,
                request.destination_address,
                request.source_address
            ),
            (59904, 0x21, 0xF9)
        );
        assert_eq!(request.to_can_id(), Some(CanId::Extended(0x18EA_21F9)));
        assert_eq!(ssi2.to_can_id(), Some(CanId::Extended(0x18F0_29E2)));
        assert_eq!(J1939Id::from_can_id(CanId::Standard(0x123)), None);
    }

    #[test]
    fn not_available_and_error_are_not_numbers() {
        assert_eq!(classify(0xFF, 8), SpnRaw::NotAvailable);
        assert_eq!(classify(0xFE, 8), SpnRaw::Error);
        assert_eq!(classify(0xFA, 8), SpnRaw::Valid(0xFA));
        assert_eq!(classify(0xFFFF, 16), SpnRaw::NotAvailable);
        assert_eq!(classify(0xFE12, 16), SpnRaw::Error);
        assert_eq!(classify(0xFB00, 16), SpnRaw::Reserved);
        assert_eq!(classify(0xFA_FFFF, 24), SpnRaw::Valid(0xFA_FFFF));
        assert_eq!(classify(0b11, 2), SpnRaw::NotAvailable);
        assert_eq!(classify(0b10, 2), SpnRaw::Error);
        assert_eq!(classify(0b01, 2), SpnRaw::Valid(1));
        let pitch = Spn {
            field: BitField::little_endian_bytes(0, 24).unwrap(),
            resolution: 1.0 / 32768.0,
            offset: -250.0,
        };
        assert_eq!(pitch.value(&[0xFF, 0xFF, 0xFF, 0, 0, 0, 0, 0]), None);
        let mut payload = [0xFFu8; 8];
        pitch.encode(12.03, &mut payload).unwrap();
        let decoded = pitch.value(&payload).unwrap();
        assert!((decoded - 12.03).abs() <= 0.5 / 32768.0, "{decoded}");
    }
}
