//! realcam's own lens format: a small TOML file that says everything realcam represents, and
//! is easy to read and write by hand (documented with an example in `lenses/README.md`).
//!
//! ```toml
//! title = "A triplet with an aspheric element (an example, not a real design)"
//! source = "where the numbers come from: patent, book, repository @ commit : path"
//! licence = "the licence of the source's data"
//! focal_length_mm = 50.0
//! f_number = 4.5
//! surfaces = [
//!   { radius = 21.48,  thickness = 2.0,  glass = "N-SK16", diameter = 16 },
//!   { radius = -124.1, thickness = 5.26, diameter = 16 },
//!   { stop = true,     thickness = 1.0,  diameter = 9.8 },
//!   { radius = -8.98, thickness = 1.0, glass = { n_d = 1.6477, v_d = 33.8 }, diameter = 10,
//!     conic = -0.3, aspheric = [0, 1.2e-5, -4e-8] },
//!   { radius = "inf", thickness = 42.9, diameter = 12 },
//! ]
//! ```
//!
//! Lengths are millimetres in the lens frame (see [`crate::lens`]); surfaces run front (scene)
//! to back (film). `radius` is signed (> 0: centre toward the film) or `"inf"` for a plane;
//! a surface with `stop = true` and no radius is the diaphragm. `thickness` is the distance to
//! the next surface (the last one's: the design's image distance, optional). `glass` is the
//! medium after the surface: a catalogue name, `{ n_d, v_d }`, `{ n = … }` for a fixed index,
//! or absent for air. `diameter` is the clear aperture's full diameter. `aspheric` lists
//! [A₂, A₄, …] (the coefficients of r², r⁴, …, in mm units).
//!
//! `coating` (optional) is the surface's coating: `"none"` (bare), `"ideal"` (reflects nothing),
//! `"single"` or `"multi"` (the [`CoatingModel`]'s coating for an air–glass surface),
//! `{ layers = [ { index, thickness_nm | quarter_wave_nm | half_wave_nm }, … ] }` (thin films
//! from the scene side) or `{ measured = [[nm, reflectance], …] }`; without it the lens-wide
//! default applies.
//!
//! Optional `[zoom]` (`surfaces`, 1-based, and `positions`, each with `gaps` after those
//! surfaces, optionally `focal_length_mm`, `stop_diameter` and, for a zoom whose focus travel
//! differs per position, `close_gaps`: the same gaps at close focus) and `[focus]`
//! (`close_focus_m`, and optionally `surfaces` with their gaps at `infinity` and at `close`
//! focus) tables give a zoom lens's positions and a lens's focus groups (see
//! [`crate::lens::spacing`]).

use std::fmt::Write;
use std::path::Path;

use serde::Deserialize;

use crate::glass::{FRAUNHOFER_D_NM, Glass, catalogue};
use crate::lens::coating::{Coating, CoatingModel, Layer};
use crate::lens::info::LensInfo;
use crate::lens::prescription::{
    LensFormat, Prescription, PrescriptionError, SurfaceBase, SurfaceRow,
};
use crate::lens::shape::{ASPHERIC_TERMS, Asphere};
use crate::lens::spacing::{FocusGap, FocusGroups, Gap, VariableSpacings, ZoomPosition};

/// The file's top level: the lens's name, [`LensInfo`]'s fields, and the surfaces.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LensFile {
    format: Option<String>,
    name: Option<String>,
    title: Option<String>,
    source: Option<String>,
    licence: Option<String>,
    year: Option<u32>,
    focal_length_mm: Option<f64>,
    f_number: Option<f64>,
    film_diagonal_mm: Option<f64>,
    notes: Option<String>,
    surfaces: Vec<::toml::Spanned<SurfaceEntry>>,
    zoom: Option<ZoomTable>,
    focus: Option<FocusTable>,
}

/// `[zoom]`: the surfaces (1-based) whose gaps change, and each position's gaps after them, as
/// a patent tabulates them.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ZoomTable {
    surfaces: Vec<usize>,
    positions: Vec<ZoomEntry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ZoomEntry {
    focal_length_mm: Option<f64>,
    gaps: Vec<f64>,
    stop_diameter: Option<f64>,
    /// The gaps after the `[zoom]` surfaces at close focus, at this position.
    close_gaps: Option<Vec<f64>>,
}

