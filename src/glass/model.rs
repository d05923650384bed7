//! Dispersion from n_d and V_d alone: a three-term Buchdahl model fitted to the catalogue.
//!
//! Buchdahl's chromatic coordinate (Buchdahl 1954; Robb & Mercado 1983) with λ in µm:
//!
//! ```text
//! ω(λ) = Δλ / (1 + α·Δλ),   Δλ = λ − λ_d,   α = 2.5
//! n(λ) = n_d + ν₁·ω + ν₂·ω² + ν₃·ω³
//! ```
//!
//! ω(λ_d) = 0, so n(λ_d) = n_d exactly. The principal dispersion is imposed exactly too:
//! with D = (n_d − 1)/V_d and Δₖ = ω_F^k − ω_C^k, ν₁Δ₁ + ν₂Δ₂ + ν₃Δ₃ = D. Writing ν₂ = D·a and
//! ν₃ = D·b leaves the curve's *shape* (a, b), free of both identities:
//!
//! ```text
//! n(λ) = n_d + D·[ ω/Δ₁ + a·(ω² − ω·Δ₂/Δ₁) + b·(ω³ − ω·Δ₃/Δ₁) ]
//! ```
//!
//! The shape of a real glass's curve follows mostly from where it sits on the glass map, so
//! a and b are low-order polynomials in x = 50/V_d − 1 and y = (n_d − 1.7)/0.2 over the basis
//! [`shape_basis`] = (1, x, x², x³, y, x·y), with coefficients [`SHAPE_A`], [`SHAPE_B`] fitted
//! by weighted linear least squares to every catalogue glass's formula at 400, 405, …, 700 nm
//! (`cargo run --release --example fit_glass_model` reproduces them and prints the fit).
//! Glasses weigh w = max(1 / (1 + (δ/5·10⁻⁵)²), 0.01), δ their
//! [`g_line_departure`](super::CatalogueGlass::g_line_departure): the model follows normal
//! glasses, while anomalous ones keep a small say where they are all there is (the densest
//! flints, the fluor crowns) so the polynomials do not run wild there.
//!
//! Outside the catalogue's range of n_d and V_d the shape is taken at the nearest point of
//! that range ([`N_D_RANGE`], [`V_D_RANGE`]); n_d and n_F − n_C stay exact. How close the model
//! comes to the catalogue: `tests/lens/glass_model.rs` (normal glasses within 3·10⁻⁴ over
//! 400–700 nm) and [`catalogue_deviation`].

use super::catalogue::{CatalogueGlass, catalogue};
use super::{FRAUNHOFER_C_NM, FRAUNHOFER_D_NM, FRAUNHOFER_F_NM};

/// Buchdahl's α for optical glass, per µm.
pub const BUCHDAHL_ALPHA: f64 = 2.5;

/// The fitted shape polynomials' coefficients over [`shape_basis`]: a = SHAPE_A · φ.
/// Printed by `cargo run --release --example fit_glass_model` (1,609 catalogue glasses with a
/// published n_d and V_d).
pub const SHAPE_A: [f64; 6] = [
    1.2443770911822205e-1,
    2.945319757849727e0,
    -1.723008541511116e0,
    5.075230277991112e-1,
    -6.5956332494005e-2,
    1.3108615729215591e-2,
];
/// b = SHAPE_B · φ (same fit).
pub const SHAPE_B: [f64; 6] = [
    6.356751436284852e-1,
    6.461325509860542e-1,
    -1.1246234958979677e0,
    2.523931242426037e-1,
    2.5084172434268537e-1,
    -3.3906242006300547e-1,
];

/// n_d range the shape was fitted over (the catalogue's 1.42537–2.154).
pub const N_D_RANGE: (f64, f64) = (1.425, 2.155);
/// V_d range the shape was fitted over (the catalogue's 16.48–97.8).
pub const V_D_RANGE: (f64, f64) = (16.4, 97.8);

/// Wavelength range (nm) the model is fitted and checked over.
pub const CHECK_RANGE_NM: (f64, f64) = (400.0, 700.0);

