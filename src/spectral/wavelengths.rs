//! Choosing a camera ray's wavelength.
//!
//! A sample at wavelength λ adds w(λ) = M⁻¹·c̄(λ)·D65(λ) / p(λ) (times the radiance's
//! spectrum relative to daylight) to its pixel's red, green and blue (see [`super::upsample`]):
//! the sRGB colour-matching functions, which have negative lobes. The density p that makes the
//! sum of the three channels' variances smallest is proportional to the length of the vector
//! they form, |M⁻¹·c̄(λ)·D65(λ)| (Cauchy–Schwarz), and that is the one used: it halves the blue
//! channel's variance against a density shaped like the eye's luminance response.
//!
//! That density is tabulated per 0.5 nm over [`LAMBDA_MIN`, `LAMBDA_MAX`] (linear in between)
//! and its CDF inverted at 4096 equal steps of probability; a uniform number then maps to λ by
//! linear interpolation between those knots. The density the sampler really draws with is
//! therefore constant within each step, 1/(4096·Δλ), and every sample carries its inverse
//! ([`WavelengthSample::inverse_pdf`]), so the film's estimate is exact whatever the table's
//! resolution (see [`super::upsample`]).

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
    /// λ at cumulative probabilities k/KNOTS.
    knots: Box<WavelengthKnots>,
}

/// Equal-probability steps of the sampler.
const KNOTS: usize = 4096;

/// λ (nm) at the cumulative probabilities k/4096, k = 0..=4096 (see [`wavelength_knots`]). A
/// fixed size, so that a look-up between two knots needs no bounds check.
pub type WavelengthKnots = [f32; KNOTS + 1];

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
        let mut sampler = Sampler {
            pdf,
            cdf,
            knots: Box::new([0.0; KNOTS + 1]),
        };
        let knots: Vec<f32> = (0..=KNOTS)
            .map(|k| sampler.invert_exactly(k as f64 / KNOTS as f64) as f32)
            .collect();
        sampler.knots.copy_from_slice(&knots);
        sampler
    })
}

impl Sampler {
    /// λ with CDF(λ) = `u`, by a binary search for the cell and its quadratic's root.
    fn invert_exactly(&self, u: f64) -> f64 {
        let h = 1.0 / PER_NM as f64;
        let target = u.clamp(0.0, 1.0);
        let i = self
            .cdf
            .partition_point(|&c| c < target)
            .clamp(1, self.cdf.len() - 1)
            - 1;
        // Within a cell: target − cdf_i = p₀·x + slope·x²/2, x ∈ [0, h].
        let (p0, p1) = (self.pdf[i], self.pdf[i + 1]);
        let slope = (p1 - p0) / h;
        let need = target - self.cdf[i];
        // The root in its cancellation-free form (p₀ > 0).
        let x = 2.0 * need / (p0 + (p0 * p0 + 2.0 * slope * need).max(0.0).sqrt());
        (LAMBDA_MIN + i as f64 * h + x.clamp(0.0, h)).clamp(LAMBDA_MIN, LAMBDA_MAX)
    }
}

/// A camera sample's wavelength and the inverse of the density it was drawn with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WavelengthSample {
    /// nm.
    pub nm: f32,
    /// 1 / p(λ), nm.
    pub inverse_pdf: f32,
}

/// The wavelength for uniform `u` ∈ [0, 1).
#[inline]
pub fn sample_wavelength(u: f32) -> WavelengthSample {
    sample_wavelength_from(wavelength_knots(), u)
}

/// [`sample_wavelength`] with the sampler's `knots` ([`wavelength_knots`]) looked up by the
/// caller: once for a whole loop of draws.
#[inline(always)]
pub fn sample_wavelength_from(knots: &WavelengthKnots, u: f32) -> WavelengthSample {
    let (nm, inverse_pdf) = between_knots(knots, u);
    WavelengthSample { nm, inverse_pdf }
}

