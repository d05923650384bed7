// Shading on the GPU: the CPU's path tracer (shade::integrator, Strategy::Mis) in WGSL, with
// its materials (shade::material), BSDF (shade::bsdf, ggx, frame, warp), lights
// (shade::lights), environment (shade::environment, distribution) and sampling order: a path
// given the same Rng stream draws the same numbers at the same places as on the CPU, so the two
// devices trace the same paths (f32 rounding of the transcendental functions aside).
//
// Reads the scene through scene.wgsl (group 1): scene_intersect, scene_occluded, scene_surface,
// scene_spawn_origin, scene_offset_along_normal, scene_triangle_vertices,
// scene_triangle_material, scene_uv_at, scene_triangle_spawn_offset, scene_is_alpha_hole and
// texture_sample (each the SceneAccel / Texture method of the same name). Its own data is group 2, uploaded by gpu::shading::GpuShading.

// ---- group 2: the layouts of gpu::shading (keep the two in step) ----

struct ShadeParams {
    // A uniform environment's radiance (xyz).
    uniform_radiance: vec4f,
    // seed ^ SHADE_STREAM_KEY, (lo, hi): the base of every shading stream.
    seed_lo: u32,
    seed_hi: u32,
    max_depth: u32,
    // Materials before the default one, which follows them.
    material_count: u32,
    slot_count: u32,
    emitter_count: u32,
    // 0: uniform, 1: image.
    environment_kind: u32,
    environment_width: u32,
    environment_height: u32,
    triangles_probability: f32,
    environment_probability: f32,
    // Offsets into shade_distributions (see ShadeDistribution below).
    slot_distribution: u32,
    emitter_distribution: u32,
    environment_marginal: u32,
    // Row y of the image's conditional distributions starts at environment_rows + y (2 width + 1).
    environment_rows: u32,
    _padding: u32,
}

// scene::Material's factors, with texture indices into the scene's texture table
// (0xffffffffu: none).
struct ShadeMaterial {
    base_color: vec4f,
    // xyz: emitted radiance (nits, strength applied); w: normal scale.
    emissive: vec4f,
    metallic: f32,
    roughness: f32,
    base_color_texture: u32,
    metallic_roughness_texture: u32,
    normal_texture: u32,
    emissive_texture: u32,
    double_sided: u32,
    _padding: u32,
}

const SHADE_SLOT_POINT: u32 = 0u;
const SHADE_SLOT_SPOT: u32 = 1u;
const SHADE_SLOT_DIRECTIONAL: u32 = 2u;
const SHADE_SLOT_TRIANGLES: u32 = 3u;
const SHADE_SLOT_ENVIRONMENT: u32 = 4u;

// One slot of light selection; a punctual light's slot carries the light.
struct ShadeLightSlot {
    position: vec4f,
    // A spot's axis or the direction a directional light travels.
    direction: vec4f,
    // Intensity (cd) or, for a directional light, illuminance (lux).
    intensity: vec4f,
    kind: u32,
    // 0: no range.
    range: f32,
    cos_inner: f32,
    cos_outer: f32,
}

// An emissive triangle (in increasing triangle order, so it can be found by bisection).
struct ShadeEmitter {
    triangle: u32,
    area: f32,
}

@group(2) @binding(0) var<uniform> shade_params: ShadeParams;
@group(2) @binding(1) var<storage, read> shade_materials: array<ShadeMaterial>;
@group(2) @binding(2) var<storage, read> shade_light_slots: array<ShadeLightSlot>;
@group(2) @binding(3) var<storage, read> shade_emitters: array<ShadeEmitter>;
// Distribution1Ds: `count` probabilities, then the count + 1 entries of their cdf.
@group(2) @binding(4) var<storage, read> shade_distributions: array<f32>;
// The environment image, row-major, top row first.
@group(2) @binding(5) var<storage, read> shade_environment_texels: array<vec4f>;

const SHADE_PI: f32 = 3.14159265358979323846;
const SHADE_TAU: f32 = 6.28318530717958647692;
const SHADE_FRAC_1_PI: f32 = 0.318309886183790671538;
// Stands for f32::INFINITY as a ray's extent (WGSL has no infinity literal).
const SHADE_FAR: f32 = 3.40282347e38;
const SHADE_NONE: u32 = 0xffffffffu;
const SHADE_DIELECTRIC_F0: f32 = 0.04;
const SHADE_RUSSIAN_ROULETTE_START: u32 = 3u;
const SHADE_MAX_SURVIVAL: f32 = 0.95;
const SHADE_UNIFORM_SPHERE_PDF: f32 = 0.0795774715459476678844;
const SHADE_GGX_MIN_ALPHA: f32 = 1e-3;

// The stream a pass's shading draws from for sample `sample` of pixel `pixel`
// (Rng::for_sample(seed ^ SHADE_STREAM_KEY, pixel, sample), as Shader::shade_batch).
fn shade_rng(pixel: u32, sample: u32) -> Rng {
    return rng_for_sample(shade_params.seed_lo, shade_params.seed_hi, pixel, sample);
}

// ---- f32 helpers with the CPU's semantics ----
// WGSL implementations may assume floats are finite, so infinities and NaNs are told by their
// bits, never by comparisons.

fn shade_is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn shade_is_finite3(v: vec3f) -> bool {
    return shade_is_finite(v.x) && shade_is_finite(v.y) && shade_is_finite(v.z);
}

// x > 0 and finite-or-infinite but not NaN: the CPU's `x > 0.0` with NaN false.
fn shade_positive(x: f32) -> bool {
    return !shade_is_nan(x) && x > 0.0;
}

