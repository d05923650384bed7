//! The active lens on the GPU: what `camera_ray` (shaders/lens.wgsl) reads to make, for one
//! pixel and sample, the camera ray the CPU's [`LensCamera::generate`] makes.
//!
//! Everything is derived on the CPU by the lens systems (surfaces, pupil bounds, diaphragm,
//! dispersion) and uploaded as it is, in f32, in bind group 0:
//!
//! | binding | WGSL | contents |
//! |---|---|---|
//! | 0 | `var<uniform> lens_constants: LensConstants` | the per-render constants (`LensConstants` here, the same layout) |
//! | 1 | `var<storage, read> lens_surfaces: array<LensSurface>` | the surfaces in the order camera rays meet them (`LensSurface`) |
//! | 2 | `var<storage, read> lens_tables: array<f32>` | pupil segments, blade normals, mask, dispersion table |
//! | 3 | `var<storage, read> spectral_tables: SpectralTables` | wavelength knots and film factors (no lens data) |
//!
//! A lens swap, a focus pull or a new stop rewrites bindings 0–2 ([`GpuLens::update`]); the
//! layout never changes, so the kernels that bind the group need not be rebuilt.

use bytemuck::{Pod, Zeroable};

use super::compute::{Access, Bindings, storage_buffer, uniform_buffer};
use super::context::{GpuContext, GpuUnavailable};
use crate::film::filter::POSITION_STEP;
use crate::glass::FRAUNHOFER_D_NM;
use crate::lens::camera::{FilmTilt, GHOST_BLOCK, LensCamera, camera_seed};
use crate::lens::ghost::GHOST_EVERY;
use crate::lens::hero_wavelengths::{BACKWARD_START_MM, MAX_WAVELENGTHS, SPLAT_RADIUS};
use crate::lens::pupil::{PupilSampling, SEGMENTS};
use crate::lens::reflectance::{COSINE_STEPS, WAVELENGTH_STEP_NM};
use crate::lens::trace::Travel;
use crate::lens::trace_batch::{CONIC, POLYNOMIAL, SPHERE, SurfaceConstants};
use crate::spectral::wavelength_sets::SET_STEPS;
use crate::spectral::{LAMBDA_MIN, MAX_SET_SIZE, set_knots, spectral_film, wavelength_knots};

/// hash32, Sobol and Owen scrambling, `owen_sobol` (no bindings).
pub const SAMPLING_WGSL: &str = include_str!("shaders/sampling.wgsl");
/// `sample_wavelength` and `film_rgb` (binding 3 of group 0).
pub const SPECTRAL_WGSL: &str = include_str!("shaders/spectral.wgsl");
/// `CameraRay` and `camera_ray` (bindings 0–2 of group 0).
pub const LENS_WGSL: &str = include_str!("shaders/lens.wgsl");

/// The WGSL a kernel that makes camera rays starts with: the shared constants, sampling,
/// spectral, lens, in order.
pub fn lens_source() -> String {
    lens_source_for(MAX_WAVELENGTHS)
}

/// [`lens_source`] for samples of at most `wavelengths` wavelengths each (1 ..=
/// [`MAX_WAVELENGTHS`]): a sample's per-wavelength arrays hold that many, and the loops over
/// them run to that constant (stopping at the lens's own count), so a GPU compiler unrolls
/// them and keeps the arrays in registers instead of thread-local memory.
pub fn lens_source_for(wavelengths: u32) -> String {
    [
        shared_constants_for(wavelengths).as_str(),
        SAMPLING_WGSL,
        SPECTRAL_WGSL,
        LENS_WGSL,
    ]
    .join("\n")
}

/// WGSL constants the kernels share with the CPU code, written from its own: how far a
/// companion wavelength's share may land, how many wavelengths a sample may carry, and where
/// a backward trace starts (see [`crate::lens::hero_wavelengths`]); the steps per pixel of the
/// film filter's grid (see [`crate::film::filter`]).
pub fn shared_constants() -> String {
    shared_constants_for(MAX_WAVELENGTHS)
}

/// [`shared_constants`] with `MAX_WAVELENGTHS` = `wavelengths` (see [`lens_source_for`]).
fn shared_constants_for(wavelengths: u32) -> String {
    let wavelengths = wavelengths.clamp(1, MAX_WAVELENGTHS);
    format!(
        "const SPLAT_RADIUS: i32 = {SPLAT_RADIUS};\n\
         const FILM_POSITION_STEPS: i32 = {steps};\n\
         const MAX_WAVELENGTHS: u32 = {wavelengths}u;\n\
         const BACKWARD_START_MM: f32 = {BACKWARD_START_MM:?};\n\
         const REFLECTANCE_COSINE_STEPS: u32 = {COSINE_STEPS}u;\n\
         const REFLECTANCE_STEP_NM: f32 = {step:?};\n\
         const FRAUNHOFER_D_NM: f32 = {d:?};\n\
         const GHOST_EVERY: u32 = {GHOST_EVERY}u;\n\
         const GHOST_BLOCK_X: u32 = {bx}u;\n\
         const GHOST_BLOCK_Y: u32 = {by}u;\n",
        steps = (1.0 / POSITION_STEP) as i32,
        bx = GHOST_BLOCK[0],
        by = GHOST_BLOCK[1],
        step = WAVELENGTH_STEP_NM as f32,
        d = FRAUNHOFER_D_NM as f32,
    )
}

// The WGSL's shape numbers are the batch kernel's.
const _: () = assert!(SPHERE == 0 && CONIC == 1 && POLYNOMIAL == 2);