/// `[focus]`: the focus groups' gaps at infinity and at the closest focus.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FocusTable {
    close_focus_m: f64,
    #[serde(default)]
    surfaces: Vec<usize>,
    #[serde(default)]
    infinity: Vec<f64>,
    #[serde(default)]
    close: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SurfaceEntry {
    radius: Option<Radius>,
    thickness: Option<f64>,
    glass: Option<GlassEntry>,
    diameter: f64,
    #[serde(default)]
    stop: bool,
    #[serde(default)]
    conic: f64,
    #[serde(default)]
    aspheric: Vec<f64>,
    /// Read by [`read_coating`], which knows the surface's indices and names its problems.
    coating: Option<::toml::Spanned<::toml::Value>>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Radius {
    Number(f64),
    Word(String),
}

#[derive(Deserialize)]
#[serde(untagged)]
enum GlassEntry {
    Name(String),
    Model { n_d: f64, v_d: f64 },
    Fixed { n: f64 },
}

/// The format version this module writes (and the only one it reads).
pub const FORMAT: &str = "realcam-lens/1";

/// Reads realcam's lens format.
pub fn read_lens_file(text: &str, source: &Path) -> Result<Prescription, PrescriptionError> {
    let error = |line: Option<usize>, message: String| PrescriptionError {
        file: source.to_path_buf(),
        line,
        message,
    };
    let file: LensFile = ::toml::from_str(text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].lines().count().max(1));
        error(line, format!("not a realcam lens file: {}", e.message()))
    })?;
    if let Some(format) = &file.format
        && format != FORMAT
    {
        return Err(error(
            None,
            format!("format '{format}' is not '{FORMAT}', the one this realcam reads"),
        ));
    }
    if file.surfaces.is_empty() {
        return Err(error(
            None,
            "no surfaces: the 'surfaces' array is empty".into(),
        ));
    }
    let line_of = |offset: usize| text[..offset.min(text.len())].lines().count().max(1);
    let mut rows = Vec::with_capacity(file.surfaces.len());
    let last = file.surfaces.len() - 1;
    let mut film_distance = None;
    let mut coatings = Vec::with_capacity(file.surfaces.len());
    for (i, spanned) in file.surfaces.iter().enumerate() {
        let line = line_of(spanned.span().start);
        let entry = spanned.get_ref();
        let at = |message: String| error(Some(line), format!("surface {}: {message}", i + 1));
        let radius = match &entry.radius {
            None if entry.stop => 0.0,
            None => {
                return Err(at(
                    "no radius (give a number, or \"inf\" for a plane)".into()
                ));
            }
            Some(Radius::Number(r)) if r.is_finite() && *r != 0.0 => *r,
            Some(Radius::Number(r)) => {
                return Err(at(format!(
                    "radius {r} is not a radius (use \"inf\" for a plane)"
                )));
            }
            Some(Radius::Word(w))
                if matches!(
                    w.to_ascii_lowercase().as_str(),
                    "inf" | "infinity" | "flat" | "plane"
                ) =>
            {
                f64::INFINITY
            }
            Some(Radius::Word(w)) => {
                return Err(at(format!("radius '{w}' is not a number or \"inf\"")));
            }
        };
        let (index, glass) = match &entry.glass {
            None => (1.0, None),
            Some(GlassEntry::Name(name)) if name.eq_ignore_ascii_case("air") => (1.0, None),
            Some(GlassEntry::Name(name)) => {
                let id = catalogue()
                    .find(name)
                    .map_err(|e| at(format!("glass: {e}")))?;
                let glass = Glass::Catalogue(id);
                (glass.index(FRAUNHOFER_D_NM), Some(glass))
            }
            Some(GlassEntry::Model { n_d, v_d }) => {
                let glass = Glass::model(*n_d, *v_d).map_err(|e| at(format!("glass: {e}")))?;
                (*n_d, Some(glass))
            }
            Some(GlassEntry::Fixed { n }) => (*n, None),
        };
        if entry.aspheric.len() > ASPHERIC_TERMS {
            return Err(at(format!(
                "{} aspheric coefficients; realcam takes up to {ASPHERIC_TERMS} (A2 … A{})",
                entry.aspheric.len(),
                2 * ASPHERIC_TERMS
            )));
        }
        let mut asphere = Asphere {
            conic: entry.conic,
            ..Asphere::NONE
        };
        asphere.coefficients[..entry.aspheric.len()].copy_from_slice(&entry.aspheric);
        if !asphere.conic.is_finite() || asphere.coefficients.iter().any(|a| !a.is_finite()) {
            return Err(at("conic and aspheric coefficients must be finite".into()));
        }
        let thickness = entry.thickness.unwrap_or(0.0);
        if i == last {
            film_distance = entry.thickness.filter(|t| *t > 0.0);
        }
        if let Some(coating) = &entry.coating {
            let before = rows.last().map_or(1.0, |r: &SurfaceRow| r.base.index);
            let coating = read_coating(coating.get_ref(), before, index).map_err(|m| {
                error(
                    Some(line_of(coating.span().start)),
                    format!("surface {}: coating: {m}", i + 1),
                )
            })?;
            coatings.push(Some(coating));
        } else {
            coatings.push(None);
        }
        rows.push(SurfaceRow {
            base: SurfaceBase {
                radius,
                thickness: if i == last { 0.0 } else { thickness },
                index,
                aperture: entry.diameter,
                line,
                stop: entry.stop,
            },
            asphere,
            glass,
        });
    }
    let name = file.name.clone().unwrap_or_else(|| stem(source));
    // Validation locates problems by line: name the surface too.
    let lines: Vec<usize> = rows.iter().map(|r| r.base.line).collect();
    let mut prescription = Prescription::from_rows(&name, source, LensFormat::ThicknessAfter, rows)
        .map_err(|e| match lines.iter().position(|&l| Some(l) == e.line) {
            Some(i) => PrescriptionError {
                message: format!("surface {}: {}", i + 1, e.message),
                ..e
            },
            None => e,
        })?;
    let i = &file;
    prescription.info = LensInfo {
        title: i.title.clone(),
        source: i.source.clone(),
        licence: i.licence.clone(),
        year: i.year,
        focal_length_mm: i.focal_length_mm,
        f_number: i.f_number,
        film_diagonal_mm: i.film_diagonal_mm,
        film_distance_mm: film_distance,
        notes: i.notes.clone(),
    };
    let spacings = spacings(&file).map_err(|m| error(None, m))?;
    if !spacings.is_empty() {
        prescription = prescription.with_spacings(spacings)?;
    }
    // Each coating was checked as it was read, naming its surface by line.
    prescription.with_coatings(coatings)
}

