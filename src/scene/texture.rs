//! Decoded textures and their sampling.

use std::sync::LazyLock;

use glam::Vec2;

use crate::prefetch::prefetch_at;

/// glTF sampler wrap modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WrapMode {
    #[default]
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

impl WrapMode {
    /// Maps an integer texel coordinate (any value) onto `0..size`. `size` must not be zero.
    fn wrap(self, coordinate: i64, size: u32) -> usize {
        let size = i64::from(size);
        let wrapped = match self {
            WrapMode::Repeat => coordinate.rem_euclid(size),
            WrapMode::ClampToEdge => coordinate.clamp(0, size - 1),
            WrapMode::MirroredRepeat => {
                // One period is the image followed by its mirror image.
                let in_period = coordinate.rem_euclid(2 * size);
                if in_period < size {
                    in_period
                } else {
                    2 * size - 1 - in_period
                }
            }
        };
        wrapped as usize
    }

    /// [`Self::wrap`] of `coordinate` and of the texel after it (`coordinate.saturating_add(1)`),
    /// the two columns or rows a bilinear footprint reads: one reduction for both, and none
    /// (a mask) for a power-of-two `size`, where x mod 2^k is x's low k bits.
    #[inline]
    fn wrap_pair(self, coordinate: i64, size: u32) -> (usize, usize) {
        let size = i64::from(size);
        // The period of the mode's pattern, and where in it the coordinate and the next lie.
        let period = match self {
            WrapMode::Repeat => size,
            WrapMode::MirroredRepeat => 2 * size,
            WrapMode::ClampToEdge => {
                let next = coordinate.saturating_add(1);
                return (
                    coordinate.clamp(0, size - 1) as usize,
                    next.clamp(0, size - 1) as usize,
                );
            }
        };
        let first = if period & (period - 1) == 0 {
            coordinate & (period - 1)
        } else {
            coordinate.rem_euclid(period)
        };
        let second = if coordinate == i64::MAX {
            first
        } else if first + 1 == period {
            0
        } else {
            first + 1
        };
        let unfold = |in_period: i64| {
            if in_period < size {
                in_period as usize
            } else {
                (2 * size - 1 - in_period) as usize
            }
        };
        (unfold(first), unfold(second))
    }
}

/// How an image's stored values encode colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ColorEncoding {
    /// sRGB transfer curve on RGB (glTF base colour and emissive textures); alpha is linear.
    Srgb,
    /// Values are used as they are (metallic-roughness and normal textures).
    Linear,
}

/// An RGBA texture decoded to linear f32 (sRGB-encoded images are linearised at load).
#[derive(Clone, Debug)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first (glTF UV (0,0) is the top-left corner).
    pub texels: Vec<[f32; 4]>,
    pub wrap_s: WrapMode,
    pub wrap_t: WrapMode,
    /// Nearest-texel magnification instead of bilinear.
    pub nearest: bool,
}

/// What a texture without texels reads: white, so a factor multiplied by it is unchanged.
const MISSING_TEXEL: [f32; 4] = [1.0; 4];