fn shade_is_nan(x: f32) -> bool {
    let bits = bitcast<u32>(x);
    return (bits & 0x7f800000u) == 0x7f800000u && (bits & 0x007fffffu) != 0u;
}

fn shade_is_zero3(v: vec3f) -> bool {
    return v.x == 0.0 && v.y == 0.0 && v.z == 0.0;
}

fn shade_max_element(v: vec3f) -> f32 {
    return max(max(v.x, v.y), v.z);
}

fn shade_dot(a: vec3f, b: vec3f) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// glam's normalize_or: × 1/length, `fallback` when that is not finite and positive.
fn shade_normalize_or(v: vec3f, fallback: vec3f) -> vec3f {
    let reciprocal = 1.0 / sqrt(shade_dot(v, v));
    if shade_is_finite(reciprocal) && reciprocal > 0.0 {
        return v * reciprocal;
    }
    return fallback;
}

fn shade_normalize_or_zero(v: vec3f) -> vec3f {
    return shade_normalize_or(v, vec3f(0.0));
}

fn shade_pow5(x: f32) -> f32 {
    let x2 = x * x;
    return x2 * x2 * x;
}

// Rec. 709 luminance (bsdf::luminance).
fn shade_luminance(rgb: vec3f) -> f32 {
    return shade_dot(rgb, vec3f(0.2126, 0.7152, 0.0722));
}

// ---- warps (shade::warp) ----

fn shade_concentric_disk(u: vec2f) -> vec2f {
    let offset = vec2f(2.0 * u.x - 1.0, 2.0 * u.y - 1.0);
    if offset.x == 0.0 && offset.y == 0.0 {
        return vec2f(0.0);
    }
    var radius: f32;
    var theta: f32;
    if abs(offset.x) > abs(offset.y) {
        radius = offset.x;
        theta = SHADE_PI / 4.0 * (offset.y / offset.x);
    } else {
        radius = offset.y;
        theta = SHADE_PI / 2.0 - SHADE_PI / 4.0 * (offset.x / offset.y);
    }
    return vec2f(cos(theta), sin(theta)) * radius;
}

fn shade_cosine_hemisphere(u: vec2f) -> vec3f {
    let d = shade_concentric_disk(u);
    let z = sqrt(max(1.0 - (d.x * d.x + d.y * d.y), 0.0));
    return vec3f(d.x, d.y, z);
}

fn shade_cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    return max(cos_theta, 0.0) * SHADE_FRAC_1_PI;
}

fn shade_uniform_sphere(u: vec2f) -> vec3f {
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt(max(1.0 - z * z, 0.0));
    let phi = SHADE_TAU * u.y;
    return vec3f(r * cos(phi), r * sin(phi), z);
}

// Barycentric weights (u, v) of vertices 1 and 2 of a uniform point on a triangle.
fn shade_uniform_triangle(u: vec2f) -> vec2f {
    let s = sqrt(u.x);
    return vec2f(s * (1.0 - u.y), s * u.y);
}

// ---- shading frames (shade::frame) ----

struct ShadeFrame {
    tangent: vec3f,
    bitangent: vec3f,
    normal: vec3f,
}

// glam's any_orthonormal_pair (Duff et al. 2017); the sign of z by its sign bit, as f32::signum
// takes it (−0 is negative).
fn shade_frame_from_normal(normal: vec3f) -> ShadeFrame {
    let sign = select(1.0, -1.0, (bitcast<u32>(normal.z) & 0x80000000u) != 0u);
    let a = -1.0 / (sign + normal.z);
    let b = normal.x * normal.y * a;
    let tangent = vec3f(1.0 + sign * normal.x * normal.x * a, sign * b, -sign * normal.x);
    let bitangent = vec3f(b, sign + normal.y * normal.y * a, -normal.y);
    return ShadeFrame(tangent, bitangent, normal);
}

fn shade_to_local(frame: ShadeFrame, world: vec3f) -> vec3f {
    return vec3f(
        shade_dot(world, frame.tangent),
        shade_dot(world, frame.bitangent),
        shade_dot(world, frame.normal),
    );
}

fn shade_to_world(frame: ShadeFrame, local: vec3f) -> vec3f {
    return frame.tangent * local.x + frame.bitangent * local.y + frame.normal * local.z;
}

// ---- GGX (shade::ggx) ----

fn shade_ggx_alpha(roughness: f32) -> f32 {
    var r = 1.0;
    if shade_is_finite(roughness) {
        r = clamp(roughness, 0.0, 1.0);
    }
    return max(r * r, SHADE_GGX_MIN_ALPHA);
}

fn shade_ggx_distribution(alpha: f32, h: vec3f) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let denominator = h.z * h.z * (a2 - 1.0) + 1.0;
    return a2 / (SHADE_PI * denominator * denominator);
}

// G1 = 1 / (1 + Λ); 0 where Λ is infinite (grazing).
fn shade_ggx_masking(alpha: f32, w: vec3f) -> f32 {
    let cos2 = w.z * w.z;
    if cos2 <= 0.0 {
        return 0.0;
    }
    let tan2 = max((1.0 - cos2) / cos2, 0.0);
    let lambda = 0.5 * (sqrt(1.0 + alpha * alpha * tan2) - 1.0);
    return 1.0 / (1.0 + lambda);
}

fn shade_ggx_visibility(alpha: f32, wo: vec3f, wi: vec3f) -> f32 {
    let cos_o = wo.z;
    let cos_i = wi.z;
    if cos_o <= 0.0 || cos_i <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let term_o = sqrt(cos_o * cos_o * (1.0 - a2) + a2);
    let term_i = sqrt(cos_i * cos_i * (1.0 - a2) + a2);
    return 0.5 / (cos_i * term_o + cos_o * term_i);
}

