//! Zemax OpticStudio `.zmx` files (sequential mode): decoding, parsing, units, and the
//! conversion to a [`Prescription`].
//!
//! A `.zmx` file is a list of keyword lines. Global ones set the system (`UNIT`, the system
//! aperture `FNUM`/`ENPD`/`FLOA`, the glass catalogues `GCAT`, the fields `FTYP`/`XFLN`/
//! `YFLN`); `SURF n` opens the block of surface n, whose lines give its `TYPE`, `CURV`
//! (1/radius), `DISZ` (thickness to the next surface), `GLAS` (the medium after it), `DIAM`
//! (its **semi**-diameter), `CONI` (conic constant), `PARM i` (an even asphere's r^(2i)
//! coefficient), `STOP`, and apertures such as `CLAP`. Surface 0 is the object, the last one
//! the image; the surfaces between are the lens. The image distance (the last lens surface's
//! `DISZ`) is the design's film distance.
//!
//! Everything is converted to millimetres in realcam's lens frame. What realcam cannot
//! represent (mirrors, coordinate breaks, tilted or decentred surfaces and apertures,
//! non-rotationally-symmetric or diffractive surfaces, multi-configuration zooms, unknown glass
//! names) is refused, naming the file, the `SURF` number and what it is: never misread.

use std::collections::BTreeMap;
use std::path::Path;

use crate::glass::{FRAUNHOFER_D_NM, Glass, catalogue};
use crate::lens::clear_aperture::{self, FieldPoint};
use crate::lens::info::LensInfo;
use crate::lens::prescription::{
    LensFormat, Prescription, PrescriptionError, SurfaceBase, SurfaceRow,
};
use crate::lens::shape::{ASPHERIC_TERMS, Asphere};

/// Zemax files larger than this are refused before reading (real ones, merit functions and
/// tolerances included, are well below; UTF-16 doubles them).
pub const MAX_ZEMAX_BYTES: u64 = 16 << 20;

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

/// Surface keywords that carry no optics realcam uses (drawing, coatings, tolerances,
/// solves, comments, mechanical sizes, pickups): skipped silently.
const IGNORED_SURFACE_KEYWORDS: [&str; 24] = [
    "HIDE", "SLAB", "POPS", "FIMP", "MIRR", "MEMA", "COAT", "COMM", "PZUP", "SSID", "MAZH", "FLAP",
    "VPAR", "PPAR", "CURV", "DISZ", "EDGE", "TCED", "SQAP", "BLNK", "VCON", "XDAT", "IGNR", "THIC",
];

/// Surface keywords for apertures realcam cannot represent.
fn unsupported_surface_keyword(keyword: &str) -> Option<&'static str> {
    Some(match keyword {
        "SQAP" => "a rectangular aperture",
        "ELAP" => "an elliptical aperture",
        "OBSC" | "OBSQ" | "OBEL" => "an obscuration",
        "UDAP" | "UDAD" => "a user-defined aperture",
        "SPID" => "a spider (obscuring vanes)",
        "DECX" | "DECY" | "TILX" | "TILY" | "TILZ" | "SCBD" => "a decentre or tilt of the surface",
        _ => return None,
    })
}

/// A `.zmx` file's surface block as read, in the file's units.
#[derive(Clone, Debug, Default)]
struct ZemaxSurface {
    number: usize,
    line: usize,
    kind: Option<(String, usize)>,
    curvature: f64,
    /// `DISZ` (thickness after), `INFINITY` as ∞.
    thickness: Option<(f64, usize)>,
    glass: Option<(Vec<String>, usize)>,
    semi_diameter: Option<f64>,
    /// `CLAP min max`: a circular hard aperture.
    clear_aperture: Option<(f64, f64, usize)>,
    conic: f64,
    parameters: BTreeMap<usize, (f64, usize)>,
    stop: bool,
    /// `OBDC x y`: an aperture decentre.
    aperture_decentre: Option<(f64, f64, usize)>,
    refused: Option<(usize, String)>,
}

/// The system-wide settings of a `.zmx` file.
#[derive(Clone, Debug, Default)]
struct ZemaxSystem {
    unit_scale: Option<(f64, String)>,
    name: Option<String>,
    notes: Vec<String>,
    catalogues: Vec<String>,
    f_number: Option<f64>,
    entrance_pupil_diameter: Option<f64>,
    object_na: Option<(f64, usize)>,
    floating_stop: bool,
    field_type: Option<i64>,
    fields_x: Vec<f64>,
    fields_y: Vec<f64>,
    field_count: Option<usize>,
    configurations: Option<(usize, usize)>,
    mode: Option<(String, usize)>,
}