impl Texture {
    /// Decodes `image` to linear RGBA, with glTF's default sampler (repeat, bilinear).
    /// Grey images are expanded to RGB and images without alpha get alpha 1.
    pub fn from_image(image: &image::DynamicImage, encoding: ColorEncoding) -> Texture {
        let is_8_bit = matches!(
            image,
            image::DynamicImage::ImageLuma8(_)
                | image::DynamicImage::ImageLumaA8(_)
                | image::DynamicImage::ImageRgb8(_)
                | image::DynamicImage::ImageRgba8(_)
        );
        let texels = match encoding {
            ColorEncoding::Srgb if is_8_bit => {
                // A table: 8-bit sRGB has only 256 values, and powf per texel is slow.
                let table = &*SRGB8_TO_LINEAR;
                image
                    .to_rgba8()
                    .pixels()
                    .map(|p| {
                        let [r, g, b, a] = p.0;
                        [
                            table[r as usize],
                            table[g as usize],
                            table[b as usize],
                            f32::from(a) / 255.0,
                        ]
                    })
                    .collect()
            }
            ColorEncoding::Srgb => image
                .to_rgba32f()
                .pixels()
                .map(|p| {
                    let [r, g, b, a] = p.0;
                    [srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b), a]
                })
                .collect(),
            ColorEncoding::Linear => image.to_rgba32f().pixels().map(|p| p.0).collect(),
        };
        Texture {
            width: image.width(),
            height: image.height(),
            texels,
            wrap_s: WrapMode::Repeat,
            wrap_t: WrapMode::Repeat,
            nearest: false,
        }
    }

    /// The same texture read with the given sampler settings.
    pub fn with_sampler(self, wrap_s: WrapMode, wrap_t: WrapMode, nearest: bool) -> Texture {
        Texture {
            wrap_s,
            wrap_t,
            nearest,
            ..self
        }
    }

    /// Linear RGBA at `uv` (glTF convention: (0,0) is the top-left corner of the image, v grows
    /// downwards), filtered bilinearly or by nearest texel, wrapped by the sampler's modes.
    /// Non-finite UVs read as (0,0); an empty texture reads as white.
    pub fn sample(&self, uv: Vec2) -> [f32; 4] {
        if self.is_empty() {
            return MISSING_TEXEL;
        }
        let (x0, y0, [fx, fy]) = self.footprint(uv);
        if self.nearest {
            return self.texel(x0, y0);
        }
        // The neighbours by saturating_add, which keeps the +1 from overflowing for huge
        // coordinates, each wrapped.
        let (column0, column1) = self.wrap_s.wrap_pair(x0, self.width);
        let (row0, row1) = self.wrap_t.wrap_pair(y0, self.height);
        let top = lerp4(
            self.texel_at(column0, row0),
            self.texel_at(column1, row0),
            fx,
        );
        let bottom = lerp4(
            self.texel_at(column0, row1),
            self.texel_at(column1, row1),
            fx,
        );
        lerp4(top, bottom, fy)
    }

    /// Asks the memory system for the texels [`Texture::sample`] reads at `uv` (a bilinear
    /// footprint's two rows; a row's two texels share a cache line but at its edge): a hint
    /// that changes no result.
    pub fn prefetch(&self, uv: Vec2) {
        if self.is_empty() {
            return;
        }
        let (x0, y0, _) = self.footprint(uv);
        let column = self.wrap_s.wrap(x0, self.width);
        let (row0, row1) = self.wrap_t.wrap_pair(y0, self.height);
        let rows = if self.nearest {
            &[row0][..]
        } else {
            &[row0, row1]
        };
        for &row in rows {
            prefetch_at(&self.texels, self.offset(column, row));
        }
    }

    fn is_empty(&self) -> bool {
        self.width == 0 || self.height == 0 || self.texels.is_empty()
    }

    /// The texel `sample` reads at `uv` (nearest), or the top-left one of the four it
    /// interpolates (bilinear) with its weights' fractions.
    fn footprint(&self, uv: Vec2) -> (i64, i64, [f32; 2]) {
        // Texel space: texel (i, j) covers [i, i+1) × [j, j+1), its centre is at +0.5.
        let scaled = uv * Vec2::new(self.width as f32, self.height as f32);
        let Vec2 { x, y } = if scaled.is_finite() {
            scaled
        } else {
            Vec2::ZERO
        };
        // `as` saturates for huge coordinates.
        if self.nearest {
            return (x.floor() as i64, y.floor() as i64, [0.0; 2]);
        }
        let (x, y) = (x - 0.5, y - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        (x0 as i64, y0 as i64, [x - x0, y - y0])
    }

    /// Texel (`x`, `y`), wrapped.
    fn texel(&self, x: i64, y: i64) -> [f32; 4] {
        self.texel_at(
            self.wrap_s.wrap(x, self.width),
            self.wrap_t.wrap(y, self.height),
        )
    }

    /// The texel in wrapped `column` and `row`.
    fn texel_at(&self, column: usize, row: usize) -> [f32; 4] {
        self.texels
            .get(self.offset(column, row))
            .copied()
            .unwrap_or(MISSING_TEXEL)
    }

    /// Where the texel in wrapped `column` and `row` lies in `texels`.
    fn offset(&self, column: usize, row: usize) -> usize {
        row * self.width as usize + column
    }
}

fn lerp4(a: [f32; 4], b: [f32; 4], t: f32) -> [f32; 4] {
    std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t)
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1): encoded value in [0, 1] →
/// linear value in [0, 1].
pub fn srgb_to_linear(encoded: f32) -> f32 {
    if encoded <= 0.04045 {
        encoded / 12.92
    } else {
        ((encoded + 0.055) / 1.055).powf(2.4)
    }
}

