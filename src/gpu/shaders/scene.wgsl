// The scene on the GPU (bind group 1): the CPU's obvhs CWBVH traversed as it is, the same
// Möller–Trumbore test, alpha-mask holes, surface points, ray spawning and texture sampling.
// Each function mirrors the CPU code it names (src/accel/*, src/scene/texture.rs); the
// buffers are written by src/gpu/scene.rs, whose structs give the byte layouts.

// ---- Bindings -------------------------------------------------------------------------

struct SceneParams {
    // World → BVH space scale, an exact power of two (accel::triangles::bvh_space_scale), and
    // its inverse (also exact), so that scaling in and out rounds nothing.
    bvh_scale: f32,
    inv_bvh_scale: f32,
    // 0: the scene has no triangle, every ray misses.
    node_count: u32,
    triangle_count: u32,
    // Entries of scene_alpha_masks: one per material, then the default material's.
    alpha_mask_count: u32,
    // 0 when no material is masked: traversal skips every lookup.
    any_alpha_mask: u32,
    texture_count: u32,
    _pad: u32,
    // Packed 8-bit texel decoding, the CPU's own values: [0, 256) the sRGB table
    // (SRGB8_TO_LINEAR), [256, 512) k / 255 (linear channels and alpha).
    decode: array<vec4f, 128>,
}

// obvhs's CwBvhNode byte for byte (80 bytes): `e_imask` holds the three extent exponent bytes
// and the inner-child mask; each vec2u holds the eight bytes of one per-child field.
struct SceneNode {
    p: vec3f,
    e_imask: u32,
    child_base: u32,
    primitive_base: u32,
    child_meta: vec2u,
    child_min_x: vec2u,
    child_max_x: vec2u,
    child_min_y: vec2u,
    child_max_y: vec2u,
    child_min_z: vec2u,
    child_max_z: vec2u,
}

// One triangle in BVH order (64 bytes): BVH-space geometry as the CPU's TrianglePrimitive
// (v0, v1 − v0, v2 − v0) interleaved with its TriangleRecord.
struct SceneTriangle {
    v0: vec3f,
    material: u32,
    edge1: vec3f,
    attributes: u32,
    edge2: vec3f,
    vertex0: u32,
    vertex1: u32,
    vertex2: u32,
    _pad0: u32,
    _pad1: u32,
}

// World-space vertex attributes (accel::WorldVertices), 36 bytes.
struct SceneVertex {
    normal: array<f32, 3>,
    uv: array<f32, 2>,
    tangent: array<f32, 4>,
}

struct SceneAlphaMask {
    cutoff: f32,
    // Base-colour factor alpha.
    factor: f32,
    // SCENE_NONE: no base-colour texture, alpha 1.
    texture: u32,
    // 0: the material is not masked.
    masked: u32,
}

struct SceneTexture {
    width: u32,
    height: u32,
    // First word of the texture in scene_texels.
    offset: u32,
    texel_count: u32,
    // SCENE_TEXELS_F32 / _SRGB8 / _LINEAR8.
    format: u32,
    // SCENE_WRAP_*.
    wrap_s: u32,
    wrap_t: u32,
    nearest: u32,
}

@group(1) @binding(0) var<uniform> scene_params: SceneParams;
@group(1) @binding(1) var<storage, read> scene_nodes: array<SceneNode>;
@group(1) @binding(2) var<storage, read> scene_triangles: array<SceneTriangle>;
@group(1) @binding(3) var<storage, read> scene_vertices: array<SceneVertex>;
@group(1) @binding(4) var<storage, read> scene_alpha_masks: array<SceneAlphaMask>;
@group(1) @binding(5) var<storage, read> scene_textures: array<SceneTexture>;
@group(1) @binding(6) var<storage, read> scene_texels: array<u32>;

const SCENE_NONE: u32 = 0xffffffffu;
const SCENE_NO_MATERIAL: u32 = 0xffffffffu;

// accel::triangles::attributes
const SCENE_HAS_NORMALS: u32 = 1u;
const SCENE_HAS_UVS: u32 = 2u;
const SCENE_HAS_TANGENTS: u32 = 4u;

