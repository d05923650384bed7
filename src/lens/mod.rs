//! The lens: a real multi-element camera lens, traced exactly (Kolb, Mitchell & Hanrahan 1995).
//!
//! # Frame and sign conventions (used everywhere in this module)
//!
//! * **Lens frame**: millimetres, origin at the vertex of the *first* (front, scene-side)
//!   surface, **+z along the optical axis toward the film**. The scene lies at z < 0; the film is
//!   the plane `z = rear vertex + film distance`.
//! * The lens frame's x and y are the camera's x (image right) and y (image up), so the lens
//!   frame is the camera frame (which looks down −z) up to a shift along z and mm → m; see
//!   [`camera`]. A real lens forms an inverted image: the film point at (+x, +y) sees the
//!   scene at (−x, −y), which [`camera`] undoes when it maps pixels to film points.
//! * **Radius** R > 0 when the centre of curvature lies on the film side (+z) of the vertex;
//!   curvature c = 1/R; flat surfaces and the stop have c = 0.
//! * **Index** of a row = the medium *after* the surface (toward the film).
//! * **Film distance**: rear vertex → film, along +z. **Focus distance**: film plane → in-focus
//!   object plane, in metres (as pbrt).
//! * Every z reported to users (`realcam lens --json`) is a lens-frame z in mm.

pub mod aiming;
pub mod aperture;
pub mod camera;
pub mod chromatic;
pub mod clear_aperture;
pub mod coating;
pub mod coverage;
pub mod diagram;
pub mod diaphragm;
pub mod dispersion;
pub mod elements;
pub mod field;
pub mod first_order;
pub mod focus;
pub mod focus_probe;
pub mod ghost;
pub mod group_motion;
pub mod hero_wavelengths;
pub mod info;
pub mod io;
pub mod movements;
pub mod prescription;
pub mod pupil;
pub mod pupil_view;
pub mod ray;
pub mod reflectance;
pub mod report;
pub mod settings;
pub mod shape;
pub mod spacing;
pub mod system;
#[cfg(test)]
pub(crate) mod test_lens;
pub mod trace;
pub mod trace_batch;
pub(crate) mod wavelength_draws;
pub mod workload;

pub use prescription::{
    LensFormat, Prescription, PrescriptionError, SurfaceBase, SurfaceKind, SurfaceRow,
};
pub use shape::Asphere;
pub use system::{LensSystem, SurfaceArrays};
