// The second kernel of a several-sample dispatch: each pixel adds its samples' weighted radiance
// (render_samples wrote them, sample k of pixel p at k·pixels + p) to its sums one at a time in
// index order: the same f32 additions, in the same order, as one pass per sample.

struct PassParams {
    width: u32,
    height: u32,
    sample: u32,
    step: u32,
    count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(3) @binding(0) var<storage, read> pass_params: PassParams;
@group(3) @binding(1) var<storage, read_write> pass_film: array<vec4f>;
@group(3) @binding(3) var<storage, read_write> pass_scratch: array<vec4f>;

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
