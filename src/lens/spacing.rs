//! Variable spacings: the gaps a zoom lens changes between its zoom positions, and those a lens
//! that focuses by moving groups (internal or rear focus, floating elements) changes with the
//! focus distance.
//!
//! A prescription's rows are the lens as its file writes it (a Zemax file writes its active
//! configuration); [`VariableSpacings`] says which rows' thicknesses differ:
//!
//! - a **zoom position** ([`ZoomPosition`]) replaces some thicknesses, and where the design
//!   changes it, the stop's diameter (Zemax's `APER`, converted to the stop it opens);
//! - **focus groups** ([`FocusGroups`]) give some thicknesses at infinity focus and at the
//!   closest focus distance (`d` and `d_close` measured from the film plane, as
//!   `--focus-distance` and a lens's published minimum focus distance are). In a zoom whose
//!   focus groups travel differently at each position (an internal-focus zoom), each position
//!   gives its own gaps at close focus ([`ZoomPosition::close_gaps`]) beside its gaps at
//!   infinity.
//!
//! The two tabulated states fix the direction the groups move in: every focus gap at travel
//! `τ` is `t(τ) = t∞ + (t_close − t∞) · τ`; and their image distances (rear vertex to film),
//! `v∞` (the back focus) and `v_close` (the paraxial image of `d_close`), fix how the lens body
//! moves against the film, `v(τ) = v∞ + (v_close − v∞) · τ` (constant for a pure
//! internal-focus lens). Focus at `d` is the travel whose paraxial image of `d` falls at
//! `v(τ)`, solved in the bracket [0, 1] (regula falsi), as the lens's focusing cam is cut. Newton's x·x′ = f² makes τ
//! close to `d_close / d` (linear in 1/d, as sidp/physical-camera interpolates), which is the
//! fallback where no travel in [0, 1] solves it; but a real group's focal shift is not linear
//! in its travel, and the linear law would leave the film of an internal-focus lens tenths of a
//! millimetre off its design position between the tabulated states. The film is then placed
//! where the image of `d` falls, as for any lens.
//!
//! On a lens entity these are components of the root: [`ZoomPositions`] and [`FocusGroups`]
//! (from the file) and [`ZoomSetting`] (which position renders); the Geometry derivation reads
//! them, so a change re-derives the lens without reloading anything. A lens with none of them
//! is traced exactly as before.

use bevy_ecs::component::Component;

use super::first_order::FirstOrder;
use super::focus::paraxial_film_distance;
use super::prescription::SurfaceRow;
use super::system::LensSystem;

/// A thickness that differs from the prescription's: row `surface`'s (0-based, front first)
/// distance to the next surface, mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gap {
    pub surface: usize,
    pub thickness: f64,
}

/// One zoom position: its gaps, and the stop's diameter where the design changes it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ZoomPosition {
    /// The focal length published for this position (nominal; realcam computes its own).
    pub focal_length_mm: Option<f64>,
    pub gaps: Vec<Gap>,
    /// The stop's full clear diameter at this position, mm (`None`: the prescription's).
    pub stop_diameter: Option<f64>,
    /// Some of this position's gaps at the lens's close focus ([`FocusGroups::close_focus_m`]),
    /// as a patent tabulates an internal-focus zoom; each surface's gap at infinity is its
    /// entry in `gaps`. Empty: the position focuses by the lens's [`FocusGroups`] alone.
    pub close_gaps: Vec<Gap>,
}

/// A gap that focus groups change: its thickness at infinity focus and at the closest focus.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FocusGap {
    pub surface: usize,
    pub infinity: f64,
    pub close: f64,
}

/// How a lens focuses by moving groups: a component of its root entity.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct FocusGroups {
    /// The closest focus distance, metres from the film plane.
    pub close_focus_m: f64,
    /// The gaps that change with focus alike at every zoom position (a zoom's position-dependent
    /// focus travel is in its positions' [`ZoomPosition::close_gaps`]).
    pub gaps: Vec<FocusGap>,
}