/// A model glass further than this from every catalogue glass (glass-code units, see
/// [`lookup`](super::lookup)) gets a [`domain_warning`].
pub const FAR_FROM_CATALOGUE: f64 = 50.0;

/// Buchdahl's chromatic coordinate ω at `wavelength_nm`.
pub fn buchdahl_omega(wavelength_nm: f64) -> f64 {
    let delta_um = (wavelength_nm - FRAUNHOFER_D_NM) * 1e-3;
    delta_um / (1.0 + BUCHDAHL_ALPHA * delta_um)
}

/// The shape polynomials' basis φ(n_d, V_d) = (1, x, x², x³, y, x·y), x = 50/V_d − 1,
/// y = (n_d − 1.7)/0.2, at (n_d, V_d) clamped to [`N_D_RANGE`] × [`V_D_RANGE`].
pub fn shape_basis(n_d: f64, v_d: f64) -> [f64; 6] {
    let x = 50.0 / v_d.clamp(V_D_RANGE.0, V_D_RANGE.1) - 1.0;
    let y = (n_d.clamp(N_D_RANGE.0, N_D_RANGE.1) - 1.7) / 0.2;
    [1.0, x, x * x, x * x * x, y, x * y]
}

/// The three curves the model adds, at `wavelength_nm`: n = n_d + D·(t₀ + a·t₁ + b·t₂), where
/// t₀ = ω/Δ₁ carries the principal dispersion and t₁, t₂ vanish at d and have equal values at
/// F and C (so a and b leave n_d and n_F − n_C alone).
pub fn shape_terms(wavelength_nm: f64) -> [f64; 3] {
    let (w_f, w_c) = (
        buchdahl_omega(FRAUNHOFER_F_NM),
        buchdahl_omega(FRAUNHOFER_C_NM),
    );
    let d1 = w_f - w_c;
    let d2 = w_f * w_f - w_c * w_c;
    let d3 = w_f * w_f * w_f - w_c * w_c * w_c;
    let w = buchdahl_omega(wavelength_nm);
    [w / d1, w * w - w * d2 / d1, w * w * w - w * d3 / d1]
}

/// A Buchdahl dispersion curve n(λ) = n_d + ν₁ω + ν₂ω² + ν₃ω³.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuchdahlModel {
    pub n_d: f64,
    pub nu: [f64; 3],
}

impl BuchdahlModel {
    /// The fitted model through `n_d` and `v_d`.
    pub fn new(n_d: f64, v_d: f64) -> BuchdahlModel {
        let phi = shape_basis(n_d, v_d);
        let dot = |c: &[f64; 6]| c.iter().zip(&phi).map(|(c, p)| c * p).sum::<f64>();
        BuchdahlModel::with_shape(n_d, v_d, dot(&SHAPE_A), dot(&SHAPE_B))
    }

    /// The curve through `n_d` and `v_d` with shape (a, b) (see the module docs).
    pub fn with_shape(n_d: f64, v_d: f64, a: f64, b: f64) -> BuchdahlModel {
        let (w_f, w_c) = (
            buchdahl_omega(FRAUNHOFER_F_NM),
            buchdahl_omega(FRAUNHOFER_C_NM),
        );
        let d1 = w_f - w_c;
        let d2 = w_f * w_f - w_c * w_c;
        let d3 = w_f * w_f * w_f - w_c * w_c * w_c;
        let dispersion = (n_d - 1.0) / v_d;
        let (nu2, nu3) = (dispersion * a, dispersion * b);
        let nu1 = (dispersion - nu2 * d2 - nu3 * d3) / d1;
        BuchdahlModel {
            n_d,
            nu: [nu1, nu2, nu3],
        }
    }

    /// n at `wavelength_nm`.
    pub fn index(&self, wavelength_nm: f64) -> f64 {
        let w = buchdahl_omega(wavelength_nm);
        self.n_d + w * (self.nu[0] + w * (self.nu[1] + w * self.nu[2]))
    }
}

