// Test-only stand-in for scene.wgsl: the same functions shade.wgsl calls, over a small
// triangle list searched by brute force (group 3, bindings 0–2). It mirrors accel's
// Möller–Trumbore test and SceneAccel::surface for meshes without vertex normals or tangents
// (the test scenes' meshes), and scene::Texture::sample.

struct Hit {
    t: f32,
    u: f32,
    v: f32,
    triangle: u32,
}

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

// Five per triangle: v0 (w: material bits), v1, v2, (uv0, uv1), (uv2, 0, 0).
@group(3) @binding(0) var<storage, read> stand_in_triangles: array<vec4f>;
// Per texture: texel offset, width, height, wrap_s | wrap_t << 2 | nearest << 4.
@group(3) @binding(1) var<storage, read> stand_in_texture_info: array<vec4u>;
@group(3) @binding(2) var<storage, read> stand_in_texels: array<vec4f>;

const STAND_IN_MISS: u32 = 0xffffffffu;

fn stand_in_triangle_count() -> u32 {
    return arrayLength(&stand_in_triangles) / 5u;
}

fn scene_triangle_vertices(triangle: u32) -> array<vec3f, 3> {
    let base = 5u * triangle;
    return array<vec3f, 3>(
        stand_in_triangles[base].xyz,
        stand_in_triangles[base + 1u].xyz,
        stand_in_triangles[base + 2u].xyz,
    );
}

// (t, u, v, 1) on a hit with t in [0, t_max), w = 0 otherwise.
fn stand_in_hit(triangle: u32, origin: vec3f, direction: vec3f, t_max: f32) -> vec4f {
    let p = scene_triangle_vertices(triangle);
    let edge1 = p[1] - p[0];
    let edge2 = p[2] - p[0];
    let q_dir = cross(direction, edge2);
    let det = dot(edge1, q_dir);
    if det == 0.0 {
        return vec4f(0.0);
    }
    let inv_det = 1.0 / det;
    let s = origin - p[0];
    let u = dot(s, q_dir) * inv_det;
    if !(u >= 0.0 && u <= 1.0) {
        return vec4f(0.0);
    }
    let q = cross(s, edge1);
    let v = dot(direction, q) * inv_det;
    if !(v >= 0.0 && u + v <= 1.0) {
        return vec4f(0.0);
    }
    let t = dot(edge2, q) * inv_det;
    if t >= 0.0 && t < t_max {
        return vec4f(t, u, v, 1.0);
    }
    return vec4f(0.0);
}

fn scene_intersect(origin: vec3f, direction: vec3f, t_max: f32) -> Hit {
    var closest = Hit(t_max, 0.0, 0.0, STAND_IN_MISS);
    for (var i = 0u; i < stand_in_triangle_count(); i++) {
        let hit = stand_in_hit(i, origin, direction, closest.t);
        if hit.w != 0.0 {
            closest = Hit(hit.x, hit.y, hit.z, i);
        }
    }
    return closest;
}

fn scene_occluded(origin: vec3f, direction: vec3f, t_max: f32) -> bool {
    for (var i = 0u; i < stand_in_triangle_count(); i++) {
        if stand_in_hit(i, origin, direction, t_max).w != 0.0 {
            return true;
        }
    }
    return false;
}

fn scene_triangle_material(triangle: u32) -> u32 {
    return bitcast<u32>(stand_in_triangles[5u * triangle].w);
}

fn scene_uv_at(triangle: u32, u: f32, v: f32) -> vec2f {
    let uv01 = stand_in_triangles[5u * triangle + 3u];
    let uv2 = stand_in_triangles[5u * triangle + 4u].xy;
    return uv01.xy * (1.0 - u - v) + uv01.zw * u + uv2 * v;
}

fn scene_triangle_spawn_offset(triangle: u32) -> f32 {
    let p = scene_triangle_vertices(triangle);
    let magnitude = max(max(max(abs(p[0].x), abs(p[0].y)), max(abs(p[0].z), abs(p[1].x))),
        max(max(abs(p[1].y), abs(p[1].z)), max(max(abs(p[2].x), abs(p[2].y)), abs(p[2].z))));
    return magnitude / 65536.0;
}

fn scene_is_alpha_hole(triangle: u32, u: f32, v: f32) -> bool {
    return false;
}

fn stand_in_normalize_or(v: vec3f, fallback: vec3f) -> vec3f {
    let reciprocal = 1.0 / sqrt(dot(v, v));
    if (bitcast<u32>(reciprocal) & 0x7f800000u) != 0x7f800000u && reciprocal > 0.0 {
        return v * reciprocal;
    }
    return fallback;
}

