//! Mesh primitives → triangle [`Mesh`]es in the mesh's local frame.

use anyhow::{Context, Result, anyhow, bail};
use glam::{Vec2, Vec3, Vec4};
use gltf::json::Root;
use gltf::json::mesh::{Mode, Primitive, Semantic};
use gltf::json::validation::Checked;

use super::accessor;
use super::buffers::Buffers;
use crate::scene::Mesh;

/// "mesh 3 ('Body') primitive 1", for messages.
pub(super) fn primitive_label(root: &Root, mesh: usize, primitive: usize) -> String {
    match root.meshes.get(mesh).and_then(|mesh| mesh.name.as_deref()) {
        Some(name) => format!("mesh {mesh} ('{name}') primitive {primitive}"),
        None => format!("mesh {mesh} primitive {primitive}"),
    }
}

/// Triangle and vertex counts a primitive will produce, from the JSON accessor counts alone
/// (before any buffer is read), for the memory guard.
pub(super) fn estimated_size(root: &Root, primitive: &Primitive) -> Result<(u64, u64)> {
    let vertices = accessor::declared_count(root, position_accessor(primitive)?)?;
    let corners = match primitive.indices {
        Some(indices) => accessor::declared_count(root, indices.value())?,
        None => vertices,
    };
    let triangles = match primitive.mode {
        Checked::Valid(Mode::Triangles) => corners / 3,
        Checked::Valid(Mode::TriangleStrip | Mode::TriangleFan) => corners.saturating_sub(2),
        _ => 0,
    };
    Ok((triangles, vertices))
}

/// Reads primitive `primitive` of mesh `mesh`. `None` when it has no triangles to render
/// (points and lines are skipped with a warning).
pub(super) fn read_primitive(
    root: &Root,
    buffers: &Buffers,
    mesh: usize,
    primitive: usize,
    warnings: &mut Vec<String>,
    degenerate: &mut DegenerateTriangles,
) -> Result<Option<Mesh>> {
    let label = primitive_label(root, mesh, primitive);
    let json = root
        .meshes
        .get(mesh)
        .and_then(|json| json.primitives.get(primitive))
        .ok_or_else(|| anyhow!("{label} does not exist"))?;
    read(root, buffers, json, &label, warnings, degenerate).with_context(|| label.clone())
}

/// Zero-area triangles dropped over a whole scene. They are harmless and common (a UV sphere's
/// pole triangles, in every copy of the model), so the scene gets one warning for all of them
/// rather than one per primitive.
#[derive(Debug, Default)]
pub(super) struct DegenerateTriangles {
    /// Each primitive that had some, with how many.
    primitives: Vec<(String, usize)>,
}

impl DegenerateTriangles {
    fn add(&mut self, label: &str, count: usize) {
        if count > 0 {
            self.primitives.push((label.to_string(), count));
        }
    }

    /// The one warning, naming the primitive when there is one and the first few otherwise.
    pub(super) fn warning(&self) -> Option<String> {
        const NAMED: usize = 3;
        let total: usize = self.primitives.iter().map(|(_, count)| count).sum();
        match self.primitives.as_slice() {
            [] => None,
            [(label, count)] => Some(format!(
                "{label}: {count} degenerate (zero-area) triangles dropped"
            )),
            primitives => {
                let named: Vec<&str> = primitives
                    .iter()
                    .take(NAMED)
                    .map(|(label, _)| label.as_str())
                    .collect();
                let more = primitives.len().saturating_sub(NAMED);
                Some(format!(
                    "{total} degenerate (zero-area) triangles dropped in {} primitives ({}{})",
                    primitives.len(),
                    named.join(", "),
                    if more > 0 {
                        format!(" and {more} more")
                    } else {
                        String::new()
                    }
                ))
            }
        }
    }
}