/// The value for uniform `u` ∈ [0, 1) of a sampler given by `knots` at equal steps of
/// cumulative probability (linear between them), and the inverse of the density it was drawn
/// with: the number of steps times the width of the step it falls in.
#[inline(always)]
pub(crate) fn between_knots<const N: usize>(knots: &[f32; N], u: f32) -> (f32, f32) {
    const { assert!(N >= 2, "a sampler needs two knots at least") };
    let KnotSteps {
        steps,
        end,
        last_step,
    } = KnotSteps::of(N);
    let x = (u * steps).clamp(0.0, end);
    // Through i32, which vector units convert to directly (`x` is in [0, steps) or NaN, which
    // both conversions take to 0).
    let k = (x as i32 as usize).min(last_step);
    let width = knots[k + 1] - knots[k];
    (knots[k] + (x - k as f32) * width, steps * width)
}

/// The constants [`between_knots`] draws with from a table of knots, shared with the draws
/// that run many lanes at a time (`crate::lens::wavelength_draws`) so that both give the same
/// bits.
#[derive(Clone, Copy, Debug)]
pub(crate) struct KnotSteps {
    /// The table's steps.
    pub steps: f32,
    /// Where `u · steps` is clamped: the last step's end stays out of reach.
    pub end: f32,
    /// The last step's index.
    pub last_step: usize,
}

impl KnotSteps {
    /// For a table of `len` ≥ 2 knots.
    #[inline(always)]
    pub(crate) const fn of(len: usize) -> KnotSteps {
        let steps = len - 1;
        KnotSteps {
            steps: steps as f32,
            end: steps as f32 - 1e-3,
            last_step: steps - 1,
        }
    }
}

/// λ (nm) at the cumulative probabilities k/4096, k = 0..=4096: the knots
/// [`sample_wavelength`] interpolates between (what the GPU backend uploads).
pub fn wavelength_knots() -> &'static WavelengthKnots {
    &sampler().knots
}

/// The density (per nm) the sampler's knots were placed by (the sampler itself draws its
/// piecewise-constant approximation, see the module docs).
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
    fn design_density_integrates_to_one() {
        let n = 42_000;
        let step = (LAMBDA_MAX - LAMBDA_MIN) / n as f64;
        let integral: f64 = (0..n)
            .map(|i| wavelength_pdf(LAMBDA_MIN + (i as f64 + 0.5) * step) * step)
            .sum();
        assert!((integral - 1.0).abs() < 1e-6, "{integral}");
    }

    /// The sampler's density is what each sample says: the fraction of uniform numbers that
    /// land in a band equals the band's integral of 1/inverse_pdf; and it follows the design
    /// density closely.
    #[test]
    fn samples_carry_their_density() {
        let n = 1 << 20;
        let bands = [
            (360.0f32, 400.0f32),
            (400.0, 480.0),
            (480.0, 560.0),
            (560.0, 650.0),
            (650.0, 780.0),
        ];
        for (lo, hi) in bands {
            let (mut hits, mut integral) = (0usize, 0.0f64);
            for i in 0..n {
                let s = sample_wavelength((i as f32 + 0.5) / n as f32);
                if s.nm >= lo && s.nm < hi {
                    hits += 1;
                }
            }
            let m = 200_000;
            for i in 0..m {
                let l = lo as f64 + (hi - lo) as f64 * (i as f64 + 0.5) / m as f64;
                integral += wavelength_pdf(l) * (hi - lo) as f64 / m as f64;
            }
            let fraction = hits as f64 / n as f64;
            assert!(
                (fraction - integral).abs() < 2e-4,
                "{lo}–{hi}: {fraction} vs {integral}"
            );
        }
        // Each equal-probability step holds 1/KNOTS of the design density (so the drawn,
        // piecewise-constant density is the design's mean over the step).
        let knots = &sampler().knots;
        for k in 0..KNOTS {
            let (lo, hi) = (knots[k] as f64, knots[k + 1] as f64);
            let m = 64;
            let mass: f64 = (0..m)
                .map(|i| wavelength_pdf(lo + (hi - lo) * (i as f64 + 0.5) / m as f64))
                .sum::<f64>()
                * (hi - lo)
                / m as f64;
            assert!(
                (mass * KNOTS as f64 - 1.0).abs() < 2e-3,
                "step {k}: {lo}–{hi} holds {mass}"
            );
        }
        assert_eq!(sample_wavelength(0.0).nm, LAMBDA_MIN as f32);
        assert!((sample_wavelength(1.0 - 1e-7).nm - LAMBDA_MAX as f32).abs() < 0.5);
    }
}
