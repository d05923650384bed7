//! The diaphragm at the aperture stop: blades, or a transmission mask (or both).
//!
//! The stop row's circle stays the outer limit; a [`Diaphragm`] (a component on the stop
//! surface's entity) narrows it further where real rays cross the stop, so polygonal bokeh and
//! cat's-eye vignetting by the other elements combine by themselves.
//!
//! # Frame
//! The stop plane of the lens frame (mm, origin on the axis), with the lens frame's x and y:
//! seen from the film looking toward the scene, +x is right and +y up, as in the camera frame.
//! A far background highlight, imaged twice inverted (by the lens and back by the pixel map),
//! shows the diaphragm in the picture as it appears in this view; a foreground one shows it
//! turned by 180°.
//!
//! # Blades
//! N blades form a regular N-gon inscribed in the stop's circle (radius R), a vertex at angle
//! θ₀ (the rotation; 0 puts one at +x). Blade k's edge faces the outward normal n_k at angle
//! θ₀ + (2k + 1)π/N; its chord lies at a = R cos(π/N) from the axis, half as long as
//! h = R sin(π/N). A curved blade's edge is the arc through the same two vertices with sagitta
//! s = C · R (1 − cos(π/N)): C times the stop circle's own sagitta over that chord (C = 0
//! straight, C = 1 the circle itself). The arc's apex lies at m = a + s and its radius is
//! ρ = (h² + s²)/(2s), centred at (m − ρ) n_k, so a point p is on the open side when
//! |p − (m − ρ)n_k|² ≤ ρ², which rearranges (without the cancellation of two huge terms as
//! ρ → ∞) to
//!
//! ```text
//!     p·n_k + κ |p − m n_k|² ≤ m,      κ = 1/(2ρ) = s/(h² + s²)
//! ```
//!
//! (κ = 0 is the straight edge p·n_k ≤ a). The opening is the intersection over k.
//!
//! # Mask
//! A grey-level image spans the stop's diameter, centred on the axis (as pbrt-v4's aperture
//! images): its top row at y = +R, its left column at x = −R; each grey level (value / maximum,
//! read as linear transmission: 0 opaque, 1 open) multiplies the light of rays crossing there,
//! bilinearly interpolated between pixel centres. A colour image counts by the Rec. 709
//! luminance of its channels (each value / maximum, read linearly as the grey levels are), and
//! an alpha channel multiplies in: a transparent pixel is opaque to light, as a mask painted in
//! an image editor means it.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use std::f64::consts::PI;

use crate::film::output::luminance;

/// Most blades accepted: beyond this the polygon differs from its circle by less than 0.01 %
/// of the area, and every ray would pay for each blade.
pub const MAX_BLADES: u32 = 64;

/// Largest mask side, pixels (a 4096² mask is 64 MiB of f32).
pub const MAX_MASK_SIDE: u32 = 4096;

/// The shape of the opening at the stop: a component on the stop surface's entity (see
/// [`super::elements`]). Without one the stop is its row's circle.
#[derive(bevy_ecs::component::Component, Clone, Debug, PartialEq, Default)]
pub struct Diaphragm {
    pub blades: Option<Blades>,
    pub mask: Option<Arc<ApertureMask>>,
}

impl Diaphragm {
    /// True when the diaphragm narrows nothing (no blades, no mask).
    pub fn is_circular(&self) -> bool {
        self.blades.is_none() && self.mask.is_none()
    }

    /// What it is, in words, for reports and notes.
    pub fn describe(&self) -> String {
        let blades = self.blades.map(|b| b.describe());
        let mask = self
            .mask
            .as_ref()
            .map(|m| format!("aperture image {}", m.source.display()));
        match (blades, mask) {
            (Some(b), Some(m)) => format!("{b} and {m}"),
            (Some(b), None) => b,
            (None, Some(m)) => m,
            (None, None) => "circular stop".into(),
        }
    }