fn read(
    root: &Root,
    buffers: &Buffers,
    json: &Primitive,
    label: &str,
    warnings: &mut Vec<String>,
    degenerate: &mut DegenerateTriangles,
) -> Result<Option<Mesh>> {
    let mode = match json.mode {
        Checked::Valid(mode @ (Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan)) => mode,
        Checked::Valid(other) => {
            warnings.push(format!(
                "{label}: {other:?} primitive skipped (realcam renders triangles only)"
            ));
            return Ok(None);
        }
        Checked::Invalid => bail!("invalid primitive mode"),
    };
    if json
        .targets
        .as_ref()
        .is_some_and(|targets| !targets.is_empty())
    {
        warnings.push(format!(
            "{label}: morph targets ignored; the base shape is rendered"
        ));
    }

    let mut positions: Vec<Vec3> =
        accessor::read_vectors::<3>(root, buffers, position_accessor(json)?)?
            .into_iter()
            .map(Vec3::from)
            .collect();
    let vertex_count = positions.len();
    let corners = match json.indices {
        Some(indices) => {
            let indices = accessor::read_indices(root, buffers, indices.value())?;
            if let Some(bad) = indices
                .iter()
                .find(|&&index| index as usize >= vertex_count)
            {
                bail!(
                    "index {bad} is out of range: the primitive has {vertex_count} vertices; the file is corrupt"
                );
            }
            indices
        }
        None => {
            let count = u32::try_from(vertex_count).map_err(|_| {
                anyhow!("{vertex_count} vertices are more than 32-bit indices can address")
            })?;
            (0..count).collect()
        }
    };
    if mode == Mode::Triangles && corners.len() % 3 != 0 {
        warnings.push(format!(
            "{label}: {} indices is not a multiple of 3; the last {} ignored",
            corners.len(),
            corners.len() % 3
        ));
    }
    let mut triangles = assemble_triangles(mode, &corners);
    let zero_area = drop_bad_triangles(&mut triangles, &mut positions, label, warnings);
    degenerate.add(label, zero_area);
    if triangles.is_empty() {
        return Ok(None);
    }

    let attribute = |semantic: Semantic| {
        let accessor = json
            .attributes
            .get(&Checked::Valid(semantic.clone()))?
            .value();
        Some((accessor, semantic))
    };
    let mut optional = OptionalAttributes {
        root,
        buffers,
        vertex_count,
        label,
        warnings,
    };
    let mut normals: Vec<Vec3> = optional
        .read::<3>(attribute(Semantic::Normals))?
        .map(|normals| normals.into_iter().map(Vec3::from).collect())
        .unwrap_or_default();
    let repaired = repair_normals(&mut normals, &triangles, &positions);
    if repaired > 0 {
        optional.warnings.push(format!(
            "{label}: {repaired} zero-length or non-finite normals replaced by the mean of the adjacent face normals"
        ));
    }
    let tangents = optional
        .read::<4>(attribute(Semantic::Tangents))?
        .map(|tangents| tangents.into_iter().map(Vec4::from).collect::<Vec<_>>())
        .and_then(|tangents| optional.normalized_tangents(tangents))
        .unwrap_or_default();
    let uvs = optional
        .read::<2>(attribute(Semantic::TexCoords(0)))?
        .map(|uvs| uvs.into_iter().map(Vec2::from).collect())
        .unwrap_or_default();

    Ok(Some(Mesh {
        positions,
        normals,
        tangents,
        uvs,
        triangles,
        material: json.material.map(|material| material.value()),
    }))
}

/// Reads per-vertex attributes that may be dropped (with a warning) when they are unusable.
struct OptionalAttributes<'a> {
    root: &'a Root,
    buffers: &'a Buffers<'a>,
    vertex_count: usize,
    label: &'a str,
    warnings: &'a mut Vec<String>,
}

