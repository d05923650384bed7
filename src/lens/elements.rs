//! Lenses as ECS entities, and the systems that derive what tracing needs from them.
//!
//! A lens is a root entity ([`Lens`], [`FocusSetting`], [`ApertureSetting`]) whose children are
//! its surfaces ([`LensSurface`], one per prescription row, with [`SurfaceAsphere`] on an
//! aspheric surface and [`SurfaceGlass`] where the file names the glass after it). Derived data lives in components
//! on the lens entity and is recomputed only when its inputs change, in three steps:
//!
//! | step | writes | reruns when |
//! |---|---|---|
//! | [`derive_geometry`] | [`LensGeometry`] (packed surfaces with their losses, first-order data) | a surface (or its [`SurfaceCoating`]), the aperture, the [`CoatingChoice`], the zoom positions or setting, or the focus groups change (for a lens with focus groups, the focus too: see [`super::spacing`]) |
//! | [`place_film`] | [`FilmPlacement`] (film distance) | the geometry or the focus changes |
//! | [`focus_on_pixel`](super::focus_probe::focus_on_pixel) | [`FilmPlacement`], [`FocusProbe`] for a lens with [`FocusOnPixel`] | the geometry, focus target, movements, camera, film or scene changes |
//! | [`bound_exit_pupil`] | [`ExitPupil`] bounds | the placement, the [`FilmMovements`] or the [`FilmFormat`] changes |
//! | [`check_film_coverage`](super::coverage::check_film_coverage) | [`FilmCoverage`](super::coverage::FilmCoverage) (and a [`LensFault`] for a tilt the lens cannot cover) | the placement, the [`FilmMovements`], the film format or the image size changes |
//!
//! A lens that cannot be used (bad edit, impossible focus) gets a [`LensFault`] instead.
//!
//! The stop's surface entity may carry a [`Diaphragm`] (blades, a mask): adding, changing or
//! removing it, like a [`SurfaceAsphere`] or a [`SurfaceGlass`], re-derives the geometry as any
//! edit of a surface does.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use bevy_ecs::change_detection::DetectChanges;
use bevy_ecs::component::Component;
use bevy_ecs::entity::Entity;
use bevy_ecs::hierarchy::Children;
use bevy_ecs::lifecycle::RemovedComponents;
use bevy_ecs::query::{With, Without};
use bevy_ecs::resource::Resource;
use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule, SystemSet};
use bevy_ecs::system::{Commands, Query, Res, ResMut};
use bevy_ecs::world::{Ref, World};

use super::aperture::{ApertureSetting, stop_diameter};
use super::coating::{Coating, CoatingModel};
use super::diaphragm::Diaphragm;
use super::first_order::FirstOrder;
use super::focus::{FocusMode, best_film_distance, paraxial_film_distance};
use super::focus_probe::{FocusOnPixel, FocusProbe};
use super::movements::FilmMovements;
use super::prescription::{LensFormat, Prescription, SurfaceBase, SurfaceRow};
use super::pupil::{ExitPupil, PupilSampling};
use super::reflectance::SurfaceReflectance;
use super::shape::Asphere;
use super::spacing::{FocusGroups, ZoomPositions, ZoomSetting, rows_at};
use super::system::LensSystem;
use crate::glass::Glass;

/// The lens (root) entity.
#[derive(Component, Clone, Debug)]
pub struct Lens {
    pub name: String,
    pub source: PathBuf,
    pub format: LensFormat,
}

impl Lens {
    /// The lens entity's naming of `prescription`.
    pub fn of(prescription: &Prescription) -> Lens {
        Lens {
            name: prescription.name.clone(),
            source: prescription.source.clone(),
            format: prescription.format,
        }
    }
}

/// One surface of a lens: a child entity of its [`Lens`].
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct LensSurface {
    /// Position from the front (0) to the back.
    pub order: usize,
    pub base: SurfaceBase,
}

/// The conic and polynomial terms of an aspheric surface: a component of its [`LensSurface`]
/// entity (absent: a sphere, or a plane).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct SurfaceAsphere(pub Asphere);

