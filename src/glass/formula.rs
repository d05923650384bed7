//! A catalogue glass's dispersion formula: n(λ) from the maker's coefficients.
//!
//! The catalogue stores refractiveindex.info's formula numbers and coefficient lists
//! `c0 c1 c2 …`, with λ in µm:
//!
//! * formula 2, **Sellmeier**: n² − 1 = c0 + Σᵢ c(2i−1)·λ² / (λ² − c(2i)), the C terms in µm²
//!   (Schott, Ohara and CDGM publish this form);
//! * formula 3, **polynomial** (Schott's old "Schott formula" and its extensions, used by Hoya,
//!   Hikari and Sumita): n² = c0 + Σᵢ c(2i−1)·λ^c(2i), with integer exponents.

use std::fmt;

/// n(λ) of one catalogue glass.
#[derive(Clone, Debug, PartialEq)]
pub enum DispersionFormula {
    /// n² − 1 = c0 + Σ Bᵢ·λ² / (λ² − Cᵢ), λ in µm; `terms` are the (Bᵢ, Cᵢ µm²) pairs.
    Sellmeier { c0: f64, terms: Vec<(f64, f64)> },
    /// n² = c0 + Σ aᵢ·λ^pᵢ, λ in µm; `terms` are the (aᵢ, pᵢ) pairs.
    Polynomial { c0: f64, terms: Vec<(f64, i32)> },
}

