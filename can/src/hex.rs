//! Hex digits, both ways, by table: the log readers and writers spend most
//! of their time here.

const INVALID: u8 = 0xFF;

const NIBBLE: [u8; 256] = {
    let mut table = [INVALID; 256];
    let mut i = 0;
    while i < 10 {
        table[b'0' as usize + i] = i as u8;
        i += 1;
    }
    let mut i = 0;
    while i < 6 {
        table[b'a' as usize + i] = 10 + i as u8;
        table[b'A' as usize + i] = 10 + i as u8;
        i += 1;
    }
    table
};

const UPPER: &[u8; 16] = b"0123456789ABCDEF";

/// Value of one hex digit (either case).
#[inline]
pub fn nibble(digit: u8) -> Option<u8> {
    let value = NIBBLE[usize::from(digit)];
    (value != INVALID).then_some(value)
}

/// Parses a run of hex digits (no prefix) into a `u32`; `None` on an empty
/// run, a non-hex byte or more than 8 digits.
#[inline(always)]
pub fn parse_u32(digits: &[u8]) -> Option<u32> {
    if digits.is_empty() || digits.len() > 8 {
        return None;
    }
    digits
        .iter()
        .try_fold(0u32, |acc, &d| nibble(d).map(|v| (acc << 4) | u32::from(v)))
}

/// Reads `digits`, pairs of hex digits (either case), into the first
/// bytes of `out`; `None` for an odd count, a byte not a hex digit, or
/// more pairs than `out` holds.
/// One table look-up a digit, every digit's checked at the end at once.
#[inline(always)]
pub fn read_pairs(digits: &[u8], out: &mut [u8]) -> Option<()> {
    if digits.len() > 2 * out.len() {
        return None;
    }
    let mut seen = 0u8;
    for (byte, pair) in out.iter_mut().zip(digits.chunks_exact(2)) {
        let (high, low) = (NIBBLE[usize::from(pair[0])], NIBBLE[usize::from(pair[1])]);
        seen |= high | low;
        *byte = (high << 4) | (low & 0x0F);
    }
    // A valid digit's value is at most 0x0F; INVALID sets the high bits.
    (seen <= 0x0F && digits.len() % 2 == 0).then_some(())
}

/// Uppercase hex digit of the low nibble.
#[inline]
pub fn upper_digit(value: u8) -> u8 {
    UPPER[usize::from(value & 0x0F)]
}

/// Appends `byte` as two uppercase hex digits.
#[inline]
pub fn push_byte(out: &mut Vec<u8>, byte: u8) {
    out.push(upper_digit(byte >> 4));
    out.push(upper_digit(byte));
}

/// Appends `value` as exactly `width` uppercase hex digits.
pub fn push_fixed(out: &mut Vec<u8>, value: u32, width: usize) {
    for shift in (0..width).rev() {
        out.push(upper_digit((value >> (4 * shift)) as u8));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits_round_trip() {
        for v in 0..16u8 {
            assert_eq!(nibble(upper_digit(v)), Some(v));
        }
        assert_eq!(nibble(b'g'), None);
        assert_eq!(parse_u32(b"18fef100"), Some(0x18FE_F100));
        assert_eq!(parse_u32(b"123456789"), None);
        assert_eq!(parse_u32(b""), None);
        let mut out = Vec::new();
        push_fixed(&mut out, 0x1A5, 8);
        assert_eq!(out, b"000001A5");
    }
}
