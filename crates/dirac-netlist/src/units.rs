//! SPICE numbers: decimal mantissa, optional exponent, engineering suffix and ignored unit letters.
//!
//! | suffix (any case) | scale |
//! | --- | --- |
//! | `f` | 1e-15 |
//! | `p` | 1e-12 |
//! | `n` | 1e-9 |
//! | `u` (or `µ`) | 1e-6 |
//! | `m` | 1e-3 (milli, as in SPICE) |
//! | `mil` | 25.4e-6 |
//! | `k` | 1e3 |
//! | `meg` | 1e6 |
//! | `g` | 1e9 |
//! | `t` | 1e12 |
//!
//! All letters after the number are consumed; only the first one (or `meg`/`mil`) selects a scale,
//! the rest are ignored, so `10uF` is 1e-5, `1kOhm` is 1000 and `5V` is 5. Note that a bare `F` is
//! femto (`10F` is 1e-14) and `M` is milli, as in every SPICE.
//!
//! Scaling is done on the decimal exponent before conversion, so `10u` is exactly the `f64`
//! nearest to 1e-5.

/// Parses a SPICE number at the start of `chars`. Returns the value and the number of characters
/// consumed (mantissa, exponent, suffix and trailing letters), or `None` if `chars` does not start
/// with a number (a digit, or a `.` followed by a digit).
pub(crate) fn parse_number_prefix(chars: &[char]) -> Option<(f64, usize)> {
    let mut i = 0;
    let mut mantissa = String::new();
    let mut digits = 0;
    while i < chars.len() && chars[i].is_ascii_digit() {
        mantissa.push(chars[i]);
        i += 1;
        digits += 1;
    }
    if i < chars.len() && chars[i] == '.' {
        mantissa.push('.');
        i += 1;
        while i < chars.len() && chars[i].is_ascii_digit() {
            mantissa.push(chars[i]);
            i += 1;
            digits += 1;
        }
    }
    if digits == 0 {
        return None;
    }
    let mut exponent: i64 = 0;
    if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
        let mut j = i + 1;
        let negative = j < chars.len() && chars[j] == '-';
        if j < chars.len() && (chars[j] == '-' || chars[j] == '+') {
            j += 1;
        }
        if j < chars.len() && chars[j].is_ascii_digit() {
            let mut e: i64 = 0;
            while j < chars.len() && chars[j].is_ascii_digit() {
                let d = i64::from(chars[j].to_digit(10).unwrap_or(0));
                e = e.saturating_mul(10).saturating_add(d);
                j += 1;
            }
            exponent = if negative { -e } else { e };
            i = j;
        }
    }
    // The run of letters after the number: a suffix and/or ignored unit letters.
    let start = i;
    while i < chars.len() && chars[i].is_alphabetic() {
        i += 1;
    }
    let letters: String = chars[start..i].iter().collect::<String>().to_lowercase();
    let (shift, factor, _) = scale_suffix(&letters).unwrap_or((0, 1.0, 0));
    exponent = exponent.saturating_add(shift);
    // Keep the exponent inside what `f64::from_str` handles sensibly; beyond that the value
    // over/underflows anyway.
    let exponent = exponent.clamp(-100_000, 100_000);
    let value: f64 = format!("{mantissa}e{exponent}").parse().ok()?;
    Some((value * factor, i))
}

/// The scale suffix that `letters` (lowercase) starts with: its decimal exponent, an extra factor
/// (for `mil`) and its length in characters; `None` when the first letter is no suffix.
fn scale_suffix(letters: &str) -> Option<(i64, f64, usize)> {
    if letters.starts_with("meg") {
        return Some((6, 1.0, 3));
    }
    if letters.starts_with("mil") {
        return Some((0, 25.4e-6, 3));
    }
    let shift = match letters.chars().next()? {
        'f' => -15,
        'p' => -12,
        'n' => -9,
        'u' | 'µ' | 'μ' => -6,
        'm' => -3,
        'k' => 3,
        'g' => 9,
        't' => 12,
        _ => return None,
    };
    Some((shift, 1.0, 1))
}

