//! The packed form of a lens that tracing reads: surface parameters as structure-of-arrays.

use std::sync::Arc;

use num_traits::Float;

use super::diaphragm::{Diaphragm, StopClip};
use super::dispersion::DispersionTable;
use super::ghost::Ghosts;
use super::prescription::SurfaceRow;
use super::reflectance::SurfaceReflectance;
use super::shape::{ASPHERIC_TERMS, Profile};
use crate::glass::FRAUNHOFER_D_NM;

/// Surface parameters in one precision, one array per parameter, indexed by surface (front to
/// back). `f64` for the reference optics, `f32` for the batched render path.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct SurfaceArrays<T> {
    /// Lens-frame z of each vertex (the first is 0).
    pub vertex_z: Vec<T>,
    /// 1/R of the base surface; 0 for flat surfaces and a bare stop.
    pub curvature: Vec<T>,
    /// κ = 1 + k (1 for spheres and planes).
    pub conic_factor: Vec<T>,
    /// A₂ … A₁₆ (all 0 unless the surface is a polynomial asphere).
    pub aspheric: Vec<[T; ASPHERIC_TERMS]>,
    /// Whether each surface has polynomial terms (and needs the iterative intersection).
    pub polynomial: Vec<bool>,
    /// Square of the clear semi-aperture (the stop's as currently set).
    pub semi_aperture_sq: Vec<T>,
    /// Refractive index on the scene side of each surface.
    pub index_front: Vec<T>,
    /// Refractive index on the film side of each surface.
    pub index_back: Vec<T>,
    /// The diaphragm at the stop, when it is more than the stop's circle.
    pub stop_clip: Option<Arc<StopClip>>,
    /// What each surface reflects (its coating), when the lens loses light at its surfaces;
    /// `None`: every surface transmits everything.
    pub reflectance: Option<Arc<SurfaceReflectance>>,
}

impl<T: Float> SurfaceArrays<T> {
    /// The shape of surface `i`.
    pub fn profile(&self, i: usize) -> Profile<T> {
        Profile {
            curvature: self.curvature[i],
            conic_factor: self.conic_factor[i],
            coefficients: self.aspheric[i],
            polynomial: self.polynomial[i],
        }
    }

    /// True when every surface is a sphere or a plane (the fast batch kernel's case).
    pub fn all_spherical(&self) -> bool {
        !self.polynomial.iter().any(|&p| p) && self.conic_factor.iter().all(|&k| k == T::one())
    }
}

impl<T: Copy> SurfaceArrays<T> {
    pub fn len(&self) -> usize {
        self.vertex_z.len()
    }

    pub fn is_empty(&self) -> bool {
        self.vertex_z.is_empty()
    }

    /// The surfaces in `range` alone (a front or rear group), keeping their lens-frame z.
    pub fn slice(&self, range: std::ops::Range<usize>) -> SurfaceArrays<T> {
        SurfaceArrays {
            vertex_z: self.vertex_z[range.clone()].to_vec(),
            curvature: self.curvature[range.clone()].to_vec(),
            conic_factor: self.conic_factor[range.clone()].to_vec(),
            aspheric: self.aspheric[range.clone()].to_vec(),
            polynomial: self.polynomial[range.clone()].to_vec(),
            semi_aperture_sq: self.semi_aperture_sq[range.clone()].to_vec(),
            index_front: self.index_front[range.clone()].to_vec(),
            index_back: self.index_back[range.clone()].to_vec(),
            // The stop keeps its diaphragm in any group that holds it, renumbered.
            stop_clip: self.stop_clip.as_ref().and_then(|clip| {
                range.contains(&clip.surface).then(|| {
                    Arc::new(StopClip {
                        surface: clip.surface - range.start,
                        ..(**clip).clone()
                    })
                })
            }),
            // A group alone serves first-order and pupil work, which loses no light.
            reflectance: None,
        }
    }

    /// The rows' arrays, with each medium's index from `index` (the row's own, or at a
    /// wavelength).
    fn from_rows(
        rows: &[SurfaceRow],
        convert: impl Fn(f64) -> T,
        index: impl Fn(&SurfaceRow) -> f64,
    ) -> Self {
        let mut arrays = SurfaceArrays {
            vertex_z: Vec::with_capacity(rows.len()),
            curvature: Vec::with_capacity(rows.len()),
            conic_factor: Vec::with_capacity(rows.len()),
            aspheric: Vec::with_capacity(rows.len()),
            polynomial: Vec::with_capacity(rows.len()),
            semi_aperture_sq: Vec::with_capacity(rows.len()),
            index_front: Vec::with_capacity(rows.len()),
            index_back: Vec::with_capacity(rows.len()),
            stop_clip: None,
            reflectance: None,
        };
        let mut z = 0.0;
        let mut index_before = 1.0;
        for row in rows {
            arrays.vertex_z.push(convert(z));
            let curvature = row.curvature();
            arrays.curvature.push(convert(curvature));
            // A conic constant on a plane changes nothing: keep planes on the sphere kernel.
            let conic = if curvature == 0.0 {
                0.0
            } else {
                row.asphere.conic
            };
            arrays.conic_factor.push(convert(1.0 + conic));
            arrays.aspheric.push(row.asphere.coefficients.map(&convert));
            arrays.polynomial.push(row.asphere.has_polynomial());
            arrays
                .semi_aperture_sq
                .push(convert((row.base.aperture / 2.0).powi(2)));
            arrays.index_front.push(convert(index_before));
            arrays.index_back.push(convert(index(row)));
            z += row.base.thickness;
            index_before = index(row);
        }
        arrays
    }
}

