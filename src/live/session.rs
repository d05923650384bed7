//! The render thread's side of a live session: one renderer with its scene and BVH, whose lens
//! entity and settings change in place. A change writes only the components it touches, so
//! bevy's change detection re-derives only what depends on them (a new focus: the film placement
//! and exit pupil; a new lens: its entity set), and accumulation starts over.

use std::path::PathBuf;

use bevy_ecs::entity::Entity;
use serde_json::{Value, json};

use super::lenses::LensLibrary;
use super::settings::{LiveSettings, SpecParser};
use crate::accel::SceneAccel;
use crate::film::Image;
use crate::film::footprint::RunSize;
use crate::film::format::{ImageFormat, Tone};
use crate::film::output::{auto_exposure, write_image};
use crate::job::frame::set_if_changed;
use crate::job::outputs::Formats;
use crate::job::spec::JobSpec;
use crate::job::{Job, tone};
use crate::lens::Prescription;
use crate::lens::aperture::ApertureSetting;
use crate::lens::camera::FilmGeometry;
use crate::lens::coverage::FilmCoverage;
use crate::lens::elements::{FilmFormat, FilmPlacement, FocusSetting, LensGeometry};
use crate::lens::focus_probe::{FocusOnPixel, solve_focus_at};
use crate::pipeline::{CameraPose, PassCancel, RenderSettings, Renderer};

/// Largest side of the first, coarse pass after a change (pixels): it shows the change at once.
pub const PREVIEW_SIDE: u32 = 128;

/// A live session's renderer and settings.
pub struct Session {
    renderer: Renderer,
    settings: LiveSettings,
    /// `settings` as the render takes them: parsed, with the film diagonal filled in.
    spec: JobSpec,
    library: LensLibrary,
    /// The front end's parser of the settings (`realcam render`'s options).
    parser: SpecParser,
    lens: Entity,
    lens_name: String,
    prescription: Prescription,
    /// What `realcam render --lens` takes for this lens (a lens folder's file by its path).
    lens_argument: String,
    /// The scene camera's film diagonal (mm), for a lens that does not say its own format.
    hinted_film_diagonal: Option<f64>,
    formats: Formats,
    /// Where Save writes the picture and the linear film.
    out: PathBuf,
    exr: PathBuf,
    /// Full-resolution passes on the film since the last change.
    pub spp_done: u32,
    /// What the settings work but warn of (a shifted frame's corners leaving the image circle).
    warning: Option<String>,
}

/// The `--exr` a session saves beside `--out` when none is given: `<out stem>.exr`.
pub fn default_exr(out: &std::path::Path) -> PathBuf {
    out.with_extension("exr")
}

impl Session {
    /// Takes over a prepared job (scene loaded, BVH built, lens spawned) for live use. `settings`
    /// are the job's arguments, which `parser` reads; `library` the lenses a client may ask for.
    pub fn new(
        job: Job,
        mut settings: LiveSettings,
        parser: SpecParser,
        mut library: LensLibrary,
        cancel: PassCancel,
    ) -> anyhow::Result<Session> {
        let out = job.spec.output.out.clone();
        let exr = job
            .spec
            .output
            .exr
            .clone()
            .unwrap_or_else(|| default_exr(&out));
        let Job {
            mut renderer,
            mut lenses,
            formats,
            hinted_film_diagonal,
            width,
            height,
            ..
        } = job;
        let first = lenses.remove(0);
        for other in lenses {
            renderer.world.despawn(other.entity);
        }
        renderer.set_active_lens(first.entity);
        renderer.world.insert_resource(cancel);
        // `--focus-on` is resolved once, below, into a focus the page can then change.
        let focus_on = job.spec.focus_on;
        if focus_on.is_some() {
            renderer
                .world
                .entity_mut(first.entity)
                .remove::<FocusOnPixel>();
            settings.remove_fixed("focus_on");
        }
        // The starting values as the job resolved them (the scene's hints, autofocus), so the
        // state shows numbers and the command line reproduces them.
        let lens_name = job
            .spec
            .lenses
            .first()
            .cloned()
            .unwrap_or_else(|| first.prescription.name.clone());
        let lens_argument = match library.load(&lens_name) {
            Ok((_, argument)) => argument,
            Err(_) => {
                // A lens the scene itself names (its camera's hint): trusted like `--lens`.
                library.trust(&lens_name);
                lens_name.clone()
            }
        };
        settings.set("lens", lens_name.clone());
        match first.focus {
            FocusSetting::Distance { metres, .. } => {
                settings.unset("film_distance");
                settings.set("focus_distance", format!("{metres}"));
            }
            FocusSetting::FilmDistance(mm) => {
                settings.unset("focus_distance");
                settings.set("film_distance", format!("{mm}"));
            }
        }
        match first.aperture {
            ApertureSetting::Full => {}
            ApertureSetting::Diameter(mm) => settings.set("aperture", format!("{mm}")),
            ApertureSetting::FNumber(n) => settings.set("f_number", format!("{n}")),
        }
        settings.set("width", width.to_string());
        settings.set("height", height.to_string());
        let spec = settings.parse(&parser).map_err(anyhow::Error::msg)?;
        let mut session = Session {
            renderer,
            settings,
            spec,
            library,
            parser,
            lens: first.entity,
            lens_name,
            prescription: first.prescription,
            lens_argument,
            hinted_film_diagonal,
            formats,
            out,
            exr,
            spp_done: 0,
            warning: None,
        };
        let (settings, mut spec) = (session.settings.clone(), session.spec.clone());
        session
            .switch(&settings, &mut spec)
            .map_err(anyhow::Error::msg)?;
        session.spec = spec;
        if let Some([x, y]) = focus_on {
            let focus = session
                .focus_at_pixel(x as f64 + 0.5, y as f64 + 0.5)
                .map_err(|e| anyhow::anyhow!("--focus-on {x},{y}: {e}"))?;
            let next = session
                .settings
                .changed(&focus)
                .map_err(anyhow::Error::msg)?;
            session.apply(next).map_err(anyhow::Error::msg)?;
        }
        Ok(session)
    }

