//! The film's reconstruction filter: how one share of a sample spreads over the pixels around
//! the film point it lands on.
//!
//! Pixel (i, j) of the image estimates
//!
//! ```text
//! I(i, j) = ∫ dA(x)  f(x, i, j) · E(x)        Σ_{i, j} f(x, i, j) = 1 for every film point x
//! ```
//!
//! with E the film's irradiance (per wavelength and channel, see [`crate::lens::hero_wavelengths`]).
//! Film points are drawn uniformly, one per pixel and pass, so a share of weighted radiance
//! landing at x adds f(x, i, j) times itself to pixel (i, j): unbiased for I, and the weights of
//! every share sum to one, so no energy is gained or lost. f is separable, f = f_x · f_y, and each
//! axis's weights are the filter's profile at the pixel centres within its radius, normalised to
//! sum to one over the pixels that exist (so the frame's edge keeps every share too).
//!
//! - **box**: the pixel x lies in, weight 1 (the classic estimator; sharpest, and a share that
//!   lands across a pixel edge moves all of its colour there).
//! - **tent** (default): 1 − |d|/r with r = 1.5 pixels, d the distance from x to a pixel centre.
//!   With several wavelengths per sample the wavelengths of one sample land a fraction of a
//!   pixel apart (the lens's own colour at pixel scale); a tent shares each of them among the
//!   same few pixels in nearly the same proportions, so a grey surface stays grey where a box
//!   would colour each pixel by the part of the spectrum that happened to land in it
//!   (BENCHMARKS.md, "Colour grain": the grey floor's chroma 0.150 → 0.059 at 64 spp).
//! - **gaussian**: exp(−d²/2σ²) − exp(−r²/2σ²), σ = 0.5, r = 1.5 pixels (pbrt-v4's default).
//!
//! Positions are quantised to 1/256 pixel before the weights are taken, so the GPU, which
//! passes them between its kernels as small integers, weights every share exactly as the CPU.

use serde::{Deserialize, Serialize};

/// Film positions are multiples of this many pixels (see the module docs).
pub const POSITION_STEP: f32 = 1.0 / 256.0;

/// Radius (pixels) of the tent and Gaussian filters.
pub const FILTER_RADIUS: f32 = 1.5;

/// Standard deviation (pixels) of the Gaussian filter.
pub const GAUSSIAN_SIGMA: f32 = 0.5;

/// Pixels a share's weights reach along one axis: the pixel its film point lies in and one on
/// each side (a radius of 1.5 reaches at most the centres one pixel away).
pub const TAPS: usize = 3;

/// The reconstruction filter (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Filter {
    Box,
    #[default]
    Tent,
    Gaussian,
}

impl Filter {
    pub const ALL: [Filter; 3] = [Filter::Box, Filter::Tent, Filter::Gaussian];