/// The per-render constants, laid out as WGSL's `LensConstants` (uniform layout: every field
/// sits where the sequence of 4-byte fields puts it; `film_normal`, a vec3f, at 176 is
/// 16-aligned, and `mask_scale` at 224 8-aligned).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
struct LensConstants {
    world_from_camera: [[f32; 4]; 4],
    film_scale: [f32; 2],
    film_origin: [f32; 2],
    film_centre: [f32; 2],
    film_z: f32,
    film_distance: f32,
    tilt_centre: [f32; 2],
    tilt_x: [f32; 2],
    tilt_y: [f32; 2],
    tilt_z: [f32; 2],
    key_origin_x: u32,
    key_origin_y: u32,
    key_width: u32,
    pattern_seed: u32,
    wavelengths: u32,
    tilted: u32,
    spectral: u32,
    pupil_sampling: u32,
    segment_scale: f32,
    rear_radius: f32,
    inv_z2: f32,
    surface_count: u32,
    film_normal: [f32; 3],
    clip_step: u32,
    blade_count: u32,
    has_mask: u32,
    apex: f32,
    kappa: f32,
    clip_radius: f32,
    mask_width: u32,
    mask_height: u32,
    dispersion_len: u32,
    mask_scale: [f32; 2],
    blades_offset: u32,
    mask_offset: u32,
    segments_offset: u32,
    dispersion_offset: u32,
    dispersion_lambda_min: f32,
    film_width: u32,
    film_height: u32,
    reflectance_offset: u32,
    /// Table wavelengths per surface of the reflectance table; 0: a lossless lens.
    reflectance_wavelengths: u32,
    indices_offset: u32,
    ghost_offset: u32,
    /// Ghost pairs; 0: no ghost samples.
    ghost_pairs: u32,
    pad: [u32; 2],
}

const _: () = assert!(size_of::<LensConstants>() == 288);

/// One surface in the order camera rays meet it (film to scene), as WGSL's `LensSurface`: the
/// batch kernel's [`SurfaceConstants`].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
struct LensSurface {
    coefficients: [f32; 8],
    slope_coefficients: [f32; 8],
    shape: u32,
    vertex_z: f32,
    curvature: f32,
    radius: f32,
    conic_factor: f32,
    conic: f32,
    semi_aperture_sq: f32,
    eta: f32,
    forward_sign: f32,
    pad: [u32; 3],
}

const _: () = assert!(size_of::<LensSurface>() == 112);

/// No diaphragm step: `clip_step` never equals a step.
const NO_CLIP: u32 = u32::MAX;

/// What one camera uploads: the constants, the surfaces and the tables.
struct LensData {
    constants: LensConstants,
    surfaces: Vec<LensSurface>,
    tables: Vec<f32>,
}

impl LensData {
    fn of(camera: &LensCamera, seed: u64) -> LensData {
        let film = camera.film;
        let map = film.film_map();
        let keys = film.pixel_keys();
        let tilt = FilmTilt::of(&film.movements);
        let sampler = camera.pupil.sampler();
        let pattern_seed = camera_seed(seed);
        let f32s = &camera.system.f32s;

        // Film to scene (camera rays), then scene to film (backward traces).
        let surfaces: Vec<LensSurface> = [Travel::FilmToScene, Travel::SceneToFilm]
            .into_iter()
            .flat_map(|travel| SurfaceConstants::in_travel_order(f32s, travel))
            .map(|s| LensSurface {
                coefficients: s.coefficients,
                slope_coefficients: s.slope_coefficients,
                shape: s.shape as u32,
                vertex_z: s.vertex_z,
                curvature: s.curvature,
                radius: s.radius,
                conic_factor: s.conic_factor,
                conic: s.conic,
                semi_aperture_sq: s.semi_aperture_sq,
                eta: s.eta,
                forward_sign: s.forward_sign,
                pad: [0; 3],
            })
            .collect();
        let surface_count = f32s.len();

        // The tables: the SEGMENTS segments (corner and extent) then their areas, blades,
        // mask, dispersion.
        let mut tables: Vec<f32> = sampler.segments.iter().flatten().copied().collect();
        debug_assert_eq!(tables.len(), 4 * SEGMENTS);
        tables.extend_from_slice(&sampler.areas);
        let clip = f32s.stop_clip.as_deref();
        let blades_offset = tables.len() as u32;
        if let Some(clip) = clip {
            tables.extend(clip.normals_f32.iter().flatten());
        }
        let mask_offset = tables.len() as u32;
        let mask = clip.and_then(|c| c.mask.as_deref());
        if let Some(mask) = mask {
            tables.extend_from_slice(&mask.values);
        }
        let dispersion_offset = tables.len() as u32;
        let mut dispersion_len = 2;
        if let Some(table) = camera.dispersion {
            for surface in 0..table.surface_count() {
                let entries = table.entries(surface);
                dispersion_len = entries.len() as u32;
                tables.extend_from_slice(entries);
            }
        }
        let reflectance_offset = tables.len() as u32;
        let reflectance = f32s.reflectance.as_deref();
        if let Some(reflectance) = reflectance {
            tables.extend_from_slice(reflectance.entries());
        }
        let indices_offset = tables.len() as u32;
        tables.extend_from_slice(&f32s.index_back);
        let ghost_offset = tables.len() as u32;
        if let Some(ghosts) = camera.ghosts {
            for (&[a, b], &running) in ghosts.pairs.iter().zip(ghosts.cumulative()) {
                tables.extend_from_slice(&[running, a as f32, b as f32]);
            }
        }

        let [tilt_x, tilt_y, tilt_z] = tilt.map_or([[0.0; 2]; 3], |t| t.rotation);
        let constants = LensConstants {
            world_from_camera: camera.world_from_camera.to_cols_array_2d(),
            film_scale: map.scale,
            film_origin: map.origin,
            film_centre: map.centre,
            film_z: camera.film_z(),
            film_distance: sampler.film_distance,
            tilt_centre: tilt.map_or([0.0; 2], |t| t.centre),
            tilt_x,
            tilt_y,
            tilt_z,
            // Wrapping, as the CPU's key's final `as u32` does.
            key_origin_x: keys.origin[0] as u32,
            key_origin_y: keys.origin[1] as u32,
            key_width: keys.width as u32,
            pattern_seed,
            wavelengths: camera.wavelengths_per_sample(),
            tilted: tilt.is_some() as u32,
            spectral: camera.dispersion.is_some() as u32,
            pupil_sampling: match sampler.sampling {
                PupilSampling::Bounds => 0,
                PupilSampling::RearElement => 1,
            },
            segment_scale: sampler.segment_scale,
            rear_radius: sampler.rear_radius,
            inv_z2: sampler.inv_z2,
            surface_count: surface_count as u32,
            film_normal: sampler.film_normal,
            clip_step: clip.map_or(NO_CLIP, |c| (surface_count - 1 - c.surface) as u32),
            blade_count: clip.map_or(0, |c| c.normals_f32.len() as u32),
            has_mask: mask.is_some() as u32,
            apex: clip.map_or(0.0, |c| c.apex_f32),
            kappa: clip.map_or(0.0, |c| c.kappa_f32),
            clip_radius: clip.map_or(0.0, |c| c.radius as f32),
            mask_width: mask.map_or(1, |m| m.width),
            mask_height: mask.map_or(1, |m| m.height),
            dispersion_len,
            mask_scale: clip.map_or([0.0; 2], |c| c.mask_scale_f32),
            blades_offset,
            mask_offset,
            segments_offset: 0,
            dispersion_offset,
            dispersion_lambda_min: LAMBDA_MIN as f32,
            film_width: film.width,
            film_height: film.height,
            reflectance_offset,
            reflectance_wavelengths: reflectance.map_or(0, |r| r.wavelength_entries() as u32),
            indices_offset,
            ghost_offset,
            ghost_pairs: camera.ghosts.map_or(0, |g| g.pairs.len() as u32),
            pad: [0; 2],
        };
        LensData {
            constants,
            surfaces,
            tables,
        }
    }
}