// Heitz 2018, visible normals.
fn shade_ggx_sample_visible_normal(alpha: f32, wo: vec3f, u: vec2f) -> vec3f {
    let stretched = vec3f(alpha * wo.x, alpha * wo.y, wo.z);
    let vh = stretched * (1.0 / sqrt(shade_dot(stretched, stretched)));
    let length2 = vh.x * vh.x + vh.y * vh.y;
    var t1 = vec3f(1.0, 0.0, 0.0);
    if length2 > 0.0 {
        t1 = vec3f(-vh.y, vh.x, 0.0) / sqrt(length2);
    }
    let t2 = cross(vh, t1);
    let r = sqrt(u.x);
    let phi = SHADE_TAU * u.y;
    let p1 = r * cos(phi);
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * r * sin(phi);
    let nh = t1 * p1 + t2 * p2 + vh * sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0));
    return shade_normalize_or(vec3f(alpha * nh.x, alpha * nh.y, max(nh.z, 0.0)), vec3f(0.0, 0.0, 1.0));
}

fn shade_ggx_reflection_pdf_at(alpha: f32, wo: vec3f, h: vec3f, distribution: f32) -> f32 {
    if wo.z <= 0.0 || shade_dot(wo, h) <= 0.0 {
        return 0.0;
    }
    return shade_ggx_masking(alpha, wo) * distribution / (4.0 * wo.z);
}

fn shade_reflect(w: vec3f, h: vec3f) -> vec3f {
    return h * (2.0 * shade_dot(w, h)) - w;
}

// ---- the glTF metallic-roughness BRDF (shade::bsdf) ----

struct ShadeBsdf {
    diffuse: vec3f,
    f0: vec3f,
    alpha: f32,
}

struct ShadeBsdfSample {
    wi: vec3f,
    value: vec3f,
    // 0: no sample (the path ends).
    pdf: f32,
}

fn shade_schlick(f0: vec3f, cos_theta: f32) -> vec3f {
    let m = shade_pow5(1.0 - clamp(cos_theta, 0.0, 1.0));
    return f0 + (vec3f(1.0) - f0) * m;
}

fn shade_schlick_scalar(f0: f32, cos_theta: f32) -> f32 {
    return f0 + (1.0 - f0) * shade_pow5(1.0 - clamp(cos_theta, 0.0, 1.0));
}

fn shade_bsdf_new(base_color_in: vec3f, metallic_in: f32, roughness: f32) -> ShadeBsdf {
    var base_color = vec3f(1.0);
    if shade_is_finite3(base_color_in) {
        base_color = clamp(base_color_in, vec3f(0.0), vec3f(1.0));
    }
    var metallic = 1.0;
    if shade_is_finite(metallic_in) {
        metallic = clamp(metallic_in, 0.0, 1.0);
    }
    // glam's lerp: a (1 − t) + b t.
    let f0 = vec3f(SHADE_DIELECTRIC_F0) * (1.0 - metallic) + base_color * metallic;
    return ShadeBsdf(base_color * (1.0 - metallic), f0, shade_ggx_alpha(roughness));
}

fn shade_bsdf_specular_probability(bsdf: ShadeBsdf, wo: vec3f) -> f32 {
    let specular = shade_luminance(shade_schlick(bsdf.f0, wo.z));
    let diffuse = shade_luminance(bsdf.diffuse) * (1.0 - shade_schlick_scalar(SHADE_DIELECTRIC_F0, wo.z));
    if diffuse <= 0.0 {
        return 1.0;
    }
    return clamp(specular / (specular + diffuse), 0.1, 0.9);
}

// (f, pdf) for both directions above the surface; f in xyz, pdf in w.
fn shade_bsdf_eval_and_pdf_above(bsdf: ShadeBsdf, wo: vec3f, wi: vec3f, p_specular: f32) -> vec4f {
    let h = shade_normalize_or_zero(wo + wi);
    if shade_is_zero3(h) {
        return vec4f(0.0);
    }
    let cos_oh = shade_dot(wo, h);
    let distribution = shade_ggx_distribution(bsdf.alpha, h);
    let diffuse = bsdf.diffuse * ((1.0 - shade_schlick_scalar(SHADE_DIELECTRIC_F0, cos_oh)) * SHADE_FRAC_1_PI);
    let specular = shade_schlick(bsdf.f0, cos_oh) * (distribution * shade_ggx_visibility(bsdf.alpha, wo, wi));
    let pdf = p_specular * shade_ggx_reflection_pdf_at(bsdf.alpha, wo, h, distribution)
        + (1.0 - p_specular) * shade_cosine_hemisphere_pdf(wi.z);
    return vec4f(diffuse + specular, pdf);
}

// MetalRoughBsdf::eval_and_pdf: f in xyz, pdf in w.
fn shade_bsdf_eval_and_pdf(bsdf: ShadeBsdf, wo: vec3f, wi: vec3f) -> vec4f {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return vec4f(0.0);
    }
    return shade_bsdf_eval_and_pdf_above(bsdf, wo, wi, shade_bsdf_specular_probability(bsdf, wo));
}