fn stand_in_orthogonal_tangent(direction: vec3f, normal: vec3f, sign: f32) -> vec4f {
    let tangent = stand_in_normalize_or(direction - normal * dot(normal, direction), vec3f(0.0));
    if all(tangent == vec3f(0.0)) {
        return vec4f(0.0);
    }
    return vec4f(tangent, select(1.0, -1.0, sign < 0.0));
}

fn stand_in_uv_tangent(edge1: vec3f, edge2: vec3f, uv0: vec2f, uv1: vec2f, uv2: vec2f, normal: vec3f) -> vec4f {
    let duv1 = uv1 - uv0;
    let duv2 = uv2 - uv0;
    let det = duv1.x * duv2.y - duv1.y * duv2.x;
    if det == 0.0 {
        return vec4f(0.0);
    }
    let dp_du = (edge1 * duv2.y - edge2 * duv1.y) / det;
    let dp_dv = (edge2 * duv1.x - edge1 * duv2.x) / det;
    let sign = select(1.0, -1.0, dot(cross(normal, dp_du), -dp_dv) < 0.0);
    return stand_in_orthogonal_tangent(dp_du, normal, sign);
}

fn scene_surface(hit: Hit, direction: vec3f) -> SurfacePoint {
    let base = 5u * hit.triangle;
    let p = scene_triangle_vertices(hit.triangle);
    let uv01 = stand_in_triangles[base + 3u];
    let uv2 = stand_in_triangles[base + 4u].xy;
    let u = hit.u;
    let v = hit.v;
    let edge1 = p[1] - p[0];
    let edge2 = p[2] - p[0];
    let position = p[0] + edge1 * u + edge2 * v;
    let front_normal = stand_in_normalize_or(cross(edge1, edge2), vec3f(0.0, 0.0, 1.0));
    let back_face = dot(front_normal, direction) > 0.0;
    let side = select(1.0, -1.0, back_face);
    let uv = scene_uv_at(hit.triangle, u, v);
    let tangent = stand_in_uv_tangent(edge1, edge2, uv01.xy, uv01.zw, uv2, front_normal);
    return SurfacePoint(
        position,
        front_normal * side,
        front_normal * side,
        tangent * side,
        uv,
        scene_triangle_material(hit.triangle),
        back_face,
        scene_triangle_spawn_offset(hit.triangle),
    );
}

fn scene_offset_along_normal(position: vec3f, normal: vec3f, offset: f32, direction: vec3f) -> vec3f {
    var toward = normal;
    if dot(normal, direction) < 0.0 {
        toward = -normal;
    }
    return position + toward * offset;
}

fn scene_spawn_origin(surface: SurfacePoint, direction: vec3f) -> vec3f {
    return scene_offset_along_normal(surface.position, surface.geometric_normal, surface.spawn_offset, direction);
}

fn stand_in_wrap(coordinate: i32, size: i32, mode: u32) -> i32 {
    if mode == 2u {
        return clamp(coordinate, 0, size - 1);
    }
    if mode == 1u {
        let in_period = ((coordinate % (2 * size)) + 2 * size) % (2 * size);
        return select(2 * size - 1 - in_period, in_period, in_period < size);
    }
    return ((coordinate % size) + size) % size;
}

fn stand_in_texel(info: vec4u, x: i32, y: i32) -> vec4f {
    let column = stand_in_wrap(x, i32(info.y), info.w & 3u);
    let row = stand_in_wrap(y, i32(info.z), (info.w >> 2u) & 3u);
    return stand_in_texels[info.x + u32(row) * info.y + u32(column)];
}

fn texture_sample(texture: u32, uv: vec2f) -> vec4f {
    let info = stand_in_texture_info[texture];
    if info.y == 0u || info.z == 0u {
        return vec4f(1.0);
    }
    let scaled = uv * vec2f(f32(info.y), f32(info.z));
    if (info.w & 16u) != 0u {
        return stand_in_texel(info, i32(floor(scaled.x)), i32(floor(scaled.y)));
    }
    let x = scaled.x - 0.5;
    let y = scaled.y - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let a = stand_in_texel(info, i32(x0), i32(y0));
    let b = stand_in_texel(info, i32(x0) + 1, i32(y0));
    let c = stand_in_texel(info, i32(x0), i32(y0) + 1);
    let d = stand_in_texel(info, i32(x0) + 1, i32(y0) + 1);
    let top = a + (b - a) * fx;
    let bottom = c + (d - c) * fx;
    return top + (bottom - top) * fy;
}