    /// What the current settings warn of, if anything.
    pub fn warning(&self) -> Option<&str> {
        self.warning.as_deref()
    }

    pub fn settings(&self) -> &LiveSettings {
        &self.settings
    }

    pub fn spec(&self) -> &JobSpec {
        &self.spec
    }

    pub fn library(&self) -> &LensLibrary {
        &self.library
    }

    pub fn prescription(&self) -> &Prescription {
        &self.prescription
    }

    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    pub fn lens(&self) -> Entity {
        self.lens
    }

    /// The render's target samples per pixel.
    pub fn spp_target(&self) -> u32 {
        self.spec.spp
    }

    /// Switches to `next`; on a refusal (a bad value, a lens that cannot focus there) keeps the
    /// current settings and says why.
    pub fn apply(&mut self, next: LiveSettings) -> Result<(), String> {
        let mut spec = next.parse(&self.parser)?;
        crate::job::outputs::check_values(&spec).map_err(|e| e.to_string())?;
        let (width, height) = spec.size_or_default();
        RunSize {
            width,
            height,
            frames: 1,
            contact_sheet: false,
            wavelengths: spec.camera_wavelengths(),
        }
        .check()
        .map_err(|e| e.to_string())?;
        let (settings, mut current) = (self.settings.clone(), self.spec.clone());
        match self.switch(&next, &mut spec) {
            Ok(()) => {
                self.settings = next;
                self.spec = spec;
                Ok(())
            }
            Err(refusal) => {
                // Back to what worked; it derived before, so it derives again.
                if let Err(e) = self.switch(&settings, &mut current) {
                    return Err(format!("{refusal}; and restoring the settings failed: {e}"));
                }
                Err(refusal)
            }
        }
    }

    /// Writes the lens components and resources `spec` asks for, each only when it differs.
    /// A film diagonal `spec` leaves open is filled in with the one the lens renders on (its
    /// own format, as `realcam render` gives it), so the lens report and the state show it.
    fn switch(&mut self, settings: &LiveSettings, spec: &mut JobSpec) -> Result<(), String> {
        let name = settings.get("lens").unwrap_or(&self.lens_name).to_string();
        let current_focus = *self
            .renderer
            .world
            .get::<FocusSetting>(self.lens)
            .ok_or("the lens has no focus")?;
        let focus = spec.lens.focus(current_focus);
        let aperture = spec.lens.aperture(ApertureSetting::Full);
        let diaphragm = spec.lens.diaphragm().map_err(|e| format!("{e:#}"))?;
        if name != self.lens_name {
            let (prescription, argument) = self.library.load(&name)?;
            let entity = self.renderer.add_lens(&prescription, focus, aperture);
            self.renderer
                .world
                .entity_mut(entity)
                .insert((spec.dispersion, spec.flare));
            self.renderer.set_active_lens(entity);
            self.renderer.world.despawn(self.lens);
            self.lens = entity;
            self.lens_name = name;
            self.prescription = prescription;
            self.lens_argument = argument;
        } else {
            set_if_changed(&mut self.renderer, self.lens, focus);
            set_if_changed(&mut self.renderer, self.lens, aperture);
            set_if_changed(&mut self.renderer, self.lens, spec.dispersion);
            set_if_changed(&mut self.renderer, self.lens, spec.flare);
        }
        // The diaphragm and the film movements are the session's, whichever lens is on.
        self.renderer.set_diaphragm(self.lens, diaphragm);
        let zoom = spec
            .lens
            .zoom_setting_for(&self.prescription)
            .map_err(|e| format!("{e:#}"))?;
        self.renderer.set_zoom_position(self.lens, zoom);
        self.renderer
            .set_coating_choice(self.lens, spec.lens.coating_choice());
        self.renderer.set_movements(self.lens, spec.movements());
        let film_diagonal = spec
            .lens
            .film_diagonal_for(&self.prescription, self.hinted_film_diagonal);
        spec.lens.film_diagonal = Some(film_diagonal);
        self.renderer
            .set_film(film_diagonal, spec.lens.pupil_sampling);
        self.renderer.update().map_err(|e| e.to_string())?;
        self.renderer
            .check_active_lens()
            .map_err(|e| format!("{}: {e}", self.lens_name))?;
        let warning = self
            .renderer
            .world
            .get::<FilmCoverage>(self.lens)
            .and_then(FilmCoverage::warning)
            .map(str::to_string);
        if warning.is_some() && warning != self.warning {
            eprintln!("warning: {}", warning.as_deref().unwrap_or_default());
        }
        self.warning = warning;
        Ok(())
    }

