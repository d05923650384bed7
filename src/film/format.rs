//! Image formats: an output's format follows its name's extension, and each format gets the
//! pixels it is made for — 8-bit formats the tone-mapped sRGB picture, float formats the
//! linear film.
//!
//! EXR blocks are written in increasing line order whatever the thread count, so the same
//! render always gives the same bytes (the exr crate otherwise writes blocks as its threads
//! finish them).

use std::io::Cursor;
use std::path::Path;

use anyhow::{Context, bail};
use exr::meta::attribute::Text;
use exr::prelude::{
    Encoding, Image as ExrImage, Layer, LayerAttributes, SpecificChannels, WritableImage,
};
use image::{ImageEncoder, RgbImage};

use super::Image;
use super::output::{is_stdout, is_stream, to_srgb8};

/// EXR encoding of every EXR realcam writes (images, checkpoints, partials): lossless ZIP
/// over 16 scan lines, blocks in increasing line order (so in a fixed order in the file).
pub const EXR_ENCODING: Encoding = Encoding::SMALL_LOSSLESS;

/// JPEG quality when `--quality` is not given.
pub const DEFAULT_JPEG_QUALITY: u8 = 90;

/// A format realcam writes images in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    Png,
    Jpeg,
    Tiff,
    Exr,
    Hdr,
}

/// Which formats an output accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Accepts {
    /// Any: 8-bit tone-mapped or float linear, as the name says.
    Any,
    /// 8-bit pictures only (e.g. a captioned contact sheet).
    EightBit,
    /// Linear float only (e.g. `--exr`, the un-tonemapped film).
    Float,
}

/// How the 8-bit formats turn linear film into pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tone {
    /// Linear scale before the sRGB curve: 2^EV.
    pub exposure: f32,
    /// JPEG quality, 1–100.
    pub quality: u8,
}

impl Tone {
    pub fn exposure(exposure: f32) -> Tone {
        Tone {
            exposure,
            quality: DEFAULT_JPEG_QUALITY,
        }
    }
}

impl ImageFormat {
    pub const ALL: [ImageFormat; 5] = [
        ImageFormat::Png,
        ImageFormat::Jpeg,
        ImageFormat::Tiff,
        ImageFormat::Exr,
        ImageFormat::Hdr,
    ];

    /// File name extensions, lower case, the usual one first.
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            ImageFormat::Png => &["png"],
            ImageFormat::Jpeg => &["jpg", "jpeg"],
            ImageFormat::Tiff => &["tif", "tiff"],
            ImageFormat::Exr => &["exr"],
            ImageFormat::Hdr => &["hdr"],
        }
    }

    /// Linear float pixels (true) or 8-bit tone-mapped sRGB (false).
    pub fn is_float(self) -> bool {
        matches!(self, ImageFormat::Exr | ImageFormat::Hdr)
    }

    pub fn name(self) -> &'static str {
        match self {
            ImageFormat::Png => "PNG",
            ImageFormat::Jpeg => "JPEG",
            ImageFormat::Tiff => "TIFF",
            ImageFormat::Exr => "OpenEXR",
            ImageFormat::Hdr => "Radiance HDR",
        }
    }

    /// The format a file name's extension names (any case), if realcam writes it.
    pub fn from_path(path: &Path) -> Option<ImageFormat> {
        let extension = path.extension()?.to_str()?.to_ascii_lowercase();
        ImageFormat::ALL
            .into_iter()
            .find(|f| f.extensions().contains(&extension.as_str()))
    }

    fn accepted_by(self, accepts: Accepts) -> bool {
        match accepts {
            Accepts::Any => true,
            Accepts::EightBit => !self.is_float(),
            Accepts::Float => self.is_float(),
        }
    }
}

