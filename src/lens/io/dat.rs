//! pbrt and Kolb lens tables (`.dat`): rows of `radius thickness index aperture [glass]`.
//!
//! A prescription is a table of rows `radius thickness index aperture-diameter` (mm), front
//! (scene side) to back (film side). See [`crate::lens`] for the sign conventions. Two layouts
//! of the second column exist in the wild and both load:
//!
//! * **thickness-after** (pbrt-v3/v4): the distance from this surface to the next one; the last
//!   row holds 0, a placeholder for the film distance that focusing computes.
//! * **gap-before** (Kolb et al. 1995, the 100 mm designs): the distance from the previous
//!   surface to this one; the first row holds 0.
//!
//! An optional fifth column gives the glass of the medium after the surface: its Abbe number
//! V_d (a model glass through the row's index as n_d), or a catalogue glass name, whose n_d
//! must agree with the index column within [`GLASS_ND_TOLERANCE`] (else a warning). Rows
//! without it are non-dispersive.
//!
//! Whatever the file's layout, the rows are stored thickness-after, with the last thickness 0
//! (the film distance is not part of the lens).

use std::path::Path;

use super::shorten;
use crate::glass::{Glass, catalogue};
use crate::lens::prescription::{LensFormat, Prescription, PrescriptionError, SurfaceRow};

/// How far a named glass's catalogue n_d may be from the row's index before realcam warns.
pub const GLASS_ND_TOLERANCE: f64 = 0.002;

/// Parses a `.dat` table; `source` names it in errors and gives the lens its name.
pub fn parse_dat(
    text: &str,
    source: &Path,
    format: Option<LensFormat>,
) -> Result<Prescription, PrescriptionError> {
    let raw = parse_rows(text, source)?;
    let error = |line: Option<usize>, message: String| PrescriptionError {
        file: source.to_path_buf(),
        line,
        message,
    };
    if raw.is_empty() {
        return Err(error(
            None,
            "no surfaces: expected rows of 'radius thickness index aperture' (mm)".into(),
        ));
    }
    let format = match format {
        Some(f) => f,
        None => detect_format(&raw).map_err(|m| error(None, m))?,
    };
    let (rows, warnings) = normalise(&raw, format, source)?;
    let name = source
        .file_name()
        .map(|n| n.to_string_lossy().trim_end_matches(".dat").to_string())
        .unwrap_or_else(|| "lens".into());
    let mut prescription = Prescription::from_rows(&name, source, format, rows)?;
    prescription.warnings.extend(warnings);
    Ok(prescription)
}

/// A row as written in the file, before layout normalisation.
struct RawRow {
    values: [f64; 4],
    /// The fifth column, if any: V_d or a glass name.
    glass: Option<String>,
    line: usize,
}

fn parse_rows(text: &str, source: &Path) -> Result<Vec<RawRow>, PrescriptionError> {
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_number = i + 1;
        let error = |message: String| PrescriptionError {
            file: source.to_path_buf(),
            line: Some(line_number),
            message,
        };
        let content = line.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        if content.len() > 1000 {
            return Err(error(format!(
                "line is {} characters long; expected 4 numbers",
                content.len()
            )));
        }
        let fields: Vec<&str> = content.split_whitespace().collect();
        if !(4..=5).contains(&fields.len()) {
            return Err(error(format!(
                "expected 4 columns 'radius thickness index aperture' and optionally a fifth, the glass (V_d or a catalogue name); found {}: '{}'",
                fields.len(),
                shorten(content)
            )));
        }
        let mut values = [0.0; 4];
        const COLUMNS: [&str; 4] = ["radius", "thickness", "index", "aperture"];
        for (c, field) in fields.iter().take(4).enumerate() {
            let value = parse_number(field, c == 0).ok_or_else(|| {
                error(format!(
                    "{} '{}' is not a number{}",
                    COLUMNS[c],
                    shorten(field),
                    if c == 0 {
                        " (use inf for a flat surface)"
                    } else {
                        ""
                    }
                ))
            })?;
            values[c] = value;
        }
        rows.push(RawRow {
            values,
            glass: fields.get(4).map(|g| g.to_string()),
            line: line_number,
        });
    }
    Ok(rows)
}

/// A finite number, or for the radius column also ±inf (a flat surface).
fn parse_number(field: &str, allow_infinite: bool) -> Option<f64> {
    let value: f64 = field.parse().ok()?;
    if value.is_nan() || (value.is_infinite() && !allow_infinite) {
        return None;
    }
    Some(value)
}

