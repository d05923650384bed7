//! From film pixels to world-space camera rays through the lens.
//!
//! **Camera frame**: metres, origin at the centre of the film, looking down −z, +y up, +x to
//! the image's right (glTF's camera convention). The lens frame (see [`crate::lens`]) maps to
//! it by `camera = (x, y, z − film_z) / 1000`: the lens sits in front of the film, toward −z.
//!
//! **Pixels**: (0, 0) is the top-left corner of the image, +x right, +y down. Since the lens
//! inverts the image, the pixel at the image's top right is the film point at bottom left
//! (−x, −y); mapping pixels that way gives an upright, unmirrored picture. A shifted frame
//! (see [`super::movements`]) is the same pixel lattice moved across the film.
//!
//! **Pixel keys**: a pixel's random streams are keyed by its index in the image; a shifted
//! frame's pixels by their index in its *enclosing film*, the smallest unshifted film centred
//! on the axis that contains the frame, and their film points are computed as that film's.
//! So a frame shifted by whole pixels is exactly the matching crop of its enclosing film: the
//! same film points, the same samples (as far as the pupil sampling does not depend on the
//! film's size: exactly with `rear-element`, within noise with the bounds, whose radial
//! segments span the film's reach).

use bevy_ecs::resource::Resource;
use glam::Mat4;

use super::dispersion::DispersionTable;
use super::ghost::{GHOST_EVERY, Ghosts};
use super::hero_wavelengths::{
    BackwardScratch, BackwardTrace, Combined, HeroRays, MAX_WAVELENGTHS, PendingCompanions,
};
use super::movements::FilmMovements;
use super::pupil::{ExitPupil, FilmRays, PupilSampler, PupilSampling, concentric_disk};
use super::system::LensSystem;
use super::trace::Travel;
use super::trace_batch::ghost::{GhostBatch, GhostLens};
use super::trace_batch::{Isa, Wavelengths, on_isa, trace_batch, trace_batch_spectral, widened};
use super::wavelength_draws::{WavelengthDraws, draw_wavelengths};
use crate::batch::RayBatch;
use crate::film::filter::quantise;
use crate::glass::FRAUNHOFER_D_NM;
use crate::sampling::sobol::{SobolScratch, owen_sobol_batch};
use crate::sampling::{Rng, hash32};

/// Where the camera stands: the rigid transform from the camera frame (see above) to the world.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct CameraPose(pub Mat4);

/// The film's size in pixels, a resource of the render world: what the lens systems need of
/// the render settings to place a moved film or aim a probe ray, kept here so that the lens
/// never reads the pipeline's settings.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct FilmResolution {
    pub width: u32,
    pub height: u32,
}

/// The film's size in pixels and millimetres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmGeometry {
    pub width: u32,
    pub height: u32,
    pub width_mm: f32,
    pub height_mm: f32,
    /// Shift and tilt of the frame.
    pub movements: FilmMovements,
}

impl FilmGeometry {
    /// A film of `width` × `height` square pixels whose diagonal is `diagonal_mm`.
    pub fn new(width: u32, height: u32, diagonal_mm: f64) -> FilmGeometry {
        let aspect = width as f64 / height as f64;
        let height_mm = diagonal_mm / (1.0 + aspect * aspect).sqrt();
        FilmGeometry {
            width,
            height,
            width_mm: (height_mm * aspect) as f32,
            height_mm: height_mm as f32,
            movements: FilmMovements::NONE,
        }
    }

    /// This film shifted and tilted by `movements`.
    pub fn moved(self, movements: FilmMovements) -> FilmGeometry {
        FilmGeometry { movements, ..self }
    }

    /// Lens-frame film point (x, y, mm) of the continuous pixel position (`px`, `py`), on the
    /// film plane before any tilt.
    #[inline(always)]
    pub fn film_point(&self, px: f32, py: f32) -> [f32; 2] {
        let map = self.film_map();
        let (x, y) = (px.floor(), py.floor());
        map.apply(x, y, px - x, py - y)
    }

    /// Lens-frame film point (x, y, and z relative to the frame centre's plane, mm) of the
    /// continuous pixel position (`px`, `py`), tilt included.
    pub fn film_position(&self, px: f32, py: f32) -> [f64; 3] {
        let [x, y] = self.film_point(px, py).map(f64::from);
        let [cx, cy] = self.movements.frame_centre();
        self.movements.film_point(x - cx, y - cy, 0.0)
    }

    /// Film pitch (mm per pixel) along x and y.
    fn pitch(&self) -> [f64; 2] {
        [
            self.width_mm as f64 / self.width as f64,
            self.height_mm as f64 / self.height as f64,
        ]
    }

