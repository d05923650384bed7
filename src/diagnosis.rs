//! Why an image came out black: when the film received (almost) no light, the likely cause,
//! read from what the render already counted — camera rays through the lens, camera and
//! bounce rays that escaped to the sky, emitters hit, light samples and their fate (from
//! behind the surface, blocked, arrived) — and from what the scene has to give light.

use glam::Vec3;

use crate::film::Image;
use crate::film::output::{auto_exposure, linear_to_srgb};
use crate::pipeline::{RenderStats, Renderer, SceneEnvironment};
use crate::scene::PunctualLight;
use crate::shade::{Environment, LightSet};

/// A film with fewer lit pixels than this fraction is "almost black".
const ALMOST_BLACK: f64 = 1e-3;

/// What a scene has to give light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneLighting {
    pub punctual_lights: usize,
    pub emissive_triangles: usize,
    /// The environment (sky) gives no light.
    pub environment_black: bool,
}

impl SceneLighting {
    /// The lighting of the renderer's loaded scene.
    pub fn of(renderer: &mut Renderer) -> SceneLighting {
        let punctual_lights = renderer
            .world
            .query::<&PunctualLight>()
            .iter(&renderer.world)
            .count();
        let emissive_triangles = renderer
            .world
            .get_resource::<LightSet>()
            .map_or(0, LightSet::emissive_triangle_count);
        let environment_black = renderer
            .world
            .get_resource::<SceneEnvironment>()
            .is_none_or(|e| matches!(e.0, Environment::Uniform(v) if v == Vec3::ZERO));
        SceneLighting {
            punctual_lights,
            emissive_triangles,
            environment_black,
        }
    }

    fn has_lights(&self) -> bool {
        self.punctual_lights > 0 || self.emissive_triangles > 0
    }
}

/// `part` of `whole` as a percentage that reads 0 % or 100 % only when it is exactly that.
fn percent(part: u64, whole: u64) -> String {
    if whole == 0 || part == 0 {
        return "0 %".into();
    }
    if part >= whole {
        return "100 %".into();
    }
    let p = 100.0 * part as f64 / whole as f64;
    match p {
        p if p < 0.05 => "under 0.1 %".into(),
        p if p >= 99.95 => "over 99.9 %".into(),
        p if !(0.5..99.5).contains(&p) => format!("{p:.1} %"),
        p => format!("{p:.0} %"),
    }
}

/// Pixels of `image` that received any light.
fn lit_pixels(image: &Image) -> usize {
    image
        .sums
        .iter()
        .filter(|s| s.iter().any(|&c| c > 0.0))
        .count()
}

/// The warning for a frame whose film received (almost) no light, with its likely cause;
/// `None` for a frame with light. `stats` are the counters of this frame alone
/// ([`RenderStats::since`]).
pub fn black_image(
    image: &Image,
    stats: &RenderStats,
    lighting: &SceneLighting,
    max_depth: u32,
) -> Option<String> {
    let pixels = image.sums.len();
    let lit = lit_pixels(image);
    if pixels == 0 || lit as f64 >= ALMOST_BLACK * pixels as f64 {
        return None;
    }
    let what = if lit == 0 {
        "the image is black".to_string()
    } else {
        format!("the image is almost black (only {lit} of {pixels} pixels received light)")
    };
    Some(format!("{what}: {}", cause(stats, lighting, max_depth)))
}