/// Why (n_d, V_d) cannot be a model glass.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ModelGlassError {
    #[error("n_d {0} is not a glass's refractive index (a number above 1)")]
    IndexNotAboveOne(f64),
    #[error("V_d {0} is not an Abbe number (a positive number)")]
    AbbeNotPositive(f64),
}

/// Refuses values no glass has.
pub fn check_model_values(n_d: f64, v_d: f64) -> Result<(), ModelGlassError> {
    if !(n_d.is_finite() && n_d > 1.0) {
        return Err(ModelGlassError::IndexNotAboveOne(n_d));
    }
    if !(v_d.is_finite() && v_d > 0.0) {
        return Err(ModelGlassError::AbbeNotPositive(v_d));
    }
    Ok(())
}

/// A warning when (n_d, V_d) is far from every catalogue glass: the model then extrapolates.
pub fn domain_warning(n_d: f64, v_d: f64) -> Option<String> {
    let catalogue = catalogue();
    let &(id, distance) = catalogue.nearest(n_d, v_d, 1).first()?;
    (distance > FAR_FROM_CATALOGUE).then(|| {
        let g = catalogue.get(id);
        format!(
            "n_d {n_d}, V_d {v_d} is {distance:.0} glass-code units from the nearest catalogue \
             glass ({}: n_d {}, V_d {}); no known glass is there, so its dispersion is an \
             extrapolation of the model",
            g.label(),
            g.n_d,
            g.v_d
        )
    })
}

/// The wavelengths the model is fitted and checked at: 400, 405, …, 700 nm.
pub fn check_wavelengths_nm() -> impl Iterator<Item = f64> {
    let (lo, hi) = CHECK_RANGE_NM;
    (0..=((hi - lo) / 5.0) as usize).map(move |i| lo + 5.0 * i as f64)
}

/// Largest |model − formula| over the check wavelengths where the glass's formula is valid,
/// with the model taken through the glass's catalogue n_d and V_d.
pub fn catalogue_deviation(glass: &CatalogueGlass) -> f64 {
    let model = BuchdahlModel::new(glass.n_d, glass.v_d);
    check_wavelengths_nm()
        .filter(|&nm| glass.covers(nm))
        .map(|nm| (model.index(nm) - glass.index(nm)).abs())
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn omega_is_buchdahls_coordinate() {
        assert_eq!(buchdahl_omega(FRAUNHOFER_D_NM), 0.0);
        // λ = 487.5618 nm: Δλ = −0.1 µm, ω = −0.1 / 0.75.
        assert!((buchdahl_omega(487.5618) + 0.1 / 0.75).abs() < 1e-15);
    }

    #[test]
    fn any_shape_keeps_n_d_and_the_principal_dispersion() {
        for (n_d, v_d, a, b) in [
            (1.5168, 64.17, 0.0, 0.0),
            (1.80518, 25.36, 3.0, -40.0),
            (1.43875, 94.93, -2.0, 17.0),
        ] {
            let m = BuchdahlModel::with_shape(n_d, v_d, a, b);
            assert!((m.index(FRAUNHOFER_D_NM) - n_d).abs() < 1e-15);
            let dispersion = m.index(FRAUNHOFER_F_NM) - m.index(FRAUNHOFER_C_NM);
            assert!((dispersion - (n_d - 1.0) / v_d).abs() < 1e-15);
        }
    }

    #[test]
    fn impossible_values_are_refused() {
        assert!(check_model_values(1.5, 60.0).is_ok());
        assert_eq!(
            check_model_values(1.0, 60.0),
            Err(ModelGlassError::IndexNotAboveOne(1.0))
        );
        assert!(check_model_values(f64::NAN, 60.0).is_err());
        assert_eq!(
            check_model_values(1.5, 0.0),
            Err(ModelGlassError::AbbeNotPositive(0.0))
        );
        assert!(check_model_values(1.5, f64::INFINITY).is_err());
    }

    #[test]
    fn check_grid_spans_400_to_700_nm() {
        let grid: Vec<f64> = check_wavelengths_nm().collect();
        assert_eq!(grid.len(), 61);
        assert_eq!((grid[0], grid[60]), (400.0, 700.0));
    }
}