fn shade_bsdf_sample(bsdf: ShadeBsdf, wo: vec3f, u_lobe: f32, u: vec2f) -> ShadeBsdfSample {
    let nothing = ShadeBsdfSample(vec3f(0.0), vec3f(0.0), 0.0);
    if wo.z <= 0.0 {
        return nothing;
    }
    let p_specular = shade_bsdf_specular_probability(bsdf, wo);
    var wi: vec3f;
    if u_lobe < p_specular {
        wi = shade_reflect(wo, shade_ggx_sample_visible_normal(bsdf.alpha, wo, u));
    } else {
        wi = shade_cosine_hemisphere(u);
    }
    if wi.z <= 0.0 {
        return nothing;
    }
    let evaluated = shade_bsdf_eval_and_pdf_above(bsdf, wo, wi, p_specular);
    if !(shade_positive(evaluated.w) && shade_is_finite(evaluated.w)) {
        return nothing;
    }
    return ShadeBsdfSample(wi, evaluated.xyz, evaluated.w);
}

// ---- materials (shade::material) ----

fn shade_material(index: u32) -> ShadeMaterial {
    // MaterialLibrary::get: none (0xffffffffu) or out of range is the default, stored last.
    return shade_materials[min(index, shade_params.material_count)];
}

fn shade_texture_value(texture: u32, uv: vec2f) -> vec4f {
    if texture == SHADE_NONE {
        return vec4f(1.0);
    }
    return texture_sample(texture, uv);
}

fn shade_is_emissive(material: ShadeMaterial) -> bool {
    return shade_max_element(material.emissive.xyz) > 0.0;
}

fn shade_emitted_radiance(material: ShadeMaterial, uv: vec2f) -> vec3f {
    if !shade_is_emissive(material) {
        return vec3f(0.0);
    }
    let radiance = material.emissive.xyz * shade_texture_value(material.emissive_texture, uv).xyz;
    if shade_is_finite3(radiance) {
        return max(radiance, vec3f(0.0));
    }
    return vec3f(0.0);
}

fn shade_emits_towards(material: ShadeMaterial, back_face: bool) -> bool {
    return !back_face || material.double_sided != 0u;
}

struct ShadePoint {
    frame: ShadeFrame,
    bsdf: ShadeBsdf,
    emission: vec3f,
}

fn shade_normal_mapped(material: ShadeMaterial, surface: SurfacePoint) -> vec3f {
    let n = surface.shading_normal;
    if material.normal_texture == SHADE_NONE {
        return n;
    }
    let tangent = surface.tangent;
    if tangent.x == 0.0 && tangent.y == 0.0 && tangent.z == 0.0 && tangent.w == 0.0 {
        return n;
    }
    let t = tangent.xyz;
    let b = cross(n, t) * tangent.w;
    // Texels store (x, y, z) × 0.5 + 0.5; normalScale scales x and y (glTF 2.0 §3.9.3).
    let texel = texture_sample(material.normal_texture, surface.uv).xyz * 2.0 - vec3f(1.0);
    let scale = material.emissive.w;
    let local = vec3f(texel.x * scale, texel.y * scale, texel.z);
    let mapped = shade_normalize_or_zero(t * local.x + b * local.y + n * local.z);
    if shade_is_zero3(mapped) || !shade_is_finite3(mapped) {
        return n;
    }
    return mapped;
}

// material::shading_point.
fn shade_shading_point(material: ShadeMaterial, surface: SurfacePoint, wo: vec3f) -> ShadePoint {
    let uv = surface.uv;
    let base_color = material.base_color.xyz * shade_texture_value(material.base_color_texture, uv).xyz;
    // glTF packs roughness in green and metalness in blue.
    let metal_rough = shade_texture_value(material.metallic_roughness_texture, uv);
    let bsdf = shade_bsdf_new(base_color, material.metallic * metal_rough.z, material.roughness * metal_rough.y);

    // A shading normal the viewer is behind falls back towards the geometric normal.
    let mapped = shade_normal_mapped(material, surface);
    var normal = surface.geometric_normal;
    if shade_dot(mapped, wo) > 0.0 {
        normal = mapped;
    } else if shade_dot(surface.shading_normal, wo) > 0.0 {
        normal = surface.shading_normal;
    }

    var emission = vec3f(0.0);
    if shade_emits_towards(material, surface.back_face) {
        emission = shade_emitted_radiance(material, uv);
    }
    return ShadePoint(shade_frame_from_normal(normal), bsdf, emission);
}

// ---- piecewise-constant distributions (shade::distribution) ----

struct ShadeDistribution {
    offset: u32,
    count: u32,
}

fn shade_probability(d: ShadeDistribution, index: u32) -> f32 {
    if index >= d.count {
        return 0.0;
    }
    return shade_distributions[d.offset + index];
}

fn shade_cdf(d: ShadeDistribution, index: u32) -> f32 {
    return shade_distributions[d.offset + d.count + index];
}

// Distribution1D::is_empty: a non-empty cdf ends at exactly 1.
fn shade_distribution_is_empty(d: ShadeDistribution) -> bool {
    return !(shade_cdf(d, d.count) == 1.0);
}

struct ShadeDiscreteSample {
    // SHADE_NONE: empty distribution.
    index: u32,
    within: f32,
}

// Distribution1D::sample.
fn shade_distribution_sample(d: ShadeDistribution, u: f32) -> ShadeDiscreteSample {
    if shade_distribution_is_empty(d) {
        return ShadeDiscreteSample(SHADE_NONE, 0.0);
    }
    // partition_point(|c| c <= u) over the count + 1 cdf entries.
    var low = 0u;
    var high = d.count + 1u;
    while low < high {
        let middle = low + (high - low) / 2u;
        if shade_cdf(d, middle) <= u {
            low = middle + 1u;
        } else {
            high = middle;
        }
    }
    let index = min(max(low, 1u) - 1u, d.count - 1u);
    let c_low = shade_cdf(d, index);
    let c_high = shade_cdf(d, index + 1u);
    var within = 0.0;
    if c_high > c_low {
        // 1 − f32::EPSILON / 2: the largest f32 below 1.
        within = clamp((u - c_low) / (c_high - c_low), 0.0, 0.99999994);
    }
    return ShadeDiscreteSample(index, within);
}

