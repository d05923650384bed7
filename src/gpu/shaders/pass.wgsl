// One sample pass: every invocation renders sample `sample` of one pixel through the stages the
// CPU runs as separate systems (GenerateRays → Trace → Shade → Weight → WriteFilm), keeping the
// ray in registers between them. Each pixel's sums belong to one invocation, so the film needs no
// atomics and a seed gives the same image on every run.

// What the passes counted, as 64-bit numbers in (low, high) word pairs, PASS_COUNT_ order: the
// eight ShadeStats counts (shade.wgsl's SHADE_COUNT_ indices), then camera rays the lens let
// through and samples rejected as non-finite. Integer sums, so the order of the adds cannot
// change them.
@group(3) @binding(2) var<storage, read_write> pass_counters: array<atomic<u32>, 20>;

const PASS_COUNT_LENS_PASSED: u32 = 8u;
const PASS_COUNT_REJECTED: u32 = 9u;
const PASS_COUNTS: u32 = 10u;

// A workgroup's counts, summed in shared memory first: one global add per workgroup and count
// instead of one per invocation.
var<workgroup> pass_group_counts: array<atomic<u32>, 10>;

fn pass_is_finite(v: vec3f) -> bool {
    return shade_is_finite(v.x) && shade_is_finite(v.y) && shade_is_finite(v.z);
}

// The radiance along a camera ray that passed the lens, times its weight (the Trace and Shade
// stages, counted as the CPU counts them).
fn pass_weighted_radiance(ray: CameraRay, sample: u32) -> vec3f {
    atomicAdd(&pass_group_counts[PASS_COUNT_LENS_PASSED], 1u);
    shade_counts[SHADE_COUNT_RAYS_TRACED] += 1u;
    let hit = scene_intersect(ray.origin, ray.direction, SHADE_FAR);
    var rng = shade_rng(ray.pixel_key, sample);
    return path_radiance(ray.origin, ray.direction, hit, &rng) * ray.weight;
}

// One sample of pixel (x, y): its weighted, finite film contribution, and in w the code of
// its film position (PASS_NO_SPLAT when it adds nothing).
fn pass_render_sample(x: u32, y: u32, sample: u32) -> vec4f {
    let ray = camera_ray(x, y, sample);
    var share = vec4f(0.0, 0.0, 0.0, PASS_NO_SPLAT);
    if ray.weight > 0.0 {
        var rgb = pass_weighted_radiance(ray, sample);
        if ray.wavelength > 0.0 {
            rgb = film_rgb(ray.wavelength, ray.wavelength_weight, rgb);
        }
        if pass_is_finite(rgb) {
            share = vec4f(rgb, pass_position_code(ray.film_position));
        } else {
            atomicAdd(&pass_group_counts[PASS_COUNT_REJECTED], 1u);
        }
    }
    return share;
}

// What this invocation counted, into the workgroup's counts, then (one invocation per count)
// into the 64-bit totals. Every invocation of the workgroup must call it (it has a barrier).
fn pass_add_counts(local: u32, counted: bool) {
    if counted {
        for (var i = 0u; i < 8u; i += 1u) {
            if shade_counts[i] != 0u {
                atomicAdd(&pass_group_counts[i], shade_counts[i]);
            }
        }
    }
    workgroupBarrier();
    if local < PASS_COUNTS {
        let count = atomicLoad(&pass_group_counts[local]);
        if count != 0u {
            let low = atomicAdd(&pass_counters[2u * local], count);
            if low + count < low {
                atomicAdd(&pass_counters[2u * local + 1u], 1u);
            }
        }
    }
}

// A dispatch of one sample per pixel (`sample`), added straight to the film.
@compute @workgroup_size(8, 8, 1)
fn render_pass(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) local: u32,
) {
    // No early return: every invocation must reach the barrier in pass_add_counts.
    let inside = id.x < pass_params.width && id.y < pass_params.height;
    if inside {
        let index = id.y * pass_params.width + id.x;
        let share = pass_render_sample(id.x, id.y, pass_params.sample);
        pass_film[index] = pass_film[index] + vec4f(share.xyz, 0.0);
    }
    pass_add_counts(local, inside);
}

