//! The glTF loader: sample and hand-built scenes against facts computed by hand, corrupt
//! files, and property tests that it never panics.
//!
//! One test binary for the area (one module per topic) so that `cargo test` links the crate
//! a handful of times, not once per file.

#[path = "../support/mod.rs"]
mod support;

mod gltf_properties;
mod loading;
