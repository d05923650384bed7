//! Fits the n_d/V_d dispersion model's shape coefficients (`SHAPE_A`, `SHAPE_B` in
//! `src/glass/model.rs`) to the built-in catalogue and prints them with the fit's quality.
//!
//! ```sh
//! cargo run --release --example fit_glass_model
//! ```
//!
//! The model (see `realcam::glass::model`) is n(λ) = n_d + D·(t₀ + a·t₁ + b·t₂) with
//! D = (n_d − 1)/V_d and a, b linear in the basis φ(n_d, V_d); so n − n_d − D·t₀ =
//! Σⱼ Aⱼ·D·t₁·φⱼ + Σⱼ Bⱼ·D·t₂·φⱼ is linear in the 12 unknowns (A, B). Every catalogue glass with
//! a published n_d and V_d gives one equation per check wavelength (400, 405, …, 700 nm, where
//! its formula is valid), weighted by w = max(1 / (1 + (δ/δ₀)²), W_MIN), δ the glass's g-line
//! departure from Schott's normal line, δ₀ = 5e-5. The weighted least-squares problem is
//! solved by Givens rotations (a QR factorisation, no normal equations). The fit is repeated on
//! each half of the catalogue to show the error on glasses it did not see.

use realcam::glass::model::{
    SHAPE_A, SHAPE_B, catalogue_deviation, check_wavelengths_nm, shape_basis, shape_terms,
};
use realcam::glass::{BuchdahlModel, CatalogueGlass, catalogue};

/// Departure scale of the weights, and of the "normal glass" criterion the tests use.
const DEPARTURE_SCALE: f64 = 5e-5;
/// Smallest weight: anomalous glasses keep a say where no normal glass is.
const W_MIN: f64 = 0.01;

const UNKNOWNS: usize = 12;

/// Streaming least squares: R (upper triangular) and Qᵀy, updated by Givens rotations.
struct LeastSquares {
    r: [[f64; UNKNOWNS + 1]; UNKNOWNS],
}

impl LeastSquares {
    fn new() -> Self {
        LeastSquares {
            r: [[0.0; UNKNOWNS + 1]; UNKNOWNS],
        }
    }

    /// Adds the equation row·x = y with weight w (minimising Σ w·(row·x − y)²).
    fn add(&mut self, row: [f64; UNKNOWNS], y: f64, w: f64) {
        let s = w.sqrt();
        let mut v = [0.0; UNKNOWNS + 1];
        for (vi, ri) in v.iter_mut().zip(row) {
            *vi = ri * s;
        }
        v[UNKNOWNS] = y * s;
        for i in 0..UNKNOWNS {
            if v[i] == 0.0 {
                continue;
            }
            let (a, b) = (self.r[i][i], v[i]);
            let h = a.hypot(b);
            let (c, sn) = (a / h, b / h);
            for (rij, vj) in self.r[i][i..].iter_mut().zip(&mut v[i..]) {
                let (x, z) = (*rij, *vj);
                *rij = c * x + sn * z;
                *vj = c * z - sn * x;
            }
        }
    }

    fn solve(&self) -> [f64; UNKNOWNS] {
        let mut x = [0.0; UNKNOWNS];
        for i in (0..UNKNOWNS).rev() {
            let tail: f64 = (i + 1..UNKNOWNS).map(|j| self.r[i][j] * x[j]).sum();
            x[i] = (self.r[i][UNKNOWNS] - tail) / self.r[i][i];
        }
        x
    }
}

fn weight(glass: &CatalogueGlass) -> f64 {
    let departure = glass.g_line_departure() / DEPARTURE_SCALE;
    (1.0 / (1.0 + departure * departure)).max(W_MIN)
}

fn fit(glasses: &[&CatalogueGlass]) -> ([f64; 6], [f64; 6]) {
    let mut ls = LeastSquares::new();
    for g in glasses {
        let w = weight(g);
        let dispersion = (g.n_d - 1.0) / g.v_d;
        let phi = shape_basis(g.n_d, g.v_d);
        for nm in check_wavelengths_nm().filter(|&nm| g.covers(nm)) {
            let [t0, t1, t2] = shape_terms(nm);
            let mut row = [0.0; UNKNOWNS];
            for j in 0..6 {
                row[j] = dispersion * t1 * phi[j];
                row[6 + j] = dispersion * t2 * phi[j];
            }
            ls.add(row, g.index(nm) - g.n_d - dispersion * t0, w);
        }
    }
    let x = ls.solve();
    (x[..6].try_into().unwrap(), x[6..].try_into().unwrap())
}

