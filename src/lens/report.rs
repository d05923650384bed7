//! What a lens is, before rendering with it: first-order data, focus, pupils, field, colour
//! and the image circle (`realcam lens`, the live lab's lens panel), derived through the same
//! entities and systems the renderer uses.

use anyhow::{Context, bail};
use bevy_ecs::schedule::Schedule;
use bevy_ecs::world::World;
use serde_json::{Value, json};

use crate::film::DEFAULT_IMAGE_SIDE;
use crate::glass::FRAUNHOFER_D_NM;
use crate::lens::aperture::ApertureSetting;
use crate::lens::camera::FilmResolution;
use crate::lens::chromatic::{LATERAL_FIELD, axial_colour, lateral_colour};
use crate::lens::elements::{
    CoatingChoice, FilmFormat, FilmPlacement, FocusSetting, Lens, LensDerivationStats, LensFault,
    LensGeometry, activate_lens, add_lens_systems, build_geometry, film_distance_for,
    set_coating_choice, set_diaphragm, set_zoom_position, spawn_lens,
};
use crate::lens::field::{field_angle, field_edge};
use crate::lens::first_order::FirstOrder;
use crate::lens::focus::{FocusMode, closest_focus_mm, paraxial_focus_distance};
use crate::lens::ghost::ghost_focus_z;
use crate::lens::pupil::ExitPupil;
use crate::lens::settings::LensSettings;
use crate::lens::spacing::rows_at;
use crate::lens::{Prescription, SurfaceKind};

/// Everything `realcam lens` reports, derived through the same entities and systems the
/// renderer uses.
pub struct LensReport {
    pub prescription: Prescription,
    /// The lens with its first-order data at [`Self::wavelength_nm`].
    pub geometry: LensGeometry,
    pub wavelength_nm: f64,
    pub film_distance: f64,
    pub film_diagonal: f64,
    pub focus: FocusSetting,
    pub pupil: ExitPupil,
    pub pupil_seconds: f64,
    /// A zoom lens's first-order data at each of its positions (empty for a fixed lens).
    pub zoom_positions: Vec<ZoomPositionReport>,
    /// The coatings the transmission and T-number are given for (those the lens renders with).
    pub coating: CoatingChoice,
}

/// What `realcam lens --json` says of one zoom position: the lens at that position, focused
/// and stopped as the report's settings say, at the d line.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ZoomPositionReport {
    pub focal_length_mm: f64,
    pub f_number: f64,
    /// Diagonal field of view on the report's film (real chief rays); `None` where no chief
    /// ray reaches the film's corner, or where this position cannot focus at the report's
    /// distance.
    pub field_of_view_deg: Option<f64>,
    /// The closest focus distance, metres from the film (the focus groups' where the lens has
    /// them, else moving the whole lens).
    pub close_focus_m: f64,
    /// The diagonal field of view focused at infinity and at the closest focus (the groups
    /// moved, or the whole lens, as focusing does): how much the framing breathes.
    pub field_of_view_infinity_deg: Option<f64>,
    pub field_of_view_close_deg: Option<f64>,
}