/// The spectral tables (WGSL `SpectralTables`): a header of knot steps, where the film's
/// factors start and how many nanometres they cover, and λ_min; then the knots and the factors.
fn spectral_tables() -> Vec<u32> {
    let knots = wavelength_knots();
    let film = spectral_film().table();
    let header = 6;
    let film_start = knots.len();
    let set_start = film_start + 6 * film.len();
    let mut words = vec![
        (knots.len() - 1) as u32,
        film_start as u32,
        film.len() as u32,
        (LAMBDA_MIN as f32).to_bits(),
        set_start as u32,
        SET_STEPS as u32,
    ];
    words.extend(knots.iter().map(|v| v.to_bits()));
    words.extend(film.iter().flatten().map(|v| v.to_bits()));
    for count in 2..=MAX_SET_SIZE {
        words.extend(set_knots(count).iter().map(|v| v.to_bits()));
    }
    debug_assert_eq!(
        words.len(),
        header + set_start + (MAX_SET_SIZE as usize - 1) * (SET_STEPS + 1)
    );
    words
}

/// The active lens uploaded for `camera_ray`: bind group 0 of every kernel that makes camera
/// rays (see the module docs for its bindings).
#[derive(Debug)]
pub struct GpuLens {
    pub bindings: Bindings,
    constants: wgpu::Buffer,
    surfaces: wgpu::Buffer,
    tables: wgpu::Buffer,
    spectral: wgpu::Buffer,
    /// Wavelengths per sample of the uploaded camera (see
    /// [`LensCamera::wavelengths_per_sample`]).
    wavelengths: u32,
}

impl GpuLens {
    /// Wavelengths per sample of the uploaded camera: the film records that many shares of
    /// each sample.
    pub fn wavelengths(&self) -> u32 {
        self.wavelengths
    }

    /// Uploads `camera` (its lens, pupil, film and pose) with the camera patterns of the
    /// render's `seed`.
    pub fn upload(
        context: &GpuContext,
        camera: &LensCamera,
        seed: u64,
    ) -> Result<GpuLens, GpuUnavailable> {
        let data = LensData::of(camera, seed);
        check_fits(context, &data)?;
        let constants = uniform_buffer(context, "lens constants", &data.constants);
        let surfaces = storage_buffer(context, "lens surfaces", &data.surfaces);
        let tables = storage_buffer(context, "lens tables", &data.tables);
        let spectral = storage_buffer(context, "spectral tables", &spectral_tables());
        let bindings = lens_bindings(context, &constants, &surfaces, &tables, &spectral);
        Ok(GpuLens {
            bindings,
            constants,
            surfaces,
            tables,
            spectral,
            wavelengths: data.constants.wavelengths,
        })
    }