/// The likely reason no light reached the film, from the frame's counters.
fn cause(stats: &RenderStats, lighting: &SceneLighting, max_depth: u32) -> String {
    let s = &stats.shading;
    let passed = stats.lens_rays_passed;
    if passed == 0 {
        return "no camera ray passed through the lens (the stop lets no light through, or the film lies outside the lens's image circle: check --aperture, --film-distance and --film-diagonal)".into();
    }
    if !lighting.has_lights() && lighting.environment_black {
        return "the scene has no lights or emitters and the environment is black; light it with --env R,G,B (a sky) or add lights".into();
    }
    let hit = passed.saturating_sub(s.camera_rays_escaped);
    let sky = if lighting.environment_black {
        "the (black) sky"
    } else {
        "the sky"
    };
    if s.camera_rays_escaped == 0
        && s.bounce_rays_escaped == 0
        && s.emitter_hits == 0
        && s.light_samples_reached == 0
    {
        let mut text = format!(
            "no camera path reached a light; {} of camera rays hit geometry and none escaped to {sky} (the camera may be inside a closed model)",
            percent(hit, passed)
        );
        if s.light_samples > 0 {
            text += &format!(
                "; of the light samples, {} were blocked and {} came from behind the surface",
                percent(s.light_samples_blocked, s.light_samples),
                percent(s.light_samples_behind, s.light_samples)
            );
        }
        return text;
    }
    if s.light_samples > 0 && s.light_samples_reached == 0 && s.emitter_hits == 0 {
        let mut text = if s.light_samples_behind >= s.light_samples_blocked {
            format!(
                "the scene's lights do not reach the surfaces in view: {} of light samples came from behind the surface they were to light (the surfaces in view are lit from the back: the camera may be inside a closed model)",
                percent(s.light_samples_behind, s.light_samples)
            )
        } else {
            format!(
                "the scene's lights do not reach the surfaces in view: {} of light samples were blocked by other geometry",
                percent(s.light_samples_blocked, s.light_samples)
            )
        };
        if s.camera_rays_escaped > 0 && lighting.environment_black {
            text += &format!(
                "; {} of camera rays missed the scene and see a black sky",
                percent(s.camera_rays_escaped, passed)
            );
        }
        return text;
    }
    if s.camera_rays_escaped == passed && lighting.environment_black {
        return "every camera ray missed the scene and the sky is black (is the camera looking away from the scene?)".into();
    }
    let mut text = "no camera path carried light back to the film".to_string();
    if max_depth <= 1 {
        text += " (with --max-depth 1 only direct light counts; more bounces may find the light)";
    }
    text
}

/// The warning for an 8-bit picture that comes out all black at exposure `ev` (stops) although
/// the film holds light; `None` otherwise.
pub fn black_picture(image: &Image, ev: f32) -> Option<String> {
    let means = image.mean();
    let brightest = means
        .iter()
        .flat_map(|p| p.iter().copied())
        .fold(0.0f32, f32::max);
    // The means are finite (the Weight stage zeroes the rest): > 0 is a plain comparison.
    if brightest <= 0.0 {
        return None;
    }
    let exposure = 2f32.powf(ev);
    // An 8-bit value rounds to 0 below half a step.
    if linear_to_srgb(brightest * exposure) * 255.0 >= 0.5 {
        return None;
    }
    let automatic = auto_exposure(&means).log2();
    Some(format!(
        "the 8-bit image is black at --exposure {ev}: the film holds light, but its brightest pixel stays below one 8-bit step; the automatic exposure (no --exposure) would be {automatic:+.1} EV"
    ))
}

/// The warning for an 8-bit picture that comes out white at exposure `ev` (stops): nearly
/// every pixel (99 %) clips to 255 in all three channels, so the picture shows nothing of the
/// scene; `None` otherwise.
pub fn white_picture(image: &Image, ev: f32) -> Option<String> {
    let means = image.mean();
    let exposure = 2f32.powf(ev);
    // An 8-bit value rounds to 255 from half a step below it.
    let clips = |c: f32| linear_to_srgb(c * exposure) * 255.0 >= 254.5;
    let clipped = means.iter().filter(|p| p.iter().all(|&c| clips(c))).count();
    if means.is_empty() || (clipped as f64) < 0.99 * means.len() as f64 {
        return None;
    }
    let automatic = auto_exposure(&means).log2();
    Some(format!(
        "the 8-bit image is white at --exposure {ev}: {} of its pixels clip to white; the automatic exposure (no --exposure) would be {automatic:+.1} EV",
        percent(clipped as u64, means.len() as u64)
    ))
}

