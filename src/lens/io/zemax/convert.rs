//! Building a [`Prescription`] from a parsed `.zmx` file, in named steps: refuse what realcam
//! cannot represent (the system, then each surface in order), read each surface's medium and
//! row in millimetres, place and size the stop from the system aperture, find the clear
//! apertures the file leaves open, and validate, naming the `SURF` of any problem.

use std::path::Path;

use super::configurations;
use super::decode::number;
use super::parse::{ZemaxSurface, ZemaxSystem};
use crate::glass::{FRAUNHOFER_D_NM, Glass, catalogue};
use crate::lens::clear_aperture::{self, FieldPoint};
use crate::lens::coating::{Coating, CoatingModel};
use crate::lens::info::LensInfo;
use crate::lens::io::GlassSubstitute;
use crate::lens::prescription::{
    LensFormat, Prescription, PrescriptionError, SurfaceBase, SurfaceRow,
};
use crate::lens::shape::{ASPHERIC_TERMS, Asphere};
use crate::lens::spacing::VariableSpacings;

/// Surface types realcam traces.
const SUPPORTED_TYPES: [&str; 2] = ["STANDARD", "EVENASPH"];

/// What the surface types realcam refuses are, for the message.
fn describe_type(kind: &str) -> &'static str {
    match kind {
        "COORDBRK" => "a coordinate break (decentre or tilt of what follows)",
        "TOROIDAL" => "a toroidal surface (not rotationally symmetric)",
        "BICONICX" | "BICONIC" => "a biconic surface (not rotationally symmetric)",
        "PARAXIAL" | "PARAXIAX" => "an ideal paraxial lens (no real surface to trace)",
        "DGRATING" | "ELLIGRAT" | "VLSGRATE" => "a diffraction grating",
        "BINARY_1" | "BINARY_2" | "BINARY_3" | "BINARY_4" | "RADGRAT" => {
            "a diffractive (binary) surface"
        }
        "ODDASPHE" | "ODDASPH" => "an odd asphere (odd powers of r)",
        "XOSPHERE" | "EXTASPHE" => "an extended polynomial asphere",
        "SZERNSAG" | "ZERNSAG" | "SZERNPHA" => "a Zernike surface (not rotationally symmetric)",
        "XYPOLY" | "POLYNOMI" => "an xy-polynomial surface (not rotationally symmetric)",
        "TILTSURF" => "a tilted surface",
        "GRINSUR1" | "GRINSUR2" | "GRINSUR3" | "GRINSUR5" | "GRADIENT" => "a gradient-index medium",
        "USERSURF" | "DLL" => "a user-defined (DLL) surface",
        "NONSEQCO" => "a non-sequential component",
        _ => "a surface type realcam does not know",
    }
}

/// The medium after a surface as its `GLAS` line names it.
enum Medium {
    Air,
    /// n_d only (a model glass with V_d = 0: Zemax's constant index).
    Constant(f64),
    Glass(Glass),
}

/// The validated prescription of a parsed `.zmx` file.
pub(super) fn convert(
    system: &ZemaxSystem,
    surfaces: &[ZemaxSurface],
    source: &Path,
    substitutes: &[GlassSubstitute],
) -> Result<Prescription, PrescriptionError> {
    let conversion = Conversion::new(system, surfaces, source, substitutes)?;
    for surface in conversion.lens {
        conversion.refuse_surface(surface)?;
    }
    conversion.refuse_object_na()?;
    let (mut rows, mut missing_aperture) = conversion.rows()?;
    let stop = place_stop(&mut rows).map_err(|m| conversion.error(None, m))?;
    conversion.size_stop(&mut rows, stop, &mut missing_aperture)?;
    if missing_aperture.iter().any(|&m| m) {
        conversion.fill_clear_apertures(&mut rows, &missing_aperture)?;
    }
    let configurations = configurations::read(system, rows.len(), stop, conversion.scale)
        .map_err(|(line, m)| conversion.error(Some(line), m))?;
    if let Some(configurations) = &configurations {
        configurations.widen(&mut rows, stop);
    }
    let mut prescription = conversion.validate(rows)?;
    if let Some(configurations) = configurations {
        let (positions, warnings) = configurations
            .zoom_positions(system, &prescription.rows, stop, conversion.scale)
            .map_err(|m| conversion.error(system.configurations.map(|(_, line)| line), m))?;
        prescription = prescription.with_spacings(VariableSpacings {
            zoom: positions,
            focus: None,
        })?;
        prescription.warnings.extend(warnings);
    }
    prescription.info = conversion.info();
    prescription
        .warnings
        .extend(conversion.unused_substitutes());
    let (coatings, warnings) = conversion.coatings(&prescription.rows);
    prescription = prescription.with_coatings(coatings)?;
    prescription.warnings.extend(warnings);
    Ok(prescription)
}

