//! What glass look-ups cost: parsing the built-in catalogue (once per process), n(λ) from a
//! maker's formula and from the n_d/V_d model, and finding glasses by name and by (n_d, V_d).

use divan::{Bencher, black_box};
use realcam::glass::{BuchdahlModel, Catalogue, Glass, catalogue};

const CSV: &str = include_str!("../assets/glass/glass-catalog-all.csv");

/// 64 wavelengths across 380–780 nm: one call evaluates all of them.
fn wavelengths() -> Vec<f64> {
    (0..64)
        .map(|i| 380.0 + 400.0 * f64::from(i) / 63.0)
        .collect()
}

fn main() {
    divan::main();
}

#[divan::bench]
fn parse_catalogue() -> Catalogue {
    Catalogue::parse(black_box(CSV)).unwrap()
}

#[divan::bench(args = ["N-BK7", "J-LASF010", "model 1.5168,64.17"])]
fn index_64_wavelengths(bencher: Bencher, which: &str) {
    let glass = match which.strip_prefix("model ") {
        Some(_) => Glass::model(1.5168, 64.17).unwrap(),
        None => Glass::Catalogue(catalogue().find(which).unwrap()),
    };
    let nm = wavelengths();
    bencher.bench(|| nm.iter().map(|&l| black_box(glass).index(l)).sum::<f64>());
}

#[divan::bench]
fn model_index_64_wavelengths_precomputed(bencher: Bencher) {
    let model = BuchdahlModel::new(1.5168, 64.17);
    let nm = wavelengths();
    bencher.bench(|| nm.iter().map(|&l| black_box(model).index(l)).sum::<f64>());
}

#[divan::bench(args = ["N-BK7", "slah66", "cdgm:F5", "NBK77"])]
fn find_by_name(bencher: Bencher, name: &str) {
    let c = catalogue();
    bencher.bench(|| c.find(black_box(name)).ok());
}

#[divan::bench]
fn nearest_10(bencher: Bencher) {
    let c = catalogue();
    bencher.bench(|| c.nearest(black_box(1.62), black_box(36.4), 10));
}
