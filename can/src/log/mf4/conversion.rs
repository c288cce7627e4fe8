//! ASAM MDF 4 conversions (`##CC`): how a channel's raw value becomes its
//! physical one, as far as a bus log's fields and time master use them.
//!
//! Loggers store a bus-logging field in many ways: a bit field, a virtual
//! channel whose value is a constant through its conversion, DLC through a
//! value-to-value table to `DataLength`. Each conversion type of the
//! standard is read here (learnt from the ASAM MDF 4.1 text as asammdf's
//! `ChannelConversion.convert` implements it; no code was copied):
//!
//! | type | what | physical value |
//! |---|---|---|
//! | 0 | identity | X |
//! | 1 | linear, `[P1, P2]` | P2·X + P1 |
//! | 2 | rational, `[P1..P6]` | (P1X² + P2X + P3) / (P4X² + P5X + P6) |
//! | 3 | algebraic (a formula text) | read only when the formula is a number |
//! | 4 | value to value, interpolated, `[key, value]…` | linear between keys, the end values outside |
//! | 5 | value to value, `[key, value]…` | the nearest key's value (the lower on a tie), the end values outside |
//! | 6 | value range to value, `[lower, upper, value]…, default` | an integer X in `lower..=upper`, a float X in `lower..upper`, else the default |
//! | 7, 8, 11 | value or range to text, bit field to text | X: a bus field's text is a label, its raw value the number (as asammdf's `ignore_value2text_conversions`) |
//! | 9, 10 | text to value, text to text | refused: for string channels only |
//!
//! A `##CC` block's data: type (u8), precision (u8), flags (u16), reference
//! count (u16), value count (u16), physical range (2 f64), then the values
//! (f64). Its links: name, unit, comment, inverse, then the references.

/// A conversion of a raw value to a physical one.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Conversion {
    Identity,
    Linear {
        offset: f64,
        factor: f64,
    },
    Rational([f64; 6]),
    /// Keys ascending.
    Interpolated(Box<[(f64, f64)]>),
    /// Keys ascending.
    Nearest(Box<[(f64, f64)]>),
    Ranges {
        ranges: Box<[(f64, f64, f64)]>,
        default: f64,
    },
    /// An algebraic conversion whose formula is a number.
    Constant(f64),
}

/// What a conversion block must be, for an error message.
pub(super) const E_CONVERSION: &str = "a '##CC' conversion acq evaluates: identity, linear, rational, a formula that is a number, a value-to-value or value-range table, or one to text (its raw value read)";

