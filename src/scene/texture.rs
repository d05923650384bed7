//! Decoded textures and their sampling.

/// glTF sampler wrap modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WrapMode {
    #[default]
    Repeat,
    MirroredRepeat,
    ClampToEdge,
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
