//! Bit fields inside a CAN payload, in the two byte orders DBC files use.
//!
//! Shared by the DBC codec, CANopen PDO mapping and J1939 SPNs, so each
//! protocol describes *where* a value sits and this module alone knows *how*
//! to pull it out. A field is compiled once into the first byte, byte count
//! and shift, so extraction is nearly always one 8-byte load.

/// Byte order of a field.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ByteOrder {
    /// Intel: the start bit is the least significant bit; bit `i` is bit
    /// `i % 8` of byte `i / 8`.
    LittleEndian,
    /// Motorola: the start bit is the most significant bit, in DBC's
    /// "sawtooth" numbering (bit 7 of byte 0 is 7, bit 0 of byte 1 is 8).
    BigEndian,
}

/// A field of 1..=64 bits at a fixed place in the payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BitField {
    order: ByteOrder,
    length_bits: u8,
    first_byte: u8,
    byte_count: u8,
    /// Right shift that brings the field's LSB to bit 0 of the assembled word.
    shift: u8,
}

/// A field that cannot exist.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum BitFieldError {
    #[error("length of {0} bits is not in 1..=64")]
    BadLength(u64),
    #[error("start bit {start} with length {length} runs outside a 64-byte payload")]
    OutOfPayload { start: u64, length: u64 },
}

impl BitField {
    /// Compiles a DBC-style field (`start_bit|length@order`).
    pub fn new(order: ByteOrder, start_bit: u64, length_bits: u64) -> Result<Self, BitFieldError> {
        if !(1..=64).contains(&length_bits) {
            return Err(BitFieldError::BadLength(length_bits));
        }
        let outside = BitFieldError::OutOfPayload {
            start: start_bit,
            length: length_bits,
        };
        // Linear position of the first bit in the order's own numbering.
        let (first_linear, last_linear) = match order {
            ByteOrder::LittleEndian => (start_bit, start_bit + length_bits - 1),
            ByteOrder::BigEndian => {
                let msb = (start_bit / 8) * 8 + (7 - start_bit % 8);
                (msb, msb + length_bits - 1)
            }
        };
        if last_linear >= 64 * 8 {
            return Err(outside);
        }
        let first_byte = first_linear / 8;
        let last_byte = last_linear / 8;
        let byte_count = last_byte - first_byte + 1;
        let shift = match order {
            ByteOrder::LittleEndian => start_bit % 8,
            // Bits after the LSB in the last byte.
            ByteOrder::BigEndian => 7 - last_linear % 8,
        };
        Ok(BitField {
            order,
            length_bits: length_bits as u8,
            first_byte: first_byte as u8,
            byte_count: byte_count as u8,
            shift: shift as u8,
        })
    }

    /// Little-endian field starting at byte `byte` bit 0 (J1939 / CANopen style).
    pub fn little_endian_bytes(byte: usize, length_bits: u64) -> Result<Self, BitFieldError> {
        Self::new(ByteOrder::LittleEndian, byte as u64 * 8, length_bits)
    }

    pub fn length_bits(&self) -> u32 {
        u32::from(self.length_bits)
    }

    pub fn byte_order(&self) -> ByteOrder {
        self.order
    }

    /// Payload bytes needed to hold the field.
    #[inline]
    pub fn end_byte(&self) -> usize {
        usize::from(self.first_byte) + usize::from(self.byte_count)
    }

    /// The raw, unsigned field value; `None` if the payload is too short.
    #[inline]
    pub fn extract(&self, payload: &[u8]) -> Option<u64> {
        let (first, end) = (usize::from(self.first_byte), self.end_byte());
        if end > payload.len() {
            return None;
        }
        let mask = if self.length_bits == 64 {
            u64::MAX
        } else {
            (1u64 << self.length_bits) - 1
        };
        // Nearly every field lies in 8 bytes that the payload holds (a
        // classic frame's whole payload, or 8 from the field's first byte):
        // they are read in one load. A loop over the bytes, or a copy of
        // them, took most of a signal's decode.
        let window_start = if end <= 8 { 0 } else { first };
        if let Some(window) = payload
            .get(window_start..window_start + 8)
            .and_then(|bytes| <[u8; 8]>::try_from(bytes).ok())
            .filter(|_| self.byte_count <= 8)
        {
            let word = match self.order {
                ByteOrder::LittleEndian => {
                    u64::from_le_bytes(window) >> ((first - window_start) * 8)
                }
                ByteOrder::BigEndian => {
                    u64::from_be_bytes(window) >> ((window_start + 8 - end) * 8)
                }
            };
            return Some((word >> self.shift) & mask);
        }
        // A field of 9 bytes (64 bits not on a byte boundary), or near the
        // end of a short payload.
        let bytes = &payload[first..end];
        let word: u128 = match self.order {
            ByteOrder::LittleEndian => bytes
                .iter()
                .rev()
                .fold(0u128, |acc, &b| (acc << 8) | u128::from(b)),
            ByteOrder::BigEndian => bytes
                .iter()
                .fold(0u128, |acc, &b| (acc << 8) | u128::from(b)),
        };
        Some((word >> self.shift) as u64 & mask)
    }

