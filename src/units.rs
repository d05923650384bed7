//! Bounds on lengths that every layer checks the same way: a lens file's thicknesses and
//! apertures, and the lens settings a scene's camera hints carry, are held to one limit.

/// Thicknesses and apertures beyond this (100 m) are refused: no real lens comes near, and it
/// catches files in the wrong unit and values whose sums would overflow.
pub const MAX_LENGTH_MM: f64 = 1e5;
