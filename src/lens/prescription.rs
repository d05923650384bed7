//! The lens as data: a [`Prescription`] of [`SurfaceRow`]s, front (scene side) to back (film
//! side), and its validation (undefined sags, surfaces crossing inside their clear apertures).
//!
//! Rows are thickness-after: each row's thickness is the distance to the next surface, the last
//! one's 0 (the film distance is not part of the lens). See [`crate::lens`] for the sign
//! conventions. Reading and writing files is [`crate::lens::io`]'s, which builds prescriptions
//! through [`Prescription::from_rows`]; nothing here knows a file format.

use std::fmt;
use std::path::{Path, PathBuf};

use super::coating::Coating;
use super::info::LensInfo;
use super::shape::{Asphere, Profile};
use super::spacing::{VariableSpacings, rows_at};
use crate::glass::Glass;
use crate::units::MAX_LENGTH_MM;

/// Radii at or beyond this magnitude (mm) are flat surfaces: a sphere that large has a sag
/// below 1e-8 mm over any real clear aperture, and treating it as a plane keeps f32 tracing
/// free of catastrophic cancellation.
pub const FLAT_RADIUS_MM: f64 = 1e8;

/// Apertures below a micrometre (under the wavelength of light) are refused.
pub const MIN_APERTURE_MM: f64 = 1e-3;

/// Refractive indices above this are refused: optical glasses lie between about 1.4 and 2.1,
/// and no transparent material reaches 5 (germanium, in the infrared, is about 4).
pub const MAX_INDEX: f64 = 10.0;

/// How to read the second column.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LensFormat {
    ThicknessAfter,
    GapBefore,
}

impl LensFormat {
    pub fn name(self) -> &'static str {
        match self {
            LensFormat::ThicknessAfter => "thickness-after",
            LensFormat::GapBefore => "gap-before",
        }
    }
}

impl std::str::FromStr for LensFormat {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "thickness-after" => Ok(LensFormat::ThicknessAfter),
            "gap-before" => Ok(LensFormat::GapBefore),
            other => Err(format!(
                "unknown lens format '{other}': use thickness-after or gap-before"
            )),
        }
    }
}

/// What kind of surface a row describes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SurfaceKind {
    /// A spherical refracting surface.
    Spherical,
    /// A plane refracting surface (`inf` or a huge radius in the file).
    Flat,
    /// The aperture stop on no refracting surface (radius 0 in a `.dat` file): a plane hole in
    /// an opaque diaphragm.
    Stop,
    /// A conic or even-polynomial asphere (see [`super::shape`]).
    Aspheric,
}

/// What every surface has, whatever its shape and glass: the part of a [`SurfaceRow`] that a
/// lens entity's [`LensSurface`](super::elements::LensSurface) carries (the asphere and glass
/// are components of their own there, so each can be added, changed or taken away alone).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceBase {
    /// Signed radius of curvature of the (base) surface at its vertex, mm; > 0 when the centre
    /// lies on the film side. Infinite for flat surfaces; 0 (flat) for a `.dat` file's stop.
    pub radius: f64,
    /// Distance to the next surface's vertex, mm (the last row's is 0).
    pub thickness: f64,
    /// Refractive index of the medium after the surface, toward the film (1 for air, the
    /// stop's 0 included; n_d with a glass).
    pub index: f64,
    /// Clear aperture diameter, mm.
    pub aperture: f64,
    /// 1-based line in the source file (0 for rows made in code).
    pub line: usize,
    /// This surface carries the aperture stop: its clear aperture is the diaphragm's opening,
    /// which `--aperture` and `--f-number` set. Usually a flat surface of its own; a lens file
    /// may also put the stop on a refracting surface.
    pub stop: bool,
}

/// One normalised row: thickness is the distance to the next surface (the last row's is 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceRow {
    /// Radius, thickness, index, clear aperture, source line and stop.
    pub base: SurfaceBase,
    /// Conic constant and polynomial terms ([`Asphere::NONE`] for a sphere or a plane).
    pub asphere: Asphere,
    /// The glass of the medium after the surface, when the file names one: it gives the
    /// dispersion around `base.index` (see [`SurfaceRow::index_at`]). `None`: a fixed index.
    pub glass: Option<Glass>,
}

