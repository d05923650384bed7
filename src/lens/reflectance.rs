//! What each surface of a lens reflects, ready for tracing: the exact coatings for the
//! reference trace, and tables of R(cosine, wavelength) for the batch kernels and the GPU.
//!
//! # The table's coordinates
//!
//! A surface's reflectance depends on the angle of incidence, the wavelength (through the
//! coating's phase thicknesses and the glasses' dispersion) and nothing else: a lossless stack
//! reflects the same from either side (Stokes' reciprocity), so one table serves rays travelling
//! either way. Its angle coordinate is the cosine of the ray's angle **in the less dense of the
//! two media** (the larger of the two angles Snell's law relates): over [0, 1] that cosine covers
//! every ray that crosses the surface, and R is a smooth function of it (in the denser medium's
//! cosine R has a square-root corner at the critical angle, where rays beyond it are reflected
//! totally and never reach the table). Entries are 1/[`COSINE_STEPS`] apart in the cosine and
//! [`WAVELENGTH_STEP_NM`] apart in wavelength, bilinear in between: a quarter-wave coating's
//! reflectance bends over hundreds of nanometres, so the table agrees with the exact
//! characteristic-matrix value to 2e-4 on a three-layer stack and 1e-4 on bare and single-coated surfaces (tested).

use std::sync::Arc;

use super::coating::{Coating, CoatingModel};
use super::prescription::SurfaceRow;
use crate::spectral::{LAMBDA_MAX, LAMBDA_MIN};

/// Table intervals over the cosine's [0, 1].
pub const COSINE_STEPS: usize = 32;
/// Table spacing in wavelength, nm.
pub const WAVELENGTH_STEP_NM: f64 = 5.0;

/// The coatings of a lens's surfaces and their reflectance tables.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceReflectance {
    /// Per surface, front to back, its coating with the layers listed from the scene side.
    coatings: Vec<Coating>,
    /// Per surface (front to back), per table wavelength, per cosine entry: R of unpolarised
    /// light.
    entries: Vec<f32>,
    /// The same entries as bilinear cells, per surface, per wavelength interval, per cosine
    /// interval: the four corners [R(c, w), R(c + 1, w), R(c, w + 1), R(c + 1, w + 1)], so
    /// that the batch kernels' look-up is one 16-byte load.
    cells: Vec<[f32; 4]>,
    wavelengths: usize,
}

impl SurfaceReflectance {
    /// The reflectances of `rows` with `coatings` (one per row, layers from the scene side);
    /// `None` when every surface is [`Coating::Ideal`] (nothing is lost: tracing skips the
    /// losses altogether, so such a lens renders exactly as a lens without coatings).
    pub fn new(rows: &[SurfaceRow], coatings: Vec<Coating>) -> Option<Arc<SurfaceReflectance>> {
        assert_eq!(rows.len(), coatings.len(), "one coating per surface");
        if coatings.iter().all(|c| *c == Coating::Ideal) {
            return None;
        }
        let wavelengths = ((LAMBDA_MAX - LAMBDA_MIN) / WAVELENGTH_STEP_NM).round() as usize + 1;
        let mut entries = Vec::with_capacity(rows.len() * wavelengths * (COSINE_STEPS + 1));
        for (i, coating) in coatings.iter().enumerate() {
            for w in 0..wavelengths {
                let nm = LAMBDA_MIN + w as f64 * WAVELENGTH_STEP_NM;
                let n_front = if i == 0 {
                    1.0
                } else {
                    rows[i - 1].index_at(nm)
                };
                let n_back = rows[i].index_at(nm);
                let n_less = n_front.min(n_back);
                for c in 0..=COSINE_STEPS {
                    // Snell's law from the less dense medium's cosine to the front one's.
                    let cos_less = c as f64 / COSINE_STEPS as f64;
                    let sin_front = (n_less / n_front) * (1.0 - cos_less * cos_less).sqrt();
                    let cos_front = (1.0 - sin_front * sin_front).max(0.0).sqrt();
                    let r = coating
                        .reflectance(n_front, n_back, cos_front, nm)
                        .unpolarised();
                    entries.push(r as f32);
                }
            }
        }
        let row = COSINE_STEPS + 1;
        let cells = (0..coatings.len())
            .flat_map(|surface| {
                (0..wavelengths - 1).map(move |w| (surface * wavelengths + w) * row)
            })
            .flat_map(|start| (0..COSINE_STEPS).map(move |c| start + c))
            .map(|i| {
                [
                    entries[i],
                    entries[i + 1],
                    entries[i + row],
                    entries[i + row + 1],
                ]
            })
            .collect();
        Some(Arc::new(SurfaceReflectance {
            coatings,
            entries,
            cells,
            wavelengths,
        }))
    }

