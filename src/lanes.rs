//! The arithmetic the batch kernels are written in, over one `f32` lane, two or eight.
//!
//! The lens kernel's surface step (`lens::trace_batch`'s `refract_at`) and the BSDF's
//! evaluation ([`crate::shade::bsdf`]) are each written once against [`Lanes`]:
//! with `f32` they are the per-ray reference (and the plain kernel, vectorised by the compiler),
//! with [`Pair`] the plain kernel's two interleaved rays, with `wide::f32x8` they run eight
//! rays or path vertices at once. Every operation here is one IEEE-754 operation with the same
//! rounding in each (no fused multiply-add; `max` is a compare and a select), so all three give
//! bit-identical results.

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

use wide::f32x8;

/// Lane masks: `bool` for one lane, all-ones/all-zeros `f32` lanes for eight.
pub trait LaneMask:
    Copy + BitAnd<Output = Self> + BitOr<Output = Self> + Not<Output = Self>
{
}

/// Floating-point lanes with the operations the lens kernel needs.
pub trait Lanes:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    type Mask: LaneMask;
    fn splat(value: f32) -> Self;
    fn sqrt(self) -> Self;
    fn lt(self, other: Self) -> Self::Mask;
    fn le(self, other: Self) -> Self::Mask;
    fn gt(self, other: Self) -> Self::Mask;
    fn ge(self, other: Self) -> Self::Mask;
    fn eq(self, other: Self) -> Self::Mask;
    /// Neither infinite nor NaN.
    fn is_finite(self) -> Self::Mask;
    fn select(mask: Self::Mask, if_true: Self, if_false: Self) -> Self;

    /// True when any lane of `mask` is set.
    fn any(mask: Self::Mask) -> bool;

    /// `if self > other { self } else { other }`, spelled out with a compare and a select so
    /// that every implementation agrees for NaN and signed zeros too (platform `max`
    /// instructions differ there).
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        Self::select(self.gt(other), self, other)
    }

    /// |self| as a compare and a select, for the same reason.
    #[inline(always)]
    fn abs(self) -> Self {
        Self::select(self.lt(Self::splat(0.0)), -self, self)
    }
}

impl LaneMask for bool {}

impl Lanes for f32 {
    type Mask = bool;
    #[inline(always)]
    fn splat(value: f32) -> Self {
        value
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn lt(self, other: Self) -> bool {
        self < other
    }
    #[inline(always)]
    fn le(self, other: Self) -> bool {
        self <= other
    }
    #[inline(always)]
    fn gt(self, other: Self) -> bool {
        self > other
    }
    #[inline(always)]
    fn ge(self, other: Self) -> bool {
        self >= other
    }
    #[inline(always)]
    fn eq(self, other: Self) -> bool {
        self == other
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline(always)]
    fn select(mask: bool, if_true: Self, if_false: Self) -> Self {
        if mask { if_true } else { if_false }
    }
    #[inline(always)]
    fn any(mask: bool) -> bool {
        mask
    }
}

impl LaneMask for f32x8 {}

impl Lanes for f32x8 {
    type Mask = f32x8;
    #[inline(always)]
    fn splat(value: f32) -> Self {
        f32x8::splat(value)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32x8::sqrt(self)
    }
    #[inline(always)]
    fn lt(self, other: Self) -> f32x8 {
        self.simd_lt(other)
    }
    #[inline(always)]
    fn le(self, other: Self) -> f32x8 {
        self.simd_le(other)
    }
    #[inline(always)]
    fn gt(self, other: Self) -> f32x8 {
        self.simd_gt(other)
    }
    #[inline(always)]
    fn ge(self, other: Self) -> f32x8 {
        self.simd_ge(other)
    }
    #[inline(always)]
    fn eq(self, other: Self) -> f32x8 {
        self.simd_eq(other)
    }
    #[inline(always)]
    fn is_finite(self) -> f32x8 {
        f32x8::is_finite(self)
    }
    #[inline(always)]
    fn select(mask: f32x8, if_true: Self, if_false: Self) -> Self {
        mask.select(if_true, if_false)
    }
    #[inline(always)]
    fn any(mask: f32x8) -> bool {
        mask.any()
    }
}

/// Two `f32` lanes side by side, each operation done for both at once: a loop over rays in
/// `Pair`s, vectorised by the compiler, runs two independent vectors through every operation in
/// turn, so that a long chain of dependent operations (the lens kernel's surface step, square
/// roots and a division among them) keeps the core busy with the other chain while one waits.
/// Each lane sees exactly the `f32` operations, so the bits are `f32`'s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair(pub f32, pub f32);

/// [`Pair`]'s mask: one `bool` per lane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PairMask(pub bool, pub bool);

impl LaneMask for PairMask {}

impl BitAnd for PairMask {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, other: Self) -> Self {
        PairMask(self.0 & other.0, self.1 & other.1)
    }
}

