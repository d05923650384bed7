//! A ray in the lens frame and the vector arithmetic on `[T; 3]` that tracing it needs,
//! generic over the float type (f64 for the reference optics, f32 for the render path). Lens
//! frame, mm (see [`crate::lens`]); the surface shapes and the tracer both build on it.

use num_traits::Float;

/// A ray in the lens frame; `direction` is a unit vector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray<T> {
    pub origin: [T; 3],
    pub direction: [T; 3],
}

pub fn dot<T: Float>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn add<T: Float>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub fn scale<T: Float>(a: [T; 3], s: T) -> [T; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

pub fn normalize<T: Float>(a: [T; 3]) -> [T; 3] {
    let length = dot(a, a).sqrt();
    if length > T::zero() {
        scale(a, length.recip())
    } else {
        a
    }
}
