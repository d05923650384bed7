//! glTF materials and the textures they read.
//!
//! A missing or undecodable image is never an error: the material falls back to its factor and
//! the problem goes into the warnings.

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result, anyhow, bail};
use glam::{Vec3, Vec4};
use gltf::json::Root;
use gltf::json::material::AlphaMode as JsonAlphaMode;
use gltf::json::texture::{MagFilter, WrappingMode};
use gltf::json::validation::Checked;
use rayon::prelude::*;

use super::buffers::Buffers;
use super::uri;
use crate::scene::texture::ColorEncoding;
use crate::scene::{AlphaMode, Material, MaterialLibrary, Texture, TextureRef, WrapMode};

/// glTF's default `alphaCutoff`.
const DEFAULT_ALPHA_CUTOFF: f32 = 0.5;

/// All materials of the document (library index = glTF material index) and the textures they
/// use, decoded in parallel.
pub(super) fn load_materials(
    root: &Root,
    buffers: &Buffers,
    base_dir: Option<&Path>,
    warnings: &mut Vec<String>,
) -> MaterialLibrary {
    let slots = TextureSlots::of(root);
    let images = decode_images(root, buffers, base_dir, &slots, warnings);
    let decoded: Vec<Option<Texture>> = slots
        .slots
        .par_iter()
        .map(|&(texture, encoding)| {
            let image = images.get(&image_of(root, texture)?)?.as_ref()?;
            let (wrap_s, wrap_t, nearest) = sampler_of(root, texture);
            Some(Texture::from_image(image, encoding).with_sampler(wrap_s, wrap_t, nearest))
        })
        .collect();

    // Library index of each slot whose image decoded.
    let mut textures = Vec::new();
    let library_index: Vec<Option<usize>> = decoded
        .into_iter()
        .map(|texture| {
            texture.map(|texture| {
                textures.push(Arc::new(texture));
                textures.len() - 1
            })
        })
        .collect();
    let texture_ref = |texture: usize, tex_coord: u32, encoding: ColorEncoding| {
        let slot = slots.index.get(&(texture, encoding))?;
        Some(TextureRef {
            texture: library_index[*slot]?,
            tex_coord,
        })
    };

    let materials = root
        .materials
        .iter()
        .enumerate()
        .map(|(index, json)| {
            warn_about_unsupported_uv_sets(index, json, warnings);
            convert_material(json, &texture_ref)
        })
        .collect();
    MaterialLibrary {
        materials,
        textures,
        default_material: Material::default(),
    }
}

/// A material's texture uses, in a fixed order (base colour, metallic-roughness, normal,
/// emissive): (glTF texture, texCoord) when present, and the encoding the texture is read with.
fn texture_uses(json: &gltf::json::Material) -> [(Option<(usize, u32)>, ColorEncoding); 4] {
    let pbr = &json.pbr_metallic_roughness;
    let info = |info: &Option<gltf::json::texture::Info>| {
        info.as_ref()
            .map(|info| (info.index.value(), info.tex_coord))
    };
    let normal = json.normal_texture.as_ref();
    [
        (info(&pbr.base_color_texture), ColorEncoding::Srgb),
        (info(&pbr.metallic_roughness_texture), ColorEncoding::Linear),
        (
            normal.map(|normal| (normal.index.value(), normal.tex_coord)),
            ColorEncoding::Linear,
        ),
        (info(&json.emissive_texture), ColorEncoding::Srgb),
    ]
}

/// The (glTF texture, colour encoding) pairs the materials use, in first-use order. The same
/// glTF texture read as sRGB colour and as linear data becomes two library textures.
struct TextureSlots {
    slots: Vec<(usize, ColorEncoding)>,
    index: HashMap<(usize, ColorEncoding), usize>,
}

impl TextureSlots {
    fn of(root: &Root) -> TextureSlots {
        let mut slots = TextureSlots {
            slots: Vec::new(),
            index: HashMap::new(),
        };
        for json in &root.materials {
            for (texture, encoding) in texture_uses(json) {
                let Some((texture, _)) = texture else {
                    continue;
                };
                slots.index.entry((texture, encoding)).or_insert_with(|| {
                    slots.slots.push((texture, encoding));
                    slots.slots.len() - 1
                });
            }
        }
        slots
    }
}

fn image_of(root: &Root, texture: usize) -> Option<usize> {
    root.textures
        .get(texture)
        .map(|texture| texture.source.value())
}

/// Wrap modes and "nearest magnification" of a texture's sampler (glTF defaults: repeat,
/// filtering left to the renderer, which picks bilinear).
fn sampler_of(root: &Root, texture: usize) -> (WrapMode, WrapMode, bool) {
    let sampler = root
        .textures
        .get(texture)
        .and_then(|texture| texture.sampler)
        .and_then(|sampler| root.samplers.get(sampler.value()));
    let Some(sampler) = sampler else {
        return (WrapMode::Repeat, WrapMode::Repeat, false);
    };
    let wrap = |mode: Checked<WrappingMode>| match mode {
        Checked::Valid(WrappingMode::ClampToEdge) => WrapMode::ClampToEdge,
        Checked::Valid(WrappingMode::MirroredRepeat) => WrapMode::MirroredRepeat,
        Checked::Valid(WrappingMode::Repeat) | Checked::Invalid => WrapMode::Repeat,
    };
    let nearest = sampler.mag_filter == Some(Checked::Valid(MagFilter::Nearest));
    (wrap(sampler.wrap_s), wrap(sampler.wrap_t), nearest)
}