    /// Sign-extends a raw value of this field's width.
    #[inline]
    pub fn sign_extend(&self, raw: u64) -> i64 {
        let unused = 64 - u32::from(self.length_bits);
        ((raw << unused) as i64) >> unused
    }

    /// Writes `raw` (low `length_bits` bits) into the payload: the inverse of
    /// [`BitField::extract`], used by simulators and tests.
    pub fn insert(&self, payload: &mut [u8], raw: u64) -> Option<()> {
        let bytes = payload.get_mut(usize::from(self.first_byte)..self.end_byte())?;
        let mask = if self.length_bits == 64 {
            u64::MAX
        } else {
            (1u64 << self.length_bits) - 1
        };
        let field_mask = u128::from(mask) << self.shift;
        let value = u128::from(raw & mask) << self.shift;
        let n = bytes.len();
        for (i, byte) in bytes.iter_mut().enumerate() {
            // Position of this byte in the assembled word, counted from its LSB.
            let position = match self.order {
                ByteOrder::LittleEndian => i,
                ByteOrder::BigEndian => n - 1 - i,
            } * 8;
            let keep = !((field_mask >> position) as u8);
            *byte = (*byte & keep) | ((value >> position) as u8 & !keep);
        }
        Some(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Reference extraction, bit by bit, straight from the DBC definition.
    fn slow_extract(order: ByteOrder, start: u64, length: u64, payload: &[u8]) -> u64 {
        let bit = |i: u64| (payload[(i / 8) as usize] >> (i % 8)) & 1;
        let mut value = 0u64;
        match order {
            ByteOrder::LittleEndian => {
                for k in 0..length {
                    value |= u64::from(bit(start + k)) << k;
                }
            }
            ByteOrder::BigEndian => {
                // Walk from the MSB down the sawtooth.
                let mut position = start;
                for _ in 0..length {
                    value = (value << 1) | u64::from(bit(position));
                    position = if position % 8 == 0 {
                        position + 15
                    } else {
                        position - 1
                    };
                }
            }
        }
        value
    }

    #[test]
    fn known_fields() {
        let payload = [0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC, 0xDE, 0xF0];
        let le = BitField::new(ByteOrder::LittleEndian, 0, 16).unwrap();
        assert_eq!(le.extract(&payload), Some(0x3412));
        let be = BitField::new(ByteOrder::BigEndian, 7, 16).unwrap();
        assert_eq!(be.extract(&payload), Some(0x1234));
        let be64 = BitField::new(ByteOrder::BigEndian, 7, 64).unwrap();
        assert_eq!(be64.extract(&payload), Some(0x1234_5678_9ABC_DEF0));
        let nibble = BitField::new(ByteOrder::LittleEndian, 4, 4).unwrap();
        assert_eq!(nibble.extract(&payload), Some(1));
        assert_eq!(le.sign_extend(0xFFFE), -2);
        assert_eq!(le.extract(&payload[..1]), None);
        assert!(BitField::new(ByteOrder::LittleEndian, 0, 65).is_err());
        assert!(BitField::new(ByteOrder::LittleEndian, 511, 2).is_err());
        // Motorola LSB-side bits past byte 63.
        assert!(BitField::new(ByteOrder::BigEndian, 504, 9).is_err());
    }

    proptest! {
        #[test]
        fn extraction_matches_bit_by_bit_reference(
            order in prop_oneof![Just(ByteOrder::LittleEndian), Just(ByteOrder::BigEndian)],
            // Half the fields in a classic frame's 8 bytes, where the
            // one-load path is taken most.
            start in prop_oneof![0u64..64, 0u64..512],
            length in 1u64..=64,
            payload in proptest::collection::vec(any::<u8>(), 0..=64),
        ) {
            if let Ok(field) = BitField::new(order, start, length) {
                let expected = (field.end_byte() <= payload.len())
                    .then(|| slow_extract(order, start, length, &payload));
                prop_assert_eq!(field.extract(&payload), expected);
            }
        }

        #[test]
        fn insert_then_extract_gives_the_value_and_leaves_other_bits(
            order in prop_oneof![Just(ByteOrder::LittleEndian), Just(ByteOrder::BigEndian)],
            start in 0u64..128,
            length in 1u64..=64,
            raw in any::<u64>(),
            payload in proptest::collection::vec(any::<u8>(), 24),
        ) {
            if let Ok(field) = BitField::new(order, start, length) {
                if field.end_byte() <= payload.len() {
                    let mut written = payload.clone();
                    field.insert(&mut written, raw).unwrap();
                    let mask = if length == 64 { u64::MAX } else { (1 << length) - 1 };
                    prop_assert_eq!(field.extract(&written), Some(raw & mask));
                    // Writing back the original value restores the payload.
                    let original = field.extract(&payload).unwrap();
                    field.insert(&mut written, original).unwrap();
                    prop_assert_eq!(written, payload);
                }
            }
        }
    }
}