impl SurfaceRow {
    /// A spherical (or flat, or with radius 0 the stop's) row as a `.dat` file gives it.
    pub fn new(radius: f64, thickness: f64, index: f64, aperture: f64) -> SurfaceRow {
        SurfaceRow {
            base: SurfaceBase {
                radius,
                thickness,
                index,
                aperture,
                line: 0,
                stop: radius == 0.0,
            },
            asphere: Asphere::NONE,
            glass: None,
        }
    }

    pub fn kind(&self) -> SurfaceKind {
        let curvature = self.curvature();
        if self.asphere.is_aspheric(curvature) {
            SurfaceKind::Aspheric
        } else if curvature != 0.0 {
            SurfaceKind::Spherical
        } else if self.base.stop {
            SurfaceKind::Stop
        } else {
            SurfaceKind::Flat
        }
    }

    /// Curvature 1/R of the base surface at the vertex (0 for flat surfaces and a bare stop).
    pub fn curvature(&self) -> f64 {
        if self.base.radius == 0.0 || self.base.radius.abs() >= FLAT_RADIUS_MM {
            0.0
        } else {
            1.0 / self.base.radius
        }
    }

    pub fn is_stop(&self) -> bool {
        self.base.stop
    }

    /// The same surface for tracing at the rows' own indices: equal but for the source line and
    /// the glass's dispersion (a copy of a lens file with other comments, or without its glass
    /// column, focuses where the original does).
    pub fn same_optics(&self, other: &SurfaceRow) -> bool {
        let optics = |row: &SurfaceRow| SurfaceRow {
            base: SurfaceBase {
                line: 0,
                ..row.base
            },
            glass: None,
            ..*row
        };
        optics(self) == optics(other)
    }

    /// The surface's shape, in f64.
    pub fn profile(&self) -> Profile<f64> {
        Profile::new(self.curvature(), &self.asphere, |v| v)
    }

    /// Index of the medium after the surface at `wavelength_nm`: the row's index (its n_d)
    /// shifted by the glass's dispersion, n(λ) = index + n_glass(λ) − n_glass(d), so the file's
    /// own n_d is kept exactly and a glass without data is the fixed index.
    pub fn index_at(&self, wavelength_nm: f64) -> f64 {
        match self.glass {
            Some(glass) => {
                self.base.index + glass.index(wavelength_nm)
                    - glass.index(crate::glass::FRAUNHOFER_D_NM)
            }
            None => self.base.index,
        }
    }
}

/// A parsed, validated lens.
#[derive(Clone, Debug, PartialEq)]
pub struct Prescription {
    /// File stem, e.g. `dgauss.50mm`.
    pub name: String,
    pub source: PathBuf,
    /// The layout the file was read in.
    pub format: LensFormat,
    pub rows: Vec<SurfaceRow>,
    /// What the file says about the design.
    pub info: LensInfo,
    /// Things worth telling the user that do not stop the lens from loading.
    pub warnings: Vec<String>,
    /// The gaps that change with zoom and focus (empty for a lens with fixed spacings).
    pub spacings: VariableSpacings,
    /// The coating the file gives each surface (layers listed from the scene side), one entry
    /// per row, or empty when the file gives none; `None`: the lens-wide default
    /// ([`CoatingModel`](super::coating::CoatingModel)) applies to that surface.
    pub coatings: Vec<Option<Coating>>,
}

/// A problem with a prescription file, located by line where it has one.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub struct PrescriptionError {
    pub file: PathBuf,
    pub line: Option<usize>,
    pub message: String,
}

impl fmt::Display for PrescriptionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{}: {}", self.file.display(), line, self.message),
            None => write!(f, "{}: {}", self.file.display(), self.message),
        }
    }
}

impl Prescription {
    /// A prescription from rows already in thickness-after form (edited lens entities),
    /// validated as a file would be.
    pub fn from_rows(
        name: &str,
        source: &Path,
        format: LensFormat,
        rows: Vec<SurfaceRow>,
    ) -> Result<Prescription, PrescriptionError> {
        if rows.is_empty() {
            return Err(PrescriptionError {
                file: source.to_path_buf(),
                line: None,
                message: "no surfaces".into(),
            });
        }
        let mut prescription = Prescription {
            name: name.to_string(),
            source: source.to_path_buf(),
            format,
            rows,
            info: LensInfo::default(),
            warnings: Vec::new(),
            spacings: VariableSpacings::default(),
            coatings: Vec::new(),
        };
        prescription.check_rows()?;
        prescription.trim_touching_rims();
        prescription.check_overlaps()?;
        Ok(prescription)
    }