impl OptionalAttributes<'_> {
    fn read<const N: usize>(
        &mut self,
        attribute: Option<(usize, Semantic)>,
    ) -> Result<Option<Vec<[f32; N]>>> {
        let Some((accessor, semantic)) = attribute else {
            return Ok(None);
        };
        // Compared before reading, so a huge bogus count never allocates.
        let count = accessor::declared_count(self.root, accessor)?;
        if count != self.vertex_count as u64 {
            self.warnings.push(format!(
                "{}: {} has {count} elements but POSITION has {}; {} ignored",
                self.label,
                semantic_name(&semantic),
                self.vertex_count,
                semantic_name(&semantic)
            ));
            return Ok(None);
        }
        accessor::read_vectors::<N>(self.root, self.buffers, accessor)
            .with_context(|| semantic_name(&semantic))
            .map(Some)
    }

    /// Unit tangents with handedness ±1, or `None` (and a warning) if any is unusable (zero
    /// length, not finite): normal mapping then derives tangents itself.
    fn normalized_tangents(&mut self, tangents: Vec<Vec4>) -> Option<Vec<Vec4>> {
        let normalized: Option<Vec<Vec4>> = tangents
            .into_iter()
            .map(|tangent| {
                let xyz = tangent.truncate().try_normalize()?;
                tangent
                    .w
                    .is_finite()
                    .then(|| xyz.extend(tangent.w.signum()))
            })
            .collect();
        if normalized.is_none() {
            self.warnings.push(format!(
                "{}: TANGENT has zero-length or non-finite vectors; tangents ignored",
                self.label
            ));
        }
        normalized
    }
}

/// Normalizes every normal; a zero-length or non-finite one is replaced by the area-weighted
/// mean of the face normals of its triangles. Returns how many were replaced.
fn repair_normals(normals: &mut [Vec3], triangles: &[[u32; 3]], positions: &[Vec3]) -> usize {
    let mut broken = vec![false; normals.len()];
    for (normal, broken) in normals.iter_mut().zip(&mut broken) {
        match normal.try_normalize() {
            Some(unit) => *normal = unit,
            None => *broken = true,
        }
    }
    let repaired = broken.iter().filter(|&&broken| broken).count();
    if repaired == 0 {
        return 0;
    }
    for normal in normals
        .iter_mut()
        .zip(&broken)
        .filter_map(|(n, &b)| b.then_some(n))
    {
        *normal = Vec3::ZERO;
    }
    for &triangle in triangles {
        let [a, b, c] = triangle.map(|index| positions[index as usize]);
        // The cross product's length is twice the area: an area-weighted sum.
        let face = (b - a).cross(c - a);
        for index in triangle.map(|index| index as usize) {
            if broken[index] {
                normals[index] += face;
            }
        }
    }
    for normal in normals
        .iter_mut()
        .zip(&broken)
        .filter_map(|(n, &b)| b.then_some(n))
    {
        // Opposite faces can cancel; any unit vector is as good as another then.
        *normal = normal.try_normalize().unwrap_or(Vec3::Y);
    }
    repaired
}

fn semantic_name(semantic: &Semantic) -> String {
    match semantic {
        Semantic::Normals => "NORMAL".into(),
        Semantic::Tangents => "TANGENT".into(),
        Semantic::TexCoords(set) => format!("TEXCOORD_{set}"),
        other => format!("{other:?}"),
    }
}

fn position_accessor(primitive: &Primitive) -> Result<usize> {
    primitive
        .attributes
        .get(&Checked::Valid(Semantic::Positions))
        .map(|accessor| accessor.value())
        .ok_or_else(|| anyhow!("primitive has no POSITION attribute"))
}

/// Triangles of a triangle list, strip or fan, in the glTF spec's vertex order (§3.7.2.1),
/// so all triangles of a strip or fan share the winding of the first.
pub(super) fn assemble_triangles(mode: Mode, corners: &[u32]) -> Vec<[u32; 3]> {
    let n = corners.len();
    match mode {
        Mode::Triangles => corners
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
        Mode::TriangleStrip => (0..n.saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [corners[i], corners[i + 1], corners[i + 2]]
                } else {
                    [corners[i], corners[i + 2], corners[i + 1]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..n.saturating_sub(1))
            .map(|i| [corners[i], corners[i + 1], corners[0]])
            .collect(),
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip => Vec::new(),
    }
}

/// Removes triangles touching a non-finite position, zero-area triangles and triangles so
/// large their area overflows f32 (the first and last with a warning), then zeroes non-finite
/// positions so no NaN reaches later stages. Returns how many zero-area triangles it dropped
/// (see [`DegenerateTriangles`]).
fn drop_bad_triangles(
    triangles: &mut Vec<[u32; 3]>,
    positions: &mut [Vec3],
    label: &str,
    warnings: &mut Vec<String>,
) -> usize {
    let (mut non_finite, mut degenerate, mut overflowing) = (0usize, 0usize, 0usize);
    triangles.retain(|triangle| {
        let [a, b, c] = triangle.map(|index| positions[index as usize]);
        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
            non_finite += 1;
            return false;
        }
        let area_vector = (b - a).cross(c - a);
        if !area_vector.is_finite() {
            overflowing += 1;
            return false;
        }
        if area_vector == Vec3::ZERO {
            degenerate += 1;
            return false;
        }
        true
    });
    if overflowing > 0 {
        warnings.push(format!(
            "{label}: {overflowing} triangles so large their area overflows f32 dropped; check the scene's units"
        ));
    }
    if non_finite > 0 {
        warnings.push(format!(
            "{label}: {non_finite} triangles with non-finite vertex positions dropped"
        ));
        for position in positions.iter_mut().filter(|p| !p.is_finite()) {
            *position = Vec3::ZERO;
        }
    }
    degenerate
}

