//! Embree 3 as a traversal yardstick for `benches/bvh.rs`: the same world triangles, the same
//! rays, closest hit, one thread.
//!
//! Embree is not a dependency of realcam or of its build. The library is opened at run time
//! with `dlopen` (`libembree3.so.3`, Debian's `libembree-dev`/`libembree3-3`), so the benches
//! compile and run everywhere; where the library is missing, [`Embree::open`] returns `None`
//! and the Embree rows are skipped with a note. Only the handful of entry points the bench
//! needs are bound, with the struct layouts of Embree 3.13's headers
//! (`RTC_MAX_INSTANCE_LEVEL_COUNT` 1, `RTC_MIN_WIDTH` 0, the defaults Debian builds with).

use std::ffi::{CStr, c_char, c_int, c_uint, c_void};
use std::ptr;

use glam::Vec3;

type Device = *mut c_void;
type Scene = *mut c_void;
type Geometry = *mut c_void;

const GEOMETRY_TYPE_TRIANGLE: c_uint = 0;
const BUFFER_TYPE_INDEX: c_uint = 0;
const BUFFER_TYPE_VERTEX: c_uint = 1;
const FORMAT_UINT3: c_uint = 0x5003;
const FORMAT_FLOAT3: c_uint = 0x9003;
const BUILD_QUALITY_MEDIUM: c_uint = 1;
const INTERSECT_CONTEXT_FLAG_INCOHERENT: c_uint = 0;
const INTERSECT_CONTEXT_FLAG_COHERENT: c_uint = 1;
pub const INVALID_GEOMETRY_ID: c_uint = u32::MAX;

/// `struct RTCIntersectContext` (flags, filter, instID[1]).
#[repr(C)]
struct IntersectContext {
    flags: c_uint,
    filter: *const c_void,
    inst_id: [c_uint; 1],
}

impl IntersectContext {
    /// `rtcInitIntersectContext` (an inline function in the header), with a coherence hint.
    fn new(coherent: bool) -> Self {
        IntersectContext {
            flags: if coherent {
                INTERSECT_CONTEXT_FLAG_COHERENT
            } else {
                INTERSECT_CONTEXT_FLAG_INCOHERENT
            },
            filter: ptr::null(),
            inst_id: [INVALID_GEOMETRY_ID],
        }
    }
}

/// `struct RTCRayHit`: a 16-byte aligned ray (12 words) and hit (8 words used).
#[repr(C, align(16))]
#[derive(Clone, Copy, Default)]
pub struct RayHit1 {
    pub org: [f32; 3],
    pub tnear: f32,
    pub dir: [f32; 3],
    pub time: f32,
    pub tfar: f32,
    pub mask: c_uint,
    pub id: c_uint,
    pub flags: c_uint,
    pub ng: [f32; 3],
    pub u: f32,
    pub v: f32,
    pub prim_id: c_uint,
    pub geom_id: c_uint,
    pub inst_id: c_uint,
}

/// `struct RTCRayHit8`: eight rays in SoA form, 32-byte aligned.
#[repr(C, align(32))]
#[derive(Clone, Copy, Default)]
pub struct RayHit8 {
    pub org_x: [f32; 8],
    pub org_y: [f32; 8],
    pub org_z: [f32; 8],
    pub tnear: [f32; 8],
    pub dir_x: [f32; 8],
    pub dir_y: [f32; 8],
    pub dir_z: [f32; 8],
    pub time: [f32; 8],
    pub tfar: [f32; 8],
    pub mask: [c_uint; 8],
    pub id: [c_uint; 8],
    pub flags: [c_uint; 8],
    pub ng_x: [f32; 8],
    pub ng_y: [f32; 8],
    pub ng_z: [f32; 8],
    pub u: [f32; 8],
    pub v: [f32; 8],
    pub prim_id: [c_uint; 8],
    pub geom_id: [c_uint; 8],
    pub inst_id: [c_uint; 8],
}

/// The entry points of `libembree3` the bench uses.
struct Api {
    new_device: unsafe extern "C" fn(*const c_char) -> Device,
    release_device: unsafe extern "C" fn(Device),
    new_scene: unsafe extern "C" fn(Device) -> Scene,
    set_scene_build_quality: unsafe extern "C" fn(Scene, c_uint),
    release_scene: unsafe extern "C" fn(Scene),
    new_geometry: unsafe extern "C" fn(Device, c_uint) -> Geometry,
    set_new_geometry_buffer:
        unsafe extern "C" fn(Geometry, c_uint, c_uint, c_uint, usize, usize) -> *mut c_void,
    commit_geometry: unsafe extern "C" fn(Geometry),
    attach_geometry: unsafe extern "C" fn(Scene, Geometry) -> c_uint,
    release_geometry: unsafe extern "C" fn(Geometry),
    commit_scene: unsafe extern "C" fn(Scene),
    intersect1: unsafe extern "C" fn(Scene, *mut IntersectContext, *mut RayHit1),
    intersect8: unsafe extern "C" fn(*const c_int, Scene, *mut IntersectContext, *mut RayHit8),
}

