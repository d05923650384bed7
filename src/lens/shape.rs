//! Surface shapes: the plane, the sphere, the conic and the even asphere, one formula for all.
//!
//! Every surface is the graph of its **sag** over the vertex plane, z − z_vertex = sag(ρ) with
//! ρ = x² + y² (lens frame, mm; see [`crate::lens`]):
//!
//! ```text
//! sag(ρ) = c·ρ / (1 + √(1 − κ·c²·ρ))  +  Σ_{i=1..8} A_{2i}·ρ^i        κ = 1 + k
//! ```
//!
//! c = 1/R is the curvature of the base conic at the vertex, k its conic constant (0: sphere,
//! −1: paraboloid, < −1: hyperboloid, between: ellipsoids), A_{2i} the coefficient of r^{2i}
//! (Zemax's `PARM i`, so A₂ is the r² term). The conic part alone is the quadric
//!
//! ```text
//! c·ρ + κ·c·z² − 2z = 0      on the sheet through the vertex, where 1 − κ·c·z = √(1 − κ·c²·ρ) ≥ 0,
//! ```
//!
//! which a ray meets where a quadratic in its distance vanishes: spheres and conics are
//! intersected in closed form, and a polynomial asphere by Newton's method on the sag started
//! from its base conic. The sag is undefined where 1 − κ·c²·ρ < 0 (beyond an ellipsoid's or a
//! sphere's rim); rays meeting the surface there miss it.

use num_traits::Float;

use super::ray::{Ray, normalize};

/// Number of polynomial terms A₂ … A₁₆.
pub const ASPHERIC_TERMS: usize = 8;

/// Newton steps allowed before a ray is reported as missing an aspheric surface. Started from
/// the base conic, real camera aspheres converge in 3–6.
const MAX_NEWTON_STEPS: usize = 64;

/// The departure of a surface from a sphere: conic constant and even polynomial terms (mm
/// units: A_{2i} in mm^(1−2i)). Zero for a sphere.
#[derive(Clone, Copy, Debug, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Asphere {
    /// Conic constant k (κ = 1 + k).
    pub conic: f64,
    /// [A₂, A₄, …, A₁₆]: the coefficient of r², r⁴, … r¹⁶.
    pub coefficients: [f64; ASPHERIC_TERMS],
}

impl Asphere {
    pub const NONE: Asphere = Asphere {
        conic: 0.0,
        coefficients: [0.0; ASPHERIC_TERMS],
    };

    /// True when the surface has polynomial terms (and so needs the iterative intersection).
    pub fn has_polynomial(&self) -> bool {
        self.coefficients.iter().any(|&a| a != 0.0)
    }

    /// True when this departs from the base sphere on a surface of curvature `c` (a conic
    /// constant on a plane changes nothing).
    pub fn is_aspheric(&self, curvature: f64) -> bool {
        self.has_polynomial() || (self.conic != 0.0 && curvature != 0.0)
    }

    /// The index of the highest nonzero coefficient + 1 (0 when there is none).
    pub fn order(&self) -> usize {
        self.coefficients
            .iter()
            .rposition(|&a| a != 0.0)
            .map_or(0, |i| i + 1)
    }

    /// The same surface in units `scale` times larger (lengths × scale): c / scale and
    /// A_{2i} / scale^(2i − 1), the conic constant unchanged.
    pub fn scaled(&self, scale: f64) -> Asphere {
        let mut coefficients = self.coefficients;
        for (i, a) in coefficients.iter_mut().enumerate() {
            *a /= scale.powi(2 * i as i32 + 1);
        }
        Asphere {
            conic: self.conic,
            coefficients,
        }
    }
}

/// One surface's shape in one precision: base curvature, κ and the polynomial.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile<T> {
    pub curvature: T,
    /// κ = 1 + k.
    pub conic_factor: T,
    pub coefficients: [T; ASPHERIC_TERMS],
    /// Any coefficient nonzero.
    pub polynomial: bool,
}

impl<T: Float> Profile<T> {
    /// A sphere (or, with c = 0, a plane).
    pub fn sphere(curvature: T) -> Profile<T> {
        Profile {
            curvature,
            conic_factor: T::one(),
            coefficients: [T::zero(); ASPHERIC_TERMS],
            polynomial: false,
        }
    }

    pub fn new(curvature: f64, asphere: &Asphere, convert: impl Fn(f64) -> T) -> Profile<T> {
        Profile {
            curvature: convert(curvature),
            conic_factor: convert(1.0 + asphere.conic),
            coefficients: asphere.coefficients.map(convert),
            polynomial: asphere.has_polynomial(),
        }
    }