/// The first-order data of every zoom position of `prescription`, derived as
/// [`derive_geometry`](crate::lens::elements::derive_geometry) and
/// [`place_film`](crate::lens::elements::place_film) derive the rendered one.
fn zoom_position_reports(
    prescription: &Prescription,
    focus: FocusSetting,
    aperture: ApertureSetting,
    film_diagonal: f64,
) -> anyhow::Result<Vec<ZoomPositionReport>> {
    let lens = Lens::of(prescription);
    let metres = match focus {
        FocusSetting::Distance { metres, .. } => metres,
        FocusSetting::FilmDistance(_) => f64::INFINITY,
    };
    let groups = |metres: f64| prescription.spacings.focus.as_ref().map(|g| (g, metres));
    let mut reports = Vec::new();
    for (i, position) in prescription.spacings.zoom.iter().enumerate() {
        let at = |e: String| anyhow::anyhow!("zoom position {}: {e}", i + 1);
        // The lens at this position focused at `metres` as `focus` says: its geometry, and its
        // film distance where this position can focus there (another position of the report
        // may focus closer than this one).
        let focused = |metres: f64, focus: FocusSetting| -> anyhow::Result<_> {
            let rows = rows_at(&prescription.rows, Some(position), groups(metres)).map_err(at)?;
            let geometry = build_geometry(&lens, &rows, aperture).map_err(at)?;
            let film_distance = film_distance_for(&geometry, focus).ok();
            Ok((geometry, film_distance))
        };
        let field_of_view = |geometry: &LensGeometry, film_distance: Option<f64>| {
            field_angle(&geometry.system, film_distance?, film_diagonal / 2.0)
                .map(|a| 2.0 * a.to_degrees())
        };
        let (geometry, film_distance) = focused(metres, focus)?;
        let close_focus_m = prescription
            .spacings
            .closest_focus_mm(closest_focus_mm(&geometry.system, &geometry.first_order))
            / 1000.0;
        let at_distance = |metres: f64| -> anyhow::Result<Option<f64>> {
            let focus = FocusSetting::Distance {
                metres,
                mode: FocusMode::Paraxial,
            };
            let (geometry, film_distance) = focused(metres, focus)?;
            Ok(field_of_view(&geometry, film_distance))
        };
        reports.push(ZoomPositionReport {
            focal_length_mm: geometry.first_order.focal_length,
            f_number: geometry.first_order.f_number,
            field_of_view_deg: field_of_view(&geometry, film_distance),
            close_focus_m,
            field_of_view_infinity_deg: at_distance(f64::INFINITY)?,
            field_of_view_close_deg: at_distance(close_focus_m)?,
        });
    }
    Ok(reports)
}

impl LensReport {
    /// Lens-frame z of the film, mm (the rear vertex plus the film distance).
    fn film_z(&self) -> f64 {
        self.geometry.system.rear_z() + self.film_distance
    }

    pub fn derive(
        prescription: Prescription,
        options: &LensSettings,
    ) -> anyhow::Result<LensReport> {
        options.validate()?;
        let focus = options.focus(FocusSetting::default());
        let film_diagonal = options.film_diagonal_for(&prescription, None);
        let zoom_positions = zoom_position_reports(
            &prescription,
            focus,
            options.aperture(ApertureSetting::Full),
            film_diagonal,
        )?;
        // The lens's own derivation systems on a world of its own: the report needs no scene.
        let mut world = World::new();
        world.init_resource::<LensDerivationStats>();
        world.insert_resource(FilmResolution {
            width: DEFAULT_IMAGE_SIDE,
            height: DEFAULT_IMAGE_SIDE,
        });
        world.insert_resource(FilmFormat {
            diagonal_mm: film_diagonal,
            pupil_sampling: options.pupil_sampling,
        });
        let mut derivation = Schedule::default();
        add_lens_systems(&mut derivation);
        let entity = spawn_lens(
            &mut world,
            &prescription,
            focus,
            options.aperture(ApertureSetting::Full),
        );
        set_diaphragm(&mut world, entity, options.diaphragm()?);
        set_zoom_position(&mut world, entity, options.zoom_setting_for(&prescription)?);
        set_coating_choice(&mut world, entity, options.coating_choice());
        activate_lens(&mut world, entity);
        let start = std::time::Instant::now();
        derivation.run(&mut world);
        let pupil_seconds = start.elapsed().as_secs_f64();
        let lens = world.entity(entity);
        if let Some(fault) = lens.get::<LensFault>() {
            bail!(fault.0.clone());
        }
        let geometry = lens
            .get::<LensGeometry>()
            .context("lens geometry was not derived")?
            .clone();
        let film_distance = lens
            .get::<FilmPlacement>()
            .context("film placement was not derived")?
            .film_distance;
        let pupil = lens
            .get::<ExitPupil>()
            .context("exit pupil was not derived")?
            .clone();
        for warning in &geometry.warnings {
            eprintln!("warning: {warning}");
        }
        for note in &geometry.notes {
            eprintln!("note: {note}");
        }
        Ok(LensReport {
            prescription,
            geometry,
            wavelength_nm: FRAUNHOFER_D_NM,
            film_distance,
            film_diagonal,
            focus,
            pupil,
            pupil_seconds,
            zoom_positions,
            coating: options.coating_choice(),
        })
    }

