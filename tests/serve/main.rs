//! `realcam serve`: its JSON API over loopback, and its page in a headless browser.
//!
//! One test binary for the area (one module per topic) so that `cargo test` links the crate
//! a handful of times, not once per file.

#[path = "../live_server/mod.rs"]
mod live_server;
#[path = "../support/mod.rs"]
mod support;

mod api;
mod browser;
