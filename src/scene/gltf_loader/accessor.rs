//! Reading accessors into typed arrays. Every offset, stride and count is checked against the
//! bytes actually present, so a corrupt file gives an error instead of a panic.

use anyhow::{Context, Result, anyhow, bail};
use gltf::json::Root;
use gltf::json::accessor::{ComponentType, GenericComponentType, IndexComponentType, Type};
use gltf::json::validation::Checked;

use super::buffers::Buffers;

/// Element count of accessor `index` as declared in the JSON (nothing is read).
pub(super) fn declared_count(root: &Root, index: usize) -> Result<u64> {
    Ok(json(root, index)?.count.0)
}

/// Reads a float vector accessor (`N` = 2, 3 or 4 components). Integer components are
/// converted as glTF says: normalized ones to [0, 1] or [−1, 1], others to their value.
pub(super) fn read_vectors<const N: usize>(
    root: &Root,
    buffers: &Buffers,
    index: usize,
) -> Result<Vec<[f32; N]>> {
    let accessor = json(root, index)?;
    expect_type(accessor, index, N)?;
    let component_type = component_type(accessor, index)?;
    let component = float_decoder(component_type, accessor.normalized);
    let size = component_type.size();
    read_elements(root, buffers, index, N * size, [0.0; N], |bytes| {
        std::array::from_fn(|c| component(&bytes[c * size..]))
    })
}

/// Reads an index accessor (scalar `UNSIGNED_BYTE`, `UNSIGNED_SHORT` or `UNSIGNED_INT`).
pub(super) fn read_indices(root: &Root, buffers: &Buffers, index: usize) -> Result<Vec<u32>> {
    let accessor = json(root, index)?;
    expect_type(accessor, index, 1)?;
    let component_type = component_type(accessor, index)?;
    let Some(decode) = index_decoder(component_type) else {
        bail!(
            "accessor {index} is used as indices but has component type {component_type:?}; indices must be unsigned integers"
        );
    };
    read_elements(root, buffers, index, component_type.size(), 0, decode)
}

fn json(root: &Root, index: usize) -> Result<&gltf::json::Accessor> {
    root.accessors
        .get(index)
        .ok_or_else(|| anyhow!("accessor {index} does not exist"))
}

fn expect_type(accessor: &gltf::json::Accessor, index: usize, components: usize) -> Result<()> {
    match accessor.type_ {
        Checked::Valid(ty) if ty != Type::Mat2 && ty.multiplicity() == components => Ok(()),
        Checked::Valid(ty) => {
            bail!("accessor {index} has type {ty:?} but {components} components are needed here")
        }
        Checked::Invalid => bail!("accessor {index} has an invalid type"),
    }
}

fn component_type(accessor: &gltf::json::Accessor, index: usize) -> Result<ComponentType> {
    match accessor.component_type {
        Checked::Valid(GenericComponentType(ty)) => Ok(ty),
        Checked::Invalid => bail!("accessor {index} has an invalid componentType"),
    }
}

/// Reads `count` elements of `element_size` bytes each with `decode`, from the accessor's
/// buffer view (or `zero`s when it has none) and then its sparse substitutions.
fn read_elements<T: Clone>(
    root: &Root,
    buffers: &Buffers,
    index: usize,
    element_size: usize,
    zero: T,
    decode: impl Fn(&[u8]) -> T,
) -> Result<Vec<T>> {
    let accessor = json(root, index)?;
    let count = to_usize(accessor.count.0, index)?;
    let mut values = match accessor.buffer_view {
        Some(view) => {
            let bytes = buffers
                .view(root, view.value())
                .with_context(|| format!("accessor {index}"))?;
            let stride = root
                .buffer_views
                .get(view.value())
                .and_then(|view| view.byte_stride)
                .map_or(element_size, |stride| stride.0);
            if stride < element_size {
                bail!(
                    "accessor {index}: buffer view {} has byteStride {stride}, less than the {element_size}-byte elements it holds",
                    view.value()
                );
            }
            let offset = to_usize(accessor.byte_offset.map_or(0, |offset| offset.0), index)?;
            strided(bytes, offset, stride, count, element_size)
                .with_context(|| format!("accessor {index} (buffer view {})", view.value()))?
                .map(&decode)
                .collect()
        }
        None => vec![zero; count],
    };
    if let Some(sparse) = &accessor.sparse {
        let sparse_count = to_usize(sparse.count.0, index)?;
        let positions = sparse_indices(root, buffers, index, sparse, sparse_count)?;
        let values_bytes = buffers
            .view(root, sparse.values.buffer_view.value())
            .with_context(|| format!("sparse values of accessor {index}"))?;
        let values_offset = to_usize(sparse.values.byte_offset.0, index)?;
        let replacements = strided(
            values_bytes,
            values_offset,
            element_size,
            sparse_count,
            element_size,
        )
        .with_context(|| format!("sparse values of accessor {index}"))?;
        for (position, bytes) in positions.into_iter().zip(replacements) {
            let Some(slot) = values.get_mut(position as usize) else {
                bail!("accessor {index}: sparse index {position} is outside its {count} elements");
            };
            *slot = decode(bytes);
        }
    }
    Ok(values)
}

