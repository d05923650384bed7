//! The scene on the GPU (bind group 1): the BVH, triangles, vertex attributes, alpha masks and
//! textures, uploaded once per scene, and `shaders/scene.wgsl`, which traverses and samples
//! them as the CPU's `accel` and `scene::Texture` do.
//!
//! The BVH is obvhs's compressed 8-wide BVH (CWBVH) exactly as the CPU built it: its nodes are
//! uploaded byte for byte and traversed by a WGSL port of obvhs's own traversal. That was the
//! simplest way to get traversal exactly right: CWBVH was designed for GPU traversal (Ylitie et
//! al. 2017: 80-byte nodes, a small stack of node groups), obvhs's CPU code is a line-by-line
//! reference, there is no conversion step to get wrong, and the GPU visits the same nodes and
//! triangles in the same order as the CPU, so even exact ties (a ray through a shared edge) are
//! mostly broken the same way. Triangles keep the CPU's BVH order and BVH space (world × an
//! exact power of two), so hit indices, t, u and v mean what they mean on the CPU.
//!
//! Textures are packed into one word buffer: a texture whose f32 texels are exactly the values
//! [`Texture::from_image`] decodes from 8-bit images (the sRGB table for colour, k/255 for
//! linear channels and alpha) is stored as one byte per channel and decoded on the GPU by the
//! same tables, to the same f32s; any other texture as four f32 words per texel. Storage
//! bindings may be capped at 128 MiB (lavapipe): five 2048² 8-bit textures take 80 MiB packed,
//! 320 MiB as f32.

use rayon::prelude::*;

use super::compute::{Access, Bindings, storage_buffer, uniform_buffer};
use super::context::{GpuContext, GpuUnavailable};
use crate::accel::{SceneAccel, TrianglePrimitive, TriangleRecord, WorldVertices};
use crate::scene::texture::SRGB8_TO_LINEAR;
use crate::scene::{AlphaMode, MaterialLibrary, Texture, WrapMode};

/// The WGSL of the scene: `Hit`, `SurfacePoint`, `scene_intersect`, `scene_occluded`,
/// `scene_surface`, `scene_spawn_origin`, `scene_offset_along_normal`,
/// `scene_triangle_vertices`, `scene_triangle_material`, `scene_uv_at`, `texture_sample`;
/// bindings in @group(1).
pub const SCENE_WGSL: &str = include_str!("shaders/scene.wgsl");

/// `SCENE_NONE` in WGSL: no triangle, no texture.
const NONE: u32 = u32::MAX;

/// How a texture's texels are stored (`SCENE_TEXELS_*` in WGSL).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
enum TexelFormat {
    /// Four f32 words per texel.
    F32 = 0,
    /// One word per texel: RGB as 8-bit sRGB codes, alpha as an 8-bit linear code.
    Srgb8 = 1,
    /// One word per texel: four 8-bit linear codes.
    Linear8 = 2,
}

/// `SceneParams` in WGSL (uniform).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct SceneParams {
    bvh_scale: f32,
    inv_bvh_scale: f32,
    node_count: u32,
    triangle_count: u32,
    alpha_mask_count: u32,
    any_alpha_mask: u32,
    texture_count: u32,
    _pad: u32,
    /// [0, 256): 8-bit sRGB code → linear; [256, 512): code / 255.
    decode: [[f32; 4]; 128],
}

/// `SceneTriangle` in WGSL: a [`TrianglePrimitive`] and its [`TriangleRecord`], 64 bytes.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuTriangle {
    v0: [f32; 3],
    material: u32,
    edge1: [f32; 3],
    attributes: u32,
    edge2: [f32; 3],
    vertices: [u32; 3],
    _pad: [u32; 2],
}

/// `SceneVertex` in WGSL, 36 bytes.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuVertex {
    normal: [f32; 3],
    uv: [f32; 2],
    tangent: [f32; 4],
}

/// `SceneAlphaMask` in WGSL.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuAlphaMask {
    cutoff: f32,
    factor: f32,
    texture: u32,
    masked: u32,
}

/// `SceneTexture` in WGSL.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuTexture {
    width: u32,
    height: u32,
    offset: u32,
    texel_count: u32,
    format: u32,
    wrap_s: u32,
    wrap_t: u32,
    nearest: u32,
}

