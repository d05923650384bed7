// Camera rays through the lens: for one pixel and sample, what LensCamera::generate
// (src/lens/camera.rs) makes of it on the CPU, step for step and in the same f32 operations:
// the film point, the camera sample's Owen-scrambled Sobol numbers, the exit-pupil sample and
// its camera weight (src/lens/pupil.rs), the exact trace from film to scene (the batch kernel of
// src/lens/trace_batch, one ray at a time), and the move to the world frame (mm -> m).
// Needs sampling.wgsl and spectral.wgsl before it. Bindings: @group(0), written by gpu::lens_constants.

// The per-render constants (gpu::lens::LensConstants, the same layout).
struct LensConstants {
    // Camera frame (m) -> world.
    world_from_camera: mat4x4f,
    // Pixel -> film point: scale · ((pixel + origin + jitter) − centre), per axis (the film
    // map of the enclosing film, camera.rs).
    film_scale: vec2f,
    film_origin: vec2f,
    film_centre: vec2f,
    // Lens-frame z of the frame centre, and its distance behind the rear vertex, mm.
    film_z: f32,
    film_distance: f32,
    // A tilted film's frame centre and rotation: x, y, z of R·(a, b, 0) per (a, b).
    tilt_centre: vec2f,
    tilt_x: vec2f,
    tilt_y: vec2f,
    tilt_z: vec2f,
    // Pixel keys: the frame's pixel (0, 0) in the enclosing film (wrapping) and its width.
    key_origin_x: u32,
    key_origin_y: u32,
    key_width: u32,
    // The seed of the camera's sample patterns (camera.rs camera_seed).
    pattern_seed: u32,
    // Wavelengths per camera sample in a spectral render (1: the hero alone).
    wavelengths: u32,
    tilted: u32,
    spectral: u32,
    // 0: within the exit-pupil bounds of the film point's segment; 1: over the rear element.
    pupil_sampling: u32,
    segment_scale: f32,
    rear_radius: f32,
    inv_z2: f32,
    surface_count: u32,
    film_normal: vec3f,
    // The travel step (film to scene) of the stop with a diaphragm; 0xffffffff: none.
    clip_step: u32,
    blade_count: u32,
    has_mask: u32,
    apex: f32,
    kappa: f32,
    clip_radius: f32,
    mask_width: u32,
    mask_height: u32,
    // Entries per surface of the dispersion table (1 nm apart from dispersion_lambda_min).
    dispersion_len: u32,
    mask_scale: vec2f,
    // Offsets into lens_tables.
    blades_offset: u32,
    mask_offset: u32,
    segments_offset: u32,
    dispersion_offset: u32,
    dispersion_lambda_min: f32,
    // The frame's size in pixels (where a companion wavelength's film point must land).
    film_width: u32,
    film_height: u32,
    // Where the surfaces' reflectance table starts in lens_tables (SurfaceReflectance: per
    // surface front to back, per table wavelength, REFLECTANCE_COSINE_STEPS + 1 cosines), and
    // its wavelengths per surface; 0: a lossless lens.
    reflectance_offset: u32,
    reflectance_wavelengths: u32,
    // Where the surfaces' own indices (n after each, front to back) start in lens_tables.
    indices_offset: u32,
    // Where the ghost pairs start in lens_tables (per pair: the running probability, a, b),
    // and how many (0: no ghost samples).
    ghost_offset: u32,
    ghost_pairs: u32,
    pad0: u32,
    pad1: u32,
}

