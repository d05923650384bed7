//! Choosing a camera ray's wavelength.
//!
//! A sample at wavelength λ adds w(λ) = M⁻¹·c̄(λ)·D65(λ) / p(λ) (times the radiance's
//! spectrum relative to daylight) to its pixel's red, green and blue (see [`super::upsample`]):
//! the sRGB colour-matching functions, which have negative lobes. The density p that makes the
//! sum of the three channels' variances smallest is proportional to the length of the vector
//! they form, |M⁻¹·c̄(λ)·D65(λ)| (Cauchy–Schwarz), and that is the one used: it halves the blue
//! channel's variance against a density shaped like the eye's luminance response.
//!
//! The density is tabulated per 0.5 nm over [`LAMBDA_MIN`, `LAMBDA_MAX`] (linear in between),
//! and a uniform number maps to λ by inverting that piecewise-quadratic CDF exactly, so the
//! sampler draws exactly [`wavelength_pdf`].

use std::sync::OnceLock;

use super::observer::{SRGB_FROM_XYZ, apply, cmf, d65};

/// The wavelengths a spectral render draws from, nm. Below 360 nm and above 780 nm the CIE
/// observer's weights are below 2e-4 of their peak (and D65's table ends at 780 nm).
pub const LAMBDA_MIN: f64 = 360.0;
pub const LAMBDA_MAX: f64 = 780.0;

/// Density table steps per nanometre.
const PER_NM: usize = 2;

struct Sampler {
    /// The density at LAMBDA_MIN + i/PER_NM.
    pdf: Vec<f64>,
    /// Its integral up to there.
    cdf: Vec<f64>,
}

fn sampler() -> &'static Sampler {
    static SAMPLER: OnceLock<Sampler> = OnceLock::new();
    SAMPLER.get_or_init(|| {
        let count = (LAMBDA_MAX - LAMBDA_MIN) as usize * PER_NM + 1;
        let at = |i: usize| LAMBDA_MIN + i as f64 / PER_NM as f64;
        let shape: Vec<f64> = (0..count)
            .map(|i| {
                let l = at(i);
                let w = apply(&SRGB_FROM_XYZ, cmf().at(l).map(|c| c * d65().at(l)[0]));
                // A floor keeps every wavelength possible (and the density's inverse finite).
                (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt() + 1e-3
            })
            .collect();
        // The CDF of the piecewise-linear density, by exact trapezoids.
        let h = 1.0 / PER_NM as f64;
        let mut cdf = vec![0.0; count];
        for i in 1..count {
            cdf[i] = cdf[i - 1] + 0.5 * h * (shape[i - 1] + shape[i]);
        }
        let total = cdf[count - 1];
        let pdf: Vec<f64> = shape.iter().map(|s| s / total).collect();
        let cdf: Vec<f64> = cdf.iter().map(|c| c / total).collect();
        Sampler { pdf, cdf }
    })
}

/// The wavelength (nm) for uniform `u` ∈ [0, 1).
pub fn sample_wavelength(u: f64) -> f64 {
    let Sampler { pdf, cdf } = sampler();
    let h = 1.0 / PER_NM as f64;
    let target = u.clamp(0.0, 1.0);
    let i = cdf.partition_point(|&c| c < target).clamp(1, cdf.len() - 1) - 1;
    // Within a cell the CDF is quadratic: target − cdf_i = p₀·x + slope·x²/2, x ∈ [0, h].
    let (p0, p1) = (pdf[i], pdf[i + 1]);
    let slope = (p1 - p0) / h;
    let need = target - cdf[i];
    // The root in its cancellation-free form (p₀ > 0).
    let x = 2.0 * need / (p0 + (p0 * p0 + 2.0 * slope * need).max(0.0).sqrt());
    (LAMBDA_MIN + i as f64 * h + x.clamp(0.0, h)).clamp(LAMBDA_MIN, LAMBDA_MAX)
}

/// The density (per nm) with which [`sample_wavelength`] draws `lambda`.
pub fn wavelength_pdf(lambda: f64) -> f64 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let pdf = &sampler().pdf;
    let x = ((lambda - LAMBDA_MIN) * PER_NM as f64).min((pdf.len() - 1) as f64 - 1e-9);
    let i = x as usize;
    let t = x - i as f64;
    pdf[i] + t * (pdf[i + 1] - pdf[i])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn density_integrates_to_one_and_matches_the_sampler() {
        let n = 42_000;
        let step = (LAMBDA_MAX - LAMBDA_MIN) / n as f64;
        let integral: f64 = (0..n)
            .map(|i| wavelength_pdf(LAMBDA_MIN + (i as f64 + 0.5) * step) * step)
            .sum();
        assert!((integral - 1.0).abs() < 1e-6, "{integral}");
        // The sampler's CDF: the fraction of uniform u below u(λ) equals ∫ p up to λ.
        for target in [400.0, 500.0, 555.0, 650.0, 750.0] {
            let (mut lo, mut hi) = (0.0, 1.0);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if sample_wavelength(mid) < target {
                    lo = mid
                } else {
                    hi = mid
                }
            }
            let m = ((target - LAMBDA_MIN) / step) as usize;
            let cdf: f64 = (0..m)
                .map(|i| wavelength_pdf(LAMBDA_MIN + (i as f64 + 0.5) * step) * step)
                .sum();
            assert!((lo - cdf).abs() < 1e-7, "{target}: {lo} vs {cdf}");
        }
        assert_eq!(sample_wavelength(0.0), LAMBDA_MIN);
        assert!((sample_wavelength(1.0 - 1e-12) - LAMBDA_MAX).abs() < 1e-3);
    }
}
