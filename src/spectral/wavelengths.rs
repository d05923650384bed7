//! Choosing a camera ray's wavelength: where the eye is sensitive, sampled densely.
//!
//! The density p(λ) ∝ 1/cosh²(a·(λ − 538 nm)), a = 0.0072 nm⁻¹ (pbrt-v4's visible-wavelength
//! density: close to the shape of x̄ + ȳ + z̄, so the film's XYZ weights vary little across
//! samples), on [`LAMBDA_MIN`, `LAMBDA_MAX`]. Its CDF is a difference of tanh, so a uniform
//! number maps to λ in closed form.

/// The wavelengths a spectral render draws from, nm. Below 360 nm and above 780 nm the CIE
/// observer's weights are below 2e-4 of their peak (and D65's table ends at 780 nm).
pub const LAMBDA_MIN: f64 = 360.0;
pub const LAMBDA_MAX: f64 = 780.0;

const CENTRE: f64 = 538.0;
const SHARPNESS: f64 = 0.0072;

fn tanh_at(lambda: f64) -> f64 {
    (SHARPNESS * (lambda - CENTRE)).tanh()
}

/// The wavelength (nm) for uniform `u` ∈ [0, 1).
pub fn sample_wavelength(u: f64) -> f64 {
    let (lo, hi) = (tanh_at(LAMBDA_MIN), tanh_at(LAMBDA_MAX));
    let lambda = CENTRE + (lo + u * (hi - lo)).atanh() / SHARPNESS;
    lambda.clamp(LAMBDA_MIN, LAMBDA_MAX)
}

/// The density (per nm) with which [`sample_wavelength`] draws `lambda`.
pub fn wavelength_pdf(lambda: f64) -> f64 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let c = (SHARPNESS * (lambda - CENTRE)).cosh();
    SHARPNESS / (c * c) / (tanh_at(LAMBDA_MAX) - tanh_at(LAMBDA_MIN))
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
        assert!((integral - 1.0).abs() < 1e-9, "{integral}");
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
            assert!((lo - cdf).abs() < 1e-6, "{target}: {lo} vs {cdf}");
        }
        assert_eq!(sample_wavelength(0.0), LAMBDA_MIN);
        assert!((sample_wavelength(1.0 - 1e-12) - LAMBDA_MAX).abs() < 1e-6);
    }
}
