//! The glTF 2.0 metallic-roughness BRDF (specification Appendix B), in the local shading frame
//! (normal = +z, directions pointing away from the surface).
//!
//! glTF defines the material as `mix(dielectric_brdf, metal_brdf, metallic)` with
//! - `metal_brdf = conductor_fresnel(f0 = baseColor, specular_brdf(α))`
//! - `dielectric_brdf = fresnel_mix(ior = 1.5, diffuse_brdf(baseColor), specular_brdf(α))`
//!
//! where `specular_brdf` is GGX with height-correlated Smith visibility, `diffuse_brdf` is
//! Lambert and both Fresnel terms are Schlick's with F0 = 0.04 for the dielectric. This module
//! evaluates that mix exactly: the diffuse base is weighted by (1 − metallic)(1 − F_dielectric).
//! (Appendix B's "simplified implementation" weights it by 1 − F(mixed F0) instead; the two
//! agree at metallic 0 and 1.) Single scattering only, so rough specular loses some energy.

use std::f32::consts::FRAC_1_PI;

use glam::Vec3;

use wide::f32x8;

use super::ggx::{self, Ggx, reflect};
use super::warp::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::lanes::Lanes;

/// Normal-incidence reflectance of glTF's dielectric, ((ior − 1) / (ior + 1))² at ior 1.5.
pub const DIELECTRIC_F0: f32 = 0.04;

/// Rec. 709 luminance (the Y of the linear RGB working space).
pub fn luminance(rgb: Vec3) -> f32 {
    rgb.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// Schlick's Fresnel approximation at the cosine between the view and the microfacet normal.
fn schlick(f0: Vec3, cos_theta: f32) -> Vec3 {
    let weight = schlick_weight(cos_theta);
    Vec3::from_array(f0.to_array().map(|f0| schlick_mix(f0, weight)))
}

fn schlick_scalar(f0: f32, cos_theta: f32) -> f32 {
    schlick_mix(f0, schlick_weight(cos_theta))
}

/// Schlick's F = F0 + (1 − F0)·w, given w = [`schlick_weight`].
#[inline(always)]
fn schlick_mix<L: Lanes>(f0: L, weight: L) -> L {
    f0 + (L::splat(1.0) - f0) * weight
}

/// Schlick's (1 − cos θ)⁵, cos θ clamped to [0, 1]; the fifth power as `powi(5)` computes it,
/// x·(x²)², so every lane count gives the same bits.
#[inline(always)]
fn schlick_weight<L: Lanes>(cos_theta: L) -> L {
    let (zero, one) = (L::splat(0.0), L::splat(1.0));
    // f32::clamp, as compares and selects.
    let cos_theta = L::select(cos_theta.lt(zero), zero, cos_theta);
    let cos_theta = L::select(cos_theta.gt(one), one, cos_theta);
    let x = one - cos_theta;
    let x2 = x * x;
    x * (x2 * x2)
}

/// A drawn incident direction with its BRDF value and density (solid angle, over both lobes).
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub value: Vec3,
    pub pdf: f32,
}

/// What drawing a sample of a [`MetalRoughBsdf`] begins with ([`MetalRoughBsdf::begin_sample`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct SampleStart {
    /// The specular lobe's selection probability at wo.
    pub p_specular: f32,
    /// The direction drawn; `None` below the surface (the path ends).
    pub wi: Option<Vec3>,
}

impl BsdfSample {
    /// The sample of direction `wi` with the BRDF's value and density there: `None` where the
    /// density is not positive and finite (the path ends).
    pub(crate) fn of(wi: Vec3, value: Vec3, pdf: f32) -> Option<BsdfSample> {
        (pdf > 0.0 && pdf.is_finite()).then_some(BsdfSample { wi, value, pdf })
    }
}

/// The glTF metallic-roughness BRDF at one surface point.
#[derive(Clone, Copy, Debug)]
pub struct MetalRoughBsdf {
    /// Lambert albedo of the dielectric base, (1 − metallic) × base colour.
    diffuse: Vec3,
    /// Specular F0 mixed over dielectric and metal: lerp(0.04, base colour, metallic).
    f0: Vec3,
    ggx: Ggx,
}

impl MetalRoughBsdf {
    pub fn new(base_color: Vec3, metallic: f32, roughness: f32) -> Self {
        let base_color = if base_color.is_finite() {
            base_color.clamp(Vec3::ZERO, Vec3::ONE)
        } else {
            Vec3::ONE
        };
        let metallic = if metallic.is_finite() {
            metallic.clamp(0.0, 1.0)
        } else {
            1.0
        };
        MetalRoughBsdf {
            diffuse: base_color * (1.0 - metallic),
            f0: Vec3::splat(DIELECTRIC_F0).lerp(base_color, metallic),
            ggx: Ggx::from_roughness(roughness),
        }
    }