impl DispersionFormula {
    /// Builds a formula from refractiveindex.info's formula number and coefficient list.
    pub fn from_refractiveindex_info(
        formula: u32,
        coefficients: &[f64],
    ) -> Result<DispersionFormula, String> {
        let Some((&c0, rest)) = coefficients.split_first() else {
            return Err("no coefficients".into());
        };
        if rest.len() % 2 != 0 {
            return Err(format!(
                "formula {formula} needs c0 and pairs of coefficients, got {} numbers",
                coefficients.len()
            ));
        }
        if let Some(bad) = coefficients.iter().find(|c| !c.is_finite()) {
            return Err(format!("coefficient {bad} is not a finite number"));
        }
        let pairs = rest.chunks_exact(2).map(|p| (p[0], p[1]));
        match formula {
            2 => Ok(DispersionFormula::Sellmeier {
                c0,
                terms: pairs.collect(),
            }),
            3 => {
                let terms = pairs
                    .map(|(a, p)| {
                        if p.fract() == 0.0 && p.abs() <= 64.0 {
                            Ok((a, p as i32))
                        } else {
                            Err(format!(
                                "polynomial exponent {p} is not a small integer (only integer powers are supported)"
                            ))
                        }
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                Ok(DispersionFormula::Polynomial { c0, terms })
            }
            other => Err(format!(
                "dispersion formula {other} is not supported (only 2, Sellmeier, and 3, polynomial)"
            )),
        }
    }

    /// refractiveindex.info's number for this form.
    pub fn refractiveindex_info_number(&self) -> u32 {
        match self {
            DispersionFormula::Sellmeier { .. } => 2,
            DispersionFormula::Polynomial { .. } => 3,
        }
    }

    /// The coefficient list `c0 c1 c2 …` in refractiveindex.info's order.
    pub fn coefficients(&self) -> Vec<f64> {
        match self {
            DispersionFormula::Sellmeier { c0, terms } => std::iter::once(*c0)
                .chain(terms.iter().flat_map(|&(b, c)| [b, c]))
                .collect(),
            DispersionFormula::Polynomial { c0, terms } => std::iter::once(*c0)
                .chain(terms.iter().flat_map(|&(a, p)| [a, f64::from(p)]))
                .collect(),
        }
    }

    /// "Sellmeier" or "polynomial".
    pub fn kind(&self) -> &'static str {
        match self {
            DispersionFormula::Sellmeier { .. } => "Sellmeier",
            DispersionFormula::Polynomial { .. } => "polynomial",
        }
    }

    /// Refractive index (relative to air, as catalogues give it) at `wavelength_um` µm.
    /// Outside the glass's valid range the formula is extrapolated; far outside it may return
    /// NaN (n² < 0).
    pub fn index_um(&self, wavelength_um: f64) -> f64 {
        let l2 = wavelength_um * wavelength_um;
        let n2 = match self {
            DispersionFormula::Sellmeier { c0, terms } => {
                1.0 + c0 + terms.iter().map(|&(b, c)| b * l2 / (l2 - c)).sum::<f64>()
            }
            DispersionFormula::Polynomial { c0, terms } => {
                // Every exponent in the catalogue is even: λ^p = (λ²)^(p/2), and the negative
                // powers share one division.
                let inv_l2 = 1.0 / l2;
                c0 + terms
                    .iter()
                    .map(|&(a, p)| match (p % 2, p < 0) {
                        (0, false) => a * l2.powi(p / 2),
                        (0, true) => a * inv_l2.powi(-p / 2),
                        _ => a * wavelength_um.powi(p),
                    })
                    .sum::<f64>()
            }
        };
        n2.sqrt()
    }
}

/// The formula written out, e.g. `n² − 1 = 1.03961212·λ²/(λ² − 0.00600069867) + …`.
impl fmt::Display for DispersionFormula {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DispersionFormula::Sellmeier { c0, terms } => {
                write!(f, "n² − 1 = ")?;
                let mut first = true;
                if *c0 != 0.0 {
                    write!(f, "{c0}")?;
                    first = false;
                }
                for &(b, c) in terms {
                    if !first {
                        write!(f, " + ")?;
                    }
                    write!(f, "{b}·λ²/(λ² − {c})")?;
                    first = false;
                }
                Ok(())
            }
            DispersionFormula::Polynomial { c0, terms } => {
                write!(f, "n² = {c0}")?;
                for &(a, p) in terms {
                    write!(f, " + {a}·λ^{p}")?;
                }
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sellmeier_matches_a_hand_evaluation() {
        // One term, c0 = 0.5: n² = 1.5 + 1·λ²/(λ² − 0.01) at λ = 0.5 µm: 1.5 + 0.25/0.24.
        let f = DispersionFormula::from_refractiveindex_info(2, &[0.5, 1.0, 0.01]).unwrap();
        let expected = (1.5_f64 + 0.25 / 0.24).sqrt();
        assert!((f.index_um(0.5) - expected).abs() < 1e-15);
    }

    #[test]
    fn polynomial_matches_a_hand_evaluation() {
        // n² = 2 − 0.01·λ² + 0.02·λ⁻² at λ = 0.5 µm: 2 − 0.0025 + 0.08.
        let f = DispersionFormula::from_refractiveindex_info(3, &[2.0, -0.01, 2.0, 0.02, -2.0])
            .unwrap();
        assert!((f.index_um(0.5) - 2.0775_f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn odd_and_negative_powers_are_exact() {
        // n² = 1 + 0.1·λ³ + 0.01·λ⁻³ + 0.001·λ⁻⁴ at λ = 0.5 µm: 1 + 0.0125 + 0.08 + 0.016.
        let f = DispersionFormula::from_refractiveindex_info(
            3,
            &[1.0, 0.1, 3.0, 0.01, -3.0, 0.001, -4.0],
        )
        .unwrap();
        assert!((f.index_um(0.5) - 1.1085_f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn coefficients_round_trip() {
        let list = [2.4, -0.008, 2.0, 0.016, -2.0, 1e-4, -4.0];
        let f = DispersionFormula::from_refractiveindex_info(3, &list).unwrap();
        assert_eq!(f.coefficients(), list);
        assert_eq!(f.refractiveindex_info_number(), 3);
    }

    #[test]
    fn malformed_lists_are_refused() {
        assert!(DispersionFormula::from_refractiveindex_info(2, &[]).is_err());
        assert!(DispersionFormula::from_refractiveindex_info(2, &[0.0, 1.0]).is_err());
        assert!(DispersionFormula::from_refractiveindex_info(3, &[2.0, 0.1, 2.5]).is_err());
        assert!(DispersionFormula::from_refractiveindex_info(1, &[0.0, 1.0, 0.01]).is_err());
        assert!(DispersionFormula::from_refractiveindex_info(2, &[0.0, f64::NAN, 0.01]).is_err());
    }
}
