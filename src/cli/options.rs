//! Lens options shared by `realcam render` and `realcam lens`.

use clap::Args;

use super::values::number;

use crate::lens::LensFormat;
use crate::lens::aperture::ApertureSetting;
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

    pub fn validate(&self) -> anyhow::Result<()> {
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