/// The warning for an 8-bit picture at exposure `ev` (stops) that shows nothing: all black
/// ([`black_picture`]) or all white ([`white_picture`]).
pub fn exposure_warning(image: &Image, ev: f32) -> Option<String> {
    black_picture(image, ev).or_else(|| white_picture(image, ev))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shade::ShadeStats;

    fn image(lit: usize, pixels: usize) -> Image {
        Image {
            width: pixels as u32,
            height: 1,
            sums: (0..pixels)
                .map(|i| if i < lit { [0.5, 0.2, 0.1] } else { [0.0; 3] })
                .collect(),
            samples: 1,
        }
    }

    fn stats(passed: u64, shading: ShadeStats) -> RenderStats {
        RenderStats {
            camera_samples: 1000,
            lens_rays_passed: passed,
            shading,
            ..Default::default()
        }
    }

    const LIT_BY_A_LAMP: SceneLighting = SceneLighting {
        punctual_lights: 1,
        emissive_triangles: 0,
        environment_black: true,
    };

    const UNDER_A_SKY: SceneLighting = SceneLighting {
        punctual_lights: 0,
        emissive_triangles: 0,
        environment_black: false,
    };

    #[test]
    fn images_with_light_get_no_warning() {
        let s = stats(900, ShadeStats::default());
        assert_eq!(black_image(&image(500, 1000), &s, &LIT_BY_A_LAMP, 8), None);
        // One lit pixel in a thousand is enough: a star field is not "black".
        assert_eq!(black_image(&image(1, 1000), &s, &LIT_BY_A_LAMP, 8), None);
    }

    #[test]
    fn an_enclosed_camera_is_named() {
        let shading = ShadeStats {
            light_samples: 0,
            ..Default::default()
        };
        let warning = black_image(&image(0, 4000), &stats(900, shading), &UNDER_A_SKY, 8).unwrap();
        assert_eq!(
            warning,
            "the image is black: no camera path reached a light; 100 % of camera rays hit geometry and none escaped to the sky (the camera may be inside a closed model)"
        );
    }

    #[test]
    fn surfaces_lit_from_behind_are_named() {
        let shading = ShadeStats {
            camera_rays_escaped: 300,
            bounce_rays_escaped: 500,
            light_samples: 600,
            light_samples_behind: 600,
            ..Default::default()
        };
        let warning =
            black_image(&image(0, 4000), &stats(900, shading), &LIT_BY_A_LAMP, 8).unwrap();
        assert!(
            warning.contains("the scene's lights do not reach the surfaces in view")
                && warning.contains("100 % of light samples came from behind")
                && warning.contains("the camera may be inside a closed model")
                && warning.contains("; 33 % of camera rays missed the scene"),
            "{warning}"
        );
        let blocked = ShadeStats {
            light_samples_blocked: 590,
            light_samples_behind: 10,
            ..shading
        };
        let warning =
            black_image(&image(2, 4000), &stats(900, blocked), &LIT_BY_A_LAMP, 8).unwrap();
        assert!(
            warning.starts_with("the image is almost black (only 2 of 4000 pixels")
                && warning.contains("98 % of light samples were blocked"),
            "{warning}"
        );
    }

    #[test]
    fn other_causes_are_named() {
        let none = ShadeStats::default();
        let closed_lens = black_image(&image(0, 10), &stats(0, none), &LIT_BY_A_LAMP, 8).unwrap();
        assert!(closed_lens.contains("no camera ray passed through the lens"));
        let dark = SceneLighting {
            environment_black: true,
            ..UNDER_A_SKY
        };
        let unlit = black_image(&image(0, 10), &stats(900, none), &dark, 8).unwrap();
        assert!(unlit.contains("no lights or emitters and the environment is black"));
        let away = ShadeStats {
            camera_rays_escaped: 900,
            ..none
        };
        let away = black_image(&image(0, 10), &stats(900, away), &LIT_BY_A_LAMP, 8).unwrap();
        assert!(away.contains("every camera ray missed the scene"), "{away}");
    }

    #[test]
    fn percentages_never_round_to_all_or_nothing() {
        assert_eq!(percent(1, 1), "100 %");
        assert_eq!(percent(0, 5), "0 %");
        assert_eq!(percent(9999, 10000), "over 99.9 %");
        assert_eq!(percent(996, 1000), "99.6 %");
        assert_eq!(percent(1, 3), "33 %");
        assert_eq!(percent(4, 1000), "0.4 %");
        assert_eq!(percent(1, 100000), "under 0.1 %");
    }

    #[test]
    fn an_underexposed_picture_is_named() {
        let film = image(10, 10);
        assert_eq!(black_picture(&film, 0.0), None);
        let warning = black_picture(&film, -20.0).unwrap();
        assert!(
            warning.contains("--exposure -20") && warning.contains("automatic exposure"),
            "{warning}"
        );
        assert_eq!(black_picture(&image(0, 10), -20.0), None, "a black film");
        // 0.5 of linear light at +30 EV is 5e8: every channel of every pixel clips.
        let white = exposure_warning(&film, 30.0).unwrap();
        assert!(white.contains("white at --exposure 30"), "{white}");
        assert!(white.contains("100 % of its pixels"), "{white}");
        assert_eq!(exposure_warning(&film, 0.0), None);
        // Half the pixels unlit: the picture is not white.
        assert_eq!(white_picture(&image(5, 10), 30.0), None);
    }
}