fn detect_format(rows: &[RawRow]) -> Result<LensFormat, String> {
    // One row reads the same in both layouts; validation then says what is missing.
    if rows.len() == 1 {
        return Ok(LensFormat::ThicknessAfter);
    }
    let first_zero = rows[0].values[1] == 0.0;
    let last_zero = rows[rows.len() - 1].values[1] == 0.0;
    match (first_zero, last_zero) {
        (true, false) => Ok(LensFormat::GapBefore),
        (false, true) => Ok(LensFormat::ThicknessAfter),
        _ => Err(format!(
            "cannot tell the layout of the thickness column ({}): pass --lens-format thickness-after (distance to the next surface, last row 0) or --lens-format gap-before (distance from the previous surface, first row 0)",
            if first_zero {
                "first and last rows are both 0"
            } else {
                "neither the first nor the last row is 0"
            }
        )),
    }
}

/// Rows in thickness-after form with their glasses resolved, and the warnings about them.
fn normalise(
    raw: &[RawRow],
    format: LensFormat,
    source: &Path,
) -> Result<(Vec<SurfaceRow>, Vec<String>), PrescriptionError> {
    let n = raw.len();
    let mut warnings = Vec::new();
    let mut rows = Vec::with_capacity(n);
    for i in 0..n {
        let [radius, column2, index, aperture] = raw[i].values;
        let thickness = match format {
            LensFormat::ThicknessAfter if i + 1 < n => column2,
            LensFormat::GapBefore if i + 1 < n => raw[i + 1].values[1],
            _ => 0.0,
        };
        // The stop's 0 (and any 0) in the index column means air.
        let index = if index == 0.0 { 1.0 } else { index };
        let line = raw[i].line;
        let glass = match &raw[i].glass {
            None => None,
            Some(column) => Some(glass_column(column, index, line, source, &mut warnings)?),
        };
        let mut row = SurfaceRow::new(radius, thickness, index, aperture);
        row.base.line = line;
        row.glass = glass;
        rows.push(row);
    }
    Ok((rows, warnings))
}