/// A `COAT` name as realcam reads it, on a surface between indices `before` and `after`.
#[derive(Debug, PartialEq)]
enum ZemaxCoating {
    /// A coating realcam represents, or `None` for no coating named (the lens-wide default).
    Known(Option<Coating>),
    /// `HEAR1`/`HEAR2` between two glasses: the multi-coating model is for air–glass surfaces.
    Cemented,
    /// A name not in the sample `COATING.DAT` realcam knows.
    Unknown,
}

/// The coating a `COAT` line names: `AR` (the sample `COATING.DAT`'s quarter wave of MgF2 at
/// 550 nm), `HEAR1`/`HEAR2` (its high-efficiency multi-layers: realcam's multi-coating model),
/// `I.<digits>` (Zemax's ideal coating of intensity transmission 0.<digits>, the rest
/// reflected at every wavelength), and no name or `NONE` for none.
fn zemax_coating(name: &str, before: f64, after: f64) -> ZemaxCoating {
    let upper = name.to_ascii_uppercase();
    let coating = match upper.as_str() {
        "" | "NONE" => return ZemaxCoating::Known(None),
        "AR" => Coating::single_layer(1.38, 550.0),
        "HEAR1" | "HEAR2" => {
            let is_air = |n: f64| (n - 1.0).abs() < 1e-3;
            if !is_air(before) && !is_air(after) {
                return ZemaxCoating::Cemented;
            }
            CoatingModel::Multi.coating_for(before, after)
        }
        _ => {
            let Some(digits) = upper
                .strip_prefix("I.")
                .filter(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
            else {
                return ZemaxCoating::Unknown;
            };
            let transmission: f64 = format!("0.{digits}").parse().unwrap_or(0.0);
            Coating::Measured(vec![(550.0, 1.0 - transmission)])
        }
    };
    ZemaxCoating::Known(Some(coating))
}

/// One file's conversion: what every step reads, and the file to name in errors.
struct Conversion<'a> {
    system: &'a ZemaxSystem,
    /// Every `SURF` block, the object (first) and the image (last) included.
    surfaces: &'a [ZemaxSurface],
    /// The lens: the surfaces between the object and the image.
    lens: &'a [ZemaxSurface],
    source: &'a Path,
    /// Millimetres per file unit.
    scale: f64,
    /// Glasses to read in place of the names the file gives (`--glass NAME=GLASS`).
    substitutes: &'a [GlassSubstitute],
}