    /// BRDF value f(wo, wi) (no cosine); zero unless both directions are above the surface.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.eval_and_pdf(wo, wi).0
    }

    /// [`MetalRoughBsdf::eval`] and [`MetalRoughBsdf::pdf`] together: they share the half
    /// vector and D(h), and a path vertex needs both.
    pub fn eval_and_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        self.eval_and_pdf_above(wo, wi, self.specular_probability(wo))
    }

    /// [`MetalRoughBsdf::eval_and_pdf`] for directions both above the surface, given the
    /// specular lobe's selection probability at `wo` ([`eval_and_pdf_above`] for one lane).
    pub(crate) fn eval_and_pdf_above(&self, wo: Vec3, wi: Vec3, p_specular: f32) -> (Vec3, f32) {
        let (value, pdf) =
            eval_and_pdf_above(&self.lanes(), wo.to_array(), wi.to_array(), p_specular);
        (Vec3::from_array(value), pdf)
    }

    /// This BSDF's parameters as one lane of [`BsdfLanes`].
    pub(crate) fn lanes(&self) -> BsdfLanes<f32> {
        BsdfLanes {
            diffuse: self.diffuse.to_array(),
            f0: self.f0.to_array(),
            alpha: self.ggx.alpha(),
        }
    }

    /// Probability of drawing from the specular lobe, by each lobe's rough share of the
    /// reflected energy at this view angle. Both lobes keep some chance while both exist.
    pub(crate) fn specular_probability(&self, wo: Vec3) -> f32 {
        let specular = luminance(schlick(self.f0, wo.z));
        let diffuse = luminance(self.diffuse) * (1.0 - schlick_scalar(DIELECTRIC_F0, wo.z));
        if diffuse <= 0.0 {
            return 1.0;
        }
        (specular / (specular + diffuse)).clamp(0.1, 0.9)
    }

    /// Density of [`MetalRoughBsdf::sample`] drawing `wi` (solid angle), both lobes combined.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_and_pdf(wo, wi).1
    }

    /// Draws wi: a lobe by `u_lobe`, then a visible GGX normal or a cosine-weighted direction by
    /// `u`. `None` when the draw leaves the hemisphere (the path ends: the energy the
    /// single-scattering model does not reflect).
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: [f32; 2]) -> Option<BsdfSample> {
        let start = self.begin_sample(wo, u_lobe, u)?;
        let wi = start.wi?;
        let (value, pdf) = self.eval_and_pdf_above(wo, wi, start.p_specular);
        BsdfSample::of(wi, value, pdf)
    }

    /// [`MetalRoughBsdf::sample`] before its evaluation: the specular lobe's probability at
    /// `wo`, and the direction drawn (a lobe by `u_lobe`, then a direction by `u`); `None`
    /// with `wo` below the surface, where the BSDF is zero.
    pub(crate) fn begin_sample(&self, wo: Vec3, u_lobe: f32, u: [f32; 2]) -> Option<SampleStart> {
        if wo.z <= 0.0 {
            return None;
        }
        let p_specular = self.specular_probability(wo);
        let wi = if u_lobe < p_specular {
            reflect(wo, self.ggx.sample_visible_normal(wo, u))
        } else {
            cosine_hemisphere(u)
        };
        Some(SampleStart {
            p_specular,
            wi: (wi.z > 0.0).then_some(wi),
        })
    }
}

/// A [`MetalRoughBsdf`]'s parameters for a group of lanes (one path vertex each; see
/// [`crate::lanes`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct BsdfLanes<L> {
    /// Lambert albedo of the dielectric base.
    pub diffuse: [L; 3],
    /// Specular F0, mixed over dielectric and metal.
    pub f0: [L; 3],
    /// GGX width α.
    pub alpha: L,
}

/// f(wo, wi) and the density of drawing wi ([`MetalRoughBsdf::eval_and_pdf`]) for directions
/// both above the surface, given the specular lobe's selection probability at wo, for a group
/// of lanes: the one implementation, which the scalar BSDF runs with `f32` and the wavefront's
/// batched evaluation with eight lanes. The half vector is glam's `normalize_or_zero` (times the
/// reciprocal length where that is finite and positive); where it is zero, so are both results.
#[inline(always)]
pub(crate) fn eval_and_pdf_above<L: Lanes>(
    bsdf: &BsdfLanes<L>,
    wo: [L; 3],
    wi: [L; 3],
    p_specular: L,
) -> ([L; 3], L) {
    let (zero, one) = (L::splat(0.0), L::splat(1.0));
    let dot = |a: [L; 3], b: [L; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let sum = [wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]];
    let reciprocal = one / dot(sum, sum).sqrt();
    let normalisable = reciprocal.is_finite() & reciprocal.gt(zero);
    let h = sum.map(|c| L::select(normalisable, c * reciprocal, zero));
    let no_half_vector = h[0].eq(zero) & h[1].eq(zero) & h[2].eq(zero);
    let cos_oh = dot(wo, h);
    let distribution = ggx::distribution(bsdf.alpha, h[2]);
    let fresnel = schlick_weight(cos_oh);
    // fresnel_mix: the diffuse base sees what the dielectric coating transmits.
    let dielectric = schlick_mix(L::splat(DIELECTRIC_F0), fresnel);
    let diffuse_factor = (one - dielectric) * L::splat(FRAC_1_PI);
    let specular_factor = distribution * ggx::visibility(bsdf.alpha, wo[2], wi[2]);
    let value: [L; 3] = std::array::from_fn(|c| {
        let specular = schlick_mix(bsdf.f0[c], fresnel) * specular_factor;
        L::select(
            no_half_vector,
            zero,
            bsdf.diffuse[c] * diffuse_factor + specular,
        )
    });
    let pdf = p_specular * ggx::reflection_pdf_at(bsdf.alpha, wo[2], cos_oh, distribution)
        + (one - p_specular) * cosine_hemisphere_pdf(wi[2]);
    (value, L::select(no_half_vector, zero, pdf))
}