    /// The prescription with variable `spacings`, each zoom position (at infinity and at close
    /// focus, for focus groups) validated as a lens of its own.
    pub fn with_spacings(
        mut self,
        spacings: VariableSpacings,
    ) -> Result<Prescription, PrescriptionError> {
        let error = |message: String| PrescriptionError {
            file: self.source.clone(),
            line: None,
            message,
        };
        spacings.check(&self.rows).map_err(error)?;
        let positions: Vec<Option<usize>> = if spacings.zoom.is_empty() {
            vec![None]
        } else {
            (0..spacings.zoom.len()).map(Some).collect()
        };
        let focus_distances: Vec<Option<f64>> = match &spacings.focus {
            Some(groups) => vec![Some(f64::INFINITY), Some(groups.close_focus_m)],
            None => vec![None],
        };
        for &position in &positions {
            for &metres in &focus_distances {
                let zoom = position.map(|i| &spacings.zoom[i]);
                let focus = spacings.focus.as_ref().zip(metres);
                let rows = rows_at(&self.rows, zoom, focus).map_err(error)?;
                let at = match (position, metres) {
                    (Some(i), Some(m)) if m.is_finite() => {
                        format!("zoom position {} focused at {m} m", i + 1)
                    }
                    (Some(i), _) => format!("zoom position {}", i + 1),
                    (None, Some(m)) if m.is_finite() => format!("focused at {m} m"),
                    (None, _) => "focused at infinity".into(),
                };
                Prescription::from_rows(&self.name, &self.source, self.format, rows).map_err(
                    |e| PrescriptionError {
                        message: format!("{at}: {}", e.message),
                        ..e
                    },
                )?;
            }
        }
        self.spacings = spacings;
        Ok(self)
    }

    /// The prescription with the coatings its file gives, one per row (`None`: the lens-wide
    /// default on that surface), each checked ([`Coating::check`]).
    pub fn with_coatings(
        mut self,
        coatings: Vec<Option<Coating>>,
    ) -> Result<Prescription, PrescriptionError> {
        let error = |message: String| PrescriptionError {
            file: self.source.clone(),
            line: None,
            message,
        };
        if coatings.len() != self.rows.len() {
            return Err(error(format!(
                "{} coatings for {} surfaces",
                coatings.len(),
                self.rows.len()
            )));
        }
        for (i, coating) in coatings.iter().enumerate() {
            if let Some(coating) = coating {
                coating
                    .check()
                    .map_err(|e| error(format!("surface {i}: coating: {e}")))?;
            }
        }
        self.coatings = if coatings.iter().all(Option::is_none) {
            Vec::new()
        } else {
            coatings
        };
        Ok(self)
    }

    /// The coating the file gives surface `i` (`None`: the lens-wide default applies).
    pub fn coating(&self, i: usize) -> Option<&Coating> {
        self.coatings.get(i).and_then(Option::as_ref)
    }

    /// Index of the aperture stop row.
    pub fn stop_index(&self) -> usize {
        self.rows.iter().position(SurfaceRow::is_stop).unwrap_or(0)
    }

    /// Distance from the first to the last vertex, mm.
    pub fn vertex_span(&self) -> f64 {
        self.rows[..self.rows.len() - 1]
            .iter()
            .map(|r| r.base.thickness)
            .sum()
    }