/// What a coating may be, for messages.
const COATING_FORMS: &str = "\"none\", \"single\", \"multi\", \"ideal\", { layers = [ { index = …, thickness_nm = … }, … ] } or { measured = [[nm, reflectance], …] }";

/// A surface's `coating` value, the surface lying between the index `n_front` before it and
/// `n_back` after it (at the lens's own indices): the coating it names, checked
/// ([`Coating::check`]), or what is wrong with it.
fn read_coating(value: &::toml::Value, n_front: f64, n_back: f64) -> Result<Coating, String> {
    use ::toml::Value;
    let coating = match value {
        Value::String(name) => match name.to_ascii_lowercase().as_str() {
            "none" => Coating::None,
            "ideal" => Coating::Ideal,
            word @ ("single" | "multi") => {
                if !is_air(n_front) && !is_air(n_back) {
                    return Err(format!(
                        "\"{word}\" is a coating for a surface between air and glass, and this one has glass on both sides (n = {n_front} before it, {n_back} after it): give its layers instead, {{ layers = [ {{ index = …, thickness_nm = … }}, … ] }}, or \"none\""
                    ));
                }
                let model = if word == "single" {
                    CoatingModel::Single
                } else {
                    CoatingModel::Multi
                };
                model.coating_for(n_front, n_back)
            }
            _ => {
                return Err(format!(
                    "\"{}\" is not a coating: use {COATING_FORMS}",
                    super::shorten(name)
                ));
            }
        },
        Value::Table(table) => {
            if let Some(key) = table
                .keys()
                .find(|k| !matches!(k.as_str(), "layers" | "measured"))
            {
                return Err(format!(
                    "unknown key '{}': a coating table is {{ layers = […] }} or {{ measured = […] }}",
                    super::shorten(key)
                ));
            }
            match (table.get("layers"), table.get("measured")) {
                (Some(layers), None) => Coating::Layers(read_layers(layers)?),
                (None, Some(measured)) => Coating::Measured(read_measured(measured)?),
                (Some(_), Some(_)) => {
                    return Err(
                        "gives both layers and measured: a coating is one or the other".into(),
                    );
                }
                (None, None) => {
                    return Err(format!("an empty table: use {COATING_FORMS}"));
                }
            }
        }
        other => {
            return Err(format!(
                "{} is not a coating: use {COATING_FORMS}",
                described(other)
            ));
        }
    };
    coating.check()?;
    Ok(coating)
}