    pub fn name(self) -> &'static str {
        match self {
            Filter::Box => "box",
            Filter::Tent => "tent",
            Filter::Gaussian => "gaussian",
        }
    }

    pub fn from_name(name: &str) -> Option<Filter> {
        Filter::ALL.into_iter().find(|f| f.name() == name)
    }

    /// Whether a share reaches only the pixel it lands in.
    pub fn is_box(self) -> bool {
        self == Filter::Box
    }

    /// The filter's profile at distance `d` (pixels) from a pixel centre, before normalising.
    #[inline(always)]
    fn profile(self, d: f32) -> f32 {
        match self {
            Filter::Box => f32::from(u8::from(d.abs() <= 0.5)),
            Filter::Tent => (1.0 - d.abs() * (1.0 / FILTER_RADIUS)).max(0.0),
            Filter::Gaussian => {
                let g = |d: f32| (-d * d * (0.5 / (GAUSSIAN_SIGMA * GAUSSIAN_SIGMA))).exp();
                (g(d) - g(FILTER_RADIUS)).max(0.0)
            }
        }
    }

    /// One axis of the weights of a share at `position` (pixels from the left or top edge of
    /// the frame, quantised, on the frame): the first pixel and the weights of it and the next
    /// [`TAPS`] − 1, summing to one over the pixels inside `0..extent` (0 for the others).
    #[inline(always)]
    pub fn taps(self, position: f32, extent: u32) -> (i32, [f32; TAPS]) {
        let floor = position.floor();
        let own = floor as i32;
        if self.is_box() {
            return (own.clamp(0, extent as i32 - 1), [1.0, 0.0, 0.0]);
        }
        // The point's distances to the centres of pixels own − 1, own and own + 1 (exact:
        // positions are multiples of 1/256 well inside f32's precision).
        let within = position - floor;
        let mut weights = [
            self.profile(within + 0.5),
            self.profile(within - 0.5),
            self.profile(1.5 - within),
        ];
        if own < 1 || own + 1 >= extent as i32 {
            for (k, w) in weights.iter_mut().enumerate() {
                if !(0..extent as i32).contains(&(own - 1 + k as i32)) {
                    *w = 0.0;
                }
            }
        }
        // A point on the frame (its far edge included, where quantising may put it) is within
        // half a pixel of an inside pixel's centre, so the sum is positive.
        let scale = 1.0 / (weights[0] + weights[1] + weights[2]);
        (own - 1, weights.map(|w| w * scale))
    }
}

/// Steps of the position grid in a pixel.
const STEPS: usize = 256;

impl Filter {
    /// [`Filter::taps`] at every position on the grid: row `inside · 256 + step` holds the three
    /// weights (and a zero) of a share `step` steps into the pixel it lands in, where bit k of
    /// `inside` says whether the k-th of the three pixels it reaches lies on the frame. A
    /// share's weights depend on nothing else (its position less those pixel centres is exact in
    /// f32), so each row is taken by `taps` itself at a position on a frame just large enough
    /// to give its pattern; patterns no share has (no pixel inside, or a gap) stay zero. The CPU
    /// looks weights up here ([`GridTaps::taps_at`]) and the GPU's gather gets the same table,
    /// so both weigh every share exactly alike. Empty for the box, which weighs nothing.
    pub fn tap_table(self) -> &'static [[f32; 4]] {
        static TABLES: [std::sync::OnceLock<Vec<[f32; 4]>>; 3] =
            [const { std::sync::OnceLock::new() }; 3];
        let index = Filter::ALL
            .iter()
            .position(|&f| f == self)
            .expect("a filter of ALL");
        TABLES[index].get_or_init(|| {
            let mut table = Vec::new();
            if self.is_box() {
                return table;
            }
            table.resize((1 << TAPS) * STEPS, [0.0; 4]);
            // The pixel a share lands in (`own`) on a frame of `extent` pixels: every pattern a
            // share can meet, the last (own == extent) on the far edge of the frame.
            for extent in 1..=TAPS as i32 {
                for own in 0..=extent {
                    let inside = (0..TAPS as i32)
                        .filter(|k| (0..extent).contains(&(own - 1 + k)))
                        .fold(0, |bits, k| bits | (1 << k));
                    for step in 0..STEPS {
                        let position = own as f32 + step as f32 * POSITION_STEP;
                        let (first, [a, b, c]) = self.taps(position, extent as u32);
                        debug_assert_eq!(first, own - 1);
                        table[inside * STEPS + step] = [a, b, c, 0.0];
                    }
                }
            }
            table
        })
    }

    /// The filter with its table at hand, for weighing many shares ([`GridTaps::taps_at`]): the
    /// table is found once, not per share.
    #[inline(always)]
    pub fn grid(self) -> GridTaps {
        GridTaps {
            filter: self,
            table: self.tap_table(),
        }
    }
}

/// A filter and its [`Filter::tap_table`], looked up once.
#[derive(Clone, Copy, Debug)]
pub struct GridTaps {
    filter: Filter,
    table: &'static [[f32; 4]],
}

