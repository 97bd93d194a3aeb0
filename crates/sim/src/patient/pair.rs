//! Two runs of one patient side by side: the number type [`Pair`] for the
//! model's equations, one 128-bit vector register holding one value of
//! each run.
//!
//! Why: one run's minute is a chain of dependent operations (each RK4
//! stage waits for the previous one, and the glucose uptake for a
//! division), so a core steps one run at the speed of that chain and
//! leaves most of its arithmetic units idle. The trial's runs of one
//! patient share the gut's minute ([`super::GutTape`]); integrating two of
//! their bodies as one [`Pair`] makes both chains one, at the cost of one
//! (`crates/sim/benches/patient_day.rs`, `patient_day_10_runs`). Four
//! runs as `wide::f64x4` (two registers on SSE2) made the default trial
//! slower (21.6 against 19.9 CPU-s): 13 states of four runs do not fit in
//! the 16 vector registers.
//!
//! Every operation is the IEEE operation of each lane, so a lane's result
//! has the same bits as the same run stepped alone with `f64` (test:
//! `pair_lanes_equal_f64_bit_for_bit` and the trial's group tests). The
//! vectors are the `wide` crate's (SSE2 on x86-64, NEON on AArch64, plain
//! arrays elsewhere): safe code, no run-time dispatch.

use super::lanes::Real;
use std::ops::{Add, Div, Mul, Neg, Sub};
use wide::{f64x2, CmpEq, CmpGt, CmpLt};

/// A number type of `W` runs side by side, with its lanes in and out.
pub trait Side<const W: usize>: Real {
    /// Lane `l` holds `v[l]`.
    fn from_lanes(v: [f64; W]) -> Self;
    /// Every lane.
    fn lanes(self) -> [f64; W];
}

macro_rules! side {
    ($(#[$doc:meta])* $name:ident, $v:ident, $w:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy)]
        pub struct $name($v);

        impl $name {
            /// `a` where `mask` is set, else `b` (a lane's mask is all
            /// ones or all zeros, as the comparisons give it).
            #[inline(always)]
            fn select(mask: $v, a: Self, b: Self) -> Self {
                Self(mask.blend(a.0, b.0))
            }

            /// `f` on each lane.
            #[inline(always)]
            fn map(self, f: impl Fn(f64) -> f64) -> Self {
                Self($v::new(self.0.to_array().map(f)))
            }
        }

        impl Side<$w> for $name {
            #[inline(always)]
            fn from_lanes(v: [f64; $w]) -> Self {
                Self($v::new(v))
            }
            #[inline(always)]
            fn lanes(self) -> [f64; $w] {
                self.0.to_array()
            }
        }

        impl Add for $name {
            type Output = Self;
            #[inline(always)]
            fn add(self, o: Self) -> Self {
                Self(self.0 + o.0)
            }
        }
        impl Sub for $name {
            type Output = Self;
            #[inline(always)]
            fn sub(self, o: Self) -> Self {
                Self(self.0 - o.0)
            }
        }
        impl Mul for $name {
            type Output = Self;
            #[inline(always)]
            fn mul(self, o: Self) -> Self {
                Self(self.0 * o.0)
            }
        }
        impl Div for $name {
            type Output = Self;
            #[inline(always)]
            fn div(self, o: Self) -> Self {
                Self(self.0 / o.0)
            }
        }
        impl Add<f64> for $name {
            type Output = Self;
            #[inline(always)]
            fn add(self, o: f64) -> Self {
                Self(self.0 + $v::splat(o))
            }
        }
        impl Sub<f64> for $name {
            type Output = Self;
            #[inline(always)]
            fn sub(self, o: f64) -> Self {
                Self(self.0 - $v::splat(o))
            }
        }
        impl Mul<f64> for $name {
            type Output = Self;
            #[inline(always)]
            fn mul(self, o: f64) -> Self {
                Self(self.0 * $v::splat(o))
            }
        }
        impl Neg for $name {
            type Output = Self;
            /// The sign bit flipped, as `f64`'s negation does (wide's `-`
            /// computes 0 − x, which gives +0 for +0).
            #[inline(always)]
            fn neg(self) -> Self {
                Self(self.0 ^ $v::splat(-0.0))
            }
        }

        impl Real for $name {
            const EAGER: bool = true;
            #[inline(always)]
            fn splat(v: f64) -> Self {
                Self($v::splat(v))
            }
            #[inline(always)]
            fn if_gt(self, other: Self, a: Self, b: Self) -> Self {
                Self::select(self.0.cmp_gt(other.0), a, b)
            }
            #[inline(always)]
            fn if_zero(self, a: Self, b: impl FnOnce() -> Self) -> Self {
                self.select_zero(a, b())
            }
            #[inline(always)]
            fn select_zero(self, a: Self, b: Self) -> Self {
                Self::select(self.0.cmp_eq($v::ZERO), a, b)
            }
            #[inline(always)]
            fn unless_negative(self, mass: Self) -> Self {
                Self::select(mass.0.cmp_lt($v::ZERO), Self::splat(0.0), self)
            }
            /// Lane by lane `f64::max`, so that NaN and signed zeros go as
            /// they go for one run.
            #[inline(always)]
            fn max0(self) -> Self {
                self.map(|v| v.max(0.0))
            }
            /// libm's `exp` on each lane, as one run computes it.
            #[inline(always)]
            fn exp_for_tanh(self) -> Self {
                self.map(f64::exp)
            }
        }
    };
}

side!(
    /// One value of each of two runs (one 128-bit register).
    Pair,
    f64x2,
    2
);

#[cfg(test)]
mod tests {
    use super::*;

    /// Every operation the model uses, on awkward values, lane by lane
    /// against `f64`: the same bits.
    #[test]
    fn pair_lanes_equal_f64_bit_for_bit() {
        let values = [
            0.0,
            -0.0,
            1.0,
            -2.5,
            1e-310,
            -1e-310,
            3.7e300,
            f64::MIN_POSITIVE,
            0.1,
            7.3,
        ];
        for &a in &values {
            for &b in &values {
                let p = Pair::from_lanes([a, b]);
                let q = Pair::from_lanes([b, a]);
                let check = |got: Pair, want: [f64; 2], what: &str| {
                    let g = got.lanes();
                    assert!(
                        g[0].to_bits() == want[0].to_bits() && g[1].to_bits() == want[1].to_bits(),
                        "{what}({a:e}, {b:e}): {g:?} against {want:?}"
                    );
                };
                check(p + q, [a + b, b + a], "add");
                check(p - q, [a - b, b - a], "sub");
                check(p * q, [a * b, b * a], "mul");
                check(p / q, [a / b, b / a], "div");
                check(p * 0.5, [a * 0.5, b * 0.5], "mul f64");
                check(-p, [-a, -b], "neg");
                check(p.max0(), [a.max(0.0), b.max(0.0)], "max0");
                check(
                    p.if_gt(q, Pair::splat(1.0), Pair::splat(2.0)),
                    [a.if_gt(b, 1.0, 2.0), b.if_gt(a, 1.0, 2.0)],
                    "if_gt",
                );
                check(
                    q.unless_negative(p),
                    [b.unless_negative(a), a.unless_negative(b)],
                    "unless_negative",
                );
                check(
                    p.select_zero(Pair::splat(9.0), q),
                    [a.select_zero(9.0, b), b.select_zero(9.0, a)],
                    "select_zero",
                );
            }
        }
    }
}
