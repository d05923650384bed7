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
                let code = f32((dy + r) * (2 * r + 1) + (dx + r));
                let first = (k * pixels + u32(sy * width + sx)) * count;
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
