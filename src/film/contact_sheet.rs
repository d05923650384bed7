//! Contact sheets: every render of a run in one labelled grid, to compare lenses at a glance.

use font8x8::UnicodeFonts;
use image::{Rgb, RgbImage, imageops};

/// One finished frame and the caption under it (one line per `\n`).
pub struct Thumbnail {
    pub image: RgbImage,
    pub caption: String,
}

const MAX_THUMB_WIDTH: u32 = 320;
const PADDING: u32 = 8;
const LINE_HEIGHT: u32 = 11;
const BACKGROUND: Rgb<u8> = Rgb([24, 24, 24]);
const INK: Rgb<u8> = Rgb([235, 235, 235]);

/// Lays `frames` out in a near-square grid, each scaled to at most 320 px wide, captioned.
pub fn contact_sheet(frames: &[Thumbnail]) -> RgbImage {
    if frames.is_empty() {
        return RgbImage::from_pixel(1, 1, BACKGROUND);
    }
    let thumbs: Vec<RgbImage> = frames
        .iter()
        .map(|f| {
            if f.image.width() <= MAX_THUMB_WIDTH {
                f.image.clone()
            } else {
                let height = (f.image.height() as u64 * MAX_THUMB_WIDTH as u64
                    / f.image.width() as u64)
                    .max(1) as u32;
                imageops::resize(
                    &f.image,
                    MAX_THUMB_WIDTH,
                    height,
                    imageops::FilterType::Triangle,
                )
            }
        })
        .collect();
    let lines = frames
        .iter()
        .map(|f| f.caption.lines().count() as u32)
        .max()
        .unwrap_or(0);
    let cell_w = thumbs.iter().map(RgbImage::width).max().unwrap_or(1) + PADDING;
    let cell_h =
        thumbs.iter().map(RgbImage::height).max().unwrap_or(1) + PADDING + lines * LINE_HEIGHT;
    let columns = (frames.len() as f64).sqrt().ceil() as u32;
    let rows = (frames.len() as u32).div_ceil(columns);
    let mut sheet = RgbImage::from_pixel(
        columns * cell_w + PADDING,
        rows * cell_h + PADDING,
        BACKGROUND,
    );
    for (i, (thumb, frame)) in thumbs.iter().zip(frames).enumerate() {
        let x = PADDING + (i as u32 % columns) * cell_w;
        let y = PADDING + (i as u32 / columns) * cell_h;
        imageops::replace(&mut sheet, thumb, x as i64, y as i64);
        for (line, text) in frame.caption.lines().enumerate() {
            draw_text(
                &mut sheet,
                x,
                y + thumb.height() + 2 + line as u32 * LINE_HEIGHT,
                text,
            );
        }
    }
    sheet
}

/// Draws `text` in the 8×8 public-domain bitmap font; characters it lacks become '?'.
pub fn draw_text(image: &mut RgbImage, x: u32, y: u32, text: &str) {
    for (i, c) in text.chars().enumerate() {
        let glyph = font8x8::BASIC_FONTS
            .get(c)
            .or_else(|| font8x8::BASIC_FONTS.get('?'))
            .unwrap_or([0; 8]);
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                let (px, py) = (x + i as u32 * 8 + col, y + row as u32);
                if bits & (1 << col) != 0 && px < image.width() && py < image.height() {
                    image.put_pixel(px, py, INK);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_holds_every_frame_with_its_caption() {
        let frames: Vec<Thumbnail> = (0..5)
            .map(|i| Thumbnail {
                image: RgbImage::from_pixel(40, 30, Rgb([i * 50, 0, 0])),
                caption: format!("lens {i}\nf/2"),
            })
            .collect();
        let sheet = contact_sheet(&frames);
        // 5 frames → 3 columns × 2 rows of (40 + 8) × (30 + 8 + 2 lines).
        assert_eq!(sheet.width(), 3 * 48 + PADDING);
        assert_eq!(sheet.height(), 2 * (38 + 2 * LINE_HEIGHT) + PADDING);
        assert_eq!(
            *sheet.get_pixel(PADDING + 48 + 1, PADDING + 1),
            Rgb([50, 0, 0])
        );
        let inked = sheet.pixels().filter(|p| **p == INK).count();
        assert!(inked > 100, "captions drawn: {inked} pixels");
    }
}
