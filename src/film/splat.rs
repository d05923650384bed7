//! Contributions a sample adds to a pixel other than its own.
//!
//! With several wavelengths per camera sample, a companion wavelength's share belongs to the
//! pixel its own film point lies in, a pixel or two from the sample's (see
//! [`crate::lens::hero_wavelengths`]). The Weight stage lists those shares per tile, in ray
//! order; WriteFilm adds each tile's own samples first and then, for every tile in a fixed
//! order, the shares that land in it, so the film's sums do not depend on how many threads
//! ran the pass. With a reconstruction filter wider than a pixel every share, the ray's own
//! included, spreads over the pixels around its film point instead ([`Spread`]).

use super::filter::{GridTaps, TAPS};
use crate::lens::hero_wavelengths::SPLAT_RADIUS;

/// One share of a sample's weighted radiance for image pixel (`x`, `y`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Splat {
    pub x: u32,
    pub y: u32,
    pub rgb: [f32; 3],
}

/// Image pixels (x0, y0, width, height) of a tile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRect {
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
}

impl PixelRect {
    #[inline(always)]
    pub fn contains(&self, x: u32, y: u32) -> bool {
        x >= self.x0 && y >= self.y0 && x - self.x0 < self.width && y - self.y0 < self.height
    }

    /// Whether a splat from this tile's samples, at most `reach` pixels from its pixel, can
    /// land in `other`.
    pub fn may_reach(&self, other: &PixelRect, reach: u32) -> bool {
        let (ax0, ay0) = (self.x0.saturating_sub(reach), self.y0.saturating_sub(reach));
        let (ax1, ay1) = (self.x0 + self.width + reach, self.y0 + self.height + reach);
        ax0 < other.x0 + other.width
            && other.x0 < ax1
            && ay0 < other.y0 + other.height
            && other.y0 < ay1
    }
}

/// How far (pixels) beyond its tile a sample's shares reach through a filter: a companion
/// wavelength lands within [`SPLAT_RADIUS`] of its pixel, on the filter's grid possibly on the
/// next pixel's edge, and the filter reaches one pixel further.
pub const SPREAD_BORDER: u32 = SPLAT_RADIUS as u32 + 2;

/// With a reconstruction filter wider than a pixel (see [`super::filter`]): what a tile's
/// samples add to its pixels and to a border of [`SPREAD_BORDER`] around them, the Weight
/// stage's sums in ray order. WriteFilm adds to each tile the part of every tile's spread that
/// covers it, the tiles in image order, so the film's sums do not depend on the thread count.
#[derive(Clone, Debug, Default)]
pub struct Spread {
    /// Image pixel of the first sum (the tile's corner less the border; may be negative).
    pub x0: i32,
    pub y0: i32,
    pub width: u32,
    pub height: u32,
    /// Row-major RGB sums.
    pub sums: Vec<[f32; 3]>,
    /// Whether anything was added since the last reset: an untouched spread (a tile of a
    /// fisheye's frame outside its image circle) is all zeros, which need neither clearing
    /// nor adding to the film.
    touched: bool,
}

impl Spread {
    /// Zeroed sums for the tile `rect` and its border.
    pub fn reset(&mut self, rect: PixelRect) {
        let border = SPREAD_BORDER;
        (self.x0, self.y0) = (
            rect.x0 as i32 - border as i32,
            rect.y0 as i32 - border as i32,
        );
        (self.width, self.height) = (rect.width + 2 * border, rect.height + 2 * border);
        let len = (self.width * self.height) as usize;
        if self.touched || self.sums.len() != len {
            self.sums.clear();
            self.sums.resize(len, [0.0; 3]);
        }
        self.touched = false;
    }

    /// Whether any share was added since the last reset (otherwise every sum is zero).
    pub fn touched(&self) -> bool {
        self.touched
    }

    /// Adds `rgb` spread by `filter` from the image's grid point (`x`, `y`) (in steps of
    /// [`POSITION_STEP`](super::filter::POSITION_STEP), see
    /// [`grid_point`](super::filter::grid_point)) on a frame of `size` pixels. Every tap lies
    /// inside the border (a share lands within [`SPLAT_RADIUS`] of its pixel), those beyond the
    /// frame with weight 0, so the 3 × 3 taps are added without a test.
    #[inline(always)]
    pub fn add(&mut self, filter: &GridTaps, [x, y]: [i32; 2], size: [u32; 2], rgb: [f32; 3]) {
        self.touched = true;
        let (first_x, weights_x) = filter.taps_at(x, size[0]);
        let (first_y, weights_y) = filter.taps_at(y, size[1]);
        let column = (first_x - self.x0) as usize;
        for (ky, &wy) in weights_y.iter().enumerate() {
            let start = (first_y + ky as i32 - self.y0) as usize * self.width as usize + column;
            let row = &mut self.sums[start..start + TAPS];
            for (sum, &wx) in row.iter_mut().zip(&weights_x) {
                let w = wx * wy;
                *sum = [
                    sum[0] + rgb[0] * w,
                    sum[1] + rgb[1] * w,
                    sum[2] + rgb[2] * w,
                ];
            }
        }
    }

    /// Adds the part of these sums that covers `rect` to its row-major `sums`.
    pub fn add_to(&self, rect: PixelRect, sums: [&mut [f32]; 3]) {
        let [r, g, b] = sums;
        let x_lo = self.x0.max(rect.x0 as i32);
        let x_hi = (self.x0 + self.width as i32).min((rect.x0 + rect.width) as i32);
        let y_lo = self.y0.max(rect.y0 as i32);
        let y_hi = (self.y0 + self.height as i32).min((rect.y0 + rect.height) as i32);
        for y in y_lo..y_hi {
            for x in x_lo..x_hi {
                let from = ((y - self.y0) as u32 * self.width + (x - self.x0) as u32) as usize;
                let to = ((y as u32 - rect.y0) * rect.width + (x as u32 - rect.x0)) as usize;
                let s = self.sums[from];
                (r[to], g[to], b[to]) = (r[to] + s[0], g[to] + s[1], b[to] + s[2]);
            }
        }
    }
}