// Texel formats: four f32 words per texel, or one word of four bytes decoded by table.
const SCENE_TEXELS_F32: u32 = 0u;
const SCENE_TEXELS_SRGB8: u32 = 1u;
const SCENE_TEXELS_LINEAR8: u32 = 2u;

const SCENE_WRAP_REPEAT: u32 = 0u;
const SCENE_WRAP_MIRRORED_REPEAT: u32 = 1u;
const SCENE_WRAP_CLAMP_TO_EDGE: u32 = 2u;

// obvhs's child-box entry clamp (cwbvh::node::EPSILON), BVH space.
const SCENE_ENTRY_EPSILON: f32 = 0.0001;
// obvhs's TRAVERSAL_STACK_SIZE: CwBvh::validate keeps trees shallower.
const SCENE_STACK_SIZE: u32 = 32u;
// A t_max for rays without a bound (WGSL cannot spell infinity; this times any BVH scale
// above 1 overflows to it, and below 1 stays beyond every hit).
const SCENE_NO_T_MAX: f32 = 3.40282347e38;

// ---- Public interface -------------------------------------------------------------------

// A closest hit, as crate::batch::Hit: t in metres along the (unit) world direction,
// barycentric weights u, v of vertices 1 and 2; triangle == SCENE_NONE (0xffffffff): no hit.
struct Hit {
    t: f32,
    u: f32,
    v: f32,
    triangle: u32,
}

// accel::SurfacePoint; material SCENE_NO_MATERIAL (0xffffffff) = the default material.
struct SurfacePoint {
    position: vec3f,
    geometric_normal: vec3f,
    shading_normal: vec3f,
    tangent: vec4f,
    uv: vec2f,
    material: u32,
    back_face: bool,
    spawn_offset: f32,
}

// SceneAccel::intersect: the closest hit in (0, t_max) skipping alpha-mask holes.
fn scene_intersect(origin: vec3f, direction: vec3f, t_max: f32) -> Hit {
    var ray: SceneRay;
    if !scene_bvh_ray(origin, direction, t_max, &ray) {
        return scene_miss();
    }
    var hit = scene_traverse(ray, false);
    if hit.triangle != SCENE_NONE {
        hit.t = hit.t * scene_params.inv_bvh_scale;
    }
    return hit;
}

// SceneAccel::occluded: any opaque hit in (0, t_max); stops at the first found.
fn scene_occluded(origin: vec3f, direction: vec3f, t_max: f32) -> bool {
    var ray: SceneRay;
    if !scene_bvh_ray(origin, direction, t_max, &ray) {
        return false;
    }
    return scene_traverse(ray, true).triangle != SCENE_NONE;
}

// SceneAccel::surface: the shading frame at `hit`, seen along `direction`.
fn scene_surface(hit: Hit, direction: vec3f) -> SurfacePoint {
    if hit.triangle >= scene_params.triangle_count {
        // Not a triangle of this scene (a caller bug): a harmless frame, as the CPU gives.
        let normal = -scene_normalize_or(direction, vec3f(0.0, 0.0, 1.0));
        return SurfacePoint(vec3f(0.0), normal, normal, vec4f(0.0), vec2f(0.0), SCENE_NO_MATERIAL,
            false, 0.0);
    }
    let triangle = scene_triangles[hit.triangle];
    let u = hit.u;
    let v = hit.v;
    let w = 1.0 - u - v;
    let position = (triangle.v0 + triangle.edge1 * u + triangle.edge2 * v) * scene_params.inv_bvh_scale;
    let front_normal = scene_normalize_or(cross(triangle.edge1, triangle.edge2), vec3f(0.0, 0.0, 1.0));
    let back_face = dot(front_normal, direction) > 0.0;
    let side = select(1.0, -1.0, back_face);
    let geometric_normal = front_normal * side;

    let a = scene_vertices[triangle.vertex0];
    let b = scene_vertices[triangle.vertex1];
    let c = scene_vertices[triangle.vertex2];
    var interpolated_normal = front_normal;
    if (triangle.attributes & SCENE_HAS_NORMALS) != 0u {
        interpolated_normal = scene_normalize_or(
            scene_vertex_normal(a) * w + scene_vertex_normal(b) * u + scene_vertex_normal(c) * v,
            front_normal);
    }
    let has_uvs = (triangle.attributes & SCENE_HAS_UVS) != 0u;
    var uv = vec2f(0.0);
    if has_uvs {
        uv = scene_vertex_uv(a) * w + scene_vertex_uv(b) * u + scene_vertex_uv(c) * v;
    }
    var tangent = vec4f(0.0);
    if (triangle.attributes & SCENE_HAS_TANGENTS) != 0u {
        let t0 = scene_vertex_tangent(a);
        let interpolated = t0 * w + scene_vertex_tangent(b) * u + scene_vertex_tangent(c) * v;
        tangent = scene_orthogonal_tangent(interpolated.xyz, interpolated_normal, t0.w);
    } else if has_uvs {
        tangent = scene_uv_tangent(triangle.edge1, triangle.edge2, scene_vertex_uv(a),
            scene_vertex_uv(b), scene_vertex_uv(c), interpolated_normal);
    }

    // The whole frame mirrored onto the side the ray came from; vertex normals against their
    // own face (inverted data) turned to the viewer's side as well.
    var shading_normal = interpolated_normal * side;
    if dot(shading_normal, geometric_normal) < 0.0 {
        shading_normal = -shading_normal;
    }
    return SurfacePoint(position, geometric_normal, shading_normal, tangent * side, uv,
        triangle.material, back_face, scene_triangle_spawn_offset(hit.triangle));
}