    /// The opening's area as a fraction of the stop circle's: exact for blades alone, the
    /// mask's transmission integrated over a 1024 × 1024 grid otherwise.
    pub fn open_fraction(&self) -> f64 {
        if self.mask.is_none() {
            return self.blades.map_or(1.0, |b| b.open_fraction());
        }
        let clip = StopClip::new(self, 0, 1.0);
        const GRID: usize = 1024;
        let cell = 2.0 / GRID as f64;
        let mut sum = 0.0;
        for iy in 0..GRID {
            let y = -1.0 + (iy as f64 + 0.5) * cell;
            for ix in 0..GRID {
                let x = -1.0 + (ix as f64 + 0.5) * cell;
                if x * x + y * y <= 1.0 {
                    sum += clip.transmission(x, y);
                }
            }
        }
        sum * cell * cell / PI
    }

    /// Values for a render's settings fingerprint: the blades, and the mask's size and a hash
    /// of its values (not its path: the same picture under another name is the same stop).
    pub fn fingerprint(&self) -> serde_json::Value {
        serde_json::json!({
            "blades": self.blades.map(|b| serde_json::json!({
                "count": b.count,
                "rotation_deg": b.rotation_deg,
                "curvature": b.curvature,
            })),
            "mask": self.mask.as_ref().map(|m| serde_json::json!({
                "width": m.width,
                "height": m.height,
                "hash": format!("{:016x}", m.content_hash()),
            })),
        })
    }
}

/// A bladed diaphragm (see the module docs for the shape).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blades {
    pub count: u32,
    /// Angle of a vertex from +x, degrees, counter-clockwise seen from the film.
    pub rotation_deg: f64,
    /// 0 = straight blades … 1 = the stop's circle.
    pub curvature: f64,
}

impl Blades {
    /// Checks the values: at least 3 blades (at most [`MAX_BLADES`]), a finite rotation, a
    /// curvature in 0..=1.
    pub fn new(count: u32, rotation_deg: f64, curvature: f64) -> Result<Blades, String> {
        if count < 3 {
            return Err(format!(
                "--blades {count}: a diaphragm needs at least 3 blades"
            ));
        }
        if count > MAX_BLADES {
            return Err(format!(
                "--blades {count}: at most {MAX_BLADES} blades (beyond that the opening is a circle to 0.01 %: leave --blades out)"
            ));
        }
        if !rotation_deg.is_finite() {
            return Err(format!(
                "--blade-rotation {rotation_deg} must be a finite number of degrees"
            ));
        }
        if !(curvature.is_finite() && (0.0..=1.0).contains(&curvature)) {
            return Err(format!(
                "--blade-curvature {curvature} must be between 0 (straight blades) and 1 (a circle)"
            ));
        }
        Ok(Blades {
            count,
            rotation_deg,
            curvature,
        })
    }

    pub fn describe(&self) -> String {
        let mut text = format!("{} blades", self.count);
        if self.curvature > 0.0 {
            text += &format!(" (curvature {})", self.curvature);
        }
        if self.rotation_deg != 0.0 {
            text += &format!(" turned {}°", self.rotation_deg);
        }
        text
    }

    /// The edges' geometry at stop radius `radius`: apex distance m and κ (module docs).
    fn edge(&self, radius: f64) -> (f64, f64) {
        let half_angle = PI / self.count as f64;
        let a = radius * half_angle.cos();
        let h = radius * half_angle.sin();
        let s = self.curvature * (radius - a);
        (a + s, s / (h * h + s * s))
    }

    /// Outward edge normals (cos, sin).
    fn normals(&self) -> Vec<[f64; 2]> {
        let n = self.count as f64;
        (0..self.count)
            .map(|k| {
                let angle = self.rotation_deg.to_radians() + (2.0 * k as f64 + 1.0) * PI / n;
                [angle.cos(), angle.sin()]
            })
            .collect()
    }

