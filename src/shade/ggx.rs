//! The GGX (Trowbridge–Reitz) microfacet distribution, isotropic, in the local frame where the
//! macro-surface normal is +z. All directions point away from the surface.
//!
//! Masking-shadowing is Smith's height-correlated form (Heitz 2014), the one glTF 2.0
//! Appendix B specifies; importance sampling draws visible normals (Heitz 2018), so no sample
//! is spent on microfacets the viewer cannot see.

use std::f32::consts::{PI, TAU};

use glam::Vec3;

use crate::lanes::Lanes;

#[derive(Clone, Copy, Debug)]
pub struct Ggx {
    /// Width parameter α = perceptual roughness².
    alpha: f32,
}

impl Ggx {
    /// Below this α the lobe is a near-mirror whose D overflows useful f32 ranges; glTF
    /// roughness 0 renders as this.
    pub const MIN_ALPHA: f32 = 1e-3;

    pub fn from_roughness(roughness: f32) -> Self {
        let roughness = if roughness.is_finite() {
            roughness.clamp(0.0, 1.0)
        } else {
            1.0
        };
        Ggx {
            alpha: (roughness * roughness).max(Self::MIN_ALPHA),
        }
    }

    pub fn alpha(&self) -> f32 {
        self.alpha
    }

    /// Normal distribution D(h) = α² / (π ((n·h)² (α² − 1) + 1)²).
    pub fn distribution(&self, h: Vec3) -> f32 {
        distribution(self.alpha, h.z)
    }

    /// Masking of one direction, G1 = 1 / (1 + Λ).
    pub fn masking(&self, w: Vec3) -> f32 {
        masking(self.alpha, w.z)
    }

    /// Height-correlated visibility V = G2 / (4 |n·wo| |n·wi|), in the finite form of glTF
    /// Appendix B; zero unless both directions are above the surface.
    pub fn visibility(&self, wo: Vec3, wi: Vec3) -> f32 {
        visibility(self.alpha, wo.z, wi.z)
    }

    /// A microfacet normal drawn from the distribution of normals visible from `wo`
    /// (Heitz 2018, "Sampling the GGX Distribution of Visible Normals"). Requires wo.z > 0.
    pub fn sample_visible_normal(&self, wo: Vec3, u: [f32; 2]) -> Vec3 {
        // Stretch the view direction to the configuration where the distribution is a
        // hemisphere of unit roughness.
        let vh = Vec3::new(self.alpha * wo.x, self.alpha * wo.y, wo.z).normalize();
        let length2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if length2 > 0.0 {
            Vec3::new(-vh.y, vh.x, 0.0) / length2.sqrt()
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        // Uniform point on the projected area: a disk, half of it foreshortened.
        let r = u[0].sqrt();
        let phi = TAU * u[1];
        let p1 = r * phi.cos();
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
        let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        // Unstretch.
        Vec3::new(self.alpha * nh.x, self.alpha * nh.y, nh.z.max(0.0)).normalize_or(Vec3::Z)
    }

    /// Density of [`Ggx::sample_visible_normal`]: D_wo(h) = G1(wo) max(0, wo·h) D(h) / (n·wo).
    pub fn visible_normal_pdf(&self, wo: Vec3, h: Vec3) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        self.masking(wo) * wo.dot(h).max(0.0) * self.distribution(h) / wo.z
    }

    /// Density of the direction wi reached by reflecting wo about a visible normal:
    /// D_wo(h) / (4 wo·h), the Jacobian of reflection.
    pub fn reflection_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let h = (wo + wi).normalize_or_zero();
        self.reflection_pdf_at(wo, h, self.distribution(h))
    }

    /// [`Ggx::reflection_pdf`] given the half vector `h` of (wo, wi) and D(h), for callers that
    /// already have them. The wo·h of the visible-normal density cancels the Jacobian's:
    /// G1(wo) D(h) / (4 n·wo).
    pub fn reflection_pdf_at(&self, wo: Vec3, h: Vec3, distribution: f32) -> f32 {
        reflection_pdf_at(self.alpha, wo.z, wo.dot(h), distribution)
    }
}

// The distribution's terms for a group of lanes (`f32` for one direction, `f32x8` for eight;
// see `crate::lanes`), each with the cosines to the normal it needs. Every branch of the
// scalar form is a select, so one lane gives what `f32` gives.

/// D(h) = α² / (π ((n·h)² (α² − 1) + 1)²), zero where n·h ≤ 0.
#[inline(always)]
pub(crate) fn distribution<L: Lanes>(alpha: L, cos_h: L) -> L {
    let a2 = alpha * alpha;
    let denominator = cos_h * cos_h * (a2 - L::splat(1.0)) + L::splat(1.0);
    let d = a2 / (L::splat(PI) * denominator * denominator);
    L::select(cos_h.le(L::splat(0.0)), L::splat(0.0), d)
}

/// Smith Λ(w) = (−1 + √(1 + α² tan²θ)) / 2, written with cos θ to stay finite at normal
/// incidence; infinite where cos θ = 0.
#[inline(always)]
fn lambda<L: Lanes>(alpha: L, cos: L) -> L {
    let cos2 = cos * cos;
    let tan2 = ((L::splat(1.0) - cos2) / cos2).max(L::splat(0.0));
    let lambda = L::splat(0.5) * ((L::splat(1.0) + alpha * alpha * tan2).sqrt() - L::splat(1.0));
    L::select(cos2.le(L::splat(0.0)), L::splat(f32::INFINITY), lambda)
}

/// Masking of one direction, G1 = 1 / (1 + Λ).
#[inline(always)]
pub(crate) fn masking<L: Lanes>(alpha: L, cos: L) -> L {
    L::splat(1.0) / (L::splat(1.0) + lambda(alpha, cos))
}

/// Height-correlated visibility V = G2 / (4 |n·wo| |n·wi|), in the finite form of glTF
/// Appendix B: 0.5 / (n·wi √((n·wo)²(1 − α²) + α²) + n·wo √((n·wi)²(1 − α²) + α²)); zero unless
/// both directions are above the surface.
#[inline(always)]
pub(crate) fn visibility<L: Lanes>(alpha: L, cos_o: L, cos_i: L) -> L {
    let a2 = alpha * alpha;
    let term_o = (cos_o * cos_o * (L::splat(1.0) - a2) + a2).sqrt();
    let term_i = (cos_i * cos_i * (L::splat(1.0) - a2) + a2).sqrt();
    let v = L::splat(0.5) / (cos_i * term_o + cos_o * term_i);
    let zero = L::splat(0.0);
    L::select(cos_o.le(zero) | cos_i.le(zero), zero, v)
}

/// Density of the direction reached by reflecting wo about a visible normal h, given n·wo,
/// wo·h and D(h): the visible-normal density's wo·h cancels the reflection's Jacobian 1/(4 wo·h),
/// leaving G1(wo) D(h) / (4 n·wo); zero unless n·wo and wo·h are positive.
#[inline(always)]
pub(crate) fn reflection_pdf_at<L: Lanes>(alpha: L, cos_o: L, cos_oh: L, distribution: L) -> L {
    let pdf = masking(alpha, cos_o) * distribution / (L::splat(4.0) * cos_o);
    let zero = L::splat(0.0);
    L::select(cos_o.le(zero) | cos_oh.le(zero), zero, pdf)
}

/// Reflection of `w` about the unit normal `h`.
pub fn reflect(w: Vec3, h: Vec3) -> Vec3 {
    h * (2.0 * w.dot(h)) - w
}