    /// The same report with first-order data at `wavelength_nm` (the film where the focus put
    /// it at d).
    pub fn at_wavelength(mut self, wavelength_nm: f64) -> anyhow::Result<LensReport> {
        if !(wavelength_nm.is_finite() && (200.0..=3000.0).contains(&wavelength_nm)) {
            bail!(
                "--wavelength {wavelength_nm} nm is not a wavelength realcam's glass data cover (200–3000 nm)"
            );
        }
        if wavelength_nm == self.wavelength_nm {
            return Ok(self);
        }
        for (i, row) in self.prescription.rows.iter().enumerate() {
            if let Some(range) = row.glass.and_then(|g| g.valid_range_nm())
                && !range.contains(&wavelength_nm)
            {
                eprintln!(
                    "warning: surface {i}'s glass {} has data for {:.0}–{:.0} nm; {wavelength_nm} nm is extrapolated",
                    row.glass.map(|g| g.label()).unwrap_or_default(),
                    range.start(),
                    range.end()
                );
            }
        }
        let system = self.geometry.system.at_wavelength(wavelength_nm);
        self.geometry.first_order = FirstOrder::compute(&system)
            .map_err(|e| anyhow::anyhow!("at {wavelength_nm} nm: {e}"))?;
        self.geometry.system = system;
        self.wavelength_nm = wavelength_nm;
        Ok(self)
    }

    /// The in-focus object distance (film plane → object, mm; ∞ at infinity focus).
    pub fn focus_distance_mm(&self) -> f64 {
        match self.focus {
            FocusSetting::Distance { metres, .. } => metres * 1000.0,
            FocusSetting::FilmDistance(mm) => {
                let d_line = self.geometry.system.at_wavelength(FRAUNHOFER_D_NM);
                FirstOrder::compute(&d_line).map_or(f64::INFINITY, |fo| {
                    paraxial_focus_distance(&d_line, &fo, mm)
                })
            }
        }
    }

    /// `chromatic`: axial and lateral colour and the glasses (see [`crate::lens::chromatic`]).
    pub fn chromatic_json(&self) -> Value {
        let system = &self.geometry.system;
        let glasses: Vec<Value> = system
            .rows
            .iter()
            .enumerate()
            .map(|(i, row)| {
                json!({
                    "surface": i,
                    "glass": row.glass.map(|g| g.label()),
                    "n_d": row.base.index,
                    "v_d": row.glass.map(|g| g.v_d()),
                })
            })
            .collect();
        json!({
            "axial_colour_mm": axial_colour(system),
            "lateral_colour_mm": lateral_colour(system, self.film_distance, self.film_diagonal, self.focus_distance_mm()),
            "lateral_colour_film_height_mm": LATERAL_FIELD * self.film_diagonal / 2.0,
            "glasses": glasses,
        })
    }

    /// Diagonal field of view for the film diagonal, degrees (real chief rays).
    pub fn field_of_view_degrees(&self) -> Option<f64> {
        field_angle(
            &self.geometry.system,
            self.film_distance,
            self.film_diagonal / 2.0,
        )
        .map(|a| 2.0 * a.to_degrees())
    }

    /// Film radius and field angle of the image circle's edge (see [`field_edge`]).
    pub fn image_circle(&self) -> Option<(f64, f64)> {
        field_edge(
            &self.geometry.system,
            self.film_distance,
            self.film_diagonal / 2.0,
        )
    }

    /// What the lens transmits on its axis at the d line (every surface met at normal
    /// incidence), coated as [`Self::coating`] says.
    pub fn transmission(&self) -> f64 {
        let system = &self.geometry.system;
        system
            .f64s
            .reflectance
            .as_deref()
            .map_or(1.0, |reflectance| {
                reflectance.axial_transmission(&system.rows, FRAUNHOFER_D_NM)
            })
    }