    /// The reflectances of `rows`, each surface coated as `coating(i)` gives it, or where that
    /// is `None` as `model` coats a surface between its indices.
    pub fn with_model(
        rows: &[SurfaceRow],
        coating: impl Fn(usize) -> Option<Coating>,
        model: CoatingModel,
    ) -> Option<Arc<SurfaceReflectance>> {
        let coatings = (0..rows.len())
            .map(|i| {
                coating(i).unwrap_or_else(|| {
                    let n_front = if i == 0 { 1.0 } else { rows[i - 1].base.index };
                    model.coating_for(n_front, rows[i].base.index)
                })
            })
            .collect();
        SurfaceReflectance::new(rows, coatings)
    }

    /// What the lens transmits on its axis at `wavelength_nm`, every surface met at normal
    /// incidence: the product of 1 − R over its surfaces (`rows` give the indices).
    pub fn axial_transmission(&self, rows: &[SurfaceRow], wavelength_nm: f64) -> f64 {
        let mut before = 1.0;
        let mut transmitted = 1.0;
        for (i, row) in rows.iter().enumerate() {
            let after = row.index_at(wavelength_nm);
            transmitted *= 1.0 - self.exact(i, before, after, 1.0, wavelength_nm, true);
            before = after;
        }
        transmitted
    }

    /// Surface `i`'s coating, layers from the scene side.
    pub fn coating(&self, i: usize) -> &Coating {
        &self.coatings[i]
    }

    pub fn surface_count(&self) -> usize {
        self.coatings.len()
    }

    /// Entries per surface and wavelength: `COSINE_STEPS + 1`.
    pub const fn cosine_entries() -> usize {
        COSINE_STEPS + 1
    }

    /// Table wavelengths per surface ([`WAVELENGTH_STEP_NM`] apart from `LAMBDA_MIN`).
    pub fn wavelength_entries(&self) -> usize {
        self.wavelengths
    }

    /// The bilinear cells (see the field's docs): per surface `(wavelength_entries() − 1) ·
    /// COSINE_STEPS` of them.
    pub fn cells(&self) -> &[[f32; 4]] {
        &self.cells
    }

    /// Every entry, surface-major, then wavelength, then cosine: what the GPU uploads.
    pub fn entries(&self) -> &[f32] {
        &self.entries
    }

    /// The table coordinate of `wavelength_nm`: entry `w` and the fraction toward `w + 1`.
    #[inline(always)]
    pub fn position(&self, wavelength_nm: f32) -> (usize, f32) {
        let last = self.wavelengths - 1;
        let x = ((wavelength_nm - LAMBDA_MIN as f32) / WAVELENGTH_STEP_NM as f32)
            .clamp(0.0, last as f32);
        let w = (x as usize).min(last - 1);
        (w, x - w as f32)
    }

    /// R at surface `surface` for a ray whose cosine in the less dense medium is `cosine`, at
    /// table wavelength `(w, t)` (from [`Self::position`]): bilinear in the table.
    #[inline(always)]
    pub fn lookup(&self, surface: usize, cosine: f32, (w, t): (usize, f32)) -> f32 {
        let x = (cosine * COSINE_STEPS as f32).clamp(0.0, COSINE_STEPS as f32);
        let c = (x as usize).min(COSINE_STEPS - 1);
        let u = x - c as f32;
        let row = (surface * self.wavelengths + w) * (COSINE_STEPS + 1) + c;
        let next = row + COSINE_STEPS + 1;
        let e = &self.entries;
        let at = |base: usize| e[base] + u * (e[base + 1] - e[base]);
        let (r0, r1) = (at(row), at(next));
        r0 + t * (r1 - r0)
    }