    /// The opening's area over the circle's: N triangles (origin and two neighbouring
    /// vertices) of ½R² sin(2π/N) each, plus N circular segments between chord and arc,
    /// ρ²(α − sin α cos α) with sin α = h/ρ.
    pub fn open_fraction(&self) -> f64 {
        let n = self.count as f64;
        let polygon = n / 2.0 * (2.0 * PI / n).sin();
        let (_, kappa) = self.edge(1.0);
        let segment = if kappa == 0.0 {
            0.0
        } else {
            let rho = 1.0 / (2.0 * kappa);
            let h = (PI / n).sin();
            let alpha = (h / rho).min(1.0).asin();
            // For a nearly straight blade α − sin α cos α = α − ½ sin 2α loses everything to
            // cancellation: its series, 2α³/3 − 2α⁵/15 + 4α⁷/315, is exact to f64 there.
            let lens_term = if alpha < 1e-2 {
                let a2 = alpha * alpha;
                alpha * a2 * (2.0 / 3.0 - a2 * (2.0 / 15.0 - a2 * 4.0 / 315.0))
            } else {
                alpha - alpha.sin() * alpha.cos()
            };
            rho * rho * lens_term
        };
        (polygon + n * segment) / PI
    }
}

/// Values this far outside 0..=1 are rounding (a white pixel's luminance weights summing to
/// 1 + 1 ulp in f32), clamped rather than refused.
const ROUNDING: f32 = 4.0 * f32::EPSILON;

/// A transmission mask: grey levels in 0..=1, row-major, row 0 at the top (+y).
#[derive(Clone, Debug, PartialEq)]
pub struct ApertureMask {
    pub source: PathBuf,
    pub width: u32,
    pub height: u32,
    pub values: Vec<f32>,
    /// How the image's pixels became transmissions, for the note that says what was read
    /// ("64×64 8-bit RGBA: Rec. 709 luminance × alpha").
    pub reading: String,
}

impl ApertureMask {
    /// Reads a mask image (PNG or any format realcam reads), refusing what cannot serve.
    pub fn load(path: &Path) -> Result<ApertureMask, String> {
        let shown = path.display();
        let reader = image::ImageReader::open(path)
            .map_err(|e| format!("--aperture-image {shown}: cannot read it: {e}"))?
            .with_guessed_format()
            .map_err(|e| format!("--aperture-image {shown}: cannot read it: {e}"))?;
        let (width, height) = reader
            .into_dimensions()
            .map_err(|e| format!("--aperture-image {shown}: not an image realcam reads: {e}"))?;
        if width > MAX_MASK_SIDE || height > MAX_MASK_SIDE {
            return Err(format!(
                "--aperture-image {shown}: {width}×{height} pixels is larger than {MAX_MASK_SIDE}×{MAX_MASK_SIDE}; a mask needs far fewer"
            ));
        }
        let image = image::ImageReader::open(path)
            .and_then(|r| r.with_guessed_format())
            .map_err(|e| format!("--aperture-image {shown}: cannot read it: {e}"))?
            .decode()
            .map_err(|e| format!("--aperture-image {shown}: not an image realcam reads: {e}"))?;
        let (values, reading) = transmission(&image);
        let mut mask = ApertureMask::from_values(path, width, height, values)?;
        mask.reading = format!("{width}×{height} {reading}");
        Ok(mask)
    }

    /// A mask from grey levels (row-major, top row first), refusing sizes that do not match,
    /// values outside 0..=1 (beyond the last rounding ulps, which are clamped) and masks that
    /// let no light through.
    pub fn from_values(
        source: &Path,
        width: u32,
        height: u32,
        mut values: Vec<f32>,
    ) -> Result<ApertureMask, String> {
        let shown = source.display();
        if width == 0 || height == 0 || values.len() != width as usize * height as usize {
            return Err(format!(
                "--aperture-image {shown}: {width}×{height} pixels with {} values is not an image",
                values.len()
            ));
        }
        if let Some(bad) = values
            .iter()
            .find(|v| !(v.is_finite() && (-ROUNDING..=1.0 + ROUNDING).contains(*v)))
        {
            return Err(format!(
                "--aperture-image {shown}: grey level {bad} is outside 0 (opaque) … 1 (open)"
            ));
        }
        for value in &mut values {
            *value = value.clamp(0.0, 1.0);
        }
        let mask = ApertureMask {
            source: source.to_path_buf(),
            width,
            height,
            values,
            reading: format!("{width}×{height} grey levels"),
        };
        let open = Diaphragm {
            blades: None,
            mask: Some(Arc::new(mask.clone())),
        }
        .open_fraction();
        if open <= 0.0 {
            return Err(format!(
                "--aperture-image {shown}: lets no light through the stop's circle (it is black there)"
            ));
        }
        Ok(mask)
    }

