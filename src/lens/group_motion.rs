//! Where a zoom or focus-group lens's groups stand at each of its settings: the motion
//! diagram a patent draws beside its tables, one row per zoom position (and focus state), each
//! group's surfaces at their axial positions measured from the film plane.
//!
//! A **group** is a run of surfaces whose spacings never change: the lens is cut after every
//! surface whose gap varies (with zoom or with focus). Positions are vertex z measured from the
//! film (negative: in front of it), the film placed where the paraxial image of the state's
//! focus distance falls, so the rows line up on a fixed film plane, as a camera holds it.

use super::first_order::FirstOrder;
use super::focus::paraxial_film_distance;
use super::prescription::Prescription;
use super::spacing::{FocusGroups, ZoomPosition, rows_at};
use super::system::LensSystem;

/// Surfaces `first..=last` (0-based) that move together.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Group {
    pub first: usize,
    pub last: usize,
}

/// The lens at one setting.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionState {
    /// "zoom 2 (50 mm)", "close focus 0.45 m", ….
    pub label: String,
    /// Each surface's vertex z minus the film plane's, mm.
    pub from_film_mm: Vec<f64>,
}

/// Every group, and the lens at each zoom position (at infinity focus, and at close focus where
/// groups focus it).
#[derive(Clone, Debug, PartialEq)]
pub struct GroupMotion {
    pub groups: Vec<Group>,
    /// The stop's surface (0-based).
    pub stop: Option<usize>,
    pub states: Vec<MotionState>,
}

impl GroupMotion {
    /// The motion of `prescription`'s groups; `None` for a lens with fixed spacings. A setting
    /// whose first-order image cannot be found (no power, no real image of its close focus) has
    /// no row: the diagram shows whatever settings can be drawn.
    pub fn of(prescription: &Prescription) -> Option<GroupMotion> {
        let spacings = &prescription.spacings;
        if spacings.is_empty() {
            return None;
        }
        let groups = groups(prescription);
        let positions: Vec<(String, Option<&ZoomPosition>)> = if spacings.zoom.is_empty() {
            vec![(String::new(), None)]
        } else {
            spacings
                .zoom
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let label = match p.focal_length_mm {
                        Some(mm) => format!("zoom {} ({} mm)", i + 1, trim(mm)),
                        None => format!("zoom {}", i + 1),
                    };
                    (label, Some(p))
                })
                .collect()
        };
        let mut states = Vec::new();
        for (label, position) in positions {
            let separator = if label.is_empty() { "" } else { ", " };
            let infinity = match spacings.focus {
                Some(_) => format!("{label}{separator}focused at infinity"),
                None => label.clone(),
            };
            states.extend(state(prescription, position, None, infinity));
            if let Some(focus) = &spacings.focus {
                let close = trim(focus.close_focus_m);
                let label = format!("{label}{separator}close focus {close} m");
                states.extend(state(prescription, position, Some(focus), label));
            }
        }
        let stop = prescription.rows.iter().position(|r| r.base.stop);
        (!states.is_empty()).then_some(GroupMotion {
            groups,
            stop,
            states,
        })
    }
}

/// The groups of `prescription`: cut after every surface whose gap changes.
fn groups(prescription: &Prescription) -> Vec<Group> {
    let spacings = &prescription.spacings;
    let varies = |s: usize| {
        spacings
            .zoom
            .iter()
            .any(|p| p.gaps.iter().any(|g| g.surface == s))
            || spacings
                .focus
                .as_ref()
                .is_some_and(|f| f.gaps.iter().any(|g| g.surface == s))
    };
    let mut groups = Vec::new();
    let mut first = 0;
    let last = prescription.rows.len() - 1;
    for s in 0..=last {
        if s == last || varies(s) {
            groups.push(Group { first, last: s });
            first = s + 1;
        }
    }
    groups
}

/// The lens at `position`, focused at infinity or (with `focus`) at its groups' close focus.
fn state(
    prescription: &Prescription,
    position: Option<&ZoomPosition>,
    focus: Option<&FocusGroups>,
    label: String,
) -> Option<MotionState> {
    let metres = focus.map_or(f64::INFINITY, |f| f.close_focus_m);
    let groups = prescription.spacings.focus.as_ref().map(|g| (g, metres));
    let rows = rows_at(&prescription.rows, position, groups).ok()?;
    let system = LensSystem::new(&rows, None);
    let first_order = FirstOrder::compute(&system).ok()?;
    let film_distance = paraxial_film_distance(&system, &first_order, metres * 1000.0).ok()?;
    let film_z = system.rear_z() + film_distance;
    Some(MotionState {
        label,
        from_film_mm: system.f64s.vertex_z.iter().map(|z| z - film_z).collect(),
    })
}

/// A number as a label gives it: at most two decimals, no trailing zeros.
fn trim(value: f64) -> String {
    let text = format!("{value:.2}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}