/// The glass of the medium after a surface, which gives the dispersion around the row's index
/// (see [`SurfaceRow::index_at`]): a component of its [`LensSurface`] entity (absent: a fixed
/// index at every wavelength).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct SurfaceGlass(pub Glass);

/// The coating a lens file gives a surface, layers listed from the scene side: a component of
/// its [`LensSurface`] entity (absent: the lens's [`CoatingChoice`] decides).
#[derive(Component, Clone, Debug, PartialEq)]
pub struct SurfaceCoating(pub Coating);

/// How a lens's surfaces are coated for rendering: a component of the lens entity (absent: as
/// its file says, and the default model where it says nothing).
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CoatingChoice {
    /// Each surface as its file says ([`SurfaceCoating`]), this model on the others.
    AsFileSays { default: CoatingModel },
    /// This model on every surface, whatever the file says (`--coating`).
    Everywhere(CoatingModel),
}

impl Default for CoatingChoice {
    fn default() -> Self {
        CoatingChoice::AsFileSays {
            default: CoatingModel::default(),
        }
    }
}

impl CoatingChoice {
    /// The choice in words: the model on every surface (`single`), or where the lens file
    /// gives coatings (`file_has`) those and the model on the rest (`file, single elsewhere`).
    pub fn describe(self, file_has: bool) -> String {
        match self {
            CoatingChoice::AsFileSays { default } if file_has => {
                format!("file, {} elsewhere", default.name())
            }
            CoatingChoice::AsFileSays { default } => default.name().to_string(),
            CoatingChoice::Everywhere(model) => model.name().to_string(),
        }
    }

    /// The choice `--coating` makes: the model on every surface, or without one the file's
    /// coatings and the default.
    pub fn from_option(model: Option<CoatingModel>) -> CoatingChoice {
        model.map_or_else(CoatingChoice::default, CoatingChoice::Everywhere)
    }

    /// The reflectances of `rows` coated as this choice says, `file` giving each surface's
    /// coating from the lens file (`None`: none given); `None` for a lossless lens.
    pub fn reflectance(
        self,
        rows: &[SurfaceRow],
        file: &[Option<Coating>],
    ) -> Option<Arc<SurfaceReflectance>> {
        match self {
            CoatingChoice::AsFileSays { default } => {
                SurfaceReflectance::with_model(rows, |i| file.get(i).cloned().flatten(), default)
            }
            CoatingChoice::Everywhere(model) => {
                SurfaceReflectance::with_model(rows, |_| None, model)
            }
        }
    }
}

impl LensSurface {
    /// The whole prescription row: the base with the surface's asphere and glass.
    pub fn full_row(
        &self,
        asphere: Option<&SurfaceAsphere>,
        glass: Option<&SurfaceGlass>,
    ) -> SurfaceRow {
        SurfaceRow {
            base: self.base,
            asphere: asphere.map_or(Asphere::NONE, |a| a.0),
            glass: glass.map(|g| g.0),
        }
    }
}

/// Marks the lens the renderer uses.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct ActiveLens;

/// Whether a lens with glass data renders each camera ray at its own wavelength (colour
/// fringes), or every ray at the lens file's indices (n_d). A lens without the component
/// renders spectrally; one without glass data is the same either way.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Dispersion {
    #[default]
    On,
    Off,
}

impl Dispersion {
    /// True when rays of `geometry`'s lens get wavelengths under this setting.
    pub fn is_spectral(setting: Option<&Dispersion>, geometry: &LensGeometry) -> bool {
        setting != Some(&Dispersion::Off) && geometry.system.is_dispersive()
    }
}

/// Whether a render traces the lens's ghosts (light reflected twice inside it, see
/// [`super::ghost`]): a lens without the component does, where its surfaces reflect.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Flare {
    #[default]
    On,
    Off,
}

/// Where the lens is focused.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub enum FocusSetting {
    /// Object plane at this distance from the film, metres.
    Distance { metres: f64, mode: FocusMode },
    /// Rear vertex → film, mm, set directly.
    FilmDistance(f64),
}

impl Default for FocusSetting {
    /// pbrt's and `realcam lens`'s default.
    fn default() -> Self {
        FocusSetting::Distance {
            metres: 10.0,
            mode: FocusMode::Paraxial,
        }
    }
}