impl FocusGroups {
    /// `d_close / d` for focus at `metres` from the film: the travel (0 at infinity, 1 at close
    /// focus) linear in 1/d, the first-order law ([`rows_at`] solves the exact one). Refuses a
    /// distance closer than the close focus, naming the distance the lens accepts.
    fn linear_travel(&self, metres: f64) -> Result<f64, String> {
        if metres.is_infinite() {
            return Ok(0.0);
        }
        // A millimetre's grace for a distance read back from a printed close focus.
        if metres < self.close_focus_m - 1e-6 {
            return Err(format!(
                "focus distance {metres} m is closer than this lens focuses: its focus groups reach {} m at the closest",
                self.close_focus_m
            ));
        }
        Ok((self.close_focus_m / metres).min(1.0))
    }
}

/// The zoom positions a lens has: a component of its root entity.
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct ZoomPositions(pub Vec<ZoomPosition>);

/// Which zoom position a lens renders at: index into its [`ZoomPositions`] (0-based; the
/// command line's `--zoom-position` is 1-based, as Zemax numbers its configurations). Absent:
/// the lens as its rows give it.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub struct ZoomSetting(pub usize);

/// Everything variable about a prescription's spacings (empty for a fixed lens).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VariableSpacings {
    pub zoom: Vec<ZoomPosition>,
    pub focus: Option<FocusGroups>,
}

impl VariableSpacings {
    /// The closest focus distance (mm from the film) of a lens that focuses by moving groups,
    /// else `unit_focus_mm`, the closest the whole lens moved away from the film reaches.
    pub fn closest_focus_mm(&self, unit_focus_mm: f64) -> f64 {
        self.focus
            .as_ref()
            .map_or(unit_focus_mm, |g| g.close_focus_m * 1000.0)
    }

    /// True for a lens with fixed spacings.
    pub fn is_empty(&self) -> bool {
        self.zoom.is_empty() && self.focus.is_none()
    }

    /// Whether the gaps and numbers make sense for a lens of `rows` (each position's rows are
    /// validated as a lens by [`Prescription::with_spacings`](super::Prescription::with_spacings)).
    pub fn check(&self, rows: &[SurfaceRow]) -> Result<(), String> {
        // The last row's thickness is the image distance, which realcam's focus sets.
        let gaps = rows.len().saturating_sub(1);
        let surface = |s: usize, what: &str| {
            if s < gaps {
                Ok(())
            } else {
                Err(format!(
                    "{what} names surface {}; the lens's gaps follow surfaces 1 to {gaps}",
                    s + 1
                ))
            }
        };
        let length = |t: f64, what: &str| {
            if t.is_finite() && t >= 0.0 {
                Ok(())
            } else {
                Err(format!(
                    "{what}: thickness {t} mm must be a length of 0 or more"
                ))
            }
        };
        for (i, position) in self.zoom.iter().enumerate() {
            let what = format!("zoom position {}", i + 1);
            for gap in &position.gaps {
                surface(gap.surface, &what)?;
                length(gap.thickness, &what)?;
            }
            if let Some(d) = position.stop_diameter
                && !(d.is_finite() && d > 0.0)
            {
                return Err(format!("{what}: stop diameter {d} mm must be positive"));
            }
            for gap in &position.close_gaps {
                if !position.gaps.iter().any(|g| g.surface == gap.surface) {
                    return Err(format!(
                        "{what}: surface {}'s gap at close focus is given, but not its gap at infinity at this position",
                        gap.surface + 1
                    ));
                }
                length(gap.thickness, &format!("{what} at close focus"))?;
            }
            if !position.close_gaps.is_empty() && self.focus.is_none() {
                return Err(format!(
                    "{what} gives gaps at close focus, but the lens gives no close focus distance ([focus] close_focus_m)"
                ));
            }
        }
        if let Some(focus) = &self.focus {
            if !(focus.close_focus_m.is_finite() && focus.close_focus_m > 0.0) {
                return Err(format!(
                    "close focus {} m must be a positive distance",
                    focus.close_focus_m
                ));
            }
            let zoom_focuses = self.zoom.iter().any(|p| !p.close_gaps.is_empty());
            if focus.gaps.is_empty() && !zoom_focuses {
                return Err(
                    "the focus groups move no gap: give [focus] surfaces with their gaps at infinity and close focus, or each zoom position's close_gaps".into(),
                );
            }
            for gap in &focus.gaps {
                surface(gap.surface, "a focus group")?;
                length(gap.infinity, "a focus group at infinity")?;
                length(gap.close, "a focus group at close focus")?;
                if self
                    .zoom
                    .iter()
                    .any(|p| p.gaps.iter().any(|g| g.surface == gap.surface))
                {
                    return Err(format!(
                        "surface {}'s gap changes both with zoom and with focus: give its gap at close focus per zoom position instead ([zoom] positions' close_gaps)",
                        gap.surface + 1
                    ));
                }
            }
        }
        Ok(())
    }
}

