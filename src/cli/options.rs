//! Lens options shared by `realcam render` and `realcam lens`.

use std::path::PathBuf;
use std::sync::Arc;

use clap::Args;

use super::values::{number, whole};

use crate::lens::LensFormat;
use crate::lens::aperture::ApertureSetting;
use crate::lens::diaphragm::{ApertureMask, Blades, Diaphragm};
use crate::lens::elements::FocusSetting;
use crate::lens::focus::FocusMode;
use crate::lens::pupil::PupilSampling;

/// Largest film distance accepted. Film distances far beyond the focal length focus near the
/// front focal point at huge magnification; 100 m is beyond any real bellows, and keeps the
/// f32 ray generator far from overflow.
pub const MAX_FILM_DISTANCE_MM: f64 = 1e5;

#[derive(Args, Debug, Clone, Default)]
pub struct LensOptions {
    /// Focus on the plane this far from the film, in metres (as pbrt); `inf` for infinity.
    #[arg(
        long,
        value_name = "M",
        conflicts_with = "film_distance",
        allow_hyphen_values = true,
        value_parser = number::<f64>
    )]
    pub focus_distance: Option<f64>,
    /// How the film distance is found for --focus-distance: `paraxial` (pbrt's thick-lens
    /// answer) or `best` (smallest real-ray RMS spot of the on-axis point).
    #[arg(long, value_name = "MODE", default_value = "paraxial")]
    pub focus_mode: FocusMode,
    /// Set the film distance (rear vertex → film, mm) directly instead of focusing.
    #[arg(long, value_name = "MM", allow_hyphen_values = true, value_parser = number::<f64>)]
    pub film_distance: Option<f64>,
    /// Aperture-stop diameter, mm (clamped to the lens's maximum, with a warning).
    #[arg(
        long,
        value_name = "MM",
        conflicts_with = "f_number",
        allow_hyphen_values = true,
        value_parser = number::<f64>
    )]
    pub aperture: Option<f64>,
    /// Open the stop so the real f-number (EFL / entrance-pupil diameter) is N.
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = number::<f64>)]
    pub f_number: Option<f64>,
    /// Film diagonal, mm [default: 35, or the scene camera's hint].
    #[arg(long, value_name = "MM", allow_hyphen_values = true, value_parser = number::<f64>)]
    pub film_diagonal: Option<f64>,
    /// Layout of the lens file's thickness column, when it cannot be detected.
    #[arg(long, value_name = "thickness-after|gap-before")]
    pub lens_format: Option<LensFormat>,
    /// Where camera rays aim: `bounds` (exit-pupil bounds, efficient) or `rear-element`
    /// (the whole rear element, as the CS348b course did).
    #[arg(long, value_name = "SCHEME", default_value = "bounds")]
    pub pupil_sampling: PupilSampling,
    /// Diaphragm blades: the stop becomes a regular N-gon (N ≥ 3) inscribed in its circle;
    /// with --f-number the polygon gets the area of that f-number's circle.
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = whole::<u32>(3, crate::lens::diaphragm::MAX_BLADES))]
    pub blades: Option<u32>,
    /// Angle of a blade vertex from the stop's +x (image right, seen from the film),
    /// degrees, counter-clockwise [default: 0].
    #[arg(long, value_name = "DEG", requires = "blades", allow_hyphen_values = true, value_parser = number::<f64>)]
    pub blade_rotation: Option<f64>,
    /// Curvature of the blades: 0 = straight … 1 = the stop's circle [default: 0].
    #[arg(long, value_name = "C", requires = "blades", allow_hyphen_values = true, value_parser = number::<f64>)]
    pub blade_curvature: Option<f64>,
    /// Transmission mask at the stop: a grey-level image (0 = opaque, 1 = open; RGB by its
    /// luminance, alpha multiplied in) spanning the stop's diameter, centred on the axis, top
    /// row up, as seen from the film.
    #[arg(long, value_name = "FILE.png")]
    pub aperture_image: Option<PathBuf>,
}

impl LensOptions {
    /// The focus the flags ask for, else `fallback`.
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

    /// The aperture the flags ask for, else `fallback`.
    pub fn aperture(&self, fallback: ApertureSetting) -> ApertureSetting {
        match (self.aperture, self.f_number) {
            (Some(mm), _) => ApertureSetting::Diameter(mm),
            (None, Some(n)) => ApertureSetting::FNumber(n),
            (None, None) => fallback,
        }
    }

    /// The diaphragm the flags ask for (`None`: the stop's circle); reads the mask image.
    pub fn diaphragm(&self) -> anyhow::Result<Option<Diaphragm>> {
        let blades = self.blades_setting()?;
        let mask = match &self.aperture_image {
            Some(path) => {
                let mask = ApertureMask::load(path).map_err(anyhow::Error::msg)?;
                eprintln!("note: aperture image {}: {}", path.display(), mask.reading);
                if mask.width != mask.height {
                    eprintln!(
                        "warning: --aperture-image {}: {}×{} pixels is not square; it is stretched over the stop's diameter",
                        path.display(),
                        mask.width,
                        mask.height
                    );
                }
                Some(Arc::new(mask))
            }
            None => None,
        };
        let diaphragm = Diaphragm { blades, mask };
        Ok((!diaphragm.is_circular()).then_some(diaphragm))
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

    pub fn validate(&self) -> anyhow::Result<()> {
        self.blades_setting()?;
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
        Ok(())
    }
}
