//! `realcam lens FILE`: what a lens is, before rendering with it.

use std::io::Read;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::Args;
use serde_json::{Value, json};

use super::options::LensOptions;
use super::values::number;
use crate::film::contact_sheet::{Thumbnail, contact_sheet};
use crate::film::format::{
    Accepts, DEFAULT_JPEG_QUALITY, ImageFormat, encode_rgb8, output_format, require_extension,
};
use crate::film::output::{
    check_not_terminal, check_writable, is_stdout, same_file, shown, write_output,
};
use crate::glass::FRAUNHOFER_D_NM;
use crate::lens::diagram::draw_report_diagram;
use crate::lens::io::bundled::read_lens;
use crate::lens::io::export::export_text;
use crate::lens::pupil_view::PupilViews;
use crate::lens::report::LensReport;
use crate::lens::trace::{Ray, Travel, normalize, trace};

// The field docs are `--help` text for a terminal: brackets there are clap's "[default: …]"
// and JSON, not rustdoc links.
#[allow(rustdoc::broken_intra_doc_links)]
#[derive(Args, Debug, Clone)]
pub struct LensArgs {
    /// Lens prescription file, or a bundled lens name (e.g. dgauss.50mm).
    pub file: String,
    #[command(flatten)]
    pub lens: LensOptions,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// Read a JSON array of rays {"origin":[x,y,z],"direction":[x,y,z]} (lens frame, mm,
    /// heading toward +z) on stdin, trace each scene→film and print the results as JSON.
    #[arg(long)]
    pub trace: bool,
    /// Draw the lens cross-section with traced ray fans to this SVG file.
    #[arg(long, value_name = "FILE.svg")]
    pub diagram: Option<PathBuf>,
    /// With `--diagram`: draw the on-axis bundle along the ghost path of surfaces A and B too
    /// (0-based, as `ghosts` lists them in `--json`).
    #[arg(long, value_name = "A,B", requires = "diagram", allow_hyphen_values = true, value_parser = surface_pair)]
    pub ghost: Option<[usize; 2]>,
    /// Report first-order data (and trace `--trace` rays without their own) at this wavelength,
    /// nm; the film stays where the focus puts it at d.
    #[arg(
        long,
        value_name = "NM",
        default_value_t = FRAUNHOFER_D_NM,
        allow_hyphen_values = true,
        value_parser = number::<f64>
    )]
    pub wavelength: f64,
    /// Draw the exit pupil as seen from film points from the centre to the corner (with the
    /// film radius and the fraction of the centre's light under each) to this image.
    #[arg(long, value_name = "OUT.png")]
    pub pupil_view: Option<PathBuf>,
    /// Write the lens to this file: `.toml` (realcam's lens format: everything realcam
    /// represents) or `.dat` (a pbrt table: spherical lenses only).
    #[arg(long, value_name = "OUT.toml|OUT.dat")]
    pub export: Option<PathBuf>,
}

pub fn run(args: &LensArgs) -> anyhow::Result<ExitCode> {
    if !args.wavelength.is_finite() {
        bail!(
            "--wavelength must be a number of nanometres, got {}",
            args.wavelength
        );
    }
    let settings = args.lens.settings();
    let prescription = read_lens(&args.file, &settings.reading())?;
    for warning in &prescription.warnings {
        eprintln!("warning: {warning}");
    }
    if let Some(path) = &args.export {
        let text = export_text(&prescription, path).map_err(|m| anyhow::anyhow!(m))?;
        crate::film::output::write_atomically(path, |w| {
            w.extend_from_slice(text.as_bytes());
            Ok(())
        })?;
        eprintln!("wrote {}", path.display());
    }
    if let Some(path) = &args.diagram {
        // The diagram is SVG text; rasterising it for a .png would take an SVG renderer
        // (resvg and its tree of crates), too much build for one picture a browser shows.
        if is_stdout(path) {
            bail!(
                "--diagram -: standard output carries the lens summary; name an .svg file for the diagram"
            );
        }
        require_extension("--diagram", path, "svg", "an SVG cross-section")?;
        check_writable(path)?;
    }
    let pupil_view_format = match &args.pupil_view {
        Some(path) => {
            if same_file(path, std::path::Path::new(&args.file))
                || args
                    .lens
                    .aperture_image
                    .as_deref()
                    .is_some_and(|mask| same_file(path, mask))
            {
                bail!(
                    "{}: the output would overwrite an input file; choose another output path",
                    path.display()
                );
            }
            check_not_terminal("--pupil-view", path)?;
            let format = output_format("--pupil-view", path, Accepts::EightBit)?;
            check_writable(path)?;
            Some(format)
        }
        None => None,
    };
    let report = LensReport::derive(prescription, &settings)?.at_wavelength(args.wavelength)?;
    for message in settings.mask_messages(report.geometry.system.diaphragm.as_ref()) {
        eprintln!("{message}");
    }
    if let (Some(path), Some(format)) = (&args.pupil_view, pupil_view_format) {
        write_pupil_view(&report, path, format)?;
    }
    if let Some(path) = &args.diagram {
        if let Some([a, b]) = args.ghost {
            let ghosts = report.geometry.system.ghosts.as_deref();
            let pairs = ghosts.map_or(&[][..], |g| &g.pairs[..]);
            if pairs.is_empty() {
                bail!(
                    "--ghost {a},{b}: {} has no ghosts with {} coating: no surface reflects",
                    report.prescription.name,
                    report.coating_name()
                );
            }
            if !pairs.contains(&[a.min(b), a.max(b)]) {
                let reflecting: std::collections::BTreeSet<usize> =
                    pairs.iter().flatten().copied().collect();
                bail!(
                    "--ghost {a},{b}: not a ghost of {} with {} coating (two different surfaces among those that reflect: {:?})",
                    report.prescription.name,
                    report.coating_name(),
                    reflecting
                );
            }
        }
        let svg = draw_report_diagram(&report, args.ghost.map(|[a, b]| [a.min(b), a.max(b)]));
        crate::film::output::write_atomically(path, |w| {
            w.extend_from_slice(svg.as_bytes());
            Ok(())
        })?;
        eprintln!("wrote {}", path.display());
    }
    if args.trace {
        let mut input = String::new();
        std::io::stdin()
            .read_to_string(&mut input)
            .context("cannot read rays from stdin")?;
        let traced = trace_json(&report, &input)?;
        println!("{}", serde_json::to_string_pretty(&traced)?);
    } else if args.json {
        println!("{}", serde_json::to_string_pretty(&report.to_json())?);
    } else {
        print!("{}", report.summary());
    }
    Ok(ExitCode::SUCCESS)
}