    /// Rewrites the buffers for `camera` and `seed` (a lens swap, a focus pull, a new stop or
    /// diaphragm, new film movements): in place where the data fits, in new buffers only where
    /// it grew; then [`Self::bindings`] holds a new bind group (same layout), so a pass takes
    /// the group from here at every dispatch.
    pub fn update(
        &mut self,
        context: &GpuContext,
        camera: &LensCamera,
        seed: u64,
    ) -> Result<(), GpuUnavailable> {
        let data = LensData::of(camera, seed);
        check_fits(context, &data)?;
        context
            .queue
            .write_buffer(&self.constants, 0, bytemuck::bytes_of(&data.constants));
        self.wavelengths = data.constants.wavelengths;
        let mut grew = false;
        for (buffer, bytes, label) in [
            (
                &mut self.surfaces,
                bytemuck::cast_slice::<LensSurface, u8>(&data.surfaces),
                "lens surfaces",
            ),
            (
                &mut self.tables,
                bytemuck::cast_slice::<f32, u8>(&data.tables),
                "lens tables",
            ),
        ] {
            if bytes.len() as u64 > buffer.size() {
                *buffer = storage_buffer(context, label, bytes);
                grew = true;
            } else if !bytes.is_empty() {
                context.queue.write_buffer(buffer, 0, bytes);
            }
        }
        if grew {
            self.bindings = lens_bindings(
                context,
                &self.constants,
                &self.surfaces,
                &self.tables,
                &self.spectral,
            );
        }
        Ok(())
    }
}

fn lens_bindings(
    context: &GpuContext,
    constants: &wgpu::Buffer,
    surfaces: &wgpu::Buffer,
    tables: &wgpu::Buffer,
    spectral: &wgpu::Buffer,
) -> Bindings {
    Bindings::new(
        context,
        "lens",
        &[
            (constants, Access::Uniform),
            (surfaces, Access::ReadOnly),
            (tables, Access::ReadOnly),
            (spectral, Access::ReadOnly),
        ],
    )
}

