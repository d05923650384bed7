//! Whole renders against physical facts computed independently of the renderer: light
//! transport, black images that say why, film movements and focus on a pixel, and bokeh.
//!
//! One test binary for the area (one module per topic) so that `cargo test` links the crate
//! a handful of times, not once per file.

#[path = "../support/mod.rs"]
mod support;

mod black_images;
mod bokeh;
mod coatings;
mod colour_grain;
mod example;
mod film_movements;
mod gpu;
mod physics;