/// Evaluations of many path vertices' BSDFs ([`eval_and_pdf_above`]), gathered as a structure
/// of arrays and made eight lanes at a time: the wavefront's batched half of a vertex step
/// (see `Shader::step_paths`). Each lane computes what [`MetalRoughBsdf::eval_and_pdf`] does
/// for its vertex, bit for bit.
pub(crate) struct EvalBatch {
    len: usize,
    diffuse: [[f32; EVAL_BATCH]; 3],
    f0: [[f32; EVAL_BATCH]; 3],
    alpha: [f32; EVAL_BATCH],
    wo: [[f32; EVAL_BATCH]; 3],
    wi: [[f32; EVAL_BATCH]; 3],
    p_specular: [f32; EVAL_BATCH],
    value: [[f32; EVAL_BATCH]; 3],
    pdf: [f32; EVAL_BATCH],
}

/// Evaluations an [`EvalBatch`] holds.
pub(crate) const EVAL_BATCH: usize = 64;

/// Lanes of one evaluation step.
const EVAL_LANES: usize = 8;

impl EvalBatch {
    pub(crate) fn new() -> EvalBatch {
        let zeros = [0.0; EVAL_BATCH];
        EvalBatch {
            len: 0,
            diffuse: [zeros; 3],
            f0: [zeros; 3],
            alpha: zeros,
            wo: [zeros; 3],
            wi: [zeros; 3],
            p_specular: zeros,
            value: [zeros; 3],
            pdf: zeros,
        }
    }

    pub(crate) fn clear(&mut self) {
        self.len = 0;
    }

    /// Asks for `bsdf`'s value and density at (`wo`, `wi`), both above the surface, with the
    /// specular lobe's probability `p_specular` at `wo`; returns the evaluation's index.
    /// At most [`EVAL_BATCH`] between clears.
    pub(crate) fn push(
        &mut self,
        bsdf: &MetalRoughBsdf,
        wo: Vec3,
        wi: Vec3,
        p_specular: f32,
    ) -> usize {
        let i = self.len;
        let lanes = bsdf.lanes();
        for c in 0..3 {
            self.diffuse[c][i] = lanes.diffuse[c];
            self.f0[c][i] = lanes.f0[c];
            self.wo[c][i] = wo[c];
            self.wi[c][i] = wi[c];
        }
        self.alpha[i] = lanes.alpha;
        self.p_specular[i] = p_specular;
        self.len += 1;
        i
    }

    /// Makes every evaluation asked for, eight at a time (the last group's spare lanes compute
    /// on whatever they hold, and are not read).
    pub(crate) fn run(&mut self) {
        let lanes = |array: &[f32; EVAL_BATCH], at: usize| {
            f32x8::new(array[at..at + EVAL_LANES].try_into().expect("eight lanes"))
        };
        for at in (0..self.len).step_by(EVAL_LANES) {
            let bsdf = BsdfLanes {
                diffuse: self.diffuse.each_ref().map(|c| lanes(c, at)),
                f0: self.f0.each_ref().map(|c| lanes(c, at)),
                alpha: lanes(&self.alpha, at),
            };
            let wo = self.wo.each_ref().map(|c| lanes(c, at));
            let wi = self.wi.each_ref().map(|c| lanes(c, at));
            let (value, pdf) = eval_and_pdf_above(&bsdf, wo, wi, lanes(&self.p_specular, at));
            for (out, lanes) in self.value.iter_mut().zip(value) {
                out[at..at + EVAL_LANES].copy_from_slice(&lanes.to_array());
            }
            self.pdf[at..at + EVAL_LANES].copy_from_slice(&pdf.to_array());
        }
    }

    /// Evaluation `i`'s value and density, once [`EvalBatch::run`] has made it.
    pub(crate) fn result(&self, i: usize) -> (Vec3, f32) {
        (
            Vec3::new(self.value[0][i], self.value[1][i], self.value[2][i]),
            self.pdf[i],
        )
    }
}