/// `rows` with the thicknesses (and stop diameter) of zoom position `zoom` and focus groups
/// `focus` set for focus at `metres` from the film (infinity for a film distance set directly).
pub fn rows_at(
    rows: &[SurfaceRow],
    zoom: Option<&ZoomPosition>,
    focus: Option<(&FocusGroups, f64)>,
) -> Result<Vec<SurfaceRow>, String> {
    let mut rows = rows.to_vec();
    if let Some(position) = zoom {
        for gap in &position.gaps {
            rows[gap.surface].base.thickness = gap.thickness;
        }
        if let Some(diameter) = position.stop_diameter
            && let Some(stop) = rows.iter_mut().find(|r| r.base.stop)
        {
            stop.base.aperture = diameter;
        }
    }
    if let Some((groups, metres)) = focus {
        let linear = groups.linear_travel(metres)?;
        let zoom_focus = zoom.iter().flat_map(|p| {
            p.close_gaps.iter().filter_map(|close| {
                let infinity = p.gaps.iter().rev().find(|g| g.surface == close.surface)?;
                Some(FocusGap {
                    surface: close.surface,
                    infinity: infinity.thickness,
                    close: close.thickness,
                })
            })
        });
        let gaps: Vec<FocusGap> = groups.gaps.iter().copied().chain(zoom_focus).collect();
        let travel = if linear == 0.0 || linear == 1.0 {
            linear
        } else {
            solve_travel(&rows, &gaps, groups.close_focus_m, metres).unwrap_or(linear)
        };
        move_groups(&mut rows, &gaps, travel);
    }
    Ok(rows)
}

/// Sets each focus gap of `rows` for the groups' `travel` (0 at infinity, 1 at close focus).
fn move_groups(rows: &mut [SurfaceRow], gaps: &[FocusGap], travel: f64) {
    for gap in gaps {
        rows[gap.surface].base.thickness = gap.infinity + (gap.close - gap.infinity) * travel;
    }
}

/// How closely [`solve_travel`] puts the image on the lens body's film: a picometre (f64 reaches it in a few steps).
const TRAVEL_TOLERANCE_MM: f64 = 1e-9;
/// Steps of [`solve_travel`] at most (it takes a handful: the miss is smooth in the travel).
const TRAVEL_STEPS: usize = 60;

