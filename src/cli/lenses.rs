//! `realcam lenses`: the lenses built into realcam, with their optics computed by realcam.
//!
//! Every figure comes from the lens itself, not from the nominal fields of its file: the focal
//! length and f-number from first-order optics (the system matrix and the entrance pupil), the
//! field of view from real chief rays at infinity focus ([`field_angle`]). The nominal
//! (published) focal length and f-number are shown beside them where they differ.

use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::Args;
use serde::Serialize;

use crate::lens::field::{field_angle, field_edge};
use crate::lens::first_order::FirstOrder;
use crate::lens::io::bundled::{BUNDLED, BundledLens};
use crate::lens::spacing::rows_at;
use crate::lens::{LensSystem, SurfaceKind};

/// Diagonal of the 35 mm still frame (36 × 24 mm), on which `realcam lenses` gives every
/// lens's field of view so that they compare directly.
pub const FULL_FRAME_DIAGONAL_MM: f64 = 43.266_615_305_567_875;

#[derive(Args, Debug, Clone)]
pub struct LensesArgs {
    /// Only the lenses whose name contains this text (e.g. `canon`, `fisheye`).
    pub filter: Option<String>,
    /// Print a JSON array instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// A lens's image circle when it is smaller than the frame asked about.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ImageCircle {
    pub diameter_mm: f64,
    /// Full angle the circle covers, degrees.
    pub field_of_view_deg: f64,
}

/// Diagonal field of view on a frame, or the image circle where the frame's corners get no
/// light.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Coverage {
    pub film_diagonal_mm: f64,
    /// Full diagonal field of view, degrees (`None` where the corners are outside the image
    /// circle).
    pub field_of_view_deg: Option<f64>,
    pub image_circle: Option<ImageCircle>,
}

/// One zoom position of a bundled zoom, at infinity focus.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ZoomPositionEntry {
    /// Paraxial effective focal length, mm (computed).
    pub focal_length_mm: f64,
    /// EFL / entrance-pupil diameter with the stop as the position opens it (computed).
    pub f_number: f64,
    /// Diagonal field of view on the 35 mm frame (`None` where its corners get no light).
    pub field_of_view_deg: Option<f64>,
}

/// One bundled lens as `realcam lenses` reports it.
#[derive(Clone, Debug, Serialize)]
pub struct LensEntry {
    pub name: &'static str,
    pub file: &'static str,
    pub title: Option<String>,
    /// Paraxial effective focal length, mm (computed).
    pub focal_length_mm: f64,
    /// Published focal length, mm, from the lens file.
    pub nominal_focal_length_mm: Option<f64>,
    /// EFL / entrance-pupil diameter with the stop wide open (computed).
    pub f_number: f64,
    pub nominal_f_number: Option<f64>,
    /// At infinity focus on the 35 mm frame (36 × 24 mm).
    pub full_frame: Coverage,
    /// At infinity focus on the image format the lens was designed for, when its file says.
    pub design_format: Option<Coverage>,
    /// Pieces of glass, cemented ones counted apart (a filter or cover plate included).
    pub elements: usize,
    pub aspheric_surfaces: usize,
    /// A zoom's positions (`--zoom-position 1, 2, …`); empty for a lens of fixed focal length.
    pub zoom_positions: Vec<ZoomPositionEntry>,
    pub year: Option<u32>,
    pub source: Option<String>,
    pub licence: Option<String>,
}