/// Whether an index is air's, as [`CoatingModel::coating_for`] tells them apart.
fn is_air(n: f64) -> bool {
    (n - 1.0).abs() < 1e-3
}

/// A TOML value as a message names it: `a string "x"`, `an integer 3`, `an array`.
fn described(value: &::toml::Value) -> String {
    use ::toml::Value;
    match value {
        Value::String(s) => format!("a string \"{}\"", super::shorten(s)),
        Value::Integer(i) => format!("an integer {i}"),
        Value::Float(f) => format!("a number {f}"),
        Value::Boolean(b) => format!("a boolean {b}"),
        Value::Datetime(d) => format!("a date {d}"),
        Value::Array(_) => "an array".into(),
        Value::Table(_) => "a table".into(),
    }
}

/// A TOML number (integer or float) as f64.
fn number(value: &::toml::Value) -> Option<f64> {
    match value {
        ::toml::Value::Integer(i) => Some(*i as f64),
        ::toml::Value::Float(f) => Some(*f),
        _ => None,
    }
}

/// `layers = [ { index, thickness_nm | quarter_wave_nm | half_wave_nm }, … ]`, from the scene
/// side.
fn read_layers(value: &::toml::Value) -> Result<Vec<Layer>, String> {
    let Some(entries) = value.as_array() else {
        return Err(format!(
            "layers must be an array of {{ index = …, thickness_nm = … }} tables, found {}",
            described(value)
        ));
    };
    const THICKNESSES: [&str; 3] = ["thickness_nm", "quarter_wave_nm", "half_wave_nm"];
    const ONE_OF: &str = "one of thickness_nm, quarter_wave_nm or half_wave_nm";
    let mut layers = Vec::with_capacity(entries.len());
    for (k, entry) in entries.iter().enumerate() {
        let at = |message: String| format!("layer {}: {message}", k + 1);
        let Some(table) = entry.as_table() else {
            return Err(at(format!(
                "expected a table {{ index = …, thickness_nm = … }}, found {}",
                described(entry)
            )));
        };
        if let Some(key) = table
            .keys()
            .find(|k| k.as_str() != "index" && !THICKNESSES.contains(&k.as_str()))
        {
            return Err(at(format!(
                "unknown key '{}': a layer has an index and {ONE_OF}",
                super::shorten(key),
            )));
        }
        let field = |key: &str| -> Result<Option<f64>, String> {
            table
                .get(key)
                .map(|v| {
                    number(v).ok_or_else(|| {
                        at(format!("{key} must be a number, found {}", described(v)))
                    })
                })
                .transpose()
        };
        let index = field("index")?.ok_or_else(|| at("no index".into()))?;
        let given: Vec<&str> = THICKNESSES
            .into_iter()
            .filter(|k| table.contains_key(*k))
            .collect();
        let [key] = given[..] else {
            return Err(at(if given.is_empty() {
                format!("no thickness: give {ONE_OF}")
            } else {
                format!("gives {}: give only one", given.join(" and "))
            }));
        };
        let value = field(key)?.unwrap_or(f64::NAN);
        let layer = match key {
            "thickness_nm" => Layer {
                index,
                thickness_nm: value,
            },
            _ => {
                if !(value.is_finite() && value > 0.0) {
                    return Err(at(format!(
                        "{key} = {value}: a design wavelength must be a positive number of nm"
                    )));
                }
                if !(index.is_finite() && index >= 1.0) {
                    return Err(at(format!(
                        "index {index} (must be a number of at least 1)"
                    )));
                }
                let waves = if key == "quarter_wave_nm" { 4.0 } else { 2.0 };
                Layer {
                    index,
                    thickness_nm: value / (waves * index),
                }
            }
        };
        layers.push(layer);
    }
    Ok(layers)
}