/// The fifth column: V_d (a model glass through the row's index) or a catalogue glass name.
fn glass_column(
    column: &str,
    index: f64,
    line: usize,
    source: &Path,
    warnings: &mut Vec<String>,
) -> Result<Glass, PrescriptionError> {
    let error = |message: String| PrescriptionError {
        file: source.to_path_buf(),
        line: Some(line),
        message,
    };
    if index == 1.0 {
        return Err(error(format!(
            "glass '{}' given for air (index 1): the fifth column is the glass of the medium after the surface",
            shorten(column)
        )));
    }
    if let Ok(v_d) = column.parse::<f64>() {
        return Glass::model(index, v_d).map_err(|e| error(format!("glass column: {e}")));
    }
    let id = catalogue()
        .find(column)
        .map_err(|e| error(format!("glass column: {e}")))?;
    let glass = Glass::Catalogue(id);
    if (glass.n_d() - index).abs() > GLASS_ND_TOLERANCE {
        warnings.push(format!(
            "{}:{line}: glass {} has n_d {:.5} but the index column says {index}; the index column is used, with the glass's dispersion",
            source.display(),
            glass.label(),
            glass.n_d()
        ));
    }
    Ok(glass)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use crate::lens::prescription::{LensFormat, Prescription, PrescriptionError, SurfaceKind};

    fn parse(text: &str) -> Result<Prescription, PrescriptionError> {
        Prescription::parse(text, Path::new("test.dat"), None)
    }

    const SIMPLE_AFTER: &str = "# comment\n50 5 1.5 20\n0 5 0 10\n-50 0 1 20\n";

    #[test]
    fn thickness_after_layout() {
        let p = parse(SIMPLE_AFTER).unwrap();
        assert_eq!(p.format, LensFormat::ThicknessAfter);
        assert_eq!(p.rows.len(), 3);
        assert_eq!(p.rows[0].base.thickness, 5.0);
        assert_eq!(p.rows[1].base.index, 1.0);
        assert_eq!(p.stop_index(), 1);
        assert_eq!(p.vertex_span(), 10.0);
    }

    #[test]
    fn gap_before_layout_gives_same_rows() {
        let before = "50 0 1.5 20\r\n0\t5 0 10  # stop \"quoted\r\n-50 5 1 20";
        let a = parse(SIMPLE_AFTER).unwrap();
        let b = parse(before).unwrap();
        assert_eq!(b.format, LensFormat::GapBefore);
        let strip = |p: &Prescription| {
            p.rows
                .iter()
                .map(|r| {
                    (
                        r.base.radius,
                        r.base.thickness,
                        r.base.index,
                        r.base.aperture,
                    )
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(strip(&a), strip(&b));
    }

    #[test]
    fn infinite_radius_is_flat() {
        let p = parse("inf 5 1.5 20\n0 5 0 10\n-50 0 1 20\n").unwrap();
        assert_eq!(p.rows[0].kind(), SurfaceKind::Flat);
        assert_eq!(p.rows[0].curvature(), 0.0);
        let p = parse("1e12 5 1.5 20\n0 5 0 10\n-50 0 1 20\n").unwrap();
        assert_eq!(p.rows[0].kind(), SurfaceKind::Flat);
    }

    #[test]
    fn ambiguous_layout_asks_for_override() {
        let e = parse("50 5 1.5 20\n0 5 0 10\n-50 3 1 20\n").unwrap_err();
        assert!(e.to_string().contains("--lens-format"), "{e}");
        let p = Prescription::parse(
            "50 5 1.5 20\n0 5 0 10\n-50 3 1 20\n",
            Path::new("x.dat"),
            Some(LensFormat::ThicknessAfter),
        )
        .unwrap();
        assert_eq!(p.rows[2].base.thickness, 0.0);
    }

    #[test]
    fn bad_files_name_file_and_line() {
        let cases: &[(&str, &str, Option<usize>)] = &[
            ("", "no surfaces", None),
            ("# only a comment\n", "no surfaces", None),
            ("50 5 1.5 20\n-50 0 1 20\n", "no aperture stop", None),
            (
                "50 5 1.5 20\n0 5 0 10\n0 5 0 10\n-50 0 1 20\n",
                "second aperture stop",
                Some(3),
            ),
            (
                "50 5 1.5\n0 5 0 10\n-50 0 1 20\n",
                "expected 4 columns",
                Some(1),
            ),
            (
                "50 5 glass 20\n0 5 0 10\n-50 0 1 20\n",
                "index 'glass' is not a number",
                Some(1),
            ),
            (
                "50 5 1.5 nan\n0 5 0 10\n-50 0 1 20\n",
                "aperture 'nan'",
                Some(1),
            ),
            (
                "50 inf 1.5 20\n0 5 0 10\n-50 0 1 20\n",
                "thickness 'inf'",
                Some(1),
            ),
            (
                "50 5 1.5 -20\n0 5 0 10\n-50 0 1 20\n",
                "must be positive",
                Some(1),
            ),
            (
                "50 5 1.5 0\n0 5 0 10\n-50 0 1 20\n",
                "must be positive",
                Some(1),
            ),
            (
                "50 -5 1.5 20\n0 5 0 10\n-50 0 1 20\n",
                "negative thickness",
                Some(1),
            ),
            ("50 5 0.5 20\n0 5 0 10\n-50 0 1 20\n", "below 1", Some(1)),
            (
                "50 5 1.5 20\n0 5 0 10\n-50 0 1 2e5\n",
                "more than 100 m",
                Some(3),
            ),
            (
                "50 5 1.5 20\n0 1e300 0 10\n-50 0 1 20\n",
                "more than 100 m",
                Some(2),
            ),
            (
                "50 5 1.5 1e-4\n0 5 0 10\n-50 0 1 20\n",
                "below a micrometre",
                Some(1),
            ),
            (
                "50 5 11 20\n0 5 0 10\n-50 0 1 20\n",
                "not a real material",
                Some(1),
            ),
            (
                "5 5 1.5 20\n0 5 0 10\n-50 0 1 20\n",
                "wider than the sphere",
                Some(1),
            ),
            (
                "20 0.5 1.5 20\n-20 5 1 20\n0 0 0 10\n-50 0 1 20\n",
                "crosses the one before it",
                Some(2),
            ),
            (
                "50 5 1.5 20\n-50 0 0 10\n0 0 0 10",
                "cannot be the last surface",
                Some(3),
            ),
        ];
        for (text, expect, line) in cases {
            let e =
                Prescription::parse(text, Path::new("bad.dat"), Some(LensFormat::ThicknessAfter))
                    .unwrap_err();
            let shown = e.to_string();
            assert!(shown.contains(expect), "{text:?}: {shown}");
            assert!(shown.starts_with("bad.dat"), "{shown}");
            assert_eq!(e.line, *line, "{text:?}: {shown}");
        }
    }
}