/// Reads a `.zmx` file's bytes (any of its encodings) into a validated prescription.
pub fn read_zemax(bytes: &[u8], source: &Path) -> Result<Prescription, PrescriptionError> {
    let error = |line: Option<usize>, message: String| PrescriptionError {
        file: source.to_path_buf(),
        line,
        message,
    };
    let text = decode(bytes).map_err(|m| error(None, m))?;
    let (system, surfaces) = parse(&text).map_err(|(line, m)| error(line, m))?;
    convert(&system, &surfaces, source)
}

/// True when `bytes` look like a Zemax file (its keywords, in any of its encodings): lets a
/// `.zmx` saved under another name load too.
pub fn looks_like_zemax(bytes: &[u8]) -> bool {
    let Ok(text) = decode(&bytes[..bytes.len().min(4096)]) else {
        return false;
    };
    text.lines()
        .take(40)
        .any(|l| l.starts_with("VERS ") || l.starts_with("MODE SEQ") || l.starts_with("SURF 0"))
}

/// Text of a `.zmx` file: UTF-16 (little- or big-endian, with or without a byte-order mark:
/// what OpticStudio writes), UTF-8 (with or without a mark), or Latin-1.
fn decode(bytes: &[u8]) -> Result<String, String> {
    let utf16 = |body: &[u8], little: bool| -> Result<String, String> {
        if !body.len().is_multiple_of(2) {
            return Err("is UTF-16 with an odd number of bytes: the file is truncated".into());
        }
        let units: Vec<u16> = body
            .chunks_exact(2)
            .map(|p| {
                if little {
                    u16::from_le_bytes([p[0], p[1]])
                } else {
                    u16::from_be_bytes([p[0], p[1]])
                }
            })
            .collect();
        String::from_utf16(&units).map_err(|_| "is not valid UTF-16 text".to_string())
    };
    match bytes {
        [0xFF, 0xFE, rest @ ..] => utf16(rest, true),
        [0xFE, 0xFF, rest @ ..] => utf16(rest, false),
        [0xEF, 0xBB, 0xBF, rest @ ..] => {
            String::from_utf8(rest.to_vec()).map_err(|_| "is not valid UTF-8 text".into())
        }
        // UTF-16 without a mark: ASCII keywords leave every other byte zero.
        [a, 0, b, 0, ..] if *a != 0 && *b != 0 => utf16(bytes, true),
        [0, a, 0, b, ..] if *a != 0 && *b != 0 => utf16(bytes, false),
        _ => Ok(match String::from_utf8(bytes.to_vec()) {
            Ok(text) => text,
            // Latin-1: every byte is the code point of the same number.
            Err(_) => bytes.iter().map(|&b| b as char).collect(),
        }),
    }
}

/// A number as Zemax writes it (`7.0E-002`, `0.`, `INFINITY`).
fn number(token: &str) -> Option<f64> {
    match token.to_ascii_uppercase().as_str() {
        "INFINITY" | "INF" => Some(f64::INFINITY),
        "-INFINITY" | "-INF" => Some(f64::NEG_INFINITY),
        _ => token.parse::<f64>().ok().filter(|v| !v.is_nan()),
    }
}

type ParseError = (Option<usize>, String);