struct ShadeContinuousSample {
    x: f32,
    density: f32,
    // SHADE_NONE: empty distribution.
    cell: u32,
}

fn shade_distribution_sample_continuous(d: ShadeDistribution, u: f32) -> ShadeContinuousSample {
    let drawn = shade_distribution_sample(d, u);
    if drawn.index == SHADE_NONE {
        return ShadeContinuousSample(0.0, 0.0, SHADE_NONE);
    }
    let n = f32(d.count);
    return ShadeContinuousSample(
        (f32(drawn.index) + drawn.within) / n,
        shade_probability(d, drawn.index) * n,
        drawn.index,
    );
}

fn shade_distribution_density_continuous(d: ShadeDistribution, x: f32) -> f32 {
    if d.count == 0u {
        return 0.0;
    }
    // `as usize` saturates: negatives and NaN to 0.
    var scaled = x * f32(d.count);
    if shade_is_nan(scaled) {
        scaled = 0.0;
    }
    let cell = min(u32(clamp(scaled, 0.0, 4294967040.0)), d.count - 1u);
    return shade_distribution_probability_density(d, cell);
}

fn shade_distribution_probability_density(d: ShadeDistribution, cell: u32) -> f32 {
    return shade_probability(d, cell) * f32(d.count);
}

// ---- the environment (shade::environment) ----

fn shade_environment_marginal() -> ShadeDistribution {
    return ShadeDistribution(shade_params.environment_marginal, shade_params.environment_height);
}

fn shade_environment_row(row: u32) -> ShadeDistribution {
    let width = shade_params.environment_width;
    return ShadeDistribution(shade_params.environment_rows + row * (2u * width + 1u), width);
}

// Direction → image coordinates (environment::direction_to_image).
fn shade_direction_to_image(direction: vec3f) -> vec2f {
    let d = shade_normalize_or(direction, vec3f(0.0, 0.0, -1.0));
    let u = atan2(d.x, -d.z) / SHADE_TAU + 0.5;
    let v = atan2(sqrt(d.x * d.x + d.z * d.z), d.y) / SHADE_PI;
    return vec2f(u, v);
}

fn shade_image_to_direction(uv: vec2f) -> vec3f {
    let phi = SHADE_TAU * (uv.x - 0.5);
    let theta = SHADE_PI * uv.y;
    let sin_theta = sin(theta);
    let cos_theta = cos(theta);
    return vec3f(sin_theta * sin(phi), cos_theta, -sin_theta * cos(phi));
}

fn shade_environment_texel(x: i32, y: i32) -> vec4f {
    let width = i32(shade_params.environment_width);
    let height = i32(shade_params.environment_height);
    // Wraps around in u (repeat), clamps at the poles.
    let column = ((x % width) + width) % width;
    let row = clamp(y, 0, height - 1);
    return shade_environment_texels[u32(row * width + column)];
}

// The image's bilinear lookup (scene::Texture::sample with repeat × clamp-to-edge).
fn shade_environment_lookup(uv: vec2f) -> vec3f {
    var scaled = uv * vec2f(f32(shade_params.environment_width), f32(shade_params.environment_height));
    if !(shade_is_finite(scaled.x) && shade_is_finite(scaled.y)) {
        scaled = vec2f(0.0);
    }
    let x = scaled.x - 0.5;
    let y = scaled.y - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let ix = i32(x0);
    let iy = i32(y0);
    let a = shade_environment_texel(ix, iy);
    let b = shade_environment_texel(ix + 1, iy);
    let c = shade_environment_texel(ix, iy + 1);
    let d = shade_environment_texel(ix + 1, iy + 1);
    let top = a + (b - a) * fx;
    let bottom = c + (d - c) * fx;
    return (top + (bottom - top) * fy).xyz;
}

// Environment::radiance: seen looking towards `direction`.
fn shade_environment_radiance(direction: vec3f) -> vec3f {
    if shade_params.environment_kind == 0u {
        return shade_params.uniform_radiance.xyz;
    }
    return shade_environment_lookup(shade_direction_to_image(direction));
}

struct ShadeEnvironmentSample {
    direction: vec3f,
    radiance: vec3f,
    // 0: none.
    pdf: f32,
}

// Environment::sample.
fn shade_environment_sample(u: vec2f) -> ShadeEnvironmentSample {
    let nothing = ShadeEnvironmentSample(vec3f(0.0), vec3f(0.0), 0.0);
    if shade_params.environment_kind == 0u {
        let radiance = shade_params.uniform_radiance.xyz;
        if !(shade_luminance(radiance) > 0.0) {
            return nothing;
        }
        return ShadeEnvironmentSample(shade_uniform_sphere(u), radiance, SHADE_UNIFORM_SPHERE_PDF);
    }
    // Distribution2D::sample: a row by the marginal, then a column in it.
    let vertical = shade_distribution_sample_continuous(shade_environment_marginal(), u.y);
    if vertical.cell == SHADE_NONE {
        return nothing;
    }
    let horizontal = shade_distribution_sample_continuous(shade_environment_row(vertical.cell), u.x);
    if horizontal.cell == SHADE_NONE {
        return nothing;
    }
    let density_uv = horizontal.density * vertical.density;
    let sin_theta = sin(SHADE_PI * vertical.x);
    if !shade_positive(sin_theta) {
        return nothing;
    }
    let direction = shade_image_to_direction(vec2f(horizontal.x, vertical.x));
    // dω = 2π² sin θ du dv.
    let pdf = density_uv / (2.0 * SHADE_PI * SHADE_PI * sin_theta);
    if !(shade_positive(pdf) && shade_is_finite(pdf)) {
        return nothing;
    }
    return ShadeEnvironmentSample(direction, shade_environment_radiance(direction), pdf);
}