fn sparse_indices(
    root: &Root,
    buffers: &Buffers,
    index: usize,
    sparse: &gltf::json::accessor::sparse::Sparse,
    count: usize,
) -> Result<Vec<u32>> {
    let Checked::Valid(IndexComponentType(component_type)) = sparse.indices.component_type else {
        bail!("sparse indices of accessor {index} have an invalid componentType");
    };
    let Some(decode) = index_decoder(component_type) else {
        bail!("sparse indices of accessor {index} are not unsigned integers");
    };
    let bytes = buffers
        .view(root, sparse.indices.buffer_view.value())
        .with_context(|| format!("sparse indices of accessor {index}"))?;
    let offset = to_usize(sparse.indices.byte_offset.0, index)?;
    let size = component_type.size();
    Ok(strided(bytes, offset, size, count, size)
        .with_context(|| format!("sparse indices of accessor {index}"))?
        .map(decode)
        .collect())
}

/// The `count` element slices at `offset + i × stride`, after checking that all lie in `bytes`.
fn strided(
    bytes: &[u8],
    offset: usize,
    stride: usize,
    count: usize,
    element_size: usize,
) -> Result<impl Iterator<Item = &[u8]>> {
    if count > 0 {
        let end = (count - 1)
            .checked_mul(stride)
            .and_then(|span| span.checked_add(offset)?.checked_add(element_size));
        match end {
            Some(end) if end <= bytes.len() => {}
            _ => bail!(
                "{count} elements of {element_size} bytes (stride {stride}, offset {offset}) do not fit in the {} bytes available; the file is corrupt",
                bytes.len()
            ),
        }
    }
    Ok((0..count).map(move |i| &bytes[offset + i * stride..][..element_size]))
}

fn to_usize(value: u64, index: usize) -> Result<usize> {
    usize::try_from(value).map_err(|_| anyhow!("accessor {index}: {value} is too large"))
}

/// The decoder of one float component, following glTF §3.11 for normalized integers.
fn float_decoder(component_type: ComponentType, normalized: bool) -> fn(&[u8]) -> f32 {
    match (component_type, normalized) {
        (ComponentType::F32, _) => |b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        (ComponentType::U8, false) => |b| f32::from(b[0]),
        (ComponentType::U8, true) => |b| f32::from(b[0]) / 255.0,
        (ComponentType::I8, false) => |b| f32::from(b[0] as i8),
        (ComponentType::I8, true) => |b| (f32::from(b[0] as i8) / 127.0).max(-1.0),
        (ComponentType::U16, false) => |b| f32::from(u16::from_le_bytes([b[0], b[1]])),
        (ComponentType::U16, true) => |b| f32::from(u16::from_le_bytes([b[0], b[1]])) / 65535.0,
        (ComponentType::I16, false) => |b| f32::from(i16::from_le_bytes([b[0], b[1]])),
        (ComponentType::I16, true) => {
            |b| (f32::from(i16::from_le_bytes([b[0], b[1]])) / 32767.0).max(-1.0)
        }
        (ComponentType::U32, false) => |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
        (ComponentType::U32, true) => |b| {
            (f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])) / f64::from(u32::MAX)) as f32
        },
    }
}

fn index_decoder(component_type: ComponentType) -> Option<fn(&[u8]) -> u32> {
    match component_type {
        ComponentType::U8 => Some(|b| u32::from(b[0])),
        ComponentType::U16 => Some(|b| u32::from(u16::from_le_bytes([b[0], b[1]]))),
        ComponentType::U32 => Some(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        ComponentType::I8 | ComponentType::I16 | ComponentType::F32 => None,
    }
}