    /// Each two-reflection ghost path of the lens as its coatings make it (none for a lossless
    /// lens): the two surfaces (0-based, front first), its strength (the product of their
    /// reflectances on the axis at d) and where the ghost of a distant point on the axis comes
    /// to focus, mm from the film (+ behind it; `null` where the path leaves parallel).
    pub fn ghosts_json(&self) -> Vec<Value> {
        let system = &self.geometry.system;
        let Some(ghosts) = system.ghosts.as_deref() else {
            return Vec::new();
        };
        let film_z = self.film_z();
        let at_d: Vec<f64> = system
            .rows
            .iter()
            .map(|row| row.index_at(FRAUNHOFER_D_NM))
            .collect();
        let index = |i: usize| (if i == 0 { 1.0 } else { at_d[i - 1] }, at_d[i]);
        // A paraxial ray: a thousandth of the entrance pupil's radius high.
        let height = 5e-4 * self.geometry.first_order.entrance_pupil.diameter_mm;
        ghosts
            .pairs
            .iter()
            .zip(&ghosts.strength)
            .map(|(&pair, &strength)| {
                let focus = ghost_focus_z(&system.f64s, pair, height, index)
                    .map(|z| z - film_z)
                    .filter(|z| z.is_finite());
                json!({ "surfaces": pair, "strength": strength, "focus_from_film_mm": focus })
            })
            .collect()
    }

    /// The coatings in words: the model on every surface, or the file's coatings and the model
    /// on the surfaces it says nothing of.
    pub fn coating_name(&self) -> String {
        self.coating
            .describe(!self.prescription.coatings.is_empty())
    }

    /// The T-number: the f-number of a lossless lens that would give the film as much light,
    /// N / √transmission.
    pub fn t_number(&self) -> f64 {
        self.geometry.first_order.f_number / self.transmission().sqrt()
    }

    pub fn to_json(&self) -> Value {
        let fo = &self.geometry.first_order;
        let system = &self.geometry.system;
        let last = system.surface_count() - 1;
        let surfaces: Vec<Value> = system
            .rows
            .iter()
            .enumerate()
            .map(|(i, row)| {
                let thickness = if i == last { self.film_distance } else { row.base.thickness };
                json!({
                    "radius_mm": match row.curvature() { 0.0 => Value::Null, _ => json!(row.base.radius) },
                    "curvature_per_mm": row.curvature(),
                    "thickness_mm": thickness,
                    "index": row.base.index,
                    "aperture_mm": row.base.aperture,
                    "kind": row.kind(),
                    "stop": row.base.stop,
                    "conic": row.asphere.conic,
                    "aspheric_coefficients": &row.asphere.coefficients[..row.asphere.order()],
                    "z_mm": system.f64s.vertex_z[i],
                })
            })
            .collect();
        json!({
            "name": self.prescription.name,
            "source": self.prescription.source.display().to_string(),
            "design": self.prescription.info,
            "wavelength_nm": self.wavelength_nm,
            "chromatic": self.chromatic_json(),
            "format": self.prescription.format,
            "focal_length_mm": fo.focal_length,
            "back_focal_length_mm": fo.back_focal_length,
            "front_focal_length_mm": fo.front_focal_z,
            "principal_planes_mm": { "front": fo.front_principal_z, "rear": fo.rear_principal_z },
            "entrance_pupil": fo.entrance_pupil,
            "exit_pupil": fo.exit_pupil,
            "f_number": fo.f_number,
            "working_f_number": fo.working_f_number(self.film_z()),
            "coating": self.coating_name(),
            "transmission": self.transmission(),
            "t_number": self.t_number(),
            "ghosts": self.ghosts_json(),
            "stop_diameter_mm": system.stop_diameter(),
            "diaphragm": system.diaphragm.as_ref().map(|d| json!({
                "shape": d.describe(),
                "open_fraction": self.geometry.open_fraction,
                "area_equivalent_f_number": self.geometry.f_number(),
            })),
            "total_track_mm": self.film_z(),
            "vertex_span_mm": system.rear_z(),
            "film_distance_mm": self.film_distance,
            "focus_distance_m": match self.focus { FocusSetting::Distance { metres, .. } => json!(metres), FocusSetting::FilmDistance(_) => Value::Null },
            "closest_focus_m": self.prescription.spacings.closest_focus_mm(closest_focus_mm(system, fo)) / 1000.0,
            "film_diagonal_mm": self.film_diagonal,
            "field_of_view_deg": self.field_of_view_degrees(),
            "image_circle": self.image_circle().map(|(radius, angle)| json!({
                "diameter_mm": 2.0 * radius,
                "field_of_view_deg": 2.0 * angle.to_degrees(),
            })),
            "exit_pupil_bounds": {
                "segments": self.pupil.segments.len(),
                "rays_traced": self.pupil.rays_traced,
            },
            "surfaces": surfaces,
            "zoom_positions": self.zoom_positions,
        })
    }

