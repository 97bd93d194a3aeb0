//! The number type of the model's equations: one patient (`f64`) or
//! several patients side by side ([`Lanes`]), so that the equations in
//! `model.rs` are written once and read the same for both.
//!
//! [`Lanes`] holds one value per patient in a plain array; every operation
//! is a loop over the lanes that the compiler turns into vector
//! instructions. Branches of the model (the renal threshold, the EGP floor,
//! the sign guards, the empty-stomach shortcut) become per-lane selects.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Arithmetic the model needs, for one patient or for [`Lanes`].
pub trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
{
    /// The same value for every patient.
    fn splat(v: f64) -> Self;
    /// `a` where `self > other`, else `b` (per lane).
    fn if_gt(self, other: Self, a: Self, b: Self) -> Self;
    /// `a` where `self == 0`, else `b()` (per lane). One patient
    /// evaluates `b` only when it is chosen; lanes evaluate it once for all.
    fn if_zero(self, a: Self, b: impl FnOnce() -> Self) -> Self;
    /// `a` where `self == 0`, else `b` (per lane), both already computed.
    fn select_zero(self, a: Self, b: Self) -> Self;
    /// True when [`Real::if_zero`] evaluates its alternative for every
    /// value anyway (lanes): callers then compute it inline.
    const EAGER: bool;
    /// 0 where `mass < 0`, else `self` (the model's sign guards).
    fn unless_negative(self, mass: Self) -> Self;
    /// max(self, 0) as `f64::max`.
    fn max0(self) -> Self;
    /// e^self for a tanh, where arguments beyond ±40 all saturate it. One
    /// patient: libm's `exp` of `self`; lanes: [`exp_small`] (within 2
    /// ulp) of `self` clamped to [−40, 40], which keeps it in range.
    fn exp_for_tanh(self) -> Self;
}

impl Real for f64 {
    const EAGER: bool = false;
    #[inline(always)]
    fn select_zero(self, a: Self, b: Self) -> Self {
        if self == 0.0 {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn splat(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn if_gt(self, other: Self, a: Self, b: Self) -> Self {
        if self > other {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn if_zero(self, a: Self, b: impl FnOnce() -> Self) -> Self {
        if self == 0.0 {
            a
        } else {
            b()
        }
    }
    #[inline(always)]
    fn unless_negative(self, mass: Self) -> Self {
        if mass < 0.0 {
            0.0
        } else {
            self
        }
    }
    #[inline(always)]
    fn max0(self) -> Self {
        self.max(0.0)
    }
    #[inline(always)]
    fn exp_for_tanh(self) -> Self {
        f64::exp(self)
    }
}

/// One value per patient for `W` patients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lanes<const W: usize>(pub [f64; W]);

impl<const W: usize> Lanes<W> {
    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        let mut out = self.0;
        for v in out.iter_mut() {
            *v = f(*v);
        }
        Self(out)
    }

    #[inline(always)]
    fn zip(self, other: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        let mut out = self.0;
        for (v, o) in out.iter_mut().zip(other.0) {
            *v = f(*v, o);
        }
        Self(out)
    }

    /// `a` where `mask`, else `b`, as bit operations (no branches).
    #[inline(always)]
    fn select(mask: [bool; W], a: Self, b: Self) -> Self {
        let mut out = b.0;
        for ((v, m), x) in out.iter_mut().zip(mask).zip(a.0) {
            let bits = 0u64.wrapping_sub(u64::from(m));
            *v = f64::from_bits((x.to_bits() & bits) | (v.to_bits() & !bits));
        }
        Self(out)
    }
}

macro_rules! lane_ops {
    ($($tr:ident $f:ident $op:tt),*) => {$(
        impl<const W: usize> $tr for Lanes<W> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: Self) -> Self {
                self.zip(o, |a, b| a $op b)
            }
        }
        impl<const W: usize> $tr<f64> for Lanes<W> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: f64) -> Self {
                self.map(|a| a $op o)
            }
        }
    )*};
}
lane_ops!(Add add +, Sub sub -, Mul mul *, Div div /);

impl<const W: usize> Neg for Lanes<W> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(|a| -a)
    }
}