// Environment::pdf.
fn shade_environment_pdf(direction: vec3f) -> f32 {
    if shade_params.environment_kind == 0u {
        if shade_luminance(shade_params.uniform_radiance.xyz) > 0.0 {
            return SHADE_UNIFORM_SPHERE_PDF;
        }
        return 0.0;
    }
    let uv = shade_direction_to_image(direction);
    let d = shade_normalize_or_zero(direction);
    let sin_theta = sqrt(d.x * d.x + d.z * d.z);
    if !shade_positive(sin_theta) {
        return 0.0;
    }
    // Distribution2D::density.
    let marginal = shade_environment_marginal();
    let height = shade_params.environment_height;
    var density = 0.0;
    if height != 0u && !shade_distribution_is_empty(marginal) {
        var scaled = uv.y * f32(height);
        if shade_is_nan(scaled) {
            scaled = 0.0;
        }
        let row = min(u32(clamp(scaled, 0.0, 4294967040.0)), height - 1u);
        density = shade_distribution_density_continuous(marginal, uv.y)
            * shade_distribution_density_continuous(shade_environment_row(row), uv.x);
    }
    let pdf = density / (2.0 * SHADE_PI * SHADE_PI * sin_theta);
    if shade_is_finite(pdf) {
        return pdf;
    }
    return 0.0;
}

// ---- lights (shade::lights) ----

const SHADE_TARGET_POINT: u32 = 0u;
const SHADE_TARGET_SURFACE: u32 = 1u;
const SHADE_TARGET_INFINITE: u32 = 2u;

struct ShadeLightSample {
    direction: vec3f,
    // Radiance (nits), or illuminance (lux) for delta lights.
    radiance: vec3f,
    // 0: no sample.
    pdf: f32,
    is_delta: bool,
    // ShadowTarget: its kind, the point (or surface point), the surface's normal and offset.
    target_kind: u32,
    target_position: vec3f,
    target_normal: vec3f,
    target_offset: f32,
}

fn shade_no_light() -> ShadeLightSample {
    return ShadeLightSample(vec3f(0.0), vec3f(0.0), 0.0, false, SHADE_TARGET_INFINITE, vec3f(0.0), vec3f(0.0), 0.0);
}

fn shade_slot_distribution() -> ShadeDistribution {
    return ShadeDistribution(shade_params.slot_distribution, shade_params.slot_count);
}

fn shade_emitter_distribution() -> ShadeDistribution {
    return ShadeDistribution(shade_params.emitter_distribution, shade_params.emitter_count);
}

// Unit direction and distance from `from` to `to`; w = 0 when they coincide.
fn shade_direction_and_distance(start: vec3f, end: vec3f) -> vec4f {
    let offset = end - start;
    let distance = sqrt(shade_dot(offset, offset));
    if shade_positive(distance) && shade_is_finite(distance) {
        return vec4f(offset / distance, distance);
    }
    return vec4f(0.0);
}

fn shade_range_window(distance: f32, range: f32) -> f32 {
    if !(range > 0.0) {
        return 1.0;
    }
    let ratio = distance / range;
    let ratio2 = ratio * ratio;
    return clamp(1.0 - ratio2 * ratio2, 0.0, 1.0);
}

fn shade_sample_punctual(light: ShadeLightSlot, position: vec3f, selection: f32) -> ShadeLightSample {
    var direction: vec3f;
    var illuminance: vec3f;
    var shadow_target = SHADE_TARGET_POINT;
    if light.kind == SHADE_SLOT_DIRECTIONAL {
        direction = -shade_normalize_or_zero(light.direction.xyz);
        illuminance = light.intensity.xyz;
        shadow_target = SHADE_TARGET_INFINITE;
    } else {
        let towards = shade_direction_and_distance(position, light.position.xyz);
        if towards.w == 0.0 {
            return shade_no_light();
        }
        direction = towards.xyz;
        let distance = towards.w;
        var intensity = light.intensity.xyz;
        if light.kind == SHADE_SLOT_SPOT {
            let cos_angle = shade_dot(shade_normalize_or_zero(light.direction.xyz), -direction);
            let scale = 1.0 / max(light.cos_inner - light.cos_outer, 1e-3);
            let attenuation = clamp((cos_angle - light.cos_outer) * scale, 0.0, 1.0);
            intensity = intensity * (attenuation * attenuation);
        }
        illuminance = intensity * shade_range_window(distance, light.range) / (distance * distance);
    }
    if shade_is_zero3(direction) || !shade_is_finite3(illuminance) || !(shade_max_element(illuminance) > 0.0) {
        return shade_no_light();
    }
    return ShadeLightSample(direction, illuminance, selection, true, shadow_target, light.position.xyz, vec3f(0.0), 0.0);
}

