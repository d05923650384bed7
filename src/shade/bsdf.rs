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

use super::ggx::{Ggx, reflect};
use super::warp::{cosine_hemisphere, cosine_hemisphere_pdf};

/// Normal-incidence reflectance of glTF's dielectric, ((ior − 1) / (ior + 1))² at ior 1.5.
pub const DIELECTRIC_F0: f32 = 0.04;

/// Rec. 709 luminance (the Y of the linear RGB working space).
pub fn luminance(rgb: Vec3) -> f32 {
    rgb.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// Schlick's Fresnel approximation at the cosine between the view and the microfacet normal.
fn schlick(f0: Vec3, cos_theta: f32) -> Vec3 {
    let m = (1.0 - cos_theta.clamp(0.0, 1.0)).powi(5);
    f0 + (Vec3::ONE - f0) * m
}

fn schlick_scalar(f0: f32, cos_theta: f32) -> f32 {
    f0 + (1.0 - f0) * (1.0 - cos_theta.clamp(0.0, 1.0)).powi(5)
}

/// A drawn incident direction with its BRDF value and density (solid angle, over both lobes).
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub value: Vec3,
    pub pdf: f32,
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
    /// specular lobe's selection probability at `wo`.
    fn eval_and_pdf_above(&self, wo: Vec3, wi: Vec3, p_specular: f32) -> (Vec3, f32) {
        let h = (wo + wi).normalize_or_zero();
        if h == Vec3::ZERO {
            return (Vec3::ZERO, 0.0);
        }
        let cos_oh = wo.dot(h);
        let distribution = self.ggx.distribution(h);
        // fresnel_mix: the diffuse base sees what the dielectric coating transmits.
        let diffuse = self.diffuse * ((1.0 - schlick_scalar(DIELECTRIC_F0, cos_oh)) * FRAC_1_PI);
        let specular = schlick(self.f0, cos_oh) * (distribution * self.ggx.visibility(wo, wi));
        let pdf = p_specular * self.ggx.reflection_pdf_at(wo, h, distribution)
            + (1.0 - p_specular) * cosine_hemisphere_pdf(wi.z);
        (diffuse + specular, pdf)
    }

    /// Probability of drawing from the specular lobe, by each lobe's rough share of the
    /// reflected energy at this view angle. Both lobes keep some chance while both exist.
    fn specular_probability(&self, wo: Vec3) -> f32 {
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
        if wo.z <= 0.0 {
            return None;
        }
        let p_specular = self.specular_probability(wo);
        let wi = if u_lobe < p_specular {
            reflect(wo, self.ggx.sample_visible_normal(wo, u))
        } else {
            cosine_hemisphere(u)
        };
        if wi.z <= 0.0 {
            return None;
        }
        let (value, pdf) = self.eval_and_pdf_above(wo, wi, p_specular);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(BsdfSample { wi, value, pdf })
    }
}
