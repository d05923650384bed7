//! RGB radiance as a spectrum, and what one wavelength sample of it adds to the film.
//!
//! The spectrum of linear-sRGB radiance (r, g, b) is
//!
//! ```text
//! S(λ) = k·D65(λ) · ρ(λ)ᵀ·C·(r, g, b)
//! ```
//!
//! where ρ = (ρ_r, ρ_g, ρ_b) are smooth reflectance-like bands that sum to 1 (logistic edges at
//! 490 and 590 nm), so sRGB white is exactly daylight (D65, scaled by k to unit luminance), and
//! C is the 3×3 matrix that makes the whole map exact: integrated against the CIE observer the
//! spectrum has the XYZ of (r, g, b) (to the tables' interpolation, ~1e-5). The map is linear,
//! so this holds for every colour, in gamut or not, and radiance sums stay radiance sums.
//!
//! A camera sample at wavelength λ drawn with density p(λ) ([`super::wavelengths`]) then adds
//!
//! ```text
//! film = M⁻¹·c̄(λ)·S(λ) / p(λ)        (M⁻¹: XYZ → linear sRGB, c̄ = (x̄, ȳ, z̄))
//! ```
//!
//! to its pixel: an unbiased estimate of the sample's XYZ, in sRGB, whatever the density.
//! [`SpectralFilm`] keeps both factors per nanometre, a(λ) = M⁻¹·c̄·k·D65 and b(λ) = Cᵀ·ρ, so
//! that film = a·(b·rgb)/p, and C is computed from the same interpolated tables, so the
//! estimate's expectation is the colour exactly.

use std::sync::OnceLock;

use super::observer::{SRGB_FROM_XYZ, apply, cmf, d65, invert};
use super::wavelengths::{LAMBDA_MAX, LAMBDA_MIN};

/// Band edges of the smooth basis (nm) and their width: chosen (over edges 470–520 and
/// 560–630 nm, widths 4–20 nm) so that C stays close to the identity and even the sRGB
/// primaries' spectra stay non-negative to 0.1 % of white's.
const BLUE_EDGE: f64 = 490.0;
const RED_EDGE: f64 = 590.0;
const EDGE_WIDTH: f64 = 6.0;

/// ρ_r, ρ_g, ρ_b at `lambda`: each in [0, 1], summing to 1.
pub fn bands(lambda: f64) -> [f64; 3] {
    let logistic = |x: f64| 1.0 / (1.0 + (-x).exp());
    let red = logistic((lambda - RED_EDGE) / EDGE_WIDTH);
    let blue = 1.0 - logistic((lambda - BLUE_EDGE) / EDGE_WIDTH);
    [red, 1.0 - red - blue, blue]
}

/// Samples per nanometre of the tables.
const PER_NM: usize = 1;

/// The per-wavelength factors of the film estimate (see the module docs), f32 for the Weight
/// stage's loops.
#[derive(Clone, Debug)]
pub struct SpectralFilm {
    /// Per nm from [`LAMBDA_MIN`]: a(λ) (3 values) then b(λ) (3 values).
    table: Vec<[f32; 6]>,
    /// k·D65 normalisation (luminance of sRGB white = 1) and C, for [`Self::spectrum`].
    scale: f64,
    correction: [[f64; 3]; 3],
}

/// The film weights, computed once.
pub fn spectral_film() -> &'static SpectralFilm {
    static FILM: OnceLock<SpectralFilm> = OnceLock::new();
    FILM.get_or_init(SpectralFilm::new)
}

