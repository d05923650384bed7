// Wavelengths of spectral camera rays and what a sample at one adds to the film: the f32 code
// of spectral::sample_wavelength and spectral::SpectralFilm::film_rgb, reading the CPU's own
// tables (uploaded once by gpu::lens; they depend on no lens).

// The wavelength sampler's knots and the film's per-nm factors, one buffer:
//   data[0 ..= knot_steps]: λ (nm) at cumulative probability k / knot_steps;
//   data[film_start + 6 i ..]: a(λ) (3 values) then b(λ) (3 values) at λ = lambda_min + i nm.
struct SpectralTables {
    knot_steps: u32,
    film_start: u32,
    film_len: u32,
    lambda_min: f32,
    data: array<f32>,
}

@group(0) @binding(3) var<storage, read> spectral_tables: SpectralTables;

// A camera sample's wavelength (nm) and the inverse of the density it was drawn with (nm).
struct SpectralSample {
    nm: f32,
    inverse_pdf: f32,
}

// The wavelength for uniform `u` in [0, 1): linear between equal-probability knots, so the
// density drawn with is constant within each step and every sample knows it exactly.
fn sample_wavelength(u: f32) -> SpectralSample {
    let steps = spectral_tables.knot_steps;
    // 4096 - 1e-3 in f32, as the CPU computes it: the last step's end stays out of reach.
    let x = clamp(u * f32(steps), 0.0, f32(steps) - 0.001);
    let k = min(u32(x), steps - 1u);
    let knot = spectral_tables.data[k];
    let width = spectral_tables.data[k + 1u] - knot;
    return SpectralSample(knot + (x - f32(k)) * width, f32(steps) * width);
}

// What a sample of linear-sRGB radiance `rgb` at `wavelength` (nm), drawn with density
// 1 / `wavelength_weight`, adds to the film, in linear sRGB: a(λ) · (b(λ) · rgb) / p(λ).
fn film_rgb(wavelength: f32, wavelength_weight: f32, rgb: vec3f) -> vec3f {
    let len = spectral_tables.film_len;
    let x = clamp(wavelength - spectral_tables.lambda_min, 0.0, f32(len - 1u));
    let i = min(u32(x), len - 2u);
    let t = x - f32(i);
    let p = spectral_tables.film_start + 6u * i;
    var w: array<f32, 6>;
    for (var k = 0u; k < 6u; k++) {
        let a = spectral_tables.data[p + k];
        w[k] = a + t * (spectral_tables.data[p + 6u + k] - a);
    }
    let radiance = (w[3] * rgb.x + w[4] * rgb.y + w[5] * rgb.z) * wavelength_weight;
    return vec3f(w[0] * radiance, w[1] * radiance, w[2] * radiance);
}
