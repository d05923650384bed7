//! Whether the lens covers the film, moved or not: derived on the lens entity, like its
//! geometry and pupil, whenever the lens, its film placement, its [`FilmMovements`] or the film
//! change.
//!
//! The verdict is [`check_coverage`]'s: a tilt that drives the film into the lens, or darkens
//! a real part of what the untilted film has light on, cannot be rendered (the lens gets a
//! [`LensFault`] saying why, which the renderer's `check_active_lens` reports); a
//! frame whose corners lie outside the image circle — a film larger than the lens covers, or a
//! frame shifted out of it — renders with those corners black, tilted or not, and the lens
//! carries the warning.

use bevy_ecs::change_detection::DetectChanges;
use bevy_ecs::component::Component;
use bevy_ecs::entity::{Entity, EntityHashSet};
use bevy_ecs::lifecycle::RemovedComponents;
use bevy_ecs::system::{Commands, Query, Res};
use bevy_ecs::world::Ref;

use super::camera::{FilmGeometry, FilmResolution};
use super::elements::{FilmFormat, FilmPlacement, Lens, LensFault, LensGeometry};
use super::movements::{FilmMovements, check_coverage};

/// What the lens leaves of the frame on its film, moved or not: a component of every lens
/// entity with a geometry and a film placement.
#[derive(Component, Clone, Debug, PartialEq)]
pub enum FilmCoverage {
    /// The lens covers the frame.
    Covered,
    /// The frame's corners lie outside the image circle and render black: the warning.
    DarkCorners(String),
    /// The lens cannot cover the tilted frame; the lens carries a [`LensFault`] with this.
    Uncovered(String),
}

impl FilmCoverage {
    /// The warning to show, if any.
    pub fn warning(&self) -> Option<&str> {
        match self {
            FilmCoverage::DarkCorners(warning) => Some(warning),
            _ => None,
        }
    }
}

type CoverageQuery<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static Lens,
        Ref<'static, LensGeometry>,
        Ref<'static, FilmPlacement>,
        Option<Ref<'static, FilmMovements>>,
        Option<&'static FilmCoverage>,
    ),
>;

/// Checks the coverage of every lens whose inputs changed, a lens whose movements were taken
/// away included (its film is then judged unmoved).
pub fn check_film_coverage(
    mut commands: Commands,
    lenses: CoverageQuery,
    mut unmoved: RemovedComponents<FilmMovements>,
    resolution: Res<FilmResolution>,
    film: Res<FilmFormat>,
) {
    let unmoved: EntityHashSet = unmoved.read().collect();
    let film_changed = resolution.is_changed() || film.is_changed();
    for (entity, lens, geometry, placement, movements, previous) in &lenses {
        if !(film_changed
            || geometry.is_changed()
            || placement.is_changed()
            || movements.as_ref().is_some_and(Ref::is_changed)
            || unmoved.contains(&entity))
        {
            continue;
        }
        let movements = movements.as_deref().copied().unwrap_or(FilmMovements::NONE);
        // Values out of range are the pupil bounds' fault to report, not a coverage question.
        if movements.validate().is_err() {
            continue;
        }
        let frame = FilmGeometry::new(resolution.width, resolution.height, film.diagonal_mm);
        let coverage = match check_coverage(
            &geometry.system,
            placement.film_distance,
            &movements,
            frame.width_mm as f64,
            frame.height_mm as f64,
        ) {
            Ok(None) => FilmCoverage::Covered,
            Ok(Some(warning)) => FilmCoverage::DarkCorners(warning),
            Err(message) => FilmCoverage::Uncovered(message),
        };
        let mut commands = commands.entity(entity);
        match &coverage {
            FilmCoverage::Uncovered(message) => {
                commands.insert(LensFault(format!("{}: {message}", lens.source.display())));
            }
            // A fault this check put there goes with the cause.
            _ if matches!(previous, Some(FilmCoverage::Uncovered(_))) => {
                commands.remove::<LensFault>();
            }
            _ => {}
        }
        if previous != Some(&coverage) {
            commands.insert(coverage);
        }
    }
}