/// [`parse_spice_number`] that refuses letters other than a scale suffix and then `unit` (or
/// nothing): `"0.3m"`, `"300us"`, `"1megs"` read with unit `"s"`, `"0.3x"` does not, where a
/// netlist would read 0.3. For values typed on a command line, where stray letters are typos.
pub fn parse_spice_quantity(text: &str, unit: &str) -> Option<f64> {
    let value = parse_spice_number(text)?;
    let trimmed = text.trim().to_lowercase();
    let body = trimmed.strip_suffix(unit).unwrap_or(&trimmed);
    let start = body
        .char_indices()
        .rev()
        .take_while(|(_, c)| c.is_alphabetic())
        .last()
        .map_or(body.len(), |(i, _)| i);
    let letters = &body[start..];
    let suffix = scale_suffix(letters).map_or(0, |(_, _, len)| len);
    (letters.chars().count() == suffix).then_some(value)
}

/// Parses a whole string as a SPICE number, e.g. `"10uF"` → 1e-5, `"1meg"` → 1e6, `"2.2k"` →
/// 2200, `"5V"` → 5. Leading and trailing whitespace is ignored; a sign is allowed. Returns `None`
/// if anything else is left over (use the expression syntax of `.param` for arithmetic).
pub fn parse_spice_number(text: &str) -> Option<f64> {
    let chars: Vec<char> = text.trim().chars().collect();
    let (sign, body) = match chars.first() {
        Some('-') => (-1.0, &chars[1..]),
        Some('+') => (1.0, &chars[1..]),
        _ => (1.0, &chars[..]),
    };
    let (value, used) = parse_number_prefix(body)?;
    (used == body.len()).then_some(sign * value)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A quantity takes a scale suffix and then the unit, or nothing; any other letters refuse it.
    #[test]
    fn quantities_refuse_stray_letters() {
        for (text, value) in [
            ("0.3m", 3e-4),
            ("300us", 3e-4),
            ("1megs", 1e6),
            ("2", 2.0),
            ("1mil", 25.4e-6),
        ] {
            let parsed = parse_spice_quantity(text, "s").unwrap_or(f64::NAN);
            assert!((parsed - value).abs() <= 1e-15 * value, "{text}: {parsed}");
        }
        for text in ["0.3x", "0.3mx", "2mss", "1kohm", ""] {
            assert_eq!(parse_spice_quantity(text, "s"), None, "{text}");
        }
    }

    #[test]
    fn suffixes_and_units() {
        let cases = [
            ("10uF", 1e-5),
            ("1meg", 1e6),
            ("1MEG", 1e6),
            ("1Meg", 1e6),
            ("1m", 1e-3),
            ("1M", 1e-3),
            ("2.2k", 2200.0),
            ("1e-3", 1e-3),
            ("5V", 5.0),
            ("1kOhm", 1000.0),
            ("3p", 3e-12),
            ("4n", 4e-9),
            ("7f", 7e-15),
            ("10F", 1e-14),
            ("1g", 1e9),
            ("2T", 2e12),
            (".5", 0.5),
            ("1.", 1.0),
            ("1.5e3k", 1.5e6),
            ("1E3", 1000.0),
            ("100mA", 0.1),
            ("3H", 3.0),
            ("-4.7u", -4.7e-6),
            ("+1k", 1000.0),
            ("1mil", 25.4e-6),
            ("1e", 1.0),
        ];
        for (text, want) in cases {
            assert_eq!(parse_spice_number(text), Some(want), "{text}");
        }
    }

    #[test]
    fn rejects_non_numbers() {
        for text in ["", "k", "abc", "1k5", "1+2", ".", "-"] {
            assert_eq!(parse_spice_number(text), None, "{text}");
        }
    }

    #[test]
    fn prefix_reports_consumed_length() {
        let chars: Vec<char> = "10uF*2".chars().collect();
        assert_eq!(parse_number_prefix(&chars), Some((1e-5, 4)));
        let chars: Vec<char> = "1e-3+x".chars().collect();
        assert_eq!(parse_number_prefix(&chars), Some((1e-3, 4)));
    }
}
