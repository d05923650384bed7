//! Ray–scene intersection: an obvhs BVH over every world-space triangle of the scene.
//!
//! Built once per scene in the BuildBvh stage; read by Trace (camera rays, in batches) and by
//! Shade (bounce and shadow rays). World frame, metres (see [`crate::scene`]).
//!
//! The BVH is an 8-wide compressed CWBVH built with PLOC (obvhs `fast_build`: no spatial
//! pre-splits, which would list a triangle in several leaves and break the one-to-one triangle
//! order). Triangle data is stored in BVH order, so the index obvhs reports *is* the triangle
//! index ([`Hit::triangle`]). Ray directions are expected to be unit vectors; hit distances are
//! in metres along them.
//!
//! The CPU traverses its own copy of that tree (`wide`): the same nodes and leaves with the
//! child boxes decoded once to floats, tested eight at a time with a rounding margin, nearest
//! child first (`wide_traversal`), and batches of camera and bounce rays eight at a time
//! (module `packet`; bounce rays one at a time where their packets run too sparse to pay,
//! module `packet_use`). obvhs's own traversal of its compressed nodes (and the same loop with an
//! AVX2 node test, `traversal.rs`) stays as the reference: the wide traversals give its
//! closest hits, up to which of two triangles at exactly the same distance is reported
//! ([`SceneAccel::intersect_with`]; the tests in `tests.rs`). The GPU backend uploads the
//! compressed tree itself.

mod alpha_mask;
#[cfg(target_arch = "x86_64")]
mod packet;
mod packet_use;
pub mod spawn;
mod surface;
mod traversal;
mod triangles;
mod wide;
mod wide_traversal;

#[cfg(test)]
mod tests;

use std::time::{Duration, Instant};

use bevy_ecs::resource::Resource;
use glam::{Vec2, Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use rayon::prelude::*;

use crate::batch::{Hit, HitBatch, RayBatch};
use crate::scene::{Bounds, MaterialLibrary, MeshInstance};

use alpha_mask::AlphaMasks;
use wide::WideBvh;
/// The packet traversal's stack type, a placeholder where there is no packet traversal.
mod packet_stack {
    #[cfg(target_arch = "x86_64")]
    pub type Entry = super::packet::StackEntry;
    #[cfg(not(target_arch = "x86_64"))]
    pub type Entry = ();
}
use packet_use::Walk;
pub use packet_use::{PacketGauge, PacketUse};
pub use traversal::Traversal;
use triangles::TriangleHit;
pub(crate) use triangles::{
    NO_MATERIAL, TrianglePrimitive, TriangleRecord, WorldVertices, attributes,
};

/// The shading frame and attributes at a hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub position: Vec3,
    /// Unit geometric normal, facing the side the ray came from.
    pub geometric_normal: Vec3,
    /// Unit interpolated vertex normal (before normal mapping), same hemisphere as the geometric one.
    pub shading_normal: Vec3,
    /// Unit tangent along +u for normal mapping (w = bitangent sign), zero if unavailable.
    /// On a back face the whole tangent frame is mirrored with the normal (xyz and w negated),
    /// so a normal map perturbs the back face as the mirror image of the front.
    pub tangent: glam::Vec4,
    pub uv: Vec2,
    /// Index into the material library (`None` = default material).
    pub material: Option<usize>,
    /// True when the ray hit the side the geometric normal (winding) points away from.
    pub back_face: bool,
    /// How far along the geometric normal a ray leaving this point must start to clear its
    /// own triangle (see [`SurfacePoint::spawn_origin`]), metres.
    pub spawn_offset: f32,
}