    /// Each row on its own, and the stops: everything [`Self::check_overlaps`] does not check.
    fn check_rows(&self) -> Result<(), PrescriptionError> {
        let error = |line: usize, message: String| PrescriptionError {
            file: self.source.clone(),
            line: (line > 0).then_some(line),
            message,
        };
        let stops: Vec<&SurfaceRow> = self.rows.iter().filter(|r| r.is_stop()).collect();
        match stops.len() {
            0 => {
                return Err(error(
                    0,
                    "no aperture stop: one row must have radius 0 (the diaphragm)".into(),
                ));
            }
            1 => {}
            _ => {
                return Err(error(
                    stops[1].base.line,
                    format!(
                        "a second aperture stop (radius 0; the first is on line {}): a lens has exactly one",
                        stops[0].base.line
                    ),
                ));
            }
        }
        let last = self.rows.len() - 1;
        for row in &self.rows {
            if row.base.aperture <= 0.0 {
                return Err(error(
                    row.base.line,
                    format!("aperture diameter {} must be positive", row.base.aperture),
                ));
            }
            if row.base.thickness < 0.0 {
                return Err(error(
                    row.base.line,
                    format!("negative thickness {} mm", row.base.thickness),
                ));
            }
            if row.base.index < 1.0 {
                return Err(error(
                    row.base.line,
                    format!(
                        "refractive index {} is below 1 (use 1 or 0 for air)",
                        row.base.index
                    ),
                ));
            }
            if row.base.aperture > MAX_LENGTH_MM || row.base.thickness > MAX_LENGTH_MM {
                return Err(error(
                    row.base.line,
                    format!(
                        "aperture {} mm or thickness {} mm is more than 100 m; lens files are in millimetres",
                        row.base.aperture, row.base.thickness
                    ),
                ));
            }
            if row.base.aperture < MIN_APERTURE_MM {
                return Err(error(
                    row.base.line,
                    format!(
                        "aperture diameter {} mm is below a micrometre; lens files are in millimetres",
                        row.base.aperture
                    ),
                ));
            }
            if row.base.index > MAX_INDEX {
                return Err(error(
                    row.base.line,
                    format!(
                        "refractive index {} is not a real material (glasses lie between 1.4 and 2.1; the limit is {MAX_INDEX})",
                        row.base.index
                    ),
                ));
            }
            if let Some(message) = undefined_sag(row) {
                return Err(error(row.base.line, message));
            }
        }
        if self.rows[last].is_stop() {
            return Err(error(
                self.rows[last].base.line,
                "the aperture stop cannot be the last surface: the rear element must be glass"
                    .into(),
            ));
        }
        Ok(())
    }

    /// Neighbouring surfaces whose clear apertures reach a little past the circle where they
    /// meet (a designer's rounded semi-diameters, an element whose edge is where its two
    /// surfaces meet): both apertures are reduced to that circle, as the real element's edge
    /// is, with a warning. Only when the circle lies within [`TOUCHING_RIM_TOLERANCE`] of the
    /// smaller aperture's rim; a crossing further in is left for [`Self::check_overlaps`] to
    /// refuse (a wrong thickness or layout, not a rounded aperture).
    fn trim_touching_rims(&mut self) {
        for i in 0..self.rows.len().saturating_sub(1) {
            let (front, back) = (&self.rows[i], &self.rows[i + 1]);
            let semi = front.base.aperture.min(back.base.aperture) / 2.0;
            let Some(meet) = meeting_height(front, back, semi) else {
                continue;
            };
            if meet < semi * (1.0 - TOUCHING_RIM_TOLERANCE) {
                continue;
            }
            // A diameter rounded down to a micrometre, so the surfaces do not cross inside it.
            let diameter = (2.0 * meet * 1000.0).floor() / 1000.0;
            if diameter < MIN_APERTURE_MM {
                continue;
            }
            let what = if front.base.index > 1.0 {
                "glass"
            } else {
                "air gap"
            };
            let gap = gap_at(front, back, semi);
            for row in [i, i + 1] {
                let base = &mut self.rows[row].base;
                if base.aperture > diameter {
                    self.warnings.push(format!(
                        "{}surface {} meets surface {} {meet:.3} mm from the axis, inside the clear apertures the file gives (the {what} between them would be {gap:.4} mm thick at ⌀{:.3} mm): its clear aperture ⌀{:.3} mm is reduced to ⌀{diameter} mm, where the surfaces meet",
                        line_prefix(base.line),
                        row + 1,
                        if row == i { i + 2 } else { i + 1 },
                        2.0 * semi,
                        base.aperture,
                    ));
                    base.aperture = diameter;
                }
            }
        }
    }