impl GridTaps {
    /// [`Filter::taps`] for the grid point `steps` steps of [`POSITION_STEP`] from the frame's
    /// edge ([`grid_point`]), looked up in [`Filter::tap_table`]: the same weights, bit for bit,
    /// without evaluating the profile. The pixel is `steps` ÷ 256 rounded down and the step into
    /// it the remainder, both exact, so no float is rounded on the way to the table.
    #[inline(always)]
    pub fn taps_at(&self, steps: i32, extent: u32) -> (i32, [f32; TAPS]) {
        let own = steps >> STEPS.trailing_zeros();
        if self.filter.is_box() {
            return self.filter.taps(own as f32, extent);
        }
        let step = (steps & (STEPS as i32 - 1)) as usize;
        let extent = extent as i32;
        let inside = usize::from(own >= 1)
            | usize::from(own < extent) << 1
            | usize::from(own + 1 < extent) << 2;
        let [a, b, c, _] = self.table[inside * STEPS + step];
        (own - 1, [a, b, c])
    }
}

/// A position (pixels) in steps of [`POSITION_STEP`], rounded down: exact for a position on
/// the grid ([`quantise`]), as a multiple of 1/256 times 256 is an integer in f32.
#[inline(always)]
pub fn grid_steps(position: f32) -> i32 {
    (position * STEPS as f32).floor() as i32
}

/// The grid point (see [`grid_steps`]) `offset` pixels from the corner of pixel `pixel`.
#[inline(always)]
pub fn grid_point(pixel: u32, offset: f32) -> i32 {
    pixel as i32 * STEPS as i32 + grid_steps(offset)
}

/// `position` (pixels) on the 1/256-pixel grid the filter's weights are taken at.
#[inline(always)]
pub fn quantise(position: f32) -> f32 {
    (position * 256.0).round() * POSITION_STEP
}