impl Conversion {
    /// The conversion a `##CC` block's data states; `formula` is the text of
    /// its first reference, asked for only by an algebraic one.
    pub(super) fn parse(
        data: &[u8],
        formula: impl FnOnce() -> Option<Vec<u8>>,
    ) -> Result<Self, &'static str> {
        let kind = *data.first().ok_or(E_CONVERSION)?;
        let count = usize::from(u16::from_le_bytes(
            data.get(6..8)
                .ok_or(E_CONVERSION)?
                .try_into()
                .map_err(|_| E_CONVERSION)?,
        ));
        let values: Vec<f64> = (0..count)
            .map(|index| {
                let at = 24 + 8 * index;
                data.get(at..at + 8)
                    .map(|bytes| f64::from_le_bytes(bytes.try_into().unwrap_or_default()))
            })
            .collect::<Option<_>>()
            .ok_or(E_CONVERSION)?;
        if values.iter().any(|v| v.is_nan()) {
            return Err(E_CONVERSION);
        }
        let pairs = |values: &[f64]| -> Result<Box<[(f64, f64)]>, &'static str> {
            if values.is_empty() || values.len() % 2 != 0 {
                return Err(E_CONVERSION);
            }
            let pairs: Box<[(f64, f64)]> = values.chunks(2).map(|p| (p[0], p[1])).collect();
            if pairs.windows(2).any(|w| w[0].0 > w[1].0) {
                return Err(E_CONVERSION);
            }
            Ok(pairs)
        };
        let conversion = match kind {
            0 => Conversion::Identity,
            1 if count >= 2 => Conversion::Linear {
                offset: values[0],
                factor: values[1],
            },
            2 if count >= 6 => {
                let mut p = [0.0; 6];
                p.copy_from_slice(&values[..6]);
                Conversion::Rational(p)
            }
            3 => {
                let text = formula().ok_or(E_CONVERSION)?;
                let text = std::str::from_utf8(&text).map_err(|_| E_CONVERSION)?;
                let value: f64 = text.trim().parse().map_err(|_| E_CONVERSION)?;
                if !value.is_finite() {
                    return Err(E_CONVERSION);
                }
                Conversion::Constant(value)
            }
            4 => Conversion::Interpolated(pairs(&values)?),
            5 => Conversion::Nearest(pairs(&values)?),
            6 if count % 3 == 1 => Conversion::Ranges {
                ranges: values[..count - 1]
                    .chunks(3)
                    .map(|r| (r[0], r[1], r[2]))
                    .collect(),
                default: values[count - 1],
            },
            7 | 8 | 11 => Conversion::Identity,
            _ => return Err(E_CONVERSION),
        };
        Ok(conversion)
    }

    /// The physical value of `raw`; `integer` when the raw value is an
    /// integer channel's (value ranges include their upper bound then).
    pub(super) fn apply(&self, raw: f64, integer: bool) -> f64 {
        match self {
            Conversion::Identity => raw,
            Conversion::Linear { offset, factor } => factor * raw + offset,
            Conversion::Rational([p1, p2, p3, p4, p5, p6]) => {
                (p1 * raw * raw + p2 * raw + p3) / (p4 * raw * raw + p5 * raw + p6)
            }
            Conversion::Constant(value) => *value,
            Conversion::Interpolated(pairs) => interpolate(pairs, raw),
            Conversion::Nearest(pairs) => nearest(pairs, raw),
            Conversion::Ranges { ranges, default } => ranges
                .iter()
                .find(|(lower, upper, _)| {
                    *lower <= raw && if integer { raw <= *upper } else { raw < *upper }
                })
                .map_or(*default, |(_, _, value)| *value),
        }
    }

    /// The one value this conversion gives whatever the raw value, if so:
    /// what a virtual channel of a constant is.
    pub(super) fn constant(&self) -> Option<f64> {
        let all_equal = |mut values: std::slice::Iter<'_, (f64, f64)>| {
            let first = values.next()?.1;
            values.all(|(_, v)| *v == first).then_some(first)
        };
        match self {
            Conversion::Identity => None,
            Conversion::Linear { offset, factor } => (*factor == 0.0).then_some(*offset),
            Conversion::Rational([p1, p2, p3, p4, p5, p6]) => {
                (*p1 == 0.0 && *p2 == 0.0 && *p4 == 0.0 && *p5 == 0.0 && *p6 != 0.0)
                    .then(|| p3 / p6)
            }
            Conversion::Constant(value) => Some(*value),
            Conversion::Interpolated(pairs) | Conversion::Nearest(pairs) => all_equal(pairs.iter()),
            Conversion::Ranges { ranges, default } => ranges
                .iter()
                .all(|(_, _, v)| v == default)
                .then_some(*default),
        }
    }
}

/// Linear between the keys around `raw`; the end values outside them.
fn interpolate(pairs: &[(f64, f64)], raw: f64) -> f64 {
    let above = pairs.partition_point(|(key, _)| *key <= raw);
    match (above.checked_sub(1).map(|i| pairs[i]), pairs.get(above)) {
        (Some((_, value)), None) | (None, Some(&(_, value))) => value,
        (Some((k0, v0)), Some(&(k1, v1))) => {
            if k1 == k0 {
                v0
            } else {
                v0 + (v1 - v0) * (raw - k0) / (k1 - k0)
            }
        }
        (None, None) => raw,
    }
}