/// Refuses a lens whose tables exceed what one storage binding may hold (a huge mask).
fn check_fits(context: &GpuContext, data: &LensData) -> Result<(), GpuUnavailable> {
    let bytes = (data.tables.len() * size_of::<f32>()) as u64;
    let limit = context.limits.max_storage_buffer_binding_size;
    if bytes > limit {
        return Err(GpuUnavailable(format!(
            "the lens's tables ({bytes} bytes: pupil, diaphragm mask, dispersion) exceed the \
             GPU's {limit}-byte storage binding"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::compute::{dispatch, kernel_with, read_buffer, workgroups_for, zeroed_buffer};
    use crate::lens::camera::CameraRays;
    use crate::lens::diaphragm::{ApertureMask, Blades, Diaphragm};
    use crate::lens::io::bundled::load_lens;
    use crate::lens::movements::FilmMovements;
    use crate::lens::test_lens::{PLAIN, Setup, TestLens};
    use crate::sampling::hash32;
    use crate::sampling::sobol::{DIMENSIONS, owen_sobol};
    use crate::spectral::sample_wavelength;

    /// The test kernels: group 3 holds their parameters and outputs, groups 1 and 2 are empty.
    const TEST_WGSL: &str = "
struct TestParams { width: u32, height: u32, sample: u32, count: u32 }
@group(3) @binding(0) var<uniform> test_params: TestParams;
@group(3) @binding(1) var<storage, read_write> test_out: array<f32>;
@group(3) @binding(2) var<storage, read_write> test_bits: array<u32>;

const TEST_RAY_FLOATS: u32 = 11u;

@compute @workgroup_size(64)
fn test_camera_rays(@builtin(global_invocation_id) id: vec3u) {
    let i = id.x;
    if i >= test_params.width * test_params.height { return; }
    let ray = camera_ray(i % test_params.width, i / test_params.width, test_params.sample);
    let o = i * TEST_RAY_FLOATS;
    test_out[o] = ray.origin.x;
    test_out[o + 1u] = ray.origin.y;
    test_out[o + 2u] = ray.origin.z;
    test_out[o + 3u] = ray.direction.x;
    test_out[o + 4u] = ray.direction.y;
    test_out[o + 5u] = ray.direction.z;
    test_out[o + 6u] = ray.weight;
    test_out[o + 7u] = ray.wavelength;
    test_out[o + 8u] = ray.wavelength_weight;
    test_out[o + 9u] = f32(ray.film_position.x);
    test_out[o + 10u] = f32(ray.film_position.y);
}

// Per pixel: the weight, then per wavelength (4) λ, factor, the offset of its pixel and its
// film position (filter steps).
@compute @workgroup_size(64)
fn test_camera_wavelengths(@builtin(global_invocation_id) id: vec3u) {
    let i = id.x;
    if i >= test_params.width * test_params.height { return; }
    var wavelengths: CameraWavelengths;
    let ray = camera_ray_with(i % test_params.width, i / test_params.width, test_params.sample, &wavelengths);
    let o = i * 25u;
    test_out[o] = ray.weight;
    for (var k = 0u; k < 4u; k++) {
        test_out[o + 1u + 6u * k] = wavelengths.nm[k];
        test_out[o + 2u + 6u * k] = wavelengths.factor[k];
        test_out[o + 3u + 6u * k] = f32(wavelengths.offset[k].x);
        test_out[o + 4u + 6u * k] = f32(wavelengths.offset[k].y);
        test_out[o + 5u + 6u * k] = f32(wavelengths.position[k].x);
        test_out[o + 6u + 6u * k] = f32(wavelengths.position[k].y);
    }
}

// Per index i: hash32(i'), then owen_sobol(i, d, key) for d = 0..4, with i' and key hashed
// from i so that every bit pattern occurs.
@compute @workgroup_size(64)
fn test_sampling(@builtin(global_invocation_id) id: vec3u) {
    let i = id.x;
    if i >= test_params.count { return; }
    let word = i * 0x9e3779b9u;
    let key = hash32(word ^ 0x5bd1e995u);
    test_bits[6u * i] = hash32(word);
    for (var d = 0u; d < 5u; d++) {
        test_bits[6u * i + 1u + d] = bitcast<u32>(owen_sobol(i, d, key));
    }
}

// Per index i: a wavelength sample from u = i / count, and film_rgb of three colours at it.
@compute @workgroup_size(64)
fn test_spectral(@builtin(global_invocation_id) id: vec3u) {
    let i = id.x;
    if i >= test_params.count { return; }
    let s = sample_wavelength((f32(i) + 0.5) / f32(test_params.count));
    let o = 11u * i;
    test_out[o] = s.nm;
    test_out[o + 1u] = s.inverse_pdf;
    let colours = array<vec3f, 3>(vec3f(1.0, 1.0, 1.0), vec3f(0.8, 0.1, 0.05), vec3f(0.1, 0.2, 0.9));
    for (var c = 0u; c < 3u; c++) {
        let rgb = film_rgb(s.nm, s.inverse_pdf, colours[c]);
        test_out[o + 2u + 3u * c] = rgb.x;
        test_out[o + 3u + 3u * c] = rgb.y;
        test_out[o + 4u + 3u * c] = rgb.z;
    }
}
";

    #[repr(C)]
    #[derive(Clone, Copy, Pod, Zeroable)]
    struct TestParams {
        width: u32,
        height: u32,
        sample: u32,
        count: u32,
    }

    /// Runs test kernel `entry` with the lens's group 0 and `params`; returns the float and
    /// the word outputs (`floats` and `words` long).
    fn run_test_kernel(
        context: &GpuContext,
        lens: &GpuLens,
        entry: &str,
        params: TestParams,
        floats: usize,
        words: usize,
    ) -> (Vec<f32>, Vec<u32>) {
        let source = lens_source() + TEST_WGSL;
        let empty = Bindings::new(context, "empty", &[]);
        let params_buffer = uniform_buffer(context, "test params", &params);
        let out = zeroed_buffer::<f32>(context, "test out", floats);
        let bits = zeroed_buffer::<u32>(context, "test bits", words);
        let test = Bindings::new(
            context,
            "test",
            &[
                (&params_buffer, Access::Uniform),
                (&out, Access::ReadWrite),
                (&bits, Access::ReadWrite),
            ],
        );
        let layouts = [
            &lens.bindings.layout,
            &empty.layout,
            &empty.layout,
            &test.layout,
        ];
        let pipeline = kernel_with(context, entry, &source, entry, &layouts).unwrap();
        let n = (params.width * params.height).max(params.count) as usize;
        dispatch(
            context,
            &pipeline,
            &[
                &lens.bindings.group,
                &empty.group,
                &empty.group,
                &test.group,
            ],
            [workgroups_for(n, 64), 1, 1],
        )
        .unwrap();
        (
            read_buffer(context, &out, floats).unwrap(),
            read_buffer(context, &bits, words).unwrap(),
        )
    }

    /// How far the GPU's rays may be from the CPU's: f32 rounding of the same operations
    /// (the GPU may fuse multiply-adds and its sqrt and division may differ in the last bit),
    /// grown through a dozen refractions. The weight's is the widest: it multiplies cos⁴θ, the
    /// pupil area over z² and a graded mask's transmission, read bilinearly where the ray
    /// crosses the stop, so a rounding shift of that point moves it along the mask's gradient
    /// (on an H200, 2026-11-26: 1.2e-3 at worst through the graded, notched mask, 1.1e-4
    /// without one; lavapipe, which does not fuse, agrees exactly).
    const ORIGIN_TOLERANCE_M: f32 = 2e-6;
    const DIRECTION_TOLERANCE: f32 = 2e-5;
    const WEIGHT_RELATIVE_TOLERANCE: f32 = 3e-3;
    /// Rays blocked on one device and not the other: those grazing an aperture's edge or a
    /// blade, where a last-bit difference decides. At most this many per 1000 rays.
    const BORDERLINE_PER_MILLE: usize = 3;
    /// Companions whose film position the GPU puts one 1/256-pixel step from the CPU's: the
    /// position is rounded to the step's grid, so a companion lands a step off with probability
    /// about 2·E|Δ|/step for a rounding difference Δ before the grid. Fused multiply-adds on an
    /// H200 (2026-11-27) put 4 of 2,488 and 7 of 2,247 a step off (0.16–0.31 %, so E|Δ| is about
    /// 1e-3 of a step, far inside the rays' own tolerances); lavapipe, which does not fuse, none.
    /// No companion may be more than one step off.
    const COMPANION_STEP_OFF_PER_MILLE: usize = 10;

    /// A wavelength sample's λ as the CPU draws it: bit for bit on lavapipe; within two ulps
    /// (at 780 nm) where a GPU fuses the interpolation's multiply-add.
    /// The inverse CDF turns a rounding of u into one of λ as large as its slope, 1/p: an ulp
    /// of u near 1 is 6e-8, and 1/p reaches 1.7e4 nm in the deep red, where an H200 was 1.0e-3
    /// nm off. So a few ulps of u through that slope, and a picometre besides (far below the
    /// 1 nm steps of the index tables).
    fn same_wavelength(gpu: f32, cpu: f32, inverse_pdf: f32) -> bool {
        (gpu - cpu).abs() <= 4.0 * f32::EPSILON * inverse_pdf + 1e-3
    }

    /// Its 1/p (knot spacing × 4096): bit for bit, but for rounding of the knots' difference.
    fn same_wavelength_weight(gpu: f32, cpu: f32) -> bool {
        (gpu - cpu).abs() <= 1e-6 * cpu
    }

    /// A film position (pixels) in steps of the filter's grid, as the GPU passes it.
    fn in_steps(position: [f32; 2]) -> [f32; 2] {
        position.map(|p| p / crate::film::filter::POSITION_STEP)
    }

    /// Every pixel of the lens's film at a few sample indices, on both devices; returns the
    /// number of rays that pass.
    fn compare_with_cpu(context: &GpuContext, lens: &TestLens, seed: u64) -> usize {
        let camera = lens.camera();
        let gpu_lens = GpuLens::upload(context, &camera, seed).unwrap();
        compare_uploaded(context, &gpu_lens, lens, seed)
    }

    fn compare_uploaded(
        context: &GpuContext,
        gpu_lens: &GpuLens,
        lens: &TestLens,
        seed: u64,
    ) -> usize {
        let camera = lens.camera();
        let (width, height) = (lens.film.width, lens.film.height);
        let n = (width * height) as usize;
        let mut cpu = CameraRays::default();
        let (mut passed, mut borderline, mut total) = (0, 0, 0);
        // The largest deviations seen: origin (m), direction, relative weight.
        let mut worst = [0.0f32; 3];
        for sample in [0, 1, 5, 77] {
            let params = TestParams {
                width,
                height,
                sample,
                count: 0,
            };
            let (gpu, _) =
                run_test_kernel(context, gpu_lens, "test_camera_rays", params, 11 * n, 1);
            let pixels = (0..height).flat_map(|y| (0..width).map(move |x| (x, y)));
            camera.generate(pixels, sample, seed, &mut cpu);
            for i in 0..n {
                total += 1;
                let g = &gpu[11 * i..11 * i + 11];
                let context = format!(
                    "pixel ({}, {}) sample {sample}",
                    i as u32 % width,
                    i as u32 / width
                );
                // The film jitter, from the same Sobol bits, on the filter's grid: exact.
                assert_eq!(
                    [g[9], g[10]],
                    in_steps(cpu.film_position[i]),
                    "{context}: film position"
                );
                // The CPU draws no wavelength for a ray blocked before the lens (it gets the d
                // line and a factor of 0: it carries no light); the GPU draws one for every ray.
                if lens.spectral && cpu.wavelength_weight[i] != 0.0 {
                    let (nm, inverse_pdf) = (cpu.wavelength[i], cpu.wavelength_weight[i]);
                    assert!(
                        same_wavelength(g[7], nm, inverse_pdf),
                        "{context}: {} nm vs {nm}",
                        g[7]
                    );
                    assert!(
                        same_wavelength_weight(g[8], inverse_pdf),
                        "{context}: 1/p {} vs {inverse_pdf}",
                        g[8]
                    );
                } else if !lens.spectral {
                    assert_eq!((g[7], g[8]), (0.0, 1.0), "{context}");
                }
                let cpu_weight = cpu.weight[i];
                if (g[6] > 0.0) != (cpu_weight > 0.0) {
                    borderline += 1;
                    continue;
                }
                if cpu_weight == 0.0 {
                    continue;
                }
                passed += 1;
                let origin = cpu.rays.origin(i);
                let direction = cpu.rays.direction(i);
                for axis in 0..3 {
                    worst[0] = worst[0].max((g[axis] - origin[axis]).abs());
                    worst[1] = worst[1].max((g[3 + axis] - direction[axis]).abs());
                    assert!(
                        (g[axis] - origin[axis]).abs() < ORIGIN_TOLERANCE_M,
                        "{context}: origin {:?} vs {origin:?}",
                        &g[0..3]
                    );
                    assert!(
                        (g[3 + axis] - direction[axis]).abs() < DIRECTION_TOLERANCE,
                        "{context}: direction {:?} vs {direction:?}",
                        &g[3..6]
                    );
                }
                worst[2] = worst[2].max((g[6] - cpu_weight).abs() / cpu_weight);
                assert!(
                    (g[6] - cpu_weight).abs() <= WEIGHT_RELATIVE_TOLERANCE * cpu_weight,
                    "{context}: weight {} vs {cpu_weight}",
                    g[6]
                );
            }
        }
        assert!(
            borderline * 1000 <= BORDERLINE_PER_MILLE * total,
            "{borderline} of {total} rays blocked on one device only"
        );
        eprintln!(
            "{passed} of {total} rays passed, {borderline} borderline; largest deviations: \
             origin {:e} m, direction {:e}, weight {:e} (relative)",
            worst[0], worst[1], worst[2]
        );
        passed
    }

    /// Four wavelengths per sample: the hero's companions, traced back on the GPU, land in the
    /// pixels the CPU finds, at the same film positions on the filter's grid, with the same
    /// film factors (the balance heuristic over them); returns the samples whose hero passed.
    ///
    /// The hero's position (the jitter) is exact. A companion's is where its backward trace
    /// lands, through the same f32 operations as on the CPU, which lavapipe (not fusing) does
    /// bit for bit; a GPU that fuses multiply-adds moves the point by a few ulps, and one within
    /// that of a half step rounds to the neighbouring step: within one step, and exact but for
    /// a few per thousand.
    fn compare_wavelengths_with_cpu(context: &GpuContext, lens: &TestLens, seed: u64) -> usize {
        let camera = LensCamera {
            wavelengths: 4,
            ghosts: None,
            ..lens.camera()
        };
        let gpu_lens = GpuLens::upload(context, &camera, seed).unwrap();
        assert_eq!(gpu_lens.wavelengths(), 4);
        let (width, height) = (lens.film.width, lens.film.height);
        let n = (width * height) as usize;
        let mut cpu = CameraRays::default();
        let (mut passed, mut borderline, mut total, mut worst) = (0, 0, 0, 0.0f32);
        // Counted companions, and those a step off the CPU's position.
        let (mut companions, mut a_step_off) = (0, 0);
        for sample in [0, 3, 40] {
            let params = TestParams {
                width,
                height,
                sample,
                count: 0,
            };
            let (gpu, _) = run_test_kernel(
                context,
                &gpu_lens,
                "test_camera_wavelengths",
                params,
                25 * n,
                1,
            );
            let pixels = (0..height).flat_map(|y| (0..width).map(move |x| (x, y)));
            camera.generate(pixels, sample, seed, &mut cpu);
            for i in 0..n {
                let g = &gpu[25 * i..25 * i + 25];
                if (g[0] > 0.0) != (cpu.weight[i] > 0.0) {
                    borderline += 1;
                    total += 1;
                    continue;
                }
                if cpu.weight[i] == 0.0 {
                    continue;
                }
                passed += 1;
                for k in 0..4 {
                    total += 1;
                    let j = k * n + i;
                    let (nm, factor) = (cpu.wavelength[j], cpu.wavelength_weight[j]);
                    let offset = cpu.wavelength_offset[j];
                    let share = &g[1 + 6 * k..7 + 6 * k];
                    let context = format!("pixel {i} sample {sample} wavelength {k}");
                    assert!(
                        (share[0] - nm).abs() < 0.05,
                        "{context}: {} vs {nm} nm",
                        share[0]
                    );
                    let same_pixel = [share[2], share[3]] == [offset[0] as f32, offset[1] as f32];
                    // A companion landing within rounding of a pixel's edge or the pupil
                    // bounds may count on one device only.
                    if (share[1] == 0.0) != (factor == 0.0) || !same_pixel {
                        borderline += 1;
                        continue;
                    }
                    if factor != 0.0 {
                        let relative = (share[1] - factor).abs() / factor;
                        worst = worst.max(relative);
                        assert!(
                            relative <= WEIGHT_RELATIVE_TOLERANCE,
                            "{context}: factor {} vs {factor}",
                            share[1]
                        );
                        let cpu_position = in_steps(cpu.film_position[j]);
                        let apart = [share[4], share[5]]
                            .iter()
                            .zip(cpu_position)
                            .map(|(g, c)| (g - c).abs())
                            .fold(0.0f32, f32::max);
                        assert!(
                            apart == 0.0 || (k > 0 && apart == 1.0),
                            "{context}: film position {:?} vs {cpu_position:?} (steps)",
                            &share[4..6]
                        );
                        if k > 0 {
                            companions += 1;
                            a_step_off += usize::from(apart != 0.0);
                        }
                    }
                }
            }
        }
        assert!(
            a_step_off * 1000 <= COMPANION_STEP_OFF_PER_MILLE * companions,
            "{a_step_off} of {companions} companions' film positions a step off the CPU's"
        );
        assert!(
            borderline * 1000 <= BORDERLINE_PER_MILLE * total,
            "{borderline} of {total} shares differ in where they count"
        );
        eprintln!(
            "{passed} samples, {borderline} borderline; factors within {worst:e}; \
             {a_step_off} of {companions} companions' positions a step off"
        );
        passed
    }

    #[test]
    fn several_wavelengths_per_sample_match_the_cpu() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let spectral = Setup {
            spectral: true,
            ..PLAIN
        };
        let lens = TestLens::new("dgauss.50mm", spectral.clone());
        assert!(compare_wavelengths_with_cpu(&context, &lens, 5) > 500);
        let lens = TestLens::new("dgauss.50mm", moved_bladed_spectral());
        assert!(compare_wavelengths_with_cpu(&context, &lens, 9) > 300);
        let rear = Setup {
            sampling: PupilSampling::RearElement,
            ..spectral
        };
        let lens = TestLens::new("fisheye.10mm", rear);
        assert!(compare_wavelengths_with_cpu(&context, &lens, 2) > 100);
    }

    fn blades_and_mask() -> Diaphragm {
        // A radial ramp with an opaque notch, so rays see every grey level and a black part.
        let values: Vec<f32> = (0..256)
            .map(|i| {
                let (x, y) = ((i % 16) as f32 - 7.5, (i / 16) as f32 - 7.5);
                if x > 2.0 && y.abs() < 1.5 {
                    0.0
                } else {
                    (1.0 - (x * x + y * y).sqrt() / 12.0).clamp(0.0, 1.0)
                }
            })
            .collect();
        let mask = ApertureMask::from_values(std::path::Path::new("ramp"), 16, 16, values).unwrap();
        Diaphragm {
            blades: Some(Blades::new(7, 11.0, 0.4).unwrap()),
            mask: Some(std::sync::Arc::new(mask)),
        }
    }

    fn moved_bladed_spectral() -> Setup {
        Setup {
            sampling: PupilSampling::Bounds,
            movements: MOVED,
            diaphragm: Some(blades_and_mask()),
            spectral: true,
        }
    }

    const MOVED: FilmMovements = FilmMovements {
        shift_mm: [2.5, -1.5],
        tilt_deg: [6.0, -4.0],
    };

    #[test]
    fn double_gauss_rays_match_the_cpu() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let lens = TestLens::new("dgauss.50mm", PLAIN);
        assert!(compare_with_cpu(&context, &lens, 7) > 1000);
    }

    #[test]
    fn double_gauss_spectral_shifted_tilted_bladed_rays_match_the_cpu() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let lens = TestLens::new("dgauss.50mm", moved_bladed_spectral());
        assert!(compare_with_cpu(&context, &lens, 11) > 500);
    }

    #[test]
    fn rear_element_sampling_matches_the_cpu() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let setup = Setup {
            sampling: PupilSampling::RearElement,
            movements: MOVED,
            diaphragm: Some(Diaphragm {
                blades: Some(Blades::new(5, 0.0, 0.0).unwrap()),
                mask: None,
            }),
            spectral: false,
        };
        let lens = TestLens::new("dgauss.50mm", setup);
        assert!(compare_with_cpu(&context, &lens, 3) > 100);
    }

    /// Polynomial aspheres (Newton on the sag), spectral and not.
    #[test]
    fn aspheric_fisheye_rays_match_the_cpu() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        for spectral in [false, true] {
            let lens = TestLens::new("aspheric-fisheye", Setup { spectral, ..PLAIN });
            assert!(compare_with_cpu(&context, &lens, 5) > 500);
        }
    }

    /// Polynomial aspheres on conic bases (a phone lens), a fisheye whose film corners see no
    /// light, a wide angle.
    #[test]
    fn phone_fisheye_and_wide_rays_match_the_cpu() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        for name in ["deeplens-phone-68deg", "fisheye.10mm", "wide.22mm"] {
            let lens = TestLens::new(name, PLAIN);
            assert!(compare_with_cpu(&context, &lens, 9) > 200, "{name}");
        }
    }

    /// Conic surfaces without polynomial terms (no bundled lens has them): the double Gauss
    /// with conics on its outer surfaces, spectral.
    #[test]
    fn conic_rays_match_the_cpu() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let mut rows = load_lens("dgauss.50mm", None).unwrap().rows;
        rows[0].asphere.conic = -0.6;
        let last = rows.len() - 1;
        rows[last].asphere.conic = 1.5;
        let lens = TestLens::of_rows(
            &rows,
            35.0,
            Setup {
                spectral: true,
                ..PLAIN
            },
        );
        assert!(lens.system.f32s.conic_factor.iter().any(|&k| k != 1.0));
        assert!(compare_with_cpu(&context, &lens, 13) > 1000);
    }

    /// A lens swap and a new stop rewrite the buffers (growing them where needed) and the
    /// rays follow.
    #[test]
    fn an_update_retargets_the_uploaded_lens() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let small = TestLens::new("wide.22mm", PLAIN);
        let mut gpu_lens = GpuLens::upload(&context, &small.camera(), 1).unwrap();
        let larger = TestLens::new("dgauss.50mm", moved_bladed_spectral());
        gpu_lens.update(&context, &larger.camera(), 2).unwrap();
        compare_uploaded(&context, &gpu_lens, &larger, 2);
        gpu_lens.update(&context, &small.camera(), 4).unwrap();
        compare_uploaded(&context, &gpu_lens, &small, 4);
    }

    #[test]
    fn hash32_and_owen_sobol_are_bit_exact() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let lens = TestLens::new("dgauss.50mm", PLAIN);
        let gpu_lens = GpuLens::upload(&context, &lens.camera(), 0).unwrap();
        const COUNT: u32 = 1 << 16;
        let params = TestParams {
            width: 0,
            height: 0,
            sample: 0,
            count: COUNT,
        };
        let (_, bits) = run_test_kernel(
            &context,
            &gpu_lens,
            "test_sampling",
            params,
            1,
            6 * COUNT as usize,
        );
        for i in 0..COUNT {
            let word = i.wrapping_mul(0x9e37_79b9);
            let key = hash32(word ^ 0x5bd1_e995);
            let got = &bits[6 * i as usize..6 * i as usize + 6];
            assert_eq!(got[0], hash32(word), "hash32({word:#x})");
            for d in 0..DIMENSIONS {
                assert_eq!(
                    f32::from_bits(got[1 + d]),
                    owen_sobol(i, d, key),
                    "owen_sobol({i}, {d}, {key:#x})"
                );
            }
        }
    }

    /// Wavelength samples bit for bit; film weights to f32 rounding (relative 1e-6 of the
    /// largest channel: the GPU may fuse the interpolation's multiply-adds).
    #[test]
    fn wavelength_sampling_and_film_rgb_match_the_cpu() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let lens = TestLens::new("dgauss.50mm", PLAIN);
        let gpu_lens = GpuLens::upload(&context, &lens.camera(), 0).unwrap();
        const COUNT: u32 = 20_000;
        let params = TestParams {
            width: 0,
            height: 0,
            sample: 0,
            count: COUNT,
        };
        let (out, _) = run_test_kernel(
            &context,
            &gpu_lens,
            "test_spectral",
            params,
            11 * COUNT as usize,
            1,
        );
        let film = spectral_film();
        let colours = [[1.0, 1.0, 1.0], [0.8, 0.1, 0.05], [0.1, 0.2, 0.9]];
        for i in 0..COUNT as usize {
            let s = sample_wavelength((i as f32 + 0.5) / COUNT as f32);
            let got = &out[11 * i..11 * i + 11];
            assert!(
                same_wavelength(got[0], s.nm, s.inverse_pdf)
                    && same_wavelength_weight(got[1], s.inverse_pdf),
                "sample {i}: {:?} vs {s:?}",
                &got[0..2]
            );
            for (c, rgb) in colours.iter().enumerate() {
                // At the GPU's own wavelength: the film's response is steep in the red, where
                // the picometre the wavelengths may differ by moves it by 2.4e-5.
                let expected = film.film_rgb(got[0], got[1], *rgb);
                let scale = expected.iter().fold(0.0f32, |m, v| m.max(v.abs()));
                for k in 0..3 {
                    assert!(
                        // The GPU's exp and division may differ in the last bits (an H200: 3.5e-6).
                        (got[2 + 3 * c + k] - expected[k]).abs() <= 2e-5 * scale,
                        "{} nm {rgb:?}: {:?} vs {expected:?}",
                        s.nm,
                        &got[2 + 3 * c..5 + 3 * c]
                    );
                }
            }
        }
    }
}
