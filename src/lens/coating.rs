//! What a surface reflects: Fresnel at a bare interface, and thin-film interference in an
//! anti-reflection coating on it.
//!
//! # Conventions (used throughout this module)
//!
//! * Light arrives from medium `n_in` (index, real: the glasses and coatings are lossless in
//!   the visible) onto medium `n_out`, at an angle whose cosine in the incident medium is
//!   `cos_in` ∈ [0, 1]. A coating's layers are listed **from the incident side**, so the same
//!   coating seen from the other side is its layers reversed (a caller tracing toward the
//!   film and one tracing toward the scene see the same physical stack).
//! * Wavelengths are in air, nm; a layer's thickness is physical, nm.
//! * Unpolarised light reflects the mean of the s (TE) and p (TM) reflectances. No absorption:
//!   what is not reflected is transmitted, T = 1 − R.
//!
//! # The characteristic matrix (Macleod, *Thin-Film Optical Filters*, ch. 2)
//!
//! Each layer j of index n_j and thickness d_j carries the ray at an angle θ_j fixed by Snell's
//! law, n_j sin θ_j = n_in sin θ_in, with phase thickness δ_j = 2π n_j d_j cos θ_j / λ and
//! tilted admittance η_j = n_j cos θ_j (s) or n_j / cos θ_j (p). Its matrix is
//!
//! ```text
//! M_j = | cos δ_j            i sin δ_j / η_j |
//!       | i η_j sin δ_j      cos δ_j         |
//! ```
//!
//! and the stack on the exit medium (admittance η_out) gives (B, C) = M_1 ⋯ M_m (1, η_out) and
//! the amplitude reflectance r = (η_in B − C) / (η_in B + C), R = |r|². With no layers this is
//! Fresnel's r at the bare interface. Beyond the critical angle cos θ becomes imaginary (an
//! evanescent wave): the same formulas in complex numbers give R = 1 for total internal
//! reflection, and the tunnelling through a thin layer above its critical angle.

use num_complex::Complex64;

/// One layer of a coating: its index and physical thickness (nm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layer {
    pub index: f64,
    pub thickness_nm: f64,
}

impl Layer {
    /// A layer of `index` a quarter wave thick at `design_nm` (optical thickness n·d = λ/4 at
    /// normal incidence).
    pub fn quarter_wave(index: f64, design_nm: f64) -> Layer {
        Layer {
            index,
            thickness_nm: design_nm / (4.0 * index),
        }
    }
}

/// The coating on one surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Coating {
    /// Bare: Fresnel reflection at the interface.
    None,
    /// Thin films, from the incident side (see the module docs).
    Layers(Vec<Layer>),
    /// A measured reflectance curve, (nm, R) by increasing wavelength, linear in between and
    /// held beyond its ends; for both polarisations and every angle (what a datasheet gives).
    Measured(Vec<(f64, f64)>),
    /// A perfect anti-reflection coating: reflects nothing at any wavelength or angle (the
    /// lossless lens of renderers without coatings, and of realcam before it had them).
    Ideal,
}

/// The reflectances of the two polarisations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reflectance {
    pub s: f64,
    pub p: f64,
}

impl Reflectance {
    /// Of unpolarised light.
    pub fn unpolarised(&self) -> f64 {
        0.5 * (self.s + self.p)
    }
}

impl Coating {
    /// A single quarter-wave layer of `index` at `design_nm` (magnesium fluoride, n = 1.38 at
    /// 550 nm, is the classic one).
    pub fn single_layer(index: f64, design_nm: f64) -> Coating {
        Coating::Layers(vec![Layer::quarter_wave(index, design_nm)])
    }

