// The pass's film bindings and parameters, shared by pass.wgsl and accumulate.wgsl (compiled
// separately). Both are compiled after gpu::lens::shared_constants (SPLAT_RADIUS, MAX_WAVELENGTHS).

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
    _pad1: u32,
    _pad2: u32,
}

// A storage buffer, not a uniform: lavapipe compiles a kernel variant per distinct uniform
// value it inlines, which the sample index changing every pass would make a compile per pass.
@group(3) @binding(0) var<storage, read> pass_params: PassParams;
// Per pixel, row-major: the RGB sums of weighted radiance (w unused).
@group(3) @binding(1) var<storage, read_write> pass_film: array<vec4f>;
// Sample k of pixel p at k·pixels + p, between render_samples and accumulate.wgsl; with several
// wavelengths per sample, its shares from (k·pixels + p)·wavelengths on (render_wavelengths).
@group(3) @binding(3) var<storage, read_write> pass_scratch: array<vec4f>;