impl LensEntry {
    /// Loads `lens` and derives its figures.
    pub fn derive(lens: &'static BundledLens) -> anyhow::Result<LensEntry> {
        let prescription = lens.load(None)?;
        let system = LensSystem::new(&prescription.rows, None);
        let first_order =
            FirstOrder::compute(&system).with_context(|| format!("bundled lens {}", lens.name))?;
        // Infinity focus: the film at the rear focal plane.
        let film_distance = first_order.back_focal_length;
        let zoom_positions = prescription
            .spacings
            .zoom
            .iter()
            .enumerate()
            .map(|(i, position)| -> anyhow::Result<ZoomPositionEntry> {
                let at = || format!("bundled lens {}, zoom position {}", lens.name, i + 1);
                let rows = rows_at(&prescription.rows, Some(position), None)
                    .map_err(anyhow::Error::msg)
                    .with_context(at)?;
                let system = LensSystem::new(&rows, None);
                let first_order = FirstOrder::compute(&system).with_context(at)?;
                let semi = FULL_FRAME_DIAGONAL_MM / 2.0;
                Ok(ZoomPositionEntry {
                    focal_length_mm: first_order.focal_length,
                    f_number: first_order.f_number,
                    field_of_view_deg: field_angle(&system, first_order.back_focal_length, semi)
                        .map(|a| 2.0 * a.to_degrees()),
                })
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let coverage = |diagonal: f64| {
            let semi = diagonal / 2.0;
            let field_of_view_deg =
                field_angle(&system, film_distance, semi).map(|a| 2.0 * a.to_degrees());
            let image_circle = match field_of_view_deg {
                Some(_) => None,
                None => image_circle(&system, film_distance, semi),
            };
            Coverage {
                film_diagonal_mm: diagonal,
                field_of_view_deg,
                image_circle,
            }
        };
        let info = &prescription.info;
        Ok(LensEntry {
            name: lens.name,
            file: lens.file,
            title: info.title.clone(),
            focal_length_mm: first_order.focal_length,
            nominal_focal_length_mm: info.focal_length_mm,
            f_number: first_order.f_number,
            nominal_f_number: info.f_number,
            full_frame: coverage(FULL_FRAME_DIAGONAL_MM),
            design_format: info.film_diagonal_mm.map(coverage),
            elements: prescription
                .rows
                .iter()
                .filter(|r| r.base.index != 1.0)
                .count(),
            aspheric_surfaces: prescription
                .rows
                .iter()
                .filter(|r| r.kind() == SurfaceKind::Aspheric)
                .count(),
            zoom_positions,
            year: info.year,
            source: info.source.clone(),
            licence: info.licence.clone(),
        })
    }
}

/// The edge of the image circle of a lens that does not cover a film of radius `film_radius`:
/// [`field_edge`]'s coarse scan, refined by bisection to a micrometre.
fn image_circle(system: &LensSystem, film_distance: f64, film_radius: f64) -> Option<ImageCircle> {
    let (mut inside, mut angle) = field_edge(system, film_distance, film_radius)?;
    let mut outside = (inside + film_radius / 64.0).min(film_radius);
    while outside - inside > 1e-3 {
        let middle = 0.5 * (inside + outside);
        match field_angle(system, film_distance, middle) {
            Some(a) => (inside, angle) = (middle, a),
            None => outside = middle,
        }
    }
    Some(ImageCircle {
        diameter_mm: 2.0 * inside,
        field_of_view_deg: 2.0 * angle.to_degrees(),
    })
}

/// The bundled lenses whose name contains `filter` (all of them for `None`), in `BUNDLED`'s
/// order: the classic tables first, then the library.
pub fn entries(filter: Option<&str>) -> anyhow::Result<Vec<LensEntry>> {
    BUNDLED
        .iter()
        .filter(|lens| filter.is_none_or(|f| lens.name.contains(f)))
        .map(LensEntry::derive)
        .collect()
}

/// `computed` to `decimals` between `prefix` and `unit`, followed by the nominal value in
/// brackets when it reads differently at that precision.
fn with_nominal(
    prefix: &str,
    computed: f64,
    unit: &str,
    nominal: Option<f64>,
    decimals: usize,
) -> String {
    let shown = format!("{computed:.decimals$}");
    match nominal {
        Some(n) if format!("{n:.decimals$}") != shown => {
            format!("{prefix}{shown}{unit} ({prefix}{n}{unit})")
        }
        _ => format!("{prefix}{shown}{unit}"),
    }
}

fn coverage_cell(c: &Coverage) -> String {
    match (c.field_of_view_deg, c.image_circle) {
        (Some(fov), _) => format!("{fov:.1}°"),
        (None, Some(circle)) => format!(
            "○ {:.1}° ⌀{:.1}",
            circle.field_of_view_deg, circle.diameter_mm
        ),
        (None, None) => "n/a".into(),
    }
}

/// A zoom's first and last position of `figure`, as `a–b` to `decimals` (the zoom's
/// positions run from one end of its range to the other).
fn zoom_range(
    positions: &[ZoomPositionEntry],
    figure: impl Fn(&ZoomPositionEntry) -> Option<f64>,
    decimals: usize,
) -> Option<String> {
    let (first, last) = (figure(positions.first()?)?, figure(positions.last()?)?);
    Some(format!("{first:.decimals$}–{last:.decimals$}"))
}

/// The table `realcam lenses` prints.
pub fn table(entries: &[LensEntry]) -> String {
    let rows: Vec<[String; 8]> = entries
        .iter()
        .map(|e| {
            let zoom = &e.zoom_positions;
            [
                e.name.to_string(),
                zoom_range(zoom, |p| Some(p.focal_length_mm), 1).map_or_else(
                    || with_nominal("", e.focal_length_mm, " mm", e.nominal_focal_length_mm, 1),
                    |range| format!("{range} mm"),
                ),
                zoom_range(zoom, |p| Some(p.f_number), 2).map_or_else(
                    || with_nominal("f/", e.f_number, "", e.nominal_f_number, 2),
                    |range| format!("f/{range}"),
                ),
                zoom_range(zoom, |p| p.field_of_view_deg, 1)
                    .map_or_else(|| coverage_cell(&e.full_frame), |range| format!("{range}°")),
                e.elements.to_string(),
                e.aspheric_surfaces.to_string(),
                e.year.map_or("–".into(), |y| y.to_string()),
                e.source.as_deref().map_or_else(
                    || "pbrt/Kolb .dat table, see lenses/README.md".to_string(),
                    // The patent or design; the repository it came from follows the ';'.
                    |s| s.split(';').next().unwrap_or(s).trim().to_string(),
                ),
            ]
        })
        .collect();
    let header = [
        "name",
        "focal length",
        "f-number",
        "FoV on 36×24",
        "elements",
        "aspheres",
        "year",
        "source",
    ];
    let width = |k: usize| {
        rows.iter()
            .map(|r| r[k].chars().count())
            .chain([header[k].chars().count()])
            .max()
            .unwrap_or(0)
    };
    let widths: Vec<usize> = (0..header.len()).map(width).collect();
    let line = |cells: [&str; 8]| {
        let mut out = String::new();
        for (k, cell) in cells.iter().enumerate() {
            let pad = widths[k].saturating_sub(cell.chars().count());
            // Text left-aligned, figures right-aligned.
            if matches!(k, 0 | 7) {
                out += cell;
                if k < 7 {
                    out += &" ".repeat(pad);
                }
            } else {
                out += &" ".repeat(pad);
                out += cell;
            }
            if k < 7 {
                out += "  ";
            }
        }
        out.trim_end().to_string() + "\n"
    };
    let mut out = line(header);
    for r in &rows {
        out += &line(std::array::from_fn(|k| r[k].as_str()));
    }
    out += "\nFocal length and f-number: computed by realcam (paraxial; the f-number with the stop \
            wide open),\nthe published value in brackets where it differs. FoV on 36×24: diagonal field \
            of view at infinity\nfocus on a 36 × 24 mm (\"35 mm\" full-frame) frame, 43.3 mm diagonal, from \
            real chief rays; ○ a° ⌀d: the\nimage circle, d mm across and covering a°, is smaller than the \
            frame. `realcam render` films a 35 mm\ndiagonal unless the lens, the scene or --film-diagonal \
            says otherwise.\nA zoom gives its range, first to last zoom position. `realcam lens NAME` \
            shows one lens in full.\n";
    out
}

pub fn run(args: &LensesArgs) -> anyhow::Result<ExitCode> {
    let entries = entries(args.filter.as_deref())?;
    if entries.is_empty() {
        bail!(
            "no bundled lens name contains '{}' (`realcam lenses` lists them all)",
            args.filter.as_deref().unwrap_or_default()
        );
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&entries)?);
    } else {
        print!("{}", table(&entries));
    }
    Ok(ExitCode::SUCCESS)
}
