//! realcam: render glTF scenes through real multi-element camera lenses.
//!
//! The optics live in [`lens`] and the glass data in [`glass`], the scene in [`scene`],
//! ray–scene intersection in [`accel`], the path tracer in [`shade`], the image in [`film`],
//! and the bevy_ecs schedule that ties them together in [`pipeline`].

pub mod accel;
pub mod allocator;
pub mod batch;
pub mod cli;
pub mod diagnosis;
pub mod film;
pub mod glass;
pub mod gpu;
pub mod job;
pub(crate) mod lanes;
pub mod lens;
pub mod live;
pub mod memory;
pub mod pipeline;
pub(crate) mod prefetch;
pub mod sampling;
pub mod scene;
pub mod server;
pub mod shade;
pub mod spectral;
pub(crate) mod sync;
pub mod units;