    /// The enclosing film of a shifted frame (see the module docs): its size in pixels and
    /// where the frame's pixel (0, 0) lies in it; the frame itself when not shifted.
    fn enclosing(&self) -> Enclosing {
        let [shift_x, shift_y] = self.movements.shift_mm;
        let pitch = self.pitch();
        // The frame centre's offset from the axis in pixels, +x right, +y down.
        let offset = [shift_x / pitch[0], -shift_y / pitch[1]];
        let size = [self.width as f64, self.height as f64];
        let margin = offset.map(|o| o.abs().ceil());
        Enclosing {
            size: [0, 1].map(|a| size[a] + 2.0 * margin[a]),
            origin: [0, 1].map(|a| margin[a] + offset[a]),
        }
    }

    /// Pixel position → film point as a scale per axis about the enclosing film's centre, so a
    /// loop over many pixels does not divide by the film size each time.
    #[inline(always)]
    pub(crate) fn film_map(&self) -> FilmMap {
        let enclosing = self.enclosing();
        FilmMap {
            scale: [
                -self.width_mm / self.width as f32,
                self.height_mm / self.height as f32,
            ],
            origin: enclosing.origin.map(|v| v as f32),
            centre: enclosing.size.map(|v| (0.5 * v) as f32),
        }
    }

    /// The keys of this film's pixels' random streams (see [`PixelKeys`]).
    pub fn pixel_keys(&self) -> PixelKeys {
        let enclosing = self.enclosing();
        PixelKeys {
            origin: enclosing.origin.map(|v| v.round() as i64),
            width: enclosing.size[0] as i64,
        }
    }
}

/// A shifted frame's enclosing film, in pixels.
struct Enclosing {
    size: [f64; 2],
    /// The frame's pixel (0, 0) in the enclosing film.
    origin: [f64; 2],
}

/// A pixel's key: its index in the enclosing film (wrapping past 2³² pixels).
#[derive(Clone, Copy, Debug)]
pub struct PixelKeys {
    pub(crate) origin: [i64; 2],
    pub(crate) width: i64,
}

impl PixelKeys {
    #[inline(always)]
    pub fn key(&self, x: u32, y: u32) -> u32 {
        ((y as i64 + self.origin[1]) * self.width + (x as i64 + self.origin[0])) as u32
    }
}

/// `film = scale · (((pixel + origin) + jitter) − centre)`, per axis (x flipped: see the
/// module docs): the pixel's place in the enclosing film (origin 0 and the image's own centre
/// when not shifted), so the same enclosing-film pixel gives the same film point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FilmMap {
    pub(crate) scale: [f32; 2],
    pub(crate) origin: [f32; 2],
    pub(crate) centre: [f32; 2],
}

impl FilmMap {
    /// The continuous pixel position (pixel + jitter) of film point `film`: [`Self::apply`]
    /// inverted.
    #[inline(always)]
    pub(crate) fn pixel_position(&self, film: [f32; 2]) -> [f32; 2] {
        [
            film[0] / self.scale[0] + self.centre[0] - self.origin[0],
            film[1] / self.scale[1] + self.centre[1] - self.origin[1],
        ]
    }

    #[inline(always)]
    pub(crate) fn apply(&self, px: f32, py: f32, jitter_x: f32, jitter_y: f32) -> [f32; 2] {
        [
            self.scale[0] * (((px + self.origin[0]) + jitter_x) - self.centre[0]),
            self.scale[1] * (((py + self.origin[1]) + jitter_y) - self.centre[1]),
        ]
    }
}

/// A tilted film's rotation and frame centre in f32, for the ray generator's loop.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FilmTilt {
    pub(crate) centre: [f32; 2],
    /// x, y, z of R·(a, b, 0) per film-plane coordinate: [[x_a, x_b], [y_a, y_b], [z_a, z_b]].
    pub(crate) rotation: [[f32; 2]; 3],
}

impl FilmTilt {
    pub(crate) fn of(movements: &FilmMovements) -> Option<FilmTilt> {
        if !movements.is_tilted() {
            return None;
        }
        let [xa, ya, za] = movements.film_offset(1.0, 0.0).map(|v| v as f32);
        let [xb, yb, zb] = movements.film_offset(0.0, 1.0).map(|v| v as f32);
        Some(FilmTilt {
            centre: movements.frame_centre().map(|v| v as f32),
            rotation: [[xa, xb], [ya, yb], [za, zb]],
        })
    }
}