    /// The sag and its derivative d sag / dρ at ρ = x² + y²; `None` where the conic part is
    /// undefined (1 − κc²ρ < 0).
    #[inline]
    pub fn sag_and_slope(&self, rho: T) -> Option<(T, T)> {
        let c = self.curvature;
        let one = T::one();
        let two = one + one;
        let under_root = one - self.conic_factor * c * c * rho;
        if under_root < T::zero() || under_root.is_nan() {
            return None;
        }
        let root = under_root.sqrt();
        // c·ρ / (1 + √·) is (1 − √·)/(κc) without cancellation, and well defined as c → 0 or
        // κ → 0; its derivative c / (2√·) follows from differentiating c·ρ + κc·z² − 2z = 0.
        let mut sag = c * rho / (one + root);
        let mut slope = c / (two * root);
        if self.polynomial {
            // Horner in ρ: Σ A_{2i} ρ^i and Σ i·A_{2i} ρ^(i−1).
            let mut value = T::zero();
            let mut derivative = T::zero();
            for (i, &a) in self.coefficients.iter().enumerate().rev() {
                derivative = derivative * rho + T::from(i + 1).unwrap() * a;
                value = value * rho + a;
            }
            sag = sag + value * rho;
            slope = slope + derivative;
        }
        Some((sag, slope))
    }

    /// The sag at height `h` from the axis.
    pub fn sag(&self, h: T) -> Option<T> {
        self.sag_and_slope(h * h).map(|(s, _)| s)
    }

    /// The curvature of the surface at its vertex: c + 2·A₂ (what paraxial rays see).
    pub fn vertex_curvature(&self) -> T {
        self.curvature + (T::one() + T::one()) * self.coefficients[0]
    }

    /// Unit normal at `p` (on the surface, lens frame) pointing toward the scene (−z) at the
    /// vertex: ∇(sag(ρ) − z) = (2x·sag′, 2y·sag′, −1). `None` where the sag is undefined.
    pub fn normal(&self, vertex_z: T, p: [T; 3]) -> Option<[T; 3]> {
        if !self.polynomial {
            // The quadric's gradient (c·x, c·y, κc·z − 1): exact and defined at the rim of a
            // hemisphere, where sag′ is infinite.
            let c = self.curvature;
            let z = p[2] - vertex_z;
            return Some(normalize([
                c * p[0],
                c * p[1],
                self.conic_factor * c * z - T::one(),
            ]));
        }
        let (_, slope) = self.sag_and_slope(p[0] * p[0] + p[1] * p[1])?;
        let two_slope = (T::one() + T::one()) * slope;
        Some(normalize([two_slope * p[0], two_slope * p[1], -T::one()]))
    }

    /// Distance along `ray` (unit direction) to the surface whose vertex is at `vertex_z`, if
    /// the ray meets it ahead of its origin.
    pub fn intersect(&self, vertex_z: T, ray: &Ray<T>) -> Option<T> {
        let base = self.intersect_quadric(vertex_z, ray);
        if !self.polynomial {
            return base;
        }
        // Start Newton from the base conic; where the ray misses it (a strong polynomial can
        // bend the surface into the ray's way), from the vertex plane if that is ahead, else
        // from the ray's origin (a ray leaving a neighbouring surface whose rim reaches past
        // this vertex plane).
        let start = base.unwrap_or_else(|| {
            let dz = ray.direction[2];
            let t = (vertex_z - ray.origin[2]) / dz;
            if t > T::zero() { t } else { T::zero() }
        });
        self.newton(vertex_z, ray, start)
    }

