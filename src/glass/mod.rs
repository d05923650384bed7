//! Optical glass: refractive index as a function of wavelength.
//!
//! # Conventions (used everywhere in this module)
//!
//! * Wavelengths at the API are **air wavelengths in nanometres**, as glass catalogues give
//!   them; the formulas inside take µm.
//! * Indices are **relative to air** (catalogue convention, 20 °C), which is what a lens
//!   prescription's index column means.
//! * The reference lines are the Fraunhofer/spectral lines of the catalogues: d (He,
//!   587.5618 nm), F (H, 486.1327 nm), C (H, 656.2725 nm), e (Hg, 546.0740 nm) and g (Hg,
//!   435.8343 nm). The Abbe number is V_d = (n_d − 1) / (n_F − n_C).
//!
//! A lens surface refers to its glass by a small `Copy` value, [`Glass`]: either an entry of
//! the built-in [`catalogue()`] (1,610 glasses from Schott, Ohara, Hoya, Hikari, CDGM and Sumita;
//! see `assets/glass/README.md`) or, when a prescription gives only n_d and V_d, the
//! [`model`] dispersion through those two numbers.

pub mod catalogue;
pub mod formula;
pub mod lookup;
pub mod model;
pub mod partial;

use std::fmt;
use std::ops::RangeInclusive;

pub use catalogue::{Catalogue, CatalogueGlass, GlassStatus, Maker, catalogue};
pub use formula::DispersionFormula;
pub use lookup::GlassLookupError;
pub use model::{BuchdahlModel, ModelGlassError};

/// The helium d line, nm: where n_d is measured.
pub const FRAUNHOFER_D_NM: f64 = 587.5618;
/// The hydrogen F line, nm (blue end of V_d's dispersion n_F − n_C).
pub const FRAUNHOFER_F_NM: f64 = 486.1327;
/// The hydrogen C line, nm (red end of V_d's dispersion n_F − n_C).
pub const FRAUNHOFER_C_NM: f64 = 656.2725;
/// The mercury e line, nm (n_e, V_e).
pub const FRAUNHOFER_E_NM: f64 = 546.0740;
/// The mercury g line, nm (the partial dispersion P_g,F).
pub const FRAUNHOFER_G_NM: f64 = 435.8343;

/// The lines above with their catalogue letters, in the order data sheets list them.
pub const SPECTRAL_LINES: [(&str, f64); 5] = [
    ("F", FRAUNHOFER_F_NM),
    ("d", FRAUNHOFER_D_NM),
    ("C", FRAUNHOFER_C_NM),
    ("e", FRAUNHOFER_E_NM),
    ("g", FRAUNHOFER_G_NM),
];

/// Abbe number V = (n_mid − 1) / (n_blue − n_red).
pub fn abbe_number(n_mid: f64, n_blue: f64, n_red: f64) -> f64 {
    (n_mid - 1.0) / (n_blue - n_red)
}

/// A catalogue entry's position in [`Catalogue::glasses`]; valid for the built-in catalogue.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct GlassId(pub(crate) u16);

impl GlassId {
    /// Position in [`Catalogue::glasses`].
    pub fn index(self) -> usize {
        usize::from(self.0)
    }

    /// The built-in catalogue's entry.
    pub fn get(self) -> &'static CatalogueGlass {
        catalogue().get(self)
    }
}

/// A glass as a lens surface refers to it: small and `Copy`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Glass {
    /// An entry of the built-in catalogue: n(λ) from the maker's formula.
    Catalogue(GlassId),
    /// Only n_d and V_d are known: n(λ) from the [`model`] through them (exact at d, exact
    /// n_F − n_C). Build it with [`Glass::model`], which checks the numbers.
    Model { n_d: f64, v_d: f64 },
}

impl Glass {
    /// A model glass through `n_d` and `v_d`; refuses values no glass has (n_d ≤ 1, V_d ≤ 0,
    /// non-finite). See [`model::domain_warning`] for values far from every catalogue glass.
    pub fn model(n_d: f64, v_d: f64) -> Result<Glass, ModelGlassError> {
        model::check_model_values(n_d, v_d)?;
        Ok(Glass::Model { n_d, v_d })
    }

    /// Refractive index at `wavelength_nm` (air wavelength, nm).
    pub fn index(&self, wavelength_nm: f64) -> f64 {
        match *self {
            Glass::Catalogue(id) => id.get().index(wavelength_nm),
            Glass::Model { n_d, v_d } => BuchdahlModel::new(n_d, v_d).index(wavelength_nm),
        }
    }

    /// n_d: the catalogue's published value (or, for the one entry without it, its formula's).
    /// A catalogue glass's `index(FRAUNHOFER_D_NM)` comes from its formula and may differ from
    /// the published n_d by up to 3.8e-5 (Sumita; 6e-6 for the other makers).
    pub fn n_d(&self) -> f64 {
        match *self {
            Glass::Catalogue(id) => id.get().n_d,
            Glass::Model { n_d, .. } => n_d,
        }
    }

    /// V_d: the catalogue's published value (or its formula's where none is published).
    pub fn v_d(&self) -> f64 {
        match *self {
            Glass::Catalogue(id) => id.get().v_d,
            Glass::Model { v_d, .. } => v_d,
        }
    }

    /// The catalogue name (e.g. "N-BK7"); `None` for a model glass.
    pub fn name(&self) -> Option<&'static str> {
        match *self {
            Glass::Catalogue(id) => Some(id.get().name),
            Glass::Model { .. } => None,
        }
    }

    /// The maker (e.g. "Schott"); `None` for a model glass.
    pub fn maker(&self) -> Option<&'static str> {
        match *self {
            Glass::Catalogue(id) => Some(id.get().maker.name()),
            Glass::Model { .. } => None,
        }
    }

    /// Wavelengths (nm) where the catalogue formula is valid; `None` for a model glass (fitted
    /// over 400–700 nm, see [`model`]).
    pub fn valid_range_nm(&self) -> Option<RangeInclusive<f64>> {
        match *self {
            Glass::Catalogue(id) => Some(id.get().valid_range_nm()),
            Glass::Model { .. } => None,
        }
    }

    /// "N-BK7 (Schott)" or "n_d 1.5168, V_d 64.17". [`Catalogue::find`] reads the first form
    /// back.
    pub fn label(&self) -> String {
        match *self {
            Glass::Catalogue(id) => id.get().label(),
            Glass::Model { n_d, v_d } => format!("n_d {n_d}, V_d {v_d}"),
        }
    }
}

/// Whether `text` gives numbers (an n_d, or n_d,V_d for a model glass) rather than a glass's
/// name: glass names start with a letter.
pub fn looks_numeric(text: &str) -> bool {
    text.trim_start()
        .starts_with(|c: char| c.is_ascii_digit() || c == '.' || c == '-' || c == '+')
}

impl fmt::Display for Glass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.label())
    }
}