    /// Neighbouring surfaces must not cross inside their common clear aperture: a lens whose
    /// glass or air gaps have negative thickness anywhere is not buildable, and tracing it
    /// would send rays backwards.
    fn check_overlaps(&self) -> Result<(), PrescriptionError> {
        const SAMPLES: usize = 64;
        for pair in self.rows.windows(2) {
            let (front, back) = (&pair[0], &pair[1]);
            let semi = front.base.aperture.min(back.base.aperture) / 2.0;
            for k in 0..=SAMPLES {
                let h = semi * k as f64 / SAMPLES as f64;
                let gap = gap_at(front, back, h);
                if gap < -TOLERANCE_MM {
                    return Err(PrescriptionError {
                        file: self.source.clone(),
                        line: Some(back.base.line).filter(|&l| l > 0),
                        message: format!(
                            "this surface crosses the one before it {h:.3} mm from the axis, inside their clear apertures (the {} between them would be {gap:.4} mm thick there): check the thicknesses and clear apertures{}",
                            if front.base.index > 1.0 {
                                "glass"
                            } else {
                                "air gap"
                            },
                            if self.format == LensFormat::GapBefore
                                || self.source.extension().is_none_or(|e| e == "dat")
                            {
                                ", and the thickness column's layout (--lens-format)"
                            } else {
                                ""
                            }
                        ),
                    });
                }
            }
        }
        Ok(())
    }
}

/// Surfaces closer than this (mm) anywhere inside their clear apertures cross: a micrometre's
/// overlap is rounding in a file, not glass through glass.
const TOLERANCE_MM: f64 = 1e-6;

/// How far inside the smaller clear aperture's rim (a fraction of its semi-diameter) two
/// neighbouring surfaces may meet for the apertures to be reduced to where they meet, with a
/// warning, rather than the lens refused: a tenth. A designer's semi-diameters, rounded up or
/// left at a ray trace's value, reach a little past an element's edge (Canon's EF 35 mm f/2 as
/// DeepLens gives it: surfaces 8 and 9 meet 9.538 mm from the axis, 8.7 % inside the smaller
/// of its file's semi-apertures, 10.444 mm); a crossing further in is a wrong thickness, not an edge.
pub const TOUCHING_RIM_TOLERANCE: f64 = 0.1;

/// Axial thickness (mm) of the glass or air between `front` and `back` at height `h`.
fn gap_at(front: &SurfaceRow, back: &SurfaceRow, h: f64) -> f64 {
    front.base.thickness + sag(back, h) - sag(front, h)
}