// SurfacePoint::spawn_origin: the origin for a ray leaving `surface` along `direction` that
// does not hit the surface it leaves.
fn scene_spawn_origin(surface: SurfacePoint, direction: vec3f) -> vec3f {
    return scene_offset_along_normal(surface.position, surface.geometric_normal,
        surface.spawn_offset, direction);
}

// accel::spawn::offset_along_normal: `position` moved `offset` along `normal`, to the side
// `direction` points to.
fn scene_offset_along_normal(position: vec3f, normal: vec3f, offset: f32, direction: vec3f) -> vec3f {
    let toward = select(normal, -normal, dot(normal, direction) < 0.0);
    return position + toward * offset;
}

// SceneAccel::triangle_vertices: world-space vertices (zeros for an index out of range).
fn scene_triangle_vertices(triangle: u32) -> array<vec3f, 3> {
    if triangle >= scene_params.triangle_count {
        return array<vec3f, 3>(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    }
    let t = scene_triangles[triangle];
    let s = scene_params.inv_bvh_scale;
    return array<vec3f, 3>(t.v0 * s, (t.v0 + t.edge1) * s, (t.v0 + t.edge2) * s);
}

// SceneAccel::triangle_material (SCENE_NO_MATERIAL: the default material).
fn scene_triangle_material(triangle: u32) -> u32 {
    if triangle >= scene_params.triangle_count {
        return SCENE_NO_MATERIAL;
    }
    return scene_triangles[triangle].material;
}

// SceneAccel::triangle_spawn_offset: how far off `triangle` a ray leaving it must start,
// 2^-16 of its largest world coordinate.
fn scene_triangle_spawn_offset(triangle: u32) -> f32 {
    let vertices = scene_triangle_vertices(triangle);
    let magnitude = max(scene_max_abs(vertices[0]), max(scene_max_abs(vertices[1]),
        scene_max_abs(vertices[2])));
    return select(0.0, magnitude, scene_is_finite(magnitude)) * (1.0 / 65536.0);
}

// SceneAccel::uv_at: texture coordinates at barycentrics (u, v); zero without UVs.
fn scene_uv_at(triangle: u32, u: f32, v: f32) -> vec2f {
    if triangle >= scene_params.triangle_count {
        return vec2f(0.0);
    }
    let t = scene_triangles[triangle];
    if (t.attributes & SCENE_HAS_UVS) == 0u {
        return vec2f(0.0);
    }
    return scene_vertex_uv(scene_vertices[t.vertex0]) * (1.0 - u - v)
        + scene_vertex_uv(scene_vertices[t.vertex1]) * u
        + scene_vertex_uv(scene_vertices[t.vertex2]) * v;
}

// scene::Texture::sample: linear RGBA at `uv` ((0,0) the top-left corner, v downwards),
// bilinear or nearest, wrapped by the texture's modes. Non-finite UVs read as (0,0); an empty
// texture (or an index out of range) reads as white. Texel coordinates are clamped to i32
// (the CPU's to i64): only |uv × size| ≥ 2^31 reads differently.
fn texture_sample(texture: u32, uv: vec2f) -> vec4f {
    if texture >= scene_params.texture_count {
        return vec4f(1.0);
    }
    let info = scene_textures[texture];
    if info.width == 0u || info.height == 0u || info.texel_count == 0u {
        return vec4f(1.0);
    }
    var scaled = uv * vec2f(f32(info.width), f32(info.height));
    if !(scene_is_finite(scaled.x) && scene_is_finite(scaled.y)) {
        scaled = vec2f(0.0);
    }
    if info.nearest != 0u {
        return scene_texel(info, scene_texel_coordinate(floor(scaled.x)),
            scene_texel_coordinate(floor(scaled.y)));
    }
    // Texel (i, j) covers [i, i+1) × [j, j+1); its centre is at +0.5.
    let x = scaled.x - 0.5;
    let y = scaled.y - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let ix0 = scene_texel_coordinate(x0);
    let iy0 = scene_texel_coordinate(y0);
    let ix1 = ix0 + 1;
    let iy1 = iy0 + 1;
    let top = scene_lerp4(scene_texel(info, ix0, iy0), scene_texel(info, ix1, iy0), fx);
    let bottom = scene_lerp4(scene_texel(info, ix0, iy1), scene_texel(info, ix1, iy1), fx);
    return scene_lerp4(top, bottom, fy);
}

// ---- Traversal ----------------------------------------------------------------------------

// A ray in BVH space, as obvhs's Ray: the direction is not scaled, so t scales with positions.
struct SceneRay {
    origin: vec3f,
    direction: vec3f,
    inv_direction: vec3f,
    t_max: f32,
}

fn scene_miss() -> Hit {
    return Hit(0.0, 0.0, 0.0, SCENE_NONE);
}

// SceneAccel::bvh_ray: false for input no ray can be made of (non-finite, zero direction,
// t_max not above 0) or an empty scene.
fn scene_bvh_ray(origin: vec3f, direction: vec3f, t_max: f32, ray: ptr<function, SceneRay>) -> bool {
    let valid = scene_params.node_count != 0u && scene_is_finite3(origin)
        && scene_is_finite3(direction) && any(direction != vec3f(0.0)) && !scene_is_nan(t_max)
        && t_max > 0.0;
    if !valid {
        return false;
    }
    let inv_direction = vec3f(scene_safe_inverse(direction.x), scene_safe_inverse(direction.y),
        scene_safe_inverse(direction.z));
    *ray = SceneRay(origin * scene_params.bvh_scale, direction, inv_direction,
        t_max * scene_params.bvh_scale);
    return true;
}

// obvhs::ray::safe_inverse: 1/x, or ±1/f32::EPSILON for |x| ≤ f32::EPSILON (signum of ±0 is ±1).
fn scene_safe_inverse(x: f32) -> f32 {
    if abs(x) <= 1.1920929e-7 {
        return select(8388608.0, -8388608.0, (bitcast<u32>(x) & 0x80000000u) != 0u);
    }
    return 1.0 / x;
}

// obvhs's ray_get_octant_inv4: per byte, the direction octant with each axis bit inverted.
fn scene_octant_inv4(direction: vec3f) -> u32 {
    return select(0x04040404u, 0u, direction.x < 0.0) | select(0x02020202u, 0u, direction.y < 0.0)
        | select(0x01010101u, 0u, direction.z < 0.0);
}

// Byte `i` of eight little-endian bytes.
fn scene_byte(bytes: vec2u, i: u32) -> u32 {
    return (bytes[i >> 2u] >> ((i & 3u) * 8u)) & 0xffu;
}

// CwBvhNode::intersect_ray: the ray against the node's eight quantised child boxes. For a hit
// inner child its traversal-priority bit in bits 24..32 of the mask; for a hit leaf its
// primitives' bits in 0..24.
fn scene_intersect_node(node: SceneNode, ray: SceneRay, oct_inv4: u32) -> u32 {
    let extent = vec3f(bitcast<f32>((node.e_imask & 0xffu) << 23u),
        bitcast<f32>(((node.e_imask >> 8u) & 0xffu) << 23u),
        bitcast<f32>(((node.e_imask >> 16u) & 0xffu) << 23u));
    // The ray in the node's quantised grid.
    let scale = extent * ray.inv_direction;
    let offset = (node.p - ray.origin) * ray.inv_direction;
    let negative = ray.direction < vec3f(0.0);
    var hit_mask = 0u;
    for (var child = 0u; child < 8u; child++) {
        let low = vec3f(f32(scene_byte(node.child_min_x, child)), f32(scene_byte(node.child_min_y, child)),
            f32(scene_byte(node.child_min_z, child)));
        let high = vec3f(f32(scene_byte(node.child_max_x, child)), f32(scene_byte(node.child_max_y, child)),
            f32(scene_byte(node.child_max_z, child)));
        // A ray going down an axis enters through the max plane.
        let near = select(low, high, negative) * scale + offset;
        let far = select(high, low, negative) * scale + offset;
        let t_near = max(max(near.x, max(near.y, near.z)), SCENE_ENTRY_EPSILON);
        let t_far = min(min(far.x, min(far.y, far.z)), ray.t_max);
        if t_near <= t_far {
            // child_meta: inner children 001 then 24 + slot; leaves their primitive count in
            // unary (3 bits) then their first primitive's offset. Empty slots are 0.
            let child_meta = scene_byte(node.child_meta, child);
            let is_inner = (child_meta & (child_meta << 1u) & 0x10u) != 0u;
            let bit_index = (child_meta ^ select(0u, oct_inv4 & 0xffu, is_inner)) & 0x1fu;
            hit_mask |= ((child_meta >> 5u) & 7u) << bit_index;
        }
    }
    return hit_mask;
}

// obvhs's traverse! (Ylitie et al. 2017), with closest-hit (CwBvh::ray_traverse) or, with
// `any_hit`, stop-at-first-hit (CwBvh::ray_traverse_miss) semantics. Groups are (base index,
// bit mask): nodes in bits 24..32 of current_group, primitives of a node in primitive_group.
fn scene_traverse(initial: SceneRay, any_hit: bool) -> Hit {
    var ray = initial;
    var hit = scene_miss();
    var stack: array<vec2u, SCENE_STACK_SIZE>;
    var stack_size = 0u;
    let oct_inv4 = scene_octant_inv4(ray.direction);
    var current_group = vec2u(0u, 0x80000000u);
    var primitive_group = vec2u(0u);
    loop {
        while primitive_group.y != 0u {
            let local = firstLeadingBit(primitive_group.y);
            primitive_group.y &= ~(1u << local);
            let candidate = scene_hit_triangle(ray, primitive_group.x + local);
            if candidate.triangle != SCENE_NONE && candidate.t < ray.t_max {
                hit = candidate;
                ray.t_max = candidate.t;
                if any_hit {
                    return hit;
                }
            }
        }
        if (current_group.y & 0xff000000u) != 0u {
            let hits_imask = current_group.y;
            let child_index_offset = firstLeadingBit(hits_imask);
            current_group.y &= ~(1u << child_index_offset);
            if (current_group.y & 0xff000000u) != 0u {
                // obvhs's StackStack: a full stack overwrites its top entry.
                stack[stack_size] = current_group;
                stack_size = min(stack_size + 1u, SCENE_STACK_SIZE - 1u);
            }
            let slot_index = (child_index_offset - 24u) ^ (oct_inv4 & 0xffu);
            let relative_index = countOneBits(hits_imask & ~(0xffffffffu << slot_index));
            let node = scene_nodes[current_group.x + relative_index];
            let hitmask = scene_intersect_node(node, ray, oct_inv4);
            current_group = vec2u(node.child_base, (hitmask & 0xff000000u) | (node.e_imask >> 24u));
            primitive_group = vec2u(node.primitive_base, hitmask & 0x00ffffffu);
        } else {
            current_group = vec2u(0u);
        }
        if primitive_group.y == 0u && (current_group.y & 0xff000000u) == 0u {
            if stack_size == 0u {
                break;
            }
            stack_size -= 1u;
            current_group = stack[stack_size];
        }
    }
    return hit;
}

// SceneAccel::hit_triangle: the triangle test in (0, ray.t_max], then the alpha mask.
fn scene_hit_triangle(ray: SceneRay, index: u32) -> Hit {
    let hit = scene_intersect_triangle(index, ray.origin, ray.direction, 0.0, ray.t_max);
    if hit.triangle == SCENE_NONE || scene_is_alpha_hole(index, hit.u, hit.v) {
        return scene_miss();
    }
    return hit;
}

// TrianglePrimitive::intersect, Möller–Trumbore (1997): edges and t = t_max inclusive, so a
// ray through a shared edge hits at least one of its triangles (t in BVH space).
fn scene_intersect_triangle(index: u32, origin: vec3f, direction: vec3f, t_min: f32, t_max: f32) -> Hit {
    let triangle = scene_triangles[index];
    let p = cross(direction, triangle.edge2);
    let det = dot(triangle.edge1, p);
    // A ray in the triangle's plane (det = 0) or a degenerate triangle never hits.
    if det == 0.0 || !scene_is_finite(det) {
        return scene_miss();
    }
    let inv_det = 1.0 / det;
    let s = origin - triangle.v0;
    let u = dot(s, p) * inv_det;
    if !(u >= 0.0 && u <= 1.0) {
        return scene_miss();
    }
    let q = cross(s, triangle.edge1);
    let v = dot(direction, q) * inv_det;
    if !(v >= 0.0 && u + v <= 1.0) {
        return scene_miss();
    }
    let t = dot(triangle.edge2, q) * inv_det;
    if !(t >= t_min && t <= t_max) {
        return scene_miss();
    }
    return Hit(t, u, v, index);
}

// SceneAccel::is_alpha_hole (AlphaMasks::is_hole): the point lies where the material's
// alpha (factor × base-colour texture alpha) is below its cutoff.
fn scene_is_alpha_hole(triangle: u32, u: f32, v: f32) -> bool {
    if scene_params.any_alpha_mask == 0u {
        return false;
    }
    // Like MaterialLibrary::get: no material, or one out of range, is the default (last).
    let slot = min(scene_triangles[triangle].material, scene_params.alpha_mask_count - 1u);
    let mask = scene_alpha_masks[slot];
    if mask.masked == 0u {
        return false;
    }
    var alpha = 1.0;
    if mask.texture != SCENE_NONE {
        alpha = texture_sample(mask.texture, scene_uv_at(triangle, u, v)).w;
    }
    return mask.factor * alpha < mask.cutoff;
}

// ---- Surface helpers ------------------------------------------------------------------------

fn scene_vertex_normal(vertex: SceneVertex) -> vec3f {
    return vec3f(vertex.normal[0], vertex.normal[1], vertex.normal[2]);
}

fn scene_vertex_uv(vertex: SceneVertex) -> vec2f {
    return vec2f(vertex.uv[0], vertex.uv[1]);
}

fn scene_vertex_tangent(vertex: SceneVertex) -> vec4f {
    return vec4f(vertex.tangent[0], vertex.tangent[1], vertex.tangent[2], vertex.tangent[3]);
}

// glam's normalize_or: v / |v|, or `fallback` where 1/|v| is not finite and positive.
fn scene_normalize_or(v: vec3f, fallback: vec3f) -> vec3f {
    let rcp = 1.0 / length(v);
    if scene_is_finite(rcp) && rcp > 0.0 {
        return v * rcp;
    }
    return fallback;
}

// accel::surface::orthogonal_tangent: `direction` made orthogonal to `normal` (Gram–Schmidt)
// and unit, with bitangent sign `sign`; zero when nothing of it is left.
fn scene_orthogonal_tangent(direction: vec3f, normal: vec3f, bitangent_sign: f32) -> vec4f {
    let tangent = scene_normalize_or(direction - normal * dot(normal, direction), vec3f(0.0));
    if all(tangent == vec3f(0.0)) {
        return vec4f(0.0);
    }
    return vec4f(tangent, select(1.0, -1.0, bitangent_sign < 0.0));
}

// accel::surface::uv_tangent: tangent = dp/du, bitangent sign so that cross(normal, tangent)
// × sign points to −v ("up" in a glTF image, where a normal map's +Y points).
fn scene_uv_tangent(edge1: vec3f, edge2: vec3f, uv0: vec2f, uv1: vec2f, uv2: vec2f,
    normal: vec3f) -> vec4f {
    let duv1 = uv1 - uv0;
    let duv2 = uv2 - uv0;
    let det = duv1.x * duv2.y - duv1.y * duv2.x;
    if det == 0.0 || !scene_is_finite(det) {
        return vec4f(0.0);
    }
    // Solve edge_i = duv_i.x · dp/du + duv_i.y · dp/dv for dp/du and dp/dv.
    let dp_du = (edge1 * duv2.y - edge2 * duv1.y) / det;
    let dp_dv = (edge2 * duv1.x - edge1 * duv2.x) / det;
    let bitangent_sign = select(1.0, -1.0, dot(cross(normal, dp_du), -dp_dv) < 0.0);
    return scene_orthogonal_tangent(dp_du, normal, bitangent_sign);
}

fn scene_max_abs(v: vec3f) -> f32 {
    let a = abs(v);
    return max(a.x, max(a.y, a.z));
}

// Bit tests, not comparisons: WGSL lets compilers assume floats are finite.
fn scene_is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn scene_is_nan(x: f32) -> bool {
    let bits = bitcast<u32>(x);
    return (bits & 0x7f800000u) == 0x7f800000u && (bits & 0x007fffffu) != 0u;
}

fn scene_is_finite3(v: vec3f) -> bool {
    return scene_is_finite(v.x) && scene_is_finite(v.y) && scene_is_finite(v.z);
}

// ---- Texture helpers ------------------------------------------------------------------------

// A floor()ed texel coordinate as an integer (the CPU's `as i64`, saturating, here at i32).
fn scene_texel_coordinate(x: f32) -> i32 {
    return i32(clamp(x, -2147483648.0, 2147483520.0));
}

// WrapMode::wrap: an integer texel coordinate onto 0..size.
fn scene_wrap(coordinate: i32, size: u32, mode: u32) -> u32 {
    let n = i32(size);
    if mode == SCENE_WRAP_CLAMP_TO_EDGE {
        return u32(clamp(coordinate, 0, n - 1));
    }
    if mode == SCENE_WRAP_MIRRORED_REPEAT {
        // One period is the image followed by its mirror image.
        let period = 2 * n;
        let in_period = ((coordinate % period) + period) % period;
        return u32(select(period - 1 - in_period, in_period, in_period < n));
    }
    return u32(((coordinate % n) + n) % n);
}

// Texture::texel: the decoded texel at a wrapped coordinate (white past the stored texels).
fn scene_texel(info: SceneTexture, x: i32, y: i32) -> vec4f {
    let index = scene_wrap(y, info.height, info.wrap_t) * info.width + scene_wrap(x, info.width, info.wrap_s);
    if index >= info.texel_count {
        return vec4f(1.0);
    }
    if info.format == SCENE_TEXELS_F32 {
        let at = info.offset + 4u * index;
        return vec4f(bitcast<f32>(scene_texels[at]), bitcast<f32>(scene_texels[at + 1u]),
            bitcast<f32>(scene_texels[at + 2u]), bitcast<f32>(scene_texels[at + 3u]));
    }
    let word = scene_texels[info.offset + index];
    // sRGB-encoded colour, linear alpha; or every channel linear.
    let colour_table = select(256u, 0u, info.format == SCENE_TEXELS_SRGB8);
    return vec4f(scene_decode(colour_table + (word & 0xffu)),
        scene_decode(colour_table + ((word >> 8u) & 0xffu)),
        scene_decode(colour_table + ((word >> 16u) & 0xffu)), scene_decode(256u + (word >> 24u)));
}

fn scene_decode(entry: u32) -> f32 {
    return scene_params.decode[entry >> 2u][entry & 3u];
}

// texture.rs lerp4: a + (b − a) t per channel.
fn scene_lerp4(a: vec4f, b: vec4f, t: f32) -> vec4f {
    return a + (b - a) * t;
}