/// The scene's buffers on the GPU, bound as @group(1) of every kernel that traces or samples
/// textures (see [`SCENE_WGSL`]). Uploaded once per scene; immutable.
#[derive(Debug)]
pub struct GpuScene {
    /// Binding 0: `SceneParams` (uniform); 1: nodes; 2: triangles; 3: vertices; 4: alpha
    /// masks; 5: texture table; 6: texel words (all read-only storage).
    pub bindings: Bindings,
    /// Bytes uploaded, all buffers together.
    pub uploaded_bytes: u64,
}

impl GpuScene {
    /// Uploads `accel`'s BVH and triangles and every texture of `materials` (the library the
    /// accelerator was built with: its alpha masks are read from it).
    pub fn upload(
        context: &GpuContext,
        accel: &SceneAccel,
        materials: &MaterialLibrary,
    ) -> Result<GpuScene, GpuUnavailable> {
        let nodes = accel.bvh.as_ref().map_or(&[][..], |bvh| &bvh.nodes[..]);
        let triangles = gpu_triangles(&accel.primitives, &accel.records);
        let vertices = gpu_vertices(&accel.vertices);
        let alpha_masks = gpu_alpha_masks(materials);
        let (textures, texels) = pack_textures(&materials.textures)?;

        let mut decode = [[0.0f32; 4]; 128];
        for code in 0..256 {
            decode[code / 4][code % 4] = SRGB8_TO_LINEAR[code];
            decode[(256 + code) / 4][code % 4] = linear8(code as u8);
        }
        let params = SceneParams {
            bvh_scale: accel.bvh_scale,
            inv_bvh_scale: 1.0 / accel.bvh_scale,
            node_count: nodes.len() as u32,
            triangle_count: triangles.len() as u32,
            alpha_mask_count: alpha_masks.len() as u32,
            any_alpha_mask: u32::from(alpha_masks.iter().any(|m| m.masked != 0)),
            texture_count: textures.len() as u32,
            _pad: 0,
            decode,
        };

        let mut uploaded_bytes = size_of::<SceneParams>() as u64;
        let mut upload = Uploader {
            context,
            uploaded_bytes: &mut uploaded_bytes,
        };
        let node_buffer = upload.storage("BVH nodes", nodes)?;
        let triangle_buffer = upload.storage("triangles", &triangles)?;
        let vertex_buffer = upload.storage("vertices", &vertices)?;
        let mask_buffer = upload.storage("alpha masks", &alpha_masks)?;
        let texture_buffer = upload.storage("texture table", &textures)?;
        let texel_buffer = upload.storage("textures", &texels)?;
        let params_buffer = uniform_buffer(context, "scene params", &params);
        let bindings = Bindings::new(
            context,
            "scene",
            &[
                (&params_buffer, Access::Uniform),
                (&node_buffer, Access::ReadOnly),
                (&triangle_buffer, Access::ReadOnly),
                (&vertex_buffer, Access::ReadOnly),
                (&mask_buffer, Access::ReadOnly),
                (&texture_buffer, Access::ReadOnly),
                (&texel_buffer, Access::ReadOnly),
            ],
        );
        Ok(GpuScene {
            bindings,
            uploaded_bytes,
        })
    }
}

/// Storage buffers checked against the device's limits, counted.
struct Uploader<'a> {
    context: &'a GpuContext,
    uploaded_bytes: &'a mut u64,
}

impl Uploader<'_> {
    fn storage<T: bytemuck::Pod>(
        &mut self,
        label: &str,
        data: &[T],
    ) -> Result<wgpu::Buffer, GpuUnavailable> {
        let size = size_of_val(data) as u64;
        let limits = &self.context.limits;
        let limit = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        if size > limit {
            return Err(GpuUnavailable(format!(
                "the scene's {label} take {} MiB; this GPU binds at most {} MiB per buffer",
                size >> 20,
                limit >> 20
            )));
        }
        *self.uploaded_bytes += size;
        Ok(storage_buffer(self.context, label, data))
    }
}

fn gpu_triangles(primitives: &[TrianglePrimitive], records: &[TriangleRecord]) -> Vec<GpuTriangle> {
    primitives
        .par_iter()
        .zip(records)
        .map(|(primitive, record)| GpuTriangle {
            v0: primitive.v0.into(),
            material: record.material,
            edge1: primitive.edge1.into(),
            attributes: u32::from(record.attributes),
            edge2: primitive.edge2.into(),
            vertices: record.vertices,
            _pad: [0; 2],
        })
        .collect()
}