// A dispatch of several samples per pixel (with a filter wider than a pixel, of any number),
// all in parallel: sample k (the grid's z) of pixel (x, y) into the scratch buffer;
// accumulate.wgsl then adds them to the film in index order (accumulate), or spreads them
// around their film positions (accumulate_filtered).
@compute @workgroup_size(8, 8, 1)
fn render_samples(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) local: u32,
) {
    let inside = id.x < pass_params.width && id.y < pass_params.height;
    if inside {
        let pixels = pass_params.width * pass_params.height;
        let sample = pass_params.sample + id.z * pass_params.step;
        var share = pass_render_sample(id.x, id.y, sample);
        if pass_params.filtered == 0u {
            share.w = 0.0;
        }
        pass_scratch[id.z * pixels + id.y * pass_params.width + id.x] = share;
    }
    pass_add_counts(local, inside);
}

// Several wavelengths per sample, all samples of the dispatch in parallel: sample k (the grid's
// z) of pixel (x, y) leaves one share per wavelength in the scratch buffer, each with the code
// of the pixel it belongs to (the box filter; accumulate_splats gathers them) or of its film
// position (a wider filter; accumulate_filtered spreads them). The Weight stage's rules: a
// sample with any non-finite share is rejected whole.
@compute @workgroup_size(8, 8, 1)
fn render_wavelengths(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) local: u32,
) {
    let inside = id.x < pass_params.width && id.y < pass_params.height;
    if inside {
        let pixels = pass_params.width * pass_params.height;
        let count = pass_params.wavelengths;
        let sample = pass_params.sample + id.z * pass_params.step;
        let first = (id.z * pixels + id.y * pass_params.width + id.x) * count;
        var wavelengths: CameraWavelengths;
        let ray = camera_ray_with(id.x, id.y, sample, &wavelengths);
        var shares: array<vec4f, MAX_WAVELENGTHS>;
        for (var k = 0u; k < MAX_WAVELENGTHS; k++) {
            if k >= count {
                break;
            }
            shares[k] = vec4f(0.0, 0.0, 0.0, PASS_NO_SPLAT);
        }
        if ray.weight > 0.0 {
            let radiance = pass_weighted_radiance(ray, sample);
            var finite = true;
            for (var k = 0u; k < MAX_WAVELENGTHS; k++) {
            if k >= count {
                break;
            }
                if wavelengths.factor[k] != 0.0 {
                    let rgb = film_rgb(wavelengths.nm[k], wavelengths.factor[k], radiance);
                    let o = wavelengths.offset[k] + vec2i(SPLAT_RADIUS, SPLAT_RADIUS);
                    var code = f32(o.y * (2 * SPLAT_RADIUS + 1) + o.x);
                    if pass_params.filtered != 0u {
                        code = pass_position_code(wavelengths.position[k]);
                    }
                    shares[k] = vec4f(rgb, code);
                    finite = finite && pass_is_finite(rgb);
                }
            }
            if !finite {
                atomicAdd(&pass_group_counts[PASS_COUNT_REJECTED], 1u);
                for (var k = 0u; k < MAX_WAVELENGTHS; k++) {
            if k >= count {
                break;
            }
                    shares[k] = vec4f(0.0, 0.0, 0.0, PASS_NO_SPLAT);
                }
            }
        }
        // How far the shares that count land from this pixel, in pixels along either axis.
        var reach = 0;
        for (var k = 0u; k < MAX_WAVELENGTHS; k++) {
            if k >= count {
                break;
            }
            pass_scratch[first + k] = shares[k];
            if shares[k].w != PASS_NO_SPLAT {
                var landed = wavelengths.offset[k];
                if pass_params.filtered != 0u {
                    let q = wavelengths.position[k];
                    landed = vec2i(pass_pixel_of_step(q.x), pass_pixel_of_step(q.y));
                }
                reach = max(reach, max(abs(landed.x), abs(landed.y)));
            }
        }
        pass_reach[id.z * pixels + id.y * pass_params.width + id.x] = u32(reach);
    }
    pass_add_counts(local, inside);
}