    pub fn summary(&self) -> String {
        let fo = &self.geometry.first_order;
        let system = &self.geometry.system;
        let mut out = format!(
            "{}  ({}, {} layout)\n\n   #     radius  thickness    index   aperture\n",
            self.prescription.name,
            self.prescription.source.display(),
            self.prescription.format.name()
        );
        let last = system.surface_count() - 1;
        for (i, row) in system.rows.iter().enumerate() {
            let radius = match row.kind() {
                SurfaceKind::Stop => "stop".to_string(),
                SurfaceKind::Flat => "flat".to_string(),
                SurfaceKind::Spherical | SurfaceKind::Aspheric => format!("{:.3}", row.base.radius),
            };
            let mut notes = Vec::new();
            if row.base.stop && row.kind() != SurfaceKind::Stop {
                notes.push("stop".to_string());
            }
            if row.kind() == SurfaceKind::Aspheric {
                notes.push(aspheric_note(row));
            }
            if let Some(glass) = row.glass {
                notes.push(glass.label());
            }
            let thickness = if i == last {
                self.film_distance
            } else {
                row.base.thickness
            };
            if i == last {
                notes.push("to film".into());
            }
            let note = if notes.is_empty() {
                String::new()
            } else {
                format!("  {}", notes.join("; "))
            };
            out += &format!(
                "{i:4} {radius:>10} {thickness:>10.3} {:>8.4} {:>10.2}{note}\n",
                row.base.index, row.base.aperture
            );
        }
        let focus = match self.focus {
            FocusSetting::Distance { metres, mode } => {
                format!("focused at {metres} m, {} focus", mode.name())
            }
            FocusSetting::FilmDistance(_) => "set directly".into(),
        };
        let fov = match self.field_of_view_degrees() {
            Some(d) => format!("{d:.1}°"),
            None => self.image_circle().map_or("n/a".into(), |(h, a)| {
                format!(
                    "corners outside the image circle (⌀ {:.1} mm, {:.1}° across); n/a",
                    2.0 * h,
                    2.0 * a.to_degrees()
                )
            }),
        };
        out += &format!(
            "\nfocal length        {:10.3} mm\nback focal length   {:10.3} mm\nfront focal point   z = {:.3} mm\nprincipal planes    front z = {:.3} mm, rear z = {:.3} mm\nentrance pupil      z = {:.3} mm, diameter {:.3} mm\nexit pupil          z = {:.3} mm, diameter {:.3} mm\nf-number            f/{:.2} (stop {:.2} mm)\nworking f-number    f/{:.2} (exit pupil to film ÷ its diameter)\ntotal track         {:10.3} mm (front vertex to film)\nfilm distance       {:10.3} mm ({focus})\nclosest focus       {:10.3} m\nfield of view       {fov} diagonal on a {:.1} mm film diagonal\nexit-pupil bounds   {} segments, {} rays, {:.3} s to derive\n",
            fo.focal_length,
            fo.back_focal_length,
            fo.front_focal_z,
            fo.front_principal_z,
            fo.rear_principal_z,
            fo.entrance_pupil.z_mm,
            fo.entrance_pupil.diameter_mm,
            fo.exit_pupil.z_mm,
            fo.exit_pupil.diameter_mm,
            fo.f_number,
            system.stop_diameter(),
            fo.working_f_number(self.film_z()),
            self.film_z(),
            self.film_distance,
            self.prescription
                .spacings
                .closest_focus_mm(closest_focus_mm(system, fo))
                / 1000.0,
            self.film_diagonal,
            self.pupil.segments.len(),
            self.pupil.rays_traced,
            self.pupil_seconds,
        );
        out += &format!(
            "transmission        {:.1} % on the axis at d ({} coating), T/{:.2}\n",
            100.0 * self.transmission(),
            self.coating_name(),
            self.t_number()
        );
        if let Some(ghosts) = self.geometry.system.ghosts.as_deref() {
            let total: f64 = ghosts.strength.iter().sum();
            let strongest = (0..ghosts.pairs.len())
                .max_by(|&a, &b| ghosts.strength[a].total_cmp(&ghosts.strength[b]));
            if let Some(k) = strongest {
                out += &format!(
                    "ghosts              {} two-reflection paths, {:.3} % of the light on the axis in all; strongest: surfaces {} and {}, {:.3} %\n",
                    ghosts.pairs.len(),
                    100.0 * total,
                    ghosts.pairs[k][0],
                    ghosts.pairs[k][1],
                    100.0 * ghosts.strength[k],
                );
            }
        }
        if let Some(diaphragm) = &system.diaphragm {
            out += &format!(
                "diaphragm           {}: {:.1} % of the stop's circle, the light of f/{:.2}\n",
                diaphragm.describe(),
                100.0 * self.geometry.open_fraction,
                self.geometry.f_number()
            );
        }
        if system.is_dispersive() {
            let mm = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:+.4} mm"));
            out += &format!(
                "axial colour        {} (back focal length at F minus at C)\nlateral colour      {} (image height at F minus at C, {:.0} % of the half-diagonal)\n",
                mm(axial_colour(system)),
                mm(lateral_colour(
                    system,
                    self.film_distance,
                    self.film_diagonal,
                    self.focus_distance_mm()
                )),
                LATERAL_FIELD * 100.0
            );
        } else {
            out += "colour              none: the lens file gives no glass, every wavelength sees the same indices\n";
        }
        if self.wavelength_nm != FRAUNHOFER_D_NM {
            out += &format!("first-order data at {} nm\n", self.wavelength_nm);
        }
        for (i, position) in self.zoom_positions.iter().enumerate() {
            out += &format!(
                "{:<20}f {:.2} mm, f/{:.2}, {} diagonal (--zoom-position {})\n",
                if i == 0 { "zoom positions" } else { "" },
                position.focal_length_mm,
                position.f_number,
                position
                    .field_of_view_deg
                    .map_or("n/a".to_string(), |d| format!("{d:.1}°")),
                i + 1
            );
        }
        out += "\nz: lens frame, mm, origin at the front vertex, +z toward the film.\n";
        out
    }
}