/// A lens ready for tracing: its rows with the stop opened to the chosen diameter, and the
/// same data packed as arrays in f64 and f32, with the indices at one wavelength (the rows'
/// own indices, their n_d, unless built [`at_wavelength`](Self::at_wavelength)).
#[derive(Clone, Debug, PartialEq)]
pub struct LensSystem {
    pub rows: Vec<SurfaceRow>,
    pub stop: usize,
    pub f64s: SurfaceArrays<f64>,
    pub f32s: SurfaceArrays<f32>,
    /// The wavelength of the arrays' indices, nm.
    pub wavelength_nm: f64,
    /// Every medium's index over the rendered wavelengths, when any surface has glass data.
    pub dispersion: Option<Arc<DispersionTable>>,
    /// The diaphragm at the stop (also in both arrays' `stop_clip`), sized to the stop as set.
    pub diaphragm: Option<Diaphragm>,
    /// The two-reflection paths of a lens whose surfaces reflect (see [`super::ghost`]).
    pub ghosts: Option<Arc<Ghosts>>,
}

impl LensSystem {
    /// Packs `rows` (thickness-after, validated); `stop_diameter` replaces the stop row's
    /// aperture when given (the caller clamps it to the row's maximum).
    pub fn new(rows: &[SurfaceRow], stop_diameter: Option<f64>) -> LensSystem {
        let mut rows = rows.to_vec();
        let stop = rows.iter().position(|r| r.base.stop).unwrap_or(0);
        if let Some(d) = stop_diameter {
            rows[stop].base.aperture = d;
        }
        let f64s = SurfaceArrays::from_rows(&rows, |v| v, |r| r.base.index);
        let f32s = SurfaceArrays::from_rows(&rows, |v| v as f32, |r| r.base.index);
        let dispersion = DispersionTable::new(&rows).map(Arc::new);
        LensSystem {
            rows,
            stop,
            f64s,
            f32s,
            wavelength_nm: FRAUNHOFER_D_NM,
            dispersion,
            diaphragm: None,
            ghosts: None,
        }
    }

    /// The same lens with `diaphragm` at its stop (inscribed in the stop's circle as set);
    /// `None` or a circular one leaves the stop its circle.
    pub fn with_diaphragm(mut self, diaphragm: Option<&Diaphragm>) -> LensSystem {
        let diaphragm = diaphragm.filter(|d| !d.is_circular());
        let clip = diaphragm.map(|d| {
            Arc::new(StopClip::new(
                d,
                self.stop,
                self.rows[self.stop].base.aperture / 2.0,
            ))
        });
        self.f64s.stop_clip = clip.clone();
        self.f32s.stop_clip = clip;
        self.diaphragm = diaphragm.cloned();
        self
    }

    /// The same lens losing at its surfaces what `reflectance` says they reflect (`None`: a
    /// lossless lens).
    pub fn with_reflectance(mut self, reflectance: Option<Arc<SurfaceReflectance>>) -> LensSystem {
        self.ghosts = reflectance.as_deref().and_then(|r| {
            let after: Vec<f64> = self
                .rows
                .iter()
                .map(|row| row.index_at(FRAUNHOFER_D_NM))
                .collect();
            let before: Vec<f64> = std::iter::once(1.0)
                .chain(after.iter().copied())
                .take(after.len())
                .collect();
            Ghosts::new(r, &before, &after, FRAUNHOFER_D_NM).map(Arc::new)
        });
        self.f64s.reflectance = reflectance.clone();
        self.f32s.reflectance = reflectance;
        self
    }

    /// The same lens with the stop's plain circle (for bounds that must hold for any
    /// diaphragm inside it).
    pub fn without_diaphragm(&self) -> LensSystem {
        self.clone().with_diaphragm(None)
    }

    /// The same lens with every medium's index at `wavelength_nm` (see
    /// [`SurfaceRow::index_at`]): for first-order data and reference rays at any wavelength.
    pub fn at_wavelength(&self, wavelength_nm: f64) -> LensSystem {
        let index = |r: &SurfaceRow| r.index_at(wavelength_nm);
        LensSystem {
            f64s: SurfaceArrays {
                stop_clip: self.f64s.stop_clip.clone(),
                reflectance: self.f64s.reflectance.clone(),
                ..SurfaceArrays::from_rows(&self.rows, |v| v, index)
            },
            f32s: SurfaceArrays {
                stop_clip: self.f32s.stop_clip.clone(),
                reflectance: self.f32s.reflectance.clone(),
                ..SurfaceArrays::from_rows(&self.rows, |v| v as f32, index)
            },
            wavelength_nm,
            ..self.clone()
        }
    }

    /// True when some surface's glass makes the lens's indices depend on wavelength.
    pub fn is_dispersive(&self) -> bool {
        self.dispersion.is_some()
    }

    pub fn surface_count(&self) -> usize {
        self.rows.len()
    }

    /// Lens-frame z of the rear (last) vertex, mm.
    pub fn rear_z(&self) -> f64 {
        *self.f64s.vertex_z.last().unwrap_or(&0.0)
    }

    /// Clear semi-aperture of the rear element, mm.
    pub fn rear_semi_aperture(&self) -> f64 {
        self.rows.last().map_or(0.0, |r| r.base.aperture / 2.0)
    }

    /// Clear semi-aperture of the front element, mm.
    pub fn front_semi_aperture(&self) -> f64 {
        self.rows.first().map_or(0.0, |r| r.base.aperture / 2.0)
    }

    pub fn stop_diameter(&self) -> f64 {
        self.rows[self.stop].base.aperture
    }
}