impl SpectralFilm {
    fn new() -> SpectralFilm {
        let count = ((LAMBDA_MAX - LAMBDA_MIN) as usize) * PER_NM + 1;
        let grid = |i: usize| LAMBDA_MIN + i as f64 / PER_NM as f64;
        // k: the luminance of D65 over the rendered range is 1.
        let luminance: f64 = quadrature(|l| cmf().at(l)[1] * d65().at(l)[0]);
        let scale = 1.0 / luminance;
        let a_at = |l: f64| -> [f64; 3] {
            let xyz = cmf().at(l).map(|v| v * scale * d65().at(l)[0]);
            apply(&SRGB_FROM_XYZ, xyz)
        };
        let a: Vec<[f64; 3]> = (0..count).map(|i| a_at(grid(i))).collect();
        let rho: Vec<[f64; 3]> = (0..count).map(|i| bands(grid(i))).collect();
        let lerp = |table: &[[f64; 3]], l: f64| -> [f64; 3] {
            let x = ((l - LAMBDA_MIN) * PER_NM as f64).clamp(0.0, (count - 1) as f64);
            let i = (x as usize).min(count - 2);
            let t = x - i as f64;
            std::array::from_fn(|k| table[i][k] + t * (table[i + 1][k] - table[i][k]))
        };
        // Q = ∫ a·ρᵀ dλ with the interpolated tables the estimator reads; C = Q⁻¹ makes the
        // estimate's expectation, ∫ p·(a/p)·ρᵀ·C dλ, exactly the sample's colour.
        let mut q = [[0.0; 3]; 3];
        for (r, row) in q.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = quadrature(|l| lerp(&a, l)[r] * lerp(&rho, l)[c]);
            }
        }
        let correction = invert(q);
        let table = (0..count)
            .map(|i| {
                // b = Cᵀ·ρ.
                let b: [f64; 3] = std::array::from_fn(|k| {
                    (0..3).map(|j| correction[j][k] * rho[i][j]).sum::<f64>()
                });
                [a[i][0], a[i][1], a[i][2], b[0], b[1], b[2]].map(|v| v as f32)
            })
            .collect();
        SpectralFilm {
            table,
            scale,
            correction,
        }
    }

    /// What a sample of linear-sRGB radiance `rgb` at wavelength `lambda` (nm), drawn with
    /// density 1/`inverse_pdf` (see [`super::sample_wavelength`]), adds to the film, in linear
    /// sRGB.
    #[inline(always)]
    pub fn film_rgb(&self, lambda: f32, inverse_pdf: f32, rgb: [f32; 3]) -> [f32; 3] {
        let x = ((lambda - LAMBDA_MIN as f32) * PER_NM as f32)
            .clamp(0.0, (self.table.len() - 1) as f32);
        let i = (x as usize).min(self.table.len() - 2);
        let t = x - i as f32;
        let (p, q) = (&self.table[i], &self.table[i + 1]);
        let w: [f32; 6] = std::array::from_fn(|k| p[k] + t * (q[k] - p[k]));
        let radiance = (w[3] * rgb[0] + w[4] * rgb[1] + w[5] * rgb[2]) * inverse_pdf;
        [w[0] * radiance, w[1] * radiance, w[2] * radiance]
    }

    /// Per nm from [`LAMBDA_MIN`]: a(λ) then b(λ) (see the module docs), as
    /// [`Self::film_rgb`] interpolates them: what the GPU backend uploads.
    pub fn table(&self) -> &[[f32; 6]] {
        &self.table
    }

    /// The spectral radiance S(λ) of linear-sRGB radiance `rgb` (per nm; sRGB white has unit
    /// luminance ∫ȳ·S).
    pub fn spectrum(&self, rgb: [f64; 3], lambda: f64) -> f64 {
        let weights = apply(&self.correction, rgb);
        let rho = bands(lambda);
        self.scale * d65().at(lambda)[0] * (0..3).map(|j| rho[j] * weights[j]).sum::<f64>()
    }
}