    /// The exact reflectance of surface `surface` for light from `n_in` at cosine `cos_in` onto
    /// `n_out`, at `wavelength_nm` (`from_front`: the light comes from the scene side). For the
    /// reference trace.
    pub fn exact(
        &self,
        surface: usize,
        n_in: f64,
        n_out: f64,
        cos_in: f64,
        wavelength_nm: f64,
        from_front: bool,
    ) -> f64 {
        let coating = &self.coatings[surface];
        let r = if from_front {
            coating.reflectance(n_in, n_out, cos_in, wavelength_nm)
        } else {
            coating
                .reversed()
                .reflectance(n_in, n_out, cos_in, wavelength_nm)
        };
        r.unpolarised()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::io::bundled::load_lens;

    fn dgauss_rows() -> Vec<SurfaceRow> {
        load_lens("dgauss.50mm", None).unwrap().rows
    }

    /// The table agrees with the characteristic-matrix reflectance it samples, between its
    /// entries (the worst case for bilinear interpolation), for every surface of a real lens
    /// with its glasses' dispersion, and every model.
    #[test]
    fn the_table_agrees_with_the_exact_reflectance_between_its_entries() {
        let rows = dgauss_rows();
        for model in [
            CoatingModel::None,
            CoatingModel::Single,
            CoatingModel::Multi,
        ] {
            let table = SurfaceReflectance::with_model(&rows, |_| None, model).unwrap();
            let mut worst = 0.0f64;
            for i in 0..rows.len() {
                for nm in [401.7, 486.1, 555.5, 587.6, 656.3, 702.9] {
                    let n_front = if i == 0 {
                        1.0
                    } else {
                        rows[i - 1].index_at(nm)
                    };
                    let n_back = rows[i].index_at(nm);
                    for degrees in [0.0f64, 7.3, 21.1, 33.3, 48.8, 61.9] {
                        // A ray at this angle in the less dense medium, seen from the front.
                        let n_less = n_front.min(n_back);
                        let cos_less = degrees.to_radians().cos();
                        let sin_front = n_less / n_front * degrees.to_radians().sin();
                        let cos_front = (1.0 - sin_front * sin_front).sqrt();
                        let exact = table.exact(i, n_front, n_back, cos_front, nm, true);
                        let looked_up =
                            table.lookup(i, cos_less as f32, table.position(nm as f32)) as f64;
                        worst = worst.max((exact - looked_up).abs());
                    }
                }
            }
            assert!(worst < 2e-4, "{model:?}: worst {worst}");
        }
    }

    /// Every surface ideal: no table, so tracing skips the losses and the render is the lossless
    /// lens's, bit for bit.
    #[test]
    fn an_ideal_lens_has_no_table() {
        let rows = dgauss_rows();
        assert!(SurfaceReflectance::with_model(&rows, |_| None, CoatingModel::Ideal).is_none());
        assert!(SurfaceReflectance::with_model(&rows, |_| None, CoatingModel::None).is_some());
    }

    /// A bare surface's normal-incidence entry is Fresnel's ((n − 1)/(n + 1))² at the table's
    /// wavelengths, with n from the glass at that wavelength.
    #[test]
    fn normal_incidence_entries_are_fresnels_figure() {
        let rows = dgauss_rows();
        let table = SurfaceReflectance::with_model(&rows, |_| None, CoatingModel::None).unwrap();
        let nm = LAMBDA_MIN + 20.0 * WAVELENGTH_STEP_NM;
        let n = rows[0].index_at(nm);
        let expected = ((n - 1.0) / (n + 1.0)).powi(2);
        let got = table.lookup(0, 1.0, table.position(nm as f32)) as f64;
        assert!((got - expected).abs() < 1e-6, "{got} vs {expected}");
    }
}
