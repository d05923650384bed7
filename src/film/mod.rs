//! The film: tiles that accumulate linear radiance, and the finished image.
//!
//! Each [`FilmTile`] is an entity with its own accumulation buffers, so tiles are rendered in
//! parallel without sharing anything. A tile stores *sums* of weighted samples (not means), so
//! a render can be stopped, saved and resumed, or split and merged, without rounding drift.

pub mod checkpoint;
pub mod contact_sheet;
pub mod filter;
pub mod footprint;
pub mod format;
pub mod merge;
pub mod output;
pub mod samples;
pub mod splat;

use bevy_ecs::component::Component;

/// The largest image side realcam renders, in pixels: 16K, far beyond any display, while a
/// 16384² film's sums still fit comfortably in memory (3 GiB).
pub const MAX_IMAGE_SIDE: u32 = 16_384;

/// Image width and height when neither the user nor the scene's camera gives one.
pub const DEFAULT_IMAGE_SIDE: u32 = 512;

/// The most samples per pixel realcam renders: 2²⁴. The film keeps per-pixel sums in f32,
/// whose 24-bit significand cannot take in one more sample of similar size beyond 2²⁴ of
/// them — further samples would be lost, not averaged in.
pub const MAX_SPP: u32 = 1 << 24;

/// A rectangle of the image with its accumulation buffers.
#[derive(Component, Clone, Debug)]
pub struct FilmTile {
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
    /// Per-pixel sums of weighted radiance, row-major within the tile.
    pub sum_r: Vec<f32>,
    pub sum_g: Vec<f32>,
    pub sum_b: Vec<f32>,
    /// Samples accumulated into every pixel of the tile.
    pub samples: u32,
}

impl FilmTile {
    pub fn new(x0: u32, y0: u32, width: u32, height: u32) -> FilmTile {
        let n = (width * height) as usize;
        FilmTile {
            x0,
            y0,
            width,
            height,
            sum_r: vec![0.0; n],
            sum_g: vec![0.0; n],
            sum_b: vec![0.0; n],
            samples: 0,
        }
    }

    /// The image pixels this tile covers.
    pub fn rect(&self) -> splat::PixelRect {
        splat::PixelRect {
            x0: self.x0,
            y0: self.y0,
            width: self.width,
            height: self.height,
        }
    }

    /// Image coordinates of the tile's pixels in accumulation order.
    pub fn pixels(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        (0..self.height).flat_map(move |y| (0..self.width).map(move |x| (self.x0 + x, self.y0 + y)))
    }

    /// Takes this tile's pixels and sample count from a whole-image `image`.
    pub fn load(&mut self, image: &Image) {
        self.load_from(image.width, image.samples, |i| image.sums[i]);
    }

    /// Takes this tile's pixels from row-major whole-image sums of `image_width` pixels a row
    /// (`sum(i)`: pixel i's RGB), and `samples`.
    pub fn load_from(&mut self, image_width: u32, samples: u32, sum: impl Fn(usize) -> [f32; 3]) {
        for ty in 0..self.height {
            for tx in 0..self.width {
                let t = (ty * self.width + tx) as usize;
                let s = sum(((self.y0 + ty) * image_width + self.x0 + tx) as usize);
                (self.sum_r[t], self.sum_g[t], self.sum_b[t]) = (s[0], s[1], s[2]);
            }
        }
        self.samples = samples;
    }

    /// Whether the tile is as [`FilmTile::clear`] leaves it: no samples, and every sum +0.0
    /// (bit for bit: a −0.0 sum would add differently).
    pub fn is_clear(&self) -> bool {
        self.samples == 0
            && [&self.sum_r, &self.sum_g, &self.sum_b]
                .iter()
                .all(|sums| sums.iter().all(|s| s.to_bits() == 0))
    }

    pub fn clear(&mut self) {
        for v in [&mut self.sum_r, &mut self.sum_g, &mut self.sum_b] {
            v.iter_mut().for_each(|s| *s = 0.0);
        }
        self.samples = 0;
    }
}

/// Cuts a `width` × `height` image into tiles of at most `size` × `size` pixels.
pub fn tiles(width: u32, height: u32, size: u32) -> Vec<FilmTile> {
    let size = size.max(1);
    let mut out = Vec::new();
    for y0 in (0..height).step_by(size as usize) {
        for x0 in (0..width).step_by(size as usize) {
            out.push(FilmTile::new(
                x0,
                y0,
                size.min(width - x0),
                size.min(height - y0),
            ));
        }
    }
    out
}

/// A finished linear image: the film's per-pixel sums and sample counts.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// Row-major linear RGB *sums* of weighted samples.
    pub sums: Vec<[f32; 3]>,
    /// Samples per pixel accumulated into `sums`.
    pub samples: u32,
}

impl Image {
    pub fn new(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            sums: vec![[0.0; 3]; (width * height) as usize],
            samples: 0,
        }
    }

    /// Gathers tiles (all with the same sample count) into one image.
    pub fn from_tiles<'a>(
        width: u32,
        height: u32,
        tiles: impl IntoIterator<Item = &'a FilmTile>,
    ) -> Image {
        let mut image = Image::new(width, height);
        for tile in tiles {
            image.samples = tile.samples;
            for ty in 0..tile.height {
                for tx in 0..tile.width {
                    let t = (ty * tile.width + tx) as usize;
                    let i = ((tile.y0 + ty) * width + tile.x0 + tx) as usize;
                    image.sums[i] = [tile.sum_r[t], tile.sum_g[t], tile.sum_b[t]];
                }
            }
        }
        image
    }

    /// Per-pixel means: the film's irradiance estimate (scene radiance × lens weight).
    pub fn mean(&self) -> Vec<[f32; 3]> {
        let scale = if self.samples > 0 {
            1.0 / self.samples as f32
        } else {
            0.0
        };
        self.sums
            .iter()
            .map(|s| [s[0] * scale, s[1] * scale, s[2] * scale])
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tile is clear exactly as `clear` leaves it: a sample, a sum or even a −0.0 sum (which
    /// adds differently from +0.0) makes it not.
    #[test]
    fn a_tile_is_clear_only_as_cleared() {
        let mut tile = FilmTile::new(0, 0, 4, 3);
        assert!(tile.is_clear());
        tile.sum_g[5] = 0.25;
        assert!(!tile.is_clear());
        tile.clear();
        tile.sum_b[11] = -0.0;
        assert!(!tile.is_clear());
        tile.clear();
        tile.samples = 1;
        assert!(!tile.is_clear());
        tile.clear();
        assert!(tile.is_clear());
    }
}