/// Max |model − formula| over the check wavelengths, for shape coefficients (a, b).
fn deviation(g: &CatalogueGlass, a: &[f64; 6], b: &[f64; 6]) -> f64 {
    let phi = shape_basis(g.n_d, g.v_d);
    let dot = |c: &[f64; 6]| c.iter().zip(&phi).map(|(c, p)| c * p).sum::<f64>();
    let model = BuchdahlModel::with_shape(g.n_d, g.v_d, dot(a), dot(b));
    check_wavelengths_nm()
        .filter(|&nm| g.covers(nm))
        .map(|nm| (model.index(nm) - g.index(nm)).abs())
        .fold(0.0, f64::max)
}

fn summary(label: &str, mut errors: Vec<f64>) {
    errors.sort_by(f64::total_cmp);
    let at = |q: f64| errors[((errors.len() - 1) as f64 * q).round() as usize];
    println!(
        "  {label:<44} {:>5} glasses  median {:.2e}  95th pct {:.2e}  max {:.2e}",
        errors.len(),
        at(0.5),
        at(0.95),
        at(1.0)
    );
}

fn print_array(name: &str, c: &[f64; 6]) {
    let items: Vec<String> = c.iter().map(|v| format!("{v:e}")).collect();
    println!("pub const {name}: [f64; 6] = [{}];", items.join(", "));
}

fn main() {
    let glasses: Vec<&CatalogueGlass> = catalogue()
        .glasses()
        .iter()
        .filter(|g| g.published_n_d_v_d)
        .collect();
    let (a, b) = fit(&glasses);
    println!("// fitted to {} catalogue glasses", glasses.len());
    print_array("SHAPE_A", &a);
    print_array("SHAPE_B", &b);
    // Equal up to the last bits float rounding may differ in across compilers.
    let in_code = a
        .iter()
        .chain(&b)
        .zip(SHAPE_A.iter().chain(&SHAPE_B))
        .all(|(x, y)| (x - y).abs() <= 1e-12 * x.abs());
    println!(
        "// src/glass/model.rs holds {}",
        if in_code {
            "these values"
        } else {
            "DIFFERENT values: paste the ones above"
        }
    );

    let normal = |g: &CatalogueGlass| g.g_line_departure().abs() <= DEPARTURE_SCALE;
    println!("\nmax |model − formula| over 400–700 nm per glass (the fit above):");
    let fitted: Vec<(f64, &CatalogueGlass)> =
        glasses.iter().map(|g| (deviation(g, &a, &b), *g)).collect();
    summary(
        "normal (|ΔP_g,F·(n_F − n_C)| ≤ 5e-5)",
        fitted
            .iter()
            .filter(|(_, g)| normal(g))
            .map(|p| p.0)
            .collect(),
    );
    summary(
        "anomalous",
        fitted
            .iter()
            .filter(|(_, g)| !normal(g))
            .map(|p| p.0)
            .collect(),
    );
    summary("all", fitted.iter().map(|p| p.0).collect());

    println!("\nthe same with the constants in src/glass/model.rs (catalogue_deviation):");
    summary(
        "all",
        glasses.iter().map(|g| catalogue_deviation(g)).collect(),
    );

    println!("\nheld out: fitted on one half of the catalogue, checked on the other:");
    let (even, odd): (Vec<_>, Vec<_>) = glasses.iter().enumerate().partition(|(i, _)| i % 2 == 0);
    let halves: [Vec<&CatalogueGlass>; 2] = [
        even.into_iter().map(|p| *p.1).collect(),
        odd.into_iter().map(|p| *p.1).collect(),
    ];
    let mut held_out = Vec::new();
    for k in 0..2 {
        let (a, b) = fit(&halves[k]);
        held_out.extend(halves[1 - k].iter().map(|g| (deviation(g, &a, &b), *g)));
    }
    summary(
        "normal, held out",
        held_out
            .iter()
            .filter(|(_, g)| normal(g))
            .map(|p| p.0)
            .collect(),
    );
    summary("all, held out", held_out.iter().map(|p| p.0).collect());

    let mut worst = fitted.clone();
    worst.sort_by(|x, y| y.0.total_cmp(&x.0));
    println!("\nworst normal glasses:");
    for (e, g) in worst.iter().filter(|(_, g)| normal(g)).take(6) {
        println!(
            "  {:<22} n_d {:.5} V_d {:5.2}  ΔP_g,F {:+.4}  departure {:+.1e}  off by {e:.2e}",
            g.label(),
            g.n_d,
            g.v_d,
            g.delta_p_g_f(),
            g.g_line_departure()
        );
    }
    println!("worst glasses overall:");
    for (e, g) in worst.iter().take(8) {
        println!(
            "  {:<22} n_d {:.5} V_d {:5.2}  ΔP_g,F {:+.4}  departure {:+.1e}  off by {e:.2e}",
            g.label(),
            g.n_d,
            g.v_d,
            g.delta_p_g_f(),
            g.g_line_departure()
        );
    }
}