/// The same mesh with every triangle's winding reversed: placed by a mirroring transform
/// (negative determinant), it keeps its geometric normals pointing outwards.
pub(super) fn with_reversed_winding(mesh: &Mesh) -> Mesh {
    Mesh {
        triangles: mesh.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect(),
        ..mesh.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strip_alternates_to_keep_winding() {
        let triangles = assemble_triangles(Mode::TriangleStrip, &[0, 1, 2, 3, 4]);
        assert_eq!(triangles, [[0, 1, 2], [1, 3, 2], [2, 3, 4]]);
    }

    #[test]
    fn fan_shares_first_vertex() {
        let triangles = assemble_triangles(Mode::TriangleFan, &[0, 1, 2, 3, 4]);
        assert_eq!(triangles, [[1, 2, 0], [2, 3, 0], [3, 4, 0]]);
    }

    #[test]
    fn short_inputs_give_no_triangles() {
        for mode in [Mode::Triangles, Mode::TriangleStrip, Mode::TriangleFan] {
            assert!(assemble_triangles(mode, &[0, 1]).is_empty());
            assert!(assemble_triangles(mode, &[]).is_empty());
        }
    }

    #[test]
    fn bad_triangles_are_dropped_and_counted() {
        let mut positions = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::new(f32::NAN, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(1e30, 0.0, 0.0),
            Vec3::new(0.0, 1e30, 0.0),
        ];
        let mut triangles = vec![[0, 1, 2], [0, 1, 3], [0, 1, 4], [2, 2, 1], [0, 5, 6]];
        let mut warnings = Vec::new();
        let zero_area = drop_bad_triangles(&mut triangles, &mut positions, "test", &mut warnings);
        assert_eq!(triangles, [[0, 1, 2]]);
        assert_eq!(zero_area, 2);
        assert_eq!(warnings.len(), 2, "{warnings:?}");
        assert!(warnings[0].contains("1 triangles so large their area overflows"));
        assert!(warnings[1].contains("1 triangles with non-finite"));
        assert!(positions.iter().all(|p| p.is_finite()));
    }

    #[test]
    fn zero_area_triangles_are_one_warning_for_the_scene() {
        let mut tally = DegenerateTriangles::default();
        assert_eq!(tally.warning(), None);
        tally.add("mesh 0 ('Sphere') primitive 0", 2);
        assert_eq!(
            tally.warning().unwrap(),
            "mesh 0 ('Sphere') primitive 0: 2 degenerate (zero-area) triangles dropped"
        );
        for mesh in 1..98 {
            tally.add(&format!("mesh {mesh} ('Sphere') primitive 0"), 2);
        }
        tally.add("mesh 98 primitive 0", 0);
        assert_eq!(
            tally.warning().unwrap(),
            "196 degenerate (zero-area) triangles dropped in 98 primitives (mesh 0 ('Sphere') primitive 0, mesh 1 ('Sphere') primitive 0, mesh 2 ('Sphere') primitive 0 and 95 more)"
        );
    }

    #[test]
    fn broken_normals_are_rebuilt_from_faces() {
        let positions = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let mut normals = [Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, Vec3::splat(f32::NAN)];
        assert_eq!(repair_normals(&mut normals, &[[0, 1, 2]], &positions), 2);
        assert_eq!(normals, [Vec3::Z; 3]);
    }
}