/// `measured = [[nm, reflectance], …]`.
fn read_measured(value: &::toml::Value) -> Result<Vec<(f64, f64)>, String> {
    let Some(entries) = value.as_array() else {
        return Err(format!(
            "measured must be an array of [nm, reflectance] pairs, found {}",
            described(value)
        ));
    };
    entries
        .iter()
        .enumerate()
        .map(|(k, entry)| {
            match entry
                .as_array()
                .map(|pair| pair.iter().map(number).collect::<Vec<_>>())
                .as_deref()
            {
                Some(&[Some(nm), Some(r)]) => Ok((nm, r)),
                _ => Err(format!(
                    "measured point {}: expected [nm, reflectance], two numbers",
                    k + 1
                )),
            }
        })
        .collect()
}

/// A coating as the `coating` key writes it (layers by their physical thickness).
pub(super) fn write_coating(coating: &Coating) -> String {
    match coating {
        Coating::None => "\"none\"".into(),
        Coating::Ideal => "\"ideal\"".into(),
        Coating::Layers(layers) => {
            let layers: Vec<String> = layers
                .iter()
                .map(|l| {
                    format!(
                        "{{ index = {}, thickness_nm = {} }}",
                        num(l.index),
                        num(l.thickness_nm)
                    )
                })
                .collect();
            format!("{{ layers = [{}] }}", layers.join(", "))
        }
        Coating::Measured(curve) => {
            let points: Vec<String> = curve
                .iter()
                .map(|&(nm, r)| format!("[{}, {}]", num(nm), num(r)))
                .collect();
            format!("{{ measured = [{}] }}", points.join(", "))
        }
    }
}

/// The `[zoom]` and `[focus]` tables as variable spacings (surface numbers made 0-based).
fn spacings(file: &LensFile) -> Result<VariableSpacings, String> {
    let surface = |table: &str, s: usize| {
        s.checked_sub(1).ok_or_else(|| {
            format!("[{table}] surfaces are numbered from 1, as the surfaces list counts them")
        })
    };
    let mut spacings = VariableSpacings::default();
    if let Some(zoom) = &file.zoom {
        if zoom.positions.is_empty() {
            return Err("[zoom] has no positions".into());
        }
        let surfaces = zoom
            .surfaces
            .iter()
            .map(|&s| surface("zoom", s))
            .collect::<Result<Vec<_>, _>>()?;
        for (i, entry) in zoom.positions.iter().enumerate() {
            if entry.gaps.len() != surfaces.len() {
                return Err(format!(
                    "[zoom] position {} gives {} gaps for {} surfaces",
                    i + 1,
                    entry.gaps.len(),
                    surfaces.len()
                ));
            }
            let close = entry.close_gaps.as_deref().unwrap_or_default();
            if entry.close_gaps.is_some() && close.len() != surfaces.len() {
                return Err(format!(
                    "[zoom] position {} gives {} close_gaps for {} surfaces",
                    i + 1,
                    close.len(),
                    surfaces.len()
                ));
            }
            let gaps = |values: &[f64]| {
                surfaces
                    .iter()
                    .zip(values)
                    .map(|(&surface, &thickness)| Gap { surface, thickness })
                    .collect::<Vec<_>>()
            };
            spacings.zoom.push(ZoomPosition {
                focal_length_mm: entry.focal_length_mm,
                gaps: gaps(&entry.gaps),
                stop_diameter: entry.stop_diameter,
                close_gaps: gaps(close),
            });
        }
    }
    if let Some(focus) = &file.focus {
        let n = focus.surfaces.len();
        if focus.infinity.len() != n || focus.close.len() != n {
            return Err(format!(
                "[focus] gives {} infinity and {} close gaps for {n} surfaces",
                focus.infinity.len(),
                focus.close.len()
            ));
        }
        let gaps = (0..n)
            .map(|k| {
                Ok(FocusGap {
                    surface: surface("focus", focus.surfaces[k])?,
                    infinity: focus.infinity[k],
                    close: focus.close[k],
                })
            })
            .collect::<Result<Vec<_>, String>>()?;
        spacings.focus = Some(FocusGroups {
            close_focus_m: focus.close_focus_m,
            gaps,
        });
    }
    Ok(spacings)
}

