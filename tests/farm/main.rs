//! The render farm: what the farm scripts rely on without a scheduler, the Kubernetes
//! manifests and pod scripts, and a real one-node Slurm cluster.
//!
//! One test binary for the area (one module per topic) so that `cargo test` links the crate
//! a handful of times, not once per file.

#[path = "../support/mod.rs"]
mod support;

mod kubernetes;
mod slurm;
mod stop_and_merge;