impl<'a> Conversion<'a> {
    /// Refuses a file whose system realcam cannot read (not sequential, no lens surface).
    fn new(
        system: &'a ZemaxSystem,
        surfaces: &'a [ZemaxSurface],
        source: &'a Path,
        substitutes: &'a [GlassSubstitute],
    ) -> Result<Conversion<'a>, PrescriptionError> {
        let error = |line: Option<usize>, message: String| PrescriptionError {
            file: source.to_path_buf(),
            line,
            message,
        };
        if let Some((mode, line)) = &system.mode
            && !mode.eq_ignore_ascii_case("SEQ")
        {
            return Err(error(
                Some(*line),
                format!("MODE {mode}: realcam reads sequential (MODE SEQ) lens files only"),
            ));
        }
        if surfaces.len() < 3 {
            return Err(error(
                None,
                format!(
                    "has {} SURF block(s); a lens needs the object surface, at least one lens surface and the image surface",
                    surfaces.len()
                ),
            ));
        }
        let (scale, _) = system.unit_scale.clone().unwrap_or((1.0, "MM".into()));
        Ok(Conversion {
            system,
            surfaces,
            lens: &surfaces[1..surfaces.len() - 1],
            source,
            scale,
            substitutes,
        })
    }

    fn error(&self, line: Option<usize>, message: String) -> PrescriptionError {
        PrescriptionError {
            file: self.source.to_path_buf(),
            line,
            message,
        }
    }

    /// An error on `line` of surface `s`'s block, naming its `SURF`.
    fn at(&self, s: &ZemaxSurface, line: usize, what: String) -> PrescriptionError {
        self.error(Some(line), format!("SURF {}: {what}", s.number))
    }

    /// Refuses a lens surface realcam cannot represent: its type, a mirror, an aperture that is
    /// not a centred disc, asphere terms beyond realcam's, a thickness of infinity.
    fn refuse_surface(&self, s: &ZemaxSurface) -> Result<(), PrescriptionError> {
        if let Some((kind, line)) = &s.kind
            && !SUPPORTED_TYPES.contains(&kind.as_str())
        {
            return Err(self.at(
                s,
                *line,
                format!(
                    "TYPE {kind} is {}; realcam traces STANDARD and EVENASPH surfaces only",
                    describe_type(kind)
                ),
            ));
        }
        if let Some((tokens, line)) = &s.glass
            && tokens
                .first()
                .is_some_and(|t| t.eq_ignore_ascii_case("MIRROR"))
        {
            return Err(self.at(
                s,
                *line,
                "GLAS MIRROR: a mirror; realcam traces refracting (dioptric) lenses only".into(),
            ));
        }
        if let Some((line, what)) = &s.refused {
            return Err(self.at(s, *line, format!("{what}: realcam cannot represent it")));
        }
        if let Some((x, y, line)) = s.aperture_decentre
            && (x != 0.0 || y != 0.0)
        {
            return Err(self.at(
                s,
                line,
                format!(
                    "the aperture is decentred by ({x}, {y}) (OBDC): realcam's surfaces are centred on the axis"
                ),
            ));
        }
        if let Some((min, _, line)) = s.clear_aperture
            && min > 0.0
        {
            return Err(self.at(
                s,
                line,
                format!(
                    "CLAP with an inner radius {min}: an annular aperture (a central obscuration) cannot be represented"
                ),
            ));
        }
        if is_even_asphere(s)
            && let Some((&i, &(_, line))) = s.parameters.range(ASPHERIC_TERMS + 1..).next()
        {
            return Err(self.at(
                s,
                line,
                format!(
                    "PARM {i}: an even asphere has terms PARM 1 (r²) to PARM {ASPHERIC_TERMS} (r^{})",
                    2 * ASPHERIC_TERMS
                ),
            ));
        }
        if let Some((t, line)) = s.thickness
            && !t.is_finite()
        {
            return Err(self.at(
                s,
                line,
                "DISZ INFINITY on a lens surface: only the object may be at infinity".into(),
            ));
        }
        Ok(())
    }

    /// Refuses an object-space numerical aperture (`OBNA`) as the system aperture unless the
    /// stop has a size of its own.
    fn refuse_object_na(&self) -> Result<(), PrescriptionError> {
        if let Some((na, line)) = self.system.object_na
            && !self
                .lens
                .iter()
                .any(|s| s.stop && s.semi_diameter.is_some_and(|d| d > 0.0))
        {
            return Err(self.error(
                Some(line),
                format!(
                    "OBNA {na}: the system aperture is an object-space numerical aperture, which realcam cannot size the stop from; give the stop surface a DIAM"
                ),
            ));
        }
        Ok(())
    }

    /// A warning for each `--glass` substitute whose name no surface's `GLAS` gives: a typo
    /// would otherwise pass silently.
    fn unused_substitutes(&self) -> Vec<String> {
        self.substitutes
            .iter()
            .filter(|substitute| {
                !self.lens.iter().any(|s| {
                    s.glass
                        .as_ref()
                        .and_then(|(tokens, _)| tokens.first())
                        .is_some_and(|name| substitute.replaces(name))
                })
            })
            .map(|substitute| {
                format!(
                    "--glass {}=…: the file names no glass {}; nothing was substituted",
                    substitute.name(),
                    substitute.name()
                )
            })
            .collect()
    }

    /// The medium after surface `s`: air, a constant index, a model glass (`___BLANK`, a glass
    /// code) or a catalogue glass, looked up preferring the file's catalogues (`GCAT`).
    fn medium(&self, s: &ZemaxSurface) -> Result<Medium, PrescriptionError> {
        let Some((tokens, line)) = &s.glass else {
            return Ok(Medium::Air);
        };
        let at = |message: String| self.at(s, *line, message);
        let name = tokens.first().map(String::as_str).unwrap_or("");
        if name.is_empty() || name.eq_ignore_ascii_case("AIR") {
            return Ok(Medium::Air);
        }
        if name == "___BLANK" {
            // `GLAS ___BLANK mode pickup n_d V_d …`: a model glass.
            let n_d = tokens.get(3).and_then(|t| number(t));
            let v_d = tokens.get(4).and_then(|t| number(t));
            let (Some(n_d), Some(v_d)) = (n_d, v_d) else {
                return Err(at(format!(
                    "GLAS ___BLANK needs n_d and V_d: '{}'",
                    tokens.join(" ")
                )));
            };
            if v_d == 0.0 {
                return Ok(Medium::Constant(n_d));
            }
            return Glass::model(n_d, v_d)
                .map(Medium::Glass)
                .map_err(|e| at(format!("model glass: {e}")));
        }
        if name.len() == 6 && name.bytes().all(|b| b.is_ascii_digit()) {
            // A six-digit glass code nnnvvv: n_d = 1.nnn, V_d = vv.v.
            let code: f64 = name.parse().unwrap_or(0.0);
            let n_d = 1.0 + (code / 1000.0).floor() / 1000.0;
            let v_d = (code % 1000.0) / 10.0;
            return Glass::model(n_d, v_d)
                .map(Medium::Glass)
                .map_err(|e| at(format!("glass code {name}: {e}")));
        }
        if let Some(substitute) = self.substitutes.iter().find(|s| s.replaces(name)) {
            return Ok(Medium::Glass(substitute.glass));
        }
        let makers: Vec<&str> = self.system.catalogues.iter().map(String::as_str).collect();
        catalogue()
            .find_preferring(name, &makers)
            .map(|id| Medium::Glass(Glass::Catalogue(id)))
            .map_err(|e| {
                at(format!(
                    "GLAS {name}: {e}; to read it as another glass, give --glass {name}=GLASS (a catalogue glass, or N_D,V_D)"
                ))
            })
    }

    /// The lens's rows in millimetres, and for each whether the file leaves its clear aperture
    /// open (no `DIAM` or `CLAP`; the row's aperture is 0 until sized).
    fn rows(&self) -> Result<(Vec<SurfaceRow>, Vec<bool>), PrescriptionError> {
        let scale = self.scale;
        let mut rows = Vec::with_capacity(self.lens.len());
        let mut missing_aperture = Vec::with_capacity(self.lens.len());
        for (i, s) in self.lens.iter().enumerate() {
            let (index, glass) = match self.medium(s)? {
                Medium::Air => (1.0, None),
                Medium::Constant(n) => (n, None),
                Medium::Glass(g) => (g.index(FRAUNHOFER_D_NM), Some(g)),
            };
            let radius = if s.curvature == 0.0 {
                f64::INFINITY
            } else {
                scale / s.curvature
            };
            // The last surface's DISZ is the image distance, which is not part of the lens.
            let thickness = if i + 1 == self.lens.len() {
                0.0
            } else {
                s.thickness.map_or(0.0, |(t, _)| t * scale)
            };
            let mut asphere = Asphere {
                conic: s.conic,
                ..Asphere::NONE
            };
            if is_even_asphere(s) {
                for (&k, &(value, _)) in s.parameters.range(1..=ASPHERIC_TERMS) {
                    asphere.coefficients[k - 1] = value;
                }
            }
            let semi = match s.clear_aperture {
                Some((_, max, _)) if max > 0.0 => Some(max),
                _ => s.semi_diameter.filter(|&d| d > 0.0),
            };
            missing_aperture.push(semi.is_none());
            rows.push(SurfaceRow {
                base: SurfaceBase {
                    radius,
                    thickness,
                    index,
                    aperture: semi.map_or(0.0, |d| 2.0 * d * scale),
                    line: s.line,
                    stop: s.stop,
                },
                asphere: asphere.scaled(scale),
                glass,
            });
        }
        Ok((rows, missing_aperture))
    }

    /// The design's film distance: the last lens surface's `DISZ`, when a positive length.
    fn film_distance(&self) -> Option<f64> {
        self.lens
            .last()
            .and_then(|s| s.thickness)
            .map(|(t, _)| t * self.scale)
            .filter(|t| t.is_finite() && *t > 0.0)
    }

    /// Sizes the stop from the system aperture, as OpticStudio does, where a semi-diameter
    /// clips no ray: an entrance-pupil diameter (ENPD) or an f-number (FNUM) sizes it
    /// paraxially, and only a floating stop (FLOA, or no system aperture at all) takes the
    /// stop's own DIAM; a floating stop without one opens as wide as the other clear apertures
    /// let an axial beam.
    fn size_stop(
        &self,
        rows: &mut [SurfaceRow],
        stop: usize,
        missing_aperture: &mut [bool],
    ) -> Result<(), PrescriptionError> {
        let system = self.system;
        let stop_diam = (!missing_aperture[stop]).then_some(rows[stop].base.aperture);
        let sized = if let Some(epd) = system
            .entrance_pupil_diameter
            .filter(|_| !system.floating_stop)
        {
            clear_aperture::stop_for_entrance_pupil(rows, stop, epd * self.scale)
        } else if let Some(n) = system.f_number.filter(|_| !system.floating_stop) {
            clear_aperture::stop_for_f_number(rows, stop, n)
        } else if stop_diam.is_some() {
            return Ok(());
        } else if system.floating_stop {
            clear_aperture::widest_stop(rows, stop, missing_aperture)
        } else {
            Err("the file gives no system aperture (FNUM, ENPD or FLOA)".to_string())
        };
        let s = &self.lens[stop];
        let diameter =
            sized.map_err(|why| self.at(s, s.line, format!("cannot size the stop: {why}")))?;
        rows[stop].base.aperture = diameter;
        missing_aperture[stop] = false;
        Ok(())
    }

    /// Fills the clear apertures the file leaves open from the rays the design's fields send
    /// through the sized stop.
    fn fill_clear_apertures(
        &self,
        rows: &mut [SurfaceRow],
        missing_aperture: &[bool],
    ) -> Result<(), PrescriptionError> {
        let object_distance = self.surfaces[0]
            .thickness
            .map_or(f64::INFINITY, |(t, _)| t * self.scale);
        let fields = field_points(self.system, self.scale, self.film_distance())
            .map_err(|m| self.error(None, m))?;
        clear_aperture::fill_missing(rows, missing_aperture, &fields, object_distance).map_err(
            |(i, why)| {
                let s = &self.lens[i];
                self.at(
                    s,
                    s.line,
                    format!("has no DIAM and its clear aperture cannot be found: {why}"),
                )
            },
        )
    }

    /// The prescription of `rows`, validated; a problem is located by its row's line, the line
    /// of its `SURF`, so the message names the `SURF` too.
    fn validate(&self, rows: Vec<SurfaceRow>) -> Result<Prescription, PrescriptionError> {
        let stem = self
            .source
            .file_stem()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "lens".into());
        let surf_at_line = |line: Option<usize>| {
            self.lens
                .iter()
                .find(|s| Some(s.line) == line)
                .map(|s| s.number)
        };
        Prescription::from_rows(&stem, self.source, LensFormat::ThicknessAfter, rows).map_err(|e| {
            match surf_at_line(e.line) {
                Some(n) => PrescriptionError {
                    message: format!("SURF {n}: {}", e.message),
                    ..e
                },
                None => e,
            }
        })
    }

    /// Each lens surface's coating from its `COAT` line (`None`: the lens-wide default), and
    /// the warnings for the names realcam does not read: one per unknown name, listing its
    /// surfaces, and one per multi-layer coating on a cemented surface.
    fn coatings(&self, rows: &[SurfaceRow]) -> (Vec<Option<Coating>>, Vec<String>) {
        let mut coatings = Vec::with_capacity(self.lens.len());
        let mut warnings = Vec::new();
        // Unknown names: the name as written, its first line, and its SURF numbers.
        let mut unknown: Vec<(&str, usize, Vec<usize>)> = Vec::new();
        for (i, s) in self.lens.iter().enumerate() {
            let Some((name, line)) = &s.coating else {
                coatings.push(None);
                continue;
            };
            let before = if i == 0 { 1.0 } else { rows[i - 1].base.index };
            let after = rows[i].base.index;
            coatings.push(match zemax_coating(name, before, after) {
                ZemaxCoating::Known(coating) => coating,
                ZemaxCoating::Cemented => {
                    warnings.push(format!(
                        "{}:{line}: SURF {}: COAT {name} is a multi-layer coating for a surface between air and glass, and this surface has glass on both sides (n = {before} before it, {after} after it): the lens-wide default coating is used there",
                        self.source.display(),
                        s.number
                    ));
                    None
                }
                ZemaxCoating::Unknown => {
                    match unknown.iter_mut().find(|(n, _, _)| n == name) {
                        Some((_, _, surfaces)) => surfaces.push(s.number),
                        None => unknown.push((name, *line, vec![s.number])),
                    }
                    None
                }
            });
        }
        for (name, line, surfaces) in unknown {
            let surfaces: Vec<String> = surfaces.iter().map(usize::to_string).collect();
            warnings.push(format!(
                "{}:{line}: COAT {name} on SURF {}: a coating realcam does not know (it reads AR, HEAR1, HEAR2, I.<transmission> and NONE, as the sample COATING.DAT defines them); the lens-wide default coating is used there",
                self.source.display(),
                surfaces.join(", ")
            ));
        }
        (coatings, warnings)
    }

    /// What the file says about the design.
    fn info(&self) -> LensInfo {
        let image = &self.surfaces[self.surfaces.len() - 1];
        let image_semi = image
            .semi_diameter
            .filter(|&d| d > 0.0)
            .map(|d| d * self.scale);
        LensInfo {
            title: self.system.name.clone(),
            source: Some(format!("Zemax file {}", self.source.display())),
            f_number: self.system.f_number,
            film_diagonal_mm: image_semi.map(|h| 2.0 * h),
            film_distance_mm: self.film_distance(),
            notes: (!self.system.notes.is_empty()).then(|| self.system.notes.join(" ")),
            ..LensInfo::default()
        }
    }
}