/// An Embree device (one build thread, one traversal thread: the caller's).
pub struct Embree {
    api: Api,
    device: Device,
}

// SAFETY: Embree devices and committed scenes may be used from any thread (Embree's API is
// thread-safe for traversal and object creation).
unsafe impl Send for Embree {}
unsafe impl Sync for Embree {}
unsafe impl Send for EmbreeScene<'_> {}
unsafe impl Sync for EmbreeScene<'_> {}

/// A committed Embree scene of one triangle mesh.
pub struct EmbreeScene<'a> {
    embree: &'a Embree,
    scene: Scene,
}

impl Embree {
    /// Opens `libembree3.so.3` and creates a device, or `None` (with a note) if the library
    /// is not installed.
    pub fn open() -> Option<Embree> {
        let name = c"libembree3.so.3";
        // SAFETY: dlopen with a valid C string; a null handle is checked.
        let handle = unsafe { libc::dlopen(name.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
        if handle.is_null() {
            eprintln!(
                "note: libembree3.so.3 not found (apt-get install libembree-dev): the Embree \
                 traversal anchor is skipped"
            );
            return None;
        }
        let symbol = |name: &CStr| {
            // SAFETY: the handle is open; a missing symbol is reported below.
            let address = unsafe { libc::dlsym(handle, name.as_ptr()) };
            assert!(!address.is_null(), "libembree3 lacks {name:?}");
            address
        };
        // SAFETY: each symbol is given the signature Embree 3's headers declare.
        let api = unsafe {
            Api {
                new_device: function(symbol(c"rtcNewDevice")),
                release_device: function(symbol(c"rtcReleaseDevice")),
                new_scene: function(symbol(c"rtcNewScene")),
                set_scene_build_quality: function(symbol(c"rtcSetSceneBuildQuality")),
                release_scene: function(symbol(c"rtcReleaseScene")),
                new_geometry: function(symbol(c"rtcNewGeometry")),
                set_new_geometry_buffer: function(symbol(c"rtcSetNewGeometryBuffer")),
                commit_geometry: function(symbol(c"rtcCommitGeometry")),
                attach_geometry: function(symbol(c"rtcAttachGeometry")),
                release_geometry: function(symbol(c"rtcReleaseGeometry")),
                commit_scene: function(symbol(c"rtcCommitScene")),
                intersect1: function(symbol(c"rtcIntersect1")),
                intersect8: function(symbol(c"rtcIntersect8")),
            }
        };
        // One thread: the traversal comparison is per core, and the build runs once.
        // SAFETY: a valid configuration string.
        let device = unsafe { (api.new_device)(c"threads=1".as_ptr()) };
        if device.is_null() {
            eprintln!("note: rtcNewDevice failed: the Embree traversal anchor is skipped");
            return None;
        }
        Some(Embree { api, device })
    }

    /// Builds Embree's BVH (medium quality, its default) over `triangles` (world space).
    pub fn scene(&self, triangles: &[[Vec3; 3]]) -> EmbreeScene<'_> {
        let api = &self.api;
        // SAFETY: buffers are allocated by Embree with the sizes written below; the geometry
        // is released after attaching (the scene keeps its own reference).
        unsafe {
            let scene = (api.new_scene)(self.device);
            (api.set_scene_build_quality)(scene, BUILD_QUALITY_MEDIUM);
            let geometry = (api.new_geometry)(self.device, GEOMETRY_TYPE_TRIANGLE);
            let n = triangles.len();
            let vertices = (api.set_new_geometry_buffer)(
                geometry,
                BUFFER_TYPE_VERTEX,
                0,
                FORMAT_FLOAT3,
                12,
                3 * n,
            ) as *mut f32;
            let indices =
                (api.set_new_geometry_buffer)(geometry, BUFFER_TYPE_INDEX, 0, FORMAT_UINT3, 12, n)
                    as *mut u32;
            assert!(!vertices.is_null() && !indices.is_null(), "Embree buffers");
            let vertices = std::slice::from_raw_parts_mut(vertices, 9 * n);
            let indices = std::slice::from_raw_parts_mut(indices, 3 * n);
            for (i, triangle) in triangles.iter().enumerate() {
                for (k, p) in triangle.iter().enumerate() {
                    vertices[9 * i + 3 * k..9 * i + 3 * k + 3].copy_from_slice(&p.to_array());
                    indices[3 * i + k] = (3 * i + k) as u32;
                }
            }
            (api.commit_geometry)(geometry);
            (api.attach_geometry)(scene, geometry);
            (api.release_geometry)(geometry);
            (api.commit_scene)(scene);
            EmbreeScene {
                embree: self,
                scene,
            }
        }
    }
}

impl Drop for Embree {
    fn drop(&mut self) {
        // SAFETY: the device was created by `open`; scenes borrow it, so none outlives it.
        unsafe { (self.api.release_device)(self.device) }
    }
}

impl EmbreeScene<'_> {
    /// Closest hits of single rays (`rtcIntersect1`); returns the number of rays that hit.
    /// `hits` receives each ray's result (`tfar`, `prim_id`).
    pub fn intersect1(&self, rays: &mut [RayHit1], coherent: bool) -> usize {
        let mut context = IntersectContext::new(coherent);
        let mut found = 0;
        for ray in rays {
            ray.hit_reset();
            // SAFETY: a valid scene, context and aligned ray.
            unsafe { (self.embree.api.intersect1)(self.scene, &mut context, ray) };
            found += usize::from(ray.geom_id != INVALID_GEOMETRY_ID);
        }
        found
    }