fn parse(text: &str) -> Result<(ZemaxSystem, Vec<ZemaxSurface>), ParseError> {
    let mut system = ZemaxSystem::default();
    let mut surfaces: Vec<ZemaxSurface> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let tokens: Vec<&str> = raw.split_whitespace().collect();
        let Some(&keyword) = tokens.first() else {
            continue;
        };
        let args = &tokens[1..];
        let value = |k: usize, what: &str| -> Result<f64, ParseError> {
            args.get(k).and_then(|t| number(t)).ok_or_else(|| {
                (
                    Some(line),
                    format!(
                        "{keyword}: expected a number for {what}, found '{}'",
                        raw.trim()
                    ),
                )
            })
        };
        let finite = |k: usize, what: &str| -> Result<f64, ParseError> {
            let v = value(k, what)?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err((
                    Some(line),
                    format!("{keyword}: {what} must be finite, found {v}"),
                ))
            }
        };
        if keyword == "SURF" {
            let number = args
                .first()
                .and_then(|t| t.parse::<usize>().ok())
                .ok_or((Some(line), "SURF: expected a surface number".to_string()))?;
            if number != surfaces.len() {
                return Err((
                    Some(line),
                    format!(
                        "SURF {number} follows SURF {}: surfaces must be numbered 0, 1, 2, … in order",
                        surfaces.len() as i64 - 1
                    ),
                ));
            }
            surfaces.push(ZemaxSurface {
                number,
                line,
                ..ZemaxSurface::default()
            });
            continue;
        }
        if let Some(surface) = surfaces.last_mut() {
            match keyword {
                "TYPE" => {
                    let kind = args.first().map_or("STANDARD", |t| t).to_ascii_uppercase();
                    surface.kind = Some((kind, line));
                    continue;
                }
                "CURV" => {
                    surface.curvature = finite(0, "the curvature")?;
                    continue;
                }
                "DISZ" => {
                    surface.thickness = Some((value(0, "the thickness")?, line));
                    continue;
                }
                "GLAS" => {
                    surface.glass = Some((args.iter().map(|s| s.to_string()).collect(), line));
                    continue;
                }
                "DIAM" => {
                    surface.semi_diameter = Some(finite(0, "the semi-diameter")?.abs());
                    continue;
                }
                "CLAP" => {
                    surface.clear_aperture = Some((
                        finite(0, "the minimum radius")?,
                        finite(1, "the maximum radius")?,
                        line,
                    ));
                    continue;
                }
                "OBDC" => {
                    surface.aperture_decentre = Some((
                        finite(0, "the x decentre")?,
                        finite(1, "the y decentre")?,
                        line,
                    ));
                    continue;
                }
                "CONI" => {
                    surface.conic = finite(0, "the conic constant")?;
                    continue;
                }
                "PARM" => {
                    let index = args
                        .first()
                        .and_then(|t| t.parse::<usize>().ok())
                        .ok_or((Some(line), "PARM: expected a parameter number".to_string()))?;
                    surface
                        .parameters
                        .insert(index, (finite(1, "the parameter")?, line));
                    continue;
                }
                "STOP" => {
                    surface.stop = true;
                    continue;
                }
                _ => {
                    if let Some(what) = unsupported_surface_keyword(keyword)
                        && surface.refused.is_none()
                        && !ignorable_aperture(keyword, args)
                    {
                        surface.refused = Some((line, format!("{what} ({keyword})")));
                    }
                    if IGNORED_SURFACE_KEYWORDS.contains(&keyword)
                        || unsupported_surface_keyword(keyword).is_some()
                    {
                        continue;
                    }
                }
            }
        }
        match keyword {
            "MODE" => system.mode = Some((args.first().unwrap_or(&"").to_string(), line)),
            "UNIT" => {
                let unit = args.first().unwrap_or(&"").to_ascii_uppercase();
                let scale = match unit.as_str() {
                    "MM" => 1.0,
                    "CM" => 10.0,
                    "IN" | "INCH" | "INCHES" => 25.4,
                    "METER" | "METERS" | "M" => 1000.0,
                    other => {
                        return Err((
                            Some(line),
                            format!(
                                "UNIT '{other}' is not a lens unit realcam knows (MM, CM, IN, METER)"
                            ),
                        ));
                    }
                };
                system.unit_scale = Some((scale, unit));
            }
            "NAME" => {
                let name = args.join(" ").trim_matches('"').trim().to_string();
                system.name = (!name.is_empty()).then_some(name);
            }
            "NOTE" => {
                let note = args.iter().skip(1).copied().collect::<Vec<_>>().join(" ");
                if !note.trim().is_empty() {
                    system.notes.push(note.trim().to_string());
                }
            }
            "GCAT" => system.catalogues = args.iter().map(|s| s.to_string()).collect(),
            "FNUM" => system.f_number = Some(finite(0, "the f-number")?),
            "ENPD" => {
                system.entrance_pupil_diameter = Some(finite(0, "the entrance pupil diameter")?)
            }
            "OBNA" => system.object_na = Some((finite(0, "the object-space NA")?, line)),
            "FLOA" => system.floating_stop = true,
            "FTYP" => {
                system.field_type = args.first().and_then(|t| t.parse().ok());
                system.field_count = args.get(2).and_then(|t| t.parse().ok());
            }
            "XFLN" | "XFLD" => {
                system.fields_x = args.iter().filter_map(|t| number(t)).collect();
            }
            "YFLN" | "YFLD" => {
                system.fields_y = args.iter().filter_map(|t| number(t)).collect();
            }
            "MNUM" => {
                let count = args.first().and_then(|t| t.parse().ok()).unwrap_or(1);
                system.configurations = Some((count, line));
            }
            _ => {}
        }
    }
    Ok((system, surfaces))
}

