//! The lens settings of a render or a lens report: focus, stop, diaphragm, film format and
//! where camera rays aim. Plain data: the command line (`--focus-distance`, `--f-number`, …)
//! and the live lab fill it in; its messages name the command line's options, which are the
//! names users know these settings by.

use std::path::PathBuf;
use std::sync::Arc;

use crate::lens::aperture::ApertureSetting;
use crate::lens::coating::CoatingModel;
use crate::lens::diaphragm::{ApertureMask, Blades, Diaphragm};
use crate::lens::elements::CoatingChoice;
use crate::lens::elements::DEFAULT_FILM_DIAGONAL_MM;
use crate::lens::elements::FocusSetting;
use crate::lens::first_order::FirstOrder;
use crate::lens::focus::FocusMode;
use crate::lens::io::{GlassSubstitute, ReadOptions};
use crate::lens::pupil::PupilSampling;
#[cfg(doc)]
use crate::lens::spacing::ZoomSetting;
use crate::lens::spacing::rows_at;
use crate::lens::{LensFormat, LensSystem, Prescription};

/// Largest film distance accepted. Film distances far beyond the focal length focus near the
/// front focal point at huge magnification; 100 m is beyond any real bellows, and keeps the
/// f32 ray generator far from overflow.
pub const MAX_FILM_DISTANCE_MM: f64 = 1e5;

/// How a lens is set for a render (`None`: the lens's or the scene's default).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LensSettings {
    /// Focus on the plane this far from the film, metres (`inf` for infinity).
    pub focus_distance: Option<f64>,
    /// How the film distance is found for `focus_distance`.
    pub focus_mode: FocusMode,
    /// The film distance (rear vertex → film, mm), set directly instead of focusing.
    pub film_distance: Option<f64>,
    /// Aperture-stop diameter, mm.
    pub aperture: Option<f64>,
    /// The real f-number (EFL / entrance-pupil diameter) to open the stop to.
    pub f_number: Option<f64>,
    /// Film diagonal, mm.
    pub film_diagonal: Option<f64>,
    /// Layout of a `.dat` lens file's thickness column, when it cannot be detected.
    pub lens_format: Option<LensFormat>,
    /// Where camera rays aim.
    pub pupil_sampling: PupilSampling,
    /// Diaphragm blades (a regular N-gon stop).
    pub blades: Option<u32>,
    /// Angle of a blade vertex from the stop's +x, degrees.
    pub blade_rotation: Option<f64>,
    /// Curvature of the blades: 0 straight … 1 the stop's circle.
    pub blade_curvature: Option<f64>,
    /// Transmission mask image at the stop.
    pub aperture_image: Option<PathBuf>,
    /// Glasses a lens file names, read as others (`--glass NAME=GLASS`).
    pub glasses: Vec<GlassSubstitute>,
    /// The zoom position of a zoom lens, 1-based as Zemax numbers its configurations
    /// (`--zoom-position`; `None`: the lens as its surfaces are written).
    pub zoom_position: Option<usize>,
    /// The zoom position of a zoom lens by its focal length, mm (`--zoom`): the position whose
    /// focal length this is.
    pub zoom_focal_length: Option<f64>,
    /// The coating on every surface (`--coating`; `None`: as the lens file says, and the
    /// default model on the surfaces it says nothing of).
    pub coating: Option<CoatingModel>,
}

impl LensSettings {
    /// The film a lens renders on: `film_diagonal` (`--film-diagonal`), else the format the
    /// lens was designed for (a phone lens's is a few mm), else the scene camera's `hinted`
    /// one, else [`DEFAULT_FILM_DIAGONAL_MM`]. Each lens of a run, and each lens a live session
    /// swaps in, gets its own, so a lens renders the same picture beside others as alone.
    pub fn film_diagonal_for(&self, lens: &Prescription, hinted: Option<f64>) -> f64 {
        self.film_diagonal
            .or(lens.info.film_diagonal_mm)
            .or(hinted)
            .unwrap_or(DEFAULT_FILM_DIAGONAL_MM)
    }
    /// How the lens's surfaces are coated.
    pub fn coating_choice(&self) -> CoatingChoice {
        CoatingChoice::from_option(self.coating)
    }

    /// How the lens files are read.
    pub fn reading(&self) -> ReadOptions {
        ReadOptions {
            format: self.lens_format,
            glasses: self.glasses.clone(),
        }
    }

    /// The focus these settings ask for, else `fallback`.
    pub fn focus(&self, fallback: FocusSetting) -> FocusSetting {
        match (self.film_distance, self.focus_distance) {
            (Some(mm), _) => FocusSetting::FilmDistance(mm),
            (None, Some(metres)) => FocusSetting::Distance {
                metres,
                mode: self.focus_mode,
            },
            (None, None) => match fallback {
                FocusSetting::Distance { metres, .. } => FocusSetting::Distance {
                    metres,
                    mode: self.focus_mode,
                },
                other => other,
            },
        }
    }

    /// The aperture these settings ask for, else `fallback`.
    pub fn aperture(&self, fallback: ApertureSetting) -> ApertureSetting {
        match (self.aperture, self.f_number) {
            (Some(mm), _) => ApertureSetting::Diameter(mm),
            (None, Some(n)) => ApertureSetting::FNumber(n),
            (None, None) => fallback,
        }
    }