    /// Whether the coating is physically possible: layer indices of at least 1 and finite,
    /// non-negative thicknesses; a measured curve of reflectances in [0, 1] at increasing
    /// wavelengths.
    pub fn check(&self) -> Result<(), String> {
        match self {
            Coating::None | Coating::Ideal => Ok(()),
            Coating::Layers(layers) => {
                for (k, layer) in layers.iter().enumerate() {
                    if !(layer.index.is_finite() && layer.index >= 1.0) {
                        return Err(format!(
                            "layer {}: index {} (must be a number of at least 1)",
                            k + 1,
                            layer.index
                        ));
                    }
                    if !(layer.thickness_nm.is_finite() && layer.thickness_nm >= 0.0) {
                        return Err(format!(
                            "layer {}: thickness {} nm (must be a number of at least 0)",
                            k + 1,
                            layer.thickness_nm
                        ));
                    }
                }
                Ok(())
            }
            Coating::Measured(curve) => {
                if curve.is_empty() {
                    return Err("a measured curve with no points".into());
                }
                for (k, &(nm, r)) in curve.iter().enumerate() {
                    if !(nm.is_finite() && nm > 0.0) {
                        return Err(format!("point {}: wavelength {nm} nm", k + 1));
                    }
                    if !(0.0..=1.0).contains(&r) {
                        return Err(format!(
                            "point {}: reflectance {r} at {nm} nm (must be between 0 and 1)",
                            k + 1
                        ));
                    }
                    if k > 0 && nm <= curve[k - 1].0 {
                        return Err(format!(
                            "point {}: {nm} nm after {} nm (wavelengths must increase)",
                            k + 1,
                            curve[k - 1].0
                        ));
                    }
                }
                Ok(())
            }
        }
    }

    /// The coating seen from its other side: its layers in reverse order.
    pub fn reversed(&self) -> Coating {
        match self {
            Coating::Layers(layers) => Coating::Layers(layers.iter().rev().copied().collect()),
            other => other.clone(),
        }
    }

    /// What light from `n_in` at cosine `cos_in` reflects off this coating on `n_out`, at
    /// wavelength `lambda_nm`.
    pub fn reflectance(&self, n_in: f64, n_out: f64, cos_in: f64, lambda_nm: f64) -> Reflectance {
        match self {
            Coating::None => stack_reflectance(&[], n_in, n_out, cos_in, lambda_nm),
            Coating::Layers(layers) => stack_reflectance(layers, n_in, n_out, cos_in, lambda_nm),
            Coating::Measured(curve) => {
                let r = measured_at(curve, lambda_nm);
                Reflectance { s: r, p: r }
            }
            Coating::Ideal => Reflectance { s: 0.0, p: 0.0 },
        }
    }
}

/// Which coatings a lens's surfaces get when its file says nothing of them (and what
/// `--coating` chooses): the same model on every air–glass surface; cemented surfaces (glass on
/// both sides) stay bare, as they are in real lenses (the cement matches the glasses closely).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CoatingModel {
    /// Every surface bare: Fresnel's losses alone.
    None,
    /// A quarter wave of magnesium fluoride (n = 1.38) at 550 nm: the classic single coating.
    #[default]
    Single,
    /// A broadband quarter–half–quarter stack at 550 nm (from the air side: n = 1.38, 2.15
    /// and 1.38·√n_glass), the classic three-layer multi-coating.
    Multi,
    /// A perfect anti-reflection coating on every surface, cemented ones included: no losses
    /// (and no ghosts), the lossless lens.
    Ideal,
}

/// The single coating's layer: magnesium fluoride, a quarter wave at 550 nm.
const MGF2: f64 = 1.38;
/// Design wavelength of the models' coatings, nm.
const DESIGN_NM: f64 = 550.0;

impl std::str::FromStr for CoatingModel {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        match text {
            "none" => Ok(CoatingModel::None),
            "single" => Ok(CoatingModel::Single),
            "multi" => Ok(CoatingModel::Multi),
            "ideal" => Ok(CoatingModel::Ideal),
            other => Err(format!(
                "unknown coating '{other}': use none, single, multi or ideal"
            )),
        }
    }
}

