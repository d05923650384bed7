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

/// Size of a frame's thumbnail: the frame itself up to 320 px wide, else scaled down to that.
pub fn thumbnail_size(width: u32, height: u32) -> (u32, u32) {
    if width <= MAX_THUMB_WIDTH {
        (width, height)
    } else {
        let height = (height as u64 * MAX_THUMB_WIDTH as u64 / width as u64).max(1) as u32;
        (MAX_THUMB_WIDTH, height)
    }
}

/// The grid of a sheet: `frames` cells of thumbnails of at most `thumbnail` size with
/// `caption_lines` lines under each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    pub columns: u32,
    pub rows: u32,
    pub cell_width: u32,
    pub cell_height: u32,
}

impl Layout {
    /// A near-square grid.
    pub fn new(frames: usize, thumbnail: (u32, u32), caption_lines: u32) -> Layout {
        let columns = ((frames as f64).sqrt().ceil() as u32).max(1);
        Layout {
            columns,
            rows: (frames as u32).div_ceil(columns),
            cell_width: thumbnail.0 + PADDING,
            cell_height: thumbnail.1 + PADDING + caption_lines * LINE_HEIGHT,
        }
    }

    /// The sheet's width and height in pixels.
    pub fn size(&self) -> (u64, u64) {
        (
            self.columns as u64 * self.cell_width as u64 + PADDING as u64,
            self.rows as u64 * self.cell_height as u64 + PADDING as u64,
        )
    }
}

/// Memory a contact sheet of `frames` frames of `width` × `height` takes, in bytes: the
/// thumbnails kept until the end of the run, the sheet and its encoded file.
pub fn estimated_bytes(frames: usize, width: u32, height: u32, caption_lines: u32) -> u64 {
    let thumbnail = thumbnail_size(width, height);
    let (sheet_width, sheet_height) = Layout::new(frames, thumbnail, caption_lines).size();
    let thumbnails = frames as u64 * thumbnail.0 as u64 * thumbnail.1 as u64 * 3;
    thumbnails + 2 * sheet_width * sheet_height * 3
}

/// Lays `frames` out in a near-square grid, each scaled to at most 320 px wide, captioned.
pub fn contact_sheet(frames: &[Thumbnail]) -> RgbImage {
    if frames.is_empty() {
        return RgbImage::from_pixel(1, 1, BACKGROUND);
    }
    let thumbs: Vec<RgbImage> = frames
        .iter()
        .map(|f| {
            let (width, height) = thumbnail_size(f.image.width(), f.image.height());
            if width == f.image.width() {
                f.image.clone()
            } else {
                imageops::resize(&f.image, width, height, imageops::FilterType::Triangle)
            }
        })
        .collect();
    let largest = (
        thumbs.iter().map(RgbImage::width).max().unwrap_or(1),
        thumbs.iter().map(RgbImage::height).max().unwrap_or(1),
    );
    // Each caption wrapped to its thumbnail's width: a long lens name under a small frame
    // would otherwise run into the next cell's caption.
    let captions: Vec<Vec<String>> = thumbs
        .iter()
        .zip(frames)
        .map(|(thumb, frame)| wrap_caption(&frame.caption, thumb.width() / GLYPH_WIDTH))
        .collect();
    let lines = captions.iter().map(|c| c.len() as u32).max().unwrap_or(0);
    let layout = Layout::new(frames.len(), largest, lines);
    let (width, height) = layout.size();
    let mut sheet = RgbImage::from_pixel(width as u32, height as u32, BACKGROUND);
    for (i, (thumb, caption)) in thumbs.iter().zip(&captions).enumerate() {
        let x = PADDING + (i as u32 % layout.columns) * layout.cell_width;
        let y = PADDING + (i as u32 / layout.columns) * layout.cell_height;
        imageops::replace(&mut sheet, thumb, x as i64, y as i64);
        for (line, text) in caption.iter().enumerate() {
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

/// Width of a character of [`draw_text`]'s font, pixels.
const GLYPH_WIDTH: u32 = 8;

/// `caption`'s lines broken to at most `columns` characters each (at least one): after the
/// last '-', ' ', '/' or ',' that leaves at least half a line, else at the width.
fn wrap_caption(caption: &str, columns: u32) -> Vec<String> {
    let columns = columns.max(1) as usize;
    let mut wrapped = Vec::new();
    for line in caption.lines() {
        let mut rest: Vec<char> = line.chars().collect();
        while rest.len() > columns {
            let cut = rest[..columns]
                .iter()
                .rposition(|c| matches!(c, '-' | ' ' | '/' | ','))
                .map(|at| at + 1)
                .filter(|&at| 2 * at >= columns)
                .unwrap_or(columns);
            wrapped.push(
                rest[..cut]
                    .iter()
                    .collect::<String>()
                    .trim_end()
                    .to_string(),
            );
            rest.drain(..cut);
            while rest.first() == Some(&' ') {
                rest.remove(0);
            }
        }
        wrapped.push(rest.into_iter().collect());
    }
    wrapped
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
                let (px, py) = (x + i as u32 * GLYPH_WIDTH + col, y + row as u32);
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
                caption: format!("lens{i}\nf/2"),
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
        let layout = Layout::new(5, (40, 30), 2);
        assert_eq!(layout.size(), (sheet.width() as u64, sheet.height() as u64));
    }

    /// A caption wider than its frame wraps to the frame's width, at a hyphen where one
    /// leaves half a line, so it never runs into the next cell; every character is kept.
    #[test]
    fn long_captions_wrap_within_their_frame() {
        assert_eq!(
            wrap_caption("canon-ef-100mm-f2.8-macro\nf=100.0mm f/2.8", 16),
            ["canon-ef-100mm-", "f2.8-macro", "f=100.0mm f/2.8"]
        );
        assert_eq!(wrap_caption("abcdefghij", 4), ["abcd", "efgh", "ij"]);
        assert_eq!(wrap_caption("short", 16), ["short"]);
        assert_eq!(wrap_caption("x", 0), ["x"]);
        let frames: Vec<Thumbnail> = (0..2)
            .map(|_| Thumbnail {
                image: RgbImage::from_pixel(64, 16, Rgb([0, 0, 0])),
                caption: "nikon-af-s-600mm-f4e-fl-if".to_string(),
            })
            .collect();
        let sheet = contact_sheet(&frames);
        // 64 px hold 8 characters: "nikon-", "af-s-", "600mm-", "f4e-fl-", "if".
        assert_eq!(sheet.height(), 16 + PADDING + 5 * LINE_HEIGHT + PADDING);
        // No ink in the gap between the two cells.
        for x in PADDING + 64..PADDING + 64 + PADDING {
            for y in 0..sheet.height() {
                assert_ne!(*sheet.get_pixel(x, y), INK, "ink at ({x}, {y})");
            }
        }
    }

    #[test]
    fn thumbnails_are_at_most_320_wide_and_keep_their_shape() {
        assert_eq!(thumbnail_size(200, 100), (200, 100));
        assert_eq!(thumbnail_size(640, 480), (320, 240));
        assert_eq!(thumbnail_size(16384, 1), (320, 1));
        // 100 frames of 640×480: 10×10 cells of (320 + 8) × (240 + 8 + 3 lines).
        let bytes = estimated_bytes(100, 640, 480, 3);
        let sheet = (10 * 328 + 8) * (10 * (248 + 33) + 8) * 3;
        assert_eq!(bytes, 100 * 320 * 240 * 3 + 2 * sheet);
    }
}
