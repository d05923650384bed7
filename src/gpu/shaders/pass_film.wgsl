// The pass's film bindings and parameters, shared by pass.wgsl and accumulate.wgsl (compiled
// separately). Both are compiled after gpu::lens::shared_constants (SPLAT_RADIUS,
// MAX_WAVELENGTHS, FILM_POSITION_STEPS).

struct PassParams {
    width: u32,
    height: u32,
    // This dispatch's sample indices: sample + k·step for k < count.
    sample: u32,
    step: u32,
    count: u32,
    // Wavelengths per sample: the shares each sample leaves in the scratch buffer
    // (render_wavelengths).
    wavelengths: u32,
    // 1: the film's filter is wider than a pixel, so every share carries its film position
    // (pass_position_code) for accumulate_filtered; 0: the box, whose shares carry nothing
    // (one share per sample) or their splat codes.
    filtered: u32,
    _pad: u32,
}

// A storage buffer, not a uniform: lavapipe compiles a kernel variant per distinct uniform
// value it inlines, which the sample index changing every pass would make a compile per pass.
@group(3) @binding(0) var<storage, read> pass_params: PassParams;
// Per pixel, row-major: the RGB sums of weighted radiance (w unused).
@group(3) @binding(1) var<storage, read_write> pass_film: array<vec4f>;
// Sample k of pixel p at k·pixels + p, between render_samples and accumulate.wgsl; with several
// wavelengths per sample, its shares from (k·pixels + p)·wavelengths on (render_wavelengths).
@group(3) @binding(3) var<storage, read_write> pass_scratch: array<vec4f>;
// The film filter's normalised weights along one axis (gpu::film::filter_taps): per in-frame
// pattern of the three pixels a share reaches (bit k: pixel k of them lies inside) and per
// step of the share's position within its pixel, the weights of the three pixels.
@group(3) @binding(4) var<storage, read> pass_filter_taps: array<vec4f>;
// With several wavelengths per sample, per sample k and pixel p (at k·pixels + p), how far its
// shares reach: the most pixels any of them lands from p along either axis (0 when none
// counts). The gathers skip a pixel's shares beyond it without reading them.
@group(3) @binding(5) var<storage, read_write> pass_reach: array<u32>;

// A share in the scratch buffer says in w where it goes, as a whole number an f32 holds
// exactly: with the box filter, a splat code (dy + R)·(2R + 1) + (dx + R) for the offset
// (dx, dy) of its pixel within the splat radius R; with a wider filter, a position code
// (pass_position_code). A share that does not count gets PASS_NO_SPLAT.
const PASS_NO_SPLAT: f32 = -1.0;

// Position codes: (qy + B)·2B + (qx + B) for a film position (qx, qy) relative to the share's
// pixel's corner in filter steps, below 2²²; B = PASS_POSITION_BIAS steps is more than the
// SPLAT_RADIUS + 1 pixels a share may land from that corner.
const PASS_POSITION_BIAS: i32 = 1024;

fn pass_position_code(q: vec2i) -> f32 {
    let biased = q + vec2i(PASS_POSITION_BIAS);
    return f32(biased.y * (2 * PASS_POSITION_BIAS) + biased.x);
}

// The pixel a position `at` (filter steps from the frame's or a pixel's corner) lies in, in
// pixels from the same corner: floor(at / FILM_POSITION_STEPS), also below zero.
fn pass_pixel_of_step(at: i32) -> i32 {
    let steps = FILM_POSITION_STEPS;
    return (at - (((at % steps) + steps) % steps)) / steps;
}

fn pass_position_of(code: f32) -> vec2i {
    let c = i32(code);
    let span = 2 * PASS_POSITION_BIAS;
    return vec2i(c % span, c / span) - vec2i(PASS_POSITION_BIAS);
}
