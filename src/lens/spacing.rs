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
//!   closest focus distance. Between them a gap moves linearly in the reciprocal of the focus
//!   distance: `t(d) = t∞ + (t_close − t∞) · d_close / d`, with `d` and `d_close` measured from
//!   the film plane (as `--focus-distance` and a lens's published minimum focus distance are).
//!   In a zoom whose focus groups travel differently at each position (an internal-focus
//!   zoom), each position gives its own gaps at close focus ([`ZoomPosition::close_gaps`]),
//!   interpolated the same way from that position's gaps at infinity.
//!   For a thin group moving to keep the image on a fixed film, the motion is exactly linear in
//!   1/d to first order (Newton's x·x' = f²), which is why designs tabulate two positions and
//!   sidp/physical-camera interpolates so. The film is then placed where the image of `d`
//!   falls, as for any lens, so the little the interpolation leaves over is taken up there and
//!   the image is always on the film.
//!
//! On a lens entity these are components of the root: [`ZoomPositions`] and [`FocusGroups`]
//! (from the file) and [`ZoomSetting`] (which position renders); the Geometry derivation reads
//! them, so a change re-derives the lens without reloading anything. A lens with none of them
//! is traced exactly as before.

use bevy_ecs::component::Component;

use super::prescription::SurfaceRow;

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
    /// How far the groups have travelled from infinity (0) toward close focus (1) for focus at
    /// `metres` from the film: `d_close / d`, linear in 1/d. Refuses a distance closer than the
    /// close focus, naming the distance the lens accepts.
    pub fn travel(&self, metres: f64) -> Result<f64, String> {
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
        let travel = groups.travel(metres)?;
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
        for gap in groups.gaps.iter().copied().chain(zoom_focus) {
            rows[gap.surface].base.thickness = gap.infinity + (gap.close - gap.infinity) * travel;
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn focus_groups_move_linearly_in_reciprocal_distance() {
        let groups = FocusGroups {
            close_focus_m: 0.5,
            gaps: vec![FocusGap {
                surface: 0,
                infinity: 4.0,
                close: 2.0,
            }],
        };
        let rows = vec![
            SurfaceRow::new(50.0, 3.0, 1.5, 20.0),
            SurfaceRow::new(-50.0, 0.0, 1.0, 20.0),
        ];
        let at = |m: f64| {
            rows_at(&rows, None, Some((&groups, m))).unwrap()[0]
                .base
                .thickness
        };
        assert_eq!(at(f64::INFINITY), 4.0);
        assert_eq!(at(0.5), 2.0);
        // 1 m is half way in 1/d between ∞ (0) and 0.5 m (2 /m).
        assert_eq!(at(1.0), 3.0);
        assert_eq!(at(2.0), 3.5);
        let e = rows_at(&rows, None, Some((&groups, 0.3))).unwrap_err();
        assert!(e.contains("0.5 m"), "{e}");
    }
}