    /// The diaphragm these settings ask for (`None`: the stop's circle); reads the mask image.
    pub fn diaphragm(&self) -> anyhow::Result<Option<Diaphragm>> {
        let blades = self.blades_setting()?;
        let mask = match &self.aperture_image {
            Some(path) => {
                let mask = ApertureMask::load(path).map_err(anyhow::Error::msg)?;
                Some(Arc::new(mask))
            }
            None => None,
        };
        let diaphragm = Diaphragm { blades, mask };
        Ok((!diaphragm.is_circular()).then_some(diaphragm))
    }

    /// What the user should hear of the mask in `diaphragm` (how the image was read; a
    /// warning when it is not square): for a front end to print once, not on every change that
    /// re-derives the lens.
    pub fn mask_messages(&self, diaphragm: Option<&Diaphragm>) -> Vec<String> {
        let (Some(path), Some(mask)) = (
            &self.aperture_image,
            diaphragm.and_then(|d| d.mask.as_deref()),
        ) else {
            return Vec::new();
        };
        let mut messages = vec![format!(
            "note: aperture image {}: {}",
            path.display(),
            mask.reading
        )];
        if mask.width != mask.height {
            messages.push(format!(
                "warning: --aperture-image {}: {}×{} pixels is not square; it is stretched over the stop's diameter",
                path.display(),
                mask.width,
                mask.height
            ));
        }
        messages
    }

    fn blades_setting(&self) -> anyhow::Result<Option<Blades>> {
        self.blades
            .map(|count| {
                Blades::new(
                    count,
                    self.blade_rotation.unwrap_or(0.0),
                    self.blade_curvature.unwrap_or(0.0),
                )
                .map_err(anyhow::Error::msg)
            })
            .transpose()
    }

    /// The zoom position of `lens` as its entity's [`ZoomSetting`] counts it (0-based):
    /// `--zoom-position`, or the position whose focal
    /// length `--zoom` names (within 2 % of the paraxial one, or its published figure); a
    /// focal length between positions, or `--zoom` on a fixed lens, is refused in words.
    pub fn zoom_setting_for(&self, lens: &Prescription) -> anyhow::Result<Option<usize>> {
        let Some(mm) = self.zoom_focal_length else {
            return Ok(self.zoom_position.map(|n| n.saturating_sub(1)));
        };
        let positions = &lens.spacings.zoom;
        if positions.is_empty() {
            anyhow::bail!(
                "--zoom {mm} mm: {} has fixed spacings, no zoom positions",
                lens.name
            );
        }
        let focal_lengths: Vec<f64> = positions
            .iter()
            .map(|position| {
                rows_at(&lens.rows, Some(position), None)
                    .ok()
                    .and_then(|rows| FirstOrder::compute(&LensSystem::new(&rows, None)).ok())
                    .map_or(f64::NAN, |first_order| first_order.focal_length)
            })
            .collect();
        let named = |k: usize| {
            (focal_lengths[k] - mm).abs() <= 0.02 * mm
                || positions[k]
                    .focal_length_mm
                    .is_some_and(|published| (published - mm).abs() <= 1e-9 * mm)
        };
        if let Some(k) = (0..positions.len()).filter(|&k| named(k)).min_by(|&a, &b| {
            (focal_lengths[a] - mm)
                .abs()
                .total_cmp(&(focal_lengths[b] - mm).abs())
        }) {
            return Ok(Some(k));
        }
        let list: Vec<String> = focal_lengths
            .iter()
            .enumerate()
            .map(|(k, f)| format!("{} at {f:.1} mm", k + 1))
            .collect();
        anyhow::bail!(
            "--zoom {mm} mm: {} zooms through its design's positions only ({}); name one of those focal lengths, or --zoom-position N",
            lens.name,
            list.join(", ")
        )
    }

    pub fn validate(&self) -> anyhow::Result<()> {
        self.blades_setting()?;
        if self.zoom_position == Some(0) {
            anyhow::bail!("--zoom-position counts from 1, as Zemax numbers its configurations");
        }
        let positive = |name: &str, v: Option<f64>| match v {
            Some(x) if !(x.is_finite() && x > 0.0) => Err(anyhow::anyhow!(
                "--{name} must be a positive number, got {x}"
            )),
            _ => Ok(()),
        };
        if let Some(metres) = self.focus_distance
            && (metres.is_nan() || metres <= 0.0)
        {
            anyhow::bail!(
                "--focus-distance must be a positive number of metres or inf, got {metres}"
            );
        }
        positive("film-distance", self.film_distance)?;
        if let Some(mm) = self.film_distance
            && mm > MAX_FILM_DISTANCE_MM
        {
            anyhow::bail!(
                "--film-distance {mm} mm is beyond {MAX_FILM_DISTANCE_MM} mm (100 m): no lens focuses with its film that far back"
            );
        }
        positive("aperture", self.aperture)?;
        positive("f-number", self.f_number)?;
        positive("film-diagonal", self.film_diagonal)?;
        positive("zoom", self.zoom_focal_length)?;
        Ok(())
    }
}