/// Film size and pupil-sampling scheme: a resource, since the film belongs to the camera, not
/// to any one lens.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct FilmFormat {
    pub diagonal_mm: f64,
    pub pupil_sampling: PupilSampling,
}

/// Film diagonal (mm) when neither the job, the lens nor the scene's camera gives one.
pub const DEFAULT_FILM_DIAGONAL_MM: f64 = 35.0;

impl Default for FilmFormat {
    fn default() -> Self {
        FilmFormat {
            diagonal_mm: DEFAULT_FILM_DIAGONAL_MM,
            pupil_sampling: PupilSampling::Bounds,
        }
    }
}

/// Packed surfaces with the stop opened as set, and their first-order data.
#[derive(Component, Clone, Debug)]
pub struct LensGeometry {
    pub system: LensSystem,
    /// Paraxial data, with the stop's full circle (a diaphragm's opening is inside it).
    pub first_order: FirstOrder,
    /// The diaphragm's opening over the stop circle's area (1 without one).
    pub open_fraction: f64,
    pub warnings: Vec<String>,
    /// What a user should know that is not wrong (how an f-number sized a diaphragm).
    pub notes: Vec<String>,
}

impl LensGeometry {
    /// The f-number of the opening's area-equivalent circle: the first-order f-number, made
    /// slower by the light the diaphragm holds back.
    pub fn f_number(&self) -> f64 {
        if self.open_fraction == 1.0 {
            self.first_order.f_number
        } else {
            self.first_order.f_number / self.open_fraction.sqrt()
        }
    }
}

/// The film position for the current focus.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct FilmPlacement {
    /// Rear vertex → film, mm.
    pub film_distance: f64,
}

/// Why a lens cannot be rendered with right now.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct LensFault(pub String);

/// How often and how long each derivation step ran (for `--stats` and the swap benchmark).
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct LensDerivationStats {
    pub geometry_runs: u64,
    pub placement_runs: u64,
    pub pupil_runs: u64,
    pub total_time: Duration,
}

/// The derivation steps, in order.
#[derive(SystemSet, Clone, Debug, PartialEq, Eq, Hash)]
pub enum LensDerivation {
    Geometry,
    Placement,
    Pupil,
}

/// Adds the derivation systems to `schedule`, chained so each sees the previous one's writes.
pub fn add_lens_systems(schedule: &mut Schedule) {
    schedule.configure_sets(
        (
            LensDerivation::Geometry,
            LensDerivation::Placement,
            LensDerivation::Pupil,
        )
            .chain(),
    );
    schedule.add_systems((
        derive_geometry.in_set(LensDerivation::Geometry),
        place_film.in_set(LensDerivation::Placement),
        super::focus_probe::focus_on_pixel.in_set(LensDerivation::Placement),
        bound_exit_pupil.in_set(LensDerivation::Pupil),
        super::coverage::check_film_coverage
            .in_set(LensDerivation::Pupil)
            .after(bound_exit_pupil),
    ));
}

/// Spawns a lens and its surfaces; returns the lens entity.
pub fn spawn_lens(
    world: &mut World,
    prescription: &Prescription,
    focus: FocusSetting,
    aperture: ApertureSetting,
) -> Entity {
    let lens = Lens::of(prescription);
    let mut entity = world.spawn((lens, focus, aperture));
    if !prescription.spacings.zoom.is_empty() {
        entity.insert(ZoomPositions(prescription.spacings.zoom.clone()));
    }
    if let Some(groups) = &prescription.spacings.focus {
        entity.insert(groups.clone());
    }
    entity.with_children(|children| {
        for (order, row) in prescription.rows.iter().enumerate() {
            let mut surface = children.spawn(LensSurface {
                order,
                base: row.base,
            });
            if row.asphere != Asphere::NONE {
                surface.insert(SurfaceAsphere(row.asphere));
            }
            if let Some(glass) = row.glass {
                surface.insert(SurfaceGlass(glass));
            }
            if let Some(coating) = prescription.coating(order) {
                surface.insert(SurfaceCoating(coating.clone()));
            }
        }
    });
    entity.id()
}

