//! Reading a `.zmx` file's keyword lines into its system settings and its `SURF` blocks, in
//! the file's units; which surfaces realcam can represent is [`super::convert`]'s to decide,
//! but the keywords for what it cannot are noted here, with their lines.

use std::collections::BTreeMap;

use super::decode::{number, unit_scale};

/// Surface keywords that carry no optics realcam uses (drawing, tolerances, solves, comments,
/// mechanical sizes, pickups): skipped silently.
const IGNORED_SURFACE_KEYWORDS: [&str; 23] = [
    "HIDE", "SLAB", "POPS", "FIMP", "MIRR", "MEMA", "COMM", "PZUP", "SSID", "MAZH", "FLAP", "VPAR",
    "PPAR", "CURV", "DISZ", "EDGE", "TCED", "SQAP", "BLNK", "VCON", "XDAT", "IGNR", "THIC",
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
pub(super) struct ZemaxSurface {
    pub(super) number: usize,
    pub(super) line: usize,
    pub(super) kind: Option<(String, usize)>,
    pub(super) curvature: f64,
    /// `DISZ` (thickness after), `INFINITY` as ∞.
    pub(super) thickness: Option<(f64, usize)>,
    pub(super) glass: Option<(Vec<String>, usize)>,
    pub(super) semi_diameter: Option<f64>,
    /// `CLAP min max`: a circular hard aperture.
    pub(super) clear_aperture: Option<(f64, f64, usize)>,
    pub(super) conic: f64,
    pub(super) parameters: BTreeMap<usize, (f64, usize)>,
    pub(super) stop: bool,
    /// `COAT name`: the coating's name in the coating file (`COATING.DAT`), as written (empty
    /// for a bare `COAT`), and the line.
    pub(super) coating: Option<(String, usize)>,
    /// `OBDC x y`: an aperture decentre.
    pub(super) aperture_decentre: Option<(f64, f64, usize)>,
    pub(super) refused: Option<(usize, String)>,
}

/// The system-wide settings of a `.zmx` file.
#[derive(Clone, Debug, Default)]
pub(super) struct ZemaxSystem {
    pub(super) unit_scale: Option<(f64, String)>,
    pub(super) name: Option<String>,
    pub(super) notes: Vec<String>,
    pub(super) catalogues: Vec<String>,
    pub(super) f_number: Option<f64>,
    pub(super) entrance_pupil_diameter: Option<f64>,
    pub(super) object_na: Option<(f64, usize)>,
    pub(super) floating_stop: bool,
    pub(super) field_type: Option<i64>,
    pub(super) fields_x: Vec<f64>,
    pub(super) fields_y: Vec<f64>,
    pub(super) field_count: Option<usize>,
    /// `MNUM count active`: the number of configurations, and the line.
    pub(super) configurations: Option<(usize, usize)>,
    /// The multi-configuration editor's rows that follow `MNUM`.
    pub(super) operands: Vec<ConfigurationOperand>,
    pub(super) mode: Option<(String, usize)>,
}

/// One row of the multi-configuration editor: `OPER number configuration value …`, e.g.
/// `THIC 5 2 12.3 0 0 0 1 1 1 0 0 "" 0` (surface 5's thickness in configuration 2) or
/// `APER 0 2 4.0 …` (the system aperture's value in configuration 2). Rows come operand by
/// operand, each with its value in every configuration.
#[derive(Clone, Debug)]
pub(super) struct ConfigurationOperand {
    pub(super) name: String,
    /// The operand's own number: a surface for `THIC`, a field or wavelength for others.
    pub(super) number: i64,
    /// 1-based configuration.
    pub(super) configuration: usize,
    /// The value, where it is a number (a glass operand's is a name).
    pub(super) value: Option<f64>,
    pub(super) line: usize,
}

/// A multi-configuration row's shape: an operand name, then two whole numbers (its number and
/// its configuration) and a value.
fn configuration_operand(
    keyword: &str,
    args: &[&str],
    line: usize,
) -> Option<ConfigurationOperand> {
    let name_like = (3..=4).contains(&keyword.len())
        && keyword
            .bytes()
            .all(|b| b.is_ascii_uppercase() || b.is_ascii_digit());
    if !name_like || args.len() < 3 {
        return None;
    }
    Some(ConfigurationOperand {
        name: keyword.to_string(),
        number: args[0].parse().ok()?,
        configuration: args[1].parse().ok()?,
        value: number(args[2]),
        line,
    })
}

/// A parse failure: the line (where there is one) and what is wrong.
pub(super) type ParseError = (Option<usize>, String);

/// The system settings and the surface blocks of a `.zmx` file's text, as written (file units,
/// nothing refused yet but what cannot be read).
pub(super) fn parse(text: &str) -> Result<(ZemaxSystem, Vec<ZemaxSurface>), ParseError> {
    let mut system = ZemaxSystem::default();
    let mut surfaces: Vec<ZemaxSurface> = Vec::new();
    // After `MNUM`, lines of an operand row's shape are the multi-configuration editor's.
    let mut in_configurations = false;
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
        if in_configurations
            && keyword != "SURF"
            && let Some(operand) = configuration_operand(keyword, args, line)
        {
            system.operands.push(operand);
            continue;
        }
        if keyword == "SURF" {
            in_configurations = false;
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
                "COAT" => {
                    surface.coating = Some((args.first().map_or("", |t| t).to_string(), line));
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
                let scale = unit_scale(&unit).ok_or_else(|| {
                    (
                        Some(line),
                        format!(
                            "UNIT '{unit}' is not a lens unit realcam knows (MM, CM, IN, METER)"
                        ),
                    )
                })?;
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
                in_configurations = true;
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
