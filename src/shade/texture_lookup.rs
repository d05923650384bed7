//! Texture lookups for shading and alpha testing.
//!
//! A stand-in for `Texture::sample`, which the scene module will provide: when that lands, the
//! body of [`sample_texture`] becomes a call to it. Conventions follow glTF: UV (0, 0) is the
//! top-left corner of the image, texel centres sit at half-integer texel coordinates, and the
//! sampler's wrap modes apply per axis.

use glam::{Vec2, Vec4};

use crate::scene::{Texture, WrapMode};

/// The texture's value at `uv`: bilinear, or nearest when the texture asks for it. An empty or
/// malformed texture reads as opaque white, the neutral value for every glTF texture slot.
pub fn sample_texture(texture: &Texture, uv: Vec2) -> Vec4 {
    let (width, height) = (texture.width as i64, texture.height as i64);
    if width == 0 || height == 0 || texture.texels.len() < (width * height) as usize {
        return Vec4::ONE;
    }
    let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
    let texel = |x: i64, y: i64| -> Vec4 {
        let x = wrap(x, width, texture.wrap_s);
        let y = wrap(y, height, texture.wrap_t);
        Vec4::from_array(texture.texels[(y * width + x) as usize])
    };
    // Continuous texel coordinates; `as i64` saturates, so huge UVs cannot overflow.
    let x = uv.x * width as f32;
    let y = uv.y * height as f32;
    if texture.nearest {
        return texel(x.floor() as i64, y.floor() as i64);
    }
    let (x, y) = (x - 0.5, y - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let top = texel(x0, y0).lerp(texel(x0.saturating_add(1), y0), fx);
    let bottom =
        texel(x0, y0.saturating_add(1)).lerp(texel(x0.saturating_add(1), y0.saturating_add(1)), fx);
    top.lerp(bottom, fy)
}

/// Maps an integer texel coordinate into `0..size` by the sampler's wrap mode.
fn wrap(i: i64, size: i64, mode: WrapMode) -> i64 {
    match mode {
        WrapMode::Repeat => i.rem_euclid(size),
        WrapMode::ClampToEdge => i.clamp(0, size - 1),
        WrapMode::MirroredRepeat => {
            let m = i.rem_euclid(2 * size);
            if m < size { m } else { 2 * size - 1 - m }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(width: u32, height: u32, texels: Vec<[f32; 4]>, wrap: WrapMode) -> Texture {
        Texture {
            width,
            height,
            texels,
            wrap_s: wrap,
            wrap_t: wrap,
            nearest: false,
        }
    }

    #[test]
    fn bilinear_hits_texel_centres_and_blends_between() {
        let t = texture(2, 1, vec![[0.0; 4], [1.0; 4]], WrapMode::ClampToEdge);
        assert_eq!(sample_texture(&t, Vec2::new(0.25, 0.5)).x, 0.0);
        assert_eq!(sample_texture(&t, Vec2::new(0.75, 0.5)).x, 1.0);
        assert!((sample_texture(&t, Vec2::new(0.5, 0.5)).x - 0.5).abs() < 1e-6);
        // Clamped beyond the edge centres.
        assert_eq!(sample_texture(&t, Vec2::new(0.0, 0.5)).x, 0.0);
        assert_eq!(sample_texture(&t, Vec2::new(1.0, 0.5)).x, 1.0);
    }

    #[test]
    fn wrap_modes() {
        assert_eq!(wrap(-1, 4, WrapMode::Repeat), 3);
        assert_eq!(wrap(5, 4, WrapMode::Repeat), 1);
        assert_eq!(wrap(-1, 4, WrapMode::ClampToEdge), 0);
        assert_eq!(wrap(9, 4, WrapMode::ClampToEdge), 3);
        assert_eq!(wrap(4, 4, WrapMode::MirroredRepeat), 3);
        assert_eq!(wrap(-1, 4, WrapMode::MirroredRepeat), 0);
        assert_eq!(wrap(8, 4, WrapMode::MirroredRepeat), 0);
    }

    #[test]
    fn top_row_is_v_zero_and_bad_input_is_safe() {
        let mut t = texture(
            1,
            2,
            vec![[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0]],
            WrapMode::Repeat,
        );
        t.nearest = true;
        assert_eq!(sample_texture(&t, Vec2::new(0.5, 0.1)).x, 1.0);
        assert_eq!(sample_texture(&t, Vec2::new(0.5, 0.9)).y, 1.0);
        assert!(sample_texture(&t, Vec2::new(f32::NAN, 1e30)).is_finite());
        let empty = texture(0, 0, vec![], WrapMode::Repeat);
        assert_eq!(sample_texture(&empty, Vec2::ZERO), Vec4::ONE);
    }
}