    /// Bilinear transmission at image coordinates (`u`, `v`) in pixels (0 at the left and top
    /// edges), edge pixels extended outward.
    fn sample(&self, u: f64, v: f64) -> f64 {
        let (w, h) = (self.width as usize, self.height as usize);
        let fx = (u - 0.5).clamp(0.0, (w - 1) as f64);
        let fy = (v - 0.5).clamp(0.0, (h - 1) as f64);
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
        let (tx, ty) = (fx - x0 as f64, fy - y0 as f64);
        let at = |x: usize, y: usize| self.values[y * w + x] as f64;
        let top = at(x0, y0) + (at(x1, y0) - at(x0, y0)) * tx;
        let bottom = at(x0, y1) + (at(x1, y1) - at(x0, y1)) * tx;
        top + (bottom - top) * ty
    }

    /// `Self::sample` in f32, for the batch kernels.
    pub fn sample_f32(&self, u: f32, v: f32) -> f32 {
        let (w, h) = (self.width as usize, self.height as usize);
        let fx = (u - 0.5).clamp(0.0, (w - 1) as f32);
        let fy = (v - 0.5).clamp(0.0, (h - 1) as f32);
        let (x0, y0) = (fx as usize, fy as usize);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
        let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
        let at = |x: usize, y: usize| self.values[y * w + x];
        let top = at(x0, y0) + (at(x1, y0) - at(x0, y0)) * tx;
        let bottom = at(x0, y1) + (at(x1, y1) - at(x0, y1)) * tx;
        top + (bottom - top) * ty
    }

    /// FNV-1a over the size and the values' bits.
    pub fn content_hash(&self) -> u64 {
        let mut hash = 0xcbf2_9ce4_8422_2325u64;
        let words = [self.width, self.height]
            .into_iter()
            .chain(self.values.iter().map(|v| v.to_bits()));
        for word in words {
            for byte in word.to_le_bytes() {
                hash ^= byte as u64;
                hash = hash.wrapping_mul(0x0100_0000_01b3);
            }
        }
        hash
    }
}

/// An image's pixels as transmissions (module docs: grey levels as they are, colour by its
/// Rec. 709 luminance, alpha multiplied in), and how they were read, in words.
fn transmission(image: &image::DynamicImage) -> (Vec<f32>, String) {
    let colour = image.color();
    let (has_colour, has_alpha) = (colour.has_color(), colour.has_alpha());
    let opacity = |level: f32, alpha: f32| if has_alpha { level * alpha } else { level };
    let values = if has_colour {
        let rgba = image.to_rgba32f();
        rgba.pixels()
            .map(|&image::Rgba([r, g, b, alpha])| opacity(luminance([r, g, b]), alpha))
            .collect()
    } else {
        // A grey image's levels as they are, with no weights to round.
        let grey = image.to_luma_alpha32f();
        grey.pixels()
            .map(|&image::LumaA([level, alpha])| opacity(level, alpha))
            .collect()
    };
    let bits = colour.bits_per_pixel() / u16::from(colour.channel_count());
    let float = if matches!(colour, image::ColorType::Rgb32F | image::ColorType::Rgba32F) {
        " float"
    } else {
        ""
    };
    let reading = match (has_colour, has_alpha) {
        (false, false) => "grey levels",
        (false, true) => "grey + alpha: grey level × alpha",
        (true, false) => "RGB: Rec. 709 luminance",
        (true, true) => "RGBA: Rec. 709 luminance × alpha",
    };
    (values, format!("{bits}-bit{float} {reading}"))
}

