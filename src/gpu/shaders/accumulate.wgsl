// The second kernel of a several-sample dispatch: each pixel adds its samples' weighted radiance
// (render_samples wrote them, sample k of pixel p at k·pixels + p) to its sums one at a time in
// index order: the same f32 additions, in the same order, as one pass per sample.

@compute @workgroup_size(64, 1, 1)
fn accumulate(@builtin(global_invocation_id) id: vec3u) {
    let pixels = pass_params.width * pass_params.height;
    let pixel = id.x;
    if pixel >= pixels {
        return;
    }
    var sums = pass_film[pixel];
    for (var k = 0u; k < pass_params.count; k += 1u) {
        sums = sums + pass_scratch[k * pixels + pixel];
    }
    pass_film[pixel] = sums;
}

// The second kernel of a dispatch with several wavelengths per sample: each pixel gathers, for
// every sample index in order, the shares of the pixels within the splat radius whose code
// names it (render_wavelengths), then adds the sample's total to its sums: a fixed order, so a
// seed gives the same image on every run.
@compute @workgroup_size(64, 1, 1)
fn accumulate_splats(@builtin(global_invocation_id) id: vec3u) {
    let pixels = pass_params.width * pass_params.height;
    let pixel = id.x;
    if pixel >= pixels {
        return;
    }
    let width = i32(pass_params.width);
    let height = i32(pass_params.height);
    let x = i32(pixel % pass_params.width);
    let y = i32(pixel / pass_params.width);
    let r = SPLAT_RADIUS;
    let count = pass_params.wavelengths;
    var sums = pass_film[pixel];
    for (var k = 0u; k < pass_params.count; k += 1u) {
        var sample = vec4f(0.0);
        for (var dy = -r; dy <= r; dy++) {
            for (var dx = -r; dx <= r; dx++) {
                // A share of pixel (x − dx, y − dy) lands here when its offset is (dx, dy).
                let sx = x - dx;
                let sy = y - dy;
                if sx < 0 || sy < 0 || sx >= width || sy >= height {
                    continue;
                }
                let source = k * pixels + u32(sy * width + sx);
                if max(abs(dx), abs(dy)) > i32(pass_reach[source]) {
                    continue;
                }
                let code = f32((dy + r) * (2 * r + 1) + (dx + r));
                let first = source * count;
                for (var w = 0u; w < count; w++) {
                    let share = pass_scratch[first + w];
                    if share.w == code {
                        sample = sample + vec4f(share.xyz, 0.0);
                    }
                }
            }
        }
        sums = sums + sample;
    }
    pass_film[pixel] = sums;
}

fn pass_inside(pixel: i32, extent: i32) -> u32 {
    return select(0u, 1u, pixel >= 0 && pixel < extent);
}

// Along one axis of `extent` pixels, the weight pixel `pixel` takes from a share at `at`
// (filter steps from the frame's edge): Filter::taps's, 0 beyond its three pixels. Those
// weights depend only on the step within the pixel and on which of the three pixels lie
// inside the frame, so they come from a table made on the CPU by Filter::taps itself
// (pass_filter_taps): the CPU's bit for bit, however this GPU rounds exp and division.
fn pass_filter_tap(at: i32, pixel: i32, extent: i32) -> f32 {
    let steps = FILM_POSITION_STEPS;
    let own = pass_pixel_of_step(at);
    let within = at - own * steps;
    let k = pixel - (own - 1);
    if k < 0 || k > 2 {
        return 0.0;
    }
    let inside = pass_inside(own - 1, extent) | (pass_inside(own, extent) << 1u)
        | (pass_inside(own + 1, extent) << 2u);
    return pass_filter_taps[inside * u32(steps) + u32(within)][k];
}

// The second kernel of a dispatch with a filter wider than a pixel, after render_samples (one
// share per sample) or render_wavelengths (one per wavelength): each pixel gathers, for every
// sample index in order, what the shares of the pixels around it add to it through the filter,
// then adds the sample's total to its sums: a fixed order, so a seed gives the same image on
// every run, and a dispatch of several samples adds what single ones would.
@compute @workgroup_size(64, 1, 1)
fn accumulate_filtered(@builtin(global_invocation_id) id: vec3u) {
    let pixels = pass_params.width * pass_params.height;
    let pixel = id.x;
    if pixel >= pixels {
        return;
    }
    let width = i32(pass_params.width);
    let height = i32(pass_params.height);
    let x = i32(pixel % pass_params.width);
    let y = i32(pixel / pass_params.width);
    let count = max(pass_params.wavelengths, 1u);
    // The pixels whose shares can reach this one: a share lands at most SPLAT_RADIUS pixels
    // before its pixel's corner (a companion wavelength; the film jitter, alone, not at all)
    // and one pixel further after it (on the far edge of the last pixel it may land in, once
    // rounded to the filter's grid), and the filter weighs the pixels whose centres lie closer
    // than its radius, 1.5 pixels (its profile vanishes there): those within `around`.
    var around = 1;
    if count > 1u {
        around = SPLAT_RADIUS + 1;
    }
    var sums = pass_film[pixel];
    for (var k = 0u; k < pass_params.count; k += 1u) {
        var sample = vec3f(0.0);
        for (var sy = max(y - around, 0); sy <= min(y + around, height - 1); sy++) {
            for (var sx = max(x - around, 0); sx <= min(x + around, width - 1); sx++) {
                let source = k * pixels + u32(sy * width + sx);
                // A share in pixel `own` of its source weighs pixels own − 1 … own + 1 only:
                // beyond its reach + 1 a source adds nothing here.
                let distance = max(abs(sx - x), abs(sy - y));
                if distance > 1 && distance > i32(pass_reach[source]) + 1 {
                    continue;
                }
                let first = source * count;
                for (var w = 0u; w < count; w++) {
                    let share = pass_scratch[first + w];
                    if share.w == PASS_NO_SPLAT {
                        continue;
                    }
                    let q = pass_position_of(share.w);
                    let wx = pass_filter_tap(sx * FILM_POSITION_STEPS + q.x, x, width);
                    if wx == 0.0 {
                        continue;
                    }
                    let wy = pass_filter_tap(sy * FILM_POSITION_STEPS + q.y, y, height);
                    if wy == 0.0 {
                        continue;
                    }
                    sample = sample + share.xyz * (wx * wy);
                }
            }
        }
        sums = sums + vec4f(sample, 0.0);
    }
    pass_film[pixel] = sums;
}
