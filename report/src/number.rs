//! Numbers as a reader wants them: to a stated number of significant
//! figures, never the 17 digits a float's shortest round trip can need
//! (116.88459379999991 says nothing that 116.9 does not).

/// `value` to `digits` significant figures (1 to 17): fixed-point between
/// 1e-4 and 1e7, scientific outside (`1.235e-6`, its mantissa's trailing
/// zeros dropped); `NaN`, `inf` and `-inf` as such.
pub fn significant(value: f64, digits: usize) -> String {
    let digits = digits.clamp(1, 17);
    if !value.is_finite() {
        return format!("{value}");
    }
    if value == 0.0 {
        return "0".to_string();
    }
    let magnitude = value.abs().log10().floor() as i32;
    if !(-4..7).contains(&magnitude) {
        let text = format!("{value:.*e}", digits - 1);
        return match text.split_once('e') {
            Some((mantissa, exponent)) if mantissa.contains('.') => format!(
                "{}e{exponent}",
                mantissa.trim_end_matches('0').trim_end_matches('.')
            ),
            _ => text,
        };
    }
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    format!("{value:.decimals$}")
}

/// `n` and `noun`, plural when `n` is not one ("1 run", "2 runs").
pub fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// [`significant`] without the trailing zeros of its fraction: a bound of
/// 0.1 reads `0.1`, not `0.100000`; a value of 125.9 reads `125.9`.
pub fn plain(value: f64, digits: usize) -> String {
    let text = significant(value, digits);
    match text.split_once('e') {
        None if text.contains('.') => text.trim_end_matches('0').trim_end_matches('.').to_string(),
        _ => text,
    }
}

#[cfg(test)]
mod tests {
    use super::{plain, significant};

    #[test]
    fn plain_drops_the_zeros_a_fraction_ends_in() {
        assert_eq!(plain(0.1, 6), "0.1");
        assert_eq!(plain(1.9320000000000002, 6), "1.932");
        assert_eq!(plain(121.0, 6), "121");
        assert_eq!(plain(-11.292969, 6), "-11.293");
        assert_eq!(plain(1500.0, 2), "1500");
        assert_eq!(plain(1.0e-6, 4), "1e-6");
    }

    #[test]
    fn a_float_is_cut_to_its_significant_figures() {
        assert_eq!(significant(116.884_593_799_999_9, 4), "116.9");
        assert_eq!(significant(125.90791, 6), "125.908");
        assert_eq!(significant(-11.292969, 4), "-11.29");
        assert_eq!(significant(0.0123456, 3), "0.0123");
        assert_eq!(significant(2_500_000.0, 3), "2500000");
        assert_eq!(significant(12_345_678.9, 4), "1.235e7");
        assert_eq!(significant(0.000012345, 3), "1.23e-5");
        assert_eq!(significant(1e-6, 4), "1e-6");
        assert_eq!(significant(0.0, 4), "0");
        assert_eq!(significant(f64::NAN, 4), "NaN");
        assert_eq!(significant(f64::NEG_INFINITY, 4), "-inf");
    }
}
