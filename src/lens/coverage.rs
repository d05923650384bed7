//! Whether the lens covers the moved film: derived on the lens entity, like its geometry and
//! pupil, whenever the lens, its film placement, its [`FilmMovements`] or the film change.
//!
//! The verdict is [`check_coverage`]'s: a tilted film that reaches into the lens or leaves the
//! image circle cannot be rendered (the lens gets a [`LensFault`] saying why, which the
//! renderer's `check_active_lens` reports); a shifted frame whose corners leave the image
//! circle renders with those corners black, and the lens carries the warning.

use bevy_ecs::change_detection::DetectChanges;
use bevy_ecs::component::Component;
use bevy_ecs::entity::Entity;
use bevy_ecs::lifecycle::RemovedComponents;
use bevy_ecs::system::{Commands, Query, Res};
use bevy_ecs::world::Ref;

use super::camera::{FilmGeometry, FilmResolution};
use super::elements::{FilmFormat, FilmPlacement, Lens, LensFault, LensGeometry};
use super::movements::{FilmMovements, check_coverage};

/// What the film movements of a lens leave of its image: a component of a lens entity with
/// [`FilmMovements`].
#[derive(Component, Clone, Debug, PartialEq)]
pub enum FilmCoverage {
    /// The lens covers the moved frame.
    Covered,
    /// A shifted frame's corners leave the image circle and render black: the warning.
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
        Ref<'static, FilmMovements>,
        Option<&'static FilmCoverage>,
    ),
>;

/// Checks the coverage of every moved lens whose inputs changed; takes the verdict off a lens
/// whose movements were taken away.
pub fn check_film_coverage(
    mut commands: Commands,
    lenses: CoverageQuery,
    mut unmoved: RemovedComponents<FilmMovements>,
    resolution: Res<FilmResolution>,
    film: Res<FilmFormat>,
) {
    for entity in unmoved.read() {
        if let Ok(mut lens) = commands.get_entity(entity) {
            lens.remove::<FilmCoverage>();
        }
    }
    let film_changed = resolution.is_changed() || film.is_changed();
    for (entity, lens, geometry, placement, movements, previous) in &lenses {
        if !(film_changed
            || geometry.is_changed()
            || placement.is_changed()
            || movements.is_changed())
        {
            continue;
        }
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