/// Marks the stop (Zemax's default is surface 1) and returns its row; refuses several.
fn place_stop(rows: &mut [SurfaceRow]) -> Result<usize, String> {
    if !rows.iter().any(|r| r.base.stop) {
        rows[0].base.stop = true;
    }
    if rows.iter().filter(|r| r.base.stop).count() > 1 {
        return Err("more than one surface is marked STOP".into());
    }
    Ok(rows.iter().position(|r| r.base.stop).unwrap_or(0))
}

fn is_even_asphere(s: &ZemaxSurface) -> bool {
    s.kind.as_ref().is_some_and(|(k, _)| k == "EVENASPH")
}

/// The design's field points (`FTYP`, `XFLN`/`YFLN`) as realcam's clear-aperture search wants
/// them: radial distances from the axis as object-space angles, object heights, or image
/// heights. Always includes the axis.
fn field_points(
    system: &ZemaxSystem,
    scale: f64,
    film_distance: Option<f64>,
) -> Result<Vec<FieldPoint>, String> {
    let count = system
        .field_count
        .unwrap_or(system.fields_x.len().max(system.fields_y.len()));
    let radial: Vec<f64> = (0..count.max(1))
        .map(|i| {
            let x = system.fields_x.get(i).copied().unwrap_or(0.0);
            let y = system.fields_y.get(i).copied().unwrap_or(0.0);
            x.hypot(y)
        })
        .collect();
    let mut points = vec![FieldPoint::Angle(0.0)];
    for r in radial.into_iter().filter(|&r| r > 0.0) {
        points.push(match system.field_type.unwrap_or(0) {
            0 => FieldPoint::Angle(r.to_radians()),
            1 => FieldPoint::ObjectHeight(r * scale),
            2 => FieldPoint::ParaxialImageHeight(r * scale),
            3 => FieldPoint::RealImageHeight {
                height: r * scale,
                film_distance: film_distance.ok_or("real image height fields need the image distance (DISZ of the last lens surface)")?,
            },
            other => return Err(format!("FTYP {other}: a field type realcam does not know (0 angle, 1 object height, 2 paraxial and 3 real image height)")),
        });
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::coating::Layer;

    #[test]
    fn coat_names_are_read_as_the_sample_coating_file_defines_them() {
        // AR: a quarter wave (n·d = λ/4) of MgF2 at 550 nm, whichever side it is on.
        let ar = ZemaxCoating::Known(Some(Coating::Layers(vec![Layer {
            index: 1.38,
            thickness_nm: 550.0 / (4.0 * 1.38),
        }])));
        assert_eq!(zemax_coating("AR", 1.0, 1.5), ar);
        assert_eq!(zemax_coating("ar", 1.6, 1.7), ar);
        // I.<digits>: transmission 0.<digits>, the rest reflected.
        for (name, reflected) in [
            ("I.99", 1.0 - 0.99),
            ("I.0", 1.0),
            ("I.5", 0.5),
            ("I.05", 0.95),
        ] {
            assert_eq!(
                zemax_coating(name, 1.0, 1.5),
                ZemaxCoating::Known(Some(Coating::Measured(vec![(550.0, reflected)]))),
                "{name}"
            );
        }
        // HEAR1/HEAR2: the multi-coating model, on air–glass surfaces only.
        assert_eq!(
            zemax_coating("HEAR1", 1.5, 1.0),
            ZemaxCoating::Known(Some(CoatingModel::Multi.coating_for(1.5, 1.0)))
        );
        assert_eq!(
            zemax_coating("HEAR2", 1.0, 1.62),
            ZemaxCoating::Known(Some(CoatingModel::Multi.coating_for(1.0, 1.62)))
        );
        assert_eq!(zemax_coating("HEAR1", 1.5, 1.7), ZemaxCoating::Cemented);
        for none in ["", "NONE", "none"] {
            assert_eq!(zemax_coating(none, 1.0, 1.5), ZemaxCoating::Known(None));
        }
        for unknown in ["WAR", "I.", "I.9X", "I", "BBAR", "METAL"] {
            assert_eq!(
                zemax_coating(unknown, 1.0, 1.5),
                ZemaxCoating::Unknown,
                "{unknown}"
            );
        }
    }
}