// One surface in the order a camera ray meets it (film to scene): trace_batch's
// SurfaceConstants.
struct LensSurface {
    // A2 … A16, and i·A2i for the slope.
    coefficients: array<vec4f, 2>,
    slope_coefficients: array<vec4f, 2>,
    // LENS_SPHERE, LENS_CONIC or LENS_POLYNOMIAL.
    shape: u32,
    vertex_z: f32,
    curvature: f32,
    // 1 / curvature (infinite for planes).
    radius: f32,
    conic_factor: f32,
    conic: f32,
    semi_aperture_sq: f32,
    // n_incident / n_transmitted at the lens's own indices.
    eta: f32,
    // −1: rays leave toward −z (the scene).
    forward_sign: f32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<uniform> lens_constants: LensConstants;
// surface_count surfaces in the order a camera ray meets them (film to scene), then the same
// surfaces in the order a backward trace meets them (scene to film).
@group(0) @binding(1) var<storage, read> lens_surfaces: array<LensSurface>;
// The exit-pupil segments (min x, min y, extent x, extent y, then the 64 areas), the blade
// normals (x, y per blade), the mask's grey levels (row-major, row 0 at +y) and the dispersion
// table (per surface front to back, the index after it at every table wavelength).
@group(0) @binding(2) var<storage, read> lens_tables: array<f32>;

// A camera ray in the world frame (metres) and its lens weight (0: blocked); in a spectral
// render its wavelength (nm) and the inverse of the density it was drawn with (nm);
// wavelength 0 (weight 1) otherwise.
struct CameraRay {
    origin: vec3f,
    direction: vec3f,
    weight: f32,
    wavelength: f32,
    wavelength_weight: f32,
    // The pixel's key in the enclosing (unshifted) film: what the shading streams are keyed by.
    pixel_key: u32,
    // The film jitter: where the ray leaves the film relative to its pixel's top-left corner,
    // in steps of the film filter's grid (CameraRays::film_position, times FILM_POSITION_STEPS).
    film_position: vec2i,
}

const LENS_SPHERE: u32 = 0u;
const LENS_CONIC: u32 = 1u;
const LENS_POLYNOMIAL: u32 = 2u;
const LENS_SEGMENTS: u32 = 64u;
// trace_batch::refract's T_MIN and NEWTON_STEPS.
const LENS_T_MIN: f32 = 1e-6;
const LENS_NEWTON_STEPS: u32 = 16u;
const LENS_F32_MAX: f32 = 3.40282347e38;
const LENS_F32_EPSILON: f32 = 1.1920929e-7;
// camera.rs's GHOST_KEY.
const LENS_GHOST_KEY: u32 = 0x47485354u;
const LENS_FRAC_PI_4: f32 = 0.7853981633974483;
const LENS_PI: f32 = 3.141592653589793;

// The CPU's `a.max(b)` of the lane kernels: select(a > b, a, b) (b when either is NaN).
fn lens_max(a: f32, b: f32) -> f32 {
    return select(b, a, a > b);
}

// The lane kernels' abs: select(x < 0, −x, x).
fn lens_abs(x: f32) -> f32 {
    return select(x, -x, x < 0.0);
}

// `t < ∞` of the CPU (false for NaN and +∞).
fn lens_finite_below(t: f32) -> bool {
    return t <= LENS_F32_MAX;
}

// A ray in the lens frame, mm, and whether it still passes.
struct LensRay {
    origin: vec3f,
    direction: vec3f,
    alive: bool,
}

// sag(ρ), d sag/dρ, and whether they are defined (1 − κc²ρ ≥ 0).
struct LensSag {
    sag: f32,
    slope: f32,
    defined: bool,
}

// Σ c_k ρ^k over the 8 terms by Horner's rule, highest first and from 0 as the CPU runs it;
// written out so that no array is indexed at run time (a GPU would spill it to memory).
fn lens_horner(c: array<vec4f, 2>, rho: f32) -> f32 {
    var v = 0.0;
    v = v * rho + c[1].w;
    v = v * rho + c[1].z;
    v = v * rho + c[1].y;
    v = v * rho + c[1].x;
    v = v * rho + c[0].w;
    v = v * rho + c[0].z;
    v = v * rho + c[0].y;
    v = v * rho + c[0].x;
    return v;
}

fn lens_sag_and_slope(s: LensSurface, rho: f32) -> LensSag {
    let c = s.curvature;
    let under_root = 1.0 - s.conic_factor * c * c * rho;
    let root = sqrt(lens_max(under_root, 0.0));
    let value = lens_horner(s.coefficients, rho);
    let derivative = lens_horner(s.slope_coefficients, rho);
    let sag = c * rho / (1.0 + root) + value * rho;
    let slope = c / (root + root) + derivative;
    return LensSag(sag, slope, under_root >= 0.0);
}

// A distance along the ray and whether the surface is hit there.
struct LensHit {
    t: f32,
    hit: bool,
}

// The nearer valid root of a·t² + 2b·t + k = 0 (refract.rs nearer_root): the far root is q / a
// on a conic, q · radius on a sphere (a = c there); `sheet` is the κc of the sheet test.
fn lens_nearer_root(ovz: f32, vz: f32, b: f32, k: f32, discriminant: f32, conic: bool,
                    s: LensSurface, a: f32, sheet: f32) -> LensHit {
    let root = sqrt(lens_max(discriminant, 0.0));
    let q = select(-b - root, root - b, b < 0.0);
    let t_near = k / q;
    var t_far: f32;
    if conic {
        t_far = q / a;
    } else {
        t_far = q * s.radius;
    }
    let ok_near = t_near > LENS_T_MIN && lens_finite_below(t_near) && sheet * (ovz + t_near * vz) < 1.0;
    let ok_far = t_far > LENS_T_MIN && lens_finite_below(t_far) && sheet * (ovz + t_far * vz) < 1.0;
    let use_near = ok_near && (!ok_far || t_near <= t_far);
    return LensHit(select(t_far, t_near, use_near), discriminant >= 0.0 && (ok_near || ok_far));
}

fn lens_hit_sphere(s: LensSurface, ray: LensRay) -> LensHit {
    let p = ray.origin;
    let v = ray.direction;
    let c = s.curvature;
    let ovz = p.z - s.vertex_z;
    let b = c * (p.x * v.x + p.y * v.y + ovz * v.z) - v.z;
    let k = c * (p.x * p.x + p.y * p.y + ovz * ovz) - (ovz + ovz);
    let discriminant = b * b - c * k;
    return lens_nearer_root(ovz, v.z, b, k, discriminant, false, s, 0.0, c);
}

fn lens_hit_conic(s: LensSurface, ray: LensRay) -> LensHit {
    let p = ray.origin;
    let v = ray.direction;
    let c = s.curvature;
    let kappa = s.conic_factor;
    let ovz = p.z - s.vertex_z;
    let a = c * (1.0 + s.conic * v.z * v.z);
    let b = c * (p.x * v.x + p.y * v.y + kappa * ovz * v.z) - v.z;
    let k = c * (p.x * p.x + p.y * p.y + kappa * ovz * ovz) - (ovz + ovz);
    let discriminant = b * b - a * k;
    return lens_nearer_root(ovz, v.z, b, k, discriminant, true, s, a, kappa * c);
}

// Newton's method on z(t) − sag(ρ(t)) from the base conic's root (or the vertex plane ahead,
// or the origin), as refract.rs Newton: a step within a few ulps of the lengths it comes from
// has converged; an undefined sag or a non-finite step fails.
fn lens_hit_polynomial(s: LensSurface, ray: LensRay) -> LensHit {
    let conic = lens_hit_conic(s, ray);
    var plane_t = (s.vertex_z - ray.origin.z) / ray.direction.z;
    plane_t = select(0.0, plane_t, plane_t > 0.0);
    var t = select(plane_t, conic.t, conic.hit);
    var searching = ray.alive && plane_t >= 0.0;
    var converged = false;
    let p = ray.origin;
    let v = ray.direction;
    let ovz = p.z - s.vertex_z;
    for (var i = 0u; i < LENS_NEWTON_STEPS && searching; i++) {
        let x = p.x + t * v.x;
        let y = p.y + t * v.y;
        let z = ovz + t * v.z;
        let sag = lens_sag_and_slope(s, x * x + y * y);
        let derivative = v.z - (sag.slope + sag.slope) * (x * v.x + y * v.y);
        let step = (z - sag.sag) / derivative;
        let next = t - step;
        let valid = sag.defined && lens_finite_below(lens_abs(next));
        let scale = lens_abs(next) + lens_abs(ovz) + lens_abs(sag.sag);
        let done = lens_abs(step) <= 1e-7 + (16.0 * LENS_F32_EPSILON) * scale;
        if valid {
            t = next;
        }
        converged = converged || (valid && done);
        searching = valid && !done;
    }
    return LensHit(t, converged && t > LENS_T_MIN);
}

// Moves a live ray onto surface `s` and refracts it with index ratio `eta` (refract.rs
// refract_at); a ray that misses, leaves the clear aperture, is totally reflected or turns
// back is blocked and keeps its state.
// The unit normal of surface `s` at (hx, hy, hz), facing the scene at the vertex (a far hit
// sits slightly off the surface; normalising makes that a tilt, not a scale).
fn lens_normal(s: LensSurface, hx: f32, hy: f32, hz: f32) -> vec3f {
    var n: vec3f;
    if s.shape == LENS_SPHERE {
        n = vec3f(s.curvature * hx, s.curvature * hy, s.curvature * (hz - s.vertex_z) - 1.0);
    } else if s.shape == LENS_CONIC {
        n = vec3f(s.curvature * hx, s.curvature * hy,
                  s.conic_factor * s.curvature * (hz - s.vertex_z) - 1.0);
    } else {
        let sag = lens_sag_and_slope(s, hx * hx + hy * hy);
        let two_slope = sag.slope + sag.slope;
        n = vec3f(two_slope * hx, two_slope * hy, -1.0);
    }
    let inv_length = 1.0 / sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    return vec3f(n.x * inv_length, n.y * inv_length, n.z * inv_length);
}

// Where `ray` meets surface `s`, by the kernel of its shape (trace_batch's per-surface choice).
fn lens_hit(s: LensSurface, ray: LensRay) -> LensHit {
    if s.shape == LENS_SPHERE {
        return lens_hit_sphere(s, ray);
    } else if s.shape == LENS_CONIC {
        return lens_hit_conic(s, ray);
    }
    return lens_hit_polynomial(s, ray);
}

// Returns the ray's cosine in the less dense of the two media (the reflectance table's angle
// coordinate: refract.rs's Crossing::cosine).
fn lens_refract(s: LensSurface, ray: ptr<function, LensRay>, eta: f32) -> f32 {
    let found = lens_hit(s, *ray);
    let t = found.t;
    let p = (*ray).origin;
    let v = (*ray).direction;
    let hx = p.x + t * v.x;
    let hy = p.y + t * v.y;
    let hz = p.z + t * v.z;
    let inside = hx * hx + hy * hy <= s.semi_aperture_sq;
    let n = lens_normal(s, hx, hy, hz);
    let cos_raw = -(v.x * n.x + v.y * n.y + v.z * n.z);
    let flip = select(1.0, -1.0, cos_raw < 0.0);
    let cos_i = cos_raw * flip;
    let cos_t_sq = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    let no_tir = cos_t_sq >= 0.0;
    let cos_t = sqrt(lens_max(cos_t_sq, 0.0));
    let along_normal = (eta * cos_i - cos_t) * flip;
    let r = vec3f(eta * v.x + along_normal * n.x, eta * v.y + along_normal * n.y,
                  eta * v.z + along_normal * n.z);
    let forward = r.z * s.forward_sign > 0.0;
    let survives = (*ray).alive && found.hit && inside && no_tir && forward;
    if survives {
        (*ray).origin = vec3f(hx, hy, hz);
        (*ray).direction = r;
    }
    (*ray).alive = survives;
    return select(cos_t, cos_i, eta <= 1.0);
}

// R of surface `surface` (front = 0) at `cosine` (in the less dense medium) and table
// wavelength entry w + t: SurfaceReflectance::lookup, bilinear.
fn lens_reflectance(surface: u32, cosine: f32, w: u32, t: f32) -> f32 {
    let steps = REFLECTANCE_COSINE_STEPS;
    let x = clamp(cosine * f32(steps), 0.0, f32(steps));
    let c = min(u32(x), steps - 1u);
    let u = x - f32(c);
    let row = lens_constants.reflectance_offset
        + (surface * lens_constants.reflectance_wavelengths + w) * (steps + 1u) + c;
    let next = row + steps + 1u;
    let r0 = lens_tables[row] + u * (lens_tables[row + 1u] - lens_tables[row]);
    let r1 = lens_tables[next] + u * (lens_tables[next + 1u] - lens_tables[next]);
    return r0 + t * (r1 - r0);
}

// The mask's grey level at stop-plane point (x, y), bilinear (ApertureMask::sample_f32).
fn lens_mask_transmission(x: f32, y: f32) -> f32 {
    let radius = lens_constants.clip_radius;
    let u = (x + radius) * lens_constants.mask_scale.x;
    let v = (radius - y) * lens_constants.mask_scale.y;
    let w = lens_constants.mask_width;
    let h = lens_constants.mask_height;
    let fx = clamp(u - 0.5, 0.0, f32(w - 1u));
    let fy = clamp(v - 0.5, 0.0, f32(h - 1u));
    let x0 = u32(fx);
    let y0 = u32(fy);
    let x1 = min(x0 + 1u, w - 1u);
    let y1 = min(y0 + 1u, h - 1u);
    let tx = fx - f32(x0);
    let ty = fy - f32(y0);
    let o = lens_constants.mask_offset;
    let a = lens_tables[o + y0 * w + x0];
    let b = lens_tables[o + y0 * w + x1];
    let c = lens_tables[o + y1 * w + x0];
    let d = lens_tables[o + y1 * w + x1];
    let top = a + (b - a) * tx;
    let bottom = c + (d - c) * tx;
    return top + (bottom - top) * ty;
}

// The diaphragm at the stop (trace_batch clip.rs): blocked on the closed side of a blade
// (p·n + κ|p − m n|² > m) or where the mask is black; the mask's grey level otherwise.
fn lens_clip(ray: ptr<function, LensRay>) -> f32 {
    let x = (*ray).origin.x;
    let y = (*ray).origin.y;
    let apex = lens_constants.apex;
    let kappa = lens_constants.kappa;
    var inside = true;
    for (var i = 0u; i < lens_constants.blade_count; i++) {
        let nx = lens_tables[lens_constants.blades_offset + 2u * i];
        let ny = lens_tables[lens_constants.blades_offset + 2u * i + 1u];
        let along = x * nx + y * ny;
        let ex = x - apex * nx;
        let ey = y - apex * ny;
        inside = inside && along + kappa * (ex * ex + ey * ey) <= apex;
    }
    (*ray).alive = (*ray).alive && inside;
    if lens_constants.has_mask != 0u && (*ray).alive {
        let t = lens_mask_transmission(x, y);
        (*ray).alive = t > 0.0;
        if (*ray).alive {
            return t;
        }
    }
    return 1.0;
}

// The index of the medium after front-to-back surface `surface` at table position (i, t).
fn lens_index_after(surface: u32, i: u32, t: f32) -> f32 {
    let row = lens_constants.dispersion_offset + surface * lens_constants.dispersion_len;
    let a = lens_tables[row + i];
    return a + t * (lens_tables[row + i + 1u] - a);
}

// An entry of a table over wavelength and the fraction toward the next.
struct LensTablePosition {
    cell: u32,
    fraction: f32,
}

// DispersionTable::position: where `nm` falls in the dispersion table (1 nm entries).
fn lens_dispersion_position(nm: f32) -> LensTablePosition {
    let last = lens_constants.dispersion_len - 1u;
    let x = clamp(nm - lens_constants.dispersion_lambda_min, 0.0, f32(last));
    let cell = min(u32(x), last - 1u);
    return LensTablePosition(cell, x - f32(cell));
}

// SurfaceReflectance::position: where a ray at `nm` falls in the reflectance table (rays at
// the lens's own indices lose what they would at the d line).
fn lens_loss_position(nm: f32) -> LensTablePosition {
    var loss_nm = FRAUNHOFER_D_NM;
    if lens_constants.spectral != 0u {
        loss_nm = nm;
    }
    let last = max(lens_constants.reflectance_wavelengths, 2u) - 1u;
    let x = clamp((loss_nm - lens_constants.dispersion_lambda_min) / REFLECTANCE_STEP_NM,
                  0.0, f32(last));
    let cell = min(u32(x), last - 1u);
    return LensTablePosition(cell, x - f32(cell));
}

// Traces a film-side ray through every surface to the scene side (trace_batch with
// Travel::FilmToScene; at the ray's own wavelength `nm` in a spectral render), returning the
// diaphragm mask's transmission along it.
fn lens_trace(ray: ptr<function, LensRay>, nm: f32) -> f32 {
    return lens_trace_toward(ray, nm, false);
}

// lens_trace, or with `backward` a scene-side ray through every surface to the film side
// (Travel::SceneToFilm, the surfaces' second half of lens_surfaces).
fn lens_trace_toward(ray: ptr<function, LensRay>, nm: f32, backward: bool) -> f32 {
    let count = lens_constants.surface_count;
    var transmission = 1.0;
    let index_at = lens_dispersion_position(nm);
    let cell = index_at.cell;
    let fraction = index_at.fraction;
    var carried = 1.0;
    if lens_constants.spectral != 0u && !backward {
        carried = lens_index_after(count - 1u, cell, fraction);
    }
    let losses = lens_constants.reflectance_wavelengths != 0u;
    var loss = 1.0;
    let loss_at = lens_loss_position(nm);
    let loss_cell = loss_at.cell;
    let loss_fraction = loss_at.fraction;
    var clip_step = lens_constants.clip_step;
    if backward && clip_step != 0xffffffffu {
        clip_step = count - 1u - clip_step;
    }
    for (var step = 0u; step < count; step++) {
        var s: LensSurface;
        var eta: f32;
        if backward {
            s = lens_surfaces[count + step];
            eta = s.eta;
            if lens_constants.spectral != 0u {
                let after = lens_index_after(step, cell, fraction);
                eta = carried / after;
                carried = after;
            }
        } else {
            s = lens_surfaces[step];
            eta = s.eta;
            if lens_constants.spectral != 0u {
                let surface = count - 1u - step;
                var before = 1.0;
                if surface != 0u {
                    before = lens_index_after(surface - 1u, cell, fraction);
                }
                eta = carried / before;
                carried = before;
            }
        }
        let cosine = lens_refract(s, ray, eta);
        if step == clip_step {
            transmission = lens_clip(ray);
        }
        if !(*ray).alive {
            break;
        }
        if losses {
            var surface = step;
            if !backward {
                surface = count - 1u - step;
            }
            loss = loss * (1.0 - lens_reflectance(surface, cosine, loss_cell, loss_fraction));
        }
    }
    // The batch kernels multiply the mask's grey level first, then the surfaces' losses.
    transmission = transmission * loss;
    if (*ray).alive {
        let d = (*ray).direction;
        let inv_length = 1.0 / sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
        (*ray).direction = vec3f(d.x * inv_length, d.y * inv_length, d.z * inv_length);
    }
    return transmission;
}

// Shirley–Chiu concentric map of the unit square onto the unit disk (pupil.rs).
fn lens_concentric_disk(u: f32, v: f32) -> vec2f {
    let a = 2.0 * u - 1.0;
    let b = 2.0 * v - 1.0;
    if a == 0.0 && b == 0.0 {
        return vec2f(0.0, 0.0);
    }
    var r: f32;
    var phi: f32;
    if abs(a) > abs(b) {
        r = a;
        phi = LENS_FRAC_PI_4 * (b / a);
    } else {
        r = b;
        phi = 2.0 * LENS_FRAC_PI_4 - LENS_FRAC_PI_4 * (a / b);
    }
    return vec2f(r * cos(phi), r * sin(phi));
}

// A rear-plane point for a film point and the area it was drawn from (0: no ray passes).
struct LensPupilPoint {
    point: vec2f,
    area: f32,
}

// PupilSampler::in_bounds / on_rear_element.
fn lens_pupil_point(x: f32, y: f32, u: f32, v: f32) -> LensPupilPoint {
    if lens_constants.pupil_sampling == 1u {
        let disk = lens_concentric_disk(u, v);
        let radius = lens_constants.rear_radius;
        return LensPupilPoint(vec2f(disk.x * radius, disk.y * radius), LENS_PI * radius * radius);
    }
    let r = sqrt(x * x + y * y);
    // min before the conversion: a film point far beyond the film's reach takes the last
    // segment, as the CPU's saturating `as usize` then min does.
    let k = u32(min(r * lens_constants.segment_scale, f32(LENS_SEGMENTS - 1u)));
    let o = lens_constants.segments_offset + 4u * k;
    let bx = lens_tables[o] + lens_tables[o + 2u] * u;
    let by = lens_tables[o + 1u] + lens_tables[o + 3u] * v;
    // The bounds were found for a film point on +x: rotate by the point's angle.
    let inv_r = 1.0 / r;
    var sin_a = 0.0;
    var cos_a = 1.0;
    if r > 0.0 {
        sin_a = y * inv_r;
        cos_a = x * inv_r;
    }
    let area = lens_tables[lens_constants.segments_offset + 4u * LENS_SEGMENTS + k];
    return LensPupilPoint(vec2f(cos_a * bx - sin_a * by, sin_a * bx + cos_a * by), area);
}

// A sample's wavelengths beyond the hero (lens/hero_wavelengths.rs): each one's λ (nm), its
// factor T/(p(λ)·Σ 1/W) for the film (0: it does not count), the offset from the sample's
// pixel to the pixel its contribution goes to, and where it lands relative to that pixel's
// top-left corner on the film filter's grid (lens_film_steps; the hero's: the film jitter).
// Index 0 is the hero.
struct CameraWavelengths {
    nm: array<f32, MAX_WAVELENGTHS>,
    factor: array<f32, MAX_WAVELENGTHS>,
    offset: array<vec2i, MAX_WAVELENGTHS>,
    position: array<vec2i, MAX_WAVELENGTHS>,
}

// film::filter::quantise in steps: round(p · FILM_POSITION_STEPS) per axis, rounding halves
// away from zero as Rust's round does (WGSL's round takes them to even, and a landing point a
// few hundred pixels from the frame's corner lies exactly halfway between two steps about once
// in a hundred: its f32 has only a few bits below the step).
fn lens_film_steps(p: vec2f) -> vec2i {
    let scaled = p * f32(FILM_POSITION_STEPS);
    let whole = trunc(scaled);
    let up = abs(scaled - whole) >= vec2f(0.5);
    return vec2i(whole + select(vec2f(0.0), sign(scaled), up));
}

// PupilSampler::drawn_weight: the camera weight the sampler gives the ray from film point
// `film` (depth mm behind the rear-vertex plane) through rear-plane point `rear`; 0 where it
// never draws that point.
fn lens_drawn_weight(film: vec2f, depth: f32, rear: vec2f) -> f32 {
    return lens_drawn_weight_over(film, depth, rear, lens_constants.pupil_sampling == 1u);
}

// lens_drawn_weight for a sampler drawing over the rear element (`rear_element`) or within
// the exit pupil's bounds.
fn lens_drawn_weight_over(film: vec2f, depth: f32, rear: vec2f, rear_element: bool) -> f32 {
    let x = film.x;
    let y = film.y;
    var area = 0.0;
    if rear_element {
        let radius = lens_constants.rear_radius;
        let reach = radius * (1.0 + 1e-5);
        if rear.x * rear.x + rear.y * rear.y <= reach * reach {
            area = LENS_PI * radius * radius;
        }
    } else {
        let r = sqrt(x * x + y * y);
        let k = u32(min(r * lens_constants.segment_scale, f32(LENS_SEGMENTS - 1u)));
        let o = lens_constants.segments_offset + 4u * k;
        let min_x = lens_tables[o];
        let min_y = lens_tables[o + 1u];
        let extent_x = lens_tables[o + 2u];
        let extent_y = lens_tables[o + 3u];
        var sin_a = 0.0;
        var cos_a = 1.0;
        if r > 0.0 {
            sin_a = y / r;
            cos_a = x / r;
        }
        let bx = cos_a * rear.x + sin_a * rear.y;
        let by = cos_a * rear.y - sin_a * rear.x;
        let slack = 1e-5 * (extent_x + extent_y);
        if bx >= min_x - slack && bx <= min_x + extent_x + slack && by >= min_y - slack
            && by <= min_y + extent_y + slack {
            area = lens_tables[lens_constants.segments_offset + 4u * LENS_SEGMENTS + k];
        }
    }
    let to = vec3f(rear.x - x, rear.y - y, -depth);
    if lens_constants.tilted != 0u {
        let inv_len = 1.0 / sqrt(to.x * to.x + to.y * to.y + to.z * to.z);
        let cos_rear = abs(to.z * inv_len);
        let nrm = lens_constants.film_normal;
        let cos_film = abs((to.x * nrm.x + to.y * nrm.y + to.z * nrm.z) * inv_len);
        return cos_film * cos_rear * cos_rear * cos_rear * area / (depth * depth);
    }
    let cos2 = to.z * to.z / (to.x * to.x + to.y * to.y + to.z * to.z);
    return cos2 * cos2 * area * lens_constants.inv_z2;
}

// Where a backward-traced ray (on the rear surface, heading for the film) lands
// (BackwardTrace::landing): its pixel, the continuous pixel position (pixels from the frame's
// top-left corner) and the inverse of the camera weight it would have been drawn with there;
// valid only on the frame and where the pupil sampler draws.
struct LensLanding {
    pixel: vec2i,
    position: vec2f,
    inverse_weight: f32,
    valid: bool,
}

fn lens_landing(ray: LensRay) -> LensLanding {
    let o = ray.origin;
    let d = ray.direction;
    var lens_xy: vec2f;
    var plane: vec2f;
    var depth: f32;
    if lens_constants.tilted == 0u {
        let t = (lens_constants.film_z - o.z) / d.z;
        lens_xy = vec2f(o.x + t * d.x, o.y + t * d.y);
        plane = lens_xy;
        depth = lens_constants.film_distance;
    } else {
        let normal = lens_constants.film_normal;
        let centre = vec3f(lens_constants.tilt_centre, lens_constants.film_z);
        let to_centre = centre - o;
        let t = (to_centre.x * normal.x + to_centre.y * normal.y + to_centre.z * normal.z)
            / (d.x * normal.x + d.y * normal.y + d.z * normal.z);
        let p = vec3f(o.x + t * d.x, o.y + t * d.y, o.z + t * d.z);
        let offset = p - centre;
        let a = offset.x * lens_constants.tilt_x.x + offset.y * lens_constants.tilt_y.x
            + offset.z * lens_constants.tilt_z.x;
        let b = offset.x * lens_constants.tilt_x.y + offset.y * lens_constants.tilt_y.y
            + offset.z * lens_constants.tilt_z.y;
        plane = vec2f(lens_constants.tilt_centre.x + a, lens_constants.tilt_centre.y + b);
        lens_xy = p.xy;
        depth = lens_constants.film_distance + offset.z;
    }
    let qx = plane.x / lens_constants.film_scale.x + lens_constants.film_centre.x - lens_constants.film_origin.x;
    let qy = plane.y / lens_constants.film_scale.y + lens_constants.film_centre.y - lens_constants.film_origin.y;
    var landing = LensLanding(vec2i(0, 0), vec2f(0.0), 0.0, false);
    let on_frame = qx >= 0.0 && qy >= 0.0 && qx < f32(lens_constants.film_width)
        && qy < f32(lens_constants.film_height);
    if !on_frame {
        return landing;
    }
    let rear_z = lens_constants.film_z - lens_constants.film_distance;
    let t = (rear_z - o.z) / d.z;
    let rear = vec2f(o.x + t * d.x, o.y + t * d.y);
    let w = lens_drawn_weight(lens_xy, depth, rear);
    landing.pixel = vec2i(i32(qx), i32(qy));
    landing.position = vec2f(qx, qy);
    landing.inverse_weight = 1.0 / w;
    landing.valid = w > 0.0 && w <= LENS_F32_MAX;
    return landing;
}

fn lens_within_radius(a: vec2i, b: vec2i) -> bool {
    return abs(a.x - b.x) <= SPLAT_RADIUS && abs(a.y - b.y) <= SPLAT_RADIUS;
}

// The companions of a hero ray that passed (lens frame, on the front surface; camera weight
// `hero_weight`, mask transmission `hero_transmission`), traced back and combined with the
// balance heuristic (BackwardTrace::combine) into `out`; returns the sample's weight (1, or 0
// when the hero does not count).
fn lens_companions(ray: LensRay, pixel: vec2i, wavelength_set: WavelengthSet, hero_weight: f32,
                   hero_transmission: f32, out: ptr<function, CameraWavelengths>) -> f32 {
    let count = lens_constants.wavelengths;
    var inverse: array<f32, MAX_WAVELENGTHS>;
    var landed: array<vec2i, MAX_WAVELENGTHS>;
    var landed_at: array<vec2f, MAX_WAVELENGTHS>;
    var valid: array<bool, MAX_WAVELENGTHS>;
    var transmission: array<f32, MAX_WAVELENGTHS>;
    valid[0] = ray.alive && hero_weight > 0.0;
    inverse[0] = 1.0 / hero_weight;
    landed[0] = pixel;
    transmission[0] = hero_transmission;
    // Loops over a sample's wavelengths run to the constant MAX_WAVELENGTHS (the kernel is
    // compiled for the render's count) and stop at `count`: unrolled, with the arrays in
    // registers.
    for (var k = 1u; k < MAX_WAVELENGTHS; k++) {
        if k >= count {
            break;
        }
        var shifted = wavelength_set.u + f32(k) / f32(count);
        if shifted >= 1.0 {
            shifted = shifted - 1.0;
        }
        let wavelength = sample_wavelength(shifted);
        (*out).nm[k] = wavelength.nm;
        (*out).factor[k] = wavelength.inverse_pdf * wavelength_set.inverse_density;
        valid[k] = false;
        transmission[k] = 0.0;
        if ray.alive {
            let d = ray.direction;
            var back = LensRay(
                vec3f(ray.origin.x + BACKWARD_START_MM * d.x, ray.origin.y + BACKWARD_START_MM * d.y,
                      ray.origin.z + BACKWARD_START_MM * d.z),
                vec3f(-d.x, -d.y, -d.z), true);
            let t = lens_trace_toward(&back, wavelength.nm, true);
            if back.alive {
                let landing = lens_landing(back);
                valid[k] = landing.valid;
                landed[k] = landing.pixel;
                landed_at[k] = landing.position;
                inverse[k] = landing.inverse_weight;
                transmission[k] = t;
            }
        }
    }
    for (var k = 0u; k < MAX_WAVELENGTHS; k++) {
        if k >= count {
            break;
        }
        if valid[k] && lens_within_radius(landed[k], pixel) {
            var inverse_sum = 0.0;
            for (var j = 0u; j < MAX_WAVELENGTHS; j++) {
                if j >= count {
                    break;
                }
                if valid[j] && lens_within_radius(landed[j], landed[k]) {
                    inverse_sum += inverse[j];
                }
            }
            (*out).factor[k] = (*out).factor[k] * (transmission[k] / inverse_sum);
            (*out).offset[k] = landed[k] - pixel;
            if k > 0u {
                (*out).position[k] = lens_film_steps(landed_at[k] - vec2f(pixel));
            }
        } else {
            (*out).factor[k] = 0.0;
            (*out).offset[k] = vec2i(0, 0);
        }
    }
    return select(0.0, 1.0, valid[0]);
}

// The index before and after front-to-back surface `surface`: at table position (cell,
// fraction) in a spectral render, else the lens's own.
fn lens_indices(surface: u32, cell: u32, fraction: f32) -> vec2f {
    if lens_constants.spectral != 0u {
        var before = 1.0;
        if surface != 0u {
            before = lens_index_after(surface - 1u, cell, fraction);
        }
        return vec2f(before, lens_index_after(surface, cell, fraction));
    }
    var before = 1.0;
    if surface != 0u {
        before = lens_tables[lens_constants.indices_offset + surface - 1u];
    }
    return vec2f(before, lens_tables[lens_constants.indices_offset + surface]);
}

// One step of a ghost path (ghost.rs trace_ghost) at front-to-back surface `surface`:
// refracting through it, or with `reflect` reflecting off it; returns the fraction of the light
// it passes (the ray's `alive` turns false where the path ends).
fn lens_ghost_step(surface: u32, ray: ptr<function, LensRay>, reflect: bool, cell: u32,
                   fraction: f32, loss_cell: u32, loss_fraction: f32) -> f32 {
    let count = lens_constants.surface_count;
    // The scene-to-film copy: its geometry is the surface's whichever way the ray goes.
    let s = lens_surfaces[count + surface];
    let found = lens_hit(s, *ray);
    let p = (*ray).origin;
    let d = (*ray).direction;
    let h = vec3f(p.x + found.t * d.x, p.y + found.t * d.y, p.z + found.t * d.z);
    if !found.hit || h.x * h.x + h.y * h.y > s.semi_aperture_sq {
        (*ray).alive = false;
        return 0.0;
    }
    var passed = 1.0;
    let clip_step = lens_constants.clip_step;
    if clip_step != 0xffffffffu && surface == count - 1u - clip_step {
        (*ray).origin = h;
        passed = lens_clip(ray);
        if !(*ray).alive {
            return 0.0;
        }
    }
    let n = lens_normal(s, h.x, h.y, h.z);
    let toward_film = d.z > 0.0;
    let indices = lens_indices(surface, cell, fraction);
    var n_in = indices.y;
    var n_out = indices.x;
    if toward_film {
        n_in = indices.x;
        n_out = indices.y;
    }
    let along = d.x * n.x + d.y * n.y + d.z * n.z;
    let cos_in = abs(along);
    let eta = n_in / n_out;
    let sin2_out = eta * eta * (1.0 - cos_in * cos_in);
    let total = sin2_out > 1.0;
    var r = 1.0;
    if !total {
        var cosine = cos_in;
        if n_in > n_out {
            cosine = sqrt(1.0 - sin2_out);
        }
        r = lens_reflectance(surface, cosine, loss_cell, loss_fraction);
    }
    var direction: vec3f;
    var keeps: f32;
    if reflect {
        direction = d - (along + along) * n;
        keeps = r;
    } else {
        if total {
            (*ray).alive = false;
            return 0.0;
        }
        // trace::refract: the normal against the ray, Snell's law in vector form.
        var m = n;
        var cos_i = -along;
        if cos_i < 0.0 {
            m = -n;
            cos_i = -cos_i;
        }
        let cos_t = sqrt(1.0 - sin2_out);
        direction = normalize(eta * d + (eta * cos_i - cos_t) * m);
        keeps = 1.0 - r;
    }
    if (direction.z > 0.0) != (toward_film != reflect) {
        (*ray).alive = false;
        return 0.0;
    }
    (*ray).origin = h;
    (*ray).direction = direction;
    return passed * keeps;
}

// A ghost sample (ghost.rs): the film-side ray `ray` along the ghost path of the pair chosen by
// `u`, at wavelength `nm`; returns the path's transmission over the pair's probability (0 where
// it ends inside the lens).
fn lens_ghost(ray: ptr<function, LensRay>, u: f32, nm: f32) -> f32 {
    // Ghosts::choose: the first pair whose running probability exceeds u.
    let pairs = lens_constants.ghost_pairs;
    let o = lens_constants.ghost_offset;
    var k = 0u;
    while k + 1u < pairs && lens_tables[o + 3u * k] <= u {
        k++;
    }
    var below = 0.0;
    if k > 0u {
        below = lens_tables[o + 3u * (k - 1u)];
    }
    let probability = lens_tables[o + 3u * k] - below;
    let a = u32(lens_tables[o + 3u * k + 1u]);
    let b = u32(lens_tables[o + 3u * k + 2u]);
    let index_at = lens_dispersion_position(nm);
    let loss_at = lens_loss_position(nm);
    let cell = index_at.cell;
    let fraction = index_at.fraction;
    let loss_cell = loss_at.cell;
    let loss_fraction = loss_at.fraction;
    // film → n−1 … a+1 → (a) → a+1 … b−1 → (b) → b−1 … 0 → scene (ghost_steps), as one loop
    // so the step is compiled once.
    let count = lens_constants.surface_count;
    let first = count - 1u - a;
    let between = b - a - 1u;
    var passed = 1.0;
    for (var k = 0u; k < count + 2u * (b - a) && (*ray).alive; k++) {
        var surface: u32;
        var reflect = false;
        if k < first {
            surface = count - 1u - k;
        } else if k == first {
            surface = a;
            reflect = true;
        } else if k < first + 1u + between {
            surface = a + 1u + (k - first - 1u);
        } else if k == first + 1u + between {
            surface = b;
            reflect = true;
        } else {
            surface = b - 1u - (k - first - 2u - between);
        }
        passed *= lens_ghost_step(surface, ray, reflect, cell, fraction, loss_cell, loss_fraction);
    }
    if !(*ray).alive {
        return 0.0;
    }
    return passed / probability;
}

// Sample `sample` of pixel (pixel_x, pixel_y) through the lens, in the world frame (metres).
fn camera_ray(pixel_x: u32, pixel_y: u32, sample: u32) -> CameraRay {
    var unused: CameraWavelengths;
    return camera_ray_with(pixel_x, pixel_y, sample, &unused);
}

// camera_ray, and with several wavelengths per sample (a spectral render with
// lens_constants.wavelengths > 1) the hero's companions in `wavelengths`; the ray's weight is
// then 1 (or 0) and the factors carry the rest.
fn camera_ray_with(pixel_x: u32, pixel_y: u32, sample: u32,
                   wavelengths: ptr<function, CameraWavelengths>) -> CameraRay {
    // The camera sample: pupil point (dimensions 1-2), film jitter (3-4) and in a spectral
    // render the wavelength (5) of the pixel's Owen-scrambled Sobol pattern
    // (LensCamera::camera_samples).
    let pixel = (pixel_y + lens_constants.key_origin_y) * lens_constants.key_width + (pixel_x + lens_constants.key_origin_x);
    let pattern_key = hash32(pixel ^ lens_constants.pattern_seed);
    let pupil_u = owen_sobol(sample, 0u, pattern_key);
    let pupil_v = owen_sobol(sample, 1u, pattern_key);
    let film_u = owen_sobol(sample, 2u, pattern_key);
    let film_v = owen_sobol(sample, 3u, pattern_key);
    let jitter = lens_film_steps(vec2f(film_u, film_v));
    (*wavelengths).position[0] = jitter;
    var nm = 0.0;
    var wavelength_weight = 1.0;
    var wavelength_set = WavelengthSet(0.0, 1.0);
    if lens_constants.spectral != 0u {
        wavelength_set = draw_wavelength_set(owen_sobol(sample, 4u, pattern_key), lens_constants.wavelengths);
        let wavelength = sample_wavelength(wavelength_set.u);
        nm = wavelength.nm;
        wavelength_weight = wavelength.inverse_pdf * wavelength_set.inverse_density;
    }

    // The film point (LensCamera::film_to_pupil), tilted about the frame centre.
    let px = f32(pixel_x);
    let py = f32(pixel_y);
    var ox = lens_constants.film_scale.x * (((px + lens_constants.film_origin.x) + film_u) - lens_constants.film_centre.x);
    var oy = lens_constants.film_scale.y * (((py + lens_constants.film_origin.y) + film_v) - lens_constants.film_centre.y);
    var oz = lens_constants.film_z;
    var depth = lens_constants.film_distance;
    if lens_constants.tilted != 0u {
        let a = ox - lens_constants.tilt_centre.x;
        let b = oy - lens_constants.tilt_centre.y;
        ox = lens_constants.tilt_centre.x + lens_constants.tilt_x.x * a + lens_constants.tilt_x.y * b;
        oy = lens_constants.tilt_centre.y + lens_constants.tilt_y.x * a + lens_constants.tilt_y.y * b;
        let dz = lens_constants.tilt_z.x * a + lens_constants.tilt_z.y * b;
        oz = lens_constants.film_z + dz;
        depth = lens_constants.film_distance + dz;
    }

    // One sample in GHOST_EVERY follows a ghost path (LensCamera::trace_ghost_samples): from
    // a point drawn over the rear element, with that drawing's camera weight.
    // The pixel's ghost block (camera.rs ghost_block_key): 8 × 4 pixels, a warp, decide
    // together.
    let block_x = (pixel % lens_constants.key_width) / GHOST_BLOCK_X;
    let block_y = (pixel / lens_constants.key_width) / GHOST_BLOCK_Y;
    let block_key = hash32((block_y * 65536u + block_x) ^ lens_constants.pattern_seed);
    if lens_constants.ghost_pairs != 0u
        && (sample + hash32(block_key ^ LENS_GHOST_KEY)) % GHOST_EVERY == 0u {
        let disk = lens_concentric_disk(pupil_u, pupil_v);
        let rear = vec2f(disk.x * lens_constants.rear_radius, disk.y * lens_constants.rear_radius);
        let drawn = lens_drawn_weight_over(vec2f(ox, oy), depth, rear, true);
        let rear_z = lens_constants.film_z - lens_constants.film_distance;
        let to = vec3f(rear.x - ox, rear.y - oy, rear_z - oz);
        let length = sqrt(to.x * to.x + to.y * to.y + to.z * to.z);
        var ray = LensRay(vec3f(ox, oy, oz), to / length, true);
        let u = f32(hash32(hash32(pattern_key ^ LENS_GHOST_KEY) ^ sample) >> 8u)
            * (1.0 / 16777216.0);
        let passed = lens_ghost(&ray, u, nm);
        var weight = 0.0;
        if ray.alive && drawn > 0.0 {
            weight = drawn * passed * f32(GHOST_EVERY);
        }
        // A ghost sample carries its hero wavelength alone.
        (*wavelengths).nm[0] = nm;
        (*wavelengths).factor[0] = wavelength_weight;
        for (var k = 1u; k < MAX_WAVELENGTHS; k++) {
            (*wavelengths).nm[k] = nm;
            (*wavelengths).factor[k] = 0.0;
            (*wavelengths).offset[k] = vec2i(0, 0);
        }
        (*wavelengths).offset[0] = vec2i(0, 0);
        return lens_to_world(ray, weight, nm, wavelength_weight, pixel, jitter);
    }

    // The pupil point and the camera weight (PupilSampler::sample_with / sample_tilted).
    let chosen = lens_pupil_point(ox, oy, pupil_u, pupil_v);
    let to = vec3f(chosen.point.x - ox, chosen.point.y - oy, -depth);
    let inv_len = 1.0 / sqrt(to.x * to.x + to.y * to.y + to.z * to.z);
    let passing = chosen.area > 0.0;
    let d = vec3f(to.x * inv_len, to.y * inv_len, to.z * inv_len);
    var weight: f32;
    if lens_constants.tilted != 0u {
        // |cos θ_film| · cos³θ_rear · A / depth².
        let cos_rear = abs(to.z * inv_len);
        let nrm = lens_constants.film_normal;
        let cos_film = abs((to.x * nrm.x + to.y * nrm.y + to.z * nrm.z) * inv_len);
        weight = cos_film * cos_rear * cos_rear * cos_rear * chosen.area / (depth * depth);
    } else {
        // cos⁴θ · A / z².
        let cos2 = d.z * d.z / (d.x * d.x + d.y * d.y + d.z * d.z);
        weight = cos2 * cos2 * chosen.area * lens_constants.inv_z2;
    }
    var ray = LensRay(vec3f(ox, oy, oz), select(vec3f(0.0, 0.0, -1.0), d, passing), passing);

    // Through the lens; what the mask and the surfaces pass scales the weight (with several
    // wavelengths, each one's factor).
    let transmission = lens_trace(&ray, nm);
    if lens_constants.spectral != 0u && lens_constants.wavelengths > 1u {
        (*wavelengths).nm[0] = nm;
        (*wavelengths).factor[0] = wavelength_weight;
        weight = lens_companions(ray, vec2i(i32(pixel_x), i32(pixel_y)), wavelength_set, weight,
                                 transmission, wavelengths);
    } else if lens_constants.has_mask != 0u || lens_constants.reflectance_wavelengths != 0u {
        weight *= transmission;
    }
    if lens_constants.ghost_pairs != 0u {
        // The ordinary samples are the other GHOST_EVERY − 1 in GHOST_EVERY.
        weight *= f32(GHOST_EVERY) / f32(GHOST_EVERY - 1u);
    }
    return lens_to_world(ray, weight, nm, wavelength_weight, pixel, jitter);
}

// A lens-frame camera ray in the world frame (LensCamera::move_to_world): lens frame (mm) ->
// camera frame (m) -> world; zero weight when it was blocked.
fn lens_to_world(ray: LensRay, lens_weight: f32, nm: f32, wavelength_weight: f32,
                 pixel: u32, jitter: vec2i) -> CameraRay {
    var weight = lens_weight;
    let m = lens_constants.world_from_camera;
    let p = vec3f(ray.origin.x * 1e-3, ray.origin.y * 1e-3, (ray.origin.z - lens_constants.film_z) * 1e-3);
    let v = ray.direction;
    let origin = vec3f(
        m[0].x * p.x + m[1].x * p.y + m[2].x * p.z + m[3].x,
        m[0].y * p.x + m[1].y * p.y + m[2].y * p.z + m[3].y,
        m[0].z * p.x + m[1].z * p.y + m[2].z * p.z + m[3].z,
    );
    let direction = vec3f(
        m[0].x * v.x + m[1].x * v.y + m[2].x * v.z,
        m[0].y * v.x + m[1].y * v.y + m[2].y * v.z,
        m[0].z * v.x + m[1].z * v.y + m[2].z * v.z,
    );
    if !ray.alive {
        weight = 0.0;
    }
    return CameraRay(origin, direction, weight, nm, wavelength_weight, pixel, jitter);
}
