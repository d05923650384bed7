//! A multi-configuration `.zmx` file's zoom positions: `MNUM count active`, then the
//! multi-configuration editor's rows, operand by operand (see [`ConfigurationOperand`]).
//!
//! Each configuration becomes a [`ZoomPosition`]: its `THIC` rows set the gaps after lens
//! surfaces, and its stop is sized from the system aperture as OpticStudio sizes it in that
//! configuration (`APER`, the system aperture's value there: an f-number under `FNUM`, an
//! entrance-pupil diameter under `ENPD`; a floating stop keeps its own size). `THIC` on the
//! object surface (a focus series' object distances) and on the last lens surface (the image
//! distance, which realcam's focus sets) is not part of the lens. Operands that only weigh or
//! place fields and wavelengths are ignored; any other operand changes what realcam
//! represents (a curvature, a glass, an asphere term, a clear aperture) in a way it does not
//! read yet, and is refused by name.

use super::parse::{ConfigurationOperand, ZemaxSystem};
use crate::lens::clear_aperture;
use crate::lens::prescription::SurfaceRow;
use crate::lens::spacing::{Gap, ZoomPosition, rows_at};

/// Operands that change no part of the lens realcam represents: the editor's empty row, the
/// fields and their weights and vignetting factors, the wavelengths and their weights, and the
/// environment's temperature and pressure (realcam's indices are at 20 °C, 1 atm).
const IGNORED_OPERANDS: [&str; 14] = [
    "MOFF", "WAVE", "WLWT", "PWAV", "XFIE", "YFIE", "FLWT", "FVDX", "FVDY", "FVCX", "FVCY", "FVAN",
    "TEMP", "PRES",
];

/// What the configurations say, for the converter.
pub(super) struct Configurations {
    pub(super) positions: Vec<ZoomPosition>,
    pub(super) warnings: Vec<String>,
}

/// The zoom positions of `system`'s configurations (none for a single configuration), for a
/// lens of `rows` (millimetres, the stop sized, `stop` its row) read at `scale` mm per file
/// unit. Errors name the line.
pub(super) fn zoom_positions(
    system: &ZemaxSystem,
    rows: &[SurfaceRow],
    stop: usize,
    scale: f64,
) -> Result<Configurations, (usize, String)> {
    let mut configurations = Configurations {
        positions: Vec::new(),
        warnings: Vec::new(),
    };
    let Some((count, _)) = system.configurations.filter(|&(count, _)| count > 1) else {
        return Ok(configurations);
    };
    let mut positions = vec![ZoomPosition::default(); count];
    let mut apertures: Vec<Option<f64>> = vec![None; count];
    let mut object_distances = false;
    for operand in &system.operands {
        let ConfigurationOperand {
            name,
            number,
            configuration,
            value,
            line,
        } = operand;
        let line = *line;
        if IGNORED_OPERANDS.contains(&name.as_str()) {
            continue;
        }
        if !(1..=count).contains(configuration) {
            return Err((
                line,
                format!(
                    "{name}: configuration {configuration} is not one of the file's {count} (MNUM {count})"
                ),
            ));
        }
        let config = configuration - 1;
        let value = || {
            value.ok_or_else(|| {
                (
                    line,
                    format!("{name} {number} {configuration}: expected a number"),
                )
            })
        };
        match name.as_str() {
            "THIC" => {
                let surface = usize::try_from(*number).unwrap_or(usize::MAX);
                if surface == 0 {
                    object_distances |= value()?.abs() < 1e9;
                } else if surface < rows.len() {
                    positions[config].gaps.push(Gap {
                        surface: surface - 1,
                        thickness: value()? * scale,
                    });
                } else if surface != rows.len() {
                    return Err((
                        line,
                        format!(
                            "THIC {number}: surface {number} is not a lens surface (the lens is SURF 1 to {})",
                            rows.len()
                        ),
                    ));
                }
            }
            "APER" => apertures[config] = Some(value()?),
            other => {
                return Err((
                    line,
                    format!(
                        "multi-configuration operand {other} changes the lens between configurations in a way realcam does not read (it reads THIC and APER); save the configuration you want on its own"
                    ),
                ));
            }
        }
    }
    for (i, position) in positions.iter_mut().enumerate() {
        position.stop_diameter = stop_diameter(system, rows, stop, position, apertures[i], scale)
            .map_err(|why| {
            (
                system.configurations.map_or(0, |(_, l)| l),
                format!("configuration {}: cannot size the stop: {why}", i + 1),
            )
        })?;
    }
    if object_distances {
        configurations.warnings.push(
            "THIC 0: the configurations put the object at different distances (a focus series?); realcam reads their lens gaps and focuses with --focus-distance".into(),
        );
    }
    configurations.positions = positions;
    Ok(configurations)
}

/// The stop diameter OpticStudio opens in a configuration: the system aperture (its `APER`
/// value there, else the system's own) applied to the configuration's gaps; `None` for a
/// floating stop, which keeps its size.
fn stop_diameter(
    system: &ZemaxSystem,
    rows: &[SurfaceRow],
    stop: usize,
    position: &ZoomPosition,
    aperture: Option<f64>,
    scale: f64,
) -> Result<Option<f64>, String> {
    if system.floating_stop {
        return Ok(None);
    }
    let rows = rows_at(rows, Some(position), None)?;
    if let Some(epd) = aperture
        .or(system.entrance_pupil_diameter)
        .filter(|_| system.entrance_pupil_diameter.is_some())
    {
        return clear_aperture::stop_for_entrance_pupil(&rows, stop, epd * scale).map(Some);
    }
    if let Some(n) = aperture
        .or(system.f_number)
        .filter(|_| system.f_number.is_some())
    {
        return clear_aperture::stop_for_f_number(&rows, stop, n).map(Some);
    }
    Ok(None)
}