impl std::fmt::Display for Filter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_share_keeps_its_energy_at_every_position_and_edge() {
        for filter in Filter::ALL {
            for extent in [1u32, 2, 3, 16] {
                for step in 0..(extent * 256) {
                    let p = step as f32 * POSITION_STEP;
                    let (first, w) = filter.taps(p, extent);
                    let sum: f32 = w.iter().sum();
                    assert!(
                        (sum - 1.0).abs() < 1e-6,
                        "{filter} at {p} of {extent}: {w:?}"
                    );
                    for (k, &w) in w.iter().enumerate() {
                        let pixel = first + k as i32;
                        assert!(w >= 0.0);
                        assert!(
                            w == 0.0 || (0..extent as i32).contains(&pixel),
                            "{filter} {p}"
                        );
                    }
                    // The pixel the point lies in always gets the most.
                    let own = p.floor().min(extent as f32 - 1.0) as i32;
                    let own_weight = w[(own - first) as usize];
                    assert!(
                        w.iter().all(|&v| v <= own_weight + 1e-6),
                        "{filter} {p}: {w:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_filters_are_the_profiles_they_are_named_for() {
        // A point on a pixel centre, far from the edges: the centre and its two neighbours.
        let (first, w) = Filter::Tent.taps(8.5, 16);
        assert_eq!(first, 7);
        // 1 − 1/1.5 = 1/3 beside a centre weight of 1, normalised by 5/3.
        for (got, want) in w.iter().zip([0.2, 0.6, 0.2]) {
            assert!((got - want).abs() < 1e-6, "{w:?}");
        }
        // Halfway between centres: two pixels, equal, and the third beyond the radius.
        let (first, w) = Filter::Gaussian.taps(9.0, 16);
        assert_eq!(first, 8);
        assert!((w[0] - 0.5).abs() < 1e-6 && (w[1] - 0.5).abs() < 1e-6 && w[2] == 0.0);
        let g = |d: f32| (-2.0 * d * d).exp() - (-2.0f32 * 2.25).exp();
        let (_, w) = Filter::Gaussian.taps(8.5, 16);
        let expect = g(1.0) / (g(0.0) + 2.0 * g(1.0));
        assert!((w[0] - expect).abs() < 1e-6 && (w[2] - expect).abs() < 1e-6);
        assert_eq!(Filter::Box.taps(8.99, 16), (8, [1.0, 0.0, 0.0]));
        // At the frame's edge the pixel beyond is dropped and the rest take its share.
        let (first, w) = Filter::Tent.taps(0.5, 16);
        assert_eq!(first, -1);
        assert!(w[0] == 0.0 && (w[1] - 0.75).abs() < 1e-6 && (w[2] - 0.25).abs() < 1e-6);
    }

    #[test]
    fn positions_are_quantised_to_the_grid_the_gpu_passes() {
        assert_eq!(quantise(0.3), 77.0 / 256.0);
        assert_eq!(quantise(-1.0009), -1.0);
        assert_eq!(quantise(2.999), 3.0);
        for name in ["box", "tent", "gaussian"] {
            assert_eq!(Filter::from_name(name).map(Filter::name), Some(name));
        }
        assert_eq!(Filter::from_name("mitchell"), None);
    }

    /// The table, and the look-up in it, give Filter::taps's weights for every position a share
    /// can have, near the frame's edges and far from them.
    #[test]
    fn the_filter_table_is_filter_taps() {
        assert!(Filter::Box.tap_table().is_empty());
        let steps = (1.0 / POSITION_STEP) as usize;
        for filter in [Filter::Tent, Filter::Gaussian] {
            // accumulate_filtered looks for shares no further than this allows: a pixel whose
            // centre lies a whole radius from a share's point takes none of it.
            assert_eq!(filter.taps(1.0, 3).1[2], 0.0, "{filter}");
            let table = filter.tap_table();
            for extent in (1..12).chain([16_384]) {
                let end = extent as usize * steps;
                let ats = (0..=end.min(4 * steps)).chain(end.saturating_sub(4 * steps)..=end);
                for at in ats {
                    let position = at as f32 * POSITION_STEP;
                    let (first, weights) = filter.taps(position, extent);
                    let inside = (0..3)
                        .filter(|&k| (0..extent as i32).contains(&(first + k)))
                        .fold(0, |bits, k| bits | (1 << k));
                    let row = table[inside * steps + at % steps];
                    assert_eq!(row[..3], weights, "{filter} at {position} of {extent}");
                    let looked_up = filter.grid().taps_at(grid_steps(position), extent);
                    assert_eq!(
                        (looked_up.0, looked_up.1.map(f32::to_bits)),
                        (first, weights.map(f32::to_bits)),
                        "{filter} at {position} of {extent}"
                    );
                }
            }
        }
    }

    /// A share's grid point, from its pixel and its offset from that pixel's corner (a
    /// companion's lies up to a few pixels either side), weighs it as its position in pixels
    /// does: the integer path to the table gives Filter::taps's weights, bit for bit.
    #[test]
    fn a_grid_point_weighs_a_share_as_its_position_does() {
        for filter in Filter::ALL {
            let grid = filter.grid();
            for (pixel, extent) in [(0u32, 16u32), (1, 16), (7, 16), (14, 16), (15, 16), (3, 5)] {
                for step in -3 * 256..4 * 256 {
                    let offset = step as f32 * POSITION_STEP;
                    let position = pixel as f32 + offset;
                    if !(0.0..=extent as f32).contains(&position) {
                        continue;
                    }
                    let at = grid_point(pixel, offset);
                    assert_eq!(at, pixel as i32 * 256 + step);
                    let (first, weights) = filter.taps(position, extent);
                    let looked_up = grid.taps_at(at, extent);
                    assert_eq!(
                        (looked_up.0, looked_up.1.map(f32::to_bits)),
                        (first, weights.map(f32::to_bits)),
                        "{filter}: pixel {pixel} + {offset} of {extent}"
                    );
                }
            }
        }
    }
}
