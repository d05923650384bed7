//! Alpha-mask cut-outs (glTF `alphaMode: MASK`): where base-colour alpha falls below the
//! material's cutoff the surface does not exist, so rays pass through as if it were a hole.

use std::sync::Arc;

use glam::Vec2;

use crate::scene::{AlphaMode, MaterialLibrary, Texture};

/// What the alpha test of one masked material reads.
#[derive(Clone, Debug)]
struct AlphaMask {
    cutoff: f32,
    /// Base-colour factor alpha.
    factor: f32,
    texture: Option<Arc<Texture>>,
}

/// The alpha masks of a material library, copied out so the BVH owns what it tests.
#[derive(Clone, Debug, Default)]
pub struct AlphaMasks {
    /// Indexed by material; the last entry is the library's default material, which
    /// [`super::triangles::NO_MATERIAL`] reaches by clamping.
    by_material: Vec<Option<AlphaMask>>,
    any: bool,
}

impl AlphaMasks {
    pub fn new(materials: &MaterialLibrary) -> Self {
        let by_material: Vec<Option<AlphaMask>> = materials
            .materials
            .iter()
            .chain(std::iter::once(&materials.default_material))
            .map(|material| match material.alpha_mode {
                AlphaMode::Mask(cutoff) => Some(AlphaMask {
                    cutoff,
                    factor: material.base_color.w,
                    texture: material
                        .base_color_texture
                        .and_then(|t| materials.textures.get(t.texture).cloned()),
                }),
                AlphaMode::Opaque | AlphaMode::Blend => None,
            })
            .collect();
        let any = by_material.iter().any(Option::is_some);
        AlphaMasks { by_material, any }
    }

    /// True when some material is masked: lets traversal skip all lookups otherwise.
    pub fn any(&self) -> bool {
        self.any
    }

    /// True when `material` has a mask and its alpha at `uv` is below the cutoff.
    pub fn is_hole(&self, material: u32, uv: Vec2) -> bool {
        // Like `MaterialLibrary::get`: no material, or one out of range, means the default.
        let slot = (material as usize).min(self.by_material.len().saturating_sub(1));
        let Some(Some(mask)) = self.by_material.get(slot) else {
            return false;
        };
        let texture_alpha = mask.texture.as_deref().map_or(1.0, |t| t.sample(uv)[3]);
        mask.factor * texture_alpha < mask.cutoff
    }
}
