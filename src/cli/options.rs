//! Lens options shared by `realcam render` and `realcam lens`: the command line's form of
//! [`LensSettings`].

use std::path::PathBuf;

use clap::Args;

use super::values::{number, whole, whole_within};

use crate::lens::LensFormat;
use crate::lens::coating::CoatingModel;
use crate::lens::focus::FocusMode;
use crate::lens::io::GlassSubstitute;
use crate::lens::pupil::PupilSampling;
use crate::lens::settings::LensSettings;

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
    /// Read a Zemax file's glass NAME as GLASS: a catalogue glass (S-TIM28, ohara:S-TIM28) or
    /// a model glass N_D,V_D; the way round a glass realcam's catalogue lacks. Repeat it for
    /// several glasses.
    #[arg(long, value_name = "NAME=GLASS", allow_hyphen_values = true)]
    pub glass: Vec<GlassSubstitute>,
    /// A zoom lens's zoom position N, 1-based as Zemax numbers its configurations
    /// [default: the lens as its surfaces are written].
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = whole_within::<usize>(1, MAX_ZOOM_POSITIONS))]
    pub zoom_position: Option<usize>,
    /// A zoom lens at the position of this focal length, mm (one of its design's positions:
    /// within 2 % of its paraxial focal length, or its published one).
    #[arg(long = "zoom", value_name = "FOCAL_MM", allow_hyphen_values = true, conflicts_with = "zoom_position", value_parser = number::<f64>)]
    pub zoom_focal_length: Option<f64>,
    /// Coat every surface so, whatever the lens file says: `none` (bare glass: Fresnel's
    /// losses), `single` (a quarter wave of MgF₂ at 550 nm on the air–glass surfaces, cemented
    /// ones bare), `multi` (a broadband three-layer stack, likewise) or `ideal` (a perfect
    /// anti-reflection coating: no losses) [default: as the lens file says; `single` on the
    /// surfaces it says nothing of].
    #[arg(long, value_name = "none|single|multi|ideal")]
    pub coating: Option<CoatingModel>,
}

/// The most zoom positions `--zoom-position` counts to (Zemax's configurations are far fewer).
const MAX_ZOOM_POSITIONS: i128 = 1000;

impl LensOptions {
    /// The settings these options give.
    pub fn settings(&self) -> LensSettings {
        let LensOptions {
            focus_distance,
            focus_mode,
            film_distance,
            aperture,
            f_number,
            film_diagonal,
            lens_format,
            pupil_sampling,
            blades,
            blade_rotation,
            blade_curvature,
            aperture_image,
            glass,
            zoom_position,
            zoom_focal_length,
            coating,
        } = self.clone();
        LensSettings {
            focus_distance,
            focus_mode,
            film_distance,
            aperture,
            f_number,
            film_diagonal,
            lens_format,
            pupil_sampling,
            blades,
            blade_rotation,
            blade_curvature,
            aperture_image,
            glasses: glass,
            zoom_position,
            zoom_focal_length,
            coating,
        }
    }
}