    /// The settings that focus the lens on what the image shows at (`x`, `y`) (pixels of the
    /// full image, (0, 0) its top-left corner): a probe ray through the real lens, shift and
    /// tilt included, as `--focus-on` does ([`solve_focus_at`]). The answer is a focus
    /// distance (m, along the axis), or with a tilted film the film distance the solve found,
    /// since a distance along the axis does not say where a tilted plane of focus lies.
    pub fn focus_at_pixel(&self, x: f64, y: f64) -> Result<Value, String> {
        let (width, height) = self.size();
        let inside = (0.0..=width as f64).contains(&x) && (0.0..=height as f64).contains(&y);
        if !inside {
            return Err(format!(
                "the point ({x}, {y}) is outside the {width}×{height} image"
            ));
        }
        let world = &self.renderer.world;
        let geometry = world
            .get::<LensGeometry>(self.lens)
            .ok_or("the lens is not derived")?;
        let accel = world
            .get_resource::<SceneAccel>()
            .ok_or("no scene is loaded")?;
        let pose = world.get_resource::<CameraPose>().ok_or("no camera")?;
        let film = FilmGeometry::new(width, height, world.resource::<FilmFormat>().diagonal_mm)
            .moved(self.spec.movements().unwrap_or_default());
        let probe = solve_focus_at(
            &geometry.system,
            &geometry.first_order,
            accel,
            pose.0,
            &film,
            [x as f32, y as f32],
        )
        .map_err(|e| format!("nothing to focus on at ({x:.0}, {y:.0}): {e}"))?;
        Ok(if film.movements.is_tilted() {
            json!({ "film_distance": probe.film_distance })
        } else {
            json!({ "focus_distance": probe.object_distance_mm / 1e3 })
        })
    }

    fn render_settings(&self, scale: u32) -> RenderSettings {
        let (width, height) = self.size();
        RenderSettings {
            width: width.div_ceil(scale),
            height: height.div_ceil(scale),
            seed: self.spec.seed,
            max_depth: self.spec.max_depth,
            tile_size: 32,
            wavelengths: self.spec.wavelengths,
            filter: self.spec.filter,
        }
    }

    /// The image's size in pixels.
    pub fn size(&self) -> (u32, u32) {
        self.spec.size_or_default()
    }

    /// How much coarser than the image the first pass after a change is.
    fn preview_scale(&self) -> u32 {
        let (width, height) = self.size();
        width.max(height).div_ceil(PREVIEW_SIDE)
    }

    /// The first pass after a change: one sample per pixel of a film [`PREVIEW_SIDE`] pixels
    /// across, enlarged to the image's size; `None` when the image is no larger than that, or
    /// the pass was cancelled.
    pub fn render_preview(&mut self) -> anyhow::Result<Option<Image>> {
        let scale = self.preview_scale();
        if scale <= 1 {
            return Ok(None);
        }
        let coarse = self.render_settings(scale);
        self.renderer.set_settings(coarse);
        self.renderer.begin_film(None)?;
        if !self.renderer.render_pass_unless_cancelled(0)? {
            return Ok(None);
        }
        let small = self.renderer.image()?;
        let (width, height) = self.size();
        let mut image = Image::new(width, height);
        image.samples = 1;
        let means = small.mean();
        for y in 0..height {
            for x in 0..width {
                let source = (y / scale).min(small.height - 1) * small.width
                    + (x / scale).min(small.width - 1);
                image.sums[(y * width + x) as usize] = means[source as usize];
            }
        }
        Ok(Some(image))
    }

