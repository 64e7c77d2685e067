//! Text formatting of numbers at full precision.

/// Formats `x` so that parsing the text gives back exactly `x` (shortest round-trip digits), in
/// plain notation for magnitudes in [1e-5, 1e16) and zero, in exponent notation (`1.5e-7`)
/// otherwise, so that tiny or huge values stay short. The caller guarantees `x` is finite.
pub(crate) fn fmt_f64(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || (1e-5..1e16).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::fmt_f64;

    #[test]
    fn round_trips_exactly() {
        for &x in &[
            0.0,
            -0.0,
            1.0,
            -2.5,
            0.1,
            1.0 / 3.0,
            std::f64::consts::PI * 1e-9,
            6.02214076e23,
            f64::MIN_POSITIVE,
            f64::MAX,
            -1e-300,
            123_456_789.123_456_79,
        ] {
            let s = fmt_f64(x);
            let back: f64 = s.parse().expect("formatted number parses");
            assert_eq!(back.to_bits(), x.to_bits(), "{x} -> {s}");
            assert!(s.len() <= 25, "{s} is too long");
        }
    }
}