/// ∫ f over the rendered range (Simpson's rule on 0.05 nm steps: exact for the tables' linear
/// pieces and far below 1e-9 for the smooth factors).
fn quadrature(f: impl Fn(f64) -> f64) -> f64 {
    const STEPS: usize = 8400;
    let h = (LAMBDA_MAX - LAMBDA_MIN) / STEPS as f64;
    let mut sum = f(LAMBDA_MIN) + f(LAMBDA_MAX);
    for i in 1..STEPS {
        let weight = if i % 2 == 1 { 4.0 } else { 2.0 };
        sum += weight * f(LAMBDA_MIN + i as f64 * h);
    }
    sum * h / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectral::{XYZ_FROM_SRGB, sample_wavelength};

    /// In-gamut colours: primaries, secondaries, greys, and mixes.
    fn colours() -> Vec<[f64; 3]> {
        let mut out = Vec::new();
        for r in [0.0, 0.3, 1.0] {
            for g in [0.0, 0.55, 1.0] {
                for b in [0.0, 0.2, 1.0] {
                    out.push([r, g, b]);
                }
            }
        }
        out
    }

    /// RGB → spectrum → XYZ (the CIE observer) → RGB returns the colour to 1e-3 (the issue's
    /// bound; here it is ~1e-5).
    #[test]
    fn round_trip_through_the_spectrum_is_exact() {
        let film = spectral_film();
        for rgb in colours() {
            let xyz: [f64; 3] =
                std::array::from_fn(|k| quadrature(|l| cmf().at(l)[k] * film.spectrum(rgb, l)));
            let back = apply(&SRGB_FROM_XYZ, xyz);
            for k in 0..3 {
                assert!((back[k] - rgb[k]).abs() < 1e-4, "{rgb:?} → {back:?}");
            }
        }
    }

    /// White is daylight: the spectrum of (1, 1, 1) is D65 (up to the exactness correction)
    /// and has unit luminance; in-gamut colours' spectra are smooth and non-negative.
    #[test]
    fn white_is_daylight_and_spectra_are_physical() {
        let film = spectral_film();
        let luminance = quadrature(|l| cmf().at(l)[1] * film.spectrum([1.0; 3], l));
        assert!((luminance - 1.0).abs() < 1e-4);
        let d65_ratio = |l: f64| film.spectrum([1.0; 3], l) / d65().at(l)[0];
        for l in [380.0, 450.0, 550.0, 650.0, 750.0] {
            assert!((d65_ratio(l) / d65_ratio(560.0) - 1.0).abs() < 0.03, "{l}");
        }
        for rgb in colours() {
            for l in (360..=780).step_by(5) {
                let s = film.spectrum(rgb, l as f64);
                assert!(
                    s > -2e-3 * film.spectrum([1.0; 3], l as f64),
                    "{rgb:?} at {l}: {s}"
                );
            }
        }
    }

    /// The film estimate over wavelengths drawn from the sampler averages to the sample's colour
    /// (stratified, so the check is tight): a non-dispersive lens renders the same colours with
    /// spectral camera rays.
    #[test]
    fn film_estimate_is_unbiased() {
        let film = spectral_film();
        let n = 200_000;
        for rgb in [
            [1.0, 1.0, 1.0],
            [0.8, 0.1, 0.05],
            [0.1, 0.2, 0.9],
            [0.0, 1.0, 0.0],
        ] {
            let mut sum = [0.0f64; 3];
            for i in 0..n {
                let s = sample_wavelength((i as f32 + 0.5) / n as f32);
                let v = film.film_rgb(s.nm, s.inverse_pdf, rgb.map(|c| c as f32));
                for k in 0..3 {
                    sum[k] += v[k] as f64;
                }
            }
            for k in 0..3 {
                assert!(
                    (sum[k] / n as f64 - rgb[k]).abs() < 2e-4,
                    "{rgb:?}: {:?}",
                    sum.map(|s| s / n as f64)
                );
            }
        }
        // The luminance matrix row the film uses is sRGB's.
        assert_eq!(XYZ_FROM_SRGB[1], [0.2126, 0.7152, 0.0722]);
    }
}