/// The active lens as the ray generator sees it.
#[derive(Clone, Copy, Debug)]
pub struct LensCamera<'a> {
    pub system: &'a LensSystem,
    pub pupil: &'a ExitPupil,
    pub film: FilmGeometry,
    /// Rigid transform from the camera frame (see module docs) to the world.
    pub world_from_camera: Mat4,
    /// When set, every camera ray gets its own wavelength and is refracted with the lens's
    /// indices at it (a lens with glass data, dispersion on); `None`: all at the lens's own
    /// indices, as the lens file gives them.
    pub dispersion: Option<&'a DispersionTable>,
    /// Wavelengths per camera sample in a spectral render (1 ..= [`MAX_WAVELENGTHS`]): the
    /// hero and its companions, traced backward from the hero's scene ray (see
    /// [`super::hero_wavelengths`]); 1 is one wavelength per sample.
    pub wavelengths: u32,
    /// When set, one sample in [`GHOST_EVERY`] follows a ghost path (see [`super::ghost`]).
    pub ghosts: Option<&'a Ghosts>,
}

/// Camera rays of one batch: rays in the world frame and the lens weight of each.
#[derive(Clone, Debug, Default)]
pub struct CameraRays {
    pub rays: RayBatch,
    /// Camera-measurement weight (see [`super::pupil::PupilSample`]); 0 for blocked rays.
    pub weight: Vec<f32>,
    /// In a spectral render (see [`LensCamera::dispersion`]) each ray's wavelengths, nm,
    /// wavelength-major: [`LensCamera::wavelengths`] blocks of one per ray, the heroes (those
    /// the rays were traced at) first; empty otherwise.
    pub wavelength: Vec<f32>,
    /// What each of those wavelengths adds per unit of weighted radiance, laid out as
    /// `wavelength`: with one wavelength 1/p(λ) (p: the density λ was drawn with, 1/nm; the
    /// mask's transmission is in `weight`); with several T/(p(λ)·Σ 1/W) (T: the diaphragm
    /// mask's transmission at λ, the sum over the techniques that make this share, see
    /// [`super::hero_wavelengths`]; `weight` is then 1), or 0 for a share that does not count.
    /// The film adds a(λ_k)·(b(λ_k)·L)·weight·wavelength_weight_k (see [`crate::spectral`]) to
    /// the pixel at `wavelength_offset`.
    pub wavelength_weight: Vec<f32>,
    /// With several wavelengths per sample, laid out as `wavelength`: the offset (dx, dy) from
    /// the ray's pixel to the pixel that wavelength's contribution goes to (see
    /// [`super::hero_wavelengths`]); empty with one.
    pub wavelength_offset: Vec<[i8; 2]>,
    /// Where each share lands on the film relative to its ray's pixel's top-left corner,
    /// pixels, on the film filter's grid (see [`crate::film::filter`]): laid out as
    /// `wavelength` with several wavelengths per sample, else one per ray (the film jitter).
    pub film_position: Vec<[f32; 2]>,
    /// With several wavelengths per sample, the heroes whose companions are still to be
    /// landed ([`LensCamera::land_companions`]); `wavelength_weight`, `wavelength_offset` and
    /// `film_position` hold their final values only once they are.
    pub companions: PendingCompanions,
}

/// What [`LensCamera::generate`] works in besides its outputs: a batch's per-pixel inputs and
/// the intermediate arrays, structure of arrays. One per thread ([`CAMERA_SCRATCH`]), not one per
/// tile: it is filled and used up within one call, so a thread reuses the same memory tile
/// after tile. Kept per tile, it was half of a frame's batch memory (the peer helmet at 640²:
/// 223 MB at its peak, 103 MB with one per thread).
#[derive(Default)]
struct Scratch {
    pixel: Vec<u32>,
    px: Vec<f32>,
    py: Vec<f32>,
    /// Film points' depth behind the rear-vertex plane on a tilted film.
    depth: Vec<f32>,
    /// The camera sample: film jitter x, y; pupil u, v; the wavelength set's uniform number and
    /// its inverse density (see [`crate::spectral::wavelength_sets`]).
    u: [Vec<f32>; 6],
    /// The companion wavelengths' backward traces.
    backward: BackwardScratch,
    /// Each pixel's pattern key (see [`LensCamera::camera_samples`]), and the Sobol batch's
    /// buffers.
    keys: Vec<u32>,
    sobol: SobolScratch,
    /// The rays that are ghost samples (their indices, ascending), and per ghost sample the
    /// uniform number choosing its pair and the inverse density its wavelength was drawn with.
    ghosts: Vec<u32>,
    ghost_u: Vec<f32>,
    ghost_inverse_pdf: Vec<f32>,
    /// This batch's ghost paths, and per ghost sample its camera weight and its pair's
    /// probability.
    ghost_batch: GhostBatch,
    ghost_factor: Vec<(f32, f32)>,
    /// The rays that need their wavelengths drawn: those still alive and the ghost samples.
    needs_wavelengths: Vec<bool>,
}