/// The height at which `back` first comes closer to `front` than [`TOLERANCE_MM`] (they meet),
/// searched up to `semi`; `None` when they stay apart that far. Sampled as
/// [`Prescription::check_overlaps`] samples, then bisected to 1e-9 mm.
fn meeting_height(front: &SurfaceRow, back: &SurfaceRow, semi: f64) -> Option<f64> {
    const SAMPLES: usize = 2048;
    let crosses = |h: f64| gap_at(front, back, h) < 0.0;
    if crosses(0.0) {
        return Some(0.0);
    }
    let mut previous = 0.0;
    for k in 1..=SAMPLES {
        let h = semi * k as f64 / SAMPLES as f64;
        if crosses(h) {
            let (mut lo, mut hi) = (previous, h);
            while hi - lo > 1e-9 {
                let mid = 0.5 * (lo + hi);
                if crosses(mid) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return (gap_at(front, back, semi) < -TOLERANCE_MM).then_some(lo);
        }
        previous = h;
    }
    None
}

/// `"line N: "` for a row read from a file, nothing for one made in code.
fn line_prefix(line: usize) -> String {
    if line > 0 {
        format!("line {line}: ")
    } else {
        String::new()
    }
}

/// Sag (axial depth) of a surface at height `h` from the axis, measured from its vertex
/// toward +z (the film); at the rim of the conic where `h` lies beyond it (only for heights
/// outside a validated clear aperture).
pub fn sag(row: &SurfaceRow, h: f64) -> f64 {
    let profile = row.profile();
    profile.sag(h).unwrap_or_else(|| {
        // Beyond the rim: the rim's sag, 1/(κc), is where the conic part closes.
        let rim = profile.curvature * profile.conic_factor;
        if rim == 0.0 { 0.0 } else { 1.0 / rim }
    })
}

/// Why a row's surface is not defined over its whole clear aperture, if it is not: the conic
/// part needs 1 − (1+k)·c²·r² ≥ 0, and the polynomial must stay finite.
fn undefined_sag(row: &SurfaceRow) -> Option<String> {
    let semi = row.base.aperture / 2.0;
    let profile = row.profile();
    let defined = (0..=64).all(|k| {
        let h = semi * k as f64 / 64.0;
        profile.sag(h).is_some_and(f64::is_finite)
    });
    if defined {
        return None;
    }
    let c = row.curvature();
    let kappa = 1.0 + row.asphere.conic;
    if row.kind() == SurfaceKind::Spherical {
        return Some(format!(
            "clear aperture {} mm is wider than the sphere of radius {} mm allows",
            row.base.aperture, row.base.radius
        ));
    }
    let rim = if kappa * c * c > 0.0 {
        format!(
            "; the conic closes at r = {:.4} mm",
            1.0 / (kappa * c * c).sqrt()
        )
    } else {
        String::new()
    };
    Some(format!(
        "the surface's sag is undefined inside its clear aperture (semi-diameter {semi} mm): 1 − (1+k)·c²·r² < 0 with radius {} mm and conic {}{rim}",
        row.base.radius, row.asphere.conic
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sag_matches_sphere_geometry() {
        let row = SurfaceRow::new(-40.0, 0.0, 1.0, 20.0);
        let h: f64 = 10.0;
        let expected = -(40.0 - (40.0f64 * 40.0 - h * h).sqrt());
        assert!((sag(&row, h) - expected).abs() < 1e-12);
    }

    /// A biconvex element of radii ±50 mm, 2 mm thick at the axis: its sags, 50 − √(2500 − h²)
    /// each, close the 2 mm where √(2500 − h²) = 49, at h = √99 = 9.94987 mm. Then a stop and
    /// a rear element.
    fn biconvex(diameter: f64) -> Vec<SurfaceRow> {
        vec![
            SurfaceRow::new(50.0, 2.0, 1.5, diameter),
            SurfaceRow::new(-50.0, 5.0, 1.0, diameter),
            SurfaceRow::new(0.0, 5.0, 1.0, 8.0),
            SurfaceRow::new(100.0, 3.0, 1.5, 20.0),
            SurfaceRow::new(-100.0, 0.0, 1.0, 20.0),
        ]
    }

    #[test]
    fn apertures_a_little_past_where_the_surfaces_meet_are_reduced_to_it() {
        let meet = 99f64.sqrt();
        // 20.8 mm: the element's edge (⌀19.8997) lies 4.3 % inside the file's semi-aperture.
        let lens = Prescription::from_rows(
            "t",
            Path::new("t.dat"),
            LensFormat::ThicknessAfter,
            biconvex(20.8),
        )
        .expect("a hair's overlap loads");
        let expected = (2.0 * meet * 1000.0).floor() / 1000.0;
        assert_eq!(expected, 19.899);
        assert_eq!(lens.rows[0].base.aperture, expected);
        assert_eq!(lens.rows[1].base.aperture, expected);
        assert_eq!(
            lens.rows[3].base.aperture, 20.0,
            "the rear element is untouched"
        );
        assert_eq!(lens.warnings.len(), 2, "{:?}", lens.warnings);
        for warning in &lens.warnings {
            assert!(warning.contains("9.950 mm from the axis"), "{warning}");
            assert!(warning.contains("reduced to ⌀19.899 mm"), "{warning}");
        }
        // The glass is still (just) there at the new rim.
        let rim = expected / 2.0;
        assert!(gap_at(&lens.rows[0], &lens.rows[1], rim) >= 0.0);
        assert!(gap_at(&lens.rows[0], &lens.rows[1], rim) < 1e-3);
    }

    #[test]
    fn apertures_well_past_where_the_surfaces_meet_are_refused() {
        // ⌀24: the surfaces meet 17 % inside the rim, beyond the 10 % tolerance.
        let error = Prescription::from_rows(
            "t",
            Path::new("t.dat"),
            LensFormat::ThicknessAfter,
            biconvex(24.0),
        )
        .unwrap_err();
        assert!(
            error.message.contains("crosses the one before it"),
            "{error}"
        );
        // ⌀19.8: inside the edge, nothing to change.
        let lens = Prescription::from_rows(
            "t",
            Path::new("t.dat"),
            LensFormat::ThicknessAfter,
            biconvex(19.8),
        )
        .unwrap();
        assert!(lens.warnings.is_empty());
        assert_eq!(lens.rows[0].base.aperture, 19.8);
    }
}