/// The scene's BVH and the triangle data it indexes, in BVH order.
#[derive(Resource)]
pub struct SceneAccel {
    /// `None` when the scene has no usable triangle. (Crate-visible, like the triangle data
    /// below, for the GPU backend, which uploads it as it is: `crate::gpu::scene`.)
    pub(crate) bvh: Option<CwBvh>,
    /// Positions in BVH space (world × `bvh_scale`), BVH order.
    pub(crate) primitives: Vec<TrianglePrimitive>,
    /// Vertex indices, material and attribute flags, BVH order.
    pub(crate) records: Vec<TriangleRecord>,
    pub(crate) vertices: WorldVertices,
    alpha_masks: AlphaMasks,
    /// World → BVH space scale, an exact power of two (see `triangles::bvh_space_scale`).
    pub(crate) bvh_scale: f32,
    /// 1 / `bvh_scale`, exact: multiplying by it divides by `bvh_scale` bit for bit (both are
    /// the correctly rounded x·2⁻ᵏ), for a fraction of a division's cost.
    world_per_bvh_unit: f32,
    /// The same tree with float boxes, for the CPU's own traversal (`None` for an empty scene
    /// or a tree it cannot hold: see [`WideBvh::from_cwbvh`]).
    wide: Option<WideBvh>,
    bounds: Bounds,
    dropped_triangles: usize,
    build_time: Duration,
    /// The faster traversal of obvhs's nodes on this CPU ([`Traversal::fastest_obvhs`]),
    /// detected once at build: the fallback, and whether the packets' AVX2 code runs.
    obvhs_traversal: Traversal,
}

