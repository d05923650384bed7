//! Contributions a sample adds to a pixel other than its own.
//!
//! With several wavelengths per camera sample, a companion wavelength's share belongs to the
//! pixel its own film point lies in, a pixel or two from the sample's (see
//! [`crate::lens::hero_wavelengths`]). The Weight stage lists those shares per tile, in ray
//! order; WriteFilm adds each tile's own samples first and then, for every tile in a fixed
//! order, the shares that land in it, so the film's sums do not depend on how many threads
//! ran the pass.

/// One share of a sample's weighted radiance for image pixel (`x`, `y`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Splat {
    pub x: u32,
    pub y: u32,
    pub rgb: [f32; 3],
}

/// Image pixels (x0, y0, width, height) of a tile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRect {
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
}

impl PixelRect {
    #[inline(always)]
    pub fn contains(&self, x: u32, y: u32) -> bool {
        x >= self.x0 && y >= self.y0 && x - self.x0 < self.width && y - self.y0 < self.height
    }

    /// Whether a splat from this tile's samples, at most `reach` pixels from its pixel, can
    /// land in `other`.
    pub fn may_reach(&self, other: &PixelRect, reach: u32) -> bool {
        let (ax0, ay0) = (self.x0.saturating_sub(reach), self.y0.saturating_sub(reach));
        let (ax1, ay1) = (self.x0 + self.width + reach, self.y0 + self.height + reach);
        ax0 < other.x0 + other.width
            && other.x0 < ax1
            && ay0 < other.y0 + other.height
            && other.y0 < ay1
    }
}