/// The inverse of [`srgb_to_linear`].
pub fn linear_to_srgb(linear: f32) -> f32 {
    if linear <= 0.0031308 {
        linear * 12.92
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// 8-bit sRGB code → linear value, as [`Texture::from_image`] decodes it (the GPU backend
/// uploads the same table so that it decodes packed 8-bit texels to the same f32s).
pub(crate) static SRGB8_TO_LINEAR: LazyLock<[f32; 256]> =
    LazyLock::new(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)));

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// A texture whose red channel holds the given values, one row per slice.
    fn red_texture(rows: &[&[f32]]) -> Texture {
        Texture {
            width: rows[0].len() as u32,
            height: rows.len() as u32,
            texels: rows
                .iter()
                .flat_map(|row| row.iter().map(|&r| [r, 0.0, 0.0, 1.0]))
                .collect(),
            wrap_s: WrapMode::Repeat,
            wrap_t: WrapMode::Repeat,
            nearest: false,
        }
    }

    #[test]
    fn srgb_188_decodes_to_about_half() {
        let image = image::DynamicImage::ImageRgb8(image::RgbImage::from_pixel(
            1,
            1,
            image::Rgb([188, 188, 188]),
        ));
        let texel = Texture::from_image(&image, ColorEncoding::Srgb).texels[0];
        // ((188/255 + 0.055) / 1.055)^2.4 = 0.5029
        assert_relative_eq!(texel[0], 0.5029, epsilon = 1e-3);
        assert_eq!(texel[3], 1.0);
        let linear = Texture::from_image(&image, ColorEncoding::Linear).texels[0];
        assert_relative_eq!(linear[0], 188.0 / 255.0, epsilon = 1e-6);
    }

    #[test]
    fn srgb_table_matches_formula_and_16_bit_path() {
        let eight = image::DynamicImage::ImageRgba8(image::RgbaImage::from_pixel(
            1,
            1,
            image::Rgba([10, 100, 250, 128]),
        ));
        let sixteen = image::DynamicImage::ImageRgba16(image::ImageBuffer::from_pixel(
            1,
            1,
            image::Rgba([10 * 257, 100 * 257, 250 * 257, 128 * 257]),
        ));
        let a = Texture::from_image(&eight, ColorEncoding::Srgb).texels[0];
        let b = Texture::from_image(&sixteen, ColorEncoding::Srgb).texels[0];
        for channel in 0..4 {
            assert_relative_eq!(a[channel], b[channel], epsilon = 1e-6);
        }
        assert_relative_eq!(a[3], 128.0 / 255.0, epsilon = 1e-6);
    }

    #[test]
    fn srgb_round_trip() {
        for i in 0..=255 {
            let encoded = i as f32 / 255.0;
            assert_relative_eq!(
                linear_to_srgb(srgb_to_linear(encoded)),
                encoded,
                epsilon = 1e-5
            );
        }
    }

    #[test]
    fn bilinear_midpoint_between_two_texels() {
        let texture = red_texture(&[&[0.0, 1.0]]);
        // u = 0.5 is the boundary between the two texel centres at u = 0.25 and 0.75.
        assert_relative_eq!(texture.sample(Vec2::new(0.5, 0.5))[0], 0.5);
        assert_relative_eq!(texture.sample(Vec2::new(0.25, 0.5))[0], 0.0);
        assert_relative_eq!(texture.sample(Vec2::new(0.75, 0.5))[0], 1.0);
        assert_relative_eq!(texture.sample(Vec2::new(0.375, 0.5))[0], 0.25);
    }

    #[test]
    fn v_zero_is_the_top_row() {
        let texture = red_texture(&[&[1.0], &[0.0]]).with_sampler(
            WrapMode::ClampToEdge,
            WrapMode::ClampToEdge,
            true,
        );
        assert_eq!(texture.sample(Vec2::new(0.5, 0.1))[0], 1.0);
        assert_eq!(texture.sample(Vec2::new(0.5, 0.9))[0], 0.0);
    }

    /// The pair a bilinear footprint wraps at once is the two coordinates wrapped one by one,
    /// for every mode, sizes with and without a power of two, and coordinates far out on
    /// both sides, up to the ones `saturating_add` stops at.
    #[test]
    fn a_wrapped_pair_is_each_coordinate_wrapped() {
        let extremes = [
            i64::MIN,
            i64::MIN + 1,
            i64::MAX - 1,
            i64::MAX,
            -(1 << 40),
            1 << 40,
        ];
        let coordinates: Vec<i64> = (-300..300).chain(extremes).collect();
        for mode in [
            WrapMode::Repeat,
            WrapMode::MirroredRepeat,
            WrapMode::ClampToEdge,
        ] {
            for size in (1..=70).chain([255, 256, 257, 1024, 2048, 3000]) {
                for &c in &coordinates {
                    let pair = mode.wrap_pair(c, size);
                    let each = (mode.wrap(c, size), mode.wrap(c.saturating_add(1), size));
                    assert_eq!(pair, each, "{mode:?}, size {size}, coordinate {c}");
                }
            }
        }
    }

    #[test]
    fn wrap_modes() {
        let texture = red_texture(&[&[0.0, 1.0, 2.0, 3.0]]);
        let nearest = |wrap: WrapMode, u: f32| {
            texture
                .clone()
                .with_sampler(wrap, WrapMode::Repeat, true)
                .sample(Vec2::new(u, 0.5))[0]
        };
        // u = 1.125 is texel 4.5 → one past the right edge.
        assert_eq!(nearest(WrapMode::Repeat, 1.125), 0.0);
        assert_eq!(nearest(WrapMode::Repeat, -0.125), 3.0);
        assert_eq!(nearest(WrapMode::ClampToEdge, 1.125), 3.0);
        assert_eq!(nearest(WrapMode::ClampToEdge, -5.0), 0.0);
        assert_eq!(nearest(WrapMode::MirroredRepeat, 1.125), 3.0);
        assert_eq!(nearest(WrapMode::MirroredRepeat, 1.375), 2.0);
        assert_eq!(nearest(WrapMode::MirroredRepeat, -0.125), 0.0);
        assert_eq!(nearest(WrapMode::MirroredRepeat, 2.125), 0.0);

        // Bilinear across the right edge blends with the texel the wrap mode names.
        let bilinear = |wrap: WrapMode| {
            texture
                .clone()
                .with_sampler(wrap, WrapMode::Repeat, false)
                .sample(Vec2::new(1.0, 0.5))[0]
        };
        assert_relative_eq!(bilinear(WrapMode::Repeat), 1.5); // (3 + 0) / 2
        assert_relative_eq!(bilinear(WrapMode::ClampToEdge), 3.0);
        assert_relative_eq!(bilinear(WrapMode::MirroredRepeat), 3.0);
    }

    /// Odd UVs sample finite values, and the texels a prefetch asks for lie inside the
    /// texture: its footprint is the one `sample` reads (for the nearest texel, that very
    /// texel), at ordinary UVs too.
    #[test]
    fn odd_inputs_do_not_panic() {
        let texture = red_texture(&[&[0.25, 0.5], &[0.75, 1.0]]);
        for uv in [
            Vec2::new(f32::NAN, 0.0),
            Vec2::new(f32::INFINITY, f32::NEG_INFINITY),
            Vec2::new(1e30, -1e30),
            Vec2::new(f32::MAX, f32::MIN),
            Vec2::new(0.3, 0.7),
            Vec2::new(-2.6, 17.25),
        ] {
            for wrap in [
                WrapMode::Repeat,
                WrapMode::MirroredRepeat,
                WrapMode::ClampToEdge,
            ] {
                for nearest in [false, true] {
                    let texture = texture.clone().with_sampler(wrap, wrap, nearest);
                    let sampled = texture.sample(uv);
                    assert!(
                        sampled.iter().all(|v| v.is_finite()),
                        "{uv} {wrap:?} {sampled:?}"
                    );
                    let (x0, y0, _) = texture.footprint(uv);
                    let index = |x, y| {
                        texture.offset(wrap.wrap(x, texture.width), wrap.wrap(y, texture.height))
                    };
                    let rows = [index(x0, y0), index(x0, y0.saturating_add(1))];
                    assert!(rows.iter().all(|&i| i < 4), "{uv} {wrap:?}: {rows:?}");
                    if nearest {
                        assert_eq!(sampled, texture.texels[rows[0]], "{uv} {wrap:?}");
                    }
                    texture.prefetch(uv);
                }
            }
        }
        let empty = Texture {
            width: 0,
            height: 0,
            texels: Vec::new(),
            ..texture
        };
        assert_eq!(empty.sample(Vec2::splat(0.5)), MISSING_TEXEL);
        empty.prefetch(Vec2::splat(0.5));
    }
}