fn gpu_vertices(vertices: &WorldVertices) -> Vec<GpuVertex> {
    vertices
        .normals
        .par_iter()
        .zip(&vertices.uvs)
        .zip(&vertices.tangents)
        .map(|((normal, uv), tangent)| GpuVertex {
            normal: normal.to_array(),
            uv: uv.to_array(),
            tangent: tangent.to_array(),
        })
        .collect()
}

/// One mask per material, then the default material's: what `accel::alpha_mask::AlphaMasks`
/// holds, with textures as indices (one out of range reads as no texture, as on the CPU).
fn gpu_alpha_masks(materials: &MaterialLibrary) -> Vec<GpuAlphaMask> {
    materials
        .materials
        .iter()
        .chain(std::iter::once(&materials.default_material))
        .map(|material| match material.alpha_mode {
            AlphaMode::Mask(cutoff) => GpuAlphaMask {
                cutoff,
                factor: material.base_color.w,
                texture: material
                    .base_color_texture
                    .filter(|t| t.texture < materials.textures.len())
                    .map_or(NONE, |t| t.texture as u32),
                masked: 1,
            },
            AlphaMode::Opaque | AlphaMode::Blend => GpuAlphaMask {
                cutoff: 0.0,
                factor: 1.0,
                texture: NONE,
                masked: 0,
            },
        })
        .collect()
}

/// The texture table and the texel words of every texture, in library order.
fn pack_textures(
    textures: &[std::sync::Arc<Texture>],
) -> Result<(Vec<GpuTexture>, Vec<u32>), GpuUnavailable> {
    let mut table = Vec::with_capacity(textures.len());
    let mut words: Vec<u32> = Vec::new();
    for texture in textures {
        let (format, packed) = pack_texels(&texture.texels);
        // Word offsets are u32 in WGSL.
        if words.len() + packed.len() > u32::MAX as usize {
            return Err(GpuUnavailable("the scene's textures exceed 16 GiB".into()));
        }
        table.push(GpuTexture {
            width: texture.width,
            height: texture.height,
            offset: words.len() as u32,
            texel_count: texture.texels.len() as u32,
            format: format as u32,
            wrap_s: wrap_code(texture.wrap_s),
            wrap_t: wrap_code(texture.wrap_t),
            nearest: u32::from(texture.nearest),
        });
        words.extend_from_slice(&packed);
    }
    Ok((table, words))
}

fn wrap_code(wrap: WrapMode) -> u32 {
    match wrap {
        WrapMode::Repeat => 0,
        WrapMode::MirroredRepeat => 1,
        WrapMode::ClampToEdge => 2,
    }
}

/// The most compact format that reproduces `texels` bit for bit, and the packed words.
fn pack_texels(texels: &[[f32; 4]]) -> (TexelFormat, Vec<u32>) {
    let linear: [f32; 256] = std::array::from_fn(|code| linear8(code as u8));
    let srgb: &[f32; 256] = &SRGB8_TO_LINEAR;
    let pack = |colour: &[f32; 256]| -> Option<Vec<u32>> {
        texels
            .par_iter()
            .map(|&[r, g, b, a]| {
                Some(u32::from_le_bytes([
                    code_of(colour, r)?,
                    code_of(colour, g)?,
                    code_of(colour, b)?,
                    code_of(&linear, a)?,
                ]))
            })
            .collect()
    };
    if let Some(words) = pack(srgb) {
        (TexelFormat::Srgb8, words)
    } else if let Some(words) = pack(&linear) {
        (TexelFormat::Linear8, words)
    } else {
        let words = bytemuck::cast_slice::<[f32; 4], u32>(texels).to_vec();
        (TexelFormat::F32, words)
    }
}

/// An 8-bit code decoded as linear, as `image` converts 8-bit samples to f32 (and as
/// `Texture::from_image` decodes alpha).
fn linear8(code: u8) -> f32 {
    f32::from(code) / 255.0
}

/// The code whose table entry is `value`, bit for bit (the tables increase with the code).
fn code_of(table: &[f32; 256], value: f32) -> Option<u8> {
    let code = table.partition_point(|&entry| entry < value);
    (code < 256 && table[code].to_bits() == value.to_bits()).then_some(code as u8)
}

#[cfg(test)]
mod tests;