impl<const W: usize> Real for Lanes<W> {
    const EAGER: bool = true;
    #[inline(always)]
    fn select_zero(self, a: Self, b: Self) -> Self {
        let mask = self.0.map(|x| x == 0.0);
        Self::select(mask, a, b)
    }
    #[inline(always)]
    fn splat(v: f64) -> Self {
        Self([v; W])
    }
    #[inline(always)]
    fn if_gt(self, other: Self, a: Self, b: Self) -> Self {
        let mut mask = [false; W];
        for ((m, x), y) in mask.iter_mut().zip(self.0).zip(other.0) {
            *m = x > y;
        }
        Self::select(mask, a, b)
    }
    #[inline(always)]
    fn if_zero(self, a: Self, b: impl FnOnce() -> Self) -> Self {
        let mask = self.0.map(|x| x == 0.0);
        Self::select(mask, a, b())
    }
    #[inline(always)]
    fn unless_negative(self, mass: Self) -> Self {
        let mask = mass.0.map(|m| m < 0.0);
        Self::select(mask, Self::splat(0.0), self)
    }
    #[inline(always)]
    fn max0(self) -> Self {
        self.map(|a| a.max(0.0))
    }
    #[inline(always)]
    fn exp_for_tanh(self) -> Self {
        self.map(|a| exp_small(a.clamp(-40.0, 40.0)))
    }
}

/// e^t for |t| <= 700 to within 2 ulp, branch-free, so that it vectorises.
///
/// The classic reduction t = k·ln 2 + r with k = round(t/ln 2) and
/// |r| <= ln2/2 (ln 2 split in a high part with trailing zero bits, so that
/// k·ln2_hi is exact, and a low part); e^r by its Taylor series to degree
/// 13 (the first omitted term is below 5e-18 relative) in Estrin's form;
/// 2^k assembled from exponent bits. k is read from the bits of the
/// rounding sum, so no float-to-integer conversion is needed.
#[inline(always)]
pub fn exp_small(t: f64) -> f64 {
    const LOG2_E: f64 = std::f64::consts::LOG2_E;
    // ln 2 rounded to 32 significant bits (exact products with small k),
    // and the rest.
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    // 1.5·2^52: adding and subtracting it rounds to the nearest integer;
    // the sum's low mantissa bits hold that integer.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let shifted = t * LOG2_E + ROUND;
    let k = shifted - ROUND;
    let r = (t - k * LN2_HI) - k * LN2_LO;
    let c = &INV_FACTORIAL;
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let q0 = (c[0] + c[1] * r) + (c[2] + c[3] * r) * r2;
    let q1 = (c[4] + c[5] * r) + (c[6] + c[7] * r) * r2;
    let q2 = (c[8] + c[9] * r) + (c[10] + c[11] * r) * r2;
    let s0 = q0 + q1 * r4;
    let s1 = q2 + (c[12] + c[13] * r) * r4;
    let p = s0 + s1 * r8;
    // Bits of 2^k: the biased exponent k + 1023 in the top 12 bits. The
    // top bits of `shifted` (those of 1.5·2^52) shift out.
    let two_k = f64::from_bits(shifted.to_bits().wrapping_add(1023) << 52);
    p * two_k
}

/// 1/n! for n = 0..=13.
const INV_FACTORIAL: [f64; 14] = [
    1.0,
    1.0,
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5_040.0,
    1.0 / 40_320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
    1.0 / 39_916_800.0,
    1.0 / 479_001_600.0,
    1.0 / 6_227_020_800.0,
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectorisable_exp_is_within_two_ulp_of_libm() {
        let mut worst: f64 = 0.0;
        for k in -700_000..=700_000 {
            let t = k as f64 * 1e-3;
            let reference = t.exp();
            worst = worst.max(((exp_small(t) - reference) / reference).abs());
        }
        assert!(worst < 4.5e-16, "largest relative error {worst:e}");
    }

    #[test]
    fn lanes_choose_per_lane() {
        let a = Lanes([1.0, -2.0, 0.0, 3.0]);
        let guarded = Lanes::splat(5.0).unless_negative(a);
        assert_eq!(guarded.0, [5.0, 0.0, 5.0, 5.0]);
        let z = a.if_zero(Lanes::splat(9.0), || a);
        assert_eq!(z.0, [1.0, -2.0, 9.0, 3.0]);
        let g = a.if_gt(Lanes::splat(0.5), Lanes::splat(1.0), Lanes::splat(0.0));
        assert_eq!(g.0, [1.0, 0.0, 0.0, 1.0]);
    }
}
