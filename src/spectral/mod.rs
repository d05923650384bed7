//! Light as a spectrum: the eye's colour matching, the wavelengths camera rays carry, and the
//! spectra the RGB path tracer's radiance stands for.
//!
//! # Conventions (used everywhere in this module)
//!
//! * Wavelengths are **air wavelengths in nanometres** (as glass catalogues and the CIE give
//!   them). A spectral render uses [`LAMBDA_MIN`]..[`LAMBDA_MAX`].
//! * Colour is **CIE 1931 XYZ** (2° observer) with Y = 1 for a white of unit luminance, and
//!   **linear sRGB** (ITU-R BT.709 primaries, D65 white) is the film's space, so sRGB
//!   (1, 1, 1) is D65 white with Y = 1.
//! * Scene radiance is RGB (glTF materials are); [`upsample`] turns it into spectral radiance
//!   at one wavelength, and [`SpectralFilm`] weighs a sample at that wavelength so that the
//!   film, summed over wavelengths drawn from [`sample_wavelength`], records the sample's XYZ
//!   (expressed in linear sRGB: a fixed linear map, so the film, checkpoints and shards keep
//!   their format).

pub mod observer;
pub mod upsample;
pub mod wavelength_sets;
pub mod wavelengths;

pub use observer::{SRGB_FROM_XYZ, XYZ_FROM_SRGB, cmf, d65};
pub use upsample::{SpectralFilm, spectral_film};
pub use wavelength_sets::{
    MAX_SET_SIZE, SetKnots, WavelengthSet, draw_wavelength_set, draw_wavelength_set_from, set_knots,
};
pub use wavelengths::{
    LAMBDA_MAX, LAMBDA_MIN, WavelengthKnots, WavelengthSample, sample_wavelength,
    sample_wavelength_from, wavelength_knots, wavelength_pdf,
};
