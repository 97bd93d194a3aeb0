//! The rounding oref0 does, computed the way JavaScript computes it, so that
//! our categorisation sees the very numbers oref0's does.

/// `Math.round(x)`: the nearest integer, halves toward +∞.
pub fn round(x: f64) -> f64 {
    let r = x.floor();
    if x - r >= 0.5 {
        r + 1.0
    } else {
        r
    }
}

/// `Math.round(x * 10^digits) / 10^digits`, as oref0 writes it.
pub fn round_to(x: f64, digits: i32) -> f64 {
    let f = 10f64.powi(digits);
    round(x * f) / f
}

/// `parseFloat(x.toFixed(2))`: the exact decimal value rounded to two
/// digits, halves away from zero (ECMA-262 Number.prototype.toFixed).
pub fn fixed2(x: f64) -> f64 {
    if !x.is_finite() {
        return x;
    }
    // A double is a tie at the third decimal only if it is an odd multiple
    // of 1/8 (k/8 = n/100 + 5/1000 needs 25 | 2n + 1); those Rust's
    // formatter would round to even.
    let eighths = x.abs() * 8.0;
    if eighths == eighths.floor() && (eighths as i64) % 2 == 1 {
        let up = ((x.abs() * 100.0).floor() + 1.0) / 100.0;
        return up.copysign(x);
    }
    // Far from a tie, the rounded product decides (x · 100 is within a few
    // ulps of the exact value, far below the 1e-6 margin for |x| < 1e6);
    // n / 100 is then the double nearest the decimal, as parseFloat gives.
    let y = x.abs() * 100.0;
    let frac = y - y.floor();
    if y < 1e8 && (frac - 0.5).abs() > 1e-6 {
        let n = if frac > 0.5 {
            y.floor() + 1.0
        } else {
            y.floor()
        };
        return (n / 100.0).copysign(x);
    }
    format!("{x:.2}").parse().unwrap_or(x)
}

/// `parseInt(x)` of a number: its integer part.
pub fn int(x: f64) -> f64 {
    x.trunc()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_is_javascripts() {
        assert_eq!(round(2.5), 3.0);
        assert_eq!(round(-2.5), -2.0);
        assert_eq!(round(0.499_999_999_999_999_94), 0.0);
        // As node 20 prints: 2.675 * 100 is 267.5, 1.005 * 100 is 100.49999999999999.
        assert_eq!(round_to(2.675, 2), 2.68);
        assert_eq!(round_to(1.005, 2), 1.0);
        // toFixed rounds the exact binary value: 1.005 is 1.00499999...
        assert_eq!(fixed2(1.005), 1.0);
        assert_eq!(fixed2(0.125), 0.13);
        assert_eq!(fixed2(-0.125), -0.13);
        assert_eq!(fixed2(2.375), 2.38);
        assert_eq!(fixed2(-4.0), -4.0);
        assert_eq!(int(51.9), 51.0);
    }

    /// The fast path gives what the exact decimal formatting gives.
    #[test]
    fn fixed2_fast_path_is_the_formatters() {
        let mut x = -40.0_f64;
        while x < 40.0 {
            for v in [x, x + 1e-9, x - 1e-9, x / 3.0] {
                let slow: f64 =
                    if (v.abs() * 8.0).fract() == 0.0 && ((v.abs() * 8.0) as i64) % 2 == 1 {
                        fixed2(v)
                    } else {
                        format!("{v:.2}").parse().unwrap()
                    };
                assert_eq!(fixed2(v).to_bits(), slow.to_bits(), "{v}");
            }
            x += 0.000_731;
        }
    }
}