/// The `[zoom]` and `[focus]` tables of `spacings` (nothing for fixed spacings).
fn write_spacings(out: &mut String, spacings: &VariableSpacings, rows: &[SurfaceRow]) {
    let list = |values: &[f64]| {
        values
            .iter()
            .map(|&v| num(v))
            .collect::<Vec<_>>()
            .join(", ")
    };
    if !spacings.zoom.is_empty() {
        // Every surface any position moves; a position that leaves one alone has the row's.
        let mut surfaces: Vec<usize> = spacings
            .zoom
            .iter()
            .flat_map(|p| p.gaps.iter().map(|g| g.surface))
            .collect();
        surfaces.sort_unstable();
        surfaces.dedup();
        let numbers: Vec<String> = surfaces.iter().map(|s| (s + 1).to_string()).collect();
        let _ = writeln!(out, "\n[zoom]");
        let _ = writeln!(out, "surfaces = [{}]", numbers.join(", "));
        let _ = writeln!(out, "positions = [");
        for position in &spacings.zoom {
            let gaps: Vec<f64> = surfaces
                .iter()
                .map(|&s| {
                    position
                        .gaps
                        .iter()
                        .rev()
                        .find(|g| g.surface == s)
                        .map_or(rows[s].base.thickness, |g| g.thickness)
                })
                .collect();
            let mut fields = Vec::new();
            if let Some(f) = position.focal_length_mm {
                fields.push(format!("focal_length_mm = {}", num(f)));
            }
            fields.push(format!("gaps = [{}]", list(&gaps)));
            if let Some(d) = position.stop_diameter {
                fields.push(format!("stop_diameter = {}", num(d)));
            }
            if !position.close_gaps.is_empty() {
                // A surface whose gap does not move with focus keeps its gap at infinity.
                let close: Vec<f64> = surfaces
                    .iter()
                    .zip(&gaps)
                    .map(|(&s, &infinity)| {
                        position
                            .close_gaps
                            .iter()
                            .find(|g| g.surface == s)
                            .map_or(infinity, |g| g.thickness)
                    })
                    .collect();
                fields.push(format!("close_gaps = [{}]", list(&close)));
            }
            let _ = writeln!(out, "  {{ {} }},", fields.join(", "));
        }
        let _ = writeln!(out, "]");
    }
    if let Some(focus) = &spacings.focus {
        let numbers: Vec<String> = focus
            .gaps
            .iter()
            .map(|g| (g.surface + 1).to_string())
            .collect();
        let infinity: Vec<f64> = focus.gaps.iter().map(|g| g.infinity).collect();
        let close: Vec<f64> = focus.gaps.iter().map(|g| g.close).collect();
        let _ = writeln!(out, "\n[focus]");
        let _ = writeln!(out, "close_focus_m = {}", num(focus.close_focus_m));
        if !focus.gaps.is_empty() {
            let _ = writeln!(out, "surfaces = [{}]", numbers.join(", "));
            let _ = writeln!(out, "infinity = [{}]", list(&infinity));
            let _ = writeln!(out, "close = [{}]", list(&close));
        }
    }
}

fn stem(path: &Path) -> String {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "lens".into());
    name.trim_end_matches(".toml")
        .trim_end_matches(".lens")
        .to_string()
}