fn shade_sample_triangle(position: vec3f, rng: ptr<function, Rng>) -> ShadeLightSample {
    let drawn = shade_distribution_sample(shade_emitter_distribution(), rng_next_f32(rng));
    if drawn.index == SHADE_NONE {
        return shade_no_light();
    }
    let emitter = shade_emitters[drawn.index];
    let barycentric = shade_uniform_triangle(rng_next_2d(rng));
    let u = barycentric.x;
    let v = barycentric.y;
    if scene_is_alpha_hole(emitter.triangle, u, v) {
        return shade_no_light();
    }
    let vertices = scene_triangle_vertices(emitter.triangle);
    let p0 = vertices[0];
    let p1 = vertices[1];
    let p2 = vertices[2];
    let light_point = p0 * (1.0 - u - v) + p1 * u + p2 * v;
    let normal = shade_normalize_or_zero(cross(p1 - p0, p2 - p0));
    let to_light = light_point - position;
    let distance2 = shade_dot(to_light, to_light);
    let direction = shade_normalize_or_zero(to_light);
    let cos_light = -shade_dot(normal, direction);
    let material = shade_material(scene_triangle_material(emitter.triangle));
    if shade_is_zero3(direction) || !shade_emits_towards(material, cos_light < 0.0) {
        return shade_no_light();
    }
    let radiance = shade_emitted_radiance(material, scene_uv_at(emitter.triangle, u, v));
    let pdf = shade_params.triangles_probability * shade_probability(shade_emitter_distribution(), drawn.index)
        * distance2 / (emitter.area * abs(cos_light));
    if !(shade_positive(pdf) && shade_is_finite(pdf)) {
        return shade_no_light();
    }
    return ShadeLightSample(direction, radiance, pdf, false, SHADE_TARGET_SURFACE, light_point, normal,
        scene_triangle_spawn_offset(emitter.triangle));
}

// LightSet::sample: a light sample seen from `position` (pdf 0: none).
fn shade_sample_light(position: vec3f, rng: ptr<function, Rng>) -> ShadeLightSample {
    let slots = shade_slot_distribution();
    let drawn = shade_distribution_sample(slots, rng_next_f32(rng));
    if drawn.index == SHADE_NONE {
        return shade_no_light();
    }
    let slot_probability = shade_probability(slots, drawn.index);
    let slot = shade_light_slots[drawn.index];
    if slot.kind == SHADE_SLOT_TRIANGLES {
        return shade_sample_triangle(position, rng);
    }
    if slot.kind == SHADE_SLOT_ENVIRONMENT {
        let drawn = shade_environment_sample(rng_next_2d(rng));
        if drawn.pdf == 0.0 {
            return shade_no_light();
        }
        return ShadeLightSample(drawn.direction, drawn.radiance, drawn.pdf * slot_probability, false, SHADE_TARGET_INFINITE, vec3f(0.0), vec3f(0.0), 0.0);
    }
    return shade_sample_punctual(slot, position, slot_probability);
}

// LightSet::triangle_pdf.
fn shade_triangle_pdf(triangle: u32, distance: f32, cos_light_in: f32) -> f32 {
    // Emitters are in increasing triangle order: bisect for this one.
    var low = 0u;
    var high = shade_params.emitter_count;
    while low < high {
        let middle = low + (high - low) / 2u;
        if shade_emitters[middle].triangle < triangle {
            low = middle + 1u;
        } else {
            high = middle;
        }
    }
    if low >= shade_params.emitter_count || shade_emitters[low].triangle != triangle {
        return 0.0;
    }
    let cos_light = abs(cos_light_in);
    if !shade_positive(cos_light) {
        return 0.0;
    }
    let pdf = shade_params.triangles_probability * shade_probability(shade_emitter_distribution(), low)
        * distance * distance / (shade_emitters[low].area * cos_light);
    if shade_is_finite(pdf) {
        return pdf;
    }
    return 0.0;
}

// LightSet::environment_pdf.
fn shade_light_environment_pdf(direction: vec3f) -> f32 {
    if shade_params.environment_probability > 0.0 {
        return shade_params.environment_probability * shade_environment_pdf(direction);
    }
    return 0.0;
}

// ---- the path tracer (shade::integrator, Strategy::Mis) ----

fn shade_power_heuristic(chosen: f32, other: f32) -> f32 {
    if !shade_positive(chosen) {
        return 0.0;
    }
    if !shade_positive(other) {
        return 1.0;
    }
    let ratio = other / chosen;
    let weight = 1.0 / (1.0 + ratio * ratio);
    if shade_is_finite(weight) {
        return weight;
    }
    return 0.0;
}

struct ShadePath {
    direction: vec3f,
    radiance: vec3f,
    throughput: vec3f,
    // The density that drew `direction`; negative for the camera ray.
    bsdf_pdf: f32,
    bounces: u32,
}

// What one invocation's path met, as ShadeStats counts it (a private variable: each invocation
// has its own; the pass kernel sums them per workgroup). Indices are the SHADE_COUNT_ constants.
var<private> shade_counts: array<u32, 8>;
const SHADE_COUNT_CAMERA_ESCAPED: u32 = 0u;
const SHADE_COUNT_BOUNCE_ESCAPED: u32 = 1u;
const SHADE_COUNT_EMITTER_HITS: u32 = 2u;
const SHADE_COUNT_LIGHT_SAMPLES: u32 = 3u;
const SHADE_COUNT_BEHIND: u32 = 4u;
const SHADE_COUNT_BLOCKED: u32 = 5u;
const SHADE_COUNT_REACHED: u32 = 6u;
const SHADE_COUNT_RAYS_TRACED: u32 = 7u;