    /// Clears the full-resolution film for a new accumulation.
    pub fn begin_accumulation(&mut self) -> anyhow::Result<()> {
        let full = self.render_settings(1);
        self.renderer.set_settings(full);
        self.renderer.begin_film(None)?;
        self.spp_done = 0;
        Ok(())
    }

    /// Renders the next full-resolution pass; false when it was cancelled.
    pub fn render_next_pass(&mut self) -> anyhow::Result<bool> {
        let finished = self.renderer.render_pass_unless_cancelled(self.spp_done)?;
        if finished {
            self.spp_done += 1;
        }
        Ok(finished)
    }

    pub fn image(&mut self) -> anyhow::Result<Image> {
        self.renderer.image()
    }

    /// The 8-bit picture's exposure (linear scale) for `image`.
    pub fn exposure(&self, image: &Image) -> f32 {
        self.spec
            .output
            .exposure
            .map_or_else(|| auto_exposure(&image.mean()), |ev| 2f32.powf(ev))
    }

    /// The settings by name, defaults filled in with the values they stand for.
    pub fn settings_json(&self) -> serde_json::Map<String, Value> {
        let mut json = self.settings.to_json();
        let spec = &self.spec;
        let options = &spec.lens;
        let effective = [
            ("spp", json!(spec.spp)),
            ("seed", json!(spec.seed)),
            ("max_depth", json!(spec.max_depth)),
            (
                "dispersion",
                json!(match spec.dispersion {
                    crate::lens::elements::Dispersion::On => "on",
                    crate::lens::elements::Dispersion::Off => "off",
                }),
            ),
            ("wavelengths", json!(spec.wavelengths)),
            ("filter", json!(spec.filter.name())),
            (
                "flare",
                json!(match spec.flare {
                    crate::lens::elements::Flare::On => "on",
                    crate::lens::elements::Flare::Off => "off",
                }),
            ),
            (
                "focus_mode",
                json!(match options.focus_mode {
                    crate::lens::focus::FocusMode::Paraxial => "paraxial",
                    crate::lens::focus::FocusMode::Best => "best",
                }),
            ),
            ("pupil_sampling", json!(options.pupil_sampling)),
            ("film_diagonal", json!(options.film_diagonal)),
        ];
        for (name, value) in effective {
            if json.get(name).is_none_or(Value::is_null) {
                json.insert(name.to_string(), value);
            }
        }
        json
    }

    /// The equivalent `realcam render` command line.
    pub fn command_line(&self) -> String {
        let mut settings = self.settings.clone();
        settings.set("lens", self.lens_argument.clone());
        settings.command_line(&[])
    }

    /// Lens data for the state: focal length, f-number, film distance as derived.
    pub fn lens_info(&self) -> Value {
        let entity = self.renderer.world.entity(self.lens);
        match (entity.get::<LensGeometry>(), entity.get::<FilmPlacement>()) {
            (Some(geometry), Some(film)) => json!({
                "name": self.prescription.name,
                "focal_length_mm": geometry.first_order.focal_length,
                "f_number": geometry.f_number(),
                "film_distance_mm": film.film_distance,
                "stop_diameter_mm": geometry.system.stop_diameter(),
                // A zoom lens's positions (1-based, as `zoom_position` takes them), each with
                // its published focal length where the file gives one.
                "zoom_positions": self
                    .prescription
                    .spacings
                    .zoom
                    .iter()
                    .enumerate()
                    .map(|(i, p)| json!({ "position": i + 1, "focal_length_mm": p.focal_length_mm }))
                    .collect::<Vec<_>>(),
            }),
            _ => Value::Null,
        }
    }

    /// Writes the film so far to the session's `--out` and `--exr`; what was written, with the
    /// equivalent command line.
    pub fn save(&mut self) -> Result<Value, String> {
        if self.spp_done == 0 {
            return Err("nothing rendered at full resolution yet; save again in a moment".into());
        }
        let image = self.renderer.image().map_err(|e| format!("{e:#}"))?;
        let exposure = self.exposure(&image);
        write_image(
            &self.out,
            &image,
            self.formats.out,
            tone(&self.spec, exposure),
        )
        .map_err(|e| format!("{e:#}"))?;
        let linear = self.formats.exr.unwrap_or(ImageFormat::Exr);
        write_image(&self.exr, &image, linear, Tone::exposure(1.0))
            .map_err(|e| format!("{e:#}"))?;
        Ok(json!({
            "out": self.out.display().to_string(),
            "exr": self.exr.display().to_string(),
            "spp": image.samples,
            "command": self.command_line(),
        }))
    }
}