/// A TOML basic string.
fn quoted(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            c if c.is_control() => {
                let _ = write!(out, "\\u{:04X}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// A number as TOML reads it back exactly (Rust's shortest round-trip form, e.g. `1.5`,
/// `1e-5`, `-0.25`).
fn num(v: f64) -> String {
    format!("{v:?}")
}

/// `prescription` in realcam's lens format. `film_distance` (the last surface's thickness)
/// is written when known.
pub fn write_lens_file(prescription: &Prescription) -> String {
    let info = &prescription.info;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# realcam lens file: lengths in mm, surfaces front (scene) to back (film)."
    );
    let _ = writeln!(
        out,
        "# Format: see lenses/README.md in the realcam repository."
    );
    let _ = writeln!(out, "format = {}", quoted(FORMAT));
    let _ = writeln!(out, "name = {}", quoted(&prescription.name));
    let strings = [
        ("title", &info.title),
        ("source", &info.source),
        ("licence", &info.licence),
    ];
    for (key, value) in strings {
        if let Some(v) = value {
            let _ = writeln!(out, "{key} = {}", quoted(v));
        }
    }
    if let Some(year) = info.year {
        let _ = writeln!(out, "year = {year}");
    }
    let numbers = [
        ("focal_length_mm", info.focal_length_mm),
        ("f_number", info.f_number),
        ("film_diagonal_mm", info.film_diagonal_mm),
    ];
    for (key, value) in numbers {
        if let Some(v) = value {
            let _ = writeln!(out, "{key} = {}", num(v));
        }
    }
    if let Some(notes) = &info.notes {
        let _ = writeln!(out, "notes = {}", quoted(notes));
    }
    let _ = writeln!(out, "surfaces = [");
    let last = prescription.rows.len() - 1;
    for (i, row) in prescription.rows.iter().enumerate() {
        let mut fields = Vec::new();
        let bare_stop = row.base.stop && row.curvature() == 0.0 && !row.asphere.is_aspheric(0.0);
        if !bare_stop {
            fields.push(match row.curvature() {
                0.0 => "radius = \"inf\"".to_string(),
                _ => format!("radius = {}", num(row.base.radius)),
            });
        }
        if row.base.stop {
            fields.push("stop = true".into());
        }
        let thickness = if i == last {
            info.film_distance_mm
        } else {
            Some(row.base.thickness)
        };
        if let Some(t) = thickness {
            fields.push(format!("thickness = {}", num(t)));
        }
        match row.glass {
            Some(Glass::Catalogue(id)) => {
                let glass = id.get();
                fields.push(format!("glass = {}", quoted(&glass.label())));
            }
            Some(Glass::Model { n_d, v_d }) => {
                fields.push(format!(
                    "glass = {{ n_d = {}, v_d = {} }}",
                    num(n_d),
                    num(v_d)
                ));
            }
            None if row.base.index != 1.0 => {
                fields.push(format!("glass = {{ n = {} }}", num(row.base.index)))
            }
            None => {}
        }
        fields.push(format!("diameter = {}", num(row.base.aperture)));
        if row.asphere.conic != 0.0 {
            fields.push(format!("conic = {}", num(row.asphere.conic)));
        }
        let order = row.asphere.order();
        if order > 0 {
            let terms: Vec<String> = row.asphere.coefficients[..order]
                .iter()
                .map(|&a| num(a))
                .collect();
            fields.push(format!("aspheric = [{}]", terms.join(", ")));
        }
        if let Some(coating) = prescription.coating(i) {
            fields.push(format!("coating = {}", write_coating(coating)));
        }
        let _ = writeln!(out, "  {{ {} }},", fields.join(", "));
    }
    let _ = writeln!(out, "]");
    write_spacings(&mut out, &prescription.spacings, &prescription.rows);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value(text: &str) -> ::toml::Value {
        let table: ::toml::Table = ::toml::from_str(&format!("coating = {text}")).unwrap();
        table["coating"].clone()
    }

    fn read(text: &str, n_front: f64, n_back: f64) -> Result<Coating, String> {
        read_coating(&value(text), n_front, n_back)
    }

    #[test]
    fn coating_words_and_tables_read_to_their_coatings() {
        assert_eq!(read(r#""none""#, 1.0, 1.5), Ok(Coating::None));
        assert_eq!(read(r#""Ideal""#, 1.5, 1.7), Ok(Coating::Ideal));
        // MgF2 a quarter wave at 550 nm: n·d = 550/4.
        let Ok(Coating::Layers(single)) = read(r#""single""#, 1.0, 1.5) else {
            panic!("single");
        };
        assert_eq!(single.len(), 1);
        assert_eq!(single[0].index, 1.38);
        assert!((single[0].index * single[0].thickness_nm - 137.5).abs() < 1e-9);
        // From glass to air the stack is listed from the glass side: MgF2 last.
        let Ok(Coating::Layers(multi)) = read(r#""multi""#, 1.6, 1.0) else {
            panic!("multi");
        };
        assert_eq!(multi.len(), 3);
        assert_eq!(multi[2].index, 1.38);
        assert!((multi[0].index - 1.38 * 1.6f64.sqrt()).abs() < 1e-12);
        // Integers are numbers; half and quarter waves are optical thicknesses λ/2 and λ/4.
        let layers = read(
            "{ layers = [ { index = 2, thickness_nm = 10 }, { index = 1.5, half_wave_nm = 600 }, { quarter_wave_nm = 500, index = 1.25 } ] }",
            1.0,
            1.5,
        )
        .unwrap();
        let expected = [(2.0, 10.0), (1.5, 200.0), (1.25, 100.0)];
        let Coating::Layers(layers) = layers else {
            panic!("{layers:?}");
        };
        for (layer, (index, thickness)) in layers.iter().zip(expected) {
            assert_eq!(layer.index, index);
            assert!((layer.thickness_nm - thickness).abs() < 1e-12, "{layers:?}");
        }
        assert_eq!(
            read("{ measured = [[400, 0.5], [450.5, 0]] }", 1.0, 1.5),
            Ok(Coating::Measured(vec![(400.0, 0.5), (450.5, 0.0)]))
        );
    }

    #[test]
    fn a_bad_coating_value_says_what_is_wrong() {
        let cases = [
            (r#""SINGLE-ish""#, "\"SINGLE-ish\" is not a coating"),
            ("true", "a boolean true is not a coating"),
            ("1.5", "a number 1.5 is not a coating"),
            ("{ layers = 3 }", "layers must be an array"),
            ("{ layers = [3] }", "layer 1: expected a table"),
            (
                "{ layers = [ { index = 1.4, thickness_nm = 1, colour = 2 } ] }",
                "layer 1: unknown key 'colour'",
            ),
            ("{ layers = [ { thickness_nm = 1 } ] }", "layer 1: no index"),
            (
                "{ layers = [ { index = 1.4, half_wave_nm = -500 } ] }",
                "layer 1: half_wave_nm = -500",
            ),
            (
                "{ layers = [ { index = 0, quarter_wave_nm = 500 } ] }",
                "layer 1: index 0",
            ),
            (
                "{ layers = [ { index = 1.4, thickness_nm = \"thin\" } ] }",
                "thickness_nm must be a number, found a string \"thin\"",
            ),
            ("{ measured = [] }", "no points"),
            ("{ measured = [[400, -0.1]] }", "point 1: reflectance -0.1"),
            (
                "{ measured = [[400]] }",
                "measured point 1: expected [nm, reflectance]",
            ),
        ];
        for (text, expected) in cases {
            let error = read(text, 1.0, 1.5).expect_err(text);
            assert!(
                error.contains(expected),
                "{text}: '{expected}' not in: {error}"
            );
        }
        // The named models are for air–glass surfaces; on glass–air–… too, never glass–glass.
        let error = read(r#""multi""#, 1.5, 1.7).unwrap_err();
        assert!(error.contains("glass on both sides"), "{error}");
        assert!(error.contains("layers"), "{error}");
    }

    #[test]
    fn written_coatings_read_back_equal() {
        let coatings = [
            Coating::None,
            Coating::Ideal,
            Coating::single_layer(1.38, 550.0),
            CoatingModel::Multi.coating_for(1.0, 1.7234),
            Coating::Layers(Vec::new()),
            Coating::Measured(vec![(380.0, 0.031), (550.0, 1.0 - 0.99), (780.25, 0.0)]),
        ];
        for coating in coatings {
            let text = write_coating(&coating);
            assert_eq!(read(&text, 1.0, 1.5).as_ref(), Ok(&coating), "{text}");
        }
    }
}