/// `SQAP`/`OBSC`-style lines that a file writes with zero size are no aperture at all.
fn ignorable_aperture(keyword: &str, args: &[&str]) -> bool {
    matches!(keyword, "SQAP" | "ELAP" | "OBSC" | "OBSQ" | "OBEL")
        && args.iter().take(2).all(|t| number(t) == Some(0.0))
}

/// The medium after a surface as its `GLAS` line names it.
enum Medium {
    Air,
    /// n_d only (a model glass with V_d = 0: Zemax's constant index).
    Constant(f64),
    Glass(Glass),
}

fn convert(
    system: &ZemaxSystem,
    surfaces: &[ZemaxSurface],
    source: &Path,
) -> Result<Prescription, PrescriptionError> {
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
    if let Some((count, line)) = system.configurations
        && count > 1
    {
        return Err(error(
            Some(line),
            format!(
                "MNUM {count}: a multi-configuration file (a zoom or focus series of {count} configurations); realcam reads single-configuration lenses: save one configuration on its own"
            ),
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
    let lens = &surfaces[1..surfaces.len() - 1];

    // Refuse what cannot be represented, surface by surface, in order.
    for s in lens {
        let at =
            |line: usize, what: String| error(Some(line), format!("SURF {}: {what}", s.number));
        if let Some((kind, line)) = &s.kind
            && !SUPPORTED_TYPES.contains(&kind.as_str())
        {
            return Err(at(
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
            return Err(at(
                *line,
                "GLAS MIRROR: a mirror; realcam traces refracting (dioptric) lenses only".into(),
            ));
        }
        if let Some((line, what)) = &s.refused {
            return Err(at(*line, format!("{what}: realcam cannot represent it")));
        }
        if let Some((x, y, line)) = s.aperture_decentre
            && (x != 0.0 || y != 0.0)
        {
            return Err(at(
                line,
                format!(
                    "the aperture is decentred by ({x}, {y}) (OBDC): realcam's surfaces are centred on the axis"
                ),
            ));
        }
        if let Some((min, _, line)) = s.clear_aperture
            && min > 0.0
        {
            return Err(at(
                line,
                format!(
                    "CLAP with an inner radius {min}: an annular aperture (a central obscuration) cannot be represented"
                ),
            ));
        }
        let is_asphere = s.kind.as_ref().is_some_and(|(k, _)| k == "EVENASPH");
        if is_asphere
            && let Some((&i, &(_, line))) = s.parameters.range(ASPHERIC_TERMS + 1..).next()
        {
            return Err(at(
                line,
                format!(
                    "PARM {i}: an even asphere has terms PARM 1 (r²) to PARM {ASPHERIC_TERMS} (r^{})",
                    2 * ASPHERIC_TERMS
                ),
            ));
        }
        match s.thickness {
            Some((t, line)) if !t.is_finite() => {
                return Err(at(
                    line,
                    "DISZ INFINITY on a lens surface: only the object may be at infinity".into(),
                ));
            }
            _ => {}
        }
    }
    if let Some((na, line)) = system.object_na
        && !lens
            .iter()
            .any(|s| s.stop && s.semi_diameter.is_some_and(|d| d > 0.0))
    {
        return Err(error(
            Some(line),
            format!(
                "OBNA {na}: the system aperture is an object-space numerical aperture, which realcam cannot size the stop from; give the stop surface a DIAM"
            ),
        ));
    }

    let medium_of = |s: &ZemaxSurface| -> Result<Medium, PrescriptionError> {
        let Some((tokens, line)) = &s.glass else {
            return Ok(Medium::Air);
        };
        let at = |message: String| error(Some(*line), format!("SURF {}: {message}", s.number));
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
        let makers: Vec<&str> = system.catalogues.iter().map(String::as_str).collect();
        catalogue()
            .find_preferring(name, &makers)
            .map(|id| Medium::Glass(Glass::Catalogue(id)))
            .map_err(|e| at(format!("GLAS {name}: {e}")))
    };

    let mut rows = Vec::with_capacity(lens.len());
    let mut missing_aperture = Vec::with_capacity(lens.len());
    for (i, s) in lens.iter().enumerate() {
        let (index, glass) = match medium_of(s)? {
            Medium::Air => (1.0, None),
            Medium::Constant(n) => (n, None),
            Medium::Glass(g) => (g.index(FRAUNHOFER_D_NM), Some(g)),
        };
        let radius = if s.curvature == 0.0 {
            f64::INFINITY
        } else {
            scale / s.curvature
        };
        let thickness = if i + 1 == lens.len() {
            0.0
        } else {
            s.thickness.map_or(0.0, |(t, _)| t * scale)
        };
        let mut asphere = Asphere {
            conic: s.conic,
            ..Asphere::NONE
        };
        if s.kind.as_ref().is_some_and(|(k, _)| k == "EVENASPH") {
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
    // Zemax's default stop is surface 1.
    if !rows.iter().any(|r| r.base.stop) {
        rows[0].base.stop = true;
    }
    let stop = rows.iter().position(|r| r.base.stop).unwrap_or(0);
    if rows.iter().filter(|r| r.base.stop).count() > 1 {
        return Err(error(None, "more than one surface is marked STOP".into()));
    }
    let image = &surfaces[surfaces.len() - 1];
    let object = &surfaces[0];
    let object_distance = object.thickness.map_or(f64::INFINITY, |(t, _)| t * scale);
    let film_distance = lens
        .last()
        .and_then(|s| s.thickness)
        .map(|(t, _)| t * scale)
        .filter(|t| t.is_finite() && *t > 0.0);
    let image_semi = image.semi_diameter.filter(|&d| d > 0.0).map(|d| d * scale);

    // The stop's size is the system aperture's, as in OpticStudio, where a semi-diameter clips
    // no ray: an entrance-pupil diameter (ENPD) or an f-number (FNUM) sizes it paraxially, and
    // only a floating stop (FLOA, or no system aperture at all) takes the stop's own DIAM; a
    // floating stop without one opens as wide as the other clear apertures let an axial beam.
    // Then the clear apertures the file leaves open are found from the rays the design's fields
    // send through that stop.
    let name_of = |s: &ZemaxSurface| format!("SURF {}", s.number);
    let stop_diam = (!missing_aperture[stop]).then_some(rows[stop].base.aperture);
    let sized = if let Some(epd) = system
        .entrance_pupil_diameter
        .filter(|_| !system.floating_stop)
    {
        Some(clear_aperture::stop_for_entrance_pupil(
            &rows,
            stop,
            epd * scale,
        ))
    } else if let Some(n) = system.f_number.filter(|_| !system.floating_stop) {
        Some(clear_aperture::stop_for_f_number(&rows, stop, n))
    } else if stop_diam.is_some() {
        None
    } else if system.floating_stop {
        Some(clear_aperture::widest_stop(&rows, stop, &missing_aperture))
    } else {
        Some(Err(
            "the file gives no system aperture (FNUM, ENPD or FLOA)".to_string(),
        ))
    };
    if let Some(sized) = sized {
        let diameter = sized.map_err(|why| {
            error(
                Some(lens[stop].line),
                format!("{}: cannot size the stop: {why}", name_of(&lens[stop])),
            )
        })?;
        rows[stop].base.aperture = diameter;
        missing_aperture[stop] = false;
    }
    if missing_aperture.iter().any(|&m| m) {
        let fields =
            field_points(system, scale, &rows, film_distance).map_err(|m| error(None, m))?;
        clear_aperture::fill_missing(&mut rows, &missing_aperture, &fields, object_distance)
            .map_err(|(i, why)| {
                error(
                    Some(lens[i].line),
                    format!(
                        "{}: has no DIAM and its clear aperture cannot be found: {why}",
                        name_of(&lens[i])
                    ),
                )
            })?;
    }

    let stem = source
        .file_stem()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "lens".into());
    // Validation locates problems by the row's line, the line of its SURF: name the SURF too.
    let surf_at_line =
        |line: Option<usize>| lens.iter().find(|s| Some(s.line) == line).map(|s| s.number);
    let mut prescription = Prescription::from_rows(&stem, source, LensFormat::ThicknessAfter, rows)
        .map_err(|e| match surf_at_line(e.line) {
            Some(n) => PrescriptionError {
                message: format!("SURF {n}: {}", e.message),
                ..e
            },
            None => e,
        })?;
    prescription.info = LensInfo {
        title: system.name.clone(),
        source: Some(format!("Zemax file {}", source.display())),
        f_number: system.f_number,
        film_diagonal_mm: image_semi.map(|h| 2.0 * h),
        film_distance_mm: film_distance,
        notes: (!system.notes.is_empty()).then(|| system.notes.join(" ")),
        ..LensInfo::default()
    };
    Ok(prescription)
}

/// The design's field points (`FTYP`, `XFLN`/`YFLN`) as realcam's clear-aperture search wants
/// them: radial distances from the axis as object-space angles, object heights, or image
/// heights. Always includes the axis.
fn field_points(
    system: &ZemaxSystem,
    scale: f64,
    rows: &[SurfaceRow],
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
    let _ = rows;
    Ok(points)
}