/// A diaphragm packed for tracing at one stop radius: what the per-ray reference
/// ([`super::trace`], f64) and the batch kernels ([`super::trace_batch`], f32) test where a
/// ray crosses the stop surface.
#[derive(Clone, Debug, PartialEq)]
pub struct StopClip {
    /// Row index of the stop surface.
    pub surface: usize,
    /// The stop's semi-aperture, mm.
    pub radius: f64,
    /// Blade edges: outward normals and (m, κ) of the module docs; empty without blades.
    pub normals: Vec<[f64; 2]>,
    pub apex: f64,
    pub kappa: f64,
    pub normals_f32: Vec<[f32; 2]>,
    pub apex_f32: f32,
    pub kappa_f32: f32,
    pub mask: Option<Arc<ApertureMask>>,
    /// Mask pixels per mm across x and y (mask width / 2R, height / 2R).
    pub mask_scale: [f64; 2],
    pub mask_scale_f32: [f32; 2],
}

impl StopClip {
    /// `diaphragm` at the stop surface `surface` of semi-aperture `radius` (mm).
    pub fn new(diaphragm: &Diaphragm, surface: usize, radius: f64) -> StopClip {
        let (normals, apex, kappa) = match diaphragm.blades {
            Some(blades) => {
                let (m, kappa) = blades.edge(radius);
                (blades.normals(), m, kappa)
            }
            None => (Vec::new(), radius, 0.0),
        };
        let mask_scale = diaphragm.mask.as_ref().map_or([0.0; 2], |m| {
            [
                m.width as f64 / (2.0 * radius),
                m.height as f64 / (2.0 * radius),
            ]
        });
        StopClip {
            surface,
            radius,
            normals_f32: normals.iter().map(|n| n.map(|v| v as f32)).collect(),
            normals,
            apex,
            kappa,
            apex_f32: apex as f32,
            kappa_f32: kappa as f32,
            mask: diaphragm.mask.clone(),
            mask_scale,
            mask_scale_f32: mask_scale.map(|v| v as f32),
        }
    }

    /// True when some point inside the stop's circle lets only part of the light through (the
    /// batch kernels then carry a throughput per ray).
    pub fn has_mask(&self) -> bool {
        self.mask.is_some()
    }

    /// The light passed at stop-plane point (`x`, `y`) mm inside the stop's circle: 0 behind a
    /// blade, else the mask's grey level there (1 without a mask). The f64 reference.
    pub fn transmission(&self, x: f64, y: f64) -> f64 {
        for n in &self.normals {
            let along = x * n[0] + y * n[1];
            let (ex, ey) = (x - self.apex * n[0], y - self.apex * n[1]);
            if along + self.kappa * (ex * ex + ey * ey) > self.apex {
                return 0.0;
            }
        }
        match &self.mask {
            None => 1.0,
            Some(mask) => mask.sample(
                (x + self.radius) * self.mask_scale[0],
                (self.radius - y) * self.mask_scale[1],
            ),
        }
    }