// Shader::direct_light: one light sample, MIS-weighted against BSDF sampling.
fn shade_direct_light(surface: SurfacePoint, shading: ShadePoint, wo: vec3f, rng: ptr<function, Rng>) -> vec3f {
    let light = shade_sample_light(surface.position, rng);
    if light.pdf == 0.0 {
        return vec3f(0.0);
    }
    shade_counts[SHADE_COUNT_LIGHT_SAMPLES] += 1u;
    let wi = light.direction;
    if shade_dot(wi, surface.geometric_normal) <= 0.0 {
        shade_counts[SHADE_COUNT_BEHIND] += 1u;
        return vec3f(0.0);
    }
    let wo_local = shade_to_local(shading.frame, wo);
    let wi_local = shade_to_local(shading.frame, wi);
    let evaluated = shade_bsdf_eval_and_pdf(shading.bsdf, wo_local, wi_local);
    let reflected = evaluated.xyz * light.radiance * wi_local.z;
    if shade_max_element(reflected) <= 0.0 {
        return vec3f(0.0);
    }
    var weight = 1.0;
    if !light.is_delta {
        weight = shade_power_heuristic(light.pdf, evaluated.w);
    }
    if weight <= 0.0 {
        return vec3f(0.0);
    }
    let origin = scene_spawn_origin(surface, wi);
    var shadow = vec4f(wi, SHADE_FAR);
    if light.target_kind == SHADE_TARGET_POINT {
        shadow = shade_direction_and_distance(origin, light.target_position);
    } else if light.target_kind == SHADE_TARGET_SURFACE {
        let end = scene_offset_along_normal(light.target_position, light.target_normal, light.target_offset, origin - light.target_position);
        shadow = shade_direction_and_distance(origin, end);
    }
    if shadow.w == 0.0 {
        return vec3f(0.0);
    }
    shade_counts[SHADE_COUNT_RAYS_TRACED] += 1u;
    if scene_occluded(origin, shadow.xyz, shadow.w) {
        shade_counts[SHADE_COUNT_BLOCKED] += 1u;
        return vec3f(0.0);
    }
    shade_counts[SHADE_COUNT_REACHED] += 1u;
    return reflected * (weight / light.pdf);
}

// Shader::advance: one path vertex. Returns the next ray's origin in xyz with w = 1, or w = 0
// when the path has ended.
fn shade_advance(path: ptr<function, ShadePath>, hit: Hit, rng: ptr<function, Rng>) -> vec4f {
    let done = vec4f(0.0);
    let direction = (*path).direction;
    if hit.triangle == SHADE_NONE {
        if (*path).bsdf_pdf >= 0.0 {
            shade_counts[SHADE_COUNT_BOUNCE_ESCAPED] += 1u;
        } else {
            shade_counts[SHADE_COUNT_CAMERA_ESCAPED] += 1u;
        }
        var weight = 1.0;
        if (*path).bsdf_pdf >= 0.0 {
            weight = shade_power_heuristic((*path).bsdf_pdf, shade_light_environment_pdf(direction));
        }
        (*path).radiance += (*path).throughput * shade_environment_radiance(direction) * weight;
        return done;
    }
    let surface = scene_surface(hit, direction);
    let wo = -direction;
    let material = shade_material(surface.material);
    let shading = shade_shading_point(material, surface, wo);

    if !shade_is_zero3(shading.emission) {
        shade_counts[SHADE_COUNT_EMITTER_HITS] += 1u;
        var weight = 1.0;
        if (*path).bsdf_pdf >= 0.0 {
            let cos_light = shade_dot(surface.geometric_normal, wo);
            weight = shade_power_heuristic((*path).bsdf_pdf, shade_triangle_pdf(hit.triangle, hit.t, cos_light));
        }
        (*path).radiance += (*path).throughput * shading.emission * weight;
    }

    (*path).bounces += 1u;
    if (*path).bounces > shade_params.max_depth {
        return done;
    }
    (*path).radiance += (*path).throughput * shade_direct_light(surface, shading, wo, rng);

    let wo_local = shade_to_local(shading.frame, wo);
    let u_lobe = rng_next_f32(rng);
    let u = rng_next_2d(rng);
    let scattered = shade_bsdf_sample(shading.bsdf, wo_local, u_lobe, u);
    if scattered.pdf == 0.0 {
        return done;
    }
    let wi = shade_to_world(shading.frame, scattered.wi);
    // A shading normal can send a sample under the real surface: it would leak light.
    if shade_dot(wi, surface.geometric_normal) <= 0.0 {
        return done;
    }
    (*path).throughput *= scattered.value * (scattered.wi.z / scattered.pdf);
    if !shade_is_finite3((*path).throughput) {
        return done;
    }
    if (*path).bounces >= SHADE_RUSSIAN_ROULETTE_START {
        let survival = min(shade_max_element((*path).throughput), SHADE_MAX_SURVIVAL);
        if !shade_positive(survival) {
            return done;
        }
        if rng_next_f32(rng) >= survival {
            return done;
        }
        (*path).throughput /= survival;
    }
    (*path).direction = wi;
    (*path).bsdf_pdf = scattered.pdf;
    return vec4f(scene_spawn_origin(surface, wi), 1.0);
}

// Radiance (nits) arriving at `origin` from `direction` (world frame), given the ray's closest
// hit: Shader::path_radiance with Strategy::Mis. Non-finite results are 0.
fn path_radiance(origin: vec3f, direction: vec3f, first_hit: Hit, rng: ptr<function, Rng>) -> vec3f {
    let start = shade_normalize_or_zero(direction);
    if shade_is_zero3(start) || !shade_is_finite3(origin) {
        return vec3f(0.0);
    }
    var path = ShadePath(start, vec3f(0.0), vec3f(1.0), -1.0, 0u);
    var hit = first_hit;
    loop {
        let next = shade_advance(&path, hit, rng);
        if next.w == 0.0 {
            break;
        }
        hit = scene_intersect(next.xyz, path.direction, SHADE_FAR);
        shade_counts[SHADE_COUNT_RAYS_TRACED] += 1u;
    }
    if shade_is_finite3(path.radiance) {
        return path.radiance;
    }
    return vec3f(0.0);
}
