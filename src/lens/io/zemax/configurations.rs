//! A multi-configuration `.zmx` file's zoom positions: `MNUM count active`, then the
//! multi-configuration editor's rows, operand by operand (see [`ConfigurationOperand`]).
//!
//! Each configuration becomes a [`ZoomPosition`]: its `THIC` rows set the gaps after lens
//! surfaces, and its stop is sized from the system aperture as OpticStudio sizes it in that
//! configuration (`APER`, the system aperture's value there: an f-number under `FNUM`, an
//! entrance-pupil diameter under `ENPD`; a floating stop keeps its own size). `THIC` on the
//! object surface (a focus series' object distances) and on the last lens surface (the image
//! distance, which realcam's focus sets) is not part of the lens. A clear aperture given per
//! configuration (`SDIA`, a semi-diameter; `APMX`, a circular aperture's radius) is the
//! element's at its widest, since the glass is the same at every position; on a floating stop
//! it is that position's stop. Operands that only weigh or place fields and wavelengths, or
//! weigh configurations, are ignored; any other operand changes what realcam represents (a
//! curvature, a glass, an asphere term, the stop surface) in a way it does not read yet, and
//! is refused by name.

use super::parse::{ConfigurationOperand, ZemaxSystem};
use crate::lens::clear_aperture;
use crate::lens::prescription::SurfaceRow;
use crate::lens::spacing::{Gap, ZoomPosition, rows_at};

/// Operands that change no part of the lens realcam represents: the editor's empty row, the
/// fields, their type, weights and vignetting factors, the wavelengths and their weights, ray
/// aiming, the configurations' weights, and the environment's temperature and pressure
/// (realcam's indices are at 20 °C, 1 atm).
const IGNORED_OPERANDS: [&str; 17] = [
    "MOFF", "WAVE", "WLWT", "PWAV", "XFIE", "YFIE", "FLTP", "FLWT", "FVDX", "FVDY", "FVCX", "FVCY",
    "FVAN", "RAAM", "CWGT", "TEMP", "PRES",
];

/// A multi-configuration file's editor, read: what each configuration changes, in
/// millimetres and lens rows.
pub(super) struct Configurations {
    /// Each configuration's gaps (its stop diameter is sized by [`Self::zoom_positions`]).
    positions: Vec<ZoomPosition>,
    /// Each configuration's `APER` value, where it has one.
    apertures: Vec<Option<f64>>,
    /// Per lens row, the widest clear diameter a configuration gives it (`SDIA`, `APMX`).
    widest: Vec<Option<f64>>,
    /// Per configuration, the stop's clear diameter where one is given.
    stop_diameters: Vec<Option<f64>>,
    /// Whether the configurations put the object at different finite distances.
    object_distances: bool,
}

/// The configurations of `system` for a lens of `lens_rows` surfaces with the stop on row
/// `stop`, at `scale` mm per file unit; `None` for a single configuration. Errors name the line.
pub(super) fn read(
    system: &ZemaxSystem,
    lens_rows: usize,
    stop: usize,
    scale: f64,
) -> Result<Option<Configurations>, (usize, String)> {
    let Some((count, _)) = system.configurations.filter(|&(count, _)| count > 1) else {
        return Ok(None);
    };
    let mut table = Configurations {
        positions: vec![ZoomPosition::default(); count],
        apertures: vec![None; count],
        widest: vec![None; lens_rows],
        stop_diameters: vec![None; count],
        object_distances: false,
    };
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
        // The operand's surface: 0 the object, 1..=lens_rows the lens, then the image.
        let surface = usize::try_from(*number).unwrap_or(usize::MAX);
        let not_a_surface = || {
            (
                line,
                format!(
                    "{name} {number}: surface {number} is not a surface of the file (the lens is SURF 1 to {lens_rows})"
                ),
            )
        };
        match name.as_str() {
            "THIC" => {
                if surface == 0 {
                    table.object_distances |= value()?.abs() < 1e9;
                } else if surface < lens_rows {
                    table.positions[config].gaps.push(Gap {
                        surface: surface - 1,
                        thickness: value()? * scale,
                    });
                } else if surface != lens_rows {
                    // The last lens surface's is the image distance, which focusing sets.
                    return Err(not_a_surface());
                }
            }
            "APER" => table.apertures[config] = Some(value()?),
            "SDIA" | "APMX" => {
                if (1..=lens_rows).contains(&surface) {
                    let diameter = 2.0 * value()?.abs() * scale;
                    let row = surface - 1;
                    if row == stop {
                        table.stop_diameters[config] = Some(diameter);
                    }
                    let widest = &mut table.widest[row];
                    *widest = Some(widest.map_or(diameter, |w: f64| w.max(diameter)));
                } else if surface > lens_rows + 1 {
                    return Err(not_a_surface());
                }
            }
            other => {
                return Err((
                    line,
                    format!(
                        "multi-configuration operand {other} changes the lens between configurations in a way realcam does not read (it reads THIC, APER, SDIA and APMX); save the configuration you want on its own"
                    ),
                ));
            }
        }
    }
    Ok(Some(table))
}

impl Configurations {
    /// Opens each lens row's clear aperture (not the stop's) to the widest any configuration
    /// gives it.
    pub(super) fn widen(&self, rows: &mut [SurfaceRow], stop: usize) {
        for (i, (row, widest)) in rows.iter_mut().zip(&self.widest).enumerate() {
            if let Some(d) = *widest
                && i != stop
            {
                row.base.aperture = row.base.aperture.max(d);
            }
        }
    }

    /// The zoom positions, each stop sized as OpticStudio sizes it in that configuration, for
    /// the lens of `rows` (the stop on row `stop`), and the warnings to give.
    pub(super) fn zoom_positions(
        self,
        system: &ZemaxSystem,
        rows: &[SurfaceRow],
        stop: usize,
        scale: f64,
    ) -> Result<(Vec<ZoomPosition>, Vec<String>), String> {
        let mut positions = self.positions;
        for (i, position) in positions.iter_mut().enumerate() {
            position.stop_diameter =
                match stop_diameter(system, rows, stop, position, self.apertures[i], scale)
                    .map_err(|why| {
                        format!("configuration {}: cannot size the stop: {why}", i + 1)
                    })? {
                    Some(d) => Some(d),
                    // A floating stop: its own size in this configuration, where the file gives one.
                    None => self.stop_diameters[i],
                };
        }
        let mut warnings = Vec::new();
        if self.object_distances {
            warnings.push(
                "THIC 0: the configurations put the object at different distances (a focus series?); realcam reads their lens gaps and focuses with --focus-distance".into(),
            );
        }
        Ok((positions, warnings))
    }
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
    if let Some(epd) = system.entrance_pupil_diameter {
        let epd = aperture.unwrap_or(epd);
        return clear_aperture::stop_for_entrance_pupil(&rows, stop, epd * scale).map(Some);
    }
    if let Some(n) = system.f_number {
        return clear_aperture::stop_for_f_number(&rows, stop, aperture.unwrap_or(n)).map(Some);
    }
    Ok(None)
}