/// Puts `diaphragm` on the stop surface of `lens` (`None` or a circular one: the stop's plain
/// circle), touching the component only when it changes. Returns false when `lens` has no
/// surfaces.
pub fn set_diaphragm(world: &mut World, lens: Entity, diaphragm: Option<Diaphragm>) -> bool {
    let Some(children) = world.get::<Children>(lens) else {
        return false;
    };
    let surfaces: Vec<(Entity, LensSurface)> = children
        .iter()
        .filter_map(|&c| world.get::<LensSurface>(c).map(|s| (c, *s)))
        .collect();
    // The stop as [`LensSystem::new`] finds it: the stop row, else the first.
    let Some(stop) = surfaces
        .iter()
        .find(|(_, s)| s.base.stop)
        .or_else(|| surfaces.iter().find(|(_, s)| s.order == 0))
        .map(|(e, _)| *e)
    else {
        return false;
    };
    let diaphragm = diaphragm.filter(|d| !d.is_circular());
    let current = world.get::<Diaphragm>(stop);
    if current == diaphragm.as_ref() {
        return true;
    }
    match diaphragm {
        Some(d) => {
            world.entity_mut(stop).insert(d);
        }
        None => {
            world.entity_mut(stop).remove::<Diaphragm>();
        }
    }
    true
}

/// Sets the zoom position `lens` renders at (0-based; `None`: as its rows give it), touching
/// the component only when it changes.
pub fn set_zoom_position(world: &mut World, lens: Entity, position: Option<usize>) {
    let mut entity = world.entity_mut(lens);
    match position {
        Some(p) if entity.get::<ZoomSetting>() != Some(&ZoomSetting(p)) => {
            entity.insert(ZoomSetting(p));
        }
        None if entity.contains::<ZoomSetting>() => {
            entity.remove::<ZoomSetting>();
        }
        _ => {}
    }
}

/// Sets how `lens`'s surfaces are coated, touching the component only when it changes.
pub fn set_coating_choice(world: &mut World, lens: Entity, choice: CoatingChoice) {
    let mut entity = world.entity_mut(lens);
    if entity.get::<CoatingChoice>() != Some(&choice) {
        entity.insert(choice);
    }
}

/// Makes `lens` the only [`ActiveLens`].
pub fn activate_lens(world: &mut World, lens: Entity) {
    let active: Vec<Entity> = world
        .query_filtered::<Entity, With<ActiveLens>>()
        .iter(world)
        .collect();
    for e in active {
        world.entity_mut(e).remove::<ActiveLens>();
    }
    world.entity_mut(lens).insert(ActiveLens);
}

/// A surface entity's components, each with its change ticks.
type SurfaceParts = (
    Ref<'static, LensSurface>,
    Option<Ref<'static, SurfaceAsphere>>,
    Option<Ref<'static, SurfaceGlass>>,
    Option<Ref<'static, Diaphragm>>,
    Option<Ref<'static, SurfaceCoating>>,
);

/// A lens root's variable spacings, each with its change ticks: the positions, the chosen
/// one, the focus groups and the focus they follow.
type SpacingParts = (
    Option<Ref<'static, ZoomPositions>>,
    Option<Ref<'static, ZoomSetting>>,
    Option<Ref<'static, FocusGroups>>,
    Option<Ref<'static, FocusSetting>>,
);

/// What the geometry of a lens root is derived from, besides its surfaces.
type GeometryInputs = (
    Entity,
    &'static Lens,
    Ref<'static, Children>,
    Ref<'static, ApertureSetting>,
    SpacingParts,
    Option<Ref<'static, CoatingChoice>>,
);

