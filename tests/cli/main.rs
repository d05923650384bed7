//! The command line from the outside, as a user runs it: `realcam render`, `lens`, `glass`,
//! limits, outputs, hostile input, and README.md's list of options.
//!
//! One test binary for the area (one module per topic) so that `cargo test` links the crate
//! a handful of times, not once per file.

#[path = "../support/mod.rs"]
mod support;

mod bad_inputs;
mod glass;
mod lens;
mod limits;
mod outputs;
mod readme_options;
mod render;