    /// Closest hits of 8-ray packets (`rtcIntersect8`, all lanes valid).
    pub fn intersect8(&self, packets: &mut [RayHit8], coherent: bool) -> usize {
        let mut context = IntersectContext::new(coherent);
        let valid = Valid8([-1; 8]);
        let mut found = 0;
        for packet in packets {
            packet.geom_id = [INVALID_GEOMETRY_ID; 8];
            packet.tfar = packet.tnear.map(|_| f32::INFINITY);
            // SAFETY: a valid scene, context, 32-byte aligned mask and packet.
            unsafe {
                (self.embree.api.intersect8)(valid.0.as_ptr(), self.scene, &mut context, packet)
            };
            found += packet
                .geom_id
                .iter()
                .filter(|&&g| g != INVALID_GEOMETRY_ID)
                .count();
        }
        found
    }
}

/// A symbol's address as a function pointer of type `F`.
///
/// # Safety
/// `F` must be the symbol's true signature.
unsafe fn function<F: Copy>(address: *mut c_void) -> F {
    assert_eq!(size_of::<F>(), size_of::<*mut c_void>());
    // SAFETY: same size; the caller vouches for the signature.
    unsafe { std::mem::transmute_copy(&address) }
}

/// The valid mask of `rtcIntersect8`, which Embree loads 32-byte aligned.
#[repr(C, align(32))]
struct Valid8([c_int; 8]);

impl Drop for EmbreeScene<'_> {
    fn drop(&mut self) {
        // SAFETY: the scene was created by `Embree::scene`.
        unsafe { (self.embree.api.release_scene)(self.scene) }
    }
}

impl RayHit1 {
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        RayHit1 {
            org: origin.to_array(),
            dir: direction.to_array(),
            tfar: f32::INFINITY,
            mask: u32::MAX,
            geom_id: INVALID_GEOMETRY_ID,
            inst_id: INVALID_GEOMETRY_ID,
            ..Default::default()
        }
    }

    fn hit_reset(&mut self) {
        self.tfar = f32::INFINITY;
        self.geom_id = INVALID_GEOMETRY_ID;
    }
}

/// Consecutive rays packed 8 at a time (the last packet padded with copies of the last ray).
pub fn packets8(origins: &[Vec3], directions: &[Vec3]) -> Vec<RayHit8> {
    origins
        .chunks(8)
        .zip(directions.chunks(8))
        .map(|(o, d)| {
            let mut p = RayHit8 {
                mask: [u32::MAX; 8],
                inst_id: [INVALID_GEOMETRY_ID; 8],
                ..Default::default()
            };
            for lane in 0..8 {
                let k = lane.min(o.len() - 1);
                [p.org_x[lane], p.org_y[lane], p.org_z[lane]] = o[k].to_array();
                [p.dir_x[lane], p.dir_y[lane], p.dir_z[lane]] = d[k].to_array();
            }
            p
        })
        .collect()
}