impl BitOr for PairMask {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, other: Self) -> Self {
        PairMask(self.0 | other.0, self.1 | other.1)
    }
}

impl Not for PairMask {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        PairMask(!self.0, !self.1)
    }
}

/// `Pair`'s arithmetic operators, lane by lane.
macro_rules! pair_operators {
    ($($trait:ident $method:ident $op:tt),*) => {$(
        impl $trait for Pair {
            type Output = Self;
            #[inline(always)]
            fn $method(self, other: Self) -> Self {
                Pair(self.0 $op other.0, self.1 $op other.1)
            }
        }
    )*};
}

pair_operators!(Add add +, Sub sub -, Mul mul *, Div div /);

impl Neg for Pair {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Pair(-self.0, -self.1)
    }
}

/// `Pair`'s comparisons, lane by lane.
macro_rules! pair_comparisons {
    ($($method:ident),*) => {$(
        #[inline(always)]
        fn $method(self, other: Self) -> PairMask {
            PairMask(
                <f32 as Lanes>::$method(self.0, other.0),
                <f32 as Lanes>::$method(self.1, other.1),
            )
        }
    )*};
}

impl Lanes for Pair {
    type Mask = PairMask;
    #[inline(always)]
    fn splat(value: f32) -> Self {
        Pair(value, value)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Pair(self.0.sqrt(), self.1.sqrt())
    }
    pair_comparisons!(lt, le, gt, ge, eq);
    #[inline(always)]
    fn is_finite(self) -> PairMask {
        PairMask(self.0.is_finite(), self.1.is_finite())
    }
    #[inline(always)]
    fn select(mask: PairMask, if_true: Self, if_false: Self) -> Self {
        Pair(
            <f32 as Lanes>::select(mask.0, if_true.0, if_false.0),
            <f32 as Lanes>::select(mask.1, if_true.1, if_false.1),
        )
    }
    #[inline(always)]
    fn any(mask: PairMask) -> bool {
        mask.0 | mask.1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Awkward values: signed zeros, subnormals, infinities, NaN, and ordinary ones.
    const VALUES: [f32; 10] = [
        0.0,
        -0.0,
        1.0e-40,
        -2.5,
        3.0,
        0.1,
        f32::MAX,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
    ];

    /// Every `Pair` operation is the `f32` one in each lane, to the bit (the lens kernel's
    /// paired loop relies on it to give the reference's rays).
    #[test]
    fn a_pair_computes_each_lane_as_f32_does() {
        let bits = |p: Pair| [p.0.to_bits(), p.1.to_bits()];
        for &a in &VALUES {
            for &b in &VALUES {
                // The second lane gets the operands the other way round, so the lanes differ.
                let (x, y) = (Pair(a, b), Pair(b, a));
                let each = |f: fn(f32, f32) -> f32| [f(a, b).to_bits(), f(b, a).to_bits()];
                assert_eq!(bits(x + y), each(|p, q| p + q));
                assert_eq!(bits(x - y), each(|p, q| p - q));
                assert_eq!(bits(x * y), each(|p, q| p * q));
                assert_eq!(bits(x / y), each(|p, q| p / q));
                assert_eq!(bits(x.max(y)), each(<f32 as Lanes>::max));
                assert_eq!(bits(-x), [(-a).to_bits(), (-b).to_bits()]);
                assert_eq!(bits(x.sqrt()), [a.sqrt().to_bits(), b.sqrt().to_bits()]);
                assert_eq!(
                    bits(x.abs()),
                    [Lanes::abs(a).to_bits(), Lanes::abs(b).to_bits()]
                );
                let masks = |f: fn(f32, f32) -> bool| PairMask(f(a, b), f(b, a));
                assert_eq!(x.lt(y), masks(<f32 as Lanes>::lt));
                assert_eq!(x.le(y), masks(<f32 as Lanes>::le));
                assert_eq!(x.gt(y), masks(<f32 as Lanes>::gt));
                assert_eq!(x.ge(y), masks(<f32 as Lanes>::ge));
                assert_eq!(x.eq(y), masks(<f32 as Lanes>::eq));
                assert_eq!(x.is_finite(), PairMask(a.is_finite(), b.is_finite()));
                let mask = x.lt(y);
                assert_eq!(
                    bits(Pair::select(mask, x, y)),
                    [
                        <f32 as Lanes>::select(mask.0, a, b).to_bits(),
                        <f32 as Lanes>::select(mask.1, b, a).to_bits()
                    ]
                );
                assert_eq!(Pair::any(mask), mask.0 || mask.1);
                assert_eq!(!mask & mask, PairMask(false, false));
                assert_eq!(!mask | mask, PairMask(true, true));
            }
        }
    }
}