/// The value of the key nearest `raw` (the lower one on a tie); the end
/// values outside the keys.
fn nearest(pairs: &[(f64, f64)], raw: f64) -> f64 {
    let above = pairs.partition_point(|(key, _)| *key <= raw);
    match (above.checked_sub(1).map(|i| pairs[i]), pairs.get(above)) {
        (Some((_, value)), None) | (None, Some(&(_, value))) => value,
        (Some((k0, v0)), Some(&(k1, v1))) => {
            if raw - k0 <= k1 - raw {
                v0
            } else {
                v1
            }
        }
        (None, None) => raw,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `##CC` block's data of `kind` with `values`.
    fn data(kind: u8, values: &[f64]) -> Vec<u8> {
        let mut data = vec![kind, 0, 0, 0, 0, 0];
        data.extend_from_slice(&(values.len() as u16).to_le_bytes());
        data.extend_from_slice(&[0u8; 16]);
        for value in values {
            data.extend_from_slice(&value.to_le_bytes());
        }
        data
    }

    fn parse(kind: u8, values: &[f64]) -> Conversion {
        Conversion::parse(&data(kind, values), || None).unwrap()
    }

    #[test]
    fn linear_and_rational_follow_the_standard_s_formulas() {
        let linear = parse(1, &[0.5, 2.0]);
        assert_eq!(linear.apply(3.0, true), 6.5);
        assert_eq!(linear.constant(), None);
        assert_eq!(parse(1, &[2.0, 0.0]).constant(), Some(2.0));
        // (X^2 + 2X + 3) / (X + 1) at X = 2: 11 / 3.
        let rational = parse(2, &[1.0, 2.0, 3.0, 0.0, 1.0, 1.0]);
        assert_eq!(rational.apply(2.0, false), 11.0 / 3.0);
        assert_eq!(
            parse(2, &[0.0, 0.0, 6.0, 0.0, 0.0, 2.0]).constant(),
            Some(3.0)
        );
    }

    #[test]
    fn tables_interpolate_or_take_the_nearest_key_and_hold_their_ends() {
        let keys = [0.0, 0.0, 10.0, 100.0, 20.0, 50.0];
        let interpolated = parse(4, &keys);
        assert_eq!(interpolated.apply(5.0, false), 50.0);
        assert_eq!(interpolated.apply(15.0, false), 75.0);
        assert_eq!(interpolated.apply(-3.0, false), 0.0);
        assert_eq!(interpolated.apply(99.0, false), 50.0);
        let nearest = parse(5, &keys);
        assert_eq!(nearest.apply(4.0, true), 0.0);
        assert_eq!(nearest.apply(5.0, true), 0.0, "a tie takes the lower key");
        assert_eq!(nearest.apply(6.0, true), 100.0);
        assert_eq!(nearest.apply(30.0, true), 50.0);
        // CAN FD's DLC to data length.
        let lengths = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64];
        let table: Vec<f64> = lengths
            .iter()
            .enumerate()
            .flat_map(|(dlc, &len)| [dlc as f64, f64::from(len)])
            .collect();
        let dlc_to_length = parse(5, &table);
        for (dlc, len) in lengths.iter().enumerate() {
            assert_eq!(dlc_to_length.apply(dlc as f64, true), f64::from(*len));
        }
    }

    #[test]
    fn a_range_includes_its_upper_bound_for_integers_only() {
        let ranges = parse(6, &[0.0, 5.0, 100.0, 10.0, 20.0, 200.0, -1.0]);
        assert_eq!(ranges.apply(5.0, true), 100.0);
        assert_eq!(ranges.apply(5.0, false), -1.0);
        assert_eq!(ranges.apply(7.0, true), -1.0);
        assert_eq!(ranges.apply(12.0, false), 200.0);
        assert_eq!(parse(6, &[0.0, 5.0, 3.0, 3.0]).constant(), Some(3.0));
    }

    #[test]
    fn a_formula_is_read_only_when_it_is_a_number() {
        let constant = Conversion::parse(&data(3, &[]), || Some(b"2".to_vec())).unwrap();
        assert_eq!(constant.constant(), Some(2.0));
        assert!(Conversion::parse(&data(3, &[]), || Some(b"X * 2".to_vec())).is_err());
        assert!(Conversion::parse(&data(3, &[]), || None).is_err());
    }

    #[test]
    fn text_conversions_give_the_raw_value_and_string_ones_are_refused() {
        assert_eq!(parse(7, &[1.0, 2.0]).apply(2.0, true), 2.0);
        assert!(Conversion::parse(&data(9, &[1.0]), || None).is_err());
        assert!(Conversion::parse(&data(4, &[1.0, 2.0, 0.0, 3.0]), || None).is_err());
        assert!(Conversion::parse(&data(1, &[f64::NAN, 1.0]), || None).is_err());
        assert!(Conversion::parse(&[1, 0, 0], || None).is_err());
    }
}