/// The travel (see the module docs) at which the paraxial image of a point `metres` from the
/// film falls at the image distance interpolated between the two tabulated states: `None`
/// where the lens forms no real image along the way or no travel in [0, 1] solves it.
fn solve_travel(
    rows: &[SurfaceRow],
    gaps: &[FocusGap],
    close_focus_m: f64,
    metres: f64,
) -> Option<f64> {
    let lens_at = |travel: f64| {
        let mut moved = rows.to_vec();
        move_groups(&mut moved, gaps, travel);
        let system = LensSystem::new(&moved, None);
        let first_order = FirstOrder::compute(&system).ok()?;
        Some((system, first_order))
    };
    let image_distance = |(system, first_order): &(LensSystem, FirstOrder), mm: f64| {
        paraxial_film_distance(system, first_order, mm).ok()
    };
    // The two tabulated states, each built once: they give the lens body's film and bracket
    // the travel.
    let (at_infinity, at_close) = (lens_at(0.0)?, lens_at(1.0)?);
    let v_infinity = at_infinity.1.back_focal_length;
    let v_close = image_distance(&at_close, close_focus_m * 1000.0)?;
    // Where the image of the point falls against where the lens body puts the film.
    let film_at = |travel: f64| v_infinity + (v_close - v_infinity) * travel;
    let miss =
        |travel: f64| Some(image_distance(&lens_at(travel)?, metres * 1000.0)? - film_at(travel));
    // Regula falsi with the Illinois modification, inside the bracket [0, 1].
    let (mut low, mut high) = (0.0, 1.0);
    let mut miss_low = image_distance(&at_infinity, metres * 1000.0)? - film_at(low);
    let mut miss_high = image_distance(&at_close, metres * 1000.0)? - film_at(high);
    if miss_low == 0.0 {
        return Some(low);
    }
    if miss_low.signum() == miss_high.signum() {
        return None;
    }
    let mut kept = 0i8;
    for _ in 0..TRAVEL_STEPS {
        let travel = (low * miss_high - high * miss_low) / (miss_high - miss_low);
        let m = miss(travel)?;
        if m.abs() < TRAVEL_TOLERANCE_MM {
            return Some(travel);
        }
        if m.signum() == miss_low.signum() {
            (low, miss_low) = (travel, m);
            if kept == -1 {
                miss_high *= 0.5;
            }
            kept = -1;
        } else {
            (high, miss_high) = (travel, m);
            if kept == 1 {
                miss_low *= 0.5;
            }
            kept = 1;
        }
    }
    Some(0.5 * (low + high))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn focus_groups_move_until_the_image_falls_where_the_lens_body_puts_the_film() {
        // A plane window, then the focus gap, then an equiconvex singlet (n 1.5, R 50 mm) that
        // moves toward the window to focus closer.
        let groups = FocusGroups {
            close_focus_m: 0.5,
            gaps: vec![FocusGap {
                surface: 1,
                infinity: 10.0,
                close: 2.0,
            }],
        };
        let rows = vec![
            SurfaceRow::new(0.0, 2.0, 1.5, 30.0),
            SurfaceRow::new(0.0, 10.0, 1.0, 30.0),
            SurfaceRow::new(50.0, 3.0, 1.5, 30.0),
            SurfaceRow::new(-50.0, 0.0, 1.0, 30.0),
        ];
        let gap = |m: f64| {
            rows_at(&rows, None, Some((&groups, m))).unwrap()[1]
                .base
                .thickness
        };
        assert_eq!(gap(f64::INFINITY), 10.0);
        assert_eq!(gap(0.5), 2.0);
        // Between them the travel τ = (10 − gap)/8 puts the paraxial image of d at
        // v∞ + (v_close − v∞)·τ: the ends' image distances, from the same lens.
        let v = |gap: f64, mm: f64| {
            let mut moved = rows.clone();
            moved[1].base.thickness = gap;
            let system = LensSystem::new(&moved, None);
            let first_order = FirstOrder::compute(&system).unwrap();
            paraxial_film_distance(&system, &first_order, mm).unwrap()
        };
        let (v_infinity, v_close) = (v(10.0, 1e12), v(2.0, 500.0));
        for metres in [0.7, 1.0, 2.0, 10.0] {
            let g = gap(metres);
            let travel = (10.0 - g) / 8.0;
            assert!((0.0..1.0).contains(&travel), "{metres} m: gap {g}");
            let expected = v_infinity + (v_close - v_infinity) * travel;
            assert!(
                (v(g, metres * 1000.0) - expected).abs() < 1e-7,
                "{metres} m: image at {} mm, the lens body's film at {expected} mm",
                v(g, metres * 1000.0)
            );
        }
        let e = rows_at(&rows, None, Some((&groups, 0.3))).unwrap_err();
        assert!(e.contains("0.5 m"), "{e}");
    }
}