/// `--pupil-view`: six views from the film centre to the corner, labelled, in one picture.
fn write_pupil_view(
    report: &LensReport,
    path: &std::path::Path,
    format: ImageFormat,
) -> anyhow::Result<()> {
    const VIEWS: usize = 6;
    const CELLS: usize = 200;
    let views = PupilViews::compute(
        &report.geometry.system,
        &report.pupil,
        report.film_diagonal / 2.0,
        VIEWS,
        CELLS,
    );
    let thumbnails: Vec<Thumbnail> = views
        .views
        .iter()
        .map(|view| {
            eprintln!(
                "pupil view at film radius {:.2} mm: {:.3} of the centre's light",
                view.film_radius_mm, view.relative_light
            );
            Thumbnail {
                image: views.picture(view),
                caption: format!(
                    "film r {:.1} mm\nlight {:.2}",
                    view.film_radius_mm, view.relative_light
                ),
            }
        })
        .collect();
    let sheet = contact_sheet(&thumbnails);
    write_output(path, |w| {
        encode_rgb8(w, &sheet, format, DEFAULT_JPEG_QUALITY)
    })?;
    eprintln!(
        "wrote {} (exit pupil from {VIEWS} film points, {:.1} mm window on the rear-vertex plane, seen from the film)",
        shown(path),
        2.0 * views.half_width_mm
    );
    Ok(())
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct InputRay {
    origin: [f64; 3],
    direction: [f64; 3],
    /// The ray's wavelength, nm [default: the report's].
    wavelength_nm: Option<f64>,
}

/// Traces the JSON array of rays in `input` scene→film, in f64.
pub fn trace_json(report: &LensReport, input: &str) -> anyhow::Result<Value> {
    let rays: Vec<InputRay> = serde_json::from_str(input).context(
        "stdin: expected a JSON array of {\"origin\":[x,y,z],\"direction\":[x,y,z]} (and optionally \"wavelength_nm\")",
    )?;
    // One system per wavelength asked for.
    let mut systems: Vec<(f64, crate::lens::LensSystem)> = Vec::new();
    let results = rays
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let finite = r.origin.iter().chain(&r.direction).all(|v| v.is_finite());
            let length = r.direction.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !finite || length == 0.0 {
                bail!("stdin: ray {i} has a non-finite or zero origin/direction");
            }
            let ray = Ray {
                origin: r.origin,
                direction: normalize(r.direction),
            };
            let nm = r.wavelength_nm.unwrap_or(report.wavelength_nm);
            if !(nm.is_finite() && (200.0..=3000.0).contains(&nm)) {
                bail!("stdin: ray {i} has wavelength_nm {nm}, not a wavelength in 200–3000 nm");
            }
            let system = match systems.iter().position(|(w, _)| *w == nm) {
                Some(k) => &systems[k].1,
                None => {
                    systems.push((nm, report.geometry.system.at_wavelength(nm)));
                    &systems.last().expect("just pushed").1
                }
            };
            Ok(match trace(&system.f64s, ray, Travel::SceneToFilm) {
                Ok(out) => json!({ "point": out.origin, "direction": out.direction }),
                Err(blocked) => {
                    json!({ "blocked": blocked.reason, "surface": blocked.surface })
                }
            })
        })
        .collect::<anyhow::Result<Vec<Value>>>()?;
    Ok(Value::Array(results))
}

/// `--ghost A,B`: two surface numbers.
fn surface_pair(text: &str) -> Result<[usize; 2], String> {
    let numbers: Vec<&str> = text.split(',').collect();
    match numbers[..] {
        [a, b] => match (a.trim().parse(), b.trim().parse()) {
            (Ok(a), Ok(b)) => Ok([a, b]),
            _ => Err(format!(
                "'{text}': two surface numbers A,B (0-based), e.g. 2,5"
            )),
        },
        _ => Err(format!(
            "'{text}': two surface numbers A,B (0-based), e.g. 2,5"
        )),
    }
}