    /// The mask's grey level at (`x`, `y`) in f32 (1 without a mask): the kernels' lookup.
    #[inline(always)]
    pub fn mask_transmission_f32(&self, x: f32, y: f32) -> f32 {
        match &self.mask {
            None => 1.0,
            Some(mask) => {
                let radius = self.radius as f32;
                mask.sample_f32(
                    (x + radius) * self.mask_scale_f32[0],
                    (radius - y) * self.mask_scale_f32[1],
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Monte-Carlo-free check of the analytic area: the fraction of a fine grid inside the
    /// clip, for straight and curved blades of several counts.
    #[test]
    fn open_fraction_matches_the_area_counted_on_a_grid() {
        for (count, curvature) in [(3, 0.0), (5, 0.0), (6, 0.0), (6, 0.5), (9, 0.3), (4, 1.0)] {
            let blades = Blades::new(count, 17.0, curvature).unwrap();
            let clip = StopClip::new(
                &Diaphragm {
                    blades: Some(blades),
                    mask: None,
                },
                0,
                1.0,
            );
            const GRID: usize = 2000;
            let cell = 2.0 / GRID as f64;
            let mut inside = 0usize;
            for iy in 0..GRID {
                for ix in 0..GRID {
                    let (x, y) = (
                        -1.0 + (ix as f64 + 0.5) * cell,
                        -1.0 + (iy as f64 + 0.5) * cell,
                    );
                    if x * x + y * y <= 1.0 && clip.transmission(x, y) > 0.0 {
                        inside += 1;
                    }
                }
            }
            let counted = inside as f64 * cell * cell / PI;
            let exact = blades.open_fraction();
            assert!(
                (counted - exact).abs() < 2e-3,
                "{count} blades, curvature {curvature}: grid {counted} vs {exact}"
            );
        }
        // Independent closed forms: the regular hexagon 3√3/(2π), the square 2/π, the circle 1.
        let hexagon = Blades::new(6, 0.0, 0.0).unwrap().open_fraction();
        assert!((hexagon - 3.0 * 3f64.sqrt() / (2.0 * PI)).abs() < 1e-12);
        let square = Blades::new(4, 0.0, 0.0).unwrap().open_fraction();
        assert!((square - 2.0 / PI).abs() < 1e-12);
        let round = Blades::new(5, 0.0, 1.0).unwrap().open_fraction();
        assert!((round - 1.0).abs() < 1e-12, "{round}");
        let nearly_straight = Blades::new(6, 0.0, 1e-9).unwrap().open_fraction();
        assert!((nearly_straight - hexagon).abs() < 1e-9);
    }

    #[test]
    fn vertices_sit_on_the_circle_at_the_rotation() {
        // Rotation 0: a vertex at +x (just inside passes, just outside along +x is cut by
        // nothing but the circle), and the middle of an edge at angle π/N is at R cos(π/N).
        let clip = StopClip::new(
            &Diaphragm {
                blades: Some(Blades::new(6, 0.0, 0.0).unwrap()),
                mask: None,
            },
            0,
            2.0,
        );
        assert_eq!(clip.transmission(1.999, 0.0), 1.0);
        let a = 2.0 * (PI / 6.0).cos();
        let (c, s) = ((PI / 6.0).cos(), (PI / 6.0).sin());
        assert_eq!(clip.transmission((a - 1e-6) * c, (a - 1e-6) * s), 1.0);
        assert_eq!(clip.transmission((a + 1e-6) * c, (a + 1e-6) * s), 0.0);
    }

    #[test]
    fn bad_values_are_refused_with_the_option_named() {
        assert!(Blades::new(2, 0.0, 0.0).unwrap_err().contains("at least 3"));
        assert!(
            Blades::new(6, 0.0, 1.5)
                .unwrap_err()
                .contains("--blade-curvature")
        );
        assert!(
            Blades::new(6, 0.0, -0.1)
                .unwrap_err()
                .contains("--blade-curvature")
        );
        assert!(
            Blades::new(6, f64::NAN, 0.0)
                .unwrap_err()
                .contains("--blade-rotation")
        );
        let black = ApertureMask::from_values(Path::new("black.png"), 2, 2, vec![0.0; 4]);
        assert!(black.unwrap_err().contains("no light"));
        let missing = ApertureMask::load(Path::new("/nonexistent/mask.png"));
        assert!(missing.unwrap_err().contains("/nonexistent/mask.png"));
    }

    /// Rec. 709 luminance of 8-bit channels read linearly (value / 255), the test's own.
    fn rec709(rgb: [u8; 3]) -> f64 {
        let [r, g, b] = rgb.map(|v| v as f64 / 255.0);
        0.2126 * r + 0.7152 * g + 0.0722 * b
    }

    /// RGB and RGBA PNGs (as image editors save masks) read as the luminance of their colour
    /// times their alpha; grey PNGs as their grey levels; white is fully open, not refused by
    /// the last rounding ulp of the luminance weights; the note says what was read.
    #[test]
    fn colour_and_alpha_masks_read_as_luminance_times_alpha() {
        let dir = tempfile::tempdir().unwrap();
        let colours = [
            [255, 255, 255],
            [255, 0, 0],
            [0, 255, 0],
            [0, 0, 255],
            [200, 100, 50],
        ];
        let alphas = [255u8, 128, 0, 64, 200];
        let rgb = image::RgbImage::from_fn(5, 1, |x, _| image::Rgb(colours[x as usize]));
        let rgba = image::RgbaImage::from_fn(5, 1, |x, _| {
            let [r, g, b] = colours[x as usize];
            image::Rgba([r, g, b, alphas[x as usize]])
        });
        let grey = image::GrayImage::from_fn(5, 1, |x, _| image::Luma([alphas[x as usize]]));
        for (name, image) in [
            ("rgb.png", image::DynamicImage::from(rgb)),
            ("rgba.png", rgba.into()),
            ("grey.png", grey.into()),
        ] {
            image.save(dir.path().join(name)).unwrap();
        }
        let read = |name: &str| ApertureMask::load(&dir.path().join(name)).unwrap();

        let mask = read("rgb.png");
        for (x, colour) in colours.into_iter().enumerate() {
            let expected = rec709(colour);
            assert!(
                (mask.values[x] as f64 - expected).abs() < 1e-6,
                "{x}: {mask:?}"
            );
        }
        assert_eq!(mask.values[0], 1.0, "white is open");
        assert_eq!(mask.reading, "5×1 8-bit RGB: Rec. 709 luminance");

        let mask = read("rgba.png");
        for x in 0..5 {
            let expected = rec709(colours[x]) * alphas[x] as f64 / 255.0;
            assert!(
                (mask.values[x] as f64 - expected).abs() < 1e-6,
                "{x}: {mask:?}"
            );
        }
        assert_eq!(mask.reading, "5×1 8-bit RGBA: Rec. 709 luminance × alpha");

        let mask = read("grey.png");
        for (x, alpha) in alphas.into_iter().enumerate() {
            let expected = alpha as f64 / 255.0;
            assert!(
                (mask.values[x] as f64 - expected).abs() < 1e-7,
                "{x}: {mask:?}"
            );
        }
        assert_eq!(mask.reading, "5×1 8-bit grey levels");

        // An all-white RGB mask is the stop's circle: all of its area open (to the 1024²
        // grid's count of the circle's area), every point of it passing all the light.
        let white = image::RgbImage::from_pixel(16, 16, image::Rgb([255; 3]));
        white.save(dir.path().join("white_rgb.png")).unwrap();
        let white = Diaphragm {
            blades: None,
            mask: Some(Arc::new(read("white_rgb.png"))),
        };
        let open = white.open_fraction();
        assert!((open - 1.0).abs() < 1e-3, "{open}");
        let clip = StopClip::new(&white, 0, 1.0);
        for (x, y) in [(0.0, 0.0), (0.7, -0.2), (-0.3, 0.9)] {
            assert_eq!(clip.transmission(x, y), 1.0);
        }
    }

    /// Only the rounding ulps beyond 0 … 1 are clamped; a real excess is still refused.
    #[test]
    fn levels_beyond_rounding_are_refused() {
        let ulp_over = 1.0 + f32::EPSILON;
        let mask = ApertureMask::from_values(Path::new("m"), 1, 1, vec![ulp_over]).unwrap();
        assert_eq!(mask.values, [1.0]);
        let over = ApertureMask::from_values(Path::new("m"), 1, 1, vec![1.01]);
        assert!(over.unwrap_err().contains("outside 0"));
    }

    /// A mask's top row is +y, its left column −x; grey levels pass as linear transmission.
    #[test]
    fn mask_orientation_and_levels() {
        // 2×2: top-left 1, top-right 0.5, bottom row 0.
        let mask =
            ApertureMask::from_values(Path::new("m"), 2, 2, vec![1.0, 0.5, 0.0, 0.0]).unwrap();
        let clip = StopClip::new(
            &Diaphragm {
                blades: None,
                mask: Some(Arc::new(mask)),
            },
            0,
            1.0,
        );
        assert_eq!(clip.transmission(-0.5, 0.5), 1.0);
        assert_eq!(clip.transmission(0.5, 0.5), 0.5);
        assert_eq!(clip.transmission(0.0, -0.5), 0.0);
        assert_eq!(clip.mask_transmission_f32(0.5, 0.5), 0.5);
    }
}
