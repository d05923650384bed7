//! Relative partial dispersion P_g,F and Schott's normal line: how far a glass's dispersion
//! curve departs from the curve its n_d and V_d predict.
//!
//! P_g,F = (n_g − n_F) / (n_F − n_C). "Normal" glasses lie on a line in (V_d, P_g,F), which
//! Schott defines through its glasses K7 and F2 (TIE-29): P_g,F = 0.6438 − 0.001682·V_d.
//! ΔP_g,F is a glass's distance above that line; glasses with a large |ΔP_g,F| (fluor and
//! phosphate crowns, short flints, the densest flints) are the "anomalous partial dispersion"
//! glasses that apochromats are built from, and that no model from n_d and V_d alone can follow.

use super::catalogue::CatalogueGlass;
use super::{FRAUNHOFER_C_NM, FRAUNHOFER_F_NM, FRAUNHOFER_G_NM};

/// Schott's normal line P_g,F = a + b·V_d (TIE-29): (a, b).
pub const NORMAL_LINE_G_F: (f64, f64) = (0.6438, -0.001682);

/// P_g,F of a normal glass with Abbe number `v_d`.
pub fn normal_p_g_f(v_d: f64) -> f64 {
    NORMAL_LINE_G_F.0 + NORMAL_LINE_G_F.1 * v_d
}

impl CatalogueGlass {
    /// Relative partial dispersion P_g,F = (n_g − n_F) / (n_F − n_C), from the formula.
    pub fn p_g_f(&self) -> f64 {
        let n_f = self.index(FRAUNHOFER_F_NM);
        (self.index(FRAUNHOFER_G_NM) - n_f) / (n_f - self.index(FRAUNHOFER_C_NM))
    }

    /// ΔP_g,F: P_g,F minus the normal line's at the glass's V_d.
    pub fn delta_p_g_f(&self) -> f64 {
        self.p_g_f() - normal_p_g_f(self.v_d)
    }

    /// ΔP_g,F in index units: ΔP_g,F·(n_F − n_C), how far n_g − n_F is from a normal glass's
    /// with the same principal dispersion. A dispersion model that knows only n_d and V_d is
    /// off by about this much at the g line whatever its form, and more toward 400 nm.
    pub fn g_line_departure(&self) -> f64 {
        self.delta_p_g_f() * (self.index(FRAUNHOFER_F_NM) - self.index(FRAUNHOFER_C_NM))
    }
}
