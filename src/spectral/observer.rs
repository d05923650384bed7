//! The CIE 1931 2° colour-matching functions, illuminant D65, and the sRGB ↔ XYZ matrices.
//! Data: `assets/spectral/` (sources there).

use std::sync::OnceLock;

/// Linear sRGB → XYZ (IEC 61966-2-1; D65 white, Y = 1), row-major.
pub const XYZ_FROM_SRGB: [[f64; 3]; 3] = [
    [0.4124, 0.3576, 0.1805],
    [0.2126, 0.7152, 0.0722],
    [0.0193, 0.1192, 0.9505],
];

/// XYZ → linear sRGB: the inverse of [`XYZ_FROM_SRGB`] (IEC 61966-2-1's rounded inverse
/// would not round-trip to 1e-4; this one is computed).
pub const SRGB_FROM_XYZ: [[f64; 3]; 3] = invert(XYZ_FROM_SRGB);

/// A sampled spectral function: values at `start`, `start + step`, … (nm), linear in between
/// and zero outside.
#[derive(Clone, Debug)]
pub struct Tabulated<const N: usize> {
    pub start: f64,
    pub step: f64,
    pub values: Vec<[f64; N]>,
}

impl<const N: usize> Tabulated<N> {
    /// The values at `wavelength_nm` (linear interpolation).
    pub fn at(&self, wavelength_nm: f64) -> [f64; N] {
        let x = (wavelength_nm - self.start) / self.step;
        // Outside the table (or not a number): nothing.
        if x.is_nan() || x < 0.0 || x > (self.values.len() - 1) as f64 {
            return [0.0; N];
        }
        let i = (x as usize).min(self.values.len() - 2);
        let t = x - i as f64;
        let (a, b) = (self.values[i], self.values[i + 1]);
        std::array::from_fn(|k| a[k] + t * (b[k] - a[k]))
    }

    pub fn end(&self) -> f64 {
        self.start + self.step * (self.values.len() - 1) as f64
    }
}

fn parse<const N: usize>(csv: &str, what: &str) -> Tabulated<N> {
    let rows: Vec<(f64, [f64; N])> = csv
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("wavelength"))
        .map(|l| {
            let mut fields = l.split(',').map(|f| {
                f.trim()
                    .parse::<f64>()
                    .unwrap_or_else(|_| panic!("{what}: bad number in '{l}'"))
            });
            let w = fields.next().expect("wavelength");
            (w, std::array::from_fn(|_| fields.next().expect("value")))
        })
        .collect();
    let step = rows[1].0 - rows[0].0;
    assert!(
        rows.windows(2)
            .all(|p| (p[1].0 - p[0].0 - step).abs() < 1e-9),
        "{what}: uneven steps"
    );
    Tabulated {
        start: rows[0].0,
        step,
        values: rows.into_iter().map(|r| r.1).collect(),
    }
}

/// x̄, ȳ, z̄ of the CIE 1931 2° observer, 360–830 nm at 1 nm.
pub fn cmf() -> &'static Tabulated<3> {
    static CMF: OnceLock<Tabulated<3>> = OnceLock::new();
    CMF.get_or_init(|| {
        parse(
            include_str!("../../assets/spectral/cie1931-2deg-cmf.csv"),
            "CIE 1931 CMF",
        )
    })
}

/// CIE D65, relative power, 300–780 nm at 5 nm (scale as tabulated: 100 at 560 nm).
pub fn d65() -> &'static Tabulated<1> {
    static D65: OnceLock<Tabulated<1>> = OnceLock::new();
    D65.get_or_init(|| parse(include_str!("../../assets/spectral/cie-d65.csv"), "CIE D65"))
}

/// `m · v`.
pub fn apply(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

/// `a · b`.
pub const fn multiply(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut out = [[0.0; 3]; 3];
    let mut r = 0;
    while r < 3 {
        let mut c = 0;
        while c < 3 {
            out[r][c] = a[r][0] * b[0][c] + a[r][1] * b[1][c] + a[r][2] * b[2][c];
            c += 1;
        }
        r += 1;
    }
    out
}

/// The inverse of a 3×3 matrix (by cofactors; the callers' matrices are well conditioned).
pub const fn invert(m: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let c = [
        [
            m[1][1] * m[2][2] - m[1][2] * m[2][1],
            m[0][2] * m[2][1] - m[0][1] * m[2][2],
            m[0][1] * m[1][2] - m[0][2] * m[1][1],
        ],
        [
            m[1][2] * m[2][0] - m[1][0] * m[2][2],
            m[0][0] * m[2][2] - m[0][2] * m[2][0],
            m[0][2] * m[1][0] - m[0][0] * m[1][2],
        ],
        [
            m[1][0] * m[2][1] - m[1][1] * m[2][0],
            m[0][1] * m[2][0] - m[0][0] * m[2][1],
            m[0][0] * m[1][1] - m[0][1] * m[1][0],
        ],
    ];
    let det = m[0][0] * c[0][0] + m[0][1] * c[1][0] + m[0][2] * c[2][0];
    let mut out = [[0.0; 3]; 3];
    let mut r = 0;
    while r < 3 {
        let mut k = 0;
        while k < 3 {
            out[r][k] = c[r][k] / det;
            k += 1;
        }
        r += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Published checks of the tables: ȳ peaks at 555 nm with 1.0; D65 is 100 at 560 nm; the
    /// chromaticity of D65 through the 1931 observer is (0.3127, 0.3290).
    #[test]
    fn tables_match_published_values() {
        assert!((cmf().at(555.0)[1] - 1.0).abs() < 1e-4);
        assert!((d65().at(560.0)[0] - 100.0).abs() < 1e-9);
        let (mut x, mut y, mut z) = (0.0, 0.0, 0.0);
        for w in 360..=780 {
            let [a, b, c] = cmf().at(w as f64);
            let p = d65().at(w as f64)[0];
            (x, y, z) = (x + a * p, y + b * p, z + c * p);
        }
        let sum = x + y + z;
        assert!((x / sum - 0.3127).abs() < 2e-4, "{}", x / sum);
        assert!((y / sum - 0.3290).abs() < 2e-4, "{}", y / sum);
    }

    #[test]
    fn srgb_matrices_are_inverse() {
        let identity = multiply(&SRGB_FROM_XYZ, &XYZ_FROM_SRGB);
        for (r, row) in identity.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                assert!((v - f64::from(u8::from(r == c))).abs() < 1e-12);
            }
        }
    }
}
