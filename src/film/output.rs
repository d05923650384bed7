//! Writing images: sRGB PNG with exposure, linear EXR; always atomically.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};

use super::Image;

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Exposure (a linear scale) that maps the image's log-average luminance to 18 % grey, the
/// photographer's "middle grey"; 1 for a black image. A real lens at f/5.6 passes far less
/// light than a pinhole model would suggest, so a fixed scale would give black or white images.
pub fn auto_exposure(pixels: &[[f32; 3]]) -> f32 {
    let (mut sum_log, mut count) = (0.0f64, 0usize);
    for &p in pixels {
        let l = luminance(p);
        if l > 0.0 && l.is_finite() {
            sum_log += (l as f64).ln();
            count += 1;
        }
    }
    if count == 0 {
        return 1.0;
    }
    let log_average = (sum_log / count as f64).exp();
    (0.18 / log_average) as f32
}

/// sRGB opto-electronic transfer function, linear [0, 1] → encoded [0, 1].
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// 8-bit sRGB pixels of `pixels` × `exposure`, clipped.
pub fn to_srgb8(pixels: &[[f32; 3]], exposure: f32) -> Vec<u8> {
    pixels
        .iter()
        .flat_map(|p| p.map(|c| (linear_to_srgb(c * exposure) * 255.0 + 0.5) as u8))
        .collect()
}

/// Writes `image`'s means as an sRGB PNG scaled by `exposure`.
pub fn write_png(path: &Path, image: &Image, exposure: f32) -> anyhow::Result<()> {
    let bytes = to_srgb8(&image.mean(), exposure);
    let buffer = image::RgbImage::from_raw(image.width, image.height, bytes)
        .context("image size mismatch")?;
    write_atomically(path, |w| {
        buffer.write_to(&mut std::io::Cursor::new(&mut *w), image::ImageFormat::Png)?;
        Ok(())
    })
}

/// Writes `image`'s means as linear, un-tonemapped RGB float EXR.
pub fn write_exr(path: &Path, image: &Image) -> anyhow::Result<()> {
    let floats: Vec<f32> = image.mean().into_iter().flatten().collect();
    let buffer = image::Rgb32FImage::from_raw(image.width, image.height, floats)
        .context("image size mismatch")?;
    write_atomically(path, |w| {
        buffer.write_to(
            &mut std::io::Cursor::new(&mut *w),
            image::ImageFormat::OpenExr,
        )?;
        Ok(())
    })
}

/// Checks before a long render that `path` can be written: its folder exists and is writable.
/// True when both paths name one existing file (through links, `..` and the like): an output
/// must never be written over one of the inputs.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

pub fn check_writable(path: &Path) -> anyhow::Result<()> {
    if path.is_dir() {
        bail!(
            "{}: is a directory; give a file name for the output",
            path.display()
        );
    }
    let probe = temp_path(path);
    std::fs::File::create(&probe)
        .with_context(|| format!("{}: cannot write here", path.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Encodes into memory, writes a temporary file beside `path`, then renames it over `path`:
/// readers never see a half-written image, even if realcam is killed mid-write.
pub fn write_atomically(
    path: &Path,
    encode: impl FnOnce(&mut Vec<u8>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut bytes = Vec::new();
    encode(&mut bytes).with_context(|| format!("{}: cannot encode image", path.display()))?;
    let temp = temp_path(path);
    let result = (|| -> std::io::Result<()> {
        let mut file = BufWriter::new(std::fs::File::create(&temp)?);
        file.write_all(&bytes)?;
        file.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&temp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&temp);
        return Err(e).with_context(|| format!("{}: cannot write output", path.display()));
    }
    Ok(())
}

fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_curve_matches_the_standard() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
        // 18 % grey encodes to about 46 % (118/255).
        assert!((linear_to_srgb(0.18) * 255.0 - 117.6).abs() < 1.0);
    }

    #[test]
    fn auto_exposure_maps_uniform_image_to_middle_grey() {
        let pixels = vec![[0.02f32; 3]; 100];
        let k = auto_exposure(&pixels);
        assert!((luminance(pixels[0]) * k - 0.18).abs() < 1e-5);
    }

    #[test]
    fn atomic_write_leaves_no_temp_and_replaces() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        let image = Image {
            width: 2,
            height: 1,
            sums: vec![[1.0; 3], [0.5; 3]],
            samples: 1,
        };
        write_png(&path, &image, 1.0).unwrap();
        write_png(&path, &image, 0.5).unwrap();
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
        let decoded = image::open(&path).unwrap().to_rgb8();
        assert_eq!(decoded.get_pixel(0, 0).0, [188, 188, 188]);
    }
}