/// Builds the geometry of every lens whose surfaces (a row, an asphere, a glass, a coating, the
/// stop's diaphragm: changed, added or taken away), aperture, coating choice or variable
/// spacings (zoom positions, the zoom setting, focus groups, and for a lens with groups the
/// focus) changed.
// A system's parameters are its explicit queries and resources (bevy style), not a bundle.
#[allow(clippy::too_many_arguments)]
pub fn derive_geometry(
    mut commands: Commands,
    lenses: Query<GeometryInputs>,
    surfaces: Query<SurfaceParts>,
    mut removed_aspheres: RemovedComponents<SurfaceAsphere>,
    mut removed_glasses: RemovedComponents<SurfaceGlass>,
    mut removed_diaphragms: RemovedComponents<Diaphragm>,
    mut removed_coatings: RemovedComponents<SurfaceCoating>,
    mut removed_choices: RemovedComponents<CoatingChoice>,
    mut removed_zoom: RemovedComponents<ZoomSetting>,
    mut removed_spacings: RemovedComponents<ZoomPositions>,
    mut removed_groups: RemovedComponents<FocusGroups>,
    mut stats: ResMut<LensDerivationStats>,
) {
    let removed: Vec<Entity> = removed_aspheres
        .read()
        .chain(removed_glasses.read())
        .chain(removed_diaphragms.read())
        .chain(removed_coatings.read())
        .collect();
    let respaced: Vec<Entity> = removed_zoom
        .read()
        .chain(removed_spacings.read())
        .chain(removed_groups.read())
        .chain(removed_choices.read())
        .collect();
    for (entity, lens, children, aperture, (positions, zoom, groups, focus), choice) in &lenses {
        let spacing_changed = respaced.contains(&entity)
            || choice.as_ref().is_some_and(|c| c.is_changed())
            || positions.as_ref().is_some_and(|p| p.is_changed())
            || zoom.as_ref().is_some_and(|z| z.is_changed())
            || groups.as_ref().is_some_and(|g| g.is_changed())
            || (groups.is_some() && focus.as_ref().is_some_and(|f| f.is_changed()));
        let surface_changed = children.iter().any(|c| {
            removed.contains(c)
                || surfaces.get(*c).is_ok_and(|(s, a, g, d, coating)| {
                    s.is_changed()
                        || a.is_some_and(|a| a.is_changed())
                        || g.is_some_and(|g| g.is_changed())
                        || d.is_some_and(|d| d.is_changed())
                        || coating.is_some_and(|c| c.is_changed())
                })
        });
        if !(children.is_changed() || aperture.is_changed() || surface_changed || spacing_changed) {
            continue;
        }
        let start = Instant::now();
        let mut parts: Vec<SurfacePart> = children
            .iter()
            .filter_map(|c| surfaces.get(*c).ok())
            .map(|(s, a, g, d, coating)| {
                let row = s.full_row(a.as_deref(), g.as_deref());
                (
                    s.order,
                    row,
                    d.map(|d| d.into_inner()),
                    coating.map(|c| &c.into_inner().0),
                )
            })
            .collect();
        parts.sort_by_key(|(order, ..)| *order);
        let diaphragm = parts.iter().find_map(|(_, _, d, _)| *d);
        let coatings: Vec<Option<Coating>> = parts.iter().map(|(.., c)| c.cloned()).collect();
        let rows: Vec<SurfaceRow> = parts.into_iter().map(|(_, row, ..)| row).collect();
        let choice = choice.as_deref().copied().unwrap_or_default();
        let spaced = spaced_rows(
            &rows,
            positions.as_deref(),
            zoom.as_deref(),
            groups.as_deref(),
            focus.as_deref(),
        );
        let built = spaced
            .map_err(|e| format!("{}: {e}", lens.source.display()))
            .and_then(|rows| build_geometry_with(lens, &rows, *aperture, diaphragm))
            .map(|mut geometry| {
                let reflectance = choice.reflectance(&geometry.system.rows, &coatings);
                geometry.system = geometry.system.with_reflectance(reflectance);
                geometry
            });
        match built {
            Ok(geometry) => {
                commands
                    .entity(entity)
                    .insert(geometry)
                    .remove::<LensFault>();
            }
            Err(message) => {
                commands
                    .entity(entity)
                    .insert(LensFault(message))
                    .remove::<LensGeometry>();
            }
        }
        stats.geometry_runs += 1;
        stats.total_time += start.elapsed();
    }
}

/// One surface entity's part in its lens: its order, row, diaphragm and coating.
type SurfacePart<'a> = (
    usize,
    SurfaceRow,
    Option<&'a Diaphragm>,
    Option<&'a Coating>,
);

