//! Lenses and glass against independent numbers: optics of the bundled and library designs,
//! aspheres, Zemax import, coatings in lens files, colour, lens entities and swapping, the glass catalogue and model,
//! and property tests of the loader and the batched tracer.
//!
//! One test binary for the area (one module per topic) so that `cargo test` links the crate
//! a handful of times, not once per file.

#[path = "../support/mod.rs"]
mod support;

mod aspheres;
mod chromatic;
mod coatings_io;
mod entities;
mod glass_catalogue;
mod glass_model;
mod library;
mod optics;
mod properties;
mod swapping;
mod zemax;
mod zoom;
