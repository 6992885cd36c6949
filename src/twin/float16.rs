//! IEEE 754 binary16 ("half") coordinates, as some LiDAR drivers and recordings store points:
//! 11 significant bits, so a coordinate between 32 and 64 m lands on a 3.1 cm grid (up to 1.6 cm
//! off). Done on the bits: two small functions do not justify a dependency.

/// The binary16 nearest `x`, as its bits: round to nearest, ties to even (IEEE's default).
/// Magnitudes from 65520 up become infinity (65504 is the largest finite half); NaN stays NaN.
pub fn to_bits(x: f32) -> u16 {
    let bits = x.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exponent = ((bits >> 23) & 0xff) as i32;
    let mantissa = bits & 0x7f_ffff;
    if exponent == 0xff {
        // Infinity keeps its sign; NaN stays a (quiet) NaN.
        return sign | 0x7c00 | if mantissa != 0 { 0x200 } else { 0 };
    }
    // The half's biased exponent: f32's bias is 127, half's 15.
    let half_exponent = exponent - 127 + 15;
    if half_exponent >= 0x1f {
        return sign | 0x7c00;
    }
    if half_exponent <= 0 {
        // A subnormal half (units of 2^-24) or zero. The f32's own subnormals are far below
        // 2^-25 and round to zero like any other tiny value.
        if half_exponent < -10 || exponent == 0 {
            return sign;
        }
        let significand = mantissa | 0x80_0000;
        return sign | round_shift(significand, (14 - half_exponent) as u32) as u16;
    }
    // Drop the 13 low mantissa bits; a carry out of the mantissa bumps the exponent, up to
    // 0x7c00 (infinity) from just below 65520, which is what IEEE rounding gives.
    let joined = ((half_exponent as u32) << 23) | mantissa;
    sign | round_shift(joined, 13) as u16
}

/// The f32 a binary16 stands for (exact: every half is an f32).
pub fn from_bits(h: u16) -> f32 {
    let sign = u32::from(h & 0x8000) << 16;
    let exponent = u32::from((h >> 10) & 0x1f);
    let mantissa = u32::from(h & 0x3ff);
    match exponent {
        0 => {
            // Subnormal: mantissa * 2^-24, exact in f32.
            let magnitude = mantissa as f32 * f32::from_bits(0x3380_0000);
            f32::from_bits(sign | magnitude.to_bits())
        }
        0x1f => f32::from_bits(sign | 0x7f80_0000 | (mantissa << 13)),
        _ => f32::from_bits(sign | ((exponent + 127 - 15) << 23) | (mantissa << 13)),
    }
}

/// `x` rounded to the nearest binary16, back as an f32.
pub fn round(x: f32) -> f32 {
    from_bits(to_bits(x))
}

/// `value >> shift` rounded to nearest, ties to even (`1 <= shift < 32`).
fn round_shift(value: u32, shift: u32) -> u32 {
    let kept = value >> shift;
    let rest = value & ((1 << shift) - 1);
    let half = 1 << (shift - 1);
    if rest > half || (rest == half && kept & 1 == 1) { kept + 1 } else { kept }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    #[test]
    fn known_halves() {
        let cases: [(f32, u16); 22] = [
            (0.0, 0x0000),
            (-0.0, 0x8000),
            (1.0, 0x3c00),
            (-2.0, 0xc000),
            (0.5, 0x3800),
            (0.1, 0x2e66),
            (1.0 / 3.0, 0x3555),
            (12.3456, 0x4a2c),
            (65504.0, 0x7bff),
            (65519.99, 0x7bff),
            (65520.0, 0x7c00),
            (1e6, 0x7c00),
            (-1e6, 0xfc00),
            (f32::INFINITY, 0x7c00),
            // 2^-14, the smallest normal; 2^-24, the smallest subnormal.
            (6.103_515_6e-5, 0x0400),
            (5.960_464_5e-8, 0x0001),
            // 2^-25 is a tie between 0 and 2^-24: to even, 0; a little more rounds up.
            (2.980_232_2e-8, 0x0000),
            (4.0e-8, 0x0001),
            (1e-10, 0x0000),
            // Ties to even between 2048 and 2050 (even mantissa 0) and between 2050 and 2052.
            (2049.0, 0x6800),
            (2051.0, 0x6802),
            (2050.0, 0x6801),
        ];
        for (x, bits) in cases {
            assert_eq!(to_bits(x), bits, "{x:e}: {:#06x} vs {bits:#06x}", to_bits(x));
        }
        assert!(to_bits(f32::NAN) & 0x7c00 == 0x7c00 && to_bits(f32::NAN) & 0x3ff != 0);
        assert!(round(f32::NAN).is_nan());
        assert_eq!(from_bits(0x3555), 0.333_251_95);
        assert_eq!(from_bits(0x0001), 5.960_464_5e-8);
        assert_eq!(from_bits(0x7bff), 65504.0);
        assert_eq!(from_bits(0xfc00), f32::NEG_INFINITY);
        assert_eq!(round(-0.0).to_bits(), (-0.0f32).to_bits());
    }

    /// Against rounding done in f64 arithmetic (scaling by a power of two is exact there).
    #[test]
    fn matches_rounding_in_f64_and_round_trips() {
        let mut rng = Pcg64::seed_from_u64(16);
        for _ in 0..200_000 {
            let x = rng.random_range(-1.0f64..1.0) * 2f64.powi(rng.random_range(-26..17));
            let x = x as f32;
            let v = f64::from(x);
            // The binade's exponent from the bits (log2 can round up just below a power of 2).
            let exponent = (((x.to_bits() >> 23) & 0xff) as i32 - 127).max(-14);
            let ulp = 2f64.powi(exponent - 10);
            let expected = (v / ulp).round_ties_even() * ulp;
            let expected =
                if expected.abs() > 65504.0 { v.signum() * f64::INFINITY } else { expected };
            assert_eq!(f64::from(round(x)), expected, "{x:e}");
            // A half's own value comes back unchanged.
            assert_eq!(round(round(x)).to_bits(), round(x).to_bits());
        }
        for h in 0..=u16::MAX {
            let x = from_bits(h);
            if !x.is_nan() {
                assert_eq!(to_bits(x), h, "{h:#06x}");
            }
        }
    }
}