impl CoatingModel {
    pub fn name(self) -> &'static str {
        match self {
            CoatingModel::None => "none",
            CoatingModel::Single => "single",
            CoatingModel::Multi => "multi",
            CoatingModel::Ideal => "ideal",
        }
    }

    /// The coating this model puts on a surface between indices `n_in` (the side light comes
    /// from) and `n_out`, its layers listed from the `n_in` side.
    pub fn coating_for(self, n_in: f64, n_out: f64) -> Coating {
        let is_air = |n: f64| (n - 1.0).abs() < 1e-3;
        let air_glass = is_air(n_in) != is_air(n_out);
        if !air_glass {
            return match self {
                CoatingModel::Ideal => Coating::Ideal,
                _ => Coating::None,
            };
        }
        let from_air = match self {
            CoatingModel::None => return Coating::None,
            CoatingModel::Single => Coating::single_layer(MGF2, DESIGN_NM),
            CoatingModel::Multi => {
                let glass = if is_air(n_in) { n_out } else { n_in };
                let half = |index: f64| Layer {
                    index,
                    thickness_nm: DESIGN_NM / (2.0 * index),
                };
                // The inner quarter wave's index makes the pair reflect nothing at the design
                // wavelength, n₂ = n₁·√n_glass (the V-coat condition); the half wave between
                // them, absent at 550 nm, flattens the response across the visible.
                Coating::Layers(vec![
                    Layer::quarter_wave(MGF2, DESIGN_NM),
                    half(2.15),
                    Layer::quarter_wave(MGF2 * glass.sqrt(), DESIGN_NM),
                ])
            }
            CoatingModel::Ideal => return Coating::Ideal,
        };
        if is_air(n_in) {
            from_air
        } else {
            from_air.reversed()
        }
    }
}

/// Fresnel's reflectances at a bare interface from `n_in` onto `n_out` at cosine `cos_in`.
pub fn fresnel(n_in: f64, n_out: f64, cos_in: f64) -> Reflectance {
    Coating::None.reflectance(n_in, n_out, cos_in, 550.0)
}

/// cos θ in a medium of index `n`, from the invariant n_in sin θ_in = n sin θ (complex beyond
/// the critical angle: the root with positive imaginary part, the wave that decays).
fn cosine_in(n: f64, n_in: f64, cos_in: f64) -> Complex64 {
    let sin_in_sq = (1.0 - cos_in * cos_in).max(0.0);
    let cos_sq = 1.0 - (n_in / n).powi(2) * sin_in_sq;
    if cos_sq >= 0.0 {
        Complex64::new(cos_sq.sqrt(), 0.0)
    } else {
        Complex64::new(0.0, (-cos_sq).sqrt())
    }
}

/// Tilted admittances (s, p) of a medium of index `n` where the ray's cosine is `cos`.
fn admittances(n: f64, cos: Complex64) -> (Complex64, Complex64) {
    (n * cos, n / cos)
}

fn stack_reflectance(
    layers: &[Layer],
    n_in: f64,
    n_out: f64,
    cos_in: f64,
    lambda_nm: f64,
) -> Reflectance {
    let cos_in = cos_in.clamp(0.0, 1.0);
    let (eta_in_s, eta_in_p) = admittances(n_in, Complex64::new(cos_in, 0.0));
    let (eta_out_s, eta_out_p) = admittances(n_out, cosine_in(n_out, n_in, cos_in));
    let i = Complex64::i();
    // (B, C) for each polarisation, built from the exit medium outward.
    let mut s = (Complex64::new(1.0, 0.0), eta_out_s);
    let mut p = (Complex64::new(1.0, 0.0), eta_out_p);
    for layer in layers.iter().rev() {
        let cos = cosine_in(layer.index, n_in, cos_in);
        let delta = 2.0 * std::f64::consts::PI * layer.index * layer.thickness_nm * cos / lambda_nm;
        let (cos_d, sin_d) = (delta.cos(), delta.sin());
        let (eta_s, eta_p) = admittances(layer.index, cos);
        let apply = |(b, c): (Complex64, Complex64), eta: Complex64| {
            (
                cos_d * b + i * sin_d / eta * c,
                i * eta * sin_d * b + cos_d * c,
            )
        };
        s = apply(s, eta_s);
        p = apply(p, eta_p);
    }
    let reflect = |(b, c): (Complex64, Complex64), eta_in: Complex64| {
        let r = (eta_in * b - c) / (eta_in * b + c);
        // Lossless media: R ≤ 1 up to rounding.
        r.norm_sqr().min(1.0)
    };
    Reflectance {
        s: reflect(s, eta_in_s),
        p: reflect(p, eta_in_p),
    }
}