impl SceneAccel {
    /// Builds the BVH over every instance's triangles. Degenerate and non-finite triangles are
    /// dropped (see [`SceneAccel::dropped_triangle_count`]). An empty scene gives an
    /// accelerator every ray misses.
    pub fn build<'a>(
        instances: impl IntoIterator<Item = &'a MeshInstance>,
        materials: &MaterialLibrary,
    ) -> anyhow::Result<SceneAccel> {
        let start = Instant::now();
        let soup = triangles::flatten_instances(instances);
        if soup.positions.len() >= u32::MAX as usize {
            anyhow::bail!(
                "the scene has {} triangles; at most {} are supported",
                soup.positions.len(),
                u32::MAX - 1
            );
        }
        let bvh_scale = triangles::bvh_space_scale(&soup.bounds);
        let obvhs_triangles: Vec<Triangle> = soup
            .positions
            .par_iter()
            .map(|&[a, b, c]| Triangle {
                v0: Vec3A::from(a * bvh_scale),
                v1: Vec3A::from(b * bvh_scale),
                v2: Vec3A::from(c * bvh_scale),
            })
            .collect();

        let (bvh, primitives, records) = if obvhs_triangles.is_empty() {
            (None, Vec::new(), Vec::new())
        } else {
            // obvhs's `fast_build` (a narrower PLOC search and less reinsertion than
            // `medium_build`): on the peer scenes the wide traversal is as fast through its trees
            // (bvh bench, per ray: within ±3 %), and the 1M-triangle build is 7 % shorter.
            let bvh = build_cwbvh_from_tris(
                &obvhs_triangles,
                BvhBuildParams::fast_build(),
                &mut Duration::default(),
            );
            if bvh.primitive_indices.len() != obvhs_triangles.len() {
                anyhow::bail!(
                    "BVH build listed {} primitives for {} triangles",
                    bvh.primitive_indices.len(),
                    obvhs_triangles.len()
                );
            }
            let primitives = bvh
                .primitive_indices
                .par_iter()
                .map(|&i| {
                    let t = &obvhs_triangles[i as usize];
                    TrianglePrimitive::new(t.v0, t.v1, t.v2)
                })
                .collect();
            let records = bvh
                .primitive_indices
                .par_iter()
                .map(|&i| soup.records[i as usize])
                .collect();
            (Some(bvh), primitives, records)
        };
        let wide = bvh.as_ref().and_then(WideBvh::from_cwbvh);

        Ok(SceneAccel {
            bvh,
            primitives,
            records,
            vertices: soup.vertices,
            alpha_masks: AlphaMasks::new(materials),
            bvh_scale,
            world_per_bvh_unit: 1.0 / bvh_scale,
            wide,
            bounds: soup.bounds,
            dropped_triangles: soup.dropped,
            build_time: start.elapsed(),
            obvhs_traversal: Traversal::fastest_obvhs(),
        })
    }

    pub fn triangle_count(&self) -> usize {
        self.primitives.len()
    }

    pub fn node_count(&self) -> usize {
        self.bvh.as_ref().map_or(0, |bvh| bvh.nodes.len())
    }

    /// Wall time of [`SceneAccel::build`]: world transform, BVH build and reordering.
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// Input triangles left out as degenerate (zero area) or non-finite.
    pub fn dropped_triangle_count(&self) -> usize {
        self.dropped_triangles
    }

    /// World-space bounds of all kept triangles (empty for an empty scene).
    pub fn bounds(&self) -> Bounds {
        self.bounds
    }

    /// Closest hit in (t_min, t_max), skipping alpha-masked holes.
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<Hit> {
        self.intersect_with(Traversal::Wide, origin, direction, t_max)
    }

    /// What answers a query asked of `traversal`: itself where it runs here, else the fastest
    /// that does.
    #[inline(always)]
    fn runnable(&self, traversal: Traversal) -> Traversal {
        match traversal {
            Traversal::Wide if self.wide.is_some() => Traversal::Wide,
            Traversal::Obvhs => Traversal::Obvhs,
            _ => self.obvhs_traversal,
        }
    }

    /// [`SceneAccel::intersect`] through the given traversal (or, where it does not run here,
    /// the fastest that does). Every traversal gives the same answer, to exact ties; this is
    /// for comparing them.
    pub fn intersect_with(
        &self,
        traversal: Traversal,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
    ) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let ray = self.bvh_ray(origin, direction, t_max)?;
        let traversal = self.runnable(traversal);
        if traversal == Traversal::Wide {
            return self.to_hit(self.wide_closest(ray));
        }
        let mut closest: Option<(usize, TriangleHit)> = None;
        let test = |ray: &Ray, index| {
            match self.hit_triangle(ray, index) {
                // Traversal accepts t < tmax only; the triangle test is inclusive, so check
                // here too.
                Some(hit) if hit.t < ray.tmax => {
                    closest = Some((index, hit));
                    hit.t
                }
                _ => f32::INFINITY,
            }
        };
        match traversal {
            // SAFETY: `runnable` picks Avx2 only where `Traversal::fastest_obvhs` found it.
            #[cfg(target_arch = "x86_64")]
            Traversal::Avx2 => unsafe { traversal::ray_traverse_avx2(bvh, ray, test) },
            _ => {
                bvh.ray_traverse(ray, &mut RayHit::none(), test);
            }
        }
        self.to_hit(closest)
    }

    /// A BVH-space hit as the world-space [`Hit`].
    #[inline(always)]
    fn to_hit(&self, closest: Option<(usize, TriangleHit)>) -> Option<Hit> {
        closest.map(|(index, hit)| Hit {
            t: hit.t * self.world_per_bvh_unit,
            triangle: index as u32,
            u: hit.u,
            v: hit.v,
        })
    }

    /// Any hit in (t_min, t_max), skipping alpha-masked holes (shadow rays).
    ///
    /// Stops at the first opaque hit found (like obvhs `ray_traverse_miss`; its
    /// `ray_traverse_anyhit` visits every hit without stopping).
    pub fn occluded(&self, origin: Vec3, direction: Vec3, t_max: f32) -> bool {
        self.occluded_with(Traversal::Wide, origin, direction, t_max)
    }

    /// [`SceneAccel::occluded`] through the given traversal (or the fastest that runs here).
    pub fn occluded_with(
        &self,
        traversal: Traversal,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
    ) -> bool {
        let (Some(bvh), Some(ray)) = (self.bvh.as_ref(), self.bvh_ray(origin, direction, t_max))
        else {
            return false;
        };
        let test = |ray: &Ray, index| {
            self.hit_triangle(ray, index)
                .map_or(f32::INFINITY, |hit| hit.t)
        };
        match self.runnable(traversal) {
            Traversal::Obvhs => !bvh.ray_traverse_miss(ray, test),
            // SAFETY: `runnable` picks Avx2 only where `Traversal::fastest_obvhs` found it.
            #[cfg(target_arch = "x86_64")]
            Traversal::Avx2 => unsafe { !traversal::ray_traverse_miss_avx2(bvh, ray, test) },
            Traversal::Wide => self.wide_any_hit(ray),
            #[cfg(not(target_arch = "x86_64"))]
            Traversal::Avx2 => unreachable!("only x86-64 runs the AVX2 traversal"),
        }
    }

    /// Closest hits of every alive ray of the batch (dead rays get a miss): the same hits
    /// [`SceneAccel::intersect`] gives each ray.
    ///
    /// Rays are traced in packets of eight consecutive rays where the CPU has AVX2 (see
    /// module `packet`): the renderer's camera rays are neighbouring pixels, coherent enough that a
    /// packet walks nearly the nodes each of its rays would. A packet whose rays disagree in
    /// direction octant, or with a single alive ray, goes one ray at a time. Hits are those of
    /// [`SceneAccel::intersect`], to exact ties.
    pub fn intersect_batch(&self, rays: &RayBatch, hits: &mut HitBatch) {
        self.intersect_batch_with(rays, hits, BatchParallelism::Spread);
    }

    /// [`SceneAccel::intersect_batch`], its rays shared among the threads as `parallelism`
    /// says (the same hits either way).
    pub fn intersect_batch_with(
        &self,
        rays: &RayBatch,
        hits: &mut HitBatch,
        parallelism: BatchParallelism,
    ) {
        self.intersect_batch_using(rays, hits, parallelism, PacketUse::Always);
    }

    /// [`SceneAccel::intersect_batch_with`], its rays walking the tree in packets as
    /// `packets` says (the same hits whichever way: see [`PacketUse`]), a
    /// [`PacketUse::WherePaying`] batch measured from scratch. Spread over the threads, a
    /// task's 64 rays are too few to measure, so there every packet walks as one.
    pub fn intersect_batch_using(
        &self,
        rays: &RayBatch,
        hits: &mut HitBatch,
        parallelism: BatchParallelism,
        packets: PacketUse,
    ) {
        self.trace_batch(
            rays,
            hits,
            parallelism,
            packets,
            &mut PacketGauge::default(),
        );
    }

    /// [`SceneAccel::intersect_batch_with`] on this thread alone, packets walking where they
    /// pay ([`PacketUse::WherePaying`]) by `gauge`'s measure, which the caller keeps from one
    /// batch of a kind to the next (a thread's bounce rays): small batches then need no
    /// measure of their own.
    pub fn intersect_batch_gauged(
        &self,
        rays: &RayBatch,
        hits: &mut HitBatch,
        gauge: &mut PacketGauge,
    ) {
        gauge.fade();
        self.trace_batch(
            rays,
            hits,
            BatchParallelism::OneThread,
            PacketUse::WherePaying,
            gauge,
        );
    }

    /// The batch calls' work; `gauge` measures a one-thread [`PacketUse::WherePaying`] batch.
    fn trace_batch(
        &self,
        rays: &RayBatch,
        hits: &mut HitBatch,
        parallelism: BatchParallelism,
        packets: PacketUse,
        gauge: &mut PacketGauge,
    ) {
        const CHUNK: usize = 64;
        let packets = match (parallelism, packets) {
            (BatchParallelism::Spread, PacketUse::WherePaying) => PacketUse::Always,
            (_, packets) => packets,
        };
        hits.resize(rays.len());
        let HitBatch { t, triangle, u, v } = hits;
        // Rays first.. of the batch, packet by packet, their hits written in place.
        let trace_packets = |stack: &mut Vec<packet_stack::Entry>,
                             gauge: &mut PacketGauge,
                             first: usize,
                             t: &mut [f32],
                             triangle: &mut [u32],
                             u: &mut [f32],
                             v: &mut [f32]| {
            for (index, p) in (0..t.len()).step_by(PACKET_RAYS).enumerate() {
                let end = (p + PACKET_RAYS).min(t.len());
                let out = HitSlices {
                    t: &mut t[p..end],
                    triangle: &mut triangle[p..end],
                    u: &mut u[p..end],
                    v: &mut v[p..end],
                };
                let walk = gauge.walk(packets, index);
                self.intersect_packet(rays, first + p, out, stack, walk, gauge);
            }
        };
        match parallelism {
            // The thread's own stack, kept from call to call: nothing allocated per batch.
            BatchParallelism::OneThread => PACKET_STACK
                .with_borrow_mut(|stack| trace_packets(stack, gauge, 0, t, triangle, u, v)),
            // Packets never straddle tasks (the chunk length is a multiple of the packet
            // size), so the packets, and the hits, are those of one thread.
            BatchParallelism::Spread => t
                .par_chunks_mut(CHUNK)
                .zip(triangle.par_chunks_mut(CHUNK))
                .zip(u.par_chunks_mut(CHUNK))
                .zip(v.par_chunks_mut(CHUNK))
                .enumerate()
                .for_each_init(Vec::new, |stack, (chunk, (((t, triangle), u), v))| {
                    // Every packet walks (see above): nothing to measure.
                    let mut unused = PacketGauge::default();
                    trace_packets(stack, &mut unused, chunk * CHUNK, t, triangle, u, v)
                }),
        }
    }

    /// Closest hits of rays `first..first + out.len()` (at most eight) of the batch, written
    /// to `out` (which holds misses on entry): as one packet unless `walk` says single rays
    /// (or the rays cannot go as one), a probe counting into `gauge` how full it ran.
    #[cfg_attr(not(target_arch = "x86_64"), allow(unused_variables))]
    fn intersect_packet(
        &self,
        rays: &RayBatch,
        first: usize,
        out: HitSlices,
        stack: &mut Vec<packet_stack::Entry>,
        walk: Walk,
        gauge: &mut PacketGauge,
    ) {
        let n = out.t.len();
        #[cfg(target_arch = "x86_64")]
        if self.obvhs_traversal == Traversal::Avx2
            && walk != Walk::Single
            && let Some(wide) = self.wide.as_ref()
        {
            let mut packet = packet::PacketRays::default();
            let mut active = 0u32;
            let mut octants = 0u8;
            for (lane, ray) in (first..first + n).enumerate() {
                if !rays.alive[ray] {
                    continue;
                }
                let d = rays.direction(ray);
                if let Some(r) =
                    self.bvh_ray(Vec3::from(rays.origin(ray)), Vec3::from(d), f32::INFINITY)
                {
                    packet.set(lane, &r);
                    active |= 1 << lane;
                    // obvhs's octant test: `d < 0` per axis.
                    octants |= 1
                        << (u8::from(d[0] < 0.0)
                            | u8::from(d[1] < 0.0) << 1
                            | u8::from(d[2] < 0.0) << 2);
                }
            }
            if active.count_ones() > 1 && octants.count_ones() == 1 {
                // Lanes without a ray carry a copy of an alive one, masked off.
                let lead = active.trailing_zeros() as usize;
                for lane in 0..packet::LANES {
                    if active & (1 << lane) == 0 {
                        packet.copy_lane(lead, lane);
                    }
                }
                // SAFETY: `Traversal::fastest_obvhs` found AVX2 on this CPU.
                let hits = unsafe {
                    packet::intersect_packet_avx2(
                        wide,
                        &self.primitives,
                        &packet,
                        active,
                        self.alpha_masks
                            .any()
                            .then_some(|index, u, v| self.is_alpha_hole(index as u32, u, v)),
                        stack,
                        walk == Walk::Probe,
                    )
                };
                gauge.add(hits.visits, hits.rays_at_visits);
                for lane in 0..n {
                    if hits.triangle[lane] != u32::MAX {
                        out.t[lane] = hits.t[lane] * self.world_per_bvh_unit;
                        out.triangle[lane] = hits.triangle[lane];
                        out.u[lane] = hits.u[lane];
                        out.v[lane] = hits.v[lane];
                    }
                }
                return;
            }
        }
        for lane in 0..n {
            let i = first + lane;
            if !rays.alive[i] {
                continue;
            }
            let hit = self.intersect(
                Vec3::from(rays.origin(i)),
                Vec3::from(rays.direction(i)),
                f32::INFINITY,
            );
            if let Some(hit) = hit {
                out.t[lane] = hit.t;
                out.triangle[lane] = hit.triangle;
                out.u[lane] = hit.u;
                out.v[lane] = hit.v;
            }
        }
    }

    /// World-space vertices of a triangle (zeros for an index out of range).
    pub fn triangle_vertices(&self, triangle: u32) -> [Vec3; 3] {
        self.primitives
            .get(triangle as usize)
            .map_or([Vec3::ZERO; 3], |p| {
                p.vertices()
                    .map(|v| Vec3::from(v) * self.world_per_bvh_unit)
            })
    }

    /// The material of a triangle (`None` = the library's default material).
    pub fn triangle_material(&self, triangle: u32) -> Option<usize> {
        self.records
            .get(triangle as usize)
            .and_then(|r| (r.material != NO_MATERIAL).then_some(r.material as usize))
    }

    /// Texture coordinates at barycentrics (u, v) of a triangle; zero without UVs.
    pub fn uv_at(&self, triangle: u32, u: f32, v: f32) -> Vec2 {
        match self.records.get(triangle as usize) {
            Some(record) if record.attributes & attributes::UVS != 0 => {
                let [a, b, c] = record.vertices.map(|i| self.vertices.uvs[i as usize]);
                a * (1.0 - u - v) + b * u + c * v
            }
            _ => Vec2::ZERO,
        }
    }

    /// True when the point at barycentrics (u, v) of a triangle lies in an alpha-mask hole.
    pub fn is_alpha_hole(&self, triangle: u32, u: f32, v: f32) -> bool {
        self.alpha_masks.any()
            && self.records.get(triangle as usize).is_some_and(|record| {
                self.alpha_masks
                    .is_hole(record.material, self.uv_at(triangle, u, v))
            })
    }

    /// The ray in BVH space, or `None` for input no ray can be made of.
    fn bvh_ray(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<Ray> {
        if !(origin.is_finite() && direction.is_finite() && direction != Vec3::ZERO && t_max > 0.0)
        {
            return None;
        }
        Some(Ray::new(
            Vec3A::from(origin * self.bvh_scale),
            Vec3A::from(direction),
            0.0,
            t_max * self.bvh_scale,
        ))
    }

    /// Closest hit through the wide BVH (`runnable` checked it is there).
    #[inline(always)]
    fn wide_closest(&self, ray: Ray) -> Option<(usize, TriangleHit)> {
        self.wide_first_hit::<false>(ray)
    }

    /// Any hit through the wide BVH.
    #[inline(always)]
    fn wide_any_hit(&self, ray: Ray) -> bool {
        self.wide_first_hit::<true>(ray).is_some()
    }

    /// [`wide_traversal::first_hit`] with the AVX2 node test where this CPU has it.
    #[inline(always)]
    fn wide_first_hit<const ANY_HIT: bool>(&self, ray: Ray) -> Option<(usize, TriangleHit)> {
        let wide = self.wide.as_ref()?;
        let is_hole = |index: usize, u, v| self.is_alpha_hole(index as u32, u, v);
        #[cfg(target_arch = "x86_64")]
        if self.obvhs_traversal == Traversal::Avx2 {
            // SAFETY: `Traversal::fastest_obvhs` found AVX2 on this CPU.
            return unsafe {
                wide_traversal::first_hit_avx2::<ANY_HIT>(wide, &self.primitives, ray, is_hole)
            };
        }
        wide_traversal::first_hit::<ANY_HIT>(wide, &self.primitives, ray, is_hole)
    }

    /// The triangle test traversal calls: geometry, then the alpha mask.
    #[inline(always)]
    fn hit_triangle(&self, ray: &Ray, index: usize) -> Option<TriangleHit> {
        let hit =
            self.primitives[index].intersect(ray.origin, ray.direction, ray.tmin, ray.tmax)?;
        (!self.is_alpha_hole(index as u32, hit.u, hit.v)).then_some(hit)
    }
}

/// How a batch's rays are shared among the worker threads: spread over them in tasks, or all
/// handled by the thread that holds the batch. The renderer's stages work on many batches at
/// once, one per film tile; where those alone keep every thread busy, splitting each batch
/// again only adds tasks to schedule and moves rays between cores.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BatchParallelism {
    #[default]
    Spread,
    OneThread,
}

impl BatchParallelism {
    /// The least number of items one task takes: `per_task` when spread, else all of them.
    pub fn min_task_len(self, per_task: usize) -> usize {
        match self {
            BatchParallelism::Spread => per_task,
            BatchParallelism::OneThread => usize::MAX,
        }
    }
}

thread_local! {
    /// The packet traversal's stack for batches traced on one thread.
    static PACKET_STACK: std::cell::RefCell<Vec<packet_stack::Entry>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// Rays per packet of [`SceneAccel::intersect_batch`] (the AVX2 packet width, also where
/// packets are not used, so that a batch splits alike on every CPU).
const PACKET_RAYS: usize = 8;

/// The hits of one packet's rays: slices of a [`HitBatch`]'s arrays.
struct HitSlices<'a> {
    t: &'a mut [f32],
    triangle: &'a mut [u32],
    u: &'a mut [f32],
    v: &'a mut [f32],
}