thread_local! {
    static CAMERA_SCRATCH: std::cell::RefCell<Scratch> =
        std::cell::RefCell::new(Scratch::default());
}

widened! {
    /// [`BackwardTrace::land_companions`] compiled for wider vector units.
    fn land_companions_avx2 / land_companions_avx512(
        backward: &BackwardTrace,
        hero: HeroRays,
        carries_light: impl Fn(usize) -> bool,
        out: Combined,
        scratch: &mut BackwardScratch,
    ) {
        backward.land_companions(hero, carries_light, out, scratch)
    }
}

/// Seed key of the camera's sample patterns, apart from the shading streams.
const CAMERA_KEY: u64 = 0x4341_4d45_5241_5f4b; // "CAMERA_K"

/// Mixed into a pixel's pattern key for its ghost samples: which ones, and their pairs.
const GHOST_KEY: u32 = 0x4748_5354; // "GHST"

/// Whether sample `sample` of a pixel in the ghost block with key `block_key`
/// ([`ghost_block_key`]) is a ghost sample: every [`GHOST_EVERY`]th, from an offset the key
/// picks (so each sample is one with probability 1/[`GHOST_EVERY`]).
#[inline(always)]
pub(crate) fn is_ghost_sample(block_key: u32, sample: u32) -> bool {
    sample
        .wrapping_add(hash32(block_key ^ GHOST_KEY))
        .is_multiple_of(GHOST_EVERY)
}

/// The pixels that take their ghost samples in the same passes: blocks of 8 × 4, a GPU
/// warp's worth, so that its lanes all follow ghost paths or all ordinary ones (each waiting
/// for the other's path would cost the slower of the two on every lane).
pub(crate) const GHOST_BLOCK: [u32; 2] = [8, 4];

/// The key of the ghost block of the pixel with key `pixel_key` (keys `key_width` to a row),
/// mixed with the render's pattern seed ([`camera_seed`]).
#[inline(always)]
pub(crate) fn ghost_block_key(pixel_key: u32, key_width: u32, pattern_seed: u32) -> u32 {
    let (x, y) = (pixel_key % key_width, pixel_key / key_width);
    let block = (y / GHOST_BLOCK[1])
        .wrapping_mul(0x1_0000)
        .wrapping_add(x / GHOST_BLOCK[0]);
    hash32(block ^ pattern_seed)
}