/// Decodes every image the slots use, in parallel. Failures become warnings and `None`.
fn decode_images(
    root: &Root,
    buffers: &Buffers,
    base_dir: Option<&Path>,
    slots: &TextureSlots,
    warnings: &mut Vec<String>,
) -> HashMap<usize, Option<image::DynamicImage>> {
    let mut images: Vec<usize> = slots
        .slots
        .iter()
        .filter_map(|&(texture, _)| image_of(root, texture))
        .collect();
    images.sort_unstable();
    images.dedup();
    let decoded: Vec<(usize, Result<image::DynamicImage>)> = images
        .into_par_iter()
        .map(|image| (image, decode_image(root, buffers, base_dir, image)))
        .collect();
    decoded
        .into_iter()
        .map(|(image, result)| {
            let image_or_none = result
                .map_err(|error| {
                    warnings.push(format!(
                        "{}: {error:#}; materials using it fall back to their factors",
                        image_label(root, image)
                    ))
                })
                .ok();
            (image, image_or_none)
        })
        .collect()
}

fn image_label(root: &Root, image: usize) -> String {
    let json = root.images.get(image);
    match (
        json.and_then(|i| i.name.as_deref()),
        json.and_then(|i| i.uri.as_deref()),
    ) {
        (_, Some(uri)) if !uri.starts_with("data:") => format!("image {image} ('{uri}')"),
        (Some(name), _) => format!("image {image} ('{name}')"),
        _ => format!("image {image}"),
    }
}

/// A PNG or JPEG image from a buffer view, a data URI or a file beside the glTF.
fn decode_image(
    root: &Root,
    buffers: &Buffers,
    base_dir: Option<&Path>,
    image: usize,
) -> Result<image::DynamicImage> {
    let json = root
        .images
        .get(image)
        .ok_or_else(|| anyhow!("image does not exist"))?;
    let bytes: Cow<[u8]> = match (&json.buffer_view, &json.uri) {
        (Some(view), _) => Cow::Borrowed(buffers.view(root, view.value())?),
        (None, Some(uri)) => Cow::Owned(uri::read_uri(uri, base_dir, None)?),
        (None, None) => bail!("the image has neither a uri nor a bufferView"),
    };
    let format = image::guess_format(&bytes).context("not a PNG or JPEG image")?;
    if !matches!(format, image::ImageFormat::Png | image::ImageFormat::Jpeg) {
        bail!("{format:?} images are not supported; glTF textures must be PNG or JPEG");
    }
    image::load_from_memory_with_format(&bytes, format)
        .with_context(|| format!("cannot decode the {format:?} image"))
}

fn warn_about_unsupported_uv_sets(
    index: usize,
    json: &gltf::json::Material,
    warnings: &mut Vec<String>,
) {
    let tex_coords = texture_uses(json).map(|(texture, _)| texture.map(|(_, set)| set));
    if let Some(set) = tex_coords.into_iter().flatten().find(|&set| set != 0) {
        let name = json
            .name
            .as_deref()
            .map_or(String::new(), |name| format!(" ('{name}')"));
        warnings.push(format!(
            "material {index}{name}: a texture reads TEXCOORD_{set}, but realcam loads only TEXCOORD_0, which it will use instead"
        ));
    }
}

fn convert_material(
    json: &gltf::json::Material,
    texture_ref: &impl Fn(usize, u32, ColorEncoding) -> Option<TextureRef>,
) -> Material {
    let pbr = &json.pbr_metallic_roughness;
    let [
        base_color_texture,
        metallic_roughness_texture,
        normal_texture,
        emissive_texture,
    ] = texture_uses(json).map(|(texture, encoding)| {
        texture.and_then(|(texture, tex_coord)| texture_ref(texture, tex_coord, encoding))
    });
    let emissive_strength = json
        .extensions
        .as_ref()
        .and_then(|extensions| extensions.emissive_strength.as_ref())
        .map_or(1.0, |strength| strength.emissive_strength.0);
    Material {
        name: json.name.clone(),
        base_color: Vec4::from(pbr.base_color_factor.0),
        base_color_texture,
        metallic: pbr.metallic_factor.0,
        roughness: pbr.roughness_factor.0,
        metallic_roughness_texture,
        normal_texture,
        normal_scale: json
            .normal_texture
            .as_ref()
            .map_or(1.0, |normal| normal.scale),
        emissive: Vec3::from(json.emissive_factor.0) * emissive_strength,
        emissive_texture,
        alpha_mode: match json.alpha_mode {
            Checked::Valid(JsonAlphaMode::Mask) => AlphaMode::Mask(
                json.alpha_cutoff
                    .as_ref()
                    .map_or(DEFAULT_ALPHA_CUTOFF, |cutoff| cutoff.0),
            ),
            Checked::Valid(JsonAlphaMode::Blend) => AlphaMode::Blend,
            Checked::Valid(JsonAlphaMode::Opaque) | Checked::Invalid => AlphaMode::Opaque,
        },
        double_sided: json.double_sided,
    }
}