/// `rows` at the chosen zoom position, with the focus groups where `focus` puts them (at
/// infinity for a film distance set directly): the rows themselves for a lens without
/// variable spacings.
fn spaced_rows(
    rows: &[SurfaceRow],
    positions: Option<&ZoomPositions>,
    zoom: Option<&ZoomSetting>,
    groups: Option<&FocusGroups>,
    focus: Option<&FocusSetting>,
) -> Result<Vec<SurfaceRow>, String> {
    if positions.is_none() && zoom.is_none() && groups.is_none() {
        return Ok(rows.to_vec());
    }
    let position = match (positions, zoom) {
        (_, None) => None,
        (Some(ZoomPositions(list)), Some(&ZoomSetting(i))) if i < list.len() => Some(&list[i]),
        (Some(ZoomPositions(list)), Some(&ZoomSetting(i))) => {
            return Err(format!(
                "zoom position {}: the lens has {} (1 to {})",
                i + 1,
                list.len(),
                list.len()
            ));
        }
        (None, Some(&ZoomSetting(i))) => {
            return Err(format!(
                "zoom position {}: this lens has fixed spacings, no zoom positions",
                i + 1
            ));
        }
    };
    let metres = match focus {
        Some(FocusSetting::Distance { metres, .. }) => *metres,
        _ => f64::INFINITY,
    };
    rows_at(rows, position, groups.map(|g| (g, metres)))
}

/// Re-validates `rows` (an edit may have broken them), sizes the stop, computes first-order data.
pub fn build_geometry(
    lens: &Lens,
    rows: &[SurfaceRow],
    aperture: ApertureSetting,
) -> Result<LensGeometry, String> {
    build_geometry_with(lens, rows, aperture, None)
}

/// [`build_geometry`] with a diaphragm at the stop, inscribed in the stop's circle; an
/// f-number sizes that circle so the opening has the f-number circle's area (and says so in
/// the notes).
pub fn build_geometry_with(
    lens: &Lens,
    rows: &[SurfaceRow],
    aperture: ApertureSetting,
    diaphragm: Option<&Diaphragm>,
) -> Result<LensGeometry, String> {
    let prescription =
        Prescription::from_rows(&lens.name, &lens.source, lens.format, rows.to_vec())
            .map_err(|e| e.to_string())?;
    let full = LensSystem::new(&prescription.rows, None);
    let full_first_order =
        FirstOrder::compute(&full).map_err(|e| format!("{}: {e}", lens.source.display()))?;
    let diaphragm = diaphragm.filter(|d| !d.is_circular());
    let open_fraction = diaphragm.map_or(1.0, Diaphragm::open_fraction);
    let (diameter, warning) = stop_diameter(aperture, &full, &full_first_order, open_fraction)?;
    let system = LensSystem::new(&prescription.rows, Some(diameter)).with_diaphragm(diaphragm);
    let first_order =
        FirstOrder::compute(&system).map_err(|e| format!("{}: {e}", lens.source.display()))?;
    let mut geometry = LensGeometry {
        system,
        first_order,
        open_fraction,
        warnings: warning.into_iter().collect(),
        notes: Vec::new(),
    };
    if let (Some(diaphragm), ApertureSetting::FNumber(n)) = (diaphragm, aperture) {
        geometry.notes.push(format!(
            "f/{n} with {}: the opening ({:.1} % of its circle) has the area of the f/{n} circle, so the stop's circle is {:.3} mm across (f/{:.2} were it round); the lens passes the light of f/{:.2}",
            diaphragm.describe(),
            100.0 * open_fraction,
            geometry.system.stop_diameter(),
            geometry.first_order.f_number,
            geometry.f_number(),
        ));
    }
    Ok(geometry)
}

type PlacementQuery<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static Lens,
        Ref<'static, LensGeometry>,
        Ref<'static, FocusSetting>,
    ),
    Without<FocusOnPixel>,
>;

