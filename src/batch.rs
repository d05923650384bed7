//! Structure-of-arrays ray batches: the form in which rays travel between pipeline stages.
//!
//! One array per component, so the hot loops over a batch touch contiguous `f32`s and the
//! compiler can vectorise them. The same type carries rays in the lens frame (mm, see
//! [`crate::lens`]) and in the world frame (metres, see [`crate::scene`]); each stage says which.

/// A batch of rays with per-ray throughput, pixel and liveness.
#[derive(Clone, Debug, Default)]
pub struct RayBatch {
    pub ox: Vec<f32>,
    pub oy: Vec<f32>,
    pub oz: Vec<f32>,
    pub dx: Vec<f32>,
    pub dy: Vec<f32>,
    pub dz: Vec<f32>,
    /// Linear RGB throughput (the lens weight lands here in the Weight stage).
    pub tr: Vec<f32>,
    pub tg: Vec<f32>,
    pub tb: Vec<f32>,
    /// Index of the film pixel the ray belongs to (row-major over the whole image).
    pub pixel: Vec<u32>,
    /// Index of the sample within its pixel (the key of its random stream).
    pub sample: Vec<u32>,
    /// False once the ray is blocked (by the lens) or finished.
    pub alive: Vec<bool>,
}

impl RayBatch {
    pub fn with_capacity(n: usize) -> Self {
        RayBatch {
            ox: Vec::with_capacity(n),
            oy: Vec::with_capacity(n),
            oz: Vec::with_capacity(n),
            dx: Vec::with_capacity(n),
            dy: Vec::with_capacity(n),
            dz: Vec::with_capacity(n),
            tr: Vec::with_capacity(n),
            tg: Vec::with_capacity(n),
            tb: Vec::with_capacity(n),
            pixel: Vec::with_capacity(n),
            sample: Vec::with_capacity(n),
            alive: Vec::with_capacity(n),
        }
    }

    pub fn len(&self) -> usize {
        self.ox.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ox.is_empty()
    }

    /// Room for `additional` more rays in every array, so that growing to that many
    /// allocates nothing.
    pub fn reserve(&mut self, additional: usize) {
        for v in self.float_arrays() {
            v.reserve(additional);
        }
        self.pixel.reserve(additional);
        self.sample.reserve(additional);
        self.alive.reserve(additional);
    }

    /// Origins, directions and throughputs: the arrays of `f32`.
    fn float_arrays(&mut self) -> [&mut Vec<f32>; 9] {
        [
            &mut self.ox,
            &mut self.oy,
            &mut self.oz,
            &mut self.dx,
            &mut self.dy,
            &mut self.dz,
            &mut self.tr,
            &mut self.tg,
            &mut self.tb,
        ]
    }

    pub fn clear(&mut self) {
        for v in self.float_arrays() {
            v.clear();
        }
        self.pixel.clear();
        self.sample.clear();
        self.alive.clear();
    }

    /// Sets every array to `n` rays; new rays have unit throughput and are alive, with zero
    /// origin, direction, pixel and sample, for a stage that fills them in place by index.
    pub fn resize(&mut self, n: usize) {
        let [ox, oy, oz, dx, dy, dz, tr, tg, tb] = self.float_arrays();
        for v in [ox, oy, oz, dx, dy, dz] {
            v.resize(n, 0.0);
        }
        for v in [tr, tg, tb] {
            v.resize(n, 1.0);
        }
        self.pixel.resize(n, 0);
        self.sample.resize(n, 0);
        self.alive.resize(n, true);
    }

    /// Appends one ray with unit throughput.
    pub fn push(&mut self, origin: [f32; 3], direction: [f32; 3], pixel: u32, sample: u32) {
        self.ox.push(origin[0]);
        self.oy.push(origin[1]);
        self.oz.push(origin[2]);
        self.dx.push(direction[0]);
        self.dy.push(direction[1]);
        self.dz.push(direction[2]);
        self.tr.push(1.0);
        self.tg.push(1.0);
        self.tb.push(1.0);
        self.pixel.push(pixel);
        self.sample.push(sample);
        self.alive.push(true);
    }

    pub fn origin(&self, i: usize) -> [f32; 3] {
        [self.ox[i], self.oy[i], self.oz[i]]
    }

    pub fn direction(&self, i: usize) -> [f32; 3] {
        [self.dx[i], self.dy[i], self.dz[i]]
    }

    pub fn alive_count(&self) -> usize {
        self.alive.iter().filter(|&&a| a).count()
    }
}

/// A ray–triangle hit: one entry of a [`HitBatch`], and what the one-ray queries of
/// [`crate::accel::SceneAccel`] return.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Triangle index in [`crate::accel::SceneAccel`] order.
    pub triangle: u32,
    /// Barycentric weights of vertices 1 and 2.
    pub u: f32,
    pub v: f32,
}

/// Closest hits of a [`RayBatch`] against the scene, one entry per ray.
#[derive(Clone, Debug, Default)]
pub struct HitBatch {
    /// Distance along the (unit) ray direction; `f32::INFINITY` for a miss.
    pub t: Vec<f32>,
    /// Triangle index in [`crate::accel::SceneAccel`] order; `u32::MAX` for a miss.
    pub triangle: Vec<u32>,
    /// Barycentric coordinates of the hit (weights of vertices 1 and 2).
    pub u: Vec<f32>,
    pub v: Vec<f32>,
}

impl HitBatch {
    pub const MISS: u32 = u32::MAX;

    /// Room for `additional` more hits, so that growing to that many allocates nothing.
    pub fn reserve(&mut self, additional: usize) {
        self.t.reserve(additional);
        self.triangle.reserve(additional);
        self.u.reserve(additional);
        self.v.reserve(additional);
    }

    pub fn resize(&mut self, n: usize) {
        self.t.clear();
        self.t.resize(n, f32::INFINITY);
        self.triangle.clear();
        self.triangle.resize(n, Self::MISS);
        self.u.clear();
        self.u.resize(n, 0.0);
        self.v.clear();
        self.v.resize(n, 0.0);
    }

    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// The closest hit of ray `i`, `None` for a miss.
    pub fn hit(&self, i: usize) -> Option<Hit> {
        (self.triangle[i] != Self::MISS).then(|| Hit {
            t: self.t[i],
            triangle: self.triangle[i],
            u: self.u[i],
            v: self.v[i],
        })
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
}