    /// The base conic's intersection (closed form): the smaller positive root on the sheet
    /// through the vertex.
    ///
    /// Along o + t·d (o relative to the vertex, |d| = 1) the quadric is a·t² + 2b·t + q₀ = 0 with
    /// a = c(1 + k·d_z²), b = c(o_x d_x + o_y d_y + κ o_z d_z) − d_z, q₀ = c(o_x² + o_y² + κ o_z²)
    /// − 2o_z. With q = −b − sign(b)·√(b² − a·q₀) (two terms of one sign: no cancellation) the
    /// roots are q₀/q, which tends to the plane's as c → 0, and q/a.
    pub fn intersect_quadric(&self, vertex_z: T, ray: &Ray<T>) -> Option<T> {
        let [ox, oy, oz] = ray.origin;
        let [dx, dy, dz] = ray.direction;
        let oz = oz - vertex_z;
        let c = self.curvature;
        let kappa = self.conic_factor;
        let one = T::one();
        let two = one + one;
        let a = c * (one + (kappa - one) * dz * dz);
        let b = c * (ox * dx + oy * dy + kappa * oz * dz) - dz;
        let q0 = c * (ox * ox + oy * oy + kappa * oz * oz) - two * oz;
        let discriminant = b * b - a * q0;
        if discriminant < T::zero() {
            return None;
        }
        let root = discriminant.sqrt();
        let q = if b < T::zero() { root - b } else { -b - root };
        let epsilon = T::from(1e-9).unwrap_or_else(T::epsilon);
        let mut best: Option<T> = None;
        for t in [q0 / q, q / a] {
            // On the vertex sheet, 1 − κc·z > 0 (κc·z < 1; for a sphere: nearer the vertex
            // than the equator).
            let z = oz + t * dz;
            let on_vertex_sheet = kappa * c * z < one;
            if t > epsilon && t.is_finite() && on_vertex_sheet && best.is_none_or(|b| t < b) {
                best = Some(t);
            }
        }
        best
    }

