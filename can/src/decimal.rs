//! Decimal digits eight at a time: a candump timestamp's sixteen digits
//! read as two 64-bit words, checked and converted in a few operations
//! each, where a loop took a branch and a multiplication per digit.

const ZEROS: u64 = 0x3030_3030_3030_3030;
const HIGH_NIBBLES: u64 = 0xF0F0_F0F0_F0F0_F0F0;

/// The value of eight ASCII decimal digits, the first the most
/// significant; `None` if any byte is not a digit.
#[inline(always)]
pub fn eight_digits(text: [u8; 8]) -> Option<u32> {
    let word = u64::from_le_bytes(text);
    // A digit is 0x30..=0x39: its high nibble is 3, and stays 3 with 6
    // added. No byte carries into the next: one that would (0xFA and
    // above) has failed the first test already.
    if word & HIGH_NIBBLES != ZEROS
        || word.wrapping_add(0x0606_0606_0606_0606) & HIGH_NIBBLES != ZEROS
    {
        return None;
    }
    // Each byte 0..=9, the first digit in the lowest byte; pairs, then
    // fours, then the eight combined by multiplications that add a lane
    // times 10, 100, 10,000 to the next (Lemire's eight-digit parse).
    let digits = word - ZEROS;
    let pairs = (digits.wrapping_mul(10 * 256 + 1) >> 8) & 0x00FF_00FF_00FF_00FF;
    let fours = (pairs.wrapping_mul(100 * 65_536 + 1) >> 16) & 0x0000_FFFF_0000_FFFF;
    Some((fours.wrapping_mul(10_000 * (1 << 32) + 1) >> 32) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn by_loop(text: [u8; 8]) -> Option<u32> {
        text.iter().try_fold(0u32, |value, &d| {
            d.is_ascii_digit().then(|| value * 10 + u32::from(d - b'0'))
        })
    }

    #[test]
    fn eight_digits_read_as_a_loop_reads_them() {
        for text in [
            *b"00000000",
            *b"99999999",
            *b"12345678",
            *b"00000100",
            *b"90000009",
        ] {
            assert_eq!(eight_digits(text), by_loop(text), "{text:?}");
        }
        // Every byte value in every place, the others digits.
        for place in 0..8 {
            for byte in 0..=255u8 {
                let mut text = *b"31415926";
                text[place] = byte;
                assert_eq!(eight_digits(text), by_loop(text), "{text:?}");
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn any_eight_bytes_read_as_a_loop_reads_them(text in proptest::array::uniform8(0u8..)) {
            proptest::prop_assert_eq!(eight_digits(text), by_loop(text));
        }

        #[test]
        fn any_eight_digits_read_as_a_loop_reads_them(value in 0u32..100_000_000) {
            let text: [u8; 8] = format!("{value:08}").into_bytes().try_into().unwrap();
            proptest::prop_assert_eq!(eight_digits(text), Some(value));
        }
    }
}
