// Wavelengths of spectral camera rays and what a sample at one adds to the film: the f32 code
// of spectral::sample_wavelength and spectral::SpectralFilm::film_rgb, reading the CPU's own
// tables (uploaded once by gpu::lens; they depend on no lens).

// The wavelength sampler's knots, the film's per-nm factors and the wavelength sets' knots, one
// buffer:
//   data[0 ..= knot_steps]: λ (nm) at cumulative probability k / knot_steps;
//   data[film_start + 6 i ..]: a(λ) (3 values) then b(λ) (3 values) at λ = lambda_min + i nm;
//   data[set_start + (count - 2) (set_steps + 1) + j]: for sets of `count` wavelengths, v' at
//   cumulative probability j / set_steps (spectral::set_knots).
struct SpectralTables {
    knot_steps: u32,
    film_start: u32,
    film_len: u32,
    lambda_min: f32,
    set_start: u32,
    set_steps: u32,
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
    let drawn = spectral_between_knots(0u, spectral_tables.knot_steps, u);
    return SpectralSample(drawn.x, drawn.y);
}

// The value for uniform `u` in [0, 1) of a sampler whose `steps` + 1 knots, at equal steps of
// cumulative probability, start at data[start] (linear between them), and the inverse of the
// density it was drawn with (spectral::between_knots).
fn spectral_between_knots(start: u32, steps: u32, u: f32) -> vec2f {
    // steps - 1e-3 in f32, as the CPU computes it: the last step's end stays out of reach.
    let x = clamp(u * f32(steps), 0.0, f32(steps) - 0.001);
    let k = min(u32(x), steps - 1u);
    let knot = spectral_tables.data[start + k];
    let width = spectral_tables.data[start + k + 1u] - knot;
    return vec2f(knot + (x - f32(k)) * width, f32(steps) * width);
}

// A camera sample's set of `count` wavelengths for uniform `u` (spectral::draw_wavelength_set):
// the hero's uniform number, warped within its stratum by the set's luminance, and the inverse of
// the density it was drawn with.
struct WavelengthSet {
    u: f32,
    inverse_density: f32,
}

fn draw_wavelength_set(u: f32, count: u32) -> WavelengthSet {
    if count < 2u {
        return WavelengthSet(u, 1.0);
    }
    let steps = spectral_tables.set_steps;
    let start = spectral_tables.set_start + (count - 2u) * (steps + 1u);
    let scaled = u * f32(count);
    let stratum = min(u32(scaled), count - 1u);
    let warped = spectral_between_knots(start, steps, scaled - f32(stratum));
    // 1 - 2^-24: the largest f32 below 1, as the CPU clamps.
    return WavelengthSet(min((f32(stratum) + warped.x) / f32(count), 0.99999994), warped.y);
}

// Three consecutive values of the film table from `start`.
fn spectral_film_factor(start: u32) -> vec3f {
    let data = &spectral_tables.data;
    return vec3f(data[start], data[start + 1u], data[start + 2u]);
}

// What a sample of linear-sRGB radiance `rgb` at `wavelength` (nm), drawn with density
// 1 / `wavelength_weight`, adds to the film, in linear sRGB: a(λ) · (b(λ) · rgb) / p(λ).
fn film_rgb(wavelength: f32, wavelength_weight: f32, rgb: vec3f) -> vec3f {
    let len = spectral_tables.film_len;
    let x = clamp(wavelength - spectral_tables.lambda_min, 0.0, f32(len - 1u));
    let i = min(u32(x), len - 2u);
    let t = x - f32(i);
    let p = spectral_tables.film_start + 6u * i;
    let a = spectral_film_factor(p) + t * (spectral_film_factor(p + 6u) - spectral_film_factor(p));
    let b = spectral_film_factor(p + 3u)
        + t * (spectral_film_factor(p + 9u) - spectral_film_factor(p + 3u));
    let radiance = (b.x * rgb.x + b.y * rgb.y + b.z * rgb.z) * wavelength_weight;
    return vec3f(a.x * radiance, a.y * radiance, a.z * radiance);
}