/// "asph k −1.2, A4 1.1e-5, A6 −3e-8": a surface's departure from its sphere, shortly.
fn aspheric_note(row: &crate::lens::SurfaceRow) -> String {
    let mut parts = vec![format!("asph k {}", row.asphere.conic)];
    for (i, a) in row.asphere.coefficients[..row.asphere.order()]
        .iter()
        .enumerate()
    {
        if *a != 0.0 {
            parts.push(format!("A{} {a:.4e}", 2 * i + 2));
        }
    }
    parts.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::io::bundled::load_lens;

    #[test]
    fn the_summary_names_the_focus_mode_in_lower_case() {
        let settings = LensSettings {
            focus_distance: Some(3.0),
            ..LensSettings::default()
        };
        let report =
            LensReport::derive(load_lens("dgauss.50mm", None).unwrap(), &settings).unwrap();
        let summary = report.summary();
        assert!(
            summary.contains("focused at 3 m, paraxial focus"),
            "{summary}"
        );
        assert!(!summary.contains("Paraxial"), "{summary}");
    }

    /// A colour figure the lens cannot give is null, not zero: fisheye.10mm's image circle
    /// (about 26 mm across) does not reach 70 % of a 43.3 mm film's half-diagonal (15.2 mm).
    #[test]
    fn lateral_colour_outside_the_image_circle_is_null() {
        let settings = LensSettings {
            film_diagonal: Some(43.3),
            ..LensSettings::default()
        };
        let report =
            LensReport::derive(load_lens("fisheye.10mm", None).unwrap(), &settings).unwrap();
        let (circle, _) = report.image_circle().unwrap();
        let colour = report.chromatic_json();
        let height = colour["lateral_colour_film_height_mm"].as_f64().unwrap();
        assert!(
            (height - 0.7 * 43.3 / 2.0).abs() < 1e-9 && height > circle,
            "{colour}"
        );
        assert!(colour["lateral_colour_mm"].is_null(), "{colour}");
        assert!(report.summary().contains("lateral colour      n/a"));
    }
}
