//! What a lens file says about its design besides the surfaces: where it comes from and what
//! it was designed to do. Reported by `realcam lens` and `realcam lenses`; the nominal film
//! diagonal is the default film size when the user gives none.

/// Design data of a lens, all optional (pbrt's `.dat` files carry none of it).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct LensInfo {
    /// A descriptive name, e.g. "Canon EF 35mm f/2".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub title: Option<String>,
    /// Where the prescription comes from: patent, book, repository and file.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// The licence the prescription's data is used under.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub licence: Option<String>,
    /// Year of the design (patent filing or publication).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub year: Option<u32>,
    /// Published (nominal) focal length, mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub focal_length_mm: Option<f64>,
    /// Published (nominal) f-number.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub f_number: Option<f64>,
    /// Diagonal of the image format the lens was designed for (its image circle), mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub film_diagonal_mm: Option<f64>,
    /// The design's distance from the rear vertex to the image plane, mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub film_distance_mm: Option<f64>,
    /// Free-form notes (conversion remarks, glass substitutions).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub notes: Option<String>,
}
