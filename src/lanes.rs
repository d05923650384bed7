//! The arithmetic the batch kernels are written in, over one `f32` lane or eight.
//!
//! The lens kernel's surface step (`lens::trace_batch`'s `refract_at`) and the BSDF's
//! evaluation ([`crate::shade::bsdf`]) are each written once against [`Lanes`]:
//! with `f32` they are the per-ray reference (and the plain kernel, vectorised by the compiler),
//! with `wide::f32x8` they run eight rays or path vertices at once. Every operation here is one
//! IEEE-754 operation with the same rounding in both (no fused multiply-add; `max` is a compare
//! and a select), so both give bit-identical results.

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