    /// Newton's method on f(t) = z(t) − sag(ρ(t)), f′(t) = d_z − 2·sag′·(x·d_x + y·d_y), from
    /// `t`; converged when a step is below 1e-10 mm (the point is then within 1e-9 mm of the
    /// surface along the ray), else a miss.
    ///
    /// z is taken from the vertex (o_z − z_vertex once, then + t·d_z), and in a precision that
    /// cannot resolve 1e-10 mm (f32) a step counts as converged within a few ulps of the
    /// lengths it is computed from: the distance, the origin's height over the vertex, the sag.
    fn newton(&self, vertex_z: T, ray: &Ray<T>, mut t: T) -> Option<T> {
        let tolerance = T::from(1e-10).unwrap();
        let relative = T::epsilon() * T::from(16.0).unwrap();
        let [ox, oy, oz] = ray.origin;
        let [dx, dy, dz] = ray.direction;
        let oz = oz - vertex_z;
        let two = T::one() + T::one();
        for _ in 0..MAX_NEWTON_STEPS {
            let x = ox + t * dx;
            let y = oy + t * dy;
            let z = oz + t * dz;
            let (sag, slope) = self.sag_and_slope(x * x + y * y)?;
            let f = z - sag;
            let derivative = dz - two * slope * (x * dx + y * dy);
            if derivative == T::zero() || !derivative.is_finite() {
                return None;
            }
            let step = f / derivative;
            t = t - step;
            if !t.is_finite() {
                return None;
            }
            let scale = t.abs() + oz.abs() + sag.abs();
            if step.abs() <= tolerance.max(relative * scale) {
                return (t > T::from(1e-9).unwrap_or_else(T::epsilon)).then_some(t);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile(radius: f64, conic: f64, coefficients: &[f64]) -> Profile<f64> {
        let mut asphere = Asphere {
            conic,
            ..Asphere::NONE
        };
        asphere.coefficients[..coefficients.len()].copy_from_slice(coefficients);
        Profile::new(1.0 / radius, &asphere, |v| v)
    }

    /// A strongly aspheric surface of the kind phone lenses use (a 4 mm aperture).
    fn phone_asphere() -> Profile<f64> {
        profile(3.2, -1.8, &[0.0, 1.2e-2, -3.1e-3, 4.0e-4, -2.0e-5])
    }

    #[test]
    fn sphere_sag_is_the_circle() {
        let p = profile(-40.0, 0.0, &[]);
        let h: f64 = 10.0;
        let expected = -(40.0 - (40.0f64 * 40.0 - h * h).sqrt());
        assert!((p.sag(h).unwrap() - expected).abs() < 1e-12);
    }

    #[test]
    fn conic_sag_solves_the_conic_equation() {
        // c·ρ + κc·z² − 2z = 0 on every conic type.
        for k in [-3.0, -1.0, -0.5, 0.0, 0.7] {
            let p = profile(25.0, k, &[]);
            for h in [0.5, 3.0, 8.0] {
                let z = p.sag(h).unwrap();
                let c = 1.0 / 25.0;
                let residual = c * h * h + (1.0 + k) * c * z * z - 2.0 * z;
                assert!(residual.abs() < 1e-13, "k {k} h {h}: {residual}");
            }
        }
        // A paraboloid is z = c·r²/2 exactly.
        let p = profile(10.0, -1.0, &[]);
        assert!((p.sag(4.0).unwrap() - 0.1 * 16.0 / 2.0).abs() < 1e-14);
    }

    #[test]
    fn slope_and_normal_match_finite_differences() {
        let p = phone_asphere();
        for h in [0.0, 0.3, 1.1, 1.9] {
            let rho: f64 = h * h;
            let (_, slope) = p.sag_and_slope(rho).unwrap();
            let e = 1e-6;
            let numeric = (p.sag_and_slope(rho + e).unwrap().0
                - p.sag_and_slope(rho - e).unwrap().0)
                / (2.0 * e);
            assert!(
                (slope - numeric).abs() < 1e-7 * (1.0 + slope.abs()),
                "{slope} {numeric}"
            );
            // The normal is perpendicular to the surface's tangent along x and along y.
            let (x, y) = (h * 0.6, h * 0.8);
            let z = |x: f64, y: f64| p.sag((x * x + y * y).sqrt()).unwrap();
            let point = [x, y, 5.0 + z(x, y)];
            let n = p.normal(5.0, point).unwrap();
            let tangent_x = [2.0 * e, 0.0, z(x + e, y) - z(x - e, y)];
            let tangent_y = [0.0, 2.0 * e, z(x, y + e) - z(x, y - e)];
            for t in [tangent_x, tangent_y] {
                let t = normalize(t);
                let cos = n[0] * t[0] + n[1] * t[1] + n[2] * t[2];
                assert!(cos.abs() < 1e-8, "h {h}: normal·tangent {cos}");
            }
            assert!(n[2] < 0.0, "normal faces the scene");
        }
    }

    #[test]
    fn sag_is_undefined_beyond_the_conic_rim() {
        let p = profile(10.0, 0.0, &[]);
        assert!(p.sag(9.9999).is_some());
        assert!(p.sag(10.001).is_none());
        // An oblate ellipsoid (k > 0) closes before its base sphere does.
        let p = profile(10.0, 1.0, &[]);
        assert!(p.sag(7.0).is_some() && p.sag(7.1).is_none());
    }

    /// The Newton intersection against bisection along the ray on f(t) = z(t) − sag(ρ(t)).
    #[test]
    fn intersection_agrees_with_bisection() {
        let p = phone_asphere();
        let vertex_z = 2.0;
        let mut checked = 0;
        for i in 0..40 {
            let angle = -0.5 + i as f64 * 0.025;
            for start_x in [-1.5, -0.4, 0.0, 0.9, 1.6] {
                let origin = [start_x, 0.3 * start_x, -3.0];
                let direction = normalize([angle.sin(), 0.2 * angle, angle.cos()]);
                let ray = Ray { origin, direction };
                let f = |t: f64| {
                    let x = origin[0] + t * direction[0];
                    let y = origin[1] + t * direction[1];
                    let z = origin[2] + t * direction[2] - vertex_z;
                    p.sag_and_slope(x * x + y * y).map(|(s, _)| z - s)
                };
                // Bracket the first sign change from the origin, then bisect.
                let mut lo = 0.0;
                let mut bracket = None;
                for k in 1..=4000 {
                    let hi = k as f64 * 0.005;
                    match (f(lo), f(hi)) {
                        (Some(a), Some(b)) if a.signum() != b.signum() => {
                            bracket = Some((lo, hi));
                            break;
                        }
                        (_, None) => break,
                        _ => lo = hi,
                    }
                }
                let Some((mut lo, mut hi)) = bracket else {
                    continue;
                };
                let sign_lo = f(lo).unwrap().signum();
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if f(mid).unwrap().signum() == sign_lo {
                        lo = mid
                    } else {
                        hi = mid
                    }
                }
                let t = p.intersect(vertex_z, &ray).expect("Newton finds the root");
                assert!(
                    (t - lo).abs() < 1e-9,
                    "angle {angle} x {start_x}: {t} vs {lo}"
                );
                checked += 1;
            }
        }
        assert!(checked > 150, "{checked}");
    }

    #[test]
    fn scaling_keeps_the_shape() {
        let p = phone_asphere();
        let mut asphere = Asphere {
            conic: -1.8,
            ..Asphere::NONE
        };
        asphere.coefficients[1..5].copy_from_slice(&[1.2e-2, -3.1e-3, 4.0e-4, -2.0e-5]);
        let scaled = Profile::new(1.0 / (3.2 * 25.4), &asphere.scaled(25.4), |v| v);
        for h in [0.2, 1.0, 1.8] {
            let a = p.sag(h).unwrap() * 25.4;
            let b = scaled.sag(h * 25.4).unwrap();
            assert!((a - b).abs() < 1e-10 * a.abs().max(1.0), "{a} {b}");
        }
    }
}