/// The uniform number choosing a ghost sample's pair.
#[inline(always)]
pub(crate) fn ghost_pair_u(pattern_key: u32, sample: u32) -> f32 {
    let bits = hash32(hash32(pattern_key ^ GHOST_KEY) ^ sample);
    (bits >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// The seed of the camera's sample patterns for a render's `seed`, mixed with every pixel's
/// key (see [`LensCamera::generate`]).
pub(crate) fn camera_seed(seed: u64) -> u32 {
    Rng::for_sample(seed ^ CAMERA_KEY, u32::MAX, u32::MAX).next_u32()
}

impl LensCamera<'_> {
    /// Wavelengths each camera sample carries: [`Self::wavelengths`] (within 1 ..=
    /// [`MAX_WAVELENGTHS`]) in a spectral render, else 1.
    pub fn wavelengths_per_sample(&self) -> u32 {
        if self.dispersion.is_some() {
            self.wavelengths.clamp(1, MAX_WAVELENGTHS)
        } else {
            1
        }
    }

    /// Lens-frame z of the frame centre, mm.
    pub(crate) fn film_z(&self) -> f32 {
        (self.system.rear_z() + self.pupil.film_distance) as f32
    }

    /// Generates sample `sample` of each pixel in `pixels` (x, y) into `out`, replacing its
    /// contents: film point and pupil point from the sample's own numbers, traced through
    /// the lens as one SoA batch, then moved to the world frame; in a spectral render with
    /// several wavelengths per sample, every hero's companions landed.
    pub fn generate(
        &self,
        pixels: impl IntoIterator<Item = (u32, u32)>,
        sample: u32,
        seed: u64,
        out: &mut CameraRays,
    ) {
        self.generate_heroes(pixels, sample, seed, out);
        self.land_companions(out, |_| true);
    }

    /// [`Self::generate`], leaving the companions of the heroes in `out.companions` for
    /// [`Self::land_companions`]: the pipeline lands only those of samples that carry light.
    pub fn generate_heroes(
        &self,
        pixels: impl IntoIterator<Item = (u32, u32)>,
        sample: u32,
        seed: u64,
        out: &mut CameraRays,
    ) {
        // Nothing under this call runs other tasks on this thread, so the thread's scratch is
        // free.
        CAMERA_SCRATCH
            .with_borrow_mut(|scratch| self.generate_in(pixels, sample, seed, out, scratch))
    }

    /// Lands the companions of the heroes [`Self::generate_heroes`] left in `out` for which
    /// `carries_light` holds (by index in the batch): traces them back through the lens and
    /// sets their samples' factors, offsets and film positions (see
    /// [`super::hero_wavelengths`]). The others' samples must add nothing to the film.
    pub fn land_companions(&self, out: &mut CameraRays, carries_light: impl Fn(usize) -> bool) {
        let Some(table) = self.dispersion else {
            return;
        };
        if out.companions.is_empty() {
            return;
        }
        CAMERA_SCRATCH.with_borrow_mut(|scratch| {
            let sampler = self.pupil.sampler();
            let backward = self.backward_trace(table, &sampler);
            let hero = HeroRays {
                pending: &out.companions,
                transmission: &out.rays.tr,
                nm: &out.wavelength,
            };
            let combined = Combined {
                coefficient: &mut out.wavelength_weight,
                offset: &mut out.wavelength_offset,
                position: &mut out.film_position,
            };
            // The landing's loops compiled again for wider vector units, as the kernel's.
            let scratch = &mut scratch.backward;
            on_isa!(Isa::detect(),
                baseline: backward.land_companions(hero, carries_light, combined, scratch),
                avx2: land_companions_avx2(&backward, hero, carries_light, combined, scratch),
                avx512: land_companions_avx512(&backward, hero, carries_light, combined, scratch),
            )
        })
    }

    /// The backward traces' view of this camera (see [`super::hero_wavelengths`]).
    fn backward_trace<'a>(
        &'a self,
        table: &'a DispersionTable,
        sampler: &'a PupilSampler,
    ) -> BackwardTrace<'a> {
        BackwardTrace {
            surfaces: &self.system.f32s,
            table,
            film: self.film.film_map(),
            size: [self.film.width, self.film.height],
            tilt: FilmTilt::of(&self.film.movements),
            sampler,
            film_z: self.film_z(),
        }
    }

    /// [`Self::generate`] with its working memory in `scratch`.
    fn generate_in(
        &self,
        pixels: impl IntoIterator<Item = (u32, u32)>,
        sample: u32,
        seed: u64,
        out: &mut CameraRays,
        scratch: &mut Scratch,
    ) {
        scratch.pixel.clear();
        scratch.px.clear();
        scratch.py.clear();
        let keys = self.film.pixel_keys();
        for (x, y) in pixels {
            scratch.pixel.push(keys.key(x, y));
            scratch.px.push(x as f32);
            scratch.py.push(y as f32);
        }
        let n = scratch.pixel.len();
        for v in &mut scratch.u {
            v.resize(n, 0.0);
        }
        out.rays.clear();
        out.rays.resize(n);
        out.weight.clear();
        out.weight.resize(n, 0.0);
        out.wavelength.clear();
        out.wavelength_weight.clear();
        out.wavelength_offset.clear();
        out.film_position.clear();
        out.film_position.resize(n, [0.0; 2]);
        out.companions.clear();
        if self.dispersion.is_some() {
            let count = self.wavelengths_per_sample() as usize;
            out.wavelength.resize(n * count, 0.0);
            out.wavelength_weight.resize(n * count, 0.0);
            if count > 1 {
                out.wavelength_offset.resize(n * count, [0, 0]);
                out.film_position.resize(n * count, [0.0; 2]);
            }
        }
        // The per-pixel loops are compiled again for wider vector units and the widest this
        // CPU has is chosen, as for the lens kernel.
        on_isa!(Isa::detect(),
            baseline: self.generate_prepared(sample, seed, out, scratch),
            avx2: self.generate_prepared_avx2(sample, seed, out, scratch),
            avx512: self.generate_prepared_avx512(sample, seed, out, scratch),
        )
    }

    widened! {
        fn generate_prepared_avx2 / generate_prepared_avx512(
            &self,
            sample: u32,
            seed: u64,
            out: &mut CameraRays,
            scratch: &mut Scratch,
        ) {
            self.generate_prepared(sample, seed, out, scratch)
        }
    }

    /// [`Self::generate`] once the pixels are in the scratch arrays and the outputs sized.
    #[inline(always)]
    fn generate_prepared(
        &self,
        sample: u32,
        seed: u64,
        out: &mut CameraRays,
        scratch: &mut Scratch,
    ) {
        let film_z = self.film_z();
        let sampler = self.pupil.sampler();
        self.camera_samples(sample, seed, scratch);
        self.film_to_pupil(&sampler, sample, film_z, out, scratch);
        let [film_u, film_v, ..] = &scratch.u;
        for ((position, &u), &v) in out.film_position.iter_mut().zip(film_u).zip(film_v) {
            *position = [quantise(u), quantise(v)];
        }
        self.choose_ghost_samples(sample, seed, out, scratch);
        match self.dispersion {
            None => trace_batch(&self.system.f32s, &mut out.rays, Travel::FilmToScene),
            Some(table) => {
                let n = out.rays.len();
                let count = out.wavelength.len() / n.max(1);
                // A ray blocked before the lens (most of a fisheye's frame) carries no light at
                // any wavelength: it gets the d line and a factor of 0.
                let needs = &mut scratch.needs_wavelengths;
                needs.clear();
                needs.extend_from_slice(&out.rays.alive[..n]);
                for &i in &scratch.ghosts {
                    needs[i as usize] = true;
                }
                let [.., wave_u, set_inverse_density] = &mut scratch.u;
                let draws = WavelengthDraws {
                    u: wave_u,
                    inverse_density: set_inverse_density,
                    needs,
                    nm: &mut out.wavelength,
                    inverse_pdf: &mut out.wavelength_weight,
                };
                draw_wavelengths(draws, count, Isa::detect());
                let wavelengths = Wavelengths {
                    table,
                    nm: &out.wavelength[..n],
                };
                trace_batch_spectral(
                    &self.system.f32s,
                    wavelengths,
                    &mut out.rays,
                    Travel::FilmToScene,
                );
                if count > 1 {
                    if self.ghosts.is_some() {
                        scratch.ghost_inverse_pdf.clear();
                        scratch.ghost_inverse_pdf.extend(
                            scratch
                                .ghosts
                                .iter()
                                .map(|&i| out.wavelength_weight[i as usize]),
                        );
                    }
                    let combined = Combined {
                        coefficient: &mut out.wavelength_weight,
                        offset: &mut out.wavelength_offset,
                        position: &mut out.film_position,
                    };
                    let pixels = [&scratch.px[..], &scratch.py[..]];
                    out.companions
                        .keep(&out.rays, pixels, &mut out.weight, combined);
                    // What the mask and the surfaces pass is in each wavelength's factor.
                    self.trace_ghost_samples(&sampler, film_z, out, scratch);
                    self.move_to_world(film_z, out);
                    return;
                }
            }
        }
        let masked = self
            .system
            .f32s
            .stop_clip
            .as_deref()
            .is_some_and(|clip| clip.has_mask());
        if masked || self.system.f32s.reflectance.is_some() {
            // The batch kernel left in each ray's throughput the share of its light the mask
            // and the surfaces pass.
            for (weight, &t) in out.weight.iter_mut().zip(&out.rays.tr) {
                *weight *= t;
            }
        }
        self.trace_ghost_samples(&sampler, film_z, out, scratch);
        self.move_to_world(film_z, out);
    }

    /// Marks this pass's ghost samples (see [`super::ghost`]) and takes them out of the
    /// ordinary trace.
    #[inline(always)]
    fn choose_ghost_samples(&self, sample: u32, seed: u64, out: &mut CameraRays, s: &mut Scratch) {
        s.ghosts.clear();
        s.ghost_u.clear();
        if self.ghosts.is_none() {
            return;
        }
        let pattern_seed = camera_seed(seed);
        let key_width = self.film.pixel_keys().width as u32;
        let n = s.pixel.len();
        for i in 0..n {
            let block = ghost_block_key(s.pixel[i], key_width, pattern_seed);
            if is_ghost_sample(block, sample) {
                s.ghosts.push(i as u32);
                // `keys` holds each pixel's pattern key, as camera_samples made it.
                s.ghost_u.push(ghost_pair_u(s.keys[i], sample));
                out.rays.alive[i] = false;
            }
        }
    }

    /// Traces every ghost sample along a ghost path, and scales the ordinary samples by the
    /// share of samples they are (see [`super::ghost`]).
    #[inline(always)]
    fn trace_ghost_samples(
        &self,
        sampler: &PupilSampler,
        film_z: f32,
        out: &mut CameraRays,
        s: &mut Scratch,
    ) {
        let Some(ghosts) = self.ghosts else {
            return;
        };
        let rear = PupilSampler {
            sampling: PupilSampling::RearElement,
            ..sampler.clone()
        };
        let f32s = &self.system.f32s;
        let n = out.rays.len();
        let count = out.wavelength.len() / n.max(1);
        let ordinary = GHOST_EVERY as f32 / (GHOST_EVERY - 1) as f32;
        let film_distance = self.pupil.film_distance as f32;
        let rear_z = film_z - film_distance;
        // The scratch keeps a tilted film's depths from earlier batches: only a tilt sets them.
        let tilted = FilmTilt::of(&self.film.movements).is_some();
        // The ordinary samples' weights scaled by the share of samples they are (the ghost
        // samples' are set below); then each ghost sample's ray to its rear-element point, its
        // camera weight and its pair.
        for weight in &mut out.weight {
            *weight *= ordinary;
        }
        let m = s.ghosts.len();
        s.ghost_batch.clear_with_room(m);
        s.ghost_factor.clear();
        s.ghost_factor.reserve(m);
        for (g, &i) in s.ghosts.iter().enumerate() {
            let i = i as usize;
            let rays = &out.rays;
            let film = [rays.ox[i], rays.oy[i], rays.oz[i]];
            let depth = if tilted { s.depth[i] } else { film_distance };
            let [u, v] = concentric_disk([s.u[2][i], s.u[3][i]]);
            let point = [u * rear.rear_radius, v * rear.rear_radius];
            let weight = rear.drawn_weight([film[0], film[1]], depth, point);
            let to = [point[0] - film[0], point[1] - film[1], rear_z - film[2]];
            let length = (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
            let (pair, probability) = ghosts.choose(s.ghost_u[g]);
            let nm = if count > 0 {
                out.wavelength[i]
            } else {
                FRAUNHOFER_D_NM as f32
            };
            let direction = to.map(|c| c / length);
            s.ghost_batch.push(film, direction, nm, ghosts.pairs[pair]);
            s.ghost_factor.push((weight, probability));
        }
        // Then every ghost path at once (without reflectances nothing reflects, and no ghost
        // path passes).
        let reflectance = f32s.reflectance.as_deref();
        if let Some(reflectance) = reflectance {
            let lens = GhostLens {
                surfaces: f32s,
                reflectance,
                dispersion: self.dispersion,
            };
            s.ghost_batch.trace(&lens);
        }
        for (g, &i) in s.ghosts.iter().enumerate() {
            let i = i as usize;
            let rays = &mut out.rays;
            let (weight, probability) = s.ghost_factor[g];
            let traced = reflectance.and_then(|_| s.ghost_batch.traced(g));
            match traced {
                Some((origin, direction, transmission)) if weight > 0.0 => {
                    [rays.ox[i], rays.oy[i], rays.oz[i]] = origin;
                    [rays.dx[i], rays.dy[i], rays.dz[i]] = direction;
                    rays.alive[i] = true;
                    out.weight[i] = weight * transmission * (GHOST_EVERY as f32 / probability);
                }
                _ => {
                    rays.alive[i] = false;
                    out.weight[i] = 0.0;
                }
            }
            // A ghost sample carries its hero wavelength alone.
            if count > 1 {
                out.wavelength_weight[i] = s.ghost_inverse_pdf[g];
                for k in 1..count {
                    out.wavelength_weight[k * n + i] = 0.0;
                    out.wavelength_offset[k * n + i] = [0, 0];
                }
                out.wavelength_offset[i] = [0, 0];
            }
        }
    }

    /// The camera sample (pupil point, film jitter, and in a spectral render the wavelength) of
    /// `sample` in every scratch pixel: dimensions 1–2 (pupil), 3–4 (film) and 5 (wavelength)
    /// of the pixel's one Owen-scrambled Sobol pattern (see [`crate::sampling::sobol`]), so the
    /// three are stratified jointly. The pupil takes the first two, the best stratified pair
    /// (a (0, 2)-sequence): defocus, vignetting and the lens's colour all vary over it. Against
    /// a film pattern and a pupil (and wavelength) pattern of their own, this lowers the
    /// luminance error by 6–11 % and the spectral chroma error by 2–8 % at the same spp on the
    /// four course lenses (BENCHMARKS.md, "One Sobol pattern per pixel"). The sequences are
    /// progressive: sample *k* is the same whatever the target spp, so every prefix of a
    /// pixel's samples is well stratified, and a render continued to more samples (a resumed
    /// checkpoint) is the render made at that spp directly.
    #[inline(always)]
    fn camera_samples(&self, sample: u32, seed: u64, scratch: &mut Scratch) {
        let [film_u, film_v, pupil_u, pupil_v, wave_u, _] = &mut scratch.u;
        let pattern_seed = camera_seed(seed);
        // hash32 is a bijection: distinct pixels get distinct patterns.
        let keys = &mut scratch.keys;
        keys.clear();
        keys.extend(
            scratch
                .pixel
                .iter()
                .map(|&pixel| hash32(pixel ^ pattern_seed)),
        );
        let sobol = &mut scratch.sobol;
        if self.dispersion.is_some() {
            owen_sobol_batch(
                sample,
                keys,
                [pupil_u, pupil_v, film_u, film_v, wave_u],
                sobol,
            );
        } else {
            owen_sobol_batch(sample, keys, [pupil_u, pupil_v, film_u, film_v], sobol);
        }
    }

    /// Film point and pupil point of every ray, as the lens-frame ray between them, with its
    /// camera weight; rays from film points no ray leaves are blocked at once.
    #[inline(always)]
    fn film_to_pupil(
        &self,
        sampler: &PupilSampler,
        sample: u32,
        film_z: f32,
        out: &mut CameraRays,
        s: &mut Scratch,
    ) {
        let film = self.film.film_map();
        let tilt = FilmTilt::of(&self.film.movements);
        let rays = &mut out.rays;
        let n = s.pixel.len();
        let [film_u, film_v, ..] = &s.u;
        let (px, py, film_u, film_v) = (&s.px[..n], &s.py[..n], &film_u[..n], &film_v[..n]);
        let (ox, oy) = (&mut rays.ox[..n], &mut rays.oy[..n]);
        for i in 0..n {
            [ox[i], oy[i]] = film.apply(px[i], py[i], film_u[i], film_v[i]);
        }
        rays.oz.fill(film_z);
        if let Some(tilt) = tilt {
            s.depth.resize(n, 0.0);
            let film_distance = self.pupil.film_distance as f32;
            let [[xa, xb], [ya, yb], [za, zb]] = tilt.rotation;
            let [cx, cy] = tilt.centre;
            let oz = &mut rays.oz[..n];
            for i in 0..n {
                let (a, b) = (ox[i] - cx, oy[i] - cy);
                ox[i] = cx + xa * a + xb * b;
                oy[i] = cy + ya * a + yb * b;
                let dz = za * a + zb * b;
                oz[i] = film_z + dz;
                s.depth[i] = film_distance + dz;
            }
        }
        let [_, _, pupil_u, pupil_v, ..] = &s.u;
        rays.pixel.copy_from_slice(&s.pixel);
        rays.sample.fill(sample);
        sampler.sample(FilmRays {
            x: &rays.ox,
            y: &rays.oy,
            depth: tilt.map(|_| &s.depth[..n]),
            u: pupil_u,
            v: pupil_v,
            dx: &mut rays.dx,
            dy: &mut rays.dy,
            dz: &mut rays.dz,
            weight: &mut out.weight,
            passes: &mut rays.alive,
        });
    }

    /// Lens frame (mm) → camera frame (m) → world, for every ray; zero weight for the blocked.
    #[inline(always)]
    fn move_to_world(&self, film_z: f32, out: &mut CameraRays) {
        let m = self.world_from_camera.to_cols_array_2d();
        let rays = &mut out.rays;
        let n = rays.len();
        let (ox, oy, oz) = (&mut rays.ox[..n], &mut rays.oy[..n], &mut rays.oz[..n]);
        let (dx, dy, dz) = (&mut rays.dx[..n], &mut rays.dy[..n], &mut rays.dz[..n]);
        let (alive, weight) = (&rays.alive[..n], &mut out.weight[..n]);
        for i in 0..n {
            let p = [ox[i] * 1e-3, oy[i] * 1e-3, (oz[i] - film_z) * 1e-3];
            let d = [dx[i], dy[i], dz[i]];
            let world =
                |v: [f32; 3], row: usize| m[0][row] * v[0] + m[1][row] * v[1] + m[2][row] * v[2];
            ox[i] = world(p, 0) + m[3][0];
            oy[i] = world(p, 1) + m[3][1];
            oz[i] = world(p, 2) + m[3][2];
            dx[i] = world(d, 0);
            dy[i] = world(d, 1);
            dz[i] = world(d, 2);
            if !alive[i] {
                weight[i] = 0.0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn film_has_requested_diagonal_and_aspect() {
        let film = FilmGeometry::new(300, 200, 36.0);
        let diagonal = (film.width_mm.powi(2) + film.height_mm.powi(2)).sqrt();
        assert!((diagonal - 36.0).abs() < 1e-4);
        assert!((film.width_mm / film.height_mm - 1.5).abs() < 1e-6);
    }

    #[test]
    fn pixels_map_to_inverted_film_points() {
        let film = FilmGeometry::new(100, 100, 10.0);
        // Top-right pixel corner → film bottom-left (the lens flips it back upright).
        let [x, y] = film.film_point(100.0, 0.0);
        assert!(x < 0.0 && y < 0.0);
        let [x, y] = film.film_point(50.0, 50.0);
        assert_eq!((x, y), (0.0, 0.0));
    }
}