/// A measured curve's reflectance at `lambda_nm` (see [`Coating::Measured`]).
fn measured_at(curve: &[(f64, f64)], lambda_nm: f64) -> f64 {
    match curve {
        [] => 0.0,
        [(_, r)] => *r,
        _ => {
            let k = curve
                .partition_point(|&(l, _)| l < lambda_nm)
                .clamp(1, curve.len() - 1);
            let ((l0, r0), (l1, r1)) = (curve[k - 1], curve[k]);
            let t = ((lambda_nm - l0) / (l1 - l0)).clamp(0.0, 1.0);
            r0 + t * (r1 - r0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cos_deg(degrees: f64) -> f64 {
        degrees.to_radians().cos()
    }

    /// At normal incidence a bare surface reflects ((n − 1)/(n + 1))² from either side: 4.26 %
    /// for n = 1.52 and 6.30 % for 1.67.
    #[test]
    fn a_bare_surface_reflects_fresnels_normal_figure() {
        for (n, expected) in [(1.52, 0.042_580), (1.67, 0.062_969)] {
            let into = fresnel(1.0, n, 1.0);
            let out_of = fresnel(n, 1.0, 1.0);
            for r in [into.s, into.p, out_of.s, out_of.p] {
                assert!((r - expected).abs() < 1e-6, "n = {n}: {r} vs {expected}");
            }
        }
    }

    /// Hecht's worked figures for air to n = 1.5 at 45°: Rs = 0.0920, Rp = 0.0085; p vanishes
    /// at Brewster's angle tan θ = n₂/n₁ (from either side); beyond the critical angle, and at
    /// grazing incidence, everything is reflected.
    #[test]
    fn oblique_reflectance_matches_the_closed_forms_and_their_landmarks() {
        let r = fresnel(1.0, 1.5, cos_deg(45.0));
        assert!((r.s - 0.092_02).abs() < 5e-5, "{r:?}");
        assert!((r.p - 0.008_47).abs() < 5e-5, "{r:?}");
        for (n1, n2) in [(1.0f64, 1.5f64), (1.5, 1.0), (1.2, 1.9)] {
            let brewster: f64 = (n2 / n1).atan();
            let r = fresnel(n1, n2, brewster.cos());
            assert!(r.p < 1e-20, "{n1} → {n2}: {r:?}");
            assert!(r.s > 0.01, "{n1} → {n2}: {r:?}");
        }
        let critical = (1.0f64 / 1.5).asin();
        for beyond in [critical + 1e-3, critical + 0.2, 1.5] {
            let r = fresnel(1.5, 1.0, beyond.cos());
            assert!(
                (r.s - 1.0).abs() < 1e-12 && (r.p - 1.0).abs() < 1e-12,
                "{r:?}"
            );
        }
        let grazing = fresnel(1.0, 1.5, 0.0);
        assert!((grazing.s - 1.0).abs() < 1e-12 && (grazing.p - 1.0).abs() < 1e-12);
        // The closed forms at several angles, written out independently.
        for degrees in [0.0f64, 10.0, 30.0, 50.0, 70.0, 85.0] {
            let (n1, n2) = (1.0, 1.67);
            let ci = cos_deg(degrees);
            let ct = (1.0 - (n1 / n2) * (n1 / n2) * (1.0 - ci * ci)).sqrt();
            let rs = ((n1 * ci - n2 * ct) / (n1 * ci + n2 * ct)).powi(2);
            let rp = ((n1 * ct - n2 * ci) / (n1 * ct + n2 * ci)).powi(2);
            let r = fresnel(n1, n2, ci);
            assert!(
                (r.s - rs).abs() < 1e-12 && (r.p - rp).abs() < 1e-12,
                "{degrees}°"
            );
        }
    }

    /// A quarter-wave layer of index n_c on glass n_s, at its design wavelength and normal
    /// incidence, reflects ((n_s − n_c²)/(n_s + n_c²))²: magnesium fluoride (1.38) on n = 1.67
    /// about 0.43 %, its minimum, at the design wavelength; a layer of n_c = √n_s none at all.
    #[test]
    fn a_quarter_wave_layer_has_its_minimum_at_its_design_wavelength() {
        let (n_s, n_c, design) = (1.67, 1.38, 550.0);
        let coating = Coating::single_layer(n_c, design);
        let expected = ((n_s - n_c * n_c) / (n_s + n_c * n_c)).powi(2);
        let at_design = coating.reflectance(1.0, n_s, 1.0, design).unpolarised();
        assert!(
            (at_design - expected).abs() < 1e-9,
            "{at_design} vs {expected}"
        );
        assert!((0.0042..0.0044).contains(&at_design), "{at_design}");
        let scan: Vec<(f64, f64)> = (380..=780)
            .map(|l| {
                let l = l as f64;
                (l, coating.reflectance(1.0, n_s, 1.0, l).unpolarised())
            })
            .collect();
        let (lowest, _) = scan
            .iter()
            .copied()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        assert!((lowest - design).abs() <= 1.0, "minimum at {lowest} nm");
        // The bare surface reflects more everywhere in the visible.
        let bare = fresnel(1.0, n_s, 1.0).unpolarised();
        assert!(scan.iter().all(|&(_, r)| r < bare));
        let perfect = Coating::single_layer(n_s.sqrt(), design);
        assert!(perfect.reflectance(1.0, n_s, 1.0, design).unpolarised() < 1e-20);
    }

    /// Two quarter-wave layers (a "V" coat), n₁ next to air and n₂ next to the glass, reflect
    /// ((n₂² − n_s n₁²)/(n₂² + n_s n₁²))² at the design wavelength; and the stack seen from
    /// the glass side reflects the same (a lossless stack's reflectance does not depend on the
    /// side).
    #[test]
    fn a_two_layer_stack_matches_its_closed_form_from_either_side() {
        let (n_s, n1, n2, design) = (1.52, 1.38, 1.70, 520.0);
        let coating = Coating::Layers(vec![
            Layer::quarter_wave(n1, design),
            Layer::quarter_wave(n2, design),
        ]);
        let expected = ((n2 * n2 - n_s * n1 * n1) / (n2 * n2 + n_s * n1 * n1)).powi(2);
        let from_air = coating.reflectance(1.0, n_s, 1.0, design).unpolarised();
        assert!(
            (from_air - expected).abs() < 1e-9,
            "{from_air} vs {expected}"
        );
        for l in [400.0, 520.0, 650.0] {
            for degrees in [0.0, 20.0, 35.0] {
                let a = coating.reflectance(1.0, n_s, cos_deg(degrees), l);
                // The same ray from the glass side: its angle there by Snell's law.
                let sin_glass = cos_deg(90.0 - degrees) / n_s;
                let cos_glass = (1.0 - sin_glass * sin_glass).sqrt();
                let b = coating.reversed().reflectance(n_s, 1.0, cos_glass, l);
                assert!(
                    (a.s - b.s).abs() < 1e-12 && (a.p - b.p).abs() < 1e-12,
                    "{l} nm {degrees}°"
                );
            }
        }
    }

    /// Energy bookkeeping: every reflectance lies in [0, 1] (so T = 1 − R does too) over
    /// random indices, angles, wavelengths and stacks, including rays beyond a critical angle.
    #[test]
    fn reflectance_stays_between_zero_and_one() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..20_000 {
            let n_in = 1.0 + next();
            let n_out = 1.0 + next();
            let layers: Vec<Layer> = (0..(next() * 5.0) as usize)
                .map(|_| Layer {
                    index: 1.2 + next(),
                    thickness_nm: next() * 400.0,
                })
                .collect();
            let r =
                Coating::Layers(layers).reflectance(n_in, n_out, next(), 360.0 + 420.0 * next());
            for v in [r.s, r.p] {
                assert!((0.0..=1.0).contains(&v) && v.is_finite(), "{r:?}");
            }
        }
    }

    /// What a plate of `n` in air coated on both faces as `model` says transmits at normal
    /// incidence.
    fn plate_transmission(n: f64, model: CoatingModel, lambda_nm: f64) -> f64 {
        let into = model
            .coating_for(1.0, n)
            .reflectance(1.0, n, 1.0, lambda_nm);
        let out_of = model
            .coating_for(n, 1.0)
            .reflectance(n, 1.0, 1.0, lambda_nm);
        (1.0 - into.unpolarised()) * (1.0 - out_of.unpolarised())
    }

    /// The models coat air–glass surfaces only, the same physical stack from either side.
    #[test]
    fn the_models_coat_air_glass_surfaces_and_leave_cemented_ones_bare() {
        for model in [CoatingModel::Single, CoatingModel::Multi] {
            assert_eq!(model.coating_for(1.6, 1.52), Coating::None, "cemented");
            assert_eq!(
                model.coating_for(1.0, 1.0),
                Coating::None,
                "the stop in air"
            );
            let into = model.coating_for(1.0, 1.6);
            assert_eq!(model.coating_for(1.6, 1.0), into.reversed());
            assert_ne!(into, Coating::None);
        }
        assert_eq!(CoatingModel::None.coating_for(1.0, 1.6), Coating::None);
        assert_eq!("multi".parse::<CoatingModel>(), Ok(CoatingModel::Multi));
        assert!(
            "mgf2"
                .parse::<CoatingModel>()
                .unwrap_err()
                .contains("none, single, multi or ideal")
        );
        // A plate of n = 1.52 in air, uncoated: (1 − R)² with R = ((n − 1)/(n + 1))².
        let r = (0.52f64 / 2.52).powi(2);
        let plate = plate_transmission(1.52, CoatingModel::None, 587.56);
        assert!((plate - (1.0 - r).powi(2)).abs() < 1e-12);
        // Coated, it loses less at every visible wavelength, multi less than single near 550.
        for l in [450.0, 550.0, 650.0] {
            let single = plate_transmission(1.52, CoatingModel::Single, l);
            let multi = plate_transmission(1.52, CoatingModel::Multi, l);
            assert!(
                single > plate && multi > plate,
                "{l} nm: {single} {multi} {plate}"
            );
        }
        let single = plate_transmission(1.52, CoatingModel::Single, 550.0);
        let multi = plate_transmission(1.52, CoatingModel::Multi, 550.0);
        assert!(multi > single, "{multi} vs {single}");
    }

    #[test]
    fn a_measured_curve_is_read_linearly_and_held_at_its_ends() {
        let curve = Coating::Measured(vec![(400.0, 0.02), (500.0, 0.004), (700.0, 0.01)]);
        let at = |l: f64| curve.reflectance(1.0, 1.5, 1.0, l).unpolarised();
        assert!((at(450.0) - 0.012).abs() < 1e-12);
        assert!((at(600.0) - 0.007).abs() < 1e-12);
        assert_eq!(at(300.0), 0.02);
        assert_eq!(at(800.0), 0.01);
    }
}