/// Solves the film distance of every lens whose geometry or focus changed (or that stopped
/// focusing on a pixel), except those focused on a pixel.
pub fn place_film(
    mut commands: Commands,
    lenses: PlacementQuery,
    mut unpinned: RemovedComponents<FocusOnPixel>,
    mut stats: ResMut<LensDerivationStats>,
) {
    let unpinned: Vec<Entity> = unpinned.read().collect();
    for (entity, lens, geometry, focus) in &lenses {
        if !(geometry.is_changed() || focus.is_changed() || unpinned.contains(&entity)) {
            continue;
        }
        let start = Instant::now();
        match film_distance_for(&geometry, *focus) {
            Ok(film_distance) => {
                commands
                    .entity(entity)
                    .insert(FilmPlacement { film_distance })
                    .remove::<(LensFault, FocusProbe)>();
            }
            Err(message) => {
                let message = format!("{}: {message}", lens.source.display());
                commands
                    .entity(entity)
                    .insert(LensFault(message))
                    .remove::<FilmPlacement>();
            }
        }
        stats.placement_runs += 1;
        stats.total_time += start.elapsed();
    }
}

/// Film distance (rear vertex → film, mm) for a focus setting.
pub fn film_distance_for(geometry: &LensGeometry, focus: FocusSetting) -> Result<f64, String> {
    match focus {
        FocusSetting::FilmDistance(mm) => {
            if mm.is_finite() && mm > 0.0 {
                Ok(mm)
            } else {
                Err(format!("film distance {mm} mm must be a positive number"))
            }
        }
        FocusSetting::Distance { metres, mode } => {
            let mm = metres * 1000.0;
            let paraxial = paraxial_film_distance(&geometry.system, &geometry.first_order, mm)
                .map_err(|e| e.to_string())?;
            match mode {
                FocusMode::Paraxial => Ok(paraxial),
                FocusMode::Best => {
                    best_film_distance(&geometry.system, mm, paraxial).map_err(|e| e.to_string())
                }
            }
        }
    }
}

type PupilQuery<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static Lens,
        Ref<'static, LensGeometry>,
        Ref<'static, FilmPlacement>,
        Option<Ref<'static, Dispersion>>,
        Option<Ref<'static, FilmMovements>>,
    ),
>;

/// Bounds the exit pupil of every lens whose placement, movements or dispersion setting
/// changed, or of all when the film did: over every rendered wavelength for a spectral lens,
/// and over every point of a shifted or tilted film.
pub fn bound_exit_pupil(
    mut commands: Commands,
    lenses: PupilQuery,
    mut unmoved: RemovedComponents<FilmMovements>,
    film: Res<FilmFormat>,
    mut stats: ResMut<LensDerivationStats>,
) {
    let unmoved: Vec<Entity> = unmoved.read().collect();
    for (entity, lens, geometry, placement, dispersion, movements) in &lenses {
        let dispersion_changed = dispersion.as_ref().is_some_and(|d| d.is_changed());
        let movements_changed = movements.as_ref().is_some_and(|m| m.is_changed());
        if !(geometry.is_changed()
            || placement.is_changed()
            || film.is_changed()
            || dispersion_changed
            || movements_changed
            || unmoved.contains(&entity))
        {
            continue;
        }
        let start = Instant::now();
        let movements = movements.as_deref().copied().unwrap_or_default();
        if let Err(message) = movements.validate() {
            let message = format!("{}: {message}", lens.source.display());
            commands
                .entity(entity)
                .insert(LensFault(message))
                .remove::<ExitPupil>();
            continue;
        }
        // A diaphragm lies inside the stop's circle: bounds for the circle hold for it, however
        // fine its features (a grid search could miss a mask's small holes).
        let circular;
        let system = if geometry.system.diaphragm.is_some() {
            circular = geometry.system.without_diaphragm();
            &circular
        } else {
            &geometry.system
        };
        let pupil = ExitPupil::compute_moved(
            system,
            placement.film_distance,
            film.diagonal_mm,
            film.pupil_sampling,
            Dispersion::is_spectral(dispersion.as_deref(), &geometry),
            &movements,
        );
        commands.entity(entity).insert(pupil).remove::<LensFault>();
        stats.pupil_runs += 1;
        stats.total_time += start.elapsed();
    }
}