/// `.png, .jpg/.jpeg, …` for the formats `accepts` allows, with what each kind holds.
pub fn supported(accepts: Accepts) -> String {
    let list = |float: bool| {
        ImageFormat::ALL
            .into_iter()
            .filter(|f| f.is_float() == float && f.accepted_by(accepts))
            .map(|f| {
                f.extensions()
                    .iter()
                    .map(|e| format!(".{e}"))
                    .collect::<Vec<_>>()
                    .join("/")
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    match accepts {
        Accepts::Any => format!(
            "{} (8-bit sRGB, tone-mapped) or {} (linear float)",
            list(false),
            list(true)
        ),
        Accepts::EightBit => format!("{} (8-bit sRGB, tone-mapped)", list(false)),
        Accepts::Float => format!("{} (linear float)", list(true)),
    }
}

/// The format the output `option` (e.g. `--out`) writes to `path`, from its extension;
/// standard output (`-`) and a FIFO or device named without one (`/dev/stdout`) get PNG, or
/// EXR for a float-only option. Refuses an unknown or missing extension, and a format of the
/// wrong kind, listing what the option writes.
pub fn output_format(option: &str, path: &Path, accepts: Accepts) -> anyhow::Result<ImageFormat> {
    if is_stdout(path) || (path.extension().is_none() && is_stream(path)) {
        return Ok(match accepts {
            Accepts::Float => ImageFormat::Exr,
            _ => ImageFormat::Png,
        });
    }
    let shown = path.display();
    let Some(format) = ImageFormat::from_path(path) else {
        match path.extension() {
            Some(extension) => bail!(
                "{option} {shown}: '.{}' is not an image format realcam writes; {option} writes {}",
                extension.to_string_lossy(),
                supported(accepts)
            ),
            None => bail!(
                "{option} {shown}: the name has no extension to choose the image format by; {option} writes {}",
                supported(accepts)
            ),
        }
    };
    if !format.accepted_by(accepts) {
        let (kind, wanted) = if format.is_float() {
            ("a linear float format", "an 8-bit picture")
        } else {
            ("an 8-bit format", "the linear float film")
        };
        bail!(
            "{option} {shown}: {} is {kind}, but {option} writes {wanted}; name it {}",
            format.name(),
            supported(accepts)
        );
    }
    Ok(format)
}

/// Refuses a name whose extension is not `extension` (any case), for outputs of one fixed
/// format: checkpoints and partials (.exr), statistics (.json). A FIFO or device named
/// without an extension takes the format as it is.
pub fn require_extension(
    option: &str,
    path: &Path,
    extension: &str,
    what: &str,
) -> anyhow::Result<()> {
    let named = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(extension));
    let unnamed_stream = path.extension().is_none() && is_stream(path);
    if !(named || unnamed_stream) {
        bail!(
            "{option} {}: {option} writes {what}; name the file .{extension}",
            path.display()
        );
    }
    Ok(())
}

/// Refuses tone options that no output would use: `--quality` without a JPEG output,
/// `--exposure` without an 8-bit one. `outputs` are the run's image outputs and formats.
pub fn check_tone_options(
    outputs: &[(&str, &Path, ImageFormat)],
    exposure_given: bool,
    quality_given: bool,
) -> anyhow::Result<()> {
    let listed = || {
        outputs
            .iter()
            .map(|(option, path, _)| format!("{option} {}", path.display()))
            .collect::<Vec<_>>()
            .join(", ")
    };
    if quality_given && !outputs.iter().any(|o| o.2 == ImageFormat::Jpeg) {
        bail!(
            "--quality sets the JPEG quality, but no output is a JPEG ({}); name an output .jpg or drop --quality",
            listed()
        );
    }
    if exposure_given && outputs.iter().all(|o| o.2.is_float()) {
        bail!(
            "--exposure tone-maps 8-bit outputs, but every output is linear float ({}); float images keep the film's values",
            listed()
        );
    }
    Ok(())
}

/// Encodes `image`'s means in `format` into `bytes`.
pub fn encode_image(
    bytes: &mut Vec<u8>,
    image: &Image,
    format: ImageFormat,
    tone: Tone,
) -> anyhow::Result<()> {
    let means = image.mean();
    match format {
        ImageFormat::Exr => encode_exr(bytes, image.width, image.height, |i| means[i]),
        ImageFormat::Hdr => {
            let pixels: Vec<image::Rgb<f32>> = means.iter().map(|&p| image::Rgb(p)).collect();
            image::codecs::hdr::HdrEncoder::new(&mut *bytes)
                .encode(&pixels, image.width as usize, image.height as usize)
                .context("cannot encode Radiance HDR")
        }
        _ => {
            let pixels =
                RgbImage::from_raw(image.width, image.height, to_srgb8(&means, tone.exposure))
                    .context("image size mismatch")?;
            encode_rgb8(bytes, &pixels, format, tone.quality)
        }
    }
}

/// Encodes an 8-bit sRGB picture in the 8-bit `format` into `bytes`.
pub fn encode_rgb8(
    bytes: &mut Vec<u8>,
    pixels: &RgbImage,
    format: ImageFormat,
    quality: u8,
) -> anyhow::Result<()> {
    let (width, height) = pixels.dimensions();
    let rgb = image::ExtendedColorType::Rgb8;
    match format {
        ImageFormat::Png => image::codecs::png::PngEncoder::new(&mut *bytes)
            .write_image(pixels, width, height, rgb)
            .context("cannot encode PNG"),
        ImageFormat::Jpeg => {
            image::codecs::jpeg::JpegEncoder::new_with_quality(&mut *bytes, quality.clamp(1, 100))
                .write_image(pixels, width, height, rgb)
                .context("cannot encode JPEG")
        }
        ImageFormat::Tiff => image::codecs::tiff::TiffEncoder::new(Cursor::new(&mut *bytes))
            .write_image(pixels, width, height, rgb)
            .context("cannot encode TIFF"),
        ImageFormat::Exr | ImageFormat::Hdr => {
            bail!("{} holds linear float pixels, not 8-bit", format.name())
        }
    }
}

/// Encodes linear RGB `pixel(i)` (row-major) as an OpenEXR image in [`EXR_ENCODING`].
fn encode_exr(
    bytes: &mut Vec<u8>,
    width: u32,
    height: u32,
    pixel: impl Fn(usize) -> [f32; 3] + Sync,
) -> anyhow::Result<()> {
    let mut attributes = LayerAttributes::named("film");
    attributes.software_name = Some(Text::from("realcam"));
    let row = width as usize;
    let layer = Layer::new(
        (width as usize, height as usize),
        attributes,
        EXR_ENCODING,
        SpecificChannels::rgb(|p: exr::math::Vec2<usize>| {
            let [r, g, b] = pixel(p.y() * row + p.x());
            (r, g, b)
        }),
    );
    ExrImage::from_layer(layer)
        .write()
        .to_buffered(Cursor::new(bytes))
        .context("cannot encode OpenEXR")
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    fn gradient(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            sums: (0..width * height)
                .map(|i| {
                    let v = i as f32 / (width * height) as f32;
                    [v, 0.5 * v, 0.25 + 0.1 * (i % 7) as f32]
                })
                .collect(),
            samples: 1,
        }
    }

    fn encoded(format: ImageFormat, image: &Image) -> Vec<u8> {
        let mut bytes = Vec::new();
        encode_image(&mut bytes, image, format, Tone::exposure(1.0)).unwrap();
        bytes
    }

    #[test]
    fn every_format_decodes_as_itself_with_the_right_pixels() {
        let image = gradient(40, 30);
        let means = image.mean();
        for format in ImageFormat::ALL {
            let bytes = encoded(format, &image);
            let guessed = image::guess_format(&bytes).unwrap();
            let expected = match format {
                ImageFormat::Png => image::ImageFormat::Png,
                ImageFormat::Jpeg => image::ImageFormat::Jpeg,
                ImageFormat::Tiff => image::ImageFormat::Tiff,
                ImageFormat::Exr => image::ImageFormat::OpenExr,
                ImageFormat::Hdr => image::ImageFormat::Hdr,
            };
            assert_eq!(guessed, expected, "{format:?}");
            let decoded = image::load_from_memory(&bytes).unwrap();
            assert_eq!((decoded.width(), decoded.height()), (40, 30));
            let pixel = 40 * 20 + 33;
            let (x, y) = (33, 20);
            if format.is_float() {
                let linear = decoded.to_rgb32f().get_pixel(x, y).0;
                // EXR holds f32 exactly; Radiance HDR shares one exponent over 8-bit mantissas.
                let tolerance = if format == ImageFormat::Exr {
                    0.0
                } else {
                    0.01
                };
                for c in 0..3 {
                    assert!(
                        (linear[c] - means[pixel][c]).abs() <= tolerance * means[pixel][c].abs(),
                        "{format:?} channel {c}: {} vs {}",
                        linear[c],
                        means[pixel][c]
                    );
                }
            } else {
                let srgb = decoded.to_rgb8().get_pixel(x, y).0;
                let expected = &to_srgb8(&means[pixel..=pixel], 1.0);
                // JPEG is lossy: within a few levels on a smooth gradient.
                let tolerance = if format == ImageFormat::Jpeg { 8 } else { 0 };
                for c in 0..3 {
                    assert!(
                        srgb[c].abs_diff(expected[c]) <= tolerance,
                        "{format:?} channel {c}: {} vs {}",
                        srgb[c],
                        expected[c]
                    );
                }
            }
        }
    }

    #[test]
    fn jpeg_quality_is_used() {
        let image = gradient(64, 64);
        let jpeg = |quality| {
            let mut bytes = Vec::new();
            let tone = Tone {
                exposure: 1.0,
                quality,
            };
            encode_image(&mut bytes, &image, ImageFormat::Jpeg, tone).unwrap();
            bytes.len()
        };
        assert!(jpeg(20) < jpeg(95), "{} vs {}", jpeg(20), jpeg(95));
    }

    #[test]
    fn names_choose_formats_and_wrong_ones_are_refused_with_the_list() {
        let format = |name: &str, accepts| output_format("--out", Path::new(name), accepts);
        assert_eq!(format("a.png", Accepts::Any).unwrap(), ImageFormat::Png);
        assert_eq!(format("a.JPG", Accepts::Any).unwrap(), ImageFormat::Jpeg);
        assert_eq!(format("a.jpeg", Accepts::Any).unwrap(), ImageFormat::Jpeg);
        assert_eq!(format("a.tiff", Accepts::Any).unwrap(), ImageFormat::Tiff);
        assert_eq!(format("a.exr", Accepts::Any).unwrap(), ImageFormat::Exr);
        assert_eq!(format("a.hdr", Accepts::Float).unwrap(), ImageFormat::Hdr);
        assert_eq!(format("-", Accepts::Any).unwrap(), ImageFormat::Png);
        assert_eq!(format("-", Accepts::Float).unwrap(), ImageFormat::Exr);
        let message = format("a.bmp", Accepts::Any).unwrap_err().to_string();
        for phrase in [
            "a.bmp",
            "'.bmp'",
            ".png",
            ".jpg/.jpeg",
            ".tif/.tiff",
            ".exr",
            ".hdr",
        ] {
            assert!(message.contains(phrase), "{phrase}: {message}");
        }
        let message = format("shot", Accepts::Any).unwrap_err().to_string();
        assert!(message.contains("no extension"), "{message}");
        let message = output_format("--exr", Path::new("x.png"), Accepts::Float)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("--exr x.png")
                && message.contains("8-bit")
                && message.contains(".exr, .hdr")
                && !message.contains(".jpg"),
            "{message}"
        );
        let message = output_format("--contact-sheet", Path::new("s.exr"), Accepts::EightBit)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("linear float") && message.contains(".png"),
            "{message}"
        );
    }

    #[test]
    fn tone_options_need_an_output_that_uses_them() {
        let png = ("--out", Path::new("a.png"), ImageFormat::Png);
        let jpg = ("--out", Path::new("a.jpg"), ImageFormat::Jpeg);
        let exr = ("--exr", Path::new("a.exr"), ImageFormat::Exr);
        assert!(check_tone_options(&[jpg, exr], true, true).is_ok());
        let message = check_tone_options(&[png, exr], false, true)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("--quality") && message.contains("--out a.png"),
            "{message}"
        );
        let out_exr = ("--out", Path::new("b.exr"), ImageFormat::Exr);
        let message = check_tone_options(&[out_exr, exr], true, false)
            .unwrap_err()
            .to_string();
        assert!(message.contains("--exposure"), "{message}");
        assert!(check_tone_options(&[out_exr, exr], false, false).is_ok());
    }

    /// The same image gives the same bytes in every format, however busy the thread pool is
    /// (the exr crate compresses blocks on several threads).
    #[test]
    fn the_same_image_gives_the_same_bytes_under_parallel_load() {
        let image = gradient(300, 200);
        let reference: Vec<Vec<u8>> = ImageFormat::ALL
            .iter()
            .map(|&f| encoded(f, &image))
            .collect();
        let stop = std::sync::atomic::AtomicBool::new(false);
        std::thread::scope(|scope| {
            // Busy work competing for the same threads.
            scope.spawn(|| {
                while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                    (0..10_000u64)
                        .into_par_iter()
                        .map(|i| i.wrapping_mul(i))
                        .sum::<u64>();
                }
            });
            let again: Vec<Vec<Vec<u8>>> = (0..8)
                .into_par_iter()
                .map(|_| {
                    ImageFormat::ALL
                        .iter()
                        .map(|&f| encoded(f, &image))
                        .collect()
                })
                .collect();
            stop.store(true, std::sync::atomic::Ordering::Relaxed);
            for run in again {
                assert!(run == reference, "bytes differ between runs");
            }
        });
    }
}
